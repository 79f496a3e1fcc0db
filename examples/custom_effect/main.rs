//! Write your own effect: a height fog added to hadou from outside the library (fog.rs, fog.comp)
//! and rendered for a few frames while the game thickens it through its run-time handle.
//!
//! `cargo run --example custom_effect -- [out.png]` (default out/custom_effect.png).

mod fog;

use fog::{Fog, HeightFog, FOG_TRANSMITTANCE};
use hadou::effect::Effects;
use hadou::{Aov, FrameRequest, Runtime, RuntimeOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "out/custom_effect.png".into());
    // One registration: hadou's effects and the fog after them.
    let effects = Effects::builtin().with(HeightFog::default())?;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/custom_effect/foggy.toml");
    let scene = hadou::scene::load_scene_with(&path, &effects)?;
    let (width, height) = (scene.render.width, scene.render.height);
    let options = RuntimeOptions { effects, ..RuntimeOptions::from_env() };
    let mut runtime = Runtime::new(&options)?;
    runtime.load_scene(scene)?;
    let mut request = FrameRequest::new(width, height);
    request.aovs = vec![Aov::Effect(&FOG_TRANSMITTANCE), Aov::Depth];
    let mut frame = None;
    for i in 0..4 {
        // The game's hold on the fog: denser every frame.
        runtime.renderer().update_effect(|fog: &mut Fog| fog.density = 0.012 * f64::from(i + 1))?;
        frame = Some(runtime.render(&request)?);
    }
    let frame = frame.expect("four frames were rendered");
    // The centre pixel against the f64 twin (tests/custom_effect.rs checks every pixel).
    let scene = runtime.scene().expect("loaded");
    let fog = scene.effects.get::<Fog>().expect("the fog is in the scene");
    let (x, y) = (width / 2, height / 2);
    let (camera, ray) = scene.camera.pixel_ray(x, y, width, height);
    let far = scene.camera.far;
    let len = f64::from(frame.aov(Aov::Depth).expect("requested").at(x, y, 0)).min(far);
    let gpu = frame.aov(Aov::Effect(&FOG_TRANSMITTANCE)).expect("requested").at(x, y, 0);
    println!(
        "centre pixel: transmittance {gpu} on the GPU, {:.7} by the f64 twin",
        fog.transmittance(camera, ray, len)
    );
    let rgba = frame.color.expect("colour was requested");
    if let Some(dir) = std::path::Path::new(&out).parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    image::save_buffer(&out, &rgba, width, height, image::ColorType::Rgba8)?;
    println!("{out}: {width}x{height}, passes {}", runtime.pass_names().join(", "));
    let counts = runtime.validation_counts();
    if counts.errors + counts.warnings > 0 {
        return Err(format!("validation: {counts:?} (HADOU_VALIDATION=1 turns it on)").into());
    }
    Ok(())
}
