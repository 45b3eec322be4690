//! Texture coordinates and colours carried through tessellation: interpolated linearly in
//! each patch's barycentric domain, split at UV seams (records) while positions stay shared
//! bit for bit, and written by every writer so that the matching reader gives them back.

use crate::common;

use std::collections::HashMap;

use g1tess::stitch_plan;
use g1tess::CpuEvaluator;
use g1tess::NoProgress;
use g1tess::TempFiles;
use g1tess::Vector;
use g1tess::{stitch_into, StitchPlan, StitchedMesh};
use g1tess::{write_stitched, MeshFormat};
use g1tess::{InnerRule, Levels};
use g1tess::{LoadOptions, Mesh};
use g1tess::{PatchTable, Scheme, SchemeOptions};
use glam::DVec3;

/// A unit cube (8 vertices, 12 triangles, estimated smooth normals) whose six faces each
/// have their own square of the UV plane: every cube edge is a UV seam, the face diagonals
/// are not. With `colors`, each corner also gets a colour (with alpha) of its face.
fn seamed_cube(colors: bool) -> Mesh {
    let p = common::cube_corners();
    let quads = common::CUBE_QUADS;
    let mut tris = Vec::new();
    let mut uvs = Vec::new();
    let mut cols = Vec::new();
    for (f, q) in quads.iter().enumerate() {
        // The face's chart: a square at (f, f / 2) scaled by 0.75, with irregular corners
        // so that no two faces share a UV.
        let chart = |c: usize| -> [f32; 2] {
            let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]][c];
            [
                f as f32 + 0.75 * sq[0] + 0.01 * c as f32,
                0.5 * f as f32 + 0.75 * sq[1],
            ]
        };
        let col = |c: usize| -> [f32; 4] {
            [
                f as f32 / 6.0,
                c as f32 / 4.0,
                1.0 - f as f32 / 8.0,
                0.5 + c as f32 / 8.0,
            ]
        };
        for t in [[0, 1, 2], [0, 2, 3]] {
            tris.push(t.map(|c| q[c]));
            uvs.push(t.map(chart));
            cols.push(t.map(col));
        }
    }
    let mut mesh = Mesh::from_soup("cube", &p, &tris, None, &LoadOptions::default()).unwrap();
    assert_eq!(mesh.triangles, tris, "the weld keeps the cube as it is");
    mesh.set_corner_uvs(Some(uvs)).unwrap();
    if colors {
        mesh.set_corner_colors(Some(cols), true).unwrap();
    }
    mesh
}

fn table(mesh: &Mesh) -> PatchTable {
    PatchTable::build(mesh, Scheme::G1, &SchemeOptions::default()).unwrap()
}

/// Linear interpolation of a triangle's corner values at barycentric `b`, in f64.
fn lerp<const N: usize>(c: &[[f32; N]; 3], b: [f64; 3]) -> [f64; N] {
    std::array::from_fn(|i| (0..3).map(|k| b[k] * c[k][i] as f64).sum())
}

