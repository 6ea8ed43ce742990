//! Variational sphere-set fitting (SHEXP §6.2, after Wang et al. 2006 "Variational sphere set
//! approximation for solid objects"), a k-means baseline, and their evaluation.
//!
//! The fit seeks `n_S` spheres that bound the sample points of the object T while minimizing the
//! outside volume `E = Σ_i V(S_i − T)` (SHEXP Eq. 35):
//!
//! 1. **Samples**: surface points (every mesh vertex and every triangle midpoint) and interior points
//!    (centres of a voxel grid whose generalized winding number is ≥ ½, so open meshes such as the
//!    Stanford bunny work). A neighbour graph links mesh edges, midpoints to their vertices, grid
//!    6-neighbours, and surface points to the grid cells around them.
//! 2. **Point clustering**: flood fill from the sphere centres. The paper pops a stack; we pop a
//!    priority queue keyed by the error increase (as in Cohen-Steiner et al.'s variational shape
//!    approximation, which Wang et al. follow), so regions grow in order of least cost and the result
//!    does not depend on push order. A popped point joins, among the clusters of its already-assigned
//!    neighbours, the one whose sphere (radius extended to reach the point) gains the least outside
//!    volume. Points unreachable in the graph (disconnected parts) join the cheapest cluster.
//! 3. **Sphere update**: each centre is moved to minimize `V(S_i − T)` with the radius constrained to
//!    bound its points, `r_i(P) = max_j ‖x_j − P‖` (Nelder–Mead; the paper uses Powell: both are
//!    derivative-free). A tiny volume term (10⁻³ of the sphere volume) breaks the tie between
//!    positions of spheres wholly inside T.
//! 4. **Teleportation** (Cohen-Steiner et al. 2004) when an iteration lowers E by less than
//!    `stall_ratio`: the cluster of maximal error is split at its farthest-apart pair of points and the
//!    cluster of maximal overlap (share of its volume inside other spheres) is deleted; kept only if E
//!    drops. A rejected split is not retried from the same state (the next-worst cluster is tried);
//!    the fit stops after four rejections in a row or `max_teleports` trials.
//!
//! During clustering the centres are fixed, so each cluster's outside volume as a function of radius
//! is tabulated once (a radial profile of shell outside-shares) and each candidate point costs one
//! O(1) lookup.
//!
//! `V(S − T)` during the fit is estimated with a fixed set of points uniform in the unit ball (the same
//! set for every sphere: common random numbers keep the objective smooth in the centre) looked up in a
//! grid of winding numbers with trilinear interpolation. The reported quality ([`evaluate`]) is
//! independent of that: seeded Monte Carlo with the winding-number tree at each sample.
//!
//! Everything is seeded by `FitSettings::seed` and single-threaded: the same mesh and settings give
//! bit-identical spheres.

use crate::geom::{nelder_mead3, Sphere};
use crate::mesh::{Mesh, WindingTree};
use crate::BlockerError;
use engine_math::rng::Pcg32;
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::f64::consts::PI;
use std::time::Instant;

/// Settings of [`fit_spheres`]. Stored in sphere files: a change triggers a refit in the cache.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitSettings {
    /// Number of spheres n_S.
    pub count: usize,
    /// Seed of every random choice (initial centres, ball samples).
    pub seed: u64,
    /// Interior sample grid: cells along the longest axis of the mesh bounds.
    pub grid_resolution: usize,
    /// Winding-number lookup grid for outside-volume estimates: cells along the longest axis.
    pub lookup_resolution: usize,
    /// Points per sphere in the outside-volume estimate during the fit.
    pub volume_samples: usize,
    /// Cluster/update iterations at most (teleport trials included).
    pub max_iterations: usize,
    /// Teleportations tried at most.
    pub max_teleports: usize,
    /// An iteration "stalls" when it lowers E by less than this fraction.
    pub stall_ratio: f64,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            count: 64,
            seed: 1,
            grid_resolution: 24,
            lookup_resolution: 48,
            volume_samples: 96,
            max_iterations: 40,
            max_teleports: 12,
            stall_ratio: 0.01,
        }
    }
}

impl FitSettings {
    pub fn validate(&self) -> Result<(), BlockerError> {
        let bad = |m: &str| Err(BlockerError::InvalidSettings(m.into()));
        if self.count == 0 {
            return Err(BlockerError::ZeroCount);
        }
        if !(2..=512).contains(&self.grid_resolution) {
            return bad("grid_resolution must be in 2..=512");
        }
        if !(2..=1024).contains(&self.lookup_resolution) {
            return bad("lookup_resolution must be in 2..=1024");
        }
        if !(8..=65536).contains(&self.volume_samples) {
            return bad("volume_samples must be in 8..=65536");
        }
        if !(self.stall_ratio >= 0.0 && self.stall_ratio < 1.0) {
            return bad("stall_ratio must be in [0, 1)");
        }
        Ok(())
    }
}

/// Progress report of [`fit_spheres`]: one per step of the set-up (`setup`: only `message` says anything; the
/// tree, the sample points and the inside grid take seconds on a mesh of millions of triangles), then one per
/// iteration.
#[derive(Clone, Debug, Default)]
pub struct FitProgress {
    /// A set-up step, not an iteration.
    pub setup: bool,
    pub iteration: usize,
    /// Current E (SHEXP Eq. 35, the sum over spheres, grid estimate).
    pub outside_sum: f64,
    pub teleports_tried: usize,
    pub teleports_accepted: usize,
    pub message: String,
}

/// Result of [`fit_spheres`].
#[derive(Clone, Debug)]
pub struct FitResult {
    pub spheres: Vec<Sphere>,
    /// Final E (SHEXP Eq. 35: Σ_i V(S_i − T)), grid estimate used by the fit.
    pub outside_sum: f64,
    pub iterations: usize,
    pub teleports_tried: usize,
    pub teleports_accepted: usize,
    pub surface_samples: usize,
    pub interior_samples: usize,
}

/// Winding numbers on a regular grid of corners, for O(1) inside lookups.
struct InsideField {
    lo: DVec3,
    h: f64,
    dims: [usize; 3],
    w: Vec<f32>,
}

