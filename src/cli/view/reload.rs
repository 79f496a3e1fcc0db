//! Hot reload. A `Watch` is told of changes by `notify` (inotify on Linux) on the folders of the
//! watched files, so a save that renames a new file over the old one is seen too; only where notify
//! cannot watch (no inotify instance or watch left, a platform without events) it falls back to
//! notify's polling watcher. A new scene or shader set replaces the running one only if it works;
//! otherwise the last good one stays and the error is kept for the title and printed once.
//!
//! **Debounce.** A save is a burst of events (truncate, writes, close; or write a temporary, rename
//! it), a few system calls in a row. A change is handed out once the files have been quiet for
//! `QUIET` (25 ms: far longer than the gaps inside such a burst, a quarter of the 100 ms promise),
//! or `LONGEST` (50 ms) after the burst began if writes keep coming: a burst whose gaps are shorter
//! than `QUIET` reloads once, and a save is read at most `LONGEST` after it began plus the frame in
//! flight (tests/viewer.rs prints the whole it measured: 33 ms at 96×64 on an idle lavapipe). A slow writer read
//! half-way shows a parse error for a moment and its remaining events reload it again, so nothing
//! is lost by the cap.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use notify::event::{AccessKind, AccessMode};
use notify::{Event, EventKind, PollWatcher, RecommendedWatcher, RecursiveMode, Watcher};

/// How long the files must be quiet before a change is handed out.
pub const QUIET: Duration = Duration::from_millis(25);
/// The longest a change waits from the first event of its burst.
pub const LONGEST: Duration = Duration::from_millis(50);
/// The polling fallback's period (it compares modification times).
const POLL_PERIOD: Duration = Duration::from_millis(100);

/// Called from the watcher's thread on every relevant event (the viewer wakes its event loop).
pub type Wake = Arc<dyn Fn() + Send + Sync>;

/// The first and last event of the burst not yet handed out.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Burst {
    first: Option<Instant>,
    last: Option<Instant>,
}

impl Burst {
    fn note(&mut self, now: Instant) {
        self.first.get_or_insert(now);
        self.last = Some(now);
    }

    /// When the burst is to be handed out.
    fn due(&self) -> Option<Instant> {
        Some((self.last? + QUIET).min(self.first? + LONGEST))
    }

    /// True (and the burst forgotten) when it is due at `now`.
    fn take(&mut self, now: Instant) -> bool {
        let due = self.due().is_some_and(|d| now >= d);
        if due {
            *self = Burst::default();
        }
        due
    }
}

/// Which event paths count: some files, or every shader source under a folder.
#[derive(Clone, Debug)]
enum Filter {
    Files(Vec<PathBuf>),
    Shaders(PathBuf),
}

impl Filter {
    fn matches(&self, path: &Path) -> bool {
        match self {
            Filter::Files(files) => files.iter().any(|f| f == path),
            Filter::Shaders(dir) => path.starts_with(dir) && is_shader(path),
        }
    }
}

fn is_shader(path: &Path) -> bool {
    path.extension().is_some_and(|e| ["comp", "vert", "frag", "glsl"].iter().any(|x| e == *x))
}

/// notify's callback: notes relevant events in the burst and wakes the viewer.
#[derive(Clone)]
struct Handler {
    filter: Filter,
    burst: Arc<Mutex<Burst>>,
    wake: Wake,
    /// Every path of every event handled, relevant or not, in order (tests wait on a fence file).
    #[cfg(test)]
    seen: Arc<Mutex<Vec<PathBuf>>>,
}

impl notify::EventHandler for Handler {
    fn handle_event(&mut self, event: notify::Result<Event>) {
        #[cfg(test)]
        if let Ok(e) = &event {
            self.seen.lock().unwrap_or_else(|e| e.into_inner()).extend(e.paths.iter().cloned());
        }
        let relevant = match &event {
            Ok(e) => e.need_rescan() || (changes(&e.kind) && e.paths.iter().any(|p| self.filter.matches(p))),
            // The watcher lost track (an overflowed queue, a vanished folder): look again.
            Err(_) => true,
        };
        if relevant {
            lock(&self.burst).note(Instant::now());
            (self.wake)();
        }
    }
}

