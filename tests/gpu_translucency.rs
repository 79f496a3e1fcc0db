//! The light_id and translucency passes (seed 003) vs the CPU f64 references on lavapipe, with
//! validation on.
//!
//! The GPU thickness (the `thickness` AOV) is compared with `exact_thickness`: the length of
//! material on the ray from the shaded point toward the light, cast on the mesh in f64, with the
//! shaded point placed by the GPU's own depth (so only the thickness is compared, not the
//! raster). Errors are reported in voxel edges of the instance: the object voxel edge h times
//! ∛|det M| (the edge of a world cube of a voxel's transformed volume). `HADOU_TEST_DUMP=1` writes
//! error and colour images to /tmp.
//!
//! Where the LUT is worst: paths that graze a surface (the light tangent to the torus's inner
//! rim, the bottle's walls seen edge-on, a cavity's rim), where moving an end by a fraction of a
//! voxel adds or removes a long stretch of material (the seed's own discretization error). They
//! set the maxima printed (up to ~13 voxels on the torus) while the 95th percentiles stay under
//! a voxel.
//!
//! # The colour bound
//!
//! The pass adds T = w·L·a·exp(−σ·d) per channel (L the light's radiance, a the albedo, w the exit
//! weight max(n·l, 0) from the G-buffer normal the pass reads, which the test reads back too: the
//! same f16 values, so w differs only by f32 rounding of one dot product, inside the 1e-5 term). The test
//! isolates it as HDR(translucent) − HDR(the same scene with lambert materials): the raster's
//! surface term is the same in both. Against the f64 T with the exact thickness d*:
//! - thickness: |e^{−σd} − e^{−σd*}| ≤ σ·|d − d*|·e^{−σ·min(d, d*)} (mean value theorem);
//! - HDR is RGBA16F: each of the two values is within one f16 step, 2⁻¹⁰ of itself (Vulkan lets a
//!   store round to nearest or toward zero; lavapipe truncates), and values below 2⁻¹⁴ (subnormal
//!   f16) within 2⁻²⁴ absolutely;
//! - f32 arithmetic (radiance, albedo, σ, exp): ~1e-6 relative, 1e-5·L·a covers it.
//!
//! so per pixel and channel |ΔT| ≤ L·a·σ·|d − d*|·e^{−σ·min(d, d*)} + 2⁻¹⁰·(|H₁| + |H₀|) + 2⁻²³ +
//! 1e-5·L·a, asserted for every translucent pixel with the GPU's own d. With |d − d*| ≤ one voxel
//! edge h_w (the thickness bound, at the 95th percentile), the 95th percentile of |ΔT| is at most
//! max over channels of L·a·σ·h_w (the exponential is ≤ 1) plus the rounding terms; asserted too.

mod common;

use glam::DVec3;
use hadou::effects::raycast::SceneCaster;
use hadou::effects::translucency::{exit_weight, transmitted};
use hadou::report::translucency::{self as report, abs_stats as stats, with_thickness, Sample};
use hadou::scene::transform::{Transform, TransformOp};
use hadou::scene::{MaterialKind, Scene, ThicknessMode};
use hadou::{Aov, FrameRequest};

// ---------------------------------------------------------------------------------------------
// Rendering

struct Rendered {
    width: u32,
    height: u32,
    /// World thickness per pixel (+inf where no translucent surface).
    thickness: Vec<f32>,
    /// Distance from the camera per pixel.
    depth: Vec<f32>,
    /// RGBA per pixel.
    hdr: Vec<f32>,
    /// The G-buffer normal per pixel (RGBA, turned toward the camera).
    normal: Vec<f32>,
    passes: Vec<String>,
}

/// Renders `scene` (validation on) and reads back the thickness, depth and HDR AOVs; asserts
/// validation stayed clean.
fn render(scene: &Scene, width: u32, height: u32) -> Rendered {
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let translucent = rt.pass_names().contains(&"translucency");
    let mut request = FrameRequest::new(width, height);
    request.color = false;
    request.aovs = vec![Aov::Depth, Aov::Hdr, Aov::Normal];
    if translucent {
        request.aovs.push(Aov::Thickness);
    }
    let frame = rt.render(&request).unwrap();
    common::assert_clean(&rt);
    let n = (width * height) as usize;
    Rendered {
        width,
        height,
        thickness: frame.aov(Aov::Thickness).map_or(vec![f32::INFINITY; n], |a| a.data.clone()),
        depth: frame.aov(Aov::Depth).unwrap().data.clone(),
        hdr: frame.aov(Aov::Hdr).unwrap().data.clone(),
        normal: frame.aov(Aov::Normal).unwrap().data.clone(),
        passes: rt.pass_names().iter().map(|p| p.to_string()).collect(),
    }
}

