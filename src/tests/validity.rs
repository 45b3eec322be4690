//! The validity certificate of `patch::validity` and the fold repair of `patch::repair`.

use crate::tests::common;

use crate::mesh::generators::icosphere;
use crate::patch::repair::{repair_line, RepairOptions};
use crate::patch::validity::{
    check_patch, count, jacobian, PatchCounts, Verdict, QUICK_BLEND_BOUND,
};
use crate::CpuEvaluator;
use crate::{continuity, stats_report, Continuity};
use crate::{repair, RepairReport};
use crate::{LoadOptions, Mesh};
use crate::{PatchKind, PatchTable, Scheme, SchemeOptions};
use glam::DVec3;

/// A quadratic Bézier triangle in the plane z = 0 over the corners (0,0), (1,0), (0,1),
/// with the control point of the edge from corner 0 to corner 1 at (c, 0): the edge's
/// parametrisation x(s) = 2c s(1 − s) + s² turns back (x'(1) = 2(1 − c) < 0) when c > 1.
fn quadratic(c: f64) -> PatchTable {
    let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
    // bezier_powers(2) order: (2,0,0) (1,1,0) (1,0,1) (0,2,0) (0,1,1) (0,0,2).
    PatchTable {
        scheme: Scheme::Phong,
        kind: PatchKind::Bezier(2),
        stride: 6,
        points: vec![
            p(0.0, 0.0),
            p(c, 0.0),
            p(0.0, 0.5),
            p(1.0, 0.0),
            p(0.5, 0.5),
            p(0.0, 1.0),
        ],
        flat_normals: vec![DVec3::Z],
        fallbacks: 0,
    }
}

/// J by central differences of the evaluated positions (independent of the evaluator's
/// derivatives).
fn fd_jacobian(table: &PatchTable, b: [f64; 3]) -> f64 {
    let h = 1e-6;
    let at = |s: f64, t: f64| table.eval(0, [1.0 - s - t, s, t]).p;
    let (s, t) = (b[1], b[2]);
    // One-sided where the point is on the domain's boundary.
    let (s0, s1) = if s >= h { (s - h, s) } else { (s, s + h) };
    let (t0, t1) = if t >= h { (t - h, t) } else { (t, t + h) };
    let ds = (at(s1, t) - at(s0, t)) / h;
    let dt = (at(s, t1) - at(s, t0)) / h;
    ds.cross(dt).dot(DVec3::Z)
}

#[test]
fn a_constructed_fold_is_found_with_its_witness() {
    let table = quadratic(1.2);
    let v = check_patch(&table, 0);
    let Verdict::Folded { s, t, jacobian: j } = v else {
        panic!("expected a fold, got {v:?}");
    };
    let b = [1.0 - s - t, s, t];
    assert!(j < 0.0);
    // The witness holds by an independent measure: finite differences of positions
    // (error O(h) = 1e-6 on derivatives of order 1).
    let fd = fd_jacobian(&table, b);
    assert!(fd < 0.0 && (fd - j).abs() < 1e-5, "fd {fd} vs {j} at {b:?}");
    assert_eq!(count(&table).folded, 1);
    // Analytically J(s, 0) = x_s y_t with y_t = 1 on that edge and
    // x_s = 2c(1 − 2s) + 2s: negative for s > c/(2c − 1) = 0.857.
    let (j1, _) = jacobian(&table, 0, [0.0, 1.0, 0.0]);
    assert!((j1 - 2.0 * (1.0 - 1.2)).abs() < 1e-12, "J at (1,0) = {j1}");
}

#[test]
fn a_patch_close_to_folding_is_never_called_folded() {
    for c in [0.9, 0.99, 0.999, 0.999_999] {
        let table = quadratic(c);
        // J at (1, 0) is 2(1 − c) > 0: valid, by a margin down to 2e-6.
        let v = check_patch(&table, 0);
        assert!(
            matches!(v, Verdict::Valid | Verdict::Undecided),
            "c = {c}: {v:?}"
        );
    }
    // With a comfortable margin the certificate proves it.
    assert_eq!(check_patch(&quadratic(0.9), 0), Verdict::Valid);
    assert_eq!(check_patch(&quadratic(0.5), 0), Verdict::Valid);
}

/// One triangle with given corner normals (unit after loading).
fn triangle(normals: [[f64; 3]; 3]) -> Mesh {
    let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    Mesh::from_soup(
        "one",
        &p.map(DVec3::from),
        &[[0, 1, 2]],
        Some(&normals.map(DVec3::from)),
        &LoadOptions::default(),
    )
    .unwrap()
}