/// Opening or reading a file (the viewer's own reads included) changes nothing; a write's close does.
fn changes(kind: &EventKind) -> bool {
    match kind {
        EventKind::Access(AccessKind::Close(AccessMode::Write)) => true,
        EventKind::Access(_) => false,
        _ => true,
    }
}

fn lock(burst: &Mutex<Burst>) -> MutexGuard<'_, Burst> {
    burst.lock().unwrap_or_else(|e| e.into_inner())
}

/// The running watcher.
#[allow(dead_code)] // held, never read
enum Backend {
    Events(RecommendedWatcher),
    Polling(PollWatcher),
    /// Neither could watch: hot reload is off (said on stderr).
    None,
}

/// Files watched for changes.
pub struct Watch {
    burst: Arc<Mutex<Burst>>,
    #[cfg(test)]
    seen: Arc<Mutex<Vec<PathBuf>>>,
    /// Kept for its thread (tests read which one runs).
    #[cfg_attr(not(test), allow(dead_code))]
    backend: Backend,
}

impl Watch {
    /// Watches `files` (their folders, for events).
    pub fn files(files: &[PathBuf], wake: Wake) -> Self {
        // Event paths are the watched folder joined with the name: compare in that form. A
        // symbolic link is watched as a name in its folder and as the file it points to.
        let polled = files.iter().map(|f| (absolute_in_folder(f), RecursiveMode::NonRecursive)).collect();
        let mut names: Vec<PathBuf> = files.iter().map(|f| absolute_in_folder(f)).collect();
        names.extend(files.iter().filter_map(|f| std::fs::canonicalize(f).ok()));
        names.sort();
        names.dedup();
        let mut folders: Vec<PathBuf> =
            names.iter().filter_map(|f| f.parent().map(Path::to_path_buf)).collect();
        folders.sort();
        folders.dedup();
        let events = folders.into_iter().map(|d| (d, RecursiveMode::NonRecursive)).collect();
        Watch::start(Filter::Files(names), events, polled, wake, false)
    }

    /// Every shader source under `dir` (what `HADOU_SHADER_DIR` compiles from), new files included.
    pub fn shader_dir(dir: &Path, wake: Wake) -> Self {
        let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
        let targets = vec![(dir.clone(), RecursiveMode::Recursive)];
        Watch::start(Filter::Shaders(dir), targets.clone(), targets, wake, false)
    }

    /// Event watching on `events`, else polling `polled` (`force_poll` skips the first: tests).
    fn start(
        filter: Filter,
        events: Vec<(PathBuf, RecursiveMode)>,
        polled: Vec<(PathBuf, RecursiveMode)>,
        wake: Wake,
        force_poll: bool,
    ) -> Self {
        let burst = Arc::new(Mutex::new(Burst::default()));
        #[cfg(test)]
        let seen = Arc::new(Mutex::new(Vec::new()));
        let handler = Handler {
            filter,
            burst: burst.clone(),
            wake,
            #[cfg(test)]
            seen: seen.clone(),
        };
        let watch_all = |w: &mut dyn Watcher, targets: &[(PathBuf, RecursiveMode)]| {
            targets
                .iter()
                .try_for_each(|(p, mode)| w.watch(p, *mode).map_err(|e| format!("{}: {e}", p.display())))
        };
        let native = if force_poll {
            Err("polling asked for".to_string())
        } else {
            RecommendedWatcher::new(handler.clone(), notify::Config::default())
                .map_err(|e| e.to_string())
                .and_then(|mut w| watch_all(&mut w, &events).map(|()| w))
        };
        let backend = match native {
            Ok(w) => Backend::Events(w),
            Err(why) => {
                let config = notify::Config::default().with_poll_interval(POLL_PERIOD);
                let polling = PollWatcher::new(handler, config)
                    .map_err(|e| e.to_string())
                    .and_then(|mut w| watch_all(&mut w, &polled).map(|()| w));
                match polling {
                    Ok(w) => {
                        if !force_poll {
                            eprintln!("hot reload: polling every {POLL_PERIOD:?} ({why})");
                        }
                        Backend::Polling(w)
                    }
                    Err(e) => {
                        eprintln!("hot reload off: cannot watch ({why}; polling: {e})");
                        Backend::None
                    }
                }
            }
        };
        Watch {
            burst,
            #[cfg(test)]
            seen,
            backend,
        }
    }

