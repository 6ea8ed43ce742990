//! Mesh primitives the scenes (and the test fixtures in tests/src/fixtures.rs) are made of.

use engine::scene::Mesh;
use glam::Vec3;

/// A square ground plane of half-size `half` at y = 0, tessellated `n` × `n` (per-vertex shading
/// needs vertices), normal +Y.
pub fn ground_plane(half: f32, n: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let x = -half + 2.0 * half * i as f32 / n as f32;
            let z = -half + 2.0 * half * j as f32 / n as f32;
            positions.push(Vec3::new(x, 0.0, z));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    let normals = vec![Vec3::Y; positions.len()];
    Mesh { name: "ground".into(), positions, normals, indices, material_offsets: Vec::new() }
}

/// A UV sphere of radius 1 with `stacks` × `2·stacks` quads.
pub fn uv_sphere(stacks: u32) -> Mesh {
    let slices = 2 * stacks;
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for j in 0..=stacks {
        let theta = std::f32::consts::PI * j as f32 / stacks as f32;
        for i in 0..=slices {
            let phi = 2.0 * std::f32::consts::PI * i as f32 / slices as f32;
            positions.push(Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
        }
    }
    for j in 0..stacks {
        for i in 0..slices {
            let a = j * (slices + 1) + i;
            let (b, c, d) = (a + 1, a + slices + 1, a + slices + 2);
            if j != 0 {
                indices.extend_from_slice(&[a, b, c]);
            }
            if j != stacks - 1 {
                indices.extend_from_slice(&[b, d, c]);
            }
        }
    }
    let normals = positions.clone();
    Mesh { name: "sphere".into(), positions, normals, indices, material_offsets: Vec::new() }
}

/// A closed swept solid: a circle of radius `radii[i]` around `centers[i]`, in the plane spanned by
/// `frames[i] = (n, b)` (unit, orthogonal, `n × b` pointing along the spine), `segments` vertices per ring,
/// consecutive rings joined by quads. An end whose radius is 0 closes at a pole vertex (a point); one whose
/// radius is positive gets a flat cap with its own vertices (normal along the spine, out of the solid), so the
/// rim stays sharp. Every interior radius must be positive. The side's normals are area-weighted from its
/// triangles; the triangles wind counter-clockwise seen from outside.
fn swept(centers: &[Vec3], radii: &[f32], frames: &[(Vec3, Vec3)], segments: u32, name: &str) -> Mesh {
    let n = centers.len();
    assert!(n >= 2 && radii.len() == n && frames.len() == n && segments >= 3, "swept: bad input");
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    // Vertex index of each ring's first vertex, or of its pole (a ring of radius 0 is one vertex).
    let mut first = Vec::with_capacity(n);
    for i in 0..n {
        first.push(positions.len() as u32);
        if radii[i] == 0.0 {
            assert!(i == 0 || i == n - 1, "swept: only an end may have radius 0");
            positions.push(centers[i]);
            continue;
        }
        let (nv, bv) = frames[i];
        for j in 0..segments {
            let a = std::f32::consts::TAU * j as f32 / segments as f32;
            positions.push(centers[i] + radii[i] * (a.cos() * nv + a.sin() * bv));
        }
    }
    let pole = |i: usize| radii[i] == 0.0;
    for i in 0..n - 1 {
        for j in 0..segments {
            let k = (j + 1) % segments;
            let (a, b) = (first[i] + j, first[i] + k);
            let (c, d) = (first[i + 1] + j, first[i + 1] + k);
            match (pole(i), pole(i + 1)) {
                (false, false) => indices.extend_from_slice(&[a, b, c, b, d, c]),
                (true, false) => indices.extend_from_slice(&[first[i], d, c]),
                (false, true) => indices.extend_from_slice(&[a, b, first[i + 1]]),
                (true, true) => panic!("swept: two poles in a row"),
            }
        }
    }
    let mut normals = engine::scene::compute_normals(&positions, &indices);
    // Flat caps at the ends with a positive radius.
    for (i, outward) in [(0, -1.0f32), (n - 1, 1.0)] {
        if pole(i) {
            continue;
        }
        let (nv, bv) = frames[i];
        let normal = (outward * nv.cross(bv)).normalize();
        let centre = positions.len() as u32;
        positions.push(centers[i]);
        normals.push(normal);
        for j in 0..segments {
            positions.push(positions[(first[i] + j) as usize]);
            normals.push(normal);
        }
        for j in 0..segments {
            let (a, b) = (centre + 1 + j, centre + 1 + (j + 1) % segments);
            if outward < 0.0 {
                indices.extend_from_slice(&[centre, b, a]);
            } else {
                indices.extend_from_slice(&[centre, a, b]);
            }
        }
    }
    Mesh { name: name.into(), positions, normals, indices, material_offsets: Vec::new() }
}

/// A closed solid of revolution about +Y: the profile `(y, r)` from the bottom up (r ≥ 0 the distance from
/// the axis, positive except possibly at the two ends), revolved with `segments` vertices per ring. Ends of
/// radius 0 close at a point on the axis, others with a flat disc. The profile may turn back (an undercut: y
/// decreasing for a while, as in a cup), as long as it does not cross itself.
pub fn lathe(profile: &[(f32, f32)], segments: u32, name: &str) -> Mesh {
    let centers: Vec<Vec3> = profile.iter().map(|&(y, _)| Vec3::new(0.0, y, 0.0)).collect();
    let radii: Vec<f32> = profile.iter().map(|&(_, r)| r).collect();
    // n = X, b = −Z: n × b = +Y, the spine's direction (fixed, so an undercut keeps the winding).
    let frames = vec![(Vec3::X, Vec3::NEG_Z); profile.len()];
    swept(&centers, &radii, &frames, segments, name)
}

/// A closed tube along the polyline `spine` (at least two points, no two consecutive equal) with radius
/// `radii[i]` at `spine[i]`: rings perpendicular to the spine, their frames carried along it by parallel
/// transport (no twist). Ends as in [`lathe`].
pub fn tube(spine: &[Vec3], radii: &[f32], segments: u32, name: &str) -> Mesh {
    let n = spine.len();
    assert!(n >= 2 && radii.len() == n, "tube: bad input");
    let tangent = |i: usize| (spine[(i + 1).min(n - 1)] - spine[i.saturating_sub(1)]).normalize();
    let t0 = tangent(0);
    let mut nv = t0.any_orthonormal_vector();
    let mut frames = Vec::with_capacity(n);
    for i in 0..n {
        let t = tangent(i);
        nv = (nv - t * t.dot(nv)).normalize();
        // b = t × n makes n × b = t (the spine's direction).
        frames.push((nv, t.cross(nv)));
    }
    swept(spine, radii, &frames, segments, name)
}

/// One mesh holding all of `parts` (their index ranges offset; vertices not shared).
pub fn merge(parts: &[Mesh], name: &str) -> Mesh {
    let mut m = Mesh {
        name: name.into(),
        positions: Vec::new(),
        normals: Vec::new(),
        indices: Vec::new(),
        material_offsets: Vec::new(),
    };
    for p in parts {
        let base = m.positions.len() as u32;
        m.positions.extend_from_slice(&p.positions);
        m.normals.extend_from_slice(&p.normals);
        m.indices.extend(p.indices.iter().map(|i| i + base));
    }
    m
}
