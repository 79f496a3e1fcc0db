//! Raster pass vs the CPU f64 ray cast: per-pixel depth, normals under instance transforms,
//! tonemap vs its CPU twin, empty scenes. Lavapipe with validation on.

mod common;

use glam::DVec3;
use hadou::effects::raycast::SceneCaster;
use hadou::effects::tonemap::tonemap_channel;
use hadou::scene::Scene;
use hadou::testing::Comparison;
use hadou::{Aov, FrameRequest};

/// A CPU hit: distance, instance, world-space geometric normal.
type Hit = (f64, usize, DVec3);

/// How far from the pixel centre the rasterizer's coverage may act as if it sampled: lavapipe
/// snaps vertices to 2⁻⁸ px (subPixelPrecisionBits = 8), which moves an edge by ≤ 2⁻⁹·√2 ≈ 0.0028
/// px, and its f32 edge functions add ~1e-5 px at these sizes. Rays at ±2⁻⁷ px along x and y reach
/// past that band whatever the edge's direction (2⁻⁷/√2 ≈ 0.0055 px across it).
const BAND: f64 = 1.0 / 128.0;

/// CPU reference of one pixel: the centre ray, then the rays at ±`BAND` px along x and y.
struct PixelRef {
    rays: [Option<Hit>; 5],
}

impl PixelRef {
    fn centre(&self) -> Option<Hit> {
        self.rays[0]
    }

    /// Whether the f64 scene is the same all over the band, so the GPU must match the centre ray:
    /// every ray misses, or every ray hits the centre's instance with a depth within `JUMP` of the
    /// centre's and a normal within `normal_tol` (rad).
    fn settled(&self, normal_tol: f64) -> bool {
        let centre = self.centre();
        self.rays[1..].iter().all(|r| match (centre, r) {
            (None, None) => true,
            (Some((t, id, n)), Some((tr, idr, nr))) => {
                *idr == id && (tr - t).abs() <= JUMP * t && n.dot(*nr) >= normal_tol.cos()
            }
            _ => false,
        })
    }

    /// How much the depth changes over the band, relative to the centre's (0 for a miss): where
    /// the rasterizer's coverage point lies, ≤ 0.0028 px from the centre, the depth is within it.
    fn spread(&self) -> f64 {
        let Some((t, _, _)) = self.centre() else { return 0.0 };
        self.rays[1..].iter().flatten().map(|(tr, _, _)| (tr - t).abs() / t).fold(0.0, f64::max)
    }
}

/// A depth step of an instance over itself (self-occlusion) within the band: a continuous surface
/// at incidence θ changes depth by t·α·tanθ over 2⁻⁷ px (α: a pixel's angle, ≤ 0.01 rad here), so
/// 5 % over the band takes tanθ ≥ 0.05·128/0.01 = 640, θ > 89.9°: only a step does that.
const JUMP: f64 = 0.05;

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
            let cast = |(dx, dy): (f64, f64)| {
                let (o, d) = cam.ray_through(x as f64 + 0.5 + dx, y as f64 + 0.5 + dy, w, h);
                caster.cast(o, d).filter(|hit| hit.t <= cam.far).map(|hit| (hit.t, hit.instance, hit.normal))
            };
            let rays = [(0.0, 0.0), (-BAND, 0.0), (BAND, 0.0), (0.0, -BAND), (0.0, BAND)].map(cast);
            out.push(PixelRef { rays });
        }
    }
    out
}

/// f32 arithmetic keeps 2⁻²⁴ ≈ 6e-8 relative per operation; the vertex transform, the
/// perspective-correct interpolation and the length take a few dozen such steps, so 1e-4
/// relative leaves two orders of magnitude of margin while still catching any wrong transform,
/// projection or pixel-centre convention (those are off by ≥ 1e-3).
const DEPTH_REL_TOL: f64 = 1e-4;

/// The share of pixels whose f64 scene changes within the band (`BAND`) that a depth or normal
/// test may leave out of the strict comparison: the band is 2⁻⁶ px wide along each outline (and
/// crease, for normals), so 1 % of the image would take 0.64 px of outline per pixel, ≈ 12 000 px
/// at 160 × 120: several times what these scenes draw (measured: ≤ 0.2 %).
const BAND_SHARE: f64 = 0.01;

/// A depth (or `f64::INFINITY`, nothing hit) against one CPU ray's: relative, or 0/∞ for a miss.
fn depth_error(gpu: f64, cpu: Option<Hit>) -> f64 {
    match cpu {
        None if gpu == f64::INFINITY => 0.0,
        None => f64::INFINITY,
        Some((t, _, _)) => (gpu - t).abs() / t,
    }
}

/// `min_surface`: how many settled pixels must show a surface (so misses alone cannot pass).
fn check_depth(scene_rel: &str, w: u32, h: u32, min_surface: usize) {
    check_scene_depth(scene_rel, common::load(scene_rel), w, h, min_surface);
}

