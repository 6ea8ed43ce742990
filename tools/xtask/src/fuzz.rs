//! `cargo xtask fuzz TARGET|all [--runs N] [--seconds S] [--seed K] [--dir D]`: mutation-fuzz the engine's
//! loaders on the stable toolchain (tools/fuzz; targets obj, gltf, glb, exr, hdr, spheres). Built in release;
//! findings are saved in D (default out/fuzz) and make the command fail. The suite's short run and the
//! regression corpus are tests of the engine-fuzz crate, so `cargo xtask test` runs them.

use anyhow::Result;

pub fn run(rest: &[String]) -> Result<()> {
    let mut c = crate::cargo();
    c.args(["run", "--release", "--quiet", "-p", "engine-fuzz", "--bin", "fuzz", "--"]).args(rest);
    crate::run(c)
}
