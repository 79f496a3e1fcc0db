//! Translucency (seed 003): the thickness LUT at several voxel resolutions against the TSM
//! baseline on assets/scenes/translucency.toml, with peel and the seed's own pair table. Per variant: pass times, LUT bytes and bake
//! seconds, the GPU thickness against the exact f64 thickness (`effects::thickness`) at the
//! GPU's own shaded point, and the colour against the f64 shading (`effects::translucency`).

use std::time::Instant;

use glam::DVec3;

use crate::profile::Summary;
use hadou::bake::bake_cache::BakeCache;
use hadou::bake::thickness_lut::{bake, BakeOptions};
use hadou::bake::thickness_pairs::{self, PairOptions};
use hadou::reference::{exact_thickness, tsm_thickness};
use hadou::reference::{exit_weight, light_map_size, peel_image_bytes, translucent_colour};
use hadou::reference::{MeshBvh, SceneCaster};
use hadou::scene::{MaterialKind, Scene, ThicknessMode};
use hadou::{Aov, Error, FrameRequest, Runtime};

use super::ceilings::Ceilings;
use super::costs::{self, FRACTION_COLUMNS};
use super::plot::{Plot, PlotPoint};
use super::table::{Cell, Fmt, Table};
use super::{ReportError, ReportOptions, Section, Steps};

/// `scene` with every translucent material's thickness taken by `mode`.
pub fn with_thickness(mut scene: Scene, mode: ThicknessMode) -> Scene {
    for m in &mut scene.materials {
        if let MaterialKind::Translucent { thickness, .. } = &mut m.kind {
            *thickness = mode;
        }
    }
    scene
}

/// `scene` with every translucent material baked at `res`³.
pub fn with_voxel_res(mut scene: Scene, res: u32) -> Scene {
    for m in &mut scene.materials {
        if let MaterialKind::Translucent { voxel_res, .. } = &mut m.kind {
            *voxel_res = res;
        }
    }
    scene
}

/// The world voxel edge of a translucent instance: its mesh's object voxel edge (the bounding
/// box's longest side / res) times ∛|det M| (the edge of a cube of a voxel's transformed volume).
pub fn world_voxel(scene: &Scene, instance: usize) -> Option<f64> {
    let inst = &scene.instances[instance];
    let MaterialKind::Translucent { voxel_res, .. } = scene.materials[inst.material].kind else {
        return None;
    };
    let (lo, hi) = scene.meshes[inst.mesh].mesh.bounds();
    let h = (hi - lo).max_element() / voxel_res as f64;
    Some(h * inst.transform.matrix.determinant().abs().cbrt())
}

/// A translucent pixel with its f64 references.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub pixel: usize,
    pub instance: usize,
    /// The shaded point, placed by the GPU's depth.
    pub point: DVec3,
    pub gpu: f64,
    pub exact: f64,
    pub tsm: f64,
}

/// The most pixels [`sample_set`] may leave out, as a share of the pixels with a finite GPU
/// thickness. Left out are pixels where the f32 raster and the f64 cast see different surfaces:
/// a silhouette rim as wide as the raster's 1/256-pixel snap (a negligible share), and surfaces
/// seen steeper than [`same_surface`] covers (cos θ < ¼, where f32 coordinates far from the origin
/// can move the depth beyond it): on a sphere's disc the share 1 − (√15/4)² = 1/16.
pub const MAX_SKIPPED_SHARE: f64 = 1.0 / 16.0;

