//! A simulated cloth (plain data, no Vulkan) and the f64 CPU twin of the GPU simulation
//! (`engine::passes::cloth`, shaders-glsl/cloth).
//!
//! The cloth is one instance of a rectangular grid mesh ([`grid_mesh`]: `columns × rows` vertices, row
//! major). It is simulated in world space by position-based dynamics with XPBD compliance (Macklin et al.
//! 2016, without the λ accumulation: one Jacobi projection per iteration), in fixed substeps:
//!
//! 1. **predict**: `v ← v·max(0, 1 − damping·dt) + g·dt`, `p ← x + v·dt`, pushed out of the colliders;
//! 2. **solve**, `iterations` Jacobi sweeps (ping-pong buffers): every vertex gathers the corrections of
//!    its distance constraints to its 12 neighbours, structural (±1 in i or j), shear (diagonals) and
//!    bending (±2 in i or j), `Δp_i = −C/(w_i + w_j + α̃) · n` with `C = |p_i − p_j| − L`, unit masses and
//!    `α̃ = compliance / dt²` (XPBD Eq. 18 with λ = 0), and moves by `relaxation · ΣΔp / count`
//!    (averaged Jacobi, Macklin et al. 2014 §4.2); no float atomics, so the result is deterministic;
//! 3. **finish**: pushed out of the colliders again, `v ← (p − x)/dt`, friction on the contact's
//!    tangential velocity and no velocity into the collider, `x ← p`.
//!
//! Colliders are the scene's blocker spheres (world space, the frame's pose) grown by `thickness`, and the
//! ground plane `y = ground` (if any), in that order. Rest lengths are the distances of the rest positions
//! ([`rest_positions`]: the grid under its instance transform, each vertex lifted by a seeded jitter of at
//! most `jitter` so that the folds are not perfectly symmetric; deterministic for a seed).

use glam::{DVec3, Mat4, Vec3};

/// The 12 neighbours of a vertex, in gather order: `(di, dj, kind)` with kind 0 structural, 1 shear,
/// 2 bending. The GPU kernel (shaders-glsl/cloth/solve.comp) uses the same table in the same order.
pub const NEIGHBOURS: [(i32, i32, usize); 12] = [
    (1, 0, 0),
    (-1, 0, 0),
    (0, 1, 0),
    (0, -1, 0),
    (1, 1, 1),
    (-1, -1, 1),
    (1, -1, 1),
    (-1, 1, 1),
    (2, 0, 2),
    (-2, 0, 2),
    (0, 2, 2),
    (0, -2, 2),
];

/// Simulation parameters (SI-like units: metres, seconds, unit vertex masses).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClothParams {
    /// Fixed substep (s).
    pub substep: f32,
    /// Jacobi iterations per substep.
    pub iterations: u32,
    /// Over-relaxation ω of the averaged Jacobi step (1 ≤ ω < 2).
    pub relaxation: f32,
    pub gravity: Vec3,
    /// Linear velocity damping (1/s).
    pub damping: f32,
    /// XPBD compliance of the structural, shear and bending constraints.
    pub compliance: [f32; 3],
    /// Collision margin around the spheres and above the ground (m).
    pub thickness: f32,
    /// Fraction of the tangential velocity removed per substep in contact.
    pub friction: f32,
    /// Height of the ground plane (`None`: no ground).
    pub ground: Option<f32>,
    /// Quads per side of the patch that one generated blocker sphere bounds (0: no spheres).
    pub sphere_patch: u32,
    pub seed: u64,
    /// Largest vertical offset of the seeded rest jitter (m).
    pub jitter: f32,
}

impl Default for ClothParams {
    fn default() -> Self {
        Self {
            substep: 1.0 / 240.0,
            iterations: 8,
            relaxation: 1.5,
            gravity: Vec3::new(0.0, -9.81, 0.0),
            damping: 0.5,
            compliance: [0.0, 1e-6, 1e-4],
            thickness: 0.01,
            friction: 0.3,
            ground: Some(0.0),
            sphere_patch: 4,
            seed: 1,
            jitter: 1e-3,
        }
    }
}

/// Most substeps one frame runs; a larger jump in time catches up over the following frames.
pub const MAX_SUBSTEPS_PER_FRAME: u64 = 1024;

/// Most Jacobi iterations per substep (each is one dispatch).
pub const MAX_ITERATIONS: u32 = 64;

/// A simulated cloth: mesh `mesh` (a [`grid_mesh`] of `columns × rows` vertices) of the scene's only
/// instance of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Cloth {
    pub mesh: usize,
    pub columns: u32,
    pub rows: u32,
    pub params: ClothParams,
}