#[test]
fn g1_folds_where_a_normal_faces_away_and_is_valid_when_flat() {
    let flat = triangle([[0.0, 0.0, 1.0]; 3]);
    let t = PatchTable::build(&flat, Scheme::G1, &SchemeOptions::default()).unwrap();
    assert_eq!(check_patch(&t, 0), Verdict::Valid);
    // Corner 0's normal leans past the triangle's plane: its tangent plane is seen from
    // behind, so J < 0 at that corner.
    let bad = triangle([[-0.3, -0.3, -0.2], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]);
    let t = PatchTable::build(&bad, Scheme::G1, &SchemeOptions::default()).unwrap();
    let v = check_patch(&t, 0);
    let Verdict::Folded {
        s,
        t: tt,
        jacobian: j,
    } = v
    else {
        panic!("expected a fold, got {v:?}");
    };
    let (again, _) = jacobian(&t, 0, [1.0 - s - tt, s, tt]);
    assert_eq!(again, j);
    assert!(j < 0.0);
}

#[test]
fn built_in_and_spot_patches_are_all_certified() {
    for spec in ["sphere320", "torus200", "icosphere:2"] {
        let mesh = common::load(spec);
        for s in Scheme::all() {
            let t = PatchTable::build(&mesh, s, &SchemeOptions::default()).unwrap();
            // Every patch of these smooth meshes is valid (exact count: deterministic).
            assert_eq!(
                count(&t),
                PatchCounts {
                    valid: mesh.triangles.len(),
                    folded: 0,
                    undecided: 0
                },
                "{spec} {s}"
            );
        }
    }
    let spot = common::load("spot.obj");
    let t = PatchTable::build(&spot, Scheme::G1, &SchemeOptions::default()).unwrap();
    assert_eq!(count(&t).valid, 5856);
}

#[test]
fn the_quick_blend_bound_holds_over_the_domain() {
    // ρ = 12 x² y z (φ − 1/2), φ = y/(y + z), for corner m (x, y, z = b_m, b_{m+1}, b_{m+2}),
    // differentiated along s (b1 − b0) and t (b2 − b0) by central differences on a grid of
    // the open domain; the derivation gives a largest value of 6 · 4/27 ≈ 0.889.
    let rho = |m: usize, b: [f64; 3]| {
        let (x, y, z) = (b[m], b[(m + 1) % 3], b[(m + 2) % 3]);
        12.0 * x * x * y * z * (y / (y + z) - 0.5)
    };
    let h = 1e-6;
    let n = 300;
    let mut largest = 0.0f64;
    for i in 1..n {
        for j in 1..n - i {
            let b = [
                1.0 - (i + j) as f64 / n as f64,
                i as f64 / n as f64,
                j as f64 / n as f64,
            ];
            for m in 0..3 {
                for dir in [[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]] {
                    let at = |e: f64| std::array::from_fn(|k| b[k] + e * dir[k]);
                    let d = (rho(m, at(h)) - rho(m, at(-h))) / (2.0 * h);
                    largest = largest.max(d.abs());
                }
            }
        }
    }
    // Central differences are exact to O(h²) ≈ 1e-12 here; the supremum 0.889 is reached
    // on the edge y = 0 (x = 2/3), which this open grid only approaches (0.837 at n = 300):
    // the bound is not vacuous.
    assert!(largest <= QUICK_BLEND_BOUND, "{largest}");
    assert!(largest > 0.8, "{largest}");
}

#[test]
fn bunny_verdicts_are_counted_exactly() {
    // The bunny's G1 patches: almost all certified by the quick whole-domain test, the
    // rest by subdivision; the 7 folds come with witnesses (deterministic counts).
    let bunny = common::load("stanford-bunny.obj");
    let t = PatchTable::build(&bunny, Scheme::G1, &SchemeOptions::default()).unwrap();
    let verdicts = crate::patch::validity::check_table(&t);
    let folded: Vec<_> = verdicts
        .iter()
        .enumerate()
        .filter_map(|(i, v)| match v {
            Verdict::Folded {
                s,
                t: tt,
                jacobian: j,
            } => Some((i, *s, *tt, *j)),
            _ => None,
        })
        .collect();
    assert_eq!(folded.len(), 7);
    assert_eq!(
        verdicts
            .iter()
            .filter(|v| **v == Verdict::Undecided)
            .count(),
        0
    );
    for (i, s, tt, j) in folded {
        // Each witness is a fold by the patch's own evaluation (b_0 = 1 − s − t rounds
        // apart from the witness's own b_0, hence the relative 1e-9).
        let (again, scale) = jacobian(&t, i, [1.0 - s - tt, s, tt]);
        assert!((again - j).abs() <= 1e-9 * j.abs(), "{again} vs {j}");
        assert!(again < -1e-12 * scale);
    }
}

#[test]
fn suzanne_verdicts_are_decided_by_the_deeper_subdivision() {
    // Suzanne's G1 patches (deterministic counts): 8 that the first subdivision budget
    // leaves undecided are decided by the second, deeper one (all certified); the 76
    // folds come with witnesses.
    let suzanne = common::load("suzanne.obj");
    let t = PatchTable::build(&suzanne, Scheme::G1, &SchemeOptions::default()).unwrap();
    assert_eq!(
        count(&t),
        PatchCounts {
            valid: 892,
            folded: 76,
            undecided: 0
        }
    );
}

