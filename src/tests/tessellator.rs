//! Device-resident tessellation (`gpu::tessellator`): its WGSL validates with naga for
//! every patch kind in f32 and f64 and names the Rust it mirrors; the level-independent
//! topology table gives `StitchPlan`'s numbering exactly at every level (CPU mirror, no
//! GPU); and on the Vulkan adapter (lavapipe in CI) the index buffer equals the plan's
//! triangles and the vertex buffer the stitched CPU surface, with creases and a boundary.
//!
//! Without a Vulkan adapter the GPU tests print a SKIP line and pass, unless CI=true: then
//! they fail.

use glam::DVec3;

use crate::gpu::read_buffer;
use crate::gpu::shaders::validate;
use crate::gpu::tessellator::{
    decode_bounds, record_of, tess_module_source, Topology, FLAG_COPY, FLAG_WRITE, TESS_WGSL,
    VERTEX_BYTES,
};
use crate::CpuEvaluator;
use crate::{stitch, StitchPlan, StitchedMesh};
use crate::{vertex_layout, GpuTessellator};
use crate::{GpuContext, Precision};
use crate::{LoadOptions, Mesh};
use crate::{PatchKind, PatchTable, Scheme, SchemeOptions};

use crate::tests::common;
use crate::tests::eval_cases;
use eval_cases::{angle, context, load, normal_error, open_box, EPS32, EPS64, ROUNDING_FACTOR};

fn fandisk() -> Mesh {
    let opts = LoadOptions::default().with_crease_angle(Some(45.0));
    Mesh::load(&common::shared_spec("fandisk.obj"), &opts).unwrap()
}

#[test]
fn tessellation_module_validates_for_every_kind_in_f32_and_f64() {
    for kind in PatchKind::all() {
        for precision in [Precision::F32, Precision::F64] {
            let src = tess_module_source(kind, precision).unwrap();
            let module = validate(&src, precision)
                .unwrap_or_else(|e| panic!("tessellate.wgsl {kind:?} {precision}: {e}"));
            let entries: Vec<&str> = module
                .entry_points
                .iter()
                .map(|e| e.name.as_str())
                .filter(|n| n.starts_with("tess"))
                .collect();
            assert_eq!(
                entries,
                [
                    "tess_main",
                    "tess_basis_main",
                    "tess_copy_main",
                    "tess_bounds_main"
                ]
            );
        }
    }
    // The vertex layout documented for render pipelines: 24 bytes, position then normal.
    let layout = vertex_layout();
    assert_eq!(layout.array_stride, VERTEX_BYTES);
    assert_eq!(VERTEX_BYTES, 24);
    let attrs: Vec<(u32, u64, wgpu::VertexFormat)> = layout
        .attributes
        .iter()
        .map(|a| (a.shader_location, a.offset, a.format))
        .collect();
    assert_eq!(
        attrs,
        [
            (0, 0, wgpu::VertexFormat::Float32x3),
            (1, 12, wgpu::VertexFormat::Float32x3)
        ]
    );
}

#[test]
fn tessellate_wgsl_names_rust_functions_it_mirrors_and_they_exist() {
    let names = common::mirrored_functions("tessellate.wgsl", TESS_WGSL);
    assert!(
        names.iter().any(|n| n == "gpu::tessellator::record_of"),
        "{names:?}"
    );
    // The table layout and the workgroup size come from the generated header only.
    for name in ["TOPO_STRIDE", "TOPO_EDGE", "TESS_WORKGROUP", "FLAG_COPY"] {
        assert!(
            !TESS_WGSL.contains(&format!("const {name}")),
            "{name} copied"
        );
    }
}

/// The triangles of a plan as record ids, and the position id of every record.
fn plan_triangles(plan: &StitchPlan) -> Vec<[u32; 3]> {
    let grid = crate::eval::grid_triangles(plan.level);
    let mut scratch = (Vec::new(), Vec::new());
    let mut out = Vec::new();
    for p in 0..plan.patches() {
        plan.patch_triangles(p, &grid, &mut scratch, &mut out);
    }
    out
}

