//! GLSL → SPIR-V with shaderc: `#include` from `shaders-glsl`, warnings as errors, errors as
//! `file:line: message`, and a SPIR-V cache on disk keyed by the sources of the include closure.

use super::spirv::{reflect, Reflection};
use super::{GpuError, Result};
use std::collections::hash_map::DefaultHasher;
use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShaderStage {
    Compute,
    Vertex,
    Fragment,
}

impl ShaderStage {
    fn kind(self) -> shaderc::ShaderKind {
        match self {
            Self::Compute => shaderc::ShaderKind::Compute,
            Self::Vertex => shaderc::ShaderKind::Vertex,
            Self::Fragment => shaderc::ShaderKind::Fragment,
        }
    }
}

/// A compiled shader: SPIR-V words and their reflection.
#[derive(Clone, Debug)]
pub struct ShaderModuleInfo {
    pub path: String,
    pub spirv: Vec<u32>,
    pub reflection: Reflection,
}

pub struct ShaderCompiler {
    root: PathBuf,
    compiler: shaderc::Compiler,
    cache_dir: Option<PathBuf>,
    memory: Mutex<HashMap<u64, ShaderModuleInfo>>,
}

/// Bumped whenever compile options change, so stale cache entries are never used.
const CACHE_VERSION: u32 = 1;

