//! PLY, STL and glTF input: files built here byte by byte (ASCII, both binary byte orders,
//! GLB and `.gltf` + `.bin`), the writers' files read back, `spot.obj` through every
//! format, errors that name the element or line, the format chosen by content, and the
//! command line's `stats` on written files.

use crate::common;

use std::path::{Path, PathBuf};
#[cfg(feature = "cli")]
use std::process::Command;

use glam::DVec3;
use serde_json::json;

use g1tess::stats_report;
use g1tess::stitch_in;
use g1tess::CpuEvaluator;
use g1tess::NoProgress;
use g1tess::TempFiles;
use g1tess::{stitch_into, StitchedMesh};
use g1tess::{write_stitched, MeshFormat};
use g1tess::{InputFormat, LoadOptions, Mesh};
use g1tess::{PatchTable, Scheme, SchemeOptions};

fn dir() -> PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-readers-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn put(name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let p = dir().join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn load(p: &Path) -> Mesh {
    Mesh::load(p.to_str().unwrap(), &LoadOptions::default()).unwrap()
}

fn load_err(p: &Path) -> String {
    let e = Mesh::load(p.to_str().unwrap(), &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(!e.contains('\n'), "one line: {e}");
    e
}

/// A tetrahedron, outward.
const TETRA_P: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];
const TETRA_T: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

/// The positions of each triangle's corners.
fn corners(m: &Mesh) -> Vec<[DVec3; 3]> {
    m.triangles
        .iter()
        .map(|t| t.map(|v| m.positions[v as usize]))
        .collect()
}

/// The G1 statistics of a mesh, without the fields that name the file or the loader.
fn stats(m: &Mesh) -> serde_json::Value {
    let r = stats_report(
        m,
        Scheme::G1,
        &SchemeOptions::default(),
        &CpuEvaluator::default(),
    )
    .unwrap();
    let mut v = serde_json::to_value(&r).unwrap();
    let o = v.as_object_mut().unwrap();
    o.remove("mesh");
    o.remove("load");
    v
}

// ---------------------------------------------------------------------------------------
// PLY

/// A PLY file: `format` is `ascii`, `binary_little_endian` or `binary_big_endian`;
/// vertex properties `(type, name)` with one row of values per vertex; faces as lists
/// (`list uchar int vertex_indices`), then `extra` header lines (other elements, empty).
fn ply(format: &str, props: &[(&str, &str)], rows: &[Vec<f64>], faces: &[Vec<u32>]) -> Vec<u8> {
    let mut h = format!(
        "ply\nformat {format} 1.0\ncomment test\nelement vertex {}\n",
        rows.len()
    );
    for (ty, name) in props {
        h += &format!("property {ty} {name}\n");
    }
    h += &format!(
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        faces.len()
    );
    let mut out = h.into_bytes();
    let big = format == "binary_big_endian";
    let put = |out: &mut Vec<u8>, ty: &str, x: f64| {
        let b: Vec<u8> = match (ty, big) {
            ("float", false) => (x as f32).to_le_bytes().to_vec(),
            ("float", true) => (x as f32).to_be_bytes().to_vec(),
            ("double", false) => x.to_le_bytes().to_vec(),
            ("double", true) => x.to_be_bytes().to_vec(),
            ("uchar", _) => vec![x as u8],
            ("int", false) => (x as i32).to_le_bytes().to_vec(),
            ("int", true) => (x as i32).to_be_bytes().to_vec(),
            _ => panic!("type {ty}"),
        };
        out.extend(b);
    };
    if format == "ascii" {
        for r in rows {
            let s: Vec<String> = r.iter().map(|x| format!("{x}")).collect();
            out.extend(format!("{}\n", s.join(" ")).bytes());
        }
        for f in faces {
            let s: Vec<String> = f.iter().map(|x| x.to_string()).collect();
            out.extend(format!("{} {}\n", f.len(), s.join(" ")).bytes());
        }
    } else {
        for r in rows {
            for ((ty, _), &x) in props.iter().zip(r) {
                put(&mut out, ty, x);
            }
        }
        for f in faces {
            out.push(f.len() as u8);
            for &i in f {
                put(&mut out, "int", i as f64);
            }
        }
    }
    out
}

fn tetra_rows() -> Vec<Vec<f64>> {
    TETRA_P
        .iter()
        .map(|p| p.iter().map(|&x| x as f64).collect())
        .collect()
}

fn tetra_faces() -> Vec<Vec<u32>> {
    TETRA_T.iter().map(|t| t.to_vec()).collect()
}

/// `file` with `from` replaced by `to` in its header only.
fn in_header(file: &[u8], from: &str, to: &str) -> Vec<u8> {
    let end = file.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let mut out = String::from_utf8(file[..end].to_vec())
        .unwrap()
        .replace(from, to)
        .into_bytes();
    out.extend(&file[end..]);
    out
}

const XYZ: [(&str, &str); 3] = [("float", "x"), ("float", "y"), ("float", "z")];

#[test]
fn ply_in_every_encoding_reads_the_same_mesh() {
    let want = Mesh::from_soup(
        "tetra",
        &TETRA_P.map(|p| p.map(f64::from)),
        &TETRA_T,
        None,
        &LoadOptions::default(),
    )
    .unwrap();
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let p = put(
            &format!("tetra-{format}.ply"),
            ply(format, &XYZ, &tetra_rows(), &tetra_faces()),
        );
        let m = load(&p);
        assert_eq!(m.positions, want.positions, "{format}");
        assert_eq!(m.triangles, want.triangles, "{format}");
        // No normals in the file: estimated as for OBJ, so equal to the soup's.
        assert_eq!(m.corner_normals, want.corner_normals, "{format}");
        assert_eq!(m.load_report.normals_estimated, 12);
        assert!(m.corner_uvs().is_none() && m.corner_colors().is_none());
    }
}

