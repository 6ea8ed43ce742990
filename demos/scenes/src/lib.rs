//! The `scenes` crate: the demo scenes (one file per scene, one entry each in the registry [`SCENES`]), the
//! procedural battle characters ([`characters`]) and the glTF writer ([`gltf_writer`]), user models and scene files
//! ([`user`]), the environment-light options ([`env_lights`]), the assets folder, and the one logger and exit
//! helper that every binary calls.
//!
//! Everything that names scenes reads the registry: `--scene` of `demo`, `compare` and `sphere_scaling`
//! (accepted values and the `--help` list with summaries), `demo --animate`'s help and warning, the scene
//! names of the report sweep (tools/report/sweep.json, checked before it runs), and the tests, which build
//! every registered scene, pose its motion and render it (demos/tests/scenes.rs, tests/tests/scenes.rs).
//! Analytic scenes that only tests use (`sphere_over_plane`, `sheet_over_plane`) are fixtures in
//! tests/src/fixtures.rs, not demo scenes.
//!
//! # Adding a scene
//!
//! Write `demos/scenes/src/NAME.rs` after the template below, add `pub mod NAME;` here and `NAME::SCENE` to
//! [`SCENES`]. The scene is then accepted by `--scene NAME` everywhere, listed in every `--help`, and built,
//! posed and rendered by the tests. Meshes come from `engine::scene::load_obj` / `load_gltf` or
//! [`shapes`]; assets go in `assets/` (read through [`SceneInputs::assets`]) with their credits in
//! `assets/README.md`. The template is compiled and run as a doctest, so it stays current:
//!
//! ```
//! // demos/scenes/src/NAME.rs
//! //! `NAME`: what the scene shows and why it exists (the hard case it exercises).
//!
//! use scenes::{shapes, Motion, Pose, Rest, SceneEntry, SceneInputs};
//! use engine::blockers::Sphere;
//! use engine::scene::{load_environment, Camera, Instance, Material, Scene, SceneBlockers, SphereLight};
//! use glam::{DVec3, Mat4, Vec3};
//!
//! pub const SCENE: SceneEntry = SceneEntry {
//!     name: "NAME",
//!     // One line: shown by `--help` next to the name.
//!     summary: "a ball over a ground plane under the courtyard and one light",
//!     build,
//!     // `None` for a static scene.
//!     motion: Some(Motion { summary: "the ball bobs", pose: bob }),
//! };
//!
//! fn build(inputs: &SceneInputs) -> anyhow::Result<Scene> {
//!     // Honour `--env` (inputs.env) or reject it with an error, never ignore it silently.
//!     let env = inputs.env.map(Into::into).unwrap_or_else(|| inputs.assets.join("envmaps/courtyard.exr"));
//!     let ball = Mat4::from_translation(Vec3::new(0.0, 0.6, 0.0)) * Mat4::from_scale(Vec3::splat(0.4));
//!     Ok(Scene {
//!         meshes: vec![shapes::ground_plane(2.0, 16), shapes::uv_sphere(32)],
//!         materials: vec![Material::diffuse(Vec3::splat(0.6)), Material::glossy(Vec3::splat(0.7), 0.2, 100.0)],
//!         instances: vec![
//!             Instance { mesh: 0, transform: Mat4::IDENTITY, material: 0 },
//!             Instance { mesh: 1, transform: ball, material: 1 },
//!         ],
//!         environment: load_environment(&env)?,
//!         environment_intensity: 1.0,
//!         env_lights: Default::default(),
//!         lights: vec![SphereLight { center: Vec3::new(1.0, 2.0, 0.5), radius: 0.2, radiance: Vec3::splat(20.0) }],
//!         // Blocker spheres per mesh in object space (None: casts no sphere shadow); a real mesh gets a fitted
//!         // set: engine::scene::blockers::fitted_spheres(&mesh, &FitSettings::default(), &cache_path).
//!         blockers: SceneBlockers {
//!             spheres: vec![None, Some(vec![Sphere::new(DVec3::ZERO, 1.0)])],
//!             ..Default::default()
//!         },
//!         camera: Camera { eye: Vec3::new(0.0, 1.2, 3.0), target: Vec3::new(0.0, 0.4, 0.0), fov_y_degrees: 45.0 },
//!     })
//! }
//!
//! /// Instance 1 (the ball) moves up and down around its rest transform.
//! fn bob(rest: &Rest, t: f32) -> Pose {
//!     let lift = Mat4::from_translation(Vec3::new(0.0, 0.2 * t.sin(), 0.0));
//!     Pose { transforms: vec![(1, lift * rest.transforms[1])], bones: None }
//! }
//! # // The registry's CPU checks (demos/tests/scenes.rs runs them on every registered scene):
//! # let assets = scenes::assets_dir();
//! # let options = engine::options::parse("NAME", &[], &[]).unwrap(); // a scene without options
//! # let scene = (SCENE.build)(&SceneInputs { env: None, assets: &assets, options: &options }).unwrap();
//! # scenes::check(&SCENE, &scene).unwrap();
//! ```

