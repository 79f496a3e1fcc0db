//! A living world: waves and metaball groups spawned and despawned over 300 frames with 3 frames
//! in flight, the passes following the world (the energy and metaballs passes come and go), no
//! wait on the device after `prepare`, nothing leaked, and sampled frames equal to the same world
//! rendered alone by the headless runtime (itself checked against the f64 twins) and, for the
//! energy, to the f64 integral of that frame's waves. Bad calls are typed errors that leave the
//! world as it was. Lavapipe, validation + synchronization validation, zero messages.

mod common;

use common::host::Host;

use glam::{DMat4, DVec3};
use hadou::effects::energy_wave::line_integral;
use hadou::passes::energy_wave::wave_params;
use hadou::{
    Aov, Ball, Error, FrameInputs, FrameRequest, MetaballsDesc, Renderer, RendererOptions, WaveDesc,
};

const SCENE: &str = r#"
[camera]
position = [0, 1, 9]
look_at = [0, 0, 0]
fov_y_deg = 50
near = 0.5
far = 60
[[light]]
direction = [-0.3, -1, -0.5]
[[mesh]]
name = "box"
kind = "cube"
size = 2
[[material]]
name = "slime"
albedo = [0.3, 0.8, 0.4]
[[material]]
name = "jade"
kind = "translucent"
albedo = [0.55, 0.85, 0.65]
sigma = [3.0, 1.2, 2.2]
voxel_res = 10
[[instance]]
mesh = "box"
transform = [{ translate = [2, 0, -1] }]
"#;

fn wave(k: usize) -> WaveDesc {
    let a = k as f64 * 0.37;
    WaveDesc {
        origin: DVec3::new(-4.0 + (k % 7) as f64, (a.sin() * 1.5).round() * 0.5, -((k % 3) as f64)),
        direction: DVec3::new(1.0, 0.3 * a.cos(), 0.2 * a.sin()),
        a: 0.5 + (k % 4) as f64 * 0.3,
        b: 0.2 + (k % 5) as f64 * 0.2,
        core: 0.05,
        length: 2.0 + (k % 6) as f64,
        color: DVec3::new(0.3, 0.6, 1.0),
        intensity: 0.5,
        cutoff: 0.0,
    }
}

fn metaballs(k: usize) -> MetaballsDesc {
    let n = 1 + k % 5;
    let balls = (0..n)
        .map(|i| {
            let a = (k * 3 + i) as f64 * 0.9;
            Ball { centre: DVec3::new(0.6 * a.cos(), 0.4 * a.sin(), 0.2 * i as f64), radius: 0.7, q: 1.0 }
        })
        .collect();
    let at = DVec3::new(-2.5 + (k % 6) as f64, -1.0 + (k % 3) as f64, 0.0);
    MetaballsDesc { balls, threshold: 0.5, material: "slime".into(), transform: DMat4::from_translation(at) }
}

const W: u32 = 40;
const H: u32 = 30;
const AOVS: [Aov; 3] = [Aov::Depth, Aov::Energy, Aov::Normal];

