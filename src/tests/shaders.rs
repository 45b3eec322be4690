//! The evaluation shaders without a GPU: every module (one per patch kind × f32/f64) parses
//! and validates with naga as wgpu would; modules are chosen by patch kind; the generated
//! header matches `PatchKind::layout()` and the crate's constants; the WGSL files copy none
//! of those numbers; and every Rust function a WGSL file says it mirrors exists.

use std::collections::BTreeSet;

use crate::gpu::shaders::{
    ceiling_source, file_for, header, loop_bound_source, module_source, patch_vecs, stats_source,
    validate, variants, BEZIER, CEILING, COMMON, EXTRA_VECS, FILES, GREGORY, LOOP_BOUND,
    SLOT_CORNERS, SLOT_FLAT_NORMAL, SLOT_ORIGIN_LO, STATS, STATS_REALS, UNIFORM_TABLE_BYTES,
    WORKGROUP,
};
use crate::patch::basis::MAX_POINTS;
use crate::patch::{MIN_NORMAL_LEN_F32, MIN_NORMAL_LEN_F64};
use crate::Precision;
use crate::{PatchKind, PatchTable, Scheme};

use crate::tests::common;

const PRECISIONS: [Precision; 2] = [Precision::F32, Precision::F64];

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

/// The literal value of module constant `name`.
fn constant(module: &naga::Module, name: &str) -> naga::Literal {
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no constant {name}"));
    match module.global_expressions[c.init] {
        naga::Expression::Literal(l) => l,
        ref e => panic!("constant {name} is not a literal: {e:?}"),
    }
}

fn constant_u32(module: &naga::Module, name: &str) -> usize {
    match constant(module, name) {
        naga::Literal::U32(v) => v as usize,
        l => panic!("{name} = {l:?} is not a u32"),
    }
}

/// The value of a real constant, and whether it is an f64.
fn constant_real(module: &naga::Module, name: &str) -> (f64, bool) {
    match constant(module, name) {
        naga::Literal::F32(v) => (v as f64, false),
        naga::Literal::F64(v) => (v, true),
        l => panic!("{name} = {l:?} is not a real"),
    }
}

/// The entry points of every evaluation module, in order.
const EVAL_ENTRIES: [&str; 4] = [
    "grid_main",
    "grid_table_main",
    "points_main",
    "grid_patch_main",
];

fn entry_points(module: &naga::Module) -> Vec<&str> {
    module
        .entry_points
        .iter()
        .map(|e| e.name.as_str())
        .collect()
}

