//! Properties every scheme must have, checked against independent expectations: central
//! finite differences for the derivatives, the input points (and normals, where the scheme
//! interpolates them) at the corners, watertight shared edges, and the identities between
//! schemes that `SCHEMES.md` states.

use crate::tests::common;

use crate::analysis::distance::{distance, Surface};
use crate::analysis::stats::{EdgeStats, CHUNK_EDGES, SAMPLES_PER_EDGE};
use crate::eval::{PatchPoint, PAIR_COS_TOLERANCE};
use crate::mesh::generators;
use crate::patch::{PatchBuilder, SCHEMES};
use crate::CpuEvaluator;
use crate::{continuity, Continuity};
use crate::{Evaluator, Pattern};
use crate::{LoadOptions, Mesh};
use crate::{PatchKind, PatchTable, Scheme, SchemeOptions};
use common::Rng;
use glam::DVec3;

/// Meshes for the checks: exact, analytic and averaged normals, estimated normals on an
/// organic and a CAD mesh (sharp creases).
fn meshes() -> Vec<Mesh> {
    let mut out = vec![
        generators::icosphere(2),
        generators::from_spec("torus:7x9:analytic")
            .unwrap()
            .unwrap(),
        generators::from_spec("torus200").unwrap().unwrap(),
    ];
    for f in ["spot.obj", "fandisk.obj"] {
        out.push(Mesh::load(&common::shared_spec(f), &LoadOptions::default()).unwrap());
    }
    out
}

fn table(mesh: &Mesh, scheme: Scheme) -> PatchTable {
    PatchTable::build(mesh, scheme, &SchemeOptions::default()).unwrap()
}

#[test]
fn every_scheme_is_named_on_the_command_line() {
    let names: Vec<&str> = Scheme::all().iter().map(|s| s.name()).collect();
    assert_eq!(
        names,
        [
            "g1",
            "phong",
            "nagata",
            "nagata-guarded",
            "nlsa",
            "pn",
            "pn-normals",
            "flat"
        ]
    );
    for s in Scheme::all() {
        assert_eq!(Scheme::parse(s.name()).unwrap(), s);
        #[cfg(feature = "cli")]
        assert_eq!(
            <Scheme as clap::ValueEnum>::from_str(s.name(), false).unwrap(),
            s
        );
    }
    assert!(Scheme::parse("bogus").is_err());
}

#[test]
fn patch_kinds_are_the_specified_ones() {
    let m = generators::icosphere(0);
    let kinds = [
        (Scheme::G1, PatchKind::Gregory),
        (Scheme::Phong, PatchKind::Bezier(2)),
        (Scheme::Nagata, PatchKind::Bezier(2)),
        (Scheme::NagataGuarded, PatchKind::Bezier(2)),
        (Scheme::Nlsa, PatchKind::Bezier(2)),
        (Scheme::Pn, PatchKind::Bezier(3)),
        (Scheme::PnNormals, PatchKind::PnNormals),
        (Scheme::Flat, PatchKind::Bezier(1)),
    ];
    for (s, k) in kinds {
        let t = table(&m, s);
        assert_eq!(t.kind, k, "{s}");
        assert_eq!(t.points.len(), k.stride() * m.triangles.len(), "{s}");
    }
}

/// ∂S/∂s and ∂S/∂t against central differences of the position, at random interior points
/// of random patches.
#[test]
fn derivatives_match_central_differences() {
    let h = 1e-5;
    for mesh in meshes() {
        for scheme in Scheme::all() {
            let t = table(&mesh, scheme);
            let mut rng = Rng(0x9E37_79B9_7F4A_7C15 ^ t.len() as u64);
            let mut worst = 0.0f64;
            for _ in 0..200 {
                let i = (rng.f64() * t.len() as f64) as usize;
                let b = rng.interior_b(2e-3);
                let at = |ds: f64, dt: f64| t.eval(i, [b[0] - ds - dt, b[1] + ds, b[2] + dt]).p;
                let sp = t.eval(i, b);
                let fs = (at(h, 0.0) - at(-h, 0.0)) / (2.0 * h);
                let ft = (at(0.0, h) - at(0.0, -h)) / (2.0 * h);
                let scale = sp.ds.length().max(sp.dt.length()).max(1e-300);
                worst = worst
                    .max((fs - sp.ds).length() / scale)
                    .max((ft - sp.dt).length() / scale);
            }
            // Central differences with h = 1e-5 err by O(h²) ≈ 1e-10 relative (times the
            // third derivative) plus rounding O(ε/h) ≈ 1e-11; 1e-7 leaves room for the
            // strongly curved patches of the coarse meshes.
            assert!(
                worst < 1e-7,
                "{} {scheme}: derivative vs finite difference, relative error {worst:e}",
                mesh.name
            );
        }
    }
}

