//! `cargo xtask --help` (and `-h`, `help`) prints the subcommands on stdout and exits 0; it used to print them
//! on stderr and exit 2, the status of a usage error, which no command or unknown command still gets.

use std::process::Command;

const COMMANDS: &[&str] =
    &["demo", "test", "bless", "setup", "spheres", "tables", "report", "bench", "bench-package", "soak", "fuzz"];

fn xtask(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_xtask")).args(args).output().expect("running xtask")
}

#[test]
fn help_exits_0_and_lists_every_subcommand() {
    for flag in ["--help", "-h", "help"] {
        let out = xtask(&[flag]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert_eq!(
            out.status.code(),
            Some(0),
            "xtask {flag}: {:?}\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        for c in COMMANDS {
            assert!(stdout.lines().any(|l| l.trim_start().starts_with(c)), "xtask {flag} lacks '{c}':\n{stdout}");
        }
    }
}

#[test]
fn usage_errors_exit_2_with_the_help_on_stderr() {
    for args in [&[][..], &["no-such-command"][..]] {
        let out = xtask(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "xtask {args:?}: {:?}", out.status);
        assert!(stderr.contains("usage: cargo xtask") && COMMANDS.iter().all(|c| stderr.contains(c)), "{stderr}");
        if let Some(cmd) = args.first() {
            assert!(stderr.contains(cmd), "the error names '{cmd}': {stderr}");
        }
    }
}