impl InsideField {
    fn new(tree: &WindingTree, lo: DVec3, hi: DVec3, resolution: usize) -> Self {
        let h = (hi - lo).max_element().max(1e-300) / resolution as f64;
        // One cell of margin on each side so the interpolation reaches 0 outside the mesh.
        let lo = lo - DVec3::splat(h);
        let dims = ((hi - lo) / h).ceil().as_uvec3().to_array().map(|d| d as usize + 2);
        let mut w = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = lo + DVec3::new(i as f64, j as f64, k as f64) * h;
                    w.push(tree.winding_number(p) as f32);
                }
            }
        }
        Self { lo, h, dims, w }
    }

    /// 1 − clamp(w, 0, 1) by trilinear interpolation: 1 well outside, 0 inside, fractional within a
    /// cell of the surface (and near holes). Outside the grid: 1.
    fn outside(&self, p: DVec3) -> f64 {
        let g = (p - self.lo) / self.h;
        let [nx, ny, nz] = self.dims;
        if !(g.x >= 0.0 && g.y >= 0.0 && g.z >= 0.0)
            || g.x >= (nx - 1) as f64
            || g.y >= (ny - 1) as f64
            || g.z >= (nz - 1) as f64
        {
            return 1.0;
        }
        let (i, j, k) = (g.x as usize, g.y as usize, g.z as usize);
        let (fx, fy, fz) = (g.x - i as f64, g.y - j as f64, g.z - k as f64);
        let at = |di: usize, dj: usize, dk: usize| self.w[(k + dk) * nx * ny + (j + dj) * nx + i + di] as f64;
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let x00 = lerp(at(0, 0, 0), at(1, 0, 0), fx);
        let x10 = lerp(at(0, 1, 0), at(1, 1, 0), fx);
        let x01 = lerp(at(0, 0, 1), at(1, 0, 1), fx);
        let x11 = lerp(at(0, 1, 1), at(1, 1, 1), fx);
        let w = lerp(lerp(x00, x10, fy), lerp(x01, x11, fy), fz);
        1.0 - w.clamp(0.0, 1.0)
    }
}

fn ball_volume(r: f64) -> f64 {
    4.0 / 3.0 * PI * r * r * r
}

/// `count` points uniform in the unit ball (rejection from the cube), seeded.
fn unit_ball_points(count: usize, rng: &mut Pcg32) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let p = DVec3::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
        if p.length_squared() <= 1.0 {
            out.push(p);
        }
    }
    out
}

/// `n` nearly uniform unit vectors (Fibonacci / golden-angle spiral), deterministic.
fn fibonacci_sphere(n: usize) -> Vec<DVec3> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), z, r * phi.sin())
        })
        .collect()
}

/// The sample points of T and their neighbour graph (shared by the fit and the k-means baseline).
pub struct FitSamples {
    /// Surface points first (`surface_count`: vertices then triangle midpoints), then interior points.
    pub points: Vec<DVec3>,
    pub surface_count: usize,
    /// The object's volume as the interior samples see it: their count times the volume of a grid cell (0 for a
    /// surface without volume).
    pub interior_volume: f64,
    /// CSR neighbour lists.
    offsets: Vec<u32>,
    adjacency: Vec<u32>,
}

impl FitSamples {
    pub fn new(mesh: &Mesh, tree: &WindingTree, grid_resolution: usize) -> Self {
        let positions = mesh.positions();
        let nv = positions.len();
        let mut points: Vec<DVec3> = positions.to_vec();
        let mut edges: Vec<(u32, u32)> = Vec::new();
        for (t, tri) in mesh.triangles().iter().enumerate() {
            let id = (nv + t) as u32;
            let [a, b, c] = mesh.triangle(t);
            points.push((a + b + c) / 3.0);
            for e in 0..3 {
                edges.push((tri[e], tri[(e + 1) % 3]));
                edges.push((id, tri[e]));
            }
        }
        let surface_count = points.len();
        // Interior: cell centres of a grid over the bounds.
        let (lo, hi) = mesh.bounds().unwrap_or((DVec3::ZERO, DVec3::ZERO));
        let g = (hi - lo).max_element().max(1e-300) / grid_resolution as f64;
        let dims = ((hi - lo) / g).ceil().as_uvec3().to_array().map(|d| (d as usize).max(1));
        let cell_id = |i: usize, j: usize, k: usize| (k * dims[1] + j) * dims[0] + i;
        let mut grid_point = vec![u32::MAX; dims[0] * dims[1] * dims[2]];
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = lo + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * g;
                    if tree.inside(p) {
                        grid_point[cell_id(i, j, k)] = points.len() as u32;
                        points.push(p);
                    }
                }
            }
        }
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let a = grid_point[cell_id(i, j, k)];
                    if a == u32::MAX {
                        continue;
                    }
                    for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                        let (ii, jj, kk) = (i + di, j + dj, k + dk);
                        if ii < dims[0] && jj < dims[1] && kk < dims[2] {
                            let b = grid_point[cell_id(ii, jj, kk)];
                            if b != u32::MAX {
                                edges.push((a, b));
                            }
                        }
                    }
                }
            }
        }
        // Surface point ↔ the (up to 8) interior cell centres around it.
        for (s, point) in points.iter().enumerate().take(surface_count) {
            let q = (*point - lo) / g - 0.5;
            let base = q.floor();
            for corner in 0..8 {
                let c = base + DVec3::new((corner & 1) as f64, ((corner >> 1) & 1) as f64, (corner >> 2) as f64);
                if c.min_element() < 0.0 || c.x >= dims[0] as f64 || c.y >= dims[1] as f64 || c.z >= dims[2] as f64 {
                    continue;
                }
                let b = grid_point[cell_id(c.x as usize, c.y as usize, c.z as usize)];
                if b != u32::MAX {
                    edges.push((s as u32, b));
                }
            }
        }
        // Compressed neighbour lists, counted first and filled in place: one allocation, not one per point (a
        // 3-million-face mesh has 4.5 million surface points).
        let n = points.len();
        let mut offsets = vec![0u32; n + 1];
        for &(a, b) in edges.iter().filter(|(a, b)| a != b) {
            offsets[a as usize + 1] += 1;
            offsets[b as usize + 1] += 1;
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut adjacency = vec![0u32; offsets[n] as usize];
        for (a, b) in edges.into_iter().filter(|(a, b)| a != b) {
            adjacency[fill[a as usize] as usize] = b;
            fill[a as usize] += 1;
            adjacency[fill[b as usize] as usize] = a;
            fill[b as usize] += 1;
        }
        drop(fill);
        // Each list sorted and deduplicated, compacted towards the front.
        let mut write = 0usize;
        for p in 0..n {
            let (start, end) = (offsets[p] as usize, offsets[p + 1] as usize);
            adjacency[start..end].sort_unstable();
            offsets[p] = write as u32;
            let mut last = None;
            for k in start..end {
                let v = adjacency[k];
                if last != Some(v) {
                    adjacency[write] = v;
                    write += 1;
                    last = Some(v);
                }
            }
        }
        offsets[n] = write as u32;
        adjacency.truncate(write);
        adjacency.shrink_to_fit();
        let interior_volume = (points.len() - surface_count) as f64 * g * g * g;
        Self { points, surface_count, interior_volume, offsets, adjacency }
    }

    fn neighbors(&self, p: usize) -> &[u32] {
        &self.adjacency[self.offsets[p] as usize..self.offsets[p + 1] as usize]
    }

    /// Seeded farthest-point sampling: a random first point, then repeatedly the point farthest from
    /// all chosen ones. Spreads the initial centres (the paper picks them at random).
    fn farthest_points(&self, count: usize, rng: &mut Pcg32) -> Vec<DVec3> {
        let n = self.points.len();
        let first = (rng.next_u32() as usize) % n;
        let mut chosen = vec![self.points[first]];
        let mut dist: Vec<f64> = self.points.iter().map(|p| p.distance_squared(self.points[first])).collect();
        while chosen.len() < count {
            let far = (0..n).fold(0, |b, i| if dist[i] > dist[b] { i } else { b });
            let c = self.points[far];
            chosen.push(c);
            for (d, p) in dist.iter_mut().zip(&self.points) {
                *d = d.min(p.distance_squared(c));
            }
        }
        chosen
    }
}

