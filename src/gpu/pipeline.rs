//! Pipelines, descriptor set layouts and a descriptor pool, each created named.

use ash::vk;

use super::context::GpuContext;
use super::error::{GpuResult, VkResultExt};

/// A pipeline with its layout and its one descriptor set layout.
pub struct Pipeline {
    pub name: String,
    pub raw: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub set_layout: vk::DescriptorSetLayout,
    pub bind_point: vk::PipelineBindPoint,
}

impl Pipeline {
    pub fn destroy(&self, ctx: &GpuContext) {
        // SAFETY: called after the last frame using it finished.
        unsafe {
            ctx.device.destroy_pipeline(self.raw, None);
            ctx.device.destroy_pipeline_layout(self.layout, None);
            ctx.device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// Binding `index` of set 0 holds one descriptor of type `ty`, seen by `stages`.
pub fn binding(
    index: u32,
    ty: vk::DescriptorType,
    stages: vk::ShaderStageFlags,
) -> vk::DescriptorSetLayoutBinding<'static> {
    vk::DescriptorSetLayoutBinding::default()
        .binding(index)
        .descriptor_type(ty)
        .descriptor_count(1)
        .stage_flags(stages)
}

pub(super) fn create_layouts(
    ctx: &GpuContext,
    name: &str,
    bindings: &[vk::DescriptorSetLayoutBinding],
    push_constant_bytes: u32,
    push_stages: vk::ShaderStageFlags,
) -> GpuResult<(vk::DescriptorSetLayout, vk::PipelineLayout)> {
    let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(bindings);
    // SAFETY: valid device; destroyed with the pipeline.
    let set_layout =
        unsafe { ctx.device.create_descriptor_set_layout(&info, None) }.vk("vkCreateDescriptorSetLayout")?;
    let set_layouts = [set_layout];
    let ranges = [vk::PushConstantRange::default().stage_flags(push_stages).size(push_constant_bytes)];
    let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
    if push_constant_bytes > 0 {
        layout_info = layout_info.push_constant_ranges(&ranges);
    }
    let layout = match unsafe { ctx.device.create_pipeline_layout(&layout_info, None) } {
        Ok(l) => l,
        Err(e) => {
            unsafe { ctx.device.destroy_descriptor_set_layout(set_layout, None) };
            return Err(e).vk("vkCreatePipelineLayout");
        }
    };
    ctx.name_object(set_layout, &format!("{name} set layout"));
    ctx.name_object(layout, &format!("{name} layout"));
    Ok((set_layout, layout))
}

pub(super) fn shader_module(ctx: &GpuContext, name: &str, words: &[u32]) -> GpuResult<vk::ShaderModule> {
    let info = vk::ShaderModuleCreateInfo::default().code(words);
    // SAFETY: words is SPIR-V from shaderc.
    let module = unsafe { ctx.device.create_shader_module(&info, None) }.vk("vkCreateShaderModule")?;
    ctx.name_object(module, name);
    Ok(module)
}

pub fn create_compute_pipeline(
    ctx: &GpuContext,
    name: &str,
    spirv: &[u32],
    bindings: &[vk::DescriptorSetLayoutBinding],
    push_constant_bytes: u32,
) -> GpuResult<Pipeline> {
    let (set_layout, layout) =
        create_layouts(ctx, name, bindings, push_constant_bytes, vk::ShaderStageFlags::COMPUTE)?;
    let module = shader_module(ctx, name, spirv)?;
    let stage = vk::PipelineShaderStageCreateInfo::default()
        .stage(vk::ShaderStageFlags::COMPUTE)
        .module(module)
        .name(c"main");
    let info = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout)];
    // SAFETY: module and layout are valid.
    let result = unsafe { ctx.device.create_compute_pipelines(vk::PipelineCache::null(), &info, None) };
    unsafe { ctx.device.destroy_shader_module(module, None) };
    let layouts = (set_layout, layout);
    finish(ctx, name, result, layouts, vk::PipelineBindPoint::COMPUTE, "vkCreateComputePipelines")
}

