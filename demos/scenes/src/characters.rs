//! The `battle` scene's two characters (SHEXP §9): a troll with a club and a wizard with a staff, built
//! procedurally and written as skinned, animated glTF ([`crate::gltf_writer`]) into `assets/battle/`, from where
//! the scene loads them through the glTF importer like any user file.
//!
//! Both share one 14-bone skeleton (hips, spine, chest, head, and per side upper arm, forearm, hand, thigh,
//! shin), at rest standing along +y and facing +z, every rest rotation the identity (so inverse bind matrices are
//! translations). The body is made of capsules and tubes ([`Part`]), each skinned rigidly to one bone (weight 1:
//! the parts overlap at the joints, so bending opens no gap); the club and the staff are the second mesh, skinned
//! to a hand. Blocker spheres are placed along each part's axis ([`Character::spheres`]) in the bind pose; the
//! renderer binds them to bones through the skin of the vertices around them.
//!
//! Clips (rotations about the bones' local x, slerped): `walk` (both), `attack` (the troll raises its club and
//! strikes forward) and `cast` (the wizard raises its staff and its other hand).

use crate::gltf_writer::GltfBuilder;
use engine::blockers::Sphere;
use engine::scene::Mesh;
use glam::{DVec3, Mat4, Quat, Vec3};
use serde_json::{json, Value};

/// Bone names, in skin joint order.
pub const BONES: [&str; 14] = [
    "hips",
    "spine",
    "chest",
    "head",
    "l_upper_arm",
    "l_forearm",
    "l_hand",
    "r_upper_arm",
    "r_forearm",
    "r_hand",
    "l_thigh",
    "l_shin",
    "r_thigh",
    "r_shin",
];
const PARENTS: [Option<usize>; 14] = [
    None,
    Some(0),
    Some(1),
    Some(2),
    Some(2),
    Some(4),
    Some(5),
    Some(2),
    Some(7),
    Some(8),
    Some(0),
    Some(10),
    Some(0),
    Some(12),
];
const HIPS: usize = 0;
const SPINE: usize = 1;
const CHEST: usize = 2;
const HEAD: usize = 3;
const L_UPPER: usize = 4;
const L_FORE: usize = 5;
const L_HAND: usize = 6;
const R_UPPER: usize = 7;
const R_FORE: usize = 8;
const R_HAND: usize = 9;
const L_THIGH: usize = 10;
const L_SHIN: usize = 11;
const R_THIGH: usize = 12;
const R_SHIN: usize = 13;

/// Vertices around every ring of a part.
pub const SEGMENTS: u32 = 24;

/// One body part: a closed tube along `spine` with `radii`, skinned to `bone`, with `spheres` blocker spheres
/// along it.
#[derive(Clone, Debug)]
pub struct Part {
    pub bone: usize,
    /// Part of the prop (club, staff): the second mesh.
    pub prop: bool,
    pub spine: Vec<Vec3>,
    pub radii: Vec<f32>,
    /// Sphere centres and radii (bind pose).
    pub blockers: Vec<(Vec3, f32)>,
}

/// A tapered capsule from `a` (radius `ra`) to `b` (radius `rb`): hemispherical ends closed at poles, `rings`
/// rings, and `n` blocker spheres (n ≥ 2) from `a` to `b` with the interpolated radius.
fn capsule(bone: usize, a: Vec3, b: Vec3, ra: f32, rb: f32, rings: usize, n: usize) -> Part {
    let len = a.distance(b);
    let dir = (b - a) / len;
    let (mut spine, mut radii) = (Vec::new(), Vec::new());
    // Rings uniform in angle over the end caps, uniform in length between them.
    let cap = rings / 4;
    for k in 0..=cap {
        let th = std::f32::consts::FRAC_PI_2 * (1.0 - k as f32 / cap as f32);
        spine.push(a - dir * ra * th.sin());
        radii.push(ra * th.cos());
    }
    let mid = rings - 2 * cap;
    for k in 1..mid {
        let t = k as f32 / mid as f32;
        spine.push(a + (b - a) * t);
        radii.push(ra + (rb - ra) * t);
    }
    for k in 0..=cap {
        let th = std::f32::consts::FRAC_PI_2 * k as f32 / cap as f32;
        spine.push(b + dir * rb * th.sin());
        radii.push(rb * th.cos());
    }
    radii[0] = 0.0;
    *radii.last_mut().expect("rings") = 0.0;
    let blockers = (0..n)
        .map(|i| {
            let t = i as f32 / (n - 1) as f32;
            (a + (b - a) * t, ra + (rb - ra) * t)
        })
        .collect();
    Part { bone, prop: false, spine, radii, blockers }
}

