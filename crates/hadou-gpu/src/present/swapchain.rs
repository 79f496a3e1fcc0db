//! The swapchain and its synchronization: acquire, present, recreate (see the module docs).

use ash::vk;

use crate::error::{GpuResult, VkResultExt};

/// What the swapchain should look like; the first supported entry of each list wins.
#[derive(Clone, Debug)]
pub struct PresentConfig {
    /// Preferred surface formats. hadou's tonemap writes sRGB-encoded bytes, which are copied
    /// unchanged, so the viewer asks for `*_UNORM` formats (an `*_SRGB` one would encode twice
    /// when rendered to); a game rendering linear colour would ask for `B8G8R8A8_SRGB`.
    pub formats: Vec<vk::Format>,
    /// Preferred present modes; FIFO (always supported) is the fallback.
    pub present_modes: Vec<vk::PresentModeKHR>,
    /// How the caller writes the images (`TRANSFER_DST` for copies, `COLOR_ATTACHMENT` to render).
    pub usage: vk::ImageUsageFlags,
    /// Frames the CPU may record ahead of the GPU.
    pub frames_in_flight: usize,
}

impl Default for PresentConfig {
    fn default() -> Self {
        PresentConfig {
            formats: vec![vk::Format::B8G8R8A8_UNORM, vk::Format::R8G8B8A8_UNORM],
            present_modes: vec![vk::PresentModeKHR::MAILBOX, vk::PresentModeKHR::FIFO],
            usage: vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::COLOR_ATTACHMENT,
            frames_in_flight: 2,
        }
    }
}

/// An acquired image and the synchronization its one submission must use.
#[derive(Clone, Copy, Debug)]
pub struct Acquired {
    pub index: u32,
    pub image: vk::Image,
    /// A 2D colour view of `image`.
    pub view: vk::ImageView,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
    /// Signalled when the image may be written: wait on it before the first write.
    pub wait: vk::Semaphore,
    /// Signal it when the image is finished; presentation waits on it.
    pub signal: vk::Semaphore,
    /// Signal it with the same submission: the slot is reused once it has signalled.
    pub fence: vk::Fence,
    /// The frame-in-flight slot (0..frames_in_flight), for per-slot resources of the caller.
    pub slot: usize,
}

struct Chain {
    swapchain: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    views: Vec<vk::ImageView>,
    /// One per image: a semaphore is reused only when its image is acquired again, which implies
    /// the presentation that waited on it has consumed it.
    rendered: Vec<vk::Semaphore>,
    format: vk::Format,
    extent: vk::Extent2D,
}

struct Slot {
    acquired: vk::Semaphore,
    fence: vk::Fence,
}

/// A swapchain on a surface, with frames-in-flight synchronization. Owns the surface.
pub struct Presenter {
    surface_fn: ash::khr::surface::Instance,
    swapchain_fn: ash::khr::swapchain::Device,
    device: ash::Device,
    physical: vk::PhysicalDevice,
    surface: vk::SurfaceKHR,
    config: PresentConfig,
    chain: Option<Chain>,
    slots: Vec<Slot>,
    next_slot: usize,
    /// The image `acquire` handed out whose fence it reset, until `present` or `abandon`: a
    /// submission with that fence is owed, so the next `acquire` must not wait on it.
    outstanding: Option<Acquired>,
    stale: bool,
    recreations: u32,
}

/// The swapchain extent for a surface: its current extent when the surface fixes it, else the
/// window's size clamped to what the surface allows. `None` when either side is 0 (minimized).
pub fn choose_extent(caps: &vk::SurfaceCapabilitiesKHR, window: (u32, u32)) -> Option<vk::Extent2D> {
    let extent = if caps.current_extent.width != u32::MAX {
        caps.current_extent
    } else {
        vk::Extent2D {
            width: window.0.clamp(caps.min_image_extent.width, caps.max_image_extent.width.max(1)),
            height: window.1.clamp(caps.min_image_extent.height, caps.max_image_extent.height.max(1)),
        }
    };
    (extent.width > 0 && extent.height > 0 && window.0 > 0 && window.1 > 0).then_some(extent)
}