/// Wraps a created pipeline with its layouts, or frees the layouts when creation failed.
pub(super) fn finish(
    ctx: &GpuContext,
    name: &str,
    result: Result<Vec<vk::Pipeline>, (Vec<vk::Pipeline>, vk::Result)>,
    (set_layout, layout): (vk::DescriptorSetLayout, vk::PipelineLayout),
    bind_point: vk::PipelineBindPoint,
    call: &'static str,
) -> GpuResult<Pipeline> {
    match result {
        Ok(p) => {
            ctx.name_object(p[0], name);
            Ok(Pipeline { name: name.into(), raw: p[0], layout, set_layout, bind_point })
        }
        Err((_, e)) => {
            // SAFETY: nothing uses the layouts of a pipeline that was not created.
            unsafe {
                ctx.device.destroy_pipeline_layout(layout, None);
                ctx.device.destroy_descriptor_set_layout(set_layout, None);
            }
            Err(e).vk(call)
        }
    }
}

/// What a dynamic-rendering graphics pipeline needs beyond its shaders.
pub struct GraphicsDesc<'a> {
    pub name: &'a str,
    pub vertex: &'a [u32],
    pub fragment: &'a [u32],
    pub bindings: &'a [vk::DescriptorSetLayoutBinding<'a>],
    pub push_constant_bytes: u32,
    /// The stages that read the push constants (`vkCmdPushConstants` must name the same).
    pub push_stages: vk::ShaderStageFlags,
    pub vertex_bindings: &'a [vk::VertexInputBindingDescription],
    pub vertex_attributes: &'a [vk::VertexInputAttributeDescription],
    pub color_formats: &'a [vk::Format],
    /// `vk::Format::UNDEFINED`: no depth attachment and no depth test.
    pub depth_format: vk::Format,
    pub depth_compare: vk::CompareOp,
    pub cull_mode: vk::CullModeFlags,
    pub blend: Blend,
}

/// How a graphics pipeline writes its colour attachments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Blend {
    /// The fragment's value replaces the attachment's.
    Replace,
    /// Premultiplied alpha: result = src + (1 − src.a)·dst (colour and alpha).
    PremultipliedOver,
}

impl Blend {
    fn attachment(self) -> vk::PipelineColorBlendAttachmentState {
        let state =
            vk::PipelineColorBlendAttachmentState::default().color_write_mask(vk::ColorComponentFlags::RGBA);
        match self {
            Blend::Replace => state,
            Blend::PremultipliedOver => state
                .blend_enable(true)
                .src_color_blend_factor(vk::BlendFactor::ONE)
                .dst_color_blend_factor(vk::BlendFactor::ONE_MINUS_SRC_ALPHA)
                .color_blend_op(vk::BlendOp::ADD)
                .src_alpha_blend_factor(vk::BlendFactor::ONE)
                .dst_alpha_blend_factor(vk::BlendFactor::ONE_MINUS_SRC_ALPHA)
                .alpha_blend_op(vk::BlendOp::ADD),
        }
    }
}

/// The vertex and fragment modules of `desc`, or none (the first one freed when the second fails).
fn graphics_modules(
    ctx: &GpuContext,
    desc: &GraphicsDesc,
) -> GpuResult<(vk::ShaderModule, vk::ShaderModule)> {
    let vs = shader_module(ctx, &format!("{}.vert", desc.name), desc.vertex)?;
    match shader_module(ctx, &format!("{}.frag", desc.name), desc.fragment) {
        Ok(fs) => Ok((vs, fs)),
        Err(e) => {
            unsafe { ctx.device.destroy_shader_module(vs, None) };
            Err(e)
        }
    }
}

