//! The Vulkan context: instance, validation messenger, device choice, one queue.

use std::ffi::{c_char, CStr, CString};
use std::sync::Arc;

use ash::vk;

use super::error::{GpuError, GpuResult, VkResultExt};
use super::resources::{HostWaits, Releaser, Resources};
use super::validation::{messenger_callback, ValidationCounts, ValidationLog};

mod raw;
pub use raw::{EnabledFeatures, RawVulkan};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How a context is created.
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Turn on the Khronos validation layer with synchronization validation.
    pub validation: bool,
    /// Pick the first device whose name contains this (case-insensitive).
    pub device_filter: Option<String>,
}

impl ContextOptions {
    /// Options from the environment: `HADOU_VALIDATION=1`, `HADOU_DEVICE=<substring>`.
    pub fn from_env() -> Self {
        let validation = std::env::var("HADOU_VALIDATION").is_ok_and(|v| v == "1" || v == "true");
        let device_filter = std::env::var("HADOU_DEVICE").ok().filter(|s| !s.is_empty());
        ContextOptions { validation, device_filter }
    }
}

/// What a context that presents to a window needs (the viewer, `examples/game_prototype`): the
/// instance gets the surface's extensions, the device `VK_KHR_swapchain`, and a device is chosen
/// only if its queue family can present to the surface.
pub struct PresentRequest<'a> {
    /// Instance extensions the surface needs (`ash_window::enumerate_required_extensions`).
    pub instance_extensions: &'a [*const c_char],
    /// Creates the surface once the instance exists (e.g. with `ash_window::create_surface`).
    pub create_surface: &'a dyn Fn(&ash::Entry, &ash::Instance) -> Result<vk::SurfaceKHR, vk::Result>,
}

/// What was chosen, for reports.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DeviceInfo {
    /// The device's name as the driver reports it.
    pub name: String,
    /// "discrete GPU", "integrated GPU", "virtual GPU", "CPU" or "other".
    pub kind: String,
    /// The device's Vulkan version, "major.minor.patch".
    pub api_version: String,
    /// The driver's name and info string (`VkPhysicalDeviceDriverProperties`), space-separated.
    pub driver: String,
    /// PCI vendor id.
    pub vendor_id: u32,
    /// Vendor-specific device id.
    pub device_id: u32,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period_ns: f32,
}

/// The Vulkan instance, device and queue hadou records with: its own (`new`) or a game's
/// (`from_raw`). Dropping it waits for the device, frees what hadou retired, and destroys the
/// device and instance only if it created them.
pub struct GpuContext {
    /// The loaded Vulkan entry points.
    pub entry: ash::Entry,
    /// The instance (Vulkan 1.3).
    pub instance: ash::Instance,
    /// The chosen (or the game's) physical device.
    pub physical_device: vk::PhysicalDevice,
    /// The logical device.
    pub device: ash::Device,
    /// The queue hadou submits to (the headless runtime's frames, `load_scene`'s uploads).
    pub queue: vk::Queue,
    /// `queue`'s family: graphics, compute and timestamps.
    pub queue_family: u32,
    /// What was chosen, for reports.
    pub info: DeviceInfo,
    /// The physical device's limits.
    pub limits: vk::PhysicalDeviceLimits,
    /// Valid bits of `queue_family`'s timestamps.
    pub timestamp_valid_bits: u32,
    /// `fragmentStoresAndAtomics` is enabled (optional; the peel pass needs it). hadou's own
    /// device enables it whenever the device has it: features are fixed at device creation,
    /// before any scene is known, and enabling it costs nothing where it is unused.
    pub fragment_stores_and_atomics: bool,
    /// Debug-utils entry points (naming, labels, messenger); present when the extension is.
    pub debug_instance: Option<ash::ext::debug_utils::Instance>,
    /// Debug-utils device entry points (object names, labels); present with `debug_instance`.
    pub debug_device: Option<ash::ext::debug_utils::Device>,
    messenger: vk::DebugUtilsMessengerEXT,
    log: Arc<ValidationLog>,
    /// Whether the Khronos validation layer is on (always false for `from_raw`).
    pub validation: bool,
    /// False for a context made by `from_raw`: the game owns the instance and device, and Drop
    /// leaves them alone.
    owns_device: bool,
    /// The allocator and the queue of dropped objects waiting for their frames to finish.
    resources: Arc<Resources>,
}

