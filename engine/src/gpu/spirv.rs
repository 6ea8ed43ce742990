//! Minimal SPIR-V reflection: descriptor bindings (name, set, binding, kind) and the push-constant
//! size, so that pipelines bind resources by name and check them against the shader; and the layout of
//! every explicitly laid-out struct (member names, offsets, sizes, array and matrix strides), so that
//! tests check the host twins of shader structs against the compiled shader (`gpu::layout_check`).

use std::collections::HashMap;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DescriptorKind {
    StorageBuffer,
    UniformBuffer,
    StorageImage,
    CombinedImageSampler,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReflectedBinding {
    pub name: String,
    pub set: u32,
    pub binding: u32,
    pub kind: DescriptorKind,
}

#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Reflection {
    pub bindings: Vec<ReflectedBinding>,
    pub push_constant_size: u32,
    /// Compute shaders: the workgroup size (from `LocalSize`; 0 when given by spec constants/ids).
    pub local_size: [u32; 3],
    /// Every struct type with explicit member offsets (the structs inside buffer blocks and push
    /// constants, and the blocks themselves), in type-id order. Function-local copies of a struct carry
    /// no offsets and are not listed; structs the optimizer removed (unused) are not either.
    pub structs: Vec<StructLayout>,
}

/// The component type of a scalar, vector, matrix or array of those.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScalarKind {
    Float,
    SignedInt,
    UnsignedInt,
    Bool,
}

/// A scalar type: its kind and width in bytes (`float` = (Float, 4), `uint` = (UnsignedInt, 4)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Scalar {
    pub kind: ScalarKind,
    pub bytes: u32,
}

/// One member of a laid-out struct, as the compiled shader declares it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MemberLayout {
    /// `OpMemberName` (empty when the module carries no debug names).
    pub name: String,
    /// `Offset` decoration: bytes from the start of the struct.
    pub offset: u32,
    /// Bytes the member spans: scalar width × components for vectors, columns × `MatrixStride` for
    /// matrices, length × `ArrayStride` for arrays, the extent of a nested struct; 0 for a runtime array.
    pub size: u32,
    /// The component type; `None` for a struct (or arrays of structs).
    pub scalar: Option<Scalar>,
    /// `ArrayStride` when the member is an array (sized or runtime).
    pub array_stride: Option<u32>,
    /// `MatrixStride` when the member is a matrix or an array of matrices.
    pub matrix_stride: Option<u32>,
    /// `RowMajor` decoration (the host writes column-major matrices).
    pub row_major: bool,
    /// The member is a runtime (unsized) array.
    pub runtime_array: bool,
}

/// A struct type with explicit layout.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StructLayout {
    /// `OpName` of the type: the GLSL struct name, or the block name for a buffer/uniform/push block.
    pub name: String,
    pub members: Vec<MemberLayout>,
    /// max(offset + size) over the members: the bytes a host struct must cover (without any
    /// trailing padding std430 adds when the struct is an array element: see `array_stride`).
    pub extent: u32,
    /// `ArrayStride` of an array of this struct somewhere in the module (its size as an array element).
    pub array_stride: Option<u32>,
    /// The descriptor binding whose block this struct is (its name as in [`ReflectedBinding::name`]).
    pub binding: Option<String>,
    /// This struct is the push-constant block.
    pub push_constants: bool,
}

impl Reflection {
    /// The laid-out struct type named `name`. glslang emits one type per layout in which a struct is
    /// used, so the same name may appear more than once: that is accepted when all of them agree.
    pub fn struct_named(&self, name: &str) -> Result<&StructLayout, String> {
        let found: Vec<&StructLayout> = self.structs.iter().filter(|s| s.name == name).collect();
        match found.as_slice() {
            [] => Err(format!("no laid-out struct named '{name}' (present: {})", self.struct_names())),
            [first, rest @ ..] => match rest.iter().find(|s| s.members != first.members) {
                Some(_) => Err(format!("struct '{name}' appears with different layouts (std140 and std430?)")),
                None => Ok(first),
            },
        }
    }

