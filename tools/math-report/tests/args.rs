//! `report-math`'s command line is clap's: a malformed value is a usage error (exit 2) naming the option.

#[test]
fn malformed_values_are_usage_errors() {
    let run =
        |args: &[&str]| std::process::Command::new(env!("CARGO_BIN_EXE_report-math")).args(args).output().unwrap();
    for (args, names) in [
        (&["--scenes", "x"][..], "invalid value 'x' for '--scenes <SCENES>'"),
        (&["--product-per-decade", "0"][..], "invalid value '0' for '--product-per-decade <PRODUCT_PER_DECADE>'"),
        (&["--bogus"][..], "unexpected argument '--bogus'"),
    ] {
        let o = run(args);
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(names), "{args:?}: {err}");
    }
    let o = run(&["--help"]);
    assert!(o.status.success() && String::from_utf8_lossy(&o.stdout).contains("--quick"));
}
