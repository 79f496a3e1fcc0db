//! `thickness = "peel"` (the peel pass and the translucency pass's peel branch) vs its f64 twin
//! (`effects::peel::PeelTwin`) and vs the exact thickness, on lavapipe with validation and
//! synchronization validation on; overflow of a texel's list; meshes deformed across frames in
//! flight; scenes with peel materials and nothing to draw.
//!
//! # The tolerance against the twin
//!
//! The twin casts, in f64, the same ray the GPU rasterized: the light ray through the centre of
//! P's light-map texel. The GPU's value differs by:
//! - **the crossings' depths**: each is the light-space z of the vertices (f32: the model matrix,
//!   the view's dot products, |z| ≤ 2R) interpolated at the texel centre. The rasterizer snaps
//!   vertices to its sub-pixel grid (lavapipe: 8 bits, 1/256 texel), so the interpolated plane is
//!   that of a triangle moved by up to 1/512 texel: z moves by that times the surface's slope seen
//!   from the light, tan θ (θ between its normal and the light). With the f32 terms
//!   (~16·2⁻²⁴·(|C| + 2R) per crossing, two crossings per interval end) the per-pixel bound is
//!   `EPS_DEPTH`·(|C| + 2R) + (texel/512)·tan θ per crossing; with tan θ ≤ 8 (83°) for all but the
//!   rims, we assert |GPU − twin| ≤ 1e-5·(|C| + 2R) + 2 · 8 · texel/512 on all but a small fraction
//!   of the pixels;
//! - **the texel itself**: P comes from the raster's f32 distance, its light-space (x, y) from f32
//!   dot products: within ~1e-6·(|C| + 2R) of a texel edge the GPU may pick the neighbour. And at
//!   rims (the texel centre's ray grazing a surface: tan θ → ∞) the rasterizer and the f64 cast
//!   may disagree on whether the ray crosses at all; the interval in question is then at most the
//!   chord of a ray grazing within 1/512 texel — but a rim of one instance can also be hit or
//!   missed by the neighbour texel. So every pixel must lie within the **envelope** of the twin over
//!   its texel's 3×3 block (± the bound), and at most `OFF_TEXEL_FRACTION` of them outside the
//!   bound of their own texel.
//!
//! # Against the exact thickness (P's own light ray)
//!
//! That is the method's error, not the GPU's: the texel centre's ray runs up to (√2/2) texel
//! beside P's, texels are ≤ ¼ voxel of the material's `voxel_res` (light_map_size), so on smooth
//! parts the error is ≤ 0.35 texel × slope; at rims whole intervals differ. Asserted: p95 ≤ ¼
//! voxel on the hollow shapes, ≤ ½ voxel on the seed's three objects (the bottle's glass is 1.4
//! voxels thin); the maxima (rims, 1–2.5 voxels) are printed.

mod common;

use common::host::Host;
use glam::{DVec3, Vec3};
use hadou::effects::peel::{PeelThickness, PeelTwin};
use hadou::passes::peel;
use hadou::scene::mesh::Mesh;
use hadou::scene::transform::{Transform, TransformOp};
use hadou::scene::{Scene, ThicknessMode};
use hadou::testing::Comparison;
use hadou::{Aov, Error, FrameInputs, FrameRequest, Renderer, RendererOptions, Runtime};
use hadou_cli::report::translucency::{
    self as report, abs_stats as stats, with_thickness, Sample, SampleSet,
};

/// Relative f32 term of the bound (module docs), times |C| + 2R.
const EPS_DEPTH: f64 = 1e-5;
/// Pixels allowed outside the bound of their own texel, within the envelope of their 3×3 block:
/// texel-edge ties (P within ~1e-6·(|C| + 2R) ≤ 5e-6 of an edge, on texels ≥ 4e-3: ≤ 4·1.25e-3 of
/// the pixels for the four edges) and as much again for rims: 1 %.
const OFF_TEXEL_FRACTION: f64 = 0.01;

struct Frame {
    thickness: Vec<f32>,
    depth: Vec<f32>,
    stats: hadou::frame::FrameStats,
}

