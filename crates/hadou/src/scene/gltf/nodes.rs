//! The node hierarchy: each node's local transform as seed-002 steps (TRS as scale, rotate,
//! translate; a matrix as one step), the parent of every node with the tree rules glTF states
//! (one parent, no cycles) enforced, and the scene's nodes in depth-first order.

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat4, DQuat, DVec3, DVec4};

use super::error::GltfError;
use super::primitive::{self, over_budget, Budget, Spent};
use crate::scene::transform::TransformOp;

/// Deeper hierarchies are refused: a node's steps are its ancestors' (O(depth) each), and no
/// real asset comes near this.
pub const MAX_DEPTH: usize = 1024;

/// Parents and local steps of every node.
pub(super) struct Hierarchy {
    pub parent: Vec<Option<usize>>,
    pub local: Vec<Vec<TransformOp>>,
    /// The file's budget, checked against the node count here and the shown scene's cost by
    /// `scene_nodes`.
    pub budget: Budget,
}

impl Hierarchy {
    /// The steps taking node `n`'s coordinates to the file's world: its own local steps, then its
    /// parent's, up to the root (M = M_root ⋯ M_parent · M_node), then `base` (the placement of
    /// the whole file).
    pub fn world_ops(&self, n: usize, base: &[TransformOp]) -> Vec<TransformOp> {
        let mut ops = Vec::new();
        let mut at = Some(n);
        while let Some(i) = at {
            ops.extend(self.local[i].iter().cloned());
            at = self.parent[i];
        }
        ops.extend(base.iter().cloned());
        ops
    }
}

/// Reads every node's transform and checks the graph is a forest of at most `MAX_DEPTH` levels.
pub(super) fn hierarchy(path: &Path, doc: &gltf::Document) -> Result<Hierarchy, GltfError> {
    let budget = Budget::from_env(path)?;
    let count = doc.nodes().len();
    if count as u64 > budget.nodes {
        let message = format!(
            "{count} nodes (hadou reads at most {} nodes per glTF file; set {}=\"nodes=N\" to allow more)",
            budget.nodes,
            primitive::BUDGET_VAR
        );
        return Err(GltfError::at(path, "/nodes", message));
    }
    let mut parent = vec![None; count];
    let mut local = Vec::with_capacity(count);
    for node in doc.nodes() {
        local.push(local_ops(path, &node)?);
        for (k, child) in node.children().enumerate() {
            let c = child.index();
            if let Some(first) = parent[c] {
                let message = format!(
                    "node {c} is already a child of /nodes/{first} (glTF nodes form trees: one parent each)"
                );
                return Err(GltfError::at(path, format!("/nodes/{}/children/{k}", node.index()), message));
            }
            parent[c] = Some(node.index());
        }
    }
    check_acyclic(path, &parent)?;
    Ok(Hierarchy { parent, local, budget })
}

/// Walks up from every node; a walk that meets a node of its own path is a cycle. Nodes already
/// known to end at a root are not walked again, so this is linear in the node count.
fn check_acyclic(path: &Path, parent: &[Option<usize>]) -> Result<(), GltfError> {
    const NEW: u8 = 0;
    const ON_PATH: u8 = 1;
    const DONE: u8 = 2;
    let mut state = vec![NEW; parent.len()];
    let mut depth = vec![0usize; parent.len()];
    for start in 0..parent.len() {
        let mut walk: Vec<usize> = Vec::new();
        let mut at = Some(start);
        while let Some(i) = at {
            match state[i] {
                DONE => break,
                ON_PATH => {
                    let from = walk.iter().position(|&w| w == i).unwrap_or(0);
                    // Walked child → parent; listed parent → child, back to the first.
                    let mut cycle: Vec<String> = walk[from..].iter().rev().map(|w| w.to_string()).collect();
                    cycle.push(cycle[0].clone());
                    let message = format!(
                        "the node graph has a cycle: {} (each node a child of the one before; glTF nodes form trees)",
                        cycle.join(" → ")
                    );
                    let p = parent[i].unwrap_or(i);
                    return Err(GltfError::at(path, format!("/nodes/{p}/children"), message));
                }
                _ => {
                    state[i] = ON_PATH;
                    walk.push(i);
                    at = parent[i];
                }
            }
        }
        // Depths from the top of the walk down.
        let top = at.map_or(0, |i| depth[i] + 1);
        for (d, &i) in (top..).zip(walk.iter().rev()) {
            depth[i] = d;
            if d >= MAX_DEPTH {
                let message = format!("node {i} is {d} levels deep (hadou reads at most {MAX_DEPTH})");
                return Err(GltfError::at(path, format!("/nodes/{i}"), message));
            }
            state[i] = DONE;
        }
    }
    Ok(())
}

