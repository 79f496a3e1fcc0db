//! What a shader binds, read from its SPIR-V: descriptor bindings of set 0 with their types, and
//! the size of its push-constant block. Pipelines take their layouts from here, so a layout cannot
//! drift from its shader, and the pass runner checks each frame's bindings against it.

use std::collections::HashMap;

use ash::vk;

use super::error::{GpuError, GpuResult};

/// One descriptor binding of set 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reflected {
    pub binding: u32,
    pub ty: vk::DescriptorType,
    /// Uniform and storage buffers: bytes of one element as the shader lays it out — the array
    /// stride of a block ending in a runtime array (`Wave waves[]`), else the block's size; 0 for
    /// other descriptors.
    pub element_bytes: u32,
}

/// A shader module's interface.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Interface {
    /// Sorted by binding.
    pub bindings: Vec<Reflected>,
    /// Bytes of the push-constant block (0 when there is none).
    pub push_bytes: u32,
    /// How many descriptor sets the module uses (highest set number + 1; 0 or 1 for set 0
    /// alone). Sets past 0 have layouts of the pipeline's own (`create_graphics_pipeline_with_sets`);
    /// their bindings are not listed in `bindings`.
    pub sets: u32,
}

const OP_NAME: u32 = 5;
const OP_MEMBER_NAME: u32 = 6;
const OP_TYPE_INT: u32 = 21;
const OP_TYPE_FLOAT: u32 = 22;
const OP_TYPE_VECTOR: u32 = 23;
const OP_TYPE_MATRIX: u32 = 24;
const OP_TYPE_IMAGE: u32 = 25;
const OP_TYPE_SAMPLER: u32 = 26;
const OP_TYPE_SAMPLED_IMAGE: u32 = 27;
const OP_TYPE_ARRAY: u32 = 28;
const OP_TYPE_RUNTIME_ARRAY: u32 = 29;
const OP_TYPE_STRUCT: u32 = 30;
const OP_TYPE_POINTER: u32 = 32;
const OP_CONSTANT: u32 = 43;
const OP_VARIABLE: u32 = 59;
const OP_DECORATE: u32 = 71;
const OP_MEMBER_DECORATE: u32 = 72;

const DECORATION_BUFFER_BLOCK: u32 = 3;
const DECORATION_ARRAY_STRIDE: u32 = 6;
const DECORATION_BINDING: u32 = 33;
const DECORATION_DESCRIPTOR_SET: u32 = 34;
const DECORATION_OFFSET: u32 = 35;

const CLASS_UNIFORM_CONSTANT: u32 = 0;
const CLASS_UNIFORM: u32 = 2;
const CLASS_PUSH_CONSTANT: u32 = 9;
const CLASS_STORAGE_BUFFER: u32 = 12;

const DIM_BUFFER: u32 = 5;

/// The types, decorations and variables of a module, by result id.
#[derive(Default)]
struct Module {
    types: HashMap<u32, (u32, Vec<u32>)>,
    constants: HashMap<u32, u32>,
    decorations: HashMap<(u32, u32), u32>,
    member_offsets: HashMap<(u32, u32), u32>,
    /// Debug names (OpName) and member names (OpMemberName): present because shaders are
    /// compiled with debug info (`gpu::shader`); read by the tests' struct check (`gpu::layout`).
    names: HashMap<u32, String>,
    member_names: HashMap<(u32, u32), String>,
    /// (result type, id, storage class).
    variables: Vec<(u32, u32, u32)>,
}