/// Checks a stitched seamed mesh against its plan: closed by position (every position edge
/// used twice, once each way), each record's UV (and colour) the linear interpolation of
/// the corner values of every patch that uses it, corner records the input values bit for
/// bit, and across every seam: different records on the two sides, one position. Returns
/// (seam samples checked, records).
fn check_seamed<V: Vector>(mesh: &Mesh, plan: &StitchPlan, out: &StitchedMesh<V>) -> usize {
    let uvs = mesh.corner_uvs().unwrap();
    assert_eq!(out.attributes.len(), out.record_position.len());
    // Watertight by position.
    let ptris: Vec<[u32; 3]> = out.position_triangles();
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for t in &ptris {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "position edge {a}-{b} used {n} times one way");
        assert_eq!(
            directed.get(&(b, a)),
            Some(&1),
            "position edge {a}-{b} open"
        );
    }
    let edges = directed.len() / 2;
    assert_eq!(
        out.positions.len() as i64 - edges as i64 + ptris.len() as i64,
        2,
        "a sphere's Euler characteristic"
    );
    // Records of each position, per patch sample.
    let (mut rec, mut pos, mut bary) = (Vec::new(), Vec::new(), Vec::new());
    let mut by_position: HashMap<u32, Vec<(u32, usize)>> = HashMap::new();
    for p in 0..plan.patches() {
        plan.local_ids(p, &mut rec, &mut pos);
        bary.clear();
        plan.patch_points(p, &mut bary);
        for g in 0..rec.len() {
            let r = rec[g] as usize;
            assert_eq!(out.record_position[r], pos[g]);
            let a = out.attributes[r];
            let want = lerp(&uvs[p], bary[g]);
            for i in 0..2 {
                // Interpolated in f64 and rounded once to f32: half an f32 ulp of values
                // below 8, plus the f64 sums' own rounding.
                assert!(
                    (a.uv[i] as f64 - want[i]).abs() <= 5e-7,
                    "patch {p} sample {g}: uv {:?}, expected {want:?}",
                    a.uv
                );
            }
            if let Some(c) = mesh.corner_colors() {
                let want = lerp(&c[p], bary[g]);
                for (&got, want) in a.color.iter().zip(want) {
                    // As for the UVs, values in [0, 1].
                    assert!((got as f64 - want).abs() <= 1e-7);
                }
            }
            if bary[g].contains(&1.0) {
                let k = bary[g].iter().position(|&x| x == 1.0).unwrap();
                assert_eq!(a.uv, uvs[p][k], "corner UVs are the input's");
            }
            by_position.entry(pos[g]).or_default().push((rec[g], p));
        }
    }
    // Seams: a position on a cube edge (not a face diagonal) has one record per face.
    let face = |p: usize| p / 2;
    let mut seam_samples = 0;
    for uses in by_position.values() {
        let mut records: HashMap<usize, u32> = HashMap::new();
        for &(r, p) in uses {
            let prev = *records.entry(face(p)).or_insert(r);
            assert_eq!(prev, r, "one record per face at a position");
        }
        let distinct: std::collections::HashSet<u32> = records.values().copied().collect();
        assert_eq!(distinct.len(), records.len(), "each face its own record");
        if records.len() > 1 {
            seam_samples += 1;
        }
    }
    seam_samples
}

#[test]
fn seamed_cube_is_watertight_with_both_uv_sets() {
    let mesh = seamed_cube(true);
    let t = table(&mesh);
    let n = 4u32;
    let plan = StitchPlan::new(&mesh, &mesh.adjacency(), n).unwrap();
    assert!(plan.has_uvs() && plan.has_colors() && plan.colors_have_alpha());
    // Positions: 8 + 18 edges × 3 + 12 patches × 3 interior. Records: 3 per cube vertex
    // (one per face), 2 × 3 per cube edge (seams), 3 per diagonal, interiors.
    assert_eq!(plan.positions, 8 + 18 * 3 + 12 * 3);
    assert_eq!(plan.records, 8 * 3 + 12 * 2 * 3 + 6 * 3 + 12 * 3);
    assert_eq!(plan.report.split_edges, 12);
    let (f64_out, _) = stitch_plan::<DVec3>(&plan, &t, &CpuEvaluator::default()).unwrap();
    // Seam samples: the 8 corners and 12 × 3 edge samples.
    assert_eq!(check_seamed(&mesh, &plan, &f64_out), 8 + 12 * 3);
    let (f32_out, _) = stitch_plan::<[f32; 3]>(&plan, &t, &CpuEvaluator::default()).unwrap();
    assert_eq!(check_seamed(&mesh, &plan, &f32_out), 8 + 12 * 3);
    // The same attributes whatever the sample precision.
    assert_eq!(f64_out.attributes, f32_out.attributes);
}

#[test]
fn seamed_cube_per_edge_levels() {
    let mesh = seamed_cube(false);
    let adj = mesh.adjacency();
    let mut rng = common::Rng(13);
    let edges: Vec<u32> = (0..adj.edges.len())
        .map(|_| 1 + (rng.next_u64() % 6) as u32)
        .collect();
    let seam_samples: usize = adj
        .edges
        .iter()
        .zip(&edges)
        .filter(|(e, _)| {
            let (t0, t1) = (e.uses[0].triangle, e.uses[1].triangle);
            t0 / 2 != t1 / 2
        })
        .map(|(_, &l)| l as usize - 1)
        .sum();
    let levels = Levels::from_edges(&mesh, &adj, edges, InnerRule::Max).unwrap();
    assert!(levels.uniform_level().is_none());
    let plan = StitchPlan::with_levels(&mesh, &adj, &levels).unwrap();
    let t = table(&mesh);
    let (f64_out, _) = stitch_plan::<DVec3>(&plan, &t, &CpuEvaluator::default()).unwrap();
    assert_eq!(check_seamed(&mesh, &plan, &f64_out), 8 + seam_samples);
    let (f32_out, _) = stitch_plan::<[f32; 3]>(&plan, &t, &CpuEvaluator::default()).unwrap();
    assert_eq!(check_seamed(&mesh, &plan, &f32_out), 8 + seam_samples);
}

