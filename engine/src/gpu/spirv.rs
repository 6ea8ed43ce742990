//! Minimal SPIR-V reflection: descriptor bindings (name, set, binding, kind) and the push-constant
//! size, so that pipelines bind resources by name and check them against the shader.

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
}

#[derive(Clone, Debug)]
enum Ty {
    Scalar(u32),
    Vector(u32, u32),
    Matrix(u32, u32),
    Array(u32, u32),
    RuntimeArray,
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
const OP_ENTRY_POINT: u32 = 15;
const OP_EXECUTION_MODE: u32 = 16;
/// SPIR-V 1.2+; glslang emits `OpExecutionModeId LocalSizeId` for SPIR-V 1.6 (Vulkan 1.3) targets.
const OP_EXECUTION_MODE_ID: u32 = 331;
const MODE_LOCAL_SIZE: u32 = 17;
const MODE_LOCAL_SIZE_ID: u32 = 38;
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
            OP_EXECUTION_MODE if w.len() >= 5 && w[1] == MODE_LOCAL_SIZE => {
                local_size = [w[2], w[3], w[4]];
            }
            OP_EXECUTION_MODE_ID if w.len() >= 5 && w[1] == MODE_LOCAL_SIZE_ID => {
                local_size_ids = Some([w[2], w[3], w[4]]);
            }
            OP_ENTRY_POINT => {}
            OP_TYPE_INT | OP_TYPE_FLOAT if w.len() >= 2 => {
                types.insert(w[0], Ty::Scalar(w[1] / 8));
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
            OP_TYPE_RUNTIME_ARRAY if !w.is_empty() => {
                types.insert(w[0], Ty::RuntimeArray);
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
            OP_MEMBER_DECORATE if w.len() >= 4 && w[2] == DEC_MATRIX_STRIDE => {}
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

    let size_of = |root: u32| -> u32 {
        fn go(
            id: u32,
            types: &HashMap<u32, Ty>,
            constants: &HashMap<u32, u32>,
            decorations: &HashMap<(u32, u32), u32>,
            offsets: &HashMap<u32, Vec<(u32, u32)>>,
        ) -> u32 {
            match types.get(&id) {
                Some(Ty::Scalar(b)) => *b,
                Some(Ty::Vector(c, n)) => go(*c, types, constants, decorations, offsets) * n,
                Some(Ty::Matrix(c, n)) => go(*c, types, constants, decorations, offsets).next_multiple_of(16) * n,
                Some(Ty::Array(e, len)) => {
                    let n = constants.get(len).copied().unwrap_or(1);
                    let stride = decorations
                        .get(&(id, DEC_ARRAY_STRIDE))
                        .copied()
                        .unwrap_or_else(|| go(*e, types, constants, decorations, offsets));
                    stride * n
                }
                Some(Ty::Struct(members)) => {
                    let offs = offsets.get(&id).cloned().unwrap_or_default();
                    offs.iter()
                        .map(|&(m, off)| {
                            off + members.get(m as usize).map_or(0, |&t| go(t, types, constants, decorations, offsets))
                        })
                        .max()
                        .unwrap_or(0)
                }
                _ => 0,
            }
        }
        go(root, &types, &constants, &decorations, &member_offsets)
    };

    let mut out = Reflection { local_size, ..Default::default() };
    for &(ptr_ty, id, sc) in &variables {
        let Some(Ty::Pointer(pointee)) = types.get(&ptr_ty) else { continue };
        let mut base = *pointee;
        while let Some(Ty::Array(e, _)) = types.get(&base) {
            base = *e;
        }
        if sc == SC_PUSH_CONSTANT {
            out.push_constant_size = size_of(base);
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
