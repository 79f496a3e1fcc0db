//! On-disk cache of thickness LUT bakes, keyed by mesh content and resolution.
//!
//! **Where.** `$HADOU_CACHE_DIR`, else `$XDG_CACHE_HOME/hadou`, else `$HOME/.cache/hadou`.
//!
//! **Key.** `mesh_hash`: FNV-1a 64 over the f32 position bits, the indices, their counts and
//! `FORMAT_VERSION` (normals do not change the solid, so they are not hashed). One file per
//! (mesh, resolution): `lut-{hash:016x}-r{res}.hlut`.
//!
//! **File.** A 92-byte little-endian header, then the payload:
//!
//! | offset | field |
//! |---|---|
//! | 0 | magic `HADOULUT` (8 bytes) |
//! | 8 | format version u32 (`FORMAT_VERSION`) |
//! | 12 | res u32 |
//! | 16 | mesh hash u64 |
//! | 24 | dims 3×u32 (voxels; corners are dims + 1 per axis) |
//! | 36 | origin 3×f64, voxel size f64 |
//! | 68 | payload length u64 |
//! | 76 | payload checksum u64 (FNV-1a 64 of the payload) |
//! | 84 | header checksum u64 (FNV-1a 64 of bytes 0..84) |
//!
//! Payload: the field, one i8 per corner (x fastest), Π(dims + 1) bytes; then τ, one byte per
//! cell (x fastest), Π dims bytes.
//!
//! **Safety.** Files are written to a temporary name in the same folder and renamed into place, so
//! a reader never sees half a file. On load, anything that does not match — a short file, a wrong
//! magic, version, hash, resolution, count or checksum, an id out of range — is logged with
//! `log::warn!` naming the file and treated as a miss: the table is rebuilt and the file replaced.
//! A cache that cannot be written is a warning too; the bake is still returned.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::DVec3;

use super::thickness_lut::{
    bake, BakeError, BakeOptions, BakeStats, ThicknessLut, FIELD_LEVELS, TAU_MAX_STEPS,
};
use super::voxelize::grid_layout;
use crate::scene::mesh::Mesh;

pub const MAGIC: [u8; 8] = *b"HADOULUT";
/// Bump when the file layout or the meaning of any stored value changes.
pub const FORMAT_VERSION: u32 = 3;
const HEADER_LEN: usize = 92;

/// FNV-1a 64.
#[derive(Clone, Copy, Debug)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Fnv64(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    pub fn finish(&self) -> u64 {
        self.0
    }
}

pub(crate) fn fnv(bytes: &[u8]) -> u64 {
    let mut h = Fnv64::default();
    h.write(bytes);
    h.finish()
}

/// The content hash of a mesh's solid: positions (f32 bits) and indices.
pub fn mesh_hash(mesh: &Mesh) -> u64 {
    let mut h = Fnv64::default();
    h.write(&FORMAT_VERSION.to_le_bytes());
    h.write(&(mesh.positions.len() as u64).to_le_bytes());
    for p in &mesh.positions {
        for c in p {
            // +0.0 for −0.0: the same solid.
            h.write(&(c + 0.0).to_bits().to_le_bytes());
        }
    }
    h.write(&(mesh.indices.len() as u64).to_le_bytes());
    for i in &mesh.indices {
        h.write(&i.to_le_bytes());
    }
    h.finish()
}