    /// The block struct of the descriptor binding named `binding` (the name pipelines bind by).
    pub fn block_bound_as(&self, binding: &str) -> Result<&StructLayout, String> {
        self.structs.iter().find(|s| s.binding.as_deref() == Some(binding)).ok_or_else(|| {
            let names: Vec<&str> = self.structs.iter().filter_map(|s| s.binding.as_deref()).collect();
            format!("no buffer block bound as '{binding}' (blocks: {})", names.join(", "))
        })
    }

    /// The push-constant block, if the shader has one.
    pub fn push_constant_block(&self) -> Option<&StructLayout> {
        self.structs.iter().find(|s| s.push_constants)
    }

    fn struct_names(&self) -> String {
        let mut names: Vec<&str> = self.structs.iter().map(|s| s.name.as_str()).collect();
        names.dedup();
        names.join(", ")
    }
}

#[derive(Clone, Debug)]
enum Ty {
    Scalar(Scalar),
    Vector(u32, u32),
    Matrix(u32, u32),
    Array(u32, u32),
    RuntimeArray(u32),
    Struct(Vec<u32>),
    Image {
        sampled: u32,
    },
    SampledImage,
    Sampler,
    /// Pointer to the pointee type id (the storage class is not needed).
    Pointer(u32),
    Other,
}

const OP_NAME: u32 = 5;
const OP_MEMBER_NAME: u32 = 6;
const OP_ENTRY_POINT: u32 = 15;
const OP_EXECUTION_MODE: u32 = 16;
/// SPIR-V 1.2+; glslang emits `OpExecutionModeId LocalSizeId` for SPIR-V 1.6 (Vulkan 1.3) targets.
const OP_EXECUTION_MODE_ID: u32 = 331;
const MODE_LOCAL_SIZE: u32 = 17;
const MODE_LOCAL_SIZE_ID: u32 = 38;
const OP_TYPE_BOOL: u32 = 20;
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

const DEC_BLOCK: u32 = 2;
const DEC_BUFFER_BLOCK: u32 = 3;
const DEC_ROW_MAJOR: u32 = 4;
const DEC_ARRAY_STRIDE: u32 = 6;
const DEC_MATRIX_STRIDE: u32 = 7;
const DEC_BINDING: u32 = 33;
const DEC_SET: u32 = 34;
const DEC_OFFSET: u32 = 35;

const SC_UNIFORM_CONSTANT: u32 = 0;
const SC_UNIFORM: u32 = 2;
const SC_PUSH_CONSTANT: u32 = 9;
const SC_STORAGE_BUFFER: u32 = 12;

fn literal_string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).take_while(|&b| b != 0).collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// The type tables of a parsed module, for sizes and component types.
struct Tables<'a> {
    types: &'a HashMap<u32, Ty>,
    constants: &'a HashMap<u32, u32>,
    decorations: &'a HashMap<(u32, u32), u32>,
    offsets: &'a HashMap<u32, Vec<(u32, u32)>>,
}

impl Tables<'_> {
    /// Bytes type `id` spans in an explicit layout. `matrix_stride` is the `MatrixStride` of the struct
    /// member being measured (it decorates the member, and applies through arrays of matrices); without
    /// one a matrix column is rounded up to 16 bytes (std140/std430 for 4-component columns).
    fn size(&self, id: u32, matrix_stride: Option<u32>) -> u32 {
        match self.types.get(&id) {
            Some(Ty::Scalar(s)) => s.bytes,
            Some(Ty::Vector(c, n)) => self.size(*c, None) * n,
            Some(Ty::Matrix(c, n)) => matrix_stride.unwrap_or_else(|| self.size(*c, None).next_multiple_of(16)) * n,
            Some(Ty::Array(e, len)) => {
                let n = self.constants.get(len).copied().unwrap_or(1);
                let stride = self
                    .decorations
                    .get(&(id, DEC_ARRAY_STRIDE))
                    .copied()
                    .unwrap_or_else(|| self.size(*e, matrix_stride));
                stride * n
            }
            Some(Ty::Struct(members)) => {
                let offs = self.offsets.get(&id).cloned().unwrap_or_default();
                offs.iter()
                    .map(|&(m, off)| off + members.get(m as usize).map_or(0, |&t| self.size(t, None)))
                    .max()
                    .unwrap_or(0)
            }
            _ => 0,
        }
    }

    /// The component type of a scalar, vector, matrix or array of those; `None` for structs.
    fn scalar(&self, id: u32) -> Option<Scalar> {
        match self.types.get(&id) {
            Some(Ty::Scalar(s)) => Some(*s),
            Some(Ty::Vector(c, _) | Ty::Matrix(c, _) | Ty::Array(c, _) | Ty::RuntimeArray(c)) => self.scalar(*c),
            _ => None,
        }
    }
}

