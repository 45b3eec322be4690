//! `g1tess sweep`: the distance study of figures 17–18 — every scheme on refined
//! icospheres and tori, distance to the analytic surface, convergence order, CSV + JSON +
//! log–log plots.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use super::out;
use super::BackendArgs;
use super::TEMP_FILES;
use crate::analysis::distance::{self, Series, SweepPlan, SweepRow};
use crate::eval::Evaluator;
use crate::io::atomic::{ensure_dir, write_atomic};
use crate::io::plot;
use crate::patch::SchemeOptions;

#[derive(Args, Clone, Debug)]
#[command(mut_arg("backend", |a| a
    .default_value("cpu")
    .help("Evaluation backend (default cpu: the study's meshes are small, and the f64 \
           CPU reference is faster on them than a GPU in f64)")))]
pub struct SweepArgs {
    /// Output folder for distance.csv, distance.json and the plots.
    #[arg(short, long, alias = "out", default_value = "out/sweep")]
    pub output: PathBuf,
    /// Print the JSON document on stdout instead of the text summary.
    #[arg(long)]
    pub json: bool,
    /// No progress bar and no "wrote" lines on stderr.
    #[arg(short, long)]
    pub quiet: bool,
    /// Where the patches are evaluated (the study reads f64: the GPU runs in f64 unless
    /// told otherwise).
    #[command(flatten)]
    pub backend: BackendArgs,
    /// Segments per patch edge of the sampling grid (at least 1).
    #[arg(
        long,
        default_value_t = distance::STUDY_LEVEL,
        allow_negative_numbers = true,
        value_parser = super::common::whole_number(1, u32::MAX)
    )]
    pub level: u32,
    /// Phong tessellation's shape factor α (any finite number).
    #[arg(long, default_value_t = 0.75, allow_hyphen_values = true)]
    pub phong_alpha: f64,
    #[command(flatten)]
    pub memory: super::common::MemoryArgs,
}

/// What the distance study holds at grid level `level`: the basis weights of every grid
/// point (the CPU evaluator's `Weights`, with their barycentrics), one chunk of f64
/// samples (position + normal), and the study's meshes and patches (under 1 MiB each).
pub fn sweep_need(level: u32) -> u64 {
    let points = crate::eval::grid_len(level) as u64;
    let per_point = std::mem::size_of::<crate::patch::basis::Weights>() as u64 + 24;
    points
        .saturating_mul(per_point)
        .saturating_add(super::common::CHUNK_SAMPLES as u64 * 48)
        .saturating_add(16 << 20)
}

/// Refuses a study whose grid would exceed the budget, before anything is allocated.
pub fn check_sweep(
    budget: &super::common::Budget,
    command: &str,
    level: u32,
) -> anyhow::Result<()> {
    budget.check(
        command,
        &format!("the distance study at level {level}"),
        sweep_need(level),
        &format!(
            "{} grid points per patch",
            super::common::human_count(crate::eval::grid_len(level) as u64)
        ),
    )
}

/// What `sweep` wrote.
pub struct SweepOutput {
    pub rows: Vec<SweepRow>,
    pub json: serde_json::Value,
    pub files: Vec<PathBuf>,
}

fn progress_bar(len: usize, quiet: bool) -> ProgressBar {
    let target = if quiet || !std::io::stderr().is_terminal() {
        ProgressDrawTarget::hidden()
    } else {
        ProgressDrawTarget::stderr()
    };
    let pb = ProgressBar::with_draw_target(Some(len as u64), target);
    if let Ok(style) = ProgressStyle::with_template("{msg:>28} [{bar:30}] {pos}/{len} {elapsed}") {
        pb.set_style(style.progress_chars("=> "));
    }
    pb
}

