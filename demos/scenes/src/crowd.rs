//! `crowd`: N skinned characters, the battle's troll and wizard (`assets/battle/*.glb`) in turn, on a
//! grid or a ring, each walking or playing its action clip at its own phase, under the courtyard and one
//! spherical light, seen from above. Every character has its own blocker spheres (16 fitted per mesh, shipped in
//! `assets/battle/*-{body,prop}.spheres.json`) that follow its own skin. The hard case: thousands of skinned
//! blocker spheres of which each pixel sees a few, the case where a per-pixel BVH walk costs most.
//!
//! Options (`--scene crowd:count=16,layout=ring`): [`OPTIONS`]. `examples/crowd.toml` is the default scene as a
//! scene file (demos/scenes/tests/crowd.rs checks that both build the same scene).

use super::user::{self, Blockers, ClipChoice, Composition, Model, Placement, UserOptions};
use super::{Motion, Pose, Rest, SceneEntry, SceneInputs};
use anyhow::{ensure, Result};
use engine::options::{Kind, OptionSpec};
use engine::scene::{load_environment, Camera, Material, SphereLight};
use glam::{Mat4, Quat, Vec3};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

pub const SCENE: SceneEntry = SceneEntry {
    name: "crowd",
    summary: "N skinned trolls and wizards (glTF, 16 fitted spheres per mesh) on a grid, courtyard and one light",
    build,
    motion: Some(Motion { summary: "every character walks or plays its action clip, each at its own phase", pose }),
};

/// The scene's options: `--scene crowd:count=N,layout=grid|ring,spacing=S`.
pub const OPTIONS: &[OptionSpec] = &[
    OptionSpec {
        key: "count",
        aliases: &["n"],
        kind: Kind::Int { min: 1, max: MAX_COUNT as i64 },
        default: Some("64"),
        help: "characters (trolls and wizards in turn)",
    },
    OptionSpec {
        key: "layout",
        aliases: &[],
        kind: Kind::Choice(&["grid", "ring"]),
        default: Some("grid"),
        help: "grid: a square grid, row by row; ring: one circle, every character facing the centre",
    },
    OptionSpec {
        key: "frame",
        aliases: &[],
        kind: Kind::Int { min: 0, max: MAX_COUNT as i64 },
        default: Some("0"),
        help: "the camera and the light as for a crowd of this many (0: count); measuring cost against count keeps \
               one view with e.g. crowd:count=4,frame=64",
    },
    OptionSpec {
        key: "spacing",
        aliases: &[],
        kind: Kind::closed(0.5, 10.0),
        default: Some("1.6"),
        help: "metres between neighbours (grid rows and columns, or along the ring)",
    },
];

/// The most characters (`count`).
pub const MAX_COUNT: usize = 1024;
/// Blocker spheres fitted per mesh (body and prop), as in the shipped sphere files.
pub const SPHERES_PER_MESH: usize = 16;
/// The characters, in turn: (file stem, action clip).
const KINDS: [(&str, &str); 2] = [("troll", "attack"), ("wizard", "cast")];
/// Bones per character (both share one skeleton: crate::characters::BONES).
const BONES_PER_CHARACTER: usize = crate::characters::BONES.len();

/// One character of the crowd: where it stands and what it plays.
#[derive(Clone, Debug, PartialEq)]
pub struct Member {
    /// 0: troll, 1: wizard ([`KINDS`]).
    pub kind: usize,
    /// Where it stands (on the ground, y = 0).
    pub at: Vec3,
    /// Its turn about +y, in degrees (the models face +z).
    pub heading: f32,
    /// `walk` or the kind's action clip.
    pub clip: &'static str,
    /// Seconds into the clip at t = 0.
    pub phase: f32,
}

/// A deterministic number in [0, 1) per (character, salt): splitmix64's finalizer.
fn unit(i: usize, salt: u64) -> f32 {
    let mut z = (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ salt.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 24) as f32
}

