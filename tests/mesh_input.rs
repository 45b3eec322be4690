//! Mesh input: OBJ face forms, negative indices, groups, welding, unused vertices, normals,
//! adjacency, built-in meshes.

#![allow(clippy::needless_range_loop)]

use crate::common;

use std::path::PathBuf;

use g1tess::generators::{icosphere, torus, TorusNormals};
use g1tess::vertex_normals;
use g1tess::{LoadOptions, Mesh, NormalWeighting};
use glam::DVec3;

fn write_obj(name: &str, text: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("mesh_input");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn load_path(p: &std::path::Path, opts: &LoadOptions) -> Mesh {
    Mesh::load(p.to_str().unwrap(), opts).unwrap()
}

const CUBE_V: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";

#[test]
fn every_face_form_and_negative_indices() {
    // One quad per face form; the last uses negative indices. All describe the same square.
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
                vn 0 0 2\n\
                f 1 2 3 4\nf 1/1 2/2 3/3 4/4\nf 1//1 2//1 3//1 4//1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n\
                f -4/-4/-1 -3/-3/-1 -2/-2/-1 -1/-1/-1\n";
    let p = write_obj("forms.obj", text);
    let m = load_path(&p, &LoadOptions::default());
    assert_eq!(m.positions.len(), 4);
    assert_eq!(m.triangles.len(), 10);
    assert_eq!(m.load_report.polygons_triangulated, 5);
    // The first two quads have no normals: estimated (+z); the others give vn renormalised.
    // Axis-aligned: exact up to one rounding of a unit vector (1e-15 ≈ 4 ulps of 1).
    for n in m.corner_normals.iter().flatten() {
        assert!((n.length() - 1.0).abs() < 1e-15);
        assert!((*n - DVec3::Z).length() < 1e-15);
    }
    assert_eq!(m.load_report.normals_estimated, 12);
    // Every triangle keeps the file's counter-clockwise orientation (normal +z).
    for t in &m.triangles {
        let q = t.map(|v| m.positions[v as usize]);
        assert!((q[1] - q[0]).cross(q[2] - q[0]).z > 0.0);
    }
}

#[test]
fn groups_merge_weld_and_drop_unused_vertices() {
    // Two objects sharing an edge by coordinates (duplicated vertices), plus an unused vertex.
    let text = "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n\
                o b\ng g1\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 5 5 5\nf 4 5 6\n";
    let p = write_obj("groups.obj", text);
    let m = load_path(&p, &LoadOptions::default());
    assert_eq!(m.triangles.len(), 2);
    assert_eq!(m.positions.len(), 4, "duplicated corners welded");
    assert_eq!(m.load_report.vertices_welded, 2);
    assert_eq!(m.load_report.unused_vertices_dropped, 1);
    let adj = m.adjacency();
    assert_eq!((adj.interior, adj.boundary, adj.nonmanifold), (1, 4, 0));
}

#[test]
fn per_corner_normals_are_kept() {
    // A vertex with different normals in its two faces (a crease): both kept.
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvn 0 1 1\n\
                f 1//1 2//1 3//1\nf 2//2 4//2 3//2\n";
    let p = write_obj("split.obj", text);
    let m = load_path(&p, &LoadOptions::default());
    let s = 0.5f64.sqrt();
    assert_eq!(m.corner_normals[0][1], DVec3::Z);
    // (0, 1, 1) normalised once: an ulp or two of (0, √½, √½).
    assert!((m.corner_normals[1][0] - DVec3::new(0.0, s, s)).length() < 1e-15);
}

#[test]
fn adjacency_detects_nonmanifold_and_misoriented_edges() {
    // Three triangles on edge (1,2): non-manifold; the rest of their edges are boundary.
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\n\
                f 1 2 3\nf 2 1 4\nf 1 2 5\n";
    let p = write_obj("nonmanifold.obj", text);
    let adj = load_path(&p, &LoadOptions::default()).adjacency();
    assert_eq!((adj.nonmanifold, adj.interior, adj.boundary), (1, 0, 6));
    // Two triangles running along their shared edge (1,2) in the same direction.
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nf 1 2 3\nf 1 2 4\n";
    let p = write_obj("misoriented.obj", text);
    let adj = load_path(&p, &LoadOptions::default()).adjacency();
    assert_eq!((adj.nonmanifold, adj.interior, adj.misoriented), (0, 1, 1));
}

#[test]
fn suzanne_topology() {
    let m = common::load("suzanne.obj");
    let adj = m.adjacency();
    assert_eq!(adj.boundary, 42);
    assert_eq!(adj.nonmanifold, 1);
    assert!(m.load_report.polygons_triangulated > 0);
}

#[test]
fn normal_weightings_on_a_known_fan() {
    // Vertex 0 at the origin with two faces: a large one in the z=0 plane spanning 90°, a
    // small one in the x=0 plane spanning 45°.
    let pos = vec![
        DVec3::ZERO,
        DVec3::new(4.0, 0.0, 0.0),
        DVec3::new(0.0, 4.0, 0.0),
        DVec3::new(0.0, 1.0, 1.0),
        DVec3::new(0.0, 0.0, 1.0),
    ];
    let tris = vec![[0, 1, 2], [0, 3, 4]];
    // Face normals: +z (area 8, angle 90°) and +x (area 0.5... angle 45°).
    let nz = DVec3::Z;
    let nx = (pos[3] - pos[0]).cross(pos[4] - pos[0]).normalize();
    // Cross product of small integer vectors (exact), normalised once.
    assert!((nx - DVec3::X).length() < 1e-15);
    let expect = |wz: f64, wx: f64| (wz * nz + wx * nx).normalize();
    let cases = [
        (NormalWeighting::Unweighted, expect(1.0, 1.0)),
        (NormalWeighting::Area, expect(8.0, 0.5)),
        (
            NormalWeighting::Angle,
            expect(std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_4),
        ),
    ];
    for (w, e) in cases {
        let n = vertex_normals(&pos, &tris, w);
        // Two weighted unit normals summed and normalised, here and in the loader: a few
        // roundings of unit-size values.
        assert!((n[0] - e).length() < 1e-15, "{w:?}: {:?} vs {e:?}", n[0]);
    }
}

#[test]
fn recompute_normals_option_overrides_file_normals() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1 0 0\nf 1//1 2//1 3//1\n";
    let p = write_obj("recompute.obj", text);
    let keep = load_path(&p, &LoadOptions::default());
    assert_eq!(keep.corner_normals[0][0], DVec3::X);
    let re = load_path(&p, &LoadOptions::default().with_recompute_normals(true));
    assert_eq!(re.corner_normals[0][0], DVec3::Z);
}