impl Presenter {
    /// Takes ownership of `surface` (destroyed by [`Presenter::destroy`]). The swapchain itself is
    /// created by the first `acquire`, at the window's size then.
    ///
    /// # Safety
    /// The handles must be valid and related (surface and device from `instance`, the device's
    /// queue family able to present to the surface), and outlive the presenter; `destroy` must be
    /// called before the device and the instance are destroyed.
    pub unsafe fn new(
        entry: &ash::Entry,
        instance: &ash::Instance,
        physical: vk::PhysicalDevice,
        device: &ash::Device,
        surface: vk::SurfaceKHR,
        config: PresentConfig,
    ) -> GpuResult<Self> {
        let mut presenter = Presenter {
            surface_fn: ash::khr::surface::Instance::new(entry, instance),
            swapchain_fn: ash::khr::swapchain::Device::new(instance, device),
            device: device.clone(),
            physical,
            surface,
            chain: None,
            slots: Vec::new(),
            next_slot: 0,
            outstanding: None,
            stale: true,
            recreations: 0,
            config,
        };
        for _ in 0..presenter.config.frames_in_flight.max(1) {
            match create_slot(device) {
                Ok(slot) => presenter.slots.push(slot),
                Err(e) => {
                    presenter.destroy();
                    return Err(e);
                }
            }
        }
        Ok(presenter)
    }

    /// The current swapchain's format and extent (`None` before the first image or while minimized).
    pub fn current(&self) -> Option<(vk::Format, vk::Extent2D)> {
        self.chain.as_ref().map(|c| (c.format, c.extent))
    }

    /// How many times the swapchain was (re)created, for tests and logs.
    pub fn recreations(&self) -> u32 {
        self.recreations
    }

    /// The window changed size: recreate before the next image.
    pub fn window_resized(&mut self) {
        self.stale = true;
    }