/// The default cache folder from the environment (see the module documentation).
pub fn default_cache_dir() -> Option<PathBuf> {
    let var = |name| std::env::var_os(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    if let Some(dir) = var("HADOU_CACHE_DIR") {
        return Some(dir);
    }
    if let Some(dir) = var("XDG_CACHE_HOME") {
        return Some(dir.join("hadou"));
    }
    var("HOME").map(|home| home.join(".cache").join("hadou"))
}

/// How a request was served.
#[derive(Clone, Debug, PartialEq)]
pub enum CacheOutcome {
    /// Read from this file.
    Hit(PathBuf),
    /// No file yet: baked and written.
    Miss(PathBuf),
    /// A file was there but refused (the reason); baked and rewritten.
    Rebuilt { path: PathBuf, reason: String },
}

/// A bake served through the cache.
#[derive(Clone, Debug)]
pub struct CachedBake {
    pub lut: ThicknessLut,
    pub outcome: CacheOutcome,
    /// Stats of the bake; `None` for a hit.
    pub stats: Option<BakeStats>,
    /// Wall time of the whole request (load or bake + store).
    pub seconds: f64,
}

/// A folder of cached bakes.
#[derive(Clone, Debug)]
pub struct BakeCache {
    dir: PathBuf,
}

impl BakeCache {
    pub fn new(dir: impl Into<PathBuf>) -> BakeCache {
        BakeCache { dir: dir.into() }
    }

    /// The cache in `default_cache_dir()`; `None` when no folder can be named.
    pub fn from_env() -> Option<BakeCache> {
        default_cache_dir().map(BakeCache::new)
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The file a bake of `mesh` at `res` lives in.
    pub fn path_for(&self, mesh: &Mesh, res: u32) -> PathBuf {
        self.dir.join(file_name(mesh_hash(mesh), res))
    }

    /// The cached table of `mesh` at `res`, or why there is none usable. `Ok(None)`: no file.
    pub fn load(&self, mesh: &Mesh, res: u32) -> Result<Option<ThicknessLut>, String> {
        let path = self.path_for(mesh, res);
        let meta = match std::fs::metadata(&path) {
            Ok(meta) => meta,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(format!("cannot read it: {e}")),
        };
        // Checked before opening: a FIFO would block, a device (a link to /dev/zero) never ends.
        if !meta.is_file() {
            return Err("not a regular file".into());
        }
        let expect = Expect { hash: mesh_hash(mesh), res, mesh };
        read_bounded(&path, &expect).map(Some)
    }

    /// Writes `lut` (a bake of `mesh`) atomically: a temporary file, then a rename.
    pub fn store(&self, mesh: &Mesh, lut: &ThicknessLut) -> std::io::Result<PathBuf> {
        std::fs::create_dir_all(&self.dir)?;
        let path = self.path_for(mesh, lut.res);
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        crate::output::remove_stale_temps(&self.dir, &name);
        let bytes = encode(lut, mesh_hash(mesh));
        write_atomic(&path, &bytes)?;
        Ok(path)
    }

    /// The cached table if it is valid, else a fresh bake (stored for next time).
    pub fn get_or_bake(
        &self,
        mesh: &Mesh,
        res: u32,
        options: &BakeOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<CachedBake, BakeError> {
        let start = Instant::now();
        let path = self.path_for(mesh, res);
        let refused = match self.load(mesh, res) {
            Ok(Some(lut)) => {
                let seconds = start.elapsed().as_secs_f64();
                return Ok(CachedBake { lut, outcome: CacheOutcome::Hit(path), stats: None, seconds });
            }
            Ok(None) => None,
            Err(reason) => {
                log::warn!("thickness LUT cache {}: {reason}; rebuilding it", path.display());
                Some(reason)
            }
        };
        let (lut, stats) = bake(mesh, res, options, progress)?;
        if let Err(e) = self.store(mesh, &lut) {
            log::warn!("thickness LUT cache {}: cannot write it: {e}", path.display());
        }
        let outcome = match refused {
            Some(reason) => CacheOutcome::Rebuilt { path, reason },
            None => CacheOutcome::Miss(path),
        };
        Ok(CachedBake { lut, outcome, stats: Some(stats), seconds: start.elapsed().as_secs_f64() })
    }
}

fn file_name(hash: u64, res: u32) -> String {
    format!("lut-{hash:016x}-r{res}.hlut")
}

pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("lut");
    let tmp = path.with_file_name(format!(".{name}.{}.{n}.tmp", std::process::id()));
    // Registered, so SIGINT/SIGTERM during a bake's store removes it (output::interrupt).
    crate::output::interrupt::write_through_temporary(&tmp, bytes, path)
}

/// Serializes `lut` (see the module documentation for the layout).
pub fn encode(lut: &ThicknessLut, hash: u64) -> Vec<u8> {
    let mut payload: Vec<u8> = lut.field.iter().map(|&q| q as u8).collect();
    payload.extend_from_slice(&lut.tau);
    let mut out = Vec::with_capacity(HEADER_LEN + payload.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&lut.res.to_le_bytes());
    out.extend_from_slice(&hash.to_le_bytes());
    for d in lut.dims {
        out.extend_from_slice(&d.to_le_bytes());
    }
    for f in [lut.origin.x, lut.origin.y, lut.origin.z, lut.voxel_size] {
        out.extend_from_slice(&f.to_le_bytes());
    }
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&fnv(&payload).to_le_bytes());
    let header_sum = fnv(&out);
    out.extend_from_slice(&header_sum.to_le_bytes());
    debug_assert_eq!(out.len(), HEADER_LEN);
    out.extend_from_slice(&payload);
    out
}

/// What a file must say to be the bake asked for.
struct Expect<'a> {
    hash: u64,
    res: u32,
    mesh: &'a Mesh,
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let end = self.at + N;
        let chunk = self
            .bytes
            .get(self.at..end)
            .ok_or_else(|| format!("truncated: {} bytes, needed more than {}", self.bytes.len(), self.at))?;
        self.at = end;
        Ok(chunk.try_into().unwrap_or([0; N]))
    }
    fn u32(&mut self) -> Result<u32, String> {
        self.take::<4>().map(u32::from_le_bytes)
    }
    fn u64(&mut self) -> Result<u64, String> {
        self.take::<8>().map(u64::from_le_bytes)
    }
    fn f64(&mut self) -> Result<f64, String> {
        self.take::<8>().map(f64::from_le_bytes)
    }
}