fn parse(name: &str, words: &[u32]) -> GpuResult<Module> {
    let bad = |why: &str| GpuError::Shader { name: name.into(), message: format!("SPIR-V: {why}") };
    if words.len() < 5 || words[0] != 0x0723_0203 {
        return Err(bad("not a SPIR-V module"));
    }
    let mut m = Module::default();
    let mut at = 5;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        let op = words[at] & 0xffff;
        if count == 0 || at + count > words.len() {
            return Err(bad("truncated instruction"));
        }
        let args = &words[at + 1..at + count];
        match op {
            OP_TYPE_INT..=OP_TYPE_POINTER if !args.is_empty() => {
                m.types.insert(args[0], (op, args[1..].to_vec()));
            }
            OP_CONSTANT if args.len() >= 3 => {
                m.constants.insert(args[1], args[2]);
            }
            OP_VARIABLE if args.len() >= 3 => m.variables.push((args[0], args[1], args[2])),
            OP_DECORATE if args.len() >= 2 => {
                m.decorations.insert((args[0], args[1]), args.get(2).copied().unwrap_or(0));
            }
            OP_NAME if args.len() >= 2 => {
                m.names.insert(args[0], literal_string(&args[1..]));
            }
            OP_MEMBER_NAME if args.len() >= 3 => {
                m.member_names.insert((args[0], args[1]), literal_string(&args[2..]));
            }
            OP_MEMBER_DECORATE if args.len() >= 4 && args[2] == DECORATION_OFFSET => {
                m.member_offsets.insert((args[0], args[1]), args[3]);
            }
            _ => {}
        }
        at += count;
    }
    Ok(m)
}

/// A SPIR-V literal string: UTF-8 bytes packed little-endian into words, NUL-terminated.
fn literal_string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).take_while(|&b| b != 0).collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

impl Module {
    fn ty(&self, id: u32) -> Option<&(u32, Vec<u32>)> {
        self.types.get(&id)
    }

    /// A type as GLSL spells it: `float`, `uvec4`, `mat4`, `Light[8]`, `vec4[]`, a struct's name.
    fn glsl_type(&self, id: u32) -> String {
        let Some((op, args)) = self.ty(id) else { return format!("?{id}") };
        let scalar_prefix = |id: u32| match self.ty(id) {
            Some((OP_TYPE_FLOAT, a)) if a[0] == 32 => "",
            Some((OP_TYPE_FLOAT, a)) if a[0] == 64 => "d",
            Some((OP_TYPE_INT, a)) if a[1] == 0 => "u",
            Some((OP_TYPE_INT, _)) => "i",
            _ => "?",
        };
        match *op {
            OP_TYPE_FLOAT if args[0] == 32 => "float".into(),
            OP_TYPE_FLOAT => "double".into(),
            OP_TYPE_INT if args[1] == 0 => "uint".into(),
            OP_TYPE_INT => "int".into(),
            OP_TYPE_VECTOR => format!("{}vec{}", scalar_prefix(args[0]), args[1]),
            OP_TYPE_MATRIX => {
                let (column, columns) = (args[0], args[1]);
                let (prefix, rows) = match self.ty(column) {
                    Some((OP_TYPE_VECTOR, c)) => (scalar_prefix(c[0]), c[1]),
                    _ => ("?", 0),
                };
                if rows == columns {
                    format!("{prefix}mat{columns}")
                } else {
                    format!("{prefix}mat{columns}x{rows}")
                }
            }
            OP_TYPE_ARRAY => {
                let length = self.constants.get(&args[1]).copied().unwrap_or(0);
                format!("{}[{length}]", self.glsl_type(args[0]))
            }
            OP_TYPE_RUNTIME_ARRAY => format!("{}[]", self.glsl_type(args[0])),
            OP_TYPE_STRUCT => self.names.get(&id).cloned().unwrap_or_else(|| format!("struct{id}")),
            _ => format!("?{id}"),
        }
    }

