//! Scene export for an offline cross-check: the current frame as a Mitsuba 3 scene (`demo --export DIR`).
//!
//! Writes into `DIR`:
//! - `scene.xml`: Mitsuba 3 scene description (`<scene version="3.0.0">`), `direct` integrator (direct lighting
//!   with MIS, which is what our techniques and our reference integrate: environment + spherical lights,
//!   with visibility, no interreflection);
//! - `meshes/<i>_<name>.ply`: every instance in world space (instance transform and linear blend skinning at the
//!   current bones applied, as the skin pass does), binary little-endian PLY with positions, vertex normals
//!   and triangles;
//! - `envmap.exr`: the environment resampled onto Mitsuba's lat-long grid (below), with the scene's intensity
//!   as the emitter's `scale`;
//! - `ours_bsdf.py`: our BRDFs as a Mitsuba 3 Python BSDF plugin (`ours`, below), `render.py`: the runner
//!   (`python3 render.py --spp N` renders the scene through the plugin and compares with `engine.exr`, our frame).
//!
//! **Environment orientation.** Ours: row 0 = zenith (+Y), `d = (sin θ cos φ, cos θ, sin θ sin φ)`, `u = φ/2π`,
//! `v = θ/π`. Mitsuba's `envmap` (src/emitters/envmap.cpp): in emitter space `d = (sin φ' sin θ, cos θ,
//! −cos φ' sin θ)`, `u = atan2(d.x, −d.z)/2π`, `v = θ/π`. The same u for every direction needs emitter-space
//! `(x, y, z) = (z_w, y_w, −x_w)`, i.e. `to_world`: world = (−z, y, x), a rotation by −90° about +Y
//! ([`ENVMAP_TO_WORLD`], written as an explicit matrix). **Grid.** Mitsuba puts column j at u = (j + ½)/W (as we
//! do) but row i at v = i/(H − 1) (rows on the poles, bilinear in between), where ours is at (i + ½)/H; so the
//! exported map is our bilinear lookup sampled at Mitsuba's row positions (same W × H). What remains is
//! interpolation: Mitsuba interpolates our (bilinear) map once more; our reference integrates the texels as
//! piecewise constant.
//!
//! **Materials** (`--export-bsdf`). `plugin` (default): every material is `<bsdf type="ours">` with our exact
//! f = ρ_d/π + f_s for all three specular models (Blinn-Phong, Cook-Torrance Beckmann/GGX, Ashikhmin-Shirley;
//! parameters per channel, the Ashikhmin-Shirley tangent as our world direction), two-sided like our G-buffer,
//! importance-sampled as our reference samples (integrate.glsl: the model's half-vector density with
//! probability mean(k_s)/(mean(k_s)+mean(ρ_d)), else cosine). Such a scene loads only from Python after
//! `import ours_bsdf` (the `mitsuba` command line has no Python plugins). Measured against our reference on
//! the bunny: see render.py's numbers in docs/measuring.md. `builtin`: Mitsuba's own BSDFs, approximate for
//! glossy materials (12.7 % off on the glossy bunny), loadable by the command line, Blinn-Phong only:
//! each material becomes
//! `twosided(blendbsdf(weight = w, diffuse(ρ_d/(1−w)), roughconductor(beckmann, α, material="none",
//! specular_reflectance = k_s/w)))` with w = mean(k_s)/(mean(k_s)+mean(ρ_d)) (a material with k_s = 0 is a
//! plain `diffuse`, exact). α = sqrt(2/(s+2)) is the Beckmann roughness of the Blinn-Phong exponent (Walter et al.
//! 2007). The diffuse part is exact; the specular lobe is a microfacet lobe D G F/(4 cos θ_i cos θ_o) with F = 1,
//! which differs from ours by the factor (s+2)/(s+8) at the peak and by the 1/(cos θ_i cos θ_o) and shadowing
//! terms away from normal incidence: [`specular_albedo`] measures both lobes' directional albedo
//! and the difference is large: ours falls off as about cos²θ_o (it has no 1/(4 cos θ_i cos θ_o)), the microfacet
//! lobe keeps albedo ≈ 1. Measured for s = 200 (k_s = 1): ours 1.010 / 0.820 / 0.500 / 0.260 at cos θ_o = 1 /
//! 0.9 / 0.7 / 0.5, the Mitsuba lobe 1.000 / 1.000 / 1.000 / 1.000 (−1 %, +22 %, +100 %, +285 %). So the
//! builtin export cross-checks geometry, camera, environment, visibility, lights and the diffuse term exactly,
//! and the specular term only near normal view.
//!
//! **Spherical lights** become `sphere` shapes with an `area` emitter of the light's radiance and a black
//! diffuse BSDF. Difference: in Mitsuba they are opaque (they cast shadows and hide the environment behind
//! them); ours add radiance along the directions they subtend and cast none.

