//! The scene on the GPU: one vertex and index buffer per mesh (shared by all its instances), built
//! once per loaded scene; the instance and material tables are kept on the host and uploaded each
//! frame through the frame slot's ring (transforms and materials change per frame).
//!
//! A mesh deformed at run time (`Renderer::set_mesh_positions`) gets one vertex buffer per frame
//! slot, written on the host when its slot begins a frame (that slot's previous frame has
//! finished: the frame contract) and only when it is older than the mesh: a frame in flight keeps
//! reading the vertices it was recorded with. The draws of a frame use its slot's buffer
//! (`GpuMesh::vertex_buffer`).

use crate::gpu::memory::MemoryLocation;
use crate::gpu::memory::{Buffer, Memory};
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::passes::gpu_structs::{instance_records, material_records, InstanceData, MaterialData};
use crate::scene::Scene;

pub struct GpuMesh {
    /// The vertices as loaded (position, normal: 24 bytes).
    pub vertices: Buffer,
    pub indices: Buffer,
    pub index_count: u32,
    /// The glTF vertex attributes (`attribute_records`), None for a mesh without them: the
    /// raster draws those with its plain pipeline.
    pub attributes: Option<Buffer>,
    /// The mesh's object-space bounds now (kept with its vertices: the frame's pre-exposure reads
    /// them instead of every vertex).
    pub bounds: (glam::DVec3, glam::DVec3),
    /// Once deformed: a vertex buffer per frame slot, made on the slot's first frame after that.
    deformed: Vec<Option<Buffer>>,
    /// Bit s: slot s's buffer is older than the mesh.
    stale: u32,
    /// The slot whose buffer this frame draws (None: `vertices`).
    in_use: Option<usize>,
    /// With motion vectors on, once deformed: the vertices (as `vertices` holds them) the frame
    /// recorded last drew, and those the previous frame drew (what this one's motion is from).
    drawn: Option<Vec<u8>>,
    previous: Option<Vec<u8>>,
}

impl GpuMesh {
    /// With motion vectors on, a deformed mesh's vertices in the previous frame (None: the mesh
    /// never deformed, its vertices are `vertices`).
    pub fn previous_vertices(&self) -> Option<&[u8]> {
        self.previous.as_deref()
    }

    /// The buffers of `mesh` (named `name` in debug labels), written at once: host-visible, so
    /// a mesh spawned at run time waits for nothing.
    pub fn new(
        ctx: &GpuContext,
        memory: &Memory,
        name: &str,
        mesh: &crate::scene::mesh::Mesh,
    ) -> GpuResult<GpuMesh> {
        let vertices = interleaved(mesh);
        let vertex_usage = vk::BufferUsageFlags::VERTEX_BUFFER;
        let label = format!("mesh {name} vertices");
        let vertices = upload(ctx, memory, &label, vertex_usage, bytemuck::cast_slice(&vertices))?;
        let label = format!("mesh {name} indices");
        let index_bytes = bytemuck::cast_slice(&mesh.indices);
        let indices = upload(ctx, memory, &label, vk::BufferUsageFlags::INDEX_BUFFER, index_bytes)?;
        let index_count = mesh.indices.len() as u32;
        let attributes = match attribute_records(mesh) {
            Some(records) => {
                let label = format!("mesh {name} vertex attributes");
                Some(upload(ctx, memory, &label, vertex_usage, bytemuck::cast_slice(&records))?)
            }
            None => None,
        };
        let (deformed, stale, in_use) = (Vec::new(), 0, None);
        let bounds = mesh.bounds();
        let (drawn, previous) = (None, None);
        Ok(GpuMesh {
            vertices,
            indices,
            index_count,
            attributes,
            bounds,
            deformed,
            stale,
            in_use,
            drawn,
            previous,
        })
    }

    /// The vertex buffer the frame being recorded draws: the slot's own once the mesh deformed.
    pub fn vertex_buffer(&self) -> &Buffer {
        self.in_use.and_then(|s| self.deformed.get(s)?.as_ref()).unwrap_or(&self.vertices)
    }
}

