//! f32 evaluation (`Evaluator::evaluate_f32`; on the CPU the SIMD grid kernel) against the
//! f64 reference, for every patch kind, on the test meshes at levels 1, 8 and 32, with both
//! CPU kernels (AVX-512F or AVX2+FMA where the CPU has it, and the portable one), the
//! AVX-512F kernel bitwise the AVX2 one; chunked runs
//! identical to whole ones; corner samples equal to the input vertices bit for bit on every
//! backend (the harness's `evaluators`) in both precisions. The edge pattern of the
//! statistics (`EdgePairs`, `Evaluator::evaluate_edges`): bitwise its explicit point list
//! on the CPU with every edge kernel (AVX-512F, AVX, sparse), within f32 rounding of the
//! f64 reference on every backend; its per-sample products
//! (`Evaluator::evaluate_edge_products`): gap² bitwise those of the points and cos within
//! `PAIR_COS_TOLERANCE` of them (bitwise where they go through the points), bitwise the
//! same with both lane widths.

use crate::tests::eval_cases;
use eval_cases::{
    angle, evaluators, load, normal_error, regular, tables, EPS32, MESHES, ROUNDING_FACTOR,
};

use glam::DVec3;
use rayon::prelude::*;

use crate::analysis::stats::{edge_pairs, SAMPLES_PER_EDGE};
use crate::eval::cpu::{grid_weights, EdgeKernel, F32Kernel, GridWeightsF32};
use crate::eval::{
    grid_corners, grid_len, to_f32, EdgePairs, EdgeSide, PairProducts, PatchPoint,
    PAIR_COS_TOLERANCE,
};
use crate::CpuEvaluator;
use crate::PatchTable;
use crate::{Chunk, Evaluator, Pattern};

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

/// Largest mesh the GPU backends of the harness run on in these CPU-path tests (see
/// `grid_corners_are_the_input_vertices_bit_for_bit`).
const GPU_MAX_TRIANGLES: usize = 1000;
/// Largest mesh `f32_fast_path_matches_the_f64_reference` runs at its finest level.
const FINE_LEVEL_MAX_TRIANGLES: usize = 1000;

