//! glTF 2.0 import for this engine: node hierarchy, meshes, materials, skins and animations.
//!
//! What a file gives ([`GltfScene`]):
//! - every triangle primitive of every mesh the default scene reaches, as one [`Mesh`]; a glTF mesh used by several
//!   nodes is one engine mesh with several [`Instance`]s (uploaded once);
//! - base colour / metallic / roughness factors as materials ([`Material::from_metallic_roughness`]);
//! - skins: the file's joints become bones (all skins' joints in one list, [`Rig::bones`]) with their inverse bind
//!   matrices; each skinned mesh gets a [`Skin`] indexing that list. Up to four influences per vertex are kept:
//!   `JOINTS_1`/`WEIGHTS_1` and beyond are read and the four largest kept, renormalized, with a warning;
//! - animations ([`Clip`]): translation, rotation and scale channels with step, linear (slerp for rotations) and
//!   cubic-spline interpolation; [`Rig::pose`] evaluates a clip at a time into instance transforms and bone
//!   matrices.
//!
//! glTF skinning (§3.7.3) puts a skinned mesh in world space through its joints, ignoring the transform of the
//! node that holds it: its instance transform is the identity and bone `j` is `world(joint j) · inverse_bind(j)`,
//! the matrix the engine's skin and sphere passes apply (`SceneBlockers::bones`).
//!
//! Refused, each with an error naming the file and the feature: morph targets (and animations of their weights),
//! any extension the file lists as required, and extensions that change geometry even when only used
//! ([`GEOMETRY_EXTENSIONS`]).
//!
//! Cameras ([`GltfCamera`]) and `KHR_lights_punctual` lights ([`GltfLight`]) of the default scene's nodes are read
//! with their nodes' world transforms at rest; the scene builder chooses a camera and turns the lights into
//! spherical lights ([`GltfLight::sphere_light`], units in its docs). Textures are ignored.

use super::{Camera, Instance, Material, Mesh, Result, SceneError, Skin, SphereLight};
use engine_io::excerpt;
use glam::{Mat4, Quat, Vec3, Vec4};
use std::collections::HashMap;
use std::path::Path;

/// Extensions that change what geometry a file describes: refused even when listed only as used.
pub const GEOMETRY_EXTENSIONS: &[&str] =
    &["KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_mesh_quantization", "EXT_mesh_gpu_instancing"];

/// What a glTF file contributes to a scene.
#[derive(Clone, Debug, Default)]
pub struct GltfScene {
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    pub instances: Vec<Instance>,
    /// Skin per mesh (index = mesh index; `None`: rigid). Joint indices index [`Rig::bones`].
    pub skins: Vec<Option<Skin>>,
    /// Nodes, bones and animation clips: what poses the instances and bones over time.
    pub rig: Rig,
    /// Camera nodes of the default scene, in the order the scene reaches them.
    pub cameras: Vec<GltfCamera>,
    /// `KHR_lights_punctual` light nodes of the default scene, in the order the scene reaches them.
    pub lights: Vec<GltfLight>,
}

/// A camera node of the file (glTF 2.0 §3.10), at rest.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfCamera {
    /// Index into the file's `cameras`.
    pub camera: usize,
    /// The camera's name (empty if none).
    pub name: String,
    /// The node that holds it, and the node's name (empty if none).
    pub node: usize,
    pub node_name: String,
    /// Vertical field of view in degrees; `None` for an orthographic camera (refused when chosen).
    pub fov_y_degrees: Option<f32>,
    /// The node's world transform at rest (the camera looks down its −z, +y up).
    pub world: Mat4,
}

/// The kind of a `KHR_lights_punctual` light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Intensity in candela (lm/sr).
    Point,
    /// Intensity in candela; cone angles in radians. Refused by [`GltfLight::sphere_light`].
    Spot { inner_cone: f32, outer_cone: f32 },
    /// Illuminance in lux (lm/m²) on a surface facing it; the light travels along the node's −z.
    Directional,
}

/// A `KHR_lights_punctual` light on a node, at rest.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfLight {
    /// Index into the extension's `lights`.
    pub light: usize,
    /// The light's name (empty if none).
    pub name: String,
    pub node: usize,
    pub kind: LightKind,
    /// Linear RGB, each ≥ 0.
    pub color: Vec3,
    /// Candela (point, spot) or lux (directional), ≥ 0.
    pub intensity: f32,
    /// `extras.radius` of the node (else of the light): the sphere's radius in the file's units, > 0.
    pub radius: Option<f32>,
    /// The glTF `range` (ignored: spherical lights fall off as the inverse square, with no cut-off).
    pub range: Option<f32>,
    /// The node's world transform at rest (the light sits at its origin and points down its −z).
    pub world: Mat4,
}

