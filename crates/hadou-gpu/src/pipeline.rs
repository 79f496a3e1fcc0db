//! Pipelines whose layouts come from their shaders' SPIR-V (`gpu::reflect`), descriptor pools,
//! and descriptor writes. Every object is freed by Drop through the retire queue.

use ash::vk;

use super::context::GpuContext;
use super::error::{GpuError, GpuResult, VkResultExt};
use super::reflect::{merge, reflect, Reflected};
use super::resources::{Garbage, Releaser};

/// A pipeline with its layout and its one descriptor set layout (set 0), as its shaders declare.
pub struct Pipeline {
    pub name: String,
    pub raw: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub set_layout: vk::DescriptorSetLayout,
    pub bind_point: vk::PipelineBindPoint,
    /// The bindings of set 0 the shaders use, by binding number.
    pub bindings: Vec<Reflected>,
    /// The stages that read the push constants.
    pub push_stages: vk::ShaderStageFlags,
    releaser: Releaser,
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        for g in [
            Garbage::Pipeline(self.raw),
            Garbage::PipelineLayout(self.layout),
            Garbage::SetLayout(self.set_layout),
        ] {
            self.releaser.retire(g);
        }
    }
}

/// A shader module destroyed when it goes out of scope (modules are not needed after creation).
struct Module<'a> {
    ctx: &'a GpuContext,
    raw: vk::ShaderModule,
}

impl Drop for Module<'_> {
    fn drop(&mut self) {
        // SAFETY: pipelines made from it keep their own copy of the code.
        unsafe { self.ctx.device.destroy_shader_module(self.raw, None) };
    }
}

fn shader_module<'a>(ctx: &'a GpuContext, name: &str, words: &[u32]) -> GpuResult<Module<'a>> {
    let info = vk::ShaderModuleCreateInfo::default().code(words);
    // SAFETY: words is SPIR-V from shaderc.
    let raw = unsafe { ctx.device.create_shader_module(&info, None) }.vk("vkCreateShaderModule")?;
    ctx.name_object(raw, name);
    Ok(Module { ctx, raw })
}

/// An empty pipeline (null handles) that `create` fills; dropping it part-way frees what was made.
fn empty(ctx: &GpuContext, name: &str, bind_point: vk::PipelineBindPoint) -> Pipeline {
    Pipeline {
        name: name.into(),
        raw: vk::Pipeline::null(),
        layout: vk::PipelineLayout::null(),
        set_layout: vk::DescriptorSetLayout::null(),
        bind_point,
        bindings: Vec::new(),
        push_stages: vk::ShaderStageFlags::empty(),
        releaser: ctx.releaser(),
    }
}

/// Fills in the set layout and pipeline layout from the shaders' reflected bindings; the Rust
/// push-constant struct of `push_bytes` must have the size the shaders declare.
fn layouts(
    ctx: &GpuContext,
    p: &mut Pipeline,
    stages: &[(vk::ShaderStageFlags, &[u32])],
    push_bytes: u32,
    extra_sets: &[vk::DescriptorSetLayout],
) -> GpuResult<()> {
    let mut interfaces = Vec::new();
    for (stage, words) in stages {
        interfaces.push((*stage, reflect(&p.name, words)?));
    }
    let sets = interfaces.iter().map(|(_, i)| i.sets).max().unwrap_or(0);
    if sets > 1 + extra_sets.len() as u32 {
        return Err(GpuError::Shader {
            name: p.name.clone(),
            message: format!(
                "the shaders use descriptor set {}, the pipeline has layouts for sets 0..={}",
                sets - 1,
                extra_sets.len()
            ),
        });
    }
    let declared = interfaces.iter().map(|(_, i)| i.push_bytes).max().unwrap_or(0);
    if declared != push_bytes {
        return Err(GpuError::Shader {
            name: p.name.clone(),
            message: format!(
                "the shaders declare {declared} bytes of push constants, the Rust struct has {push_bytes}"
            ),
        });
    }
    p.push_stages = interfaces
        .iter()
        .filter(|(_, i)| i.push_bytes > 0)
        .fold(vk::ShaderStageFlags::empty(), |acc, (s, _)| acc | *s);
    let refs: Vec<_> = interfaces.iter().map(|(s, i)| (*s, i)).collect();
    let merged = merge(&p.name, &refs)?;
    let bindings: Vec<_> = merged
        .iter()
        .map(|(b, stages)| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(b.binding)
                .descriptor_type(b.ty)
                .descriptor_count(1)
                .stage_flags(*stages)
        })
        .collect();
    p.bindings = merged.iter().map(|(b, _)| *b).collect();
    let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
    // SAFETY: valid device; freed by the pipeline's Drop.
    p.set_layout =
        unsafe { ctx.device.create_descriptor_set_layout(&info, None) }.vk("vkCreateDescriptorSetLayout")?;
    let set_layouts: Vec<vk::DescriptorSetLayout> =
        std::iter::once(p.set_layout).chain(extra_sets.iter().copied()).collect();
    let ranges = [vk::PushConstantRange::default().stage_flags(p.push_stages).size(push_bytes)];
    let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
    if push_bytes > 0 {
        layout_info = layout_info.push_constant_ranges(&ranges);
    }
    // SAFETY: the set layout was just created on this device; `layout_info`'s arrays outlive the
    // call; freed by the pipeline's Drop.
    p.layout =
        unsafe { ctx.device.create_pipeline_layout(&layout_info, None) }.vk("vkCreatePipelineLayout")?;
    ctx.name_object(p.set_layout, &format!("{} set layout", p.name));
    ctx.name_object(p.layout, &format!("{} layout", p.name));
    Ok(())
}

