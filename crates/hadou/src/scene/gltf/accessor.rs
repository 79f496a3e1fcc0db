//! Reading accessors with every range checked: the accessor inside its buffer view, the view
//! inside its buffer, strides and alignment as glTF requires. Problems name the place that used
//! the accessor (a primitive's attribute or indices) and the accessor itself.

use std::path::Path;

use gltf::accessor::{DataType, Dimensions};

use super::error::GltfError;

/// The most elements an accessor without a bufferView (zeros, then sparse substitutions) may
/// have: 2²⁴ vertices (192 MiB of positions) is past any single game asset.
pub const MAX_ZEROS: usize = 1 << 24;

/// Why an accessor could not be read: a broken file, or a valid encoding hadou does not read.
pub(super) enum ReadError {
    /// The file is malformed here.
    Bad(GltfError),
    /// Valid glTF hadou does not read (quantized accessors): the primitive is skipped and listed
    /// as ignored.
    Unsupported(String),
}

impl From<GltfError> for ReadError {
    fn from(e: GltfError) -> Self {
        ReadError::Bad(e)
    }
}

/// Where accessors are read from: the file (for errors) and its buffers' bytes.
pub(super) struct Source<'a> {
    pub path: &'a Path,
    pub buffers: &'a [Vec<u8>],
}

/// True for an accessor hadou does not read as positions or normals (normalized integers,
/// `KHR_mesh_quantization`): the primitive is skipped.
pub(super) fn quantized(a: &gltf::Accessor) -> bool {
    a.normalized() || a.data_type() != DataType::F32
}

/// True when `vec3` (for a VEC3 accessor) or `indices` (for a SCALAR one) would go on to read
/// `a`'s elements rather than refuse its type: only then is `check_declared` the read's first
/// error.
pub(super) fn readable(a: &gltf::Accessor) -> bool {
    match a.dimensions() {
        Dimensions::Vec3 => !quantized(a),
        Dimensions::Scalar => matches!(a.data_type(), DataType::U8 | DataType::U16 | DataType::U32),
        _ => false,
    }
}

/// The checks on an accessor's declared count that need none of its data: run before anything
/// is decoded, so a count no buffer bounds is refused before it is allocated.
/// The same checks and messages as a read, from the JSON alone (a buffer's data is at least its
/// declared `byteLength`: `buffers::load` checks that).
pub(super) fn check_declared(path: &Path, a: &gltf::Accessor, at: &str) -> Result<(), GltfError> {
    let count = a.count();
    if count == 0 {
        return Err(bad(path, at, a, "accessor has count 0 (expected at least one element)"));
    }
    match a.view() {
        Some(view) => {
            let stride = element_stride(path, at, a, &view)?;
            declared_range(path, a, at, &view, a.offset(), count, a.size(), stride)?;
        }
        None if count > MAX_ZEROS => {
            let message = format!("{count} elements without a bufferView (hadou reads at most {MAX_ZEROS})");
            return Err(bad(path, at, a, message));
        }
        None => {}
    }
    Ok(())
}

/// The distance between elements in `view`: its byteStride (a multiple of the component size, at
/// least the element size) or, without one, the element size.
fn element_stride(
    path: &Path,
    at: &str,
    a: &gltf::Accessor,
    view: &gltf::buffer::View,
) -> Result<usize, GltfError> {
    let (size, component) = (a.size(), a.data_type().size());
    let stride = view.stride().unwrap_or(size);
    if stride < size || stride % component != 0 {
        let message = format!(
            "buffer view /bufferViews/{} has byteStride {stride} (expected a multiple of {component} and at least the element size {size})",
            view.index()
        );
        return Err(bad(path, at, a, message));
    }
    Ok(stride)
}

