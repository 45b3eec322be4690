//! `--backend cpu|gpu|auto` on the command line: the GPU names its adapter, `auto` falls
//! back to the CPU with a message when no Vulkan driver can be loaded, `gpu` then fails
//! with one line. The no-driver cases hide every Vulkan driver from the loader, so they
//! run on any machine; the GPU case follows the GPU tests' rule (CI=true: must run).

use std::process::Command;

fn g1tess(args: &[&str], no_driver: bool) -> (bool, String, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_g1tess"));
    cmd.args(args);
    if no_driver {
        // Both spellings of the Vulkan loader's driver list (old and new loaders).
        cmd.env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
            .env("VK_DRIVER_FILES", "/nonexistent/icd.json");
    }
    let out = cmd.output().expect("run g1tess");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn json(stdout: &str) -> serde_json::Value {
    serde_json::from_str(stdout.trim()).unwrap_or_else(|e| panic!("{e}: {stdout}"))
}

#[test]
fn auto_falls_back_to_the_cpu_and_says_so() {
    let (ok, out, err) = g1tess(&["stats", "sphere320", "--json"], true);
    assert!(ok, "{err}");
    assert!(err.contains("falling back to the CPU"), "{err}");
    let v = json(&out);
    assert!(v["backend"].as_str().unwrap().starts_with("cpu"), "{v}");
    // The CPU reference: G1 to rounding.
    assert!(1.0 - v["cos"]["min"].as_f64().unwrap() < 1e-14, "{v}");
}

#[test]
fn gpu_without_a_driver_is_one_line_error() {
    let (ok, out, err) = g1tess(&["stats", "sphere320", "--backend", "gpu"], true);
    assert!(!ok);
    assert!(out.is_empty(), "{out}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.starts_with("error: gpu: no Vulkan adapter"), "{err}");
}

#[test]
fn gpu_backend_names_its_adapter() {
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    if let Err(e) = g1tess::gpu::GpuContext::shared() {
        assert!(!ci, "CI=true and no GPU adapter: {e}");
        eprintln!("\n======== SKIP: no GPU adapter ({e}); GPU CLI test not run ========\n");
        return;
    }
    for precision in ["f32", "f64"] {
        let (ok, out, err) = g1tess(
            &[
                "stats",
                "torus200",
                "--backend",
                "gpu",
                "--precision",
                precision,
                "--json",
            ],
            false,
        );
        if !ok && precision == "f64" && err.contains("SHADER_F64") {
            eprintln!("NOTE: adapter without SHADER_F64: {err}");
            continue;
        }
        assert!(ok, "{err}");
        eprintln!("{}", err.trim());
        let v = json(&out);
        let backend = v["backend"].as_str().unwrap();
        assert!(
            backend.starts_with(&format!("gpu ({precision}, ")),
            "{backend}"
        );
        assert!(err.starts_with("gpu: "), "{err}");
        assert!(err.contains("Vulkan"), "{err}");
        // Same edge count as the CPU, G1 within the GPU precision.
        assert_eq!(v["samples"].as_u64(), Some(21 * 300));
        let bound = if precision == "f32" { 1e-5 } else { 1e-12 };
        assert!(1.0 - v["cos"]["min"].as_f64().unwrap() <= bound, "{v}");
    }
}