#[test]
fn ply_normals_uvs_colours_and_ignored_properties() {
    // Every vertex: position, a normal (not unit: renormalised), UV, colour bytes with
    // alpha, and a property the reader does not use.
    let props = [
        ("float", "x"),
        ("float", "y"),
        ("float", "z"),
        ("float", "nx"),
        ("float", "ny"),
        ("float", "nz"),
        ("float", "s"),
        ("float", "t"),
        ("uchar", "red"),
        ("uchar", "green"),
        ("uchar", "blue"),
        ("uchar", "alpha"),
        ("float", "quality"),
    ];
    let rows: Vec<Vec<f64>> = TETRA_P
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut r: Vec<f64> = p.iter().map(|&x| x as f64).collect();
            r.extend([0.0, 0.0, 2.0]); // normal (0, 0, 2): unit (0, 0, 1)
            r.extend([i as f64 * 0.25, 1.0 - i as f64 * 0.25]);
            r.extend([255.0, 51.0 * i as f64, 0.0, 102.0]);
            r.push(7.0);
            r
        })
        .collect();
    // A quad as the last face: split in two as a fan.
    let mut faces = tetra_faces();
    faces.pop();
    faces.push(vec![1, 2, 3]);
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let p = put(
            &format!("attrs-{format}.ply"),
            ply(format, &props, &rows, &faces),
        );
        let m = load(&p);
        assert_eq!(m.triangles.len(), 4);
        assert!(m.corner_normals.iter().flatten().all(|n| *n == DVec3::Z));
        assert_eq!(m.load_report.normals_estimated, 0);
        let uvs = m.corner_uvs().expect("uvs");
        let cols = m.corner_colors().expect("colours");
        assert!(m.colors_have_alpha());
        // Vertex ids are kept (input order, nothing welded): corner k of triangle t is
        // input vertex TETRA_T[t][k].
        for (t, tri) in m.triangles.iter().enumerate() {
            for k in 0..3 {
                let i = tri[k] as usize;
                assert_eq!(uvs[t][k], [i as f32 * 0.25, 1.0 - i as f32 * 0.25]);
                // Bytes scaled by 255, as the writers of colour bytes mean them.
                assert_eq!(
                    cols[t][k],
                    [1.0, (51 * i) as f32 / 255.0, 0.0, 102.0 / 255.0],
                    "{format}"
                );
            }
        }
        assert_eq!(
            m.load_report.notes,
            vec!["vertex properties ignored: quality".to_string()],
            "{format}"
        );
    }
    // Float colours as they are; a quad is a fan of two triangles.
    let props = [
        ("float", "x"),
        ("float", "y"),
        ("float", "z"),
        ("float", "red"),
        ("float", "green"),
        ("float", "blue"),
    ];
    let rows: Vec<Vec<f64>> = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ]
    .iter()
    .map(|p| vec![p[0], p[1], p[2], 0.5, 0.25, 0.125])
    .collect();
    let p = put("quad.ply", ply("ascii", &props, &rows, &[vec![0, 1, 2, 3]]));
    let m = load(&p);
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(m.load_report.polygons_triangulated, 1);
    assert!(!m.colors_have_alpha());
    assert!(m
        .corner_colors()
        .unwrap()
        .iter()
        .flatten()
        .all(|c| *c == [0.5, 0.25, 0.125, 1.0]));
}

#[test]
fn ply_errors_name_the_line_or_element() {
    let good = ply("binary_little_endian", &XYZ, &tetra_rows(), &tetra_faces());
    // Truncated inside the last face: the element and its index.
    let p = put("cut.ply", &good[..good.len() - 3]);
    let e = load_err(&p);
    assert!(e.contains("cut.ply: face 3: truncated"), "{e}");
    // A vertex count that lies: refused at its header line before anything is allocated.
    let p = put(
        "lie.ply",
        in_header(&good, "element vertex 4", "element vertex 4000000000"),
    );
    let e = load_err(&p);
    assert!(
        e.contains("lie.ply:4: element 'vertex' counts 4000000000 records"),
        "{e}"
    );
    // Big-endian bytes under a little-endian header: indices out of range, named.
    let be = ply("binary_big_endian", &XYZ, &tetra_rows(), &tetra_faces());
    let swapped = in_header(&be, "binary_big_endian", "binary_little_endian");
    let p = put("swapped.ply", swapped);
    let e = load_err(&p);
    assert!(e.contains("swapped.ply: face 0: vertex index"), "{e}");
    // An unknown property type.
    let text = String::from_utf8_lossy(&ply("ascii", &XYZ, &tetra_rows(), &tetra_faces()))
        .replace("property float y", "property float128 y");
    let p = put("type.ply", text);
    assert!(load_err(&p).contains("type.ply:6: unknown property type 'float128'"));
    // ASCII: a bad number, a face out of range, a short file: the line.
    let ascii = String::from_utf8(ply("ascii", &XYZ, &tetra_rows(), &tetra_faces())).unwrap();
    let body = ascii.lines().position(|l| l == "end_header").unwrap() + 2;
    let p = put("num.ply", ascii.replacen("1 0 0", "1 zero 0", 1));
    let e = load_err(&p);
    assert!(
        e.contains(&format!(
            "num.ply:{}: vertex 1: 'zero' is not a number",
            body + 1
        )),
        "{e}"
    );
    let p = put("range.ply", ascii.replace("3 1 2 3", "3 1 2 9"));
    let e = load_err(&p);
    assert!(
        e.contains(&format!(
            "range.ply:{}: face 3: vertex index 9 out of range",
            body + 7
        )),
        "{e}"
    );
    let lines: Vec<&str> = ascii.lines().collect();
    let p = put("short.ply", lines[..lines.len() - 1].join("\n"));
    let e = load_err(&p);
    assert!(e.contains("short.ply:") && e.contains("face 3"), "{e}");
    let p = put("two.ply", ascii.replace("3 0 2 1", "2 0 2"));
    assert!(load_err(&p).contains("face 0: face needs at least 3 corners, found 2"));
    let p = put("noheader.ply", "ply\nformat ascii 1.0\nelement vertex 3\n");
    assert!(load_err(&p).contains("no 'end_header'"));
}

