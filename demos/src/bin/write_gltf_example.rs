//! `write_gltf_example [PATH]`: write the example skinned, animated arm (`demos::gltf_writer::example_arm`) as
//! `.gltf` with an embedded buffer, `.glb`, or `.gltf` + `.bin` with `--external` (default PATH:
//! examples/arm.gltf). The test `examples_gltf_is_the_writers_output` checks the shipped file against it.

use anyhow::Context;
use demos::gltf_writer::{example_arm, Container};
use std::path::PathBuf;

fn main() {
    demos::init_logging();
    demos::exit_on_error(run());
}

fn run() -> anyhow::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let external = args.iter().any(|a| a == "--external");
    args.retain(|a| a != "--external");
    anyhow::ensure!(args.len() <= 1, "usage: write_gltf_example [--external] [PATH.gltf|PATH.glb]");
    let path = args.pop().map(PathBuf::from).unwrap_or_else(|| "examples/arm.gltf".into());
    let glb = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    let container = match (glb, external) {
        (true, true) => anyhow::bail!("--external applies to .gltf"),
        (true, false) => Container::Glb,
        (false, true) => Container::External,
        (false, false) => Container::Embedded,
    };
    let (b, doc) = example_arm();
    b.write(doc, &path, container).with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}
