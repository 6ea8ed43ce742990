//! Measurements of the fits and tables against the exact integrals (for the report; the heavy
//! sweeps run outside the unit tests).

use super::{
    cap_exponent, cap_relative_l2_error, clamped_cosine_integral, exponent_samples, hemisphere_integral, ln_wallis,
    product_fit, sphere_integral, wallis, HemisphereTable, ProductFit, ProductShape, ProductTable,
};
use std::f64::consts::PI;

/// Error of the single-lobe product at one (e1, e2, α), unit scales.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProductError {
    pub e1: f64,
    pub e2: f64,
    pub alpha: f64,
    /// `∫ c1 c2 dω` (exact).
    pub true_integral: f64,
    /// `p_r 2π/(e_r + 1)`.
    pub approx_integral: f64,
    /// `|approx − true|`: the paper's Fig. 3 error (unit scales).
    pub abs_error: f64,
    /// `|approx − true| / true` (0 when both vanish).
    pub rel_error: f64,
    /// `‖c1 c2 − c_r‖ / ‖c1 c2‖` over the sphere (the quantity Eq. 19 minimizes, normalized).
    pub rel_l2: f64,
}

/// Measures a fit (from [`product_fit`] or a table lookup) against the exact product.
pub fn product_error(e1: f64, e2: f64, alpha: f64, fit: &ProductFit) -> ProductError {
    let (true_integral, rel_l2) = if alpha >= PI {
        (0.0, 0.0)
    } else {
        let shape = ProductShape::new(e1, e2, alpha);
        let ti = (shape.ln_peak + ln_wallis(shape.sum_e() + 1.0)).exp() * shape.x_integral(0.0);
        // Relative L2 in units of the peak: ‖P‖², ⟨P, L⟩, ‖L‖² all scaled by exp(−ln_peak).
        let pp = wallis(2.0 * shape.sum_e() + 1.0) * shape.x_integral_squared();
        let pl = shape.ln_inner(fit.e_r).exp();
        let pr = fit.ln_pr_rel.exp();
        let ll = 2.0 * PI / (2.0 * fit.e_r + 1.0);
        let res = pp - 2.0 * pr * pl + pr * pr * ll;
        (ti, (res.max(0.0) / pp).sqrt())
    };
    let approx = fit.p_r() * sphere_integral(fit.e_r);
    let abs_error = (approx - true_integral).abs();
    let rel_error = if true_integral > 0.0 { abs_error / true_integral } else { 0.0 };
    ProductError { e1, e2, alpha, true_integral, approx_integral: approx, abs_error, rel_error, rel_l2 }
}

/// Summary statistics of a set of product errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorStats {
    pub count: usize,
    pub mean_abs: f64,
    pub median_abs: f64,
    pub max_abs: f64,
    /// Cases entering the relative statistics ([`is_significant`]).
    pub count_significant: usize,
    pub mean_rel: f64,
    pub median_rel: f64,
    pub max_rel: f64,
    pub mean_rel_l2: f64,
    /// The case with the largest relative integral error.
    pub worst_rel: Option<ProductError>,
    /// The case with the largest absolute integral error.
    pub worst_abs: Option<ProductError>,
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Whether a product matters enough for relative errors to mean something: it keeps at least
/// 1e-3 of the sharper lobe's own integral `2π/(max(e1, e2) + 1)`. (Far-apart sharp lobes have
/// products of 1e-300, whose relative error is noise and whose absolute error is nil.)
pub fn is_significant(e: &ProductError) -> bool {
    e.true_integral >= 1e-3 * sphere_integral(e.e1.max(e.e2))
}

/// Statistics: absolute errors over all cases (the paper's measure, unit scales); relative
/// errors over the [`is_significant`] cases only (`count_significant`).
pub fn error_stats(errors: &[ProductError]) -> ErrorStats {
    let n = errors.len().max(1) as f64;
    let sig: Vec<ProductError> = errors.iter().copied().filter(is_significant).collect();
    let ns = sig.len().max(1) as f64;
    let worst_rel = sig.iter().copied().max_by(|a, b| a.rel_error.total_cmp(&b.rel_error));
    let worst_abs = errors.iter().copied().max_by(|a, b| a.abs_error.total_cmp(&b.abs_error));
    ErrorStats {
        count: errors.len(),
        mean_abs: errors.iter().map(|e| e.abs_error).sum::<f64>() / n,
        median_abs: median(errors.iter().map(|e| e.abs_error).collect()),
        max_abs: worst_abs.map_or(0.0, |e| e.abs_error),
        count_significant: sig.len(),
        mean_rel: sig.iter().map(|e| e.rel_error).sum::<f64>() / ns,
        median_rel: median(sig.iter().map(|e| e.rel_error).collect()),
        max_rel: worst_rel.map_or(0.0, |e| e.rel_error),
        mean_rel_l2: sig.iter().map(|e| e.rel_l2).sum::<f64>() / ns,
        worst_rel,
        worst_abs,
    }
}

