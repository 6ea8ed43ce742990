//! `write_gltf_example [PATH]`: write the example skinned, animated arm (`scenes::gltf_writer::example_arm`) as
//! `.gltf` with an embedded buffer, `.glb`, or `.gltf` + `.bin` with `--external` (default PATH:
//! examples/arm.gltf). `--model room` writes the lit room instead (`scenes::gltf_writer::lit_room`: a block on its own
//! floor, two cameras, a point and a directional light; default PATH examples/lit_room.gltf). The tests
//! `examples_gltf_is_the_writers_output` and `examples_lit_room_is_the_writers_output` check the shipped files.

use anyhow::Context;
use clap::Parser;
use scenes::gltf_writer::{example_arm, lit_room, Container};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "write_gltf_example", about = "Write the two-bone arm example (scenes::gltf_writer) as glTF")]
struct Args {
    /// Write the buffer as an external .bin beside a .gltf (instead of embedded).
    #[arg(long)]
    external: bool,
    /// Which model: `arm` or `room`.
    #[arg(long, default_value = "arm")]
    model: String,
    /// Output file, .gltf or .glb [default: examples/arm.gltf or examples/lit_room.gltf].
    path: Option<PathBuf>,
}

fn main() {
    scenes::init_logging();
    scenes::exit_on_error(run());
}

fn run() -> anyhow::Result<()> {
    let Args { external, model, path } = Args::parse();
    let (default, (b, doc)) = match model.as_str() {
        "arm" => ("examples/arm.gltf", example_arm()),
        "room" => ("examples/lit_room.gltf", lit_room()),
        m => anyhow::bail!("--model {m}: use arm or room"),
    };
    let path = path.unwrap_or_else(|| PathBuf::from(default));
    let glb = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    let container = match (glb, external) {
        (true, true) => anyhow::bail!("--external applies to .gltf"),
        (true, false) => Container::Glb,
        (false, true) => Container::External,
        (false, false) => Container::Embedded,
    };
    b.write(doc, &path, container).with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}
