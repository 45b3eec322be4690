//! g1tess: smooth curved surfaces from flat triangle meshes with vertex normals.
//!
//! Everything a program needs is named from the crate root (`use g1tess::{Mesh, PatchTable,
//! Scheme};`); the modules behind it are private. They are layers, each using only those
//! before it (see `ARCHITECTURE.md`; a test reads the `use` lines and checks it): `error` →
//! `mesh` (load, weld, adjacency, normals, generators) → `patch` (one file per scheme,
//! backend-agnostic f64 control-point tables) → `eval` (the evaluator interface, the CPU
//! backend, sample patterns) → `tess` (per-edge levels, stitching) → `analysis` (continuity
//! statistics, the distance study, Table 1) → `io` (mesh writers, MSH, control nets, atomic
//! files) → `gpu` (device, the GPU evaluator, statistics and tessellator) → `render` (the
//! normal field drawn by a GPU render pass) → `cli`.
//!
//! # Cargo features
//!
//! - `gpu` (default): the GPU path on wgpu: `gpu` (device, shaders, tessellator, GPU
//!   statistics), and the render pass (`render::pipeline`),
//!   on the platform's native backend (Vulkan on Linux, Vulkan or DX12 on Windows, Metal on
//!   macOS).
//! - `cli` (default, implies `gpu`): the `g1tess` binary and `cli`, with what only the
//!   command line needs: argument parsing (clap), progress bars (indicatif), log–log plots
//!   (`io::plot`) and composed PNG pictures (`render::compose`), which use plotters.
//!
//! Without default features the library is CPU-only and compiles no GPU crate: meshes,
//! patches, the CPU evaluator, statistics, the writers and the render module's camera and
//! colour ramp.
//!
//! # Example
//!
//! Every patch of a built-in icosphere on the grid of level 8, on the CPU:
//!
//! ```
//! use g1tess::{CpuEvaluator, Evaluator, Mesh, PatchTable, Pattern, Scheme};
//!
//! // A built-in mesh (320 triangles on the unit sphere), or a file: "tests/data/spot.obj".
//! let mesh = Mesh::load("icosphere:2", &Default::default())?;
//! let table = PatchTable::build(&mesh, Scheme::G1, &Default::default())?;
//! // Streamed chunk by chunk, in f64 (evaluate_f32 for f32).
//! let mut farthest: f64 = 0.0;
//! CpuEvaluator::default().evaluate(&table, &Pattern::Grid { level: 8 }, &mut |chunk| {
//!     for p in chunk.positions {
//!         farthest = farthest.max((p.length() - 1.0).abs());
//!     }
//!     Ok(())
//! })?;
//! println!("largest distance to the unit sphere: {farthest:.1e}");
//! # // The G1 sphere of 320 triangles is not the sphere, but close: its mean distance is
//! # // about 2e-5 (the distance study) and its largest stays below 1e-4.
//! # assert!(farthest > 1e-6 && farthest < 1e-4, "{farthest}");
//! # Ok::<(), g1tess::Error>(())
//! ```

// Without the command line (feature `cli`), the parts only it uses (the distance study and
// Table 1, the picture code, memory estimates, report lines) are compiled but not called.
#![cfg_attr(not(feature = "cli"), allow(dead_code, unused_imports))]
#![warn(missing_docs)]

