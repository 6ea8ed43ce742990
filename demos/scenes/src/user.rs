//! The user's own scenes: `--scene FILE`.
//!
//! - `.gltf`, `.glb`, `.obj`: one model ([`load_model`]) framed by the default camera, on a ground plane (a plane
//!   blocker) under the default environment (the courtyard), its meshes' blocker spheres fitted and cached on disk
//!   ([`cache_dir`]), skinned meshes with skinned spheres; its animation clips play with `--animate`.
//! - `.toml`: a scene description ([`SceneFile`], strict: unknown keys and wrong types are errors naming the file,
//!   the line and the key): models with transforms and materials, environment (with rotation about +y), spherical
//!   lights, camera, ground, clips and blockers (a count to fit, sphere files, or none).

use super::limits;
use super::{shapes, Pose};
use anyhow::{anyhow, bail, ensure, Context, Result};
use engine::blockers::fit::FitSettings;
use engine::blockers::Sphere;
use engine::math::env_lights::EnvLightParams;
use engine::math::envmap::LatLongMap;
use engine::scene::gltf_import::{GltfCamera, GltfLight, LightParams};
use engine::scene::material_map::{MaterialMap, MaterialMapping};
use engine::scene::{load_environment, Camera, Instance, Material, Mesh, Rig, Scene, SceneBlockers, Skin, SphereLight};
use glam::{EulerRot, Mat4, Quat, Vec3};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// File extensions `--scene` takes as one model.
pub const MODEL_EXTENSIONS: &[&str] = &["gltf", "glb", "obj"];
/// File extensions `--scene` takes as a scene description.
pub const SCENE_EXTENSIONS: &[&str] = &["toml"];
/// Blocker spheres fitted per mesh when neither `--spheres` nor the scene file says.
pub const DEFAULT_SPHERES: usize = 32;

/// Whether `spec` names a file `--scene` reads (by its extension, case-insensitive).
pub fn is_file_spec(spec: &str) -> bool {
    let ext = Path::new(spec).extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    ext.is_some_and(|e| MODEL_EXTENSIONS.contains(&e.as_str()) || SCENE_EXTENSIONS.contains(&e.as_str()))
}

/// What the command line adds to a file scene.
#[derive(Clone, Debug, Default)]
pub struct UserOptions {
    /// `--spheres N`: blocker spheres fitted per mesh (a scene file's `spheres` key wins).
    pub spheres: Option<usize>,
    /// `--clip NAME`: play only this clip of every model that has it (an error if none has it).
    pub clip: Option<String>,
    /// Where fitted sphere sets are cached (default: [`cache_dir`]).
    pub cache: Option<PathBuf>,
    /// Fit settings other than the count (tests use small ones; default: `FitSettings::default()`).
    pub fit: Option<FitSettings>,
    /// `--camera N|NAME|auto`: a camera of the file(s), or the automatic framing (default: the file's first
    /// camera for a model file, the scene file's `[camera]` for a scene file).
    pub camera: Option<CameraChoice>,
    /// `--ground none|auto|engine` (default: auto, or the scene file's `ground.mode`).
    pub ground: Option<GroundMode>,
}

/// `--camera`: the automatic framing, or a camera of the model's file.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraChoice {
    Auto,
    File(CameraKey),
}

/// A glTF camera by its index in the file's `cameras`, or by its name (or its node's).
#[derive(Clone, Debug, PartialEq)]
pub enum CameraKey {
    Index(usize),
    Name(String),
    /// The file's first camera (an error if it has none).
    First,
}

impl std::str::FromStr for CameraChoice {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "" => Err("--camera: give N (the file's camera index), a camera's name, or auto".into()),
            "auto" => Ok(Self::Auto),
            _ => Ok(Self::File(match s.parse::<usize>() {
                Ok(i) => CameraKey::Index(i),
                Err(_) => CameraKey::Name(s.to_string()),
            })),
        }
    }
}

impl CameraKey {
    fn find<'a>(&self, cameras: &'a [GltfCamera]) -> Option<&'a GltfCamera> {
        match self {
            CameraKey::Index(i) => cameras.iter().find(|c| c.camera == *i),
            CameraKey::Name(n) => cameras.iter().find(|c| c.is_named(n)),
            CameraKey::First => cameras.first(),
        }
    }
}

impl std::fmt::Display for CameraKey {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            CameraKey::Index(i) => write!(f, "{i}"),
            CameraKey::Name(n) => write!(f, "'{}'", engine::io::excerpt(n)),
            CameraKey::First => write!(f, "(the first)"),
        }
    }
}

/// `--ground`: whether the engine adds its ground plane under the models.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroundMode {
    /// No engine ground.
    None,
    /// The engine's ground unless a model brings its own floor ([`find_floors`]).
    Auto,
    /// The engine's ground always.
    Engine,
}

impl std::str::FromStr for GroundMode {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "none" => Ok(Self::None),
            "auto" => Ok(Self::Auto),
            "engine" => Ok(Self::Engine),
            _ => Err(format!("ground mode '{}': use none, auto or engine", engine::io::excerpt(s))),
        }
    }
}

/// A file scene, built.
pub struct UserScene {
    pub scene: Scene,
    /// The clips that `--animate` plays (`None`: no model has clips).
    pub clips: Option<Arc<ClipPlayer>>,
}

/// The sphere cache folder: `$SOFTSHADOWS_SPHERE_CACHE`, else `$XDG_CACHE_HOME/softshadows/spheres`, else
/// `$HOME/.cache/softshadows/spheres`, else the temporary folder's `softshadows-spheres`.
pub fn cache_dir() -> PathBuf {
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    var("SOFTSHADOWS_SPHERE_CACHE")
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("softshadows/spheres")))
        .or_else(|| var("HOME").map(|d| d.join(".cache/softshadows/spheres")))
        .unwrap_or_else(|| std::env::temp_dir().join("softshadows-spheres"))
}

/// One model loaded from a file, before placement.
#[derive(Clone, Debug, Default)]
pub struct Model {
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    /// Instances with material indices into `materials`.
    pub instances: Vec<Instance>,
    pub skins: Vec<Option<Skin>>,
    /// glTF nodes, bones and clips (OBJ: the default, no bones or clips).
    pub rig: Rig,
    /// glTF cameras (OBJ: none).
    pub cameras: Vec<GltfCamera>,
    /// glTF `KHR_lights_punctual` lights (OBJ: none).
    pub lights: Vec<GltfLight>,
}

