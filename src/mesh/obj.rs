//! OBJ input through `tobj`, preceded by a line-by-line check that turns every defect a
//! user can make into an error naming the file and the line.

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;

use super::{normals, LoadOptions, LoadReport, Mesh};
use crate::{Error, Result};

/// What the line check counted.
#[derive(Debug, Default)]
struct ObjCounts {
    polygons: usize,
}

/// Reads a Wavefront OBJ file: polygons triangulated (fan), every face form (`v`, `v/vt`,
/// `v//vn`, `v/vt/vn`), negative indices, all objects and groups merged, positions welded
/// by exact coordinates, unused vertices dropped, per-corner normals kept (renormalised),
/// missing normals estimated.
pub fn load_obj(path: &Path, opts: &LoadOptions) -> Result<Mesh> {
    let text = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let text = String::from_utf8(text).map_err(|e| {
        Error::parse(
            path,
            line_of_byte(e.as_bytes(), e.utf8_error().valid_up_to()),
            "not UTF-8 text",
        )
    })?;
    let counts = check_lines(path, &text)?;

    let load = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &load, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| Error::mesh(path.display().to_string(), format!("OBJ parse error: {e}")))?;

    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string());
    let mut report = LoadReport {
        polygons_triangulated: counts.polygons,
        ..Default::default()
    };

    // Weld positions by exact coordinates; only referenced positions get an id.
    let mut weld: HashMap<[u64; 3], u32> = HashMap::new();
    let mut positions: Vec<DVec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut normals_in: Vec<[Option<DVec3>; 3]> = Vec::new();
    let mut referenced = 0usize;
    for model in &models {
        let m = &model.mesh;
        let pos = |i: u32| {
            let i = i as usize * 3;
            DVec3::new(m.positions[i], m.positions[i + 1], m.positions[i + 2])
        };
        let has_normals = !m.normal_indices.is_empty() && m.normal_indices.len() == m.indices.len();
        let mut local: HashMap<u32, u32> = HashMap::new();
        for (f, tri) in m.indices.chunks_exact(3).enumerate() {
            let mut t = [0u32; 3];
            for k in 0..3 {
                t[k] = *local.entry(tri[k]).or_insert_with(|| {
                    referenced += 1;
                    let p = pos(tri[k]);
                    let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
                    *weld.entry(key).or_insert_with(|| {
                        positions.push(p);
                        (positions.len() - 1) as u32
                    })
                });
            }
            if t[0] == t[1] || t[1] == t[2] || t[2] == t[0] {
                report.degenerate_triangles_dropped += 1;
                continue;
            }
            let n = if has_normals {
                std::array::from_fn(|k| {
                    let i = m.normal_indices[f * 3 + k] as usize * 3;
                    m.normals
                        .get(i..i + 3)
                        .map(|v| DVec3::new(v[0], v[1], v[2]).normalize())
                })
            } else {
                [None; 3]
            };
            triangles.push(t);
            normals_in.push(n);
        }
    }
    let total_vertices = text
        .lines()
        .filter(|l| l.trim_start().starts_with("v "))
        .count();
    report.unused_vertices_dropped = total_vertices.saturating_sub(referenced);
    report.vertices_welded = referenced - positions.len();

    let missing = normals_in.iter().flatten().filter(|n| n.is_none()).count();
    report.normals_estimated = missing;
    let estimated = if missing > 0 {
        normals::vertex_normals(&positions, &triangles, opts.weighting)
    } else {
        Vec::new()
    };
    let corner_normals = triangles
        .iter()
        .zip(&normals_in)
        .map(|(t, n)| std::array::from_fn(|k| n[k].unwrap_or_else(|| estimated[t[k] as usize])))
        .collect();
    let mesh = Mesh {
        name,
        positions,
        triangles,
        corner_normals,
        load_report: report,
    };
    if mesh.triangles.is_empty() {
        return Err(Error::mesh(
            path.display().to_string(),
            "empty mesh: no triangles (no usable 'f' lines)",
        ));
    }
    Ok(mesh)
}

fn line_of_byte(bytes: &[u8], offset: usize) -> usize {
    1 + bytes[..offset].iter().filter(|&&b| b == b'\n').count()
}

/// Checks every `v`, `vn`, `vt` and `f` line: numbers parse and are finite, normals are not
/// zero, face indices are in range and not zero, faces have at least three corners.
fn check_lines(path: &Path, text: &str) -> Result<ObjCounts> {
    let mut counts = ObjCounts::default();
    let (mut nv, mut nt, mut nn) = (0i64, 0i64, 0i64);
    // Positive indices may only be checked once every element has been counted.
    let mut forward: Vec<(usize, i64, usize)> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let lineno = i + 1;
        let err = |msg: String| Error::parse(path, lineno, msg);
        let line = line.split('#').next().unwrap_or("");
        let mut tok = line.split_whitespace();
        let Some(kw) = tok.next() else { continue };
        let floats =
            |tok: std::str::SplitWhitespace, need: usize, what: &str| -> Result<Vec<f64>> {
                let vals: Vec<&str> = tok.collect();
                if vals.len() < need {
                    return Err(err(format!(
                        "'{kw}' needs {need} numbers, found {}",
                        vals.len()
                    )));
                }
                vals.iter()
                    .take(need)
                    .map(|s| {
                        let x: f64 = s
                            .parse()
                            .map_err(|_| err(format!("{what}: '{s}' is not a number")))?;
                        if x.is_finite() {
                            Ok(x)
                        } else {
                            Err(err(format!("{what}: non-finite coordinate '{s}'")))
                        }
                    })
                    .collect()
            };
        match kw {
            "v" => {
                floats(tok, 3, "vertex")?;
                nv += 1;
            }
            "vt" => {
                floats(tok, 1, "texture coordinate")?;
                nt += 1;
            }
            "vn" => {
                let n = floats(tok, 3, "normal")?;
                if n.iter().all(|&x| x == 0.0) {
                    return Err(err("zero-length normal".into()));
                }
                nn += 1;
            }
            "f" => {
                let corners: Vec<&str> = tok.collect();
                if corners.len() < 3 {
                    return Err(err(format!(
                        "face needs at least 3 corners, found {}",
                        corners.len()
                    )));
                }
                if corners.len() > 3 {
                    counts.polygons += 1;
                }
                for c in corners {
                    let parts: Vec<&str> = c.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(err(format!("malformed face corner '{c}'")));
                    }
                    for (slot, s) in parts.iter().enumerate() {
                        if s.is_empty() {
                            continue;
                        }
                        let (what, have) = match slot {
                            0 => ("vertex", nv),
                            1 => ("texture coordinate", nt),
                            _ => ("normal", nn),
                        };
                        let idx: i64 = s.parse().map_err(|_| {
                            err(format!("face corner '{c}': '{s}' is not an index"))
                        })?;
                        if idx == 0 {
                            return Err(err(format!(
                                "face corner '{c}': index 0 (OBJ counts from 1)"
                            )));
                        }
                        if idx < 0 && -idx > have {
                            return Err(err(format!(
                                "face corner '{c}': {what} index {idx} out of range (only {have} {what}s so far)"
                            )));
                        }
                        if idx > 0 {
                            forward.push((lineno, idx, slot));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    for (lineno, idx, slot) in forward {
        let (what, have) = match slot {
            0 => ("vertex", nv),
            1 => ("texture coordinate", nt),
            _ => ("normal", nn),
        };
        if idx > have {
            return Err(Error::parse(
                path,
                lineno,
                format!("{what} index {idx} out of range (the file has {have} {what}s)"),
            ));
        }
    }
    Ok(counts)
}
