//! A small glTF 2.0 writer: enough to make real test files for the importer (meshes, a node hierarchy, skins,
//! animations) as `.gltf` with an embedded or an external buffer, or as `.glb`. It writes the glTF JSON with
//! serde_json and the binary buffer by hand (glTF 2.0 §3.6, §4.4).
//!
//! [`two_bone_arm`] is the test model: a skinned cylinder with two joints and three clips, one per
//! interpolation, plus a rigid stone mesh used by two nodes (instancing). `examples/arm.gltf` is its output.

use serde_json::{json, Value};
use std::path::Path;

/// A glTF document under construction: its JSON and its one binary buffer.
#[derive(Clone, Debug, Default)]
pub struct GltfBuilder {
    pub bin: Vec<u8>,
    pub views: Vec<Value>,
    pub accessors: Vec<Value>,
}

/// How the binary buffer is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    /// `.gltf` with the buffer as a base64 data URI.
    Embedded,
    /// `.gltf` with the buffer in a `.bin` file beside it (same stem).
    External,
    /// Binary glTF (`.glb`).
    Glb,
}

impl GltfBuilder {
    /// A buffer view over `bytes` (4-byte aligned), for accessors written by hand (sparse ones).
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views.push(json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len() }));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    /// A float accessor of `kind` (`SCALAR`, `VEC3`, `VEC4`, `MAT4`) over `data`; `min`/`max` written (POSITION
    /// and animation inputs require them).
    pub fn floats(&mut self, kind: &str, data: &[f32]) -> usize {
        let width = match kind {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => 16,
        };
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let count = data.len() / width;
        let mut min = vec![f32::INFINITY; width];
        let mut max = vec![f32::NEG_INFINITY; width];
        for c in data.chunks_exact(width) {
            for k in 0..width {
                min[k] = min[k].min(c[k]);
                max[k] = max[k].max(c[k]);
            }
        }
        let mut a = json!({ "bufferView": view, "componentType": 5126, "count": count, "type": kind });
        if width <= 4 {
            a["min"] = json!(min);
            a["max"] = json!(max);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// A `u16` `VEC4` accessor (joint indices).
    pub fn joints(&mut self, data: &[[u16; 4]]) -> usize {
        let bytes: Vec<u8> = data.iter().flatten().flat_map(|j| j.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors.push(json!({ "bufferView": view, "componentType": 5123, "count": data.len(), "type": "VEC4" }));
        self.accessors.len() - 1
    }

    /// A `u32` index accessor.
    pub fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors
            .push(json!({ "bufferView": view, "componentType": 5125, "count": data.len(), "type": "SCALAR" }));
        self.accessors.len() - 1
    }

    /// Complete `doc` (without buffers, views and accessors) and write it to `path`.
    pub fn write(&self, mut doc: Value, path: &Path, container: Container) -> std::io::Result<()> {
        let mut bin = self.bin.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        doc["asset"] = json!({ "version": "2.0", "generator": "softshadows scenes::gltf_writer" });
        doc["bufferViews"] = json!(self.views);
        doc["accessors"] = json!(self.accessors);
        match container {
            Container::Embedded => {
                let uri = format!("data:application/octet-stream;base64,{}", base64(&bin));
                doc["buffers"] = json!([{ "byteLength": bin.len(), "uri": uri }]);
                std::fs::write(path, serde_json::to_string_pretty(&doc)?)
            }
            Container::External => {
                let bin_path = path.with_extension("bin");
                let name = bin_path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                doc["buffers"] = json!([{ "byteLength": bin.len(), "uri": name }]);
                std::fs::write(&bin_path, &bin)?;
                std::fs::write(path, serde_json::to_string_pretty(&doc)?)
            }
            Container::Glb => {
                doc["buffers"] = json!([{ "byteLength": bin.len() }]);
                let mut text = serde_json::to_vec(&doc)?;
                while !text.len().is_multiple_of(4) {
                    text.push(b' ');
                }
                let total = 12 + 8 + text.len() + 8 + bin.len();
                let mut out = Vec::with_capacity(total);
                out.extend_from_slice(b"glTF");
                out.extend_from_slice(&2u32.to_le_bytes());
                out.extend_from_slice(&(total as u32).to_le_bytes());
                out.extend_from_slice(&(text.len() as u32).to_le_bytes());
                out.extend_from_slice(b"JSON");
                out.extend_from_slice(&text);
                out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
                out.extend_from_slice(b"BIN\0");
                out.extend_from_slice(&bin);
                std::fs::write(path, out)
            }
        }
    }
}

/// Standard base64 with padding (RFC 4648 §4).
fn base64(bytes: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// The arm's length along +x (mesh space) and radius; the elbow joint is at x = 1.
pub const ARM_LENGTH: f32 = 2.0;
pub const ARM_RADIUS: f32 = 0.15;
/// Where the arm's root node puts the shoulder.
pub const ARM_ROOT: [f32; 3] = [-1.0, 0.5, 0.0];

/// A skinned, animated two-bone cylinder and a stone used twice.
///
/// Nodes: 0 `root` (translation [`ARM_ROOT`], children 1), 1 `upper` (joint 0, at the shoulder, children 2),
/// 2 `fore` (joint 1, translation (1, 0, 0): the elbow), 3 `arm` (the skinned mesh), 4 and 5 `stone` instances of
/// one mesh. Inverse bind matrices: identity for `upper`, translate(−1, 0, 0) for `fore` (the elbow in mesh
/// space), so the rest pose puts the arm along +x from the shoulder. Weights blend linearly over x ∈ [0.8, 1.2].
///
/// Clips: `bend` rotates `fore` about +z through 0°, 60°, 0° at t = 0, 1, 2 (linear: slerp); `lift` moves `root`
/// up by 0.5 and back with a cubic spline (t = 0, 1, 2; zero tangents except an out-tangent (0, 1, 0) at t = 0);
/// `pulse` scales `upper` by 1, 1.2, 1.2 at t = 0, 1, 2 (step).
pub fn two_bone_arm(rings: u32, segments: u32) -> (GltfBuilder, Value) {
    let mut b = GltfBuilder::default();
    let (mut pos, mut nrm, mut joints, mut weights, mut idx) = (vec![], vec![], vec![], vec![], vec![]);
    for i in 0..=rings {
        let x = ARM_LENGTH * i as f32 / rings as f32;
        let t = ((x - 0.8) / 0.4).clamp(0.0, 1.0);
        for j in 0..segments {
            let a = std::f32::consts::TAU * j as f32 / segments as f32;
            let (s, c) = a.sin_cos();
            pos.extend([x, ARM_RADIUS * c, ARM_RADIUS * s]);
            nrm.extend([0.0, c, s]);
            joints.push([0u16, 1, 0, 0]);
            weights.extend([1.0 - t, t, 0.0, 0.0]);
        }
    }
    for i in 0..rings {
        for j in 0..segments {
            let a = i * segments + j;
            let bb = i * segments + (j + 1) % segments;
            idx.extend([a, a + segments, bb, bb, a + segments, bb + segments]);
        }
    }
    let arm = json!({ "name": "arm", "primitives": [{
        "attributes": {
            "POSITION": b.floats("VEC3", &pos),
            "NORMAL": b.floats("VEC3", &nrm),
            "JOINTS_0": b.joints(&joints),
            "WEIGHTS_0": b.floats("VEC4", &weights),
        },
        "indices": b.indices(&idx),
        "material": 0,
    }]});
    // A tetrahedron-like stone (a squashed octahedron).
    let stone_pos = [0.2, 0.0, 0.0, -0.2, 0.0, 0.0, 0.0, 0.15, 0.0, 0.0, -0.15, 0.0, 0.0, 0.0, 0.2, 0.0, 0.0, -0.2];
    let stone_idx = [0u32, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5];
    let stone = json!({ "name": "stone", "primitives": [{
        "attributes": { "POSITION": b.floats("VEC3", &stone_pos) },
        "indices": b.indices(&stone_idx),
        "material": 1,
    }]});
    let ibm: Vec<f32> = [glam::Mat4::IDENTITY, glam::Mat4::from_translation(glam::Vec3::new(-1.0, 0.0, 0.0))]
        .iter()
        .flat_map(|m| m.to_cols_array())
        .collect();
    let ibm = b.floats("MAT4", &ibm);
    let q60 = glam::Quat::from_rotation_z(60f32.to_radians());
    let bend_t = b.floats("SCALAR", &[0.0, 1.0, 2.0]);
    let bend_v = b.floats("VEC4", &[0.0, 0.0, 0.0, 1.0, q60.x, q60.y, q60.z, q60.w, 0.0, 0.0, 0.0, 1.0]);
    let lift_t = b.floats("SCALAR", &[0.0, 1.0, 2.0]);
    #[rustfmt::skip]
    let lift_v = b.floats("VEC3", &[
        // key 0: in-tangent, value, out-tangent
        0.0, 0.0, 0.0,  -1.0, 0.5, 0.0,  0.0, 1.0, 0.0,
        // key 1
        0.0, 0.0, 0.0,  -1.0, 1.0, 0.0,  0.0, 0.0, 0.0,
        // key 2
        0.0, 0.0, 0.0,  -1.0, 0.5, 0.0,  0.0, 0.0, 0.0,
    ]);
    let pulse_t = b.floats("SCALAR", &[0.0, 1.0, 2.0]);
    let pulse_v = b.floats("VEC3", &[1.0, 1.0, 1.0, 1.2, 1.2, 1.2, 1.2, 1.2, 1.2]);
    let doc = json!({
        "scene": 0,
        "scenes": [{ "nodes": [0, 3, 4, 5] }],
        "nodes": [
            { "name": "root", "translation": ARM_ROOT, "children": [1] },
            { "name": "upper", "children": [2] },
            { "name": "fore", "translation": [1.0, 0.0, 0.0] },
            { "name": "arm", "mesh": 0, "skin": 0 },
            { "name": "stone-a", "mesh": 1, "translation": [0.8, 0.15, 0.6] },
            { "name": "stone-b", "mesh": 1, "translation": [-0.7, 0.15, -0.5], "scale": [1.5, 1.5, 1.5] },
        ],
        "meshes": [arm, stone],
        "skins": [{ "joints": [1, 2], "inverseBindMatrices": ibm, "skeleton": 0 }],
        "materials": [
            { "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.5, 0.4, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.9 } },
            { "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.5, 0.55, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.7 } },
        ],
        "animations": [
            { "name": "bend", "channels": [{ "sampler": 0, "target": { "node": 2, "path": "rotation" } }],
              "samplers": [{ "input": bend_t, "output": bend_v, "interpolation": "LINEAR" }] },
            { "name": "lift", "channels": [{ "sampler": 0, "target": { "node": 0, "path": "translation" } }],
              "samplers": [{ "input": lift_t, "output": lift_v, "interpolation": "CUBICSPLINE" }] },
            { "name": "pulse", "channels": [{ "sampler": 0, "target": { "node": 1, "path": "scale" } }],
              "samplers": [{ "input": pulse_t, "output": pulse_v, "interpolation": "STEP" }] },
        ],
    });
    (b, doc)
}

/// A skinned strip shaped as Khronos' SimpleSkin sample: 1 wide (x) and 2 tall (y) in the plane z = 0, five rows
/// of two vertices (10 vertices, 8 triangles: the fit's 18 sample points, no interior), two joints (`root` at the
/// origin, `top` at y = 1; inverse bind matrices identity and translate(0, −1, 0)), the rows at y ≤ 0.5 bound to
/// `root`, y = 1 half to each, y ≥ 1.5 to `top`; one clip `bend` turning `top` about +z by 0°, 30°, 0° at t = 0, 1,
/// 2. No material (the importer's default grey). A flat, small, skinned blocker without volume.
pub fn simple_skin() -> (GltfBuilder, Value) {
    let mut b = GltfBuilder::default();
    let (mut pos, mut joints, mut weights, mut idx) = (vec![], vec![], vec![], vec![]);
    for row in 0..5u32 {
        let y = 0.5 * row as f32;
        let w_top = [0.0, 0.0, 0.5, 1.0, 1.0][row as usize];
        for x in [0.0, 1.0] {
            pos.extend([x, y, 0.0]);
            joints.push([0u16, 1, 0, 0]);
            weights.extend([1.0 - w_top, w_top, 0.0, 0.0]);
        }
    }
    for row in 0..4u32 {
        let a = 2 * row;
        idx.extend([a, a + 1, a + 3, a, a + 3, a + 2]);
    }
    let strip = json!({ "name": "strip", "primitives": [{
        "attributes": {
            "POSITION": b.floats("VEC3", &pos),
            "JOINTS_0": b.joints(&joints),
            "WEIGHTS_0": b.floats("VEC4", &weights),
        },
        "indices": b.indices(&idx),
    }]});
    let ibm: Vec<f32> = [glam::Mat4::IDENTITY, glam::Mat4::from_translation(glam::Vec3::new(0.0, -1.0, 0.0))]
        .iter()
        .flat_map(|m| m.to_cols_array())
        .collect();
    let ibm = b.floats("MAT4", &ibm);
    let q30 = glam::Quat::from_rotation_z(30f32.to_radians());
    let bend_t = b.floats("SCALAR", &[0.0, 1.0, 2.0]);
    let bend_v = b.floats("VEC4", &[0.0, 0.0, 0.0, 1.0, q30.x, q30.y, q30.z, q30.w, 0.0, 0.0, 0.0, 1.0]);
    let doc = json!({
        "scene": 0,
        "scenes": [{ "nodes": [0, 1] }],
        "nodes": [
            { "name": "strip", "mesh": 0, "skin": 0 },
            { "name": "root", "children": [2] },
            { "name": "top", "translation": [0.0, 1.0, 0.0] },
        ],
        "meshes": [strip],
        "skins": [{ "joints": [1, 2], "inverseBindMatrices": ibm }],
        "animations": [
            { "name": "bend", "channels": [{ "sampler": 0, "target": { "node": 2, "path": "rotation" } }],
              "samplers": [{ "input": bend_t, "output": bend_v, "interpolation": "LINEAR" }] },
        ],
    });
    (b, doc)
}

/// Where [`lit_room`]'s point light and main camera sit, and the room's sizes.
pub const ROOM_LAMP: [f32; 3] = [1.2, 2.0, 1.0];
pub const ROOM_LAMP_RADIUS: f32 = 0.2;
pub const ROOM_LAMP_CANDELA: f32 = 2000.0;
/// A Blender sun of strength 1 as Blender's exporter writes it (1 W/m² × 683).
pub const ROOM_SUN_LUX: f32 = 683.0;
/// The sun node's turn: yaw about +y, then pitch about x (degrees); it travels along −z turned by them.
pub const ROOM_SUN_YAW_PITCH: [f32; 2] = [60.0, -50.0];
pub const ROOM_CAMERA_EYE: [f32; 3] = [0.0, 1.5, 4.0];
pub const ROOM_CAMERA_YFOV: f32 = 0.7;
/// Half the floor's side and half the block's side.
pub const ROOM_FLOOR_HALF: f32 = 2.0;
pub const ROOM_BLOCK_HALF: f32 = 0.3;

/// A model as an author exports it with its own stage: a block (a 0.6 m cube on the floor, material 0) on a floor
/// (a 4 m square at y = 0, material 1), two cameras and two `KHR_lights_punctual` lights.
///
/// Nodes: 0 `block`, 1 `floor`, 2 `main-camera` (camera 0 `Main`, perspective, yfov [`ROOM_CAMERA_YFOV`] rad, at
/// [`ROOM_CAMERA_EYE`] turned about x to look at (0, 0.3, 0)), 3 `top-camera` (camera 1 `Top`, orthographic, 5 m
/// above, looking down), 4 `lamp` (light 0 `Lamp`: point, [`ROOM_LAMP_CANDELA`] cd, colour (1, 0.9, 0.8), at
/// [`ROOM_LAMP`], `extras.radius` [`ROOM_LAMP_RADIUS`]), 5 `sun` (light 1 `Sun`: directional, [`ROOM_SUN_LUX`]
/// lux, turned by [`ROOM_SUN_YAW_PITCH`]: it comes from the right, in front and 50° high, so the block's shadow
/// falls to its left and back, in view).
pub fn lit_room() -> (GltfBuilder, Value) {
    let mut b = GltfBuilder::default();
    let h = ROOM_BLOCK_HALF;
    let (mut pos, mut nrm, mut idx) = (vec![], vec![], vec![]);
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = [0.0f32; 3];
            n[axis] = sign;
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = (pos.len() / 3) as u32;
            for (a, c) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let mut p = [0.0f32; 3];
                p[axis] = sign * h;
                p[u] = a * h;
                p[v] = c * h;
                p[1] += h;
                pos.extend(p);
                nrm.extend(n);
            }
            // Counter-clockwise seen from outside: (u, v, n) is right-handed, so flip for the negative side.
            if sign > 0.0 {
                idx.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
            } else {
                idx.extend([base, base + 2, base + 1, base, base + 3, base + 2]);
            }
        }
    }
    let block = json!({ "name": "block", "primitives": [{
        "attributes": { "POSITION": b.floats("VEC3", &pos), "NORMAL": b.floats("VEC3", &nrm) },
        "indices": b.indices(&idx),
        "material": 0,
    }]});
    let f = ROOM_FLOOR_HALF;
    let floor_pos = [-f, 0.0, -f, -f, 0.0, f, f, 0.0, f, f, 0.0, -f];
    let floor = json!({ "name": "floor", "primitives": [{
        "attributes": { "POSITION": b.floats("VEC3", &floor_pos), "NORMAL": b.floats("VEC3", &[0.0, 1.0, 0.0].repeat(4)) },
        "indices": b.indices(&[0, 1, 2, 0, 2, 3]),
        "material": 1,
    }]});
    let eye = glam::Vec3::from(ROOM_CAMERA_EYE);
    let look = glam::Vec3::new(0.0, 0.3, 0.0) - eye;
    let pitch = glam::Quat::from_rotation_x((look.y / (-look.z)).atan());
    let down = glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let [yaw, pitch_deg] = ROOM_SUN_YAW_PITCH;
    let sun = glam::Quat::from_rotation_y(yaw.to_radians()) * glam::Quat::from_rotation_x(pitch_deg.to_radians());
    let doc = json!({
        "scene": 0,
        "scenes": [{ "nodes": [0, 1, 2, 3, 4, 5] }],
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": { "KHR_lights_punctual": { "lights": [
            { "name": "Lamp", "type": "point", "color": [1.0, 0.9, 0.8], "intensity": ROOM_LAMP_CANDELA },
            { "name": "Sun", "type": "directional", "intensity": ROOM_SUN_LUX },
        ]}},
        "nodes": [
            { "name": "block", "mesh": 0 },
            { "name": "floor", "mesh": 1 },
            { "name": "main-camera", "camera": 0, "translation": ROOM_CAMERA_EYE, "rotation": pitch.to_array() },
            { "name": "top-camera", "camera": 1, "translation": [0.0, 5.0, 0.0], "rotation": down.to_array() },
            { "name": "lamp", "translation": ROOM_LAMP, "extras": { "radius": ROOM_LAMP_RADIUS },
              "extensions": { "KHR_lights_punctual": { "light": 0 } } },
            { "name": "sun", "rotation": sun.to_array(), "extensions": { "KHR_lights_punctual": { "light": 1 } } },
        ],
        "cameras": [
            { "name": "Main", "type": "perspective", "perspective": { "yfov": ROOM_CAMERA_YFOV, "znear": 0.05, "aspectRatio": 1.5 } },
            { "name": "Top", "type": "orthographic", "orthographic": { "xmag": 3.0, "ymag": 2.0, "znear": 0.1, "zfar": 10.0 } },
        ],
        "meshes": [block, floor],
        "materials": [
            { "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.3, 0.2, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.6 } },
            { "pbrMetallicRoughness": { "baseColorFactor": [0.6, 0.6, 0.6, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 } },
        ],
    });
    (b, doc)
}

/// The arm of `examples/arm.gltf` (24 rings of 16 vertices).
pub fn example_arm() -> (GltfBuilder, Value) {
    two_bone_arm(24, 16)
}

#[cfg(test)]
mod tests {
    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (i, o) in
            [("", ""), ("f", "Zg=="), ("fo", "Zm8="), ("foo", "Zm9v"), ("foob", "Zm9vYg=="), ("foobar", "Zm9vYmFy")]
        {
            assert_eq!(super::base64(i.as_bytes()), o);
        }
    }
}
