//! Device-resident tessellation with a level per edge (`GpuTessellator::tessellate_levels`):
//! its WGSL validates for every patch kind in f32 and f64 and names the Rust it mirrors; on
//! the Vulkan adapter (lavapipe in CI) random per-edge levels give exactly the index buffer
//! of `StitchPlan::with_levels` and the samples of the f64 CPU stitched surface (creases, a
//! boundary, a non-manifold edge), from host and device levels; and screen-space levels
//! computed on the GPU each frame of a camera path, tessellated on the GPU, are watertight.
//!
//! Without a Vulkan adapter the GPU tests print a SKIP line and pass, unless CI=true: then
//! they fail.

use std::collections::HashMap;

use glam::{DMat4, DVec3};
use wgpu::util::DeviceExt;

use crate::gpu::read_buffer;
use crate::gpu::screen::{LevelParams, LevelPass};
use crate::gpu::shaders::validate;
use crate::gpu::tessellator::{
    level_grid_base, tess_levels_module_source, LevelSource, LV_STATE_RECORDS, TESS_LEVELS_WGSL,
    VERTEX_BYTES,
};
use crate::tess::stitch::stitch_plan;
use crate::CpuEvaluator;
use crate::GpuTessellator;
use crate::ScreenView;
use crate::{GpuContext, Precision};
use crate::{InnerRule, Levels};
use crate::{LoadOptions, Mesh};
use crate::{PatchKind, PatchTable, Scheme, SchemeOptions};
use crate::{StitchPlan, StitchedMesh};

use crate::tests::common;
use crate::tests::eval_cases;
use eval_cases::{angle, context, load, normal_error, open_box, EPS32, EPS64, ROUNDING_FACTOR};

#[test]
fn level_module_validates_for_every_kind_in_f32_and_f64() {
    for kind in PatchKind::all() {
        for precision in [Precision::F32, Precision::F64] {
            let src = tess_levels_module_source(kind, precision).unwrap();
            let module = validate(&src, precision)
                .unwrap_or_else(|e| panic!("tessellate_levels.wgsl {kind:?} {precision}: {e}"));
            let entries: Vec<&str> = module
                .entry_points
                .iter()
                .map(|e| e.name.as_str())
                .filter(|n| n.starts_with("lv_"))
                .collect();
            assert_eq!(
                entries,
                [
                    "lv_patch_main",
                    "lv_scan_main",
                    "lv_finish_main",
                    "lv_points_main",
                    "lv_points_basis_main",
                    "lv_triangles_main",
                    "lv_copy_main"
                ]
            );
        }
    }
}

/// The per-edge basis table puts the grid of level l after those of levels 1..l − 1.
#[test]
fn level_grid_base_counts_the_smaller_grids() {
    let mut sum = 0u64;
    for l in 1..=200u32 {
        assert_eq!(level_grid_base(l), sum, "level {l}");
        sum += crate::eval::grid_len(l) as u64;
    }
    // Past 32-bit products: the cap's largest level.
    let l = crate::MAX_LEVEL as u64 + 1;
    assert_eq!(level_grid_base(l as u32), l * (l + 1) * (l + 2) / 6 - 1);
}

