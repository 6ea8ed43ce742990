//! `battle` (SHEXP §9): a troll with a club and a wizard with a staff face each other among rocks and columns,
//! under the sunset environment and two spherical lights (a warm torch, a cold magic light). The characters are
//! skinned glTF files (`assets/battle/*.glb`, written by `write_battle_characters` from [`crate::characters`])
//! loaded through the importer as a user's files are; `--animate` plays their clips: the troll attacks, the
//! wizard casts. The hard case: skinned blockers whose spheres must follow the skin, next to many static ones.
//!
//! Blocker spheres are placed, not fitted: along each body part's axis (the characters), stacked up each column's
//! shaft, along each rock's long axis; the ground is a plane blocker.

use super::user::{self, Blockers, ClipChoice, ClipPlayer, Composition, Model, Placement, UserOptions};
use super::{shapes, Motion, Pose, Rest, SceneEntry, SceneInputs};
use crate::characters;
use anyhow::Result;
use engine::blockers::Sphere;
use engine::math::envmap::LatLongMap;
use engine::scene::{load_environment, Camera, Instance, Material, Mesh, Rig, Scene, SphereLight};
use glam::{DVec3, Mat4, Quat, Vec3};
use std::path::Path;
use std::sync::{Arc, OnceLock};

pub const SCENE: SceneEntry = SceneEntry {
    name: "battle",
    summary: "a skinned troll and wizard (glTF) among rocks and columns, sunset sky and two spherical lights",
    build,
    motion: Some(Motion { summary: "the troll swings its club and the wizard casts (their glTF clips)", pose }),
};

/// Where the troll and the wizard stand (on the x axis, facing each other).
pub const TROLL_AT: Vec3 = Vec3::new(-1.0, 0.0, 0.0);
pub const WIZARD_AT: Vec3 = Vec3::new(1.1, 0.0, 0.0);
/// Instance and mesh indices: troll body, troll club, wizard body, wizard staff come first.
pub const CHARACTER_MESHES: [usize; 4] = [0, 1, 2, 3];

/// The characters' placements: the troll turned to face +x, the wizard to face −x.
pub fn placements() -> [Mat4; 2] {
    [
        Mat4::from_rotation_translation(Quat::from_rotation_y(std::f32::consts::FRAC_PI_2), TROLL_AT),
        Mat4::from_rotation_translation(Quat::from_rotation_y(-std::f32::consts::FRAC_PI_2), WIZARD_AT),
    ]
}

fn build(inputs: &SceneInputs) -> Result<Scene> {
    let env = inputs.env.map(Into::into).unwrap_or_else(|| inputs.assets.join("envmaps/sunset.exr"));
    Ok(compose(inputs.assets, load_environment(&env)?)?.scene)
}

/// The clips of the scene's characters (loaded once, from the same files as the scene).
fn player() -> Option<&'static Arc<ClipPlayer>> {
    static PLAYER: OnceLock<Option<Arc<ClipPlayer>>> = OnceLock::new();
    PLAYER
        .get_or_init(|| {
            let env = LatLongMap { width: 1, height: 1, texels: vec![[0.0; 3]] };
            compose(&crate::assets_dir(), env).ok().and_then(|u| u.clips)
        })
        .as_ref()
}

/// The troll's `attack` and the wizard's `cast`, looping (the rocks and columns stay).
fn pose(_rest: &Rest, t: f32) -> Pose {
    player().map(|p| p.pose(t)).unwrap_or_default()
}

/// The scene with its clip player.
pub fn compose(assets: &Path, environment: LatLongMap) -> Result<user::UserScene> {
    let mut models = Vec::new();
    let mut spheres: Vec<Vec<Sphere>> = Vec::new();
    for ((name, clip), placement) in [("troll", "attack"), ("wizard", "cast")].into_iter().zip(placements()) {
        let file = assets.join(format!("battle/{name}.glb"));
        let model = user::load_model(&file)?;
        anyhow::ensure!(model.meshes.len() == 2, "{}: expected a body and a prop mesh", file.display());
        let c =
            if name == "troll" { characters::troll(characters::RINGS) } else { characters::wizard(characters::RINGS) };
        spheres.push(c.spheres(false));
        spheres.push(c.spheres(true));
        let choice =
            ClipChoice::One(model.rig.clip_index(clip).map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?);
        models.push(Placement {
            model,
            file,
            transform: placement,
            material: None,
            map: None,
            blockers: Blockers::Fit(0),
            choice,
            lights: None,
            receivers: None,
        });
    }
    let (statics, static_spheres) = props();
    spheres.extend(static_spheres);
    models.push(Placement {
        model: statics,
        file: "battle props".into(),
        transform: Mat4::IDENTITY,
        material: None,
        map: None,
        blockers: Blockers::Fit(0),
        choice: ClipChoice::Still,
        lights: None,
        receivers: None,
    });
    let composition = Composition {
        models,
        environment,
        environment_intensity: 0.6,
        env_lights: Default::default(),
        lights: lights(),
        camera: user::CameraSetup::Fixed(Camera {
            eye: Vec3::new(0.4, 2.3, 5.2),
            target: Vec3::new(0.0, 0.8, -0.3),
            fov_y_degrees: 45.0,
        }),
        ground: Some(user::Ground::plain(Material::diffuse(Vec3::new(0.45, 0.4, 0.33)))),
        ground_mode: user::GroundMode::Engine,
    };
    let mut u = user::assemble(composition, &UserOptions::default())?;
    for (mesh, s) in spheres.into_iter().enumerate() {
        u.scene.blockers.spheres[mesh] = Some(s);
    }
    Ok(u)
}

