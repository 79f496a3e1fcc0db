//! The viewer's event loop (winit `ApplicationHandler`): input, time, hot reload, frames, title.

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime};

use hadou::gpu::validation::ValidationLog;
use hadou::scene::Scene;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use super::camera_control::{CameraControl, Mode};
use super::gpu::{Presented, ViewerGpu};
use super::keys::{self, Action};
use super::reload::{LastGood, Replaced, Wake, Watch};
use super::script::{Command, Script};
use super::title::{title, PassTimes};
use super::toggles::Toggles;

/// One step of `.`.
const STEP_SECONDS: f64 = 1.0 / 60.0;

pub struct App {
    scene_path: PathBuf,
    size: (u32, u32),
    file: LastGood<Scene>,
    toggles: Toggles,
    control: CameraControl,
    time: f64,
    paused: bool,
    last_tick: Instant,
    held: HashSet<KeyCode>,
    dragging: bool,
    cursor: Option<(f64, f64)>,
    /// None for a built-in scene (no file to watch).
    scene_watch: Option<Watch>,
    /// The files `scene_watch` watches: the scene and what it reads (OBJ, glTF and its buffers),
    /// watched again when a reload changes them.
    watched: Vec<PathBuf>,
    /// Wakes the event loop: the next watch is made with it.
    wake: Wake,
    shader_watch: Option<Watch>,
    times: PassTimes,
    shown_title: String,
    /// The last presented frame (for screenshots).
    last_frame: Option<Presented>,
    script: Option<Script>,
    /// The runtime has nothing loaded (a failed reload could not roll back): wait for a change.
    broken: bool,
    /// The last shader edit that did not compile (cleared by one that does).
    shader_error: Option<String>,
    /// A scene edit seen while the shaders did not compile: applied once they do.
    scene_pending: bool,
    /// Set by the script's `resize_events=off` (tests of the driver's out-of-date reports).
    ignore_resize_events: bool,
    /// Why the last toggle was undone.
    toggle_error: Option<String>,
    fatal: Option<anyhow::Error>,
    log: Option<Arc<ValidationLog>>,
    totals: Totals,
    // Field order is drop order: the GPU side (surface) before the window it presents to.
    gpu: Option<ViewerGpu>,
    window: Option<std::sync::Arc<Window>>,
}

impl App {
    /// `wake` wakes the event loop (a change was seen while it waits).
    pub fn new(
        scene_path: PathBuf,
        scene: Scene,
        size: (u32, u32),
        script: Option<Script>,
        wake: Wake,
    ) -> Self {
        let now = Instant::now();
        let shader_watch = std::env::var_os("HADOU_SHADER_DIR")
            .map(|d| Watch::shader_dir(PathBuf::from(d).as_ref(), wake.clone()));
        let builtin = hadou::builtin::name_of(&scene_path).is_some();
        let watched = if builtin { Vec::new() } else { crate::cli::scene_inputs(&scene_path, &scene) };
        App {
            scene_watch: (!builtin).then(|| Watch::files(&watched, wake.clone())),
            watched,
            wake,
            scene_path,
            size,
            control: CameraControl::new(&scene.camera),
            file: LastGood::new(scene),
            toggles: Toggles::default(),
            time: 0.0,
            paused: false,
            last_tick: now,
            held: HashSet::new(),
            dragging: false,
            cursor: None,
            shader_watch,
            times: PassTimes::new(now),
            shown_title: String::new(),
            last_frame: None,
            script,
            broken: false,
            shader_error: None,
            scene_pending: false,
            toggle_error: None,
            ignore_resize_events: false,
            fatal: None,
            log: None,
            totals: Totals::default(),
            gpu: None,
            window: None,
        }
    }

    pub fn set_time(&mut self, time: f64, paused: bool) {
        self.time = time;
        self.paused = paused;
    }

    /// Tears down the GPU side and the window; returns the run's result and the validation log.
    pub fn finish(mut self) -> (anyhow::Result<()>, Option<Arc<ValidationLog>>) {
        if let Some(line) = self.totals.summary() {
            eprintln!("{line}");
        }
        self.gpu = None;
        self.window = None;
        (self.fatal.map_or(Ok(()), Err), self.log)
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, error: anyhow::Error) {
        if self.fatal.is_none() {
            self.fatal = Some(error);
        }
        event_loop.exit();
    }

