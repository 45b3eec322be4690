//! The GPU backend against the f64 CPU reference, on whatever Vulkan adapter is present
//! (Mesa's lavapipe in CI). With `CI=true` a missing adapter fails these tests; otherwise
//! they print a SKIP line and return.
//!
//! Every scheme's table is run, so every patch kind's module (see `eval_cases::cases`),
//! through both outputs: `evaluate` (f64) and `evaluate_f32`.

use std::sync::{Arc, OnceLock};

use glam::DVec3;
use rayon::prelude::*;

use crate::analysis::stats::edge_points;
use crate::continuity;
use crate::eval::{grid_barycentrics, grid_len, PatchPoint};
use crate::patch::basis::Weights;
use crate::CpuEvaluator;
use crate::GpuEvaluator;
use crate::Mesh;
use crate::{Chunk, Evaluator, Pattern};
use crate::{GpuContext, Precision};
use crate::{PatchKind, PatchTable, Scheme};

use crate::tests::common;
use crate::tests::eval_cases;
use eval_cases::{
    angle, cases, load, normal_error, regular, EPS32, EPS64, MESHES, ROUNDING_FACTOR,
};

const LEVELS: [u32; 3] = [1, 8, 33];
/// Meshes small enough for level 33 (an odd level past a 32-wide workgroup row) on every
/// scheme: spot and fandisk at level 33 are 3.5 M and 7.7 M samples a scheme, minutes of
/// device time on a software adapter, and prove nothing the built-ins do not (splitting
/// work across bindings and dispatch grids is proven with forced tiny limits in
/// `tiny_chunks_split_dispatches_and_2d_grids_give_identical_results`).
const FINE_LEVEL_MAX_TRIANGLES: usize = 1000;
/// Levels of the f32 output's comparison: its values are the f64 output's rounded once
/// away from the corners (checked bit for bit by the corner test), so the finest level,
/// most of the device time on a software adapter, adds nothing there.
const LEVELS_F32_OUTPUT: [u32; 2] = [1, 8];

fn ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true" || v == "1")
}

