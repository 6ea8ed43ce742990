//! `cargo xtask soak [--frames N] [soak args]`: build the `soak` binary (release) and run it with the
//! validation layer required: N animated frames (default 10,000) through the viewer's per-frame path, every
//! technique in turn, failing on memory growth after the warm-up or on any validation error
//! (demos/lab/src/soak.rs; `cargo xtask soak --help` lists the options).

use anyhow::Result;

pub fn run(rest: &[String]) -> Result<()> {
    let mut c = crate::cargo();
    c.env("ENGINE_VALIDATION", "1");
    c.args(["run", "--release", "--quiet", "-p", "lab", "--bin", "soak", "--"]).args(rest);
    crate::run(c)
}
