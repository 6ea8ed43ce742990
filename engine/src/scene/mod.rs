//! `engine::scene`: meshes, materials, environment, camera — plain data, no Vulkan.

pub mod blockers;
pub mod cloth;
mod env;
pub mod gltf_import;
pub mod material_map;
mod mesh;
pub mod triangle_bvh;

pub use blockers::{SceneBlockers, Skin};
pub use env::{load_environment, load_environment_with_repairs, MAX_ENV_SIDE, MAX_ENV_TEXELS};
pub use gltf_import::{Clip, GltfScene, Rig, RigPose};
pub use mesh::{compute_normals, load_gltf, load_obj, load_obj_with_materials, material_from_mtl, Mesh};

use crate::options::{Kind, OptionSpec};
use glam::{Mat4, Vec3};
use std::path::PathBuf;

/// Errors loading scene input: always name the file and the problem.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: file not found")]
    NotFound { path: PathBuf },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
}

impl SceneError {
    /// The message is [`engine_io::shorten`]ed: it may quote the file's content.
    pub(crate) fn invalid(path: &std::path::Path, message: impl Into<String>) -> Self {
        Self::Invalid { path: path.to_path_buf(), message: engine_io::shorten(&message.into()) }
    }
}

impl From<engine_io::InputError> for SceneError {
    fn from(e: engine_io::InputError) -> Self {
        match e {
            engine_io::InputError::NotFound { path } => SceneError::NotFound { path },
            engine_io::InputError::Refused { path, message } => SceneError::Invalid { path, message },
        }
    }
}

pub type Result<T> = std::result::Result<T, SceneError>;

/// The one rule for material values read from files (`.mtl`, glTF, scene files): every value must be a finite
/// number. NaN and infinities (also a finite literal beyond f32, such as 1e39) are refused with an error naming
/// the file, the material value and the line or key where the format has them; they are never replaced, since no
/// default would be what the file meant. Finite values out of range are clamped as each loader documents.
pub fn check_material_values(what: &str, values: &[f32]) -> std::result::Result<(), String> {
    match values.iter().any(|v| !v.is_finite()) {
        true => Err(format!("{what} is not finite ({values:?} as f32): material values must be finite numbers")),
        false => Ok(()),
    }
}

/// Our material model: Lambertian diffuse plus one specular term `f = ρ_d/π + f_s`
/// (the ISG paper's k_d + k_s s(ω_i, ω_o) form), f_s chosen by [`Brdf`]:
/// - [`Brdf::BlinnPhong`] (default): `k_s (s+8)/(8π) (n·h)^s`, s = [`Material::shininess`];
/// - [`Brdf::CookTorrance`]: `D F G / (4 n·l n·v)`, Beckmann or GGX D of width α = `roughness`,
///   Schlick F with F0 = k_s, separable Smith G of the same NDF;
/// - [`Brdf::AshikhminShirley`]: anisotropic exponents n_u (along the tangent t), n_v (along n × t),
///   Schlick F with F0 = k_s. The tangent at a point is [`Material::tangent`] (a world-space
///   direction) projected on the tangent plane (no UVs or per-vertex tangents needed; it does not
///   follow an object's rotation).
///
/// k_s = 0 means "no specular layer" in every model. Exact formulas: `engine::math::brdf`.
/// glTF metallic-roughness maps onto Blinn-Phong in [`Material::from_metallic_roughness`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Diffuse reflectance ρ_d (albedo), linear RGB.
    pub diffuse: Vec3,
    /// Specular scale k_s (Cook-Torrance, Ashikhmin–Shirley: Fresnel F0), linear RGB.
    pub specular: Vec3,
    /// Blinn-Phong exponent s (glossiness), used by [`Brdf::BlinnPhong`].
    pub shininess: f32,
    /// The specular model.
    pub brdf: Brdf,
    /// Ashikhmin–Shirley: world-space direction whose projection on the tangent plane is t.
    pub tangent: Vec3,
}