/// The table's numbering is the plan's at every level, without a plan per level: counts,
/// triangles (record ids), and split records take their positions from a record of the
/// same position. Meshes with creases (fandisk, the open box), a boundary and a
/// non-manifold edge (suzanne, the open box).
#[test]
fn topology_table_gives_the_stitch_plan_numbering_at_every_level() {
    let suzanne = Mesh::load(&common::shared_spec("suzanne.obj"), &LoadOptions::default()).unwrap();
    for mesh in [open_box(), fandisk(), suzanne] {
        let adj = mesh.adjacency();
        let topo = Topology::new(&mesh, &adj).unwrap();
        let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
        let mut copies = 0;
        for level in [1u32, 2, 3, 5, 8] {
            let plan = StitchPlan::new(&mesh, &adj, level).unwrap();
            assert_eq!(
                topo.records(level),
                plan.records as u64,
                "{} {level}",
                mesh.name
            );
            assert_eq!(topo.index_count(level), 3 * plan.triangles as u64);
            assert_eq!(
                topo.triangles(level),
                plan_triangles(&plan),
                "{} {level}",
                mesh.name
            );
            if level == 3 {
                let (w, _, _) = stitch(&mesh, &table, &CpuEvaluator::default(), level).unwrap();
                for p in 0..topo.patches as u32 {
                    for j in 0..=level {
                        for i in 0..=level - j {
                            let r = record_of(&topo, p, level, i, j);
                            if r.flags & FLAG_COPY != 0 {
                                copies += 1;
                                assert_ne!(r.id, r.source);
                            }
                            assert_eq!(
                                w.record_position[r.id as usize],
                                w.record_position[r.source as usize]
                            );
                        }
                    }
                }
            }
        }
        if mesh.name == "suzanne.obj" {
            assert_eq!((adj.boundary, adj.nonmanifold), (42, 1));
        } else {
            // Creases: split records exist and were checked.
            assert!(topo.copied_blocks > 0 && copies > 0, "{}", mesh.name);
        }
        if mesh.name == "open box" {
            // 4 boundary edges; 8 box edges with a crease, each with a second block.
            assert_eq!(adj.boundary, 4);
            assert_eq!(topo.copied_blocks, 8);
        }
    }
}

/// Copies `bytes` of `src` into a mappable buffer and reads them back (tests only).
fn read_back(ctx: &GpuContext, src: &wgpu::Buffer, bytes: u64) -> Vec<u8> {
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("test readback"),
        size: bytes.max(4),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(src, 0, &staging, 0, bytes);
    ctx.queue.submit([enc.finish()]);
    read_buffer(&ctx.device, &staging, bytes, |b| b.to_vec()).unwrap()
}

/// Positions, normals and triangles read back from the tessellator's buffers.
type Surface = (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<[u32; 3]>);

fn tessellate(ctx: &GpuContext, tess: &mut GpuTessellator, level: u32) -> Surface {
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    let counts = tess
        .tessellate(&ctx.device, &ctx.queue, &mut enc, level)
        .unwrap();
    ctx.queue.submit([enc.finish()]);
    ctx.check().unwrap();
    let v = read_back(ctx, tess.vertices(), counts.vertices as u64 * VERTEX_BYTES);
    let i = read_back(ctx, tess.indices(), counts.indices as u64 * 4);
    let a = read_back(ctx, tess.indirect(), 20);
    let args: &[u32] = bytemuck::cast_slice(&a);
    assert_eq!(args, [counts.indices, 1, 0, 0, 0]);
    let floats: &[[f32; 6]] = bytemuck::cast_slice(&v);
    let pos = floats.iter().map(|r| [r[0], r[1], r[2]]).collect();
    let nrm = floats.iter().map(|r| [r[3], r[4], r[5]]).collect();
    (pos, nrm, bytemuck::cast_slice(&i).to_vec())
}