/// Reflect a SPIR-V module. Errors on malformed input.
pub fn reflect(code: &[u32]) -> Result<Reflection, String> {
    if code.len() < 5 || code[0] != 0x0723_0203 {
        return Err("not a SPIR-V module (bad magic)".into());
    }
    let mut names: HashMap<u32, String> = HashMap::new();
    let mut types: HashMap<u32, Ty> = HashMap::new();
    let mut constants: HashMap<u32, u32> = HashMap::new();
    let mut decorations: HashMap<(u32, u32), u32> = HashMap::new();
    let mut member_offsets: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
    let mut member_names: HashMap<(u32, u32), String> = HashMap::new();
    let mut member_decorations: HashMap<(u32, u32, u32), u32> = HashMap::new();
    let mut variables: Vec<(u32, u32, u32)> = Vec::new(); // (type, id, storage class)
    let mut local_size = [0u32; 3];
    // LocalSizeId names constants that are defined later in the module.
    let mut local_size_ids: Option<[u32; 3]> = None;
    let mut i = 5;
    while i < code.len() {
        let count = (code[i] >> 16) as usize;
        let op = code[i] & 0xffff;
        if count == 0 || i + count > code.len() {
            return Err(format!("malformed instruction at word {i}"));
        }
        let w = &code[i + 1..i + count];
        match op {
            OP_NAME if !w.is_empty() => {
                names.insert(w[0], literal_string(&w[1..]));
            }
            OP_MEMBER_NAME if w.len() >= 2 => {
                member_names.insert((w[0], w[1]), literal_string(&w[2..]));
            }
            OP_EXECUTION_MODE if w.len() >= 5 && w[1] == MODE_LOCAL_SIZE => {
                local_size = [w[2], w[3], w[4]];
            }
            OP_EXECUTION_MODE_ID if w.len() >= 5 && w[1] == MODE_LOCAL_SIZE_ID => {
                local_size_ids = Some([w[2], w[3], w[4]]);
            }
            OP_ENTRY_POINT => {}
            OP_TYPE_BOOL if !w.is_empty() => {
                // Booleans have no defined size in memory (not allowed in blocks); 4 is glslang's uint.
                types.insert(w[0], Ty::Scalar(Scalar { kind: ScalarKind::Bool, bytes: 4 }));
            }
            OP_TYPE_INT if w.len() >= 3 => {
                let kind = if w[2] == 0 { ScalarKind::UnsignedInt } else { ScalarKind::SignedInt };
                types.insert(w[0], Ty::Scalar(Scalar { kind, bytes: w[1] / 8 }));
            }
            OP_TYPE_FLOAT if w.len() >= 2 => {
                types.insert(w[0], Ty::Scalar(Scalar { kind: ScalarKind::Float, bytes: w[1] / 8 }));
            }
            OP_TYPE_VECTOR if w.len() >= 3 => {
                types.insert(w[0], Ty::Vector(w[1], w[2]));
            }
            OP_TYPE_MATRIX if w.len() >= 3 => {
                types.insert(w[0], Ty::Matrix(w[1], w[2]));
            }
            OP_TYPE_IMAGE if w.len() >= 7 => {
                types.insert(w[0], Ty::Image { sampled: w[6] });
            }
            OP_TYPE_SAMPLER if !w.is_empty() => {
                types.insert(w[0], Ty::Sampler);
            }
            OP_TYPE_SAMPLED_IMAGE if !w.is_empty() => {
                types.insert(w[0], Ty::SampledImage);
            }
            OP_TYPE_ARRAY if w.len() >= 3 => {
                types.insert(w[0], Ty::Array(w[1], w[2]));
            }
            OP_TYPE_RUNTIME_ARRAY if w.len() >= 2 => {
                types.insert(w[0], Ty::RuntimeArray(w[1]));
            }
            OP_TYPE_STRUCT if !w.is_empty() => {
                types.insert(w[0], Ty::Struct(w[1..].to_vec()));
            }
            OP_TYPE_POINTER if w.len() >= 3 => {
                types.insert(w[0], Ty::Pointer(w[2]));
            }
            OP_CONSTANT if w.len() >= 3 => {
                constants.insert(w[1], w[2]);
            }
            OP_VARIABLE if w.len() >= 3 => variables.push((w[0], w[1], w[2])),
            OP_DECORATE if w.len() >= 2 => {
                decorations.insert((w[0], w[1]), w.get(2).copied().unwrap_or(0));
            }
            OP_MEMBER_DECORATE if w.len() >= 4 && w[2] == DEC_OFFSET => {
                member_offsets.entry(w[0]).or_default().push((w[1], w[3]));
            }
            OP_MEMBER_DECORATE if w.len() >= 3 => {
                member_decorations.insert((w[0], w[1], w[2]), w.get(3).copied().unwrap_or(0));
            }
            _ => {
                let _ = types.entry(u32::MAX).or_insert(Ty::Other);
            }
        }
        i += count;
    }

    if let Some(ids) = local_size_ids {
        for (k, id) in ids.iter().enumerate() {
            local_size[k] =
                *constants.get(id).ok_or_else(|| format!("LocalSizeId names {id}, which is not a constant"))?;
        }
    }

    let tables = Tables { types: &types, constants: &constants, decorations: &decorations, offsets: &member_offsets };
    let size_of = |root: u32| -> u32 { tables.size(root, None) };

    let mut out = Reflection { local_size, ..Default::default() };
    let mut struct_ids: Vec<u32> =
        member_offsets.keys().copied().filter(|id| matches!(types.get(id), Some(Ty::Struct(_)))).collect();
    struct_ids.sort_unstable();
    for &sid in &struct_ids {
        let Some(Ty::Struct(member_types)) = types.get(&sid) else { continue };
        let mut offs = member_offsets.get(&sid).cloned().unwrap_or_default();
        offs.sort_unstable();
        let members: Vec<MemberLayout> = offs
            .iter()
            .map(|&(m, offset)| {
                let t = member_types.get(m as usize).copied().unwrap_or(0);
                let matrix_stride = member_decorations.get(&(sid, m, DEC_MATRIX_STRIDE)).copied();
                let (array_stride, runtime_array) = match types.get(&t) {
                    Some(Ty::Array(..)) => (decorations.get(&(t, DEC_ARRAY_STRIDE)).copied(), false),
                    Some(Ty::RuntimeArray(_)) => (decorations.get(&(t, DEC_ARRAY_STRIDE)).copied(), true),
                    _ => (None, false),
                };
                MemberLayout {
                    name: member_names.get(&(sid, m)).cloned().unwrap_or_default(),
                    offset,
                    size: tables.size(t, matrix_stride),
                    scalar: tables.scalar(t),
                    array_stride,
                    matrix_stride,
                    row_major: member_decorations.contains_key(&(sid, m, DEC_ROW_MAJOR)),
                    runtime_array,
                }
            })
            .collect();
        let array_stride = types
            .iter()
            .filter(|(_, t)| matches!(t, Ty::Array(e, _) | Ty::RuntimeArray(e) if *e == sid))
            .find_map(|(id, _)| decorations.get(&(*id, DEC_ARRAY_STRIDE)).copied());
        out.structs.push(StructLayout {
            name: names.get(&sid).cloned().unwrap_or_default(),
            extent: tables.size(sid, None),
            members,
            array_stride,
            binding: None,
            push_constants: false,
        });
    }
    let struct_index = |id: u32| struct_ids.iter().position(|&s| s == id);
    for &(ptr_ty, id, sc) in &variables {
        let Some(Ty::Pointer(pointee)) = types.get(&ptr_ty) else { continue };
        let mut base = *pointee;
        while let Some(Ty::Array(e, _)) = types.get(&base) {
            base = *e;
        }
        if sc == SC_PUSH_CONSTANT {
            out.push_constant_size = size_of(base);
            if let Some(k) = struct_index(base) {
                out.structs[k].push_constants = true;
            }
            continue;
        }
        let kind = match (sc, types.get(&base)) {
            (SC_STORAGE_BUFFER, _) => DescriptorKind::StorageBuffer,
            (SC_UNIFORM, _) if decorations.contains_key(&(base, DEC_BUFFER_BLOCK)) => DescriptorKind::StorageBuffer,
            (SC_UNIFORM, _) if decorations.contains_key(&(base, DEC_BLOCK)) => DescriptorKind::UniformBuffer,
            (SC_UNIFORM_CONSTANT, Some(Ty::Image { sampled: 2 })) => DescriptorKind::StorageImage,
            (SC_UNIFORM_CONSTANT, Some(Ty::SampledImage)) => DescriptorKind::CombinedImageSampler,
            (SC_UNIFORM_CONSTANT, Some(Ty::Sampler | Ty::Image { .. })) => {
                return Err(format!(
                    "variable '{}': separate samplers/images are not supported; use combined image samplers",
                    names.get(&id).cloned().unwrap_or_default()
                ))
            }
            _ => continue,
        };
        let (Some(&set), Some(&binding)) = (decorations.get(&(id, DEC_SET)), decorations.get(&(id, DEC_BINDING)))
        else {
            continue;
        };
        let mut name = names.get(&id).cloned().unwrap_or_default();
        if name.is_empty() {
            name = names.get(&base).cloned().unwrap_or_default();
        }
        if let Some(k) = struct_index(base) {
            out.structs[k].binding = Some(name.clone());
        }
        out.bindings.push(ReflectedBinding { name, set, binding, kind });
    }
    out.bindings.sort_by_key(|b| (b.set, b.binding));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inst(op: u32, operands: &[u32]) -> Vec<u32> {
        let mut v = vec![((operands.len() as u32 + 1) << 16) | op];
        v.extend_from_slice(operands);
        v
    }

    // Member names, offsets, sizes and strides of a hand-assembled module: a block `Blk { S s[]; }`
    // of `struct S { vec3 a; float b; mat4 m; float c[4]; }` (std430), bound at set 0, binding 3.
    #[test]
    fn struct_layouts() {
        let name = |id: u32, s: &str| {
            let mut w = vec![id];
            let mut bytes = s.as_bytes().to_vec();
            bytes.resize((bytes.len() / 4 + 1) * 4, 0);
            w.extend(bytes.chunks(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])));
            w
        };
        let member_name = |id: u32, m: u32, s: &str| {
            let mut w = name(id, s);
            w.insert(1, m);
            w
        };
        let mut m = vec![0x0723_0203, 0x0001_0600, 0, 100, 0];
        m.extend(inst(OP_NAME, &name(9, "S")));
        m.extend(inst(OP_NAME, &name(11, "Blk")));
        for (k, n) in ["a", "b", "m", "c"].iter().enumerate() {
            m.extend(inst(OP_MEMBER_NAME, &member_name(9, k as u32, n)));
        }
        m.extend(inst(OP_MEMBER_NAME, &member_name(11, 0, "s")));
        for (k, off) in [0, 12, 16, 80].iter().enumerate() {
            m.extend(inst(OP_MEMBER_DECORATE, &[9, k as u32, DEC_OFFSET, *off]));
        }
        m.extend(inst(OP_MEMBER_DECORATE, &[9, 2, DEC_MATRIX_STRIDE, 16]));
        m.extend(inst(OP_MEMBER_DECORATE, &[11, 0, DEC_OFFSET, 0]));
        m.extend(inst(OP_DECORATE, &[8, DEC_ARRAY_STRIDE, 4]));
        m.extend(inst(OP_DECORATE, &[10, DEC_ARRAY_STRIDE, 96]));
        m.extend(inst(OP_DECORATE, &[11, DEC_BLOCK]));
        m.extend(inst(OP_DECORATE, &[13, DEC_SET, 0]));
        m.extend(inst(OP_DECORATE, &[13, DEC_BINDING, 3]));
        m.extend(inst(OP_TYPE_FLOAT, &[2, 32]));
        m.extend(inst(OP_TYPE_VECTOR, &[3, 2, 3]));
        m.extend(inst(OP_TYPE_VECTOR, &[4, 2, 4]));
        m.extend(inst(OP_TYPE_MATRIX, &[5, 4, 4]));
        m.extend(inst(OP_TYPE_INT, &[6, 32, 0]));
        m.extend(inst(OP_CONSTANT, &[6, 7, 4]));
        m.extend(inst(OP_TYPE_ARRAY, &[8, 2, 7]));
        m.extend(inst(OP_TYPE_STRUCT, &[9, 3, 2, 5, 8]));
        m.extend(inst(OP_TYPE_RUNTIME_ARRAY, &[10, 9]));
        m.extend(inst(OP_TYPE_STRUCT, &[11, 10]));
        m.extend(inst(OP_TYPE_POINTER, &[12, SC_STORAGE_BUFFER, 11]));
        m.extend(inst(OP_VARIABLE, &[12, 13, SC_STORAGE_BUFFER]));
        let r = reflect(&m).unwrap();
        let s = r.struct_named("S").unwrap();
        let got: Vec<(&str, u32, u32)> = s.members.iter().map(|m| (m.name.as_str(), m.offset, m.size)).collect();
        assert_eq!(got, [("a", 0, 12), ("b", 12, 4), ("m", 16, 64), ("c", 80, 16)]);
        assert_eq!((s.extent, s.array_stride), (96, Some(96)));
        assert_eq!(s.members[2].matrix_stride, Some(16));
        assert_eq!(s.members[3].array_stride, Some(4));
        let float = Scalar { kind: ScalarKind::Float, bytes: 4 };
        assert!(s.members.iter().all(|m| m.scalar == Some(float)));
        let blk = r.block_bound_as("Blk").unwrap();
        assert_eq!(blk.name, "Blk");
        assert!(
            blk.members[0].runtime_array && blk.members[0].array_stride == Some(96) && blk.members[0].scalar.is_none()
        );
        assert!(r.push_constant_block().is_none());
        assert_eq!(
            r.bindings,
            [ReflectedBinding { name: "Blk".into(), set: 0, binding: 3, kind: DescriptorKind::StorageBuffer }]
        );
    }

    // Both ways of declaring the workgroup size reach Reflection::local_size; a size of 0 would make
    // Recorder::dispatch launch one workgroup per invocation.
    #[test]
    fn local_size_and_local_size_id() {
        let header = [0x0723_0203, 0x0001_0600, 0, 100, 0];
        let mut literal = header.to_vec();
        literal.extend(inst(OP_EXECUTION_MODE, &[1, MODE_LOCAL_SIZE, 64, 2, 1]));
        assert_eq!(reflect(&literal).unwrap().local_size, [64, 2, 1]);
        let mut by_id = header.to_vec();
        by_id.extend(inst(OP_EXECUTION_MODE_ID, &[1, MODE_LOCAL_SIZE_ID, 10, 11, 12]));
        by_id.extend(inst(OP_TYPE_INT, &[9, 32, 0]));
        for (id, v) in [(10, 256), (11, 1), (12, 1)] {
            by_id.extend(inst(OP_CONSTANT, &[9, id, v]));
        }
        assert_eq!(reflect(&by_id).unwrap().local_size, [256, 1, 1]);
    }
}
