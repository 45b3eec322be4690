//! Per-edge levels: random levels give closed output with the counts the pattern predicts;
//! equal levels are the uniform plan bit for bit; levels for a tolerance are measured within
//! it with fewer triangles than the uniform level that meets it; screen-space levels along
//! a camera path stay watertight; the WGSL level pass validates and matches the CPU; the
//! GPU evaluates per-edge patterns with the CPU's topology.

use crate::tests::common;

use std::collections::HashMap;
#[cfg(feature = "gpu")]
use std::sync::Arc;

use glam::{DMat4, DVec3};

#[cfg(feature = "gpu")]
use crate::gpu::screen::{gpu_screen_levels, LEVELS_WGSL};
use crate::tess::adaptive::{measure_deviation, DEVIATION_POINTS};
use crate::tess::layout;
use crate::tess::screen::edge_level;
use crate::tess::stitch::stitch_plan;
use crate::CpuEvaluator;
#[cfg(feature = "gpu")]
use crate::GpuEvaluator;
use crate::NoProgress;
use crate::{levels_for_tolerance, InnerRule, Levels, ToleranceOptions};
use crate::{screen_levels, ScreenView};
use crate::{stitch, StitchPlan, StitchedMesh};
use crate::{Adjacency, LoadOptions, Mesh};
use crate::{Evaluator, Vector};
#[cfg(feature = "gpu")]
use crate::{GpuContext, Precision};
use crate::{PatchTable, Scheme, SchemeOptions};

fn table(mesh: &Mesh) -> PatchTable {
    PatchTable::build(mesh, Scheme::G1, &SchemeOptions::default()).unwrap()
}

fn load(name: &str, crease: Option<f64>) -> Mesh {
    let spec = if name.ends_with(".obj") {
        common::shared_spec(name)
    } else {
        name.to_string()
    };
    let opts = LoadOptions::default().with_crease_angle(crease);
    Mesh::load(&spec, &opts).unwrap()
}

/// Undirected edge (position ids) → triangles using it.
fn undirected(tris: &[[u32; 3]]) -> HashMap<(u32, u32), usize> {
    let mut m = HashMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *m.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    m
}

/// Counts the pattern predicts: positions V + Σ(L_e − 1) + Σ interior, triangles Σ per
/// patch (formulas in `tess::layout`).
fn predicted(mesh: &Mesh, adj: &Adjacency, levels: &Levels) -> (usize, usize) {
    let pe = crate::tess::levels::patch_edges(mesh.triangles.len(), adj);
    let mut pos =
        mesh.positions.len() + levels.edges.iter().map(|&l| l as usize - 1).sum::<usize>();
    let mut tris = 0;
    for t in 0..mesh.triangles.len() {
        let e = [0, 1, 2].map(|k| levels.edges[pe[3 * t + k] as usize]);
        pos += layout::interior_count(e, levels.inner[t]);
        tris += layout::triangle_count(e, levels.inner[t]);
    }
    (pos, tris)
}