#[test]
fn builtin_meshes_match_their_definitions() {
    let s = Mesh::load("sphere320", &LoadOptions::default()).unwrap();
    assert_eq!((s.triangles.len(), s.positions.len()), (320, 162));
    for (t, tri) in s.triangles.iter().enumerate() {
        for k in 0..3 {
            let p = s.positions[tri[k] as usize];
            // Vertices normalised once, normals equal to them: one rounding of unit values.
            assert!((p.length() - 1.0).abs() < 1e-15);
            assert!(
                (s.corner_normals[t][k] - p).length() < 1e-15,
                "exact normals"
            );
        }
        let q = tri.map(|v| s.positions[v as usize]);
        assert!(
            (q[1] - q[0]).cross(q[2] - q[0]).dot(q[0]) > 0.0,
            "outward winding"
        );
    }
    assert_eq!(s.adjacency().boundary, 0);

    let t = Mesh::load("torus200", &LoadOptions::default()).unwrap();
    assert_eq!((t.triangles.len(), t.positions.len()), (200, 100));
    // Averaged normals: the unweighted mean of the incident face normals.
    let avg = vertex_normals(&t.positions, &t.triangles, NormalWeighting::Unweighted);
    for (tri, cn) in t.triangles.iter().zip(&t.corner_normals) {
        for k in 0..3 {
            // The same mean of unit normals: at most a few roundings of unit-size values.
            assert!((cn[k] - avg[tri[k] as usize]).length() < 1e-15);
        }
    }
    // Outer equator vertex (u = 0, v = 0) at (1.5, 0, 0) with normal close to +x.
    // cos 0 = 1 and sin 0 = 0: exact up to one rounding.
    assert!((t.positions[0] - DVec3::new(1.5, 0.0, 0.0)).length() < 1e-15);
    let analytic = torus(10, 10, 1.0, 0.5, TorusNormals::Analytic);
    for (tri, cn) in analytic.triangles.iter().zip(&analytic.corner_normals) {
        for k in 0..3 {
            let p = analytic.positions[tri[k] as usize];
            let ring = DVec3::new(p.x, p.y, 0.0).normalize();
            // Trigonometric normals vs normalised differences of rounded positions: a few
            // dozen roundings of unit-size values.
            assert!((cn[k] - (p - ring).normalize()).length() < 1e-14);
        }
        let q = tri.map(|v| analytic.positions[v as usize]);
        let c = (q[0] + q[1] + q[2]) / 3.0;
        let ring = DVec3::new(c.x, c.y, 0.0).normalize();
        assert!(
            (q[1] - q[0]).cross(q[2] - q[0]).dot(c - ring) > 0.0,
            "outward winding"
        );
    }
    assert_eq!(icosphere(3).triangles.len(), 1280);
    assert_eq!(
        Mesh::load("torus:5x7:analytic", &LoadOptions::default())
            .unwrap()
            .triangles
            .len(),
        70
    );
    assert_eq!(
        Mesh::load("icosphere:0", &LoadOptions::default())
            .unwrap()
            .triangles
            .len(),
        20
    );
}

#[test]
fn non_unit_normals_are_renormalised() {
    // Blender writes normals to 4 decimals: G1 must not lose digits because of it.
    let s = icosphere(2);
    let mut text = String::new();
    for p in &s.positions {
        text += &format!("v {:?} {:?} {:?}\n", p.x, p.y, p.z);
    }
    for p in &s.positions {
        text += &format!("vn {:.4} {:.4} {:.4}\n", 3.0 * p.x, 3.0 * p.y, 3.0 * p.z);
    }
    for t in &s.triangles {
        let [a, b, c] = t.map(|v| v + 1);
        text += &format!("f {a}//{a} {b}//{b} {c}//{c}\n");
    }
    let p = write_obj("rounded.obj", &text);
    let m = load_path(&p, &LoadOptions::default());
    // Renormalised on load: unit up to one rounding (1e-15 ≈ 4 ulps of 1).
    for n in m.corner_normals.iter().flatten() {
        assert!((n.length() - 1.0).abs() < 1e-15);
    }
    let table = g1tess::PatchTable::build(&m, g1tess::Scheme::G1, &Default::default()).unwrap();
    let c =
        g1tess::continuity(&m, &m.adjacency(), &table, &g1tess::CpuEvaluator::default()).unwrap();
    // G1 to f64 rounding (~1e-16); 1e-12 is far above that and far below any real kink.
    assert!(
        1.0 - c.cos.min <= 1e-12,
        "1 - min cos = {:e}",
        1.0 - c.cos.min
    );
}

#[test]
fn cube_without_normals_is_closed() {
    let text =
        format!("{CUBE_V}f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n");
    let p = write_obj("cube.obj", &text);
    let m = load_path(&p, &LoadOptions::default());
    let adj = m.adjacency();
    assert_eq!(
        (
            m.triangles.len(),
            adj.interior,
            adj.boundary,
            adj.misoriented
        ),
        (12, 18, 0, 0)
    );
    // Angle-weighted normal at a cube corner is the diagonal direction.
    let d = DVec3::splat(1.0).normalize();
    let i = m.positions.iter().position(|p| *p == DVec3::ONE).unwrap() as u32;
    for (t, tri) in m.triangles.iter().enumerate() {
        for k in 0..3 {
            if tri[k] == i {
                // Three axis normals with equal weights, summed and normalised: one rounding.
                assert!((m.corner_normals[t][k] - d).length() < 1e-15);
            }
        }
    }
}

/// The regular octahedron as a renderer holds it: every face with its own three vertices
/// (24 in all) and, as normals, the face normal on each of them.
fn split_octahedron() -> (Vec<DVec3>, Vec<[u32; 3]>, Vec<DVec3>) {
    let (mut pos, mut tris, mut nrm) = (Vec::new(), Vec::new(), Vec::new());
    for sx in [1.0, -1.0] {
        for sy in [1.0, -1.0] {
            for sz in [1.0, -1.0] {
                let mut f = [
                    DVec3::new(sx, 0.0, 0.0),
                    DVec3::new(0.0, sy, 0.0),
                    DVec3::new(0.0, 0.0, sz),
                ];
                if sx * sy * sz < 0.0 {
                    f.swap(1, 2); // counter-clockwise seen from outside
                }
                let base = pos.len() as u32;
                tris.push([base, base + 1, base + 2]);
                pos.extend(f);
                nrm.extend([DVec3::new(sx, sy, sz); 3]);
            }
        }
    }
    (pos, tris, nrm)
}

