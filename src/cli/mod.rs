//! The command line: one file per command. `main` prints errors as one line and exits
//! non-zero; nothing a user can type makes it panic.

mod bench;
mod common;
mod compare;
mod export_net;
pub mod paper;
mod progress;
mod render;
mod stats;
mod sweep;
mod tessellate;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub use common::{Backend, BackendArgs, InputArgs};

#[derive(Parser)]
#[command(
    name = "g1tess",
    version,
    about = "Smooth G1 curved surfaces from triangle meshes with vertex normals",
    long_about = "Smooth G1 curved surfaces from triangle meshes with vertex normals.\n\n\
                  With no command, runs the default job (see the README)."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand)]
pub enum Command {
    /// Evaluate every patch on a barycentric grid and write the surface (positions + normals).
    Tessellate(tessellate::TessellateArgs),
    /// Continuity statistics across shared edges (Table 1 protocol).
    Stats(stats::StatsArgs),
    /// Write every patch's control points as JSON (for boundary-element solvers).
    ExportNet(export_net::ExportNetArgs),
    /// Pictures of the normal field: n_x, n_y, n_z of the evaluated surface (PNG, Vulkan).
    Render(render::RenderArgs),
    /// Table 1: continuity statistics of every scheme on each mesh (markdown or JSON).
    Compare(compare::CompareArgs),
    /// Distance to the analytic surface on refined icospheres and tori (figures 17–18):
    /// CSV, JSON and log–log plots.
    Sweep(sweep::SweepArgs),
    /// Throughput of the CPU and GPU evaluators against the memory write bandwidth.
    Bench(bench::BenchArgs),
}

/// The default job: `cargo run --release` with no arguments reproduces the paper into
/// `out/paper/` (steps in `paper.rs`).
fn default_run() -> anyhow::Result<()> {
    // `--backend auto` in f64: the GPU where it has f64, else the CPU (saying so).
    let evaluator = BackendArgs::default().evaluator(crate::gpu::Precision::F64)?;
    paper::run(&paper::PaperRun {
        evaluator,
        ..Default::default()
    })
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Some(Command::Stats(a)) => stats::run(&a),
        Some(Command::Tessellate(a)) => tessellate::run(&a),
        Some(Command::ExportNet(a)) => export_net::run(&a),
        Some(Command::Render(a)) => render::run(&a),
        Some(Command::Compare(a)) => compare::run(&a),
        Some(Command::Sweep(a)) => sweep::run(&a),
        Some(Command::Bench(a)) => bench::run(&a),
        None => default_run(),
    }
}

pub fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let chain: Vec<String> = e.chain().map(|c| c.to_string()).collect();
            eprintln!("error: {}", chain.join(": "));
            ExitCode::FAILURE
        }
    }
}