impl ShaderCompiler {
    pub fn new(root: PathBuf) -> Result<Self> {
        let compiler = shaderc::Compiler::new()
            .map_err(|e| GpuError::Other(format!("could not start the shaderc compiler: {e}")))?;
        if !root.is_dir() {
            return Err(GpuError::Shader {
                path: root.display().to_string(),
                message: "shader folder not found (set ENGINE_SHADER_ROOT to the shaders-glsl folder)".into(),
            });
        }
        let cache_dir = std::env::var_os("ENGINE_SHADER_CACHE")
            .map(PathBuf::from)
            .or_else(|| Some(root.join("../target/shader-cache")))
            .filter(|d| std::fs::create_dir_all(d).is_ok());
        Ok(Self { root, compiler, cache_dir, memory: Mutex::new(HashMap::new()) })
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The source of `rel` and, recursively, of every file it `#include`s (textual scan), each once, in the order
    /// first met: `(path relative to the root, text)`.
    pub fn include_closure(&self, rel: &str) -> Result<Vec<(String, String)>> {
        let mut out = Vec::new();
        self.closure(rel, &mut out, &mut Vec::new())?;
        Ok(out)
    }

    fn closure(&self, rel: &str, out: &mut Vec<(String, String)>, seen: &mut Vec<PathBuf>) -> Result<()> {
        let path = self.root.join(rel);
        let canon = path.canonicalize().unwrap_or(path.clone());
        if seen.contains(&canon) {
            return Ok(());
        }
        seen.push(canon);
        let text = std::fs::read_to_string(&path)
            .map_err(|e| GpuError::Shader { path: path.display().to_string(), message: format!("cannot read: {e}") })?;
        let dir = Path::new(rel).parent().unwrap_or(Path::new(""));
        let includes: Vec<PathBuf> = text
            .lines()
            .filter_map(|line| line.trim_start().strip_prefix("#include"))
            .filter_map(|rest| rest.trim().strip_prefix('"').and_then(|r| r.split('"').next()))
            .map(|name| normalize(&dir.join(name)))
            .collect();
        out.push((rel.to_string(), text));
        for inc in includes {
            self.closure(&inc.to_string_lossy(), out, seen)?;
        }
        Ok(())
    }

    /// The paths (relative to the root) of the shaders compiled so far by this compiler, sorted.
    pub fn compiled(&self) -> Vec<String> {
        let mut paths: Vec<String> =
            self.memory.lock().map(|m| m.values().map(|i| i.path.clone()).collect()).unwrap_or_default();
        paths.sort();
        paths.dedup();
        paths
    }

    /// Compile `rel` (relative to the shader root) with `defines`.
    pub fn compile(&self, rel: &str, stage: ShaderStage, defines: &[(&str, &str)]) -> Result<ShaderModuleInfo> {
        let mut h = DefaultHasher::new();
        CACHE_VERSION.hash(&mut h);
        rel.hash(&mut h);
        stage.hash(&mut h);
        defines.hash(&mut h);
        for (_, text) in self.include_closure(rel)? {
            text.hash(&mut h);
        }
        let key = h.finish();
        if let Some(m) = self.memory.lock().ok().and_then(|m| m.get(&key).cloned()) {
            return Ok(m);
        }
        let cache_file = self.cache_dir.as_ref().map(|d| d.join(format!("{key:016x}.spv")));
        let cached = cache_file
            .as_ref()
            .and_then(|f| std::fs::read(f).ok())
            .filter(|b| b.len() % 4 == 0 && b.len() >= 20)
            .map(|b| bytemuck::pod_collect_to_vec::<u8, u32>(&b));
        let spirv = match cached {
            Some(words) => words,
            None => {
                let words = self.compile_uncached(rel, stage, defines)?;
                if let Some(f) = &cache_file {
                    let tmp = f.with_extension(format!("tmp{}", std::process::id()));
                    if std::fs::write(&tmp, bytemuck::cast_slice::<u32, u8>(&words)).is_ok() {
                        let _ = std::fs::rename(&tmp, f);
                    }
                }
                words
            }
        };
        let reflection = reflect(&spirv).map_err(|message| GpuError::Shader { path: rel.to_string(), message })?;
        let info = ShaderModuleInfo { path: rel.to_string(), spirv, reflection };
        if let Ok(mut m) = self.memory.lock() {
            m.insert(key, info.clone());
        }
        Ok(info)
    }

    fn compile_uncached(&self, rel: &str, stage: ShaderStage, defines: &[(&str, &str)]) -> Result<Vec<u32>> {
        let path = self.root.join(rel);
        let source = std::fs::read_to_string(&path)
            .map_err(|e| GpuError::Shader { path: path.display().to_string(), message: format!("cannot read: {e}") })?;
        let mut options =
            shaderc::CompileOptions::new().map_err(|e| GpuError::Other(format!("shaderc options: {e}")))?;
        options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_3 as u32);
        options.set_target_spirv(shaderc::SpirvVersion::V1_6);
        options.set_source_language(shaderc::SourceLanguage::GLSL);
        options.set_warnings_as_errors();
        options.set_generate_debug_info();
        options.set_optimization_level(shaderc::OptimizationLevel::Performance);
        for (k, v) in defines {
            options.add_macro_definition(k, Some(v));
        }
        let root = self.root.clone();
        options.set_include_callback(move |requested, _ty, requesting, depth| {
            if depth > 32 {
                return Err(format!("#include nesting deeper than 32 at {requested}"));
            }
            let base = Path::new(requesting).parent().unwrap_or(Path::new(""));
            let rel = normalize(&base.join(requested));
            let full = root.join(&rel);
            match std::fs::read_to_string(&full) {
                Ok(content) => {
                    Ok(shaderc::ResolvedInclude { resolved_name: rel.to_string_lossy().into_owned(), content })
                }
                Err(e) => Err(format!("cannot include \"{requested}\" ({}): {e}", full.display())),
            }
        });
        let artifact =
            self.compiler.compile_into_spirv(&source, stage.kind(), rel, "main", Some(&options)).map_err(|e| {
                GpuError::Shader {
                    path: rel.to_string(),
                    message: match e {
                        shaderc::Error::CompilationError(_, msg) => msg.trim_end().to_string(),
                        other => other.to_string(),
                    },
                }
            })?;
        Ok(artifact.as_binary().to_vec())
    }
}

/// Resolve `.` and `..` without touching the file system (include names are relative paths).
fn normalize(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            std::path::Component::ParentDir => {
                out.pop();
            }
            std::path::Component::CurDir => {}
            other => out.push(other.as_os_str()),
        }
    }
    out
}
