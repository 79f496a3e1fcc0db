//! The camera as a game gives it (`Renderer::set_view_projection`): standard and reverse-Z,
//! finite and infinite far, y up and Vulkan's y flipped, sub-pixel jitter and an off-centre
//! frustum. For each, the depth AOV against an f64 ray cast and the energy AOV against the f64
//! line integral, along pixel rays built here from the matrices alone (the inverse of proj·view
//! at each pixel's centre, independent of crates/hadou/src/scene/camera.rs). Bad matrices are typed errors
//! that leave the camera as it was. Lavapipe, validation + synchronization validation.

mod common;

use glam::{DMat4, DVec3, DVec4};
use hadou::effects::energy_wave::line_integral;
use hadou::effects::raycast::SceneCaster;
use hadou::passes::energy_wave::wave_params;
use hadou::scene::Scene;
use hadou::testing::Comparison;
use hadou::{Aov, Error, FrameRequest};

const SCENE: &str = r#"
[camera]
position = [0, 2, 8]
look_at = [0, 0, 0]
[[light]]
direction = [-0.3, -1, -0.5]
[[mesh]]
name = "box"
kind = "cube"
size = 2
[[mesh]]
name = "floor"
kind = "plane"
size = 12
[[instance]]
mesh = "box"
transform = [{ rotate = { angle_deg = 30, axis = [0.3, 1, 0] } }, { translate = [0.5, 0, -1] }]
[[instance]]
mesh = "floor"
transform = [{ translate = [0, -1.2, 0] }]
[[wave]]
origin = [-3, 0.4, 0.5]
direction = [1, 0.1, -0.2]
a = 1
b = 0.6
core = 0.05
length = 5
"#;

const W: u32 = 64;
const H: u32 = 48;

/// f32 arithmetic keeps 2⁻²⁴ relative per step; the raster's transform and interpolation take a
/// few dozen (tests/gpu_raster.rs argues 1e-4 with two orders of margin). The energy's 1e-4 is
/// tests/gpu_energy_wave.rs's bound (f32 pixel rays enter the integral only logarithmically).
const REL_TOL: f64 = 1e-4;

/// The world ray through image point (px, py) (pixels from the top left) from the matrices alone:
/// the camera at inv(view)·0, toward inv(proj·view) of that point at clip depth 0.5.
fn matrix_ray(view: DMat4, proj: DMat4, px: f64, py: f64) -> (DVec3, DVec3) {
    let ndc_x = 2.0 * px / W as f64 - 1.0;
    let ndc_up = 1.0 - 2.0 * py / H as f64;
    // The clip y of the image's up: flipped when the projection flips y (Vulkan style).
    let ndc_y = if proj.y_axis.y < 0.0 { -ndc_up } else { ndc_up };
    let origin = view.inverse().transform_point3(DVec3::ZERO);
    let p = (proj * view).inverse() * DVec4::new(ndc_x, ndc_y, 0.5, 1.0);
    (origin, (p.truncate() / p.w - origin).normalize())
}

fn caster(scene: &Scene) -> SceneCaster {
    let meshes: Vec<_> = scene.meshes.iter().map(|m| m.mesh.clone()).collect();
    let instances: Vec<_> = scene.instances.iter().map(|i| (i.mesh, i.transform)).collect();
    SceneCaster::new(&meshes, &instances).unwrap()
}

/// Renders the scene from (view, proj), whose far plane is the view depth `far` (+inf for an
/// infinite projection), and checks depth and energy per pixel; returns the depth.
fn check(label: &str, view: DMat4, proj: DMat4, far: f64) -> Vec<f32> {
    let scene = common::parse(SCENE);
    let caster = caster(&scene);
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    rt.renderer().set_view_projection(view, proj).unwrap();
    let mut request = FrameRequest::new(W, H);
    request.aovs = vec![Aov::Depth, Aov::Energy];
    let frame = rt.render(&request).unwrap();
    let (depth, energy) = (frame.aov(Aov::Depth).unwrap(), frame.aov(Aov::Energy).unwrap());
    let params: Vec<_> = scene.waves().iter().map(|w| wave_params(&w.at(0.0))).collect();
    let hit = |px: f64, py: f64| {
        let (o, d) = matrix_ray(view, proj, px, py);
        caster.cast(o, d).map(|h| (h.t, h.instance))
    };
    let mut interior = 0;
    let mut depth_vs_f64 = Comparison::new(format!("{label}: depth vs f64 (interior hits)"));
    let mut energy_vs_f64 = Comparison::new(format!("{label}: energy vs f64"));
    for y in 0..H {
        for x in 0..W {
            let k = (y * W + x) as usize;
            let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
            let (o, d) = matrix_ray(view, proj, fx, fy);
            let gpu = depth.data[k] as f64;
            assert!(!gpu.is_nan() && !energy.data[k].is_nan(), "{label} ({x}, {y}): NaN");
            // Depth where the centre and the four corners see the same surface (no silhouette).
            let centre = hit(fx, fy);
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .map(|(a, b)| hit(x as f64 + a, y as f64 + b));
            let same = corners.iter().all(|c| match (c, centre) {
                (None, None) => true,
                (Some((t, i)), Some((tc, ic))) => *i == ic && (t - tc).abs() < 0.05 * tc,
                _ => false,
            });
            if same {
                interior += 1;
                match centre {
                    None => assert_eq!(gpu, f64::INFINITY, "{label} ({x}, {y}): sky"),
                    Some((t, _)) => {
                        depth_vs_f64.rel(format_args!("({x}, {y})"), gpu, t);
                    }
                }
            }
            // Energy up to the GPU's own distance (the clipping is the raster's, checked above),
            // at most `far` along the ray (the energy pass's convention, as in every energy test).
            let l = gpu.min(far);
            let reference: f64 = params.iter().map(|p| line_integral(p, o, d, l)).sum();
            let got = energy.data[k] as f64;
            if reference > 0.0 {
                energy_vs_f64.rel(format_args!("({x}, {y})"), got, reference);
            } else {
                energy_vs_f64.error(format_args!("({x}, {y}) where f64 is 0: {got}"), got.abs());
            }
        }
    }
    assert!(interior > (W * H) as usize * 3 / 4, "{label}: {interior} interior pixels");
    // Floors: the view shows the scene (> 1000 interior hits); the energy on every pixel.
    depth_vs_f64.assert_within(REL_TOL, 1000);
    energy_vs_f64.assert_within(REL_TOL, (W * H) as usize);
    rt.finish();
    depth.data.clone()
}