#[test]
fn meshes_without_attributes_carry_none() {
    let mesh = common::load("sphere320");
    let plan = StitchPlan::new(&mesh, &mesh.adjacency(), 3).unwrap();
    assert!(!plan.has_attributes() && !plan.has_uvs() && !plan.has_colors());
    let (out, _) = stitch_plan::<[f32; 3]>(&plan, &table(&mesh), &CpuEvaluator::default()).unwrap();
    assert!(out.attributes.is_empty());
    // No records beyond one per position: normals are not split on the sphere.
    assert_eq!(plan.records, plan.positions);
    // Attributes out of step with the triangles (the field is public) are refused.
    let mut bad = mesh.clone();
    bad.attributes.uvs = Some(vec![[[0.0; 2]; 3]; 3]);
    let e = StitchPlan::new(&bad, &bad.adjacency(), 3)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("attributes for 3 triangles, the mesh has 320"),
        "{e}"
    );
}

fn temp(name: &str) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-attributes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Tessellates `mesh` at `level` in f32 into `path` and in memory (the same plan).
fn write(mesh: &Mesh, level: u32, path: &std::path::Path) -> (StitchPlan, StitchedMesh<[f32; 3]>) {
    let plan = StitchPlan::new(mesh, &mesh.adjacency(), level).unwrap();
    let t = table(mesh);
    let format = MeshFormat::from_path(path).unwrap();
    write_stitched::<[f32; 3]>(
        path,
        &TempFiles::default(),
        format,
        &plan,
        "test",
        &NoProgress,
        &mut |sink| {
            stitch_into(&plan, &t, &CpuEvaluator::default(), sink, &NoProgress)?;
            Ok(())
        },
    )
    .unwrap();
    let (out, _) = stitch_plan::<[f32; 3]>(&plan, &t, &CpuEvaluator::default()).unwrap();
    (plan, out)
}

/// Reads the f32 values of a glTF accessor (float components) from a GLB, through the
/// `gltf` crate's document and the accessor's own offsets and stride.
fn glb_floats(bytes: &[u8], attribute: &str) -> Vec<Vec<f32>> {
    let g = gltf::Gltf::from_slice(bytes).unwrap();
    let blob = g.blob.as_ref().unwrap();
    let prim = g.meshes().next().unwrap().primitives().next().unwrap();
    let acc = prim
        .attributes()
        .find(|(s, _)| s.to_string() == attribute)
        .unwrap_or_else(|| panic!("no {attribute}"))
        .1;
    assert_eq!(acc.data_type(), gltf::accessor::DataType::F32);
    let view = acc.view().unwrap();
    let width = acc.dimensions().multiplicity();
    let stride = view.stride().unwrap_or(4 * width);
    (0..acc.count())
        .map(|i| {
            let at = view.offset() + acc.offset() + i * stride;
            (0..width)
                .map(|c| f32::from_le_bytes(blob[at + 4 * c..at + 4 * c + 4].try_into().unwrap()))
                .collect()
        })
        .collect()
}

#[test]
fn spot_glb_has_the_input_uvs_at_the_input_corners() {
    let spot = common::load("spot.obj");
    let uvs = spot.corner_uvs().expect("spot has texture coordinates");
    let path = temp("spot.glb");
    let n = 2;
    let (plan, _) = write(&spot, n, &path);
    let texcoords = glb_floats(&std::fs::read(&path).unwrap(), "TEXCOORD_0");
    assert_eq!(texcoords.len(), plan.records);
    // Grid indices of the corners at level n: (0, 0), (n, 0), (0, n).
    let corners = [0, n as usize, g1tess::grid_len(n) - 1];
    let (mut rec, mut pos) = (Vec::new(), Vec::new());
    for (t, tri_uvs) in uvs.iter().enumerate() {
        plan.local_ids(t, &mut rec, &mut pos);
        for k in 0..3 {
            let r = rec[corners[k]] as usize;
            assert_eq!(texcoords[r], tri_uvs[k].to_vec(), "triangle {t} corner {k}");
        }
    }
    std::fs::remove_file(&path).unwrap();
}

