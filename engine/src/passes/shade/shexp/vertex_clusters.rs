//! Receiver clusters of the per-vertex target, and of the per-pixel target under `pixel_clusters=world`
//! (SHEXP §6.3): each instance's vertices split into spatially compact groups of at most `max_size`, no side
//! of whose bounding box is longer than `max_extent`, by recursive median splits along the longest axis of
//! their bounding box (a balanced k-d partition, in place of the paper's Lloyd clustering: every cluster is
//! a compact box, none holds more than the cluster pass's workgroup loops over, and the partition is
//! deterministic). The positions are the world positions of the first `prepare` (the bind pose under each
//! instance's transform, [`world_positions`]); the clusters are sets of vertices, computed once per scene:
//! a cluster follows its instance's rigid motion and, approximately, its skinning, because its bounding
//! sphere is taken from the vertices' current world positions every frame. Static geometry is clustered
//! once like the rest. The extent bound keeps a large, coarsely tessellated mesh (a ground of a few hundred
//! vertices spanning the scene) from becoming one cluster whose bounding sphere holds every blocker.

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

    /// The partition of `vertices` vertices given by its cluster lists (`items[offsets[c] .. offsets[c + 1]]`).
    fn from_lists(offsets: Vec<u32>, items: Vec<u32>, vertices: usize) -> Self {
        let mut cluster_of = vec![0u32; vertices];
        for c in 0..offsets.len() - 1 {
            for &v in &items[offsets[c] as usize..offsets[c + 1] as usize] {
                cluster_of[v as usize] = c as u32;
            }
        }
        Self { offsets, items, cluster_of }
    }
}

/// The fraction of the scene's size (its vertices' bounding-box diagonal) that bounds a cluster's
/// longest side: [`scene_partition`] uses `diagonal / EXTENT_DIVISOR`.
pub const EXTENT_DIVISOR: f32 = 8.0;

/// Partition vertices given as (position, instance index) into clusters of at most `max_size` (≥ 1)
/// vertices of one instance each, split further while a cluster of two or more vertices has a bounding-box
/// side longer than `max_extent` (`f32::INFINITY`: no bound). Non-finite positions sort as the origin.
pub fn partition(vertices: &[([f32; 3], u32)], max_size: usize, max_extent: f32) -> VertexClusters {
    let max_size = max_size.max(1);
    let max_extent = if max_extent > 0.0 { max_extent } else { f32::INFINITY };
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
            let too_many = hi - lo > max_size;
            if !too_many && (hi - lo < 2 || max[axis] - min[axis] <= max_extent) {
                leaves.push((lo, hi));
                continue;
            }
            // Split at a multiple of max_size (at least one full cluster on the left) near the middle, so
            // that the clusters come out as full as the count allows; for the extent alone, at the middle.
            let half = (hi - lo) / 2;
            let mid = if too_many { half.div_ceil(max_size) * max_size } else { half }.min(hi - lo - 1).max(1);
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
    VertexClusters::from_lists(offsets, items, vertices.len())
}

/// Centroids a vertex may move to in one Lloyd step: its cluster's and the nearest others of its instance.
const LLOYD_NEIGHBOURS: usize = 8;

