//! `chess` (ISG Fig. 7, §6: "32 chess pieces and a board", 306 spheres): 32 procedural Staunton-like pieces on a
//! checkered board under the courtyard, 308 blocker spheres along the pieces' axes, the board's ground as a
//! plane blocker; `--animate` replays the Opera Game (Morphy vs. the Duke of Brunswick and Count Isouard, Paris
//! 1858, 17 moves): the pieces slide, knights hop, captured pieces are lifted off to the side of the board.
//!
//! Geometry: every piece is a union of closed swept solids ([`shapes::lathe`], [`shapes::tube`]): pawn, rook,
//! bishop and queen are one lathe each; the king is a lathe and a cross of two tubes; the knight is a lathe
//! base and a tube whose spine (a quadratic Bézier) rises and bends forward into the muzzle (round cross
//! sections: a neck and head, no ears or mane).
//!
//! Blocker spheres ([`piece_spheres`]): each part's extent along its axis (the lathe's y, the tube's arc length)
//! is cut into equal slabs, one sphere per slab, centred on the axis in the slab's middle with the largest
//! radius of the surface within the slab (the silhouette's half width there), capped at the centre's height so
//! that no sphere reaches below the board. Per piece: pawn 8, rook 10, knight 12 (3 base + 9 neck and head),
//! bishop 10, queen 12, king 14 (10 body + 2 + 2 on the cross): 16·8 + 4·(10 + 12 + 10) + 2·(12 + 14) = 308.
//!
//! The checker pattern: the materials have no textures, so the light and the dark squares are two meshes with
//! two materials, at y = 0; under them a larger ground (the table, a third material) at y = −0.002 is the plane
//! blocker. `--brdf` and the viewer's `B` key change the glossy materials 0 and 1, the white and black pieces
//! (diffuse to Blinn-Phong s = 1000+, Cook-Torrance, Ashikhmin–Shirley). The environment turns by events
//! (`--env-rotation`, the viewer's `E` key, `Renderer::set_environment_rotation`), not per animation frame.

use super::{shapes, Motion, Pose, Rest, SceneEntry, SceneInputs};
use engine::blockers::Sphere;
use engine::scene::{load_environment, Camera, Instance, Material, Mesh, Scene, SceneBlockers};
use glam::{Mat4, Vec3};

pub const SCENE: SceneEntry = SceneEntry {
    name: "chess",
    summary: "32 lathe chess pieces on a checkered board (ISG Fig. 7), 308 blocker spheres + the ground plane",
    build,
    motion: Some(Motion {
        summary: "the chess pieces replay the Opera Game (Morphy 1858: slides, hops, captures; a 40 s loop)",
        pose: replay_pose,
    }),
};

/// Side of a board square (world units); the board spans [−4, 4]² squares around the origin.
pub const SQUARE: f32 = 0.25;
/// Vertices per ring of the pieces' solids.
pub const SEGMENTS: u32 = 32;
/// Height of the ground (the table, the plane blocker) under the squares at y = 0.
pub const GROUND_Y: f32 = -0.002;

/// The piece types, in the order of their meshes (mesh index = `kind as usize`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    Pawn,
    Rook,
    Knight,
    Bishop,
    Queen,
    King,
}

impl Kind {
    pub const ALL: [Kind; 6] = [Kind::Pawn, Kind::Rook, Kind::Knight, Kind::Bishop, Kind::Queen, Kind::King];
    /// Blocker spheres per piece of this kind (see the module notes).
    pub fn sphere_count(self) -> usize {
        parts(self).iter().map(|p| p.spheres).sum()
    }
}

/// One closed solid of a piece: rings of `radii[i]` around `spine[i]` (world units, the piece standing at the
/// origin, the knight looking towards +z), and how many blocker spheres it gets.
#[derive(Clone, Debug)]
pub struct Part {
    pub spine: Vec<Vec3>,
    pub radii: Vec<f32>,
    /// A solid of revolution about +Y (its axis coordinate is y), else a tube (arc length along the spine).
    pub lathe: bool,
    pub spheres: usize,
}

