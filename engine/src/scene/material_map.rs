//! Spatially varying Lafortune materials (cosine-lobes paper §5.1, Fig. 14): a parameter map blends two
//! Lafortune materials across a mesh, per vertex.
//!
//! - The map is an 8-bit PNG; its red channel, read as stored (no sRGB decoding: it is data, not a colour),
//!   gives t ∈ [0, 1] per texel.
//! - It is projected from above (+y) onto the mesh's own x–z bounds: column 0 at the smallest x, row 0 (the
//!   image's top) at the smallest z, so that a camera looking down −z sees it upright. Each vertex reads it
//!   bilinearly (texel centres, clamped at the edges).
//! - t blends the base material `a` (t = 0) into `b` (t = 1): ρ_d, k_s and Lafortune's C linearly, the
//!   exponent e geometrically (e_a^(1−t) e_b^t: exponents span decades). The tangent is `a`'s.
//! - t is quantized to `levels` materials (a palette, [`MaterialMapping::palette`]); the vertex's level is
//!   its [`Mesh::material_offsets`] entry. 256 levels reproduce an 8-bit map's values exactly at its texel
//!   centres.
//!
//! Every technique and the reference shade a vertex with its palette material, so they all see the same
//! spatially varying BRDF (`none` and `isg` through their SG equivalents of Lafortune). Per-pixel shading
//! takes a triangle's first vertex's level (the material index is flat), so the map is resolved at the mesh's
//! vertex spacing: tessellate finely (the ground's `subdivisions`).

use super::{Brdf, LafortuneLobe, Material, Mesh, SceneError};
use glam::Vec3;
use std::path::Path;

/// The most palette levels of a map.
pub const MAX_LEVELS: u32 = 256;

/// A scalar parameter map t(u, v) ∈ [0, 1], row-major, row 0 at v = 0.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialMap {
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
}

impl MaterialMap {
    /// A map from values in [0, 1] (`width` × `height`, both ≥ 1).
    pub fn new(width: u32, height: u32, values: Vec<f32>) -> Result<Self, String> {
        if width == 0 || height == 0 || values.len() != (width as usize) * (height as usize) {
            return Err(format!("a {width}×{height} map needs {} values, not {}", width * height, values.len()));
        }
        if let Some(v) = values.iter().find(|v| !(0.0..=1.0).contains(*v)) {
            return Err(format!("value {v} is not in [0, 1]"));
        }
        Ok(Self { width, height, values })
    }

    /// The red channel of an 8-bit RGB or RGBA PNG, as t = red / 255.
    pub fn load(path: &Path) -> super::Result<Self> {
        let bytes = engine_io::read(path, engine_io::Limit::IMAGE)?;
        let (w, h, rgba) = crate::output::decode_png(&bytes).map_err(|m| SceneError::invalid(path, m))?;
        let values = rgba.chunks_exact(4).map(|p| p[0] as f32 / 255.0).collect();
        Self::new(w, h, values).map_err(|e| SceneError::invalid(path, e))
    }

    /// Bilinear at (u, v) ∈ [0, 1]² (texel centres at (i + ½)/width, clamped at the edges).
    pub fn sample(&self, u: f32, v: f32) -> f32 {
        let (w, h) = (self.width as usize, self.height as usize);
        let x = u.clamp(0.0, 1.0) as f64 * w as f64 - 0.5;
        let y = v.clamp(0.0, 1.0) as f64 * h as f64 - 0.5;
        engine_math::envmap::bilinear_clamp(|c, r| self.values[r * w + c], w, h, x, y) as f32
    }
}

/// The blend of Lafortune material `a` (t = 0) into `b` (t = 1) (see the module doc).
pub fn blend_lafortune(a: &Material, b: &Material, t: f32) -> Result<Material, String> {
    let (Brdf::Lafortune { c: ca, e: ea, more: ma }, Brdf::Lafortune { c: cb, e: eb, more: mb }) = (a.brdf, b.brdf)
    else {
        return Err("a material map blends two Lafortune materials (brdf = \"lafortune:…\" or \"phong:…\")".into());
    };
    if !(ea > 0.0 && eb > 0.0 && ea.is_finite() && eb.is_finite()) {
        return Err(format!("the exponents must be finite and > 0 (e = {ea}, {eb})"));
    }
    let t = t.clamp(0.0, 1.0);
    let blend_c = |ca: [f32; 3], cb: [f32; 3]| std::array::from_fn(|k| ca[k] + t * (cb[k] - ca[k]));
    let blend_e = |ea: f32, eb: f32| ea.powf(1.0 - t) * eb.powf(t);
    // Further lobes: blended where both hold them; one only the other lacks fades in or out by its weight.
    let more = std::array::from_fn(|i| {
        let (la, lb) = (ma[i], mb[i]);
        let w = la.w + t * (lb.w - la.w);
        match (la.w > 0.0, lb.w > 0.0) {
            (true, true) => LafortuneLobe { c: blend_c(la.c, lb.c), e: blend_e(la.e, lb.e), w },
            (true, false) => LafortuneLobe { w, ..la },
            (false, true) => LafortuneLobe { w, ..lb },
            (false, false) => LafortuneLobe::default(),
        }
    });
    Ok(Material {
        diffuse: a.diffuse.lerp(b.diffuse, t),
        specular: a.specular.lerp(b.specular, t),
        brdf: Brdf::Lafortune { c: blend_c(ca, cb), e: blend_e(ea, eb), more },
        ..*a
    })
}

