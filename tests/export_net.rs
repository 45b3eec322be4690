//! `g1tess export-net`: the JSON control nets, evaluated here from the README's formula
//! alone, reproduce the library's surface; G1 nets interpolate the mesh vertices.

use crate::common;

use std::path::PathBuf;
use std::process::Command;

use glam::DVec3;

use g1tess::{LoadOptions, Mesh};
use g1tess::{PatchTable, Scheme, SchemeOptions};

fn out(name: &str) -> PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-nets-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn export(mesh: &str, scheme: &str, extra: &[&str]) -> serde_json::Value {
    let path = out(&format!(
        "{}-{scheme}.json",
        mesh.replace([':', '/', '.'], "_")
    ));
    let o = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args([
            "export-net",
            mesh,
            "--scheme",
            scheme,
            "-o",
            path.to_str().unwrap(),
            "-q",
        ])
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap()
}

fn v3(v: &serde_json::Value) -> DVec3 {
    DVec3::new(
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    )
}

fn fact(n: u32) -> f64 {
    (1..=n).map(f64::from).product()
}

/// The README's evaluation of one patch: Bernstein terms for "bezier" slots, the rational
/// blend of the "gregory" pairs, at barycentric b.
fn eval_patch(net: &serde_json::Value, patch: &serde_json::Value, b: [f64; 3]) -> DVec3 {
    let degree = net["degree"].as_u64().unwrap() as u32;
    let slots = net["slots"].as_array().unwrap();
    let pts: Vec<DVec3> = patch["points"].as_array().unwrap().iter().map(v3).collect();
    let mut s = DVec3::ZERO;
    let mut gregory = std::collections::HashMap::new();
    for (slot, p) in slots.iter().zip(&pts) {
        let pw: Vec<u32> = slot["powers"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap() as u32)
            .collect();
        match slot["role"].as_str().unwrap() {
            "bezier" => {
                let c = fact(degree) / (fact(pw[0]) * fact(pw[1]) * fact(pw[2]));
                s += c
                    * b[0].powi(pw[0] as i32)
                    * b[1].powi(pw[1] as i32)
                    * b[2].powi(pw[2] as i32)
                    * *p;
            }
            "gregory" => {
                gregory.insert(slot["name"].as_str().unwrap().to_string(), *p);
            }
            _ => {}
        }
    }
    for m in 0..3 {
        let (x, y, z) = (b[m], b[(m + 1) % 3], b[(m + 2) % 3]);
        if gregory.is_empty() || y + z == 0.0 {
            continue;
        }
        let g1 = gregory[&format!("G{m},1")];
        let g2 = gregory[&format!("G{},2", (m + 2) % 3)];
        s += 12.0 * x * x * y * z * (y * g1 + z * g2) / (y + z);
    }
    s
}

fn check(mesh_spec: &str, scheme: Scheme, extra: &[&str], opts: LoadOptions) {
    let net = export(mesh_spec, scheme.name(), extra);
    let mesh = Mesh::load(mesh_spec, &opts).unwrap();
    let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default()).unwrap();
    assert_eq!(net["format"], "g1tess-control-nets");
    assert_eq!(net["stride"].as_u64().unwrap() as usize, table.stride);
    let patches = net["patches"].as_array().unwrap();
    assert_eq!(patches.len(), mesh.triangles.len());
    // serde_json's default number parser may be 1 ulp off (the file itself is written
    // with shortest round-trip digits), hence the tolerances below.
    let diag = mesh.diagonal();
    let verts: Vec<DVec3> = net["vertices"].as_array().unwrap().iter().map(v3).collect();
    assert_eq!(verts.len(), mesh.positions.len());
    for (a, b) in verts.iter().zip(&mesh.positions) {
        assert!((*a - *b).length() <= 1e-15 * diag);
    }
    let samples = [
        [1.0, 0.0, 0.0],
        [0.0, 0.5, 0.5],
        [0.2, 0.3, 0.5],
        [0.6, 0.1, 0.3],
        [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
        [0.05, 0.9, 0.05],
    ];
    for (t, p) in patches.iter().enumerate() {
        let tri: Vec<u32> = p["vertices"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap() as u32)
            .collect();
        assert_eq!(tri, mesh.triangles[t]);
        for b in samples {
            let want = table.eval(t, b).p;
            let got = eval_patch(&net, p, b);
            // The test's own evaluation of the net (another order of operations) on top of
            // the 1-ulp parse: a few dozen f64 roundings of coordinate-size values.
            assert!((got - want).length() <= 1e-14 * diag, "patch {t} at {b:?}");
        }
        // Corners interpolate the mesh.
        for k in 0..3 {
            let mut b = [0.0; 3];
            b[k] = 1.0;
            let corner = eval_patch(&net, p, b);
            assert!((corner - mesh.positions[tri[k] as usize]).length() <= 1e-15 * diag);
        }
    }
}

#[test]
fn g1_nets_reproduce_the_surface() {
    check("sphere320", Scheme::G1, &[], LoadOptions::default());
    let fandisk = common::shared_spec("fandisk.obj");
    check(
        &fandisk,
        Scheme::G1,
        &["--crease-angle", "30"],
        LoadOptions::default().with_crease_angle(Some(30.0)),
    );
}

#[test]
fn flat_nets_are_the_triangles() {
    check("torus200", Scheme::Flat, &[], LoadOptions::default());
}

#[test]
fn export_net_errors_are_one_line() {
    let o = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(["export-net", "sphere320", "-o", "/nonexistent-dir/x.json"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let msg = String::from_utf8_lossy(&o.stderr);
    assert_eq!(msg.lines().count(), 1, "{msg}");
    assert!(msg.contains("x.json"), "{msg}");
}