/// A PLY of triangle strips as Stanford's strip files hold them (`element tristrips 1`,
/// `property list int int vertex_indices`, strips separated by -1): vertices `xyz` as
/// floats, then the one strip list.
fn strip_ply(format: &str, xyz: &[[f32; 3]], list: &[i32]) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement tristrips 1\nproperty list int int vertex_indices\n\
         end_header\n",
        xyz.len()
    )
    .into_bytes();
    let big = format == "binary_big_endian";
    let bytes = |b: [u8; 4]| {
        if big {
            b.into_iter().rev().collect()
        } else {
            b.to_vec()
        }
    };
    if format == "ascii" {
        for p in xyz {
            out.extend(format!("{} {} {}\n", p[0], p[1], p[2]).bytes());
        }
        let items: Vec<String> = list.iter().map(|i| i.to_string()).collect();
        out.extend(format!("{} {}\n", list.len(), items.join(" ")).bytes());
    } else {
        for p in xyz {
            for x in p {
                out.extend(bytes(x.to_le_bytes()));
            }
        }
        out.extend(bytes((list.len() as i32).to_le_bytes()));
        for i in list {
            out.extend(bytes(i.to_le_bytes()));
        }
    }
    out
}

/// A 4 × 4 grid of vertices in the plane z = 0, vertex 4j + i at (i, j).
fn grid_xyz() -> Vec<[f32; 3]> {
    (0..16)
        .map(|v| [(v % 4) as f32, (v / 4) as f32, 0.0])
        .collect()
}

/// Strips over [`grid_xyz`], each starting counter-clockwise seen from +z: the rows
/// y 0..1 (6 triangles) joined to the rows y 1..2 (6) by the repeated 3 and 8 (4
/// triangles with a repeated corner), then after -1 a strip of 2 triangles (rows 2..3,
/// starting at an odd position of the list), a strip of 2 vertices (no triangle) and an
/// empty one.
const STRIPS: [i32; 28] = [
    4, 0, 5, 1, 6, 2, 7, 3, 3, 8, 8, 4, 9, 5, 10, 6, 11, 7, -1, 12, 8, 13, 9, -1, 14, 15, -1, -1,
];

/// The triangles of [`STRIPS`], worked out by hand: (k, k+1, k+2) at even positions k of
/// each strip, (k+1, k, k+2) at odd ones, the 4 with a repeated corner left out.
const STRIP_TRIANGLES: [[u32; 3]; 14] = [
    [4, 0, 5],
    [5, 0, 1],
    [5, 1, 6],
    [6, 1, 2],
    [6, 2, 7],
    [7, 2, 3],
    [8, 4, 9],
    [9, 4, 5],
    [9, 5, 10],
    [10, 5, 6],
    [10, 6, 11],
    [11, 6, 7],
    [12, 8, 13],
    [13, 8, 9],
];