#[test]
fn level_wgsl_names_rust_functions_it_mirrors_and_they_exist() {
    let names = common::mirrored_functions("tessellate_levels.wgsl", TESS_LEVELS_WGSL);
    assert!(
        names.iter().any(|n| n == "tess::layout::triangles"),
        "{names:?}"
    );
    for name in ["TOPO_STRIDE", "TOPO_EDGE", "TESS_WORKGROUP", "FLAG_COPY"] {
        assert!(
            !TESS_LEVELS_WGSL.contains(&format!("const {name}")),
            "{name} copied"
        );
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

fn read_u32(ctx: &GpuContext, src: &wgpu::Buffer, count: usize) -> Vec<u32> {
    bytemuck::cast_slice(&read_back(ctx, src, 4 * count as u64)).to_vec()
}

/// Positions, normals and triangles of the last per-edge tessellation, read back through
/// the counts the device computed (indirect arguments, record count).
type Surface = (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<[u32; 3]>);

fn read_surface(ctx: &GpuContext, tess: &GpuTessellator) -> Surface {
    let args = read_u32(ctx, tess.indirect(), 5);
    assert_eq!(args[1..], [1, 0, 0, 0]);
    let state = read_u32(ctx, tess.level_state().unwrap(), LV_STATE_RECORDS + 1);
    let records = state[LV_STATE_RECORDS] as u64;
    let v = read_back(ctx, tess.vertices(), records * VERTEX_BYTES);
    let i = read_back(ctx, tess.indices(), args[0] as u64 * 4);
    let floats: &[[f32; 6]] = bytemuck::cast_slice(&v);
    let pos = floats.iter().map(|r| [r[0], r[1], r[2]]).collect();
    let nrm = floats.iter().map(|r| [r[3], r[4], r[5]]).collect();
    (pos, nrm, bytemuck::cast_slice(&i).to_vec())
}

/// The plan's triangles as record ids.
fn plan_triangles(plan: &StitchPlan) -> Vec<[u32; 3]> {
    let grid = crate::eval::grid_triangles(plan.level);
    let mut scratch = (Vec::new(), Vec::new());
    let mut out = Vec::new();
    for p in 0..plan.patches() {
        plan.patch_triangles(p, &grid, &mut scratch, &mut out);
    }
    out
}

/// Equal triangle lists; a failure names the first difference.
fn same_triangles(what: &str, gpu: &[[u32; 3]], cpu: &[[u32; 3]]) {
    assert_eq!(gpu.len(), cpu.len(), "{what}: triangle counts");
    if let Some(t) = (0..gpu.len()).find(|&t| gpu[t] != cpu[t]) {
        panic!("{what}: triangle {t}: GPU {:?}, CPU {:?}", gpu[t], cpu[t]);
    }
}

/// The GPU surface against the f64 CPU stitched surface of the same levels: the index
/// buffer exactly, positions within f32 rounding, normals within the rounding predicted for
/// their patch and sample, corners the input rounded once bit for bit, records of one
/// position sharing it bit for bit.
fn check_against_cpu(
    what: &str,
    mesh: &Mesh,
    table: &PatchTable,
    levels: &Levels,
    precision: Precision,
    (pos, nrm, tris): &Surface,
) {
    let adj = mesh.adjacency();
    let plan = StitchPlan::with_levels(mesh, &adj, levels).unwrap();
    same_triangles(what, tris, &plan_triangles(&plan));
    assert_eq!(pos.len(), plan.records, "{what}");
    let (w, _): (StitchedMesh, _) = stitch_plan(&plan, table, &CpuEvaluator::default()).unwrap();
    same_triangles(what, tris, &w.triangles);
    let diag = mesh.diagonal();
    for (r, (p, q)) in pos.iter().zip(&w.record_positions()).enumerate() {
        let p = DVec3::from(p.map(f64::from));
        // f32 storage of coordinates of size ~100 (the box) and control points relative to
        // the patch origin: a few f32 ulps of the coordinates.
        assert!(
            p.distance(*q) <= 1e-6 * (q.length() + diag),
            "{what} record {r}: {p} vs {q}"
        );
    }
    // Normals: each record against the f64 reference, within the rounding error predicted
    // for the patch that writes it (the first to use it) and its sample, in the working
    // precision (eval_cases::normal_error times ROUNDING_FACTOR), plus 1e-6 for the f32
    // storage of a unit vector.
    let eps = match precision {
        Precision::F32 => EPS32,
        Precision::F64 => EPS64,
    };
    let mut seen = vec![false; plan.records];
    let (mut rec, mut pid) = (Vec::new(), Vec::new());
    let mut bary = Vec::new();
    for p in 0..plan.patches() {
        plan.local_ids(p, &mut rec, &mut pid);
        bary.clear();
        plan.patch_points(p, &mut bary);
        for (&r, &b) in rec.iter().zip(&bary) {
            if std::mem::replace(&mut seen[r as usize], true) {
                continue;
            }
            let weights = table.kind.weights(b);
            let allowed = 1e-6 + ROUNDING_FACTOR * normal_error(table, p, &weights, eps);
            let n = DVec3::from(nrm[r as usize].map(f64::from));
            let m = w.normals[r as usize];
            assert!(
                angle(n, m) <= allowed,
                "{what} record {r}: {n} vs {m}, allowed {allowed}"
            );
        }
        // Corners (local samples 0, 1, 2): the input vertex rounded once to f32.
        for (k, &v) in mesh.triangles[p].iter().enumerate() {
            let want = mesh.positions[v as usize]
                .to_array()
                .map(|x| (x as f32).to_bits());
            assert_eq!(pos[rec[k] as usize].map(f32::to_bits), want, "{what}");
        }
    }
    let mut first = HashMap::new();
    for (r, &p) in w.record_position.iter().enumerate() {
        let bits = pos[r].map(f32::to_bits);
        assert_eq!(*first.entry(p).or_insert(bits), bits, "{what} record {r}");
    }
}

/// Random per-edge levels (1 to 9, some at the cap of 9, some above it for the device
/// source, which clamps), from the host (with random inner levels in the first round) and
/// from a device buffer with each inner rule: the GPU surface is the CPU plan's. The open
/// box (creases, a boundary) in f32 and f64, G1 and PN normals; Suzanne (a boundary, a
/// non-manifold edge, 968 patches) with one rule.
#[test]
fn random_per_edge_levels_match_the_cpu_plan() {
    let Some(ctx) = context("random_per_edge_levels_match_the_cpu_plan") else {
        return;
    };
    let suzanne = Mesh::load(&common::shared_spec("suzanne.obj"), &LoadOptions::default()).unwrap();
    let mut precisions = vec![Precision::F32];
    if ctx.supports_f64() {
        precisions.push(Precision::F64);
    }
    let mut rng = common::Rng(11);
    const CAP: u32 = 9;
    let mut sizes = None;
    let all = [InnerRule::Max, InnerRule::Mean, InnerRule::Min];
    for (mesh, scheme, precisions, rules) in [
        (open_box(), Scheme::G1, &precisions[..], &all[..]),
        (open_box(), Scheme::PnNormals, &precisions[..1], &all[..]),
        (suzanne, Scheme::G1, &precisions[..1], &all[1..2]),
    ] {
        let adj = mesh.adjacency();
        let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default()).unwrap();
        for &precision in precisions {
            let mut tess =
                GpuTessellator::new(&ctx.device, &ctx.queue, &mesh, &table, precision).unwrap();
            for (round, &rule) in rules.iter().enumerate() {
                let what = format!("{} {scheme:?} {precision} {rule:?}", mesh.name);
                // Raw device levels 0..=CAP + 2: 0 and above the cap are clamped to 1..=CAP.
                let raw: Vec<u32> = (0..adj.edges.len())
                    .map(|_| (rng.next_u64() % (CAP as u64 + 3)) as u32)
                    .collect();
                let clamped: Vec<u32> = raw.iter().map(|&l| l.clamp(1, CAP)).collect();
                let levels = Levels::from_edges(&mesh, &adj, clamped, rule).unwrap();
                assert!(levels.uniform_level().is_none(), "{what}");
                // From a device buffer.
                let buf = ctx
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("test levels"),
                        contents: bytemuck::cast_slice(&raw),
                        usage: wgpu::BufferUsages::STORAGE,
                    });
                let mut enc = ctx.device.create_command_encoder(&Default::default());
                let source = LevelSource::Device { levels: &buf, rule };
                tess.tessellate_levels(&ctx.device, &ctx.queue, &mut enc, source, CAP)
                    .unwrap();
                ctx.queue.submit([enc.finish()]);
                ctx.check().unwrap();
                let surface = read_surface(&ctx, &tess);
                check_against_cpu(&what, &mesh, &table, &levels, precision, &surface);
                // From the host, with inner levels of their own (1..=CAP) on the first
                // round, by the rule after.
                let mut host = levels.clone();
                if round == 0 {
                    for l in &mut host.inner {
                        *l = 1 + (rng.next_u64() % CAP as u64) as u32;
                    }
                }
                let mut enc = ctx.device.create_command_encoder(&Default::default());
                tess.tessellate_levels(
                    &ctx.device,
                    &ctx.queue,
                    &mut enc,
                    LevelSource::Host(&host),
                    CAP,
                )
                .unwrap();
                ctx.queue.submit([enc.finish()]);
                ctx.check().unwrap();
                let surface = read_surface(&ctx, &tess);
                check_against_cpu(
                    &format!("{what} host"),
                    &mesh,
                    &table,
                    &host,
                    precision,
                    &surface,
                );
            }
            // The uniform path still works on the same tessellator, and the buffers sized
            // for the cap are reused by a coarser uniform level.
            let before = (tess.vertices().size(), tess.indices().size());
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            let counts = tess
                .tessellate(&ctx.device, &ctx.queue, &mut enc, 4)
                .unwrap();
            ctx.queue.submit([enc.finish()]);
            let uniform = Levels::uniform(&adj, mesh.triangles.len(), 4);
            let plan = StitchPlan::with_levels(&mesh, &adj, &uniform).unwrap();
            let i = read_back(&ctx, tess.indices(), counts.indices as u64 * 4);
            let tris: &[[u32; 3]] = bytemuck::cast_slice(&i);
            same_triangles(
                &format!("{} uniform", mesh.name),
                tris,
                &plan_triangles(&plan),
            );
            assert_eq!(
                (tess.vertices().size(), tess.indices().size()),
                before,
                "{}",
                mesh.name
            );
            sizes = Some(before);
        }
    }
    assert!(sizes.is_some());
}

