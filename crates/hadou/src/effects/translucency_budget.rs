//! Translucency's levels for the frame budget (`crate::budget`): the light map's texel, then the
//! thickness from the light's entry point (TSM) instead of the baked tables.
//!
//! Errors bound the relative error of the transmittance T = exp(−σ·d) that each level adds:
//! - **the light map**: the entry point a texel gives is within 1.5·√2·texel·tan θ of the light's
//!   own (`translucency::lut_thickness`), which moves d by as much. On entry faces at most 45°
//!   from the light (tan θ ≤ 1), |T − T*| / T* ≤ expm1(σ_max · 1.5·√2 · texel), σ_max the
//!   largest extinction of a translucent material. Steeper faces scale the term by tan θ at
//!   every level alike, which keeps the levels' order.
//! - **TSM** counts the cavities and gaps a baked table leaves out: d_tsm ≥ d*, by at most the
//!   instance's world diameter D (the light's path inside it), so 1 ≥ T_tsm / T* ≥ exp(−σ_max·D)
//!   and the share is 1 − exp(−σ_max·D). With the light map's, (1 + e_map)(1 + e_tsm) − 1. Only
//!   offered where an instance reads a table (`lut`, `pairs`); a `peel` or `tsm` material keeps
//!   its mode. The tables stay baked and uploaded, so going back costs nothing.

use super::tonemap::mesh_bounds;
use super::translucency::{light_map_size_at, LightView};
use crate::budget::QualityLevel;
use crate::scene::transform::frobenius;
use crate::scene::{MaterialKind, Scene};

/// One level: the light map's texel target in finest voxel edges, and whether the thickness is
/// TSM's instead of the tables'.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BudgetLevel {
    pub texel_voxels: f64,
    pub tsm: bool,
}

/// The levels: the default map, each next one halving its side (where it is above its smallest
/// size), then TSM at the smallest map.
pub const BUDGET_LEVELS: [BudgetLevel; 5] = [
    BudgetLevel { texel_voxels: 0.25, tsm: false },
    BudgetLevel { texel_voxels: 0.5, tsm: false },
    BudgetLevel { texel_voxels: 1.0, tsm: false },
    BudgetLevel { texel_voxels: 2.0, tsm: false },
    BudgetLevel { texel_voxels: 2.0, tsm: true },
];

/// The prior share of light_id (whose time goes with the map's texels) in the effect's passes at
/// level 0; the rest (the translucency pass, per pixel) does not change with the map. A prior
/// only, replaced by what is measured: on assets/scenes/budget.toml at 256² it was 87 % (light_id
/// 20.7 of 23.9 ms, lavapipe); a scene with more translucent pixels has less.
const LIGHT_ID_SHARE: f64 = 0.75;
/// The prior of TSM's translucency pass against the tables' (no field march): 12.5 against 24.7 ms
/// in docs/PERFORMANCE.md's translucency table.
const TSM_PASS_SHARE: f64 = 0.5;

/// The effect's name (`Effect::name` of `effect::Translucency`): its key in `Scene::quality`.
const NAME: &str = "translucency";

fn level(scene: &Scene) -> BudgetLevel {
    scene.quality.level(NAME).and_then(|l| BUDGET_LEVELS.get(l)).copied().unwrap_or(BUDGET_LEVELS[0])
}

/// The light map's texel target in finest voxel edges: the frame budget's level, else ¼.
pub fn texel_voxels(scene: &Scene) -> f64 {
    level(scene).texel_voxels
}

/// Whether the frame budget chose TSM's thickness for the materials that read a table.
pub fn tsm_instead_of_tables(scene: &Scene) -> bool {
    level(scene).tsm
}

