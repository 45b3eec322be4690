//! Creases: split normals from a file or from `--crease-angle`, one shared boundary curve
//! per crease edge (no crack), G1 across every other edge, split output normals.

use crate::tests::common;

use std::collections::HashMap;
use std::path::PathBuf;

use glam::DVec3;

use crate::mesh::creases::crease_edges;
use crate::patch::g1::{crease_curve, patch_points, walton_meek};
use crate::stitch;
use crate::CpuEvaluator;
use crate::{continuity, Continuity};
use crate::{LoadOptions, Mesh};
use crate::{PatchTable, Scheme, SchemeOptions};

fn tmp(name: &str) -> PathBuf {
    common::tmp_dir("creases").join(name)
}

fn stats(mesh: &Mesh, table: &PatchTable) -> Continuity {
    continuity(mesh, &mesh.adjacency(), table, &CpuEvaluator::default()).unwrap()
}

/// A cube whose creases come from the file's per-face normals, and one whose creases come
/// from `--crease-angle`: the G1 surface is the cube itself (flat faces, straight creases),
/// welded, closed, with three normals at each corner and two along each crease.
#[test]
fn cube_is_reproduced_exactly() {
    for flat in [true, false] {
        let path = tmp(if flat { "flat.obj" } else { "plain.obj" });
        std::fs::write(&path, common::cube_obj(flat)).unwrap();
        let opts = LoadOptions::default().with_crease_angle(if flat { None } else { Some(30.0) });
        let mesh = Mesh::load(path.to_str().unwrap(), &opts).unwrap();
        let adj = mesh.adjacency();
        assert_eq!(crease_edges(&mesh, &adj).iter().filter(|&&c| c).count(), 12);
        let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
        let c = stats(&mesh, &table);
        assert_eq!(c.crease_edges, 12);
        // The unit cube's faces are axis planes and its creases straight edges: every
        // bound below is exact up to a few roundings of unit-size values (1e-15 ≈ 4 ulps of 1).
        assert!(c.crease_max_gap < 1e-15, "crease gap {}", c.crease_max_gap);
        assert!(1.0 - c.cos.min < 1e-15);
        let level = 6;
        let (w, plan, snap) = stitch(&mesh, &table, &CpuEvaluator::default(), level).unwrap();
        assert!(snap < 1e-15);
        // 8 corners with 3 normals, 12 edges × 5 samples with 2 normals.
        assert_eq!(plan.records - plan.positions, 8 * 2 + 12 * 5);
        assert_eq!(plan.report.split_edges, 12);
        for (t, tri) in w.triangles.iter().enumerate() {
            let face = mesh.triangles[t / (level * level) as usize];
            let fp = face.map(|v| mesh.positions[v as usize]);
            let fnrm = (fp[1] - fp[0]).cross(fp[2] - fp[0]).normalize();
            for &r in tri {
                let p = w.positions[w.record_position[r as usize] as usize];
                assert!(
                    (p - fp[0]).dot(fnrm).abs() < 1e-15,
                    "off the face plane: {p}"
                );
                assert!(
                    p.cmpge(DVec3::splat(-1e-15)).all() && p.cmple(DVec3::splat(1.0 + 1e-15)).all()
                );
                assert!((w.normals[r as usize] - fnrm).length() < 1e-15);
            }
        }
        // Still one closed surface in positions: every edge used twice, χ = 2.
        let mut uses: HashMap<(u32, u32), usize> = HashMap::new();
        let pt = w.position_triangles();
        for t in &pt {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        assert!(uses.values().all(|&c| c == 2));
        assert_eq!(
            w.positions.len() as i64 - uses.len() as i64 + pt.len() as i64,
            2
        );
    }
}

/// fandisk.obj (no normals) with --crease-angle 30: creases found, crease edges meet
/// without a gap, every other edge G1 to 1e-12; the welded output is closed (genus 0) and
/// its patches meet where they were welded. Building each side's crease curve from its own
/// normals instead (the ordinary construction) opens cracks: the check can fail.
#[test]
fn fandisk_creases_without_cracks() {
    let opts = LoadOptions::default().with_crease_angle(Some(30.0));
    let mesh = Mesh::load(&common::shared_spec("fandisk.obj"), &opts).unwrap();
    let diag = mesh.diagonal();
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let c = stats(&mesh, &table);
    assert!(c.crease_edges > 300, "only {} crease edges", c.crease_edges);
    assert!(c.samples > 0);
    // G1 to f64 rounding (~1e-16); 1e-12 is far above that and far below any real kink.
    assert!(1.0 - c.cos.min <= 1e-12, "1 - min cos {}", 1.0 - c.cos.min);
    assert_eq!(c.folded, 0);
    // Both sides evaluate the same crease curve (and shared boundaries elsewhere): the gaps
    // and the snap are a few f64 ulps of the coordinates, below 1e-14 of the diagonal.
    assert!(
        c.crease_max_gap <= 1e-14 * diag,
        "crease gap {}",
        c.crease_max_gap
    );
    assert!(c.max_gap <= 1e-14 * diag);

    let (w, plan, snap) = stitch(&mesh, &table, &CpuEvaluator::default(), 3).unwrap();
    // Edge samples of two patches on one shared curve: the same rounding bound as the gaps.
    assert!(snap <= 1e-14 * diag, "snap {snap}");
    assert_eq!(plan.report.split_edges, c.crease_edges);
    assert!(plan.records > plan.positions);
    let pt = w.position_triangles();
    let mut uses: HashMap<(u32, u32), usize> = HashMap::new();
    for t in &pt {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    assert!(uses.values().all(|&c| c == 2));
    assert_eq!(
        w.positions.len() as i64 - uses.len() as i64 + pt.len() as i64,
        2
    );

    // The ordinary construction (each side from its own normals) cracks along creases.
    let mut naive = table.clone();
    let mut f = 0;
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let q = tri.map(|v| mesh.positions[v as usize]);
        let p = patch_points(q, mesh.corner_normals[t], *tri, &mut f);
        naive.points[18 * t..18 * t + 18].copy_from_slice(&p);
    }
    let cn = stats(&mesh, &naive);
    // Not rounding: 1e-4 of the diagonal is a real crack, ten orders above the bound above.
    assert!(
        cn.crease_max_gap > 1e-4 * diag,
        "naive gap {}",
        cn.crease_max_gap
    );
}

/// The crease curve: at a split end its tangent lies in both sides' tangent planes, at an
/// agreeing end it is the Walton–Meek tangent (perpendicular to the common normal).
#[test]
fn crease_curve_end_tangents() {
    let qa = DVec3::new(0.0, 0.0, 0.0);
    let qb = DVec3::new(1.0, 0.2, -0.1);
    let n = |x: f64, y: f64, z: f64| DVec3::new(x, y, z).normalize();
    let na = [n(0.1, -0.3, 1.0), n(0.9, -0.2, 0.3)];
    let nb_split = [n(-0.2, 0.1, 1.0), n(1.0, -0.4, -0.1)];
    let nb_same = [n(0.3, -0.2, 1.0); 2];
    let mut f = 0;
    for (nb, split_b) in [(nb_split, true), (nb_same, false)] {
        let c = crease_curve(qa, qb, na, nb, [true, split_b], &mut f);
        let ta = (c[1] - c[0]).normalize();
        let tb = (c[3] - c[2]).normalize();
        // Unit tangents built from unit normals: a few f64 roundings of unit-size values.
        assert!(ta.dot(na[0]).abs() < 1e-15 && ta.dot(na[1]).abs() < 1e-15);
        assert!(ta.dot(qb - qa) > 0.0);
        if split_b {
            assert!(tb.dot(nb[0]).abs() < 1e-15 && tb.dot(nb[1]).abs() < 1e-15);
        } else {
            assert!(tb.dot(nb[0]).abs() < 1e-15);
        }
        assert!(tb.dot(qb - qa) > 0.0);
        assert_eq!((c[0], c[3]), (qa, qb));
    }
    // Agreeing normals at both ends give back the Walton–Meek cubic.
    let c = crease_curve(qa, qb, [na[0]; 2], nb_same, [false, false], &mut f);
    assert_eq!(c, walton_meek(qa, na[0], qb, nb_same[0]));
    assert_eq!(f, 0);
}