/// Load a `.gltf`, `.glb` or `.obj` file as one model.
pub fn load_model(path: &Path) -> Result<Model> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    match ext.as_str() {
        "gltf" | "glb" => {
            let g = engine::scene::load_gltf(path, 0)?;
            Ok(Model {
                meshes: g.meshes,
                materials: g.materials,
                instances: g.instances,
                skins: g.skins,
                rig: g.rig,
                cameras: g.cameras,
                lights: g.lights,
            })
        }
        "obj" => {
            let (meshes, materials) = engine::scene::load_obj_with_materials(path)?;
            let instances =
                (0..meshes.len()).map(|i| Instance { mesh: i, transform: Mat4::IDENTITY, material: i }).collect();
            let skins = vec![None; meshes.len()];
            let rig = Rig { instance_nodes: vec![None; meshes.len()], ..Default::default() };
            Ok(Model { meshes, materials, instances, skins, rig, ..Default::default() })
        }
        _ => bail!("{}: not a model file (expected .gltf, .glb or .obj)", path.display()),
    }
}

/// Which clips of a model play.
#[derive(Clone, Debug, PartialEq)]
pub enum ClipChoice {
    /// Every clip, one after the other, looping.
    All,
    /// One clip (an index into the rig's clips), looping.
    One(usize),
    /// One clip, looping, `phase` seconds into it at t = 0 (a crowd's characters out of step).
    Phased(usize, f32),
    /// None: the model stays at rest.
    Still,
}

/// The animated part of a placed model.
#[derive(Clone, Debug)]
struct PlacedRig {
    rig: Rig,
    placement: Mat4,
    instance_base: usize,
    bone_base: usize,
    choice: ClipChoice,
}

/// Plays the clips of a scene's models: instance transforms and bone matrices at any time.
#[derive(Clone, Debug, Default)]
pub struct ClipPlayer {
    models: Vec<PlacedRig>,
    bone_count: usize,
}

impl ClipPlayer {
    /// The pose at `t` seconds.
    pub fn pose(&self, t: f32) -> Pose {
        let mut pose = Pose { transforms: Vec::new(), bones: None };
        let mut bones = vec![Mat4::IDENTITY; self.bone_count];
        for m in &self.models {
            let (clip, local_t) = match &m.choice {
                ClipChoice::Still => (None, 0.0),
                ClipChoice::One(c) => (Some(*c), t),
                ClipChoice::Phased(c, phase) => (Some(*c), t + phase),
                ClipChoice::All => {
                    let total: f32 = m.rig.clips.iter().map(|c| c.duration).sum();
                    let mut u = if total > 0.0 && t.is_finite() { t.rem_euclid(total) } else { 0.0 };
                    let mut pick = None;
                    for (i, c) in m.rig.clips.iter().enumerate() {
                        if u < c.duration || i + 1 == m.rig.clips.len() {
                            pick = Some(i);
                            break;
                        }
                        u -= c.duration;
                    }
                    (pick, u)
                }
            };
            let p = m.rig.pose(clip, local_t);
            for (k, tr) in p.instance_transforms.iter().enumerate() {
                pose.transforms.push((m.instance_base + k, m.placement * *tr));
            }
            bones[m.bone_base..m.bone_base + p.bones.len()].copy_from_slice(&p.bones);
        }
        if self.bone_count > 0 {
            pose.bones = Some(bones);
        }
        pose
    }

    /// Whether anything moves.
    pub fn moves(&self) -> bool {
        self.models.iter().any(|m| m.choice != ClipChoice::Still && !m.rig.clips.is_empty())
    }
}

/// A model placed in a scene.
pub struct Placement {
    pub model: Model,
    /// Source file (for messages).
    pub file: PathBuf,
    pub transform: Mat4,
    /// Replaces every material of the model.
    pub material: Option<Material>,
    /// Blends `material` spatially across each mesh (needs `material`: the map's t = 0 end).
    pub map: Option<MaterialMapping>,
    pub blockers: Blockers,
    pub choice: ClipChoice,
    /// How the file's punctual lights become spherical lights (`None`: they are dropped).
    pub lights: Option<LightParams>,
    /// Meshes that only receive (no blocker spheres), by name (`name#primitive` or the glTF mesh's name); `None`:
    /// the model's floors ([`find_floors`]).
    pub receivers: Option<Vec<String>>,
}

/// A model's blocker spheres.
#[derive(Clone, Debug, PartialEq)]
pub enum Blockers {
    /// Fit this many per mesh (0: none).
    Fit(usize),
    /// Sphere files, one per mesh in order.
    Files(Vec<PathBuf>),
}

/// Everything [`assemble`] needs.
pub struct Composition {
    pub models: Vec<Placement>,
    pub environment: LatLongMap,
    pub environment_intensity: f32,
    /// How the environment is split into lights and a residual (`[environment] lights`, …).
    pub env_lights: EnvLightParams,
    pub lights: Vec<SphereLight>,
    pub camera: CameraSetup,
    /// A ground plane under the models' rest bounds (with [`GroundMode::Auto`]: unless a model has a floor).
    pub ground: Option<Ground>,
    pub ground_mode: GroundMode,
}

/// Which camera a [`Composition`] uses.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraSetup {
    /// Framed automatically around the models' rest bounds ([`framing_camera`]).
    Auto,
    Fixed(Camera),
    /// A camera of a model's file: of model `model` (`None`: the first model that has it); `key` `None`: the first
    /// camera of the file, or the automatic framing when no model has one.
    File {
        model: Option<usize>,
        key: Option<CameraKey>,
    },
}

/// The ground plane of a [`Composition`].
#[derive(Clone, Debug, PartialEq)]
pub struct Ground {
    pub material: Material,
    /// Quads per side (per-vertex shading and a material map resolve at this spacing).
    pub subdivisions: u32,
    /// Blends `material` spatially across the ground.
    pub map: Option<MaterialMapping>,
}

impl Ground {
    /// The default ground: 16 × 16 quads, one material.
    pub fn plain(material: Material) -> Self {
        Self { material, subdivisions: DEFAULT_GROUND_SUBDIVISIONS, map: None }
    }
}

/// Quads per side of a scene's ground unless its file says otherwise.
pub const DEFAULT_GROUND_SUBDIVISIONS: u32 = 16;
/// The most quads per side of a ground (513² vertices).
pub const MAX_GROUND_SUBDIVISIONS: u32 = limits::GROUND_SUBDIVISIONS.hi as u32;
/// Palette levels of a material map unless its file says otherwise.
pub const DEFAULT_MAP_LEVELS: u32 = 32;

