//! `SceneError`: one message with the place in the scene file it is about.

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Why a scene file was refused. Displays as `path:line:col: message` (1-based line, column in
/// characters), the form editors and terminals turn into a link.
///
/// Errors that concern the file as a whole (it cannot be read) have `line == column == 0` and
/// display as `path: message`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneError {
    /// The scene file.
    pub path: PathBuf,
    /// 1-based line, or 0 when the error has no place in the file.
    pub line: usize,
    /// 1-based column counted in characters (not bytes), or 0 with `line`.
    pub column: usize,
    /// What is wrong and what was expected.
    pub message: String,
}

impl SceneError {
    /// An error about the file as a whole (no line or column).
    pub fn whole_file(path: &Path, message: impl Into<String>) -> SceneError {
        SceneError { path: path.to_path_buf(), line: 0, column: 0, message: message.into() }
    }

    /// An error at byte `offset` of `source`.
    pub fn at_offset(path: &Path, source: &str, offset: usize, message: impl Into<String>) -> SceneError {
        let (line, column) = line_column(source, offset);
        SceneError { path: path.to_path_buf(), line, column, message: message.into() }
    }

    /// An error at the start of the byte range `span` of `source`.
    pub fn at_span(path: &Path, source: &str, span: Range<usize>, message: impl Into<String>) -> SceneError {
        Self::at_offset(path, source, span.start, message)
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line == 0 {
            write!(f, "{}: {}", self.path.display(), self.message)
        } else {
            write!(f, "{}:{}:{}: {}", self.path.display(), self.line, self.column, self.message)
        }
    }
}

impl std::error::Error for SceneError {}

/// 1-based (line, column) of byte `offset` in `source`; the column counts characters. Offsets
/// past the end clamp to the end, and an offset inside a multi-byte character counts that
/// character, so no input can make this panic.
pub(crate) fn line_column(source: &str, offset: usize) -> (usize, usize) {
    let bytes = &source.as_bytes()[..offset.min(source.len())];
    let line_start = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let line = 1 + bytes.iter().filter(|&&b| b == b'\n').count();
    // Count UTF-8 lead bytes: every character has exactly one.
    let column = 1 + bytes[line_start..].iter().filter(|&&b| b & 0xC0 != 0x80).count();
    (line, column)
}

/// Line starts of a text, for many (line, column) look-ups in O(log lines) each: `line_column`
/// scans from the start, which for one position per table of a large scene is quadratic.
pub(crate) struct LineIndex<'a> {
    source: &'a str,
    starts: Vec<usize>,
}

impl<'a> LineIndex<'a> {
    pub(crate) fn new(source: &'a str) -> Self {
        let starts = std::iter::once(0).chain(source.match_indices('\n').map(|(i, _)| i + 1)).collect();
        LineIndex { source, starts }
    }

    /// The same as `line_column(source, offset)`.
    pub(crate) fn line_column(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.source.len());
        let line = self.starts.partition_point(|&s| s <= offset);
        let start = self.starts[line - 1];
        let column = 1 + self.source.as_bytes()[start..offset].iter().filter(|&&b| b & 0xC0 != 0x80).count();
        (line, column)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_index_agrees_with_line_column() {
        let s = "ab\nçd = 1\n\n\u{1F600}x\n";
        let index = LineIndex::new(s);
        for offset in 0..s.len() + 3 {
            assert_eq!(index.line_column(offset), line_column(s, offset), "offset {offset}");
        }
    }

    #[test]
    fn line_column_counts_characters() {
        let s = "ab\nçd = 1\n";
        assert_eq!(line_column(s, 0), (1, 1));
        assert_eq!(line_column(s, 3), (2, 1));
        // 'ç' is two bytes; 'd' is the second character of line 2.
        assert_eq!(line_column(s, 5), (2, 2));
        assert_eq!(line_column(s, 999), (3, 1));
    }

    #[test]
    fn display_forms() {
        let p = Path::new("s.toml");
        let e = SceneError::at_offset(p, "x\ny", 2, "bad");
        assert_eq!(e.to_string(), "s.toml:2:1: bad");
        assert_eq!(SceneError::whole_file(p, "gone").to_string(), "s.toml: gone");
    }
}