/// A node's transform as steps applied to its content: TRS as scale, then rotate, then translate
/// (glTF's M = T·R·S), each left out when it is the identity; a matrix as one step.
fn local_ops(path: &Path, node: &gltf::Node) -> Result<Vec<TransformOp>, GltfError> {
    let at = |field: &str| format!("/nodes/{}/{field}", node.index());
    let finite = |field: &str, v: &[f32]| {
        if v.iter().all(|c| c.is_finite()) {
            Ok(())
        } else {
            Err(GltfError::at(path, at(field), format!("{v:?} is not finite (expected finite numbers)")))
        }
    };
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            finite("matrix", matrix.as_flattened())?;
            let m = DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)));
            if m.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
                let message = format!(
                    "bottom row is {:?} (expected an affine matrix: 0, 0, 0, 1)",
                    m.row(3).to_array()
                );
                return Err(GltfError::at(path, at("matrix"), message));
            }
            Ok(if m == DMat4::IDENTITY { Vec::new() } else { vec![TransformOp::Matrix(m)] })
        }
        gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
            finite("translation", &translation)?;
            finite("rotation", &rotation)?;
            finite("scale", &scale)?;
            let mut ops = Vec::new();
            let s = DVec3::from_array(scale.map(f64::from));
            if s != DVec3::ONE {
                ops.push(TransformOp::Scale(s));
            }
            let q = DQuat::from_array(rotation.map(f64::from));
            let len = q.length();
            let Some(q) = (len > 0.0).then(|| q / len) else {
                let message = format!("{rotation:?} has zero length (expected a unit quaternion)");
                return Err(GltfError::at(path, at("rotation"), message));
            };
            let v = q.xyz();
            if v.length() > 0.0 {
                // q = (sin(θ/2)·axis, cos(θ/2)): θ = 2·atan2(|v|, w) about v/|v|.
                let angle_deg = (2.0 * v.length().atan2(q.w)).to_degrees();
                ops.push(TransformOp::Rotate { angle_deg, axis: v });
            }
            let t = DVec3::from_array(translation.map(f64::from));
            if t != DVec3::ZERO {
                ops.push(TransformOp::Translate(t));
            }
            Ok(ops)
        }
    }
}

/// The nodes of the scene glTF says to show (`scene`, else the first of `scenes`, else every node
/// without a parent), depth-first, parents before children; and the other scenes (not shown).
pub(super) fn scene_nodes(
    path: &Path,
    doc: &gltf::Document,
    h: &Hierarchy,
    spent: Spent,
) -> Result<(Vec<usize>, Vec<String>, Spent), GltfError> {
    let chosen = doc.default_scene().or_else(|| doc.scenes().next());
    let (roots, others): (Vec<usize>, Vec<String>) = match &chosen {
        Some(s) => {
            let mut listed = HashMap::new();
            for (k, n) in s.nodes().enumerate() {
                let at = format!("/scenes/{}/nodes/{k}", s.index());
                if let Some(p) = h.parent[n.index()] {
                    let message =
                        format!("node {} is a child of /nodes/{p} (expected root nodes only)", n.index());
                    return Err(GltfError::at(path, at, message));
                }
                // glTF 2.0 §5.29: a scene's nodes are unique; a node listed twice would be drawn twice.
                if let Some(first) = listed.insert(n.index(), k) {
                    let message = format!(
                        "node {} is listed twice, first at /scenes/{}/nodes/{first} (expected each root once)",
                        n.index(),
                        s.index()
                    );
                    return Err(GltfError::at(path, at, message));
                }
            }
            let others =
                doc.scenes().filter(|o| o.index() != s.index()).map(|o| format!("/scenes/{}", o.index()));
            (s.nodes().map(|n| n.index()).collect(), others.collect())
        }
        None => ((0..h.parent.len()).filter(|&i| h.parent[i].is_none()).collect(), Vec::new()),
    };
    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    let mut order = Vec::new();
    let mut stack: Vec<usize> = roots.into_iter().rev().collect();
    while let Some(n) = stack.pop() {
        order.push(n);
        let children: Vec<usize> = nodes[n].children().map(|c| c.index()).collect();
        stack.extend(children.into_iter().rev());
    }
    let spent = check_budget(path, &nodes, h, &order, spent)?;
    Ok((order, others, spent))
}

