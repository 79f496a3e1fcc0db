//! One scene of `hadou test`: its sidecar, its reference files, its outcome; the summary table
//! and the JUnit XML report.
//!
//! Sidecar `REFS/NAME.test.toml` (every key optional):
//! ```toml
//! size = "96x64"          # default: the scene's [render] size
//! time = 0.5              # scene time, seconds (default 0)
//! aovs = ["depth"]        # AOVs compared as well as the PNG
//! skip = "why"            # not rendered; reported as skipped
//! [tolerance]             # see `hadou compare`; every threshold defaults to 0 (bit-exact)
//! flip = 0.0
//! abs = 0.0
//! rel = 0.0
//! pixels = 0.0
//! ```

use std::path::{Path, PathBuf};

use anyhow::Context;
use hadou::compare::Tolerance;
use hadou::Aov;
use serde::Deserialize;

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sidecar {
    pub size: Option<String>,
    #[serde(default)]
    pub time: f64,
    #[serde(default)]
    aovs: Vec<String>,
    pub skip: Option<String>,
    #[serde(default)]
    pub tolerance: Tolerance,
}

impl Sidecar {
    /// The sidecar at `path`, or the defaults when there is none. Only a regular file is read (a
    /// FIFO would block forever, a device might never end), and at most `MAX_SIDECAR_BYTES`.
    pub fn read(path: &Path) -> anyhow::Result<Sidecar> {
        let meta = match std::fs::metadata(path) {
            Ok(meta) => meta,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                // A symlink to nothing is a mistake, not "no sidecar".
                if std::fs::symlink_metadata(path).is_ok() {
                    anyhow::bail!(
                        "{}: is a symlink to nothing (expected a sidecar TOML file)",
                        path.display()
                    );
                }
                return Ok(Sidecar::default());
            }
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
        };
        if !meta.is_file() {
            anyhow::bail!(
                "{}: is {}, not a regular file (expected a sidecar TOML file)",
                path.display(),
                file_kind(meta.file_type())
            );
        }
        if meta.len() > MAX_SIDECAR_BYTES {
            anyhow::bail!(
                "{}: is {} bytes, more than a sidecar may have ({MAX_SIDECAR_BYTES}; a sidecar is a few lines of TOML)",
                path.display(),
                meta.len()
            );
        }
        let text =
            std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
        let sidecar: Sidecar = toml::from_str(&text).map_err(|e| {
            let at = e.span().map(|s| line_col(&text, s.start)).unwrap_or_default();
            anyhow::anyhow!(
                "{}{at}: {} (expected size, time, aovs, skip, [tolerance] flip/abs/rel/pixels)",
                path.display(),
                e.message()
            )
        })?;
        let bad = |what: String| anyhow::anyhow!("{}: {what}", path.display());
        sidecar.tolerance.validate().map_err(bad)?;
        if !sidecar.time.is_finite() {
            return Err(bad(format!("time {} is not a finite number of seconds", sidecar.time)));
        }
        sidecar.aovs().map_err(|e| bad(e.to_string()))?;
        Ok(sidecar)
    }

    pub fn aovs(&self) -> anyhow::Result<Vec<Aov>> {
        let names: Vec<_> = Aov::ALL.iter().chain(&Aov::UPSCALER).map(|a| a.name()).collect();
        self.aovs
            .iter()
            .map(|n| {
                Aov::from_name(n).with_context(|| {
                    format!("unknown AOV `{n}` in aovs (expected one of: {})", names.join(", "))
                })
            })
            .collect()
    }
}

/// The largest sidecar read: 64 KiB. A sidecar is a handful of lines (this project's are under
/// 100 bytes); a thousand times that still reads in no time, and a file named `.test.toml` that is
/// really an image or a log is refused by its size instead of being read whole.
pub const MAX_SIDECAR_BYTES: u64 = 64 << 10;