/// The specular term of a [`Material`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Brdf {
    /// Normalized Blinn-Phong with exponent [`Material::shininess`].
    #[default]
    BlinnPhong,
    /// Cook-Torrance with the NDF `ndf` of width α = `roughness`.
    CookTorrance { ndf: Ndf, roughness: f32 },
    /// Ashikhmin–Shirley with exponents n_u, n_v.
    AshikhminShirley { nu: f32, nv: f32 },
    /// One Lafortune lobe `k_s (e+2)/(2π) max(C_x l_t v_t + C_y l_b v_b + C_z l_n v_n, 0)^e` in the
    /// frame of [`Material::tangent`] (|C_i| ≤ 1); C = (−1, −1, 1) is the modified Phong model
    /// (`--brdf phong`). Cosine-lobes paper Eq. 24–30; `engine::math::brdf`. `more`: Eq. 28's further
    /// lobes, each `w k_s (e+2)/(2π) max(…, 0)^e` with its own C and e (w = 0: absent).
    Lafortune { c: [f32; 3], e: f32, more: [LafortuneLobe; LAFORTUNE_MORE] },
}

pub use engine_math::brdf::LAFORTUNE_MORE;

/// A further lobe of a [`Brdf::Lafortune`] material: C, e and its weight w relative to k_s
/// (ρ_i = w k_s, so k_s = 0 still means "no specular layer"); w = 0: absent.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LafortuneLobe {
    pub c: [f32; 3],
    pub e: f32,
    pub w: f32,
}

impl Brdf {
    /// One Lafortune lobe.
    pub const fn lafortune(c: [f32; 3], e: f32) -> Self {
        Brdf::Lafortune { c, e, more: [LafortuneLobe { c: [0.0; 3], e: 0.0, w: 0.0 }; LAFORTUNE_MORE] }
    }
}

/// Lafortune's C for the modified Phong model (the mirror direction).
pub const PHONG_C: [f32; 3] = [-1.0, -1.0, 1.0];

pub use engine_math::sg::Ndf;

impl Material {
    pub fn diffuse(albedo: Vec3) -> Self {
        Self { diffuse: albedo, specular: Vec3::ZERO, shininess: 1.0, brdf: Brdf::BlinnPhong, tangent: Vec3::Y }
    }
    pub fn glossy(albedo: Vec3, ks: f32, shininess: f32) -> Self {
        Self { specular: Vec3::splat(ks), shininess, ..Self::diffuse(albedo) }
    }
    /// glTF base colour / metallic / roughness: ρ_d = base (1 − metallic), k_s = mix(0.04, base,
    /// metallic), and s = 2/α² − 2 with α = roughness² (the Beckmann–Blinn correspondence), clamped
    /// to [1, 1e5].
    pub fn from_metallic_roughness(base: Vec3, metallic: f32, roughness: f32) -> Self {
        let m = metallic.clamp(0.0, 1.0);
        let alpha = (roughness.clamp(0.0, 1.0) * roughness.clamp(0.0, 1.0)).max(1e-3);
        Self {
            specular: Vec3::splat(0.04).lerp(base, m),
            shininess: (2.0 / (alpha * alpha) - 2.0).clamp(1.0, 1e5),
            ..Self::diffuse(base * (1.0 - m))
        }
    }

    /// The specular model in f64 for `engine::math::brdf`.
    pub fn specular_model(&self) -> engine_math::brdf::SpecularModel {
        use engine_math::brdf::SpecularModel as M;
        match self.brdf {
            Brdf::BlinnPhong => M::BlinnPhong { s: self.shininess as f64 },
            Brdf::CookTorrance { ndf, roughness } => M::CookTorrance { ndf, alpha: roughness as f64 },
            Brdf::AshikhminShirley { nu, nv } => M::AshikhminShirley { nu: nu as f64, nv: nv as f64 },
            Brdf::Lafortune { c, e, more } => M::Lafortune {
                c: c.map(|x| x as f64),
                e: e as f64,
                more: more.map(|l| engine_math::brdf::LafortuneTerm {
                    c: l.c.map(|x| x as f64),
                    e: l.e as f64,
                    w: l.w as f64,
                }),
            },
        }
    }

