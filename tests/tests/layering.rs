//! The layering written in engine/src/lib.rs is true: a module imports only from lower layers or from
//! itself, and neither the engine's modules nor the math crate's import each other in a circle. Reads
//! the sources (comments stripped), so a new `use crate::renderer` in a pass fails here.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// engine/src's top-level modules, lowest layer first (engine/src/lib.rs says why).
const ENGINE_LAYERS: &[(&str, u32)] = &[
    ("gpu", 0),
    ("options", 0),
    ("metrics", 0),
    ("output", 0),
    ("scene", 1),
    ("tables", 2),
    ("resources", 3),
    ("passes", 4),
    ("renderer", 5),
    ("converge", 6),
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).expect("source folder") {
        let p = e.expect("entry").path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Source without comments (line comments and doc comments; block comments are not used here).
fn code_of(path: &Path) -> String {
    let text = std::fs::read_to_string(path).expect("source");
    text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n")
}

/// `crate::X` references of a source: the top-level module names X, including those inside
/// `use crate::{a::b, c}` groups.
fn crate_refs(code: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let ident = |s: &str| s.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect::<String>();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        let before = rest[..i].chars().last();
        rest = &rest[i + "crate::".len()..];
        // `my_crate::` or `a::crate::` are not this crate's root.
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for part in group[..end].split(',') {
                let name = ident(part.trim());
                if !name.is_empty() {
                    out.insert(name);
                }
            }
        } else {
            let name = ident(rest);
            if !name.is_empty() {
                out.insert(name);
            }
        }
    }
    out
}

/// Top-level module of a file under `src`: `passes/shade/isg/mod.rs` → `passes`, `lib.rs` → None.
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).ok()?;
    let first = rel.components().next()?.as_os_str().to_string_lossy().to_string();
    let name = first.strip_suffix(".rs").unwrap_or(&first).to_string();
    (name != "lib" && name != "main" && name != "bin").then_some(name)
}

/// Module → modules it references, over a crate's `src`.
fn module_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        let Some(m) = module_of(src, &f) else { continue };
        let refs = crate_refs(&code_of(&f));
        graph.entry(m.clone()).or_default().extend(refs.into_iter().filter(|r| *r != m));
    }
    graph
}

/// A circle in the graph, if any (as the list of modules around it).
fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(n) {
            Some(2) => return None,
            Some(1) => {
                let start = path.iter().position(|p| p == n).unwrap_or(0);
                let mut c = path[start..].to_vec();
                c.push(n.to_string());
                return Some(c);
            }
            _ => {}
        }
        state.insert(n.to_string(), 1);
        path.push(n.to_string());
        for m in g.get(n).into_iter().flatten() {
            if g.contains_key(m) {
                if let Some(c) = visit(m, g, state, path) {
                    return Some(c);
                }
            }
        }
        path.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        if let Some(c) = visit(n, graph, &mut state, &mut Vec::new()) {
            return Some(c);
        }
    }
    None
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn engine_modules_import_only_lower_layers() {
    let src = root().join("engine/src");
    let graph = module_graph(&src);
    let layer = |m: &str| ENGINE_LAYERS.iter().find(|(n, _)| *n == m).map(|(_, l)| *l);
    let mut bad = Vec::new();
    for (m, refs) in &graph {
        let lm = layer(m).unwrap_or_else(|| panic!("engine module '{m}' has no layer in ENGINE_LAYERS (and lib.rs)"));
        for r in refs {
            match layer(r) {
                Some(lr) if lr <= lm => {}
                Some(lr) => bad.push(format!("{m} (layer {lm}) imports {r} (layer {lr})")),
                // `crate::Error` and friends defined in lib.rs.
                None => {}
            }
        }
    }
    assert!(bad.is_empty(), "imports against the layering of engine/src/lib.rs:\n{}", bad.join("\n"));
    assert_eq!(find_cycle(&graph), None, "an import circle between engine modules");
}

#[test]
fn no_import_circles_in_the_math_blocker_and_io_crates() {
    for krate in ["engine/math/src", "engine/blockers/src", "engine/io/src"] {
        let graph = module_graph(&root().join(krate));
        assert!(!graph.is_empty(), "{krate}: no modules found");
        assert_eq!(find_cycle(&graph), None, "{krate}: an import circle between modules");
    }
}

/// The checker itself, on sources with known answers (a test that cannot fail proves nothing).
#[test]
fn the_checker_sees_imports_and_circles() {
    let refs = crate_refs("use crate::gpu::{Buffer};\nuse crate::{renderer::X, scene};\nlet a = engine_math::crate::x; crate::tables::load()");
    assert_eq!(refs, ["gpu", "renderer", "scene", "tables"].iter().map(|s| s.to_string()).collect());
    let mut g = BTreeMap::new();
    g.insert("a".to_string(), BTreeSet::from(["b".to_string()]));
    g.insert("b".to_string(), BTreeSet::from(["a".to_string()]));
    assert!(find_cycle(&g).is_some());
    g.insert("b".to_string(), BTreeSet::new());
    assert_eq!(find_cycle(&g), None);
}
