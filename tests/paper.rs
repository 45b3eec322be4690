//! The paper's results: Table 1 to the printed digits, the distance study's convergence
//! orders and values, and the commands (`compare`, `sweep`, the default run) end to end.

#[cfg(feature = "cli")]
use std::path::Path;
#[cfg(feature = "cli")]
use std::process::Command;

use g1tess::analysis::distance::{sweep, Series, SweepPlan, SweepRow};
use g1tess::analysis::stats::StatsReport;
use g1tess::analysis::table1::compare_mesh;
use g1tess::eval::cpu::CpuEvaluator;
use g1tess::mesh::{LoadOptions, Mesh};
use g1tess::patch::{Scheme, SchemeOptions};

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

#[cfg(feature = "cli")]
fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_g1tess"))
}

#[cfg(feature = "cli")]
fn temp_dir(name: &str) -> std::path::PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-paper-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
#[cfg(feature = "cli")]
fn compare_json_has_one_stats_object_per_mesh_and_scheme() {
    let out = bin().args(["compare", "--json"]).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let a = v.as_array().unwrap();
    assert_eq!(a.len(), 2 * Scheme::all().len());
    // The fields of `stats --json`.
    let stats = bin()
        .args(["stats", "sphere320", "--scheme", "nlsa", "--json"])
        .output()
        .unwrap();
    let s: serde_json::Value = serde_json::from_slice(&stats.stdout).unwrap();
    let keys = |o: &serde_json::Value| {
        let mut k: Vec<String> = o.as_object().unwrap().keys().cloned().collect();
        k.sort();
        k
    };
    let nlsa = a
        .iter()
        .find(|o| o["mesh"] == "sphere320" && o["scheme"] == "nlsa")
        .unwrap();
    assert_eq!(keys(nlsa), keys(&s));
    assert_eq!(nlsa["cos"], s["cos"]);
}

#[test]
#[cfg(feature = "cli")]
fn compare_markdown_and_errors() {
    let out = bin()
        .args(["compare", "icosphere:1", "--schemes", "g1,pn"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let md = String::from_utf8(out.stdout).unwrap();
    assert!(md.contains("| scheme |") && md.contains("| g1 |") && md.contains("| pn |"));
    assert!(!md.contains("| nlsa |"));

    let out = bin()
        .args(["compare", "no-such-mesh.obj"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("no-such-mesh.obj"), "{err}");

    let out = bin()
        .args([
            "stats",
            "sphere320",
            "--scheme",
            "phong",
            "--phong-alpha",
            "NaN",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8(out.stderr).unwrap().contains("finite"));
}

#[cfg(feature = "cli")]
fn check_study_files(dir: &Path) {
    let csv = std::fs::read_to_string(dir.join("distance.csv")).unwrap();
    // Header + 8 schemes × (5 icospheres + 2 × 26 tori).
    assert_eq!(csv.lines().count(), 1 + 8 * (5 + 2 * 26));
    assert!(csv.starts_with("series,mesh,scheme,triangles,h,samples,mean,max,order_mean,order_max"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("distance.json")).unwrap()).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), 8 * 57);
    assert_eq!(json["level"], 16);
    for stem in ["sphere_distance", "torus_distance"] {
        let png = std::fs::read(dir.join(format!("{stem}.png"))).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        let svg = std::fs::read_to_string(dir.join(format!("{stem}.svg"))).unwrap();
        // Axis labels and a legend entry per plotted line.
        assert!(
            svg.contains("triangles") && svg.contains("mean distance"),
            "{stem}"
        );
        for label in ["g1", "phong", "nlsa", "flat", "pn = pn-normals"] {
            assert!(
                svg.contains(&format!("\n{label}\n</text>")),
                "{stem}: no legend entry {label}"
            );
        }
    }
    // No temporary files left behind.
    for e in std::fs::read_dir(dir).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.starts_with('.'), "left over: {name}");
    }
}

#[test]
#[cfg(feature = "cli")]
fn sweep_writes_csv_json_and_plots() {
    let dir = temp_dir("sweep");
    let out = bin()
        .args(["sweep", "--quiet", "--json", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(printed["rows"].as_array().unwrap().len(), 8 * 57);
    check_study_files(&dir);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
#[cfg(feature = "cli")]
fn default_run_reproduces_the_paper_into_out_paper() {
    let dir = temp_dir("default");
    let out = bin().current_dir(&dir).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    // The table is printed, with the paper's rows beside ours.
    assert!(stdout.contains("**sphere320**") && stdout.contains("**torus200**"));
    assert!(
        stdout.contains("| nagata | 0.999988 | 1.000000 | 0.999996 |"),
        "{stdout}"
    );
    let paper = dir.join("out/paper");
    let md = std::fs::read_to_string(paper.join("table1.md")).unwrap();
    assert!(stdout.contains(md.trim()));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(paper.join("table1.json")).unwrap()).unwrap();
    assert_eq!(json.as_array().unwrap().len(), 2 * Scheme::all().len());
    check_study_files(&paper);
    std::fs::remove_dir_all(&dir).unwrap();
}
