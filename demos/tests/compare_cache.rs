//! `compare --reference-cache` with `--time`: the time is part of the cache key, so a posed scene's reference is
//! reused at the same time and converged afresh at another (the key without `--time` is unchanged, so caches made
//! before stay valid).

use std::process::Command;

fn compare(cache: &std::path::Path, time: &str) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_compare"))
        .env("ENGINE_VALIDATION", "1")
        .env_remove("ENGINE_DEVICE")
        .args(["--scene", "lamp-one", "--width", "16", "--height", "12", "--max-spp", "8", "--fraction", "0.5"])
        .args(["--technique", "none", "--visibility", "spheres", "--time", time, "--reference-cache"])
        .arg(cache)
        .arg("--out")
        .arg(cache.join("out"))
        .output()
        .expect("running compare");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "compare --time {time} failed:\n{stderr}");
    stderr
}

#[test]
fn the_reference_cache_keys_the_time() {
    let cache = std::env::temp_dir().join(format!("compare-cache-time-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&cache);
    let hit = "reference from the cache";
    assert!(!compare(&cache, "0.5").contains(hit), "the first run converges");
    assert!(compare(&cache, "0.5").contains(hit), "the same time reuses the cached reference");
    assert!(!compare(&cache, "0.75").contains(hit), "another time is another reference");
    let files = std::fs::read_dir(&cache)
        .expect("cache")
        .filter(|e| e.as_ref().is_ok_and(|e| e.path().extension().is_some_and(|x| x == "refimg")));
    assert_eq!(files.count(), 2, "one cached reference per time");
    let _ = std::fs::remove_dir_all(&cache);
}
