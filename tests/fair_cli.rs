//! `--fair` on the command line: `stats --fair --json` reports the fair surface's
//! statistics and the optimiser's report, checked against the statistics themselves and
//! against the least bending energy any closed surface of the sphere's topology has.

use std::process::Command;

/// `stats icosphere:2 --fair --fairness --json` (320 triangles with the sphere's exact
/// normals, so bounded to 15°): the fair surface stays G1 (1 − min cos ≤ 1e-12, rounding)
/// with every patch certified and no crease; its energy is the `fairness` object's, no
/// more than the input's, and at least 8π: ∫ (κ₁² + κ₂²) dA = 4 ∫ H² dA − 4π χ ≥ 16π − 8π
/// for a closed surface of genus 0 (Willmore's inequality ∫ H² dA ≥ 4π), with 1e-9 for the
/// quadrature's tolerance (1e-4 per cell, relative, measured within 1e-10 on spheres).
#[test]
fn stats_fair_json_reports_the_fair_surface() {
    let v = crate::common::g1tess_json(&[
        "stats",
        "icosphere:2",
        "--backend",
        "cpu",
        "--json",
        "--fair",
        "--fairness",
    ]);
    let f = &v["fair"];
    let clean = serde_json::json!({"valid": 320, "folded": 0, "undecided": 0});
    assert_eq!(v["patches"], clean);
    assert_eq!(f["after"], clean);
    assert_eq!(f["creases_made"], 0);
    assert_eq!(f["normal_bound_deg"], 15.0);
    assert!(f["max_normal_change_deg"].as_f64().unwrap() <= 15.0);
    assert!(1.0 - v["cos"]["min"].as_f64().unwrap() <= 1e-12, "{v}");
    let before = f["energy_before"]["energy"].as_f64().unwrap();
    let after = f["energy_after"]["energy"].as_f64().unwrap();
    assert_eq!(after, v["fairness"]["energy"].as_f64().unwrap());
    assert!(after <= before, "{before} -> {after}");
    assert!(
        after >= 8.0 * std::f64::consts::PI * (1.0 - 1e-9),
        "{after}"
    );
}

/// `--fair` with another scheme is refused in one line.
#[test]
fn fair_needs_the_g1_scheme() {
    let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(["stats", "icosphere:1", "--scheme", "pn", "--fair"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--fair") && err.contains("--scheme g1"),
        "{err}"
    );
}

/// `--fair-sweeps 1` runs exactly one sweep (the report says so), and without `--fair`
/// it is refused in one line naming `--fair`.
#[test]
fn fair_sweeps_bounds_the_sweeps() {
    let v = crate::common::g1tess_json(&[
        "stats",
        "icosphere:1",
        "--backend",
        "cpu",
        "--json",
        "--fair",
        "--fair-sweeps",
        "1",
    ]);
    assert_eq!(v["fair"]["sweeps"], 1, "{v}");
    let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(["stats", "icosphere:1", "--fair-sweeps", "1"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--fair"), "{err}");
}
