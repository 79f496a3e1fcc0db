//! The game's own Vulkan — instance (with validation), device, queue, a command buffer and fence
//! per frame in flight, images, and a raster pipeline for flat-shaded boxes into standard-Z depth.
//! Nothing here calls hadou: hadou is embedded on top of these objects (game.rs).
#![allow(dead_code)]

use std::ffi::{c_char, c_void, CStr};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use ash::vk;

/// Validation messages the game's messenger received (hadou's included: it shares the device).
#[derive(Default)]
pub struct Messages {
    pub errors: AtomicU64,
    pub warnings: AtomicU64,
    pub texts: Mutex<Vec<String>>,
}

impl Messages {
    pub fn counts(&self) -> (u64, u64) {
        (self.errors.load(Ordering::Relaxed), self.warnings.load(Ordering::Relaxed))
    }
}

/// A messenger that counts validation errors and warnings into `messages` (`on_message`); the
/// caller keeps `messages` until the messenger is destroyed.
pub fn messenger_info(messages: &Arc<Messages>) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::ERROR | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(on_message))
        .user_data(Arc::as_ptr(messages) as *mut c_void)
}

pub unsafe extern "system" fn on_message(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    let error = severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR);
    if !error && !severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        return vk::FALSE;
    }
    // SAFETY: `user` is the Arc<Messages> the messenger was created with; it outlives the messenger.
    let messages = unsafe { &*(user as *const Messages) };
    let counter = if error { &messages.errors } else { &messages.warnings };
    counter.fetch_add(1, Ordering::Relaxed);
    // SAFETY: the loader passes null or callback data valid for this call; its `pMessage` is null or
    // a NUL-terminated string valid for the call too.
    let text = unsafe { data.as_ref() }
        // SAFETY: as above.
        .and_then(|d| unsafe { d.message_as_c_str() })
        .map(|m| m.to_string_lossy().into_owned())
        .unwrap_or_default();
    if let Ok(mut t) = messages.texts.lock() {
        if t.len() < 32 {
            t.push(text);
        }
    }
    vk::FALSE
}

pub struct GameVk {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    pub physical: vk::PhysicalDevice,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub messages: Arc<Messages>,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    pool: vk::CommandPool,
    /// The command buffer being recorded: slot `slot`'s.
    pub cmd: vk::CommandBuffer,
    /// The fence of the slot being recorded.
    pub fence: vk::Fence,
    pub slot: usize,
    /// How long the last `begin_slot` waited for the slot's previous frame (ms).
    pub last_wait_ms: f64,
    /// How long the last `submit_slot` took (ms): on lavapipe the frame runs inside it.
    pub last_submit_ms: f64,
    /// Per frame in flight: its command buffer and fence, and whether a submission is pending.
    slots: Vec<(vk::CommandBuffer, vk::Fence, bool)>,
    memory_props: vk::PhysicalDeviceMemoryProperties,
}

/// The game's frames in flight (hadou's renderer is made with the same number).
pub const FRAMES_IN_FLIGHT: usize = 2;

const VALIDATION: &CStr = c"VK_LAYER_KHRONOS_validation";

