//! The paper's results: Table 1 to the printed digits, the distance study's convergence
//! orders and values, and the commands (`compare`, `sweep`, the default run) end to end.

#[cfg(feature = "cli")]
#[cfg(feature = "cli")]
use crate::analysis::distance::{sweep, Series, SweepPlan, SweepRow};

use crate::analysis::table1::compare_mesh;

use crate::CpuEvaluator;

use crate::StatsReport;

use crate::{LoadOptions, Mesh};

use crate::{Scheme, SchemeOptions};

/// Table 1 as printed in the paper (min, max, mean, std), copied from
/// `spec/EVALUATION.md` independently of the library's copy.
const PAPER: [(&str, Scheme, [f64; 4]); 8] = [
    (
        "sphere320",
        Scheme::Phong,
        [0.995723, 0.998740, 0.997072, 7.657330e-4],
    ),
    (
        "sphere320",
        Scheme::Nagata,
        [0.999988, 1.000000, 0.999996, 3.276020e-6],
    ),
    (
        "sphere320",
        Scheme::Nlsa,
        [0.999958, 1.000000, 0.999979, 9.690380e-6],
    ),
    (
        "sphere320",
        Scheme::Pn,
        [0.999975, 1.000000, 0.999991, 6.656300e-6],
    ),
    (
        "torus200",
        Scheme::Phong,
        [0.915295, 0.999999, 0.987918, 1.578150e-2],
    ),
    (
        "torus200",
        Scheme::Nagata,
        [0.938828, 1.000000, 0.997556, 8.603600e-3],
    ),
    (
        "torus200",
        Scheme::Nlsa,
        [0.969450, 1.000000, 0.994738, 6.790900e-3],
    ),
    (
        "torus200",
        Scheme::Pn,
        [0.989164, 1.000000, 0.998873, 1.846800e-3],
    ),
];

/// The two last-digit differences EVALUATION.md documents: (mesh, scheme, which value,
/// what a correct f64 implementation gives to 7 decimals).
const KNOWN: [(&str, Scheme, usize, &str); 2] = [
    ("torus200", Scheme::Nagata, 0, "0.9388299"),
    ("sphere320", Scheme::Nlsa, 1, "0.9999994"),
];

fn reports(mesh: &str) -> Vec<StatsReport> {
    let m = Mesh::load(mesh, &LoadOptions::default()).unwrap();
    compare_mesh(
        &m,
        &Scheme::all(),
        &SchemeOptions::default(),
        &CpuEvaluator::default(),
    )
    .unwrap()
}

fn report(rs: &[StatsReport], s: Scheme) -> &StatsReport {
    rs.iter().find(|r| r.scheme == s.name()).unwrap()
}

fn icosphere_rows() -> Vec<SweepRow> {
    let plan = SweepPlan {
        series: vec![(Series::Icosphere, (0..=4).collect())],
        schemes: vec![
            Scheme::G1,
            Scheme::Nagata,
            Scheme::Pn,
            Scheme::Nlsa,
            Scheme::Phong,
            Scheme::Flat,
        ],
        ..SweepPlan::default()
    };
    sweep(&plan, &CpuEvaluator::default(), &mut |_| {}).unwrap()
}

fn row(rows: &[SweepRow], s: Scheme, triangles: usize) -> &SweepRow {
    rows.iter()
        .find(|r| r.scheme == s && r.triangles == triangles)
        .unwrap()
}

#[test]
fn table1_competitor_rows_to_the_printed_digits() {
    for mesh in ["sphere320", "torus200"] {
        let rs = reports(mesh);
        for (m, scheme, paper) in PAPER.iter().filter(|p| p.0 == mesh) {
            let r = report(&rs, *scheme);
            let ours = [r.cos.min, r.cos.max, r.cos.mean];
            for (k, name) in ["min", "max", "mean"].iter().enumerate() {
                let known = KNOWN
                    .iter()
                    .find(|x| x.0 == *m && x.1 == *scheme && x.2 == k);
                match known {
                    None => assert_eq!(
                        format!("{:.6}", ours[k]),
                        format!("{:.6}", paper[k]),
                        "{m} {scheme} {name}: {}",
                        ours[k]
                    ),
                    Some(&(_, _, _, seven)) => {
                        assert_eq!(format!("{:.7}", ours[k]), seven, "{m} {scheme} {name}");
                        // The paper rounded a value sitting on a digit boundary: ours is
                        // within 2 units of its sixth decimal.
                        assert!((ours[k] - paper[k]).abs() < 2e-6, "{m} {scheme} {name}");
                    }
                }
            }
            // std to 3 significant digits.
            assert_eq!(
                format!("{:.2e}", r.cos.std),
                format!("{:.2e}", paper[3]),
                "{m} {scheme} std: {}",
                r.cos.std
            );
            assert_eq!(r.samples, r.interior_edges * 21);
        }
        // G1: the tangent plane is shared to rounding (the paper printed 1e-16 / 1e-10).
        let g1 = report(&rs, Scheme::G1);
        // 1e-12: many orders above rounding (~1e-16), many below any real kink.
        assert!(1.0 - g1.cos.min < 1e-12, "{mesh} g1 {:?}", g1.cos);
        assert!(g1.cos.std < 1e-12);
        // One boundary curve per edge, built bitwise the same: rounding of the blends only.
        assert!(g1.max_gap_relative < 1e-12);
    }
}

