//! `hadou bake MESH.obj|SCENE.toml [--res N] [--out FILE] [--threads N] [--force]`: bakes
//! thickness fields (seed 003's LUT) through the on-disk cache, with a progress bar on stderr (one
//! step per z-slice of grid corners) and one summary line per field on stdout; and the seed's own
//! pair tables of a scene's `thickness = "pairs"` materials (`bake_pairs`: one step per row).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;
use hadou::bake::bake_cache::{self, BakeCache, CacheOutcome};
use hadou::bake::thickness_lut::{self, BakeOptions, BakeStats, ThicknessLut, FIELD_FORMAT};
use hadou::scene::mesh::Mesh;
use hadou::scene::{MaterialKind, ThicknessMode};

#[derive(Args, Debug)]
pub struct BakeArgs {
    /// A Wavefront OBJ (one closed mesh), or a scene file: every mesh drawn with a translucent
    /// material whose `thickness` is "lut" (or "pairs": the seed's pair table)
    /// (`builtin:NAME` names a built-in scene).
    input: PathBuf,
    /// Voxel resolution (default: each material's `voxel_res`; 48 for an OBJ).
    #[arg(long)]
    res: Option<u32>,
    /// Also write the table to FILE (the cache's file format); needs exactly one table.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Bake even when the cache holds the table (and replace it).
    #[arg(long)]
    force: bool,
}

/// One table to bake: a label, the mesh, the resolution, and whether it is a pair table.
struct Job {
    label: String,
    mesh: Mesh,
    res: u32,
    pairs: bool,
}

/// The tables to bake, and the files they were read from (which `--out` may not replace).
fn jobs(args: &BakeArgs) -> anyhow::Result<(Vec<Job>, Vec<PathBuf>)> {
    let is_obj = args.input.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    if is_obj {
        let mesh = hadou::scene::obj::load_obj(&args.input)?;
        let res = args.res.unwrap_or(hadou::scene::DEFAULT_VOXEL_RES);
        let job = Job { label: args.input.display().to_string(), mesh, res, pairs: false };
        return Ok((vec![job], vec![args.input.clone()]));
    }
    let scene = hadou::builtin::load(&args.input)?;
    let inputs = super::scene_inputs(&args.input, &scene);
    let mut out: Vec<(usize, u32, bool)> = Vec::new();
    for inst in &scene.instances {
        if let MaterialKind::Translucent { voxel_res, thickness, .. } = scene.materials[inst.material].kind {
            if !thickness.is_baked() {
                continue;
            }
            let key = (inst.mesh, args.res.unwrap_or(voxel_res), thickness == ThicknessMode::Pairs);
            if !out.contains(&key) {
                out.push(key);
            }
        }
    }
    if out.is_empty() {
        bail!(
            "{}: no instance uses a translucent material with thickness = \"lut\" or \"pairs\": nothing to bake",
            args.input.display()
        );
    }
    let jobs = out
        .into_iter()
        .map(|(m, res, pairs)| Job {
            label: format!("mesh \"{}\"", scene.meshes[m].name),
            mesh: scene.meshes[m].mesh.clone(),
            res,
            pairs,
        })
        .collect();
    Ok((jobs, inputs))
}

pub fn run(args: BakeArgs) -> anyhow::Result<()> {
    if let Some(res) = args.res {
        if res == 0 || res > hadou::bake::MAX_VOXEL_RES {
            bail!("--res {res}: expected 1..={}", hadou::bake::MAX_VOXEL_RES);
        }
    }
    let (jobs, inputs) = jobs(&args)?;
    if let Some(out) = &args.out {
        if jobs.len() != 1 {
            bail!("--out needs exactly one table, but {} has {}", args.input.display(), jobs.len());
        }
        super::check_outputs(&[out], &inputs)?;
    }
    let options = BakeOptions { threads: args.threads };
    let cache = BakeCache::from_env();
    if cache.is_none() {
        log::warn!("no cache folder (set HADOU_CACHE_DIR, XDG_CACHE_HOME or HOME): baking without a cache");
    }
    for job in &jobs {
        if job.pairs {
            bake_pairs(job, &args, cache.as_ref())?;
            continue;
        }
        let progress = super::progress::bar(&format!("baking {} at {}³", job.label, job.res), 0);
        let show = |done: usize, total: usize| {
            if progress.length() != Some(total as u64) {
                progress.set_length(total as u64);
                progress.set_message(format!("of {total} slices"));
            }
            progress.set_position(done as u64);
        };
        let start = Instant::now();
        let (lut, stats, how) = match (&cache, args.force) {
            (Some(cache), false) => {
                let got = cache
                    .get_or_bake(&job.mesh, job.res, &options, &show)
                    .with_context(|| format!("{} at resolution {}", job.label, job.res))?;
                let how = match &got.outcome {
                    CacheOutcome::Hit(p) => format!("cache hit {}", p.display()),
                    CacheOutcome::Miss(p) => format!("baked, cached in {}", p.display()),
                    CacheOutcome::Rebuilt { path, reason } => {
                        format!("rebuilt {} ({reason})", path.display())
                    }
                };
                (got.lut, got.stats, how)
            }
            _ => {
                let (lut, stats) = thickness_lut::bake(&job.mesh, job.res, &options, &show)
                    .with_context(|| format!("{} at resolution {}", job.label, job.res))?;
                let how = match &cache {
                    Some(cache) => match cache.store(&job.mesh, &lut) {
                        Ok(p) => format!("baked (--force), cached in {}", p.display()),
                        Err(e) => format!("baked (--force); cache not written: {e}"),
                    },
                    None => "baked, no cache".to_string(),
                };
                (lut, Some(stats), how)
            }
        };
        if stats.is_some() {
            progress.finish();
        } else {
            progress.finish_and_clear(); // a cache hit: nothing was baked
        }
        print_summary(job, &lut, stats.as_ref(), start.elapsed().as_secs_f64(), &how);
        if let Some(out) = &args.out {
            write_out(out, &job.mesh, &lut)?;
            println!("  written to {}", out.display());
        }
    }
    Ok(())
}

