//! Several views of one world per frame (`Renderer::record_views`): split screen, a headset's two
//! eyes. Two views recorded together must give, frame after frame, exactly the pixels of two
//! renderers each recording one of them alone — colour, every AOV, bit for bit — so no per-frame
//! or per-slot state of a pass (history images, an adapted exposure, the wave's tile path, the
//! metaballs' lists, the light maps, the previous frames motion is measured against) leaks from
//! one view into the other. Lavapipe, validation + synchronization validation, zero messages.

mod common;

use common::host::Host;

use glam::{DMat4, DVec3};
use hadou::scene::camera::Camera;
use hadou::scene::ExposureMode;
use hadou::{Aov, AovReadback, Error, FrameInputs, Renderer, RendererOptions, View, ViewCamera};

const FRAMES: usize = 4;
const IN_FLIGHT: usize = 2;
const AOVS: [Aov; 5] = Aov::ALL;

/// The showcase (instances, a translucent cube with a light map, a keyframed wave, keyframed
/// metaballs) with an automatic exposure: its adaptation is per-view state across frames.
fn scene() -> hadou::scene::Scene {
    let mut scene = common::load("assets/scenes/showcase.toml");
    scene.render.exposure_mode = ExposureMode::Auto;
    scene
}

/// A second camera: from the side, lower and wider.
fn side_camera() -> Camera {
    Camera {
        position: DVec3::new(7.0, 2.0, 3.0),
        look_at: DVec3::new(0.0, 0.5, 0.0),
        up: DVec3::Y,
        fov_y_deg: 60.0,
        near: 0.2,
        far: 30.0,
        lens: Default::default(),
    }
}

/// A third, as a game's matrices (reverse-Z, infinite far).
fn eye_matrices() -> (DMat4, DMat4) {
    let view = DMat4::look_at_rh(DVec3::new(-3.0, 3.0, 8.0), DVec3::new(0.5, 0.5, 0.0), DVec3::Y);
    let projection = DMat4::perspective_infinite_reverse_rh(50f64.to_radians(), 1.0, 0.1);
    (view, projection)
}

/// What one view gave in each frame: its colour and AOVs.
type Frames = Vec<(Vec<u8>, Vec<hadou::AovImage>)>;

fn read(readbacks: &[(AovReadback, AovReadback)], wanted: &[Aov]) -> Frames {
    readbacks
        .iter()
        .map(|(color, aovs)| {
            let images = wanted.iter().map(|&a| aovs.aov(a).expect("read back")).collect();
            (color.color().expect("colour read back").to_vec(), images)
        })
        .collect()
}

/// Runs `FRAMES` frames, two in flight, of `views` through one renderer set up by `setup`; per
/// view, per frame, what it gave (its colour and the `AOVS`).
fn render(views: &[View], setup: impl Fn(&mut Renderer)) -> Vec<Frames> {
    render_aovs(views, &AOVS, setup)
}

/// As `render`, reading back the `wanted` AOVs.
fn render_aovs(views: &[View], wanted: &[Aov], setup: impl Fn(&mut Renderer)) -> Vec<Frames> {
    let (_leaks, ctx) = common::context();
    let log = ctx.validation_log();
    let mut host = Host::new(&ctx, IN_FLIGHT);
    let options = RendererOptions { frames_in_flight: IN_FLIGHT, ..RendererOptions::default() };
    let mut hadou = Renderer::with_options(ctx, &options).unwrap();
    hadou.load_scene(scene()).unwrap();
    setup(&mut hadou);
    let mut per_view: Vec<Vec<(AovReadback, AovReadback)>> = views.iter().map(|_| Vec::new()).collect();
    for i in 0..FRAMES {
        let slot = i % IN_FLIGHT;
        let cmd = host.begin(slot);
        let frame = hadou.record_views(cmd, 0.45 * i as f64, views).unwrap();
        assert!(frame.recorded);
        for (v, out) in per_view.iter_mut().enumerate() {
            let color = hadou.record_view_color_readback(cmd, v).unwrap();
            out.push((color, hadou.record_view_aov_readback(cmd, v, wanted).unwrap()));
        }
        host.submit(slot);
    }
    host.wait_all();
    hadou.frame_finished(FRAMES as u64 - 1).unwrap();
    let frames = per_view.iter().map(|r| read(r, wanted)).collect();
    drop(per_view);
    host.destroy();
    drop(hadou);
    common::assert_log_clean(&log, "after shutdown");
    frames
}

