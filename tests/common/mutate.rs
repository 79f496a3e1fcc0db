//! Mutators for the fuzz harness of tests/fuzz_formats.rs: glTF JSON (numbers replaced by extreme
//! or non-JSON tokens, members deleted or duplicated, values of the wrong type, URIs leaving the
//! folder), GLB containers (header and chunk lengths, bytes of the BIN chunk), PNG chunks (IHDR
//! dimensions with a valid CRC), OpenEXR headers (data and display windows, channel lists),
//! `hadou test` sidecars (TOML values, lines and bytes) and, through the JSON mutator,
//! `hadou profile --json` files. Deterministic: every choice comes from
//! `hadou::testing::Rng`, so a case number replays the same bytes on every machine.
#![allow(dead_code)]

use hadou::testing::Rng;
use serde_json::Value;

/// Uniform in 0..n; 0 when n is 0 (a file a mutation already emptied).
pub fn below(rng: &mut Rng, n: usize) -> usize {
    ((rng.next() * n as f64) as usize).min(n.saturating_sub(1))
}

/// Number tokens put in place of a JSON number: past u32, i32, f32 and f64, the 2²⁴ the issue's
/// bombs declared, zero, negatives, signed zero, subnormals, and tokens JSON has no word for
/// (`NaN`, `Infinity`), which a strict parser must refuse.
pub const JSON_NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1",
    "3",
    "-0",
    "0.5",
    "16777216",
    "2147483647",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "18446744073709551616",
    "9007199254740993",
    "1e16",
    "1e-8",
    "1e39",
    "-1e39",
    "1e308",
    "1e999",
    "-1e999",
    "1e-320",
    "NaN",
    "Infinity",
    "-Infinity",
    "nan",
];

/// Strings put in place of a JSON string: paths out of the file's folder (plain, percent-encoded,
/// absolute, special files), an empty string, a data: URI with bad base64, and ordinary names.
pub const JSON_STRINGS: &[&str] = &[
    "",
    "../x.bin",
    "%2e%2e/x.bin",
    "/etc/hostname",
    "/dev/zero",
    "/proc/self/mem",
    "data:application/octet-stream;base64,!!!!",
    "data:application/octet-stream;base64,",
    "1.0",
    "3.0",
    "SCALAR",
    "VEC3",
    "MAT4",
    "gpu frame",
    "KHR_materials_volume",
    "KHR_lights_punctual",
    "\u{1b}[31mred\u{1b}[0m",
    "x",
];

/// Members whose numbers size what a decoder allocates or reads (glTF accessors, views, buffers,
/// sparse blocks, primitives, images; profile frame counts and sizes).
pub const COUNT_KEYS: &[&str] = &[
    "count",
    "byteLength",
    "byteOffset",
    "byteStride",
    "componentType",
    "mode",
    "bufferView",
    "buffer",
    "indices",
    "POSITION",
    "NORMAL",
    "mesh",
    "camera",
    "light",
    "scene",
    "width",
    "height",
    "frames",
    "warmup",
];

/// Values for those members: none, one, a few, the 2²⁴ vertices, the ends of i32 and u32,
/// negative, fractional and past every integer type.
pub const COUNTS: &[Count] = &[
    Count::U(0),
    Count::U(1),
    Count::U(2),
    Count::U(3),
    Count::U(1 << 24),
    Count::U(0x7FFF_FFFF),
    Count::U(0xFFFF_FFFF),
    Count::U(1 << 32),
    Count::I(-1),
    Count::F(2.5),
    Count::F(1e308),
];

/// A JSON number of one of serde_json's three kinds.
#[derive(Clone, Copy, Debug)]
pub enum Count {
    U(u64),
    I(i64),
    F(f64),
}

impl From<Count> for Value {
    fn from(c: Count) -> Value {
        match c {
            Count::U(v) => Value::from(v),
            Count::I(v) => Value::from(v),
            Count::F(v) => Value::from(v),
        }
    }
}