/// The frame budget's levels (module docs); none without a lit translucent instance, and no TSM
/// level without an instance that reads a table.
pub fn budget_levels(scene: &Scene) -> Vec<QualityLevel> {
    let bounds = mesh_bounds(scene);
    let Some(view) = LightView::fit_with(scene, &bounds) else { return Vec::new() };
    let (mut sigma, mut diameter, mut baked) = (0.0f64, 0.0f64, false);
    for inst in &scene.instances {
        if let MaterialKind::Translucent { sigma: s, thickness, .. } = scene.materials[inst.material].kind {
            sigma = sigma.max(s.max_element());
            if thickness.is_baked() {
                baked = true;
                // The mesh box's diagonal stretched by at most ‖M‖_F (the linear part).
                let (lo, hi) = bounds[inst.mesh];
                let stretch = frobenius(glam::DMat3::from_mat4(inst.transform.matrix));
                diameter = diameter.max((hi - lo).length() * stretch);
            }
        }
    }
    let size_0 = light_map_size_at(scene, &bounds, Some(&view), BUDGET_LEVELS[0].texel_voxels) as f64;
    let finite = |e: f64| if e.is_finite() { e } else { f64::MAX };
    BUDGET_LEVELS
        .iter()
        .filter(|l| baked || !l.tsm)
        .map(|l| {
            let size = light_map_size_at(scene, &bounds, Some(&view), l.texel_voxels);
            let light_id = LIGHT_ID_SHARE * (size as f64 / size_0).powi(2);
            let texel = 2.0 * view.radius / size as f64;
            let map = (sigma * 1.5 * std::f64::consts::SQRT_2 * texel).exp_m1();
            if l.tsm {
                let cavities = -(-sigma * diameter).exp_m1();
                let hint = light_id + (1.0 - LIGHT_ID_SHARE) * TSM_PASS_SHARE;
                let name = format!("texel {} voxel, tsm", l.texel_voxels);
                QualityLevel::new(name, finite((1.0 + map) * (1.0 + cavities) - 1.0), hint)
            } else {
                let hint = light_id + (1.0 - LIGHT_ID_SHARE);
                QualityLevel::new(format!("texel {} voxel", l.texel_voxels), finite(map), hint)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::translucency::light_map_size;
    use crate::scene::ThicknessMode;

    /// Errors rise as the map's side halves (down to its smallest), TSM last; the level on the
    /// scene sizes the map; no lit translucent instance, no levels; no table read, no TSM level.
    #[test]
    fn levels_halve_the_map_then_take_tsm() {
        let mut scene = crate::builtin::scene("budget").unwrap();
        let levels = budget_levels(&scene);
        assert_eq!(levels.len(), BUDGET_LEVELS.len());
        assert!(QualityLevel::check(&levels).is_ok(), "{levels:?}");
        assert_eq!(levels[0].cost_hint, 1.0);
        let mut sizes = Vec::new();
        for l in 0..levels.len() {
            scene.quality.set(NAME, Some(l));
            sizes.push(light_map_size(&scene));
            assert_eq!(tsm_instead_of_tables(&scene), l == 4);
        }
        assert_eq!(sizes, [3584, 1792, 1024, 512, 512], "{levels:?}");
        assert!(levels.windows(2).all(|w| w[1].error > w[0].error && w[1].cost_hint < w[0].cost_hint));
        // TSM's share on the budget scene: 1.5-unit cubes, σ_max 3: 1 − e^(−3·1.5·√3) ≈ 1.
        assert!(levels[4].error > 0.99 && levels[4].error < 1.0 + 2.0 * levels[3].error, "{levels:?}");
        scene.quality.set(NAME, None);
        assert_eq!(light_map_size(&scene), 3584, "no level: the default texel");
        for m in &mut scene.materials {
            if let MaterialKind::Translucent { thickness, .. } = &mut m.kind {
                *thickness = ThicknessMode::Tsm;
            }
        }
        assert_eq!(budget_levels(&scene).len(), 4, "nothing reads a table: no TSM level");
        scene.lights.clear();
        assert!(budget_levels(&scene).is_empty());
    }
}