    fn start(&mut self, event_loop: &ActiveEventLoop) -> anyhow::Result<()> {
        let attributes = Window::default_attributes()
            .with_title(format!("hadou view {}", self.scene_path.display()))
            .with_inner_size(PhysicalSize::new(self.size.0, self.size.1));
        let window = std::sync::Arc::new(event_loop.create_window(attributes)?);
        let mut gpu = ViewerGpu::new(window.clone())?;
        self.log = Some(gpu.validation_log());
        let scene = self.toggles.apply(self.file.get());
        gpu.load(&scene, self.control.camera()).map_err(anyhow::Error::msg)?;
        self.gpu = Some(gpu);
        self.window = Some(window);
        Ok(())
    }

    /// Rebuilds the runtime's scene after a toggle; if that fails the toggle is undone (the
    /// previous passes rebuilt) and the error shown.
    fn reload_toggled(&mut self, previous: Toggles) {
        let (Some(gpu), camera) = (self.gpu.as_mut(), self.control.camera()) else { return };
        let file = self.file.get();
        let mut toggles = LastGood::new(previous);
        let outcome = toggles.replace(Ok(self.toggles), |t| gpu.load(&t.apply(file), camera));
        self.toggles = *toggles.get();
        self.toggle_error = toggles.error().map(str::to_string);
        self.broken = matches!(outcome, Replaced::Broken(_));
        match outcome {
            Replaced::Yes => {}
            Replaced::KeptLastGood(e) => eprintln!("error: toggle undone: {e}"),
            Replaced::Broken(e) => eprintln!("error: {e}"),
        }
    }

    /// When a seen change will be due (debounced), if one is pending.
    fn reload_due(&self) -> Option<Instant> {
        self.scene_watch.iter().chain(&self.shader_watch).filter_map(Watch::due).min()
    }

    /// Reloads the scene or the shaders when their watch hands out a (debounced) change.
    fn take_file_changes(&mut self) {
        let now = Instant::now();
        let scene_changed = self.scene_watch.as_ref().is_some_and(|w| w.take(now)) || self.scene_pending;
        let shaders_changed = self.shader_watch.as_ref().is_some_and(|w| w.take(now));
        self.scene_pending = false;
        if shaders_changed || (scene_changed && self.shader_error.is_some()) {
            // Compile every shader first: an edit that does not compile never touches the runtime,
            // and a scene edit waits until the shaders compile again (its passes would not build).
            if let Err(e) = check_shaders() {
                self.scene_pending = scene_changed;
                eprintln!("error: shader reload kept the last good shaders: {e}");
                self.shader_error = Some(e);
                if let Some(script) = &mut self.script {
                    script.reload_happened();
                }
                return;
            }
            self.shader_error = None;
        }
        if !(scene_changed || shaders_changed) {
            return;
        }
        let Some(gpu) = self.gpu.as_mut() else { return };
        // The file's modification time is its save: how long ago it was, when read, is the reload's
        // latency (the coarse file clock can only make it look longer).
        let saved = std::fs::metadata(&self.scene_path).and_then(|m| m.modified()).ok();
        let since_save = saved.and_then(|t| SystemTime::now().duration_since(t).ok());
        let candidate = hadou::builtin::load(&self.scene_path).map_err(|e| e.to_string());
        let old_file_camera = self.file.get().camera;
        let (toggles, control) = (self.toggles, &mut self.control);
        let outcome = self.file.replace(candidate, |file| {
            // A new [camera] in the file moves the view there; otherwise the user's view stays.
            let camera = if file.camera != old_file_camera {
                CameraControl::new(&file.camera)
            } else {
                control.clone()
            };
            gpu.load(&toggles.apply(file), camera.camera())?;
            *control = camera;
            Ok(())
        });
        if let Some(script) = &mut self.script {
            script.reload_happened();
        }
        match outcome {
            Replaced::Yes => {
                self.broken = false;
                self.toggle_error = None;
                // The scene may now read other files (a new OBJ path): watch those.
                let inputs = crate::cli::scene_inputs(&self.scene_path, self.file.get());
                if self.scene_watch.is_some() && inputs != self.watched {
                    self.scene_watch = Some(Watch::files(&inputs, self.wake.clone()));
                    self.watched = inputs;
                }
                let after = since_save
                    .map_or(String::new(), |d| format!(", read {} ms after its save", d.as_millis()));
                eprintln!("reloaded {}{after}", self.scene_path.display());
            }
            Replaced::KeptLastGood(e) => {
                self.broken = false;
                eprintln!("error: reload kept the last good state: {e}");
            }
            Replaced::Broken(e) => {
                self.broken = true;
                eprintln!("error: reload failed: {e}");
            }
        }
    }
}

