//! The metaballs pass on the GPU vs the f64 reference (`effects::metaballs::cast`) per pixel:
//! hit mask, depth and normals on the metaball scene, the intersection curve with a raster cube,
//! the energy wave clipped by a metaball, 10,000 balls piled into one tile, and the hard cases
//! (camera inside a support or the surface, a group behind the camera, balls on the near
//! plane). Lavapipe with validation on; every runtime's log is checked after its device is
//! destroyed (`common::runtime`).
//!
//! Where f32 may legitimately disagree with f64 is stated by the tangency band
//! (`metaballs_f32::tangency(..).in_band()`, see its module docs): band pixels are counted,
//! excluded from the comparisons and capped at a share of the pixels; everywhere else the GPU
//! must agree, within a per-pixel bound derived from the band's f32 error model (`f32_bound`),
//! on at least a stated number of compared pixels (`hadou::testing::Comparison`).

mod common;

use common::metaball_bound::{self, angle};

use glam::DVec3;
use hadou::effects::energy_wave::line_integral;
use hadou::effects::metaballs::{cast, CastMethod, Kernel, MetaHit, MetaballGroupParams};
use hadou::effects::metaballs_compare::{compare_metaballs, MetaballFrame};
use hadou::effects::metaballs_f32::{tangency, BAND_C};
use hadou::effects::metaballs_trace::{TRACE_BISECT, TRACE_MIN_STEP};
use hadou::effects::raycast::SceneCaster;
use hadou::passes::energy_wave::wave_params;
use hadou::passes::metaballs::{CLIP_STEPS, CLIP_STEPS_MAX, DROPPED, HITS, STREAMED};
use hadou::passes::plan;
use hadou::scene::Scene;
use hadou::testing::Comparison;
use hadou::{Aov, AovImage, FrameOutput, FrameRequest};

/// The band pixels allowed, as a share of a frame's pixels. A ray is in the band when it passes
/// within δ/‖∇F‖ (δ = 16·ε_f32·(S + X·G): ~10⁻⁵ world units here) of grazing the surface, or
/// starts or ends within δ of it; a pixel is ~0.05–0.2 units across in these scenes, so a
/// silhouette or an intersection curve puts ~10⁻⁴ of its pixels in the band: ~one pixel per frame.
/// 1% is a hundred times more, yet small enough that the band cannot hollow out a comparison.
const BAND_SHARE: f64 = 0.01;

/// What the f64 reference sees on one pixel's ray: the nearest hit over the groups (with the
/// group that made it) and whether any group's ray is in the tangency band.
struct Reference {
    hit: Option<(usize, MetaHit)>,
    band: bool,
}

