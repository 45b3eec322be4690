//! The unit tests of `src/cli/`: the lazily opened GPU backend.
//! (Moved from the library's own unit tests: the integration suite is built once.)

#[cfg(feature = "cli")]
mod cli_common {
    use g1tess::cli::Backend;
    use g1tess::eval::{Chunk, EdgePairs, Evaluator, PairChunk, Pattern};
    use g1tess::internals::LazyGpu;
    use g1tess::patch::PatchTable;

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
            _: &mut dyn FnMut(Chunk<'_>) -> g1tess::Result<()>,
        ) -> g1tess::Result<()> {
            Err(g1tess::Error::Invalid("evaluate".into()))
        }
        fn evaluate_edges(
            &self,
            _: &PatchTable,
            _: &EdgePairs,
            _: &mut dyn FnMut(Chunk<'_>) -> g1tess::Result<()>,
        ) -> g1tess::Result<()> {
            Err(g1tess::Error::Invalid("evaluate_edges".into()))
        }
        fn evaluate_edge_products(
            &self,
            _: &PatchTable,
            _: &EdgePairs,
            _: &mut dyn FnMut(PairChunk<'_>) -> g1tess::Result<()>,
        ) -> g1tess::Result<()> {
            Err(g1tess::Error::Invalid("evaluate_edge_products".into()))
        }
    }

    /// The backend `auto` opens hands the edge patterns to the evaluator it chose (the CPU
    /// fallback's own edge kernel), not to the trait's point-by-point defaults.
    #[test]
    fn lazy_gpu_forwards_the_edge_patterns() {
        let lazy = LazyGpu {
            backend: Backend::Auto,
            precision: g1tess::gpu::Precision::F32,
            quiet: true,
            inner: std::cell::OnceCell::from(Box::new(Marker) as Box<dyn Evaluator>),
        };
        let mesh = g1tess::mesh::generators::icosphere(0);
        let table = PatchTable::build(
            &mesh,
            g1tess::patch::Scheme::G1,
            &g1tess::patch::SchemeOptions::default(),
        )
        .unwrap();
        let adjacency = mesh.adjacency();
        let edges = g1tess::analysis::stats::edge_pairs(&mesh, &adjacency);
        let called = |r: g1tess::Result<()>| r.unwrap_err().to_string();
        assert_eq!(
            called(lazy.evaluate_edges(&table, &edges, &mut |_| Ok(()))),
            "evaluate_edges"
        );
        assert_eq!(
            called(lazy.evaluate_edge_products(&table, &edges, &mut |_| Ok(()))),
            "evaluate_edge_products"
        );
    }
}
