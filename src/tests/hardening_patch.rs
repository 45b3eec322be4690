//! The library's costly paths, bounded: the validity certificate's cost per patch and in
//! total (normals in their triangles' plane), the fold repair around one edge shared by
//! many triangles.

use crate::patch::validity::{
    check_patch, check_range, undecided_note, PatchCounts, Verdict, DEEP_FLOOR, FIRST_FLOOR,
    WITNESS_SHARE,
};
use crate::tests::common;
use crate::{LoadOptions, Mesh, PatchTable, Scheme, SchemeOptions};

/// An OBJ of the unit square in the plane z = 0, cut into n × n squares of two triangles
/// each (2n² triangles, counter-clockwise seen from +z), every corner with the normal `vn`.
pub fn grid_obj(n: usize, vn: [f64; 3]) -> String {
    let mut s = String::new();
    for j in 0..=n {
        for i in 0..=n {
            s += &format!("v {} {} 0\n", i as f64 / n as f64, j as f64 / n as f64);
        }
    }
    s += &format!("vn {} {} {}\n", vn[0], vn[1], vn[2]);
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            s += &format!("f {a}//1 {b}//1 {d}//1\nf {a}//1 {d}//1 {c}//1\n");
        }
    }
    s
}

/// `text` written as the OBJ `name` in this file's temporary folder, loaded.
fn load_obj(name: &str, text: &str) -> Mesh {
    let path = common::tmp_dir("hardening-patch").join(name);
    std::fs::write(&path, text).unwrap();
    Mesh::load(path.to_str().unwrap(), &LoadOptions::default()).unwrap()
}

/// Every normal of a 32 × 32 grid lies in the grid's plane: J vanishes along two edges of
/// every G1 patch, so no subdivision can certify one, and each was searched for a witness
/// down to the first subdivision's limit, then again deeper (over 60 s for the 2,048
/// patches). Now their witness searches share [`WITNESS_SHARE`] cells per patch.
#[test]
fn in_plane_normals_cost_a_bounded_number_of_cells() {
    let mesh = load_obj("in-plane.obj", &grid_obj(32, [1.0, 0.0, 0.0]));
    assert_eq!(mesh.triangles.len(), 2048);
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let r = check_range(&table, 0..table.len());
    let counts = r
        .verdicts
        .iter()
        .fold(PatchCounts::default(), PatchCounts::with);
    // Nothing is certified (J = 0 at the corners); the folds are witnessed where J, zero
    // in exact arithmetic, rounds below −1e-12 |S_s| |S_t| (deterministic counts).
    assert_eq!(
        counts,
        PatchCounts {
            valid: 0,
            folded: 156,
            undecided: 1892
        }
    );
    // The work: within the witness searches' budget, nothing beyond (no patch goes
    // deeper); every undecided patch stopped there.
    assert!(r.cells <= WITNESS_SHARE * 2048, "{} cells", r.cells);
    assert_eq!(r.stopped, 1892);
    // And the run says so.
    let note = undecided_note(&counts).unwrap();
    assert!(note.starts_with("1892 of 2048 patches undecided"), "{note}");
}

/// Normals near their triangles' plane (at 0.06° from it) leave patches that the
/// certificate could prove only at great cost: the first subdivisions share
/// `FIRST_SHARE` cells per patch of a range, the deeper ones `DEEP_SHARE`, at least their
/// floors.
#[test]
fn near_plane_normals_cost_a_bounded_number_of_cells() {
    let mesh = load_obj("near-plane.obj", &grid_obj(8, [1.0, 0.0, 0.001]));
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let n = table.len();
    assert_eq!(n, 128);
    let r = check_range(&table, 0..n);
    // Without the budgets each patch examined its whole first subdivision (4,093 cells
    // here) and then the deeper one; the floors are what a range this small gets.
    assert!(r.cells <= FIRST_FLOOR + DEEP_FLOOR, "{} cells", r.cells);
    assert!(r.verdicts.iter().all(|v| *v != Verdict::Valid));
}

/// On the test meshes no budget binds: every verdict of a whole table is the one
/// [`check_patch`] gives the patch alone, including Suzanne's 8 G1 patches that only the
/// deeper subdivision certifies and the 7 Nagata folds of the fandisk that the first
/// subdivision witnesses after more than 1,000 cells.
#[test]
fn the_budgets_leave_the_test_meshes_verdicts_alone() {
    for (name, scheme) in [("suzanne.obj", Scheme::G1), ("fandisk.obj", Scheme::Nagata)] {
        let mesh = common::load(name);
        let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default()).unwrap();
        let r = check_range(&table, 0..table.len());
        assert_eq!(r.stopped, 0, "{name} {scheme}");
        let alone: Vec<Verdict> = (0..table.len()).map(|i| check_patch(&table, i)).collect();
        assert!(r.verdicts == alone, "{name} {scheme}");
        let counts = alone.iter().fold(PatchCounts::default(), PatchCounts::with);
        let expected = match scheme {
            Scheme::G1 => (892, 76, 0),
            _ => (8440, 4175, 331),
        };
        assert_eq!(
            (counts.valid, counts.folded, counts.undecided),
            expected,
            "{name} {scheme}"
        );
    }
}
