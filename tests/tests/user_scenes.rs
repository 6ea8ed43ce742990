//! The user's own scenes (issue 16): glTF import with skins and animation checked against hand-computed matrices on
//! files our own writer makes (`scenes::gltf_writer`), in all three containers; instancing; more than four
//! influences; OBJ `.mtl` materials; the scene description file; and bad input, each an error naming the file and
//! the problem. The GPU tests render the two example scene files at a tiny size and check that the Monte Carlo
//! reference traces the glTF-animated pose.

use engine::scene::{load_gltf, load_obj_with_materials};
use engine_tests::assert_err_names;
use glam::{Mat4, Quat, Vec3};
use scenes::gltf_writer::{two_bone_arm, Container, GltfBuilder, ARM_ROOT};
use scenes::user::{self, UserOptions};
use serde_json::json;
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("user-scenes-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write_arm(name: &str, container: Container) -> PathBuf {
    let (b, doc) = two_bone_arm(8, 8);
    let p = dir().join(name);
    b.write(doc, &p, container).unwrap();
    p
}

fn close(a: Mat4, b: Mat4, what: &str) {
    let d = (a - b).to_cols_array().iter().fold(0f32, |m, x| m.max(x.abs()));
    assert!(d < 1e-5, "{what}: {a} vs {b} (max difference {d})");
}

