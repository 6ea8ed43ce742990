//! The 4-ary blocker hierarchy of SHEXP §6.3 and its per-receiver cut by angle θ_max (Eq. 36).
//!
//! Construction (bottom-up, one level at a time): the nodes of the current level are clustered by
//! Lloyd's algorithm on their centres into ⌈n/4⌉ clusters (average branching ≈ 4); each cluster's
//! bounding sphere starts at the mean of its children's centres and is moved to minimize the
//! bounding radius ([`bounding_sphere_of_spheres`]); the clusters become the parents. Repeated until
//! one node remains. Animation refit: parents re-bounded bottom-up by successive pair merges
//! (the paper's "sphere pair bound").
//!
//! Nodes are stored in breadth-first order from the root (index 0), so each node's children are
//! contiguous: `first_child .. first_child + child_count`. That is the GPU layout too.

use crate::geom::{bounding_sphere_of_spheres, merge_spheres, subtends_less_than, Sphere};
use crate::BlockerError;
use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// One hierarchy node as the GPU reads it (std430, 32 bytes):
///
/// | offset | field | meaning |
/// |---|---|---|
/// | 0 | `center: vec3` | bounding-sphere centre (f32) |
/// | 12 | `radius: float` | radius rounded up so the f32 sphere contains the f64 one |
/// | 16 | `first_child: uint` | index of the first child (children contiguous); [`crate::bvh::INVALID`] for a leaf |
/// | 20 | `child_count: uint` | number of children, 0 for a leaf |
/// | 24 | `parent: uint` | parent index, [`crate::bvh::INVALID`] for the root |
/// | 28 | `sphere: uint` | for a leaf, the index of its sphere in the input set; else [`crate::bvh::INVALID`] |
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuHierarchyNode {
    pub center: [f32; 3],
    pub radius: f32,
    pub first_child: u32,
    pub child_count: u32,
    pub parent: u32,
    pub sphere: u32,
}

#[derive(Clone, Debug)]
pub struct HierarchyNode {
    pub sphere: Sphere,
    pub first_child: u32,
    pub child_count: u32,
    pub parent: Option<u32>,
    /// For leaves: index of the sphere in the input set.
    pub leaf_sphere: Option<u32>,
    /// 0 for leaves, growing towards the root.
    pub level: u32,
}

/// The 4-ary sphere hierarchy (root = node 0).
#[derive(Clone, Debug)]
pub struct SphereHierarchy {
    nodes: Vec<HierarchyNode>,
    leaf_of_sphere: Vec<u32>,
}

/// Lloyd clustering of `centers` into `k` groups: farthest-point initial seeds (deterministic),
/// at most 32 iterations; an emptied cluster is reseeded at the centre farthest from its cluster.
fn lloyd(centers: &[DVec3], k: usize) -> Vec<usize> {
    let n = centers.len();
    let mut seeds = vec![centers[0]];
    let mut dist: Vec<f64> = centers.iter().map(|c| c.distance_squared(centers[0])).collect();
    while seeds.len() < k {
        let far = (0..n).fold(0, |b, i| if dist[i] > dist[b] { i } else { b });
        seeds.push(centers[far]);
        for (d, c) in dist.iter_mut().zip(centers) {
            *d = d.min(c.distance_squared(centers[far]));
        }
    }
    let nearest = |p: DVec3, seeds: &[DVec3]| {
        (0..seeds.len()).fold(0, |b, i| if p.distance_squared(seeds[i]) < p.distance_squared(seeds[b]) { i } else { b })
    };
    let mut assign: Vec<usize> = centers.iter().map(|&c| nearest(c, &seeds)).collect();
    for _ in 0..32 {
        let mut sum = vec![DVec3::ZERO; k];
        let mut count = vec![0usize; k];
        for (&a, c) in assign.iter().zip(centers) {
            sum[a] += *c;
            count[a] += 1;
        }
        for i in 0..k {
            if count[i] > 0 {
                seeds[i] = sum[i] / count[i] as f64;
            } else {
                let far = (0..n).fold(0, |b, j| {
                    let d = |j: usize| centers[j].distance_squared(seeds[assign[j]]);
                    if d(j) > d(b) {
                        j
                    } else {
                        b
                    }
                });
                seeds[i] = centers[far];
                assign[far] = i;
            }
        }
        let next: Vec<usize> = centers.iter().map(|&c| nearest(c, &seeds)).collect();
        if next == assign {
            break;
        }
        assign = next;
    }
    // Reseeding can still leave a cluster empty if two seeds coincide (duplicate centres): give each
    // empty cluster one member from the largest cluster so every parent has a child.
    loop {
        let mut count = vec![0usize; k];
        for &a in &assign {
            count[a] += 1;
        }
        let Some(empty) = (0..k).find(|&i| count[i] == 0) else {
            break;
        };
        let largest = (0..k).fold(0, |b, i| if count[i] > count[b] { i } else { b });
        let member = assign.iter().position(|&a| a == largest).unwrap_or(0);
        assign[member] = empty;
    }
    assign
}