/// A lathe part from a profile `(y, r)` in squares.
fn lathe(profile: &[(f32, f32)], spheres: usize) -> Part {
    Part {
        spine: profile.iter().map(|&(y, _)| Vec3::new(0.0, y * SQUARE, 0.0)).collect(),
        radii: profile.iter().map(|&(_, r)| r * SQUARE).collect(),
        lathe: true,
        spheres,
    }
}

/// Append an arc of the circle of radius `rr` around (y = `cy`, r = `cx`) to a profile, from angle `a0` to
/// `a1` (degrees, 0 = outwards, 90 = up), `n` steps: beads and knobs.
fn arc(p: &mut Vec<(f32, f32)>, cy: f32, cx: f32, rr: f32, a0: f32, a1: f32, n: u32) {
    for i in 0..=n {
        let a = (a0 + (a1 - a0) * i as f32 / n as f32).to_radians();
        p.push((cy + rr * a.sin(), (cx + rr * a.cos()).max(0.0)));
    }
    if let Some(last) = p.last_mut() {
        if a1 >= 90.0 && cx == 0.0 {
            last.1 = 0.0;
        }
    }
}

/// The Staunton-like base shared by the pieces: a foot of radius `r` with a bead, narrowing to `waist`.
fn base(r: f32) -> Vec<(f32, f32)> {
    let mut p = vec![(0.0, r), (0.05, r)];
    arc(&mut p, 0.09, r - 0.04, 0.035, -60.0, 90.0, 4);
    p.push((0.14, r - 0.08));
    p.push((0.18, r - 0.12));
    p
}

/// The solids of a piece (world units).
pub fn parts(kind: Kind) -> Vec<Part> {
    match kind {
        Kind::Pawn => {
            let mut p = base(0.30);
            p.extend([(0.24, 0.155), (0.32, 0.13), (0.40, 0.115), (0.45, 0.105), (0.46, 0.17), (0.50, 0.18)]);
            p.extend([(0.53, 0.17), (0.55, 0.11)]);
            arc(&mut p, 0.69, 0.0, 0.15, -45.0, 90.0, 8);
            vec![lathe(&p, 8)]
        }
        Kind::Rook => {
            let mut p = base(0.34);
            p.extend([(0.24, 0.21), (0.40, 0.19), (0.60, 0.185), (0.74, 0.20), (0.77, 0.25), (0.80, 0.26)]);
            // The battlement: a rim around a shallow cup (an undercut profile).
            p.extend([(1.00, 0.26), (1.00, 0.19), (0.92, 0.19), (0.92, 0.0)]);
            vec![lathe(&p, 10)]
        }
        Kind::Bishop => {
            let mut p = base(0.32);
            p.extend([(0.24, 0.18), (0.42, 0.14), (0.60, 0.115), (0.72, 0.105), (0.74, 0.17), (0.77, 0.18)]);
            p.extend([(0.80, 0.17), (0.82, 0.11)]);
            // The mitre (an egg) and its finial.
            p.extend([(0.86, 0.13), (0.92, 0.16), (1.00, 0.175), (1.08, 0.165), (1.15, 0.14), (1.21, 0.10)]);
            p.extend([(1.25, 0.05), (1.26, 0.035)]);
            arc(&mut p, 1.30, 0.0, 0.045, -50.0, 90.0, 5);
            vec![lathe(&p, 10)]
        }
        Kind::Queen => {
            let mut p = base(0.36);
            p.extend([(0.24, 0.22), (0.45, 0.16), (0.70, 0.125), (0.90, 0.11), (0.93, 0.20), (0.96, 0.21)]);
            p.extend([(0.99, 0.20), (1.02, 0.12), (1.10, 0.14), (1.25, 0.20), (1.33, 0.235), (1.36, 0.235)]);
            // The crown's flat top (undercut) and a dome with a ball.
            p.extend([(1.36, 0.16), (1.41, 0.15), (1.44, 0.11), (1.455, 0.05)]);
            arc(&mut p, 1.51, 0.0, 0.055, -40.0, 90.0, 5);
            vec![lathe(&p, 12)]
        }
        Kind::King => {
            let mut p = base(0.37);
            p.extend([(0.24, 0.23), (0.45, 0.17), (0.70, 0.135), (0.95, 0.12), (0.98, 0.21), (1.01, 0.22)]);
            p.extend([(1.04, 0.21), (1.07, 0.13), (1.15, 0.15), (1.30, 0.20), (1.37, 0.215), (1.41, 0.20)]);
            p.extend([(1.44, 0.15), (1.48, 0.11), (1.51, 0.06), (1.53, 0.0)]);
            let bar = |a: Vec3, b: Vec3, spheres| Part {
                spine: (0..=4).map(|i| a.lerp(b, i as f32 / 4.0) * SQUARE).collect(),
                radii: vec![0.035 * SQUARE; 5],
                lathe: false,
                spheres,
            };
            vec![
                lathe(&p, 10),
                bar(Vec3::new(0.0, 1.47, 0.0), Vec3::new(0.0, 1.80, 0.0), 2),
                bar(Vec3::new(-0.11, 1.66, 0.0), Vec3::new(0.11, 1.66, 0.0), 2),
            ]
        }
        Kind::Knight => {
            let mut p = base(0.34);
            p.extend([(0.22, 0.22), (0.26, 0.21)]);
            // Neck and head: a quadratic Bézier spine from inside the base up and forward to the muzzle.
            let (p0, p1, p2) = (Vec3::new(0.0, 0.16, -0.06), Vec3::new(0.0, 1.10, -0.16), Vec3::new(0.0, 0.78, 0.34));
            let radius = |t: f32| {
                let keys = [(0.0, 0.21), (0.3, 0.17), (0.55, 0.155), (0.7, 0.145), (0.85, 0.12), (1.0, 0.075)];
                let k = keys.windows(2).find(|w| t <= w[1].0).unwrap_or(&keys[4..6]);
                let s = (t - k[0].0) / (k[1].0 - k[0].0);
                k[0].1 + s * (k[1].1 - k[0].1)
            };
            let n = 16;
            let ts: Vec<f32> = (0..=n).map(|i| i as f32 / n as f32).collect();
            let spine = ts
                .iter()
                .map(|&t| ((1.0 - t) * (1.0 - t) * p0 + 2.0 * t * (1.0 - t) * p1 + t * t * p2) * SQUARE)
                .collect();
            let head =
                Part { spine, radii: ts.iter().map(|&t| radius(t) * SQUARE).collect(), lathe: false, spheres: 9 };
            vec![lathe(&p, 3), head]
        }
    }
}