/// Level errors: a cap outside 1..=MAX_LEVEL, host levels above the cap or of the wrong
/// length, a device buffer too short; each one line.
#[test]
fn bad_level_input_is_refused() {
    let Some(ctx) = context("bad_level_input_is_refused") else {
        return;
    };
    let mesh = load("icosphere:1");
    let adj = mesh.adjacency();
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let mut tess =
        GpuTessellator::new(&ctx.device, &ctx.queue, &mesh, &table, Precision::F32).unwrap();
    let levels = Levels::uniform(&adj, mesh.triangles.len(), 5);
    let short = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("short"),
        size: 16,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let mut wrong = levels.clone();
    wrong.inner.pop();
    let cases: [(LevelSource<'_>, u32, &str); 4] = [
        (LevelSource::Host(&levels), 0, "outside 1..="),
        (LevelSource::Host(&levels), 4, "level 5 of edge 0"),
        (LevelSource::Host(&wrong), 8, "inner levels for"),
        (
            LevelSource::Device {
                levels: &short,
                rule: InnerRule::Max,
            },
            8,
            "level buffer of 16 bytes",
        ),
    ];
    for (source, cap, want) in cases {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let e = tess
            .tessellate_levels(&ctx.device, &ctx.queue, &mut enc, source, cap)
            .expect_err("accepted")
            .to_string();
        assert!(e.contains(want), "{e}");
        assert_eq!(e.lines().count(), 1);
    }
}

/// Every frame of a camera path: screen-space levels by `LevelPass` into a device buffer,
/// tessellated from it on the GPU in the same encoder (nothing read back in between). The
/// test reads each frame back: the levels vary over the surface and from frame to frame;
/// the surface is the CPU plan of those levels; and it is watertight: with records welded
/// by position (bit for bit), every edge is in exactly two triangles, oppositely oriented,
/// and V − E + F = 2 (a sphere).
#[test]
fn screen_space_levels_on_a_camera_path_are_watertight() {
    let Some(ctx) = context("screen_space_levels_on_a_camera_path_are_watertight") else {
        return;
    };
    let mesh = load("sphere320");
    let adj = mesh.adjacency();
    assert_eq!((adj.boundary, adj.nonmanifold), (0, 0));
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let mut tess =
        GpuTessellator::new(&ctx.device, &ctx.queue, &mesh, &table, Precision::F32).unwrap();
    let device = &ctx.device;
    let pass = LevelPass::new(device).unwrap();
    let positions: Vec<[f32; 4]> = mesh
        .positions
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32, 1.0])
        .collect();
    let ends: Vec<[u32; 2]> = adj.edges.iter().map(|e| e.v).collect();
    use wgpu::BufferUsages as U;
    let init = |label, contents: &[u8], usage| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
    };
    let pos_buf = init("positions", bytemuck::cast_slice(&positions), U::STORAGE);
    let edge_buf = init("edges", bytemuck::cast_slice(&ends), U::STORAGE);
    let ne = adj.edges.len();
    let level_buf = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("levels"),
        size: 4 * ne as u64,
        usage: U::STORAGE | U::COPY_SRC,
        mapped_at_creation: false,
    });
    let params_buf = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("level params"),
        size: std::mem::size_of::<LevelParams>() as u64,
        usage: U::UNIFORM | U::COPY_DST,
        mapped_at_creation: false,
    });
    const CAP: u32 = 12;
    let groups = LevelPass::groups(
        ne as u32,
        device.limits().max_compute_workgroups_per_dimension,
    );
    let mut previous: Option<Vec<u32>> = None;
    for frame in 0..4 {
        // Orbiting and approaching: the near side of the unit sphere gets finer levels.
        let a = frame as f64 * 0.7;
        let dist = 4.0 - 0.6 * frame as f64;
        let eye = DVec3::new(dist * a.cos(), 0.8, dist * a.sin());
        let view_proj = DMat4::perspective_rh(0.8, 1.5, 0.1, 100.0)
            * DMat4::look_at_rh(eye, DVec3::ZERO, DVec3::Y);
        let view = ScreenView {
            view_proj,
            viewport: [480.0, 320.0],
            target_px: 6.0,
            max_level: CAP,
        };
        let mut params = LevelParams::new(&view, ne as u32);
        params.groups_x = groups.0;
        ctx.queue
            .write_buffer(&params_buf, 0, bytemuck::bytes_of(&params));
        let mut enc = device.create_command_encoder(&Default::default());
        pass.record(
            device,
            &mut enc,
            [&params_buf, &pos_buf, &edge_buf, &level_buf],
            groups,
        );
        let source = LevelSource::Device {
            levels: &level_buf,
            rule: InnerRule::Max,
        };
        tess.tessellate_levels(device, &ctx.queue, &mut enc, source, CAP)
            .unwrap();
        ctx.queue.submit([enc.finish()]);
        ctx.check().unwrap();
        // Read back (test only).
        let edge_levels = read_u32(&ctx, &level_buf, ne);
        let (lo, hi) = (
            *edge_levels.iter().min().unwrap(),
            *edge_levels.iter().max().unwrap(),
        );
        assert!(lo >= 1 && hi <= CAP && lo < hi, "frame {frame}: {lo}..{hi}");
        assert_ne!(previous.as_ref(), Some(&edge_levels), "frame {frame}");
        let (pos, _, tris) = read_surface(&ctx, &tess);
        let levels = Levels::from_edges(&mesh, &adj, edge_levels.clone(), InnerRule::Max).unwrap();
        let plan = StitchPlan::with_levels(&mesh, &adj, &levels).unwrap();
        same_triangles(&format!("frame {frame}"), &tris, &plan_triangles(&plan));
        // Weld records by position bits; count directed edges.
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        let weld: Vec<u32> = pos
            .iter()
            .map(|p| {
                let n = ids.len() as u32;
                *ids.entry(p.map(f32::to_bits)).or_insert(n)
            })
            .collect();
        assert_eq!(ids.len(), plan.positions, "frame {frame}");
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &tris {
            let t = t.map(|r| weld[r as usize]);
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &c) in &directed {
            assert_eq!(c, 1, "frame {frame}: edge {a}-{b} used {c} times one way");
            assert_eq!(
                directed.get(&(b, a)),
                Some(&1),
                "frame {frame}: edge {a}-{b} has no opposite (a crack)"
            );
        }
        let (v, e, f) = (
            ids.len() as i64,
            directed.len() as i64 / 2,
            tris.len() as i64,
        );
        assert_eq!(v - e + f, 2, "frame {frame}");
        previous = Some(edge_levels);
    }
}