/// A cone-like tube from `a` (radius `ra`, flat cap) to a point at `b`, with `n` spheres along its wider part.
fn cone(bone: usize, a: Vec3, b: Vec3, ra: f32, rings: usize, n: usize) -> Part {
    let spine: Vec<Vec3> = (0..=rings).map(|k| a + (b - a) * (k as f32 / rings as f32)).collect();
    let radii: Vec<f32> = (0..=rings).map(|k| ra * (1.0 - k as f32 / rings as f32)).collect();
    // Sphere i sits at t_i ∈ [0, 0.6] with the cone's radius there.
    let blockers = (0..n)
        .map(|i| {
            let t = 0.6 * i as f32 / (n.max(2) - 1) as f32;
            (a + (b - a) * t, ra * (1.0 - t))
        })
        .collect();
    Part { bone, prop: false, spine, radii, blockers }
}

/// A named clip: key times and, per animated bone, one local rotation angle about x (degrees) per key.
#[derive(Clone, Debug)]
pub struct ClipSpec {
    pub name: &'static str,
    pub times: Vec<f32>,
    pub rotations: Vec<(usize, Vec<f32>)>,
    /// Hip height offsets per key (the walk's bob), if any.
    pub bob: Option<Vec<f32>>,
}

/// A character: skeleton at rest, parts, colours and clips.
#[derive(Clone, Debug)]
pub struct Character {
    pub name: &'static str,
    /// Joint positions at rest (model space, metres, +y up, facing +z).
    pub joints: [Vec3; 14],
    pub parts: Vec<Part>,
    pub body_color: [f32; 3],
    pub prop_color: [f32; 3],
    pub clips: Vec<ClipSpec>,
}

/// Joint positions for height scale `h` and width scale `w`.
fn skeleton(h: f32, w: f32) -> [Vec3; 14] {
    let v = |x: f32, y: f32| Vec3::new(x * w, y * h, 0.0);
    [
        v(0.0, 0.95),
        v(0.0, 1.12),
        v(0.0, 1.36),
        v(0.0, 1.58),
        v(0.22, 1.50),
        v(0.27, 1.22),
        v(0.29, 0.96),
        v(-0.22, 1.50),
        v(-0.27, 1.22),
        v(-0.29, 0.96),
        v(0.11, 0.92),
        v(0.12, 0.50),
        v(-0.11, 0.92),
        v(-0.12, 0.50),
    ]
}

/// Limbs common to both: arms, hands, legs, feet (radii scaled by `w`).
fn limbs(j: &[Vec3; 14], h: f32, w: f32, rings: usize) -> Vec<Part> {
    let ankle = |x: f32| Vec3::new(x * w, 0.08 * h, 0.0);
    let mut parts = Vec::new();
    for (upper, fore, hand, thigh, shin, side) in
        [(L_UPPER, L_FORE, L_HAND, L_THIGH, L_SHIN, 1.0f32), (R_UPPER, R_FORE, R_HAND, R_THIGH, R_SHIN, -1.0)]
    {
        parts.push(capsule(upper, j[upper], j[fore], 0.075 * w, 0.065 * w, rings, 4));
        parts.push(capsule(fore, j[fore], j[hand], 0.065 * w, 0.055 * w, rings, 4));
        parts.push(capsule(hand, j[hand], j[hand] + Vec3::new(0.0, -0.09, 0.03), 0.055 * w, 0.05 * w, rings, 2));
        parts.push(capsule(thigh, j[thigh], j[shin], 0.095 * w, 0.075 * w, rings, 5));
        let a = ankle(0.12 * side);
        parts.push(capsule(shin, j[shin], a, 0.075 * w, 0.055 * w, rings, 5));
        let toe = a + Vec3::new(0.0, -0.02 * h, 0.16 * w);
        parts.push(capsule(shin, a + Vec3::new(0.0, -0.02 * h, -0.03), toe, 0.05 * w, 0.05 * w, rings, 3));
    }
    parts
}

