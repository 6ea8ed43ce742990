//! The layering written in engine/src/lib.rs is true: a module imports only from lower layers or from
//! itself, and neither the engine's modules nor the math crate's import each other in a circle, at the level
//! of the top modules (`crate::` paths) and at the level of every file's module (`crate::`, `super::` and
//! `self::` paths, so that two sibling files such as `isg/cpu.rs` and `isg/thin.rs` cannot import each
//! other). Reads the sources (comments stripped), so a new `use crate::renderer` in a pass fails here.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// engine/src's top-level modules, lowest layer first (engine/src/lib.rs says why).
const ENGINE_LAYERS: &[(&str, u32)] = &[
    ("gpu", 0),
    ("options", 0),
    ("input", 0),
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

/// A file's module path under `src`: `passes/shade/isg/cpu.rs` → `[passes, shade, isg, cpu]`, a `mod.rs` →
/// its folder's, `lib.rs` → `[]`.
fn module_path(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).expect("under src");
    let mut parts: Vec<String> = rel.components().map(|c| c.as_os_str().to_string_lossy().to_string()).collect();
    let last = parts.pop().unwrap_or_default();
    let stem = last.strip_suffix(".rs").unwrap_or(&last).to_string();
    if stem != "mod" && stem != "lib" && stem != "main" {
        parts.push(stem);
    }
    parts
}

/// The paths a module's code names through `crate::`, `super::` (any number) and `self::`, resolved to absolute
/// segment lists, `use` groups (`super::{a::X, b}`) expanded one level. `me` is the module the code is in.
fn path_refs(code: &str, me: &[String]) -> Vec<Vec<String>> {
    let ident = |s: &str| s.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect::<String>();
    // The segments of a path at the start of `s` (`a::b::c`), and what follows it.
    fn segments(s: &str, ident: &dyn Fn(&str) -> String) -> (Vec<String>, usize) {
        let (mut out, mut at) = (Vec::new(), 0);
        loop {
            let id = ident(&s[at..]);
            if id.is_empty() {
                break;
            }
            at += id.len();
            out.push(id);
            if s[at..].starts_with("::") {
                at += 2;
            } else {
                break;
            }
        }
        (out, at)
    }
    let mut out = Vec::new();
    for (i, _) in code.match_indices("::") {
        // Find each path's first segment: the identifier before the first `::` not preceded by `::`.
        let head_start = code[..i].rfind(|c: char| !(c.is_alphanumeric() || c == '_')).map_or(0, |p| p + 1);
        if code[..head_start].ends_with("::") {
            continue;
        }
        let head = &code[head_start..i];
        if !matches!(head, "crate" | "super" | "self") {
            continue;
        }
        let (segs, end) = segments(&code[head_start..], &ident);
        let mut base: Vec<String> = match head {
            "crate" => Vec::new(),
            _ => me.to_vec(),
        };
        let mut rest = segs.into_iter().skip(1).peekable();
        if head == "super" {
            base.pop();
        }
        while rest.peek().is_some_and(|s| s == "super") {
            base.pop();
            rest.next();
        }
        base.extend(rest.filter(|s| s != "self"));
        let after = &code[head_start + end..];
        if let Some(group) = after.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for part in group[..end].split(',') {
                let (segs, _) = segments(part.trim(), &ident);
                let mut p = base.clone();
                p.extend(segs.into_iter().filter(|s| s != "self"));
                out.push(p);
            }
        } else {
            out.push(base);
        }
    }
    out
}