/// Writes a coordinate as OBJ text; `neg_zero` spells zeros as `-0` (what some exporters
/// write after a mirror or a negation).
fn coord(x: f64, neg_zero: bool) -> String {
    if x == 0.0 && neg_zero {
        "-0".to_string()
    } else {
        format!("{x:?}")
    }
}

#[test]
fn signed_zeros_weld_in_every_reader() {
    let (pos, tris, nrm) = split_octahedron();
    // OBJ: the faces of odd index spell their zeros as -0, the others as 0.
    let mut obj = String::new();
    for (i, p) in pos.iter().enumerate() {
        let neg = (i / 3) % 2 == 1;
        obj += &format!(
            "v {} {} {}\n",
            coord(p.x, neg),
            coord(p.y, neg),
            coord(p.z, neg)
        );
    }
    for t in &tris {
        obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    let m = load_path(
        &write_obj("octa-signed-zero.obj", &obj),
        &LoadOptions::default(),
    );
    let adj = m.adjacency();
    assert_eq!(m.positions.len(), 6);
    assert_eq!((adj.interior, adj.boundary, adj.misoriented), (12, 0, 0));
    assert_eq!(m.load_report.vertices_welded, 18);
    // The welded positions carry +0.0.
    assert!(m
        .positions
        .iter()
        .flat_map(|p| p.to_array())
        .all(|x| x != 0.0 || x.is_sign_positive()));

    // The same soup as a .pn file, with -0.0 on the faces of odd index.
    let mut pn = format!("g1tess-pn 1\ncounts {} {} 0\n", pos.len(), tris.len());
    for (i, (p, n)) in pos.iter().zip(&nrm).enumerate() {
        let neg = (i / 3) % 2 == 1;
        pn += &format!(
            "v {} {} {} {} {} {}\n",
            coord(p.x, neg),
            coord(p.y, neg),
            coord(p.z, neg),
            n.x,
            n.y,
            n.z
        );
    }
    for t in &tris {
        pn += &format!("t {} {} {}\n", t[0], t[1], t[2]);
    }
    let m = load_path(
        &write_obj("octa-signed-zero.pn", &pn),
        &LoadOptions::default(),
    );
    let adj = m.adjacency();
    assert_eq!((m.positions.len(), adj.interior, adj.boundary), (6, 12, 0));

    // An open 4 × 4 grid of quads in z = 0 written as two objects meeting at x = 0; the
    // right one spells every zero as -0. Welded, the seam disappears: only the 16 perimeter
    // edges are boundary, and 3·32 half-edges − 16 = 2·40 are interior.
    let mut obj = String::new();
    let mut nv = 0;
    for (half, neg) in [(-2i32..=0, false), (0i32..=2, true)] {
        let xs: Vec<i32> = half.collect();
        let base = nv;
        for &x in &xs {
            for y in 0..=4 {
                let q = [x as f64, y as f64, 0.0].map(|c| coord(c, neg));
                obj += &format!("v {} {} {}\n", q[0], q[1], q[2]);
                nv += 1;
            }
        }
        let id = |i: usize, j: usize| base + i * 5 + j + 1;
        for i in 0..xs.len() - 1 {
            for j in 0..4 {
                obj += &format!(
                    "f {} {} {} {}\n",
                    id(i, j),
                    id(i + 1, j),
                    id(i + 1, j + 1),
                    id(i, j + 1)
                );
            }
        }
    }
    let m = load_path(&write_obj("grid-seam.obj", &obj), &LoadOptions::default());
    let adj = m.adjacency();
    assert_eq!(m.triangles.len(), 32);
    assert_eq!(m.positions.len(), 25);
    assert_eq!((adj.interior, adj.boundary, adj.nonmanifold), (40, 16, 0));
    assert_eq!(m.load_report.vertices_welded, 5);
}

#[test]
fn soup_constructor_welds_a_split_vertex_octahedron() {
    let (pos, tris, nrm) = split_octahedron();
    // Flip the sign of every zero on half the faces: still the same points.
    let pos: Vec<DVec3> = pos
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if (i / 3) % 2 == 1 {
                p.map(|x| if x == 0.0 { -0.0 } else { x })
            } else {
                *p
            }
        })
        .collect();
    let m = Mesh::from_soup("octa", &pos, &tris, Some(&nrm), &LoadOptions::default()).unwrap();
    let adj = m.adjacency();
    assert_eq!((m.positions.len(), m.triangles.len()), (6, 8));
    assert_eq!((adj.interior, adj.boundary, adj.misoriented), (12, 0, 0));
    assert_eq!(m.load_report.vertices_welded, 18);
    assert_eq!(m.load_report.normals_estimated, 0);
    // Each corner keeps its face's normal, renormalised: the split normals survive.
    for (t, cn) in m.triangles.iter().zip(&m.corner_normals) {
        let q = t.map(|v| m.positions[v as usize]);
        let face = (q[0] + q[1] + q[2]).normalize();
        for n in cn {
            // (±1, ±1, ±1) / √3 against the normalised centroid: the same unit vector up to
            // one rounding of each.
            assert!((*n - face).length() < 1e-15, "{n:?} vs {face:?}");
        }
    }

    // Without normals they are estimated: at (1, 0, 0) the four faces' normals average to
    // +x, and with arrays instead of glam vectors.
    let arrays: Vec<[f64; 3]> = pos.iter().map(|p| p.to_array()).collect();
    let m = Mesh::from_soup("octa", &arrays, &tris, None, &LoadOptions::default()).unwrap();
    assert_eq!(m.load_report.normals_estimated, 24);
    let x = m.positions.iter().position(|p| *p == DVec3::X).unwrap() as u32;
    for (t, cn) in m.triangles.iter().zip(&m.corner_normals) {
        for k in 0..3 {
            if t[k] == x {
                // Four symmetric unit normals summed: exact up to a rounding per addition.
                assert!((cn[k] - DVec3::X).length() < 1e-15);
            }
        }
    }
}