/// A warm torch behind the troll and a cold magic light behind the wizard, both above head height.
pub fn lights() -> Vec<SphereLight> {
    vec![
        SphereLight { center: Vec3::new(-2.2, 2.4, -1.2), radius: 0.3, radiance: Vec3::new(1.0, 0.7, 0.4) * 25.0 },
        SphereLight { center: Vec3::new(2.3, 2.6, -0.8), radius: 0.25, radiance: Vec3::new(0.45, 0.6, 1.0) * 30.0 },
    ]
}

/// Rows of the rock mesh (a bumpy ellipsoid) and rings of a column.
const ROCK_STACKS: u32 = 40;
const COLUMN_SEGMENTS: u32 = 48;

/// The static props as one model: two rock shapes used three times each, a column used four times and a broken
/// column used twice; with the sphere set of each mesh.
fn props() -> (Model, Vec<Vec<Sphere>>) {
    let rock_a = rock(Vec3::new(0.55, 0.35, 0.4), 1, "rock-a");
    let rock_b = rock(Vec3::new(0.4, 0.3, 0.35), 2, "rock-b");
    let (column_mesh, column_spheres) = column(2.6, "column");
    let (broken, broken_spheres) = column(1.1, "broken-column");
    let meshes = vec![rock_a.0, rock_b.0, column_mesh, broken];
    let spheres = vec![rock_a.1, rock_b.1, column_spheres, broken_spheres];
    let at = |mesh: usize, x: f32, z: f32, turn: f32, scale: f32| Instance {
        mesh,
        transform: Mat4::from_scale_rotation_translation(
            Vec3::splat(scale),
            Quat::from_rotation_y(turn.to_radians()),
            Vec3::new(x, 0.0, z),
        ),
        material: if mesh < 2 { 0 } else { 1 },
    };
    let instances = vec![
        at(0, -2.6, 0.9, 20.0, 1.0),
        at(0, 2.9, 1.2, 110.0, 0.8),
        at(0, 0.2, -2.4, 65.0, 1.3),
        at(1, -0.3, 1.6, 10.0, 0.7),
        at(1, -3.1, -1.0, 80.0, 1.1),
        at(1, 2.4, -2.1, 140.0, 1.0),
        at(2, -2.0, -2.6, 0.0, 1.0),
        at(2, 2.0, -2.9, 30.0, 1.0),
        at(2, -3.6, -3.2, 0.0, 1.0),
        at(2, 3.7, -3.0, 0.0, 1.0),
        at(3, 3.3, 0.0, 45.0, 1.0),
        at(3, -0.9, -3.6, 10.0, 1.0),
    ];
    let n = meshes.len();
    let model = Model {
        meshes,
        materials: vec![
            Material::diffuse(Vec3::new(0.42, 0.4, 0.38)),
            Material::glossy(Vec3::new(0.6, 0.57, 0.5), 0.15, 40.0),
        ],
        instances,
        skins: vec![None; n],
        rig: Rig::default(),
        ..Default::default()
    };
    (model, spheres)
}

/// A bumpy ellipsoid of semi-axes `axes` resting on y = 0 (bumps of ±12% from a few low harmonics, fixed by
/// `seed`), and 5 spheres along its long (x) axis inside the smooth ellipsoid's cross-section.
fn rock(axes: Vec3, seed: u32, name: &str) -> (Mesh, Vec<Sphere>) {
    let mut m = shapes::uv_sphere(ROCK_STACKS);
    let s = seed as f32;
    for p in &mut m.positions {
        let (theta, phi) = (p.y.clamp(-1.0, 1.0).acos(), p.z.atan2(p.x));
        let bump = 1.0
            + 0.07 * (3.0 * theta + s).sin() * (2.0 * phi).cos()
            + 0.05 * (5.0 * theta).sin() * (3.0 * phi + s).sin();
        *p = *p * bump * axes + Vec3::new(0.0, axes.y, 0.0);
    }
    m.normals = engine::scene::compute_normals(&m.positions, &m.indices);
    m.name = name.into();
    let spheres = [-0.55f32, -0.28, 0.0, 0.28, 0.55]
        .iter()
        .map(|&u| {
            let r = axes.y.min(axes.z) * (1.0 - u * u).sqrt();
            Sphere::new(DVec3::new((u * axes.x) as f64, axes.y as f64, 0.0), r as f64)
        })
        .collect();
    (m, spheres)
}

/// A column of height `height` on a square-ish base (a lathe: plinth, fluted-free shaft tapering slightly, capital)
/// and its spheres stacked up the shaft one radius apart.
fn column(height: f32, name: &str) -> (Mesh, Vec<Sphere>) {
    let mut profile = vec![(0.0, 0.32), (0.12, 0.32), (0.16, 0.26), (0.2, 0.22)];
    let shaft_top = height - 0.2;
    let rings = 40;
    for k in 1..rings {
        let t = k as f32 / rings as f32;
        profile.push((0.2 + (shaft_top - 0.2) * t, 0.22 - 0.03 * t + 0.004 * (t * 40.0).sin()));
    }
    profile.extend([(shaft_top, 0.19), (shaft_top + 0.06, 0.26), (height - 0.06, 0.3), (height, 0.3)]);
    let mesh = shapes::lathe(&profile, COLUMN_SEGMENTS, name);
    let mut spheres =
        vec![Sphere::new(DVec3::new(0.0, 0.1, 0.0), 0.1), Sphere::new(DVec3::new(0.0, height as f64 - 0.1, 0.0), 0.28)];
    let mut y = 0.35f32;
    while y < shaft_top {
        spheres.push(Sphere::new(DVec3::new(0.0, y as f64, 0.0), (0.22 - 0.03 * (y - 0.2) / (shaft_top - 0.2)) as f64));
        y += 0.2;
    }
    (mesh, spheres)
}
