//! The TOML scenes' numeric limits for glTF content (docs/scene-format.md, "Numeric limits"):
//! a mesh's positions within ±`MAX_LENGTH` of its origin and its box at least `MIN_LENGTH` across
//! (the `[[mesh]]` lengths), every drawn instance within ±`MAX_WORLD` and at least `MIN_LENGTH`
//! across in the world, its world matrix and inverse within f32. A refusal names the JSON pointer
//! of the value at fault: the accessor's `min`/`max`, or the node field (`scale`, `rotation`,
//! `translation`, `matrix`) whose step took the instance out of the limits.

use std::path::Path;

use glam::{DMat4, DQuat, DVec3};

use super::error::GltfError;
use super::nodes::Hierarchy;
use crate::scene::file::MAX_EXTENT;
use crate::scene::mesh::Mesh;
use crate::scene::procedural::{MAX_LENGTH, MIN_LENGTH};
use crate::scene::transform::{Transform, TransformOp};

/// The largest world coordinate of a drawn instance's box: 2⁴⁴ ≈ 1.7592e13, `MAX_EXTENT` / 16.
/// A TOML scene keeps its camera and `far` within 2⁴⁸ (every view depth below it); a glTF file
/// without a camera is framed (`framing`): with every corner within ±L the bounding sphere's
/// radius and centre are at most √3·L, the camera stands within L + 2.62·√3·L·0.82 ≈ 4.7·L of the
/// origin per axis and its `far` is 2·(2.62 + 1)·√3·L ≈ 12.5·L, or 1.25 times its distance to the
/// farthest corner (what the framing left out, ≤ 1.25·√3·5.7·L ≈ 12.4·L). L = 2⁴⁴ keeps both
/// below 2⁴⁸, as a TOML scene's; a file camera's `far` when glTF gives none (twice its reach)
/// stays there too.
pub const MAX_WORLD: f64 = MAX_EXTENT / 16.0;

/// A computed number (not one the file wrote) to 5 digits, in exponent form: `1.7592e13`, `1e-8`.
pub(crate) fn show_computed(v: f64) -> String {
    let s = format!("{v:.4e}");
    match s.split_once('e') {
        Some((m, e)) if m.contains('.') => {
            format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
        }
        _ => s,
    }
}

/// Marks a refusal caused by the `[[gltf]]` `transform` of a TOML scene (`placed_by_transform`).
const BY_TRANSFORM: &str = ", placed by the [[gltf]] `transform`,";

/// True for a refusal of `check_instance` whose culprit is the `[[gltf]]` `transform` (the TOML
/// scene places the error at that `transform`, not at the file's `path`).
pub(crate) fn placed_by_transform(e: &GltfError) -> bool {
    e.message.contains(BY_TRANSFORM)
}

/// A number as the messages show it: plain, or in exponent form outside [1e-4, 1e9).
fn show(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-4..1e9).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A file's f32 value as written (1e16, not 1.0000000272564224e16).
fn show_f32(v: f64) -> String {
    show((v as f32).to_string().parse().unwrap_or(v))
}

fn show_vec_f32(v: DVec3) -> String {
    format!("[{}, {}, {}]", show_f32(v.x), show_f32(v.y), show_f32(v.z))
}

/// Positions of primitive mesh `mesh` (read from accessor `accessor`) within ±`MAX_LENGTH` and its
/// box at least `MIN_LENGTH` on its longest side: the lengths a `[[mesh]]` may have, the range
/// `Renderer::set_mesh_positions` takes for the same mesh.
pub(super) fn check_mesh(path: &Path, accessor: usize, mesh: &Mesh) -> Result<(), GltfError> {
    let (lo, hi) = mesh.bounds();
    let at = |field: &str| format!("/accessors/{accessor}{field}");
    if hi.max_element() > MAX_LENGTH {
        let message = format!(
            "POSITION max is {} (expected every coordinate within ±1e6, the longest `[[mesh]]` length: \
             place far content with node translations; f32 keeps ~7 digits of a position)",
            show_vec_f32(hi)
        );
        return Err(GltfError::at(path, at("/max"), message));
    }
    if lo.min_element() < -MAX_LENGTH {
        let message = format!(
            "POSITION min is {} (expected every coordinate within ±1e6, the longest `[[mesh]]` length: \
             place far content with node translations; f32 keeps ~7 digits of a position)",
            show_vec_f32(lo)
        );
        return Err(GltfError::at(path, at("/min"), message));
    }
    let size = (hi - lo).max_element();
    if size < MIN_LENGTH {
        let message = format!(
            "the positions span {} on their longest side (min {}, max {}; expected at least 1e-6, \
             the shortest `[[mesh]]` length: f32 keeps ~7 digits, and a smaller mesh is rounding \
             noise on the GPU)",
            show_f32(size),
            show_vec_f32(lo),
            show_vec_f32(hi)
        );
        return Err(GltfError::at(path, at(""), message));
    }
    Ok(())
}

/// What is wrong with an instance placed by a matrix, if anything.
enum Problem {
    /// An entry of the matrix or of its inverse past f32 (the value found).
    Matrix(f64),
    /// A box corner past ±`MAX_WORLD` (the coordinate found).
    Far(f64),
    /// The box's longest side below `MIN_LENGTH` (the side found).
    Small(f64),
}