/// The vertex buffer's contents: position and normal per vertex.
fn interleaved(mesh: &crate::scene::mesh::Mesh) -> Vec<[f32; 6]> {
    mesh.positions.iter().zip(&mesh.normals).map(|(p, n)| [p[0], p[1], p[2], n[0], n[1], n[2]]).collect()
}

/// The second vertex buffer of a mesh with glTF attributes: per vertex the colour (RGBA, white
/// where the mesh has none) and both texture coordinate sets (zero where absent), 32 bytes.
pub(crate) fn attribute_records(mesh: &crate::scene::mesh::Mesh) -> Option<Vec<[f32; 8]>> {
    let a = mesh.attributes.as_ref()?;
    let records = (0..mesh.positions.len())
        .map(|i| {
            let c = a.colors.get(i).copied().unwrap_or([1.0; 4]);
            let [u0, u1] = [0, 1].map(|k| a.texcoords[k].get(i).copied().unwrap_or([0.0; 2]));
            [c[0], c[1], c[2], c[3], u0[0], u0[1], u1[0], u1[1]]
        })
        .collect();
    Some(records)
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
    /// The material table as the passes read it, and the pre-exposure its emission was built for.
    materials: Vec<MaterialData>,
    materials_pre_exposure: f64,
    /// The instance table as the raster reads it (grouped by mesh), rebuilt when transforms change.
    instances: Vec<InstanceData>,
    /// The materials' textures (`scene_textures`), uploaded by the first frame.
    pub textures: crate::scene_textures::SceneTextures,
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
            meshes.push(GpuMesh::new(ctx, memory, &m.name, &m.mesh)?);
        }
        let materials_pre_exposure = crate::effects::tonemap::pre_exposure(scene);
        let materials = material_records(scene, materials_pre_exposure);
        let (instances, draws) = instance_layout(scene);
        let textures = crate::scene_textures::SceneTextures::new(ctx, memory, scene)?;
        Ok(SceneGpu { meshes, draws, materials, materials_pre_exposure, instances, textures })
    }

    /// The material table to upload this frame (at least one record: an empty table still binds).
    /// Frees the buffers of mesh `index`, which nothing draws any more (despawned): they retire
    /// with the frames that may still read them, and a one-triangle stand-in keeps the slot.
    pub fn retire_mesh(&mut self, ctx: &GpuContext, memory: &Memory, index: usize) -> GpuResult<()> {
        let stand_in = crate::scene::mesh::Mesh {
            positions: vec![[0.0; 3]],
            normals: vec![[0.0, 1.0, 0.0]],
            indices: vec![0, 0, 0],
            attributes: None,
        };
        if let Some(slot) = self.meshes.get_mut(index) {
            *slot = GpuMesh::new(ctx, memory, "despawned", &stand_in)?;
        }
        Ok(())
    }

    /// Each mesh's object-space bounds, in scene order (`tonemap::pre_exposure_with`).
    pub fn mesh_bounds(&self) -> Vec<(glam::DVec3, glam::DVec3)> {
        self.meshes.iter().map(|m| m.bounds).collect()
    }

    pub fn material_table(&self) -> &[MaterialData] {
        &self.materials
    }

    /// Rebuilds the material table when a material `changed` or the frame's pre-exposure is not
    /// the one its emission was built for (a light, the ambient, the background or the exposure
    /// changed).
    pub fn refresh_materials(&mut self, scene: &Scene, pre_exposure: f64, changed: bool) {
        if changed || self.materials_pre_exposure != pre_exposure {
            self.materials = material_records(scene, pre_exposure);
            self.materials_pre_exposure = pre_exposure;
        }
    }

    /// The instance table to upload this frame.
    pub fn instance_table(&self) -> &[InstanceData] {
        &self.instances
    }

    /// Whether mesh `mesh` was deformed since the scene was loaded.
    pub fn is_deformed(&self, mesh: usize) -> bool {
        self.meshes.get(mesh).is_some_and(|m| m.stale != 0 || !m.deformed.is_empty())
    }

    /// Mesh `mesh`'s vertices changed in the scene: every slot's copy is stale.
    pub fn mesh_deformed(&mut self, mesh: usize) {
        if let Some(m) = self.meshes.get_mut(mesh) {
            m.stale = u32::MAX;
        }
    }

    /// Before recording a frame in `slot` (whose previous frame has finished): the deformed meshes'
    /// buffers of that slot brought up to date and put in use; with `motion`, their vertices of
    /// the previous frame kept for it.
    pub fn begin_slot(
        &mut self,
        ctx: &GpuContext,
        memory: &Memory,
        scene: &Scene,
        slot: usize,
        motion: bool,
    ) -> GpuResult<()> {
        for (i, m) in self.meshes.iter_mut().enumerate() {
            if m.stale == 0 && m.deformed.is_empty() {
                continue; // never deformed
            }
            if motion {
                let now: Vec<u8> = bytemuck::cast_slice(&interleaved(&scene.meshes[i].mesh)).to_vec();
                // Before its first deformed frame the mesh drew its loaded vertices.
                let loaded = || m.vertices.mapped().map(<[u8]>::to_vec);
                let drawn = m.drawn.replace(now.clone()).or_else(loaded);
                m.previous = Some(drawn.filter(|d| d.len() == now.len()).unwrap_or(now));
            } else {
                (m.drawn, m.previous) = (None, None);
            }
            if m.deformed.len() <= slot {
                m.deformed.resize_with(slot + 1, || None);
            }
            let bit = 1u32 << slot;
            if m.stale & bit != 0 || m.deformed[slot].is_none() {
                let bytes = interleaved(&scene.meshes[i].mesh);
                let bytes: &[u8] = bytemuck::cast_slice(&bytes);
                let buffer = match &mut m.deformed[slot] {
                    Some(b) => b,
                    empty => {
                        let name = format!("mesh {} vertices, slot {slot}", scene.meshes[i].name);
                        let usage = vk::BufferUsageFlags::VERTEX_BUFFER;
                        let size = bytes.len() as u64;
                        empty.insert(memory.create_buffer(
                            ctx,
                            &name,
                            size,
                            usage,
                            MemoryLocation::CpuToGpu,
                        )?)
                    }
                };
                buffer.write(0, bytes)?;
                m.stale &= !bit;
            }
            m.in_use = Some(slot);
        }
        Ok(())
    }

    /// Rebuilds the instance table and the draws after instances moved, came or went.
    pub fn refresh_instances(&mut self, scene: &Scene) {
        (self.instances, self.draws) = instance_layout(scene);
    }
}