    /// Acquires the next image (see the module docs). `window` is the window's inner size in pixels.
    pub fn acquire(&mut self, window: (u32, u32)) -> GpuResult<Option<Acquired>> {
        if let Some(prev) = &self.outstanding {
            // Its fence was reset and never submitted (or the caller lost track): waiting on the
            // slot's fence, now or n frames later, would never return.
            return Err(crate::GpuError::FrameNotFinished {
                index: prev.index,
                slot: prev.slot,
                message: "acquired but neither presented nor given back: after a failed recording \
                          or submission call Presenter::abandon before the next acquire"
                    .into(),
            });
        }
        if window.0 == 0 || window.1 == 0 {
            return Ok(None); // minimized: nothing to draw, nothing to recreate yet
        }
        if (self.stale || self.chain.is_none()) && !self.recreate(window)? {
            return Ok(None);
        }
        let slot = self.next_slot;
        let (sem, fence) = (self.slots[slot].acquired, self.slots[slot].fence);
        let Some(chain) = &self.chain else { return Ok(None) };
        // SAFETY: handles owned by this presenter; the fence was signalled at creation or submitted.
        unsafe { self.device.wait_for_fences(&[fence], true, u64::MAX) }.vk("vkWaitForFences")?;
        // SAFETY: the swapchain is this presenter's; `sem` has no pending operation: the submission
        // that waited on it last (the caller's, as `Acquired::wait`) finished with the fence above.
        let acquired = unsafe {
            self.swapchain_fn.acquire_next_image(chain.swapchain, u64::MAX, sem, vk::Fence::null())
        };
        let (index, suboptimal) = match acquired {
            Ok(v) => v,
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                log::info!("vkAcquireNextImageKHR: out of date; recreating the swapchain");
                self.stale = true;
                return Ok(None);
            }
            Err(e) => return Err(e).vk("vkAcquireNextImageKHR"),
        };
        // Suboptimal still presents correctly: use this image, recreate before the next one.
        if suboptimal {
            log::info!("vkAcquireNextImageKHR: suboptimal; recreating after this frame");
            self.stale = true;
        }
        // Reset only now that a submission with the fence will follow.
        // SAFETY: the fence is this presenter's and signalled (waited above), so no submission uses it.
        unsafe { self.device.reset_fences(&[fence]) }.vk("vkResetFences")?;
        let i = index as usize;
        let acquired = Acquired {
            index,
            image: chain.images[i],
            view: chain.views[i],
            format: chain.format,
            extent: chain.extent,
            wait: sem,
            signal: chain.rendered[i],
            fence,
            slot,
        };
        self.outstanding = Some(acquired);
        Ok(Some(acquired))
    }

    /// Gives back an image whose frame was not submitted (its recording, or `vkQueueSubmit`
    /// itself, failed): submits an empty batch on `queue` that waits on [`Acquired::wait`] and
    /// signals [`Acquired::fence`], so the slot's fence and semaphore are ready for the next
    /// `acquire`, and recreates the swapchain before the next image (which releases this one,
    /// never presented: it holds no picture). Call it instead of `present`, only when no
    /// submission with `acquired.fence` was made.
    pub fn abandon(&mut self, queue: vk::Queue, acquired: &Acquired) -> GpuResult<()> {
        let waits = [vk::SemaphoreSubmitInfo::default()
            .semaphore(acquired.wait)
            .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
        let submit = [vk::SubmitInfo2::default().wait_semaphore_infos(&waits)];
        // SAFETY: `wait` has a pending signal from this presenter's acquire that nothing waits on,
        // and `fence` was reset by it and not submitted (this function's contract); both are this
        // presenter's, on `queue`'s device.
        unsafe { self.device.queue_submit2(queue, &submit, acquired.fence) }.vk("vkQueueSubmit2")?;
        // Only now: if the submission failed, the fence is still unsignalled and `acquire` refuses.
        self.outstanding = None;
        self.stale = true;
        self.next_slot = (self.next_slot + 1) % self.slots.len();
        Ok(())
    }

    /// Queues `acquired` for presentation on `queue` (after the caller's submission).
    pub fn present(&mut self, queue: vk::Queue, acquired: &Acquired) -> GpuResult<()> {
        self.outstanding = None;
        self.next_slot = (self.next_slot + 1) % self.slots.len();
        let Some(chain) = &self.chain else { return Ok(()) };
        let swapchains = [chain.swapchain];
        let indices = [acquired.index];
        let waits = [acquired.signal];
        let info = vk::PresentInfoKHR::default()
            .wait_semaphores(&waits)
            .swapchains(&swapchains)
            .image_indices(&indices);
        // SAFETY: the image was acquired from this swapchain and its submission signals `signal`.
        match unsafe { self.swapchain_fn.queue_present(queue, &info) } {
            Ok(false) => {}
            Ok(true) | Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                log::info!("vkQueuePresentKHR: suboptimal or out of date; recreating the swapchain");
                self.stale = true;
            }
            Err(e) => return Err(e).vk("vkQueuePresentKHR"),
        }
        Ok(())
    }

    /// Recreates the swapchain for the window's size; false when the surface is 0×0 now.
    fn recreate(&mut self, window: (u32, u32)) -> GpuResult<bool> {
        // SAFETY: plain queries on owned handles.
        let caps =
            unsafe { self.surface_fn.get_physical_device_surface_capabilities(self.physical, self.surface) }
                .vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR")?;
        let Some(extent) = choose_extent(&caps, window) else { return Ok(false) };
        // SAFETY: the device outlives the presenter (`new`'s contract).
        unsafe { self.device.device_wait_idle() }.vk("vkDeviceWaitIdle")?;
        let old = self.chain.take();
        let created = self.create_chain(&caps, extent, old.as_ref().map(|c| c.swapchain));
        if let Some(old) = old {
            self.destroy_chain(old);
        }
        self.chain = Some(created?);
        self.stale = false;
        self.recreations += 1;
        log::info!("swapchain {}x{} ({} recreations)", extent.width, extent.height, self.recreations);
        Ok(true)
    }

    fn create_chain(
        &self,
        caps: &vk::SurfaceCapabilitiesKHR,
        extent: vk::Extent2D,
        old: Option<vk::SwapchainKHR>,
    ) -> GpuResult<Chain> {
        // SAFETY: plain queries; physical device and surface come from this presenter's instance.
        let (formats, modes) = unsafe {
            (
                self.surface_fn.get_physical_device_surface_formats(self.physical, self.surface),
                self.surface_fn.get_physical_device_surface_present_modes(self.physical, self.surface),
            )
        };
        let formats = formats.vk("vkGetPhysicalDeviceSurfaceFormatsKHR")?;
        let modes = modes.vk("vkGetPhysicalDeviceSurfacePresentModesKHR")?;
        let format =
            self.config.formats.iter().find_map(|f| formats.iter().find(|s| s.format == *f)).ok_or_else(
                || crate::GpuError::SurfaceUnsupported {
                    what: "swapchain format",
                    message: format!(
                        "the surface offers {:?}, none of the wanted {:?}",
                        formats.iter().map(|f| f.format).collect::<Vec<_>>(),
                        self.config.formats
                    ),
                },
            )?;
        let mode = self
            .config
            .present_modes
            .iter()
            .copied()
            .find(|m| modes.contains(m))
            .unwrap_or(vk::PresentModeKHR::FIFO);
        if !caps.supported_usage_flags.contains(self.config.usage) {
            return Err(crate::GpuError::SurfaceUnsupported {
                what: "swapchain image usage",
                message: format!(
                    "wanted {:?}, the surface supports {:?}",
                    self.config.usage, caps.supported_usage_flags
                ),
            });
        }
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let alpha = [vk::CompositeAlphaFlagsKHR::OPAQUE, vk::CompositeAlphaFlagsKHR::INHERIT]
            .into_iter()
            .find(|a| caps.supported_composite_alpha.contains(*a))
            .unwrap_or(vk::CompositeAlphaFlagsKHR::OPAQUE);
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(self.config.usage)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(alpha)
            .present_mode(mode)
            .clipped(true)
            .old_swapchain(old.unwrap_or_default());
        // SAFETY: valid create info; the old swapchain is retired, destroyed by the caller.
        let swapchain =
            unsafe { self.swapchain_fn.create_swapchain(&info, None) }.vk("vkCreateSwapchainKHR")?;
        let mut chain = Chain {
            swapchain,
            images: Vec::new(),
            views: Vec::new(),
            rendered: Vec::new(),
            format: format.format,
            extent,
        };
        let filled = (|| {
            // SAFETY: `swapchain` was just created on this device.
            chain.images =
                unsafe { self.swapchain_fn.get_swapchain_images(swapchain) }.vk("vkGetSwapchainImagesKHR")?;
            for &image in &chain.images {
                let view_info = vk::ImageViewCreateInfo::default()
                    .image(image)
                    .view_type(vk::ImageViewType::TYPE_2D)
                    .format(format.format)
                    .subresource_range(color_range());
                // SAFETY: the image belongs to the live swapchain; destroy_chain destroys the view
                // before the swapchain.
                chain.views.push(
                    unsafe { self.device.create_image_view(&view_info, None) }.vk("vkCreateImageView")?,
                );
                // SAFETY: valid device; destroyed by destroy_chain.
                let sem = unsafe { self.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) };
                chain.rendered.push(sem.vk("vkCreateSemaphore")?);
            }
            Ok(())
        })();
        match filled {
            Ok(()) => Ok(chain),
            Err(e) => {
                self.destroy_chain(chain);
                Err(e)
            }
        }
    }

    fn destroy_chain(&self, chain: Chain) {
        // SAFETY: the device is idle (recreate and destroy wait first); owned handles.
        unsafe {
            chain.views.iter().for_each(|v| self.device.destroy_image_view(*v, None));
            chain.rendered.iter().for_each(|s| self.device.destroy_semaphore(*s, None));
            self.swapchain_fn.destroy_swapchain(chain.swapchain, None);
        }
    }

    /// Waits for the device, then destroys the swapchain, the synchronization objects and the surface.
    pub fn destroy(&mut self) {
        // SAFETY: owned handles; after the idle wait nothing uses them.
        unsafe {
            let _ = self.device.device_wait_idle();
            if let Some(chain) = self.chain.take() {
                self.destroy_chain(chain);
            }
            for slot in self.slots.drain(..) {
                self.device.destroy_fence(slot.fence, None);
                self.device.destroy_semaphore(slot.acquired, None);
            }
            if self.surface != vk::SurfaceKHR::null() {
                self.surface_fn.destroy_surface(self.surface, None);
                self.surface = vk::SurfaceKHR::null();
            }
        }
    }
}