fn problem(matrix: &DMat4, bounds: (DVec3, DVec3)) -> Option<Problem> {
    let inverse = matrix.inverse();
    let entries = matrix.to_cols_array().into_iter().chain(inverse.to_cols_array());
    if let Some(v) = entries.map(f64::abs).find(|v| v.is_nan() || *v > f32::MAX as f64) {
        return Some(Problem::Matrix(v));
    }
    let (lo, hi) = world_box(matrix, bounds);
    let far = lo.abs().max(hi.abs()).max_element();
    if far.is_nan() || far > MAX_WORLD {
        return Some(Problem::Far(far));
    }
    let size = (hi - lo).max_element();
    if size.is_nan() || size < MIN_LENGTH {
        return Some(Problem::Small(size));
    }
    None
}

/// The world box of the object box `bounds` placed by `matrix` (its 8 corners).
pub(super) fn world_box(matrix: &DMat4, (a, b): (DVec3, DVec3)) -> (DVec3, DVec3) {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for k in 0..8 {
        let corner = DVec3::new(
            if k & 1 == 0 { a.x } else { b.x },
            if k & 2 == 0 { a.y } else { b.y },
            if k & 4 == 0 { a.z } else { b.z },
        );
        let p = matrix.transform_point3(corner);
        lo = lo.min(p);
        hi = hi.max(p);
    }
    (lo, hi)
}

/// One step's matrix (as `Transform::from_ops` builds it, without its checks: a step may be
/// ill-conditioned alone when the whole is not).
fn step_matrix(op: &TransformOp) -> DMat4 {
    match *op {
        TransformOp::Translate(t) => DMat4::from_translation(t),
        TransformOp::Rotate { angle_deg, axis } => {
            DMat4::from_quat(DQuat::from_axis_angle(axis.normalize(), angle_deg.to_radians()))
        }
        TransformOp::Scale(s) => DMat4::from_scale(s),
        TransformOp::Matrix(m) => m,
    }
}

/// The node field a step comes from.
fn field(op: &TransformOp) -> &'static str {
    match op {
        TransformOp::Translate(_) => "translation",
        TransformOp::Rotate { .. } => "rotation",
        TransformOp::Scale(_) => "scale",
        TransformOp::Matrix(_) => "matrix",
    }
}

/// The instance of node `n` drawing a mesh of object box `bounds` (named `what`), placed by
/// `world` (the node's steps, its parents', then `base`): within f32, ±`MAX_WORLD` and at least
/// `MIN_LENGTH` across. A refusal names the step that took the instance out last (walking from
/// the node up to the root, then `base`): `/nodes/i/translation` and the like, or the `[[gltf]]`
/// `transform` of a TOML scene.
pub(super) fn check_instance(
    path: &Path,
    hierarchy: &Hierarchy,
    n: usize,
    base: &[TransformOp],
    bounds: (DVec3, DVec3),
    world: &Transform,
    what: &str,
) -> Result<(), GltfError> {
    let Some(found) = problem(&world.matrix, bounds) else { return Ok(()) };
    // The steps in the order they apply, each with its node (None: the `[[gltf]]` transform).
    let mut steps: Vec<(Option<usize>, &TransformOp)> = Vec::new();
    let mut at = Some(n);
    while let Some(i) = at {
        steps.extend(hierarchy.local[i].iter().map(|op| (Some(i), op)));
        at = hierarchy.parent[i];
    }
    steps.extend(base.iter().map(|op| (None, op)));
    let mut matrix = DMat4::IDENTITY;
    let mut was_bad = false;
    let mut culprit = None;
    for (k, (_, op)) in steps.iter().enumerate() {
        matrix = step_matrix(op) * matrix;
        let bad = problem(&matrix, bounds).is_some();
        if bad && !was_bad {
            culprit = Some(k);
        }
        was_bad = bad;
    }
    let (pointer, by) = match culprit.map(|k| steps[k]) {
        Some((Some(i), op)) => (format!("/nodes/{i}/{}", field(op)), String::new()),
        Some((None, _)) => (format!("/nodes/{n}"), BY_TRANSFORM.to_owned()),
        None => (format!("/nodes/{n}"), String::new()),
    };
    let message = match found {
        Problem::Matrix(v) => format!(
            "node {n} ({what}){by} has a world matrix or inverse with an entry of {} (expected \
             entries within ±3.4028235e38: they are uploaded as f32)",
            show_computed(v)
        ),
        Problem::Far(v) => format!(
            "node {n} ({what}){by} reaches {} in world space (expected every coordinate within \
             ±1.7592e13 = 2^44: the view depths of the camera that frames it stay within 2^48, the \
             extent of a TOML scene; see docs/scene-format.md, Numeric limits)",
            show_computed(v)
        ),
        Problem::Small(v) => format!(
            "node {n} ({what}){by} is {} across in world space (expected at least 1e-6 on its \
             longest side, the shortest `[[mesh]]` length: f32 keeps ~7 digits, and a smaller \
             instance is rounding noise on the GPU)",
            show_computed(v)
        ),
    };
    Err(GltfError::at(path, pointer, message))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn max_world_is_2_to_the_44() {
        assert_eq!(MAX_WORLD, 2f64.powi(44));
        assert_eq!(show_computed(MAX_WORLD), "1.7592e13");
        assert_eq!(show_computed(9.99999993922529e-9), "1e-8");
        assert_eq!(show_computed(-2.5e40), "-2.5e40");
    }

    #[test]
    fn f32_values_show_as_written() {
        assert_eq!(show_f32(1e16f32 as f64), "1e16");
        assert_eq!(show_vec_f32(DVec3::new(1e16f32 as f64, 0.5, -2e-8f32 as f64)), "[1e16, 0.5, -2e-8]");
    }
}