/// The characters for `count`, `layout` (`grid` or `ring`) and `spacing`: trolls and wizards in turn; three in
/// four walk, the fourth plays its action clip; every phase (a fraction of 2 s) and, on the grid, every heading
/// differs. Centred on the origin.
pub fn members(count: usize, layout: &str, spacing: f32) -> Vec<Member> {
    let columns = (count as f32).sqrt().ceil().max(1.0) as usize;
    let rows = count.div_ceil(columns);
    (0..count)
        .map(|i| {
            let kind = i % 2;
            let clip = if i % 4 == 3 { KINDS[kind].1 } else { "walk" };
            // Whole hundredths of a second and whole degrees: examples/crowd.toml writes them exactly.
            let phase = (200.0 * unit(i, 1)).round() / 100.0;
            let (at, heading) = match layout {
                "ring" => {
                    // Neighbours `spacing` apart along the chord; each faces the centre (the model faces +z).
                    let radius =
                        if count > 1 { spacing / (2.0 * (std::f32::consts::PI / count as f32).sin()) } else { 0.0 };
                    let a = std::f32::consts::TAU * i as f32 / count as f32;
                    (Vec3::new(radius * a.sin(), 0.0, radius * a.cos()), a.to_degrees() + 180.0)
                }
                _ => {
                    let (r, c) = (i / columns, i % columns);
                    let at = Vec3::new(
                        (c as f32 - 0.5 * (columns - 1) as f32) * spacing,
                        0.0,
                        (r as f32 - 0.5 * (rows - 1) as f32) * spacing,
                    );
                    (at, (360.0 * unit(i, 2)).round())
                }
            };
            Member { kind, at, heading, clip, phase }
        })
        .collect()
}

impl Member {
    /// Object to world: turned about +y by `heading`, as a scene file's `rotation = [0, heading, 0]` makes it.
    pub fn transform(&self) -> Mat4 {
        let turn = Quat::from_euler(glam::EulerRot::ZYX, 0.0, self.heading.to_radians(), 0.0);
        Mat4::from_rotation_translation(turn, self.at)
    }
}

/// The scene as a scene file (examples/crowd.toml is `scene_file(&members(64, "grid", 1.6))`): the same models,
/// placements, clips, phases, sphere files, light, camera, environment and ground. Grid members (whole degrees,
/// hundredths of a second) are written exactly.
pub fn scene_file(members: &[Member]) -> String {
    use std::fmt::Write as _;
    let extent = extent(members);
    let (c, l, g) = (camera(extent), light(extent), ground_material().diffuse);
    let v = |v: Vec3| format!("[{:?}, {:?}, {:?}]", v.x, v.y, v.z);
    let mut s = format!(
        "# The `crowd` scene (demos/scenes/src/crowd.rs) at its defaults as a scene file: {} trolls and wizards \
         from\n# assets/battle, each with its 16 fitted spheres per mesh, walking or playing its action clip at its \
         own phase,\n# under the courtyard and one spherical light. Written by `crowd::scene_file`; demos/scenes/tests/crowd.rs \
         checks\n# that it builds the same scene as `--scene crowd`.\n#   cargo xtask demo --scene examples/crowd.toml \
         --animate\n\n[camera]\neye = {}\ntarget = {}\nfov_y = {:?}\n\n[environment]\nfile = \
         \"../assets/envmaps/courtyard.exr\"\nintensity = 1.0\n\n[ground]\nmaterial = {{ diffuse = {} }}\n\n[[light]]\n\
         center = {}\nradius = {:?}\nradiance = {}\n",
        members.len(),
        v(c.eye),
        v(c.target),
        c.fov_y_degrees,
        v(g),
        v(l.center),
        l.radius,
        v(l.radiance)
    );
    for m in members {
        let name = KINDS[m.kind].0;
        let _ = write!(
            s,
            "\n[[model]]\nfile = \"../assets/battle/{name}.glb\"\ntranslation = {}\nrotation = [0.0, {:?}, 0.0]\n\
             sphere_files = [\"../assets/battle/{name}-body.spheres.json\", \"../assets/battle/{name}-prop.spheres.json\"]\n\
             clip = \"{}\"\nclip_phase = {:?}\n",
            v(m.at),
            m.heading,
            m.clip,
            m.phase
        );
    }
    s
}

/// The shipped sphere files of a kind: body, then prop (16 fitted spheres each, `engine-blockers` format).
pub fn sphere_files(assets: &Path, kind: usize) -> Vec<PathBuf> {
    let name = KINDS[kind].0;
    vec![
        assets.join(format!("battle/{name}-body.spheres.json")),
        assets.join(format!("battle/{name}-prop.spheres.json")),
    ]
}

/// The spherical light: above and to one side of the crowd, its height growing with the crowd's extent.
pub fn light(extent: f32) -> SphereLight {
    let h = 4.0 + 0.3 * extent;
    SphereLight {
        center: Vec3::new(0.35 * h, h, 0.25 * h),
        radius: 0.1 * h,
        radiance: Vec3::new(1.0, 0.9, 0.75) * 30.0,
    }
}