/// Module → modules it references, one node per file, over a crate's `src`. A reference counts when it names a
/// module that is neither the file's own nor one of its ancestors or descendants (a child using its parent's
/// items, or a parent re-exporting its child's, is how Rust modules are built, not a circle); code after an
/// inline `mod NAME {` (the tests) is resolved inside that module and counted for its file.
fn file_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let modules: BTreeSet<Vec<String>> = files.iter().map(|f| module_path(src, f)).collect();
    let related = |a: &[String], b: &[String]| a.starts_with(b) || b.starts_with(a);
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in &files {
        let me = module_path(src, f);
        let code = code_of(f);
        // (code, the module it is in): the file's top, then an inline module's body.
        let mut parts = vec![(code.as_str(), me.clone())];
        if let Some(at) = code.find("mod tests {") {
            let mut inner = me.clone();
            inner.push("tests".into());
            parts = vec![(&code[..at], me.clone()), (&code[at..], inner)];
        }
        let node = graph.entry(me.join("::")).or_default();
        for (text, at) in parts {
            for p in path_refs(text, &at) {
                // The longest prefix of the path that is a module (the rest names items in it).
                let Some(target) = (0..=p.len()).rev().map(|n| p[..n].to_vec()).find(|m| modules.contains(m)) else {
                    continue;
                };
                if !related(&target, &me) {
                    node.insert(target.join("::"));
                }
            }
        }
    }
    graph
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
    for krate in ["engine/math/src", "engine/blockers/src", "engine/io/src", "demos/scenes/src", "demos/lab/src"] {
        let graph = module_graph(&root().join(krate));
        assert!(!graph.is_empty(), "{krate}: no modules found");
        assert_eq!(find_cycle(&graph), None, "{krate}: an import circle between modules");
    }
}

#[test]
fn no_import_circles_between_files() {
    for krate in
        ["engine/src", "engine/math/src", "engine/blockers/src", "demos/scenes/src", "demos/lab/src", "demos/src"]
    {
        let graph = file_graph(&root().join(krate));
        assert!(graph.len() > 1, "{krate}: {} modules", graph.len());
        assert_eq!(find_cycle(&graph), None, "{krate}: files whose modules import each other in a circle");
    }
}

