//! `cargo xtask report math [--scenes N] [--product-per-decade N] [--quick]`: plots and tables of the ISG, SH exp
//! and cosine-lobe errors into out/report/math/README.md. The work is tools/math-report's `report-math` binary,
//! built optimized (this crate stays free of native dependencies).

use anyhow::Result;

pub fn run(args: &[String]) -> Result<()> {
    let root = crate::root();
    let out = root.canonicalize().unwrap_or(root).join("out/report/math");
    let mut c = crate::cargo();
    c.args(["run", "--release", "--quiet", "-p", "math-report", "--bin", "report-math", "--", "--out"])
        .arg(&out)
        .args(args);
    crate::run(c)
}