/// Engine radiance per nit (cd/m²) of a file light: 1/683 W/lm. Blender's exporter (lighting mode "Standard")
/// writes its watts × 683 (/4π for point and spot lights), so this exposure gives back Blender's own radiometric
/// values, the units in which an environment map at intensity 1 and Blender's lights are balanced.
pub const PHOTOMETRIC_EXPOSURE: f32 = 1.0 / 683.0;
/// Radius of a point light's sphere (file units, metres in glTF) when neither the node's `extras.radius` nor the
/// scene file gives one.
pub const DEFAULT_POINT_RADIUS: f32 = 0.1;
/// Angular radius of a directional light's sphere unless the scene file says otherwise: the sun's, 0.27°.
pub const DEFAULT_DIRECTIONAL_ANGLE_DEGREES: f32 = 0.27;
/// A directional light's sphere sits this many scene radii from the scene's centre (its direction then varies by
/// at most 1/1000 rad, a fifth of the sun's angular radius, across the scene).
pub const DIRECTIONAL_DISTANCE: f32 = 1000.0;

/// How file lights become spherical lights ([`GltfLight::sphere_light`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightParams {
    /// Engine radiance per nit ([`PHOTOMETRIC_EXPOSURE`] by default).
    pub exposure: f32,
    /// Point lights' radius when the node has no `extras.radius` ([`DEFAULT_POINT_RADIUS`]).
    pub default_radius: f32,
    /// Every point light's radius, whatever the file says (a scene file's `light_radius`).
    pub radius_override: Option<f32>,
    /// Directional lights' angular radius in degrees ([`DEFAULT_DIRECTIONAL_ANGLE_DEGREES`]).
    pub directional_angle_degrees: f32,
}

impl Default for LightParams {
    fn default() -> Self {
        Self {
            exposure: PHOTOMETRIC_EXPOSURE,
            default_radius: DEFAULT_POINT_RADIUS,
            radius_override: None,
            directional_angle_degrees: DEFAULT_DIRECTIONAL_ANGLE_DEGREES,
        }
    }
}

impl GltfCamera {
    /// Whether `key` names this camera: its name, or its node's name.
    pub fn is_named(&self, key: &str) -> bool {
        (!self.name.is_empty() && self.name == key) || (!self.node_name.is_empty() && self.node_name == key)
    }

    /// How messages name it: `camera 2 ('Main')`.
    pub fn label(&self) -> String {
        let name = if self.name.is_empty() { &self.node_name } else { &self.name };
        format!("camera {} ('{}')", self.camera, excerpt(name))
    }

    /// The engine camera of this glTF camera placed by `placement`: the eye at the node's origin, looking down its
    /// −z, the target `focus` away along it (for orbiting viewers). The engine keeps +y up: a rolled camera is
    /// levelled (with a warning). An orthographic camera is an error.
    pub fn view(&self, placement: Mat4, focus: f32) -> std::result::Result<Camera, String> {
        let fov = self.fov_y_degrees.ok_or_else(|| {
            format!(
                "{} is orthographic: only perspective cameras are supported (--camera auto frames the model)",
                self.label()
            )
        })?;
        if !(fov > 1.0 && fov < 179.0) {
            return Err(format!("{}: its yfov is {fov}° (the engine takes (1, 179))", self.label()));
        }
        let world = placement * self.world;
        let eye = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        if !eye.is_finite() || forward == Vec3::ZERO || !forward.is_finite() {
            return Err(format!("{}: its node's transform gives no view direction", self.label()));
        }
        let camera = Camera { eye, target: eye + forward * focus.max(1e-3), fov_y_degrees: fov };
        let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
        let (_, level_up, _) = camera.basis();
        let roll = up.dot(level_up).clamp(-1.0, 1.0).acos().to_degrees();
        if roll > 1.0 {
            log::warn!("{} is rolled by {roll:.1}°: the engine keeps +y up, so its view is levelled", self.label());
        }
        Ok(camera)
    }
}

impl GltfLight {
    /// How messages name it: `light 1 ('Lamp')`.
    pub fn label(&self) -> String {
        format!("light {} ('{}')", self.light, excerpt(&self.name))
    }