/// 100 waves, 50 metaball groups and 20 translucent instances spawned and despawned over 300
/// frames, 3 in flight. Each translucent block is sampled once while it lives (5 frames after its
/// spawn): its thickness AOV equals the world rendered alone, bit for bit, and the exact f64
/// thickness within the documented bound.
#[test]
fn spawn_and_despawn_over_three_hundred_frames() {
    let (_leaks, ctx) = common::context();
    let log = ctx.validation_log();
    let mut host = Host::new(&ctx, 3);
    let options = RendererOptions { frames_in_flight: 3, ..RendererOptions::default() };
    let mut hadou = Renderer::with_options(ctx, &options).unwrap();
    hadou.load_scene(common::parse(SCENE)).unwrap();
    assert_eq!(hadou.pass_names(), ["raster", "tonemap"], "no effect: only the raster runs");
    // The box's thickness table, baked (and uploaded) once before the frames: later translucent
    // boxes spawn on it with no bake and no upload.
    let warm = hadou.spawn_instance("box", "jade", DMat4::IDENTITY).unwrap();
    hadou.wait_for_bakes().unwrap();
    hadou.despawn_instance(warm).unwrap();
    let inputs = FrameInputs::headless(W, H, 0.0);
    hadou.prepare(&inputs).unwrap();
    let waits = hadou.context().host_waits();
    let (mut waves, mut groups, mut blocks) = (Vec::new(), Vec::new(), Vec::new());
    let (mut spawned_waves, mut spawned_groups, mut spawned_blocks) = (0, 0, 0);
    let (mut with_energy, mut without_energy) = (0, 0);
    let mut sampled = Vec::new();
    let mut translucent = Vec::new();
    for i in 0..300usize {
        // Waves: one spawned every other frame (100 in all), each living 8 to 20 frames; the
        // world is without waves now and then, so the energy pass goes and comes back.
        if i % 2 == 0 && spawned_waves < 100 && (i / 40) % 3 != 2 {
            waves.push((hadou.spawn_wave(&wave(spawned_waves)).unwrap(), i + 8 + spawned_waves % 13));
            spawned_waves += 1;
        }
        // Translucent boxes: one every 14th frame (20 in all), each living 6 to 20 frames, turned
        // and scaled as they come; in front of the box and the metaball groups (z = 1), so each
        // shows when it is sampled.
        if i % 14 == 3 && spawned_blocks < 20 {
            let k = spawned_blocks as f64;
            let m = DMat4::from_translation(DVec3::new(-3.0 + 0.3 * k, 1.2 - 0.1 * k, 1.0))
                * DMat4::from_axis_angle(DVec3::new(0.2, 1.0, 0.3).normalize(), 0.4 * k)
                * DMat4::from_scale(DVec3::new(0.4, 0.3 + 0.02 * k, 0.5));
            blocks.push((hadou.spawn_instance("box", "jade", m).unwrap(), i + 6 + spawned_blocks % 15));
            spawned_blocks += 1;
        }
        // Metaball groups: one every sixth frame (50 in all), each living 10 to 25 frames.
        if i % 6 == 1 && spawned_groups < 50 {
            groups.push((
                hadou.spawn_metaballs(&metaballs(spawned_groups)).unwrap(),
                i + 10 + spawned_groups % 16,
            ));
            spawned_groups += 1;
        }
        for (id, _) in waves.iter().filter(|(_, until)| *until == i) {
            hadou.despawn_wave(*id).unwrap();
        }
        waves.retain(|(_, until)| *until != i);
        for (id, _) in groups.iter().filter(|(_, until)| *until == i) {
            hadou.despawn_metaballs(*id).unwrap();
        }
        groups.retain(|(_, until)| *until != i);
        for (id, _) in blocks.iter().filter(|(_, until)| *until == i) {
            hadou.despawn_instance(*id).unwrap();
        }
        blocks.retain(|(_, until)| *until != i);
        let names = hadou.pass_names();
        assert_eq!(names.contains(&"translucency"), !blocks.is_empty(), "frame {i}: {names:?}");
        assert_eq!(names.contains(&"energy_wave"), !waves.is_empty(), "frame {i}: {names:?}");
        assert_eq!(names.contains(&"metaballs"), !groups.is_empty(), "frame {i}: {names:?}");
        if waves.is_empty() {
            without_energy += 1;
        } else {
            with_energy += 1;
        }
        let slot = i % 3;
        let cmd = host.begin(slot);
        hadou.record_frame(cmd, &inputs).unwrap();
        if i % 37 == 36 && !waves.is_empty() && !groups.is_empty() {
            let readback = hadou.record_aov_readback(cmd, &AOVS).unwrap();
            sampled.push((i, hadou.scene().unwrap().clone(), readback));
        }
        // Every block lives ≥ 6 frames: 5 frames after each spawn, it (at least) is in the world.
        if i % 14 == 8 && !blocks.is_empty() {
            let readback = hadou.record_aov_readback(cmd, &[Aov::Depth, Aov::Thickness]).unwrap();
            translucent.push((i, hadou.scene().unwrap().clone(), readback));
        }
        host.submit(slot);
    }
    assert_eq!((spawned_waves, spawned_groups, spawned_blocks), (100, 50, 20));
    assert!(
        with_energy > 50 && without_energy > 20,
        "the energy pass came and went: {with_energy}/{without_energy}"
    );
    assert_eq!(hadou.context().host_waits(), waits, "spawning or despawning waited on the device");
    host.wait_all();
    assert!(sampled.len() >= 4, "{} frames sampled", sampled.len());
    assert_eq!(translucent.len(), 20, "each block sampled once");

    let mut rt = common::runtime();
    for (i, world, readback) in &sampled {
        rt.load_scene(world.clone()).unwrap();
        let mut request = FrameRequest::new(W, H);
        request.aovs = AOVS.to_vec();
        let alone = rt.render(&request).unwrap();
        for aov in AOVS {
            let got = readback.aov(aov).unwrap();
            assert!(
                common::same_bits(&got, alone.aov(aov).unwrap()),
                "frame {i}: {} differs from the world alone",
                aov.name()
            );
        }
        // Energy vs the f64 integral of that frame's waves up to the GPU's distance (bound 1e-4:
        // f32 pixel rays enter H only logarithmically; tests/gpu_energy_wave.rs argues it).
        let (energy, distance) = (readback.aov(Aov::Energy).unwrap(), readback.aov(Aov::Depth).unwrap());
        let cam = &world.camera;
        for y in 0..H {
            for x in 0..W {
                let k = (y * W + x) as usize;
                let (o, u) = cam.pixel_ray(x, y, W, H);
                let d = distance.data[k] as f64;
                assert!(!d.is_nan(), "frame {i} ({x}, {y}): distance NaN");
                let l = d.min(cam.far);
                let reference: f64 =
                    world.waves().iter().map(|w| line_integral(&wave_params(&w.at(0.0)), o, u, l)).sum();
                let got = energy.data[k] as f64;
                let rel = if reference > 0.0 { (got - reference).abs() / reference } else { got };
                assert!(rel <= 1e-4, "frame {i} ({x}, {y}): {got} vs f64 {reference}");
            }
        }
    }
    check_translucent_blocks(&mut rt, &translucent);
    rt.finish();
    drop(sampled);
    drop(translucent);
    host.destroy();
    drop(hadou);
    common::assert_log_clean(&log, "after shutdown (leaks included)");
}