impl SphereHierarchy {
    /// Builds the hierarchy over `spheres` (the leaves). Errors: no spheres, invalid spheres.
    /// Duplicate centres and zero radii are fine.
    pub fn build(spheres: &[Sphere]) -> Result<Self, BlockerError> {
        if spheres.is_empty() {
            return Err(BlockerError::NoSpheres);
        }
        for (i, s) in spheres.iter().enumerate() {
            s.validate(i)?;
        }
        // Build with temporary ids (leaves 0..n, parents appended), then renumber breadth-first.
        let mut spheres_tmp: Vec<Sphere> = spheres.to_vec();
        let mut children_tmp: Vec<Vec<usize>> = vec![Vec::new(); spheres.len()];
        let mut level_tmp: Vec<u32> = vec![0; spheres.len()];
        let mut current: Vec<usize> = (0..spheres.len()).collect();
        let mut level = 0;
        while current.len() > 1 {
            level += 1;
            let k = current.len().div_ceil(4);
            let centers: Vec<DVec3> = current.iter().map(|&v| spheres_tmp[v].center).collect();
            let assign = lloyd(&centers, k);
            let mut next = Vec::with_capacity(k);
            for c in 0..k {
                let kids: Vec<usize> = current.iter().zip(&assign).filter(|(_, &a)| a == c).map(|(&v, _)| v).collect();
                let kid_spheres: Vec<Sphere> = kids.iter().map(|&v| spheres_tmp[v]).collect();
                let Some(bound) = bounding_sphere_of_spheres(&kid_spheres) else {
                    continue;
                };
                next.push(spheres_tmp.len());
                spheres_tmp.push(bound);
                children_tmp.push(kids);
                level_tmp.push(level);
            }
            current = next;
        }
        let root_tmp = current[0];
        // Breadth-first renumbering.
        let mut order = vec![root_tmp];
        let mut head = 0;
        while head < order.len() {
            let v = order[head];
            order.extend_from_slice(&children_tmp[v]);
            head += 1;
        }
        let mut new_id = vec![0u32; spheres_tmp.len()];
        for (i, &v) in order.iter().enumerate() {
            new_id[v] = i as u32;
        }
        let mut nodes: Vec<HierarchyNode> = order
            .iter()
            .map(|&v| HierarchyNode {
                sphere: spheres_tmp[v],
                first_child: children_tmp[v].first().map_or(crate::bvh::INVALID, |&c| new_id[c]),
                child_count: children_tmp[v].len() as u32,
                parent: None,
                leaf_sphere: (v < spheres.len()).then_some(v as u32),
                level: level_tmp[v],
            })
            .collect();
        for &v in &order {
            for &c in &children_tmp[v] {
                nodes[new_id[c] as usize].parent = Some(new_id[v]);
            }
        }
        let leaf_of_sphere = (0..spheres.len()).map(|i| new_id[i]).collect();
        Ok(Self { nodes, leaf_of_sphere })
    }