#[test]
fn soup_constructor_rejects_bad_input_naming_the_element() {
    let p = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let t = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    let opts = LoadOptions::default();
    let err = |r: g1tess::Result<Mesh>| r.unwrap_err().to_string();
    let mut bad = p.clone();
    bad[2][1] = f64::NAN;
    assert_eq!(
        err(Mesh::from_soup("soup", &bad, &t, None, &opts)),
        "soup: vertex 2 has a non-finite coordinate"
    );
    bad[2][1] = f64::NEG_INFINITY;
    assert!(err(Mesh::from_soup("soup", &bad, &t, None, &opts)).contains("vertex 2 "));
    assert_eq!(
        err(Mesh::from_soup("soup", &p, &[[0, 1, 4]], None, &opts)),
        "soup: triangle 0 has vertex index 4, out of range (the soup has 4 vertices)"
    );
    let n = vec![[0.0, 0.0, 1.0]; 3];
    assert_eq!(
        err(Mesh::from_soup("soup", &p, &t, Some(&n), &opts)),
        "soup: 3 normals for 4 vertices (one per vertex expected)"
    );
    let mut n = vec![[0.0, 0.0, 1.0]; 4];
    n[3] = [0.0, 0.0, 0.0];
    assert_eq!(
        err(Mesh::from_soup("soup", &p, &t, Some(&n), &opts)),
        "soup: normal 3 is zero or non-finite"
    );
    n[3] = [f64::NAN, 0.0, 1.0];
    assert!(err(Mesh::from_soup("soup", &p, &t, Some(&n), &opts)).contains("normal 3"));
    assert_eq!(
        err(Mesh::from_soup("soup", &p, &[], None, &opts)),
        "soup: empty mesh: no triangles"
    );
    assert_eq!(
        err(Mesh::from_soup("soup", &p, &[[0, 1, 1]], None, &opts)),
        "soup: empty mesh: every triangle is degenerate"
    );
    // A good soup: closed, every normal a unit vector, counts in the report.
    let m = Mesh::from_soup("soup", &p, &t, None, &opts).unwrap();
    assert_eq!(m.adjacency().boundary, 0);
    assert_eq!(m.name, "soup");
}

#[test]
fn line_endings_byte_order_mark_and_continuations() {
    // The same tetrahedron with every line ending, a BOM, and a face continued over lines.
    let lines = [
        "v 0 0 0",
        "v 1 0 0",
        "v 0 1 0",
        "v 0 0 1",
        "f 1 3 2",
        "f 1 2 \\",
        "4",
        "f 1 4 3",
        "f 2 3 4 \\",
    ];
    let reference = Mesh::from_soup(
        "tetra",
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        &[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        None,
        &LoadOptions::default(),
    )
    .unwrap();
    for (i, (nl, bom, last_nl)) in [
        ("\n", "", true),
        ("\r\n", "", true),
        ("\r", "", true),
        ("\n", "\u{feff}", true),
        ("\r\n", "\u{feff}", false),
        ("\r", "", false),
    ]
    .into_iter()
    .enumerate()
    {
        let mut text = format!("{bom}{}", lines.join(nl));
        if last_nl {
            text += nl;
        }
        let m = load_path(
            &write_obj(&format!("endings{i}.obj"), &text),
            &LoadOptions::default(),
        );
        // The last face, continued at the end of the file, is read too.
        assert_eq!(corners(&m), corners(&reference), "case {i}");
        assert_eq!(m.adjacency().boundary, 0);
        // Line numbers count each ending once; a continued statement has its first line.
        let bad = text.replace("f 1 4 3", "f 1 4 x");
        let e = Mesh::load(
            write_obj(&format!("endings-bad{i}.obj"), &bad)
                .to_str()
                .unwrap(),
            &LoadOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.ends_with(":8: face corner 'x': 'x' is not an index"),
            "{e}"
        );
        let bad = text.replace("\\", "x \\");
        let e = Mesh::load(
            write_obj(&format!("endings-cont{i}.obj"), &bad)
                .to_str()
                .unwrap(),
            &LoadOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains(":6: face corner 'x'"), "{e}");
    }
}

#[test]
fn errors_escape_and_cut_the_input_they_quote() {
    let text = format!(
        "v 0 0 0\nv 1 0 0\nv 0 \u{1b}[31m 0\nf 1 2 {}\n",
        "9".repeat(300)
    );
    let e = Mesh::load(
        write_obj("escape.obj", &text).to_str().unwrap(),
        &LoadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.ends_with(":3: vertex: '\\u{1b}[31m' is not a number"),
        "{e}"
    );
    let text = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/{}\n", "x".repeat(300));
    let e = Mesh::load(
        write_obj("long.obj", &text).to_str().unwrap(),
        &LoadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains(":4: face corner '3/xxxxx"), "{e}");
    assert!(e.contains(&format!("'3/{}…'", "x".repeat(78))), "{e}");
    assert!(
        e.contains(&format!("'{}…' is not an index", "x".repeat(80))),
        "{e}"
    );
}

/// Each triangle's corner positions: a mesh independent of how its vertices are numbered.
fn corners(m: &Mesh) -> Vec<[DVec3; 3]> {
    m.triangles
        .iter()
        .map(|t| t.map(|v| m.positions[v as usize]))
        .collect()
}

/// A grid of `n` × `n` vertices on a wavy sheet as OBJ text, written row by row: each row's
/// vertices and normals, then the faces between it and the previous row, with negative
/// (relative) indices on odd rows and positive ones on even rows. Returns the text, the line
/// of each row's first face, and the soup it describes.
fn wavy_sheet(n: usize) -> (String, Vec<usize>, Soup) {
    let (mut pos, mut nrm, mut tris) = (Vec::new(), Vec::new(), Vec::new());
    let mut text = String::from("# a wavy sheet\r\n");
    let mut face_line = vec![0; n];
    let mut line = 2;
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (i as f64 / 7.0, j as f64 / 3.0);
            let p = DVec3::new(x, y, (x * 0.9).sin() * (y * 1.3).cos());
            let nn = DVec3::new(-(x * 0.9).cos() * 0.9, (y * 1.3).sin() * 1.3, 1.0);
            text += &format!(
                "v {:?} {:?} {:?}\nvn {} {} {}\n",
                p.x, p.y, p.z, nn.x, nn.y, nn.z
            );
            line += 2;
            pos.push(p);
            nrm.push(nn);
        }
        if i == 0 {
            continue;
        }
        face_line[i] = line;
        for j in 0..n - 1 {
            let id = |a: usize, b: usize| (a * n + b) as u32;
            let q = [id(i - 1, j), id(i, j), id(i, j + 1), id(i - 1, j + 1)];
            tris.push([q[0], q[1], q[2]]);
            tris.push([q[0], q[2], q[3]]);
            let c: Vec<String> = q
                .iter()
                .map(|&v| {
                    if i % 2 == 1 {
                        let r = v as i64 - (i as i64 + 1) * n as i64;
                        format!("{r}//{r}")
                    } else {
                        format!("{}//{}", v + 1, v + 1)
                    }
                })
                .collect();
            text += &format!("f {}\n", c.join(" "));
            line += 1;
        }
    }
    (text, face_line, (pos, tris, nrm))
}

