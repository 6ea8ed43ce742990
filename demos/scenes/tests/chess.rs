//! The `chess` scene (demos/scenes/src/chess.rs), CPU side: the pieces' solids are closed and outward, their
//! blocker spheres number 308 and cover them, the scripted game is the Opera Game and the motion replays it
//! deterministically, captured pieces leaving the board (the GPU side: tests/tests/chess.rs).

use engine::scene::Mesh;
use glam::Vec3;
use scenes::chess::{self, Kind, OPERA_GAME, PERIOD, SQUARE};
use scenes::shapes;
use std::collections::HashMap;

/// Every directed edge (after welding equal positions) appears once, and its reverse once: closed, consistently
/// wound, no edge shared by more than two triangles.
fn assert_closed(m: &Mesh, what: &str) {
    let mut id: HashMap<[u32; 3], u32> = HashMap::new();
    let weld: Vec<u32> = m
        .positions
        .iter()
        .map(|p| {
            let n = id.len() as u32;
            *id.entry(p.to_array().map(f32::to_bits)).or_insert(n)
        })
        .collect();
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in m.indices.chunks_exact(3) {
        let v = [weld[t[0] as usize], weld[t[1] as usize], weld[t[2] as usize]];
        assert!(v[0] != v[1] && v[1] != v[2] && v[0] != v[2], "{what}: degenerate triangle {t:?}");
        for k in 0..3 {
            *edges.entry((v[k], v[(k + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &edges {
        assert_eq!(n, 1, "{what}: edge {a}→{b} used {n} times");
        assert_eq!(edges.get(&(b, a)), Some(&1), "{what}: edge {a}→{b} has no twin (open or flipped)");
    }
}

/// The enclosed volume (divergence theorem): positive when the triangles wind outwards.
fn volume(m: &Mesh) -> f64 {
    m.indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| m.positions[i as usize].as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

fn part_meshes(kind: Kind) -> Vec<Mesh> {
    chess::parts(kind)
        .iter()
        .map(|p| {
            if p.lathe {
                let profile: Vec<(f32, f32)> = p.spine.iter().zip(&p.radii).map(|(c, &r)| (c.y, r)).collect();
                shapes::lathe(&profile, chess::SEGMENTS, "part")
            } else {
                shapes::tube(&p.spine, &p.radii, chess::SEGMENTS, "part")
            }
        })
        .collect()
}

#[test]
fn every_part_is_a_closed_outward_solid() {
    for kind in Kind::ALL {
        let mut total = 0.0;
        for (i, part) in part_meshes(kind).iter().enumerate() {
            let what = format!("{kind:?} part {i}");
            assert_closed(part, &what);
            let v = volume(part);
            assert!(v > 0.0, "{what}: volume {v} (inward winding)");
            total += v;
        }
        // The merged mesh is the parts side by side: closed too, with their volumes (overlaps counted twice).
        let mesh = chess::piece_mesh(kind);
        assert_closed(&mesh, &format!("{kind:?}"));
        assert!((volume(&mesh) - total).abs() < 1e-9, "{kind:?}: merged volume");
        // Normals: unit, and on the outer side of every triangle they belong to (the smooth side normals lean
        // at most 90° from each face at the sharpest profile corners).
        assert_eq!(mesh.normals.len(), mesh.positions.len());
        for t in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| mesh.positions[i as usize]);
            let face = (b - a).cross(c - a).normalize();
            for &i in t {
                let n = mesh.normals[i as usize];
                assert!((n.length() - 1.0).abs() < 1e-4, "{kind:?}: normal {n} not unit");
                assert!(n.dot(face) > 0.0, "{kind:?}: vertex {i}'s normal {n} points inwards of face {face}");
            }
        }
    }
}

#[test]
fn a_lathe_of_a_cylinder_has_the_cylinders_volume() {
    // r = 1, h = 2 with flat caps: π r² h up to the polygon's area (n/2 sin(2π/n) r² per ring).
    let m = shapes::lathe(&[(0.0, 1.0), (1.0, 1.0), (2.0, 1.0)], 64, "cylinder");
    assert_closed(&m, "cylinder");
    let polygon = 32.0 * (std::f64::consts::TAU / 64.0).sin();
    assert!((volume(&m) - 2.0 * polygon).abs() < 1e-5, "{}", volume(&m));
    // A cone closed at a pole: π r² h / 3 likewise.
    let m = shapes::lathe(&[(0.0, 1.0), (3.0, 0.0)], 64, "cone");
    assert_closed(&m, "cone");
    assert!((volume(&m) - polygon).abs() < 1e-5, "{}", volume(&m));
    // A bent tube closes and winds outwards too.
    let spine: Vec<Vec3> = (0..=8).map(|i| Vec3::new((i as f32 * 0.3).sin(), i as f32 * 0.2, 0.0)).collect();
    let m = shapes::tube(&spine, &[0.1; 9], 24, "tube");
    assert_closed(&m, "tube");
    assert!(volume(&m) > 0.0);
}

/// The farthest any vertex of `mesh` lies outside the union of `spheres`.
fn uncovered(mesh: &Mesh, spheres: &[engine::blockers::Sphere], above: f32) -> f64 {
    mesh.positions
        .iter()
        .filter(|p| p.y > above)
        .map(|p| spheres.iter().map(|s| s.center.distance(p.as_dvec3()) - s.radius).fold(f64::MAX, f64::min).max(0.0))
        .fold(0.0, f64::max)
}

#[test]
fn three_hundred_and_eight_spheres_cover_the_pieces() {
    let expected = [
        (Kind::Pawn, 8),
        (Kind::Rook, 10),
        (Kind::Knight, 12),
        (Kind::Bishop, 10),
        (Kind::Queen, 12),
        (Kind::King, 14),
    ];
    for (kind, n) in expected {
        let spheres = chess::piece_spheres(kind);
        assert_eq!(spheres.len(), n, "{kind:?}");
        assert_eq!(kind.sphere_count(), n, "{kind:?}");
        let mesh = chess::piece_mesh(kind);
        for s in &spheres {
            assert!(s.radius > 0.0 && s.center.is_finite(), "{kind:?}: {s:?}");
            // None reaches below the board (it would shadow the squares around the foot).
            assert!(s.center.y - s.radius >= -1e-6, "{kind:?}: {s:?} reaches below the board");
        }
        // Each sphere is as wide as the piece in its slab, so a vertex sticks out at most by the slab's
        // half-height beyond it (sqrt(r² + (w/2)²) − r): measured ≤ 0.01 squares, 0.055 at the ends of the
        // king's cross. The feet stick out further: a sphere that stays above the board cannot reach the rim
        // of a disc lying on it (it would need its centre higher than its radius), measured ≤ 0.22 squares.
        let gap = uncovered(&mesh, &spheres, 0.25 * SQUARE);
        let foot = uncovered(&mesh, &spheres, -1.0);
        eprintln!(
            "{kind:?}: {n} spheres, {} vertices, {} triangles; farthest vertex {:.4} squares outside ({:.4} with the foot)",
            mesh.positions.len(),
            mesh.indices.len() / 3,
            gap / SQUARE as f64,
            foot / SQUARE as f64
        );
        assert!(gap < 0.07 * SQUARE as f64, "{kind:?}: a vertex {gap} outside the spheres");
        assert!(foot < 0.25 * SQUARE as f64, "{kind:?}: a vertex of the foot {foot} outside the spheres");
    }
    let scene = scenes::build("chess", None).unwrap();
    let total: usize = scene.instances.iter().filter_map(|i| scene.blockers.spheres_of(i.mesh)).map(<[_]>::len).sum();
    assert_eq!(total, 308, "leaf spheres in the scene");
    assert_eq!(scene.instances.len(), 35, "32 pieces, the ground and the two colours of squares");
}

#[test]
fn the_script_is_the_opera_game() {
    let r = chess::replay(OPERA_GAME).unwrap();
    let pieces = chess::starting_position();
    // The final position of Morphy – Duke Karl / Count Isouard, Paris 1858 (17. Rd8#).
    let expected = [
        ("c1", Kind::King, true),
        ("d8", Kind::Rook, true),
        ("g5", Kind::Bishop, true),
        ("a2", Kind::Pawn, true),
        ("b2", Kind::Pawn, true),
        ("c2", Kind::Pawn, true),
        ("e4", Kind::Pawn, true),
        ("f2", Kind::Pawn, true),
        ("g2", Kind::Pawn, true),
        ("h2", Kind::Pawn, true),
        ("e8", Kind::King, false),
        ("e6", Kind::Queen, false),
        ("b8", Kind::Knight, false),
        ("f8", Kind::Bishop, false),
        ("h8", Kind::Rook, false),
        ("a7", Kind::Pawn, false),
        ("e5", Kind::Pawn, false),
        ("f7", Kind::Pawn, false),
        ("g7", Kind::Pawn, false),
        ("h7", Kind::Pawn, false),
    ];
    let mut on_board = 0;
    for (f, file) in r.board.iter().enumerate() {
        for (k, sq) in file.iter().enumerate() {
            let Some(p) = *sq else { continue };
            on_board += 1;
            let name = format!("{}{}", (b'a' + f as u8) as char, k + 1);
            let e = expected.iter().find(|e| e.0 == name).unwrap_or_else(|| panic!("a piece on {name}"));
            assert_eq!((pieces[p].kind, pieces[p].white), (e.1, e.2), "{name}");
        }
    }
    assert_eq!(on_board, expected.len());
    assert_eq!(r.captured.len(), 12);
    // Wrong scripts are refused, naming the move.
    for (game, needle) in [
        (&["e7e5"][..], "side to move"),
        (&["e2e4", "e7e5", "e1e2", "d8e8"], "takes its own"),
        (&["e3e4"], "no piece"),
        (&["e2e9"], "bad square"),
        (&["e1g1"], "takes its own"),
        (&["g1h3", "a7a6", "e1g1"], "castling through"),
    ] {
        let err = chess::replay(game).unwrap_err();
        assert!(err.contains(needle), "{game:?}: {err}");
    }
}

#[test]
fn the_motion_replays_the_game_and_loops() {
    let scene = scenes::build("chess", None).unwrap();
    let entry = scenes::find("chess").unwrap();
    let anim = scenes::Animation::for_entry(entry, &scene).expect("chess moves");
    let rest: Vec<_> = scene.instances.iter().map(|i| i.transform).collect();
    let at = |t: f32| {
        let mut m = rest.clone();
        for (i, x) in anim.pose(t).transforms {
            m[i] = x;
        }
        m
    };
    assert_eq!(at(0.0), rest, "t = 0 is the starting position");
    // Deterministic, and periodic: the loop starts again after PERIOD.
    assert_eq!(at(7.3), at(7.3));
    for (a, b) in at(7.3 + PERIOD).iter().zip(at(7.3)) {
        assert!(a.abs_diff_eq(b, 1e-4), "not periodic: {a} vs {b}");
    }
    assert_eq!(at(PERIOD), rest);
    let pieces = chess::starting_position();
    let foot = |m: glam::Mat4| m.w_axis.truncate();
    // 1. e4: the e2 pawn (instance 12) is halfway at the middle of its slide, on e4 after it.
    let e2 = chess::square_centre(4, 1);
    let e4 = chess::square_centre(4, 3);
    let mid = foot(at(chess::START + 0.5 * chess::SLIDE)[12]);
    assert!((mid - 0.5 * (e2 + e4)).length() < 1e-5, "{mid}");
    assert!((foot(at(chess::START + chess::PLY)[12]) - e4).length() < 1e-5);
    // 2. Nf3: the knight (instance 6) hops: above the board in the middle of its move.
    let hop = foot(at(chess::START + 2.0 * chess::PLY + 0.5 * chess::SLIDE)[6]);
    assert!(hop.y > 0.5 * SQUARE, "{hop}");
    // At the end, every piece stands still at its final square or beside the board, none inside another.
    let end = at(PERIOD - 0.1);
    assert_eq!(end, at(PERIOD - 1.0), "the final position holds");
    let r = chess::replay(OPERA_GAME).unwrap();
    for (i, p) in pieces.iter().enumerate() {
        let f = foot(end[i]);
        assert!(f.y.abs() < 1e-6, "{i}: {f}");
        let off_board = f.x.abs() > 4.0 * SQUARE || f.z.abs() > 4.0 * SQUARE;
        assert_eq!(off_board, r.captured.contains(&i), "piece {i} ({p:?}) at {f}");
        for (j, other) in end[..i].iter().enumerate() {
            assert!(foot(*other).distance(f) > 0.9 * SQUARE, "pieces {j} and {i} overlap at {f}");
        }
    }
    // Rigid: the rotation part (the knights' facing) never changes.
    for t in [0.0, 3.3, 12.9, 25.0, 39.0] {
        for (m, r) in at(t).iter().zip(&rest) {
            assert_eq!(glam::Mat3::from_mat4(*m), glam::Mat3::from_mat4(*r));
        }
    }
}