/// Every scheme passes through its triangle's corners. G1 and PN (both normals) reproduce
/// the corner normals exactly; Nagata's corner tangents are orthogonal to the corner normal
/// (its defining property), so its tangent plane is the input's, but its orientation is not
/// guaranteed: the tangents dx − c are not orthogonal projections of the edges and can swap
/// order (on the coarse 7 × 9 torus some corners come out with −N_i: the ξ = 0 patch folds).
#[test]
fn corners_interpolate_points_and_normals() {
    for mesh in meshes() {
        let scale = mesh.diagonal();
        for scheme in Scheme::all() {
            let t = table(&mesh, scheme);
            let exact = matches!(scheme, Scheme::G1 | Scheme::Pn | Scheme::PnNormals);
            // Where Nagata took a fallback (a vanishing denominator, or a guarded straight
            // edge) that edge is not orthogonal to the normals.
            let plane =
                matches!(scheme, Scheme::Nagata | Scheme::NagataGuarded) && t.fallbacks == 0;
            let (mut gap, mut ncos, mut nabs) = (0.0f64, 0.0f64, 0.0f64);
            for (i, tri) in mesh.triangles.iter().enumerate() {
                for k in 0..3 {
                    let mut b = [0.0; 3];
                    b[k] = 1.0;
                    let sp = t.eval(i, b);
                    gap = gap.max((sp.p - mesh.positions[tri[k] as usize]).length());
                    let c = sp.n.dot(mesh.corner_normals[i][k]);
                    ncos = ncos.max(1.0 - c);
                    nabs = nabs.max(1.0 - c.abs());
                }
            }
            // The corner is a sum of weights 1 and 0 times control points: exact up to a
            // few roundings of coordinates of size ≤ the diagonal.
            assert!(
                gap <= 1e-14 * scale,
                "{} {scheme}: corner off by {gap:e}",
                mesh.name
            );
            // Normals from a cross product of tangents, normalised: 1 − cos of a few
            // roundings is ~1e-16; 1e-12 allows tangents of very different lengths.
            if exact {
                assert!(
                    ncos < 1e-12,
                    "{} {scheme}: corner normal differs from the input, 1 - cos = {ncos:e}",
                    mesh.name
                );
            }
            if plane {
                assert!(
                    nabs < 1e-12,
                    "{} {scheme}: corner tangent plane differs from the input, 1 - |cos| = {nabs:e}",
                    mesh.name
                );
            }
        }
    }
}

/// The two patches of every interior edge meet: position gap ≤ 1e-12 × diagonal.
#[test]
fn shared_edges_are_watertight() {
    let ev = CpuEvaluator::default();
    for mesh in meshes() {
        let adj = mesh.adjacency();
        for scheme in Scheme::all() {
            let t = table(&mesh, scheme);
            let c = continuity(&mesh, &adj, &t, &ev).unwrap();
            assert_eq!(c.samples, SAMPLES_PER_EDGE as usize * adj.interior);
            // Both patches evaluate the same boundary curve, built bitwise the same; their
            // blends differ in rounding only (a few ε times the coordinates).
            assert!(
                c.max_gap <= 1e-12 * mesh.diagonal(),
                "{} {scheme}: gap {:e} (diagonal {})",
                mesh.name,
                c.max_gap,
                mesh.diagonal()
            );
        }
    }
}

/// Positions of two tables at random points of every patch.
fn max_position_difference(a: &PatchTable, b: &PatchTable) -> f64 {
    let mut rng = Rng(42);
    let mut worst = 0.0f64;
    for i in 0..a.len() {
        for _ in 0..5 {
            let p = rng.interior_b(0.0);
            worst = worst.max((a.eval(i, p).p - b.eval(i, p).p).length());
        }
    }
    worst
}