fn reference(groups: &[MetaballGroupParams], o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Reference {
    let mut hit: Option<(usize, MetaHit)> = None;
    let mut band = false;
    for (k, g) in groups.iter().enumerate() {
        if let Some(h) = cast(g, o, d, t_min, t_max) {
            if hit.as_ref().is_none_or(|(_, best)| h.t < best.t) {
                hit = Some((k, h));
            }
        }
        band |= tangency(g, o, d, t_min, t_max).in_band();
    }
    Reference { hit, band }
}

/// The camera's near plane measured along the pixel ray (the pass's t_min).
fn near_along(scene: &Scene, d: DVec3) -> f64 {
    scene.camera.near / d.dot(scene.camera.basis().forward)
}

fn render(scene: &Scene, w: u32, h: u32, time: f64, aovs: &[Aov]) -> FrameOutput {
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let mut req = FrameRequest::new(w, h);
    req.time = time;
    req.aovs = aovs.to_vec();
    let frame = rt.render(&req).unwrap();
    // Checked again after the device is destroyed (leaks), when `rt` drops.
    common::assert_clean(&rt);
    frame
}

/// The same scene without its metaballs: the raster's own distance, the pass's t_max.
fn raster_only(scene: &Scene, w: u32, h: u32) -> FrameOutput {
    let mut bare = scene.clone();
    bare.metaballs_mut().clear();
    bare.waves_mut().clear();
    render(&bare, w, h, 0.0, &[Aov::Depth])
}

fn groups_at(scene: &Scene, time: f64) -> Vec<MetaballGroupParams> {
    scene.metaballs().iter().map(|g| g.at(time)).collect()
}

/// How far an f32 cast may lie from the exact hit of `g` at world distance `t` on a ray outside
/// the tangency band: (relative depth, normal angle in radians), `common::metaball_bound::f32_bound`
/// with the group's method's own term (`method_term`). (The same model is checked ray by ray on the
/// shader's cast itself in tests/metaballs_gpu.rs.)
fn f32_bound(g: &MetaballGroupParams, o: DVec3, d: DVec3, t: f64) -> (f64, f64) {
    let t_scale = g.transform.ray_to_object(o, d).t_scale;
    metaball_bound::f32_bound(g, o, d, t, method_term(g, t_scale))
}

/// A cast method's own distance from the root (object units): sphere tracing bisects a bracket
/// one least step wide (TRACE_MIN_STEP·T/L, L ≥ the group's least |q|γ/R) 16 times, so its
/// middle is within 2⁻¹⁷ of that (metaballs_math.rs); clipping with a tolerance answers the middle
/// of a bracket up to that wide (world units).
fn method_term(g: &MetaballGroupParams, t_scale: f64) -> f64 {
    match g.method {
        CastMethod::Bezier { tolerance } => 0.5 * tolerance * t_scale,
        CastMethod::SphereTrace { .. } => {
            let l_min = g
                .balls
                .iter()
                .map(|b| b.q.abs() * g.kernel.max_slope() / b.radius)
                .fold(f64::INFINITY, f64::min);
            TRACE_MIN_STEP * g.threshold / l_min * 0.5f64.powi(TRACE_BISECT as i32 + 1)
        }
    }
}

/// The normal AOV is RGBA16F: each component rounded to 11 significant bits (relative error
/// ≤ 2⁻¹¹, so the vector moves by ≤ 2⁻¹¹ of its length and turns by ≤ 2⁻¹¹ rad), components below
/// the least normal half (6.1·10⁻⁵) by ≤ 2⁻²⁵ absolutely (2⁻²⁴ for all three, to spare).
const NORMAL_AOV_STEP: f64 = 1.0 / 2048.0 + 1.0 / 16_777_216.0;

/// A frame's metaball depth (and normals) against the f64 reference on every pixel.
struct Checked {
    /// 1 where GPU and reference disagree about a metaball hit (tolerance 0); band pixels excluded.
    hit_miss: Comparison,
    /// |t_gpu − t|/t over its `f32_bound`, on the hits both see.
    depth: Comparison,
    /// The pass's contract (metaballs_f32 module docs): depth ≤ 1e-4 relative.
    contract_depth: Comparison,
    /// With a normal AOV: the angle over its `f32_bound` plus the RGBA16F step, and in degrees
    /// (contract 0.5°).
    normal: Option<(Comparison, Comparison)>,
    ref_hits: usize,
    gpu_hits: usize,
}

impl Checked {
    /// Asserts every comparison: band (and other left-out pixels) ≤ `left_out` of the pixels,
    /// hit/miss equal on every other pixel, depth and normals within their bounds on at least
    /// `min_hits` pixels.
    #[track_caller]
    fn assert(&self, min_hits: usize, left_out: f64) {
        self.hit_miss.assert_excluded_at_most(left_out);
        let pixels = self.hit_miss.compared() + self.hit_miss.excluded();
        self.hit_miss.assert_within(0.0, pixels - (left_out * pixels as f64) as usize);
        self.depth.assert_within(1.0, min_hits);
        self.contract_depth.assert_within(1e-4, min_hits);
        if let Some((bound, contract)) = &self.normal {
            bound.assert_within(1.0, min_hits);
            contract.assert_within(0.5, min_hits);
        }
    }
}

/// The frame's metaballs against the f64 reference on every pixel: t_max is the GPU raster's own
/// distance (`raster`), and a pixel shows a metaball where its depth differs from it. Band pixels
/// and those `leave_out(o, d, t_min, t_max)` names are excluded.
fn check(
    label: &str,
    scene: &Scene,
    time: f64,
    (depth, raster, normal): (&AovImage, &AovImage, Option<&AovImage>),
    leave_out: impl Fn(DVec3, DVec3, f64, f64) -> bool,
) -> Checked {
    let (w, h) = (depth.width, depth.height);
    let groups = groups_at(scene, time);
    let cam = &scene.camera;
    let new = |what: &str| Comparison::new(format!("{label}: {what}"));
    let mut c = Checked {
        hit_miss: new("metaball hit/miss differs from f64"),
        depth: new("depth vs f64 / its bound"),
        contract_depth: new("depth vs f64, relative"),
        normal: normal.map(|_| (new("normal vs f64 / its bound"), new("normal vs f64, degrees"))),
        ref_hits: 0,
        gpu_hits: 0,
    };
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (o, d) = cam.pixel_ray(x, y, w, h);
            let (t_min, t_max) = (near_along(scene, d), (raster.data[i] as f64).min(cam.far));
            let r = reference(&groups, o, d, t_min, t_max);
            let gpu_hit = depth.data[i].to_bits() != raster.data[i].to_bits();
            c.ref_hits += usize::from(r.hit.is_some());
            c.gpu_hits += usize::from(gpu_hit);
            let at = format_args!("({x}, {y}): gpu {}, raster {}", depth.data[i], raster.data[i]);
            if depth.data[i].is_nan() {
                // Never acceptable, not even where the comparison leaves the pixel out.
                c.hit_miss.error(at, f64::NAN);
                continue;
            }
            if r.band || leave_out(o, d, t_min, t_max) {
                c.hit_miss.exclude();
                continue;
            }
            c.hit_miss.error(at, f64::from(u8::from(gpu_hit != r.hit.is_some())));
            let (Some((k, hit)), true) = (r.hit, gpu_hit) else { continue };
            let (bound_t, bound_n) = f32_bound(&groups[k], o, d, hit.t);
            let gpu_t = depth.data[i] as f64;
            c.depth.error(at, (gpu_t - hit.t).abs() / hit.t / bound_t);
            c.contract_depth.rel(at, gpu_t, hit.t);
            if let (Some(image), Some((bound, contract))) = (normal, c.normal.as_mut()) {
                // The pass writes the normal facing the camera.
                let n = if hit.normal.dot(d) > 0.0 { -hit.normal } else { hit.normal };
                let g = DVec3::from_array([0, 1, 2].map(|ch| image.at(x, y, ch) as f64));
                bound.error(at, angle(g, n) / (bound_n + NORMAL_AOV_STEP));
                contract.error(at, angle(g, n).to_degrees());
            }
        }
    }
    println!("{label}: {} px, reference hits {}, gpu hits {}", w * h, c.ref_hits, c.gpu_hits);
    c
}

/// Renders `scene` (depth, normal, HDR) and its raster alone, and checks the metaballs.
fn compare(label: &str, scene: &Scene, w: u32, h: u32, time: f64) -> (Checked, FrameOutput, FrameOutput) {
    let frame = render(scene, w, h, time, &[Aov::Depth, Aov::Normal, Aov::Hdr]);
    let raster = raster_only(scene, w, h);
    for aov in [Aov::Hdr, Aov::Normal] {
        assert!(frame.aov(aov).unwrap().data.iter().all(|v| v.is_finite()), "{label}: {aov:?} holds NaN/Inf");
    }
    assert!(!frame.aov(Aov::Depth).unwrap().data.iter().any(|v| v.is_nan()), "{label}: depth holds NaN");
    let images = (frame.aov(Aov::Depth).unwrap(), raster.aov(Aov::Depth).unwrap(), frame.aov(Aov::Normal));
    let c = check(label, scene, time, images, |_, _, _, _| false);
    (c, frame, raster)
}

