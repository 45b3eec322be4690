//! The lazily opened GPU backend and the memory budget.

use super::{Backend, LazyGpu};
use crate::eval::{Chunk, EdgePairs, Evaluator, PairChunk, Pattern};
use crate::patch::PatchTable;

/// An evaluator that names which of its methods was called, by its error.
struct Marker;

impl Evaluator for Marker {
    fn describe(&self) -> String {
        "marker".into()
    }
    fn evaluate(
        &self,
        _: &PatchTable,
        _: &Pattern,
        _: &mut dyn FnMut(Chunk<'_>) -> crate::Result<()>,
    ) -> crate::Result<()> {
        Err(crate::Error::Invalid("evaluate".into()))
    }
    fn evaluate_edges(
        &self,
        _: &PatchTable,
        _: &EdgePairs,
        _: &mut dyn FnMut(Chunk<'_>) -> crate::Result<()>,
    ) -> crate::Result<()> {
        Err(crate::Error::Invalid("evaluate_edges".into()))
    }
    fn evaluate_edge_products(
        &self,
        _: &PatchTable,
        _: &EdgePairs,
        _: &mut dyn FnMut(PairChunk<'_>) -> crate::Result<()>,
    ) -> crate::Result<()> {
        Err(crate::Error::Invalid("evaluate_edge_products".into()))
    }
}

/// The backend `auto` opens hands the edge patterns to the evaluator it chose (the CPU
/// fallback's own edge kernel), not to the trait's point-by-point defaults.
#[test]
fn lazy_gpu_forwards_the_edge_patterns() {
    let lazy = LazyGpu {
        backend: Backend::Auto,
        precision: crate::gpu::Precision::F32,
        quiet: true,
        inner: std::cell::OnceCell::from(Box::new(Marker) as Box<dyn Evaluator>),
    };
    let mesh = crate::mesh::generators::icosphere(0);
    let table = PatchTable::build(
        &mesh,
        crate::patch::Scheme::G1,
        &crate::patch::SchemeOptions::default(),
    )
    .unwrap();
    let adjacency = mesh.adjacency();
    let edges = crate::analysis::stats::edge_pairs(&mesh, &adjacency);
    let called = |r: crate::Result<()>| r.unwrap_err().to_string();
    assert_eq!(
        called(lazy.evaluate_edges(&table, &edges, &mut |_| Ok(()))),
        "evaluate_edges"
    );
    assert_eq!(
        called(lazy.evaluate_edge_products(&table, &edges, &mut |_| Ok(()))),
        "evaluate_edge_products"
    );
}

#[test]
fn memory_budget_refusal_is_over_budget_with_the_sizes() {
    let budget = super::Budget { bytes: 1 << 20 };
    let err = budget.check("stats", "the mesh", 3 << 20, "").unwrap_err();
    assert_eq!(
        err.to_string(),
        "stats: the mesh needs about 3.0 MiB, over the memory budget of 1.0 MiB (--max-memory)"
    );
    match err.downcast_ref::<crate::Error>() {
        Some(crate::Error::OverBudget {
            what,
            needed,
            allowed,
            ..
        }) => {
            assert_eq!(what, "the mesh");
            assert_eq!((*needed, *allowed), (3 << 20, 1 << 20));
        }
        other => panic!("expected OverBudget, got {other:?}"),
    }
}

/// `icosphere:0` (vertices on the unit sphere, largest coordinate 0.85) scaled so that its
/// largest coordinate is `largest`.
fn scaled_icosahedron(largest: f64) -> crate::mesh::Mesh {
    let mut m = crate::mesh::Mesh::load("icosphere:0", &Default::default()).unwrap();
    let now = m
        .positions
        .iter()
        .flat_map(|p| p.to_array())
        .fold(0.0f64, |a, c| a.max(c.abs()));
    for p in &mut m.positions {
        *p *= largest / now;
    }
    m
}

#[test]
fn f32_range_bounds() {
    use super::f32_range;
    let normal = f64::from(f32::MIN_POSITIVE); // 2^-126
                                               // In f32's normal range, down to its smallest normal number: nothing to say.
    for largest in [1.0, 1e30, 1e-30, normal] {
        assert!(
            f32_range(&scaled_icosahedron(largest)).unwrap().is_none(),
            "{largest:e}"
        );
    }
    // Just below it: a note, and the relative step is 2^-149 / largest = 2^-23 / 0.75 (1.6e-7).
    let note = f32_range(&scaled_icosahedron(normal * 0.75))
        .unwrap()
        .unwrap();
    assert!(
        note.contains("below f32's normal range (1.2e-38)"),
        "{note}"
    );
    assert!(note.contains("1.6e-7 of the largest coordinate"), "{note}");
    // The smallest subnormal, 2^-149, is still held (one step: no digit left).
    let note = f32_range(&scaled_icosahedron(2f64.powi(-149)))
        .unwrap()
        .unwrap();
    assert!(
        note.contains("1.0e0 of the largest coordinate (about 0.0 significant digits"),
        "{note}"
    );
    // 2^-150 rounds to 0 (ties to even): refused.
    let e = f32_range(&scaled_icosahedron(2f64.powi(-150))).unwrap_err();
    assert!(
        e.to_string()
            .contains("every coordinate rounds to 0 in f32"),
        "{e}"
    );
}
