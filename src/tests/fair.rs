//! The fair G1 optimiser ([`crate::fair`]) against independent checks: the certificate's
//! verdicts and the continuity statistics of the table built from its mesh, the vertices
//! bit for bit, the crease edges counted by the statistics, the bending energy against the
//! fold repair's, and a discrete bending energy of the tessellated surface (welded by
//! position) that converges as the level rises on a surface without folds or kinks.

use std::collections::HashMap;

use glam::DVec3;

use super::common::load;
use crate::{
    check_table, continuity, fair, fairness, repair, singular_at_a_corner, stitch, CpuEvaluator,
    FairOptions, FairReport, FairnessOptions, LoadOptions, Mesh, PatchTable, RepairOptions, Scheme,
    SchemeOptions, Verdict,
};

/// Σ over the interior edges of the tessellated G1 surface of `mesh` at `level` (positions
/// welded, as the stitcher shares them) of 3 θ² |e|² / (A₁ + A₂), θ the angle between the
/// two triangles' normals, A their areas (the discrete shell bending energy of Grinspun et
/// al. 2003, whose sum approaches ∫ (κ₁² + κ₂²) dA on a smooth surface). Edges on crease
/// curves (their two triangles use different vertex records, the stitcher's split normals)
/// are left out: there the sum grows with the level without bound.
fn discrete_energy(mesh: &Mesh, level: u32) -> f64 {
    let table = PatchTable::build(mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let (out, _, _) = stitch(mesh, &table, &CpuEvaluator::default(), level).unwrap();
    let pos = |r: u32| out.positions[out.record_position[r as usize] as usize];
    // Per welded edge (position ids, lower first): the uses (triangle, records at the ends
    // in the edge's order).
    let mut uses: HashMap<[u32; 2], Vec<(usize, [u32; 2])>> = HashMap::new();
    for (t, tri) in out.triangles.iter().enumerate() {
        for k in 0..3 {
            let (ra, rb) = (tri[k], tri[(k + 1) % 3]);
            let (a, b) = (
                out.record_position[ra as usize],
                out.record_position[rb as usize],
            );
            let (key, recs) = if a < b {
                ([a, b], [ra, rb])
            } else {
                ([b, a], [rb, ra])
            };
            uses.entry(key).or_default().push((t, recs));
        }
    }
    let normal_area = |t: usize| {
        let [a, b, c] = out.triangles[t].map(pos);
        let n = (b - a).cross(c - a);
        (n.normalize(), 0.5 * n.length())
    };
    let mut sum = 0.0;
    for (key, u) in &uses {
        if u.len() != 2 || u[0].1 != u[1].1 {
            continue;
        }
        let ((n1, a1), (n2, a2)) = (normal_area(u[0].0), normal_area(u[1].0));
        let theta = n1.cross(n2).length().atan2(n1.dot(n2));
        let e = out.positions[key[0] as usize] - out.positions[key[1] as usize];
        sum += 3.0 * theta * theta * e.length_squared() / (a1 + a2);
    }
    sum
}

/// The tessellated G1 surface of `mesh` at `level`, welded by position: its positions and
/// triangles (position ids).
fn welded(mesh: &Mesh, level: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let table = PatchTable::build(mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let (out, _, _) = stitch(mesh, &table, &CpuEvaluator::default(), level).unwrap();
    let tris = (out.triangles.iter())
        .map(|t| t.map(|r| out.record_position[r as usize]))
        .collect();
    (out.positions.clone(), tris)
}

/// An estimate of ∫ (κ₁² + κ₂²) dA = ∫ 4H² dA − 2 ∫ K dA from the tessellated surface alone,
/// independent of the patches' derivatives and of the quadrature: ∫ 4H² dA as Σ |L x|² / Aᵢ
/// with L the cotangent Laplacian (Meyer et al. 2003: L x = 2 H n Aᵢ) and Aᵢ a third of the
/// areas around vertex i, and ∫ K dA as the sum of the angle defects 2π − Σ θ (exactly 2π χ on
/// a closed surface, by Gauss–Bonnet). Also returns that sum.
fn willmore_estimate(pos: &[DVec3], tris: &[[u32; 3]]) -> (f64, f64) {
    let n = pos.len();
    let (mut lx, mut area, mut angle) = (vec![DVec3::ZERO; n], vec![0.0; n], vec![0.0; n]);
    for t in tris {
        for k in 0..3 {
            let [i, j, l] = [t[k], t[(k + 1) % 3], t[(k + 2) % 3]].map(|v| v as usize);
            let (a, b) = (pos[j] - pos[i], pos[l] - pos[i]);
            let (c, d) = (a.cross(b).length(), a.dot(b));
            // The angle at i, and the cotangent weight of the opposite edge j–l.
            angle[i] += c.atan2(d);
            let w = 0.5 * d / c;
            lx[j] += w * (pos[l] - pos[j]);
            lx[l] += w * (pos[j] - pos[l]);
            area[i] += c / 6.0;
        }
    }
    let h2: f64 = (0..n)
        .filter(|&i| area[i] > 0.0)
        .map(|i| lx[i].length_squared() / area[i])
        .sum();
    let defect: f64 = (0..n)
        .filter(|&i| area[i] > 0.0)
        .map(|i| std::f64::consts::TAU - angle[i])
        .sum();
    (h2 - 2.0 * defect, defect)
}

/// The bending energy (adaptive, default rule) of the certified G1 patches of `mesh`.
fn exact_energy(mesh: &Mesh) -> f64 {
    let table = PatchTable::build(mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    fairness(mesh, &mesh.adjacency(), &table, &FairnessOptions::default())
        .unwrap()
        .energy
}

/// What every fair mesh must satisfy whatever the input: the vertices and triangles bit
/// for bit, G1 on every non-crease edge (1 − |cos| ≤ 1e-12, and 1 − min cos where nothing
/// folds: the rounding of the statistics' normals, measured ≤ 5e-16) and watertight (gap ≤ 1e-12 of the bounding box),
/// the same crease edges as the input, the report's verdicts the certificate's, and the
/// normals within the bound where it applies.
fn check_fair(mesh: &Mesh, faired: &Mesh, report: &FairReport) {
    assert_eq!(faired.positions, mesh.positions);
    assert_eq!(faired.triangles, mesh.triangles);
    let table = PatchTable::build(faired, Scheme::G1, &SchemeOptions::default()).unwrap();
    let c = continuity(
        faired,
        &faired.adjacency(),
        &table,
        &CpuEvaluator::default(),
    )
    .unwrap();
    let table0 = PatchTable::build(mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let c0 = continuity(mesh, &mesh.adjacency(), &table0, &CpuEvaluator::default()).unwrap();
    // A folded patch meets its neighbour at cos = -1 (the tangent plane shared, turned
    // over): the statistics' G1 measure is then 1 - |cos|.
    assert!(
        c.max_one_minus_abs_cos <= 1e-12,
        "{}",
        c.max_one_minus_abs_cos
    );
    if report.after.folded == 0 {
        assert!(1.0 - c.cos.min <= 1e-12, "{}", c.cos.min);
    }
    let (lo, hi) = mesh
        .positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    assert!(c.max_gap <= 1e-12 * (hi - lo).length(), "{}", c.max_gap);
    assert_eq!(c.crease_edges, c0.crease_edges);
    assert_eq!(report.creases_made, 0);
    let counts = check_table(&table)
        .iter()
        .fold(Default::default(), crate::PatchCounts::with);
    assert_eq!(counts, report.after);
    if let Some(b) = report.normal_bound_deg {
        // The bound is kept with a relative margin of 1e-9 (the clamp's), so the largest
        // change reaches it at most.
        assert!(report.max_normal_change_deg <= b, "{report:?}");
    }
}

/// Spot (estimated normals, all free): nothing folds before or after; two sweeps bring
/// the bending energy from 1028.5 to 614.5 (0.597 of it; six sweeps, the default, 0.578:
/// the repair leaves spot as it is, so the aim of half the repair's energy is not
/// met here, see `docs/fair.md`); the discrete energy at level 16 is within 15 % of level
/// 8's.
#[test]
fn fair_spot_keeps_g1_and_lowers_the_energy() {
    let mesh = load("spot.obj");
    let (faired, report) = fair(&mesh, &FairOptions::default().with_sweeps(2)).unwrap();
    check_fair(&mesh, &faired, &report);
    assert_eq!((report.after.folded, report.after.undecided), (0, 0));
    assert_eq!(report.normal_bound_deg, None);
    let before = exact_energy(&mesh);
    let after = exact_energy(&faired);
    // The report's figures are the fairness measure's (same rule, same patches).
    assert_eq!(report.energy_before.energy, before);
    assert_eq!(report.energy_after.energy, after);
    // Measured 0.597; 0.65 leaves room for other rounding of the trials only.
    assert!(after < 0.65 * before, "{before} -> {after}");
    assert_converged(discrete_energy(&faired, 8), discrete_energy(&faired, 16));
    // The exact energy against an estimate from the level-16 tessellation alone. Spot is
    // closed and of genus 0, so the angle defects sum to 4π (the welded tessellation is
    // watertight). The estimate approaches the energy from below as the level rises
    // (measured: 607.4 at level 16 against 614.5 here; after six sweeps 585.6 at level 8
    // and 590.0 at level 16 against 594.7), so 2 % holds its discretisation error at level
    // 16 with room.
    let (pos, tris) = welded(&faired, 16);
    let (estimate, defect) = willmore_estimate(&pos, &tris);
    assert!(
        (defect - 4.0 * std::f64::consts::PI).abs() < 1e-6,
        "{defect}"
    );
    assert!(
        (estimate / after - 1.0).abs() < 0.02,
        "{estimate} vs {after}"
    );
}

/// The test of a converged surface: the discrete energy at level 16 within 15 %
/// of level 8's (it diverges at folds and creases, and settles on a smooth surface).
fn assert_converged(d8: f64, d16: f64) {
    assert!(
        (d16 / d8 - 1.0).abs() < 0.15,
        "level 8 {d8}, level 16 {d16}"
    );
}

/// Fandisk with creases at 30° (normals estimated per smoothing group, all free): two
/// sweeps bring the energy to 0.652 of the repair's (72.136 with the crease the repair
/// makes; the aim, half, is not met), no crease is made, and the discrete energy
/// away from the creases converges (level 16 within 15 % of level 8). The input's one
/// undecided patch stays undecided: the crease-free start does not certify it (the
/// repair's fallback does, by making a crease), nor do the sweeps.
#[test]
fn fair_fandisk_lowers_the_energy_without_a_crease() {
    let opts = LoadOptions::default().with_crease_angle(Some(30.0));
    let mesh = Mesh::load(&super::common::shared_spec("fandisk.obj"), &opts).unwrap();
    let (faired, report) = fair(&mesh, &FairOptions::default().with_sweeps(2)).unwrap();
    check_fair(&mesh, &faired, &report);
    assert_eq!((report.after.folded, report.after.undecided), (0, 1));
    assert_eq!(report.singular_at_a_corner, 1);
    let (repaired, _) = repair(&mesh, Scheme::G1, &RepairOptions::default()).unwrap();
    let (after, repaired) = (exact_energy(&faired), exact_energy(&repaired));
    // Measured 0.652; 0.7 leaves room for other rounding of the trials only.
    assert!(after <= 0.7 * repaired, "{after} vs repair {repaired}");
    assert_converged(discrete_energy(&faired, 8), discrete_energy(&faired, 16));
}

/// Fandisk's one undecided patch (creases at 30°) is forced by the input's crease structure:
/// the triangle is the only one of its normal group at a vertex, and its two edges there
/// are creases against one other normal group. Both boundary curves then leave the vertex
/// along the line where the two tangent planes meet, so J is 0 at that corner
/// ([`singular_at_a_corner`]) whatever the two normals are: no fair or repair without a
/// new crease certifies it.
#[test]
fn fandisk_undecided_patch_is_forced_by_its_creases() {
    let opts = LoadOptions::default().with_crease_angle(Some(30.0));
    let mut mesh = Mesh::load(&super::common::shared_spec("fandisk.obj"), &opts).unwrap();
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let bad: Vec<usize> = (check_table(&table).iter().enumerate())
        .filter(|(_, v)| **v != Verdict::Valid)
        .map(|(i, _)| i)
        .collect();
    assert_eq!(bad.len(), 1);
    let t = bad[0];
    // The sine of the angle between the patch's two arms at corner k (Gregory layout: edge
    // k's boundary points from 4k, edge k + 2 ends at corner k). The crease curves' arms
    // are multiples of one unit vector, so they agree to rounding (measured 1.9e-14).
    let sine = |table: &PatchTable, k: usize| {
        let p = table.patch(t);
        let (a, b) = (p[4 * k + 1] - p[4 * k], p[4 * ((k + 2) % 3) + 3] - p[4 * k]);
        a.cross(b).length() / (a.length() * b.length())
    };
    let k = (0..3)
        .find(|&k| sine(&table, k) < 1e-12)
        .expect("parallel arms");
    assert!(singular_at_a_corner(&table, t));
    let tri = mesh.triangles[t];
    let (v, next, prev) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
    let own = mesh.corner_normals[t][k];
    // The normals at v of the triangles across the two edges at v.
    let across = |w: u32| -> Vec<DVec3> {
        (mesh.triangles.iter().enumerate())
            .filter(|&(u, o)| u != t && o.contains(&v) && o.contains(&w))
            .map(|(u, o)| mesh.corner_normals[u][o.iter().position(|&x| x == v).unwrap()])
            .collect()
    };
    let (a, b) = (across(next), across(prev));
    assert_eq!((a.len(), b.len()), (1, 1));
    assert_eq!(a[0], b[0]);
    assert_ne!(a[0], own);
    let other = a[0];
    // Every corner at v has one of the two normals, and only this triangle has its own.
    let at_v: Vec<(usize, usize)> = (mesh.triangles.iter().enumerate())
        .filter_map(|(u, o)| o.iter().position(|&x| x == v).map(|j| (u, j)))
        .collect();
    for &(u, j) in &at_v {
        let n = mesh.corner_normals[u][j];
        assert!(n == other || (u == t && n == own));
    }
    // Any other two normals near them: still parallel arms, still singular.
    for (da, db) in [(0.2, -0.1), (-0.15, 0.25), (0.05, 0.3)] {
        let (na, nb) = (
            (own + da * DVec3::X - db * DVec3::Z).normalize(),
            (other + db * DVec3::Y + da * DVec3::Z).normalize(),
        );
        for &(u, j) in &at_v {
            mesh.corner_normals[u][j] = if u == t { na } else { nb };
        }
        let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
        assert!(sine(&table, k) < 1e-12, "{}", sine(&table, k));
        assert!(singular_at_a_corner(&table, t));
    }
}

/// The fair report's verdicts, energy and singular patches, found a chunk at a time, are
/// those of the whole table (`check_table`, `total_certified`, `singular_at_a_corner`) bit
/// for bit: spot in chunks of 1,000 patches, and Suzanne (file normals, 76 folded
/// patches) in chunks of 64.
#[test]
fn the_fair_measure_in_chunks_is_the_whole_tables() {
    let exact = crate::BendingEnergy::new(Scheme::G1.kind(), &FairnessOptions::default()).unwrap();
    for (name, chunk) in [("spot.obj", 1000), ("suzanne.obj", 64)] {
        let mesh = load(name);
        let opts = SchemeOptions::default();
        let got = crate::analysis::fair::measure(&mesh, &opts, &exact, &crate::NoProgress, chunk)
            .unwrap();
        let table = PatchTable::build(&mesh, Scheme::G1, &opts).unwrap();
        let verdicts = check_table(&table);
        let counts = verdicts
            .iter()
            .fold(Default::default(), crate::PatchCounts::with);
        let total = exact.total_certified(&table, &verdicts).unwrap();
        let singular = (0..table.len())
            .filter(|&i| verdicts[i] != Verdict::Valid && singular_at_a_corner(&table, i))
            .count();
        assert_eq!(got.0, counts, "{name}");
        assert_eq!(got.1, total, "{name}");
        assert_eq!(got.2, singular, "{name}");
        assert!(mesh.triangles.len() > 3 * chunk, "{name}: several chunks");
    }
}

/// The fair surface is the same on one thread and on two: normals, arm factors and the
/// report (the built-in torus of 200 triangles with averaged normals, the default sweeps).
#[test]
fn fair_is_the_same_on_one_thread_and_on_two() {
    let mesh = load("torus200");
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| fair(&mesh, &FairOptions::default()).unwrap())
    };
    let (faired, report) = run(2);
    check_fair(&mesh, &faired, &report);
    assert!(
        report.normal_moves > 0 && report.arm_edges_scaled > 0,
        "{report:?}"
    );
    let (one, report1) = run(1);
    assert_eq!(one.corner_normals, faired.corner_normals);
    assert_eq!(one.attributes.arm_scales, faired.attributes.arm_scales);
    assert_eq!(report1, report);
}

/// A progress that records every phase and the units reported in it.
#[derive(Default)]
struct Phases(std::sync::Mutex<Vec<(String, u64, u64)>>);

impl crate::Progress for Phases {
    fn start(&self, phase: &str, total: u64) {
        self.0.lock().unwrap().push((phase.to_string(), total, 0));
    }
    fn inc(&self, n: u64) {
        if let Some(last) = self.0.lock().unwrap().last_mut() {
            last.2 += n;
        }
    }
}

/// `fair_with_progress` gives `fair`'s result and reports its phases with exact counts:
/// on the torus of 200 triangles (100 vertices, one normal group each; 300 interior
/// edges), the energy of 200 patches, the start, judging 200 patches, and each sweep over
/// 100 groups and 300 edges (with two sweeps, both run: the first gains more than 0.1 %),
/// then the energy again; every counted phase reports exactly its total.
#[test]
fn fair_reports_its_phases_with_exact_counts() {
    let mesh = load("torus200");
    let opts = FairOptions::default().with_sweeps(2);
    let phases = Phases::default();
    let (faired, report) = crate::fair_with_progress(&mesh, &opts, &phases).unwrap();
    let (plain, plain_report) = fair(&mesh, &opts).unwrap();
    assert_eq!(faired.corner_normals, plain.corner_normals);
    assert_eq!(report, plain_report);
    let got = phases.0.into_inner().unwrap();
    let want = [
        ("fair: energy", 200, 200),
        ("fair: start", 0, 0),
        ("fair: judging", 200, 200),
        ("fair: sweep 1/2", 400, 400),
        ("fair: sweep 2/2", 400, 400),
        ("fair: energy", 200, 200),
    ];
    let want: Vec<(String, u64, u64)> = want
        .iter()
        .map(|&(p, t, n)| (p.to_string(), t, n))
        .collect();
    assert_eq!(report.sweeps, 2);
    assert_eq!(got, want);
}

/// Suzanne with its file normals, bounded to 15°: the input forces creases at 3 groups
/// (doubled triangles) and no G1 repair can move its normals less than 27.1°, so some
/// patches stay uncertified (six sweeps: 76 folded before, 42 after, energy of the others
/// 6.05e4 -> 1.41e4); the bound holds, no crease is made and no patch certified at the
/// start is lost.
#[test]
fn fair_suzanne_keeps_the_bound() {
    let mesh = load("suzanne.obj");
    // One sweep: what is checked here does not depend on how far the energy falls.
    let opts = FairOptions::default().with_sweeps(1);
    let (faired, report) = fair(&mesh, &opts).unwrap();
    check_fair(&mesh, &faired, &report);
    assert_eq!(report.normal_bound_deg, Some(15.0));
    assert_eq!(report.crease_forced_groups, 3);
    assert!((report.normal_change_lower_bound_deg - 27.107).abs() < 1e-3);
    // Every patch the start certified stays certified: what is left is what the start
    // left (the search's verdict is stricter than the certificate's).
    let table = PatchTable::build(&faired, Scheme::G1, &SchemeOptions::default()).unwrap();
    let valid = check_table(&table)
        .iter()
        .filter(|v| **v == Verdict::Valid)
        .count();
    assert!(valid + report.start_uncertified >= mesh.triangles.len());
}

/// The figures of `docs/fair.md`: the report, the fold repair's energy for comparison, and
/// the discrete energy of the input, repaired and fair surfaces at levels 4, 8 and 16, of
/// the 200-triangle torus, or of the mesh in `FAIR_MESH` (`FAIR_MESH=path [FAIR_CREASE=deg]
/// cargo test --release --lib fair_figures -- --nocapture`). On the torus, whose every patch
/// stays certified, the fair surface's discrete energy converges (level 16 within 15 % of
/// level 8, as on spot) and the report's energy is the exact energy's; a mesh of one's own
/// is printed only (one with folds left diverges).
#[test]
fn fair_figures() {
    let own = std::env::var("FAIR_MESH").ok();
    let path = own.clone().unwrap_or_else(|| "torus200".into());
    let crease = std::env::var("FAIR_CREASE")
        .ok()
        .map(|s| s.parse().unwrap());
    let mesh = Mesh::load(&path, &LoadOptions::default().with_crease_angle(crease)).unwrap();
    let t = std::time::Instant::now();
    let (faired, report) = fair(&mesh, &FairOptions::default()).unwrap();
    let time = t.elapsed().as_secs_f64();
    println!("{}", report.to_text(&mesh.name));
    println!("{}", serde_json::to_string(&report).unwrap());
    println!("fair: {time:.2} s");
    let (repaired, r) = repair(&mesh, Scheme::G1, &RepairOptions::default()).unwrap();
    println!(
        "repair: energy {:.6e}, {} creases made, largest normal change {:.2}°",
        exact_energy(&repaired),
        r.edges_made_creases,
        r.max_normal_change_deg
    );
    let mut fair_levels = Vec::new();
    for level in [4, 8, 16] {
        fair_levels.push(discrete_energy(&faired, level));
        println!(
            "discrete energy level {level}: input {:.6e} repair {:.6e} fair {:.6e}",
            discrete_energy(&mesh, level),
            discrete_energy(&repaired, level),
            fair_levels[fair_levels.len() - 1]
        );
    }
    if own.is_none() {
        assert_eq!((report.after.folded, report.after.undecided), (0, 0));
        assert_eq!(report.energy_after.energy, exact_energy(&faired));
        assert!(report.energy_after.energy < report.energy_before.energy);
        assert_converged(fair_levels[1], fair_levels[2]);
    }
}
