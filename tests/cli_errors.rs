//! Every bad input gets a one-line error naming the file and the problem, a non-zero exit,
//! and no panic.

use std::path::PathBuf;
use std::process::Command;

fn tmp(name: &str, text: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli_errors");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs `g1tess stats FILE` and returns stderr, asserting failure without a panic.
fn fails(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(args)
        .output()
        .unwrap();
    // Drop the backend's information lines ("gpu: ADAPTER", "note: ... falling back").
    let err: String = String::from_utf8_lossy(&out.stderr)
        .lines()
        .filter(|l| !l.starts_with("gpu: ") && !l.starts_with("note: "))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(!out.status.success(), "{args:?} should fail");
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.starts_with("error: "), "{err}");
    err
}

fn stats_error(name: &str, text: &str) -> (String, String) {
    let p = tmp(name, text);
    let err = fails(&["stats", p.to_str().unwrap()]);
    assert!(err.contains(name), "names the file: {err}");
    (err, p.display().to_string())
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

#[test]
fn missing_file() {
    let err = fails(&["stats", "no/such/mesh.obj"]);
    assert!(
        err.contains("no/such/mesh.obj") && err.contains("no such file"),
        "{err}"
    );
}

#[test]
fn parse_error_names_the_line() {
    let (err, p) = stats_error("parse.obj", "v 0 0 0\nv 1 0 0\nv 0 one 0\nf 1 2 3\n");
    assert!(err.contains(&format!("{p}:3:")), "{err}");
    assert!(err.contains("'one' is not a number"), "{err}");
    let (err, p) = stats_error("short.obj", "v 0 0\n");
    assert!(
        err.contains(&format!("{p}:1:")) && err.contains("needs 3 numbers"),
        "{err}"
    );
    let (err, _) = stats_error("corner.obj", &format!("{TRI}f 1 2\n"));
    assert!(
        err.contains(":4:") && err.contains("at least 3 corners"),
        "{err}"
    );
    let (err, _) = stats_error("slash.obj", &format!("{TRI}f 1/2/3/4 2 3\n"));
    assert!(
        err.contains(":4:") && err.contains("malformed face corner"),
        "{err}"
    );
}

#[test]
fn index_out_of_range() {
    let (err, p) = stats_error("range.obj", &format!("{TRI}f 1 2 4\n"));
    assert!(err.contains(&format!("{p}:4:")), "{err}");
    assert!(err.contains("vertex index 4 out of range"), "{err}");
    let (err, _) = stats_error("negative.obj", &format!("{TRI}f -1 -2 -4\n"));
    assert!(
        err.contains(":4:") && err.contains("index -4 out of range"),
        "{err}"
    );
    let (err, _) = stats_error("zero.obj", &format!("{TRI}f 0 1 2\n"));
    assert!(err.contains(":4:") && err.contains("index 0"), "{err}");
    let (err, _) = stats_error("normal.obj", &format!("{TRI}vn 0 0 1\nf 1//1 2//1 3//2\n"));
    assert!(
        err.contains(":5:") && err.contains("normal index 2 out of range"),
        "{err}"
    );
}

#[test]
fn non_finite_coordinates() {
    for (name, bad) in [("nan.obj", "nan"), ("inf.obj", "inf"), ("big.obj", "1e999")] {
        let (err, _) = stats_error(name, &format!("v 0 0 0\nv 1 0 {bad}\nv 0 1 0\nf 1 2 3\n"));
        assert!(
            err.contains(":2:") && err.contains("non-finite coordinate"),
            "{err}"
        );
    }
}

#[test]
fn zero_normals() {
    let (err, _) = stats_error("zeron.obj", &format!("{TRI}vn 0 0 0\nf 1//1 2//1 3//1\n"));
    assert!(
        err.contains(":4:") && err.contains("zero-length normal"),
        "{err}"
    );
}

#[test]
fn empty_mesh() {
    let (err, _) = stats_error("empty.obj", "# nothing here\n");
    assert!(err.contains("empty mesh"), "{err}");
    let (err, _) = stats_error("points.obj", TRI);
    assert!(err.contains("empty mesh"), "{err}");
    let (err, _) = stats_error("degenerate.obj", &format!("{TRI}f 1 1 2\n"));
    assert!(
        err.contains("empty mesh") && err.contains("degenerate"),
        "{err}"
    );
}

#[test]
fn not_utf8() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli_errors");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("binary.obj");
    std::fs::write(&p, b"v 0 0 0\n\xff\xfe\n").unwrap();
    let err = fails(&["stats", p.to_str().unwrap()]);
    assert!(err.contains(":2:") && err.contains("not UTF-8"), "{err}");
}