/// Positions, triangles and one normal per position.
type Soup = (Vec<DVec3>, Vec<[u32; 3]>, Vec<DVec3>);

#[test]
fn a_large_file_reads_like_its_soup_and_names_lines_deep_inside() {
    // 350 × 350 vertices: about 16 MB of text, two chunks of many blocks each, so
    // relative indices reach back across block and chunk boundaries.
    let n = 350;
    let (text, face_line, (pos, tris, nrm)) = wavy_sheet(n);
    assert!(text.len() > 12 << 20, "{} bytes", text.len());
    let soup = Mesh::from_soup("sheet", &pos, &tris, Some(&nrm), &LoadOptions::default()).unwrap();
    let p = write_obj("sheet.obj", &text);
    let m = load_path(&p, &LoadOptions::default());
    assert_eq!(m.positions.len(), n * n);
    // Every coordinate back bit for bit, every corner normal the one given (renormalised).
    assert_eq!(corners(&m), corners(&soup));
    assert_eq!(m.corner_normals, soup.corner_normals);
    assert_eq!(m.load_report.polygons_triangulated, (n - 1) * (n - 1));
    let adj = m.adjacency();
    assert_eq!(adj.boundary, 4 * (n - 1));

    let lines: Vec<&str> = text.split('\n').collect();
    let fails = |name: &str, edit: &dyn Fn(&mut Vec<String>)| -> String {
        let mut l: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
        edit(&mut l);
        let p = write_obj(name, &l.join("\n"));
        let r = Mesh::load(p.to_str().unwrap(), &LoadOptions::default());
        std::fs::remove_file(&p).unwrap();
        r.err().map(|e| e.to_string()).unwrap_or_default()
    };
    // Line numbers count from 1; `lines[k]` is line k + 1 (the first ends in \r\n).
    let row = 241; // odd: relative indices
    let at = face_line[row];
    let e = fails("sheet-nan.obj", &|l| l[at - 3] = "v 0 nan 0".into());
    assert!(
        e.ends_with(&format!(":{}: vertex: non-finite coordinate 'nan'", at - 2)),
        "{e}"
    );
    let e = fails("sheet-back.obj", &|l| l[at + 5] = "f -1 -2 -9999999".into());
    let have = (row + 1) * n;
    assert!(
        e.ends_with(&format!(
            ":{}: face corner '-9999999': vertex index -9999999 out of range (only {have} vertices so far)",
            at + 6
        )),
        "{e}"
    );
    let e = fails("sheet-forward.obj", &|l| l[at + 7] = "f 1 2 9999999".into());
    assert!(
        e.ends_with(&format!(
            ":{}: face corner '9999999': vertex index 9999999 out of range (the file has {} vertices)",
            at + 8,
            n * n
        )),
        "{e}"
    );
    let e = fails("sheet-normal.obj", &|l| {
        l[at + 9] = "f 1//1 2//2 3//999999".into()
    });
    assert!(
        e.ends_with(&format!(
            ":{}: face corner '3//999999': normal index 999999 out of range (the file has {} normals)",
            at + 10,
            n * n
        )),
        "{e}"
    );
}

#[test]
fn a_large_file_with_normals_on_some_faces_estimates_the_others() {
    // The wavy sheet (about 12 MB, read in parallel blocks) with the normals cut from the
    // faces of its first 40 % and last 30 % of rows and of every fifth band of 11 rows
    // between: blocks with no normal index at all come before and after blocks with some,
    // and bands start and end inside blocks. Each corner must get the normal given for its
    // vertex where its face gives one and, elsewhere, the normal estimated for the sheet
    // (both as the soup of the same sheet gets them); every position as given.
    let n = 300;
    let (text, face_line, (pos, tris, nrm)) = wavy_sheet(n);
    assert!(text.len() > 10 << 20, "{} bytes", text.len());
    let strip = |line: &str| -> String {
        let corners: Vec<&str> = line[2..]
            .split(' ')
            .map(|c| c.split('/').next().unwrap())
            .collect();
        format!("f {}", corners.join(" "))
    };
    let banded = |cut: &dyn Fn(usize) -> bool| -> String {
        let mut row = 0;
        let mut out = String::with_capacity(text.len());
        for (k, line) in text.split_inclusive('\n').enumerate() {
            // Rows 1.. start at their first face line (line numbers count from 1).
            while row + 1 < n && face_line[row + 1] == k + 1 {
                row += 1;
            }
            if line.starts_with("f ") && cut(row) {
                out += &strip(line.trim_end());
                out.push('\n');
            } else {
                out += line;
            }
        }
        out
    };
    let opts = LoadOptions::default();
    let given = Mesh::from_soup("sheet", &pos, &tris, Some(&nrm), &opts).unwrap();
    let none = Mesh::from_soup("sheet", &pos, &tris, None, &opts).unwrap();
    let all = load_path(&write_obj("sheet-all.obj", &text), &opts);
    let bare = load_path(&write_obj("sheet-none.obj", &banded(&|_| true)), &opts);
    assert_eq!(all.corner_normals, given.corner_normals);
    assert_eq!(bare.corner_normals, none.corner_normals);
    let cut = |row: usize| 5 * row < 2 * n || 10 * row >= 7 * n || (row / 11).is_multiple_of(5);
    let mixed = load_path(&write_obj("sheet-mixed.obj", &banded(&cut)), &opts);
    // Faces per row of the sheet (rows 1 to n - 1).
    let per_row = 2 * (n - 1);
    let cut_faces = (1..n).filter(|&r| cut(r)).count() * per_row;
    assert_eq!(all.load_report.normals_estimated, 0);
    assert_eq!(bare.load_report.normals_estimated, 3 * per_row * (n - 1));
    assert_eq!(mixed.load_report.normals_estimated, 3 * cut_faces);
    assert_eq!(corners(&mixed), corners(&given));
    assert_eq!(corners(&bare), corners(&given));
    for (f, normals) in mixed.corner_normals.iter().enumerate() {
        let want = if cut(f / per_row + 1) { &none } else { &given };
        assert_eq!(*normals, want.corner_normals[f], "face {f}");
    }
    // The two sources differ (or the test would prove nothing).
    assert_ne!(none.corner_normals[0], given.corner_normals[0]);
}