/// The sampled frames with translucent blocks: thickness and depth equal, bit for bit, the same
/// world rendered alone; the thickness against the exact f64 thickness of that frame's blocks
/// (`report::translucency::samples`: ray casts against the transformed triangles), pooled over
/// the 20 frames, p95 of |error| ≤ 1 voxel of its instance (object voxel edge × ∛|det M|), the
/// documented bound for paths that cross no cavity (docs/scene-format.md, translucency). Floors:
/// ≥ 3 translucent pixels in every sampled frame (the blocks are small at 40 × 30) and ≥ 300 in
/// all, ≤ 1/16 of them left out as silhouettes (the share a
/// sphere's disc leaves at the steepest incidence the f64 cast accepts).
fn check_translucent_blocks(
    rt: &mut hadou::Runtime,
    frames: &[(usize, hadou::scene::Scene, hadou::renderer::AovReadback)],
) {
    use hadou_cli::report::translucency::{abs_stats, sample_set, world_voxel, MAX_SKIPPED_SHARE};
    let (mut errors, mut skipped) = (Vec::new(), 0);
    for (i, world, readback) in frames {
        let (thickness, depth) = (readback.aov(Aov::Thickness).unwrap(), readback.aov(Aov::Depth).unwrap());
        rt.load_scene(world.clone()).unwrap();
        let mut request = FrameRequest::new(W, H);
        request.aovs = vec![Aov::Depth, Aov::Thickness];
        let alone = rt.render(&request).unwrap();
        assert!(common::same_bits(&thickness, alone.aov(Aov::Thickness).unwrap()), "frame {i}: thickness");
        assert!(common::same_bits(&depth, alone.aov(Aov::Depth).unwrap()), "frame {i}: depth");
        let set = sample_set(world, (W, H), &thickness.data, &depth.data).unwrap();
        let (found, left_out) = (set.samples, set.skipped);
        skipped += left_out;
        assert!(found.len() >= 3, "frame {i}: its block shows on only {} pixels", found.len());
        for s in &found {
            errors.push((s.gpu - s.exact) / world_voxel(world, s.instance).unwrap());
        }
    }
    let (mean, p95, max) = abs_stats(errors.iter().copied());
    println!(
        "translucent blocks: {} px compared, {skipped} left out; |error| mean {mean:.3}, p95 {p95:.3}, max \
         {max:.2} voxels",
        errors.len()
    );
    assert!(errors.len() >= 300, "only {} translucent pixels compared", errors.len());
    let looked_at = errors.len() + skipped;
    assert!(skipped as f64 <= MAX_SKIPPED_SHARE * looked_at as f64, "{skipped} of {looked_at} left out");
    assert!(p95 <= 1.0, "thickness p95 {p95:.3} voxels");
}

