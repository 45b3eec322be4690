//! The GPU backend against the f64 CPU reference, on whatever Vulkan adapter is present
//! (Mesa's lavapipe in CI). With `CI=true` a missing adapter fails these tests; otherwise
//! they print a SKIP line and return.
//!
//! Every shader file is run for every patch kind it serves (see `common::cases`).

use std::sync::{Arc, OnceLock};

use glam::DVec3;
use rayon::prelude::*;

use g1tess::eval::cpu::{grid_weights, CpuEvaluator};
use g1tess::eval::gpu::GpuEvaluator;
use g1tess::eval::{grid_len, Chunk, Evaluator, PatchPoint, Pattern};
use g1tess::gpu::shaders::ShaderFile;
use g1tess::gpu::{GpuContext, Precision};
use g1tess::mesh::Mesh;
use g1tess::output::stats::{continuity, edge_points};
use g1tess::patch::{PatchTable, Scheme};

mod common;
mod eval_cases;
use eval_cases::{
    angle, cases, load, normal_error, regular, EPS32, EPS64, MESHES, ROUNDING_FACTOR,
};

const LEVELS: [u32; 3] = [1, 8, 33];

fn ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true" || v == "1")
}

/// The shared context, or None (SKIP) without an adapter; with CI=true no adapter panics.
fn context() -> Option<Arc<GpuContext>> {
    match GpuContext::shared() {
        Ok(c) => {
            eprintln!(
                "GPU test running on: {} ({})",
                c.describe(),
                c.limits_summary()
            );
            Some(c)
        }
        Err(e) => {
            assert!(!ci(), "CI=true and no GPU adapter: {e}");
            eprintln!("\n======== SKIP: no GPU adapter ({e}); GPU test not run ========\n");
            None
        }
    }
}

/// One evaluator per precision for the whole test binary (pipelines are cached in it).
fn evaluator(precision: Precision) -> Option<&'static GpuEvaluator> {
    static F32: OnceLock<Option<GpuEvaluator>> = OnceLock::new();
    static F64: OnceLock<Option<GpuEvaluator>> = OnceLock::new();
    let cell = match precision {
        Precision::F32 => &F32,
        Precision::F64 => &F64,
    };
    let ctx = context()?;
    cell.get_or_init(|| {
        if precision == Precision::F64 && !ctx.supports_f64() {
            eprintln!(
                "\n======== NOTE: {} has no SHADER_F64: f64 GPU checks not run ========\n",
                ctx.info.name
            );
            return None;
        }
        Some(GpuEvaluator::new(ctx.clone(), precision).expect("GPU evaluator"))
    })
    .as_ref()
}

/// Tolerances: (position / bbox diagonal, 1 − dot of normals), and the unit roundoff.
fn tolerances(precision: Precision) -> (f64, f64, f64) {
    match precision {
        Precision::F32 => (1e-5, 1e-5, EPS32),
        Precision::F64 => (1e-12, 1e-12, EPS64),
    }
}

#[derive(Default, Debug, Clone, Copy)]
struct Worst {
    /// Largest position distance (every sample).
    dp: f64,
    /// Largest 1 − dot of normals over the regular samples (see `eval_cases::regular`).
    dn: f64,
    samples: usize,
    /// Samples near singular points, where the normal is not defined to the working
    /// precision.
    singular: usize,
    /// Largest angle error / (unit roundoff · condition number) over those.
    ratio: f64,
}

impl Worst {
    fn merge(self, o: Worst) -> Worst {
        Worst {
            dp: self.dp.max(o.dp),
            dn: self.dn.max(o.dn),
            samples: self.samples + o.samples,
            singular: self.singular + o.singular,
            ratio: self.ratio.max(o.ratio),
        }
    }

    /// Checks the tolerances: positions everywhere, 1 − dot on regular samples, the
    /// rounding bound near singular points.
    fn check(&self, what: &str, diag: f64, tp: f64, tn: f64) {
        eprintln!(
            "{what}: {} samples, max |dp|/diag {:.2e}, max 1-dot {:.2e}{}",
            self.samples,
            self.dp / diag,
            self.dn,
            if self.singular > 0 {
                format!(
                    " ({} samples near singular points: angle error ≤ {:.2} × predicted rounding error)",
                    self.singular, self.ratio
                )
            } else {
                String::new()
            }
        );
        assert!(
            self.dp <= tp * diag && self.dn <= tn,
            "{what}: |dp|/diag {:e}, 1-dot {:e}",
            self.dp / diag,
            self.dn
        );
        assert!(
            self.ratio <= ROUNDING_FACTOR,
            "{what}: angle error {} × predicted rounding error near singular points",
            self.ratio
        );
    }
}