/// Whether an f64 hit at `t` along a pixel's centre ray is the surface the GPU drew at depth
/// `depth` (both distances from the camera at `camera`). The raster snaps to 1/256 pixel, which
/// moves the depth by ≤ d·α/256·tan θ (α the pixel's angle, θ the incidence): ≤ 1e-3·d for
/// α ≤ 8e-3 rad up to tan θ = 32. The f32 coordinates (|x| ≤ |C| + d, rounded to 2⁻²⁴ of that,
/// a few more ulps through the transforms: ≤ 8 ulps) move it by ≤ 2⁻²¹·(|C| + d)/cos θ: 2⁻¹⁹·(|C| + d)
/// up to cos θ = ¼ (far from the origin this dominates). Steeper pixels are left out as rims.
pub fn same_surface(t: f64, depth: f64, camera: DVec3) -> bool {
    (t - depth).abs() <= 1e-3 * depth + 2f64.powi(-19) * (camera.length() + depth)
}

/// A frame's translucent pixels with their f64 references, and how many were left out.
#[derive(Clone, Debug, Default)]
pub struct SampleSet {
    pub samples: Vec<Sample>,
    /// Pixels with a finite GPU thickness whose centre ray hits, in f64, no translucent surface at
    /// the GPU's depth (silhouettes; see [`MAX_SKIPPED_SHARE`]).
    pub skipped: usize,
}

impl SampleSet {
    /// The share of the pixels with a finite GPU thickness that were left out (0 for none).
    pub fn skipped_share(&self) -> f64 {
        let looked_at = self.samples.len() + self.skipped;
        if looked_at == 0 {
            0.0
        } else {
            self.skipped as f64 / looked_at as f64
        }
    }

    /// `Ok(summary)` when at most [`MAX_SKIPPED_SHARE`] of the pixels were left out and at least
    /// `min_compared` are samples; otherwise what failed.
    pub fn check(&self, min_compared: usize) -> Result<String, String> {
        let summary = format!(
            "{} translucent pixels compared, {} left out (share {:.4}, at most {MAX_SKIPPED_SHARE})",
            self.samples.len(),
            self.skipped,
            self.skipped_share()
        );
        if self.samples.len() < min_compared {
            Err(format!("{summary}: fewer than the {min_compared} needed"))
        } else if self.skipped_share() > MAX_SKIPPED_SHARE {
            Err(format!("{summary}: too many left out"))
        } else {
            Ok(summary)
        }
    }

    /// Panics unless [`SampleSet::check`] holds; returns the summary.
    #[track_caller]
    pub fn assert_usable(&self, min_compared: usize) -> String {
        self.check(min_compared).unwrap_or_else(|e| panic!("{e}"))
    }
}

/// Every pixel with a finite GPU thickness whose centre ray hits, in f64, a translucent instance
/// at the GPU's depth ([`same_surface`]); pixels on silhouettes, where the two disagree, are
/// counted and left out (bound them with [`SampleSet::check`]). Only the thickness is compared,
/// not the raster. A NaN or −∞ thickness, or a non-finite depth under a finite thickness, is an
/// error naming the pixel: never left out, never a sample.
pub fn sample_set(
    scene: &Scene,
    size: (u32, u32),
    thickness: &[f32],
    depth: &[f32],
) -> Result<SampleSet, Error> {
    let meshes: Vec<_> = scene.meshes.iter().map(|m| m.mesh.clone()).collect();
    let instances: Vec<_> = scene.instances.iter().map(|i| (i.mesh, i.transform)).collect();
    let mesh_error = |e: hadou::scene::mesh::MeshError| Error::Report(format!("reference ray caster: {e}"));
    let caster = SceneCaster::new(&meshes, &instances).map_err(mesh_error)?;
    let bvhs = meshes.iter().map(MeshBvh::new).collect::<Result<Vec<_>, _>>().map_err(mesh_error)?;
    let mut set = SampleSet::default();
    let Some(light) = scene.lights.first() else { return Ok(set) };
    let toward_light = -light.direction;
    for y in 0..size.1 {
        for x in 0..size.0 {
            let i = (y * size.0 + x) as usize;
            let gpu = thickness[i] as f64;
            if gpu == f64::INFINITY {
                continue;
            }
            let d = depth[i] as f64;
            if !gpu.is_finite() || !d.is_finite() {
                return Err(Error::Report(format!("pixel ({x}, {y}): GPU thickness {gpu}, depth {d}")));
            }
            let (o, u) = scene.camera.pixel_ray(x, y, size.0, size.1);
            let Some(hit) = caster.cast(o, u).filter(|h| same_surface(h.t, d, o)) else {
                set.skipped += 1;
                continue;
            };
            let inst = &scene.instances[hit.instance];
            if !matches!(scene.materials[inst.material].kind, MaterialKind::Translucent { .. }) {
                set.skipped += 1;
                continue;
            }
            let point = o + u * d;
            let bvh = &bvhs[inst.mesh];
            let exact = exact_thickness(bvh, &inst.transform, point, toward_light);
            let tsm = tsm_thickness(bvh, &inst.transform, point, toward_light);
            set.samples.push(Sample { pixel: i, instance: hit.instance, point, gpu, exact, tsm });
        }
    }
    Ok(set)
}