struct Candidate {
    physical: vk::PhysicalDevice,
    name: String,
    kind: vk::PhysicalDeviceType,
    queue_family: u32,
    timestamp_valid_bits: u32,
    /// The optional `fragmentStoresAndAtomics` (the peel pass): enabled when present.
    fragment_stores_and_atomics: bool,
}

impl GpuContext {
    /// A context on its own instance and device: the best device by kind (discrete first) that
    /// passes `options.device_filter` and has what hadou needs.
    pub fn new(options: &ContextOptions) -> GpuResult<Self> {
        Self::create(options, None).map(|(ctx, _)| ctx)
    }

    /// A context whose queue presents to the surface `present.create_surface` makes. The caller
    /// owns the returned surface: destroy it (`ash::khr::surface::Instance::destroy_surface`, after
    /// its swapchain) before the context is dropped.
    pub fn new_presenting(
        options: &ContextOptions,
        present: &PresentRequest,
    ) -> GpuResult<(Self, vk::SurfaceKHR)> {
        Self::create(options, Some(present))
    }

    fn create(
        options: &ContextOptions,
        present: Option<&PresentRequest>,
    ) -> GpuResult<(Self, vk::SurfaceKHR)> {
        // SAFETY: loading libvulkan runs its initializers; nothing else is shared yet.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::NoLoader(e.to_string()))?;
        let log = Arc::new(ValidationLog::default());
        let extra = present.map(|p| p.instance_extensions).unwrap_or(&[]);
        let (instance, debug_instance, messenger) = create_instance(&entry, options, &log, extra)?;
        let surface_loader = ash::khr::surface::Instance::new(&entry, &instance);
        let mut surface = vk::SurfaceKHR::null();
        let context = (|| {
            if let Some(p) = present {
                surface = (p.create_surface)(&entry, &instance)
                    .map_err(|result| GpuError::Vk { call: "vkCreate*SurfaceKHR", result })?;
            }
            let presents_to = present.map(|_| (&surface_loader, surface));
            let candidate = choose_device(&instance, options.device_filter.as_deref(), presents_to)?;
            let device = create_device(&instance, &candidate, present.is_some())?;
            match Resources::new(&instance, &device, candidate.physical) {
                Ok(resources) => Ok((candidate, device, resources)),
                Err(e) => {
                    // SAFETY: nothing was created on the device yet.
                    unsafe { device.destroy_device(None) };
                    Err(e)
                }
            }
        })();
        let (candidate, device, resources) = match context {
            Ok(v) => v,
            Err(e) => {
                // SAFETY: nothing but the surface was created from the instance yet (a device made
                // before a failure was destroyed above).
                unsafe {
                    if surface != vk::SurfaceKHR::null() {
                        surface_loader.destroy_surface(surface, None);
                    }
                    if let Some(d) = &debug_instance {
                        d.destroy_debug_utils_messenger(messenger, None);
                    }
                    instance.destroy_instance(None);
                }
                return Err(e);
            }
        };
        // SAFETY: valid handles from above.
        let props = unsafe { instance.get_physical_device_properties(candidate.physical) };
        // SAFETY: the device was created with one queue of `candidate.queue_family` (create_device).
        let queue = unsafe { device.get_device_queue(candidate.queue_family, 0) };
        let debug_device =
            debug_instance.as_ref().map(|_| ash::ext::debug_utils::Device::new(&instance, &device));
        let info = device_info(&instance, candidate.physical, &props);
        log::info!(
            "device: {} ({}), Vulkan {}, driver {}",
            info.name,
            info.kind,
            info.api_version,
            info.driver
        );
        let ctx = GpuContext {
            entry,
            instance,
            physical_device: candidate.physical,
            device,
            queue,
            queue_family: candidate.queue_family,
            info,
            limits: props.limits,
            timestamp_valid_bits: candidate.timestamp_valid_bits,
            fragment_stores_and_atomics: candidate.fragment_stores_and_atomics,
            debug_instance,
            debug_device,
            messenger,
            log,
            validation: options.validation,
            owns_device: true,
            resources,
        };
        Ok((ctx, surface))
    }