/// Position distance and 1 − dot over a chunk against the reference: sample k's reference
/// position, normal and predicted rounding error of the normal.
fn worst_of(
    chunk: &Chunk<'_>,
    tn: f64,
    reference: impl Fn(usize) -> (DVec3, DVec3, f64) + Sync,
) -> Worst {
    (0..chunk.positions.len())
        .into_par_iter()
        .map(|k| {
            let (p, n, predicted) = reference(k);
            assert!(chunk.positions[k].is_finite() && chunk.normals[k].is_finite());
            assert!((chunk.normals[k].length() - 1.0).abs() < 1e-12);
            let ok = regular(predicted, tn);
            Worst {
                dp: chunk.positions[k].distance(p),
                dn: if ok {
                    1.0 - chunk.normals[k].dot(n)
                } else {
                    0.0
                },
                samples: 1,
                singular: usize::from(!ok),
                ratio: if ok {
                    0.0
                } else {
                    angle(chunk.normals[k], n) / predicted
                },
            }
        })
        .reduce(Worst::default, Worst::merge)
}

/// GPU grid vs CPU reference, streamed chunk by chunk.
fn compare_grid(gpu: &GpuEvaluator, file: ShaderFile, table: &PatchTable, level: u32) -> Worst {
    let (_, tn, eps) = tolerances(gpu.precision());
    let weights = grid_weights(table, level);
    let per = grid_len(level);
    let mut worst = Worst::default();
    gpu.evaluate_with_file(file, table, &Pattern::Grid { level }, &mut |c| {
        assert_eq!(c.positions.len() % per, 0);
        let w = worst_of(&c, tn, |k| {
            let (i, w) = (c.first + k / per, &weights[k % per]);
            let sp = table.eval_weights(i, w);
            (sp.p, sp.n, normal_error(table, i, w, eps))
        });
        worst = worst.merge(w);
        Ok(())
    })
    .unwrap();
    assert_eq!(worst.samples, per * table.len());
    worst
}

/// GPU explicit points vs CPU reference.
fn compare_points(
    gpu: &GpuEvaluator,
    file: ShaderFile,
    table: &PatchTable,
    points: &[PatchPoint],
) -> Worst {
    let (_, tn, eps) = tolerances(gpu.precision());
    let mut worst = Worst::default();
    gpu.evaluate_with_file(file, table, &Pattern::Points(points.to_vec()), &mut |c| {
        let w = worst_of(&c, tn, |k| {
            let pp = points[c.first + k];
            let w = table.kind.weights(pp.b);
            let sp = table.eval_weights(pp.patch as usize, &w);
            (sp.p, sp.n, normal_error(table, pp.patch as usize, &w, eps))
        });
        worst = worst.merge(w);
        Ok(())
    })
    .unwrap();
    assert_eq!(worst.samples, points.len());
    worst
}

