//! Reading accessors with every range checked: the accessor inside its buffer view, the view
//! inside its buffer, strides and alignment as glTF requires. Problems name the place that used
//! the accessor (a primitive's attribute or indices) and the accessor itself.

use std::path::Path;

use gltf::accessor::{DataType, Dimensions};

use super::error::GltfError;

/// Why an accessor could not be read: a broken file, or a valid encoding hadou does not read.
pub(super) enum ReadError {
    /// The file is malformed here.
    Bad(GltfError),
    /// Valid glTF hadou does not read (sparse or quantized accessors): the primitive is skipped
    /// and listed as ignored.
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

impl Source<'_> {
    /// `count` VEC3 FLOAT elements (positions, normals); `at` is the pointer of the reference.
    pub fn vec3(&self, a: &gltf::Accessor, at: &str) -> Result<Vec<[f32; 3]>, ReadError> {
        if a.normalized() || a.data_type() != DataType::F32 {
            return Err(ReadError::Unsupported(format!(
                "{at}: {} accessor (KHR_mesh_quantization); hadou reads FLOAT",
                type_name(a.data_type())
            )));
        }
        if a.dimensions() != Dimensions::Vec3 {
            let found = format!("{:?}", a.dimensions()).to_uppercase();
            return Err(self.bad(at, a, format!("expected a VEC3 accessor, found {found}")).into());
        }
        let (bytes, stride) = self.elements(a, at, 12)?;
        Ok((0..a.count())
            .map(|i| {
                let e = &bytes[i * stride..];
                [0, 4, 8].map(|o| f32::from_le_bytes([e[o], e[o + 1], e[o + 2], e[o + 3]]))
            })
            .collect())
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
        let (bytes, stride) = self.elements(a, at, size)?;
        Ok((0..a.count())
            .map(|i| {
                let e = &bytes[i * stride..];
                match size {
                    1 => e[0] as u32,
                    2 => u16::from_le_bytes([e[0], e[1]]) as u32,
                    _ => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
                }
            })
            .collect())
    }

    /// The bytes from the accessor's first element to the end of its last, and the stride, after
    /// checking every bound (in u64, so no declared size can overflow the arithmetic).
    fn elements<'b>(
        &'b self,
        a: &gltf::Accessor,
        at: &str,
        size: usize,
    ) -> Result<(&'b [u8], usize), ReadError> {
        if a.sparse().is_some() {
            return Err(ReadError::Unsupported(format!("{at}: sparse accessor /accessors/{}", a.index())));
        }
        let Some(view) = a.view() else {
            return Err(self.bad(at, a, "accessor has no bufferView (expected one)").into());
        };
        let v = view.index();
        let stride = view.stride().unwrap_or(size);
        if stride < size || stride % a.data_type().size() != 0 {
            let message = format!("buffer view /bufferViews/{v} has byteStride {stride} (expected a multiple of {} and at least the element size {size})", a.data_type().size());
            return Err(self.bad(at, a, message).into());
        }
        if a.offset() % a.data_type().size() != 0 {
            let message = format!(
                "byteOffset {} is not a multiple of the component size {}",
                a.offset(),
                a.data_type().size()
            );
            return Err(self.bad(at, a, message).into());
        }
        if a.count() == 0 {
            return Err(self.bad(at, a, "accessor has count 0 (expected at least one element)").into());
        }
        let (count, stride64, offset) = (a.count() as u64, stride as u64, a.offset() as u64);
        let end = offset + stride64 * (count - 1) + size as u64;
        if end > view.length() as u64 {
            let message = format!(
                "accessor reads bytes {offset}..{end} of buffer view /bufferViews/{v}, which has {} bytes (count {}, stride {stride})",
                view.length(),
                a.count()
            );
            return Err(self.bad(at, a, message).into());
        }
        let b = view.buffer().index();
        let data = &self.buffers[b];
        let view_end = view.offset() as u64 + view.length() as u64;
        if view_end > data.len() as u64 || view_end > view.buffer().length() as u64 {
            let message = format!(
                "buffer view /bufferViews/{v} ends at byte {view_end}, past the end of buffer /buffers/{b} ({} bytes)",
                view.buffer().length().min(data.len())
            );
            return Err(self.bad(at, a, message).into());
        }
        let start = view.offset() + a.offset();
        Ok((&data[start..view.offset() + end as usize], stride))
    }

    fn bad(&self, at: &str, a: &gltf::Accessor, message: impl std::fmt::Display) -> GltfError {
        GltfError::at(self.path, at, format!("accessor /accessors/{}: {message}", a.index()))
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