#[test]
fn suzanne_repair_certifies_every_patch() {
    // The repair's outcome on Suzanne (deterministic): 76 folded before, every patch
    // certified after. The doubled triangle (a fin: the same three vertices in both
    // orders, whose vertices need a crease) is split off the surface first, flat, its
    // edge on the surface straight in every use. The crease-free phase (moves, then joint
    // moves of the normals within one ring of the patches it leaves) leaves 5 patches
    // uncertified, none at the fin, each folding near a corner whose fan nearly fills a
    // hemisphere; the arm step certifies all 5 (and the patches across their edges) by
    // scaling the tangent lengths of 8 of their edges' curves, so no fallback runs: no
    // triangle flattened, and the only creases are the fin's own 2 edges (between its two
    // sides), which are forced.
    let suzanne = common::load("suzanne.obj");
    let opts = SchemeOptions::default();
    let (fixed, r) = repair(&suzanne, Scheme::G1, &RepairOptions::default()).unwrap();
    assert_eq!(
        (
            r.before.folded,
            r.before.undecided,
            r.after.folded,
            r.after.undecided
        ),
        (76, 0, 0, 0),
        "{r:?}"
    );
    assert_eq!(
        (
            r.vertices_touched,
            r.triangles_flattened,
            r.edges_made_creases
        ),
        (91, 0, 2),
        "{r:?}"
    );
    assert_eq!(r.arm_edges_scaled, 8, "{r:?}");
    // The factors found (3 decimals: the figures quoted in the documentation).
    assert!(
        (r.arm_scale_range[0] - 0.535).abs() < 1e-3 && (r.arm_scale_range[1] - 2.117).abs() < 1e-3,
        "{r:?}"
    );
    scaled_arms_are_shared(&fixed, r.arm_edges_scaled, r.arm_scale_range);
    assert_eq!(r.crease_free_left, vec![304, 307, 856, 859, 863], "{r:?}");
    assert_eq!(r.crease_free_left_forced, 0, "{r:?}");
    // The bound and the forced creases, recomputed here from the input mesh: the doubled
    // triangle's three vertices (70, 135, 136) are the only ones whose faces fit in no
    // open hemisphere.
    let (bound, forced) = corner_facts(&suzanne, &fixed);
    assert_eq!(forced, vec![70, 135, 136]);
    assert_eq!(r.crease_forced_groups, 3);
    // 1e-9°: the two computations round differently (atan2 of the same vectors).
    assert!(
        (r.normal_change_lower_bound_deg - bound).abs() < 1e-9,
        "{r:?} {bound}"
    );
    assert!((bound - 27.107).abs() < 1e-3, "{bound}");
    assert!(r.max_normal_change_deg >= bound);
    // The largest normal change, measured here from the two meshes' corner normals.
    let largest = fixed
        .corner_normals
        .iter()
        .flatten()
        .zip(suzanne.corner_normals.iter().flatten())
        .map(|(a, b)| a.cross(*b).length().atan2(a.dot(*b)).to_degrees())
        .fold(0.0, f64::max);
    assert_eq!(largest, r.max_normal_change_deg);
    // The whole mesh's builder (not the search's one-triangle builds) certifies every
    // patch again.
    let (table, _) = repaired_is_g1_and_watertight(&suzanne, &fixed, &r, opts);
    assert_eq!(count(&table).valid, suzanne.triangles.len());
    // The fin's edge on the surface (its only edge with more than two uses) gives the
    // same points in all four of its uses (the statistics measure two-use edges only).
    assert_eq!(nonmanifold_edges(&fixed), (1, 4), "one edge of four uses");
    let gap = nonmanifold_gap_value(&fixed, &table);
    // 1e-12 of the diagonal: rounding of the coordinates (about 3e-15 here).
    assert!(gap <= 1e-12 * fixed.diagonal(), "gap {gap}");
}

/// The number of edges of `mesh` with more than two uses, and their largest number of uses.
fn nonmanifold_edges(mesh: &Mesh) -> (usize, usize) {
    let uses = edge_uses(mesh);
    let many: Vec<usize> = uses.values().map(Vec::len).filter(|&n| n > 2).collect();
    (many.len(), many.into_iter().max().unwrap_or(0))
}

/// The largest distance between the points of two uses of an edge with more than two
/// uses, at 21 points along it (each use's patch evaluated on the edge, from its lower
/// vertex to its higher one).
fn nonmanifold_gap_value(mesh: &Mesh, table: &PatchTable) -> f64 {
    let mut gap = 0.0f64;
    for ((a, b), list) in edge_uses(mesh).into_iter().filter(|(_, l)| l.len() > 2) {
        let at = |t: usize, u: f64| {
            let tri = mesh.triangles[t];
            let mut bc = [0.0; 3];
            bc[tri.iter().position(|&v| v == a).unwrap()] = 1.0 - u;
            bc[tri.iter().position(|&v| v == b).unwrap()] = u;
            table.eval(t, bc).p
        };
        for i in 0..=20 {
            let u = i as f64 / 20.0;
            let p = at(list[0] / 3, u);
            for &h in &list[1..] {
                gap = gap.max((at(h / 3, u) - p).length());
            }
        }
    }
    gap
}