#[test]
fn ply_triangle_strips_in_every_encoding() {
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let p = put(
            &format!("strips-{format}.ply"),
            strip_ply(format, &grid_xyz(), &STRIPS),
        );
        let m = load(&p);
        // Vertex ids are kept: 14 and 15 (only in the 2-vertex strip) are unused, last.
        assert_eq!(m.triangles, STRIP_TRIANGLES.to_vec(), "{format}");
        assert_eq!(m.positions.len(), 14, "{format}");
        assert_eq!(m.load_report.unused_vertices_dropped, 2, "{format}");
        assert_eq!(m.load_report.degenerate_triangles_dropped, 0, "{format}");
        assert!(m.load_report.notes.is_empty(), "{:?}", m.load_report.notes);
        // One orientation: every face normal is +z, and the areas add up to the
        // 3 + 3 + 1 unit squares the strips cover.
        let mut area = 0.0;
        for [a, b, c] in corners(&m) {
            let n = (b - a).cross(c - a);
            assert!(n.x == 0.0 && n.y == 0.0 && n.z > 0.0, "{format}: {n}");
            area += 0.5 * n.z;
        }
        assert_eq!(area, 7.0, "{format}");
    }
    // The command line reads them too.
    let p = dir().join("strips-binary_little_endian.ply");
    let o = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(["stats", p.to_str().unwrap(), "--backend", "cpu", "--json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["triangles"], 14);
}

#[test]
fn ply_strip_errors_name_the_element() {
    for (bad, what) in [
        (16, "vertex index 16 out of range"),
        (-2, "vertex index -2"),
    ] {
        let mut list = STRIPS;
        list[5] = bad;
        let p = put(
            "badstrip.ply",
            strip_ply("binary_little_endian", &grid_xyz(), &list),
        );
        let e = load_err(&p);
        assert!(
            e.contains("badstrip.ply: tristrips 0: ") && e.contains(what),
            "{e}"
        );
    }
    // Strips without their index list, and no faces: nothing to read.
    let file = strip_ply("ascii", &grid_xyz(), &STRIPS);
    let p = put(
        "nolist.ply",
        in_header(&file, "vertex_indices", "vertex_colours"),
    );
    let e = load_err(&p);
    assert!(e.contains("nolist.ply:1: no 'face' element"), "{e}");
}

// ---------------------------------------------------------------------------------------
// STL

fn stl_binary(tris: &[[[f32; 3]; 3]], header: &[u8]) -> Vec<u8> {
    let mut out = vec![b' '; 80];
    out[..header.len()].copy_from_slice(header);
    out.extend((tris.len() as u32).to_le_bytes());
    for t in tris {
        out.extend([0u8; 12]); // facet normal: zero, as some exporters write it
        for p in t {
            for x in p {
                out.extend(x.to_le_bytes());
            }
        }
        out.extend([0u8; 2]);
    }
    out
}

fn stl_ascii(tris: &[[[f32; 3]; 3]]) -> String {
    let mut s = String::from("solid test\n");
    for t in tris {
        s += "  facet normal 0 0 0\n    outer loop\n";
        for p in t {
            s += &format!("      vertex {:?} {:?} {:?}\n", p[0], p[1], p[2]);
        }
        s += "    endloop\n  endfacet\n";
    }
    s + "endsolid test\n"
}

fn tetra_facets() -> Vec<[[f32; 3]; 3]> {
    TETRA_T
        .iter()
        .map(|t| t.map(|v| TETRA_P[v as usize]))
        .collect()
}

#[test]
fn stl_ascii_and_binary_weld_and_estimate_normals() {
    // The same tetrahedron as an OBJ without normals, its vertices listed in the order the
    // facets first use them (0, 2, 1, 3), which is how an STL's welded corners are
    // numbered (in input order, and an STL's input is its facets' corners): normals
    // estimated alike.
    let first_use = [0u32, 2, 1, 3];
    let new_id = |v: u32| first_use.iter().position(|&w| w == v).unwrap() + 1;
    let mut obj = String::new();
    for v in first_use {
        let p = TETRA_P[v as usize];
        obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for t in TETRA_T {
        obj += &format!("f {} {} {}\n", new_id(t[0]), new_id(t[1]), new_id(t[2]));
    }
    let want = load(&put("tetra-stl.obj", obj));
    let files = [
        put("tetra.stl", stl_binary(&tetra_facets(), b"binary")),
        // A binary header that starts with "solid", as some exporters write: the size decides.
        put("solid.stl", stl_binary(&tetra_facets(), b"solid tetra")),
        put("tetra-ascii.stl", stl_ascii(&tetra_facets())),
    ];
    for p in &files {
        let m = load(p);
        // Twelve corners welded into the four vertices, numbered by first use (input order
        // of the corners), the facet normals not used: normals as estimated for the OBJ.
        assert_eq!(m.positions, want.positions, "{}", p.display());
        assert_eq!(m.triangles, want.triangles);
        assert_eq!(m.corner_normals, want.corner_normals);
        assert_eq!(m.load_report.vertices_welded, 8);
        assert_eq!(m.load_report.normals_estimated, 12);
    }
}

#[test]
fn stl_errors_name_the_facet_or_line() {
    let good = stl_binary(&tetra_facets(), b"x");
    let p = put("cut.stl", &good[..good.len() - 7]);
    let e = load_err(&p);
    assert!(
        e.contains("cut.stl: binary STL header counts 4 facets")
            && e.contains("facet 3 is incomplete"),
        "{e}"
    );
    let mut lie = good.clone();
    lie[80..84].copy_from_slice(&1_000_000_000u32.to_le_bytes());
    let p = put("lie.stl", lie);
    assert!(load_err(&p).contains("counts 1000000000 facets"));
    let p = put("tiny.stl", b"abc");
    assert!(load_err(&p).contains("truncated binary STL: 3 bytes"));
    let mut nan = good.clone();
    nan[84 + 12 + 12..84 + 12 + 16].copy_from_slice(&f32::NAN.to_le_bytes());
    let p = put("nan.stl", nan);
    assert!(load_err(&p).contains("nan.stl: facet 0, corner 1: non-finite coordinate"));
    let ascii = stl_ascii(&tetra_facets());
    let p = put(
        "bad.stl",
        ascii.replacen("vertex 1.0 0.0 0.0", "vertex 1.0 0.0", 1),
    );
    let e = load_err(&p);
    assert!(
        e.contains("bad.stl:") && e.contains("vertex needs 3 numbers, found 2"),
        "{e}"
    );
    let p = put("kw.stl", ascii.replacen("endloop", "endlop", 1));
    let e = load_err(&p);
    assert!(
        e.contains("kw.stl:7: 'endlop' where 'vertex' or 'endloop' was expected"),
        "{e}"
    );
    let cut: String = ascii.lines().take(5).collect::<Vec<_>>().join("\n");
    let p = put("cut-ascii.stl", cut);
    assert!(load_err(&p).contains("cut-ascii.stl:5: file ends inside a facet"));
}

// ---------------------------------------------------------------------------------------
// glTF

/// A GLB file of `json` and `bin`.
fn glb(json: &serde_json::Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).unwrap();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(b);
    out
}

fn f32_bytes(v: &[[f32; 3]]) -> Vec<u8> {
    v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect()
}

/// The tetrahedron as mesh 0 (indexed, with normals (1, 0, 1)/√2 everywhere) and as mesh 1
/// (non-indexed, no normals, moved by +10 in x), nodes given by the caller.
fn tetra_gltf(
    nodes: serde_json::Value,
    scene_nodes: serde_json::Value,
) -> (serde_json::Value, Vec<u8>) {
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let mut bin = f32_bytes(&TETRA_P); // 0..48 positions
    bin.extend(f32_bytes(&[[s, 0.0, s]; 4])); // 48..96 normals
    bin.extend(
        TETRA_T
            .iter()
            .flatten()
            .flat_map(|i| (*i as u16).to_le_bytes()),
    ); // 96..120
    let soup: Vec<[f32; 3]> = tetra_facets()
        .iter()
        .flatten()
        .map(|p| [p[0] + 10.0, p[1], p[2]])
        .collect();
    bin.extend(f32_bytes(&soup)); // 120..264
    let json = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": scene_nodes}],
        "nodes": nodes,
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]},
            {"primitives": [{"attributes": {"POSITION": 3}}]}
        ],
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 96},
            {"buffer": 0, "byteOffset": 96, "byteLength": 24},
            {"buffer": 0, "byteOffset": 120, "byteLength": 144}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 1]},
            {"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5126, "count": 12, "type": "VEC3",
             "min": [10, 0, 0], "max": [11, 1, 1]}
        ]
    });
    (json, bin)
}