#[test]
fn depth_and_normals_match_the_f64_reference() {
    let scene = common::load("assets/scenes/metaballs.toml");
    for time in [0.0, 0.5, 1.0] {
        let label = format!("metaballs.toml t={time}");
        let (c, frame, raster) = compare(&label, &scene, 96, 96, time);
        // The three groups fill ~15% of the frame (1,358 of 9,216 px when written).
        c.assert(1000, BAND_SHARE);
        assert_eq!(frame.stats.counter(DROPPED), 0);
        assert_eq!(frame.stats.counter(HITS) as usize, c.gpu_hits);
        println!(
            "  clipping: {} hits, {:.2} steps per hit, at most {}",
            frame.stats.counter(HITS),
            frame.stats.counter(CLIP_STEPS) as f64 / frame.stats.counter(HITS) as f64,
            frame.stats.counter(CLIP_STEPS_MAX)
        );
        if time == 0.0 {
            // `compare_metaballs` (what `hadou report` and the benchmark use) counts the same.
            let aovs = MetaballFrame {
                depth: frame.aov(Aov::Depth).unwrap(),
                raster_depth: raster.aov(Aov::Depth).unwrap(),
                normal: frame.aov(Aov::Normal),
            };
            let stats = compare_metaballs(&scene, time, aovs).unwrap();
            assert_eq!(
                (stats.pixels, stats.band, stats.ref_hits, stats.gpu_hits, stats.mismatched, stats.nan_depth),
                (96 * 96, c.hit_miss.excluded(), c.ref_hits, c.gpu_hits, 0, 0)
            );
            assert_eq!(stats.depth_max_rel.to_bits(), c.contract_depth.worst().to_bits());
        }
    }
}

/// A metaball group half inside a raster cube: the depth AOV follows min(cube, metaballs) of the
/// f64 references (`SceneCaster` for the cube), so the intersection curve lies where the f64
/// reference puts it. Pixels on the cube's silhouette (centre and corner rays disagree about
/// hitting it: raster coverage rules decide there) and band pixels are left out, both capped.
#[test]
fn intersection_with_a_raster_cube_follows_the_reference() {
    let scene = common::parse(
        r#"
        [camera]
        position = [1.5, 2.5, 6]
        look_at = [0, 0.3, 0]
        fov_y_deg = 40
        near = 0.1
        far = 50
        [[light]]
        direction = [-1, -2, -1]
        [[mesh]]
        name = "box"
        kind = "cube"
        size = 2
        [[material]]
        name = "slime"
        albedo = [0.3, 0.8, 0.3]
        [[instance]]
        mesh = "box"
        transform = [{ rotate = { angle_deg = 20, axis = [0, 1, 0] } }]
        [[metaballs]]
        material = "slime"
        balls = [
          { centre = [0.3, 0.9, 0.7], radius = 1.6 },
          { centre = [-0.5, 1.0, 0.9], radius = 1.3, q = 0.8 },
          { centre = [0.9, 0.2, 1.0], radius = 1.1 },
        ]
        "#,
    );
    let (w, h) = (96u32, 96u32);
    let frame = render(&scene, w, h, 0.0, &[Aov::Depth]);
    let depth = &frame.aov(Aov::Depth).unwrap().data;
    let meshes: Vec<_> = scene.meshes.iter().map(|m| m.mesh.clone()).collect();
    let instances: Vec<_> = scene.instances.iter().map(|i| (i.mesh, i.transform)).collect();
    let caster = SceneCaster::new(&meshes, &instances).unwrap();
    let groups = groups_at(&scene, 0.0);
    let cam = &scene.camera;
    let cube_t = |px: f64, py: f64| {
        let (o, d) = cam.ray_through(px, py, w, h);
        caster.cast(o, d).map(|hit| hit.t).filter(|&t| t <= cam.far)
    };
    // Per pixel: which surface the reference sees (0 none, 1 cube, 2 metaball).
    let mut kind = vec![0u8; (w * h) as usize];
    // Pixels the reference sees nothing on must be empty (1 where the GPU shows something).
    let mut empty = Comparison::new("empty pixels: the GPU shows a surface");
    // The raster distance as in tests/gpu_raster.rs (DEPTH_REL_TOL): f32 keeps 2⁻²⁴ per operation
    // and the transform, interpolation and length take a few dozen: 1e-4 relative leaves a
    // hundredfold margin.
    let mut cube = Comparison::new("cube pixels: depth vs SceneCaster, relative");
    let mut metaball = Comparison::new("metaball pixels: depth vs f64 / its bound");
    let mut contract = Comparison::new("metaball pixels: depth vs f64, relative (contract 1e-4)");
    let (mut silhouette, mut band) = (Comparison::new("cube silhouette"), Comparison::new("tangency band"));
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (o, d) = cam.pixel_ray(x, y, w, h);
            let centre = cube_t(x as f64 + 0.5, y as f64 + 0.5);
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .map(|(dx, dy)| cube_t(x as f64 + dx, y as f64 + dy).is_some());
            let t_cube = centre.unwrap_or(f64::INFINITY);
            let r = reference(&groups, o, d, near_along(&scene, d), t_cube.min(cam.far));
            kind[i] = match (&r.hit, centre) {
                (Some(_), _) => 2,
                (None, Some(_)) => 1,
                (None, None) => 0,
            };
            let on_silhouette = corners.iter().any(|&c| c != centre.is_some());
            if on_silhouette {
                silhouette.exclude();
                continue;
            }
            silhouette.error("-", 0.0);
            if r.band {
                band.exclude();
                continue;
            }
            band.error("-", 0.0);
            let gpu = depth[i] as f64;
            let at = format_args!("({x}, {y})");
            match (r.hit, centre) {
                (Some((k, hit)), _) => {
                    metaball.error(at, (gpu - hit.t).abs() / hit.t / f32_bound(&groups[k], o, d, hit.t).0);
                    contract.rel(at, gpu, hit.t);
                }
                (None, Some(t)) => {
                    cube.rel(at, gpu, t);
                }
                (None, None) => {
                    empty.error(at, f64::from(u8::from(!gpu.is_infinite())));
                }
            }
        }
    }
    // Pixels on the intersection curve: the metaball in front, the cube in a 4-neighbour.
    let mut curve = 0;
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = (y * w + x) as usize;
            let n = [i - 1, i + 1, i - w as usize, i + w as usize];
            if kind[i] == 2 && n.iter().any(|&j| kind[j] == 1) {
                curve += 1;
            }
        }
    }
    println!("cube + metaballs: {curve} px along the intersection curve");
    // The cube spans about half the frame: its outline, ≲ 4·96 px long, is at most ~4% of the
    // pixels (206 of 9,216 when written); 5% caps it.
    silhouette.assert_excluded_at_most(0.05);
    band.assert_excluded_at_most(BAND_SHARE);
    // Each surface covers a good part of the frame (cube 658, metaballs 2,151 and nothing 6,199
    // of the 9,216 px when written).
    cube.assert_within(1e-4, 500);
    metaball.assert_within(1.0, 500);
    contract.assert_within(1e-4, 500);
    empty.assert_within(0.0, 500);
    assert!(curve >= 20, "the metaballs must cut into the cube visibly: {curve} px of curve");
}