    /// Set the specular model from a spec `kind[:key=value,...]` (the `--brdf` option):
    /// `blinn-phong:s=1000,ks=0.5`, `cook-torrance:roughness=0.1,ndf=ggx,ks=0.5` (ndf `beckmann`
    /// (default) or `ggx`), `ashikhmin-shirley:nu=1000,nv=100,ks=0.5,tangent=0/1/0`, `phong:e=100,ks=0.5`,
    /// `lafortune:cx=-1,cy=-0.5,cz=0.9,e=50,ks=0.5,tangent=1/0/0`. Keys not given keep the material's
    /// values (roughness 0.1, n_u = n_v = 100, Phong C and e = 100 when switching model). Every key
    /// is range-checked by the schemas of [`BRDF_MODELS`]; errors name the bad key.
    pub fn apply_brdf_spec(&mut self, spec: &str) -> std::result::Result<(), String> {
        use crate::options::Value;
        let (kind, pairs) = crate::options::split_spec(spec).map_err(|e| format!("--brdf {e}"))?;
        let Some((_, _, schema)) = BRDF_MODELS.iter().find(|(name, _, _)| *name == kind) else {
            let names: Vec<&str> = BRDF_MODELS.iter().map(|(n, _, _)| *n).collect();
            return Err(format!(
                "--brdf '{}': unknown model '{}' ({})",
                engine_io::excerpt(spec),
                engine_io::excerpt(kind),
                names.join(", ")
            ));
        };
        let o = crate::options::parse(&format!("--brdf '{kind}'"), schema, &pairs).map_err(|e| e.0)?;
        let mut m = *self;
        m.brdf = match kind {
            "cook-torrance" => match self.brdf {
                b @ Brdf::CookTorrance { .. } => b,
                _ => Brdf::CookTorrance { ndf: Ndf::Beckmann, roughness: 0.1 },
            },
            "ashikhmin-shirley" => match self.brdf {
                b @ Brdf::AshikhminShirley { .. } => b,
                _ => Brdf::AshikhminShirley { nu: 100.0, nv: 100.0 },
            },
            "phong" => match self.brdf {
                Brdf::Lafortune { e, .. } => Brdf::lafortune(PHONG_C, e),
                _ => Brdf::lafortune(PHONG_C, 100.0),
            },
            "lafortune" => match self.brdf {
                b @ Brdf::Lafortune { .. } => b,
                _ => Brdf::lafortune(PHONG_C, 100.0),
            },
            _ => Brdf::BlinnPhong,
        };
        let num = |key: &str| o.float_if_given(key).map(|x| x as f32);
        if let Some(ks) = num("ks") {
            m.specular = Vec3::splat(ks);
        }
        if let Some(kd) = num("kd") {
            m.diffuse = Vec3::splat(kd);
        }
        if let Some(s) = num("s") {
            m.shininess = s;
        }
        match &mut m.brdf {
            Brdf::CookTorrance { roughness, ndf } => {
                if let Some(r) = num("roughness") {
                    *roughness = r;
                }
                if let Some(Value::Choice(n)) = o.get("ndf") {
                    *ndf = if n == "ggx" { Ndf::Ggx } else { Ndf::Beckmann };
                }
            }
            Brdf::AshikhminShirley { nu, nv } => {
                if let Some(x) = num("nu") {
                    *nu = x;
                }
                if let Some(x) = num("nv") {
                    *nv = x;
                }
                if let Some(Value::Direction(d)) = o.get("tangent") {
                    m.tangent = Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32).normalize();
                }
            }
            Brdf::Lafortune { c, e, more } => {
                for (k, key) in ["cx", "cy", "cz"].iter().enumerate() {
                    if let Some(x) = num(key) {
                        c[k] = x;
                    }
                }
                if let Some(x) = num("e") {
                    *e = x;
                }
                // Further lobes i = 1, 2: keys cx1 … e1, w1; a lobe that was absent starts as Phong with
                // lobe 0's exponent.
                for (i, lobe) in more.iter_mut().enumerate() {
                    let key = |k: &str| format!("{k}{}", i + 1);
                    let given: Vec<String> =
                        ["cx", "cy", "cz", "e", "w"].iter().map(|k| key(k)).filter(|k| o.get(k).is_some()).collect();
                    if given.is_empty() {
                        continue;
                    }
                    if lobe.w <= 0.0 {
                        *lobe = LafortuneLobe { c: PHONG_C, e: *e, w: 0.0 };
                    }
                    for (k, name) in ["cx", "cy", "cz"].iter().enumerate() {
                        if let Some(x) = num(&key(name)) {
                            lobe.c[k] = x;
                        }
                    }
                    if let Some(x) = num(&key("e")) {
                        lobe.e = x;
                    }
                    if let Some(x) = num(&key("w")) {
                        lobe.w = x;
                    }
                    if lobe.w <= 0.0 && given.iter().any(|k| !k.starts_with('w')) {
                        return Err(format!(
                            "--brdf '{spec}': {} set lobe {} but its weight {} is 0 (the lobe is absent)",
                            given.join(", "),
                            i + 1,
                            key("w")
                        ));
                    }
                    if lobe.w <= 0.0 {
                        *lobe = LafortuneLobe::default();
                    }
                }
                if let Some(Value::Direction(d)) = o.get("tangent") {
                    m.tangent = Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32).normalize();
                }
            }
            Brdf::BlinnPhong => {}
        }
        *self = m;
        Ok(())
    }
}

