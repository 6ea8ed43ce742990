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
}

/// Load a `.gltf`, `.glb` or `.obj` file as one model.
pub fn load_model(path: &Path) -> Result<Model> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    match ext.as_str() {
        "gltf" | "glb" => {
            let g = engine::scene::load_gltf(path, 0)?;
            Ok(Model { meshes: g.meshes, materials: g.materials, instances: g.instances, skins: g.skins, rig: g.rig })
        }
        "obj" => {
            let (meshes, materials) = engine::scene::load_obj_with_materials(path)?;
            let instances =
                (0..meshes.len()).map(|i| Instance { mesh: i, transform: Mat4::IDENTITY, material: i }).collect();
            let skins = vec![None; meshes.len()];
            let rig = Rig { instance_nodes: vec![None; meshes.len()], ..Default::default() };
            Ok(Model { meshes, materials, instances, skins, rig })
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
    pub camera: Option<Camera>,
    /// A ground plane under the models' rest bounds.
    pub ground: Option<Ground>,
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

/// World-space bounds of `scene` at rest, skinned vertices posed by the rest bones.
pub fn posed_bounds(scene: &Scene) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for inst in &scene.instances {
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
    }
    (lo, hi)
}

/// A camera looking at the middle of `lo..hi` from the front and above, far enough to see all of it.
pub fn framing_camera(lo: Vec3, hi: Vec3) -> Camera {
    let fov_y_degrees: f32 = 45.0;
    let target = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-3);
    let distance = 1.15 * radius / (0.5 * fov_y_degrees.to_radians()).sin();
    Camera { eye: target + Vec3::new(0.0, 0.45, 1.0).normalize() * distance, target, fov_y_degrees }
}

/// Build the scene: meshes, skins and bones of every model (joint indices offset into one bone list), the
/// ground, camera, and blocker spheres (fitted with progress on stderr, or loaded and checked against their mesh).
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
    let (lo, hi) = posed_bounds(&scene);
    ensure!(lo.is_finite() && hi.is_finite(), "the models' bounds are not finite");
    scene.camera = c.camera.unwrap_or_else(|| framing_camera(lo, hi));
    scene.blockers.spheres = vec![None; scene.meshes.len()];
    scene.blockers.plane_meshes = vec![false; scene.meshes.len()];
    for (mesh, blockers, k, file) in sphere_jobs {
        scene.blockers.spheres[mesh] = spheres_of(&scene.meshes[mesh], &blockers, k, &file, opts)?;
    }
    if let Some(ground) = c.ground {
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
            transform: Mat4::from_translation(Vec3::new(center.x, lo.y, center.z)),
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
        }],
        environment: default_environment(env, assets)?,
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: Vec::new(),
        camera: None,
        ground: Some(Ground::plain(Material::diffuse(Vec3::splat(0.6)))),
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

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    #[serde(default = "default_fov")]
    pub fov_y: f32,
}

fn default_fov() -> f32 {
    45.0
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
        models.push(Placement { model, file, transform, material, map, blockers, choice });
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
    let camera = match &spec.camera {
        Some(c) => {
            limits::CAMERA_EYE.check_key("camera.eye", &c.eye.map(f64::from))?;
            limits::CAMERA_TARGET.check_key("camera.target", &c.target.map(f64::from))?;
            limits::CAMERA_FOV_Y.check_key("camera.fov_y", &[c.fov_y as f64])?;
            ensure!(Vec3::from(c.eye) != Vec3::from(c.target), "camera: eye and target are the same point");
            Some(Camera { eye: c.eye.into(), target: c.target.into(), fov_y_degrees: c.fov_y })
        }
        None => None,
    };
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
    let composition =
        Composition { models, environment, environment_intensity: intensity, env_lights, lights, camera, ground };
    assemble(composition, opts)
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
