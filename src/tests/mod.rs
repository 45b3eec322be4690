//! Tests that check the library's inner parts across layers (stitching against the GPU
//! topology, the certificate's verdicts, the kernels against the f64 reference, the paper's
//! Table 1), built with the library's unit tests. The tests of what a user can do, through
//! the public API and the `g1tess` command line, are in `tests/`.
//!
//! Tests of different files share one process: they keep their temporary files in per-test
//! names, leave the environment and the global rayon pool alone, and GPU tests print a SKIP
//! line without an adapter (a failure with CI=true).

pub(crate) mod common;
mod eval_cases;

mod adaptive;
mod cpu_fast;
mod creases;
mod fair;
mod fairness;
mod g1_patch;
#[cfg(feature = "gpu")]
mod gpu;
mod hardening_patch;
mod paper;
#[cfg(feature = "gpu")]
mod render;
#[cfg(feature = "gpu")]
mod render_isophotes;
mod render_shader;
mod schemes;
#[cfg(feature = "gpu")]
mod shaders;
mod stats_certified;
mod stitch;
#[cfg(feature = "gpu")]
mod tessellator;
#[cfg(feature = "gpu")]
mod tessellator_levels;
mod validity;