/// The half-edges 3 t + k (corner k to corner k + 1 of triangle t) using each edge (lower
/// vertex, higher vertex), in increasing order.
fn edge_uses(mesh: &Mesh) -> std::collections::BTreeMap<(u32, u32), Vec<usize>> {
    let mut uses = std::collections::BTreeMap::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            uses.entry((a.min(b), a.max(b)))
                .or_insert_with(Vec::new)
                .push(3 * t + k);
        }
    }
    uses
}

/// The lower bound of a G1-keeping repair's largest normal change (degrees), computed
/// plainly from `mesh`'s corner normals and face normals (the mesh has no crease edge):
/// the largest angle beyond 90° between a corner's normal and its triangle's face normal;
/// and the vertices whose corners' face normals fit in no open hemisphere, found as the
/// vertices with two exactly opposite face normals (cosine −1 to 1e-12), after checking
/// that every other vertex has a direction facing all of its faces (its input normal, a
/// normal of the repaired mesh `fixed` there, the normalised sum of its face normals, one
/// of them, or one of 20,000 directions spread evenly over the sphere).
fn corner_facts(mesh: &Mesh, fixed: &Mesh) -> (f64, Vec<u32>) {
    let face = |t: usize| {
        let p = mesh.triangles[t].map(|v| mesh.positions[v as usize]);
        (p[1] - p[0]).cross(p[2] - p[0]).normalize()
    };
    let mut bound = 0.0f64;
    let mut faces_at: Vec<Vec<DVec3>> = vec![Vec::new(); mesh.positions.len()];
    let mut normals_at: Vec<Vec<DVec3>> = vec![Vec::new(); mesh.positions.len()];
    for t in 0..mesh.triangles.len() {
        let f = face(t);
        for k in 0..3 {
            let n = mesh.corner_normals[t][k];
            bound = bound.max(n.angle_between(f).to_degrees() - 90.0);
            let v = mesh.triangles[t][k] as usize;
            faces_at[v].push(f);
            normals_at[v].extend([n, fixed.corner_normals[t][k]]);
        }
    }
    // A Fibonacci lattice on the sphere.
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let spread: Vec<DVec3> = (0..20_000)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 20_000.0;
            let r = (1.0 - z * z).sqrt();
            let a = golden * i as f64;
            DVec3::new(r * a.cos(), r * a.sin(), z)
        })
        .collect();
    let mut forced = Vec::new();
    for (v, fs) in faces_at.iter().enumerate() {
        if fs.is_empty() {
            continue;
        }
        let opposite = fs
            .iter()
            .any(|a| fs.iter().any(|b| a.dot(*b) < -1.0 + 1e-12));
        let mut tries = normals_at[v].clone();
        tries.push(fs.iter().copied().sum::<DVec3>().normalize_or_zero());
        tries.extend(fs.iter().copied());
        tries.extend(spread.iter().copied());
        let faced = tries.iter().any(|n| fs.iter().all(|f| f.dot(*n) > 0.0));
        assert!(opposite != faced, "vertex {v}: {opposite} {faced}");
        if opposite {
            forced.push(v as u32);
        }
    }
    (bound, forced)
}

