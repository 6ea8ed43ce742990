//! Every numeric scene-file key has the range of its command-line twin, from one table (`scenes::limits`), so
//! that a file cannot pass what the option refuses (e.g. `environment.rotation = -9223372036854775808`).
//!
//! The test walks the table: for every scene-file key, values just outside its range and at f32's limits are
//! refused by the scene-file parser with an error naming the key, and its bounds themselves (where they belong to
//! the range) are accepted; for every key with an option, the option refuses the same values (`demo`, no GPU).

use scenes::limits::{Range, RANGES};
use scenes::user::{scene_file, UserOptions};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn temp() -> PathBuf {
    let d = std::env::temp_dir().join(format!("number-ranges-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    // A triangle, a 2 × 1 Radiance map of radiance ≈ 0.5 (so that intensity 1e9 stays within the bound) and a
    // 2 × 2 material map.
    std::fs::write(d.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let mut hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n".to_vec();
    hdr.extend_from_slice(&[128, 128, 128, 128, 128, 128, 128, 128]);
    std::fs::write(d.join("env.hdr"), hdr).unwrap();
    engine::output::write_png(&d.join("map.png"), 2, 2, &[0, 0, 0, 255, 255, 255, 255, 255].repeat(2)).unwrap();
    d
}

/// Where each table key sits in the scene file, and the key its error names.
fn place(key: &str) -> (&'static str, &'static str, &'static str) {
    // (section, the key's name inside it, the key as the error names it)
    match key {
        "camera.eye" => ("camera", "eye", "camera.eye"),
        "camera.target" => ("camera", "target", "camera.target"),
        "camera.fov_y" => ("camera", "fov_y", "camera.fov_y"),
        "environment.intensity" => ("environment", "intensity", "environment.intensity"),
        "environment.rotation" => ("environment", "rotation", "environment.rotation"),
        "environment.lights" => ("environment", "lights", "environment.lights"),
        "environment.light_threshold" => ("environment", "light_threshold", "environment.light_threshold"),
        "environment.light_share" => ("environment", "light_share", "environment.light_share"),
        "environment.light_radius" => ("environment", "light_radius", "environment.light_radius"),
        "ground.subdivisions" => ("ground", "subdivisions", "ground.subdivisions"),
        "light.center" => ("light", "center", "light[0].center"),
        "light.radius" => ("light", "radius", "light[0].radius"),
        "light.radiance" => ("light", "radiance", "light[0].radiance"),
        "model.translation" => ("model", "translation", "model[0].translation"),
        "model.rotation" => ("model", "rotation", "model[0].rotation"),
        "model.scale" => ("model", "scale", "model[0].scale"),
        "model.spheres" => ("model", "spheres", "model[0].spheres"),
        "material.diffuse" => ("material", "diffuse", "model[0].material.diffuse"),
        "material.specular" => ("material", "specular", "model[0].material.specular"),
        "material.shininess" => ("material", "shininess", "model[0].material.shininess"),
        "material_map.levels" => ("map", "levels", "ground.material_map.levels"),
        other => panic!("the test does not know where `{other}` goes: add it here"),
    }
}

/// A complete scene file with every numeric key, `key` set to `value` (arrays: the first component).
fn scene_text(key: &str, value: &str) -> String {
    let mut v: HashMap<&str, String> = [
        ("camera.eye", "[0, 1, 3]"),
        ("camera.target", "[0, 0, 0]"),
        ("camera.fov_y", "45"),
        ("environment.intensity", "1"),
        ("environment.rotation", "10"),
        ("environment.lights", "2"),
        ("environment.light_threshold", "4"),
        ("environment.light_share", "1"),
        ("environment.light_radius", "15"),
        ("ground.subdivisions", "4"),
        ("light.center", "[0, 2, 0]"),
        ("light.radius", "0.2"),
        ("light.radiance", "[1, 1, 1]"),
        ("model.translation", "[0, 0, 0]"),
        ("model.rotation", "[0, 0, 0]"),
        ("model.scale", "[1, 1, 1]"),
        ("model.spheres", "0"),
        ("material.diffuse", "[0.5, 0.5, 0.5]"),
        ("material.specular", "[0, 0, 0]"),
        ("material.shininess", "10"),
        ("material_map.levels", "4"),
    ]
    .into_iter()
    .map(|(k, d)| (k, d.to_string()))
    .collect();
    let old = v.get(key).cloned().unwrap_or_else(|| panic!("no default for {key}"));
    // An array key gets the value in its first component, the others kept.
    let new = match old.split_once(',') {
        Some((_, rest)) if old.starts_with('[') => format!("[{value},{rest}"),
        _ => value.to_string(),
    };
    v.insert(key, new);
    let g = |k: &str| v[k].clone();
    format!(
        "[camera]\neye = {}\ntarget = {}\nfov_y = {}\n\n\
         [environment]\nfile = \"env.hdr\"\nintensity = {}\nrotation = {}\nlights = {}\nlight_threshold = {}\n\
         light_share = {}\nlight_radius = {}\n\n\
         [ground]\nsubdivisions = {}\nmaterial = {{ brdf = \"phong:e=10\" }}\n\
         material_map = {{ file = \"map.png\", material = {{ brdf = \"phong:e=20\" }}, levels = {} }}\n\n\
         [[light]]\ncenter = {}\nradius = {}\nradiance = {}\n\n\
         [[model]]\nfile = \"tri.obj\"\ntranslation = {}\nrotation = {}\nscale = {}\nspheres = {}\n\
         material = {{ diffuse = {}, specular = {}, shininess = {} }}\n",
        g("camera.eye"),
        g("camera.target"),
        g("camera.fov_y"),
        g("environment.intensity"),
        g("environment.rotation"),
        g("environment.lights"),
        g("environment.light_threshold"),
        g("environment.light_share"),
        g("environment.light_radius"),
        g("ground.subdivisions"),
        g("material_map.levels"),
        g("light.center"),
        g("light.radius"),
        g("light.radiance"),
        g("model.translation"),
        g("model.rotation"),
        g("model.scale"),
        g("model.spheres"),
        g("material.diffuse"),
        g("material.specular"),
        g("material.shininess"),
    )
}

/// Values just outside `r` (and f32's limits), as a file writes them.
fn outside(r: &Range) -> Vec<String> {
    let mut out = Vec::new();
    if r.integer {
        out.push(format!("{}", r.lo - 1.0));
        out.push(format!("{}", r.hi + 1.0));
        out.push("9223372036854775807".into());
        out.push("-9223372036854775808".into());
        return out;
    }
    let step = |x: f64| (x.abs() * 1e-5).max(1e-6);
    out.push(if r.lo_open { format!("{:e}", r.lo) } else { format!("{:e}", r.lo - step(r.lo)) });
    out.push(if r.hi_open { format!("{:e}", r.hi) } else { format!("{:e}", r.hi + step(r.hi)) });
    // f32's limits, beyond them (inf once read as f32), the integer the issue found, and non-finite literals.
    for v in ["3.4028235e38", "-3.4028235e38", "3.5e38", "-9223372036854775808", "nan", "inf", "-inf"] {
        out.push(v.into());
    }
    out
}

/// The bounds that belong to `r`, as a file writes them.
fn inside(r: &Range) -> Vec<String> {
    let mut out = Vec::new();
    if !r.lo_open {
        out.push(if r.integer { format!("{}", r.lo) } else { format!("{:e}", r.lo) });
    }
    if !r.hi_open {
        out.push(if r.integer { format!("{}", r.hi) } else { format!("{:e}", r.hi) });
    }
    out
}

fn build(dir: &Path, key: &str, value: &str) -> Result<(), String> {
    let p = dir.join("s.toml");
    std::fs::write(&p, scene_text(key, value)).unwrap();
    let opts = UserOptions { cache: Some(dir.join("cache")), ..Default::default() };
    let assets = scenes::assets_dir();
    scene_file(&p, None, &assets, &opts).map(|_| ()).map_err(|e| format!("{e:#}"))
}

#[test]
fn every_scene_file_key_refuses_values_just_outside_its_range() {
    let dir = temp();
    build(&dir, "camera.fov_y", "45").expect("the base scene builds");
    let mut walked = 0;
    for r in RANGES.iter().filter(|r| !r.key.is_empty()) {
        let (_, _, named) = place(r.key);
        for v in outside(r) {
            let e = build(&dir, r.key, &v).expect_err(&format!("{} = {v} was accepted", r.key));
            // A value TOML cannot hold in the field (an integer past i64) is the parser's error at the line.
            let toml_error = e.contains("TOML parse error");
            assert!(e.contains(named) || toml_error, "{} = {v}: the error does not name `{named}`: {e}", r.key);
            assert!(!e.contains('\u{1b}'), "{e:?}");
            walked += 1;
        }
        for v in inside(r) {
            build(&dir, r.key, &v).unwrap_or_else(|e| panic!("{} = {v} is in {} but refused: {e}", r.key, r.bounds()));
        }
    }
    eprintln!("{walked} values outside the ranges refused");
    assert!(walked > 100, "{walked}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The options refuse what the scene-file keys refuse, naming the option and the same range.
#[test]
fn every_option_refuses_what_its_scene_key_refuses() {
    let mut checked = 0;
    for r in RANGES.iter() {
        let Some(option) = r.option else { continue };
        for v in outside(r) {
            let out = Command::new(env!("CARGO_BIN_EXE_demo"))
                // `--option=-inf`: clap takes `-inf` after a space for a flag.
                .args(["--scene", "sheet", "--technique", "none", "--width", "8", "--height", "6"])
                .arg(format!("{option}={v}"))
                .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
                .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
                .output()
                .expect("running demo");
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{option} {v}: exit status\n{stderr}");
            assert!(stderr.contains(option), "{option} {v}: {stderr}");
            // clap's own integer parser words its range as `0..=4096`, the table's bounds() the same.
            assert!(stderr.contains(&r.bounds()), "{option} {v}: the message lacks {}: {stderr}", r.bounds());
            checked += 1;
        }
    }
    assert!(checked > 30, "{checked}");
}

/// docs/scene-files.md lists every key with the table's range.
#[test]
fn the_manual_lists_every_range() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/scene-files.md")).unwrap();
    for r in RANGES.iter().filter(|r| !r.key.is_empty()) {
        let row =
            format!("| `{}` | {} | {} |", r.key, r.option.map(|o| format!("`{o}`")).unwrap_or_default(), r.bounds());
        assert!(doc.contains(&row), "docs/scene-files.md lacks the row {row}");
    }
}
