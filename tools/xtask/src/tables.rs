//! `cargo xtask tables [--check] [--only NAME,...] [--samples N] [--seed S]`: regenerate the versioned binary math
//! tables into assets/tables (or, with `--check`, regenerate a seeded random sample of entries of every table and
//! compare them with the files). The work is engine-math's `tables` binary, built optimized: this crate stays free
//! of native dependencies.

use anyhow::Result;

pub fn run(args: &[String]) -> Result<()> {
    let root = crate::root();
    let out = root.canonicalize().unwrap_or(root).join("assets/tables");
    let mut c = crate::cargo();
    c.args(["run", "--release", "--quiet", "-p", "engine-math", "--bin", "tables", "--", "--out"]).arg(&out).args(args);
    crate::run(c)
}
