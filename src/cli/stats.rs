//! `g1tess stats`: continuity statistics of one mesh and scheme.

use clap::Args;

use super::{BackendArgs, InputArgs};
use crate::mesh::Mesh;
use crate::output::stats::stats_report;

#[derive(Args, Clone, Debug)]
pub struct StatsArgs {
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub memory: super::MemoryArgs,
}

pub fn run(a: &StatsArgs) -> anyhow::Result<()> {
    // No whole patch table: the statistics build the patches a chunk of edges at a time.
    let budget = a.memory.budget();
    budget.check_load("stats", &a.input.mesh)?;
    let mesh = Mesh::load(&a.input.mesh, &a.input.load_options())?;
    budget.check_stats("stats", &mesh)?;
    let evaluator = a.backend.evaluator(crate::gpu::Precision::F64)?;
    let report = stats_report(
        &mesh,
        a.input.scheme,
        &a.input.scheme_options(),
        evaluator.as_ref(),
    )?;
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!("{}\n", report.to_text());
    }
    Ok(())
}
