//! hadou embedded in a wgpu application: wgpu owns the instance, device, queue, textures and
//! command encoders; its Vulkan objects are taken through wgpu's hal interop, and hadou records
//! into wgpu's frame (the game prototype's world: wgpu draws the floor, player and pillars, hadou
//! the wave, the translucent target and the slime over them, depth and colour shared).
//!
//! - `cargo run --release --example wgpu_host`: a window (HADOU_VALIDATION=1 turns validation on,
//!   GAME_FRAMES=N quits after N frames).
//! - `-- --headless [--size 640x360] [--frames 60] [--out out/wgpu_host.png]`: no window; the last
//!   frame is written as PNG.
//! - `-- --bench [--size 640x360] [--frames 60] [--rounds 3]`: frame cost of this host against the
//!   ash game prototype, same world, same size, same process (docs/PERFORMANCE.md).

#[path = "../game_prototype/app.rs"]
mod app;
mod bench;
mod boxes;
mod device;
#[path = "../game_prototype/game.rs"]
mod game;
#[path = "../game_prototype/gpu.rs"]
mod gpu;
mod headless;
mod host;
#[path = "../game_prototype/painter.rs"]
mod painter;
mod readback;
#[path = "../game_prototype/slime_sim.rs"]
mod slime_sim;
mod window;
mod world;

/// `--name value` of the command line, parsed.
fn arg<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> Result<T, String> {
    match args.iter().position(|a| a == name) {
        None => Ok(default),
        Some(i) => args.get(i + 1).and_then(|v| v.parse().ok()).ok_or(format!("{name}: a value")),
    }
}

fn size(args: &[String]) -> Result<(u32, u32), String> {
    let text: String = arg(args, "--size", "640x360".to_string())?;
    let (w, h) = text.split_once('x').ok_or("--size WxH")?;
    Ok((w.parse().map_err(|_| "--size WxH")?, h.parse().map_err(|_| "--size WxH")?))
}

fn run(args: &[String]) -> Result<(), String> {
    if args.iter().any(|a| a == "--bench") {
        bench::run(size(args)?, arg(args, "--frames", 60)?, arg(args, "--rounds", 3)?)
    } else if args.iter().any(|a| a == "--headless") {
        let out: String = arg(args, "--out", "out/wgpu_host.png".to_string())?;
        headless::run(size(args)?, arg(args, "--frames", 60)?, out.as_ref())
    } else {
        window::run()
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Err(e) = run(&args) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