/// Checks `count` (≥ 1) elements of `size` bytes, `stride` apart, from byte `offset` of `view`
/// lie inside the view and the view inside its buffer's declared length (in u128, so no declared
/// size can overflow the arithmetic); the end of the read within the view.
#[allow(clippy::too_many_arguments)]
fn declared_range(
    path: &Path,
    a: &gltf::Accessor,
    at: &str,
    view: &gltf::buffer::View,
    offset: usize,
    count: usize,
    size: usize,
    stride: usize,
) -> Result<u128, GltfError> {
    let v = view.index();
    let component = a.data_type().size();
    if offset % component != 0 {
        let message = format!("byteOffset {offset} is not a multiple of the component size {component}");
        return Err(bad(path, at, a, message));
    }
    // u128: offset, stride and count are each at most 2⁶⁴, so their sum of products fits.
    let end = offset as u128 + stride as u128 * (count as u128 - 1) + size as u128;
    if end > view.length() as u128 {
        let message = format!(
            "accessor reads bytes {offset}..{end} of buffer view /bufferViews/{v}, which has {} bytes (count {count}, stride {stride})",
            view.length()
        );
        return Err(bad(path, at, a, message));
    }
    let b = view.buffer().index();
    let view_end = view.offset() as u128 + view.length() as u128;
    if view_end > view.buffer().length() as u128 {
        let message = format!(
            "buffer view /bufferViews/{v} ends at byte {view_end}, past the end of buffer /buffers/{b} ({} bytes)",
            view.buffer().length()
        );
        return Err(bad(path, at, a, message));
    }
    Ok(end)
}

fn bad(path: &Path, at: &str, a: &gltf::Accessor, message: impl std::fmt::Display) -> GltfError {
    GltfError::at(path, at, format!("accessor /accessors/{}: {message}", a.index()))
}

