//! A `VkPipelineCache` kept on disk beside the bake cache (`pipelines-VENDOR-DEVICE-UUID.bin`), so
//! a second run builds its pipelines from the driver's cache. The file is checked against the
//! device before the driver sees it (Vulkan's header: length, version, vendor, device, UUID), and
//! written atomically when the renderer is dropped. Any problem only costs the cache, never an error.
//! Lavapipe keeps nothing but the header in it (Mesa caches compiled shaders on disk itself);
//! drivers of real GPUs keep their pipeline binaries there.

use std::path::{Path, PathBuf};

use ash::vk;

use super::context::GpuContext;
use super::error::{GpuResult, VkResultExt};

/// Writes bytes to a temporary (the first path) and renames it over the file (the second).
pub type CacheWriter = dyn Fn(&Path, &[u8], &Path) -> std::io::Result<()>;

pub struct PipelineCache {
    device: ash::Device,
    pub raw: vk::PipelineCache,
    path: Option<PathBuf>,
}

/// The device's pipeline-cache UUID as hex.
fn uuid(ctx: &GpuContext) -> [u8; vk::UUID_SIZE] {
    // SAFETY: plain query.
    unsafe { ctx.instance.get_physical_device_properties(ctx.physical_device) }.pipeline_cache_uuid
}

/// Whether `data` starts with a Vulkan pipeline-cache header for this device.
fn header_matches(data: &[u8], ctx: &GpuContext) -> bool {
    let word = |i: usize| data.get(4 * i..4 * i + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    let version_one = vk::PipelineCacheHeaderVersion::ONE.as_raw() as u32;
    word(0).is_some_and(|len| len >= 32)
        && word(1) == Some(version_one)
        && word(2) == Some(ctx.info.vendor_id)
        && word(3) == Some(ctx.info.device_id)
        && data.get(16..32) == Some(&uuid(ctx)[..])
}

impl PipelineCache {
    /// The cache for this device, from `dir` when a usable file is there.
    pub fn open(ctx: &GpuContext, dir: Option<&Path>) -> GpuResult<Self> {
        let name = format!(
            "pipelines-{:04x}-{:04x}-{}.bin",
            ctx.info.vendor_id,
            ctx.info.device_id,
            uuid(ctx).iter().map(|b| format!("{b:02x}")).collect::<String>()
        );
        let path = dir.map(|d| d.join(name));
        let data = path
            .as_ref()
            .filter(|p| p.metadata().is_ok_and(|m| m.is_file() && m.len() < 256 << 20))
            .and_then(|p| std::fs::read(p).ok())
            .filter(|d| header_matches(d, ctx))
            .unwrap_or_default();
        let info = vk::PipelineCacheCreateInfo::default().initial_data(&data);
        // SAFETY: valid device; the data carries this device's header (checked above) or is empty.
        let raw = unsafe { ctx.device.create_pipeline_cache(&info, None) }.vk("vkCreatePipelineCache")?;
        ctx.name_object(raw, "hadou pipeline cache");
        log::debug!("pipeline cache: {} bytes loaded", data.len());
        Ok(PipelineCache { device: ctx.device.clone(), raw, path })
    }

    /// Writes the cache's current contents to its file (atomically; failures are logged) with
    /// `write(tmp, bytes, file)`, which writes `bytes` to the temporary `tmp` beside the file and
    /// renames it over the file, removing the temporary on failure. hadou's renderer passes its
    /// interrupt registry's writer, so SIGINT/SIGTERM during the save removes the temporary. A
    /// file that is there and is not a regular file (a folder, a link) is left alone.
    pub fn save(&self, write: &CacheWriter) {
        let Some(path) = &self.path else { return };
        if std::fs::symlink_metadata(path).is_ok_and(|m| !m.is_file()) {
            return log::warn!("pipeline cache: {} is not a regular file; not replacing it", path.display());
        }
        // SAFETY: valid cache of this device.
        let data = match unsafe { self.device.get_pipeline_cache_data(self.raw) } {
            Ok(d) => d,
            Err(e) => return log::warn!("pipeline cache: cannot read it back: {e:?}"),
        };
        // Unique per save: renderers of one process may be dropped at once.
        static SAVES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = SAVES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let tmp = path.with_extension(format!("{}.{n}.tmp", std::process::id()));
        let written =
            path.parent().map_or(Ok(()), std::fs::create_dir_all).and_then(|_| write(&tmp, &data, path));
        if let Err(e) = written {
            log::warn!("pipeline cache: cannot write {}: {e}", path.display());
        }
    }
}

/// The plain writer for [`PipelineCache::save`] (no interrupt registry): write, rename, and
/// remove the temporary on failure.
pub fn write_then_rename(tmp: &Path, bytes: &[u8], path: &Path) -> std::io::Result<()> {
    let written = std::fs::write(tmp, bytes).and_then(|_| std::fs::rename(tmp, path));
    if written.is_err() {
        let _ = std::fs::remove_file(tmp);
    }
    written
}

impl Drop for PipelineCache {
    fn drop(&mut self) {
        // SAFETY: pipelines made with it keep what they need; no creation is in progress.
        unsafe { self.device.destroy_pipeline_cache(self.raw, None) };
    }
}