impl Cloth {
    pub fn vertex_count(&self) -> usize {
        self.columns as usize * self.rows as usize
    }

    /// Generated blocker spheres along each axis: one per `sphere_patch × sphere_patch` quads.
    pub fn sphere_grid(&self) -> (u32, u32) {
        let k = self.params.sphere_patch;
        if k == 0 {
            return (0, 0);
        }
        ((self.columns - 1).div_ceil(k), (self.rows - 1).div_ceil(k))
    }

    pub fn sphere_count(&self) -> u32 {
        let (a, b) = self.sphere_grid();
        a * b
    }

    /// Substeps from t = 0 to `t` seconds: the floor of t / substep with a slack of a thousandth of a substep,
    /// for times and substeps rounded to f32 (1.5 s / (1/240 s in f32) is 359.99998).
    pub fn substeps_at(&self, t: f64) -> u64 {
        if t.is_nan() || t <= 0.0 {
            return 0;
        }
        (t / self.params.substep as f64 + 1e-3).floor() as u64
    }

    /// Check the sizes and parameters against the mesh (`vertex_count`): a clear message, never a crash.
    pub fn validate(&self, vertex_count: usize) -> Result<(), String> {
        let p = &self.params;
        if self.columns < 3 || self.rows < 3 {
            return Err(format!("cloth: a grid of {} × {} vertices (at least 3 × 3)", self.columns, self.rows));
        }
        if self.vertex_count() != vertex_count {
            return Err(format!("cloth: {} × {} vertices, its mesh has {vertex_count}", self.columns, self.rows));
        }
        let finite = p.substep.is_finite()
            && p.relaxation.is_finite()
            && p.gravity.is_finite()
            && p.damping.is_finite()
            && p.compliance.iter().all(|c| c.is_finite() && *c >= 0.0)
            && p.thickness.is_finite()
            && p.friction.is_finite()
            && p.jitter.is_finite()
            && p.ground.is_none_or(f32::is_finite);
        if !finite {
            return Err("cloth: non-finite or negative parameter".into());
        }
        if !(p.substep > 0.0 && p.substep <= 0.1) {
            return Err(format!("cloth: substep {} s (0 < dt ≤ 0.1)", p.substep));
        }
        if p.iterations == 0 || p.iterations > MAX_ITERATIONS {
            return Err(format!("cloth: {} iterations (1..={MAX_ITERATIONS})", p.iterations));
        }
        if !(1.0..2.0).contains(&p.relaxation) {
            return Err(format!("cloth: relaxation {} (1 ≤ ω < 2)", p.relaxation));
        }
        if p.damping < 0.0 || p.thickness < 0.0 || p.jitter < 0.0 || !(0.0..=1.0).contains(&p.friction) {
            return Err("cloth: damping, thickness and jitter must be ≥ 0, friction in [0, 1]".into());
        }
        Ok(())
    }
}

/// The cloth's instance in `scene` (the only one of its mesh, which must be a grid of its size) and the
/// index of its first vertex in the scene's vertex buffers (instances in order, as the upload lays them out).
pub fn cloth_instance(scene: &super::Scene, cloth: &Cloth) -> Result<(usize, u32), String> {
    let mesh = scene.meshes.get(cloth.mesh).ok_or_else(|| format!("cloth: no mesh {}", cloth.mesh))?;
    cloth.validate(mesh.positions.len())?;
    let mut found = None;
    let mut base = 0u32;
    for (i, inst) in scene.instances.iter().enumerate() {
        if inst.mesh == cloth.mesh {
            if found.is_some() {
                return Err(format!("cloth: mesh '{}' has more than one instance", mesh.name));
            }
            found = Some((i, base));
        }
        base += scene.meshes.get(inst.mesh).map_or(0, |m| m.positions.len() as u32);
    }
    found.ok_or_else(|| format!("cloth: mesh '{}' has no instance", mesh.name))
}

