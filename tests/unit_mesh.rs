//! The unit tests of `src/mesh/`: welding, creases, the point-normal reader, the edge index
//! and the text-reading helpers.
//! (Moved from the library's own unit tests: the integration suite is built once.)

mod weld {
    use g1tess::mesh::weld::{representatives, weld, Order};
    use g1tess::mesh::LoadReport;
    use glam::DVec3;

    #[test]
    fn signed_zeros_weld_and_counts_add_up() {
        let p = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(-0.0, 0.0, -0.0), // = vertex 0
            DVec3::new(1.0, -0.0, 0.0),  // = vertex 1
            DVec3::new(0.0, 1.0, -0.0),  // = vertex 2
            DVec3::new(7.0, 7.0, 7.0),   // unused
            DVec3::new(0.0, 0.0, 1.0),
        ];
        let mut tris = vec![[0, 1, 2], [3, 4, 7], [3, 0, 5], [5, 3, 7]];
        let mut normals = vec!['a', 'b', 'c', 'd'];
        let mut report = LoadReport::default();
        let out = weld(&p, &mut tris, &mut normals, Order::Input, &mut report).unwrap();
        assert_eq!(out.len(), 4);
        assert_eq!(tris, vec![[0, 1, 2], [0, 1, 3], [2, 0, 3]]);
        assert_eq!(normals, vec!['a', 'b', 'd']);
        assert_eq!(report.degenerate_triangles_dropped, 1);
        assert_eq!(report.vertices_welded, 3);
        assert_eq!(report.unused_vertices_dropped, 1);
        // Welded positions carry +0.0.
        assert!(out
            .iter()
            .flat_map(|q| q.to_array())
            .all(|x| x != 0.0 || x.is_sign_positive()));
        // Numbered by first use: the last kept vertex (7) is used before vertex 2.
        let (mut t1, mut n1, mut r1) = (
            vec![[0, 1, 7], [3, 4, 2]],
            vec![0, 1],
            LoadReport::default(),
        );
        let out1 = weld(&p, &mut t1, &mut n1, Order::FirstUse, &mut r1).unwrap();
        assert_eq!(t1, vec![[0, 1, 2], [0, 1, 3]]);
        assert_eq!(out1[2], p[7]);
        let mut bad = vec![[0, 1, 8]];
        let e = weld(
            &p,
            &mut bad,
            &mut Vec::<()>::new(),
            Order::Input,
            &mut report,
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("triangle 0 has vertex index 8"),
            "{e}"
        );
    }

    #[test]
    fn distinct_points_stay_distinct_under_collisions() {
        // A 40×40×40 integer grid (hash-unfriendly: many equal high bits) plus a copy of it.
        let mut p = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                for k in 0..40 {
                    p.push(DVec3::new(i as f64, j as f64, k as f64));
                }
            }
        }
        let n = p.len();
        p.extend_from_within(..);
        let rep = representatives(&p);
        for v in 0..n {
            assert_eq!(rep[v], v as u32);
            assert_eq!(rep[v + n], v as u32);
        }
    }
}

mod creases {
    use g1tess::mesh::creases::{crease_edges, split_normals_by_angle};
    use g1tess::mesh::normals::face_normal;
    use g1tess::mesh::{Mesh, NormalWeighting};
    use glam::DVec3;

    /// A unit cube, 12 triangles, outward, one normal per vertex (smooth).
    fn cube() -> Mesh {
        let p: Vec<DVec3> = crate::common::cube_corners()
            .into_iter()
            .map(DVec3::from)
            .collect();
        let mut tris = Vec::new();
        for q in crate::common::CUBE_QUADS {
            tris.push([q[0], q[1], q[2]]);
            tris.push([q[0], q[2], q[3]]);
        }
        let c = DVec3::splat(0.5);
        let n: Vec<DVec3> = p.iter().map(|x| (*x - c).normalize()).collect();
        Mesh::from_soup("cube", &p, &tris, Some(&n), &Default::default()).unwrap()
    }

