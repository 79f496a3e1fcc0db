//! The energy wave with a tolerance on the GPU against the f64 closed form: on the hard-ray scenes
//! (a singular core in view, a beam seen along its length, far from the origin, clipped by
//! depth, several waves) no pixel's H is off by more than the tolerance (plus the exact pass's
//! own f32 bound) at 1e-2, 1e-3 and 1e-4, and tiles were really interpolated. Lavapipe with
//! validation on.

mod common;

use hadou::passes::energy_wave::{TILES_EXACT, TILES_INTERPOLATED};
use hadou::reference::{line_integral, wave_params};
use hadou::scene::Scene;
use hadou::testing::Comparison;
use hadou::{Aov, FrameRequest};

/// The exact pass's own bound per pixel (its tests' largest relative error, tests/gpu_energy_wave.rs):
/// the corners an interpolated pixel is made from carry it too.
const EXACT: f64 = 1e-4;

/// A wall behind everything (depth clipping and a silhouette edge) and a camera.
fn scene(camera: &str, waves: &str) -> Scene {
    common::parse(&format!(
        r#"
        [camera]
        {camera}
        fov_y_deg = 50
        far = 400
        [[mesh]]
        name = "wall"
        kind = "plane"
        size = 30
        [[mesh]]
        name = "block"
        kind = "cube"
        size = 2
        [[instance]]
        mesh = "wall"
        transform = [{{ rotate = {{ angle_deg = 75, axis = [1, 0.3, 0] }} }}, {{ translate = [0, 0, -4] }}]
        [[instance]]
        mesh = "block"
        transform = [{{ translate = [2, -1, 1] }}]
        {waves}
        "#
    ))
}

/// The hard-ray scenes: (what, scene).
fn hard_scenes() -> Vec<(&'static str, Scene)> {
    vec![
        (
            "singular core in view (ε = 0), endless beam",
            scene(
                "position = [0, 1, 12]\nlook_at = [0, 0, 0]",
                "[[wave]]\norigin = [0, 0, 0]\ndirection = [1, 0.2, 0]\na = 60\nb = 30",
            ),
        ),
        (
            "beam seen along its length (grazing)",
            scene(
                "position = [-20, 0.3, 0.2]\nlook_at = [0, 0, 0]",
                "[[wave]]\norigin = [-5, 0, 0]\ndirection = [1, 0, 0]\na = 10\nb = 40\nlength = 12",
            ),
        ),
        (
            "far from the origin",
            scene(
                "position = [100000, 100000, 100012]\nlook_at = [100000, 100000, 100000]",
                "[[wave]]\norigin = [100001, 100000, 100000]\ndirection = [0, 1, 0]\na = 20\nb = 20\ncore = 0.2",
            ),
        ),
        (
            "several waves, soft and hard cores, clipped by the wall",
            scene(
                "position = [3, 4, 14]\nlook_at = [0, 0, 0]",
                "[[wave]]\norigin = [-3, 0, 0]\ndirection = [1, 0, 0]\na = 30\nb = 10\nlength = 6\n\
                 [[wave]]\norigin = [2, 2, -6]\ndirection = [0, 0, 1]\na = 5\nb = 50\ncore = 0.5\n\
                 [[wave]]\norigin = [0, -3, 2]\ndirection = [0, 1, 0.1]\na = 80",
            ),
        ),
    ]
}

/// Renders `scene` with every wave at `tolerance` and compares each pixel's H with f64 up to the
/// GPU's own depth; returns the tiles (interpolated, exact).
fn check(what: &str, scene: &Scene, tolerance: f64, size: (u32, u32)) -> (u64, u64) {
    let mut scene = scene.clone();
    for wave in scene.waves_mut() {
        wave.tolerance = Some(tolerance);
    }
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let (w, h) = size;
    let mut req = FrameRequest::new(w, h);
    req.aovs = vec![Aov::Energy, Aov::Depth];
    let frame = rt.render(&req).unwrap();
    rt.finish();
    let energy = &frame.aov(Aov::Energy).unwrap().data;
    let depth = &frame.aov(Aov::Depth).unwrap().data;
    let waves: Vec<_> = scene.waves().iter().map(|wv| wave_params(&wv.at(0.0))).collect();
    let cam = &scene.camera;
    // |H̃ − H| ≤ τ·H for the interpolation (the bound's guarantee on the corners' values) plus
    // the corners' own f32 error, which the convex combination carries over: (τ + EXACT)(1 + τ).
    let bound = (tolerance + EXACT) * (1.0 + tolerance);
    let mut c = Comparison::new(format!("{what}, tolerance {tolerance:e}: energy vs f64, relative"));
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (o, u) = cam.pixel_ray(x, y, w, h);
            let l = (depth[i] as f64).min(cam.far);
            let reference: f64 = waves.iter().map(|p| line_integral(p, o, u, l)).sum();
            c.rel(format_args!("({x}, {y})"), energy[i] as f64, reference);
        }
    }
    c.assert_within(bound, (w * h) as usize);
    (frame.stats.counter(TILES_INTERPOLATED), frame.stats.counter(TILES_EXACT))
}