/// The energy wave integrates up to the metaball: its AOV matches the f64 integral up to the f64
/// metaball distance on metaball pixels, where that clips the wave.
#[test]
fn metaballs_clip_the_energy_wave() {
    let scene = common::parse(
        r#"
        [camera]
        position = [0, 1, 9]
        look_at = [0, 0, 0]
        fov_y_deg = 45
        far = 60
        [[metaballs]]
        balls = [
          { centre = [-0.8, 0, 0], radius = 2 },
          { centre = [0.9, 0.4, 0.3], radius = 1.7 },
        ]
        [[wave]]
        origin = [-3, 0.2, -2]
        direction = [1, 0, 0.1]
        a = 1.5
        b = 0.8
        core = 0.05
        length = 7
        "#,
    );
    let (w, h) = (80u32, 80u32);
    let frame = render(&scene, w, h, 0.0, &[Aov::Energy, Aov::Depth]);
    assert_eq!(
        frame.stats.passes.iter().map(|p| p.name.as_str()).collect::<Vec<_>>()[..3],
        ["raster", "metaballs", "energy_wave"]
    );
    let energy = &frame.aov(Aov::Energy).unwrap().data;
    let groups = groups_at(&scene, 0.0);
    let wave = wave_params(&scene.waves()[0].at(0.0));
    let cam = &scene.camera;
    let mut clipped = 0;
    let mut integral =
        Comparison::new("energy on metaball pixels vs the f64 integral to the f64 hit, relative");
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            assert!(energy[i].is_finite() && energy[i] >= 0.0, "({x}, {y}): energy {}", energy[i]);
            let (o, d) = cam.pixel_ray(x, y, w, h);
            let r = reference(&groups, o, d, near_along(&scene, d), cam.far);
            if r.band {
                integral.exclude();
                continue;
            }
            let Some((_, hit)) = r.hit else { continue };
            let h_ref = line_integral(&wave, o, d, hit.t);
            if line_integral(&wave, o, d, cam.far) > 1.01 * h_ref {
                clipped += 1;
            }
            integral.rel(format_args!("({x}, {y})"), energy[i] as f64, h_ref);
        }
    }
    println!("wave behind metaballs: {clipped} clipped metaball px");
    integral.assert_excluded_at_most(BAND_SHARE);
    // 1e-4: the bound tests/gpu_energy_wave.rs argues for H itself (the pixel ray in f32, the
    // closed form); the clip point's own error (the metaball depth, within `f32_bound`) moves H
    // by the integrand there times ~10⁻⁵ of the distance, not added here.
    integral.assert_within(1e-4, 500);
    assert!(clipped > 200, "the wave must pass behind the metaballs: {clipped} px clipped");
}

/// 10,000 balls piled into one 16×16 tile: every point of the pile lies in dozens of supports.
/// No validation error, nothing NaN, and every surface the f64 reference sees (outside the band)
/// the GPU shows, at the reference's depth and normal: the crowded casts are streamed, none
/// dropped.
#[test]
fn ten_thousand_balls_in_one_tile() {
    let scene = common::parse(
        r#"
        [camera]
        position = [0, 0, 20]
        look_at = [0, 0, 0]
        fov_y_deg = 45
        far = 100
        [[metaballs]]
        generate = { count = 10000, seed = 11, bounds = [[-2.1, -2.1, -2.1], [2.1, 2.1, 2.1]], radius = [0.2, 0.5], q = [0.8, 1.2] }
        "#,
    );
    // 48×48 (2.9 px per unit at the pile): the pile, 5.2 units across with its supports, covers
    // ~15 px around the centre of tile (1, 1).
    let (w, h) = (48u32, 48u32);
    let (c, frame, _) = compare("10,000 balls", &scene, w, h, 0.0);
    let depth = &frame.aov(Aov::Depth).unwrap().data;
    for (i, v) in depth.iter().enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        if !(16..32).contains(&x) || !(16..32).contains(&y) {
            assert!(v.is_infinite(), "({x}, {y}) outside the pile's tile shows {v}");
        }
    }
    // 203 reference hits when written, all inside the tile.
    c.assert(150, BAND_SHARE);
    assert_eq!(frame.stats.counter(DROPPED), 0, "every surface found, none dropped");
    assert!(frame.stats.counter(STREAMED) > 0, "the pile crowds more than 32 supports on a point");
}

/// A depth AOV (no raster: t_max = far) against the f64 reference of `groups`: every pixel whose
/// ray provably misses (`provable_miss`, cheap) and every `stride`-th pixel each way of the others
/// (the f64 reference, costly), band pixels excluded. Counts the pixels where the reference hits
/// and the GPU shows nothing; GPU hits where the reference misses are errors of 1 (tolerance 0);
/// the depths of the hits both see are compared.
struct Tally {
    missed: u64,
    sampled_hits: u64,
    phantom: Comparison,
    depth: Comparison,
    contract: Comparison,
}

