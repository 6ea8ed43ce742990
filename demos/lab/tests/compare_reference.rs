//! `compare --per-vertex` measures per-vertex techniques against the per-pixel reference (issue 35, defect 3):
//! the reference image is the same bits with and without `--per-vertex`, and `--help` says so (it used to say
//! that `--per-vertex` applied to the reference too).

use std::path::Path;
use std::process::Command;

fn compare(out: &Path, extra: &[&str]) {
    let run = Command::new(env!("CARGO_BIN_EXE_compare"))
        .env("ENGINE_VALIDATION", "1")
        .env_remove("ENGINE_DEVICE")
        .args(["--scene", "lamp-one", "--width", "16", "--height", "12", "--max-spp", "8", "--fraction", "0.5"])
        .args(["--technique", "none", "--visibility", "spheres", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .expect("running compare");
    assert!(run.status.success(), "compare {extra:?} failed:\n{}", String::from_utf8_lossy(&run.stderr));
}

#[test]
fn the_reference_is_per_pixel_with_per_vertex_techniques() {
    let root = std::env::temp_dir().join(format!("compare-per-vertex-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    compare(&root.join("pixel"), &[]);
    compare(&root.join("vertex"), &["--per-vertex"]);
    let read = |dir: &str, file: &str| std::fs::read(root.join(dir).join(file)).expect("an image");
    assert_eq!(read("pixel", "reference-spheres.exr"), read("vertex", "reference-spheres.exr"));
    assert_ne!(read("pixel", "none.exr"), read("vertex", "none.exr"), "--per-vertex shades the technique per vertex");
    let _ = std::fs::remove_dir_all(&root);

    let help = Command::new(env!("CARGO_BIN_EXE_compare")).arg("--help").output().expect("compare --help");
    let help = String::from_utf8_lossy(&help.stdout).split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        help.contains("Per-vertex shading for the techniques. The reference is always rendered per pixel"),
        "{help}"
    );
}
