//! Records the git commit the binaries were built from (`ENGINE_GIT_COMMIT`), so that the bench's files name it
//! even when the binary runs on a machine without the checkout (the portable package).

use std::path::Path;
use std::process::Command;

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    // Rebuild when HEAD moves (a commit, a checkout) or the index changes (the dirty flag).
    for f in [".git/HEAD", ".git/index", ".git/packed-refs"] {
        let p = root.join(f);
        if p.exists() {
            println!("cargo:rerun-if-changed={}", p.display());
        }
    }
    if let Ok(head) = std::fs::read_to_string(root.join(".git/HEAD")) {
        if let Some(r) = head.trim().strip_prefix("ref: ") {
            let p = root.join(".git").join(r);
            if p.exists() {
                println!("cargo:rerun-if-changed={}", p.display());
            }
        }
    }
    let git = |args: &[&str]| {
        Command::new("git")
            .args(args)
            .current_dir(&root)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    let commit = match git(&["rev-parse", "--short=12", "HEAD"]) {
        Some(c) => {
            // `git diff --quiet` exits 1 when tracked files differ from HEAD; unlike `git status` it does not
            // rewrite the index (which would rerun this script on every build).
            let dirty = Command::new("git")
                .args(["diff", "--quiet", "HEAD", "--"])
                .current_dir(&root)
                .status()
                .is_ok_and(|s| s.code() == Some(1));
            if dirty {
                format!("{c}-dirty")
            } else {
                c
            }
        }
        None => "unknown".to_string(),
    };
    println!("cargo:rustc-env=ENGINE_GIT_COMMIT={commit}");
}