/// GPU index buffer = the plan's triangles exactly; positions and normals = the f64 CPU
/// stitched surface within f32 rounding; corners the input rounded once, bit for bit; split
/// records share the owner's position bit for bit. Levels 1, 2, 5, then 3 again (buffers
/// reused), f32 and f64, G1 and PN normals.
#[test]
fn gpu_tessellation_matches_the_cpu_stitched_surface() {
    let Some(ctx) = context("gpu_tessellation_matches_the_cpu_stitched_surface") else {
        return;
    };
    let suzanne = Mesh::load(&common::shared_spec("suzanne.obj"), &LoadOptions::default()).unwrap();
    let mut precisions = vec![Precision::F32];
    if ctx.supports_f64() {
        precisions.push(Precision::F64);
    }
    for (mesh, scheme) in [
        (open_box(), Scheme::G1),
        (suzanne, Scheme::G1),
        (open_box(), Scheme::PnNormals),
    ] {
        let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default()).unwrap();
        for &precision in &precisions {
            let mut tess =
                GpuTessellator::new(&ctx.device, &ctx.queue, &mesh, &table, precision).unwrap();
            let mut sizes = None;
            for level in [1u32, 2, 5, 3] {
                let what = format!("{} {scheme:?} {precision} level {level}", mesh.name);
                let (pos, nrm, tris) = tessellate(&ctx, &mut tess, level);
                let (w, plan, _): (StitchedMesh, _, _) =
                    stitch(&mesh, &table, &CpuEvaluator::default(), level).unwrap();
                assert_eq!(tris, w.triangles, "{what}");
                assert_eq!(pos.len(), plan.records, "{what}");
                let diag = mesh.diagonal();
                let rp = w.record_positions();
                for (r, (p, q)) in pos.iter().zip(&rp).enumerate() {
                    let p = DVec3::from(p.map(f64::from));
                    // f32 storage of coordinates of size ~100 (the box) and control points
                    // relative to the patch origin: a few f32 ulps of the coordinates.
                    assert!(
                        p.distance(*q) <= 1e-6 * (q.length() + diag),
                        "{what} record {r}: {p} vs {q}"
                    );
                }
                // Normals: each record against the f64 reference, within the rounding
                // error predicted for its patch and grid point in the working precision
                // (eval_cases::normal_error, times its ROUNDING_FACTOR; unbounded near
                // singular points of the parametrisation), plus 1e-6 for the f32 storage
                // of a unit vector (a few ulps of 6e-8 per component).
                let eps = match precision {
                    Precision::F32 => EPS32,
                    Precision::F64 => EPS64,
                };
                let bary = crate::eval::grid_barycentrics(level);
                for p in 0..mesh.triangles.len() {
                    for j in 0..=level {
                        for i in 0..=level - j {
                            let r = record_of(tess.topology(), p as u32, level, i, j);
                            if r.flags & FLAG_WRITE == 0 {
                                continue;
                            }
                            let g = crate::eval::pattern::grid_index(level, i, j);
                            let weights = table.kind.weights(bary[g]);
                            let allowed =
                                1e-6 + ROUNDING_FACTOR * normal_error(&table, p, &weights, eps);
                            let n = DVec3::from(nrm[r.id as usize].map(f64::from));
                            let m = w.normals[r.id as usize];
                            assert!(
                                angle(n, m) <= allowed,
                                "{what} record {}: {n} vs {m}, allowed {allowed}",
                                r.id
                            );
                        }
                    }
                }
                // Records of one position (split normals) share it bit for bit.
                let mut first = std::collections::HashMap::new();
                for (r, &pid) in w.record_position.iter().enumerate() {
                    let bits = pos[r].map(f32::to_bits);
                    assert_eq!(*first.entry(pid).or_insert(bits), bits, "{what} record {r}");
                }
                // Corners: the input vertex rounded once to f32.
                for (t, tri) in mesh.triangles.iter().enumerate() {
                    let corners = [0, 1, 2].map(|k| {
                        let n = level;
                        let (i, j) = [(0, 0), (n, 0), (0, n)][k];
                        record_of(tess.topology(), t as u32, n, i, j).id
                    });
                    for (k, &v) in tri.iter().enumerate() {
                        let want = mesh.positions[v as usize]
                            .to_array()
                            .map(|x| (x as f32).to_bits());
                        assert_eq!(pos[corners[k] as usize].map(f32::to_bits), want, "{what}");
                    }
                }
                // Coarser levels reuse the buffers of the finest so far.
                let now = (tess.vertices().size(), tess.indices().size());
                if level == 3 {
                    assert_eq!(Some(now), sizes, "{what}: buffers reallocated");
                }
                sizes = Some(now);
            }
        }
    }
}