fn walk(h: f32) -> ClipSpec {
    ClipSpec {
        name: "walk",
        times: vec![0.0, 0.3, 0.6, 0.9, 1.2],
        rotations: vec![
            (L_THIGH, vec![-25.0, 0.0, 25.0, 0.0, -25.0]),
            (R_THIGH, vec![25.0, 0.0, -25.0, 0.0, 25.0]),
            (L_SHIN, vec![5.0, 35.0, 5.0, 5.0, 5.0]),
            (R_SHIN, vec![5.0, 5.0, 5.0, 35.0, 5.0]),
            (L_UPPER, vec![20.0, 0.0, -20.0, 0.0, 20.0]),
            (R_UPPER, vec![-20.0, 0.0, 20.0, 0.0, -20.0]),
        ],
        bob: Some(vec![0.0, 0.03 * h, 0.0, 0.03 * h, 0.0]),
    }
}

/// The troll: 1.25 times a human's height, 1.5 times as wide, green, a paunch, a club in its right hand.
pub fn troll(rings: usize) -> Character {
    let (h, w) = (1.25, 1.5);
    let j = skeleton(h, w);
    let y = |f: f32| f * h;
    let mut parts = vec![
        capsule(HIPS, Vec3::new(0.0, y(0.88), 0.0), Vec3::new(0.0, y(1.02), 0.0), 0.2 * w, 0.2 * w, rings, 3),
        capsule(SPINE, Vec3::new(0.0, y(1.08), 0.05), Vec3::new(0.0, y(1.26), 0.05), 0.25 * w, 0.22 * w, rings, 4),
        capsule(
            CHEST,
            Vec3::new(-0.13 * w, y(1.44), 0.0),
            Vec3::new(0.13 * w, y(1.44), 0.0),
            0.16 * w,
            0.16 * w,
            rings,
            4,
        ),
        // A heavy head pushed forward, and a jaw.
        capsule(HEAD, Vec3::new(0.0, y(1.62), 0.06), Vec3::new(0.0, y(1.74), 0.1), 0.14, 0.12, rings, 3),
        capsule(HEAD, Vec3::new(-0.07, y(1.6), 0.16), Vec3::new(0.07, y(1.6), 0.16), 0.07, 0.07, rings, 2),
    ];
    parts.extend(limbs(&j, h, w, rings));
    // The club: from behind the right fist, thin at the grip, to a thick head ahead of the troll.
    let mut club = capsule(
        R_HAND,
        j[R_HAND] + Vec3::new(0.0, -0.04, -0.1),
        j[R_HAND] + Vec3::new(0.0, 0.05, 0.95),
        0.04,
        0.13,
        2 * rings,
        7,
    );
    club.prop = true;
    parts.push(club);
    let attack = ClipSpec {
        name: "attack",
        times: vec![0.0, 0.6, 0.85, 1.1, 1.6],
        rotations: vec![
            (R_UPPER, vec![0.0, -165.0, -60.0, -60.0, 0.0]),
            (R_FORE, vec![0.0, -30.0, 0.0, 0.0, 0.0]),
            (CHEST, vec![0.0, -10.0, 20.0, 20.0, 0.0]),
            (SPINE, vec![0.0, -5.0, 10.0, 10.0, 0.0]),
            (L_UPPER, vec![0.0, 20.0, -30.0, -30.0, 0.0]),
        ],
        bob: None,
    };
    Character {
        name: "troll",
        joints: j,
        parts,
        body_color: [0.35, 0.45, 0.25],
        prop_color: [0.4, 0.26, 0.14],
        clips: vec![walk(h), attack],
    }
}

