//! Stitched output: counts from the topology, closed manifolds stay closed with the same
//! Euler characteristic, orientation kept, shared edge samples bitwise identical, boundary
//! and non-manifold edges kept, streaming independent of the chunk size, and the f32 path
//! (kernel → stitcher in f32) with the topology of the f64 one.

use crate::tests::common;

use std::collections::HashMap;

use crate::eval::{grid_barycentrics, grid_len, to_f32};
use crate::tess::stitch::{stitch_in, CountingSink};
use crate::CpuEvaluator;
use crate::NoProgress;
use crate::{stitch, stitch_into, StitchedMesh};
use crate::{LoadOptions, Mesh};
use crate::{PatchTable, Scheme, SchemeOptions};

fn load(spec: &str) -> Mesh {
    Mesh::load(spec, &LoadOptions::default()).unwrap()
}

/// Directed edge uses of a triangle list: (a, b) → count.
fn directed(tris: &[[u32; 3]]) -> HashMap<(u32, u32), usize> {
    let mut m = HashMap::new();
    for t in tris {
        for k in 0..3 {
            *m.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    m
}

/// Undirected edge → number of triangles using it.
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

fn euler(vertices: usize, tris: &[[u32; 3]]) -> i64 {
    vertices as i64 - undirected(tris).len() as i64 + tris.len() as i64
}

fn stitch_mesh(mesh: &Mesh, scheme: Scheme, level: u32) -> (StitchedMesh, PatchTable, f64) {
    let table = PatchTable::build(mesh, scheme, &SchemeOptions::default()).unwrap();
    let (w, plan, snap) = stitch(mesh, &table, &CpuEvaluator::default(), level).unwrap();
    assert_eq!(w.positions.len(), plan.positions);
    assert_eq!(w.normals.len(), plan.records);
    assert_eq!(w.triangles.len(), plan.triangles);
    (w, table, snap)
}

#[test]
fn closed_manifolds_stay_closed() {
    for spec in ["sphere320", "torus200", "icosphere:1", "torus:7x5:analytic"] {
        let mesh = load(spec);
        let adj = mesh.adjacency();
        assert_eq!(adj.boundary + adj.nonmanifold, 0, "{spec}");
        let chi_in = euler(mesh.positions.len(), &mesh.triangles);
        for level in [1u32, 2, 3, 5, 8] {
            let (w, _, snap) = stitch_mesh(&mesh, Scheme::G1, level);
            let n = level as usize;
            let (v, e, f) = (mesh.positions.len(), adj.edges.len(), mesh.triangles.len());
            // Independent count: vertices, edge interiors, patch interiors.
            assert_eq!(
                w.positions.len(),
                v + e * (n - 1) + f * (n - 1) * n.saturating_sub(2) / 2,
                "{spec} level {level}"
            );
            assert_eq!(w.triangles.len(), f * n * n);
            // Smooth input: one record per position, record i at position i.
            assert_eq!(w.normals.len(), w.positions.len());
            let tris = w.position_triangles();
            let und = undirected(&tris);
            assert!(
                und.values().all(|&c| c == 2),
                "{spec} level {level}: open or non-manifold"
            );
            // Consistent orientation: each directed edge once.
            assert!(
                directed(&tris).values().all(|&c| c == 1),
                "{spec}: orientation"
            );
            assert_eq!(
                euler(w.positions.len(), &tris),
                chi_in,
                "{spec} level {level}"
            );
            // No unused position.
            let mut used = vec![false; w.positions.len()];
            tris.iter().flatten().for_each(|&i| used[i as usize] = true);
            assert!(used.iter().all(|&u| u));
            // The patches meet: each patch's own edge samples lie on the shared ones. G1
            // builds each boundary curve once per edge, but the two patches weigh it
            // with their own (rational) blends, so a few f64 ulps of these unit-size
            // meshes remain.
            assert!(snap < 1e-14, "{spec} level {level}: snap {snap}");
            // Orientation kept: the flat normal of each output triangle agrees with the
            // evaluated normals at its corners.
            for t in &w.triangles {
                let p = t.map(|r| w.positions[w.record_position[r as usize] as usize]);
                let flat = (p[1] - p[0]).cross(p[2] - p[0]);
                let nsum = t
                    .iter()
                    .map(|&r| w.normals[r as usize])
                    .sum::<glam::DVec3>();
                assert!(
                    flat.dot(nsum) > 0.0,
                    "{spec} level {level}: flipped triangle"
                );
            }
        }
        assert_eq!(chi_in, if spec.starts_with("torus") { 0 } else { 2 });
    }
}

/// Each output vertex on an input edge or corner holds bitwise the owner patch's own
/// evaluation at that point; patches map their edge samples onto the same ids.
#[test]
fn shared_edge_samples_are_the_owners_evaluation() {
    let mesh = load("torus200");
    let level = 6;
    let (w, table, _) = stitch_mesh(&mesh, Scheme::G1, level);
    let per = crate::eval::grid_len(level);
    let bary = grid_barycentrics(level);
    // Key each position by (input triangle, grid point): collect the position id that
    // every patch's grid point maps to.
    let mut by_point: HashMap<[u64; 3], u32> = HashMap::new();
    let mut first_patch_of: HashMap<u32, usize> = HashMap::new();
    for (t_out, t) in w.position_triangles().iter().enumerate() {
        let patch = t_out / (level * level) as usize;
        for &p in t {
            first_patch_of.entry(p).or_insert(patch);
        }
    }
    for (pid, p) in w.positions.iter().enumerate() {
        let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
        assert!(
            by_point.insert(key, pid as u32).is_none(),
            "position {pid} duplicated: stitching missed a shared sample"
        );
    }
    // The owner's evaluation reproduces the shared positions bitwise.
    let mut exact = 0;
    for (&pid, &patch) in &first_patch_of {
        let p = w.positions[pid as usize];
        let found = bary
            .iter()
            .map(|b| table.eval(patch, *b).p)
            .any(|q| q.to_array().map(f64::to_bits) == p.to_array().map(f64::to_bits));
        if found {
            exact += 1;
        }
    }
    assert_eq!(exact, w.positions.len());
    assert_eq!(per, bary.len());
}

#[test]
fn chunking_does_not_change_the_output() {
    let mesh = load("sphere320");
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let (a, _, _) = stitch(&mesh, &table, &CpuEvaluator::default(), 5).unwrap();
    for chunk_samples in [1, 21, 100, 1000] {
        let (b, _, _) = stitch(
            &mesh,
            &table,
            &CpuEvaluator::with_chunk_samples(chunk_samples),
            5,
        )
        .unwrap();
        assert_eq!(a.triangles, b.triangles);
        assert_eq!(a.record_position, b.record_position);
        let bits = |v: &[glam::DVec3]| -> Vec<[u64; 3]> {
            v.iter().map(|p| p.to_array().map(f64::to_bits)).collect()
        };
        assert_eq!(bits(&a.positions), bits(&b.positions));
        assert_eq!(bits(&a.normals), bits(&b.normals));
    }
}

/// The stages follow the pool: 2^14 samples for each of its threads. What `tessellate`
/// runs on the CPU (patches built, certified and evaluated per stage, then stitched) gives
/// the same mesh, bit for bit, and the same verdicts with stages of 2^14 samples (1
/// thread: 191 stages on the bunny at level 8), 3 · 2^14 and 16 · 2^14 (12 stages).
#[test]
fn stages_follow_the_pool_and_leave_the_output_alone() {
    use crate::patch::PatchBuilder;
    use crate::tess::stitch::stitch_certified;
    let mesh = load(&common::shared_spec("stanford-bunny.obj"));
    let plan = crate::StitchPlan::new(&mesh, &mesh.adjacency(), 8).unwrap();
    let builder = PatchBuilder::new(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            assert_eq!(crate::eval::stage_samples(), threads << 14);
            let mut out = StitchedMesh::<[f32; 3]>::default();
            let cpu = CpuEvaluator::default();
            let (snap, counts) =
                stitch_certified(&plan, &builder, &cpu, &mut out, &NoProgress).unwrap();
            (out, snap.to_bits(), counts)
        })
    };
    let bits =
        |v: &[[f32; 3]]| -> Vec<[u32; 3]> { v.iter().map(|p| p.map(f32::to_bits)).collect() };
    let (a, snap, counts) = run(1);
    // 69,451 patches of 45 samples: 191 stages of up to 364 patches on one thread, 12 of
    // up to 5,825 on 16.
    assert_eq!(mesh.triangles.len(), 69_451);
    assert_eq!(mesh.triangles.len().div_ceil((1 << 14) / 45), 191);
    assert_eq!(mesh.triangles.len().div_ceil((16 << 14) / 45), 12);
    for threads in [3, 16] {
        let (b, s, c) = run(threads);
        assert_eq!(a.triangles, b.triangles, "{threads} threads");
        assert_eq!(a.record_position, b.record_position, "{threads} threads");
        assert_eq!(bits(&a.positions), bits(&b.positions), "{threads} threads");
        assert_eq!(bits(&a.normals), bits(&b.normals), "{threads} threads");
        assert_eq!((snap, counts), (s, c), "{threads} threads");
    }
}

