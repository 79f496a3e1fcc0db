//! SIGINT and SIGTERM while outputs are being written: the temporaries of this process are
//! removed before it exits (with 130 or 143, 128 + the signal, as a shell reports it).
//!
//! Nothing but an async-signal-safe `write(2)` of one byte to a socket runs in the signal
//! handler. A watcher thread waits on the other end; when the byte comes it takes the registry
//! of temporaries (the lock every creation, commit and removal of a temporary holds), removes
//! every file in it and ends the process with `_exit`, the lock still held: no other thread can
//! create, rename or register a temporary after the removal, and no destructor or atexit handler
//! runs on the way out (other threads may be inside the Vulkan driver).
//!
//! A signal the process was started ignoring (SIGINT of a background job, say) stays ignored.
//!
//! A set of outputs commits under the same lock, so an interrupt lands before the first rename
//! (nothing replaced, every temporary removed) or after the last (all replaced): never half a set.

use std::ffi::{c_int, c_void};
use std::io::Read;
use std::os::fd::IntoRawFd;
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicI32, Ordering};
use std::sync::{Mutex, MutexGuard, OnceLock};

/// The signals handled (the same numbers on every Linux architecture).
const SIGINT: c_int = 2;
const SIGTERM: c_int = 15;
/// `signal`'s error value, `SIG_ERR` (-1), and the disposition "ignore", `SIG_IGN` (1).
const SIG_ERR: usize = usize::MAX;
const SIG_IGN: usize = 1;

extern "C" {
    // std links the C library; these three are declared here rather than through the `libc`
    // crate (not a direct dependency). Their C prototypes take `int`, `void *` and `size_t`.
    fn signal(signum: c_int, handler: usize) -> usize;
    fn write(fd: c_int, buf: *const c_void, count: usize) -> isize;
    fn _exit(status: c_int) -> !;
    #[cfg(target_os = "linux")]
    fn __errno_location() -> *mut c_int;
}

/// The socket end the handler writes to; -1 until `install`.
static WAKE_FD: AtomicI32 = AtomicI32::new(-1);

/// The temporaries of this process not yet renamed or removed.
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The registry, locked. A panic while it was held leaves the list usable (poisoning ignored).
pub(crate) fn registry() -> MutexGuard<'static, Vec<PathBuf>> {
    TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner())
}

/// Creates (or truncates) the temporary `path` and registers it, under the registry's lock: an
/// interrupt either comes before (no file) or finds it registered.
pub(crate) fn create_temporary(path: &Path) -> std::io::Result<std::fs::File> {
    let mut list = registry();
    let file = std::fs::File::create(path)?;
    list.push(path.to_path_buf());
    Ok(file)
}

/// Removes the temporary `path` (a file, or a folder with what it holds) and forgets it (best
/// effort: one already gone is fine).
pub fn remove_temporary(path: &Path) {
    let mut list = registry();
    remove_path(path);
    forget(&mut list, path);
}

/// Creates the temporary folder `path` (and its parents) and registers it, under the registry's
/// lock: on SIGINT/SIGTERM it is removed with everything in it (a report's staging folder,
/// `profile --ab`'s runs).
pub fn create_temporary_dir(path: &Path) -> std::io::Result<()> {
    let mut list = registry();
    std::fs::create_dir_all(path)?;
    list.push(path.to_path_buf());
    Ok(())
}

/// Puts the temporary folder `tmp` (from `create_temporary_dir`) in place of the folder `out`,
/// replacing an earlier one there. Both renames happen under the registry's lock, so SIGINT/SIGTERM
/// is handled before them (the temporary removed, the old folder kept) or after (the new one in
/// place). On failure the old folder is back and the temporary still registered; the error names
/// which step failed.
pub fn commit_temporary_dir(tmp: &Path, out: &Path) -> std::io::Result<()> {
    let step = |what: &str, e: std::io::Error| std::io::Error::new(e.kind(), format!("{what}: {e}"));
    let mut list = registry();
    let old = tmp.with_extension("old");
    if out.is_dir() {
        std::fs::rename(out, &old).map_err(|e| step("cannot move the earlier folder aside", e))?;
    }
    if let Err(e) = std::fs::rename(tmp, out) {
        let _ = std::fs::rename(&old, out);
        return Err(step("cannot rename the new folder into place", e));
    }
    forget(&mut list, tmp);
    drop(list);
    if old.exists() {
        let _ = std::fs::remove_dir_all(&old);
    }
    Ok(())
}

/// Removes a file, or a folder and what it holds; whether something was removed.
fn remove_path(path: &Path) -> bool {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => std::fs::remove_dir_all(path).is_ok(),
        Ok(_) => std::fs::remove_file(path).is_ok(),
        Err(_) => false,
    }
}

