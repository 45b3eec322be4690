//! The point-normal mesh format `.pn` (version 1): positions, vertex normals, optional
//! per-corner normals and triangles, as text with full f64 round-trip precision. The
//! Blender add-on (`blender/`) writes it; `docs/formats.md` documents it.
//!
//! ```text
//! g1tess-pn 1
//! # comments and blank lines anywhere after the header
//! counts V T C
//! v x y z nx ny nz      (V lines: vertex i = i-th v line, 0-based; position, vertex normal)
//! t a b c               (T lines: triangle, 0-based vertex ids, counter-clockwise)
//! c t k nx ny nz        (C lines: normal of corner k ∈ {0,1,2} of triangle t, 0-based,
//!                        replacing the vertex normal there: sharp edges, custom normals)
//! ```
//!
//! Records may come in any order after `counts`; the counts must match what the file holds
//! (a truncated file is an error). Positions are welded by exact coordinates like OBJ input
//! (with [`super::weld`]: `-0.0` equals `0.0`; each corner keeps its own normal), unused vertices and triangles with a repeated vertex
//! are dropped and reported, and every normal is renormalised.

use std::path::Path;

use glam::DVec3;
use rayon::prelude::*;

use super::text::{self, echo, Tokens};
use super::{normals, weld, LoadReport, Mesh, Source};
use crate::{Error, Result};

/// The first line of every version-1 file.
pub const HEADER: &str = "g1tess-pn 1";

/// Reads a `.pn` file (see the module documentation).
///
/// The file is read in chunks of whole lines, each split into blocks parsed in parallel; any
/// defect sends the file through the same parser once more, sequentially, which reports the
/// first defect with its line (errors cost a second pass, valid files do not).
pub fn load_pn(src: Source<'_>) -> Result<Mesh> {
    let path = src.path();
    let raw = match pass(src, true) {
        Some(Ok(raw)) if raw.consistent() => raw,
        Some(Err(e)) => return Err(e),
        _ => match pass(src, false) {
            Some(r) => r?,
            None => {
                return Err(Error::Invalid(format!(
                    "{}: internal error: the sequential pass asked for another",
                    path.display()
                )))
            }
        },
    };
    build(path, raw)
}

/// The file's records. Lines are kept in the sequential pass only (for its errors).
#[derive(Default)]
struct Raw {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    triangle_lines: Vec<usize>,
    /// (triangle, corner, normal).
    corners: Vec<(usize, usize, DVec3)>,
    corner_lines: Vec<usize>,
    counts: Option<[usize; 3]>,
    /// Whether the header line has been read.
    header: bool,
    /// Whether records before a counts line are an error here (the start of the file).
    expect_counts: bool,
    /// Number of the last line.
    last: usize,
}

impl Raw {
    /// What a parallel pass checks before the records are used: the counts match, every
    /// index is in range and no corner is given twice. Anything else is left to the
    /// sequential pass, which names the line.
    fn consistent(&self) -> bool {
        let (nv, nt) = (self.positions.len(), self.triangles.len());
        if self.counts != Some([nv, nt, self.corners.len()]) {
            return false;
        }
        if self.triangles.iter().flatten().any(|&v| v as usize >= nv) {
            return false;
        }
        let mut seen = vec![0u8; nt];
        self.corners.iter().all(|&(t, k, _)| {
            t < nt && {
                let bit = 1 << k;
                let fresh = seen[t] & bit == 0;
                seen[t] |= bit;
                fresh
            }
        })
    }

    fn append(&mut self, b: Raw) {
        self.positions.extend_from_slice(&b.positions);
        self.normals.extend_from_slice(&b.normals);
        self.triangles.extend_from_slice(&b.triangles);
        self.triangle_lines.extend_from_slice(&b.triangle_lines);
        self.corners.extend_from_slice(&b.corners);
        self.corner_lines.extend_from_slice(&b.corner_lines);
    }