/// Each edge whose arms `mesh` scales (`edges` of them, factors within `range`) has
/// bitwise one boundary curve in both of its patches (watertight), and that curve's end
/// tangents are the plain Walton–Meek tangents of the edge (rebuilt here from the end
/// points and normals, formula of the construction) times the factors: same direction
/// (in the tangent planes, so G1 is kept), lengths scaled.
fn scaled_arms_are_shared(mesh: &Mesh, edges: usize, range: [f64; 2]) {
    let table = PatchTable::build(mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let scales = mesh.attributes.arm_scales.as_ref().expect("arm factors");
    let uses = edge_uses(mesh);
    let wm = |qa: DVec3, na: DVec3, qb: DVec3, nb: DVec3| {
        // Walton–Meek (1996) Theorem 2.1: the first arm V1 − V0.
        let e = qb - qa;
        let (d, g) = (e.length(), e.normalize());
        let (a0, a1, a) = (na.dot(g), nb.dot(g), na.dot(nb));
        let zeta = 6.0 * (2.0 * a0 + a * a1) / (4.0 - a * a);
        let theta = 6.0 * (2.0 * a1 + a * a0) / (4.0 - a * a);
        d * (6.0 * g - 2.0 * zeta * na + theta * nb) / 18.0
    };
    let mut seen = 0;
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for (&(a, b), list) in &uses {
        let s: Vec<[f64; 2]> = list.iter().map(|&h| scales[h / 3][h % 3]).collect();
        if s.iter().all(|s| *s == [1.0, 1.0]) {
            continue;
        }
        seen += 1;
        assert_eq!(list.len(), 2, "edge {a}-{b}");
        // The quartic boundary points L0..L4 of each use, run from a to b.
        let curve = |h: usize| -> Vec<DVec3> {
            let (t, k) = (h / 3, h % 3);
            let p = &table.points[18 * t..18 * t + 12];
            let mut l: Vec<DVec3> = p[4 * k..4 * k + 4].to_vec();
            l.push(p[4 * ((k + 1) % 3)]);
            if mesh.triangles[t][k] == a {
                l
            } else {
                l.into_iter().rev().collect()
            }
        };
        let (c0, c1) = (curve(list[0]), curve(list[1]));
        assert_eq!(c0, c1, "edge {a}-{b}: the two uses differ");
        // Back to the cubic: L1 = (V0 + 3 V1)/4, L3 = (3 V2 + V3)/4.
        let v1 = (4.0 * c0[1] - c0[0]) / 3.0;
        let v2 = (4.0 * c0[3] - c0[4]) / 3.0;
        let normal = |v: u32| {
            let t = list[0] / 3;
            let j = (0..3).find(|&j| mesh.triangles[t][j] == v).unwrap();
            mesh.corner_normals[t][j]
        };
        let (qa, qb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
        let arms = [
            (v1 - c0[0], wm(qa, normal(a), qb, normal(b))),
            (v2 - c0[4], wm(qb, normal(b), qa, normal(a))),
        ];
        for (arm, plain) in arms {
            let f = arm.length() / plain.length();
            // 1e-9: rounding of the degree elevation and its inverse on these short arms.
            assert!(
                arm.normalize().dot(plain.normalize()) > 1.0 - 1e-9,
                "edge {a}-{b}"
            );
            lo = lo.min(f);
            hi = hi.max(f);
        }
    }
    assert_eq!(seen, edges);
    // 1e-9: as above.
    assert!(
        (lo - range[0]).abs() < 1e-9 && (hi - range[1]).abs() < 1e-9,
        "{lo} {hi} {range:?}"
    );
}

/// The table of the repaired mesh `fixed` (of `input`, repaired with report `r`), after
/// checking that the report's changed patches cover every patch that differs from the
/// input's ([`changed_patches_are_reported`]), and its continuity: on every smooth edge
/// the tangent plane is shared to rounding and no sample's normal turns over (cos < 0);
/// every edge, crease edges included, is watertight to rounding of the coordinates.
fn repaired_is_g1_and_watertight(
    input: &Mesh,
    fixed: &Mesh,
    r: &RepairReport,
    opts: SchemeOptions,
) -> (PatchTable, Continuity) {
    let table = PatchTable::build(fixed, Scheme::G1, &opts).unwrap();
    changed_patches_are_reported(input, &table, r, opts);
    let c = continuity(fixed, &fixed.adjacency(), &table, &CpuEvaluator::default()).unwrap();
    assert_eq!(c.folded, 0);
    // 1e-12: the bound for G1 (rounding gives about 5e-16).
    assert!(1.0 - c.cos.min <= 1e-12, "1 - min cos {}", 1.0 - c.cos.min);
    // 1e-12 of the diagonal: rounding of the coordinates (about 1e-15 here).
    assert!(c.max_gap <= 1e-12 * fixed.diagonal(), "gap {}", c.max_gap);
    assert!(
        c.crease_max_gap <= 1e-12 * fixed.diagonal(),
        "crease gap {}",
        c.crease_max_gap
    );
    (table, c)
}

/// The patches of `table` (of the repaired mesh) that differ from `input`'s, bit for bit,
/// are at most the report's `patches_changed`: the search's one-triangle builds (crease
/// curves included) give the whole mesh's patches, and its list of changed patches, from
/// which the report's `after` verdicts and `max_distance` come, misses none. The whole
/// table's verdicts are the report's `after`.
fn changed_patches_are_reported(
    input: &Mesh,
    table: &PatchTable,
    r: &RepairReport,
    opts: SchemeOptions,
) {
    let plain = PatchTable::build(input, table.scheme, &opts).unwrap();
    let differ = (0..table.len())
        .filter(|&i| plain.patch(i) != table.patch(i))
        .count();
    assert!(differ > 0 && differ <= r.patches_changed, "{differ} {r:?}");
    assert_eq!(count(table), r.after);
}

#[test]
fn repair_leaves_a_valid_mesh_bit_for_bit() {
    let mesh = common::load("torus200");
    let plain = SchemeOptions::default();
    for s in [Scheme::G1, Scheme::Pn, Scheme::Phong] {
        let a = PatchTable::build(&mesh, s, &plain).unwrap();
        let (m, r) = repair(&mesh, s, &RepairOptions::default()).unwrap();
        let b = PatchTable::build(&m, s, &plain).unwrap();
        assert_eq!(a.points, b.points, "{s}");
        assert_eq!(m.corner_normals, mesh.corner_normals);
        assert!(m.attributes.arm_scales.is_none());
        assert_eq!(r.before, count(&a));
        assert_eq!(r.after, r.before);
        assert_eq!(r.vertices_touched, 0);
        assert_eq!(r.max_distance, 0.0);
    }
}

#[test]
fn repair_fixes_a_tilted_normal_and_keeps_g1_and_watertight() {
    let mut mesh = icosphere(2);
    // Tilt the normal of vertex 0 by about 100° at every corner that uses it.
    let v0 = mesh.positions[0];
    let tilted = (-(v0.normalize()) + 0.8 * v0.any_orthonormal_vector()).normalize();
    for (tri, normals) in mesh.triangles.iter().zip(mesh.corner_normals.iter_mut()) {
        for (v, n) in tri.iter().zip(normals.iter_mut()) {
            if *v == 0 {
                *n = tilted;
            }
        }
    }
    let opts = SchemeOptions::default();
    let before = count(&PatchTable::build(&mesh, Scheme::G1, &opts).unwrap());
    assert!(before.folded > 0, "{before:?}");
    let (fixed, r) = repair(&mesh, Scheme::G1, &RepairOptions::default()).unwrap();
    assert_eq!(r.before, before);
    assert_eq!(r.after.folded + r.after.undecided, 0, "{r:?}");
    assert_eq!(r.vertices_touched, 1);
    // The input normal makes up to 150.75° with the five faces' normals, so a repair
    // that keeps G1 changes it by at least 60.75° (recomputed here from the two meshes).
    // The crease-free phase gives it the nearest normal facing them by a cosine of 0.05
    // and then moves it further while that lowers the measure: 71.33° (deterministic; to
    // 1e-3° for the printed digits).
    let (bound, forced) = corner_facts(&mesh, &fixed);
    assert!(forced.is_empty());
    // 1e-9°: the two computations round differently (atan2 of the same vectors).
    assert!(
        (r.normal_change_lower_bound_deg - bound).abs() < 1e-9,
        "{r:?}"
    );
    assert!((bound - 60.752).abs() < 1e-3, "{bound}");
    assert!((r.max_normal_change_deg - 71.329).abs() < 1e-3, "{r:?}");
    assert_eq!(r.edges_made_creases, 0);
    assert!(
        r.max_distance > 0.0 && r.max_distance < mesh.diagonal(),
        "{r:?}"
    );
    let (table, _) = repaired_is_g1_and_watertight(&mesh, &fixed, &r, opts);
    assert_eq!(count(&table).valid, fixed.triangles.len());
    // The repair keeps nothing between calls: a second call searches afresh and finds
    // bit for bit the same normals and report.
    let (again, r2) = repair(&mesh, Scheme::G1, &RepairOptions::default()).unwrap();
    assert_eq!(again.corner_normals, fixed.corner_normals);
    assert_eq!(r2, r);
}

#[test]
fn bunny_repair_counts_are_exact_and_make_the_repair_line() {
    // The repair's outcome on the bunny (deterministic): 7 folded before, none folded or
    // undecided after, by the crease-free phase alone: no edge becomes a crease, so G1
    // holds on every edge; 11 vertices move. Two input triangles turn away from every
    // other triangle at each of their corners (among them a sliver of aspect 0.007); their
    // vertices get normals facing every triangle around them.
    let bunny = common::load("stanford-bunny.obj");
    let opts = SchemeOptions::default();
    let (fixed, r) = repair(&bunny, Scheme::G1, &RepairOptions::default()).unwrap();
    assert_eq!(
        (
            r.before.folded,
            r.before.undecided,
            r.after.folded,
            r.after.undecided
        ),
        (7, 0, 0, 0),
        "{r:?}"
    );
    assert_eq!(r.vertices_touched, 11);
    assert_eq!(
        (
            r.slivers_isolated,
            r.groups_split,
            r.edges_made_creases,
            r.triangles_flattened
        ),
        (0, 0, 0, 0),
        "{r:?}"
    );
    assert!(r.crease_free_left.is_empty(), "{r:?}");
    assert_eq!(r.left_on_flipped_triangles, 0);
    // The lower bound of any repair that keeps G1, recomputed here from the input: 38.3°
    // (a corner whose input normal makes 128.3° with its face normal); no crease forced.
    let (bound, forced) = corner_facts(&bunny, &fixed);
    assert!(forced.is_empty(), "{forced:?}");
    assert_eq!(r.crease_forced_groups, 0);
    // 1e-9°: the two computations round differently (atan2 of the same vectors).
    assert!(
        (r.normal_change_lower_bound_deg - bound).abs() < 1e-9,
        "{r:?} {bound}"
    );
    assert!((bound - 38.305).abs() < 1e-3, "{bound}");
    // The largest change, measured here from the two meshes' corner normals: above the
    // bound, as it must be.
    let largest = fixed
        .corner_normals
        .iter()
        .flatten()
        .zip(bunny.corner_normals.iter().flatten())
        .map(|(a, b)| a.cross(*b).length().atan2(a.dot(*b)).to_degrees())
        .fold(0.0, f64::max);
    assert_eq!(largest, r.max_normal_change_deg);
    assert!(largest >= bound, "{r:?}");
    // 47.109° (deterministic; to 1e-3° for the printed digits): 8.8° above the bound, at
    // a close corner of the sliver.
    assert!((largest - 47.109).abs() < 1e-3, "{r:?}");
    let (table, c) = repaired_is_g1_and_watertight(&bunny, &fixed, &r, opts);
    // No crease: G1 across every edge (1 − min cos checked above).
    assert_eq!(c.crease_edges, 0);
    assert_eq!(count(&table), r.after);
    // The line the commands print: the report, not a warning (nothing is left folded or
    // undecided), with the figures above.
    let line = repair_line("stanford-bunny.obj", &table, Some(&r)).unwrap();
    assert_eq!(line, r.to_text("stanford-bunny.obj", Scheme::G1));
    assert!(
        line.starts_with(
            "stanford-bunny.obj: g1 fold repair: 7 folded and 0 undecided patches before, 0 \
             folded and 0 undecided after; 11 vertices touched"
        ),
        "{line}"
    );
    assert!(line.contains("largest normal change 47.109°"), "{line}");
    // Without a report, the line counts the input's folded patches.
    let input = PatchTable::build(&bunny, Scheme::G1, &opts).unwrap();
    let folds = repair_line("stanford-bunny.obj", &input, None).unwrap();
    assert!(
        folds.starts_with("warning: stanford-bunny.obj: 7 of 69451 g1 patches are folded"),
        "{folds}"
    );
    // Fandisk (sharp features, crease normals): every G1 patch certified, nothing to
    // repair.
    let fandisk = common::load("fandisk.obj");
    let t = PatchTable::build(&fandisk, Scheme::G1, &opts).unwrap();
    assert_eq!(count(&t).valid, fandisk.triangles.len());
    assert_eq!(fandisk.triangles.len(), 12946);
}

#[test]
fn repair_next_to_a_crease_keeps_both_sides_of_the_crease_curve() {
    // Fandisk with creases above 40°: tilt one normal group of a crease vertex by about 100°;
    // the patches across the crease share the crease curve built from both groups'
    // normals, so the repair must rebuild them too, or the option's table would crack.
    let mut mesh = Mesh::load(
        &common::shared_spec("fandisk.obj"),
        &LoadOptions::default().with_crease_angle(Some(40.0)),
    )
    .unwrap();
    let key = |n: DVec3| n.to_array().map(f64::to_bits);
    let mut normals_at: std::collections::HashMap<u32, Vec<[u64; 3]>> = Default::default();
    for (tri, ns) in mesh.triangles.iter().zip(&mesh.corner_normals) {
        for (v, n) in tri.iter().zip(ns) {
            let e = normals_at.entry(*v).or_default();
            if !e.contains(&key(*n)) {
                e.push(key(*n));
            }
        }
    }
    let v = (0..mesh.positions.len() as u32)
        .find(|v| normals_at.get(v).is_some_and(|k| k.len() == 2))
        .unwrap();
    let target = normals_at[&v][0];
    let mut old = DVec3::ZERO;
    for (tri, ns) in mesh.triangles.iter().zip(mesh.corner_normals.iter_mut()) {
        for (w, n) in tri.iter().zip(ns.iter_mut()) {
            if *w == v && key(*n) == target {
                old = *n;
                *n = (-*n + 0.8 * n.any_orthonormal_vector()).normalize();
            }
        }
    }
    assert!(old != DVec3::ZERO);
    let opts = SchemeOptions::default();
    let before = count(&PatchTable::build(&mesh, Scheme::G1, &opts).unwrap());
    assert!(before.folded > 0, "{before:?}");
    let (fixed, r) = repair(&mesh, Scheme::G1, &RepairOptions::default()).unwrap();
    assert!(r.after.folded < before.folded, "{r:?}");
    let table = PatchTable::build(&fixed, Scheme::G1, &opts).unwrap();
    // The patches across the crease changed too, and the report counts them.
    changed_patches_are_reported(&mesh, &table, &r, opts);
    let c = continuity(&fixed, &fixed.adjacency(), &table, &CpuEvaluator::default()).unwrap();
    assert!(c.max_gap <= 1e-12 * fixed.diagonal(), "gap {}", c.max_gap);
    assert_eq!(count(&table), r.after);
}

#[test]
fn stats_report_counts_patches_and_prints_null_without_interior_edges() {
    let mesh = triangle([[0.0, 0.0, 1.0]; 3]);
    let r = stats_report(
        &mesh,
        Scheme::G1,
        &SchemeOptions::default(),
        &CpuEvaluator::default(),
    )
    .unwrap();
    let json: serde_json::Value = serde_json::to_value(&r).unwrap();
    assert!(json["cos"].is_null(), "{json}");
    assert!(json["max_gap"].is_null());
    assert!(json["max_one_minus_abs_cos"].is_null());
    assert_eq!(json["patches"]["valid"], 1);
    assert_eq!(json["patches"]["folded"], 0);
    assert!(r.to_text().contains("no interior edges"), "{}", r.to_text());
    let ico = common::load("icosphere:1");
    let r = stats_report(
        &ico,
        Scheme::Pn,
        &SchemeOptions::default(),
        &CpuEvaluator::default(),
    )
    .unwrap();
    let json: serde_json::Value = serde_json::to_value(&r).unwrap();
    assert!(json["cos"]["min"].as_f64().unwrap() > 0.9);
    assert_eq!(json["patches"]["valid"], 80);
}

#[test]
fn scaled_arms_keep_g1_and_watertight() {
    // Arm factors on one edge of an icosphere (mesh.attributes.arm_scales): both uses get
    // one curve, with the factors of the first use (the lower half-edge, triangle 0's)
    // whatever the other use says; the tangent plane stays shared along every edge and no
    // sample turns over; the patches off that edge are unchanged bit for bit.
    let plain = icosphere(1);
    let n = plain.triangles.len();
    let [a, b, _] = plain.triangles[0];
    let other = (1..n)
        .flat_map(|t| (0..3).map(move |k| (t, k)))
        .find(|&(t, k)| {
            let u = plain.triangles[t];
            u[k] == b && u[(k + 1) % 3] == a
        })
        .unwrap();
    let mut scales = vec![[[1.0; 2]; 3]; n];
    scales[0][0] = [2.0, 0.5];
    scales[other.0][other.1] = [3.0, 3.0];
    let mut mesh = plain.clone();
    mesh.attributes.arm_scales = Some(scales);
    let opts = SchemeOptions::default();
    let t0 = PatchTable::build(&plain, Scheme::G1, &opts).unwrap();
    let t1 = PatchTable::build(&mesh, Scheme::G1, &opts).unwrap();
    for t in 0..n {
        if t == 0 || t == other.0 {
            assert_ne!(t0.patch(t), t1.patch(t), "{t}");
        } else {
            assert_eq!(t0.patch(t), t1.patch(t), "{t}");
        }
    }
    // Edge 0 of triangle 0 (from a to b): its cubic's arms (L1 = (V0 + 3 V1)/4 and
    // L3 = (3 V2 + V3)/4 of the degree-elevated curve) are the plain ones times 2 and 0.5,
    // in the same directions.
    let arms = |p: &[DVec3]| {
        let (v0, v3) = (p[0], p[4]);
        [(4.0 * p[1] - v0) / 3.0 - v0, (4.0 * p[3] - v3) / 3.0 - v3]
    };
    let (p0, p1) = (t0.patch(0), t1.patch(0));
    let (plain_arms, scaled) = (arms(&p0[0..5]), arms(&p1[0..5]));
    for (i, f) in [2.0, 0.5].into_iter().enumerate() {
        // 1e-12: rounding of the degree elevation and its inverse.
        assert!(
            (scaled[i] - f * plain_arms[i]).length() <= 1e-12 * plain_arms[i].length(),
            "arm {i}: {:?} vs {:?}",
            scaled[i],
            plain_arms[i]
        );
    }
    let c = continuity(&mesh, &mesh.adjacency(), &t1, &CpuEvaluator::default()).unwrap();
    assert_eq!(c.folded, 0);
    // 1e-12: the bound for G1 (rounding gives about 5e-16).
    assert!(1.0 - c.cos.min <= 1e-12, "1 - min cos {}", 1.0 - c.cos.min);
    // Watertight: one curve in both uses (rounding of the evaluation only).
    assert!(c.max_gap <= 1e-12 * mesh.diagonal(), "gap {}", c.max_gap);
}

/// The verdicts found a chunk at a time (`check_in_chunks`, as the repair's start and the
/// fair's energy find them) are `check_table`'s of the whole table, fold witnesses included:
/// Suzanne's G1 patches (76 folded) and PN patches in chunks of 64, fandisk's G1 patches
/// (creases at 30°, one undecided) in chunks of 1,000. Each chunk is seen once, in order.
#[test]
fn verdicts_in_chunks_are_the_whole_tables() {
    let cases = [
        ("suzanne.obj", None, Scheme::G1, 64),
        ("suzanne.obj", None, Scheme::Pn, 64),
        ("fandisk.obj", Some(30.0), Scheme::G1, 1000),
    ];
    for (name, crease, scheme, chunk) in cases {
        let opts = LoadOptions::default().with_crease_angle(crease);
        let mesh = Mesh::load(&common::shared_spec(name), &opts).unwrap();
        let builder =
            crate::patch::PatchBuilder::new(&mesh, scheme, &SchemeOptions::default()).unwrap();
        let mut starts = Vec::new();
        let (got, _) = crate::patch::validity::check_in_chunks(&builder, chunk, |t, start, v| {
            assert_eq!(t.len(), v.len());
            starts.push(start);
            Ok(())
        })
        .unwrap();
        let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default()).unwrap();
        assert_eq!(got, crate::check_table(&table), "{name} {scheme}");
        let n = mesh.triangles.len();
        assert_eq!(starts, (0..n).step_by(chunk).collect::<Vec<_>>(), "{name}");
    }
}
