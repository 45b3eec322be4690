//! f32 evaluation (`Evaluator::evaluate_f32`; on the CPU the SIMD grid kernel) against the
//! f64 reference, for every patch kind, on the test meshes at levels 1, 8 and 32, with both
//! CPU kernels (AVX2+FMA where the CPU has it, and the portable one); chunked runs
//! identical to whole ones; corner samples equal to the input vertices bit for bit on every
//! backend (the harness's `evaluators`) in both precisions.

mod common;
mod eval_cases;
use eval_cases::{
    angle, cases, evaluators, load, normal_error, regular, EPS32, MESHES, ROUNDING_FACTOR,
};

use glam::DVec3;
use rayon::prelude::*;

use g1tess::eval::cpu::{grid_weights, CpuEvaluator, F32Kernel, GridWeightsF32};
use g1tess::eval::{grid_corners, grid_len, to_f32, Evaluator, Pattern};
use g1tess::patch::PatchTable;

/// Normals are held to 1 − dot ≤ this (an angle of 4.5e-3 rad) where they are defined to
/// f32 precision: the harness calls a sample regular when ROUNDING_FACTOR times its
/// predicted f32 rounding error fits in that angle (`eval_cases::regular`), so this is the
/// bound the prediction guarantees with that margin; elsewhere the angle is held to the
/// prediction itself.
const TN: f64 = 1e-5;

/// Max |dp| / diag, max 1 − dot over the regular samples (see `eval_cases::regular`), the
/// number of samples near singular points and their largest angle error / (eps · κ).
fn compare(table: &PatchTable, level: u32, kernel: F32Kernel, diag: f64) -> (f64, f64, usize, f64) {
    let reference = grid_weights(table, level);
    let per = grid_len(level);
    let (mut dp, mut dn, mut singular, mut ratio, mut samples) = (0f64, 0f64, 0, 0f64, 0);
    let ev = CpuEvaluator {
        f32_kernel: kernel,
        ..Default::default()
    };
    ev.evaluate_f32(table, &Pattern::Grid { level }, &mut |c| {
        assert_eq!(c.positions.len(), c.normals.len());
        let (p, n, s, ns) = (0..c.positions.len())
            .into_par_iter()
            .map(|k| {
                let (i, w) = (c.first + k / per, &reference[k % per]);
                let sp = table.eval_weights(i, w);
                let q = DVec3::from(c.positions[k].map(f64::from));
                let m = DVec3::from(c.normals[k].map(f64::from));
                assert!(q.is_finite() && m.is_finite());
                // A unit vector rounded to f32 and renormalised in f32: a few ulps.
                assert!((m.length() - 1.0).abs() < 1e-6, "unit normal {m}");
                let predicted = normal_error(table, i, w, EPS32);
                if regular(predicted, TN) {
                    (q.distance(sp.p), 1.0 - m.dot(sp.n), 0, 0.0)
                } else {
                    (q.distance(sp.p), 0.0, 1, angle(m, sp.n) / predicted)
                }
            })
            .reduce(
                || (0.0, 0.0, 0, 0.0),
                |a, b| (a.0.max(b.0), a.1.max(b.1), a.2 + b.2, a.3.max(b.3)),
            );
        dp = dp.max(p);
        dn = dn.max(n);
        singular += s;
        ratio = ratio.max(ns);
        samples += c.positions.len();
        Ok(())
    })
    .unwrap();
    assert_eq!(samples, per * table.len());
    (dp / diag, dn, singular, ratio)
}

#[test]
fn f32_fast_path_matches_the_f64_reference() {
    eprintln!("fast path kernel here: {}", F32Kernel::Auto.name());
    for name in MESHES {
        let mesh = load(name);
        let diag = mesh.diagonal();
        for (_, table, what) in cases(&mesh) {
            for level in [1, 8, 32] {
                for kernel in [F32Kernel::Auto, F32Kernel::Portable] {
                    let (dp, dn, singular, dns) = compare(&table, level, kernel, diag);
                    eprintln!(
                        "{name} {what} level {level} {}: max |dp|/diag {dp:.2e}, max 1-dot {dn:.2e}{}",
                        kernel.name(),
                        if singular > 0 {
                            format!(" ({singular} samples near singular points: angle error ≤ {dns:.2} × predicted rounding error)")
                        } else {
                            String::new()
                        }
                    );
                    // Positions: f32 control points relative to the patch origin, a sum of
                    // at most 19 products (|w| ≤ a few units), rounded to f32 at the end:
                    // well under 1e-5 of the diagonal on these meshes (eps32 ≈ 6e-8).
                    assert!(
                        dp <= 1e-5 && dn <= TN && dns <= ROUNDING_FACTOR,
                        "{name} {what} level {level} {}: {dp:e} {dn:e} {dns}",
                        kernel.name()
                    );
                }
            }
        }
    }
}