fn assert_same(what: &str, got: &Frames, alone: &Frames) {
    assert_same_aovs(what, got, alone, &AOVS);
}

fn assert_same_aovs(what: &str, got: &Frames, alone: &Frames, wanted: &[Aov]) {
    for (i, ((color, aovs), (color_alone, aovs_alone))) in got.iter().zip(alone).enumerate() {
        assert!(color == color_alone, "{what}, frame {i}: the colour differs from the view rendered alone");
        for ((aov, a), b) in wanted.iter().zip(aovs).zip(aovs_alone) {
            assert!(
                common::same_bits(a, b),
                "{what}, frame {i}: {} differs from the view rendered alone",
                aov.name()
            );
        }
    }
}

#[test]
fn three_views_give_the_pixels_of_three_renderers() {
    let (view, projection) = eye_matrices();
    let views = [
        View::headless(ViewCamera::Renderer, 80, 48),
        View::headless(ViewCamera::Camera(side_camera()), 56, 56),
        View::headless(ViewCamera::ViewProjection { view, projection }, 40, 40),
    ];
    let together = render(&views, |_| {});
    let first = render(&[View::headless(ViewCamera::Renderer, 80, 48)], |_| {});
    let second =
        render(&[View::headless(ViewCamera::Renderer, 56, 56)], |r| r.set_camera(side_camera()).unwrap());
    let third = render(&[View::headless(ViewCamera::Renderer, 40, 40)], |r| {
        r.set_view_projection(view, projection).unwrap()
    });
    assert_same("the first view", &together[0], &first[0]);
    assert_same("the side view", &together[1], &second[0]);
    assert_same("the matrices' view", &together[2], &third[0]);
    // The frames differ (the showcase moves; the exposure adapts), so each frame is its own check.
    assert!(together[0][0].0 != together[0][FRAMES - 1].0, "the showcase moves: frames differ");
}

/// With motion vectors on, each view's motion is measured against its own previous frame: the
/// showcase's keyframed metaballs (whose motion the metaballs pass keeps per view) and moving
/// instances seen by two cameras together give each view's motion as a renderer of that view
/// alone gives it, bit for bit.
#[test]
fn two_views_with_motion_vectors_give_the_pixels_of_two_renderers() {
    let wanted = [Aov::Depth, Aov::Motion, Aov::Reactive, Aov::Composition];
    let views = [
        View::headless(ViewCamera::Renderer, 80, 48),
        View::headless(ViewCamera::Camera(side_camera()), 56, 56),
    ];
    let motion = |r: &mut Renderer| r.set_motion_vectors(true).unwrap();
    let together = render_aovs(&views, &wanted, motion);
    let first = render_aovs(&[View::headless(ViewCamera::Renderer, 80, 48)], &wanted, motion);
    let second = render_aovs(&[View::headless(ViewCamera::Renderer, 56, 56)], &wanted, |r| {
        motion(r);
        r.set_camera(side_camera()).unwrap()
    });
    assert_same_aovs("the first view", &together[0], &first[0], &wanted);
    assert_same_aovs("the side view", &together[1], &second[0], &wanted);
    // Something moves on screen in the later frames (the metaballs' keyframes).
    let moving = |f: &Frames| f[1..].iter().any(|(_, aovs)| aovs[1].data.iter().any(|&m| m != 0.0));
    assert!(moving(&together[0]) && moving(&together[1]), "no motion in the frames");
}

