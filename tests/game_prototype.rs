//! The game prototype's frame loop, headless (no window, no swapchain: the game renders into its
//! own offscreen image), two frames in flight, for N frames under validation + synchronization
//! validation: the player charges a wave, fires it past the slime at the translucent target. Every
//! frame's energy AOV is checked against the f64 integral of the wave its game state set.

mod common;

#[path = "../examples/game_prototype/game.rs"]
mod game;
#[path = "../examples/game_prototype/gpu.rs"]
mod gpu;
#[path = "../examples/game_prototype/painter.rs"]
mod painter;
#[path = "../examples/game_prototype/slime_sim.rs"]
mod slime_sim;
#[path = "../examples/game_prototype/taa.rs"]
mod taa;

use ash::vk;
use game::{Game, Input};
use hadou::effects::energy_wave::{line_integral, WaveParams};
use hadou::testing::Comparison;
use hadou::Aov;

/// Compares each pixel's energy with the f64 closed form up to the GPU's own distance (the game's
/// imported depth, or hadou's surfaces), into `energy_cmp` (no pixel when no wave was alive: then
/// there must be no energy AOV). Relative error where the closed form is positive, bound 1e-4,
/// gpu_energy_wave's: f32 pixel rays (≈ 3e-7) enter H only logarithmically, and the closed form
/// is a few f32 ulps. Where it is 0 (off the wave) the GPU's energy itself is the error, same bound.
fn check_energy(frame: &game::OffscreenFrame, e: vk::Extent2D, energy_cmp: &mut Comparison) {
    check_view_energy(frame, 0, &game::camera(), e, energy_cmp);
}

/// As `check_energy`, for view `view` of the frame, seen by `camera` at `e`.
fn check_view_energy(
    frame: &game::OffscreenFrame,
    view: usize,
    camera: &painter::GameCamera,
    e: vk::Extent2D,
    energy_cmp: &mut Comparison,
) {
    let aov = |a: Aov| frame.views[view].iter().find(|(x, _)| *x == a).map(|(_, img)| &img.data);
    // The wave of the state this frame was rendered from (it finished two frames later); with no
    // wave the energy pass did not run and the AOV was not produced.
    let Some(w) = frame.state.wave_desc() else {
        assert!(aov(Aov::Energy).is_none(), "no wave at t={}, yet an energy AOV", frame.state.time);
        return;
    };
    let (energy, distance) = (aov(Aov::Energy).expect("a wave: energy"), aov(Aov::Depth).unwrap());
    let params = WaveParams {
        origin: w.origin,
        direction: w.direction.normalize(),
        a: w.a,
        b: w.b,
        core: 0.05,
        length: w.length,
    };
    let cam = camera.for_hadou();
    let t = frame.state.time;
    for y in 0..e.height {
        for x in 0..e.width {
            let i = (y * e.width + x) as usize;
            let (o, u) = cam.pixel_ray(x, y, e.width, e.height);
            // A GPU distance, clamped to the far plane where nothing was hit (+∞): a NaN would be
            // clamped too, so it fails here.
            assert!(!distance[i].is_nan(), "t={t} ({x}, {y}): a NaN distance");
            let reference = line_integral(&params, o, u, (distance[i] as f64).min(cam.far));
            let at = format_args!("t={t} ({x}, {y})");
            if reference > 0.0 {
                energy_cmp.rel(at, energy[i] as f64, reference);
            } else {
                energy_cmp.abs(at, energy[i] as f64, reference);
            }
        }
    }
}