const KS: OptionSpec = OptionSpec {
    key: "ks",
    aliases: &[],
    kind: Kind::closed(0.0, 1.0),
    default: None,
    help: "specular reflectance k_s (F0 of the Fresnel term; 0: no specular layer)",
};
const KD: OptionSpec = OptionSpec {
    key: "kd",
    aliases: &[],
    kind: Kind::closed(0.0, 1.0),
    default: None,
    help: "diffuse albedo ρ_d (grey)",
};

/// The `--brdf` models: name, one-line summary, option schema (no defaults: keys not given keep the
/// material's values).
pub const BRDF_MODELS: &[(&str, &str, &[OptionSpec])] = &[
    (
        "blinn-phong",
        "k_s (s+8)/(8π) (n·h)^s",
        &[
            KS,
            KD,
            OptionSpec { key: "s", aliases: &[], kind: Kind::closed(1e-3, 1e6), default: None, help: "exponent s" },
        ],
    ),
    (
        "cook-torrance",
        "D F G / (4 n·l n·v), Schlick F with F0 = k_s, separable Smith G",
        &[
            KS,
            KD,
            OptionSpec {
                key: "roughness",
                aliases: &[],
                kind: Kind::closed(1e-3, 1.0),
                default: None,
                help: "NDF width α (used as α, not squared)",
            },
            OptionSpec {
                key: "ndf",
                aliases: &[],
                kind: Kind::Choice(&["beckmann", "ggx"]),
                default: None,
                help: "normal distribution",
            },
        ],
    ),
    (
        "ashikhmin-shirley",
        "anisotropic: exponents n_u along the tangent, n_v along n × t",
        &[
            KS,
            KD,
            OptionSpec { key: "nu", aliases: &[], kind: Kind::closed(1e-3, 1e6), default: None, help: "exponent n_u" },
            OptionSpec { key: "nv", aliases: &[], kind: Kind::closed(1e-3, 1e6), default: None, help: "exponent n_v" },
            TANGENT,
        ],
    ),
    ("phong", "modified Phong, k_s (e+2)/(2π) max(r·l, 0)^e (Lafortune with C = (−1, −1, 1))", &[KS, KD, EXPONENT]),
    (
        "lafortune",
        "Lafortune lobes k_s Σ_i w_i (e_i+2)/(2π) max(C_x l_t v_t + C_y l_b v_b + C_z l_n v_n, 0)^e_i: lobe 0 \
         (cx, cy, cz, e; w_0 = 1) and up to two more (cx1 … e1, w1; cx2 … e2, w2)",
        &[
            KS,
            KD,
            EXPONENT,
            spec_key("cx", Kind::closed(-1.0, 1.0), "C_x (along t)"),
            spec_key("cy", Kind::closed(-1.0, 1.0), "C_y (along n × t)"),
            spec_key("cz", Kind::closed(-1.0, 1.0), "C_z (along n)"),
            TANGENT,
            spec_key("w1", Kind::closed(0.0, 100.0), "weight of lobe 1 relative to k_s (0: no lobe 1)"),
            spec_key("cx1", Kind::closed(-1.0, 1.0), "C_x of lobe 1 (a new lobe starts as Phong)"),
            spec_key("cy1", Kind::closed(-1.0, 1.0), "C_y of lobe 1"),
            spec_key("cz1", Kind::closed(-1.0, 1.0), "C_z of lobe 1"),
            spec_key("e1", Kind::closed(1e-3, 1e6), "exponent of lobe 1 (a new lobe starts with e)"),
            spec_key("w2", Kind::closed(0.0, 100.0), "weight of lobe 2 relative to k_s (0: no lobe 2)"),
            spec_key("cx2", Kind::closed(-1.0, 1.0), "C_x of lobe 2"),
            spec_key("cy2", Kind::closed(-1.0, 1.0), "C_y of lobe 2"),
            spec_key("cz2", Kind::closed(-1.0, 1.0), "C_z of lobe 2"),
            spec_key("e2", Kind::closed(1e-3, 1e6), "exponent of lobe 2"),
        ],
    ),
];
const fn spec_key(key: &'static str, kind: Kind, help: &'static str) -> OptionSpec {
    OptionSpec { key, aliases: &[], kind, default: None, help }
}
const TANGENT: OptionSpec = OptionSpec {
    key: "tangent",
    aliases: &[],
    kind: Kind::Direction,
    default: None,
    help: "anisotropy direction (world space), projected on the tangent plane",
};
const EXPONENT: OptionSpec =
    OptionSpec { key: "e", aliases: &[], kind: Kind::closed(1e-3, 1e6), default: None, help: "lobe exponent e" };

