//! The frame budget (issue 22 item 4) on assets/scenes/budget.toml: each effect's (time, error)
//! front, every level pinned in turn (`Scene::quality` without a budget), and the levels the
//! budget picks at three budgets with what those frames then took.

use hadou::budget::{BudgetStatus, DECIDE_EVERY};
use hadou::scene::Scene;
use hadou::{Error, FrameRequest, FrameStats, Runtime};

use super::pareto;
use super::plot::{Plot, PlotPoint};
use super::table::{Cell, Fmt, Table};
use super::{ReportError, ReportOptions, Section, Steps};
use crate::profile::Summary;

/// The budgets, as shares of the frame with every effect at level 0: one it fits with room (a
/// share of 1 sits on the edge, where noise decides), then halved twice.
pub const BUDGET_SHARES: [f64; 3] = [1.2, 0.6, 0.3];
/// Frames a budget runs before its frames are measured: five decisions.
const SETTLE: usize = 5 * DECIDE_EVERY as usize;

/// Progress steps: the exact frame, each level the built-in effects offer on the scene (read
/// from the effects, as the budget does), each budget.
pub fn steps(opts: &ReportOptions) -> usize {
    let effects = hadou::effect::Effects::builtin();
    let levels = |scene: &Scene| effects.iter().map(|e| e.quality_levels(scene).len()).sum::<usize>();
    1 + opts.load_scene("budget.toml").map_or(0, |s| levels(&s)) + BUDGET_SHARES.len()
}

/// `warmup` frames, then `frames` measured.
fn frames(
    runtime: &mut Runtime,
    size: (u32, u32),
    warmup: usize,
    frames: usize,
) -> Result<Vec<FrameStats>, Error> {
    let mut request = FrameRequest::new(size.0, size.1);
    request.color = false;
    let mut out = Vec::with_capacity(frames);
    for i in 0..warmup + frames {
        let stats = runtime.render(&request)?.stats;
        if i >= warmup {
            out.push(stats);
        }
    }
    Ok(out)
}

fn p50(values: &[f64]) -> f64 {
    Summary::of(values).map_or(f64::NAN, |s| s.p50)
}

/// The levels of a status, "effect level, …".
fn picks(status: &BudgetStatus) -> String {
    let each = status.effects.iter().map(|e| format!("{} {}", e.name, e.levels[e.chosen].name));
    each.collect::<Vec<_>>().join(", ")
}

fn status(runtime: &mut Runtime) -> Result<BudgetStatus, ReportError> {
    runtime
        .renderer()
        .budget_status()
        .ok_or_else(|| ReportError::from(Error::Report("no budget status".into())))
}