use anyhow::Result;
use engine::scene::Scene;
use glam::Mat4;
use std::path::Path;
use std::path::PathBuf;

pub mod characters;
pub mod env_lights;
pub mod gltf_writer;

/// The project's `assets/` folder (`ENGINE_ASSETS` overrides).
pub fn assets_dir() -> PathBuf {
    std::env::var_os("ENGINE_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets"))
}

/// Install the logger of a binary: `RUST_LOG` as `env_logger` reads it, warnings and errors when it is unset
/// (the engine reports dropped triangles, recomputed normals, missing materials and the validation-layer
/// fallback as warnings). Every binary of the workspace whose code can log calls this first (demos/tests/logging.rs checks it).
///
/// A line may quote input (a mesh or material name from a file): it is written as `engine::io::shorten` writes
/// messages, control characters escaped, so that no file can send escape sequences to the terminal.
pub fn init_logging() {
    use std::io::Write;
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn"))
        .format(|buf, record| {
            let message = engine::io::shorten(&record.args().to_string());
            writeln!(buf, "[{} {:5} {}] {message}", buf.timestamp(), record.level(), record.target())
        })
        .init();
}

/// The binaries' `main`: print the error with its causes as `error: …` and exit with status 1. Input quoted in
/// the message is cut short (`engine::io::shorten`).
pub fn exit_on_error(result: anyhow::Result<()>) {
    if let Err(e) = result {
        eprintln!("error: {}", engine::io::shorten(&format!("{e:#}")));
        std::process::exit(1);
    }
}

/// The materials `--brdf` and the viewer's `B` key change: every glossy material of the scene (k_s > 0, e.g.
/// chess's white and black pieces), or material 0 when none is glossy.
pub fn brdf_materials(scene: &Scene) -> Vec<usize> {
    let glossy: Vec<usize> =
        scene.materials.iter().enumerate().filter(|(_, m)| m.specular.max_element() > 0.0).map(|(i, _)| i).collect();
    if glossy.is_empty() && !scene.materials.is_empty() {
        vec![0]
    } else {
        glossy
    }
}

/// Set the specular BRDF of the scene's [`brdf_materials`] from a `--brdf` spec
/// ([`engine::scene::Material::apply_brdf_spec`]; keys not given keep each material's values).
pub fn apply_brdf(scene: &mut Scene, spec: &str) -> anyhow::Result<()> {
    let targets = brdf_materials(scene);
    if targets.is_empty() {
        anyhow::bail!("--brdf: the scene has no material");
    }
    for i in targets {
        scene.materials[i].apply_brdf_spec(spec).map_err(anyhow::Error::msg)?;
    }
    Ok(())
}

/// `--env-spin`: turn the renderer's environment to `deg_per_s` × `t` degrees (modulo 360) from where the scene put
/// it, unless it is there already (`Renderer::set_environment_rotation`: the maps are rebuilt and the technique
/// prepared again).
pub fn spin_environment(
    gpu: &engine::gpu::Gpu,
    renderer: &mut engine::renderer::Renderer,
    deg_per_s: f32,
    t: f32,
) -> engine::gpu::Result<()> {
    let degrees = (deg_per_s * t).rem_euclid(360.0);
    if degrees != renderer.environment_rotation() {
        renderer.set_environment_rotation(gpu, degrees)?;
    }
    Ok(())
}