/// Bad calls: a despawned id, NaN, an unknown material, no balls — typed errors, world unchanged.
#[test]
fn bad_calls_are_typed_errors_and_change_nothing() {
    let (_leaks, ctx) = common::context();
    let mut hadou = Renderer::with_options(ctx, &RendererOptions::default()).unwrap();
    hadou.load_scene(common::parse(SCENE)).unwrap();
    let id = hadou.spawn_wave(&wave(0)).unwrap();
    let group = hadou.spawn_metaballs(&metaballs(0)).unwrap();
    let before = hadou.scene().unwrap().clone();
    let nan = WaveDesc { a: f64::NAN, ..wave(1) };
    assert!(matches!(hadou.spawn_wave(&nan), Err(Error::InvalidUpdate { .. })));
    assert!(matches!(hadou.update_wave(id, &nan), Err(Error::InvalidUpdate { .. })));
    let too_bright = WaveDesc { color: DVec3::splat(1e30), intensity: 1e30, ..wave(1) };
    assert!(matches!(hadou.spawn_wave(&too_bright), Err(Error::InvalidUpdate { .. })), "beyond f32");
    let zero_dir = WaveDesc { direction: DVec3::ZERO, ..wave(1) };
    assert!(matches!(hadou.spawn_wave(&zero_dir), Err(Error::InvalidUpdate { .. })));
    let unknown = MetaballsDesc { material: "no such".into(), ..metaballs(1) };
    assert!(matches!(hadou.spawn_metaballs(&unknown), Err(Error::InvalidUpdate { .. })));
    let empty = MetaballsDesc { balls: Vec::new(), ..metaballs(1) };
    assert!(matches!(hadou.spawn_metaballs(&empty), Err(Error::InvalidUpdate { .. })));
    let singular = MetaballsDesc { transform: DMat4::ZERO, ..metaballs(1) };
    assert!(matches!(hadou.spawn_metaballs(&singular), Err(Error::InvalidUpdate { .. })));
    assert_eq!(hadou.scene().unwrap().waves(), before.waves(), "a refused call changes nothing");
    assert_eq!(hadou.scene().unwrap().metaballs(), before.metaballs());
    hadou.despawn_wave(id).unwrap();
    hadou.despawn_metaballs(group).unwrap();
    assert!(matches!(hadou.despawn_wave(id), Err(Error::StaleId(_))));
    assert!(matches!(hadou.update_wave(id, &wave(2)), Err(Error::StaleId(_))));
    assert!(matches!(hadou.despawn_metaballs(group), Err(Error::StaleId(_))));
    assert_eq!(hadou.pass_names(), ["raster", "tonemap"]);
    // Errors and warnings so far; the guard checks again once the device is destroyed.
    common::assert_log_clean(&hadou.context().validation_log(), "after the bad calls");
}

/// Lights and materials change at run time exactly as if the file had said so: a frame after
/// `set_light` / `set_material` equals, bit for bit, the scene loaded with those values (a
/// translucent material's σ and albedo, the back light's direction, colour and intensity, which
/// also moves the light's view of the translucent object). Bad values are refused, state kept.
#[test]
fn lights_and_materials_change_as_the_file_would() {
    let text = r#"
        [camera]
        position = [0, 0.6, 5]
        look_at = [0, 0, 0]
        [[light]]
        direction = [0.2, -0.25, 1]
        intensity = 4
        [[mesh]]
        name = "block"
        kind = "cube"
        size = 1.2
        [[material]]
        name = "jade"
        kind = "translucent"
        albedo = [0.55, 0.85, 0.65]
        sigma = [3.0, 1.2, 2.2]
        voxel_res = 16
        [[instance]]
        mesh = "block"
        material = "jade"
        transform = [{ rotate = { angle_deg = 30, axis = [0, 1, 0] } }]
    "#;
    let base = common::parse(text);
    let mut changed = base.clone();
    let (dir, color, intensity) = (DVec3::new(-0.4, -0.3, 1.0), DVec3::new(1.0, 0.8, 0.6), 6.0);
    changed.lights[0].direction = dir.normalize();
    changed.lights[0].color = color;
    changed.lights[0].intensity = intensity;
    let (albedo, sigma) = (DVec3::new(0.9, 0.5, 0.3), DVec3::new(0.7, 2.0, 4.0));
    changed.materials[0].albedo = albedo;
    if let hadou::scene::MaterialKind::Translucent { sigma: s, .. } = &mut changed.materials[0].kind {
        *s = sigma;
    }
    let mut request = FrameRequest::new(64, 48);
    request.aovs = vec![Aov::Hdr, Aov::Thickness];
    let mut live = common::runtime();
    live.load_scene(base).unwrap();
    let before = live.render(&request).unwrap();
    let r = live.renderer();
    let (light, jade) = (r.light_ids()[0], r.material_named("jade").unwrap());
    assert_eq!(r.material_ids(), [jade]);
    assert!(matches!(r.set_light(light, DVec3::ZERO, color, 1.0), Err(Error::InvalidUpdate { .. })));
    let gone = r.spawn_light(dir, color, 1.0).unwrap();
    r.despawn_light(gone).unwrap();
    assert!(matches!(r.set_light(gone, dir, color, 1.0), Err(Error::StaleId(_))));
    assert!(
        matches!(r.set_light(light, dir, color, 1e39), Err(Error::InvalidUpdate { .. })),
        "past f32's range"
    );
    // A light brighter than the HDR image holds is taken (the frame is pre-exposed).
    r.set_light(light, dir, color, 1e5).unwrap();
    assert!(matches!(r.set_material(jade, DVec3::splat(2.0), None), Err(Error::InvalidUpdate { .. })));
    assert!(matches!(r.set_material(jade, albedo, Some(DVec3::ZERO)), Err(Error::InvalidUpdate { .. })));
    r.set_light(light, dir, color, intensity).unwrap();
    r.set_material(jade, albedo, Some(sigma)).unwrap();
    let after = live.render(&request).unwrap();
    let mut file = common::runtime();
    file.load_scene(changed).unwrap();
    let want = file.render(&request).unwrap();
    assert_same(&after, &want, &[Aov::Hdr, Aov::Thickness]);
    assert!(
        !common::same_bits(before.aov(Aov::Hdr).unwrap(), after.aov(Aov::Hdr).unwrap()),
        "the change shows"
    );
    common::assert_clean(&live);
    common::assert_clean(&file);
}