/// World-space bounds of one instance of `scene` at rest, skinned vertices posed by the rest bones.
pub fn instance_bounds(scene: &Scene, inst: &Instance) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mesh = &scene.meshes[inst.mesh];
    let skin = scene.blockers.skin_of(inst.mesh);
    for (v, p) in mesh.positions.iter().enumerate() {
        let local = match skin {
            Some(s) if s.weights[v].iter().sum::<f32>() > 0.0 => (0..4)
                .map(|k| {
                    let b = scene.blockers.bones.get(s.joints[v][k] as usize).copied().unwrap_or(Mat4::IDENTITY);
                    s.weights[v][k] * b.transform_point3(*p)
                })
                .sum(),
            _ => *p,
        };
        let w = inst.transform.transform_point3(local);
        lo = lo.min(w);
        hi = hi.max(w);
    }
    (lo, hi)
}

/// World-space bounds of `scene` at rest, skinned vertices posed by the rest bones.
pub fn posed_bounds(scene: &Scene) -> (Vec3, Vec3) {
    bounds_of(scene, |_| true)
}

/// World-space bounds at rest of the instances whose mesh passes `keep`.
fn bounds_of(scene: &Scene, keep: impl Fn(usize) -> bool) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for inst in scene.instances.iter().filter(|i| keep(i.mesh)) {
        let (a, b) = instance_bounds(scene, inst);
        lo = lo.min(a);
        hi = hi.max(b);
    }
    (lo, hi)
}

/// A floor's height (y extent) is at most this fraction of its width; it lies at most this fraction of the
/// model's size above the model's lowest point.
pub const FLOOR_FLATNESS: f32 = 1e-3;

/// The meshes of `scene` that are a floor the models bring: a rigid mesh with one instance that is flat and
/// horizontal (its y extent at most [`FLOOR_FLATNESS`] of its x–z extent), lies at the base of everything (its y
/// within [`FLOOR_FLATNESS`] of the scene's size of the lowest point), and is larger than the rest (its x–z
/// rectangle holds the centre of the other instances' x–z bounds and has at least their area). A lone mesh is never
/// a floor. Index = mesh index.
pub fn find_floors(scene: &Scene) -> Vec<bool> {
    let n = scene.meshes.len();
    let mut count = vec![0usize; n];
    for inst in &scene.instances {
        count[inst.mesh] += 1;
    }
    let bounds: Vec<(Vec3, Vec3)> = scene.instances.iter().map(|i| instance_bounds(scene, i)).collect();
    let (lo, hi) = posed_bounds(scene);
    let size = (hi - lo).max_element().max(1e-6);
    let mut floors = vec![false; n];
    for (i, inst) in scene.instances.iter().enumerate() {
        let m = inst.mesh;
        if count[m] != 1 || scene.blockers.skin_of(m).is_some() || scene.meshes[m].indices.is_empty() {
            continue;
        }
        let (flo, fhi) = bounds[i];
        let ext = fhi - flo;
        let flat = ext.y <= FLOOR_FLATNESS * ext.x.max(ext.z) && ext.x > 0.0 && ext.z > 0.0;
        if !flat || flo.y - lo.y > FLOOR_FLATNESS * size {
            continue;
        }
        let mut olo = Vec3::splat(f32::INFINITY);
        let mut ohi = Vec3::splat(f32::NEG_INFINITY);
        for (k, b) in bounds.iter().enumerate() {
            if k != i {
                olo = olo.min(b.0);
                ohi = ohi.max(b.1);
            }
        }
        if !olo.is_finite() || !ohi.is_finite() {
            continue;
        }
        let c = 0.5 * (olo + ohi);
        let holds = (flo.x..=fhi.x).contains(&c.x) && (flo.z..=fhi.z).contains(&c.z);
        let other = (ohi - olo).max(Vec3::ZERO);
        floors[m] = holds && ext.x * ext.z >= other.x * other.z;
    }
    floors
}

/// Whether every instance of `mesh` is a flat rectangle (so it can stand in for the engine's ground as a plane
/// blocker, `BlockerPlane::from_flat_mesh`).
fn is_rectangle(scene: &Scene, mesh: usize) -> bool {
    let m = &scene.meshes[mesh];
    scene.instances.iter().filter(|i| i.mesh == mesh).all(|i| {
        let world: Vec<glam::DVec3> = m.positions.iter().map(|p| i.transform.transform_point3(*p).as_dvec3()).collect();
        engine::scene::blockers::BlockerPlane::from_flat_mesh(&world, &m.indices).is_ok()
    })
}

/// A camera looking at the middle of `lo..hi` from the front and above, far enough to see all of it.
pub fn framing_camera(lo: Vec3, hi: Vec3) -> Camera {
    let fov_y_degrees: f32 = 45.0;
    let target = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-3);
    let distance = 1.15 * radius / (0.5 * fov_y_degrees.to_radians()).sin();
    Camera { eye: target + Vec3::new(0.0, 0.45, 1.0).normalize() * distance, target, fov_y_degrees }
}

/// The meshes of a model that `names` lists (`name#primitive`, or a glTF mesh's name for all its primitives); a
/// name that matches none is an error listing the meshes.
fn named_meshes(meshes: &[Mesh], names: &[String], file: &Path) -> Result<Vec<bool>> {
    let mut out = vec![false; meshes.len()];
    for n in names {
        let mut found = false;
        for (k, m) in meshes.iter().enumerate() {
            let base = m.name.rsplit_once('#').map_or(m.name.as_str(), |(b, _)| b);
            if m.name == *n || base == n {
                out[k] = true;
                found = true;
            }
        }
        if !found {
            let all: Vec<&str> = meshes.iter().map(|m| m.name.as_str()).collect();
            bail!("{}: no mesh '{}' (meshes: {})", file.display(), engine::io::excerpt(n), all.join(", "));
        }
    }
    Ok(out)
}

/// The camera of a composition: fixed, framed, or a model's glTF camera.
fn choose_camera(
    setup: &CameraSetup,
    cameras: &[(Mat4, PathBuf, Vec<GltfCamera>)],
    lo: Vec3,
    hi: Vec3,
) -> Result<Camera> {
    let framed = || framing_camera(lo, hi);
    let (model, key) = match setup {
        CameraSetup::Auto => return Ok(framed()),
        CameraSetup::Fixed(c) => return Ok(*c),
        CameraSetup::File { model, key } => (*model, key.as_ref()),
    };
    let candidates: Vec<usize> = match model {
        Some(m) => {
            ensure!(m < cameras.len(), "camera.model: {m} is not a model index (the scene has {})", cameras.len());
            vec![m]
        }
        None => (0..cameras.len()).collect(),
    };
    let found = candidates.iter().find_map(|&m| {
        let list = &cameras[m].2;
        match key {
            None => list.first(),
            Some(k) => k.find(list),
        }
        .map(|c| (m, c))
    });
    let Some((m, cam)) = found else {
        let Some(k) = key else { return Ok(framed()) };
        let listed: Vec<String> = candidates.iter().flat_map(|&m| cameras[m].2.iter().map(|c| c.label())).collect();
        let files: Vec<String> = candidates.iter().map(|&m| cameras[m].1.display().to_string()).collect();
        if listed.is_empty() {
            bail!("camera {k}: {} has no cameras (use auto)", files.join(", "));
        }
        bail!("camera {k}: no such camera in {} (cameras: {})", files.join(", "), listed.join(", "));
    };
    let (placement, file) = (cameras[m].0, &cameras[m].1);
    let center = 0.5 * (lo + hi);
    let eye = (placement * cam.world).transform_point3(Vec3::ZERO);
    let forward = (placement * cam.world).transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    let focus = (center - eye).dot(forward).max(0.1 * (hi - lo).length());
    cam.view(placement, focus).map_err(|e| anyhow!("{}: {e}", file.display()))
}