fn render_with(rt: &mut Runtime, w: u32, h: u32) -> Frame {
    let mut request = FrameRequest::new(w, h);
    request.color = false;
    request.aovs = vec![Aov::Depth, Aov::Thickness];
    let frame = rt.render(&request).unwrap();
    common::assert_clean(rt);
    Frame {
        thickness: frame.aov(Aov::Thickness).unwrap().data.clone(),
        depth: frame.aov(Aov::Depth).unwrap().data.clone(),
        stats: frame.stats,
    }
}

fn render(scene: &Scene, w: u32, h: u32) -> Frame {
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    assert_eq!(rt.pass_names(), ["raster", "light_id", "peel", "translucency", "tonemap"]);
    render_with(&mut rt, w, h)
}

const BACK_LIT: &str = r#"
    [render]
    background = [0, 0, 0]
    [camera]
    position = [0, 0, 6]
    look_at = [0, 0, 0]
    fov_y_deg = 28
    [[light]]
    kind = "directional"
    direction = [0.1, -0.2, 1]
    intensity = 3
    [[mesh]]
    name = "ball"
    kind = "hollow_ball"
    radius = 1
    cavity_radius = 0.24
    segments = 48
    rings = 24
    [[mesh]]
    name = "box"
    kind = "cube"
    size = 1.6
    [[material]]
    name = "wax"
    kind = "translucent"
    albedo = [0.9, 0.75, 0.55]
    sigma = [0.7, 1.6, 2.8]
    thickness = "peel"
    voxel_res = 24
    [[instance]]
    mesh = "MESH"
    material = "wax"
"#;

/// A box of edge 1.6 with a box cavity of edge 0.7 (inward faces), not centred.
fn box_with_box_cavity() -> Mesh {
    let mut outer = hadou::scene::procedural::cube(1.6).unwrap();
    let inner = hadou::scene::procedural::cube(0.7).unwrap();
    let base = outer.positions.len() as u32;
    outer.positions.extend(inner.positions.iter().map(|p| [p[0] + 0.2, p[1] - 0.1, p[2] + 0.15]));
    outer.normals.extend(inner.normals.iter().map(|n| n.map(|c| -c)));
    outer.indices.extend(inner.indices.chunks_exact(3).flat_map(|t| [t[0] + base, t[2] + base, t[1] + base]));
    outer.check_closed_oriented().unwrap();
    outer
}

fn scene_of(mesh: &str, ops: Vec<TransformOp>) -> Scene {
    let mut scene = common::parse(&BACK_LIT.replace("MESH", if mesh == "ball" { "ball" } else { "box" }));
    if mesh == "box cavity" {
        let box_mesh = scene.meshes.iter().position(|m| m.name == "box").unwrap();
        scene.meshes[box_mesh].mesh = box_with_box_cavity();
    }
    scene.instances[0].transform = Transform::from_ops(&ops).unwrap();
    scene.instances[0].ops = ops;
    scene
}

fn rot(angle_deg: f64, axis: [f64; 3]) -> TransformOp {
    TransformOp::Rotate { angle_deg, axis: DVec3::from_array(axis) }
}

fn scale(s: [f64; 3]) -> TransformOp {
    TransformOp::Scale(DVec3::from_array(s))
}

fn inside(t: PeelThickness) -> f64 {
    match t {
        PeelThickness::Inside(d) => d,
        PeelThickness::Overflow => panic!("no list overflows in these scenes"),
    }
}

/// The translucent pixels of a frame (`report::translucency::sample_set`), at most
/// `MAX_SKIPPED_SHARE` of them left out, at least an eighth of the frame compared: every scene
/// here puts its objects over more than that (the ball alone covers ≈ π·0.67²/4 ≈ 0.35 of it).
fn sample_set(scene: &Scene, (w, h): (u32, u32), thickness: &[f32], depth: &[f32]) -> SampleSet {
    let set = report::sample_set(scene, (w, h), thickness, depth).unwrap();
    set.assert_usable((w * h / 8) as usize);
    set
}

/// GPU vs twin (and vs exact) for one scene; returns (pixels, p95 vs exact in voxels).
fn compare(label: &str, scene: &Scene) -> (usize, f64) {
    let (w, h) = (256, 256);
    let frame = render(scene, w, h);
    assert_eq!(frame.stats.counter(peel::OVERFLOWED), 0, "{label}");
    compare_frame(label, scene, (w, h), &frame.thickness, &frame.depth)
}

