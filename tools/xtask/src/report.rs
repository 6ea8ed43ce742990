//! `cargo xtask report`: measurement reports into out/report.
//! `report math` is the mathematics report (report_math.rs); the rest is the speed-against-error sweep
//! (demos/lab/src/report/, run as the release binary `report`: `[--tiny | --sweep NAME] [--config FILE] [--out DIR]`).

use anyhow::Result;

mod report_math;

pub fn run(args: &[String]) -> Result<()> {
    match args.first().map(String::as_str) {
        Some("math") => report_math::run(&args[1..]),
        _ => {
            let mut c = crate::cargo();
            c.args(["run", "--release", "--quiet", "-p", "lab", "--bin", "report", "--"]).args(args);
            crate::run(c)
        }
    }
}