/// Checks a stitched output of per-edge levels: the predicted counts, every edge of the
/// output in two triangles except along the input's boundary and non-manifold edges (as
/// many as the input edge has, L_e of them per input edge), the input's Euler
/// characteristic, consistent orientation (each two-triangle edge once each way), no
/// degenerate triangle.
fn check_closed<V: Vector>(
    mesh: &Mesh,
    adj: &Adjacency,
    levels: &Levels,
    out: &StitchedMesh<V>,
    plan: &StitchPlan,
) {
    let (pos, tris) = predicted(mesh, adj, levels);
    assert_eq!(plan.positions, pos, "{}", mesh.name);
    assert_eq!(out.positions.len(), pos, "{}", mesh.name);
    assert_eq!(plan.triangles, tris, "{}", mesh.name);
    assert_eq!(out.triangles.len(), tris, "{}", mesh.name);
    let pt = out.position_triangles();
    let uses = undirected(&pt);
    // Output edges used by c ≠ 2 triangles lie on input edges with c uses (boundary: 1,
    // non-manifold: 3 or more), L_e of them per input edge.
    let mut expect: HashMap<usize, usize> = HashMap::new();
    for (e, &l) in adj.edges.iter().zip(&levels.edges) {
        if e.uses.len() != 2 {
            *expect.entry(e.uses.len()).or_insert(0) += l as usize;
        }
    }
    let mut got: HashMap<usize, usize> = HashMap::new();
    for &c in uses.values() {
        if c != 2 {
            *got.entry(c).or_insert(0) += 1;
        }
    }
    if adj.nonmanifold == 0 {
        assert_eq!(got, expect, "{}", mesh.name);
    } else {
        // Where two triangles share two edges (suzanne has such a pair at its
        // non-manifold edge) they share the segment cutting off their common corner too:
        // the boundary is exact, the non-manifold segments at least L_e.
        assert_eq!(got.get(&1), expect.get(&1), "{}", mesh.name);
        for (c, n) in &expect {
            assert!(got.get(c).is_some_and(|g| g >= n), "{}", mesh.name);
        }
    }
    let euler_in =
        mesh.positions.len() as i64 - adj.edges.len() as i64 + mesh.triangles.len() as i64;
    let euler_out = pos as i64 - uses.len() as i64 + tris as i64;
    if adj.nonmanifold == 0 {
        assert_eq!(euler_out, euler_in, "{}", mesh.name);
    } else {
        // Each shared corner segment (above) is one edge fewer.
        let shared: usize = got
            .iter()
            .map(|(c, n)| n - expect.get(c).copied().unwrap_or(0))
            .sum();
        assert_eq!(euler_out, euler_in + shared as i64, "{}", mesh.name);
    }
    // Consistent orientation: no directed edge twice.
    let mut directed = HashMap::new();
    for t in &pt {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    for (&(a, b), &c) in &directed {
        if uses[&(a.min(b), a.max(b))] == 2 {
            assert_eq!(c, 1, "{}: ({a}, {b})", mesh.name);
        }
    }
    // No degenerate triangle (three distinct positions).
    assert!(pt
        .iter()
        .all(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]));
}

#[test]
fn random_edge_levels_give_closed_output_with_predicted_counts() {
    let mut rng = common::Rng(11);
    // (mesh, share of edges drawn from 1..=64 (the rest 1..=2, or 1 where the share is
    // small), inner rule): small meshes
    // get every edge random; big ones a share, so that the whole test stays near 10^5
    // triangles.
    let cases = [
        ("icosphere:0", 1.0, InnerRule::Max),
        ("sphere320", 0.5, InnerRule::Min),
        ("torus200", 1.0, InnerRule::Min),
        ("torus:7x5:analytic", 1.0, InnerRule::Mean),
        ("suzanne.obj", 0.05, InnerRule::Mean),
        ("spot.obj", 0.02, InnerRule::Min),
        ("fandisk.obj", 0.01, InnerRule::Mean),
        ("stanford-bunny.obj", 0.003, InnerRule::Min),
    ];
    let mut total = 0;
    for (name, share, rule) in cases {
        let mesh = load(
            name,
            if name == "fandisk.obj" {
                Some(30.0)
            } else {
                None
            },
        );
        let adj = mesh.adjacency();
        let edges: Vec<u32> = (0..adj.edges.len())
            .map(|_| {
                if rng.f64() < share {
                    1 + (rng.next_u64() % 64) as u32
                } else if share < 0.5 {
                    1
                } else {
                    1 + (rng.next_u64() % 2) as u32
                }
            })
            .collect();
        let levels = Levels::from_edges(&mesh, &adj, edges, rule).unwrap();
        assert!(levels.uniform_level().is_none());
        let plan = StitchPlan::with_levels(&mesh, &adj, &levels).unwrap();
        assert!(!plan.is_uniform());
        let t = table(&mesh);
        let (out, snap) = stitch_plan::<DVec3>(&plan, &t, &CpuEvaluator::default()).unwrap();
        check_closed(&mesh, &adj, &levels, &out, &plan);
        // Shared samples: each patch's own evaluation of an edge point equals the owner's
        // up to rounding (G1 patches share their boundary curves): 1e-12 of the size.
        assert!(snap <= 1e-12 * mesh.diagonal(), "{name}: snap {snap}");
        // Corner samples (local samples 0, 1, 2 of a non-uniform patch) are the input
        // vertices bit for bit.
        let (mut rec, mut pos) = (Vec::new(), Vec::new());
        for (p, tri) in mesh.triangles.iter().enumerate() {
            plan.local_ids(p, &mut rec, &mut pos);
            for k in 0..3 {
                assert_eq!(
                    out.positions[pos[k] as usize],
                    mesh.positions[tri[k] as usize]
                );
            }
        }
        eprintln!("{name}: {} triangles", plan.triangles);
        total += plan.triangles;
    }
    // Sized for CI: a few hundred thousand triangles in all.
    assert!(total < 500_000, "{total} triangles");
}