/// The BRDFs the viewer's `B` key steps through after the scene's own: diffuse, highly specular,
/// anisotropic, several Lafortune lobes, microfacet (ISG Fig. 7's range).
pub const BRDF_PRESETS: &[(&str, &str)] = &[
    ("diffuse", "blinn-phong:ks=0"),
    ("Blinn-Phong s=1000", "blinn-phong:s=1000,ks=0.5"),
    ("Ashikhmin-Shirley nu=1000 nv=10", "ashikhmin-shirley:nu=1000,nv=10,ks=0.5"),
    ("Lafortune anisotropic e=60", "lafortune:cx=-1,cy=-0.85,cz=1,e=60,ks=0.5,tangent=1/0/0"),
    (
        "Lafortune 3 lobes: sharp, broad off-specular, retro",
        "lafortune:cx=-1,cy=-1,cz=1,e=200,ks=0.3,w1=2,cx1=-0.8,cy1=-0.8,cz1=0.8,e1=8,w2=1,cx2=0.9,cy2=0.9,cz2=0.9,e2=20",
    ),
    ("Cook-Torrance GGX 0.2", "cook-torrance:roughness=0.2,ndf=ggx,ks=0.5"),
];

/// The viewer's BRDF switch: the scene's own materials, then each of [`BRDF_PRESETS`] applied to its
/// [`brdf_materials`] (chosen once, from the scene as built), then the scene's own again.
#[derive(Clone, Debug)]
pub struct BrdfCycle {
    own: Vec<engine::scene::Material>,
    targets: Vec<usize>,
    /// 0: the scene's own; k: preset k − 1.
    step: usize,
}

impl BrdfCycle {
    pub fn new(scene: &Scene) -> Self {
        Self { own: scene.materials.clone(), targets: brdf_materials(scene), step: 0 }
    }

    /// What the current step shows.
    pub fn label(&self) -> &'static str {
        if self.step == 0 {
            "scene's own"
        } else {
            BRDF_PRESETS[self.step - 1].0
        }
    }

    /// Advance one step and return the materials to upload (every preset parses: checked by a test).
    pub fn step(&mut self) -> anyhow::Result<Vec<engine::scene::Material>> {
        self.step = (self.step + 1) % (BRDF_PRESETS.len() + 1);
        let mut materials = self.own.clone();
        if self.step > 0 {
            for &i in &self.targets {
                materials[i].apply_brdf_spec(BRDF_PRESETS[self.step - 1].1).map_err(anyhow::Error::msg)?;
            }
        }
        Ok(materials)
    }
}

pub mod arm;
pub mod battle;
pub mod bunny;
pub mod chess;
pub mod cloth;
pub mod crowd;
pub mod furnace;
pub mod lamp;
pub mod limits;
pub mod shapes;
pub mod sheet;
pub mod sphere;
pub mod spheres;
pub mod user;

/// Every demo scene, in the order `--help` lists them.
pub const SCENES: &[SceneEntry] = &[
    bunny::SCENE,
    lamp::SCENE,
    lamp::SCENE_ONE,
    spheres::SCENE,
    sheet::SCENE,
    arm::SCENE,
    sphere::SCENE,
    furnace::SCENE,
    chess::SCENE,
    cloth::SCENE,
    battle::SCENE,
    crowd::SCENE,
];

/// The scenes that take options (`--scene NAME:key=value,...`), with their schemas: a table beside the registry,
/// so that no entry has to change for a scene to have none. Any other scene given options is an error.
pub const SCENE_OPTIONS: &[(&str, &[engine::options::OptionSpec])] = &[("crowd", crowd::OPTIONS)];

/// A registered scene.
#[derive(Clone, Copy)]
pub struct SceneEntry {
    /// The `--scene` name.
    pub name: &'static str,
    /// One line for `--help`.
    pub summary: &'static str,
    /// Build the scene at its rest pose.
    pub build: fn(&SceneInputs) -> Result<Scene>,
    /// What `--animate` does to it (`None`: static).
    pub motion: Option<Motion>,
}

/// What a scene builder may read besides its own code.
#[derive(Clone, Copy, Debug)]
pub struct SceneInputs<'a> {
    /// `--env`: an environment map to use instead of the scene's. A scene whose environment is part of what it
    /// tests (the furnace) rejects it with an error.
    pub env: Option<&'a Path>,
    /// The assets folder (meshes, environment maps, cached sphere sets): [`crate::assets_dir`].
    pub assets: &'a Path,
    /// The scene's options (`--scene NAME:key=value,...`), parsed against its schema in [`SCENE_OPTIONS`] with
    /// the defaults filled in (empty for a scene without options).
    pub options: &'a engine::options::Options,
}