fn check_scene_depth(scene_rel: &str, mut scene: Scene, w: u32, h: u32, min_surface: usize) {
    // The raster's depth alone: metaballs (a compute pass) would add surfaces the mesh ray cast
    // does not know; they have their own test.
    scene.metaballs_mut().clear();
    let caster = caster(&scene);
    let refs = reference(&scene, &caster, w, h);
    let mut rt = common::runtime();
    rt.load_scene(scene).unwrap();
    let mut req = FrameRequest::new(w, h);
    req.aovs = vec![Aov::Depth];
    let frame = rt.render(&req).unwrap();
    rt.finish();
    let depth = frame.aov(Aov::Depth).unwrap();
    // Every pixel whose f64 scene is settled over the band: the GPU depth against the centre ray
    // (an infinite depth where it misses), within DEPTH_REL_TOL plus the depth's change over the
    // band (the coverage point's offset on a slope). Elsewhere the rasterizer may cover the centre
    // with any surface of the band (a face seen edge-on included): those pixels are left out, and
    // capped at BAND_SHARE.
    let mut strict = Comparison::new(format!("{scene_rel}: depth vs the f64 centre ray, error / bound"));
    let mut hits = 0;
    for (i, r) in refs.iter().enumerate() {
        let gpu = depth.data[i] as f64;
        let (x, y) = (i as u32 % w, i as u32 / w);
        if r.settled(std::f64::consts::PI) {
            hits += usize::from(r.centre().is_some());
            let bound = DEPTH_REL_TOL + r.spread();
            let at = format_args!("({x}, {y}): gpu {gpu}, f64 {:?}, bound {bound:.2e}", r.centre());
            strict.error(at, depth_error(gpu, r.centre()) / bound);
        } else {
            strict.exclude();
        }
    }
    let total = (w * h) as usize;
    strict.assert_within(1.0, (total as f64 * (1.0 - BAND_SHARE)) as usize);
    strict.assert_excluded_at_most(BAND_SHARE);
    println!("{hits} settled pixels show a surface");
    assert!(hits >= min_surface, "{hits} settled pixels with a surface of {total}, want {min_surface}");
}

#[test]
fn showcase_depth_matches_f64_raycast() {
    // The ground and the objects cover over two thirds of the view.
    check_depth("assets/scenes/showcase.toml", 160, 120, 160 * 120 / 2);
}

#[test]
fn instances_depth_matches_f64_raycast() {
    // 50 small cubes cover ≈ 12 % of the view.
    check_depth("assets/scenes/instances.toml", 128, 128, 128 * 128 / 10);
}

/// The 50 instances and their camera carried 10⁴ and 10⁵ units from the world's origin: the
/// depth keeps its bound, which knows nothing of where the scene is.
#[test]
fn far_from_the_origin_the_depth_keeps_its_bound() {
    use hadou::scene::transform::{Transform, TransformOp};
    for far in [1.0e4, 1.0e5] {
        let mut scene = common::load("assets/scenes/instances.toml");
        let at = DVec3::new(far, -0.3 * far, far);
        scene.camera.position += at;
        scene.camera.look_at += at;
        for inst in &mut scene.instances {
            inst.ops.push(TransformOp::Translate(at));
            inst.transform = Transform::from_ops(&inst.ops).unwrap();
        }
        check_scene_depth(&format!("instances at {far}"), scene, 128, 128, 128 * 128 / 10);
    }
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
    rt.finish();
    let normals = frame.aov(Aov::Normal).unwrap();
    // The angle to one CPU ray's normal, facing the camera like the G-buffer's; where the ray
    // misses, the G-buffer must hold no surface (w = 0): 0 or ∞.
    let angle = |x: u32, y: u32, cpu: Option<Hit>| {
        let n_gpu =
            DVec3::new(normals.at(x, y, 0) as f64, normals.at(x, y, 1) as f64, normals.at(x, y, 2) as f64);
        let surface = normals.at(x, y, 3) > 0.0;
        match cpu {
            None if !surface => 0.0,
            None => f64::INFINITY,
            Some(_) if !surface => f64::INFINITY,
            Some((_, _, n_cpu)) => {
                let (_, d) = scene.camera.pixel_ray(x, y, w, h);
                let n_cpu = if n_cpu.dot(d) > 0.0 { -n_cpu } else { n_cpu };
                n_gpu.normalize().dot(n_cpu).clamp(-1.0, 1.0).acos()
            }
        }
    };
    // Settled pixels (one face over the whole band; the two triangles of a face agree to ~1e-15)
    // against the centre ray; the others left out, capped at BAND_SHARE.
    let mut strict = Comparison::new("normals vs the f64 centre ray, angle (rad)");
    let mut hits = 0;
    for (i, r) in refs.iter().enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        if r.settled(1e-6) {
            hits += usize::from(r.centre().is_some());
            strict.error(format_args!("({x}, {y}), f64 {:?}", r.centre()), angle(x, y, r.centre()));
        } else {
            strict.exclude();
        }
    }
    let total = (w * h) as usize;
    strict.assert_within(2e-3, (total as f64 * (1.0 - BAND_SHARE)) as usize);
    strict.assert_excluded_at_most(BAND_SHARE);
    assert!(hits > 1000, "only {hits} settled pixels show a surface");
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
    rt.finish();
    let hdr = frame.aov(Aov::Hdr).unwrap();
    let color = frame.color.as_ref().unwrap();
    let mut codes = Comparison::new("tonemap vs its f64 twin, 8-bit codes");
    for (i, px) in color.chunks_exact(4).enumerate() {
        for (c, &gpu) in px.iter().take(3).enumerate() {
            let cpu = tonemap_channel(hdr.data[i * 4 + c] as f64, exposure);
            codes.abs(format_args!("pixel {i} channel {c}"), gpu as f64, cpu);
        }
        assert_eq!(px[3], 255);
    }
    codes.assert_within(1.0, 64 * 48 * 3);
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
    rt.finish();
}

/// Resizing between frames, reloading a scene, many frames: no leaks or hazards (validation,
/// checked by `finish` after the device is destroyed, where leaked objects are reported).
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
    rt.finish();
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
    rt.finish();
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
    rt.finish();
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
    rt.finish();
}
