//! A triangle BVH for ray visibility in the Monte Carlo reference (`shade/reference`): a binned SAH
//! builder (Wald 2007, "On fast construction of SAH-based bounding volume hierarchies") over
//! world-space triangles, a flat node array with adjacent children, and CPU traversal (closest
//! and any hit) that the GLSL twin (`shaders-glsl/shade/reference/trace.glsl`) mirrors and the
//! tests compare with brute force.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// SAH bins per axis.
const BINS: usize = 16;
/// Leaves never hold more triangles than this (SAH may stop earlier).
pub const MAX_LEAF: usize = 8;
/// SAH cost of one node traversal relative to one triangle test.
const TRAVERSAL_COST: f32 = 1.0;

/// One node, std430 (`struct TriNode` in trace.glsl). Internal nodes: `count == 0`, children at
/// `first` and `first + 1`. Leaves: triangles `first .. first + count` of [`TriangleBvh::triangles`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct TriNode {
    pub lo: [f32; 3],
    pub first: u32,
    pub hi: [f32; 3],
    pub count: u32,
}

/// One triangle in leaf order, std430 (`struct Tri`: three `vec4`, w unused).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuTriangle {
    pub v0: [f32; 4],
    pub v1: [f32; 4],
    pub v2: [f32; 4],
}

#[derive(Clone, Copy)]
struct Aabb {
    lo: Vec3,
    hi: Vec3,
}

impl Aabb {
    const EMPTY: Self = Self { lo: Vec3::splat(f32::INFINITY), hi: Vec3::splat(f32::NEG_INFINITY) };
    fn grow(&mut self, p: Vec3) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }
    fn merge(&mut self, o: &Aabb) {
        self.lo = self.lo.min(o.lo);
        self.hi = self.hi.max(o.hi);
    }
    fn area(&self) -> f32 {
        let d = self.hi - self.lo;
        if d.x < 0.0 {
            return 0.0;
        }
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }
}

/// A built BVH: nodes (root 0) and triangles in leaf order.
#[derive(Clone, Debug, Default)]
pub struct TriangleBvh {
    pub nodes: Vec<TriNode>,
    pub triangles: Vec<GpuTriangle>,
}

/// A ray hit: distance along the (unit) direction and the triangle's index in leaf order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub triangle: usize,
}

/// Ray/triangle (Möller–Trumbore); `t` in (t_min, t_max).
pub fn intersect_triangle(o: Vec3, d: Vec3, tri: [Vec3; 3], t_min: f32, t_max: f32) -> Option<f32> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - tri[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > t_min && t < t_max).then_some(t)
}

/// 1/d with zero components replaced by ±1e-20 first, so the slab test never computes 0·∞.
pub fn safe_recip(d: Vec3) -> Vec3 {
    let f = |x: f32| if x.abs() < 1e-20 { 1e-20f32.copysign(x) } else { x };
    Vec3::new(f(d.x), f(d.y), f(d.z)).recip()
}

fn slab(o: Vec3, inv_d: Vec3, n: &TriNode, t_max: f32) -> bool {
    let t0 = (Vec3::from(n.lo) - o) * inv_d;
    let t1 = (Vec3::from(n.hi) - o) * inv_d;
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element().min(t_max);
    near <= far
}

