//! Host twins of shader structs checked against the compiled shader.
//!
//! A `#[repr(C)]` struct that the host writes into a buffer or push constants must match the GLSL
//! struct byte for byte. Hand-typed offset tests only restate what the Rust author believes; here the
//! real shader is compiled (the engine's shaderc path, same options as the pipelines) and reflected
//! ([`Reflection::structs`](super::Reflection)), and every field is compared with its GLSL member:
//! name, offset, size, component type, plus the struct's size (its `ArrayStride` when the shader has
//! an array of it). No Vulkan device is needed.
//!
//! One line per struct, with [`layout_check!`](crate::layout_check):
//! ```ignore
//! layout_check!(GpuMaterial, "shade/none/pixel.comp", struct "Material", [diffuse, specular, brdf, lobes, tangent])
//! layout_check!(ReferenceParams, "shade/reference/pixel.comp", push_constants, [sample_base, samples, ...])
//! layout_check!(GpuIsgParams, "shade/isg/pixel.comp", block "IsgParams", [...])
//! ```
//! The field list must name every field of the Rust struct (a pattern in the expansion fails to compile
//! otherwise) in declaration order, and each must be named as in GLSL; `field as "glsl_name"` maps a
//! field whose GLSL name cannot be its Rust name (a Rust keyword, say). The shader must use the struct:
//! the optimizer drops unused buffers, and then the struct is reported missing.

use super::spirv::{Scalar, ScalarKind, StructLayout};
use super::{ShaderCompiler, ShaderStage};

/// Which laid-out struct of the shader a host struct is checked against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// The struct type of this name (`struct Material { … }`).
    Struct(&'static str),
    /// The block of the descriptor binding of this name (the name `Binding::buffer` uses).
    Block(&'static str),
    /// The push-constant block.
    PushConstants,
}

/// One field of the host struct (built by [`layout_check!`](crate::layout_check)).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostField {
    pub rust: &'static str,
    /// The GLSL member name it must match (equal to `rust` unless mapped).
    pub glsl: &'static str,
    pub offset: usize,
    pub size: usize,
    /// Component type when the field is a scalar or an array of scalars.
    pub scalar: Option<Scalar>,
}

/// A host struct and the shader struct it twins (built by [`layout_check!`](crate::layout_check)).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostLayout {
    pub rust_type: &'static str,
    pub size: usize,
    /// Path relative to `shaders-glsl`; the stage follows from the extension.
    pub shader: &'static str,
    /// Preprocessor definitions for the compile (a struct that only exists in a shader variant).
    pub defines: &'static [(&'static str, &'static str)],
    pub target: Target,
    pub fields: Vec<HostField>,
}

/// The component type of a host field: implemented for the scalars the engine shares with GLSL and
/// for arrays of them (nested to any depth: `[[f32; 4]; 4]` for a `mat4`).
pub trait HostScalar {
    const SCALAR: Scalar;
}

impl HostScalar for f32 {
    const SCALAR: Scalar = Scalar { kind: ScalarKind::Float, bytes: 4 };
}
impl HostScalar for f64 {
    const SCALAR: Scalar = Scalar { kind: ScalarKind::Float, bytes: 8 };
}
impl HostScalar for u32 {
    const SCALAR: Scalar = Scalar { kind: ScalarKind::UnsignedInt, bytes: 4 };
}
impl HostScalar for i32 {
    const SCALAR: Scalar = Scalar { kind: ScalarKind::SignedInt, bytes: 4 };
}
impl<T: HostScalar, const N: usize> HostScalar for [T; N] {
    const SCALAR: Scalar = T::SCALAR;
}

/// `size_of` of a field, from an accessor (no value of the struct needed).
pub fn field_size<T, F>(_: fn(&T) -> &F) -> usize {
    std::mem::size_of::<F>()
}

/// The component type of a field, from an accessor.
pub fn field_scalar<T, F: HostScalar>(_: fn(&T) -> &F) -> Option<Scalar> {
    Some(F::SCALAR)
}

/// Stage from the file extension (`.comp`, `.vert`, `.frag`).
fn stage_of(shader: &str) -> Result<ShaderStage, String> {
    match shader.rsplit('.').next() {
        Some("comp") => Ok(ShaderStage::Compute),
        Some("vert") => Ok(ShaderStage::Vertex),
        Some("frag") => Ok(ShaderStage::Fragment),
        _ => Err(format!("{shader}: unknown shader stage (expected .comp, .vert or .frag)")),
    }
}