    /// Validation errors and warnings counted since creation (zero unless validation is on).
    pub fn validation_counts(&self) -> ValidationCounts {
        self.log.counts()
    }

    /// The first validation messages received (errors and warnings), oldest first.
    pub fn validation_messages(&self) -> Vec<String> {
        self.log.messages()
    }

    /// The message log itself; it outlives the context, so tests can read what destroying the
    /// device reported (leaked objects).
    pub fn validation_log(&self) -> Arc<ValidationLog> {
        self.log.clone()
    }

    /// Names a Vulkan object for validation messages and capture tools.
    pub fn name_object<H: vk::Handle>(&self, handle: H, name: &str) {
        let Some(debug) = &self.debug_device else { return };
        let Ok(name) = CString::new(name) else { return };
        let info = vk::DebugUtilsObjectNameInfoEXT::default().object_handle(handle).object_name(&name);
        // SAFETY: the handle belongs to this device. Naming is advisory: a failure is only logged.
        if let Err(e) = unsafe { debug.set_debug_utils_object_name(&info) } {
            log::debug!("naming {name:?} failed: {e:?}");
        }
    }

    /// Opens a debug label `name` in `cmd` for capture tools; a no-op without debug utils.
    pub fn begin_label(&self, cmd: vk::CommandBuffer, name: &str) {
        let Some(debug) = &self.debug_device else { return };
        let Ok(name) = CString::new(name) else { return };
        let label = vk::DebugUtilsLabelEXT::default().label_name(&name);
        // SAFETY: cmd is recording.
        unsafe { debug.cmd_begin_debug_utils_label(cmd, &label) };
    }

    /// Closes the label `begin_label` opened last in `cmd`.
    pub fn end_label(&self, cmd: vk::CommandBuffer) {
        if let Some(debug) = &self.debug_device {
            // SAFETY: paired with begin_label on the same recording command buffer.
            unsafe { debug.cmd_end_debug_utils_label(cmd) };
        }
    }

    /// Waits for the device to be idle (teardown only: a frame path never waits; counted).
    pub fn wait_idle(&self) -> GpuResult<()> {
        self.resources.count_device_idle_wait();
        // SAFETY: the device is valid for the context's lifetime.
        unsafe { self.device.device_wait_idle() }.vk("vkDeviceWaitIdle")
    }

    pub(crate) fn resources(&self) -> &Arc<Resources> {
        &self.resources
    }

    /// Numbers the frame being recorded: objects dropped from now on are retired with `frame`
    /// (destroyed once it is known finished).
    pub fn begin_frame(&self, frame: u64) {
        self.resources.set_frame(frame);
    }

    /// Frame `frame` and every one before it finished: destroys what was retired with them.
    pub fn frames_finished(&self, frame: u64) {
        self.resources.collect(frame);
    }

    /// Destroys everything retired (teardown, after `wait_idle`).
    pub fn destroy_retired(&self) {
        self.resources.collect_all();
    }

    /// The pipeline cache pipelines are created with from now on (null: none).
    pub fn set_pipeline_cache(&self, cache: vk::PipelineCache) {
        self.resources.set_pipeline_cache(cache);
    }

    /// The pipeline cache every pipeline is created with (null until a renderer sets one).
    pub(crate) fn pipeline_cache(&self) -> vk::PipelineCache {
        self.resources.pipeline_cache()
    }

    /// The link every owned object keeps to the retire queue.
    pub(crate) fn releaser(&self) -> Releaser {
        self.resources.releaser()
    }

