//! A frame whose recording or submission failed, on a real swapchain (a winit window under Xvfb,
//! lavapipe, validation on): `Presenter::acquire` resets the slot's fence for the submission the
//! caller owes, so after a failed frame the next `acquire` must neither wait on that fence forever
//! nor reuse the acquire semaphore with its signal pending. It refuses with an error until the
//! frame is given back with `Presenter::abandon`, after which frames present again, with zero
//! validation messages. A watchdog turns a hang into a failure.

mod common;

use std::sync::Arc;
use std::time::Duration;

use common::xvfb::Xvfb;
use hadou::gpu::ContextOptions;
use hadou::present::{PresentConfig, WindowOutput};
use winit::event_loop::EventLoop;
use winit::platform::x11::EventLoopBuilderExtX11;
use winit::window::Window;

/// Far longer than any step here takes on lavapipe; only a wait that never returns reaches it.
const HANG_LIMIT: Duration = Duration::from_secs(120);

#[test]
fn a_failed_frame_is_refused_then_abandoned_and_frames_present_again() {
    let x = Xvfb::start();
    // The only test in this binary: no other thread reads the environment.
    std::env::set_var("DISPLAY", &x.display);
    let (done, finished) = std::sync::mpsc::channel::<()>();
    std::thread::spawn(move || {
        if finished.recv_timeout(HANG_LIMIT).is_err() {
            eprintln!("present_abandon: a presenter call did not return within {HANG_LIMIT:?} (a fence never signalled)");
            std::process::exit(101);
        }
    });

    let event_loop = EventLoop::builder().with_any_thread(true).build().expect("an X11 event loop on Xvfb");
    #[allow(deprecated)] // one window, no event handling: the 0.30 shortcut is enough
    let window = event_loop
        .create_window(Window::default_attributes().with_inner_size(winit::dpi::PhysicalSize::new(64, 48)))
        .expect("a window");
    let window = Arc::new(window);
    let options = ContextOptions { validation: true, device_filter: None };
    let config = PresentConfig { frames_in_flight: 1, ..PresentConfig::default() };
    let (ctx, mut output) = WindowOutput::open(window, &options, config).expect("a presenting context");
    let log = ctx.validation_log();
    let size = (64, 48);

    // A frame that fails after acquire: nothing is submitted with its fence.
    let failed = output.presenter.acquire(size).unwrap().expect("an image");
    // The next acquire refuses instead of waiting on the reset fence (slot 0 again: one in flight).
    let refused = output.presenter.acquire(size).expect_err("acquire after an unfinished frame");
    let message = refused.to_string();
    assert!(
        message.contains(&format!("swapchain image {}", failed.index))
            && message.contains("Presenter::abandon"),
        "{message}"
    );
    // Given back: its fence signals, its semaphore is consumed, the swapchain is recreated.
    let before = output.presenter.recreations();
    output.presenter.abandon(ctx.queue, &failed).expect("abandon");

    for frame in 0..3u8 {
        let acquired = output.presenter.acquire(size).unwrap().expect("an image after abandon");
        assert_eq!(acquired.fence, failed.fence, "one frame in flight: the abandoned slot's fence again");
        let e = acquired.extent;
        let rgba = vec![frame * 60; (e.width * e.height * 4) as usize];
        output.copier.copy_and_submit(ctx.queue, &acquired, &rgba).expect("copy");
        output.presenter.present(ctx.queue, &acquired).expect("present");
    }
    assert_eq!(output.presenter.recreations(), before + 1, "the abandoned image's swapchain was recreated");
    output.destroy();
    done.send(()).ok();
    let (counts, messages) = (log.counts(), log.messages());
    drop(ctx);
    drop(x);
    assert_eq!((counts.errors, counts.warnings), (0, 0), "validation: {messages:#?}");
}
