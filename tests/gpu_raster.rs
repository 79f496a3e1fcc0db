//! Raster pass vs the CPU f64 ray cast: per-pixel depth, normals under instance transforms,
//! tonemap vs its CPU twin, empty scenes. Lavapipe with validation on.

mod common;

use glam::DVec3;
use hadou::effects::raycast::SceneCaster;
use hadou::effects::tonemap::tonemap_channel;
use hadou::scene::Scene;
use hadou::{Aov, FrameRequest};

/// CPU reference of one pixel: the centre ray and the four corner rays.
struct PixelRef {
    centre: Option<(f64, usize, DVec3)>,
    /// All five rays hit the same instance on a continuous surface.
    interior: bool,
}

fn caster(scene: &Scene) -> SceneCaster {
    let meshes: Vec<_> = scene.meshes.iter().map(|m| m.mesh.clone()).collect();
    let instances: Vec<_> = scene.instances.iter().map(|i| (i.mesh, i.transform)).collect();
    SceneCaster::new(&meshes, &instances).expect("scene meshes are valid")
}

fn reference(scene: &Scene, caster: &SceneCaster, w: u32, h: u32) -> Vec<PixelRef> {
    let cam = &scene.camera;
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let cast = |px: f64, py: f64| {
                let (o, d) = cam.ray_through(px, py, w, h);
                caster.cast(o, d).filter(|hit| hit.t <= cam.far).map(|hit| (hit.t, hit.instance, hit.normal))
            };
            let centre = cast(x as f64 + 0.5, y as f64 + 0.5);
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .map(|(dx, dy)| cast(x as f64 + dx, y as f64 + dy));
            let interior = match centre {
                None => corners.iter().all(|c| c.is_none()),
                Some((t, id, _)) => corners.iter().all(|c| {
                    // Same instance, and no depth jump (self-occlusion edges inside one instance).
                    c.is_some_and(|(tc, idc, _)| idc == id && (tc - t).abs() <= 0.05 * t)
                }),
            };
            out.push(PixelRef { centre, interior });
        }
    }
    out
}

/// f32 arithmetic keeps 2⁻²⁴ ≈ 6e-8 relative per operation; the vertex transform, the
/// perspective-correct interpolation and the length take a few dozen such steps, so 1e-4
/// relative leaves two orders of magnitude of margin while still catching any wrong transform,
/// projection or pixel-centre convention (those are off by ≥ 1e-3).
const DEPTH_REL_TOL: f64 = 1e-4;

fn check_depth(scene_rel: &str, w: u32, h: u32) {
    let mut scene = common::load(scene_rel);
    // The raster's depth alone: metaballs (a compute pass) would add surfaces the mesh ray cast
    // does not know; they have their own test.
    scene.metaballs.clear();
    let caster = caster(&scene);
    let refs = reference(&scene, &caster, w, h);
    let mut rt = common::runtime();
    rt.load_scene(scene).unwrap();
    let mut req = FrameRequest::new(w, h);
    req.aovs = vec![Aov::Depth];
    let frame = rt.render(&req).unwrap();
    let depth = frame.aov(Aov::Depth).unwrap();
    let (mut interior, mut edge, mut edge_mismatch, mut worst) = (0usize, 0usize, 0usize, 0f64);
    for (i, r) in refs.iter().enumerate() {
        let gpu = depth.data[i] as f64;
        assert!(!gpu.is_nan(), "NaN depth at pixel {i}");
        let agree = match r.centre {
            None => gpu == f64::INFINITY,
            Some((t, _, _)) => ((gpu - t) / t).abs() <= DEPTH_REL_TOL,
        };
        if r.interior {
            interior += 1;
            if let Some((t, _, _)) = r.centre {
                worst = worst.max(((gpu - t) / t).abs());
            }
            assert!(
                agree,
                "{scene_rel}: pixel ({}, {}) gpu {gpu} vs cpu {:?}",
                i as u32 % w,
                i as u32 / w,
                r.centre
            );
        } else {
            edge += 1;
            edge_mismatch += usize::from(!agree);
        }
    }
    // Silhouette pixels: the rasterizer and the centre ray may disagree only where the surface
    // changes within the pixel. Bound them: they are a thin band, under 10% of the image here,
    // and at most half of them may disagree at all.
    let total = (w * h) as usize;
    println!("{scene_rel}: {interior} interior pixels (worst rel {worst:.2e}), {edge} edge pixels, {edge_mismatch} disagree");
    assert!(edge * 10 < total, "too many edge pixels: {edge} of {total}");
    assert!(edge_mismatch * 2 <= edge.max(1), "{edge_mismatch} of {edge} edge pixels disagree");
    assert!(interior > total / 2);
    common::assert_clean(&rt);
}

#[test]
fn showcase_depth_matches_f64_raycast() {
    check_depth("assets/scenes/showcase.toml", 160, 120);
}