    /// How often hadou waited on this device (device idle, fences) since the context was made.
    pub fn host_waits(&self) -> HostWaits {
        self.resources.host_waits()
    }

    /// Objects dropped and not yet freed (their frames have not been reported finished).
    pub fn retired_count(&self) -> usize {
        self.resources.retired_count()
    }
}

impl Drop for GpuContext {
    fn drop(&mut self) {
        // Whatever hadou dropped is freed once the device is idle (the game stopped submitting
        // hadou's frames before dropping the renderer: the embedding contract).
        // SAFETY: valid device.
        let _ = unsafe { self.device.device_wait_idle() };
        self.resources.shut_down();
        if !self.owns_device {
            return;
        }
        // SAFETY: owners of device objects dropped them before the context (Runtime's field order).
        unsafe {
            self.device.destroy_device(None);
            if let Some(d) = &self.debug_instance {
                d.destroy_debug_utils_messenger(self.messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

fn has_instance_extension(entry: &ash::Entry, name: &CStr) -> bool {
    // SAFETY: plain query.
    unsafe { entry.enumerate_instance_extension_properties(None) }
        .map(|exts| exts.iter().any(|e| e.extension_name_as_c_str() == Ok(name)))
        .unwrap_or(false)
}

fn has_layer(entry: &ash::Entry, name: &CStr) -> bool {
    // SAFETY: plain query.
    unsafe { entry.enumerate_instance_layer_properties() }
        .map(|layers| layers.iter().any(|l| l.layer_name_as_c_str() == Ok(name)))
        .unwrap_or(false)
}

type InstanceParts = (ash::Instance, Option<ash::ext::debug_utils::Instance>, vk::DebugUtilsMessengerEXT);

fn create_instance(
    entry: &ash::Entry,
    options: &ContextOptions,
    log: &Arc<ValidationLog>,
    extra_extensions: &[*const c_char],
) -> GpuResult<InstanceParts> {
    // SAFETY: plain query.
    let version = unsafe { entry.try_enumerate_instance_version() }.vk("vkEnumerateInstanceVersion")?;
    let version = version.unwrap_or(vk::API_VERSION_1_0);
    if version < vk::API_VERSION_1_3 {
        return Err(GpuError::NoSuitableDevice {
            filter: String::new(),
            devices: vec![(
                "Vulkan loader".into(),
                format!("instance version {} < 1.3", version_string(version)),
            )],
        });
    }
    let debug_utils = has_instance_extension(entry, ash::ext::debug_utils::NAME);
    if options.validation && !has_layer(entry, VALIDATION_LAYER) {
        return Err(GpuError::ValidationLayerMissing);
    }
    let app_info = vk::ApplicationInfo::default()
        .application_name(c"hadou")
        .engine_name(c"hadou")
        .api_version(vk::API_VERSION_1_3);
    let layers: Vec<*const c_char> =
        if options.validation { vec![VALIDATION_LAYER.as_ptr()] } else { vec![] };
    let mut extensions: Vec<*const c_char> =
        if debug_utils { vec![ash::ext::debug_utils::NAME.as_ptr()] } else { vec![] };
    extensions.extend_from_slice(extra_extensions);
    let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
    let mut messenger_info = messenger_create_info(log);
    let mut info = vk::InstanceCreateInfo::default()
        .application_info(&app_info)
        .enabled_layer_names(&layers)
        .enabled_extension_names(&extensions);
    // HADOU_SYNC_VALIDATION=0 leaves synchronization validation out: only to show that the suite's
    // sync-hazard meta-test (tests/gpu_context.rs) then fails.
    let sync_validation = std::env::var("HADOU_SYNC_VALIDATION").map_or(true, |v| v != "0");
    if options.validation && sync_validation {
        info = info.push_next(&mut features);
    }
    if debug_utils {
        // Also catches messages from instance creation itself.
        info = info.push_next(&mut messenger_info);
    }
    // SAFETY: every pointer in `info` outlives the call.
    let instance = unsafe { entry.create_instance(&info, None) }.map_err(|e| match e {
        vk::Result::ERROR_INCOMPATIBLE_DRIVER => GpuError::NoDriver,
        vk::Result::ERROR_LAYER_NOT_PRESENT => GpuError::ValidationLayerMissing,
        result => GpuError::Vk { call: "vkCreateInstance", result },
    })?;
    if !debug_utils {
        return Ok((instance, None, vk::DebugUtilsMessengerEXT::null()));
    }
    let debug = ash::ext::debug_utils::Instance::new(entry, &instance);
    // SAFETY: the log outlives the messenger (the context destroys the messenger first).
    match unsafe { debug.create_debug_utils_messenger(&messenger_create_info(log), None) } {
        Ok(messenger) => Ok((instance, Some(debug), messenger)),
        Err(result) => {
            // SAFETY: nothing was created from the instance (the messenger failed), and it is not
            // used again.
            unsafe { instance.destroy_instance(None) };
            Err(GpuError::Vk { call: "vkCreateDebugUtilsMessengerEXT", result })
        }
    }
}

fn messenger_create_info(log: &Arc<ValidationLog>) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(messenger_callback))
        .user_data(Arc::as_ptr(log) as *mut std::ffi::c_void)
}

fn version_string(v: u32) -> String {
    format!("{}.{}.{}", vk::api_version_major(v), vk::api_version_minor(v), vk::api_version_patch(v))
}

fn kind_name(kind: vk::PhysicalDeviceType) -> &'static str {
    match kind {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
}

/// Lower is preferred: discrete > integrated > virtual > CPU > other.
fn kind_rank(kind: vk::PhysicalDeviceType) -> u32 {
    match kind {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

type PresentsTo<'a> = Option<(&'a ash::khr::surface::Instance, vk::SurfaceKHR)>;

fn choose_device(
    instance: &ash::Instance,
    filter: Option<&str>,
    surface: PresentsTo,
) -> GpuResult<Candidate> {
    // SAFETY: plain query.
    let physicals = unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
    let mut refused = Vec::new();
    let mut best: Option<Candidate> = None;
    for physical in physicals {
        // SAFETY: `physical` was just enumerated from this instance.
        let props = unsafe { instance.get_physical_device_properties(physical) };
        let name = props.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let label = format!("{name} ({})", kind_name(props.device_type));
        if let Some(f) = filter {
            if !name.to_lowercase().contains(&f.to_lowercase()) {
                refused.push((label, format!("name does not contain HADOU_DEVICE={f:?}")));
                continue;
            }
        }
        let checked = check_device(instance, physical, &props)
            .and_then(|found| check_present(instance, physical, found.0, surface).map(|_| found));
        match checked {
            Ok((queue_family, timestamp_valid_bits)) => {
                // SAFETY: plain query.
                let features = unsafe { instance.get_physical_device_features(physical) };
                let c = Candidate {
                    physical,
                    name,
                    kind: props.device_type,
                    queue_family,
                    timestamp_valid_bits,
                    fragment_stores_and_atomics: features.fragment_stores_and_atomics == vk::TRUE,
                };
                if best.as_ref().is_none_or(|b| kind_rank(c.kind) < kind_rank(b.kind)) {
                    best = Some(c);
                }
            }
            Err(why) => refused.push((label, why)),
        }
    }
    best.ok_or_else(|| GpuError::NoSuitableDevice {
        filter: filter.map(|f| format!(" matching HADOU_DEVICE={f:?}")).unwrap_or_default(),
        devices: refused,
    })
}

/// Checks API version, features and a graphics+compute queue with timestamps.
fn check_device(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    props: &vk::PhysicalDeviceProperties,
) -> Result<(u32, u32), String> {
    if props.api_version < vk::API_VERSION_1_3 {
        return Err(format!("supports Vulkan {}, hadou needs 1.3", version_string(props.api_version)));
    }
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f13).push_next(&mut f12);
    // SAFETY: plain query into local structs.
    unsafe { instance.get_physical_device_features2(physical, &mut f2) };
    for (ok, feature) in [
        (f13.dynamic_rendering, "dynamicRendering"),
        (f13.synchronization2, "synchronization2"),
        (f13.maintenance4, "maintenance4"),
        (f12.host_query_reset, "hostQueryReset"),
    ] {
        if ok == vk::FALSE {
            return Err(format!("lacks feature {feature}"));
        }
    }
    if props.limits.timestamp_compute_and_graphics == vk::FALSE {
        return Err("no timestamps on graphics and compute queues".into());
    }
    // SAFETY: plain query; `physical` comes from this instance.
    let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
    let needed = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
    families
        .iter()
        .enumerate()
        .find(|(_, f)| f.queue_flags.contains(needed) && f.timestamp_valid_bits > 0)
        .map(|(i, f)| (i as u32, f.timestamp_valid_bits))
        .ok_or_else(|| "no queue family with graphics, compute and timestamps".into())
}

/// With a surface: the chosen queue family must present to it and the device offer VK_KHR_swapchain.
fn check_present(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    family: u32,
    surface: PresentsTo,
) -> Result<(), String> {
    let Some((loader, surface)) = surface else { return Ok(()) };
    // SAFETY: plain queries; the surface belongs to this instance.
    let supported = unsafe { loader.get_physical_device_surface_support(physical, family, surface) };
    if !supported.unwrap_or(false) {
        return Err(format!("queue family {family} cannot present to the window surface"));
    }
    // SAFETY: plain query; `physical` comes from this instance.
    let exts = unsafe { instance.enumerate_device_extension_properties(physical) }.unwrap_or_default();
    if !exts.iter().any(|e| e.extension_name_as_c_str() == Ok(ash::khr::swapchain::NAME)) {
        return Err("lacks VK_KHR_swapchain".into());
    }
    Ok(())
}

fn create_device(instance: &ash::Instance, c: &Candidate, swapchain: bool) -> GpuResult<ash::Device> {
    let priorities = [1.0f32];
    let queues = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(c.queue_family)
        .queue_priorities(&priorities)];
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
        .dynamic_rendering(true)
        .synchronization2(true)
        .maintenance4(true);
    // Timestamps are reset from the host, so reading them never needs a command buffer or a wait.
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default().host_query_reset(true);
    // Optional, for the peel pass only: on whenever the device has it (see GpuContext).
    let core =
        vk::PhysicalDeviceFeatures::default().fragment_stores_and_atomics(c.fragment_stores_and_atomics);
    let mut f2 =
        vk::PhysicalDeviceFeatures2::default().features(core).push_next(&mut f13).push_next(&mut f12);
    let extensions: Vec<*const c_char> =
        if swapchain { vec![ash::khr::swapchain::NAME.as_ptr()] } else { vec![] };
    let info = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queues)
        .enabled_extension_names(&extensions)
        .push_next(&mut f2);
    // SAFETY: the features were checked in check_device.
    unsafe { instance.create_device(c.physical, &info, None) }.map_err(|result| match result {
        vk::Result::ERROR_FEATURE_NOT_PRESENT => {
            GpuError::MissingFeature { device: c.name.clone(), feature: "Vulkan 1.3 core features" }
        }
        result => GpuError::Vk { call: "vkCreateDevice", result },
    })
}

fn device_info(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    props: &vk::PhysicalDeviceProperties,
) -> DeviceInfo {
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver);
    // SAFETY: plain query into local structs.
    unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
    let driver_name =
        driver.driver_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let driver_info =
        driver.driver_info_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    DeviceInfo {
        name: props.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        kind: kind_name(props.device_type).into(),
        api_version: version_string(props.api_version),
        driver: format!("{driver_name} {driver_info}").trim().to_string(),
        vendor_id: props.vendor_id,
        device_id: props.device_id,
        timestamp_period_ns: props.limits.timestamp_period,
    }
}