fn color_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange::default()
        .aspect_mask(vk::ImageAspectFlags::COLOR)
        .level_count(1)
        .layer_count(1)
}

/// A frame-in-flight slot; its fence starts signalled so the first wait returns at once.
unsafe fn create_slot(device: &ash::Device) -> GpuResult<Slot> {
    let signalled = vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED);
    let fence = device.create_fence(&signalled, None).vk("vkCreateFence")?;
    match device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None).vk("vkCreateSemaphore") {
        Ok(acquired) => Ok(Slot { acquired, fence }),
        Err(e) => {
            device.destroy_fence(fence, None);
            Err(e)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn caps(current: (u32, u32)) -> vk::SurfaceCapabilitiesKHR {
        vk::SurfaceCapabilitiesKHR {
            current_extent: vk::Extent2D { width: current.0, height: current.1 },
            min_image_extent: vk::Extent2D { width: 1, height: 1 },
            max_image_extent: vk::Extent2D { width: 4096, height: 4096 },
            ..Default::default()
        }
    }

    #[test]
    fn minimized_window_gives_no_extent() {
        assert_eq!(choose_extent(&caps((0, 0)), (0, 0)), None);
        assert_eq!(choose_extent(&caps((0, 0)), (640, 480)), None, "the surface says 0×0");
        assert_eq!(choose_extent(&caps((u32::MAX, u32::MAX)), (0, 480)), None, "the window says 0 wide");
        assert_eq!(choose_extent(&caps((640, 480)), (640, 0)), None);
    }

    #[test]
    fn surface_extent_wins_and_free_surfaces_clamp_the_window() {
        assert_eq!(
            choose_extent(&caps((320, 200)), (640, 480)),
            Some(vk::Extent2D { width: 320, height: 200 })
        );
        let free = caps((u32::MAX, u32::MAX));
        assert_eq!(choose_extent(&free, (640, 480)), Some(vk::Extent2D { width: 640, height: 480 }));
        assert_eq!(choose_extent(&free, (9000, 10)), Some(vk::Extent2D { width: 4096, height: 10 }));
    }
}
