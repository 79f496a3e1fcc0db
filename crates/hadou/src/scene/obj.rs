//! Wavefront OBJ loader: `v`, `vn`, `vt` (counted for index checks, otherwise ignored) and `f`
//! with `v`, `v/vt`, `v//vn`, `v/vt/vn` corners, negative (relative) indices, polygons
//! fan-triangulated. `o g s usemtl mtllib l` and `#` comments are ignored; any other statement is
//! an error. Errors carry the 1-based line and column of the offending token.
//!
//! Normals: a corner with `vn` uses it (renormalized; vertices are split per distinct (v, vn)
//! pair); a corner without uses the area-weighted average of the face normals around its `v`.
//!
//! Degenerate triangles (zero area, `mesh::is_degenerate`) are reported with `log::warn!` (count
//! and first line). Those with two corners at the same position are dropped: their two real edges
//! run in opposite directions and cancel, so dropping them never opens a closed mesh. Slivers
//! (three distinct collinear corners) are kept, because a closed mesh may need them (T-junction
//! fills); they have zero area, so the raster draws nothing, the watertight ray test never hits
//! them, and they add nothing to smooth normals.

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;

use super::mesh::{is_degenerate, Mesh, MeshError};

/// Statements that are valid OBJ but carry nothing hadou uses.
const IGNORED: &[&str] = &["o", "g", "s", "usemtl", "mtllib", "l"];

/// Loads an OBJ file. A missing or unreadable file, or one that is not a regular file, is
/// `MeshError::Io`; bytes that are not UTF-8 are replaced (they can only matter inside tokens,
/// which then fail to parse).
pub fn load_obj(path: &Path) -> Result<Mesh, MeshError> {
    let io = |source| MeshError::Io { path: path.to_path_buf(), source };
    // Checked before opening: opening a FIFO would block until a writer comes, and a device
    // may never end.
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(io(std::io::Error::other("not a regular file")));
    }
    let bytes = std::fs::read(path).map_err(io)?;
    parse_obj(&String::from_utf8_lossy(&bytes), path)
}

/// The lines of OBJ text: ended by LF, CR LF or a lone CR (old Mac exports), after a UTF-8 byte
/// order mark if there is one.
fn lines(text: &str) -> impl Iterator<Item = &str> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.split_terminator('\n').flat_map(|l| l.strip_suffix('\r').unwrap_or(l).split('\r'))
}

/// Parses OBJ text; `path` only labels errors and warnings.
pub fn parse_obj(text: &str, path: &Path) -> Result<Mesh, MeshError> {
    let mut p = Parser {
        path,
        positions: Vec::new(),
        normals: Vec::new(),
        texcoords: 0,
        corners: Vec::new(),
        lines: Vec::new(),
    };
    for (i, line) in lines(text).enumerate() {
        p.statement(i + 1, line)?;
    }
    p.finish()
}

/// One face corner: 0-based position index and optional 0-based normal index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Corner {
    v: u32,
    vn: Option<u32>,
}

struct Parser<'a> {
    path: &'a Path,
    positions: Vec<[f32; 3]>,
    normals: Vec<DVec3>,
    texcoords: usize,
    /// Fan-triangulated corners, three per triangle, and the line each triangle came from.
    corners: Vec<Corner>,
    lines: Vec<usize>,
}

/// A whitespace-separated token with its 1-based column (in characters).
#[derive(Clone, Copy, Debug)]
struct Token<'t> {
    column: usize,
    text: &'t str,
}

fn tokenize(line: &str) -> (Vec<Token<'_>>, usize) {
    let line = line.split('#').next().unwrap_or("");
    let mut tokens = Vec::new();
    let mut start: Option<(usize, usize)> = None; // (byte, column)
    let mut column = 0;
    for (byte, ch) in line.char_indices() {
        column += 1;
        match (ch.is_whitespace(), start) {
            (false, None) => start = Some((byte, column)),
            (true, Some((b, c))) => {
                tokens.push(Token { column: c, text: &line[b..byte] });
                start = None;
            }
            _ => {}
        }
    }
    if let Some((b, c)) = start {
        tokens.push(Token { column: c, text: &line[b..] });
    }
    // The column just past the last character, where "found end of line" points.
    (tokens, column + 1)
}