#[test]
fn equal_levels_are_the_uniform_plan_bit_for_bit() {
    let mesh = load("spot.obj", None);
    let adj = mesh.adjacency();
    let t = table(&mesh);
    let cpu = CpuEvaluator::default();
    for n in [1, 3] {
        let levels = Levels::uniform(&adj, mesh.triangles.len(), n);
        assert_eq!(levels.uniform_level(), Some(n));
        let plan = StitchPlan::with_levels(&mesh, &adj, &levels).unwrap();
        assert!(plan.is_uniform());
        let (a, _) = stitch_plan::<[f32; 3]>(&plan, &t, &cpu).unwrap();
        let (b, _, _) = crate::tess::stitch::stitch_in::<[f32; 3]>(&mesh, &t, &cpu, n).unwrap();
        assert_eq!(a.positions, b.positions);
        assert_eq!(a.normals, b.normals);
        assert_eq!(a.triangles, b.triangles);
    }
    // A non-uniform plan whose patches are all uniform but for one edge: every other
    // patch's points are the grid's (as a set, in its own order).
    let mut levels = Levels::uniform(&adj, mesh.triangles.len(), 4);
    levels.edges[0] = 5;
    let plan = StitchPlan::with_levels(&mesh, &adj, &levels).unwrap();
    let (out, _) = stitch_plan::<DVec3>(&plan, &t, &cpu).unwrap();
    check_closed(&mesh, &adj, &levels, &out, &plan);
    let (uni, _, _) = stitch(&mesh, &t, &cpu, 4).unwrap();
    // One edge with 5 segments instead of 4: one more position; its two patches keep the
    // inner level 4 (≥ 3): 16 + 1 triangles each instead of 16.
    assert_eq!(out.positions.len(), uni.positions.len() + 1);
    assert_eq!(out.triangles.len(), uni.triangles.len() + 2);
}

/// (mesh, crease angle, relative tolerance, smallest uniform level within it (found by
/// measuring every level below it), uniform triangles at that level).
const TOLERANCE_CASES: [(&str, Option<f64>, f64, u32); 5] = [
    ("spot.obj", None, 1e-3, 2),
    ("spot.obj", None, 1e-4, 8),
    ("fandisk.obj", Some(30.0), 1e-3, 1),
    ("fandisk.obj", Some(30.0), 1e-4, 4),
    ("stanford-bunny.obj", None, 1e-3, 3),
];