/// A pair table (`thickness = "pairs"`) through the cache, or baked afresh with `--force`; a
/// progress step per row of pairs; `--out` writes the pair cache's file format.
fn bake_pairs(job: &Job, args: &BakeArgs, cache: Option<&BakeCache>) -> anyhow::Result<()> {
    use hadou::bake::thickness_pairs::{self, PairOptions, PAIR_FORMAT};
    let progress =
        super::progress::bar(&format!("baking the pair table of {} at {}³", job.label, job.res), 0);
    let show = |done: usize, total: usize| {
        if progress.length() != Some(total as u64) {
            progress.set_length(total as u64);
            progress.set_message(format!("of {total} rows"));
        }
        progress.set_position(done as u64);
    };
    let options = PairOptions { threads: args.threads, ..PairOptions::default() };
    let context = || format!("pair table of {} at resolution {}", job.label, job.res);
    let start = Instant::now();
    let (table, how) = match (cache, args.force) {
        (Some(cache), false) => {
            let got = cache.get_or_bake_pairs(&job.mesh, job.res, &options, &show).with_context(context)?;
            let how = match &got.outcome {
                CacheOutcome::Hit(p) => format!("cache hit {}", p.display()),
                CacheOutcome::Miss(p) => format!("baked, cached in {}", p.display()),
                CacheOutcome::Rebuilt { path, reason } => format!("rebuilt {} ({reason})", path.display()),
            };
            (got.table, how)
        }
        _ => {
            let (table, _) =
                thickness_pairs::bake(&job.mesh, job.res, &options, &show).with_context(context)?;
            let how = match cache.map(|c| c.store_pairs(&job.mesh, &table)) {
                Some(Ok(p)) => format!("baked (--force), cached in {}", p.display()),
                Some(Err(e)) => format!("baked (--force); cache not written: {e}"),
                None => "baked, no cache".to_string(),
            };
            (table, how)
        }
    };
    progress.finish_and_clear();
    let n = table.surface_voxels();
    println!(
        "{} res {}: pair table {n}×{n} {PAIR_FORMAT} ({} surface voxels), {} bytes + {} of lookups, {:.2} s; {how}",
        job.label,
        job.res,
        n,
        table.bytes(),
        table.gpu_bytes() - table.bytes(),
        start.elapsed().as_secs_f64()
    );
    if let Some(out) = &args.out {
        let bytes = hadou::bake::pair_cache::encode(&table, bake_cache::mesh_hash(&job.mesh));
        hadou::output::write_atomically(out, &bytes)?;
        println!("  written to {}", out.display());
    }
    Ok(())
}

fn print_summary(job: &Job, lut: &ThicknessLut, stats: Option<&BakeStats>, seconds: f64, how: &str) {
    let detail = stats.map_or(String::new(), |s| {
        format!(
            ", {} threads, {} of {} corners near the surface, field {:.2} s, τ {:.2} s",
            s.threads, s.near_corners, s.corners, s.field_seconds, s.threshold_seconds
        )
    });
    let [x, y, z] = lut.corner_dims();
    println!(
        "{} res {}: field {x}×{y}×{z} {FIELD_FORMAT}, {} bytes, largest gap threshold {:.3} voxel, {seconds:.2} s{detail}; {how}",
        job.label,
        job.res,
        lut.bytes(),
        lut.gap_threshold() / lut.voxel_size,
    );
}

fn write_out(out: &Path, mesh: &Mesh, lut: &ThicknessLut) -> anyhow::Result<()> {
    let bytes = bake_cache::encode(lut, bake_cache::mesh_hash(mesh));
    Ok(hadou::output::write_atomically(out, &bytes)?)
}
