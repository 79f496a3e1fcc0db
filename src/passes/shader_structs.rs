//! Every struct shared with GLSL against every shader that uses it, member by member (name,
//! offset, GLSL type; `gpu::layout`): the one check that keeps the Rust and GLSL declarations one
//! source of truth. Structs read from texel buffers (`LutRecord`, `TranslucentInstance`,
//! `GpuMetaGroup`, `GpuMetaBall`) have no offsets in SPIR-V; their packing is checked by the
//! texel-buffer round trips.

use crate::effects::energy_wave_f32::GpuWave;
use crate::gpu::layout::{GpuLayout, Layout};
use crate::gpu::reflect::structs;
use crate::gpu::shader::ShaderCompiler;
use crate::passes::energy_wave::{EnergyWaveParams, WaveStyle};
use crate::passes::gpu_structs::{FrameUniforms, GpuLight, InstanceData, MaterialData};
use crate::passes::metaballs::MetaballParams;
use crate::passes::translucency::{LightViewData, TranslucencyParams};

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
        ("composite.frag", vec![], vec![super::composite::Params::layout()]),
        ("depth_out.frag", vec![], [frame(), vec![super::depth_out::Params::layout()]].concat()),
        ("depth_import.comp", vec![], [frame(), vec![super::depth_import::Params::layout()]].concat()),
        ("raster.vert", vec![], [frame(), vec![InstanceData::layout(), MaterialData::layout()]].concat()),
        ("raster.frag", vec![], frame()),
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
    for defines in
        [vec![("WITH_LUT", "1")], vec![("WITH_PEEL", "1")], vec![("WITH_LUT", "1"), ("WITH_PEEL", "1")]]
    {
        rows.push(("translucency.comp", defines, translucency()));
    }
    rows
}

#[test]
fn every_shared_struct_matches_its_glsl_twin_member_by_member() {
    let mut compiler = ShaderCompiler::new().unwrap();
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
        let compiler = shaderc::Compiler::new().unwrap();
        let mut options = shaderc::CompileOptions::new().unwrap();
        options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_3 as u32);
        options.set_generate_debug_info();
        let words = compiler
            .compile_into_spirv(&source, shaderc::ShaderKind::Compute, "t.comp", "main", Some(&options))
            .unwrap();
        structs("t.comp", words.as_binary()).unwrap()
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