#[test]
fn tolerance_levels_are_measured_within_it_with_fewer_triangles() {
    let cpu = CpuEvaluator::default();
    let mut rng = common::Rng(7);
    for (name, crease, rel, uniform) in TOLERANCE_CASES {
        let mesh = load(name, crease);
        let adj = mesh.adjacency();
        let t = table(&mesh);
        let eps = rel * mesh.diagonal();
        let opts = ToleranceOptions::default()
            .with_tolerance(eps)
            .with_max_level(64)
            .with_rounds(8);
        let r = levels_for_tolerance(&mesh, &adj, &t, &cpu, &opts, &NoProgress).unwrap();
        assert!(r.met, "{name} {rel}: {:e} > {eps:e}", r.deviation.max);
        assert!(r.deviation.max <= eps);
        let plan = StitchPlan::with_levels(&mesh, &adj, &r.levels).unwrap();
        assert_eq!(r.deviation.triangles, plan.triangles);
        assert_eq!(r.deviation.points, DEVIATION_POINTS.len() * plan.triangles);
        // The uniform level: within ε, and the level below it not.
        let at = |n: u32| {
            let p = StitchPlan::new(&mesh, &adj, n).unwrap();
            measure_deviation(&p, &t, &cpu, &NoProgress).unwrap()
        };
        let u = at(uniform);
        assert!(u.max <= eps, "{name} {rel}: uniform {uniform}: {:e}", u.max);
        if uniform > 1 {
            assert!(
                at(uniform - 1).max > eps,
                "{name} {rel}: uniform {}",
                uniform - 1
            );
        }
        assert_eq!(
            u.triangles,
            mesh.triangles.len() * (uniform * uniform) as usize
        );
        let ratio = plan.triangles as f64 / u.triangles as f64;
        eprintln!(
            "{name} tolerance {rel:e} x diagonal: adaptive {} triangles (deviation {:.3e}), \
             uniform level {uniform} {} triangles (deviation {:.3e}): {:.1} %",
            plan.triangles,
            r.deviation.max,
            u.triangles,
            u.max,
            100.0 * ratio
        );
        if uniform > 1 {
            assert!(ratio <= 0.6, "{name} {rel}: {ratio}");
        } else {
            // Level 1 (the input itself) meets ε: one triangle per patch is the least any
            // levels give; the coarsening must come back to it.
            assert_eq!(plan.triangles, u.triangles, "{name} {rel}");
        }
        // Independent check at other points: the stitched f64 surface re-read triangle by
        // triangle, at random interior points of 200 random triangles per case, each flat
        // point against the patch. The 10 measured points of a triangle bound its
        // deviation up to the variation between them: 1.25 × ε leaves room for that.
        let (out, _) = stitch_plan::<DVec3>(&plan, &t, &cpu).unwrap();
        let pt = out.position_triangles();
        let mut starts = Vec::with_capacity(plan.patches() + 1);
        let mut acc = 0;
        for p in 0..plan.patches() {
            starts.push(acc);
            let (e, inner) = plan.patch_levels(p);
            acc += layout::triangle_count(e, inner);
        }
        starts.push(acc);
        let mut queries = Vec::new();
        let mut flat = Vec::new();
        let (mut bary, mut local) = (Vec::new(), Vec::new());
        for _ in 0..200 {
            let k = (rng.next_u64() % pt.len() as u64) as usize;
            let p = starts.partition_point(|&s| s <= k) - 1;
            bary.clear();
            local.clear();
            plan.patch_points(p, &mut bary);
            plan.patch_local_triangles(p, &mut local);
            let lt = local[k - starts[p]];
            let w = rng.interior_b(0.05);
            let b: [f64; 3] =
                std::array::from_fn(|c| (0..3).map(|v| w[v] * bary[lt[v] as usize][c]).sum());
            let x: DVec3 = (0..3)
                .map(|v| w[v] * out.positions[pt[k][v] as usize])
                .sum();
            queries.push(crate::eval::PatchPoint { patch: p as u32, b });
            flat.push(x);
        }
        let (s, _) = cpu
            .evaluate_all(&t, &crate::Pattern::Points(queries))
            .unwrap();
        for (a, b) in s.iter().zip(&flat) {
            assert!(a.distance(*b) <= 1.25 * eps, "{name}: {:e}", a.distance(*b));
        }
    }
}

/// A perspective camera at `eye` looking at the origin.
fn camera(eye: DVec3, aspect: f64) -> DMat4 {
    DMat4::perspective_rh(0.8, aspect, 0.05, 100.0) * DMat4::look_at_rh(eye, DVec3::ZERO, DVec3::Y)
}

#[test]
fn screen_space_levels_stay_watertight_along_a_camera_path() {
    let mesh = load("spot.obj", None);
    let adj = mesh.adjacency();
    let t = table(&mesh);
    let (lo, hi) = mesh.bbox();
    let c = 0.5 * (lo + hi);
    let r = mesh.diagonal();
    let cpu = CpuEvaluator::default();
    let mut last = None;
    for frame in 0..5 {
        // Closer each frame, turning around the model.
        let a = frame as f64 * 0.7;
        let d = r * (2.5 - 0.4 * frame as f64);
        let eye = DVec3::new(d * a.cos(), 0.3 * r, d * a.sin());
        let view = ScreenView {
            view_proj: camera(eye, 4.0 / 3.0) * DMat4::from_translation(-c),
            viewport: [640.0, 480.0],
            target_px: 12.0,
            max_level: 16,
        };
        let levels = screen_levels(&mesh, &adj, &view, InnerRule::Max).unwrap();
        for (e, &l) in adj.edges.iter().zip(&levels.edges) {
            let p = e.v.map(|v| mesh.positions[v as usize]);
            assert_eq!(l, edge_level(&view, p[0], p[1]));
        }
        let plan = StitchPlan::with_levels(&mesh, &adj, &levels).unwrap();
        let (out, _) = stitch_plan::<[f32; 3]>(&plan, &t, &cpu).unwrap();
        check_closed(&mesh, &adj, &levels, &out, &plan);
        // Closer frames ask for more triangles.
        if let Some(prev) = last {
            assert!(
                plan.triangles > prev,
                "frame {frame}: {} <= {prev}",
                plan.triangles
            );
        }
        last = Some(plan.triangles);
    }
}