    /// True once per debounced burst of changes, when it is due.
    pub fn take(&self, now: Instant) -> bool {
        lock(&self.burst).take(now)
    }

    /// When a pending change will be due (the viewer sleeps no longer than that).
    pub fn due(&self) -> Option<Instant> {
        lock(&self.burst).due()
    }

    #[cfg(test)]
    fn polling(&self) -> bool {
        matches!(self.backend, Backend::Polling(_))
    }
}

/// `path` as its folder's canonical path joined with its name (the folder exists: the file was read).
fn absolute_in_folder(path: &Path) -> PathBuf {
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    match (std::fs::canonicalize(folder), path.file_name()) {
        (Ok(dir), Some(name)) => dir.join(name),
        _ => path.to_path_buf(),
    }
}

/// The value in use and the error of the last failed replacement.
#[derive(Debug)]
pub struct LastGood<T> {
    good: T,
    error: Option<String>,
}

/// What `LastGood::replace` did.
#[derive(Debug, PartialEq, Eq)]
pub enum Replaced {
    /// The candidate is in use now.
    Yes,
    /// The candidate failed; the last good value is in use again (or still).
    KeptLastGood(String),
    /// The candidate failed and so did re-applying the last good value: nothing works until the
    /// next change (the caller stops rendering and shows the error).
    Broken(String),
}

impl<T> LastGood<T> {
    pub fn new(good: T) -> Self {
        LastGood { good, error: None }
    }

    pub fn get(&self) -> &T {
        &self.good
    }