/// The camera: from above and in front, far enough to see the whole crowd (`extent`: its half-width).
pub fn camera(extent: f32) -> Camera {
    let fov_y_degrees: f32 = 45.0;
    let target = Vec3::new(0.0, 0.6, 0.0);
    let distance = 1.15 * (extent + 1.0) / (0.5 * fov_y_degrees.to_radians()).tan();
    Camera { eye: target + Vec3::new(0.0, 1.0, 0.75).normalize() * distance, target, fov_y_degrees }
}

/// The crowd's half-width: the largest |x| or |z| of a character.
pub fn extent(members: &[Member]) -> f32 {
    members.iter().map(|m| m.at.x.abs().max(m.at.z.abs())).fold(0.0, f32::max)
}

/// The ground's material.
pub fn ground_material() -> Material {
    Material::diffuse(Vec3::new(0.5, 0.48, 0.44))
}

fn build(inputs: &SceneInputs) -> Result<engine::scene::Scene> {
    let o = inputs.options;
    let (count, layout, spacing) = (o.int("count") as usize, o.choice("layout"), o.float("spacing") as f32);
    let frame = match o.int("frame") as usize {
        0 => count,
        n => n,
    };
    let env = inputs.env.map(Into::into).unwrap_or_else(|| inputs.assets.join("envmaps/courtyard.exr"));
    let view = extent(&members(frame, layout, spacing));
    Ok(compose(inputs.assets, load_environment(&env)?, &members(count, layout, spacing), view)?.scene)
}

/// The two models, loaded once.
fn models(assets: &Path) -> Result<[Model; 2]> {
    let load = |k: usize| user::load_model(&assets.join(format!("battle/{}.glb", KINDS[k].0)));
    Ok([load(0)?, load(1)?])
}

/// The scene of `members` with its clip player, the camera and the light placed for a crowd of half-width
/// `view` ([`extent`]).
pub fn compose(
    assets: &Path,
    environment: engine::math::envmap::LatLongMap,
    members: &[Member],
    view: f32,
) -> Result<user::UserScene> {
    ensure!(!members.is_empty() && members.len() <= MAX_COUNT, "crowd: 1..={MAX_COUNT} characters");
    let kinds = models(assets)?;
    let mut placements = Vec::with_capacity(members.len());
    for m in members {
        let model = kinds[m.kind].clone();
        let clip = model.rig.clip_index(m.clip).map_err(|e| anyhow::anyhow!("{}: {e}", KINDS[m.kind].0))?;
        placements.push(Placement {
            model,
            file: assets.join(format!("battle/{}.glb", KINDS[m.kind].0)),
            transform: m.transform(),
            material: None,
            map: None,
            blockers: Blockers::Files(sphere_files(assets, m.kind)),
            choice: ClipChoice::Phased(clip, m.phase),
            lights: None,
            receivers: None,
        });
    }
    let composition = Composition {
        models: placements,
        environment,
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: vec![light(view)],
        camera: user::CameraSetup::Fixed(camera(view)),
        ground: Some(user::Ground::plain(ground_material())),
        ground_mode: user::GroundMode::Engine,
    };
    user::assemble(composition, &UserOptions::default())
}

/// The rigs of the two kinds and their clip indices, loaded once (the pose needs no scene options: it reads the
/// character count from the rest pose).
fn rigs() -> Option<&'static [Model; 2]> {
    static RIGS: OnceLock<Option<[Model; 2]>> = OnceLock::new();
    RIGS.get_or_init(|| models(&crate::assets_dir()).ok()).as_ref()
}

/// Every character's bones at `t`: the rest pose holds 2 instances (body, prop) per character plus the ground, and
/// 14 bones per character; [`members`] gives each one's kind, clip and phase (they depend on the index only).
/// The meshes' own nodes are not animated in these files, so only bones change.
fn pose(rest: &Rest, t: f32) -> Pose {
    let Some(rigs) = rigs() else { return Pose::default() };
    let n = rest.bones.len() / BONES_PER_CHARACTER;
    if n == 0 || rest.bones.len() != n * BONES_PER_CHARACTER {
        return Pose::default();
    }
    let mut bones = Vec::with_capacity(rest.bones.len());
    for (i, m) in members(n, "grid", 1.0).iter().enumerate() {
        let rig = &rigs[m.kind].rig;
        let clip = rig.clip_index(m.clip).ok();
        let p = rig.pose(clip, t + m.phase);
        if p.bones.len() != BONES_PER_CHARACTER {
            return Pose::default();
        }
        bones.extend(p.bones);
        debug_assert!(bones.len() == (i + 1) * BONES_PER_CHARACTER);
    }
    Pose { transforms: Vec::new(), bones: Some(bones) }
}
