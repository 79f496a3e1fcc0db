//! A mesh primitive → a hadou `Mesh`: positions, indices (any of the three triangle modes, made a
//! list), normals read or, when absent, flat normals as glTF asks (each triangle gets its own
//! three vertices and its face normal).

use std::path::Path;

use glam::DVec3;
use gltf::mesh::{Mode, Semantic};

use super::accessor::{self, ReadError, Source};
use super::error::GltfError;
use crate::scene::mesh::{Mesh, VertexAttributes};

/// The environment variable that overrides `Budget`'s defaults: `vertices=N,indices=N,nodes=N,
/// instances=N,steps=N`, any subset. An environment variable rather than a CLI flag or an
/// `ImportOptions` field alone because it reaches every way a glTF file is loaded — `render`,
/// `test`, `profile`, `view`, `bake`, a TOML scene's `[[gltf]]`, `load_scene` in a game — none of
/// which has to pass it along, and a CI job sets it once.
pub(super) const BUDGET_VAR: &str = "HADOU_GLTF_BUDGET";

/// What one glTF file may cost, checked from the counts it declares before anything is decoded
/// or allocated (docs/scene-format.md, "glTF budgets"). Meshes are counted once per use (per node
/// that draws them): that is what is drawn, and per use is what a file of many nodes sharing one
/// accessor costs. The defaults are far above real assets and keep the worst accepted file at
/// about 1 GiB of host memory at the peak (the bytes given below; indices are held up to three
/// times while a primitive becomes a triangle list) and seconds of decoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Budget {
    /// Decoded vertices: each drawn primitive's POSITION count, plus 3 per triangle when it gets
    /// flat normals (no NORMAL). 2²³ = 8,388,608: twice the largest mesh hadou makes itself (a
    /// sphere of 2048 segments, 4.2 M vertices) and several times a dense game level; 192 MiB of
    /// f32 positions and normals.
    pub vertices: u64,
    /// Decoded indices: 3 per drawn triangle. 3·2²⁴ = 50,331,648 (16.7 M triangles, 192 MiB of
    /// u32): two triangles per vertex of the vertex budget, what a closed mesh has.
    pub indices: u64,
    /// Nodes in the file. 2¹⁸ = 262,144: each costs its parent, depth and up to three transform
    /// steps (≤ 432 bytes, 108 MiB in all); city-sized levels have tens of thousands.
    pub nodes: u64,
    /// Drawn instances, one per (node, drawable primitive). 2¹⁶ = 65,536: each is a draw and an
    /// instance record per frame; a software rasterizer spends seconds a frame well before this.
    pub instances: u64,
    /// Transform steps over all nodes of the shown scene and all instances (each keeps its own
    /// copy of its node's and every ancestor's steps): 2²⁰ = 1,048,576, ≤ 136 MiB at 136 bytes a
    /// step. Without it 65,536 instances 1024 levels deep would hold 2·10⁸ steps (25 GiB).
    pub steps: u64,
    /// Texels of the images the drawn textures read, each image counted once, from the sizes
    /// their headers declare before any is decoded. 2²⁶ = 67,108,864 (sixteen 2048² textures
    /// or four 4096²): 256 MiB of RGBA8, 341 MiB with the mip chains.
    pub texels: u64,
}

/// What the glTF files loaded so far into one scene drew, in the budget's terms: a TOML scene's
/// `[[gltf]]` files share one budget (otherwise a scene of many files, each just within it, could
/// add up to any total).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Spent {
    /// Decoded vertices.
    pub vertices: u64,
    /// Decoded indices.
    pub indices: u64,
    /// Drawn instances.
    pub instances: u64,
    /// Transform steps.
    pub steps: u64,
}

impl Default for Budget {
    fn default() -> Self {
        Budget {
            vertices: 1 << 23,
            indices: 3 << 24,
            nodes: 1 << 18,
            instances: 1 << 16,
            steps: 1 << 20,
            texels: 1 << 26,
        }
    }
}

