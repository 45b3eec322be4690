//! OBJ, binary PLY, binary STL and glTF binary output, read back (readers written here,
//! the project's own OBJ reader, the `gltf` crate) and compared with the stitched mesh in
//! memory of the same precision (files are written from f32 samples, as `tessellate` does,
//! and from f64 ones); atomic writes; the command line.

use std::path::{Path, PathBuf};
#[cfg(feature = "cli")]
use std::process::Command;

use glam::DVec3;

use g1tess::ply_file_bytes;
use g1tess::stitch_in;
use g1tess::CpuEvaluator;
use g1tess::NoProgress;
use g1tess::TempFiles;
use g1tess::Vector;
use g1tess::{stitch_into, PatchOut, StitchPlan, StitchSink, StitchedMesh};
use g1tess::{write_stitched, MeshFormat};
use g1tess::{LoadOptions, Mesh};
use g1tess::{PatchTable, Scheme, SchemeOptions};

use crate::common;

fn dir() -> PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-formats-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A smooth mesh and one with split normals (cube with one normal per face).
fn meshes() -> Vec<Mesh> {
    // A folder per call: one test writing `cube.obj` (truncating it first) while another
    // read it gave the reader an empty file ("no faces") in a CI-like run.
    let cube = common::fresh_dir(&dir(), "meshes").join("cube.obj");
    std::fs::write(&cube, common::cube_obj(true)).unwrap();
    vec![
        Mesh::load("torus200", &LoadOptions::default()).unwrap(),
        Mesh::load(cube.to_str().unwrap(), &LoadOptions::default()).unwrap(),
    ]
}

