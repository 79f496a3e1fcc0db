//! depth_import: the game's depth → hadou's `distance` (along each pixel's view ray) and its own
//! reverse-Z `depth`. `import_depth` is the f64 twin of shaders/depth_import.comp.

use crate::gpu::memory::MemoryLocation;

use super::{Binding, FrameContext, ImageUse, Pass, PassRecording, Reader};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::memory::Buffer;
use crate::gpu::pipeline::{create_compute_pipeline, Bound, BufferRange, Pipeline};
use crate::gpu::sampler::Sampler;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::renderer::DepthConvention;
use crate::scene::camera::{Camera, PixelRect};
use crate::scene::Scene;
use crate::targets::Target;

/// What one stored depth value becomes: (distance along the pixel's view ray, +inf for the far
/// plane = sky; hadou's reverse-Z depth for `camera`'s near/far, clamped to [0, 1], 0 for sky).
/// `ray_scale` = |forward + (ndc_x + offset.x)·right + (ndc_y + offset.y)·up| of `Camera::ray_frame` (1 / cos of the
/// pixel ray's angle to the forward axis).
pub fn import_depth(stored: f64, convention: DepthConvention, ray_scale: f64, camera: &Camera) -> (f64, f64) {
    let (a, b) = convention.coefficients();
    let sky = if convention.reversed() { stored <= 0.0 } else { stored >= 1.0 };
    if sky {
        return (f64::INFINITY, 0.0);
    }
    let z = b / (stored + a);
    let (hn, hf) = (camera.near, camera.far);
    let own = if hf.is_infinite() { hn / z } else { hn * (hf - z) / (z * (hf - hn)) };
    (z * ray_scale, own.clamp(0.0, 1.0))
}

/// The stored depth of view depth z (the projection the game used), in f64.
pub fn store_depth(z: f64, convention: DepthConvention) -> f64 {
    let (a, b) = convention.coefficients();
    -a + b / z
}

/// Push constants of shaders/depth_import.comp (size checked against the shader). The camera's
/// ray frame, its far distance and the frame's size are the frame's uniforms (`FrameUniforms`:
/// `ray_right`, `ray_up`, `ray_forward`, `counts`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct Params {
    /// x: 1 if the game's depth is reverse-Z; y: the staging buffer's row length (the depth
    /// rectangle's width rounded up to whole 8-pixel workgroups); z, w: the rectangle's first
    /// column and row.
    dims: [u32; 4],
    /// The game's projection (stored d = −A + B / z): A, B; hadou's near distance.
    planes: [f32; 4],
}

crate::gpu::layout::gpu_layout!(Params as "Params" { dims, planes });

/// The pixels whose depth the raster can test: the screen bounds of the corners of every
/// instance's transformed mesh box (`Camera::pixel_bounds`, conservative: the box's hull holds the
/// mesh, and a box reaching past the near plane gives the whole frame). None: no instance.
pub fn raster_pixels(
    scene: &Scene,
    mesh_bounds: &[(glam::DVec3, glam::DVec3)],
    extent: vk::Extent2D,
) -> Option<PixelRect> {
    let corners: Vec<glam::DVec3> = scene
        .instances
        .iter()
        .flat_map(|inst| {
            let (lo, hi) = mesh_bounds[inst.mesh];
            (0..8).map(move |c| {
                let p =
                    glam::DVec3::new([lo.x, hi.x][c & 1], [lo.y, hi.y][(c >> 1) & 1], [lo.z, hi.z][c >> 2]);
                inst.transform.transform_point(p)
            })
        })
        .collect();
    scene.camera.pixel_bounds(&corners, extent.width, extent.height)
}

/// Runs first in an embedded frame whose game hands its depth (`FrameInputs::depth`). The game's
/// depth image is the frame's `GameDepth` target, imported for that frame only: its view is bound
/// into the slot's descriptor set each frame, never cached by handle. Two dispatches: `distance`
/// over the whole frame (the energy wave reads every pixel of it), and hadou's own `depth` only
/// over `raster_pixels` (staged in a buffer and copied into that rectangle) when the raster is the
/// only later pass that declares `depth` (its depth attachment, inside its instances' bounds);
/// when any other pass declares it (an effect may read it anywhere) the whole image.
pub struct DepthImportPass {
    /// `distance`, every pixel.
    pipeline: Pipeline,
    /// `depth` (HADOU_DEPTH) into the staging buffer, over `rect`.
    depth_pipeline: Pipeline,
    sampler: Sampler,
    /// hadou's reverse-Z depth as f32 texels, copied into the D32 `depth` (lavapipe has no
    /// storage D32); sized for the whole frame (rows padded to whole workgroups: whether the
    /// rectangle or the whole image is imported is known when the pass records). Frames in flight
    /// share it: the runner orders each frame's write after the previous frame's copy.
    staging: Option<Buffer>,
    params: Params,
    /// The frame's size: the distance dispatch.
    extent: vk::Extent2D,
    /// This frame's depth rectangle for the raster; None: no instance.
    rect: Option<PixelRect>,
    convention: DepthConvention,
}