/// The mesh of a piece: its parts' closed solids, merged.
pub fn piece_mesh(kind: Kind) -> Mesh {
    let name = format!("{kind:?}").to_lowercase();
    let meshes: Vec<Mesh> = parts(kind)
        .iter()
        .map(|p| {
            if p.lathe {
                let profile: Vec<(f32, f32)> = p.spine.iter().zip(&p.radii).map(|(c, &r)| (c.y, r)).collect();
                shapes::lathe(&profile, SEGMENTS, &name)
            } else {
                shapes::tube(&p.spine, &p.radii, SEGMENTS, &name)
            }
        })
        .collect();
    shapes::merge(&meshes, &name)
}

/// The blocker spheres of a piece (object space = the piece at the origin), fitted as the module notes say.
pub fn piece_spheres(kind: Kind) -> Vec<Sphere> {
    parts(kind).iter().flat_map(part_spheres).collect()
}

fn part_spheres(part: &Part) -> Vec<Sphere> {
    // Dense samples (axis coordinate, centre on the axis, radius) of the part's profile: the rings and 16
    // points between consecutive rings, so that a slab narrower than a ring spacing still sees the surface.
    let mut samples: Vec<(f32, Vec3, f32)> = Vec::new();
    let mut s = 0.0;
    for i in 0..part.spine.len() - 1 {
        let (a, b) = (part.spine[i], part.spine[i + 1]);
        for k in 0..16 {
            let f = k as f32 / 16.0;
            let c = a.lerp(b, f);
            let axis = if part.lathe { c.y } else { s + f * a.distance(b) };
            samples.push((axis, c, part.radii[i] + f * (part.radii[i + 1] - part.radii[i])));
        }
        s += a.distance(b);
    }
    let last = *part.spine.last().expect("a part has a spine");
    samples.push((if part.lathe { last.y } else { s }, last, *part.radii.last().expect("radii")));
    let lo = samples.iter().map(|x| x.0).fold(f32::MAX, f32::min);
    let hi = samples.iter().map(|x| x.0).fold(f32::MIN, f32::max);
    let width = (hi - lo) / part.spheres as f32;
    (0..part.spheres)
        .map(|k| {
            let (a, b) = (lo + k as f32 * width, lo + (k + 1) as f32 * width);
            let mid = 0.5 * (a + b);
            let radius = samples.iter().filter(|x| x.0 >= a - 1e-6 && x.0 <= b + 1e-6).map(|x| x.2).fold(0.0, f32::max);
            let centre = if part.lathe {
                Vec3::new(0.0, mid, 0.0)
            } else {
                samples.iter().min_by(|x, y| (x.0 - mid).abs().total_cmp(&(y.0 - mid).abs())).expect("samples").1
            };
            // Never below the board: a sphere reaching under y = 0 would shadow the squares around the foot.
            Sphere::new(centre.as_dvec3(), radius.min(centre.y) as f64)
        })
        .collect()
}

