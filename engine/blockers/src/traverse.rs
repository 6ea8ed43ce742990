//! Bounded-stack traversal of a BVH node array in the device layout ([`GpuBvhNode`]), in f64: the twin
//! of `shaders-glsl/common/bvh.glsl` (same cursor, same push order, same overflow rule), and a
//! structural check of node arrays built on the GPU.
//!
//! Overflow rule (both sides): a node whose two children do not fit on the stack is taken whole, i.e.
//! reported as if it were a leaf of the cut, and the traversal records that it overflowed. Taking the
//! bounding sphere of a subtree instead of its leaves can only add occlusion. With
//! [`STACK_SIZE`] = 64 this never happens on an LBVH (depth ≤ 63, see bvh.glsl).

use crate::bvh::{GpuBvhNode, INVALID};
use crate::geom::{cone_intersects_sphere, Cone, Sphere};
use glam::{DVec3, Vec3};

/// `BVH_STACK_SIZE` of bvh.glsl.
pub const STACK_SIZE: usize = 64;

/// A node's sphere in f64 (exact: every f32 is an f64).
pub fn node_sphere(n: &GpuBvhNode) -> Sphere {
    Sphere::new(Vec3::from_array(n.center).as_dvec3(), n.radius as f64)
}

pub fn is_leaf(n: &GpuBvhNode) -> bool {
    n.left == INVALID
}

/// The cursor of bvh.glsl.
struct Cursor {
    stack: Vec<u32>,
    cap: usize,
    overflowed: bool,
}

impl Cursor {
    fn begin(sphere_count: u32, cap: usize) -> Self {
        let mut stack = Vec::with_capacity(cap.min(STACK_SIZE));
        if sphere_count > 0 {
            stack.push(0);
        }
        Self { stack, cap, overflowed: false }
    }
    fn next(&mut self) -> Option<u32> {
        self.stack.pop()
    }
    fn push_children(&mut self, left: u32, right: u32) -> bool {
        if self.stack.len() + 2 > self.cap {
            self.overflowed = true;
            return false;
        }
        self.stack.push(right);
        self.stack.push(left);
        true
    }
}

/// What a cut visited: node indices in visiting order, and whether the stack overflowed.
#[derive(Clone, Debug, PartialEq)]
pub struct Cut {
    pub nodes: Vec<u32>,
    pub overflowed: bool,
}

/// `bvh_cut` of bvh.glsl: from the root, nodes missing the cone are dropped with their subtrees; a leaf,
/// a node subtending less than θ_max from every receiver point (SHEXP Eq. 36 with `sin_theta_max`), or a
/// node whose children do not fit on a stack of `stack_size` is visited whole; otherwise its children are
/// visited. `sin_theta_max = 0` visits leaves only.
pub fn cut(
    nodes: &[GpuBvhNode],
    sphere_count: u32,
    receiver: &Sphere,
    sin_theta_max: f64,
    cone: &Cone,
    stack_size: usize,
) -> Cut {
    cut_dropping(nodes, sphere_count, receiver, sin_theta_max, |s| !cone_intersects_sphere(cone, s), stack_size)
}

/// [`cut`] with any drop test in place of the cone: a node for which `drop` holds is dropped with its
/// subtree (the receiver-cluster pass of shaders-glsl/shade/shexp/clusters.glsl drops by θ_min only).
pub fn cut_dropping(
    nodes: &[GpuBvhNode],
    sphere_count: u32,
    receiver: &Sphere,
    sin_theta_max: f64,
    drop: impl Fn(&Sphere) -> bool,
    stack_size: usize,
) -> Cut {
    let mut c = Cursor::begin(sphere_count, stack_size);
    let mut out = Vec::new();
    while let Some(v) = c.next() {
        let n = &nodes[v as usize];
        let s = node_sphere(n);
        if drop(&s) {
            continue;
        }
        let small = s.radius < sin_theta_max * (receiver.center.distance(s.center) - receiver.radius);
        if is_leaf(n) || small || !c.push_children(n.left, n.right) {
            out.push(v);
        }
    }
    Cut { nodes: out, overflowed: c.overflowed }
}

