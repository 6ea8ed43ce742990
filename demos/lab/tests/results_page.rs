//! What README.md shows from the sweep `readme` is what docs/results/ holds, checked by text alone (nothing is
//! rendered): the summary block equals docs/results/summary.md, every number in it is results.csv's (formatted
//! as the report formats it), every picture and plot README.md takes from docs/results/ exists there, and the
//! pages name the same commit and command.

use lab::report::page::{block_of, summary_cell};
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(root().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// `results.csv` as (scene, shading, technique) → the named columns, parsed.
fn results() -> Vec<(String, String, String, std::collections::HashMap<String, f64>)> {
    let mut r = csv::Reader::from_path(root().join("docs/results/results.csv")).expect("docs/results/results.csv");
    let header: Vec<String> = r.headers().expect("a header").iter().map(str::to_string).collect();
    r.records()
        .map(|rec| {
            let rec = rec.expect("a record");
            let values = header
                .iter()
                .zip(rec.iter())
                .filter_map(|(h, v)| v.parse::<f64>().ok().map(|x| (h.clone(), x)))
                .collect();
            (rec[0].to_string(), rec[1].to_string(), rec[2].to_string(), values)
        })
        .collect()
}

#[test]
fn readme_figures_match_the_results_page() {
    let readme = read("README.md");
    let summary = read("docs/results/summary.md");
    let block = block_of(&readme).expect("README.md has the generated summary block (results_page::BEGIN … END)");
    assert_eq!(
        block,
        summary.trim_end(),
        "README.md's summary differs from docs/results/summary.md: run `cargo xtask report --sweep readme`"
    );

    // Every cell of the table is the CSV's row, formatted as the report formats it.
    let rows = results();
    let lines: Vec<&str> = block.lines().filter(|l| l.starts_with('|')).collect();
    let techniques: Vec<&str> =
        lines[0].split('|').map(str::trim).filter(|c| !c.is_empty()).skip(1).map(|c| c.trim_matches('`')).collect();
    assert!(techniques.len() >= 4, "summary columns: {techniques:?}");
    let mut cells = 0;
    for line in &lines[2..] {
        let parts: Vec<&str> = line.split('|').map(str::trim).filter(|c| !c.is_empty()).collect();
        let scene = parts[0];
        for (tech, cell) in techniques.iter().zip(&parts[1..]) {
            let (_, _, _, v) = rows
                .iter()
                .find(|(s, shading, t, _)| s == scene && shading == "pixel" && t == tech)
                .unwrap_or_else(|| panic!("README shows {scene} / {tech}, which results.csv does not have"));
            let get = |k: &str| v.get(k).copied().unwrap_or(f64::NAN);
            let expected = summary_cell(get("rmse_sph_debiased_pct"), get("rmse_tri_debiased_pct"), get("shade_ms"));
            assert_eq!(*cell, expected, "README's {scene} / {tech} is not results.csv's");
            cells += 1;
        }
    }
    assert!(cells >= 6 * 4, "the summary covers the six scenes × four techniques: {cells} cells");

    // The results page's Markdown shows the same rows.
    let page = read("docs/results/README.md");
    for line in &lines {
        assert!(page.contains(line), "docs/results/README.md lacks the summary row {line}");
    }

    // Every figure README.md takes from docs/results/ exists there.
    let mut figures = 0;
    for (i, _) in readme.match_indices("](docs/results/") {
        let rest = &readme[i + 2..];
        let target = &rest[..rest.find(')').expect("a closing parenthesis")];
        let path = target.split('#').next().unwrap();
        assert!(root().join(path).is_file(), "README.md links {target}, which docs/results/ lacks");
        figures += 1;
    }
    assert!(readme.contains("](docs/results/hero.png)") && readme.contains("](docs/results/summary.svg)"));
    assert!(figures >= 3, "{figures} links into docs/results/");

    // The block, the Markdown page and index.html name the same commit and command.
    let commit = block.split("at commit ").nth(1).and_then(|r| r.split([';', ' ']).next()).expect("the commit");
    let command = block.split('`').nth(1).expect("the command");
    assert!(command.starts_with("cargo xtask report"), "command: {command}");
    for page in ["docs/results/README.md", "docs/results/index.html"] {
        let text = read(page);
        assert!(text.contains(commit), "{page} does not name commit {commit}");
        assert!(text.contains(command), "{page} does not name the command {command}");
    }
}