fn view() -> DMat4 {
    DMat4::look_at_rh(DVec3::new(0.5, 2.0, 8.0), DVec3::new(0.0, -0.2, 0.0), DVec3::Y)
}

/// Vulkan's clip y points down: a game's projection often flips it.
fn flip_y(p: DMat4) -> DMat4 {
    DMat4::from_scale(DVec3::new(1.0, -1.0, 1.0)) * p
}

const FOV: f64 = 0.8;
const ASPECT: f64 = W as f64 / H as f64;

#[test]
fn standard_and_reverse_z_finite_and_infinite() {
    let standard = DMat4::perspective_rh(FOV, ASPECT, 0.5, 40.0);
    let reverse = flip_y(DMat4::perspective_rh(FOV, ASPECT, 40.0, 0.5));
    let a = check("standard", view(), standard, 40.0);
    let b = check("reverse-Z, y flipped", view(), reverse, 40.0);
    let inf = f64::INFINITY;
    check("infinite far", view(), DMat4::perspective_infinite_rh(FOV, ASPECT, 0.5), inf);
    check(
        "infinite reverse-Z",
        view(),
        flip_y(DMat4::perspective_infinite_reverse_rh(FOV, ASPECT, 0.5)),
        inf,
    );
    // The same frustum however the game stores depth: the same distances. hadou turns either
    // matrix into its own camera (f64) and rasterizes into its own reverse-Z depth, so the frames
    // differ only by that recovery's f64 rounding (≈ 1e-16), which can flip at most the last bit of
    // an f32 uniform and so move a distance by a few f32 ulps: 1e-6 ≈ 16·2⁻²⁴. (Measured: equal.)
    let mut same = Comparison::new("standard vs reverse-Z distances");
    for (k, (x, y)) in a.iter().zip(&b).enumerate() {
        if x.is_infinite() && x == y {
            same.exclude();
        } else {
            same.rel(k, *y as f64, *x as f64);
        }
    }
    same.assert_within(1e-6, 1000);
}

#[test]
fn jitter_and_off_centre() {
    // TAA jitter: (0.37, −0.21) pixels, in the third column as engines add it.
    let mut jittered = flip_y(DMat4::perspective_infinite_reverse_rh(FOV, ASPECT, 0.5));
    jittered.z_axis.x += 0.37 * 2.0 / W as f64;
    jittered.z_axis.y += -0.21 * 2.0 / H as f64;
    let inf = f64::INFINITY;
    let plain =
        check("unjittered", view(), flip_y(DMat4::perspective_infinite_reverse_rh(FOV, ASPECT, 0.5)), inf);
    let moved = check("jittered", view(), jittered, inf);
    assert_ne!(plain, moved, "a sub-pixel jitter moves the samples");
    // An off-centre frustum (a portal's or one eye's): shifted a quarter of the image.
    let mut off = DMat4::perspective_rh(FOV, ASPECT, 0.5, 40.0);
    off.z_axis.x = 0.5;
    off.z_axis.y = -0.2;
    check("off-centre", view(), off, 40.0);
}

#[test]
fn bad_matrices_are_typed_errors_and_change_nothing() {
    let mut rt = common::runtime();
    rt.load_scene(common::parse(SCENE)).unwrap();
    let r = rt.renderer();
    let before = r.scene().unwrap().camera;
    let p = DMat4::perspective_rh(FOV, ASPECT, 0.5, 40.0);
    let scaled = DMat4::from_scale(DVec3::splat(2.0)) * view();
    let mirrored = DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0)) * view();
    let ortho = DMat4::orthographic_rh(-1.0, 1.0, -1.0, 1.0, 0.5, 40.0);
    let mut skewed = p;
    skewed.y_axis.x = 0.1;
    let mut nan = p;
    nan.x_axis.x = f64::NAN;
    let behind = DMat4::perspective_rh(FOV, ASPECT, -0.5, 40.0);
    let tiny = DMat4::perspective_infinite_reverse_rh(FOV, ASPECT, 1e-46);
    for (label, v, proj) in [
        ("scaled view", scaled, p),
        ("mirrored view", mirrored, p),
        ("orthographic", view(), ortho),
        ("skewed", view(), skewed),
        ("NaN", view(), nan),
        ("near behind the camera", view(), behind),
        ("near below f32's normal range", view(), tiny),
    ] {
        assert!(matches!(r.set_view_projection(v, proj), Err(Error::InvalidUpdate { .. })), "{label}");
        assert_eq!(r.scene().unwrap().camera, before, "{label}: refused, the camera is unchanged");
    }
    rt.finish();
}