impl DepthImportPass {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let push = std::mem::size_of::<Params>() as u32;
        let spirv = compiler.compile("depth_import.comp", &[])?;
        let pipeline = create_compute_pipeline(ctx, "depth_import", &spirv, push)?;
        let spirv = compiler.compile("depth_import.comp", &[("HADOU_DEPTH", "1")])?;
        let depth_pipeline = create_compute_pipeline(ctx, "depth_import (depth)", &spirv, push)?;
        Ok(DepthImportPass {
            pipeline,
            depth_pipeline,
            sampler: Sampler::nearest(ctx, "depth_import sampler")?,
            staging: None,
            params: Params::default(),
            extent: vk::Extent2D::default(),
            rect: None,
            convention: DepthConvention::ReverseZ { near: 1.0, far: 2.0 },
        })
    }

    /// This frame's depth convention (the game's projection may change per frame).
    pub fn set_convention(&mut self, convention: DepthConvention) {
        self.convention = convention;
    }
}

impl Pass for DepthImportPass {
    fn name(&self) -> &'static str {
        "depth_import"
    }

    fn images(&self) -> Vec<ImageUse> {
        vec![ImageUse::new(Target::Depth, ImageAccess::TRANSFER_DST)]
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let extent = frame.extent;
        self.rect = raster_pixels(frame.scene, &frame.scene_gpu.mesh_bounds(), extent);
        // Whole 8×8 workgroups: every lane stores into the buffer, the copy skips the padding.
        let (row, rows) = (extent.width.next_multiple_of(8), extent.height.next_multiple_of(8));
        let size = row as u64 * rows as u64 * 4;
        if self.staging.as_ref().is_none_or(|b| b.size < size) {
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
            let name = "depth_import staging";
            // The old buffer retires with the frame.
            self.staging =
                Some(frame.memory.create_buffer(frame.ctx, name, size, usage, MemoryLocation::GpuOnly)?);
        }
        let (a, b) = self.convention.coefficients();
        self.params = Params {
            dims: [u32::from(self.convention.reversed()), row, 0, 0],
            planes: [a as f32, b as f32, frame.scene.camera.near as f32, 0.0],
        };
        self.extent = extent;
        let staging = self
            .staging
            .as_ref()
            .map_or(BufferRange::whole(vk::Buffer::null()), |b| BufferRange::whole(b.raw));
        Ok(vec![
            Binding::sampled(Target::GameDepth, self.sampler.raw),
            Binding::write(Target::Distance),
            Binding::Written(staging, Reader::Copy),
            Binding::Bound(Bound::Uniform(frame.uniforms)),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline, &self.depth_pipeline]
    }

    fn record(&self, pass: &PassRecording) {
        let rec = pass.rec;
        let vk::Extent2D { width, height } = self.extent;
        rec.bind_pipeline(&self.pipeline, pass.set(0));
        rec.push_constants(&self.pipeline, bytemuck::bytes_of(&self.params));
        rec.dispatch_2d(width, height, (8, 8));
        // A later pass other than the raster that declares `depth` may read it anywhere.
        let whole = pass.used_later_by(Target::Depth).any(|name| name != "raster");
        let rect = if whole { Some(PixelRect::full(width, height)) } else { self.rect };
        let (Some(r), Some(staging)) = (rect, &self.staging) else { return };
        let params =
            Params { dims: [self.params.dims[0], r.width().next_multiple_of(8), r.x0, r.y0], ..self.params };
        rec.bind_pipeline(&self.depth_pipeline, pass.set(1));
        rec.push_constants(&self.depth_pipeline, bytemuck::bytes_of(&params));
        rec.dispatch_2d(r.width(), r.height(), (8, 8));
        rec.compute_to_copy_barrier();
        let region = vk::Rect2D {
            offset: vk::Offset2D { x: r.x0 as i32, y: r.y0 as i32 },
            extent: vk::Extent2D { width: r.width(), height: r.height() },
        };
        rec.copy_buffer_to_depth(staging, params.dims[1], &pass.targets.image(Target::Depth), region);
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
            lens: Default::default(),
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