    /// The spherical light of this light placed by `placement` (a rigid transform with uniform `scale`), in a scene
    /// whose models have their centre at `center` and bounding radius `radius`.
    ///
    /// - Point, intensity I (cd): a sphere of radius r (`radius_override`, else the node's `extras.radius`, else
    ///   `default_radius`; times `scale`) at the node's origin, of radiance `I / (π r²)`: seen from afar it gives
    ///   the same illuminance `I / d²` as the point.
    /// - Directional, illuminance E (lux): a sphere of angular radius α ([`LightParams::directional_angle_degrees`])
    ///   [`DIRECTIONAL_DISTANCE`] scene radii away along the node's +z, of radiance `E / (π sin² α)`: the
    ///   illuminance on a surface facing it is E.
    /// - Spot: an error (the techniques have no cone falloff).
    ///
    /// Radiance is multiplied by the colour and by `exposure` (engine radiance per nit).
    pub fn sphere_light(
        &self,
        placement: Mat4,
        scale: f32,
        params: &LightParams,
        center: Vec3,
        radius: f32,
    ) -> std::result::Result<SphereLight, String> {
        let world = placement * self.world;
        let rgb = self.color * self.intensity * params.exposure;
        let light = match self.kind {
            LightKind::Spot { .. } => {
                return Err(format!(
                    "{} is a spot light: spot cones are not supported (no technique has a cone falloff); drop the \
                     file's lights with a scene file: [[model]] file = \"<this file>\" lights = false \
                     (docs/scene-files.md)",
                    self.label()
                ))
            }
            LightKind::Point => {
                let r = params.radius_override.or(self.radius).unwrap_or(params.default_radius) * scale;
                SphereLight {
                    center: world.transform_point3(Vec3::ZERO),
                    radius: r,
                    radiance: rgb / (std::f32::consts::PI * r * r),
                }
            }
            LightKind::Directional => {
                let to_light = world.transform_vector3(Vec3::Z).normalize_or_zero();
                if to_light == Vec3::ZERO {
                    return Err(format!("{}: its node's transform gives no direction", self.label()));
                }
                let alpha = params.directional_angle_degrees.to_radians();
                let distance = DIRECTIONAL_DISTANCE * radius.max(1e-3);
                let sin = alpha.sin();
                SphereLight {
                    center: center + to_light * distance,
                    radius: distance * sin,
                    radiance: rgb / (std::f32::consts::PI * sin * sin),
                }
            }
        };
        let ok = light.center.is_finite() && light.radius.is_finite() && light.radius > 0.0;
        if !ok || !light.radiance.is_finite() || light.radiance.min_element() < 0.0 {
            return Err(format!(
                "{}: its sphere is not finite (centre {}, radius {})",
                self.label(),
                light.center,
                light.radius
            ));
        }
        Ok(light)
    }
}

/// One node of the file's hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct RigNode {
    pub parent: Option<usize>,
    /// Local transform at rest (the node's `matrix`, or T·R·S).
    pub local: Mat4,
    /// The rest transform as translation, rotation, scale (what animation channels replace).
    pub translation: Vec3,
    pub rotation: Quat,
    pub scale: Vec3,
}

/// A joint: the node it follows and its inverse bind matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bone {
    pub node: usize,
    pub inverse_bind: Mat4,
}

/// Which part of a node's transform a channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Property {
    Translation,
    Rotation,
    Scale,
}

/// Keyframe interpolation (glTF 2.0 §3.11, Appendix C).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Step,
    /// Linear; spherical linear for rotations.
    Linear,
    /// Cubic Hermite spline with in- and out-tangents per key.
    CubicSpline,
}

/// One animated property of one node.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    pub node: usize,
    pub property: Property,
    pub interpolation: Interpolation,
    /// Key times in seconds, strictly increasing.
    pub times: Vec<f32>,
    /// One value per key (`(x, y, z, 0)` or a quaternion `(x, y, z, w)`); cubic spline: three per key
    /// (in-tangent, value, out-tangent).
    pub values: Vec<Vec4>,
}

/// A named animation (a glTF `animation`).
#[derive(Clone, Debug, PartialEq)]
pub struct Clip {
    pub name: String,
    /// The last key time of any channel (the clip loops over [0, duration]).
    pub duration: f32,
    pub channels: Vec<Channel>,
}

/// The file's node hierarchy with its bones and clips.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rig {
    pub nodes: Vec<RigNode>,
    /// Node indices with every parent before its children.
    pub order: Vec<usize>,
    /// Per instance: the node whose world transform it takes, `None` for a skinned instance (identity).
    pub instance_nodes: Vec<Option<usize>>,
    pub bones: Vec<Bone>,
    pub clips: Vec<Clip>,
}

/// Instance transforms (one per instance, in order) and bone matrices of one pose.
#[derive(Clone, Debug, PartialEq)]
pub struct RigPose {
    pub instance_transforms: Vec<Mat4>,
    pub bones: Vec<Mat4>,
}

impl Channel {
    fn value(&self, k: usize) -> Vec4 {
        match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * k + 1],
            _ => self.values[k],
        }
    }

    /// The channel's value at `t` seconds (clamped to its first and last key).
    pub fn sample(&self, t: f32) -> Vec4 {
        let n = self.times.len();
        if n == 1 || t <= self.times[0] {
            return self.value(0);
        }
        if t >= self.times[n - 1] {
            return self.value(n - 1);
        }
        let k = self.times.partition_point(|&x| x <= t) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let s = (t - t0) / (t1 - t0);
        let rotation = self.property == Property::Rotation;
        match self.interpolation {
            Interpolation::Step => self.value(k),
            Interpolation::Linear if rotation => {
                Vec4::from(Quat::from_vec4(self.value(k)).slerp(Quat::from_vec4(self.value(k + 1)), s))
            }
            Interpolation::Linear => self.value(k).lerp(self.value(k + 1), s),
            Interpolation::CubicSpline => {
                // glTF 2.0 Appendix C: p(s) = (2s³−3s²+1)v_k + (s³−2s²+s)Δ·b_k + (−2s³+3s²)v_{k+1} + (s³−s²)Δ·a_{k+1},
                // b_k the out-tangent of key k, a_{k+1} the in-tangent of key k+1, Δ = t_{k+1} − t_k.
                let d = t1 - t0;
                let (s2, s3) = (s * s, s * s * s);
                let v = (2.0 * s3 - 3.0 * s2 + 1.0) * self.values[3 * k + 1]
                    + (s3 - 2.0 * s2 + s) * d * self.values[3 * k + 2]
                    + (-2.0 * s3 + 3.0 * s2) * self.values[3 * (k + 1) + 1]
                    + (s3 - s2) * d * self.values[3 * (k + 1)];
                if rotation {
                    v.normalize_or(Vec4::W)
                } else {
                    v
                }
            }
        }
    }
}

