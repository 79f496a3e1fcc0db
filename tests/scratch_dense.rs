mod common;
use hadou::passes::metaballs::*;
use hadou::FrameRequest;
#[test]
fn scratch() {
    let mut scene = common::load("assets/scenes/metaballs_4096.toml");
    let n: usize = std::env::var("N").map(|v| v.parse().unwrap()).unwrap_or(10000);
    scene.metaballs[0].balls.truncate(n);
    let mut rt = common::runtime();
    rt.load_scene(scene).unwrap();
    let t = std::time::Instant::now();
    let f = rt.render(&FrameRequest::new(256, 256)).unwrap();
    println!(
        "time {:?} hits {} rounds {} walks {} streamed {} dropped {}",
        t.elapsed(),
        f.stats.counter(HITS),
        f.stats.counter(CLIP_STEPS),
        f.stats.counter(CLIP_STEPS_MAX),
        f.stats.counter(STREAMED),
        f.stats.counter(DROPPED)
    );
}