/// suzanne.obj: 42 boundary edges and one non-manifold edge are kept and reported.
#[test]
fn boundary_and_nonmanifold_edges_are_kept() {
    let mesh = load(&common::shared_spec("suzanne.obj"));
    let adj = mesh.adjacency();
    assert_eq!(adj.boundary, 42);
    assert_eq!(adj.nonmanifold, 1);
    let level = 4u32;
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let (w, plan, snap) = stitch(&mesh, &table, &CpuEvaluator::default(), level).unwrap();
    assert_eq!(plan.report.boundary_edges, 42);
    assert_eq!(plan.report.nonmanifold_edges, 1);
    let uses = undirected(&w.position_triangles());
    let count = |n: usize| uses.values().filter(|&&c| c == n).count();
    // Each input edge becomes `level` output edges with the same number of uses.
    assert_eq!(count(1), 42 * level as usize);
    // The non-manifold edge (four uses: suzanne doubles one triangle with the opposite
    // orientation) becomes `level` output edges with four uses; the doubled triangle's two
    // patches also share the grid edges that join two of their (shared) edge samples.
    let nm = adj.edges.iter().find(|e| e.uses.len() > 2).unwrap();
    assert_eq!(nm.uses.len(), 4);
    assert_eq!(count(4), level as usize + 3);
    assert_eq!(uses.len(), count(1) + count(2) + count(4));
    let (v, e, f) = (mesh.positions.len(), adj.edges.len(), mesh.triangles.len());
    let n = level as usize;
    assert_eq!(
        w.positions.len(),
        v + e * (n - 1) + f * (n - 1) * (n - 2) / 2
    );
    assert!(snap.is_finite());
    assert!(w.positions.iter().all(|p| p.is_finite()));
    // Unit normals normalised in f64: a few ulps.
    assert!(w.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-12));
}