/// The state of one clustering: spheres and their point sets.
#[derive(Clone)]
struct Clusters {
    centers: Vec<DVec3>,
    radii: Vec<f64>,
    outside: Vec<f64>,
    members: Vec<Vec<u32>>,
}

impl Clusters {
    fn total(&self) -> f64 {
        self.outside.iter().sum()
    }
}

struct Fitter<'a> {
    samples: &'a FitSamples,
    field: InsideField,
    ball: Vec<DVec3>,
    /// Fixed directions (Fibonacci sphere) for the radial profiles.
    directions: Vec<DVec3>,
    /// Largest useful radius: the diagonal of the lookup grid.
    max_radius: f64,
}

/// Outside volume of the balls around one fixed centre as a function of radius:
/// `V(ρ) = ∫₀^ρ 4π s² f(s) ds` with f(s) the outside share of the shell of radius s (fixed
/// directions), tabulated by the trapezoid rule. During clustering the centres are fixed and each
/// point costs one O(1) lookup here instead of a full ball estimate.
struct RadialProfile {
    dr: f64,
    cumulative: Vec<f64>,
}

impl RadialProfile {
    const SHELLS: usize = 128;

    fn volume(&self, r: f64) -> f64 {
        let x = r / self.dr;
        let last = self.cumulative.len() - 1;
        if x >= last as f64 {
            // Beyond the grid everything is outside: add the full shells.
            let r_last = last as f64 * self.dr;
            return self.cumulative[last] + ball_volume(r) - ball_volume(r_last);
        }
        let i = x as usize;
        let t = x - i as f64;
        self.cumulative[i] + (self.cumulative[i + 1] - self.cumulative[i]) * t
    }
}

impl Fitter<'_> {
    /// V(S − T) estimate for the sphere (c, r).
    fn outside_volume(&self, c: DVec3, r: f64) -> f64 {
        if r <= 0.0 {
            return 0.0;
        }
        let s: f64 = self.ball.iter().map(|u| self.field.outside(c + *u * r)).sum();
        ball_volume(r) * s / self.ball.len() as f64
    }

    fn profile(&self, c: DVec3) -> RadialProfile {
        let dr = self.max_radius / RadialProfile::SHELLS as f64;
        let shell = |s: f64| {
            let f = self.directions.iter().map(|d| self.field.outside(c + *d * s)).sum::<f64>();
            4.0 * PI * s * s * f / self.directions.len() as f64
        };
        let mut cumulative = Vec::with_capacity(RadialProfile::SHELLS + 1);
        cumulative.push(0.0);
        let mut prev = shell(0.0);
        for j in 1..=RadialProfile::SHELLS {
            let cur = shell(j as f64 * dr);
            cumulative.push(cumulative[j - 1] + 0.5 * dr * (prev + cur));
            prev = cur;
        }
        RadialProfile { dr, cumulative }
    }

    /// Step 2: flood-fill clustering from `centers`.
    fn cluster(&self, centers: &[DVec3]) -> Clusters {
        let pts = &self.samples.points;
        let n = pts.len();
        let k = centers.len();
        const NONE: u32 = u32::MAX;
        let mut assign = vec![NONE; n];
        let mut radii = vec![0.0; k];
        let profiles: Vec<RadialProfile> = centers.iter().map(|&c| self.profile(c)).collect();
        let cost = |i: usize, p: usize, radii: &[f64]| {
            let d = centers[i].distance(pts[p]);
            if d <= radii[i] {
                0.0
            } else {
                (profiles[i].volume(d) - profiles[i].volume(radii[i])).max(0.0)
            }
        };
        // Keys are non-negative f64: their bit patterns order like the values.
        let mut heap: BinaryHeap<Reverse<(u64, u32, u32)>> = BinaryHeap::new();
        let assign_point = |p: usize,
                            i: usize,
                            assign: &mut Vec<u32>,
                            radii: &mut Vec<f64>,
                            heap: &mut BinaryHeap<Reverse<(u64, u32, u32)>>| {
            assign[p] = i as u32;
            radii[i] = radii[i].max(centers[i].distance(pts[p]));
            for &q in self.samples.neighbors(p) {
                if assign[q as usize] == NONE {
                    let c = cost(i, q as usize, radii);
                    heap.push(Reverse((c.to_bits(), q, i as u32)));
                }
            }
        };
        // Seeds: the nearest free point to each centre (distinct even for duplicate centres).
        for (i, c) in centers.iter().enumerate() {
            let seed = (0..n).filter(|&p| assign[p] == NONE).fold(None, |b: Option<usize>, p| match b {
                Some(b) if pts[b].distance_squared(*c) <= pts[p].distance_squared(*c) => Some(b),
                _ => Some(p),
            });
            if let Some(p) = seed {
                assign_point(p, i, &mut assign, &mut radii, &mut heap);
            }
        }
        let mut next_unassigned = 0;
        loop {
            while let Some(Reverse((_, p, _))) = heap.pop() {
                let p = p as usize;
                if assign[p] != NONE {
                    continue;
                }
                let mut best = (f64::INFINITY, usize::MAX);
                for &q in self.samples.neighbors(p) {
                    let i = assign[q as usize];
                    if i != NONE {
                        let c = cost(i as usize, p, &radii);
                        if c < best.0 || (c == best.0 && (i as usize) < best.1) {
                            best = (c, i as usize);
                        }
                    }
                }
                assign_point(p, best.1, &mut assign, &mut radii, &mut heap);
            }
            // Points not reachable through the graph: attach to the cheapest cluster, then flood on.
            while next_unassigned < n && assign[next_unassigned] != NONE {
                next_unassigned += 1;
            }
            if next_unassigned == n {
                break;
            }
            let p = next_unassigned;
            let i = (0..k)
                .map(|i| (cost(i, p, &radii), i))
                .fold((f64::INFINITY, 0), |b, c| if c.0 < b.0 { c } else { b })
                .1;
            assign_point(p, i, &mut assign, &mut radii, &mut heap);
        }
        let mut members = vec![Vec::new(); k];
        for (p, &i) in assign.iter().enumerate() {
            members[i as usize].push(p as u32);
        }
        let outside = (0..k).map(|i| self.outside_volume(centers[i], radii[i])).collect();
        Clusters { centers: centers.to_vec(), radii, outside, members }
    }

    /// Step 3: move each centre to minimize its outside volume, radius bounding its points.
    fn update(&self, clusters: &mut Clusters) {
        let pts = &self.samples.points;
        for i in 0..clusters.centers.len() {
            let members = &clusters.members[i];
            if members.is_empty() {
                // Cannot happen after `cluster` (each cluster gets a seed while points remain, and
                // count ≤ points is checked), but keep an empty cluster harmless: zero radius.
                clusters.radii[i] = 0.0;
                clusters.outside[i] = 0.0;
                continue;
            }
            let bound = |c: DVec3| members.iter().map(|&p| c.distance(pts[p as usize])).fold(0.0, f64::max);
            let objective = |c: DVec3| {
                let r = bound(c);
                self.outside_volume(c, r) + 1e-3 * ball_volume(r)
            };
            let start = clusters.centers[i];
            let r0 = bound(start);
            let (best, _) = nelder_mead3(objective, start, 0.2 * r0.max(1e-12), 90);
            let c = if objective(best) <= objective(start) { best } else { start };
            clusters.centers[i] = c;
            clusters.radii[i] = bound(c);
            clusters.outside[i] = self.outside_volume(c, clusters.radii[i]);
        }
    }

    fn step(&self, centers: &[DVec3]) -> Clusters {
        let mut c = self.cluster(centers);
        self.update(&mut c);
        c
    }

    /// Step 4: split the worst cluster, delete the most overlapped one. Returns the new centres.
    /// Clusters in `skip` (splits already rejected for this state) are not split again.
    fn teleport(&self, state: &Clusters, skip: &[usize]) -> Option<(usize, Vec<DVec3>)> {
        let k = state.centers.len();
        if k < 2 {
            return None;
        }
        let pts = &self.samples.points;
        let worst = (0..k)
            .filter(|i| !skip.contains(i) && state.members[*i].len() >= 2)
            .map(|i| (state.outside[i], i))
            .fold(None, |b: Option<(f64, usize)>, c| match b {
                Some(b) if b.0 >= c.0 => Some(b),
                _ => Some(c),
            })?
            .1;
        // Overlap: share of each sphere's volume inside any other sphere (same ball samples).
        let overlap = |j: usize| {
            let inside = self
                .ball
                .iter()
                .filter(|u| {
                    let x = state.centers[j] + **u * state.radii[j];
                    (0..k).any(|o| o != j && state.centers[o].distance(x) <= state.radii[o])
                })
                .count();
            inside as f64 / self.ball.len() as f64
        };
        let victim = (0..k)
            .filter(|&j| j != worst)
            .map(|j| (overlap(j), j))
            .fold((f64::NEG_INFINITY, usize::MAX), |b, c| if c.0 > b.0 { c } else { b })
            .1;
        let members = &state.members[worst];
        let farthest_from = |c: DVec3| {
            members.iter().map(|&p| pts[p as usize]).fold(c, |b, p| {
                if p.distance_squared(c) > b.distance_squared(c) {
                    p
                } else {
                    b
                }
            })
        };
        let p1 = farthest_from(state.centers[worst]);
        let p2 = farthest_from(p1);
        let mut centers = state.centers.clone();
        centers[worst] = p1;
        centers[victim] = p2;
        Some((worst, centers))
    }
}

