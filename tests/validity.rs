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

/// Every patch's verdict (valid, folded with its witness, undecided) on the test meshes for
/// every scheme, as a digest (FNV-1a over each verdict's kind and the bits of its witness)
/// with the counts. The certificate's speed-ups (the whole-domain bound first for
/// polynomial patches, the four-lane subdivision) changed no verdict and no witness
/// (compared patch by patch with the code before them); a later change that moves one
/// fails here.
#[test]
fn every_verdict_and_witness_is_the_recorded_one() {
    use g1tess::{check_table, LoadOptions, Mesh, PatchTable, Scheme, SchemeOptions, Verdict};
    let digest = |v: &[Verdict]| {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |x: u64| {
            for b in x.to_le_bytes() {
                h ^= b as u64;
                h = h.wrapping_mul(0x0100_0000_01b3);
            }
        };
        for x in v {
            match *x {
                Verdict::Valid => eat(1),
                Verdict::Undecided => eat(2),
                Verdict::Folded { s, t, jacobian } => {
                    eat(3);
                    eat(s.to_bits());
                    eat(t.to_bits());
                    eat(jacobian.to_bits());
                }
            }
        }
        h
    };
    let mut got = Vec::new();
    for (file, crease) in [
        ("suzanne.obj", None),
        ("spot.obj", None),
        ("fandisk.obj", None),
        ("fandisk.obj", Some(30.0)),
        ("stanford-bunny.obj", None),
    ] {
        let mesh = Mesh::load(
            &common::shared_spec(file),
            &LoadOptions::default().with_crease_angle(crease),
        )
        .unwrap();
        for scheme in Scheme::all() {
            let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default()).unwrap();
            let v = check_table(&table);
            let valid = v.iter().filter(|x| **x == Verdict::Valid).count();
            let undecided = v.iter().filter(|x| **x == Verdict::Undecided).count();
            got.push(format!(
                "{file} {crease:?} {scheme}: {valid} {} {undecided} {:016x}",
                v.len() - valid - undecided,
                digest(&v)
            ));
        }
    }
    let expected: Vec<String> = EXPECTED_VERDICTS.lines().map(str::to_owned).collect();
    assert_eq!(got, expected, "\n{}", got.join("\n"));
}

/// Per mesh and scheme: valid, folded, undecided, digest.
const EXPECTED_VERDICTS: &str = "\
suzanne.obj None g1: 892 76 0 9f85a7c27efd995a\n\
suzanne.obj None phong: 958 10 0 9694993391c4f205\n\
suzanne.obj None nagata: 374 594 0 0d7ca75acf112231\n\
suzanne.obj None nagata-guarded: 720 248 0 34550cc5f02bba87\n\
suzanne.obj None nlsa: 964 4 0 7159ff31ab4a4b22\n\
suzanne.obj None pn: 964 2 2 b3e887bdc524dd72\n\
suzanne.obj None pn-normals: 964 2 2 b3e887bdc524dd72\n\
suzanne.obj None flat: 968 0 0 b196819b96cefba5\n\
spot.obj None g1: 5856 0 0 4c7a6bce209b2125\n\
spot.obj None phong: 5856 0 0 4c7a6bce209b2125\n\
spot.obj None nagata: 5199 657 0 f4173f9365617c5b\n\
spot.obj None nagata-guarded: 5720 136 0 b601836dd2dffb36\n\
spot.obj None nlsa: 5856 0 0 4c7a6bce209b2125\n\
spot.obj None pn: 5856 0 0 4c7a6bce209b2125\n\
spot.obj None pn-normals: 5856 0 0 4c7a6bce209b2125\n\
spot.obj None flat: 5856 0 0 4c7a6bce209b2125\n\
fandisk.obj None g1: 12946 0 0 637ee9d51cbd3745\n\
fandisk.obj None phong: 12946 0 0 637ee9d51cbd3745\n\
fandisk.obj None nagata: 8440 4175 331 66cdebb03fe0465e\n\
fandisk.obj None nagata-guarded: 10696 1919 331 e9fb352617fe6b1b\n\
fandisk.obj None nlsa: 12946 0 0 637ee9d51cbd3745\n\
fandisk.obj None pn: 12946 0 0 637ee9d51cbd3745\n\
fandisk.obj None pn-normals: 12946 0 0 637ee9d51cbd3745\n\
fandisk.obj None flat: 12946 0 0 637ee9d51cbd3745\n\
fandisk.obj Some(30.0) g1: 12945 0 1 ab49d424939eb866\n\
fandisk.obj Some(30.0) phong: 12946 0 0 637ee9d51cbd3745\n\
fandisk.obj Some(30.0) nagata: 9459 3426 61 f918ac1014e574f8\n\
fandisk.obj Some(30.0) nagata-guarded: 12283 600 63 c47bc6e1840a3a39\n\
fandisk.obj Some(30.0) nlsa: 12946 0 0 637ee9d51cbd3745\n\
fandisk.obj Some(30.0) pn: 12946 0 0 637ee9d51cbd3745\n\
fandisk.obj Some(30.0) pn-normals: 12946 0 0 637ee9d51cbd3745\n\
fandisk.obj Some(30.0) flat: 12946 0 0 637ee9d51cbd3745\n\
stanford-bunny.obj None g1: 69444 7 0 6c70e7c8b637792d\n\
stanford-bunny.obj None phong: 69448 3 0 52a6044beb42620a\n\
stanford-bunny.obj None nagata: 37894 31557 0 57cdf9fb0047cfed\n\
stanford-bunny.obj None nagata-guarded: 63786 5665 0 e64c73c1f5d6ad2a\n\
stanford-bunny.obj None nlsa: 69450 1 0 25ad3590a9ecebc8\n\
stanford-bunny.obj None pn: 69450 1 0 d0be046a4fbf3a40\n\
stanford-bunny.obj None pn-normals: 69450 1 0 d0be046a4fbf3a40\n\
stanford-bunny.obj None flat: 69451 0 0 5c0cc78a81270744\n\
";