impl TriangleBvh {
    /// Build over `triangles` (world space). Degenerate input (no triangles) gives an empty BVH
    /// whose traversal finds nothing.
    pub fn build(triangles: &[[Vec3; 3]]) -> Self {
        let n = triangles.len();
        if n == 0 {
            return Self::default();
        }
        let bounds: Vec<Aabb> = triangles
            .iter()
            .map(|t| {
                let mut b = Aabb::EMPTY;
                t.iter().for_each(|p| b.grow(*p));
                b
            })
            .collect();
        let centroids: Vec<Vec3> = bounds.iter().map(|b| 0.5 * (b.lo + b.hi)).collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut nodes = vec![TriNode::default()];
        // (node, first, count) still to split.
        let mut stack = vec![(0usize, 0usize, n)];
        while let Some((node, first, count)) = stack.pop() {
            let idx = &mut order[first..first + count];
            let mut nb = Aabb::EMPTY;
            let mut cb = Aabb::EMPTY;
            for &i in idx.iter() {
                nb.merge(&bounds[i as usize]);
                cb.grow(centroids[i as usize]);
            }
            nodes[node].lo = nb.lo.to_array();
            nodes[node].hi = nb.hi.to_array();
            let split = if count <= 2 { None } else { best_split(idx, &bounds, &centroids, &cb, &nb, count) };
            let mid = match split {
                Some((axis, bin, _)) => {
                    let lo = cb.lo[axis];
                    let scale = BINS as f32 / (cb.hi[axis] - cb.lo[axis]);
                    let bin_of = |i: u32| (((centroids[i as usize][axis] - lo) * scale) as usize).min(BINS - 1);
                    partition(idx, |i| bin_of(i) <= bin)
                }
                None if count > MAX_LEAF => {
                    // All centroids in one bin (or SAH prefers a leaf that is too big): split by
                    // count along the widest centroid axis so leaves stay small.
                    let axis = (cb.hi - cb.lo).max_position();
                    idx.sort_by(|a, b| centroids[*a as usize][axis].total_cmp(&centroids[*b as usize][axis]));
                    count / 2
                }
                None => 0,
            };
            if mid == 0 || mid == count {
                nodes[node].first = first as u32;
                nodes[node].count = count as u32;
                continue;
            }
            let left = nodes.len();
            nodes.push(TriNode::default());
            nodes.push(TriNode::default());
            nodes[node].first = left as u32;
            nodes[node].count = 0;
            stack.push((left, first, mid));
            stack.push((left + 1, first + mid, count - mid));
        }
        let tris = order
            .iter()
            .map(|&i| {
                let t = &triangles[i as usize];
                GpuTriangle {
                    v0: t[0].extend(0.0).to_array(),
                    v1: t[1].extend(0.0).to_array(),
                    v2: t[2].extend(0.0).to_array(),
                }
            })
            .collect();
        Self { nodes, triangles: tris }
    }

    fn triangle(&self, i: usize) -> [Vec3; 3] {
        let t = &self.triangles[i];
        [Vec3::from_slice(&t.v0[..3]), Vec3::from_slice(&t.v1[..3]), Vec3::from_slice(&t.v2[..3])]
    }

    /// Nearest hit with t in (t_min, t_max), or any hit if `any` (shadow rays).
    pub fn trace(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32, any: bool) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv_d = safe_recip(d);
        let mut best: Option<Hit> = None;
        let mut t_far = t_max;
        let mut stack = vec![0usize];
        while let Some(ni) = stack.pop() {
            let n = &self.nodes[ni];
            if !slab(o, inv_d, n, t_far) {
                continue;
            }
            if n.count == 0 {
                stack.push(n.first as usize);
                stack.push(n.first as usize + 1);
                continue;
            }
            for k in n.first as usize..(n.first + n.count) as usize {
                if let Some(t) = intersect_triangle(o, d, self.triangle(k), t_min, t_far) {
                    best = Some(Hit { t, triangle: k });
                    if any {
                        return best;
                    }
                    t_far = t;
                }
            }
        }
        best
    }

    /// Deepest root-to-leaf path (the GLSL traversal stack must hold it).
    pub fn depth(&self) -> usize {
        if self.nodes.is_empty() {
            return 0;
        }
        let mut deepest = 0;
        let mut stack = vec![(0usize, 1usize)];
        while let Some((i, d)) = stack.pop() {
            deepest = deepest.max(d);
            let n = &self.nodes[i];
            if n.count == 0 {
                stack.push((n.first as usize, d + 1));
                stack.push((n.first as usize + 1, d + 1));
            }
        }
        deepest
    }
}

/// Binned SAH: the best (axis, last bin of the left side, cost) if it beats a leaf.
fn best_split(
    idx: &[u32],
    bounds: &[Aabb],
    centroids: &[Vec3],
    cb: &Aabb,
    nb: &Aabb,
    count: usize,
) -> Option<(usize, usize, f32)> {
    let leaf_cost = count as f32;
    let parent_area = nb.area().max(f32::MIN_POSITIVE);
    let mut best: Option<(usize, usize, f32)> = None;
    #[allow(clippy::needless_range_loop)] // `axis` indexes Vec3 lanes of several arrays
    for axis in 0..3 {
        let extent = cb.hi[axis] - cb.lo[axis];
        if extent.is_nan() || extent <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / extent;
        let mut bin_bounds = [Aabb::EMPTY; BINS];
        let mut bin_count = [0usize; BINS];
        for &i in idx {
            let b = (((centroids[i as usize][axis] - cb.lo[axis]) * scale) as usize).min(BINS - 1);
            bin_bounds[b].merge(&bounds[i as usize]);
            bin_count[b] += 1;
        }
        // Sweep from the right for suffix areas, then from the left.
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0usize; BINS];
        let mut acc = Aabb::EMPTY;
        let mut c = 0;
        for b in (1..BINS).rev() {
            acc.merge(&bin_bounds[b]);
            c += bin_count[b];
            right_area[b] = acc.area();
            right_count[b] = c;
        }
        let mut left = Aabb::EMPTY;
        let mut lc = 0;
        for b in 0..BINS - 1 {
            left.merge(&bin_bounds[b]);
            lc += bin_count[b];
            let rc = right_count[b + 1];
            if lc == 0 || rc == 0 {
                continue;
            }
            let cost = TRAVERSAL_COST + (left.area() * lc as f32 + right_area[b + 1] * rc as f32) / parent_area;
            if best.is_none_or(|(_, _, c)| cost < c) {
                best = Some((axis, b, cost));
            }
        }
    }
    best.filter(|&(_, _, c)| c < leaf_cost || count > MAX_LEAF)
}