/// Lloyd iterations (the paper's clustering, SHEXP §6.3) started from a partition: every cluster's
/// centroid, then every vertex to the nearest centroid among its cluster's [`LLOYD_NEIGHBOURS`] nearest of
/// the same instance (its own included: the cost stays linear in the vertices), until no vertex moves or
/// `iterations` have run. Clusters that end over `max_size` vertices or `max_extent` a side are split again
/// by [`partition`]'s median rule; emptied ones are dropped. Non-finite positions count as the origin.
pub fn lloyd(
    vertices: &[([f32; 3], u32)],
    start: &VertexClusters,
    max_size: usize,
    max_extent: f32,
    iterations: usize,
) -> VertexClusters {
    let pos = |v: usize| vertices[v].0.map(|x| if x.is_finite() { x as f64 } else { 0.0 });
    let k = start.count();
    let mut assign = start.cluster_of.clone();
    let instance: Vec<u32> = (0..k).map(|c| vertices[start.items[start.offsets[c] as usize] as usize].1).collect();
    let mut by_instance: std::collections::BTreeMap<u32, Vec<usize>> = std::collections::BTreeMap::new();
    for (c, &i) in instance.iter().enumerate() {
        by_instance.entry(i).or_default().push(c);
    }
    let d2 = |a: [f64; 3], b: [f64; 3]| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>();
    for _ in 0..iterations {
        let mut sum = vec![[0f64; 3]; k];
        let mut count = vec![0usize; k];
        for (v, &c) in assign.iter().enumerate() {
            let p = pos(v);
            for a in 0..3 {
                sum[c as usize][a] += p[a];
            }
            count[c as usize] += 1;
        }
        let centre: Vec<[f64; 3]> = (0..k).map(|c| sum[c].map(|x| x / count[c].max(1) as f64)).collect();
        let mut near: Vec<Vec<usize>> = vec![Vec::new(); k];
        for group in by_instance.values() {
            for &c in group.iter().filter(|&&c| count[c] > 0) {
                let mut others: Vec<usize> = group.iter().copied().filter(|&o| count[o] > 0).collect();
                others.sort_by(|&a, &b| d2(centre[a], centre[c]).total_cmp(&d2(centre[b], centre[c])).then(a.cmp(&b)));
                others.truncate(LLOYD_NEIGHBOURS);
                near[c] = others;
            }
        }
        let mut moved = 0usize;
        for (v, c) in assign.iter_mut().enumerate() {
            let p = pos(v);
            let best = near[*c as usize]
                .iter()
                .copied()
                .min_by(|&a, &b| d2(p, centre[a]).total_cmp(&d2(p, centre[b])).then(a.cmp(&b)))
                .unwrap_or(*c as usize) as u32;
            if best != *c {
                *c = best;
                moved += 1;
            }
        }
        if moved == 0 {
            break;
        }
    }
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); k];
    for (v, &c) in assign.iter().enumerate() {
        members[c as usize].push(v as u32);
    }
    let mut offsets = vec![0u32];
    let mut items = Vec::with_capacity(vertices.len());
    for m in members.into_iter().filter(|m| !m.is_empty()) {
        let sub: Vec<([f32; 3], u32)> = m.iter().map(|&v| (vertices[v as usize].0, 0)).collect();
        let split = partition(&sub, max_size, max_extent);
        for c in 0..split.count() {
            items.extend(
                split.items[split.offsets[c] as usize..split.offsets[c + 1] as usize].iter().map(|&i| m[i as usize]),
            );
            offsets.push(items.len() as u32);
        }
    }
    VertexClusters::from_lists(offsets, items, vertices.len())
}

/// World positions of object-space vertices (`position`, instance) under the instances' column-major model
/// matrices (`models[instance]`; an instance without one keeps its object-space position).
pub fn world_positions(vertices: &[([f32; 3], u32)], models: &[[f32; 16]]) -> Vec<([f32; 3], u32)> {
    vertices
        .iter()
        .map(|&(p, inst)| {
            let Some(m) = models.get(inst as usize) else { return (p, inst) };
            (glam::Mat4::from_cols_array(m).transform_point3(glam::Vec3::from(p)).to_array(), inst)
        })
        .collect()
}

/// Lloyd iterations run by `vertex_clusters=lloyd` (at most; they stop when no vertex moves).
pub const LLOYD_ITERATIONS: usize = 10;

