//! Analytic scenes of the tests: closed-form answers, not demo scenes (those are the registry in
//! demos/src/scenes; a test that needs one builds it from there).

use demos::scenes::shapes::{ground_plane, uv_sphere};
use engine::blockers::Sphere;
use engine::math::envmap::LatLongMap;
use engine::scene::{Camera, Instance, Material, Scene, SceneBlockers};
use glam::{Mat4, Vec3};

/// A Lambertian plane (half-size 1.5 at y = 0, albedo `albedo`, material 0) under `env`, with a
/// tessellated sphere of `radius` at `center` (material 1) that casts sphere shadows through a
/// one-sphere blocker set; seen obliquely so that the shadow is in view. The closed-form scene of
/// the shadowing tests: for a constant environment L the plane's radiance is ρL (1 − h r²/d³) where
/// the sphere's cap lies wholly above the horizon.
pub fn sphere_over_plane(env: LatLongMap, albedo: f32, center: Vec3, radius: f32) -> Scene {
    Scene {
        meshes: vec![ground_plane(1.5, 8), uv_sphere(32)],
        materials: vec![Material::diffuse(Vec3::splat(albedo)), Material::diffuse(Vec3::splat(0.8))],
        instances: vec![
            Instance { mesh: 0, transform: Mat4::IDENTITY, material: 0 },
            Instance {
                mesh: 1,
                transform: Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius)),
                material: 1,
            },
        ],
        environment: env,
        environment_intensity: 1.0,
        lights: Vec::new(),
        blockers: SceneBlockers {
            spheres: vec![None, Some(vec![Sphere::new(glam::DVec3::ZERO, 1.0)])],
            ..Default::default()
        },
        camera: Camera { eye: Vec3::new(0.0, 2.2, 2.6), target: Vec3::new(0.0, 0.0, -0.2), fov_y_degrees: 45.0 },
    }
}

/// A Lambertian plane (half-size 1.5 at y = 0, albedo `albedo`, material 0) under `env` with a flat
/// square thin sheet (half-size `half`, `n` × `n` quads, material 1, albedo 0.8) parallel to it at
/// `height`, centred above the origin: the closed-form scene of the thin-shell tests (for a constant
/// environment L a plane point shades to ρL (1 − F) with F the parallel-rectangle form factor).
pub fn sheet_over_plane(env: LatLongMap, albedo: f32, half: f32, height: f32, n: u32) -> Scene {
    let mut sheet = ground_plane(half, n);
    sheet.name = "sheet".into();
    Scene {
        meshes: vec![ground_plane(1.5, 8), sheet],
        materials: vec![Material::diffuse(Vec3::splat(albedo)), Material::diffuse(Vec3::splat(0.8))],
        instances: vec![
            Instance { mesh: 0, transform: Mat4::IDENTITY, material: 0 },
            Instance { mesh: 1, transform: Mat4::from_translation(Vec3::new(0.0, height, 0.0)), material: 1 },
        ],
        environment: env,
        environment_intensity: 1.0,
        lights: Vec::new(),
        blockers: SceneBlockers { thin: vec![false, true], ..Default::default() },
        camera: Camera { eye: Vec3::new(0.0, 2.2, 2.6), target: Vec3::new(0.0, 0.0, -0.2), fov_y_degrees: 45.0 },
    }
}

/// How [`ball_above_ground`] makes its ground a blocker.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GroundBlocker {
    /// An explicit half-space y < 0 (the ground mesh itself is not marked).
    HalfSpace,
    /// The ground mesh marked as a plane blocker (its rectangle).
    Rectangle,
}

/// A Lambertian ball (radius `radius` at `center`, albedo `albedo`, material 0, no blocker spheres:
/// it is convex) above a huge ground (half-size 1000 at y = 0, material 1) that is a plane blocker, under
/// `env`, seen from the side and slightly above. The closed-form scene of the plane tests: for a
/// constant environment L a ball pixel with normal n sees only the upper hemisphere,
/// ρL (1 + n_y)/2 (the ground's edge, 1000 away, hides less than 1e-3 of it).
pub fn ball_above_ground(env: LatLongMap, albedo: f32, center: Vec3, radius: f32, blocker: GroundBlocker) -> Scene {
    let mut blockers = SceneBlockers::default();
    match blocker {
        GroundBlocker::HalfSpace => {
            blockers.planes = vec![engine::scene::blockers::BlockerPlane::half_space(glam::DVec3::ZERO, glam::DVec3::Y)]
        }
        GroundBlocker::Rectangle => blockers.plane_meshes = vec![false, true],
    }
    let eye = center + Vec3::new(0.0, 0.35, 3.2) * radius;
    Scene {
        meshes: vec![uv_sphere(32), ground_plane(1000.0, 1)],
        materials: vec![Material::diffuse(Vec3::splat(albedo)), Material::diffuse(Vec3::splat(0.5))],
        instances: vec![
            Instance {
                mesh: 0,
                transform: Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius)),
                material: 0,
            },
            Instance { mesh: 1, transform: Mat4::IDENTITY, material: 1 },
        ],
        environment: env,
        environment_intensity: 1.0,
        lights: Vec::new(),
        blockers,
        camera: Camera { eye, target: center, fov_y_degrees: 45.0 },
    }
}
