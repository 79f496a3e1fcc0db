//! depth_import: the game's depth → hadou's `distance` (along each pixel's view ray) and its own
//! reverse-Z `depth`. `import_depth` is the f64 twin of shaders/depth_import.comp.

use gpu_allocator::MemoryLocation;

use super::inputs::{DepthConvention, ExternalDepth};
use crate::gpu::memory::{Buffer, Memory};
use crate::gpu::pipeline::{binding, create_compute_pipeline, write_set, Bound, DescriptorPool, Pipeline};
use crate::gpu::recorder::Recorder;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::upload::Sampler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene::camera::Camera;

/// What one stored depth value becomes: (distance along the pixel's view ray, +inf for the far
/// plane = sky; hadou's reverse-Z depth for `camera`'s near/far, clamped to [0, 1], 0 for sky).
/// `ray_scale` = |forward + ndc_x·right + ndc_y·up| of `Camera::ray_frame` (1 / cos of the
/// pixel ray's angle to the forward axis).
pub fn import_depth(stored: f64, convention: DepthConvention, ray_scale: f64, camera: &Camera) -> (f64, f64) {
    let (a, b) = convention.coefficients();
    let sky = if convention.reversed() { stored <= 0.0 } else { stored >= 1.0 };
    if sky {
        return (f64::INFINITY, 0.0);
    }
    let z = b / (stored + a);
    let (hn, hf) = (camera.near, camera.far);
    (z * ray_scale, (hn * (hf - z) / (z * (hf - hn))).clamp(0.0, 1.0))
}

/// The stored depth of view depth z (the projection the game used), in f64.
pub fn store_depth(z: f64, convention: DepthConvention) -> f64 {
    let (a, b) = convention.coefficients();
    -a + b / z
}

/// Push constants; keep in sync with shaders/depth_import.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    right: [f32; 4],
    up: [f32; 4],
    forward: [f32; 4],
    dims: [u32; 4],
    planes: [f32; 4],
}

pub struct DepthImport {
    pipeline: Pipeline,
    sampler: Sampler,
    /// Sets per game depth view (a game cycles through a few): a set is written once, never while
    /// a pending frame may use it. Cleared with the pool when the frame size changes.
    pool: DescriptorPool,
    sets: Vec<(vk::ImageView, vk::DescriptorSet)>,
    /// hadou's reverse-Z depth as f32 texels, copied into the D32 `depth` (lavapipe has no
    /// storage D32); sized to the frame.
    pub staging: Option<Buffer>,
}

/// Game depth views remembered at most; older ones are dropped with the pool.
const MAX_VIEWS: u32 = 8;

