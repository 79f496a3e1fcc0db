//! `hadou test --bless` all or none: the new references are staged as temporaries (an
//! `OutputSet`); before they are renamed into place, every reference they replace is kept as a
//! hard link (a copy where the file system has none) `.NAME.PID.1.tmp` beside it. When a rename
//! fails midway, the references already replaced are renamed back from those and the new ones
//! removed: the folder is as it was. A process killed in between leaves the backups as stale
//! temporaries, which the next write of that reference removes (`hadou::output`).

use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use anyhow::Context;
use hadou::output::{self, OutputSet};

/// A reference about to be replaced: its file (a symlink's target), and what it was.
struct Kept {
    target: PathBuf,
    /// Device and inode of the file there before (None: there was none).
    before: Option<(u64, u64)>,
    /// Where the old file is kept.
    backup: Option<PathBuf>,
}

/// Renames every file staged in `set` (the outputs `paths`, in staging order) into place, or,
/// when one cannot be, none: those already renamed are put back.
pub fn commit(set: OutputSet, paths: &[PathBuf]) -> anyhow::Result<()> {
    let mut kept: Vec<Kept> = Vec::new();
    let result = keep_all(paths, &mut kept).and_then(|()| Ok(set.commit()?));
    let Err(e) = result else {
        remove_backups(&kept);
        return Ok(());
    };
    let failed = restore(&kept);
    remove_backups(&kept);
    if failed.is_empty() {
        Err(e.context("nothing was blessed (every reference is as it was)"))
    } else {
        Err(e.context(format!(
            "blessing failed midway and these references could not be put back: {}",
            failed.join("; ")
        )))
    }
}

fn identity(path: &Path) -> Option<(u64, u64)> {
    std::fs::symlink_metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

/// Keeps the file each path replaces; fails (changing nothing) when one cannot be kept.
fn keep_all(paths: &[PathBuf], kept: &mut Vec<Kept>) -> anyhow::Result<()> {
    for path in paths {
        let target = output::resolve_target(path)?;
        let before = identity(&target);
        let mut k = Kept { target, before, backup: None };
        if before.is_some() {
            let name = k.target.file_name().unwrap_or_default().to_string_lossy().to_string();
            let backup = k.target.with_file_name(format!(".{name}.{}.1.tmp", std::process::id()));
            let _ = std::fs::remove_file(&backup);
            let made = std::fs::hard_link(&k.target, &backup)
                .or_else(|_| std::fs::copy(&k.target, &backup).map(drop))
                .with_context(|| format!("cannot keep a copy of {} to restore on failure", path.display()));
            if made.is_err() {
                let _ = std::fs::remove_file(&backup);
            }
            made?;
            k.backup = Some(backup);
        }
        kept.push(k);
    }
    Ok(())
}

/// Puts back every reference that was replaced; returns those that could not be.
fn restore(kept: &[Kept]) -> Vec<String> {
    let mut failed = Vec::new();
    for k in kept {
        let now = identity(&k.target);
        if now == k.before {
            continue; // not replaced
        }
        let undone = match &k.backup {
            Some(backup) => std::fs::rename(backup, &k.target),
            None => std::fs::remove_file(&k.target),
        };
        if let Err(e) = undone {
            failed.push(format!("{}: {e}", k.target.display()));
        }
    }
    failed
}

fn remove_backups(kept: &[Kept]) {
    for backup in kept.iter().filter_map(|k| k.backup.as_ref()) {
        let _ = std::fs::remove_file(backup);
    }
}