/// GPU vs twin (and vs exact) for one frame's thickness and depth (module docs); returns (pixels,
/// p95 vs exact in voxels).
fn compare_frame(
    label: &str,
    scene: &Scene,
    size: (u32, u32),
    thickness: &[f32],
    depth: &[f32],
) -> (usize, f64) {
    let twin = PeelTwin::new(scene).unwrap().unwrap();
    let samples = sample_set(scene, size, thickness, depth).samples;
    let v = &twin.view;
    let texel = 2.0 * v.radius / twin.size as f64;
    let eps = EPS_DEPTH * (v.centre.length() + 2.0 * v.radius);
    let bound = eps + 2.0 * 8.0 * texel / 512.0;
    let voxel_of = |i: usize| report::world_voxel(scene, i).unwrap();
    let voxel = voxel_of(samples[0].instance);
    // Every pixel within the bound of its own texel but the off-texel ones (excluded, capped), and
    // those within the bound of their block's envelope.
    let mut own = Comparison::new(format!("{label}: GPU vs twin, own texel"));
    let mut envelope =
        Comparison::new(format!("{label}: GPU vs twin, off-texel pixels vs their 3×3 envelope"));
    let mut exact_err = Vec::new();
    for s in &samples {
        let ((tx, ty), zp) = twin.texel_of(s.point);
        let own_twin = inside(twin.thickness_in_texel((tx, ty), s.instance, zp));
        let err = (s.gpu - own_twin).abs();
        exact_err.push((s.gpu - s.exact) / voxel_of(s.instance));
        // A NaN is not > bound: it is compared (and fails), never excluded.
        if err.is_nan() || err <= bound {
            own.error(format_args!("pixel {}: GPU {}, twin {own_twin}", s.pixel, s.gpu), err);
            continue;
        }
        own.exclude();
        let last = twin.size as i64 - 1;
        let block: Vec<f64> = (-1..=1)
            .flat_map(|dy| (-1..=1).map(move |dx| (dx, dy)))
            .map(|(dx, dy)| ((tx as i64 + dx).clamp(0, last) as u32, (ty as i64 + dy).clamp(0, last) as u32))
            .map(|t| inside(twin.thickness_in_texel(t, s.instance, zp)))
            .collect();
        // total_cmp orders a NaN above everything: it would be `hi` and fail below.
        let lo = *block.iter().min_by(|a, b| a.total_cmp(b)).unwrap();
        let hi = *block.iter().max_by(|a, b| a.total_cmp(b)).unwrap();
        let outside = if s.gpu < lo {
            lo - s.gpu
        } else if s.gpu > hi {
            s.gpu - hi
        } else if lo.is_finite() && hi.is_finite() {
            0.0
        } else {
            f64::NAN
        };
        envelope.error(
            format_args!("pixel {}: GPU {} vs [{lo}, {hi}] (own texel {own_twin})", s.pixel, s.gpu),
            outside,
        );
    }
    let (em, ep, ex) = stats(exact_err);
    println!(
        "{label}: {}² map (texel {texel:.5}, voxel {voxel:.4} of the first), bound {bound:.2e}; vs exact mean {em:.3}, p95 {ep:.3}, max {ex:.2} voxels",
        twin.size
    );
    own.assert_within(bound, samples.len() / 2);
    own.assert_excluded_at_most(OFF_TEXEL_FRACTION);
    // Zero off-texel pixels is the usual case: no floor.
    envelope.assert_within(bound, 0);
    assert!(ex.is_finite(), "{label}: a non-finite thickness error vs exact");
    (samples.len(), ep)
}

#[test]
fn peel_matches_its_twin_on_hollow_shapes_under_any_transform() {
    let transforms = [
        ("rotated", vec![rot(80.0, [1.0, 0.0, 0.0]), rot(15.0, [0.0, 1.0, 0.0])]),
        ("non-uniform", vec![scale([1.2, 0.8, 1.1]), rot(75.0, [1.0, 0.3, 0.0])]),
        ("mirrored", vec![scale([-1.1, 0.9, 1.0]), rot(70.0, [1.0, -0.2, 0.1])]),
    ];
    for mesh in ["ball", "box cavity"] {
        for (name, ops) in &transforms {
            let (_, p95) = compare(&format!("{mesh}, {name}"), &scene_of(mesh, ops.clone()));
            assert!(p95 <= 0.25, "{mesh}, {name}: p95 {p95:.3} voxels vs exact");
        }
    }
}

