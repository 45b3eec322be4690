//! `g1tess bench --json` end to end on a small mesh: one row per scheme and level, sample
//! counts of the grid, every throughput consistent with its time and with the roofline
//! measured in the same run. Speeds are reported, never asserted.

use std::process::Command;

use g1tess::grid_len;

fn bench(args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .arg("bench")
        .args(args)
        .output()
        .expect("run g1tess bench");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

/// Rates, fractions and bandwidths are quotients of the reported numbers; JSON carries
/// f64 to the last bit, so they agree to a few f64 ulps (1e-9 is far above that and far
/// below any real inconsistency).
const QUOTIENT: f64 = 1e-9;

fn check_rate(r: &serde_json::Value, samples: f64, roofline: f64) {
    let s = r["seconds"].as_f64().unwrap();
    let rate = r["samples_per_s"].as_f64().unwrap();
    assert!(s > 0.0 && s.is_finite(), "{r}");
    assert!((rate * s / samples - 1.0).abs() < QUOTIENT, "{r}");
    let f = r["roofline_fraction"].as_f64().unwrap();
    assert!((f * roofline / rate - 1.0).abs() < QUOTIENT, "{r}");
}

#[test]
fn bench_json_rows_and_rates_are_consistent() {
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    let context = crate::common::shared_gpu();
    let gpu = context.is_ok();
    let software = context.is_ok_and(|c| c.info.device_type == wgpu::DeviceType::Cpu);
    assert!(gpu || !ci, "CI=true and no GPU adapter");
    let v = bench(&[
        "sphere320",
        "--levels",
        "2,3",
        "--schemes",
        "g1,flat",
        "--bandwidth-mib",
        "64",
        "--json",
        "--quiet",
    ]);
    let m = &v["machine"];
    let bw = m["write_bandwidth_gbs"].as_f64().unwrap();
    assert!(bw > 0.0 && m["write_bandwidth_1_thread_gbs"].as_f64().unwrap() > 0.0);
    let roofline = m["roofline_samples_per_s"].as_f64().unwrap();
    assert!((roofline * 24.0 / (bw * 1e9) - 1.0).abs() < QUOTIENT);
    assert_eq!(m["gpu"].is_string(), gpu, "{m}");
    let rows = v["rows"].as_array().unwrap();
    let keys: Vec<_> = rows
        .iter()
        .map(|r| (r["scheme"].as_str().unwrap(), r["level"].as_u64().unwrap()))
        .collect();
    assert_eq!(keys, [("g1", 2), ("g1", 3), ("flat", 2), ("flat", 3)]);
    for r in rows {
        let samples = r["samples"].as_f64().unwrap();
        assert_eq!(
            samples as usize,
            320 * grid_len(r["level"].as_u64().unwrap() as u32)
        );
        assert!(r["build_s"].as_f64().unwrap() > 0.0);
        for k in [
            "cpu_f32_1_thread",
            "cpu_f32_all_threads",
            "cpu_f32_all_threads_whole_output",
            "cpu_f64_reference_all_threads",
        ] {
            check_rate(&r[k], samples, roofline);
        }
        for k in [
            "gpu_dispatch_only",
            "gpu_with_readback",
            "gpu_to_f32_sink",
            "gpu_to_f32_sink_single_buffer",
            "gpu_ceiling",
        ] {
            if gpu {
                check_rate(&r[k], samples, roofline);
            } else {
                assert!(r[k].is_null(), "{r}");
            }
        }
        // The two fractions are quotients of the rates of the same row.
        let rate = |k: &str| r[k]["samples_per_s"].as_f64().unwrap();
        if gpu {
            let d = rate("gpu_dispatch_only");
            let c = r["gpu_ceiling_fraction"].as_f64().unwrap();
            assert!((c * rate("gpu_ceiling") / d - 1.0).abs() < QUOTIENT, "{r}");
            let f = r["gpu_cpu_f32_fraction"].as_f64().unwrap();
            assert!(
                (f * rate("cpu_f32_all_threads") / d - 1.0).abs() < QUOTIENT,
                "{r}"
            );
            // The patch loop's bound exists where grids run the patch loop: on software
            // adapters (G1 at any level, flat's basis fits the uniform table at 2 and 3).
            if software {
                check_rate(&r["gpu_loop_bound"], samples, roofline);
                let b = r["gpu_loop_bound_fraction"].as_f64().unwrap();
                assert!(
                    (b * rate("gpu_ceiling") / rate("gpu_loop_bound") - 1.0).abs() < QUOTIENT,
                    "{r}"
                );
            } else {
                assert!(r["gpu_loop_bound"].is_null(), "{r}");
                assert!(r["gpu_loop_bound_fraction"].is_null(), "{r}");
            }
        } else {
            assert!(r["gpu_loop_bound"].is_null(), "{r}");
            assert!(r["gpu_ceiling_fraction"].is_null(), "{r}");
            assert!(r["gpu_cpu_f32_fraction"].is_null(), "{r}");
        }
    }
}

/// `bench --gpu-check --json` (what scripts/gpu-check.sh runs) on a small mesh: the
/// adapter named, the copy bandwidth positive, the four rows with their sample counts,
/// and every rate and bandwidth fraction consistent with the reported numbers. Without an
/// adapter it fails with one line (with CI=true an adapter must exist).
#[test]
fn bench_gpu_check_rows_are_consistent() {
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    let args = [
        "bench",
        "sphere320",
        "--gpu-check",
        "--levels",
        "2,3",
        "--bandwidth-mib",
        "16",
        "--json",
        "--quiet",
    ];
    if let Err(e) = crate::common::shared_gpu() {
        assert!(!ci, "CI=true and no GPU adapter: {e}");
        let out = Command::new(env!("CARGO_BIN_EXE_g1tess"))
            .args(args)
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        return;
    }
    let v = bench(&args[1..]);
    assert!(v["gpu"].as_str().unwrap().contains("Vulkan"), "{v}");
    let bw = v["copy_bandwidth_gbs"].as_f64().unwrap();
    assert!(bw > 0.0 && bw.is_finite(), "{v}");
    assert_eq!(v["copy_mib"].as_u64(), Some(16));
    assert_eq!(v["triangles"].as_u64(), Some(320));
    let rows = v["rows"].as_array().unwrap();
    let keys: Vec<_> = rows
        .iter()
        .map(|r| (r["step"].as_str().unwrap(), r["level"].as_u64()))
        .collect();
    assert_eq!(
        keys,
        [
            ("device_resident", Some(2)),
            ("readback_f32", Some(2)),
            ("tessellator_frame", Some(2)),
            ("device_resident", Some(3)),
            ("readback_f32", Some(3)),
            ("tessellator_frame", Some(3)),
            ("statistics", None)
        ]
    );
    for r in rows {
        let samples = r["samples"].as_f64().unwrap();
        let expect = match r["level"].as_u64() {
            // The welded surface's vertices: sphere320 is closed (162 vertices, 480 edges,
            // 320 faces), so V + E (l − 1) + F (l − 1)(l − 2)/2.
            Some(l) if r["step"] == "tessellator_frame" => {
                let l = l as usize;
                162 + 480 * (l - 1) + 320 * (l - 1) * (l - 2) / 2
            }
            Some(l) => 320 * grid_len(l as u32),
            // 21 samples on each of sphere320's 480 interior edges.
            None => 21 * 480,
        };
        assert_eq!(samples as usize, expect, "{r}");
        let (s, rate) = (
            r["seconds"].as_f64().unwrap(),
            r["samples_per_s"].as_f64().unwrap(),
        );
        assert!(
            s > 0.0 && (rate * s / samples - 1.0).abs() < QUOTIENT,
            "{r}"
        );
        let bytes = r["bytes_per_sample"].as_f64().unwrap();
        let gb = r["gb_per_s"].as_f64().unwrap();
        assert!((gb * 1e9 / (rate * bytes) - 1.0).abs() < QUOTIENT, "{r}");
        let f = r["bandwidth_fraction"].as_f64().unwrap();
        assert!((f * bw / gb - 1.0).abs() < QUOTIENT, "{r}");
    }
    // f32 grid samples write 24 bytes.
    assert_eq!(rows[0]["bytes_per_sample"].as_u64(), Some(24));
    // A welded vertex: 24 bytes, and its share of 3 l² F 32-bit indices: 3840 · 4 / 642 and
    // 8640 · 4 / 1442 bytes at levels 2 and 3, both just under 24, rounded up.
    assert_eq!(rows[2]["bytes_per_sample"].as_u64(), Some(48));
    assert_eq!(rows[5]["bytes_per_sample"].as_u64(), Some(48));
}

#[test]
fn bench_without_gpu_says_why() {
    let v = bench(&[
        "sphere320",
        "--levels",
        "1",
        "--schemes",
        "flat",
        "--bandwidth-mib",
        "16",
        "--no-gpu",
        "--no-reference",
        "--json",
    ]);
    assert!(v["machine"]["gpu"].is_null());
    assert_eq!(v["machine"]["gpu_note"], "--no-gpu");
    let r = &v["rows"][0];
    assert!(r["gpu_dispatch_only"].is_null() && r["cpu_f64_reference_all_threads"].is_null());
}

/// `bench --end-to-end --json` on a small mesh: every step once (wc -w where the system has
/// it), sample and byte counts from the mesh and the files, rates consistent with the
/// times, ratios with the baselines of the same run, the machine named, no file left.
#[test]
fn bench_end_to_end_rows_are_consistent() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-bench-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let v = bench(&[
        "sphere320",
        "--end-to-end",
        "--tess-level",
        "5",
        "--stats-level",
        "2",
        "--memory-levels",
        "2,5",
        "--dir",
        dir.to_str().unwrap(),
        "--json",
        "--quiet",
    ]);
    let m = &v["machine"];
    assert!(!m["cpu"].as_str().unwrap().is_empty());
    assert!(m["cpus"].as_u64().unwrap() >= 1 && m["threads"].as_u64().unwrap() >= 1);
    assert_eq!(v["triangles"], 320);
    // Level 2 splits each triangle into 4.
    assert_eq!(v["stats_triangles"], 320 * 4);
    let rows = v["rows"].as_array().unwrap();
    let steps: Vec<&str> = rows.iter().map(|r| r["step"].as_str().unwrap()).collect();
    let wc = std::process::Command::new("wc")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    let mut want = Vec::new();
    for _ in [2, 5] {
        want.extend([
            "tessellate_setup",
            "tessellate_eval",
            "tessellate_setup_eval",
        ]);
    }
    want.extend([
        "tessellate_memory",
        "tessellate_ply_file",
        "plain_write",
        "piped_write",
        "load_obj",
        "count_words",
    ]);
    if wc {
        want.push("wc_w");
    }
    want.push("stats");
    assert_eq!(steps, want);
    let row = |step: &str| rows.iter().find(|r| r["step"] == step).unwrap();
    for r in rows {
        let s = r["seconds"].as_f64().unwrap();
        assert!(s > 0.0 && s.is_finite(), "{r}");
        // Rates are the counts over the time (to f64 rounding).
        if let Some(n) = r["samples"].as_f64() {
            assert!((r["samples_per_s"].as_f64().unwrap() * s / n - 1.0).abs() < QUOTIENT);
        }
        if let Some(b) = r["bytes"].as_f64() {
            assert!((r["mb_per_s"].as_f64().unwrap() * 1e6 * s / b - 1.0).abs() < QUOTIENT);
        }
    }
    let samples = 320 * grid_len(5) as u64;
    assert_eq!(row("tessellate_memory")["samples"], samples);
    // Set-up and evaluation apart at levels 2 and 5, each row with its level's samples;
    // the sum row is the sum of the two; level 5 is --tess-level, so tessellate_memory is
    // its evaluation row.
    for (k, level) in [2u64, 5].into_iter().enumerate() {
        let [setup, eval, both] = [0, 1, 2].map(|j| &rows[3 * k + j]);
        for r in [setup, eval, both] {
            assert_eq!(r["level"], level);
            assert_eq!(r["samples"], 320 * grid_len(level as u32) as u64);
        }
        // The sum of the two to the last bits (serde_json's reading of a float may be an
        // ulp off).
        let sum = setup["seconds"].as_f64().unwrap() + eval["seconds"].as_f64().unwrap();
        assert!((both["seconds"].as_f64().unwrap() / sum - 1.0).abs() < QUOTIENT);
    }
    assert_eq!(row("tessellate_memory")["seconds"], rows[4]["seconds"]);
    assert_eq!(row("tessellate_memory")["level"], 5);
    assert_eq!(row("load_obj")["level"], serde_json::Value::Null);
    let file = row("tessellate_ply_file");
    assert_eq!(file["samples"], samples);
    // PLY: header, then 24 bytes per vertex record and 13 per triangle. The sphere is
    // smooth: records = positions = V + E(n − 1) + F(n − 1)(n − 2)/2.
    let records = 162 + 480 * 4 + 320 * 6;
    let body = 24 * records + 13 * 320 * 25;
    let bytes = file["bytes"].as_u64().unwrap();
    assert!(bytes > body && bytes < body + 400, "{bytes} vs body {body}");
    let plain = row("plain_write");
    assert_eq!(plain["bytes"], bytes);
    assert_eq!(row("piped_write")["bytes"], bytes);
    let ratio = file["ratio_to_baseline"].as_f64().unwrap();
    assert!(
        (ratio * plain["seconds"].as_f64().unwrap() / file["seconds"].as_f64().unwrap() - 1.0)
            .abs()
            < QUOTIENT
    );
    let load = row("load_obj");
    let count = row("count_words");
    assert_eq!(load["bytes"], count["bytes"]);
    // The OBJ at level 2: 162 + 480 positions and as many normals (smooth), 1280 faces,
    // 4 words per v, vn and f line, and 2 + 11 words in the two header comments.
    let positions = 162 + 480;
    let words = 4 * (2 * positions + 320 * 4) + 13;
    assert!(
        count["what"]
            .as_str()
            .unwrap()
            .contains(&format!("({words} words)")),
        "{count}"
    );
    if wc {
        assert!(row("wc_w")["what"]
            .as_str()
            .unwrap()
            .contains(&format!("({words} words)")));
    }
    // Stats: 21 samples on each of the 1280 × 3 / 2 interior edges of the closed mesh.
    assert_eq!(row("stats")["samples"], 21 * 1920);
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        0,
        "files left behind"
    );
    std::fs::remove_dir(&dir).unwrap();
}
