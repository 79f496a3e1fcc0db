//! The debug messenger: counts validation errors and warnings and keeps their text. It never
//! panics across the FFI boundary: every step that could fail is skipped instead.

use std::ffi::{c_void, CStr};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use ash::vk;

/// How many messages the log keeps; the counts go on past it.
const KEPT_MESSAGES: usize = 64;

/// What the validation layer reported to a context: counts of errors and warnings, and the text
/// of the first 64 messages.
#[derive(Default, Debug)]
pub struct ValidationLog {
    errors: AtomicU64,
    warnings: AtomicU64,
    messages: Mutex<Vec<String>>,
}

/// Counts since the context was created.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ValidationCounts {
    /// Messages of severity error.
    pub errors: u64,
    /// Messages of severity warning.
    pub warnings: u64,
}

impl ValidationLog {
    /// The counts so far.
    pub fn counts(&self) -> ValidationCounts {
        ValidationCounts {
            errors: self.errors.load(Ordering::Relaxed),
            warnings: self.warnings.load(Ordering::Relaxed),
        }
    }

    /// The first messages received (errors and warnings), oldest first.
    pub fn messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }

    fn record(&self, severity: vk::DebugUtilsMessageSeverityFlagsEXT, text: String) {
        let label = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
            self.errors.fetch_add(1, Ordering::Relaxed);
            log::error!("vulkan: {text}");
            "error"
        } else {
            self.warnings.fetch_add(1, Ordering::Relaxed);
            log::warn!("vulkan: {text}");
            "warning"
        };
        if let Ok(mut kept) = self.messages.lock() {
            if kept.len() < KEPT_MESSAGES {
                kept.push(format!("{label}: {text}"));
            }
        }
    }
}

/// The messenger callback; `user_data` points at the context's `ValidationLog`.
///
/// # Safety
/// Called by the Vulkan loader only, with `user_data` set to a live `ValidationLog`.
pub unsafe extern "system" fn messenger_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    if data.is_null() || user_data.is_null() {
        return vk::FALSE;
    }
    // SAFETY: the context keeps the log alive until after the messenger is destroyed.
    let log = unsafe { &*(user_data as *const ValidationLog) };
    // SAFETY: non-null (checked above); the loader's callback data is valid for this call.
    let data = unsafe { &*data };
    let text = if data.p_message.is_null() {
        String::from("(no message)")
    } else {
        // SAFETY: non-null; pMessage is a NUL-terminated string valid for this call (Vulkan spec).
        unsafe { CStr::from_ptr(data.p_message) }.to_string_lossy().into_owned()
    };
    if severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::ERROR | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
    ) {
        log.record(severity, text);
    } else {
        log::debug!("vulkan: {text}");
    }
    vk::FALSE
}