/// The seed's three objects (assets/scenes/translucency.toml: cavity cube, torus, bottle with
/// liquid) drawn with peel: the twin's bound as above, and against the exact thickness p95 ≤ ½
/// voxel over all of them (the LUT's target is 1 voxel); the bottle's glass is 1.4 voxels thin,
/// where the half-texel offset of the texel's ray matters most.
#[test]
fn seed_objects_with_peel() {
    let scene = with_thickness(common::load("assets/scenes/translucency.toml"), ThicknessMode::Peel);
    let (_, p95) = compare("seed objects", &scene);
    assert!(p95 <= 0.5, "p95 {p95:.3} voxels vs exact");
}

/// The light crosses the hollow ball's two cavities: peel leaves them out as the exact thickness
/// does, TSM counts them (a whole cavity diameter on the paths through its centre).
#[test]
fn cavities_drop_out_where_tsm_counts_them() {
    let scene = scene_of("ball", vec![rot(90.0, [1.0, 0.0, 0.0])]);
    let (w, h) = (160, 160);
    let peel_frame = render(&scene, w, h);
    // Outer shell and both cavities along the light: lists of 6, more than K/2, so reported.
    assert_eq!(peel_frame.stats.counter(peel::LONGEST), 6);
    assert_eq!(peel_frame.stats.counter(peel::OVERFLOWED), 0);
    let samples = sample_set(&scene, (w, h), &peel_frame.thickness, &peel_frame.depth).samples;
    let voxel = report::world_voxel(&scene, 0).unwrap();
    // TSM − exact is the air on P's light path (both f64, from the same crossings: 0 to 1e-12
    // elsewhere); 0.2 (2.4 voxels, 0.4 of a cavity's diameter 0.48) picks the paths through the
    // cavities rather than past their rims. A selection only: the floor keeps it from emptying.
    let through: Vec<&Sample> = samples.iter().filter(|s| s.tsm - s.exact > 0.2).collect();
    assert!(through.len() > 200, "only {} pixels see the light through a cavity", through.len());
    let (m, p95, max) = stats(through.iter().map(|s| (s.gpu - s.exact) / voxel));
    println!(
        "{} pixels through the cavities: peel vs exact mean {m:.3}, p95 {p95:.3}, max {max:.2} voxels",
        through.len()
    );
    assert!(p95 <= 0.25, "p95 {p95}");
}

/// Two peel boxes one behind the other along the light: the front one (seen by the camera) is lit
/// through the back one, whose material does not count (only the pixel's own instance's
/// intervals), as in the twin and the exact per-instance thickness.
#[test]
fn other_instances_in_front_do_not_count() {
    let base =
        BACK_LIT.replace("MESH", "box").replace("direction = [0.1, -0.2, 1]", "direction = [0.05, -0.1, 1]");
    let mut text = base.replace("[[instance]]\n    mesh = \"box\"\n    material = \"wax\"\n", "");
    for (z, turn) in [(-1.2, 20.0), (0.6, -15.0)] {
        text += &format!(
            "[[instance]]\nmesh = \"box\"\nmaterial = \"wax\"\ntransform = [{{ rotate = {{ angle_deg = {turn}, axis = [0.3, 1, 0.2] }} }}, {{ scale = [0.9, 0.9, 0.5] }}, {{ translate = [0, 0, {z}] }}]\n"
        );
    }
    let scene = common::parse(&text);
    let (_, p95) = compare("two boxes along the light", &scene);
    assert!(p95 <= 0.25, "p95 {p95:.3} voxels vs exact");
}

