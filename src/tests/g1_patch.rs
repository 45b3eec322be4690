//! The G1 patch against independent expectations: finite differences, interpolation of the
//! point-normal data, tangent-plane continuity across edges, and distance to the sphere.

#![allow(clippy::needless_range_loop)]

use crate::tests::common;

use crate::continuity;
use crate::patch::g1::{walton_meek, walton_meek_offsets};
use crate::CpuEvaluator;
use crate::Mesh;
use crate::{Evaluator, Pattern};
use crate::{PatchTable, Scheme, SchemeOptions};
use common::{load, Rng};
use glam::DVec3;

fn g1_table(mesh: &Mesh) -> PatchTable {
    PatchTable::build(mesh, Scheme::G1, &SchemeOptions::default()).unwrap()
}

/// ∂S/∂s and ∂S/∂t against central differences along (−1, 1, 0) and (−1, 0, 1).
#[test]
fn g1_derivatives_match_central_differences() {
    let mut rng = Rng(7);
    for spec in ["sphere320", "torus200", "spot.obj", "fandisk.obj"] {
        let mesh = load(spec);
        let table = g1_table(&mesh);
        let mut worst: f64 = 0.0;
        for _ in 0..200 {
            let i = (rng.next_u64() % table.len() as u64) as usize;
            let b = rng.interior_b(0.02);
            let h = 1e-5;
            let at = |db: [f64; 3]| table.eval(i, [b[0] + db[0], b[1] + db[1], b[2] + db[2]]).p;
            let fd_s = (at([-h, h, 0.0]) - at([h, -h, 0.0])) / (2.0 * h);
            let fd_t = (at([-h, 0.0, h]) - at([h, 0.0, -h])) / (2.0 * h);
            let sp = table.eval(i, b);
            let scale = sp.ds.length().max(sp.dt.length());
            let err = (fd_s - sp.ds).length().max((fd_t - sp.dt).length()) / scale;
            worst = worst.max(err);
        }
        // Central differences with h = 1e-5: O(h²) truncation (~1e-10 relative) plus
        // O(ε/h) rounding (~1e-11); 1e-7 leaves room for strongly curved patches.
        assert!(
            worst < 1e-7,
            "{spec}: worst relative derivative error {worst:e}"
        );
        println!("{spec}: worst relative derivative error {worst:.2e}");
    }
}

/// The patch passes through each corner Q_k with normal N_k; the boundary cubics' end
/// tangents are perpendicular to the end normals.
#[test]
fn g1_corners_interpolate_points_and_normals() {
    for spec in ["sphere320", "torus200", "spot.obj", "fandisk.obj"] {
        let mesh = load(spec);
        let table = g1_table(&mesh);
        let (mut pos_err, mut nrm_err, mut perp, mut perp_pts): (f64, f64, f64, f64) =
            (0.0, 0.0, 0.0, 0.0);
        let scale = mesh.diagonal();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let mut b = [0.0; 3];
                b[k] = 1.0;
                let sp = table.eval(t, b);
                assert!(sp.n.is_finite() && sp.p.is_finite());
                let q = mesh.positions[tri[k] as usize];
                let n = mesh.corner_normals[t][k];
                pos_err = pos_err.max((sp.p - q).length() / scale);
                nrm_err = nrm_err.max(1.0 - sp.n.dot(n));
                // Boundary cubic of edge k.
                let (a, bb) = (k, (k + 1) % 3);
                let (qa, na) = (mesh.positions[tri[a] as usize], mesh.corner_normals[t][a]);
                let (qb, nb) = (mesh.positions[tri[bb] as usize], mesh.corner_normals[t][bb]);
                // The end tangents as the construction defines them (unit-length test).
                let [t0, t1] = walton_meek_offsets(qa, na, qb, nb);
                perp = perp
                    .max(t0.normalize().dot(na).abs())
                    .max(t1.normalize().dot(nb).abs());
                // The same from the stored control points: V1 − V0 carries the rounding of
                // V1 = V0 + offset, so it is measured against the size of the coordinates.
                let v = walton_meek(qa, na, qb, nb);
                let size = qa
                    .abs()
                    .max_element()
                    .max(qb.abs().max_element())
                    .max(1e-300);
                perp_pts = perp_pts
                    .max((v[1] - v[0]).dot(na).abs() / size)
                    .max((v[3] - v[2]).dot(nb).abs() / size);
            }
        }
        println!(
            "{spec}: corner position {pos_err:.1e}, normal 1-dot {nrm_err:.1e}, \
             unit tangent·normal {perp:.1e}, (V1-V0)·N / |V| {perp_pts:.1e}"
        );
        // The offsets are perpendicular to rounding of their own size; adding them to the
        // positions rounds at ε × |V| (ε ≈ 1.1e-16).
        assert!(perp_pts <= 1e-15, "{spec}: (V1-V0)·N / |V| = {perp_pts:e}");
        // The corner is its control point times a weight of exactly 1.
        assert!(
            pos_err <= 1e-15,
            "{spec}: corner position error {pos_err:e}"
        );
        // The exact normal at a corner is a normalised cross product of the two end
        // tangents, both perpendicular to N_k: 1 − cos is a few roundings.
        assert!(
            nrm_err <= 1e-14,
            "{spec}: corner normal 1 - dot = {nrm_err:e}"
        );
        // Unit tangent · unit normal of a construction that makes them orthogonal: a few
        // roundings.
        assert!(perp <= 1e-14, "{spec}: end tangent · normal = {perp:e}");
    }
}

