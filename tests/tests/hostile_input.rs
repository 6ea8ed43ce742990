//! Inputs that used to kill the process (issue 14, defects 2 and 3): each must now be an error naming the
//! file, quickly, with no abort, panic or runaway allocation.
//! - Environment maps whose header announces a huge image (a Radiance `-Y 65536 +X 65536` header in 8 KB
//!   asked for 51.5 GB; corrupt OpenEXR dataWindows asked for up to 3.4 PB) or a file too short for it.
//! - glTF files the `gltf` crates panic on, and node graphs with cycles (once a million visits, copying a
//!   mesh on each).

use engine::scene::{load_environment, load_gltf, MAX_ENV_TEXELS};
use engine_tests::assert_err_names;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn tmp(name: &str, bytes: &[u8]) -> PathBuf {
    engine_tests::temp_file("hostile-input", name, bytes)
}

/// Run `f`, require it to finish in under 2 s.
fn quick<T>(what: &str, f: impl FnOnce() -> T) -> T {
    let t0 = Instant::now();
    let r = f();
    assert!(t0.elapsed() < Duration::from_secs(2), "{what} took {:?}", t0.elapsed());
    r
}

#[test]
fn hdr_headers_announcing_huge_images_are_refused() {
    let hdr = |res: &str| {
        let mut b = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{res}\n").into_bytes();
        b.resize(8192, 0x80);
        b
    };
    // Over the documented maximum (the 51.5 GB request).
    let p = tmp("huge.hdr", &hdr("-Y 65536 +X 65536"));
    assert_err_names(quick("huge.hdr", || load_environment(&p)).unwrap_err(), &p, "larger than");
    // Within the maximum but far more than 8 KB can encode.
    let p = tmp("short.hdr", &hdr("-Y 8192 +X 16384"));
    assert_err_names(quick("short.hdr", || load_environment(&p)).unwrap_err(), &p, "truncated");
    // Overflowing numbers.
    let p = tmp("overflow.hdr", &hdr("-Y 18446744073709551615 +X 18446744073709551615"));
    assert_err_names(quick("overflow.hdr", || load_environment(&p)).unwrap_err(), &p, "Radiance");
}

/// A small, valid EXR written by the `exr` crate (uncompressed, 8 × 4).
fn tiny_exr() -> Vec<u8> {
    use exr::prelude::*;
    let layer = Layer::new(
        (8, 4),
        LayerAttributes::named("rgb"),
        Encoding::UNCOMPRESSED,
        SpecificChannels::rgb(|p: Vec2<usize>| (p.x() as f32, p.y() as f32, 0.5f32)),
    );
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer).write().to_buffered(&mut out).expect("write tiny exr");
    out.into_inner()
}

/// Overwrite the `dataWindow` box2i (xMin, yMin, xMax, yMax) of the first header, and its `chunkCount`
/// to match (as a consistent but hostile writer would: the `exr` crate refuses a mismatch by itself).
fn patch_data_window(bytes: &mut [u8], b: [i32; 4]) {
    let find = |bytes: &[u8], key: &[u8]| bytes.windows(key.len()).position(|w| w == key).map(|i| i + key.len() + 4);
    let at = find(bytes, b"dataWindow\0box2i\0").expect("dataWindow");
    for (k, v) in b.iter().enumerate() {
        bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
    }
    let lines = match find(bytes, b"compression\0compression\0").map(|i| bytes[i]) {
        Some(0..=2) | None => 1i64,
        Some(3 | 5) => 16,
        Some(9) => 256,
        Some(_) => 32,
    };
    if let Some(at) = find(bytes, b"chunkCount\0int\0") {
        let h = b[3] as i64 - b[1] as i64 + 1;
        let chunks = (h.max(0) + lines - 1) / lines;
        bytes[at..at + 4].copy_from_slice(&(chunks.clamp(0, i32::MAX as i64) as i32).to_le_bytes());
    }
}

