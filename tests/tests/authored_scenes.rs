//! The user's scene as its author made it: a glTF file's cameras, its `KHR_lights_punctual` lights and
//! its own floor, on files our writer makes (`scenes::gltf_writer::lit_room`). CPU only: what the importer reads,
//! what the scene builder makes of it (camera, spherical lights in engine units, floor without spheres and without
//! the engine's ground), and the refusals, each an error naming the file and the thing refused.

use engine::scene::gltf_import::{LightKind, PHOTOMETRIC_EXPOSURE};
use engine::scene::load_gltf;
use glam::Vec3;
use scenes::gltf_writer::{self, lit_room, Container};
use scenes::user::{self, CameraChoice, CameraKey, GroundMode, UserOptions};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// Where the lit room's sun light travels (see `lit_room`).
const SUN_TRAVEL: Vec3 = Vec3::new(-0.556670, -0.766044, -0.321394);

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("authored-scenes-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write_room(name: &str, edit: impl FnOnce(&mut Value)) -> PathBuf {
    let (b, mut doc) = lit_room();
    edit(&mut doc);
    let p = dir().join(name);
    let container = if name.ends_with(".glb") { Container::Glb } else { Container::Embedded };
    b.write(doc, &p, container).unwrap();
    p
}

/// Small, fast sphere fits in a cache of this test's own.
fn opts(test: &str) -> UserOptions {
    UserOptions {
        spheres: Some(4),
        cache: Some(dir().join(format!("cache-{test}"))),
        fit: Some(engine::blockers::fit::FitSettings {
            grid_resolution: 8,
            lookup_resolution: 16,
            volume_samples: 32,
            max_iterations: 4,
            max_teleports: 1,
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn load(p: &Path, o: &UserOptions) -> anyhow::Result<engine::scene::Scene> {
    Ok(scenes::load(p.to_str().unwrap(), None, o)?.scene)
}

fn err(p: &Path, o: &UserOptions) -> String {
    match load(p, o) {
        Ok(_) => panic!("{} loaded; an error was expected", p.display()),
        Err(e) => format!("{e:#}"),
    }
}

#[test]
fn the_importer_reads_cameras_and_punctual_lights() {
    for name in ["room.gltf", "room.glb"] {
        let p = write_room(name, |_| {});
        let g = load_gltf(&p, 0).unwrap();
        assert_eq!(g.cameras.len(), 2, "{name}");
        let main = &g.cameras[0];
        assert_eq!((main.camera, main.name.as_str(), main.node_name.as_str()), (0, "Main", "main-camera"));
        let fov = main.fov_y_degrees.unwrap();
        assert!((fov - gltf_writer::ROOM_CAMERA_YFOV.to_degrees()).abs() < 1e-4, "{fov}");
        assert!(main.world.w_axis.truncate().distance(Vec3::from(gltf_writer::ROOM_CAMERA_EYE)) < 1e-6);
        assert_eq!(g.cameras[1].fov_y_degrees, None, "Top is orthographic");
        assert_eq!(g.lights.len(), 2);
        let (lamp, sun) = (&g.lights[0], &g.lights[1]);
        assert_eq!((lamp.kind, lamp.name.as_str(), lamp.radius), (LightKind::Point, "Lamp", Some(0.2)));
        assert_eq!((lamp.intensity, lamp.color), (gltf_writer::ROOM_LAMP_CANDELA, Vec3::new(1.0, 0.9, 0.8)));
        assert!(lamp.world.w_axis.truncate().distance(Vec3::from(gltf_writer::ROOM_LAMP)) < 1e-6);
        assert_eq!((sun.kind, sun.radius, sun.color), (LightKind::Directional, None, Vec3::ONE));
        // The sun travels along its node's −z: pitched −50° about x then turned 60° about y, by hand
        // (−cos 50° sin 60°, −sin 50°, −cos 50° cos 60°).
        let travel = sun.world.transform_vector3(Vec3::NEG_Z);
        assert!(travel.distance(SUN_TRAVEL) < 1e-4, "{travel}");
    }
}

#[test]
fn a_model_file_is_seen_through_its_own_camera_unless_told_otherwise() {
    let p = write_room("camera.gltf", |_| {});
    let o = opts("camera");
    let s = load(&p, &o).unwrap();
    let eye = Vec3::from(gltf_writer::ROOM_CAMERA_EYE);
    assert!(s.camera.eye.distance(eye) < 1e-5, "{:?}", s.camera);
    assert!((s.camera.fov_y_degrees - gltf_writer::ROOM_CAMERA_YFOV.to_degrees()).abs() < 1e-4);
    let forward = (s.camera.target - s.camera.eye).normalize();
    let wanted = (Vec3::new(0.0, 0.3, 0.0) - eye).normalize();
    assert!(forward.distance(wanted) < 1e-5, "looks at the block: {forward} vs {wanted}");
    // The target lies in front, near the models (the point viewers orbit about).
    assert!((s.camera.target - eye).length() > 1.0);
    // By index and by name (the camera's, or its node's): the same camera.
    for key in [CameraKey::Index(0), CameraKey::Name("Main".into()), CameraKey::Name("main-camera".into())] {
        let t = load(&p, &UserOptions { camera: Some(CameraChoice::File(key.clone())), ..o.clone() }).unwrap();
        assert_eq!(t.camera, s.camera, "{key:?}");
    }
    // auto: the framing of the models without their floor.
    let framed = load(&p, &UserOptions { camera: Some(CameraChoice::Auto), ..o.clone() }).unwrap();
    assert!(framed.camera.eye.distance(eye) > 0.1);
    assert!(framed.camera.target.distance(Vec3::new(0.0, 0.3, 0.0)) < 1e-5, "{:?}", framed.camera);
    // Refusals: orthographic, an unknown index or name (the cameras listed).
    let q = |k: &str| UserOptions { camera: Some(k.parse().unwrap()), ..o.clone() };
    for k in ["1", "Top", "top-camera"] {
        let e = err(&p, &q(k));
        assert!(e.contains("orthographic") && e.contains("camera 1 ('Top')") && e.contains("camera.gltf"), "{e}");
    }
    for k in ["7", "Nope"] {
        let e = err(&p, &q(k));
        assert!(e.contains("no such camera") && e.contains("camera 0 ('Main')"), "{k}: {e}");
    }
    assert!("".parse::<CameraChoice>().is_err());
    // A file whose first camera is orthographic is refused by default, with the way out in the message.
    let ortho_first = write_room("ortho-first.gltf", |d| {
        d["nodes"][2]["camera"] = json!(1);
        d["nodes"][3]["camera"] = json!(0);
    });
    let e = err(&ortho_first, &o);
    assert!(e.contains("orthographic") && e.contains("--camera auto"), "{e}");
    // A file without cameras is framed, as before.
    let none = write_room("no-camera.gltf", |d| {
        d["nodes"][2].as_object_mut().unwrap().remove("camera");
        d["nodes"][3].as_object_mut().unwrap().remove("camera");
        d.as_object_mut().unwrap().remove("cameras");
    });
    assert_eq!(load(&none, &o).unwrap().camera, framed.camera);
    let e = err(&none, &q("Main"));
    assert!(e.contains("has no cameras"), "{e}");
}

#[test]
fn punctual_lights_become_spherical_lights_in_engine_units() {
    let p = write_room("lights.gltf", |_| {});
    let s = load(&p, &opts("lights")).unwrap();
    assert_eq!(s.lights.len(), 2);
    let (lamp, sun) = (s.lights[0], s.lights[1]);
    // Point: a sphere of the node's extras.radius at the node, radiance I / (π r²) / 683 per channel.
    let r = gltf_writer::ROOM_LAMP_RADIUS;
    assert!(lamp.center.distance(Vec3::from(gltf_writer::ROOM_LAMP)) < 1e-6);
    assert!((lamp.radius - r).abs() < 1e-7);
    let want = Vec3::new(1.0, 0.9, 0.8) * gltf_writer::ROOM_LAMP_CANDELA * PHOTOMETRIC_EXPOSURE
        / (std::f32::consts::PI * r * r);
    assert!((lamp.radiance - want).abs().max_element() < 1e-5 * want.max_element(), "{} vs {want}", lamp.radiance);
    // Its irradiance at the floor below it, by quadrature over the sphere's solid angle, is I / d² (× exposure):
    // the sphere gives what the point light gives.
    let below = Vec3::new(lamp.center.x, 0.0, lamp.center.z);
    let e = irradiance(below, Vec3::Y, lamp.center, lamp.radius, lamp.radiance.x as f64);
    let d = lamp.center.y as f64;
    let point = gltf_writer::ROOM_LAMP_CANDELA as f64 * PHOTOMETRIC_EXPOSURE as f64 / (d * d);
    assert!((e / point - 1.0).abs() < 2e-3, "sphere {e} vs point {point}");
    // Directional: 0.27° seen from the scene, along the node's +z, far away; illuminance facing it E (× exposure).
    let to_sun = (sun.center - Vec3::new(0.0, 0.3, 0.0)).normalize();
    assert!(to_sun.distance(-SUN_TRAVEL) < 1e-3, "{to_sun}");
    let alpha = (sun.radius / sun.center.distance(Vec3::new(0.0, 0.3, 0.0))).asin().to_degrees();
    assert!((alpha - 0.27).abs() < 1e-3, "{alpha}°");
    let e = irradiance(Vec3::new(0.0, 0.3, 0.0), to_sun, sun.center, sun.radius, sun.radiance.x as f64);
    let lux = gltf_writer::ROOM_SUN_LUX as f64 * PHOTOMETRIC_EXPOSURE as f64;
    assert!((e / lux - 1.0).abs() < 2e-3, "sun {e} vs {lux}");
}

/// Irradiance at `p` (normal `n`) from a sphere of uniform radiance `l`: quadrature over the cone it subtends.
fn irradiance(p: Vec3, n: Vec3, center: Vec3, radius: f32, l: f64) -> f64 {
    let (p, n, c) = (p.as_dvec3(), n.as_dvec3(), center.as_dvec3());
    let axis = (c - p).normalize();
    let cos_max = (1.0 - (radius as f64 / (c - p).length()).powi(2)).sqrt();
    let (t, b) = axis.any_orthonormal_pair();
    let (nt, np) = (400, 64);
    let mut sum = 0.0;
    for i in 0..nt {
        // Uniform in cos θ over [cos_max, 1]: each cell has solid angle (1 − cos_max) 2π / (nt np).
        let cos = 1.0 - (1.0 - cos_max) * (i as f64 + 0.5) / nt as f64;
        let sin = (1.0 - cos * cos).sqrt();
        for j in 0..np {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / np as f64;
            let w = axis * cos + (t * phi.cos() + b * phi.sin()) * sin;
            sum += w.dot(n).max(0.0);
        }
    }
    l * sum * (1.0 - cos_max) * std::f64::consts::TAU / (nt * np) as f64
}

#[test]
fn refused_and_bad_lights_name_the_file_and_the_light() {
    let o = opts("bad-lights");
    let spot = write_room("spot.gltf", |d| {
        d["extensions"]["KHR_lights_punctual"]["lights"][0] =
            json!({ "name": "Cone", "type": "spot", "intensity": 10.0, "spot": { "outerConeAngle": 0.5 } });
    });
    let e = err(&spot, &o);
    assert!(e.contains("spot.gltf") && e.contains("light 0 ('Cone')") && e.contains("spot"), "{e}");
    assert!(e.contains("lights = false"), "the way out: {e}");
    let bad_radius = write_room("bad-radius.gltf", |d| d["nodes"][4]["extras"] = json!({ "radius": -1.0 }));
    let e = err(&bad_radius, &o);
    assert!(e.contains("bad-radius.gltf") && e.contains("extras.radius") && e.contains("node 4"), "{e}");
    let text_radius = write_room("text-radius.gltf", |d| d["nodes"][4]["extras"] = json!({ "radius": "big" }));
    assert!(err(&text_radius, &o).contains("extras.radius"));
    let negative = write_room("negative.gltf", |d| {
        d["extensions"]["KHR_lights_punctual"]["lights"][1]["intensity"] = json!(-5.0);
    });
    let e = err(&negative, &o);
    assert!(e.contains("negative.gltf") && e.contains("light 1 ('Sun')") && e.contains("intensity"), "{e}");
    let huge = write_room("huge.gltf", |d| {
        d["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = json!(1e39);
    });
    // Beyond f32: the JSON parser refuses it first ("number out of range"), naming the file and the line.
    let e = err(&huge, &o);
    assert!(e.contains("huge.gltf") && e.contains("out of range"), "{e}");
    // Extras that are not an object, or have no radius, leave the default radius (0.1).
    let plain = write_room("plain-extras.gltf", |d| d["nodes"][4]["extras"] = json!([1, 2]));
    assert!((load(&plain, &o).unwrap().lights[0].radius - 0.1).abs() < 1e-7);
}

#[test]
fn a_model_with_its_own_floor_gets_no_engine_ground_and_no_spheres_on_the_floor() {
    let p = write_room("floor.gltf", |_| {});
    let o = opts("floor");
    let s = load(&p, &o).unwrap();
    // block, floor; no engine ground (auto).
    assert_eq!(s.meshes.len(), 2, "{:?}", s.meshes.iter().map(|m| &m.name).collect::<Vec<_>>());
    assert_eq!(user::find_floors(&s), vec![false, true]);
    assert!(s.blockers.spheres_of(0).is_some_and(|x| !x.is_empty()), "the block casts");
    assert!(s.blockers.spheres_of(1).is_none(), "the floor only receives");
    assert!(s.blockers.is_plane(1), "the floor, a rectangle, blocks as the engine's ground does");
    // engine: the engine's ground as well, at the floor's height (the user asked for it).
    let both = load(&p, &UserOptions { ground: Some(GroundMode::Engine), ..o.clone() }).unwrap();
    assert_eq!(both.meshes.len(), 3);
    assert!(both.blockers.spheres_of(1).is_none() && both.blockers.is_plane(2));
    assert!(both.instances[2].transform.w_axis.y.abs() < 1e-6);
    // none: neither; the floor still casts nothing.
    let bare = load(&p, &UserOptions { ground: Some(GroundMode::None), ..o.clone() }).unwrap();
    assert_eq!(bare.meshes.len(), 2);
    // A floor smaller than what stands on it is no floor: it gets spheres, and the engine's ground comes back.
    let small = write_room("small-floor.gltf", |d| {
        d["nodes"][1]["scale"] = json!([0.1, 1.0, 0.1]);
    });
    let s = load(&small, &o).unwrap();
    assert_eq!(s.meshes.len(), 3, "block, floor, the engine's ground");
    assert_eq!(user::find_floors(&s)[..2], [false, false]);
    assert!(s.blockers.spheres_of(1).is_some());
    // A model without a floor keeps the engine's ground in auto, loses it with none.
    let arm = dir().join("arm.gltf");
    let (b, doc) = gltf_writer::two_bone_arm(8, 8);
    b.write(doc, &arm, Container::Embedded).unwrap();
    assert_eq!(load(&arm, &o).unwrap().meshes.len(), 3, "arm, stone, ground");
    assert_eq!(load(&arm, &UserOptions { ground: Some(GroundMode::None), ..o.clone() }).unwrap().meshes.len(), 2);
    assert!("sideways".parse::<GroundMode>().is_err());
    // Registered scenes take neither option.
    let e = scenes::load("bunny", None, &UserOptions { ground: Some(GroundMode::None), ..Default::default() });
    assert!(format!("{:#}", e.err().unwrap()).contains("--ground applies to file scenes"));
}

fn scene_file(name: &str, text: &str) -> anyhow::Result<engine::scene::Scene> {
    let d = dir();
    let room = d.join("room-for-toml.gltf");
    if !room.exists() {
        let (b, doc) = lit_room();
        b.write(doc, &room, Container::Embedded).unwrap();
    }
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    let o = opts("toml");
    Ok(user::scene_file(&p, None, &scenes::assets_dir(), &o)?.scene)
}

#[test]
fn scene_files_name_a_models_camera_its_lights_and_its_receivers() {
    let model = "[[model]]\nfile = \"room-for-toml.gltf\"\ntranslation = [1.0, 0.0, 0.0]\n";
    // No [camera]: framed, as before; a model's camera by name, moved with its model.
    let framed = scene_file("a.toml", model).unwrap();
    let named = scene_file("b.toml", &format!("[camera]\nmodel = 0\nname = \"Main\"\n{model}")).unwrap();
    let eye = Vec3::from(gltf_writer::ROOM_CAMERA_EYE) + Vec3::X;
    assert!(named.camera.eye.distance(eye) < 1e-5 && framed.camera.eye.distance(eye) > 0.1);
    let by_index = scene_file("c.toml", &format!("[camera]\nname = 0\n{model}")).unwrap();
    assert_eq!(by_index.camera, named.camera);
    let first = scene_file("d.toml", &format!("[camera]\nmodel = 0\n{model}")).unwrap();
    assert_eq!(first.camera, named.camera);
    let e = format!("{:#}", scene_file("e.toml", &format!("[camera]\nname = \"Top\"\n{model}")).err().unwrap());
    assert!(e.contains("orthographic"), "{e}");
    let e = format!("{:#}", scene_file("f.toml", &format!("[camera]\nmodel = 3\n{model}")).err().unwrap());
    assert!(e.contains("camera.model: 3"), "{e}");
    let e = format!(
        "{:#}",
        scene_file("g.toml", &format!("[camera]\nmodel = 0\neye = [0.0, 1.0, 2.0]\ntarget = [0.0, 0.0, 0.0]\n{model}"))
            .err()
            .unwrap()
    );
    assert!(e.contains("not both"), "{e}");
    assert_eq!(scene_file("h.toml", &format!("[camera]\nauto = true\n{model}")).unwrap().camera, framed.camera);
    // Lights: the file's, moved with the model; light_radius and light_intensity; lights = false drops them.
    assert_eq!(framed.lights.len(), 2);
    assert!(framed.lights[0].center.distance(Vec3::from(gltf_writer::ROOM_LAMP) + Vec3::X) < 1e-5);
    let tuned = scene_file("i.toml", &format!("{model}light_radius = 0.4\nlight_intensity = 2.0\nlight_angle = 1.0\n"))
        .unwrap();
    assert!((tuned.lights[0].radius - 0.4).abs() < 1e-6);
    // Radiance ∝ intensity / r²: twice the intensity on four times the area.
    let ratio = tuned.lights[0].radiance.x / framed.lights[0].radiance.x;
    assert!((ratio - 2.0 * 0.25 / 1.0).abs() < 1e-4, "{ratio}");
    let sun_alpha = |s: &engine::scene::Scene| (s.lights[1].radius / s.lights[1].center.length()).asin().to_degrees();
    assert!((sun_alpha(&tuned) - 1.0).abs() < 0.01, "{}", sun_alpha(&tuned));
    assert!(scene_file("j.toml", &format!("{model}lights = false\n")).unwrap().lights.is_empty());
    for (bad, what) in [("light_radius = 0.0", "light_radius"), ("light_angle = 90.0", "light_angle")] {
        let e = format!("{:#}", scene_file("k.toml", &format!("{model}{bad}\n")).err().unwrap());
        assert!(e.contains(what), "{e}");
    }
    // Receivers: the block only receives (no spheres); an unknown mesh is an error listing the meshes.
    let r = scene_file("l.toml", &format!("{model}receivers = [\"block\"]\n")).unwrap();
    assert!(r.blockers.spheres_of(0).is_none());
    let e = format!("{:#}", scene_file("m.toml", &format!("{model}receivers = [\"table\"]\n")).err().unwrap());
    assert!(e.contains("no mesh 'table'") && e.contains("block#0") && e.contains("floor#0"), "{e}");
    // ground.mode: engine adds the engine's ground under the model's floor; a bad mode is an error.
    assert_eq!(framed.meshes.len(), 2);
    assert_eq!(scene_file("n.toml", &format!("[ground]\nmode = \"engine\"\n{model}")).unwrap().meshes.len(), 3);
    let e = format!("{:#}", scene_file("o.toml", &format!("[ground]\nmode = \"sky\"\n{model}")).err().unwrap());
    assert!(e.contains("ground.mode"), "{e}");
}

#[test]
fn examples_lit_room_is_the_writers_output() {
    let shipped = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/lit_room.gltf");
    let fresh = dir().join("example-lit-room.gltf");
    let (b, doc) = lit_room();
    b.write(doc, &fresh, Container::Embedded).unwrap();
    let (a, b) = (std::fs::read_to_string(&shipped).unwrap(), std::fs::read_to_string(&fresh).unwrap());
    assert!(a == b, "examples/lit_room.gltf drifted: `cargo run -p scenes --bin write_gltf_example -- --model room`");
}
