//! Per-edge levels from the command line: `--tolerance-rel` reports what it measured, and
//! every writer takes per-edge levels.

use crate::common;

fn g1tess(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(args)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .unwrap()
}

#[test]
fn cli_tolerance_reports_what_it_measured() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-adaptive-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("spot.obj");
    let spot = common::shared_spec("spot.obj");
    let o = g1tess(&[
        "tessellate",
        &spot,
        "--tolerance-rel",
        "1e-3",
        "--backend",
        "cpu",
        "-q",
        "--json",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let a = &j["adaptive"];
    let mesh = common::load("spot.obj");
    let eps = 1e-3 * mesh.diagonal();
    assert!((a["tolerance"].as_f64().unwrap() - eps).abs() <= 1e-15 * eps);
    assert_eq!(a["tolerance_met"], true);
    assert!(a["max_deviation"].as_f64().unwrap() <= eps);
    assert_eq!(a["points_per_triangle"], 10);
    let tris = j["triangles"].as_u64().unwrap();
    assert_eq!(a["measured_triangles"].as_u64().unwrap(), tris);
    assert_eq!(a["measured_points"].as_u64().unwrap(), 10 * tris);
    // The file read back: its faces are the reported triangles, its vertices the
    // reported positions.
    let text = std::fs::read_to_string(&out).unwrap();
    let faces = text.lines().filter(|l| l.starts_with("f ")).count();
    let verts = text.lines().filter(|l| l.starts_with("v ")).count();
    assert_eq!(faces as u64, tris);
    assert_eq!(verts as u64, j["vertices"].as_u64().unwrap());
    // A cap too low for the tolerance: the file is written, the run says it missed and
    // fails; it never claims the tolerance.
    let o = g1tess(&[
        "tessellate",
        &spot,
        "--tolerance-rel",
        "1e-5",
        "--max-level",
        "2",
        "--backend",
        "cpu",
        "-q",
        "--json",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["adaptive"]["tolerance_met"], false);
    assert!(j["adaptive"]["max_deviation"].as_f64().unwrap() > 1e-5 * mesh.diagonal());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("not met"), "{err}");
    // --max-level alone, and --level with --tolerance, are refused.
    let o = g1tess(&[
        "tessellate",
        &spot,
        "--max-level",
        "4",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let o = g1tess(&[
        "tessellate",
        &spot,
        "--level",
        "3",
        "--tolerance",
        "0.1",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_ne!(o.status.code(), Some(0));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn every_writer_takes_per_edge_levels() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-adaptive-fmt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // fandisk with creases: split normals along the crease edges.
    let fandisk = common::shared_spec("fandisk.obj");
    let mut counts = Vec::new();
    for ext in ["obj", "ply", "stl", "glb"] {
        let out = dir.join(format!("f.{ext}"));
        let o = g1tess(&[
            "tessellate",
            &fandisk,
            "--crease-angle",
            "30",
            "--tolerance-rel",
            "3e-4",
            "--backend",
            "cpu",
            "-q",
            "--json",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(j["adaptive"]["tolerance_met"], true);
        assert!(j["crease_edges"].as_u64().unwrap() > 0);
        let tris = j["triangles"].as_u64().unwrap();
        let file_vertices = j["file_vertices"].as_u64().unwrap();
        let bytes = std::fs::read(&out).unwrap();
        // Each file's own count of triangles and vertices, read from its bytes.
        let (t, v) = match ext {
            "obj" => {
                let text = String::from_utf8(bytes).unwrap();
                let n = |p: &str| text.lines().filter(|l| l.starts_with(p)).count() as u64;
                (n("f "), n("v "))
            }
            "ply" => {
                let end = bytes
                    .windows(11)
                    .position(|w| w == b"end_header\n")
                    .unwrap();
                let header = String::from_utf8_lossy(&bytes[..end]).to_string();
                let count = |e: &str| {
                    header
                        .lines()
                        .find_map(|l| l.strip_prefix(&format!("element {e} ")))
                        .unwrap()
                        .trim()
                        .parse::<u64>()
                        .unwrap()
                };
                (count("face"), count("vertex"))
            }
            "stl" => {
                let n = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as u64;
                assert_eq!(bytes.len() as u64, 84 + 50 * n);
                (n, file_vertices)
            }
            _ => {
                let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
                let json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + len]).unwrap();
                let acc = json["accessors"].as_array().unwrap();
                let v = acc[0]["count"].as_u64().unwrap();
                let i = acc.iter().find(|a| a["type"] == "SCALAR").unwrap()["count"]
                    .as_u64()
                    .unwrap();
                (i / 3, v)
            }
        };
        assert_eq!((t, v), (tris, file_vertices), "{ext}");
        counts.push(tris);
    }
    // The same levels whatever the format.
    assert!(counts.windows(2).all(|w| w[0] == w[1]), "{counts:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
