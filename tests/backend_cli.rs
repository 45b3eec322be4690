//! `--backend cpu|gpu|auto` on the command line: the GPU names its adapter, `auto` falls
//! back to the CPU with a message when no Vulkan driver can be loaded (and prefers the CPU
//! to a software adapter, saying so once), `gpu` then fails with one line, and a
//! successful GPU run prints no `error:` line (also without XDG_RUNTIME_DIR). The no-driver cases hide every Vulkan driver from the loader, so they
//! run on any machine; the GPU case follows the GPU tests' rule (CI=true: must run).

use std::process::Command;

fn g1tess(args: &[&str], no_driver: bool) -> (bool, String, String) {
    g1tess_env(args, no_driver, &[])
}

/// [`g1tess`] with the variables `unset` removed from the environment.
fn g1tess_env(args: &[&str], no_driver: bool, unset: &[&str]) -> (bool, String, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_g1tess"));
    for v in unset {
        cmd.env_remove(v);
    }
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
    // The CPU reference: G1 to f64 rounding (two unit normals of the same tangent plane
    // agree to a few ulps).
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

/// `--backend gpu` names its adapter and agrees with the CPU where an adapter exists, and
/// fails with one line where none does (with CI=true an adapter must exist).
#[test]
fn gpu_backend_names_its_adapter_or_says_there_is_none() {
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    let precisions: &[&str] = match crate::common::shared_gpu() {
        Ok(_) => &["f32", "f64"],
        Err(e) => {
            assert!(!ci, "CI=true and no GPU adapter: {e}");
            eprintln!(
                "expected error: no GPU adapter ({e}): checking the one-line failure instead"
            );
            let (ok, out, err) = g1tess(&["stats", "torus200", "--backend", "gpu"], false);
            assert!(!ok && out.is_empty(), "{out}");
            assert_eq!(err.trim().lines().count(), 1, "{err}");
            assert!(err.starts_with("error: gpu: "), "{err}");
            &[]
        }
    };
    for &precision in precisions {
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
            eprintln!("expected error: adapter without SHADER_F64: {}", err.trim());
            assert_eq!(err.trim().lines().count(), 1, "{err}");
            continue;
        }
        assert!(ok, "{err}");
        eprintln!("stderr of a passing run: {}", err.trim());
        let v = json(&out);
        let backend = v["backend"].as_str().unwrap();
        assert!(
            backend.starts_with(&format!("gpu ({precision}, ")),
            "{backend}"
        );
        assert!(err.starts_with("gpu: "), "{err}");
        assert!(err.contains("Vulkan"), "{err}");
        // Same edge count as the CPU: 21 samples on each of torus200's 300 edges.
        assert_eq!(v["samples"].as_u64(), Some(21 * 300));
        // G1 to the working precision: 1 − cos of two unit normals rounded in f32 is a
        // few f32 ulps (1e-5 leaves room for the normalisation of each side); in f64 a
        // few f64 ulps amplified by the torus's curvature (1e-12).
        let bound = if precision == "f32" { 1e-5 } else { 1e-12 };
        assert!(1.0 - v["cos"]["min"].as_f64().unwrap() <= bound, "{v}");
    }
}

/// `auto` runs the CPU where every Vulkan adapter is a software one (lavapipe shares the
/// CPU's cores and is slower than the CPU backend) and says so in exactly one line; with a
/// hardware adapter it runs the GPU. Either way no line says `error`.
#[test]
fn auto_prefers_the_cpu_to_a_software_adapter() {
    let adapters = g1tess::gpu_adapters();
    let names: Vec<String> = adapters
        .iter()
        .map(|a| format!("{} ({:?})", a.name, a.device_type))
        .collect();
    eprintln!("Vulkan adapters: {names:?}");
    let (ok, out, err) = g1tess(&["stats", "torus200", "--json"], false);
    assert!(ok, "{err}");
    assert!(!err.to_lowercase().contains("error"), "{err}");
    let backend = json(&out)["backend"].as_str().unwrap().to_string();
    if adapters.is_empty() {
        assert!(backend.starts_with("cpu"), "{backend}");
        assert!(err.contains("falling back to the CPU"), "{err}");
    } else if adapters
        .iter()
        .all(|a| a.device_type == wgpu::DeviceType::Cpu)
    {
        assert!(backend.starts_with("cpu"), "{backend}");
        assert_eq!(err.trim().lines().count(), 1, "said once: {err}");
        assert!(
            err.starts_with("note: the only Vulkan adapter is a software one ("),
            "{err}"
        );
        assert!(err.contains(&adapters[0].name), "{err}");
        assert!(err.contains("using the CPU backend"), "{err}");
        // One sentence, not the source's line breaks kept as runs of spaces.
        assert!(!err.contains("  "), "{err}");
    } else {
        assert!(backend.starts_with("gpu ("), "{backend}");
        assert!(err.starts_with("gpu: "), "{err}");
    }
}

/// A successful `--backend gpu` run (on lavapipe too) prints its adapter line and no
/// `error:` line, also when XDG_RUNTIME_DIR is unset (the Vulkan loader complains about a
/// missing runtime folder; the binary gives it a private one). `tessellate` and `stats`
/// both go through it.
#[test]
fn gpu_run_prints_no_error_line_without_xdg_runtime_dir() {
    let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
    if let Err(e) = crate::common::shared_gpu() {
        assert!(!ci, "CI=true and no GPU adapter: {e}");
        eprintln!("expected: no GPU adapter ({e}); the no-adapter cases are tested above");
        return;
    }
    let obj = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-backend-{}.obj", std::process::id()));
    let obj_s = obj.display().to_string();
    for args in [
        &[
            "stats",
            "sphere320",
            "--backend",
            "gpu",
            "--precision",
            "f32",
        ][..],
        &[
            "tessellate",
            "sphere320",
            "--level",
            "2",
            "--backend",
            "gpu",
            "-o",
            &obj_s,
        ][..],
    ] {
        for unset in [&["XDG_RUNTIME_DIR"][..], &[]] {
            let (ok, _, err) = g1tess_env(args, false, unset);
            assert!(ok, "{args:?}: {err}");
            assert!(err.starts_with("gpu: "), "{args:?}: {err}");
            assert!(
                !err.lines().any(|l| l.to_lowercase().contains("error")),
                "{args:?} (unset {unset:?}): {err}"
            );
        }
    }
    // 320 triangles at level 2: 162 vertices, 480 edges with one interior sample each.
    let text = std::fs::read_to_string(&obj).unwrap();
    let _ = std::fs::remove_file(&obj);
    assert_eq!(
        text.lines().filter(|l| l.starts_with("v ")).count(),
        162 + 480
    );
    assert_eq!(
        text.lines().filter(|l| l.starts_with("f ")).count(),
        320 * 4
    );
}
