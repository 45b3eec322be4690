//! The paper's results: Table 1 to the printed digits, the distance study's convergence
//! orders and values, and the commands (`compare`, `sweep`, the default run) end to end.

#[cfg(feature = "cli")]
use std::path::Path;
#[cfg(feature = "cli")]
use std::process::Command;

use g1tess::Scheme;

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
