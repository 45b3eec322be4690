//! The fold repair from the command line: `tessellate` cuts the output along the repair's
//! creases, and the commands count, warn and repair.

use crate::common;

/// `tessellate --repair-folds` stitches the repaired mesh: the bunny's repair makes no
/// crease (see `bunny_repair_counts_are_exact_and_make_the_repair_line`), so the output
/// has one record per position, as without the option.
#[test]
fn tessellate_cuts_the_output_along_the_repairs_creases() {
    use std::process::Command;
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-validity-cut-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bunny = common::shared_spec("stanford-bunny.obj");
    let run = |extra: Option<&str>| {
        let out = dir.join("b.ply");
        let o = Command::new(env!("CARGO_BIN_EXE_g1tess"))
            .args([
                "tessellate",
                &bunny,
                "--level",
                "1",
                "--backend",
                "cpu",
                "--json",
            ])
            .arg("-o")
            .arg(&out)
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{o:?}");
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (
            v["crease_edges"].clone(),
            v["vertices"].clone(),
            v["vertex_records"].clone(),
        )
    };
    assert_eq!(run(None), (0.into(), 34834.into(), 34834.into()));
    assert_eq!(
        run(Some("--repair-folds")),
        (0.into(), 34834.into(), 34834.into())
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The command line: `stats --json` counts patches, `tessellate` warns about a fold and
/// `--repair-folds` repairs it, and leaves a mesh without folds bit for bit alone.
#[test]
fn command_line_counts_warns_and_repairs() {
    use std::process::Command;
    let bin = env!("CARGO_BIN_EXE_g1tess");
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-validity-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // One triangle whose first normal leans past the triangle's plane (as in
    // `g1_folds_where_a_normal_faces_away_and_is_valid_when_flat`).
    let obj = dir.join("fold.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn -0.3 -0.3 -0.2\nvn 0 0 1\nvn 0 0 1\nf 1//1 2//2 3//3\n",
    )
    .unwrap();
    let run = |args: &[&str]| {
        let out = Command::new(bin).args(args).output().unwrap();
        assert!(out.status.success(), "{args:?}: {out:?}");
        (
            String::from_utf8(out.stdout).unwrap(),
            String::from_utf8(out.stderr).unwrap(),
        )
    };
    let o = obj.to_str().unwrap();
    let (json, _) = run(&["stats", o, "--backend", "cpu", "--json"]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["patches"]["folded"], 1, "{json}");
    assert!(v["cos"].is_null());
    let (json, _) = run(&["stats", o, "--backend", "cpu", "--json", "--repair-folds"]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["patches"]["valid"], 1, "{json}");
    assert_eq!(v["repair"]["vertices_touched"], 1, "{json}");
    let out = dir.join("fold.ply");
    let (_, err) = run(&[
        "tessellate",
        o,
        "-o",
        out.to_str().unwrap(),
        "--backend",
        "cpu",
    ]);
    assert!(
        err.contains("warning: fold.obj: 1 of 1 g1 patches are folded"),
        "{err}"
    );
    let (_, err) = run(&[
        "tessellate",
        o,
        "-o",
        out.to_str().unwrap(),
        "--backend",
        "cpu",
        "--repair-folds",
    ]);
    assert!(err.contains("0 folded and 0 undecided after"), "{err}");
    // No fold: the same bytes with and without the option.
    let (a, b) = (dir.join("a.ply"), dir.join("b.ply"));
    for (p, extra) in [(&a, None), (&b, Some("--repair-folds"))] {
        let mut args = vec!["tessellate", "torus200", "-o", p.to_str().unwrap()];
        args.extend(["--backend", "cpu", "--level", "3", "-q"]);
        args.extend(extra);
        run(&args);
    }
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    std::fs::remove_dir_all(&dir).unwrap();
}