/// Writes `mesh` at `level` to `path` from samples of precision `V` and returns the
/// in-memory stitched mesh of the same precision.
fn write_in<V: Vector>(mesh: &Mesh, level: u32, path: &Path) -> (StitchedMesh<V>, StitchPlan) {
    let table = PatchTable::build(mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let (w, plan, _) = stitch_in::<V>(mesh, &table, &CpuEvaluator::default(), level).unwrap();
    let format = MeshFormat::from_path(path).unwrap();
    write_stitched::<V>(
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
    (w, plan)
}

/// [`write_in`] in f32, as `tessellate` writes.
fn write(mesh: &Mesh, level: u32, path: &Path) -> (StitchedMesh<[f32; 3]>, StitchPlan) {
    write_in::<[f32; 3]>(mesh, level, path)
}

fn f32s<V: Vector>(v: V) -> [f32; 3] {
    v.to_f32()
}

/// Equal lengths and bitwise equal entries, reporting the first difference.
fn same<V: Vector>(got: &[DVec3], want: &[V], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: lengths");
    if let Some(i) = (0..got.len()).find(|&i| got[i] != want[i].to_dvec3()) {
        panic!(
            "{what}: entry {i} reads back as {} instead of {:?}",
            got[i], want[i]
        );
    }
}

/// What [`read_obj`] returns: positions, normals, faces as position and normal indices.
type ObjData = (Vec<DVec3>, Vec<DVec3>, Vec<[u32; 3]>, Vec<[u32; 3]>);

/// A minimal OBJ reader for what the writer emits: `v`, `vn`, `f p//n p//n p//n`.
fn read_obj(path: &Path) -> ObjData {
    let text = std::fs::read_to_string(path).unwrap();
    let (mut v, mut vn, mut fp, mut fr) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let xyz = |rest: &str| -> DVec3 {
        let c: Vec<f64> = rest.split(' ').map(|x| x.parse().unwrap()).collect();
        assert_eq!(c.len(), 3);
        DVec3::from_slice(&c)
    };
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("v ") {
            v.push(xyz(rest));
        } else if let Some(rest) = line.strip_prefix("vn ") {
            vn.push(xyz(rest));
        } else if let Some(rest) = line.strip_prefix("f ") {
            let c: Vec<(u32, u32)> = rest
                .split(' ')
                .map(|c| {
                    let (p, n) = c.split_once("//").unwrap();
                    (p.parse::<u32>().unwrap() - 1, n.parse::<u32>().unwrap() - 1)
                })
                .collect();
            assert_eq!(c.len(), 3);
            // Faces only refer to lines already read (the file streams).
            assert!(c
                .iter()
                .all(|&(p, n)| (p as usize) < v.len() && (n as usize) < vn.len()));
            fp.push([c[0].0, c[1].0, c[2].0]);
            fr.push([c[0].1, c[1].1, c[2].1]);
        } else {
            assert!(
                line.starts_with('#') || line.is_empty(),
                "unexpected line {line}"
            );
        }
    }
    (v, vn, fp, fr)
}

#[test]
fn obj_reads_back_exactly() {
    for mesh in meshes() {
        let path = dir().join(format!("{}.obj", mesh.name));
        let (w, _) = write(&mesh, 4, &path);
        let (pos, nrm, fp, fr) = read_obj(&path);
        // Each f32 sample is written as the shortest decimal of its exact f64 value: parsed
        // as f64 it is the f32 itself (and read as f32 by any reader, too).
        let widened = |v: &[DVec3]| -> Vec<DVec3> {
            v.iter()
                .map(|p| DVec3::from(f32s(*p).map(f64::from)))
                .collect()
        };
        assert_eq!(
            widened(&pos),
            pos,
            "{}: positions are f32 values",
            mesh.name
        );
        assert_eq!(widened(&nrm), nrm, "{}: normals are f32 values", mesh.name);
        same(&pos, &w.positions, &mesh.name);
        same(&nrm, &w.normals, &mesh.name);
        // Shortest: every number is Rust's shortest round-trip text of the f64 it reads as.
        let text = std::fs::read_to_string(&path).unwrap();
        for line in text.lines().filter(|l| l.starts_with('v')) {
            for x in line.split(' ').skip(1) {
                let back: f64 = x.parse().unwrap();
                assert_eq!(format!("{back:?}"), x, "{x} in {line}");
            }
        }
        assert_eq!(fp, w.position_triangles());
        assert_eq!(fr, w.triangles);
        // From f64 samples every value reads back exactly as f64.
        let path64 = dir().join(format!("{}-f64.obj", mesh.name));
        let (w64, _) = write_in::<DVec3>(&mesh, 4, &path64);
        let (pos64, nrm64, fp64, _) = read_obj(&path64);
        same(&pos64, &w64.positions, &mesh.name);
        same(&nrm64, &w64.normals, &mesh.name);
        assert_eq!(fp64, fp);
        // The project's own reader welds it back to a mesh with the same positions at every
        // triangle corner.
        let back = Mesh::load(path64.to_str().unwrap(), &LoadOptions::default()).unwrap();
        assert_eq!(back.positions.len(), w.positions.len());
        let corners = |tris: &[[u32; 3]], pos: &[DVec3]| -> Vec<DVec3> {
            tris.iter().flatten().map(|&i| pos[i as usize]).collect()
        };
        same(
            &corners(&back.triangles, &back.positions),
            &corners(&w64.position_triangles(), &w64.positions),
            &mesh.name,
        );
    }
}

/// A minimal binary PLY reader: header counts, then the vertex and face elements.
fn read_ply(path: &Path) -> (Vec<[f32; 6]>, Vec<[i32; 3]>) {
    let bytes = std::fs::read(path).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    let lines: Vec<&str> = header.lines().collect();
    assert_eq!(lines[0], "ply");
    assert_eq!(lines[1], "format binary_little_endian 1.0");
    let count = |el: &str| -> usize {
        lines
            .iter()
            .find_map(|l| l.strip_prefix(&format!("element {el} ")))
            .unwrap()
            .parse()
            .unwrap()
    };
    let props: Vec<&str> = lines
        .iter()
        .filter(|l| l.starts_with("property"))
        .copied()
        .collect();
    assert_eq!(
        props,
        [
            "property float x",
            "property float y",
            "property float z",
            "property float nx",
            "property float ny",
            "property float nz",
            "property list uchar int vertex_indices"
        ]
    );
    let (nv, nf) = (count("vertex"), count("face"));
    let mut at = end;
    let mut verts = Vec::with_capacity(nv);
    for _ in 0..nv {
        verts.push(std::array::from_fn(|k| {
            f32::from_le_bytes(bytes[at + 4 * k..at + 4 * k + 4].try_into().unwrap())
        }));
        at += 24;
    }
    let mut faces = Vec::with_capacity(nf);
    for _ in 0..nf {
        assert_eq!(bytes[at], 3);
        faces.push(std::array::from_fn(|k| {
            i32::from_le_bytes(bytes[at + 1 + 4 * k..at + 5 + 4 * k].try_into().unwrap())
        }));
        at += 13;
    }
    assert_eq!(at, bytes.len(), "trailing bytes");
    (verts, faces)
}

/// Meshes and levels whose face section is over 1 MiB in PLY and glTF: the writer puts
/// it in place from a thread of its own while the vertices stream (on a file; the split
/// point is the first page boundary in the section, so the stream writes the section's
/// first bytes). The bunny at level 2 has 52 bytes of PLY faces per patch, so that split
/// point lies many patches in.
fn large_cases() -> Vec<(Mesh, u32)> {
    vec![
        (
            Mesh::load("sphere320", &LoadOptions::default()).unwrap(),
            20,
        ),
        (
            Mesh::load("tests/data/stanford-bunny.obj", &LoadOptions::default()).unwrap(),
            2,
        ),
    ]
}

#[test]
fn ply_reads_back() {
    let cases = meshes().into_iter().map(|m| (m, 5)).chain(large_cases());
    for (mesh, level) in cases {
        let path = dir().join(format!("{}-{level}.ply", mesh.name));
        let (w, plan) = write(&mesh, level, &path);
        assert_eq!(
            std::fs::metadata(&path).unwrap().len(),
            ply_file_bytes(&plan, "test")
        );
        let (verts, faces) = read_ply(&path);
        assert_eq!(verts.len(), plan.records);
        for (r, v) in verts.iter().enumerate() {
            let p = w.positions[w.record_position[r] as usize];
            let n = w.normals[r];
            assert_eq!(v[..3], f32s(p));
            assert_eq!(v[3..], f32s(n));
        }
        let expect: Vec<[i32; 3]> = w.triangles.iter().map(|t| t.map(|i| i as i32)).collect();
        assert_eq!(faces, expect);
    }
}

#[test]
fn stl_reads_back() {
    for mesh in meshes() {
        let path = dir().join(format!("{}.stl", mesh.name));
        let (w, plan) = write(&mesh, 3, &path);
        let bytes = std::fs::read(&path).unwrap();
        assert!(!bytes.starts_with(b"solid"));
        let n = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
        assert_eq!(n, plan.triangles);
        assert_eq!(bytes.len(), 84 + 50 * n);
        let f = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        for (i, t) in w.position_triangles().iter().enumerate() {
            let base = 84 + 50 * i;
            let normal = [f(base), f(base + 4), f(base + 8)];
            let p = t.map(|k| w.positions[k as usize]);
            for (c, q) in p.iter().enumerate() {
                let at = base + 12 + 12 * c;
                assert_eq!([f(at), f(at + 4), f(at + 8)], f32s(*q));
            }
            let d = p.map(|q| q.to_dvec3());
            let flat = (d[1] - d[0]).cross(d[2] - d[0]).normalize();
            assert_eq!(normal, f32s(flat));
        }
    }
}

#[test]
fn glb_reads_back() {
    let cases = meshes().into_iter().map(|m| (m, 4)).chain(large_cases());
    for (mesh, level) in cases {
        let path = dir().join(format!("{}-{level}.glb", mesh.name));
        let (w, plan) = write(&mesh, level, &path);
        // The gltf crate parses the container and the JSON; its one buffer is the GLB's
        // binary chunk.
        let glb = gltf::Gltf::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        let buffers = [glb.blob.clone().unwrap()];
        let doc = glb.document;
        let prim = doc.meshes().next().unwrap().primitives().next().unwrap();
        // Read each accessor through its buffer view (offset, stride, component type).
        let read = |acc: gltf::Accessor<'_>, width: usize| -> Vec<[u8; 4]> {
            let view = acc.view().unwrap();
            let data = &buffers[view.buffer().index()];
            let stride = view.stride().unwrap_or(4 * width);
            let mut out = Vec::new();
            for i in 0..acc.count() {
                let at = view.offset() + acc.offset() + i * stride;
                for k in 0..width {
                    out.push(data[at + 4 * k..at + 4 * k + 4].try_into().unwrap());
                }
            }
            out
        };
        let vec3 = |acc: gltf::Accessor<'_>| -> Vec<[f32; 3]> {
            assert_eq!(acc.data_type(), gltf::accessor::DataType::F32);
            assert_eq!(acc.dimensions(), gltf::accessor::Dimensions::Vec3);
            read(acc, 3)
                .chunks(3)
                .map(|c| std::array::from_fn(|k| f32::from_le_bytes(c[k])))
                .collect()
        };
        let pos = vec3(prim.get(&gltf::Semantic::Positions).unwrap());
        let nrm = vec3(prim.get(&gltf::Semantic::Normals).unwrap());
        let ia = prim.indices().unwrap();
        assert_eq!(ia.data_type(), gltf::accessor::DataType::U32);
        let idx: Vec<u32> = read(ia, 1).into_iter().map(u32::from_le_bytes).collect();
        assert_eq!(pos.len(), plan.records);
        let rp = w.record_positions();
        assert_eq!(pos, rp.iter().map(|p| f32s(*p)).collect::<Vec<_>>());
        assert_eq!(nrm, w.normals.iter().map(|n| f32s(*n)).collect::<Vec<_>>());
        assert_eq!(
            idx,
            w.triangles.iter().flatten().copied().collect::<Vec<_>>()
        );
        // Bounds: the accessor's min/max are those of the f32 positions.
        let acc = prim.get(&gltf::Semantic::Positions).unwrap();
        let min: Vec<f32> = serde_json::from_value(acc.min().unwrap()).unwrap();
        let max: Vec<f32> = serde_json::from_value(acc.max().unwrap()).unwrap();
        for k in 0..3 {
            assert_eq!(
                min[k],
                pos.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min)
            );
            assert_eq!(
                max[k],
                pos.iter().map(|p| p[k]).fold(f32::NEG_INFINITY, f32::max)
            );
        }
    }
}

