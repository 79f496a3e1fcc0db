//! wgpu on Vulkan, opened through wgpu-hal so that its device also has what hadou needs
//! (`EnabledFeatures::REQUIRED`), and the raw Vulkan objects handed to hadou (`hadou_raw`).
//! Validation (wgpu's `InstanceFlags::VALIDATION`) adds synchronization validation and a
//! messenger of our own that counts what the layer reports, hadou's commands included.
#![allow(dead_code)]

use std::sync::Arc;

use ash::vk;
use wgpu::hal::api::Vulkan;

use super::gpu::{messenger_info, Messages};

/// wgpu's instance, adapter, device and queue, made for hadou to record into.
pub struct WgpuVulkan {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// What the validation layer reported (stays 0 without validation).
    pub messages: Arc<Messages>,
    messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
}

const VALIDATION_LAYER: &std::ffi::CStr = c"VK_LAYER_KHRONOS_validation";

impl WgpuVulkan {
    /// `validation`: the Khronos layer with synchronization validation; an error when the layer
    /// is missing (a run that asked for validation must not silently go without).
    pub fn new(validation: bool) -> Result<Self, String> {
        let instance = create_instance(validation)?;
        let messages = Arc::new(Messages::default());
        let messenger = if validation { Some(create_messenger(&instance, &messages)?) } else { None };
        let adapter = pick_adapter(&instance)?;
        let (device, queue) = open_device(&adapter)?;
        Ok(WgpuVulkan { instance, adapter, device, queue, messages, messenger })
    }

    /// What hadou needs to embed itself on wgpu's device (wgpu keeps owning all of it).
    pub fn hadou_raw(&self) -> hadou::gpu::RawVulkan {
        // SAFETY: the hal objects are only read here (handles cloned); wgpu keeps them alive as long
        // as `self.instance`/`self.device`, which outlive hadou (the host drops hadou first).
        unsafe {
            let instance = self.instance.as_hal::<Vulkan>().expect("a Vulkan instance");
            let shared = instance.shared_instance();
            let device = self.device.as_hal::<Vulkan>().expect("a Vulkan device");
            hadou::gpu::RawVulkan {
                entry: shared.entry().clone(),
                instance: shared.raw_instance().clone(),
                physical_device: device.raw_physical_device(),
                device: device.raw_device().clone(),
                queue_family: device.queue_family_index(),
                queue_index: device.queue_index(),
                enabled: hadou::gpu::EnabledFeatures::REQUIRED,
                debug_utils: shared.extensions().contains(&ash::ext::debug_utils::NAME),
            }
        }
    }

    /// The Vulkan format wgpu made a texture of `format` with (what hadou's composite is built for).
    pub fn raw_format(&self, format: wgpu::TextureFormat) -> vk::Format {
        // SAFETY: a read of the adapter's format table.
        unsafe { self.adapter.as_hal::<Vulkan>() }.expect("a Vulkan adapter").texture_format_as_raw(format)
    }

    /// Drops the device (everything made on it must be gone: hadou and the host's wgpu objects)
    /// while the messenger still listens (leaks are reported at vkDestroyDevice), then the
    /// messenger, then the instance. Returns what validation reported.
    pub fn destroy(self) -> Arc<Messages> {
        let WgpuVulkan { instance, adapter, device, queue, messages, messenger } = self;
        let _ = device.poll(wgpu::PollType::Wait);
        drop(queue);
        drop(device);
        if let Some((debug, messenger)) = messenger {
            // SAFETY: made on this instance, which is still alive (`instance` below).
            unsafe { debug.destroy_debug_utils_messenger(messenger, None) };
        }
        drop(adapter);
        drop(instance);
        messages
    }
}

fn create_instance(validation: bool) -> Result<wgpu::Instance, String> {
    // Not InstanceFlags::DEBUG: it also writes WGSL debug info into wgpu's SPIR-V (OpSource
    // language 10), which the installed validation layer's SPIR-V validator rejects. Debug utils
    // (our messenger, hadou's labels) are enabled by the callback below instead.
    let flags = if validation { wgpu::InstanceFlags::VALIDATION } else { wgpu::InstanceFlags::empty() };
    let desc = wgpu::hal::InstanceDescriptor {
        name: "wgpu_host",
        flags,
        memory_budget_thresholds: Default::default(),
        backend_options: Default::default(),
    };
    // wgpu enables the layer but not synchronization validation (only GPU-assisted validation, on
    // request): chain VkValidationFeaturesEXT into its instance create info ourselves.
    let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
    let layer_found = std::sync::atomic::AtomicBool::new(false);
    // Moved into the callback, so that it lives as long as the create info's chain needs.
    let (features, found_flag) = (&mut features, &layer_found);
    let callback: Box<wgpu::hal::vulkan::CreateInstanceCallback<'_>> = Box::new(move |args| {
        if !validation {
            return;
        }
        // SAFETY: a plain query of the loader.
        let layers = unsafe { args.entry.enumerate_instance_layer_properties() }.unwrap_or_default();
        let found = layers.iter().any(|l| l.layer_name_as_c_str() == Ok(VALIDATION_LAYER));
        found_flag.store(found, std::sync::atomic::Ordering::Relaxed);
        if !args.extensions.contains(&ash::ext::debug_utils::NAME) {
            args.extensions.push(ash::ext::debug_utils::NAME);
        }
        *args.create_info = std::mem::take(args.create_info).push_next(features);
    });
    // SAFETY: the callback only adds a validation-features struct that outlives the call.
    let hal = unsafe { wgpu::hal::vulkan::Instance::init_with_callback(&desc, Some(callback)) }
        .map_err(|e| format!("Vulkan instance: {e}"))?;
    if validation && !layer_found.load(std::sync::atomic::Ordering::Relaxed) {
        return Err("validation asked for, but VK_LAYER_KHRONOS_validation is not installed".into());
    }
    // SAFETY: a hal instance of the Vulkan backend, handed over to wgpu.
    Ok(unsafe { wgpu::Instance::from_hal::<Vulkan>(hal) })
}