use anyhow::{ensure, Context, Result};
use engine::math::envmap::LatLongMap;
use engine::scene::{Camera, Material, Scene};
use glam::{Mat3, Mat4, Vec3};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Mitsuba envmap emitter space → our world space (row-major 3×3): world = (−z, y, x).
pub const ENVMAP_TO_WORLD: [[f64; 3]; 3] = [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]];

/// What to export besides the scene.
#[derive(Clone, Debug)]
pub struct ExportOptions {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel written as the `spp` default of the scene (overridable: `mitsuba -D spp=N`).
    pub spp: u32,
    /// The camera of the frame (`None`: the scene's).
    pub camera: Option<Camera>,
    /// How materials are written (default: our exact BRDFs as the Python plugin).
    pub bsdf: ExportBsdf,
}

/// How the export writes materials (`demo --export-bsdf`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExportBsdf {
    /// Our exact BRDFs (all three models) as the Python plugin `ours` (ours_bsdf.py, written beside scene.xml):
    /// exact, but the scene then loads only from Python (`render.py`, or `import ours_bsdf` first).
    #[default]
    Plugin,
    /// Mitsuba's own BSDFs: `diffuse` + a Beckmann `roughconductor` blend for Blinn-Phong (module
    /// documentation; approximate for glossy materials), loadable by the `mitsuba` command line; refuses
    /// Cook-Torrance and Ashikhmin-Shirley.
    Builtin,
}

impl ExportBsdf {
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "plugin" => Ok(Self::Plugin),
            "builtin" => Ok(Self::Builtin),
            _ => Err(format!(
                "'{s}' is not an export BSDF (plugin: our exact BRDFs as a Python plugin, builtin: \
                              Mitsuba's diffuse/roughconductor approximation)"
            )),
        }
    }
}

/// The plugin (our BRDFs as a Mitsuba 3 Python BSDF) and the runner, written beside scene.xml.
pub const PLUGIN_PY: &str = include_str!("mitsuba/ours_bsdf.py");
pub const RENDER_PY: &str = include_str!("mitsuba/render.py");

/// Files written by [`export_mitsuba`].
#[derive(Clone, Debug)]
pub struct Exported {
    pub xml: PathBuf,
    /// ours_bsdf.py (the plugin) and render.py (the runner).
    pub plugin: PathBuf,
    pub runner: PathBuf,
    pub meshes: Vec<PathBuf>,
    pub envmap: PathBuf,
}

/// Mitsuba parameters of one of our materials (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MitsubaMaterial {
    /// blendbsdf weight of the specular part (0: plain diffuse).
    pub weight: f32,
    /// `diffuse` reflectance = ρ_d / (1 − w).
    pub diffuse: Vec3,
    /// `roughconductor` specular_reflectance = k_s / w.
    pub specular: Vec3,
    /// Beckmann roughness α = sqrt(2/(s+2)).
    pub alpha: f32,
}

pub fn mitsuba_material(m: &Material) -> MitsubaMaterial {
    let mean = |v: Vec3| (v.x + v.y + v.z) / 3.0;
    let (ks, kd) = (mean(m.specular).max(0.0), mean(m.diffuse).max(0.0));
    let alpha = (2.0 / (m.shininess.max(0.0) + 2.0)).sqrt();
    if ks <= 0.0 {
        return MitsubaMaterial { weight: 0.0, diffuse: m.diffuse, specular: Vec3::ZERO, alpha };
    }
    let w = ks / (ks + kd);
    let diffuse = if w < 1.0 { m.diffuse / (1.0 - w) } else { Vec3::ZERO };
    MitsubaMaterial { weight: w, diffuse, specular: m.specular / w, alpha }
}