pub fn create_graphics_pipeline(ctx: &GpuContext, desc: &GraphicsDesc) -> GpuResult<Pipeline> {
    let (set_layout, layout) =
        create_layouts(ctx, desc.name, desc.bindings, desc.push_constant_bytes, desc.push_stages)?;
    let (vs, fs) = match graphics_modules(ctx, desc) {
        Ok(m) => m,
        Err(e) => {
            // SAFETY: nothing uses the layouts of a pipeline that was not created.
            unsafe {
                ctx.device.destroy_pipeline_layout(layout, None);
                ctx.device.destroy_descriptor_set_layout(set_layout, None);
            }
            return Err(e);
        }
    };
    let stages = [
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::VERTEX)
            .module(vs)
            .name(c"main"),
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::FRAGMENT)
            .module(fs)
            .name(c"main"),
    ];
    let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
        .vertex_binding_descriptions(desc.vertex_bindings)
        .vertex_attribute_descriptions(desc.vertex_attributes);
    let assembly =
        vk::PipelineInputAssemblyStateCreateInfo::default().topology(vk::PrimitiveTopology::TRIANGLE_LIST);
    let viewport = vk::PipelineViewportStateCreateInfo::default().viewport_count(1).scissor_count(1);
    let raster = vk::PipelineRasterizationStateCreateInfo::default()
        .polygon_mode(vk::PolygonMode::FILL)
        .cull_mode(desc.cull_mode)
        .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
        .line_width(1.0);
    let multisample =
        vk::PipelineMultisampleStateCreateInfo::default().rasterization_samples(vk::SampleCountFlags::TYPE_1);
    let depth_test = desc.depth_format != vk::Format::UNDEFINED;
    let depth = vk::PipelineDepthStencilStateCreateInfo::default()
        .depth_test_enable(depth_test)
        .depth_write_enable(depth_test)
        .depth_compare_op(desc.depth_compare);
    let blend_attachments: Vec<_> = desc.color_formats.iter().map(|_| desc.blend.attachment()).collect();
    let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
    let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
    let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
    let mut rendering = vk::PipelineRenderingCreateInfo::default()
        .color_attachment_formats(desc.color_formats)
        .depth_attachment_format(desc.depth_format);
    let info = [vk::GraphicsPipelineCreateInfo::default()
        .stages(&stages)
        .vertex_input_state(&vertex_input)
        .input_assembly_state(&assembly)
        .viewport_state(&viewport)
        .rasterization_state(&raster)
        .multisample_state(&multisample)
        .depth_stencil_state(&depth)
        .color_blend_state(&blend)
        .dynamic_state(&dynamic)
        .layout(layout)
        .push_next(&mut rendering)];
    // SAFETY: every referenced state outlives the call.
    let result = unsafe { ctx.device.create_graphics_pipelines(vk::PipelineCache::null(), &info, None) };
    unsafe {
        ctx.device.destroy_shader_module(vs, None);
        ctx.device.destroy_shader_module(fs, None);
    }
    let layouts = (set_layout, layout);
    finish(ctx, desc.name, result, layouts, vk::PipelineBindPoint::GRAPHICS, "vkCreateGraphicsPipelines")
}

/// A descriptor pool sized for every pass of a frame; reset as a whole when targets change.
pub struct DescriptorPool {
    pub raw: vk::DescriptorPool,
}

