//! `stats --fairness` as a user runs it: the bending energy and the G2 defect in the JSON
//! report and the text, checked against the sphere's closed form and exact counts.

use std::process::Command;

use serde_json::Value;

use crate::common;

fn stats_json(mesh: &str, extra: &[&str]) -> Value {
    let mut args = vec![
        "stats",
        mesh,
        "--backend",
        "cpu",
        "--fairness",
        "--json",
        "-q",
    ];
    args.extend_from_slice(extra);
    common::g1tess_json(&args)
}

/// The G1 surface of the 320-triangle icosphere with exact normals: its bending energy is
/// the sphere's, 8π for any radius, up to the interpolation error. That error falls at
/// order 4 with the level (7.1e-4 at 80 triangles, so about 7.1e-4 / 16 = 4.4e-5 here;
/// 4.2e-5 measured), so 1e-4 holds it with room for the quadrature's 1e-4-per-cell
/// tolerance, which acts on the patch's own energy, far below this. Every patch is
/// certified, and the G2 defect counts every edge of the closed mesh: 320 · 3 / 2 = 480
/// edges, 21 samples each.
#[test]
fn the_sphere_has_the_energy_8_pi_and_every_edge_in_the_g2_defect() {
    let r = stats_json("sphere320", &[]);
    let f = &r["fairness"];
    let energy = f["energy"].as_f64().unwrap();
    let relative = (energy / (8.0 * std::f64::consts::PI) - 1.0).abs();
    assert!(relative < 1e-4, "energy {energy}: {relative:e} from 8π");
    assert_eq!(f["uncertified_patches"], 0);
    assert_eq!(f["singular_patches"], 0);
    assert_eq!(f["unresolved_patches"], 0);
    let g2 = &f["g2"];
    assert_eq!(g2["edges"], 480);
    assert_eq!(g2["samples"], 480 * 21);
    assert_eq!(g2["uncertified_edges"], 0);
    // Both sides' normal curvature approximates the sphere's 1: the jump is a fraction of
    // it (6.5e-3 measured; the edge curves' own error is of order h² ≈ 0.1 at this size).
    let (max, mean) = (g2["max"].as_f64().unwrap(), g2["mean"].as_f64().unwrap());
    assert!(
        0.0 < mean && mean <= max && max < 0.1,
        "G2 defect max {max}, mean {mean}"
    );
}

/// The patches the certificate does not prove valid are left out of the energy, and the
/// edges beside them out of the G2 defect: the report's count is the verdicts' own count
/// in the same report (Suzanne with its file normals: 76 folded patches).
#[test]
fn uncertified_patches_are_counted_apart() {
    let suzanne = common::shared_mesh("suzanne.obj");
    let r = stats_json(suzanne.to_str().unwrap(), &[]);
    let patches = &r["patches"];
    let left_out = patches["folded"].as_u64().unwrap() + patches["undecided"].as_u64().unwrap();
    assert_eq!(left_out, 76);
    assert_eq!(r["fairness"]["uncertified_patches"], left_out);
    // 177 of its edges have an uncertified patch on a side (measured; at most 3 per patch).
    let edges = r["fairness"]["g2"]["uncertified_edges"].as_u64().unwrap();
    assert!(0 < edges && edges <= 3 * left_out, "{edges} edges left out");
}

/// The text report carries the same two measures in two lines.
#[test]
fn the_text_report_has_the_energy_and_the_g2_lines() {
    let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .args(["stats", "sphere320", "--backend", "cpu", "--fairness"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let energy = text
        .lines()
        .find(|l| l.starts_with("bending energy"))
        .unwrap();
    assert!(energy.contains("2.513379e1"), "{energy}");
    let g2 = text.lines().find(|l| l.starts_with("G2 defect")).unwrap();
    assert!(g2.contains("480 non-crease edges (10080 samples)"), "{g2}");
}