/// Fit error of the product approximation at the table's own nodes (e1, e2 on `exponent_samples
/// (per_decade)`, α on `alpha_samples` points in [0, π) — the last point π is excluded, its product
/// is zero). This is the paper's measurement (Sec. 4.1: mean 7.1e-4, worst for e < 1 near π/2).
pub fn measure_product_fit_on_grid(per_decade: usize, alpha_samples: usize) -> Vec<ProductError> {
    let es = exponent_samples(per_decade);
    let mut out = Vec::new();
    for &e1 in &es {
        for &e2 in &es {
            for j in 0..alpha_samples - 1 {
                let alpha = PI * j as f64 / (alpha_samples - 1) as f64;
                out.push(product_error(e1, e2, alpha, &product_fit(e1, e2, alpha)));
            }
        }
    }
    out
}

/// Error of table lookups (fit + interpolation) at `count` seeded random queries: exponents
/// log-uniform in [1e-2, 1e5] (one in eight exactly 0), α uniform in [α_lo, α_hi].
pub fn measure_product_table(
    table: &ProductTable,
    count: usize,
    alpha_lo: f64,
    alpha_hi: f64,
    seed: u64,
) -> Vec<ProductError> {
    let mut rng = crate::rng::Pcg32::new(seed, 11);
    let exp_sample = |rng: &mut crate::rng::Pcg32| {
        if rng.next_u32().is_multiple_of(8) {
            0.0
        } else {
            10f64.powf(rng.uniform(-2.0, 5.0))
        }
    };
    (0..count)
        .map(|_| {
            let e1 = exp_sample(&mut rng);
            let e2 = exp_sample(&mut rng);
            let alpha = rng.uniform(alpha_lo, alpha_hi);
            product_error(e1, e2, alpha, &table.lookup(e1, e2, alpha))
        })
        .collect()
}

/// Largest relative error of the hemisphere table against the exact integrals at `count` seeded
/// random (e log-uniform in [1e-2, 1e5], cos β uniform) queries: `[hemisphere, clamped cosine]`,
/// each relative to the lobe's full integral (so that tiny tails do not dominate).
pub fn measure_hemisphere_table(table: &HemisphereTable, count: usize, seed: u64) -> [f64; 2] {
    let mut rng = crate::rng::Pcg32::new(seed, 12);
    let mut worst = [0.0f64; 2];
    for _ in 0..count {
        let e = 10f64.powf(rng.uniform(-2.0, 5.0));
        let c = rng.uniform(-1.0, 1.0);
        let h = (table.hemisphere_integral(e, c) - hemisphere_integral(e, c)).abs() / sphere_integral(e);
        let k = (table.clamped_cosine_integral(e, c) - clamped_cosine_integral(e, c)).abs() / (2.0 * PI / (e + 2.0));
        worst[0] = worst[0].max(h);
        worst[1] = worst[1].max(k);
    }
    worst
}