    pub fn nodes(&self) -> &[HierarchyNode] {
        &self.nodes
    }

    pub fn children(&self, v: u32) -> std::ops::Range<u32> {
        let n = &self.nodes[v as usize];
        if n.child_count == 0 {
            0..0
        } else {
            n.first_child..n.first_child + n.child_count
        }
    }

    /// Mean number of children over internal nodes.
    pub fn mean_branching(&self) -> f64 {
        let internal: Vec<_> = self.nodes.iter().filter(|n| n.child_count > 0).collect();
        if internal.is_empty() {
            return 0.0;
        }
        internal.iter().map(|n| n.child_count as f64).sum::<f64>() / internal.len() as f64
    }

    /// Animation refit: new leaf spheres (same count and order as at build), parents re-bounded
    /// bottom-up by successive pair merges (SHEXP §6.3). Breadth-first order means children have
    /// larger indices than parents, so a reverse sweep is bottom-up.
    pub fn refit(&mut self, spheres: &[Sphere]) -> Result<(), BlockerError> {
        crate::geom::validate_refit(spheres, self.leaf_of_sphere.len())?;
        for (s, &leaf) in spheres.iter().zip(&self.leaf_of_sphere) {
            self.nodes[leaf as usize].sphere = *s;
        }
        for v in (0..self.nodes.len() as u32).rev() {
            let mut kids = self.children(v);
            if let Some(first) = kids.next() {
                let bound = kids.fold(self.nodes[first as usize].sphere, |acc, c| {
                    merge_spheres(&acc, &self.nodes[c as usize].sphere)
                });
                self.nodes[v as usize].sphere = bound;
            }
        }
        Ok(())
    }

