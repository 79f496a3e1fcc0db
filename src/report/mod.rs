//! `hadou report`: speed against error, measured in one run on the current device. Each section
//! (energy wave, translucency, metaballs, the frame, the device ceilings) measures its variants
//! and returns tables (written as markdown and CSV) and plots (PNG, time against error with the
//! Pareto front). `write_report` writes everything into a folder atomically; `update_docs`
//! rewrites the marked blocks of a markdown file (docs/PERFORMANCE.md) from the same tables.

pub mod budget;
pub mod ceilings;
pub mod costs;
pub mod csv;
pub mod docs;
pub mod energy_wave;
pub mod frame;
pub mod header;
pub mod lut_paths;
pub mod metaballs;
pub mod output;
pub mod pareto;
pub mod plot;
pub mod table;
pub mod translucency;

use std::path::PathBuf;

pub use header::Header;
pub use plot::{Plot, PlotPoint};
pub use table::{Cell, Fmt, Table};

use hadou::Runtime;

/// The sections' ids, in report order (CSV and plot stems, docs markers).
pub const SECTION_IDS: [&str; 6] =
    ["energy_wave", "translucency", "metaballs", "budget", "frame", "ceilings"];

/// What to measure. `ReportOptions::new(quick)` gives the defaults of each mode.
#[derive(Clone, Debug, PartialEq)]
pub struct ReportOptions {
    /// Fewer frames, smaller images, fewer variants: a CI-sized run. The report says so.
    pub quick: bool,
    /// Sizes of the frame section (the showcase).
    pub frame_sizes: Vec<(u32, u32)>,
    /// Image size of the effect sections (energy wave, translucency, metaballs).
    pub effect_size: (u32, u32),
    /// Frames measured per variant, after `warmup` unmeasured ones.
    pub frames: usize,
    pub warmup: usize,
    /// Ray-march step counts compared with the closed form.
    pub raymarch_steps: Vec<u32>,
    /// Thickness-LUT voxel resolutions compared with TSM.
    pub voxel_res: Vec<u32>,
    /// Voxel resolutions of the bake-free `thickness = "peel"` rows: they size its light map
    /// (texels of ¼ voxel, `effects::translucency::light_map_size`), so each is a light-map size.
    pub peel_res: Vec<u32>,
    /// Voxel resolutions of the `thickness = "pairs"` rows (the seed's own LUT: its bytes grow
    /// as the square of the surface voxels, so low resolutions).
    pub pairs_res: Vec<u32>,
    /// A folder to read the scenes from; `None` (the default) takes the built-in copies of
    /// `assets/scenes` (`hadou::builtin`), so the report runs from any directory.
    pub scenes: Option<PathBuf>,
}

impl ReportOptions {
    pub fn new(quick: bool) -> ReportOptions {
        let scenes = None;
        if quick {
            ReportOptions {
                quick,
                frame_sizes: vec![(128, 128), (240, 135)],
                effect_size: (128, 128),
                frames: 3,
                warmup: 1,
                raymarch_steps: vec![8, 16, 32, 64, 128, 256, 512, 1024],
                voxel_res: vec![16, 25],
                peel_res: vec![25],
                pairs_res: vec![16],
                scenes,
            }
        } else {
            ReportOptions {
                quick,
                frame_sizes: vec![(512, 512), (1920, 1080)],
                effect_size: (512, 512),
                frames: 20,
                warmup: 3,
                raymarch_steps: vec![8, 16, 32, 64, 128, 256, 512, 1024],
                voxel_res: vec![25, 40, 56],
                peel_res: vec![25, 56],
                pairs_res: vec![16, 25],
                scenes,
            }
        }
    }

    /// How many steps `run` reports through its progress callback.
    pub fn step_count(&self) -> usize {
        2 + (1 + energy_wave::TOLERANCES.len() + self.raymarch_steps.len())
            + (self.voxel_res.len() + self.peel_res.len() + self.pairs_res.len() + 2)
            + metaballs::STEPS
            + budget::steps(self)
            + self.frame_sizes.len()
    }

