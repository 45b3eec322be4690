//! Mesh input: OBJ face forms, negative indices, groups, welding, unused vertices, normals,
//! adjacency, built-in meshes.

#![allow(clippy::needless_range_loop)]

mod common;

use std::path::PathBuf;

use g1tess::mesh::generators::{icosphere, torus, TorusNormals};
use g1tess::mesh::normals::vertex_normals;
use g1tess::mesh::{LoadOptions, Mesh, NormalWeighting};
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
        assert!((n[0] - e).length() < 1e-15, "{w:?}: {:?} vs {e:?}", n[0]);
    }
}

#[test]
fn recompute_normals_option_overrides_file_normals() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1 0 0\nf 1//1 2//1 3//1\n";
    let p = write_obj("recompute.obj", text);
    let keep = load_path(&p, &LoadOptions::default());
    assert_eq!(keep.corner_normals[0][0], DVec3::X);
    let re = load_path(
        &p,
        &LoadOptions {
            recompute_normals: true,
            ..Default::default()
        },
    );
    assert_eq!(re.corner_normals[0][0], DVec3::Z);
}

#[test]
fn builtin_meshes_match_their_definitions() {
    let s = Mesh::load("sphere320", &LoadOptions::default()).unwrap();
    assert_eq!((s.triangles.len(), s.positions.len()), (320, 162));
    for (t, tri) in s.triangles.iter().enumerate() {
        for k in 0..3 {
            let p = s.positions[tri[k] as usize];
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
            assert!((cn[k] - avg[tri[k] as usize]).length() < 1e-15);
        }
    }
    // Outer equator vertex (u = 0, v = 0) at (1.5, 0, 0) with normal close to +x.
    assert!((t.positions[0] - DVec3::new(1.5, 0.0, 0.0)).length() < 1e-15);
    let analytic = torus(10, 10, 1.0, 0.5, TorusNormals::Analytic);
    for (tri, cn) in analytic.triangles.iter().zip(&analytic.corner_normals) {
        for k in 0..3 {
            let p = analytic.positions[tri[k] as usize];
            let ring = DVec3::new(p.x, p.y, 0.0).normalize();
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
    for n in m.corner_normals.iter().flatten() {
        assert!((n.length() - 1.0).abs() < 1e-15);
    }
    let table =
        g1tess::patch::PatchTable::build(&m, g1tess::patch::Scheme::G1, &Default::default())
            .unwrap();
    let c = g1tess::output::stats::continuity(
        &m,
        &m.adjacency(),
        &table,
        &g1tess::eval::cpu::CpuEvaluator::default(),
    )
    .unwrap();
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
                assert!((m.corner_normals[t][k] - d).length() < 1e-15);
            }
        }
    }
}