    /// The descriptor type of a variable of pointee type `id` in storage class `class`.
    fn descriptor_type(&self, id: u32, class: u32) -> Option<vk::DescriptorType> {
        let (op, args) = self.ty(id)?;
        match (*op, class) {
            (OP_TYPE_ARRAY, _) => self.descriptor_type(args[0], class),
            (OP_TYPE_STRUCT, CLASS_STORAGE_BUFFER) => Some(vk::DescriptorType::STORAGE_BUFFER),
            (OP_TYPE_STRUCT, CLASS_UNIFORM) => {
                if self.decorations.contains_key(&(id, DECORATION_BUFFER_BLOCK)) {
                    Some(vk::DescriptorType::STORAGE_BUFFER)
                } else {
                    Some(vk::DescriptorType::UNIFORM_BUFFER)
                }
            }
            (OP_TYPE_SAMPLER, CLASS_UNIFORM_CONSTANT) => Some(vk::DescriptorType::SAMPLER),
            (OP_TYPE_SAMPLED_IMAGE, CLASS_UNIFORM_CONSTANT) => {
                let (_, image) = self.ty(args[0])?;
                Some(if image[1] == DIM_BUFFER {
                    vk::DescriptorType::UNIFORM_TEXEL_BUFFER
                } else {
                    vk::DescriptorType::COMBINED_IMAGE_SAMPLER
                })
            }
            (OP_TYPE_IMAGE, CLASS_UNIFORM_CONSTANT) => {
                // args: sampled type, dim, depth, arrayed, ms, sampled (1 sampled, 2 storage), format
                let (dim, sampled) = (args[1], args[5]);
                Some(match (dim == DIM_BUFFER, sampled == 2) {
                    (true, true) => vk::DescriptorType::STORAGE_TEXEL_BUFFER,
                    (true, false) => vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
                    (false, true) => vk::DescriptorType::STORAGE_IMAGE,
                    (false, false) => vk::DescriptorType::SAMPLED_IMAGE,
                })
            }
            _ => None,
        }
    }

    /// A buffer block's element size (see `Reflected::element_bytes`).
    fn element_bytes(&self, block: u32) -> u32 {
        let Some((OP_TYPE_STRUCT, members)) = self.ty(block).map(|(op, a)| (*op, a)) else { return 0 };
        match members.last().and_then(|&m| self.ty(m).map(|(op, _)| (m, *op))) {
            Some((array, OP_TYPE_RUNTIME_ARRAY)) => {
                self.decorations.get(&(array, DECORATION_ARRAY_STRIDE)).copied().unwrap_or(0)
            }
            _ => self.size(block),
        }
    }

    /// Bytes of a type as laid out in a block (offsets and strides from its decorations).
    fn size(&self, id: u32) -> u32 {
        let Some((op, args)) = self.ty(id) else { return 0 };
        match *op {
            OP_TYPE_INT | OP_TYPE_FLOAT => args[0] / 8,
            OP_TYPE_VECTOR | OP_TYPE_MATRIX => args[1] * self.size(args[0]),
            OP_TYPE_ARRAY => {
                let length = self.constants.get(&args[1]).copied().unwrap_or(0);
                let stride = self.decorations.get(&(id, DECORATION_ARRAY_STRIDE)).copied();
                length * stride.unwrap_or_else(|| self.size(args[0]))
            }
            OP_TYPE_STRUCT => (0..args.len() as u32)
                .map(|i| {
                    self.member_offsets.get(&(id, i)).copied().unwrap_or(0) + self.size(args[i as usize])
                })
                .max()
                .unwrap_or(0),
            _ => 0,
        }
    }
}

/// The interface of one SPIR-V module.
pub fn reflect(name: &str, words: &[u32]) -> GpuResult<Interface> {
    let m = parse(name, words)?;
    let mut interface = Interface::default();
    for &(pointer, id, class) in &m.variables {
        let Some((OP_TYPE_POINTER, p)) = m.ty(pointer).map(|(op, a)| (*op, a)) else { continue };
        let pointee = p[1];
        if class == CLASS_PUSH_CONSTANT {
            interface.push_bytes = m.size(pointee);
            continue;
        }
        let Some(&binding) = m.decorations.get(&(id, DECORATION_BINDING)) else { continue };
        let set = m.decorations.get(&(id, DECORATION_DESCRIPTOR_SET)).copied().unwrap_or(0);
        interface.sets = interface.sets.max(set + 1);
        if set != 0 {
            continue;
        }
        let ty = m.descriptor_type(pointee, class).ok_or_else(|| GpuError::Shader {
            name: name.into(),
            message: format!("binding {binding}: a resource type hadou does not bind"),
        })?;
        let buffer = matches!(ty, vk::DescriptorType::UNIFORM_BUFFER | vk::DescriptorType::STORAGE_BUFFER);
        let element_bytes = if buffer { m.element_bytes(pointee) } else { 0 };
        interface.bindings.push(Reflected { binding, ty, element_bytes });
    }
    interface.bindings.sort_by_key(|b| b.binding);
    Ok(interface)
}