/// The leaves below node `v` in visiting order (a node whose children do not fit on a stack of
/// `stack_size` is taken whole), those for which `drop` holds left out, subtrees included.
pub fn leaves_under(nodes: &[GpuBvhNode], v: u32, drop: impl Fn(&Sphere) -> bool, stack_size: usize) -> Vec<u32> {
    let mut c = Cursor { stack: vec![v], cap: stack_size, overflowed: false };
    let mut out = Vec::new();
    while let Some(u) = c.next() {
        let n = &nodes[u as usize];
        if drop(&node_sphere(n)) {
            continue;
        }
        if is_leaf(n) || !c.push_children(n.left, n.right) {
            out.push(u);
        }
    }
    out
}

/// Input sphere indices of the leaves whose spheres intersect `cone` (sorted).
pub fn cone_leaves(nodes: &[GpuBvhNode], sphere_count: u32, cone: &Cone) -> Vec<u32> {
    let mut out: Vec<u32> = cut(nodes, sphere_count, &Sphere::new(DVec3::ZERO, 0.0), 0.0, cone, usize::MAX)
        .nodes
        .iter()
        .map(|&v| nodes[v as usize].sphere)
        .collect();
    out.sort_unstable();
    out
}

/// Input sphere indices of the leaves containing `p` (boundary included; sorted).
pub fn containing(nodes: &[GpuBvhNode], sphere_count: u32, p: DVec3) -> Vec<u32> {
    let mut c = Cursor::begin(sphere_count, usize::MAX);
    let mut out = Vec::new();
    while let Some(v) = c.next() {
        let n = &nodes[v as usize];
        if !node_sphere(n).contains_point(p) {
            continue;
        }
        if is_leaf(n) {
            out.push(n.sphere);
        } else {
            c.push_children(n.left, n.right);
        }
    }
    out.sort_unstable();
    out
}