#[test]
fn headless_game_loop_charges_fires_and_hits() {
    let vk =
        gpu::GameVk::new(true, &[], &[], &|_, _, _, _| true).unwrap_or_else(|e| panic!("game device: {e}"));
    let mut g = Game::new(vk).unwrap();
    let e = vk::Extent2D { width: 64, height: 40 };
    let dt = 0.1;
    let mut energy_cmp = Comparison::new("energy AOV vs f64 integral");
    let (mut energy_sums, mut finished) = (Vec::new(), Vec::new());
    // 8 frames holding Space, then released: the shot flies until it passes the target.
    for frame_index in 0..26 {
        let input = Input { charge: frame_index < 8, right: frame_index % 5 == 0, ..Input::default() };
        g.update(&input, dt).unwrap();
        if frame_index == 7 {
            assert!(g.state.charge > 0.5 && g.state.shot.is_none(), "{:?}", g.state);
        }
        if frame_index == 8 {
            assert!(g.state.shot.is_some() && g.state.charge == 0.0, "released: fired");
        }
        // Two frames in flight: a frame is read when its slot comes round again.
        let done = g.offscreen_submit(e, &[Aov::Energy, Aov::Depth]).unwrap();
        finished.extend(done);
    }
    finished.extend(g.offscreen_finish().unwrap());
    assert_eq!(finished.len(), 26);
    for frame in &finished {
        check_energy(frame, e, &mut energy_cmp);
        let energy = frame.aovs().iter().find(|(a, _)| *a == Aov::Energy).map(|(_, img)| &img.data);
        energy_sums.push(energy.map_or(0.0, |e| e.iter().map(|&v| v as f64).sum::<f64>()));
        assert!(frame.color.iter().any(|&c| c > 0), "the frame is not black");
    }
    println!("energy per frame {energy_sums:.3?}");
    // Charging grows a, b and the beam: more energy every frame while Space is held.
    assert!(energy_sums[..8].windows(2).all(|w| w[1] > w[0]), "{energy_sums:?}");
    assert_eq!(g.state.hits, 1, "the shot reached the target: {:?}", g.state);
    // The slime is drawn from the balls the game's compute shader wrote (no host copy).
    let (_, stats) = g.hadou.latest_stats().expect("a finished frame's counters");
    assert!(stats.counter(hadou::passes::metaballs::HITS) > 0, "the GPU-driven slime shows");
    assert_eq!(stats.counter(hadou::passes::metaballs::INVALID_BALLS), 0);
    let timings = g.hadou.latest_timings().expect("timings of a finished frame");
    let names: Vec<&str> = timings.passes.iter().map(|p| p.name.as_str()).collect();
    for pass in ["depth_import", "raster", "metaballs", "light_id", "translucency", "composite"] {
        assert!(names.contains(&pass), "{pass} missing from {names:?}");
    }
    // The shot hit and nothing is charging: the wave was despawned, its pass left the frame.
    assert!(g.state.wave_desc().is_none() && !names.contains(&"energy_wave"), "{names:?}");
    let with_wave = finished.iter().filter(|f| f.aovs().iter().any(|(a, _)| *a == Aov::Energy)).count();
    assert!(with_wave >= 10 && with_wave < finished.len(), "frames with a wave: {with_wave}");
    // Every pixel of every frame with a wave was compared.
    energy_cmp.assert_within(1e-4, with_wave * (e.width * e.height) as usize);
    let messages = g.destroy();
    let (errors, warnings) = messages.counts();
    assert!(errors == 0 && warnings == 0, "validation: {:?}", messages.texts.lock().unwrap());
}