#[test]
fn f32_fast_path_matches_the_f64_reference() {
    eprintln!("fast path kernel here: {}", F32Kernel::Auto.name());
    for name in MESHES {
        let mesh = load(name);
        let diag = mesh.diagonal();
        for (table, what) in tables(&mesh) {
            for level in [1, 8, 32] {
                // Level 32 (561 samples a patch: 70 blocks of 8 and a partial one) on the
                // built-ins only: on spot and fandisk it is 3.3 M and 7.3 M samples a
                // scheme and kernel, two thirds of this binary's time; a sample runs the
                // same code at any level, and their patches are compared at levels 1 and 8.
                if level > 8 && mesh.triangles.len() > FINE_LEVEL_MAX_TRIANGLES {
                    continue;
                }
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
    for (table, what) in tables(&mesh) {
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

/// The AVX-512F kernel (16 lanes: `Auto` where the CPU has it) and the AVX2 one (8 lanes)
/// run the same operations in the same order on each lane: bitwise the same samples, for
/// every kind of patch, at levels whose last block of 16 holds 3, 6, 10, 13 and 1 samples
/// (3, 6, 10, 45 and 561 samples a patch). Where the CPU lacks AVX-512F both run AVX2.
#[test]
fn f32_kernels_of_both_widths_give_the_same_bits() {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx512f") {
        assert_eq!(F32Kernel::Auto.name(), "avx512f");
    }
    eprintln!(
        "kernels here: {} and {}",
        F32Kernel::Auto.name(),
        F32Kernel::Avx2.name()
    );
    let mesh = load("sphere320");
    for (table, what) in tables(&mesh) {
        for level in [1, 2, 3, 8, 32] {
            let run = |f32_kernel: F32Kernel| {
                let ev = CpuEvaluator {
                    f32_kernel,
                    ..Default::default()
                };
                let mut bits = Vec::new();
                ev.evaluate_f32(&table, &Pattern::Grid { level }, &mut |c| {
                    for (p, n) in c.positions.iter().zip(c.normals) {
                        bits.push([p.map(f32::to_bits), n.map(f32::to_bits)]);
                    }
                    Ok(())
                })
                .unwrap();
                bits
            };
            let (wide, narrow) = (run(F32Kernel::Auto), run(F32Kernel::Avx2));
            assert_eq!(wide.len(), grid_len(level) * table.len(), "{what}");
            assert!(wide == narrow, "{what} level {level}: the kernels differ");
        }
    }
}

#[test]
fn f32_fast_path_refuses_weights_of_another_kind() {
    let mesh = load("sphere320");
    let table = PatchTable::build(&mesh, crate::Scheme::G1, &Default::default()).unwrap();
    let g = GridWeightsF32::new(crate::PatchKind::Bezier(1), 4);
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
        for (table, what) in tables(&mesh) {
            let input = |i: usize, k: usize| mesh.positions[mesh.triangles[i][k] as usize];
            for i in 0..table.len() {
                for k in 0..3 {
                    assert_eq!(table.corner(i, k), input(i, k), "{name} {what}");
                }
            }
            for (backend, ev) in evaluators() {
                // The GPU's corners are checked on every kind, precision and pattern in
                // tests/gpu.rs; here its backends run on the small built-in only, since a
                // software adapter spends most of the suite's time on the big meshes.
                if backend.starts_with("gpu") && mesh.triangles.len() > GPU_MAX_TRIANGLES {
                    continue;
                }
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
    for (table, what) in tables(&mesh) {
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

/// Every result of `evaluate_edges`, checking that chunks arrive in order and counting
/// them.
fn run_edges(
    ev: &dyn Evaluator,
    table: &PatchTable,
    edges: &EdgePairs,
) -> (Vec<DVec3>, Vec<DVec3>, usize) {
    let (mut pos, mut nrm, mut chunks) = (Vec::new(), Vec::new(), 0);
    ev.evaluate_edges(table, edges, &mut |c| {
        assert_eq!(c.first, pos.len(), "chunks arrive in order");
        assert_eq!(c.positions.len(), c.normals.len());
        pos.extend_from_slice(c.positions);
        nrm.extend_from_slice(c.normals);
        chunks += 1;
        Ok(())
    })
    .unwrap();
    (pos, nrm, chunks)
}

/// Every result of `evaluate_edge_products` as bits (cos, gap²), checking that chunks
/// arrive in order and counting them.
fn run_products(
    ev: &dyn Evaluator,
    table: &PatchTable,
    edges: &EdgePairs,
) -> (Vec<[u64; 2]>, usize) {
    let (mut out, mut chunks) = (Vec::new(), 0);
    ev.evaluate_edge_products(table, edges, &mut |c| {
        assert_eq!(c.first, out.len(), "chunks arrive in order");
        out.extend(c.pairs.iter().map(|s| [s.cos.to_bits(), s.gap2.to_bits()]));
        chunks += 1;
        Ok(())
    })
    .unwrap();
    (out, chunks)
}

/// The products of the points `pos`/`nrm` (each sample on its two patches), as bits.
fn products_of(pos: &[DVec3], nrm: &[DVec3]) -> Vec<[u64; 2]> {
    pos.chunks_exact(2)
        .zip(nrm.chunks_exact(2))
        .map(|(p, n)| {
            let s = PairProducts::of([p[0], p[1]], [n[0], n[1]]);
            [s.cos.to_bits(), s.gap2.to_bits()]
        })
        .collect()
}

/// Products `got` against `want`, those of the points (as bits): gap² bitwise, cos
/// bitwise or within `PAIR_COS_TOLERANCE` (the CPU's lane kernel takes cos from the
/// unnormalised cross products, a few u from the unit normals' dot product: derivation at
/// the constant). Returns how many cos differ.
fn assert_products_close(got: &[[u64; 2]], want: &[[u64; 2]], what: &str) -> usize {
    assert_eq!(got.len(), want.len(), "{what}");
    let mut differ = 0;
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        assert_eq!(g[1], w[1], "{what}: gap² of sample {k}");
        if g[0] != w[0] {
            let (a, b) = (f64::from_bits(g[0]), f64::from_bits(w[0]));
            assert!(
                (a - b).abs() <= PAIR_COS_TOLERANCE,
                "{what}: cos of sample {k}: {a:e} against {b:e}"
            );
            differ += 1;
        }
    }
    differ
}

/// An evaluator with only `evaluate`: `evaluate_edges` is the trait's default (the points
/// expanded a bounded run at a time), what the GPU backend runs.
struct ViaPoints(CpuEvaluator);

impl Evaluator for ViaPoints {
    fn describe(&self) -> String {
        "cpu through points".into()
    }
    fn evaluate(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(Chunk<'_>) -> crate::Result<()>,
    ) -> crate::Result<()> {
        self.0.evaluate(table, pattern, sink)
    }
}

/// Each of the six ordered slot pairs on each of the first `patches` patches, paired with
/// the reverse order on the next patch.
fn all_orders(patches: usize, samples: u32) -> EdgePairs {
    let mut pairs = Vec::new();
    for i in 0..patches as u32 {
        for (from, to) in [(0, 1), (1, 0), (1, 2), (2, 1), (2, 0), (0, 2)] {
            pairs.push([
                EdgeSide { patch: i, from, to },
                EdgeSide {
                    patch: (i + 1) % patches as u32,
                    from: to,
                    to: from,
                },
            ]);
        }
    }
    EdgePairs { samples, pairs }
}

/// Whether `a` and `b` are the same vectors bit for bit.
fn same_bits(a: &[DVec3], b: &[DVec3]) -> bool {
    let bits = |p: &DVec3| p.to_array().map(f64::to_bits);
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| bits(x) == bits(y))
}

/// On the CPU the edge pattern is bitwise `Pattern::Points` of its point list and
/// `PatchTable::eval` at each point, for every scheme, in any chunking and through the
/// trait's default; its ends are the input vertices bit for bit; exact sample counts
/// (2 × 21 per interior edge).
#[test]
fn edge_pairs_are_bitwise_the_point_list_on_the_cpu() {
    for name in ["fandisk.obj", "spot.obj"] {
        let mesh = load(name);
        let adj = mesh.adjacency();
        let stats = edge_pairs(&mesh, &adj);
        assert_eq!(stats.samples, SAMPLES_PER_EDGE);
        assert_eq!(stats.pairs.len(), adj.interior);
        assert_eq!(stats.len(), 2 * 21 * adj.interior);
        for (table, what) in tables(&mesh) {
            let patterns = [
                stats.clone(),
                all_orders(40, 1),
                all_orders(40, 2),
                all_orders(40, 5),
            ];
            for (pattern, edges) in patterns.iter().enumerate() {
                // Chunks of 7 points (one pair each when a pair has more) and, through the
                // default, of 5 (samples split between chunks) on the small patterns; on
                // the mesh's (thousands of pairs) 889 = 21 pairs of 42 points and 7, and
                // 887, odd (samples split), so that its thousands of chunks do not each
                // start a parallel job.
                let (chunk, via) = if pattern == 0 { (889, 887) } else { (7, 5) };
                let points = edges.points();
                assert_eq!(points.len(), edges.len());
                let (pos, nrm, _) = run_edges(&CpuEvaluator::default(), &table, edges);
                assert_eq!(pos.len(), edges.len(), "{name} {what}");
                let (rp, rn) = CpuEvaluator::default()
                    .evaluate_all(&table, &Pattern::Points(points.clone()))
                    .unwrap();
                let what = format!("{name} {what} {} samples", edges.samples);
                assert!(same_bits(&pos, &rp) && same_bits(&nrm, &rn), "{what}");
                for (k, pp) in points.iter().enumerate().step_by(7) {
                    let r = table.eval(pp.patch as usize, pp.b);
                    assert!(same_bits(&[pos[k], nrm[k]], &[r.p, r.n]), "{what} {pp:?}");
                }
                // Ends: slot `from` at sample 0, slot `to` at the last sample.
                let per = edges.samples as usize;
                for (q, pair) in edges.pairs.iter().enumerate() {
                    for (side, e) in pair.iter().enumerate() {
                        let tri = mesh.triangles[e.patch as usize];
                        let at = |i: usize| pos[2 * (per * q + i) + side];
                        assert_eq!(at(0), mesh.positions[tri[e.from as usize] as usize]);
                        if per > 1 {
                            assert_eq!(at(per - 1), mesh.positions[tri[e.to as usize] as usize]);
                        }
                    }
                }
                let (tp, tn, chunks) =
                    run_edges(&CpuEvaluator::with_chunk_samples(chunk), &table, edges);
                // Chunks hold whole pairs (at least one).
                let pairs_per_chunk = (chunk / (2 * per)).max(1);
                assert_eq!(chunks, edges.pairs.len().div_ceil(pairs_per_chunk));
                assert!(
                    same_bits(&tp, &pos) && same_bits(&tn, &nrm),
                    "{what}: chunked"
                );
                let (vp, vn, _) = run_edges(
                    &ViaPoints(CpuEvaluator::with_chunk_samples(via)),
                    &table,
                    edges,
                );
                assert!(
                    same_bits(&vp, &pos) && same_bits(&vn, &nrm),
                    "{what}: default"
                );
                // Products: the CPU's own (whole, and one pair per chunk), and the trait's
                // default through points in chunks of 5 (so samples split between chunks).
                let want = products_of(&pos, &nrm);
                assert_eq!(want.len(), per * edges.pairs.len());
                let (cp, _) = run_products(&CpuEvaluator::default(), &table, edges);
                assert_products_close(&cp, &want, &format!("{what}: products"));
                let (tp, chunks) =
                    run_products(&CpuEvaluator::with_chunk_samples(chunk), &table, edges);
                assert_eq!(chunks, edges.pairs.len().div_ceil(pairs_per_chunk));
                assert!(tp == cp, "{what}: products chunked");
                let (vp, _) = run_products(
                    &ViaPoints(CpuEvaluator::with_chunk_samples(via)),
                    &table,
                    edges,
                );
                assert!(vp == want, "{what}: products by default");
                // The other edge kernels: the same points; AVX (4 lanes) the same products
                // as the widest (8 lanes with AVX-512F), the sparse kernel those of the
                // points.
                for kernel in [EdgeKernel::Avx, EdgeKernel::Sparse] {
                    let ev = CpuEvaluator {
                        edge_kernel: kernel,
                        ..Default::default()
                    };
                    let (kp, kn, _) = run_edges(&ev, &table, edges);
                    assert!(
                        same_bits(&kp, &pos) && same_bits(&kn, &nrm),
                        "{what}: {kernel:?} points"
                    );
                    let (kc, _) = run_products(&ev, &table, edges);
                    let same = if kernel.lanes() == 0 { &want } else { &cp };
                    assert!(kc == *same, "{what}: {kernel:?} products");
                }
            }
        }
    }
}

/// A patch with a control point that is not finite is evaluated point by point, as the
/// point list is (the lane kernel would add 0 × ∞ where a sample's weight vanishes), and so
/// is one whose huge finite point overflows the lane sums; bad patch numbers and slots are
/// errors.
#[test]
fn edge_pairs_on_a_non_finite_patch_and_bad_input() {
    let mesh = load("spot.obj");
    let built = PatchTable::build(&mesh, crate::Scheme::G1, &Default::default()).unwrap();
    let bits = |v: &[DVec3]| -> Vec<[u64; 3]> {
        v.iter().map(|p| p.to_array().map(f64::to_bits)).collect()
    };
    let edges = all_orders(3, 21);
    // An interior (Gregory) point of patch 0, a point of patch 1's boundary cubic from
    // corner 0 (point 1), and corner 2 of patch 2 (point 8) at a finite 1e308, whose
    // derivative sums overflow.
    for (at, bad) in [
        (15, DVec3::new(f64::INFINITY, 0.0, 1.0)),
        (15, DVec3::new(0.0, f64::NAN, 1.0)),
        (18 + 1, DVec3::new(0.0, 0.0, f64::NEG_INFINITY)),
        (36 + 8, DVec3::new(1e308, -1e308, 1e308)),
    ] {
        let mut table = built.clone();
        table.points[at] = bad;
        let (pos, nrm, _) = run_edges(&CpuEvaluator::default(), &table, &edges);
        let (rp, rn) = CpuEvaluator::default()
            .evaluate_all(&table, &Pattern::Points(edges.points()))
            .unwrap();
        assert!(
            bits(&pos) == bits(&rp) && bits(&nrm) == bits(&rn),
            "{at} {bad}"
        );
        let (cp, _) = run_products(&CpuEvaluator::default(), &table, &edges);
        // Sides that weigh the bad point go through the points (bitwise), the others
        // through the lanes.
        assert_products_close(
            &cp,
            &products_of(&rp, &rn),
            &format!("{at} {bad}: products"),
        );
    }
    let table = built;
    let side = |patch, from, to| EdgeSide { patch, from, to };
    for (pair, want) in [
        ([side(0, 0, 1), side(table.len() as u32, 1, 0)], "patch"),
        ([side(0, 1, 1), side(1, 1, 0)], "slots"),
        ([side(0, 0, 3), side(1, 1, 0)], "slots"),
    ] {
        let bad = EdgePairs {
            samples: 21,
            pairs: vec![pair],
        };
        for ev in [
            &CpuEvaluator::default() as &dyn Evaluator,
            &ViaPoints(CpuEvaluator::default()),
        ] {
            let e = ev
                .evaluate_edges(&table, &bad, &mut |_| Ok(()))
                .unwrap_err();
            assert!(e.to_string().contains(want), "{e}");
        }
    }
    let start = PatchPoint {
        patch: 0,
        b: [1.0, 0.0, 0.0],
    };
    assert_eq!(EdgePairs::default().points(), Vec::<PatchPoint>::new());
    assert_eq!(edges.point(0), start);
}

/// The lane kernel's products where the unnormalised route cannot be taken or a normal is
/// the flat one: a table scaled by 1e-60 (squared cross products about 1e-240, their
/// product below the normal range) and by 1e60 (their product overflows) gives the unit
/// normals' products bitwise; a patch collapsed to the origin (S_s × S_t = 0: the flat
/// normal at every sample) gives them within the tolerance, and the flat normal itself.
#[test]
fn edge_products_of_tiny_huge_and_collapsed_patches() {
    let mesh = load("spot.obj");
    let built = PatchTable::build(&mesh, crate::Scheme::G1, &Default::default()).unwrap();
    let edges = edge_pairs(&mesh, &mesh.adjacency());
    let points = |table: &PatchTable| {
        let (p, n, _) = run_edges(&CpuEvaluator::default(), table, &edges);
        (products_of(&p, &n), n)
    };
    for scale in [1e-60, 1e60] {
        let mut table = built.clone();
        table.points.iter_mut().for_each(|p| *p *= scale);
        let (want, _) = points(&table);
        let (cp, _) = run_products(&CpuEvaluator::default(), &table, &edges);
        assert!(cp == want, "scaled by {scale:e}");
    }
    let mut table = built.clone();
    let stride = table.stride;
    table.points[..stride].fill(DVec3::ZERO);
    let (want, nrm) = points(&table);
    let (cp, _) = run_products(&CpuEvaluator::default(), &table, &edges);
    assert_products_close(&cp, &want, "collapsed patch 0");
    let on_patch_0: Vec<usize> = (0..edges.len())
        .filter(|&k| edges.pairs[k / 42][k % 2].patch == 0)
        .collect();
    // Patch 0 has three interior edges, 21 samples each.
    assert_eq!(on_patch_0.len(), 3 * 21);
    assert!(on_patch_0.iter().all(|&k| nrm[k] == table.flat_normals[0]));
}

/// The edge pattern on every backend (the harness's `evaluators`; the GPU through the
/// trait's default) against `PatchTable::eval`: positions within 1e-5 of the diagonal and
/// regular normals to 1 − dot ≤ TN (the f32 bounds of the grid comparison above, which an
/// f32 GPU's samples widened to f64 meet), ends the input vertices bit for bit, exact
/// counts.
#[test]
fn edge_pairs_agree_with_the_f64_reference_on_every_backend() {
    // torus200 keeps the GPU backends (a software adapter in CI) to seconds; the CPU edge
    // kernel is held bitwise to the point list on spot and fandisk in
    // `edge_pairs_are_bitwise_the_point_list_on_the_cpu`.
    let mesh = load("torus200");
    let diag = mesh.diagonal();
    let adj = mesh.adjacency();
    let edges = edge_pairs(&mesh, &adj);
    let points = edges.points();
    let per = edges.samples as usize;
    for (table, what) in tables(&mesh) {
        let weights: Vec<_> = points.iter().map(|p| table.kind.weights(p.b)).collect();
        for (backend, ev) in evaluators() {
            let (pos, nrm, _) = run_edges(ev.as_ref(), &table, &edges);
            assert_eq!(pos.len(), 2 * 21 * adj.interior, "{what} {backend}");
            let (mut dp, mut dn) = (0f64, 0f64);
            for (k, (pp, w)) in points.iter().zip(&weights).enumerate() {
                let i = pp.patch as usize;
                let sp = table.eval_weights(i, w);
                dp = dp.max(pos[k].distance(sp.p) / diag);
                if regular(normal_error(&table, i, w, EPS32), TN) {
                    dn = dn.max(1.0 - nrm[k].dot(sp.n));
                }
                let q = k / 2;
                let e = edges.pairs[q / per][k % 2];
                let tri = mesh.triangles[e.patch as usize];
                if q % per == 0 {
                    assert_eq!(
                        pos[k], mesh.positions[tri[e.from as usize] as usize],
                        "{backend}"
                    );
                } else if q % per == per - 1 {
                    assert_eq!(
                        pos[k], mesh.positions[tri[e.to as usize] as usize],
                        "{backend}"
                    );
                }
            }
            eprintln!(
                "torus200 edges {what} {backend}: max |dp|/diag {dp:.2e}, max 1-dot {dn:.2e}"
            );
            assert!(dp <= 1e-5 && dn <= TN, "{what} {backend}: {dp:e} {dn:e}");
        }
    }
}

#[test]
fn an_unallocatable_grid_is_an_error_not_an_abort() {
    // Level 10⁷: 5·10¹³ grid points, petabytes of basis tables on any machine.
    let mesh = crate::Mesh::load("sphere320", &Default::default()).unwrap();
    let table = PatchTable::build(&mesh, crate::Scheme::G1, &Default::default()).unwrap();
    let cpu = CpuEvaluator::default();
    let grid = Pattern::Grid { level: 10_000_000 };
    let err = cpu.evaluate(&table, &grid, &mut |_| Ok(())).unwrap_err();
    assert!(
        err.to_string().contains("the grid of level 10000000 needs"),
        "{err}"
    );
    let err = cpu
        .evaluate_f32(&table, &grid, &mut |_| Ok(()))
        .unwrap_err();
    assert!(
        err.to_string().contains("more than can be allocated"),
        "{err}"
    );
}