/// Fits `settings.count` spheres to `mesh` (see the module documentation for the algorithm).
/// `progress` receives one report per iteration.
pub fn fit_spheres(
    mesh: &Mesh,
    settings: &FitSettings,
    progress: &mut dyn FnMut(&FitProgress),
) -> Result<FitResult, BlockerError> {
    fit_spheres_within(mesh, settings, MAX_FIT_TRIANGLES, progress)
}

/// [`fit_spheres`] with a mesh of more than `max_triangles` fitted through its simplification.
fn fit_spheres_within(
    mesh: &Mesh,
    settings: &FitSettings,
    max_triangles: usize,
    progress: &mut dyn FnMut(&FitProgress),
) -> Result<FitResult, BlockerError> {
    settings.validate()?;
    let t0 = Instant::now();
    let triangles = mesh.triangles().len();
    if triangles > max_triangles {
        if let Some((coarse, cell, map)) = mesh.simplified(max_triangles) {
            if settings.count <= coarse.positions().len() + coarse.triangles().len() {
                setup(
                    progress,
                    format!(
                        "set-up: {triangles} triangles are more than the {max_triangles} the fit works on: fitting \
                         a simplification of {} triangles (vertices merged within {cell:.3e}; {:.1} s), then growing \
                         the spheres to bound every vertex and triangle midpoint of the mesh",
                        coarse.triangles().len(),
                        t0.elapsed().as_secs_f64()
                    ),
                );
                let mut fit = fit_spheres_within(&coarse, settings, max_triangles, progress)?;
                bound_every_sample(mesh, &coarse, &map, &mut fit.spheres);
                return Ok(fit);
            }
        }
    }
    setup(progress, format!("set-up: the winding-number tree over {triangles} triangles..."));
    let tree = WindingTree::new(mesh);
    setup(progress, format!("set-up: sample points and their neighbours ({:.1} s)...", t0.elapsed().as_secs_f64()));
    let samples = FitSamples::new(mesh, &tree, settings.grid_resolution);
    setup(
        progress,
        format!(
            "set-up: {} surface and {} interior sample points; the inside grid ({:.1} s)...",
            samples.surface_count,
            samples.points.len() - samples.surface_count,
            t0.elapsed().as_secs_f64()
        ),
    );
    fit_spheres_with_samples(mesh, &tree, &samples, settings, progress)
}

/// The most triangles the fit works on directly. Each iteration clusters every sample point (every vertex and
/// triangle midpoint) and moves every sphere over its points, so its cost grows with the points: a 3-million-face
/// mesh (4.5 million points) took minutes per iteration. A larger mesh is fitted through a simplification of at
/// most this many triangles ([`Mesh::simplified`]) and the spheres then grown to bound every vertex and midpoint
/// of the mesh itself (docs/lab-notes.md has the fit's outside volume on a 262k-triangle mesh, direct and
/// through the simplification).
pub const MAX_FIT_TRIANGLES: usize = 65536;

/// Grow `spheres` (fitted to `coarse`, which every sample point of `coarse` lies in) so that every vertex and
/// triangle midpoint of `mesh` lies in one: each coarse vertex picks the sphere that holds it deepest, and each
/// point of `mesh` grows the sphere of the coarse vertex standing for it (`map`; for a midpoint, its first
/// vertex's) to reach it. Linear in the points of `mesh` (a search over every sphere per point would cost
/// points × spheres).
fn bound_every_sample(mesh: &Mesh, coarse: &Mesh, map: &[u32], spheres: &mut [Sphere]) {
    let owner: Vec<usize> = coarse
        .positions()
        .iter()
        .map(|&p| {
            (0..spheres.len())
                .min_by(|&a, &b| {
                    let depth = |s: &Sphere| p.distance(s.center) - s.radius;
                    depth(&spheres[a]).total_cmp(&depth(&spheres[b]))
                })
                .unwrap_or(0)
        })
        .collect();
    let mut reach = |p: DVec3, rep: u32| {
        let s = &mut spheres[owner[rep as usize]];
        s.radius = s.radius.max(p.distance(s.center));
    };
    for (v, &p) in mesh.positions().iter().enumerate() {
        reach(p, map[v]);
    }
    for (t, tri) in mesh.triangles().iter().enumerate() {
        let [a, b, c] = mesh.triangle(t);
        reach((a + b + c) / 3.0, map[tri[0] as usize]);
    }
}

/// The share of the object's volume below which the fit's outside volume (SHEXP Eq. 35, the sum form) counts as
/// negligible: a stalled fit stops there instead of teleporting. Far below what any fit of a real model reaches
/// (the bunny with 32 spheres: ~30 %); reached by thousands of spheres on a simple solid.
pub const NEGLIGIBLE_OUTSIDE: f64 = 1e-3;