    /// The common records in one pass over their bytes: `v` with exactly six plain numbers
    /// and `t` with exactly three plain indices (digits only, within u32), blanks between
    /// them and nothing after. Returns false, having changed nothing, for anything else
    /// (another record, a comment, a value out of range, a defect), which the general path
    /// of [`Raw::line`] then reads: results and errors are the same whichever path reads a
    /// line.
    #[inline]
    fn fast(&mut self, line: &str) -> bool {
        match line.as_bytes() {
            [b'v', b' ' | b'\t', ..] => {
                let Some(f) = text::plain_numbers::<6>(&line[2..]) else {
                    return false;
                };
                let p = DVec3::new(f[0], f[1], f[2]);
                if p.abs().max_element() > normals::MAX_COORD {
                    return false;
                }
                let Some(n) = normals::unit(DVec3::new(f[3], f[4], f[5])) else {
                    return false;
                };
                self.positions.push(p);
                self.normals.push(n);
            }
            [b't', b' ' | b'\t', rest @ ..] => {
                let mut t = [0u32; 3];
                let mut i = 0;
                for v in &mut t {
                    while i < rest.len() && text::is_blank(rest[i]) {
                        i += 1;
                    }
                    let start = i;
                    let mut k = 0u64;
                    while i < rest.len() && rest[i].is_ascii_digit() && i - start < 10 {
                        k = k * 10 + u64::from(rest[i] - b'0');
                        i += 1;
                    }
                    if i == start || (i < rest.len() && !text::is_blank(rest[i])) {
                        return false;
                    }
                    let Ok(k) = u32::try_from(k) else {
                        return false;
                    };
                    *v = k;
                }
                if !rest[i..].iter().all(|&c| text::is_blank(c)) {
                    return false;
                }
                self.triangles.push(t);
            }
            _ => return false,
        }
        true
    }

    /// Parses one line. `sequential` keeps lines; a parallel block assumes the counts line
    /// came before it (checked when the blocks are joined).
    fn line(&mut self, path: &Path, sequential: bool, lineno: usize, line: &str) -> Result<()> {
        let err = |msg: String| Error::parse(path, lineno, msg);
        self.last = lineno;
        if !sequential
            && self.header
            && !(self.counts.is_none() && self.expect_counts)
            && self.fast(line)
        {
            return Ok(());
        }
        if !self.header {
            self.header = true;
            let l = line.trim_end();
            if l == HEADER {
                return Ok(());
            }
            if l.starts_with("g1tess-pn ") {
                return Err(Error::unsupported(
                    format!("{}:{lineno}", path.display()),
                    format!(
                        "unsupported version '{}' (this g1tess reads '{HEADER}')",
                        echo(l)
                    ),
                ));
            }
            return Err(err(format!(
                "not a point-normal file: the first line must be '{HEADER}'"
            )));
        }
        let mut tok = Tokens::new(line);
        let Some(kw) = tok.next() else {
            return Ok(());
        };
        let mut fields = [""; 6];
        let mut found = 0;
        for t in tok {
            if let Some(f) = fields.get_mut(found) {
                *f = t;
            }
            found += 1;
        }
        let need = |n: usize| -> Result<()> {
            if found == n {
                Ok(())
            } else {
                Err(err(format!(
                    "'{}' needs {n} fields, found {found}",
                    echo(kw)
                )))
            }
        };
        let float = |s: &str, what: &str| -> Result<f64> {
            let x = text::parse_f64(s)
                .ok_or_else(|| err(format!("{what}: '{}' is not a number", echo(s))))?;
            if x.is_finite() {
                Ok(x)
            } else {
                Err(err(format!("{what}: non-finite value '{}'", echo(s))))
            }
        };
        let index = |s: &str, what: &str| -> Result<usize> {
            let v = if s.starts_with('-') {
                None
            } else if s.len() <= 18 {
                text::parse_i64(s).map(|v| v as usize)
            } else {
                s.parse().ok()
            };
            v.ok_or_else(|| {
                err(format!(
                    "{what}: '{}' is not an index (0-based integer)",
                    echo(s)
                ))
            })
        };
        let normal = |f: &[&str]| -> Result<DVec3> {
            let n = DVec3::new(
                float(f[0], "normal")?,
                float(f[1], "normal")?,
                float(f[2], "normal")?,
            );
            normals::unit(n).ok_or_else(|| err("zero-length normal".into()))
        };
        if kw != "counts" && self.counts.is_none() && self.expect_counts {
            return Err(err(format!(
                "'{}' before the 'counts V T C' line (it must follow the header)",
                echo(kw)
            )));
        }
        match kw.as_bytes() {
            b"counts" => {
                if self.counts.is_some() {
                    return Err(err("a second 'counts' line".into()));
                }
                need(3)?;
                self.counts = Some([
                    index(fields[0], "vertex count")?,
                    index(fields[1], "triangle count")?,
                    index(fields[2], "corner normal count")?,
                ]);
            }
            b"v" => {
                need(6)?;
                let mut p = [0.0; 3];
                for k in 0..3 {
                    p[k] = float(fields[k], "vertex")?;
                    if p[k].abs() > normals::MAX_COORD {
                        return Err(err(format!(
                            "vertex: coordinate '{}' above {:e} in magnitude (products of \
                             such coordinates overflow)",
                            echo(fields[k]),
                            normals::MAX_COORD
                        )));
                    }
                }
                self.positions.push(DVec3::from_array(p));
                self.normals.push(normal(&fields[3..])?);
            }
            b"t" => {
                need(3)?;
                let mut t = [0u32; 3];
                for k in 0..3 {
                    let i = index(fields[k], "triangle")?;
                    t[k] = u32::try_from(i)
                        .map_err(|_| err(format!("triangle: vertex index {i} too large")))?;
                }
                self.triangles.push(t);
                if sequential {
                    self.triangle_lines.push(lineno);
                }
            }
            b"c" => {
                need(5)?;
                let t = index(fields[0], "corner normal: triangle")?;
                let k = index(fields[1], "corner normal: corner")?;
                if k > 2 {
                    return Err(err(format!(
                        "corner normal: corner {k} out of range (0, 1 or 2)"
                    )));
                }
                self.corners.push((t, k, normal(&fields[2..5])?));
                if sequential {
                    self.corner_lines.push(lineno);
                }
            }
            _ => {
                return Err(err(format!(
                    "unknown record '{}' (expected v, t or c)",
                    echo(kw)
                )))
            }
        }
        Ok(())
    }
}