    /// Where scene `name` (`showcase.toml`) comes from, as the report names it: the built-in
    /// scenes are the source tree's files, so they are named by their place there.
    pub fn scene(&self, name: &str) -> PathBuf {
        self.scenes.as_deref().unwrap_or("assets/scenes".as_ref()).join(name)
    }

    /// Loads scene `name` (`showcase.toml`) from `scenes`, or the built-in copy.
    pub fn load_scene(&self, name: &str) -> Result<hadou::scene::Scene, hadou::scene::SceneError> {
        match &self.scenes {
            Some(dir) => hadou::scene::load_scene(&dir.join(name)),
            None => hadou::builtin::scene(name),
        }
    }
}

/// Progress through the run: `next(label)` is called before each measurement.
pub struct Steps<'a> {
    done: usize,
    total: usize,
    show: &'a mut dyn FnMut(&str, usize, usize),
}

impl<'a> Steps<'a> {
    pub fn new(total: usize, show: &'a mut dyn FnMut(&str, usize, usize)) -> Steps<'a> {
        Steps { done: 0, total, show }
    }

    pub fn next(&mut self, label: &str) {
        (self.show)(label, self.done, self.total);
        self.done += 1;
    }

    pub fn finish(&mut self) {
        (self.show)("done", self.total, self.total);
    }
}

/// One section of the report.
#[derive(Clone, Debug, PartialEq)]
pub struct Section {
    /// Marker name in docs (`<!-- report:ID -->`) and CSV/PNG stem prefix.
    pub id: &'static str,
    pub title: String,
    /// Markdown shown above the tables: what was measured and how.
    pub text: String,
    pub tables: Vec<Table>,
    pub plots: Vec<Plot>,
}

impl Section {
    /// The section's markdown (tables and plot links), headed at level `level`.
    pub fn markdown(&self, level: usize, plot_dir: &str) -> String {
        let mut out = format!("{} {}\n\n{}\n\n", "#".repeat(level), self.title, self.text.trim_end());
        for t in &self.tables {
            out += &format!("**{}** (`{}.csv`)\n\n{}\n", t.title, t.id, t.markdown());
        }
        for p in &self.plots {
            out += &format!("![{}]({plot_dir}{}.png)\n\n", p.title, p.id);
        }
        out
    }
}

/// Everything one run measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    pub header: Header,
    pub sections: Vec<Section>,
}

impl Report {
    pub fn markdown(&self) -> String {
        let mut out = format!("# Speed against error\n\n{}\n", self.header.markdown());
        for s in &self.sections {
            out += &s.markdown(2, "");
        }
        out
    }
}

/// Errors of the report: measurement (the library's), or the output folder.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    #[error(transparent)]
    Hadou(#[from] hadou::Error),
    #[error("{0}")]
    Output(String),
}

impl From<hadou::gpu::GpuError> for ReportError {
    fn from(e: hadou::gpu::GpuError) -> Self {
        ReportError::Hadou(e.into())
    }
}

impl From<hadou::scene::SceneError> for ReportError {
    fn from(e: hadou::scene::SceneError) -> Self {
        ReportError::Hadou(e.into())
    }
}

/// Measures every section on `runtime`'s device. `command` is the command line, for the header.
pub fn run(
    runtime: &mut Runtime,
    opts: &ReportOptions,
    command: &str,
    show: &mut dyn FnMut(&str, usize, usize),
) -> Result<Report, ReportError> {
    let mut steps = Steps::new(opts.step_count(), show);
    let header = Header::collect(runtime.device_info(), opts, command);
    // Ceilings first: the other sections read their passes against them.
    let (ceiling_section, ceilings) = ceilings::section(runtime, opts, &mut steps)?;
    let energy = energy_wave::section(runtime, opts, &ceilings, &mut steps)?;
    let translucency = translucency::section(runtime, opts, &ceilings, &mut steps)?;
    let metaballs = metaballs::section(runtime, opts, &mut steps)?;
    let budget = budget::section(runtime, opts, &mut steps)?;
    let frame = frame::section(runtime, opts, &ceilings, &mut steps)?;
    steps.finish();
    Ok(Report { header, sections: vec![energy, translucency, metaballs, budget, frame, ceiling_section] })
}
