//! The measurement binaries that parsed their arguments by hand now use clap, as the others do: `--help`
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
    let lobes = env!("CARGO_BIN_EXE_lobes_weights");
    let o = run(lobes, &["--help"]);
    assert!(o.status.success() && text(&o).contains("--check") && text(&o).contains("--by-distance"), "{}", text(&o));
    let o = run(lobes, &["--bogus"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("unexpected argument '--bogus'"), "{}", text(&o));
    let o = run(lobes, &["--check", "--by-distance"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("cannot be used with"), "{}", text(&o));
}