/// One set-up step's progress line.
fn setup(progress: &mut dyn FnMut(&FitProgress), message: String) {
    progress(&FitProgress { setup: true, message, ..Default::default() });
}

fn fit_spheres_with_samples(
    mesh: &Mesh,
    tree: &WindingTree,
    samples: &FitSamples,
    settings: &FitSettings,
    progress: &mut dyn FnMut(&FitProgress),
) -> Result<FitResult, BlockerError> {
    settings.validate()?;
    if settings.count > samples.points.len() {
        return Err(BlockerError::CountTooLarge { count: settings.count, samples: samples.points.len() });
    }
    let (lo, hi) = mesh.bounds().ok_or(BlockerError::EmptyMesh)?;
    let mut rng = Pcg32::new(settings.seed, 0x5f17);
    let field = InsideField::new(tree, lo, hi, settings.lookup_resolution);
    let max_radius =
        (field.h * (DVec3::new(field.dims[0] as f64, field.dims[1] as f64, field.dims[2] as f64) - 1.0)).length();
    let fitter = Fitter {
        samples,
        field,
        ball: unit_ball_points(settings.volume_samples, &mut rng),
        directions: fibonacci_sphere(64),
        max_radius,
    };
    let init = samples.farthest_points(settings.count, &mut rng);
    let mut best = fitter.step(&init);
    let mut best_e = best.total();
    let (mut tried, mut accepted) = (0, 0);
    let mut rejected_splits: Vec<usize> = Vec::new();
    let mut iteration = 0;
    let mut report = |iteration: usize, e: f64, tried: usize, accepted: usize, message: String| {
        progress(&FitProgress {
            setup: false,
            iteration,
            outside_sum: e,
            teleports_tried: tried,
            teleports_accepted: accepted,
            message,
        })
    };
    report(0, best_e, 0, 0, "initial clustering".into());
    while iteration < settings.max_iterations {
        iteration += 1;
        let next = fitter.step(&best.centers);
        let e = next.total();
        let improved_enough = e < best_e * (1.0 - settings.stall_ratio);
        if e < best_e {
            best = next;
            best_e = e;
            rejected_splits.clear();
        }
        if improved_enough {
            report(iteration, best_e, tried, accepted, "lloyd step".into());
            continue;
        }
        // Stalled. Once the outside volume is a negligible share of the object's, teleports (two iterations each)
        // buy nothing the shadows can show (4096 spheres on a cube: 12 teleports for E from 0.034 % of the
        // cube's volume to 0.013 %; docs/lab-notes.md).
        if best_e < NEGLIGIBLE_OUTSIDE * samples.interior_volume {
            report(
                iteration,
                best_e,
                tried,
                accepted,
                format!(
                    "converged: the outside volume is {:.3} % of the object's, below {} %",
                    100.0 * best_e / samples.interior_volume,
                    100.0 * NEGLIGIBLE_OUTSIDE
                ),
            );
            break;
        }
        // Try a teleportation.
        if tried >= settings.max_teleports || rejected_splits.len() >= 4 {
            report(iteration, best_e, tried, accepted, "converged".into());
            break;
        }
        let Some((split, centers)) = fitter.teleport(&best, &rejected_splits) else {
            report(iteration, best_e, tried, accepted, "converged (nothing to teleport)".into());
            break;
        };
        tried += 1;
        let mut trial = fitter.step(&centers);
        trial = fitter.step(&trial.centers);
        iteration += 1;
        let e = trial.total();
        if e < best_e {
            let gain = 1.0 - e / best_e;
            best = trial;
            best_e = e;
            accepted += 1;
            rejected_splits.clear();
            report(iteration, best_e, tried, accepted, format!("teleport accepted ({:.1} % lower)", 100.0 * gain));
        } else {
            rejected_splits.push(split);
            report(iteration, best_e, tried, accepted, format!("teleport rejected (E would be {e:.4})"));
        }
    }
    // A surface without volume (a sheet, an open strip, anything thinner than the interior grid) has no interior
    // samples: a cluster of one surface point got radius 0, and with as many spheres as sample points every
    // sphere did, so the mesh blocked nothing (issue 38: a skinned strip's shadow vanished under `shexp`'s
    // clusters, and the other techniques showed only the bounding spheres of their BVH nodes).
    let floor =
        if samples.points.len() == samples.surface_count { sheet_radius(mesh, samples.surface_count) } else { 0.0 };
    let spheres = best.centers.iter().zip(&best.radii).map(|(&c, &r)| Sphere::new(c, r.max(floor))).collect();
    Ok(FitResult {
        spheres,
        outside_sum: best_e,
        iterations: iteration,
        teleports_tried: tried,
        teleports_accepted: accepted,
        surface_samples: samples.surface_count,
        interior_samples: samples.points.len() - samples.surface_count,
    })
}

/// The smallest radius of a sphere fitted to a surface without volume: each of its `surface_samples` points stands
/// for 1/`surface_samples` of the mesh's area A, and a sphere of radius √(A / (π · surface_samples)) centred on
/// the surface covers a disc of that area. (The spheres of a volume are bounded by its interior samples instead.)
pub fn sheet_radius(mesh: &Mesh, surface_samples: usize) -> f64 {
    let area: f64 = (0..mesh.triangles().len()).map(|t| mesh.triangle_area(t)).sum();
    (area / (PI * surface_samples.max(1) as f64)).sqrt()
}

/// The sample points of `mesh` the fit with `settings` works on (surface, interior): at most that many spheres
/// can be fitted to it (each sphere's cluster holds at least one point). The interior grid is built only when the
/// surface points alone (every vertex and triangle midpoint) are fewer than `settings.count`.
pub fn sample_points(mesh: &Mesh, settings: &FitSettings) -> (usize, usize) {
    let surface = mesh.positions().len() + mesh.triangles().len();
    if settings.count <= surface {
        return (surface, 0);
    }
    let tree = WindingTree::new(mesh);
    let samples = FitSamples::new(mesh, &tree, settings.grid_resolution);
    (samples.surface_count, samples.points.len() - samples.surface_count)
}

/// Baseline: k-means (Lloyd) on the same sample points from the same farthest-point initial centres,
/// each sphere centred at its cluster mean with the radius of its farthest point.
pub fn fit_kmeans(mesh: &Mesh, settings: &FitSettings) -> Result<Vec<Sphere>, BlockerError> {
    settings.validate()?;
    let tree = WindingTree::new(mesh);
    let samples = FitSamples::new(mesh, &tree, settings.grid_resolution);
    kmeans_with_samples(&samples, settings)
}