/// A square (file 0 = a … 7 = h, rank 0 = 1 … 7 = 8) in world space at y = 0: white sits at +z (near the
/// camera), the a-file on the camera's left.
pub fn square_centre(file: i32, rank: i32) -> Vec3 {
    Vec3::new((file as f32 - 3.5) * SQUARE, 0.0, (3.5 - rank as f32) * SQUARE)
}

/// A piece of the starting position: kind, colour, square (file, rank).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Piece {
    pub kind: Kind,
    pub white: bool,
    pub square: (i32, i32),
}

/// The 32 pieces in instance order: white's back rank a–h, white's pawns a–h, then black's likewise.
pub fn starting_position() -> Vec<Piece> {
    use Kind::*;
    let back = [Rook, Knight, Bishop, Queen, King, Bishop, Knight, Rook];
    let mut v = Vec::new();
    for (white, first, pawns) in [(true, 0, 1), (false, 7, 6)] {
        v.extend((0..8).map(|f| Piece { kind: back[f as usize], white, square: (f, first) }));
        v.extend((0..8).map(|f| Piece { kind: Pawn, white, square: (f, pawns) }));
    }
    v
}

/// The Opera Game in long algebraic notation (from-square, to-square; castling as the king's move).
pub const OPERA_GAME: &[&str] = &[
    "e2e4", "e7e5", "g1f3", "d7d6", "d2d4", "c8g4", "d4e5", "g4f3", "d1f3", "d6e5", "f1c4", "g8f6", "f3b3", "d8e7",
    "b1c3", "c7c6", "c1g5", "b7b5", "c3b5", "c6b5", "c4b5", "b8d7", "e1c1", "a8d8", "d1d7", "d8d7", "h1d1", "e7e6",
    "b5d7", "f6d7", "b3b8", "d7b8", "d1d8",
];

/// Seconds before the first move, per ply (half move), of sliding within a ply, and of rest after the mate.
pub const START: f32 = 0.25;
pub const PLY: f32 = 1.0;
pub const SLIDE: f32 = 0.6;
pub const HOLD: f32 = 6.75;
/// The loop's period: the game, then the final position held, then the start again.
pub const PERIOD: f32 = START + PLY * OPERA_GAME.len() as f32 + HOLD;

/// One piece's move: it slides from `from` to `to` (world, y = 0) over [`SLIDE`] s from `start`, lifted by
/// `lift`·sin(π s) on the way (knights hop, a castling rook passes over its king, captured pieces are carried
/// over the others).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Move {
    pub piece: usize,
    pub from: Vec3,
    pub to: Vec3,
    pub start: f32,
    pub lift: f32,
}

/// The game replayed: every piece movement in time order, and the final position.
#[derive(Clone, Debug)]
pub struct Replay {
    pub moves: Vec<Move>,
    /// The piece (instance) on each square (`[file][rank]`) after the last move.
    pub board: [[Option<usize>; 8]; 8],
    /// The pieces captured, in order.
    pub captured: Vec<usize>,
}

fn parse_square(s: &str) -> Result<(i32, i32), String> {
    let b = s.as_bytes();
    match b {
        [f @ b'a'..=b'h', r @ b'1'..=b'8'] => Ok(((f - b'a') as i32, (r - b'1') as i32)),
        _ => Err(format!("bad square '{s}'")),
    }
}

