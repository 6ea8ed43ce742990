//! Mitsuba 3 export (`demo --export`): the bunny scene and the lamp scene (spherical lights) export to XML that a
//! real XML parser reads, whose referenced files exist and parse (PLY headers and sizes match the scene's meshes, the
//! EXR opens), with the camera, environment emitter, materials and lights carrying the scene's values.

use engine::scene::Scene;
use glam::Vec3;
use lab::export::{export_mitsuba, ExportBsdf, ExportOptions};
use std::path::{Path, PathBuf};

fn out_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("demo-export-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn floats(s: &str) -> Vec<f64> {
    s.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).map(|t| t.parse().unwrap()).collect()
}

fn close(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-5 * (1.0 + y.abs()))
}

/// Parse a binary little-endian PLY written by the export: (vertex count, face count, positions), checking the
/// header's properties and that the body has exactly the declared size and only triangles with valid indices.
fn read_ply(path: &Path) -> (usize, usize, Vec<[f32; 3]>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let end = bytes.windows(11).position(|w| w == b"end_header\n").expect("end_header") + 11;
    let header = std::str::from_utf8(&bytes[..end]).expect("ASCII header");
    let mut lines = header.lines();
    assert_eq!(lines.next(), Some("ply"));
    assert_eq!(lines.next(), Some("format binary_little_endian 1.0"));
    let (mut nv, mut nf, mut props) = (0, 0, Vec::new());
    for l in lines {
        let t: Vec<&str> = l.split_whitespace().collect();
        match t.as_slice() {
            ["element", "vertex", n] => nv = n.parse().unwrap(),
            ["element", "face", n] => nf = n.parse().unwrap(),
            ["property", "float", name] => props.push(name.to_string()),
            ["property", "list", "uchar", "int", "vertex_indices"] | ["end_header"] | ["comment", ..] => {}
            other => panic!("unexpected header line {other:?}"),
        }
    }
    assert_eq!(props, ["x", "y", "z", "nx", "ny", "nz"]);
    let body = &bytes[end..];
    assert_eq!(body.len(), nv * 24 + nf * 13, "{}: body size", path.display());
    let f = |o: usize| f32::from_le_bytes(body[o..o + 4].try_into().unwrap());
    let positions: Vec<[f32; 3]> = (0..nv).map(|v| [f(v * 24), f(v * 24 + 4), f(v * 24 + 8)]).collect();
    for v in 0..nv {
        let n = [f(v * 24 + 12), f(v * 24 + 16), f(v * 24 + 20)];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!((len - 1.0).abs() < 1e-3, "vertex {v}: normal length {len}");
    }
    for t in 0..nf {
        let o = nv * 24 + t * 13;
        assert_eq!(bytes[end + o], 3, "face {t} is not a triangle");
        for k in 0..3 {
            let i = i32::from_le_bytes(body[o + 1 + 4 * k..o + 5 + 4 * k].try_into().unwrap());
            assert!(i >= 0 && (i as usize) < nv, "face {t}: index {i} of {nv}");
        }
    }
    (nv, nf, positions)
}

fn named<'a, 'i>(node: roxmltree::Node<'a, 'i>, tag: &str, name: &str) -> Option<roxmltree::Node<'a, 'i>> {
    node.children().find(|c| c.tag_name().name() == tag && c.attribute("name") == Some(name))
}