/// `--help` text of the `--brdf` models and their keys.
pub fn brdf_help() -> String {
    BRDF_MODELS
        .iter()
        .map(|(name, summary, schema)| format!("  {name}: {summary}\n{}", crate::options::help_lines(schema, "      ")))
        .collect()
}

/// One drawable: a mesh, its object-to-world transform and its material index.
#[derive(Clone, Debug)]
pub struct Instance {
    pub mesh: usize,
    pub transform: Mat4,
    pub material: usize,
}

/// A pinhole camera (Y up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub fov_y_degrees: f32,
}

impl Camera {
    /// Orthonormal basis (right, up, forward) of the view.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let f = (self.target - self.eye).normalize_or(Vec3::NEG_Z);
        let r = f.cross(Vec3::Y).normalize_or(Vec3::X);
        let u = r.cross(f);
        (r, u, f)
    }
}

/// A spherical area light of uniform radiance (world space). Techniques and the reference treat
/// its radiance as added to the environment's along the directions it subtends (it does not hide
/// the environment behind it); it casts no shadow itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereLight {
    pub center: Vec3,
    pub radius: f32,
    /// Emitted radiance, linear RGB.
    pub radiance: Vec3,
}

/// The largest radiance a scene may carry, per channel: a light's radiance, and the environment's intensity times
/// its brightest texel. Shading multiplies radiance by the BRDF (Blinn-Phong s = 10⁶ peaks at (s+8)/(8π) ≈ 4·10⁴)
/// and a light's solid angle (at most 2π), the reference sums the squares of such samples over up to 2¹⁶ samples
/// for its variance, and `--exposure` scales by up to 10⁶: with 10⁹ the squares stay near 10³⁴, within f32's
/// 3.4·10³⁸, and exposed values stay finite. A light of radiance 10³⁸ gave an EXR of values up to 1.1·10³⁶ (and
/// inf/NaN on the way). The bound is far above any measured sky (the sun's disc is ~10⁹ W/(sr·m²) in physical
/// units; HDR maps store it scaled far lower).
pub const MAX_RADIANCE: f32 = 1e9;

/// The scene's radiance within [`MAX_RADIANCE`]: every light's radiance finite, ≥ 0 and at most the bound per
/// channel, the environment's intensity finite and ≥ 0, and its product with the map's brightest texel at most the
/// bound. Checked when a scene is uploaded; a scene file names its own keys before that.
pub fn check_radiance(scene: &Scene) -> std::result::Result<(), String> {
    for (i, l) in scene.lights.iter().enumerate() {
        let r = l.radiance;
        if !r.is_finite() || r.min_element() < 0.0 || r.max_element() > MAX_RADIANCE {
            return Err(format!(
                "light {i}: radiance [{}, {}, {}] is not in [0, {MAX_RADIANCE:e}] per channel (what f32 shading \
                 carries)",
                r.x, r.y, r.z
            ));
        }
    }
    let (intensity, brightest) = (scene.environment_intensity, brightest_texel(&scene.environment));
    if !intensity.is_finite() || intensity < 0.0 {
        return Err(format!("environment intensity {intensity} is not a finite number ≥ 0"));
    }
    let product = intensity as f64 * brightest as f64;
    if product > MAX_RADIANCE as f64 {
        return Err(format!(
            "environment intensity {intensity} × its brightest texel {brightest:e} = {product:e}: more than the \
             {MAX_RADIANCE:e} f32 shading carries"
        ));
    }
    Ok(())
}

/// The largest channel of any texel of `map` (0 for an empty map; the loaders have made every texel finite).
pub fn brightest_texel(map: &engine_math::envmap::LatLongMap) -> f32 {
    map.texels.iter().flat_map(|t| t.iter().copied()).fold(0.0, f32::max)
}