impl Rig {
    /// The index of the clip called `name`; an unknown name is an error listing the clips.
    pub fn clip_index(&self, name: &str) -> std::result::Result<usize, String> {
        self.clips.iter().position(|c| c.name == name).ok_or_else(|| {
            let names: Vec<&str> = self.clips.iter().map(|c| c.name.as_str()).collect();
            if names.is_empty() {
                format!("no animation clip '{name}' (the file has none)")
            } else {
                format!("no animation clip '{name}' (clips: {})", names.join(", "))
            }
        })
    }

    /// World transform of every node with `clip` (if any) evaluated at `t` seconds (looping over its duration).
    pub fn world_transforms(&self, clip: Option<usize>, t: f32) -> Vec<Mat4> {
        let mut trs: Vec<Option<(Vec3, Quat, Vec3)>> = vec![None; self.nodes.len()];
        if let Some(c) = clip.and_then(|c| self.clips.get(c)) {
            let t = if c.duration > 0.0 && t.is_finite() { t.rem_euclid(c.duration) } else { 0.0 };
            for ch in &c.channels {
                let n = &self.nodes[ch.node];
                let e = trs[ch.node].get_or_insert((n.translation, n.rotation, n.scale));
                let v = ch.sample(t);
                match ch.property {
                    Property::Translation => e.0 = v.truncate(),
                    Property::Rotation => e.1 = Quat::from_vec4(v).normalize(),
                    Property::Scale => e.2 = v.truncate(),
                }
            }
        }
        let mut world = vec![Mat4::IDENTITY; self.nodes.len()];
        for &i in &self.order {
            let n = &self.nodes[i];
            let local = match trs[i] {
                Some((t, r, s)) => Mat4::from_scale_rotation_translation(s, r, t),
                None => n.local,
            };
            world[i] = match n.parent {
                Some(p) => world[p] * local,
                None => local,
            };
        }
        world
    }

    /// Instance transforms and bone matrices with `clip` at `t` seconds (`None`: the rest pose).
    pub fn pose(&self, clip: Option<usize>, t: f32) -> RigPose {
        let world = self.world_transforms(clip, t);
        RigPose {
            instance_transforms: self.instance_nodes.iter().map(|n| n.map_or(Mat4::IDENTITY, |n| world[n])).collect(),
            bones: self.bones.iter().map(|b| world[b.node] * b.inverse_bind).collect(),
        }
    }
}

/// Keep the four largest influences of a vertex, renormalized to sum 1 (all-zero stays all-zero).
/// Returns whether influences beyond four were dropped.
fn four_largest(mut influences: Vec<(u32, f32)>) -> ([u32; 4], [f32; 4], bool) {
    influences.retain(|i| i.1 > 0.0);
    influences.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    let dropped = influences.len() > 4;
    influences.truncate(4);
    let total: f32 = influences.iter().map(|i| i.1).sum();
    let (mut j, mut w) = ([0u32; 4], [0f32; 4]);
    if total > 0.0 {
        for (k, (jj, ww)) in influences.into_iter().enumerate() {
            j[k] = jj;
            w[k] = ww / total;
        }
    }
    (j, w, dropped)
}

/// The refusals that need only the JSON: required extensions, geometry extensions, morph targets.
fn check_supported(doc: &gltf::Document) -> std::result::Result<(), String> {
    if let Some(e) = doc.extensions_required().next() {
        return Err(format!("requires the extension {e}, which this importer does not support"));
    }
    if let Some(e) = doc.extensions_used().find(|e| GEOMETRY_EXTENSIONS.contains(e)) {
        return Err(format!("uses the extension {e} (it changes geometry; not supported)"));
    }
    for m in doc.meshes() {
        for (pi, p) in m.primitives().enumerate() {
            if p.morph_targets().len() > 0 {
                return Err(format!(
                    "mesh {} ('{}') primitive {pi} has morph targets (not supported)",
                    m.index(),
                    m.name().unwrap_or("")
                ));
            }
        }
    }
    for a in doc.animations() {
        for c in a.channels() {
            if c.target().property() == gltf::animation::Property::MorphTargetWeights {
                return Err(format!(
                    "animation {} ('{}') animates morph target weights (not supported)",
                    a.index(),
                    a.name().unwrap_or("")
                ));
            }
        }
    }
    Ok(())
}

/// Parse, check what we refuse (clear messages first), then let the `gltf` crate validate the rest.
pub(super) fn parse(bytes: &[u8]) -> std::result::Result<gltf::Gltf, String> {
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| e.to_string())?;
    check_supported(&document)?;
    let document = gltf::Document::from_json(document.into_json()).map_err(|e| e.to_string())?;
    Ok(gltf::Gltf { document, blob })
}