    /// The error of the last failed replacement, until a replacement succeeds.
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// Tries `candidate` (already an error if it could not be read or parsed) with `apply`. If it
    /// fails, `apply` is called again with the last good value, because a failed apply may have
    /// torn down what was running.
    pub fn replace(
        &mut self,
        candidate: Result<T, String>,
        mut apply: impl FnMut(&T) -> Result<(), String>,
    ) -> Replaced {
        let error = match candidate {
            Ok(new) => match apply(&new) {
                Ok(()) => {
                    self.good = new;
                    self.error = None;
                    return Replaced::Yes;
                }
                Err(e) => match apply(&self.good) {
                    Ok(()) => e,
                    Err(again) => {
                        let message = format!("{e}; the last good state failed too: {again}");
                        self.error = Some(message.clone());
                        return Replaced::Broken(message);
                    }
                },
            },
            // Nothing was applied: what runs is untouched.
            Err(e) => e,
        };
        self.error = Some(error.clone());
        Replaced::KeptLastGood(error)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::RefCell;

    fn scene_text(fov: u32) -> String {
        let base =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/scenes/showcase.toml"))
                .unwrap();
        base.replace("fov_y_deg = 45", &format!("fov_y_deg = {fov}"))
    }

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("hadou-view-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A scene file edited into a bad one keeps the last good scene running, reports the file,
    /// line and column, and a later good edit is picked up again.
    #[test]
    fn a_bad_scene_keeps_the_last_good_one() {
        let dir = temp_dir("reload");
        let path = dir.join("scene.toml");
        std::fs::write(&path, scene_text(45)).unwrap();
        let load = |p: &Path| hadou::scene::load_scene(p).map_err(|e| e.to_string());
        let mut current = LastGood::new(load(&path).unwrap());
        let applied = RefCell::new(Vec::new());
        let apply = |s: &hadou::scene::Scene| {
            applied.borrow_mut().push(s.camera.fov_y_deg);
            Ok(())
        };

        // Bad: a negative field of view; the error must name its line.
        let bad = scene_text(45).replace("fov_y_deg = 45", "fov_y_deg = -3");
        let line = bad.lines().position(|l| l.starts_with("fov_y_deg")).unwrap() + 1;
        std::fs::write(&path, bad).unwrap();
        let outcome = current.replace(load(&path), apply);
        let Replaced::KeptLastGood(message) = outcome else { panic!("{outcome:?}") };
        assert!(message.contains(&format!("scene.toml:{line}:")), "{message}");
        assert!(message.contains("fov_y_deg"), "{message}");
        assert_eq!(current.get().camera.fov_y_deg, 45.0);
        assert!(applied.borrow().is_empty(), "a scene that does not parse never reaches the runtime");
        assert!(current.error().is_some());

        std::fs::write(&path, scene_text(60)).unwrap();
        assert_eq!(current.replace(load(&path), apply), Replaced::Yes);
        assert_eq!(current.get().camera.fov_y_deg, 60.0);
        assert_eq!(*applied.borrow(), vec![60.0]);
        assert!(current.error().is_none());
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A candidate that parses but fails in the runtime (a GPU or shader error) is rolled back by
    /// re-applying the last good value; if even that fails, the state says so.
    #[test]
    fn a_failing_apply_rolls_back() {
        let mut current = LastGood::new(1);
        let log = RefCell::new(Vec::new());
        let apply = |v: &i32| {
            log.borrow_mut().push(*v);
            if *v == 2 {
                Err("two is broken".to_string())
            } else {
                Ok(())
            }
        };
        assert_eq!(current.replace(Ok(2), apply), Replaced::KeptLastGood("two is broken".into()));
        assert_eq!(*log.borrow(), vec![2, 1], "the new value was tried, then the old one re-applied");
        assert_eq!(*current.get(), 1);
        let mut always_fails = LastGood::new(1);
        let outcome = always_fails.replace(Ok(3), |_| Err("device lost".to_string()));
        assert!(matches!(outcome, Replaced::Broken(ref m) if m.contains("device lost")), "{outcome:?}");
    }

    /// A watch whose wakes are counted.
    fn counted() -> (Arc<std::sync::atomic::AtomicUsize>, Wake) {
        let n = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let m = n.clone();
        (
            n,
            Arc::new(move || {
                m.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }),
        )
    }

    /// Far enough ahead that any pending change is due: `take(later())` hands out whatever the
    /// watcher has noted, whatever the debounce's timing (tested on a clock of its own below).
    fn later() -> Instant {
        Instant::now() + Duration::from_secs(3600)
    }

    /// Writes a fence file in `dir` (a watched folder; no filter counts it: another name, not a
    /// shader) and waits until the watcher has handled its event. One inotify instance queues its
    /// events in order and notify's thread handles them in that order, so once the fence is
    /// handled, every event of what the test did before in the watched folders has been noted:
    /// ordering, not a wall-clock window. The 60 s limit only turns a watcher that never delivers
    /// into a failure instead of a hang.
    fn fence(watch: &Watch, dir: &Path) {
        static FENCES: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let name = format!("fence-{}.txt", FENCES.fetch_add(1, std::sync::atomic::Ordering::Relaxed));
        std::fs::write(dir.join(&name), "").unwrap();
        let start = Instant::now();
        let handled = || lock_seen(watch).iter().any(|p| p.file_name() == Some(name.as_ref()));
        while !handled() {
            assert!(start.elapsed() < Duration::from_secs(60), "the watcher never handled {name}");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    fn lock_seen(watch: &Watch) -> MutexGuard<'_, Vec<PathBuf>> {
        watch.seen.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// A save in place and a save by rename are each seen (and handed out once taken: the next
    /// take finds nothing); reading the file (as the viewer does), writing another file in the
    /// folder and the fences are not changes and do not wake the viewer. Each step is followed by
    /// a fence, so what was noted is known without a time window. How soon a change is handed out
    /// is the debounce's (`bursts_are_handed_out_once`, on its own clock: `QUIET` after the last
    /// event, at most `LONGEST` after the first); the viewer's whole latency is printed by
    /// tests/viewer.rs, not asserted (it is the machine's load as much as hadou's).
    #[test]
    fn saves_are_seen_and_reads_are_not_changes() {
        let dir = temp_dir("watch");
        let path = dir.join("scene.toml");
        std::fs::write(&path, "a").unwrap();
        let (wakes, wake) = counted();
        let watch = Watch::files(std::slice::from_ref(&path), wake);
        assert!(!watch.polling(), "inotify is available here");
        fence(&watch, &dir);
        assert!(!watch.take(later()), "starting to watch is not a change");
        for how in ["in place", "by rename"] {
            if how == "in place" {
                std::fs::write(&path, how).unwrap();
            } else {
                std::fs::write(dir.join("scene.tmp"), how).unwrap();
                std::fs::rename(dir.join("scene.tmp"), &path).unwrap();
            }
            fence(&watch, &dir);
            assert!(watch.take(later()), "a save {how} was not seen");
            assert!(!watch.take(later()), "a save {how} was handed out twice");
        }
        let woken = wakes.load(std::sync::atomic::Ordering::Relaxed);
        assert!(woken > 0, "the viewer is woken");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "by rename");
        std::fs::write(dir.join("other.toml"), "b").unwrap();
        fence(&watch, &dir);
        assert!(!watch.take(later()), "reading the file or writing another one is not a change");
        assert_eq!(wakes.load(std::sync::atomic::Ordering::Relaxed), woken, "nor does it wake the viewer");
        // A link to a file in another folder: an edit of the file it points to counts.
        std::fs::create_dir_all(dir.join("real")).unwrap();
        std::fs::write(dir.join("real/target.toml"), "t").unwrap();
        std::os::unix::fs::symlink(dir.join("real/target.toml"), dir.join("link.toml")).unwrap();
        let (_, wake) = counted();
        let linked = Watch::files(&[dir.join("link.toml")], wake);
        std::fs::write(dir.join("real/target.toml"), "edited").unwrap();
        fence(&linked, &dir.join("real"));
        assert!(linked.take(later()), "an edit through a link was missed");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The debounce on a clock of its own: events closer than `QUIET` are one burst, handed out
    /// `QUIET` after the last one, or `LONGEST` after the first if they keep coming.
    #[test]
    fn bursts_are_handed_out_once() {
        let t0 = Instant::now();
        let ms = |n: u64| t0 + Duration::from_millis(n);
        let mut b = Burst::default();
        assert!(!b.take(ms(1000)), "nothing happened");
        b.note(ms(0));
        b.note(ms(10));
        assert_eq!(b.due(), Some(ms(10) + QUIET));
        assert!(!b.take(ms(30)) && b.take(ms(35)) && !b.take(ms(1000)), "once, 25 ms after the last");
        for t in (100..200).step_by(10) {
            b.note(ms(t));
        }
        assert_eq!(b.due(), Some(ms(100) + LONGEST), "a stream of writes waits no longer than LONGEST");
    }

    #[test]
    fn shader_dir_watch_sees_edits_and_new_files() {
        let dir = temp_dir("shaders");
        std::fs::create_dir_all(dir.join("common")).unwrap();
        std::fs::write(dir.join("a.comp"), "void main(){}").unwrap();
        std::fs::write(dir.join("common/b.glsl"), "").unwrap();
        let (_, wake) = counted();
        let watch = Watch::shader_dir(&dir, wake);
        std::fs::write(dir.join("notes.txt"), "").unwrap();
        fence(&watch, &dir);
        assert!(!watch.take(later()), "only shader sources count");
        std::fs::write(dir.join("common/b.glsl"), "// edited").unwrap();
        fence(&watch, &dir);
        assert!(watch.take(later()), "an edit in a subfolder");
        std::fs::write(dir.join("new.frag"), "").unwrap();
        fence(&watch, &dir);
        assert!(watch.take(later()), "a new shader");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Where notify cannot watch, the polling watcher sees a save (its modification time moved,
    /// since file systems with coarse timestamps could give the edit the same one).
    #[test]
    fn the_polling_fallback_sees_a_save() {
        let dir = temp_dir("poll");
        let path = dir.join("scene.toml");
        std::fs::write(&path, "a").unwrap();
        let (_, wake) = counted();
        let file = absolute_in_folder(&path);
        let targets = vec![(file.clone(), RecursiveMode::NonRecursive)];
        let watch = Watch::start(Filter::Files(vec![file]), vec![], targets, wake, true);
        assert!(watch.polling());
        std::fs::write(&path, "bb").unwrap();
        let ahead = std::time::SystemTime::now() + Duration::from_secs(5);
        std::fs::File::options().write(true).open(&path).unwrap().set_modified(ahead).unwrap();
        // No fence here (the poller watches the file alone): wait until the save is noted. One
        // poll period (100 ms) is due; the 60 s limit only turns a missed save into a failure
        // instead of a hang.
        let start = Instant::now();
        while watch.due().is_none() {
            assert!(start.elapsed() < Duration::from_secs(60), "the poller missed the save");
            std::thread::sleep(Duration::from_millis(1));
        }
        assert!(watch.take(later()) && !watch.take(later()), "the save is handed out once");
        std::fs::remove_dir_all(&dir).ok();
    }
}