    #[test]
    fn cube_creases_by_angle() {
        let mut m = cube();
        let adj = m.adjacency();
        assert_eq!(adj.interior, 18);
        assert!(crease_edges(&m, &adj).iter().all(|c| !c));
        // The 12 cube edges are 90° creases, the 6 face diagonals are flat.
        let n = split_normals_by_angle(&mut m, 30.0, NormalWeighting::Angle).unwrap();
        assert_eq!(n, 12);
        let creases = crease_edges(&m, &adj);
        assert_eq!(creases.iter().filter(|&&c| c).count(), 12);
        // Every corner normal is now its face's normal.
        for (t, tri) in m.triangles.iter().enumerate() {
            let f = face_normal(tri.map(|v| m.positions[v as usize]));
            for k in 0..3 {
                assert!((m.corner_normals[t][k] - f).length() < 1e-15);
            }
        }
        // Above 90°, nothing is a crease.
        let mut m2 = cube();
        assert_eq!(
            split_normals_by_angle(&mut m2, 95.0, NormalWeighting::Angle).unwrap(),
            0
        );
        assert!(crease_edges(&m2, &adj).iter().all(|c| !c));
        assert!(split_normals_by_angle(&mut m2, -1.0, NormalWeighting::Angle).is_err());
    }
}

mod pn_file {
    use g1tess::mesh::generators::icosphere;
    use g1tess::mesh::pn_file::HEADER;
    use g1tess::mesh::LoadOptions;
    use g1tess::mesh::Mesh;
    use g1tess::patch::{PatchTable, Scheme, SchemeOptions};
    use g1tess::Result;
    use glam::DVec3;

    /// A scratch file that is removed when dropped (straight in the temporary directory,
    /// so nothing stays behind).
    struct Scratch(std::path::PathBuf);
    impl Scratch {
        fn new(name: &str, text: impl AsRef<[u8]>) -> Scratch {
            let p = std::env::temp_dir().join(format!("g1tess-pn-{}-{name}", std::process::id()));
            std::fs::write(&p, text).unwrap();
            Scratch(p)
        }
    }
    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    /// Writes a mesh the way the Blender add-on does: shortest round-trip decimal form of
    /// every f64 (Rust's `{:?}` and Python's `repr` agree on that), one vertex normal per
    /// vertex taken from the first corner that uses it.
    fn to_pn(mesh: &Mesh) -> String {
        let mut vn = vec![DVec3::ZERO; mesh.positions.len()];
        for (t, n) in mesh.triangles.iter().zip(&mesh.corner_normals) {
            for k in 0..3 {
                vn[t[k] as usize] = n[k];
            }
        }
        let mut s = format!(
            "{HEADER}\n# written by a test\ncounts {} {} 0\n",
            mesh.positions.len(),
            mesh.triangles.len()
        );
        for (p, n) in mesh.positions.iter().zip(&vn) {
            s += &format!(
                "v {:?} {:?} {:?} {:?} {:?} {:?}\n",
                p.x, p.y, p.z, n.x, n.y, n.z
            );
        }
        for t in &mesh.triangles {
            s += &format!("t {} {} {}\n", t[0], t[1], t[2]);
        }
        s
    }

    fn load(name: &str, text: &str) -> Result<Mesh> {
        let f = Scratch::new(name, text);
        Mesh::load(f.0.to_str().unwrap(), &LoadOptions::default())
    }

