//! GPU (f32 GLSL, shaders-glsl/common/lobes.glsl) vs CPU (f64, engine_math::lobes) twins through
//! shaders-glsl/tests/lobes_twin.comp (layout documented there: 12 floats in, 20 out per case).
//!
//! Inputs are rounded to f32 first and the CPU twin sees the same values. Where the GLSL relies on
//! unit vectors (1 − a·v = |a − v|²/2, the product axis), the CPU twin gets the f32 vectors
//! renormalized in f64: the GLSL formula is exact for the nearest unit directions, while a·v of the
//! raw f32 vectors is off by up to ~2ε, which a lobe exponent of 1e5 would amplify to 1 % and
//! blame on the shader. Outputs that are chained in the shader (α into the product functions) are
//! compared function by function: the CPU twin gets the GPU's α (output 3).
//!
//! Tolerances: f32 arithmetic error bounds in units of EPS = 2⁻²⁴, with the built-ins' accuracy of
//! twin/mod.rs (exp EXP_ULP + 2|x| ulp, atan/atan2 ATAN_ABS absolute; checked on the device by
//! math_gpu_sg.rs), plus, where a function is ill conditioned (asin near ±1, √(1 − c²) near
//! |c| = 1), the change of the f64 function over the f32 rounding of its argument.

mod twin;

use engine::gpu::testing::{run_f32_kernel, test_gpu};
use engine::math::lobes;
use engine::math::rng::Pcg32;
use std::f64::consts::{FRAC_PI_2, PI};
use twin::*;

const IN: usize = 12;
const OUT: usize = 20;
/// The GLSL stand-in for −∞ (LOBES_NEG_INF).
const NEG_INF_F32: f32 = -3.0e38;
/// The Lafortune frame of lobes_twin.comp: tangent +x, bitangent +z, normal +y.
const FRAME: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]];

/// Error of asin(x) when x carries an absolute error dx (f64 asin' = 1/√(1 − x²); within dx of
/// ±1 the square-root branch point gives √(2 dx)).
fn asin_err(x: f64, dx: f64) -> f64 {
    let m = 1.0 - x.abs();
    if m > 2.0 * dx {
        dx / ((1.0 - x) * (1.0 + x)).sqrt()
    } else {
        (4.0 * dx).sqrt()
    }
}

struct Case {
    a1: [f32; 3],
    e1: f32,
    a2: [f32; 3],
    e2: f32,
    v: [f32; 3],
    s: f32,
}

fn cases() -> Vec<Case> {
    let mut rng = Pcg32::new(1009, 11);
    let special = [0.0, 1e-4, 0.5, 1.0, 9.999, 10.0, 100.0, 1e3, 1e4, 99999.0, 1e5, 2e5];
    let mut out = Vec::new();
    for c in 0..640 {
        let a1 = rng.unit_vector();
        let e1 = if c % 3 == 0 { special[(c / 3) % special.len()] } else { log_uniform(&mut rng, 1e-4, 1e5) };
        let e2 = if c % 4 == 1 { special[(c / 4) % special.len()] } else { log_uniform(&mut rng, 1e-4, 1e5) };
        let anti = a1.map(|x| -x);
        let a2 = match c % 9 {
            0 => anti,                                           // α = π
            1 => normalize(madd(anti, 1e-5, rng.unit_vector())), // α → π
            2 => normalize(madd(anti, 1e-2, rng.unit_vector())),
            3 => a1,                                                                                     // α = 0
            4 => normalize(madd(a1, 1e-4, rng.unit_vector())),                                           // α → 0
            5 => normalize(madd(normalize(cross(a1, rng.unit_vector())), rng.uniform(-0.01, 0.01), a1)), // α ≈ π/2
            _ => rng.unit_vector(),
        };
        let v = match c % 5 {
            0 => a1,                                                                                     // at the peak
            1 => normalize(madd(a1, log_uniform(&mut rng, 1e-4, 0.1), rng.unit_vector())),               // near it
            2 => normalize(madd(normalize(cross(a1, rng.unit_vector())), rng.uniform(-1e-3, 1e-3), a1)), // grazing
            3 => anti,
            _ => rng.unit_vector(),
        };
        // Scale, also the sphere radius at distance ~3 (> 4: the receiver is inside the light)
        // and the Lafortune ρ.
        let s = if c % 6 == 0 { rng.uniform(3.5, 5.0) } else { log_uniform(&mut rng, 1e-2, 3.0) };
        out.push(Case { a1: f32v(a1), e1: e1 as f32, a2: f32v(a2), e2: e2 as f32, v: f32v(v), s: s as f32 });
    }
    // Lafortune with C = 0 (w = 0: the zero lobe about n).
    out.push(Case { a1: [0.0, 0.0, 1.0], e1: 2.0, a2: [0.0; 3], e2: 10.0, v: [0.0, 1.0, 0.0], s: 1.0 });
    out
}