impl Source<'_> {
    /// `count` VEC3 FLOAT elements (positions, normals); `at` is the pointer of the reference.
    pub fn vec3(&self, a: &gltf::Accessor, at: &str) -> Result<Vec<[f32; 3]>, ReadError> {
        if quantized(a) {
            return Err(ReadError::Unsupported(format!(
                "{at}: {} accessor (KHR_mesh_quantization); hadou reads FLOAT",
                type_name(a.data_type())
            )));
        }
        if a.dimensions() != Dimensions::Vec3 {
            let found = format!("{:?}", a.dimensions()).to_uppercase();
            return Err(self.bad(at, a, format!("expected a VEC3 accessor, found {found}")).into());
        }
        let decode = |e: &[u8]| [0, 4, 8].map(|o| f32::from_le_bytes([e[o], e[o + 1], e[o + 2], e[o + 3]]));
        self.read(a, at, 12, decode, [0.0; 3])
    }

    /// A vertex colour or texture coordinate: `dims` (the types glTF allows for it) of FLOAT, or
    /// of normalized UNSIGNED_BYTE or UNSIGNED_SHORT (c / 255, c / 65535), padded with `pad`
    /// past the accessor's components (a VEC3 colour gets alpha 1).
    pub fn unit_vec4(
        &self,
        a: &gltf::Accessor,
        at: &str,
        dims: &[Dimensions],
        pad: [f32; 4],
    ) -> Result<Vec<[f32; 4]>, ReadError> {
        let n = match a.dimensions() {
            Dimensions::Vec2 if dims.contains(&Dimensions::Vec2) => 2,
            Dimensions::Vec3 if dims.contains(&Dimensions::Vec3) => 3,
            Dimensions::Vec4 if dims.contains(&Dimensions::Vec4) => 4,
            d => {
                let expected: Vec<String> = dims.iter().map(|d| format!("{d:?}").to_uppercase()).collect();
                let found = format!("{d:?}").to_uppercase();
                let message = format!("expected a {} accessor, found {found}", expected.join(" or "));
                return Err(self.bad(at, a, message).into());
            }
        };
        let (component, scale) = match (a.data_type(), a.normalized()) {
            (DataType::F32, _) => (4, 0.0),
            (DataType::U8, true) => (1, 255.0),
            (DataType::U16, true) => (2, 65535.0),
            (t, normalized) => {
                let message = format!(
                    "expected FLOAT, or normalized UNSIGNED_BYTE or UNSIGNED_SHORT components, found {}{}",
                    if normalized { "normalized " } else { "" },
                    type_name(t)
                );
                return Err(self.bad(at, a, message).into());
            }
        };
        let decode = move |e: &[u8]| {
            let mut out = pad;
            for (k, c) in out.iter_mut().take(n).enumerate() {
                let b = &e[k * component..];
                *c = match component {
                    4 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                    // Exact division in f64, rounded once to f32.
                    _ => (unsigned(b, component) as f64 / scale) as f32,
                };
            }
            out
        };
        let mut zero = pad;
        zero[..n].fill(0.0);
        self.read(a, at, n * component, decode, zero)
    }

    /// Triangle indices: SCALAR UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT.
    pub fn indices(&self, a: &gltf::Accessor, at: &str) -> Result<Vec<u32>, ReadError> {
        if a.dimensions() != Dimensions::Scalar {
            let found = format!("{:?}", a.dimensions()).to_uppercase();
            return Err(self.bad(at, a, format!("expected a SCALAR index accessor, found {found}")).into());
        }
        let size = match a.data_type() {
            DataType::U8 => 1,
            DataType::U16 => 2,
            DataType::U32 => 4,
            t => {
                let message = format!(
                    "expected indices of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT, found {}",
                    type_name(t)
                );
                return Err(self.bad(at, a, message).into());
            }
        };
        self.read(a, at, size, move |e| unsigned(e, size), 0)
    }

    /// The accessor's elements decoded: from its buffer view (zeros without one), then the sparse
    /// substitutions, if any (glTF 2.0 §3.6.2.3).
    fn read<T: Clone>(
        &self,
        a: &gltf::Accessor,
        at: &str,
        size: usize,
        decode: impl Fn(&[u8]) -> T,
        zero: T,
    ) -> Result<Vec<T>, ReadError> {
        let count = a.count();
        if count == 0 {
            return Err(self.bad(at, a, "accessor has count 0 (expected at least one element)").into());
        }
        let mut out = match a.view() {
            Some(view) => {
                let stride = element_stride(self.path, at, a, &view)?;
                let bytes = self.range(a, at, &view, a.offset(), count, size, stride)?;
                (0..count).map(|i| decode(&bytes[i * stride..])).collect()
            }
            // All zeros but the sparse substitutions: no buffer bounds the count, so a limit does.
            None if count > MAX_ZEROS => {
                let message =
                    format!("{count} elements without a bufferView (hadou reads at most {MAX_ZEROS})");
                return Err(self.bad(at, a, message).into());
            }
            None => vec![zero; count],
        };
        if let Some(sparse) = a.sparse() {
            let n = sparse.count();
            if n == 0 || n > count {
                let message = format!("sparse count {n} (expected 1..={count}, the accessor's count)");
                return Err(self.bad(at, a, message).into());
            }
            let isize = match sparse.indices().index_type() {
                gltf::accessor::sparse::IndexType::U8 => 1,
                gltf::accessor::sparse::IndexType::U16 => 2,
                gltf::accessor::sparse::IndexType::U32 => 4,
            };
            let ind = sparse.indices();
            let idx = self.range(a, at, &ind.view(), ind.offset(), n, isize, isize)?;
            let val = sparse.values();
            let values = self.range(a, at, &val.view(), val.offset(), n, size, size)?;
            let mut previous = None;
            for k in 0..n {
                let i = unsigned(&idx[k * isize..], isize) as usize;
                if i >= count || previous.is_some_and(|p| i <= p) {
                    let message = format!(
                        "sparse index {k} is {i} (expected strictly increasing indices below the count {count})"
                    );
                    return Err(self.bad(at, a, message).into());
                }
                previous = Some(i);
                out[i] = decode(&values[k * size..]);
            }
        }
        Ok(out)
    }

    /// The bytes of `count` elements of `size` bytes, `stride` apart, from byte `offset` of `view`,
    /// after checking every bound (in u128, so no declared size can overflow the arithmetic).
    #[allow(clippy::too_many_arguments)]
    fn range<'b>(
        &'b self,
        a: &gltf::Accessor,
        at: &str,
        view: &gltf::buffer::View,
        offset: usize,
        count: usize,
        size: usize,
        stride: usize,
    ) -> Result<&'b [u8], ReadError> {
        let end = declared_range(self.path, a, at, view, offset, count, size, stride)?;
        let v = view.index();
        let b = view.buffer().index();
        let data = &self.buffers[b];
        let view_end = view.offset() as u128 + view.length() as u128;
        if view_end > data.len() as u128 {
            let message = format!(
                "buffer view /bufferViews/{v} ends at byte {view_end}, past the end of buffer /buffers/{b} ({} bytes)",
                view.buffer().length().min(data.len())
            );
            return Err(self.bad(at, a, message).into());
        }
        Ok(&data[view.offset() + offset..view.offset() + end as usize])
    }

    fn bad(&self, at: &str, a: &gltf::Accessor, message: impl std::fmt::Display) -> GltfError {
        bad(self.path, at, a, message)
    }
}

/// A little-endian unsigned integer of 1, 2 or 4 bytes.
fn unsigned(e: &[u8], size: usize) -> u32 {
    match size {
        1 => e[0] as u32,
        2 => u16::from_le_bytes([e[0], e[1]]) as u32,
        _ => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
    }
}

fn type_name(t: DataType) -> &'static str {
    match t {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    }
}
