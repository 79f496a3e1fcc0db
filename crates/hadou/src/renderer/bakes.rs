//! Thickness tables baked at run time. A translucent instance spawned with a mesh and voxel_res
//! whose table the loaded scene did not bake is drawn at once, with the shadow-map thickness
//! (TSM: the translucency pass falls back to it for an instance without a table), while a
//! background thread bakes the table through the bake cache (keyed on the mesh's content, so the
//! same mesh under many transforms bakes once) and packs it with the tables already in use. The
//! first frame recorded after the job ends puts the new tables in use — host-visible buffers
//! written at once, the LUT image filled by a copy in that frame's own command buffer, no wait —
//! and rebuilds the two translucency passes on them: the instance switches to its table. One job runs at a time; keys asked for meanwhile make the next.
//! `bakes_in_progress` shows progress, `wait_for_bakes` blocks until all are in (tests, tools).
//! The seed's pair tables (`thickness = "pairs"`, keys with `PAIRS_KEY`) go the same way; their
//! image is staged then and copied by the first frame that reads it (no wait).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

use super::Renderer;
use crate::gpu::GpuResult;
use crate::passes::translucency::{pack_keys, PackLimits, Packed, TranslucentData, PAIRS_KEY};
use crate::Error;

/// A run-time bake not yet in use.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeProgress {
    /// The mesh's name.
    pub mesh: String,
    /// Its table's resolution.
    pub voxel_res: u32,
    /// Steps of the bake done (0 while queued or reading the cache).
    pub done: usize,
    /// Steps in all (0 until the bake starts).
    pub total: usize,
}

struct Job {
    /// The keys the job adds to those in use.
    adds: Vec<(usize, u32)>,
    done: Arc<AtomicUsize>,
    total: Arc<AtomicUsize>,
    thread: JoinHandle<GpuResult<Packed>>,
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
        loaded.bakes.job = Some(Job { adds, done, total, thread });
    }

    /// Puts a finished job's tables in use (`block`: waits for a running job first).
    pub(super) fn poll_bakes(&mut self, block: bool) -> Result<(), Error> {
        let Some(loaded) = &mut self.loaded else { return Ok(()) };
        let finished = loaded.bakes.job.as_ref().is_some_and(|j| block || j.thread.is_finished());
        if !finished {
            return Ok(());
        }
        let Some(job) = loaded.bakes.job.take() else { return Ok(()) };
        let packed = job.thread.join().unwrap_or_else(|_| {
            Err(crate::gpu::GpuError::Bake {
                what: "run-time bake".into(),
                message: "the bake thread panicked".into(),
            })
        });
        match packed.and_then(|p| TranslucentData::upload(&self.ctx, &self.memory, p)) {
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
            out.extend(job.adds.iter().map(|&(m, r)| BakeProgress {
                mesh: name(m),
                voxel_res: r & !PAIRS_KEY,
                done,
                total,
            }));
        }
        let queued = loaded.bakes.queued.iter();
        out.extend(queued.map(|&(m, r)| BakeProgress {
            mesh: name(m),
            voxel_res: r & !PAIRS_KEY,
            done: 0,
            total: 0,
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