/// Reversing an edge gives the same Walton–Meek curve (both neighbours build one boundary).
#[test]
fn walton_meek_curve_is_symmetric() {
    let mut rng = Rng(11);
    for _ in 0..100 {
        let mut r = || DVec3::new(rng.f64() - 0.5, rng.f64() - 0.5, rng.f64() - 0.5);
        let (qa, qb) = (r(), r());
        let na = (r() + DVec3::Z).normalize();
        let nb = (r() + DVec3::Z).normalize();
        let f = walton_meek(qa, na, qb, nb);
        let g = walton_meek(qb, nb, qa, na);
        for i in 0..4 {
            // The formula is symmetric; the two orders round differently (coordinates
            // ≤ 1, a few operations).
            assert!((f[i] - g[3 - i]).length() < 1e-14, "{f:?} vs {g:?}");
        }
    }
}

fn assert_g1(spec: &str) {
    let mesh = load(spec);
    let table = g1_table(&mesh);
    let adj = mesh.adjacency();
    let c = continuity(&mesh, &adj, &table, &CpuEvaluator::default()).unwrap();
    let diag = mesh.diagonal();
    println!(
        "{spec}: samples {} 1-min cos {:.2e} max gap {:.2e} (diag {diag:.3})",
        c.samples,
        1.0 - c.cos.min,
        c.max_gap
    );
    assert_eq!(c.samples, 21 * adj.interior);
    assert!(adj.interior > 0);
    // G1: both patches have the same tangent plane along the edge in exact arithmetic;
    // 1 − cos collects the rounding of two independently evaluated normals (the paper's
    // G1 rows print 1.000000, with std ~1e-16 on sphere320).
    assert!(
        1.0 - c.cos.min <= 1e-12,
        "{spec}: 1 - min cos = {:e}",
        1.0 - c.cos.min
    );
    // Both patches evaluate one boundary curve built bitwise the same; the blends differ by
    // rounding of coordinates ≤ the diagonal.
    assert!(c.max_gap <= 1e-12 * diag, "{spec}: max gap {:e}", c.max_gap);
    assert_eq!(c.folded, 0);
}

#[test]
fn g1_on_sphere320() {
    assert_g1("sphere320");
}

#[test]
fn g1_on_torus200() {
    assert_g1("torus200");
}

#[test]
fn g1_on_spot_with_estimated_normals() {
    assert_g1("spot.obj");
}

#[test]
fn g1_on_fandisk_with_estimated_normals() {
    assert_g1("fandisk.obj");
}

