//! Hot reload: files are polled for a changed modification time (no watcher thread, no extra
//! crate), and a new scene or shader set replaces the running one only if it works; otherwise the
//! last good one stays and the error is kept for the title and printed once.

use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// A set of files and the modification times last seen.
#[derive(Debug)]
pub struct Watch {
    files: Vec<(PathBuf, Option<SystemTime>)>,
}

impl Watch {
    pub fn new(files: Vec<PathBuf>) -> Self {
        let files = files.into_iter().map(|p| (p.clone(), mtime(&p))).collect();
        Watch { files }
    }

    /// Every shader source under `dir` (what `HADOU_SHADER_DIR` compiles from).
    pub fn shader_dir(dir: &Path) -> Self {
        let mut files = Vec::new();
        collect_files(dir, &mut files);
        files.sort();
        Watch::new(files)
    }

    /// True when any file's modification time changed (or it appeared or vanished) since the last call.
    pub fn changed(&mut self) -> bool {
        let mut changed = false;
        for (path, seen) in &mut self.files {
            let now = mtime(path);
            if now != *seen {
                *seen = now;
                changed = true;
            }
        }
        changed
    }

    #[cfg(test)]
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.files.iter().map(|(p, _)| p.as_path())
    }
}

fn mtime(path: &Path) -> Option<SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}

fn collect_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            collect_files(&path, out);
        } else if path.extension().is_some_and(|e| ["comp", "vert", "frag", "glsl"].iter().any(|x| e == *x)) {
            out.push(path);
        }
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
        let mut watch = Watch::new(vec![path.clone()]);
        let mut current = LastGood::new(load(&path).unwrap());
        let applied = RefCell::new(Vec::new());
        let apply = |s: &hadou::scene::Scene| {
            applied.borrow_mut().push(s.camera.fov_y_deg);
            Ok(())
        };
        assert!(!watch.changed());

        // Bad: a negative field of view; the error must name its line.
        let bad = scene_text(45).replace("fov_y_deg = 45", "fov_y_deg = -3");
        let line = bad.lines().position(|l| l.starts_with("fov_y_deg")).unwrap() + 1;
        std::fs::write(&path, bad).unwrap();
        set_mtime_forward(&path);
        assert!(watch.changed());
        let outcome = current.replace(load(&path), apply);
        let Replaced::KeptLastGood(message) = outcome else { panic!("{outcome:?}") };
        assert!(message.contains(&format!("scene.toml:{line}:")), "{message}");
        assert!(message.contains("fov_y_deg"), "{message}");
        assert_eq!(current.get().camera.fov_y_deg, 45.0);
        assert!(applied.borrow().is_empty(), "a scene that does not parse never reaches the runtime");
        assert!(current.error().is_some());

        std::fs::write(&path, scene_text(60)).unwrap();
        set_mtime_forward(&path);
        assert!(watch.changed());
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

    #[test]
    fn shader_dir_watch_sees_edits_and_new_files() {
        let dir = temp_dir("shaders");
        std::fs::create_dir_all(dir.join("common")).unwrap();
        std::fs::write(dir.join("a.comp"), "void main(){}").unwrap();
        std::fs::write(dir.join("common/b.glsl"), "").unwrap();
        std::fs::write(dir.join("notes.txt"), "").unwrap();
        let mut watch = Watch::shader_dir(&dir);
        assert_eq!(watch.paths().count(), 2, "only shader sources are watched");
        assert!(!watch.changed());
        set_mtime_forward(&dir.join("common/b.glsl"));
        assert!(watch.changed());
        assert!(!watch.changed(), "a change is reported once");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// File systems with coarse timestamps could give an edit the same mtime: move it forward.
    fn set_mtime_forward(path: &Path) {
        let later = SystemTime::now() + std::time::Duration::from_secs(5 + COUNTER.fetch_add(1, ORD));
        std::fs::File::options().write(true).open(path).unwrap().set_modified(later).unwrap();
    }
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    const ORD: std::sync::atomic::Ordering = std::sync::atomic::Ordering::Relaxed;
}
