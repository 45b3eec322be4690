//! `g1tess export-net`: every patch's control points as JSON, for solvers.

use std::path::PathBuf;

use clap::Args;

use super::common::MemoryArgs;
use super::out;
use super::InputArgs;
use super::TEMP_FILES;
use crate::io::atomic;
use crate::io::nets::write_nets;

#[derive(Args, Clone, Debug)]
pub struct ExportNetArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// Output JSON file (format in docs/formats.md, "Control nets"); `-` writes to standard
    /// output. A symbolic link is written through to its target; a directory, device or
    /// FIFO is refused, and so is the input mesh itself.
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// No summary line on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

pub fn run(a: &ExportNetArgs) -> anyhow::Result<()> {
    if !atomic::is_stdout(&a.output) {
        atomic::resolve_output(&a.output)?;
        atomic::refuse_input_files(&a.output, std::path::Path::new(&a.input.mesh))?;
    }
    let mesh = a.input.load_mesh()?;
    // The patch table (stride × 3 f64 per patch) is what grows with the input; writing
    // streams one patch at a time through a 1 MiB buffer.
    let stride = a.input.scheme.kind().layout().stride as u64;
    let patches = mesh.triangles.len() as u64;
    a.memory.budget().check(
        "export-net",
        &format!("{patches} patches"),
        patches.saturating_mul(stride * 24) + (1 << 20),
        &format!("{stride} control points each"),
    )?;
    // With --repair-folds the patches of the repaired mesh.
    let (mesh, _) = a.input.repaired(&mesh, a.quiet)?;
    let table = crate::patch::PatchTable::build(&mesh, a.input.scheme, &a.input.scheme_options())?;
    write_nets(&a.output, &TEMP_FILES, &mesh, &table)?;
    if !a.quiet {
        out::stderr_line(&format!(
            "wrote {}: {} patches of {} control points ({})",
            a.output.display(),
            table.len(),
            table.stride,
            table.scheme
        ));
    }
    Ok(())
}
