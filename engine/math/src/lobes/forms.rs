//! Lobe forms of BRDFs and lights (paper Sec. 5.1, 5.2): Phong, modified Phong and Lafortune
//! lobes, and a spherical light seen from a point as one lobe.

use super::{add3, dot, length, normalize, scale3, sub3, CapTable, Lobe};
use std::f64::consts::{FRAC_PI_2, PI};

/// Mirror direction of `v_o` about the unit normal `n`: `2(n·v_o)n − v_o`.
pub fn reflect(v_o: [f64; 3], n: [f64; 3]) -> [f64; 3] {
    sub3(scale3(n, 2.0 * dot(n, v_o)), v_o)
}

/// Phong as the paper writes it (Eq. 24–27): `f̃_r(v) = k_d max(n·v, 0) + k_s max(r·v, 0)^{e_s}`,
/// r the mirror of v_o. This is already the BRDF times the cosine, as in the paper.
pub fn phong_lobes(n: [f64; 3], v_o: [f64; 3], k_d: f64, k_s: f64, e_s: f64) -> [Lobe; 2] {
    [Lobe::new(n, k_d, 1.0), Lobe::new(reflect(v_o, n), k_s, e_s)]
}

/// Modified Phong (Lewis 1994), energy-normalized BRDF `f_r(v) = k_d/π + k_s (e+2)/(2π) max(r·v, 0)^e`.
/// These lobes are `f_r` itself (the diffuse one is the e = 0 hemisphere lobe about n): the cosine
/// factor is the separate lobe `(n, 1, 1)` of paper Eq. 22, multiplied in by the renderer.
/// The normalization makes `∫ f_r^{spec} cos θ dω = k_s` at normal incidence.
pub fn modified_phong_lobes(n: [f64; 3], v_o: [f64; 3], k_d: f64, k_s: f64, e_s: f64) -> [Lobe; 2] {
    [Lobe::new(n, k_d / PI, 0.0), Lobe::new(reflect(v_o, n), k_s * (e_s + 2.0) / (2.0 * PI), e_s)]
}

/// One generalized cosine lobe of the Lafortune model (Lafortune et al. 1997): in the local frame
/// (tangent x, bitangent y, normal z), `ρ · max(C_x u_x v_x + C_y u_y v_y + C_z u_z v_z, 0)^e`.
/// `C_x ≠ C_y` is anisotropic; `C_x = C_y = −1, C_z = 1` is a Phong lobe about the mirror.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LafortuneLobe {
    pub c: [f64; 3],
    pub rho: f64,
    pub exponent: f64,
}

/// The Lafortune lobe for a fixed outgoing direction `v_o` as a cosine lobe in v (paper Eq. 30):
/// with `w = M v_o` (M = diag(C) in the local frame), `(w·v)^e = |w|^e (ŵ·v)^e`, so the axis is ŵ
/// and the scale `ρ |w|^e`, computed as `ρ exp(e ln|w|)`. `frame` = (tangent, bitangent, normal),
/// orthonormal, world space. A zero w gives a zero lobe.
pub fn lafortune_lobe(lobe: &LafortuneLobe, frame: [[f64; 3]; 3], v_o: [f64; 3]) -> Lobe {
    let u = [dot(v_o, frame[0]), dot(v_o, frame[1]), dot(v_o, frame[2])];
    let wl = [lobe.c[0] * u[0], lobe.c[1] * u[1], lobe.c[2] * u[2]];
    let w = add3(add3(scale3(frame[0], wl[0]), scale3(frame[1], wl[1])), scale3(frame[2], wl[2]));
    let lw = length(w);
    if lw == 0.0 {
        return Lobe { axis: frame[2], scale: 0.0, exponent: lobe.exponent };
    }
    let scale = if lobe.exponent == 0.0 { lobe.rho } else { lobe.rho * (lobe.exponent * lw.ln()).exp() };
    Lobe { axis: scale3(w, 1.0 / lw), scale, exponent: lobe.exponent }
}

/// Half-angle of the cone a sphere (centre, radius) subtends from x; π/2 when x is inside or on it
/// (then the light covers at least the hemisphere towards its centre).
pub fn sphere_cap_angle(center: [f64; 3], radius: f64, x: [f64; 3]) -> f64 {
    let d = length(sub3(center, x));
    if d <= radius {
        FRAC_PI_2
    } else {
        (radius / d).asin()
    }
}