pub fn section(
    runtime: &mut Runtime,
    opts: &ReportOptions,
    steps: &mut Steps,
) -> Result<Section, ReportError> {
    let path = opts.scene("budget.toml");
    let scene = opts.load_scene("budget.toml")?;
    let size = opts.effect_size;
    // The effects with levels, and the frame with all of them at level 0 (a budget nothing
    // reaches), which the budgets are shares of.
    steps.next("budget: every effect at level 0");
    runtime.load_scene(scene.clone())?;
    runtime.renderer().set_frame_budget(Some(*hadou::budget::BUDGET_RANGE_MS.end()))?;
    let exact = frames(runtime, size, opts.warmup + DECIDE_EVERY as usize, opts.frames)?;
    let exact_ms = p50(&exact.iter().map(|f| f.gpu_frame_ms).collect::<Vec<_>>());
    let modelled = status(runtime)?;
    runtime.renderer().set_frame_budget(None)?;

    let mut fronts = Table::new(
        "budget_fronts",
        "Frame budget: each effect's levels, pinned",
        &["effect", "level", "passes ms p50", "error bound", "on the front"],
    );
    let mut plot = Plot {
        id: "budget".into(),
        title: format!("Frame budget, {}×{}: each effect's passes against its error bound", size.0, size.1),
        x_label: "effect's passes ms (p50)".into(),
        y_label: "error bound (relative)".into(),
        series: modelled.effects.iter().map(|e| e.name.to_string()).collect(),
        points: Vec::new(),
    };
    for (series, effect) in modelled.effects.iter().enumerate() {
        let passes: Vec<&'static str> = (runtime.renderer().effects().get(effect.name))
            .map(|e| e.passes().iter().map(|p| p.name).collect())
            .unwrap_or_default();
        let mut points = Vec::new();
        for (l, level) in effect.levels.iter().enumerate() {
            steps.next(&format!("budget: {} {}", effect.name, level.name));
            let mut pinned: Scene = scene.clone();
            pinned.quality.set(effect.name, Some(l));
            runtime.load_scene(pinned)?;
            let measured = frames(runtime, size, opts.warmup, opts.frames)?;
            let ms: Vec<f64> = (measured.iter())
                .map(|f| {
                    f.passes.iter().filter(|p| passes.contains(&p.name.as_str())).map(|p| p.gpu_ms).sum()
                })
                .collect();
            points.push((p50(&ms), level.error));
        }
        let front = pareto::front(&points);
        for (l, (level, &(ms, error))) in effect.levels.iter().zip(&points).enumerate() {
            fronts.push(vec![
                Cell::text(effect.name),
                Cell::text(&level.name),
                Cell::Num(ms, Fmt::Fixed(3)),
                Cell::Num(error, Fmt::Sci(2)),
                Cell::text(if front.contains(&l) { "yes" } else { "no" }),
            ]);
            plot.points.push(PlotPoint { label: level.name.clone(), x: ms, y: error, series });
        }
    }

    let mut budgets = Table::new(
        "budget_picks",
        "Frame budget: what it picks",
        &[
            "budget ms",
            "share of level-0 frame",
            "gpu frame ms p50",
            "predicted ms",
            "fits",
            "summed error bound",
            "levels",
        ],
    );
    for share in BUDGET_SHARES {
        let budget = exact_ms * share;
        steps.next(&format!("budget: {budget:.2} ms"));
        runtime.load_scene(scene.clone())?;
        runtime.renderer().set_frame_budget(Some(budget))?;
        let measured = frames(runtime, size, SETTLE, opts.frames)?;
        let s = status(runtime)?;
        budgets.push(vec![
            Cell::Num(budget, Fmt::Fixed(3)),
            Cell::Num(share, Fmt::Fixed(2)),
            Cell::Num(p50(&measured.iter().map(|f| f.gpu_frame_ms).collect::<Vec<_>>()), Fmt::Fixed(3)),
            Cell::Num(s.predicted_ms, Fmt::Fixed(3)),
            Cell::text(if s.fits { "yes" } else { "no" }),
            Cell::Num(s.error(), Fmt::Sci(2)),
            Cell::text(picks(&s)),
        ]);
    }
    runtime.renderer().set_frame_budget(None)?;
    let text = format!(
        "`{}` at {}×{}: an energy wave (levels: its tolerance τ, a bound on the relative error of H) and \
         two translucent cubes (levels: the light map's texel, a bound on the light map's share of the \
         transmittance's relative error). Fronts: each level pinned in turn (`Scene::quality`, no budget), \
         the effect's passes' p50 over {} frames after {} warm-up. Budgets: shares of the frame with every \
         effect at level 0 ({exact_ms:.3} ms p50), each run {SETTLE} frames to settle (a decision every \
         {DECIDE_EVERY}), then {} measured; \"summed error bound\" is what the budget minimizes \
         (`crate::budget`).",
        path.display(),
        size.0,
        size.1,
        opts.frames,
        opts.warmup,
        opts.frames,
    );
    Ok(Section {
        id: "budget",
        title: "Frame budget".into(),
        text,
        tables: vec![fronts, budgets],
        plots: vec![plot],
    })
}
