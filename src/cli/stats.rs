//! `g1tess stats`: continuity statistics of one mesh and scheme.

use clap::Args;

use super::{BackendArgs, InputArgs};
use crate::mesh::Mesh;
use crate::output::stats::{EdgeStats, StatsReport};
use crate::patch::PatchBuilder;

#[derive(Args, Clone, Debug)]
pub struct StatsArgs {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: &StatsArgs) -> anyhow::Result<()> {
    // No whole patch table: the statistics build the patches a chunk of edges at a time.
    let mesh = Mesh::load(&a.input.mesh, &a.input.load_options())?;
    let evaluator = a.backend.evaluator(crate::gpu::Precision::F64)?;
    // The edge index (one thread) is built while the scheme prepares its per-mesh data.
    let opts = a.input.scheme_options();
    let (stats, builder) = std::thread::scope(|s| {
        let index = s.spawn(|| EdgeStats::new(&mesh));
        let builder = PatchBuilder::new(&mesh, a.input.scheme, &opts);
        let index = index
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        (index, builder)
    });
    let builder = builder?;
    let (continuity, fallbacks) = stats.continuity(&builder, evaluator.as_ref())?;
    let report = StatsReport::new(
        &mesh,
        stats.counts(),
        a.input.scheme,
        fallbacks,
        continuity,
        evaluator.describe(),
    );
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!("{}\n", report.to_text());
    }
    Ok(())
}
