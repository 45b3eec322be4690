//! Rules the source tree keeps, read from the files themselves: the module graph that
//! ARCHITECTURE.md draws has no cycles, no function is over 200 lines, no file over 1,500,
//! and the library holds no process-wide mutable state.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

use crate::common::rust_files;

/// The module path of a file under src/: `src/patch/repair/arm.rs` → ["patch", "repair",
/// "arm"]; `mod.rs`, `lib.rs` and `main.rs` name their folder (the root is []).
fn module_of(file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src()).unwrap();
    let mut parts: Vec<String> = rel
        .iter()
        .map(|s| s.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The code of a line without its `//` comment (string contents are kept: a `//` inside a
/// string cuts the line short, which only loses paths, never invents one).
fn code(line: &str) -> &str {
    line.split("//").next().unwrap_or("")
}

/// The module paths a file's library code names (see [`references_in`]). Test code is not
/// part of the graph: the files of `src/tests/` and a file's `#[cfg(test)] mod` (its unit
/// tests, which may use any layer to check it).
fn references(file: &Path) -> Vec<Vec<String>> {
    let here = module_of(file);
    if here.first().is_some_and(|m| m == "tests") {
        return Vec::new();
    }
    let text = std::fs::read_to_string(file).unwrap();
    references_in(library_code(&text), &here)
}

/// `text` up to its first `#[cfg(test)]` line followed by a `mod` line.
fn library_code(text: &str) -> &str {
    let mut at = 0;
    let mut lines = text.split_inclusive('\n').peekable();
    while let Some(line) = lines.next() {
        if line.trim() == "#[cfg(test)]"
            && lines
                .peek()
                .is_some_and(|l| l.trim_start().starts_with("mod "))
        {
            return &text[..at];
        }
        at += line.len();
    }
    text
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The module paths the code `text` of module `here` names: `crate::a::b` anywhere in its
/// code (in `use` lines, in grouped `use crate::{a::x, b::{y, z}}` trees, on one line or
/// several, and in inline paths), and `super::` paths (`super::super::` too) resolved
/// against the module. Each is returned as a full path of names, which may end in an item
/// rather than a module; a group's `self` names the group's own path.
fn references_in(text: &str, here: &[String]) -> Vec<Vec<String>> {
    let code: String = text.lines().map(code).collect::<Vec<_>>().join("\n");
    let mut out = Vec::new();
    for start in ["crate::", "super::"] {
        let mut from = 0;
        while let Some(i) = code[from..].find(start) {
            let at = from + i;
            from = at + start.len();
            // Part of a longer name or path (`my_crate::`, `super::super::`).
            if code[..at].ends_with(is_ident) || code[..at].ends_with("::") {
                continue;
            }
            let mut root: Vec<String> = Vec::new();
            let mut rest = &code[from..];
            if start == "super::" {
                // A file's `super` is its module's parent (for `mod.rs` too).
                root = here[..here.len().saturating_sub(1)].to_vec();
                while let Some(r) = rest.strip_prefix("super::") {
                    root.pop();
                    rest = r;
                }
            }
            use_tree(rest, &root, &mut out);
        }
    }
    out
}

/// Parses the path or use tree at the start of `s` (`a::b`, `a::{b, c::{d, self}}`,
/// `a as b`, `a::*`), pushing `prefix` followed by each full path onto `out`; returns the
/// text after it.
fn use_tree<'a>(mut s: &'a str, prefix: &[String], out: &mut Vec<Vec<String>>) -> &'a str {
    let mut path = prefix.to_vec();
    loop {
        s = s.trim_start();
        let n = s.find(|c: char| !is_ident(c)).unwrap_or(s.len());
        if n == 0 {
            break;
        }
        path.push(s[..n].to_string());
        s = &s[n..];
        match s.trim_start().strip_prefix("::") {
            Some(r) => s = r,
            None => break,
        }
    }
    let t = s.trim_start();
    if let Some(mut r) = t.strip_prefix('{') {
        loop {
            r = use_tree(r, &path, out).trim_start();
            if let Some(x) = r.strip_prefix(',') {
                r = x;
            } else {
                // The closing brace (or malformed text: stop there).
                return r.strip_prefix('}').unwrap_or(r);
            }
            if let Some(x) = r.trim_start().strip_prefix('}') {
                return x; // a trailing comma
            }
        }
    }
    if path.last().is_some_and(|l| l == "self") {
        path.pop();
    }
    out.push(path);
    let t = t.strip_prefix('*').unwrap_or(t).trim_start();
    match t.strip_prefix("as ") {
        Some(r) => r.trim_start().trim_start_matches(is_ident),
        None => t,
    }
}

/// Module folders and files: the set of module paths that exist.
fn modules() -> BTreeSet<Vec<String>> {
    rust_files(&src()).iter().map(|f| module_of(f)).collect()
}

/// The longest prefix of `path` that is a module.
fn module_prefix(path: &[String], mods: &BTreeSet<Vec<String>>) -> Vec<String> {
    (0..=path.len())
        .rev()
        .map(|n| path[..n].to_vec())
        .find(|p| mods.contains(p))
        .unwrap_or_default()
}

/// Edges between sibling modules, by their parent: (from, to, the file that names it).
type Edges = BTreeMap<Vec<String>, BTreeSet<(String, String, String)>>;

/// A file as the scan sees it: its module, its name under src/, the paths it names.
type SourceFile = (Vec<String>, String, Vec<Vec<String>>);

/// Edges between sibling modules of src/ (see [`edges_between`]).
fn sibling_edges() -> Edges {
    let files: Vec<_> = rust_files(&src())
        .iter()
        .map(|f| {
            let rel = f.strip_prefix(src()).unwrap().display().to_string();
            (module_of(f), rel, references(f))
        })
        .collect();
    edges_between(&files, &modules())
}

/// Edges between sibling modules: for every file (its module, its name, the paths it
/// names) in module `a` naming a module `b`, the edge is drawn between the children of
/// their deepest common ancestor that hold them (so `eval::cpu::edges` naming
/// `tess::stitch` is `eval → tess`, and `patch::validity` naming `patch::repair::arm` is
/// `patch::validity → patch::repair`). A module naming its own ancestor or descendant
/// draws nothing: a parent and its children are one unit.
fn edges_between(files: &[SourceFile], mods: &BTreeSet<Vec<String>>) -> Edges {
    let mut edges = Edges::new();
    for (from, rel, paths) in files {
        for path in paths {
            let to = module_prefix(path, mods);
            let common = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
            if common == from.len() || common == to.len() {
                continue;
            }
            edges.entry(from[..common].to_vec()).or_default().insert((
                from[common].clone(),
                to[common].clone(),
                rel.clone(),
            ));
        }
    }
    edges
}

/// A cycle in a directed graph, as the list of its nodes, if there is one.
fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(n) {
            Some(2) => return None,
            Some(1) => {
                let at = stack.iter().position(|s| s == n).unwrap();
                return Some([&stack[at..], &[n.to_string()]].concat());
            }
            _ => {}
        }
        state.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for m in g.get(n).into_iter().flatten() {
            if let Some(c) = visit(m, g, state, stack) {
                return Some(c);
            }
        }
        stack.pop();
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

fn names(path: &str) -> Vec<String> {
    path.split("::")
        .filter(|s| !s.is_empty())
        .map(String::from)
        .collect()
}

#[test]
fn unit_tests_at_the_end_of_a_file_are_not_library_code() {
    let text = "use crate::a;\n#[cfg(test)]\nuse crate::b;\n#[cfg(test)]\nmod tests {\n    use crate::c;\n}\n";
    assert_eq!(
        library_code(text),
        "use crate::a;\n#[cfg(test)]\nuse crate::b;\n"
    );
    assert_eq!(library_code("fn f() {}\n"), "fn f() {}\n");
}

#[test]
fn references_read_use_trees_inline_paths_and_super() {
    let text = "use crate::{Error, Result};\n\
                use crate::eval::{grid_len, pattern::{self, grid_index as gi}, Chunk};\n\
                use super::{\n    atomic::write_atomic,\n    msh,\n};\n\
                // use crate::commented::Out;\n\
                fn f() { let n = crate::tess::layout::MAX_LEVEL; my_crate::not::Me; }\n\
                use super::super::mesh::Mesh;\n";
    let mut got = references_in(text, &names("io::writers"));
    got.sort();
    let mut want: Vec<Vec<String>> = [
        "Error",
        "Result",
        "eval::grid_len",
        "eval::pattern",
        "eval::pattern::grid_index",
        "eval::Chunk",
        "io::atomic::write_atomic",
        "io::msh",
        "mesh::Mesh",
        "tess::layout::MAX_LEVEL",
    ]
    .iter()
    .map(|p| names(p))
    .collect();
    want.sort();
    assert_eq!(got, want);
}

#[test]
fn a_cycle_between_sibling_files_is_found_and_a_chain_is_not() {
    let mods: BTreeSet<Vec<String>> = ["", "a", "a::x", "a::y", "a::z", "b"]
        .iter()
        .map(|m| names(m))
        .collect();
    let file = |m: &str, text: &str| (names(m), format!("{m}.rs"), references_in(text, &names(m)));
    let files = [
        file("a::x", "use super::y::Y;"),
        file("a::y", "fn f() { crate::a::z::g() }"),
        file("a::z", "use crate::{a::{x::X, self}, Error};"),
        file("b", "use crate::a::x::X;"),
    ];
    let edges = edges_between(&files, &mods);
    let graph = |parent: &str| -> BTreeMap<String, BTreeSet<String>> {
        let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b, _) in &edges[&names(parent)] {
            g.entry(a.clone()).or_default().insert(b.clone());
        }
        g
    };
    let cycle = find_cycle(&graph("a")).expect("x -> y -> z -> x");
    assert_eq!(cycle.first(), cycle.last());
    assert_eq!(cycle.len(), 4);
    // The top level: b -> a only (z naming its parent `a` draws nothing).
    assert_eq!(
        graph(""),
        BTreeMap::from([("b".into(), BTreeSet::from(["a".into()]))])
    );
    assert_eq!(find_cycle(&graph("")), None);
    // Without z -> x the chain has no cycle.
    let files = [
        files[0].clone(),
        files[1].clone(),
        file("a::z", "use super::Z;"),
    ];
    let edges = edges_between(&files, &mods);
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (a, b, _) in &edges[&names("a")] {
        g.entry(a.clone()).or_default().insert(b.clone());
    }
    assert_eq!(find_cycle(&g), None);
}

