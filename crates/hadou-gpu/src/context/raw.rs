//! A context over a game's own Vulkan objects (embedding): hadou borrows the instance and device
//! and never destroys them.

use std::sync::Arc;

use ash::vk;

use super::{device_info, version_string, GpuContext};
use crate::error::{GpuError, GpuResult};
use crate::resources::Resources;
use crate::validation::ValidationLog;

/// The device features the game enabled in `vkCreateDevice`. Vulkan cannot be asked which features
/// a device was created with, so the game states them and `from_raw` checks them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EnabledFeatures {
    /// `VkApplicationInfo::apiVersion` the instance was created with.
    pub api_version: u32,
    /// Vulkan 1.3 `dynamicRendering`.
    pub dynamic_rendering: bool,
    /// Vulkan 1.3 `synchronization2`.
    pub synchronization2: bool,
    /// Vulkan 1.3 `maintenance4`.
    pub maintenance4: bool,
    /// Vulkan 1.2 `hostQueryReset`: hadou resets its timestamp pools from the host.
    pub host_query_reset: bool,
    /// Vulkan 1.0 `fragmentStoresAndAtomics`: optional, needed only by scenes with a
    /// `thickness = "peel"` material (the peel pass's fragment shader appends to its lists).
    pub fragment_stores_and_atomics: bool,
}

impl EnabledFeatures {
    /// Everything hadou needs: what a game turns on in its `VkPhysicalDeviceVulkan1{2,3}Features`.
    pub const REQUIRED: EnabledFeatures = EnabledFeatures {
        api_version: vk::API_VERSION_1_3,
        dynamic_rendering: true,
        synchronization2: true,
        maintenance4: true,
        host_query_reset: true,
        fragment_stores_and_atomics: false,
    };
}

/// The game's Vulkan objects hadou records with. The game keeps owning all of them.
pub struct RawVulkan {
    /// The entry points the instance was created with.
    pub entry: ash::Entry,
    /// The game's instance (Vulkan 1.3).
    pub instance: ash::Instance,
    /// The physical device `device` was created on.
    pub physical_device: vk::PhysicalDevice,
    /// The game's device.
    pub device: ash::Device,
    /// The queue family of the command buffers the game will hand to hadou.
    pub queue_family: u32,
    /// A queue of that family. hadou submits to it only inside `load_scene` (one-off uploads of
    /// baked tables, each waited on its own fence), never per frame.
    pub queue_index: u32,
    /// What the game enabled when it created the instance and device.
    pub enabled: EnabledFeatures,
    /// True when the game enabled `VK_EXT_debug_utils` on the instance: hadou then names its
    /// objects and labels its passes (the game's messenger sees hadou's validation messages).
    pub debug_utils: bool,
}

