//! Energy wave (seed 004): the closed-form pass against the ray-marched baseline at N steps, each
//! timed over frames and compared per pixel with the f64 reference integrated to the GPU's own
//! depth. `examples/energy_wave_bench.rs` prints its tables from the same `measure`.

use crate::profile::Summary;
use hadou::reference::line_integral;
use hadou::reference::wave_params;
use hadou::scene::{Scene, WaveMethod};
use hadou::{Aov, Error, FrameRequest, Runtime};

use super::ceilings::Ceilings;
use super::costs::{self, FRACTION_COLUMNS};
use super::plot::{Plot, PlotPoint};
use super::table::{Cell, Fmt, Table};
use super::{ReportError, ReportOptions, Section, Steps};

/// The scene time the variants are measured at (the seed's second figure).
pub const TIME: f64 = 1.0;

/// One variant's speed and error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measured {
    /// p50 of the `energy_wave` pass's GPU time over the measured frames.
    pub p50_ms: f64,
    /// Largest and 99th-percentile per-pixel relative error |H − H*| / H* (|H| where H* = 0).
    pub max_rel: f64,
    pub p99_rel: f64,
}

/// H* per pixel: the f64 closed form summed over the scene's waves along each pixel ray, up to the
/// given per-pixel depth (clipped at the camera's far distance).
pub fn reference(scene: &Scene, depth: &[f32], w: u32, h: u32, time: f64) -> Vec<f64> {
    let states: Vec<_> = scene.waves().iter().map(|wave| wave_params(&wave.at(time))).collect();
    let cam = &scene.camera;
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (o, u) = cam.pixel_ray(x, y, w, h);
            let l = (depth[(y * w + x) as usize] as f64).min(cam.far);
            states.iter().map(|p| line_integral(p, o, u, l)).sum()
        })
        .collect()
}

/// Nearest-rank percentile `p` (0..=1) of sorted values.
fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() as f64 * p).ceil() as usize).clamp(1, sorted.len()) - 1]
}

/// Renders `warmup` + `frames` frames of `scene` at `size` (time `time`), then one frame with the
/// energy and depth AOVs, and compares it with `reference`.
pub fn measure(
    runtime: &mut Runtime,
    scene: &Scene,
    size: (u32, u32),
    warmup: usize,
    frames: usize,
    time: f64,
) -> Result<Measured, Error> {
    runtime.load_scene(scene.clone())?;
    let mut req = FrameRequest::new(size.0, size.1);
    req.time = time;
    req.color = false;
    let mut times = Vec::new();
    for i in 0..warmup + frames {
        let stats = runtime.render(&req)?.stats;
        if i >= warmup {
            times.extend(stats.passes.iter().filter(|p| p.name == "energy_wave").map(|p| p.gpu_ms));
        }
    }
    req.aovs = vec![Aov::Energy, Aov::Depth];
    let frame = runtime.render(&req)?;
    let missing = |what: &str| Error::Report(format!("the {what} AOV was not read back"));
    let energy = &frame.aov(Aov::Energy).ok_or_else(|| missing("energy"))?.data;
    let depth = &frame.aov(Aov::Depth).ok_or_else(|| missing("depth"))?.data;
    let refs = reference(scene, depth, size.0, size.1, time);
    let mut rel: Vec<f64> = energy
        .iter()
        .zip(&refs)
        .map(|(&g, &r)| if r > 0.0 { (g as f64 - r).abs() / r } else { (g as f64).abs() })
        .collect();
    // A NaN error sorts last and becomes the max: it is reported, not hidden.
    rel.sort_by(|a, b| a.total_cmp(b));
    Ok(Measured {
        p50_ms: Summary::of(&times).map_or(f64::NAN, |s| s.p50),
        max_rel: rel.last().copied().unwrap_or(f64::NAN),
        p99_rel: if rel.is_empty() { f64::NAN } else { percentile(&rel, 0.99) },
    })
}

/// `scene` with every wave integrated by `method`.
pub fn with_method(scene: &Scene, method: WaveMethod) -> Scene {
    let mut s = scene.clone();
    s.waves_mut().iter_mut().for_each(|w| w.method = method);
    s
}

/// `scene` with every wave at `tolerance` (0: every pixel exact).
pub fn with_tolerance(scene: &Scene, tolerance: f64) -> Scene {
    let mut s = scene.clone();
    s.waves_mut().iter_mut().for_each(|w| w.tolerance = Some(tolerance));
    s
}

