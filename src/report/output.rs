//! The report folder, written all or nothing: files go into a fresh sibling folder, which replaces
//! `--out` only once everything is written. A bad `--out` (a regular file, an unwritable place)
//! fails before any measurement.

use std::path::{Path, PathBuf};

use super::{csv, plot, Report, ReportError};

/// A staging folder beside the final one; removed on drop unless committed.
pub struct Staging {
    out: PathBuf,
    tmp: PathBuf,
    committed: bool,
}

fn io(what: &str, path: &Path, e: std::io::Error) -> ReportError {
    ReportError::Output(format!("{what} {}: {e}", path.display()))
}

impl Staging {
    /// Checks `out` (absent or a folder) and creates the staging folder beside it.
    pub fn create(out: &Path) -> Result<Staging, ReportError> {
        if out.exists() && !out.is_dir() {
            return Err(ReportError::Output(format!(
                "--out {}: exists and is not a directory (expected a directory to create or replace)",
                out.display()
            )));
        }
        let name = out.file_name().ok_or_else(|| {
            ReportError::Output(format!("--out {}: expected a directory name", out.display()))
        })?;
        let parent = match out.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&parent).map_err(|e| io("cannot create", &parent, e))?;
        let tmp = parent.join(format!(".{}.tmp-{}", name.to_string_lossy(), std::process::id()));
        if tmp.exists() {
            std::fs::remove_dir_all(&tmp).map_err(|e| io("cannot remove the stale", &tmp, e))?;
        }
        // Registered: SIGINT/SIGTERM removes it (output::interrupt).
        hadou::output::interrupt::create_temporary_dir(&tmp).map_err(|e| io("cannot create", &tmp, e))?;
        Ok(Staging { out: out.to_path_buf(), tmp, committed: false })
    }

    /// Writes report.md, one CSV per table and one PNG per plot into the staging folder.
    pub fn write(&self, report: &Report) -> Result<Vec<PathBuf>, ReportError> {
        let mut written = Vec::new();
        let put = |name: &str, bytes: &[u8]| -> Result<PathBuf, ReportError> {
            let path = self.tmp.join(name);
            std::fs::write(&path, bytes).map_err(|e| io("cannot write", &path, e))?;
            Ok(self.out.join(name))
        };
        written.push(put("report.md", report.markdown().as_bytes())?);
        for section in &report.sections {
            for table in &section.tables {
                written.push(put(&format!("{}.csv", table.id), csv::to_csv(table).as_bytes())?);
            }
            for p in &section.plots {
                let (w, h, rgba) =
                    plot::render(p).map_err(|e| ReportError::Output(format!("plot {}: {e}", p.id)))?;
                let name = format!("{}.png", p.id);
                let path = self.tmp.join(&name);
                hadou::output::write_png(&path, w, h, &rgba)
                    .map_err(|e| ReportError::Output(format!("{}: {e}", path.display())))?;
                written.push(self.out.join(name));
            }
        }
        Ok(written)
    }

    /// Puts the staging folder in place of `out` (replacing an earlier report there).
    pub fn commit(mut self) -> Result<PathBuf, ReportError> {
        hadou::output::interrupt::commit_temporary_dir(&self.tmp, &self.out)
            .map_err(|e| io("cannot put the report in place at", &self.out, e))?;
        self.committed = true;
        Ok(self.out.clone())
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        if !self.committed {
            hadou::output::interrupt::remove_temporary(&self.tmp);
        }
    }
}

/// A one-table report for unit tests.
#[cfg(test)]
pub mod tests_support {
    use crate::report::{Header, Report, Section, Table};

    pub fn tiny() -> Report {
        let mut t = Table::new("t", "T", &["a"]);
        t.push(vec![crate::report::Cell::text("x")]);
        let header = Header {
            device: "d".into(),
            device_kind: "cpu".into(),
            driver: "v".into(),
            api_version: "1.3".into(),
            cpu: "c".into(),
            load: "0.1 0.2 0.3".into(),
            git_revision: "r".into(),
            date: "2000-01-01 00:00".into(),
            quick: true,
            build_profile: "debug",
            command: "hadou report".into(),
            effect_size: (1, 1),
            frame_sizes: vec![],
            frames: 1,
            warmup: 0,
        };
        let s = Section { id: "s", title: "S".into(), text: String::new(), tables: vec![t], plots: vec![] };
        Report { header, sections: vec![s] }
    }
}

#[cfg(test)]
mod tests {
    use super::tests_support::tiny;
    use super::*;

    #[test]
    fn replaces_a_folder_and_refuses_a_file() {
        let base = std::env::temp_dir().join(format!("hadou-report-output-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        std::fs::create_dir_all(&base).unwrap();
        let out = base.join("r");
        for _ in 0..2 {
            let staging = Staging::create(&out).unwrap();
            staging.write(&tiny()).unwrap();
            staging.commit().unwrap();
            assert!(out.join("report.md").is_file() && out.join("t.csv").is_file());
        }
        // Only the report is left: no staging or old folder.
        assert_eq!(std::fs::read_dir(&base).unwrap().count(), 1);
        // Dropped without commit: nothing is left behind.
        let other = base.join("q");
        drop(Staging::create(&other).unwrap());
        assert!(!other.exists());
        assert_eq!(std::fs::read_dir(&base).unwrap().count(), 1);
        let file = base.join("file");
        std::fs::write(&file, b"x").unwrap();
        let err = Staging::create(&file).err().unwrap().to_string();
        assert!(err.contains("not a directory"), "{err}");
        std::fs::remove_dir_all(&base).unwrap();
    }
}