#[test]
fn a_large_point_normal_file_reads_like_its_soup_and_names_lines_deep_inside() {
    // The wavy sheet as .pn, with a corner normal on every 50th triangle: about 14 MB,
    // two chunks of parallel blocks.
    let n = 330;
    let (_, _, (pos, tris, nrm)) = wavy_sheet(n);
    let mut text = format!(
        "g1tess-pn 1\n# a wavy sheet\ncounts {} {} {}\n",
        pos.len(),
        tris.len(),
        tris.len().div_ceil(50)
    );
    for (p, q) in pos.iter().zip(&nrm) {
        text += &format!(
            "v {:?} {:?} {:?} {:?} {:?} {:?}\n",
            p.x, p.y, p.z, q.x, q.y, q.z
        );
    }
    let t_line = text.lines().count() + 1;
    for t in &tris {
        text += &format!("t {} {} {}\n", t[0], t[1], t[2]);
    }
    for t in (0..tris.len()).step_by(50) {
        text += &format!("c {t} 1 0 0 1\n");
    }
    assert!(text.len() > 10 << 20, "{} bytes", text.len());
    let mut soup =
        Mesh::from_soup("sheet", &pos, &tris, Some(&nrm), &LoadOptions::default()).unwrap();
    for t in (0..tris.len()).step_by(50) {
        soup.corner_normals[t][1] = DVec3::Z;
    }
    let m = load_path(&write_obj("sheet.pn", &text), &LoadOptions::default());
    assert_eq!(m.positions, soup.positions);
    assert_eq!(m.triangles, soup.triangles);
    assert_eq!(m.corner_normals, soup.corner_normals);

    let lines: Vec<&str> = text.lines().collect();
    let fails = |name: &str, line: usize, new: &str| -> String {
        let mut l = lines.clone();
        l[line - 1] = new;
        let p = write_obj(name, &l.join("\n"));
        let r = Mesh::load(p.to_str().unwrap(), &LoadOptions::default());
        std::fs::remove_file(&p).unwrap();
        r.err().map(|e| e.to_string()).unwrap_or_default()
    };
    let deep = t_line + 150_000;
    let e = fails("sheet-range.pn", deep, "t 0 1 999999");
    assert!(
        e.ends_with(&format!(
            ":{deep}: triangle: vertex index 999999 out of range (the file has {} vertices)",
            n * n
        )),
        "{e}"
    );
    let e = fails("sheet-bad.pn", deep, "t 0 1 x");
    assert!(
        e.ends_with(&format!(
            ":{deep}: triangle: 'x' is not an index (0-based integer)"
        )),
        "{e}"
    );
    let last = lines.len();
    let e = fails("sheet-twice.pn", last, "c 0 1 0 0 1");
    assert!(
        e.ends_with(&format!(
            ":{last}: corner normal: corner 1 of triangle 0 given twice"
        )),
        "{e}"
    );
    let e = fails("sheet-counts.pn", deep, "counts 1 1 1");
    assert!(
        e.ends_with(&format!(":{deep}: a second 'counts' line")),
        "{e}"
    );
}

/// Loads `text` as a file named `name`, expecting an error; returns its message.
fn load_err(name: &str, text: impl AsRef<[u8]>) -> String {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("mesh_input");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    Mesh::load(p.to_str().unwrap(), &LoadOptions::default())
        .unwrap_err()
        .to_string()
}

