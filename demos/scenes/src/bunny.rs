//! `bunny`, the default scene: the Stanford bunny (scaled to unit height) on a ground plane under the
//! courtyard environment (CC0, Poly Haven), 64 blocker spheres and the ground as a plane blocker;
//! `--animate` turns it on its base.

use super::{Motion, Pose, Rest, SceneEntry, SceneInputs};
use engine::scene::blockers::fitted_spheres;
use engine::scene::{load_environment, load_obj, Camera, Instance, Material, Scene, SceneBlockers};
use glam::{Mat4, Vec3};

pub const SCENE: SceneEntry = SceneEntry {
    name: "bunny",
    summary:
        "Stanford bunny on a ground plane, courtyard environment, 64 blocker spheres + the ground plane (the default)",
    build: scene,
    motion: Some(TURNTABLE),
};

/// The bunny (instance 0) turns about the world's +Y axis at 0.5 rad/s: a rigid transform, so its
/// blocker spheres follow; other instances stay. Also used by `sheet` and `lamp`.
pub const TURNTABLE: Motion = Motion { summary: "the bunny turns on its base", pose: turntable };

fn turntable(rest: &Rest, t: f32) -> Pose {
    let transforms = rest.transforms.first().map(|&base| (0, Mat4::from_rotation_y(0.5 * t) * base));
    Pose { transforms: transforms.into_iter().collect(), bones: None }
}

/// The bunny scene; `inputs.env` replaces the courtyard.
pub fn scene(inputs: &SceneInputs) -> anyhow::Result<Scene> {
    let bunny = load_obj(&inputs.assets.join("meshes/bunny.obj"))?;
    let env_path =
        inputs.env.map(std::path::Path::to_path_buf).unwrap_or_else(|| inputs.assets.join("envmaps/courtyard.exr"));
    let environment = load_environment(&env_path)?;
    let (lo, hi) =
        bunny.positions.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(l, h), p| (l.min(*p), h.max(*p)));
    let scale = 1.0 / (hi.y - lo.y);
    let centre = 0.5 * (lo + hi);
    let transform =
        Mat4::from_scale(Vec3::splat(scale)) * Mat4::from_translation(Vec3::new(-centre.x, -lo.y, -centre.z));
    // 64 blocker spheres (SHEXP §6.2 fit), fitted once and cached beside the mesh; refitted when the
    // mesh or the settings change.
    let settings = engine::blockers::fit::FitSettings::default();
    let spheres = fitted_spheres(&bunny, &settings, &inputs.assets.join("meshes/bunny.spheres.json"))?;
    Ok(Scene {
        meshes: vec![bunny, super::shapes::ground_plane(2.0, 32)],
        materials: vec![
            Material::glossy(Vec3::new(0.7, 0.68, 0.62), 0.15, 200.0),
            Material::diffuse(Vec3::new(0.55, 0.55, 0.55)),
        ],
        instances: vec![
            Instance { mesh: 0, transform, material: 0 },
            Instance { mesh: 1, transform: Mat4::IDENTITY, material: 1 },
        ],
        environment,
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: Vec::new(),
        // The ground is a plane blocker (a rectangle, from its mesh): below the horizon it hides the
        // environment from the bunny, as the triangles do in the ground truth.
        blockers: SceneBlockers { spheres: vec![Some(spheres)], plane_meshes: vec![false, true], ..Default::default() },
        camera: Camera { eye: Vec3::new(0.0, 0.9, 2.4), target: Vec3::new(0.0, 0.4, 0.0), fov_y_degrees: 40.0 },
    })
}
