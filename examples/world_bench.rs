//! What a living world costs: the game prototype's frame headless for N frames with 2 frames in
//! flight, once with the world changing every frame (the player walks, the wave is charged, fired,
//! flies and is despawned, the slime buds and merges) and once with the same world held still;
//! then what spawning costs — the first wave / metaball group (the pass is built: shaders compiled,
//! pipeline made) and a later one (the pass is parked, built: nothing to compile); then run-time
//! bakes with an empty bake cache: the glTF prop (translucent glass and liquid) dropped into the
//! changing world, then a translucent torus at 128³ — every `record_frame`'s CPU time until their
//! tables are baked in the background and put in use: before, while baking, at each switch-over
//! and after.
//!
//! LP_NUM_THREADS=1 cargo run --release --example world_bench -- [--frames N] [--size WxH]

#[path = "common/bench_util.rs"]
mod bench_util;
#[path = "game_prototype/game.rs"]
mod game;
#[path = "game_prototype/gpu.rs"]
mod gpu;
#[path = "game_prototype/painter.rs"]
mod painter;
#[path = "game_prototype/slime_sim.rs"]
mod slime_sim;

use std::time::Instant;

use ash::vk;
use bench_util::{arg, percentile};
use game::{Game, Input};
use glam::{DMat4, DVec3};
use hadou::scene::{MaterialKind, ThicknessMode, MAX_VOXEL_RES};
use hadou::{Ball, MetaballsDesc, WaveDesc};

/// The input of frame `i` of the changing run: walk, charge for a second, release, repeat.
fn input(i: usize) -> Input {
    Input { charge: i % 60 < 30, right: i % 40 < 20, left: i % 40 >= 20, reset: false }
}