/// Replay `game` (long algebraic, alternating white and black from the start) from the starting position:
/// each move must take a piece of the side to move to an empty square or one of the opponent's (captured: it
/// leaves to the side of the board); a king moving two files castles (the rook jumps over it). Legality beyond
/// that is not checked (the tests check the final position against the recorded game).
pub fn replay(game: &[&str]) -> Result<Replay, String> {
    let pieces = starting_position();
    let mut board = [[None; 8]; 8];
    for (i, p) in pieces.iter().enumerate() {
        board[p.square.0 as usize][p.square.1 as usize] = Some(i);
    }
    let mut moves = Vec::new();
    let mut captured = Vec::new();
    let mut lost = [0, 0]; // pieces lost by white, black: their slots beside the board
    for (ply, m) in game.iter().enumerate() {
        let white = ply % 2 == 0;
        if m.len() != 4 {
            return Err(format!("move {ply}: '{m}' is not from-to"));
        }
        let (from, to) = (parse_square(&m[..2])?, parse_square(&m[2..])?);
        let start = START + ply as f32 * PLY;
        let at = |b: &[[Option<usize>; 8]; 8], s: (i32, i32)| b[s.0 as usize][s.1 as usize];
        let piece = at(&board, from).ok_or_else(|| format!("move {ply} '{m}': no piece on the from-square"))?;
        if pieces[piece].white != white || from == to {
            return Err(format!("move {ply} '{m}': not a move of the side to move"));
        }
        if let Some(victim) = at(&board, to) {
            if pieces[victim].white == white {
                return Err(format!("move {ply} '{m}': takes its own piece"));
            }
            // White's lost pieces stand in a column right of the board (from white's side), black's on the left.
            let side = usize::from(!pieces[victim].white);
            let slot = lost[side] as f32;
            lost[side] += 1;
            let x = if pieces[victim].white { 4.9 } else { -4.9 };
            let z = if pieces[victim].white { -3.5 + slot } else { 3.5 - slot };
            let grave = Vec3::new(x * SQUARE, 0.0, z * SQUARE);
            moves.push(Move { piece: victim, from: square_centre(to.0, to.1), to: grave, start, lift: 2.2 * SQUARE });
            captured.push(victim);
        }
        let lift = if pieces[piece].kind == Kind::Knight { 1.2 * SQUARE } else { 0.0 };
        moves.push(Move { piece, from: square_centre(from.0, from.1), to: square_centre(to.0, to.1), start, lift });
        board[to.0 as usize][to.1 as usize] = Some(piece);
        board[from.0 as usize][from.1 as usize] = None;
        if pieces[piece].kind == Kind::King && (to.0 - from.0).abs() == 2 {
            let (rook_from, rook_to) =
                if to.0 > from.0 { ((7, from.1), (5, from.1)) } else { ((0, from.1), (3, from.1)) };
            let rook = at(&board, rook_from).ok_or_else(|| format!("move {ply} '{m}': castling without a rook"))?;
            if at(&board, rook_to).is_some() {
                return Err(format!("move {ply} '{m}': castling through a piece"));
            }
            let (a, b) = (square_centre(rook_from.0, rook_from.1), square_centre(rook_to.0, rook_to.1));
            moves.push(Move { piece: rook, from: a, to: b, start, lift: 2.0 * SQUARE });
            board[rook_to.0 as usize][rook_to.1 as usize] = Some(rook);
            board[rook_from.0 as usize][rook_from.1 as usize] = None;
        }
    }
    Ok(Replay { moves, board, captured })
}

/// Where piece `piece` stands at `t` seconds into the loop (world, its foot's centre): its start square, or
/// along its latest move (smoothstep-eased, lifted). `t` is taken modulo [`PERIOD`].
pub fn placement(replay: &Replay, piece: usize, t: f32) -> Vec3 {
    let t = t.rem_euclid(PERIOD);
    let start = starting_position()[piece].square;
    let latest = replay.moves.iter().rfind(|m| m.piece == piece && m.start <= t);
    match latest {
        None => square_centre(start.0, start.1),
        Some(m) => {
            let s = ((t - m.start) / SLIDE).clamp(0.0, 1.0);
            let s = s * s * (3.0 - 2.0 * s);
            m.from.lerp(m.to, s) + Vec3::Y * m.lift * (std::f32::consts::PI * s).sin()
        }
    }
}

