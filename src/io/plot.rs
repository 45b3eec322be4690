//! Log–log line plots (PNG and SVG) with plotters, text in the DejaVu Sans font shipped in
//! `assets/` (registered once as "sans-serif" through plotters' ab_glyph support, so no
//! system font is needed).

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use super::atomic::{write_atomic, write_atomic_with, TempFiles};
use crate::analysis::distance::{Series, SweepRow};
use crate::patch::Scheme;
use crate::{Error, Result};

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

/// Registers the shipped font under "sans-serif" (idempotent).
pub fn register_font() {
    REGISTER.call_once(|| {
        // The font is compiled in and valid; a failure would show as missing text, and
        // `render` checks for it below.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Writes `rgb` (`width` × `height` pixels, 3 bytes each, rows top to bottom) as an 8-bit
/// RGB PNG to `path`, atomically (the temporary file listed in `temp`).
pub fn write_png_rgb(
    path: &Path,
    temp: &TempFiles,
    width: u32,
    height: u32,
    rgb: &[u8],
) -> Result<()> {
    if rgb.len() != width as usize * height as usize * 3 {
        return Err(Error::Invalid(format!(
            "{}: {} bytes are not a {width} x {height} RGB picture",
            path.display(),
            rgb.len()
        )));
    }
    let err = |e: png::EncodingError| {
        Error::io(path, std::io::Error::other(format!("PNG encoding: {e}")))
    };
    write_atomic_with(path, temp, |w| {
        let mut enc = png::Encoder::new(w, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        // What plotters' own PNG output used (through the image crate): fast deflate with
        // an adaptive filter per row.
        enc.set_compression(png::Compression::Fast);
        enc.set_filter(png::FilterType::Sub);
        enc.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut writer = enc.write_header().map_err(err)?;
        writer.write_image_data(rgb).map_err(err)?;
        writer.finish().map_err(err)
    })
}

/// One line of a plot.
#[derive(Clone, Debug)]
pub struct Line {
    pub label: String,
    pub color: RGBColor,
    /// Drawn thicker (the scheme the study is about).
    pub bold: bool,
    pub points: Vec<(f64, f64)>,
}

/// One log–log panel.
#[derive(Clone, Debug)]
pub struct Panel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub lines: Vec<Line>,
}

/// A figure: panels side by side under a common caption.
#[derive(Clone, Debug)]
pub struct Figure {
    pub caption: String,
    pub panels: Vec<Panel>,
    /// Pixel size of one panel.
    pub panel_size: (u32, u32),
}

fn plot_err(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::io(path, std::io::Error::other(format!("plotting failed: {e}")))
}

/// Log range covering `values` with some margin, on whole-ish decades.
fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() || hi <= 0.0 {
        return (1e-3, 1.0);
    }
    (lo / 1.6, hi * 1.6)
}

/// Grid of a log axis over `lo..hi` (0 < lo < hi): labelled points (bold grid lines) and
/// minor grid lines. Labels go at 1, 2 and 5 × 10^k when the range spans at most four
/// decades, at 10^k beyond; where that leaves fewer than four labels (a range of about a
/// decade), every integer mantissa is labelled. Minor lines go at the other integer
/// mantissas, only when the range spans at most eight decades (beyond, they would crowd).
pub fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return (Vec::new(), Vec::new());
    }
    let decades = (hi / lo).log10();
    let points = |mantissas: &[u32]| -> Vec<f64> {
        let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        (k0..=k1)
            .flat_map(|k| mantissas.iter().map(move |&m| m as f64 * 10f64.powi(k)))
            // Rounded to 12 significant digits: 10^k in floating point is not exact.
            .map(|v| format!("{v:.11e}").parse::<f64>().unwrap_or(v))
            .filter(|v| *v >= lo && *v <= hi)
            .collect()
    };
    let all: Vec<u32> = (1..=9).collect();
    let mut bold = points(if decades <= 4.0 { &[1, 2, 5] } else { &[1] });
    if bold.len() < 4 {
        bold = points(&all);
    }
    let light = if decades <= 8.0 {
        points(&all)
            .into_iter()
            .filter(|v| !bold.contains(v))
            .collect()
    } else {
        Vec::new()
    };
    (bold, light)
}

