//! CSV (RFC 4180) for the report's tables: a header row, then one line per row. Numbers keep
//! full precision (the shortest digits that read back to the same f64), a missing value is an empty field, and a
//! field holding a comma, quote or line break is quoted with its quotes doubled.

use super::table::{Cell, Table};

fn field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

fn cell(c: &Cell) -> String {
    match c {
        Cell::Text(s) => field(s),
        // Debug: shortest round-trip digits, an exponent for very large or small values.
        Cell::Num(v, _) => format!("{v:?}"),
        Cell::Missing => String::new(),
    }
}

/// The table as CSV text, lines ended by "\n".
pub fn to_csv(table: &Table) -> String {
    let mut out = table.columns.iter().map(|c| field(c)).collect::<Vec<_>>().join(",");
    out.push('\n');
    for row in &table.rows {
        out += &row.iter().map(cell).collect::<Vec<_>>().join(",");
        out.push('\n');
    }
    out
}

/// Parses CSV text into rows of fields (quoted fields, doubled quotes, "\n" or "\r\n" line
/// ends). An unterminated quote is an error naming its line.
pub fn parse(text: &str) -> Result<Vec<Vec<String>>, String> {
    let mut rows = Vec::new();
    let (mut row, mut field) = (Vec::new(), String::new());
    let (mut quoted, mut line, mut quote_line) = (false, 1, 0);
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match (quoted, c) {
            (true, '"') if chars.peek() == Some(&'"') => {
                chars.next();
                field.push('"');
            }
            (true, '"') => quoted = false,
            (true, c) => {
                line += usize::from(c == '\n');
                field.push(c);
            }
            (false, '"') if field.is_empty() => {
                quoted = true;
                quote_line = line;
            }
            (false, ',') => row.push(std::mem::take(&mut field)),
            (false, '\r') if chars.peek() == Some(&'\n') => {}
            (false, '\n') => {
                row.push(std::mem::take(&mut field));
                rows.push(std::mem::take(&mut row));
                line += 1;
            }
            (false, c) => field.push(c),
        }
    }
    if quoted {
        return Err(format!("line {quote_line}: quoted field not closed"));
    }
    if !field.is_empty() || !row.is_empty() {
        row.push(field);
        rows.push(row);
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::table::Fmt;

    #[test]
    fn writes_quotes_and_round_trips() {
        let mut t = Table::new("t", "T", &["variant", "ms", "note"]);
        t.push(vec![Cell::text("raymarch N = 8"), Cell::Num(0.1 + 0.2, Fmt::Fixed(2)), Cell::Missing]);
        t.push(vec![Cell::text("a, \"b\"\nc"), Cell::Num(f64::INFINITY, Fmt::Sci(1)), Cell::text("x")]);
        t.push(vec![Cell::text(""), Cell::Num(-1e-300, Fmt::Sci(1)), Cell::Num(f64::NAN, Fmt::Int)]);
        let text = to_csv(&t);
        assert_eq!(
            text,
            "variant,ms,note\nraymarch N = 8,0.30000000000000004,\n\"a, \"\"b\"\"\nc\",inf,x\n,-1e-300,NaN\n"
        );
        let rows = parse(&text).unwrap();
        assert_eq!(rows.len(), 4);
        assert_eq!(rows[1], ["raymarch N = 8", "0.30000000000000004", ""]);
        assert_eq!(rows[2], ["a, \"b\"\nc", "inf", "x"]);
        // Full precision: the number reads back bit for bit.
        assert_eq!(rows[1][1].parse::<f64>().unwrap(), 0.1 + 0.2);
        assert_eq!(rows[3][1].parse::<f64>().unwrap(), -1e-300);
        assert_eq!(parse("a,b\r\n1,2").unwrap(), [["a", "b"], ["1", "2"]]);
        assert!(parse("a\n\"b,c\n").unwrap_err().contains("line 2"));
    }
}
