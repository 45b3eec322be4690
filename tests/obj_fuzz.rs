//! Property tests: whatever OBJ-like text a user feeds in, loading either succeeds with a
//! valid mesh (finite positions, unit normals, indices in range) or returns an error; it
//! never panics.

use std::path::PathBuf;

use g1tess::{LoadOptions, Mesh};
use g1tess::{PatchTable, Scheme, SchemeOptions};
use proptest::prelude::*;

fn line() -> impl Strategy<Value = String> {
    let num = prop_oneof![
        (-3.0f64..3.0).prop_map(|x| format!("{x}")),
        Just("0".to_string()),
        Just("nan".to_string()),
        Just("x".to_string()),
    ];
    let idx = prop_oneof![(-6i64..8).prop_map(|i| i.to_string()), Just(String::new())];
    let corner =
        (idx.clone(), idx.clone(), idx, 0usize..4).prop_map(|(a, b, c, form)| match form {
            0 => a,
            1 => format!("{a}/{b}"),
            2 => format!("{a}//{c}"),
            _ => format!("{a}/{b}/{c}"),
        });
    prop_oneof![
        4 => prop::collection::vec(num.clone(), 2..4).prop_map(|v| format!("v {}", v.join(" "))),
        2 => prop::collection::vec(num, 2..4).prop_map(|v| format!("vn {}", v.join(" "))),
        4 => prop::collection::vec(corner, 1..6).prop_map(|c| format!("f {}", c.join(" "))),
        1 => Just("g group".to_string()),
        1 => Just("# comment".to_string()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn loading_never_panics(lines in prop::collection::vec(line(), 0..24), case in 0u32..1_000_000) {
        let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("obj_fuzz");
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(format!("case{case}.obj"));
        std::fs::write(&p, lines.join("\n")).unwrap();
        match Mesh::load(p.to_str().unwrap(), &LoadOptions::default()) {
            Ok(m) => {
                prop_assert!(!m.triangles.is_empty());
                prop_assert!(m.positions.iter().all(|x| x.is_finite()));
                for (t, n) in m.triangles.iter().zip(&m.corner_normals) {
                    prop_assert!(t.iter().all(|&v| (v as usize) < m.positions.len()));
                    // Unit normals up to the rounding of one normalisation (a few ulps).
                    prop_assert!(n.iter().all(|x| (x.length() - 1.0).abs() < 1e-12));
                }
                // Whatever loads builds a G1 table that evaluates to finite values.
                let table = PatchTable::build(&m, Scheme::G1, &SchemeOptions::default()).unwrap();
                for i in 0..table.len() {
                    for b in [[1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.2, 0.3, 0.5]] {
                        let sp = table.eval(i, b);
                        prop_assert!(sp.p.is_finite() && sp.n.is_finite());
                    }
                }
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
        let _ = std::fs::remove_file(&p);
    }
}