impl App {
    fn act(&mut self, event_loop: &ActiveEventLoop, action: Action) {
        let file = self.file.get().clone();
        match action {
            Action::Quit => event_loop.exit(),
            Action::TogglePause => self.paused = !self.paused,
            Action::StepFrame => {
                self.paused = true;
                self.time += STEP_SECONDS;
            }
            Action::SwitchCameraMode => self.control.toggle_mode(),
            Action::ResetCamera => {
                let mode = self.control.mode;
                self.control = CameraControl::new(&file.camera);
                self.control.mode = mode;
            }
            Action::Screenshot => {
                let path = super::screenshot::next_path(std::path::Path::new("."));
                self.screenshot(event_loop, path);
            }
            Action::ToggleEnergyWave | Action::ToggleTranslucency | Action::ToggleMetaballs => {
                let previous = self.toggles;
                let t = &mut self.toggles;
                match action {
                    Action::ToggleEnergyWave => t.energy_wave = !t.energy_wave,
                    Action::ToggleTranslucency => t.translucency = !t.translucency,
                    _ => t.metaballs = !t.metaballs,
                }
                self.reload_toggled(previous);
            }
            Action::SwitchThickness => {
                let previous = self.toggles;
                self.toggles.switch_thickness(&file);
                self.reload_toggled(previous);
            }
            Action::SwitchWaveMethod => {
                let previous = self.toggles;
                self.toggles.switch_wave_method(&file);
                self.reload_toggled(previous);
            }
        }
    }

    fn screenshot(&mut self, event_loop: &ActiveEventLoop, path: PathBuf) {
        let Some(frame) = &self.last_frame else {
            eprintln!("screenshot: no frame presented yet");
            return;
        };
        match hadou::output::write_png(&path, frame.width, frame.height, &frame.rgba) {
            Ok(()) => eprintln!("wrote {} ({}x{})", path.display(), frame.width, frame.height),
            // A scripted screenshot that fails is a failed run; a key press only reports it.
            Err(e) if self.script.is_some() => self.fail(event_loop, e.into()),
            Err(e) => eprintln!("error: {e}"),
        }
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) {
        let now = Instant::now();
        let dt = now.duration_since(self.last_tick).as_secs_f64().min(0.25);
        self.last_tick = now;
        if !self.paused {
            self.time += dt;
        }
        self.control.fly(keys::motion(&self.held), dt);
        if self.broken {
            return;
        }
        let (Some(gpu), Some(window)) = (self.gpu.as_mut(), self.window.as_ref()) else { return };
        let size = window.inner_size();
        let presented = match gpu.frame((size.width, size.height), self.control.camera(), self.time) {
            Ok(p) => p,
            Err(e) => return self.fail(event_loop, e),
        };
        let Some(frame) = presented else { return };
        self.times.add(&frame.stats);
        self.totals.add(&frame);
        let extent = (frame.width, frame.height);
        self.last_frame = Some(frame);
        self.update_title();
        let commands = match self.script.as_mut().map(|s| s.after_frame(extent)) {
            None => return,
            Some(Ok(c)) => c,
            Some(Err(e)) => return self.fail(event_loop, anyhow::Error::msg(e)),
        };
        for command in commands {
            match command {
                Command::Resize(w, h) => {
                    if let Some(window) = &self.window {
                        // The new size arrives as a Resized event (or at once, as the return value).
                        let _ = window.request_inner_size(PhysicalSize::new(w, h));
                    }
                    self.window_resized();
                }
                Command::Screenshot(path) => self.screenshot(event_loop, path),
                Command::Key(action) => self.act(event_loop, action),
                Command::Say(text) => eprintln!("{text}"),
                Command::IgnoreResizeEvents => self.ignore_resize_events = true,
                Command::Quit => event_loop.exit(),
            }
        }
    }

    fn window_resized(&mut self) {
        if let (Some(gpu), false) = (self.gpu.as_mut(), self.ignore_resize_events) {
            gpu.window_resized();
        }
    }