impl Budget {
    /// The defaults with `HADOU_GLTF_BUDGET`'s overrides; a malformed value is an error of `path`
    /// (the file being loaded) naming the variable.
    pub fn from_env(path: &Path) -> Result<Budget, GltfError> {
        match std::env::var_os(BUDGET_VAR) {
            None => Ok(Budget::default()),
            Some(v) => match v.to_str() {
                Some(text) => Budget::parse(text),
                None => Err("the value is not UTF-8".to_owned()),
            }
            .map_err(|why| GltfError::at(path, "", format!("environment variable {BUDGET_VAR}: {why}"))),
        }
    }

    /// `key=N` pairs separated by commas (empty: the defaults).
    pub fn parse(text: &str) -> Result<Budget, String> {
        let mut b = Budget::default();
        for item in text.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            let expected = "expected KEY=N pairs separated by commas, KEY one of vertices, indices, nodes, instances, steps, texels and N a whole number of at least 1";
            let shown: String = item.chars().take(40).collect();
            let Some((key, value)) = item.split_once('=') else {
                return Err(format!("`{shown}` ({expected})"));
            };
            let slot = match key.trim() {
                "vertices" => &mut b.vertices,
                "indices" => &mut b.indices,
                "nodes" => &mut b.nodes,
                "instances" => &mut b.instances,
                "steps" => &mut b.steps,
                "texels" => &mut b.texels,
                _ => return Err(format!("unknown key in `{shown}` ({expected})")),
            };
            *slot = match value.trim().parse::<u64>() {
                Ok(n) if n >= 1 => n,
                _ => return Err(format!("`{shown}` ({expected})")),
            };
        }
        Ok(b)
    }
}

/// What drawing a primitive once decodes, from its declared counts (see `Budget`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Cost {
    pub vertices: u64,
    pub indices: u64,
}

/// The cost of drawing primitive `p` of mesh `m` once, None when it is skipped (as `build` would
/// skip it: not a triangle mode, no POSITION, quantized). Reads no data; an accessor whose count
/// no buffer bounds is refused here, before anything is allocated for it.
pub(super) fn cost(path: &Path, m: usize, p: &gltf::Primitive) -> Result<Option<Cost>, GltfError> {
    let at = format!("/meshes/{m}/primitives/{}", p.index());
    if !matches!(p.mode(), Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        return Ok(None);
    }
    let Some(pos) = p.get(&Semantic::Positions) else { return Ok(None) };
    // Only accessors of the type the read expects: for any other the read's own error (a wrong
    // type, before any allocation) is the one to give.
    let declared = |a: &gltf::Accessor, at: String| match accessor::readable(a) {
        true => accessor::check_declared(path, a, &at),
        false => Ok(()),
    };
    declared(&pos, format!("{at}/attributes/POSITION"))?;
    let normals = p.get(&Semantic::Normals);
    if let Some(a) = &normals {
        declared(a, format!("{at}/attributes/NORMAL"))?;
    }
    if accessor::quantized(&pos) || normals.as_ref().is_some_and(accessor::quantized) {
        return Ok(None);
    }
    let order = match p.indices() {
        Some(a) => {
            declared(&a, format!("{at}/indices"))?;
            a.count() as u64
        }
        None => pos.count() as u64,
    };
    let triangles = match p.mode() {
        Mode::Triangles => order / 3,
        _ => order.saturating_sub(2),
    };
    let flat = if normals.is_some() { 0 } else { 3 * triangles };
    Ok(Some(Cost { vertices: pos.count() as u64 + flat, indices: 3 * triangles }))
}

/// A primitive built, or why it was skipped (valid glTF hadou does not draw).
pub(super) enum Built {
    Mesh(Mesh),
    Skipped(String),
}

