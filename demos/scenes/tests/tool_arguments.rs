//! The scene-writing binaries that parsed their arguments by hand now use clap, as the others do: `--help`
//! describes every option, an unknown or malformed argument is a usage error (exit status 2) naming it.

use std::process::{Command, Output};

fn run(exe: &str, args: &[&str]) -> Output {
    Command::new(exe).args(args).output().expect("running the binary")
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

#[test]
fn hand_parsed_binaries_use_clap() {
    let gltf = env!("CARGO_BIN_EXE_write_gltf_example");
    let o = run(gltf, &["--help"]);
    assert!(o.status.success() && text(&o).contains("--external"), "{}", text(&o));
    let o = run(gltf, &["a.gltf", "b.gltf"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("unexpected argument 'b.gltf'"), "{}", text(&o));

    let battle = env!("CARGO_BIN_EXE_write_battle_characters");
    let o = run(battle, &["--help"]);
    assert!(o.status.success() && text(&o).contains("[DIR]"), "{}", text(&o));
}