/// Label of a log-axis key point: the number as written (no exponent) from 1 to 10^6,
/// "2e-3" style otherwise.
fn tick_label(v: &f64) -> String {
    if (1.0..1e6).contains(v) {
        format!("{v:.0}")
    } else {
        format!("{v:.0e}")
    }
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    fig: &Figure,
) -> std::result::Result<(), String>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let root = root
        .titled(&fig.caption, ("sans-serif", 26))
        .map_err(|e| e.to_string())?;
    let areas = root.split_evenly((1, fig.panels.len().max(1)));
    // All panels share the y range so they compare at a glance.
    let ys = log_range(
        fig.panels
            .iter()
            .flat_map(|p| p.lines.iter().flat_map(|l| l.points.iter().map(|q| q.1))),
    );
    for (area, panel) in areas.iter().zip(&fig.panels) {
        let xs = log_range(
            panel
                .lines
                .iter()
                .flat_map(|l| l.points.iter().map(|q| q.0)),
        );
        // Grid lines and labels chosen here (plotters' own log key points label too few
        // points on short ranges and crowd minor lines on some).
        let axis = |(lo, hi): (f64, f64)| {
            let (bold, light) = log_ticks(lo, hi);
            (lo..hi)
                .log_scale()
                .with_key_points(bold)
                .with_light_points(light)
        };
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(48)
            .y_label_area_size(78)
            .build_cartesian_2d(axis(xs), axis(ys))
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc(&panel.x_label)
            .y_desc(&panel.y_label)
            .axis_desc_style(("sans-serif", 17))
            .label_style(("sans-serif", 14))
            .x_label_formatter(&tick_label)
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .light_line_style(RGBColor(235, 235, 235))
            .bold_line_style(RGBColor(200, 200, 200))
            .draw()
            .map_err(|e| e.to_string())?;
        for line in &panel.lines {
            let width = if line.bold { 3 } else { 2 };
            let style = ShapeStyle::from(line.color).stroke_width(width);
            let color = line.color;
            chart
                .draw_series(LineSeries::new(line.points.iter().copied(), style))
                .map_err(|e| e.to_string())?
                .label(&line.label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 22, y)], color.stroke_width(width))
                });
            chart
                .draw_series(
                    line.points
                        .iter()
                        .map(|&p| Circle::new(p, 3, color.filled())),
                )
                .map_err(|e| e.to_string())?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .label_font(("sans-serif", 15))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())
}

/// Writes `fig` as `stem.png` and `stem.svg` (each atomically, the temporary files listed
/// in `temp`); returns both paths.
pub fn write_figure(stem: &Path, temp: &TempFiles, fig: &Figure) -> Result<[PathBuf; 2]> {
    register_font();
    let size = (
        fig.panel_size.0 * fig.panels.len().max(1) as u32,
        fig.panel_size.1,
    );
    let png = stem.with_extension("png");
    let svg = stem.with_extension("svg");

    // SVG: render to a string, then write atomically.
    let mut text = String::new();
    draw(
        SVGBackend::with_string(&mut text, size).into_drawing_area(),
        fig,
    )
    .map_err(|e| plot_err(&svg, e))?;
    if !text.contains("<text") {
        return Err(plot_err(&svg, "no text was drawn (font not registered)"));
    }
    write_atomic(&svg, temp, |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })?;

    // PNG: drawn into an RGB buffer, then encoded into the file atomically.
    let mut rgb = vec![255u8; size.0 as usize * size.1 as usize * 3];
    draw(
        BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area(),
        fig,
    )
    .map_err(|e| plot_err(&png, e))?;
    write_png_rgb(&png, temp, size.0, size.1, &rgb)?;
    Ok([png, svg])
}

/// Line colours in registry order ([`crate::patch::SCHEMES`]): g1, phong, nagata,
/// nagata-guarded, nlsa, pn, pn-normals, flat, then spares, so a new scheme needs no edit
/// here (past the spares the palette repeats).
const PALETTE: [RGBColor; 12] = [
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(31, 119, 180),
    RGBColor(23, 190, 207),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(188, 189, 34),
    RGBColor(110, 110, 110),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(0, 0, 0),
    RGBColor(0, 90, 50),
];

/// Colour of a scheme, the same in every plot.
pub fn scheme_color(s: Scheme) -> RGBColor {
    PALETTE[s as usize % PALETTE.len()]
}