fn tally(
    scene: &Scene,
    groups: &[MetaballGroupParams],
    depth: &[f32],
    size: (u32, u32),
    stride: usize,
    label: &str,
) -> Tally {
    let (w, h) = size;
    let cam = &scene.camera;
    let new = |what: &str| Comparison::new(format!("{label}: {what}"));
    let mut t = Tally {
        missed: 0,
        sampled_hits: 0,
        phantom: new("GPU hit where the reference misses"),
        depth: new("depth vs f64 / its bound"),
        contract: new("depth vs f64, relative (contract 1e-4)"),
    };
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (o, d) = cam.pixel_ray(x, y, w, h);
            let gpu = depth[i] as f64;
            let at = format_args!("({x}, {y}): gpu {gpu}");
            if gpu.is_nan() {
                t.phantom.error(at, f64::NAN);
                continue;
            }
            if groups.iter().all(|g| provable_miss(g, o, d)) {
                t.phantom.error(at, if gpu.is_infinite() { 0.0 } else { 1.0 });
                continue;
            }
            if x as usize % stride != 0 || y as usize % stride != 0 {
                continue;
            }
            let r = reference(groups, o, d, near_along(scene, d), cam.far);
            if r.band {
                t.phantom.exclude();
                continue;
            }
            match r.hit {
                None => {
                    // NaN is neither infinite nor a hit: it fails here too.
                    t.phantom.error(at, if gpu.is_infinite() { 0.0 } else { 1.0 });
                }
                Some((k, hit)) => {
                    t.sampled_hits += 1;
                    if gpu.is_infinite() {
                        t.missed += 1;
                    } else {
                        t.depth.error(at, (gpu - hit.t).abs() / hit.t / f32_bound(&groups[k], o, d, hit.t).0);
                        t.contract.rel(at, gpu, hit.t);
                    }
                }
            }
        }
    }
    t
}

fn one_group_scene(camera: &str, near: f64, balls: &str, wave: bool) -> Scene {
    let wave = if wave {
        "[[wave]]\norigin = [0, 0, 0]\ndirection = [1, 0, 0]\na = 1\nb = 0.5\ncore = 0.05\nlength = 3\n"
    } else {
        ""
    };
    common::parse(&format!(
        r#"
        [camera]
        {camera}
        fov_y_deg = 50
        near = {near}
        far = 100
        [[light]]
        direction = [-1, -2, -1]
        [[metaballs]]
        balls = [{balls}]
        {wave}
        "#
    ))
}

/// Camera inside a support sphere, inside the surface, a group behind the camera, a ball centred
/// on the near plane and one whose support touches it: no NaN in any AOV, and the GPU agrees with
/// the reference outside the band (capped) on every pixel.
#[test]
fn hard_cases_stay_finite_and_agree() {
    // (label, camera, near, balls, reference hits at least: 1,600, 1,600, 0, 1,600 and 724 of
    // the 1,600 px when written).
    let cases = [
        (
            "camera inside a support",
            "position = [0, 0, 3]\nlook_at = [0, 0, 0]",
            0.1,
            "{ centre = [0, 0, 0], radius = 4 }, { centre = [1.5, 0.5, 0], radius = 2 }",
            1500,
        ),
        (
            "camera inside the surface",
            "position = [0, 0, 0.8]\nlook_at = [0, 0, 0]",
            0.1,
            "{ centre = [0, 0, 0], radius = 4 }, { centre = [1.2, 0, 0], radius = 2.5 }",
            1500,
        ),
        (
            "group behind the camera",
            "position = [0, 0, 10]\nlook_at = [0, 0, 0]",
            0.1,
            "{ centre = [0, 0, 14], radius = 2 }, { centre = [1, 0, 15], radius = 2 }",
            0,
        ),
        (
            "ball centred on the near plane",
            "position = [0, 0, 10]\nlook_at = [0, 0, 0]",
            0.5,
            "{ centre = [0, 0, 9.5], radius = 1 }, { centre = [0.6, 0, 9], radius = 0.8 }",
            1500,
        ),
        (
            "support touching the near plane",
            "position = [0, 0, 10]\nlook_at = [0, 0, 0]",
            0.5,
            "{ centre = [0, 0, 8.5], radius = 1 }",
            600,
        ),
    ];
    for (label, camera, near, balls, min_hits) in cases {
        for wave in [false, true] {
            let label = format!("{label}{}", if wave { " + wave" } else { "" });
            let scene = one_group_scene(camera, near, balls, wave);
            let (c, frame, _) = compare(&label, &scene, 40, 40, 0.0);
            c.assert(min_hits, BAND_SHARE);
            if wave {
                let frame = render(&scene, 40, 40, 0.0, &[Aov::Energy]);
                let energy = &frame.aov(Aov::Energy).unwrap().data;
                assert!(energy.iter().all(|v| v.is_finite() && *v >= 0.0), "{label}: energy NaN/Inf");
            }
            assert_eq!(frame.stats.counter(DROPPED), 0, "{label}");
            if min_hits == 0 {
                assert_eq!((c.gpu_hits, c.ref_hits), (0, 0), "{label}: nothing in front of the camera");
            }
        }
    }
}

/// The tile lists outgrow their first buffers when the frame grows: the pass recreates them and
/// rewrites its descriptors, and the frame equals one rendered by a fresh runtime.
#[test]
fn growing_tile_lists_rebind() {
    let scene = common::load("assets/scenes/metaballs_4096.toml");
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let mut req = FrameRequest::new(64, 64);
    req.aovs = vec![Aov::Depth];
    rt.render(&req).unwrap();
    req.width = 320;
    req.height = 320;
    let grown = rt.render(&req).unwrap();
    // The log after the device is destroyed (leaks included).
    rt.finish();
    let fresh = render(&scene, 320, 320, 0.0, &[Aov::Depth]);
    let (a, b) = (&grown.aov(Aov::Depth).unwrap().data, &fresh.aov(Aov::Depth).unwrap().data);
    assert!(a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()), "grown lists differ from fresh ones");
    assert!(a.iter().filter(|v| v.is_finite()).count() > 10_000);
    assert_eq!(grown.stats.counter(DROPPED), 0);
}

