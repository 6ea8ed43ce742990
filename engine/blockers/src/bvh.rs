//! Binary sphere BVH: the CPU reference of the GPU build (LBVH from 30-bit Morton codes, Karras 2012
//! "Maximizing parallelism in the construction of BVHs, octrees, and k-d trees"), refit for
//! animation, and the traversal queries the techniques need (ISG §5: cone culling and a cut by
//! projected size; SHEXP §6.3: a cut by subtended angle, Eq. 36).
//!
//! Node numbering is Karras's: for `n` leaves, internal nodes are `0 .. n−1` (node 0 is the root) and
//! leaves are `n−1 .. 2n−1`, leaf `n−1+i` holding the `i`-th sphere in Morton order. With one sphere
//! the root is that leaf (index 0). Every node's sphere bounds its children's (pair merge, exact).

use crate::geom::{cone_intersects_sphere, merge_spheres, subtends_less_than, Cone, Sphere};
use crate::BlockerError;
use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// "No node" in [`GpuBvhNode`] links.
pub const INVALID: u32 = u32::MAX;

/// One BVH node as the GPU reads it (std430, 32 bytes, 16-byte aligned in arrays):
///
/// | offset | field | meaning |
/// |---|---|---|
/// | 0 | `center: vec3` | bounding-sphere centre (f32) |
/// | 12 | `radius: float` | bounding radius, rounded up so the f32 sphere contains the f64 one |
/// | 16 | `left: uint` | left child node index, or [`INVALID`] for a leaf |
/// | 20 | `right: uint` | right child node index, or [`INVALID`] for a leaf |
/// | 24 | `parent: uint` | parent node index, [`INVALID`] for the root |
/// | 28 | `sphere: uint` | for a leaf the index of its sphere in the input set, else [`INVALID`] |
///
/// GLSL: `struct BvhNode { vec3 center; float radius; uint left; uint right; uint parent; uint sphere; };`
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuBvhNode {
    pub center: [f32; 3],
    pub radius: f32,
    pub left: u32,
    pub right: u32,
    pub parent: u32,
    pub sphere: u32,
}

/// An f64 sphere converted to f32 so that the f32 sphere contains the f64 one: each centre
/// coordinate moves by at most half an ulp (≤ |c|·2⁻²⁴), so the radius grows by √3·|c|∞·2⁻²³ plus
/// a relative 2⁻²² for its own rounding, then rounds up.
pub fn conservative_f32_sphere(s: &Sphere) -> ([f32; 3], f32) {
    let c = s.center.as_vec3().to_array();
    let shift = s.center.distance(glam::Vec3::from_array(c).as_dvec3());
    let r = (s.radius + shift) * (1.0 + 2f64.powi(-22)) + f64::from(f32::MIN_POSITIVE);
    let mut r32 = r as f32;
    if (r32 as f64) < r {
        r32 = r32.next_up();
    }
    (c, r32)
}

#[derive(Clone, Debug)]
pub struct BvhNode {
    pub sphere: Sphere,
    /// Children, or `None` for a leaf.
    pub children: Option<[u32; 2]>,
    pub parent: Option<u32>,
    /// For leaves: the index of the sphere in the input set.
    pub leaf_sphere: Option<u32>,
}

/// A binary LBVH over a sphere set.
#[derive(Clone, Debug)]
pub struct SphereBvh {
    nodes: Vec<BvhNode>,
    /// Internal nodes ordered children-before-parents (for refit).
    refit_order: Vec<u32>,
    /// leaf node index of each input sphere.
    leaf_of_sphere: Vec<u32>,
}

/// Spreads the low 10 bits of `v` to every third bit.
fn expand_bits(v: u32) -> u32 {
    let mut v = v & 0x3ff;
    v = (v | (v << 16)) & 0x0300_00ff;
    v = (v | (v << 8)) & 0x0300_f00f;
    v = (v | (v << 4)) & 0x030c_30c3;
    v = (v | (v << 2)) & 0x0924_9249;
    v
}

/// 30-bit Morton code of `p` quantized to 10 bits per axis over the box [lo, lo + extent].
pub fn morton_code(p: DVec3, lo: DVec3, extent: DVec3) -> u32 {
    let q = |x: f64, l: f64, e: f64| -> u32 {
        if e > 0.0 {
            ((x - l) / e * 1024.0).clamp(0.0, 1023.0) as u32
        } else {
            0
        }
    };
    (expand_bits(q(p.x, lo.x, extent.x)) << 2)
        | (expand_bits(q(p.y, lo.y, extent.y)) << 1)
        | expand_bits(q(p.z, lo.z, extent.z))
}

