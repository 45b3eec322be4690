//! The default run (`cargo run --release` with no arguments): reproduces the paper into
//! `out/paper/`. It is a list of steps; to add one, write a `fn(&PaperRun) ->
//! anyhow::Result<()>` and append it to [`steps`].

use std::path::PathBuf;

use super::out;
use super::TEMP_FILES;
use crate::analysis::distance::SweepPlan;
use crate::analysis::table1;
use crate::eval::cpu::CpuEvaluator;
use crate::eval::Evaluator;
use crate::io::atomic::{ensure_dir, write_atomic};

use super::compare::CompareArgs;
use super::BackendArgs;

/// Options of the default run (`g1tess` with no command).
#[derive(clap::Args, Clone, Debug, Default)]
#[command(mut_arg("backend", |a| a.help(
    "Where the patches are evaluated (Table 1, the distance study, the pictures' \
     surfaces). The pictures are drawn by a render pass on a Vulkan device whatever the \
     backend; without one they are skipped")))]
pub struct PaperArgs {
    /// Evaluation backend and precision (help text set on the struct).
    #[command(flatten)]
    pub backend: BackendArgs,
    /// No progress bars and no per-step lines on stderr (the table and the distance
    /// summary are still printed on stdout).
    #[arg(short, long)]
    pub quiet: bool,
    #[command(flatten)]
    pub memory: super::common::MemoryArgs,
}

/// The default run with its options: statistics in f64 on the GPU unless `--precision`
/// says otherwise.
pub fn run_args(a: &PaperArgs) -> anyhow::Result<()> {
    // The run's work is fixed: the largest step is the distance study's grid.
    super::sweep::check_sweep(
        &a.memory.budget(),
        "the default run",
        SweepPlan::default().level,
    )?;
    let mut backend = a.backend.clone();
    backend.quiet |= a.quiet;
    let evaluator = backend.evaluator(crate::gpu::Precision::F64)?;
    run(&PaperRun {
        evaluator,
        quiet: a.quiet,
        ..Default::default()
    })
}

/// Shared state of the default run's steps.
pub struct PaperRun {
    /// Where every step writes (`out/paper`).
    pub out: PathBuf,
    /// The backend that evaluates the patches.
    pub evaluator: Box<dyn Evaluator>,
    /// No progress bars.
    pub quiet: bool,
}

impl Default for PaperRun {
    fn default() -> Self {
        PaperRun {
            out: PathBuf::from("out/paper"),
            evaluator: Box::new(CpuEvaluator::default()),
            quiet: false,
        }
    }
}

/// One step of the default run.
pub struct Step {
    pub name: &'static str,
    pub run: fn(&PaperRun) -> anyhow::Result<()>,
}

/// The steps, in order.
pub fn steps() -> Vec<Step> {
    vec![
        Step {
            name: "table 1 (continuity across edges)",
            run: table,
        },
        Step {
            name: "figures 17-18 (distance to the analytic surface)",
            run: sweep,
        },
        Step {
            name: "figures 13-16 (normal components as colour)",
            run: normal_pictures,
        },
    ]
}

/// Runs every step.
pub fn run(ctx: &PaperRun) -> anyhow::Result<()> {
    ensure_dir(&ctx.out)?;
    for step in steps() {
        let t = std::time::Instant::now();
        (step.run)(ctx).map_err(|e| e.context(step.name))?;
        if !ctx.quiet {
            out::stderr_line(&format!(
                "{}: {:.1} s",
                step.name,
                t.elapsed().as_secs_f64()
            ));
        }
    }
    Ok(())
}

/// Table 1: markdown (also printed) and JSON.
fn table(ctx: &PaperRun) -> anyhow::Result<()> {
    let args = CompareArgs::paper();
    let reports = table1::compare(
        &args.meshes,
        &Default::default(),
        &args.schemes(),
        &Default::default(),
        ctx.evaluator.as_ref(),
    )?;
    let md = table1::to_markdown(&reports);
    out::stdout_line(&md)?;
    let md_path = ctx.out.join("table1.md");
    write_atomic(&md_path, &TEMP_FILES, |w| {
        std::io::Write::write_all(w, md.as_bytes())
    })?;
    let json = serde_json::to_string_pretty(&reports)?;
    let json_path = ctx.out.join("table1.json");
    write_atomic(&json_path, &TEMP_FILES, |w| {
        std::io::Write::write_all(w, json.as_bytes())
    })?;
    if !ctx.quiet {
        out::stderr_line(&format!(
            "wrote {} and {}",
            md_path.display(),
            json_path.display()
        ));
    }
    Ok(())
}

/// Figures 17–18: sweep CSV/JSON and both plots.
fn sweep(ctx: &PaperRun) -> anyhow::Result<()> {
    let out = super::sweep::sweep_into(
        &ctx.out,
        &SweepPlan::default(),
        ctx.evaluator.as_ref(),
        ctx.quiet,
    )?;
    out::stdout(&super::sweep::summary(&out.rows))?;
    if !ctx.quiet {
        for f in &out.files {
            out::stderr_line(&format!("wrote {}", f.display()));
        }
    }
    Ok(())
}

/// Figures 13–16: n_x, n_y, n_z of G1 and Phong side by side on sphere320 and torus200
/// (`normals_<mesh>.png`). Without a Vulkan device the step says so and is skipped.
fn normal_pictures(ctx: &PaperRun) -> anyhow::Result<()> {
    use crate::patch::Scheme;
    use crate::render::RenderOptions;
    if let Err(e) = crate::cli::common::shared_gpu() {
        if !ctx.quiet {
            out::stderr_line(&format!("skipped the normal-field pictures: {e}"));
        }
        return Ok(());
    }
    for (mesh, view) in [
        ("sphere320", glam::DVec3::new(0.5, -1.0, 0.7)),
        ("torus200", glam::DVec3::new(0.5, -1.0, 0.9)),
    ] {
        let m = crate::mesh::Mesh::load(mesh, &Default::default())?;
        let path = ctx.out.join(format!("normals_{mesh}.png"));
        super::render::render_schemes(
            &m,
            &[Scheme::G1, Scheme::Phong],
            &Default::default(),
            false,
            16,
            &RenderOptions {
                panel: 400,
                view,
                up: glam::DVec3::Z,
                ..Default::default()
            },
            ctx.evaluator.as_ref(),
            &path,
        )?;
        if !ctx.quiet {
            out::stderr_line(&format!("wrote {}", path.display()));
        }
    }
    Ok(())
}