    #[test]
    fn plain_and_general_records_read_alike() {
        // The same records written plainly (the one-pass reading of `Raw::fast`) and with a
        // leading blank and a comment (the general path): the same mesh, bit for bit, over
        // long f32 decimals, short ones, exponents, signed zeros, unnormalised normals, tabs,
        // a `+` index and a corner normal.
        let src = icosphere(1);
        let mut lines = vec![format!(
            "counts {} {} 1",
            src.positions.len(),
            src.triangles.len()
        )];
        for (i, p) in src.positions.iter().enumerate() {
            let q = p.to_array().map(|x| x as f32 as f64);
            let z = match i % 4 {
                0 => format!("{:?}", q[2]),
                1 => format!("{:.3}", q[2]),
                2 => format!("{:e}", q[2]),
                _ => "-0.0".into(),
            };
            lines.push(format!("v {:?}\t{} {z} {} 2 -0.5e0", q[0], q[1], 3 * i + 1));
        }
        for (i, t) in src.triangles.iter().enumerate() {
            lines.push(if i % 7 == 0 {
                format!("t +{} {}  {}", t[0], t[1], t[2])
            } else {
                format!("t {} {} {}", t[0], t[1], t[2])
            });
        }
        lines.push("c 3 1 0 0 1".into());
        let plain = format!("{HEADER}\n{}\n", lines.join("\n"));
        let general = format!(
            "{HEADER}\n{}",
            lines
                .iter()
                .map(|l| format!(" {l} # general\n"))
                .collect::<String>()
        );
        let a = load("plain.pn", &plain).unwrap();
        let b = load("general.pn", &general).unwrap();
        let bits = |v: &[DVec3]| -> Vec<[u64; 3]> {
            v.iter().map(|p| p.to_array().map(f64::to_bits)).collect()
        };
        assert_eq!(bits(&a.positions), bits(&b.positions));
        assert_eq!(a.triangles, b.triangles);
        let normals = |m: &Mesh| bits(&m.corner_normals.concat());
        assert_eq!(normals(&a), normals(&b));
        assert_eq!(
            format!("{:?}", a.load_report),
            format!("{:?}", b.load_report)
        );
        assert_eq!(a.triangles.len(), src.triangles.len());
    }

