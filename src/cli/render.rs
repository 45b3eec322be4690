//! `g1tess render`: pictures of the normal field (figures 13–16), headless on a Vulkan
//! device.

use std::path::PathBuf;

use clap::Args;
use glam::DVec3;

use super::InputArgs;
use crate::eval::cpu::CpuEvaluator;
use crate::mesh::Mesh;
use crate::patch::{PatchTable, Scheme, SchemeOptions};
use crate::render::{render_panels, write_png, RenderOptions, Row};
use crate::tess::stitch::stitch;

#[derive(Args, Clone, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// Output picture (.png).
    #[arg(short, long)]
    pub output: PathBuf,
    /// More schemes, one row each under the first (e.g. --also phong).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub also: Vec<Scheme>,
    /// Grid level of the evaluated surface (default: 16, lowered so that the surface has at
    /// most about two million triangles).
    #[arg(long)]
    pub level: Option<u32>,
    /// Side of one panel in pixels.
    #[arg(long, default_value_t = 512)]
    pub size: u32,
    /// Direction from the surface towards the camera, "x,y,z".
    #[arg(long, default_value = "0,0,1", value_parser = parse_vec)]
    pub view: DVec3,
    /// Direction that points up in the picture, "x,y,z".
    #[arg(long, default_value = "0,1,0", value_parser = parse_vec)]
    pub up: DVec3,
    /// No summary line on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

fn parse_vec(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}': expected three numbers x,y,z"))?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) && (x, y, z) != (0.0, 0.0, 0.0) => {
            Ok(DVec3::new(x, y, z))
        }
        _ => Err(format!(
            "'{s}': expected three finite numbers x,y,z, not all 0"
        )),
    }
}

/// The default level for a mesh of `triangles`: 16, or less so that level² × triangles
/// stays under about two million.
pub fn auto_level(triangles: usize) -> u32 {
    let fit = (2.0e6 / triangles.max(1) as f64).sqrt().floor() as u32;
    fit.clamp(1, 16)
}

/// Renders `schemes` of `mesh` (one row each) into `output`.
pub fn render_schemes(
    mesh: &Mesh,
    schemes: &[Scheme],
    scheme_opts: &SchemeOptions,
    level: u32,
    opts: &RenderOptions,
    output: &std::path::Path,
) -> anyhow::Result<()> {
    let mut rows = Vec::new();
    for &scheme in schemes {
        let table = PatchTable::build(mesh, scheme, scheme_opts)?;
        let (surface, _, _) = stitch(mesh, &table, &CpuEvaluator::default(), level)?;
        rows.push(Row {
            label: scheme.to_string(),
            panels: render_panels(&surface, opts)?,
        });
    }
    let caption = format!(
        "{}, level {level}: unit normal components, view {:.2},{:.2},{:.2}",
        mesh.name, opts.view.x, opts.view.y, opts.view.z
    );
    write_png(output, &caption, &rows)?;
    Ok(())
}

pub fn run(a: &RenderArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        a.output
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png")),
        "{}: render writes PNG pictures (.png)",
        a.output.display()
    );
    let mesh = Mesh::load(&a.input.mesh, &a.input.load_options())?;
    let level = a.level.unwrap_or_else(|| auto_level(mesh.triangles.len()));
    anyhow::ensure!(level >= 1, "--level must be at least 1");
    let mut schemes = vec![a.input.scheme];
    schemes.extend(a.also.iter().copied().filter(|s| *s != a.input.scheme));
    let opts = RenderOptions {
        panel: a.size,
        view: a.view,
        up: a.up,
    };
    render_schemes(
        &mesh,
        &schemes,
        &a.input.scheme_options(),
        level,
        &opts,
        &a.output,
    )?;
    if !a.quiet {
        eprintln!("wrote {}", a.output.display());
    }
    Ok(())
}