/// 600 frames of play, two frames in flight, validation and synchronization validation on: the
/// player walks, charges, fires, the shot flies and is despawned, again and again, while the slime
/// buds and merges. Every 50th finished frame's energy is checked against the f64 integral of the
/// wave its state set (or its absence when no wave was alive).
#[test]
fn six_hundred_frames_of_play() {
    let vk =
        gpu::GameVk::new(true, &[], &[], &|_, _, _, _| true).unwrap_or_else(|e| panic!("game device: {e}"));
    let mut g = Game::new(vk).unwrap();
    let e = vk::Extent2D { width: 48, height: 30 };
    let (mut checked, mut with_wave, mut index) = (0, 0, 0usize);
    let mut energy_cmp = Comparison::new("energy AOV vs f64 integral");
    let mut check = |frame: game::OffscreenFrame| {
        if index % 50 == 0 {
            check_energy(&frame, e, &mut energy_cmp);
            checked += 1;
            with_wave += usize::from(frame.state.wave_desc().is_some());
        }
        index += 1;
    };
    for i in 0..600 {
        let input = Input { charge: i % 45 < 20, left: i % 90 >= 60, right: i % 90 < 20, reset: false };
        g.update(&input, 1.0 / 30.0).unwrap();
        if let Some(frame) = g.offscreen_submit(e, &[Aov::Energy, Aov::Depth]).unwrap() {
            check(frame);
        }
    }
    g.offscreen_finish().unwrap().into_iter().for_each(&mut check);
    assert_eq!(index, 600);
    assert!(checked == 12 && with_wave >= 3, "{checked} frames checked, {with_wave} with a wave");
    // Every pixel of every checked frame with a wave was compared.
    energy_cmp.assert_within(1e-4, with_wave * (e.width * e.height) as usize);
    assert!(g.state.hits >= 5, "shots reached the target: {}", g.state.hits);
    let messages = g.destroy();
    let (errors, warnings) = messages.counts();
    assert!(errors == 0 && warnings == 0, "validation: {:?}", messages.texts.lock().unwrap());
}

