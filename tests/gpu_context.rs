//! The Vulkan context: validation really counts, nothing leaks at shutdown, device choice.

mod common;

use hadou::gpu::vk;
use hadou::gpu::GpuContext;
use hadou::{FrameRequest, Runtime, RuntimeOptions};

/// The messenger counts errors: otherwise every `assert_clean` in the suite could not fail.
#[test]
fn validation_counts_a_deliberate_error() {
    let rt = common::runtime_unchecked();
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
    let picked = Runtime::new(&RuntimeOptions {
        validation: true,
        device: Some(piece.to_uppercase()),
        ..Default::default()
    })
    .unwrap();
    assert_eq!(picked.device_info().name, name);
    let log = picked.validation_log();
    drop(picked);
    common::assert_log_clean(&log, "the device picked by name, after it was destroyed");
    let err = Runtime::new(&RuntimeOptions {
        validation: false,
        device: Some("no-such-device-42".into()),
        ..Default::default()
    })
    .err()
    .expect("a filter matching nothing must fail");
    let msg = err.to_string();
    assert!(msg.contains(&name) && msg.contains("no-such-device-42"), "{msg}");
}

/// Synchronization validation is on: two fills of one buffer with no barrier between them (a
/// write after write) are reported as a SYNC-HAZARD. Every "0 validation messages" of the suite
/// rests on this test; run with `HADOU_SYNC_VALIDATION=0` (sync validation left out), it fails.
#[test]
fn sync_validation_reports_a_write_after_write_hazard() {
    let ctx = common::context_unchecked();
    let log = ctx.validation_log();
    fill_twice_without_a_barrier(&ctx);
    drop(ctx);
    let messages = log.messages();
    assert!(
        messages.iter().any(|m| m.contains("SYNC-HAZARD-WRITE-AFTER-WRITE")),
        "synchronization validation did not report a write-after-write hazard (is it off?): {messages:?}"
    );
    // The hazard is the only thing wrong: the set-up itself (and its teardown) is valid.
    assert!(messages.iter().all(|m| m.contains("SYNC-HAZARD")), "{messages:?}");
}

/// Records two `vkCmdFillBuffer` on one buffer with no barrier between them and submits them;
/// returns after the queue is idle and everything created is destroyed.
fn fill_twice_without_a_barrier(ctx: &GpuContext) {
    let device = &ctx.device;
    let size = 256u64;
    // SAFETY: every object is created on this live device, used by one submission that is waited
    // for, and destroyed before returning.
    unsafe {
        let info = vk::BufferCreateInfo::default().size(size).usage(vk::BufferUsageFlags::TRANSFER_DST);
        let buffer = device.create_buffer(&info, None).unwrap();
        let needs = device.get_buffer_memory_requirements(buffer);
        let memory_type = (0..32).find(|i| needs.memory_type_bits & (1 << i) != 0).unwrap();
        let alloc =
            vk::MemoryAllocateInfo::default().allocation_size(needs.size).memory_type_index(memory_type);
        let memory = device.allocate_memory(&alloc, None).unwrap();
        device.bind_buffer_memory(buffer, memory, 0).unwrap();
        let pool_info = vk::CommandPoolCreateInfo::default().queue_family_index(ctx.queue_family);
        let pool = device.create_command_pool(&pool_info, None).unwrap();
        let alloc_info = vk::CommandBufferAllocateInfo::default().command_pool(pool).command_buffer_count(1);
        let cmd = device.allocate_command_buffers(&alloc_info).unwrap()[0];
        device.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default()).unwrap();
        device.cmd_fill_buffer(cmd, buffer, 0, size, 1);
        device.cmd_fill_buffer(cmd, buffer, 0, size, 2);
        device.end_command_buffer(cmd).unwrap();
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
        let submit = [vk::SubmitInfo2::default().command_buffer_infos(&cmds)];
        device.queue_submit2(ctx.queue, &submit, vk::Fence::null()).unwrap();
        device.queue_wait_idle(ctx.queue).unwrap();
        device.destroy_command_pool(pool, None);
        device.destroy_buffer(buffer, None);
        device.free_memory(memory, None);
    }
}
