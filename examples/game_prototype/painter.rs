//! The game's own raster: flat-shaded boxes (a quad is a thin box) with a standard-Z projection
#![allow(dead_code)]
//! (near → 0, far → 1, compare LESS), into the game's colour and depth images.

use ash::vk;
use glam::{DMat4, DVec3, DVec4};

use super::gpu::GameVk;

const VERTEX: &str = r#"
#version 460
layout(push_constant) uniform Draw { mat4 mvp; vec4 color; } draw;
layout(location = 0) flat out vec3 v_color;
// A unit box [-0.5, 0.5]^3: 6 faces x 2 triangles, from gl_VertexIndex.
const vec3 corners[8] = vec3[](vec3(-0.5,-0.5,-0.5), vec3(0.5,-0.5,-0.5), vec3(0.5,0.5,-0.5), vec3(-0.5,0.5,-0.5),
                               vec3(-0.5,-0.5,0.5), vec3(0.5,-0.5,0.5), vec3(0.5,0.5,0.5), vec3(-0.5,0.5,0.5));
const int faces[36] = int[](0,1,2, 0,2,3,  4,6,5, 4,7,6,  0,4,5, 0,5,1,  3,2,6, 3,6,7,  0,3,7, 0,7,4,  1,5,6, 1,6,2);
const float shade[6] = float[](0.8, 1.0, 0.6, 0.9, 0.7, 0.75);
void main() {
    gl_Position = draw.mvp * vec4(corners[faces[gl_VertexIndex]], 1.0);
    v_color = draw.color.rgb * shade[gl_VertexIndex / 6];
}
"#;

const FRAGMENT: &str = r#"
#version 460
layout(location = 0) flat in vec3 v_color;
layout(location = 0) out vec4 out_color;
void main() { out_color = vec4(v_color, 1.0); }
"#;

/// Push constants; keep in sync with VERTEX.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Draw {
    mvp: [[f32; 4]; 4],
    color: [f32; 4],
}

/// One box: its object → world matrix (applied to the unit box) and linear colour.
#[derive(Clone, Copy, Debug)]
pub struct BoxDraw {
    pub model: DMat4,
    pub color: DVec3,
}

/// The game's camera: a symmetric perspective frustum with Vulkan's standard depth.
#[derive(Clone, Copy, Debug)]
pub struct GameCamera {
    pub position: DVec3,
    pub look_at: DVec3,
    pub fov_y_deg: f64,
    pub near: f64,
    pub far: f64,
    /// Reverse-Z (near → 1, far → 0) instead of standard Z.
    pub reverse_z: bool,
}

impl GameCamera {
    /// View → clip: standard Z (near → 0, far → 1) or reverse-Z, y flipped so row 0 is the top.
    pub fn projection(&self, aspect: f64) -> DMat4 {
        let f = 1.0 / (self.fov_y_deg.to_radians() * 0.5).tan();
        let (n, fa) = (self.near, self.far);
        let (a, b) = if self.reverse_z {
            (n / (fa - n), n * fa / (fa - n))
        } else {
            (fa / (n - fa), n * fa / (n - fa))
        };
        DMat4::from_cols(
            DVec4::new(f / aspect, 0.0, 0.0, 0.0),
            DVec4::new(0.0, -f, 0.0, 0.0),
            DVec4::new(0.0, 0.0, a, -1.0),
            DVec4::new(0.0, 0.0, b, 0.0),
        )
    }

    pub fn view_projection(&self, width: u32, height: u32) -> DMat4 {
        let view = DMat4::look_at_rh(self.position, self.look_at, DVec3::Y);
        self.projection(width as f64 / height as f64) * view
    }

    /// The same camera for hadou (up = +Y).
    pub fn for_hadou(&self) -> hadou::scene::camera::Camera {
        hadou::scene::camera::Camera {
            position: self.position,
            look_at: self.look_at,
            up: DVec3::Y,
            fov_y_deg: self.fov_y_deg,
            near: self.near,
            far: self.far,
            lens: Default::default(),
        }
    }
}

/// Where a frame is painted: the colour and depth views, their size, and the clear colour.
#[derive(Clone, Copy, Debug)]
pub struct PaintTarget {
    pub color: vk::ImageView,
    pub depth: vk::ImageView,
    pub extent: vk::Extent2D,
    pub clear: DVec3,
}

pub struct Painter {
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    pub color_format: vk::Format,
    pub depth_format: vk::Format,
    /// Depth test GREATER and clear to 0 (for a reverse-Z camera) instead of LESS and 1.
    pub reverse_z: bool,
}

fn compile(
    compiler: &shaderc::Compiler,
    source: &str,
    kind: shaderc::ShaderKind,
    name: &str,
) -> Result<Vec<u32>, String> {
    let mut options = shaderc::CompileOptions::new().map_err(|e| e.to_string())?;
    options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_3 as u32);
    compiler
        .compile_into_spirv(source, kind, name, "main", Some(&options))
        .map(|a| a.as_binary().to_vec())
        .map_err(|e| format!("{name}: {e}"))
}