#[test]
fn nlsa_is_phong_at_one_half_and_phong_at_zero_is_flat() {
    let mesh = generators::from_spec("torus200").unwrap().unwrap();
    let half = PatchTable::build(
        &mesh,
        Scheme::Phong,
        &SchemeOptions::default().with_phong_alpha(0.5),
    )
    .unwrap();
    let zero = PatchTable::build(
        &mesh,
        Scheme::Phong,
        &SchemeOptions::default().with_phong_alpha(0.0),
    )
    .unwrap();
    // Same control points up to the rounding of differently ordered formulas (ε times
    // coordinates below 1.5).
    assert!(max_position_difference(&table(&mesh, Scheme::Nlsa), &half) < 1e-15);
    assert!(max_position_difference(&table(&mesh, Scheme::Flat), &zero) < 1e-15);
    // α changes the surface: 3/4 differs from 1/2 (by far more than any rounding).
    assert!(max_position_difference(&table(&mesh, Scheme::Phong), &half) > 1e-3);
}

/// Phong tessellation by its definition S = (1 − α) p + α Σ b_i π_i(p), evaluated directly.
#[test]
fn phong_matches_its_projection_definition() {
    let mesh = generators::from_spec("torus:6x5:averaged")
        .unwrap()
        .unwrap();
    let alpha = 0.75;
    let t = table(&mesh, Scheme::Phong);
    let mut rng = Rng(7);
    for (i, tri) in mesh.triangles.iter().enumerate() {
        let q = tri.map(|v| mesh.positions[v as usize]);
        let n = mesh.corner_normals[i];
        let b = rng.interior_b(0.0);
        let p: DVec3 = (0..3).map(|k| b[k] * q[k]).sum();
        let proj: DVec3 = (0..3)
            .map(|k| b[k] * (p - (p - q[k]).dot(n[k]) * n[k]))
            .sum();
        let expect = (1.0 - alpha) * p + alpha * proj;
        // Two exact formulas for the same point: a few roundings of coordinates ≤ 1.5.
        assert!((t.eval(i, b).p - expect).length() < 1e-14);
    }
}

/// Nagata's edge curve is orthogonal to both end normals (the defining property), and on a
/// circle of the sphere it bulges outwards.
#[test]
fn nagata_edges_are_orthogonal_to_the_end_normals() {
    let mesh = generators::icosphere(1);
    let t = table(&mesh, Scheme::Nagata);
    for (i, _) in mesh.triangles.iter().enumerate() {
        let n = mesh.corner_normals[i];
        for k in 0..3 {
            let (a, b) = (k, (k + 1) % 3);
            // Tangent of edge a→b at a: derivative of S(b_a = 1 − u, b_b = u) at u = 0.
            let mut ba = [0.0; 3];
            ba[a] = 1.0;
            let sp = t.eval(i, ba);
            // Homogeneous derivatives up to a common term: ∂S/∂b0 := 0, ∂S/∂b1 = S_s,
            // ∂S/∂b2 = S_t.
            let d = |m: usize| match m {
                0 => DVec3::ZERO,
                1 => sp.ds,
                _ => sp.dt,
            };
            let tangent = d(b) - d(a);
            // Orthogonal by construction; the cosine is a few roundings of unit vectors.
            assert!(tangent.normalize().dot(n[a]).abs() < 1e-13);
        }
    }
}