fn check<T: PartialEq + std::fmt::Debug>(what: &str, found: T, expected: T) -> Result<(), String> {
    if found == expected {
        Ok(())
    } else {
        Err(format!("{what} is {found:?}, expected {expected:?}"))
    }
}

/// Reads and decodes a cache file, never more bytes than the header and the payload the
/// request implies (plus one, to see a file that is too long).
fn read_bounded(path: &Path, expect: &Expect) -> Result<ThicknessLut, String> {
    use std::io::Read;
    let mut file = std::fs::File::open(path).map_err(|e| format!("cannot read it: {e}"))?;
    let mut read = |limit: u64| -> Result<Vec<u8>, String> {
        let mut bytes = Vec::new();
        (&mut file).take(limit).read_to_end(&mut bytes).map_err(|e| format!("cannot read it: {e}"))?;
        Ok(bytes)
    };
    let head = read(HEADER_LEN as u64)?;
    let header = decode_header(&head, expect)?;
    let payload = read(header.payload_len.saturating_add(1))?;
    decode_payload(&header, &payload, expect)
}

/// Parses and validates a cache file against what was asked for (the tests' whole-buffer form).
#[cfg(test)]
fn decode(bytes: &[u8], expect: &Expect) -> Result<ThicknessLut, String> {
    let header = decode_header(bytes, expect)?;
    decode_payload(&header, bytes.get(HEADER_LEN..).unwrap_or_default(), expect)
}

/// The header's fields, checked against the request; `payload_len` is the length the request
/// implies (the header must agree).
#[derive(Clone, Copy)]
struct Header {
    dims: [u32; 3],
    origin: DVec3,
    voxel_size: f64,
    payload_len: u64,
    payload_sum: u64,
}

fn decode_header(bytes: &[u8], expect: &Expect) -> Result<Header, String> {
    let mut r = Reader { bytes, at: 0 };
    check("magic", r.take::<8>()?, MAGIC)?;
    check("format version", r.u32()?, FORMAT_VERSION)?;
    let Some(header) = bytes.get(..HEADER_LEN) else {
        return Err(format!("truncated: {} bytes, shorter than the {HEADER_LEN}-byte header", bytes.len()));
    };
    let (fields, stored) = header.split_at(HEADER_LEN - 8);
    if stored != fnv(fields).to_le_bytes() {
        return Err("header checksum does not match (corrupt file)".into());
    }
    check("resolution", r.u32()?, expect.res)?;
    check("mesh hash", r.u64()?, expect.hash)?;
    let dims = [r.u32()?, r.u32()?, r.u32()?];
    let origin = DVec3::new(r.f64()?, r.f64()?, r.f64()?);
    let voxel_size = r.f64()?;
    let payload_len = r.u64()?;
    let payload_sum = r.u64()?;
    r.u64()?; // header checksum, checked above
              // The grid is a function of the mesh and res: it must be the one a bake would make now.
    let (want_dims, want_origin, want_h) = grid_layout(expect.mesh, expect.res).map_err(|e| e.to_string())?;
    check("grid dims", dims, want_dims)?;
    check("grid origin", origin, want_origin)?;
    check("voxel size", voxel_size, want_h)?;
    let corners: u64 = dims.iter().map(|&d| d as u64 + 1).product();
    let cells: u64 = dims.iter().map(|&d| d as u64).product();
    check("payload length", payload_len, corners + cells)?;
    Ok(Header { dims, origin, voxel_size, payload_len, payload_sum })
}