/// Five boxes in a row along the light: 10 crossings per texel through all of them, more than
/// PEEL_K = 8 — as five instances, and as one mesh of five boxes. The overflow is counted, and
/// those pixels get exactly TSM's thickness.
#[test]
fn overflowing_lists_are_counted_and_fall_back_to_tsm() {
    let base = BACK_LIT.replace("MESH", "box").replace("direction = [0.1, -0.2, 1]", "direction = [0, 0, 1]");
    let mut instances = base.replace("[[instance]]\n    mesh = \"box\"\n    material = \"wax\"\n", "");
    for k in 0..5 {
        let z = -2.0 + k as f64;
        instances += &format!(
            "[[instance]]\nmesh = \"box\"\nmaterial = \"wax\"\ntransform = [{{ scale = [0.3, 0.3, 0.3] }}, {{ translate = [0.12, 0.05, {z}] }}]\n"
        );
    }
    let mut one_mesh = common::parse(&base);
    let stack = |m: &hadou::scene::mesh::Mesh| {
        let mut out = Mesh::default();
        for k in 0..5 {
            let first = out.positions.len() as u32;
            let z = (-2.0 + k as f32) / 0.3;
            out.positions.extend(m.positions.iter().map(|p| [p[0] + 0.4, p[1] + 0.17, p[2] + z]));
            out.normals.extend_from_slice(&m.normals);
            out.indices.extend(m.indices.iter().map(|i| i + first));
        }
        out
    };
    let b = one_mesh.meshes.iter().position(|m| m.name == "box").unwrap();
    one_mesh.meshes[b].mesh = stack(&one_mesh.meshes[b].mesh);
    let ops = vec![scale([0.3, 0.3, 0.3])];
    one_mesh.instances[0].transform = Transform::from_ops(&ops).unwrap();
    one_mesh.instances[0].ops = ops;
    for (label, scene) in [("five instances", common::parse(&instances)), ("one mesh", one_mesh)] {
        let (w, h) = (128, 128);
        let frame = render(&scene, w, h);
        let overflowed = frame.stats.counter(peel::OVERFLOWED);
        println!(
            "{label}: overflowed texels {overflowed}, longest list {}, texels with crossings {}",
            frame.stats.counter(peel::LONGEST),
            frame.stats.counter(peel::TEXELS)
        );
        assert!(overflowed > 100, "{label}: {overflowed}");
        assert_eq!(frame.stats.counter(peel::LONGEST), 10, "{label}");
        let tsm = render_tsm(&scene, w, h);
        let twin = PeelTwin::new(&scene).unwrap().unwrap();
        let samples = report::sample_set(&scene, (w, h), &frame.thickness, &frame.depth).unwrap();
        // The front box alone, 0.48 wide 4 units away, spans ≈ 0.24 of the frame's height (≈ 1/17
        // of its pixels): half of that is the floor.
        samples.assert_usable((w * h / 34) as usize);
        let mut fell_back = 0;
        for s in &samples.samples {
            if twin.thickness(s.instance, s.point) == PeelThickness::Overflow {
                fell_back += 1;
                assert_eq!(s.gpu as f32, tsm[s.pixel], "{label}: pixel {}: peel vs tsm", s.pixel);
            }
        }
        assert!(fell_back > 100, "{label}: {fell_back} pixels fell back");
    }
}

fn render_tsm(scene: &Scene, w: u32, h: u32) -> Vec<f32> {
    let mut rt = common::runtime();
    rt.load_scene(with_thickness(scene.clone(), ThicknessMode::Tsm)).unwrap();
    render_with(&mut rt, w, h).thickness
}