/// [`sample_set`] as (samples, pixels left out), without the bound on what was left out.
pub fn samples(
    scene: &Scene,
    size: (u32, u32),
    thickness: &[f32],
    depth: &[f32],
) -> Result<(Vec<Sample>, usize), Error> {
    sample_set(scene, size, thickness, depth).map(|s| (s.samples, s.skipped))
}

/// (mean, nearest-rank p95, max) of |values|; NaN for none. A NaN value sorts last: it is the max.
pub fn abs_stats(values: impl IntoIterator<Item = f64>) -> (f64, f64, f64) {
    let mut v: Vec<f64> = values.into_iter().map(f64::abs).collect();
    if v.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    v.sort_by(f64::total_cmp);
    let p95 = v[((v.len() as f64 * 0.95).ceil() as usize).clamp(1, v.len()) - 1];
    (v.iter().sum::<f64>() / v.len() as f64, p95, v[v.len() - 1])
}

/// One variant's frame: pass times and the AOVs the errors need.
struct Rendered {
    light_id_ms: f64,
    /// The peel pass (bake-free variant), NaN where it did not run.
    peel_ms: f64,
    translucency_ms: f64,
    thickness: Vec<f32>,
    depth: Vec<f32>,
    hdr: Vec<f32>,
    normal: Vec<f32>,
}

fn render(
    runtime: &mut Runtime,
    scene: &Scene,
    opts: &ReportOptions,
    aovs: Vec<Aov>,
) -> Result<Rendered, Error> {
    runtime.load_scene(scene.clone())?;
    let (w, h) = opts.effect_size;
    let mut req = FrameRequest::new(w, h);
    req.color = false;
    let (mut light_id, mut peel, mut pass) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..opts.warmup + opts.frames {
        let stats = runtime.render(&req)?.stats;
        if i >= opts.warmup {
            for p in &stats.passes {
                match p.name.as_str() {
                    "light_id" => light_id.push(p.gpu_ms),
                    "peel" => peel.push(p.gpu_ms),
                    "translucency" => pass.push(p.gpu_ms),
                    _ => {}
                }
            }
        }
    }
    req.aovs = aovs;
    let frame = runtime.render(&req)?;
    let n = (w * h) as usize;
    let get = |aov: Aov, channels: usize| {
        frame.aov(aov).map_or(vec![f32::INFINITY; n * channels], |a| a.data.clone())
    };
    let p50 = |v: &[f64]| Summary::of(v).map_or(f64::NAN, |s| s.p50);
    Ok(Rendered {
        light_id_ms: p50(&light_id),
        peel_ms: p50(&peel),
        translucency_ms: p50(&pass),
        thickness: get(Aov::Thickness, 1),
        depth: get(Aov::Depth, 1),
        hdr: get(Aov::Hdr, 4),
        normal: get(Aov::Normal, 4),
    })
}

