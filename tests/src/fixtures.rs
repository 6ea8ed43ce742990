//! Analytic scenes of the tests: closed-form answers, not demo scenes (those are the registry in
//! demos/scenes; a test that needs one builds it from there).

use engine::blockers::Sphere;
use engine::math::envmap::LatLongMap;
use engine::scene::{Camera, Instance, Material, Scene, SceneBlockers};
use glam::{Mat4, Vec3};
use scenes::shapes::{ground_plane, uv_sphere};

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
        env_lights: Default::default(),
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
        env_lights: Default::default(),
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
        env_lights: Default::default(),
        lights: Vec::new(),
        blockers,
        camera: Camera { eye, target: center, fov_y_degrees: 45.0 },
    }
}

/// The grazing-normal case (issue 15, item 5): a closed box `[−1, 1] × [−0.3, 0] × [−1, 1]` whose
/// top face (mesh 0, material 0, albedo `albedo`, `n` × `n` quads) carries vertex normals tilted by
/// `tilt` radians away from the camera (towards −z), the rest of the box (mesh 1, material 1) flat
/// normals, under `env`. The camera looks down at 15°–29° onto the top face, so with `tilt` above
/// 0.51 (29°) every top-face pixel has an interpolated normal that faces away from the viewer while
/// the geometric normal (+y) faces it; the box is closed, so a normal flipped towards the viewer
/// points into it and the triangle reference sees nothing but the box's inside.
pub fn tilted_normal_box(env: LatLongMap, albedo: f32, tilt: f32, n: u32) -> Scene {
    let mut top = ground_plane(1.0, n);
    top.name = "tilted-top".into();
    let tilted = Vec3::new(0.0, tilt.cos(), -tilt.sin());
    top.normals.iter_mut().for_each(|v| *v = tilted);
    // Five flat faces below the top (outward normals; counter-clockwise seen from outside).
    let (lo, hi) = (-0.3f32, 0.0f32);
    let faces: [(Vec3, [Vec3; 4]); 5] = [
        (
            Vec3::NEG_Y,
            [Vec3::new(-1.0, lo, -1.0), Vec3::new(1.0, lo, -1.0), Vec3::new(1.0, lo, 1.0), Vec3::new(-1.0, lo, 1.0)],
        ),
        (
            Vec3::Z,
            [Vec3::new(-1.0, lo, 1.0), Vec3::new(1.0, lo, 1.0), Vec3::new(1.0, hi, 1.0), Vec3::new(-1.0, hi, 1.0)],
        ),
        (
            Vec3::NEG_Z,
            [Vec3::new(1.0, lo, -1.0), Vec3::new(-1.0, lo, -1.0), Vec3::new(-1.0, hi, -1.0), Vec3::new(1.0, hi, -1.0)],
        ),
        (
            Vec3::X,
            [Vec3::new(1.0, lo, 1.0), Vec3::new(1.0, lo, -1.0), Vec3::new(1.0, hi, -1.0), Vec3::new(1.0, hi, 1.0)],
        ),
        (
            Vec3::NEG_X,
            [Vec3::new(-1.0, lo, -1.0), Vec3::new(-1.0, lo, 1.0), Vec3::new(-1.0, hi, 1.0), Vec3::new(-1.0, hi, -1.0)],
        ),
    ];
    let mut sides = engine::scene::Mesh {
        name: "box-sides".into(),
        positions: vec![],
        normals: vec![],
        indices: vec![],
        material_offsets: Vec::new(),
    };
    for (normal, quad) in faces {
        let base = sides.positions.len() as u32;
        sides.positions.extend_from_slice(&quad);
        sides.normals.extend_from_slice(&[normal; 4]);
        sides.indices.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    Scene {
        meshes: vec![top, sides],
        materials: vec![Material::diffuse(Vec3::splat(albedo)), Material::diffuse(Vec3::splat(0.5))],
        instances: vec![
            Instance { mesh: 0, transform: Mat4::IDENTITY, material: 0 },
            Instance { mesh: 1, transform: Mat4::IDENTITY, material: 1 },
        ],
        environment: env,
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: Vec::new(),
        blockers: SceneBlockers { spheres: vec![None, None], ..Default::default() },
        camera: Camera { eye: Vec3::new(0.0, 1.0, 2.8), target: Vec3::new(0.0, 0.0, 0.0), fov_y_degrees: 45.0 },
    }
}

/// A smooth-shaded cube (half-size 1 at the origin, 8 shared corners whose normals are the corners'
/// directions, the classic averaged-normal box) under `env`, diffuse albedo `albedo`, seen from
/// 10°–20° above its top face: the interpolated normal tilts up to 45° towards the back on the far
/// half of the top face, past the view direction, while the face itself faces the camera (the
/// bunny's silhouette pixels, issue 15 item 5, over a large area).
pub fn smooth_cube(env: LatLongMap, albedo: f32) -> Scene {
    let positions: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            )
        })
        .collect();
    let normals = positions.iter().map(|p| p.normalize()).collect();
    // Corner index = x + 2y + 4z (bits); each face as two triangles, counter-clockwise from outside.
    let quads = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let indices = quads.iter().flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]]).collect();
    let cube =
        engine::scene::Mesh { name: "smooth-cube".into(), positions, normals, indices, material_offsets: Vec::new() };
    Scene {
        meshes: vec![cube],
        materials: vec![Material::diffuse(Vec3::splat(albedo))],
        instances: vec![Instance { mesh: 0, transform: Mat4::IDENTITY, material: 0 }],
        environment: env,
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: Vec::new(),
        blockers: SceneBlockers { spheres: vec![None], ..Default::default() },
        camera: Camera { eye: Vec3::new(0.0, 1.8, 3.2), target: Vec3::new(0.0, 0.3, 0.0), fov_y_degrees: 45.0 },
    }
}

/// Every analytic scene of this file under `env`, named, at parameters the other tests use: the test scenes
/// of the artefact gate (tests/tests/artefact_gate.rs), which also takes every registered demo scene. A new
/// fixture joins the gate by being listed here.
pub fn gate_scenes(env: &LatLongMap) -> Vec<(&'static str, Scene)> {
    vec![
        ("fixture:sphere-over-plane", sphere_over_plane(env.clone(), 0.6, Vec3::new(0.0, 0.8, 0.0), 0.5)),
        ("fixture:sheet-over-plane", sheet_over_plane(env.clone(), 0.7, 0.5, 0.7, 8)),
        (
            "fixture:ball-above-half-space",
            ball_above_ground(env.clone(), 0.7, Vec3::new(0.0, 0.6, 0.0), 0.4, GroundBlocker::HalfSpace),
        ),
        (
            "fixture:ball-above-rectangle",
            ball_above_ground(env.clone(), 0.7, Vec3::new(0.0, 0.6, 0.0), 0.4, GroundBlocker::Rectangle),
        ),
        ("fixture:tilted-normal-box", tilted_normal_box(env.clone(), 0.7, 0.7, 4)),
        ("fixture:smooth-cube", smooth_cube(env.clone(), 0.8)),
    ]
}
