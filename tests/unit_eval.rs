//! The unit tests of `src/eval/`: the grid pattern and the edge kernel's length threshold.
//! (Moved from the library's own unit tests: the integration suite is built once.)

mod pattern {
    use g1tess::eval::pattern::{
        grid_barycentrics, grid_corners, grid_index, grid_len, grid_triangles,
    };

    #[test]
    fn grid_index_and_triangles() {
        for n in 1..=9 {
            let b = grid_barycentrics(n);
            assert_eq!(b.len(), grid_len(n));
            for j in 0..=n {
                for i in 0..=n - j {
                    let p = b[grid_index(n, i, j)];
                    assert_eq!(p[1], i as f64 / n as f64);
                    assert_eq!(p[2], j as f64 / n as f64);
                }
            }
            assert_eq!(grid_triangles(n).len(), (n * n) as usize);
            let c = grid_corners(n);
            assert_eq!(c, [0, n as usize, grid_len(n) - 1]);
            for (k, &g) in c.iter().enumerate() {
                assert_eq!(b[g][k], 1.0);
            }
        }
    }
}

mod edges {
    use g1tess::internals::min_len2;

    /// `min_len2` is the exact threshold: its root is not above the minimum length, the
    /// next f64's is.
    #[test]
    fn min_len2_is_the_square_root_threshold() {
        let (t, m) = (min_len2(), g1tess::patch::MIN_NORMAL_LEN_F64);
        let next = f64::from_bits(t.to_bits() + 1);
        assert!(t > 0.0 && t.sqrt() <= m && next.sqrt() > m, "{t:e}");
    }
}
