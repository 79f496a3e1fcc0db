//! The frame: per-pass GPU time percentiles of the showcase scene at each size, through the same
//! statistics as `hadou profile` (`profile::ProfileReport`).

use crate::profile::{ProfileReport, Summary};
use hadou::{FrameRequest, Runtime};

use super::ceilings::Ceilings;
use super::costs::{self, PassCost, FRACTION_COLUMNS};
use super::table::{Cell, Fmt, Table};
use super::{ReportError, ReportOptions, Section, Steps};

/// Scene time advanced per frame (60 Hz), as `hadou profile` does by default.
const DT: f64 = 1.0 / 60.0;

/// Profiles `scene` at `size`: `warmup` unmeasured frames, then `frames`.
pub fn profile(
    runtime: &mut Runtime,
    name: &str,
    size: (u32, u32),
    warmup: usize,
    frames: usize,
) -> Result<ProfileReport, hadou::Error> {
    let mut request = FrameRequest::new(size.0, size.1);
    request.color = false;
    let mut stats = Vec::with_capacity(frames);
    for i in 0..warmup + frames {
        request.time = i as f64 * DT;
        let s = runtime.render(&request)?.stats;
        if i >= warmup {
            stats.push(s);
        }
    }
    Ok(ProfileReport::new(name.to_string(), runtime.device_info().clone(), size, warmup, &stats))
}

/// The per-pixel cost of the passes that have one (`costs`); the others are not counted.
fn cost_of(pass: &str, waves: usize) -> Option<PassCost> {
    match pass {
        "energy_wave" => Some(costs::energy_analytic(waves)),
        "tonemap" => Some(costs::tonemap()),
        _ => None,
    }
}

pub fn section(
    runtime: &mut Runtime,
    opts: &ReportOptions,
    ceilings: &Ceilings,
    steps: &mut Steps,
) -> Result<Section, ReportError> {
    let path = opts.scene("showcase.toml");
    let scene = opts.load_scene("showcase.toml")?;
    let analytic = scene.waves().iter().all(|w| w.method == hadou::scene::WaveMethod::Analytic);
    let waves = if analytic { scene.waves().len() } else { 0 };
    runtime.load_scene(scene)?;
    let mut columns = vec!["size", "pass", "ms p50", "ms p95", "ms p99", "frames"];
    columns.extend(FRACTION_COLUMNS);
    let mut table = Table::new("frame", "Showcase frame: GPU ms per pass", &columns);
    for &size in &opts.frame_sizes {
        steps.next(&format!("frame: showcase {}×{}", size.0, size.1));
        let report = profile(runtime, &path.display().to_string(), size, opts.warmup, opts.frames)?;
        let pixels = size.0 as f64 * size.1 as f64;
        let size_label = format!("{}x{}", size.0, size.1);
        let mut row = |pass: &str, s: Option<&Summary>, cost: Option<PassCost>| {
            let (p50, p95, p99) = s.map_or((f64::NAN, f64::NAN, f64::NAN), |s| (s.p50, s.p95, s.p99));
            let mut cells = vec![
                Cell::text(&size_label),
                Cell::text(pass),
                Cell::Num(p50, Fmt::Fixed(3)),
                Cell::Num(p95, Fmt::Fixed(3)),
                Cell::Num(p99, Fmt::Fixed(3)),
                Cell::Num(report.frames as f64, Fmt::Int),
            ];
            cells.extend(costs::fraction_cells(
                cost.filter(|_| waves > 0 || pass != "energy_wave"),
                pixels,
                p50,
                ceilings,
            ));
            table.push(cells);
        };
        for pass in &report.pass_order {
            row(pass, report.passes.get(pass), cost_of(pass, waves));
        }
        row("gpu frame", report.gpu_frame.as_ref(), None);
        row("cpu frame", report.cpu_frame.as_ref(), None);
    }
    let sizes: Vec<String> = opts.frame_sizes.iter().map(|(w, h)| format!("{w}×{h}")).collect();
    let note = if opts.quick {
        " Quick mode: small sizes and few frames instead of 512×512 and 1920×1080 with 20 frames."
    } else {
        ""
    };
    let text = format!(
        "`{}` at {}: {} frames measured after {} warm-up, scene time advancing {DT:.4} s per frame, \
         nearest-rank percentiles (as `hadou profile {} --size WxH --frames {} --warmup {}`). \
         \"gpu frame\" is the first to the last timestamp; \"cpu frame\" the whole `render` call.{note} \
         Fractions of the ceilings are given for the passes with a counted cost (`src/report/costs.rs`).",
        path.display(),
        sizes.join(" and "),
        opts.frames,
        opts.warmup,
        path.display(),
        opts.frames,
        opts.warmup,
    );
    Ok(Section { id: "frame", title: "The frame".into(), text, tables: vec![table], plots: vec![] })
}
