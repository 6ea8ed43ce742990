//! `cargo xtask report`: measurement reports into out/report.
//! `report math` is the mathematics report (report_math.rs); the rest is the speed-against-error sweep.

use anyhow::{bail, Result};

mod report_math;

pub fn run(args: &[String]) -> Result<()> {
    match args.first().map(String::as_str) {
        Some("math") => report_math::run(&args[1..]),
        _ => bail!("the speed-against-error report (`cargo xtask report`) is not built yet; `cargo xtask report math` is"),
    }
}