/// Every scheme stitches (the flat scheme exactly reproduces the subdivided input).
#[test]
fn flat_scheme_stitches_onto_the_input_triangles() {
    let mesh = load("icosphere:1");
    let (w, _, snap) = stitch_mesh(&mesh, Scheme::Flat, 4);
    // Linear interpolation of the same two end points from both sides: an ulp or so of
    // the unit sphere's coordinates.
    assert!(snap < 1e-15);
    // Every output position lies in the plane of its input triangle.
    let tris = w.position_triangles();
    for (i, t) in tris.iter().enumerate() {
        let input = mesh.triangles[i / 16].map(|v| mesh.positions[v as usize]);
        let n = (input[1] - input[0]).cross(input[2] - input[0]).normalize();
        for &p in t {
            // In the plane to rounding of unit-size coordinates.
            assert!((w.positions[p as usize] - input[0]).dot(n).abs() < 1e-15);
        }
    }
}

/// The f32 path (the CPU's f32 kernel into the stitcher in f32) has the f64 path's
/// topology exactly, its counts V + E(n − 1) + F(n − 1)(n − 2)/2, the input vertices
/// rounded once at the corners, every shared position once, positions within an f32
/// rounding bound of the f64 ones, and does not depend on the chunk size.
#[test]
fn f32_stitching_matches_the_f64_topology() {
    for spec in ["torus200", "spot.obj"] {
        let mesh = if spec.ends_with(".obj") {
            load(&common::shared_spec(spec))
        } else {
            load(spec)
        };
        let adj = mesh.adjacency();
        let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
        let level = 7u32;
        let n = level as usize;
        let ev = CpuEvaluator::default();
        let (a, plan, _) = stitch(&mesh, &table, &ev, level).unwrap();
        let (b, _, snap) = stitch_in::<[f32; 3]>(&mesh, &table, &ev, level).unwrap();
        let (v, e, f) = (mesh.positions.len(), adj.edges.len(), mesh.triangles.len());
        assert_eq!(
            b.positions.len(),
            v + e * (n - 1) + f * (n - 1) * (n - 2) / 2
        );
        assert_eq!(b.positions.len(), plan.positions);
        assert_eq!(b.normals.len(), plan.records);
        assert_eq!(b.triangles.len(), f * n * n);
        assert_eq!(a.triangles, b.triangles, "{spec}");
        assert_eq!(a.record_position, b.record_position, "{spec}");
        // Corners: the position the plan gives each patch's corner grid points is the
        // input vertex rounded once, bit for bit.
        let (mut rec, mut pos) = (Vec::new(), Vec::new());
        let corners = crate::eval::grid_corners(level);
        for (t, tri) in mesh.triangles.iter().enumerate() {
            plan.local_ids(t, &mut rec, &mut pos);
            for (k, &vk) in tri.iter().enumerate() {
                let got = b.positions[pos[corners[k]] as usize];
                let want = to_f32(mesh.positions[vk as usize]);
                assert_eq!(
                    got.map(f32::to_bits),
                    want.map(f32::to_bits),
                    "{spec} patch {t} corner {k}"
                );
            }
        }
        let mut seen = HashMap::new();
        for (pid, p) in b.positions.iter().enumerate() {
            assert!(
                seen.insert(p.map(f32::to_bits), pid).is_none(),
                "{spec}: position {pid} duplicated"
            );
        }
        // f32 control points relative to each patch origin, a short weighted sum in f32:
        // within 1e-5 of the diagonal (as in tests/cpu_fast.rs); the snap is the f32
        // evaluations of two patches at one edge point, the same order of magnitude.
        let diag = mesh.diagonal();
        for (p, q) in a.positions.iter().zip(&b.positions) {
            let q = glam::DVec3::from(q.map(f64::from));
            assert!(p.distance(q) <= 1e-5 * diag, "{spec}: {p} vs {q}");
        }
        assert!(snap <= 1e-5 * diag, "{spec}: snap {snap}");
        let (c, _, _) =
            stitch_in::<[f32; 3]>(&mesh, &table, &CpuEvaluator::with_chunk_samples(37), level)
                .unwrap();
        assert_eq!(b.positions, c.positions);
        assert_eq!(b.normals, c.normals);
        assert_eq!(b.triangles, c.triangles);
    }
}