/// The wizard: slim, in a long blue robe with a pointed hat and a beard, a staff in the left hand.
pub fn wizard(rings: usize) -> Character {
    let (h, w) = (1.0, 0.9);
    let j = skeleton(h, w);
    let mut parts = vec![
        capsule(HIPS, Vec3::new(0.0, 0.88, 0.0), Vec3::new(0.0, 1.02, 0.0), 0.16 * w, 0.16 * w, rings, 3),
        capsule(SPINE, Vec3::new(0.0, 1.06, 0.0), Vec3::new(0.0, 1.26, 0.0), 0.16 * w, 0.17 * w, rings, 3),
        capsule(CHEST, Vec3::new(-0.12 * w, 1.42, 0.0), Vec3::new(0.12 * w, 1.42, 0.0), 0.13 * w, 0.13 * w, rings, 4),
        capsule(HEAD, Vec3::new(0.0, 1.62, 0.0), Vec3::new(0.0, 1.7, 0.01), 0.1, 0.1, rings, 2),
        // Pointed hat (brim and cone) and beard.
        cone(HEAD, Vec3::new(0.0, 1.74, 0.0), Vec3::new(0.0, 2.12, -0.08), 0.19, rings, 3),
        cone(HEAD, Vec3::new(0.0, 1.6, 0.08), Vec3::new(0.0, 1.36, 0.14), 0.07, rings, 2),
        // The robe's skirt, down to the ankles.
        {
            let mut robe = cone(HIPS, Vec3::new(0.0, 0.1, 0.0), Vec3::new(0.0, 1.4, 0.0), 0.34, rings, 4);
            // Cut the cone's point off at 0.9 m: a skirt open upwards into the body.
            robe.spine.truncate(robe.spine.len() * 2 / 3);
            robe.radii.truncate(robe.spine.len());
            *robe.radii.last_mut().expect("rings") = 0.0;
            // Spheres inside the skirt, none reaching below the ground (y = 0).
            robe.blockers = [0.28f32, 0.5, 0.72, 0.92]
                .iter()
                .map(|&y| (Vec3::new(0.0, y, 0.0), (0.34 * (1.0 - (y - 0.1) / 1.3)).min(y)))
                .collect();
            robe
        },
    ];
    parts.extend(limbs(&j, h, w, rings));
    let mut staff = capsule(
        L_HAND,
        j[L_HAND] + Vec3::new(0.0, -0.9, 0.05),
        j[L_HAND] + Vec3::new(0.0, 0.9, 0.05),
        0.025,
        0.03,
        2 * rings,
        8,
    );
    staff.prop = true;
    parts.push(staff);
    let top = j[L_HAND] + Vec3::new(0.0, 0.97, 0.05);
    let mut orb = capsule(L_HAND, top, top + Vec3::new(0.0, 0.02, 0.0), 0.07, 0.07, rings, 2);
    orb.prop = true;
    parts.push(orb);
    let cast = ClipSpec {
        name: "cast",
        times: vec![0.0, 0.6, 1.0, 1.4, 2.0],
        rotations: vec![
            (L_UPPER, vec![0.0, -60.0, -110.0, -60.0, 0.0]),
            (L_FORE, vec![0.0, 20.0, 30.0, 20.0, 0.0]),
            (R_UPPER, vec![0.0, -70.0, -95.0, -70.0, 0.0]),
            (R_FORE, vec![0.0, -30.0, -20.0, -30.0, 0.0]),
            (HEAD, vec![0.0, -10.0, -15.0, -10.0, 0.0]),
        ],
        bob: None,
    };
    Character {
        name: "wizard",
        joints: j,
        parts,
        body_color: [0.2, 0.25, 0.6],
        prop_color: [0.55, 0.4, 0.25],
        clips: vec![walk(h), cast],
    }
}

/// The ring count of the shipped files (`assets/battle/*.glb`).
pub const RINGS: usize = 24;

impl Character {
    /// The body (`prop == false`) or prop mesh at rest, with each vertex's bone.
    pub fn mesh(&self, prop: bool) -> (Mesh, Vec<u16>) {
        let name = format!("{}-{}", self.name, if prop { "prop" } else { "body" });
        let mut parts = Vec::new();
        let mut bones = Vec::new();
        for p in self.parts.iter().filter(|p| p.prop == prop) {
            let m = crate::shapes::tube(&p.spine, &p.radii, SEGMENTS, &name);
            bones.extend(std::iter::repeat_n(p.bone as u16, m.positions.len()));
            parts.push(m);
        }
        (crate::shapes::merge(&parts, &name), bones)
    }

    /// The blocker spheres of the body or the prop at rest (model space).
    pub fn spheres(&self, prop: bool) -> Vec<Sphere> {
        self.parts
            .iter()
            .filter(|p| p.prop == prop)
            .flat_map(|p| p.blockers.iter().map(|&(c, r)| Sphere::new(c.as_dvec3(), r as f64)))
            .collect()
    }

    /// All blocker spheres (body, then prop).
    pub fn sphere_count(&self) -> usize {
        self.parts.iter().map(|p| p.blockers.len()).sum()
    }

