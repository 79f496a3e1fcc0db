//! Metaballs from a buffer the game owns (`Renderer::set_metaball_buffer`): a compute shader of
//! the "game" writes the balls into its own device buffer each frame, in the same command buffer
//! before hadou's frame; hadou copies them on the device, completes them (ρ*·R) and draws them
//! with no host copy. The picture is checked against the f64 reference of the balls the shader
//! wrote (read back afterwards, for the test only), with the tangency band the other metaball
//! tests use; a ball with a NaN radius is drawn as no ball and counted. Lavapipe, validation and
//! synchronization validation, zero messages.

mod common;

use common::host::Host;

use hadou::effects::metaballs_compare::{compare_metaballs, MetaballFrame};
use hadou::gpu::memory::{Memory, MemoryLocation};
use hadou::gpu::pipeline::{bind_set, create_compute_pipeline, Bound, BufferRange, DescriptorPool};
use hadou::gpu::recorder::Recorder;
use hadou::gpu::vk;
use hadou::passes::metaballs::{DROPPED, INVALID_BALLS};
use hadou::scene::model::AnimatedBall;
use hadou::{Aov, AovImage, DeviceBall, DeviceBalls, FrameInputs, Renderer};

/// The game's simulation: ball i on a wobbling helix at time `t`; the last one has a NaN radius
/// (a simulation gone wrong: it must not reach the picture).
const SIM: &str = r#"
#version 460
layout(local_size_x = 64) in;
struct Ball { vec4 centre_radius; vec4 q; };
layout(set = 0, binding = 0, std430) buffer Balls { Ball balls[]; };
layout(push_constant) uniform Sim { uvec4 count; vec4 time; } sim;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.count.x) return;
    float a = 0.37 * float(i) + sim.time.x;
    vec3 c = vec3(1.6 * cos(a), -1.2 + 2.4 * float(i) / float(sim.count.x), 1.6 * sin(a));
    float r = i + 1u == sim.count.x ? uintBitsToFloat(0x7fc00000u) : 0.7 + 0.1 * sin(3.0 * a);
    balls[i] = Ball(vec4(c, r), vec4(1.0 + 0.2 * cos(a), 0.0, 0.0, 0.0));
}
"#;

const BALLS: u32 = 97;
const OFFSET: u64 = 64; // the records start past a header of the game's

const SCENE: &str = r#"
[camera]
position = [0, 1, 7]
look_at = [0, 0, 0]
fov_y_deg = 45
near = 0.5
far = 40
[[light]]
direction = [-0.3, -1, -0.5]
[[material]]
name = "slime"
albedo = [0.3, 0.8, 0.4]
[[metaballs]]
material = "slime"
threshold = 0.35
balls = [{ centre = [0, 0, 0], radius = 1 }]
"#;

fn compile(source: &str) -> Vec<u32> {
    let compiler = shaderc::Compiler::new().unwrap();
    let mut options = shaderc::CompileOptions::new().unwrap();
    options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_3 as u32);
    compiler
        .compile_into_spirv(source, shaderc::ShaderKind::Compute, "sim.comp", "main", Some(&options))
        .unwrap()
        .as_binary()
        .to_vec()
}