/// Read every piece of the file (the caller has checked the buffers and the node forest).
pub(super) fn read(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    material_base: usize,
) -> Result<GltfScene> {
    let bad = |m: String| SceneError::invalid(path, m);
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| &d[..]);
    let mut out = GltfScene::default();
    for (i, m) in doc.materials().enumerate() {
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, a] = pbr.base_color_factor();
        // JSON has no NaN, but a number beyond f32 (1e39) arrives as an infinity: the one rule for materials.
        let what = |key: &str| format!("material {i} ('{}') {key}", excerpt(m.name().unwrap_or("")));
        super::check_material_values(&what("baseColorFactor"), &[r, g, b, a]).map_err(bad)?;
        super::check_material_values(&what("metallicFactor"), &[pbr.metallic_factor()]).map_err(bad)?;
        super::check_material_values(&what("roughnessFactor"), &[pbr.roughness_factor()]).map_err(bad)?;
        out.materials.push(Material::from_metallic_roughness(
            Vec3::new(r, g, b),
            pbr.metallic_factor(),
            pbr.roughness_factor(),
        ));
    }
    warn_unread_material_parts(path, doc);
    let default_material = out.materials.len();
    out.materials.push(Material::diffuse(Vec3::splat(0.8)));

    // Nodes: rest transforms and parents (the caller checked the hierarchy is a forest).
    let mut rig = Rig::default();
    for node in doc.nodes() {
        let (t, r, s) = node.transform().decomposed();
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        if !local.is_finite() {
            return Err(bad(format!("node {} has a non-finite transform", node.index())));
        }
        rig.nodes.push(RigNode {
            parent: None,
            local,
            translation: Vec3::from(t),
            rotation: Quat::from_array(r),
            scale: Vec3::from(s),
        });
    }
    let mut children = vec![Vec::new(); rig.nodes.len()];
    for node in doc.nodes() {
        for c in node.children() {
            rig.nodes[c.index()].parent = Some(node.index());
            children[node.index()].push(c.index());
        }
    }
    // Parents first: depth-first from the roots (a forest, so every node is reached once).
    let mut stack: Vec<usize> = (0..rig.nodes.len()).filter(|&i| rig.nodes[i].parent.is_none()).collect();
    while let Some(i) = stack.pop() {
        rig.order.push(i);
        stack.extend(&children[i]);
    }

    // Skins: every skin's joints appended to one bone list.
    let mut skin_base = Vec::new();
    for skin in doc.skins() {
        skin_base.push(rig.bones.len());
        let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
        let ibms: Vec<Mat4> = match skin.reader(get).read_inverse_bind_matrices() {
            Some(it) => it.map(|m| Mat4::from_cols_array_2d(&m)).collect(),
            None => vec![Mat4::IDENTITY; joints.len()],
        };
        if ibms.len() < joints.len() {
            return Err(bad(format!(
                "skin {}: {} inverse bind matrices for {} joints",
                skin.index(),
                ibms.len(),
                joints.len()
            )));
        }
        if let Some(k) = ibms.iter().position(|m| !m.is_finite()) {
            return Err(bad(format!("skin {}: inverse bind matrix {k} is not finite", skin.index())));
        }
        rig.bones.extend(joints.iter().zip(&ibms).map(|(&node, &inverse_bind)| Bone { node, inverse_bind }));
    }

    // Meshes, once per (mesh, primitive, skin); instances per node.
    let scene = doc.default_scene().or_else(|| doc.scenes().next()).ok_or_else(|| bad("no scene".into()))?;
    let mut uploaded: HashMap<(usize, usize, Option<usize>), usize> = HashMap::new();
    // Depth-first in file order (meshes and instances come out in the order the file lists them).
    let mut stack: Vec<gltf::Node> = scene.nodes().collect();
    stack.reverse();
    let (mut camera_nodes, mut light_nodes) = (Vec::new(), Vec::new());
    while let Some(node) = stack.pop() {
        let at = stack.len();
        stack.extend(node.children());
        stack[at..].reverse();
        if let Some(c) = node.camera() {
            camera_nodes.push((node.index(), c.index()));
        }
        if let Some(l) = node.light() {
            light_nodes.push((node.index(), l.index()));
        }
        let Some(mesh) = node.mesh() else { continue };
        for (pi, prim) in mesh.primitives().enumerate() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                log::warn!("{}: mesh {} primitive {pi}: mode {:?} skipped", path.display(), mesh.index(), prim.mode());
                continue;
            }
            let reader = prim.reader(get);
            let skin = node.skin().filter(|_| reader.read_joints(0).is_some());
            let key = (mesh.index(), pi, skin.as_ref().map(|s| s.index()));
            let index = match uploaded.get(&key) {
                Some(&i) => i,
                None => {
                    let Some(pos) = reader.read_positions() else {
                        return Err(bad(format!("mesh {} primitive {pi} has no positions", mesh.index())));
                    };
                    let positions: Vec<Vec3> = pos.map(Vec3::from).collect();
                    let normals = reader.read_normals().map(|n| n.map(Vec3::from).collect());
                    let indices: Vec<u32> = match reader.read_indices() {
                        Some(i) => i.into_u32().collect(),
                        None => (0..positions.len() as u32).collect(),
                    };
                    let name = format!("{}#{pi}", mesh.name().unwrap_or("mesh"));
                    let vertex_skin = match &skin {
                        Some(s) => Some(read_skin(path, &reader, s, skin_base[s.index()], positions.len(), &name)?),
                        None => None,
                    };
                    out.meshes.push(Mesh::new(path, &name, positions, normals, indices)?);
                    out.skins.push(vertex_skin);
                    uploaded.insert(key, out.meshes.len() - 1);
                    out.meshes.len() - 1
                }
            };
            out.instances.push(Instance {
                mesh: index,
                transform: Mat4::IDENTITY,
                material: material_base + prim.material().index().unwrap_or(default_material),
            });
            rig.instance_nodes.push(skin.is_none().then_some(node.index()));
        }
    }
    if out.meshes.is_empty() {
        return Err(bad("no triangle meshes in the default scene".into()));
    }

    for anim in doc.animations() {
        rig.clips.push(read_clip(path, &anim, get)?);
    }
    let rest = rig.pose(None, 0.0);
    let rest_world = rig.world_transforms(None, 0.0);
    for (inst, m) in out.instances.iter_mut().zip(&rest.instance_transforms) {
        if !m.is_finite() {
            return Err(bad("a node's world transform is not finite".into()));
        }
        inst.transform = *m;
    }
    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    for (node, c) in camera_nodes {
        let Some(cam) = doc.cameras().nth(c) else { continue };
        let fov_y_degrees = match cam.projection() {
            gltf::camera::Projection::Perspective(p) => Some(p.yfov().to_degrees()),
            gltf::camera::Projection::Orthographic(_) => None,
        };
        out.cameras.push(GltfCamera {
            camera: c,
            name: cam.name().unwrap_or("").to_string(),
            node,
            node_name: nodes[node].name().unwrap_or("").to_string(),
            fov_y_degrees,
            world: rest_world[node],
        });
    }
    let lights: Vec<gltf::khr_lights_punctual::Light> = doc.lights().map(|l| l.collect()).unwrap_or_default();
    for (node, l) in light_nodes {
        let Some(light) = lights.get(l) else { continue };
        out.lights.push(read_light(light, &nodes[node], rest_world[node]).map_err(bad)?);
    }
    out.rig = rig;
    Ok(out)
}