/// Replacement values of another type (or an empty one).
fn other_value(rng: &mut Rng) -> Value {
    match below(rng, 7) {
        0 => Value::Null,
        1 => Value::Bool(true),
        2 => Value::Array(vec![]),
        3 => Value::Object(Default::default()),
        4 => Value::String(JSON_STRINGS[below(rng, JSON_STRINGS.len())].to_owned()),
        5 => serde_json::json!([0, 0, 0]),
        _ => serde_json::json!(-1),
    }
}

/// Byte ranges of the number-like tokens of JSON `text` (outside strings).
pub fn json_numbers(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let (mut out, mut i, mut in_string) = (Vec::new(), 0, false);
    while i < b.len() {
        let c = b[i];
        if in_string {
            if c == b'\\' {
                i += 1;
            } else if c == b'"' {
                in_string = false;
            }
            i += 1;
            continue;
        }
        if c == b'"' {
            in_string = true;
            i += 1;
            continue;
        }
        if c == b'-' || c.is_ascii_digit() {
            let start = i;
            i += 1;
            while i < b.len() && (b[i].is_ascii_digit() || matches!(b[i], b'.' | b'e' | b'E' | b'+' | b'-')) {
                i += 1;
            }
            out.push((start, i));
            continue;
        }
        i += 1;
    }
    out
}

fn escape(key: &str) -> String {
    key.replace('~', "~0").replace('/', "~1")
}