fn kmeans_with_samples(samples: &FitSamples, settings: &FitSettings) -> Result<Vec<Sphere>, BlockerError> {
    let pts = &samples.points;
    if settings.count > pts.len() {
        return Err(BlockerError::CountTooLarge { count: settings.count, samples: pts.len() });
    }
    let mut rng = Pcg32::new(settings.seed, 0x5f17);
    let _ = unit_ball_points(settings.volume_samples, &mut rng); // same stream position as the fit
    let mut centers = samples.farthest_points(settings.count, &mut rng);
    let k = centers.len();
    let mut assign = vec![0usize; pts.len()];
    for _ in 0..settings.max_iterations.max(1) {
        for (a, p) in assign.iter_mut().zip(pts) {
            *a = (0..k).fold(
                0,
                |b, i| {
                    if p.distance_squared(centers[i]) < p.distance_squared(centers[b]) {
                        i
                    } else {
                        b
                    }
                },
            );
        }
        let mut sum = vec![DVec3::ZERO; k];
        let mut count = vec![0usize; k];
        for (&a, p) in assign.iter().zip(pts) {
            sum[a] += *p;
            count[a] += 1;
        }
        let mut moved = false;
        for i in 0..k {
            let c = if count[i] > 0 {
                sum[i] / count[i] as f64
            } else {
                // Empty cluster: reseed at the point farthest from its centre.
                let far = (0..pts.len()).fold(0, |b, p| {
                    let d = |q: usize| pts[q].distance_squared(centers[assign[q]]);
                    if d(p) > d(b) {
                        p
                    } else {
                        b
                    }
                });
                pts[far]
            };
            moved |= c != centers[i];
            centers[i] = c;
        }
        if !moved {
            break;
        }
    }
    for (a, p) in assign.iter_mut().zip(pts) {
        *a = (0..k).fold(0, |b, i| if p.distance_squared(centers[i]) < p.distance_squared(centers[b]) { i } else { b });
    }
    let mut radii = vec![0.0f64; k];
    for (&a, p) in assign.iter().zip(pts) {
        radii[a] = radii[a].max(p.distance(centers[a]));
    }
    Ok(centers.into_iter().zip(radii).map(|(c, r)| Sphere::new(c, r)).collect())
}

/// Quality of a sphere set against its mesh, by seeded Monte Carlo with exact-to-tree winding numbers.
#[derive(Clone, Debug)]
pub struct FitQuality {
    /// Volume of the union of the spheres outside T.
    pub outside_volume: f64,
    /// Volume of T (winding number ≥ ½).
    pub object_volume: f64,
    /// E = outside volume of the union / object volume (what leaks shadow).
    pub e_union: f64,
    /// SHEXP Eq. 35 normalized: Σ_i V(S_i − T) / V(T) (overlaps outside T counted per sphere).
    pub e_sum: f64,
    /// One standard error of `e_union` from the Monte Carlo sampling (object volume error included).
    pub e_union_std_error: f64,
    /// Share of area-uniform surface samples inside some sphere.
    pub surface_coverage: f64,
    pub samples: usize,
}

/// Evaluates `spheres` against `mesh` with `samples` Monte Carlo samples for each volume and for the
/// surface coverage. Object volume: uniform points in the mesh bounds. Union outside volume: a sphere
/// chosen with probability ∝ its volume, a uniform point in it, weighted 1/m with m the number of
/// spheres containing the point (an unbiased estimator of the union's volume).
pub fn evaluate(mesh: &Mesh, spheres: &[Sphere], samples: usize, seed: u64) -> Result<FitQuality, BlockerError> {
    if spheres.is_empty() {
        return Err(BlockerError::NoSpheres);
    }
    for (i, s) in spheres.iter().enumerate() {
        s.validate(i)?;
    }
    let samples = samples.max(16);
    let tree = WindingTree::new(mesh);
    let (lo, hi) = mesh.bounds().ok_or(BlockerError::EmptyMesh)?;
    let mut rng = Pcg32::new(seed, 0xe7a1);
    let box_volume = (hi - lo).x * (hi - lo).y * (hi - lo).z;
    let inside_count = (0..samples)
        .filter(|_| {
            let p = DVec3::new(rng.uniform(lo.x, hi.x), rng.uniform(lo.y, hi.y), rng.uniform(lo.z, hi.z));
            tree.inside(p)
        })
        .count();
    let f = inside_count as f64 / samples as f64;
    let object_volume = box_volume * f;
    let volumes: Vec<f64> = spheres.iter().map(|s| ball_volume(s.radius)).collect();
    let total: f64 = volumes.iter().sum();
    let (mut acc_u, mut acc_u2, mut acc_s) = (0.0, 0.0, 0.0);
    for _ in 0..samples {
        let mut t = rng.uniform(0.0, total);
        let mut i = 0;
        while i + 1 < volumes.len() && t >= volumes[i] {
            t -= volumes[i];
            i += 1;
        }
        let s = &spheres[i];
        let u = loop {
            let u = DVec3::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
            if u.length_squared() <= 1.0 {
                break u;
            }
        };
        let x = s.center + u * s.radius;
        if !tree.inside(x) {
            let m = spheres.iter().filter(|o| o.contains_point(x)).count().max(1) as f64;
            acc_u += 1.0 / m;
            acc_u2 += 1.0 / (m * m);
            acc_s += 1.0;
        }
    }
    let n = samples as f64;
    let mean_u = acc_u / n;
    let var_u = (acc_u2 / n - mean_u * mean_u).max(0.0) / n;
    let outside_volume = total * mean_u;
    let object_volume_safe = object_volume.max(1e-300);
    let rel_obj = ((1.0 - f) / (f.max(1e-300) * n)).sqrt();
    let rel_out = if mean_u > 0.0 { var_u.sqrt() / mean_u } else { 0.0 };
    let e_union = outside_volume / object_volume_safe;
    // Surface coverage: area-uniform points.
    let areas: Vec<f64> = (0..mesh.triangles().len()).map(|t| mesh.triangle_area(t)).collect();
    let area_total: f64 = areas.iter().sum();
    let mut covered = 0;
    for _ in 0..samples {
        let mut t = rng.uniform(0.0, area_total);
        let mut i = 0;
        while i + 1 < areas.len() && t >= areas[i] {
            t -= areas[i];
            i += 1;
        }
        let [a, b, c] = mesh.triangle(i);
        let (mut u, mut v) = (rng.next_f64(), rng.next_f64());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let x = a + (b - a) * u + (c - a) * v;
        if spheres.iter().any(|s| s.contains_point(x)) {
            covered += 1;
        }
    }
    Ok(FitQuality {
        outside_volume,
        object_volume,
        e_union,
        e_sum: total * acc_s / n / object_volume_safe,
        e_union_std_error: e_union * (rel_obj * rel_obj + rel_out * rel_out).sqrt(),
        surface_coverage: covered as f64 / samples as f64,
        samples,
    })
}

/// One row of [`compare_with_baseline`].
#[derive(Clone, Debug)]
pub struct ComparisonRow {
    pub count: usize,
    pub method: &'static str,
    pub quality: FitQuality,
    /// Wall-clock seconds of the fit (samples and grids shared between methods are not counted).
    pub fit_seconds: f64,
}