/// Scanned normals fold some patches: the tangent plane is still shared everywhere, but
/// 168 of 2.2 million samples have opposite normals. They are counted, not hidden.
#[test]
fn bunny_shares_tangent_planes_and_reports_folds() {
    let mesh = load("stanford-bunny.obj");
    let table = g1_table(&mesh);
    let adj = mesh.adjacency();
    assert_eq!(adj.boundary, 223);
    let c = continuity(&mesh, &adj, &table, &CpuEvaluator::default()).unwrap();
    println!(
        "bunny: samples {} folded {} max 1-|cos| {:.2e} min cos {}",
        c.samples, c.folded, c.max_one_minus_abs_cos, c.cos.min
    );
    assert_eq!(adj.interior, 104_065);
    assert_eq!(c.samples, 21 * adj.interior);
    // Same tangent plane, possibly opposite orientation: |cos| = 1 to rounding.
    assert!(c.max_one_minus_abs_cos <= 1e-12);
    // Exact: the mesh, the patches and the 21 sample points are fixed, each cos is f64
    // arithmetic without fused operations or parallel reductions (IEEE-exact on every
    // backend path that computes it), and the folded samples have cos = −1 to rounding,
    // far from the threshold 0, so no rounding difference can move a sample across it.
    assert_eq!(c.folded, 168);
    assert!(
        c.cos.min < -1.0 + 1e-12,
        "folds have cos = -1 (to rounding)"
    );
    // One boundary curve per edge, built bitwise the same by both patches.
    assert!(c.max_gap <= 1e-12 * mesh.diagonal());
}

/// Mean | |p| − 1 | over sphere320 at level 16 is 2.0e-5 (EVALUATION.md), within 5%.
#[test]
fn sphere320_accuracy() {
    let mesh = load("sphere320");
    let table = g1_table(&mesh);
    let (pos, nrm) = CpuEvaluator::default()
        .evaluate_all(&table, &Pattern::Grid { level: 16 })
        .unwrap();
    assert_eq!(pos.len(), 320 * 153);
    let mean = pos.iter().map(|p| (p.length() - 1.0).abs()).sum::<f64>() / pos.len() as f64;
    let normal_dev = pos
        .iter()
        .zip(&nrm)
        .map(|(p, n)| 1.0 - n.dot(p.normalize()))
        .fold(0.0, f64::max);
    println!("sphere320 level 16: mean ||p|-1| = {mean:.4e}, max 1 - n·p̂ = {normal_dev:.2e}");
    // EVALUATION.md prints the value to two digits: 5% covers its rounding.
    assert!(
        (mean / 2.0e-5 - 1.0).abs() <= 0.05,
        "mean ||p|-1| = {mean:e}"
    );
    // The patch normal vs the sphere's: the surface is an approximation of order 1e-5 in
    // position, so its normal deviates by about the square root (1 − cos ~ 1e-4..1e-3).
    assert!(normal_dev < 1e-3);
}

/// Random meshes with randomly tilted unit normals: tangent planes still agree across every
/// edge (G1 does not depend on the normals being "good").
#[test]
fn g1_holds_on_randomly_perturbed_meshes() {
    let mut rng = Rng(3);
    for trial in 0..20 {
        let mut mesh = crate::mesh::generators::icosphere(1);
        for p in &mut mesh.positions {
            *p *= 1.0 + 0.2 * (rng.f64() - 0.5);
        }
        let tilt: Vec<DVec3> = (0..mesh.positions.len())
            .map(|_| 0.3 * DVec3::new(rng.f64() - 0.5, rng.f64() - 0.5, rng.f64() - 0.5))
            .collect();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let v = tri[k] as usize;
                mesh.corner_normals[t][k] = (mesh.positions[v].normalize() + tilt[v]).normalize();
            }
        }
        let table = g1_table(&mesh);
        let c = continuity(&mesh, &mesh.adjacency(), &table, &CpuEvaluator::default()).unwrap();
        // G1 in exact arithmetic whatever the normals; rounding of two normals only.
        assert!(
            c.max_one_minus_abs_cos <= 1e-12,
            "trial {trial}: 1-|cos| = {:e}",
            c.max_one_minus_abs_cos
        );
        // One boundary curve per edge: rounding of the blends only.
        assert!(c.max_gap <= 1e-12 * mesh.diagonal());
    }
}

/// Corners and edges are evaluated as limits: never NaN, anywhere on the grid.
#[test]
fn no_nan_on_dense_grid() {
    let mesh = load("fandisk.obj");
    let table = g1_table(&mesh);
    let (pos, nrm) = CpuEvaluator::default()
        .evaluate_all(&table, &Pattern::Grid { level: 5 })
        .unwrap();
    assert!(pos.iter().all(|p| p.is_finite()));
    // Unit normals: a normalised vector has length 1 to a few roundings.
    assert!(nrm
        .iter()
        .all(|n| n.is_finite() && (n.length() - 1.0).abs() < 1e-12));
}
