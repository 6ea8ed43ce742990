//! GPU (f32 GLSL, shaders-glsl/common/planes.glsl) vs CPU (f64, engine_blockers::plane) twins through
//! shaders-glsl/tests/planes_twin.comp (layout documented there: 29 floats in, 15 out per case): the
//! self-shadowing rule, the ray hit, a rectangle's edge normals and the projected (cosine-weighted) solid
//! angle of the blocked directions for a random receiver normal, for random half-spaces and rectangles
//! (tilted, both sides, receivers near and far). The CPU twin sees the f32 record
//! (engine::resources::blockers::GpuBlockerPlane) widened to f64.
//!
//! Cases within f32 rounding of a decision (the receiver at ε from the plane, a ray grazing the plane
//! or crossing the rectangle's edge) may decide either way and are left out of the decision checks;
//! every other decision must agree, and hit distances to 1e-4 relative (the f32 quotient of two
//! differences of O(10) quantities), edge normals to 1e-4, projected solid angles to 1e-4 (of π).

use engine::gpu::testing::{run_f32_kernel, test_gpu};
use engine::math::rng::Pcg32;
use engine::resources::blockers::GpuBlockerPlane;
use engine::scene::blockers::BlockerPlane;
use glam::DVec3;

const IN: usize = 29;
const OUT: usize = 15;

fn v(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

fn f32v(a: [f32; 4]) -> DVec3 {
    DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

/// The plane the GPU sees: the record's f32 values.
fn from_record(r: &GpuBlockerPlane) -> BlockerPlane {
    BlockerPlane {
        normal: f32v(r.plane),
        offset: r.plane[3] as f64,
        rect: (r.center[3] > 0.5).then(|| (f32v(r.center), f32v(r.half_u), f32v(r.half_v))),
        epsilon: r.half_u[3] as f64,
    }
}

#[test]
fn planes_glsl_matches_its_f64_twin() {
    let mut rng = Pcg32::new(7, 3);
    let mut cases = Vec::new();
    for k in 0..4096 {
        let m = v(rng.unit_vector());
        let c = DVec3::new(rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0));
        let plane = if k % 2 == 0 {
            BlockerPlane::half_space(c, m)
        } else {
            let t = m.any_orthonormal_vector();
            let (u, w) = (t * rng.uniform(0.1, 3.0), m.cross(t) * rng.uniform(0.1, 3.0));
            BlockerPlane::rectangle(c, u, w)
        };
        let record = GpuBlockerPlane::from_plane(&plane);
        // Receivers at heights from 1e-6 to 3 on either side, offset along the plane.
        let h = (if rng.next_f64() < 0.5 { -1.0 } else { 1.0 }) * 10f64.powf(rng.uniform(-6.0, 0.5));
        let along = m.any_orthonormal_vector() * rng.uniform(-4.0, 4.0);
        let p = c + m * h + along;
        let o = p + m * 1e-4 * h.signum();
        // Half the rays head towards the plane, so that many hit it.
        let d = v(rng.unit_vector());
        let d = if rng.next_f64() < 0.5 { (d - m * (2.0 * h.signum())).normalize() } else { d };
        let t_max = if rng.next_f64() < 0.3 { rng.uniform(0.1, 5.0) } else { 1e30 };
        let n = v(rng.unit_vector());
        cases.push((record, p, o, d, t_max, n));
    }
    let mut input = Vec::with_capacity(cases.len() * IN);
    for (r, p, o, d, t_max, n) in &cases {
        let f = |x: DVec3| [x.x as f32, x.y as f32, x.z as f32];
        input.extend_from_slice(&r.plane);
        input.extend_from_slice(&r.center);
        input.extend_from_slice(&r.half_u);
        input.extend_from_slice(&r.half_v);
        input.extend_from_slice(&f(*p));
        input.extend_from_slice(&f(*o));
        input.extend_from_slice(&f(*d));
        input.push(*t_max as f32);
        input.extend_from_slice(&f(*n));
    }
    let gpu = test_gpu().expect("GPU");
    let out =
        run_f32_kernel(&gpu, "tests/planes_twin.comp", &input, cases.len() * OUT, cases.len() as u32).expect("kernel");
    gpu.shutdown().expect("clean teardown");
    assert!(out.iter().all(|x| x.is_finite()), "a non-finite output");
    let (mut decided, mut hits, mut worst_t, mut worst_e, mut worst_o) = (0, 0, 0.0f64, 0.0f64, 0.0f64);
    for (k, (r, p, o, d, t_max, n)) in cases.iter().enumerate() {
        let pl = from_record(r);
        let w = &out[k * OUT..(k + 1) * OUT];
        // The f32-rounded inputs, as the shader read them.
        let r32 = |x: DVec3| DVec3::new(x.x as f32 as f64, x.y as f32 as f64, x.z as f32 as f64);
        let (p, o, d, t_max, n) = (r32(*p), r32(*o), r32(*d), *t_max as f32 as f64, r32(*n));
        let h = pl.height(p);
        if (h.abs() - pl.epsilon).abs() < 1e-5 * (1.0 + pl.offset.abs() + p.length()) {
            continue; // at the tolerance: either side is right in f32
        }
        assert_eq!(w[0] == 1.0, pl.blocks_receiver(p), "case {k}: the self-shadowing rule (height {h:e})");
        decided += 1;
        worst_o = worst_o.max((w[14] as f64 - pl.projected_solid_angle(p, n)).abs());
        if let Some(e) = pl.edge_normals(p) {
            for (j, e) in e.iter().enumerate() {
                let g = DVec3::new(w[2 + 3 * j] as f64, w[3 + 3 * j] as f64, w[4 + 3 * j] as f64);
                worst_e = worst_e.max((g - *e).length());
            }
        }
        // Hits: skip rays that graze the plane, end within rounding of the hit, or cross the edge.
        let md = pl.normal.dot(d);
        let t = (pl.offset - pl.normal.dot(o)) / md;
        let near_edge = pl.rect.is_some_and(|(c, u, v)| {
            let q = o + t * d - c;
            let s = (q.dot(u).abs() / u.length_squared(), q.dot(v).abs() / v.length_squared());
            (s.0 - 1.0).abs() < 1e-3 || (s.1 - 1.0).abs() < 1e-3
        });
        if md.abs() < 1e-3 || (t - t_max).abs() < 1e-4 * t.abs().max(1.0) || t.abs() < 1e-3 || near_edge {
            continue;
        }
        let want = pl.hit(p, o, d, t_max);
        let got = (w[1] >= 0.0).then_some(w[1] as f64);
        assert_eq!(got.is_some(), want.is_some(), "case {k}: hit {got:?} vs {want:?}");
        if let (Some(g), Some(x)) = (got, want) {
            worst_t = worst_t.max((g - x).abs() / x.max(1.0));
            hits += 1;
        }
    }
    eprintln!(
        "{decided} decided cases, {hits} hits: worst hit distance {worst_t:.2e} relative, worst edge normal \
         {worst_e:.2e}, worst projected solid angle {worst_o:.2e}"
    );
    assert!(decided > 3500 && hits > 500, "too few cases decided ({decided}) or hit ({hits})");
    assert!(worst_t < 1e-4, "hit distance {worst_t}");
    assert!(worst_e < 1e-4, "edge normal {worst_e}");
    assert!(worst_o < 1e-4 * std::f64::consts::PI, "projected solid angle {worst_o}");
}
