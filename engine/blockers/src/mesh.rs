//! Triangle meshes for fitting: loading (OBJ via `tobj`), validation, a content hash, and
//! generalized winding numbers (Jacobson et al. 2013) for inside tests on meshes with holes.

use crate::BlockerError;
use glam::DVec3;
use std::f64::consts::PI;
use std::path::Path;

/// An indexed triangle mesh in f64. Construct with [`Mesh::new`] or [`Mesh::load_obj`], which
/// validate: at least one triangle, finite positions, indices in range, not every triangle degenerate.
/// Individual degenerate triangles are allowed (they subtend no solid angle and have no area).
#[derive(Clone, Debug)]
pub struct Mesh {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn new(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<Self, BlockerError> {
        if triangles.is_empty() || positions.is_empty() {
            return Err(BlockerError::EmptyMesh);
        }
        if let Some(vertex) = positions.iter().position(|p| !p.is_finite()) {
            return Err(BlockerError::NonFinitePosition { vertex, position: positions[vertex].to_array() });
        }
        for (triangle, t) in triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(BlockerError::IndexOutOfRange { triangle, index, vertex_count: positions.len() });
            }
        }
        let mesh = Self { positions, triangles };
        let extent = mesh.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length());
        let total_area: f64 = (0..mesh.triangles.len()).map(|t| mesh.triangle_area(t)).sum();
        // Written so that a NaN area also fails.
        if total_area.partial_cmp(&(1e-24 * extent * extent)) != Some(std::cmp::Ordering::Greater) {
            return Err(BlockerError::DegenerateMesh);
        }
        Ok(mesh)
    }

    /// Loads every model of an OBJ file (positions and faces only; polygons are triangulated). The file is read
    /// through `engine_io` (a regular file of at most `Limit::MESH`; its `.mtl` is not read) and a panic of the
    /// `tobj` parser is contained quietly as an error.
    pub fn load_obj(path: &Path) -> Result<Self, BlockerError> {
        let obj_err = |message: String| BlockerError::Obj { path: path.display().to_string(), message };
        let bytes = engine_io::read(path, engine_io::Limit::MESH).map_err(|e| obj_err(e.message()))?;
        let options = tobj::LoadOptions { triangulate: true, single_index: false, ..Default::default() };
        let no_materials = |_: &Path| -> tobj::MTLLoadResult { Err(tobj::LoadError::OpenFileFailed) };
        let (models, _) = engine_io::catch_quiet(|| tobj::load_obj_buf(&mut &bytes[..], &options, no_materials))
            .map_err(|_| obj_err("the OBJ parser panicked on it".into()))?
            .map_err(|e| obj_err(e.to_string()))?;
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for model in &models {
            let base = positions.len() as u32;
            let m = &model.mesh;
            positions.extend(m.positions.chunks_exact(3).map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)));
            triangles.extend(m.indices.chunks_exact(3).map(|t| [base + t[0], base + t[1], base + t[2]]));
        }
        Self::new(positions, triangles).map_err(|e| match e {
            BlockerError::EmptyMesh => {
                BlockerError::Obj { path: path.display().to_string(), message: "no triangles (empty mesh)".into() }
            }
            other => other,
        })
    }

    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    pub fn triangle(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    pub fn triangle_area(&self, t: usize) -> f64 {
        let [a, b, c] = self.triangle(t);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Axis-aligned bounds of the vertices used by triangles.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let mut it = self.triangles.iter().flatten().map(|&i| self.positions[i as usize]);
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
    }

    /// FNV-1a 64 over the little-endian bytes of the vertex count, every position's f64 bits and
    /// every index: identifies the geometry (not the file's formatting). Written `fnv1a64:<16 hex>`.
    pub fn content_hash(&self) -> String {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h ^= b as u64;
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        eat(&(self.positions.len() as u64).to_le_bytes());
        for p in &self.positions {
            for c in p.to_array() {
                eat(&c.to_bits().to_le_bytes());
            }
        }
        for t in &self.triangles {
            for i in t {
                eat(&i.to_le_bytes());
            }
        }
        format!("fnv1a64:{h:016x}")
    }

    /// A simplification with at most about `max_triangles` triangles by vertex clustering (Rossignac & Borrel
    /// 1993): the vertices are binned on a uniform grid over the bounds, each occupied cell becomes one vertex (the
    /// mean of its own), and triangles whose corners fall in fewer than three cells are dropped. The grid is
    /// coarsened until the count fits. Returns the simplified mesh, its grid's cell size and, per vertex of this
    /// mesh, the vertex of the simplification that stands for it (within one cell diagonal). Deterministic;
    /// O(n) per trial grid. `None` when no grid leaves a triangle (the mesh is smaller than a cell everywhere).
    pub fn simplified(&self, max_triangles: usize) -> Option<(Mesh, f64, Vec<u32>)> {
        let (lo, hi) = self.bounds()?;
        let extent = (hi - lo).max_element().max(1e-300);
        // A closed surface of T triangles on a grid of side R keeps about 4 R² of them (two per occupied face
        // cell): start there and coarsen by the square root of the excess.
        let mut resolution = ((max_triangles as f64 / 4.0).sqrt().ceil() as usize).max(2);
        loop {
            let h = extent / resolution as f64;
            let cell = |p: DVec3| {
                let g = ((p - lo) / h).floor().as_uvec3().min(glam::UVec3::splat(resolution as u32));
                (g.z as u64 * (resolution as u64 + 1) + g.y as u64) * (resolution as u64 + 1) + g.x as u64
            };
            let mut index: std::collections::HashMap<u64, u32> = std::collections::HashMap::new();
            let mut sums: Vec<(DVec3, u32)> = Vec::new();
            let mut map = Vec::with_capacity(self.positions.len());
            for &p in &self.positions {
                let k = *index.entry(cell(p)).or_insert_with(|| {
                    sums.push((DVec3::ZERO, 0));
                    (sums.len() - 1) as u32
                });
                sums[k as usize].0 += p;
                sums[k as usize].1 += 1;
                map.push(k);
            }
            let mut triangles: Vec<[u32; 3]> = self
                .triangles
                .iter()
                .map(|t| t.map(|i| map[i as usize]))
                .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
                .collect();
            // Two triangles on the same three cells with the same orientation are one.
            triangles.sort_unstable_by_key(|t| {
                let r = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
                [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]
            });
            triangles.dedup_by_key(|t| {
                let r = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
                [t[r], t[(r + 1) % 3], t[(r + 2) % 3]]
            });
            if triangles.len() <= max_triangles || resolution <= 2 {
                let positions = sums.iter().map(|(s, n)| *s / *n as f64).collect();
                return Mesh::new(positions, triangles).ok().map(|m| (m, h * 3f64.sqrt(), map));
            }
            let shrink = (max_triangles as f64 / triangles.len() as f64).sqrt() * 0.95;
            resolution = ((resolution as f64 * shrink).floor() as usize).clamp(2, resolution - 1);
        }
    }

    /// Generalized winding number at `p` by direct summation over all triangles (the reference;
    /// O(triangles)). 1 inside a closed outward-oriented mesh, 0 outside, fractional near holes.
    pub fn winding_number_exact(&self, p: DVec3) -> f64 {
        (0..self.triangles.len()).map(|t| triangle_solid_angle(self.triangle(t), p)).sum::<f64>() / (4.0 * PI)
    }
}