/// What a file that is not a regular file is, for messages.
pub fn file_kind(t: std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_socket() {
        "a socket"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else {
        "not a regular file"
    }
}

fn line_col(text: &str, offset: usize) -> String {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map(|l| l.chars().count()).unwrap_or(0) + 1;
    format!(":{line}:{col}")
}

#[derive(Debug)]
pub enum Outcome {
    NotRun,
    Passed(String),
    Failed(String),
    Error(String),
    Skipped(String),
    Blessed(usize),
}

#[derive(Debug)]
pub struct Case {
    /// The scene's file stem, as the file system has it (references are named from it).
    pub stem: std::ffi::OsString,
    /// The stem for people: control characters and odd bytes escaped.
    pub name: String,
    pub scene: PathBuf,
    pub refs: PathBuf,
    pub sidecar_path: PathBuf,
    pub sidecar: Sidecar,
    pub outcome: Outcome,
    pub seconds: f64,
    /// The scene, loaded before the GPU starts (its files are inputs that no output may name).
    pub loaded: Option<Result<hadou::scene::Scene, String>>,
}

impl Case {
    pub fn new(scene: PathBuf, refs: &Path) -> Case {
        let stem = scene.file_stem().unwrap_or_default().to_os_string();
        Case {
            sidecar_path: refs.join(with_suffix(&stem, ".test.toml")),
            name: super::escape_os(&stem),
            stem,
            scene,
            refs: refs.to_path_buf(),
            sidecar: Sidecar::default(),
            outcome: Outcome::NotRun,
            seconds: 0.0,
            loaded: None,
        }
    }

    pub fn reference_png(&self) -> PathBuf {
        self.refs.join(with_suffix(&self.stem, ".png"))
    }

    pub fn reference_aov(&self, aov: Aov) -> PathBuf {
        self.refs.join(with_suffix(&self.stem, &format!(".{}.exr", aov.name())))
    }

    /// Every reference file of the scene: the PNG, then one EXR per AOV of its sidecar.
    pub fn references(&self) -> Vec<PathBuf> {
        let aovs = self.sidecar.aovs().unwrap_or_default();
        std::iter::once(self.reference_png()).chain(aovs.into_iter().map(|a| self.reference_aov(a))).collect()
    }
}

/// `stem` + `suffix`, without going through text (a stem need not be UTF-8).
pub fn with_suffix(stem: &std::ffi::OsStr, suffix: &str) -> std::ffi::OsString {
    let mut name = stem.to_os_string();
    name.push(suffix);
    name
}

/// One row per scene, then the counts.
pub fn table(cases: &[Case], bless: bool) -> String {
    let width = cases.iter().map(|c| c.name.len()).max().unwrap_or(5).max(5);
    let mut out = format!("{:<width$}  {:<7} {:>7}  detail\n", "scene", "result", "seconds");
    let (mut passed, mut failed, mut errors, mut skipped) = (0, 0, 0, 0);
    for c in cases {
        let (result, detail) = match &c.outcome {
            Outcome::Passed(d) => {
                passed += 1;
                ("pass", d.clone())
            }
            Outcome::Blessed(n) => {
                passed += 1;
                ("blessed", format!("{n} reference file(s) written"))
            }
            Outcome::Failed(d) => {
                failed += 1;
                ("FAIL", d.clone())
            }
            Outcome::Error(d) => {
                errors += 1;
                ("ERROR", d.clone())
            }
            Outcome::Skipped(d) => {
                skipped += 1;
                ("skip", d.clone())
            }
            Outcome::NotRun => ("-", String::new()),
        };
        // Names and details may hold file names: nothing in them reaches the terminal raw.
        let detail = super::escape_controls(&detail);
        out += &format!("{:<width$}  {result:<7} {:>7.2}  {detail}\n", c.name, c.seconds);
    }
    let verb = if bless { "blessed" } else { "passed" };
    // Not the bare "N passed, N failed" line: test harnesses read that as their own summary.
    out += &format!(
        "hadou test: {} scenes: {passed} {verb}, {failed} failed, {errors} errors, {skipped} skipped\n",
        cases.len()
    );
    if bless && errors > 0 {
        out += "hadou test: nothing was blessed (a scene had an error)\n";
    }
    out
}

fn xml(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for ch in text.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // Control characters are not allowed in XML 1.0.
            c if (c as u32) < 0x20 && !matches!(c, '\n' | '\t' | '\r') => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

/// A JUnit XML report: one `testsuite`, one `testcase` per scene.
pub fn junit(cases: &[Case], dir: &Path, seconds: f64) -> String {
    let count = |f: fn(&Outcome) -> bool| cases.iter().filter(|c| f(&c.outcome)).count();
    let failures = count(|o| matches!(o, Outcome::Failed(_)));
    let errors = count(|o| matches!(o, Outcome::Error(_)));
    let skipped = count(|o| matches!(o, Outcome::Skipped(_)));
    let suite = xml(&format!("hadou test {}", dir.display()));
    let mut out = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let attrs = format!(
        "tests=\"{}\" failures=\"{failures}\" errors=\"{errors}\" skipped=\"{skipped}\" time=\"{seconds:.3}\"",
        cases.len()
    );
    out += &format!("<testsuites name=\"{suite}\" {attrs}>\n  <testsuite name=\"{suite}\" {attrs}>\n");
    for c in cases {
        out += &format!(
            "    <testcase classname=\"hadou.golden\" name=\"{}\" file=\"{}\" time=\"{:.3}\"",
            xml(&c.name),
            xml(&c.scene.display().to_string()),
            c.seconds
        );
        let (tag, text) = match &c.outcome {
            Outcome::Failed(t) => ("failure", t),
            Outcome::Error(t) => ("error", t),
            Outcome::Skipped(t) => ("skipped", t),
            _ => {
                out += "/>\n";
                continue;
            }
        };
        out += &format!(">\n      <{tag} message=\"{}\">{}</{tag}>\n    </testcase>\n", xml(text), xml(text));
    }
    out += "  </testsuite>\n</testsuites>\n";
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn junit_escapes_what_xml_reserves() {
        assert_eq!(xml("a<b>&\"c'\u{1}\n"), "a&lt;b&gt;&amp;&quot;c&apos; \n");
        let mut case = Case::new(PathBuf::from("s/<odd>.toml"), Path::new("r"));
        case.outcome = Outcome::Failed("x.png: mean FLIP 0.5 > threshold 0 & more".into());
        let report = junit(&[case], Path::new("s"), 1.0);
        assert!(report.contains("name=\"&lt;odd&gt;\""), "{report}");
        assert!(
            report.contains("<failure message=\"x.png: mean FLIP 0.5 &gt; threshold 0 &amp; more\">"),
            "{report}"
        );
        assert!(report.contains("tests=\"1\" failures=\"1\" errors=\"0\" skipped=\"0\""), "{report}");
    }
}