/// How the passes read the scene's vertex buffers: binding 0 of interleaved (position, normal)
/// f32 triples, 24 bytes a vertex; location 0 the position and, `with_normal`, location 1 the
/// normal.
pub(crate) fn vertex_input(
    with_normal: bool,
) -> ([crate::gpu::vk::VertexInputBindingDescription; 1], Vec<crate::gpu::vk::VertexInputAttributeDescription>)
{
    use crate::gpu::vk;
    let binding = [vk::VertexInputBindingDescription::default()
        .binding(0)
        .stride(24)
        .input_rate(vk::VertexInputRate::VERTEX)];
    let attribute = |location: u32, offset: u32| {
        vk::VertexInputAttributeDescription::default()
            .location(location)
            .format(vk::Format::R32G32B32_SFLOAT)
            .offset(offset)
    };
    let mut attributes = vec![attribute(0, 0)];
    if with_normal {
        attributes.push(attribute(1, 12));
    }
    (binding, attributes)
}

/// The raster's vertex input for meshes with glTF attributes: `vertex_input(true)` plus binding
/// 1 of `attribute_records` (32 bytes a vertex): location 2 the colour, location 3 both texture
/// coordinate sets.
pub(crate) fn attributed_vertex_input(
) -> ([crate::gpu::vk::VertexInputBindingDescription; 2], Vec<crate::gpu::vk::VertexInputAttributeDescription>)
{
    use crate::gpu::vk;
    let ([first], mut attributes) = vertex_input(true);
    let second = vk::VertexInputBindingDescription::default()
        .binding(1)
        .stride(32)
        .input_rate(vk::VertexInputRate::VERTEX);
    for (location, offset) in [(2, 0), (3, 16)] {
        attributes.push(
            vk::VertexInputAttributeDescription::default()
                .binding(1)
                .location(location)
                .format(vk::Format::R32G32B32A32_SFLOAT)
                .offset(offset),
        );
    }
    ([first, second], attributes)
}