/// Every JSON pointer of `v` (its root "" included), depth-first.
pub fn pointers(v: &Value) -> Vec<String> {
    fn walk(v: &Value, at: String, out: &mut Vec<String>) {
        out.push(at.clone());
        match v {
            Value::Object(m) => m.iter().for_each(|(k, c)| walk(c, format!("{at}/{}", escape(k)), out)),
            Value::Array(a) => a.iter().enumerate().for_each(|(i, c)| walk(c, format!("{at}/{i}"), out)),
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(v, String::new(), &mut out);
    out
}

/// The parent pointer and last token of `ptr` (None for the root).
fn split(ptr: &str) -> Option<(&str, String)> {
    let (parent, last) = ptr.rsplit_once('/')?;
    Some((parent, last.replace("~1", "/").replace("~0", "~")))
}

/// Writes `v` as compact JSON, the member at pointer `dup` twice (a duplicated key).
fn write(v: &Value, at: &str, dup: &str, out: &mut String) {
    match v {
        Value::Object(m) => {
            out.push('{');
            let mut first = true;
            for (k, c) in m {
                let here = format!("{at}/{}", escape(k));
                let times = if here == dup { 2 } else { 1 };
                for _ in 0..times {
                    if !first {
                        out.push(',');
                    }
                    first = false;
                    out.push_str(&serde_json::to_string(k).unwrap());
                    out.push(':');
                    write(c, &here, dup, out);
                }
            }
            out.push('}');
        }
        Value::Array(a) => {
            out.push('[');
            for (i, c) in a.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                write(c, &format!("{at}/{i}"), dup, out);
            }
            out.push(']');
        }
        _ => out.push_str(&serde_json::to_string(v).unwrap()),
    }
}

/// The longest JSON text an array repetition grows (4 MiB, the 1.2 MB file of issue 24's shared
/// accessor three times over): a bomb is in what the text declares, not in its length.
pub const MAX_GROWN_TEXT: usize = 4 << 20;

/// One structural or numeric mutation of JSON `text` (returned unchanged when it does not parse:
/// then only the token mutation applies). Numbers weigh most: the budgets and limits under test
/// are numeric.
pub fn mutate_json_once(text: &str, rng: &mut Rng) -> String {
    let numeric = |text: &str, rng: &mut Rng| {
        let spans = json_numbers(text);
        if spans.is_empty() {
            return text.to_owned();
        }
        let (s, e) = spans[below(rng, spans.len())];
        format!("{}{}{}", &text[..s], JSON_NUMBERS[below(rng, JSON_NUMBERS.len())], &text[e..])
    };
    let Ok(mut root) = serde_json::from_str::<Value>(text) else { return numeric(text, rng) };
    let ptrs = pointers(&root);
    let ptr = ptrs[below(rng, ptrs.len())].clone();
    match below(rng, 12) {
        0..=3 => return numeric(text, rng),
        10 | 11 => {
            // A count, length, offset, stride or type code replaced: what sizes the allocations.
            let keyed: Vec<&String> = ptrs
                .iter()
                .filter(|p| split(p).is_some_and(|(_, last)| COUNT_KEYS.contains(&last.as_str())))
                .collect();
            if !keyed.is_empty() {
                let p = keyed[below(rng, keyed.len())].clone();
                *root.pointer_mut(&p).unwrap() = COUNTS[below(rng, COUNTS.len())].into();
            }
        }
        4 => {
            // Delete a member or an element.
            if let Some((parent, last)) = split(&ptr) {
                match root.pointer_mut(parent) {
                    Some(Value::Object(m)) => {
                        m.remove(&last);
                    }
                    Some(Value::Array(a)) => {
                        if let Ok(i) = last.parse::<usize>() {
                            a.remove(i);
                        }
                    }
                    _ => {}
                }
            }
        }
        5 => {
            // Duplicate a member (the same key twice) or an array element.
            if let Some((parent, last)) = split(&ptr) {
                if let Some(Value::Array(a)) = root.pointer_mut(parent) {
                    if let Ok(i) = last.parse::<usize>() {
                        let copy = a[i].clone();
                        a.insert(i, copy);
                    }
                } else {
                    let mut out = String::new();
                    write(&root, "", &ptr, &mut out);
                    return out;
                }
            }
        }
        6 => {
            if let Some(v) = root.pointer_mut(&ptr) {
                *v = other_value(rng);
            }
        }
        7 => {
            // A string (a URI, a type, a name) replaced.
            let strings: Vec<&String> =
                ptrs.iter().filter(|p| root.pointer(p).is_some_and(Value::is_string)).collect();
            if !strings.is_empty() {
                let p = strings[below(rng, strings.len())].clone();
                *root.pointer_mut(&p).unwrap() =
                    Value::String(JSON_STRINGS[below(rng, JSON_STRINGS.len())].into());
            }
        }
        8 => {
            // An integer (an index, a count) replaced by another index-like value.
            let ints: Vec<&String> =
                ptrs.iter().filter(|p| root.pointer(p).is_some_and(Value::is_u64)).collect();
            if !ints.is_empty() {
                let p = ints[below(rng, ints.len())].clone();
                let n = root.pointer(&p).unwrap().as_u64().unwrap();
                let v = [n.saturating_add(1), n.saturating_sub(1), 0, 1 << 24, u32::MAX as u64, 255, 65535]
                    [below(rng, 7)];
                *root.pointer_mut(&p).unwrap() = Value::from(v);
            }
        }
        _ => {
            // An array grown by repeating its elements (shared indices, a node listed twice).
            let arrays: Vec<&String> = ptrs
                .iter()
                .filter(|p| root.pointer(p).is_some_and(|v| v.as_array().is_some_and(|a| !a.is_empty())))
                .collect();
            if !arrays.is_empty() {
                let p = arrays[below(rng, arrays.len())].clone();
                let a = root.pointer_mut(&p).unwrap().as_array_mut().unwrap();
                let times = [2, 16, 400][below(rng, 3)];
                // Bounded by MAX_GROWN_TEXT: mutations of mutations would otherwise grow the
                // text 400-fold each (this process's memory, not the one under the cap).
                let times = times.min((MAX_GROWN_TEXT / text.len().max(1)).max(1));
                let copy = a.clone();
                for _ in 1..times {
                    a.extend(copy.iter().cloned());
                }
            }
        }
    }
    serde_json::to_string(&root).unwrap()
}

/// 1 to 3 mutations of JSON text.
pub fn mutate_json(text: &str, rng: &mut Rng) -> String {
    let n = 1 + below(rng, 3);
    (0..n).fold(text.to_owned(), |t, _| mutate_json_once(&t, rng))
}

// ---------------------------------------------------------------- GLB

/// The JSON and BIN chunks of a well-formed GLB (None when it is not one).
pub fn glb_parts(bytes: &[u8]) -> Option<(Vec<u8>, Vec<u8>)> {
    let u32_at = |o: usize| Some(u32::from_le_bytes(bytes.get(o..o + 4)?.try_into().ok()?) as usize);
    let jl = u32_at(12)?;
    let json = bytes.get(20..20 + jl)?.to_vec();
    let bl = u32_at(20 + jl).unwrap_or(0);
    let bin = bytes.get(28 + jl..28 + jl + bl).map(<[u8]>::to_vec).unwrap_or_default();
    Some((json, bin))
}

/// A GLB from its chunks, every length right (the JSON padded with spaces, the BIN with zeros).
pub fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut json = json.to_vec();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
    }
    out
}

