//! Writes a command's outputs safely.
//!
//! - Only regular files are written: an output path that is a directory, device, FIFO or socket
//!   is refused; a symlink is followed to the regular file it names (that file is replaced, the
//!   link kept); a symlink to anything else, or to nothing, is refused.
//! - `check_outputs` runs before any work: the checks above, no output naming an input or
//!   another output (compared as canonical paths), and every output folder takes a new file.
//! - `OutputSet` commits the outputs of one command as a set: every file goes to a temporary
//!   `.NAME.PID.tmp` beside its target first; only when all are written are they renamed into
//!   place. A failed write removes every temporary and replaces nothing. Temporaries left by a
//!   killed process (whose PID is gone) are removed the next time that target is written.
//! - SIGINT and SIGTERM remove this process's temporaries before it exits (`interrupt`), and a
//!   set is never half renamed by them.

// Signal handling through libc: the one place this crate needs `unsafe`.
#[allow(unsafe_code)]
pub mod interrupt;
mod memory;

use std::io::{ErrorKind, Write};
use std::os::unix::fs::FileTypeExt;
use std::path::{Component, Path, PathBuf};

use crate::aov::AovImage;

/// Why an output was not written; each names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    // `error` is not a `source`: the message already holds the OS text, and a chain printer
    // (anyhow's `{:#}`) would repeat it.
    /// Creating, writing or renaming the file (or its temporary) failed.
    #[error("cannot write {}: {error}", path.display())]
    Io {
        /// The output.
        path: PathBuf,
        /// What the OS said.
        error: std::io::Error,
    },
    /// The image could not be encoded in the format its extension names.
    #[error("cannot encode {}: {message}", path.display())]
    Encode {
        /// The output.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
    /// The path is not one hadou writes to (the rules in the module docs); the message says what
    /// was found and what was expected.
    #[error("output {}: {message}", path.display())]
    Refused {
        /// The output.
        path: PathBuf,
        /// What was expected.
        message: String,
    },
}

fn io_error(path: &Path) -> impl Fn(std::io::Error) -> OutputError + '_ {
    move |error| OutputError::Io { path: path.to_path_buf(), error }
}

fn refused(path: &Path, message: impl Into<String>) -> OutputError {
    OutputError::Refused { path: path.to_path_buf(), message: message.into() }
}

/// What a non-regular file is, for messages.
fn kind(t: std::fs::FileType) -> &'static str {
    if t.is_dir() {
        "a directory"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_socket() {
        "a socket"
    } else if t.is_symlink() {
        "a symlink"
    } else {
        "not a regular file"
    }
}

/// The file an output path will replace, as a canonical path: the path itself, or the regular
/// file a symlink leads to. Refuses anything that is not (or does not lead to) a regular file.
pub fn resolve_target(path: &Path) -> Result<PathBuf, OutputError> {
    if path.file_name().is_none() {
        return Err(refused(path, "names no file (expected a file name, e.g. out.png)"));
    }
    let meta = match std::fs::symlink_metadata(path) {
        Ok(meta) => meta,
        // Not there yet (or a file stands where a folder should: `check_writable` says so).
        Err(e) if matches!(e.kind(), ErrorKind::NotFound | ErrorKind::NotADirectory) => {
            return absent_target(path)
        }
        Err(e) => return Err(io_error(path)(e)),
    };
    if meta.file_type().is_symlink() {
        return match std::fs::metadata(path) {
            Ok(to) if to.is_file() => std::fs::canonicalize(path).map_err(io_error(path)),
            Ok(to) => {
                Err(refused(path, format!("is a symlink to {}, not to a regular file", kind(to.file_type()))))
            }
            Err(_) => Err(refused(path, "is a symlink to nothing (a dangling link is not written through)")),
        };
    }
    if !meta.is_file() {
        let what = kind(meta.file_type());
        return Err(refused(path, format!("is {what}; only regular files are written")));
    }
    std::fs::canonicalize(path).map_err(io_error(path))
}

/// A path that does not exist yet: its nearest existing folder canonicalized, then the rest.
/// The rest is resolved lexically, which is exact because none of it exists (no symlinks).
fn absent_target(path: &Path) -> Result<PathBuf, OutputError> {
    let abs = std::path::absolute(path).map_err(io_error(path))?;
    let base = abs.ancestors().find(|a| std::fs::metadata(a).is_ok()).unwrap_or(Path::new("/"));
    let mut out = std::fs::canonicalize(base).map_err(io_error(path))?;
    for c in abs.strip_prefix(base).unwrap_or(&abs).components() {
        match c {
            Component::Normal(name) => out.push(name),
            Component::ParentDir => {
                out.pop();
            }
            _ => {}
        }
    }
    Ok(out)
}