/// The bounds pass: the extent of the vertex buffer along three axes, as the CPU finds it
/// on the same f32 vertices.
#[test]
fn bounds_pass_gives_the_extent_of_the_vertices() {
    let Some(ctx) = context("bounds_pass_gives_the_extent_of_the_vertices") else {
        return;
    };
    let mesh = load("sphere320");
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let mut tess =
        GpuTessellator::new(&ctx.device, &ctx.queue, &mesh, &table, Precision::F32).unwrap();
    let (pos, _, _) = tessellate(&ctx, &mut tess, 4);
    let s = 0.5f32.sqrt();
    let axes = [[s, s, 0.0], [-s, s, 0.0], [0.0, 0.0, 1.0]];
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    tess.tessellate(&ctx.device, &ctx.queue, &mut enc, 4)
        .unwrap();
    tess.record_bounds(&ctx.queue, &mut enc, axes).unwrap();
    ctx.queue.submit([enc.finish()]);
    let keys = read_back(&ctx, tess.bounds(), 24);
    let keys: [u32; 6] = bytemuck::cast_slice::<u8, u32>(&keys).try_into().unwrap();
    let (lo, hi) = decode_bounds(keys);
    for k in 0..3 {
        let d = |p: &[f32; 3]| (0..3).map(|c| axes[k][c] * p[c]).sum::<f32>();
        let want_hi = pos.iter().map(d).fold(f32::MIN, f32::max);
        let want_lo = pos.iter().map(d).fold(f32::MAX, f32::min);
        // The same f32 dot product on both sides, up to the order of its two roundings
        // (FMA or not): an ulp of the unit sphere.
        assert!((hi[k] - want_hi).abs() <= 1e-6 && (lo[k] - want_lo).abs() <= 1e-6);
        // The unit sphere's extent, within the chordal error of level 4 (≤ 1 %).
        assert!(
            (hi[k] - 1.0).abs() < 0.01 && (lo[k] + 1.0).abs() < 0.01,
            "{lo:?} {hi:?}"
        );
    }
}

/// A device opened without SHADER_F64 refuses f64 tessellation with a clear error.
#[test]
fn f64_without_shader_f64_is_refused() {
    let Some(ctx) = context("f64_without_shader_f64_is_refused") else {
        return;
    };
    let (device, queue) = pollster::block_on(ctx.adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("no f64"),
        required_features: wgpu::Features::empty(),
        ..Default::default()
    }))
    .unwrap();
    let mesh = load("icosphere:1");
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let e = GpuTessellator::new(&device, &queue, &mesh, &table, Precision::F64)
        .err()
        .expect("f64 accepted without SHADER_F64")
        .to_string();
    assert!(e.contains("SHADER_F64") && e.contains("f64"), "{e}");
    assert_eq!(e.lines().count(), 1);
    // f32 works on that device.
    assert!(GpuTessellator::new(&device, &queue, &mesh, &table, Precision::F32).is_ok());
}