/// 32-bit values put in place of a length, a count or a float's bits: 0, 1, tiny and huge, every
/// bit set, 2²⁴, the float bits of NaN, +inf and 3e38.
pub const WORDS: &[u32] = &[
    0,
    1,
    3,
    4,
    0xFF,
    0xFFFF,
    1 << 24,
    0x7FFF_FFFF,
    0x8000_0000,
    0xFFFF_FFFF,
    0x7FC0_0000,
    0x7F80_0000,
    0xFF80_0000,
    0x7F61_B1E6,
];

fn put_u32(bytes: &mut [u8], at: usize, v: u32) {
    if at + 4 <= bytes.len() {
        bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }
}

fn flip_bytes(bytes: &mut [u8], range: std::ops::Range<usize>, rng: &mut Rng) {
    if range.is_empty() {
        return;
    }
    for _ in 0..1 + below(rng, 4) {
        let at = range.start + below(rng, range.len());
        bytes[at] ^= 1 << below(rng, 8);
    }
}

/// One mutation of a GLB: its JSON chunk (re-wrapped with right lengths, so the JSON reaches the
/// importer), its container (a header or chunk length or type replaced), its BIN chunk (bits
/// flipped, a 32-bit word replaced by an extreme), or its end (cut short, grown).
pub fn mutate_glb(bytes: &[u8], rng: &mut Rng) -> Vec<u8> {
    let Some((json, bin)) = glb_parts(bytes) else {
        let mut b = bytes.to_vec();
        flip_bytes(&mut b, 0..bytes.len(), rng);
        return b;
    };
    let bin_at = 28 + json.len();
    match below(rng, 12) {
        0..=4 => {
            let text = String::from_utf8_lossy(&json).into_owned();
            glb(mutate_json(text.trim_end(), rng).as_bytes(), &bin)
        }
        5 | 6 => {
            let mut b = bytes.to_vec();
            let fields = [8, 12, 16, 20 + json.len(), 24 + json.len(), 4];
            let at = fields[below(rng, fields.len())];
            let v = if below(rng, 3) == 0 {
                // Off by a little: a length just short of or past the truth.
                let old = b.get(at..at + 4).map_or(0, |w| u32::from_le_bytes(w.try_into().unwrap()));
                old.wrapping_add([4, 0xFFFF_FFFC, 1][below(rng, 3)])
            } else {
                WORDS[below(rng, WORDS.len())]
            };
            put_u32(&mut b, at, v);
            b
        }
        7 | 8 => {
            let mut b = bytes.to_vec();
            let end = b.len();
            flip_bytes(&mut b, bin_at.min(end)..end, rng);
            b
        }
        9 | 10 => {
            let mut b = bytes.to_vec();
            if b.len() > bin_at + 4 {
                let words = (b.len() - bin_at) / 4;
                put_u32(&mut b, bin_at + 4 * below(rng, words), WORDS[below(rng, WORDS.len())]);
            }
            b
        }
        _ => {
            let mut b = bytes.to_vec();
            if below(rng, 2) == 0 {
                let keep = below(rng, b.len());
                b.truncate(keep);
            } else {
                b.extend_from_slice(&[0x20; 13]);
            }
            b
        }
    }
}

// ---------------------------------------------------------------- PNG

/// CRC-32 (ISO 3309, the PNG chunk checksum), bit by bit.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

/// PNG dimensions: 0, 1, the 16384 hadou renders at most, 100000 (the EXR bomb), 2³¹−1
/// (PNG's largest) and past it.
pub const PNG_SIDES: &[u32] = &[0, 1, 16384, 65535, 100_000, 0x7FFF_FFFF, 0x8000_0000, 0xFFFF_FFFF];