/// A sink that keeps nothing sees every patch, position and record exactly once.
#[test]
fn counting_sink_sees_the_planned_counts() {
    let mesh = load(&common::shared_spec("suzanne.obj"));
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let plan = crate::StitchPlan::new(&mesh, &mesh.adjacency(), 6).unwrap();
    let mut sink = CountingSink::default();
    stitch_into::<[f32; 3]>(
        &plan,
        &table,
        &CpuEvaluator::with_chunk_samples(grid_len(6) * 10),
        &mut sink,
        &NoProgress,
    )
    .unwrap();
    assert_eq!(sink.patches, mesh.triangles.len());
    assert_eq!(sink.positions, plan.positions);
    assert_eq!(sink.records, plan.records);
}

#[test]
fn memory_estimate_counts_the_store_and_bounds_batches() {
    use crate::tess::stitch::{batch_patches, memory_estimate};
    use crate::Needs;
    let mesh = common::load("sphere320");
    let adjacency = mesh.adjacency();
    // The icosphere of 320 triangles: 162 vertices, 480 edges.
    assert_eq!((mesh.positions.len(), adjacency.edges.len()), (162, 480));
    let m = memory_estimate(162, 480, 320, 8, 12, 1 << 20, Needs::RECORDS);
    // V + E(n − 1) points of 12 bytes.
    assert_eq!(m.store_points, 162 + 480 * 7);
    assert_eq!(m.store_bytes, (162 + 480 * 7) * 12);
    // Level 8: 45 points per patch, all 320 patches in one chunk of 14400 samples,
    // positions and normals, twice.
    assert_eq!(m.chunk_bytes, 14400 * 2 * 2 * 12);
    // Runs of at most 2^14 grid points (a thread's share): 29 patches of 561 points at
    // level 32, 364 of 45 at level 8, one at level 5000 (12.5 M points); with 16 threads'
    // shares (2^18 points), 467 and 5825.
    let s = crate::eval::STAGE_SAMPLES;
    assert_eq!(batch_patches(32, s), 29);
    assert_eq!(batch_patches(8, s), 364);
    assert_eq!(batch_patches(5000, s), 1);
    assert_eq!(batch_patches(32, 16 * s), 467);
    assert_eq!(batch_patches(8, 16 * s), 5825);
    // Absurd levels saturate instead of wrapping.
    let huge = memory_estimate(3, 3, 1, u32::MAX, 24, 1 << 22, Needs::ALL);
    assert!(huge.total() >= u64::MAX / 2);
}

