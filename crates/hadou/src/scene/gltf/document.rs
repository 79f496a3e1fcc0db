//! Reading a .gltf / .glb file into the gltf crate's `Document`: the file checked regular before it
//! is opened, the GLB header checked before the crate parses it, and the crate's validation (every
//! index in range, required fields present) run with each finding turned into a JSON pointer.

use std::path::Path;

use gltf::json::validation::{Error as Invalid, Validate};

use super::error::{pointer_from_crate_path, GltfError};

/// The extensions hadou honours: a file may require them. Each is read as docs/scene-format.md's
/// mapping table says (what it cannot draw of them, such as point lights or thin-walled
/// transmission, is listed in the one warning).
pub(super) const HONOURED: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_emissive_strength",
    "KHR_texture_transform",
];

/// Extensions that change how geometry is stored: a file that requires one cannot be drawn
/// at all without it (its message says so).
const GEOMETRY: &[&str] = &[
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_mesh_quantization",
    "EXT_mesh_gpu_instancing",
];

/// A parsed, validated glTF: the document and the GLB's BIN chunk, if any.
pub(super) struct Parsed {
    pub doc: gltf::Document,
    pub blob: Option<Vec<u8>>,
}

/// Reads and validates `path`.
pub(super) fn read(path: &Path) -> Result<Parsed, GltfError> {
    let whole = |message: String| GltfError::at(path, "", message);
    let unreadable = |e: std::io::Error| {
        whole(format!("cannot read glTF file: {e} (expected a readable .gltf or .glb file)"))
    };
    // The type is checked before opening: a FIFO would block, a device might never end.
    let meta = std::fs::metadata(path).map_err(unreadable)?;
    if !meta.is_file() {
        return Err(unreadable(std::io::Error::other("not a regular file")));
    }
    let bytes = std::fs::read(path).map_err(unreadable)?;
    check_glb_header(&bytes).map_err(whole)?;
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| whole(parse_message(e)))?;
    validate(path, &gltf.document)?;
    Ok(Parsed { doc: gltf.document, blob: gltf.blob })
}

/// The GLB header's total length must cover the header itself: the crate subtracts 12 from it
/// unchecked (a length below 12 would underflow).
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let Some(length) = bytes.get(8..12) else {
        return Err(format!("binary glTF header cut short: {} bytes (expected 12)", bytes.len()));
    };
    let length = u32::from_le_bytes([length[0], length[1], length[2], length[3]]);
    if length < 20 {
        return Err(format!("binary glTF header gives a total length of {length} bytes (expected at least 20: header and JSON chunk header)"));
    }
    // The crate splits the chunks from the bytes it was given, not from this length: bytes past
    // the stated end (appended data, a truncated rewrite) would be read as chunks silently.
    if length as usize != bytes.len() {
        return Err(format!(
            "binary glTF header gives a total length of {length} bytes but the file has {} (expected the two to be equal: glTF 2.0 §4.4.2)",
            bytes.len()
        ));
    }
    Ok(())
}

/// hadou reads glTF 2.x: `asset.version` must be `2.<minor>`, and a `minVersion`, if given, at most
/// 2.0 (a later minor version may need what a 2.0 reader lacks; glTF 2.0 §3.2).
fn check_version(path: &Path, asset: &gltf::json::Asset) -> Result<(), GltfError> {
    fn major_minor(v: &str) -> Option<(u64, u64)> {
        let (major, minor) = v.split_once('.')?;
        let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
        if !digits(major) || !digits(minor) {
            return None;
        }
        Some((major.parse().ok()?, minor.parse().ok()?))
    }
    let shown = |v: &str| v.chars().take(32).collect::<String>();
    let version = asset.version.as_str();
    if major_minor(version).is_none_or(|(major, _)| major != 2) {
        let message = format!(
            "glTF version \"{}\" (expected \"2.0\" or another 2.x: hadou reads glTF 2)",
            shown(version)
        );
        return Err(GltfError::at(path, "/asset/version", message));
    }
    if let Some(min) = asset.min_version.as_deref() {
        if major_minor(min).is_none_or(|v| v > (2, 0)) {
            let message =
                format!("minVersion \"{}\" (expected at most \"2.0\", the version hadou reads)", shown(min));
            return Err(GltfError::at(path, "/asset/minVersion", message));
        }
    }
    Ok(())
}

/// The crate's primitive validation reads `accessors[POSITION]` before checking the index is in
/// range (gltf-json 1.4.1, mesh.rs): an out-of-range POSITION index would panic there.
fn check_position_indices(path: &Path, root: &gltf::json::Root) -> Result<(), GltfError> {
    use gltf::json::mesh::Semantic;
    use gltf::json::validation::Checked;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(a) = prim.attributes.get(&Checked::Valid(Semantic::Positions)) {
                if a.value() >= root.accessors.len() {
                    let message = format!(
                        "accessor {} does not exist (the file has {}): index out of range",
                        a.value(),
                        root.accessors.len()
                    );
                    return Err(GltfError::at(
                        path,
                        format!("/meshes/{m}/primitives/{p}/attributes/POSITION"),
                        message,
                    ));
                }
            }
        }
    }
    Ok(())
}

fn parse_message(e: gltf::Error) -> String {
    match e {
        gltf::Error::Deserialize(e) if e.line() > 0 => {
            format!("invalid glTF JSON at line {}, column {}: {e}", e.line(), e.column())
        }
        gltf::Error::Deserialize(e) => format!("invalid glTF JSON: {e}"),
        gltf::Error::Binary(e) => format!("invalid binary glTF (.glb): {e}"),
        e => format!("cannot parse glTF: {e}"),
    }
}

