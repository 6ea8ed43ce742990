//! `lamp`: the bunny on its ground plane under the courtyard dimmed to 0.3, lit by two warm spherical
//! lights behind it that outshine it, so that the bunny casts two overlapping soft shadows towards the camera.

use super::{SceneEntry, SceneInputs};
use engine::scene::{Scene, SphereLight};
use glam::Vec3;

pub const SCENE: SceneEntry = SceneEntry {
    name: "lamp",
    summary: "the bunny under two warm spherical lights behind it (courtyard dimmed to 0.3): soft light shadows",
    build,
    motion: Some(super::bunny::TURNTABLE),
};

/// `lamp-one`: `lamp` with its key light alone (one soft shadow; the cosine-lobe technique's one-light case).
pub const SCENE_ONE: SceneEntry = SceneEntry {
    name: "lamp-one",
    summary: "lamp with its key light alone (one soft shadow)",
    build: build_one,
    motion: Some(super::bunny::TURNTABLE),
};

fn build_one(inputs: &SceneInputs) -> anyhow::Result<Scene> {
    let mut scene = build(inputs)?;
    scene.lights.truncate(1);
    Ok(scene)
}

fn build(inputs: &SceneInputs) -> anyhow::Result<Scene> {
    let mut scene = super::bunny::scene(inputs)?;
    scene.environment_intensity = ENVIRONMENT_INTENSITY;
    scene.lights = lights();
    Ok(scene)
}

/// The courtyard's scale in `lamp`.
pub const ENVIRONMENT_INTENSITY: f32 = 0.3;

/// The two lights, behind the bunny (unit height, base centred at the origin) about 1.6 from its centre: a key light
/// at its back left and a smaller one at its back right, so that their soft shadows fall towards the camera onto
/// the ground in view and overlap in front of it. Penumbrae of about 2r·h/(H − h) ≈ 0.36 for the bunny's middle
/// (h = 0.5, H = 1.2, r = 0.25). On the lit ground they give about 1.5× the dimmed courtyard's radiance (green;
/// 2× red), and in the overlapped shadow in front of the bunny the ground falls to about a quarter of the lit
/// ground's radiance (`demo --scene lamp --technique reference --spp 256 --width 160 --height 120`).
pub fn lights() -> Vec<SphereLight> {
    vec![
        SphereLight { center: Vec3::new(-1.0, 1.2, -1.0), radius: 0.25, radiance: Vec3::new(1.0, 0.75, 0.5) * 50.0 },
        SphereLight { center: Vec3::new(1.1, 1.3, -0.8), radius: 0.2, radiance: Vec3::new(1.0, 0.85, 0.6) * 70.0 },
    ]
}
