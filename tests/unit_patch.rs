//! The unit tests of `src/patch/`: Bernstein bases and the validity certificate.
//! (Moved from the library's own unit tests: the integration suite is built once.)

mod basis {
    use g1tess::patch::basis::{bezier, bezier_index, bezier_powers, g1};

    #[test]
    fn bezier_index_matches_order() {
        for n in 1..=4 {
            for (i, p) in bezier_powers(n).iter().enumerate() {
                assert_eq!(bezier_index(n, *p), i);
            }
        }
    }

    #[test]
    fn partitions_of_unity() {
        for b in [[0.2, 0.3, 0.5], [1.0, 0.0, 0.0], [0.0, 0.25, 0.75]] {
            for n in 1..=3 {
                let w = bezier(n, b);
                assert!((w.w[..w.n].iter().sum::<f64>() - 1.0).abs() < 1e-15);
                assert!(w.ws[..w.n].iter().sum::<f64>().abs() < 1e-14);
            }
            let w = g1(b);
            assert!((w.w.iter().sum::<f64>() - 1.0).abs() < 1e-15, "{b:?}");
            assert!(w.ws.iter().sum::<f64>().abs() < 1e-14);
            assert!(w.wt.iter().sum::<f64>().abs() < 1e-14);
        }
    }
}

mod validity {
    use g1tess::internals::{
        interior_powers, quick_flat, quick_quartic, tables, QUARTIC_BOUNDARY, QUARTIC_INTERIOR,
        QUARTIC_UP,
    };
    use g1tess::mesh::{LoadOptions, Mesh};
    use g1tess::patch::basis;
    use g1tess::patch::validity::jacobian;
    use g1tess::patch::PatchTable;
    use g1tess::patch::{Scheme, SchemeOptions};

    /// The compile-time index tables of [`quick_quartic`] are those of the runtime
    /// functions they stand for.
    #[test]
    fn quartic_tables_match_the_basis() {
        for (j, p) in basis::g1_boundary_powers().iter().enumerate() {
            assert_eq!(QUARTIC_BOUNDARY[j], basis::bezier_index(4, *p));
        }
        for (m, &slot) in QUARTIC_INTERIOR.iter().enumerate() {
            assert_eq!(slot, basis::bezier_index(4, interior_powers(m)));
        }
        assert_eq!(tables().up[4], QUARTIC_UP.to_vec());
    }

    /// Every bunny G1 patch that [`quick_flat`] certifies has J > 0 at the 15 points of a
    /// level-4 barycentric grid by the patch's own f64 evaluation (independent of the
    /// bound), and the pre-test certifies the bulk of the patches of this fine mesh.
    #[test]
    fn quick_flat_certifies_only_positive_jacobians() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/stanford-bunny.obj");
        let mesh = Mesh::load(path, &LoadOptions::default()).unwrap();
        let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
        let mut passed = 0;
        for i in 0..table.len() {
            let c = table.patch(i);
            let (ds, dt, r, cmax) = quick_quartic(c);
            if !quick_flat(c, &ds, &dt, r, table.flat_normals[i], cmax) {
                continue;
            }
            passed += 1;
            for p in basis::bezier_powers(4) {
                let b = p.map(|k| k as f64 / 4.0);
                // Strictly positive: the certificate keeps a margin far above rounding.
                let (j, _) = jacobian(&table, i, b);
                assert!(j > 0.0, "patch {i} at {b:?}: J = {j}");
            }
        }
        // Deterministic: 66,615 of the 69,451 patches.
        assert_eq!((passed, table.len()), (66_615, 69_451));
    }
}
