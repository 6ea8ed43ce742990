//! `cloth` (ISG Fig. 10): a 1.8 m square cloth (48 × 48 vertices) falls from 0.95 m onto four bunnies
//! (0.55 m tall, 64 blocker spheres each) on a ground plane under the courtyard environment. The cloth is
//! simulated on the GPU (`engine::passes::cloth`: XPBD distance constraints solved by Jacobi sweeps, 240
//! substeps per second, colliding with the bunnies' spheres and the ground) and is a thin shell: ISG and
//! the reference see its triangles; the techniques that read only spheres see 144 spheres generated along
//! it every frame (one per 4 × 4 quads, their bounding sphere plus the collision thickness).
//! Deterministic for a seed ([`ClothParams::seed`]) and a frame count; `--animate` plays the fall (at t = 0
//! the cloth hangs flat above the bunnies).

use super::{Motion, Pose, Rest, SceneEntry, SceneInputs};
use engine::scene::blockers::fitted_spheres;
use engine::scene::cloth::{grid_mesh, Cloth, ClothParams};
use engine::scene::{load_environment, load_obj, Camera, Instance, Material, Scene, SceneBlockers};
use glam::{Mat4, Vec3};

pub const SCENE: SceneEntry = SceneEntry {
    name: "cloth",
    summary: "a simulated cloth (48×48, GPU XPBD) falls onto four bunnies on a ground plane (ISG Fig. 10)",
    build,
    motion: Some(Motion { summary: "the cloth falls onto the bunnies (GPU simulation)", pose: still }),
};

/// Vertices per side of the cloth.
pub const CLOTH_SIDE: u32 = 48;
/// Half the cloth's side (m).
pub const CLOTH_HALF: f32 = 0.9;
/// Height the cloth starts at (m).
pub const CLOTH_HEIGHT: f32 = 0.95;
/// Height of each bunny (m).
pub const BUNNY_HEIGHT: f32 = 0.55;

/// The instances: bunnies 0..4 (mesh 0), the ground 4 (mesh 1), the cloth 5 (mesh 2).
pub const CLOTH_INSTANCE: usize = 5;

/// The simulation's parameters in this scene.
pub fn params() -> ClothParams {
    ClothParams { ground: Some(0.0), sphere_patch: 4, seed: 1, ..ClothParams::default() }
}

fn build(inputs: &SceneInputs) -> anyhow::Result<Scene> {
    let bunny = load_obj(&inputs.assets.join("meshes/bunny.obj"))?;
    let env_path =
        inputs.env.map(std::path::Path::to_path_buf).unwrap_or_else(|| inputs.assets.join("envmaps/courtyard.exr"));
    let environment = load_environment(&env_path)?;
    let (lo, hi) =
        bunny.positions.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(l, h), p| (l.min(*p), h.max(*p)));
    let scale = BUNNY_HEIGHT / (hi.y - lo.y);
    let centre = 0.5 * (lo + hi);
    let base = Mat4::from_scale(Vec3::splat(scale)) * Mat4::from_translation(Vec3::new(-centre.x, -lo.y, -centre.z));
    let settings = engine::blockers::fit::FitSettings::default();
    let spheres = fitted_spheres(&bunny, &settings, &inputs.assets.join("meshes/bunny.spheres.json"))?;
    // Four bunnies on a 0.9 m square, each turned a quarter more than the last.
    let mut instances: Vec<Instance> = [(-0.45, -0.45), (0.45, -0.45), (-0.45, 0.45), (0.45, 0.45)]
        .iter()
        .enumerate()
        .map(|(k, &(x, z))| Instance {
            mesh: 0,
            transform: Mat4::from_translation(Vec3::new(x, 0.0, z))
                * Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2 * k as f32 + 0.4)
                * base,
            material: 0,
        })
        .collect();
    instances.push(Instance { mesh: 1, transform: Mat4::IDENTITY, material: 1 });
    // Turned a little about the vertical so that its rows do not line up with the bunnies.
    instances.push(Instance {
        mesh: 2,
        transform: Mat4::from_translation(Vec3::new(0.0, CLOTH_HEIGHT, 0.0)) * Mat4::from_rotation_y(0.3),
        material: 2,
    });
    let cloth = Cloth { mesh: 2, columns: CLOTH_SIDE, rows: CLOTH_SIDE, params: params() };
    Ok(Scene {
        meshes: vec![
            bunny,
            super::shapes::ground_plane(2.0, 32),
            grid_mesh(CLOTH_SIDE, CLOTH_SIDE, CLOTH_HALF, CLOTH_HALF),
        ],
        materials: vec![
            Material::glossy(Vec3::new(0.7, 0.68, 0.62), 0.15, 200.0),
            Material::diffuse(Vec3::new(0.55, 0.55, 0.55)),
            Material::diffuse(Vec3::new(0.2, 0.35, 0.7)),
        ],
        instances,
        environment,
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: Vec::new(),
        // The bunnies' spheres (4 × 64), the ground a plane blocker, the cloth a thin shell that is simulated.
        blockers: SceneBlockers {
            spheres: vec![Some(spheres)],
            plane_meshes: vec![false, true, false],
            thin: vec![false, false, true],
            cloth: Some(cloth),
            ..Default::default()
        },
        camera: Camera { eye: Vec3::new(0.0, 1.7, 2.7), target: Vec3::new(0.0, 0.25, 0.0), fov_y_degrees: 40.0 },
    })
}

/// Nothing is posed: the cloth moves by itself with the renderer's time (`Renderer::set_time`).
fn still(_: &Rest, _: f32) -> Pose {
    Pose::default()
}

/// `scene` frozen at `t` seconds: its cloth simulated on the GPU to `t` (a renderer with technique `none`
/// at 8 × 8 pixels), its mesh replaced by that state in world space (identity transform, no jitter) and its
/// normals recomputed. The cloth stays simulated, at rest in that state, so at time 0 it keeps its shape and
/// the sphere-only techniques still get its generated spheres; the reference's triangles, which are posed on
/// the host from the meshes, see the draped cloth too. A scene without a cloth is returned unchanged.
pub fn frozen_at(gpu: &engine::gpu::Gpu, scene: &Scene, t: f32) -> anyhow::Result<Scene> {
    let Some(cloth) = scene.blockers.cloth.clone() else { return Ok(scene.clone()) };
    let settings =
        engine::renderer::RenderSettings { width: 8, height: 8, technique: "none".into(), ..Default::default() };
    let mut r = engine::renderer::Renderer::new(gpu, scene, settings)?;
    let state = r.set_time(t).and_then(|_| r.render(gpu)).and_then(|_| {
        let pass = r.cloth().ok_or_else(|| engine::gpu::GpuError::Other("internal: no cloth pass".into()))?;
        gpu.read_buffer::<[f32; 4]>(&pass.x)
    });
    r.destroy(gpu);
    let state = state?;
    let (instance, _) = engine::scene::cloth::cloth_instance(scene, &cloth).map_err(anyhow::Error::msg)?;
    let mut s = scene.clone();
    let mesh = &mut s.meshes[cloth.mesh];
    mesh.positions = state.iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
    mesh.normals = engine::scene::compute_normals(&mesh.positions, &mesh.indices);
    s.instances[instance].transform = Mat4::IDENTITY;
    if let Some(c) = s.blockers.cloth.as_mut() {
        c.params.jitter = 0.0;
    }
    Ok(s)
}