#[test]
fn balls_a_compute_shader_writes_are_drawn_as_the_f64_reference() {
    let (w, h) = (96u32, 72u32);
    let (_leaks, ctx) = common::context();
    let log = ctx.validation_log();
    let memory = Memory::new(&ctx).unwrap();
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
    let size = OFFSET + u64::from(BALLS) * 32;
    let game_balls = memory.create_buffer(&ctx, "game balls", size, usage, MemoryLocation::GpuOnly).unwrap();
    let usage = vk::BufferUsageFlags::TRANSFER_DST;
    let seen = memory.create_buffer(&ctx, "balls seen", size, usage, MemoryLocation::GpuToCpu).unwrap();
    let sim = create_compute_pipeline(&ctx, "game sim", &compile(SIM), 32).unwrap();
    let pool = DescriptorPool::new(&ctx, "game sim", 1).unwrap();
    let range = BufferRange {
        buffer: game_balls.raw,
        offset: OFFSET,
        range: u64::from(BALLS) * 32,
        element_bytes: 0,
    };
    let set = bind_set(&ctx, &pool, &sim, &[Bound::Storage(range)]).unwrap();
    let mut host = Host::new(&ctx, 1);
    let mut hadou = Renderer::new(ctx).unwrap();
    hadou.load_scene(common::parse(SCENE)).unwrap();
    let group = hadou.metaballs_ids()[0];
    // Refused: no buffer, no balls.
    let none = DeviceBalls { buffer: vk::Buffer::null(), offset: 0, count: 1, previous_centres: false };
    assert!(hadou.set_metaball_buffer(group, Some(none)).is_err());
    let empty = DeviceBalls { buffer: game_balls.raw, offset: OFFSET, count: 0, previous_centres: false };
    assert!(hadou.set_metaball_buffer(group, Some(empty)).is_err());
    let source =
        DeviceBalls { buffer: game_balls.raw, offset: OFFSET, count: BALLS, previous_centres: false };
    hadou.set_metaball_buffer(group, Some(source)).unwrap();

    let time = 0.8f32;
    let cmd = host.begin(0);
    let rec = Recorder { ctx: hadou.context(), cmd };
    rec.bind_pipeline(&sim, set);
    let push: [u32; 8] = [BALLS, 0, 0, 0, time.to_bits(), 0, 0, 0];
    rec.push_constants(&sim, bytemuck::cast_slice(&push));
    rec.dispatch_groups(BALLS.div_ceil(64), 1);
    let frame = hadou.record_frame(cmd, &FrameInputs::headless(w, h, 0.0)).unwrap();
    let readback = hadou.record_aov_readback(cmd, &[Aov::Depth, Aov::Normal, Aov::Hdr]).unwrap();
    // For the test only: what the simulation wrote (hadou's copy has finished reading it).
    let rec = Recorder { ctx: hadou.context(), cmd };
    rec.compute_to_copy_barrier();
    rec.copy_buffer(game_balls.raw, 0, seen.raw, 0, size);
    host.submit(0);
    host.wait_all();
    hadou.frame_finished(frame.frame).unwrap();
    let (_, stats) = hadou.latest_stats().unwrap();
    assert_eq!(stats.counter(INVALID_BALLS), 1, "the NaN ball is counted");
    assert_eq!(stats.counter(DROPPED), 0);

    // The reference: the balls as written (f32, exact in f64), the NaN one left out.
    let written: &[DeviceBall] = bytemuck::cast_slice(&seen.mapped().unwrap()[OFFSET as usize..]);
    let mut scene = common::parse(SCENE);
    scene.metaballs_mut()[0].balls = written[..BALLS as usize - 1]
        .iter()
        .map(|b| AnimatedBall {
            centre: glam::DVec3::new(
                b.centre_radius[0].into(),
                b.centre_radius[1].into(),
                b.centre_radius[2].into(),
            ),
            radius: b.centre_radius[3].into(),
            q: b.q[0].into(),
            velocity: glam::DVec3::ZERO,
            q_rate: 0.0,
        })
        .collect();
    assert!(written[BALLS as usize - 1].centre_radius[3].is_nan());
    let depth = readback.aov(Aov::Depth).unwrap();
    let normal = readback.aov(Aov::Normal).unwrap();
    for (aov, img) in [("hdr", readback.aov(Aov::Hdr).unwrap()), ("normal", normal.clone())] {
        assert!(img.data.iter().all(|v| v.is_finite()), "{aov} holds a value that is not finite");
    }
    let nothing = AovImage { width: w, height: h, channels: 1, data: vec![f32::INFINITY; (w * h) as usize] };
    let frame = MetaballFrame { depth: &depth, raster_depth: &nothing, normal: Some(&normal) };
    let checked = compare_metaballs(&scene, 0.0, frame).unwrap();
    println!("{checked:?}");
    assert_eq!(checked.nan_depth, 0);
    assert_eq!(checked.mismatched, 0, "hit/miss outside the tangency band: {:?}", checked.mismatches);
    assert!(checked.gpu_hits > 1000, "the helix covers the frame's middle: {} hits", checked.gpu_hits);
    drop(readback);
    host.destroy();
    drop((sim, pool, game_balls, seen, memory));
    drop(hadou);
    common::assert_log_clean(&log, "after shutdown");
}