/// Everything a frame renders.
#[derive(Clone, Debug)]
pub struct Scene {
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    pub instances: Vec<Instance>,
    pub environment: engine_math::envmap::LatLongMap,
    /// Radiance scale applied to the environment.
    pub environment_intensity: f32,
    /// Spherical lights (may be empty).
    pub lights: Vec<SphereLight>,
    /// How the environment's bright regions become spherical lights for the techniques whose `env_lights`
    /// option is on ([`engine_math::env_lights`]; `max_lights = 0`: never).
    pub env_lights: engine_math::env_lights::EnvLightParams,
    /// Blocker sphere sets per mesh, skins and bone matrices (`Default`: none).
    pub blockers: SceneBlockers,
    pub camera: Camera,
}

impl Scene {
    /// Axis-aligned bounds of every instance in world space.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for inst in &self.instances {
            for p in &self.meshes[inst.mesh].positions {
                let w = inst.transform.transform_point3(*p);
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brdf_specs_parse_and_name_bad_keys() {
        let mut m = Material::glossy(Vec3::splat(0.5), 0.15, 200.0);
        m.apply_brdf_spec("blinn-phong:s=1000,ks=0.5").unwrap();
        assert_eq!((m.brdf, m.shininess, m.specular), (Brdf::BlinnPhong, 1000.0, Vec3::splat(0.5)));
        m.apply_brdf_spec("cook-torrance:roughness=0.1,ndf=ggx").unwrap();
        assert_eq!(m.brdf, Brdf::CookTorrance { ndf: Ndf::Ggx, roughness: 0.1 });
        m.apply_brdf_spec("ashikhmin-shirley:nu=1000,nv=100,ks=0.25,tangent=1/0/0").unwrap();
        assert_eq!(m.brdf, Brdf::AshikhminShirley { nu: 1000.0, nv: 100.0 });
        assert_eq!((m.specular, m.tangent), (Vec3::splat(0.25), Vec3::X));
        m.apply_brdf_spec("phong:e=50").unwrap();
        assert_eq!(m.brdf, Brdf::lafortune(PHONG_C, 50.0));
        m.apply_brdf_spec("lafortune:cx=-0.9,cz=0.5").unwrap();
        assert_eq!(m.brdf, Brdf::lafortune([-0.9, -1.0, 0.5], 50.0), "keys not given are kept");
        // Further lobes: a new one starts as Phong with lobe 0's e; keys not given are kept.
        m.apply_brdf_spec("lafortune:w1=0.5,cz1=0.8,w2=0.25,e2=8").unwrap();
        let lobe = |c: [f32; 3], e: f32, w: f32| LafortuneLobe { c, e, w };
        let want = [lobe([-1.0, -1.0, 0.8], 50.0, 0.5), lobe(PHONG_C, 8.0, 0.25)];
        assert_eq!(m.brdf, Brdf::Lafortune { c: [-0.9, -1.0, 0.5], e: 50.0, more: want });
        m.apply_brdf_spec("lafortune:e1=4").unwrap();
        assert!(matches!(m.brdf, Brdf::Lafortune { more, .. } if more[0].e == 4.0 && more[1] == want[1]));
        m.apply_brdf_spec("lafortune:w2=0").unwrap();
        assert!(matches!(m.brdf, Brdf::Lafortune { more, .. } if more[1] == LafortuneLobe::default()), "w = 0 removes");
        m.apply_brdf_spec("phong").unwrap();
        assert_eq!(m.brdf, Brdf::lafortune(PHONG_C, 50.0), "phong resets C and the further lobes, keeps e");
        for (bad, key) in [
            ("cook-torrance:roughness=2", "roughness"),
            ("cook-torrance:s=10", "s"),
            ("ashikhmin-shirley:nu=x", "nu"),
            ("ashikhmin-shirley:tangent=0/0/0", "tangent"),
            ("blinn-phong:ks=-1", "ks"),
            ("cook-torrance:ndf=phong", "ndf"),
            ("lambert", "lambert"),
            ("blinn-phong:s", "s"),
            ("lafortune:cx=1.5", "cx"),
            ("phong:e=0", "e"),
            ("phong:cx=1", "cx"),
            ("lafortune:w1=-1", "w1"),
            ("lafortune:cx2=2", "cx2"),
            ("phong:w1=1", "w1"),
        ] {
            let before = m;
            let e = m.apply_brdf_spec(bad).unwrap_err();
            assert!(e.contains(&format!("'{key}'")), "{bad}: {e}");
            assert_eq!(m, before, "a failed spec leaves the material unchanged");
        }
        // A further lobe's keys without its weight: an error naming the weight.
        let e = m.apply_brdf_spec("lafortune:e2=5").unwrap_err();
        assert!(e.contains("w2") && e.contains("e2"), "{e}");
    }
}
