//! The textures of a scene's materials on the GPU: each image once (RGBA8 sRGB with the mip
//! chain the scene holds, `scene::texture`), one sampler per distinct glTF sampler, and one
//! descriptor set per textured material (binding 0 the base-colour texture, 1 the emissive one),
//! written once when the scene is loaded and bound by the raster between the draws of its
//! instances (`passes::raster`). There is no fixed-size table to overflow: the pool holds exactly
//! one set per textured material.
//!
//! The images are copied from a host-visible staging buffer by the first frame recorded after the
//! scene was loaded (`record_uploads`), before its passes, so loading waits on nothing; the
//! staging buffer is dropped then and retired with that frame.

use std::collections::HashMap;
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use crate::gpu::memory::{Buffer, Image, Memory, MemoryLocation};
use crate::gpu::pipeline::{write_set, Bound, DescriptorPool};
use crate::gpu::recorder::Recorder;
use crate::gpu::sampler::Sampler;
use crate::gpu::set_layout::SetLayout;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene::texture::{Filter, SamplerDesc, TextureImage, TextureRef, Wrap};
use crate::scene::{Material, Scene};

/// The raster's push constants for a textured material (shaders/raster.frag, MATERIAL_TEXTURES):
/// each texture's 2×3 coordinate map as its two rows (u' and v': xyz; w unused) and, in `flags`,
/// whether the base-colour (x) and emissive (y) textures are present and which coordinate set
/// each reads (z, w).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TexturePush {
    pub base_u: [f32; 4],
    pub base_v: [f32; 4],
    pub emissive_u: [f32; 4],
    pub emissive_v: [f32; 4],
    pub flags: [u32; 4],
}

crate::gpu::layout::gpu_layout!(TexturePush as "TexturePush" { base_u, base_v, emissive_u, emissive_v, flags });

/// The layout of a material's texture set (set 1 of the raster's textured pipeline).
pub fn texture_set_layout(ctx: &GpuContext) -> GpuResult<SetLayout> {
    SetLayout::samplers(ctx, "material textures set layout", 2, vk::ShaderStageFlags::FRAGMENT)
}

/// Copies not yet recorded: the staging buffer and, per image, its levels' offsets and sizes.
struct Pending {
    staging: Buffer,
    copies: Vec<(vk::Image, Vec<(u64, vk::Extent2D)>)>,
}

/// What the sets refer to, kept alive with them (retired when the scene is).
struct Owned {
    _images: Vec<Image>,
    _samplers: Vec<Sampler>,
    _layout: SetLayout,
    _pool: DescriptorPool,
}

#[derive(Default)]
pub struct SceneTextures {
    /// The scene's, then those of each glTF file spawned into the world (`append`).
    owned: Vec<Owned>,
    /// Per material: its set in `sets` (None: untextured).
    by_material: Vec<Option<usize>>,
    sets: Vec<(vk::DescriptorSet, TexturePush)>,
    pending: Vec<Pending>,
}

fn sampler_info(d: &SamplerDesc) -> vk::SamplerCreateInfo<'static> {
    let filter = |f: Filter| match f {
        Filter::Nearest => vk::Filter::NEAREST,
        Filter::Linear => vk::Filter::LINEAR,
    };
    let wrap = |w: Wrap| match w {
        Wrap::Repeat => vk::SamplerAddressMode::REPEAT,
        Wrap::MirroredRepeat => vk::SamplerAddressMode::MIRRORED_REPEAT,
        Wrap::ClampToEdge => vk::SamplerAddressMode::CLAMP_TO_EDGE,
    };
    let mipmap = match d.mipmap {
        Some(Filter::Linear) => vk::SamplerMipmapMode::LINEAR,
        _ => vk::SamplerMipmapMode::NEAREST,
    };
    // Without mipmapping only level 0 is read; max_lod 0.25 (not 0) keeps the choice between the
    // min and mag filters, which is made on the unclamped lod (OpenGL's convention for
    // GL_NEAREST / GL_LINEAR minification).
    let max_lod = if d.mipmap.is_some() { vk::LOD_CLAMP_NONE } else { 0.25 };
    vk::SamplerCreateInfo::default()
        .mag_filter(filter(d.mag))
        .min_filter(filter(d.min))
        .mipmap_mode(mipmap)
        .address_mode_u(wrap(d.wrap_s))
        .address_mode_v(wrap(d.wrap_t))
        .address_mode_w(vk::SamplerAddressMode::REPEAT)
        .min_lod(0.0)
        .max_lod(max_lod)
}

fn rows(t: &TextureRef) -> [[f32; 4]; 2] {
    t.transform.map(|r| [r[0] as f32, r[1] as f32, r[2] as f32, 0.0])
}

impl SceneTextures {
    /// Every textured material's images, samplers and set; nothing at all for a scene without
    /// textures.
    pub fn new(ctx: &GpuContext, memory: &Memory, scene: &Scene) -> GpuResult<Self> {
        Self::of_materials(ctx, memory, &scene.materials)
    }

