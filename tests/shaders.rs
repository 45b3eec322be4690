//! Every evaluation shader (each scheme file × patch kind it serves × f32/f64) parses and
//! validates with naga, as wgpu would on shader creation. No GPU needed.

use g1tess::gpu::shaders::{self, scheme_file, validate, variants, FILES};
use g1tess::gpu::Precision;
use g1tess::patch::{PatchKind, Scheme};

/// Whether a naga module has a float type of `width` bytes.
fn has_float(module: &naga::Module, width: u8) -> bool {
    module.types.iter().any(|(_, t)| {
        let scalar = match t.inner {
            naga::TypeInner::Scalar(s) => Some(s),
            naga::TypeInner::Vector { scalar, .. } => Some(scalar),
            _ => None,
        };
        scalar.is_some_and(|s| s.kind == naga::ScalarKind::Float && s.width == width)
    })
}

#[test]
fn every_shader_validates_in_f32_and_f64() {
    let all = variants();
    // Every file serves at least one kind, and every patch kind has a file.
    assert_eq!(all.len(), 7, "{all:?}");
    for kind in [
        PatchKind::Bezier(1),
        PatchKind::Bezier(2),
        PatchKind::Bezier(3),
        PatchKind::Gregory,
        PatchKind::PnNormals,
    ] {
        assert!(
            all.iter().any(|(_, k)| *k == kind),
            "no shader for {kind:?}"
        );
    }
    for (file, kind) in all {
        for precision in [Precision::F32, Precision::F64] {
            let src = shaders::module_source(file, kind, precision);
            let module = validate(&src, precision)
                .unwrap_or_else(|e| panic!("{} {kind:?} {precision}: {e}", file.name));
            let entries: Vec<_> = module
                .entry_points
                .iter()
                .map(|e| e.name.as_str())
                .collect();
            assert_eq!(
                entries,
                ["grid_main", "grid_table_main", "points_main"],
                "{}",
                file.name
            );
            // The f64 module really computes in f64 (the f32 one validated without the
            // FLOAT64 capability, so it has none).
            assert_eq!(
                has_float(&module, 8),
                precision == Precision::F64,
                "{} {kind:?} {precision}",
                file.name
            );
        }
    }
}

#[test]
fn f64_module_needs_the_float64_capability() {
    // The f64 source validated as if it were f32 (no FLOAT64 capability) must fail: the
    // capability check is real.
    let src = shaders::module_source(shaders::G1, PatchKind::Gregory, Precision::F64);
    let err = validate(&src, Precision::F32).expect_err("f64 module accepted without FLOAT64");
    assert!(err.to_string().contains("validation"), "{err}");
}

#[test]
fn broken_shader_is_reported_with_naga_text() {
    let src = shaders::module_source(shaders::FLAT, PatchKind::Bezier(1), Precision::F32)
        .replace("return bezier(1u, b);", "return bezier(1u, b, b);");
    let err = validate(&src, Precision::F32).expect_err("broken shader accepted");
    assert!(err.to_string().contains("WGSL"), "{err}");
}

#[test]
fn schemes_map_to_their_files() {
    for scheme in Scheme::all() {
        // Every scheme's table kind has a file (the kind comes from a tiny table).
        let mesh = g1tess::mesh::generators::icosphere(0);
        let table = g1tess::patch::PatchTable::build(&mesh, scheme, &Default::default()).unwrap();
        let file = scheme_file(scheme, table.kind).unwrap();
        assert!(file.kinds.contains(&table.kind));
        let stem = file.name.trim_end_matches(".wgsl");
        assert!(
            scheme.name().starts_with(stem)
                || FILES
                    .iter()
                    .all(|f| !scheme.name().starts_with(f.name.trim_end_matches(".wgsl"))),
            "{scheme} -> {}",
            file.name
        );
    }
    assert_eq!(
        scheme_file(Scheme::G1, PatchKind::Gregory).unwrap().name,
        "g1.wgsl"
    );
    assert_eq!(
        scheme_file(Scheme::Flat, PatchKind::Bezier(1))
            .unwrap()
            .name,
        "flat.wgsl"
    );
    // A file never evaluates a kind it was not written for.
    assert!(scheme_file(Scheme::Flat, PatchKind::Bezier(2)).is_err());
    assert!(scheme_file(Scheme::G1, PatchKind::Bezier(3)).is_err());
}