/// Every difference between `host` and the shader's `layout`, one line each (empty: they match).
pub fn compare(host: &HostLayout, layout: &StructLayout) -> Vec<String> {
    let mut problems = Vec::new();
    let ty = host.rust_type;
    if host.fields.len() != layout.members.len() {
        let glsl: Vec<&str> = layout.members.iter().map(|m| m.name.as_str()).collect();
        let rust: Vec<&str> = host.fields.iter().map(|f| f.rust).collect();
        problems.push(format!(
            "{ty}: {} fields [{}], GLSL '{}' has {} members [{}]",
            rust.len(),
            rust.join(", "),
            layout.name,
            glsl.len(),
            glsl.join(", ")
        ));
    }
    for (f, m) in host.fields.iter().zip(&layout.members) {
        let at = format!("{ty}.{} (GLSL {}.{})", f.rust, layout.name, m.name);
        if m.name.is_empty() {
            problems.push(format!("{at}: the shader carries no member names (compiled without debug info?)"));
        } else if f.glsl != m.name {
            problems.push(format!("{at}: name differs: expected GLSL member '{}'", f.glsl));
        }
        if f.offset != m.offset as usize {
            problems.push(format!("{at}: offset {} on the host, {} in the shader", f.offset, m.offset));
        }
        if m.runtime_array {
            problems.push(format!("{at}: a runtime array in GLSL has no host twin inside a struct"));
        } else if f.size != m.size as usize {
            problems.push(format!("{at}: {} bytes on the host, {} in the shader", f.size, m.size));
        }
        if m.row_major {
            problems.push(format!("{at}: row_major in the shader, the host writes column-major matrices"));
        }
        match (f.scalar, m.scalar) {
            (Some(h), Some(g)) if h != g => {
                problems.push(format!("{at}: component type {h:?} on the host, {g:?} in the shader"))
            }
            (Some(h), None) => problems.push(format!("{at}: {h:?} components on the host, a struct in the shader")),
            _ => {}
        }
    }
    // As an array element the struct is its ArrayStride apart (std430 rounds its size up to its
    // alignment); as a whole block or push constants it covers its extent.
    let (shader_size, what) = match layout.array_stride {
        Some(stride) => (stride, "array stride"),
        None => (layout.extent, "extent"),
    };
    if host.size != shader_size as usize {
        problems.push(format!("{ty}: size_of {} on the host, {what} {shader_size} in the shader", host.size));
    }
    problems
}

/// Compile `host.shader`, find its target struct and compare. `Err` lists every difference.
pub fn check(compiler: &ShaderCompiler, host: &HostLayout) -> Result<(), String> {
    let head = format!("{} vs {} ({:?})", host.rust_type, host.shader, host.target);
    let stage = stage_of(host.shader)?;
    let module = compiler.compile(host.shader, stage, host.defines).map_err(|e| format!("{head}: {e}"))?;
    let r = &module.reflection;
    let layout = match host.target {
        Target::Struct(name) => r.struct_named(name),
        Target::Block(name) => r.block_bound_as(name),
        Target::PushConstants => r.push_constant_block().ok_or_else(|| "no push-constant block".to_string()),
    }
    .map_err(|e| format!("{head}: {e}"))?;
    let problems = compare(host, layout);
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!("{head}:\n  {}", problems.join("\n  ")))
    }
}

/// [`check`] every layout; `Err` lists the failures of all of them (not only the first).
pub fn check_all(compiler: &ShaderCompiler, hosts: &[HostLayout]) -> Result<(), String> {
    let failures: Vec<String> = hosts.iter().filter_map(|h| check(compiler, h).err()).collect();
    if failures.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{} of {} host structs differ from their shaders:\n{}",
            failures.len(),
            hosts.len(),
            failures.join("\n")
        ))
    }
}

/// A [`HostLayout`] for the struct `$ty` against a struct of a shader; see the
/// [module documentation](crate::gpu::layout_check).
///
/// `layout_check!(Type, "dir/shader.comp", struct "GlslName" | block "BindingName" | push_constants,
/// [field, field as "glsl_name", …])`
#[macro_export]
macro_rules! layout_check {
    ($ty:path, $shader:literal, struct $name:literal, [$($fields:tt)*]) => {
        $crate::layout_check!(@make $ty, $shader, $crate::gpu::layout_check::Target::Struct($name), [$($fields)*])
    };
    ($ty:path, $shader:literal, block $name:literal, [$($fields:tt)*]) => {
        $crate::layout_check!(@make $ty, $shader, $crate::gpu::layout_check::Target::Block($name), [$($fields)*])
    };
    ($ty:path, $shader:literal, push_constants, [$($fields:tt)*]) => {
        $crate::layout_check!(@make $ty, $shader, $crate::gpu::layout_check::Target::PushConstants, [$($fields)*])
    };
    (@make $ty:path, $shader:literal, $target:expr, [$($field:ident $(as $glsl:literal)?),* $(,)?]) => {{
        // Names every field without `..`: a field added to the Rust struct but not to this list is a
        // compile error here, so the list cannot silently fall behind the struct.
        #[allow(dead_code, clippy::unneeded_field_pattern)]
        fn all_fields_listed(v: $ty) {
            let $ty { $($field: _),* } = v;
        }
        $crate::gpu::layout_check::HostLayout {
            rust_type: stringify!($ty),
            size: ::std::mem::size_of::<$ty>(),
            shader: $shader,
            defines: &[],
            target: $target,
            fields: vec![$(
                $crate::gpu::layout_check::HostField {
                    rust: stringify!($field),
                    glsl: $crate::layout_check!(@glsl $field $(as $glsl)?),
                    offset: ::std::mem::offset_of!($ty, $field),
                    size: $crate::gpu::layout_check::field_size(|v: &$ty| &v.$field),
                    scalar: $crate::gpu::layout_check::field_scalar(|v: &$ty| &v.$field),
                }
            ),*],
        }
    }};
    (@glsl $field:ident) => { stringify!($field) };
    (@glsl $field:ident as $glsl:literal) => { $glsl };
}
