//! `g1tess export-net`: every patch's control points as JSON, for solvers.

use std::path::PathBuf;

use clap::Args;

use super::InputArgs;
use crate::output::nets::write_nets;

#[derive(Args, Clone, Debug)]
pub struct ExportNetArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// Output JSON file (format in the README, "Control nets").
    #[arg(short, long)]
    pub output: PathBuf,
    /// No summary line on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

pub fn run(a: &ExportNetArgs) -> anyhow::Result<()> {
    let (mesh, table) = a.input.load()?;
    write_nets(&a.output, &mesh, &table)?;
    if !a.quiet {
        eprintln!(
            "wrote {}: {} patches of {} control points ({})",
            a.output.display(),
            table.len(),
            table.stride,
            table.scheme
        );
    }
    Ok(())
}