/// The stitcher hands patches to the sink in order while it builds the next ones (and the
/// CPU kernel evaluates the next chunk): a sink's error ends the run at once and is the
/// result, with every patch before it seen once, in order, at any chunk size.
#[test]
fn a_sink_error_stops_stitching_in_order() {
    struct Failing {
        seen: Vec<usize>,
        fail_at: usize,
    }
    impl crate::StitchSink<[f32; 3]> for Failing {
        fn patch(&mut self, out: &crate::PatchOut<'_, [f32; 3]>) -> crate::Result<()> {
            self.seen.push(out.patch);
            if out.patch == self.fail_at {
                return Err(crate::Error::Invalid("sink full".into()));
            }
            Ok(())
        }
    }
    let mesh = load("sphere320");
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let plan = crate::StitchPlan::new(&mesh, &mesh.adjacency(), 6).unwrap();
    for (chunk_samples, fail_at) in [(1, 0), (grid_len(6) * 7, 100), (1 << 20, 319)] {
        let mut sink = Failing {
            seen: Vec::new(),
            fail_at,
        };
        let e = stitch_into::<[f32; 3]>(
            &plan,
            &table,
            &CpuEvaluator::with_chunk_samples(chunk_samples),
            &mut sink,
            &NoProgress,
        )
        .unwrap_err();
        assert!(e.to_string().contains("sink full"), "{e}");
        assert_eq!(sink.seen, (0..=fail_at).collect::<Vec<_>>());
    }
}

