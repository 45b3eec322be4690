//! The documentation stays readable and its links resolve: README.md and ARCHITECTURE.md
//! keep their length limits, no module comment (`//!` block) in `src/` grows into a
//! chapter, every relative link of the documents points at a file that exists (and at a
//! heading that exists, where it names one), and the README's Rust sample is the crate's
//! doctest.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Documents whose links are checked: README.md, ARCHITECTURE.md, BENCHMARKS.md and every
/// `docs/*.md`.
fn documents() -> Vec<PathBuf> {
    let mut out = vec![
        root().join("README.md"),
        root().join("ARCHITECTURE.md"),
        root().join("BENCHMARKS.md"),
    ];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    docs.sort();
    assert!(docs.len() >= 5, "docs/ holds too few documents: {docs:?}");
    out.extend(docs);
    out
}

/// The lines of a markdown text outside fenced code blocks, numbered from 1.
fn prose_lines(text: &str) -> Vec<(usize, &str)> {
    let mut fenced = false;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if !fenced {
            out.push((i + 1, line));
        }
    }
    out
}

/// The targets of the inline links and images of one line: `[text](target)`,
/// `![alt](target)`, with an optional title after the target.
fn link_targets(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(at) = rest.find("](") {
        let after = &rest[at + 2..];
        let Some(end) = after.find(')') else { break };
        let target = after[..end].split_whitespace().next().unwrap_or("");
        out.push(target.to_string());
        rest = &after[end..];
    }
    out
}

/// GitHub's anchor of a heading: lower case, letters, digits, `-` and `_` kept, spaces
/// turned into `-`, everything else dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(markdown: &str) -> BTreeSet<String> {
    prose_lines(markdown)
        .into_iter()
        .filter_map(|(_, l)| l.strip_prefix('#'))
        .map(|l| slug(l.trim_start_matches('#')))
        .collect()
}

#[test]
fn slug_follows_github_for_the_headings_we_use() {
    assert_eq!(
        slug(" Table 1: continuity across edges"),
        "table-1-continuity-across-edges"
    );
    assert_eq!(
        slug("The point-normal format `.pn`"),
        "the-point-normal-format-pn"
    );
    assert_eq!(slug("Gmsh MSH 4.1"), "gmsh-msh-41");
    assert_eq!(slug("Set-up"), "set-up");
    assert_eq!(
        link_targets("see [a](x.md#b \"t\") and ![c](d/e.png), not [f] (g)"),
        ["x.md#b", "d/e.png"]
    );
}

#[test]
fn readme_is_at_most_300_lines() {
    let n = read(&root().join("README.md")).lines().count();
    assert!(
        n <= 300,
        "README.md has {n} lines; reference material belongs in docs/"
    );
}

#[test]
fn architecture_is_at_most_200_lines_without_lines_over_400_characters() {
    let text = read(&root().join("ARCHITECTURE.md"));
    let n = text.lines().count();
    assert!(n <= 200, "ARCHITECTURE.md has {n} lines");
    let long: Vec<String> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.chars().count() > 400)
        .map(|(i, l)| format!("line {}: {} characters", i + 1, l.chars().count()))
        .collect();
    assert!(long.is_empty(), "ARCHITECTURE.md: {long:?}");
}

use crate::common::rust_files;

/// The longest run of consecutive `//!` lines of a file, and the line it starts on.
fn longest_module_comment(text: &str) -> (usize, usize) {
    let (mut best, mut start, mut run) = ((0, 0), 0, 0);
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("//!") {
            if run == 0 {
                start = i + 1;
            }
            run += 1;
            if run > best.0 {
                best = (run, start);
            }
        } else {
            run = 0;
        }
    }
    best
}

#[test]
fn no_module_comment_is_over_60_lines() {
    assert_eq!(longest_module_comment("//! a\n//! b\nx\n//! c\n"), (2, 1));
    let files = rust_files(&root().join("src"));
    assert!(
        files.len() > 50,
        "found only {} files under src/",
        files.len()
    );
    let mut long = Vec::new();
    for file in files {
        let rel = file
            .strip_prefix(root())
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        let (lines, at) = longest_module_comment(&read(&file));
        if lines > 60 {
            long.push(format!("{rel}:{at}: a //! block of {lines} lines"));
        }
    }
    assert!(
        long.is_empty(),
        "module comments over 60 lines (move the detail to docs/ or ARCHITECTURE.md):\n{}",
        long.join("\n")
    );
}

