//! Every struct shared with GLSL against every shader that uses it, member by member (name,
//! offset, GLSL type; `gpu::layout`): the one check that keeps the Rust and GLSL declarations one
//! source of truth. Structs read from texel buffers (`LutRecord`, `TranslucentInstance`,
//! `GpuMetaGroup`, `GpuMetaBall`) have no offsets in SPIR-V; their packing is checked by the
//! texel-buffer round trips.

use crate::effects::energy_wave_f32::GpuWave;
use crate::gpu::layout::{GpuLayout, Layout};
use crate::gpu::reflect::{reflect, structs, Interface};
use crate::gpu::shader::ShaderCompiler;
use crate::passes::energy_wave::{EnergyWaveParams, WaveStyle};
use crate::passes::gpu_structs::{FrameUniforms, GpuLight, InstanceData, MaterialData};
use crate::passes::metaballs::MetaballParams;
use crate::passes::metaballs_bin::{BinGroup, BinParams};
use crate::passes::translucency::{LightViewData, TranslucencyParams};
use std::mem::size_of;

/// A shader, its defines, and the Rust twins of the structs it shares.
type Row = (&'static str, Vec<(&'static str, &'static str)>, Vec<Layout>);

/// Every variant a pass compiles.
fn table() -> Vec<Row> {
    let frame = || vec![FrameUniforms::layout(), GpuLight::layout()];
    let translucency = || {
        [frame(), vec![MaterialData::layout(), TranslucencyParams::layout(), LightViewData::layout()]]
            .concat()
    };
    let mut rows = vec![
        (
            "energy_wave.comp",
            vec![],
            [frame(), vec![GpuWave::layout(), WaveStyle::layout(), EnergyWaveParams::layout()]].concat(),
        ),
        ("energy_probe.comp", vec![], vec![GpuWave::layout(), super::energy_probe::ProbeParams::layout()]),
        ("tonemap.comp", vec![], vec![super::tonemap::Params::layout()]),
        (
            "tonemap.comp",
            vec![("AUTO_EXPOSURE", "1")],
            vec![super::tonemap::Params::layout(), super::tonemap::Measured::layout()],
        ),
        ("exposure.comp", vec![], vec![super::tonemap::Params::layout(), super::tonemap::Measured::layout()]),
        ("composite.frag", vec![("MODE", "0")], vec![super::composite::Params::layout()]),
        (
            "composite.frag",
            vec![("MODE", "1"), ("AUTO_EXPOSURE", "1")],
            vec![super::composite::Params::layout(), super::tonemap::Measured::layout()],
        ),
        ("depth_out.frag", vec![], [frame(), vec![super::depth_out::Params::layout()]].concat()),
        ("depth_import.comp", vec![], [frame(), vec![super::depth_import::Params::layout()]].concat()),
        (
            "depth_import.comp",
            vec![("HADOU_DEPTH", "1")],
            [frame(), vec![super::depth_import::Params::layout()]].concat(),
        ),
        ("raster.vert", vec![], [frame(), vec![InstanceData::layout(), MaterialData::layout()]].concat()),
        ("raster.frag", vec![], frame()),
        (
            "raster.frag",
            vec![("VERTEX_ATTRIBUTES", "1"), ("MATERIAL_TEXTURES", "1")],
            [frame(), vec![crate::scene_textures::TexturePush::layout()]].concat(),
        ),
        ("light_id.vert", vec![], vec![InstanceData::layout(), LightViewData::layout()]),
        ("peel.vert", vec![], vec![InstanceData::layout(), LightViewData::layout()]),
        ("translucency.comp", vec![], translucency()),
        ("translucency.comp", vec![("FILL_ONLY", "1")], frame()),
    ];
    for (clip, trace) in [("1", "0"), ("0", "1"), ("1", "1")] {
        let uses = [frame(), vec![MaterialData::layout(), MetaballParams::layout()]].concat();
        let defines = vec![("MB_WITH_CLIP", clip), ("MB_WITH_TRACE", trace)];
        rows.push(("metaballs.comp", defines.clone(), uses.clone()));
        rows.push(("metaballs.comp", [defines, vec![("MB_STREAM_PASS", "1")]].concat(), uses));
    }
    // Each stage declares what it reads (bounds: the frame's camera; scan and fill: the groups).
    let bin =
        |g: bool| [vec![BinParams::layout()], if g { vec![BinGroup::layout()] } else { vec![] }].concat();
    rows.push(("metaballs_bin.comp", vec![("MB_BIN_STAGE", "0")], [frame(), bin(true)].concat()));
    for (stage, groups) in [("1", false), ("3", true), ("4", true), ("5", false)] {
        rows.push(("metaballs_bin.comp", vec![("MB_BIN_STAGE", stage)], bin(groups)));
    }
    let device = || vec![super::metaballs_device::DeviceBallParams::layout()];
    rows.push(("metaballs_device.comp", vec![], device()));
    rows.push(("metaballs_device.comp", vec![("MB_PREVIOUS", "1")], device()));
    let motion = || vec![super::motion::MotionUniforms::layout()];
    rows.push(("motion.comp", vec![], [frame(), motion(), vec![MaterialData::layout()]].concat()));
    // Every cast combination with motion vectors on (the pass compiles the one the scene needs).
    for (clip, trace) in [("1", "0"), ("0", "1"), ("1", "1")] {
        for stream in [vec![], vec![("MB_STREAM_PASS", "1")]] {
            let casts = vec![("MB_WITH_CLIP", clip), ("MB_WITH_TRACE", trace), ("MB_MOTION", "1")];
            let uses = [frame(), motion(), vec![MaterialData::layout(), MetaballParams::layout()]].concat();
            rows.push(("metaballs.comp", [casts, stream].concat(), uses));
        }
    }
    rows.push((
        "raster.vert",
        vec![("MOTION", "1")],
        [frame(), motion(), vec![InstanceData::layout(), MaterialData::layout()]].concat(),
    ));
    rows.push(("raster.frag", vec![("MOTION", "1")], frame()));
    rows.push((
        "energy_wave.comp",
        vec![("REACTIVE", "1")],
        [frame(), vec![GpuWave::layout(), WaveStyle::layout(), EnergyWaveParams::layout()]].concat(),
    ));
    for defines in
        [vec![("WITH_LUT", "1")], vec![("WITH_PEEL", "1")], vec![("WITH_LUT", "1"), ("WITH_PEEL", "1")]]
    {
        rows.push(("translucency.comp", defines, translucency()));
    }
    rows
}

#[test]
fn every_shared_struct_matches_its_glsl_twin_member_by_member() {
    let mut compiler = ShaderCompiler::new(super::SHADERS).unwrap();
    let mut failures = Vec::new();
    for (shader, defines, layouts) in table() {
        let words = compiler.compile(shader, &defines).unwrap();
        let reflected = structs(shader, &words).unwrap();
        for layout in &layouts {
            if let Err(e) = layout.check_in(&format!("{shader} {defines:?}"), &reflected) {
                failures.push(e);
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// What a size check could not see: two `vec4` members swapped in the GLSL (or a member renamed,
/// retyped or moved) is refused, naming the member.
#[test]
fn a_swapped_member_is_refused() {
    let compile = |body: &str| {
        let source = format!(
            "#version 460\nlayout(local_size_x = 1) in;\n{body}\n\
             layout(set = 0, binding = 0, std430) buffer B {{ Wave waves[]; }};\n\
             void main() {{ waves[0] = waves[1]; }}\n"
        );
        let words = ShaderCompiler::new(&[]).unwrap().compile_source("t.comp", &source, &[]).unwrap();
        structs("t.comp", &words).unwrap()
    };
    let wave = GpuWave::layout();
    let same = compile("struct Wave { vec4 dir; vec4 rperp; vec4 strength; uvec4 flags; };");
    assert_eq!(wave.check_in("t.comp", &same), Ok(()));
    let swapped = compile("struct Wave { vec4 rperp; vec4 dir; vec4 strength; uvec4 flags; };");
    let err = wave.check_in("t.comp", &swapped).unwrap_err();
    assert!(err.contains("member 0") && err.contains("rperp") && err.contains("dir"), "{err}");
    let retyped = compile("struct Wave { vec4 dir; vec4 rperp; vec4 strength; vec4 flags; };");
    assert!(wave.check_in("t.comp", &retyped).unwrap_err().contains("uvec4 flags"));
    let longer = compile("struct Wave { vec4 dir; vec4 rperp; vec4 strength; uvec4 flags; vec4 extra; };");
    assert!(wave.check_in("t.comp", &longer).unwrap_err().contains("5 members"));
    assert!(wave.check_in("t.comp", &compile("struct Other { vec4 a; };\n#define Wave Other")).is_err());
}

/// A Rust field left out of `gpu_layout!` leaves a gap the check names.
#[test]
fn a_field_left_out_of_the_declaration_is_refused() {
    let mut layout = FrameUniforms::layout();
    assert_eq!(layout.check_complete(), Ok(()));
    layout.members.remove(2);
    assert!(layout.check_complete().unwrap_err().contains("bytes 80..96"));
}

fn interface(name: &str, defines: &[(&str, &str)]) -> Interface {
    let words = ShaderCompiler::new(super::SHADERS).unwrap().compile(name, defines).unwrap();
    reflect(name, &words).unwrap()
}

fn element(i: &Interface, binding: u32) -> u32 {
    i.bindings.iter().find(|b| b.binding == binding).map_or(0, |b| b.element_bytes)
}

/// Every Rust struct a pass binds has its GLSL twin's size, as the shader's SPIR-V lays it
/// out (std140/std430 offsets and strides included): the check `bind_set` makes each frame,
/// made here for every shader at once.
#[test]
fn rust_structs_have_their_shader_twins_sizes() {
    let size = |n: usize| n as u32;
    let ew = interface("energy_wave.comp", &[]);
    assert_eq!(element(&ew, 3), size(size_of::<GpuWave>()));
    assert_eq!(element(&ew, 4), size(size_of::<WaveStyle>()));
    assert_eq!(element(&ew, 5), size(size_of::<FrameUniforms>()));
    assert_eq!(ew.push_bytes, size(size_of::<EnergyWaveParams>()));
    let probe = interface("energy_probe.comp", &[]);
    assert_eq!(element(&probe, 0), size(size_of::<GpuWave>()));
    let raster = interface("raster.vert", &[]);
    assert_eq!(element(&raster, 0), size(size_of::<FrameUniforms>()));
    assert_eq!(element(&raster, 1), size(size_of::<InstanceData>()));
    assert_eq!(element(&raster, 2), size(size_of::<MaterialData>()));
    assert_eq!(element(&interface("light_id.vert", &[]), 0), size(size_of::<InstanceData>()));
    let mb = interface("metaballs.comp", &[("MB_WITH_CLIP", "1"), ("MB_WITH_TRACE", "1")]);
    assert_eq!(element(&mb, 4), size(size_of::<FrameUniforms>()));
    assert_eq!(element(&mb, 5), size(size_of::<MaterialData>()));
    assert_eq!(mb.push_bytes, size(size_of::<MetaballParams>()));
    let tr = interface("translucency.comp", &[]);
    assert_eq!(element(&tr, 0), size(size_of::<TranslucencyParams>()));
    assert_eq!(element(&tr, 10), size(size_of::<MaterialData>()));
    assert_eq!(element(&tr, 12), size(size_of::<FrameUniforms>()));
    assert_eq!(interface("tonemap.comp", &[]).push_bytes, 24);
    let auto = interface("tonemap.comp", &[("AUTO_EXPOSURE", "1")]);
    assert_eq!(auto.push_bytes, size(size_of::<super::tonemap::Params>()));
    assert_eq!(element(&auto, 3), size(size_of::<super::tonemap::Measured>()));
    let measure = interface("exposure.comp", &[]);
    assert_eq!(measure.push_bytes, size(size_of::<super::tonemap::Params>()));
    assert_eq!(element(&measure, 3), size(size_of::<super::tonemap::Measured>()));
}