#[test]
fn gltf_nested_node_transforms_place_the_mesh() {
    // Node 0: translation (1, 2, 3), 90° about z, scale 2; its child node 1: translation
    // (0, 0, 1), scale (1, 1, 3), mesh 0. Node 2 at the root: mesh 1, no transform.
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let nodes = json!([
        {"translation": [1, 2, 3], "rotation": [0, 0, h, h], "scale": [2, 2, 2], "children": [1]},
        {"translation": [0, 0, 1], "scale": [1, 1, 3], "mesh": 0},
        {"mesh": 1}
    ]);
    let (json, bin) = tetra_gltf(nodes, json!([0, 2]));
    let p = put("nested.glb", glb(&json, &bin));
    let m = load(&p);
    assert_eq!(m.triangles.len(), 8);
    // Worked by hand: S1 (x, y, 3z), T1 (x, y, 3z + 1), S0 (2x, 2y, 6z + 2),
    // R0 (-2y, 2x, 6z + 2), T0 (1 - 2y, 2 + 2x, 6z + 5).
    let place = |p: [f32; 3]| {
        let [x, y, z] = p.map(f64::from);
        DVec3::new(1.0 - 2.0 * y, 2.0 + 2.0 * x, 6.0 * z + 5.0)
    };
    // The rotation is an f32 quaternion: sin 45° rounded to f32, so 1e-6 of the unit.
    let tol = 1e-6;
    let got = corners(&m);
    for (t, tri) in TETRA_T.iter().enumerate() {
        for k in 0..3 {
            let want = place(TETRA_P[tri[k] as usize]);
            assert!(
                (got[t][k] - want).length() < tol,
                "{t} {k}: {} vs {want}",
                got[t][k]
            );
            // Normals by the inverse transpose: R0 · diag(1/2, 1/2, 1/6) · (1, 0, 1)
            // ∝ (0, 3, 1), not R0 · diag(2, 2, 6) · (1, 0, 1) ∝ (0, 1, 3).
            let n = m.corner_normals[t][k];
            let want_n = DVec3::new(0.0, 3.0, 1.0).normalize();
            assert!((n - want_n).length() < tol, "{n}");
        }
        // Mesh 1 (non-indexed) in place, untransformed, after mesh 0.
        for k in 0..3 {
            let p = TETRA_P[tri[k] as usize].map(f64::from);
            assert_eq!(got[4 + t][k], DVec3::new(p[0] + 10.0, p[1], p[2]));
        }
    }
    // The same scene as .gltf with an external .bin, and with a data URI.
    let (mut json, bin) = tetra_gltf(
        json!([{"mesh": 0, "translation": [0, 0, 5]}, {"mesh": 1}]),
        json!([0, 1]),
    );
    std::fs::write(dir().join("tetra data.bin"), &bin).unwrap();
    json["buffers"][0]["uri"] = json!("tetra%20data.bin");
    let a = load(&put("ext.gltf", serde_json::to_vec(&json).unwrap()));
    json["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        b64(&bin)
    ));
    let b = load(&put("uri.gltf", serde_json::to_vec(&json).unwrap()));
    assert_eq!(a.positions, b.positions);
    assert_eq!(a.triangles, b.triangles);
    assert_eq!(a.positions[0], DVec3::new(0.0, 0.0, 5.0));
}