    #[test]
    fn round_trip_is_bitwise_and_gives_the_same_patches() {
        let src = icosphere(2);
        let back = load("ico2.pn", &to_pn(&src)).unwrap();
        assert_eq!(back.triangles, src.triangles);
        assert_eq!(back.positions.len(), 162);
        for (a, b) in back.positions.iter().zip(&src.positions) {
            assert_eq!(
                a.to_array().map(f64::to_bits),
                b.to_array().map(f64::to_bits)
            );
        }
        for (a, b) in back.corner_normals.iter().zip(&src.corner_normals) {
            for k in 0..3 {
                // Renormalising an already unit normal moves it by a few ulps at most.
                assert!((a[k] - b[k]).length() <= 1e-15, "{:?} vs {:?}", a[k], b[k]);
            }
        }
        let t0 = PatchTable::build(&src, Scheme::G1, &SchemeOptions::default()).unwrap();
        let t1 = PatchTable::build(&back, Scheme::G1, &SchemeOptions::default()).unwrap();
        let worst = t0
            .points
            .iter()
            .zip(&t1.points)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0, f64::max);
        assert!(worst <= 1e-15, "control points differ by {worst}");
    }

    #[test]
    fn shortest_decimal_forms_read_back_exactly() {
        // Python's repr(0.1 + 0.2), an exponent form, a subnormal-free tiny value, -0.0.
        let text = format!(
            "{HEADER}\ncounts 3 1 0\n\
             v 0.30000000000000004 1e-05 -0.0 0 0 1\n\
             v 1.0 2.5e-300 0.0 0 0 2\n\
             v 0.0 1.0 -9.87654321e+74 0 0 1\n\
             t 0 1 2\n"
        );
        let m = load("exact.pn", &text).unwrap();
        assert_eq!(m.positions[0].x, 0.1 + 0.2);
        assert_eq!(m.positions[0].y, 1e-5);
        assert_eq!(m.positions[1].y, 2.5e-300);
        assert_eq!(m.positions[2].z, -9.87654321e74);
        // The second vertex normal (0, 0, 2) is renormalised.
        assert_eq!(m.corner_normals[0][1], DVec3::Z);
    }

    #[test]
    fn corner_normals_replace_vertex_normals_and_welding_keeps_them() {
        // Two triangles of a square folded along the diagonal 0-2. Vertex 4 duplicates
        // vertex 2 (as Blender's unmerged vertices would), vertex 5 is unused, the last
        // triangle repeats a vertex.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let text = format!(
            "{HEADER}\ncounts 6 3 2\n\
             v 0 0 0 0 0 1\n\
             v 1 0 0 0 0 1\n\
             v 1 1 0 0 0 1\n\
             v 0 1 0 0 0 1\n\
             v 1.0 1.0 -0.0 0 {s} {s}\n\
             v 9 9 9 1 0 0\n\
             t 0 1 2\n\
             t 0 4 3   # 4 welds onto 2\n\
             t 0 0 1\n\
             c 0 1 1 0 1\n\
             c 1 0 0 3 4\n"
        );
        let m = load("fold.pn", &text).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.load_report.vertices_welded, 1);
        assert_eq!(m.load_report.unused_vertices_dropped, 1);
        assert_eq!(m.load_report.degenerate_triangles_dropped, 1);
        let n = &m.corner_normals;
        assert_eq!(n[0][0], DVec3::Z);
        assert!((n[0][1] - DVec3::new(1.0, 0.0, 1.0) / 2f64.sqrt()).length() < 1e-16);
        assert_eq!(n[0][2], DVec3::Z);
        assert!((n[1][0] - DVec3::new(0.0, 0.6, 0.8)).length() < 1e-16);
        assert!((n[1][1] - DVec3::new(0.0, s, s)).length() < 1e-16);
        assert_eq!(n[1][2], DVec3::Z);
    }

    #[test]
    fn bad_input_names_the_file_and_line() {
        let v3 = "v 0 0 0 0 0 1\nv 1 0 0 0 0 1\nv 0 1 0 0 0 1\n";
        let cases: Vec<(String, usize, &str)> = vec![
            ("solid x\n".into(), 1, "first line must be 'g1tess-pn 1'"),
            (
                "g1tess-pn 2\ncounts 0 0 0\n".into(),
                1,
                "unsupported version",
            ),
            (format!("{HEADER}\n{v3}t 0 1 2\n"), 2, "before the 'counts"),
            (format!("{HEADER}\n# no records\n"), 2, "no 'counts"),
            (
                format!("{HEADER}\ncounts 3 1\n"),
                2,
                "needs 3 fields, found 2",
            ),
            (
                format!("{HEADER}\ncounts 3 1 0\ncounts 3 1 0\n"),
                3,
                "second 'counts'",
            ),
            (
                format!("{HEADER}\ncounts 1 0 0\nv 0 0 0 0 1\n"),
                3,
                "needs 6 fields",
            ),
            (
                format!("{HEADER}\ncounts 1 0 0\nv 0 x 0 0 0 1\n"),
                3,
                "'x' is not a number",
            ),
            (
                format!("{HEADER}\ncounts 1 0 0\nv 0 nan 0 0 0 1\n"),
                3,
                "non-finite",
            ),
            (
                format!("{HEADER}\ncounts 1 0 0\nv 0 0 inf 0 0 1\n"),
                3,
                "non-finite",
            ),
            (
                format!("{HEADER}\ncounts 1 0 0\nv 0 0 0 0 0 0\n"),
                3,
                "zero-length normal",
            ),
            (
                format!("{HEADER}\ncounts 3 1 0\n{v3}t 0 1 -2\n"),
                6,
                "'-2' is not an index",
            ),
            (
                format!("{HEADER}\ncounts 3 1 0\n{v3}t 0 1 3\n"),
                6,
                "index 3 out of range",
            ),
            (
                format!("{HEADER}\ncounts 3 1 1\n{v3}t 0 1 2\nc 0 3 0 0 1\n"),
                7,
                "corner 3 out of range",
            ),
            (
                format!("{HEADER}\ncounts 3 1 1\n{v3}t 0 1 2\nc 1 0 0 0 1\n"),
                7,
                "triangle 1 out of range",
            ),
            (
                format!("{HEADER}\ncounts 3 1 1\n{v3}t 0 1 2\nc 0 0 0 0 0\n"),
                7,
                "zero-length normal",
            ),
            (
                format!("{HEADER}\ncounts 3 1 2\n{v3}t 0 1 2\nc 0 1 0 0 1\nc 0 1 1 0 0\n"),
                8,
                "corner 1 of triangle 0 given twice",
            ),
            (
                format!("{HEADER}\ncounts 3 2 0\n{v3}t 0 1 2\n"),
                6,
                "declares 2 triangles, the file holds 1",
            ),
            (
                format!("{HEADER}\ncounts 4 1 0\n{v3}t 0 1 2\n"),
                6,
                "declares 4 vertices",
            ),
            (
                format!("{HEADER}\ncounts 3 1 0\n{v3}f 1 2 3\n"),
                6,
                "unknown record 'f'",
            ),
        ];
        for (i, (text, line, what)) in cases.iter().enumerate() {
            let name = format!("bad{i}.pn");
            let e = load(&name, text).expect_err(text).to_string();
            let want = format!("{name}:{line}: ");
            assert!(
                e.contains(&want) && e.contains(what),
                "case {i}: got '{e}', want '{want}…{what}'"
            );
            assert!(!e.contains('\n'), "one line: {e}");
        }
        // No triangles at all: an error for the mesh, not a panic.
        let e = load("empty.pn", &format!("{HEADER}\ncounts 3 0 0\n{v3}")).unwrap_err();
        assert!(e.to_string().contains("empty mesh"), "{e}");
        let e = load(
            "degenerate.pn",
            &format!("{HEADER}\ncounts 3 1 0\n{v3}t 0 1 1\n"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("empty mesh"), "{e}");
        // Not UTF-8.
        let f = Scratch::new("binary.pn", b"g1tess-pn 1\ncounts 0 0 0\n\xff\n");
        let e = Mesh::load(f.0.to_str().unwrap(), &LoadOptions::default()).unwrap_err();
        assert!(e.to_string().contains("binary.pn:3: not UTF-8"), "{e}");
    }

    #[test]
    fn extension_dispatch_is_case_insensitive_and_obj_still_reads_as_obj() {
        let v3 = "v 0 0 0 0 0 1\nv 1 0 0 0 0 1\nv 0 1 0 0 0 1\n";
        let m = load(
            "upper.PN",
            &format!("{HEADER}\ncounts 3 1 0\n{v3}t 0 1 2\n"),
        )
        .unwrap();
        assert_eq!(m.triangles.len(), 1);
        let m = load("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert_eq!(m.triangles.len(), 1);
    }
}

mod adjacency {
    use g1tess::mesh::adjacency::{Adjacency, EdgeCounts, EdgeIndex, EdgeUse, EdgeUses, MeshEdge};

    /// The edges by the obvious method: every use keyed by its sorted ends, sorted.
    fn reference(triangles: &[[u32; 3]]) -> Vec<([u32; 2], Vec<EdgeUse>)> {
        let mut uses = Vec::new();
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                uses.push((
                    [a.min(b), a.max(b)],
                    EdgeUse::from_half_edge((3 * t + k) as u32),
                ));
            }
        }
        uses.sort_by_key(|&(v, u)| (v, u.half_edge()));
        let mut out: Vec<([u32; 2], Vec<EdgeUse>)> = Vec::new();
        for (v, u) in uses {
            match out.last_mut() {
                Some(last) if last.0 == v => last.1.push(u),
                _ => out.push((v, vec![u])),
            }
        }
        out
    }

    #[test]
    fn index_matches_the_sorted_uses() {
        // Interior, boundary and non-manifold edges, and an unused vertex id (7).
        let tris = [
            [0, 1, 2],
            [0, 2, 3],
            [0, 3, 4],
            [2, 1, 5],
            [1, 2, 6],
            [0, 3, 8],
            [8, 9, 4],
        ];
        let index = EdgeIndex::new(&tris);
        let adj = Adjacency::new(&tris);
        let expect = reference(&tris);
        assert_eq!(index.edges, expect.len());
        assert_eq!(adj.edges.len(), expect.len());
        for ((e, m), (v, u)) in index.edges().zip(&adj.edges).zip(&expect) {
            assert_eq!(e.v, *v);
            assert_eq!(m.v, *v);
            let got: Vec<EdgeUse> = (0..e.half_edges.len()).map(|i| e.use_at(i)).collect();
            assert_eq!(&got, u);
            assert_eq!(&m.uses[..], &u[..]);
        }
        // Edges: 01 02 03 04 08 12 15 16 23 25 26 34 38 48 49 89 (16); 02 is interior,
        // 03 (triangles 1, 2, 5) and 12 (triangles 0, 3, 4) are non-manifold.
        assert_eq!(
            index.counts,
            EdgeCounts {
                interior: 1,
                boundary: 13,
                nonmanifold: 2,
                misoriented: 0,
            }
        );
        assert_eq!(adj.counts(), index.counts);
        // A reversed copy of a triangle on the same edge is misoriented.
        let flipped = EdgeIndex::new(&[[0, 1, 2], [1, 0, 3]]);
        assert_eq!(flipped.counts.misoriented, 0);
        let same = EdgeIndex::new(&[[0, 1, 2], [0, 1, 3]]);
        assert_eq!(same.counts.misoriented, 1);
    }

    #[test]
    fn parallel_index_matches_the_sorted_uses() {
        // 60000 triangles on 9000 vertex ids from a fixed pseudo-random sequence: several
        // triangle ranges (2¹⁴ triangles or more each) and vertex ranges per thread count,
        // interior, boundary, non-manifold and misoriented edges all present.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % 9000) as u32
        };
        let tris: Vec<[u32; 3]> = (0..60000)
            .map(|_| loop {
                let t = [next(), next(), next()];
                if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                    break t;
                }
            })
            .collect();
        let expect = reference(&tris);
        let mut counts = EdgeCounts::default();
        for (_, u) in &expect {
            match u.len() {
                1 => counts.boundary += 1,
                2 => {
                    counts.interior += 1;
                    let fwd = |u: EdgeUse| {
                        let t = tris[u.triangle as usize];
                        t[u.local as usize] < t[(u.local as usize + 1) % 3]
                    };
                    if fwd(u[0]) == fwd(u[1]) {
                        counts.misoriented += 1;
                    }
                }
                _ => counts.nonmanifold += 1,
            }
        }
        assert!(counts.interior > 0 && counts.nonmanifold > 0 && counts.misoriented > 0);
        for threads in [1, 2, 3, 5] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let index = pool.install(|| EdgeIndex::new(&tris));
            assert_eq!(index.edges, expect.len());
            assert_eq!(index.counts, counts);
            for (e, (v, u)) in index.edges().zip(&expect) {
                assert_eq!(e.v, *v);
                let got: Vec<EdgeUse> = (0..e.half_edges.len()).map(|i| e.use_at(i)).collect();
                assert_eq!(&got, u);
            }
        }
    }

    #[test]
    fn uses_are_compact() {
        assert!(std::mem::size_of::<MeshEdge>() <= 32);
        let many = [
            EdgeUse::from_half_edge(1),
            EdgeUse::from_half_edge(5),
            EdgeUse::from_half_edge(9),
        ];
        for n in 0..=3 {
            let u = EdgeUses::new(&many[..n]);
            assert_eq!(&u[..], &many[..n]);
            assert_eq!((&u).into_iter().count(), n);
        }
    }
}