#[test]
fn table1_meshes_are_the_papers() {
    let s = reports("sphere320");
    assert_eq!(
        (s[0].triangles, s[0].interior_edges, s[0].samples),
        (320, 480, 10080)
    );
    let t = reports("torus200");
    assert_eq!(
        (t[0].triangles, t[0].interior_edges, t[0].samples),
        (200, 300, 6300)
    );
}

#[test]
fn icosphere_convergence_orders_and_values() {
    let rows = icosphere_rows();
    // Observed order of the mean distance on the last refinement (1280 → 5120 triangles).
    for s in [Scheme::G1, Scheme::Nagata, Scheme::Pn, Scheme::Nlsa] {
        let o = row(&rows, s, 5120).order_mean.unwrap();
        // Fourth order asymptotically; 3.5 allows the last refinement to be pre-asymptotic.
        assert!(o >= 3.5, "{s}: order {o}");
    }
    for s in [Scheme::Phong, Scheme::Flat] {
        let o = row(&rows, s, 5120).order_mean.unwrap();
        // Second order asymptotically; ±0.3 for the pre-asymptotic last refinement.
        assert!((o - 2.0).abs() <= 0.3, "{s}: order {o}");
    }
    // The order is log(e0/e1)/log(h0/h1): recompute one from the rows themselves.
    let (a, b) = (row(&rows, Scheme::G1, 1280), row(&rows, Scheme::G1, 5120));
    let o = (a.mean / b.mean).ln() / (a.h / b.h).ln();
    // Same formula, possibly a different association: rounding of a logarithm ratio.
    assert!((o - b.order_mean.unwrap()).abs() < 1e-12);
    assert_eq!(a.samples, 1280 * 153);

    // G1 and Nagata below PN at 320 triangles.
    let at = |s| row(&rows, s, 320).mean;
    assert!(at(Scheme::G1) < at(Scheme::Pn) && at(Scheme::Nagata) < at(Scheme::Pn));
    // EVALUATION.md's values at 320 triangles, to 10 % (they are printed to two digits,
    // and the 5% rounding of the smallest leaves the rest as margin).
    for (s, v) in [
        (Scheme::G1, 2.0e-5),
        (Scheme::Nagata, 2.1e-5),
        (Scheme::Pn, 1.9e-4),
        (Scheme::Nlsa, 2.2e-4),
        (Scheme::Phong, 5.0e-3),
        (Scheme::Flat, 1.1e-2),
    ] {
        assert!((at(s) / v - 1.0).abs() < 0.1, "{s}: {} vs {v}", at(s));
    }
    // The flat icosahedron, computed independently: its faces are inscribed in the unit
    // sphere, so the farthest point is a face centre at 1 − inradius/circumradius
    // = 1 − √((5 + 2√5)/15). The level-16 grid has no sample exactly there (16 is not a
    // multiple of 3), so the sampled maximum lies just below.
    let flat20 = row(&rows, Scheme::Flat, 20);
    let centre = 1.0 - ((5.0 + 2.0 * 5f64.sqrt()) / 15.0).sqrt();
    // 1e-3: the nearest grid sample lies about δ = 0.02 from the centre (a third of a grid
    // step of a 1.05-long edge), where the distance to the unit sphere falls by δ²/2 ≈ 2e-4.
    assert!(
        flat20.max <= centre && flat20.max > centre - 1e-3,
        "{} vs {centre}",
        flat20.max
    );
}