/// One member of a struct as a shader lays it out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReflectedMember {
    pub name: String,
    pub offset: u32,
    /// As GLSL spells it (`vec4`, `uvec4`, `mat4`, `Light[8]`).
    pub glsl: String,
}

/// A struct type of a module (a block's type or a struct inside one), with its debug name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReflectedStruct {
    pub name: String,
    pub members: Vec<ReflectedMember>,
}

/// Every named struct type of one SPIR-V module that has explicit member offsets (the structs
/// inside buffer blocks and push constants: what a Rust `#[repr(C)]` twin must match). A struct
/// used under two layouts (std140 and std430) appears once per layout, under the same name.
pub fn structs(name: &str, words: &[u32]) -> GpuResult<Vec<ReflectedStruct>> {
    let m = parse(name, words)?;
    let mut ids: Vec<u32> =
        m.types.iter().filter(|(_, (op, _))| *op == OP_TYPE_STRUCT).map(|(&id, _)| id).collect();
    ids.sort_unstable();
    let mut out = Vec::new();
    for id in ids {
        let (_, members) = &m.types[&id];
        if members.is_empty() || !m.member_offsets.contains_key(&(id, 0)) {
            continue;
        }
        let Some(struct_name) = m.names.get(&id) else { continue };
        let members = (0..members.len() as u32)
            .map(|i| ReflectedMember {
                name: m.member_names.get(&(id, i)).cloned().unwrap_or_default(),
                offset: m.member_offsets.get(&(id, i)).copied().unwrap_or(0),
                glsl: m.glsl_type(members[i as usize]),
            })
            .collect();
        out.push(ReflectedStruct { name: struct_name.clone(), members });
    }
    Ok(out)
}

/// The layout bindings of shaders used together (vertex + fragment), with the stages that see
/// each; an error when two stages declare one binding with different types.
pub fn merge(
    name: &str,
    stages: &[(vk::ShaderStageFlags, &Interface)],
) -> GpuResult<Vec<(Reflected, vk::ShaderStageFlags)>> {
    let mut merged: Vec<(Reflected, vk::ShaderStageFlags)> = Vec::new();
    for (stage, interface) in stages {
        for b in &interface.bindings {
            match merged.iter_mut().find(|(m, _)| m.binding == b.binding) {
                Some((m, _)) if m.ty != b.ty => {
                    return Err(GpuError::Shader {
                        name: name.into(),
                        message: format!(
                            "binding {} is {:?} in one stage, {:?} in another",
                            b.binding, m.ty, b.ty
                        ),
                    })
                }
                Some((_, stages)) => *stages |= *stage,
                None => merged.push((*b, *stage)),
            }
        }
    }
    merged.sort_by_key(|(b, _)| b.binding);
    Ok(merged)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn element(i: &Interface, binding: u32) -> u32 {
        i.bindings.iter().find(|b| b.binding == binding).map_or(0, |b| b.element_bytes)
    }

    /// The reflection sees a drifted layout: a vec3 + float member pair versus vec3 + vec4.
    #[test]
    fn a_drifted_struct_changes_the_reflected_size() {
        let compile = |body: &str| {
            let source = format!(
                "#version 460\nlayout(local_size_x = 1) in;\nstruct S {{ {body} }};\n\
                 layout(set = 0, binding = 0, std430) buffer B {{ S s[]; }};\n\
                 layout(push_constant) uniform P {{ uvec2 a; float b; }} p;\n\
                 void main() {{ s[0] = s[1]; s[0].x.x += p.b; }}\n"
            );
            let compiler = shaderc::Compiler::new().unwrap();
            let mut options = shaderc::CompileOptions::new().unwrap();
            options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_3 as u32);
            let words = compiler
                .compile_into_spirv(&source, shaderc::ShaderKind::Compute, "t.comp", "main", Some(&options))
                .unwrap();
            reflect("t.comp", words.as_binary()).unwrap()
        };
        let packed = compile("vec3 x; float w;");
        let padded = compile("vec3 x; vec4 w;");
        assert_eq!(element(&packed, 0), 16);
        assert_eq!(element(&padded, 0), 32);
        assert_eq!(packed.push_bytes, 12);
        assert_eq!(packed.bindings[0].ty, vk::DescriptorType::STORAGE_BUFFER);
    }
}