#[test]
fn instances_depth_matches_f64_raycast() {
    check_depth("assets/scenes/instances.toml", 128, 128);
}

/// Normals under rotation and non-uniform scale, on flat-shaded cubes (the vertex normals equal
/// the face normals, so the GPU's interpolated normal must equal M⁻ᵀn of the hit face). The
/// normal target is RGBA16F: 2⁻¹¹ relative per component, so 2e-3 rad bounds the angle.
#[test]
fn instance_normals_follow_inverse_transpose() {
    let scene = common::parse(
        r#"
        [camera]
        position = [0, 0, 9]
        look_at = [0, 0, 0]
        fov_y_deg = 40
        [[mesh]]
        name = "box"
        kind = "cube"
        [[instance]]
        mesh = "box"
        transform = [{ rotate = { angle_deg = 35, axis = [1, 1, 0] } }, { scale = [2.5, 0.6, 1.2] }, { translate = [-1.5, 0, 0] }]
        [[instance]]
        mesh = "box"
        transform = [{ scale = [0.5, 2, 1] }, { rotate = { angle_deg = -50, axis = [0.2, 1, 0.4] } }, { translate = [1.8, 0.3, 0] }]
        "#,
    );
    let (w, h) = (160, 120);
    let caster = caster(&scene);
    let refs = reference(&scene, &caster, w, h);
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let mut req = FrameRequest::new(w, h);
    req.aovs = vec![Aov::Normal];
    let frame = rt.render(&req).unwrap();
    let normals = frame.aov(Aov::Normal).unwrap();
    let mut checked = 0;
    for (i, r) in refs.iter().enumerate() {
        let (Some((t, _, n_cpu)), true) = (r.centre, r.interior) else { continue };
        let (x, y) = (i as u32 % w, i as u32 / w);
        let n_gpu =
            DVec3::new(normals.at(x, y, 0) as f64, normals.at(x, y, 1) as f64, normals.at(x, y, 2) as f64);
        // The G-buffer normal faces the camera.
        let (_, d) = scene.camera.pixel_ray(x, y, w, h);
        let n_cpu = if n_cpu.dot(d) > 0.0 { -n_cpu } else { n_cpu };
        let angle = n_gpu.normalize().dot(n_cpu).clamp(-1.0, 1.0).acos();
        assert!(angle < 2e-3, "pixel ({x}, {y}) t {t}: gpu {n_gpu} vs cpu {n_cpu}, {angle} rad");
        checked += 1;
    }
    assert!(checked > 1000, "only {checked} pixels checked");
    common::assert_clean(&rt);
}

/// The tonemap pass vs its f64 twin on the same HDR values: the curve in f32 differs from f64 by
/// well under 0.01 of an 8-bit code, and UNORM conversion rounds to nearest, so ≤ 1 code.
#[test]
fn tonemap_matches_cpu_twin() {
    let mut rt = common::runtime();
    let scene = common::load("assets/scenes/showcase.toml");
    let exposure = scene.render.exposure;
    rt.load_scene(scene).unwrap();
    let mut req = FrameRequest::new(64, 48);
    req.aovs = vec![Aov::Hdr];
    let frame = rt.render(&req).unwrap();
    let hdr = frame.aov(Aov::Hdr).unwrap();
    let color = frame.color.as_ref().unwrap();
    for (i, px) in color.chunks_exact(4).enumerate() {
        for (c, &gpu) in px.iter().take(3).enumerate() {
            let cpu = tonemap_channel(hdr.data[i * 4 + c] as f64, exposure);
            assert!((gpu as f64 - cpu).abs() <= 1.0, "pixel {i} channel {c}: gpu {gpu} cpu {cpu}");
        }
        assert_eq!(px[3], 255);
    }
    common::assert_clean(&rt);
}

#[test]
fn empty_scene_renders_background_and_infinite_depth() {
    let mut rt = common::runtime();
    let scene = common::load("assets/scenes/empty.toml");
    let bg = scene.render.background;
    let exposure = scene.render.exposure;
    rt.load_scene(scene).unwrap();
    assert_eq!(rt.pass_names(), vec!["raster", "tonemap"]);
    let mut req = FrameRequest::new(33, 17); // odd sizes: partial workgroups
    req.aovs = vec![Aov::Depth, Aov::Normal];
    let frame = rt.render(&req).unwrap();
    assert!(frame.aov(Aov::Depth).unwrap().data.iter().all(|&d| d == f32::INFINITY));
    assert!(frame.aov(Aov::Normal).unwrap().data.iter().all(|&n| n == 0.0));
    let want = [bg.x, bg.y, bg.z].map(|c| tonemap_channel(c as f32 as f64, exposure));
    for px in frame.color.as_ref().unwrap().chunks_exact(4) {
        for (got, want) in px.iter().zip(want) {
            assert!((*got as f64 - want).abs() <= 1.0);
        }
    }
    common::assert_clean(&rt);
}