#[test]
fn gltf_round_trip_poses_match_hand_computed_matrices() {
    let root = Mat4::from_translation(Vec3::from(ARM_ROOT));
    let elbow = Vec3::new(1.0, 0.0, 0.0);
    let bent = |deg: f32| {
        Mat4::from_translation(elbow) * Mat4::from_rotation_z(deg.to_radians()) * Mat4::from_translation(-elbow)
    };
    let mut first = None;
    for (name, c) in
        [("arm.gltf", Container::Embedded), ("arm-ext.gltf", Container::External), ("arm.glb", Container::Glb)]
    {
        let p = write_arm(name, c);
        let g = load_gltf(&p, 0).unwrap_or_else(|e| panic!("{name}: {e}"));
        // Instancing: the stone mesh is used by two nodes and loaded once.
        assert_eq!(g.meshes.len(), 2, "{name}: arm + stone");
        assert_eq!(g.instances.len(), 3, "{name}");
        let stones: Vec<_> = g.instances.iter().filter(|i| g.meshes[i.mesh].name.starts_with("stone")).collect();
        assert_eq!(stones.len(), 2);
        assert_eq!(stones[0].mesh, stones[1].mesh, "{name}: one upload for both stones");
        let mut placed: Vec<Mat4> = stones.iter().map(|s| s.transform).collect();
        placed.sort_by(|a, b| a.w_axis.x.total_cmp(&b.w_axis.x));
        close(placed[0], Mat4::from_translation(Vec3::new(-0.7, 0.15, -0.5)) * Mat4::from_scale(Vec3::splat(1.5)), "b");
        close(placed[1], Mat4::from_translation(Vec3::new(0.8, 0.15, 0.6)), "stone a");
        // The skin: two bones, the arm instance at identity (glTF skinning ignores the node's transform).
        let arm = g.instances.iter().position(|i| g.meshes[i.mesh].name.starts_with("arm")).unwrap();
        let skin = g.skins[g.instances[arm].mesh].as_ref().expect("the arm is skinned");
        assert_eq!(g.rig.bones.len(), 2);
        assert!(skin.joints.iter().flatten().all(|&j| j < 2));
        assert!(skin.weights.iter().all(|w| (w.iter().sum::<f32>() - 1.0).abs() < 1e-6));
        close(g.instances[arm].transform, Mat4::IDENTITY, "skinned instance");
        let names: Vec<&str> = g.rig.clips.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["bend", "lift", "pulse"]);
        // Rest: both bones put the mesh at the shoulder.
        let rest = g.rig.pose(None, 0.0);
        close(rest.bones[0], root, "rest bone 0");
        close(rest.bones[1], root, "rest bone 1");
        // bend (linear, slerp): 30° at t = 0.5 and 1.5, 60° at t = 1; loops after 2 s.
        let bend = g.rig.clip_index("bend").unwrap();
        for (t, deg) in [(0.5, 30.0), (1.0, 60.0), (1.5, 30.0), (2.5, 30.0), (0.25, 15.0)] {
            let pose = g.rig.pose(Some(bend), t);
            close(pose.bones[0], root, "bend bone 0");
            close(pose.bones[1], root * bent(deg), &format!("{name}: bend t = {t}"));
            // A vertex at the tip, all on the forearm, lands where the hand computation puts it.
            let tip = Vec3::new(2.0, 0.0, 0.0);
            let want = Vec3::from(ARM_ROOT) + elbow + Quat::from_rotation_z(f32::to_radians(deg)) * Vec3::X;
            assert!((pose.bones[1].transform_point3(tip) - want).length() < 1e-5, "{name}: tip at t = {t}");
        }
        // lift (cubic spline): p(s) = (2s³−3s²+1)v0 + (s³−2s²+s)Δ b0 + (−2s³+3s²)v1 + (s³−s²)Δ a1, with v0.y = 0.5,
        // b0.y = 1, v1.y = 1, a1 = 0, Δ = 1: at s = 0.5, y = 0.25 + 0.125 + 0.5 = 0.875.
        let lift = g.rig.clip_index("lift").unwrap();
        let pose = g.rig.pose(Some(lift), 0.5);
        close(pose.bones[0], Mat4::from_translation(Vec3::new(-1.0, 0.875, 0.0)), "lift t = 0.5");
        let s: f32 = 0.25;
        let y = (2.0 * s.powi(3) - 3.0 * s * s + 1.0) * 0.5
            + (s.powi(3) - 2.0 * s * s + s)
            + (-2.0 * s.powi(3) + 3.0 * s * s);
        close(g.rig.pose(Some(lift), 0.25).bones[0], Mat4::from_translation(Vec3::new(-1.0, y, 0.0)), "lift 0.25");
        // The stones are not animated: their transforms stay.
        let stone = stones_index(&g);
        close(pose.instance_transforms[stone], g.instances[stone].transform, "the stones stay");
        // pulse (step): scale 1 before t = 1, 1.2 from t = 1.
        let pulse = g.rig.clip_index("pulse").unwrap();
        close(g.rig.pose(Some(pulse), 0.99).bones[0], root, "pulse t = 0.99");
        close(g.rig.pose(Some(pulse), 1.0).bones[0], root * Mat4::from_scale(Vec3::splat(1.2)), "pulse t = 1");
        close(g.rig.pose(Some(pulse), 1.0).bones[1], root * Mat4::from_scale(Vec3::splat(1.2)), "pulse child");
        // The three containers hold the same scene.
        match &first {
            None => first = Some((g.meshes.clone(), g.rig.clone())),
            Some((m, r)) => {
                assert_eq!(&g.meshes, m, "{name}: same meshes as the embedded file");
                assert_eq!(&g.rig, r, "{name}: same rig as the embedded file");
            }
        }
    }
    assert!(load_gltf(&dir().join("arm.gltf"), 0).unwrap().rig.clip_index("wave").unwrap_err().contains("bend"));
}

fn stones_index(g: &engine::scene::GltfScene) -> usize {
    g.instances.iter().position(|i| g.meshes[i.mesh].name.starts_with("stone")).unwrap()
}