/// Runs the crate's validation; the first finding is the error. `Unsupported` findings are about
/// `extensionsRequired`, checked here instead (`check_required`).
fn validate(path: &Path, doc: &gltf::Document) -> Result<(), GltfError> {
    let root = doc.as_json();
    check_version(path, &root.asset)?;
    check_position_indices(path, root)?;
    let mut findings = Vec::new();
    // A backstop: the crate's validation indexes some arrays before checking (see
    // `check_position_indices`); any other such slip is an error here, not an abort.
    let ran = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        root.validate(root, gltf::json::Path::new, &mut |p: &dyn Fn() -> gltf::json::Path, e| {
            findings.push((p().as_str().to_owned(), e));
        })
    }));
    if ran.is_err() {
        return Err(GltfError::at(
            path,
            "",
            "the gltf crate's validation failed on this file (malformed glTF)",
        ));
    }
    for (p, e) in findings {
        if e == Invalid::Unsupported {
            continue;
        }
        let what = match e {
            Invalid::IndexOutOfBounds => "index out of range (no such object in the file)",
            Invalid::Invalid => "invalid value",
            Invalid::Missing => "required value missing",
            Invalid::Oversize => "size or offset too large",
            Invalid::Unsupported => unreachable!(),
        };
        return Err(GltfError::at(path, pointer_from_crate_path(&p), what));
    }
    check_required(path, &root.extensions_required)
}

/// glTF 2.0 §3.12: "If a required extension is not supported by the client, the client must not
/// load the asset": every extension of `extensionsRequired` must be one hadou honours
/// (`HONOURED`), else the file is refused at its pointer, naming it. (Before, a required
/// extension hadou does not read — `KHR_materials_unlit`, `KHR_texture_basisu` — loaded with a
/// warning and drew something the file says is wrong.)
fn check_required(path: &Path, required: &[String]) -> Result<(), GltfError> {
    for (i, ext) in required.iter().enumerate() {
        if HONOURED.contains(&ext.as_str()) {
            continue;
        }
        let shown: String = ext.chars().take(64).collect();
        let why = if GEOMETRY.contains(&ext.as_str()) {
            "which hadou cannot read (its meshes cannot be drawn without it)"
        } else {
            "which hadou does not implement (glTF 2.0 §3.12: a file that requires an extension must not be loaded without it)"
        };
        let message = format!(
            "the file requires extension {shown}, {why}; expected only required extensions hadou honours: {}",
            HONOURED.join(", ")
        );
        return Err(GltfError::at(path, format!("/extensionsRequired/{i}"), message));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_glb_headers_are_refused_before_the_crate_sees_them() {
        assert!(check_glb_header(b"glTF\x02\0\0\0").unwrap_err().contains("cut short"));
        assert!(check_glb_header(b"glTF\x02\0\0\0\x04\0\0\0").unwrap_err().contains("total length of 4"));
        assert!(check_glb_header(b"{\"asset\":{}}").is_ok());
        let mut glb = b"glTF\x02\0\0\0\x18\0\0\0\x04\0\0\0JSON{}  ".to_vec();
        assert!(check_glb_header(&glb).is_ok());
        glb.extend_from_slice(b"tail");
        let e = check_glb_header(&glb).unwrap_err();
        assert!(e.contains("total length of 24 bytes but the file has 28"), "{e}");
    }

    #[test]
    fn only_gltf_2_is_read() {
        let asset = |version: &str, min: Option<&str>| gltf::json::Asset {
            version: version.to_owned(),
            min_version: min.map(str::to_owned),
            ..Default::default()
        };
        let p = Path::new("a.gltf");
        for ok in [asset("2.0", None), asset("2.1", Some("2.0")), asset("2.0", Some("1.0"))] {
            check_version(p, &ok).unwrap();
        }
        for (bad, at) in [
            (asset("1.0", None), "/asset/version"),
            (asset("3.0", None), "/asset/version"),
            (asset("2", None), "/asset/version"),
            (asset("2.x", None), "/asset/version"),
            (asset("", None), "/asset/version"),
            (asset("2.1", Some("2.1")), "/asset/minVersion"),
        ] {
            assert_eq!(check_version(p, &bad).unwrap_err().pointer, at, "{bad:?}");
        }
    }

    #[test]
    fn required_extensions_must_be_honoured() {
        let p = Path::new("a.glb");
        let req = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        check_required(
            p,
            &req(&["KHR_materials_volume", "KHR_lights_punctual", "KHR_materials_transmission"]),
        )
        .unwrap();
        for (list, at, words) in [
            (
                req(&["KHR_lights_punctual", "KHR_materials_unlit"]),
                "/extensionsRequired/1",
                "does not implement",
            ),
            (req(&["KHR_texture_basisu"]), "/extensionsRequired/0", "does not implement"),
            (req(&["KHR_draco_mesh_compression"]), "/extensionsRequired/0", "cannot read"),
        ] {
            let e = check_required(p, &list).unwrap_err();
            assert_eq!(e.pointer, at);
            assert!(e.message.contains(list.last().unwrap()) && e.message.contains(words), "{e}");
            assert!(e.to_string().starts_with("a.glb: /extensionsRequired/"), "{e}");
        }
    }
}
