//! Fuzzing on stable Rust: property tests that mutate the seed inputs of `tests/data/fuzz/`
//! and feed them to every reader (OBJ, `.pn`, PLY, STL, glTF, built-in specs,
//! `Mesh::from_soup`) and to the command line. Whatever comes in, a reader returns a valid mesh (finite positions, indices
//! in range, unit normals, patches of every scheme finite) or a one-line error; the binary
//! exits 0 or 1 with a one-line error, never a panic or an abort.
//!
//! The normal suite runs 10,000 in-process cases and 300 command lines. `PROPTEST_CASES`
//! sets the in-process count of each reader test (long campaigns: `scripts/fuzz.sh`);
//! `FUZZ_CLI_CASES` the command lines.

use std::path::{Path, PathBuf};
#[cfg(feature = "cli")]
use std::process::Command;

use g1tess::{LoadOptions, Mesh};
use g1tess::{PatchTable, Scheme, SchemeOptions};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// Cases of a test: `PROPTEST_CASES` when set, else `default`.
fn config(default: u32, var: &str) -> ProptestConfig {
    let cases = std::env::var(var)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default);
    ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn seed_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz")
}

/// The seed files with extension `ext`, sorted by name.
fn seeds(ext: &str) -> Vec<Vec<u8>> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(seed_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    paths.sort();
    assert!(!paths.is_empty(), "no .{ext} seeds");
    paths.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

/// Bytes and tokens that steer a parser into its corners.
const TOKENS: &[&str] = &[
    "\n",
    "\r",
    "\r\n",
    "\\",
    "\\\n",
    "/",
    "//",
    "-",
    " ",
    "\t",
    "#",
    "\0",
    "\u{1b}[2J",
    "\u{feff}",
    "\u{a0}",
    "é",
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "-2",
    "7",
    "99999999999",
    "-9223372036854775808",
    "1e75",
    "1e76",
    "-1e300",
    "1e-320",
    "1e-80",
    "nan",
    "inf",
    "0.1",
    "1.5e-7",
    "v",
    "vn",
    "vt",
    "f",
    "t",
    "c",
    "counts",
    "g1tess-pn 1",
    "v 0 0 0",
    "f 1 2 3",
    "vn 0 0 0",
    "v 2 0 0",
    "element",
    "property",
    "list",
    "uchar",
    "float",
    "end_header",
    "binary_big_endian",
    "facet",
    "vertex",
    "endloop",
    "solid",
    "\"count\":",
    "\"byteStride\":",
    "4294967295",
];

/// One edit of a byte string; positions are taken modulo its length.
#[derive(Clone, Debug)]
enum Edit {
    Flip(usize, u8),
    Insert(usize, usize),
    Delete(usize, usize),
    /// Replaces the whitespace-separated token around a position.
    Token(usize, usize),
    /// Copies line `from` to before line `to`.
    DupLine(usize, usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    let t = 0..TOKENS.len();
    prop_oneof![
        1 => (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Edit::Flip(p, b)),
        1 => (any::<usize>(), t.clone()).prop_map(|(p, k)| Edit::Insert(p, k)),
        1 => (any::<usize>(), 1usize..12).prop_map(|(p, n)| Edit::Delete(p, n)),
        3 => (any::<usize>(), t).prop_map(|(p, k)| Edit::Token(p, k)),
        1 => (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Edit::DupLine(a, b)),
    ]
}

fn apply(mut b: Vec<u8>, edits: &[Edit]) -> Vec<u8> {
    let blank = |c: u8| c.is_ascii_whitespace();
    for e in edits {
        let n = b.len().max(1);
        match *e {
            Edit::Flip(p, x) => {
                if !b.is_empty() {
                    b[p % n] = x;
                }
            }
            Edit::Insert(p, k) => {
                let at = p % (b.len() + 1);
                b.splice(at..at, TOKENS[k].bytes());
            }
            Edit::Delete(p, len) => {
                let at = p % n;
                let end = (at + len).min(b.len());
                b.drain(at.min(end)..end);
            }
            Edit::Token(p, k) => {
                let at = p % n;
                let (mut s, mut t) = (at.min(b.len()), at.min(b.len()));
                while s > 0 && !blank(b[s - 1]) {
                    s -= 1;
                }
                while t < b.len() && !blank(b[t]) {
                    t += 1;
                }
                b.splice(s..t, TOKENS[k].bytes());
            }
            Edit::DupLine(from, to) => {
                let starts: Vec<usize> = std::iter::once(0)
                    .chain(
                        b.iter()
                            .enumerate()
                            .filter(|x| *x.1 == b'\n')
                            .map(|x| x.0 + 1),
                    )
                    .filter(|&i| i <= b.len())
                    .collect();
                let s = starts[from % starts.len()];
                let e = b[s..]
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(b.len(), |i| s + i + 1);
                let line = b[s..e].to_vec();
                let at = starts[to % starts.len()];
                b.splice(at..at, line);
            }
        }
    }
    b
}

/// A scratch file per test (the cases of one test run one after another).
fn scratch(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// What every loaded mesh must satisfy, and every error message.
fn check(result: g1tess::Result<Mesh>) -> Result<(), TestCaseError> {
    let m = match result {
        Err(e) => {
            let s = e.to_string();
            prop_assert!(!s.is_empty());
            prop_assert!(!s.contains('\n') && !s.contains('\r'), "two lines: {s:?}");
            prop_assert!(!s.chars().any(|c| c.is_control()), "control: {s:?}");
            // Echoes are cut to 80 characters; paths and wording add the rest.
            prop_assert!(s.chars().count() < 600, "long: {s}");
            return Ok(());
        }
        Ok(m) => m,
    };
    prop_assert!(!m.triangles.is_empty());
    // Attributes stay in step with the triangles through the weld, finite.
    if let Some(u) = m.corner_uvs() {
        prop_assert_eq!(u.len(), m.triangles.len());
        prop_assert!(u.iter().flatten().flatten().all(|x| x.is_finite()));
    }
    if let Some(c) = m.corner_colors() {
        prop_assert_eq!(c.len(), m.triangles.len());
        prop_assert!(c.iter().flatten().flatten().all(|x| x.is_finite()));
    }
    prop_assert!(m.positions.iter().all(|p| p.is_finite()));
    prop_assert_eq!(m.corner_normals.len(), m.triangles.len());
    for (t, n) in m.triangles.iter().zip(&m.corner_normals) {
        prop_assert!(t.iter().all(|&v| (v as usize) < m.positions.len()));
        // Unit normals up to the rounding of one normalisation.
        prop_assert!(n.iter().all(|x| (x.length() - 1.0).abs() < 1e-12), "{n:?}");
    }
    // Small meshes (every fuzzed file is): every scheme's patches evaluate finite.
    if m.triangles.len() <= 400 {
        for scheme in Scheme::all() {
            let table = PatchTable::build(&m, scheme, &SchemeOptions::default());
            let table = match table {
                Ok(t) => t,
                Err(e) => return Err(TestCaseError::fail(format!("{scheme:?}: {e}"))),
            };
            for i in 0..table.len() {
                for b in [[1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.2, 0.3, 0.5]] {
                    let sp = table.eval(i, b);
                    prop_assert!(sp.p.is_finite() && sp.n.is_finite(), "{scheme:?} {i}");
                }
            }
        }
    }
    Ok(())
}

fn load(path: &Path) -> g1tess::Result<Mesh> {
    Mesh::load(path.to_str().unwrap(), &LoadOptions::default())
}

proptest! {
    #![proptest_config(config(3000, "PROPTEST_CASES"))]
    #[test]
    fn obj_mutants(seed in any::<prop::sample::Index>(), edits in prop::collection::vec(edit(), 1..8)) {
        let seeds = seeds("obj");
        let bytes = apply(seed.get(&seeds).clone(), &edits);
        check(load(&scratch("mutant.obj", &bytes)))?;
    }
}

proptest! {
    #![proptest_config(config(2000, "PROPTEST_CASES"))]
    #[test]
    fn pn_mutants(seed in any::<prop::sample::Index>(), edits in prop::collection::vec(edit(), 1..8)) {
        let seeds = seeds("pn");
        let bytes = apply(seed.get(&seeds).clone(), &edits);
        check(load(&scratch("mutant.pn", &bytes)))?;
    }
}

proptest! {
    #![proptest_config(config(1000, "PROPTEST_CASES"))]
    #[test]
    fn ply_mutants(seed in any::<prop::sample::Index>(), edits in prop::collection::vec(edit(), 1..8)) {
        let seeds = seeds("ply");
        let bytes = apply(seed.get(&seeds).clone(), &edits);
        check(load(&scratch("mutant.ply", &bytes)))?;
    }
}

proptest! {
    #![proptest_config(config(800, "PROPTEST_CASES"))]
    #[test]
    fn stl_mutants(seed in any::<prop::sample::Index>(), edits in prop::collection::vec(edit(), 1..8)) {
        let seeds = seeds("stl");
        let bytes = apply(seed.get(&seeds).clone(), &edits);
        check(load(&scratch("mutant.stl", &bytes)))?;
    }
}

proptest! {
    #![proptest_config(config(700, "PROPTEST_CASES"))]
    #[test]
    fn gltf_mutants(seed in any::<prop::sample::Index>(), edits in prop::collection::vec(edit(), 1..8)) {
        let all: Vec<(Vec<u8>, &str)> = seeds("glb").into_iter().map(|s| (s, "glb"))
            .chain(seeds("gltf").into_iter().map(|s| (s, "gltf"))).collect();
        let (bytes, ext) = seed.get(&all);
        let bytes = apply(bytes.clone(), &edits);
        check(load(&scratch(&format!("mutant.{ext}"), &bytes)))?;
    }
}

fn spec() -> impl Strategy<Value = String> {
    let num = prop_oneof![
        (0u32..24).prop_map(|n| n.to_string()),
        Just(String::new()),
        Just("-3".to_string()),
        Just("2001".to_string()),
        Just("4294967296".to_string()),
        "[0-9x:.+-]{1,4}",
    ];
    let level = prop_oneof![
        (0u32..4).prop_map(|n| n.to_string()),
        Just("8".to_string()),
        Just("-1".to_string()),
        Just("99999999999".to_string()),
        "[0-9a-z:]{0,3}",
    ];
    prop_oneof![
        Just("sphere320".to_string()),
        Just("torus200".to_string()),
        level.prop_map(|l| format!("icosphere:{l}")),
        (
            num.clone(),
            num,
            prop::sample::select(vec![
                "",
                ":analytic",
                ":averaged",
                ":x",
                "::",
                ":analytic:1"
            ])
        )
            .prop_map(|(n, m, s)| format!("torus:{n}x{m}{s}")),
        "[a-z0-9:x]{0,14}",
    ]
}

proptest! {
    #![proptest_config(config(1500, "PROPTEST_CASES"))]
    #[test]
    fn spec_strings(s in spec()) {
        match g1tess::generators::from_spec(&s) {
            Ok(Some(m)) => check(Ok(m))?,
            Ok(None) => {}
            Err(e) => check(Err(e))?,
        }
    }
}

fn coordinate() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => (-4i32..5).prop_map(f64::from),
        2 => -2.0f64..2.0,
        1 => prop::sample::select(vec![
            0.0, -0.0, 1e75, -1e76, 1e300, 1e-320, 1e-80, f64::NAN, f64::INFINITY,
        ]),
    ]
}

proptest! {
    #![proptest_config(config(1000, "PROPTEST_CASES"))]
    #[test]
    fn soups(
        positions in prop::collection::vec([coordinate(), coordinate(), coordinate()], 0..8),
        triangles in prop::collection::vec([0u32..9, 0u32..9, 0u32..9], 0..10),
        normals in prop::option::of(prop::collection::vec([coordinate(), coordinate(), coordinate()], 0..8)),
    ) {
        let r = Mesh::from_soup("soup", &positions, &triangles, normals.as_deref(), &LoadOptions::default());
        check(r)?;
    }
}

/// One argument of a command line, possibly mutated.
#[cfg(feature = "cli")]
fn argument() -> impl Strategy<Value = Vec<String>> {
    let v =
        |xs: &[&str]| prop::sample::select(xs.iter().map(|s| s.to_string()).collect::<Vec<_>>());
    prop_oneof![
        v(&[
            "g1",
            "pn",
            "phong",
            "nagata",
            "nagata-guarded",
            "nlsa",
            "pn-normals",
            "flat",
            "G1",
            "",
            "g1,pn"
        ])
        .prop_map(|s| vec!["--scheme".into(), s]),
        v(&["0", "1", "2", "5", "-1", "x", "", "1e3"]).prop_map(|s| vec!["--level".into(), s]),
        v(&["angle", "area", "unweighted", "none"]).prop_map(|s| vec!["--normals".into(), s]),
        v(&["0", "30", "180", "-5", "nan", "1e999"]).prop_map(|s| vec!["--crease-angle".into(), s]),
        v(&["0.75", "0", "-1", "inf", "a"]).prop_map(|s| vec!["--phong-alpha".into(), s]),
        v(&["f32", "f64", "f16"]).prop_map(|s| vec!["--precision".into(), s]),
        v(&["--recompute-normals", "--json", "-q", "--bogus", "-", "--"]).prop_map(|s| vec![s]),
    ]
}

#[cfg(feature = "cli")]
fn run_cli(args: &[String]) -> Result<(), TestCaseError> {
    let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(args)
        .env("RUST_BACKTRACE", "1")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    prop_assert!(
        !stderr.contains("panicked") && !stderr.contains("backtrace"),
        "{args:?}: {stderr}"
    );
    match out.status.code() {
        Some(0) => {}
        Some(1) => {
            // The backend's information lines aside, one line: the error.
            let lines: Vec<&str> = stderr
                .lines()
                .filter(|l| !l.starts_with("gpu: ") && !l.starts_with("note: "))
                .collect();
            prop_assert_eq!(lines.len(), 1, "{:?}: {}", args, stderr);
            prop_assert!(lines[0].starts_with("error: "), "{args:?}: {stderr}");
        }
        // Usage errors from the argument parser: exit code 2, one line ending in a
        // pointer to --help.
        Some(2) => prop_assert!(
            stderr.starts_with("error: ")
                && stderr.trim_end().lines().count() == 1
                && stderr.trim_end().ends_with("--help')"),
            "{args:?}: {stderr}"
        ),
        code => prop_assert!(
            false,
            "{args:?}: exit {code:?} (killed by a signal?): {stderr}"
        ),
    }
    Ok(())
}

#[cfg(feature = "cli")]
proptest! {
    #![proptest_config(config(300, "FUZZ_CLI_CASES"))]
    #[test]
    fn command_lines(
        command in prop::sample::select(vec!["stats", "tessellate", "export-net"]),
        input in prop_oneof![
            3 => (any::<prop::sample::Index>(), prop::collection::vec(edit(), 0..6)).prop_map(|(i, e)| (Some((i, e)), String::new())),
            1 => prop::sample::select(vec!["sphere320", "icosphere:1", "torus:5x4", "torus:1x1", "/dev/zero", "no-such.obj", ""])
                .prop_map(|s| (None, s.to_string())),
        ],
        args in prop::collection::vec(argument(), 0..4),
        output in prop::sample::select(vec!["out.obj", "out.ply", "out.json", "out.xyz"]),
    ) {
        let mesh = match input {
            (Some((seed, edits)), _) => {
                let all: Vec<(Vec<u8>, &str)> = ["obj", "pn", "ply", "stl", "glb"]
                    .into_iter()
                    .flat_map(|ext| seeds(ext).into_iter().map(move |s| (s, ext)))
                    .collect();
                let (bytes, ext) = seed.get(&all);
                let p = scratch(&format!("cli-input.{ext}"), &apply(bytes.clone(), &edits));
                p.display().to_string()
            }
            (None, s) => s,
        };
        let mut argv: Vec<String> = vec![command.into(), mesh];
        // The CPU backend keeps each run short; the GPU path has tests of its own.
        if command != "export-net" {
            argv.extend(["--backend".into(), "cpu".into()]);
        }
        argv.extend(args.into_iter().flatten());
        if command != "stats" {
            let o = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz").join(output);
            let o = o.display().to_string();
            argv.extend(["-o".into(), o]);
        }
        run_cli(&argv)?;
    }
}