/// Every scheme's patches on `m`, evaluated at corners, edge midpoints and the centre: all
/// finite, normals unit.
fn patches_are_finite(m: &Mesh) {
    use g1tess::{PatchTable, Scheme, SchemeOptions};
    for scheme in Scheme::all() {
        let table = PatchTable::build(m, scheme, &SchemeOptions::default())
            .unwrap_or_else(|e| panic!("{scheme:?} on {}: {e}", m.name));
        for i in 0..table.len() {
            for b in [[1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [1.0 / 3.0; 3]] {
                let sp = table.eval(i, b);
                assert!(sp.p.is_finite(), "{scheme:?} {} patch {i}", m.name);
                // Unit normals up to rounding of one normalisation.
                assert!(
                    (sp.n.length() - 1.0).abs() < 1e-12,
                    "{scheme:?} {} patch {i}: {}",
                    m.name,
                    sp.n
                );
            }
        }
    }
}

#[test]
fn huge_and_subnormal_normals_are_normalised_in_every_reader() {
    // Lengths overflow (1e300·√2) or underflow (1e-320 squared) if computed directly.
    let s = 0.5f64.sqrt();
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1e300 1e300 0\nvn 0 0 1e-320\n\
                f 1//1 2//2 3//2\n";
    let m = load_path(&write_obj("huge-vn.obj", text), &LoadOptions::default());
    // Within rounding of one normalisation (1e-15, a few ulps), in every reader below.
    assert!((m.corner_normals[0][0] - DVec3::new(s, s, 0.0)).length() < 1e-15);
    assert_eq!(m.corner_normals[0][1], DVec3::Z);
    let pn = "g1tess-pn 1\ncounts 3 1 0\nv 0 0 0 1e300 1e300 0\nv 1 0 0 0 0 1e-320\n\
              v 0 1 0 0 0 -1e308\nt 0 1 2\n";
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("mesh_input");
    std::fs::write(dir.join("huge-vn.pn"), pn).unwrap();
    let m = load_path(&dir.join("huge-vn.pn"), &LoadOptions::default());
    assert!((m.corner_normals[0][0] - DVec3::new(s, s, 0.0)).length() < 1e-15);
    assert_eq!(m.corner_normals[0][1], DVec3::Z);
    assert_eq!(m.corner_normals[0][2], -DVec3::Z);
    let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let n = [[1e300, 1e300, 0.0], [0.0, 0.0, 1e-320], [0.0, 0.0, 1e308]];
    let m = Mesh::from_soup("soup", &p, &[[0, 1, 2]], Some(&n), &LoadOptions::default()).unwrap();
    assert!((m.corner_normals[0][0] - DVec3::new(s, s, 0.0)).length() < 1e-15);
    assert_eq!(m.corner_normals[0][1..], [DVec3::Z, DVec3::Z]);
    // Zero stays an error, naming the line.
    let e = load_err("zero-vn.obj", "v 0 0 0\nvn 0 0 0\n");
    assert!(e.ends_with("zero-vn.obj:2: zero-length normal"), "{e}");
}

/// A regular tetrahedron's corners scaled by `s`, as OBJ text.
fn tetra_obj(s: &str) -> String {
    format!("v 0 0 0\nv {s} 0 0\nv 0 {s} 0\nv 0 0 {s}\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
}

#[test]
fn extreme_coordinates_work_or_are_refused_naming_the_line() {
    // Up to 1e75 in magnitude, and down to edges of 1e-75, every scheme's patches are
    // finite (fourth powers of coordinates stay within f64).
    for s in ["1e75", "-1e75", "1e-70", "1e-75"] {
        let m = load_path(
            &write_obj(&format!("tetra{s}.obj"), &tetra_obj(s)),
            &LoadOptions::default(),
        );
        assert_eq!(m.triangles.len(), 4, "{s}");
        patches_are_finite(&m);
    }
    // Above: refused at the vertex's line, in OBJ, .pn and soups.
    let e = load_err("tetra-big.obj", tetra_obj("1e200"));
    assert!(
        e.ends_with(
            "tetra-big.obj:2: vertex: coordinate '1e200' above 1e75 in magnitude \
             (products of such coordinates overflow)"
        ),
        "{e}"
    );
    let e = load_err(
        "big.pn",
        "g1tess-pn 1\ncounts 3 1 0\nv 0 0 0 0 0 1\nv 0 -2e75 0 0 0 1\nv 0 1 0 0 0 1\nt 0 1 2\n",
    );
    assert!(
        e.ends_with("big.pn:4: vertex: coordinate '-2e75' above 1e75 in magnitude (products of such coordinates overflow)"),
        "{e}"
    );
    let e = Mesh::from_soup(
        "soup",
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1e76]],
        &[[0, 1, 2]],
        None,
        &LoadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with("soup: vertex 2 has a coordinate above 1e75"),
        "{e}"
    );
    // Below: a triangle whose area underflows f64 has no normal; it is dropped like any
    // degenerate triangle, and a mesh of nothing else names its first face.
    let e = load_err("tetra-small.obj", tetra_obj("1e-200"));
    assert!(
        e.contains("tetra-small.obj:5: every face is degenerate"),
        "{e}"
    );
    let text = format!(
        "{}v 5 5 5\nv 5 5 5.5\nv 5 5.5 5\nf 5 6 7\n",
        tetra_obj("1e-200")
    );
    let m = load_path(
        &write_obj("tetra-small-mixed.obj", &text),
        &LoadOptions::default(),
    );
    assert_eq!(m.triangles.len(), 1);
    assert_eq!(m.load_report.degenerate_triangles_dropped, 4);
    assert_eq!(m.load_report.unused_vertices_dropped, 4);
}

#[test]
fn collinear_triangles_are_dropped_and_counted_in_every_reader() {
    // Triangle 2 has three distinct but collinear corners: no normal, dropped.
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n";
    let m = load_path(&write_obj("collinear.obj", text), &LoadOptions::default());
    assert_eq!(m.triangles.len(), 1);
    assert_eq!(m.positions.len(), 3);
    assert_eq!(m.load_report.degenerate_triangles_dropped, 1);
    assert_eq!(m.load_report.unused_vertices_dropped, 1);
    assert!(m.corner_normals[0].iter().all(|&n| n == DVec3::Z));
    let pn = "g1tess-pn 1\ncounts 4 2 0\nv 0 0 0 0 0 1\nv 1 0 0 0 0 1\nv 0 1 0 0 0 1\n\
              v 2 0 0 0 0 1\nt 0 1 2\nt 0 1 3\n";
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("mesh_input");
    std::fs::write(dir.join("collinear.pn"), pn).unwrap();
    let m = load_path(&dir.join("collinear.pn"), &LoadOptions::default());
    assert_eq!(
        (
            m.triangles.len(),
            m.load_report.degenerate_triangles_dropped
        ),
        (1, 1)
    );
    let p = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [2.0, 0.0, 0.0],
    ];
    let m = Mesh::from_soup(
        "s",
        &p,
        &[[0, 1, 2], [0, 1, 3]],
        None,
        &LoadOptions::default(),
    )
    .unwrap();
    assert_eq!(
        (
            m.triangles.len(),
            m.load_report.degenerate_triangles_dropped
        ),
        (1, 1)
    );
    // Only collinear faces: an error naming the first one.
    let e = load_err(
        "all-collinear.obj",
        "v 0 0 0\nv 1 1 1\nv 3 3 3\n\nf 1 2 3\n",
    );
    assert!(
        e.contains("all-collinear.obj:5: every face is degenerate"),
        "{e}"
    );
}

#[test]
fn texture_indices_out_of_range_are_refused_both_ways() {
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n";
    let e = load_err("vt-pos.obj", format!("{tri}f 1/1 2/2 3/1\n"));
    assert!(
        e.ends_with(
            "vt-pos.obj:5: face corner '2/2': texture coordinate index 2 out of range \
             (the file has 1 texture coordinates)"
        ),
        "{e}"
    );
    let e = load_err("vt-neg.obj", format!("{tri}f 1/-2 2/1 3/1\n"));
    assert!(
        e.ends_with(
            "vt-neg.obj:5: face corner '1/-2': texture coordinate index -2 out of range \
             (only 1 texture coordinates so far)"
        ),
        "{e}"
    );
    // A forward reference that the file fills later is fine.
    let m = load_path(
        &write_obj("vt-forward.obj", &format!("{tri}f 1/2 2/1 3/1\nvt 1 1\n")),
        &LoadOptions::default(),
    );
    assert_eq!(m.triangles.len(), 1);
    // Plurals are words ("vertices"), for every kind.
    let e = load_err("v-neg.obj", "v 0 0 0\nf 1 -2 -1\n");
    assert!(
        e.ends_with(
            "v-neg.obj:2: face corner '-2': vertex index -2 out of range (only 1 vertices so far)"
        ),
        "{e}"
    );
    let e = load_err("v-pos.obj", "v 0 0 0\nf 1 2 1\n");
    assert!(e.ends_with("(the file has 1 vertices)"), "{e}");
}