#[test]
fn every_kind_validates_in_f32_and_f64() {
    let all = variants();
    assert_eq!(all.len(), PatchKind::all().len(), "{all:?}");
    for (file, kind) in all {
        assert_eq!(file, file_for(kind));
        for precision in PRECISIONS {
            let src = module_source(kind, precision).unwrap();
            let module = validate(&src, precision)
                .unwrap_or_else(|e| panic!("{} {kind:?} {precision}: {e}", file.name));
            assert_eq!(entry_points(&module), EVAL_ENTRIES, "{}", file.name);
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
fn generated_header_matches_the_layout_of_every_kind() {
    for kind in PatchKind::all() {
        let layout = kind.layout();
        for precision in PRECISIONS {
            // The header is read back through naga from the assembled module, as the GPU
            // gets it.
            let module = validate(&module_source(kind, precision).unwrap(), precision).unwrap();
            let what = format!("{kind:?} {precision}");
            assert_eq!(constant_u32(&module, "STRIDE"), layout.stride, "{what}");
            assert_eq!(constant_u32(&module, "GEOMETRY"), layout.geometry, "{what}");
            assert_eq!(
                constant_u32(&module, "DEGREE"),
                layout.degree as usize,
                "{what}"
            );
            assert_eq!(constant_u32(&module, "MAX_POINTS"), MAX_POINTS, "{what}");
            assert_eq!(
                constant_u32(&module, "WORKGROUP"),
                WORKGROUP as usize,
                "{what}"
            );
            assert_eq!(
                constant_u32(&module, "PATCH_VECS"),
                patch_vecs(kind),
                "{what}"
            );
            assert_eq!(patch_vecs(kind), layout.stride + EXTRA_VECS);
            for (name, slot) in [
                ("SLOT_FLAT_NORMAL", SLOT_FLAT_NORMAL),
                ("SLOT_ORIGIN_LO", SLOT_ORIGIN_LO),
                ("SLOT_CORNERS", SLOT_CORNERS),
            ] {
                assert_eq!(constant_u32(&module, name), layout.stride + slot, "{what}");
            }
            // Thresholds bit for bit: the same numbers as the CPU backends use.
            let (min_len, max_real, f64s) = match precision {
                Precision::F32 => (MIN_NORMAL_LEN_F32 as f64, f32::MAX as f64, false),
                Precision::F64 => (MIN_NORMAL_LEN_F64, f64::MAX, true),
            };
            assert_eq!(constant_real(&module, "MIN_NORMAL_LEN"), (min_len, f64s));
            assert_eq!(constant_real(&module, "MAX_REAL"), (max_real, f64s));
        }
        assert!(header(kind, Precision::F32).contains(&format!("{kind:?}")));
    }
}

#[test]
fn modules_are_chosen_by_patch_kind_not_by_scheme() {
    assert_eq!(file_for(PatchKind::Gregory), GREGORY);
    for kind in [1, 2, 3, 4].map(PatchKind::Bezier) {
        assert_eq!(file_for(kind), BEZIER);
    }
    assert_eq!(file_for(PatchKind::PnNormals), BEZIER);
    // One module per kind: schemes of one kind (phong, nagata, nagata-guarded and nlsa all
    // build Bezier(2)) get the same source, so the same pipeline.
    let mesh = crate::mesh::generators::icosphere(0);
    let mut modules = BTreeSet::new();
    let mut kinds = Vec::new();
    for scheme in Scheme::all() {
        let table = PatchTable::build(&mesh, scheme, &Default::default()).unwrap();
        modules.insert(module_source(table.kind, Precision::F32).unwrap());
        if !kinds.contains(&table.kind) {
            kinds.push(table.kind);
        }
    }
    assert_eq!(kinds.len(), 5, "{kinds:?}");
    assert_eq!(modules.len(), kinds.len());
    // Every kind a table can have is built by some scheme.
    for kind in PatchKind::all() {
        assert!(kinds.contains(&kind), "{kind:?}");
    }
}

#[test]
fn kinds_beyond_the_shaders_capacity_are_errors() {
    // Bezier(5) has 21 control points, more than MAX_POINTS (18).
    let kind = PatchKind::Bezier(5);
    assert!(kind.stride() > MAX_POINTS);
    let e = module_source(kind, Precision::F32).unwrap_err();
    assert!(e.to_string().contains("21 control points"), "{e}");
}

/// Numeric literals of WGSL source outside comments: (text, is a float).
fn literals(src: &str) -> Vec<(String, bool)> {
    let mut out = Vec::new();
    for line in src.lines() {
        let code = line.split("//").next().unwrap_or("");
        let chars: Vec<char> = code.chars().collect();
        let mut k = 0;
        while k < chars.len() {
            let starts = chars[k].is_ascii_digit()
                && (k == 0 || !(chars[k - 1].is_alphanumeric() || chars[k - 1] == '_'));
            if !starts {
                k += 1;
                continue;
            }
            let mut tok = String::new();
            while k < chars.len() {
                let c = chars[k];
                let exp_sign = (c == '-' || c == '+') && tok.ends_with(['e', 'E']);
                if c.is_alphanumeric() || c == '.' || exp_sign {
                    tok.push(c);
                    k += 1;
                } else {
                    break;
                }
            }
            let float = tok.contains('.') || (tok.contains(['e', 'E']) && !tok.starts_with("0x"));
            out.push((tok, float));
        }
    }
    out
}

fn value(tok: &str) -> f64 {
    tok.trim_end_matches(['u', 'i', 'f', 'h', 'l'])
        .parse()
        .unwrap_or_else(|e| panic!("literal {tok}: {e}"))
}

#[test]
fn wgsl_files_copy_no_layout_number_or_threshold() {
    // Layout facts that only the generated header may state: strides, geometry counts and
    // upload sizes of every kind, MAX_POINTS and WORKGROUP. Values up to 4 are left out:
    // 0..=3 are also vector components and the small factors of the basis formulas, and no
    // kind's layout number that small is used as such in the files.
    let mut forbidden: BTreeSet<usize> = PatchKind::all()
        .into_iter()
        .flat_map(|k| [k.stride(), k.geometry(), patch_vecs(k)])
        .collect();
    forbidden.extend([MAX_POINTS, WORKGROUP as usize]);
    forbidden.retain(|&v| v > 4);
    assert!(forbidden.contains(&18) && forbidden.contains(&16) && forbidden.contains(&10));
    let mut checked = 0;
    for file in FILES {
        for (tok, float) in literals(file.source) {
            let v = value(&tok);
            checked += 1;
            if float {
                // No copy of a normal threshold or of a huge bound.
                assert!(
                    v != MIN_NORMAL_LEN_F32 as f64 && v != MIN_NORMAL_LEN_F64 && v.abs() < 1e6,
                    "shaders/{}: literal {tok} copies a threshold",
                    file.name
                );
            } else {
                assert!(
                    !forbidden.contains(&(v as usize)),
                    "shaders/{}: literal {tok} copies a layout number (use the header's names)",
                    file.name
                );
            }
        }
    }
    assert!(
        checked > 50,
        "only {checked} literals found: the scanner is broken"
    );
    // The scanner finds what it must.
    let found = literals("let a = 18u; // 16u\nlet b = x1 * 1e-30f + 2.5;");
    assert_eq!(
        found,
        [
            ("18u".to_string(), false),
            ("1e-30f".to_string(), true),
            ("2.5".to_string(), true)
        ]
    );
}

#[test]
fn every_wgsl_file_names_rust_functions_it_mirrors_and_they_exist() {
    for file in FILES {
        common::mirrored_functions(&format!("shaders/{}", file.name), file.source);
    }
    assert_eq!(COMMON.name, "common.wgsl");
}

#[test]
fn f64_module_needs_the_float64_capability() {
    // The f64 source validated as if it were f32 (no FLOAT64 capability) must fail: the
    // capability check is real.
    let src = module_source(PatchKind::Gregory, Precision::F64).unwrap();
    let err = validate(&src, Precision::F32).expect_err("f64 module accepted without FLOAT64");
    assert!(err.to_string().contains("validation"), "{err}");
}

#[test]
fn broken_shader_is_reported_with_naga_text() {
    let src = module_source(PatchKind::Bezier(1), Precision::F32)
        .unwrap()
        .replace("return bezier(DEGREE, b);", "return bezier(DEGREE, b, b);");
    let err = validate(&src, Precision::F32).expect_err("broken shader accepted");
    assert!(err.to_string().contains("WGSL"), "{err}");
}

/// The uniform basis table of `grid_patch_main` is declared exactly UNIFORM_TABLE_BYTES
/// long in both precisions (4 reals per entry), and the ceiling shader of `bench` validates,
/// has its two entry points, takes WORKGROUP from the generated line and copies no number.
#[test]
fn uniform_table_size_and_ceiling_shader() {
    for kind in PatchKind::all() {
        for precision in PRECISIONS {
            let module = validate(&module_source(kind, precision).unwrap(), precision).unwrap();
            assert_eq!(
                constant_u32(&module, "GRID_U_VECS") * 4 * precision.bytes(),
                UNIFORM_TABLE_BYTES,
                "{kind:?} {precision}"
            );
        }
    }
    let module = validate(&ceiling_source(), Precision::F32).unwrap();
    assert_eq!(
        entry_points(&module),
        ["ceiling_main", "ceiling_quads_main"]
    );
    assert_eq!(constant_u32(&module, "WORKGROUP"), WORKGROUP as usize);
    // Components, binding numbers and the 4 samples of a quad; nothing else.
    for (tok, _) in literals(CEILING.source) {
        assert!(
            value(&tok) <= 4.0 || tok == "7",
            "shaders/ceiling.wgsl: literal {tok}"
        );
    }
}

/// The loop bound of `bench` (a kind's module with shaders/loop_bound.wgsl's
/// kind_loop_point in place of the kind's) validates for every kind in both precisions,
/// with the kind's entry points, exactly one kind_loop_point (the bound's: the kind's is
/// renamed and still there) and no number but components and zero.
#[test]
fn loop_bound_module_validates_for_every_kind() {
    for kind in PatchKind::all() {
        for precision in PRECISIONS {
            let src = loop_bound_source(kind, precision).unwrap();
            let module = validate(&src, precision)
                .unwrap_or_else(|e| panic!("loop bound {kind:?} {precision}: {e}"));
            assert_eq!(entry_points(&module), EVAL_ENTRIES, "{kind:?}");
            let names: Vec<_> = module
                .functions
                .iter()
                .filter_map(|(_, f)| f.name.as_deref())
                .filter(|n| n.starts_with("kind_loop_point"))
                .collect();
            assert_eq!(
                names,
                ["kind_loop_point_evaluated", "kind_loop_point"],
                "{kind:?} {precision}"
            );
            assert!(src.ends_with(LOOP_BOUND.source));
        }
    }
    for (tok, _) in literals(LOOP_BOUND.source) {
        assert!(value(&tok) <= 2.0, "shaders/loop_bound.wgsl: literal {tok}");
    }
}

/// The statistics module (a kind's evaluation module + shaders/stats.wgsl) validates for
/// every kind in both precisions with `stats_main` among its entry points, takes its record
/// size from the generated line, and names Rust functions it mirrors that exist.
#[test]
fn statistics_module_validates_for_every_kind() {
    for kind in PatchKind::all() {
        for precision in PRECISIONS {
            let src = stats_source(kind, precision).unwrap();
            let module = validate(&src, precision)
                .unwrap_or_else(|e| panic!("stats {kind:?} {precision}: {e}"));
            assert!(module.entry_points.iter().any(|e| e.name == "stats_main"));
            assert_eq!(constant_u32(&module, "STATS_REALS"), STATS_REALS);
        }
    }
    common::mirrored_functions("shaders/stats.wgsl", STATS.source);
    // The record offsets 0..=10 are written out; the record size and the crease bit are not.
    for (tok, _) in literals(STATS.source) {
        let v = value(&tok);
        assert!(
            v < STATS_REALS as f64,
            "shaders/stats.wgsl: literal {tok} copies a generated number"
        );
    }
}
