//! One table of the report: the same rows become a markdown table, a CSV file and plot points.

/// How a number is shown in markdown (the CSV always keeps full precision).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fmt {
    /// Fixed decimals.
    Fixed(usize),
    /// Scientific notation with this many decimals.
    Sci(usize),
    /// A whole number with thousands separators.
    Int,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Cell {
    Text(String),
    Num(f64, Fmt),
    /// Not applicable (an empty CSV field, "—" in markdown).
    Missing,
}

impl Cell {
    pub fn text(s: impl Into<String>) -> Cell {
        Cell::Text(s.into())
    }

    /// The value, for plots and checks.
    pub fn value(&self) -> Option<f64> {
        match self {
            Cell::Num(v, _) => Some(*v),
            _ => None,
        }
    }

    pub fn markdown(&self) -> String {
        match self {
            Cell::Text(s) => s.replace('|', "\\|"),
            Cell::Missing => "—".into(),
            Cell::Num(v, _) if !v.is_finite() => format!("{v}"),
            Cell::Num(v, Fmt::Fixed(d)) => format!("{v:.d$}"),
            Cell::Num(v, Fmt::Sci(d)) => format!("{v:.d$e}"),
            Cell::Num(v, Fmt::Int) => thousands(v.round() as i64),
        }
    }
}

fn thousands(v: i64) -> String {
    let digits = v.unsigned_abs().to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    if v < 0 {
        format!("-{out}")
    } else {
        out
    }
}

/// A table: `id` names its CSV file (`<id>.csv`); the first column names the row.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    pub id: String,
    pub title: String,
    pub columns: Vec<String>,
    pub rows: Vec<Vec<Cell>>,
}

impl Table {
    pub fn new(id: &str, title: &str, columns: &[&str]) -> Table {
        Table {
            id: id.into(),
            title: title.into(),
            columns: columns.iter().map(|c| c.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row; it must have one cell per column (a programming error otherwise).
    pub fn push(&mut self, row: Vec<Cell>) {
        assert_eq!(row.len(), self.columns.len(), "table {}: row width", self.id);
        self.rows.push(row);
    }

    /// The column's index by name.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }

    /// The value in row `row` of column `name`.
    pub fn value(&self, row: usize, name: &str) -> Option<f64> {
        self.rows.get(row)?.get(self.column(name)?)?.value()
    }

    pub fn markdown(&self) -> String {
        let mut out = format!("| {} |\n|", self.columns.join(" | "));
        for (i, _) in self.columns.iter().enumerate() {
            out += if i == 0 { "---|" } else { "---:|" };
        }
        out.push('\n');
        for row in &self.rows {
            let cells: Vec<String> = row.iter().map(Cell::markdown).collect();
            out += &format!("| {} |\n", cells.join(" | "));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_formats_and_escapes() {
        let mut t = Table::new("t", "T", &["name", "ms", "err", "bytes"]);
        t.push(vec![
            Cell::text("a|b"),
            Cell::Num(1.23456, Fmt::Fixed(2)),
            Cell::Num(0.000123, Fmt::Sci(1)),
            Cell::Num(1234567.0, Fmt::Int),
        ]);
        t.push(vec![
            Cell::text("x"),
            Cell::Missing,
            Cell::Num(f64::INFINITY, Fmt::Sci(1)),
            Cell::Num(12.0, Fmt::Int),
        ]);
        assert_eq!(
            t.markdown(),
            "| name | ms | err | bytes |\n|---|---:|---:|---:|\n| a\\|b | 1.23 | 1.2e-4 | 1,234,567 |\n| x | — | inf | 12 |\n"
        );
        assert_eq!(t.value(0, "ms"), Some(1.23456));
        assert_eq!(t.value(1, "ms"), None);
        assert_eq!(thousands(-1000), "-1,000");
    }
}