/// Bakes every LUT the scene uses (timed, the sum over its meshes) and stores them in the bake
/// cache when there is one, so loading the scene does not bake again. Returns (seconds, bytes).
fn bake_all(scene: &Scene) -> Result<(f64, usize), Error> {
    let mut keys: Vec<(usize, u32)> = Vec::new();
    for inst in &scene.instances {
        if let MaterialKind::Translucent { voxel_res, thickness: ThicknessMode::Lut, .. } =
            scene.materials[inst.material].kind
        {
            if !keys.contains(&(inst.mesh, voxel_res)) {
                keys.push((inst.mesh, voxel_res));
            }
        }
    }
    let options = BakeOptions::default();
    let cache = BakeCache::from_env();
    let (mut seconds, mut bytes) = (0.0, 0);
    for (mesh, res) in keys {
        let m = &scene.meshes[mesh];
        let start = Instant::now();
        let (lut, _) = bake(&m.mesh, res, &options, &|_, _| {})
            .map_err(|e| Error::Report(format!("thickness LUT of mesh \"{}\" at {res}³: {e}", m.name)))?;
        seconds += start.elapsed().as_secs_f64();
        bytes += lut.bytes();
        if let Some(cache) = &cache {
            if let Err(e) = cache.store(&m.mesh, &lut) {
                log::warn!("bake cache not written: {e}");
            }
        }
    }
    Ok((seconds, bytes))
}

/// Bakes every pair table (`thickness = "pairs"`) the scene uses, timed (the sum over its meshes),
/// and stores them in the bake cache when there is one. Returns (seconds, bytes: the tables' N²
/// and their lookups' words).
fn bake_all_pairs(scene: &Scene) -> Result<(f64, usize), Error> {
    let mut keys: Vec<(usize, u32)> = Vec::new();
    for inst in &scene.instances {
        if let MaterialKind::Translucent { voxel_res, thickness: ThicknessMode::Pairs, .. } =
            scene.materials[inst.material].kind
        {
            if !keys.contains(&(inst.mesh, voxel_res)) {
                keys.push((inst.mesh, voxel_res));
            }
        }
    }
    let options = PairOptions::default();
    let cache = BakeCache::from_env();
    let (mut seconds, mut bytes) = (0.0, 0);
    for (mesh, res) in keys {
        let m = &scene.meshes[mesh];
        let start = Instant::now();
        let (table, _) = thickness_pairs::bake(&m.mesh, res, &options, &|_, _| {}).map_err(|e| {
            Error::Report(format!("thickness pair table of mesh \"{}\" at {res}³: {e}", m.name))
        })?;
        seconds += start.elapsed().as_secs_f64();
        bytes += table.gpu_bytes() as usize;
        if let Some(cache) = &cache {
            if let Err(e) = cache.store_pairs(&m.mesh, &table) {
                log::warn!("bake cache not written: {e}");
            }
        }
    }
    Ok((seconds, bytes))
}

/// Errors of one variant against the f64 references.
struct Errors {
    pixels: usize,
    /// Mean length of the pixels' light paths (the TSM distance), in voxels of their instance.
    path_voxels: f64,
    /// |d − d*| in voxels of each pixel's instance (mean, p95, max), then in world units.
    voxels: (f64, f64, f64),
    world: (f64, f64, f64),
    /// Largest channel of |HDR − f64 colour| per pixel (mean, p95, max).
    colour: (f64, f64, f64),
}