impl DepthImport {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let spirv = compiler.compile("depth_import.comp", &[])?;
        let c = vk::ShaderStageFlags::COMPUTE;
        let bindings = [
            binding(0, vk::DescriptorType::COMBINED_IMAGE_SAMPLER, c),
            binding(1, vk::DescriptorType::STORAGE_IMAGE, c),
            binding(2, vk::DescriptorType::STORAGE_BUFFER, c),
        ];
        let push = std::mem::size_of::<Params>() as u32;
        let pipeline = create_compute_pipeline(ctx, "depth_import", &spirv, &bindings, push)?;
        let sampler = match Sampler::nearest(ctx, "depth_import sampler") {
            Ok(s) => s,
            Err(e) => {
                pipeline.destroy(ctx);
                return Err(e);
            }
        };
        let pool = match DescriptorPool::new(ctx, "depth_import descriptors", MAX_VIEWS) {
            Ok(p) => p,
            Err(e) => {
                sampler.destroy(ctx);
                pipeline.destroy(ctx);
                return Err(e);
            }
        };
        Ok(DepthImport { pipeline, sampler, pool, sets: Vec::new(), staging: None })
    }

    /// Makes the staging buffer for `extent` (after a resize dropped it).
    pub fn ensure_size(&mut self, ctx: &GpuContext, memory: &Memory, extent: vk::Extent2D) -> GpuResult<()> {
        if self.staging.is_none() {
            let size = extent.width as u64 * extent.height as u64 * 4;
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
            let name = "depth_import staging";
            self.staging = Some(memory.create_buffer(ctx, name, size, usage, MemoryLocation::GpuOnly)?);
        }
        Ok(())
    }

    /// The set reading `depth.view` and writing `distance`; written the first time a view is seen.
    pub fn set_for(
        &mut self,
        ctx: &GpuContext,
        depth: &ExternalDepth,
        distance: vk::ImageView,
    ) -> GpuResult<vk::DescriptorSet> {
        if let Some((_, set)) = self.sets.iter().find(|(v, _)| *v == depth.view) {
            return Ok(*set);
        }
        if self.sets.len() as u32 >= MAX_VIEWS {
            // Every set may belong to a pending frame: wait before reusing the pool.
            ctx.wait_idle()?;
            self.forget_views(ctx)?;
        }
        let Some(staging) = &self.staging else {
            return Err(crate::gpu::GpuError::Limit {
                what: "depth_import".into(),
                message: "staging buffer missing (ensure_size not called)".into(),
            });
        };
        let set = self.pool.allocate(ctx, self.pipeline.set_layout, "depth_import set")?;
        write_set(
            ctx,
            set,
            &[
                (0, Bound::Sampled(depth.view, self.sampler.raw)),
                (1, Bound::StorageImage(distance)),
                (2, Bound::Storage(staging.raw)),
            ],
        );
        self.sets.push((depth.view, set));
        Ok(set)
    }

    /// Forgets every game view (their sets): after a resize, or when the game destroyed a view.
    /// The caller guarantees no pending frame uses the sets.
    pub fn forget_views(&mut self, ctx: &GpuContext) -> GpuResult<()> {
        self.sets.clear();
        self.pool.reset(ctx)
    }

    pub fn record(
        &self,
        rec: &Recorder,
        set: vk::DescriptorSet,
        depth: &ExternalDepth,
        camera: &Camera,
        extent: vk::Extent2D,
    ) {
        let [right, up, forward] = camera.ray_frame(extent.width, extent.height).to_f32();
        let (a, b) = depth.convention.coefficients();
        let reversed = depth.convention.reversed();
        let params = Params {
            right,
            up,
            forward,
            dims: [extent.width, extent.height, u32::from(reversed), 0],
            planes: [a as f32, b as f32, camera.near as f32, camera.far as f32],
        };
        rec.bind_pipeline(&self.pipeline, set);
        rec.push_constants(&self.pipeline, vk::ShaderStageFlags::COMPUTE, bytemuck::bytes_of(&params));
        rec.dispatch_2d(extent.width, extent.height, (8, 8));
    }

    pub fn drop_sized(&mut self, ctx: &GpuContext, memory: &Memory) {
        if let Some(b) = self.staging.take() {
            memory.destroy_buffer(ctx, b);
        }
        let _ = self.forget_views(ctx);
    }

    pub fn destroy(mut self, ctx: &GpuContext, memory: &Memory) {
        self.drop_sized(ctx, memory);
        self.pool.destroy(ctx);
        self.sampler.destroy(ctx);
        self.pipeline.destroy(ctx);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn camera() -> Camera {
        Camera {
            position: DVec3::ZERO,
            look_at: DVec3::new(0.0, 0.0, -1.0),
            up: DVec3::Y,
            fov_y_deg: 60.0,
            near: 0.1,
            far: 100.0,
        }
    }

    /// Storing a view depth and importing it gives the depth back, for both conventions, and
    /// hadou's depth equals its own projection's (Camera::projection_matrix) at that depth.
    #[test]
    fn round_trip_both_conventions() {
        let cam = camera();
        for conv in [
            DepthConvention::Standard { near: 0.1, far: 100.0 },
            DepthConvention::ReverseZ { near: 0.5, far: 50.0 },
        ] {
            for z in [0.6, 1.0, 3.7, 20.0, 49.0] {
                let (dist, own) = import_depth(store_depth(z, conv), conv, 1.25, &cam);
                assert!((dist - 1.25 * z).abs() < 1e-12 * z, "{conv:?} {z}: {dist}");
                let clip = cam.projection_matrix(1.0) * glam::DVec4::new(0.0, 0.0, -z, 1.0);
                assert!((own - clip.z / clip.w).abs() < 1e-12, "{own} vs {}", clip.z / clip.w);
            }
        }
    }

    /// A projection matrix gives the same import as the near/far form it equals, and glam's
    /// infinite reverse-Z works (no far plane).
    #[test]
    fn projection_matrices() {
        let cam = camera();
        let (n, f) = (0.5, 40.0);
        let fov = 1.0;
        let pairs = [
            (
                DepthConvention::Projection(glam::DMat4::perspective_rh(fov, 1.5, n, f)),
                DepthConvention::Standard { near: n, far: f },
            ),
            (
                DepthConvention::Projection(glam::DMat4::perspective_rh(fov, 1.5, f, n)),
                DepthConvention::ReverseZ { near: n, far: f },
            ),
        ];
        for (matrix, planes) in pairs {
            matrix.check().unwrap();
            for z in [0.7, 3.0, 39.0] {
                let d = store_depth(z, planes);
                assert!((store_depth(z, matrix) - d).abs() < 1e-12, "{matrix:?} at {z}");
                let (dist, _) = import_depth(d, matrix, 1.0, &cam);
                assert!((dist - z).abs() < 1e-9 * z);
            }
        }
        let infinite = DepthConvention::Projection(glam::DMat4::perspective_infinite_reverse_rh(fov, 1.5, n));
        infinite.check().unwrap();
        assert!(infinite.reversed());
        for z in [0.6, 10.0, 1e4] {
            let (dist, _) = import_depth(store_depth(z, infinite), infinite, 1.0, &cam);
            assert!((dist - z).abs() < 1e-9 * z);
        }
        assert_eq!(import_depth(0.0, infinite, 1.0, &cam).0, f64::INFINITY);
        assert!(DepthConvention::Projection(glam::DMat4::IDENTITY).check().is_err());
        assert!(DepthConvention::Standard { near: 0.0, far: 1.0 }.check().is_err());
    }

    #[test]
    fn far_plane_is_sky() {
        let cam = camera();
        let std = DepthConvention::Standard { near: 0.1, far: 100.0 };
        assert_eq!(import_depth(1.0, std, 1.0, &cam), (f64::INFINITY, 0.0));
        let rev = DepthConvention::ReverseZ { near: 0.1, far: 100.0 };
        assert_eq!(import_depth(0.0, rev, 1.0, &cam), (f64::INFINITY, 0.0));
        // Nearer than hadou's near plane clamps to its near plane (depth 1), never above.
        assert_eq!(import_depth(store_depth(0.05, rev), rev, 1.0, &cam).1, 1.0);
    }
}