// ---------------------------------------------------------------------------------------------
// Scenes and references

fn transform(ops: &[TransformOp]) -> Transform {
    Transform::from_ops(ops).unwrap()
}

fn rot(angle_deg: f64, axis: [f64; 3]) -> TransformOp {
    TransformOp::Rotate { angle_deg, axis: DVec3::from_array(axis) }
}

fn scale(s: [f64; 3]) -> TransformOp {
    TransformOp::Scale(DVec3::from_array(s))
}

fn translate(t: [f64; 3]) -> TransformOp {
    TransformOp::Translate(DVec3::from_array(t))
}

/// assets/scenes/translucency.toml with the three objects rotated and non-uniformly scaled; the
/// torus turned 55° from facing the light, so part of the light crosses the ring twice, through
/// its hole (the seed's figure 11).
fn seed_objects_transformed() -> Scene {
    let mut scene = common::load("assets/scenes/translucency.toml");
    let named = |scene: &Scene, name: &str| {
        scene.instances.iter().position(|i| i.name.as_deref() == Some(name)).unwrap()
    };
    let placements = [
        (
            "cavity cube",
            vec![scale([1.2, 0.85, 1.1]), rot(25.0, [0.3, 1.0, 0.2]), translate([-2.3, 0.75, 0.0])],
        ),
        (
            "upright torus",
            vec![
                scale([1.1, 1.35, 0.9]),
                rot(90.0, [1.0, 0.0, 0.0]),
                rot(-55.0, [0.0, 1.0, 0.0]),
                translate([0.0, 1.1, 0.0]),
            ],
        ),
        (
            "bottle",
            vec![
                scale([1.2, 0.9, 0.85]),
                rot(12.0, [0.0, 0.0, 1.0]),
                rot(30.0, [0.0, 1.0, 0.0]),
                translate([2.3, 0.75, 0.0]),
            ],
        ),
    ];
    for (name, ops) in placements {
        let k = named(&scene, name);
        scene.instances[k].transform = transform(&ops);
        scene.instances[k].ops = ops;
    }
    scene
}

fn caster(scene: &Scene) -> SceneCaster {
    let meshes: Vec<_> = scene.meshes.iter().map(|m| m.mesh.clone()).collect();
    let instances: Vec<_> = scene.instances.iter().map(|i| (i.mesh, i.transform)).collect();
    SceneCaster::new(&meshes, &instances).unwrap()
}

/// The pixels with +inf GPU thickness whose centre ray hits, in f64, a translucent instance at the
/// GPU's depth: pixels the pass left out (it runs only over the screen bounds of the translucent
/// instances). Must be none.
fn missing_translucent_pixels(scene: &Scene, frame: &Rendered) -> Vec<(u32, u32)> {
    let caster = caster(scene);
    let mut missing = Vec::new();
    for y in 0..frame.height {
        for x in 0..frame.width {
            let i = (y * frame.width + x) as usize;
            if frame.thickness[i] != f32::INFINITY {
                continue;
            }
            let (o, u) = scene.camera.pixel_ray(x, y, frame.width, frame.height);
            let depth = frame.depth[i] as f64;
            let Some(hit) = caster.cast(o, u).filter(|h| (h.t - depth).abs() <= 1e-3 * depth) else {
                continue;
            };
            let material = scene.instances[hit.instance].material;
            if matches!(scene.materials[material].kind, MaterialKind::Translucent { .. }) {
                missing.push((x, y));
            }
        }
    }
    missing
}

/// The world voxel edge of a translucent instance (`report::translucency::world_voxel`).
fn world_voxel(scene: &Scene, instance: usize) -> f64 {
    report::world_voxel(scene, instance).unwrap_or_else(|| panic!("instance {instance} is not translucent"))
}