/// What `tessellate` runs on the CPU at one level ([`stitch_built`]: each chunk's patches
/// built where they are evaluated, the whole table never held) gives bitwise the output of
/// [`stitch_into`] on the table of every patch, and its certificate ([`Certifier`], fed
/// the chunks' tables) the counts of [`validity::count`] on that table: every test mesh
/// (fandisk with its creases at 30°), every scheme, with chunks of 37 samples (a chunk
/// boundary inside most patches' neighbourhoods) and the default.
#[test]
fn built_chunks_give_the_table_output_and_counts() {
    use crate::patch::validity::{self, Certifier};
    use crate::tess::stitch::stitch_built;
    let fandisk = Mesh::load(
        &common::shared_spec("fandisk.obj"),
        &LoadOptions::default().with_crease_angle(Some(30.0)),
    )
    .unwrap();
    let meshes = [
        load(&common::shared_spec("suzanne.obj")),
        load(&common::shared_spec("spot.obj")),
        fandisk,
    ];
    let mut pending = 0;
    for mesh in &meshes {
        let plan = crate::StitchPlan::new(mesh, &mesh.adjacency(), 3).unwrap();
        for scheme in Scheme::all() {
            let opts = SchemeOptions::default();
            let table = PatchTable::build(mesh, scheme, &opts).unwrap();
            let builder = crate::patch::PatchBuilder::new(mesh, scheme, &opts).unwrap();
            let want_counts = validity::count(&table);
            for cpu in [
                CpuEvaluator::with_chunk_samples(37),
                CpuEvaluator::default(),
            ] {
                let mut want = StitchedMesh::<[f32; 3]>::default();
                stitch_into(&plan, &table, &cpu, &mut want, &NoProgress).unwrap();
                let mut got = StitchedMesh::<[f32; 3]>::default();
                let mut certifier = Certifier::new();
                let mut chunks = 0;
                let mut see = |_: usize, t: &PatchTable| {
                    chunks += 1;
                    certifier.see(t)
                };
                stitch_built(&plan, &builder, &cpu, &mut see, &mut got, &NoProgress).unwrap();
                let what = format!("{} {scheme}", mesh.name);
                // 37 samples: three patches of level 3 a chunk.
                let most = mesh.triangles.len().min(cpu.chunk_samples / 10);
                assert!(
                    chunks >= mesh.triangles.len() / most.max(1),
                    "{what}: {chunks}"
                );
                assert_eq!(got.positions, want.positions, "{what}");
                assert_eq!(got.normals, want.normals, "{what}");
                assert_eq!(got.triangles, want.triangles, "{what}");
                assert_eq!(got.record_position, want.record_position, "{what}");
                assert_eq!(certifier.finish(), want_counts, "{what}");
            }
            pending += want_counts.folded + want_counts.undecided;
        }
    }
    // The subdivisions decided some of them: Suzanne's G1 folds, fandisk's undecided patch.
    assert!(pending > 100, "{pending} folded or undecided patches");
}

/// A chunk whose patches cannot be built (a control point overflows) stops [`stitch_built`]
/// with the error `PatchTable::build` gives, naming the same triangle; no panic.
#[test]
fn built_chunks_stop_at_a_patch_that_cannot_be_built() {
    use crate::tess::stitch::stitch_built;
    let mut mesh = load(&common::shared_spec("spot.obj"));
    // A vertex far out: the boundary curves' tangent lengths overflow f64.
    let far = mesh.triangles[mesh.triangles.len() / 2][0] as usize;
    mesh.positions[far] *= 1e308;
    let Err(want) = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()) else {
        panic!("the table fails");
    };
    let want = want.to_string();
    assert!(want.contains("non-finite control point"), "{want}");
    let builder =
        crate::patch::PatchBuilder::new(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let plan = crate::StitchPlan::new(&mesh, &mesh.adjacency(), 2).unwrap();
    let mut sink = CountingSink::default();
    let got = stitch_built(
        &plan,
        &builder,
        &CpuEvaluator::with_chunk_samples(60),
        &mut |_, _| {},
        &mut sink,
        &NoProgress,
    )
    .expect_err("the evaluation fails")
    .to_string();
    assert_eq!(got, want);
}

/// Levels whose output cannot have 32-bit indices are refused with one error, before
/// anything of their size is made: at `u32::MAX` one patch's grid alone is out of range
/// (its edge tables would take 48 GiB), and at 92,681 (the first level whose grid has
/// 2^32 − 1 points or more) and 65,536 (the first whose n² triangles are) as well.
#[test]
fn absurd_levels_are_refused_not_allocated() {
    use crate::tess::stitch::StitchPlan;
    let mesh = common::load("sphere320");
    let adjacency = mesh.adjacency();
    assert!(grid_len(92_680) < u32::MAX as usize && grid_len(92_681) >= u32::MAX as usize);
    for level in [u32::MAX, 5_000_000, 92_681, 65_536] {
        let e = StitchPlan::new(&mesh, &adjacency, level)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!(
                "level {level} gives too many vertices for 32-bit indices"
            )),
            "{e}"
        );
    }
    // A level that fits plans as before.
    assert!(StitchPlan::new(&mesh, &adjacency, 64).is_ok());
}
