//! The parts of a glTF file hadou does not draw, gathered while importing and reported once, as
//! one warning: never silently dropped.

use std::collections::BTreeMap;
use std::path::Path;

/// What was ignored, by kind, each with the JSON pointers where it occurs.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Ignored(pub BTreeMap<&'static str, Vec<String>>);

/// How many places of one kind the warning names before it only counts the rest.
const SHOWN: usize = 4;

impl Ignored {
    /// Notes `kind` (e.g. "textures") at `pointer`.
    pub fn add(&mut self, kind: &'static str, pointer: impl Into<String>) {
        self.0.entry(kind).or_default().push(pointer.into());
    }

    /// True when nothing was ignored.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The one-line summary: `kind (where, where, … and N more); kind (…)`.
    pub fn summary(&self) -> String {
        let parts: Vec<String> = self
            .0
            .iter()
            .map(|(kind, at)| {
                let shown: Vec<&str> = at.iter().take(SHOWN).map(String::as_str).collect();
                let more = at.len().saturating_sub(SHOWN);
                let more = if more > 0 { format!(" and {more} more") } else { String::new() };
                format!("{kind} ({}{more})", shown.join(", "))
            })
            .collect();
        parts.join("; ")
    }

    /// Logs the summary as one warning (nothing when nothing was ignored).
    pub fn warn(&self, file: &Path) {
        if !self.is_empty() {
            log::warn!("{}: hadou does not draw these parts of the file: {}", file.display(), self.summary());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_names_a_few_and_counts_the_rest() {
        let mut i = Ignored::default();
        for k in 0..6 {
            i.add("textures", format!("/textures/{k}"));
        }
        i.add("skins", "/skins/0");
        assert_eq!(
            i.summary(),
            "skins (/skins/0); textures (/textures/0, /textures/1, /textures/2, /textures/3 and 2 more)"
        );
    }
}
