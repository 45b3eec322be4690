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