/// Builds primitive `p` of mesh `m`.
pub(super) fn build(src: &Source, m: usize, p: &gltf::Primitive) -> Result<Built, GltfError> {
    let at = format!("/meshes/{m}/primitives/{}", p.index());
    // One primitive alone within the file's budget, before any of it is decoded (the file's
    // total, every use counted, is checked before the import builds anything: nodes.rs).
    if let Some(c) = cost(src.path, m, p)? {
        let budget = Budget::from_env(src.path)?;
        for (what, n, most) in
            [("vertices", c.vertices, budget.vertices), ("indices", c.indices, budget.indices)]
        {
            if n > most {
                return Err(GltfError::at(src.path, at.clone(), over_budget(what, n, most, "")));
            }
        }
    }
    let mode = p.mode();
    if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        return Ok(Built::Skipped(format!("{at}: mode {}", mode_name(mode))));
    }
    let Some(pos_accessor) = p.get(&Semantic::Positions) else {
        return Ok(Built::Skipped(format!("{at}: no POSITION attribute")));
    };
    let pos_at = format!("{at}/attributes/POSITION");
    let positions = match src.vec3(&pos_accessor, &pos_at) {
        Ok(v) => v,
        Err(ReadError::Bad(e)) => return Err(e),
        Err(ReadError::Unsupported(why)) => return Ok(Built::Skipped(why)),
    };
    if let Some((k, v)) = positions.iter().enumerate().find(|(_, v)| !v.iter().all(|c| c.is_finite())) {
        let message = format!("position {k} is {v:?} (expected finite numbers)");
        return Err(GltfError::at(src.path, pos_at, message));
    }
    let n = positions.len();
    // Compared before the normals are decoded: their count is not bounded by the positions'.
    let normal_accessor = p.get(&Semantic::Normals);
    if let Some(a) = &normal_accessor {
        if a.count() != n {
            let message = format!("{} normals for {n} positions (expected one per position)", a.count());
            return Err(GltfError::at(src.path, format!("{at}/attributes/NORMAL"), message));
        }
    }
    let order = match p.indices() {
        Some(a) => {
            let idx_at = format!("{at}/indices");
            let order = match src.indices(&a, &idx_at) {
                Ok(v) => v,
                Err(ReadError::Bad(e)) => return Err(e),
                Err(ReadError::Unsupported(why)) => return Ok(Built::Skipped(why)),
            };
            if let Some((k, i)) = order.iter().enumerate().find(|(_, &i)| i as usize >= n) {
                let message = format!("index {k} is {i}, out of range for {n} vertices (POSITION count)");
                return Err(GltfError::at(src.path, idx_at, message));
            }
            order
        }
        None => (0..n as u32).collect(),
    };
    let indices = triangle_list(mode, &order).map_err(|why| GltfError::at(src.path, at.clone(), why))?;
    let attributes = match attributes(src, &at, p, n)? {
        Ok(a) => a,
        Err(why) => return Ok(Built::Skipped(why)),
    };
    let mesh = match normal_accessor {
        Some(a) => {
            let nrm_at = format!("{at}/attributes/NORMAL");
            let normals = match src.vec3(&a, &nrm_at) {
                Ok(v) => v,
                Err(ReadError::Bad(e)) => return Err(e),
                Err(ReadError::Unsupported(why)) => return Ok(Built::Skipped(why)),
            };
            if normals.len() != n {
                let message =
                    format!("{} normals for {n} positions (expected one per position)", normals.len());
                return Err(GltfError::at(src.path, nrm_at, message));
            }
            let normals = unit_normals(&normals).map_err(|why| GltfError::at(src.path, nrm_at, why))?;
            Mesh { positions, normals, indices, attributes }
        }
        None => {
            // Flat shading gives each triangle fresh vertices: the attributes follow its indices.
            let mut mesh = flat(&positions, &indices);
            mesh.attributes = attributes.map(|a| {
                Box::new(VertexAttributes {
                    colors: spread(&a.colors, &indices),
                    texcoords: [spread(&a.texcoords[0], &indices), spread(&a.texcoords[1], &indices)],
                })
            });
            mesh
        }
    };
    // The checks above cover these; this keeps any gap from reaching the GPU.
    mesh.validate_basic().map_err(|why| GltfError::at(src.path, at, why))?;
    Ok(Built::Mesh(mesh))
}