/// The guard of `nagata-guarded` fires exactly on the two rings of nearly parallel normals
/// (top and bottom of the tube) of an 8 × 8 torus with averaged normals, where ξ = 0 folds
/// the surface, and nowhere on the sphere.
#[test]
fn nagata_guard_fires_only_where_xi_zero_folds() {
    let ev = CpuEvaluator::default();
    let sphere = generators::icosphere(2);
    let a = table(&sphere, Scheme::Nagata);
    let b = table(&sphere, Scheme::NagataGuarded);
    assert_eq!(b.fallbacks, 0);
    assert_eq!(a.points, b.points);

    let torus = generators::from_spec("torus:8x8:averaged")
        .unwrap()
        .unwrap();
    let adj = torus.adjacency();
    let bare = table(&torus, Scheme::Nagata);
    let guarded = table(&torus, Scheme::NagataGuarded);
    // 2 rings × 8 edges × 2 triangles per edge.
    assert_eq!(guarded.fallbacks, 32);
    let cb = continuity(&torus, &adj, &bare, &ev).unwrap();
    let cg = continuity(&torus, &adj, &guarded, &ev).unwrap();
    assert!(cb.folded > 0, "xi = 0 should fold here: {cb:?}");
    assert_eq!(cg.folded, 0, "{cg:?}");
    // The straightened edges keep a kink (the normals are not those of a straight edge),
    // but the surface comes back to the torus: far closer than the folded one, and closer
    // than the flat triangles.
    let surface = Surface::Torus { big_r: 1.0, r: 0.5 };
    let d = |t: &PatchTable| distance(t, &surface, 16, &ev).unwrap().mean;
    let (db, dg, df) = (d(&bare), d(&guarded), d(&table(&torus, Scheme::Flat)));
    // Not a tolerance: the guard must bring the surface at least 3× closer than both.
    assert!(
        dg < db / 3.0 && dg < df / 3.0,
        "bare {db:e} guarded {dg:e} flat {df:e}"
    );
}

/// PN's quadratic normal field: the corner normals at the corners, continuous across edges
/// (it is built from edge data only), and not the geometry's normal.
#[test]
fn pn_normal_field_is_continuous_and_labelled_apart() {
    let ev = CpuEvaluator::default();
    let mesh = generators::from_spec("torus200").unwrap().unwrap();
    let adj = mesh.adjacency();
    let field = table(&mesh, Scheme::PnNormals);
    let exact = table(&mesh, Scheme::Pn);
    let cf = continuity(&mesh, &adj, &field, &ev).unwrap();
    let ce = continuity(&mesh, &adj, &exact, &ev).unwrap();
    // The field's edge coefficients are built bitwise the same on both sides, so both
    // normals are one value up to the rounding of the blend; the exact normal of the cubic
    // differs across edges by the paper's 1e-3 order (Table 1's PN row on torus200).
    assert!(1.0 - cf.cos.min < 1e-12, "{cf:?}");
    assert!(1.0 - ce.cos.min > 1e-3, "{ce:?}");
    // Same geometry.
    assert!(max_position_difference(&field, &exact) == 0.0);
    // Mid-edge: the field is the normalised mix of the corners and the edge coefficient,
    // and for a sphere with exact normals that is the normalised chord midpoint direction.
    let sphere = generators::icosphere(1);
    let t = table(&sphere, Scheme::PnNormals);
    for (i, tri) in sphere.triangles.iter().enumerate() {
        let q = tri.map(|v| sphere.positions[v as usize]);
        let n = t.eval(i, [0.5, 0.5, 0.0]).n;
        let expect = (q[0] + q[1]).normalize();
        // Two normalisations of the same direction: 1 − cos of a few roundings.
        assert!(1.0 - n.dot(expect) < 1e-14);
    }
}

#[test]
fn bad_phong_alpha_is_an_error_not_a_nan() {
    let mesh = generators::icosphere(0);
    let e = PatchTable::build(
        &mesh,
        Scheme::Phong,
        &SchemeOptions::default().with_phong_alpha(f64::NAN),
    );
    let msg = e.unwrap_err().to_string();
    assert!(msg.contains("phong") && msg.contains("finite"), "{msg}");
}

/// The registry is the one source of each scheme's name and kind: clap's and serde's
/// spellings agree with it, and tables get its kind.
#[test]
fn registry_names_and_kinds_are_the_ones_used_everywhere() {
    assert_eq!(SCHEMES.len(), Scheme::all().len());
    #[cfg(feature = "cli")]
    assert_eq!(
        <Scheme as clap::ValueEnum>::value_variants().len(),
        SCHEMES.len()
    );
    let mesh = generators::icosphere(0);
    for (i, info) in SCHEMES.iter().enumerate() {
        assert_eq!(info.scheme, Scheme::all()[i]);
        assert_eq!(info.scheme.info().name, info.name);
        assert_eq!(
            serde_json::to_string(&info.scheme).unwrap(),
            format!("\"{}\"", info.name)
        );
        #[cfg(feature = "cli")]
        assert_eq!(
            <Scheme as clap::ValueEnum>::to_possible_value(&info.scheme)
                .unwrap()
                .get_name(),
            info.name
        );
        assert_eq!(table(&mesh, info.scheme).kind, info.kind);
        assert_eq!(info.scheme.kind(), info.kind);
    }
}