/// Signed solid angle of triangle `tri` seen from `p` (Van Oosterom & Strackee 1983):
/// `tan(Ω/2) = a·(b×c) / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|)` with a, b, c relative to p.
/// atan2 keeps the sign and the full range (−2π, 2π).
pub fn triangle_solid_angle(tri: [DVec3; 3], p: DVec3) -> f64 {
    let (a, b, c) = (tri[0] - p, tri[1] - p, tri[2] - p);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

#[cfg(test)]
thread_local! {
    /// Centroid reads of the tree's median splits (tests count the build's work with it).
    static READS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// A tree over the triangles that evaluates generalized winding numbers in roughly O(log n) per
/// point: clusters far from the query (distance > `BETA` × cluster radius) are replaced by their
/// dipole term `N·(x̄ − p) / |x̄ − p|³` with N the summed area vector (the first-order far field of
/// Barnes–Hut winding numbers, Barber et al. 2018); near clusters are summed exactly.
pub struct WindingTree<'a> {
    mesh: &'a Mesh,
    nodes: Vec<WindingNode>,
    order: Vec<u32>,
}

struct WindingNode {
    centroid: DVec3,
    radius: f64,
    area_vector: DVec3,
    /// Range into `order` for leaves; children indices for inner nodes.
    start: u32,
    count: u32,
    children: [u32; 2],
    leaf: bool,
}

impl<'a> WindingTree<'a> {
    /// β = 4 keeps the dipole truncation error per cluster near (1/4)² of its solid angle; measured
    /// maximum deviation from the exact sum at 300 random points around the bunny: 9.8e-3 (β = 3 gave
    /// 2.2e-2).
    const BETA: f64 = 4.0;
    const LEAF: usize = 8;

    pub fn new(mesh: &'a Mesh) -> Self {
        let mut order: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
        let centroids: Vec<DVec3> = (0..mesh.triangles.len())
            .map(|t| {
                let [a, b, c] = mesh.triangle(t);
                (a + b + c) / 3.0
            })
            .collect();
        let mut tree = Self { mesh, nodes: Vec::new(), order: Vec::new() };
        tree.build(&mut order, 0, &centroids);
        tree.order = order;
        tree
    }

    fn build(&mut self, order: &mut [u32], start: usize, centroids: &[DVec3]) -> u32 {
        let mesh = self.mesh;
        let mut area_vector = DVec3::ZERO;
        let mut weighted = DVec3::ZERO;
        let mut area = 0.0;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &t in order.iter() {
            let [a, b, c] = mesh.triangle(t as usize);
            let n = 0.5 * (b - a).cross(c - a);
            area_vector += n;
            weighted += centroids[t as usize] * n.length();
            area += n.length();
            for v in [a, b, c] {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        let centroid = if area > 0.0 { weighted / area } else { 0.5 * (lo + hi) };
        let radius =
            order.iter().flat_map(|&t| mesh.triangle(t as usize)).map(|v| v.distance(centroid)).fold(0.0, f64::max);
        let index = self.nodes.len() as u32;
        self.nodes.push(WindingNode {
            centroid,
            radius,
            area_vector,
            start: start as u32,
            count: order.len() as u32,
            children: [0, 0],
            leaf: true,
        });
        if order.len() > Self::LEAF {
            // A median split needs the halves, not a sorted range: selection is O(n) per node, so the whole
            // build is O(n log n) in the triangle count (a full sort per node made it O(n log² n): a
            // 3-million-face mesh spent minutes here, silently). Ties are broken by the triangle index, so the
            // split is deterministic.
            let axis = (hi - lo).max_position();
            let mid = order.len() / 2;
            order.select_nth_unstable_by(mid, |&a, &b| {
                #[cfg(test)]
                READS.with(|r| r.set(r.get() + 2));
                centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis]).then(a.cmp(&b))
            });
            let (left, right) = order.split_at_mut(mid);
            let l = self.build(left, start, centroids);
            let r = self.build(right, start + mid, centroids);
            let node = &mut self.nodes[index as usize];
            node.children = [l, r];
            node.leaf = false;
        }
        index
    }

    /// Generalized winding number at `p` (approximate far field, exact near field).
    pub fn winding_number(&self, p: DVec3) -> f64 {
        let mut sum = 0.0;
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            let r = node.centroid - p;
            let d = r.length();
            if d > Self::BETA * node.radius {
                sum += node.area_vector.dot(r) / (d * d * d);
            } else if node.leaf {
                for &t in &self.order[node.start as usize..(node.start + node.count) as usize] {
                    sum += triangle_solid_angle(self.mesh.triangle(t as usize), p);
                }
            } else {
                stack.extend_from_slice(&node.children);
            }
        }
        sum / (4.0 * PI)
    }

    /// Inside test: winding number ≥ ½.
    pub fn inside(&self, p: DVec3) -> bool {
        self.winding_number(p) >= 0.5
    }
}

