//! Checks shared by the scene-file conversions: each turns a `Spanned` value from the schema into
//! a model value or a `SceneError` at that value's line:col, worded "expected …, found …".

use std::collections::HashMap;
use std::fmt::Display;
use std::ops::Range;
use std::path::Path;

use glam::DVec3;
use toml::Spanned;

use super::error::{line_column, SceneError};
use super::file_schema::{Array, Int, Num};

/// The scene text and its path: everything needed to turn a byte span into an error.
#[derive(Clone, Copy)]
pub(crate) struct Ctx<'a> {
    pub text: &'a str,
    pub path: &'a Path,
}

impl Ctx<'_> {
    pub fn err(&self, span: Range<usize>, message: impl Into<String>) -> SceneError {
        SceneError::at_span(self.path, self.text, span, message)
    }

    /// A toml syntax or shape error. Spanless ones (rare) point at the top of the file.
    pub fn toml(&self, e: &toml::de::Error) -> SceneError {
        let span = e.span().unwrap_or(0..0);
        // toml's messages can span lines ("invalid key\nexpected …"); keep one line per error.
        let message = e.message().trim().replace('\n', "; ");
        self.err(span, message)
    }

    /// The start of the key in `key = value`, found by walking back from the value; the value's
    /// own start when the text around it is not that simple shape. Used to point at a key whose
    /// presence (not its value) is the problem.
    pub fn key_start(&self, value: &Range<usize>) -> usize {
        let bytes = self.text.as_bytes();
        let mut i = value.start.min(bytes.len());
        let skip_blank = |mut i: usize| {
            while i > 0 && matches!(bytes[i - 1], b' ' | b'\t') {
                i -= 1;
            }
            i
        };
        i = skip_blank(i);
        if i == 0 || bytes[i - 1] != b'=' {
            return value.start;
        }
        let end = skip_blank(i - 1);
        let mut start = end;
        while start > 0
            && (bytes[start - 1].is_ascii_alphanumeric() || matches!(bytes[start - 1], b'_' | b'-'))
        {
            start -= 1;
        }
        if start == end {
            value.start
        } else {
            start
        }
    }
}

/// A range rule for numbers, worded for messages ("a number > 0").
#[derive(Clone, Copy)]
pub(crate) struct Rule {
    pub ok: fn(f64) -> bool,
    /// The bound as written after "a number": "> 0", "in [0, 1]".
    pub bound: &'static str,
}

pub(crate) const ANY: Rule = Rule { ok: |_| true, bound: "" };
pub(crate) const POSITIVE: Rule = Rule { ok: |v| v > 0.0, bound: "> 0" };
pub(crate) const NON_NEGATIVE: Rule = Rule { ok: |v| v >= 0.0, bound: ">= 0" };
/// At least 0.1°: neighbouring pixel rays (16384 rows at most) differ by 2·tan(fov/2)/16384 of the
/// view direction, which f32 (2⁻²⁴ relative) must resolve: tan(fov/2) ≥ 2⁻¹¹, fov ≥ 0.056°.
pub(crate) const FOV: Rule = Rule { ok: |v| (0.1..180.0).contains(&v), bound: "in [0.1, 180)" };
pub(crate) const UNIT: Rule = Rule { ok: |v| (0.0..=1.0).contains(&v), bound: "in [0, 1]" };
/// A factor the GPU multiplies by (exposure): a normal f32, so it neither flushes to 0 (GPUs may
/// treat subnormals as 0) nor overflows.
pub(crate) const F32_NORMAL: Rule =
    Rule { ok: |v| v >= f32::MIN_POSITIVE as f64, bound: ">= 1.1754944e-38 (f32's smallest normal number)" };
/// A length the GPU squares (a metaball's support radius R, in |x − c|²/R²): R² stays a normal,
/// finite f32, R in [2⁻⁶³, 2⁶³].
pub(crate) const SQUARED_LENGTH: Rule = Rule {
    ok: |v| (1.0842021724855044e-19..=9.223372036854776e18).contains(&v),
    bound: "in [1.0842e-19, 9.2234e18] (2^-63 to 2^63: its square must be a normal f32)",
};
/// A colour written into the HDR target as it is (the background): RGBA16F holds up to 65504.
pub(crate) const HDR: Rule = Rule {
    ok: |v| (0.0..=super::file::MAX_HDR).contains(&v),
    bound: "in [0, 65504] (the HDR target is 16-bit float)",
};