impl GpuContext {
    /// A context on the game's instance and device (embedding).
    ///
    /// Ownership: the game owns the instance, the device, the queue, its command buffers and its
    /// images; it destroys them, after it dropped (or `destroy`ed) everything hadou made on them.
    /// hadou owns what it creates through this context (pipelines, buffers, its internal images,
    /// descriptor and query pools) and destroys those itself. Dropping this context destroys
    /// nothing. Validation messages go to the game's messenger, so `validation_counts` stays 0.
    ///
    /// Checked, each with a clear error: Vulkan 1.3 on the instance and the device, the features
    /// in `EnabledFeatures::REQUIRED` enabled, and the queue family offering graphics, compute and
    /// timestamps.
    ///
    /// # Safety
    /// Every handle must be valid and come from `entry`/`instance`; `enabled` must describe the
    /// device truthfully; the device must outlive the returned context and everything made with it.
    pub unsafe fn from_raw(raw: RawVulkan) -> GpuResult<Self> {
        // SAFETY: the caller guarantees the handles are valid.
        let props = unsafe { raw.instance.get_physical_device_properties(raw.physical_device) };
        let name = props.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        check_enabled(&name, &raw.enabled)?;
        if props.api_version < vk::API_VERSION_1_3 {
            let why = format!("supports Vulkan {}, hadou needs 1.3", version_string(props.api_version));
            return Err(GpuError::NoSuitableDevice { filter: String::new(), devices: vec![(name, why)] });
        }
        // SAFETY: as above, the caller guarantees the physical device comes from this instance.
        let families =
            unsafe { raw.instance.get_physical_device_queue_family_properties(raw.physical_device) };
        let family = families.get(raw.queue_family as usize).ok_or_else(|| GpuError::RawQueue {
            field: "queue_family",
            message: format!(
                "{} is not a queue family of {name} ({} families)",
                raw.queue_family,
                families.len()
            ),
        })?;
        let needed = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
        if !family.queue_flags.contains(needed) || family.timestamp_valid_bits == 0 {
            return Err(GpuError::RawQueue {
                field: "queue_family",
                message: format!(
                    "queue family {} of {name} has {:?} and {} timestamp bits; hadou records graphics and \
                     compute work with timestamps",
                    raw.queue_family, family.queue_flags, family.timestamp_valid_bits
                ),
            });
        }
        if raw.queue_index >= family.queue_count {
            return Err(GpuError::RawQueue {
                field: "queue_index",
                message: format!("{} >= the family's {} queues", raw.queue_index, family.queue_count),
            });
        }
        // SAFETY: `RawVulkan::queue_index` names a queue of that family the game created the device
        // with (the caller's contract); the check above only bounds it by the family's queue count.
        let queue = unsafe { raw.device.get_device_queue(raw.queue_family, raw.queue_index) };
        let info = device_info(&raw.instance, raw.physical_device, &props);
        let (debug_instance, debug_device) = if raw.debug_utils {
            (
                Some(ash::ext::debug_utils::Instance::new(&raw.entry, &raw.instance)),
                Some(ash::ext::debug_utils::Device::new(&raw.instance, &raw.device)),
            )
        } else {
            (None, None)
        };
        let resources = Resources::new(&raw.instance, &raw.device, raw.physical_device)?;
        Ok(GpuContext {
            entry: raw.entry,
            instance: raw.instance,
            physical_device: raw.physical_device,
            device: raw.device,
            queue,
            queue_family: raw.queue_family,
            info,
            limits: props.limits,
            timestamp_valid_bits: family.timestamp_valid_bits,
            fragment_stores_and_atomics: raw.enabled.fragment_stores_and_atomics,
            debug_instance,
            debug_device,
            messenger: vk::DebugUtilsMessengerEXT::null(),
            log: Arc::new(ValidationLog::default()),
            validation: false,
            owns_device: false,
            resources,
        })
    }

    /// False for a context made by `from_raw` (the game's device).
    pub fn owns_device(&self) -> bool {
        self.owns_device
    }
}

/// The first requirement `enabled` misses, as an error naming it.
fn check_enabled(device: &str, enabled: &EnabledFeatures) -> GpuResult<()> {
    if enabled.api_version < vk::API_VERSION_1_3 {
        return Err(GpuError::MissingFeature {
            device: device.into(),
            feature: "Vulkan 1.3 (the instance's apiVersion)",
        });
    }
    for (on, feature) in [
        (enabled.dynamic_rendering, "dynamicRendering (VkPhysicalDeviceVulkan13Features)"),
        (enabled.synchronization2, "synchronization2 (VkPhysicalDeviceVulkan13Features)"),
        (enabled.maintenance4, "maintenance4 (VkPhysicalDeviceVulkan13Features)"),
        (enabled.host_query_reset, "hostQueryReset (VkPhysicalDeviceVulkan12Features)"),
    ] {
        if !on {
            return Err(GpuError::MissingFeature { device: device.into(), feature });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_missing_feature_is_named() {
        assert!(check_enabled("d", &EnabledFeatures::REQUIRED).is_ok());
        let cases = [
            (EnabledFeatures { api_version: vk::API_VERSION_1_2, ..EnabledFeatures::REQUIRED }, "Vulkan 1.3"),
            (EnabledFeatures { dynamic_rendering: false, ..EnabledFeatures::REQUIRED }, "dynamicRendering"),
            (EnabledFeatures { synchronization2: false, ..EnabledFeatures::REQUIRED }, "synchronization2"),
            (EnabledFeatures { maintenance4: false, ..EnabledFeatures::REQUIRED }, "maintenance4"),
            (EnabledFeatures { host_query_reset: false, ..EnabledFeatures::REQUIRED }, "hostQueryReset"),
        ];
        for (features, name) in cases {
            let message = check_enabled("dev", &features).unwrap_err().to_string();
            assert!(message.contains(name) && message.contains("dev"), "{message}");
        }
    }
}