/// Re-computes the CRC of the chunk starting at `at` (its length field).
fn fix_crc(b: &mut [u8], at: usize) {
    let len = u32::from_be_bytes(b[at..at + 4].try_into().unwrap()) as usize;
    if at + 12 + len <= b.len() {
        let crc = crc32(&b[at + 4..at + 8 + len]);
        b[at + 8 + len..at + 12 + len].copy_from_slice(&crc.to_be_bytes());
    }
}

/// One mutation of a PNG: IHDR's width or height replaced (CRC kept right, so the decoder reads
/// the claim), its bit depth, colour type or interlace byte replaced, an IDAT bit flipped, or the
/// file cut short.
pub fn mutate_png(bytes: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut b = bytes.to_vec();
    if b.len() < 33 {
        // Already cut inside IHDR (a second mutation): flip what is left.
        let end = b.len();
        flip_bytes(&mut b, 0..end, rng);
        return b;
    }
    // IHDR is the first chunk: length at 8, type at 12, data at 16..29, CRC at 29.
    match below(rng, 10) {
        8 | 9 => {
            // Both sides claimed large at once.
            let side = [100_000, 65535, 0x7FFF_FFFF][below(rng, 3)];
            put_be(&mut b, 16, side);
            put_be(&mut b, 20, side);
            fix_crc(&mut b, 8);
        }
        0..=3 => {
            put_be(&mut b, 16 + 4 * below(rng, 2), PNG_SIDES[below(rng, PNG_SIDES.len())]);
            if below(rng, 2) == 0 {
                put_be(&mut b, 16 + 4 * below(rng, 2), PNG_SIDES[below(rng, PNG_SIDES.len())]);
            }
            fix_crc(&mut b, 8);
        }
        4 => {
            let at = 24 + below(rng, 5);
            b[at] = [0, 1, 2, 3, 4, 6, 8, 16, 255][below(rng, 9)];
            fix_crc(&mut b, 8);
        }
        5 | 6 => {
            let start = 33.min(b.len());
            let end = b.len();
            flip_bytes(&mut b, start..end, rng);
        }
        _ => {
            let keep = below(rng, b.len());
            b.truncate(keep);
        }
    }
    b
}

fn put_be(b: &mut [u8], at: usize, v: u32) {
    b[at..at + 4].copy_from_slice(&v.to_be_bytes());
}

// ---------------------------------------------------------------- OpenEXR

/// One attribute of an OpenEXR header: name, type and where its value lies.
#[derive(Clone, Debug)]
pub struct ExrAttribute {
    /// Offset of its name.
    pub start: usize,
    pub name: String,
    pub kind: String,
    /// Offset of the 4-byte size field.
    pub size_at: usize,
    /// Offset and length of the value.
    pub value: std::ops::Range<usize>,
}

/// The attributes of a single-part OpenEXR header (empty when it does not parse).
pub fn exr_attributes(b: &[u8]) -> Vec<ExrAttribute> {
    let cstr = |at: usize| -> Option<(String, usize)> {
        let end = at + b.get(at..)?.iter().position(|&c| c == 0)?;
        Some((String::from_utf8_lossy(&b[at..end]).into_owned(), end + 1))
    };
    let mut out = Vec::new();
    let mut at = 8;
    while let Some((name, next)) = cstr(at) {
        if name.is_empty() {
            break;
        }
        let Some((kind, size_at)) = cstr(next) else { break };
        let Some(size) = b.get(size_at..size_at + 4).map(|s| i32::from_le_bytes(s.try_into().unwrap()))
        else {
            break;
        };
        let start = size_at + 4;
        let Some(end) = usize::try_from(size).ok().map(|s| start + s).filter(|&e| e <= b.len()) else {
            break;
        };
        out.push(ExrAttribute { start: at, name, kind, size_at, value: start..end });
        at = end;
    }
    out
}

/// i32 values for a window's corners: 0, −1, 1, the 100000 − 1, hadou's 16384, the
/// extremes of i32.
pub const EXR_COORDS: &[i32] =
    &[0, -1, 1, 3, 16383, 16384, 65535, 99_999, 1 << 24, i32::MAX, i32::MIN, -100_000];