/// A mesh deformed every frame with two frames in flight, driven as a game does (its own command
/// buffers, tests/common/host.rs): every frame's thickness and depth are read back and equal, bit
/// for bit, the shape it was recorded with loaded as a scene and rendered alone, and match that
/// shape's twin (`compare_frame`); consecutive shapes differ on most pixels, so a frame showing
/// another frame's shape fails. hadou never waits; bad updates are typed errors that change
/// nothing; validation silent, nothing leaked (checked after the device is destroyed).
#[test]
fn deformed_meshes_are_followed_across_frames_in_flight() {
    let scene = scene_of("ball", vec![rot(80.0, [1.0, 0.0, 0.0])]);
    let original: Vec<Vec3> = scene.meshes[0].mesh.positions.iter().map(|p| Vec3::from(*p)).collect();
    let shape = |k: usize| -> Vec<Vec3> {
        let s = 1.0 + 0.08 * k as f32;
        original.iter().map(|p| Vec3::new(p.x * s, p.y / s, p.z + 0.1 * (k as f32) * p.x * p.x)).collect()
    };
    // Shape k loaded from the start.
    let still = |k: usize| {
        let mut still = scene.clone();
        let mesh = &mut still.meshes[0].mesh;
        mesh.positions = shape(k).iter().map(|p| p.to_array()).collect();
        mesh.normals = hadou::renderer::vertex_normals(&mesh.positions, &mesh.indices, &mesh.normals);
        still
    };
    let (_leaks, ctx) = common::context();
    let mut host = Host::new(&ctx, 2);
    let mut hadou = Renderer::with_options(ctx, &RendererOptions::default()).unwrap();
    hadou.load_scene(scene.clone()).unwrap();
    let (w, h) = (128, 128);
    let inputs = FrameInputs::headless(w, h, 0.0);
    hadou.prepare(&inputs).unwrap();
    let waits = hadou.context().host_waits();
    let mut frames = Vec::new();
    for k in 0..6 {
        hadou.set_mesh_positions("ball", &shape(k)).unwrap();
        let slot = k % 2;
        let cmd = host.begin(slot);
        hadou.record_frame(cmd, &inputs).unwrap();
        frames.push(hadou.record_aov_readback(cmd, &[Aov::Thickness, Aov::Depth]).unwrap());
        host.submit(slot);
    }
    assert_eq!(hadou.context().host_waits(), waits, "deforming a mesh waited");
    host.wait_all();
    let mut previous: Option<Vec<f32>> = None;
    for (k, readback) in frames.iter().enumerate() {
        let reference = still(k);
        let thickness = readback.aov(Aov::Thickness).unwrap().data;
        let depth = readback.aov(Aov::Depth).unwrap().data;
        let alone = render(&reference, w, h);
        let differ =
            thickness.iter().zip(&alone.thickness).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
        assert_eq!(differ, 0, "frame {k}: {differ} pixels differ from its shape rendered alone");
        let (pixels, _) =
            compare_frame(&format!("frame {k} in flight"), &reference, (w, h), &thickness, &depth);
        // Each shape moves the thickness on most of the ball's pixels (it is 8 % wider each frame).
        if let Some(previous) = previous {
            let changed = thickness.iter().zip(&previous).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
            println!("frame {k}: {changed} pixels changed from frame {}", k - 1);
            assert!(changed * 2 > pixels, "frame {k}: only {changed} pixels changed from frame {}", k - 1);
        }
        previous = Some(thickness);
    }
    assert_eq!(hadou.scene().unwrap().meshes[0].mesh.positions, still(5).meshes[0].mesh.positions);

    // Refusals change nothing.
    let before = hadou.scene().unwrap().meshes[0].mesh.clone();
    assert!(matches!(hadou.set_mesh_positions("nope", &shape(1)), Err(Error::InvalidUpdate { .. })));
    assert!(matches!(hadou.set_mesh_positions("ball", &shape(1)[1..]), Err(Error::InvalidUpdate { .. })));
    let mut bad = shape(1);
    bad[3].x = f32::NAN;
    assert!(matches!(hadou.set_mesh_positions("ball", &bad), Err(Error::InvalidUpdate { .. })));
    assert_eq!(hadou.scene().unwrap().meshes[0].mesh, before);
    // A mesh drawn with a LUT material is refused (its table is of the loaded shape).
    hadou.load_scene(with_thickness(scene.clone(), ThicknessMode::Lut)).unwrap();
    let err = hadou.set_mesh_positions("ball", &shape(1)).unwrap_err().to_string();
    assert!(err.contains("lut"), "{err}");
    drop(frames);
    host.destroy();
    drop(hadou);
}

/// `[[mesh]] wobble`: the scene's own deformation at a frame's time, followed by peel exactly as
/// a game's `set_mesh_positions` (the same thickness as that shape loaded still, and its twin).
#[test]
fn a_wobbling_mesh_is_followed_at_the_frame_time() {
    let text = BACK_LIT
        .replace("MESH", "ball")
        .replace("rings = 24\n", "rings = 24\n    wobble = 0.06\n    wobble_hz = 0.5\n");
    let mut scene = common::parse(&text);
    assert!(scene.meshes[0].wobble.is_some());
    let ops = vec![rot(80.0, [1.0, 0.0, 0.0])];
    scene.instances[0].transform = Transform::from_ops(&ops).unwrap();
    scene.instances[0].ops = ops;
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let (w, h) = (128, 128);
    let mut request = FrameRequest::new(w, h);
    request.color = false;
    request.aovs = vec![Aov::Thickness];
    request.time = 0.5;
    let wobbled = rt.render(&request).unwrap().aov(Aov::Thickness).unwrap().data.clone();
    common::assert_clean(&rt);
    let mut still = rt.scene().unwrap().clone();
    assert_ne!(still.meshes[0].mesh.positions, scene.meshes[0].mesh.positions);
    still.meshes[0].wobble = None;
    assert!(wobbled.iter().zip(&render(&still, w, h).thickness).all(|(a, b)| a.to_bits() == b.to_bits()));
    compare("wobbled ball", &still);
    // Back at rest at time 0.
    request.time = 0.0;
    let rest = rt.render(&request).unwrap().aov(Aov::Thickness).unwrap().data.clone();
    assert!(rest.iter().zip(&render(&scene, w, h).thickness).all(|(a, b)| a.to_bits() == b.to_bits()));
    // The frames after the last mid-test check: destroyed and the log checked here (leaks too).
    rt.finish();
}