    /// SHEXP §6.3 per-cluster cut: from the root, a node that subtends less than `theta_max` from
    /// every point of the receiver cluster's bounding sphere (Eq. 36) is taken, otherwise its
    /// children are visited; leaves are always taken. Node indices in DFS order.
    pub fn cut(&self, receiver: &Sphere, theta_max: f64) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![0u32];
        while let Some(v) = stack.pop() {
            let node = &self.nodes[v as usize];
            if node.child_count > 0 && !subtends_less_than(receiver, &node.sphere, theta_max) {
                stack.extend(self.children(v).rev());
            } else {
                out.push(v);
            }
        }
        out
    }

    /// Input sphere indices under node `v` (sorted).
    pub fn leaves_under(&self, v: u32) -> Vec<u32> {
        let mut out = Vec::new();
        let mut stack = vec![v];
        while let Some(v) = stack.pop() {
            let n = &self.nodes[v as usize];
            out.extend(n.leaf_sphere);
            stack.extend(self.children(v));
        }
        out.sort_unstable();
        out
    }

    /// The std430 node array (same indices as [`SphereHierarchy::nodes`]).
    pub fn gpu_nodes(&self) -> Vec<GpuHierarchyNode> {
        self.nodes
            .iter()
            .map(|n| {
                let (center, radius) = crate::bvh::conservative_f32_sphere(&n.sphere);
                GpuHierarchyNode {
                    center,
                    radius,
                    first_child: n.first_child,
                    child_count: n.child_count,
                    parent: n.parent.unwrap_or(crate::bvh::INVALID),
                    sphere: n.leaf_sphere.unwrap_or(crate::bvh::INVALID),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::random_spheres;
    use engine_math::rng::Pcg32;

    fn check(h: &SphereHierarchy, spheres: &[Sphere]) {
        let mut seen = vec![0u32; h.nodes().len()];
        let mut stack = vec![0u32];
        assert!(h.nodes()[0].parent.is_none());
        while let Some(v) = stack.pop() {
            seen[v as usize] += 1;
            let node = &h.nodes()[v as usize];
            for c in h.children(v) {
                let child = &h.nodes()[c as usize];
                assert_eq!(child.parent, Some(v));
                assert!(child.level < node.level);
                // Bounding radius computed as max(|P − c| + r) then compared the same way: 1e-12 slack
                // for rounding on a scene of size ~10.
                assert!(node.sphere.contains_sphere(&child.sphere, 1e-12), "{v} ⊅ {c}");
                stack.push(c);
            }
            if node.child_count == 0 {
                assert_eq!(node.sphere, spheres[node.leaf_sphere.unwrap() as usize]);
            }
        }
        assert!(seen.iter().all(|&c| c == 1), "every node reachable exactly once");
        assert_eq!(h.leaves_under(0), (0..spheres.len() as u32).collect::<Vec<_>>());
    }

    #[test]
    fn hierarchy_invariants_and_branching() {
        let mut rng = Pcg32::new(21, 1);
        for n in [1usize, 2, 4, 5, 16, 64, 244] {
            let spheres = random_spheres(&mut rng, n);
            let h = SphereHierarchy::build(&spheres).unwrap();
            check(&h, &spheres);
            if n >= 16 {
                // ⌈n/4⌉ clusters per level: the mean branching is near 4; Lloyd can leave a few
                // small clusters, so allow 3..4.
                let b = h.mean_branching();
                assert!((3.0..=4.0).contains(&b), "n={n}: mean branching {b}");
            }
        }
        let dup = vec![Sphere::new(DVec3::ONE, 0.25); 13];
        check(&SphereHierarchy::build(&dup).unwrap(), &dup);
        assert!(matches!(SphereHierarchy::build(&[]), Err(BlockerError::NoSpheres)));
        assert!(SphereHierarchy::build(&[Sphere::new(DVec3::ZERO, f64::NAN)]).is_err());
    }

    #[test]
    fn cut_partitions_leaves_and_is_maximal() {
        let mut rng = Pcg32::new(22, 2);
        let spheres = random_spheres(&mut rng, 100);
        let h = SphereHierarchy::build(&spheres).unwrap();
        for _ in 0..40 {
            let receiver = Sphere::new(
                DVec3::new(rng.uniform(-30.0, 30.0), rng.uniform(-30.0, 30.0), rng.uniform(-30.0, 30.0)),
                rng.uniform(0.0, 3.0),
            );
            let theta = rng.uniform(20f64.to_radians(), 30f64.to_radians());
            let cut = h.cut(&receiver, theta);
            let mut leaves: Vec<u32> = cut.iter().flat_map(|&v| h.leaves_under(v)).collect();
            leaves.sort_unstable();
            assert_eq!(leaves, (0..100).collect::<Vec<_>>(), "cut must cover every leaf exactly once");
            for &v in &cut {
                let n = &h.nodes()[v as usize];
                if n.child_count > 0 {
                    assert!(subtends_less_than(&receiver, &n.sphere, theta));
                }
                if let Some(p) = n.parent {
                    assert!(!subtends_less_than(&receiver, &h.nodes()[p as usize].sphere, theta));
                }
            }
        }
    }

    #[test]
    fn refit_keeps_bounds() {
        let mut rng = Pcg32::new(23, 3);
        let mut spheres = random_spheres(&mut rng, 70);
        let mut h = SphereHierarchy::build(&spheres).unwrap();
        for s in &mut spheres {
            s.center += DVec3::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
        }
        h.refit(&spheres).unwrap();
        check(&h, &spheres);
        assert!(h.refit(&spheres[1..]).is_err());
        assert_eq!(std::mem::size_of::<GpuHierarchyNode>(), 32);
        let g = h.gpu_nodes();
        for (g, n) in g.iter().zip(h.nodes()) {
            let c = glam::Vec3::from_array(g.center).as_dvec3();
            assert!(c.distance(n.sphere.center) + n.sphere.radius <= g.radius as f64);
        }
    }
}