/// Export, parse and check everything the XML references; returns the parsed XML text for scene-specific checks.
fn export_and_check(scene: &Scene, tag: &str, bsdf: ExportBsdf) -> (PathBuf, String) {
    let dir = out_dir(tag);
    let opts = ExportOptions { width: 160, height: 120, spp: 64, camera: None, bsdf };
    let exported = export_mitsuba(scene, &dir, &opts).expect("export");
    let text = std::fs::read_to_string(&exported.xml).expect("scene.xml");
    let doc = roxmltree::Document::parse(&text).expect("scene.xml is well-formed XML");
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "scene");
    assert_eq!(root.attribute("version"), Some("3.0.0"));

    // Camera.
    let sensor = root.children().find(|c| c.has_tag_name("sensor")).expect("sensor");
    assert_eq!(sensor.attribute("type"), Some("perspective"));
    let fov = named(sensor, "float", "fov").expect("fov").attribute("value").unwrap();
    assert_eq!(fov.parse::<f32>().unwrap(), scene.camera.fov_y_degrees);
    assert_eq!(named(sensor, "string", "fov_axis").unwrap().attribute("value"), Some("y"));
    let lookat = sensor.descendants().find(|c| c.has_tag_name("lookat")).expect("lookat");
    let cam = scene.camera;
    assert!(close(&floats(lookat.attribute("origin").unwrap()), &[cam.eye.x, cam.eye.y, cam.eye.z].map(f64::from)));
    assert!(close(
        &floats(lookat.attribute("target").unwrap()),
        &[cam.target.x, cam.target.y, cam.target.z].map(f64::from)
    ));
    let up = floats(lookat.attribute("up").unwrap());
    let f = (cam.target - cam.eye).normalize();
    assert!((up[0] * f.x as f64 + up[1] * f.y as f64 + up[2] * f.z as f64).abs() < 1e-5, "up ⟂ view direction");
    assert!(up[1] > 0.0, "up points up");
    let film = sensor.children().find(|c| c.has_tag_name("film")).expect("film");
    assert_eq!(named(film, "integer", "width").unwrap().attribute("value"), Some("160"));
    assert_eq!(named(film, "integer", "height").unwrap().attribute("value"), Some("120"));

    // Environment emitter: file, scale, the −90° rotation about +Y.
    let env = root
        .children()
        .find(|c| c.has_tag_name("emitter") && c.attribute("type") == Some("envmap"))
        .expect("envmap emitter");
    let file = named(env, "string", "filename").unwrap().attribute("value").unwrap();
    let map = engine::scene::load_environment(&dir.join(file)).expect("envmap.exr opens");
    assert_eq!((map.width, map.height), (scene.environment.width, scene.environment.height));
    let expect = lab::export::mitsuba_envmap(&scene.environment);
    assert!(map.texels.iter().zip(expect.chunks_exact(4)).all(|(a, b)| a[..] == b[..3]), "EXR holds the resampled map");
    let scale = named(env, "float", "scale").unwrap().attribute("value").unwrap();
    assert_eq!(scale.parse::<f32>().unwrap(), scene.environment_intensity);
    let matrix = env.descendants().find(|c| c.has_tag_name("matrix")).expect("to_world matrix");
    assert_eq!(
        floats(matrix.attribute("value").unwrap()),
        [0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    );

    // Materials: one per scene material, with an id the shapes reference.
    let bsdf_ids: Vec<&str> =
        root.children().filter(|c| c.has_tag_name("bsdf")).map(|c| c.attribute("id").expect("bsdf id")).collect();
    assert_eq!(bsdf_ids.len(), scene.materials.len());

    // Meshes: one PLY per instance, in world space, matching the scene's vertex and triangle counts.
    let shapes: Vec<_> =
        root.children().filter(|c| c.has_tag_name("shape") && c.attribute("type") == Some("ply")).collect();
    assert_eq!(shapes.len(), scene.instances.len());
    for (i, (shape, inst)) in shapes.iter().zip(&scene.instances).enumerate() {
        let file = named(*shape, "string", "filename").unwrap().attribute("value").unwrap();
        let (nv, nf, pos) = read_ply(&dir.join(file));
        let mesh = &scene.meshes[inst.mesh];
        assert_eq!((nv, nf), (mesh.positions.len(), mesh.indices.len() / 3), "instance {i}");
        let r = shape.children().find(|c| c.has_tag_name("ref")).expect("material ref");
        assert_eq!(r.attribute("id"), Some(format!("mat{}", inst.material).as_str()));
        assert!(bsdf_ids.contains(&r.attribute("id").unwrap()));
        // World space: vertex 0 went through the instance transform (no skins in these scenes).
        let w = inst.transform.transform_point3(mesh.positions[0]);
        assert!((Vec3::from(pos[0]) - w).length() < 1e-5, "instance {i}: {:?} vs {w}", pos[0]);
    }
    // The plugin and the runner beside scene.xml, byte for byte the repository's files.
    assert_eq!(exported.plugin, dir.join("ours_bsdf.py"));
    assert_eq!(exported.runner, dir.join("render.py"));
    assert_eq!(std::fs::read_to_string(&exported.plugin).unwrap(), lab::export::PLUGIN_PY);
    assert_eq!(std::fs::read_to_string(&exported.runner).unwrap(), lab::export::RENDER_PY);
    (dir, text)
}