#[test]
fn f32_fast_path_chunks_and_threads_do_not_change_results() {
    let mesh = load("spot.obj");
    for (_, table, what) in cases(&mesh) {
        let run = |ev: &CpuEvaluator| {
            let (mut p, mut n, mut firsts) = (Vec::new(), Vec::new(), Vec::new());
            ev.evaluate_f32(&table, &Pattern::Grid { level: 9 }, &mut |c| {
                firsts.push(c.first);
                p.extend_from_slice(c.positions);
                n.extend_from_slice(c.normals);
                Ok(())
            })
            .unwrap();
            (p, n, firsts)
        };
        let whole = run(&CpuEvaluator::default());
        let tiny = run(&CpuEvaluator::with_chunk_samples(1));
        assert_eq!(tiny.2, (0..table.len()).collect::<Vec<_>>(), "{what}");
        assert!(
            whole.0 == tiny.0 && whole.1 == tiny.1,
            "{what}: chunking changed results"
        );
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let single = one.install(|| run(&CpuEvaluator::default()));
        assert!(
            whole.0 == single.0 && whole.1 == single.1,
            "{what}: threads changed results"
        );
    }
}

#[test]
fn f32_fast_path_refuses_weights_of_another_kind() {
    let mesh = load("sphere320");
    let table = PatchTable::build(&mesh, g1tess::patch::Scheme::G1, &Default::default()).unwrap();
    let g = GridWeightsF32::new(g1tess::patch::PatchKind::Bezier(1), 4);
    let e = CpuEvaluator::default()
        .grid_f32(&table, &g, &mut |_| Ok(()))
        .unwrap_err();
    assert!(e.to_string().contains("Gregory"), "{e}");
}

/// Corner samples of a grid are the input vertices: exactly in f64, rounded once in f32,
/// bit for bit, on every backend, for every scheme (the corner control points of every
/// scheme are the input positions).
#[test]
fn grid_corners_are_the_input_vertices_bit_for_bit() {
    let level = 5;
    let corners = grid_corners(level);
    let per = grid_len(level);
    for name in ["torus200", "spot.obj", "fandisk.obj"] {
        let mesh = load(name);
        for (_, table, what) in cases(&mesh) {
            let input = |i: usize, k: usize| mesh.positions[mesh.triangles[i][k] as usize];
            for i in 0..table.len() {
                for k in 0..3 {
                    assert_eq!(table.corner(i, k), input(i, k), "{name} {what}");
                }
            }
            for (backend, ev) in evaluators() {
                let pattern = Pattern::Grid { level };
                let mut checked = 0;
                ev.evaluate(&table, &pattern, &mut |c| {
                    for (j, p) in c.positions.chunks_exact(per).enumerate() {
                        for (k, &g) in corners.iter().enumerate() {
                            let want = input(c.first + j, k);
                            assert!(
                                p[g] == want,
                                "{name} {what} {backend} f64: patch {} corner {k}: {} instead of {want}",
                                c.first + j,
                                p[g]
                            );
                            checked += 1;
                        }
                    }
                    Ok(())
                })
                .unwrap();
                assert_eq!(checked, 3 * table.len());
                checked = 0;
                ev.evaluate_f32(&table, &pattern, &mut |c| {
                    for (j, p) in c.positions.chunks_exact(per).enumerate() {
                        for (k, &g) in corners.iter().enumerate() {
                            let want = to_f32(input(c.first + j, k));
                            assert!(
                                p[g].map(f32::to_bits) == want.map(f32::to_bits),
                                "{name} {what} {backend} f32: patch {} corner {k}: {:?} instead of {want:?}",
                                c.first + j,
                                p[g]
                            );
                            checked += 1;
                        }
                    }
                    Ok(())
                })
                .unwrap();
                assert_eq!(checked, 3 * table.len());
            }
        }
    }
}

/// f32 grid samples agree with the f64 reference on every backend to a bound that follows
/// from f32 rounding: positions within 1e-5 of the mesh diagonal (control points rounded
/// relative to the patch origin, a short weighted sum in f32, |w| sums of a few units, eps32
/// ≈ 6e-8, so a few hundred ulps of the extent at most), normals to 1 − dot ≤ TN where the
/// harness calls them regular.
#[test]
fn f32_grids_agree_with_the_f64_reference_on_every_backend() {
    let level = 6;
    let per = grid_len(level);
    let mesh = load("spot.obj");
    let diag = mesh.diagonal();
    for (_, table, what) in cases(&mesh) {
        let reference = grid_weights(&table, level);
        for (backend, ev) in evaluators() {
            let (mut dp, mut dn, mut samples) = (0f64, 0f64, 0);
            ev.evaluate_f32(&table, &Pattern::Grid { level }, &mut |c| {
                for k in 0..c.positions.len() {
                    let (i, w) = (c.first + k / per, &reference[k % per]);
                    let sp = table.eval_weights(i, w);
                    let q = DVec3::from(c.positions[k].map(f64::from));
                    let m = DVec3::from(c.normals[k].map(f64::from));
                    dp = dp.max(q.distance(sp.p) / diag);
                    if regular(normal_error(&table, i, w, EPS32), TN) {
                        dn = dn.max(1.0 - m.dot(sp.n));
                    }
                }
                samples += c.positions.len();
                Ok(())
            })
            .unwrap();
            assert_eq!(samples, per * table.len(), "{what} {backend}");
            eprintln!("spot {what} {backend}: max |dp|/diag {dp:.2e}, max 1-dot {dn:.2e}");
            assert!(dp <= 1e-5 && dn <= TN, "{what} {backend}: {dp:e} {dn:e}");
        }
    }
}
