//! Thickness tables baked at run time. A translucent instance spawned with a mesh and voxel_res
//! whose table the loaded scene did not bake is drawn at once, with the shadow-map thickness
//! (TSM: the translucency pass falls back to it for an instance without a table), while a
//! background thread bakes the table through the bake cache (keyed on the mesh's content, so the
//! same mesh under many transforms bakes once) and packs it with the tables already in use. The
//! frames recorded after the job ends copy the packed tables into fresh host-visible buffers, at
//! most `Renderer::UPLOAD_BYTES_PER_FRAME` each (`passes::translucency::Uploading`), and the one
//! whose slice completes them puts them in use — the pair image filled by a copy in that frame's
//! own command buffer, no wait — and rebuilds the two translucency passes on them (pipelines from
//! the memo: nothing compiled): the instance switches to its table. One job runs at a time; keys
//! asked for meanwhile make the next.
//! `bakes_in_progress` shows progress, `wait_for_bakes` blocks until all are in (tests, tools).
//! The seed's pair tables (`thickness = "pairs"`, keys with `PAIRS_KEY`) go the same way; their
//! image is staged then and copied by the first frame that reads it (no wait).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

use super::Renderer;
use crate::gpu::GpuResult;
use crate::passes::translucency::{
    pack_keys, PackLimits, Packed, TranslucentData, Uploading, PAIRS_KEY, UPLOAD_BYTES_PER_FRAME,
};
use crate::Error;

/// A run-time bake not yet in use.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct BakeProgress {
    /// The mesh's name.
    pub mesh: String,
    /// Its table's resolution.
    pub voxel_res: u32,
    /// Steps of the bake done (0 while queued or reading the cache).
    pub done: usize,
    /// Steps in all (0 until the bake starts).
    pub total: usize,
    /// Bytes of the tables (all in use, packed again with this one) copied into their buffers so
    /// far: a finished bake's tables are copied by the frames that follow, at most
    /// `Renderer::UPLOAD_BYTES_PER_FRAME` each, and put in use by the frame that completes them.
    pub copied: usize,
    /// Bytes to copy in all (0 until the bake is done).
    pub bytes: usize,
}

struct Job {
    /// The keys the job adds to those in use.
    adds: Vec<(usize, u32)>,
    done: Arc<AtomicUsize>,
    total: Arc<AtomicUsize>,
    stage: Stage,
}

/// Where a job is: baking and packing on its thread, then its tables copied into their buffers by
/// the frames that follow, `UPLOAD_BYTES_PER_FRAME` a frame; in use once all are in.
enum Stage {
    Baking(JoinHandle<GpuResult<Packed>>),
    Uploading(Box<Uploading>),
}

/// The run-time bakes of the loaded scene.
#[derive(Default)]
pub(super) struct Bakes {
    job: Option<Job>,
    /// (mesh, voxel_res) asked for while a job ran.
    queued: Vec<(usize, u32)>,
    /// Keys whose bake failed (logged): their instances stay on TSM.
    failed: Vec<(usize, u32)>,
}

/// The scene's current tables, if the translucency passes were ever built.
fn current_data(shared: &crate::effect::SharedData) -> Option<Arc<TranslucentData>> {
    shared.get::<TranslucentData>()
}

impl Renderer {
    /// The most bytes of a finished run-time bake's tables one frame copies (`BakeProgress`):
    /// 512 KiB, ≈ 0.3 ms of `record_frame` on lavapipe here (docs/PERFORMANCE.md).
    pub const UPLOAD_BYTES_PER_FRAME: usize = UPLOAD_BYTES_PER_FRAME;

    /// Whether (mesh, voxel_res) has a table in use, or is being or was tried to be baked.
    pub(super) fn table_known(&self, key: (usize, u32)) -> bool {
        let Some(loaded) = &self.loaded else { return false };
        let b = &loaded.bakes;
        current_data(&loaded.passes.shared).is_some_and(|d| d.keys.contains(&key))
            || b.job.as_ref().is_some_and(|j| j.adds.contains(&key))
            || b.queued.contains(&key)
            || b.failed.contains(&key)
    }

    /// Makes sure the tables exist (an empty set when the scene never drew a translucent
    /// instance) so passes built from now on find them instead of baking on this thread.
    pub(super) fn ensure_tables(&mut self) -> Result<(), Error> {
        let limit = PackLimits::of(&self.ctx);
        let Some(loaded) = &mut self.loaded else { return Err(Error::NoScene) };
        if current_data(&loaded.passes.shared).is_none() {
            let packed = pack_keys(&loaded.scene, Vec::new(), limit, &|_, _| {})?;
            let data = TranslucentData::upload(&self.ctx, &self.memory, packed)?;
            loaded.passes.shared.replace(data);
        }
        Ok(())
    }

    /// Makes the translucency pipeline that reads pair tables ahead (a pair table is baking), so
    /// the frame that puts it in use compiles nothing; nothing when no translucency pass was
    /// built yet (it will be built with its tables).
    pub(super) fn warm_pair_pipelines(&mut self) -> Result<(), Error> {
        let Some(loaded) = &self.loaded else { return Ok(()) };
        let Some(memo) = loaded.passes.shared.get::<crate::passes::pipeline_memo::PipelineMemo>() else {
            return Ok(());
        };
        let scene = &loaded.scene;
        let (lut, peel) = (crate::passes::translucency::reads_lut(scene), crate::passes::peel::needed(scene));
        crate::passes::translucency::pipelines(&self.ctx, &mut self.compiler, &memo, lut, peel, true)?;
        Ok(())
    }