/// `COLOR_0`, `TEXCOORD_0` and `TEXCOORD_1` of a primitive of `n` vertices (None when it has
/// none of them); the inner Err is why the primitive is skipped.
fn attributes(
    src: &Source,
    at: &str,
    p: &gltf::Primitive,
    n: usize,
) -> Result<Result<Option<Box<VertexAttributes>>, String>, GltfError> {
    use gltf::accessor::Dimensions::{Vec2, Vec3, Vec4};
    let mut out = VertexAttributes::default();
    let wanted = [
        (Semantic::Colors(0), "COLOR_0"),
        (Semantic::TexCoords(0), "TEXCOORD_0"),
        (Semantic::TexCoords(1), "TEXCOORD_1"),
    ];
    for (k, (semantic, name)) in wanted.into_iter().enumerate() {
        let Some(a) = p.get(&semantic) else { continue };
        let a_at = format!("{at}/attributes/{name}");
        // Compared before decoding: the count is not bounded by the positions'.
        if a.count() != n {
            let message = format!("{} elements for {n} positions (expected one per position)", a.count());
            return Err(GltfError::at(src.path, a_at, message));
        }
        let read = match k {
            0 => src.unit_vec4(&a, &a_at, &[Vec3, Vec4], [1.0; 4]),
            _ => src.unit_vec4(&a, &a_at, &[Vec2], [0.0; 4]),
        };
        let values = match read {
            Ok(v) => v,
            Err(ReadError::Bad(e)) => return Err(e),
            Err(ReadError::Unsupported(why)) => return Ok(Err(why)),
        };
        if let Some((i, v)) = values.iter().enumerate().find(|(_, v)| !v.iter().all(|c| c.is_finite())) {
            let message =
                format!("element {i} is {:?} (expected finite numbers)", &v[..if k == 0 { 4 } else { 2 }]);
            return Err(GltfError::at(src.path, a_at, message));
        }
        match k {
            0 => out.colors = values.into_iter().map(|c| c.map(|x| x.clamp(0.0, 1.0))).collect(),
            _ => out.texcoords[k - 1] = values.into_iter().map(|v| [v[0], v[1]]).collect(),
        }
    }
    let none = out.colors.is_empty() && out.texcoords.iter().all(Vec::is_empty);
    Ok(Ok((!none).then(|| Box::new(out))))
}

/// A per-vertex list indexed by a triangle list (empty stays empty).
fn spread<T: Copy>(values: &[T], indices: &[u32]) -> Vec<T> {
    match values.is_empty() {
        true => Vec::new(),
        false => indices.iter().map(|&i| values[i as usize]).collect(),
    }
}

/// The message for a budget passed: what, how many, the most, and how to raise it. `use_of`
/// says which use crossed it (empty for one primitive alone).
pub(super) fn over_budget(what: &str, n: u64, most: u64, use_of: &str) -> String {
    let per = if use_of.is_empty() { "for one primitive, ".to_owned() } else { format!("{use_of}; ") };
    format!(
        "{n} {what} to decode and draw ({per}hadou reads at most {most} {what} per glTF file, counting a mesh once per node that draws it; set {BUDGET_VAR}=\"{what}=N\" to allow more)"
    )
}

