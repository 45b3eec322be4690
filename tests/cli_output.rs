//! Command-line outputs under hostile conditions: the memory budget, interrupts,
//! non-regular and aliased outputs, symbolic links, standard output, non-finite values,
//! `--schemes` lists and `--quiet`. Expected errors are printed with the prefix
//! "expected error: " so that a passing run's log cannot be mistaken for a failure.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::common;

const ONE_TRIANGLE: &str =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\nf 1//1 2//2 3//3\n";

fn bin() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_g1tess"));
    cmd.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    cmd
}

/// A fresh, empty folder for one test.
fn dir(name: &str) -> PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-cli-output-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().unwrap()
}

/// Asserts a one-line refusal with exit status 1 containing every one of `needles`, and
/// prints it as an expected error.
fn expect_error(out: &Output, needles: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).trim().to_string();
    assert_eq!(
        out.status.code(),
        Some(1),
        "status {:?}: {stderr}",
        out.status
    );
    let lines: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(lines.len(), 1, "one error line: {stderr}");
    for n in needles {
        assert!(lines[0].contains(n), "{n:?} not in {stderr}");
    }
    eprintln!("expected error: {}", lines[0].trim_start_matches("error: "));
    lines[0].to_string()
}

/// Names in `d`, sorted.
fn listing(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn one_triangle(d: &Path) -> String {
    let p = d.join("one.obj");
    std::fs::write(&p, ONE_TRIANGLE).unwrap();
    p.to_string_lossy().into_owned()
}

#[test]
fn memory_budget_refuses_before_allocating() {
    let d = dir("budget");
    let mesh = one_triangle(&d);
    let ply = d.join("o.ply");
    // Level 5000 on one triangle: 12.5 M samples per patch; the estimate is ~3.8 GiB
    // (measured peak 3.7 GiB), far over 1 GiB.
    let out = run(&[
        "tessellate",
        &mesh,
        "--level",
        "5000",
        "-o",
        ply.to_str().unwrap(),
        "--max-memory",
        "1G",
    ]);
    expect_error(
        &out,
        &[
            "tessellate: level 5000 needs about",
            "over the memory budget of 1.0 GiB (--max-memory)",
        ],
    );
    // Level 65536 to OBJ: 2.1 G samples in one patch, hundreds of GiB.
    let obj = d.join("o.obj");
    let out = run(&[
        "tessellate",
        &mesh,
        "--level",
        "65536",
        "-o",
        obj.to_str().unwrap(),
        "--max-memory",
        "64G",
    ]);
    expect_error(
        &out,
        &["level 65536", "2.1 G samples per patch", "--max-memory"],
    );
    // The largest level: 2^32 (2^32 + 1)/2 samples per patch overflows 64 bits, so the
    // count saturates (2^63 − 1: 9223372036.9 G) rather than wrapping to 2^31 (2.1 G).
    let out = run(&[
        "tessellate",
        &mesh,
        "--level",
        "4294967295",
        "-o",
        obj.to_str().unwrap(),
    ]);
    expect_error(
        &out,
        &[
            "level 4294967295",
            "9223372036.9 G samples per patch",
            "--max-memory",
        ],
    );
    // The bandwidth buffer of bench: 100000 MiB = 97.7 GiB.
    let out = run(&[
        "bench",
        "--bandwidth-mib",
        "100000",
        "--max-memory",
        "8G",
        "-q",
    ]);
    expect_error(
        &out,
        &[
            "bench: --bandwidth-mib 100000 needs about 97.7 GiB",
            "8.0 GiB",
        ],
    );
    // export-net: the bunny's patches of 18 control points need megabytes, over 1 MiB.
    let json = d.join("n.json");
    let out = run(&[
        "export-net",
        &common::shared_spec("stanford-bunny.obj"),
        "-o",
        json.to_str().unwrap(),
        "--max-memory",
        "1M",
    ]);
    expect_error(
        &out,
        &["export-net:", "patches needs about", "--max-memory"],
    );
    assert_eq!(listing(&d), ["one.obj"], "nothing written");
    // A bad size is refused by the parser.
    let out = run(&["tessellate", &mesh, "-o", "x.ply", "--max-memory", "8Q"]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("'8Q' is not a size"), "{stderr}");
    eprintln!("expected error: {}", stderr.lines().next().unwrap_or(""));
    // Within the budget the run goes through: level 300 on one triangle is ~14 MiB.
    let out = run(&[
        "tessellate",
        &mesh,
        "--level",
        "300",
        "-o",
        ply.to_str().unwrap(),
        "--max-memory",
        "64M",
        "--backend",
        "cpu",
        "-q",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.stderr.is_empty(), "-q prints nothing");
    let bytes = std::fs::read(&ply).unwrap();
    // 301·302/2 vertex records of 24 bytes and 300² faces of 13 bytes after the header.
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    assert_eq!(bytes.len() - header_end, 45451 * 24 + 90000 * 13);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Starts a big tessellation, waits for its temporary file, sends `signal`, and checks the
/// exit status and that the folder is empty afterwards.
fn interrupt(signal: &str, code: i32) {
    let d = dir(&format!("signal-{signal}"));
    let target = d.join("big.ply");
    let mut child = bin()
        .args([
            "tessellate",
            &common::shared_spec("stanford-bunny.obj"),
            "--level",
            "48",
            "--backend",
            "cpu",
            "-q",
            "-o",
        ])
        .arg(&target)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    // The temporary file is `.big.ply.RANDOM.tmp`.
    let is_tmp = |n: &String| n.starts_with(".big.ply.") && n.ends_with(".tmp");
    while !listing(&d).iter().any(is_tmp) {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no temporary file .big.ply.*.tmp after 120 s"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "exited before the signal"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let kill = Command::new("kill")
        .args([format!("-{signal}"), child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(code), "{:?}", out.status);
    assert!(listing(&d).is_empty(), "left behind: {:?}", listing(&d));
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn sigint_removes_the_temporary_file_and_exits_130() {
    interrupt("INT", 130);
}

#[test]
fn sigterm_removes_the_temporary_file_and_exits_143() {
    interrupt("TERM", 143);
}

#[test]
fn non_regular_outputs_are_refused() {
    let d = dir("nonregular");
    let mesh = one_triangle(&d);
    let folder = d.join("x.ply");
    std::fs::create_dir(&folder).unwrap();
    let out = run(&["tessellate", &mesh, "-o", folder.to_str().unwrap()]);
    expect_error(&out, &["x.ply: is a directory, not a regular file"]);
    assert!(folder.is_dir());
    let fifo = d.join("f.ply");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let out = run(&["tessellate", &mesh, "-o", fifo.to_str().unwrap()]);
    expect_error(&out, &["f.ply: is a FIFO, not a regular file"]);
    // A character device: /dev/null itself (refused before anything is opened).
    let out = run(&["export-net", &mesh, "-o", "/dev/null"]);
    expect_error(&out, &["/dev/null: is a character device"]);
    assert!(!std::fs::metadata("/dev/null").unwrap().is_file());
    // Through a symbolic link to a device.
    let link = d.join("null.obj");
    std::os::unix::fs::symlink("/dev/null", &link).unwrap();
    let out = run(&["tessellate", &mesh, "-o", link.to_str().unwrap()]);
    expect_error(
        &out,
        &["(the link's target /dev/null): is a character device"],
    );
    assert_eq!(listing(&d), ["f.ply", "null.obj", "one.obj", "x.ply"]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn the_input_is_never_the_output() {
    let d = dir("same");
    let mesh = one_triangle(&d);
    let out = run(&["tessellate", &mesh, "-o", &mesh]);
    expect_error(&out, &["is the input", "refusing to overwrite the input"]);
    // The same file by another name: a symbolic link, and a path with "./".
    let link = d.join("link.obj");
    std::os::unix::fs::symlink("one.obj", &link).unwrap();
    let out = run(&["tessellate", link.to_str().unwrap(), "-o", &mesh]);
    expect_error(&out, &["is the input"]);
    let dotted = format!("{}/./one.obj", d.display());
    let out = run(&["export-net", &mesh, "-o", &dotted]);
    expect_error(&out, &["is the input"]);
    assert_eq!(std::fs::read_to_string(&mesh).unwrap(), ONE_TRIANGLE);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn symbolic_links_are_written_through() {
    let d = dir("symlink");
    let mesh = one_triangle(&d);
    std::fs::create_dir(d.join("real")).unwrap();
    let link = d.join("out.ply");
    std::os::unix::fs::symlink("real/target.ply", &link).unwrap();
    let out = bin()
        .args([
            "tessellate",
            &mesh,
            "--level",
            "4",
            "--backend",
            "cpu",
            "-q",
            "-o",
        ])
        .arg(&link)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The link stays a link; its target is the regular file written.
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    let target = d.join("real/target.ply");
    assert!(std::fs::symlink_metadata(&target).unwrap().is_file());
    let bytes = std::fs::read(&target).unwrap();
    let text = String::from_utf8_lossy(&bytes[..400]);
    // Level 4: 15 vertex records, 16 faces.
    assert!(text.contains("element vertex 15\n"), "{text}");
    assert!(text.contains("element face 16\n"), "{text}");
    assert_eq!(listing(&d.join("real")), ["target.ply"]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn standard_output_streams_the_same_bytes() {
    let d = dir("stdout");
    let mesh = one_triangle(&d);
    for format in ["obj", "ply", "stl"] {
        let file = d.join(format!("out.{format}"));
        let out = run(&[
            "tessellate",
            &mesh,
            "--level",
            "6",
            "--backend",
            "cpu",
            "-q",
            "-o",
            file.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let piped = run(&[
            "tessellate",
            &mesh,
            "--level",
            "6",
            "--backend",
            "cpu",
            "-q",
            "-o",
            "-",
            "--format",
            format,
        ]);
        assert!(
            piped.status.success(),
            "{}",
            String::from_utf8_lossy(&piped.stderr)
        );
        assert_eq!(piped.stdout, std::fs::read(&file).unwrap(), "{format}");
    }
    let out = run(&["tessellate", &mesh, "-o", "-", "--format", "glb"]);
    expect_error(&out, &["--format glb cannot go to standard output"]);
    let out = run(&["tessellate", &mesh, "-o", "-"]);
    expect_error(&out, &["needs --format"]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn non_finite_values_are_never_written() {
    let d = dir("nonfinite");
    let mesh = d.join("huge.obj");
    // 1e39 is finite in f64 and overflows f32 (max 3.4e38).
    std::fs::write(&mesh, "v 1e39 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    for ext in ["ply", "glb", "obj", "stl"] {
        let out_path = d.join(format!("out.{ext}"));
        let out = run(&[
            "tessellate",
            mesh.to_str().unwrap(),
            "--level",
            "2",
            "--backend",
            "cpu",
            "-o",
            out_path.to_str().unwrap(),
        ]);
        expect_error(
            &out,
            &[
                &format!("out.{ext}: patch 0 (input triangle 1) has a non-finite position"),
                "coordinates too large for f32",
            ],
        );
    }
    assert_eq!(listing(&d), ["huge.obj"], "no file, no temporary file");
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn scheme_lists_accept_spaces() {
    let expect = |args: &[&str]| {
        let out = run(args);
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let schemes: Vec<&str> = v
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["scheme"].as_str().unwrap())
            .collect();
        assert_eq!(schemes, ["g1", "pn"], "{args:?}");
    };
    let base = ["compare", "sphere320", "--json", "--backend", "cpu"];
    for schemes in [
        &["g1, pn"][..],
        &["g1,", "pn"],
        &["g1 ,", " pn"],
        &["g1,pn"],
    ] {
        let mut args: Vec<&str> = base.to_vec();
        args.push("--schemes");
        args.extend_from_slice(schemes);
        expect(&args);
    }
    let mut args: Vec<&str> = base.to_vec();
    args.push("--schemes=g1, pn");
    expect(&args);
}

#[test]
fn quiet_commands_print_nothing_on_stderr() {
    let d = dir("quiet");
    let mesh = one_triangle(&d);
    let ply = d.join("q.ply");
    let json = d.join("q.json");
    for args in [
        vec![
            "tessellate",
            &mesh,
            "--backend",
            "cpu",
            "-q",
            "-o",
            ply.to_str().unwrap(),
        ],
        vec!["export-net", &mesh, "-q", "-o", json.to_str().unwrap()],
        vec!["export-net", &mesh, "--quiet", "-o", json.to_str().unwrap()],
    ] {
        let out = run(&args);
        assert!(out.status.success(), "{args:?}");
        assert!(
            out.stderr.is_empty(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// `stats` and `compare` take `-q`/`--quiet` as the other commands do: nothing on stderr
/// (no adapter line, no CPU fallback note), the results still on stdout.
#[test]
fn stats_and_compare_take_quiet() {
    for args in [
        vec!["stats", "sphere320", "-q"],
        vec!["stats", "sphere320", "--quiet", "--json"],
        vec!["compare", "sphere320", "--schemes", "g1", "-q"],
        vec![
            "compare",
            "sphere320",
            "--schemes",
            "g1",
            "--quiet",
            "--json",
        ],
    ] {
        let out = run(&args);
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            out.stderr.is_empty(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.contains("sphere320"), "{args:?}: {stdout}");
    }
}

/// The unit cube as OBJ with each face's own square of texture coordinates (face i at
/// u in [i, i + 1]), so that the faces disagree on the UVs along all 12 cube edges; with
/// `flat`, one normal per face as well.
fn uv_cube(flat: bool) -> String {
    let mut s = String::new();
    for p in common::cube_corners() {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for n in common::CUBE_FACE_NORMALS {
        s += &format!("vn {} {} {}\n", n[0], n[1], n[2]);
    }
    for i in 0..6 {
        for (u, v) in [(0, 0), (1, 0), (1, 1), (0, 1)] {
            s += &format!("vt {} {v}\n", i + u);
        }
    }
    for (i, q) in common::CUBE_QUADS.iter().enumerate() {
        let c: Vec<String> = q
            .iter()
            .enumerate()
            .map(|(j, v)| match flat {
                true => format!("{}/{}/{}", v + 1, 4 * i + j + 1, i + 1),
                false => format!("{}/{}", v + 1, 4 * i + j + 1),
            })
            .collect();
        s += &format!("f {}\n", c.join(" "));
    }
    s
}

/// `tessellate --json`'s counts of the edges the output is cut along, and `stats --json`'s
/// crease count.
fn edge_counts(mesh: &str, extra: &[&str], out: &Path) -> (u64, u64, u64, u64) {
    let mut args = vec![
        "tessellate",
        mesh,
        "--level",
        "1",
        "--backend",
        "cpu",
        "--json",
    ];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["-o", out.to_str().unwrap()]);
    let o = run(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let t: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let mut args = vec!["stats", mesh, "--backend", "cpu", "--json"];
    args.extend_from_slice(extra);
    let o = run(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let n = |v: &serde_json::Value| v.as_u64().unwrap();
    (
        n(&t["crease_edges"]),
        n(&t["seam_edges"]),
        n(&t["split_edges"]),
        n(&s["crease_edges"]),
    )
}

/// Texture seams are counted apart from creases: `tessellate`'s crease count is the one
/// `stats` gives, the seams have a field and a name of their own, and `split_edges` is
/// every edge the output is cut along.
#[test]
fn tessellate_counts_uv_seams_apart_from_creases() {
    let d = dir("seams");
    let ply = d.join("s.ply");
    // (crease, seam, split, stats' crease): the smooth cube's 12 edges are all UV seams
    // (estimated normals are shared), the flat cube's all creases, which also split UVs.
    for (flat, want) in [(false, (0, 12, 12, 0)), (true, (12, 0, 12, 12))] {
        let obj = d.join(format!("cube-{flat}.obj"));
        std::fs::write(&obj, uv_cube(flat)).unwrap();
        assert_eq!(
            edge_counts(obj.to_str().unwrap(), &[], &ply),
            want,
            "flat {flat}"
        );
    }
    // The newcomer's case: spot has UV seams and no creases.
    let spot = common::shared_spec("spot.obj");
    assert_eq!(edge_counts(&spot, &[], &ply), (0, 288, 288, 0));
    // fandisk's creases from the angle, no UVs: all three counts agree with stats.
    let fandisk = common::shared_spec("fandisk.obj");
    let (crease, seam, split, stats) = edge_counts(&fandisk, &["--crease-angle", "30"], &ply);
    assert_eq!((crease, seam, split), (stats, 0, stats));
    assert_eq!(
        stats, 722,
        "the README's crease count of fandisk at 30 degrees"
    );
    // The summary line names both.
    let o = bin()
        .args([
            "tessellate",
            &spot,
            "--level",
            "1",
            "--backend",
            "cpu",
            "-o",
        ])
        .arg(&ply)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("0 crease edges, 288 UV seam edges"), "{err}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// `tessellate --json`'s "precision" is what the samples were evaluated in: on the CPU the
/// f32 kernel for a uniform grid (a tolerance whose levels all agree gives one), f64
/// (rounded once) for the point lists of differing per-edge levels.
#[test]
fn tessellate_json_precision_is_the_evaluation_s() {
    let d = dir("precision");
    let ply = d.join("p.ply");
    let spot = common::shared_spec("spot.obj");
    for (mesh, extra, want, levels) in [
        ("sphere320", &["--level", "2"][..], "f32", None),
        (
            "sphere320",
            &["--tolerance-rel", "1e-2"][..],
            "f32",
            Some([1, 1]),
        ),
        (&spot, &["--tolerance-rel", "1e-3"][..], "f64", Some([1, 3])),
    ] {
        let mut args = vec!["tessellate", mesh, "--backend", "cpu", "--json", "-q"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["-o", ply.to_str().unwrap()]);
        let o = run(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(j["precision"], want, "{extra:?}");
        if let Some(l) = levels {
            assert_eq!(
                j["adaptive"]["edge_levels"],
                serde_json::json!(l),
                "{extra:?}"
            );
        }
    }
    std::fs::remove_dir_all(&d).unwrap();
}
