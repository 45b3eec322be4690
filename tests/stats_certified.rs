//! The statistics certify each patch where they first build it: the validity counts of a
//! streamed `stats` run are exactly those of certifying every patch of the builder
//! (`validity::count_builder`), whatever the chunking, including triangles that no interior
//! edge reaches.

use crate::common;

use g1tess::eval::cpu::CpuEvaluator;
use g1tess::mesh::{LoadOptions, Mesh};
use g1tess::output::stats::{stats_report, EdgeStats, CHUNK_EDGES};
use g1tess::patch::validity::count_builder;
use g1tess::patch::{PatchBuilder, Scheme, SchemeOptions};

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