/// Build the scene: meshes, skins and bones of every model (joint indices offset into one bone list), the
/// ground, camera, lights, and blocker spheres (fitted with progress on stderr, or loaded and checked against their
/// mesh).
pub fn assemble(c: Composition, opts: &UserOptions) -> Result<UserScene> {
    let mut scene = Scene {
        meshes: Vec::new(),
        materials: Vec::new(),
        instances: Vec::new(),
        environment: c.environment,
        environment_intensity: c.environment_intensity,
        env_lights: c.env_lights,
        lights: c.lights,
        blockers: SceneBlockers::default(),
        camera: Camera { eye: Vec3::Z, target: Vec3::ZERO, fov_y_degrees: 45.0 },
    };
    let mut player = ClipPlayer::default();
    let mut sphere_jobs: Vec<(usize, Blockers, usize, PathBuf)> = Vec::new();
    // Per scene mesh: `Some(true)` the scene file lists it as a receiver, `Some(false)` it does not; `None`: the
    // model's floors only receive.
    let mut listed_receivers: Vec<Option<bool>> = Vec::new();
    let mut cameras = Vec::new();
    let mut file_lights = Vec::new();
    for p in c.models {
        let m = p.model;
        let (mesh_base, material_base) = (scene.meshes.len(), scene.materials.len());
        let (instance_base, bone_base) = (scene.instances.len(), scene.blockers.bones.len());
        match (p.material, &p.map) {
            (Some(mat), Some(map)) => scene
                .materials
                .extend(map.palette(&mat).map_err(|e| anyhow!("{}: material_map: {e}", p.file.display()))?),
            (Some(mat), None) => scene.materials.push(mat),
            (None, Some(_)) => {
                bail!("{}: a material map needs the model's `material` (its t = 0 end)", p.file.display())
            }
            (None, None) => scene.materials.extend(&m.materials),
        }
        let receivers = p.receivers.as_ref().map(|r| named_meshes(&m.meshes, r, &p.file)).transpose()?;
        for (k, mut mesh) in m.meshes.into_iter().enumerate() {
            if let Some(map) = &p.map {
                map.apply(&mut mesh);
            }
            scene.meshes.push(mesh);
            let skin = m.skins.get(k).cloned().flatten().map(|mut s| {
                for j in s.joints.iter_mut().flatten() {
                    *j += bone_base as u32;
                }
                s
            });
            scene.blockers.skins.push(skin);
            sphere_jobs.push((mesh_base + k, p.blockers.clone(), k, p.file.clone()));
            listed_receivers.push(receivers.as_ref().map(|r| r[k]));
        }
        for inst in &m.instances {
            scene.instances.push(Instance {
                mesh: mesh_base + inst.mesh,
                transform: p.transform * inst.transform,
                material: material_base + if p.material.is_some() { 0 } else { inst.material },
            });
        }
        let rest = m.rig.pose(None, 0.0);
        scene.blockers.bones.extend(&rest.bones);
        cameras.push((p.transform, p.file.clone(), m.cameras));
        if let Some(params) = p.lights {
            file_lights.push((p.transform, p.file.clone(), params, m.lights));
        }
        player.models.push(PlacedRig {
            rig: m.rig,
            placement: p.transform,
            instance_base,
            bone_base,
            choice: p.choice,
        });
    }
    player.bone_count = scene.blockers.bones.len();
    ensure!(!scene.instances.is_empty(), "the scene has no models");
    let (all_lo, all_hi) = posed_bounds(&scene);
    ensure!(all_lo.is_finite() && all_hi.is_finite(), "the models' bounds are not finite");
    // The models' own floors: they only receive (a flat floor encloses nothing to fit spheres to), a rectangle
    // one blocks as the engine's ground does (a plane blocker), and the framing and ground ignore them.
    let floors = find_floors(&scene);
    let receive_only: Vec<bool> = listed_receivers.iter().zip(&floors).map(|(l, f)| l.unwrap_or(*f)).collect();
    let (lo, hi) = match bounds_of(&scene, |m| !floors[m]) {
        (lo, hi) if lo.is_finite() && hi.is_finite() => (lo, hi),
        _ => (all_lo, all_hi),
    };
    scene.camera = choose_camera(&c.camera, &cameras, lo, hi)?;
    scene.blockers.spheres = vec![None; scene.meshes.len()];
    scene.blockers.plane_meshes = vec![false; scene.meshes.len()];
    for (mesh, blockers, k, file) in sphere_jobs {
        if receive_only[mesh] {
            if floors[mesh] && is_rectangle(&scene, mesh) {
                scene.blockers.plane_meshes[mesh] = true;
            }
            log::info!(
                "{}: mesh '{}' only receives (a floor, or listed in `receivers`): no blocker spheres{}",
                file.display(),
                scene.meshes[mesh].name,
                if scene.blockers.plane_meshes[mesh] { "; it blocks as a plane" } else { "" }
            );
            continue;
        }
        scene.blockers.spheres[mesh] = spheres_of(&scene.meshes[mesh], &blockers, k, &file, opts)?;
    }
    let (center, radius) = (0.5 * (all_lo + all_hi), 0.5 * (all_hi - all_lo).length());
    for (placement, file, params, lights) in file_lights {
        let scale = placement.to_scale_rotation_translation().0.abs().max_element();
        for l in &lights {
            if l.range.is_some() {
                log::warn!(
                    "{}: {}: its range is ignored (spherical lights have no cut-off)",
                    file.display(),
                    l.label()
                );
            }
            let light = l
                .sphere_light(placement, scale, &params, center, radius)
                .map_err(|e| anyhow!("{}: {e}", file.display()))?;
            scene.lights.push(light);
        }
    }
    let has_floor = floors.iter().any(|&f| f);
    let ground = match c.ground_mode {
        GroundMode::None => None,
        GroundMode::Auto if has_floor => None,
        GroundMode::Auto | GroundMode::Engine => c.ground,
    };
    if let Some(ground) = ground {
        let center = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo).max_element()).max(0.5) * 2.0;
        let mut plane = shapes::ground_plane(half, ground.subdivisions.clamp(1, MAX_GROUND_SUBDIVISIONS));
        let material = scene.materials.len();
        match &ground.map {
            Some(map) => {
                scene.materials.extend(map.palette(&ground.material).map_err(|e| anyhow!("ground.material_map: {e}"))?);
                map.apply(&mut plane);
            }
            None => scene.materials.push(ground.material),
        }
        scene.meshes.push(plane);
        scene.instances.push(Instance {
            mesh: scene.meshes.len() - 1,
            transform: Mat4::from_translation(Vec3::new(center.x, all_lo.y, center.z)),
            material,
        });
        scene.blockers.spheres.push(None);
        scene.blockers.skins.push(None);
        scene.blockers.plane_meshes.push(true);
    }
    let clips = player.moves().then(|| Arc::new(player));
    Ok(UserScene { scene, clips })
}