/// Cap fit quality: (α, e_cap, e_cap α², relative L2 error) at the given angles.
pub fn measure_cap_fit(alphas: &[f64]) -> Vec<(f64, f64, f64, f64)> {
    alphas
        .iter()
        .map(|&a| {
            let e = cap_exponent(a);
            (a, e, e * a * a, cap_relative_l2_error(a, e))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lobes::{cap_table, hemisphere_table, product_table, PRODUCT_ALPHA_SAMPLES, PRODUCT_SAMPLES_PER_DECADE};
    use crate::rng::Pcg32;
    use std::f64::consts::FRAC_PI_2;

    /// The report's numbers: full-size tables (timed) and the error sweeps. Heavy (about a minute
    /// in release), so ignored by default:
    /// `cargo test --release -p engine-math lobes::tests::report -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn report_measurements() {
        use std::time::Instant;
        let t0 = Instant::now();
        let hemi = hemisphere_table();
        let t_hemi = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let prod = product_table();
        let t_prod = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let caps = cap_table();
        let t_cap = t0.elapsed().as_secs_f64();
        println!(
            "tables: hemisphere {t_hemi:.2} s {} B; product {t_prod:.2} s {} B; cap {t_cap:.3} s {} B",
            hemi.size_bytes(),
            prod.size_bytes(),
            caps.size_bytes()
        );
        let total = hemi.size_bytes() + prod.size_bytes() + caps.size_bytes();
        println!("total {total} B = {:.2} MiB", total as f64 / (1024.0 * 1024.0));
        assert!(total < 8 << 20);
        assert!(prod.data.iter().all(|v| v[0].is_finite() && v[1].is_finite()));

        let show = |name: &str, errs: &[ProductError]| {
            let s = error_stats(errs);
            println!(
                "{name}: n={} abs mean {:.3e} median {:.3e} max {:.3e} | significant {}: rel mean {:.3e} median {:.3e} max {:.3e} | relL2 mean {:.3e}",
                s.count, s.mean_abs, s.median_abs, s.max_abs, s.count_significant, s.mean_rel, s.median_rel, s.max_rel, s.mean_rel_l2
            );
            if let Some(w) = s.worst_rel {
                println!(
                    "   worst rel at e1={:.4} e2={:.4} α={:.4}: true {:.4e} approx {:.4e}",
                    w.e1, w.e2, w.alpha, w.true_integral, w.approx_integral
                );
            }
            if let Some(w) = s.worst_abs {
                println!(
                    "   worst abs at e1={:.4} e2={:.4} α={:.4}: true {:.4e} approx {:.4e}",
                    w.e1, w.e2, w.alpha, w.true_integral, w.approx_integral
                );
            }
            s
        };
        let grid = measure_product_fit_on_grid(PRODUCT_SAMPLES_PER_DECADE, PRODUCT_ALPHA_SAMPLES);
        let all = show("fit on grid, all α < π", &grid);
        let small: Vec<_> = grid.iter().copied().filter(|e| e.alpha <= 0.5).collect();
        let s_small = show("fit on grid, α ≤ 0.5", &small);
        let mid: Vec<_> = grid.iter().copied().filter(|e| e.alpha > 0.5 && e.alpha < FRAC_PI_2).collect();
        show("fit on grid, 0.5 < α < π/2", &mid);
        let big: Vec<_> = grid.iter().copied().filter(|e| e.alpha >= FRAC_PI_2).collect();
        let s_big = show("fit on grid, α ≥ π/2", &big);
        let low: Vec<_> = grid.iter().copied().filter(|e| e.e1 < 1.0 && e.e2 < 1.0).collect();
        show("fit on grid, e1, e2 < 1", &low);
        let high: Vec<_> = grid.iter().copied().filter(|e| e.e1 >= 1.0 && e.e2 >= 1.0).collect();
        show("fit on grid, e1, e2 ≥ 1", &high);
        for (lo, hi) in [(0.0, 0.5), (0.5, FRAC_PI_2), (FRAC_PI_2, PI)] {
            let r = measure_product_table(&prod, 20000, lo, hi, 1);
            show(&format!("table lookup, random α ∈ [{lo:.3}, {hi:.3}]"), &r);
        }
        let hw = measure_hemisphere_table(&hemi, 20000, 2);
        println!(
            "hemisphere table worst error / lobe integral: hemisphere {:.3e}, clamped cosine {:.3e}",
            hw[0], hw[1]
        );
        for (a, e, k, r) in measure_cap_fit(&[1e-4, 1e-2, 0.1, 0.3, 0.6, 1.0, 1.3, 1.5, 1.56]) {
            println!("cap α={a:.4}: e_cap={e:.5e} e·α²={k:.5} relL2={r:.4}");
        }
        let mut rng = Pcg32::new(4, 4);
        let mut worst_cap = 0.0f64;
        for _ in 0..20000 {
            let a = rng.uniform(1e-4, 1.55);
            let d = cap_exponent(a);
            worst_cap = worst_cap.max((caps.exponent(a) - d).abs() / (d + 1.0));
        }
        println!("cap table worst |Δe|/(e+1) over α ∈ [1e-4, 1.55]: {worst_cap:.3e}");
        // The claims the report makes, checked (margins over the printed values).
        assert!(s_small.mean_rel < all.mean_rel && s_big.max_rel > 0.3);
        assert!(hw[0] < 1e-3 && hw[1] < 1e-3 && worst_cap < 1e-3);
    }
}
