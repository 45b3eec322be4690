//! g1tess: smooth curved surfaces from flat triangle meshes with vertex normals.
//!
//! Data flows one way (see `ARCHITECTURE.md`):
//! [`mesh`] (load, weld, adjacency, normals, generators) → [`patch`] (one file per scheme,
//! backend-agnostic f64 control-point tables) → [`eval`] (CPU and GPU evaluators, sample
//! patterns) → [`output`] (statistics, writers, control nets, the distance study) and
//! [`render`] (the normal field drawn by a GPU render pass).
//!
//! # Cargo features
//!
//! - `gpu` (default): the GPU path on wgpu: `gpu` (device, shaders, tessellator, GPU
//!   statistics), `eval::gpu`, `tess::screen_gpu` and the render pass (`render::pipeline`),
//!   on the platform's native backend (Vulkan on Linux, Vulkan or DX12 on Windows, Metal on
//!   macOS).
//! - `cli` (default, implies `gpu`): the `g1tess` binary and `cli`, with what only the
//!   command line needs: argument parsing (clap), progress bars (indicatif), log–log plots
//!   (`output::plot`) and composed PNG pictures (`render::compose`), which use plotters.
//!
//! Without default features the library is CPU-only and compiles no GPU crate: meshes,
//! patches, the CPU evaluator, statistics, the writers and the render module's camera and
//! colour ramp.

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

#[cfg(feature = "cli")]
pub mod cli;
pub mod error;
pub mod eval;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod mesh;
pub mod output;
pub mod patch;
mod pipelined;
pub mod progress;
pub mod render;
pub mod tess;

/// Not part of the API: items the integration tests check directly (the library's own
/// unit-test build would compile the crate a second time). May change without notice.
#[doc(hidden)]
pub mod internals {
    #[cfg(feature = "cli")]
    pub use crate::cli::common::LazyGpu;
    pub use crate::eval::cpu::edges::min_len2;
    pub use crate::mesh::text::{echo, parse_f64, parse_i64, split, statements};
    pub use crate::output::atomic::DIRECT_ALIGN;
    pub use crate::output::stats::{Part, BLOCK_PAIRS};
    pub use crate::patch::validity::{
        interior_powers, quick_flat, quick_quartic, tables, Tables, QUARTIC_BOUNDARY,
        QUARTIC_INTERIOR, QUARTIC_UP,
    };
    pub use crate::tess::layout::rings;
}

pub use error::{Error, Result};