/// A material map applied to meshes: `map` blends `a` into `b` in `levels` steps.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialMapping {
    pub map: MaterialMap,
    pub b: Material,
    pub levels: u32,
}

impl MaterialMapping {
    /// The `levels` materials level k = 0 … levels − 1 stands for (t = k / (levels − 1)), from base `a`.
    pub fn palette(&self, a: &Material) -> Result<Vec<Material>, String> {
        if !(2..=MAX_LEVELS).contains(&self.levels) {
            return Err(format!("levels = {} is not in 2..={MAX_LEVELS}", self.levels));
        }
        let last = (self.levels - 1) as f32;
        (0..self.levels).map(|k| blend_lafortune(a, &self.b, k as f32 / last)).collect()
    }

    /// Set `mesh`'s material offsets: each vertex's nearest level of the map projected onto the mesh's x–z
    /// bounds (a degenerate axis reads the map's middle).
    pub fn apply(&self, mesh: &mut Mesh) {
        let lo = mesh.positions.iter().fold(Vec3::splat(f32::INFINITY), |a, p| a.min(*p));
        let hi = mesh.positions.iter().fold(Vec3::splat(f32::NEG_INFINITY), |a, p| a.max(*p));
        let along = |x: f32, l: f32, h: f32| if h > l { (x - l) / (h - l) } else { 0.5 };
        let last = self.levels.saturating_sub(1) as f32;
        mesh.material_offsets = mesh
            .positions
            .iter()
            .map(|p| {
                let t = self.map.sample(along(p.x, lo.x, hi.x), along(p.z, lo.z, hi.z));
                (t * last).round() as u32
            })
            .collect();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lafortune(c: [f32; 3], e: f32, ks: f32) -> Material {
        Material { brdf: Brdf::lafortune(c, e), ..Material::glossy(Vec3::splat(0.2), ks, 1.0) }
    }

    #[test]
    fn sampling_is_bilinear_between_texel_centres_and_clamped() {
        let m = MaterialMap::new(2, 1, vec![0.0, 1.0]).unwrap();
        assert_eq!(m.sample(0.0, 0.5), 0.0);
        assert_eq!(m.sample(0.25, 0.5), 0.0, "the first texel's centre");
        assert!((m.sample(0.5, 0.5) - 0.5).abs() < 1e-6);
        assert_eq!(m.sample(0.75, 0.5), 1.0);
        assert_eq!(m.sample(2.0, -1.0), 1.0, "clamped");
        let one = MaterialMap::new(1, 1, vec![0.3]).unwrap();
        assert_eq!(one.sample(0.9, 0.1), 0.3);
    }

    #[test]
    fn bad_maps_are_refused() {
        assert!(MaterialMap::new(0, 1, vec![]).is_err());
        assert!(MaterialMap::new(2, 2, vec![0.0; 3]).unwrap_err().contains("needs 4 values"));
        assert!(MaterialMap::new(1, 1, vec![f32::NAN]).is_err());
        assert!(MaterialMap::new(1, 1, vec![1.5]).is_err());
        let e = MaterialMap::load(Path::new("/nonexistent/map.png")).unwrap_err().to_string();
        assert!(e.contains("/nonexistent/map.png") && e.contains("not found"), "{e}");
    }

    fn write_png(name: &str, color: png::ColorType, depth: png::BitDepth, data: &[u8]) -> std::path::PathBuf {
        let path = std::env::temp_dir().join(format!("material-map-{}-{name}.png", std::process::id()));
        let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        let mut enc = png::Encoder::new(file, 2, 1);
        enc.set_color(color);
        enc.set_depth(depth);
        enc.write_header().unwrap().write_image_data(data).unwrap();
        path
    }

    /// Parameter maps are often grey or 16-bit: both load (the high byte), a corrupt file is an error naming it.
    #[test]
    fn grey_and_16_bit_maps_load_and_corrupt_ones_are_errors() {
        use png::{BitDepth, ColorType};
        let grey = write_png("grey", ColorType::Grayscale, BitDepth::Eight, &[0, 255]);
        assert_eq!(MaterialMap::load(&grey).unwrap().values, vec![0.0, 1.0]);
        let grey16 = write_png("grey16", ColorType::Grayscale, BitDepth::Sixteen, &[0x80, 0x00, 0xff, 0xff]);
        assert_eq!(MaterialMap::load(&grey16).unwrap().values, vec![128.0 / 255.0, 1.0]);
        let grey_alpha = write_png("grey-alpha", ColorType::GrayscaleAlpha, BitDepth::Eight, &[51, 255, 102, 0]);
        assert_eq!(MaterialMap::load(&grey_alpha).unwrap().values, vec![0.2, 0.4]);
        let corrupt = std::env::temp_dir().join(format!("material-map-{}-corrupt.png", std::process::id()));
        std::fs::write(&corrupt, b"\x89PNG not really").unwrap();
        let e = MaterialMap::load(&corrupt).unwrap_err().to_string();
        assert!(e.contains(&corrupt.display().to_string()), "{e}");
        for p in [grey, grey16, grey_alpha, corrupt] {
            let _ = std::fs::remove_file(p);
        }
    }

    #[test]
    fn the_blend_is_linear_in_c_and_geometric_in_e() {
        let (a, b) = (lafortune([-1.0, -1.0, 1.0], 10.0, 0.2), lafortune([-0.2, -1.0, 0.6], 1000.0, 0.6));
        let m = blend_lafortune(&a, &b, 0.5).unwrap();
        let Brdf::Lafortune { c, e, .. } = m.brdf else { panic!() };
        assert!((e - 100.0).abs() < 1e-3, "{e}");
        assert!(c.iter().zip([-0.6, -1.0, 0.8]).all(|(x, y)| (x - y).abs() < 1e-6), "{c:?}");
        assert!((m.specular - Vec3::splat(0.4)).abs().max_element() < 1e-6);
        assert_eq!(blend_lafortune(&a, &b, 0.0).unwrap(), a);
        let e = blend_lafortune(&Material::glossy(Vec3::ONE, 0.5, 50.0), &b, 0.5).unwrap_err();
        assert!(e.contains("Lafortune"), "{e}");
        // Further lobes: blended where both hold them, faded by their weight where one does.
        let with = |m: &Material, more: [LafortuneLobe; 2]| {
            let Brdf::Lafortune { c, e, .. } = m.brdf else { panic!() };
            Material { brdf: Brdf::Lafortune { c, e, more }, ..*m }
        };
        let lobe = |e: f32, w: f32| LafortuneLobe { c: [-0.5, -0.5, 0.5], e, w };
        let a = with(&a, [lobe(4.0, 0.2), LafortuneLobe::default()]);
        let b = with(&b, [lobe(16.0, 0.4), lobe(9.0, 0.8)]);
        let Brdf::Lafortune { more, .. } = blend_lafortune(&a, &b, 0.5).unwrap().brdf else { panic!() };
        assert!((more[0].e - 8.0).abs() < 1e-4 && (more[0].w - 0.3).abs() < 1e-6, "{more:?}");
        assert!(more[1].e == 9.0 && (more[1].w - 0.4).abs() < 1e-6, "{more:?}");
    }

    #[test]
    fn vertices_take_the_nearest_level_of_the_map_below_them() {
        // A 3-vertex strip along x over a black | white map: the left vertex level 0, the right the last.
        let mut mesh = Mesh {
            name: "strip".into(),
            positions: vec![Vec3::new(-1.0, 0.0, 0.0), Vec3::new(0.1, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0)],
            normals: vec![Vec3::Y; 3],
            indices: vec![0, 1, 2],
            material_offsets: Vec::new(),
        };
        let mapping = MaterialMapping {
            map: MaterialMap::new(2, 1, vec![0.0, 1.0]).unwrap(),
            b: lafortune([-1.0, -1.0, 1.0], 100.0, 0.5),
            levels: 5,
        };
        mapping.apply(&mut mesh);
        // x = 0.1 is u = 0.55: t = 0.6 between the texel centres, level round(0.6 · 4) = 2.
        assert_eq!(mesh.material_offsets, vec![0, 2, 4]);
        let palette = mapping.palette(&lafortune([-1.0, -1.0, 1.0], 1.0, 0.1)).unwrap();
        assert_eq!(palette.len(), 5);
        assert_eq!(palette[4].brdf, Brdf::lafortune([-1.0, -1.0, 1.0], 100.0));
        assert!(MaterialMapping { levels: 1, ..mapping.clone() }.palette(&palette[0]).is_err());
        assert!(MaterialMapping { levels: 257, ..mapping }.palette(&palette[0]).is_err());
    }
}
