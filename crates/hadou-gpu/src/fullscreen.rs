//! A full-screen-triangle graphics pipeline with one colour attachment and a fixed blend: how
//! hadou draws its result into a game's colour target (any colour-attachment format, no storage).

use ash::vk;

use super::context::GpuContext;
use super::error::GpuResult;
use super::pipeline::{create_graphics_pipeline, Blend, GraphicsDesc, Pipeline};

/// `fullscreen.vert` + a fragment shader writing location 0 into `color_format`, blended as
/// premultiplied alpha: result = src + (1 − src.a)·dst (colour and alpha).
pub fn create_fullscreen_pipeline(
    ctx: &GpuContext,
    name: &str,
    vertex: &[u32],
    fragment: &[u32],
    push_constant_bytes: u32,
    color_format: vk::Format,
) -> GpuResult<Pipeline> {
    create_graphics_pipeline(
        ctx,
        &GraphicsDesc {
            name,
            vertex,
            fragment,
            push_constant_bytes,
            vertex_bindings: &[],
            vertex_attributes: &[],
            color_formats: &[color_format],
            depth_format: vk::Format::UNDEFINED,
            depth_compare: vk::CompareOp::ALWAYS,
            cull_mode: vk::CullModeFlags::NONE,
            blend: Blend::PremultipliedOver,
        },
    )
}
