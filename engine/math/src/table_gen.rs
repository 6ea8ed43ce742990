//! The precomputed tables the techniques read, as [`crate::tables`] files: what each one holds, how to generate it
//! in full, and how to regenerate any single entry (the drift check).
//!
//! | name | generator | shape |
//! |---|---|---|
//! | `isg_lut` | [`IsgLut::generate_default`] | 55 λ slices × 2 marginals × 64, packed (4 floats) |
//! | `lobe_product` | [`lobes::product_table`] | 97 e1 × 97 e2 × 49 α, (ln p_r/peak, e_r) |
//! | `lobe_hemisphere` | [`lobes::hemisphere_table`] | 769 e × 129 y, (f_h, f_b) |
//! | `lobe_cap` | [`lobes::cap_table`] | 1000 α, k = e_cap α² |
//! | `shN_circle_log` | [`CircleLogTable::new`] | 12 segments × 64 u = 1 − cos θ, (f*_l(θ)/u, u) |
//! | `shN_ol` | [`OlTable::new`] resampled | [`OL_SAMPLES`] ‖f̂‖, (a, b) |
//! | `shN_gamma` | [`ShTensor::new`] | entries, (packed i j k, Γ) |
//!
//! for SH orders N in [`SH_ORDERS`]. Full generation calls the library generators (the product table's loop is
//! spread over threads here: it is the one that takes more than a second or two); [`Regenerator`] recomputes single
//! entries from the same functions, and a unit test checks, bit for bit, that both agree on small tables.

use crate::isg::{
    isg_lut_marginals, isg_lut_slice_lambda, IsgLut, ISG_LUT_N, ISG_LUT_OCTAVE0, ISG_LUT_OCTAVES, ISG_LUT_PER_OCTAVE,
};
use crate::lobes::{self, exponent_samples};
use crate::sh::{CircleLogTable, ShTensor, CIRCLE_TABLE_SEGMENTS, CIRCLE_TABLE_SEGMENT_SAMPLES};
use crate::shexp::OlTable;
use crate::tables::{Axis, Component, Table, TableHeader};
use std::f64::consts::{FRAC_PI_2, PI};

/// SH orders whose tables are generated.
pub const SH_ORDERS: std::ops::RangeInclusive<usize> = 2..=8;
/// Samples of the OL (a, b) tables, uniform in ‖f̂‖ over [0, ‖f̂‖_max].
pub const OL_SAMPLES: usize = 256;

/// Tolerance of the drift check for f32 components: `|stored − regenerated| ≤ ABS + REL · |regenerated|`.
/// Regenerating on the machine that wrote the tables reproduces them bit for bit; the slack allows for libm
/// differences between platforms (a few f64 ulps in exp/ln/sin, amplified at most a little by the fits), and is far
/// below every table's own interpolation error (≥ 1e-4).
pub const DRIFT_ABS: f64 = 1e-6;
pub const DRIFT_REL: f64 = 1e-5;

/// One of the precomputed tables.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MathTable {
    IsgLut,
    LobeProduct,
    LobeHemisphere,
    LobeCap,
    ShCircleLog(usize),
    ShOl(usize),
    ShGamma(usize),
}

/// Every table, in generation order.
pub fn all_tables() -> Vec<MathTable> {
    let mut v = vec![MathTable::IsgLut, MathTable::LobeProduct, MathTable::LobeHemisphere, MathTable::LobeCap];
    for n in SH_ORDERS {
        v.extend([MathTable::ShCircleLog(n), MathTable::ShOl(n), MathTable::ShGamma(n)]);
    }
    v
}

