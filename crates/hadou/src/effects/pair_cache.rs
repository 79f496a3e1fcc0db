//! The pair tables (`effects::thickness_pairs`) in the bake cache: the same folder, key
//! (`bake_cache::mesh_hash`), atomic writes and outcomes as the fields, a file of their own:
//! `pairs-{hash:016x}-r{res}.hpair`.
//!
//! **File.** Header, little-endian: magic `HADOUPRS`, format version u32 (`PAIRS_VERSION`), res
//! u32, mesh hash u64, dims 3×u32, origin 3×f64, voxel size f64, max thickness f64, surface voxels
//! N u32, payload length u64, payload checksum u64, then the FNV-1a 64 of all of that. Payload: N
//! words of surface-voxel coordinates (`PairTable::coordinate_words`), one u32 per grid voxel
//! (`lookup`), then the N×N table bytes. Anything that does not match what the request implies (the
//! grid is recomputed from the mesh) is a miss with its reason, as for the fields.

use std::time::Instant;

use glam::DVec3;

use super::bake_cache::{fnv, mesh_hash, write_atomic, BakeCache, CacheOutcome};
use super::thickness_pairs::{
    bake, PairOptions, PairStats, PairTable, PairsError, SurfaceVoxels, NO_SURFACE,
};
use super::voxelize::grid_layout;
use crate::scene::mesh::Mesh;

pub const PAIRS_MAGIC: [u8; 8] = *b"HADOUPRS";
/// Bump when the file layout or the meaning of any stored value changes.
pub const PAIRS_VERSION: u32 = 1;
const HEADER_LEN: usize = 8 + 4 + 4 + 8 + 12 + 24 + 8 + 8 + 4 + 8 + 8 + 8;

/// A pair bake served through the cache.
#[derive(Clone, Debug)]
pub struct CachedPairs {
    pub table: PairTable,
    pub outcome: CacheOutcome,
    /// Stats of the bake; `None` for a hit.
    pub stats: Option<PairStats>,
    /// Wall time of the whole request.
    pub seconds: f64,
}

impl BakeCache {
    /// The file the pair table of `mesh` at `res` lives in.
    pub fn pairs_path_for(&self, mesh: &Mesh, res: u32) -> std::path::PathBuf {
        self.dir().join(format!("pairs-{:016x}-r{res}.hpair", mesh_hash(mesh)))
    }

    /// Writes `table` (a bake of `mesh`) atomically.
    pub fn store_pairs(&self, mesh: &Mesh, table: &PairTable) -> std::io::Result<std::path::PathBuf> {
        std::fs::create_dir_all(self.dir())?;
        let path = self.pairs_path_for(mesh, table.voxels.res);
        write_atomic(&path, &encode(table, mesh_hash(mesh)))?;
        Ok(path)
    }

    /// The cached pair table if it is valid (and within `options`' limits), else a fresh bake,
    /// stored for next time.
    pub fn get_or_bake_pairs(
        &self,
        mesh: &Mesh,
        res: u32,
        options: &PairOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<CachedPairs, PairsError> {
        let start = Instant::now();
        let path = self.pairs_path_for(mesh, res);
        let refused = match read(&path, mesh, res) {
            Ok(Some(table)) => {
                // A table cached under larger limits is refused here as a bake would be.
                table.voxels.check_limits(options)?;
                let seconds = start.elapsed().as_secs_f64();
                return Ok(CachedPairs { table, outcome: CacheOutcome::Hit(path), stats: None, seconds });
            }
            Ok(None) => None,
            Err(reason) => {
                log::warn!("thickness pair cache {}: {reason}; rebuilding it", path.display());
                Some(reason)
            }
        };
        let (table, stats) = bake(mesh, res, options, progress)?;
        if let Err(e) = self.store_pairs(mesh, &table) {
            log::warn!("thickness pair cache {}: cannot write it: {e}", path.display());
        }
        let outcome = match refused {
            Some(reason) => CacheOutcome::Rebuilt { path, reason },
            None => CacheOutcome::Miss(path),
        };
        Ok(CachedPairs { table, outcome, stats: Some(stats), seconds: start.elapsed().as_secs_f64() })
    }
}

fn read(path: &std::path::Path, mesh: &Mesh, res: u32) -> Result<Option<PairTable>, String> {
    let meta = match std::fs::metadata(path) {
        Ok(meta) => meta,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("cannot read it: {e}")),
    };
    // Checked before opening: a FIFO would block, a device never ends.
    if !meta.is_file() {
        return Err("not a regular file".into());
    }
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read it: {e}"))?;
    decode(&bytes, mesh, res).map(Some)
}

