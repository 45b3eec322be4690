//! g1tess: smooth curved surfaces from flat triangle meshes with vertex normals.
//!
//! The modules are layers, each using only those before it (see `ARCHITECTURE.md`; a test
//! reads the `use` lines and checks it): [`error`] → [`mesh`] (load, weld, adjacency,
//! normals, generators) → [`patch`] (one file per scheme, backend-agnostic f64
//! control-point tables) → [`eval`] (the evaluator interface, the CPU backend, sample
//! patterns) → [`tess`] (per-edge levels, stitching) → [`analysis`] (continuity
//! statistics, the distance study, Table 1) → [`io`] (mesh writers, MSH, control nets,
//! atomic files) → [`gpu`] (device, the GPU evaluator, statistics and tessellator) →
//! [`render`] (the normal field drawn by a GPU render pass) → `cli`.
//!
//! # Cargo features
//!
//! - `cli` (default): the `g1tess` binary and [`cli`], with what only the command line needs:
//!   argument parsing (clap), progress bars (indicatif), log–log plots (`io::plot`) and
//!   composed PNG pictures (`render::compose`), which use plotters.
//!
//! Without default features the library builds without any of them and keeps meshes,
//! patches, the CPU and GPU evaluators (wgpu), statistics, the writers and the render pass.

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

pub mod analysis;
#[cfg(feature = "cli")]
pub mod cli;
pub mod error;
pub mod eval;
pub mod gpu;
pub mod io;
pub mod mesh;
pub mod patch;
mod pipelined;
pub mod progress;
pub mod render;
pub mod tess;

/// Not part of the API: items the integration tests check directly (the library's own
/// unit-test build would compile the crate a second time). May change without notice.
#[doc(hidden)]
pub mod internals {
    pub use crate::analysis::stats::{Part, BLOCK_PAIRS};
    #[cfg(feature = "cli")]
    pub use crate::cli::common::LazyGpu;
    pub use crate::eval::cpu::edges::min_len2;
    pub use crate::io::atomic::DIRECT_ALIGN;
    pub use crate::mesh::text::{echo, parse_f64, parse_i64, split, statements};
    pub use crate::patch::validity::{
        interior_powers, quick_flat, quick_quartic, tables, Tables, QUARTIC_BOUNDARY,
        QUARTIC_INTERIOR, QUARTIC_UP,
    };
    pub use crate::tess::layout::rings;
}

pub use error::{Error, Result};
