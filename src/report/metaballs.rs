//! Metaballs (seed 000): the ray-cast pass against the f64 reference per pixel of
//! assets/scenes/metaballs.toml, through `effects::metaballs_compare` (the comparison the GPU
//! tests use): pass time, the share of pixels where the GPU and the reference disagree on a hit,
//! and the depth error on the pixels both hit; pixels in the f32 tangency band are counted apart.
//! Variants: Bézier clipping (the pass's default and coarser stopping tolerances) and the
//! sphere-tracing baseline at several step budgets, each group's `method` set as a scene file's
//! `method`/`tolerance`/`steps` would.

use crate::profile::Summary;
use hadou::reference::{compare_metaballs, MetaballErrorStats, MetaballFrame};
use hadou::scene::CastMethod;
use hadou::scene::Scene;
use hadou::{Aov, AovImage, Error, FrameRequest, Runtime};

use super::plot::{Plot, PlotPoint};
use super::table::{Cell, Fmt, Table};
use super::{ReportError, ReportOptions, Section, Steps};

/// Bézier-clipping stopping tolerances (world distance along the ray) besides the default.
const TOLERANCES: [f64; 4] = [1e-1, 1e-2, 1e-3, 1e-4];
/// Sphere-tracing step budgets.
const TRACE_STEPS: [u32; 4] = [16, 64, 256, 1024];

/// The variants measured, by name: the CSV's `variant` column.
pub fn variant_methods() -> Vec<(String, CastMethod)> {
    let mut out = vec![("bezier (default)".to_string(), CastMethod::default())];
    out.extend(
        TOLERANCES.iter().map(|&t| (format!("bezier tol {t:e}"), CastMethod::Bezier { tolerance: t })),
    );
    out.extend(
        TRACE_STEPS.iter().map(|&n| (format!("sphere_trace {n}"), CastMethod::SphereTrace { steps: n })),
    );
    out
}

/// `scene` with every group cast by `method`.
fn with_method(scene: &Scene, method: CastMethod) -> Scene {
    let mut s = scene.clone();
    s.metaballs_mut().iter_mut().for_each(|g| g.method = method);
    s
}

/// Progress steps of this section: the raster reference, then one per variant.
pub const STEPS: usize = 1 + 1 + TOLERANCES.len() + TRACE_STEPS.len();

/// One variant's speed and agreement with the f64 reference.
#[derive(Clone, Debug, PartialEq)]
pub struct Measured {
    pub p50_ms: f64,
    pub errors: MetaballErrorStats,
}

fn depth(runtime: &mut Runtime, scene: &Scene, size: (u32, u32)) -> Result<AovImage, Error> {
    runtime.load_scene(scene.clone())?;
    let mut req = FrameRequest::new(size.0, size.1);
    req.color = false;
    req.aovs = vec![Aov::Depth];
    let frame = runtime.render(&req)?;
    frame.aov(Aov::Depth).cloned().ok_or_else(|| Error::Report("no depth AOV".into()))
}

/// Times the metaballs pass of `scene` and compares its depth with the f64 cast
/// (`effects::metaballs_compare::compare_metaballs`), the rays clipped at `raster` (the depth of
/// the same scene without metaballs: the pass's t_max).
pub fn measure(
    runtime: &mut Runtime,
    scene: &Scene,
    raster: &AovImage,
    opts: &ReportOptions,
) -> Result<Measured, Error> {
    let (w, h) = opts.effect_size;
    runtime.load_scene(scene.clone())?;
    let mut req = FrameRequest::new(w, h);
    req.color = false;
    let mut times = Vec::new();
    for i in 0..opts.warmup + opts.frames {
        let stats = runtime.render(&req)?.stats;
        if i >= opts.warmup {
            times.extend(stats.passes.iter().filter(|p| p.name == "metaballs").map(|p| p.gpu_ms));
        }
    }
    let gpu = depth(runtime, scene, opts.effect_size)?;
    let frame = MetaballFrame { depth: &gpu, raster_depth: raster, normal: None };
    let errors = compare_metaballs(scene, 0.0, frame).map_err(Error::Report)?;
    Ok(Measured { p50_ms: Summary::of(&times).map_or(f64::NAN, |s| s.p50), errors })
}