fn spheres_of(
    mesh: &Mesh,
    blockers: &Blockers,
    k: usize,
    file: &Path,
    opts: &UserOptions,
) -> Result<Option<Vec<Sphere>>> {
    match blockers {
        Blockers::Fit(0) => Ok(None),
        Blockers::Fit(n) => {
            let settings = FitSettings { count: *n, ..opts.fit.clone().unwrap_or_default() };
            let dir = opts.cache.clone().unwrap_or_else(cache_dir);
            let name = mesh.name.clone();
            let mut announced = false;
            let t0 = std::time::Instant::now();
            let cached = engine::scene::blockers::cached_spheres(mesh, &settings, &dir, &mut |p| {
                if !announced {
                    eprintln!(
                        "fitting {} blocker spheres to '{name}' of {} ({} triangles; at most {} iterations, each \
                         clustering every sample point and moving every sphere: cached after)...",
                        settings.count,
                        file.display(),
                        mesh.triangle_count(),
                        settings.max_iterations
                    );
                    announced = true;
                }
                let at = t0.elapsed().as_secs_f64();
                if p.setup {
                    eprintln!("  {at:6.1} s  {}", p.message);
                } else {
                    eprintln!(
                        "  {at:6.1} s  iteration {:>3}: outside volume {:.4e} {}",
                        p.iteration, p.outside_sum, p.message
                    );
                }
            })
            .with_context(|| format!("{}: fitting {n} blocker spheres to mesh '{name}' (--spheres)", file.display()))?;
            if let Some((asked, (surface, interior))) = cached.capped {
                eprintln!(
                    "warning: {}: mesh '{name}' supports at most {} blocker spheres (its {surface} surface and \
                     {interior} interior sample points): using {}, not the {asked} asked (--spheres, or a scene \
                     file's `spheres`)",
                    file.display(),
                    surface + interior,
                    cached.spheres.len()
                );
            }
            if cached.fitted {
                eprintln!("fitted {} spheres to '{name}', cached in {}", cached.spheres.len(), cached.file.display());
            }
            Ok(Some(cached.spheres))
        }
        Blockers::Files(files) => {
            let f = files.get(k).ok_or_else(|| {
                anyhow!(
                    "{}: {} sphere files for more meshes (mesh {k}, '{}', has none)",
                    file.display(),
                    files.len(),
                    mesh.name
                )
            })?;
            Ok(Some(engine::scene::blockers::spheres_for_mesh(mesh, f)?))
        }
    }
}

/// The default environment of file scenes (`--env` replaces it).
pub fn default_environment(env: Option<&Path>, assets: &Path) -> Result<LatLongMap> {
    let p = env.map(Path::to_path_buf).unwrap_or_else(|| assets.join("envmaps/courtyard.exr"));
    Ok(load_environment(&p)?)
}

/// `--scene FILE.{gltf,glb,obj}`: the model on a ground plane, framed, under the default environment.
pub fn single_model(path: &Path, env: Option<&Path>, assets: &Path, opts: &UserOptions) -> Result<UserScene> {
    let model = load_model(path)?;
    let choice = match &opts.clip {
        Some(name) => {
            ClipChoice::One(model.rig.clip_index(name).map_err(|e| anyhow!("{}: --clip: {e}", path.display()))?)
        }
        None => ClipChoice::All,
    };
    let composition = Composition {
        models: vec![Placement {
            model,
            file: path.to_path_buf(),
            transform: Mat4::IDENTITY,
            material: None,
            map: None,
            blockers: Blockers::Fit(opts.spheres.unwrap_or(DEFAULT_SPHERES)),
            choice,
            lights: Some(LightParams::default()),
            receivers: None,
        }],
        environment: default_environment(env, assets)?,
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: Vec::new(),
        camera: match &opts.camera {
            None => CameraSetup::File { model: Some(0), key: None },
            Some(CameraChoice::Auto) => CameraSetup::Auto,
            Some(CameraChoice::File(k)) => CameraSetup::File { model: Some(0), key: Some(k.clone()) },
        },
        ground: Some(Ground::plain(Material::diffuse(Vec3::splat(0.6)))),
        ground_mode: opts.ground.unwrap_or(GroundMode::Auto),
    };
    assemble(composition, opts)
}

// ---------------------------------------------------------------------------------------------------------------
// The scene description file.

/// A scene description (`.toml`). Every key is optional except `model`; unknown keys are errors.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub camera: Option<CameraSpec>,
    pub environment: Option<EnvironmentSpec>,
    pub ground: Option<GroundSpec>,
    #[serde(default)]
    pub light: Vec<LightSpec>,
    pub model: Vec<ModelSpec>,
}

/// `[camera]`: `eye` and `target` (and `fov_y`), or a camera of a model's glTF file (`model`, `name`), or
/// `auto = true` (framed).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    pub eye: Option<[f32; 3]>,
    pub target: Option<[f32; 3]>,
    pub fov_y: Option<f32>,
    /// The model whose glTF camera to use (an index into `[[model]]`; default: the first model that has it).
    pub model: Option<usize>,
    /// The glTF camera: its index in the file's `cameras` or its name (default: the file's first camera).
    pub name: Option<CameraName>,
    /// `true`: framed automatically (as with no `[camera]`).
    pub auto: Option<bool>,
}