#[test]
fn bad_builtin_and_arguments() {
    let err = fails(&["stats", "icosphere:x"]);
    assert!(err.contains("bad built-in mesh 'icosphere:x'"), "{err}");
    let err = fails(&["stats", "torus:3"]);
    assert!(err.contains("torus:NxM"), "{err}");
    let err = fails(&["tessellate", "sphere320", "--level", "0", "-o", "x.obj"]);
    assert!(err.contains("--level"), "{err}");
}

#[test]
fn unwritable_output_is_an_error_not_a_panic() {
    let err = fails(&[
        "tessellate",
        "sphere320",
        "--level",
        "2",
        "-o",
        "/nonexistent-dir/out.obj",
    ]);
    assert!(err.contains("/nonexistent-dir/out.obj"), "{err}");
}

#[test]
fn stats_json_has_the_documented_fields() {
    let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(["stats", "sphere320", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "mesh",
        "scheme",
        "triangles",
        "interior_edges",
        "boundary_edges",
        "nonmanifold_edges",
        "samples",
        "cos",
        "max_one_minus_abs_cos",
        "max_gap",
        "folded",
        "backend",
    ] {
        assert!(v.get(key).is_some(), "missing {key}: {v}");
    }
    for key in ["min", "max", "mean", "std"] {
        assert!(v["cos"][key].is_f64(), "cos.{key}");
    }
    assert_eq!(v["triangles"], 320);
    assert_eq!(v["interior_edges"], 480);
    assert_eq!(v["samples"], 480 * 21);
    // G1 to f64 rounding (~1e-16); 1e-12 is far above that and far below any real kink.
    assert!(1.0 - v["cos"]["min"].as_f64().unwrap() <= 1e-12);
}

#[test]
fn tessellate_writes_a_readable_obj() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli_tess");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("sphere.obj");
    let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args([
            "tessellate",
            "sphere320",
            "--level",
            "4",
            "-o",
            p.to_str().unwrap(),
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    let nv = text.lines().filter(|l| l.starts_with("v ")).count();
    let nf = text.lines().filter(|l| l.starts_with("f ")).count();
    assert_eq!(v["vertices"].as_u64().unwrap() as usize, nv);
    assert_eq!(v["triangles"].as_u64().unwrap() as usize, nf);
    assert_eq!(nf, 320 * 16);
    // Every written point lies within the G1 sphere's accuracy of the unit sphere.
    for l in text.lines().filter(|l| l.starts_with("v ")) {
        let c: Vec<f64> = l[2..].split(' ').map(|x| x.parse().unwrap()).collect();
        let r = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        // 2e-4: ten times the G1 sphere320's mean distance to the unit sphere (2.0e-5,
        // README), room for its largest deviation at a sample.
        assert!((r - 1.0).abs() < 2e-4, "{l}");
    }
}

#[test]
fn devices_and_endless_lines_are_refused_in_one_line() {
    // /dev/zero never ends and holds no newline: refused before reading, exit 1.
    let err = fails(&["stats", "/dev/zero"]);
    assert!(err.contains("/dev/zero: not a regular file"), "{err}");
    // The same through a link named like a glTF file: the memory estimate, which reads a
    // glTF scene's JSON before the load, leaves it to the loader's refusal.
    let link = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli_errors-zero.gltf");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
    let err = fails(&["stats", link.to_str().unwrap()]);
    assert!(err.contains("zero.gltf: not a regular file"), "{err}");
    let p = tmp("zeros.obj", &"\0".repeat(3 << 20));
    let err = fails(&["stats", p.to_str().unwrap()]);
    assert!(
        err.contains("zeros.obj:1: line longer than 1 MiB: not a mesh file"),
        "{err}"
    );
    // A huge normal is a direction like any other; collinear faces are dropped and counted.
    let p = tmp(
        "huge-normal.obj",
        &format!("{TRI}v 2 0 0\nvn 1e300 1e300 0\nf 1//1 2//1 3//1\nf 1 2 4\n"),
    );
    let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(["stats", p.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("\"triangles\":1,"), "{text}");
    assert!(
        text.contains("\"degenerate_triangles_dropped\":1,"),
        "{text}"
    );
}

/// Runs g1tess and returns (exit code, stderr).
fn run_code(args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn usage_errors_are_one_line_with_exit_code_2() {
    let cases: [(&[&str], &[&str]); 5] = [
        (
            &["stats", "--frobnicate"],
            &[
                "unexpected argument '--frobnicate'",
                "'g1tess stats --help'",
            ],
        ),
        (&["stats"], &["<MESH>", "'g1tess stats --help'"]),
        (
            &["tessellate", "x.obj", "--level", "abc"],
            &[
                "invalid value 'abc' for '--level",
                "'g1tess tessellate --help'",
            ],
        ),
        (
            &["stats", "x", "--scheme", "foo"],
            &["invalid value 'foo'", "possible values: g1,"],
        ),
        (
            &["frob"],
            &["unrecognized subcommand 'frob'", "'g1tess --help'"],
        ),
    ];
    for (args, wanted) in cases {
        let (code, err) = run_code(args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert_eq!(
            err.trim_end().lines().count(),
            1,
            "{args:?}: one line: {err}"
        );
        assert!(err.starts_with("error: "), "{err}");
        for w in wanted {
            assert!(err.contains(w), "{args:?}: {w:?} in {err}");
        }
    }
    // A long argument is echoed cut to 80 characters.
    let long = "9".repeat(5000);
    let (code, err) = run_code(&["tessellate", "x.obj", "--level", &format!("x{long}")]);
    assert_eq!(code, Some(2));
    assert!(err.len() < 300 && err.contains('…'), "{err}");
}

#[test]
fn every_evaluating_command_refuses_work_over_the_memory_budget() {
    // (arguments, what the refusal names). Each is refused before it allocates: the
    // built-in torus is 8 M triangles (about 1.2 GiB to load); the study's grid at level
    // 100000 holds 5 G points.
    let cases: [(&[&str], &str); 5] = [
        (
            &["stats", "torus:2000x2000", "--max-memory", "100M"],
            "stats: loading torus:2000x2000 needs about 1.2 GiB",
        ),
        (
            &[
                "compare",
                "sphere320",
                "torus:2000x2000",
                "--max-memory",
                "100M",
            ],
            "compare: loading torus:2000x2000 needs",
        ),
        (
            &["sweep", "--level", "100000", "-q", "-o", "unused-sweep-dir"],
            "sweep: the distance study at level 100000 needs about 2.1 TiB",
        ),
        (
            &["--max-memory", "10M", "-q"],
            "the default run: the distance study at level 16 needs",
        ),
        (
            &["stats", "sphere320", "--max-memory", "1M"],
            "over the memory budget of 1.0 MiB (--max-memory)",
        ),
    ];
    for (args, wanted) in cases {
        let (code, err) = run_code(args);
        assert_eq!(code, Some(1), "{args:?}: {err}");
        assert_eq!(
            err.trim_end().lines().count(),
            1,
            "{args:?}: one line: {err}"
        );
        assert!(err.contains(wanted), "{args:?}: {wanted:?} in {err}");
        assert!(err.contains("(--max-memory)"), "{err}");
    }
    assert!(!std::path::Path::new("unused-sweep-dir").exists());
}

#[test]
fn an_instanced_gltf_scene_is_sized_by_what_it_instances_not_by_its_file() {
    // One mesh of a 100 x 100 grid (10,201 vertices, 60,000 index entries, 280 KB) placed
    // by 1,000 nodes: a 300 KB file that loads as 10.2 M vertices and 20 M triangles. Sized
    // by the file (6 bytes per byte) it would pass a 1 GiB budget and then allocate
    // gigabytes; counted from the scene it is refused before anything is read:
    // 10,201,000 x 128 + 60,000,000 x 92 bytes + 32 MiB = 6.39 GiB.
    let n = 100u32;
    let mut bin = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            for x in [i as f32 / n as f32, j as f32 / n as f32, 0.0] {
                bin.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    let positions = bin.len();
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            for v in [a, a + 1, a + n + 2, a, a + n + 2, a + n + 1] {
                bin.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli_errors-instanced");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("grid.bin"), &bin).unwrap();
    let nodes: Vec<String> = (0..1000)
        .map(|k| format!(r#"{{"mesh":0,"translation":[{},0,0]}}"#, 2 * k))
        .collect();
    let scene: Vec<String> = (0..1000).map(|k| k.to_string()).collect();
    let gltf = format!(
        r#"{{"asset":{{"version":"2.0"}},
        "buffers":[{{"uri":"grid.bin","byteLength":{}}}],
        "bufferViews":[{{"buffer":0,"byteLength":{positions}}},
                       {{"buffer":0,"byteOffset":{positions},"byteLength":{}}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":10201,"type":"VEC3",
                       "min":[0,0,0],"max":[1,1,0]}},
                     {{"bufferView":1,"componentType":5125,"count":60000,"type":"SCALAR"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "nodes":[{}],"scenes":[{{"nodes":[{}]}}],"scene":0}}"#,
        bin.len(),
        bin.len() - positions,
        nodes.join(","),
        scene.join(",")
    );
    let path = dir.join("instanced.gltf");
    std::fs::write(&path, gltf).unwrap();
    let (code, err) = run_code(&["stats", path.to_str().unwrap(), "--max-memory", "1G"]);
    assert_eq!(code, Some(1), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(
        err.contains("instanced.gltf needs about 6.4 GiB (estimated)")
            && err.contains("(--max-memory)"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_closed_standard_output_ends_quietly_without_a_panic() {
    // `g1tess tessellate … -o - | head -c 100`: the reader goes away; the writer must end
    // (SIGPIPE, as other Unix tools) rather than panic on the failed write.
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args([
            "tessellate",
            "sphere320",
            "--level",
            "64",
            "-o",
            "-",
            "--format",
            "obj",
        ])
        .arg("-q")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = child.stdout.take().unwrap();
    let mut first = [0u8; 100];
    std::io::Read::read_exact(&mut out, &mut first).unwrap();
    drop(out);
    let result = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert!(!result.status.success());
    use std::os::unix::process::ExitStatusExt;
    assert_eq!(result.status.signal(), Some(13), "SIGPIPE: {err}");
}

/// clap's tip survives the one-line usage error: a misspelt option names the one meant.
#[test]
fn a_misspelt_option_gets_clap_s_suggestion_on_its_one_line() {
    let (code, err) = run_code(&["tessellate", "m.obj", "--tolerence", "1e-3"]);
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    for w in [
        "error: unexpected argument '--tolerence' found",
        "tip: a similar argument exists: '--tolerance'",
        "(see 'g1tess tessellate --help')",
    ] {
        assert!(err.contains(w), "{w:?} in {err}");
    }
}

/// Every numeric option takes a negative number as its value (not as an unknown option)
/// and refuses it with its range: the command's own check (exit 1) for real numbers and
/// sizes read as text, the value parser's (exit 2, a usage error) for whole numbers.
#[test]
fn negative_values_of_numeric_options_get_the_range_message() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli_errors_negative");
    std::fs::create_dir_all(&dir).unwrap();
    let out = |name: &str| dir.join(name).display().to_string();
    let (ply, msh, png, sweep) = (out("n.ply"), out("n.msh"), out("n.png"), out("sweep"));
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    let cases: Vec<(Vec<String>, i32, &str)> = vec![
        (
            s(&["tessellate", "sphere320", "--tolerance", "-1", "-o", &ply]),
            1,
            "--tolerance and --tolerance-rel take a positive distance (got -1)",
        ),
        (
            s(&[
                "tessellate",
                "sphere320",
                "--tolerance-rel",
                "-1e-3",
                "-o",
                &ply,
            ]),
            1,
            "take a positive distance (got -0.001)",
        ),
        (
            s(&["tessellate", "sphere320", "--tolerance", "-inf", "-o", &ply]),
            1,
            "take a positive distance (got -inf)",
        ),
        (
            s(&["tessellate", "sphere320", "--level", "-1", "-o", &ply]),
            2,
            "invalid value '-1' for '--level <LEVEL>': must be at least 1",
        ),
        (
            s(&[
                "tessellate",
                "sphere320",
                "--tolerance",
                "1e-3",
                "--max-level",
                "-3",
                "-o",
                &ply,
            ]),
            2,
            "invalid value '-3' for '--max-level <N>': must be 1 to 4096",
        ),
        (
            s(&["stats", "sphere320", "--crease-angle", "-5"]),
            1,
            "the crease angle must be between 0 and 180 degrees, got -5",
        ),
        (
            s(&["stats", "sphere320", "--max-memory", "-1"]),
            2,
            "'-1' is out of range (1 byte to 16 EiB)",
        ),
        (
            s(&["export-msh", "sphere320", "--order", "-1", "-o", &msh]),
            2,
            "invalid value '-1' for '--order <ORDER>': must be 1 to 5",
        ),
        (
            s(&["render", "sphere320", "--size", "-16", "-o", &png]),
            2,
            "invalid value '-16' for '--size <SIZE>': must be 16 to 4096",
        ),
        (
            s(&["render", "sphere320", "--level", "-2", "-o", &png]),
            2,
            "invalid value '-2' for '--level <LEVEL>': must be at least 1",
        ),
        // Negative components of a direction are values too (checked before any device).
        (
            s(&[
                "render",
                "sphere320",
                "--view",
                "-1,0,0",
                "--up",
                "-2,0,0",
                "-o",
                &png,
            ]),
            1,
            "--view -1,0,0 is parallel to --up -2,0,0",
        ),
        (
            s(&["sweep", "--level", "-1", "-o", &sweep]),
            2,
            "invalid value '-1' for '--level <LEVEL>': must be at least 1",
        ),
        // What was refused before stays refused in the same words.
        (
            s(&["tessellate", "sphere320", "--level", "0", "-o", &ply]),
            1,
            "--level must be at least 1",
        ),
    ];
    for (args, code, wanted) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (got, err) = run_code(&args);
        let err: String = err
            .lines()
            .filter(|l| !l.starts_with("gpu: ") && !l.starts_with("note: "))
            .collect();
        assert_eq!(got, Some(code), "{args:?}: {err}");
        assert!(!err.contains("unexpected argument"), "{args:?}: {err}");
        assert!(
            err.starts_with("error: ") && err.contains(wanted),
            "{args:?}: {err}"
        );
    }
    // Phong's shape factor is any finite number: a negative one is used, not refused.
    let (got, err) = run_code(&[
        "stats",
        "icosphere:0",
        "--scheme",
        "phong",
        "--phong-alpha",
        "-0.5",
        "--backend",
        "cpu",
    ]);
    assert_eq!(got, Some(0), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Every command's help names the formats the readers read, and says what the CPU backend
/// evaluates in (f64, except tessellate's f32 grid kernel), not that it is always f64.
#[test]
fn help_lists_the_formats_read_and_the_cpu_precision() {
    for cmd in [
        "tessellate",
        "stats",
        "export-net",
        "export-msh",
        "render",
        "compare",
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
            .args([cmd, "--help"])
            .output()
            .unwrap();
        assert!(out.status.success(), "{cmd}");
        let help = String::from_utf8_lossy(&out.stdout);
        assert!(help.contains("OBJ, PLY, STL, glTF"), "{cmd}: {help}");
        assert!(help.contains(".pn"), "{cmd}: {help}");
        assert!(!help.contains(".obj, or .pn"), "{cmd}: {help}");
        if cmd != "export-net" && cmd != "export-msh" {
            assert!(!help.contains("the CPU is always f64"), "{cmd}: {help}");
            assert!(
                !help.contains("The f64 CPU reference (rayon"),
                "{cmd}: {help}"
            );
            assert!(help.contains("f32 SIMD kernel"), "{cmd}: {help}");
        }
    }
}