#[test]
fn hard_scenes_stay_within_the_tolerance() {
    let size: (u32, u32) = (480, 360);
    let tiles_of = |t: u32| u64::from(size.0.div_ceil(t) * size.1.div_ceil(t));
    for (what, scene) in hard_scenes() {
        let mut interpolated = Vec::new();
        for tolerance in [1e-2, 1e-3, 1e-4] {
            let (smooth, exact) = check(what, &scene, tolerance, size);
            // Every tile (of 4 or 8 pixels a side) is listed once.
            let tiles = smooth + exact;
            assert!(tiles == tiles_of(4) || tiles == tiles_of(8), "{what} at {tolerance:e}: {tiles} tiles");
            interpolated.push(smooth as f64 / tiles as f64);
            println!("{what} at {tolerance:e}: {smooth} of {tiles} tiles interpolated");
        }
        // Not vacuous: the bound lets tiles through, more of them at larger tolerances, and the
        // hard places (core, edges, the view along the beam) stay exact.
        assert!(interpolated[0] > 0.0, "{what}: no tile interpolated at 1e-2");
        assert!(
            interpolated[0] >= interpolated[1] && interpolated[1] >= interpolated[2],
            "{what}: {interpolated:?}"
        );
        assert!(interpolated[0] < 1.0, "{what}: every tile interpolated at 1e-2");
    }
}

/// The seed's scene (occluders: depth edges) at sizes where each tolerance interpolates tiles, and
/// at a size no tile size divides (partial tiles at the right and bottom edges).
#[test]
fn seed_scene_with_occluders_stays_within_the_tolerance() {
    let scene = hadou::scene::load_scene("assets/scenes/energy_wave.toml".as_ref()).unwrap();
    for (tolerance, size) in [(1e-2, (256, 256)), (1e-2, (301, 203)), (1e-3, (512, 512)), (1e-4, (960, 540))]
    {
        let (smooth, exact) = check("seed 004 with occluders", &scene, tolerance, size);
        println!("seed at {tolerance:e}: {smooth} interpolated, {exact} exact");
        assert!(smooth > 0 && exact > 0, "{smooth} interpolated, {exact} exact");
    }
}

/// The tolerance is a run-time setting: a game turns it on and off per wave
/// (`Renderer::set_wave_tolerance`); 0 gives back the exact pass's image bit for bit, and a value
/// outside [0, 1) is refused naming it.
#[test]
fn tolerance_is_set_at_run_time() {
    let mut scene = hadou::scene::load_scene("assets/scenes/energy_wave.toml".as_ref()).unwrap();
    scene.waves_mut()[0].tolerance = Some(0.0);
    let mut rt = common::runtime();
    rt.load_scene(scene).unwrap();
    let mut req = FrameRequest::new(512, 512);
    req.aovs = vec![Aov::Energy];
    let energy = |rt: &mut hadou::Runtime, req: &FrameRequest| {
        let frame = rt.render(req).unwrap();
        let tiles = frame.stats.counter(TILES_INTERPOLATED);
        (frame.aov(Aov::Energy).unwrap().data.clone(), tiles)
    };
    let (exact, none) = energy(&mut rt, &req);
    assert_eq!(none, 0);
    let id = rt.renderer().wave_ids()[0];
    rt.renderer().set_wave_tolerance(id, Some(1e-2)).unwrap();
    let (tolerant, tiles) = energy(&mut rt, &req);
    assert!(tiles > 0, "no tile interpolated at 1e-2");
    assert_ne!(exact, tolerant);
    rt.renderer().set_wave_tolerance(id, Some(0.0)).unwrap();
    let (again, _) = energy(&mut rt, &req);
    assert!(
        exact.iter().zip(&again).all(|(a, b)| a.to_bits() == b.to_bits()),
        "tolerance 0 is not the exact image"
    );
    let err = rt.renderer().set_wave_tolerance(id, Some(1.0)).unwrap_err().to_string();
    assert!(err.contains("wave tolerance 1") && err.contains("[0, 1)"), "{err}");
    rt.finish();
}