fn errors(scene: &Scene, opts: &ReportOptions, r: &Rendered, surface: &[f32]) -> Result<Errors, Error> {
    let set = sample_set(scene, opts.effect_size, &r.thickness, &r.depth)?;
    // Errors over silhouettes alone would be no measurement: the share left out is bounded, and
    // there must be pixels to measure.
    set.check(1).map_err(|e| Error::Report(format!("translucency errors: {e}")))?;
    let samples = set.samples;
    let voxel = |s: &Sample| world_voxel(scene, s.instance).unwrap_or(f64::NAN);
    let light = scene.lights.first();
    let colour = samples.iter().map(|s| {
        let Some(light) = light else { return 0.0 };
        let inst = &scene.instances[s.instance];
        let mat = &scene.materials[inst.material];
        let MaterialKind::Translucent { sigma, .. } = mat.kind else { return f64::NAN };
        let px = |img: &[f32]| {
            DVec3::new(img[s.pixel * 4] as f64, img[s.pixel * 4 + 1] as f64, img[s.pixel * 4 + 2] as f64)
        };
        let w = exit_weight(px(&r.normal), light.direction);
        let cpu =
            translucent_colour(px(surface), light.color * light.intensity, mat.albedo, sigma, s.exact, w);
        // The largest channel, NaN when any channel is (`max_element` would drop it).
        let e = (px(&r.hdr) - cpu).abs();
        if e.is_nan() {
            f64::NAN
        } else {
            e.max_element()
        }
    });
    let paths: f64 = samples.iter().map(|s| s.tsm / voxel(s)).filter(|v| v.is_finite()).sum();
    Ok(Errors {
        pixels: samples.len(),
        path_voxels: if samples.is_empty() { 0.0 } else { paths / samples.len() as f64 },
        voxels: abs_stats(samples.iter().map(|s| (s.gpu - s.exact) / voxel(s))),
        world: abs_stats(samples.iter().map(|s| s.gpu - s.exact)),
        colour: abs_stats(colour.collect::<Vec<_>>()),
    })
}