/// A scene's animation: a pose as a function of time.
#[derive(Clone, Copy)]
pub struct Motion {
    /// What moves, for `--help` (`the bunny turns on its base`).
    pub summary: &'static str,
    /// The pose at `t` seconds, from the scene's rest pose.
    pub pose: fn(rest: &Rest, t: f32) -> Pose,
}

/// The rest pose of a built scene: what motions start from.
#[derive(Clone, Debug, PartialEq)]
pub struct Rest {
    /// Object-to-world transform per instance.
    pub transforms: Vec<Mat4>,
    /// Bone matrices (empty without skins).
    pub bones: Vec<Mat4>,
}

impl Rest {
    pub fn of(scene: &Scene) -> Self {
        Self { transforms: scene.instances.iter().map(|i| i.transform).collect(), bones: scene.blockers.bones.clone() }
    }
}

/// What a motion changes at one time: some instances' transforms and the bone matrices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Pose {
    /// (instance index, object-to-world transform); instances not listed keep theirs.
    pub transforms: Vec<(usize, Mat4)>,
    /// Every bone matrix (as many as the scene has), or `None` to keep them.
    pub bones: Option<Vec<Mat4>>,
}

impl Pose {
    /// Upload the pose (`Renderer::set_instance_transform`, `Renderer::set_bones`).
    pub fn apply(&self, renderer: &mut engine::renderer::Renderer) -> engine::gpu::Result<()> {
        for &(i, m) in &self.transforms {
            renderer.set_instance_transform(i, m)?;
        }
        if let Some(b) = &self.bones {
            renderer.set_bones(b)?;
        }
        Ok(())
    }
}

/// A built scene's motion, ready to pose it at any time (`--animate`: the demo, the viewer, captures): a registered
/// scene's [`Motion`], or a file scene's clips ([`user::ClipPlayer`]).
#[derive(Clone)]
pub struct Animation {
    driver: Driver,
}

#[derive(Clone)]
enum Driver {
    Motion { motion: Motion, rest: Rest },
    Clips(std::sync::Arc<user::ClipPlayer>),
}

impl Animation {
    pub fn new(motion: Motion, scene: &Scene) -> Self {
        Self { driver: Driver::Motion { motion, rest: Rest::of(scene) } }
    }

    /// The animation of a file scene: its clips.
    pub fn clips(player: std::sync::Arc<user::ClipPlayer>) -> Self {
        Self { driver: Driver::Clips(player) }
    }

    /// The animation of `scene`, built from `entry`, if the entry has a motion.
    pub fn for_entry(entry: &SceneEntry, scene: &Scene) -> Option<Self> {
        entry.motion.map(|m| Self::new(m, scene))
    }

    pub fn pose(&self, t: f32) -> Pose {
        match &self.driver {
            Driver::Motion { motion, rest } => (motion.pose)(rest, t),
            Driver::Clips(p) => p.pose(t),
        }
    }

    /// Pose the renderer's scene at time `t` seconds (and set its time: a simulated cloth advances to it at
    /// the next frame).
    pub fn apply(&self, renderer: &mut engine::renderer::Renderer, t: f32) -> engine::gpu::Result<()> {
        self.pose(t).apply(renderer)?;
        renderer.set_time(t)
    }
}

/// A scene built from `--scene` (a registered name or a file) with what `--animate` would play.
pub struct Loaded {
    /// The registered name or the file as given.
    pub label: String,
    pub scene: Scene,
    /// Its motion or clips (`None`: static).
    pub animation: Option<Animation>,
}

/// Build `--scene SPEC`: a registered name, or a `.gltf`/`.glb`/`.obj`/`.toml` file ([`user`]).
pub fn load(spec: &str, env: Option<&Path>, opts: &user::UserOptions) -> Result<Loaded> {
    if user::is_file_spec(spec) && find(spec).is_err() {
        let assets = crate::assets_dir();
        let u = user::build_file(spec, env, &assets, opts)?;
        return Ok(Loaded { label: spec.to_string(), scene: u.scene, animation: u.clips.map(Animation::clips) });
    }
    anyhow::ensure!(opts.clip.is_none(), "--clip applies to file scenes (glTF clips); '{spec}' is a registered scene");
    anyhow::ensure!(
        opts.camera.is_none(),
        "--camera applies to file scenes (glTF cameras); '{spec}' is a registered scene"
    );
    anyhow::ensure!(opts.ground.is_none(), "--ground applies to file scenes; '{spec}' is a registered scene");
    let entry = find(spec)?;
    let scene = build(spec, env)?;
    let animation = Animation::for_entry(entry, &scene);
    Ok(Loaded { label: spec.to_string(), scene, animation })
}

