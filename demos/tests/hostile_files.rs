//! Issue 38, items 3, 4, 5 and 8, at the process level (what a user of `demo` sees on stderr): contained parser
//! panics print nothing but the error; a malformed `.mtl` line is named with its file and line; NaN and infinite
//! material values are refused alike in `.mtl`, glTF and scene files; sphere values beyond what the GPU's f32 holds
//! name the sphere and the value; input quoted in an error is cut to a short excerpt.
//!
//! Every run here fails while loading the scene, before any GPU work (no Vulkan driver is offered, so a scene that
//! loaded by mistake fails the run's message check instead of rendering).

use std::path::{Path, PathBuf};
use std::process::Command;

fn temp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("demo-hostile-files-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp folder");
    d
}

/// Run `demo --scene scene` (no Vulkan driver); returns (exit code, stderr).
fn demo_scene(scene: &Path) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_demo"))
        .arg("--scene")
        .arg(scene)
        .args(["--width", "8", "--height", "6", "--technique", "none"])
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .env(
            "SOFTSHADOWS_SPHERE_CACHE",
            std::env::temp_dir().join(format!("demo-hostile-cache-{}", std::process::id())),
        )
        .env_remove("ENGINE_DEVICE")
        .output()
        .expect("running demo");
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// The run failed with one `error:` line holding every needle, and no panic text.
fn assert_error(scene: &Path, needles: &[&str]) -> String {
    let (code, stderr) = demo_scene(scene);
    let what = scene.display();
    assert_eq!(code, Some(1), "{what}: exit status\n{stderr}");
    assert!(!stderr.contains("panicked at"), "{what}: panic text on stderr:\n{stderr}");
    assert_eq!(stderr.lines().filter(|l| l.starts_with("error: ")).count(), 1, "{what}: not one error line:\n{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{what}: the message lacks '{n}':\n{stderr}");
    }
    stderr
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// An OBJ using material `a` of `name`.mtl holding `mtl`.
fn obj_with_mtl(dir: &Path, name: &str, mtl: &str) -> PathBuf {
    std::fs::write(dir.join(format!("{name}.mtl")), mtl).expect("mtl");
    let obj = dir.join(format!("{name}.obj"));
    std::fs::write(&obj, format!("mtllib {name}.mtl\nusemtl a\n{TRI}")).expect("obj");
    obj
}

/// A one-triangle glTF (embedded buffer) with `material` as its material 0.
fn gltf_with_material(dir: &Path, name: &str, material: &str) -> PathBuf {
    let bin: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|f| f.to_le_bytes()).collect();
    let b64 = |b: &[u8]| {
        const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        b.chunks(3)
            .flat_map(|c| {
                let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
                (0..4).map(move |k| if k <= c.len() { T[(n >> (18 - 6 * k) & 63) as usize] as char } else { '=' })
            })
            .collect::<String>()
    };
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],
        "materials":[{material}],
        "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{}"}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}]}}"#,
        b64(&bin)
    );
    let p = dir.join(format!("{name}.gltf"));
    std::fs::write(&p, json).expect("gltf");
    p
}

/// A scene file placing tri.obj, with `extra` TOML in its `[[model]]` table and `more` after it.
fn scene_file(dir: &Path, name: &str, extra: &str, more: &str) -> PathBuf {
    std::fs::write(dir.join("tri.obj"), TRI).expect("obj");
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, format!("[[model]]\nfile = \"tri.obj\"\n{extra}\n{more}")).expect("toml");
    p
}

#[test]
fn contained_parser_panics_print_only_the_error() {
    // The gltf crate panics on this accessor (tools/fuzz/corpus); the loader contains it. It printed
    // `thread 'main' panicked at …` before our error line.
    let input = scenes::assets_dir().join("../tools/fuzz/corpus/gltf/accessor-index-out-of-range.gltf");
    let stderr = assert_error(&input, &["accessor-index-out-of-range.gltf", "not a valid glTF file"]);
    assert_eq!(stderr.lines().count(), 1, "one line, nothing before it:\n{stderr}");
}