/// The game drops a glTF prop into the running world and takes it out again (`Game::toggle_prop`,
/// `P` in the window): a crate of the test's own glTF file beside the player covers more pixels
/// while it is there, and once it is taken out the frame is the frame before, bit for bit; zero
/// validation messages.
#[test]
fn a_gltf_prop_dropped_at_run_time_and_taken_out() {
    use common::gltf_writer::{temp_dir, IndexWidth, Writer};
    let dir = temp_dir("game_prop");
    let mut w = Writer::default();
    let cube = hadou::scene::procedural::cube(1.5).unwrap();
    let m = w
        .material(serde_json::json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.9, 0.6, 0.2, 1.0] } }));
    let p = w.primitive(&cube, IndexWidth::U16, true, Some(m));
    let mesh = w.mesh(vec![p]);
    let node = w.node(serde_json::json!({ "mesh": mesh, "translation": [0.0, 0.75, 0.0] }));
    w.scene_roots.push(node);
    let path = w.write_glb(&dir, "crate");

    let vk =
        gpu::GameVk::new(true, &[], &[], &|_, _, _, _| true).unwrap_or_else(|e| panic!("game device: {e}"));
    let mut g = Game::new(vk).unwrap();
    let e = vk::Extent2D { width: 64, height: 40 };
    g.update(&Input::default(), 0.0).unwrap();
    let frame = |g: &mut Game| {
        g.offscreen_submit(e, &[Aov::Normal]).unwrap();
        g.offscreen_finish().unwrap().pop().expect("a finished frame")
    };
    let surfaces = |f: &game::OffscreenFrame| {
        let normal = &f.aovs().iter().find(|(a, _)| *a == Aov::Normal).unwrap().1;
        normal.data.chunks_exact(4).filter(|n| n[3] == 1.0).count()
    };
    let before = frame(&mut g);
    assert!(g.toggle_prop(&path).unwrap(), "the prop is there");
    let with = frame(&mut g);
    assert!(
        surfaces(&with) > surfaces(&before),
        "{} vs {} surface pixels",
        surfaces(&with),
        surfaces(&before)
    );
    assert!(!g.toggle_prop(&path).unwrap(), "the prop is gone");
    let after = frame(&mut g);
    assert!(after.color == before.color, "the world without the prop draws as before it came");
    let messages = g.destroy();
    let (errors, warnings) = messages.counts();
    assert!(errors == 0 && warnings == 0, "validation: {:?}", messages.texts.lock().unwrap());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Split screen: the game draws two views side by side (the main camera left, `side_camera`
/// right) and hadou records both in one frame (`Renderer::record_views`). The left half is, bit
/// for bit, the frame the game draws at that size without split screen (same state, same
/// frames); both views' energy matches the f64 integral for their own camera; zero validation
/// messages.
#[test]
fn split_screen_draws_two_views_in_one_hadou_frame() {
    let new_game = |split: bool| {
        let vk = gpu::GameVk::new(true, &[], &[], &|_, _, _, _| true)
            .unwrap_or_else(|e| panic!("game device: {e}"));
        let mut g = Game::new(vk).unwrap();
        g.split = split;
        g
    };
    let (mut split, mut alone) = (new_game(true), new_game(false));
    let e = vk::Extent2D { width: 81, height: 40 };
    let halves = game::view_extents(e, true);
    assert_eq!((halves[0].width, halves[1].width), (40, 41));
    let mut energy_cmp = Comparison::new("energy AOV vs f64 integral, both views");
    let (mut frames, mut compared) = (Vec::new(), 0);
    for i in 0..14 {
        let input = Input { charge: i < 6, right: i % 4 == 0, ..Input::default() };
        split.update(&input, 0.1).unwrap();
        alone.update(&input, 0.1).unwrap();
        let two = split.offscreen_submit(e, &[Aov::Energy, Aov::Depth]).unwrap();
        let one = alone.offscreen_submit(halves[0], &[Aov::Energy, Aov::Depth]).unwrap();
        frames.extend(two.into_iter().zip(one));
    }
    frames.extend(split.offscreen_finish().unwrap().into_iter().zip(alone.offscreen_finish().unwrap()));
    assert_eq!(frames.len(), 14);
    for (two, one) in &frames {
        assert_eq!(two.views.len(), 2);
        // The left half, row by row, against the frame drawn alone at its size (RGBA8).
        let (w, half) = (e.width as usize * 4, halves[0].width as usize * 4);
        for y in 0..e.height as usize {
            assert!(two.color[y * w..y * w + half] == one.color[y * half..(y + 1) * half], "row {y}");
        }
        for ((a, x), (b, y)) in two.views[0].iter().zip(one.aovs()) {
            assert!(a == b && common::same_bits(x, y), "{} differs from the view drawn alone", a.name());
        }
        // The right half is the side view: not a copy of the left.
        assert!((0..e.height as usize)
            .any(|y| two.color[y * w..y * w + half] != two.color[y * w + half..y * w + 2 * half]));
        check_view_energy(two, 0, &game::camera(), halves[0], &mut energy_cmp);
        check_view_energy(two, 1, &game::side_camera(), halves[1], &mut energy_cmp);
        if two.state.wave_desc().is_some() {
            compared += (e.width * e.height) as usize;
        }
    }
    assert!(compared > 0, "a wave was alive in some frames");
    energy_cmp.assert_within(1e-4, compared);
    for g in [split, alone] {
        let messages = g.destroy();
        let (errors, warnings) = messages.counts();
        assert!(errors == 0 && warnings == 0, "validation: {:?}", messages.texts.lock().unwrap());
    }
}

/// The slime the game's compute shader moves (`SlimeSim`, f32) draws as the slime
/// `GameState::slime` gives on the host (f64, handed over by `set_metaball_group`): the same
/// pixels hit, at depths that differ only by the f32 rounding of the balls' centres.
#[test]
fn the_gpu_slime_draws_as_the_host_slime() {
    let vk =
        gpu::GameVk::new(true, &[], &[], &|_, _, _, _| true).unwrap_or_else(|e| panic!("game device: {e}"));
    let mut g = Game::new(vk).unwrap();
    let e = vk::Extent2D { width: 96, height: 60 };
    for _ in 0..7 {
        g.update(&Input::default(), 0.37).unwrap();
    }
    let aovs = [Aov::Normal, Aov::Depth];
    let gpu_slime = g.offscreen_frame(e, &aovs).unwrap();
    let slime = g.hadou.metaballs_named("slime").unwrap();
    g.hadou.set_metaball_buffer(slime, None).unwrap();
    g.hadou.set_metaball_group(slime, &g.state.slime()).unwrap();
    let host_slime = g.offscreen_frame(e, &aovs).unwrap();
    let get =
        |f: &game::OffscreenFrame, a: Aov| f.aovs().iter().find(|(x, _)| *x == a).unwrap().1.data.clone();
    let (n0, n1) = (get(&gpu_slime, Aov::Normal), get(&host_slime, Aov::Normal));
    let (d0, d1) = (get(&gpu_slime, Aov::Depth), get(&host_slime, Aov::Depth));
    let (mut differ, mut worst) = (0, 0.0f64);
    for i in 0..(e.width * e.height) as usize {
        assert_eq!(n0[4 * i + 3], n1[4 * i + 3], "pixel {i}: hit on one side only");
        if d0[i].to_bits() != d1[i].to_bits() {
            differ += 1;
            worst = worst.max(((d0[i] - d1[i]) / d1[i]).abs() as f64);
        }
    }
    println!("{differ} pixels differ in depth, by at most {worst:.1e} relative");
    // Each cast ends within 2⁻²² of its support interval (a few units at t ≈ 17: ~1e-7 relative)
    // and the centres differ by about an f32 ulp of a few units (sin in f32 against f64): 1e-5
    // leaves 10× what both together reach.
    assert!(worst <= 1e-5, "depths differ by {worst:e}");
    let messages = g.destroy();
    let (errors, warnings) = messages.counts();
    assert!(errors == 0 && warnings == 0, "validation: {:?}", messages.texts.lock().unwrap());
}

/// The game's own TAA resolve (`taa.rs`) fed hadou's motion vectors (`Aov::Motion`) follows a
/// swaying camera: a trail (a resolved pixel outside the range of the new frame's 3×3
/// neighbourhood by more than 0.02, colour the history brought from elsewhere) is measured with
/// the resolve's clamp off, so the history shows as it is. With the motion vectors it stays under
/// 2 % of the pixels after 24 frames — what is left are surfaces uncovered while they moved less
/// than the resolve's 1-pixel rejection, the pillars at the sway's turns — and at least twice as
/// many pixels trail when the same resolve takes its history in place. With the clamp on (the
/// game's default) no pixel trails. The slime moves in the game's compute shader, which writes
/// its balls' previous centres too (`DeviceBalls::previous_centres`).
#[test]
fn a_taa_resolve_fed_hadous_motion_vectors_leaves_no_trail() {
    let vk =
        gpu::GameVk::new(true, &[], &[], &|_, _, _, _| true).unwrap_or_else(|e| panic!("game device: {e}"));
    let mut g = Game::new(vk).unwrap();
    g.sway = true;
    g.hadou.set_motion_vectors(true).unwrap();
    let e = vk::Extent2D { width: 96, height: 60 };
    let taa = || taa::Taa::new(e.width, e.height);
    let (mut with, mut without, mut clamped) = (taa(), taa(), taa());
    (with.clamp, without.clamp) = (false, false);
    let (mut t_with, mut t_without, mut t_clamped) = (0, 0, 0);
    for _ in 0..24 {
        g.update(&Input::default(), 0.5).unwrap();
        let frame = g.offscreen_frame(e, &[Aov::Motion]).unwrap();
        let motion = &frame.aovs().iter().find(|(a, _)| *a == Aov::Motion).expect("motion").1.data;
        assert!(motion.iter().all(|m| m.is_finite()));
        let now = taa::to_linear(&frame.color);
        let trails = |resolved: &[[f32; 3]]| taa::ghosts(resolved, &now, e.width, e.height, 0.02);
        t_with = trails(with.resolve(&now, Some(motion)));
        t_without = trails(without.resolve(&now, None));
        t_clamped = trails(clamped.resolve(&now, Some(motion)));
    }
    let pixels = (e.width * e.height) as usize;
    println!(
        "trail pixels: {t_with} with motion vectors, {t_without} without, {t_clamped} clamped, of {pixels}"
    );
    assert!(t_with * 50 <= pixels, "a trail with motion vectors: {t_with} pixels");
    assert!(
        t_without >= 2 * t_with.max(20),
        "the test would see a trail: {t_without} without motion vectors"
    );
    assert_eq!(t_clamped, 0);
    let messages = g.destroy();
    let (errors, warnings) = messages.counts();
    assert!(errors == 0 && warnings == 0, "validation: {:?}", messages.texts.lock().unwrap());
}