impl Parser<'_> {
    fn err(&self, line: usize, column: usize, message: impl Into<String>) -> MeshError {
        MeshError::Obj { path: self.path.to_path_buf(), line, column, message: message.into() }
    }

    fn statement(&mut self, line: usize, text: &str) -> Result<(), MeshError> {
        let (tokens, end) = tokenize(text);
        let Some((keyword, args)) = tokens.split_first() else {
            return Ok(());
        };
        let at = Args { line, end, keyword: *keyword, args };
        match keyword.text {
            "v" => {
                let xyz = self.numbers(&at, 3, 6, "v takes x y z, optionally w or r g b", "coordinate")?;
                let p = [xyz[0] as f32, xyz[1] as f32, xyz[2] as f32];
                self.positions.push(p);
            }
            "vn" => {
                let n = self.numbers(&at, 3, 3, "vn takes x y z", "normal coordinate")?;
                let n = DVec3::new(n[0], n[1], n[2]);
                // Components are finite f32 values, so the length is finite.
                if n.length() == 0.0 {
                    return Err(self.err(
                        line,
                        args[0].column,
                        "normal has zero length (expected a direction)",
                    ));
                }
                self.normals.push(n.normalize());
            }
            "vt" => {
                self.numbers(&at, 1, 3, "vt takes u, optionally v and w", "texture coordinate")?;
                self.texcoords += 1;
            }
            "f" => self.face(&at)?,
            k if IGNORED.contains(&k) => {}
            k => {
                let message = format!(
                    "unknown statement `{k}` (expected v, vn, vt, f, or one of the ignored {})",
                    IGNORED.join(" ")
                );
                return Err(self.err(line, keyword.column, message));
            }
        }
        Ok(())
    }

    /// Between `min` and `max` finite numbers after the keyword (finite as f32, since that is how
    /// positions are stored).
    fn numbers(
        &self,
        at: &Args,
        min: usize,
        max: usize,
        usage: &str,
        what: &str,
    ) -> Result<Vec<f64>, MeshError> {
        if let Some(extra) = at.args.get(max) {
            let message = format!("expected end of line ({usage}), found `{}`", extra.text);
            return Err(self.err(at.line, extra.column, message));
        }
        if at.args.len() < min {
            let message = format!("expected a number ({usage}), found end of line");
            return Err(self.err(at.line, at.end, message));
        }
        at.args.iter().map(|t| self.number(at.line, t, what)).collect()
    }

    fn number(&self, line: usize, t: &Token, what: &str) -> Result<f64, MeshError> {
        let v: f64 = t
            .text
            .parse()
            .map_err(|_| self.err(line, t.column, format!("expected a number, found `{}`", t.text)))?;
        if !(v as f32).is_finite() {
            let range = if v.is_finite() { " (outside the f32 range)" } else { "" };
            return Err(self.err(line, t.column, format!("non-finite {what} `{}`{range}", t.text)));
        }
        Ok(v)
    }

    fn face(&mut self, at: &Args) -> Result<(), MeshError> {
        if at.args.len() < 3 {
            let message = format!("face needs at least 3 vertices, found {}", at.args.len());
            return Err(self.err(at.line, at.keyword.column, message));
        }
        let corners = at.args.iter().map(|t| self.corner(at.line, t)).collect::<Result<Vec<_>, _>>()?;
        for k in 1..corners.len() - 1 {
            self.corners.extend([corners[0], corners[k], corners[k + 1]]);
            self.lines.push(at.line);
        }
        Ok(())
    }

    /// `v`, `v/vt`, `v//vn` or `v/vt/vn`.
    fn corner(&self, line: usize, t: &Token) -> Result<Corner, MeshError> {
        let parts: Vec<&str> = t.text.split('/').collect();
        let shape_ok = match parts.as_slice() {
            [v] => !v.is_empty(),
            [v, vt] => !v.is_empty() && !vt.is_empty(),
            [v, _, vn] => !v.is_empty() && !vn.is_empty(),
            _ => false,
        };
        if !shape_ok {
            let message =
                format!("expected a face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`, found `{}`", t.text);
            return Err(self.err(line, t.column, message));
        }
        // Column of each part: the token's column plus the characters before it.
        let mut column = t.column;
        let mut located = Vec::with_capacity(parts.len());
        for part in &parts {
            located.push(Token { column, text: part });
            column += part.chars().count() + 1;
        }
        let v = self.index(line, &located[0], self.positions.len(), ("vertex", "vertices"))?;
        if let Some(vt) = located.get(1).filter(|p| !p.text.is_empty()) {
            self.index(line, vt, self.texcoords, ("texture coordinate", "texture coordinates"))?;
        }
        let vn = match located.get(2) {
            Some(vn) => Some(self.index(line, vn, self.normals.len(), ("normal", "normals"))?),
            None => None,
        };
        Ok(Corner { v, vn })
    }

    /// A 1-based or negative (relative) index resolved against the `count` items defined so far.
    fn index(
        &self,
        line: usize,
        t: &Token,
        count: usize,
        (one, many): (&str, &str),
    ) -> Result<u32, MeshError> {
        let i: i64 = t.text.parse().map_err(|_| {
            self.err(line, t.column, format!("expected an integer {one} index, found `{}`", t.text))
        })?;
        let resolved = match i {
            0 => return Err(self.err(line, t.column, "index 0 is invalid (OBJ indices start at 1)")),
            i if i > 0 => i - 1,
            i => count as i64 + i,
        };
        match u32::try_from(resolved) {
            Ok(r) if (r as usize) < count => Ok(r),
            _ => {
                let message = format!("{one} index {i} out of range (file has {count} {many} so far)");
                Err(self.err(line, t.column, message))
            }
        }
    }

    fn finish(self) -> Result<Mesh, MeshError> {
        let faces = self.lines.len();
        let kept = self.keep_triangles();
        if kept.is_empty() {
            let (line, why) = match self.lines.first() {
                Some(&l) => (l, format!(" (all {faces} have two corners at the same position)")),
                None => (1, String::new()),
            };
            return Err(self.err(line, 1, format!("file has no triangles{why}")));
        }
        let smooth = self.smooth_normals(&kept);
        let mut mesh = Mesh::default();
        let mut vertex_of: HashMap<Corner, u32> = HashMap::new();
        for &t in &kept {
            for c in &self.corners[3 * t..3 * t + 3] {
                let next = mesh.positions.len();
                let index = *vertex_of.entry(*c).or_insert_with(|| {
                    mesh.positions.push(self.positions[c.v as usize]);
                    let n = c.vn.map_or(smooth[c.v as usize], |vn| self.normals[vn as usize]);
                    mesh.normals.push(n.as_vec3().to_array());
                    next as u32
                });
                mesh.indices.push(index);
            }
        }
        Ok(mesh)
    }

    fn corner_position(&self, t: usize, k: usize) -> DVec3 {
        let p = self.positions[self.corners[3 * t + k].v as usize];
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    }

    /// Triangles to keep (see the module note on degenerate triangles), with one warning.
    fn keep_triangles(&self) -> Vec<usize> {
        let mut kept = Vec::with_capacity(self.lines.len());
        let (mut dropped, mut slivers, mut first_line) = (0usize, 0usize, None);
        for t in 0..self.lines.len() {
            let [a, b, c] = [0, 1, 2].map(|k| self.corner_position(t, k));
            if is_degenerate(a, b, c) {
                first_line.get_or_insert(self.lines[t]);
                if a == b || b == c || c == a {
                    dropped += 1;
                    continue;
                }
                slivers += 1;
            }
            kept.push(t);
        }
        if let Some(line) = first_line {
            log::warn!(
                "{}: {} degenerate triangle(s) (zero area), first on line {line}: {dropped} with two \
                 corners at the same position dropped, {slivers} sliver(s) kept",
                self.path.display(),
                dropped + slivers
            );
        }
        kept
    }

    /// Area-weighted average face normal per position; +y where only zero-area faces touch it.
    fn smooth_normals(&self, kept: &[usize]) -> Vec<DVec3> {
        let mut sum = vec![DVec3::ZERO; self.positions.len()];
        for &t in kept {
            let [a, b, c] = [0, 1, 2].map(|k| self.corner_position(t, k));
            // The cross product's length is twice the area: the weighting comes for free.
            let n = (b - a).cross(c - a);
            for k in 0..3 {
                sum[self.corners[3 * t + k].v as usize] += n;
            }
        }
        sum.into_iter().map(|n| n.try_normalize().unwrap_or(DVec3::Y)).collect()
    }
}