/// One pass over the file. `None`: a parallel pass found something to leave to the
/// sequential one.
fn pass(src: Source<'_>, parallel: bool) -> Option<Result<Raw>> {
    let path = src.path();
    let mut raw = Raw {
        expect_counts: true,
        ..Default::default()
    };
    let mut retry = false;
    let blocks = 2 * rayon::current_num_threads();
    let done = text::for_each_chunk(src, |chunk, first_line| {
        if !parallel {
            let text = text::utf8(path, chunk, first_line)?;
            return text::statements(path, text, first_line, false, |line, s| {
                raw.line(path, true, line, s)
            });
        }
        // The file's first block reads the header and must reach the counts line before
        // any record; later blocks read records only.
        let pieces = if chunk.len() < 1 << 16 {
            vec![chunk]
        } else {
            text::split(chunk, blocks)
        };
        let starts_file = !raw.header;
        let parsed: Vec<Option<Raw>> = pieces
            .par_iter()
            .enumerate()
            .map(|(i, piece)| {
                let at_start = starts_file && i == 0;
                let mut b = Raw {
                    header: !at_start,
                    expect_counts: at_start,
                    ..Default::default()
                };
                let text = std::str::from_utf8(piece).ok()?;
                text::statements(path, text, 1, false, |line, s| b.line(path, false, line, s))
                    .ok()?;
                Some(b)
            })
            .collect();
        for (i, b) in parsed.into_iter().enumerate() {
            match b {
                Some(b) if !(starts_file && i == 0) && b.counts.is_some() => retry = true,
                Some(b) if starts_file && i == 0 => {
                    raw.header = true;
                    raw.counts = b.counts;
                    raw.append(b);
                }
                Some(b) => raw.append(b),
                None => retry = true,
            }
            if retry || raw.counts.is_none() {
                retry = true;
                // Stop reading: the sequential pass starts over.
                return Err(Error::Invalid(String::new()));
            }
        }
        Ok(0)
    });
    if retry {
        return None;
    }
    Some(done.and_then(|()| {
        if parallel {
            return Ok(raw);
        }
        let last = raw.last.max(1);
        if !raw.header {
            return Err(Error::parse(
                path,
                1,
                format!("not a point-normal file: the first line must be '{HEADER}'"),
            ));
        }
        let Some([nv, nt, nc]) = raw.counts else {
            return Err(Error::parse(path, last, "no 'counts V T C' line"));
        };
        for (what, declared, found) in [
            ("vertices", nv, raw.positions.len()),
            ("triangles", nt, raw.triangles.len()),
            ("corner normals", nc, raw.corners.len()),
        ] {
            if declared != found {
                return Err(Error::parse(
                    path,
                    last,
                    format!(
                        "'counts' declares {declared} {what}, the file holds {found} (truncated?)"
                    ),
                ));
            }
        }
        Ok(raw)
    }))
}

