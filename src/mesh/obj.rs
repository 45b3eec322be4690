//! Wavefront OBJ input.
//!
//! A parser of its own rather than `tobj`: `tobj` silently invents a normal (the previous
//! corner's) for face corners that give none when other faces do, and its errors carry no
//! line number. Here every defect names the file and the line, and a corner without a
//! normal gets an estimated one.

use std::path::Path;

use glam::DVec3;

use super::{normals, weld, LoadOptions, LoadReport, Mesh};
use crate::{Error, Result};

/// One face corner: position index and optional normal index (0-based, resolved).
#[derive(Clone, Copy)]
struct Corner {
    v: usize,
    vn: Option<usize>,
}

/// A face as read, with its line for errors found after the whole file is read.
struct Face {
    line: usize,
    corners: Vec<Corner>,
}

/// Reads a Wavefront OBJ file: polygons triangulated as fans, every face form (`v`,
/// `v/vt`, `v//vn`, `v/vt/vn`), negative (relative) indices, all objects and groups merged,
/// positions welded by exact coordinates, unused vertices dropped, per-corner normals kept
/// (renormalised), missing normals estimated with `opts.weighting`.
pub fn load_obj(path: &Path, opts: &LoadOptions) -> Result<Mesh> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count();
        Error::parse(path, line, "not UTF-8 text")
    })?;

    let mut positions: Vec<DVec3> = Vec::new();
    let mut normals_in: Vec<DVec3> = Vec::new();
    let mut texcoords = 0usize;
    let mut faces: Vec<Face> = Vec::new();
    let mut report = LoadReport::default();

    let mut pending = String::new();
    let mut start_line = 0;
    for (i, raw) in text.lines().enumerate() {
        // Backslash continues a statement on the next line.
        if pending.is_empty() {
            start_line = i + 1;
        }
        if let Some(body) = raw.strip_suffix('\\') {
            pending.push_str(body);
            pending.push(' ');
            continue;
        }
        pending.push_str(raw);
        let line = std::mem::take(&mut pending);
        let lineno = start_line;
        let err = |msg: String| Error::parse(path, lineno, msg);
        let content = line.split('#').next().unwrap_or("");
        let mut tok = content.split_whitespace();
        let Some(kw) = tok.next() else { continue };
        let numbers =
            |tok: std::str::SplitWhitespace, need: usize, what: &str| -> Result<[f64; 3]> {
                let vals: Vec<&str> = tok.collect();
                if vals.len() < need {
                    return Err(err(format!(
                        "{what} needs {need} numbers, found {}",
                        vals.len()
                    )));
                }
                let mut out = [0.0; 3];
                for (k, s) in vals.iter().take(need).enumerate() {
                    let x: f64 = s
                        .parse()
                        .map_err(|_| err(format!("{what}: '{s}' is not a number")))?;
                    if !x.is_finite() {
                        return Err(err(format!("{what}: non-finite coordinate '{s}'")));
                    }
                    out[k] = x;
                }
                Ok(out)
            };
        match kw {
            "v" => positions.push(DVec3::from_array(numbers(tok, 3, "vertex")?)),
            "vn" => {
                let n = DVec3::from_array(numbers(tok, 3, "normal")?);
                let len = n.length();
                if len == 0.0 || !len.is_finite() {
                    return Err(err("zero-length normal".into()));
                }
                normals_in.push(n / len);
            }
            "vt" => {
                numbers(tok, 1, "texture coordinate")?;
                texcoords += 1;
            }
            "f" => {
                let mut corners = Vec::new();
                for c in tok {
                    let parts: Vec<&str> = c.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(err(format!("malformed face corner '{c}'")));
                    }
                    let mut idx = [None; 3];
                    for (slot, s) in parts.iter().enumerate() {
                        if s.is_empty() {
                            continue;
                        }
                        let (what, have) = match slot {
                            0 => ("vertex", positions.len()),
                            1 => ("texture coordinate", texcoords),
                            _ => ("normal", normals_in.len()),
                        };
                        let k: i64 = s.parse().map_err(|_| {
                            err(format!("face corner '{c}': '{s}' is not an index"))
                        })?;
                        let resolved = if k > 0 {
                            (k - 1) as usize
                        } else if k < 0 && (-k) as usize <= have {
                            (have as i64 + k) as usize
                        } else if k == 0 {
                            return Err(err(format!(
                                "face corner '{c}': index 0 (OBJ counts from 1)"
                            )));
                        } else {
                            return Err(err(format!(
                                "face corner '{c}': {what} index {k} out of range (only {have} {what}s so far)"
                            )));
                        };
                        idx[slot] = Some(resolved);
                    }
                    corners.push(Corner {
                        v: idx[0].unwrap_or_default(),
                        vn: idx[2],
                    });
                }
                if corners.len() < 3 {
                    return Err(err(format!(
                        "face needs at least 3 corners, found {}",
                        corners.len()
                    )));
                }
                faces.push(Face {
                    line: lineno,
                    corners,
                });
            }
            _ => {}
        }
    }

    // Positive indices may point forward; check them against the final counts.
    for f in &faces {
        for c in &f.corners {
            if c.v >= positions.len() {
                return Err(Error::parse(
                    path,
                    f.line,
                    format!(
                        "vertex index {} out of range (the file has {} vertices)",
                        c.v + 1,
                        positions.len()
                    ),
                ));
            }
            if let Some(n) = c.vn.filter(|&n| n >= normals_in.len()) {
                return Err(Error::parse(
                    path,
                    f.line,
                    format!(
                        "normal index {} out of range (the file has {} normals)",
                        n + 1,
                        normals_in.len()
                    ),
                ));
            }
        }
    }

    // Triangulate as fans, then the one input weld (see `weld`).
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut corner_in: Vec<[Option<DVec3>; 3]> = Vec::new();
    for f in &faces {
        if f.corners.len() > 3 {
            report.polygons_triangulated += 1;
        }
        for k in 1..f.corners.len() - 1 {
            let c = [0, k, k + 1].map(|i| f.corners[i]);
            triangles.push(c.map(|c| c.v as u32));
            corner_in.push(c.map(|c| c.vn.map(|n| normals_in[n])));
        }
    }
    let out_pos = weld::weld(&positions, &mut triangles, &mut corner_in, &mut report)?;

    let name = super::display_name(path);
    if triangles.is_empty() {
        return Err(Error::mesh(
            path.display().to_string(),
            if faces.is_empty() {
                "empty mesh: no faces ('f' lines)"
            } else {
                "empty mesh: every face is degenerate"
            },
        ));
    }

    let missing = corner_in.iter().flatten().filter(|n| n.is_none()).count();
    report.normals_estimated = missing;
    let estimated = if missing > 0 {
        normals::vertex_normals(&out_pos, &triangles, opts.weighting)
    } else {
        Vec::new()
    };
    let corner_normals = triangles
        .iter()
        .zip(&corner_in)
        .map(|(t, n)| std::array::from_fn(|k| n[k].unwrap_or_else(|| estimated[t[k] as usize])))
        .collect();
    Ok(Mesh {
        name,
        positions: out_pos,
        triangles,
        corner_normals,
        load_report: report,
    })
}