/// An evaluation that fails half way leaves the previous file as it was and no temporary
/// file behind.
#[test]
fn failed_write_leaves_target_untouched() {
    let mesh = Mesh::load("sphere320", &LoadOptions::default()).unwrap();
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let d = dir().join("atomic");
    std::fs::create_dir_all(&d).unwrap();
    // Level 20: PLY and glTF write their faces from a thread of their own (see
    // `large_cases`), which must stop too.
    for (level, ext) in [
        (3, "obj"),
        (3, "ply"),
        (3, "stl"),
        (3, "glb"),
        (20, "ply"),
        (20, "glb"),
    ] {
        let plan = StitchPlan::new(&mesh, &mesh.adjacency(), level).unwrap();
        let path = d.join(format!("keep.{ext}"));
        std::fs::write(&path, b"previous").unwrap();
        let format = MeshFormat::from_path(&path).unwrap();
        let err = write_stitched::<[f32; 3]>(
            &path,
            &TempFiles::default(),
            format,
            &plan,
            "t",
            &NoProgress,
            &mut |sink| {
                struct Failing<'a>(&'a mut dyn StitchSink<[f32; 3]>, usize);
                impl StitchSink<[f32; 3]> for Failing<'_> {
                    fn patch(&mut self, out: &PatchOut<'_, [f32; 3]>) -> g1tess::Result<()> {
                        self.1 += 1;
                        if self.1 > 100 {
                            return Err(g1tess::Error::Invalid("stopped".into()));
                        }
                        self.0.patch(out)
                    }
                }
                let mut f = Failing(sink, 0);
                stitch_into(
                    &plan,
                    &table,
                    &CpuEvaluator::with_chunk_samples(50),
                    &mut f,
                    &NoProgress,
                )
                .map(|_| ())
            },
        )
        .unwrap_err();
        assert_eq!(err.to_string(), "stopped");
        assert_eq!(std::fs::read(&path).unwrap(), b"previous");
        let left: Vec<_> = std::fs::read_dir(&d).unwrap().collect();
        assert_eq!(left.len(), 1, "temporary file left behind");
        std::fs::remove_file(&path).unwrap();
    }
}

