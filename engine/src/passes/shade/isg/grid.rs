//! The patch grid of one ISG lobe (shaders-glsl/common/isg_visibility.glsl): its frame, its extent (the
//! limiting angle) and its patch size. Shared by the f64 twin ([`super::cpu`]) and the thin-shell marking
//! ([`super::thin`]), which the twin calls: a module of its own, so that neither imports the other.

use super::options::IsgOptions;
use glam::DVec3;
use std::f64::consts::FRAC_PI_2;

/// The patch grid of one lobe (see isg_visibility.glsl).
pub struct Grid {
    pub x: DVec3,
    pub y: DVec3,
    pub z: DVec3,
    pub lo: f64,
    pub delta: f64,
    pub side: usize,
    pub cone: f64,
}

pub fn limiting_angle(lambda: f64, epsilon: f64) -> f64 {
    let c = 1.0 + epsilon.ln() / lambda.max(1e-30);
    if c <= 0.0 {
        FRAC_PI_2
    } else {
        c.acos()
    }
}

/// Duff et al. 2017 orthonormal basis (the same branch as the shader).
pub fn basis(z: DVec3) -> (DVec3, DVec3) {
    let s = if z.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + z.z);
    let b = z.x * z.y * a;
    (DVec3::new(1.0 + s * z.x * z.x * a, s * b, -s * z.x), DVec3::new(b, s + z.y * z.y * a, -z.y))
}

pub fn grid(axis: DVec3, lambda: f64, o: &IsgOptions) -> Grid {
    let (x, y) = basis(axis);
    let gamma = limiting_angle(lambda, o.epsilon);
    let side = o.side.clamp(1, 32);
    let c = gamma.cos();
    Grid {
        x,
        y,
        z: axis,
        lo: FRAC_PI_2 - gamma,
        delta: 2.0 * gamma / side as f64,
        side,
        cone: (c * c).clamp(0.0, 1.0).acos(),
    }
}