/// `camera.name`: an index into a glTF file's `cameras`, or a camera's (or its node's) name.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(untagged)]
pub enum CameraName {
    Index(i64),
    Name(String),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSpec {
    /// `.exr` or `.hdr`, relative to the scene file (`--env` replaces it).
    pub file: Option<String>,
    pub intensity: Option<f32>,
    /// Degrees about +y.
    pub rotation: Option<f32>,
    /// Environment lights (the bright regions taken out as spherical lights, for the techniques whose
    /// `env_lights` option is on): at most this many, K (0: none), or `false` for none [default: 8].
    pub lights: Option<LightsKey>,
    /// A texel is bright above this many times the mean radiance [default: 4].
    pub light_threshold: Option<f64>,
    /// A light must carry at least this share of the power, in % [default: 1].
    pub light_share: Option<f64>,
    /// Bright regions wider than this angular radius (degrees) are split into several lights [default: 15].
    pub light_radius: Option<f64>,
}

/// `environment.lights`: a count, or `false` (none) / `true` (the default count).
#[derive(Debug, Deserialize, Clone, Copy, PartialEq)]
#[serde(untagged)]
pub enum LightsKey {
    On(bool),
    Count(i64),
}

impl EnvironmentSpec {
    /// The decomposition's parameters from the keys given (the defaults for the others), each range-checked.
    /// The ranges are those of the `--env-light*` options (one table: [`limits`]).
    pub fn env_lights(&self) -> Result<EnvLightParams> {
        let mut p = EnvLightParams::default();
        match self.lights {
            None | Some(LightsKey::On(true)) => {}
            Some(LightsKey::On(false)) => p.max_lights = 0,
            Some(LightsKey::Count(k)) => {
                let r = &limits::ENV_LIGHTS;
                r.check(k as f64).map_err(|m| anyhow!("{}: {m} (or true/false)", r.key))?;
                p.max_lights = k as usize;
            }
        }
        if let Some(t) = self.light_threshold {
            limits::ENV_LIGHT_THRESHOLD.check_key(limits::ENV_LIGHT_THRESHOLD.key, &[t])?;
            p.threshold = t;
        }
        if let Some(s) = self.light_share {
            limits::ENV_LIGHT_SHARE.check_key(limits::ENV_LIGHT_SHARE.key, &[s])?;
            p.min_share = s / 100.0;
        }
        if let Some(r) = self.light_radius {
            limits::ENV_LIGHT_RADIUS.check_key(limits::ENV_LIGHT_RADIUS.key, &[r])?;
            p.max_radius = r.to_radians();
        }
        p.check().map_err(|e| anyhow!("environment: {e}"))?;
        Ok(p)
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundSpec {
    #[serde(default = "yes")]
    pub visible: bool,
    /// `"auto"` (default: the engine's ground unless a model brings a floor), `"engine"` or `"none"`.
    pub mode: Option<String>,
    pub material: Option<MaterialSpec>,
    /// Quads per side (default 16, at most 512). Signed, so that a negative value gets the range's message.
    pub subdivisions: Option<i64>,
    pub material_map: Option<MaterialMapSpec>,
}

/// `material_map = { file = "map.png", material = { ... }, levels = 32 }`: the PNG's red channel t blends the
/// owner's `material` (t = 0) into `material` (t = 1; keys not given are the owner's), both Lafortune, per
/// vertex in `levels` steps (`engine::scene::material_map`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialMapSpec {
    /// An 8-bit PNG, relative to the scene file.
    pub file: String,
    pub material: MaterialSpec,
    pub levels: Option<i64>,
}

fn yes() -> bool {
    true
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    pub center: [f32; 3],
    pub radius: f32,
    pub radiance: [f32; 3],
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    pub diffuse: Option<[f32; 3]>,
    pub specular: Option<[f32; 3]>,
    pub shininess: Option<f32>,
    /// A `--brdf` spec (`cook-torrance:roughness=0.2`, ...).
    pub brdf: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelSpec {
    /// `.gltf`, `.glb` or `.obj`, relative to the scene file.
    pub file: String,
    #[serde(default)]
    pub translation: [f32; 3],
    /// Degrees about x, then y, then z.
    #[serde(default)]
    pub rotation: [f32; 3],
    #[serde(default = "unit_scale")]
    pub scale: [f32; 3],
    pub material: Option<MaterialSpec>,
    /// Blends `material` spatially across each mesh (projected from above onto the mesh's x–z bounds).
    pub material_map: Option<MaterialMapSpec>,
    /// Blocker spheres fitted per mesh (0: none; the range of `--spheres`). Signed, so that a negative value
    /// gets the range's message.
    pub spheres: Option<i64>,
    /// Sphere files, one per mesh, relative to the scene file (instead of `spheres`).
    pub sphere_files: Option<Vec<String>>,
    /// The clip to play (`"all"`: every clip in turn, the default; `"none"`: stay at rest).
    pub clip: Option<String>,
    /// Whether the file's `KHR_lights_punctual` lights are used (default true).
    pub lights: Option<bool>,
    /// Every point light's radius (file units, > 0), instead of the nodes' `extras.radius` or 0.1.
    pub light_radius: Option<f32>,
    /// Multiplies the file's light intensities (default 1: engine radiance = nits / 683).
    pub light_intensity: Option<f32>,
    /// Directional lights' angular radius in degrees, (0, 45] (default 0.27, the sun's).
    pub light_angle: Option<f32>,
    /// Meshes that only receive: no blocker spheres (names as `name#primitive` or the glTF mesh's name). Default:
    /// the model's floor, if found.
    pub receivers: Option<Vec<String>>,
    /// Seconds into `clip` at t = 0 (needs a named clip): characters of a crowd out of step.
    pub clip_phase: Option<f32>,
}

fn unit_scale() -> [f32; 3] {
    [1.0; 3]
}

impl MaterialMapSpec {
    /// The mapping of `owner`'s material `base` (`key` names the owner in messages).
    fn build(&self, base: Option<&Material>, key: &str, rel: &dyn Fn(&str) -> PathBuf) -> Result<MaterialMapping> {
        let base = base.ok_or_else(|| anyhow!("{key}.material_map needs {key}.material (its t = 0 end)"))?;
        let b = self.material.build_from(*base, &format!("{key}.material_map.material"))?;
        let levels = self.levels.unwrap_or(DEFAULT_MAP_LEVELS as i64);
        limits::MAP_LEVELS.check_key(&format!("{key}.material_map.levels"), &[levels as f64])?;
        let levels = levels as u32;
        let map = MaterialMap::load(&rel(&self.file)).with_context(|| format!("{key}.material_map.file"))?;
        let mapping = MaterialMapping { map, b, levels };
        mapping.palette(base).map_err(|e| anyhow!("{key}.material_map: {e}"))?;
        Ok(mapping)
    }
}

impl MaterialSpec {
    fn build(&self, key: &str) -> Result<Material> {
        self.build_from(Material::diffuse(Vec3::splat(0.6)), key)
    }

    /// `base` with the keys given replaced.
    fn build_from(&self, base: Material, key: &str) -> Result<Material> {
        let mut m = base;
        // The one rule for material values (engine::scene::check_material_values): non-finite ones are refused.
        let finite = |what: &str, v: &[f32]| engine::scene::check_material_values(&format!("{key}.{what}"), v);
        let color = |v: [f32; 3], what: &str| -> Result<Vec3> {
            finite(what, &v).map_err(|e| anyhow!(e))?;
            limits::COLOUR.check_key(&format!("{key}.{what}"), &v.map(f64::from))?;
            Ok(Vec3::from(v))
        };
        if let Some(d) = self.diffuse {
            m.diffuse = color(d, "diffuse")?;
        }
        if let Some(s) = self.specular {
            m.specular = color(s, "specular")?;
        }
        if let Some(s) = self.shininess {
            finite("shininess", &[s]).map_err(|e| anyhow!(e))?;
            limits::SHININESS.check_key(&format!("{key}.shininess"), &[s as f64])?;
            m.shininess = s;
        }
        if let Some(b) = &self.brdf {
            m.apply_brdf_spec(b).map_err(|e| anyhow!("{key}.brdf: {e}"))?;
        }
        Ok(m)
    }
}

/// Parse a scene file's text (strict). Errors give the line, the column and the key (the toml crate's message,
/// with quoted input cut by `engine::io::shorten`: it showed a 100 kB key or line whole).
pub fn parse_scene_file(text: &str) -> std::result::Result<SceneFile, String> {
    toml::from_str(text).map_err(|e| engine::io::shorten(&e.to_string()))
}

/// Rotate a lat-long environment about +y by `degrees` ([`LatLongMap::rotated_y`]).
pub fn rotate_environment(env: &LatLongMap, degrees: f32) -> LatLongMap {
    env.rotated_y(degrees)
}

/// `--scene FILE.toml`.
pub fn scene_file(path: &Path, env: Option<&Path>, assets: &Path, opts: &UserOptions) -> Result<UserScene> {
    let text = engine::io::read_to_string(path, engine::io::Limit::SCENE)?;
    let spec = parse_scene_file(&text).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    build_scene_file(path, spec, env, assets, opts).with_context(|| format!("scene file {}", path.display()))
}

fn build_scene_file(
    path: &Path,
    spec: SceneFile,
    env: Option<&Path>,
    assets: &Path,
    opts: &UserOptions,
) -> Result<UserScene> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let rel = |f: &str| if Path::new(f).is_absolute() { PathBuf::from(f) } else { dir.join(f) };
    ensure!(!spec.model.is_empty(), "no [[model]]: a scene needs at least one");
    let mut models = Vec::new();
    let mut clip_found = opts.clip.is_none();
    for (i, m) in spec.model.iter().enumerate() {
        let key = format!("model[{i}]");
        let file = rel(&m.file);
        let model = load_model(&file).with_context(|| format!("{key}.file"))?;
        // The ranges of every numeric key: one table (limits), shared with the command line.
        let ranged = |v: [f32; 3], range: &limits::Range, what: &str| -> Result<Vec3> {
            range.check_key(&format!("{key}.{what}"), &v.map(f64::from))?;
            Ok(Vec3::from(v))
        };
        let scale = ranged(m.scale, &limits::MODEL_SCALE, "scale")?;
        let r = ranged(m.rotation, &limits::MODEL_ROTATION, "rotation")?;
        let rotation = Quat::from_euler(EulerRot::ZYX, r.z.to_radians(), r.y.to_radians(), r.x.to_radians());
        let translation = ranged(m.translation, &limits::MODEL_TRANSLATION, "translation")?;
        let transform = Mat4::from_scale_rotation_translation(scale, rotation, translation);
        let material = m.material.as_ref().map(|s| s.build(&format!("{key}.material"))).transpose()?;
        let map = m.material_map.as_ref().map(|s| s.build(material.as_ref(), &key, &rel)).transpose()?;
        let blockers = match (&m.spheres, &m.sphere_files) {
            (Some(_), Some(_)) => bail!("{key}: give `spheres` or `sphere_files`, not both"),
            (_, Some(files)) => {
                ensure!(
                    files.len() == model.meshes.len(),
                    "{key}.sphere_files: {} files for {} meshes",
                    files.len(),
                    model.meshes.len()
                );
                Blockers::Files(files.iter().map(|f| rel(f)).collect())
            }
            (Some(n), None) => {
                limits::MODEL_SPHERES.check_key(&format!("{key}.spheres"), &[*n as f64])?;
                Blockers::Fit(*n as usize)
            }
            (None, None) => Blockers::Fit(opts.spheres.unwrap_or(DEFAULT_SPHERES)),
        };
        let choice = match (opts.clip.as_deref(), m.clip.as_deref()) {
            (Some(name), _) => match model.rig.clip_index(name) {
                Ok(c) => {
                    clip_found = true;
                    ClipChoice::One(c)
                }
                Err(_) => ClipChoice::Still,
            },
            (None, None | Some("all")) => ClipChoice::All,
            (None, Some("none")) => ClipChoice::Still,
            (None, Some(name)) => ClipChoice::One(model.rig.clip_index(name).map_err(|e| anyhow!("{key}.clip: {e}"))?),
        };
        let choice = match (m.clip_phase, choice) {
            (None, c) => c,
            (Some(p), _) if !p.is_finite() => bail!("{key}.clip_phase: {p} is not finite"),
            (Some(p), ClipChoice::One(c)) => ClipChoice::Phased(c, p),
            (Some(_), _) => bail!("{key}.clip_phase needs one named clip (`clip = \"NAME\"`)"),
        };
        let lights = match m.lights {
            Some(false) => None,
            _ => Some(light_params(m, &key)?),
        };
        models.push(Placement {
            model,
            file,
            transform,
            material,
            map,
            blockers,
            choice,
            lights,
            receivers: m.receivers.clone(),
        });
    }
    ensure!(clip_found, "--clip {}: no model of the scene has that clip", opts.clip.as_deref().unwrap_or(""));
    let (mut environment, mut intensity, mut env_lights) = (None, 1.0, EnvLightParams::default());
    if let Some(e) = &spec.environment {
        env_lights = e.env_lights()?;
        if let Some(i) = e.intensity {
            limits::ENV_INTENSITY.check_key(limits::ENV_INTENSITY.key, &[i as f64])?;
            intensity = i;
        }
        let file = env.map(Path::to_path_buf).or_else(|| e.file.as_deref().map(rel));
        let map = match file {
            Some(f) => load_environment(&f).context("environment.file")?,
            None => default_environment(None, assets)?,
        };
        environment = Some(match e.rotation {
            Some(r) => {
                limits::ENV_ROTATION.check_key(limits::ENV_ROTATION.key, &[r as f64])?;
                rotate_environment(&map, r)
            }
            None => map,
        });
    }
    let environment = match environment {
        Some(e) => e,
        None => default_environment(env, assets)?,
    };
    // The intensity times the map's brightest texel is the radiance shading meets: within what f32 carries.
    let brightest = engine::scene::brightest_texel(&environment);
    ensure!(
        intensity as f64 * brightest as f64 <= engine::scene::MAX_RADIANCE as f64,
        "environment.intensity: {intensity} × the map's brightest texel {brightest:e} = {:e}, more than the {:e} \
         f32 shading carries",
        intensity as f64 * brightest as f64,
        engine::scene::MAX_RADIANCE
    );
    let mut lights = Vec::new();
    for (i, l) in spec.light.iter().enumerate() {
        limits::LIGHT_CENTER.check_key(&format!("light[{i}].center"), &l.center.map(f64::from))?;
        limits::LIGHT_RADIUS.check_key(&format!("light[{i}].radius"), &[l.radius as f64])?;
        limits::LIGHT_RADIANCE.check_key(&format!("light[{i}].radiance"), &l.radiance.map(f64::from))?;
        lights.push(SphereLight { center: l.center.into(), radius: l.radius, radiance: l.radiance.into() });
    }
    let camera = match (&opts.camera, &spec.camera) {
        (Some(CameraChoice::Auto), _) => CameraSetup::Auto,
        (Some(CameraChoice::File(k)), _) => CameraSetup::File { model: None, key: Some(k.clone()) },
        (None, Some(c)) => camera_setup(c, spec.model.len())?,
        (None, None) => CameraSetup::Auto,
    };
    let mut ground_mode = GroundMode::Auto;
    if let Some(m) = spec.ground.as_ref().and_then(|g| g.mode.as_deref()) {
        ground_mode = m.parse().map_err(|e| anyhow!("ground.mode: {e}"))?;
    }
    let ground_mode = opts.ground.unwrap_or(ground_mode);
    let ground = match &spec.ground {
        Some(g) if !g.visible => None,
        Some(g) => {
            let material = match &g.material {
                Some(m) => m.build("ground.material")?,
                None => Material::diffuse(Vec3::splat(0.6)),
            };
            let subdivisions = g.subdivisions.unwrap_or(DEFAULT_GROUND_SUBDIVISIONS as i64);
            limits::GROUND_SUBDIVISIONS.check_key("ground.subdivisions", &[subdivisions as f64])?;
            let subdivisions = subdivisions as u32;
            let map = g.material_map.as_ref().map(|s| s.build(Some(&material), "ground", &rel)).transpose()?;
            Some(Ground { material, subdivisions, map })
        }
        None => Some(Ground::plain(Material::diffuse(Vec3::splat(0.6)))),
    };
    let composition = Composition {
        models,
        environment,
        environment_intensity: intensity,
        env_lights,
        lights,
        camera,
        ground,
        ground_mode,
    };
    assemble(composition, opts)
}

/// `[camera]` of a scene file with `models` models.
fn camera_setup(c: &CameraSpec, models: usize) -> Result<CameraSetup> {
    let file = c.model.is_some() || c.name.is_some();
    let fixed = c.eye.is_some() || c.target.is_some() || c.fov_y.is_some();
    match (c.auto, file, fixed) {
        (Some(true), false, false) => return Ok(CameraSetup::Auto),
        (Some(_), _, _) => bail!("camera.auto: give `auto = true` alone (or leave [camera] out)"),
        (None, true, true) => {
            bail!("camera: give `eye`/`target`/`fov_y` or a model's camera (`model`, `name`), not both")
        }
        _ => {}
    }
    if file {
        if let Some(m) = c.model {
            ensure!(m < models, "camera.model: {m} is not a model index (the scene has {models})");
        }
        let key = match &c.name {
            None => None,
            Some(CameraName::Index(i)) => {
                ensure!(*i >= 0, "camera.name: {i} is not a camera index");
                Some(CameraKey::Index(*i as usize))
            }
            Some(CameraName::Name(n)) => Some(CameraKey::Name(n.clone())),
        };
        // A model named without a camera name takes that model's first camera, and must have one.
        return Ok(CameraSetup::File { model: c.model, key: Some(key.unwrap_or(CameraKey::First)) });
    }
    let (Some(eye), Some(target)) = (c.eye, c.target) else {
        bail!("camera: give both `eye` and `target` (or `model`/`name` for a model's camera, or `auto = true`)");
    };
    let fov = c.fov_y.unwrap_or(45.0);
    limits::CAMERA_EYE.check_key("camera.eye", &eye.map(f64::from))?;
    limits::CAMERA_TARGET.check_key("camera.target", &target.map(f64::from))?;
    limits::CAMERA_FOV_Y.check_key("camera.fov_y", &[fov as f64])?;
    let ok = eye.iter().chain(&target).all(|x| x.is_finite()) && fov > 1.0 && fov < 179.0;
    ensure!(ok, "camera: eye and target must be finite and fov_y in (1, 179) degrees");
    ensure!(Vec3::from(eye) != Vec3::from(target), "camera: eye and target are the same point");
    Ok(CameraSetup::Fixed(Camera { eye: eye.into(), target: target.into(), fov_y_degrees: fov }))
}

/// A model's light keys (`lights`, `light_radius`, `light_intensity`, `light_angle`) as [`LightParams`].
fn light_params(m: &ModelSpec, key: &str) -> Result<LightParams> {
    let mut p = LightParams::default();
    if let Some(r) = m.light_radius {
        ensure!(r.is_finite() && r > 0.0 && r < 1e6, "{key}.light_radius: {r} is not in (0, 1e6)");
        p.radius_override = Some(r);
    }
    if let Some(i) = m.light_intensity {
        ensure!(i.is_finite() && (0.0..=1e9).contains(&i), "{key}.light_intensity: {i} is not in [0, 1e9]");
        p.exposure *= i;
    }
    if let Some(a) = m.light_angle {
        ensure!(a.is_finite() && a > 0.0 && a <= 45.0, "{key}.light_angle: {a}° is not in (0, 45]");
        p.directional_angle_degrees = a;
    }
    Ok(p)
}

/// Build `--scene SPEC` when it names a file.
pub fn build_file(spec: &str, env: Option<&Path>, assets: &Path, opts: &UserOptions) -> Result<UserScene> {
    let path = Path::new(spec);
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    if SCENE_EXTENSIONS.contains(&ext.as_str()) {
        scene_file(path, env, assets, opts)
    } else {
        single_model(path, env, assets, opts)
    }
}