/// Instances come and go at run time exactly as if the file had listed them: a world where a
/// plain box, a second box and a translucent jade block (same mesh and voxel_res as the file's,
/// so its table is baked) were spawned, renders bit for bit as the scene loaded with those
/// instances (depth, HDR, normal, thickness); despawning the file's instance too equals the file
/// without it. A translucent instance whose table was never baked, an unknown mesh or material
/// and a singular matrix are refused with the world unchanged; a despawned id is stale.
#[test]
fn instances_spawn_and_despawn_as_the_file_would() {
    let head = r#"
        [camera]
        position = [0, 1.5, 7]
        look_at = [0, 0, 0]
        [[light]]
        direction = [0.3, -0.4, -1]
        intensity = 3
        [[mesh]]
        name = "block"
        kind = "cube"
        size = 1.2
        [[mesh]]
        name = "ring"
        kind = "torus"
        [[material]]
        name = "stone"
        albedo = [0.6, 0.6, 0.55]
        [[material]]
        name = "jade"
        kind = "translucent"
        albedo = [0.55, 0.85, 0.65]
        sigma = [3.0, 1.2, 2.2]
        voxel_res = 16
    "#;
    let file_instance =
        "[[instance]]\nmesh = \"block\"\nmaterial = \"jade\"\ntransform = [{ translate = [-1.5, 0, 0] }]\n";
    let spawned = [
        (
            "block",
            "stone",
            "[{ translate = [1.5, 0.2, -0.5] }, { rotate = { angle_deg = 20, axis = [0, 1, 0] } }]",
        ),
        ("ring", "stone", "[{ scale = [1, 0.5, 1] }, { translate = [0, -1, 0] }]"),
        (
            "block",
            "jade",
            "[{ rotate = { angle_deg = 35, axis = [1, 1, 0] } }, { translate = [0, 1.2, -1] }]",
        ),
    ];
    let instance_text = |(mesh, material, transform): (&str, &str, &str)| {
        format!("[[instance]]\nmesh = \"{mesh}\"\nmaterial = \"{material}\"\ntransform = {transform}\n")
    };
    let all: String = spawned.iter().map(|&s| instance_text(s)).collect();
    let with_all = common::parse(&format!("{head}{file_instance}{all}"));
    let only_spawned = common::parse(&format!("{head}{all}"));
    let mut request = FrameRequest::new(64, 48);
    request.aovs = vec![Aov::Depth, Aov::Hdr, Aov::Normal, Aov::Thickness];
    let render_file = |scene: hadou::scene::Scene| {
        let mut rt = common::runtime();
        rt.load_scene(scene).unwrap();
        let frame = rt.render(&request).unwrap();
        common::assert_clean(&rt);
        frame
    };
    let mut live = common::runtime();
    live.load_scene(common::parse(&format!("{head}{file_instance}"))).unwrap();
    live.render(&request).unwrap();
    let r = live.renderer();
    let file_id = r.instance_ids()[0];
    let before = r.scene().unwrap().instances.clone();
    let m = DMat4::from_translation(DVec3::X);
    // Refused: unknown names; a singular matrix.
    assert!(matches!(r.spawn_instance("no such", "stone", m), Err(Error::InvalidUpdate { .. })));
    assert!(matches!(r.spawn_instance("block", "no such", m), Err(Error::InvalidUpdate { .. })));
    assert!(matches!(r.spawn_instance("block", "stone", DMat4::ZERO), Err(Error::InvalidUpdate { .. })));
    assert_eq!(r.scene().unwrap().instances, before, "a refused call changes nothing");
    let ids: Vec<_> = with_all.instances[1..]
        .iter()
        .zip(spawned)
        .map(|(inst, (mesh, material, _))| r.spawn_instance(mesh, material, inst.transform.matrix).unwrap())
        .collect();
    let got = live.render(&request).unwrap();
    let want = render_file(with_all);
    assert_same(&got, &want, &request.aovs);
    let r = live.renderer();
    r.despawn_instance(file_id).unwrap();
    assert!(matches!(r.despawn_instance(file_id), Err(Error::StaleId(_))));
    assert!(matches!(r.set_transform(file_id, m), Err(Error::StaleId(_))));
    assert_eq!(r.instance_ids().iter().position(|i| *i == ids[2]), Some(2), "indices shift, ids do not");
    let got = live.render(&request).unwrap();
    let want = render_file(only_spawned);
    assert_same(&got, &want, &request.aovs);
    // The last translucent instance gone: the translucency passes go out with it.
    let r = live.renderer();
    r.despawn_instance(ids[2]).unwrap();
    let mut opaque = request.clone();
    opaque.aovs.retain(|a| *a != Aov::Thickness);
    live.render(&opaque).unwrap();
    assert!(!live.pass_names().contains(&"translucency"), "{:?}", live.pass_names());
    common::assert_clean(&live);
}