/// Checks indices, applies corner normals, welds and drops like the OBJ loader.
fn build(path: &Path, raw: Raw) -> Result<Mesh> {
    let nv = raw.positions.len();
    for (k, t) in raw.triangles.iter().enumerate() {
        if let Some(&i) = t.iter().find(|&&i| i as usize >= nv) {
            return Err(Error::parse(
                path,
                raw.triangle_lines.get(k).copied().unwrap_or(0),
                format!("triangle: vertex index {i} out of range (the file has {nv} vertices)"),
            ));
        }
    }
    let mut corner_normals: Vec<[DVec3; 3]> = raw
        .triangles
        .par_iter()
        .map(|t| t.map(|v| raw.normals[v as usize]))
        .collect();
    let mut seen = vec![[false; 3]; raw.triangles.len()];
    for (i, &(t, k, n)) in raw.corners.iter().enumerate() {
        let line = raw.corner_lines.get(i).copied().unwrap_or(0);
        if t >= raw.triangles.len() {
            return Err(Error::parse(
                path,
                line,
                format!(
                    "corner normal: triangle {t} out of range (the file has {} triangles)",
                    raw.triangles.len()
                ),
            ));
        }
        if std::mem::replace(&mut seen[t][k], true) {
            return Err(Error::parse(
                path,
                line,
                format!("corner normal: corner {k} of triangle {t} given twice"),
            ));
        }
        corner_normals[t][k] = n;
    }

    // The one input weld (see `weld`): each corner keeps its own normal.
    let mut report = LoadReport::default();
    let mut triangles = raw.triangles;
    let mut normals = corner_normals;
    let positions = weld::weld(
        &raw.positions,
        &mut triangles,
        &mut normals,
        weld::Order::Input,
        &mut report,
    )?;
    let name = super::display_name(path);
    if triangles.is_empty() {
        return Err(Error::mesh(
            path.display().to_string(),
            if report.degenerate_triangles_dropped > 0 {
                "empty mesh: every triangle is degenerate (repeated or collinear corners, or \
                 an area below the smallest f64)"
            } else {
                "empty mesh: no triangles"
            },
        ));
    }
    Ok(Mesh {
        name,
        positions,
        triangles,
        corner_normals: normals,
        attributes: Default::default(),
        load_report: report,
    })
}

#[cfg(test)]
mod tests {
    use crate::mesh::generators::icosphere;
    use crate::mesh::pn_file::HEADER;
    use crate::LoadOptions;
    use crate::Mesh;
    use crate::Result;
    use crate::{PatchTable, Scheme, SchemeOptions};
    use glam::DVec3;

