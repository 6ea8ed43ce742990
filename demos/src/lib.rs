//! The demos: the scene registry ([`scenes`]), the viewer, capture, the report sweep, the Mitsuba export and
//! the measurement helpers of the binaries in src/bin.

use engine::scene::Scene;
use std::path::PathBuf;

pub mod bench;
pub mod capture;
pub mod characters;
pub mod env_lights;
pub mod export;
pub mod gltf_writer;
pub mod measure;
pub mod report;
pub mod results_page;
pub mod scenes;
pub mod soak;
pub mod viewer;

pub use scenes::Animation;

/// The project's `assets/` folder (`ENGINE_ASSETS` overrides).
pub fn assets_dir() -> PathBuf {
    std::env::var_os("ENGINE_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets"))
}

/// Install the logger of a binary: `RUST_LOG` as `env_logger` reads it, warnings and errors when it is unset
/// (the engine reports dropped triangles, recomputed normals, missing materials and the validation-layer
/// fallback as warnings). Every binary of the workspace calls this or its one line first.
pub fn init_logging() {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
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
