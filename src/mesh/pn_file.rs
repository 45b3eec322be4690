//! The point-normal mesh format `.pn` (version 1): positions, vertex normals, optional
//! per-corner normals and triangles, as text with full f64 round-trip precision. The
//! Blender add-on (`blender/`) writes it; the README documents it.
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

use super::{weld, LoadReport, Mesh};
use crate::{Error, Result};

/// The first line of every version-1 file.
pub const HEADER: &str = "g1tess-pn 1";

/// Reads a `.pn` file (see the module documentation).
pub fn load_pn(path: &Path) -> Result<Mesh> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count();
        Error::parse(path, line, "not UTF-8 text")
    })?;
    let raw = parse(path, &text)?;
    build(path, raw)
}

/// The file's records, checked line by line.
struct Raw {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    /// Triangle and the line it came from.
    triangles: Vec<([u32; 3], usize)>,
    /// (triangle, corner, normal, line).
    corners: Vec<(usize, usize, DVec3, usize)>,
}

fn parse(path: &Path, text: &str) -> Result<Raw> {
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    match lines.next() {
        Some((_, l)) if l.trim_end() == HEADER => {}
        Some((_, l)) if l.starts_with("g1tess-pn ") => {
            return Err(Error::parse(
                path,
                1,
                format!(
                    "unsupported version '{}' (this g1tess reads '{HEADER}')",
                    l.trim_end()
                ),
            ))
        }
        _ => {
            return Err(Error::parse(
                path,
                1,
                format!("not a point-normal file: the first line must be '{HEADER}'"),
            ))
        }
    }
    let mut counts: Option<[usize; 3]> = None;
    let mut raw = Raw {
        positions: Vec::new(),
        normals: Vec::new(),
        triangles: Vec::new(),
        corners: Vec::new(),
    };
    for (lineno, line) in lines {
        let err = |msg: String| Error::parse(path, lineno, msg);
        let line = line.split('#').next().unwrap_or("");
        let mut tok = line.split_whitespace();
        let Some(kw) = tok.next() else { continue };
        let fields: Vec<&str> = tok.collect();
        let need = |n: usize| -> Result<()> {
            if fields.len() == n {
                Ok(())
            } else {
                Err(err(format!(
                    "'{kw}' needs {n} fields, found {}",
                    fields.len()
                )))
            }
        };
        let float = |s: &str, what: &str| -> Result<f64> {
            let x: f64 = s
                .parse()
                .map_err(|_| err(format!("{what}: '{s}' is not a number")))?;
            if x.is_finite() {
                Ok(x)
            } else {
                Err(err(format!("{what}: non-finite value '{s}'")))
            }
        };
        let index = |s: &str, what: &str| -> Result<usize> {
            s.parse()
                .map_err(|_| err(format!("{what}: '{s}' is not an index (0-based integer)")))
        };
        let normal = |f: &[&str]| -> Result<DVec3> {
            let n = DVec3::new(
                float(f[0], "normal")?,
                float(f[1], "normal")?,
                float(f[2], "normal")?,
            );
            let len = n.length();
            if len == 0.0 || !len.is_finite() {
                return Err(err("zero-length normal".into()));
            }
            Ok(n / len)
        };
        if kw != "counts" && counts.is_none() {
            return Err(err(format!(
                "'{kw}' before the 'counts V T C' line (it must follow the header)"
            )));
        }
        match kw {
            "counts" => {
                if counts.is_some() {
                    return Err(err("a second 'counts' line".into()));
                }
                need(3)?;
                counts = Some([
                    index(fields[0], "vertex count")?,
                    index(fields[1], "triangle count")?,
                    index(fields[2], "corner normal count")?,
                ]);
            }
            "v" => {
                need(6)?;
                raw.positions.push(DVec3::new(
                    float(fields[0], "vertex")?,
                    float(fields[1], "vertex")?,
                    float(fields[2], "vertex")?,
                ));
                raw.normals.push(normal(&fields[3..])?);
            }
            "t" => {
                need(3)?;
                let mut t = [0u32; 3];
                for k in 0..3 {
                    let i = index(fields[k], "triangle")?;
                    t[k] = u32::try_from(i)
                        .map_err(|_| err(format!("triangle: vertex index {i} too large")))?;
                }
                raw.triangles.push((t, lineno));
            }
            "c" => {
                need(5)?;
                let t = index(fields[0], "corner normal: triangle")?;
                let k = index(fields[1], "corner normal: corner")?;
                if k > 2 {
                    return Err(err(format!(
                        "corner normal: corner {k} out of range (0, 1 or 2)"
                    )));
                }
                raw.corners.push((t, k, normal(&fields[2..])?, lineno));
            }
            _ => return Err(err(format!("unknown record '{kw}' (expected v, t or c)"))),
        }
    }
    let last = text.lines().count().max(1);
    let Some([nv, nt, nc]) = counts else {
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
                format!("'counts' declares {declared} {what}, the file holds {found} (truncated?)"),
            ));
        }
    }
    Ok(raw)
}

/// Checks indices, applies corner normals, welds and drops like the OBJ loader.
fn build(path: &Path, raw: Raw) -> Result<Mesh> {
    let nv = raw.positions.len();
    for &(t, line) in &raw.triangles {
        if let Some(&i) = t.iter().find(|&&i| i as usize >= nv) {
            return Err(Error::parse(
                path,
                line,
                format!("triangle: vertex index {i} out of range (the file has {nv} vertices)"),
            ));
        }
    }
    let mut corner_normals: Vec<[DVec3; 3]> = raw
        .triangles
        .iter()
        .map(|(t, _)| t.map(|v| raw.normals[v as usize]))
        .collect();
    let mut seen = vec![[false; 3]; raw.triangles.len()];
    for &(t, k, n, line) in &raw.corners {
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
    let mut triangles: Vec<[u32; 3]> = raw.triangles.iter().map(|&(t, _)| t).collect();
    drop(raw.triangles);
    let mut normals = corner_normals;
    let positions = weld::weld(&raw.positions, &mut triangles, &mut normals, &mut report)?;
    let name = super::display_name(path);
    if triangles.is_empty() {
        return Err(Error::mesh(
            path.display().to_string(),
            "empty mesh: no triangles",
        ));
    }
    Ok(Mesh {
        name,
        positions,
        triangles,
        corner_normals: normals,
        load_report: report,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generators::icosphere;
    use crate::mesh::LoadOptions;
    use crate::patch::{PatchTable, Scheme, SchemeOptions};

    /// A scratch file that is removed when dropped.
    struct Scratch(std::path::PathBuf);
    impl Scratch {
        fn new(name: &str, text: impl AsRef<[u8]>) -> Scratch {
            let dir = std::env::temp_dir().join(format!("g1tess-pn-{}", std::process::id()));
            std::fs::create_dir_all(&dir).unwrap();
            let p = dir.join(name);
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
             v 0.0 1.0 -1.7976931348623157e+308 0 0 1\n\
             t 0 1 2\n"
        );
        let m = load("exact.pn", &text).unwrap();
        assert_eq!(m.positions[0].x, 0.1 + 0.2);
        assert_eq!(m.positions[0].y, 1e-5);
        assert_eq!(m.positions[1].y, 2.5e-300);
        assert_eq!(m.positions[2].z, -f64::MAX);
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