/// Numbers as a person would write them: no 300-digit expansions of 1e300.
pub(crate) fn show(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-4..1e9).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

pub(crate) fn show_vec(v: DVec3) -> String {
    format!("[{}, {}, {}]", show(v.x), show(v.y), show(v.z))
}

/// A computed vector (not one the user wrote) to 4 decimals: `[0, -0.2425, -0.9701]`.
pub(crate) fn show_vec_approx(v: DVec3) -> String {
    let short = |x: f64| {
        let s = format!("{x:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".to_owned()
        } else {
            s.to_owned()
        }
    };
    format!("[{}, {}, {}]", short(v.x), short(v.y), short(v.z))
}

/// One table of the scene file (`[camera]`, a `[[mesh]]`, …): its label in messages and its span.
pub(crate) struct Owner<'a> {
    pub ctx: Ctx<'a>,
    /// How messages name the table: `[camera]`, `mesh "ball"`, `instance 3`.
    pub label: String,
    pub span: Range<usize>,
}

impl<'a> Owner<'a> {
    pub fn new(ctx: Ctx<'a>, label: impl Into<String>, span: Range<usize>) -> Self {
        Owner { ctx, label: label.into(), span }
    }

    /// "`label` `field`: expected …, found …" at `span`.
    pub fn fail(&self, span: Range<usize>, field: &str, expected: &str, found: impl Display) -> SceneError {
        self.ctx.err(span, format!("{} `{field}`: expected {expected}, found {found}", self.label))
    }

    /// A keyframe's required `time`, which must be past the previous keyframe's (`previous`):
    /// keyframes of waves and metaball groups alike strictly increase in time.
    pub fn keyframe_time(
        &self,
        time: Option<&Spanned<Num>>,
        previous: Option<f64>,
    ) -> Result<f64, SceneError> {
        let def = self.required("time", time, "a number, in seconds")?;
        let t = def.get_ref().0;
        match previous {
            Some(p) if t <= p => {
                let expected =
                    format!("a time > {} (the previous keyframe's; times must strictly increase)", show(p));
                Err(self.fail(def.span(), "time", &expected, show(t)))
            }
            _ => Ok(t),
        }
    }

    /// A message about this table as a whole, at its header.
    pub fn fail_here(&self, message: impl Display) -> SceneError {
        self.ctx.err(self.span.clone(), format!("{}: {message}", self.label))
    }