/// One warning per file naming what its materials have that the importer does not read (textures, emission,
/// alpha modes): a textured model renders in its factors' colours, and the user should know why.
fn warn_unread_material_parts(path: &Path, doc: &gltf::Document) {
    let mut parts: Vec<String> = Vec::new();
    for m in doc.materials() {
        let pbr = m.pbr_metallic_roughness();
        let mut has = Vec::new();
        if pbr.base_color_texture().is_some() {
            has.push("baseColorTexture");
        }
        if pbr.metallic_roughness_texture().is_some() {
            has.push("metallicRoughnessTexture");
        }
        if m.normal_texture().is_some() {
            has.push("normalTexture");
        }
        if m.occlusion_texture().is_some() {
            has.push("occlusionTexture");
        }
        if m.emissive_texture().is_some() || m.emissive_factor().iter().any(|&e| e > 0.0) {
            has.push("emission");
        }
        if m.alpha_mode() != gltf::material::AlphaMode::Opaque {
            has.push("alphaMode");
        }
        if !has.is_empty() {
            parts.push(format!("'{}' ({})", excerpt(m.name().unwrap_or("")), has.join(", ")));
        }
    }
    if !parts.is_empty() {
        let shown = parts.len().min(4);
        log::warn!(
            "{}: {} material(s) use what the importer does not read (textures, emission, alpha): {}{}; they render \
             with their base colour, metallic and roughness factors",
            path.display(),
            parts.len(),
            parts[..shown].join(", "),
            if parts.len() > shown { ", ..." } else { "" }
        );
    }
}

/// The number `extras.radius` of a node or light, if its extras are a JSON object with that key.
fn extras_radius(extras: &gltf::json::Extras) -> std::result::Result<Option<f32>, String> {
    let Some(raw) = extras else { return Ok(None) };
    let value: gltf::json::Value = gltf::json::deserialize::from_str(raw.get()).map_err(|e| e.to_string())?;
    match value.get("radius") {
        None => Ok(None),
        Some(r) => match r.as_f64() {
            Some(r) if r.is_finite() && r > 0.0 && r < 1e30 => Ok(Some(r as f32)),
            _ => Err(format!("extras.radius is {} (a number > 0 expected)", excerpt(&r.to_string()))),
        },
    }
}

