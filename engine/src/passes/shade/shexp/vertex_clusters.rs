//! Receiver clusters of the per-vertex target (SHEXP §6.3): each instance's vertices split, in object space
//! (the bind pose for a skinned mesh), into spatially compact groups of at most `max_size`, by recursive
//! median splits along the longest axis of their bounding box (a balanced k-d partition, in place of the
//! paper's Lloyd clustering: every cluster is a compact box, none holds more than the cluster pass's
//! workgroup loops over, and the partition is deterministic). Computed once per scene: a cluster follows
//! its instance's rigid motion and, approximately, its skinning, because its bounding sphere is taken from
//! the vertices' current world positions every frame. Static geometry is clustered once like the rest.

/// The partition: cluster `c` holds `items[offsets[c] .. offsets[c + 1]]` (vertex indices); `cluster_of[v]`
/// is vertex v's cluster.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexClusters {
    pub offsets: Vec<u32>,
    pub items: Vec<u32>,
    pub cluster_of: Vec<u32>,
}

impl VertexClusters {
    pub fn count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
}

/// Partition vertices given as (object-space position, instance index) into clusters of at most
/// `max_size` (≥ 1) vertices of one instance each. Non-finite positions sort as the origin.
pub fn partition(vertices: &[([f32; 3], u32)], max_size: usize) -> VertexClusters {
    let max_size = max_size.max(1);
    let mut by_instance: std::collections::BTreeMap<u32, Vec<u32>> = std::collections::BTreeMap::new();
    for (v, (_, inst)) in vertices.iter().enumerate() {
        by_instance.entry(*inst).or_default().push(v as u32);
    }
    let pos = |v: u32| vertices[v as usize].0.map(|x| if x.is_finite() { x } else { 0.0 });
    let mut offsets = vec![0u32];
    let mut items = Vec::with_capacity(vertices.len());
    for (_, group) in by_instance {
        // An explicit stack of ranges over `group` keeps the recursion bounded for any input.
        let mut group = group;
        let mut stack = vec![(0usize, group.len())];
        let mut leaves = Vec::new();
        while let Some((lo, hi)) = stack.pop() {
            if hi - lo <= max_size {
                leaves.push((lo, hi));
                continue;
            }
            let slice = &mut group[lo..hi];
            let (mut min, mut max) = ([f32::MAX; 3], [f32::MIN; 3]);
            for &v in slice.iter() {
                let p = pos(v);
                for a in 0..3 {
                    min[a] = min[a].min(p[a]);
                    max[a] = max[a].max(p[a]);
                }
            }
            let axis = (0..3).max_by(|&a, &b| (max[a] - min[a]).total_cmp(&(max[b] - min[b]))).unwrap_or(0);
            // Split at a multiple of max_size (at least one full cluster on the left) near the middle, so
            // that the clusters come out as full as the count allows.
            let half = (hi - lo) / 2;
            let mid = (half.div_ceil(max_size) * max_size).min(hi - lo - 1).max(1);
            slice.select_nth_unstable_by(mid, |&a, &b| pos(a)[axis].total_cmp(&pos(b)[axis]).then(a.cmp(&b)));
            stack.push((lo + mid, hi));
            stack.push((lo, lo + mid));
        }
        leaves.sort_unstable();
        for (lo, hi) in leaves {
            items.extend_from_slice(&group[lo..hi]);
            offsets.push(items.len() as u32);
        }
    }
    let mut cluster_of = vec![0u32; vertices.len()];
    for c in 0..offsets.len() - 1 {
        for &v in &items[offsets[c] as usize..offsets[c + 1] as usize] {
            cluster_of[v as usize] = c as u32;
        }
    }
    VertexClusters { offsets, items, cluster_of }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize, instance: u32, dx: f32) -> Vec<([f32; 3], u32)> {
        (0..n * n).map(|i| ([dx + (i % n) as f32, 0.0, (i / n) as f32], instance)).collect()
    }

    #[test]
    fn every_vertex_once_bounded_sizes_one_instance_each_and_compact() {
        // Two instances whose vertices interleave in the buffer order.
        let mut v = grid(40, 0, 0.0);
        let b = grid(30, 1, 100.0);
        for (k, x) in b.into_iter().enumerate() {
            v.insert(2 * k + 1, x);
        }
        let c = partition(&v, 256);
        assert_eq!(c.items.len(), v.len());
        let mut seen = vec![false; v.len()];
        for k in 0..c.count() {
            let members = &c.items[c.offsets[k] as usize..c.offsets[k + 1] as usize];
            assert!(!members.is_empty() && members.len() <= 256, "cluster {k}: {} members", members.len());
            let inst = v[members[0] as usize].1;
            for &m in members {
                assert!(!seen[m as usize]);
                seen[m as usize] = true;
                assert_eq!(v[m as usize].1, inst, "a cluster spans two instances");
                assert_eq!(c.cluster_of[m as usize], k as u32);
            }
            // Compact: on a unit grid, 256 vertices fit in a box far smaller than the instance.
            let ext = |a: usize| {
                let xs = members.iter().map(|&m| v[m as usize].0[a]);
                xs.clone().fold(f32::MIN, f32::max) - xs.fold(f32::MAX, f32::min)
            };
            assert!(ext(0) < 24.0 && ext(2) < 24.0, "cluster {k}: {} × {}", ext(0), ext(2));
        }
        assert!(seen.iter().all(|s| *s));
        // 1600 + 900 vertices: at least 7 + 4 clusters, and mostly full ones.
        assert!(c.count() >= 11 && c.count() <= 16, "{} clusters", c.count());
    }

    #[test]
    fn degenerate_inputs() {
        assert_eq!(partition(&[], 16).count(), 0);
        let same = vec![([1.0, 2.0, 3.0], 0u32); 1000];
        let c = partition(&same, 64);
        assert_eq!(c.items.len(), 1000);
        assert!((0..c.count()).all(|k| c.offsets[k + 1] - c.offsets[k] <= 64));
        let nan = vec![([f32::NAN, 0.0, f32::INFINITY], 3u32); 10];
        assert_eq!(partition(&nan, 0).count(), 10, "max_size 0 acts as 1");
    }
}