#[test]
fn plan_runs_metaballs_after_raster_and_before_the_wave() {
    let with_both = one_group_scene(
        "position = [0, 0, 10]\nlook_at = [0, 0, 0]",
        0.1,
        "{ centre = [0, 0, 0], radius = 2 }",
        true,
    );
    assert_eq!(plan(&with_both), vec!["raster", "metaballs", "energy_wave"]);
    let none = common::load("assets/scenes/single_cube.toml");
    assert!(!plan(&none).contains(&"metaballs"));
    let mut rt = common::runtime();
    rt.load_scene(common::load("assets/scenes/metaballs.toml")).unwrap();
    assert_eq!(rt.pass_names(), vec!["raster", "metaballs", "tonemap"]);
    // Loading built every pass: the log after the device is destroyed (leaks included).
    rt.finish();
}

/// Whether a ray provably misses `g`: the positive q of the balls whose support it crosses sum to
/// less than T (f ≤ 1), with a margin T − Σq⁺ far above the f32 field error (δ ≈ 10⁻⁵ here), so
/// neither f64 nor an f32 cast can find a root on it.
fn provable_miss(g: &MetaballGroupParams, o: DVec3, d: DVec3) -> bool {
    let ray = g.transform.ray_to_object(o, d);
    let reach: f64 = g
        .balls
        .iter()
        .filter(|b| {
            let oc = ray.origin - b.centre;
            let along = oc.dot(ray.dir);
            // The closest approach of the whole line (conservative: also behind the camera).
            oc.length_squared() - along * along < b.radius * b.radius
        })
        .map(|b| if b.q > 0.0 { b.q } else { 0.0 })
        .sum();
    reach < g.threshold - 0.1
}

/// More than MB_MAX_RAY_BALLS (32) supports along one ray. Forty balls staggered along the view
/// axis (at most 20 supports on any point), only the last six dense enough to make a surface: the
/// search goes on past the first 32 entries, round by round, and finds the surface the reference
/// finds. Forty concentric balls put 40 supports on every point of the blob, and fogs of 48 and
/// 500 faint balls (Σq = 0.35 < T: no surface of their own) put all their supports on every ray
/// through them (the camera inside them all) in front of two dense balls: no window of 32 slots
/// holds them, so those casts go on streamed from the tile's run — and every surface the
/// reference sees is found, none dropped. Pixels whose rays cross no dense ball's support are
/// provable misses (`provable_miss`) and must show nothing; the others are checked against the
/// f64 reference: all of them, except for the fog of 500, where a ray costs ~0.2 s (1,000
/// pieces of 500 chords): one pixel in four there (every other each way), ~90 surface pixels.
#[test]
fn more_than_32_supports_on_a_ray() {
    let staggered: Vec<String> = (0..40)
        .map(|i| {
            let q = if i < 34 { 0.02 } else { 1.5 };
            format!("{{ centre = [0, {:.3}, {:.3}], radius = 2, q = {q} }}", 0.02 * i as f64, -0.2 * i as f64)
        })
        .collect();
    let concentric: Vec<String> =
        (0..40).map(|_| "{ centre = [0, 0, 0], radius = 2, q = 0.03 }".to_string()).collect();
    let fog = |k: usize| -> Vec<String> {
        let mut rng = hadou::testing::Rng(0xf0_9f_09 + k as u64);
        let mut balls: Vec<String> = (0..k)
            .map(|_| {
                let c = rng.vec(-0.3, 0.3);
                let r = rng.range(2.0, 2.4);
                format!(
                    "{{ centre = [{:.4}, {:.4}, {:.4}], radius = {r:.4}, q = {:.6} }}",
                    c.x,
                    c.y,
                    c.z + 0.8,
                    0.35 / k as f64
                )
            })
            .collect();
        balls.push("{ centre = [-0.4, 0.1, -1.2], radius = 1.2, q = 1.4 }".into());
        balls.push("{ centre = [0.5, -0.2, -1.5], radius = 1.0, q = 1.1 }".into());
        balls
    };
    let close = "position = [0, 0, 3]\nlook_at = [0, 0, 0]";
    // Inside every support of the fog (its centres within 0.52 of (0, 0, 0.8), radii ≥ 2).
    let inside_fog = "position = [0.2, 0.3, 2.2]\nlook_at = [0, 0, -1.3]";
    // (label, camera, balls, reference hits at least: 156, 912, 372 and 373 of the 1,600 px
    // when written).
    let cases = [
        ("staggered", close, staggered, 120),
        ("concentric", close, concentric, 700),
        ("fog of 48", inside_fog, fog(48), 300),
        ("fog of 500", inside_fog, fog(500), 300),
    ];
    for (label, camera, balls, min_hits) in cases {
        let stride = if balls.len() > 100 { 2 } else { 1 };
        let min_hits = min_hits / (stride * stride);
        let scene = one_group_scene(camera, 0.1, &balls.join(", "), false);
        let (w, h) = (40u32, 40u32);
        let frame = render(&scene, w, h, 0.0, &[Aov::Depth]);
        let depth = &frame.aov(Aov::Depth).unwrap().data;
        let groups = groups_at(&scene, 0.0);
        let Tally { missed, sampled_hits, phantom, depth: depth_cmp, contract } =
            tally(&scene, &groups, depth, (w, h), stride, label);
        let (dropped, streamed) = (frame.stats.counter(DROPPED), frame.stats.counter(STREAMED));
        println!(
            "{label}: reference hits {sampled_hits}, missed {missed}, dropped {dropped}, streamed {streamed}"
        );
        assert_eq!((missed, dropped), (0, 0), "{label}: every surface checked is found, none dropped");
        phantom.assert_excluded_at_most(BAND_SHARE);
        phantom.assert_within(0.0, 0);
        depth_cmp.assert_within(1.0, min_hits);
        contract.assert_within(1e-4, min_hits);
        // The staggered balls never crowd one point; every other case must take the streamed path.
        assert_eq!(streamed == 0, label == "staggered", "{label}: {streamed} streamed casts");
    }
}