    pub fn required<'v, T>(
        &self,
        field: &str,
        v: Option<&'v T>,
        expected: &str,
    ) -> Result<&'v T, SceneError> {
        v.ok_or_else(|| self.fail_here(format!("missing `{field}` (expected {expected})")))
    }

    pub fn num(
        &self,
        field: &str,
        v: Option<&Spanned<Num>>,
        default: f64,
        rule: Rule,
    ) -> Result<f64, SceneError> {
        match v {
            None => Ok(default),
            Some(v) => self.check_num(field, v, rule),
        }
    }

    pub fn check_num(&self, field: &str, v: &Spanned<Num>, rule: Rule) -> Result<f64, SceneError> {
        let x = v.get_ref().0;
        if (rule.ok)(x) {
            Ok(x)
        } else {
            Err(self.fail(v.span(), field, &format!("a number {}", rule.bound), show(x)))
        }
    }

    pub fn vec3(
        &self,
        field: &str,
        v: Option<&Spanned<Array<Num, 3>>>,
        default: DVec3,
        rule: Rule,
    ) -> Result<DVec3, SceneError> {
        match v {
            None => Ok(default),
            Some(v) => self.check_vec3(field, v, rule),
        }
    }

    pub fn check_vec3(
        &self,
        field: &str,
        v: &Spanned<Array<Num, 3>>,
        rule: Rule,
    ) -> Result<DVec3, SceneError> {
        let vec = v.get_ref().vec3();
        if vec.to_array().into_iter().all(rule.ok) {
            Ok(vec)
        } else {
            let expected = format!("an array of 3 numbers, each {}", rule.bound);
            Err(self.fail(v.span(), field, &expected, show_vec(vec)))
        }
    }

    /// A whole count such as `segments`, in `lo..=hi`.
    pub fn count(
        &self,
        field: &str,
        v: Option<&Spanned<Int>>,
        default: u32,
        lo: u32,
        hi: u32,
    ) -> Result<u32, SceneError> {
        let Some(v) = v else { return Ok(default) };
        let n = v.get_ref().0;
        match u32::try_from(n) {
            Ok(n) if (lo..=hi).contains(&n) => Ok(n),
            _ => Err(self.fail(v.span(), field, &format!("an integer in {lo}..={hi}"), n)),
        }
    }

    /// A name: present and non-empty.
    pub fn name(&self, v: Option<&'a Spanned<String>>) -> Result<&'a Spanned<String>, SceneError> {
        let name = self.required("name", v, "a non-empty string")?;
        if name.get_ref().trim().is_empty() {
            return Err(self.fail(name.span(), "name", "a non-empty string", "an empty one"));
        }
        Ok(name)
    }

    /// A `kind` string from a fixed list; `None` when absent.
    pub fn kind<'k>(
        &self,
        v: Option<&Spanned<String>>,
        kinds: &[&'k str],
    ) -> Result<Option<&'k str>, SceneError> {
        let Some(v) = v else { return Ok(None) };
        match kinds.iter().find(|k| **k == v.get_ref()) {
            Some(k) => Ok(Some(k)),
            None => Err(self.fail(v.span(), "kind", &one_of(kinds), format!("\"{}\"", v.get_ref()))),
        }
    }
}

/// Names seen so far in one kind of table, to refuse a second table with the same name. A map,
/// so a scene with n tables is checked in O(n), not O(n²).
pub(crate) struct UniqueNames<'a> {
    /// "mesh" or "material", for the message.
    what: &'static str,
    seen: HashMap<&'a str, &'a Spanned<String>>,
}

impl<'a> UniqueNames<'a> {
    pub fn new(what: &'static str) -> Self {
        UniqueNames { what, seen: HashMap::new() }
    }

    pub fn insert(&mut self, ctx: Ctx, name: &'a Spanned<String>) -> Result<(), SceneError> {
        if let Some(first) = self.seen.get(name.get_ref().as_str()) {
            let (line, _) = line_column(ctx.text, first.span().start);
            let message = format!(
                "duplicate {} name \"{}\" (expected unique names; first declared on line {line})",
                self.what,
                name.get_ref()
            );
            return Err(ctx.err(name.span(), message));
        }
        self.seen.insert(name.get_ref(), name);
        Ok(())
    }
}

/// "one of \"a\", \"b\"" or "\"a\"" for a single choice.
pub(crate) fn one_of(choices: &[&str]) -> String {
    let quoted: Vec<String> = choices.iter().map(|c| format!("\"{c}\"")).collect();
    match quoted.len() {
        1 => quoted[0].clone(),
        _ => format!("one of {}", quoted.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_start_walks_back_over_the_equals_sign() {
        let text = "a = 1\n  transform  =\t[1]\n";
        let ctx = Ctx { text, path: Path::new("x") };
        let value = text.find('[').unwrap();
        assert_eq!(ctx.key_start(&(value..value + 3)), text.find("transform").unwrap());
        // Not a `key = value` shape: stay on the value.
        assert_eq!(ctx.key_start(&(0..1)), 0);
    }

    #[test]
    fn show_avoids_long_expansions() {
        assert_eq!(show(1.0), "1");
        assert_eq!(show(-0.5), "-0.5");
        assert_eq!(show(1e300), "1e300");
        assert_eq!(show_vec_approx(DVec3::new(0.0, -0.242535625, -1.0)), "[0, -0.2425, -1]");
    }
}
