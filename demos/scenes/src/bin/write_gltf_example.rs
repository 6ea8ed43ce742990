//! `write_gltf_example [PATH]`: write the example skinned, animated arm (`scenes::gltf_writer::example_arm`) as
//! `.gltf` with an embedded buffer, `.glb`, or `.gltf` + `.bin` with `--external` (default PATH:
//! examples/arm.gltf). The test `examples_gltf_is_the_writers_output` checks the shipped file against it.

use anyhow::Context;
use clap::Parser;
use scenes::gltf_writer::{example_arm, Container};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "write_gltf_example", about = "Write the two-bone arm example (scenes::gltf_writer) as glTF")]
struct Args {
    /// Write the buffer as an external .bin beside a .gltf (instead of embedded).
    #[arg(long)]
    external: bool,
    /// Output file, .gltf or .glb.
    #[arg(default_value = "examples/arm.gltf")]
    path: PathBuf,
}

fn main() {
    scenes::init_logging();
    scenes::exit_on_error(run());
}

fn run() -> anyhow::Result<()> {
    let Args { external, path } = Args::parse();
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
