//! `compare --reference-cache`: a cached reference is reused exactly when everything that determines it is the same.
//! - The time is part of the key: a posed scene's reference is reused at the same time and converged afresh at
//!   another.
//! - Issue 35, defect 2: the cache file goes into the cache folder for a scene given by an absolute path (it used
//!   to be written next to the scene file: `dir.join(<absolute path>…)` is the absolute path), and the key is the
//!   scene's content, not its path: editing the scene file or a file it loads is a new reference.

use std::path::{Path, PathBuf};
use std::process::Command;

/// `compare` at 16 × 12, 8 spp, visibility spheres, unless `extra` gives another value of one of those.
fn run_compare(scene: &str, cache: &Path, extra: &[&str]) -> String {
    run_compare_with(scene, cache, extra, None)
}

/// [`run_compare`] with the shaders from `shader_root` instead of the repository's.
fn run_compare_with(scene: &str, cache: &Path, extra: &[&str], shader_root: Option<&Path>) -> String {
    let mut args = vec!["--width", "16", "--height", "12", "--max-spp", "8", "--visibility", "spheres"];
    for pair in extra.chunks(2) {
        match args.iter().position(|a| *a == pair[0]) {
            Some(i) => args[i + 1] = pair[1],
            None => args.extend_from_slice(pair),
        }
    }
    let mut command = Command::new(env!("CARGO_BIN_EXE_compare"));
    if let Some(root) = shader_root {
        command.env("ENGINE_SHADER_ROOT", root);
    }
    let out = command
        .env("ENGINE_VALIDATION", "1")
        .env_remove("ENGINE_DEVICE")
        .args(["--scene", scene, "--fraction", "0.5", "--technique", "none"])
        .args(&args)
        .arg("--reference-cache")
        .arg(cache)
        .arg("--out")
        .arg(cache.join("out"))
        .output()
        .expect("running compare");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "compare --scene {scene} {extra:?} failed:\n{stderr}");
    stderr
}

const HIT: &str = "reference from the cache";

fn cached_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> =
        std::fs::read_dir(dir).map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect()).unwrap_or_default();
    files.retain(|p| p.extension().is_some_and(|x| x == "refimg"));
    files.sort();
    files
}

#[test]
fn the_reference_cache_keys_the_time() {
    let cache = std::env::temp_dir().join(format!("compare-cache-time-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&cache);
    let compare = |time: &str| run_compare("lamp-one", &cache, &["--time", time]);
    assert!(!compare("0.5").contains(HIT), "the first run converges");
    assert!(compare("0.5").contains(HIT), "the same time reuses the cached reference");
    assert!(!compare("0.75").contains(HIT), "another time is another reference");
    assert_eq!(cached_files(&cache).len(), 2, "one cached reference per time");
    let _ = std::fs::remove_dir_all(&cache);
}

const OBJ: &str = "v -0.3 0 -0.3\nv 0.3 0 -0.3\nv 0 0.5 0\nv 0 0 0.3\nf 1 3 2\nf 1 4 3\nf 2 3 4\nf 1 2 4\n";

fn scene_toml(diffuse: f32) -> String {
    let env = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/envmaps/courtyard.exr");
    format!(
        "[camera]\neye = [0.0, 0.8, 1.6]\ntarget = [0.0, 0.2, 0.0]\nfov_y = 40.0\n\n\
         [environment]\nfile = {env:?}\n\n[ground]\nvisible = true\n\n\
         [[model]]\nfile = \"tetra.obj\"\nmaterial = {{ diffuse = [{diffuse}, 0.5, 0.5] }}\nspheres = 0\n"
    )
}

#[test]
fn the_reference_cache_keys_the_scene_content_and_stays_in_its_folder() {
    let root = std::env::temp_dir().join(format!("compare-cache-content-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let (scene_dir, cache) = (root.join("scene"), root.join("cache"));
    std::fs::create_dir_all(&scene_dir).unwrap();
    let scene_file = scene_dir.join("tetra.toml");
    std::fs::write(&scene_file, scene_toml(0.5)).unwrap();
    std::fs::write(scene_dir.join("tetra.obj"), OBJ).unwrap();
    let scene = scene_file.to_str().unwrap();
    assert!(scene_file.is_absolute());
    let compare = |extra: &[&str]| run_compare(scene, &cache, extra);

    assert!(!compare(&[]).contains(HIT), "the first run converges");
    assert_eq!(cached_files(&scene_dir), Vec::<PathBuf>::new(), "a cache file was written next to the scene");
    let files = cached_files(&cache);
    assert_eq!(files.len(), 1, "one cache file in the cache folder: {files:?}");
    let name = files[0].file_name().unwrap().to_string_lossy().into_owned();
    assert!(name.starts_with("tetra-spheres-"), "named by the scene file's stem and the visibility: {name}");
    assert!(compare(&[]).contains(HIT), "the same scene reuses it");

    // Everything the reference depends on is in the key: the scene file, the files it loads, the size, the
    // sample count, the visibility.
    std::fs::write(&scene_file, scene_toml(0.25)).unwrap();
    assert!(!compare(&[]).contains(HIT), "an edited scene file reused a stale reference");
    std::fs::write(scene_dir.join("tetra.obj"), OBJ.replace("v 0 0.5 0", "v 0 0.6 0")).unwrap();
    assert!(!compare(&[]).contains(HIT), "an edited mesh reused a stale reference");
    assert!(!compare(&["--max-spp", "16"]).contains(HIT), "another sample count reused the reference");
    assert!(!compare(&["--width", "17"]).contains(HIT), "another size reused the reference");
    assert!(!compare(&["--visibility", "triangles"]).contains(HIT), "another visibility reused the reference");
    let sunset = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/envmaps/sunset.exr");
    assert!(!compare(&["--env", sunset.to_str().unwrap()]).contains(HIT), "another environment reused the reference");
    assert!(compare(&[]).contains(HIT), "the edited scene's own reference is reused");
    // The reference's code: an edit of a shader its frame compiles (here a comment in its integrator).
    let shaders = root.join("shaders-glsl");
    copy_dir(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders-glsl"), &shaders);
    let integrate = shaders.join("shade/reference/integrate.glsl");
    let text = std::fs::read_to_string(&integrate).unwrap();
    assert!(run_compare_with(scene, &cache, &[], Some(&shaders)).contains(HIT), "the same sources elsewhere");
    std::fs::write(&integrate, text + "// edited\n").unwrap();
    assert!(
        !run_compare_with(scene, &cache, &[], Some(&shaders)).contains(HIT),
        "an edited reference shader reused it"
    );
    assert_eq!(cached_files(&cache).len(), 8);
    assert_eq!(cached_files(&scene_dir), Vec::<PathBuf>::new());
    let _ = std::fs::remove_dir_all(&root);
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}