/// Serializes `table` (see the module documentation).
pub fn encode(table: &PairTable, hash: u64) -> Vec<u8> {
    let v = &table.voxels;
    let mut payload: Vec<u8> = Vec::new();
    for w in table.coordinate_words().iter().chain(&v.lookup) {
        payload.extend_from_slice(&w.to_le_bytes());
    }
    payload.extend_from_slice(&table.table);
    let mut out = Vec::with_capacity(HEADER_LEN + payload.len());
    out.extend_from_slice(&PAIRS_MAGIC);
    out.extend_from_slice(&PAIRS_VERSION.to_le_bytes());
    out.extend_from_slice(&v.res.to_le_bytes());
    out.extend_from_slice(&hash.to_le_bytes());
    v.dims.iter().for_each(|d| out.extend_from_slice(&d.to_le_bytes()));
    for f in [v.origin.x, v.origin.y, v.origin.z, v.voxel_size, table.max_thickness] {
        out.extend_from_slice(&f.to_le_bytes());
    }
    out.extend_from_slice(&(v.count() as u32).to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&fnv(&payload).to_le_bytes());
    let sum = fnv(&out);
    out.extend_from_slice(&sum.to_le_bytes());
    debug_assert_eq!(out.len(), HEADER_LEN);
    out.extend_from_slice(&payload);
    out
}

fn take<'a>(bytes: &'a [u8], at: &mut usize, n: usize) -> Result<&'a [u8], String> {
    let chunk = bytes.get(*at..*at + n).ok_or_else(|| format!("truncated: {} bytes", bytes.len()))?;
    *at += n;
    Ok(chunk)
}

fn word(bytes: &[u8], at: &mut usize) -> Result<u32, String> {
    Ok(u32::from_le_bytes(take(bytes, at, 4)?.try_into().unwrap_or_default()))
}

fn long(bytes: &[u8], at: &mut usize) -> Result<u64, String> {
    Ok(u64::from_le_bytes(take(bytes, at, 8)?.try_into().unwrap_or_default()))
}

fn float(bytes: &[u8], at: &mut usize) -> Result<f64, String> {
    long(bytes, at).map(f64::from_bits)
}

fn check<T: PartialEq + std::fmt::Debug>(what: &str, found: T, expected: T) -> Result<(), String> {
    if found == expected {
        Ok(())
    } else {
        Err(format!("{what} is {found:?}, expected {expected:?}"))
    }
}