/// A single-part, uncompressed, scanline OpenEXR (no chunkCount: it is optional there) of f32
/// channels `names` (sorted, as the format stores them), `values` pixel-interleaved in that
/// order. Written by hand, independent of the decoder under test.
pub fn scanline_exr(width: i32, height: i32, names: &[&str], values: &[f32]) -> Vec<u8> {
    let n = names.len();
    assert!(names.windows(2).all(|w| w[0] < w[1]) && values.len() == (width * height) as usize * n);
    let attr = |b: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]| {
        b.extend(name.as_bytes());
        b.push(0);
        b.extend(kind.as_bytes());
        b.push(0);
        b.extend((value.len() as i32).to_le_bytes());
        b.extend(value);
    };
    let mut b = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    let mut chlist = Vec::new();
    for name in names {
        chlist.extend(name.as_bytes());
        chlist.push(0);
        chlist.extend(2i32.to_le_bytes()); // FLOAT
        chlist.extend([0, 0, 0, 0]); // pLinear, reserved
        chlist.extend(1i32.to_le_bytes());
        chlist.extend(1i32.to_le_bytes());
    }
    chlist.push(0);
    attr(&mut b, "channels", "chlist", &chlist);
    attr(&mut b, "compression", "compression", &[0]);
    let window: Vec<u8> = [0, 0, width - 1, height - 1].iter().flat_map(|v: &i32| v.to_le_bytes()).collect();
    attr(&mut b, "dataWindow", "box2i", &window);
    attr(&mut b, "displayWindow", "box2i", &window);
    attr(&mut b, "lineOrder", "lineOrder", &[0]);
    attr(&mut b, "pixelAspectRatio", "float", &1f32.to_le_bytes());
    attr(&mut b, "screenWindowCenter", "v2f", &[0; 8]);
    attr(&mut b, "screenWindowWidth", "float", &1f32.to_le_bytes());
    b.push(0);
    let line_bytes = width as usize * n * 4;
    let table_end = b.len() + 8 * height as usize;
    for y in 0..height as usize {
        b.extend(((table_end + y * (8 + line_bytes)) as u64).to_le_bytes());
    }
    for y in 0..height as usize {
        b.extend((y as i32).to_le_bytes());
        b.extend((line_bytes as i32).to_le_bytes());
        for c in 0..n {
            for x in 0..width as usize {
                b.extend(values[(y * width as usize + x) * n + c].to_le_bytes());
            }
        }
    }
    b
}

/// Sides claimed at once by an OpenEXR window: the 100000, hadou's largest image + 1,
/// 2¹⁶, 2²⁰, i32's largest.
pub const EXR_SIDES: &[i32] = &[100_000, 16385, 65536, 1 << 20, i32::MAX];

/// Writes corner value `k` (xMin, yMin, xMax, yMax) of the box2i attribute `a`, if its value
/// (perhaps resized by an earlier mutation) holds it.
fn put_corner(b: &mut [u8], a: &ExrAttribute, k: usize, v: i32) {
    let at = a.value.start + 4 * k;
    if at + 4 <= a.value.end {
        b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }
}