#[test]
fn module_graph_has_no_cycles() {
    let edges = sibling_edges();
    assert!(
        edges.get(&Vec::new()).is_some_and(|e| e.len() > 20),
        "the scan found too few top-level edges: {:?}",
        edges.get(&Vec::new())
    );
    let mut failures = Vec::new();
    // The crate's layers and the modules of each layer; deeper folders (the repair's
    // phases, `impl` blocks of one driver struct split by file) are one unit.
    for (parent, list) in edges.iter().filter(|(p, _)| p.len() <= 1) {
        let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b, _) in list {
            graph.entry(a.clone()).or_default().insert(b.clone());
        }
        if let Some(cycle) = find_cycle(&graph) {
            let witnesses: Vec<String> = cycle
                .windows(2)
                .map(|w| {
                    let files: Vec<&str> = list
                        .iter()
                        .filter(|(a, b, _)| *a == w[0] && *b == w[1])
                        .map(|(_, _, f)| f.as_str())
                        .collect();
                    format!("{} -> {} ({})", w[0], w[1], files.join(", "))
                })
                .collect();
            failures.push(format!(
                "cycle under `{}`: {}",
                if parent.is_empty() {
                    "crate".to_string()
                } else {
                    parent.join("::")
                },
                witnesses.join("; ")
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The top-level layers in ARCHITECTURE.md's order: each may name only layers before it.
const LAYERS: &[&str] = &[
    "error", "mesh", "patch", "eval", "tess", "analysis", "io", "gpu", "render", "cli",
];

#[test]
fn top_level_modules_only_depend_on_earlier_layers() {
    let edges = sibling_edges();
    let rank = |m: &str| LAYERS.iter().position(|l| *l == m);
    let mut wrong = Vec::new();
    for (a, b, file) in edges.get(&Vec::new()).into_iter().flatten() {
        match (rank(a), rank(b)) {
            (Some(x), Some(y)) if y < x => {}
            (Some(_), Some(_)) => wrong.push(format!("{a} -> {b} ({file})")),
            // Crate-private helpers outside the layers (pipelined, progress) are leaves.
            _ => {}
        }
    }
    assert!(
        wrong.is_empty(),
        "arrows against the layers:\n{}",
        wrong.join("\n")
    );
}

/// Line ranges of the functions of one file: (name, first line, line count), counted from
/// the `fn` line to its closing brace, with braces in strings and comments ignored.
fn functions(text: &str) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let c = code(line).trim_start();
        let Some(at) = c.find("fn ") else { continue };
        let head = &c[..at];
        let is_fn_line = head.split_whitespace().all(|w| {
            matches!(w, "pub" | "const" | "async" | "unsafe" | "extern" | "\"C\"")
                || w.starts_with("pub(")
        });
        if !is_fn_line {
            continue;
        }
        let name: String = c[at + 3..]
            .chars()
            .take_while(|ch| ch.is_ascii_alphanumeric() || *ch == '_')
            .collect();
        let (mut depth, mut started) = (0i64, false);
        for (j, l) in lines.iter().enumerate().skip(i) {
            let mut in_str = false;
            let mut prev = ' ';
            for ch in code(l).chars() {
                match ch {
                    '"' if prev != '\\' => in_str = !in_str,
                    '{' if !in_str => {
                        depth += 1;
                        started = true;
                    }
                    '}' if !in_str => depth -= 1,
                    _ => {}
                }
                prev = ch;
            }
            if (started && depth == 0) || (!started && code(l).trim_end().ends_with(';')) {
                out.push((name.clone(), i + 1, j - i + 1));
                break;
            }
        }
    }
    out
}

#[test]
fn function_length_scan_finds_the_long_ones() {
    // The scan itself, on a known text: a 3-line function, a braced string, a declaration.
    let text = "fn a() {\n    let s = \"}{\";\n}\npub(crate) fn b();\npub fn c() { 1 }\n";
    assert_eq!(
        functions(text),
        vec![
            ("a".to_string(), 1, 3),
            ("b".to_string(), 4, 1),
            ("c".to_string(), 5, 1)
        ]
    );
}

#[test]
fn no_function_over_200_lines_and_no_file_over_1500() {
    let mut long = Vec::new();
    for file in rust_files(&src()) {
        let text = std::fs::read_to_string(&file).unwrap();
        let rel = file.strip_prefix(src()).unwrap().display().to_string();
        let n = text.lines().count();
        if n > 1500 {
            long.push(format!("src/{rel}: {n} lines"));
        }
        for (name, line, len) in functions(&text) {
            if len > 200 {
                long.push(format!("src/{rel}:{line}: fn {name} is {len} lines"));
            }
        }
    }
    assert!(long.is_empty(), "too long:\n{}", long.join("\n"));
}

#[test]
fn no_process_wide_mutable_state_outside_the_command_line() {
    let mut found = Vec::new();
    for file in rust_files(&src()) {
        let rel = file.strip_prefix(src()).unwrap().display().to_string();
        if rel.starts_with("cli/") {
            continue;
        }
        let text = std::fs::read_to_string(&file).unwrap();
        for (i, line) in text.lines().enumerate() {
            let c = code(line);
            let is_static = c.trim_start().starts_with("static ")
                || c.contains(" static ") && !c.contains("'static");
            let mutable = ["Mutex", "RwLock", "static mut", "Atomic"]
                .iter()
                .any(|w| c.contains(w));
            if is_static && mutable {
                found.push(format!("src/{rel}:{}: {}", i + 1, line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "global mutable state:\n{}",
        found.join("\n")
    );
}