#[cfg(feature = "cli")]
fn g1tess(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
#[cfg(feature = "cli")]
fn cli_tessellate_json_and_errors() {
    let out = dir().join("cli.ply");
    let o = g1tess(&[
        "tessellate",
        "sphere320",
        "--level",
        "3",
        "-o",
        out.to_str().unwrap(),
        "--json",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(o.stderr.is_empty(), "quiet run wrote to stderr");
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // 162 vertices + 480 edges × 2 + 320 patches × 1 interior point.
    assert_eq!(j["vertices"], 162 + 480 * 2 + 320);
    assert_eq!(j["triangles"], 320 * 9);
    for key in ["output", "mesh", "scheme", "level", "backend"] {
        assert!(j.get(key).is_some(), "missing {key}");
    }
    let (verts, faces) = read_ply(&out);
    assert_eq!(verts.len(), 162 + 480 * 2 + 320);
    assert_eq!(faces.len(), 320 * 9);
    // The CPU's f32 path keeps the input vertices (rounded once) bit for bit.
    let o = g1tess(&[
        "tessellate",
        "sphere320",
        "--level",
        "3",
        "--backend",
        "cpu",
        "-o",
        out.to_str().unwrap(),
        "--json",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["precision"], "f32");
    let (verts, _) = read_ply(&out);
    let written: std::collections::HashSet<[u32; 3]> = verts
        .iter()
        .map(|v| [v[0], v[1], v[2]].map(f32::to_bits))
        .collect();
    let input = Mesh::load("sphere320", &LoadOptions::default()).unwrap();
    assert_eq!(input.positions.len(), 162);
    for p in &input.positions {
        assert!(
            written.contains(&f32s(*p).map(f32::to_bits)),
            "input vertex {p} not written bit for bit"
        );
    }

    // Without --quiet but with stderr not a terminal: no progress bar, one summary line.
    let o = g1tess(&[
        "tessellate",
        "torus200",
        "-o",
        dir().join("p.obj").to_str().unwrap(),
    ]);
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    // The backend names its adapter (or its CPU fallback) on a line of its own.
    let err: Vec<&str> = err
        .lines()
        .filter(|l| !l.starts_with("gpu: ") && !l.starts_with("note: "))
        .collect();
    assert_eq!(err.len(), 1, "{err:?}");
    assert!(
        err[0].starts_with("wrote ") && !err[0].contains('\r'),
        "{err:?}"
    );

    let bad = g1tess(&[
        "tessellate",
        "sphere320",
        "-o",
        dir().join("x.xyz").to_str().unwrap(),
    ]);
    assert!(!bad.status.success());
    let msg = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(msg.lines().count(), 1, "{msg}");
    assert!(msg.contains("unknown output format"), "{msg}");

    let missing = dir().join("no/such/dir/out.obj");
    let bad = g1tess(&["tessellate", "sphere320", "-o", missing.to_str().unwrap()]);
    assert!(!bad.status.success());
    assert_eq!(String::from_utf8_lossy(&bad.stderr).lines().count(), 1);
}