/// A living world: a peel instance spawned into a scene without one brings the peel pass (and
/// the translucency pass's peel variant) in, its despawn takes them out; frames in flight,
/// validation silent.
#[test]
fn spawning_a_peel_instance_brings_the_pass_in_and_out() {
    let text = BACK_LIT.replace("MESH", "ball").replace(
        "[[instance]]",
        "[[material]]\n    name = \"jade\"\n    kind = \"translucent\"\n    sigma = [1, 1, 1]\n    thickness = \"tsm\"\n    [[instance]]",
    );
    let mut scene = common::parse(&text.replace("material = \"wax\"", "material = \"jade\""));
    scene.instances[0].transform = Transform::from_ops(&[TransformOp::Translate(DVec3::X)]).unwrap();
    let mut rt = common::runtime();
    rt.load_scene(scene).unwrap();
    assert_eq!(rt.pass_names(), ["raster", "light_id", "translucency", "tonemap"]);
    let request = FrameRequest::new(64, 64);
    rt.submit(&request).unwrap();
    let id = rt.renderer().spawn_instance("ball", "wax", glam::DMat4::from_translation(-DVec3::X)).unwrap();
    assert_eq!(rt.pass_names(), ["raster", "light_id", "peel", "translucency", "tonemap"]);
    rt.submit(&request).unwrap();
    rt.submit(&request).unwrap();
    rt.renderer().despawn_instance(id).unwrap();
    assert_eq!(rt.pass_names(), ["raster", "light_id", "translucency", "tonemap"]);
    rt.submit(&request).unwrap();
    rt.wait_all().unwrap();
    common::assert_clean(&rt);
}

/// A device without fragmentStoresAndAtomics (a game that did not enable it): loading a peel
/// scene is an error naming the feature, and the renderer keeps working for other scenes.
#[test]
fn peel_without_the_feature_is_a_named_error() {
    let (_leaks, mut ctx) = common::context();
    ctx.fragment_stores_and_atomics = false;
    let log = ctx.validation_log();
    let mut renderer = hadou::Renderer::new(ctx).unwrap();
    let err = renderer.load_scene(scene_of("ball", vec![])).unwrap_err().to_string();
    assert!(err.contains("fragmentStoresAndAtomics"), "{err}");
    renderer.load_scene(with_thickness(scene_of("ball", vec![]), ThicknessMode::Tsm)).unwrap();
    drop(renderer);
    common::assert_log_clean(&log, "after the refused scene");
}

/// Peel materials with nothing to draw: no peel pass, no lists; a peel instance without a light
/// adds nothing.
#[test]
fn peel_with_no_instances_or_no_light() {
    let mut rt = common::runtime();
    let mut empty = scene_of("ball", vec![]);
    empty.instances.clear();
    rt.load_scene(empty).unwrap();
    assert_eq!(rt.pass_names(), ["raster", "tonemap"]);
    assert!(!rt.renderer().produces(hadou::targets::Target::PeelLists));
    let frame = rt.render(&FrameRequest::new(32, 32)).unwrap();
    assert_eq!(frame.stats.counter(peel::TEXELS), 0);
    common::assert_clean(&rt);

    let mut dark = scene_of("ball", vec![]);
    dark.lights.clear();
    let frame = render(&dark, 64, 64);
    assert!(frame.thickness.iter().all(|&d| d == f32::INFINITY));
    assert_eq!(frame.stats.counter(peel::TEXELS), 0);
}