/// The shared context, or None (SKIP) without an adapter; with CI=true no adapter panics.
fn context() -> Option<Arc<GpuContext>> {
    match crate::tests::common::shared_gpu() {
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

/// Tolerances of values computed or handed out in `precision`: (position / bbox diagonal,
/// 1 − dot of normals), and the unit roundoff. f32: a few hundred roundings of 6e-8 in the
/// basis sums and normalisation; f64: the same count of 1.1e-16.
fn tolerances(precision: Precision) -> (f64, f64, f64) {
    match precision {
        Precision::F32 => (1e-5, 1e-5, EPS32),
        Precision::F64 => (1e-12, 1e-12, EPS64),
    }
}

/// The output a comparison reads: `evaluate` (f64) or `evaluate_f32`.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Output {
    F64,
    F32,
}

/// Tolerances of `gpu`'s `output`: the coarser of the working and output precisions, and
/// the largest | |n| − 1 | (f64 output is renormalised in f64: a few ulps; f32 output is
/// normalised in f32: a few f32 ulps of 6e-8).
fn output_tolerances(gpu: &GpuEvaluator, output: Output) -> (f64, f64, f64, f64) {
    let (tp, tn, eps) = match output {
        Output::F64 => tolerances(gpu.precision()),
        Output::F32 => tolerances(Precision::F32),
    };
    let unit = match output {
        Output::F64 => 1e-12,
        Output::F32 => 1e-6,
    };
    (tp, tn, eps, unit)
}

/// Runs `pattern` through `output`, handing every chunk to `f` widened to f64.
fn each_chunk(
    gpu: &GpuEvaluator,
    output: Output,
    table: &PatchTable,
    pattern: &Pattern,
    mut f: impl FnMut(&Chunk<'_>),
) {
    match output {
        Output::F64 => gpu.evaluate(table, pattern, &mut |c| {
            f(&c);
            Ok(())
        }),
        Output::F32 => gpu.evaluate_f32(table, pattern, &mut |c| {
            let widen = |v: &[[f32; 3]]| -> Vec<DVec3> {
                v.iter().map(|p| DVec3::from(p.map(f64::from))).collect()
            };
            let (p, n) = (widen(c.positions), widen(c.normals));
            f(&Chunk {
                first: c.first,
                positions: &p,
                normals: &n,
            });
            Ok(())
        }),
    }
    .unwrap();
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
/// position, normal and predicted rounding error of the normal; normals unit within `unit`.
fn worst_of(
    chunk: &Chunk<'_>,
    tn: f64,
    unit: f64,
    reference: impl Fn(usize) -> (DVec3, DVec3, f64) + Sync,
) -> Worst {
    (0..chunk.positions.len())
        .into_par_iter()
        .map(|k| {
            let (p, n, predicted) = reference(k);
            assert!(chunk.positions[k].is_finite() && chunk.normals[k].is_finite());
            assert!((chunk.normals[k].length() - 1.0).abs() < unit);
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

/// Basis values at every point of the grid of `level` (the CPU reference's own).
fn grid_weights(kind: PatchKind, level: u32) -> Vec<Weights> {
    grid_barycentrics(level)
        .into_iter()
        .map(|b| kind.weights(b))
        .collect()
}

/// GPU grid vs CPU reference, streamed chunk by chunk.
fn compare_grid(gpu: &GpuEvaluator, output: Output, table: &PatchTable, level: u32) -> Worst {
    let (_, tn, eps, unit) = output_tolerances(gpu, output);
    let weights = grid_weights(table.kind, level);
    let per = grid_len(level);
    let mut worst = Worst::default();
    each_chunk(gpu, output, table, &Pattern::Grid { level }, |c| {
        assert_eq!(c.positions.len() % per, 0);
        let w = worst_of(c, tn, unit, |k| {
            let (i, w) = (c.first + k / per, &weights[k % per]);
            let sp = table.eval_weights(i, w);
            (sp.p, sp.n, normal_error(table, i, w, eps))
        });
        worst = worst.merge(w);
    });
    assert_eq!(worst.samples, per * table.len());
    worst
}

/// GPU explicit points vs CPU reference.
fn compare_points(
    gpu: &GpuEvaluator,
    output: Output,
    table: &PatchTable,
    points: &[PatchPoint],
) -> Worst {
    let (_, tn, eps, unit) = output_tolerances(gpu, output);
    let mut worst = Worst::default();
    each_chunk(gpu, output, table, &Pattern::Points(points.to_vec()), |c| {
        let w = worst_of(c, tn, unit, |k| {
            let pp = points[c.first + k];
            let w = table.kind.weights(pp.b);
            let sp = table.eval_weights(pp.patch as usize, &w);
            (sp.p, sp.n, normal_error(table, pp.patch as usize, &w, eps))
        });
        worst = worst.merge(w);
    });
    assert_eq!(worst.samples, points.len());
    worst
}

/// Most points one comparison of the explicit-point pattern reads (see [`test_points`]).
const MAX_TEST_POINTS: usize = 60_000;

/// Edge points of every interior edge plus three interior points per patch; on a mesh
/// with more than [`MAX_TEST_POINTS`] of them, every k-th (k = ⌈count / MAX_TEST_POINTS⌉),
/// so the points still reach every part of the patch table. Each point is evaluated on
/// its own, in the same shader code whatever its neighbours, so the subset proves what all
/// of them would; on spot and fandisk all of them (0.4 M and 0.9 M points a scheme) made
/// the CPU reference most of this binary's time. Splitting points across chunks,
/// bindings and dispatches is proven apart, with forced tiny limits, in
/// `tiny_chunks_split_dispatches_and_2d_grids_give_identical_results`.
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
    let k = pts.len().div_ceil(MAX_TEST_POINTS);
    pts.into_iter().step_by(k).collect()
}

fn gpu_matches_cpu(precision: Precision) {
    let Some(gpu) = evaluator(precision) else {
        return;
    };
    for name in MESHES {
        let mesh = load(name);
        let diag = mesh.diagonal();
        let points = test_points(&mesh);
        for (_, table, what) in cases(&mesh) {
            for output in [Output::F64, Output::F32] {
                let (tp, tn, _, _) = output_tolerances(gpu, output);
                let label = format!("{precision} GPU, {output:?} output, {name} {what}");
                let levels = match output {
                    Output::F64 => &LEVELS[..],
                    Output::F32 => &LEVELS_F32_OUTPUT[..],
                };
                for &level in levels {
                    if level > 8 && mesh.triangles.len() > FINE_LEVEL_MAX_TRIANGLES {
                        continue;
                    }
                    compare_grid(gpu, output, &table, level).check(
                        &format!("{label} level {level}"),
                        diag,
                        tp,
                        tn,
                    );
                }
                compare_points(gpu, output, &table, &points).check(
                    &format!("{label} points"),
                    diag,
                    tp,
                    tn,
                );
            }
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
            for (_, table, what) in cases(&mesh) {
                for &level in levels {
                    compare_grid(&gpu, Output::F64, &table, level).check(
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

/// [`run_all`] through `evaluate_f32`.
fn run_all_f32(gpu: &GpuEvaluator, table: &PatchTable, pattern: &Pattern) -> Vec<[f32; 6]> {
    let mut out = Vec::new();
    gpu.evaluate_f32(table, pattern, &mut |c| {
        let expect_first = match pattern {
            Pattern::Grid { level } => out.len() / grid_len(*level),
            Pattern::Points(_) => out.len(),
        };
        assert_eq!(c.first, expect_first, "chunks arrive in order");
        out.extend(
            c.positions
                .iter()
                .zip(c.normals)
                .map(|(p, n)| [p[0], p[1], p[2], n[0], n[1], n[2]]),
        );
        Ok(())
    })
    .unwrap();
    out
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
        // A dispatch smaller than a patch runs one thread per sample: compared with an
        // unsplit run of that layout (G1's patch loop rounds differently).
        let mut per_sample = make();
        per_sample.patch_loop = false;
        // Bindings of 200 samples: no basis table fits, so the basis is computed in the
        // shader, one thread per sample; compared with an unsplit run of that path.
        let mut in_shader = make();
        in_shader.max_grid_table_bytes = 0;
        in_shader.patch_loop = false;
        let mut tiny_binding = make();
        tiny_binding.max_binding_bytes = (200 * 6 * precision.bytes()) as u64 + 8;
        // 80 patches: level 33 is still 1.1 MiB (f32) to 2.2 MiB (f64) of output, past the
        // 300 KiB bindings of `split`, and 80 chunks in `tiny`; a larger mesh adds device
        // time, not cases.
        let mesh = load("icosphere:1");
        assert_eq!(mesh.triangles.len(), 80);
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
                let a32 = run_all_f32(whole, &table, &pattern);
                let b32 = run_all_f32(&tiny, &table, &pattern);
                assert!(a32 == b32, "{precision} {scheme}: tiny f32 chunks differ");
                let c = run_all(&split, &table, &pattern);
                let a1 = run_all(&per_sample, &table, &pattern);
                assert!(a1 == c, "{precision} {scheme}: split dispatches differ");
                let d = run_all(&in_shader, &table, &pattern);
                let e = run_all(&tiny_binding, &table, &pattern);
                assert!(d == e, "{precision} {scheme}: tiny bindings differ");
            }
        }
    }
}

/// The grid's two thread layouts (one thread per sample, one per patch: lavapipe's
/// default) and single- or double-buffered readback, in f64 and f32 output, in both
/// precisions; every layout is forced here, so each runs on any adapter. The Bézier kinds'
/// patch loop reads the same basis table and sums in the same order as one thread per
/// sample: bitwise the same samples. G1's evaluates its basis straight-line in the shader
/// (other roundings): against the f64 reference, as every grid. Buffering never changes a
/// bit.
#[test]
fn patch_loop_and_double_buffering_give_identical_results() {
    for precision in [Precision::F32, Precision::F64] {
        let Some(shared) = evaluator(precision) else {
            continue;
        };
        let ctx = shared.context().clone();
        let make = |patch_loop: bool, double_buffer: bool| {
            let mut g = GpuEvaluator::new(ctx.clone(), precision).unwrap();
            g.patch_loop = patch_loop;
            g.double_buffer = double_buffer;
            // 47 patches of level 16 per chunk: 7 chunks on sphere320, so readback is
            // double-buffered. per = 153 is odd, so the patch loop stores vec4s only in
            // dispatches of a multiple of 4 patches: it splits each chunk into 44 + 3
            // patches (the last, 38, into 36 + 2), the small ones stored value by value.
            g.chunk_samples = 47 * grid_len(16);
            g
        };
        let per_sample = make(false, true);
        let patch_loop = make(true, true);
        let single = make(true, false);
        let mesh = load("sphere320");
        for scheme in [Scheme::G1, Scheme::Flat, Scheme::PnNormals] {
            let table = PatchTable::build(&mesh, scheme, &Default::default()).unwrap();
            // Level 16: the Bézier kinds' uniform tables fit 64 KiB in f32; in f64 only the
            // smaller kinds' do (PN normals then runs one thread per sample); G1 needs none.
            let pattern = Pattern::Grid { level: 16 };
            let a = run_all(&per_sample, &table, &pattern);
            assert_eq!(a.0.len(), 320 * grid_len(16));
            let b = run_all(&patch_loop, &table, &pattern);
            let c = run_all(&single, &table, &pattern);
            assert!(b == c, "{precision} {scheme}: single buffer differs");
            let a32 = run_all_f32(&per_sample, &table, &pattern);
            let b32 = run_all_f32(&patch_loop, &table, &pattern);
            let c32 = run_all_f32(&single, &table, &pattern);
            assert!(
                b32 == c32,
                "{precision} {scheme}: f32 single buffer differs"
            );
            if table.kind == PatchKind::Gregory {
                for output in [Output::F64, Output::F32] {
                    let (tp, tn, _, _) = output_tolerances(&patch_loop, output);
                    compare_grid(&patch_loop, output, &table, 16).check(
                        &format!("{precision} G1 patch loop, {output:?} output"),
                        mesh.diagonal(),
                        tp,
                        tn,
                    );
                }
            } else {
                assert!(a == b, "{precision} {scheme}: patch loop differs");
                assert!(a32 == b32, "{precision} {scheme}: f32 patch loop differs");
            }
        }
    }
}

/// Table 1's statistics reduced on the device (`stats --backend gpu`) against the CPU's f64
/// statistics (`stats_report` with the CPU evaluator) on meshes with and without creases,
/// for a G1, a quadratic and a cubic scheme.
///
/// Bounds. Counts (samples, crease edges and samples) are exact. Let δ be the largest
/// error of one GPU unit normal against the f64 reference. Then each cos = n_a · n_b is
/// within 2δ of the CPU's, and so are min, max, 1 − |cos| and the mean (a mean of values
/// each within 2δ); the std of values each moved by at most 2δ moves by at most
/// 2δ·sqrt(n/(n − 1)) < 2.1δ (triangle inequality on the deviation vectors). A unit normal
/// is S_s × S_t over its length: each derivative is a sum of 15 terms, each component
/// carrying at most ~20 roundings of the unit roundoff u relative to |S_s|, |S_t|, so the
/// cross product is off by ~40u·|S_s||S_t| and the normal by 40u·κ with κ =
/// |S_s||S_t| / |S_s × S_t| (about 1 to 3 on these meshes, whose triangles are not
/// slivers); δ ≤ 40u·κ ≤ 160u leaves κ up to 4. So: 2.1δ ≤ 340u, i.e. 2e-5 in f32 (u =
/// 6e-8) and 4e-14 in f64 (u = 1.1e-16). Gaps: each absolute position is hi + (lo + p) in
/// the working precision: its rounding, u·|p| ≤ u·R with R the largest vertex norm, plus
/// the evaluation's error, 1e-5·diagonal in f32 and 1e-12·diagonal in f64 (the position
/// bounds of the comparisons above); a gap moves by at most twice that. Folded counts are
/// exact where no cos lies within the cos bound of 0 (checked: the CPU's |cos| stays above
/// it on these meshes, min cos > bound).
#[test]
fn gpu_statistics_agree_with_the_cpu_f64_statistics() {
    use crate::stats_report;
    for precision in [Precision::F32, Precision::F64] {
        let Some(gpu) = evaluator(precision) else {
            continue;
        };
        let u = match precision {
            Precision::F32 => EPS32,
            Precision::F64 => EPS64,
        };
        let cos_bound = 340.0 * u;
        let eval_bound = match precision {
            Precision::F32 => 1e-5,
            Precision::F64 => 1e-12,
        };
        let cpu = CpuEvaluator::default();
        for name in ["sphere320", "torus200", "spot.obj", "fandisk.obj"] {
            let mut mesh = load(name);
            if name == "fandisk.obj" {
                // Creases: 30° splits the normals along fandisk's sharp edges.
                mesh = crate::Mesh::load(
                    &common::shared_spec(name),
                    &crate::LoadOptions::default().with_crease_angle(Some(30.0)),
                )
                .unwrap();
            }
            let radius = mesh
                .positions
                .iter()
                .map(|p| p.length())
                .fold(0.0, f64::max);
            let gap_bound = 2.0 * (u * radius + eval_bound * mesh.diagonal());
            let adjacency = mesh.adjacency();
            for scheme in [Scheme::G1, Scheme::Phong, Scheme::PnNormals] {
                let table = PatchTable::build(&mesh, scheme, &Default::default()).unwrap();
                let c = crate::gpu::stats::gpu_continuity(gpu, &mesh, &adjacency, &table).unwrap();
                let r = stats_report(&mesh, scheme, &Default::default(), &cpu).unwrap();
                let what = format!("{precision} {name} {scheme}");
                assert_eq!(c.samples, r.samples, "{what}");
                assert_eq!(c.crease_edges, r.crease_edges, "{what}");
                assert_eq!(c.crease_samples, r.crease_samples, "{what}");
                if name == "fandisk.obj" {
                    assert!(c.crease_edges > 0, "{what}: the crease case has no crease");
                }
                assert!(r.cos.min.abs() > cos_bound, "{what}: a cos near 0");
                assert_eq!(c.folded, r.folded, "{what}");
                for (x, y, label) in [
                    (c.cos.min, r.cos.min, "min"),
                    (c.cos.max, r.cos.max, "max"),
                    (c.cos.mean, r.cos.mean, "mean"),
                    (c.max_one_minus_abs_cos, r.max_one_minus_abs_cos, "1-|cos|"),
                ] {
                    assert!((x - y).abs() <= cos_bound, "{what} {label}: {x} vs {y}");
                }
                assert!(
                    (c.cos.std - r.cos.std).abs() <= cos_bound,
                    "{what} std: {} vs {}",
                    c.cos.std,
                    r.cos.std
                );
                for (x, y, label) in [
                    (c.max_gap, r.max_gap, "gap"),
                    (c.crease_max_gap, r.crease_max_gap, "crease gap"),
                ] {
                    assert!((x - y).abs() <= gap_bound, "{what} {label}: {x} vs {y}");
                }
                eprintln!(
                    "{what}: |Δmean| {:.1e} |Δstd| {:.1e} |Δgap| {:.1e} (bounds {cos_bound:.1e}, {gap_bound:.1e})",
                    (c.cos.mean - r.cos.mean).abs(),
                    (c.cos.std - r.cos.std).abs(),
                    (c.max_gap - r.max_gap).abs()
                );
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
        // G1 to the working precision: 1 − cos of two unit normals rounded in f32 is a few
        // f32 ulps (6e-8; 1e-5 leaves room for each side's normalisation); in f64 a few
        // ulps of 1.1e-16, far below 1e-12.
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
        // A library error says what is missing, never a command-line flag.
        assert!(!e.to_string().contains("--"), "{e}");
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

/// A mesh far from the origin whose vertex 0 has x = 0.313121 (the coordinate the issue saw
/// come back as 0.3131210001682043).
fn moved_sphere() -> Mesh {
    let mut mesh = load("sphere320");
    let x0 = mesh.positions[0].x * 1.7;
    let shift = DVec3::new(0.313121 - x0, 1000.25, -3.5);
    for p in &mut mesh.positions {
        *p = *p * 1.7 + shift;
    }
    mesh.positions[0].x = 0.313121;
    mesh
}

fn bits64(v: DVec3) -> [u64; 3] {
    v.to_array().map(f64::to_bits)
}

fn bits32(v: [f32; 3]) -> [u32; 3] {
    v.map(f32::to_bits)
}

fn round32(v: DVec3) -> [f32; 3] {
    v.to_array().map(|x| x as f32)
}

#[test]
fn corners_are_the_input_bit_for_bit_on_every_kind_precision_and_pattern() {
    let mesh = moved_sphere();
    let mut kinds = Vec::new();
    let mut checked = 0;
    for precision in [Precision::F32, Precision::F64] {
        let Some(gpu) = evaluator(precision) else {
            continue;
        };
        for scheme in Scheme::all() {
            let table = PatchTable::build(&mesh, scheme, &Default::default()).unwrap();
            if !kinds.contains(&table.kind) {
                kinds.push(table.kind);
            }
            // A patch's corner control points are its triangle's input vertices.
            for (i, t) in mesh.triangles.iter().enumerate() {
                for (k, &v) in t.iter().enumerate() {
                    assert_eq!(
                        bits64(table.corner(i, k)),
                        bits64(mesh.positions[v as usize])
                    );
                }
            }
            let level = 4;
            let per = grid_len(level);
            // Every corner of every patch, then one interior point per patch.
            let mut points = Vec::new();
            for patch in 0..table.len() as u32 {
                for b in [
                    [1.0, 0.0, 0.0],
                    [0.0, 1.0, 0.0],
                    [0.0, 0.0, 1.0],
                    [0.2, 0.3, 0.5],
                ] {
                    points.push(PatchPoint { patch, b });
                }
            }
            for pattern in [Pattern::Grid { level }, Pattern::Points(points)] {
                // Sample index -> (patch, corner) where the sample is a corner.
                let corner_at = |s: usize| match &pattern {
                    Pattern::Grid { .. } => {
                        let local = s % per;
                        let k = [0, level as usize, per - 1]
                            .iter()
                            .position(|&c| c == local);
                        k.map(|k| (s / per, k))
                    }
                    Pattern::Points(p) => {
                        let k = p[s].b.iter().position(|&x| x == 1.0);
                        k.map(|k| (p[s].patch as usize, k))
                    }
                };
                let what = format!("{precision} {scheme} {pattern:?}")
                    .chars()
                    .take(60)
                    .collect::<String>();
                let (pos, _) = gpu.evaluate_all(&table, &pattern).unwrap();
                let mut pos32 = Vec::new();
                gpu.evaluate_f32(&table, &pattern, &mut |c| {
                    pos32.extend_from_slice(c.positions);
                    Ok(())
                })
                .unwrap();
                assert_eq!(pos.len(), pattern.len(table.len()));
                assert_eq!(pos32.len(), pos.len());
                let mut corners = 0;
                for s in 0..pos.len() {
                    if let Some((i, k)) = corner_at(s) {
                        let c = table.corner(i, k);
                        assert_eq!(bits64(pos[s]), bits64(c), "{what}: sample {s} (f64)");
                        assert_eq!(
                            bits32(pos32[s]),
                            bits32(round32(c)),
                            "{what}: sample {s} (f32)"
                        );
                        if mesh.triangles[i][k] == 0 {
                            assert_eq!(pos[s].x, 0.313121);
                            assert_eq!(pos32[s][0], 0.313121f32);
                        }
                        corners += 1;
                    } else {
                        // Elsewhere the f32 output is the GPU's value rounded to f32 once
                        // (an f32 GPU's own bits: no f64 round trip).
                        assert_eq!(
                            bits32(pos32[s]),
                            bits32(round32(pos[s])),
                            "{what}: sample {s}"
                        );
                    }
                }
                assert_eq!(corners, 3 * table.len(), "{what}");
                checked += 1;
            }
        }
    }
    if checked > 0 {
        let mut all = PatchKind::all();
        all.sort_by_key(|k| format!("{k:?}"));
        kinds.sort_by_key(|k| format!("{k:?}"));
        assert_eq!(kinds, all, "every patch kind was checked");
    }
}

#[test]
fn f32_output_keeps_its_digits_far_from_the_origin() {
    // y is about 1000 (f32 ulp 6.1e-5 there), x and z about 1. The GPU's f32 output must be
    // the f64 reference within eps32 · (|p| + 1): one rounding of the result (at most
    // eps32 · |p|) plus the f32 evaluation of the patch-relative part (patches span about
    // 0.5, a few roundings of it stay below eps32). Evaluating absolute coordinates in f32
    // would instead lose several eps32 · |p| in the basis sums.
    let Some(gpu) = evaluator(Precision::F32) else {
        return;
    };
    let mesh = moved_sphere();
    let table = PatchTable::build(&mesh, Scheme::G1, &Default::default()).unwrap();
    let level = 8;
    let weights = grid_weights(table.kind, level);
    let per = grid_len(level);
    let eps = f32::EPSILON as f64;
    let mut worst: f64 = 0.0;
    gpu.evaluate_f32(&table, &Pattern::Grid { level }, &mut |c| {
        for (s, p) in c.positions.iter().enumerate() {
            let reference = table.eval_weights(c.first + s / per, &weights[s % per]).p;
            for a in 0..3 {
                let r = reference[a];
                worst = worst.max((p[a] as f64 - r).abs() / (eps * (r.abs() + 1.0)));
            }
        }
        Ok(())
    })
    .unwrap();
    eprintln!("f32 GPU output 1000 from the origin: worst error {worst:.3} × eps32 (|p| + 1)");
    assert!(worst <= 1.0, "{worst}");
}

#[test]
fn schemes_of_one_kind_share_one_module_and_pipeline() {
    let Some(shared) = evaluator(Precision::F32) else {
        return;
    };
    let gpu = GpuEvaluator::new(shared.context().clone(), Precision::F32).unwrap();
    let mesh = load("sphere320");
    let mut results = Vec::new();
    for scheme in [
        Scheme::Phong,
        Scheme::Nagata,
        Scheme::NagataGuarded,
        Scheme::Nlsa,
    ] {
        let table = PatchTable::build(&mesh, scheme, &Default::default()).unwrap();
        assert_eq!(table.kind, PatchKind::Bezier(2));
        results.push(
            gpu.evaluate_all(&table, &Pattern::Grid { level: 2 })
                .unwrap()
                .0,
        );
        assert_eq!(gpu.cached_pipelines(), 1, "{scheme}");
    }
    // One pipeline, four different tables: the surfaces differ.
    assert!(results[0] != results[1] && results[0] != results[3]);
    let pn = PatchTable::build(&mesh, Scheme::Pn, &Default::default()).unwrap();
    gpu.evaluate_all(&pn, &Pattern::Grid { level: 2 }).unwrap();
    assert_eq!(gpu.cached_pipelines(), 2);
    assert!(Arc::ptr_eq(
        &gpu.pipelines(PatchKind::Bezier(2)).unwrap(),
        &gpu.pipelines(PatchKind::Bezier(2)).unwrap()
    ));
}