    /// A scratch file that is removed when dropped (straight in the temporary directory,
    /// so nothing stays behind).
    struct Scratch(std::path::PathBuf);
    impl Scratch {
        fn new(name: &str, text: impl AsRef<[u8]>) -> Scratch {
            let p = std::env::temp_dir().join(format!("g1tess-pn-{}-{name}", std::process::id()));
            std::fs::write(&p, text).unwrap();
            Scratch(p)
        }
    }
    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    /// Writes a mesh the way the Blender add-on does: shortest round-trip decimal form of
    /// every f64 (Rust's `{:?}` and Python's `repr` agree on that), one vertex normal per
    /// vertex taken from the first corner that uses it.
    fn to_pn(mesh: &Mesh) -> String {
        let mut vn = vec![DVec3::ZERO; mesh.positions.len()];
        for (t, n) in mesh.triangles.iter().zip(&mesh.corner_normals) {
            for k in 0..3 {
                vn[t[k] as usize] = n[k];
            }
        }
        let mut s = format!(
            "{HEADER}\n# written by a test\ncounts {} {} 0\n",
            mesh.positions.len(),
            mesh.triangles.len()
        );
        for (p, n) in mesh.positions.iter().zip(&vn) {
            s += &format!(
                "v {:?} {:?} {:?} {:?} {:?} {:?}\n",
                p.x, p.y, p.z, n.x, n.y, n.z
            );
        }
        for t in &mesh.triangles {
            s += &format!("t {} {} {}\n", t[0], t[1], t[2]);
        }
        s
    }

    fn load(name: &str, text: &str) -> Result<Mesh> {
        let f = Scratch::new(name, text);
        Mesh::load(f.0.to_str().unwrap(), &LoadOptions::default())
    }

    #[test]
    fn plain_and_general_records_read_alike() {
        // The same records written plainly (the one-pass reading of `Raw::fast`) and with a
        // leading blank and a comment (the general path): the same mesh, bit for bit, over
        // long f32 decimals, short ones, exponents, signed zeros, unnormalised normals, tabs,
        // a `+` index and a corner normal.
        let src = icosphere(1);
        let mut lines = vec![format!(
            "counts {} {} 1",
            src.positions.len(),
            src.triangles.len()
        )];
        for (i, p) in src.positions.iter().enumerate() {
            let q = p.to_array().map(|x| x as f32 as f64);
            let z = match i % 4 {
                0 => format!("{:?}", q[2]),
                1 => format!("{:.3}", q[2]),
                2 => format!("{:e}", q[2]),
                _ => "-0.0".into(),
            };
            lines.push(format!("v {:?}\t{} {z} {} 2 -0.5e0", q[0], q[1], 3 * i + 1));
        }
        for (i, t) in src.triangles.iter().enumerate() {
            lines.push(if i % 7 == 0 {
                format!("t +{} {}  {}", t[0], t[1], t[2])
            } else {
                format!("t {} {} {}", t[0], t[1], t[2])
            });
        }
        lines.push("c 3 1 0 0 1".into());
        let plain = format!("{HEADER}\n{}\n", lines.join("\n"));
        let general = format!(
            "{HEADER}\n{}",
            lines
                .iter()
                .map(|l| format!(" {l} # general\n"))
                .collect::<String>()
        );
        let a = load("plain.pn", &plain).unwrap();
        let b = load("general.pn", &general).unwrap();
        let bits = |v: &[DVec3]| -> Vec<[u64; 3]> {
            v.iter().map(|p| p.to_array().map(f64::to_bits)).collect()
        };
        assert_eq!(bits(&a.positions), bits(&b.positions));
        assert_eq!(a.triangles, b.triangles);
        let normals = |m: &Mesh| bits(&m.corner_normals.concat());
        assert_eq!(normals(&a), normals(&b));
        assert_eq!(
            format!("{:?}", a.load_report),
            format!("{:?}", b.load_report)
        );
        assert_eq!(a.triangles.len(), src.triangles.len());
    }