    /// Queues a bake of (mesh, voxel_res) and starts a job if none runs.
    pub(super) fn request_bake(&mut self, key: (usize, u32)) {
        if self.table_known(key) {
            return;
        }
        if let Some(loaded) = &mut self.loaded {
            loaded.bakes.queued.push(key);
        }
        self.start_bake_job();
    }

    fn start_bake_job(&mut self) {
        let limit = PackLimits::of(&self.ctx);
        let Some(loaded) = &mut self.loaded else { return };
        if loaded.bakes.job.is_some() || loaded.bakes.queued.is_empty() {
            return;
        }
        let adds = std::mem::take(&mut loaded.bakes.queued);
        let mut keys = current_data(&loaded.passes.shared).map_or(Vec::new(), |d| d.keys.clone());
        keys.extend(&adds);
        let scene = loaded.scene.clone();
        let (done, total) = (Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0)));
        let (d, t) = (done.clone(), total.clone());
        let thread = std::thread::spawn(move || {
            let progress = move |k: usize, n: usize| {
                d.store(k, Ordering::Relaxed);
                t.store(n, Ordering::Relaxed);
            };
            pack_keys(&scene, keys, limit, &progress)
        });
        loaded.bakes.job = Some(Job { adds, done, total, stage: Stage::Baking(thread) });
    }

    /// Moves the job on: a finished bake's tables get their buffers and the first slice of their
    /// copy, later frames copy a slice each, and the frame whose slice completes them puts them in
    /// use. `block`: waits for a running bake and copies everything now (tools, tests).
    pub(super) fn poll_bakes(&mut self, block: bool) -> Result<(), Error> {
        let Some(loaded) = &mut self.loaded else { return Ok(()) };
        let Some(mut job) = loaded.bakes.job.take() else { return Ok(()) };
        let uploading = match job.stage {
            Stage::Baking(thread) if !(block || thread.is_finished()) => {
                job.stage = Stage::Baking(thread);
                loaded.bakes.job = Some(job);
                return Ok(());
            }
            Stage::Baking(thread) => {
                let packed = thread.join().unwrap_or_else(|_| {
                    Err(crate::gpu::GpuError::Bake {
                        what: "run-time bake".into(),
                        message: "the bake thread panicked".into(),
                    })
                });
                packed.and_then(|p| Uploading::begin(&self.ctx, &self.memory, p)).map(Box::new)
            }
            Stage::Uploading(u) => Ok(u),
        };
        let budget = if block { usize::MAX } else { UPLOAD_BYTES_PER_FRAME };
        let data = match uploading {
            Ok(mut u) => match u.step(budget) {
                Ok(true) => u.finish(&self.ctx),
                Ok(false) => {
                    job.stage = Stage::Uploading(u);
                    loaded.bakes.job = Some(job);
                    return Ok(());
                }
                Err(e) => Err(e),
            },
            Err(e) => Err(e),
        };
        match data {
            Ok(data) => {
                loaded.passes.shared.replace(data);
                // The passes built on the old tables go (retired with the frames that use them);
                // sync_passes builds them again on the new ones.
                loaded.passes.drop_users_of::<TranslucentData>();
            }
            Err(e) => {
                let names: Vec<String> = job
                    .adds
                    .iter()
                    .map(|&(m, r)| format!("\"{}\" at {}³", loaded.scene.meshes[m].name, r & !PAIRS_KEY))
                    .collect();
                log::warn!(
                    "thickness tables of {}: {e}; those instances stay on shadow-map thickness",
                    names.join(", ")
                );
                loaded.bakes.failed.extend(&job.adds);
            }
        }
        self.sync_passes()?;
        self.start_bake_job();
        Ok(())
    }

    /// The run-time bakes not in use yet (the one running first, then those queued).
    pub fn bakes_in_progress(&self) -> Vec<BakeProgress> {
        let Some(loaded) = &self.loaded else { return Vec::new() };
        let name = |m: usize| loaded.scene.meshes[m].name.clone();
        let mut out = Vec::new();
        if let Some(job) = &loaded.bakes.job {
            let (done, total) = (job.done.load(Ordering::Relaxed), job.total.load(Ordering::Relaxed));
            let (copied, bytes) = match &job.stage {
                Stage::Baking(_) => (0, 0),
                Stage::Uploading(u) => (u.written(), u.total()),
            };
            out.extend(job.adds.iter().map(|&(m, r)| BakeProgress {
                mesh: name(m),
                voxel_res: r & !PAIRS_KEY,
                done,
                total,
                copied,
                bytes,
            }));
        }
        let queued = loaded.bakes.queued.iter();
        out.extend(queued.map(|&(m, r)| BakeProgress {
            mesh: name(m),
            voxel_res: r & !PAIRS_KEY,
            done: 0,
            total: 0,
            copied: 0,
            bytes: 0,
        }));
        out
    }

    /// Blocks until every run-time bake asked for is in use (or failed), for tools and tests; a
    /// game keeps rendering instead and the instances switch by themselves.
    pub fn wait_for_bakes(&mut self) -> Result<(), Error> {
        while self.loaded.as_ref().is_some_and(|l| l.bakes.job.is_some()) {
            self.poll_bakes(true)?;
        }
        Ok(())
    }
}
