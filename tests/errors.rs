//! The library's errors are typed: callers match on the kind of failure (an unsupported
//! format, a memory budget, a GPU limit or feature, a lost device) and each kind still
//! prints its one-line message.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use g1tess::generators;
use g1tess::Error;
use g1tess::GpuEvaluator;
use g1tess::MeshFormat;
use g1tess::{Evaluator, Pattern};
use g1tess::{GpuContext, GpuTessellator, Precision};
use g1tess::{LoadOptions, Mesh};
use g1tess::{PatchTable, Scheme};

/// The shared GPU context, or None (the test prints SKIP) without an adapter.
fn context() -> Option<Arc<GpuContext>> {
    match crate::common::shared_gpu() {
        Ok(c) => Some(c),
        Err(e) => {
            eprintln!("SKIP: no GPU adapter ({e})");
            None
        }
    }
}

#[test]
fn gpu_binding_limit_below_one_sample_is_limit_exceeded_with_the_sizes() {
    let Some(ctx) = context() else { return };
    let mut gpu = GpuEvaluator::new(ctx, Precision::F32).unwrap();
    gpu.max_binding_bytes = 8;
    let mesh = generators::from_spec("icosphere:0").unwrap().unwrap();
    let table = PatchTable::build(&mesh, Scheme::Pn, &Default::default()).unwrap();
    let err = gpu
        .evaluate(&table, &Pattern::Grid { level: 2 }, &mut |_| Ok(()))
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "gpu: storage binding limit of 8 bytes is below one sample"
    );
    match err {
        // One sample is a position and a normal: 6 f32 of 4 bytes.
        Error::LimitExceeded {
            name,
            needed,
            allowed,
            ..
        } => {
            assert_eq!(name, "max_storage_buffer_binding_size");
            assert_eq!((needed, allowed), (24, 8));
        }
        other => panic!("expected LimitExceeded, got {other:?}"),
    }
}

#[test]
fn destroyed_device_is_reported_as_device_lost() {
    if context().is_none() {
        return;
    }
    let ctx = GpuContext::new().unwrap();
    assert!(ctx.check().is_ok());
    ctx.device.destroy();
    let _ = ctx.wait();
    match ctx.check() {
        Err(Error::DeviceLost { device, .. }) => assert_eq!(device, ctx.info.name),
        other => panic!("expected DeviceLost, got {other:?}"),
    }
}

/// A file of this test module under the test binary's temporary directory.
fn temp_file(name: &str, contents: &[u8]) -> PathBuf {
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("errors-{name}"));
    std::fs::write(&path, contents).unwrap();
    path
}

#[test]
fn unknown_extension_is_unsupported_format() {
    let path = temp_file("model.fbx", b"not read");
    let err = Mesh::load(path.to_str().unwrap(), &LoadOptions::default()).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "{}: FBX files are not supported (supported: OBJ, PLY, STL, glTF (.gltf, .glb), .pn)",
            path.display()
        )
    );
    match err {
        Error::UnsupportedFormat { name, what } => {
            assert_eq!(name, path.display().to_string());
            assert!(what.starts_with("FBX files"), "{what}");
        }
        other => panic!("expected UnsupportedFormat, got {other:?}"),
    }
    match MeshFormat::from_path(Path::new("out.xyz")) {
        Err(Error::UnsupportedFormat { name, what }) => {
            assert_eq!(name, "out.xyz");
            assert_eq!(
                what,
                "unknown output format 'xyz' (known: .obj, .ply, .stl, .glb)"
            );
        }
        other => panic!("expected UnsupportedFormat, got {other:?}"),
    }
}

#[test]
fn unknown_ply_format_is_unsupported_format_at_its_line() {
    let path = temp_file("ebcdic.ply", b"ply\nformat ebcdic 1.0\nend_header\n");
    let err = Mesh::load(path.to_str().unwrap(), &LoadOptions::default()).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!("{}:2: unknown format 'ebcdic'", path.display())
    );
    assert!(
        matches!(&err, Error::UnsupportedFormat { name, .. } if *name == format!("{}:2", path.display())),
        "{err:?}"
    );
}

#[test]
fn tessellator_on_a_small_device_names_the_missing_feature_and_the_limit() {
    let Some(ctx) = context() else { return };
    // A device without SHADER_F64 and with 256-byte storage bindings (the adapter's other
    // limits), opened apart from the shared one.
    let limits = wgpu::Limits {
        max_storage_buffer_binding_size: 256,
        ..ctx.limits.clone()
    };
    let (device, queue) = pollster::block_on(ctx.adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("g1tess small"),
        required_features: wgpu::Features::empty(),
        required_limits: limits,
        ..Default::default()
    }))
    .unwrap();
    let mesh = generators::from_spec("icosphere:1").unwrap().unwrap();
    let table = PatchTable::build(&mesh, Scheme::Pn, &Default::default()).unwrap();
    match GpuTessellator::new(&device, &queue, &mesh, &table, Precision::F64) {
        Err(Error::MissingFeature { feature, .. }) => assert_eq!(feature, "SHADER_F64"),
        Err(other) => panic!("expected MissingFeature, got {other:?}"),
        Ok(_) => panic!("expected MissingFeature, got a tessellator"),
    }
    match GpuTessellator::new(&device, &queue, &mesh, &table, Precision::F32) {
        Err(Error::LimitExceeded {
            name,
            needed,
            allowed,
            message,
        }) => {
            assert_eq!(name, "max_storage_buffer_binding_size");
            assert_eq!(allowed, 256);
            // 80 patches of 10 f32 control points (3 coordinates each) alone take 9,600
            // bytes, whatever else a patch record holds.
            assert!(needed >= 9600, "{needed}");
            assert!(
                message.ends_with(&format!(
                    "of 80 patches takes {needed} bytes, over the device's storage binding \
                     limit of 256"
                )),
                "{message}"
            );
        }
        Err(other) => panic!("expected LimitExceeded, got {other:?}"),
        Ok(_) => panic!("expected LimitExceeded, got a tessellator"),
    }
}
