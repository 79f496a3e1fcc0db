//! The scene on the GPU: one vertex and index buffer per mesh (shared by all its instances),
//! the instance and material tables, and the frame uniforms. Built once per loaded scene.

use crate::gpu::memory::{Buffer, Memory};
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::passes::gpu_structs::{instance_records, material_records, FrameUniforms};
use crate::scene::Scene;
use gpu_allocator::MemoryLocation;

pub struct GpuMesh {
    pub vertices: Buffer,
    pub indices: Buffer,
    pub index_count: u32,
}

/// One instanced draw: a mesh and its range in the instance table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Draw {
    pub mesh: usize,
    pub first_instance: u32,
    pub instance_count: u32,
}

pub struct SceneGpu {
    pub meshes: Vec<GpuMesh>,
    pub draws: Vec<Draw>,
    pub instances: Buffer,
    pub materials: Buffer,
    pub uniforms: Buffer,
}

/// Host-visible buffer holding `bytes`. Scene data is small and written once, so it lives in
/// host-visible memory (device-local on integrated GPUs and lavapipe, BAR memory elsewhere).
fn upload(
    ctx: &GpuContext,
    memory: &Memory,
    name: &str,
    usage: vk::BufferUsageFlags,
    bytes: &[u8],
) -> GpuResult<Buffer> {
    let mut buffer = memory.create_buffer(ctx, name, bytes.len() as u64, usage, MemoryLocation::CpuToGpu)?;
    if let Err(e) = buffer.write(0, bytes) {
        memory.destroy_buffer(ctx, buffer);
        return Err(e);
    }
    Ok(buffer)
}

/// Non-empty bytes for a storage buffer: an empty table still needs a valid binding.
fn at_least_one_word(bytes: &[u8]) -> &[u8] {
    if bytes.is_empty() {
        &[0; 4]
    } else {
        bytes
    }
}

impl SceneGpu {
    pub fn new(ctx: &GpuContext, memory: &Memory, scene: &Scene) -> GpuResult<Self> {
        // Collect every buffer as it is made so a failure part-way frees the ones before it.
        let mut made: Vec<Buffer> = Vec::new();
        let result = Self::build(ctx, memory, scene, &mut made);
        if result.is_err() {
            for b in made {
                memory.destroy_buffer(ctx, b);
            }
        }
        result
    }

    fn build(ctx: &GpuContext, memory: &Memory, scene: &Scene, made: &mut Vec<Buffer>) -> GpuResult<Self> {
        let mut mesh_index_counts = Vec::new();
        for m in &scene.meshes {
            let vertices: Vec<[f32; 6]> = m
                .mesh
                .positions
                .iter()
                .zip(&m.mesh.normals)
                .map(|(p, n)| [p[0], p[1], p[2], n[0], n[1], n[2]])
                .collect();
            let usage = vk::BufferUsageFlags::VERTEX_BUFFER;
            made.push(upload(
                ctx,
                memory,
                &format!("mesh {} vertices", m.name),
                usage,
                bytemuck::cast_slice(&vertices),
            )?);
            let usage = vk::BufferUsageFlags::INDEX_BUFFER;
            let indices = bytemuck::cast_slice(&m.mesh.indices);
            made.push(upload(ctx, memory, &format!("mesh {} indices", m.name), usage, indices)?);
            mesh_index_counts.push(m.mesh.indices.len() as u32);
        }
        let (records, ranges) = instance_records(scene);
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let instances =
            upload(ctx, memory, "instances", storage, at_least_one_word(bytemuck::cast_slice(&records)))?;
        made.push(instances);
        let materials = material_records(scene);
        made.push(upload(
            ctx,
            memory,
            "materials",
            storage,
            at_least_one_word(bytemuck::cast_slice(&materials)),
        )?);
        let uniforms = FrameUniforms::new(scene, 1, 1);
        let usage = vk::BufferUsageFlags::UNIFORM_BUFFER;
        made.push(upload(ctx, memory, "frame uniforms", usage, bytemuck::bytes_of(&uniforms))?);

        let uniforms = made.pop().expect("pushed above");
        let materials = made.pop().expect("pushed above");
        let instances = made.pop().expect("pushed above");
        let mut buffers = std::mem::take(made).into_iter();
        let meshes = mesh_index_counts
            .into_iter()
            .filter_map(|index_count| {
                Some(GpuMesh { vertices: buffers.next()?, indices: buffers.next()?, index_count })
            })
            .collect();
        let draws = ranges
            .iter()
            .enumerate()
            .filter(|(_, (_, count))| *count > 0)
            .map(|(mesh, &(first_instance, instance_count))| Draw { mesh, first_instance, instance_count })
            .collect();
        Ok(SceneGpu { meshes, draws, instances, materials, uniforms })
    }

    /// Writes this frame's uniforms (the previous frame has finished: headless frames wait).
    pub fn update_uniforms(&mut self, scene: &Scene, width: u32, height: u32) -> GpuResult<()> {
        let uniforms = FrameUniforms::new(scene, width, height);
        self.uniforms.write(0, bytemuck::bytes_of(&uniforms))
    }

    /// Rewrites the instance table after transforms changed (same instances, same order; the
    /// previous frame has finished).
    pub fn upload_instances(&mut self, scene: &Scene) -> GpuResult<()> {
        let (records, _) = instance_records(scene);
        self.instances.write(0, at_least_one_word(bytemuck::cast_slice(&records)))
    }

    pub fn destroy(self, ctx: &GpuContext, memory: &Memory) {
        for m in self.meshes {
            memory.destroy_buffer(ctx, m.vertices);
            memory.destroy_buffer(ctx, m.indices);
        }
        memory.destroy_buffer(ctx, self.instances);
        memory.destroy_buffer(ctx, self.materials);
        memory.destroy_buffer(ctx, self.uniforms);
    }
}