/// The pieces at `t`: each one moved rigidly from its rest transform (its blocker spheres follow it).
fn replay_pose(rest: &Rest, t: f32) -> Pose {
    let replay = replay(OPERA_GAME).expect("the Opera Game replays (tested)");
    let transforms = starting_position()
        .iter()
        .enumerate()
        .filter(|&(i, _)| i < rest.transforms.len())
        .map(|(i, p)| {
            let offset = placement(&replay, i, t) - square_centre(p.square.0, p.square.1);
            (i, Mat4::from_translation(offset) * rest.transforms[i])
        })
        .collect();
    Pose { transforms, bones: None }
}

/// The light (`dark == false`) or dark squares: 32 quads at y = 0, each tessellated `n` × `n` (per-vertex
/// shading needs vertices), normal +Y. a1 is dark.
pub fn squares(dark: bool, n: u32) -> Mesh {
    let mut meshes = Vec::new();
    for file in 0..8 {
        for rank in 0..8 {
            if ((file + rank) % 2 == 0) == dark {
                let mut q = shapes::ground_plane(0.5 * SQUARE, n);
                let c = square_centre(file, rank);
                for p in &mut q.positions {
                    *p += c;
                }
                meshes.push(q);
            }
        }
    }
    shapes::merge(&meshes, if dark { "dark squares" } else { "light squares" })
}

/// Mesh indices after the six piece meshes.
const GROUND: usize = 6;
const LIGHT: usize = 7;
const DARK: usize = 8;

fn build(inputs: &SceneInputs) -> anyhow::Result<Scene> {
    let env =
        inputs.env.map(std::path::Path::to_path_buf).unwrap_or_else(|| inputs.assets.join("envmaps/courtyard.exr"));
    let mut meshes: Vec<Mesh> = Kind::ALL.iter().map(|&k| piece_mesh(k)).collect();
    let mut spheres: Vec<Option<Vec<Sphere>>> = Kind::ALL.iter().map(|&k| Some(piece_spheres(k))).collect();
    meshes.extend([shapes::ground_plane(2.0, 32), squares(false, 3), squares(true, 3)]);
    spheres.extend([None, None, None]);
    let mut instances: Vec<Instance> = starting_position()
        .iter()
        .map(|p| {
            let c = square_centre(p.square.0, p.square.1);
            // The knight's mesh looks towards +z: white's knights turn to face black.
            let turn = if p.kind == Kind::Knight && p.white { std::f32::consts::PI } else { 0.0 };
            Instance {
                mesh: p.kind as usize,
                transform: Mat4::from_translation(c) * Mat4::from_rotation_y(turn),
                material: usize::from(!p.white),
            }
        })
        .collect();
    instances.extend([
        Instance { mesh: GROUND, transform: Mat4::from_translation(Vec3::Y * GROUND_Y), material: 4 },
        Instance { mesh: LIGHT, transform: Mat4::IDENTITY, material: 2 },
        Instance { mesh: DARK, transform: Mat4::IDENTITY, material: 3 },
    ]);
    let mut plane_meshes = vec![false; meshes.len()];
    plane_meshes[GROUND] = true;
    Ok(Scene {
        meshes,
        materials: vec![
            // Materials 0 and 1 (what --brdf changes: the glossy ones): the pieces, with a Blinn-Phong gloss.
            Material::glossy(Vec3::new(0.80, 0.74, 0.62), 0.2, 300.0),
            Material::glossy(Vec3::new(0.05, 0.045, 0.04), 0.2, 300.0),
            Material::diffuse(Vec3::new(0.72, 0.62, 0.45)),
            Material::diffuse(Vec3::new(0.22, 0.12, 0.07)),
            Material::diffuse(Vec3::splat(0.4)),
        ],
        instances,
        environment: load_environment(&env)?,
        environment_intensity: 1.0,
        env_lights: Default::default(),
        lights: Vec::new(),
        blockers: SceneBlockers { spheres, plane_meshes, ..Default::default() },
        camera: Camera { eye: Vec3::new(0.0, 1.75, 2.35), target: Vec3::new(0.0, 0.05, 0.05), fov_y_degrees: 42.0 },
    })
}