#[test]
fn lobes_twin_matches_cpu() {
    let gpu = test_gpu().expect("GPU");
    let cases = cases();
    let input: Vec<f32> = cases
        .iter()
        .flat_map(|c| {
            let mut x = [0.0f32; IN];
            x[0..3].copy_from_slice(&c.a1);
            x[3] = c.e1;
            x[4..7].copy_from_slice(&c.a2);
            x[7] = c.e2;
            x[8..11].copy_from_slice(&c.v);
            x[11] = c.s;
            x
        })
        .collect();
    let out =
        run_f32_kernel(&gpu, "tests/lobes_twin.comp", &input, cases.len() * OUT, cases.len() as u32).expect("kernel");
    assert_all_finite(&out, OUT);
    let mut ck = Checker::default();
    for (ci, c) in cases.iter().enumerate() {
        let o = &out[ci * OUT..(ci + 1) * OUT];
        let (e1, e2, s) = (c.e1 as f64, c.e2 as f64, c.s as f64);
        let (a1r, a2r, vr) = (f64v(c.a1), f64v(c.a2), f64v(c.v));
        let unit = |v: [f64; 3]| if dot(v, v) > 0.0 { normalize(v) } else { v };
        let (a1, a2, v) = (unit(a1r), unit(a2r), unit(vr));

        // [1] ln max(a·v, 0)^e. Inside the hemisphere the GLSL takes ln(1 − m), m = |a − v|²/2
        // (m relative to ~4ε, log1p by series to ~4ε: 8ε|L|; the raw f32 vectors' lengths
        // 1 + δ add (δa − δv)²/2 to m) or, for m ≥ 0.5, ln of the f32 dot (absolute error 3ε, so
        // e·3ε/d). Within 4ε of the horizon the side is decided by rounding.
        let d = dot(a1, v);
        let want_l = lobes::lobe_log_eval(a1, e1, v);
        let (da, dv) = (dot(a1r, a1r).sqrt() - 1.0, dot(vr, vr).sqrt() - 1.0);
        let tol_l = 8.0 * EPS * want_l.abs()
            + e1 * ((da - dv).powi(2) + 1e-15) // + f64 rounding of the renormalized reference
            + e1 * 3.0 * EPS / d.abs().max(1e-30) * f64::from(d < 0.5)
            + 1e-30;
        if d.abs() < 4.0 * EPS {
            let ok = o[1] == NEG_INF_F32 || (want_l.is_finite() && (o[1] as f64 - want_l).abs() <= tol_l);
            assert!(ok || o[1] as f64 * 1.0 <= e1 * (8.0 * EPS).ln(), "case {ci} grazing log eval {}", o[1]);
        } else if want_l == f64::NEG_INFINITY {
            ck.exact("log eval (-inf)", ci, o[1], NEG_INF_F32 as f64);
        } else {
            ck.check("log eval", ci, o[1], want_l, tol_l);
        }
        // [0] s exp(L): L's error becomes relative, exp adds (EXP_ULP + 2|L|) ulp; flush below normal.
        let want = lobes::lobe_eval(a1, s, e1, v);
        if d <= -4.0 * EPS {
            ck.exact("eval (outside)", ci, o[0], 0.0);
        } else if d >= 4.0 * EPS {
            let tol = want * (tol_l + (EXP_ULP + 2.0 * want_l.abs().min(1e3)) * EPS) + s * F32_MIN_NORMAL;
            ck.check("eval", ci, o[0], want, tol);
        }
        // [2] s 2π/(e + 1): 4 roundings.
        ck.check(
            "sphere integral",
            ci,
            o[2],
            s * lobes::sphere_integral(e1),
            5.0 * EPS * s * lobes::sphere_integral(e1),
        );

        if dot(a2r, a2r) == 0.0 {
            // The Lafortune C = 0 case: a2 is no direction (atan2(0, 0) is undefined in GLSL).
            let lf = lobes::lafortune_lobe(&lobes::LafortuneLobe { c: a2r, rho: s, exponent: e2 }, FRAME, vr);
            assert_eq!(lf.scale, 0.0);
            ck.exact("lafortune zero lobe", ci, o[19], 0.0);
            for k in 0..3 {
                ck.exact("lafortune zero lobe", ci, o[16 + k], lf.axis[k]);
            }
            continue;
        }
        // [3] α = atan2(|a1 × a2|, a1·a2): the cross and dot carry absolute errors ~2ε, atan2
        // turns them into an absolute angle error (no cancellation problem at 0 or π), plus its own.
        let alpha_w = lobes::angle_between(a1, a2);
        ck.check("alpha", ci, o[3], alpha_w, 8.0 * EPS + 4.0 * EPS * alpha_w + ATAN_ABS);

        // From here the functions of α get the GPU's α.
        let alpha = o[3] as f64;
        // [4] t = (α + asin(r sin α))/2, r = (e2 − e1)/(e1 + e2): x = r sin α carries ~4ε|x|
        // (+ε for f32 π inside sin), asin is ill conditioned near ±1 (one exponent ≪ the other and
        // α ≈ π/2); the GLSL's asin is an atan2 (ATAN_ABS).
        let t = lobes::product_axis_angle(e1, e2, alpha);
        let sum = e1 + e2;
        let r = if sum > 0.0 { (e2 - e1) / sum } else { 0.0 };
        let x = (r * alpha.sin()).clamp(-1.0, 1.0);
        let tol_t = 0.5 * (4.0 * EPS * alpha + asin_err(x, 5.0 * EPS * x.abs() + EPS) + ATAN_ABS + 4.0 * EPS);
        ck.check("product axis angle", ci, o[4], t, tol_t);
        // [5] ln peak = e1 ln cos t + e2 ln cos(α − t): stationary in t, so t's error enters at
        // second order, ½(e1 sec²t + e2 sec²(α − t)) δt², plus the first-order term where t is at
        // the edge of its branch; ln cos by log1p: ~8ε relative per term, and near π/2 the f32
        // rounding of each angle θ (ε θ tan θ) and the cancellation in 1 − 2 sin²(θ/2) (3ε/cos θ)
        // make cos θ uncertain by ~6ε/cos θ relative, times e.
        let lp = lobes::product_log_peak(e1, e2, alpha);
        if lp == f64::NEG_INFINITY {
            ck.exact("product log peak (-inf)", ci, o[5], NEG_INF_F32 as f64);
        } else if lp < -200.0 {
            // exp(ln peak + ln p_r,rel) is 0 in f32 either way; the GPU may round cos t to ≤ 0
            // (α → π) and return −∞ for it.
            assert!(o[5] <= -100.0, "case {ci} product log peak {} vs {lp}", o[5]);
        } else {
            let sec2 = |a: f64| 1.0 / a.cos().powi(2).max(1e-30);
            let dt = tol_t;
            let slope = (-e1 * t.tan() + e2 * (alpha - t).tan()).abs();
            let tol = 8.0 * EPS * (e1 * lobes_ln_cos(t).abs() + e2 * lobes_ln_cos(alpha - t).abs())
                + 6.0 * EPS * (e1 / t.cos().max(1e-30) + e2 / (alpha - t).cos().max(1e-30))
                + slope * dt
                // Where t or α − t is within δt of π/2 the GLSL floors the distance at 6e-8 (f32
                // cannot resolve it): up to e·(|ln cos| + 17) off there.
                + [(e1, t), (e2, alpha - t)]
                    .iter()
                    .map(|&(e, th)| if th.cos() < 2.0 * dt { e * (lobes_ln_cos(th).abs() + 17.0) } else { 0.0 })
                    .sum::<f64>()
                + 0.5 * (e1 * sec2(t) + e2 * sec2(alpha - t)) * dt * dt
                + 1e-30;
            ck.check("product log peak", ci, o[5], lp, tol);
        }
        // [6..9) axis a1 cos t + b sin t, b = (a2 − a1(a1·a2))/|…|: δt from t (with the GPU's own
        // α inside) plus b's direction error ~3ε/|perp| (× sin t), any axis where |perp| is below
        // the GLSL's 1e-6 switch (antipodal axes: the product is zero, its axis immaterial).
        let ax = lobes::product_axis(a1, e1, a2, e2);
        let t64 = lobes::product_axis_angle(e1, e2, alpha_w);
        let perp = (1.0 - dot(a1, a2).powi(2)).max(0.0).sqrt();
        let tol_ax = if perp < 4e-6 {
            2.0
        } else {
            let dt = 0.5 * (asin_err(x, 5.0 * EPS * x.abs() + EPS) + ATAN_ABS + 8.0 * EPS) + (o[4] as f64 - t64).abs();
            dt + 4.0 * EPS * t64.sin().abs() / perp + 8.0 * EPS
        };
        for k in 0..3 {
            ck.check("product axis", ci, o[6 + k], ax[k], tol_ax);
        }
        // [9], [10] table coordinates of e: piecewise linear, ~6 roundings of the result.
        let c9 = lobes::exponent_coord(e1, 16);
        let c10 = lobes::exponent_coord(e2, 128);
        ck.check("exponent coord 16", ci, o[9], c9, 6.0 * EPS * c9);
        ck.check("exponent coord 128", ci, o[10], c10, 6.0 * EPS * c10);
        // [11] y = (2/π) atan2(√(e+1) c, √(1 − c²)), c = a1·a2 computed in f32 (absolute error
        // ~3ε): the tolerance is the change of y over c ± 3ε (large near |c| = 1, where
        // √(1 − c²) is ill conditioned, and near c = 0 for large e), plus atan2's and 6 roundings.
        let cb = dot(a1, a2);
        let y = lobes::hemisphere_coord_y(e1, cb);
        let dy = [-3.0 * EPS, 3.0 * EPS]
            .iter()
            .map(|dc| (lobes::hemisphere_coord_y(e1, (cb + dc).clamp(-1.0, 1.0)) - y).abs())
            .fold(0.0, f64::max);
        ck.check("hemisphere coord y", ci, o[11], y, dy + (2.0 / PI) * ATAN_ABS + 6.0 * EPS);
        // [12], [13] table coordinates of α and α/2: a division by the f32 π and a scaling.
        let c12 = lobes::alpha_coord(alpha, 49);
        let c13 = lobes::cap_coord(0.5 * alpha, 1000);
        ck.check("alpha coord", ci, o[12], c12, 5.0 * EPS * c12);
        ck.check("cap coord", ci, o[13], c13, 5.0 * EPS * c13);
        // [14] k/α² with k = s: 4 roundings.
        let ce = lobes::cap_exponent_from_k(s, 0.5 * alpha);
        ck.check("cap exponent", ci, o[14], ce, 5.0 * EPS * ce);
        // [15] asin(r/d) (GLSL: atan2(r, √((d − r)(d + r)))), d = |3a2 − v| (f32 3a2 and length:
        // relative ~4ε in r/d), π/2 inside; at d = r both give π/2, so the switch is continuous.
        let centre = a2r.map(|x| 3.0 * x);
        let ca = lobes::sphere_cap_angle(centre, s, vr);
        let dist = (dot(madd(centre, -1.0, vr), madd(centre, -1.0, vr))).sqrt();
        let q = (s / dist).min(1.0);
        ck.check("sphere cap angle", ci, o[15], ca, asin_err(q, 6.0 * EPS * q) + ATAN_ABS + 4.0 * EPS);
        // [16..20) Lafortune: w = C ⊙ v (exact up to one rounding per component: |w| to ~3ε),
        // scale ρ exp(e ln|w|): ln|w| absolute error ~3ε + 3 ulp, times e.
        let lobe = lobes::LafortuneLobe { c: a2r, rho: s, exponent: e2 };
        let lf = lobes::lafortune_lobe(&lobe, FRAME, vr);
        for k in 0..3 {
            ck.check("lafortune axis", ci, o[16 + k], lf.axis[k], 6.0 * EPS);
        }
        let lw = lf.scale / s;
        let big_l = if lw > 0.0 { lw.ln().abs() } else { 0.0 };
        let tol = lf.scale * (e2 * 4.0 * EPS + (6.0 + 2.0 * big_l.min(1e3)) * EPS) * 1.01 + s * F32_MIN_NORMAL;
        ck.check("lafortune scale", ci, o[19], lf.scale, tol);
    }
    ck.report("lobes twin");
    gpu.shutdown().expect("clean teardown");
}