/// Lights come and go as if the file had listed them: a second light spawned (then the file's
/// despawned) renders bit for bit as the file with those lights; a ninth light, a zero
/// direction and a light past the HDR limit are refused with the lights unchanged.
#[test]
fn lights_spawn_and_despawn_as_the_file_would() {
    let head = "[camera]\nposition = [0, 1, 6]\nlook_at = [0, 0, 0]\n[[mesh]]\nname = \"box\"\nkind = \"cube\"\n\
                [[instance]]\nmesh = \"box\"\ntransform = [{ rotate = { angle_deg = 30, axis = [1, 1, 0] } }]\n";
    let first = "[[light]]\ndirection = [-0.3, -1, -0.5]\n";
    let second = "[[light]]\ndirection = [1, -0.2, -0.4]\ncolor = [1, 0.5, 0.2]\nintensity = 2\n";
    let mut request = FrameRequest::new(48, 40);
    request.aovs = vec![Aov::Hdr];
    // Each file's runtime checked (errors, warnings, leaks) once its device is destroyed.
    let render_file = |text: String| {
        let mut rt = common::runtime();
        rt.load_scene(common::parse(&text)).unwrap();
        let frame = rt.render(&request).unwrap();
        rt.finish();
        frame
    };
    let mut live = common::runtime();
    live.load_scene(common::parse(&format!("{head}{first}"))).unwrap();
    let r = live.renderer();
    let file_light = r.light_ids()[0];
    let id = r.spawn_light(DVec3::new(1.0, -0.2, -0.4), DVec3::new(1.0, 0.5, 0.2), 2.0).unwrap();
    let got = live.render(&request).unwrap();
    let want = render_file(format!("{head}{first}{second}"));
    assert_same(&got, &want, &[Aov::Hdr]);
    let r = live.renderer();
    let lights = r.scene().unwrap().lights.clone();
    assert!(matches!(r.spawn_light(DVec3::ZERO, DVec3::ONE, 1.0), Err(Error::InvalidUpdate { .. })));
    assert!(matches!(r.spawn_light(DVec3::NEG_Y, DVec3::ONE, 1e39), Err(Error::InvalidUpdate { .. })));
    assert_eq!(r.scene().unwrap().lights, lights, "a refused call changes nothing");
    for _ in 2..8 {
        r.spawn_light(DVec3::NEG_Y, DVec3::ONE, 0.01).unwrap();
    }
    assert!(
        matches!(r.spawn_light(DVec3::NEG_Y, DVec3::ONE, 0.01), Err(Error::InvalidUpdate { .. })),
        "a ninth"
    );
    for extra in r.light_ids()[2..].to_vec() {
        r.despawn_light(extra).unwrap();
    }
    r.despawn_light(file_light).unwrap();
    assert!(matches!(r.despawn_light(file_light), Err(Error::StaleId(_))));
    assert_eq!(r.light_ids(), [id]);
    let got = live.render(&request).unwrap();
    let want = render_file(format!("{head}{second}"));
    assert_same(&got, &want, &[Aov::Hdr]);
    common::assert_clean(&live);
}