impl GameVk {
    /// `instance_extensions`/`device_extensions`: what a window needs (surface, swapchain).
    /// `can_present(physical, family)` filters queue families (always true offscreen).
    pub fn new(
        validation: bool,
        instance_extensions: &[*const c_char],
        device_extensions: &[*const c_char],
        can_present: &dyn Fn(&ash::Entry, &ash::Instance, vk::PhysicalDevice, u32) -> bool,
    ) -> Result<Self, String> {
        // SAFETY: loads the system's libvulkan, whose load-time initializers have no preconditions.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| format!("no Vulkan loader: {e}"))?;
        let messages = Arc::new(Messages::default());
        let app = vk::ApplicationInfo::default()
            .application_name(c"game_prototype")
            .api_version(vk::API_VERSION_1_3);
        let layers: Vec<*const c_char> = if validation { vec![VALIDATION.as_ptr()] } else { vec![] };
        let mut extensions = instance_extensions.to_vec();
        extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
        let mut info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if validation {
            info = info.push_next(&mut features);
        }
        // SAFETY: everything `info` points at (application info, layer and extension names, the
        // validation features) outlives the call; the caller's extension names are static strings.
        let instance =
            unsafe { entry.create_instance(&info, None) }.map_err(|e| format!("vkCreateInstance: {e}"))?;
        let debug_instance = ash::ext::debug_utils::Instance::new(&entry, &instance);
        let messenger_info = messenger_info(&messages);
        // SAFETY: the callback's `user_data` is `messages`, which GameVk keeps until `destroy`
        // destroys the messenger.
        let messenger = unsafe { debug_instance.create_debug_utils_messenger(&messenger_info, None) }
            .map_err(|e| format!("vkCreateDebugUtilsMessengerEXT: {e}"))?;
        let debug = Some((debug_instance, messenger));
        // SAFETY: plain query on the instance just created.
        let physicals = unsafe { instance.enumerate_physical_devices() }.map_err(|e| e.to_string())?;
        let mut found = None;
        for physical in physicals {
            // SAFETY: plain queries; `physical` was enumerated from this instance.
            let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
            // SAFETY: as above.
            let api = unsafe { instance.get_physical_device_properties(physical) }.api_version;
            if api < vk::API_VERSION_1_3 {
                continue;
            }
            let wanted = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
            if let Some(family) = families.iter().enumerate().position(|(i, f)| {
                f.queue_flags.contains(wanted)
                    && f.timestamp_valid_bits > 0
                    && can_present(&entry, &instance, physical, i as u32)
            }) {
                found = Some((physical, family as u32));
                break;
            }
        }
        let Some((physical, queue_family)) = found else {
            return Err("no Vulkan 1.3 device with a graphics+compute queue".into());
        };
        let priorities = [1.0f32];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        // What the game itself uses, plus what hadou needs (EnabledFeatures::REQUIRED).
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(true)
            .synchronization2(true)
            .maintenance4(true);
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default().host_query_reset(true);
        let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f13).push_next(&mut f12);
        let info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .enabled_extension_names(device_extensions)
            .push_next(&mut f2);
        // SAFETY: `physical` and `queue_family` come from this instance's queries; everything `info`
        // points at outlives the call (device extension names: static strings). A device lacking a
        // feature fails the call with an Err.
        let device = unsafe { instance.create_device(physical, &info, None) }
            .map_err(|e| format!("vkCreateDevice: {e}"))?;
        // SAFETY: the device was created with one queue of `queue_family`.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: the device was just created; the pool is destroyed by `destroy`.
        let pool = unsafe { device.create_command_pool(&pool_info, None) }.map_err(|e| e.to_string())?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .command_buffer_count(FRAMES_IN_FLIGHT as u32);
        // SAFETY: the pool was just created on this device; it frees the buffers when destroyed.
        let cmds = unsafe { device.allocate_command_buffers(&alloc) }.map_err(|e| e.to_string())?;
        let mut slots = Vec::new();
        for cmd in cmds {
            // SAFETY: valid device; the fences are destroyed by `destroy`.
            let fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
                .map_err(|e| e.to_string())?;
            slots.push((cmd, fence, false));
        }
        let (cmd, fence, _) = slots[0];
        // SAFETY: plain query; `physical` comes from this instance.
        let memory_props = unsafe { instance.get_physical_device_memory_properties(physical) };
        Ok(GameVk {
            entry,
            instance,
            physical,
            device,
            queue,
            queue_family,
            messages,
            debug,
            pool,
            cmd,
            fence,
            slot: 0,
            last_wait_ms: 0.0,
            last_submit_ms: 0.0,
            slots,
            memory_props,
        })
    }

    /// What hadou needs to embed itself on this device (the game keeps owning all of it).
    pub fn hadou_raw(&self) -> hadou::gpu::RawVulkan {
        hadou::gpu::RawVulkan {
            entry: self.entry.clone(),
            instance: self.instance.clone(),
            physical_device: self.physical,
            device: self.device.clone(),
            queue_family: self.queue_family,
            queue_index: 0,
            enabled: hadou::gpu::EnabledFeatures::REQUIRED,
            debug_utils: true,
        }
    }

    /// Makes `slot` the one recorded: waits for its previous submission (the game's frame n − F,
    /// which is what hadou's frame contract needs), then begins its command buffer.
    pub fn begin_slot(&mut self, slot: usize) -> Result<(), String> {
        let (cmd, fence, pending) = self.slots[slot];
        let start = std::time::Instant::now();
        if pending {
            // SAFETY: the slot's fence was submitted (pending); it is reset only after the wait.
            unsafe {
                self.device.wait_for_fences(&[fence], true, u64::MAX).map_err(|e| e.to_string())?;
                self.device.reset_fences(&[fence]).map_err(|e| e.to_string())?;
            }
            self.slots[slot].2 = false;
        }
        self.last_wait_ms = start.elapsed().as_secs_f64() * 1e3;
        (self.cmd, self.fence, self.slot) = (cmd, fence, slot);
        self.begin()
    }

    /// Makes `slot` the one recorded when the caller already waited for its previous frame (a
    /// swapchain frame's fence), and begins its command buffer.
    pub fn begin_waited_slot(&mut self, slot: usize) -> Result<(), String> {
        let (cmd, fence, _) = self.slots[slot];
        (self.cmd, self.fence, self.slot) = (cmd, fence, slot);
        self.begin()
    }

    /// Ends and submits the slot being recorded with its own fence; does not wait.
    pub fn submit_slot(&mut self) -> Result<(), String> {
        let start = std::time::Instant::now();
        // SAFETY: the slot's command buffer is recording (begin_slot); its fence is unsignalled and
        // unused (created so, or reset after its wait); the submit arrays outlive the call.
        unsafe {
            self.device.end_command_buffer(self.cmd).map_err(|e| e.to_string())?;
            let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(self.cmd)];
            let submit = [vk::SubmitInfo2::default().command_buffer_infos(&cmds)];
            self.device.queue_submit2(self.queue, &submit, self.fence).map_err(|e| e.to_string())?;
        }
        self.slots[self.slot].2 = true;
        self.last_submit_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(())
    }

    /// Waits for every pending slot.
    pub fn wait_slots(&mut self) -> Result<(), String> {
        for slot in 0..self.slots.len() {
            let (_, fence, pending) = self.slots[slot];
            if pending {
                // SAFETY: the slot's fence was submitted (pending); it is reset only after the wait.
                unsafe {
                    self.device.wait_for_fences(&[fence], true, u64::MAX).map_err(|e| e.to_string())?;
                    self.device.reset_fences(&[fence]).map_err(|e| e.to_string())?;
                }
                self.slots[slot].2 = false;
            }
        }
        Ok(())
    }

    pub fn begin(&self) -> Result<(), String> {
        // SAFETY: the command buffer is not pending: the slot's previous frame was waited for
        // (begin_slot, or the caller's swapchain fence for begin_waited_slot).
        unsafe {
            self.device
                .reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())
                .map_err(|e| e.to_string())?;
            let info =
                vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            self.device.begin_command_buffer(self.cmd, &info).map_err(|e| e.to_string())
        }
    }

    /// Ends and submits, waiting on / signalling the semaphores and signalling `fence` (a
    /// swapchain frame's); does not wait.
    pub fn submit(
        &self,
        wait: (vk::Semaphore, vk::PipelineStageFlags2),
        signal: vk::Semaphore,
        fence: vk::Fence,
    ) -> Result<(), String> {
        // SAFETY: the command buffer is recording (begin); the semaphores and the unsignalled fence
        // are the caller's swapchain frame's, on this device; the submit arrays outlive the call.
        unsafe {
            self.device.end_command_buffer(self.cmd).map_err(|e| e.to_string())?;
            let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(self.cmd)];
            let waits = [vk::SemaphoreSubmitInfo::default().semaphore(wait.0).stage_mask(wait.1)];
            let signals = [vk::SemaphoreSubmitInfo::default()
                .semaphore(signal)
                .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
            let submit = [vk::SubmitInfo2::default()
                .command_buffer_infos(&cmds)
                .wait_semaphore_infos(&waits)
                .signal_semaphore_infos(&signals)];
            self.device.queue_submit2(self.queue, &submit, fence).map_err(|e| e.to_string())
        }
    }

    /// Ends, submits (waiting on / signalling the given semaphores) and waits for the fence.
    pub fn submit_and_wait(
        &self,
        wait: Option<(vk::Semaphore, vk::PipelineStageFlags2)>,
        signal: Option<vk::Semaphore>,
    ) -> Result<(), String> {
        // SAFETY: the command buffer is recording (begin); the current fence is unsignalled and
        // unused, and is waited for and reset before returning; the submit arrays outlive the call.
        unsafe {
            self.device.end_command_buffer(self.cmd).map_err(|e| e.to_string())?;
            let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(self.cmd)];
            let waits: Vec<_> = wait
                .iter()
                .map(|&(s, stage)| vk::SemaphoreSubmitInfo::default().semaphore(s).stage_mask(stage))
                .collect();
            let signals: Vec<_> = signal
                .iter()
                .map(|&s| {
                    vk::SemaphoreSubmitInfo::default()
                        .semaphore(s)
                        .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                })
                .collect();
            let submit = [vk::SubmitInfo2::default()
                .command_buffer_infos(&cmds)
                .wait_semaphore_infos(&waits)
                .signal_semaphore_infos(&signals)];
            self.device.queue_submit2(self.queue, &submit, self.fence).map_err(|e| e.to_string())?;
            self.device.wait_for_fences(&[self.fence], true, u64::MAX).map_err(|e| e.to_string())?;
            self.device.reset_fences(&[self.fence]).map_err(|e| e.to_string())
        }
    }

    fn memory_type(&self, bits: u32, flags: vk::MemoryPropertyFlags) -> Result<u32, String> {
        (0..self.memory_props.memory_type_count)
            .find(|&i| {
                bits & (1 << i) != 0
                    && self.memory_props.memory_types[i as usize].property_flags.contains(flags)
            })
            .ok_or_else(|| format!("no memory type with {flags:?}"))
    }

    pub fn create_image(
        &self,
        extent: vk::Extent2D,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
    ) -> Result<GameImage, String> {
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width: extent.width, height: extent.height, depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .usage(usage);
        // SAFETY: every object is created on this device and used only after it is created; the
        // memory is a fresh allocation of a type the image allows; destroy_image frees them.
        unsafe {
            let image = self.device.create_image(&info, None).map_err(|e| e.to_string())?;
            let req = self.device.get_image_memory_requirements(image);
            let alloc = vk::MemoryAllocateInfo::default().allocation_size(req.size).memory_type_index(
                self.memory_type(req.memory_type_bits, vk::MemoryPropertyFlags::DEVICE_LOCAL)?,
            );
            let memory = self.device.allocate_memory(&alloc, None).map_err(|e| e.to_string())?;
            self.device.bind_image_memory(image, memory, 0).map_err(|e| e.to_string())?;
            let view_info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format)
                .subresource_range(range(format));
            let view = self.device.create_image_view(&view_info, None).map_err(|e| e.to_string())?;
            Ok(GameImage { image, view, memory, format, extent })
        }
    }

    pub fn create_host_buffer(&self, size: u64) -> Result<HostBuffer, String> {
        // TRANSFER_SRC too: tests/wgpu_host.rs uploads another host's images through it.
        let usage = vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC;
        let info = vk::BufferCreateInfo::default().size(size).usage(usage);
        // SAFETY: as in create_image; the mapping covers `size` bytes of host-coherent memory and
        // lives until destroy_buffer frees the memory.
        unsafe {
            let buffer = self.device.create_buffer(&info, None).map_err(|e| e.to_string())?;
            let req = self.device.get_buffer_memory_requirements(buffer);
            let flags = vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
            let alloc = vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(self.memory_type(req.memory_type_bits, flags)?);
            let memory = self.device.allocate_memory(&alloc, None).map_err(|e| e.to_string())?;
            self.device.bind_buffer_memory(buffer, memory, 0).map_err(|e| e.to_string())?;
            let ptr = self
                .device
                .map_memory(memory, 0, size, vk::MemoryMapFlags::empty())
                .map_err(|e| e.to_string())?;
            Ok(HostBuffer { buffer, memory, ptr: ptr as *const u8, size })
        }
    }

    /// Records a copy of a whole image (in TRANSFER_SRC_OPTIMAL) into `buffer`, then makes it
    /// visible to the host.
    pub fn record_copy_to_host(&self, image: &GameImage, buffer: &HostBuffer) {
        let aspect = range(image.format).aspect_mask;
        let region = vk::BufferImageCopy::default()
            .image_subresource(vk::ImageSubresourceLayers::default().aspect_mask(aspect).layer_count(1))
            .image_extent(vk::Extent3D { width: image.extent.width, height: image.extent.height, depth: 1 });
        // SAFETY: the command buffer is recording; image and buffer are live until the frame is
        // waited for, and the caller sized the buffer for the whole image.
        unsafe {
            self.device.cmd_copy_image_to_buffer(
                self.cmd,
                image.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buffer.buffer,
                &[region],
            );
        }
        let to_host = vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::HOST)
            .dst_access_mask(vk::AccessFlags2::HOST_READ);
        let dep = vk::DependencyInfo::default().memory_barriers(std::slice::from_ref(&to_host));
        // SAFETY: the command buffer is recording; `dep` outlives the call.
        unsafe { self.device.cmd_pipeline_barrier2(self.cmd, &dep) };
    }

    /// Records a copy of a whole colour image (in TRANSFER_SRC_OPTIMAL) into `dst` (same format,
    /// in TRANSFER_DST_OPTIMAL) at column `x`.
    pub fn record_copy_image(&self, src: &GameImage, dst: vk::Image, x: i32) {
        let layers =
            vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1);
        let region = vk::ImageCopy::default()
            .src_subresource(layers)
            .dst_subresource(layers)
            .dst_offset(vk::Offset3D { x, y: 0, z: 0 })
            .extent(vk::Extent3D { width: src.extent.width, height: src.extent.height, depth: 1 });
        // SAFETY: the command buffer is recording; both images are live until the frame is waited
        // for, and the caller placed `src` inside `dst`.
        unsafe {
            self.device.cmd_copy_image(
                self.cmd,
                src.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                dst,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            );
        }
    }

    /// One image layout transition, waiting for everything before and blocking everything after
    /// (simple and always correct; the game's frame is small).
    pub fn transition(
        &self,
        image: vk::Image,
        format: vk::Format,
        from: vk::ImageLayout,
        to: vk::ImageLayout,
    ) {
        let barrier = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE)
            .old_layout(from)
            .new_layout(to)
            .image(image)
            .subresource_range(range(format));
        let dep = vk::DependencyInfo::default().image_memory_barriers(std::slice::from_ref(&barrier));
        // SAFETY: the command buffer is recording; the image is the caller's live image.
        unsafe { self.device.cmd_pipeline_barrier2(self.cmd, &dep) };
    }

    pub fn destroy_image(&self, image: GameImage) {
        // SAFETY: the image was made by create_image on this device and is taken by value; callers
        // destroy it only after the frames using it finished (a device or slot wait).
        unsafe {
            self.device.destroy_image_view(image.view, None);
            self.device.destroy_image(image.image, None);
            self.device.free_memory(image.memory, None);
        }
    }

    pub fn destroy_buffer(&self, buffer: HostBuffer) {
        // SAFETY: as in destroy_image (freeing the memory also unmaps it).
        unsafe {
            self.device.destroy_buffer(buffer.buffer, None);
            self.device.free_memory(buffer.memory, None);
        }
    }

    /// Destroys the device and instance. Everything made on them (hadou included) is gone already.
    pub fn destroy(self) {
        // SAFETY: after the idle wait nothing runs on the device; everything else made on it
        // (hadou included) was destroyed before (the caller's order); the messenger goes before
        // the instance, and `messages` outlives it.
        unsafe {
            let _ = self.device.device_wait_idle();
            for (_, fence, _) in &self.slots {
                self.device.destroy_fence(*fence, None);
            }
            self.device.destroy_command_pool(self.pool, None);
            self.device.destroy_device(None);
            if let Some((d, m)) = &self.debug {
                d.destroy_debug_utils_messenger(*m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

pub fn is_depth(format: vk::Format) -> bool {
    matches!(format, vk::Format::D32_SFLOAT | vk::Format::D16_UNORM | vk::Format::D24_UNORM_S8_UINT)
}

pub fn range(format: vk::Format) -> vk::ImageSubresourceRange {
    let aspect = if is_depth(format) { vk::ImageAspectFlags::DEPTH } else { vk::ImageAspectFlags::COLOR };
    vk::ImageSubresourceRange::default().aspect_mask(aspect).level_count(1).layer_count(1)
}

pub struct GameImage {
    pub image: vk::Image,
    pub view: vk::ImageView,
    memory: vk::DeviceMemory,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
}

pub struct HostBuffer {
    pub buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    ptr: *const u8,
    pub size: u64,
}

impl HostBuffer {
    pub fn bytes(&self) -> &[u8] {
        // SAFETY: mapped for the buffer's lifetime, host-coherent, read after the fence.
        unsafe { std::slice::from_raw_parts(self.ptr, self.size as usize) }
    }

    /// Writes `bytes` at the start (before any command that reads the buffer is submitted).
    pub fn write(&self, bytes: &[u8]) {
        assert!(bytes.len() as u64 <= self.size, "{} bytes into a buffer of {}", bytes.len(), self.size);
        // SAFETY: mapped, host-coherent, at least `bytes.len()` long (asserted); the caller writes
        // before submitting the commands that read it, so the GPU does not read it meanwhile.
        unsafe { std::ptr::copy_nonoverlapping(bytes.as_ptr(), self.ptr as *mut u8, bytes.len()) };
    }
}