/// Standard base64 with padding (an independent encoder for the test).
fn b64(b: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in b.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

#[test]
fn gltf_texcoords_colours_and_errors() {
    // TEXCOORD_0 as floats and COLOR_0 as normalised bytes (VEC4) on mesh 0.
    let (mut json, mut bin) = tetra_gltf(json!([{"mesh": 0}]), json!([0]));
    let uv_at = bin.len();
    for i in 0..4 {
        bin.extend((i as f32 * 0.5).to_le_bytes());
        bin.extend((1.0 - i as f32 * 0.25).to_le_bytes());
    }
    let col_at = bin.len();
    for i in 0..4u8 {
        bin.extend([255, 17 * i, 0, 51]);
    }
    json["buffers"][0]["byteLength"] = json!(bin.len());
    json["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({"buffer": 0, "byteOffset": uv_at, "byteLength": 32}));
    json["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({"buffer": 0, "byteOffset": col_at, "byteLength": 16}));
    json["accessors"]
        .as_array_mut()
        .unwrap()
        .push(json!({"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC2"}));
    json["accessors"].as_array_mut().unwrap().push(json!({"bufferView": 4, "componentType": 5121, "normalized": true, "count": 4, "type": "VEC4"}));
    json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(4);
    json["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = json!(5);
    let m = load(&put("attrs.glb", glb(&json, &bin)));
    let uvs = m.corner_uvs().unwrap();
    let cols = m.corner_colors().unwrap();
    assert!(m.colors_have_alpha());
    for (t, tri) in m.triangles.iter().enumerate() {
        for k in 0..3 {
            let i = tri[k] as usize;
            assert_eq!(uvs[t][k], [i as f32 * 0.5, 1.0 - i as f32 * 0.25]);
            assert_eq!(
                cols[t][k],
                [1.0, (17 * i) as f32 / 255.0, 0.0, 51.0 / 255.0]
            );
        }
    }

    // Malformed accessors, each named.
    let (json, bin) = tetra_gltf(json!([{"mesh": 0}]), json!([0]));
    let bad = |name: &str, f: &dyn Fn(&mut serde_json::Value)| {
        let mut j = json.clone();
        f(&mut j);
        load_err(&put(name, glb(&j, &bin)))
    };
    let e = bad("count.glb", &|j| j["accessors"][0]["count"] = json!(9));
    assert!(
        e.contains("count.glb: mesh 0 primitive 0: accessor 0: 9 elements of 12 bytes")
            && e.contains("beyond buffer view 0"),
        "{e}"
    );
    let e = bad("type.glb", &|j| j["accessors"][0]["type"] = json!("VEC2"));
    assert!(
        e.contains("accessor 0: type Vec2 where [Vec3] was expected"),
        "{e}"
    );
    let e = bad("stride.glb", &|j| {
        j["bufferViews"][0]["byteStride"] = json!(4)
    });
    assert!(
        e.contains("accessor 0: byte stride 4 below its element size 12"),
        "{e}"
    );
    let e = bad("index.glb", &|j| {
        j["accessors"][2]["componentType"] = json!(5126)
    });
    assert!(e.contains("accessor 2: component type F32"), "{e}");
    let e = bad("view.glb", &|j| {
        j["bufferViews"][0]["byteLength"] = json!(100000)
    });
    assert!(
        e.contains("buffer view 0: bytes 0..+100000 beyond its buffer"),
        "{e}"
    );
    let e = bad("normals.glb", &|j| j["accessors"][1]["count"] = json!(3));
    assert!(
        e.contains("mesh 0 primitive 0: NORMAL has 3 entries for 4 positions"),
        "{e}"
    );
    // An index out of range: 12 u16 indices, the last one made 7 (4 vertices).
    let mut b2 = bin.clone();
    b2[96 + 22..96 + 24].copy_from_slice(&7u16.to_le_bytes());
    let e = load_err(&put("oob.glb", glb(&json, &b2)));
    assert!(
        e.contains("mesh 0 primitive 0: index 11 is 7, out of range (4 vertices)"),
        "{e}"
    );
    // Truncated GLB, a lying chunk length, not JSON.
    let full = glb(&json, &bin);
    let e = load_err(&put("cut.glb", &full[..full.len() - 10]));
    assert!(
        e.contains("cut.glb: GLB header says") && e.contains("(truncated)"),
        "{e}"
    );
    let mut lie = full.clone();
    let jl = u32::from_le_bytes(lie[12..16].try_into().unwrap());
    lie[12..16].copy_from_slice(&(jl + 1000).to_le_bytes());
    assert!(load_err(&put("lie.glb", lie)).contains("GLB chunk at byte 12"));
    let e = load_err(&put(
        "broken.gltf",
        "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [",
    ));
    assert!(e.contains("broken.gltf: not valid glTF"), "{e}");
    // An attribute naming an accessor that does not exist.
    let e = bad("noacc.glb", &|j| {
        j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(99)
    });
    assert!(
        e.contains("mesh 0 primitive 0: attribute") && e.contains("names accessor 99"),
        "{e}"
    );
    // A node that is its own child.
    let e = bad("cycle.glb", &|j| j["nodes"][0]["children"] = json!([0]));
    assert!(e.contains("cycle.glb:") && e.contains("node 0"), "{e}");
    // A buffer shorter than declared.
    let mut j = json.clone();
    j["buffers"][0]["byteLength"] = json!(bin.len() + 8);
    assert!(load_err(&put("short.glb", glb(&j, &bin))).contains("buffer 0:"));
}

// ---------------------------------------------------------------------------------------
// Format detection

#[test]
fn format_by_extension_then_by_content() {
    let cases: [(&str, Vec<u8>, InputFormat); 5] = [
        (
            "a.dat",
            ply("ascii", &XYZ, &tetra_rows(), &tetra_faces()),
            InputFormat::Ply,
        ),
        ("b.dat", stl_binary(&tetra_facets(), b"x"), InputFormat::Stl),
        (
            "c.dat",
            stl_ascii(&tetra_facets()).into_bytes(),
            InputFormat::Stl,
        ),
        (
            "d",
            {
                let (j, b) = tetra_gltf(json!([{"mesh": 0}]), json!([0]));
                glb(&j, &b)
            },
            InputFormat::Gltf,
        ),
        (
            "e.txt",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
            InputFormat::Obj,
        ),
    ];
    for (name, bytes, want) in cases {
        let p = put(name, bytes);
        assert_eq!(InputFormat::detect(&p).unwrap(), want, "{name}");
        load(&p);
    }
    for (name, what) in [("x.off", "OFF"), ("x.fbx", "FBX"), ("x.dae", "COLLADA")] {
        let p = put(name, "OFF\n");
        let e = load_err(&p);
        assert!(
            e.contains(&format!("{name}: {what} files are not supported")),
            "{e}"
        );
    }
    let p = put("y.mesh", "OFF\n3 1 0\n");
    assert!(load_err(&p).contains("y.mesh: OFF files are not supported"));
}

// ---------------------------------------------------------------------------------------
// Writers read back, spot through every format

/// Writes `mesh` at `level` (f32 samples, as `tessellate` writes) to `path`.
fn write(mesh: &Mesh, scheme: Scheme, level: u32, path: &Path) -> StitchedMesh<[f32; 3]> {
    let table = PatchTable::build(mesh, scheme, &SchemeOptions::default()).unwrap();
    let (w, plan, _) =
        stitch_in::<[f32; 3]>(mesh, &table, &CpuEvaluator::default(), level).unwrap();
    let format = MeshFormat::from_path(path).unwrap();
    write_stitched::<[f32; 3]>(
        path,
        &TempFiles::default(),
        format,
        &plan,
        "test",
        &NoProgress,
        &mut |sink| {
            stitch_into(&plan, &table, &CpuEvaluator::default(), sink, &NoProgress).map(|_| ())
        },
    )
    .unwrap();
    w
}

/// The stitched mesh's triangles as corner positions, widened to f64.
fn stitched_corners(w: &StitchedMesh<[f32; 3]>) -> Vec<[DVec3; 3]> {
    w.triangles
        .iter()
        .map(|t| {
            t.map(|r| {
                DVec3::from(w.positions[w.record_position[r as usize] as usize].map(f64::from))
            })
        })
        .collect()
}

/// The stitched mesh as a soup of records (the PLY and glTF vertex lists).
fn record_soup(w: &StitchedMesh<[f32; 3]>, normals: bool) -> Mesh {
    let p: Vec<DVec3> = w
        .record_position
        .iter()
        .map(|&i| DVec3::from(w.positions[i as usize].map(f64::from)))
        .collect();
    let n: Vec<DVec3> = w
        .normals
        .iter()
        .map(|n| DVec3::from(n.map(f64::from)))
        .collect();
    Mesh::from_soup(
        "w",
        &p,
        &w.triangles,
        normals.then_some(&n[..]),
        &LoadOptions::default(),
    )
    .unwrap()
}

/// The stitched mesh as STL holds it: three corners per triangle.
fn facet_soup(w: &StitchedMesh<[f32; 3]>) -> Mesh {
    let p: Vec<DVec3> = stitched_corners(w).into_iter().flatten().collect();
    let t: Vec<[u32; 3]> = (0..w.triangles.len() as u32)
        .map(|f| [3 * f, 3 * f + 1, 3 * f + 2])
        .collect();
    Mesh::from_soup("w", &p, &t, None, &LoadOptions::default()).unwrap()
}

#[test]
fn every_writer_reads_back_to_the_same_mesh_and_statistics() {
    let mesh = common::load("torus200");
    let level = 3;
    let records = {
        let w = write(&mesh, Scheme::G1, level, &dir().join("rt.ply"));
        (stats(&record_soup(&w, true)), w)
    };
    let (want_stats, w) = records;
    let want = stitched_corners(&w);
    for ext in ["ply", "glb"] {
        let p = dir().join(format!("rt.{ext}"));
        write(&mesh, Scheme::G1, level, &p);
        let m = load(&p);
        assert_eq!(m.triangles.len(), w.triangles.len(), "{ext}");
        assert_eq!(corners(&m), want, "{ext}: positions bitwise");
        // Normals are the file's f32 ones, renormalised in f64 (within 1e-7 of unit as
        // written), so compared through the statistics of the same soup.
        assert_eq!(stats(&m), want_stats, "{ext}");
    }
    let p = dir().join("rt.stl");
    write(&mesh, Scheme::G1, level, &p);
    let m = load(&p);
    assert_eq!(m.triangles.len(), w.triangles.len());
    assert_eq!(corners(&m), want, "stl: positions bitwise");
    assert_eq!(stats(&m), stats(&facet_soup(&w)), "stl");
    // OBJ: decimal text of the f32 samples' exact values, read back bit for bit.
    let p = dir().join("rt.obj");
    write(&mesh, Scheme::G1, level, &p);
    let m = load(&p);
    assert_eq!(m.triangles.len(), w.triangles.len());
    assert_eq!(corners(&m), want, "obj: positions bitwise");
    // The OBJ reader keeps the file's vertex order, which is the writer's: the same mesh,
    // so the same statistics, bit for bit.
    assert_eq!(stats(&m), want_stats, "obj");
}

/// `mesh` as an OBJ with its f64 values rounded to f32 (positions and per-corner normals,
/// in the mesh's order): what the f32 writers of `flat` level 1 hold.
fn f32_obj(mesh: &Mesh, path: &Path) {
    let mut s = String::new();
    for p in &mesh.positions {
        // The f32 value printed exactly (as f64): the reader gets the f32 value back.
        let q = p.to_array().map(|x| x as f32 as f64);
        s += &format!("v {:?} {:?} {:?}\n", q[0], q[1], q[2]);
    }
    for t in &mesh.corner_normals {
        for n in t {
            let q = n.to_array().map(|x| x as f32 as f64);
            s += &format!("vn {:?} {:?} {:?}\n", q[0], q[1], q[2]);
        }
    }
    for (i, t) in mesh.triangles.iter().enumerate() {
        s += &format!(
            "f {}//{} {}//{} {}//{}\n",
            t[0] + 1,
            3 * i + 1,
            t[1] + 1,
            3 * i + 2,
            t[2] + 1,
            3 * i + 3
        );
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn spot_reads_alike_in_every_format() {
    let spot = common::load("spot.obj");
    // Level 1 writes the input mesh itself (in f32): the corner samples are the input
    // vertices, checked below through the positions and triangles read back. Its normals
    // are the scheme's at the corners: G1 interpolates the vertex normals there (`flat`
    // would write each owner triangle's face normal instead).
    for ext in ["ply", "stl", "glb"] {
        write(&spot, Scheme::G1, 1, &dir().join(format!("spot.{ext}")));
    }
    let ply = load(&dir().join("spot.ply"));
    // The OBJ of the same f32 mesh in the writers' numbering.
    let reference = dir().join("spot-f32.obj");
    f32_obj(&ply, &reference);
    let glb = load(&dir().join("spot.glb"));
    let stl = load(&dir().join("spot.stl"));
    // The writers number vertices in order of first use in the patches (the stitcher's
    // numbering), spot.obj lists them in another order: the same mesh, renumbered. Each
    // triangle's corners are the input's, rounded to f32, bit for bit, and every format
    // holds the same numbering.
    let round: Vec<[DVec3; 3]> = corners(&spot)
        .iter()
        .map(|t| t.map(|p| p.as_vec3().as_dvec3()))
        .collect();
    for m in [&ply, &glb, &stl] {
        assert_eq!(corners(m), round, "{}", m.name);
        assert_eq!(m.triangles, ply.triangles, "{}", m.name);
        assert_eq!(m.positions, ply.positions, "{}", m.name);
    }
    // PLY and glTF hold the same f32 vertex records: identical statistics.
    assert_eq!(stats(&ply), stats(&glb));
    // Their normals are the writer's f32 evaluation of the G1 normal at the corner, which
    // is the vertex normal (spot.obj has no `vn`: estimated in f64 on loading), within f32
    // rounding of it (1e-6: a few f32 ulps of a normal computed and normalised in f32).
    for (a, b) in ply.corner_normals.iter().zip(&spot.corner_normals) {
        for k in 0..3 {
            assert!((a[k] - b[k]).length() < 1e-6, "{} vs {}", a[k], b[k]);
        }
    }
    // With the normals estimated alike everywhere (`--recompute-normals`), the same
    // positions give identical statistics in every format, STL included (STL has no
    // vertex normals).
    let opts = LoadOptions::default().with_recompute_normals(true);
    let again = |p: &Path| stats(&Mesh::load(p.to_str().unwrap(), &opts).unwrap());
    let want = again(&reference);
    for ext in ["ply", "glb"] {
        assert_eq!(again(&dir().join(format!("spot.{ext}"))), want, "{ext}");
    }
    assert_eq!(stats(&stl), want, "stl");
    assert_eq!(stl.load_report.normals_estimated, 3 * 5856);
    // UVs: spot.obj has `vt` on every corner, read per corner.
    let uvs = spot.corner_uvs().expect("spot has texture coordinates");
    assert_eq!(uvs.len(), spot.triangles.len());
    assert!(spot.load_report.notes.is_empty());
}

#[test]
fn obj_texture_coordinates_follow_the_corners_and_the_weld() {
    // Two triangles of a seam: vertex 1 and 3 carry different UVs in each face; a third
    // face is degenerate (dropped with its UVs); the last face gives no UV (0, 0 and a note).
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                vt 0.1 0.2\nvt 0.3\nvt 0.5 0.6 0.9\nvt 0.7 0.8\nvt 0.9 1.0\n\
                f 1/1 2/2 3/3\nf 1/4 1/4 2/2\nf 1/5 3/3 4/4\nf 2 3 4\n";
    let m = load(&put("uv.obj", text));
    assert_eq!(m.triangles.len(), 3);
    let uvs = m.corner_uvs().unwrap();
    assert_eq!(
        uvs,
        &[
            [[0.1, 0.2], [0.3, 0.0], [0.5, 0.6]],
            [[0.9, 1.0], [0.5, 0.6], [0.7, 0.8]],
            [[0.0, 0.0]; 3]
        ]
    );
    assert_eq!(
        m.load_report.notes,
        vec!["3 face corners without a texture coordinate: (0, 0) given".to_string()]
    );
    let e = load_err(&put(
        "uvbad.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 1e39\nf 1/1 2/1 3/1\n",
    ));
    assert!(
        e.contains("uvbad.obj:4: texture coordinate beyond the f32 range"),
        "{e}"
    );
    let e = load_err(&put(
        "uvrange.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 1\nf 1/1 2/2 3/1\n",
    ));
    assert!(
        e.contains("uvrange.obj:5:") && e.contains("texture coordinate index 2 out of range"),
        "{e}"
    );
}

#[test]
#[cfg(feature = "cli")]
fn cli_stats_reads_what_tessellate_wrote() {
    let bin = env!("CARGO_BIN_EXE_g1tess");
    for ext in ["ply", "glb", "stl"] {
        let out = dir().join(format!("cli.{ext}"));
        let o = Command::new(bin)
            .args([
                "tessellate",
                "sphere320",
                "--level",
                "2",
                "--backend",
                "cpu",
                "--quiet",
                "-o",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let o = Command::new(bin)
            .args(["stats", "--backend", "cpu", "--json"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{ext}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        // Level 2 splits each of the 320 triangles into 4.
        assert_eq!(v["triangles"], 1280, "{ext}");
        assert_eq!(v["boundary_edges"], 0, "{ext}: closed");
    }
}
