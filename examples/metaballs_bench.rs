//! The metaball pass's cost and Bézier-clipping statistics on the `generate` swarm of
//! assets/scenes/metaballs_4096.toml with 16 … 16,384 balls at 256² and 512², then the
//! speed-against-error table at 256² with 4,096 balls: Bézier clipping with coarser tolerances
//! and the sphere-tracing baseline with several step budgets, each compared per pixel with the
//! f64 reference (`compare_metaballs`). Numbers for docs/PERFORMANCE.md; not a timed test.
//!
//! LP_NUM_THREADS=2 cargo run --release --example metaballs_bench [COUNT:SIZE ...] [variants] [frames=N]
//!
//! With arguments only the named cases run (e.g. `4096:256`), and the variant table only when
//! `variants` is among them; each time is the p50 over N frames (default 5).

use hadou::effects::metaballs::CastMethod;
use hadou::effects::metaballs_compare::{compare_metaballs, MetaballFrame};
use hadou::passes::metaballs::{CLIP_STEPS, CLIP_STEPS_MAX, DROPPED, HITS};
use hadou::scene::Scene;
use hadou::{Aov, FrameRequest, FrameStats, Runtime, RuntimeOptions};

/// The metaball pass's p50 time over `frames` frames (after a warm-up frame for the shader JIT)
/// and the last frame's statistics.
fn measure(
    rt: &mut Runtime,
    scene: &Scene,
    size: u32,
    frames: usize,
) -> Result<(f64, FrameStats), Box<dyn std::error::Error>> {
    rt.load_scene(scene.clone())?;
    let mut req = FrameRequest::new(size, size);
    req.color = false;
    rt.render(&req)?;
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..frames {
        let s = rt.render(&req)?.stats;
        times.push(s.passes.iter().find(|p| p.name == "metaballs").map_or(0.0, |p| p.gpu_ms));
        last = Some(s);
    }
    times.sort_by(f64::total_cmp);
    Ok((times[frames / 2], last.ok_or("no frame measured")?))
}

fn steps_per_hit(s: &FrameStats) -> f64 {
    s.counter(CLIP_STEPS) as f64 / s.counter(HITS).max(1) as f64
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::path::Path::new("assets/scenes/metaballs_4096.toml");
    let text = std::fs::read_to_string(path)?;
    let mut rt = Runtime::new(&RuntimeOptions::from_env())?;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let frames = match args.iter().find_map(|a| a.strip_prefix("frames=")) {
        Some(n) => {
            n.parse::<usize>().ok().filter(|&n| n > 0).ok_or("frames=N: N must be a positive integer")?
        }
        None => 5,
    };
    let picked: Vec<String> = args.into_iter().filter(|a| !a.starts_with("frames=")).collect();
    let pick = |case: &str| picked.is_empty() || picked.iter().any(|p| p == case);
    let with_count = |count: u32| {
        hadou::scene::parse_scene(&text.replace("count = 4096", &format!("count = {count}")), path)
    };
    println!("device: {}", rt.device_info().name);
    println!(
        "| balls | size | metaballs ms (p50 of {frames}) | hit pixels | clip steps per hit | max | dropped |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|");
    for count in [16, 256, 4096, 16384] {
        let scene = with_count(count)?;
        for size in [256u32, 512] {
            if !pick(&format!("{count}:{size}")) {
                continue;
            }
            let (ms, s) = measure(&mut rt, &scene, size, frames)?;
            println!(
                "| {count} | {size}² | {ms:.2} | {} | {:.2} | {} | {} |",
                s.counter(HITS),
                steps_per_hit(&s),
                s.counter(CLIP_STEPS_MAX),
                s.counter(DROPPED)
            );
        }
    }
    if !pick("variants") {
        return Ok(());
    }

    // Speed against error: 4,096 balls at 256², every pixel against the f64 reference.
    let size = 256;
    let base = with_count(4096)?;
    let mut bare = base.clone();
    bare.metaballs_mut().clear();
    rt.load_scene(bare)?;
    let mut req = FrameRequest::new(size, size);
    req.color = false;
    req.aovs = vec![Aov::Depth];
    let raster = rt.render(&req)?;
    let raster_depth = raster.aov(Aov::Depth).ok_or("no depth AOV")?;
    println!();
    println!(
        "| method | ms (p50 of {frames}) | hit pixels | steps per hit | max | dropped | band px | mismatch % | \
         depth max rel | depth p99 rel | normal max ° |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut methods = vec![("bezier (default)".to_string(), CastMethod::default())];
    for tolerance in [1e-3, 1e-2, 1e-1] {
        methods.push((format!("bezier, tolerance {tolerance}"), CastMethod::Bezier { tolerance }));
    }
    for steps in [16, 32, 64, 128, 256] {
        methods.push((format!("sphere_trace, steps {steps}"), CastMethod::SphereTrace { steps }));
    }
    for (label, method) in methods {
        let mut scene = base.clone();
        scene.metaballs_mut().iter_mut().for_each(|g| g.method = method);
        let (ms, s) = measure(&mut rt, &scene, size, frames)?;
        req.aovs = vec![Aov::Depth, Aov::Normal];
        let frame = rt.render(&req)?;
        let aovs = MetaballFrame {
            depth: frame.aov(Aov::Depth).ok_or("no depth AOV")?,
            raster_depth,
            normal: frame.aov(Aov::Normal),
        };
        let e = compare_metaballs(&scene, 0.0, aovs)?;
        println!(
            "| {label} | {ms:.2} | {} | {:.2} | {} | {} | {} | {:.3} | {:.1e} | {:.1e} | {:.3} |",
            s.counter(HITS),
            steps_per_hit(&s),
            s.counter(CLIP_STEPS_MAX),
            s.counter(DROPPED),
            e.band,
            e.mismatch_percent,
            e.depth_max_rel,
            e.depth_p99_rel,
            e.normal_max_deg
        );
    }
    Ok(())
}