/// The tolerances the report and the benchmark measure the wave at.
pub const TOLERANCES: [f64; 3] = [1e-2, 1e-3, 1e-4];

/// How a row of the section integrates.
#[derive(Clone, Copy)]
enum Variant {
    Exact,
    Tolerance(f64),
    Raymarch(u32),
}

/// The energy-wave section: assets/scenes/energy_wave.toml (the seed's set-up, with occluders).
pub fn section(
    runtime: &mut Runtime,
    opts: &ReportOptions,
    ceilings: &Ceilings,
    steps: &mut Steps,
) -> Result<Section, ReportError> {
    let path = opts.scene("energy_wave.toml");
    let scene = opts.load_scene("energy_wave.toml")?;
    let size = opts.effect_size;
    let pixels = size.0 as f64 * size.1 as f64;
    let waves = scene.waves().len();
    let mut columns =
        vec!["variant", "steps", "pass ms p50", "max rel err", "p99 rel err", "time vs analytic"];
    columns.extend(FRACTION_COLUMNS);
    let mut table = Table::new("energy_wave", "Energy wave: closed form vs ray march", &columns);
    let mut plot = Plot {
        id: "energy_wave".into(),
        title: format!("Energy wave, {}×{}: pass time against p99 error", size.0, size.1),
        x_label: "pass ms (p50)".into(),
        y_label: "p99 relative error".into(),
        series: vec!["analytic, exact".into(), "analytic, tolerance".into(), "raymarch".into()],
        points: Vec::new(),
    };
    steps.next("energy wave: analytic, exact");
    let analytic = measure(runtime, &with_tolerance(&scene, 0.0), size, opts.warmup, opts.frames, TIME)?;
    let mut variants = vec![("analytic, exact".to_string(), Variant::Exact, analytic)];
    for tolerance in TOLERANCES {
        steps.next(&format!("energy wave: tolerance {tolerance:e}"));
        let tolerant = with_tolerance(&scene, tolerance);
        let m = measure(runtime, &tolerant, size, opts.warmup, opts.frames, TIME)?;
        variants.push((format!("tolerance {tolerance:e}"), Variant::Tolerance(tolerance), m));
    }
    for &n in &opts.raymarch_steps {
        steps.next(&format!("energy wave: raymarch N = {n}"));
        let marched = with_method(&scene, WaveMethod::Raymarch { steps: n, jitter: false });
        variants.push((
            format!("raymarch N = {n}"),
            Variant::Raymarch(n),
            measure(runtime, &marched, size, opts.warmup, opts.frames, TIME)?,
        ));
    }
    for (label, variant, m) in variants {
        // The tolerance path's arithmetic depends on how many tiles it interpolates: no ceiling
        // fraction for it.
        let (cost, steps_cell, series, short) = match variant {
            Variant::Exact => (Some(costs::energy_analytic(waves)), Cell::Missing, 0, "exact".to_string()),
            Variant::Tolerance(t) => (None, Cell::Missing, 1, format!("τ={t:e}")),
            Variant::Raymarch(n) => {
                (Some(costs::energy_raymarch(waves, n)), Cell::Num(n as f64, Fmt::Int), 2, format!("N={n}"))
            }
        };
        let mut row = vec![
            Cell::text(&label),
            steps_cell,
            Cell::Num(m.p50_ms, Fmt::Fixed(3)),
            Cell::Num(m.max_rel, Fmt::Sci(1)),
            Cell::Num(m.p99_rel, Fmt::Sci(1)),
            Cell::Num(m.p50_ms / analytic.p50_ms, Fmt::Fixed(2)),
        ];
        row.extend(costs::fraction_cells(cost, pixels, m.p50_ms, ceilings));
        table.push(row);
        plot.points.push(PlotPoint { label: short, x: m.p50_ms, y: m.p99_rel, series });
    }
    let text = format!(
        "`{}` (the seed's set-up: a = 60, b = 30, two tetrahedra occluding), time {TIME}, {}×{}. Errors are per \
         pixel, relative to the f64 closed form integrated up to the GPU's own depth \
         (`src/report/energy_wave.rs`). \"tolerance τ\": the closed form at tile corners, interpolated \
         inside tiles whose error bound stays within τ (every wave at τ); the ray march samples N \
         midpoints per ray (no jitter). The Pareto front in the plot is on (pass ms, p99 error).",
        path.display(),
        size.0,
        size.1
    );
    Ok(Section {
        id: "energy_wave",
        title: "Energy wave".into(),
        text,
        tables: vec![table],
        plots: vec![plot],
    })
}