#[test]
fn exr_headers_announcing_huge_images_are_refused() {
    let tiny = tiny_exr();
    let p = tmp("tiny.exr", &tiny);
    let map = load_environment(&p).expect("the unpatched tiny EXR loads");
    assert_eq!((map.width, map.height), (8, 4));

    let shipped = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/envmaps/courtyard.exr"))
        .expect("courtyard.exr");
    for (name, base) in [("tiny", &tiny), ("courtyard", &shipped)] {
        let cases: [(&str, [i32; 4], &str); 6] = [
            // 2^24 × 2^24 texels: the 3.4 PB request that aborted the process.
            ("petabytes", [0, 0, (1 << 24) - 1, (1 << 24) - 1], "larger than"),
            // 2^30 × 2^30: `vec!` panicked with "capacity overflow".
            ("capacity-overflow", [0, 0, (1 << 30) - 1, (1 << 30) - 1], "larger than"),
            ("integer-maximum", [0, 0, i32::MAX - 1, i32::MAX - 1], "larger than"),
            ("inverted", [0, 0, -5, 10], "inverted"),
            ("overflow", [i32::MIN, i32::MIN, i32::MAX, i32::MAX], "larger than"),
            // Within the maximum (16384 × 8192) but far more chunks than the tiny file holds.
            ("short", [0, 0, 16383, 8191], "need at least"),
        ];
        for (case, window, what) in cases {
            if name == "courtyard" && case == "short" {
                continue; // 2 MB holds the offset table of a 16K map; the tiny file does not
            }
            let mut bytes = base.clone();
            patch_data_window(&mut bytes, window);
            let p = tmp(&format!("{name}-{case}.exr"), &bytes);
            assert_err_names(quick(case, || load_environment(&p)).unwrap_err(), &p, what);
        }
        // Truncated: within the header, and within the pixel data.
        for (cut, at) in [("header", 200), ("pixels", base.len() * 2 / 3)] {
            let p = tmp(&format!("{name}-truncated-{cut}.exr"), &base[..at]);
            assert_err_names(quick(cut, || load_environment(&p)).unwrap_err(), &p, "OpenEXR");
        }
    }
    assert_eq!(MAX_ENV_TEXELS, 16384 * 8192);
}

#[test]
fn mutated_exr_headers_never_crash() {
    // Every byte of the tiny file set to 0x00, 0xff, 0x7f and flipped in its low bit: each load returns
    // (Ok or an error naming the file), none panics or aborts. The file has no more than a few hundred bytes.
    let tiny = tiny_exr();
    let (mut ok, mut err) = (0, 0);
    let t0 = Instant::now();
    for i in 0..tiny.len() {
        for v in [0x00u8, 0xff, 0x7f, tiny[i] ^ 1] {
            let mut bytes = tiny.clone();
            bytes[i] = v;
            let p = tmp("mutated.exr", &bytes);
            match load_environment(&p) {
                Ok(_) => ok += 1,
                Err(e) => {
                    assert!(e.to_string().contains(&p.display().to_string()), "{e}");
                    err += 1;
                }
            }
        }
    }
    eprintln!("{} mutations of {} bytes: {ok} loaded, {err} refused in {:?}", ok + err, tiny.len(), t0.elapsed());
    assert!(err > 0 && ok > 0);
}

/// Triangles in the embedded buffer: enough that copying the mesh on every visit of a cycle (what the old
/// loader did, up to a million times) is far slower than the 2 s allowed.
const TRIANGLES: usize = 1000;

/// A glTF of [`TRIANGLES`] triangles with an embedded buffer; `nodes` and `accessors` are spliced in as
/// JSON, `position` is the POSITION accessor's index.
fn gltf(nodes: &str, accessors: &str, position: usize) -> Vec<u8> {
    let mut buffer = Vec::new();
    for k in 0..TRIANGLES {
        for v in [[k as f32, 0.0, 0.0], [k as f32 + 1.0, 0.0, 0.0], [k as f32, 1.0, 0.0]] {
            buffer.extend(v.iter().flat_map(|x| x.to_le_bytes()));
        }
    }
    let (len, uri) = (buffer.len(), base64::encode(&buffer));
    format!(
        r#"{{
  "asset": {{ "version": "2.0" }},
  "scene": 0,
  "scenes": [ {{ "nodes": [0] }} ],
  "nodes": {nodes},
  "meshes": [ {{ "primitives": [ {{ "attributes": {{ "POSITION": {position} }} }} ] }} ],
  "buffers": [ {{ "byteLength": {len}, "uri": "data:application/octet-stream;base64,{uri}" }} ],
  "bufferViews": [ {{ "buffer": 0, "byteOffset": 0, "byteLength": {len} }} ],
  "accessors": {accessors}
}}"#
    )
    .into_bytes()
}

