//! Scene builders for the demos and tests: the default bunny scene and analytic test scenes.
//! (chess, cloth and battle arrive with their issues.)

use engine::blockers::Sphere;
use engine::math::envmap::LatLongMap;
use engine::scene::blockers::fitted_spheres;
use engine::scene::{load_environment, load_obj, Camera, Instance, Material, Mesh, Scene, SceneBlockers, Skin};
use glam::{Mat4, Vec3};
use std::path::{Path, PathBuf};

pub mod capture;
pub mod export;
pub mod measure;
pub mod report;
pub mod viewer;

/// The project's `assets/` folder (`ENGINE_ASSETS` overrides).
pub fn assets_dir() -> PathBuf {
    std::env::var_os("ENGINE_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets"))
}

/// The binaries' `main`: print the error with its causes as `error: …` and exit with status 1.
pub fn exit_on_error(result: anyhow::Result<()>) {
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// Scenes `--scene` accepts.
pub const SCENES: &[&str] = &["bunny", "furnace", "sphere", "arm", "sheet"];

/// A square ground plane of half-size `half` at y = 0, tessellated `n` × `n` (per-vertex shading
/// needs vertices), normal +Y.
pub fn ground_plane(half: f32, n: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let x = -half + 2.0 * half * i as f32 / n as f32;
            let z = -half + 2.0 * half * j as f32 / n as f32;
            positions.push(Vec3::new(x, 0.0, z));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    let normals = vec![Vec3::Y; positions.len()];
    Mesh { name: "ground".into(), positions, normals, indices }
}

/// A UV sphere of radius 1 with `stacks` × `2·stacks` quads.
pub fn uv_sphere(stacks: u32) -> Mesh {
    let slices = 2 * stacks;
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for j in 0..=stacks {
        let theta = std::f32::consts::PI * j as f32 / stacks as f32;
        for i in 0..=slices {
            let phi = 2.0 * std::f32::consts::PI * i as f32 / slices as f32;
            positions.push(Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
        }
    }
    for j in 0..stacks {
        for i in 0..slices {
            let a = j * (slices + 1) + i;
            let (b, c, d) = (a + 1, a + slices + 1, a + slices + 2);
            if j != 0 {
                indices.extend_from_slice(&[a, b, c]);
            }
            if j != stacks - 1 {
                indices.extend_from_slice(&[b, d, c]);
            }
        }
    }
    let normals = positions.clone();
    Mesh { name: "sphere".into(), positions, normals, indices }
}

/// The default scene: the Stanford bunny (scaled to unit height) on a ground plane under the
/// courtyard environment (CC0, Poly Haven).
pub fn bunny_scene(env: Option<&Path>) -> anyhow::Result<Scene> {
    let assets = assets_dir();
    let bunny = load_obj(&assets.join("meshes/bunny.obj"))?;
    let env_path = env.map(Path::to_path_buf).unwrap_or_else(|| assets.join("envmaps/courtyard.exr"));
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
    let spheres = fitted_spheres(&bunny, &settings, &assets.join("meshes/bunny.spheres.json"))?;
    Ok(Scene {
        meshes: vec![bunny, ground_plane(2.0, 32)],
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
        lights: Vec::new(),
        blockers: SceneBlockers { spheres: vec![Some(spheres)], ..Default::default() },
        camera: Camera { eye: Vec3::new(0.0, 0.9, 2.4), target: Vec3::new(0.0, 0.4, 0.0), fov_y_degrees: 40.0 },
    })
}

/// Furnace: a Lambertian plane of albedo ρ under a constant environment L, looked at from above;
/// every covered pixel must shade to ρL.
pub fn furnace_scene(albedo: f32, radiance: f32) -> Scene {
    Scene {
        meshes: vec![ground_plane(1.0, 4)],
        materials: vec![Material::diffuse(Vec3::splat(albedo))],
        instances: vec![Instance { mesh: 0, transform: Mat4::IDENTITY, material: 0 }],
        environment: LatLongMap::constant(64, 32, [radiance; 3]),
        environment_intensity: 1.0,
        lights: Vec::new(),
        blockers: Default::default(),
        camera: Camera { eye: Vec3::new(0.0, 1.5, 0.01), target: Vec3::ZERO, fov_y_degrees: 40.0 },
    }
}

/// A finely tessellated diffuse sphere under a smooth environment (a sky gradient): per-vertex
/// and per-pixel shading must agree.
pub fn sphere_scene(stacks: u32) -> Scene {
    let (w, h) = (64, 32);
    let texels = (0..w * h)
        .map(|i| {
            let v = ((i / w) as f32 + 0.5) / h as f32;
            let up = (std::f32::consts::PI * v).cos();
            [0.6 + 0.5 * up, 0.7 + 0.4 * up, 1.0 + 0.2 * up].map(|c| c.max(0.05))
        })
        .collect();
    Scene {
        meshes: vec![uv_sphere(stacks)],
        materials: vec![Material::diffuse(Vec3::new(0.8, 0.6, 0.4))],
        instances: vec![Instance { mesh: 0, transform: Mat4::IDENTITY, material: 0 }],
        environment: LatLongMap { width: w, height: h, texels },
        environment_intensity: 1.0,
        lights: Vec::new(),
        blockers: Default::default(),
        camera: Camera { eye: Vec3::new(0.0, 0.8, 3.0), target: Vec3::ZERO, fov_y_degrees: 45.0 },
    }
}

/// Set the specular BRDF of material 0 from a `--brdf` spec
/// ([`engine::scene::Material::apply_brdf_spec`]).
pub fn apply_brdf(scene: &mut Scene, spec: &str) -> anyhow::Result<()> {
    let m = scene.materials.first_mut().ok_or_else(|| anyhow::anyhow!("--brdf: the scene has no material"))?;
    m.apply_brdf_spec(spec).map_err(anyhow::Error::msg)
}

/// Build a scene by name.
pub fn build_scene(name: &str, env: Option<&Path>) -> anyhow::Result<Scene> {
    match name {
        "bunny" => bunny_scene(env),
        "furnace" => Ok(furnace_scene(0.5, 1.0)),
        "sphere" => Ok(sphere_scene(64)),
        "arm" => Ok(arm_scene(std::f32::consts::FRAC_PI_3)),
        "sheet" => sheet_scene(env),
        other => anyhow::bail!("unknown scene '{other}' (available: {})", SCENES.join(", ")),
    }
}

/// A skinned cylinder "arm" along +x from 0 to [`ARM_LENGTH`], radius [`ARM_RADIUS`], with two bones:
/// bone 0 (upper arm) is the identity, bone 1 (forearm) rotates about the elbow at x = 1 around +z.
/// Skin weights blend linearly over x in [0.8, 1.2]. Returns the mesh and its skin.
pub fn skinned_arm(rings: u32, segments: u32) -> (Mesh, Skin) {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut indices = Vec::new();
    for i in 0..=rings {
        let x = ARM_LENGTH * i as f32 / rings as f32;
        for j in 0..segments {
            let a = std::f32::consts::TAU * j as f32 / segments as f32;
            let (s, c) = a.sin_cos();
            positions.push(Vec3::new(x, ARM_RADIUS * c, ARM_RADIUS * s));
            normals.push(Vec3::new(0.0, c, s));
        }
    }
    for i in 0..rings {
        for j in 0..segments {
            let a = i * segments + j;
            let b = i * segments + (j + 1) % segments;
            let (c, d) = (a + segments, b + segments);
            indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    let skin = Skin {
        joints: vec![[0, 1, 0, 0]; positions.len()],
        weights: positions
            .iter()
            .map(|p| {
                let t = ((p.x - 0.8) / 0.4).clamp(0.0, 1.0);
                [1.0 - t, t, 0.0, 0.0]
            })
            .collect(),
    };
    (Mesh { name: "arm".into(), positions, normals, indices }, skin)
}

pub const ARM_LENGTH: f32 = 2.0;
pub const ARM_RADIUS: f32 = 0.15;

/// Spheres along the arm's axis that bound the cylinder at rest: centres every `spacing`, radius
/// sqrt(r² + (spacing/2)²) so the cylinder between two centres is covered.
pub fn arm_spheres(count: u32) -> Vec<Sphere> {
    let spacing = ARM_LENGTH / (count - 1) as f32;
    let radius = (ARM_RADIUS * ARM_RADIUS + 0.25 * spacing * spacing).sqrt();
    (0..count).map(|i| Sphere::new(glam::DVec3::new((spacing * i as f32) as f64, 0.0, 0.0), radius as f64)).collect()
}

/// Bone matrices of the arm with the forearm bent by `angle` (radians) about the elbow (x = 1, +z axis).
pub fn arm_bones(angle: f32) -> Vec<Mat4> {
    let elbow = Vec3::new(1.0, 0.0, 0.0);
    vec![Mat4::IDENTITY, Mat4::from_translation(elbow) * Mat4::from_rotation_z(angle) * Mat4::from_translation(-elbow)]
}

/// The skinned arm, bent by `angle`, raised above a ground plane under the smooth sky of
/// [`sphere_scene`]; 12 blocker spheres follow the skin.
pub fn arm_scene(angle: f32) -> Scene {
    let (arm, skin) = skinned_arm(24, 16);
    let sky = sphere_scene(2).environment;
    Scene {
        meshes: vec![arm, ground_plane(2.0, 16)],
        materials: vec![Material::diffuse(Vec3::new(0.8, 0.5, 0.4)), Material::diffuse(Vec3::splat(0.6))],
        instances: vec![
            Instance { mesh: 0, transform: Mat4::from_translation(Vec3::new(-1.0, 0.5, 0.0)), material: 0 },
            Instance { mesh: 1, transform: Mat4::IDENTITY, material: 1 },
        ],
        environment: sky,
        environment_intensity: 1.0,
        lights: Vec::new(),
        blockers: SceneBlockers {
            spheres: vec![Some(arm_spheres(12))],
            skins: vec![Some(skin)],
            bones: arm_bones(angle),
            thin: Vec::new(),
        },
        camera: Camera { eye: Vec3::new(0.0, 1.5, 3.5), target: Vec3::new(0.0, 0.5, 0.0), fov_y_degrees: 45.0 },
    }
}

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

/// A cloth-like sheet: `n` × `n` quads over [−half, half]² in x and z, at height
/// `y(u, v) = −sag (1 − u²)(1 − v²) − slope v` with u, v ∈ [−1, 1] the normalized x and z (a gentle drape,
/// lowest in the middle, tilted down towards +z by `slope`); normals area-weighted from the triangles.
pub fn sheet_mesh(n: u32, half: f32, sag: f32, slope: f32) -> Mesh {
    let mut m = ground_plane(half, n);
    for p in &mut m.positions {
        let (u, v) = (p.x / half, p.z / half);
        p.y = -sag * (1.0 - u * u) * (1.0 - v * v) - slope * v;
    }
    m.normals = engine::scene::compute_normals(&m.positions, &m.indices);
    m.name = "sheet".into();
    m
}

/// Demo scene `sheet`: the bunny scene with a cloth-like sheet (24 × 24 quads, 1.2 × 1.2, sagging
/// 0.15 and tilted towards the camera) hanging above the bunny's left half, marked thin (ISG §5: its
/// triangles are its blockers, no spheres); its soft shadow falls on the bunny and the ground. Meshes
/// are two-sided, so the sheet's underside, which the camera sees, is shaded with the flipped normal.
/// (Not the simulated `cloth` scene.)
pub fn sheet_scene(env: Option<&Path>) -> anyhow::Result<Scene> {
    let mut scene = bunny_scene(env)?;
    scene.meshes.push(sheet_mesh(24, 0.6, 0.15, 0.1));
    scene.materials.push(Material::diffuse(Vec3::new(0.65, 0.18, 0.14)));
    scene.instances.push(Instance {
        mesh: 2,
        transform: Mat4::from_translation(Vec3::new(-0.45, 1.35, 0.1)),
        material: 2,
    });
    scene.blockers.thin = vec![false, false, true];
    // Higher and further back than the bunny scene's view: the sheet, the bunny under it and the ground around.
    scene.camera = Camera { eye: Vec3::new(0.9, 1.9, 2.6), target: Vec3::new(-0.2, 0.45, 0.0), fov_y_degrees: 45.0 };
    Ok(scene)
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

/// Motion over time for the demo and the viewer (`--animate`): the bunny turns on its base (a rigid
/// transform: its blocker spheres follow; in `sheet` the sheet stays), the arm bends between 0° and 60° (the bones: skin and
/// skinned spheres follow). Other scenes are static.
pub struct Animation {
    kind: AnimationKind,
}

enum AnimationKind {
    /// Instance `index` turns about +Y (world) from its base transform.
    Turntable {
        index: usize,
        base: Mat4,
    },
    ArmBend,
}

impl Animation {
    /// The animation of a demo scene built by [`build_scene`], if it has one.
    pub fn for_scene(name: &str, scene: &Scene) -> Option<Self> {
        match name {
            "bunny" | "sheet" => {
                scene.instances.first().map(|i| Self { kind: AnimationKind::Turntable { index: 0, base: i.transform } })
            }
            "arm" => Some(Self { kind: AnimationKind::ArmBend }),
            _ => None,
        }
    }

    /// Pose the renderer's scene at time `t` seconds (no allocation).
    pub fn apply(&self, renderer: &mut engine::renderer::Renderer, t: f32) -> engine::gpu::Result<()> {
        match self.kind {
            AnimationKind::Turntable { index, base } => {
                renderer.set_instance_transform(index, Mat4::from_rotation_y(0.5 * t) * base)
            }
            AnimationKind::ArmBend => {
                let angle = 60f32.to_radians() * (0.5 - 0.5 * (1.3 * t).cos());
                renderer.set_bones(&arm_bones(angle))
            }
        }
    }
}