#[test]
fn bad_views_are_refused_before_anything_is_recorded() {
    let (_leaks, ctx) = common::context();
    let mut host = Host::new(&ctx, 1);
    let mut hadou = Renderer::new(ctx).unwrap();
    hadou.load_scene(scene()).unwrap();
    let cmd = host.begin(0);
    let ok = View::headless(ViewCamera::Renderer, 32, 32);
    let bad_camera = Camera { look_at: DVec3::new(7.0, 2.0, 3.0), ..side_camera() };
    let too_many = [ok; hadou::MAX_VIEWS + 1];
    for (what, views) in [
        ("no views", &[][..]),
        ("too many views", &too_many[..]),
        ("a camera looking at itself", &[ok, View::headless(ViewCamera::Camera(bad_camera), 32, 32)][..]),
    ] {
        let err = hadou.record_views(cmd, 0.0, views).expect_err(what);
        assert!(matches!(err, Error::InvalidUpdate { .. }), "{what}: {err}");
        assert_eq!(hadou.next_frame(), 0, "{what}: a frame was counted");
    }
    // A projection that is not one: refused with the field named.
    let skewed = ViewCamera::ViewProjection { view: DMat4::IDENTITY, projection: DMat4::IDENTITY };
    let err = hadou.record_views(cmd, 0.0, &[ok, View::headless(skewed, 32, 32)]).unwrap_err();
    assert!(err.to_string().contains("projection matrix"), "{err}");
    // A 0 × 0 view is skipped (a collapsed split), and reading it back says it was not recorded.
    let frame = hadou.record_views(cmd, 0.0, &[View::headless(ViewCamera::Renderer, 0, 0), ok]).unwrap();
    assert!(frame.recorded);
    assert!(matches!(hadou.record_view_aov_readback(cmd, 0, &[Aov::Depth]), Err(Error::NoFrameRecorded)));
    let second = hadou.record_view_aov_readback(cmd, 1, &[Aov::Depth]).unwrap();
    assert!(matches!(hadou.record_view_aov_readback(cmd, 2, &[Aov::Depth]), Err(Error::NoFrameRecorded)));
    // Only 0 × 0 views: nothing recorded, as `record_frame` with a minimized window.
    let none = hadou.record_views(cmd, 0.0, &[View::headless(ViewCamera::Renderer, 0, 0)]).unwrap();
    assert!(!none.recorded);
    host.submit(0);
    host.wait_all();
    assert!(
        second.aov(Aov::Depth).unwrap().data.iter().any(|d| d.is_finite()),
        "the second view saw the scene"
    );
    drop(second);
    host.destroy();
    drop(hadou);
}

/// `record_frame` is a frame of one view: the same frames as `record_views` with that view.
#[test]
fn record_frame_is_one_view() {
    let inputs = FrameInputs::headless(48, 32, 0.0);
    let views = [View::headless(ViewCamera::Renderer, 48, 32)];
    let (_leaks, ctx) = common::context();
    let mut host = Host::new(&ctx, 1);
    let mut hadou = Renderer::new(ctx).unwrap();
    // A fixed exposure: the two frames see the same world the same way.
    hadou.load_scene(common::load("assets/scenes/showcase.toml")).unwrap();
    let mut colours = Vec::new();
    for one_view in [false, true] {
        let cmd = host.begin(0);
        if one_view {
            hadou.record_views(cmd, inputs.time, &views).unwrap();
        } else {
            hadou.record_frame(cmd, &inputs).unwrap();
        }
        colours.push(hadou.record_view_color_readback(cmd, 0).unwrap());
        host.submit(0);
        host.wait_all();
    }
    let timings = {
        hadou.frame_finished(1).unwrap();
        hadou.latest_timings().unwrap()
    };
    assert!(timings.passes.iter().all(|p| !p.name.starts_with("view ")), "one view: no view prefix");
    assert_eq!(colours[0].color(), colours[1].color());
    drop(colours);
    host.destroy();
    drop(hadou);
}