/// World-space positions, normals and triangles of instance `i` at the scene's current bones (what the skin
/// pass computes on the GPU).
pub fn world_mesh(scene: &Scene, i: usize) -> (Vec<Vec3>, Vec<Vec3>, Vec<u32>) {
    let inst = &scene.instances[i];
    let mesh = &scene.meshes[inst.mesh];
    let skin = scene.blockers.skin_of(inst.mesh);
    let bones = &scene.blockers.bones;
    let model = inst.transform;
    let normal_model = Mat3::from_mat4(model).inverse().transpose();
    let mut pos = Vec::with_capacity(mesh.positions.len());
    let mut nrm = Vec::with_capacity(mesh.positions.len());
    for (v, (&p, &n)) in mesh.positions.iter().zip(&mesh.normals).enumerate() {
        let b = match skin {
            Some(s) if s.weights[v].iter().sum::<f32>() > 0.0 => {
                let mut m = Mat4::ZERO;
                for k in 0..4 {
                    let bone = bones.get(s.joints[v][k] as usize).copied().unwrap_or(Mat4::IDENTITY);
                    m += bone * s.weights[v][k];
                }
                m
            }
            _ => Mat4::IDENTITY,
        };
        pos.push(model.transform_point3(b.transform_point3(p)));
        // Cofactor of the blend (inverse transpose up to scale), as skinning.glsl.
        let m3 = Mat3::from_mat4(b);
        let cof = Mat3::from_cols(m3.y_axis.cross(m3.z_axis), m3.z_axis.cross(m3.x_axis), m3.x_axis.cross(m3.y_axis));
        let wn = normal_model * (cof * n);
        nrm.push(if wn.length() > 0.0 { wn.normalize() } else { Vec3::Y });
    }
    (pos, nrm, mesh.indices.clone())
}