fn decode_payload(header: &Header, payload: &[u8], expect: &Expect) -> Result<ThicknessLut, String> {
    let Header { dims, origin, voxel_size, payload_len, payload_sum } = *header;
    check("file length", payload.len() as u64, payload_len)?;
    if fnv(payload) != payload_sum {
        return Err("payload checksum does not match (corrupt file)".into());
    }
    let corners: usize = dims.iter().map(|&d| d as usize + 1).product();
    let (field_bytes, tau) = payload.split_at(corners);
    let field: Vec<i8> = field_bytes.iter().map(|&b| b as i8).collect();
    if let Some(k) = field.iter().position(|&q| (q as f64).abs() > FIELD_LEVELS) {
        return Err(format!("corner {k} holds {}, outside ±{FIELD_LEVELS}", field[k]));
    }
    if let Some(k) = tau.iter().position(|&t| t > TAU_MAX_STEPS) {
        return Err(format!("cell {k} has τ {} steps, above {TAU_MAX_STEPS}", tau[k]));
    }
    Ok(ThicknessLut { res: expect.res, dims, origin, voxel_size, field, tau: tau.to_vec() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;

    #[test]
    fn fnv_matches_the_reference_vectors() {
        // From the FNV reference (draft-eastlake-fnv): "" and "a".
        assert_eq!(fnv(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn hash_sees_positions_and_indices_but_not_normals() {
        let a = procedural::cube(1.0).unwrap();
        let mut b = a.clone();
        b.normals[0] = [1.0, 0.0, 0.0];
        assert_eq!(mesh_hash(&a), mesh_hash(&b));
        b.positions[0][0] += 1e-6;
        assert_ne!(mesh_hash(&a), mesh_hash(&b));
        let mut c = a.clone();
        c.indices.swap(0, 1);
        assert_ne!(mesh_hash(&a), mesh_hash(&c));
    }

    #[test]
    fn round_trip_and_every_corruption_is_refused() {
        let mesh = procedural::cube(1.0).unwrap();
        let options = BakeOptions { threads: 1 };
        let (lut, _) = bake(&mesh, 6, &options, &|_, _| {}).unwrap();
        let hash = mesh_hash(&mesh);
        let bytes = encode(&lut, hash);
        let expect = Expect { hash, res: 6, mesh: &mesh };
        assert_eq!(decode(&bytes, &expect).unwrap(), lut);
        // Every truncation and every single flipped bit anywhere in the header, and a sample of
        // the payload, is refused.
        for len in 0..bytes.len() {
            assert!(decode(&bytes[..len], &expect).is_err(), "truncated to {len}");
        }
        for at in (0..HEADER_LEN).chain((HEADER_LEN..bytes.len()).step_by(7)) {
            let mut bad = bytes.clone();
            bad[at] ^= 0x10;
            assert!(decode(&bad, &expect).is_err(), "flipped byte {at}");
        }
        let other = procedural::cube(2.0).unwrap();
        let wrong = Expect { hash: mesh_hash(&other), res: 6, mesh: &other };
        assert!(decode(&bytes, &wrong).unwrap_err().contains("mesh hash"));
        let wrong_res = Expect { res: 7, ..expect };
        assert!(decode(&bytes, &wrong_res).unwrap_err().contains("resolution"));
    }

    /// A FIFO, a link to /dev/zero and an over-long file where a cache file should be: refused
    /// without blocking or reading without end, then rebuilt.
    #[test]
    fn special_and_overlong_files_are_refused_then_rebuilt() {
        let dir = std::env::temp_dir().join(format!("hadou-cache-special-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let cache = BakeCache::new(&dir);
        let mesh = procedural::cube(1.0).unwrap();
        let options = BakeOptions { threads: 1 };
        let path = cache.path_for(&mesh, 6);
        let (lut, _) = bake(&mesh, 6, &options, &|_, _| {}).unwrap();
        let good = encode(&lut, mesh_hash(&mesh));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = || assert!(std::process::Command::new("mkfifo").arg(&path).status().unwrap().success());
        let zero = || std::os::unix::fs::symlink("/dev/zero", &path).unwrap();
        let long = || std::fs::write(&path, [good.as_slice(), &[0]].concat()).unwrap();
        for (make, says) in [
            (&fifo as &dyn Fn(), "not a regular file"),
            (&zero as &dyn Fn(), "not a regular file"),
            (&long as &dyn Fn(), "file length"),
        ] {
            let _ = std::fs::remove_file(&path);
            make();
            // On a thread, so a regression fails the test instead of hanging it.
            let (send, receive) = std::sync::mpsc::channel();
            let (c, m, o) = (cache.clone(), mesh.clone(), options);
            std::thread::spawn(move || {
                let _ = send.send(c.get_or_bake(&m, 6, &o, &|_, _| {}).map(|g| g.outcome));
            });
            let outcome = receive.recv_timeout(std::time::Duration::from_secs(60)).expect("blocked");
            match outcome.unwrap() {
                CacheOutcome::Rebuilt { reason, .. } => assert!(reason.contains(says), "{reason}"),
                other => panic!("{says}: {other:?}"),
            }
            assert_eq!(std::fs::read(&path).unwrap(), good, "rebuilt as a regular file");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