/// A flat grid of `columns × rows` vertices over `[−half_x, half_x] × [−half_z, half_z]` at y = 0, row
/// major (vertex `j·columns + i` at column i, row j), normals +Y, two triangles per quad.
pub fn grid_mesh(columns: u32, rows: u32, half_x: f32, half_z: f32) -> super::Mesh {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for j in 0..rows {
        for i in 0..columns {
            let x = -half_x + 2.0 * half_x * i as f32 / (columns - 1) as f32;
            let z = -half_z + 2.0 * half_z * j as f32 / (rows - 1) as f32;
            positions.push(Vec3::new(x, 0.0, z));
        }
    }
    for j in 0..rows - 1 {
        for i in 0..columns - 1 {
            let a = j * columns + i;
            let (b, c, d) = (a + 1, a + columns, a + columns + 1);
            indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    let normals = vec![Vec3::Y; positions.len()];
    super::Mesh { name: "cloth".into(), positions, normals, indices, material_offsets: Vec::new() }
}

/// SplitMix64 (Steele et al. 2014): the seeded jitter's hash.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The simulation's rest (and start) positions in world space: the mesh under `transform`, vertex k lifted
/// by `jitter · (2u − 1)` with u ∈ [0, 1) from the seed and k.
pub fn rest_positions(cloth: &Cloth, positions: &[Vec3], transform: Mat4) -> Vec<Vec3> {
    let p = &cloth.params;
    positions
        .iter()
        .enumerate()
        .map(|(k, &x)| {
            let u = (splitmix64(p.seed ^ splitmix64(k as u64)) >> 11) as f32 / (1u64 << 53) as f32;
            transform.transform_point3(x) + Vec3::Y * (p.jitter * (2.0 * u - 1.0))
        })
        .collect()
}

/// The CPU twin of the GPU simulation, in f64 (the same steps in the same order; see the module docs).
#[derive(Clone, Debug)]
pub struct ClothSim {
    pub columns: usize,
    pub rows: usize,
    pub params: ClothParams,
    pub rest: Vec<DVec3>,
    pub x: Vec<DVec3>,
    pub v: Vec<DVec3>,
}

impl ClothSim {
    pub fn new(cloth: &Cloth, rest: &[Vec3]) -> Self {
        let rest: Vec<DVec3> = rest.iter().map(|p| p.as_dvec3()).collect();
        Self {
            columns: cloth.columns as usize,
            rows: cloth.rows as usize,
            params: cloth.params,
            x: rest.clone(),
            v: vec![DVec3::ZERO; rest.len()],
            rest,
        }
    }

    /// Push `p` out of the colliders (spheres `(centre, radius)` grown by the thickness, in order, then the
    /// ground); returns the contact normal of the last one that moved it.
    pub fn collide(&self, mut p: DVec3, spheres: &[(DVec3, f64)]) -> (DVec3, Option<DVec3>) {
        let h = self.params.thickness as f64;
        let mut normal = None;
        for &(c, r) in spheres {
            let d = p - c;
            let dist = d.length();
            let reach = r + h;
            if dist < reach {
                let n = if dist > 1e-12 { d / dist } else { DVec3::Y };
                p = c + n * reach;
                normal = Some(n);
            }
        }
        if let Some(g) = self.params.ground {
            let floor = g as f64 + h;
            if p.y < floor {
                p.y = floor;
                normal = Some(DVec3::Y);
            }
        }
        (p, normal)
    }

    /// One Jacobi sweep over every vertex: `out[i] = p[i] + ω ΣΔp / count`.
    pub fn jacobi(&self, p: &[DVec3]) -> Vec<DVec3> {
        let dt = self.params.substep as f64;
        let alpha = self.params.compliance.map(|c| c as f64 / (dt * dt));
        let (nx, nz) = (self.columns as i32, self.rows as i32);
        let mut out = Vec::with_capacity(p.len());
        for k in 0..p.len() {
            let (i, j) = (k as i32 % nx, k as i32 / nx);
            let mut delta = DVec3::ZERO;
            let mut count = 0u32;
            for &(di, dj, kind) in &NEIGHBOURS {
                let (a, b) = (i + di, j + dj);
                if a < 0 || b < 0 || a >= nx || b >= nz {
                    continue;
                }
                let m = (b * nx + a) as usize;
                let d = p[k] - p[m];
                let len = d.length();
                count += 1;
                if len > 1e-9 {
                    let c = len - (self.rest[k] - self.rest[m]).length();
                    delta -= d * (c / ((2.0 + alpha[kind]) * len));
                }
            }
            out.push(p[k] + delta * (self.params.relaxation as f64 / count.max(1) as f64));
        }
        out
    }

    /// One substep against the colliders.
    pub fn substep(&mut self, spheres: &[(DVec3, f64)]) {
        let prm = self.params;
        let dt = prm.substep as f64;
        let keep = (1.0 - prm.damping as f64 * dt).max(0.0);
        let g = prm.gravity.as_dvec3();
        let mut p: Vec<DVec3> =
            (0..self.x.len()).map(|k| self.collide(self.x[k] + (self.v[k] * keep + g * dt) * dt, spheres).0).collect();
        for _ in 0..prm.iterations {
            p = self.jacobi(&p);
        }
        for (k, &pk) in p.iter().enumerate() {
            let (q, normal) = self.collide(pk, spheres);
            let mut v = (q - self.x[k]) / dt;
            if let Some(n) = normal {
                let vn = v.dot(n);
                let tangential = v - n * vn;
                v = tangential * (1.0 - prm.friction as f64) + n * vn.max(0.0);
            }
            self.x[k] = q;
            self.v[k] = v;
        }
    }
}

/// The bounding sphere of the generated blocker sphere of patch `(a, b)`: the vertices of quads
/// `[a·k, (a+1)·k] × [b·k, (b+1)·k]` (clamped to the grid; neighbouring patches share their edge vertices),
/// centre of their bounding box, radius the farthest one plus the collision thickness. The twin of
/// shaders-glsl/cloth/spheres.comp.
pub fn patch_sphere(cloth: &Cloth, x: &[DVec3], a: u32, b: u32) -> (DVec3, f64) {
    let k = cloth.params.sphere_patch;
    let (i0, j0) = (a * k, b * k);
    let (i1, j1) = ((i0 + k).min(cloth.columns - 1), (j0 + k).min(cloth.rows - 1));
    let at = |i: u32, j: u32| x[(j * cloth.columns + i) as usize];
    let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
    for j in j0..=j1 {
        for i in i0..=i1 {
            lo = lo.min(at(i, j));
            hi = hi.max(at(i, j));
        }
    }
    let c = 0.5 * (lo + hi);
    let mut r: f64 = 0.0;
    for j in j0..=j1 {
        for i in i0..=i1 {
            r = r.max((at(i, j) - c).length());
        }
    }
    (c, r + cloth.params.thickness as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloth(n: u32) -> (Cloth, Vec<Vec3>) {
        let c = Cloth { mesh: 0, columns: n, rows: n, params: ClothParams::default() };
        let m = grid_mesh(n, n, 0.5, 0.5);
        let rest = rest_positions(&c, &m.positions, Mat4::from_translation(Vec3::new(0.0, 0.6, 0.0)));
        (c, rest)
    }

    #[test]
    fn a_falling_cloth_lands_on_a_sphere_and_keeps_its_length() {
        let (c, rest) = cloth(16);
        let mut sim = ClothSim::new(&c, &rest);
        let ball = [(DVec3::new(0.0, 0.25, 0.0), 0.25)];
        for _ in 0..480 {
            sim.substep(&ball);
        }
        let h = c.params.thickness as f64;
        for p in &sim.x {
            assert!(p.is_finite());
            assert!(p.y >= h - 1e-9, "below the ground: {p}");
            assert!((*p - ball[0].0).length() >= ball[0].1 + h - 1e-9, "inside the ball: {p}");
        }
        // Draped: the middle rests on the ball's top, the edges hang lower.
        let mid = sim.x[8 * 16 + 8];
        assert!((mid.y - 0.51).abs() < 0.02, "middle at {mid}");
        // Structural edges stretch by a few per cent at most.
        let mut worst: f64 = 0.0;
        for k in 0..sim.x.len() - 1 {
            if (k + 1) % 16 != 0 {
                let l0 = (sim.rest[k] - sim.rest[k + 1]).length();
                worst = worst.max((sim.x[k] - sim.x[k + 1]).length() / l0 - 1.0);
            }
        }
        assert!(worst < 0.1, "stretch {worst}");
    }

    #[test]
    fn the_seed_changes_only_the_jitter() {
        let (c, a) = cloth(8);
        let b = rest_positions(&c, &grid_mesh(8, 8, 0.5, 0.5).positions, Mat4::from_translation(Vec3::Y * 0.6));
        assert_eq!(a, b);
        let c2 = Cloth { params: ClothParams { seed: 2, ..c.params }, ..c.clone() };
        let d = rest_positions(&c2, &grid_mesh(8, 8, 0.5, 0.5).positions, Mat4::from_translation(Vec3::Y * 0.6));
        assert_ne!(a, d);
        assert!(a.iter().zip(&d).all(|(p, q)| (*p - *q).length() <= 2.0 * c.params.jitter));
    }

    #[test]
    fn bad_parameters_are_named() {
        let (c, _) = cloth(8);
        assert!(c.validate(64).is_ok());
        assert!(c.validate(63).unwrap_err().contains("mesh has 63"));
        let bad = Cloth { params: ClothParams { iterations: 0, ..c.params }, ..c.clone() };
        assert!(bad.validate(64).unwrap_err().contains("iterations"));
        let bad = Cloth { params: ClothParams { substep: f32::NAN, ..c.params }, ..c.clone() };
        assert!(bad.validate(64).unwrap_err().contains("non-finite"));
        let bad = Cloth { params: ClothParams { relaxation: 2.0, ..c.params }, ..c };
        assert!(bad.validate(64).unwrap_err().contains("relaxation"));
    }
}