/// ln cos x (for the tolerance only).
fn lobes_ln_cos(x: f64) -> f64 {
    if x.abs() >= FRAC_PI_2 {
        0.0
    } else {
        x.cos().ln()
    }
}

#[test]
fn lobes_twin_alpha_is_pi_for_antipodal_axes() {
    // α = π exactly in f32 arithmetic for a2 = −a1: the product peak must be −∞ (the GLSL's
    // −3e38), never NaN, and the product exponent of the cap at α/2 = π/2 is 0.
    let gpu = test_gpu().expect("GPU");
    let mut input = Vec::new();
    for a in [[0.0f32, 0.0, 1.0], [0.6, 0.8, 0.0], [1.0, 0.0, 0.0]] {
        input.extend_from_slice(&[a[0], a[1], a[2], 3.0, -a[0], -a[1], -a[2], 7.0, a[0], a[1], a[2], 1.0]);
    }
    let out = run_f32_kernel(&gpu, "tests/lobes_twin.comp", &input, 3 * OUT, 3).expect("kernel");
    assert_all_finite(&out, OUT);
    for c in 0..3 {
        let o = &out[c * OUT..(c + 1) * OUT];
        assert!((o[3] as f64 - PI).abs() < 4.0 * EPS, "α {}", o[3]);
        assert_eq!(o[5], NEG_INF_F32, "log peak of antipodal lobes");
        assert_eq!(o[14], 0.0, "cap exponent at α/2 = π/2");
    }
    gpu.shutdown().expect("clean teardown");
}
