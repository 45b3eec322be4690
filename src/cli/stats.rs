//! `g1tess stats`: continuity statistics of one mesh and scheme.

use clap::Args;

use super::{BackendArgs, InputArgs};
use crate::output::stats::{continuity, StatsReport};

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
    let (mesh, table) = a.input.load()?;
    let adjacency = mesh.adjacency();
    let evaluator = a.backend.evaluator(crate::gpu::Precision::F64)?;
    let c = continuity(&mesh, &adjacency, &table, evaluator.as_ref())?;
    let report = StatsReport::new(&mesh, &adjacency, &table, c, evaluator.describe());
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!("{}\n", report.to_text());
    }
    Ok(())
}