/// Triangle list from any triangle mode (glTF 2.0 §3.7.2.1 gives the strip and fan orders, which
/// keep every triangle's winding).
fn triangle_list(mode: Mode, v: &[u32]) -> Result<Vec<u32>, String> {
    let n = v.len();
    let list: Vec<u32> = match mode {
        Mode::Triangles => {
            if n % 3 != 0 {
                return Err(format!("TRIANGLES with {n} indices (expected a multiple of 3)"));
            }
            v.to_vec()
        }
        Mode::TriangleStrip => {
            (0..n.saturating_sub(2)).flat_map(|i| [v[i], v[i + 1 + i % 2], v[i + 2 - i % 2]]).collect()
        }
        _ => (1..n.saturating_sub(1)).flat_map(|i| [v[i], v[i + 1], v[0]]).collect(),
    };
    if list.is_empty() {
        return Err(format!("{} with {n} vertices draws no triangle (expected at least 3)", mode_name(mode)));
    }
    Ok(list)
}

/// Normals as given, renormalized (writers round them); zero or non-finite ones are errors.
fn unit_normals(normals: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, String> {
    normals
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let d = DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
            match d.try_normalize() {
                Some(u) => Ok([u.x as f32, u.y as f32, u.z as f32]),
                None => Err(format!("normal {k} is {v:?} (expected a non-zero, finite vector)")),
            }
        })
        .collect()
}

/// Flat shading: three fresh vertices per triangle, each with the face normal (b − a) × (c − a),
/// the outward side of a counter-clockwise triangle. A triangle without area gets +y: it covers
/// no pixel, so the normal is never seen.
fn flat(positions: &[[f32; 3]], indices: &[u32]) -> Mesh {
    let mut mesh = Mesh::default();
    for tri in indices.chunks_exact(3) {
        let p = [tri[0], tri[1], tri[2]].map(|i| positions[i as usize]);
        let [a, b, c] = p.map(|q| DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64));
        let n = (b - a).cross(c - a).try_normalize().unwrap_or(DVec3::Y);
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(p);
        mesh.normals.extend([[n.x as f32, n.y as f32, n.z as f32]; 3]);
        mesh.indices.extend([base, base + 1, base + 2]);
    }
    mesh
}

pub(super) fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Points => "POINTS",
        Mode::Lines => "LINES",
        Mode::LineLoop => "LINE_LOOP",
        Mode::LineStrip => "LINE_STRIP",
        Mode::Triangles => "TRIANGLES",
        Mode::TriangleStrip => "TRIANGLE_STRIP",
        Mode::TriangleFan => "TRIANGLE_FAN",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_the_winding() {
        // A quad 0 1 2 3 counter-clockwise: every triangle of both forms is counter-clockwise too.
        assert_eq!(triangle_list(Mode::TriangleStrip, &[0, 1, 3, 2]).unwrap(), vec![0, 1, 3, 1, 2, 3]);
        assert_eq!(triangle_list(Mode::TriangleFan, &[0, 1, 2, 3]).unwrap(), vec![1, 2, 0, 2, 3, 0]);
        assert!(triangle_list(Mode::Triangles, &[0, 1]).is_err());
        assert!(triangle_list(Mode::TriangleStrip, &[0, 1]).is_err());
    }

    #[test]
    fn budget_overrides() {
        assert_eq!(Budget::parse("").unwrap(), Budget::default());
        let b = Budget::parse(" vertices = 10, steps=3 ,").unwrap();
        assert_eq!(b, Budget { vertices: 10, steps: 3, ..Budget::default() });
        for bad in
            ["vertices", "vertex=3", "nodes=0", "nodes=-1", "nodes=1e6", "indices=99999999999999999999999"]
        {
            assert!(Budget::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn flat_normals_point_to_the_counter_clockwise_side() {
        let m = flat(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], &[0, 1, 2]);
        assert_eq!(m.normals, vec![[0.0, 0.0, 1.0]; 3]);
        assert!(unit_normals(&[[0.0, 0.0, 0.0]]).is_err());
        assert_eq!(unit_normals(&[[0.0, 2.0, 0.0]]).unwrap(), vec![[0.0, 1.0, 0.0]]);
    }
}