    /// As `new`, for a list of materials (those a glTF file adds at run time).
    pub fn of_materials(ctx: &GpuContext, memory: &Memory, materials: &[Material]) -> GpuResult<Self> {
        let textured: Vec<usize> =
            (0..materials.len()).filter(|&m| !materials[m].surface.textures.is_empty()).collect();
        if textured.is_empty() {
            return Ok(SceneTextures::default());
        }
        // Each image once, in first-use order.
        let mut image_index: HashMap<*const TextureImage, usize> = HashMap::new();
        let mut unique: Vec<Arc<TextureImage>> = Vec::new();
        let mut sampler_index: HashMap<SamplerDesc, usize> = HashMap::new();
        let mut samplers = Vec::new();
        for &m in &textured {
            let t = &materials[m].surface.textures;
            for r in [&t.base, &t.emissive].into_iter().flatten() {
                image_index.entry(Arc::as_ptr(&r.image)).or_insert_with(|| {
                    unique.push(r.image.clone());
                    unique.len() - 1
                });
                if let std::collections::hash_map::Entry::Vacant(e) = sampler_index.entry(r.sampler) {
                    let name = format!("texture sampler {}", samplers.len());
                    samplers.push(Sampler::new(ctx, &name, &sampler_info(&r.sampler))?);
                    e.insert(samplers.len() - 1);
                }
            }
        }
        let total: usize = unique.iter().flat_map(|i| i.levels.iter().map(Vec::len)).sum();
        let mut staging = memory.create_buffer(
            ctx,
            "texture staging",
            total as u64,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        let mut images = Vec::with_capacity(unique.len());
        let mut copies = Vec::with_capacity(unique.len());
        let mut offset = 0usize;
        for t in &unique {
            let extent = vk::Extent2D { width: t.width, height: t.height };
            let usage = vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::SAMPLED;
            let levels = t.levels.len() as u32;
            let image =
                memory.create_image_levels(ctx, &t.name, extent, vk::Format::R8G8B8A8_SRGB, usage, levels)?;
            let mut regions = Vec::with_capacity(t.levels.len());
            for (l, bytes) in t.levels.iter().enumerate() {
                staging.write(offset, bytes)?;
                let (w, h) = t.level_size(l);
                regions.push((offset as u64, vk::Extent2D { width: w, height: h }));
                offset += bytes.len();
            }
            copies.push((image.raw, regions));
            images.push(image);
        }
        let layout = texture_set_layout(ctx)?;
        let pool = DescriptorPool::new(ctx, "material textures", textured.len() as u32)?;
        let mut by_material = vec![None; materials.len()];
        let mut sets = Vec::with_capacity(textured.len());
        for &m in &textured {
            let material = &materials[m];
            let t = &material.surface.textures;
            let bound = |r: &TextureRef| {
                Bound::Sampled(
                    images[image_index[&Arc::as_ptr(&r.image)]].view,
                    samplers[sampler_index[&r.sampler]].raw,
                )
            };
            // A material with one texture binds it at both bindings (the other is not read).
            let first = t.base.as_ref().or(t.emissive.as_ref()).expect("textured");
            let base = bound(t.base.as_ref().unwrap_or(first));
            let emissive = bound(t.emissive.as_ref().unwrap_or(first));
            let set = pool.allocate(ctx, layout.raw, &format!("textures of {}", material.name))?;
            write_set(ctx, set, &[(0, base), (1, emissive)]);
            let [base_u, base_v] = t.base.as_ref().map_or([[0.0; 4]; 2], rows);
            let [emissive_u, emissive_v] = t.emissive.as_ref().map_or([[0.0; 4]; 2], rows);
            let push = TexturePush {
                base_u,
                base_v,
                emissive_u,
                emissive_v,
                flags: [
                    t.base.is_some() as u32,
                    t.emissive.is_some() as u32,
                    t.base.as_ref().map_or(0, |r| r.texcoord),
                    t.emissive.as_ref().map_or(0, |r| r.texcoord),
                ],
            };
            by_material[m] = Some(sets.len());
            sets.push((set, push));
        }
        Ok(SceneTextures {
            owned: vec![Owned { _images: images, _samplers: samplers, _layout: layout, _pool: pool }],
            by_material,
            sets,
            pending: vec![Pending { staging, copies }],
        })
    }

    /// Adds the textures of materials added to the world at run time (`Renderer::spawn_gltf`):
    /// `more` was made for them alone, their first at material index `first_material`. Its
    /// images are copied by the next frame, like a loaded scene's.
    pub fn append(&mut self, more: SceneTextures, first_material: usize) {
        let base = self.sets.len();
        self.by_material.resize(first_material, None);
        self.by_material.extend(more.by_material.into_iter().map(|s| s.map(|i| i + base)));
        self.sets.extend(more.sets);
        self.owned.extend(more.owned);
        self.pending.extend(more.pending);
    }

    /// Records the images' copies into the frame being recorded, once (the first frame after the
    /// scene was loaded); the staging buffer is retired with that frame.
    pub fn record_uploads(&mut self, rec: &Recorder) {
        for p in std::mem::take(&mut self.pending) {
            for (image, levels) in &p.copies {
                rec.upload_texture(&p.staging, *image, levels);
            }
        }
    }

    /// The texture set of material `material` (an index of the material table), None when it has
    /// no textures (or was added after the scene was loaded).
    pub fn set_of(&self, material: u32) -> Option<usize> {
        self.by_material.get(material as usize).copied().flatten()
    }

    /// Set `i` and its push constants.
    pub fn set(&self, i: usize) -> (vk::DescriptorSet, &TexturePush) {
        let (set, push) = &self.sets[i];
        (*set, push)
    }

    /// Whether any material has textures.
    pub fn is_empty(&self) -> bool {
        self.owned.is_empty()
    }
}