/// Writes `bytes` to the registered temporary `tmp`, then renames it to `dest` under the
/// registry's lock (so an interrupt removes the temporary or finds it renamed, never half of
/// each); on failure the temporary is removed. For files outside an `OutputSet` (cache files:
/// bakes, the pipeline cache).
pub(crate) fn write_through_temporary(tmp: &Path, bytes: &[u8], dest: &Path) -> std::io::Result<()> {
    use std::io::Write;
    let written = create_temporary(tmp).and_then(|mut f| f.write_all(bytes));
    if written.is_ok() {
        super::test_pause_after_stage();
    }
    let renamed = written.and_then(|()| {
        let mut list = registry();
        let renamed = std::fs::rename(tmp, dest);
        if renamed.is_ok() {
            forget(&mut list, tmp);
        }
        renamed
    });
    if renamed.is_err() {
        remove_temporary(tmp);
    }
    renamed
}

/// Forgets `path` in a locked registry (after renaming it into place).
pub(crate) fn forget(list: &mut MutexGuard<'static, Vec<PathBuf>>, path: &Path) {
    if let Some(i) = list.iter().rposition(|p| p == path) {
        list.swap_remove(i);
    }
}

/// The handler: one byte, the signal number, to the watcher. Only async-signal-safe calls.
extern "C" fn on_signal(sig: c_int) {
    let fd = WAKE_FD.load(Ordering::Relaxed);
    let byte = sig as u8;
    #[cfg(target_os = "linux")]
    // SAFETY: __errno_location returns the calling thread's errno, valid for the thread's life;
    // reading and later restoring it keeps the interrupted code's errno intact.
    let saved = unsafe { *__errno_location() };
    // SAFETY: write(2) is async-signal-safe; `fd` is a socket kept open for the life of the
    // process (its Rust owner was turned into a raw fd and never closed) and set non-blocking,
    // so a full buffer (signals in a burst) drops a byte instead of blocking the handler; the
    // buffer is one valid byte on this stack.
    unsafe { write(fd, (&byte as *const u8).cast(), 1) };
    #[cfg(target_os = "linux")]
    // SAFETY: as above; the pointer is this thread's errno.
    unsafe {
        *__errno_location() = saved
    };
}

/// Installs the SIGINT and SIGTERM handlers and starts the watcher thread. Once per process;
/// later calls do nothing. An error leaves the default handling (the process dies at once and
/// its temporaries stay until the next write of that output removes them).
pub fn install() -> std::io::Result<()> {
    static INSTALLED: OnceLock<std::io::Result<()>> = OnceLock::new();
    let result = INSTALLED.get_or_init(|| {
        let (wake, mut watch) = UnixStream::pair()?;
        wake.set_nonblocking(true)?;
        std::thread::Builder::new().name("hadou-interrupt".into()).spawn(move || {
            let mut byte = [0u8; 1];
            loop {
                match watch.read(&mut byte) {
                    Ok(1) => break,
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                    // The other end is never closed; should the read fail, stop watching.
                    _ => return,
                }
            }
            clean_up_and_exit(c_int::from(byte[0]))
        })?;
        WAKE_FD.store(wake.into_raw_fd(), Ordering::Relaxed);
        for sig in [SIGINT, SIGTERM] {
            // SAFETY: `on_signal` is an `extern "C" fn(c_int)` that only calls async-signal-safe
            // functions (see it); signal(2) with a valid signal number has no other requirement.
            let before = unsafe { signal(sig, on_signal as extern "C" fn(c_int) as usize) };
            if before == SIG_ERR {
                return Err(std::io::Error::last_os_error());
            }
            // A signal ignored on entry stays ignored (a background job's SIGINT, `nohup`): the
            // caller asked for it not to end the process.
            if before == SIG_IGN {
                // SAFETY: as above, with the disposition the process was started with.
                unsafe { signal(sig, SIG_IGN) };
            }
        }
        Ok(())
    });
    match result {
        Ok(()) => Ok(()),
        Err(e) => Err(std::io::Error::new(e.kind(), e.to_string())),
    }
}

/// Removes every registered temporary and ends the process with 128 + `sig`, the registry's lock
/// held to the end.
fn clean_up_and_exit(sig: c_int) -> ! {
    let list = registry();
    let mut removed = 0;
    for path in list.iter() {
        if remove_path(path) {
            removed += 1;
        }
    }
    let name = if sig == SIGINT { "SIGINT" } else { "SIGTERM" };
    let message = format!("hadou: interrupted by {name}; removed {removed} temporary file(s)\n");
    // Straight to fd 2, not through std's stderr lock, which another thread might hold.
    // SAFETY: write(2) on fd 2 with a valid buffer and its length; an error (fd 2 closed) is
    // ignored.
    unsafe { write(2, message.as_ptr().cast(), message.len()) };
    // SAFETY: _exit ends the process without running destructors or atexit handlers, which is
    // the point: other threads may be inside the driver. The registry lock is never released.
    unsafe { _exit(128 + sig) }
}