impl MathTable {
    /// File stem (`assets/tables/<name>.bin`) and GPU buffer name.
    pub fn name(&self) -> String {
        match self {
            MathTable::IsgLut => "isg_lut".into(),
            MathTable::LobeProduct => "lobe_product".into(),
            MathTable::LobeHemisphere => "lobe_hemisphere".into(),
            MathTable::LobeCap => "lobe_cap".into(),
            MathTable::ShCircleLog(n) => format!("sh{n}_circle_log"),
            MathTable::ShOl(n) => format!("sh{n}_ol"),
            MathTable::ShGamma(n) => format!("sh{n}_gamma"),
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        all_tables().into_iter().find(|t| t.name() == name)
    }

    /// Bumped whenever the mathematics behind a table changes; the drift test then asks for regeneration.
    pub fn generator_version(&self) -> u32 {
        match self {
            // 2: the separable table of Ŝ's marginals (was 1: Ŝ on a 16 × 16 sigmoid-warped grid).
            MathTable::IsgLut => 2,
            // 2: f*_l/(1 − cos θ) in segments of u = 1 − cos θ split at the clip's kinks (was 1:
            // f*_l linear in θ, 256 samples: small blockers too large, the kink smoothed over).
            MathTable::ShCircleLog(_) => 2,
            _ => 1,
        }
    }

    /// The table in full.
    pub fn generate(&self) -> Table {
        match *self {
            MathTable::IsgLut => {
                let lut = IsgLut::generate_default();
                Table::from_f32(isg_header(lut.n, lut.per_octave), &lut.values)
            }
            MathTable::LobeProduct => product_generate(lobes::PRODUCT_SAMPLES_PER_DECADE, lobes::PRODUCT_ALPHA_SAMPLES),
            MathTable::LobeHemisphere => {
                let t = lobes::hemisphere_table();
                let flat: Vec<f32> = t.data.iter().flatten().copied().collect();
                Table::from_f32(hemisphere_header(t.per_decade, t.y_samples), &flat)
            }
            MathTable::LobeCap => {
                let t = lobes::cap_table();
                Table::from_f32(cap_header(t.k.len()), &t.k)
            }
            MathTable::ShCircleLog(n) => {
                let t = CircleLogTable::new(&ShTensor::new(n));
                let mut flat = Vec::with_capacity(t.ratio.len() / n * (n + 1));
                for seg in 0..CIRCLE_TABLE_SEGMENTS {
                    for i in 0..CIRCLE_TABLE_SEGMENT_SAMPLES {
                        let k = seg * CIRCLE_TABLE_SEGMENT_SAMPLES + i;
                        flat.extend(t.ratio[k * n..(k + 1) * n].iter().map(|&v| v as f32));
                        flat.push(CircleLogTable::u_of(&t.knots, seg, i) as f32);
                    }
                }
                Table::from_f32(circle_header(n), &flat)
            }
            MathTable::ShOl(n) => ol_table(n),
            MathTable::ShGamma(n) => gamma_table(&ShTensor::new(n)),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Headers.

fn f32s(k: usize) -> Vec<Component> {
    vec![Component::F32; k]
}

fn isg_header(n: usize, per_octave: usize) -> TableHeader {
    let lo = 2f64.powi(ISG_LUT_OCTAVE0);
    TableHeader {
        name: MathTable::IsgLut.name(),
        generator_version: MathTable::IsgLut.generator_version(),
        axes: vec![
            Axis::octave("lambda: SG sharpness", per_octave, lo, lo * 2f64.powi(ISG_LUT_OCTAVES as i32)),
            Axis::index("marginal: 0 = M(theta) = S^(theta, pi), 1 = N(phi) = S^(pi, phi)", 2),
            Axis::uniform(
                "s = 1/2 + (angle - pi/2) max(sqrt(lambda)/(pi sqrt 6), 1/pi), angle in [0, pi]",
                n,
                0.0,
                1.0,
            ),
        ],
        components: f32s(4),
        description: "Marginals of the normalized ISG integral S^(theta, phi; lambda) (engine_math::isg::IsgLut, \
                      isg.glsl ISG_LUT_FETCH), S^ ~ M(theta) N(phi); entry (l, a, i) packs (X_l[i], X_l[i+1], \
                      X_l+1[i], X_l+1[i+1]) for one read per bilinear lookup in (s, lambda)."
            .into(),
    }
}

fn product_header(per_decade: usize, alpha_samples: usize) -> TableHeader {
    TableHeader {
        name: MathTable::LobeProduct.name(),
        generator_version: MathTable::LobeProduct.generator_version(),
        axes: vec![
            Axis::lobe_exponent("e1: exponent of the first lobe", per_decade),
            Axis::lobe_exponent("e2: exponent of the second lobe", per_decade),
            Axis::uniform("alpha: angle between the lobe axes [rad]", alpha_samples, 0.0, PI),
        ],
        components: f32s(2),
        description: "Single-lobe fit of the product of two unit cosine lobes (lobes::product_fit): \
                      [ln p_r - ln peak, e_r]. The entry at alpha = pi repeats the previous alpha."
            .into(),
    }
}

fn hemisphere_header(per_decade: usize, y_samples: usize) -> TableHeader {
    TableHeader {
        name: MathTable::LobeHemisphere.name(),
        generator_version: MathTable::LobeHemisphere.generator_version(),
        axes: vec![
            Axis::lobe_exponent("e: lobe exponent", per_decade),
            Axis::uniform(
                "y = (2/pi) atan2(sqrt(e+1) cos beta, sin beta), beta = angle(axis, normal)",
                y_samples,
                -1.0,
                1.0,
            ),
        ],
        components: f32s(2),
        description: "Fractions of a cosine lobe above a plane (lobes::HemisphereTable): [f_h = hemisphere \
                      integral / (2pi/(e+1)), f_b = below-plane clamped-cosine integral / (2pi/(e+2))]."
            .into(),
    }
}

fn cap_header(n: usize) -> TableHeader {
    TableHeader {
        name: MathTable::LobeCap.name(),
        generator_version: MathTable::LobeCap.generator_version(),
        axes: vec![Axis::uniform("alpha_cap: angular radius of the spherical cap [rad]", n, 0.0, FRAC_PI_2)],
        components: f32s(1),
        description: "k = e_cap(alpha) * alpha^2, the L2-nearest cosine-lobe exponent of a spherical cap times \
                      alpha^2 (lobes::CapTable); k(0) is the small-angle limit."
            .into(),
    }
}

fn circle_header(n: usize) -> TableHeader {
    TableHeader {
        name: MathTable::ShCircleLog(n).name(),
        generator_version: MathTable::ShCircleLog(n).generator_version(),
        axes: vec![
            Axis::index(
                "segment of u = 1 - cos(theta) in [0, 1], its knots at the eigenvalue clip's kinks and greedy splits",
                CIRCLE_TABLE_SEGMENTS,
            ),
            Axis::uniform(
                "t: position in the segment, u = u0 + t (u1 - u0) (u0, u1: the u of the segment's first and last entry)",
                CIRCLE_TABLE_SEGMENT_SAMPLES,
                0.0,
                1.0,
            ),
        ],
        components: f32s(n + 1),
        description: format!(
            "Scaled zonal log-visibility of a circular blocker about +z divided by u = 1 - cos(theta): \
             [f*_l(theta)/u for l = 0..{}, u] (eigen method, sh::CircleLogTable, order {n}); the u = 0 entry is the \
             exact limit -2 pi. Lookup: the segment whose [u0, u1] holds u, f*_l = u (linear interpolation in t), \
             rotate with f_lm = f*_l y_lm(axis).",
            n - 1
        ),
    }
}

fn ol_header(n: usize, norm_max: f64) -> TableHeader {
    TableHeader {
        name: MathTable::ShOl(n).name(),
        generator_version: MathTable::ShOl(n).generator_version(),
        axes: vec![Axis::uniform("|f^|: norm of the log vector without its DC term", OL_SAMPLES, 0.0, norm_max)],
        components: f32s(2),
        description: format!(
            "OL coefficients [a, b] of exp*(f^) ~ a 1 + b f^ (SHEXP Eq. 23-24), fitted on circles \
             (shexp::OlTable, order {n}), resampled uniformly in |f^|; beyond the range use HYB."
        ),
    }
}

fn gamma_header(n: usize, count: usize) -> TableHeader {
    TableHeader {
        name: MathTable::ShGamma(n).name(),
        generator_version: MathTable::ShGamma(n).generator_version(),
        axes: vec![Axis::index("entry of the sparse triple-product tensor (j <= k)", count)],
        components: vec![Component::U32, Component::F32],
        description: format!(
            "SH triple-product tensor of order {n} (sh::ShTensor): [i | j << 8 | k << 16, value], value = \
             Gamma_ijk for j < k and Gamma_ijj / 2 for j == k, so c_i += value (a_j b_k + a_k b_j)."
        ),
    }
}

// ---------------------------------------------------------------------------------------------
// Generators that are not a single library call.

/// [`lobes::product_table_sized`], with its rows spread over threads (same calls, same values, bit for bit).
fn product_generate(per_decade: usize, alpha_samples: usize) -> Table {
    let es = exponent_samples(per_decade);
    let n = es.len();
    let threads = std::thread::available_parallelism().map(|t| t.get()).unwrap_or(1).min(n);
    let mut data = vec![0f32; n * n * alpha_samples * 2];
    let rows: Vec<Vec<(usize, Vec<[f32; 2]>)>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let es = &es;
                // Interleaved rows balance the triangle (row i1 holds n − i1 pairs).
                s.spawn(move || {
                    (t..n)
                        .step_by(threads)
                        .map(|i1| {
                            let mut row = Vec::with_capacity((n - i1) * alpha_samples);
                            for &e2 in &es[i1..] {
                                for j in 0..alpha_samples {
                                    row.push(product_entry(es[i1], e2, j, alpha_samples));
                                }
                            }
                            (i1, row)
                        })
                        .collect()
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().expect("product table thread panicked")).collect()
    });
    for (i1, row) in rows.into_iter().flatten() {
        for (k, v) in row.into_iter().enumerate() {
            let (i2, j) = (i1 + k / alpha_samples, k % alpha_samples);
            for idx in [(i1 * n + i2) * alpha_samples + j, (i2 * n + i1) * alpha_samples + j] {
                data[2 * idx] = v[0];
                data[2 * idx + 1] = v[1];
            }
        }
    }
    Table::from_f32(product_header(per_decade, alpha_samples), &data)
}

/// One product-table entry for `e_lo ≤ e_hi` (the table is symmetric and computed from the lower exponent first,
/// as [`lobes::product_table_sized`] does).
fn product_entry(e_lo: f64, e_hi: f64, j: usize, alpha_samples: usize) -> [f32; 2] {
    let jj = if j + 1 == alpha_samples && j > 0 { j - 1 } else { j };
    let alpha = PI * jj as f64 / (alpha_samples - 1) as f64;
    let f = lobes::product_fit(e_lo, e_hi, alpha);
    [f.ln_pr_rel as f32, f.e_r as f32]
}

fn ol_table(n: usize) -> Table {
    let ol = OlTable::new(&ShTensor::new(n)).resampled(OL_SAMPLES);
    let flat: Vec<f32> = ol.a.iter().zip(&ol.b).flat_map(|(&a, &b)| [a as f32, b as f32]).collect();
    Table::from_f32(ol_header(n, ol.norm_max()), &flat)
}

fn gamma_table(t: &ShTensor) -> Table {
    let words = t
        .entries
        .iter()
        .flat_map(|e| [e.i as u32 | (e.j as u32) << 8 | (e.k as u32) << 16, (e.v as f32).to_bits()])
        .collect();
    Table { header: gamma_header(t.n, t.entries.len()), words }
}

// ---------------------------------------------------------------------------------------------
// Single-entry regeneration (the drift check).

enum Ctx {
    Isg {
        n: usize,
        per_octave: usize,
        slices: usize,
        /// The two marginals of a slice, by slice.
        cache: std::cell::RefCell<std::collections::HashMap<usize, [Vec<f64>; 2]>>,
    },
    Product {
        alpha_samples: usize,
        es: Vec<f64>,
    },
    Hemisphere {
        y_samples: usize,
        es: Vec<f64>,
    },
    Cap {
        n: usize,
    },
    Circle {
        tensor: ShTensor,
        knots: Vec<f64>,
    },
    /// Small tables whose entries all depend on one fit: regenerated whole.
    Whole(Table),
}

/// Recomputes single entries of a table from the mathematics, without generating the whole table (except for the
/// small SH OL and Γ tables, whose entries share one fit or one enumeration and cost milliseconds).
pub struct Regenerator {
    header: TableHeader,
    ctx: Ctx,
}

impl Regenerator {
    /// For the table at its default dimensions.
    pub fn new(table: MathTable) -> Self {
        match table {
            MathTable::IsgLut => Self::isg(ISG_LUT_N, ISG_LUT_PER_OCTAVE),
            MathTable::LobeProduct => Self::product(lobes::PRODUCT_SAMPLES_PER_DECADE, lobes::PRODUCT_ALPHA_SAMPLES),
            MathTable::LobeHemisphere => {
                Self::hemisphere(lobes::HEMISPHERE_SAMPLES_PER_DECADE, lobes::HEMISPHERE_Y_SAMPLES)
            }
            MathTable::LobeCap => Self::cap(lobes::CAP_SAMPLES),
            MathTable::ShCircleLog(n) => {
                let tensor = ShTensor::new(n);
                let knots = CircleLogTable::knots(&tensor);
                Self { header: circle_header(n), ctx: Ctx::Circle { tensor, knots } }
            }
            MathTable::ShOl(n) => Self::whole(ol_table(n)),
            MathTable::ShGamma(n) => Self::whole(gamma_table(&ShTensor::new(n))),
        }
    }

    fn isg(n: usize, per_octave: usize) -> Self {
        let slices = ISG_LUT_OCTAVES * per_octave + 1;
        Self { header: isg_header(n, per_octave), ctx: Ctx::Isg { n, per_octave, slices, cache: Default::default() } }
    }
    fn product(per_decade: usize, alpha_samples: usize) -> Self {
        let es = exponent_samples(per_decade);
        Self { header: product_header(per_decade, alpha_samples), ctx: Ctx::Product { alpha_samples, es } }
    }
    fn hemisphere(per_decade: usize, y_samples: usize) -> Self {
        let es = exponent_samples(per_decade);
        Self { header: hemisphere_header(per_decade, y_samples), ctx: Ctx::Hemisphere { y_samples, es } }
    }
    fn cap(n: usize) -> Self {
        Self { header: cap_header(n), ctx: Ctx::Cap { n } }
    }
    fn whole(t: Table) -> Self {
        Self { header: t.header.clone(), ctx: Ctx::Whole(t) }
    }

    /// The header the table must have.
    pub fn header(&self) -> &TableHeader {
        &self.header
    }

    /// The words of entry `linear` (row-major, as stored).
    pub fn entry(&self, linear: usize) -> Vec<u32> {
        let idx = self.header.multi_index(linear);
        let f = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
        match &self.ctx {
            Ctx::Isg { n, per_octave, slices, cache } => {
                let (l, a, i) = (idx[0], idx[1], idx[2]);
                let mut cache = cache.borrow_mut();
                let mut get = |l: usize| {
                    cache
                        .entry(l)
                        .or_insert_with(|| {
                            let (m, nn) = isg_lut_marginals(*n, isg_lut_slice_lambda(ISG_LUT_OCTAVE0, *per_octave, l));
                            [m, nn]
                        })
                        .clone()
                };
                let (lo, hi) = (get(l), get((l + 1).min(slices - 1)));
                f(&IsgLut::pack(&lo[a], &hi[a], i).map(|v| v as f32))
            }
            Ctx::Product { alpha_samples, es, .. } => {
                let (i1, i2, j) = (idx[0], idx[1], idx[2]);
                f(&product_entry(es[i1.min(i2)], es[i1.max(i2)], j, *alpha_samples))
            }
            Ctx::Hemisphere { y_samples, es, .. } => {
                let (e, iy) = (es[idx[0]], idx[1]);
                let y = -1.0 + 2.0 * iy as f64 / (*y_samples - 1) as f64;
                let c = lobes::hemisphere_cos_beta(e, y);
                let fh = lobes::hemisphere_integral(e, c) / lobes::sphere_integral(e);
                let fb = lobes::clamped_cosine_integral(e, -c.abs()) / (2.0 * PI / (e + 2.0));
                f(&[fh as f32, fb as f32])
            }
            Ctx::Cap { n } => {
                let i = idx[0];
                let a = FRAC_PI_2 * i as f64 / (*n - 1) as f64;
                let k = if i == 0 { lobes::cap_small_angle_limit() } else { lobes::cap_exponent(a) * a * a };
                f(&[k as f32])
            }
            Ctx::Circle { tensor, knots } => {
                let u = CircleLogTable::u_of(knots, idx[0], idx[1]);
                let mut z: Vec<f32> = CircleLogTable::entry(tensor, u).iter().map(|&v| v as f32).collect();
                z.push(u as f32);
                f(&z)
            }
            Ctx::Whole(t) => t.entry(linear).to_vec(),
        }
    }

    /// Check `stored` against this regenerator: header (all fields, and the generator version), then the entries
    /// at `indices`. Returns the largest f32 deviation, in units of the tolerance scale `ABS + REL·|value|`
    /// (≤ 1 passes), or the first mismatch.
    pub fn check(&self, stored: &Table, indices: &[usize]) -> Result<f64, String> {
        let name = &self.header.name;
        let sh = &stored.header;
        if sh.generator_version != self.header.generator_version {
            return Err(format!(
                "{name}: generator version {} in the file, {} in the code: regenerate with `cargo xtask tables`",
                sh.generator_version, self.header.generator_version
            ));
        }
        if *sh != self.header {
            return Err(format!(
                "{name}: header differs from the generator's (regenerate with `cargo xtask tables`):\n  file: {sh:?}\n  \
                 code: {:?}",
                self.header
            ));
        }
        let mut worst = 0.0f64;
        for &k in indices {
            let want = self.entry(k);
            let got = stored.entry(k);
            for (c, ((&w, &g), comp)) in want.iter().zip(got).zip(&self.header.components).enumerate() {
                let ok = match comp {
                    Component::U32 => w == g,
                    Component::F32 => {
                        let (w, g) = (f32::from_bits(w) as f64, f32::from_bits(g) as f64);
                        let scale = DRIFT_ABS + DRIFT_REL * w.abs();
                        let d = if w == g { 0.0 } else { (w - g).abs() / scale };
                        worst = worst.max(d);
                        d <= 1.0
                    }
                };
                if !ok {
                    let show = |x: u32| match comp {
                        Component::U32 => format!("{x}"),
                        Component::F32 => format!("{:e}", f32::from_bits(x)),
                    };
                    return Err(format!(
                        "{name}: entry {k} {:?} component {c}: stored {}, regenerated {} (tolerance {DRIFT_ABS:e} + \
                         {DRIFT_REL:e}·|value|): the table drifted from the mathematics; regenerate with `cargo \
                         xtask tables` if the change is intended",
                        self.header.multi_index(k),
                        show(g),
                        show(w)
                    ));
                }
            }
        }
        Ok(worst)
    }
}

/// `k` distinct entry indices of a table of `count` entries, seeded: the first and last entry, then uniform random
/// ones (sorted).
pub fn sample_indices(count: usize, k: usize, seed: u64) -> Vec<usize> {
    if k >= count {
        return (0..count).collect();
    }
    let mut rng = crate::rng::Pcg32::new(seed, 0x7ab1e);
    let mut set = std::collections::BTreeSet::new();
    set.insert(0);
    set.insert(count - 1);
    while set.len() < k.max(2).min(count) {
        set.insert((rng.next_f64() * count as f64) as usize % count);
    }
    set.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every entry of `t` against the regenerator, with zero tolerance (same machine, same calls).
    fn all_entries_equal(r: &Regenerator, t: &Table) {
        assert_eq!(r.header(), &t.header);
        let n = t.header.entry_count() as usize;
        for k in 0..n {
            assert_eq!(r.entry(k), t.entry(k), "{} entry {k} {:?}", t.header.name, t.header.multi_index(k));
        }
    }

    #[test]
    fn product_regenerator_matches_library_and_threads() {
        let (pd, na) = (1, 6);
        let lib = lobes::product_table_sized(pd, na);
        let threaded = product_generate(pd, na);
        let flat: Vec<f32> = lib.data.iter().flatten().copied().collect();
        assert_eq!(threaded.f32_values(), flat, "threaded generation differs from lobes::product_table_sized");
        all_entries_equal(&Regenerator::product(pd, na), &threaded);
    }

    #[test]
    fn hemisphere_regenerator_matches_library() {
        let lib = lobes::hemisphere_table_sized(2, 9);
        let flat: Vec<f32> = lib.data.iter().flatten().copied().collect();
        all_entries_equal(&Regenerator::hemisphere(2, 9), &Table::from_f32(hemisphere_header(2, 9), &flat));
    }

    #[test]
    fn cap_regenerator_matches_library() {
        let lib = lobes::cap_table_sized(17);
        all_entries_equal(&Regenerator::cap(17), &Table::from_f32(cap_header(17), &lib.k));
    }

    #[test]
    fn isg_regenerator_matches_library() {
        // 5 samples, 1 slice per octave: every entry, bit for bit (the same calls on both paths).
        let lut = IsgLut::generate(5, ISG_LUT_OCTAVE0, ISG_LUT_OCTAVES, 1);
        let t = Table::from_f32(isg_header(5, 1), &lut.values);
        assert_eq!(t.header.axes[0].sample(3), isg_lut_slice_lambda(ISG_LUT_OCTAVE0, 1, 3));
        all_entries_equal(&Regenerator::isg(5, 1), &t);
    }

    #[test]
    fn sh_regenerators_match_library() {
        for n in [2, 4] {
            for table in [MathTable::ShCircleLog(n), MathTable::ShOl(n), MathTable::ShGamma(n)] {
                all_entries_equal(&Regenerator::new(table), &table.generate());
            }
        }
    }

    #[test]
    fn sample_indices_are_distinct_and_in_range() {
        let s = sample_indices(1000, 50, 3);
        assert_eq!(s.len(), 50);
        assert!(s.windows(2).all(|w| w[0] < w[1]) && s[0] == 0 && s[49] == 999);
        assert_eq!(sample_indices(1000, 50, 3), s, "seeded");
        assert_ne!(sample_indices(1000, 50, 4), s);
        assert_eq!(sample_indices(5, 50, 3), vec![0, 1, 2, 3, 4]);
    }

    #[test]
    fn names_are_unique_and_round_trip() {
        let all = all_tables();
        for t in &all {
            assert_eq!(MathTable::from_name(&t.name()), Some(*t));
        }
        let mut names: Vec<String> = all.iter().map(|t| t.name()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), all.len());
    }

    #[test]
    fn check_reports_drift_and_version() {
        let table = MathTable::ShCircleLog(3);
        let r = Regenerator::new(table);
        let mut t = table.generate();
        let idx: Vec<usize> = (0..t.header.entry_count() as usize).collect();
        assert_eq!(r.check(&t, &idx), Ok(0.0));
        // A change of 1e-3 in one value is drift.
        let k = 4 * 100 + 1;
        t.words[k] = (f32::from_bits(t.words[k]) + 1e-3).to_bits();
        let e = r.check(&t, &idx).unwrap_err();
        assert!(e.contains("entry 100") && e.contains("drifted"), "{e}");
        // A stale generator version.
        let mut t = table.generate();
        t.header.generator_version = 0;
        assert!(r.check(&t, &idx).unwrap_err().contains("generator version"));
    }
}