/// A spherical light (centre, radius, radiance) seen from x as one cosine lobe (paper Eq. 31):
/// axis towards the centre, scale = radiance, exponent from the cap table.
pub fn spherical_light_lobe(center: [f64; 3], radius: f64, radiance: f64, x: [f64; 3], caps: &CapTable) -> Lobe {
    let d = sub3(center, x);
    let axis = if length(d) > 0.0 { normalize(d) } else { [0.0, 1.0, 0.0] };
    Lobe { axis, scale: radiance, exponent: caps.exponent(sphere_cap_angle(center, radius, x)) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lobes::testing::rel;
    use crate::lobes::{cap_exponent, cap_table};
    use crate::rng::Pcg32;

    #[test]
    fn brdf_and_light_lobes() {
        let mut rng = Pcg32::new(9, 2);
        let n = [0.0, 1.0, 0.0];
        let v_o = normalize([0.3, 0.8, -0.2]);
        let r = reflect(v_o, n);
        let [d, s] = phong_lobes(n, v_o, 0.6, 0.4, 30.0);
        for _ in 0..50 {
            let v = rng.unit_vector();
            let direct = 0.6 * dot(n, v).max(0.0) + 0.4 * dot(r, v).max(0.0).powf(30.0);
            assert!((d.eval(v) + s.eval(v) - direct).abs() < 1e-14);
        }
        // Modified Phong is energy-normalized: ∫ f_spec cos θ dω = k_s at normal incidence
        // (through the exact clamped-cosine integral), and the diffuse lobe integrates to k_d.
        for &e in &[1.0, 10.0, 1e4] {
            let [md, ms] = modified_phong_lobes(n, n, 0.5, 0.7, e);
            assert!(rel(ms.clamped_cosine_integral(n), 0.7) < 1e-12);
            assert!(rel(md.clamped_cosine_integral(n), 0.5) < 1e-12);
        }
        // Lafortune, anisotropic (C_x ≠ C_y): the lobe equals the generalized cosine lobe formula.
        let frame = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]; // tangent, bitangent, normal
        for lob in [
            LafortuneLobe { c: [-0.9, -0.5, 0.8], rho: 2.0, exponent: 12.0 },
            LafortuneLobe { c: [-1.02, -1.0, 1.01], rho: 1.0, exponent: 2e3 },
            LafortuneLobe { c: [0.4, 0.7, 0.3], rho: 0.5, exponent: 0.0 },
        ] {
            for _ in 0..30 {
                let vo = rng.unit_vector();
                let c = lafortune_lobe(&lob, frame, vo);
                let v = rng.unit_vector();
                let u: Vec<f64> = frame.iter().map(|f| dot(vo, *f)).collect();
                let w: Vec<f64> = frame.iter().map(|f| dot(v, *f)).collect();
                let x = lob.c[0] * u[0] * w[0] + lob.c[1] * u[1] * w[1] + lob.c[2] * u[2] * w[2];
                let direct =
                    if x > 0.0 { lob.rho * if lob.exponent == 0.0 { 1.0 } else { x.powf(lob.exponent) } } else { 0.0 };
                assert!(
                    (c.eval(v) - direct).abs() <= 1e-10 * direct.max(1e-300) + 1e-300,
                    "{lob:?}: {} vs {direct}",
                    c.eval(v)
                );
            }
        }
        // Spherical light: axis to the centre, exponent of the subtended cap.
        let caps = cap_table();
        let l = spherical_light_lobe([0.0, 10.0, 0.0], 1.0, 5.0, [0.0, 0.0, 0.0], &caps);
        assert!(length(sub3(l.axis, [0.0, 1.0, 0.0])) < 1e-15 && l.scale == 5.0);
        assert!(rel(l.exponent, cap_exponent((0.1f64).asin())) < 1e-3);
        let inside = spherical_light_lobe([0.0, 0.5, 0.0], 1.0, 5.0, [0.0, 0.0, 0.0], &caps);
        assert_eq!(inside.exponent, 0.0);
    }
}