/// The sphere-tracing baseline in the pass (every group of assets/scenes/metaballs.toml with
/// method = "sphere_trace", 64 steps) against the exact f64 reference, where its f64 twin
/// (`metaballs_trace::trace`) says the method itself gets the exact answer. Left out (capped at
/// 5% of the pixels): band pixels; pixels where the twin misses the exact answer (runs out of
/// steps, or skips a sliver: hit/miss differ, or its depth lies beyond its own bracket bound,
/// `method_term`); pixels within 2⁻¹⁰ of tangency (where a sliver may be skipped, see
/// metaballs_trace.rs), and pixels whose twin needs so many of the 64 steps that the f32 march may run out (below).
/// Everywhere else the GPU must meet the f32 bounds with the trace's bracket (`f32_bound`).
#[test]
fn sphere_tracing_matches_its_f64_twin() {
    use hadou::effects::metaballs_trace::trace;
    let steps = 64;
    let mut scene = common::load("assets/scenes/metaballs.toml");
    scene.metaballs_mut().iter_mut().for_each(|g| g.method = CastMethod::SphereTrace { steps });
    let (w, h) = (96u32, 96u32);
    let frame = render(&scene, w, h, 0.0, &[Aov::Depth, Aov::Normal]);
    let raster = raster_only(&scene, w, h);
    let groups = groups_at(&scene, 0.0);
    // The f32 march differs from the twin's by rounding: each step |F − T|/L is off by ≤ δ/L
    // (δ = 16ε·(S + X·G), the band's f32 error, with S and G over all the group's balls and X to
    // the twin's hit), so 64 steps fall short by ≤ 64·δ/L: by ⌈64·δ/(2⁻¹⁰·T)⌉ least steps at most.
    // A hit whose twin needs more than 64 minus that (and one to spare) may run out on the GPU.
    // (Where the twin misses, running out changes nothing: both miss.)
    let spare = |g: &MetaballGroupParams, o: DVec3, d: DVec3, t_hit: f64| {
        let ray = g.transform.ray_to_object(o, d);
        let b_max = if g.kernel == Kernel::Wyvill6 { 104.0 / 45.0 } else { 1.6 };
        let s: f64 = g.threshold + g.balls.iter().map(|b| b.q.abs() * b_max).sum::<f64>();
        let gs: f64 = g.balls.iter().map(|b| b.q.abs() * g.kernel.max_slope() / b.radius).sum();
        let x = ray.origin.length() + t_hit * ray.t_scale;
        let delta = BAND_C * f64::from(f32::EPSILON) * (s + x * gs);
        (f64::from(steps) * delta / (TRACE_MIN_STEP * g.threshold)).ceil() as u32 + 1
    };
    let method_limited = std::cell::Cell::new(0usize);
    let leave_out = |o: DVec3, d: DVec3, t_min: f64, t_max: f64| {
        let limited = groups.iter().any(|g| {
            let tw = trace(g, o, d, t_min, t_max, steps);
            let exact = cast(g, o, d, t_min, t_max);
            let ts = g.transform.ray_to_object(o, d).t_scale;
            let depth_differs = match (tw.hit, exact) {
                // Beyond the trace's own bracket (object units, mapped to world) and f64 rounding.
                (Some(a), Some(b)) => {
                    (a.t - b.t).abs() > method_term(g, ts) / ts * (1.0 + 1e-9) + 1e-12 * b.t
                }
                (None, None) => false,
                _ => true,
            };
            tw.exhausted
                || tw.hit.is_some_and(|h| tw.steps + spare(g, o, d, h.t) > steps)
                || depth_differs
                || tangency(g, o, d, t_min, t_max).margin <= 2f64.powi(-10)
        });
        method_limited.set(method_limited.get() + usize::from(limited));
        limited
    };
    let images = (frame.aov(Aov::Depth).unwrap(), raster.aov(Aov::Depth).unwrap(), frame.aov(Aov::Normal));
    let c = check("sphere tracing (64 steps)", &scene, 0.0, images, leave_out);
    println!(
        "sphere tracing: {} method-limited px; {} px ran out of steps",
        method_limited.get(),
        frame.stats.counter(DROPPED)
    );
    // Left out: 191 of the 9,216 px when written (2%); 5% caps it. ~1,350 hits when written.
    c.assert(1000, 0.05);
    assert!(frame.stats.counter(HITS) > 1000);
}

/// The dense fluid of assets/scenes/metaballs_dense.toml at 48×48, its golden size: ~140 supports
/// on every point inside, tile runs of 1,520–2,720 balls (a crowded group: its long runs skip the
/// slot rounds), so most casts stream, gathering their chords from long runs in rounds. Every
/// surface the f64 reference finds (outside the band, capped) is found (its rim
/// pixels were missed while lavapipe's loop limit cut the streamed walks short, silently), at its
/// depth and normal; nothing dropped.
#[test]
fn dense_fluid_finds_every_surface() {
    let scene = hadou::scene::load_scene(std::path::Path::new("assets/scenes/metaballs_dense.toml")).unwrap();
    let (c, frame, _) = compare("dense fluid", &scene, 48, 48, 0.0);
    let (dropped, streamed) = (frame.stats.counter(DROPPED), frame.stats.counter(STREAMED));
    println!("dense fluid: dropped {dropped}, streamed {streamed}");
    assert!(streamed > 1000, "the fluid crowds its rays: {streamed} streamed");
    assert_eq!(dropped, 0, "every surface found");
    // 825 of the 2,304 px hit when written.
    c.assert(700, BAND_SHARE);
}