/// Edge points of every interior edge plus three interior points per patch.
fn test_points(mesh: &Mesh) -> Vec<PatchPoint> {
    let mut pts = edge_points(mesh, &mesh.adjacency());
    for t in 0..mesh.triangles.len() as u32 {
        for b in [
            [0.2, 0.3, 0.5],
            [0.7, 0.2, 0.1],
            [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
        ] {
            pts.push(PatchPoint { patch: t, b });
        }
    }
    pts
}

fn gpu_matches_cpu(precision: Precision) {
    let Some(gpu) = evaluator(precision) else {
        return;
    };
    let (tp, tn, _) = tolerances(precision);
    for name in MESHES {
        let mesh = load(name);
        let diag = mesh.diagonal();
        let points = test_points(&mesh);
        for (file, table, what) in cases(&mesh) {
            for level in LEVELS {
                compare_grid(gpu, file, &table, level).check(
                    &format!("{precision} {name} {what} level {level}"),
                    diag,
                    tp,
                    tn,
                );
            }
            compare_points(gpu, file, &table, &points).check(
                &format!("{precision} {name} {what} points"),
                diag,
                tp,
                tn,
            );
        }
    }
}

#[test]
fn in_shader_basis_grids_match_cpu() {
    for precision in [Precision::F32, Precision::F64] {
        let Some(shared) = evaluator(precision) else {
            continue;
        };
        let mut gpu = GpuEvaluator::new(shared.context().clone(), precision).unwrap();
        gpu.max_grid_table_bytes = 0;
        let (tp, tn, _) = tolerances(precision);
        for (name, levels) in [
            ("sphere320", &[1, 8, 33][..]),
            ("torus200", &[1, 33]),
            ("spot.obj", &[8]),
        ] {
            let mesh = load(name);
            let diag = mesh.diagonal();
            for (file, table, what) in cases(&mesh) {
                for &level in levels {
                    compare_grid(&gpu, file, &table, level).check(
                        &format!("{precision} in-shader basis {name} {what} level {level}"),
                        diag,
                        tp,
                        tn,
                    );
                }
            }
        }
    }
}

#[test]
fn gpu_f32_matches_cpu_on_every_scheme_mesh_and_level() {
    gpu_matches_cpu(Precision::F32);
}

#[test]
fn gpu_f64_matches_cpu_on_every_scheme_mesh_and_level() {
    gpu_matches_cpu(Precision::F64);
}

/// Whole-array evaluation through a given evaluator configuration.
fn run_all(gpu: &GpuEvaluator, table: &PatchTable, pattern: &Pattern) -> (Vec<DVec3>, Vec<DVec3>) {
    let mut chunks = 0;
    let mut pos = Vec::new();
    let mut nrm = Vec::new();
    gpu.evaluate(table, pattern, &mut |c| {
        let expect_first = match pattern {
            Pattern::Grid { level } => pos.len() / grid_len(*level),
            Pattern::Points(_) => pos.len(),
        };
        assert_eq!(c.first, expect_first, "chunks arrive in order");
        chunks += 1;
        pos.extend_from_slice(c.positions);
        nrm.extend_from_slice(c.normals);
        Ok(())
    })
    .unwrap();
    eprintln!("  {chunks} chunks");
    (pos, nrm)
}

#[test]
fn tiny_chunks_split_dispatches_and_2d_grids_give_identical_results() {
    for precision in [Precision::F32, Precision::F64] {
        let Some(whole) = evaluator(precision) else {
            continue;
        };
        let ctx = whole.context().clone();
        let make = || GpuEvaluator::new(ctx.clone(), precision).unwrap();
        // Tiny chunks: one patch (grid) or 7 points per chunk.
        let mut tiny = make();
        tiny.chunk_samples = 7;
        // 2 workgroups per dimension: at most 256 samples per dispatch, so a patch's grid
        // at level 33 (595 samples) spans several dispatches, each a 2-D grid; bindings
        // still hold the basis table.
        let mut split = make();
        split.max_binding_bytes = 300 << 10;
        split.max_workgroups_per_dim = 2;
        // Bindings of 200 samples: no basis table fits, so the basis is computed in the
        // shader; compared with an unsplit run of that path.
        let mut in_shader = make();
        in_shader.max_grid_table_bytes = 0;
        let mut tiny_binding = make();
        tiny_binding.max_binding_bytes = (200 * 6 * precision.bytes()) as u64 + 8;
        let mesh = load("sphere320");
        for scheme in Scheme::all() {
            let table = PatchTable::build(&mesh, scheme, &Default::default()).unwrap();
            let mut points = test_points(&mesh);
            points.truncate(5000);
            for pattern in [Pattern::Grid { level: 33 }, Pattern::Points(points)] {
                eprintln!("{precision} {scheme} {} samples", pattern.len(table.len()));
                let a = run_all(whole, &table, &pattern);
                assert_eq!(a.0.len(), pattern.len(table.len()));
                let b = run_all(&tiny, &table, &pattern);
                assert!(a == b, "{precision} {scheme}: tiny chunks differ");
                let c = run_all(&split, &table, &pattern);
                assert!(a == c, "{precision} {scheme}: split dispatches differ");
                let d = run_all(&in_shader, &table, &pattern);
                let e = run_all(&tiny_binding, &table, &pattern);
                assert!(d == e, "{precision} {scheme}: tiny bindings differ");
            }
        }
    }
}

#[test]
fn g1_continuity_from_gpu_output() {
    for precision in [Precision::F32, Precision::F64] {
        let Some(gpu) = evaluator(precision) else {
            continue;
        };
        let bound = match precision {
            Precision::F32 => 1e-5,
            Precision::F64 => 1e-12,
        };
        for name in MESHES {
            let mesh = load(name);
            let adjacency = mesh.adjacency();
            let table = PatchTable::build(&mesh, Scheme::G1, &Default::default()).unwrap();
            let g = continuity(&mesh, &adjacency, &table, gpu).unwrap();
            let c = continuity(&mesh, &adjacency, &table, &CpuEvaluator::default()).unwrap();
            eprintln!(
                "{precision} {name} G1 from GPU: samples {} 1-min cos {:.3e} max 1-|cos| {:.3e} folded {} (CPU: 1-min cos {:.3e}, folded {})",
                g.samples,
                1.0 - g.cos.min,
                g.max_one_minus_abs_cos,
                g.folded,
                1.0 - c.cos.min,
                c.folded
            );
            assert_eq!(g.samples, 21 * adjacency.interior);
            assert_eq!(g.folded, c.folded, "{name}");
            assert!(
                1.0 - g.cos.min <= bound,
                "{precision} {name}: 1 - min cos = {:e}",
                1.0 - g.cos.min
            );
        }
    }
}

#[test]
fn f64_without_the_feature_is_refused_and_bad_points_are_errors() {
    let Some(gpu) = evaluator(Precision::F32) else {
        return;
    };
    let ctx = gpu.context().clone();
    if !ctx.supports_f64() {
        let e = GpuEvaluator::new(ctx.clone(), Precision::F64)
            .err()
            .unwrap();
        assert!(e.to_string().contains("SHADER_F64"), "{e}");
    }
    let mesh = load("sphere320");
    let table = PatchTable::build(&mesh, Scheme::G1, &Default::default()).unwrap();
    let bad = Pattern::Points(vec![PatchPoint {
        patch: table.len() as u32,
        b: [1.0, 0.0, 0.0],
    }]);
    let e = gpu.evaluate(&table, &bad, &mut |_| Ok(())).unwrap_err();
    assert!(e.to_string().contains("patch 320"), "{e}");
}