/// Runs the study and writes its files into `out`.
pub fn sweep_into(
    out: &Path,
    plan: &SweepPlan,
    evaluator: &dyn Evaluator,
    quiet: bool,
) -> anyhow::Result<SweepOutput> {
    anyhow::ensure!(plan.level >= 1, "--level must be at least 1");
    ensure_dir(out)?;
    let pb = progress_bar(plan.jobs(), quiet);
    let rows = distance::sweep(plan, evaluator, &mut |r| {
        pb.set_message(format!("{} {}", r.mesh, r.scheme));
        pb.inc(1);
    })?;
    pb.finish_and_clear();
    let json = serde_json::json!({
        "level": plan.level,
        "phong_alpha": plan.options.phong_alpha,
        "backend": evaluator.describe(),
        "distance": "mean and max over all grid samples of the distance to the analytic surface",
        "order": "log(e_prev / e) / log(h_prev / h), h = 1/sqrt(triangles)",
        "rows": rows,
    });
    let csv_path = out.join("distance.csv");
    let json_path = out.join("distance.json");
    let csv = distance::to_csv(&rows);
    write_atomic(&csv_path, &TEMP_FILES, |w| {
        std::io::Write::write_all(w, csv.as_bytes())
    })?;
    let text = serde_json::to_string_pretty(&json)?;
    write_atomic(&json_path, &TEMP_FILES, |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })?;
    let mut files = vec![csv_path, json_path];
    files.extend(plot::write_figure(
        &out.join("sphere_distance"),
        &TEMP_FILES,
        &plot::sphere_figure(&rows),
    )?);
    files.extend(plot::write_figure(
        &out.join("torus_distance"),
        &TEMP_FILES,
        &plot::torus_figure(&rows),
    )?);
    Ok(SweepOutput { rows, json, files })
}

/// Text summary: per series and scheme, the mean distance to the analytic surface on the
/// coarsest and the finest mesh of the series, and the observed order of convergence of
/// the mean over the last refinement and over the whole series. Each series' header names
/// its columns:
///
/// ```text
/// icosphere: mean distance to the analytic surface, coarsest and finest mesh
///                   ----- coarsest mesh ------ ------ finest mesh ------- - order of mean --
///   scheme           triangles   mean distance  triangles   mean distance    last    overall
///   g1                      20       4.9950e-3       5120       7.8388e-8    4.00       3.99
/// ```
pub fn summary(rows: &[SweepRow]) -> String {
    let mut s = String::new();
    for series in Series::all() {
        let of: Vec<&SweepRow> = rows.iter().filter(|r| r.series == series).collect();
        if of.is_empty() {
            continue;
        }
        s += &format!(
            "{series}: mean distance to the analytic surface, coarsest and finest mesh\n\
             \x20 {:<15} {:-^26} {:-^26} {:-^18}\n\
             \x20 {:<15} {:>10} {:>15} {:>10} {:>15} {:>7} {:>10}\n",
            "",
            " coarsest mesh ",
            " finest mesh ",
            " order of mean ",
            "scheme",
            "triangles",
            "mean distance",
            "triangles",
            "mean distance",
            "last",
            "overall"
        );
        let mut schemes: Vec<_> = of.iter().map(|r| r.scheme).collect();
        schemes.dedup();
        schemes.sort_by_key(|x| crate::patch::Scheme::all().iter().position(|y| y == x));
        schemes.dedup();
        for sc in schemes {
            let rs: Vec<&&SweepRow> = of.iter().filter(|r| r.scheme == sc).collect();
            let (a, b) = (rs[0], rs[rs.len() - 1]);
            let overall = distance::observed_order(a.h, a.mean, b.h, b.mean);
            let f = |o: Option<f64>| o.map(|x| format!("{x:.2}")).unwrap_or("-".into());
            s += &format!(
                "  {:<15} {:>10} {:>15.4e} {:>10} {:>15.4e} {:>7} {:>10}\n",
                sc.name(),
                a.triangles,
                a.mean,
                b.triangles,
                b.mean,
                f(b.order_mean),
                f(overall)
            );
        }
    }
    s
}

pub fn run(a: &SweepArgs) -> anyhow::Result<()> {
    anyhow::ensure!(a.level >= 1, "--level must be at least 1");
    check_sweep(&a.memory.budget(), "sweep", a.level)?;
    let plan = SweepPlan {
        level: a.level,
        options: SchemeOptions {
            phong_alpha: a.phong_alpha,
        },
        ..SweepPlan::default()
    };
    let mut backend = a.backend.clone();
    backend.quiet |= a.quiet;
    let evaluator = backend.evaluator(crate::gpu::Precision::F64)?;
    let out = sweep_into(&a.output, &plan, evaluator.as_ref(), a.quiet)?;
    if a.json {
        out::stdout_json(&serde_json::to_string_pretty(&out.json)?)?;
    } else {
        out::stdout(&summary(&out.rows))?;
    }
    if !a.quiet {
        for f in &out.files {
            out::stderr_line(&format!("wrote {}", f.display()));
        }
    }
    Ok(())
}