mod text {
    use g1tess::internals::{echo, parse_f64, parse_i64, split, statements};

    #[test]
    fn number_parsers_agree_with_std() {
        // Decimal strings of every shape a mesh file holds, and some it should not.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let mut cases: Vec<String> = [
            "0",
            "-0",
            "+0",
            "0.",
            ".5",
            "-.5",
            "+.5",
            ".",
            "-",
            "+",
            "",
            "1.2.3",
            "1e5",
            "-1.5E-3",
            "inf",
            "-infinity",
            "NaN",
            "0x10",
            "1_0",
            " 1",
            "00012.5000",
            "0.30000000000000004",
            "123456789012345",
            "1234567890123456",
            "9007199254740993",
            "0.0000000000000000000001",
            "0.00000000000000000000001",
            "1.7976931348623157e308",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        for _ in 0..20000 {
            let r = next();
            let digits = (r % 20) as usize + 1;
            let point = (r >> 8) as usize % (digits + 1);
            let mut s = String::new();
            if r & (1 << 20) != 0 {
                s.push('-');
            }
            for k in 0..digits {
                if k == point {
                    s.push('.');
                }
                s.push((b'0' + (next() % 10) as u8) as char);
            }
            cases.push(s);
            let x = f64::from_bits(next()).abs();
            if x.is_finite() {
                cases.push(format!("{x:?}"));
                cases.push(format!("{:.6}", x % 1e6));
            }
        }
        for s in &cases {
            let want = s.parse::<f64>().ok().map(f64::to_bits);
            assert_eq!(parse_f64(s).map(f64::to_bits), want, "'{s}'");
            assert_eq!(parse_i64(s), s.parse::<i64>().ok(), "'{s}'");
        }
        for s in [
            "99999999999999999999",
            "-9223372036854775808",
            "9223372036854775807",
            "+7",
        ] {
            assert_eq!(parse_i64(s), s.parse::<i64>().ok(), "'{s}'");
        }
    }