    fn update_title(&mut self) {
        let state = format!(
            "t={:.2}s{} | {} | {}",
            self.time,
            if self.paused { " paused" } else { "" },
            if self.control.mode == Mode::Orbit { "orbit" } else { "fly" },
            self.toggles.summary(self.file.get()),
        );
        let name = self.scene_path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let error = self.shader_error.as_deref().or(self.toggle_error.as_deref()).or(self.file.error());
        let text = title(&name, self.times.text(Instant::now()), &state, error);
        if text != self.shown_title {
            if let Some(window) = &self.window {
                window.set_title(&text);
            }
            self.shown_title = text;
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gpu.is_none() && self.fatal.is_none() {
            if let Err(e) = self.start(event_loop) {
                self.fail(event_loop, e);
            }
            // Start-up (device, pipelines) is not scene time.
            self.last_tick = Instant::now();
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(_) => self.window_resized(),
            WindowEvent::RedrawRequested => self.redraw(event_loop),
            WindowEvent::KeyboardInput { event, .. } => {
                let PhysicalKey::Code(code) = event.physical_key else { return };
                let pressed = event.state == ElementState::Pressed;
                if keys::is_move_key(code) {
                    if pressed {
                        self.held.insert(code);
                    } else {
                        self.held.remove(&code);
                    }
                } else if pressed && !event.repeat {
                    if let Some(action) = keys::action(code) {
                        self.act(event_loop, action);
                    }
                }
            }
            WindowEvent::Focused(false) => self.held.clear(),
            WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => {
                self.dragging = state == ElementState::Pressed;
            }
            WindowEvent::CursorMoved { position, .. } => {
                let now = (position.x, position.y);
                if let (true, Some(before)) = (self.dragging, self.cursor) {
                    self.control.drag(now.0 - before.0, now.1 - before.1);
                }
                self.cursor = Some(now);
            }
            WindowEvent::MouseWheel { delta, .. } => match delta {
                MouseScrollDelta::LineDelta(_, y) => self.control.wheel(y as f64),
                MouseScrollDelta::PixelDelta(p) => self.control.wheel(p.y / 40.0),
            },
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        self.take_file_changes();
        let Some(window) = &self.window else { return };
        let size = window.inner_size();
        if size.width == 0 || size.height == 0 || self.broken {
            // Minimized, or waiting for a fixed file: look again later instead of spinning (a seen
            // change wakes the loop; its debounce says when it is due).
            self.last_tick = Instant::now();
            let later = self.last_tick + Duration::from_millis(100);
            event_loop
                .set_control_flow(ControlFlow::WaitUntil(self.reload_due().map_or(later, |d| d.min(later))));
            self.update_title();
        } else {
            event_loop.set_control_flow(ControlFlow::Poll);
            window.request_redraw();
        }
    }
}

/// Compiles every shader stage hadou has from `HADOU_SHADER_DIR`, each without `#define`s (a
/// file whose pass defines something compiles on its own with a default).
fn check_shaders() -> Result<(), String> {
    let mut compiler = hadou::gpu::shader::ShaderCompiler::new(hadou::SHADERS).map_err(|e| e.to_string())?;
    for (name, _) in hadou::SHADERS {
        if !name.starts_with("common/") {
            compiler.compile(name, &[]).map_err(|e| e.to_string())?;
        }
    }
    Ok(())
}

/// Whole-run frame costs, printed when the viewer exits (a measurement, not a check).
#[derive(Debug, Default)]
struct Totals {
    first: Option<Instant>,
    frames: u32,
    render_ms: f64,
    gpu_ms: f64,
    present_ms: f64,
}

impl Totals {
    fn add(&mut self, frame: &Presented) {
        self.first.get_or_insert_with(Instant::now);
        self.frames += 1;
        self.render_ms += frame.stats.cpu_frame_ms;
        self.gpu_ms += frame.stats.gpu_frame_ms;
        self.present_ms += frame.present_ms;
    }

    /// From the first presented frame's end: the first frame's cost (shader JIT) is left out of the rate.
    fn summary(&self) -> Option<String> {
        let seconds = self.first?.elapsed().as_secs_f64();
        let n = self.frames as f64;
        Some(format!(
            "view: {} frames, {:.1} fps after the first; mean per frame: runtime {:.1} ms \
             (GPU passes {:.1} ms), copy + present {:.2} ms",
            self.frames,
            (n - 1.0) / seconds.max(1e-9),
            self.render_ms / n,
            self.gpu_ms / n,
            self.present_ms / n
        ))
    }
}