#[test]
fn a_malformed_mtl_line_names_the_mtl_and_its_line() {
    let dir = temp("mtl");
    // A bare `Kd` panicked in tobj and was reported as "not a valid OBJ file", naming the OBJ.
    let obj = obj_with_mtl(&dir, "bare", "# one material\nnewmtl a\nKd\n");
    let stderr = assert_error(&obj, &["bare.mtl: line 3", "`Kd` needs three numbers", "material library of"]);
    assert!(!stderr.contains("not a valid OBJ file"), "{stderr}");
    assert_error(&obj_with_mtl(&dir, "two", "newmtl a\nKd 0.5 0.5\n"), &["two.mtl: line 2", "it has 2"]);
    assert_error(&obj_with_mtl(&dir, "ns", "newmtl a\nNs\n"), &["ns.mtl: line 2", "`Ns` needs one number"]);
    assert_error(&obj_with_mtl(&dir, "word", "newmtl a\nKd red 0 0\n"), &["word.mtl: line 2", "'red' is not a number"]);
    // Valid forms load: one number (the spec's r r r), three, and more than three (the first three, as tobj reads).
    for (i, kd) in ["Kd 0.5", "Kd 0.5 0.4 0.3", "Kd 0.5 0.4 0.3 1"].iter().enumerate() {
        let obj = obj_with_mtl(&dir, &format!("ok{i}"), &format!("newmtl a\n{kd}\nNs 10 # shiny\nillum 2\n"));
        let (code, stderr) = demo_scene(&obj);
        assert_eq!(code, Some(1), "{kd}: {stderr}");
        assert!(stderr.contains("no usable Vulkan device") || stderr.contains("vkCreateInstance"), "{kd}: {stderr}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn non_finite_materials_are_refused_in_every_format() {
    let dir = temp("nan");
    // .mtl: `Kd nan` rendered as black, `Ns nan` and `Ks inf` were accepted silently.
    for (i, (line, what)) in [
        ("Kd nan 0 0", "`Kd` value 'nan'"),
        ("Ns nan", "`Ns` value 'nan'"),
        ("Ks inf 0 0", "`Ks` value 'inf'"),
        ("Kd 1e39 0 0", "`Kd` value '1e39'"),
    ]
    .iter()
    .enumerate()
    {
        let obj = obj_with_mtl(&dir, &format!("m{i}"), &format!("newmtl a\n{line}\n"));
        assert_error(&obj, &[&format!("m{i}.mtl: line 2"), what, "is not finite", "material values must be finite"]);
    }
    // glTF: JSON has no NaN or infinity, and a number beyond f32 is refused by the JSON reader (the importer's
    // own check of the factors is the same rule, for a decoder that would let one through).
    for (i, m) in [
        r#"{"pbrMetallicRoughness":{"baseColorFactor":[1e39,0,0,1]}}"#,
        r#"{"pbrMetallicRoughness":{"metallicFactor":-1e39}}"#,
        r#"{"pbrMetallicRoughness":{"roughnessFactor":1e39}}"#,
    ]
    .iter()
    .enumerate()
    {
        let g = gltf_with_material(&dir, &format!("g{i}"), m);
        assert_error(&g, &[&format!("g{i}.gltf"), "not a valid glTF file", "number out of range"]);
    }
    // Scene files (TOML has nan and inf literals).
    for (i, (extra, more, what)) in [
        ("material = { diffuse = [nan, 0, 0] }", "", "model[0].material.diffuse"),
        ("material = { specular = [0, inf, 0] }", "", "model[0].material.specular"),
        ("material = { shininess = nan }", "", "model[0].material.shininess"),
        ("", "[ground]\nmaterial = { diffuse = [0.5, -inf, 0.5] }\n", "ground.material.diffuse"),
    ]
    .iter()
    .enumerate()
    {
        let s = scene_file(&dir, &format!("s{i}"), extra, more);
        assert_error(&s, &[&format!("s{i}.toml"), what, "is not finite"]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn sphere_values_beyond_f32_name_the_sphere_and_the_value() {
    let dir = temp("spheres");
    let file = |spheres: &str| {
        format!(
            r#"{{"format":"engine-blockers/spheres","version":1,"source_mesh":"tri.obj","mesh_hash":"fnv1a64:0",
            "settings":{{"count":1,"seed":1,"grid_resolution":24,"lookup_resolution":48,"volume_samples":96,
            "max_iterations":40,"max_teleports":12,"stall_ratio":0.01}},"stats":null,"spheres":{spheres}}}"#
        )
    };
    // Finite in the file (f64), infinite in f32: the sphere was silently dropped on the GPU.
    for (i, (spheres, needles)) in [
        ("[[0,0,0,0.5],[0,0,0,1e39]]", &["sphere 1", "radius 1e39"][..]),
        ("[[1e39,0,0,0.5]]", &["sphere 0", "centre x 1e39"][..]),
        ("[[0,0,-2e20,0.5]]", &["sphere 0", "centre z -2e20"][..]),
        ("[[0,0,0,1e19]]", &["sphere 0", "radius 1e19", "±1e18"][..]),
    ]
    .iter()
    .enumerate()
    {
        std::fs::write(dir.join(format!("b{i}.spheres.json")), file(spheres)).expect("sphere file");
        let s = scene_file(&dir, &format!("t{i}"), &format!("sphere_files = [\"b{i}.spheres.json\"]"), "");
        let name = format!("b{i}.spheres.json");
        assert_error(&s, &[&[name.as_str()][..], needles].concat());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn errors_quote_huge_input_as_short_excerpts() {
    let dir = temp("excerpt");
    let huge = "x".repeat(100_000);
    let cases: Vec<(PathBuf, &str)> = vec![
        (scene_file(&dir, "key", &format!("{huge} = 1"), ""), "unknown field"),
        (scene_file(&dir, "value", &format!("scale = \"{huge}\""), ""), "invalid type"),
        (scene_file(&dir, "brdf", &format!("material = {{ brdf = \"{huge}\" }}"), ""), "unknown model"),
        (
            scene_file(&dir, "line", "", &format!("[camera]\neye = [0, 0, 1]\ntarget = [0, 0, 0]\n{huge} {huge}\n")),
            "TOML",
        ),
        (
            {
                let p = dir.join("ext.gltf");
                let json = format!(r#"{{"asset":{{"version":"2.0"}},"extensionsRequired":["{huge}"]}}"#);
                std::fs::write(&p, json).expect("gltf");
                p
            },
            "extension",
        ),
        (obj_with_mtl(&dir, "mtlword", &format!("newmtl a\nKd {huge} 0 0\n")), "is not a number"),
        (
            {
                std::fs::write(dir.join("f.spheres.json"), format!(r#"{{"format":"{huge}","version":1}}"#))
                    .expect("json");
                scene_file(&dir, "fmt", "sphere_files = [\"f.spheres.json\"]", "")
            },
            "format",
        ),
    ];
    for (scene, needle) in cases {
        let (code, stderr) = demo_scene(&scene);
        let what = scene.display();
        assert_eq!(code, Some(1), "{what}: exit status\n{}", &stderr[..stderr.len().min(2000)]);
        assert!(!stderr.contains("panicked at"), "{what}: panic text");
        assert!(
            stderr.contains(needle),
            "{what}: the message lacks '{needle}':\n{}",
            &stderr[..stderr.len().min(2000)]
        );
        assert!(stderr.contains("bytes in all"), "{what}: no excerpt:\n{}", &stderr[..stderr.len().min(2000)]);
        assert!(stderr.len() < 2000, "{what}: {} bytes of message:\n{}", stderr.len(), &stderr[..2000]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_model_with_fewer_sample_points_than_spheres_is_fitted_and_named() {
    // Khronos' SimpleSkin has 18 sample points; the default 32 spheres failed with
    // `…/cache/…-n32.spheres.json: cannot fit 32 spheres to 18 sample points`.
    let dir = temp("count");
    let path = dir.join("SimpleSkin.gltf");
    let (b, doc) = scenes::gltf_writer::simple_skin();
    b.write(doc, &path, scenes::gltf_writer::Container::Embedded).expect("writing the strip");
    let (code, stderr) = demo_scene(&path);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(!stderr.contains("panicked at") && !stderr.contains("cannot fit"), "{stderr}");
    for needle in
        ["warning: ", "SimpleSkin.gltf", "supports at most 18 blocker spheres", "not the 32 asked", "--spheres"]
    {
        assert!(stderr.contains(needle), "the warning lacks '{needle}':\n{stderr}");
    }
    // It loaded: only the absent Vulkan driver stopped the run.
    assert!(stderr.contains("no usable Vulkan device") || stderr.contains("vkCreateInstance"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}
