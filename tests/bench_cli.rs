//! `g1tess bench --json` end to end on a small mesh: one row per scheme and level, sample
//! counts of the grid, every throughput consistent with its time and with the roofline
//! measured in the same run. Speeds are reported, never asserted.

use std::process::Command;

use g1tess::eval::grid_len;

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

fn check_rate(r: &serde_json::Value, samples: f64, roofline: f64) {
    let s = r["seconds"].as_f64().unwrap();
    let rate = r["samples_per_s"].as_f64().unwrap();
    assert!(s > 0.0 && s.is_finite(), "{r}");
    assert!((rate * s / samples - 1.0).abs() < 1e-9, "{r}");
    let f = r["roofline_fraction"].as_f64().unwrap();
    assert!((f * roofline / rate - 1.0).abs() < 1e-9, "{r}");
}

#[test]
fn bench_json_rows_and_rates_are_consistent() {
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    let gpu = g1tess::gpu::GpuContext::shared().is_ok();
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
    assert!((roofline * 24.0 / (bw * 1e9) - 1.0).abs() < 1e-9);
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
        for k in ["gpu_dispatch_only", "gpu_with_readback"] {
            if gpu {
                check_rate(&r[k], samples, roofline);
            } else {
                assert!(r[k].is_null(), "{r}");
            }
        }
    }
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
