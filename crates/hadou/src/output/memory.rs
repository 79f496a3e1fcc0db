//! Host buffers for encoding outputs whose size the user chooses (`--size 16384x16384`): every
//! large allocation is fallible, so running out of memory is an `error:` naming the output, never
//! an abort.

use std::io::{Error, ErrorKind, Seek, SeekFrom, Write};

/// A `Vec` of `len` copies of `fill`, or None when the host cannot hold it.
pub(crate) fn try_filled<T: Clone>(len: usize, fill: T) -> Option<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(len).ok()?;
    v.resize(len, fill);
    Some(v)
}

/// An in-memory `Write + Seek` target (what the encoders write to) whose growth is fallible: a
/// failed reservation is an `io::Error` of kind `OutOfMemory`, which the encoders pass on.
#[derive(Default)]
pub(crate) struct FallibleCursor {
    bytes: Vec<u8>,
    pos: usize,
}

impl FallibleCursor {
    /// Starts with room for `capacity` bytes (the expected size), itself fallible.
    pub(crate) fn with_capacity(capacity: usize) -> std::io::Result<FallibleCursor> {
        let mut c = FallibleCursor::default();
        c.bytes.try_reserve_exact(capacity).map_err(|e| Error::new(ErrorKind::OutOfMemory, e))?;
        Ok(c)
    }

    pub(crate) fn into_inner(self) -> Vec<u8> {
        self.bytes
    }
}

impl Write for FallibleCursor {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let end = self.pos.checked_add(buf.len()).ok_or_else(|| Error::from(ErrorKind::OutOfMemory))?;
        if end > self.bytes.len() {
            // Doubling, as Vec does, but asked for first.
            let want = end.max(self.bytes.len().saturating_mul(2)) - self.bytes.len();
            if self.bytes.try_reserve(want).is_err() {
                self.bytes
                    .try_reserve_exact(end - self.bytes.len())
                    .map_err(|e| Error::new(ErrorKind::OutOfMemory, e))?;
            }
            self.bytes.resize(end, 0);
        }
        self.bytes[self.pos..end].copy_from_slice(buf);
        self.pos = end;
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Seek for FallibleCursor {
    fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
        let base = match to {
            SeekFrom::Start(p) => Some(p as i128),
            SeekFrom::End(d) => Some(self.bytes.len() as i128 + d as i128),
            SeekFrom::Current(d) => Some(self.pos as i128 + d as i128),
        };
        match base {
            Some(p) if p >= 0 && p <= usize::MAX as i128 => {
                self.pos = p as usize;
                Ok(p as u64)
            }
            _ => Err(Error::new(ErrorKind::InvalidInput, "seek before the start")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_and_seeks_like_a_cursor() {
        let mut c = FallibleCursor::with_capacity(2).unwrap();
        c.write_all(b"hello").unwrap();
        c.seek(SeekFrom::Start(1)).unwrap();
        c.write_all(b"EL").unwrap();
        c.seek(SeekFrom::End(2)).unwrap();
        c.write_all(b"!").unwrap();
        assert_eq!(c.into_inner(), b"hELlo\0\0!");
    }

    #[test]
    fn sizes_the_host_cannot_hold_are_errors() {
        // More than isize::MAX bytes: refused at once, nothing allocated.
        assert!(try_filled(usize::MAX / 2, 0u32).is_none());
        assert!(FallibleCursor::with_capacity(usize::MAX / 2).is_err());
        let mut c = FallibleCursor::default();
        c.seek(SeekFrom::Start(u64::MAX / 2)).unwrap();
        assert_eq!(c.write(b"x").unwrap_err().kind(), ErrorKind::OutOfMemory);
    }
}