/// The partition the technique uses: [`partition`] of the world positions with `max_extent` the scene's
/// bounding-box diagonal over [`EXTENT_DIVISOR`], refined by [`LLOYD_ITERATIONS`] of [`lloyd`] when `lloyd`.
pub fn scene_partition(world: &[([f32; 3], u32)], max_size: usize, lloyd_refine: bool) -> VertexClusters {
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for (p, _) in world.iter().filter(|(p, _)| p.iter().all(|x| x.is_finite())) {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let diagonal = (0..3).map(|a| (hi[a] - lo[a]).max(0.0).powi(2)).sum::<f32>().sqrt();
    let kd = partition(world, max_size, diagonal / EXTENT_DIVISOR);
    if lloyd_refine {
        lloyd(world, &kd, max_size, diagonal / EXTENT_DIVISOR, LLOYD_ITERATIONS)
    } else {
        kd
    }
}

/// Per cluster, how far the pixels of its triangles may lie from its vertices (`pixel_clusters=world`: a
/// pixel belongs to the cluster of its triangle's first vertex): the largest distance, over the triangles
/// (`indices`, three per triangle) whose first vertex is in the cluster, from that vertex to the
/// triangle's other two. The cluster pass grows the bounding sphere of the cluster's vertices by it, so
/// that it holds every such triangle.
pub fn pixel_reach(world: &[([f32; 3], u32)], indices: &[u32], clusters: &VertexClusters) -> Vec<f32> {
    let mut reach = vec![0f32; clusters.count()];
    let finite = |p: [f32; 3]| p.iter().all(|x| x.is_finite());
    for t in indices.chunks_exact(3) {
        let (Some(a), Some(b), Some(c)) =
            (world.get(t[0] as usize), world.get(t[1] as usize), world.get(t[2] as usize))
        else {
            continue;
        };
        if !(finite(a.0) && finite(b.0) && finite(c.0)) {
            continue;
        }
        let d = |q: [f32; 3]| (0..3).map(|k| (q[k] - a.0[k]).powi(2)).sum::<f32>().sqrt();
        if let Some(r) = clusters.cluster_of.get(t[0] as usize).and_then(|&k| reach.get_mut(k as usize)) {
            *r = r.max(d(b.0)).max(d(c.0));
        }
    }
    reach
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
        let c = partition(&v, 256, f32::INFINITY);
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
        assert_eq!(partition(&[], 16, 1.0).count(), 0);
        let same = vec![([1.0, 2.0, 3.0], 0u32); 1000];
        let c = partition(&same, 64, 0.0);
        assert_eq!(c.items.len(), 1000);
        assert!((0..c.count()).all(|k| c.offsets[k + 1] - c.offsets[k] <= 64));
        let nan = vec![([f32::NAN, 0.0, f32::INFINITY], 3u32); 10];
        assert_eq!(partition(&nan, 0, 1.0).count(), 10, "max_size 0 acts as 1");
    }

    #[test]
    fn the_extent_bound_splits_a_large_coarse_mesh() {
        // A 17 × 17 ground of 16 units: by count alone one cluster of 256 and a strip of 33.
        let ground = grid(17, 0, 0.0);
        assert_eq!(partition(&ground, 256, f32::INFINITY).count(), 2);
        let c = partition(&ground, 256, 2.0);
        for k in 0..c.count() {
            let m = &c.items[c.offsets[k] as usize..c.offsets[k + 1] as usize];
            for a in [0, 2] {
                let xs = m.iter().map(|&i| ground[i as usize].0[a]);
                let ext = xs.clone().fold(f32::MIN, f32::max) - xs.fold(f32::MAX, f32::min);
                assert!(ext <= 2.0, "cluster {k} spans {ext} along axis {a}");
            }
        }
        assert!(c.count() >= 36, "{} clusters", c.count());
        // scene_partition takes the bound from the diagonal: 16 √2 / 8 ≈ 2.83 here, coarser than 2.
        let s = scene_partition(&ground, 256, false);
        assert!(s.count() > 2 && s.count() <= c.count(), "{} and {} clusters", s.count(), c.count());
    }

    #[test]
    fn lloyd_keeps_the_bounds_and_does_not_spread_the_clusters() {
        // Two instances: a 40 × 40 grid and a stretched 30 × 30 one, as in the partition test.
        let mut v = grid(40, 0, 0.0);
        v.extend(grid(30, 1, 100.0).into_iter().map(|(p, i)| ([p[0] * 3.0, p[1], p[2]], i)));
        let spread = |c: &VertexClusters| {
            (0..c.count())
                .map(|k| {
                    let m = &c.items[c.offsets[k] as usize..c.offsets[k + 1] as usize];
                    let mean = (0..3)
                        .map(|a| m.iter().map(|&i| v[i as usize].0[a] as f64).sum::<f64>() / m.len() as f64)
                        .collect::<Vec<_>>();
                    m.iter()
                        .map(|&i| (0..3).map(|a| (v[i as usize].0[a] as f64 - mean[a]).powi(2)).sum::<f64>())
                        .sum::<f64>()
                })
                .sum::<f64>()
        };
        let kd = partition(&v, 100, 30.0);
        let l = lloyd(&v, &kd, 100, 30.0, LLOYD_ITERATIONS);
        assert_eq!(l.items.len(), v.len());
        let mut seen = vec![false; v.len()];
        for k in 0..l.count() {
            let m = &l.items[l.offsets[k] as usize..l.offsets[k + 1] as usize];
            assert!(!m.is_empty() && m.len() <= 100, "cluster {k}: {}", m.len());
            for &i in m {
                assert!(!seen[i as usize]);
                seen[i as usize] = true;
                assert_eq!(v[i as usize].1, v[m[0] as usize].1, "a cluster spans two instances");
                assert_eq!(l.cluster_of[i as usize], k as u32);
            }
        }
        let (a, b) = (spread(&kd), spread(&l));
        eprintln!(
            "within-cluster squared distances: k-d {a:.0}, Lloyd {b:.0} ({} and {} clusters)",
            kd.count(),
            l.count()
        );
        assert!(b <= a, "Lloyd should not spread the clusters: {b} > {a}");
        // Deterministic, and a degenerate input survives.
        assert_eq!(l, lloyd(&v, &kd, 100, 30.0, LLOYD_ITERATIONS));
        let same = vec![([1.0, 2.0, 3.0], 0u32); 300];
        let c = lloyd(&same, &partition(&same, 64, 1.0), 64, 1.0, 5);
        assert_eq!(c.items.len(), 300);
        assert!((0..c.count()).all(|k| c.offsets[k + 1] - c.offsets[k] <= 64));
    }

    #[test]
    fn world_positions_and_pixel_reach() {
        // Translate by (10, 0, 0) and scale by 2: column-major.
        let mut m = [0f32; 16];
        m[0] = 2.0;
        m[5] = 2.0;
        m[10] = 2.0;
        m[12] = 10.0;
        m[15] = 1.0;
        let w = world_positions(&[([1.0, 2.0, 3.0], 0), ([1.0, 1.0, 1.0], 5)], &[m]);
        assert_eq!(w[0].0, [12.0, 4.0, 6.0]);
        assert_eq!(w[1].0, [1.0, 1.0, 1.0], "no model: unchanged");
        // Two triangles over four vertices in two clusters: the reach is from each triangle's first vertex.
        let v = vec![([0.0, 0.0, 0.0], 0), ([3.0, 0.0, 0.0], 0), ([0.0, 4.0, 0.0], 0), ([0.0, 0.0, 1.0], 0)];
        let clusters = VertexClusters { offsets: vec![0, 2, 4], items: vec![0, 3, 1, 2], cluster_of: vec![0, 1, 1, 0] };
        let reach = pixel_reach(&v, &[0, 1, 2, 1, 2, 99], &clusters);
        assert_eq!(reach, vec![4.0, 0.0], "the second triangle has an index out of range and is skipped");
    }
}