/// Checks a command's outputs before any work is done (see the module documentation). `inputs`
/// that cannot be resolved (missing files) are skipped: reading them reports the problem.
pub fn check_outputs(outputs: &[&Path], inputs: &[&Path]) -> Result<(), OutputError> {
    let inputs: Vec<(PathBuf, &Path)> =
        inputs.iter().filter_map(|p| std::fs::canonicalize(p).ok().map(|c| (c, *p))).collect();
    let mut seen: Vec<(PathBuf, &Path)> = Vec::new();
    for &path in outputs {
        let target = resolve_target(path)?;
        if let Some((_, input)) = inputs.iter().find(|(c, _)| *c == target) {
            return Err(refused(path, format!("is the input {}; it would be overwritten", input.display())));
        }
        if let Some((_, other)) = seen.iter().find(|(c, _)| *c == target) {
            return Err(refused(
                path,
                format!("is also the output {}; each output needs its own file", other.display()),
            ));
        }
        check_writable(path, &target)?;
        seen.push((target, path));
    }
    Ok(())
}

/// Creates and removes a temporary in the target's folder (or, when that folder does not exist
/// yet, in the nearest one that does, where it will be created).
fn check_writable(path: &Path, target: &Path) -> Result<(), OutputError> {
    let dir = target.parent().unwrap_or(Path::new("/"));
    let Some(existing) = dir.ancestors().find(|a| std::fs::symlink_metadata(a).is_ok()) else {
        return Err(refused(path, "no folder of it exists"));
    };
    if !existing.is_dir() {
        return Err(refused(path, format!("{} is not a folder", existing.display())));
    }
    let probe = temp_path(&existing.join(target.file_name().unwrap_or_default()));
    interrupt::create_temporary(&probe)
        .map_err(|e| refused(path, format!("cannot create a file in {}: {e}", existing.display())))?;
    interrupt::remove_temporary(&probe);
    Ok(())
}