#[test]
fn relative_links_point_at_files_and_headings_that_exist() {
    let root = root();
    let mut broken = Vec::new();
    let mut checked = 0;
    for doc in documents() {
        let text = read(&doc);
        let name = doc.strip_prefix(&root).unwrap().display().to_string();
        for (line, l) in prose_lines(&text) {
            for target in link_targets(l) {
                if target.contains("://") || target.starts_with("mailto:") {
                    continue;
                }
                checked += 1;
                let (path, anchor) = match target.split_once('#') {
                    Some((p, a)) => (p, Some(a)),
                    None => (target.as_str(), None),
                };
                let file = if path.is_empty() {
                    doc.clone()
                } else {
                    doc.parent().unwrap().join(path)
                };
                let Ok(file) = file.canonicalize() else {
                    broken.push(format!("{name}:{line}: {target}: no such file"));
                    continue;
                };
                if !file.starts_with(&root) {
                    broken.push(format!("{name}:{line}: {target}: outside the repository"));
                    continue;
                }
                if let Some(anchor) = anchor {
                    let is_md = file.extension().is_some_and(|x| x == "md");
                    if is_md && !anchors(&read(&file)).contains(anchor) {
                        broken.push(format!("{name}:{line}: {target}: no such heading"));
                    }
                }
            }
        }
    }
    assert!(
        checked > 40,
        "only {checked} relative links found: is the parser right?"
    );
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

/// The fenced ```` ```rust ```` block after the line `heading` in a markdown file.
pub(crate) fn sample_after<'a>(text: &'a str, heading: &str) -> Vec<&'a str> {
    text.lines()
        .skip_while(|l| *l != heading)
        .skip_while(|l| *l != "```rust")
        .skip(1)
        .take_while(|l| *l != "```")
        .collect()
}

/// The first doctest of a file's module comment, without its hidden (`# `) lines.
pub(crate) fn module_doctest(source: &str, fence: &str) -> Vec<String> {
    let doc: Vec<&str> = source
        .lines()
        .map_while(|l| l.strip_prefix("//!"))
        .map(|l| l.strip_prefix(' ').unwrap_or(l))
        .collect();
    let start = doc.iter().position(|l| *l == fence).unwrap() + 1;
    let len = doc[start..].iter().position(|l| *l == "```").unwrap();
    doc[start..start + len]
        .iter()
        .filter(|l| !(l.starts_with("# ") || **l == "#"))
        .map(|l| l.to_string())
        .collect()
}

#[test]
fn readme_rust_sample_is_the_crate_doctest() {
    let doctest = module_doctest(&read(&root().join("src/lib.rs")), "```");
    assert!(doctest.len() > 10 && doctest[0].starts_with("use g1tess::"));
    let readme = read(&root().join("README.md"));
    assert_eq!(
        sample_after(&readme, "## Rust"),
        doctest,
        "README.md: the sample under ## Rust"
    );
}

/// The embedding sample of docs/gpu.md and ARCHITECTURE.md (the ```rust block after
/// `heading`) is the module doctest of `src/gpu/tessellator/mod.rs` (compiled by `cargo test`)
/// without its hidden `# ` lines, line for line: the documents show code that compiles.
#[test]
fn docs_samples_are_the_tessellator_doctest() {
    let root = env!("CARGO_MANIFEST_DIR");
    let read = |path: &str| std::fs::read_to_string(format!("{root}/{path}")).unwrap();
    let doctest = module_doctest(&read("src/gpu/tessellator/mod.rs"), "```no_run");
    assert!(doctest.len() > 20 && doctest[0].starts_with("use g1tess::"));
    for (path, heading) in [
        ("docs/gpu.md", "## Tessellating on your own wgpu device"),
        (
            "ARCHITECTURE.md",
            "## Embedding the GPU tessellator in a wgpu program",
        ),
    ] {
        let text = read(path);
        assert!(
            text.lines().any(|l| l == heading),
            "{path}: no heading {heading:?}"
        );
        assert_eq!(
            sample_after(&text, heading),
            doctest,
            "{path}: the sample under {heading:?}"
        );
    }
}
