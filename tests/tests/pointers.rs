//! The sources' pointers lead somewhere: no reference to a DESIGN.md that is not in the repository (the design
//! notes the code cites are docs/design.md, cited as `docs/design.md §N`, and every cited section exists), and
//! every shader file a comment or a doc names (`shaders-glsl/…/x.glsl`) exists. Before, 16 comments cited a
//! DESIGN.md outside the repository and rng.rs named a `shaders-glsl/common/rng.glsl` that never existed.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Text files of the repository that comments and docs live in (build outputs and generated pages left out).
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().to_string();
        if p.is_dir() {
            if !name.starts_with("target") && name != "out" && name != "results" && name != ".git" {
                sources(&p, out);
            }
        } else if ["rs", "glsl", "comp", "vert", "frag", "toml", "md"].iter().any(|x| name.ends_with(&format!(".{x}")))
        {
            out.push(p);
        }
    }
}

#[test]
fn cited_design_notes_and_shader_files_exist() {
    let root = root();
    let mut files = Vec::new();
    for d in ["engine", "demos", "tests", "tools", "shaders-glsl", "docs", ".cargo"] {
        sources(&root.join(d), &mut files);
    }
    files.push(root.join("README.md"));
    // This test names the stale pointers it looks for.
    files.retain(|f| !f.ends_with("tests/tests/pointers.rs"));
    assert!(files.len() > 100, "{} files", files.len());
    let design = std::fs::read_to_string(root.join("docs/design.md")).expect("docs/design.md");
    let mut bad = Vec::new();
    let mut cited = 0;
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap_or_default();
        let rel = f.strip_prefix(&root).unwrap().display().to_string();
        if text.contains("DESIGN.md") {
            bad.push(format!("{rel}: cites DESIGN.md, which is not in the repository (docs/design.md is)"));
        }
        for (i, _) in text.match_indices("docs/design.md §") {
            let n: String = text[i + "docs/design.md §".len()..].chars().take_while(char::is_ascii_digit).collect();
            if !design.contains(&format!("\n## {n}. ")) {
                bad.push(format!("{rel}: cites docs/design.md §{n}, which has no such section"));
            }
            cited += 1;
        }
        for (i, _) in text.match_indices("shaders-glsl/") {
            let path: String = text[i..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '/' | '.' | '-'))
                .collect();
            let path = path.trim_end_matches('.');
            let is_file = [".glsl", ".comp", ".vert", ".frag"].iter().any(|x| path.ends_with(x));
            if is_file && !root.join(path).is_file() {
                bad.push(format!("{rel}: names {path}, which does not exist"));
            }
        }
    }
    assert!(cited >= 10, "only {cited} citations of docs/design.md found");
    assert!(bad.is_empty(), "stale pointers:\n{}", bad.join("\n"));
}