fn create_messenger(
    instance: &wgpu::Instance,
    messages: &Arc<Messages>,
) -> Result<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT), String> {
    // SAFETY: read-only access to the hal instance's handles.
    let hal = unsafe { instance.as_hal::<Vulkan>() }.ok_or("not a Vulkan instance")?;
    let shared = hal.shared_instance();
    if !shared.extensions().contains(&ash::ext::debug_utils::NAME) {
        return Err("wgpu did not enable VK_EXT_debug_utils".into());
    }
    let debug = ash::ext::debug_utils::Instance::new(shared.entry(), shared.raw_instance());
    let info = messenger_info(messages);
    // SAFETY: `user_data` is `messages`, which WgpuVulkan keeps until `destroy` destroys the
    // messenger, before the instance.
    let messenger = unsafe { debug.create_debug_utils_messenger(&info, None) }
        .map_err(|e| format!("vkCreateDebugUtilsMessengerEXT: {e}"))?;
    Ok((debug, messenger))
}

/// The first Vulkan 1.3 adapter (or the first whose name contains $HADOU_DEVICE).
fn pick_adapter(instance: &wgpu::Instance) -> Result<wgpu::Adapter, String> {
    let filter = std::env::var("HADOU_DEVICE").ok();
    let adapters = instance.enumerate_adapters(wgpu::Backends::VULKAN);
    let mut seen = Vec::new();
    for adapter in adapters {
        let info = adapter.get_info();
        // SAFETY: read-only queries on the adapter's physical device.
        let api = unsafe {
            let hal = adapter.as_hal::<Vulkan>().ok_or("not a Vulkan adapter")?;
            let shared = hal.shared_instance();
            shared.raw_instance().get_physical_device_properties(hal.raw_physical_device()).api_version
        };
        let wanted = filter.as_ref().is_none_or(|f| info.name.contains(f.as_str()));
        if wanted && api >= vk::API_VERSION_1_3 {
            return Ok(adapter);
        }
        seen.push(info.name);
    }
    Err(format!("no Vulkan 1.3 adapter (filter {filter:?}); seen {seen:?}"))
}

/// wgpu's device, opened by wgpu-hal with hadou's Vulkan 1.3 features added to its create info.
/// wgpu-hal chains the individual feature structs of what it enables, so ours are individual
/// structs too (a VkPhysicalDeviceVulkan13Features beside them would be invalid).
fn open_device(adapter: &wgpu::Adapter) -> Result<(wgpu::Device, wgpu::Queue), String> {
    let features = wgpu::Features::empty();
    let hints = wgpu::MemoryHints::Performance;
    let mut dynamic_rendering = vk::PhysicalDeviceDynamicRenderingFeatures::default().dynamic_rendering(true);
    let mut sync2 = vk::PhysicalDeviceSynchronization2Features::default().synchronization2(true);
    let mut maintenance4 = vk::PhysicalDeviceMaintenance4Features::default().maintenance4(true);
    let mut query_reset = vk::PhysicalDeviceHostQueryResetFeatures::default().host_query_reset(true);
    let chain = (&mut dynamic_rendering, &mut sync2, &mut maintenance4, &mut query_reset);
    let callback: Box<wgpu::hal::vulkan::CreateDeviceCallback<'_>> = Box::new(move |args| {
        *args.create_info = std::mem::take(args.create_info)
            .push_next(chain.0)
            .push_next(chain.1)
            .push_next(chain.2)
            .push_next(chain.3);
    });
    let open = {
        // SAFETY: the callback only enables core Vulkan 1.3 features (the adapter is 1.3:
        // pick_adapter); the feature structs outlive the call.
        let hal = unsafe { adapter.as_hal::<Vulkan>() }.ok_or("not a Vulkan adapter")?;
        // SAFETY: as above.
        unsafe { hal.open_with_callback(features, &hints, Some(callback)) }
            .map_err(|e| format!("vkCreateDevice through wgpu-hal: {e}"))?
    };
    let desc = wgpu::DeviceDescriptor {
        label: Some("wgpu_host"),
        required_features: features,
        required_limits: adapter.limits(),
        memory_hints: hints,
        trace: wgpu::Trace::Off,
    };
    // SAFETY: `open` was opened on this adapter with exactly `features`.
    unsafe { adapter.create_device_from_hal(open, &desc) }.map_err(|e| e.to_string())
}
