//! GLSL → SPIR-V with shaderc at start-up. Sources are embedded in the binary by the crate that
//! owns them (hadou's `passes::SHADERS`, so an installed `hadou` needs no shader files) and handed
//! to the compiler; `HADOU_SHADER_DIR` points at a source tree to use instead, which is how hot
//! reload reads edited shaders. Compiled words are cached by source text.

use std::collections::HashMap;
use std::path::PathBuf;

use super::error::{GpuError, GpuResult};

/// Shader files by their path under the shader folder: `("raster.vert", source)`.
pub type Sources = &'static [(&'static str, &'static str)];

/// Compiles GLSL to SPIR-V; see the module docs.
pub struct ShaderCompiler {
    compiler: shaderc::Compiler,
    embedded: Sources,
    source_dir: Option<PathBuf>,
    cache: HashMap<(String, String), Vec<u32>>,
}

impl ShaderCompiler {
    /// A compiler reading `embedded` (and `#include`s from it) unless `HADOU_SHADER_DIR` is set.
    pub fn new(embedded: Sources) -> GpuResult<Self> {
        let compiler = shaderc::Compiler::new().map_err(|e| GpuError::Shader {
            name: "shaderc".into(),
            message: format!("cannot create the compiler: {e}"),
        })?;
        let source_dir = std::env::var_os("HADOU_SHADER_DIR").map(PathBuf::from);
        Ok(ShaderCompiler { compiler, embedded, source_dir, cache: HashMap::new() })
    }

    /// The source of `name` (e.g. "raster.vert"): from HADOU_SHADER_DIR when set, else embedded.
    pub fn source(&self, name: &str) -> GpuResult<String> {
        if let Some(dir) = &self.source_dir {
            let path = dir.join(name);
            return std::fs::read_to_string(&path).map_err(|e| GpuError::Shader {
                name: name.into(),
                message: format!("{}: {e}", path.display()),
            });
        }
        self.embedded
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, text)| text.to_string())
            .ok_or_else(|| GpuError::Shader { name: name.into(), message: "no such shader".into() })
    }

    /// Compiles a shader by name, with `#define`s, to SPIR-V words for Vulkan 1.3.
    pub fn compile(&mut self, name: &str, defines: &[(&str, &str)]) -> GpuResult<Vec<u32>> {
        let source = self.source(name)?;
        self.compile_source(name, &source, defines)
    }

    /// Compiles GLSL `source` (not one of hadou's files: an effect's own shader) named `name`,
    /// whose extension gives the stage (.comp, .vert, .frag). `#include "common/…"` reaches
    /// hadou's shared GLSL.
    pub fn compile_source(
        &mut self,
        name: &str,
        source: &str,
        defines: &[(&str, &str)],
    ) -> GpuResult<Vec<u32>> {
        let key_defines: String = defines.iter().map(|(k, v)| format!("{k}={v};")).collect();
        let key = (format!("{name}|{key_defines}"), source.to_string());
        if let Some(words) = self.cache.get(&key) {
            return Ok(words.clone());
        }
        let kind = shader_kind(name)?;
        let mut options = shaderc::CompileOptions::new().map_err(|e| GpuError::Shader {
            name: name.into(),
            message: format!("cannot create compile options: {e}"),
        })?;
        options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_3 as u32);
        options.set_target_spirv(shaderc::SpirvVersion::V1_6);
        options.set_optimization_level(shaderc::OptimizationLevel::Performance);
        options.set_generate_debug_info();
        for (k, v) in defines {
            options.add_macro_definition(k, Some(v));
        }
        let (dir, embedded) = (self.source_dir.clone(), self.embedded);
        options.set_include_callback(move |requested, _, _, _| include(dir.as_ref(), embedded, requested));
        let artifact = self
            .compiler
            .compile_into_spirv(source, kind, name, "main", Some(&options))
            .map_err(|e| GpuError::Shader { name: name.into(), message: e.to_string() })?;
        if artifact.get_num_warnings() > 0 {
            log::warn!("shader {name}: {}", artifact.get_warning_messages());
        }
        let words = artifact.as_binary().to_vec();
        self.cache.insert(key, words.clone());
        Ok(words)
    }
}

fn shader_kind(name: &str) -> GpuResult<shaderc::ShaderKind> {
    match name.rsplit('.').next() {
        Some("vert") => Ok(shaderc::ShaderKind::Vertex),
        Some("frag") => Ok(shaderc::ShaderKind::Fragment),
        Some("comp") => Ok(shaderc::ShaderKind::Compute),
        _ => Err(GpuError::Shader {
            name: name.into(),
            message: "unknown stage (expected .vert, .frag or .comp)".into(),
        }),
    }
}

fn include(
    dir: Option<&PathBuf>,
    embedded: Sources,
    requested: &str,
) -> Result<shaderc::ResolvedInclude, String> {
    let content = match dir {
        Some(dir) => std::fs::read_to_string(dir.join(requested)).map_err(|e| format!("{requested}: {e}"))?,
        None => embedded
            .iter()
            .find(|(n, _)| *n == requested)
            .map(|(_, t)| t.to_string())
            .ok_or_else(|| format!("no shader include named {requested}"))?,
    };
    Ok(shaderc::ResolvedInclude { resolved_name: requested.to_string(), content })
}
