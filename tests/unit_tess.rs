//! The unit tests of `src/tess/`: screen-space levels and the adaptive triangle layouts.
//! (Moved from the library's own unit tests: the integration suite is built once.)

mod screen {
    use g1tess::tess::screen::{edge_level, ScreenView};
    use glam::{DMat4, DVec3};

    #[test]
    fn projected_length_over_target() {
        // Orthographic identity: x, y in [−1, 1] span the viewport.
        let view = ScreenView {
            view_proj: DMat4::IDENTITY,
            viewport: [200.0, 100.0],
            target_px: 10.0,
            max_level: 64,
        };
        // 0.5 in x = 50 px: 5 segments; 0.51 = 51 px: 6.
        assert_eq!(edge_level(&view, DVec3::ZERO, DVec3::new(0.5, 0.0, 0.0)), 5);
        assert_eq!(
            edge_level(&view, DVec3::ZERO, DVec3::new(0.51, 0.0, 0.0)),
            6
        );
        // 0.5 in y = 25 px: 3 segments.
        assert_eq!(edge_level(&view, DVec3::ZERO, DVec3::new(0.0, 0.5, 0.0)), 3);
        assert_eq!(edge_level(&view, DVec3::ZERO, DVec3::ZERO), 1);
        assert_eq!(
            edge_level(&view, DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0)),
            64
        );
        // Behind the eye.
        let mut back = view;
        back.view_proj = DMat4::from_cols_array(&[
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0,
        ]);
        // w = z.
        let p = |z: f64| DVec3::new(0.1, 0.0, z);
        assert_eq!(edge_level(&back, p(-1.0), p(-2.0)), 1);
        assert_eq!(edge_level(&back, p(-1.0), p(2.0)), 64);
    }
}

mod layout {
    use g1tess::eval::grid_barycentrics;
    use g1tess::internals::rings;
    use g1tess::tess::layout::{point_count, points, triangle_count, triangles};

    /// Signed area of a triangle in (b1, b2).
    fn area(p: &[[f64; 3]], t: [u32; 3]) -> f64 {
        let [a, b, c] = t.map(|i| p[i as usize]);
        (b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1])
    }

    #[test]
    fn uniform_is_the_grid_and_counts_hold() {
        for n in 1..=7 {
            let mut p = Vec::new();
            points([n; 3], n, &mut p);
            let mut g = grid_barycentrics(n);
            let key = |b: &[f64; 3]| (b[1].to_bits(), b[2].to_bits());
            let mut q = p.clone();
            q.sort_by_key(key);
            g.sort_by_key(key);
            assert_eq!(q.len(), g.len());
            for (x, y) in q.iter().zip(&g) {
                assert_eq!(x[1], y[1]);
                assert_eq!(x[2], y[2]);
            }
            let mut t = Vec::new();
            triangles([n; 3], n, &mut t);
            assert_eq!(t.len(), (n * n) as usize);
        }
    }

    /// A triangle's indices rotated to start at its smallest.
    fn canonical(t: [u32; 3]) -> [u32; 3] {
        let k = (0..3).min_by_key(|&k| t[k]).unwrap();
        [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
    }

    #[test]
    fn rings_with_equal_levels_are_the_grid() {
        for n in 3..=9 {
            let mut a = Vec::new();
            triangles([n; 3], n, &mut a);
            let mut b = Vec::new();
            rings([n; 3], n, &mut b);
            let mut a: Vec<_> = a.into_iter().map(canonical).collect();
            let mut b: Vec<_> = b.into_iter().map(canonical).collect();
            a.sort();
            b.sort();
            assert_eq!(a, b, "level {n}");
        }
    }

    #[test]
    fn every_pattern_tiles_the_triangle() {
        for e0 in 1..=6 {
            for e1 in 1..=6 {
                for e2 in [1, 2, 5, 9, 17] {
                    for inner in [1, 2, 3, 4, 5, 6, 7, 12] {
                        let e = [e0, e1, e2];
                        let mut p = Vec::new();
                        points(e, inner, &mut p);
                        assert_eq!(p.len(), point_count(e, inner));
                        let mut t = Vec::new();
                        triangles(e, inner, &mut t);
                        assert_eq!(t.len(), triangle_count(e, inner));
                        // Positive areas summing to the whole triangle (area 1/2 in (b1,
                        // b2)): with every area positive, a sum of exactly the whole means
                        // no overlap and no gap. 1e-12: rounding of the sum of a few
                        // hundred areas.
                        let mut sum = 0.0;
                        for &tri in &t {
                            let a = area(&p, tri);
                            assert!(a > 0.0, "{e:?} {inner}: triangle {tri:?} area {a}");
                            sum += a;
                        }
                        assert!((sum - 1.0).abs() < 1e-12, "{e:?} {inner}: {sum}");
                        // Every boundary segment used once.
                        let mut uses = std::collections::HashMap::new();
                        for tri in &t {
                            for k in 0..3 {
                                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                                *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                            }
                        }
                        let boundary = uses.values().filter(|&&c| c == 1).count();
                        assert_eq!(boundary, (e0 + e1 + e2) as usize);
                        assert!(uses.values().all(|&c| c <= 2));
                    }
                }
            }
        }
    }
}