/// A closed, outward-oriented UV sphere (for tests and examples): `rings` ≥ 2, `segments` ≥ 3.
pub fn uv_sphere(center: DVec3, radius: f64, rings: u32, segments: u32) -> Mesh {
    let mut positions = vec![center + DVec3::Y * radius];
    for i in 1..rings {
        let theta = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = 2.0 * PI * j as f64 / segments as f64;
            positions.push(center + radius * DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
        }
    }
    positions.push(center - DVec3::Y * radius);
    let bottom = positions.len() as u32 - 1;
    let ring = |i: u32, j: u32| 1 + i * segments + j % segments;
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(0, j + 1), ring(0, j)]);
        triangles.push([bottom, ring(rings - 2, j), ring(rings - 2, j + 1)]);
    }
    for i in 0..rings - 2 {
        for j in 0..segments {
            triangles.push([ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)]);
            triangles.push([ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)]);
        }
    }
    Mesh { positions, triangles }
}

/// A closed, outward-oriented axis-aligned box (for tests).
pub fn box_mesh(lo: DVec3, hi: DVec3) -> Mesh {
    let positions = (0..8)
        .map(|i| {
            DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        })
        .collect();
    let quads = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let triangles = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    Mesh { positions, triangles }
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine_math::rng::Pcg32;

    /// The tree's set-up grows as O(n log n) with the triangle count n. Counted, not timed (the machine is
    /// shared): the centroid reads of the median splits per triangle must stay within c · log2(n) from 1k to 64k
    /// triangles (a full sort per node, which grows as log2²(n) per triangle, fails this bound).
    #[test]
    fn winding_tree_build_is_n_log_n() {
        let per_triangle = |segments: u32| {
            let mesh = uv_sphere(DVec3::ZERO, 1.0, segments / 2, segments);
            READS.with(|r| r.set(0));
            let tree = WindingTree::new(&mesh);
            assert!(tree.nodes.len() > 1);
            let reads = READS.with(|r| r.get()) as f64;
            let n = mesh.triangles.len() as f64;
            (n, reads / n / n.log2())
        };
        let (n_small, small) = per_triangle(32);
        let (n_large, large) = per_triangle(256);
        eprintln!("reads per triangle per log2(n): {small:.2} at n = {n_small}, {large:.2} at n = {n_large}");
        assert!(n_large > 60.0 * n_small);
        assert!(large < 1.25 * small, "grows faster than n log n: {small:.2} → {large:.2}");
        // The tree answers as the exact sum does.
        let mesh = uv_sphere(DVec3::ZERO, 1.0, 64, 128);
        let tree = WindingTree::new(&mesh);
        for p in [DVec3::ZERO, DVec3::new(0.3, -0.2, 0.5), DVec3::splat(2.0)] {
            assert!((tree.winding_number(p) - mesh.winding_number_exact(p)).abs() < 1e-2, "{p}");
        }
    }

    #[test]
    fn solid_angle_of_closed_meshes_is_4pi_inside_0_outside() {
        let sphere = uv_sphere(DVec3::new(0.1, 0.2, 0.3), 1.0, 12, 16);
        let cube = box_mesh(DVec3::splat(-1.0), DVec3::new(1.0, 2.0, 0.5));
        for mesh in [&sphere, &cube] {
            let (lo, hi) = mesh.bounds().unwrap();
            let c = 0.5 * (lo + hi);
            // Exact by the divergence theorem up to rounding: 1e-12.
            assert!((mesh.winding_number_exact(c) - 1.0).abs() < 1e-12);
            assert!(mesh.winding_number_exact(hi + DVec3::ONE).abs() < 1e-12);
        }
    }

    #[test]
    fn single_triangle_solid_angle_matches_quadrature() {
        // Independent: integrate the ray–triangle hit indicator over the sphere of directions.
        let tri = [DVec3::new(1.0, -0.5, 2.0), DVec3::new(-0.7, 0.2, 1.5), DVec3::new(0.3, 1.0, 1.8)];
        let p = DVec3::new(0.1, 0.1, 0.0);
        let hit = |d: [f64; 3]| {
            let d = DVec3::from_array(d);
            let (e1, e2) = (tri[1] - tri[0], tri[2] - tri[0]);
            let h = d.cross(e2);
            let det = e1.dot(h);
            let s = p - tri[0];
            let u = s.dot(h) / det;
            let q = s.cross(e1);
            let v = d.dot(q) / det;
            let t = e2.dot(q) / det;
            if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 {
                1.0
            } else {
                0.0
            }
        };
        let quad = engine_math::quadrature::integrate_sphere(hit, 8, 64, 1024);
        let exact = triangle_solid_angle(tri, p).abs();
        // Indicator quadrature converges like 1/n at the edges: ~5e-3 sr at this resolution.
        assert!((quad - exact).abs() < 5e-3, "{quad} vs {exact}");
    }

    #[test]
    fn tree_winding_matches_direct_sum_on_bunny() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/meshes/bunny.obj");
        let mesh = Mesh::load_obj(&path).unwrap();
        let tree = WindingTree::new(&mesh);
        let (lo, hi) = mesh.bounds().unwrap();
        let mut rng = Pcg32::new(3, 0);
        let mut worst: f64 = 0.0;
        for _ in 0..300 {
            let p = DVec3::new(rng.uniform(lo.x, hi.x), rng.uniform(lo.y, hi.y), rng.uniform(lo.z, hi.z));
            worst = worst.max((tree.winding_number(p) - mesh.winding_number_exact(p)).abs());
        }
        // Dipole truncation with β = 4: measured 9.8e-3 here; 2e-2 is far from the ½ threshold
        // that the inside test uses while still catching a wrong sign or a missed cluster.
        assert!(worst < 2e-2, "worst {worst}");
    }

    #[test]
    fn bad_meshes_give_errors() {
        assert!(matches!(Mesh::new(vec![], vec![]), Err(BlockerError::EmptyMesh)));
        assert!(matches!(Mesh::new(vec![DVec3::ZERO; 3], vec![]), Err(BlockerError::EmptyMesh)));
        let nan = vec![DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Y];
        assert!(matches!(Mesh::new(nan, vec![[0, 1, 2]]), Err(BlockerError::NonFinitePosition { vertex: 1, .. })));
        let ok = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
        assert!(matches!(
            Mesh::new(ok.clone(), vec![[0, 1, 3]]),
            Err(BlockerError::IndexOutOfRange { triangle: 0, index: 3, .. })
        ));
        assert!(matches!(Mesh::new(vec![DVec3::ONE; 3], vec![[0, 1, 2]]), Err(BlockerError::DegenerateMesh)));
        assert!(Mesh::new(ok, vec![[0, 1, 2]]).is_ok());
        let missing = Mesh::load_obj(Path::new("/nonexistent/mesh.obj"));
        assert!(matches!(missing, Err(BlockerError::Obj { .. })));
    }

    #[test]
    fn content_hash_tracks_geometry() {
        let a = uv_sphere(DVec3::ZERO, 1.0, 6, 8);
        let b = uv_sphere(DVec3::ZERO, 1.0 + 1e-12, 6, 8);
        assert_eq!(a.content_hash(), uv_sphere(DVec3::ZERO, 1.0, 6, 8).content_hash());
        assert_ne!(a.content_hash(), b.content_hash());
        assert!(a.content_hash().starts_with("fnv1a64:"));
    }
}