/// `report::translucency::samples` over a rendered frame: every pixel with a finite GPU thickness
/// whose centre ray hits, in f64, a translucent instance at the GPU's depth, with its exact and
/// TSM references (silhouette pixels counted and left out); every thickness is +inf or finite ≥ 0.
fn samples(scene: &Scene, frame: &Rendered) -> (Vec<Sample>, usize) {
    for (i, &d) in frame.thickness.iter().enumerate() {
        assert!(d == f32::INFINITY || (d.is_finite() && d >= 0.0), "pixel {i}: thickness {d}");
    }
    report::samples(scene, (frame.width, frame.height), &frame.thickness, &frame.depth).unwrap()
}

// ---------------------------------------------------------------------------------------------
// Tests

/// GPU thickness vs the exact f64 thickness on the seed's three objects under rotated,
/// non-uniformly scaled instances, for the LUT and for the TSM baseline.
#[test]
fn thickness_matches_exact_on_the_seed_objects() {
    let (w, h) = (480, 270);
    let mut failures = Vec::new();
    for (mode, label) in [(ThicknessMode::Lut, "lut"), (ThicknessMode::Tsm, "tsm")] {
        let scene = with_thickness(seed_objects_transformed(), mode);
        let frame = render(&scene, w, h);
        assert_eq!(frame.passes[..3], ["raster", "light_id", "translucency"]);
        let (samples, skipped) = samples(&scene, &frame);
        println!("{label}: {} translucent pixels, {skipped} silhouette pixels left out", samples.len());
        let missing = missing_translucent_pixels(&scene, &frame);
        assert!(missing.is_empty(), "{label}: translucent pixels without a thickness: {missing:?}");
        for (k, inst) in scene.instances.iter().enumerate() {
            if !matches!(scene.materials[inst.material].kind, MaterialKind::Translucent { .. }) {
                continue;
            }
            let hw = world_voxel(&scene, k);
            let mine: Vec<&Sample> = samples.iter().filter(|s| s.instance == k).collect();
            assert!(mine.len() > 500, "{}: only {} pixels", inst.name.as_deref().unwrap_or("?"), mine.len());
            let (mean, p95, max) = stats(mine.iter().map(|s| (s.gpu - s.exact) / hw));
            let name = inst.name.as_deref().unwrap_or("?");
            println!(
                "{label} {name:>14}: {} px, voxel {hw:.4}: |error| mean {mean:.3}, p95 {p95:.3}, max {max:.2} voxels",
                mine.len()
            );
            if mode == ThicknessMode::Lut && p95 > 1.0 {
                failures.push(format!("{name}: LUT thickness p95 error {p95:.3} voxels > 1"));
            }
        }
        if std::env::var_os("HADOU_TEST_DUMP").is_some() {
            dump(&format!("/tmp/translucency_{label}"), &frame, &samples, &scene);
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// Debug images: thickness error (red: GPU too thick, blue: too thin, in voxels / 4).
fn dump(prefix: &str, frame: &Rendered, samples: &[Sample], scene: &Scene) {
    let mut rgba = vec![0u8; (frame.width * frame.height * 4) as usize];
    for s in samples {
        let e = (s.gpu - s.exact) / world_voxel(scene, s.instance) / 4.0;
        let i = s.pixel * 4;
        rgba[i] = (e.clamp(0.0, 1.0) * 255.0) as u8;
        rgba[i + 1] = 40;
        rgba[i + 2] = ((-e).clamp(0.0, 1.0) * 255.0) as u8;
        rgba[i + 3] = 255;
    }
    hadou::output::write_png(format!("{prefix}_error.png").as_ref(), frame.width, frame.height, &rgba)
        .unwrap();
    let mut rgba = vec![0u8; (frame.width * frame.height * 4) as usize];
    for (i, px) in rgba.chunks_exact_mut(4).enumerate() {
        for (c, out) in px.iter_mut().take(3).enumerate() {
            *out = hadou::effects::tonemap::tonemap_channel(frame.hdr[i * 4 + c] as f64, 1.0).round() as u8;
        }
        px[3] = 255;
    }
    hadou::output::write_png(format!("{prefix}_hdr.png").as_ref(), frame.width, frame.height, &rgba).unwrap();
}

/// The cavity cube (seed 003, figure 10) back-lit through its cavity under rotated,
/// non-uniformly scaled instances, one of them mirrored (its triangles wind the other way for the
/// light_id pass's culling): on every pixel whose light path crosses the cavity by more than the
/// bound, the LUT leaves the cavity out (within the bound of tests/translucency_bake.rs,
/// 2·e·h·s + q·L with e = 2.6 voxels per end) and TSM does not (its error is the cavity chord,
/// the diameter at the centre, as its CPU reference finds).
///
/// These paths are the LUT's hardest: near the cavity's rim the chord changes fast with the
/// path's position, and the table's segment runs up to about half a voxel beside the path. Their
/// 95th percentile error depends on how the paths meet the voxel grid: measured 0.94 voxels for
/// the first orientation, 1.24 for the second (printed, not asserted; over whole objects see
/// `thickness_matches_exact_on_the_seed_objects`).
#[test]
fn cavity_cube_back_lit_through_the_cavity() {
    let scaled = "[{ scale = [1.1, 0.9, 1.25] }, { rotate = { angle_deg = 20, axis = [0.2, 0.3, 1] } }]";
    cavity_cube_case("rotated, scaled", scaled);
    let other = "[{ scale = [1.1, 0.9, 1.25] }, { rotate = { angle_deg = -15, axis = [0.3, 0.1, 1] } }]";
    cavity_cube_case("rotated, scaled (2)", other);
    let mirrored = "[{ scale = [-1.1, 0.9, 1.25] }, { rotate = { angle_deg = 20, axis = [0.2, 0.3, 1] } }]";
    cavity_cube_case("mirrored", mirrored);
}

fn cavity_cube_case(label: &str, transform: &str) {
    let text = r#"
        [render]
        background = [0, 0, 0]
        ambient = [0.03, 0.03, 0.03]
        [camera]
        position = [0, 0, 6]
        look_at = [0, 0, 0]
        fov_y_deg = 25
        [[light]]
        kind = "directional"
        direction = [0, 0, 1]
        intensity = 3
        [[mesh]]
        name = "hollow cube"
        kind = "cavity_cube"
        size = 1.4
        cavity_radius = 0.45
        segments = 48
        rings = 24
        [[material]]
        name = "jade"
        kind = "translucent"
        albedo = [0.55, 0.85, 0.65]
        sigma = [3.0, 1.2, 2.2]
        voxel_res = 25
        [[instance]]
        mesh = "hollow cube"
        material = "jade"
        transform = TRANSFORM
    "#;
    let (w, h) = (256, 256);
    let lut_scene = common::parse(&text.replace("TRANSFORM", transform));
    let m = lut_scene.instances[0].transform;
    let hw = world_voxel(&lut_scene, 0);
    let s_max = {
        let a = glam::DMat3::from_mat4(m.matrix);
        [a.x_axis, a.y_axis, a.z_axis].map(|c| c.length()).into_iter().fold(0.0, f64::max)
    };
    let lut = samples(&lut_scene, &render(&lut_scene, w, h)).0;
    let tsm_scene = with_thickness(lut_scene.clone(), ThicknessMode::Tsm);
    let tsm = samples(&tsm_scene, &render(&tsm_scene, w, h)).0;
    assert_eq!(lut.len(), tsm.len());
    // The bound of tests/translucency_bake.rs in world units (h_obj·s_max per voxel of offset).
    let h_obj = hw / m.matrix.determinant().abs().cbrt();
    let end_offset = 0.866_025_403_784_438_6 + 1.732_050_807_568_877_2;
    let q = hadou::effects::thickness_lut::QUANTIZATION_BOUND;
    let bound = |s: &Sample| 2.0 * end_offset * h_obj * s_max + q * s.tsm;
    let through: Vec<(&Sample, &Sample)> =
        lut.iter().zip(&tsm).filter(|(l, _)| l.tsm - l.exact > bound(l) + hw).collect();
    assert!(through.len() > 2000, "only {} pixels see the light through the cavity", through.len());
    let (mut lut_err, mut tsm_err, mut tsm_vs_cpu) = (Vec::new(), Vec::new(), Vec::new());
    for (l, t) in &through {
        assert_eq!(l.pixel, t.pixel);
        let (le, te) = (l.gpu - l.exact, t.gpu - t.exact);
        assert!(
            le.abs() <= bound(l),
            "pixel {}: LUT {} vs exact {} (bound {})",
            l.pixel,
            l.gpu,
            l.exact,
            bound(l)
        );
        assert!(te > bound(t), "pixel {}: TSM {} within the bound of exact {}", t.pixel, t.gpu, t.exact);
        lut_err.push(le / hw);
        tsm_err.push(te / hw);
        // TSM is the TSM reference: its error is the cavity chord the CPU finds.
        tsm_vs_cpu.push((t.gpu - t.tsm) / hw);
    }
    let (lm, lp, lx) = stats(lut_err);
    let (tm, tp, tx) = stats(tsm_err);
    let (cm, cp, cx) = stats(tsm_vs_cpu);
    println!("{label}: {} pixels through the cavity, voxel {hw:.4}:", through.len());
    println!("  LUT |error| mean {lm:.3}, p95 {lp:.3}, max {lx:.2} voxels");
    println!("  TSM |error| mean {tm:.2}, p95 {tp:.2}, max {tx:.2} voxels (the cavity chord)");
    println!("  TSM vs its CPU reference: mean {cm:.3}, p95 {cp:.3}, max {cx:.3} voxels");
    assert!(cp <= 1.0, "TSM p95 {cp} voxels off its reference");
    // Where the light passes nearest the cavity's centre, TSM is off by the cavity's diameter:
    // 2r along the light's object-space direction, stretched by M.
    let centre = m.transform_point(DVec3::ZERO);
    let nearest = through
        .iter()
        .min_by(|a, b| {
            let off = |s: &Sample| {
                let v = s.point - centre;
                (v - v.dot(DVec3::Z) * DVec3::Z).length()
            };
            off(a.1).total_cmp(&off(b.1))
        })
        .unwrap();
    let along = m.inverse.transform_vector3(DVec3::Z);
    let diameter = 2.0 * 0.45 / along.length();
    let t = nearest.1;
    println!("  nearest the centre: TSM error {:.4}, cavity diameter {diameter:.4}", t.gpu - t.exact);
    assert!(((t.gpu - t.exact) - diameter).abs() < 0.03 * diameter);
}

/// The colour the pass adds vs the f64 formula with the exact thickness (module documentation:
/// the per-pixel bound from the pixel's own thickness error, and the 95th-percentile bound from
/// one voxel of thickness error).
#[test]
fn colour_matches_the_f64_formula() {
    let (w, h) = (480, 270);
    let scene = seed_objects_transformed();
    let frame = render(&scene, w, h);
    let mut lambert = scene.clone();
    for m in &mut lambert.materials {
        m.kind = MaterialKind::Lambert;
    }
    let surface = render(&lambert, w, h);
    assert_eq!(surface.passes[..2], ["raster", "tonemap"]);
    let (samples, _) = samples(&scene, &frame);
    let light = &scene.lights[0];
    let radiance = light.color * light.intensity;
    let light_dir = light.direction.normalize();
    let step = 2f64.powi(-10);
    let mut lit_through = 0;
    let mut per_instance: Vec<Vec<f64>> = vec![Vec::new(); scene.instances.len()];
    let mut worst: f64 = 0.0;
    for s in &samples {
        let inst = &scene.instances[s.instance];
        let mat = &scene.materials[inst.material];
        let MaterialKind::Translucent { sigma, .. } = mat.kind else { unreachable!() };
        let i = s.pixel * 4;
        let n = DVec3::new(frame.normal[i] as f64, frame.normal[i + 1] as f64, frame.normal[i + 2] as f64);
        let weight = exit_weight(n, light_dir);
        lit_through += usize::from(weight > 0.5);
        let cpu = weight * transmitted(radiance, mat.albedo, sigma, s.exact);
        let la = radiance * mat.albedo;
        let mut excess: f64 = 0.0;
        for c in 0..3 {
            let (h1, h0) = (frame.hdr[i + c] as f64, surface.hdr[i + c] as f64);
            let gpu = h1 - h0;
            let rounding = step * (h1.abs() + h0.abs()) + 2f64.powi(-23) + 1e-5 * la[c];
            let slope = weight * la[c] * sigma[c] * (-sigma[c] * s.gpu.min(s.exact)).exp();
            let bound = slope * (s.gpu - s.exact).abs() + rounding;
            let err = (gpu - cpu[c]).abs();
            assert!(
                err <= bound,
                "pixel {} channel {c}: gpu {gpu} ({h1} - {h0}), cpu {}, bound {bound}, d {} exact {}",
                s.pixel,
                cpu[c],
                s.gpu,
                s.exact
            );
            worst = worst.max(err / bound);
            excess = excess.max(err - rounding);
        }
        per_instance[s.instance].push(excess);
    }
    println!(
        "worst error / per-pixel bound: {worst:.3}; {lit_through} of {} pixels lit through",
        samples.len()
    );
    // The objects are back-lit: most of what the camera sees is a face the light leaves through.
    assert!(lit_through * 2 > samples.len(), "{lit_through} of {}", samples.len());
    for (k, errors) in per_instance.into_iter().enumerate() {
        if errors.is_empty() {
            continue;
        }
        let inst = &scene.instances[k];
        let mat = &scene.materials[inst.material];
        let MaterialKind::Translucent { sigma, .. } = mat.kind else { unreachable!() };
        let lsa = radiance * mat.albedo * sigma;
        let hw = world_voxel(&scene, k);
        let p95_bound = lsa.max_element() * hw;
        let (mean, p95, max) = stats(errors);
        println!(
            "{:>14}: colour error beyond f16 rounding: mean {mean:.4}, p95 {p95:.4} (bound max L·a·σ·h_w = {p95_bound:.4}), max {max:.4}",
            inst.name.as_deref().unwrap_or("?")
        );
        assert!(p95 <= p95_bound);
    }
}

/// The passes run only for scenes with a translucent instance, and the thickness AOV only exists
/// there; without a light the pass adds nothing and the thickness is +inf everywhere.
#[test]
fn plan_aov_and_a_scene_without_light() {
    let mut rt = common::runtime();
    rt.load_scene(common::load("assets/scenes/translucency.toml")).unwrap();
    assert_eq!(rt.pass_names(), ["raster", "light_id", "translucency", "tonemap"]);
    rt.load_scene(common::load("assets/scenes/single_cube.toml")).unwrap();
    assert!(!rt.pass_names().contains(&"light_id"));
    let mut request = FrameRequest::new(16, 16);
    request.aovs = vec![Aov::Thickness];
    let err = rt.render(&request).unwrap_err().to_string();
    assert!(err.contains("thickness"), "{err}");
    common::assert_clean(&rt);

    let mut dark = seed_objects_transformed();
    dark.lights.clear();
    let frame = render(&dark, 96, 54);
    assert!(frame.thickness.iter().all(|&d| d == f32::INFINITY));
    let mut lambert = dark.clone();
    lambert.materials.iter_mut().for_each(|m| m.kind = MaterialKind::Lambert);
    assert_eq!(frame.hdr, render(&lambert, 96, 54).hdr);
}

/// The showcase's jade cube gets a smaller light map than the seed objects
/// (`effects::translucency::light_map_size`: texels of a quarter of its finest voxel): its LUT
/// thickness still meets the seed objects' bound, p95 ≤ 1 voxel, and every pixel showing it has a
/// thickness.
#[test]
fn a_smaller_light_map_keeps_the_thickness_bound() {
    let scene = common::load("assets/scenes/showcase.toml");
    let size = hadou::effects::translucency::light_map_size(&scene);
    assert!(size < hadou::effects::translucency::LIGHT_MAP_MAX);
    let mut frame_scene = scene.clone();
    // Close on the cube so it covers many pixels.
    frame_scene.camera.position = DVec3::new(-1.6, 2.2, 6.0);
    frame_scene.camera.look_at = DVec3::new(-3.4, 0.55, 2.6);
    let frame = render(&frame_scene, 320, 240);
    assert!(missing_translucent_pixels(&frame_scene, &frame).is_empty());
    let (samples, _) = samples(&frame_scene, &frame);
    let k = frame_scene.instances.iter().position(|i| i.name.as_deref() == Some("jade cube")).unwrap();
    let hw = world_voxel(&frame_scene, k);
    let mine: Vec<&Sample> = samples.iter().filter(|s| s.instance == k).collect();
    assert!(mine.len() > 2000, "only {} pixels", mine.len());
    let (mean, p95, max) = stats(mine.iter().map(|s| (s.gpu - s.exact) / hw));
    println!(
        "jade cube, {size}² light map: {} px, error mean {mean:.3}, p95 {p95:.3}, max {max:.2} voxels",
        mine.len()
    );
    assert!(p95 <= 1.0, "p95 {p95:.3} voxels");
}