/// Fits `counts` spheres with the variational fit and the k-means baseline (same samples, seeds and
/// settings otherwise) and evaluates both with [`evaluate`] (`eval_samples`, seed `settings.seed`).
pub fn compare_with_baseline(
    mesh: &Mesh,
    counts: &[usize],
    settings: &FitSettings,
    eval_samples: usize,
) -> Result<Vec<ComparisonRow>, BlockerError> {
    settings.validate()?;
    let tree = WindingTree::new(mesh);
    let samples = FitSamples::new(mesh, &tree, settings.grid_resolution);
    let mut rows = Vec::new();
    for &count in counts {
        let s = FitSettings { count, ..settings.clone() };
        let t0 = Instant::now();
        let fit = fit_spheres_with_samples(mesh, &tree, &samples, &s, &mut |_| {})?;
        let t_fit = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let km = kmeans_with_samples(&samples, &s)?;
        let t_km = t0.elapsed().as_secs_f64();
        for (method, spheres, secs) in [("variational", &fit.spheres, t_fit), ("k-means", &km, t_km)] {
            rows.push(ComparisonRow {
                count,
                method,
                quality: evaluate(mesh, spheres, eval_samples, settings.seed)?,
                fit_seconds: secs,
            });
        }
    }
    Ok(rows)
}