/// The registered scene of `spec` (`NAME` or `NAME:key=value,...`); an unknown name is an error listing the
/// registered ones, and options the scene does not take (or bad values) are errors naming them.
pub fn find(spec: &str) -> Result<&'static SceneEntry> {
    Ok(find_with_options(spec)?.0)
}

/// [`find`], with the scene's options parsed (defaults filled in).
pub fn find_with_options(spec: &str) -> Result<(&'static SceneEntry, engine::options::Options)> {
    let (name, pairs) = engine::options::split_spec(spec).map_err(|e| anyhow::anyhow!("scene {e}"))?;
    let entry = SCENES.iter().find(|s| s.name == name).ok_or_else(|| {
        anyhow::anyhow!("unknown scene '{name}' (scenes: {}; or a .gltf, .glb, .obj or .toml file)", names())
    })?;
    let schema = SCENE_OPTIONS.iter().find(|(n, _)| *n == entry.name).map_or(&[][..], |(_, s)| *s);
    let options = engine::options::parse(&format!("scene '{}'", entry.name), schema, &pairs)?;
    Ok((entry, options))
}

/// The options of the registered scene `name` parsed from `pairs` (`key=value,...`, empty for the defaults).
pub fn parse_options(name: &str, pairs: &str) -> Result<engine::options::Options> {
    let spec = if pairs.is_empty() { name.to_string() } else { format!("{name}:{pairs}") };
    Ok(find_with_options(&spec)?.1)
}

/// The registered names, comma-separated.
pub fn names() -> String {
    SCENES.iter().map(|s| s.name).collect::<Vec<_>>().join(", ")
}

/// Build the registered scene `name` (`NAME[:key=value,...]`) from the project's assets, with `env` instead of
/// its environment; a file name builds that file's scene with the default options ([`load`] takes options and
/// returns its clips).
pub fn build(name: &str, env: Option<&Path>) -> Result<Scene> {
    if user::is_file_spec(name) && find(name).is_err() {
        return Ok(load(name, env, &user::UserOptions::default())?.scene);
    }
    let (entry, options) = find_with_options(name)?;
    let assets = crate::assets_dir();
    (entry.build)(&SceneInputs { env, assets: &assets, options: &options })
        .map_err(|e| e.context(format!("building scene '{name}'")))
}

/// `--scene`'s parser: a registered name (listed with its summary in `--help`) or a file ending in `.gltf`,
/// `.glb`, `.obj` (one model) or `.toml` (a scene description); anything else is an error listing both.
pub fn value_parser() -> SceneParser {
    SceneParser
}

/// See [`value_parser`].
#[derive(Clone, Copy, Debug)]
pub struct SceneParser;

impl clap::builder::TypedValueParser for SceneParser {
    type Value = String;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> std::result::Result<String, clap::Error> {
        let s = value.to_string_lossy().into_owned();
        if user::is_file_spec(&s) || find(&s).is_ok() {
            return Ok(s);
        }
        let arg = arg.map(|a| a.to_string()).unwrap_or_else(|| "--scene".into());
        if let (true, Err(e)) = (SCENES.iter().any(|entry| s.split(':').next() == Some(entry.name)), find(&s)) {
            // A registered scene with options it does not take, or a bad value: the option's own error.
            let msg = format!("invalid value '{s}' for '{arg}': {e:#}\n");
            return Err(clap::Error::raw(clap::error::ErrorKind::InvalidValue, msg).with_cmd(cmd));
        }
        Err(clap::Error::raw(
            clap::error::ErrorKind::InvalidValue,
            format!(
                "invalid value '{s}' for '{arg}': not a registered scene ({}) nor a .gltf, .glb, .obj or .toml file\n",
                names()
            ),
        )
        .with_cmd(cmd))
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = clap::builder::PossibleValue> + '_>> {
        let help = |s: &SceneEntry| match SCENE_OPTIONS.iter().find(|(n, _)| *n == s.name) {
            Some((_, schema)) => {
                let keys: Vec<&str> = schema.iter().map(|o| o.key).collect();
                format!("{} (options: {}:{}=...)", s.summary, s.name, keys.join("=...,"))
            }
            None => s.summary.to_string(),
        };
        Some(Box::new(SCENES.iter().map(move |s| clap::builder::PossibleValue::new(s.name).help(help(s))).chain(
            std::iter::once(clap::builder::PossibleValue::new("FILE").help(
                "a .gltf, .glb or .obj model (framed on a ground plane, spheres fitted and cached; --animate plays \
                     its clips) or a .toml scene description (docs/scene-files.md)",
            )),
        )))
    }
}

