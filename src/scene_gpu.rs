//! The scene on the GPU: one vertex and index buffer per mesh (shared by all its instances), built
//! once per loaded scene; the instance and material tables are kept on the host and uploaded each
//! frame through the frame slot's ring (transforms and materials change per frame).

use crate::gpu::memory::{Buffer, Memory};
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::passes::gpu_structs::{instance_records, material_records, InstanceData, MaterialData};
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
    /// The material table as the passes read it.
    materials: Vec<MaterialData>,
    /// The instance table as the raster reads it (grouped by mesh), rebuilt when transforms change.
    instances: Vec<InstanceData>,
}

/// Host-visible buffer holding `bytes` (at least one word: an empty table still binds). Scene data
/// is small and written once, so it lives in host-visible memory (device-local on integrated GPUs
/// and lavapipe, BAR memory elsewhere).
fn upload(
    ctx: &GpuContext,
    memory: &Memory,
    name: &str,
    usage: vk::BufferUsageFlags,
    bytes: &[u8],
) -> GpuResult<Buffer> {
    let mut buffer = memory.create_buffer(ctx, name, bytes.len() as u64, usage, MemoryLocation::CpuToGpu)?;
    buffer.write(0, bytes)?;
    Ok(buffer)
}

/// The instance table (grouped by mesh) and one instanced draw per mesh that has instances.
fn instance_layout(scene: &Scene) -> (Vec<InstanceData>, Vec<Draw>) {
    let (instances, ranges) = instance_records(scene);
    let draws = ranges
        .iter()
        .enumerate()
        .filter(|(_, (_, count))| *count > 0)
        .map(|(mesh, &(first_instance, instance_count))| Draw { mesh, first_instance, instance_count })
        .collect();
    (instances, draws)
}

impl SceneGpu {
    pub fn new(ctx: &GpuContext, memory: &Memory, scene: &Scene) -> GpuResult<Self> {
        let mut meshes = Vec::with_capacity(scene.meshes.len());
        for m in &scene.meshes {
            let vertices: Vec<[f32; 6]> = m
                .mesh
                .positions
                .iter()
                .zip(&m.mesh.normals)
                .map(|(p, n)| [p[0], p[1], p[2], n[0], n[1], n[2]])
                .collect();
            let name = format!("mesh {} vertices", m.name);
            let vertices = upload(
                ctx,
                memory,
                &name,
                vk::BufferUsageFlags::VERTEX_BUFFER,
                bytemuck::cast_slice(&vertices),
            )?;
            let name = format!("mesh {} indices", m.name);
            let index_bytes = bytemuck::cast_slice(&m.mesh.indices);
            let indices = upload(ctx, memory, &name, vk::BufferUsageFlags::INDEX_BUFFER, index_bytes)?;
            meshes.push(GpuMesh { vertices, indices, index_count: m.mesh.indices.len() as u32 });
        }
        let materials = material_records(scene);
        let (instances, draws) = instance_layout(scene);
        Ok(SceneGpu { meshes, draws, materials, instances })
    }

    /// The material table to upload this frame (at least one record: an empty table still binds).
    pub fn material_table(&self) -> &[MaterialData] {
        &self.materials
    }

    /// Rebuilds the material table after a material changed.
    pub fn refresh_materials(&mut self, scene: &Scene) {
        self.materials = material_records(scene);
    }

    /// The instance table to upload this frame.
    pub fn instance_table(&self) -> &[InstanceData] {
        &self.instances
    }

    /// Rebuilds the instance table and the draws after instances moved, came or went.
    pub fn refresh_instances(&mut self, scene: &Scene) {
        (self.instances, self.draws) = instance_layout(scene);
    }
}
