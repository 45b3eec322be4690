//! `g1tess render`: pictures of the normal field (figures 13–16), headless on a Vulkan
//! device. The render pass always needs that device; `--backend` chooses where the
//! surface is tessellated: on the GPU straight into the render pass's vertex and index
//! buffers (`gpu::tessellator`), or on the CPU and uploaded into buffers of the same layout. The device is opened first and the surface's size checked against
//! its limits and the host memory before anything is evaluated.

use std::path::PathBuf;

use clap::Args;
use glam::DVec3;

use super::common::whole_number;
use super::out;
use super::TEMP_FILES;
use super::{BackendArgs, Budget, InputArgs, MemoryArgs};
use crate::eval::Evaluator;
use crate::gpu::tessellator::GpuTessellator;
use crate::gpu::Precision;
use crate::mesh::Mesh;
use crate::patch::repair::{repair, repair_line, RepairOptions};
use crate::patch::{PatchTable, Scheme, SchemeOptions};
use crate::render::{
    max_panel, render_panels, render_tessellated, write_png, RenderOptions, Row, Shading,
    SurfaceSize, MIN_PANEL,
};
use crate::tess::stitch::stitch;

#[derive(Args, Clone, Debug)]
#[command(mut_arg("backend", |a| a.help(
    "Where the surface is evaluated. The picture itself is always drawn by a render pass \
     on the Vulkan device, so render needs one whatever the backend")))]
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
    #[arg(
        long,
        allow_negative_numbers = true,
        value_parser = whole_number(1, u32::MAX)
    )]
    pub level: Option<u32>,
    /// Side of one panel in pixels (at least 16; at most 4096 and the device's texture
    /// limit / 3).
    #[arg(
        long,
        default_value_t = 512,
        allow_negative_numbers = true,
        value_parser = whole_number(MIN_PANEL, crate::render::MAX_PANEL)
    )]
    pub size: u32,
    /// Direction from the surface towards the camera, "x,y,z".
    #[arg(long, default_value = "0,0,1", value_parser = parse_vec, allow_hyphen_values = true)]
    pub view: DVec3,
    /// Direction that points up in the picture, "x,y,z".
    #[arg(long, default_value = "0,1,0", value_parser = parse_vec, allow_hyphen_values = true)]
    pub up: DVec3,
    /// How each panel shows its normal component n·L (L = x, y, z): through the colour
    /// ramp (normals), or as isophotes, bands of 1/12 alternately light and dark whose
    /// boundaries are the curves n·L = k/12 (kinks in them show where curvature jumps).
    #[arg(long, value_enum, default_value = "normals")]
    pub shading: Shading,
    /// Evaluation backend and precision (help text set on the struct).
    #[command(flatten)]
    pub backend: BackendArgs,
    #[command(flatten)]
    pub memory: MemoryArgs,
    /// No summary line and nothing about the adapter or the CPU fallback on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Refuses a view direction parallel to the up direction (the picture's orientation would
/// be arbitrary).
pub fn check_view_up(view: DVec3, up: DVec3) -> anyhow::Result<()> {
    // Both can be normalised (parse_vec refuses the others; checked again here, so that an
    // overflow is not taken for parallel directions); the sine of the angle between them
    // below 1e-6 (0.2 arc seconds) leaves no usable up direction after projection.
    for (name, v) in [("--view", view), ("--up", up)] {
        if let Some(why) = not_a_direction(v) {
            anyhow::bail!("{name} {:?},{:?},{:?}: {why}", v.x, v.y, v.z);
        }
    }
    let sine = view.normalize().cross(up.normalize()).length();
    anyhow::ensure!(
        sine >= 1e-6,
        "--view {},{},{} is parallel to --up {},{},{}: give an up direction across the view",
        view.x,
        view.y,
        view.z,
        up.x,
        up.y,
        up.z
    );
    Ok(())
}