/// `.NAME.PID.tmp` beside `target`.
fn temp_path(target: &Path) -> PathBuf {
    let name = target.file_name().unwrap_or_default().to_string_lossy();
    target.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Removes the temporaries `.NAME.PID.tmp` (or `.NAME.PID.N.tmp`) of `name` in `dir` whose
/// process is gone: what a killed writer left. Best effort; errors are ignored.
pub fn remove_stale_temps(dir: &Path, name: &str) {
    // Without /proc a live process cannot be told from a dead one: keep everything.
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    let prefix = format!(".{name}.");
    for entry in entries.flatten() {
        let file = entry.file_name();
        let Some(pid) = file.to_str().and_then(|f| stale_pid(f, &prefix)) else { continue };
        let alive = pid == std::process::id() || Path::new("/proc").join(pid.to_string()).exists();
        if !alive && entry.file_type().is_ok_and(|t| t.is_file()) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// The PID in `{prefix}PID.tmp` or `{prefix}PID.N.tmp`.
fn stale_pid(file: &str, prefix: &str) -> Option<u32> {
    let middle = file.strip_prefix(prefix)?.strip_suffix(".tmp")?;
    let (pid, n) = middle.split_once('.').unwrap_or((middle, "0"));
    n.parse::<u64>().ok()?;
    pid.parse().ok()
}

/// Outputs written to temporaries and renamed into place together by `commit`. Dropped without
/// a commit (an error on the way), it removes its temporaries and replaces nothing.
#[derive(Debug, Default)]
pub struct OutputSet {
    staged: Vec<Staged>,
}

#[derive(Debug)]
struct Staged {
    path: PathBuf,
    target: PathBuf,
    tmp: PathBuf,
}

impl OutputSet {
    /// Writes `bytes` to the temporary of `path` (checked again: it may have changed since
    /// `check_outputs`).
    pub fn stage(&mut self, path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
        let target = resolve_target(path)?;
        if let Some(other) = self.staged.iter().find(|s| s.target == target) {
            let message =
                format!("is also the output {}; each output needs its own file", other.path.display());
            return Err(refused(path, message));
        }
        let dir = target.parent().unwrap_or(Path::new("/"));
        std::fs::create_dir_all(dir).map_err(io_error(path))?;
        remove_stale_temps(dir, &target.file_name().unwrap_or_default().to_string_lossy());
        let tmp = temp_path(&target);
        // Registered for removal on SIGINT/SIGTERM from before it exists (`interrupt`).
        let written = interrupt::create_temporary(&tmp).and_then(|mut f| {
            f.write_all(bytes)?;
            f.sync_all()
        });
        if let Err(e) = written {
            interrupt::remove_temporary(&tmp);
            return Err(io_error(path)(e));
        }
        self.staged.push(Staged { path: path.to_path_buf(), target, tmp });
        test_pause_after_stage();
        Ok(())
    }

    /// Renames every temporary over its target. The interrupt cleanup waits until all are
    /// renamed (or the first failure): a signal never leaves half a set in place.
    pub fn commit(mut self) -> Result<(), OutputError> {
        let mut registry = interrupt::registry();
        while let Some(s) = self.staged.first() {
            std::fs::rename(&s.tmp, &s.target).map_err(io_error(&s.path))?;
            interrupt::forget(&mut registry, &s.tmp);
            self.staged.remove(0);
        }
        Ok(())
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        for s in &self.staged {
            interrupt::remove_temporary(&s.tmp);
        }
    }
}

/// For tests only: `HADOU_TEST_STAGE_PAUSE_MS=N` sleeps N ms (at most a minute) after each
/// output's (or cache file's) temporary is written, so that a test can interrupt a command while
/// its temporaries exist (tests/interrupts.rs). Unset in any real use.
pub(crate) fn test_pause_after_stage() {
    let Some(ms) = std::env::var("HADOU_TEST_STAGE_PAUSE_MS").ok().and_then(|v| v.parse::<u64>().ok()) else {
        return;
    };
    std::thread::sleep(std::time::Duration::from_millis(ms.min(60_000)));
}

/// Writes `bytes` to `path` as a set of one: via a temporary in the same folder.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let mut set = OutputSet::default();
    set.stage(path, bytes)?;
    set.commit()
}

/// Encodes RGBA8 pixels as PNG; `path` names the output in errors. Host memory for the copy and
/// the encoded bytes is reserved fallibly: too little is an error, not an abort.
pub fn encode_png(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<Vec<u8>, OutputError> {
    let encode = |message: String| OutputError::Encode { path: path.to_path_buf(), message };
    let out_of_memory = |bytes: usize| encode(format!("out of host memory ({bytes} bytes)"));
    let mut pixels = memory::try_filled(rgba.len(), 0u8).ok_or_else(|| out_of_memory(rgba.len()))?;
    pixels.copy_from_slice(rgba);
    let img = image::RgbaImage::from_raw(width, height, pixels)
        .ok_or_else(|| encode(format!("{} bytes is not {width}x{height} RGBA", rgba.len())))?;
    // A PNG is rarely larger than its pixels: that much room first, more only if asked for.
    let mut bytes =
        memory::FallibleCursor::with_capacity(rgba.len() / 2).map_err(|_| out_of_memory(rgba.len() / 2))?;
    img.write_to(&mut bytes, image::ImageFormat::Png).map_err(|e| encode(e.to_string()))?;
    Ok(bytes.into_inner())
}

/// Encodes RGBA8 pixels as PNG and writes them.
pub fn write_png(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<(), OutputError> {
    write_atomically(path, &encode_png(path, width, height, rgba)?)
}

/// Encodes an AOV as OpenEXR with f32 channels: one channel named `Y`, or R, G, B, A.
pub fn encode_exr(path: &Path, name: &str, aov: &AovImage) -> Result<Vec<u8>, OutputError> {
    use exr::prelude::*;
    let encode = |message: String| OutputError::Encode { path: path.to_path_buf(), message };
    let (w, h, n) = (aov.width as usize, aov.height as usize, aov.channels as usize);
    if aov.data.len() != w * h * n {
        return Err(encode(format!("{} values is not {w}x{h}x{n}", aov.data.len())));
    }
    // One channel: luminance-like Y; two (motion): R, G; four: RGBA.
    let names: &[&str] = if n == 1 { &["Y"] } else { &["R", "G", "B", "A"][..n.min(4)] };
    // Planar copies of the channels and the encoded bytes, reserved fallibly: a size the host
    // cannot hold is an error naming the output, not an abort.
    let out_of_memory = |bytes: usize| encode(format!("out of host memory ({bytes} bytes)"));
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::with_capacity(names.len());
    for (c, label) in names.iter().enumerate() {
        let mut samples = memory::try_filled(w * h, 0f32).ok_or_else(|| out_of_memory(4 * w * h))?;
        for (s, v) in samples.iter_mut().zip(aov.data.iter().skip(c).step_by(n)) {
            *s = *v;
        }
        channels.push(AnyChannel::new(*label, FlatSamples::F32(samples)));
    }
    let layer = Layer::new(
        (w, h),
        LayerAttributes::named(name),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels.into()),
    );
    // Lossless compression of noisy floats barely shrinks them: room for half first.
    let mut bytes =
        memory::FallibleCursor::with_capacity(2 * w * h * n).map_err(|_| out_of_memory(2 * w * h * n))?;
    Image::from_layer(layer).write().to_buffered(&mut bytes).map_err(|e| encode(e.to_string()))?;
    Ok(bytes.into_inner())
}

/// Encodes an AOV as OpenEXR and writes it.
pub fn write_exr(path: &Path, name: &str, aov: &AovImage) -> Result<(), OutputError> {
    write_atomically(path, &encode_exr(path, name, aov)?)
}

/// Reads a single-channel f32 EXR written by `write_exr` (tests and tools).
pub fn read_exr_channel(path: &Path) -> Result<(u32, u32, Vec<f32>), String> {
    use exr::prelude::*;
    let image = read_first_flat_layer_from_file(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let size = image.layer_data.size;
    let channel = image.layer_data.channel_data.list.first().ok_or("no channels")?;
    let values: Vec<f32> = channel.sample_data.values_as_f32().collect();
    Ok((size.0 as u32, size.1 as u32, values))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("hadou-output-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn mkfifo(path: &Path) {
        let ok = std::process::Command::new("mkfifo").arg(path).status().unwrap().success();
        assert!(ok, "mkfifo {}", path.display());
    }

    fn refusal(result: Result<(), OutputError>) -> String {
        match result {
            Err(e @ OutputError::Refused { .. }) => e.to_string(),
            other => panic!("expected a refusal, got {other:?}"),
        }
    }

    #[test]
    fn special_files_are_refused_and_left_alone() {
        let dir = tmp_dir("special");
        let fifo = dir.join("fifo");
        mkfifo(&fifo);
        let folder = dir.join("folder");
        std::fs::create_dir(&folder).unwrap();
        let to_null = dir.join("to_null");
        std::os::unix::fs::symlink("/dev/null", &to_null).unwrap();
        let dangling = dir.join("dangling");
        std::os::unix::fs::symlink(dir.join("nothing"), &dangling).unwrap();
        for (path, says) in [
            (Path::new("/dev/null"), "character device"),
            (Path::new("/dev/full"), "character device"),
            (fifo.as_path(), "FIFO"),
            (folder.as_path(), "directory"),
            (to_null.as_path(), "symlink to a character device"),
            (dangling.as_path(), "symlink to nothing"),
        ] {
            let msg = refusal(write_atomically(path, b"x"));
            assert!(msg.contains(&path.display().to_string()) && msg.contains(says), "{msg}");
            let msg = refusal(check_outputs(&[path], &[]));
            assert!(msg.contains(says), "{msg}");
        }
        assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());
        assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
        assert!(std::fs::symlink_metadata(&to_null).unwrap().file_type().is_symlink());
        assert!(std::fs::symlink_metadata(&dangling).unwrap().file_type().is_symlink());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_symlink_to_a_regular_file_is_written_through() {
        let dir = tmp_dir("through");
        let real = dir.join("real.png");
        std::fs::write(&real, b"old").unwrap();
        let link = dir.join("link.png");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_atomically(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn outputs_may_not_name_an_input_or_each_other() {
        let dir = tmp_dir("same");
        let scene = dir.join("s.toml");
        std::fs::write(&scene, b"scene").unwrap();
        let png = dir.join("a.png");
        // The same file spelled another way, and a file not there yet.
        let scene_again = dir.join("sub/../s.toml");
        std::fs::create_dir(dir.join("sub")).unwrap();
        let msg = refusal(check_outputs(&[scene_again.as_path()], &[scene.as_path()]));
        assert!(msg.contains("is the input"), "{msg}");
        let png_again = dir.join("new/../a.png");
        let msg = refusal(check_outputs(&[png.as_path(), png_again.as_path()], &[scene.as_path()]));
        assert!(msg.contains("is also the output"), "{msg}");
        let new = dir.join("new/b.exr");
        check_outputs(&[png.as_path(), new.as_path()], &[scene.as_path()]).unwrap();
        let mut set = OutputSet::default();
        set.stage(&png, b"a").unwrap();
        assert!(refusal(set.stage(&png_again, b"b")).contains("is also the output"));
        drop(set);
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2, "only s.toml and sub/");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_unwritable_location_is_found_before_any_work() {
        let dir = tmp_dir("unwritable");
        let file = dir.join("file");
        std::fs::write(&file, b"x").unwrap();
        let msg = refusal(check_outputs(&[file.join("out.png").as_path()], &[]));
        assert!(msg.contains("is not a folder"), "{msg}");
        let msg = refusal(check_outputs(&[Path::new("/proc/hadou-out.png")], &[]));
        assert!(msg.contains("cannot create"), "{msg}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_failed_write_replaces_nothing_and_leaves_no_temporaries() {
        let dir = tmp_dir("set");
        let a = dir.join("a.png");
        std::fs::write(&a, b"old").unwrap();
        std::fs::write(dir.join("file"), b"x").unwrap();
        let mut set = OutputSet::default();
        set.stage(&a, b"new").unwrap();
        // The second output's folder cannot be made (a file is in the way).
        assert!(matches!(set.stage(&dir.join("file/b.exr"), b"b"), Err(OutputError::Io { .. })));
        drop(set);
        assert_eq!(std::fs::read(&a).unwrap(), b"old");
        let mut names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        names.sort();
        assert_eq!(names, ["a.png", "file"]);
        // Both written: both committed.
        let mut set = OutputSet::default();
        set.stage(&a, b"new").unwrap();
        set.stage(&dir.join("sub/b.exr"), b"b").unwrap();
        set.commit().unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), b"new");
        assert_eq!(std::fs::read(dir.join("sub/b.exr")).unwrap(), b"b");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn temporaries_of_dead_processes_are_removed_on_the_next_write() {
        let dir = tmp_dir("stale");
        // Above any pid_max (2^22): never a live process.
        let dead = dir.join(".a.png.2147483647.tmp");
        let dead_numbered = dir.join(".a.png.2147483647.3.tmp");
        let live = dir.join(format!(".a.png.{}.7.tmp", std::os::unix::process::parent_id()));
        let other = dir.join(".b.png.2147483647.tmp");
        for p in [&dead, &dead_numbered, &live, &other] {
            std::fs::write(p, b"litter").unwrap();
        }
        write_atomically(&dir.join("a.png"), b"png").unwrap();
        assert!(!dead.exists() && !dead_numbered.exists());
        assert!(live.exists() && other.exists(), "a live writer's and another target's are kept");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn temporaries_are_registered_for_the_interrupt_cleanup_until_renamed_or_removed() {
        let dir = tmp_dir("registry");
        let registered = |p: &Path| interrupt::registry().iter().any(|t| t == p);
        let a = dir.join("a.png");
        let tmp = temp_path(&std::fs::canonicalize(&dir).unwrap().join("a.png"));
        let mut set = OutputSet::default();
        set.stage(&a, b"a").unwrap();
        assert!(tmp.exists() && registered(&tmp));
        set.commit().unwrap();
        assert!(!tmp.exists() && !registered(&tmp));
        let mut set = OutputSet::default();
        set.stage(&a, b"b").unwrap();
        assert!(registered(&tmp));
        drop(set);
        assert!(!tmp.exists() && !registered(&tmp));
        assert_eq!(std::fs::read(&a).unwrap(), b"a");
        // The probe of `check_outputs` too.
        check_outputs(&[dir.join("b.png").as_path()], &[]).unwrap();
        assert!(!interrupt::registry().iter().any(|t| t.starts_with(&dir)));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn io_errors_state_the_os_text_once() {
        let dir = tmp_dir("once");
        std::fs::write(dir.join("file"), b"x").unwrap();
        let e = write_atomically(&dir.join("file/a.png"), b"x").unwrap_err();
        assert!(std::error::Error::source(&e).is_none(), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
