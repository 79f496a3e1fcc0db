//! The bytes of every buffer: the GLB's BIN chunk, a base64 `data:` URI, or a file beside the
//! glTF. Each is checked to hold at least its declared `byteLength`. A file URI must lead to a
//! regular file inside the glTF file's folder (after percent-decoding and resolving symbolic
//! links): a glTF file names only its own parts, never `/etc/passwd` or `../../secret`.

use std::path::{Component, Path, PathBuf};

use base64::Engine;

use super::error::GltfError;

/// Every buffer's bytes, in file order, and the external files they came from.
pub(super) struct Buffers {
    pub data: Vec<Vec<u8>>,
    pub files: Vec<PathBuf>,
}

/// Loads all buffers of `doc` (a missing one is an error even if nothing reads it: the file is
/// broken, and a later edit would reach it).
pub(super) fn load(
    path: &Path,
    doc: &gltf::Document,
    blob: &mut Option<Vec<u8>>,
) -> Result<Buffers, GltfError> {
    let mut data = Vec::new();
    let mut files = Vec::new();
    // Every image URI is checked here, also those no drawn texture reads (`texture` reads the
    // others): a URI leaving the folder is refused all the same, the file is not one to trust.
    for image in doc.images() {
        if let gltf::image::Source::Uri { uri, .. } = image.source() {
            let at = format!("/images/{}/uri", image.index());
            if !uri.starts_with("data:") && !uri.contains("://") {
                inside_folder(path, &at, uri)?;
            }
        }
    }
    for buffer in doc.buffers() {
        let i = buffer.index();
        let bytes = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                GltfError::at(
                    path,
                    format!("/buffers/{i}"),
                    "missing buffer: no `uri` and no GLB BIN chunk to take it from (expected a `uri` or a .glb with binary data)",
                )
            })?,
            gltf::buffer::Source::Uri(uri) => read_uri(path, i, uri, &mut files)?,
        };
        let declared = buffer.length();
        if bytes.len() < declared {
            let message = format!(
                "buffer declares {declared} bytes but its data has {} (expected at least byteLength bytes)",
                bytes.len()
            );
            return Err(GltfError::at(path, format!("/buffers/{i}/byteLength"), message));
        }
        data.push(bytes);
    }
    Ok(Buffers { data, files })
}

fn read_uri(path: &Path, i: usize, uri: &str, files: &mut Vec<PathBuf>) -> Result<Vec<u8>, GltfError> {
    let at = format!("/buffers/{i}/uri");
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err(GltfError::at(
                path,
                at,
                "a data: URI without `;base64,` (expected base64-encoded data)",
            ));
        };
        return base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| GltfError::at(path, at, format!("invalid base64 in data: URI: {e}")));
    }
    if uri.contains("://") {
        return Err(GltfError::at(
            path,
            at,
            format!("`{uri}`: only data: URIs and relative file paths are read"),
        ));
    }
    let file = inside_folder(path, &at, uri)?;
    let unreadable = |e: std::io::Error| {
        GltfError::at(path, at.clone(), format!("missing buffer: cannot read {}: {e}", file.display()))
    };
    // The type is checked before opening (a FIFO would block).
    let meta = std::fs::metadata(&file).map_err(unreadable)?;
    if !meta.is_file() {
        return Err(unreadable(std::io::Error::other("not a regular file")));
    }
    let bytes = std::fs::read(&file).map_err(unreadable)?;
    files.push(file);
    Ok(bytes)
}

/// The file a relative URI names, checked to lie inside the glTF file's folder: the URI
/// percent-decoded, refused when absolute, then (when the file exists) every symbolic link
/// resolved and the real path compared with the folder's real path. A file that does not exist
/// must not leave the folder by its `..` parts either; for it the joined path is returned, so
/// the caller's error names what was looked for. Messages name the URI and the folder, never
/// anything read from a file.
pub(super) fn inside_folder(path: &Path, at: &str, uri: &str) -> Result<PathBuf, GltfError> {
    let shown: String = uri.chars().take(200).collect();
    let refuse = |why: &str| {
        GltfError::at(
            path,
            at,
            format!("`{shown}` {why} (expected a path relative to the glTF file's folder, inside it: hadou reads nothing else)"),
        )
    };
    let decoded = percent_decode(uri);
    let rel = Path::new(&decoded);
    if rel.has_root() || rel.components().any(|c| matches!(c, Component::Prefix(_) | Component::RootDir)) {
        return Err(refuse("is an absolute path"));
    }
    // Lexically: `..` may not climb above the folder (`a/../b` is fine, `../b` and `a/../../b`
    // are not), whether the file exists or not.
    let mut depth = 0i64;
    for c in rel.components() {
        match c {
            Component::ParentDir => depth -= 1,
            Component::Normal(_) => depth += 1,
            _ => {}
        }
        if depth < 0 {
            return Err(refuse("leads out of the glTF file's folder"));
        }
    }
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let file = folder.join(rel);
    let real_folder = std::fs::canonicalize(&folder).map_err(|e| {
        GltfError::at(path, at, format!("cannot resolve the glTF file's folder {}: {e}", folder.display()))
    })?;
    match std::fs::canonicalize(&file) {
        // Symbolic links resolved: the real file must still be inside the real folder.
        Ok(real) if real.starts_with(&real_folder) => Ok(real),
        Ok(_) => Err(refuse("leads out of the glTF file's folder through a symbolic link")),
        // Missing (or a link to nowhere): the caller says so for a buffer or a drawn texture's
        // image (naming the path looked for); an unread image's URI has passed the lexical check.
        Err(_) => Ok(file),
    }
}

/// URIs are percent-encoded (`my%20mesh.bin`); a `%` not followed by two hex digits stays as is.
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("my%20mesh.bin"), "my mesh.bin");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("a%2"), "a%2");
        assert_eq!(percent_decode("%41"), "A");
    }
}