/// One mutation of an OpenEXR file: a corner of its dataWindow or displayWindow replaced (the
/// dimensions it claims), a channel's pixel type or sampling replaced, an attribute's size
/// replaced, the compression or line order byte replaced, header or data bits flipped, or the
/// file cut short.
pub fn mutate_exr(bytes: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut b = bytes.to_vec();
    let attrs = exr_attributes(bytes);
    let find = |name: &str| attrs.iter().find(|a| a.name == name).cloned();
    let header_end = attrs.last().map_or(8, |a| a.value.end + 1);
    match below(rng, 15) {
        12..=14 => {
            // Both sides claimed large at once (the 100000×100000 file): a decoder that
            // believes the header allocates width × height × channels before reading a pixel.
            let w = if below(rng, 4) == 0 { "displayWindow" } else { "dataWindow" };
            if let Some(a) = find(w) {
                for k in 0..4 {
                    let v = if k < 2 { 0 } else { EXR_SIDES[below(rng, EXR_SIDES.len())] - 1 };
                    put_corner(&mut b, &a, k, v);
                }
            }
        }
        0..=4 => {
            let w = if below(rng, 4) == 0 { "displayWindow" } else { "dataWindow" };
            if let Some(a) = find(w) {
                for _ in 0..1 + below(rng, 2) {
                    let k = below(rng, 4);
                    put_corner(&mut b, &a, k, EXR_COORDS[below(rng, EXR_COORDS.len())]);
                }
            }
        }
        5 | 6 => {
            // chlist: name\0, pixel type i32, pLinear u8, 3 reserved, xSampling i32, ySampling i32.
            if let Some(a) = find("channels") {
                let mut at = a.value.start;
                let mut fields = Vec::new();
                while at < a.value.end && b[at] != 0 {
                    let Some(len) = b[at..a.value.end].iter().position(|&c| c == 0) else { break };
                    let end = at + len;
                    fields.push((at, end + 1));
                    at = end + 1 + 16;
                }
                if !fields.is_empty() {
                    let (name_at, ty_at) = fields[below(rng, fields.len())];
                    match below(rng, 4) {
                        0 => put_u32(&mut b, ty_at, [0u32, 1, 2, 3, 0xFFFF_FFFF][below(rng, 5)]),
                        1 => {
                            put_u32(&mut b, ty_at + 8, [0u32, 2, 3, 0x7FFF_FFFF, 0xFFFF_FFFF][below(rng, 5)])
                        }
                        2 => {
                            put_u32(&mut b, ty_at + 12, [0u32, 2, 3, 0x7FFF_FFFF, 0xFFFF_FFFF][below(rng, 5)])
                        }
                        _ => b[name_at] = [b'R', b'Y', b'Z', 0x1b, b'.'][below(rng, 5)],
                    }
                }
            }
        }
        7 => {
            if !attrs.is_empty() {
                let a = &attrs[below(rng, attrs.len())];
                if below(rng, 2) == 0 {
                    put_u32(&mut b, a.size_at, WORDS[below(rng, WORDS.len())]);
                } else {
                    // An attribute left out (chunkCount is optional in a single-part file).
                    b.drain(a.start..a.value.end);
                }
            }
        }
        8 => {
            let which = if below(rng, 2) == 0 { "compression" } else { "lineOrder" };
            if let Some(a) = find(which) {
                b[a.value.start] = [0u8, 1, 2, 3, 4, 7, 9, 255][below(rng, 8)];
            }
        }
        9 => flip_bytes(&mut b, 8..header_end.min(bytes.len()), rng),
        10 => flip_bytes(&mut b, header_end.min(bytes.len())..bytes.len(), rng),
        _ => {
            let keep = below(rng, b.len());
            b.truncate(keep);
        }
    }
    b
}

// ------------------------------------------------------------------------------- `hadou test` sidecars

/// Values put in place of a sidecar value (`size`, `time`, `aovs`, `skip`, the tolerances): sizes
/// without a side, of 0, past 16384 and past u32, an endless time, numbers past f64 and f32,
/// negative and non-finite tolerances, AOV lists of unknown, repeated or wrongly typed names,
/// values of another TOML type, and an escape sequence for the terminal.
pub const SIDECAR_VALUES: &[&str] = &[
    "\"16x16\"",
    "\"0x16\"",
    "\"16x0\"",
    "\"16384x16384\"",
    "\"16385x1\"",
    "\"4294967296x1\"",
    "\"x16\"",
    "\"16x\"",
    "\"16 x 16\"",
    "\"-16x16\"",
    "\"\"",
    "\"\u{1b}[31mred\"",
    "16",
    "1e308",
    "1.7976931348623157e308",
    "-1.7976931348623157e308",
    "3.4e38",
    "1e39",
    "-1",
    "-0.0",
    "0",
    "0.5",
    "nan",
    "inf",
    "-inf",
    "9223372036854775807",
    "true",
    "[\"depth\"]",
    "[\"depth\", \"depth\"]",
    "[\"energy\", \"thickness\", \"normal\"]",
    "[\"nope\"]",
    "[1]",
    "[]",
    "{ flip = 1 }",
    "1979-05-27T07:32:00Z",
];