/// Checks a node array for `sphere_count` spheres: 2n − 1 nodes; root 0 without parent; parent links
/// consistent; every node reachable exactly once from the root; leaves exactly the nodes n − 1 ..
/// 2n − 2 holding each input sphere once, equal to `spheres` (as given to the build) within `tol`;
/// every child inside its parent with absolute slack `tol`. Returns the depth (edges on the longest path).
pub fn validate_nodes(nodes: &[GpuBvhNode], spheres: &[[f32; 4]], tol: f64) -> Result<usize, String> {
    let n = spheres.len();
    if n == 0 {
        return Ok(0);
    }
    if nodes.len() < 2 * n - 1 {
        return Err(format!("{} nodes for {n} spheres", nodes.len()));
    }
    let nodes = &nodes[..2 * n - 1];
    if nodes[0].parent != INVALID {
        return Err("root has a parent".into());
    }
    let mut seen = vec![0u32; nodes.len()];
    let mut sphere_seen = vec![false; n];
    let mut stack = vec![(0u32, 0usize)];
    let mut depth = 0;
    while let Some((v, d)) = stack.pop() {
        depth = depth.max(d);
        let node = nodes.get(v as usize).ok_or(format!("link to node {v} out of range"))?;
        seen[v as usize] += 1;
        if seen[v as usize] > 1 {
            return Err(format!("node {v} reached twice"));
        }
        if node.radius.is_nan() || node.radius < 0.0 || !Vec3::from_array(node.center).is_finite() {
            return Err(format!("node {v} has a bad sphere {:?} r {}", node.center, node.radius));
        }
        if is_leaf(node) {
            if (v as usize) < n - 1 {
                return Err(format!("internal index {v} is a leaf"));
            }
            let s = node.sphere as usize;
            if s >= n || sphere_seen[s] {
                return Err(format!("leaf {v} holds sphere {s} (out of range or twice)"));
            }
            sphere_seen[s] = true;
            let want = spheres[s];
            let shift =
                Vec3::from_array(node.center).as_dvec3().distance(Vec3::new(want[0], want[1], want[2]).as_dvec3());
            let error = shift + (node.radius as f64 - want[3] as f64).abs();
            if error.is_nan() || error > tol {
                return Err(format!("leaf {v} sphere {:?} r {} differs from input {want:?}", node.center, node.radius));
            }
        } else {
            if (v as usize) >= n - 1 || node.right == INVALID || node.sphere != INVALID {
                return Err(format!("node {v} is malformed: {node:?}"));
            }
            let parent = node_sphere(node);
            for ch in [node.left, node.right] {
                let child = nodes.get(ch as usize).ok_or(format!("node {v}: child {ch} out of range"))?;
                if child.parent != v {
                    return Err(format!("node {ch} has parent {} but is a child of {v}", child.parent));
                }
                let cs = node_sphere(child);
                let out = parent.center.distance(cs.center) + cs.radius - parent.radius;
                if out > tol {
                    return Err(format!("child {ch} pokes out of node {v} by {out:e} (tolerance {tol:e})"));
                }
                stack.push((ch, d + 1));
            }
        }
    }
    if let Some(v) = seen.iter().position(|&c| c != 1) {
        return Err(format!("node {v} is not reachable from the root"));
    }
    Ok(depth)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::SphereBvh;
    use crate::test_util::random_spheres;
    use engine_math::rng::Pcg32;

    fn f32_spheres(s: &[Sphere]) -> Vec<[f32; 4]> {
        s.iter().map(|s| s.to_array().map(|x| x as f32)).collect()
    }

    #[test]
    fn twin_queries_equal_the_reference_bvh() {
        let mut rng = Pcg32::new(21, 7);
        // Spheres exactly representable in f32, so the CPU node array and the f64 BVH agree on leaves.
        let spheres: Vec<Sphere> =
            f32_spheres(&random_spheres(&mut rng, 90)).iter().map(|a| Sphere::from_array(a.map(f64::from))).collect();
        let bvh = SphereBvh::build(&spheres).unwrap();
        let nodes = bvh.gpu_nodes();
        // The CPU array rounds leaf radii up (conservative f32), by far less than 1e-5 here.
        validate_nodes(&nodes, &f32_spheres(&spheres), 1e-5).unwrap();
        for _ in 0..200 {
            let p = DVec3::new(rng.uniform(-6.0, 6.0), rng.uniform(-6.0, 6.0), rng.uniform(-6.0, 6.0));
            assert_eq!(containing(&nodes, 90, p), bvh.spheres_containing(p));
            let cone = Cone::new(p, DVec3::from_array(rng.unit_vector()), rng.uniform(0.0, 1.0));
            assert_eq!(cone_leaves(&nodes, 90, &cone), bvh.cone_query(&cone));
            let theta = rng.uniform(0.05, 0.6);
            let receiver = Sphere::new(p, rng.uniform(0.0, 0.5));
            let full = cut(&nodes, 90, &receiver, theta.sin(), &cone, STACK_SIZE);
            assert!(!full.overflowed);
            assert_eq!(full.nodes, bvh.cut(&receiver, theta, Some(&cone)));
        }
    }

    #[test]
    fn overflow_takes_nodes_whole_and_stays_a_partition() {
        let mut rng = Pcg32::new(22, 8);
        let spheres = random_spheres(&mut rng, 200);
        let bvh = SphereBvh::build(&spheres).unwrap();
        let nodes = bvh.gpu_nodes();
        let everything = Cone::new(DVec3::splat(100.0), DVec3::X, std::f64::consts::PI);
        let receiver = Sphere::new(DVec3::ZERO, 0.0);
        let small = cut(&nodes, 200, &receiver, 0.0, &everything, 4);
        assert!(small.overflowed, "a 4-entry stack must overflow on 200 leaves");
        let mut leaves: Vec<u32> = small.nodes.iter().flat_map(|&v| bvh.leaves_under(v)).collect();
        leaves.sort_unstable();
        assert_eq!(leaves, (0..200).collect::<Vec<_>>(), "overflow keeps every leaf covered exactly once");
        assert!(!cut(&nodes, 200, &receiver, 0.0, &everything, STACK_SIZE).overflowed);
        assert!(cut(&nodes, 0, &receiver, 0.0, &everything, STACK_SIZE).nodes.is_empty());
    }

    #[test]
    fn validate_catches_broken_arrays() {
        let mut rng = Pcg32::new(23, 9);
        let spheres = random_spheres(&mut rng, 10);
        let f = f32_spheres(&spheres);
        let good = SphereBvh::build(&spheres).unwrap().gpu_nodes();
        let mut shrunk = good.clone();
        shrunk[0].radius *= 0.5;
        assert!(validate_nodes(&shrunk, &f, 1e-6).is_err());
        let mut relinked = good.clone();
        relinked[0].left = relinked[0].right;
        assert!(validate_nodes(&relinked, &f, 1e-6).is_err());
        let mut moved = good.clone();
        moved[9].center[0] += 1.0;
        assert!(validate_nodes(&moved, &f, 1e-6).is_err());
    }
}
