//! The command line on the library's costly paths: the certificate on normals in their
//! triangles' plane (bounded, and a note on what it left undecided), the fold repair of
//! a book of triangles around one edge, and the adaptive tessellation's memory.

use std::path::PathBuf;
use std::process::{Command, Output};

/// This file's temporary folder (created).
fn dir() -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("hardening_patch");
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(args)
        .output()
        .unwrap()
}

/// An OBJ of the unit square in the plane z = 0, cut into n × n squares of two triangles
/// each, every corner with the normal (1, 0, 0): in the plane.
fn in_plane_grid(n: usize) -> String {
    let mut s = String::new();
    for j in 0..=n {
        for i in 0..=n {
            s += &format!("v {} {} 0\n", i as f64 / n as f64, j as f64 / n as f64);
        }
    }
    s += "vn 1 0 0\n";
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            s += &format!("f {a}//1 {b}//1 {d}//1\nf {a}//1 {d}//1 {c}//1\n");
        }
    }
    s
}

/// An OBJ of a book: `n` triangles around the edge from (0, 0, 0) to (0, 0, 1), their
/// third corners evenly around a circle of radius 1 at height 1/2 (no normals given: the
/// estimated ones at the edge's ends face half of the pages away).
fn book(n: usize) -> String {
    let mut s = String::from("v 0 0 0\nv 0 0 1\n");
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        s += &format!("v {} {} 0.5\n", a.cos(), a.sin());
    }
    for k in 0..n {
        s += &format!("f 1 2 {}\n", k + 3);
    }
    s
}

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// `stats` on a 32 × 32 grid whose normals lie in its plane (2,048 patches, none of which
/// any subdivision can certify) ends, counts what the certificate left undecided, and
/// says so in a note (the run took over 60 s before the certificate's cost was bounded;
/// its time is measured in the notes of the change, not here).
#[test]
fn stats_on_in_plane_normals_reports_what_it_left_undecided() {
    let path = dir().join("in-plane.obj");
    std::fs::write(&path, in_plane_grid(32)).unwrap();
    let path = path.to_str().unwrap();
    let out = run(&["stats", path, "--backend", "cpu", "--json"]);
    let v = json(&out);
    assert_eq!(v["triangles"], 2048);
    // Deterministic counts: nothing certified, the folds witnessed where J (zero in exact
    // arithmetic) rounds below the witness's margin, the rest undecided.
    assert_eq!(
        v["patches"],
        serde_json::json!({"valid": 0, "folded": 156, "undecided": 1892})
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("note: 1892 of 2048 patches undecided: the validity certificate"),
        "{stderr}"
    );
    // The text report counts them too; `-q` leaves the note out.
    let out = run(&["stats", path, "--backend", "cpu", "-q"]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout)
        .contains("0 certified valid · 156 folded · 1892 undecided"));
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `stats --repair-folds` on a book of 200 triangles around one edge (the search moved
/// the edge's two normals for each of the 200 patches, with the 200 patches around each
/// move: 57 s): each page gets its own face normal, flat, and every patch is certified.
#[test]
fn repair_of_a_book_flattens_its_pages() {
    let path = dir().join("book.obj");
    std::fs::write(&path, book(200)).unwrap();
    let out = run(&[
        "stats",
        path.to_str().unwrap(),
        "--backend",
        "cpu",
        "--json",
        "--repair-folds",
    ]);
    let v = json(&out);
    assert_eq!(v["nonmanifold_edges"], 1);
    assert_eq!(
        v["patches"],
        serde_json::json!({"valid": 200, "folded": 0, "undecided": 0})
    );
    let r = &v["repair"];
    // Half of the pages face away from the estimated normals at the edge's ends.
    assert_eq!(r["before"]["folded"], 100);
    assert_eq!(
        r["after"],
        serde_json::json!({"valid": 200, "folded": 0, "undecided": 0})
    );
    // Only the edge's two ends changed (each page's own corner has its face normal
    // already), every page flattened, no search round needed, no smooth edge made a
    // crease (the book has none).
    assert_eq!(r["vertices_touched"], 2);
    assert_eq!(r["corners_changed"], 400);
    assert_eq!(r["triangles_flattened"], 200);
    assert_eq!(r["rounds"], 0);
    assert_eq!(r["edges_made_creases"], 0);
}

/// `tessellate --tolerance 1e-12 --max-level 4096` on a tetrahedron: the estimate of the
/// adaptive measurements (which bounds what they hold: the measurement evaluates its
/// points a bounded run at a time, even inside one patch of 16.7 million triangles) is
/// refused in one line naming --max-memory when over the budget, never an abort.
#[test]
fn adaptive_levels_up_to_a_huge_cap_are_refused_over_the_budget() {
    let out_path = dir().join("t.ply");
    let tetra = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/fuzz/tetra-normals.obj"
    );
    let out = run(&[
        "tessellate",
        tetra,
        "--tolerance",
        "1e-12",
        "--max-level",
        "4096",
        "--max-memory",
        "1G",
        "--backend",
        "cpu",
        "-o",
        out_path.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.starts_with("note:")).collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    assert!(
        lines[0].contains("levels up to the cap 4096") && lines[0].contains("(--max-memory)"),
        "{stderr}"
    );
    assert!(!out_path.exists());
}