/// The comparison as a Markdown table.
pub fn comparison_markdown(rows: &[ComparisonRow]) -> String {
    let mut s = String::from(
        "| spheres | method | E (union) | ± 1σ | E (Eq. 35 sum) | surface covered | fit s |\n|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        s += &format!(
            "| {} | {} | {:.4} | {:.4} | {:.4} | {:.2} % | {:.2} |\n",
            r.count,
            r.method,
            r.quality.e_union,
            r.quality.e_union_std_error,
            r.quality.e_sum,
            100.0 * r.quality.surface_coverage,
            r.fit_seconds
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{box_mesh, uv_sphere};
    use std::path::Path;

    fn quick(count: usize) -> FitSettings {
        FitSettings {
            count,
            grid_resolution: 10,
            lookup_resolution: 20,
            volume_samples: 48,
            max_iterations: 12,
            max_teleports: 4,
            ..FitSettings::default()
        }
    }

    fn assert_vertices_inside(mesh: &Mesh, spheres: &[Sphere]) {
        for (i, v) in mesh.positions().iter().enumerate() {
            // Epsilon 0: each radius is the maximum of the very distances tested here (same
            // `DVec3::distance` expression), so containment is exact in floating point.
            assert!(spheres.iter().any(|s| s.center.distance(*v) <= s.radius), "vertex {i} {v:?} outside every sphere");
        }
    }

    /// A mesh above the fit's triangle budget is fitted through its simplification, and the
    /// spheres still bound every vertex and triangle midpoint of the mesh itself, with an outside volume near the
    /// direct fit's. The test's budget (4000 triangles, so that it runs in seconds) makes a far coarser stand-in
    /// than the real one: 0.043 against 0.027 of the object's volume here; at full scale (262k triangles, the
    /// 65536 budget) both gave 0.2155 (docs/lab-notes.md).
    #[test]
    fn large_meshes_are_fitted_through_a_simplification_and_stay_bounded() {
        let mesh = crate::mesh::uv_sphere(DVec3::new(0.2, 0.1, -0.3), 1.0, 60, 80);
        let limit = 4000;
        assert!(mesh.triangles().len() > 2 * limit);
        let (coarse, cell, map) = mesh.simplified(limit).unwrap();
        assert!(
            coarse.triangles().len() <= limit && coarse.triangles().len() > limit / 4,
            "{}",
            coarse.triangles().len()
        );
        for (v, p) in mesh.positions().iter().enumerate() {
            assert!(p.distance(coarse.positions()[map[v] as usize]) <= cell, "vertex {v} far from its stand-in");
        }
        let settings = quick(12);
        let mut lines = Vec::new();
        let fit = fit_spheres_within(&mesh, &settings, limit, &mut |p| lines.push(p.message.clone())).unwrap();
        assert!(lines[0].contains("fitting a simplification"), "{lines:?}");
        assert_vertices_inside(&mesh, &fit.spheres);
        for t in 0..mesh.triangles().len() {
            let [a, b, c] = mesh.triangle(t);
            let m = (a + b + c) / 3.0;
            assert!(fit.spheres.iter().any(|s| s.center.distance(m) <= s.radius), "midpoint {t} outside");
        }
        let direct = fit_spheres(&mesh, &settings, &mut |_| {}).unwrap();
        let (e_simplified, e_direct) = (
            evaluate(&mesh, &fit.spheres, 20000, 3).unwrap().e_union,
            evaluate(&mesh, &direct.spheres, 20000, 3).unwrap().e_union,
        );
        eprintln!("outside volume / object volume: {e_simplified:.4} simplified, {e_direct:.4} direct");
        assert!(e_simplified < 1.25 * e_direct + 0.02, "{e_simplified} vs {e_direct}");
    }

    /// A stalled fit whose outside volume is a negligible share of the object's (below 0.1 %) stops instead of
    /// teleporting (figures at full scale, 4096 spheres on a cube, in docs/lab-notes.md), and a fit above the
    /// threshold goes on teleporting.
    #[test]
    fn a_fit_stops_once_its_outside_volume_is_negligible() {
        let cube = crate::mesh::box_mesh(DVec3::splat(-1.0), DVec3::ONE);
        let settings = FitSettings { grid_resolution: 8, ..quick(256) };
        let mut last = String::new();
        let fit = fit_spheres(&cube, &settings, &mut |p| last = p.message.clone()).unwrap();
        assert!(last.starts_with("converged: the outside volume is"), "{last}");
        assert_eq!(fit.teleports_tried, 0);
        let e = evaluate(&cube, &fit.spheres, 20000, 5).unwrap().e_union;
        assert!(e < 3.0 * NEGLIGIBLE_OUTSIDE, "{e}");
        // Few spheres: far above the threshold, the fit teleports as before.
        let mut messages = Vec::new();
        fit_spheres(&cube, &quick(6), &mut |p| messages.push(p.message.clone())).unwrap();
        assert!(!messages.iter().any(|m| m.contains("outside volume is")), "{messages:?}");
    }

    #[test]
    fn bunny_with_holes_is_bounded() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/meshes/bunny.obj");
        let mesh = Mesh::load_obj(&path).unwrap();
        let fit = fit_spheres(&mesh, &quick(16), &mut |_| {}).unwrap();
        assert_eq!(fit.spheres.len(), 16);
        // The open base must not break the inside test: a real interior is found.
        assert!(fit.interior_samples > 50, "interior samples {}", fit.interior_samples);
        assert_vertices_inside(&mesh, &fit.spheres);
        let q = evaluate(&mesh, &fit.spheres, 4000, 1).unwrap();
        // Vertices and midpoints are bounded exactly; points between them can poke out of a sphere
        // by less than a triangle's size: the full-quality fit measures ~98 % coverage; 90 % is a
        // floor that a broken bound (e.g. a missed cluster) would fail.
        assert!(q.surface_coverage > 0.9, "coverage {}", q.surface_coverage);
        assert!(q.e_union.is_finite() && q.e_union > 0.0);
        let km = fit_kmeans(&mesh, &quick(16)).unwrap();
        assert_vertices_inside(&mesh, &km);
    }

    #[test]
    fn outside_volume_falls_as_count_grows() {
        // An elongated box: one sphere wastes most of its volume, many small ones hug the faces.
        let mesh = box_mesh(DVec3::ZERO, DVec3::new(4.0, 1.0, 1.0));
        let mut last = f64::INFINITY;
        for count in [1, 4, 16] {
            let fit = fit_spheres(&mesh, &quick(count), &mut |_| {}).unwrap();
            assert_vertices_inside(&mesh, &fit.spheres);
            let q = evaluate(&mesh, &fit.spheres, 6000, 7).unwrap();
            // Steps of 4× in count change E by far more than the ~3 % Monte Carlo error (6000
            // samples), so a strict decrease by 3 standard errors is required.
            assert!(q.e_union + 3.0 * q.e_union_std_error < last, "count {count}: E {} after {last}", q.e_union);
            last = q.e_union;
        }
        // A single bounding sphere of a 4×1×1 box: its radius is at least half the diagonal
        // √18/2, so E ≥ (4/3 π (√18/2)³ − 4) / 4 ≈ 8.99.
        assert!(last < 8.99);
    }

    #[test]
    fn evaluate_matches_closed_form_for_a_sphere_in_a_sphere() {
        // T = ball of radius 1 (fine UV sphere), S = concentric ball of radius 1.5: outside volume
        // 4/3 π (1.5³ − 1), E = 1.5³ − 1 = 2.375 (minus the polygonization's volume deficit).
        let mesh = uv_sphere(DVec3::ZERO, 1.0, 48, 96);
        let q = evaluate(&mesh, &[Sphere::new(DVec3::ZERO, 1.5)], 20000, 3).unwrap();
        // The 48×96 UV sphere has ~0.2 % less volume than the ball; Monte Carlo error ~1 %:
        // 4 standard errors plus the deficit.
        assert!(
            (q.e_union - 2.375).abs() < 4.0 * q.e_union_std_error + 0.02,
            "{} ± {}",
            q.e_union,
            q.e_union_std_error
        );
        assert!((q.object_volume - 4.0 / 3.0 * PI).abs() < 0.05 * 4.0);
        assert_eq!(q.surface_coverage, 1.0);
        // Two identical spheres: the union is unchanged, Eq. 35's sum doubles.
        let s = Sphere::new(DVec3::ZERO, 1.5);
        let q2 = evaluate(&mesh, &[s, s], 20000, 3).unwrap();
        assert!((q2.e_union - q.e_union).abs() < 4.0 * q.e_union_std_error);
        assert!((q2.e_sum - 2.0 * q2.e_union).abs() < 1e-12 * q2.e_sum);
    }

    #[test]
    fn deterministic_and_seeded() {
        let mesh = uv_sphere(DVec3::ZERO, 1.0, 8, 12);
        let a = fit_spheres(&mesh, &quick(6), &mut |_| {}).unwrap();
        let b = fit_spheres(&mesh, &quick(6), &mut |_| {}).unwrap();
        assert_eq!(a.spheres, b.spheres);
        let c = fit_spheres(&mesh, &FitSettings { seed: 99, ..quick(6) }, &mut |_| {}).unwrap();
        assert_ne!(a.spheres, c.spheres);
    }

    #[test]
    fn bad_input_gives_errors() {
        let mesh = uv_sphere(DVec3::ZERO, 1.0, 4, 6);
        assert!(matches!(fit_spheres(&mesh, &quick(0), &mut |_| {}), Err(BlockerError::ZeroCount)));
        assert!(matches!(
            fit_spheres(&mesh, &quick(100_000), &mut |_| {}),
            Err(BlockerError::CountTooLarge { count: 100_000, .. })
        ));
        assert!(matches!(fit_kmeans(&mesh, &quick(100_000)), Err(BlockerError::CountTooLarge { .. })));
        let bad = FitSettings { stall_ratio: f64::NAN, ..quick(2) };
        assert!(matches!(fit_spheres(&mesh, &bad, &mut |_| {}), Err(BlockerError::InvalidSettings(_))));
        let bad = FitSettings { grid_resolution: 0, ..quick(2) };
        assert!(matches!(fit_spheres(&mesh, &bad, &mut |_| {}), Err(BlockerError::InvalidSettings(_))));
        assert!(matches!(evaluate(&mesh, &[], 100, 1), Err(BlockerError::NoSpheres)));
        let nan = Sphere::new(DVec3::new(f64::NAN, 0.0, 0.0), 1.0);
        assert!(matches!(evaluate(&mesh, &[nan], 100, 1), Err(BlockerError::InvalidSphere { index: 0, .. })));
        // Count equal to the number of samples: legal, every sphere gets a point (radius 0 allowed).
        let tiny = box_mesh(DVec3::ZERO, DVec3::ONE);
        let samples = FitSamples::new(&tiny, &WindingTree::new(&tiny), 2).points.len();
        let fit = fit_spheres(&tiny, &FitSettings { grid_resolution: 2, ..quick(samples) }, &mut |_| {}).unwrap();
        assert_eq!(fit.spheres.len(), samples);
        assert_vertices_inside(&tiny, &fit.spheres);
        // Duplicate vertices (coincident points) are harmless.
        let mut pos = tiny.positions().to_vec();
        pos.extend_from_slice(tiny.positions());
        let dup = Mesh::new(pos, tiny.triangles().to_vec()).unwrap();
        let fit = fit_spheres(&dup, &quick(4), &mut |_| {}).unwrap();
        assert_vertices_inside(&dup, &fit.spheres);
    }

    #[test]
    fn radial_profile_matches_ball_estimate() {
        // The clustering's radial profile and the update's ball estimate measure the same V(S − T):
        // compare them on the unit ball T for concentric and offset spheres.
        let mesh = uv_sphere(DVec3::ZERO, 1.0, 24, 48);
        let tree = WindingTree::new(&mesh);
        let samples = FitSamples::new(&mesh, &tree, 8);
        let (lo, hi) = mesh.bounds().unwrap();
        let field = InsideField::new(&tree, lo, hi, 32);
        let max_radius = 10.0;
        let mut rng = Pcg32::new(1, 1);
        let f = Fitter {
            samples: &samples,
            field,
            ball: unit_ball_points(4096, &mut rng),
            directions: fibonacci_sphere(256),
            max_radius,
        };
        for (c, r) in [(DVec3::ZERO, 1.5), (DVec3::new(0.5, 0.2, 0.0), 1.2), (DVec3::new(2.0, 0.0, 0.0), 0.8)] {
            let exact_concentric = if c == DVec3::ZERO { Some(4.0 / 3.0 * PI * (r * r * r - 1.0)) } else { None };
            let a = f.profile(c).volume(r);
            let b = f.outside_volume(c, r);
            // Ball estimate with 4096 points: ~1.5 % relative noise; the profile's trapezoid rule
            // with 128 shells and the grid's one-cell blur at the surface: ~1 %. 5 % binds both.
            assert!((a - b).abs() < 0.05 * b.max(0.1), "c={c:?} r={r}: profile {a} ball {b}");
            if let Some(e) = exact_concentric {
                assert!((a - e).abs() < 0.05 * e, "profile {a} exact {e}");
            }
        }
    }
}