#[test]
#[cfg(feature = "gpu")]
fn levels_wgsl_validates_and_names_the_function_it_mirrors() {
    let module = crate::gpu::shaders::validate(LEVELS_WGSL, Precision::F32).unwrap();
    assert!(module.entry_points.iter().any(|e| e.name == "levels_main"));
    assert!(module
        .functions
        .iter()
        .any(|(_, f)| f.name.as_deref() == Some("edge_level")));
    let mirrors = common::mirrored_functions("shaders/levels.wgsl", LEVELS_WGSL);
    assert_eq!(mirrors, ["tess::screen::edge_level"]);
}

#[cfg(feature = "gpu")]
fn ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true" || v == "1")
}

/// The shared context, or None (SKIP) without an adapter; with CI=true no adapter panics.
#[cfg(feature = "gpu")]
fn context() -> Option<Arc<GpuContext>> {
    match crate::tests::common::shared_gpu() {
        Ok(c) => Some(c),
        Err(e) => {
            assert!(!ci(), "CI=true and no GPU adapter: {e}");
            eprintln!("\n======== SKIP: no GPU adapter ({e}); GPU test not run ========\n");
            None
        }
    }
}

#[test]
#[cfg(feature = "gpu")]
fn gpu_level_pass_matches_the_cpu() {
    let Some(ctx) = context() else { return };
    let mesh = load("spot.obj", None);
    let adj = mesh.adjacency();
    let (lo, hi) = mesh.bbox();
    let c = 0.5 * (lo + hi);
    for (eye, target) in [
        (DVec3::new(2.0, 0.5, 1.5), 6.0),
        (DVec3::new(-0.6, 0.2, 0.5), 3.0),
    ] {
        let view = ScreenView {
            view_proj: camera(eye * mesh.diagonal(), 1.5) * DMat4::from_translation(-c),
            viewport: [900.0, 600.0],
            target_px: target,
            max_level: 32,
        };
        let gpu = gpu_screen_levels(&ctx.device, &ctx.queue, &mesh, &adj, &view).unwrap();
        let cpu = screen_levels(&mesh, &adj, &view, InnerRule::Max).unwrap();
        assert_eq!(gpu.len(), cpu.edges.len());
        let mut differ = 0;
        for (k, (&g, &l)) in gpu.iter().zip(&cpu.edges).enumerate() {
            if g != l {
                // f32 against f64: only where the projected length is within 1e-4 of a
                // whole number of targets may the rounding up differ, and by one.
                let e = &adj.edges[k];
                let p = e.v.map(|v| mesh.positions[v as usize]);
                let a = view.view_proj * p[0].extend(1.0);
                let b = view.view_proj * p[1].extend(1.0);
                let dx = (a.x / a.w - b.x / b.w) * 0.5 * view.viewport[0];
                let dy = (a.y / a.w - b.y / b.w) * 0.5 * view.viewport[1];
                let s = (dx * dx + dy * dy).sqrt() / view.target_px;
                assert!(
                    (s - s.round()).abs() < 1e-4 && g.abs_diff(l) == 1,
                    "edge {k}: gpu {g} cpu {l} ({s})"
                );
                differ += 1;
            }
        }
        assert!(
            differ * 1000 <= gpu.len(),
            "{differ} of {} differ",
            gpu.len()
        );
        assert!(
            cpu.edges.iter().any(|&l| l > 1),
            "the view asks for more than level 1"
        );
    }
}

#[test]
#[cfg(feature = "gpu")]
fn gpu_evaluates_per_edge_patterns_with_the_cpu_topology() {
    let Some(ctx) = context() else { return };
    let mesh = load("icosphere:1", None);
    let adj = mesh.adjacency();
    let t = table(&mesh);
    let mut rng = common::Rng(3);
    let edges = (0..adj.edges.len())
        .map(|_| 1 + (rng.next_u64() % 9) as u32)
        .collect();
    let levels = Levels::from_edges(&mesh, &adj, edges, InnerRule::Mean).unwrap();
    let plan = StitchPlan::with_levels(&mesh, &adj, &levels).unwrap();
    let gpu = GpuEvaluator::new(ctx, Precision::F32).unwrap();
    let (g, _) = stitch_plan::<[f32; 3]>(&plan, &t, &gpu).unwrap();
    let (c, _) = stitch_plan::<DVec3>(&plan, &t, &CpuEvaluator::default()).unwrap();
    assert_eq!(g.triangles, c.triangles);
    assert_eq!(g.record_position, c.record_position);
    for (a, b) in g.positions.iter().zip(&c.positions) {
        let a = DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
        // f32 evaluation of a unit-sized sphere: a few ulps of 1.
        assert!(a.distance(*b) < 1e-5, "{a} {b}");
    }
}