    #[test]
    fn statements_follow_every_line_ending_and_continuations() {
        let collect = |text: &str| {
            let mut out = Vec::new();
            let n = statements(std::path::Path::new("t"), text, 1, true, |line, s| {
                out.push((line, s.to_string()));
                Ok(())
            })
            .unwrap();
            (n, out)
        };
        let want = vec![
            (1, "a".to_string()),
            (2, "b  c".to_string()),
            (4, "d".to_string()),
        ];
        for nl in ["\n", "\r\n", "\r"] {
            let text = format!("a{nl}b \\{nl}c{nl}d{nl}");
            assert_eq!(collect(&text), (4, want.clone()), "{text:?}");
        }
        // A continuation on the last line, with and without a final newline.
        assert_eq!(collect("x\\").1, vec![(1, "x ".to_string())]);
        assert_eq!(collect("x\\\n").1, vec![(1, "x ".to_string())]);
        // Splitting never cuts a statement, a CRLF or a continuation.
        let text = "v 1\r\nv 2 \\\r\n3\rf 1\n\nf 2\\\n\\\nx\r";
        for n in 1..=text.len() {
            let pieces = split(text.as_bytes(), n);
            let mut all = Vec::new();
            let mut line = 1;
            for p in &pieces {
                let p = std::str::from_utf8(p).unwrap();
                line += statements(std::path::Path::new("t"), p, line, true, |l, s| {
                    all.push((l, s.to_string()));
                    Ok(())
                })
                .unwrap();
            }
            assert_eq!((line - 1, all), collect(text), "{n} pieces: {pieces:?}");
        }
    }

    #[test]
    fn echo_escapes_and_cuts() {
        assert_eq!(echo("a\u{1b}[1mb\tc"), "a\\u{1b}[1mb\\tc");
        let long = "x".repeat(200);
        assert_eq!(echo(&long), format!("{}…", "x".repeat(80)));
        assert_eq!(echo("é"), "é");
    }
}
