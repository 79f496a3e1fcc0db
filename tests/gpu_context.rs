//! The Vulkan context: validation really counts, nothing leaks at shutdown, device choice.

mod common;

use hadou::gpu::vk;
use hadou::{FrameRequest, Runtime, RuntimeOptions};

/// The messenger counts errors: otherwise every `assert_clean` in the suite could not fail.
#[test]
fn validation_counts_a_deliberate_error() {
    let rt = common::runtime();
    common::assert_clean(&rt);
    // Anisotropic filtering without the samplerAnisotropy feature enabled violates
    // VUID-VkSamplerCreateInfo-anisotropyEnable-01070; drivers create the sampler regardless.
    let ctx = rt.context();
    let info = vk::SamplerCreateInfo::default().anisotropy_enable(true).max_anisotropy(4.0);
    // SAFETY: the device is live; the sampler is destroyed right away.
    unsafe {
        let sampler = ctx.device.create_sampler(&info, None).unwrap();
        ctx.device.destroy_sampler(sampler, None);
    }
    let counts = rt.validation_counts();
    assert!(counts.errors >= 1, "the validation layer did not report a deliberate error: {counts:?}");
    assert!(rt.validation_messages().iter().any(|m| m.contains("01070")), "{:?}", rt.validation_messages());
}

/// Everything created for scenes, targets and read-backs is destroyed: the layer reports objects
/// still alive at vkDestroyDevice as errors, which the log (outliving the runtime) would hold.
#[test]
fn no_leaks_at_shutdown() {
    let log;
    {
        let mut rt = common::runtime();
        log = rt.validation_log();
        rt.load_scene(common::load("assets/scenes/showcase.toml")).unwrap();
        let mut req = FrameRequest::new(40, 30);
        req.aovs = hadou::Aov::ALL.to_vec();
        rt.render(&req).unwrap();
        rt.load_scene(common::load("assets/scenes/instances.toml")).unwrap();
        rt.render(&FrameRequest::new(20, 20)).unwrap();
    }
    let counts = log.counts();
    assert_eq!((counts.errors, counts.warnings), (0, 0), "{:?}", log.messages());
}

#[test]
fn device_filter_picks_by_name_and_lists_refusals() {
    let rt = common::runtime();
    let name = rt.device_info().name.clone();
    let piece: String = name.chars().take(4).collect();
    drop(rt);
    let picked =
        Runtime::new(&RuntimeOptions { validation: true, device: Some(piece.to_uppercase()) }).unwrap();
    assert_eq!(picked.device_info().name, name);
    common::assert_clean(&picked);
    let err = Runtime::new(&RuntimeOptions { validation: false, device: Some("no-such-device-42".into()) })
        .err()
        .expect("a filter matching nothing must fail");
    let msg = err.to_string();
    assert!(msg.contains(&name) && msg.contains("no-such-device-42"), "{msg}");
}