/// Python's own compiler accepts the file (as `py_compile` does, but without writing `__pycache__` beside it), or
/// a printed reason when there is no python3.
fn py_compiles(path: &Path) {
    let check = "import sys; compile(open(sys.argv[1], encoding='utf-8').read(), sys.argv[1], 'exec')";
    match std::process::Command::new("python3").arg("-c").arg(check).arg(path).output() {
        Ok(o) => assert!(o.status.success(), "{}: {}", path.display(), String::from_utf8_lossy(&o.stderr)),
        Err(e) => eprintln!("skipping the Python syntax check of {}: no python3 ({e})", path.display()),
    }
}

/// The `<float>`/`<string>` parameters of a plugin material, by name.
fn params(bsdf: roxmltree::Node) -> std::collections::HashMap<String, String> {
    bsdf.children()
        .filter(|c| c.is_element())
        .map(|c| (c.attribute("name").unwrap().to_string(), c.attribute("value").unwrap().to_string()))
        .collect()
}

#[test]
fn bunny_exports_as_mitsuba_scene() {
    let scene = scenes::build("bunny", None).expect("bunny scene");
    let (dir, text) = export_and_check(&scene, "bunny", ExportBsdf::Builtin);
    // The glossy bunny is a blend of diffuse and a Beckmann conductor; the ground is plain diffuse.
    let doc = roxmltree::Document::parse(&text).unwrap();
    let mat0 = doc.descendants().find(|c| c.attribute("id") == Some("mat0")).unwrap();
    let blend = mat0.descendants().find(|c| c.attribute("type") == Some("blendbsdf")).expect("blendbsdf");
    let cond = blend.children().find(|c| c.attribute("type") == Some("roughconductor")).expect("roughconductor");
    let alpha = cond.children().find(|c| c.attribute("name") == Some("alpha")).unwrap().attribute("value").unwrap();
    assert!((alpha.parse::<f32>().unwrap() - (2.0f32 / 202.0).sqrt()).abs() < 1e-6);
    let mat1 = doc.descendants().find(|c| c.attribute("id") == Some("mat1")).unwrap();
    assert!(mat1.descendants().all(|c| c.attribute("type") != Some("blendbsdf")));
    assert!(!text.contains("type=\"sphere\""), "the bunny scene has no lights");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn sphere_lights_export_as_area_emitters() {
    // The registry's scene with spherical lights.
    let scene = scenes::build("lamp", None).expect("lamp scene");
    assert!(scene.lights.len() >= 2 && scene.environment_intensity != 1.0, "lamp: lights and a dimmed environment");
    let (dir, text) = export_and_check(&scene, "light", ExportBsdf::Plugin);
    let doc = roxmltree::Document::parse(&text).unwrap();
    let lights: Vec<_> = doc
        .root_element()
        .children()
        .filter(|c| c.has_tag_name("shape") && c.attribute("type") == Some("sphere"))
        .collect();
    assert_eq!(lights.len(), scene.lights.len(), "one sphere shape per light");
    for (shape, l) in lights.iter().zip(&scene.lights) {
        let value = |tag: &str, name: &str| {
            shape
                .descendants()
                .find(|c| c.has_tag_name(tag) && c.attribute("name") == Some(name))
                .and_then(|c| c.attribute("value"))
                .unwrap_or_else(|| panic!("{tag} {name}"))
        };
        assert!(close(&floats(value("point", "center")), &l.center.to_array().map(f64::from)));
        assert!(close(&floats(value("float", "radius")), &[l.radius as f64]));
        let emitter = shape.children().find(|c| c.has_tag_name("emitter")).expect("emitter");
        assert_eq!(emitter.attribute("type"), Some("area"));
        assert!(close(&floats(value("rgb", "radiance")), &l.radiance.to_array().map(f64::from)));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn plugin_export_writes_every_model_exactly() {
    use engine::scene::{Brdf, Ndf};
    let mut scene = scenes::build("bunny", None).expect("bunny scene");
    // One material per model: the bunny's Blinn-Phong, then Cook-Torrance (both NDFs) and Ashikhmin-Shirley.
    let base = scene.materials[0];
    scene
        .materials
        .push(engine::scene::Material { brdf: Brdf::CookTorrance { ndf: Ndf::Ggx, roughness: 0.25 }, ..base });
    scene
        .materials
        .push(engine::scene::Material { brdf: Brdf::CookTorrance { ndf: Ndf::Beckmann, roughness: 0.1 }, ..base });
    scene.materials.push(engine::scene::Material {
        brdf: Brdf::AshikhminShirley { nu: 300.0, nv: 20.0 },
        tangent: Vec3::new(1.0, 0.0, 0.5),
        ..base
    });
    let (dir, text) = export_and_check(&scene, "plugin", ExportBsdf::Plugin);
    let doc = roxmltree::Document::parse(&text).unwrap();
    let bsdfs: Vec<_> = doc.root_element().children().filter(|c| c.has_tag_name("bsdf")).collect();
    assert!(bsdfs.iter().all(|b| b.attribute("type") == Some("ours")), "every material is the plugin");
    let expect = [
        ("blinn-phong", vec![("s", base.shininess)]),
        ("blinn-phong", vec![("s", scene.materials[1].shininess)]),
        ("cook-torrance-ggx", vec![("alpha", 0.25)]),
        ("cook-torrance-beckmann", vec![("alpha", 0.1)]),
        ("ashikhmin-shirley", vec![("nu", 300.0), ("nv", 20.0), ("tangent_x", 1.0), ("tangent_z", 0.5)]),
    ];
    assert_eq!(bsdfs.len(), expect.len());
    for ((bsdf, (model, extra)), m) in bsdfs.iter().zip(&expect).zip(&scene.materials) {
        let p = params(*bsdf);
        assert_eq!(p["model"], *model);
        let num = |k: &str| p[k].parse::<f32>().unwrap_or_else(|e| panic!("{k}: {e}"));
        for (i, c) in ["r", "g", "b"].iter().enumerate() {
            assert_eq!(num(&format!("kd_{c}")), m.diffuse[i]);
            assert_eq!(num(&format!("ks_{c}")), m.specular[i]);
        }
        for (k, v) in extra {
            assert_eq!(num(k), *v, "{model}: {k}");
        }
    }
    assert!(text.contains("python3 render.py"), "scene.xml says how to render it");
    py_compiles(&dir.join("ours_bsdf.py"));
    py_compiles(&dir.join("render.py"));
    // The plugin's own self-check (run by hand where Mitsuba is installed; not exported).
    py_compiles(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src/mitsuba/check_bsdf.py"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn builtin_export_refuses_what_it_cannot_approximate() {
    let mut scene = scenes::build("bunny", None).expect("bunny scene");
    scene.materials[0].brdf = engine::scene::Brdf::AshikhminShirley { nu: 100.0, nv: 100.0 };
    let dir = out_dir("refuse");
    let opts = ExportOptions { width: 8, height: 6, spp: 1, camera: None, bsdf: ExportBsdf::Builtin };
    let e = export_mitsuba(&scene, &dir, &opts).expect_err("builtin export of Ashikhmin-Shirley");
    assert!(format!("{e:#}").contains("--export-bsdf plugin"), "{e:#}");
    // Blinn-Phong whose blend would need a reflectance above 1 (ρ_d 0.7 / (1 − w) with k_s 0.5).
    scene.materials[0] = engine::scene::Material::glossy(Vec3::splat(0.7), 0.5, 1000.0);
    let e = export_mitsuba(&scene, &dir, &opts).expect_err("builtin export of ρ_d 0.7, k_s 0.5");
    assert!(format!("{e:#}").contains("outside the [0, 1]"), "{e:#}");
    // The plugin exports both.
    let opts = ExportOptions { bsdf: ExportBsdf::Plugin, ..opts };
    export_mitsuba(&scene, &dir, &opts).expect("plugin export");
    assert_eq!(ExportBsdf::parse("plugin"), Ok(ExportBsdf::Plugin));
    assert!(ExportBsdf::parse("mitsuba").is_err());
    // Per-vertex materials (a material map) are not carried: refused, not exported as the first level.
    let mut mapped = scenes::build("bunny", None).expect("bunny scene");
    mapped.materials.push(mapped.materials[1]);
    let ground = &mut mapped.meshes[1];
    ground.material_offsets = ground.positions.iter().map(|p| u32::from(p.x > 0.0)).collect();
    let e = export_mitsuba(&mapped, &dir, &opts).expect_err("per-vertex materials");
    assert!(format!("{e:#}").contains("per-vertex materials"), "{e:#}");
    let _ = std::fs::remove_dir_all(&dir);
}