pub fn section(
    runtime: &mut Runtime,
    opts: &ReportOptions,
    ceilings: &Ceilings,
    steps: &mut Steps,
) -> Result<Section, ReportError> {
    let path = opts.scene("translucency.toml");
    let base = opts.load_scene("translucency.toml")?;
    let aovs = vec![Aov::Thickness, Aov::Depth, Aov::Hdr, Aov::Normal];
    // The surface term alone: the same scene with every material lambert.
    steps.next("translucency: surface reference");
    let mut lambert = base.clone();
    lambert.materials.iter_mut().for_each(|m| m.kind = MaterialKind::Lambert);
    let surface = render(runtime, &lambert, opts, vec![Aov::Hdr])?.hdr;
    let mut columns = vec![
        "variant",
        "voxel res",
        "light map",
        "memory bytes",
        "bake s",
        "light_id ms",
        "peel ms",
        "translucency ms",
        "pixels",
        "thickness err mean (voxels)",
        "p95 (voxels)",
        "max (voxels)",
        "thickness err mean (world)",
        "p95 (world)",
        "max (world)",
        "colour err mean",
        "colour p95",
        "colour max",
    ];
    columns.extend(FRACTION_COLUMNS);
    let mut table = Table::new("translucency", "Translucency: thickness LUT vs peel vs TSM", &columns);
    let mut plot = Plot {
        id: "translucency".into(),
        title: format!(
            "Translucency, {}×{}: pass time against p95 thickness error",
            opts.effect_size.0, opts.effect_size.1
        ),
        x_label: "light_id + peel + translucency ms (p50)".into(),
        y_label: "p95 |thickness error| (world units)".into(),
        series: vec!["LUT".into(), "TSM".into(), "peel".into(), "pairs (seed's LUT)".into()],
        points: Vec::new(),
    };
    let mut variants: Vec<(ThicknessMode, Option<u32>)> =
        opts.voxel_res.iter().map(|&r| (ThicknessMode::Lut, Some(r))).collect();
    variants.extend(opts.peel_res.iter().map(|&r| (ThicknessMode::Peel, Some(r))));
    variants.extend(opts.pairs_res.iter().map(|&r| (ThicknessMode::Pairs, Some(r))));
    variants.push((ThicknessMode::Tsm, None));
    let pixels = opts.effect_size.0 as f64 * opts.effect_size.1 as f64;
    for (mode, res) in variants {
        let scene = with_thickness(res.map_or(base.clone(), |r| with_voxel_res(base.clone(), r)), mode);
        let map = light_map_size(&scene);
        let label = match (mode, res) {
            (ThicknessMode::Lut, Some(r)) => format!("lut {r}"),
            (ThicknessMode::Peel, Some(r)) => format!("peel {r}"),
            (ThicknessMode::Pairs, Some(r)) => format!("pairs {r}"),
            _ => "tsm".to_string(),
        };
        steps.next(&format!("translucency: {label}"));
        // (bake seconds, bytes): the LUT's tables, or the peel pass's per-frame lists (no bake).
        let memory = match mode {
            ThicknessMode::Lut => Some(bake_all(&scene)?),
            ThicknessMode::Pairs => Some(bake_all_pairs(&scene)?),
            ThicknessMode::Peel => Some((0.0, peel_image_bytes(map) as usize)),
            ThicknessMode::Tsm => None,
        };
        let r = render(runtime, &scene, opts, aovs.clone())?;
        let e = errors(&scene, opts, &r, &surface)?;
        let coverage = e.pixels as f64 / pixels;
        let num = Cell::Num;
        let ms = |v: f64| if v.is_nan() { Cell::Missing } else { num(v, Fmt::Fixed(3)) };
        let mut row = vec![
            Cell::text(&label),
            res.map_or(Cell::Missing, |r| num(r as f64, Fmt::Int)),
            num(map as f64, Fmt::Int),
            memory.map_or(Cell::Missing, |b| num(b.1 as f64, Fmt::Int)),
            match (mode, memory) {
                (ThicknessMode::Lut | ThicknessMode::Pairs, Some(b)) => num(b.0, Fmt::Fixed(2)),
                _ => Cell::Missing,
            },
            ms(r.light_id_ms),
            ms(r.peel_ms),
            ms(r.translucency_ms),
            num(e.pixels as f64, Fmt::Int),
            num(e.voxels.0, Fmt::Fixed(3)),
            num(e.voxels.1, Fmt::Fixed(3)),
            num(e.voxels.2, Fmt::Fixed(2)),
            num(e.world.0, Fmt::Sci(2)),
            num(e.world.1, Fmt::Sci(2)),
            num(e.world.2, Fmt::Sci(2)),
            num(e.colour.0, Fmt::Sci(2)),
            num(e.colour.1, Fmt::Sci(2)),
            num(e.colour.2, Fmt::Sci(2)),
        ];
        row.extend(costs::fraction_cells(
            // Two field samples a voxel of path for the LUT (MAX_STEP_VOXELS = ½), none for TSM and peel.
            Some(costs::translucency(
                coverage,
                if matches!(mode, ThicknessMode::Lut) { 2.0 * e.path_voxels + 2.0 } else { 0.0 },
            )),
            pixels,
            r.translucency_ms,
            ceilings,
        ));
        table.push(row);
        let peel_ms = if r.peel_ms.is_nan() { 0.0 } else { r.peel_ms };
        plot.points.push(PlotPoint {
            label: label.clone(),
            x: r.light_id_ms + peel_ms + r.translucency_ms,
            y: e.world.1,
            series: match mode {
                ThicknessMode::Lut => 0,
                ThicknessMode::Tsm => 1,
                ThicknessMode::Peel => 2,
                ThicknessMode::Pairs => 3,
            },
        });
    }
    let text = format!(
        "`{}` (cavity cube, upright torus, bottle; back-lit) at {}×{}, every translucent material at the \
         row's voxel resolution (the scene file's own resolutions are not used). Thickness errors are \
         |GPU thickness − exact f64 thickness| per translucent pixel at the GPU's own shaded point, in voxel \
         edges of the pixel's instance (mesh bounding box / res, times ∛|det M|) and in world units; \
         silhouette pixels where the f64 ray hits another surface are left out. Colour error: the largest \
         channel of |HDR − f64 colour| (the lambert render's surface term plus the transmitted light with the \
         exact thickness, `effects::translucency::translucent_colour`), in linear HDR units; it includes \
         RGBA16F rounding (2⁻¹⁰ relative). LUT bytes: the row's thickness fields (2 bytes a grid corner, 1 a cell). Bake s: wall \
         seconds of baking every table of the row (all cores), before the frames. Peel rows (`thickness = \"peel\"`, no bake): the voxel resolution only sizes the \
         light map (texels of ¼ voxel), and their memory is the pass's crossing lists and counts \
         (`reference::peel_image_bytes`), allocated for every frame; the light_id maps (the light map's \
         size, all rows) are not counted. The TSM row has neither. Pairs rows (`thickness = \"pairs\"`, \
         the seed's own LUT, `effects::thickness_pairs`): every pair of surface voxels' thickness in an \
         N×N R8 image; bytes are the tables' N² plus a 4-byte word a grid voxel and a surface voxel \
         (the lookups), bake s casts every pair in f64.",
        path.display(),
        opts.effect_size.0,
        opts.effect_size.1
    );
    Ok(Section {
        id: "translucency",
        title: "Translucency".into(),
        text,
        tables: vec![table],
        plots: vec![plot],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Sample {
        Sample { pixel: 0, instance: 0, point: DVec3::ZERO, gpu: 1.0, exact: 1.0, tsm: 1.0 }
    }

    #[test]
    fn what_is_left_out_is_capped_and_what_is_compared_has_a_floor() {
        let set = SampleSet { samples: vec![sample(); 15], skipped: 1 };
        assert!(set.check(15).is_ok(), "1 of 16 is the cap");
        assert!(set.check(16).unwrap_err().contains("fewer"));
        let set = SampleSet { samples: vec![sample(); 14], skipped: 1 };
        assert!(set.check(1).unwrap_err().contains("too many"));
        assert_eq!(SampleSet::default().skipped_share(), 0.0);
        assert!(SampleSet::default().check(1).is_err());
    }

    #[test]
    fn a_nan_from_the_gpu_is_an_error_never_a_skip() {
        let text = r#"
            [camera]
            position = [0, 0, 5]
            look_at = [0, 0, 0]
            [[light]]
            direction = [0, 0, 1]
            [[mesh]]
            name = "box"
            kind = "cube"
            [[material]]
            name = "jade"
            kind = "translucent"
            sigma = [1, 1, 1]
            [[instance]]
            mesh = "box"
            material = "jade"
        "#;
        let scene = hadou::scene::parse_scene(text, std::path::Path::new("inline.toml")).unwrap();
        let inf = f32::INFINITY;
        let err = sample_set(&scene, (2, 1), &[inf, f32::NAN], &[4.0, 4.0]).unwrap_err().to_string();
        assert!(err.contains("pixel (1, 0)"), "{err}");
        assert!(sample_set(&scene, (2, 1), &[inf, 1.0], &[4.0, f32::NAN]).is_err());
        // No thickness: nothing to compare, whatever the depth.
        assert!(sample_set(&scene, (2, 1), &[inf, inf], &[f32::NAN, 4.0]).unwrap().samples.is_empty());
    }

    #[test]
    fn the_same_surface_allows_f32_coordinates_far_out() {
        // Near the origin the 1e-3 relative term: 4 mm at 4 units.
        assert!(same_surface(4.003, 4.0, DVec3::ZERO) && !same_surface(4.005, 4.0, DVec3::ZERO));
        // 10⁵ out, 2⁻¹⁹·10⁵ ≈ 0.19 more.
        let far = DVec3::new(1e5, 0.0, 0.0);
        assert!(same_surface(4.19, 4.0, far) && !same_surface(4.2, 4.0, far));
    }
}
