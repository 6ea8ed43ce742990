//! `write_battle_characters [DIR]`: write the `battle` scene's troll and wizard (`scenes::characters`) as
//! `troll.glb` and `wizard.glb` into DIR (default assets/battle). The test
//! `battle_characters_are_the_generators_output` (demos/tests/battle.rs) checks the shipped files against it.

use anyhow::Context;
use clap::Parser;
use scenes::characters::{troll, wizard, RINGS};
use scenes::gltf_writer::Container;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "write_battle_characters", about = "Write the battle scene's troll and wizard as .glb files")]
struct Args {
    /// Output folder (default: assets/battle).
    dir: Option<PathBuf>,
}

fn main() {
    scenes::init_logging();
    scenes::exit_on_error(run());
}

fn run() -> anyhow::Result<()> {
    let dir = Args::parse().dir.unwrap_or_else(|| scenes::assets_dir().join("battle"));
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    for c in [troll(RINGS), wizard(RINGS)] {
        let path = dir.join(format!("{}.glb", c.name));
        let (b, doc) = c.gltf();
        b.write(doc, &path, Container::Glb).with_context(|| format!("writing {}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