/// A table built for any subset of the triangles holds bitwise the patches of the whole
/// table, and counts fallbacks only for the triangles it is told to.
#[test]
fn tables_of_subsets_are_slices_of_the_whole() {
    let mesh = generators::from_spec("torus:8x8:averaged")
        .unwrap()
        .unwrap();
    for scheme in Scheme::all() {
        let builder = PatchBuilder::new(&mesh, scheme, &SchemeOptions::default()).unwrap();
        let whole = builder.table().unwrap();
        let pick: Vec<u32> = (0..mesh.triangles.len() as u32).rev().step_by(3).collect();
        let part = builder.table_of(&pick, pick.len()).unwrap();
        for (i, &t) in pick.iter().enumerate() {
            assert_eq!(part.patch(i), whole.patch(t as usize), "{scheme}");
            assert_eq!(part.flat_normals[i], whole.flat_normals[t as usize]);
        }
        let all: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
        assert_eq!(
            builder.fallbacks_of(&all) + builder.prepared_fallbacks(),
            whole.fallbacks
        );
        assert_eq!(builder.table_of(&pick, 0).unwrap().fallbacks, 0);
    }
}

/// Streamed statistics do not depend on how the edges are chunked nor on how the evaluator
/// chunks its output: chunks of 1, 7 and many edges, evaluator chunks of 1, 7 and many
/// points and the whole table at once give bitwise the same numbers (the samples are
/// folded in blocks numbered over the whole run); the edge points evaluated as an explicit
/// point list give the same but for cos, within its stated tolerance. The mesh has crease
/// edges (fandisk at 30°), so both kinds of edge are folded.
#[test]
fn streamed_stats_do_not_depend_on_chunking() {
    let mesh = Mesh::load(
        &common::shared_spec("fandisk.obj"),
        &LoadOptions::default().with_crease_angle(Some(30.0)),
    )
    .unwrap();
    let adj = mesh.adjacency();
    for scheme in [Scheme::G1, Scheme::PnNormals, Scheme::NagataGuarded] {
        let whole = table(&mesh, scheme);
        let reference: Continuity =
            continuity(&mesh, &adj, &whole, &CpuEvaluator::default()).unwrap();
        assert!(reference.crease_edges > 0 && reference.samples > 0);
        assert_eq!(
            reference.samples + reference.crease_samples,
            SAMPLES_PER_EDGE as usize * adj.interior
        );
        let builder = PatchBuilder::new(&mesh, scheme, &SchemeOptions::default()).unwrap();
        let mut stats = EdgeStats::new(&mesh);
        for (edges, points) in [
            (1, 7),
            (7, 1),
            (7, 1 << 20),
            (CHUNK_EDGES, 7),
            (1 << 30, 1 << 20),
        ] {
            stats.chunk_edges = edges;
            let ev = CpuEvaluator::with_chunk_samples(points);
            let (c, fallbacks) = stats.continuity(&builder, &ev).unwrap();
            assert_eq!(
                c, reference,
                "{scheme}: {edges} edges, {points} points a chunk"
            );
            assert_eq!(fallbacks, whole.fallbacks, "{scheme}");
        }
        // Through `Evaluator::evaluate_edges`'s default (the edge points expanded and
        // evaluated as a point list, what the GPU backend runs): bitwise the same too.
        stats.chunk_edges = CHUNK_EDGES;
        let (c, _) = stats
            .continuity(&builder, &ViaPoints(CpuEvaluator::with_chunk_samples(7)))
            .unwrap();
        // Bitwise but for cos: the CPU's edge kernel takes each cos from the unnormalised
        // cross products, the point list from the unit normals, within τ =
        // PAIR_COS_TOLERANCE of each other (`PairProducts`). So min, max and 1 − |cos|
        // move by at most τ; the mean by at most τ and the std by at most τ·sqrt(n/(n − 1))
        // (each value moved by at most τ), plus the summation's own roundings of values
        // this close (a few u, inside a second τ).
        let tau = PAIR_COS_TOLERANCE;
        let near = |a: f64, b: f64, bound: f64| (a - b).abs() <= bound;
        assert!(
            near(c.cos.min, reference.cos.min, tau)
                && near(c.cos.max, reference.cos.max, tau)
                && near(
                    c.max_one_minus_abs_cos,
                    reference.max_one_minus_abs_cos,
                    tau
                )
                && near(c.cos.mean, reference.cos.mean, 2.0 * tau)
                && near(c.cos.std, reference.cos.std, 2.0 * tau),
            "{scheme}: through the point list: {:?} against {:?}",
            c.cos,
            reference.cos
        );
        let exact = Continuity {
            cos: reference.cos,
            max_one_minus_abs_cos: reference.max_one_minus_abs_cos,
            ..c
        };
        assert_eq!(exact, reference, "{scheme}: through the point list");
    }
}

