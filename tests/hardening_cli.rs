//! The command line against hostile streams, arguments and names: a full stdout or stderr
//! ends in a clean exit status (no panic, no 101), a non-UTF-8 argument gets clap's usage
//! error, every line shows user-supplied names escaped (errors, notes, `wrote` lines,
//! summaries; JSON stays valid JSON holding the real name), a direction that cannot be
//! normalised is named as such, `bench --dir` names a missing folder, and f32 output warns
//! about (or refuses) coordinates below f32's normal range.

use std::ffi::{OsStr, OsString};
use std::os::unix::ffi::{OsStrExt, OsStringExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use proptest::prelude::*;

fn dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("hardening_cli")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn g1tess() -> Command {
    Command::new(env!("CARGO_BIN_EXE_g1tess"))
}

fn run<S: AsRef<OsStr>>(args: &[S]) -> Output {
    g1tess().args(args).output().unwrap()
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// The backend's information lines aside ("gpu: ADAPTER", the fallback's "note:").
fn own_lines(stderr: &[u8]) -> Vec<String> {
    text(stderr)
        .lines()
        .filter(|l| {
            !l.starts_with("gpu: ") && !l.contains("falling back") && !l.contains("software one")
        })
        .map(str::to_string)
        .collect()
}

/// No byte that drives a terminal: no control character but the newlines that end lines.
fn assert_no_controls(what: &str, bytes: &[u8]) {
    let s = text(bytes);
    let bad: Vec<char> = s
        .chars()
        .filter(|&c| c != '\n' && (c.is_control() || ('\u{202a}'..='\u{202e}').contains(&c)))
        .collect();
    assert!(bad.is_empty(), "{what} holds {bad:?}: {s:?}");
}

/// The octahedron with unit normals at its corners, every coordinate times `scale` (OBJ).
fn octahedron(scale: f64) -> String {
    let v = [
        [1, 0, 0],
        [-1, 0, 0],
        [0, 1, 0],
        [0, -1, 0],
        [0, 0, 1],
        [0, 0, -1],
    ];
    let f = [
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    let mut s = String::new();
    for p in v {
        s += &format!(
            "v {:e} {:e} {:e}\n",
            p[0] as f64 * scale,
            p[1] as f64 * scale,
            p[2] as f64 * scale
        );
    }
    for p in v {
        s += &format!("vn {} {} {}\n", p[0], p[1], p[2]);
    }
    for t in f {
        s += &format!(
            "f {0}//{0} {1}//{1} {2}//{2}\n",
            t[0] + 1,
            t[1] + 1,
            t[2] + 1
        );
    }
    s
}

fn write(d: &Path, name: impl AsRef<OsStr>, body: &str) -> PathBuf {
    let p = d.join(name.as_ref());
    std::fs::write(&p, body).unwrap();
    p
}

// ---- full streams ----

/// Runs `args` with stdout (or stderr) on /dev/full, which fails every write with ENOSPC.
fn into_full(args: &[&OsStr], stdout: bool) -> Output {
    let full = || {
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    let mut c = g1tess();
    c.args(args).stdin(Stdio::null());
    if stdout {
        c.stdout(full()).stderr(Stdio::piped());
    } else {
        c.stdout(Stdio::piped()).stderr(full());
    }
    c.output().unwrap()
}

fn os<'a>(args: &'a [&'a str]) -> Vec<&'a OsStr> {
    args.iter().map(OsStr::new).collect()
}

#[cfg(target_os = "linux")]
#[test]
fn full_stdout_ends_with_one_error_and_exit_1() {
    let d = dir("full_stdout");
    let obj = d.join("t.obj").display().to_string();
    let msh = d.join("t.msh").display().to_string();
    let cases: Vec<Vec<&str>> = vec![
        vec!["stats", "sphere320", "--backend", "cpu"],
        vec!["stats", "sphere320", "--backend", "cpu", "--json"],
        vec![
            "compare",
            "sphere320",
            "--schemes",
            "g1",
            "--backend",
            "cpu",
        ],
        vec![
            "compare",
            "sphere320",
            "--schemes",
            "g1",
            "--backend",
            "cpu",
            "--json",
        ],
        vec![
            "tessellate",
            "--json",
            "sphere320",
            "--level",
            "2",
            "--backend",
            "cpu",
            "-o",
            &obj,
        ],
        vec![
            "tessellate",
            "sphere320",
            "--level",
            "2",
            "--backend",
            "cpu",
            "-o",
            "-",
            "--format",
            "obj",
        ],
        vec![
            "export-msh",
            "sphere320",
            "--order",
            "2",
            "--json",
            "-o",
            &msh,
        ],
        vec!["--help"],
        vec!["--version"],
        vec!["stats", "--help"],
    ];
    for args in &cases {
        let out = into_full(&os(args), true);
        let err = own_lines(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err:?}");
        assert_eq!(err.len(), 1, "{args:?}: one line: {err:?}");
        // The writers of `-o -` name the stream "-"; the command line's own writes
        // "standard output".
        assert!(
            err[0] == "error: standard output: No space left on device (os error 28)"
                || err[0] == "error: -: No space left on device (os error 28)",
            "{args:?}: {err:?}"
        );
    }
}

#[cfg(target_os = "linux")]
#[test]
fn full_stderr_keeps_the_exit_status() {
    let d = dir("full_stderr");
    let bad = write(&d, "bad.obj", "v 0 0 0\nv 1 0 zero\nf 1 2 3\n");
    // A failure whose error line cannot be written still exits 1, not 101.
    let out = into_full(&[OsStr::new("stats"), bad.as_os_str()], false);
    assert_eq!(out.status.code(), Some(1));
    // A usage error: 2.
    let out = into_full(&os(&["stats", "--no-such-option"]), false);
    assert_eq!(out.status.code(), Some(2));
    let out = into_full(&os(&["stats"]), false);
    assert_eq!(out.status.code(), Some(2));
    // A run whose notes and `wrote` line cannot be written still succeeds and writes its
    // file (the lost lines are only information).
    let obj = d.join("t.obj");
    let out = into_full(
        &[
            OsStr::new("tessellate"),
            OsStr::new("sphere320"),
            OsStr::new("--level"),
            OsStr::new("2"),
            OsStr::new("-o"),
            obj.as_os_str(),
        ],
        false,
    );
    assert_eq!(out.status.code(), Some(0));
    assert!(std::fs::metadata(&obj).unwrap().len() > 0);
    // Its statistics still reach stdout.
    let out = into_full(&os(&["stats", "sphere320", "--backend", "cpu"]), false);
    assert_eq!(out.status.code(), Some(0));
    assert!(text(&out.stdout).starts_with("mesh sphere320 · scheme g1"));
}

// ---- arguments that are not UTF-8 ----

#[test]
fn non_utf8_arguments_get_a_usage_error() {
    let ff = OsStr::from_bytes(b"\xff");
    let obj = OsStr::from_bytes(b"m\xff.obj");
    for args in [
        vec![ff],
        vec![OsStr::new("stats"), obj],
        vec![OsStr::new("stats"), OsStr::new("sphere320"), ff],
        vec![OsStr::new("--quiet"), ff],
        vec![OsStr::new("compare"), OsStr::new("--schemes"), ff],
    ] {
        let out = run(&args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(
            err.starts_with("error: ") && err.trim_end().ends_with("--help')"),
            "{err}"
        );
    }
}

#[test]
fn a_non_utf8_output_name_is_written() {
    // Paths are OS strings: an output named with a byte that is not UTF-8 is a legal name.
    let d = dir("non_utf8_output");
    let o = d.join(OsStr::from_bytes(b"o\xff.obj"));
    let out = run(&[
        OsStr::new("tessellate"),
        OsStr::new("sphere320"),
        OsStr::new("--level"),
        OsStr::new("1"),
        OsStr::new("--backend"),
        OsStr::new("cpu"),
        OsStr::new("-o"),
        o.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(o.exists());
    let err = own_lines(&out.stderr);
    assert_eq!(err.len(), 1, "{err:?}");
    assert!(
        err[0].starts_with("wrote ") && err[0].contains("o\u{fffd}.obj: "),
        "{err:?}"
    );
}

// ---- hostile names ----

/// Names that would drive a terminal or forge a line if echoed raw.
const HOSTILE: [&str; 4] = [
    "bad\nname.obj",
    "red\u{1b}[31m.obj",
    "title\u{1b}]0;pwned\u{7}.obj",
    "fake\n error: fake.obj",
];

/// The name as the command line shows it: control characters as Rust escapes them.
fn shown(name: &str) -> String {
    name.chars()
        .flat_map(|c| {
            if c.is_control() || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}') {
                c.escape_default().collect::<Vec<_>>()
            } else {
                vec![c]
            }
        })
        .collect()
}

#[test]
fn error_lines_escape_names() {
    let d = dir("error_names");
    for name in HOSTILE {
        // A missing file, a built-in spec (not one), and a file that fails to parse.
        let missing = d.join(format!("missing-{name}"));
        let bad = write(&d, name, "v 0 0 0\nv 1 0 0\nv 0 1\nf 1 2 3\n");
        for arg in [missing.as_os_str(), OsStr::new(name), bad.as_os_str()] {
            let out = run(&[OsStr::new("stats"), arg]);
            assert_eq!(out.status.code(), Some(1), "{arg:?}");
            assert_no_controls("stderr", &out.stderr);
            let err = own_lines(&out.stderr);
            assert_eq!(err.len(), 1, "{err:?}");
            assert!(err[0].starts_with("error: "), "{err:?}");
            assert!(err[0].contains(&shown(name)), "{err:?}");
        }
    }
}

#[test]
fn usage_errors_escape_arguments() {
    for arg in ["--scheme=\u{1b}[31m", "--level=\n error: fake"] {
        let out = run(&["stats", "sphere320", arg]);
        assert_eq!(out.status.code(), Some(2));
        assert_no_controls("stderr", &out.stderr);
        assert_eq!(text(&out.stderr).lines().count(), 1);
    }
}

#[test]
fn notes_summaries_and_wrote_lines_escape_names() {
    let d = dir("names");
    // One face with texture coordinates, seven without: the reader's note (21 corners
    // given (0, 0)) names the mesh.
    let body = format!("vt 0 0\n{}", octahedron(1.0)).replacen(
        "f 1//1 3//3 5//5",
        "f 1/1/1 3/1/3 5/1/5",
        1,
    );
    assert!(body.contains("f 1/1/1"));
    for name in HOSTILE {
        let input = write(&d, name, &body);
        let output = d.join(format!("out-{name}"));
        let net = d.join(format!("net-{name}.json"));
        let msh = d.join(format!("msh-{name}.msh"));
        let input_os = input.as_os_str();
        let tess = run(&[
            OsStr::new("tessellate"),
            input_os,
            OsStr::new("--level"),
            OsStr::new("2"),
            OsStr::new("--backend"),
            OsStr::new("cpu"),
            OsStr::new("-o"),
            output.as_os_str(),
        ]);
        let export_net = run(&[
            OsStr::new("export-net"),
            input_os,
            OsStr::new("-o"),
            net.as_os_str(),
        ]);
        let export_msh = run(&[
            OsStr::new("export-msh"),
            input_os,
            OsStr::new("-o"),
            msh.as_os_str(),
        ]);
        for (out, written) in [(&tess, &output), (&export_net, &net), (&export_msh, &msh)] {
            assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
            assert!(written.exists(), "{written:?}");
            assert_no_controls("stderr", &out.stderr);
            let err = own_lines(&out.stderr);
            // The note and the `wrote` line, each on a line of its own.
            assert_eq!(err.len(), 2, "{err:?}");
            assert_eq!(
                err[0],
                format!(
                    "note: {}: 21 face corners without a texture coordinate: (0, 0) given",
                    shown(name)
                )
            );
            assert!(
                err[1].starts_with(&format!(
                    "wrote {}: ",
                    shown(&written.display().to_string())
                )),
                "{err:?}"
            );
        }
        // The statistics' text summary names the mesh escaped.
        let stats = run(&[
            OsStr::new("stats"),
            input_os,
            OsStr::new("--backend"),
            OsStr::new("cpu"),
        ]);
        assert_eq!(stats.status.code(), Some(0));
        assert_no_controls("stdout", &stats.stdout);
        assert!(
            text(&stats.stdout).starts_with(&format!("mesh {} · scheme g1 · ", shown(name))),
            "{}",
            text(&stats.stdout)
        );
        // Table 1's markdown too.
        let compare = run(&[
            OsStr::new("compare"),
            input_os,
            OsStr::new("--schemes"),
            OsStr::new("g1"),
            OsStr::new("--backend"),
            OsStr::new("cpu"),
        ]);
        assert_eq!(compare.status.code(), Some(0));
        assert_no_controls("stdout", &compare.stdout);
        assert!(text(&compare.stdout).starts_with(&format!("**{}** (", shown(name))));
    }
}

#[test]
fn json_holds_the_real_name_and_stays_valid() {
    let d = dir("json_names");
    for name in HOSTILE
        .iter()
        .copied()
        .chain(["c1\u{9b}31m\u{7f}\u{202e}.obj"])
    {
        let input = write(&d, name, &octahedron(1.0));
        let output = d.join(format!("out-{name}"));
        let stats = run(&[
            OsStr::new("stats"),
            input.as_os_str(),
            OsStr::new("--backend"),
            OsStr::new("cpu"),
            OsStr::new("--json"),
        ]);
        let tess = run(&[
            OsStr::new("tessellate"),
            input.as_os_str(),
            OsStr::new("--level"),
            OsStr::new("2"),
            OsStr::new("--backend"),
            OsStr::new("cpu"),
            OsStr::new("--json"),
            OsStr::new("-o"),
            output.as_os_str(),
        ]);
        for (out, key, value) in [
            (&stats, "mesh", name.to_string()),
            (&tess, "mesh", name.to_string()),
            (&tess, "output", output.display().to_string()),
        ] {
            assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
            assert_no_controls("stdout", &out.stdout);
            let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            assert_eq!(v[key], value.as_str());
        }
    }
}

#[test]
fn a_name_cannot_forge_lines_in_an_obj_file() {
    // The OBJ's comment names the mesh: a newline in the name must not start a vertex line.
    let d = dir("obj_title");
    let input = write(&d, "x\nv 9 9 9\nf 1 1 1\n.obj", &octahedron(1.0));
    let output = d.join("o.obj");
    let out = run(&[
        OsStr::new("tessellate"),
        input.as_os_str(),
        OsStr::new("--level"),
        OsStr::new("2"),
        OsStr::new("--backend"),
        OsStr::new("cpu"),
        OsStr::new("--json"),
        OsStr::new("-o"),
        output.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let obj = std::fs::read_to_string(&output).unwrap();
    let first = obj.lines().next().unwrap();
    assert!(
        first.starts_with("# g1tess: x\\nv 9 9 9\\nf 1 1 1\\n.obj, scheme g1"),
        "{first}"
    );
    // As many vertex and face lines as the summary counts: none forged.
    let count = |p: &str| obj.lines().filter(|l| l.starts_with(p)).count() as u64;
    assert_eq!(count("v "), v["vertices"].as_u64().unwrap());
    assert_eq!(count("f "), v["triangles"].as_u64().unwrap());
    assert!(!obj.contains("v 9 9 9\n"));
}

// ---- misleading messages ----

#[test]
fn a_direction_too_large_to_normalise_is_named() {
    for (option, value) in [
        ("--view", "1e308,1e308,1e308"),
        ("--view", "1e200,0,0"),
        ("--up", "1e-170,0,0"),
    ] {
        let out = run(&["render", "sphere320", "-o", "never.png", option, value]);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains("too large or too small to normalise"), "{err}");
        assert!(err.contains(option) && err.contains(value), "{err}");
        assert!(!err.contains("parallel"), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
    }
}

#[test]
fn bench_names_a_missing_dir() {
    let d = dir("bench_dir");
    let missing = d.join("missing");
    let file = write(&d, "file", "");
    for (path, cause) in [
        (&missing, "No such file or directory (os error 2)"),
        (&file, "not a directory"),
    ] {
        let out = run(&[
            OsStr::new("bench"),
            OsStr::new("--end-to-end"),
            OsStr::new("-q"),
            OsStr::new("--dir"),
            path.as_os_str(),
        ]);
        let err = own_lines(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err:?}");
        assert_eq!(err, [format!("error: --dir {}: {cause}", path.display())]);
    }
}

// ---- tiny scales ----

fn tessellate_scaled(d: &Path, scale: f64) -> (Output, PathBuf) {
    let input = write(d, format!("oct{scale:e}.obj"), &octahedron(scale));
    let output = d.join(format!("oct{scale:e}-out.obj"));
    let out = run(&[
        OsStr::new("tessellate"),
        input.as_os_str(),
        OsStr::new("--level"),
        OsStr::new("2"),
        OsStr::new("--backend"),
        OsStr::new("cpu"),
        OsStr::new("-o"),
        output.as_os_str(),
    ]);
    (out, output)
}

#[test]
fn tiny_scales_warn_or_refuse() {
    let d = dir("tiny");
    // 1e-40 is below f32's normal range (2^-126 = 1.18e-38): f32 keeps a step of 2^-149 =
    // 1.4e-45, 1.4e-5 of 1e-40.
    let (out, written) = tessellate_scaled(&d, 1e-40);
    assert_eq!(out.status.code(), Some(0));
    let err = own_lines(&out.stderr);
    assert_eq!(err.len(), 2, "{err:?}");
    assert_eq!(
        err[0],
        "note: oct1e-40.obj: coordinates are at most 1.0e-40, below f32's normal range \
         (1.2e-38): f32 keeps steps of 1.4e-45, 1.4e-5 of the largest coordinate (about 4.9 \
         significant digits instead of 7.2); scale the mesh up for full precision"
    );
    // The corners are surface points (every scheme interpolates them): the file holds the
    // f32 nearest 1e-40, within half a step, 2^-150.
    let obj = std::fs::read_to_string(&written).unwrap();
    let largest = obj
        .lines()
        .filter(|l| l.starts_with("v "))
        .flat_map(|l| {
            l[2..]
                .split(' ')
                .map(|x| x.parse::<f64>().unwrap())
                .collect::<Vec<_>>()
        })
        .fold(0.0f64, |m, x| m.max(x.abs()));
    assert!((largest - 1e-40).abs() <= 2f64.powi(-150), "{largest:e}");

    // 1e-50 rounds to 0 in f32: every vertex would be 0 0 0; refused, nothing written.
    let (out, written) = tessellate_scaled(&d, 1e-50);
    assert_eq!(out.status.code(), Some(1));
    let err = own_lines(&out.stderr);
    assert_eq!(err.len(), 1, "{err:?}");
    assert!(
        err[0].starts_with(
            "error: oct1e-50.obj: every coordinate rounds to 0 in f32 (the largest is 1.0e-50"
        ),
        "{err:?}"
    );
    assert!(!written.exists());

    // Inside f32's normal range (1e-30 > 1.2e-38) and at ordinary scales: no note.
    for scale in [1e-30, 1.0] {
        let (out, _) = tessellate_scaled(&d, scale);
        assert_eq!(out.status.code(), Some(0));
        let err = own_lines(&out.stderr);
        assert_eq!(err.len(), 1, "{err:?}");
        assert!(err[0].starts_with("wrote "), "{err:?}");
    }
}

// ---- output paths (scripts/fuzz.sh runs more cases) ----

/// A hostile output path for a writing command, made in `d` (symlinks, directories, a file
/// in the way are created first).
#[derive(Clone, Debug)]
enum OutPath {
    /// A plain name with `insert` spliced in at `at` (newlines, escapes, bidi overrides, a
    /// byte that is not UTF-8, a slash).
    Spliced(Vec<u8>, usize),
    /// A name of `n` bytes (255 is the usual limit of a name).
    Long(usize),
    /// A symlink to a file, to a directory, or to nothing.
    Link(u8),
    /// An existing directory, or the name with a trailing slash.
    Dir(bool),
    /// A name below a regular file.
    UnderFile,
}

fn out_path() -> impl Strategy<Value = OutPath> {
    let insert = prop::sample::select(vec![
        b"\n".to_vec(),
        b"\r".to_vec(),
        b"\x1b[31m".to_vec(),
        b"\x1b]0;x\x07".to_vec(),
        b"\nwrote fake.obj".to_vec(),
        "\u{202e}".as_bytes().to_vec(),
        "\u{9b}2J".as_bytes().to_vec(),
        b"\xff".to_vec(),
        b"sub/".to_vec(),
        b" ".to_vec(),
        b"-".to_vec(),
    ]);
    prop_oneof![
        4 => (insert, 0usize..6).prop_map(|(i, at)| OutPath::Spliced(i, at)),
        2 => prop::sample::select(vec![1usize, 200, 250, 251, 255, 256, 400]).prop_map(OutPath::Long),
        2 => (0u8..3).prop_map(OutPath::Link),
        1 => any::<bool>().prop_map(OutPath::Dir),
        1 => Just(OutPath::UnderFile),
    ]
}

/// Makes the path of `kind` for an output with extension `ext` in `d`.
fn make_out_path(d: &Path, kind: &OutPath, ext: &str) -> PathBuf {
    match kind {
        OutPath::Spliced(insert, at) => {
            let mut name = b"outname".to_vec();
            let at = (*at).min(name.len());
            name.splice(at..at, insert.iter().copied());
            name.extend_from_slice(format!(".{ext}").as_bytes());
            d.join(OsString::from_vec(name))
        }
        OutPath::Long(n) => {
            let stem = "x".repeat(n.saturating_sub(ext.len() + 1).max(1));
            d.join(format!("{stem}.{ext}"))
        }
        OutPath::Link(k) => {
            let link = d.join(format!("link.{ext}"));
            let target = match k {
                0 => write(d, format!("target.{ext}"), "old"),
                1 => {
                    let t = d.join("target-dir");
                    std::fs::create_dir_all(&t).unwrap();
                    t
                }
                _ => d.join("nothing-here"),
            };
            std::os::unix::fs::symlink(target, &link).unwrap();
            link
        }
        OutPath::Dir(existing) => {
            let p = d.join(format!("dir.{ext}"));
            if *existing {
                std::fs::create_dir_all(&p).unwrap();
                p
            } else {
                PathBuf::from(format!("{}/", p.display()))
            }
        }
        OutPath::UnderFile => write(d, "file", "").join(format!("x.{ext}")),
    }
}

/// Every entry of `d`, recursively, by name.
fn entries(d: &Path) -> Vec<PathBuf> {
    let mut all = Vec::new();
    for e in std::fs::read_dir(d).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() && !p.is_symlink() {
            all.extend(entries(&p));
        }
        all.push(p);
    }
    all.sort();
    all
}

fn output_case(n: u64, command: &str, ext: &str, kind: &OutPath) -> Result<(), TestCaseError> {
    let d = dir(&format!("out_paths/{n}"));
    let output = make_out_path(&d, kind, ext);
    let before = entries(&d);
    let mut args: Vec<OsString> = vec![command.into(), "icosphere:1".into()];
    if command == "tessellate" {
        args.extend([
            "--level".into(),
            "2".into(),
            "--backend".into(),
            "cpu".into(),
        ]);
    }
    args.extend(["-o".into(), output.clone().into_os_string()]);
    let out = g1tess()
        .args(&args)
        .env("RUST_BACKTRACE", "1")
        .output()
        .unwrap();
    let err = text(&out.stderr);
    prop_assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert_no_controls("stderr", &out.stderr);
    let lines = own_lines(&out.stderr);
    match out.status.code() {
        Some(0) => {
            prop_assert_eq!(lines.len(), 1, "{:?}: {:?}", args, lines);
            let name = output.to_string_lossy();
            prop_assert!(
                lines[0].starts_with(&format!("wrote {}: ", shown(&name))),
                "{args:?}: {lines:?}"
            );
            prop_assert!(std::fs::metadata(&output).is_ok_and(|m| m.is_file() && m.len() > 0));
        }
        Some(1) => {
            prop_assert_eq!(lines.len(), 1, "{:?}: {:?}", args, lines);
            prop_assert!(lines[0].starts_with("error: "), "{args:?}: {lines:?}");
        }
        Some(2) => prop_assert!(
            lines.len() == 1 && lines[0].ends_with("--help')"),
            "{args:?}: {lines:?}"
        ),
        code => prop_assert!(false, "{args:?}: exit {code:?}: {err}"),
    }
    // Nothing left behind but the output (or what its symlink points at): no temporary
    // file, whether the run succeeded or not.
    let target = std::fs::canonicalize(&output).ok();
    let extra: Vec<PathBuf> = entries(&d)
        .into_iter()
        .filter(|p| !before.contains(p) && *p != output && std::fs::canonicalize(p).ok() != target)
        .collect();
    prop_assert!(extra.is_empty(), "{args:?}: left {extra:?}");
    Ok(())
}

fn path_cases() -> u32 {
    std::env::var("FUZZ_OUTPUT_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(24)
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: path_cases(),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]
    #[test]
    fn output_path_mutants(
        (command, ext) in prop::sample::select(vec![
            ("tessellate", "obj"),
            ("tessellate", "ply"),
            ("tessellate", "stl"),
            ("tessellate", "glb"),
            ("export-net", "json"),
            ("export-msh", "msh"),
        ]),
        kind in out_path(),
        n in any::<u64>(),
    ) {
        output_case(n, command, ext, &kind)?;
    }
}