/// Parses and validates a cache file against the request.
pub fn decode(bytes: &[u8], mesh: &Mesh, res: u32) -> Result<PairTable, String> {
    let at = &mut 0;
    check("magic", take(bytes, at, 8)?, &PAIRS_MAGIC[..])?;
    check("format version", word(bytes, at)?, PAIRS_VERSION)?;
    let header = bytes.get(..HEADER_LEN).ok_or("truncated header")?;
    if header[HEADER_LEN - 8..] != fnv(&header[..HEADER_LEN - 8]).to_le_bytes() {
        return Err("header checksum does not match (corrupt file)".into());
    }
    check("resolution", word(bytes, at)?, res)?;
    check("mesh hash", long(bytes, at)?, mesh_hash(mesh))?;
    let dims = [word(bytes, at)?, word(bytes, at)?, word(bytes, at)?];
    let origin = DVec3::new(float(bytes, at)?, float(bytes, at)?, float(bytes, at)?);
    let voxel_size = float(bytes, at)?;
    let max_thickness = float(bytes, at)?;
    let n = word(bytes, at)? as usize;
    let payload_len = long(bytes, at)?;
    let payload_sum = long(bytes, at)?;
    let (want_dims, want_origin, want_h) = grid_layout(mesh, res).map_err(|e| e.to_string())?;
    check("grid dims", dims, want_dims)?;
    check("grid origin", origin, want_origin)?;
    check("voxel size", voxel_size, want_h)?;
    if !(max_thickness.is_finite() && max_thickness > 0.0) {
        return Err(format!("max thickness {max_thickness} is not a positive number"));
    }
    let voxels: usize = dims.iter().map(|&d| d as usize).product();
    check("payload length", payload_len, (4 * (n + voxels) + n * n) as u64)?;
    let payload = &bytes[HEADER_LEN..];
    check("file length", payload.len() as u64, payload_len)?;
    if fnv(payload) != payload_sum {
        return Err("payload checksum does not match (corrupt file)".into());
    }
    let words: Vec<u32> = payload[..4 * (n + voxels)]
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let (coords, lookup) = words.split_at(n);
    let surface: Vec<[u32; 3]> =
        coords.iter().map(|&w| [w & 1023, (w >> 10) & 1023, (w >> 20) & 1023]).collect();
    if let Some(k) = surface.iter().position(|c| (0..3).any(|a| c[a] >= dims[a])) {
        return Err(format!("surface voxel {k} at {:?} is outside the grid {dims:?}", surface[k]));
    }
    if let Some(k) = lookup.iter().position(|&s| s != NO_SURFACE && s as usize >= n) {
        return Err(format!("voxel {k} names surface voxel {}, of {n}", lookup[k]));
    }
    let voxels = SurfaceVoxels { res, dims, origin, voxel_size, surface, lookup: lookup.to_vec() };
    Ok(PairTable { voxels, max_thickness, table: payload[4 * words.len()..].to_vec() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;

    #[test]
    fn round_trip_and_corruption_is_refused() {
        let mesh = procedural::cube(1.0).unwrap();
        let (table, _) = bake(&mesh, 5, &PairOptions::default(), &|_, _| {}).unwrap();
        let bytes = encode(&table, mesh_hash(&mesh));
        assert_eq!(decode(&bytes, &mesh, 5).unwrap(), table);
        for len in 0..bytes.len() {
            assert!(decode(&bytes[..len], &mesh, 5).is_err(), "truncated to {len}");
        }
        for at in (0..HEADER_LEN).chain((HEADER_LEN..bytes.len()).step_by(5)) {
            let mut bad = bytes.clone();
            bad[at] ^= 0x10;
            assert!(decode(&bad, &mesh, 5).is_err(), "flipped byte {at}");
        }
        assert!(decode(&bytes, &mesh, 6).unwrap_err().contains("resolution"));
    }

    #[test]
    fn a_miss_then_a_hit() {
        let dir = std::env::temp_dir().join(format!("hadou-pair-cache-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let cache = BakeCache::new(&dir);
        let mesh = procedural::cube(1.0).unwrap();
        let options = PairOptions::default();
        let first = cache.get_or_bake_pairs(&mesh, 5, &options, &|_, _| {}).unwrap();
        assert!(matches!(first.outcome, CacheOutcome::Miss(_)));
        let second = cache.get_or_bake_pairs(&mesh, 5, &options, &|_, _| {}).unwrap();
        assert!(matches!(second.outcome, CacheOutcome::Hit(_)) && second.table == first.table);
        // Cached, but above tighter limits: refused like a bake.
        let tight = PairOptions { memory_budget: 10, ..options };
        assert!(cache.get_or_bake_pairs(&mesh, 5, &tight, &|_, _| {}).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