fn main() -> Result<(), String> {
    let frames: usize = arg("--frames").unwrap_or(600);
    let size: String = arg("--size").unwrap_or_else(|| "640x360".into());
    let (w, h) = size
        .split_once('x')
        .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))
        .ok_or("--size WxH")?;
    let extent = vk::Extent2D { width: w, height: h };
    println!("{w}×{h}, {frames} frames each, 2 frames in flight\n");
    println!("| world | frame p50 | p95 | p99 | frames/s | update p50 (game + hadou's update calls) | hadou GPU frame p50 | `record_frame` CPU p50 / max |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    let mut p50s = Vec::new();
    for changing in [false, true] {
        let vk = gpu::GameVk::new(false, &[], &[], &|_, _, _, _| true)?;
        let mut g = Game::new(vk)?;
        // The still world: charged and held, time stopped (the same wave, slime and camera).
        g.update(&Input { charge: true, ..Input::default() }, 0.9)?;
        let mut times = Vec::with_capacity(frames);
        let mut updates = Vec::with_capacity(frames);
        let mut records = Vec::with_capacity(frames);
        let (mut gpu, mut seen) = (Vec::new(), None);
        let start = Instant::now();
        let mut last = Instant::now();
        for i in 0..frames + 10 {
            let t = Instant::now();
            if changing {
                g.update(&input(i), 1.0 / 30.0)?;
            } else {
                g.update(&Input { charge: true, ..Input::default() }, 0.0)?;
            }
            if i >= 10 {
                updates.push(t.elapsed().as_secs_f64() * 1e3);
            }
            g.offscreen_submit(extent, &[])?;
            if i >= 10 {
                records.push(g.last_record_cpu_ms);
            }
            if let Some(t) = g.hadou.latest_timings().filter(|t| i >= 10 && Some(t.frame) != seen) {
                seen = Some(t.frame);
                gpu.push(t.gpu_frame_ms);
            }
            let now = Instant::now();
            if i >= 10 {
                times.push((now - last).as_secs_f64() * 1e3);
            }
            last = now;
        }
        g.offscreen_finish()?;
        let fps = (frames + 10) as f64 / start.elapsed().as_secs_f64();
        let p = |q| percentile(&times, q);
        let label = if changing { "changing every frame" } else { "still" };
        let u = percentile(&updates, 0.5);
        let gp = percentile(&gpu, 0.5);
        let (r50, rmax) = (percentile(&records, 0.5), records.iter().copied().fold(0.0, f64::max));
        println!(
            "| {label} | {:.2} ms | {:.2} ms | {:.2} ms | {fps:.1} | {u:.3} ms | {gp:.2} ms | {r50:.3} / {rmax:.3} ms |",
            p(0.5),
            p(0.95),
            p(0.99)
        );
        p50s.push(p(0.5));
        let messages = g.destroy();
        let (errors, warnings) = messages.counts();
        if errors + warnings > 0 {
            return Err(format!("validation: {errors} errors, {warnings} warnings"));
        }
    }
    println!("\nchanging / still at p50: {:.3}\n", p50s[1] / p50s[0]);

    // Spawn costs on a world with neither effect (never built in this renderer).
    let vk = gpu::GameVk::new(false, &[], &[], &|_, _, _, _| true)?;
    let mut g = Game::new(vk)?;
    let hadou = &mut g.hadou;
    let bare = "[camera]\nposition = [0, 2, 9]\nlook_at = [0, 0, 0]\n[[material]]\nname = \"slime\"\n";
    let bare = hadou::scene::parse_scene(bare, "bare.toml".as_ref()).map_err(|e| e.to_string())?;
    hadou.load_scene(bare).map_err(|e| e.to_string())?;
    let wave = WaveDesc {
        origin: DVec3::new(-3.0, 1.0, 0.0),
        direction: DVec3::X,
        a: 1.0,
        b: 0.5,
        core: 0.05,
        length: 3.0,
        color: DVec3::ONE,
        intensity: 0.1,
        cutoff: 0.0,
    };
    let group = MetaballsDesc {
        balls: vec![Ball { centre: DVec3::ZERO, radius: 1.0, q: 1.0 }],
        threshold: 0.5,
        material: "slime".into(),
        transform: DMat4::from_translation(DVec3::new(-2.0, 1.0, 1.0)),
    };
    println!("| spawn | cold (pass built) ms | warm (pass parked) ms |");
    println!("|---|---:|---:|");
    let time = |f: &mut dyn FnMut() -> Result<(), hadou::Error>| -> Result<f64, String> {
        let t = Instant::now();
        f().map_err(|e| e.to_string())?;
        Ok(t.elapsed().as_secs_f64() * 1e3)
    };
    let mut ids = None;
    let cold = time(&mut || {
        ids = Some(hadou.spawn_wave(&wave)?);
        Ok(())
    })?;
    hadou.despawn_wave(ids.take().unwrap()).map_err(|e| e.to_string())?;
    let warm = time(&mut || {
        ids = Some(hadou.spawn_wave(&wave)?);
        Ok(())
    })?;
    println!("| wave | {cold:.2} | {warm:.2} |");
    let mut gid = None;
    let cold = time(&mut || {
        gid = Some(hadou.spawn_metaballs(&group)?);
        Ok(())
    })?;
    hadou.despawn_metaballs(gid.take().unwrap()).map_err(|e| e.to_string())?;
    let warm = time(&mut || {
        gid = Some(hadou.spawn_metaballs(&group)?);
        Ok(())
    })?;
    println!("| metaball group | {cold:.2} | {warm:.2} |");
    g.destroy();
    run_time_bake(extent)
}

