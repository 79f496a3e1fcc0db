//! tonemap: HDR → sRGB with exposure and the ACES filmic curve (Narkowicz 2015 fit).
//! CPU twin: `effects::tonemap::tonemap_pixel`.

use super::{Pass, PassInputs};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::memory::Memory;
use crate::gpu::pipeline::{binding, create_compute_pipeline, write_set, Bound, DescriptorPool, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene_gpu::SceneGpu;
use crate::targets::{Target, Targets};

pub struct TonemapPass {
    pipeline: Pipeline,
    set: vk::DescriptorSet,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    exposure: f32,
    width: u32,
    height: u32,
}

impl TonemapPass {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let spirv = compiler.compile("tonemap.comp", &[])?;
        let bindings = [
            binding(0, vk::DescriptorType::STORAGE_IMAGE, vk::ShaderStageFlags::COMPUTE),
            binding(1, vk::DescriptorType::STORAGE_IMAGE, vk::ShaderStageFlags::COMPUTE),
        ];
        let pipeline =
            create_compute_pipeline(ctx, "tonemap", &spirv, &bindings, std::mem::size_of::<Params>() as u32)?;
        Ok(TonemapPass { pipeline, set: vk::DescriptorSet::null() })
    }
}

impl Pass for TonemapPass {
    fn name(&self) -> &'static str {
        "tonemap"
    }

    fn uses(&self) -> Vec<(Target, ImageAccess)> {
        vec![(Target::Hdr, ImageAccess::COMPUTE_READ), (Target::Ldr, ImageAccess::COMPUTE_WRITE)]
    }

    fn bind(
        &mut self,
        ctx: &GpuContext,
        pool: &DescriptorPool,
        _: &SceneGpu,
        targets: &Targets,
    ) -> GpuResult<()> {
        self.set = pool.allocate(ctx, self.pipeline.set_layout, "tonemap set")?;
        write_set(
            ctx,
            self.set,
            &[
                (0, Bound::StorageImage(targets.image(Target::Hdr).view)),
                (1, Bound::StorageImage(targets.image(Target::Ldr).view)),
            ],
        );
        Ok(())
    }

    fn record(&self, inputs: &PassInputs) {
        let extent = inputs.targets.extent;
        let params = Params {
            exposure: inputs.scene.render.exposure as f32,
            width: extent.width,
            height: extent.height,
        };
        inputs.rec.bind_pipeline(&self.pipeline, self.set);
        inputs.rec.push_constants(&self.pipeline, vk::ShaderStageFlags::COMPUTE, bytemuck::bytes_of(&params));
        inputs.rec.dispatch_2d(extent.width, extent.height, (8, 8));
    }

    fn destroy(&mut self, ctx: &GpuContext, _: &Memory) {
        self.pipeline.destroy(ctx);
    }
}