/// The shown scene's cost against the file's budget, from declared counts only, before the
/// import decodes or allocates anything for it: every node's transform steps, and per node that
/// draws a mesh, each drawable primitive's vertices and indices and one instance (a mesh shared by
/// many nodes counts once per node). Nodes a singular transform will hide are counted too. Stops
/// at the first use past the budget, so its own time is bounded by the budget as well. `spent`:
/// what earlier files of the same scene drew (they share the budget); returns the new total.
fn check_budget(
    path: &Path,
    nodes: &[gltf::Node],
    h: &Hierarchy,
    order: &[usize],
    spent: Spent,
) -> Result<Spent, GltfError> {
    let b = &h.budget;
    let earlier = if spent == Spent::default() { "" } else { " (with the scene's earlier glTF files)" };
    let mut costs: HashMap<(usize, usize), Option<primitive::Cost>> = HashMap::new();
    // Each node's steps with its ancestors' (what `world_ops` builds): parents come first in
    // `order`, so one pass fills them.
    let mut steps_to = vec![0u64; nodes.len()];
    let Spent { mut vertices, mut indices, mut instances, mut steps } = spent;
    for &n in order {
        let own = h.local[n].len() as u64 + h.parent[n].map_or(0, |p| steps_to[p]);
        steps_to[n] = own;
        steps = steps.saturating_add(own);
        if steps > b.steps {
            let message =
                over_budget("transform steps", steps, b.steps, &format!("reached at /nodes/{n}{earlier}"));
            return Err(GltfError::at(path, format!("/nodes/{n}"), message));
        }
        let Some(mesh) = nodes[n].mesh() else { continue };
        for p in mesh.primitives() {
            let key = (mesh.index(), p.index());
            let cost = match costs.get(&key) {
                Some(c) => *c,
                None => {
                    let c = primitive::cost(path, mesh.index(), &p)?;
                    costs.insert(key, c);
                    c
                }
            };
            let Some(c) = cost else { continue };
            vertices = vertices.saturating_add(c.vertices);
            indices = indices.saturating_add(c.indices);
            instances += 1;
            steps = steps.saturating_add(own);
            let use_of =
                format!("reached at /meshes/{}/primitives/{} drawn by /nodes/{n}{earlier}", key.0, key.1);
            for (what, total, most) in [
                ("vertices", vertices, b.vertices),
                ("indices", indices, b.indices),
                ("instances", instances, b.instances),
                ("transform steps", steps, b.steps),
            ] {
                if total > most {
                    return Err(GltfError::at(
                        path,
                        format!("/nodes/{n}/mesh"),
                        over_budget(what, total, most, &use_of),
                    ));
                }
            }
        }
    }
    Ok(Spent { vertices, indices, instances, steps })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cycles_and_depth() {
        let p = Path::new("x.gltf");
        check_acyclic(p, &[None, Some(0), Some(1)]).unwrap();
        let e = check_acyclic(p, &[Some(2), Some(0), Some(1)]).unwrap_err();
        assert!(e.message.contains("cycle: 1 → 2 → 0 → 1") && e.pointer == "/nodes/2/children", "{e}");
        assert!(check_acyclic(p, &[Some(0)]).unwrap_err().message.contains("0 → 0"));
        let chain: Vec<Option<usize>> = (0..MAX_DEPTH + 1).map(|i| i.checked_sub(1)).collect();
        assert!(check_acyclic(p, &chain).unwrap_err().message.contains("levels deep"));
    }
}