/// A triangle skinned to six joints across JOINTS_0/WEIGHTS_0 and JOINTS_1/WEIGHTS_1.
fn six_influence_triangle(weights: [f32; 8], joint7: u16) -> (GltfBuilder, serde_json::Value) {
    let mut b = GltfBuilder::default();
    let pos = b.floats("VEC3", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let j0 = b.joints(&[[0, 1, 2, 3]; 3]);
    let w0 = b.floats("VEC4", &[weights[..4].to_vec(), weights[..4].to_vec(), weights[..4].to_vec()].concat());
    let j1 = b.joints(&[[4, 5, 0, joint7]; 3]);
    let w1 = b.floats("VEC4", &[weights[4..].to_vec(), weights[4..].to_vec(), weights[4..].to_vec()].concat());
    let doc = json!({
        "scene": 0, "scenes": [{ "nodes": [0, 1, 2, 3, 4, 5, 6] }],
        "nodes": [{}, {}, {}, {}, {}, {}, { "mesh": 0, "skin": 0 }],
        "meshes": [{ "primitives": [{ "attributes": {
            "POSITION": pos, "JOINTS_0": j0, "WEIGHTS_0": w0, "JOINTS_1": j1, "WEIGHTS_1": w1 } }] }],
        "skins": [{ "joints": [0, 1, 2, 3, 4, 5] }],
    });
    (b, doc)
}

#[test]
fn more_than_four_influences_keep_the_four_largest_renormalized() {
    let (b, doc) = six_influence_triangle([0.1, 0.3, 0.05, 0.2, 0.25, 0.1, 0.0, 0.0], 0);
    let p = dir().join("six.gltf");
    b.write(doc, &p, Container::Embedded).unwrap();
    let g = load_gltf(&p, 0).unwrap();
    let s = g.skins[0].as_ref().unwrap();
    let sum = 0.3 + 0.25 + 0.2 + 0.1;
    assert_eq!(s.joints[0], [1, 4, 3, 0], "the four largest, ties by joint index");
    for (a, e) in s.weights[0].iter().zip([0.3 / sum, 0.25 / sum, 0.2 / sum, 0.1 / sum]) {
        assert!((a - e).abs() < 1e-6, "{:?}", s.weights[0]);
    }
}

/// A glTF document edited by `edit` (on the arm's JSON) and written embedded.
fn edited(name: &str, edit: impl FnOnce(&mut GltfBuilder, &mut serde_json::Value)) -> PathBuf {
    let (mut b, mut doc) = two_bone_arm(4, 6);
    edit(&mut b, &mut doc);
    let p = dir().join(name);
    b.write(doc, &p, Container::Embedded).unwrap();
    p
}

#[test]
fn bad_gltf_files_are_errors_naming_the_file_and_the_problem() {
    let cases: Vec<(PathBuf, &str)> = vec![
        // A skin that names fewer joints than the vertices use.
        (edited("joint-range.gltf", |_, d| d["skins"][0]["joints"] = json!([1])), "names joint 1"),
        (
            edited("nan-weight.gltf", |b, d| {
                let w = b.floats("VEC4", &[f32::NAN, 1.0, 0.0, 0.0].repeat(5 * 6));
                d["meshes"][0]["primitives"][0]["attributes"]["WEIGHTS_0"] = json!(w);
            }),
            "weight NaN",
        ),
        (
            edited("times.gltf", |b, d| {
                let t = b.floats("SCALAR", &[0.0, 1.0, 1.0]);
                d["animations"][0]["samplers"][0]["input"] = json!(t);
            }),
            "not come after",
        ),
        (
            edited("morph.gltf", |_, d| {
                let pos = d["meshes"][0]["primitives"][0]["attributes"]["POSITION"].clone();
                d["meshes"][0]["primitives"][0]["targets"] = json!([{ "POSITION": pos }]);
            }),
            "morph targets",
        ),
        (
            edited("draco.gltf", |_, d| {
                d["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
                d["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
            }),
            "KHR_draco_mesh_compression",
        ),
        (
            edited("quantized.gltf", |_, d| d["extensionsUsed"] = json!(["KHR_mesh_quantization"])),
            "KHR_mesh_quantization",
        ),
        (
            edited("ibm-count.gltf", |b, d| {
                let one = b.floats("MAT4", &Mat4::IDENTITY.to_cols_array());
                d["skins"][0]["inverseBindMatrices"] = json!(one);
            }),
            "1 inverse bind matrices for 2 joints",
        ),
        (
            edited("nan-key.gltf", |b, d| {
                let v = b.floats("VEC4", &[0.0, 0.0, 0.0, 1.0, f32::NAN, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
                d["animations"][0]["samplers"][0]["output"] = json!(v);
            }),
            "not finite",
        ),
        (
            edited("cubic-count.gltf", |_, d| {
                d["animations"][0]["samplers"][0]["interpolation"] = json!("CUBICSPLINE")
            }),
            "output values",
        ),
    ];
    for (p, what) in cases {
        let e = load_gltf(&p, 0).unwrap_err();
        eprintln!("{e}");
        assert_err_names(&e, &p, what);
    }
    // Missing and corrupt files, every container.
    let missing = dir().join("missing.glb");
    assert_err_names(load_gltf(&missing, 0).unwrap_err(), &missing, "not found");
    let glb = write_arm("cut.glb", Container::Glb);
    let bytes = std::fs::read(&glb).unwrap();
    std::fs::write(&glb, &bytes[..bytes.len() / 2]).unwrap();
    assert_err_names(load_gltf(&glb, 0).unwrap_err(), &glb, "glTF");
    let ext = write_arm("nobin.gltf", Container::External);
    std::fs::remove_file(ext.with_extension("bin")).unwrap();
    assert_err_names(load_gltf(&ext, 0).unwrap_err(), &ext, "glTF");
}

#[test]
fn obj_mtl_materials_map_onto_ours() {
    let d = dir();
    std::fs::write(
        d.join("two.mtl"),
        "newmtl red\nKd 0.8 0.1 0.1\nKs 0.3 0.3 0.3\nNs 250\nnewmtl grey\nKd 0.5 0.5 0.5\n",
    )
    .unwrap();
    let obj =
        "mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\no a\nusemtl red\nf 1 2 3\no b\nusemtl grey\nf 1 2 4\n";
    let p = d.join("two.obj");
    std::fs::write(&p, obj).unwrap();
    let (meshes, materials) = load_obj_with_materials(&p).unwrap();
    assert_eq!(meshes.len(), 2);
    let red = meshes.iter().position(|m| m.name.ends_with("red")).expect("a mesh per material");
    assert_eq!(materials[red].diffuse, Vec3::new(0.8, 0.1, 0.1));
    assert_eq!(materials[red].specular, Vec3::splat(0.3));
    assert_eq!(materials[red].shininess, 250.0);
    let grey = 1 - red;
    assert_eq!((materials[grey].diffuse, materials[grey].specular), (Vec3::splat(0.5), Vec3::ZERO));
    // A missing .mtl is a warning: the mesh loads with the default grey.
    let lone = d.join("lone.obj");
    std::fs::write(&lone, "mtllib nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n").unwrap();
    let (m, mat) = load_obj_with_materials(&lone).unwrap();
    assert_eq!((m.len(), mat[0].diffuse), (1, Vec3::splat(0.8)));
    // Missing and corrupt OBJ files are errors naming the file.
    let missing = d.join("missing.obj");
    assert_err_names(load_obj_with_materials(&missing).unwrap_err(), &missing, "not found");
    let bad = d.join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nvn 0 0 1\nf 1//-11 1//1 1//1\n").unwrap();
    assert_err_names(load_obj_with_materials(&bad).unwrap_err(), &bad, "relative index");
    let nan = d.join("nan.obj");
    std::fs::write(&nan, "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    assert_err_names(load_obj_with_materials(&nan).unwrap_err(), &nan, "non-finite");
}

fn small_fit(cache: &Path) -> UserOptions {
    engine_tests::small_fit_options(6, cache)
}

#[test]
fn a_model_file_becomes_a_framed_scene_with_skinned_spheres_and_clips() {
    let p = write_arm("model-a.gltf", Container::Embedded);
    let cache = dir().join("cache-model");
    let _ = std::fs::remove_dir_all(&cache);
    let opts = small_fit(&cache);
    let loaded = scenes::load(p.to_str().unwrap(), None, &opts).unwrap();
    let s = &loaded.scene;
    // arm, stone (one mesh for two instances), ground.
    assert_eq!(s.meshes.len(), 3);
    assert_eq!(s.instances.len(), 4);
    assert!(s.blockers.is_plane(2), "the ground is a plane blocker");
    assert_eq!(s.blockers.spheres_of(0).map(<[_]>::len), Some(6));
    assert_eq!(s.blockers.spheres_of(1).map(<[_]>::len), Some(6));
    assert!(s.blockers.skin_of(0).is_some() && s.blockers.bones.len() == 2);
    // The camera sees the models' bounds: the target is their middle.
    let (lo, hi) = user::posed_bounds(s);
    assert!((s.camera.target - 0.5 * (lo + hi)).length() < 1e-5);
    // Fitted once: the cache holds a file per mesh, and a second load reads it.
    assert_eq!(std::fs::read_dir(&cache).unwrap().count(), 2);
    let again = scenes::load(p.to_str().unwrap(), None, &opts).unwrap();
    assert_eq!(again.scene.blockers.spheres, s.blockers.spheres);
    // --animate plays every clip in turn (bend 2 s, lift 2 s, pulse 1 s); --clip one.
    let all = loaded.animation.expect("clips");
    let at = |a: &scenes::Animation, t: f32| a.pose(t).bones.unwrap()[1];
    let root = Mat4::from_translation(Vec3::from(ARM_ROOT));
    let elbow =
        Mat4::from_translation(Vec3::X) * Mat4::from_rotation_z(30f32.to_radians()) * Mat4::from_translation(-Vec3::X);
    close(at(&all, 0.5), root * elbow, "all: bend first");
    close(at(&all, 2.5), Mat4::from_translation(Vec3::new(-1.0, 0.875, 0.0)), "all: then lift");
    let pulse = scenes::load(p.to_str().unwrap(), None, &UserOptions { clip: Some("pulse".into()), ..opts.clone() });
    close(at(&pulse.unwrap().animation.unwrap(), 1.0), root * Mat4::from_scale(Vec3::splat(1.2)), "--clip pulse");
    // As the registry's check does for registered motions: every pose finite, one matrix per bone, at a spread of
    // times (an hour in included).
    for t in [0.0, 0.1, 1.9, 2.0, 4.99, 5.0, 10.0, 3600.0, -1.0] {
        let pose = all.pose(t);
        assert_eq!(pose.bones.as_ref().map(Vec::len), Some(2));
        assert!(
            pose.bones.unwrap().iter().all(|m| m.is_finite()) && pose.transforms.iter().all(|(_, m)| m.is_finite())
        );
        assert!(pose.transforms.iter().all(|(i, _)| *i < s.instances.len()));
    }
    let e = scenes::load(p.to_str().unwrap(), None, &UserOptions { clip: Some("wave".into()), ..opts });
    let e = format!("{:#}", e.err().unwrap());
    assert!(e.contains("wave") && e.contains("bend") && e.contains(&p.display().to_string()), "{e}");
}

const SCENE_OK: &str = r#"
[camera]
eye = [0.0, 1.5, 3.5]
target = [0.0, 0.5, 0.0]

[[light]]
center = [1.0, 2.0, 0.5]
radius = 0.2
radiance = [10.0, 10.0, 10.0]

[[model]]
file = "model.gltf"
translation = [0.0, 0.0, 0.0]
spheres = 0
clip = "bend"
"#;

#[test]
fn scene_file_errors_name_the_file_the_line_and_the_key() {
    let d = dir();
    write_arm("model.gltf", Container::Embedded);
    let opts = small_fit(&d.join("cache-errors"));
    let assets = scenes::assets_dir();
    let ok = d.join("ok.toml");
    std::fs::write(&ok, SCENE_OK).unwrap();
    let u = user::scene_file(&ok, None, &assets, &opts).unwrap();
    assert_eq!(u.scene.lights.len(), 1);
    assert!(u.scene.blockers.spheres.iter().all(Option::is_none), "spheres = 0: no spheres");
    // Lines count from 1; SCENE_OK starts with an empty line, so `radius` is on line 8.
    let cases: [(&str, String, &[&str]); 7] = [
        ("unknown.toml", SCENE_OK.replace("radius = 0.2", "radius = 0.2\ncolour = 3"), &["line 9", "colour"]),
        ("type.toml", SCENE_OK.replace("radius = 0.2", "radius = \"big\""), &["line 8", "radius"]),
        ("nomodel.toml", SCENE_OK.replace("model.gltf", "absent.gltf"), &["model[0].file", "absent.gltf", "not found"]),
        ("clip.toml", SCENE_OK.replace("\"bend\"", "\"wave\""), &["model[0].clip", "wave"]),
        ("rotation.toml", format!("{SCENE_OK}\n[environment]\nrotation = \"x\"\n"), &["line 18", "rotation"]),
        ("radius.toml", SCENE_OK.replace("radius = 0.2", "radius = -1.0"), &["light[0]", "radius"]),
        ("syntax.toml", SCENE_OK.replace("[camera]", "[camera"), &["line 2"]),
    ];
    for (name, text, what) in cases {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        let e = format!("{:#}", user::scene_file(&p, None, &assets, &opts).err().unwrap_or_else(|| panic!("{name}")));
        eprintln!("{name}: {e}");
        assert!(e.contains(&p.display().to_string()), "{name}: no file name: {e}");
        for w in what {
            assert!(e.contains(w), "{name}: does not say '{w}': {e}");
        }
    }
    let missing = d.join("missing.toml");
    assert!(format!("{:#}", user::scene_file(&missing, None, &assets, &opts).err().unwrap()).contains("not found"));
}

#[test]
fn a_sphere_file_of_another_mesh_is_refused() {
    let d = dir();
    let bunny_spheres = scenes::assets_dir().join("meshes/bunny.spheres.json");
    let p = write_arm("model-s.gltf", Container::Embedded);
    let scene = d.join("wrong-spheres.toml");
    let text = format!(
        "[[model]]\nfile = \"{}\"\nsphere_files = [\"{}\", \"{}\"]\n",
        p.display(),
        bunny_spheres.display(),
        bunny_spheres.display()
    );
    std::fs::write(&scene, text).unwrap();
    let e =
        format!("{:#}", user::scene_file(&scene, None, &scenes::assets_dir(), &UserOptions::default()).err().unwrap());
    assert!(e.contains("bunny.spheres.json") && e.contains("another mesh"), "{e}");
}

#[test]
fn environment_rotation_shifts_columns() {
    let env = engine::math::envmap::LatLongMap {
        width: 8,
        height: 2,
        texels: (0..16).map(|i| [i as f32, 0.0, 1.0]).collect(),
    };
    assert_eq!(user::rotate_environment(&env, 360.0), env);
    let quarter = user::rotate_environment(&env, 90.0);
    for y in 0..2 {
        for x in 0..8 {
            assert_eq!(
                quarter.texels[y * 8 + (x + 2) % 8],
                env.texels[y * 8 + x],
                "a quarter turn moves 2 of 8 columns"
            );
        }
    }
    let half_texel = user::rotate_environment(&env, 22.5);
    assert_eq!(half_texel.texels[1][0], 0.5 * (env.texels[1][0] + env.texels[0][0]));
}

#[test]
fn examples_gltf_is_the_writers_output() {
    let shipped = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/arm.gltf");
    let fresh = dir().join("example-arm.gltf");
    let (b, doc) = scenes::gltf_writer::example_arm();
    b.write(doc, &fresh, Container::Embedded).unwrap();
    let (a, b) = (std::fs::read_to_string(&shipped).unwrap(), std::fs::read_to_string(&fresh).unwrap());
    assert!(
        a == b,
        "examples/arm.gltf drifted from scenes::gltf_writer: `cargo run -p scenes --bin write_gltf_example`"
    );
}

/// The complete scene-file example of docs/scene-files.md parses (every key it shows exists, with the type it
/// shows).
#[test]
fn documented_scene_example_parses() {
    let readme =
        std::fs::read_to_string(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../docs/scene-files.md")).unwrap();
    let start = readme.find("**A complete scene file**").expect("the scene-file example of docs/scene-files.md");
    let block = &readme[start..];
    let open = block.find("```toml\n").expect("a toml block") + "```toml\n".len();
    let text = &block[open..open + block[open..].find("```").unwrap()];
    let spec = user::parse_scene_file(text).unwrap_or_else(|e| panic!("docs/scene-files.md example: {e}"));
    assert_eq!((spec.model.len(), spec.light.len()), (1, 1));
    assert_eq!(spec.environment.and_then(|e| e.rotation), Some(120.0));
}

/// A sparse accessor (glTF 2.0 §3.6.2.3) is read with its substitutions: a triangle whose third vertex is moved
/// by a sparse entry.
#[test]
fn sparse_accessors_are_applied() {
    let mut b = GltfBuilder::default();
    let base = b.floats("VEC3", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let indices = b.view(&2u32.to_le_bytes());
    let values: Vec<u8> = [0.0f32, 3.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).collect();
    let values = b.view(&values);
    let view = b.accessors[base]["bufferView"].clone();
    b.accessors.push(json!({
        "bufferView": view, "componentType": 5126, "count": 3, "type": "VEC3",
        "min": [0.0, 0.0, 0.0], "max": [1.0, 3.0, 0.0],
        "sparse": { "count": 1, "indices": { "bufferView": indices, "componentType": 5125 },
                    "values": { "bufferView": values } }
    }));
    let sparse = b.accessors.len() - 1;
    let doc = json!({
        "scene": 0, "scenes": [{ "nodes": [0] }], "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": sparse } }] }],
    });
    let p = dir().join("sparse.gltf");
    b.write(doc, &p, Container::Embedded).unwrap();
    let g = load_gltf(&p, 0).unwrap();
    assert_eq!(g.meshes[0].positions, [Vec3::ZERO, Vec3::X, Vec3::new(0.0, 3.0, 0.0)]);
}

/// `examples/lafortune_map.toml` (paper Fig. 14): the ground is 256 × 256 quads whose vertices take the level of
/// the map below them (the five bands of the far half, left to right; the checkerboard of the near half), the
/// palette blends Phong e = 8 into Lafortune e = 400 (geometric in e); and the map's bad inputs are errors
/// naming the key.
#[test]
fn material_maps_blend_lafortune_per_vertex() {
    use engine::scene::Brdf;
    let assets = scenes::assets_dir();
    let example = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/lafortune_map.toml");
    let u = user::scene_file(&example, None, &assets, &UserOptions::default()).unwrap();
    let s = &u.scene;
    let ground = s.instances.last().unwrap();
    let mesh = &s.meshes[ground.mesh];
    assert_eq!(mesh.positions.len(), 257 * 257);
    assert_eq!(mesh.material_offsets.len(), mesh.positions.len());
    assert_eq!(s.materials.len() - ground.material, 32, "the palette's 32 levels are the last materials");
    let e = |k: usize| match s.materials[ground.material + k].brdf {
        Brdf::Lafortune { e, .. } => e,
        b => panic!("level {k}: {b:?}"),
    };
    assert!((e(0) - 8.0).abs() < 1e-4 && (e(31) - 400.0).abs() < 1e-2, "{} {}", e(0), e(31));
    assert!((e(31) / e(30) - e(1) / e(0)).abs() < 1e-4, "geometric steps in e");
    // The vertex in the middle of each band (far half: row 64 of 257, i.e. a quarter of the way in z).
    let level = |i: usize, j: usize| mesh.material_offsets[j * 257 + i];
    let bands: Vec<u32> = (0..5).map(|b| level(b * 256 / 5 + 25, 64)).collect();
    assert_eq!(bands, vec![0, 8, 16, 23, 31], "t = 0, ¼, ½, ¾, 1 at 32 levels (t = 64/255 → level 8)");
    // The near half: a checkerboard of 0 and 31, alternating tile by tile (tiles of 32 quads).
    assert_eq!([level(16, 144), level(48, 144), level(16, 176)], [0, 31, 31]);

    let d = dir();
    let text = std::fs::read_to_string(&example).unwrap().replace("../assets/", &format!("{}/", assets.display()));
    let cases: [(&str, String, &[&str]); 4] = [
        ("map-levels.toml", text.replace("levels = 32", "levels = 1"), &["ground.material_map.levels", "1"]),
        ("map-missing.toml", text.replace("lafortune_map.png", "absent.png"), &["material_map.file", "absent.png"]),
        (
            "map-blinn.toml",
            text.replace("brdf = \"phong:e=400\"", "brdf = \"blinn-phong:s=100\""),
            &["ground.material_map", "Lafortune"],
        ),
        ("map-subdivisions.toml", text.replace("subdivisions = 256", "subdivisions = 0"), &["ground.subdivisions"]),
    ];
    for (name, text, what) in cases {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        let e = format!("{:#}", user::scene_file(&p, None, &assets, &UserOptions::default()).err().expect(name));
        for w in what {
            assert!(e.contains(w), "{name}: does not say '{w}': {e}");
        }
    }
    // A model's map needs the model's material.
    let p = d.join("map-model.toml");
    let model_map = "[[model]]\nfile = \"{bunny}\"\nspheres = 0\nclip = \"none\"\n\
        material_map = { file = \"{map}\", material = { brdf = \"phong:e=100\" } }\n";
    let text = model_map
        .replace("{bunny}", &assets.join("meshes/bunny.obj").display().to_string())
        .replace("{map}", &assets.join("textures/lafortune_map.png").display().to_string());
    std::fs::write(&p, text).unwrap();
    let e = format!("{:#}", user::scene_file(&p, None, &assets, &UserOptions::default()).err().unwrap());
    assert!(e.contains("model[0].material_map needs model[0].material"), "{e}");
}

/// `examples/lights/{1,2,4}.toml` (docs/measuring.md: "Speed", cost against lights): the same bunny scene with 1, 2
/// and 4 spherical lights, the first two `lamp`'s, and its 64 shipped spheres.
#[test]
fn lights_examples_differ_only_in_their_lights() {
    let assets = scenes::assets_dir();
    let load = |n: usize| {
        let file = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("../examples/lights/{n}.toml"));
        user::scene_file(&file, None, &assets, &UserOptions::default()).unwrap_or_else(|e| panic!("{n}.toml: {e:#}"))
    };
    let scenes: Vec<_> = [1, 2, 4].map(load).into_iter().map(|u| u.scene).collect();
    let lamp = scenes::build("lamp", None).expect("lamp");
    for (s, n) in scenes.iter().zip([1, 2, 4]) {
        assert_eq!(s.lights.len(), n);
        assert_eq!(s.lights[..n.min(2)], lamp.lights[..n.min(2)], "{n}.toml: lamp's lights first");
        assert_eq!(s.instances.len(), scenes[0].instances.len());
        let spheres: usize = s.blockers.spheres.iter().flatten().map(|v| v.len()).sum();
        assert_eq!(spheres, 64, "{n}.toml: the bunny's 64 shipped spheres");
    }
}
