//! The slime's simulation on the GPU: a compute shader of the game's writes the slime's balls
//! into a buffer of the game's each frame, before hadou's frame in the same command buffer, and
//! hadou draws the group from that buffer (`Renderer::set_metaball_buffer`): no host copy. The
//! motion is `GameState::slime`'s, in f32.

use ash::vk;

use super::gpu::GameVk;

/// The balls the shader writes: the three of the blob, then the two drops.
pub const SLIME_BALLS: u32 = 5;

const SHADER: &str = r#"
#version 460
layout(local_size_x = 8) in;
struct Ball { vec4 centre_radius; vec4 q; };  // hadou::DeviceBall
layout(set = 0, binding = 0, std430) buffer Balls { Ball balls[]; };
layout(push_constant) uniform Sim { vec4 time; } sim;  // x: this frame's time, y: the previous one's
// The blob's balls at rest (object space) and their radii: game.rs's SLIME.
const vec4 REST[3] = vec4[3](vec4(0.0, 0.0, 0.0, 1.5), vec4(0.9, 0.2, 0.0, 1.2), vec4(-0.7, 0.1, 0.4, 1.1));
// Ball i at time t: centre and R.
vec4 ball(uint i, float t) {
    if (i < 3u) {
        // Each bobs on its own phase.
        vec3 c = REST[i].xyz;
        float phase = 2.1 * c.x + 1.3 * c.z;
        vec3 bob = vec3(0.12 * sin(1.7 * t + phase), 0.18 * sin(2.3 * t + phase), 0.0);
        return vec4(c + bob, REST[i].w);
    }
    // Two drops bud off, drift apart and merge back over a 4 s cycle.
    float side = i == 3u ? -1.0 : 1.0;
    float apart = pow(0.5 - 0.5 * cos(6.28318531 * t / 4.0), 2.0);
    return vec4(side * (0.4 + 2.2 * apart), 0.3 + 0.8 * apart, 0.2, 0.9);
}
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= 5u) return;
    // q = 1, and the centre a frame ago for hadou's motion vectors (DeviceBalls::previous_centres).
    balls[i] = Ball(ball(i, sim.time.x), vec4(1.0, ball(i, sim.time.y).xyz));
}
"#;

/// The pipeline, its set and the balls' buffer (device-local, storage and copy source).
pub struct SlimeSim {
    pub buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
}

impl SlimeSim {
    pub fn new(g: &GameVk) -> Result<SlimeSim, String> {
        let compiler = shaderc::Compiler::new().map_err(|e| e.to_string())?;
        let mut options = shaderc::CompileOptions::new().map_err(|e| e.to_string())?;
        options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_3 as u32);
        let spirv = compiler
            .compile_into_spirv(
                SHADER,
                shaderc::ShaderKind::Compute,
                "slime_sim.comp",
                "main",
                Some(&options),
            )
            .map_err(|e| format!("slime_sim.comp: {e}"))?;
        let d = &g.device;
        let err = |e: vk::Result| e.to_string();
        // SAFETY: every object is created on the game's live device; the create infos outlive their
        // calls; the module is destroyed after the pipeline call; `destroy` frees the rest after
        // the frames that use them finished (the caller's device wait).
        unsafe {
            let size = u64::from(SLIME_BALLS) * 32;
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
            let buffer = d
                .create_buffer(&vk::BufferCreateInfo::default().size(size).usage(usage), None)
                .map_err(err)?;
            let req = d.get_buffer_memory_requirements(buffer);
            let props = g.instance.get_physical_device_memory_properties(g.physical);
            let local = vk::MemoryPropertyFlags::DEVICE_LOCAL;
            let kind = (0..props.memory_type_count)
                .find(|&i| {
                    req.memory_type_bits & (1 << i) != 0
                        && props.memory_types[i as usize].property_flags.contains(local)
                })
                .ok_or("no device-local memory for the slime's balls")?;
            let alloc = vk::MemoryAllocateInfo::default().allocation_size(req.size).memory_type_index(kind);
            let memory = d.allocate_memory(&alloc, None).map_err(err)?;
            d.bind_buffer_memory(buffer, memory, 0).map_err(err)?;
            let binding = [vk::DescriptorSetLayoutBinding::default()
                .binding(0)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::COMPUTE)];
            let set_layout = d
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&binding),
                    None,
                )
                .map_err(err)?;
            let sizes =
                [vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_BUFFER, descriptor_count: 1 }];
            let pool = d
                .create_descriptor_pool(
                    &vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes),
                    None,
                )
                .map_err(err)?;
            let layouts = [set_layout];
            let set = d
                .allocate_descriptor_sets(
                    &vk::DescriptorSetAllocateInfo::default().descriptor_pool(pool).set_layouts(&layouts),
                )
                .map_err(err)?[0];
            let info = [vk::DescriptorBufferInfo { buffer, offset: 0, range: size }];
            let write = vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .buffer_info(&info);
            d.update_descriptor_sets(&[write], &[]);
            let push = [vk::PushConstantRange::default().stage_flags(vk::ShaderStageFlags::COMPUTE).size(16)];
            let layout = d
                .create_pipeline_layout(
                    &vk::PipelineLayoutCreateInfo::default()
                        .set_layouts(&layouts)
                        .push_constant_ranges(&push),
                    None,
                )
                .map_err(err)?;
            let module = d
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(spirv.as_binary()), None)
                .map_err(err)?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            let info = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout)];
            let pipeline = d.create_compute_pipelines(vk::PipelineCache::null(), &info, None);
            d.destroy_shader_module(module, None);
            let pipeline = pipeline.map_err(|(_, e)| e.to_string())?[0];
            Ok(SlimeSim { buffer, memory, set_layout, pool, set, layout, pipeline })
        }
    }

    /// Records the balls at scene time `time` (and where they were at `previous`, the last
    /// frame's time) into the game's command buffer (hadou's frame, after it, waits for the writes
    /// itself).
    pub fn record(&self, g: &GameVk, time: f64, previous: f64) {
        let push = [time as f32, previous as f32, 0.0, 0.0];
        // SAFETY: the command buffer is recording, outside a render pass; every object is live
        // until `destroy`, after the frames that use them finished.
        unsafe {
            g.device.cmd_bind_pipeline(g.cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            g.device.cmd_bind_descriptor_sets(
                g.cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &[self.set],
                &[],
            );
            g.device.cmd_push_constants(
                g.cmd,
                self.layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                bytemuck::cast_slice(&push),
            );
            g.device.cmd_dispatch(g.cmd, 1, 1, 1);
        }
    }

    /// Frees everything (nothing that uses it is in flight: the caller waited for the device).
    pub fn destroy(self, g: &GameVk) {
        // SAFETY: as above; each object is destroyed once, by value.
        unsafe {
            g.device.destroy_pipeline(self.pipeline, None);
            g.device.destroy_pipeline_layout(self.layout, None);
            g.device.destroy_descriptor_pool(self.pool, None);
            g.device.destroy_descriptor_set_layout(self.set_layout, None);
            g.device.destroy_buffer(self.buffer, None);
            g.device.free_memory(self.memory, None);
        }
    }
}