/// The lines of one series of the distance study: mean distance against triangles, one
/// line per scheme. Schemes whose values are identical to an earlier scheme's (same
/// geometry, e.g. `pn` and `pn-normals`) share its line, labelled "pn = pn-normals".
pub fn distance_lines(rows: &[SweepRow], series: Series) -> Vec<Line> {
    let mut schemes: Vec<Scheme> = Vec::new();
    for r in rows.iter().filter(|r| r.series == series) {
        if !schemes.contains(&r.scheme) {
            schemes.push(r.scheme);
        }
    }
    // Schemes sharing a line, and the line.
    type Merged = (Vec<Scheme>, Vec<(f64, f64)>);
    let mut lines: Vec<Merged> = Vec::new();
    for s in schemes {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.series == series && r.scheme == s)
            .map(|r| (r.triangles as f64, r.mean))
            .collect();
        match lines.iter_mut().find(|(_, p)| *p == pts) {
            Some((names, _)) => names.push(s),
            None => lines.push((vec![s], pts)),
        }
    }
    lines
        .into_iter()
        .map(|(names, points)| Line {
            label: names
                .iter()
                .map(|s| s.name())
                .collect::<Vec<_>>()
                .join(" = "),
            color: scheme_color(names[0]),
            bold: names[0] == Scheme::G1,
            points,
        })
        .collect()
}

/// Figure 17: mean distance to the unit sphere on icospheres.
pub fn sphere_figure(rows: &[SweepRow]) -> Figure {
    Figure {
        caption: "Distance to the sphere (icospheres, exact normals, 16 segments per edge)".into(),
        panels: vec![Panel {
            title: "unit sphere".into(),
            x_label: "triangles".into(),
            y_label: "mean distance to the sphere".into(),
            lines: distance_lines(rows, Series::Icosphere),
        }],
        panel_size: (900, 680),
    }
}

/// Figure 18: mean distance to the torus, analytic and averaged normals side by side.
pub fn torus_figure(rows: &[SweepRow]) -> Figure {
    let panel = |series: Series, title: &str| Panel {
        title: title.into(),
        x_label: "triangles".into(),
        y_label: "mean distance to the torus".into(),
        lines: distance_lines(rows, series),
    };
    Figure {
        caption:
            "Distance to the torus R = 1, r = 0.5 (n × n grids, n = 5…30, 16 segments per edge)"
                .into(),
        panels: vec![
            panel(Series::TorusAnalytic, "analytic normals"),
            panel(Series::TorusAveraged, "averaged normals"),
        ],
        panel_size: (820, 680),
    }
}

#[cfg(feature = "cli")]
#[cfg(test)]
mod tests {
    use crate::io::plot::log_ticks;

    /// The sphere's x range (20 to 5120 triangles with the 1.6 margin): 1, 2, 5 × 10^k,
    /// eight labels; minor lines at the other mantissas, never on a label.
    #[test]
    fn log_ticks_label_key_points() {
        let (bold, light) = log_ticks(20.0 / 1.6, 5120.0 * 1.6);
        assert_eq!(
            bold,
            [20.0, 50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0, 5000.0]
        );
        // 20..90, 100..900, 1000..8000 (25 mantissa points), less the 8 labels.
        assert_eq!(light.len(), 8 + 9 + 8 - 8, "{light:?}");
        assert!(light.iter().all(|v| !bold.contains(v)));
        assert!(light.contains(&30.0) && light.contains(&8000.0) && !light.contains(&10.0));
        // The y range of the study (1e-8..0.2, seven decades): decades only, minor lines.
        let (bold, light) = log_ticks(5e-9, 0.2);
        assert_eq!(bold, [1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1]);
        // 5e-9..9e-9, seven full decades 1e-8..9e-2, 1e-1 and 2e-1, less the 8 labels.
        assert_eq!(light.len(), 5 + 7 * 9 + 2 - 8, "{light:?}");
        // Under a decade: every integer mantissa labelled, at least four labels.
        let (bold, light) = log_ticks(3.5, 9.5);
        assert_eq!(bold, [4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
        assert!(light.is_empty());
        // Twelve decades: decades only, no minor lines.
        let (bold, light) = log_ticks(1e-12, 1.0);
        assert_eq!(bold.len(), 13);
        assert!(light.is_empty());
        // Not a log range: nothing.
        assert_eq!(log_ticks(0.0, 1.0), (vec![], vec![]));
    }
}