/// Lines put into a sidecar: every key (in the wrong place too), a second `[tolerance]`, unknown
/// keys and tables, a dotted key, and lines that are no TOML.
pub const SIDECAR_LINES: &[&str] = &[
    "size = \"8x8\"",
    "time = 1e300",
    "aovs = [\"depth\", \"energy\"]",
    "skip = \"later\"",
    "[tolerance]",
    "flip = 0.5",
    "abs = -1",
    "rel = nan",
    "pixels = 2",
    "pixels = 1e39",
    "unknown = 1",
    "[tolerance.nested]",
    "[[tolerance]]",
    "tolerance.abs = 1",
    "size = ",
    "= 1",
    "[",
    "\"unterminated",
];

/// The values of `text`'s `key = value` lines (what follows `=` up to a comment), as byte ranges;
/// comment lines are passed over.
fn toml_values(text: &str) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for (start, line) in text.split_inclusive('\n').scan(0, |at, l| {
        let s = *at;
        *at += l.len();
        Some((s, l))
    }) {
        let Some(eq) = line.find('=') else { continue };
        if line.trim_start().starts_with('#') {
            continue;
        }
        let value = &line[eq + 1..];
        let lead = value.len() - value.trim_start().len();
        let end = value.find('#').unwrap_or(value.len());
        let value_text = value[lead..end].trim_end();
        if !value_text.is_empty() {
            out.push((start + eq + 1 + lead, start + eq + 1 + lead + value_text.len()));
        }
    }
    out
}

/// One mutation of a sidecar: a value replaced (`SIDECAR_VALUES`), a line inserted
/// (`SIDECAR_LINES`), deleted, duplicated or swapped, the text cut short, or a few bytes flipped
/// (which may leave it no UTF-8).
pub fn mutate_sidecar_once(text: &[u8], rng: &mut Rng) -> Vec<u8> {
    let Ok(s) = std::str::from_utf8(text) else {
        let mut b = text.to_vec();
        if !b.is_empty() {
            let at = below(rng, b.len());
            b[at] = (rng.next() * 256.0) as u8;
        }
        return b;
    };
    let lines: Vec<&str> = s.lines().collect();
    let joined = |lines: &[&str]| {
        let mut t = lines.join("\n");
        t.push('\n');
        t.into_bytes()
    };
    match below(rng, 8) {
        0..=2 => {
            let values = toml_values(s);
            if values.is_empty() {
                return joined(&[s, rng.pick(SIDECAR_LINES)]);
            }
            let (a, b) = values[below(rng, values.len())];
            format!("{}{}{}", &s[..a], rng.pick(SIDECAR_VALUES), &s[b..]).into_bytes()
        }
        3 => {
            let mut l = lines.clone();
            let at = below(rng, l.len() + 1);
            l.insert(at, rng.pick(SIDECAR_LINES));
            joined(&l)
        }
        4 if !lines.is_empty() => {
            let mut l = lines.clone();
            let at = below(rng, l.len());
            match below(rng, 3) {
                0 => {
                    l.remove(at);
                }
                1 => l.insert(at, lines[at]),
                _ => l.swap(at, below(rng, lines.len())),
            }
            joined(&l)
        }
        5 => text[..below(rng, text.len() + 1)].to_vec(),
        6 => {
            let mut b = text.to_vec();
            for _ in 0..1 + below(rng, 3) {
                if !b.is_empty() {
                    let at = below(rng, b.len());
                    b[at] = (rng.next() * 256.0) as u8;
                }
            }
            b
        }
        _ => joined(&[
            s,
            rng.pick(SIDECAR_LINES),
            &format!(
                "{} = {}",
                rng.pick(&["size", "time", "aovs", "skip", "flip", "abs", "rel", "pixels"]),
                rng.pick(SIDECAR_VALUES)
            ),
        ]),
    }
}

/// One to three mutations of a sidecar.
pub fn mutate_sidecar(text: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut out = text.to_vec();
    for _ in 0..1 + below(rng, 3) {
        out = mutate_sidecar_once(&out, rng);
    }
    out
}