/// A compute pipeline; its layout is what the shader declares. `push_bytes` is the size of the
/// Rust push-constant struct (checked against the shader).
pub fn create_compute_pipeline(
    ctx: &GpuContext,
    name: &str,
    spirv: &[u32],
    push_bytes: u32,
) -> GpuResult<Pipeline> {
    let mut p = empty(ctx, name, vk::PipelineBindPoint::COMPUTE);
    layouts(ctx, &mut p, &[(vk::ShaderStageFlags::COMPUTE, spirv)], push_bytes, &[])?;
    let module = shader_module(ctx, name, spirv)?;
    let stage = vk::PipelineShaderStageCreateInfo::default()
        .stage(vk::ShaderStageFlags::COMPUTE)
        .module(module.raw)
        .name(c"main");
    let info = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(p.layout)];
    // SAFETY: module and layout are valid.
    let created = unsafe { ctx.device.create_compute_pipelines(ctx.pipeline_cache(), &info, None) };
    p.raw = created.map_err(|(_, e)| e).vk("vkCreateComputePipelines")?[0];
    ctx.name_object(p.raw, name);
    Ok(p)
}

/// What a dynamic-rendering graphics pipeline needs beyond its shaders.
pub struct GraphicsDesc<'a> {
    pub name: &'a str,
    pub vertex: &'a [u32],
    pub fragment: &'a [u32],
    /// Size of the Rust push-constant struct (checked against the shaders).
    pub push_constant_bytes: u32,
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
    /// Added: colour = src + dst, the attachment's alpha kept (light an effect adds to `hdr`).
    Add,
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
            Blend::Add => state
                .blend_enable(true)
                .src_color_blend_factor(vk::BlendFactor::ONE)
                .dst_color_blend_factor(vk::BlendFactor::ONE)
                .color_blend_op(vk::BlendOp::ADD)
                .src_alpha_blend_factor(vk::BlendFactor::ZERO)
                .dst_alpha_blend_factor(vk::BlendFactor::ONE)
                .alpha_blend_op(vk::BlendOp::ADD),
        }
    }
}

pub fn create_graphics_pipeline(ctx: &GpuContext, desc: &GraphicsDesc) -> GpuResult<Pipeline> {
    create_graphics_pipeline_with_sets(ctx, desc, &[])
}

/// A graphics pipeline whose shaders also use sets 1.. with the layouts `extra_sets` (owned by the
/// caller, who writes and binds those sets itself: `Recorder::bind_set`); set 0 is reflected.
pub fn create_graphics_pipeline_with_sets(
    ctx: &GpuContext,
    desc: &GraphicsDesc,
    extra_sets: &[vk::DescriptorSetLayout],
) -> GpuResult<Pipeline> {
    let mut p = empty(ctx, desc.name, vk::PipelineBindPoint::GRAPHICS);
    let stages =
        [(vk::ShaderStageFlags::VERTEX, desc.vertex), (vk::ShaderStageFlags::FRAGMENT, desc.fragment)];
    layouts(ctx, &mut p, &stages, desc.push_constant_bytes, extra_sets)?;
    let vs = shader_module(ctx, &format!("{}.vert", desc.name), desc.vertex)?;
    let fs = shader_module(ctx, &format!("{}.frag", desc.name), desc.fragment)?;
    let stages = [
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::VERTEX)
            .module(vs.raw)
            .name(c"main"),
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::FRAGMENT)
            .module(fs.raw)
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
        .layout(p.layout)
        .push_next(&mut rendering)];
    // SAFETY: every referenced state outlives the call.
    let created = unsafe { ctx.device.create_graphics_pipelines(ctx.pipeline_cache(), &info, None) };
    p.raw = created.map_err(|(_, e)| e).vk("vkCreateGraphicsPipelines")?[0];
    ctx.name_object(p.raw, desc.name);
    Ok(p)
}

/// Descriptor sets for one frame slot: reset as a whole when the slot is recorded again (its
/// previous frame has finished), so sets are written fresh each frame and never while in use.
pub struct DescriptorPool {
    pub raw: vk::DescriptorPool,
    releaser: Releaser,
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
                descriptor_count: max_sets * 8,
            },
        ];
        let info = vk::DescriptorPoolCreateInfo::default().max_sets(max_sets).pool_sizes(&sizes);
        // SAFETY: valid device.
        let raw = unsafe { ctx.device.create_descriptor_pool(&info, None) }.vk("vkCreateDescriptorPool")?;
        ctx.name_object(raw, name);
        Ok(DescriptorPool { raw, releaser: ctx.releaser() })
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
        // SAFETY: no set from this pool is in use by a pending frame (the caller's guarantee).
        unsafe { ctx.device.reset_descriptor_pool(self.raw, vk::DescriptorPoolResetFlags::empty()) }
            .vk("vkResetDescriptorPool")
    }
}