/// `--animate`'s help: what moves, and in which scenes.
pub fn animate_help() -> String {
    let mut motions: Vec<(&str, Vec<&str>)> = Vec::new();
    for s in SCENES {
        if let Some(m) = s.motion {
            match motions.iter_mut().find(|(summary, _)| *summary == m.summary) {
                Some((_, names)) => names.push(s.name),
                None => motions.push((m.summary, vec![s.name])),
            }
        }
    }
    let moving: Vec<String> = motions.iter().map(|(m, names)| format!("{m} ({})", names.join(", "))).collect();
    format!(
        "Animate the scene over time: {}; the other scenes are static. Headless frames and --capture step 1/30 s, \
         the viewer follows the clock",
        moving.join("; ")
    )
}

/// The names of the scenes with a motion, comma-separated.
pub fn animated_names() -> String {
    SCENES.iter().filter(|s| s.motion.is_some()).map(|s| s.name).collect::<Vec<_>>().join(", ")
}

/// Check what the registry promises about a built scene: its indices are in range, its numbers finite, and its
/// motion (if any) poses only instances and bones it has, with finite matrices, at a spread of times (including
/// t = 0 and an hour in). The CPU half of the registry's tests; the GPU half renders it.
pub fn check(entry: &SceneEntry, scene: &Scene) -> Result<()> {
    use anyhow::ensure;
    let name = entry.name;
    ensure!(!entry.summary.is_empty() && !entry.summary.contains('\n'), "{name}: the summary must be one line");
    ensure!(!scene.instances.is_empty(), "{name}: no instances");
    for (i, inst) in scene.instances.iter().enumerate() {
        ensure!(inst.mesh < scene.meshes.len(), "{name}: instance {i} names mesh {}", inst.mesh);
        ensure!(inst.material < scene.materials.len(), "{name}: instance {i} names material {}", inst.material);
        ensure!(inst.transform.is_finite(), "{name}: instance {i} has a non-finite transform");
    }
    for l in &scene.lights {
        ensure!(
            l.center.is_finite() && l.radius > 0.0 && l.radiance.is_finite() && l.radiance.min_element() >= 0.0,
            "{name}: bad light {l:?}"
        );
    }
    ensure!(scene.environment.texels.len() == scene.environment.width * scene.environment.height, "{name}: env size");
    ensure!(scene.environment.texels.iter().flatten().all(|c| c.is_finite() && *c >= 0.0), "{name}: env texels");
    ensure!(scene.environment_intensity.is_finite() && scene.environment_intensity >= 0.0, "{name}: env intensity");
    let Some(motion) = entry.motion else { return Ok(()) };
    ensure!(!motion.summary.is_empty(), "{name}: the motion needs a summary");
    let animation = Animation::new(motion, scene);
    let mut moved = false;
    for t in [0.0, 0.1, 0.5, 1.0, 2.5, 10.0, 3600.0] {
        let pose = animation.pose(t);
        for &(i, m) in &pose.transforms {
            ensure!(
                i < scene.instances.len(),
                "{name}: t = {t}: the pose moves instance {i} of {}",
                scene.instances.len()
            );
            ensure!(m.is_finite(), "{name}: t = {t}: non-finite transform of instance {i}");
            moved |= m != scene.instances[i].transform;
        }
        if let Some(b) = &pose.bones {
            ensure!(
                b.len() == scene.blockers.bones.len(),
                "{name}: t = {t}: {} bones, the scene has {}",
                b.len(),
                scene.blockers.bones.len()
            );
            ensure!(b.iter().all(|m| m.is_finite()), "{name}: t = {t}: non-finite bone matrix");
            moved |= *b != scene.blockers.bones;
        }
    }
    // A simulated cloth moves by itself with the renderer's time (Animation::apply sets it).
    moved |= scene.blockers.cloth.is_some();
    ensure!(moved, "{name}: the motion never changes the scene");
    Ok(())
}