fn good_accessor() -> String {
    format!(
        r#"[ {{ "bufferView": 0, "componentType": 5126, "count": {}, "type": "VEC3",
    "min": [0, 0, 0], "max": [{}, 1, 0] }} ]"#,
        3 * TRIANGLES,
        TRIANGLES
    )
}

#[test]
fn malformed_gltf_is_an_error_naming_the_file() {
    let p = tmp("good.gltf", &gltf(r#"[ { "mesh": 0 } ]"#, &good_accessor(), 0));
    let scene = load_gltf(&p, 0).expect("the unmodified file loads");
    assert_eq!(scene.meshes.len(), 1);
    assert_eq!(scene.meshes[0].indices.len(), 3 * TRIANGLES);

    let cases: [(&str, Vec<u8>, &str); 6] = [
        ("accessor-out-of-range", gltf(r#"[ { "mesh": 0 } ]"#, &good_accessor(), 7), "glTF"),
        (
            "accessor-past-buffer",
            gltf(
                r#"[ { "mesh": 0 } ]"#,
                r#"[ { "bufferView": 0, "byteOffset": 1000000, "componentType": 5126, "count": 1000000,
                    "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] } ]"#,
                0,
            ),
            "glTF",
        ),
        (
            "bufferview-out-of-range",
            gltf(
                r#"[ { "mesh": 0 } ]"#,
                r#"[ { "bufferView": 9, "componentType": 5126, "count": 3, "type": "VEC3",
                    "min": [0, 0, 0], "max": [1, 1, 0] } ]"#,
                0,
            ),
            "glTF",
        ),
        ("own-child", gltf(r#"[ { "mesh": 0, "children": [0] } ]"#, &good_accessor(), 0), "own child"),
        (
            "two-node-cycle",
            gltf(r#"[ { "mesh": 0, "children": [1] }, { "mesh": 0, "children": [0] } ]"#, &good_accessor(), 0),
            "cycle",
        ),
        (
            "two-parents",
            gltf(r#"[ { "children": [1, 2] }, { "children": [2] }, { "mesh": 0 } ]"#, &good_accessor(), 0),
            "two parents",
        ),
    ];
    for (name, bytes, what) in cases {
        let p = tmp(&format!("{name}.gltf"), &bytes);
        let err = quick(name, || load_gltf(&p, 0)).unwrap_err();
        eprintln!("{name}: {err}");
        assert_err_names(&err, &p, what);
    }
}

/// An external buffer must be a regular file at least `byteLength` long: a `uri` of `/dev/zero` used to be read
/// without end (the decoder reads the named file whole). (Absolute paths are refused outright now:
/// `model_files_name_only_files_in_their_folder`.)
#[test]
fn gltf_external_buffers_must_be_regular_files_of_their_length() {
    let good = String::from_utf8(gltf(r#"[ { "mesh": 0 } ]"#, &good_accessor(), 0)).unwrap();
    let start = good.find("\"uri\": \"data:").unwrap() + "\"uri\": \"".len();
    let end = start + good[start..].find('"').unwrap();
    let short = tmp("short-buffer.bin", &[0u8; 12]);
    std::fs::create_dir_all(short.with_file_name("a-folder.bin")).unwrap();
    for (name, uri, what) in [
        ("dev-zero", "/dev/zero", "is an absolute path"),
        ("dir", "a-folder.bin", "not a regular file"),
        ("short", "short-buffer.bin", "byteLength"),
    ] {
        let text = format!("{}{}{}", &good[..start], uri, &good[end..]);
        let p = tmp(&format!("external-{name}.gltf"), text.as_bytes());
        let err = quick(name, || load_gltf(&p, 0)).unwrap_err();
        eprintln!("{name}: {err}");
        assert_err_names(&err, &p, what);
    }
}

/// A model names files only inside its own folder: a buffer URI of `../../../../etc/passwd` must not be read as
/// index data. Refused, with one line naming the model and the URI: `..` out
/// of the folder, an absolute path, a symbolic link out, a `file:` URI — for a glTF's buffers and images, an OBJ's
/// `mtllib` and a `.mtl`'s texture maps. Data URIs and files inside the folder (through links that stay inside)
/// still load.
#[test]
fn model_files_name_only_files_in_their_folder() {
    use engine::scene::load_obj_with_materials;
    let root = std::env::temp_dir().join(format!("hostile-input-folder-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let model = root.join("model");
    std::fs::create_dir_all(model.join("sub")).unwrap();
    // A file outside the model's folder that parses as a buffer, a .mtl and a texture: if the loader reads it,
    // the model loads (the old behaviour), so the test cannot pass by the file being unusable.
    let good = String::from_utf8(gltf(r#"[ { "mesh": 0 } ]"#, &good_accessor(), 0)).unwrap();
    let start = good.find("\"uri\": \"data:").unwrap() + "\"uri\": \"".len();
    let end = start + good[start..].find('"').unwrap();
    let data_uri = &good[start..end];
    let buffer = base64::decode(&data_uri[data_uri.find(',').unwrap() + 1..]).unwrap();
    std::fs::write(root.join("outside.bin"), &buffer).unwrap();
    std::fs::write(root.join("outside.mtl"), "newmtl a\nKd 1 0 0\n").unwrap();
    std::fs::write(model.join("sub/inside.bin"), &buffer).unwrap();
    std::fs::write(model.join("inside.mtl"), "newmtl a\nKd 1 0 0\nmap_Kd sub/wood.png\n").unwrap();
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(root.join("outside.bin"), model.join("link-out.bin")).unwrap();
        std::os::unix::fs::symlink(root.join("outside.mtl"), model.join("link-out.mtl")).unwrap();
        std::os::unix::fs::symlink(&root, model.join("up")).unwrap();
        std::os::unix::fs::symlink(model.join("sub/inside.bin"), model.join("link-in.bin")).unwrap();
    }
    let outside = root.join("outside.bin").display().to_string();
    let gltf_with = |name: &str, uri: &str, images: &str| {
        let text = format!("{}{}{}", &good[..start], uri, &good[end..]);
        let text = text.replacen("\"asset\"", &format!("{images}\"asset\""), 1);
        let p = model.join(format!("{name}.gltf"));
        std::fs::write(&p, text).unwrap();
        p
    };
    // Inside: a data URI, a relative file, a link that stays inside, a percent-encoded relative name.
    let ok_image = r#""images": [ { "uri": "sub/wood%20grain.png" } ], "#;
    for (name, uri) in
        [("data", data_uri), ("inside", "sub/inside.bin"), ("link-in", "link-in.bin"), ("encoded", "sub/inside%2Ebin")]
    {
        let p = gltf_with(name, uri, ok_image);
        load_gltf(&p, 0).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    let file_uri = format!("file://{outside}");
    let mut cases: Vec<(&str, String, &str)> = vec![
        ("traversal", "../outside.bin".into(), "leads out of the model's folder with '..'"),
        ("deep-traversal", "../../../../etc/passwd".into(), "with '..'"),
        ("encoded-traversal", "%2E%2E/outside.bin".into(), "with '..'"),
        ("absolute", outside.clone(), "is an absolute path"),
        ("file-uri", file_uri.clone(), "is a file: URI"),
        ("other-scheme", "https://example.com/x.bin".into(), "unsupported scheme"),
    ];
    if cfg!(unix) {
        cases.push(("link-out", "link-out.bin".into(), "through a symbolic link"));
        cases.push(("dir-link-out", "up/outside.bin".into(), "through a symbolic link"));
    }
    for (name, uri, what) in &cases {
        let p = gltf_with(name, uri, "");
        let err = quick(name, || load_gltf(&p, 0)).unwrap_err().to_string();
        eprintln!("{name}: {err}");
        assert_err_names(&err, &p, what);
        assert!(err.contains(&format!("buffer 0: URI {}", engine::io::quote(uri))), "{name}: {err}");
        assert!(err.contains("inside its own folder") && !err.contains('\n'), "{name}: {err}");
    }
    // Images obey the rule too (they are not read: the renderer has no textures yet).
    let p = gltf_with("image-out", data_uri, r#""images": [ { "uri": "../outside.png" } ], "#);
    assert_err_names(load_gltf(&p, 0).unwrap_err(), &p, "image 0: URI \"../outside.png\" leads out");

    // OBJ: the .mtl library and its texture maps.
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
    let obj_with = |name: &str, mtllib: &str| {
        let p = model.join(format!("{name}.obj"));
        std::fs::write(&p, format!("mtllib {mtllib}\n{tri}")).unwrap();
        p
    };
    let (_, materials) = load_obj_with_materials(&obj_with("inside", "inside.mtl")).unwrap();
    assert!((materials[0].diffuse.x - 1.0).abs() < 1e-6, "{materials:?}");
    let mut cases: Vec<(&str, String, &str)> = vec![
        ("traversal", "../outside.mtl".into(), "with '..'"),
        ("absolute", root.join("outside.mtl").display().to_string(), "is an absolute path"),
        ("file-uri", format!("file:{}", root.join("outside.mtl").display()), "is a file: URI"),
    ];
    if cfg!(unix) {
        cases.push(("link-out", "link-out.mtl".into(), "through a symbolic link"));
    }
    for (name, mtllib, what) in &cases {
        let p = obj_with(&format!("mtl-{name}"), mtllib);
        let err = load_obj_with_materials(&p).unwrap_err().to_string();
        eprintln!("mtl-{name}: {err}");
        assert_err_names(&err, &p, what);
        assert!(err.contains(&format!("mtllib {}", engine::io::quote(mtllib))), "{err}");
    }
    for (name, map, what) in [
        ("traversal", "../outside.png", "with '..'"),
        ("absolute", "/etc/passwd", "is an absolute path"),
        ("options", "-s 1 1 1 ../../outside.png", "with '..'"),
        ("drive", "C:\\textures\\wood.png", "drive letter"),
    ] {
        let mtl = model.join(format!("tex-{name}.mtl"));
        std::fs::write(&mtl, format!("newmtl a\nKd 1 0 0\nmap_Kd {map}\n")).unwrap();
        let p = obj_with(&format!("tex-{name}"), &format!("tex-{name}.mtl"));
        let err = load_obj_with_materials(&p).unwrap_err().to_string();
        eprintln!("tex-{name}: {err}");
        assert_err_names(&err, &mtl, what);
        assert!(err.contains("line 3: `map_Kd` texture"), "{err}");
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// No loader error carries a control character from the file (a mutated .hdr's FORMAT line could put NUL, ^B,
/// ^P, ^\\ and DEL on the terminal, or an escape sequence it would obey): text quoted from
/// input is escaped as `{:?}` writes it and cut short.
#[test]
fn errors_never_carry_control_characters_from_the_input() {
    const HOSTILE: &str = "\u{0}\u{2}\u{10}\u{1c}\u{7f}\u{1b}[2J\u{1b}]0;owned\u{7}\r\u{9b}31m\u{202e}";
    let clean = |what: &str, e: &str| {
        assert!(!e.chars().any(|c| (c.is_control() && c != '\n') || c == '\u{202e}'), "{what}: {e:?}");
        assert!(e.contains("\\u{1b}"), "{what}: the escape is not shown escaped: {e}");
    };
    let hdr = |format: &str, res: &str| format!("#?RADIANCE\nFORMAT={format}\n\n{res}\n").into_bytes();
    let p = tmp("control-format.hdr", &hdr(&format!("32-bi{HOSTILE}"), "-Y 1 +X 2"));
    let e = load_environment(&p).unwrap_err().to_string();
    assert!(e.contains("unsupported FORMAT \"32-bi\\0\\u{2}"), "{e}");
    clean("hdr FORMAT", &e);
    let p = tmp("control-orientation.hdr", &hdr("32-bit_rle_rgbe", &format!("-Y 1 +X 2{HOSTILE}")));
    clean("hdr orientation", &load_environment(&p).unwrap_err().to_string());
    // An .mtl value, an OBJ's mtllib name, a glTF buffer URI.
    let dir = tmp("control.obj", b"").parent().unwrap().to_path_buf();
    std::fs::write(dir.join("control.mtl"), format!("newmtl a\nKd 1 {HOSTILE} 0\n")).unwrap();
    let p = tmp("control.obj", b"mtllib control.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n");
    clean("mtl value", &engine::scene::load_obj_with_materials(&p).unwrap_err().to_string());
    let p = tmp("control-lib.obj", format!("mtllib ../{HOSTILE}.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").as_bytes());
    clean("mtllib", &engine::scene::load_obj_with_materials(&p).unwrap_err().to_string());
    let good = String::from_utf8(gltf(r#"[ { "mesh": 0 } ]"#, &good_accessor(), 0)).unwrap();
    let start = good.find("\"uri\": \"data:").unwrap() + "\"uri\": \"".len();
    let end = start + good[start..].find('"').unwrap();
    let escaped_json: String = HOSTILE.chars().map(|c| format!("\\u{:04x}", c as u32)).collect();
    let text = format!("{}../{escaped_json}{}", &good[..start], &good[end..]);
    let p = tmp("control-uri.gltf", text.as_bytes());
    clean("glTF URI", &load_gltf(&p, 0).unwrap_err().to_string());
    // A mesh named by the file: its name is printed in progress lines and warnings.
    let named = good.replacen("\"primitives\"", &format!("\"name\": \"{escaped_json}\", \"primitives\""), 1);
    let p = tmp("control-name.gltf", named.as_bytes());
    let g = load_gltf(&p, 0).unwrap();
    clean("glTF mesh name", &g.meshes[0].name);
}

/// Bad plane blockers are errors naming the plane or the mesh, at scene upload (`gather_planes`), before
/// anything reaches the GPU: a marked mesh that is not flat or not a rectangle, one that also has spheres
/// or is thin, a non-finite or degenerate explicit plane, and more planes than the stated maximum.
#[test]
fn bad_plane_blockers_are_refused_naming_them() {
    use engine::resources::blockers::{gather_planes, MAX_PLANES};
    use engine::scene::blockers::BlockerPlane;
    use glam::DVec3;
    let base = || {
        engine_tests::fixtures::sphere_over_plane(
            engine::math::envmap::LatLongMap::constant(8, 4, [1.0; 3]),
            0.5,
            glam::Vec3::new(0.0, 0.8, 0.0),
            0.5,
        )
    };
    let err = |s: &engine::scene::Scene| gather_planes(s).expect_err("refused").to_string();
    // The ground (mesh 0) marked: one rectangle; the sphere (mesh 1, which has spheres) marked: refused.
    let mut s = base();
    s.blockers.plane_meshes = vec![true];
    assert_eq!(gather_planes(&s).expect("the ground is a rectangle").len(), 1);
    s.blockers.plane_meshes = vec![true, true];
    let e = err(&s);
    assert!(e.contains("also has spheres"), "{e}");
    // A bent ground, and a ground with a triangle missing (not a rectangle).
    let mut s = base();
    s.blockers.plane_meshes = vec![true];
    s.meshes[0].positions[10].y += 0.2;
    let e = err(&s);
    assert!(e.contains(&s.meshes[0].name) && e.contains("flat"), "{e}");
    let mut s = base();
    s.blockers.plane_meshes = vec![true];
    let kept = s.meshes[0].indices.len() - 3;
    s.meshes[0].indices.truncate(kept);
    let e = err(&s);
    assert!(e.contains("rectangle"), "{e}");
    // Thin and plane at once.
    let mut s = base();
    s.blockers.plane_meshes = vec![true];
    s.blockers.thin = vec![true];
    assert!(err(&s).contains("thin"));
    // Explicit planes: non-finite, degenerate rectangle, too many.
    let mut s = base();
    s.blockers.planes = vec![BlockerPlane::half_space(DVec3::ZERO, DVec3::new(f64::NAN, 1.0, 0.0))];
    let e = err(&s);
    assert!(e.contains("plane blocker 0"), "{e}");
    s.blockers.planes = vec![BlockerPlane::rectangle(DVec3::ZERO, DVec3::X, DVec3::ZERO)];
    assert!(err(&s).contains("plane blocker 0"));
    s.blockers.planes = vec![BlockerPlane::half_space(DVec3::ZERO, DVec3::Y); MAX_PLANES + 1];
    // A scene input error, typed apart from GPU failures (it was GpuError::Other).
    assert!(matches!(gather_planes(&s), Err(engine::gpu::GpuError::Scene(_))));
    let e = err(&s);
    assert!(e.contains(&format!("at most {MAX_PLANES}")), "{e}");
}
