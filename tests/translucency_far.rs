//! Translucency far from the origin: a rotated cavity cube placed 10,000 and 100,000 units out,
//! with the camera beside it, drawn with the thickness LUT and with peel, against the exact f64
//! thickness (`report::translucency::samples`: ray–mesh crossings at the GPU's own shaded point).
//! The issue's target — p95 ≤ 1 voxel, cavities included — must hold wherever the object is: the
//! world position's f32 spacing (1e-3 at 10⁴, 8e-3 at 10⁵) is 0.02–0.16 of this cube's 0.05
//! voxel, so placement may cost a fraction of a voxel, never the target. Validation on.

mod common;

use hadou::{Aov, FrameRequest};
use hadou_cli::report::translucency::{abs_stats, sample_set, world_voxel};

fn scene(x: f64, mode: &str) -> hadou::scene::Scene {
    common::parse(&format!(
        r#"
        [camera]
        position = [{cx}, 0.5, 4]
        look_at = [{x}, 0, 0]
        fov_y_deg = 40
        [[light]]
        direction = [0, -0.25, 1]
        intensity = 3
        [[mesh]]
        name = "box"
        kind = "cavity_cube"
        size = 1.6
        cavity_radius = 0.45
        [[material]]
        name = "jade"
        kind = "translucent"
        sigma = [1, 2, 3]
        voxel_res = 32
        thickness = "{mode}"
        [[instance]]
        mesh = "box"
        material = "jade"
        transform = [{{ rotate = {{ angle_deg = 30, axis = [0.2, 1, 0.1] }} }}, {{ translate = [{x}, 0, 0] }}]
        "#,
        cx = x + 0.3
    ))
}

#[test]
fn far_from_the_origin_the_thickness_stays_within_a_voxel() {
    let size = (96u32, 96u32);
    for x in [1.0e4, 1.0e5] {
        for mode in ["lut", "peel"] {
            let scene = scene(x, mode);
            let mut rt = common::runtime();
            rt.load_scene(scene.clone()).unwrap();
            let mut req = FrameRequest::new(size.0, size.1);
            req.aovs = vec![Aov::Thickness, Aov::Depth];
            let frame = rt.render(&req).unwrap();
            common::assert_clean(&rt);
            let thickness = &frame.aov(Aov::Thickness).unwrap().data;
            let depth = &frame.aov(Aov::Depth).unwrap().data;
            assert!(thickness.iter().all(|t| !t.is_nan()), "{mode} at {x}: NaN thickness");
            let set = sample_set(&scene, size, thickness, depth).unwrap();
            // The cube covers ~4000 of the 9216 pixels (r ≈ 36 px): its silhouette rim is
            // ≤ 2/r ≈ 6 % of them, under the library's cap (asserted), and 3000 must be compared.
            let summary = set.assert_usable(3000);
            let s = &set.samples;
            let voxel = world_voxel(&scene, 0).unwrap();
            let (mean, p95, max) = abs_stats(s.iter().map(|s| (s.gpu - s.exact) / voxel));
            println!("{mode} at x = {x:e}: {summary}; mean {mean:.3} p95 {p95:.3} max {max:.2} voxels");
            assert!(max.is_finite(), "{mode} at {x}: a non-finite thickness error");
            assert!(p95 <= 1.0, "{mode} at {x}: p95 {p95:.3} voxels");
        }
    }
}