/// The file-level checker on sources with known answers: `super::`, `super::super::`, `self::`, `crate::` and
/// groups resolve to modules; a child naming its parent is not an edge; the circle of `isg/cpu.rs` and
/// `isg/thin.rs` (before `isg/grid.rs`) is found.
#[test]
fn the_file_checker_sees_super_and_self_paths() {
    let me: Vec<String> = ["passes", "shade", "isg", "cpu"].iter().map(|s| s.to_string()).collect();
    let refs = path_refs(
        "use super::thin::mark;\nlet g = super::super::none::X; self::inner::f(); use crate::{gpu::B, scene};",
        &me,
    );
    let refs: Vec<String> = refs.iter().map(|r| r.join("::")).collect();
    assert_eq!(
        refs,
        [
            "passes::shade::isg::thin::mark",
            "passes::shade::none::X",
            "passes::shade::isg::cpu::inner::f",
            "gpu::B",
            "scene"
        ]
    );
    let dir = std::env::temp_dir().join(format!("layering-{}", std::process::id()));
    let isg = dir.join("passes/isg");
    std::fs::create_dir_all(&isg).unwrap();
    std::fs::write(dir.join("lib.rs"), "pub mod passes;").unwrap();
    std::fs::write(dir.join("passes/mod.rs"), "pub mod isg;").unwrap();
    std::fs::write(isg.join("mod.rs"), "pub mod cpu; pub mod thin; pub use cpu::Grid;").unwrap();
    std::fs::write(isg.join("cpu.rs"), "use super::IsgOptions;\npub struct Grid; fn f() { super::thin::mark(); }")
        .unwrap();
    std::fs::write(isg.join("thin.rs"), "use super::cpu::Grid; // the circle\npub fn mark() {}").unwrap();
    let graph = file_graph(&dir);
    assert!(find_cycle(&graph).is_some(), "{graph:?}");
    std::fs::write(isg.join("thin.rs"), "pub fn mark() {}\n// use super::cpu::Grid; a comment is no import").unwrap();
    let graph = file_graph(&dir);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(find_cycle(&graph), None, "{graph:?}");
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

/// The workspace's crates, each with its layer (lowest first) and the top-level folder it lives in. A crate
/// depends only on crates of a lower layer, and a folder never imports from a folder above it: `engine` (0)
/// under `demos` (1) under `tools`, `tests` and `python` (2). Every workspace member must be listed here.
const CRATES: &[(&str, &str, u32)] = &[
    ("engine-io", "engine/io", 0),
    ("engine-math", "engine/math", 0),
    ("engine-blockers", "engine/blockers", 1),
    ("engine", "engine", 2),
    ("plot", "demos/lab/plot", 2),
    ("scenes", "demos/scenes", 3),
    ("lab", "demos/lab", 4),
    ("demos", "demos", 5),
    ("engine-fuzz", "tools/fuzz", 6),
    ("math-report", "tools/math-report", 6),
    ("xtask", "tools/xtask", 6),
    ("engine-tests", "tests", 6),
    ("softshadows", "python", 6),
];

fn folder_floor(dir: &str) -> u32 {
    match dir.split('/').next().unwrap_or("") {
        "engine" => 0,
        "demos" => 1,
        "tools" | "tests" | "python" => 2,
        other => panic!("a crate in an unknown top-level folder '{other}'"),
    }
}

/// The names in a Cargo.toml's `[dependencies]` and `[dev-dependencies]` tables that are workspace crates.
fn workspace_deps(toml: &str) -> Vec<(String, bool)> {
    let mut out = Vec::new();
    let mut table = String::new();
    for line in toml.lines().map(str::trim) {
        if line.starts_with('[') {
            table = line.to_string();
        } else if table == "[dependencies]" || table == "[dev-dependencies]" {
            let name = line.split(['=', ' ']).next().unwrap_or("").trim();
            if CRATES.iter().any(|(n, _, _)| *n == name) {
                out.push((name.to_string(), table == "[dev-dependencies]"));
            }
        }
    }
    out
}

#[test]
fn crates_depend_only_on_lower_layers_and_folders() {
    let manifest = std::fs::read_to_string(root().join("Cargo.toml")).unwrap();
    let members = manifest.lines().find(|l| l.trim_start().starts_with("members")).expect("workspace members");
    for m in members.split('"').skip(1).step_by(2) {
        assert!(CRATES.iter().any(|(_, dir, _)| *dir == m), "workspace member {m} has no layer in CRATES");
    }
    let mut bad = Vec::new();
    for (name, dir, layer) in CRATES {
        let toml = std::fs::read_to_string(root().join(dir).join("Cargo.toml")).unwrap();
        assert!(toml.contains(&format!("name = \"{name}\"")), "{dir}/Cargo.toml is not the crate {name}");
        for (dep, dev) in workspace_deps(&toml) {
            let (_, ddir, dlayer) = CRATES.iter().find(|(n, _, _)| *n == dep).unwrap();
            // A crate's own tests may use a crate beside it (dev-dependencies), never one above.
            if dlayer > layer || (!dev && dlayer == layer) {
                bad.push(format!("{name} (layer {layer}) depends on {dep} (layer {dlayer})"));
            }
            if folder_floor(ddir) > folder_floor(dir) {
                bad.push(format!("{dir} imports {ddir}, a folder above it"));
            }
        }
    }
    assert!(bad.is_empty(), "dependencies against the layering:\n{}", bad.join("\n"));
}

/// The crate checker's parser on a manifest with known answers.
#[test]
fn the_crate_checker_reads_dependency_tables() {
    let toml = "[package]\nname = \"x\"\n[dependencies]\nengine = { workspace = true }\nglam = \"1\"\n\
                [dev-dependencies]\nlab = { workspace = true }\n[[bin]]\nname = \"scenes\"\n";
    assert_eq!(workspace_deps(toml), vec![("engine".to_string(), false), ("lab".to_string(), true)]);
}