/// Binary little-endian PLY: `x y z nx ny nz` floats per vertex, triangles as `uchar` count + 3 `int`.
pub fn write_ply(path: &Path, positions: &[Vec3], normals: &[Vec3], indices: &[u32]) -> Result<()> {
    ensure!(positions.len() == normals.len() && indices.len().is_multiple_of(3), "{}: malformed mesh", path.display());
    let mut b = format!(
        "ply\nformat binary_little_endian 1.0\ncomment softshadows export, world space\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        positions.len(),
        indices.len() / 3
    )
    .into_bytes();
    for (p, n) in positions.iter().zip(normals) {
        for c in [p.x, p.y, p.z, n.x, n.y, n.z] {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for t in indices.chunks_exact(3) {
        b.push(3);
        for &i in t {
            b.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    std::fs::write(path, b).with_context(|| format!("writing {}", path.display()))
}

/// The environment on Mitsuba's grid (module documentation): W × H texels, column j at u = (j + ½)/W, row i at
/// v = i/(H − 1), each our bilinear lookup there (×`intensity` left to the emitter's scale). RGBA f32.
pub fn mitsuba_envmap(env: &LatLongMap) -> Vec<f32> {
    let (w, h) = (env.width, env.height.max(2));
    let mut out = Vec::with_capacity(w * h * 4);
    for i in 0..h {
        // At the poles themselves every u is the same direction; just inside them keeps our u (row 0 and
        // row H − 1 of ours vary along u, and so do Mitsuba's pole rows).
        let v = (i as f64 / (h - 1) as f64).clamp(1e-9, 1.0 - 1e-9);
        for j in 0..w {
            let u = (j as f64 + 0.5) / w as f64;
            let c = env.lookup_bilinear(engine::math::envmap::latlong_direction(u, v));
            out.extend_from_slice(&[c[0] as f32, c[1] as f32, c[2] as f32, 1.0]);
        }
    }
    out
}

/// Mitsuba's envmap lookup (eval_spectrum of src/emitters/envmap.cpp, RGB variants) of a W × H RGBA map for a
/// world direction, through [`ENVMAP_TO_WORLD`]: for checking the export against our own lookup.
pub fn mitsuba_envmap_eval(rgba: &[f32], w: usize, h: usize, d: [f64; 3]) -> [f64; 3] {
    let m = ENVMAP_TO_WORLD;
    // Emitter space = to_worldᵀ · world (a rotation).
    let l = [0, 1, 2].map(|r| m[0][r] * d[0] + m[1][r] * d[1] + m[2][r] * d[2]);
    let len = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
    let mut u = l[0].atan2(-l[2]) / std::f64::consts::TAU;
    let mut v = (l[1] / len).clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
    // The plugin appends a copy of column 0 (W + 1 columns) and shifts by half a texel.
    u -= 0.5 / w as f64;
    u -= u.floor();
    v -= v.floor();
    let (x, y) = (u * w as f64, v * (h - 1) as f64);
    let (px, py) = ((x as usize).min(w - 1), (y as usize).min(h - 2));
    let (fx, fy) = (x - px as f64, y - py as f64);
    let at = |c: usize, r: usize, k: usize| rgba[(r * w + c % w) * 4 + k] as f64;
    [0, 1, 2].map(|k| {
        let a = at(px, py, k) * (1.0 - fx) + at(px + 1, py, k) * fx;
        let b = at(px, py + 1, k) * (1.0 - fx) + at(px + 1, py + 1, k) * fx;
        a * (1.0 - fy) + b * fy
    })
}

fn v3(v: Vec3) -> String {
    format!("{}, {}, {}", v.x, v.y, v.z)
}

fn rgb(v: Vec3) -> String {
    format!("{} {} {}", v.x, v.y, v.z)
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

fn bsdf_xml(id: &str, m: &Material) -> String {
    let mm = mitsuba_material(m);
    let diffuse =
        |refl: Vec3| format!("<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"{}\"/></bsdf>", rgb(refl));
    let inner = if mm.weight <= 0.0 {
        diffuse(mm.diffuse)
    } else {
        format!(
            "<bsdf type=\"blendbsdf\">\n      <float name=\"weight\" value=\"{}\"/>\n      {}\n      \
             <bsdf type=\"roughconductor\">\n        <string name=\"distribution\" value=\"beckmann\"/>\n        \
             <float name=\"alpha\" value=\"{}\"/>\n        <string name=\"material\" value=\"none\"/>\n        \
             <rgb name=\"specular_reflectance\" value=\"{}\"/>\n      </bsdf>\n    </bsdf>",
            mm.weight,
            diffuse(mm.diffuse),
            mm.alpha,
            rgb(mm.specular)
        )
    };
    format!(
        "  <!-- ours: rho_d = ({}), k_s = ({}), s = {} -->\n  <bsdf type=\"twosided\" id=\"{id}\">\n    {inner}\n  </bsdf>\n",
        rgb(m.diffuse),
        rgb(m.specular),
        m.shininess
    )
}

/// One material as the plugin `ours` (ours_bsdf.py): every parameter of our BRDF, exactly.
fn plugin_bsdf_xml(id: &str, m: &Material) -> String {
    use engine::scene::{Brdf, Ndf};
    let mut x = format!("  <bsdf type=\"ours\" id=\"{id}\">\n");
    let float = |x: &mut String, name: &str, v: f32| {
        let _ = writeln!(x, "    <float name=\"{name}\" value=\"{v}\"/>");
    };
    let model = match m.brdf {
        Brdf::BlinnPhong => "blinn-phong",
        Brdf::CookTorrance { ndf: Ndf::Beckmann, .. } => "cook-torrance-beckmann",
        Brdf::CookTorrance { ndf: Ndf::Ggx, .. } => "cook-torrance-ggx",
        Brdf::AshikhminShirley { .. } => "ashikhmin-shirley",
        // Refused before (export_mitsuba): ours_bsdf.py does not implement it.
        Brdf::Lafortune { .. } => "lafortune",
    };
    let _ = writeln!(x, "    <string name=\"model\" value=\"{model}\"/>");
    for (key, v) in [("kd", m.diffuse), ("ks", m.specular)] {
        for (c, value) in ["r", "g", "b"].iter().zip(v.to_array()) {
            float(&mut x, &format!("{key}_{c}"), value);
        }
    }
    match m.brdf {
        Brdf::BlinnPhong => float(&mut x, "s", m.shininess),
        Brdf::CookTorrance { roughness, .. } => float(&mut x, "alpha", roughness),
        Brdf::AshikhminShirley { nu, nv } => {
            float(&mut x, "nu", nu);
            float(&mut x, "nv", nv);
            for (c, value) in ["x", "y", "z"].iter().zip(m.tangent.to_array()) {
                float(&mut x, &format!("tangent_{c}"), value);
            }
        }
        Brdf::Lafortune { c, e, .. } => {
            for (key, value) in ["cx", "cy", "cz", "e"].iter().zip([c[0], c[1], c[2], e]) {
                float(&mut x, key, value);
            }
        }
    }
    x.push_str("  </bsdf>\n");
    x
}

/// Write `dir/scene.xml`, `dir/meshes/*.ply`, `dir/envmap.exr`, `dir/ours_bsdf.py` and `dir/render.py` (module
/// documentation).
pub fn export_mitsuba(scene: &Scene, dir: &Path, opts: &ExportOptions) -> Result<Exported> {
    if let Some(i) = scene.materials.iter().position(|m| matches!(m.brdf, engine::scene::Brdf::Lafortune { .. })) {
        anyhow::bail!(
            "material {i} is Phong/Lafortune: the Mitsuba export (ours_bsdf.py) does not implement it yet \
             (blinn-phong, cook-torrance and ashikhmin-shirley are exported exactly)"
        );
    }
    if let Some(m) = scene.meshes.iter().find(|m| m.material_offsets.iter().any(|&o| o > 0)) {
        anyhow::bail!(
            "mesh '{}' has per-vertex materials (a material map): the Mitsuba export does not carry them",
            m.name
        );
    }
    if opts.bsdf == ExportBsdf::Builtin {
        if let Some(i) = scene.materials.iter().position(|m| m.brdf != engine::scene::Brdf::BlinnPhong) {
            anyhow::bail!(
                "--export-bsdf builtin: material {i} is not Blinn-Phong; Mitsuba's own BSDFs approximate \
                 Blinn-Phong only (--export-bsdf plugin exports every model exactly)"
            );
        }
        // Mitsuba refuses an RGB reflectance outside [0, 1] (its SRGBReflectanceSpectrum): the blend's scaled
        // parts ρ_d/(1 − w) and k_s/w fit only where max ρ_d + max k_s ≲ 1 (e.g. not ρ_d 0.7, k_s 0.5).
        for (i, m) in scene.materials.iter().enumerate() {
            let mm = mitsuba_material(m);
            if mm.diffuse.max_element() > 1.0 || mm.specular.max_element() > 1.0 {
                anyhow::bail!(
                    "--export-bsdf builtin: material {i} (rho_d {}, k_s {}) needs the blend reflectances {} and {}, \
                     outside the [0, 1] Mitsuba accepts; --export-bsdf plugin exports it exactly",
                    rgb(m.diffuse),
                    rgb(m.specular),
                    rgb(mm.diffuse),
                    rgb(mm.specular)
                );
            }
        }
    }
    let mesh_dir = dir.join("meshes");
    std::fs::create_dir_all(&mesh_dir).with_context(|| format!("creating {}", mesh_dir.display()))?;
    let cam = opts.camera.unwrap_or(scene.camera);
    let (_, up, _) = cam.basis();
    let mut x = String::new();
    let _ = writeln!(x, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    let _ =
        writeln!(
        x,
        "<!-- Exported by softshadows (demo, option export): world-space meshes, camera, environment (to_world: our \
         lat-long convention, see demos/lab/src/export.rs), materials, spherical lights. {} -->",
        match opts.bsdf {
            // (No double hyphen: XML comments may not contain one, so no command-line options here.)
            ExportBsdf::Plugin => "Materials: our exact BRDFs as the Python plugin 'ours' (ours_bsdf.py). Render and \
                                   compare with engine.exr: python3 render.py (options: python3 render.py -h)",
            ExportBsdf::Builtin => "Materials: Blinn-Phong -> blendbsdf approximation. Render: mitsuba -m scalar_rgb \
                                    scene.xml, or python3 render.py to compare with engine.exr",
        }
    );
    let _ = writeln!(x, "<scene version=\"3.0.0\">");
    let _ = writeln!(x, "  <default name=\"spp\" value=\"{}\"/>", opts.spp.max(1));
    let _ = writeln!(x, "  <integrator type=\"direct\"/>");
    let _ = writeln!(x, "  <sensor type=\"perspective\">");
    let _ = writeln!(x, "    <string name=\"fov_axis\" value=\"y\"/>");
    let _ = writeln!(x, "    <float name=\"fov\" value=\"{}\"/>", cam.fov_y_degrees);
    let _ = writeln!(x, "    <transform name=\"to_world\">");
    let _ = writeln!(x, "      <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>", v3(cam.eye), v3(cam.target), v3(up));
    let _ = writeln!(x, "    </transform>");
    let _ = writeln!(x, "    <sampler type=\"independent\"><integer name=\"sample_count\" value=\"$spp\"/></sampler>");
    let _ = writeln!(x, "    <film type=\"hdrfilm\">");
    let _ = writeln!(x, "      <integer name=\"width\" value=\"{}\"/>", opts.width);
    let _ = writeln!(x, "      <integer name=\"height\" value=\"{}\"/>", opts.height);
    let _ = writeln!(x, "      <rfilter type=\"box\"/>");
    let _ = writeln!(x, "      <string name=\"pixel_format\" value=\"rgb\"/>");
    let _ = writeln!(x, "    </film>");
    let _ = writeln!(x, "  </sensor>");

    // Environment.
    let env = &scene.environment;
    ensure!(env.width >= 2 && env.height >= 3, "environment {}x{} too small for Mitsuba", env.width, env.height);
    let envmap = dir.join("envmap.exr");
    engine::output::write_exr(&envmap, env.width as u32, env.height as u32, &mitsuba_envmap(env))?;
    let m = ENVMAP_TO_WORLD;
    let _ = writeln!(x, "  <emitter type=\"envmap\">");
    let _ = writeln!(x, "    <string name=\"filename\" value=\"envmap.exr\"/>");
    let _ = writeln!(x, "    <float name=\"scale\" value=\"{}\"/>", scene.environment_intensity);
    let _ = writeln!(x, "    <!-- emitter space -> world: (x, y, z) -> (-z, y, x), a -90 degree rotation about +Y -->");
    let _ = writeln!(x, "    <transform name=\"to_world\">");
    let _ = writeln!(
        x,
        "      <matrix value=\"{} {} {} 0 {} {} {} 0 {} {} {} 0 0 0 0 1\"/>",
        m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2]
    );
    let _ = writeln!(x, "    </transform>");
    let _ = writeln!(x, "  </emitter>");

    // Materials.
    for (i, mat) in scene.materials.iter().enumerate() {
        let id = format!("mat{i}");
        x.push_str(&match opts.bsdf {
            ExportBsdf::Plugin => plugin_bsdf_xml(&id, mat),
            ExportBsdf::Builtin => bsdf_xml(&id, mat),
        });
    }

    // Meshes in world space.
    let mut meshes = Vec::new();
    for (i, inst) in scene.instances.iter().enumerate() {
        let (p, n, idx) = world_mesh(scene, i);
        let name: String = scene.meshes[inst.mesh]
            .name
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' })
            .collect();
        let file = format!("meshes/{i}_{name}.ply");
        write_ply(&dir.join(&file), &p, &n, &idx)?;
        let _ = writeln!(x, "  <shape type=\"ply\" id=\"instance{i}\">");
        let _ = writeln!(x, "    <string name=\"filename\" value=\"{}\"/>", xml_escape(&file));
        let _ = writeln!(x, "    <ref id=\"mat{}\"/>", inst.material);
        let _ = writeln!(x, "  </shape>");
        meshes.push(dir.join(file));
    }

    // Spherical lights.
    for (i, l) in scene.lights.iter().enumerate() {
        let _ = writeln!(x, "  <shape type=\"sphere\" id=\"light{i}\">");
        let _ = writeln!(x, "    <point name=\"center\" value=\"{}\"/>", v3(l.center));
        let _ = writeln!(x, "    <float name=\"radius\" value=\"{}\"/>", l.radius);
        let _ = writeln!(x, "    <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0 0 0\"/></bsdf>");
        let _ =
            writeln!(x, "    <emitter type=\"area\"><rgb name=\"radiance\" value=\"{}\"/></emitter>", rgb(l.radiance));
        let _ = writeln!(x, "  </shape>");
    }
    let _ = writeln!(x, "</scene>");
    let xml = dir.join("scene.xml");
    std::fs::write(&xml, x).with_context(|| format!("writing {}", xml.display()))?;
    let (plugin, runner) = (dir.join("ours_bsdf.py"), dir.join("render.py"));
    for (path, text) in [(&plugin, PLUGIN_PY), (&runner, RENDER_PY)] {
        std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(Exported { xml, meshes, envmap, plugin, runner })
}

/// Directional albedo ∫ f_spec cos θ_i dω_i of the specular lobe at view angle acos(`cos_o`), for ours
/// (k_s = 1: (s+8)/(8π) (n·h)^s) and for its Mitsuba mapping (Beckmann α = sqrt(2/(s+2)), Smith shadowing, F = 1):
/// the error of the material mapping. Midpoint quadrature on an `n` × 2`n` (θ_i, φ_i) grid.
pub fn specular_albedo(s: f64, cos_o: f64, n: usize) -> (f64, f64) {
    use std::f64::consts::PI;
    let alpha = (2.0 / (s + 2.0)).sqrt();
    let sin_o = (1.0 - cos_o * cos_o).max(0.0).sqrt();
    let wo = [sin_o, 0.0, cos_o];
    let g1 = |c: f64| {
        // Smith G1 for Beckmann (exact, with an erf of error < 1.5e-7).
        if c >= 1.0 {
            return 1.0;
        }
        let a = c / (alpha * (1.0 - c * c).max(0.0).sqrt());
        let t = 1.0 / (1.0 + 0.3275911 * a);
        let erf = 1.0
            - t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))))
                * (-a * a).exp();
        2.0 / (1.0 + erf + (-a * a).exp() / (a * PI.sqrt()))
    };
    let (mut ours, mut mitsuba) = (0.0, 0.0);
    let (dt, dp) = (0.5 * PI / n as f64, PI / n as f64);
    for i in 0..n {
        let th = (i as f64 + 0.5) * dt;
        let (st, ct) = th.sin_cos();
        for j in 0..2 * n {
            let ph = (j as f64 + 0.5) * dp;
            let wi = [st * ph.cos(), st * ph.sin(), ct];
            let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
            let hl = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            let nh = h[2] / hl;
            let dw = st * dt * dp;
            ours += (s + 8.0) / (8.0 * PI) * nh.powf(s) * ct * dw;
            let tan2 = (1.0 - nh * nh).max(0.0) / (nh * nh);
            let d = (-tan2 / (alpha * alpha)).exp() / (PI * alpha * alpha * nh.powi(4));
            mitsuba += d * g1(ct) * g1(cos_o) / (4.0 * ct * cos_o) * ct * dw;
        }
    }
    (ours, mitsuba)
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine::math::envmap::{latlong_direction, latlong_uv};

    #[test]
    fn envmap_rotation_maps_our_u_to_mitsubas() {
        let m = ENVMAP_TO_WORLD;
        for k in 0..200 {
            let (u, v) = ((k as f64 * 0.618034) % 1.0, 0.02 + 0.96 * ((k as f64 * 0.414214) % 1.0));
            let d = latlong_direction(u, v);
            let l = [0, 1, 2].map(|r| m[0][r] * d[0] + m[1][r] * d[1] + m[2][r] * d[2]);
            let mu = (l[0].atan2(-l[2]) / std::f64::consts::TAU).rem_euclid(1.0);
            let (ou, ov) = latlong_uv(d);
            let du = (mu - ou).abs();
            assert!(du.min(1.0 - du) < 1e-9, "u: ours {ou}, Mitsuba {mu}");
            assert!((l[1].acos() / std::f64::consts::PI - ov).abs() < 1e-9);
        }
        // A proper rotation.
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        assert_eq!(det, 1.0);
    }

    #[test]
    fn exported_envmap_evaluates_like_ours_in_mitsuba() {
        // A smooth but asymmetric map: Mitsuba's lookup of the export must match our bilinear lookup to within
        // interpolation error, and a wrong rotation or grid would miss by the map's variation.
        let (w, h) = (128, 64);
        let mut env = LatLongMap::constant(w, h, [0.0; 3]);
        for r in 0..h {
            for c in 0..w {
                let d = env.texel_direction(c, r);
                env.texels[r * w + c] =
                    [(1.0 + d[0]) as f32, (1.5 + d[1]) as f32, (1.2 + d[2] + 0.3 * d[0] * d[1]) as f32];
            }
        }
        let out = mitsuba_envmap(&env);
        // Within one texel of a pole ours is constant in v (clamped to the first row's centre) where Mitsuba
        // interpolates to a row on the pole: a difference of up to one texel's variation, there only.
        let (mut inner, mut caps): (f64, f64) = (0.0, 0.0);
        for k in 0..2000 {
            let (u, v) = ((k as f64 * 0.618034) % 1.0, (k as f64 * 0.414214) % 1.0);
            let d = latlong_direction(u, v);
            let a = mitsuba_envmap_eval(&out, w, h, d);
            let b = env.lookup_bilinear(d);
            let e = (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max);
            if (v - 0.5).abs() < 0.5 - 1.0 / h as f64 {
                inner = inner.max(e);
            } else {
                caps = caps.max(e);
            }
        }
        eprintln!(
            "export envmap vs ours: max abs difference {inner:.2e} (map range 0.5..2.5), {caps:.3} in the polar caps"
        );
        assert!(inner < 2e-3, "Mitsuba lookup of the export vs ours away from the poles: max {inner}");
        assert!(caps < 0.1, "within a texel of the poles: max {caps}");
    }

    #[test]
    fn material_mapping() {
        let m = mitsuba_material(&Material::glossy(Vec3::new(0.7, 0.68, 0.62), 0.15, 200.0));
        let w = 0.15 / (0.15 + 2.0 / 3.0);
        assert!((m.weight - w).abs() < 1e-6);
        // (1 − w)·diffuse = ρ_d and w·specular = k_s: the blend reproduces both scales.
        assert!(((1.0 - m.weight) * m.diffuse - Vec3::new(0.7, 0.68, 0.62)).abs().max_element() < 1e-6);
        assert!((m.weight * m.specular - Vec3::splat(0.15)).abs().max_element() < 1e-6);
        assert!((m.alpha - (2.0f32 / 202.0).sqrt()).abs() < 1e-7);
        let d = mitsuba_material(&Material::diffuse(Vec3::splat(0.5)));
        assert_eq!((d.weight, d.diffuse), (0.0, Vec3::splat(0.5)));
    }

    #[test]
    fn specular_lobe_mapping_error_is_small_near_normal_view() {
        // Both lobes carry about the same energy at normal view; the grazing difference is documented, not hidden.
        for s in [50.0, 200.0, 1000.0] {
            let (ours, mitsuba) = specular_albedo(s, 1.0 - 1e-9, 400);
            let rel = mitsuba / ours - 1.0;
            for c in [0.9, 0.7, 0.5, 0.3] {
                let (o, m) = specular_albedo(s, c, 400);
                eprintln!(
                    "s = {s}, cos θ_o = {c}: albedo ours {o:.4}, Mitsuba {m:.4} ({:+.1} %)",
                    100.0 * (m / o - 1.0)
                );
            }
            eprintln!("s = {s}, cos θ_o = 1: albedo ours {ours:.4}, Mitsuba {mitsuba:.4} ({:+.1} %)", 100.0 * rel);
            assert!(rel.abs() < 0.08, "s = {s}: ours {ours}, Mitsuba {mitsuba}");
        }
    }
}