/// Move the elements for which `left` holds to the front; returns how many there are.
fn partition(idx: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut m = 0;
    for k in 0..idx.len() {
        if left(idx[k]) {
            idx.swap(m, k);
            m += 1;
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (tests only).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((self.0 >> 40) as f32) / (1u64 << 24) as f32
        }
        fn vec(&mut self) -> Vec3 {
            Vec3::new(self.next(), self.next(), self.next())
        }
    }

    fn random_triangles(n: usize, rng: &mut Lcg) -> Vec<[Vec3; 3]> {
        (0..n)
            .map(|_| {
                let c = rng.vec() * 4.0 - 2.0;
                let s = 0.05 + 0.3 * rng.next();
                [c, c + (rng.vec() - 0.5) * s, c + (rng.vec() - 0.5) * s]
            })
            .collect()
    }

    fn brute(tris: &[[Vec3; 3]], o: Vec3, d: Vec3, t_max: f32) -> Option<f32> {
        tris.iter().filter_map(|t| intersect_triangle(o, d, *t, 0.0, t_max)).min_by(f32::total_cmp)
    }

    #[test]
    fn traversal_matches_brute_force() {
        let mut rng = Lcg(7);
        let tris = random_triangles(2000, &mut rng);
        let bvh = TriangleBvh::build(&tris);
        // Every triangle is in exactly one leaf.
        let in_leaves: usize = bvh.nodes.iter().filter(|n| n.count > 0).map(|n| n.count as usize).sum();
        assert_eq!(in_leaves, tris.len());
        assert!(bvh.nodes.iter().all(|n| n.count as usize <= MAX_LEAF));
        assert!(bvh.depth() < 48, "depth {}", bvh.depth());
        let mut hits = 0;
        for _ in 0..2000 {
            let o = rng.vec() * 6.0 - 3.0;
            // Half the rays aim at a triangle's centroid, so hits and misses both occur often.
            let d = if rng.next() < 0.5 {
                let t = tris[(rng.next() * tris.len() as f32) as usize % tris.len()];
                ((t[0] + t[1] + t[2]) / 3.0 - o).normalize_or(Vec3::X)
            } else {
                (rng.vec() - 0.5).normalize_or(Vec3::X)
            };
            let t_max = if rng.next() < 0.5 { f32::INFINITY } else { 3.0 * rng.next() };
            let want = brute(&tris, o, d, t_max);
            let got = bvh.trace(o, d, 0.0, t_max, false).map(|h| h.t);
            assert_eq!(got, want, "ray {o} {d}");
            assert_eq!(bvh.trace(o, d, 0.0, t_max, true).is_some(), want.is_some());
            hits += want.is_some() as usize;
        }
        // Both cases occur.
        assert!(hits > 500 && hits < 1800, "{hits}");
    }

    #[test]
    fn degenerate_inputs() {
        assert!(TriangleBvh::build(&[]).trace(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY, false).is_none());
        // Many triangles with one centroid: leaves are still bounded by MAX_LEAF.
        let t = [Vec3::new(1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, -1.0), Vec3::new(1.0, 0.0, 1.0)];
        let bvh = TriangleBvh::build(&vec![t; 100]);
        assert!(bvh.nodes.iter().all(|n| n.count as usize <= MAX_LEAF));
        let h = bvh.trace(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY, false).expect("hit");
        assert!((h.t - 1.0).abs() < 1e-6);
        // Axis-parallel rays (inverse direction components are infinite).
        assert!(bvh.trace(Vec3::new(0.0, 0.0, 0.0), Vec3::Y, 0.0, f32::INFINITY, true).is_none());
    }
}