impl DescriptorPool {
    pub fn new(ctx: &GpuContext, name: &str, max_sets: u32) -> GpuResult<Self> {
        let sizes = [
            vk::DescriptorPoolSize { ty: vk::DescriptorType::UNIFORM_BUFFER, descriptor_count: max_sets * 2 },
            vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_BUFFER, descriptor_count: max_sets * 8 },
            vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_IMAGE, descriptor_count: max_sets * 8 },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
                descriptor_count: max_sets * 4,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
                descriptor_count: max_sets * 4,
            },
        ];
        let info = vk::DescriptorPoolCreateInfo::default().max_sets(max_sets).pool_sizes(&sizes);
        // SAFETY: valid device.
        let raw = unsafe { ctx.device.create_descriptor_pool(&info, None) }.vk("vkCreateDescriptorPool")?;
        ctx.name_object(raw, name);
        Ok(DescriptorPool { raw })
    }

    pub fn allocate(
        &self,
        ctx: &GpuContext,
        layout: vk::DescriptorSetLayout,
        name: &str,
    ) -> GpuResult<vk::DescriptorSet> {
        let layouts = [layout];
        let info = vk::DescriptorSetAllocateInfo::default().descriptor_pool(self.raw).set_layouts(&layouts);
        // SAFETY: the pool outlives the set.
        let set = unsafe { ctx.device.allocate_descriptor_sets(&info) }.vk("vkAllocateDescriptorSets")?[0];
        ctx.name_object(set, name);
        Ok(set)
    }

    pub fn reset(&self, ctx: &GpuContext) -> GpuResult<()> {
        // SAFETY: no set from this pool is in use by a pending frame.
        unsafe { ctx.device.reset_descriptor_pool(self.raw, vk::DescriptorPoolResetFlags::empty()) }
            .vk("vkResetDescriptorPool")
    }

    pub fn destroy(&self, ctx: &GpuContext) {
        unsafe { ctx.device.destroy_descriptor_pool(self.raw, None) };
    }
}

/// One descriptor write: a buffer or an image at a binding.
pub enum Bound {
    Uniform(vk::Buffer),
    Storage(vk::Buffer),
    StorageImage(vk::ImageView),
    Sampled(vk::ImageView, vk::Sampler),
    /// A uniform texel buffer (`usamplerBuffer`), see `gpu::texel_buffer`.
    UniformTexel(vk::BufferView),
}

/// Writes all bindings of `set` in one call.
pub fn write_set(ctx: &GpuContext, set: vk::DescriptorSet, bindings: &[(u32, Bound)]) {
    let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = bindings
        .iter()
        .map(|(_, b)| match b {
            Bound::Uniform(buf) | Bound::Storage(buf) => {
                [vk::DescriptorBufferInfo::default().buffer(*buf).range(vk::WHOLE_SIZE)]
            }
            _ => [vk::DescriptorBufferInfo::default()],
        })
        .collect();
    let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = bindings
        .iter()
        .map(|(_, b)| match b {
            Bound::StorageImage(view) => {
                [vk::DescriptorImageInfo::default().image_view(*view).image_layout(vk::ImageLayout::GENERAL)]
            }
            Bound::Sampled(view, sampler) => [vk::DescriptorImageInfo::default()
                .image_view(*view)
                .sampler(*sampler)
                .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)],
            _ => [vk::DescriptorImageInfo::default()],
        })
        .collect();
    let texel_views: Vec<[vk::BufferView; 1]> = bindings
        .iter()
        .map(|(_, b)| match b {
            Bound::UniformTexel(view) => [*view],
            _ => [vk::BufferView::null()],
        })
        .collect();
    let writes: Vec<vk::WriteDescriptorSet> = bindings
        .iter()
        .enumerate()
        .map(|(i, (index, b))| {
            let w = vk::WriteDescriptorSet::default().dst_set(set).dst_binding(*index);
            match b {
                Bound::Uniform(_) => {
                    w.descriptor_type(vk::DescriptorType::UNIFORM_BUFFER).buffer_info(&buffer_infos[i])
                }
                Bound::Storage(_) => {
                    w.descriptor_type(vk::DescriptorType::STORAGE_BUFFER).buffer_info(&buffer_infos[i])
                }
                Bound::StorageImage(_) => {
                    w.descriptor_type(vk::DescriptorType::STORAGE_IMAGE).image_info(&image_infos[i])
                }
                Bound::Sampled(..) => {
                    w.descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER).image_info(&image_infos[i])
                }
                Bound::UniformTexel(_) => w
                    .descriptor_type(vk::DescriptorType::UNIFORM_TEXEL_BUFFER)
                    .texel_buffer_view(&texel_views[i]),
            }
        })
        .collect();
    // SAFETY: the set is not in use by a pending frame; all handles are live.
    unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
}