    #[test]
    fn round_trip_is_bitwise_and_gives_the_same_patches() {
        let src = icosphere(2);
        let back = load("ico2.pn", &to_pn(&src)).unwrap();
        assert_eq!(back.triangles, src.triangles);
        assert_eq!(back.positions.len(), 162);
        for (a, b) in back.positions.iter().zip(&src.positions) {
            assert_eq!(
                a.to_array().map(f64::to_bits),
                b.to_array().map(f64::to_bits)
            );
        }
        for (a, b) in back.corner_normals.iter().zip(&src.corner_normals) {
            for k in 0..3 {
                // Renormalising an already unit normal moves it by a few ulps at most.
                assert!((a[k] - b[k]).length() <= 1e-15, "{:?} vs {:?}", a[k], b[k]);
            }
        }
        let t0 = PatchTable::build(&src, Scheme::G1, &SchemeOptions::default()).unwrap();
        let t1 = PatchTable::build(&back, Scheme::G1, &SchemeOptions::default()).unwrap();
        let worst = t0
            .points
            .iter()
            .zip(&t1.points)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0, f64::max);
        assert!(worst <= 1e-15, "control points differ by {worst}");
    }

    #[test]
    fn shortest_decimal_forms_read_back_exactly() {
        // Python's repr(0.1 + 0.2), an exponent form, a subnormal-free tiny value, -0.0.
        let text = format!(
            "{HEADER}\ncounts 3 1 0\n\
             v 0.30000000000000004 1e-05 -0.0 0 0 1\n\
             v 1.0 2.5e-300 0.0 0 0 2\n\
             v 0.0 1.0 -9.87654321e+74 0 0 1\n\
             t 0 1 2\n"
        );
        let m = load("exact.pn", &text).unwrap();
        assert_eq!(m.positions[0].x, 0.1 + 0.2);
        assert_eq!(m.positions[0].y, 1e-5);
        assert_eq!(m.positions[1].y, 2.5e-300);
        assert_eq!(m.positions[2].z, -9.87654321e74);
        // The second vertex normal (0, 0, 2) is renormalised.
        assert_eq!(m.corner_normals[0][1], DVec3::Z);
    }

    #[test]
    fn corner_normals_replace_vertex_normals_and_welding_keeps_them() {
        // Two triangles of a square folded along the diagonal 0-2. Vertex 4 duplicates
        // vertex 2 (as Blender's unmerged vertices would), vertex 5 is unused, the last
        // triangle repeats a vertex.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let text = format!(
            "{HEADER}\ncounts 6 3 2\n\
             v 0 0 0 0 0 1\n\
             v 1 0 0 0 0 1\n\
             v 1 1 0 0 0 1\n\
             v 0 1 0 0 0 1\n\
             v 1.0 1.0 -0.0 0 {s} {s}\n\
             v 9 9 9 1 0 0\n\
             t 0 1 2\n\
             t 0 4 3   # 4 welds onto 2\n\
             t 0 0 1\n\
             c 0 1 1 0 1\n\
             c 1 0 0 3 4\n"
        );
        let m = load("fold.pn", &text).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.load_report.vertices_welded, 1);
        assert_eq!(m.load_report.unused_vertices_dropped, 1);
        assert_eq!(m.load_report.degenerate_triangles_dropped, 1);
        let n = &m.corner_normals;
        assert_eq!(n[0][0], DVec3::Z);
        assert!((n[0][1] - DVec3::new(1.0, 0.0, 1.0) / 2f64.sqrt()).length() < 1e-16);
        assert_eq!(n[0][2], DVec3::Z);
        assert!((n[1][0] - DVec3::new(0.0, 0.6, 0.8)).length() < 1e-16);
        assert!((n[1][1] - DVec3::new(0.0, s, s)).length() < 1e-16);
        assert_eq!(n[1][2], DVec3::Z);
    }

    #[test]
    fn bad_input_names_the_file_and_line() {
        let v3 = "v 0 0 0 0 0 1\nv 1 0 0 0 0 1\nv 0 1 0 0 0 1\n";
        let cases: Vec<(String, usize, &str)> = vec![
            ("solid x\n".into(), 1, "first line must be 'g1tess-pn 1'"),
            (
                "g1tess-pn 2\ncounts 0 0 0\n".into(),
                1,
                "unsupported version",
            ),
            (format!("{HEADER}\n{v3}t 0 1 2\n"), 2, "before the 'counts"),
            (format!("{HEADER}\n# no records\n"), 2, "no 'counts"),
            (
                format!("{HEADER}\ncounts 3 1\n"),
                2,
                "needs 3 fields, found 2",
            ),
            (
                format!("{HEADER}\ncounts 3 1 0\ncounts 3 1 0\n"),
                3,
                "second 'counts'",
            ),
            (
                format!("{HEADER}\ncounts 1 0 0\nv 0 0 0 0 1\n"),
                3,
                "needs 6 fields",
            ),
            (
                format!("{HEADER}\ncounts 1 0 0\nv 0 x 0 0 0 1\n"),
                3,
                "'x' is not a number",
            ),
            (
                format!("{HEADER}\ncounts 1 0 0\nv 0 nan 0 0 0 1\n"),
                3,
                "non-finite",
            ),
            (
                format!("{HEADER}\ncounts 1 0 0\nv 0 0 inf 0 0 1\n"),
                3,
                "non-finite",
            ),
            (
                format!("{HEADER}\ncounts 1 0 0\nv 0 0 0 0 0 0\n"),
                3,
                "zero-length normal",
            ),
            (
                format!("{HEADER}\ncounts 3 1 0\n{v3}t 0 1 -2\n"),
                6,
                "'-2' is not an index",
            ),
            (
                format!("{HEADER}\ncounts 3 1 0\n{v3}t 0 1 3\n"),
                6,
                "index 3 out of range",
            ),
            (
                format!("{HEADER}\ncounts 3 1 1\n{v3}t 0 1 2\nc 0 3 0 0 1\n"),
                7,
                "corner 3 out of range",
            ),
            (
                format!("{HEADER}\ncounts 3 1 1\n{v3}t 0 1 2\nc 1 0 0 0 1\n"),
                7,
                "triangle 1 out of range",
            ),
            (
                format!("{HEADER}\ncounts 3 1 1\n{v3}t 0 1 2\nc 0 0 0 0 0\n"),
                7,
                "zero-length normal",
            ),
            (
                format!("{HEADER}\ncounts 3 1 2\n{v3}t 0 1 2\nc 0 1 0 0 1\nc 0 1 1 0 0\n"),
                8,
                "corner 1 of triangle 0 given twice",
            ),
            (
                format!("{HEADER}\ncounts 3 2 0\n{v3}t 0 1 2\n"),
                6,
                "declares 2 triangles, the file holds 1",
            ),
            (
                format!("{HEADER}\ncounts 4 1 0\n{v3}t 0 1 2\n"),
                6,
                "declares 4 vertices",
            ),
            (
                format!("{HEADER}\ncounts 3 1 0\n{v3}f 1 2 3\n"),
                6,
                "unknown record 'f'",
            ),
        ];
        for (i, (text, line, what)) in cases.iter().enumerate() {
            let name = format!("bad{i}.pn");
            let e = load(&name, text).expect_err(text).to_string();
            let want = format!("{name}:{line}: ");
            assert!(
                e.contains(&want) && e.contains(what),
                "case {i}: got '{e}', want '{want}…{what}'"
            );
            assert!(!e.contains('\n'), "one line: {e}");
        }
        // No triangles at all: an error for the mesh, not a panic.
        let e = load("empty.pn", &format!("{HEADER}\ncounts 3 0 0\n{v3}")).unwrap_err();
        assert!(e.to_string().contains("empty mesh"), "{e}");
        let e = load(
            "degenerate.pn",
            &format!("{HEADER}\ncounts 3 1 0\n{v3}t 0 1 1\n"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("empty mesh"), "{e}");
        // Not UTF-8.
        let f = Scratch::new("binary.pn", b"g1tess-pn 1\ncounts 0 0 0\n\xff\n");
        let e = Mesh::load(f.0.to_str().unwrap(), &LoadOptions::default()).unwrap_err();
        assert!(e.to_string().contains("binary.pn:3: not UTF-8"), "{e}");
    }

    #[test]
    fn extension_dispatch_is_case_insensitive_and_obj_still_reads_as_obj() {
        let v3 = "v 0 0 0 0 0 1\nv 1 0 0 0 0 1\nv 0 1 0 0 0 1\n";
        let m = load(
            "upper.PN",
            &format!("{HEADER}\ncounts 3 1 0\n{v3}t 0 1 2\n"),
        )
        .unwrap();
        assert_eq!(m.triangles.len(), 1);
        let m = load("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert_eq!(m.triangles.len(), 1);
    }
}