/// An evaluator with only `evaluate` (`evaluate_edges` is the trait's default).
struct ViaPoints(CpuEvaluator);

impl Evaluator for ViaPoints {
    fn describe(&self) -> String {
        "cpu through points".into()
    }
    fn evaluate(
        &self,
        table: &PatchTable,
        pattern: &Pattern,
        sink: &mut dyn FnMut(crate::Chunk<'_>) -> crate::Result<()>,
    ) -> crate::Result<()> {
        self.0.evaluate(table, pattern, sink)
    }
}

/// Counts on closed tori, computed independently: an n × m torus has n m vertices, 2 n m
/// triangles and, by Euler's formula V − E + F = 0, E = 3 n m edges, all interior (closed
/// surface); 21 samples on each.
#[test]
fn torus_counts_are_exact() {
    for (n, m) in [(3, 3), (4, 7), (9, 5), (16, 16)] {
        let mesh = generators::from_spec(&format!("torus:{n}x{m}"))
            .unwrap()
            .unwrap();
        assert_eq!(mesh.positions.len(), n * m);
        assert_eq!(mesh.triangles.len(), 2 * n * m);
        let stats = EdgeStats::new(&mesh);
        let counts = stats.counts();
        assert_eq!(counts.interior, 3 * n * m, "{n}x{m}");
        assert_eq!(counts.boundary + counts.nonmanifold + counts.misoriented, 0);
        let r = stats
            .report(
                Scheme::G1,
                &SchemeOptions::default(),
                &CpuEvaluator::default(),
            )
            .unwrap();
        assert_eq!(r.samples, 21 * 3 * n * m, "{n}x{m}");
        assert_eq!(r.crease_edges, 0);
        assert_eq!(r.interior_edges, 3 * n * m);
    }
}

/// Evaluation at explicit points (the CPU backend memoises the basis per distinct point and
/// skips the control points whose weights vanish) is bitwise `PatchTable::eval`: at the
/// corners, at the statistics' edge points and at random interior points, repeated so
/// that the memo serves them.
#[test]
fn point_evaluation_is_bitwise_the_reference() {
    let mut rng = Rng(0xC0FFEE);
    for mesh in [
        generators::from_spec("torus:7x9:averaged")
            .unwrap()
            .unwrap(),
        Mesh::load(&common::shared_spec("spot.obj"), &LoadOptions::default()).unwrap(),
    ] {
        for scheme in Scheme::all() {
            let t = table(&mesh, scheme);
            let mut points = Vec::new();
            for round in 0..3 {
                for i in 0..t.len().min(300) {
                    for k in 0..3 {
                        for q in [0.0, 0.05, 0.5, 0.95, 1.0] {
                            let mut b = [0.0; 3];
                            b[k] = 1.0 - q;
                            b[(k + 1) % 3] = q;
                            points.push(PatchPoint { patch: i as u32, b });
                        }
                    }
                    if round == 0 {
                        points.push(PatchPoint {
                            patch: i as u32,
                            b: rng.interior_b(0.0),
                        });
                    }
                }
            }
            let (pos, nrm) = CpuEvaluator::default()
                .evaluate_all(&t, &Pattern::Points(points.clone()))
                .unwrap();
            for (pp, (p, n)) in points.iter().zip(pos.iter().zip(&nrm)) {
                let r = t.eval(pp.patch as usize, pp.b);
                let bits = |v: DVec3| v.to_array().map(f64::to_bits);
                assert_eq!(bits(*p), bits(r.p), "{scheme} {pp:?}");
                assert_eq!(bits(*n), bits(r.n), "{scheme} {pp:?}");
            }
        }
    }
}