/// One `KHR_lights_punctual` light on `node`, its values checked.
fn read_light(
    light: &gltf::khr_lights_punctual::Light,
    node: &gltf::Node,
    world: Mat4,
) -> std::result::Result<GltfLight, String> {
    let name = light.name().unwrap_or("").to_string();
    let label = format!("light {} ('{}')", light.index(), excerpt(&name));
    let color = Vec3::from(light.color());
    if !color.is_finite() || color.min_element() < 0.0 {
        return Err(format!("{label}: color {color} is not finite and ≥ 0"));
    }
    let intensity = light.intensity();
    if !intensity.is_finite() || intensity < 0.0 {
        return Err(format!("{label}: intensity {intensity} is not finite and ≥ 0"));
    }
    let kind = match light.kind() {
        gltf::khr_lights_punctual::Kind::Point => LightKind::Point,
        gltf::khr_lights_punctual::Kind::Directional => LightKind::Directional,
        gltf::khr_lights_punctual::Kind::Spot { inner_cone_angle, outer_cone_angle } => {
            LightKind::Spot { inner_cone: inner_cone_angle, outer_cone: outer_cone_angle }
        }
    };
    let node_radius = extras_radius(node.extras()).map_err(|e| format!("node {} ({label}): {e}", node.index()))?;
    let radius = match node_radius {
        Some(r) => Some(r),
        None => extras_radius(light.extras()).map_err(|e| format!("{label}: {e}"))?,
    };
    Ok(GltfLight {
        light: light.index(),
        name,
        node: node.index(),
        kind,
        color,
        intensity,
        radius,
        range: light.range(),
        world,
    })
}

/// The [`Skin`] of one primitive: joint indices offset by `base` into the rig's bone list, checked and reduced to
/// four influences.
fn read_skin<'a, 's, F>(
    path: &Path,
    reader: &gltf::mesh::Reader<'a, 's, F>,
    skin: &gltf::Skin,
    base: usize,
    vertices: usize,
    name: &str,
) -> Result<Skin>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let bad = |m: String| SceneError::invalid(path, format!("mesh '{name}' (skin {}): {m}", skin.index()));
    let joint_count = skin.joints().len();
    let mut influences: Vec<Vec<(u32, f32)>> = vec![Vec::new(); vertices];
    let mut set = 0;
    while let Some(joints) = reader.read_joints(set) {
        let Some(weights) = reader.read_weights(set) else {
            return Err(bad(format!("JOINTS_{set} without WEIGHTS_{set}")));
        };
        let joints: Vec<[u16; 4]> = joints.into_u16().collect();
        let weights: Vec<[f32; 4]> = weights.into_f32().collect();
        if joints.len() != vertices || weights.len() != vertices {
            return Err(bad(format!(
                "JOINTS_{set} has {} and WEIGHTS_{set} {} entries for {vertices} vertices",
                joints.len(),
                weights.len()
            )));
        }
        for (v, (j, w)) in joints.iter().zip(&weights).enumerate() {
            for k in 0..4 {
                if !w[k].is_finite() || w[k] < 0.0 {
                    return Err(bad(format!("vertex {v} has weight {} (not a finite number ≥ 0)", w[k])));
                }
                if w[k] > 0.0 {
                    if j[k] as usize >= joint_count {
                        return Err(bad(format!(
                            "vertex {v} names joint {} but the skin has {joint_count} joints",
                            j[k]
                        )));
                    }
                    influences[v].push(((base + j[k] as usize) as u32, w[k]));
                }
            }
        }
        set += 1;
        if set > 64 {
            break;
        }
    }
    let (mut out, mut dropped, mut unweighted) = (Skin::default(), 0usize, 0usize);
    for inf in influences {
        unweighted += usize::from(inf.is_empty());
        let (j, w, d) = four_largest(inf);
        dropped += usize::from(d);
        out.joints.push(j);
        out.weights.push(w);
    }
    if dropped > 0 {
        log::warn!(
            "{}: mesh '{name}': {dropped} vertices have more than 4 joint influences; the 4 largest are kept, \
             renormalized",
            path.display()
        );
    }
    if unweighted > 0 {
        log::warn!(
            "{}: mesh '{name}': {unweighted} skinned vertices have no weight; they stay at rest",
            path.display()
        );
    }
    Ok(out)
}