/// Whether the CPU has every named instruction set (detected at run time, once, by the
/// standard library; false off x86-64): the one check behind the kernels' choice of lanes
/// (`eval::cpu`) and the G1 builder's (`patch::g1`). Defined before the modules, so that
/// every module sees it.
macro_rules! cpu_has {
    ($($feature:tt),+) => {{
        #[cfg(target_arch = "x86_64")]
        {
            true $(&& std::is_x86_feature_detected!($feature))+
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    }};
}

pub(crate) mod analysis;
#[cfg(feature = "cli")]
mod cli;
mod error;
pub(crate) mod eval;
#[cfg(feature = "gpu")]
pub(crate) mod gpu;
pub(crate) mod io;
pub(crate) mod mesh;
mod par;
pub(crate) mod patch;
mod pipelined;
mod progress;
pub(crate) mod render;
pub(crate) mod tess;
#[cfg(test)]
mod tests;

// The public API: what a program using g1tess needs, named from the crate root
// (`use g1tess::{Mesh, PatchTable, Scheme};`).

/// Errors: one error type for the whole library.
pub use error::{Error, Result};

/// The wgpu this crate is built with (version 30), for hosts that hand it their device:
/// `use g1tess::wgpu;` keeps the two versions the same.
#[cfg(feature = "gpu")]
pub use wgpu;

/// The glam this crate is built with: the vector and matrix types of its signatures
/// (`DVec3` positions, the f32 `Mat4` of `ScreenFrame`).
pub use glam;

/// The mesh: loading (files or built-in generators), welding, adjacency and vertex normals.
pub use mesh::adjacency::{EdgeCounts, EdgeUses, MeshEdge};
pub use mesh::{
    Adjacency, CornerAttributes, EdgeUse, InputFormat, LoadOptions, LoadReport, Mesh,
    NormalWeighting,
};

/// Schemes and their patch tables: the control points of every triangle's patch.
pub use patch::{Layout, PatchKind, PatchTable, Scheme, SchemeOptions, SurfacePoint};

/// The validity certificate of each patch (valid, folded or undecided), and the repair of
/// folded patches with its report.
pub use patch::repair::{repair, RepairOptions, RepairReport};
pub use patch::validity::{check_table, singular_at_a_corner, PatchCounts, Verdict};

/// Built-in meshes (icosphere, torus, ...) by name or by parameters.
pub use mesh::generators;
/// Vertex normals estimated from positions and triangles.
pub use mesh::normals::vertex_normals;

/// Evaluators: where the patches are evaluated (CPU or GPU), on which samples, in which
/// precision, and the chunks they stream.
pub use eval::cpu::{CpuEvaluator, EdgeKernel, F32Kernel, GridWeightsF32};
pub use eval::pattern::{grid_index, EdgePairs, EdgeSide, PatchPoint};
pub use eval::{
    grid_barycentrics, grid_corners, grid_len, grid_triangles, Chunk, ChunkF32, Evaluator, Pattern,
    Precision, Vector,
};
pub use eval::{PairChunk, PairProducts};

/// Tessellation levels: uniform, per edge from the screen, or from a tolerance.
pub use tess::adaptive::{levels_for_tolerance, Deviation, ToleranceLevels, ToleranceOptions};
pub use tess::layout::MAX_LEVEL;
pub use tess::levels::{EdgeInfo, InnerRule, Levels};
pub use tess::screen::{screen_levels, ScreenView};

/// Tessellation: the welded numbering of a whole surface and the stitching of evaluated
/// patches into it, into a mesh in memory or any sink.
pub use tess::stitch::{
    stitch, stitch_in, stitch_into, stitch_plan, Needs, PatchOut, RecordAttributes, StitchPlan,
    StitchReport, StitchSink, StitchedMesh, VertexRecord,
};

/// Statistics: the continuity of the surface across edges, and the statistics report.
pub use analysis::stats::{continuity, stats_report, Continuity, CosStats, StatsReport};

/// The fair G1 surface: normals and tangent lengths chosen to lower the bending energy
/// under the validity certificate.
pub use analysis::fair::{fair, fair_with_progress, FairOptions, FairReport};
/// Fairness: the bending energy ∫ (κ₁² + κ₂²) dA of the patches (per patch or in total)
/// and the jump of normal curvature across edges (the G2 defect).
pub use analysis::fairness::{
    fairness, g2_defect, BendingEnergy, EnergyTotal, FairnessOptions, FairnessReport, G2Defect,
    PatchEnergy,
};

/// Writers: tessellated meshes, high-order MSH meshes, control nets, and the temporary
/// files they go through until they are complete.
pub use io::msh;
pub use io::msh::{export_msh, MshSummary};
pub use io::nets::write_nets;
pub use io::writers::{ply_file_bytes, write_stitched, MeshFormat};
pub use io::TempFiles;

/// Blocking forms, native only (the web awaits `GpuContext::new_async`, `gpu_adapters_async`
/// and `read_buffer_async`).
#[cfg(all(feature = "gpu", not(target_arch = "wasm32")))]
pub use gpu::adapters as gpu_adapters;
/// The GPU: a device, the GPU evaluator, and the tessellator writing straight into a host
/// program's vertex and index buffers.
#[cfg(feature = "gpu")]
pub use gpu::eval::{GpuEvaluator, GridTiming};
/// Screen-space levels computed on the device, for [`LevelSource::Device`].
#[cfg(feature = "gpu")]
pub use gpu::screen::{gpu_screen_levels, LevelParams, LevelPass, ScreenFrame, ScreenLevels};
#[cfg(feature = "gpu")]
pub use gpu::tessellator::{
    vertex_layout, GpuTessellator, LevelCapacity, LevelSource, TessCounts, Topology,
};
#[cfg(feature = "gpu")]
pub use gpu::{adapters_async as gpu_adapters_async, read_buffer, read_buffer_async, GpuContext};

/// Drawing a tessellated surface with its normal field: the camera that frames it, and (with
/// the `gpu` feature) the buffers and the render pass.
pub use render::camera::Camera;
#[cfg(feature = "gpu")]
pub use render::pipeline::{draw, upload, Geometry, IndexCount};

/// Progress of long operations.
pub use progress::{NoProgress, Progress};

/// Runs the `g1tess` command line on this process's arguments (what the `g1tess` binary
/// does) and returns its exit code.
#[cfg(feature = "cli")]
pub use cli::main as run_cli;