pub fn section(
    runtime: &mut Runtime,
    opts: &ReportOptions,
    steps: &mut Steps,
) -> Result<Section, ReportError> {
    let path = opts.scene("metaballs.toml");
    let scene = opts.load_scene("metaballs.toml")?;
    steps.next("metaballs: raster reference");
    let mut bare = scene.clone();
    bare.metaballs_mut().clear();
    bare.waves_mut().clear();
    let raster = depth(runtime, &bare, opts.effect_size)?;
    let mut table = Table::new(
        "metaballs",
        "Metaballs: pass time and agreement with the f64 cast",
        &[
            "variant",
            "pass ms p50",
            "gpu hit pixels",
            "reference hit pixels",
            "tangency-band pixels",
            "hit mismatch %",
            "depth max rel err",
            "depth p99 rel err",
        ],
    );
    let mut plot = Plot {
        id: "metaballs".into(),
        title: format!(
            "Metaballs, {}×{}: pass time against depth error",
            opts.effect_size.0, opts.effect_size.1
        ),
        x_label: "pass ms (p50)".into(),
        y_label: "p99 relative depth error".into(),
        series: vec!["Bézier clipping".into(), "sphere tracing".into()],
        points: Vec::new(),
    };
    // Depth error is measured on the pixels both hit: a cast that misses pixels can look exact
    // there. The second plot shows what it missed.
    let mut missed = Plot {
        id: "metaballs_mismatch".into(),
        title: format!(
            "Metaballs, {}×{}: pass time against hit mismatch",
            opts.effect_size.0, opts.effect_size.1
        ),
        y_label: "hit mismatch (% of pixels)".into(),
        points: Vec::new(),
        ..plot.clone()
    };
    for (label, method) in variant_methods() {
        steps.next(&format!("metaballs: {label}"));
        let m = measure(runtime, &with_method(&scene, method), &raster, opts)?;
        let series = usize::from(matches!(method, CastMethod::SphereTrace { .. }));
        let e = &m.errors;
        table.push(vec![
            Cell::text(&label),
            Cell::Num(m.p50_ms, Fmt::Fixed(3)),
            Cell::Num(e.gpu_hits as f64, Fmt::Int),
            Cell::Num(e.ref_hits as f64, Fmt::Int),
            Cell::Num(e.band as f64, Fmt::Int),
            Cell::Num(e.mismatch_percent, Fmt::Fixed(3)),
            Cell::Num(e.depth_max_rel, Fmt::Sci(1)),
            Cell::Num(e.depth_p99_rel, Fmt::Sci(1)),
        ]);
        let mismatch = m.errors.mismatch_percent;
        missed.points.push(PlotPoint { label: label.clone(), x: m.p50_ms, y: mismatch, series });
        plot.points.push(PlotPoint { label, x: m.p50_ms, y: m.errors.depth_p99_rel, series });
    }
    let text = format!(
        "`{}` at {}×{}, time 0. Per pixel the GPU depth is compared with the f64 cast \
         (`effects::metaballs_compare::compare_metaballs`: `effects::metaballs::cast`) of every group along the pixel ray from the near plane to the \
         raster's distance (the same scene rendered without metaballs). A pixel is a GPU hit where the \
         metaballs pass changed the depth. Pixels in the f32 tangency band are counted apart and left out \
         of the mismatch and depth figures. Variants: Bézier clipping with its default stopping width \
         (2⁻²² of each interval) and coarser world tolerances, and sphere tracing with a step budget \
         (`method`, `tolerance`, `steps` of `[[metaballs]]`). The reference is always the f64 Bézier \
         cast. A pixel whose sphere trace runs out of steps shows as a mismatch where the reference hits.",
        path.display(),
        opts.effect_size.0,
        opts.effect_size.1
    );
    Ok(Section {
        id: "metaballs",
        title: "Metaballs".into(),
        text,
        tables: vec![table],
        plots: vec![plot, missed],
    })
}