/// Past any work budget the pass is not silent: 100,000 concentric balls of q = 1.5/100,000 have
/// the field of one ball of q = 1.5 (the reference), and a ray through them walks a run of
/// 100,000 entries per streamed walk — on lavapipe, past the 65,535 loop iterations Mesa allows a
/// SIMD group. Every GPU hit is at the reference's depth, no GPU hit where it misses, and the
/// pixels where the reference hits but the GPU shows nothing are counted: `metaballs.dropped`
/// counts pixels too (one per pixel whose walk was cut, in each pass that cut it), so it is at
/// least their number. At least 50 surface pixels are accounted for either way (on lavapipe all
/// of them are dropped: the limit cuts every walk through the pile; a device without a loop limit
/// shows them all).
#[test]
fn a_surface_lost_past_the_loop_limit_is_counted_as_dropped() {
    const N: usize = 100_000;
    let camera = "position = [0, 0.5, 4.5]\nlook_at = [0, 0, 0]";
    let mut scene = one_group_scene(camera, 0.1, "{ centre = [0, 0, 0], radius = 2, q = 1.5 }", false);
    let single = groups_at(&scene, 0.0);
    let mut ball = scene.metaballs()[0].balls[0];
    ball.q /= N as f64;
    scene.metaballs_mut()[0].balls = vec![ball; N];
    let (w, h) = (16u32, 16u32);
    let frame = render(&scene, w, h, 0.0, &[Aov::Depth]);
    let depth = &frame.aov(Aov::Depth).unwrap().data;
    let Tally { missed, sampled_hits, phantom, depth: _, contract } =
        tally(&scene, &single, depth, (w, h), 1, "100,000 concentric balls");
    let dropped = frame.stats.counter(DROPPED);
    println!("{N} concentric balls: reference hits {sampled_hits}, missed {missed}, dropped {dropped}");
    assert!(missed <= dropped, "{missed} surface pixels missed, only {dropped} pixels counted as dropped");
    phantom.assert_excluded_at_most(BAND_SHARE);
    phantom.assert_within(0.0, 0);
    // Σ of 100,000 equal f32 terms: relative error ≤ n·ε_f32 ≈ 6e-3 of the field, which moves the
    // root by at most that over the field's slope near the surface (≥ the threshold per unit
    // radius here): 1e-2 relative.
    contract.assert_within(1e-2, 0);
    assert!(sampled_hits > 50, "the pile must cover the frame: {sampled_hits} surface pixels");
}

/// A group far from the origin, seen from nearby: its transform carries it 10⁴ and 10⁵ units
/// out and the camera sits a few units from it, so every world coordinate is large while the
/// object space the cast works in is not. The f32 error model (`f32_bound`) knows only object
/// space: it holds because the group's matrices are composed with the camera's position in f64
/// (`gpu_group`); composed in f32 on the device, the camera's object-space position lost ~ε·10⁴
/// and the depth broke its bound 33-fold at 10⁴. The device's tile lists (`Binning::Device`,
/// sphere bounds in f32) give every byte the host's do. A group whose balls are given in world
/// coordinates that far out holds the same bound: the ball table keeps them relative to the
/// group's first ball (`metaballs_f32::anchor`), where held as they were the tangency band took
/// 2.7 % of the pixels at 10⁴, over `BAND_SHARE`.
#[test]
fn far_from_the_origin_a_group_keeps_its_bound() {
    use hadou::effect::{Binning, Effects, Metaballs};
    // (x, the group placed by its transform, else its balls' own centres are world coordinates).
    for (x, by_transform) in [(1.0e4, true), (1.0e5, true), (1.0e4, false), (1.0e5, false)] {
        let (transform, balls) = if by_transform {
            (
                format!("transform = [{{ rotate = {{ angle_deg = 35, axis = [0.2, 1, 0.3] }} }}, {{ translate = [{x}, 0, {z}] }}]", z = -x),
                "{ centre = [0, 0, 0], radius = 1.6 }, { centre = [1.1, 0.4, 0.2], radius = 1.2 }, { centre = [-0.9, -0.3, 0.5], radius = 1.1 }".to_string(),
            )
        } else {
            let ball = |c: [f64; 3], r: f64| {
                format!("{{ centre = [{}, {}, {}], radius = {r} }}", x + c[0], c[1], c[2] - x)
            };
            (
                String::new(),
                [ball([0.0, 0.0, 0.0], 1.6), ball([1.1, 0.4, 0.2], 1.2), ball([-0.9, -0.3, 0.5], 1.1)]
                    .join(", "),
            )
        };
        let scene = common::parse(&format!(
            r#"
            [camera]
            position = [{cx}, 1.5, {cz}]
            look_at = [{x}, 0.2, {z}]
            fov_y_deg = 45
            near = 0.1
            far = 100
            [[light]]
            direction = [-1, -2, -1]
            [[metaballs]]
            {transform}
            balls = [{balls}]
            "#,
            cx = x + 1.0,
            cz = -x + 6.0,
            z = -x,
        ));
        let label = format!("group at {x}{}", if by_transform { "" } else { ", world-space balls" });
        let (c, frame, _) = compare(&label, &scene, 48, 48, 0.0);
        // 379 reference hits of the 2,304 pixels when written.
        c.assert(300, BAND_SHARE);
        assert_eq!(frame.stats.counter(DROPPED), 0);
        let effects = Effects::none().with(Metaballs::with_binning(Binning::Device)).unwrap();
        let mut rt = common::runtime_with_effects(effects);
        rt.load_scene(scene.clone()).unwrap();
        let mut req = FrameRequest::new(48, 48);
        req.aovs = vec![Aov::Depth, Aov::Normal];
        let device = rt.render(&req).unwrap();
        common::assert_clean(&rt);
        for aov in [Aov::Depth, Aov::Normal] {
            let bits =
                |f: &FrameOutput| f.aov(aov).unwrap().data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&frame), bits(&device), "{label}: {aov:?} with the device's tile lists");
        }
    }
}
