//! The device's memory and the queue of objects waiting to be freed (kajiya's `defer_release`).
//!
//! Every GPU object hadou owns (buffer, image, view, pipeline, sampler, descriptor or query pool)
//! is freed by its `Drop`: the raw handles go onto the retire queue stamped with the newest frame
//! that may still use them, and are destroyed once the host has said that frame finished
//! (`GpuContext::collect_retired`). Nothing the GPU may still read is destroyed, and no owner
//! unwinds by hand: a constructor that fails part-way drops what it made, and that is queued too.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, Weak};

use ash::vk;
use gpu_allocator::vulkan::{Allocation, Allocator, AllocatorCreateDesc};

use super::error::{GpuError, GpuResult};

/// Raw handles of a dropped object.
pub(crate) enum Garbage {
    Buffer(vk::Buffer, Option<Allocation>),
    Image(vk::Image, Option<Allocation>),
    ImageView(vk::ImageView),
    BufferView(vk::BufferView),
    Pipeline(vk::Pipeline),
    PipelineLayout(vk::PipelineLayout),
    SetLayout(vk::DescriptorSetLayout),
    Sampler(vk::Sampler),
    DescriptorPool(vk::DescriptorPool),
    QueryPool(vk::QueryPool),
}

/// Counts of host waits on the device, for tests that prove a frame path never waits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HostWaits {
    /// `vkDeviceWaitIdle` calls hadou made.
    pub device_idle: u64,
    /// Fence waits hadou made (its own one-off uploads and the headless runtime's frames).
    pub fences: u64,
}

pub(crate) struct Resources {
    device: ash::Device,
    allocator: Mutex<Option<Allocator>>,
    retired: Mutex<Vec<(u64, Garbage)>>,
    /// The newest frame that may use an object dropped now.
    frame: AtomicU64,
    device_idle_waits: AtomicU64,
    fence_waits: AtomicU64,
    /// The `VkPipelineCache` pipelines are made with (null: none), see `gpu::pipeline_cache`.
    pipeline_cache: AtomicU64,
}

/// A weak link to the retire queue, held by every owned object: objects outliving the context
/// (a leak the validation layer reports at shutdown) do nothing when dropped.
#[derive(Clone)]
pub(crate) struct Releaser(Weak<Resources>);

impl Releaser {
    pub fn retire(&self, garbage: Garbage) {
        if let Some(resources) = self.0.upgrade() {
            let frame = resources.frame.load(Ordering::Acquire);
            lock(&resources.retired).push((frame, garbage));
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic while holding the lock left plain data behind: keep using it.
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

impl Resources {
    pub fn new(
        instance: &ash::Instance,
        device: &ash::Device,
        physical_device: vk::PhysicalDevice,
    ) -> GpuResult<Arc<Self>> {
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|e| GpuError::Allocator { what: "the allocator".into(), message: e.to_string() })?;
        Ok(Arc::new(Resources {
            device: device.clone(),
            allocator: Mutex::new(Some(allocator)),
            retired: Mutex::new(Vec::new()),
            frame: AtomicU64::new(0),
            device_idle_waits: AtomicU64::new(0),
            fence_waits: AtomicU64::new(0),
            pipeline_cache: AtomicU64::new(0),
        }))
    }

    pub fn releaser(self: &Arc<Self>) -> Releaser {
        Releaser(Arc::downgrade(self))
    }

    /// Runs `f` on the allocator; an error once the context is being destroyed.
    pub fn with_allocator<T>(
        &self,
        what: &str,
        f: impl FnOnce(&mut Allocator) -> GpuResult<T>,
    ) -> GpuResult<T> {
        match lock(&self.allocator).as_mut() {
            Some(a) => f(a),
            None => Err(GpuError::ContextDestroyed { what: what.into() }),
        }
    }

    /// Objects dropped from now on may be used by frame `frame` (it is being recorded).
    pub fn set_frame(&self, frame: u64) {
        self.frame.store(frame, Ordering::Release);
    }

    /// Destroys every retired object whose frame is `finished` or older.
    pub fn collect(&self, finished: u64) {
        let ready: Vec<Garbage> = {
            let mut retired = lock(&self.retired);
            let (ready, pending): (Vec<_>, Vec<_>) = retired.drain(..).partition(|(f, _)| *f <= finished);
            *retired = pending;
            ready.into_iter().map(|(_, g)| g).collect()
        };
        ready.into_iter().for_each(|g| self.destroy(g));
    }

    /// Destroys everything retired; the caller guarantees the device is idle.
    pub fn collect_all(&self) {
        self.collect(u64::MAX);
    }

    /// Objects waiting to be freed.
    pub fn retired_count(&self) -> usize {
        lock(&self.retired).len()
    }

    pub fn pipeline_cache(&self) -> vk::PipelineCache {
        vk::Handle::from_raw(self.pipeline_cache.load(Ordering::Acquire))
    }

    pub fn set_pipeline_cache(&self, cache: vk::PipelineCache) {
        self.pipeline_cache.store(vk::Handle::as_raw(cache), Ordering::Release);
    }

    pub fn count_device_idle_wait(&self) {
        self.device_idle_waits.fetch_add(1, Ordering::Relaxed);
    }

    pub fn count_fence_wait(&self) {
        self.fence_waits.fetch_add(1, Ordering::Relaxed);
    }

    pub fn host_waits(&self) -> HostWaits {
        HostWaits {
            device_idle: self.device_idle_waits.load(Ordering::Relaxed),
            fences: self.fence_waits.load(Ordering::Relaxed),
        }
    }

    fn destroy(&self, garbage: Garbage) {
        let d = &self.device;
        // SAFETY: the frames that could use the object have finished (collect's contract), and
        // every handle was created on this device and is destroyed once (it left its owner).
        unsafe {
            match garbage {
                Garbage::Buffer(raw, allocation) => {
                    d.destroy_buffer(raw, None);
                    self.free(allocation);
                }
                Garbage::Image(raw, allocation) => {
                    d.destroy_image(raw, None);
                    self.free(allocation);
                }
                Garbage::ImageView(v) => d.destroy_image_view(v, None),
                Garbage::BufferView(v) => d.destroy_buffer_view(v, None),
                Garbage::Pipeline(p) => d.destroy_pipeline(p, None),
                Garbage::PipelineLayout(l) => d.destroy_pipeline_layout(l, None),
                Garbage::SetLayout(l) => d.destroy_descriptor_set_layout(l, None),
                Garbage::Sampler(s) => d.destroy_sampler(s, None),
                Garbage::DescriptorPool(p) => d.destroy_descriptor_pool(p, None),
                Garbage::QueryPool(p) => d.destroy_query_pool(p, None),
            }
        }
    }

    fn free(&self, allocation: Option<Allocation>) {
        let Some(allocation) = allocation else { return };
        if let Some(allocator) = lock(&self.allocator).as_mut() {
            if let Err(e) = allocator.free(allocation) {
                log::warn!("freeing GPU memory failed: {e}");
            }
        }
    }

    /// Frees everything and the allocator itself; the device must be idle. After this the
    /// context creates no more memory.
    pub fn shut_down(&self) {
        self.collect_all();
        lock(&self.allocator).take();
    }
}
