//! The statistics certify each patch where they first build it: the validity counts of a
//! streamed `stats` run are exactly those of certifying every patch of the builder
//! (`validity::count_builder`), whatever the chunking, including triangles that no interior
//! edge reaches.

use crate::tests::common;

use crate::analysis::stats::{EdgeStats, CHUNK_EDGES};
use crate::patch::validity::count_builder;
use crate::patch::PatchBuilder;
use crate::stats_report;
use crate::CpuEvaluator;
use crate::{LoadOptions, Mesh};
use crate::{Scheme, SchemeOptions};

#[test]
fn streamed_certificate_counts_every_patch_once() {
    let mesh = common::load("stanford-bunny.obj");
    let builder = PatchBuilder::new(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let expected = count_builder(&builder).unwrap();
    // The bunny's G1 patches include folded ones (so every verdict kind that occurs is
    // counted through the stream, not just "valid").
    assert!(expected.folded > 0, "{expected:?}");
    assert_eq!(expected.total(), mesh.triangles.len());
    let mut stats = EdgeStats::new(&mesh);
    let ev = CpuEvaluator::default();
    let reference = stats.continuity(&builder, &ev).unwrap();
    // Small chunks: triangles built again and copied between chunks, never counted twice.
    for edges in [97, CHUNK_EDGES, 1 << 30] {
        stats.chunk_edges = edges;
        let (c, fallbacks, patches) = stats.continuity_certified(&builder, &ev).unwrap();
        assert_eq!(patches, expected, "{edges} edges a chunk");
        assert_eq!((c, fallbacks), reference, "{edges} edges a chunk");
    }
    let report = stats_report(&mesh, Scheme::G1, &SchemeOptions::default(), &ev).unwrap();
    assert_eq!(report.patches, expected);
}

#[test]
fn triangles_without_interior_edges_are_certified_too() {
    // A tetrahedron (every edge interior) and a lone triangle (no interior edge: never
    // built by the statistics' chunks).
    let positions = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [5.0, 0.0, 0.0],
        [6.0, 0.0, 0.0],
        [5.0, 1.0, 0.0],
    ];
    let triangles = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3], [4, 5, 6]];
    let mesh = Mesh::from_soup(
        "soup",
        &positions,
        &triangles,
        None,
        &LoadOptions::default(),
    )
    .unwrap();
    let builder = PatchBuilder::new(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let expected = count_builder(&builder).unwrap();
    assert_eq!(expected.total(), 5);
    let stats = EdgeStats::new(&mesh);
    let (c, _, patches) = stats
        .continuity_certified(&builder, &CpuEvaluator::default())
        .unwrap();
    // 6 interior edges of the tetrahedron, 21 samples each.
    assert_eq!(c.samples + c.crease_samples, 6 * 21);
    assert_eq!(patches, expected);
}

/// The G1 builder (which builds the three edges of a patch in SIMD lanes where the CPU
/// has AVX2) gives bitwise the control points and fallbacks of the scalar construction
/// `g1::patch_points`, on every triangle of the test meshes without split normals (no
/// crease curves: the builder's curves equal `patch_points`' own) and on a triangle whose
/// first boundary tangent vanishes (a fallback: the lanes hand it to the scalar path).
#[test]
fn g1_builds_are_bitwise_the_scalar_construction() {
    use crate::patch::g1;
    let check = |mesh: &Mesh| -> usize {
        assert!(!g1::any_split_normals(mesh), "{}", mesh.name);
        let builder = PatchBuilder::new(mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
        let table = builder.table().unwrap();
        let mut fallbacks = 0;
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let q = tri.map(|v| mesh.positions[v as usize]);
            let expected = g1::patch_points(q, mesh.corner_normals[t], *tri, &mut fallbacks);
            let got = table.patch(t);
            for (j, (a, b)) in got.iter().zip(&expected).enumerate() {
                assert_eq!(
                    a.to_array().map(f64::to_bits),
                    b.to_array().map(f64::to_bits),
                    "{} triangle {t} point {j}",
                    mesh.name
                );
            }
        }
        assert_eq!(table.fallbacks, fallbacks, "{}", mesh.name);
        fallbacks
    };
    for name in ["stanford-bunny.obj", "spot.obj"] {
        check(&common::load(name));
    }
    // The normal at corner 0 runs along edge 0 → 1: the Walton–Meek arm there is exactly 0
    // (t0 = (6 g − 6 n_a) / 18 with g = n_a), which the construction counts as a fallback.
    let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let normals = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]];
    let soup = Mesh::from_soup(
        "soup",
        &positions,
        &[[0, 1, 2]],
        Some(&normals[..]),
        &LoadOptions::default(),
    )
    .unwrap();
    assert!(check(&soup) > 0);
}