#[test]
fn long_lines_and_files_that_are_not_regular_are_refused() {
    // A 2 MiB line in the middle of a file, and a 10 MiB file without a newline.
    let long = format!("v 0 0 0\n# {}\nv 1 0 0\n", "x".repeat(2 << 20));
    let e = load_err("long-line.obj", &long);
    assert!(
        e.ends_with("long-line.obj:2: line longer than 1 MiB: not a mesh file"),
        "{e}"
    );
    let e = load_err("no-newline.obj", vec![0u8; 10 << 20]);
    assert!(
        e.ends_with("no-newline.obj:1: line longer than 1 MiB: not a mesh file"),
        "{e}"
    );
    // A line continued past the bound: named by its first line.
    let cont = format!(
        "v 0 0 0\nf 1 \\\n{}",
        format!("{} \\\n", "1".repeat(1000)).repeat(1100)
    );
    let e = load_err("continued.obj", &cont);
    assert!(
        e.ends_with("continued.obj:2: line longer than 1 MiB: not a mesh file"),
        "{e}"
    );
    let pn = format!("g1tess-pn 1\ncounts 0 0 0\n#{}", "y".repeat(3 << 20));
    let e = load_err("long.pn", &pn);
    assert!(
        e.ends_with("long.pn:3: line longer than 1 MiB: not a mesh file"),
        "{e}"
    );
    // A character device that never ends, and a directory: refused before reading.
    for spec in ["/dev/zero", "/dev/null"] {
        let e = Mesh::load(spec, &LoadOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with(&format!("{spec}: not a regular file")), "{e}");
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("mesh_input/dir.pn");
    std::fs::create_dir_all(&dir).unwrap();
    let e = Mesh::load(dir.to_str().unwrap(), &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("dir.pn: not a regular file"), "{e}");
}

/// The OBJ reader reads plain `v`, `vn` and `f` statements through a shortcut and every
/// other statement through its general path. The same file written so that no statement
/// fits the shortcut (each line led by a blank, ended by a comment) must give the same mesh
/// bit for bit: positions, triangles, corner normals and texture coordinates, and the load
/// report; the forms the shortcut declines (extra values, signs, empty index parts) too.
#[test]
fn plain_and_general_statements_read_alike() {
    let mut rng = common::Rng(0x05ee_d0b1);
    let mut lines = Vec::new();
    let n = 40;
    for i in 0..n {
        let (x, y) = ((i % 8) as f64, (i / 8) as f64);
        // Long decimals (f32 values as f64 shortest forms), short ones, an exponent form,
        // a signed zero.
        let z = (rng.next_u64() % 1000) as f64 / 997.0;
        let zf = z as f32 as f64;
        let zs = match i % 4 {
            0 => format!("{zf:?}"),
            1 => format!("{z:.3}"),
            2 => format!("{:e}", z),
            _ => "-0.0".into(),
        };
        lines.push(format!("v {x} {y} {zs}"));
        lines.push(format!("vn {} -0.5 {zs}", 0.125 * x));
        lines.push(format!("vt {} {}", x / 8.0, y / 5.0));
    }
    // Every face form, quads and pentagons, explicit `+` and negative indices, an empty
    // texture part, extra values after a vertex.
    let v = |r: usize, c: usize| 8 * r + c + 1;
    for r in 0..4 {
        for c in 0..7 {
            let (a, b, d, e) = (v(r, c), v(r, c + 1), v(r + 1, c + 1), v(r + 1, c));
            lines.push(match (r + c) % 6 {
                0 => format!("f {a} {b} {d} {e}"),
                1 => format!("f {a}/{a} {b}/{b} {d}/{d}"),
                2 => format!("f {a}//{a} {b}//{b} {d}//{d} {e}//{e}"),
                3 => format!("f {a}/{a}/{a} {b}/{b}/{b} {d}/{d}/{d} {e}/{e}/{e}"),
                4 => format!("f +{a} {b}/ {d}/{d}/"),
                _ => format!("f {a}/{a}/{a}\t{b}/{b}/{b}  {d}/{d}/{d}"),
            });
            if (r + c) % 6 == 1 || (r + c) % 6 == 5 {
                lines.push(format!("f {a} {d} {e}"));
            }
        }
    }
    lines.push(format!("v 1 2 3 0.5 0.5 0.5\nf -1 {} {}", v(0, 0), v(0, 1)));
    let plain: String = lines.iter().map(|l| format!("{l}\n")).collect();
    let general: String = lines
        .iter()
        .flat_map(|l| l.lines())
        .map(|l| format!(" {l} # general\n"))
        .collect();
    let a = load_path(&write_obj("plain.obj", &plain), &LoadOptions::default());
    let b = load_path(&write_obj("general.obj", &general), &LoadOptions::default());
    let bits = |v: &[DVec3]| -> Vec<[u64; 3]> {
        v.iter().map(|p| p.to_array().map(f64::to_bits)).collect()
    };
    // Triangles per face form (quads give two; forms 1 and 5 add a second face), and the
    // last face.
    let per_form = [2, 2, 2, 2, 1, 2];
    let faces: usize = (0..4)
        .flat_map(|r| (0..7).map(move |c| per_form[(r + c) % 6]))
        .sum();
    assert_eq!(a.triangles.len(), faces + 1);
    assert_eq!(bits(&a.positions), bits(&b.positions));
    assert_eq!(a.triangles, b.triangles);
    let normals = |m: &Mesh| -> Vec<[u64; 3]> {
        m.corner_normals
            .iter()
            .flatten()
            .map(|n| n.to_array().map(f64::to_bits))
            .collect()
    };
    assert_eq!(normals(&a), normals(&b));
    assert_eq!(a.attributes.uvs, b.attributes.uvs);
    assert_eq!(
        format!("{:?}", a.load_report),
        format!("{:?}", b.load_report)
    );
    // And the values are the text's: the first vertex's long decimal, exactly.
    let z0 = ((common::Rng(0x05ee_d0b1).next_u64() % 1000) as f64 / 997.0) as f32 as f64;
    assert!(a.positions.iter().any(|p| p.z.to_bits() == z0.to_bits()));
}
