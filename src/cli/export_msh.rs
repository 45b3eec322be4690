//! `g1tess export-msh`: curved Lagrange triangles of order 1 to 5 as Gmsh MSH 4.1, for
//! solvers (see `io::msh`).

use std::path::PathBuf;

use clap::Args;

use super::common::{whole_number, MemoryArgs};
use super::out;
use super::progress;
use super::InputArgs;
use super::TEMP_FILES;
use crate::io::atomic;
use crate::io::msh::{export_msh, triangle_node_count, MAX_ORDER};

#[derive(Args, Clone, Debug)]
pub struct ExportMshArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// Element order P (1 to 5): triangles of Gmsh types 2, 9, 21, 23, 25, every node on
    /// the scheme's surface.
    #[arg(
        long,
        default_value_t = 3,
        allow_negative_numbers = true,
        value_parser = whole_number(1, MAX_ORDER)
    )]
    pub order: u32,
    /// Write binary MSH 4.1 instead of ASCII.
    #[arg(long)]
    pub binary: bool,
    /// Output .msh file; `-` writes to standard output. A symbolic link is written through
    /// to its target; a directory, device or FIFO is refused, and so is the input mesh
    /// itself.
    #[arg(short, long)]
    pub output: PathBuf,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// Print a JSON summary on stdout: {"output", "mesh", "scheme", "order", "nodes",
    /// "triangles", "min_scaled_jacobian", "max_distance", ...} (docs/cli.md).
    #[arg(long)]
    pub json: bool,
    /// No progress bars and no summary line on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

pub fn run(a: &ExportMshArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        (1..=MAX_ORDER).contains(&a.order),
        "--order must be 1 to {MAX_ORDER}"
    );
    let stdout = atomic::is_stdout(&a.output);
    anyhow::ensure!(
        !(stdout && a.json),
        "--json prints on standard output, which -o - already writes the mesh to"
    );
    if !stdout {
        atomic::resolve_output(&a.output)?;
        atomic::refuse_input_files(&a.output, std::path::Path::new(&a.input.mesh))?;
    }
    let mesh = a.input.load_mesh()?;
    // Held at once: the patch table, the nodes (24 bytes each), the connectivity, and the
    // edge and half-edge indices; the file streams through a 1 MiB buffer.
    let p = a.order as u64;
    let (nv, nt) = (mesh.positions.len() as u64, mesh.triangles.len() as u64);
    let ne = 3 * nt / 2 + nt % 2 + 1;
    let nodes = nv + ne * (p - 1) + nt * (p.saturating_sub(1) * p.saturating_sub(2) / 2);
    let stride = a.input.scheme.kind().layout().stride as u64;
    let need = nt * stride * 24
        + nodes * 24
        + nt * (triangle_node_count(a.order) as u64 * 4 + 16 + 12)
        + ne * 48
        + (1 << 20);
    a.memory.budget().check(
        "export-msh",
        &format!("order {}", a.order),
        need,
        &format!("about {nodes} nodes"),
    )?;
    // With --repair-folds the elements are those of the repaired mesh, whose creases (the
    // repair's new ones too) go into the crease group, and whose split normals decide where
    // a non-manifold edge's triangles get edge nodes of their own.
    let repair = a.input.repair_folds;
    let (mesh, table, folds) = a.input.prepare(mesh, a.quiet)?;
    if let Some(line) = folds {
        out::stderr_line(&line);
    }
    let bar = progress::bar(nt, "placing nodes", "triangles", a.quiet);
    let summary = export_msh(
        &mesh,
        &table,
        a.order,
        a.binary,
        &a.output,
        &TEMP_FILES,
        &bar,
    )?;
    bar.finish();
    if summary.nonpositive_jacobian_elements > 0 {
        out::stderr_line(&format!(
            "warning: {}: {} of {} elements of order {} may fold (their Jacobian bound is not \
             positive){}",
            mesh.name,
            summary.nonpositive_jacobian_elements,
            summary.triangles,
            summary.order,
            if !repair {
                "; --repair-folds repairs folded patches"
            } else {
                ""
            }
        ));
    }
    if a.json {
        let mut v = serde_json::to_value(&summary)?;
        v["output"] = a.output.display().to_string().into();
        out::stdout_json(&v.to_string())?;
    } else if !a.quiet {
        out::stderr_line(&format!(
            "wrote {}: {} triangles of order {} ({} nodes, {} crease and {} boundary lines); \
             min scaled Jacobian {:.4} (element {}), max distance to the surface {:.3e} \
             (element {})",
            a.output.display(),
            summary.triangles,
            summary.order,
            summary.nodes,
            summary.crease_lines,
            summary.boundary_lines,
            summary.min_scaled_jacobian,
            summary.min_scaled_jacobian_element,
            summary.max_distance,
            summary.max_distance_element
        ));
    }
    Ok(())
}