impl Painter {
    pub fn new(
        g: &GameVk,
        color_format: vk::Format,
        depth_format: vk::Format,
        reverse_z: bool,
    ) -> Result<Self, String> {
        let compiler = shaderc::Compiler::new().map_err(|e| e.to_string())?;
        let vs = compile(&compiler, VERTEX, shaderc::ShaderKind::Vertex, "game_box.vert")?;
        let fs = compile(&compiler, FRAGMENT, shaderc::ShaderKind::Fragment, "game_box.frag")?;
        let d = &g.device;
        // SAFETY: every object is created on the game's live device; everything the create infos
        // point at outlives its call; the shader modules are destroyed only after the pipeline call
        // (a pipeline keeps its own copy); `destroy` frees pipeline and layout.
        unsafe {
            let ranges = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::VERTEX)
                .size(std::mem::size_of::<Draw>() as u32)];
            let layout = d
                .create_pipeline_layout(
                    &vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&ranges),
                    None,
                )
                .map_err(|e| e.to_string())?;
            let vsm = d
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&vs), None)
                .map_err(|e| e.to_string())?;
            let fsm = d
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&fs), None)
                .map_err(|e| e.to_string())?;
            let stages = [
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(vk::ShaderStageFlags::VERTEX)
                    .module(vsm)
                    .name(c"main"),
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(vk::ShaderStageFlags::FRAGMENT)
                    .module(fsm)
                    .name(c"main"),
            ];
            let vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
            let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
                .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
            let viewport = vk::PipelineViewportStateCreateInfo::default().viewport_count(1).scissor_count(1);
            let raster = vk::PipelineRasterizationStateCreateInfo::default()
                .polygon_mode(vk::PolygonMode::FILL)
                .cull_mode(vk::CullModeFlags::NONE)
                .line_width(1.0);
            let multisample = vk::PipelineMultisampleStateCreateInfo::default()
                .rasterization_samples(vk::SampleCountFlags::TYPE_1);
            let depth = vk::PipelineDepthStencilStateCreateInfo::default()
                .depth_test_enable(true)
                .depth_write_enable(true)
                .depth_compare_op(if reverse_z { vk::CompareOp::GREATER } else { vk::CompareOp::LESS });
            let blend_attachments = [vk::PipelineColorBlendAttachmentState::default()
                .color_write_mask(vk::ColorComponentFlags::RGBA)];
            let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
            let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
            let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
            let formats = [color_format];
            let mut rendering = vk::PipelineRenderingCreateInfo::default()
                .color_attachment_formats(&formats)
                .depth_attachment_format(depth_format);
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
            let result = d.create_graphics_pipelines(vk::PipelineCache::null(), &info, None);
            d.destroy_shader_module(vsm, None);
            d.destroy_shader_module(fsm, None);
            let pipeline = result.map_err(|(_, e)| e.to_string())?[0];
            Ok(Painter { pipeline, layout, color_format, depth_format, reverse_z })
        }
    }

    /// Clears colour and depth (1.0 = far) and draws the boxes; both images must be in their
    /// attachment layouts, and stay there.
    pub fn record(&self, g: &GameVk, target: &PaintTarget, camera: &GameCamera, boxes: &[BoxDraw]) {
        let PaintTarget { color, depth, extent, clear } = *target;
        let d = &g.device;
        let color_att = [vk::RenderingAttachmentInfo::default()
            .image_view(color)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                color: vk::ClearColorValue { float32: [clear.x as f32, clear.y as f32, clear.z as f32, 1.0] },
            })];
        let depth_att = vk::RenderingAttachmentInfo::default()
            .image_view(depth)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: if self.reverse_z { 0.0 } else { 1.0 },
                    stencil: 0,
                },
            });
        let area = vk::Rect2D { offset: vk::Offset2D::default(), extent };
        let info = vk::RenderingInfo::default()
            .render_area(area)
            .layer_count(1)
            .color_attachments(&color_att)
            .depth_attachment(&depth_att);
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: extent.width as f32,
            height: extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        let view_proj = camera.view_projection(extent.width, extent.height);
        // SAFETY: the game's command buffer is recording, outside rendering; the views are live
        // until the frame is waited for and in the attachment layouts (the caller's contract); each
        // push is the `Draw` struct the layout's range was sized for.
        unsafe {
            d.cmd_begin_rendering(g.cmd, &info);
            d.cmd_set_viewport(g.cmd, 0, &[viewport]);
            d.cmd_set_scissor(g.cmd, 0, &[area]);
            d.cmd_bind_pipeline(g.cmd, vk::PipelineBindPoint::GRAPHICS, self.pipeline);
            for b in boxes {
                let mvp = (view_proj * b.model).to_cols_array_2d().map(|c| c.map(|v| v as f32));
                let draw = Draw { mvp, color: [b.color.x as f32, b.color.y as f32, b.color.z as f32, 1.0] };
                d.cmd_push_constants(
                    g.cmd,
                    self.layout,
                    vk::ShaderStageFlags::VERTEX,
                    0,
                    bytemuck::bytes_of(&draw),
                );
                d.cmd_draw(g.cmd, 36, 1, 0, 0);
            }
            d.cmd_end_rendering(g.cmd);
        }
    }

    pub fn destroy(&self, g: &GameVk) {
        // SAFETY: made on this device by `new`; callers destroy it once no frame using it is pending
        // (after a device idle wait, or frames each waited for).
        unsafe {
            g.device.destroy_pipeline(self.pipeline, None);
            g.device.destroy_pipeline_layout(self.layout, None);
        }
    }
}