    /// The glTF document: nodes 0..14 the bones (translations relative to the parent), 14 the body and 15 the
    /// prop (both skinned by skin 0), one clip per [`ClipSpec`].
    pub fn gltf(&self) -> (GltfBuilder, Value) {
        let mut b = GltfBuilder::default();
        let mut meshes = Vec::new();
        for (k, prop) in [false, true].into_iter().enumerate() {
            let (m, bones) = self.mesh(prop);
            let pos: Vec<f32> = m.positions.iter().flat_map(|p| p.to_array()).collect();
            let nrm: Vec<f32> = m.normals.iter().flat_map(|p| p.to_array()).collect();
            let joints: Vec<[u16; 4]> = bones.iter().map(|&j| [j, 0, 0, 0]).collect();
            let weights: Vec<f32> = bones.iter().flat_map(|_| [1.0, 0.0, 0.0, 0.0]).collect();
            meshes.push(json!({ "name": m.name, "primitives": [{
                "attributes": {
                    "POSITION": b.floats("VEC3", &pos),
                    "NORMAL": b.floats("VEC3", &nrm),
                    "JOINTS_0": b.joints(&joints),
                    "WEIGHTS_0": b.floats("VEC4", &weights),
                },
                "indices": b.indices(&m.indices),
                "material": k,
            }]}));
        }
        let ibm: Vec<f32> = self.joints.iter().flat_map(|p| Mat4::from_translation(-*p).to_cols_array()).collect();
        let ibm = b.floats("MAT4", &ibm);
        let mut nodes: Vec<Value> = (0..BONES.len())
            .map(|i| {
                let local = match PARENTS[i] {
                    Some(p) => self.joints[i] - self.joints[p],
                    None => self.joints[i],
                };
                let children: Vec<usize> = (0..BONES.len()).filter(|&c| PARENTS[c] == Some(i)).collect();
                let mut n = json!({ "name": BONES[i], "translation": local.to_array() });
                if !children.is_empty() {
                    n["children"] = json!(children);
                }
                n
            })
            .collect();
        nodes.push(json!({ "name": format!("{}-body", self.name), "mesh": 0, "skin": 0 }));
        nodes.push(json!({ "name": format!("{}-prop", self.name), "mesh": 1, "skin": 0 }));
        let mut animations = Vec::new();
        for c in &self.clips {
            let (mut channels, mut samplers) = (Vec::new(), Vec::new());
            let input = b.floats("SCALAR", &c.times);
            for (bone, angles) in &c.rotations {
                let q: Vec<f32> =
                    angles.iter().flat_map(|a| Quat::from_rotation_x(a.to_radians()).to_array()).collect();
                samplers.push(json!({ "input": input, "output": b.floats("VEC4", &q), "interpolation": "LINEAR" }));
                channels.push(json!({ "sampler": samplers.len() - 1, "target": { "node": bone, "path": "rotation" } }));
            }
            if let Some(bob) = &c.bob {
                let t: Vec<f32> = bob.iter().flat_map(|d| (self.joints[HIPS] + Vec3::Y * *d).to_array()).collect();
                samplers.push(json!({ "input": input, "output": b.floats("VEC3", &t), "interpolation": "LINEAR" }));
                channels
                    .push(json!({ "sampler": samplers.len() - 1, "target": { "node": HIPS, "path": "translation" } }));
            }
            animations.push(json!({ "name": c.name, "channels": channels, "samplers": samplers }));
        }
        let material = |c: [f32; 3], rough: f32| {
            json!({ "pbrMetallicRoughness": {
                "baseColorFactor": [c[0], c[1], c[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": rough } })
        };
        let doc = json!({
            "scene": 0,
            "scenes": [{ "nodes": [0, BONES.len(), BONES.len() + 1] }],
            "nodes": nodes,
            "meshes": meshes,
            "skins": [{ "joints": (0..BONES.len()).collect::<Vec<_>>(), "inverseBindMatrices": ibm, "skeleton": 0 }],
            "materials": [material(self.body_color, 0.8), material(self.prop_color, 0.6)],
            "animations": animations,
        });
        (b, doc)
    }
}

/// The distance from `p` to the nearest of `spheres`' surfaces (0 inside one).
pub fn outside(spheres: &[Sphere], p: DVec3) -> f64 {
    spheres.iter().map(|s| s.center.distance(p) - s.radius).fold(f64::MAX, f64::min).max(0.0)
}