/// A statement's tokens and where its line ends.
struct Args<'t> {
    line: usize,
    end: usize,
    keyword: Token<'t>,
    args: &'t [Token<'t>],
}

/// Test helper shared with `raycast`: where the OBJ test files are.
#[cfg(test)]
pub(crate) fn test_data(name: &str) -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/obj").join(name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn asset(name: &str) -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets/meshes").join(name)
    }

    /// Loads a malformed file and returns (line, column, message).
    fn obj_error(name: &str) -> (usize, usize, String) {
        match load_obj(&test_data(name)) {
            Err(MeshError::Obj { line, column, message, path }) => {
                assert!(path.ends_with(name));
                (line, column, message)
            }
            other => panic!("{name}: expected an OBJ error, got {other:?}"),
        }
    }

    #[test]
    fn wedge_loads_closed_with_given_normals() {
        let m = load_obj(&asset("wedge.obj")).unwrap();
        m.validate_basic().unwrap();
        m.check_closed_oriented().unwrap();
        assert_eq!(m.triangle_count(), 8);
        // Split per distinct (v, vn) pair: 3 + 3 + 4 + 4 + 4.
        assert_eq!(m.positions.len(), 18);
        assert!((m.signed_volume() - 0.5).abs() < 1e-12);
        let slanted = std::f32::consts::FRAC_1_SQRT_2;
        assert!(m.normals.iter().any(|n| (n[0] - slanted).abs() < 1e-7 && (n[1] - slanted).abs() < 1e-7));
        // Every vertex normal agrees with its face.
        for t in 0..m.triangle_count() {
            let [a, b, c] = m.triangle(t).map(|v| m.position(v));
            let face = (b - a).cross(c - a).normalize();
            for v in m.triangle(t) {
                assert!((DVec3::from(m.normals[v].map(f64::from)) - face).length() < 1e-6);
            }
        }
    }

    #[test]
    fn corner_forms_negative_indices_and_smooth_normals() {
        let text = "# tetrahedron\no t\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvn 0 0 -1\n\
                    g all\ns 1\nusemtl none\nf 1//1 3//1 2//1\nf -4/1 -3/-1/1 -1\nf 1 4 3\nf 2/1 3/1 4/1\nl 1 2\n";
        let m = parse_obj(text, Path::new("inline.obj")).unwrap();
        m.validate_basic().unwrap();
        m.check_closed_oriented().unwrap();
        assert_eq!(m.triangle_count(), 4);
        assert!((m.signed_volume() - 1.0 / 6.0).abs() < 1e-12);
        // Vertex 4 (0, 0, 1) without vn: the average of its three faces' area-weighted normals.
        let i = m.positions.iter().position(|p| *p == [0.0, 0.0, 1.0]).unwrap();
        let expect =
            (DVec3::new(0.0, -0.5, 0.0) + DVec3::new(-0.5, 0.0, 0.0) + DVec3::splat(0.5)).normalize();
        assert!((DVec3::from(m.normals[i].map(f64::from)) - expect).length() < 1e-6);
    }

    #[test]
    fn polygons_are_fan_triangulated() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0.5 1.5 0\nv 0 1 0\nf 1 2 3 4 5\n";
        let m = parse_obj(text, Path::new("pentagon.obj")).unwrap();
        assert_eq!(m.indices, vec![0, 1, 2, 0, 2, 3, 0, 3, 4]);
        assert!(m.normals.iter().all(|n| *n == [0.0, 0.0, 1.0]));
    }

    #[test]
    fn missing_file_is_io() {
        assert!(matches!(load_obj(&test_data("does_not_exist.obj")), Err(MeshError::Io { .. })));
    }

    #[test]
    fn special_files_are_refused_without_reading() {
        let dir = std::env::temp_dir().join(format!("hadou-obj-fifo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("mesh.obj");
        let _ = std::fs::remove_file(&fifo);
        assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
        // On a thread, so a regression fails the test instead of hanging it.
        let (send, receive) = std::sync::mpsc::channel();
        let path = fifo.clone();
        std::thread::spawn(move || {
            let _ = send.send(load_obj(&path).map(|_| ()).map_err(|e| e.to_string()));
        });
        let got = receive.recv_timeout(std::time::Duration::from_secs(10));
        std::fs::remove_dir_all(&dir).unwrap();
        let msg = got.expect("loading a FIFO blocked").unwrap_err();
        assert!(msg.contains("mesh.obj") && msg.contains("not a regular file"), "{msg}");
        let msg = load_obj(Path::new("/dev/zero")).unwrap_err().to_string();
        assert!(msg.contains("/dev/zero") && msg.contains("not a regular file"), "{msg}");
    }

    #[test]
    fn bom_and_every_line_ending_are_read_alike() {
        let lf = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
        let want = parse_obj(lf, Path::new("lf.obj")).unwrap();
        for (name, text) in [
            ("bom", format!("\u{feff}{lf}")),
            ("crlf", lf.replace('\n', "\r\n")),
            ("cr", lf.replace('\n', "\r")),
            ("bom cr no final break", format!("\u{feff}{}", lf.trim_end().replace('\n', "\r"))),
        ] {
            assert_eq!(parse_obj(&text, Path::new("x.obj")).unwrap(), want, "{name}");
        }
        // Positions stay right: a bad token on line 3 of a CR-only file, column 1 after a BOM.
        let e = parse_obj("v 0 0 0\rv 1 0 0\rv 1 x 0\r", Path::new("cr.obj")).unwrap_err().to_string();
        assert!(e.starts_with("cr.obj:3:5:"), "{e}");
        let e = parse_obj("\u{feff}w 1\n", Path::new("bom.obj")).unwrap_err().to_string();
        assert!(e.starts_with("bom.obj:1:1:"), "{e}");
    }

    #[test]
    fn malformed_files_point_at_the_token() {
        let cases: &[(&str, usize, usize, &str)] = &[
            ("bad_number.obj", 3, 7, "expected a number, found `abc`"),
            (
                "missing_coordinate.obj",
                2,
                6,
                "expected a number (v takes x y z, optionally w or r g b), found end of line",
            ),
            ("too_many_normal_values.obj", 2, 10, "expected end of line (vn takes x y z), found `4`"),
            ("out_of_range.obj", 6, 7, "vertex index 9 out of range (file has 4 vertices so far)"),
            ("negative_out_of_range.obj", 4, 3, "vertex index -4 out of range (file has 3 vertices so far)"),
            ("zero_index.obj", 4, 5, "index 0 is invalid (OBJ indices start at 1)"),
            ("nan.obj", 2, 3, "non-finite coordinate `nan`"),
            ("huge.obj", 1, 7, "non-finite coordinate `1e39` (outside the f32 range)"),
            ("short_face.obj", 4, 1, "face needs at least 3 vertices, found 2"),
            ("no_faces.obj", 1, 1, "file has no triangles"),
            ("unknown_statement.obj", 3, 1, "unknown statement `curv`"),
            (
                "bad_corner.obj",
                4,
                7,
                "expected a face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`, found `3/1/1/1`",
            ),
            ("float_index.obj", 4, 5, "expected an integer vertex index, found `2.5`"),
            ("normal_out_of_range.obj", 5, 11, "normal index 2 out of range (file has 1 normals so far)"),
            ("texcoord_out_of_range.obj", 4, 9, "texture coordinate index 1 out of range (file has 0"),
            ("zero_normal.obj", 4, 4, "normal has zero length"),
            (
                "all_collapsed.obj",
                4,
                1,
                "file has no triangles (all 1 have two corners at the same position)",
            ),
        ];
        for &(name, line, column, message) in cases {
            let (l, c, m) = obj_error(name);
            assert!(m.starts_with(message), "{name}: {m:?}");
            assert_eq!((l, c), (line, column), "{name}: {m}");
        }
    }

    #[test]
    fn error_display_has_path_line_column() {
        let e = load_obj(&test_data("bad_number.obj")).unwrap_err().to_string();
        assert!(e.ends_with("bad_number.obj:3:7: expected a number, found `abc`"), "{e}");
    }

    #[test]
    fn degenerate_triangles_drop_repeats_keep_slivers() {
        let m = load_obj(&test_data("degenerate.obj")).unwrap();
        // One good triangle, one sliver kept, one repeated-corner triangle dropped.
        assert_eq!(m.triangle_count(), 2);
        assert_eq!(m.degenerate_triangles(), vec![1]);
        m.validate_basic().unwrap();
    }

    /// Random lines of OBJ-ish tokens: every outcome is a mesh that passes `validate_basic` or an
    /// error, never a panic.
    #[test]
    fn random_input_never_panics() {
        let words = [
            "v",
            "vn",
            "vt",
            "f",
            "o",
            "1",
            "-1",
            "0",
            "2",
            "0.5",
            "2/3",
            "1//1",
            "1/1/1",
            "/",
            "//",
            "nan",
            "1e39",
            "abc",
            "#",
            "\t",
            "ü",
            "3/-1/2",
            "99999999999999999999",
            "-9223372036854775808",
            "-3",
        ];
        let mut state = 0x1234_5678_9abc_def0u64;
        let mut next = move |n: usize| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % n as u64) as usize
        };
        for _ in 0..3000 {
            let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n");
            for _ in 0..next(6) {
                let len = 1 + next(6);
                let line: Vec<&str> = (0..len).map(|_| words[next(words.len())]).collect();
                text.push_str(&line.join(" "));
                text.push('\n');
            }
            if let Ok(m) = parse_obj(&text, Path::new("fuzz.obj")) {
                m.validate_basic().unwrap();
            }
        }
    }

    #[test]
    fn columns_count_characters_and_tabs() {
        let text = "v\t1 2 3 # ü comment\nv 1 2 ü\n";
        match parse_obj(text, Path::new("u.obj")) {
            Err(MeshError::Obj { line: 2, column: 7, message, .. }) => assert!(message.contains("`ü`")),
            other => panic!("{other:?}"),
        }
    }
}
