//! The picture around the panels (feature `cli`): a caption, rows of panels titled n_x,
//! n_y, n_z, and the legend (the colour ramp, or the isophotes' bands), drawn with
//! plotters (the shipped font) into an RGB canvas and written as a PNG through the
//! atomic-write helper.

use std::path::Path;

use plotters::prelude::*;

use super::isophotes::{isophote, BANDS_PER_UNIT};
use super::{ramp, Panels, Shading};
use crate::io::plot::{register_font, write_png_rgb};
use crate::io::TempFiles;
use crate::{Error, Result};

/// One row of a picture: a label (the scheme) and its panels.
pub struct Row {
    pub label: String,
    pub panels: Panels,
}

const MARGIN: u32 = 16;
const TITLE: u32 = 34;
const LEGEND: u32 = 70;

/// Composes rows of panels under `caption`, each panel titled n_x, n_y, n_z, with the
/// legend of `shading` (the colour ramp, or the isophotes' bands) below, and writes a PNG
/// to `path` atomically (the temporary file listed in `temp`).
pub fn write_png(
    path: &Path,
    temp: &TempFiles,
    caption: &str,
    rows: &[Row],
    shading: Shading,
) -> Result<()> {
    let panel = rows
        .first()
        .map(|r| r.panels.panel)
        .ok_or_else(|| Error::Invalid("render: nothing to draw".into()))?;
    if rows.iter().any(|r| r.panels.panel != panel) {
        return Err(Error::Invalid("render: rows of different sizes".into()));
    }
    let width = 3 * panel + 4 * MARGIN;
    let height = TITLE + rows.len() as u32 * (panel + TITLE) + LEGEND + MARGIN;
    // The panels go into an RGB canvas first, text and legend on top.
    let mut rgb = vec![255u8; (width * height * 3) as usize];
    let mut put = |x: u32, y: u32, c: [u8; 3]| {
        let i = 3 * (y * width + x) as usize;
        rgb[i..i + 3].copy_from_slice(&c);
    };
    for (r, row) in rows.iter().enumerate() {
        let top = TITLE + r as u32 * (panel + TITLE) + TITLE;
        for c in 0..3u32 {
            let left = MARGIN + c * (panel + MARGIN);
            for y in 0..panel {
                for x in 0..panel {
                    put(left + x, top + y, row.panels.pixel(c as usize, x, y));
                }
            }
        }
    }
    // The legend's colour bar.
    let bar_w = (3 * panel + 2 * MARGIN) / 2;
    let bar_x = (width - bar_w) / 2;
    let bar_y = height - MARGIN - LEGEND + 8;
    for x in 0..bar_w {
        let v = -1.0 + 2.0 * (x as f64 + 0.5) / bar_w as f64;
        for y in 0..18 {
            let colour = match shading {
                Shading::Normals => ramp(v),
                Shading::Isophotes => isophote(v),
            };
            put(bar_x + x, bar_y + y, colour);
        }
    }

    register_font();
    let drawn = (|| -> std::result::Result<(), String> {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        let font = |px: u32| ("sans-serif", px as f64).into_font().color(&BLACK);
        root.draw_text(caption, &font(20), (MARGIN as i32, 8))
            .map_err(|e| e.to_string())?;
        for (r, row) in rows.iter().enumerate() {
            let top = (TITLE + r as u32 * (panel + TITLE)) as i32;
            for (c, comp) in ["n_x", "n_y", "n_z"].iter().enumerate() {
                let left = (MARGIN + c as u32 * (panel + MARGIN)) as i32;
                root.draw_text(
                    &format!("{}: {comp}", row.label),
                    &font(18),
                    (left, top + 10),
                )
                .map_err(|e| e.to_string())?;
            }
        }
        for (k, v) in [-1.0, -0.5, 0.0, 0.5, 1.0].iter().enumerate() {
            let x = bar_x as i32 + (k as i32 * (bar_w as i32 - 1)) / 4;
            root.draw(&PathElement::new(
                vec![(x, bar_y as i32 + 18), (x, bar_y as i32 + 24)],
                BLACK,
            ))
            .map_err(|e| e.to_string())?;
            let label = format!("{v}");
            root.draw_text(
                &label,
                &font(15),
                (x - 4 * label.len() as i32, bar_y as i32 + 27),
            )
            .map_err(|e| e.to_string())?;
        }
        let legend = match shading {
            Shading::Normals => "normal component".to_string(),
            Shading::Isophotes => format!("bands of 1/{BANDS_PER_UNIT}"),
        };
        root.draw_text(
            &legend,
            &font(15),
            (bar_x as i32 + bar_w as i32 + 10, bar_y as i32 + 1),
        )
        .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())
    })();
    drawn.map_err(|e| Error::io(path, std::io::Error::other(format!("drawing failed: {e}"))))?;
    write_png_rgb(path, temp, width, height, &rgb)
}
