//! wgpu's own "game" content: the prototype's flat-shaded boxes (floor, player, pillars) drawn by
//! a wgpu render pass into a colour and a standard-Z depth texture (cleared first).
#![allow(dead_code)]

use super::game::CLEAR;
use super::painter::BoxDraw;

const SHADER: &str = r#"
struct Draw { mvp: mat4x4<f32>, color: vec4<f32> };
@group(0) @binding(0) var<uniform> draws: array<Draw, 8>;
struct Out { @builtin(position) position: vec4<f32>, @location(0) @interpolate(flat) color: vec3<f32> };
// A unit box [-0.5, 0.5]^3 from the vertex index: 6 faces x 2 triangles (the ash painter's box).
const corners = array<vec3<f32>, 8>(vec3(-0.5,-0.5,-0.5), vec3(0.5,-0.5,-0.5), vec3(0.5,0.5,-0.5), vec3(-0.5,0.5,-0.5),
                                   vec3(-0.5,-0.5,0.5), vec3(0.5,-0.5,0.5), vec3(0.5,0.5,0.5), vec3(-0.5,0.5,0.5));
const faces = array<u32, 36>(0u,1u,2u, 0u,2u,3u, 4u,6u,5u, 4u,7u,6u, 0u,4u,5u, 0u,5u,1u,
                             3u,2u,6u, 3u,6u,7u, 0u,3u,7u, 0u,7u,4u, 1u,5u,6u, 1u,6u,2u);
const shade = array<f32, 6>(0.8, 1.0, 0.6, 0.9, 0.7, 0.75);
@vertex fn vs(@builtin(vertex_index) v: u32, @builtin(instance_index) i: u32) -> Out {
    let d = draws[i];
    return Out(d.mvp * vec4(corners[faces[v]], 1.0), d.color.rgb * shade[v / 6u]);
}
@fragment fn fs(in: Out) -> @location(0) vec4<f32> { return vec4(in.color, 1.0); }
"#;

/// At most this many boxes per frame (the uniform array's length in SHADER).
pub const MAX_BOXES: usize = 8;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Draw {
    mvp: [[f32; 4]; 4],
    color: [f32; 4],
}

pub struct BoxPainter {
    pipeline: wgpu::RenderPipeline,
    uniforms: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    pub color_format: wgpu::TextureFormat,
}

pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

impl BoxPainter {
    pub fn new(device: &wgpu::Device, color_format: wgpu::TextureFormat) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("game boxes"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("game boxes"),
            size: (MAX_BOXES * std::mem::size_of::<Draw>()) as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("game boxes"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(color_format.into())],
            }),
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            // Standard Z (near → 0), compare LESS: the convention hadou is told (`Standard`).
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: true,
                depth_compare: wgpu::CompareFunction::Less,
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            multiview: None,
            cache: None,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("game boxes"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() }],
        });
        BoxPainter { pipeline, uniforms, bind_group, color_format }
    }

    /// Clears `color` and `depth` (depth to 1, the far plane) and draws `boxes` seen through
    /// `view_projection` (wgpu's clip space). Both attachments are stored.
    pub fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::TextureView,
        depth: &wgpu::TextureView,
        view_projection: glam::Mat4,
        boxes: &[BoxDraw],
    ) {
        let boxes = &boxes[..boxes.len().min(MAX_BOXES)];
        let draws: Vec<Draw> = boxes
            .iter()
            .map(|b| Draw {
                mvp: (view_projection * b.model.as_mat4()).to_cols_array_2d(),
                color: [b.color.x as f32, b.color.y as f32, b.color.z as f32, 1.0],
            })
            .collect();
        queue.write_buffer(&self.uniforms, 0, bytemuck::cast_slice(&draws));
        let clear = wgpu::Color { r: CLEAR.x, g: CLEAR.y, b: CLEAR.z, a: 1.0 };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("game boxes"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: color,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.draw(0..36, 0..boxes.len() as u32);
    }
}