/// A translucent instance whose table was never baked: drawn at once (shadow-map thickness, no
/// NaN, validation clean; or already its table, when the bake cache had it and the job ended
/// before the frame) while its table bakes in the background (progress reported), then, once the
/// bake is in, bit for bit the scene loaded with that instance (its table baked at load).
#[test]
fn a_new_translucent_mesh_bakes_in_the_background() {
    let head = r#"
        [camera]
        position = [0, 1.2, 6]
        look_at = [0, 0, 0]
        [[light]]
        direction = [0.2, -0.3, -1]
        intensity = 3
        [[mesh]]
        name = "block"
        kind = "cube"
        size = 1.2
        [[mesh]]
        name = "ring"
        kind = "torus"
        [[material]]
        name = "jade"
        kind = "translucent"
        albedo = [0.55, 0.85, 0.65]
        sigma = [3.0, 1.2, 2.2]
        voxel_res = 14
        [[instance]]
        mesh = "block"
        material = "jade"
        transform = [{ translate = [-1.2, 0, 0] }]
    "#;
    let ring = "[[instance]]\nmesh = \"ring\"\nmaterial = \"jade\"\ntransform = [{ rotate = { angle_deg = 70, axis = [1, 0, 0] } }, { translate = [1.2, 0, 0] }]\n";
    let file = common::parse(&format!("{head}{ring}"));
    let mut request = FrameRequest::new(64, 48);
    request.aovs = vec![Aov::Hdr, Aov::Thickness];
    let mut live = common::runtime();
    live.load_scene(common::parse(head)).unwrap();
    let r = live.renderer();
    r.spawn_instance("ring", "jade", file.instances[1].transform.matrix).unwrap();
    let progress = r.bakes_in_progress();
    assert_eq!(progress.len(), 1, "{progress:?}");
    assert_eq!((progress[0].mesh.as_str(), progress[0].voxel_res), ("ring", 14));
    let early = live.render(&request).unwrap();
    for aov in &request.aovs {
        assert!(early.aov(*aov).unwrap().data.iter().all(|v| !v.is_nan()), "{} NaN", aov.name());
    }
    // A frame's own waits (the headless runtime waits for each frame's fence): the bake and the
    // frame that puts its table in use may add none to them.
    let before = live_waits(&live);
    live.render(&request).unwrap();
    let per_frame = live_waits(&live).fences - before.fences;
    let before = live_waits(&live);
    live.renderer().wait_for_bakes().unwrap();
    assert!(live.renderer().bakes_in_progress().is_empty());
    let got = live.render(&request).unwrap();
    let after = live_waits(&live);
    assert_eq!(
        (after.device_idle, after.fences),
        (before.device_idle, before.fences + per_frame),
        "the switch waited"
    );
    let mut rt = common::runtime();
    rt.load_scene(file).unwrap();
    let want = rt.render(&request).unwrap();
    assert_same(&got, &want, &request.aovs);
    common::assert_clean(&live);
    common::assert_clean(&rt);
}

/// A translucent block carried through a back light, moved every frame — rotated, scaled
/// non-uniformly (and mirrored on the last frames), translated — by `set_transform` on a live
/// renderer: at sampled frames the thickness AOV against the exact f64 thickness of that frame's
/// world (`report::translucency::samples`: ray casts against the transformed triangles), p95 of
/// the error ≤ 1 voxel of the instance (its object voxel edge × ∛|det M|), the documented bound
/// for paths that cross no cavity (docs/scene-format.md, translucency).
#[test]
fn a_moving_translucent_object_keeps_its_thickness() {
    use hadou_cli::report::translucency::{self as report, abs_stats};
    let text = r#"
        [camera]
        position = [0, 0.8, 6]
        look_at = [0, 0, 0]
        [[light]]
        direction = [0.15, -0.2, -1]
        intensity = 4
        [[mesh]]
        name = "block"
        kind = "cube"
        size = 1.4
        [[material]]
        name = "jade"
        kind = "translucent"
        albedo = [0.55, 0.85, 0.65]
        sigma = [3.0, 1.2, 2.2]
        voxel_res = 20
        [[instance]]
        mesh = "block"
        material = "jade"
    "#;
    let (w, h) = (96u32, 72u32);
    let mut request = FrameRequest::new(w, h);
    request.aovs = vec![Aov::Depth, Aov::Thickness];
    let mut live = common::runtime();
    live.load_scene(common::parse(text)).unwrap();
    let id = live.renderer().instance_ids()[0];
    let mut checked = 0;
    for frame in 0..24 {
        let t = frame as f64 / 23.0;
        let mirror = if frame >= 20 { -1.0 } else { 1.0 };
        let m = DMat4::from_translation(DVec3::new(-1.5 + 3.0 * t, 0.3 * (6.0 * t).sin(), -0.5 * t))
            * DMat4::from_axis_angle(DVec3::new(0.3, 1.0, 0.2).normalize(), 2.5 * t)
            * DMat4::from_scale(DVec3::new(mirror * (1.0 + 0.4 * t), 0.8, 1.2 - 0.3 * t));
        live.renderer().set_transform(id, m).unwrap();
        let out = live.render(&request).unwrap();
        if frame % 4 != 3 {
            continue;
        }
        let scene = live.renderer().scene().unwrap().clone();
        let (thickness, depth) = (&out.aov(Aov::Thickness).unwrap().data, &out.aov(Aov::Depth).unwrap().data);
        // ≥ 300 translucent pixels compared, ≤ 1/16 left out as silhouettes (sample_set's cap).
        let set = report::sample_set(&scene, (w, h), thickness, depth).unwrap();
        println!("frame {frame}: {}", set.assert_usable(300));
        let samples = set.samples;
        let voxel = report::world_voxel(&scene, 0).unwrap();
        let (mean, p95, max) = abs_stats(samples.iter().map(|s| (s.gpu - s.exact) / voxel));
        println!(
            "frame {frame}: {} px, |error| mean {mean:.3}, p95 {p95:.3}, max {max:.2} voxels",
            samples.len()
        );
        assert!(p95 <= 1.0, "frame {frame}: thickness p95 {p95:.3} voxels");
        checked += 1;
    }
    assert_eq!(checked, 6);
    common::assert_clean(&live);
}