/// The largest level ≤ `level` whose surface passes `fits`, if any.
fn largest_fitting(triangles: usize, level: u32, fits: impl Fn(&SurfaceSize) -> bool) -> u32 {
    let (mut lo, mut hi) = (0u32, level);
    while lo < hi {
        let mid = lo + (hi - lo).div_ceil(2);
        if fits(&SurfaceSize::new(triangles, mid)) {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    lo
}

/// Refuses a level whose surface the device cannot draw or whose picture needs more than
/// the memory budget (`--max-memory`), naming the largest level that fits.
fn check_level(
    gpu: &crate::gpu::GpuContext,
    mesh: &Mesh,
    level: u32,
    explicit: bool,
    budget: &Budget,
) -> anyhow::Result<()> {
    let t = mesh.triangles.len();
    let budget = budget.bytes as u128;
    let fits = |s: &SurfaceSize| s.check_device(gpu).is_ok() && s.host_bytes() <= budget;
    let size = SurfaceSize::new(t, level);
    if fits(&size) {
        return Ok(());
    }
    let device = size.check_device(gpu);
    let why = match &device {
        Err(e) => e.to_string(),
        Ok(()) => format!(
            "the picture needs about {} MB, over the memory budget of {} MB (--max-memory)",
            size.host_bytes() / 1_000_000,
            budget / 1_000_000
        ),
    };
    let best = largest_fitting(t, level, fits);
    let flag = if explicit {
        "--level"
    } else {
        "the default level"
    };
    let message = format!(
        "{}: {flag} {level} on {t} triangles is too large ({why}); {}",
        mesh.name,
        if best >= 1 {
            format!("use --level {best} or less")
        } else {
            "the mesh is too large to draw".into()
        }
    );
    match device {
        // The device can draw it: the memory budget refuses it.
        Ok(()) => Err(crate::Error::OverBudget {
            what: "the picture".into(),
            needed: u64::try_from(size.host_bytes()).unwrap_or(u64::MAX),
            allowed: u64::try_from(budget).unwrap_or(u64::MAX),
            message,
        }
        .into()),
        Err(_) => anyhow::bail!(message),
    }
}

/// Why `v` is no direction: it cannot be normalised, because its squared length overflows
/// f64 (a component above about 1e154) or underflows to 0 (every component below about
/// 1e-162).
fn not_a_direction(v: DVec3) -> Option<&'static str> {
    v.try_normalize().is_none().then_some(
        "too large or too small to normalise (its squared length overflows or underflows \
         f64); give components of moderate size, such as 1,1,1",
    )
}

fn parse_vec(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}': expected three numbers x,y,z"))?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) && (x, y, z) != (0.0, 0.0, 0.0) => {
            let d = DVec3::new(x, y, z);
            match not_a_direction(d) {
                Some(why) => Err(format!("'{s}': {why}")),
                None => Ok(d),
            }
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

/// The picture of one scheme: with a GPU evaluator, tessellated on the device straight into
/// the render pass's vertex and index buffers; otherwise evaluated and stitched on the host
/// and uploaded into buffers of the same layout, drawn by the same pipeline.
fn scheme_panels(
    mesh: &Mesh,
    table: &PatchTable,
    level: u32,
    opts: &RenderOptions,
    evaluator: &dyn Evaluator,
) -> anyhow::Result<crate::render::Panels> {
    if let Some(precision) = evaluator.gpu_precision() {
        let gpu = crate::cli::common::shared_gpu()?;
        let mut tess = GpuTessellator::new(&gpu.device, &gpu.queue, mesh, table, precision)?;
        // Levels whose buffers exceed the device's storage binding limit go the host way.
        if tess.check_level(level).is_ok() {
            return Ok(render_tessellated(&gpu, &mut tess, level, opts)?);
        }
    }
    let (surface, _, _) = stitch(mesh, table, evaluator, level)?;
    Ok(render_panels(
        &*crate::cli::common::shared_gpu()?,
        &surface,
        opts,
    )?)
}

/// Renders `schemes` of `mesh` (one row each), evaluated by `evaluator`, into `output`;
/// with `repair_folds`, each scheme's repaired mesh.
#[allow(clippy::too_many_arguments)]
pub fn render_schemes(
    mesh: &Mesh,
    schemes: &[Scheme],
    scheme_opts: &SchemeOptions,
    repair_folds: bool,
    level: u32,
    opts: &RenderOptions,
    evaluator: &dyn Evaluator,
    output: &std::path::Path,
) -> anyhow::Result<()> {
    let mut rows = Vec::new();
    for &scheme in schemes {
        // With --repair-folds the repaired mesh, whose new creases the surface is cut along.
        let (m, report) = if repair_folds {
            let opts = RepairOptions::default().with_scheme_options(*scheme_opts);
            let (fixed, report) = repair(mesh, scheme, &opts)?;
            (std::borrow::Cow::Owned(fixed), Some(report))
        } else {
            (std::borrow::Cow::Borrowed(mesh), None)
        };
        let table = PatchTable::build(&m, scheme, scheme_opts)?;
        if let Some(w) = repair_line(&mesh.name, &table, report.as_ref()) {
            out::stderr_line(&w);
        }
        rows.push(Row {
            label: scheme.to_string(),
            panels: scheme_panels(&m, &table, level, opts, evaluator)?,
        });
    }
    let what = match opts.shading {
        Shading::Normals => "unit normal components",
        Shading::Isophotes => "isophotes of the unit normal components",
    };
    let caption = format!(
        "{}, level {level}: {what}, view {:.2},{:.2},{:.2}",
        out::escape(&mesh.name),
        opts.view.x,
        opts.view.y,
        opts.view.z
    );
    write_png(output, &TEMP_FILES, &caption, &rows, opts.shading)?;
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
    // Refuse a directory, device or FIFO, and a file the input is read from, before any work.
    crate::io::atomic::resolve_output(&a.output)?;
    crate::io::atomic::refuse_input_files(&a.output, std::path::Path::new(&a.input.mesh))?;
    check_view_up(a.view, a.up)?;
    anyhow::ensure!(
        a.size >= MIN_PANEL,
        "--size {}: a panel is at least {MIN_PANEL} pixels",
        a.size
    );
    anyhow::ensure!(a.level != Some(0), "--level must be at least 1");
    // The render pass needs the device whatever the backend: open it before any work.
    let gpu = crate::cli::common::shared_gpu().map_err(|e| {
        anyhow::anyhow!("render draws on a Vulkan device and none could be opened ({e})")
    })?;
    let max = max_panel(&gpu);
    anyhow::ensure!(
        a.size <= max,
        "--size {} is larger than the {max} pixels this device can draw per panel",
        a.size
    );
    let mut mesh = a.input.load_mesh()?;
    // With --fair every row draws the fair mesh.
    if let Some((m, report)) = a.input.faired(&mesh, a.quiet)? {
        out::stderr_line(&report.to_text(&mesh.name));
        mesh = m;
    }
    // The surface is drawn in f32.
    if let Some(note) = super::common::f32_range(&mesh)? {
        out::stderr_line(&note);
    }
    let level = a.level.unwrap_or_else(|| auto_level(mesh.triangles.len()));
    check_level(&gpu, &mesh, level, a.level.is_some(), &a.memory.budget())?;
    let mut backend = a.backend.clone();
    backend.quiet |= a.quiet;
    // Pictures are drawn in f32: the GPU evaluates in f32 unless told otherwise.
    let evaluator = backend.evaluator(Precision::F32)?;
    let mut schemes = vec![a.input.scheme];
    schemes.extend(a.also.iter().copied().filter(|s| *s != a.input.scheme));
    let opts = RenderOptions {
        panel: a.size,
        view: a.view,
        up: a.up,
        shading: a.shading,
    };
    render_schemes(
        &mesh,
        &schemes,
        &a.input.scheme_options(),
        a.input.repair_folds,
        level,
        &opts,
        evaluator.as_ref(),
        &a.output,
    )?;
    if !a.quiet {
        out::stderr_line(&format!("wrote {}", a.output.display()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{check_view_up, parse_vec};
    use glam::DVec3;

    #[test]
    fn directions_that_cannot_be_normalised() {
        // The squared length overflows above about 1.3e154 and underflows below 1e-162.
        for s in ["1e308,1e308,1e308", "1e200,0,0", "0,-1e160,0", "1e-170,0,0"] {
            let e = parse_vec(s).unwrap_err();
            assert!(
                e.contains("too large or too small to normalise"),
                "{s}: {e}"
            );
        }
        for s in ["1,1,1", "1e150,0,0", "1e-150,0,0", "0,0,-3"] {
            assert!(parse_vec(s).is_ok(), "{s}");
        }
        // Given directly, not through the parser: named as such, not as parallel.
        let e = check_view_up(DVec3::splat(1e308), DVec3::Y)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--view 1e308,1e308,1e308: too large"), "{e}");
        let e = check_view_up(DVec3::Z, DVec3::new(0.0, 1e-200, 0.0))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--up 0.0,1e-200,0.0: too large"), "{e}");
        // A parallel pair is still called parallel, in the same words.
        let e = check_view_up(DVec3::Y, DVec3::new(0.0, 2.0, 0.0))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "--view 0,1,0 is parallel to --up 0,2,0: give an up direction across the view"
        );
    }
}