/// Resizing between frames, reloading a scene, many frames: no leaks or hazards (validation).
#[test]
fn resize_and_reload_stay_clean() {
    let mut rt = common::runtime();
    rt.load_scene(common::load("assets/scenes/single_cube.toml")).unwrap();
    for (w, h) in [(64, 64), (1, 1), (200, 30), (64, 64)] {
        let frame = rt.render(&FrameRequest::new(w, h)).unwrap();
        assert_eq!(frame.color.as_ref().unwrap().len(), (w * h * 4) as usize);
        assert_eq!(frame.stats.passes.len(), 3, "raster, tonemap, readback");
    }
    rt.load_scene(common::load("assets/scenes/showcase.toml")).unwrap();
    rt.render(&FrameRequest::new(64, 64)).unwrap();
    assert!(rt.render(&FrameRequest::new(0, 10)).is_err());
    common::assert_clean(&rt);
}

/// Instancing: one vertex/index buffer pair per mesh, one instanced draw per used mesh.
#[test]
fn instances_share_one_mesh_copy() {
    let mut rt = common::runtime();
    let scene = common::load("assets/scenes/instances.toml");
    let n = scene.instances.len() as u32;
    assert!(n >= 50);
    rt.load_scene(scene).unwrap();
    let (draws, meshes) = rt.renderer().draws();
    assert_eq!(meshes, 1);
    assert_eq!(draws, vec![hadou::scene_gpu::Draw { mesh: 0, first_instance: 0, instance_count: n }]);
    rt.render(&FrameRequest::new(16, 16)).unwrap();
    common::assert_clean(&rt);
}

/// Hard inputs on the GPU (issue 14, finding 4): `exposure = 1e20` saturates lit surfaces to
/// white instead of overflowing the tonemap curve into black, and lights at the HDR limit
/// (Σ colour × intensity = 65504 per channel, what the scene checker allows) leave no NaN or Inf in
/// the HDR image.
#[test]
fn huge_exposure_and_lights_at_the_limit_stay_finite_and_white() {
    let text = |exposure: &str, intensity: &str| {
        format!(
            "[render]\nexposure = {exposure}\nambient = [0, 0, 0]\n[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n\
             [[light]]\ndirection = [0, -1, -0.5]\nintensity = {intensity}\n[[mesh]]\nname = \"box\"\nkind = \"cube\"\n\
             [[instance]]\nmesh = \"box\"\n"
        )
    };
    let mut rt = common::runtime();
    for (exposure, intensity) in [("1e20", "1"), ("1", "65504"), ("3e38", "65504")] {
        rt.load_scene(common::parse(&text(exposure, intensity))).unwrap();
        let mut request = FrameRequest::new(48, 36);
        request.aovs = vec![Aov::Hdr, Aov::Normal];
        let frame = rt.render(&request).unwrap();
        let hdr = frame.aov(Aov::Hdr).unwrap();
        assert!(
            hdr.data.iter().all(|v| v.is_finite()),
            "exposure {exposure}, intensity {intensity}: HDR not finite"
        );
        let normal = frame.aov(Aov::Normal).unwrap();
        let color = frame.color.as_ref().unwrap();
        let lit: Vec<usize> = (0..48 * 36)
            .filter(|&i| normal.data[4 * i + 3] > 0.0 && hdr.data[4 * i..4 * i + 3].iter().any(|&c| c > 0.0))
            .collect();
        assert!(lit.len() > 50, "the box shows lit: {}", lit.len());
        if exposure != "1" {
            // Saturated: every lit pixel is white (255 in each lit channel).
            for &i in &lit {
                let px = &color[4 * i..4 * i + 3];
                assert!(px.iter().all(|&c| c == 255 || c == 0), "exposure {exposure}: pixel {i} = {px:?}");
                assert!(px.contains(&255), "exposure {exposure}: lit pixel {i} is black");
            }
        }
    }
    common::assert_clean(&rt);
}

/// `Runtime::submit` records and submits without waiting (frames overlap up to its 2 slots);
/// `wait_all` then reports them finished, and the last frame's statistics are there.
#[test]
fn submitted_frames_report_when_finished() {
    let mut rt = common::runtime();
    rt.load_scene(common::load("assets/scenes/showcase.toml")).unwrap();
    let request = FrameRequest::new(32, 24);
    let frames: Vec<u64> = (0..5).map(|_| rt.submit(&request).unwrap()).collect();
    assert_eq!(frames, [0, 1, 2, 3, 4]);
    assert!(rt.finished_stats(4).is_none(), "not yet known finished");
    rt.wait_all().unwrap();
    let stats = rt.finished_stats(4).expect("frame 4 finished");
    let names: Vec<&str> = stats.passes.iter().map(|p| p.name.as_str()).collect();
    assert!(names.starts_with(&["raster", "metaballs"]) && names.contains(&"tonemap"), "{names:?}");
    common::assert_clean(&rt);
}