/// Writes `mesh` at level 2 as `ext` and reads it back: the reader's triangles are the
/// stitched ones in order, with the written UVs and colours at their corners (within
/// `color_tol`).
fn round_trip(mesh: &Mesh, ext: &str, uv_exact: bool, color_tol: f32) {
    let path = temp(&format!("{}.{ext}", mesh.name.replace('.', "-")));
    let (plan, out) = write(mesh, 2, &path);
    let back = Mesh::load(path.to_str().unwrap(), &LoadOptions::default()).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(back.triangles.len(), plan.triangles, "{ext}");
    let ptris = out.position_triangles();
    let uvs = back.corner_uvs().expect("texture coordinates read back");
    for (i, t) in out.triangles.iter().enumerate() {
        for k in 0..3 {
            // The same triangle: its corners at the written positions.
            let p = out.positions[ptris[i][k] as usize];
            let q = back.positions[back.triangles[i][k] as usize];
            // f32 in every format (OBJ's shortest decimals read back to the same f32).
            assert_eq!(q.as_vec3().to_array(), p, "{ext}: triangle {i}");
            let a = out.attributes[t[k] as usize];
            let got = uvs[i][k];
            if uv_exact {
                assert_eq!(got, a.uv, "{ext}: triangle {i} corner {k}");
            } else {
                for c in 0..2 {
                    // Text: the shortest decimal that reads back to the f32, read in f64
                    // and rounded to f32: one f32 ulp at most.
                    let ulp = f32::EPSILON * a.uv[c].abs().max(f32::MIN_POSITIVE);
                    assert!((got[c] - a.uv[c]).abs() <= ulp, "{ext}: {got:?} {:?}", a.uv);
                }
            }
            if let Some(cols) = back.corner_colors() {
                for c in 0..4 {
                    assert!(
                        (cols[i][k][c] - a.color[c]).abs() <= color_tol,
                        "{ext}: colour {:?} written {:?}",
                        cols[i][k],
                        a.color
                    );
                }
            }
        }
    }
    if plan.has_colors() {
        let cols = back.corner_colors().expect("colours read back");
        assert_eq!(cols.len(), plan.triangles);
        assert_eq!(back.colors_have_alpha(), plan.colors_have_alpha());
    }
}

#[test]
fn writers_round_trip_attributes() {
    let spot = common::load("spot.obj");
    round_trip(&spot, "obj", false, 0.0);
    round_trip(&spot, "ply", true, 0.0);
    round_trip(&spot, "glb", true, 0.0);
    let cube = seamed_cube(true);
    // PLY colours are bytes: half a step of 1/255 (and f32 rounding of the quotient).
    round_trip(&cube, "ply", true, 0.5 / 255.0 + 1e-6);
    // glTF colours are f32 as interpolated.
    round_trip(&cube, "glb", true, 0.0);
}

#[test]
fn stl_and_attribute_free_outputs_are_unchanged() {
    // STL has no attributes; its output for a mesh with UVs equals the mesh without them.
    let spot = common::load("spot.obj");
    let mut bare = spot.clone();
    bare.set_corner_uvs(None).unwrap();
    for ext in ["stl", "obj", "ply", "glb"] {
        let a = temp(&format!("with.{ext}"));
        let b = temp(&format!("without.{ext}"));
        write(&spot, 1, &a);
        write(&bare, 1, &b);
        let (x, y) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
        if ext == "stl" {
            assert_eq!(x, y, "STL ignores attributes");
        } else {
            assert_ne!(x, y, "{ext} carries the UVs");
            // The UVs only add: OBJ `vt` lines (one per record) and `/r` in faces.
            if ext == "obj" {
                let vt = String::from_utf8(x).unwrap();
                let (vts, fs) = (
                    vt.lines().filter(|l| l.starts_with("vt ")).count(),
                    vt.lines().filter(|l| l.starts_with("f ")).count(),
                );
                let plan = StitchPlan::new(&spot, &spot.adjacency(), 1).unwrap();
                assert_eq!(vts, plan.records);
                assert_eq!(fs, plan.triangles);
            }
        }
        std::fs::remove_file(&a).unwrap();
        std::fs::remove_file(&b).unwrap();
    }
}