impl Drop for DescriptorPool {
    fn drop(&mut self) {
        self.releaser.retire(Garbage::DescriptorPool(self.raw));
    }
}

/// A range of a buffer bound as a uniform or storage buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BufferRange {
    pub buffer: vk::Buffer,
    pub offset: u64,
    /// Bytes, or `vk::WHOLE_SIZE`.
    pub range: u64,
    /// Bytes of one element of the Rust type the range holds (0: untyped). Checked against the
    /// element the shader declares (`Reflected::element_bytes`) when the range is bound, so a Rust
    /// struct and its GLSL twin cannot drift apart in size.
    pub element_bytes: u32,
}

impl BufferRange {
    pub fn whole(buffer: vk::Buffer) -> Self {
        BufferRange { buffer, offset: 0, range: vk::WHOLE_SIZE, element_bytes: 0 }
    }

    /// The same range, holding elements of `T`.
    pub fn of<T>(self) -> Self {
        BufferRange { element_bytes: std::mem::size_of::<T>() as u32, ..self }
    }
}

/// One descriptor write: a buffer or an image at a binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bound {
    Uniform(BufferRange),
    Storage(BufferRange),
    StorageImage(vk::ImageView),
    Sampled(vk::ImageView, vk::Sampler),
    /// A uniform texel buffer (`usamplerBuffer`), see `gpu::texel_buffer`.
    UniformTexel(vk::BufferView),
    /// Nothing at this binding: a pass whose later bindings are there without this one (an
    /// optional input of another variant). A shader that declares the binding is refused by
    /// `bind_set`, as for a binding past the end of the list.
    Unused,
}

impl Bound {
    /// The descriptor type; None for `Unused`.
    pub fn descriptor_type(&self) -> Option<vk::DescriptorType> {
        Some(match self {
            Bound::Uniform(_) => vk::DescriptorType::UNIFORM_BUFFER,
            Bound::Storage(_) => vk::DescriptorType::STORAGE_BUFFER,
            Bound::StorageImage(_) => vk::DescriptorType::STORAGE_IMAGE,
            Bound::Sampled(..) => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            Bound::UniformTexel(_) => vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
            Bound::Unused => return None,
        })
    }
}

/// Writes all bindings of `set` in one call.
pub fn write_set(ctx: &GpuContext, set: vk::DescriptorSet, bindings: &[(u32, Bound)]) {
    let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = bindings
        .iter()
        .map(|(_, b)| match b {
            Bound::Uniform(r) | Bound::Storage(r) => {
                [vk::DescriptorBufferInfo::default().buffer(r.buffer).offset(r.offset).range(r.range)]
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
        .filter_map(|(i, (index, b))| {
            let w = vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(*index)
                .descriptor_type(b.descriptor_type()?);
            Some(match b {
                Bound::Uniform(_) | Bound::Storage(_) => w.buffer_info(&buffer_infos[i]),
                Bound::StorageImage(_) | Bound::Sampled(..) => w.image_info(&image_infos[i]),
                Bound::UniformTexel(_) => w.texel_buffer_view(&texel_views[i]),
                Bound::Unused => return None,
            })
        })
        .collect();
    // SAFETY: the set is not in use by a pending frame; all handles are live.
    unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
}

/// Allocates a set for `pipeline` from `pool` and writes `bound` into it, binding i at binding i;
/// an error naming the pipeline when the list does not match what its shaders declare.
pub fn bind_set(
    ctx: &GpuContext,
    pool: &DescriptorPool,
    pipeline: &Pipeline,
    bound: &[Bound],
) -> GpuResult<vk::DescriptorSet> {
    for b in &pipeline.bindings {
        let given = bound.get(b.binding as usize);
        if let Some(Bound::Uniform(r) | Bound::Storage(r)) = given {
            if r.element_bytes != 0 && b.element_bytes != 0 && r.element_bytes != b.element_bytes {
                return Err(GpuError::Shader {
                    name: pipeline.name.clone(),
                    message: format!(
                        "binding {}: the shader's element is {} bytes, the Rust type bound to it {}",
                        b.binding, b.element_bytes, r.element_bytes
                    ),
                });
            }
        }
        let given = given.and_then(Bound::descriptor_type);
        if given != Some(b.ty) {
            return Err(GpuError::Shader {
                name: pipeline.name.clone(),
                message: format!(
                    "binding {} is {:?} in the shader, the pass gives {}",
                    b.binding,
                    b.ty,
                    given.map_or("nothing".to_string(), |t| format!("{t:?}"))
                ),
            });
        }
    }
    let set = pool.allocate(ctx, pipeline.set_layout, &pipeline.name)?;
    // Bindings the optimizer removed from the shader (unused) are not written.
    let writes: Vec<(u32, Bound)> =
        pipeline.bindings.iter().map(|b| (b.binding, bound[b.binding as usize])).collect();
    write_set(ctx, set, &writes);
    Ok(set)
}