fn read_clip<'a, 's, F>(path: &Path, anim: &gltf::Animation<'a>, get: F) -> Result<Clip>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let name = anim.name().map(str::to_string).unwrap_or_else(|| format!("animation{}", anim.index()));
    let mut clip = Clip { name, duration: 0.0, channels: Vec::new() };
    for (ci, c) in anim.channels().enumerate() {
        let bad = |m: String| SceneError::invalid(path, format!("animation '{}' channel {ci}: {m}", clip.name));
        let reader = c.reader(get.clone());
        let times: Vec<f32> = reader.read_inputs().ok_or_else(|| bad("no key times".into()))?.collect();
        if times.is_empty() {
            return Err(bad("no key times".into()));
        }
        if let Some(k) = times.iter().position(|t| !t.is_finite() || *t < 0.0) {
            return Err(bad(format!("key time {k} is {} (times must be finite and ≥ 0)", times[k])));
        }
        if let Some(k) = times.windows(2).position(|w| w[1] <= w[0]) {
            return Err(bad(format!(
                "key times are not increasing: key {} at {} s does not come after key {k} at {} s",
                k + 1,
                times[k + 1],
                times[k]
            )));
        }
        use gltf::animation::util::ReadOutputs;
        let (property, values): (Property, Vec<Vec4>) = match reader.read_outputs() {
            Some(ReadOutputs::Translations(it)) => {
                (Property::Translation, it.map(|v| Vec3::from(v).extend(0.0)).collect())
            }
            Some(ReadOutputs::Scales(it)) => (Property::Scale, it.map(|v| Vec3::from(v).extend(0.0)).collect()),
            Some(ReadOutputs::Rotations(r)) => (Property::Rotation, r.into_f32().map(Vec4::from).collect()),
            Some(ReadOutputs::MorphTargetWeights(_)) => {
                return Err(bad("morph target weights (not supported)".into()));
            }
            None => return Err(bad("no output values".into())),
        };
        let interpolation = match c.sampler().interpolation() {
            gltf::animation::Interpolation::Step => Interpolation::Step,
            gltf::animation::Interpolation::Linear => Interpolation::Linear,
            gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
        };
        let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        if values.len() != per_key * times.len() {
            return Err(bad(format!(
                "{} output values for {} key times ({per_key} per key with {interpolation:?})",
                values.len(),
                times.len()
            )));
        }
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(bad(format!("output value {k} is not finite")));
        }
        if property == Property::Rotation {
            if let Some(k) = (0..times.len()).position(|k| values[per_key * k + per_key / 2].length() < 1e-6) {
                return Err(bad(format!("rotation key {k} is a zero quaternion")));
            }
        }
        clip.duration = clip.duration.max(*times.last().unwrap_or(&0.0));
        clip.channels.push(Channel { node: c.target().node().index(), property, interpolation, times, values });
    }
    Ok(clip)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(property: Property, interpolation: Interpolation, times: Vec<f32>, values: Vec<Vec4>) -> Channel {
        Channel { node: 0, property, interpolation, times, values }
    }

    #[test]
    fn samplers_interpolate_as_the_spec_says() {
        let t = Property::Translation;
        let lin = channel(t, Interpolation::Linear, vec![1.0, 3.0], vec![Vec4::ZERO, Vec4::new(4.0, 0.0, 0.0, 0.0)]);
        assert_eq!(lin.sample(0.0).x, 0.0, "clamped before the first key");
        assert_eq!(lin.sample(2.0).x, 2.0);
        assert_eq!(lin.sample(2.5).x, 3.0);
        assert_eq!(lin.sample(9.0).x, 4.0, "clamped after the last key");
        let step = channel(t, Interpolation::Step, vec![0.0, 1.0], vec![Vec4::X, Vec4::Y]);
        assert_eq!((step.sample(0.99), step.sample(1.0)), (Vec4::X, Vec4::Y));
        // Cubic spline with zero tangents: the smoothstep 3s² − 2s³ between the values.
        let cubic = channel(
            t,
            Interpolation::CubicSpline,
            vec![0.0, 2.0],
            vec![Vec4::ZERO, Vec4::ZERO, Vec4::ZERO, Vec4::ZERO, Vec4::X, Vec4::ZERO],
        );
        let s: f32 = 0.25;
        assert!((cubic.sample(0.5).x - (3.0 * s * s - 2.0 * s * s * s)).abs() < 1e-6);
        // Tangents scale by the key interval: out-tangent 1 at key 0, values 0 → p'(0) = 1 per second.
        let slope = channel(
            t,
            Interpolation::CubicSpline,
            vec![0.0, 2.0],
            vec![Vec4::ZERO, Vec4::ZERO, Vec4::X, Vec4::ZERO, Vec4::ZERO, Vec4::ZERO],
        );
        let h = 1e-3;
        assert!((slope.sample(h).x / h - 1.0).abs() < 1e-2, "{}", slope.sample(h).x / h);
        // Rotation: slerp (90° about z halfway → 45°).
        let q1 = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let rot = channel(Property::Rotation, Interpolation::Linear, vec![0.0, 1.0], vec![Vec4::W, Vec4::from(q1)]);
        let half = Quat::from_vec4(rot.sample(0.5));
        assert!(half.angle_between(Quat::from_rotation_z(std::f32::consts::FRAC_PI_4)) < 1e-5);
    }

    #[test]
    fn influences_reduce_to_four_renormalized() {
        let (j, w, dropped) = four_largest(vec![(0, 0.1), (1, 0.3), (2, 0.05), (3, 0.2), (4, 0.35)]);
        assert!(dropped);
        assert_eq!(j, [4, 1, 3, 0]);
        let sum = 0.35 + 0.3 + 0.2 + 0.1;
        for (a, b) in w.iter().zip([0.35 / sum, 0.3 / sum, 0.2 / sum, 0.1 / sum]) {
            assert!((a - b).abs() < 1e-6);
        }
        assert_eq!(four_largest(vec![]), ([0; 4], [0.0; 4], false));
    }
}