impl SphereBvh {
    /// Builds the LBVH. Errors: no spheres, or a sphere with a non-finite centre or a negative /
    /// non-finite radius. Duplicate centres are fine (equal Morton codes are ordered by index, as
    /// Karras's augmented keys do); zero radii are fine.
    pub fn build(spheres: &[Sphere]) -> Result<Self, BlockerError> {
        if spheres.is_empty() {
            return Err(BlockerError::NoSpheres);
        }
        for (i, s) in spheres.iter().enumerate() {
            s.validate(i)?;
        }
        let n = spheres.len();
        let (lo, hi) =
            spheres.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), s| {
                (lo.min(s.center), hi.max(s.center))
            });
        let extent = hi - lo;
        let mut keys: Vec<(u32, u32)> =
            spheres.iter().enumerate().map(|(i, s)| (morton_code(s.center, lo, extent), i as u32)).collect();
        keys.sort_unstable();
        let internal = n - 1;
        let mut nodes: Vec<BvhNode> = Vec::with_capacity(2 * n - 1);
        for _ in 0..internal {
            nodes.push(BvhNode {
                sphere: Sphere::new(DVec3::ZERO, 0.0),
                children: None,
                parent: None,
                leaf_sphere: None,
            });
        }
        let mut leaf_of_sphere = vec![0u32; n];
        for (i, &(_, s)) in keys.iter().enumerate() {
            nodes.push(BvhNode { sphere: spheres[s as usize], children: None, parent: None, leaf_sphere: Some(s) });
            leaf_of_sphere[s as usize] = (internal + i) as u32;
        }
        // δ(i, j): length of the common prefix of the augmented keys (code, index); −1 out of range.
        let delta = |i: i64, j: i64| -> i64 {
            if j < 0 || j >= n as i64 {
                return -1;
            }
            let (a, b) = (keys[i as usize].0, keys[j as usize].0);
            if a == b {
                32 + (i as u32 ^ j as u32).leading_zeros() as i64
            } else {
                (a ^ b).leading_zeros() as i64
            }
        };
        for i in 0..internal as i64 {
            // Karras 2012, Fig. 4: direction, range end, split.
            let d: i64 = if delta(i, i + 1) - delta(i, i - 1) >= 0 { 1 } else { -1 };
            let delta_min = delta(i, i - d);
            let mut l_max = 2;
            while delta(i, i + l_max * d) > delta_min {
                l_max *= 2;
            }
            let mut l = 0;
            let mut t = l_max / 2;
            while t >= 1 {
                if delta(i, i + (l + t) * d) > delta_min {
                    l += t;
                }
                t /= 2;
            }
            let j = i + l * d;
            let delta_node = delta(i, j);
            let mut s = 0;
            let mut div = 2;
            loop {
                let t = (l + div - 1) / div;
                if delta(i, i + (s + t) * d) > delta_node {
                    s += t;
                }
                if t <= 1 {
                    break;
                }
                div *= 2;
            }
            let gamma = i + s * d + d.min(0);
            let left = if i.min(j) == gamma { internal as i64 + gamma } else { gamma };
            let right = if i.max(j) == gamma + 1 { internal as i64 + gamma + 1 } else { gamma + 1 };
            nodes[i as usize].children = Some([left as u32, right as u32]);
            nodes[left as usize].parent = Some(i as u32);
            nodes[right as usize].parent = Some(i as u32);
        }
        // Children-before-parents order by an explicit-stack DFS from the root, reversed.
        let mut refit_order = Vec::with_capacity(internal);
        if internal > 0 {
            let mut stack = vec![0u32];
            while let Some(v) = stack.pop() {
                if let Some(c) = nodes[v as usize].children {
                    refit_order.push(v);
                    stack.extend_from_slice(&c);
                }
            }
            refit_order.reverse();
        }
        let mut bvh = Self { nodes, refit_order, leaf_of_sphere };
        bvh.refit_internal();
        Ok(bvh)
    }

    fn refit_internal(&mut self) {
        for &v in &self.refit_order {
            if let Some([a, b]) = self.nodes[v as usize].children {
                self.nodes[v as usize].sphere =
                    merge_spheres(&self.nodes[a as usize].sphere, &self.nodes[b as usize].sphere);
            }
        }
    }

    /// Refit for animation: same topology, new leaf spheres (same count and order as at build),
    /// parents re-bounded bottom-up by pair merges (SHEXP §6.3). Quality degrades as spheres move
    /// far from their build positions; rebuild then.
    pub fn refit(&mut self, spheres: &[Sphere]) -> Result<(), BlockerError> {
        crate::geom::validate_refit(spheres, self.leaf_of_sphere.len())?;
        for (s, &leaf) in spheres.iter().zip(&self.leaf_of_sphere) {
            self.nodes[leaf as usize].sphere = *s;
        }
        self.refit_internal();
        Ok(())
    }

    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    pub fn leaf_count(&self) -> usize {
        self.leaf_of_sphere.len()
    }

    /// The std430 node array (same indices as [`SphereBvh::nodes`]).
    pub fn gpu_nodes(&self) -> Vec<GpuBvhNode> {
        self.nodes
            .iter()
            .map(|n| {
                let (center, radius) = conservative_f32_sphere(&n.sphere);
                let [left, right] = n.children.unwrap_or([INVALID; 2]);
                GpuBvhNode {
                    center,
                    radius,
                    left,
                    right,
                    parent: n.parent.unwrap_or(INVALID),
                    sphere: n.leaf_sphere.unwrap_or(INVALID),
                }
            })
            .collect()
    }

    /// Depth-first traversal: `visit(node)` returns whether to descend; leaves for which it returns
    /// true are collected as their input sphere indices (sorted on return).
    fn collect_leaves(&self, mut enter: impl FnMut(&Sphere) -> bool) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![0u32];
        while let Some(v) = stack.pop() {
            let node = &self.nodes[v as usize];
            if !enter(&node.sphere) {
                continue;
            }
            match node.children {
                Some(c) => stack.extend_from_slice(&c),
                None => out.extend(node.leaf_sphere),
            }
        }
        out.sort_unstable();
        out
    }

    /// Indices of the spheres containing `p` (boundary included), sorted.
    pub fn spheres_containing(&self, p: DVec3) -> Vec<u32> {
        self.collect_leaves(|s| s.contains_point(p))
    }

    /// Whether `p` is inside any sphere (stops at the first hit).
    pub fn any_contains(&self, p: DVec3) -> bool {
        let mut stack = vec![0u32];
        while let Some(v) = stack.pop() {
            let node = &self.nodes[v as usize];
            if node.sphere.contains_point(p) {
                match node.children {
                    Some(c) => stack.extend_from_slice(&c),
                    None => return true,
                }
            }
        }
        false
    }

    /// Indices of the spheres that intersect `cone`, sorted (ISG §5, Fig. 5: a node whose bounding
    /// sphere misses the cone culls its whole subtree; exact because children lie inside parents).
    pub fn cone_query(&self, cone: &Cone) -> Vec<u32> {
        self.collect_leaves(|s| cone_intersects_sphere(cone, s))
    }

    /// The cut for a receiver bounded by `receiver` (a point: radius 0): from the root, a node that
    /// subtends less than `theta_max` from every receiver point (SHEXP Eq. 36) is taken whole,
    /// otherwise its children are visited; leaves that fail are taken too. With a `cone`, nodes that
    /// miss it are dropped with their subtrees (ISG §5). Returns node indices in DFS order.
    pub fn cut(&self, receiver: &Sphere, theta_max: f64, cone: Option<&Cone>) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![0u32];
        while let Some(v) = stack.pop() {
            let node = &self.nodes[v as usize];
            if let Some(cone) = cone {
                if !cone_intersects_sphere(cone, &node.sphere) {
                    continue;
                }
            }
            match node.children {
                Some([a, b]) if !subtends_less_than(receiver, &node.sphere, theta_max) => {
                    stack.push(b);
                    stack.push(a);
                }
                _ => out.push(v),
            }
        }
        out
    }

    /// Input sphere indices under node `v` (sorted).
    pub fn leaves_under(&self, v: u32) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![v];
        while let Some(v) = stack.pop() {
            let node = &self.nodes[v as usize];
            match node.children {
                Some(c) => stack.extend_from_slice(&c),
                None => out.extend(node.leaf_sphere),
            }
        }
        out.sort_unstable();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::random_spheres;
    use engine_math::rng::Pcg32;
    use std::f64::consts::PI;

    /// Structural invariants: children inside parents, parent links, every leaf reachable once.
    fn check_structure(bvh: &SphereBvh, spheres: &[Sphere]) {
        let n = spheres.len();
        assert_eq!(bvh.nodes().len(), 2 * n - 1);
        let mut seen = vec![0u32; bvh.nodes().len()];
        let mut stack = vec![0u32];
        assert!(bvh.nodes()[0].parent.is_none());
        while let Some(v) = stack.pop() {
            seen[v as usize] += 1;
            let node = &bvh.nodes()[v as usize];
            if let Some(c) = node.children {
                for ch in c {
                    let child = &bvh.nodes()[ch as usize];
                    assert_eq!(child.parent, Some(v));
                    // Pair merges keep children inside up to rounding: 1e-12 on a scene of size ~10.
                    assert!(node.sphere.contains_sphere(&child.sphere, 1e-12), "node {v} child {ch}");
                    stack.push(ch);
                }
            } else {
                let s = node.leaf_sphere.unwrap() as usize;
                assert_eq!(node.sphere, spheres[s]);
            }
        }
        assert!(seen.iter().all(|&c| c == 1), "every node reachable exactly once");
        let mut leaves = bvh.leaves_under(0);
        leaves.dedup();
        assert_eq!(leaves, (0..n as u32).collect::<Vec<_>>());
    }

    #[test]
    fn build_invariants_random_and_degenerate() {
        let mut rng = Pcg32::new(1, 1);
        for n in [1usize, 2, 3, 5, 17, 64, 200] {
            let spheres = random_spheres(&mut rng, n);
            check_structure(&SphereBvh::build(&spheres).unwrap(), &spheres);
        }
        // Duplicate centres (equal Morton codes), zero radii, all spheres identical.
        let dup = vec![Sphere::new(DVec3::ONE, 0.5); 9];
        check_structure(&SphereBvh::build(&dup).unwrap(), &dup);
        let mut mixed = random_spheres(&mut rng, 20);
        mixed.extend(mixed.clone());
        mixed.push(Sphere::new(DVec3::ZERO, 0.0));
        check_structure(&SphereBvh::build(&mixed).unwrap(), &mixed);
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(matches!(SphereBvh::build(&[]), Err(BlockerError::NoSpheres)));
        for bad in [
            Sphere::new(DVec3::new(f64::NAN, 0.0, 0.0), 1.0),
            Sphere::new(DVec3::ZERO, -1.0),
            Sphere::new(DVec3::ZERO, f64::INFINITY),
        ] {
            let r = SphereBvh::build(&[Sphere::new(DVec3::ZERO, 1.0), bad]);
            assert!(matches!(r, Err(BlockerError::InvalidSphere { index: 1, .. })), "{r:?}");
        }
        let mut bvh = SphereBvh::build(&[Sphere::new(DVec3::ZERO, 1.0)]).unwrap();
        assert!(bvh.refit(&[]).is_err());
    }

    #[test]
    fn queries_equal_brute_force() {
        let mut rng = Pcg32::new(7, 2);
        let spheres = random_spheres(&mut rng, 150);
        let bvh = SphereBvh::build(&spheres).unwrap();
        for _ in 0..300 {
            let p = DVec3::new(rng.uniform(-6.0, 6.0), rng.uniform(-6.0, 6.0), rng.uniform(-6.0, 6.0));
            let brute: Vec<u32> =
                (0..spheres.len() as u32).filter(|&i| spheres[i as usize].contains_point(p)).collect();
            assert_eq!(bvh.spheres_containing(p), brute);
            assert_eq!(bvh.any_contains(p), !brute.is_empty());
            let cone = Cone::new(p, DVec3::from_array(rng.unit_vector()), rng.uniform(0.0, 0.8));
            let brute: Vec<u32> =
                (0..spheres.len() as u32).filter(|&i| cone_intersects_sphere(&cone, &spheres[i as usize])).collect();
            assert_eq!(bvh.cone_query(&cone), brute);
        }
    }

    #[test]
    fn cut_partitions_leaves_and_respects_eq36() {
        let mut rng = Pcg32::new(8, 3);
        let spheres = random_spheres(&mut rng, 120);
        let bvh = SphereBvh::build(&spheres).unwrap();
        for trial in 0..40 {
            let receiver = Sphere::new(
                DVec3::new(rng.uniform(-20.0, 20.0), rng.uniform(-20.0, 20.0), rng.uniform(-20.0, 20.0)),
                if trial % 2 == 0 { 0.0 } else { rng.uniform(0.0, 2.0) },
            );
            let theta = rng.uniform(0.05, 0.6);
            let cone = Cone::new(receiver.center, DVec3::from_array(rng.unit_vector()), rng.uniform(0.2, 1.2));
            for cone in [None, Some(&cone)] {
                let cut = bvh.cut(&receiver, theta, cone);
                let mut covered: Vec<u32> = cut.iter().flat_map(|&v| bvh.leaves_under(v)).collect();
                let before = covered.len();
                covered.sort_unstable();
                covered.dedup();
                assert_eq!(before, covered.len(), "a leaf is under two cut nodes");
                // Every leaf not under the cut must be culled by the cone through an ancestor (or itself).
                for i in 0..spheres.len() as u32 {
                    if covered.binary_search(&i).is_err() {
                        let cone = cone.expect("without a cone the cut covers every leaf");
                        let mut v = Some(bvh.leaf_of_sphere[i as usize]);
                        let mut culled = false;
                        while let Some(x) = v {
                            culled |= !cone_intersects_sphere(cone, &bvh.nodes()[x as usize].sphere);
                            v = bvh.nodes()[x as usize].parent;
                        }
                        assert!(culled);
                    }
                }
                for &v in &cut {
                    let node = &bvh.nodes()[v as usize];
                    if node.children.is_some() {
                        assert!(subtends_less_than(&receiver, &node.sphere, theta));
                        // Independent angle check (Eq. 36 as an angle): from the receiver point
                        // nearest the node, the node subtends less than θ_max.
                        let d = receiver.center.distance(node.sphere.center) - receiver.radius;
                        assert!((node.sphere.radius / d).asin() < theta);
                    }
                    if let Some(p) = node.parent {
                        assert!(!subtends_less_than(&receiver, &bvh.nodes()[p as usize].sphere, theta));
                    }
                }
            }
        }
        // θ_max → 0 gives all leaves; a far receiver with θ = π/2 gives the root.
        assert_eq!(bvh.cut(&Sphere::new(DVec3::ZERO, 0.0), 0.0, None).len(), spheres.len());
        assert_eq!(bvh.cut(&Sphere::new(DVec3::splat(1e6), 0.0), PI / 2.0, None), vec![0]);
    }

    #[test]
    fn refit_after_motion_keeps_invariants_and_queries() {
        let mut rng = Pcg32::new(9, 4);
        let mut spheres = random_spheres(&mut rng, 80);
        let mut bvh = SphereBvh::build(&spheres).unwrap();
        for s in &mut spheres {
            s.center += DVec3::new(rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0));
            s.radius *= rng.uniform(0.5, 1.5);
        }
        bvh.refit(&spheres).unwrap();
        check_structure(&bvh, &spheres);
        for _ in 0..100 {
            let p = DVec3::new(rng.uniform(-7.0, 7.0), rng.uniform(-7.0, 7.0), rng.uniform(-7.0, 7.0));
            let brute: Vec<u32> = (0..80).filter(|&i| spheres[i as usize].contains_point(p)).collect();
            assert_eq!(bvh.spheres_containing(p), brute);
        }
    }

    #[test]
    // The layout against bvh.glsl is checked by tests/tests/struct_layouts.rs (compiled shader).
    fn gpu_nodes_round_conservatively() {
        let mut rng = Pcg32::new(10, 5);
        let spheres = random_spheres(&mut rng, 50);
        let bvh = SphereBvh::build(&spheres).unwrap();
        let gpu = bvh.gpu_nodes();
        for (g, n) in gpu.iter().zip(bvh.nodes()) {
            let c = glam::Vec3::from_array(g.center).as_dvec3();
            // The f32 sphere must contain the f64 one exactly (no slack).
            assert!(c.distance(n.sphere.center) + n.sphere.radius <= g.radius as f64);
            assert_eq!(g.left == INVALID, n.children.is_none());
        }
        // Large coordinates: the centre shift dominates and is covered.
        let far = Sphere::new(DVec3::new(1.0e6 + 0.3, -2.0e6 + 0.7, 3.3e5), 1e-3);
        let (c, r) = conservative_f32_sphere(&far);
        assert!(glam::Vec3::from_array(c).as_dvec3().distance(far.center) + far.radius <= r as f64);
    }

    #[test]
    fn morton_codes_interleave() {
        let lo = DVec3::ZERO;
        let e = DVec3::ONE;
        assert_eq!(morton_code(DVec3::ZERO, lo, e), 0);
        assert_eq!(morton_code(DVec3::ONE, lo, e), (1 << 30) - 1);
        // x is the most significant of each triple.
        assert_eq!(morton_code(DVec3::new(1.0 / 1024.0, 0.0, 0.0), lo, e), 0b100);
        assert_eq!(morton_code(DVec3::new(0.0, 0.0, 1.0 / 1024.0), lo, e), 0b001);
        // Degenerate extent: all zero, no NaN.
        assert_eq!(morton_code(DVec3::ONE, lo, DVec3::ZERO), 0);
    }
}