/// Run-time bakes with an empty bake cache, in the changing world: the glTF prop (translucent
/// glass and liquid, the default 48³) dropped at frame 30, then, once its tables are in use, a
/// translucent torus at the largest `voxel_res` (128³). Each drop's frames go on until every table
/// it needs is in use, then 30 more. Prints `record_frame`'s CPU time before each drop, while
/// baking, at each switch-over (a frame that put a finished bake in use) and after.
fn run_time_bake(extent: vk::Extent2D) -> Result<(), String> {
    let cache = std::env::temp_dir().join(format!("hadou-world-bench-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&cache);
    // Before any renderer exists (no bake thread reads the environment yet).
    std::env::set_var("HADOU_CACHE_DIR", &cache);
    let vk = gpu::GameVk::new(false, &[], &[], &|_, _, _, _| true)?;
    let mut g = Game::new(vk)?;
    let mut frame = 0;
    // The first frames build the scene's passes (as `load_scene`'s first frame always does).
    let warmup = frames(&mut g, extent, &mut frame, 10)?;
    println!("\nRun-time bakes in the changing world, bake cache empty; `record_frame` CPU time:\n");
    println!("| frames | count | p50 | max |");
    println!("|---|---:|---:|---:|");
    row("the first 10 (the scene's passes built)", &warmup);
    let mut all = Vec::new();
    let before = frames(&mut g, extent, &mut frame, 20)?;
    row("before the prop", &before);
    all.extend(before);
    let t = Instant::now();
    g.toggle_prop(std::path::Path::new(game::PROP))?;
    let prop_ms = t.elapsed().as_secs_f64() * 1e3;
    all.extend(until_baked(&mut g, extent, &mut frame, "the prop (spawn_gltf, 48³)", prop_ms)?);
    let torus = hadou::scene::procedural::torus(0.8, 0.3, 48, 24).map_err(|e| e.to_string())?;
    let t = Instant::now();
    let v = |p: &[[f32; 3]]| p.iter().map(|&a| glam::Vec3::from(a)).collect::<Vec<_>>();
    let (hadou, err) = (&mut g.hadou, |e: hadou::Error| e.to_string());
    let mesh = hadou
        .spawn_mesh("torus", &v(&torus.positions), Some(&v(&torus.normals)), &torus.indices)
        .map_err(err)?;
    let sigma = glam::DVec3::new(0.8, 1.2, 2.0);
    let kind = MaterialKind::Translucent { sigma, voxel_res: MAX_VOXEL_RES, thickness: ThicknessMode::Lut };
    let jade = hadou.spawn_material("torus jade", glam::Vec3::new(0.3, 0.8, 0.5), kind).map_err(err)?;
    let at = DMat4::from_translation(DVec3::new(game::PLAYER_X - 1.5, 1.0, 1.0));
    hadou.spawn_instance_of(mesh, jade, at).map_err(err)?;
    let torus_ms = t.elapsed().as_secs_f64() * 1e3;
    all.extend(until_baked(&mut g, extent, &mut frame, "a torus at 128³", torus_ms)?);
    g.offscreen_finish()?;
    println!("\nmax record_frame CPU time after the first 10 frames: {:.3} ms", max(&all));
    let messages = g.destroy();
    let _ = std::fs::remove_dir_all(&cache);
    let (errors, warnings) = messages.counts();
    if errors + warnings > 0 {
        return Err(format!("validation: {errors} errors, {warnings} warnings"));
    }
    Ok(())
}

/// `n` frames of the changing world; each one's `record_frame` CPU time.
fn frames(g: &mut Game, extent: vk::Extent2D, frame: &mut usize, n: usize) -> Result<Vec<f64>, String> {
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        g.update(&input(*frame), 1.0 / 30.0)?;
        g.offscreen_submit(extent, &[])?;
        out.push(g.last_record_cpu_ms);
        *frame += 1;
    }
    Ok(out)
}

/// Frames after a spawn (which took `spawn_ms`) until no bake is in progress, then 30 more;
/// prints their rows and returns every frame's `record_frame` CPU time.
fn until_baked(
    g: &mut Game,
    extent: vk::Extent2D,
    frame: &mut usize,
    label: &str,
    spawn_ms: f64,
) -> Result<Vec<f64>, String> {
    let start = Instant::now();
    let (mut baking, mut switches) = (Vec::new(), Vec::new());
    let mut in_progress = g.hadou.bakes_in_progress().len();
    while in_progress > 0 {
        if start.elapsed().as_secs() > 600 {
            return Err(format!("{label}: bakes not in use after 10 minutes"));
        }
        let ms = frames(g, extent, frame, 1)?[0];
        let now = g.hadou.bakes_in_progress().len();
        if now < in_progress {
            switches.push((*frame - 1, ms));
        } else {
            baking.push(ms);
        }
        in_progress = now;
    }
    let baked_s = start.elapsed().as_secs_f64();
    let after = frames(g, extent, frame, 30)?;
    row(&format!("{label}: the spawn calls"), &[spawn_ms]);
    row(&format!("{label}: while baking and copying ({baked_s:.2} s)"), &baking);
    for (i, ms) in &switches {
        row(&format!("{label}: switch-over (frame {i})"), &[*ms]);
    }
    row(&format!("{label}: after"), &after);
    Ok([baking, after, switches.iter().map(|s| s.1).collect()].concat())
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(0.0, f64::max)
}

fn row(label: &str, v: &[f64]) {
    if !v.is_empty() {
        println!("| {label} | {} | {:.3} ms | {:.3} ms |", v.len(), percentile(v, 0.5), max(v));
    }
}