fn live_waits(rt: &hadou::Runtime) -> hadou::HostWaits {
    rt.context().host_waits()
}

/// Every AOV of `aovs` bit-identical in the two frames.
fn assert_same(got: &hadou::FrameOutput, want: &hadou::FrameOutput, aovs: &[Aov]) {
    for aov in aovs {
        assert!(common::same_bits(got.aov(*aov).unwrap(), want.aov(*aov).unwrap()), "{} differs", aov.name());
    }
}

/// Exposure, ambient and background set at run time (issue 23 item 4) render what the file with
/// those `[render]` values renders, bit for bit; a refused value changes nothing.
#[test]
fn exposure_ambient_and_background_change_as_the_file_would() {
    let head = "[camera]\nposition = [0, 1, 6]\nlook_at = [0, 0, 0]\n[[mesh]]\nname = \"box\"\nkind = \"cube\"\n\
                [[instance]]\nmesh = \"box\"\ntransform = [{ rotate = { angle_deg = 30, axis = [1, 1, 0] } }]\n\
                [[light]]\ndirection = [-0.3, -1, -0.5]\n";
    let mut request = FrameRequest::new(48, 40);
    request.aovs = vec![Aov::Hdr];
    let render_file = |render: &str| {
        let mut rt = common::runtime();
        rt.load_scene(common::parse(&format!("[render]\n{render}\n{head}"))).unwrap();
        let frame = rt.render(&request).unwrap();
        rt.finish();
        frame
    };
    let mut live = common::runtime();
    live.load_scene(common::parse(head)).unwrap();
    let before = live.render(&request).unwrap();
    let r = live.renderer();
    let (ambient, background) = (DVec3::new(0.2, 0.1, 0.05), DVec3::new(0.3, 0.4, 0.9));
    r.set_ambient(ambient).unwrap();
    r.set_background(background).unwrap();
    r.set_exposure(hadou::Exposure::Ev100(-1.5)).unwrap();
    for bad in [f64::NAN, -1.0, 7e4] {
        assert!(matches!(r.set_ambient(DVec3::splat(bad)), Err(Error::InvalidUpdate { .. })), "{bad}");
        assert!(matches!(r.set_background(DVec3::splat(bad)), Err(Error::InvalidUpdate { .. })), "{bad}");
    }
    for bad in
        [hadou::Exposure::Ev100(121.0), hadou::Exposure::Linear(0.0), hadou::Exposure::Linear(f64::INFINITY)]
    {
        assert!(matches!(r.set_exposure(bad), Err(Error::InvalidUpdate { .. })), "{bad:?}");
    }
    let after = live.render(&request).unwrap();
    let want = render_file("ambient = [0.2, 0.1, 0.05]\nbackground = [0.3, 0.4, 0.9]\nexposure_ev100 = -1.5");
    assert_same(&after, &want, &[Aov::Hdr]);
    assert_eq!(after.color, want.color, "the tonemapped colour too");
    assert_ne!(before.color, after.color, "the change shows");
    live.renderer().set_exposure(hadou::Exposure::Linear(0.5)).unwrap();
    let linear = live.render(&request).unwrap();
    let want = render_file("ambient = [0.2, 0.1, 0.05]\nbackground = [0.3, 0.4, 0.9]\nexposure = 0.5");
    assert_eq!(linear.color, want.color);
    live.finish();
}
