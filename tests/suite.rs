//! The integration tests, one module per file of `tests/`, built as one test binary: the
//! library, wgpu and the other dependencies are linked once instead of once per file, and
//! the harness runs every file's tests in parallel (pick some with a filter, e.g.
//! `cargo test --release --test suite gpu::`).
//!
//! The tests of different files share one process: they keep their temporary files in
//! per-file names under `CARGO_TARGET_TMPDIR`, leave the environment and the global rayon
//! pool alone (a test that needs its own threads builds a local pool), and run the
//! command line as a child process.

mod common;
mod eval_cases;

mod adaptive;
mod attributes;
mod backend_cli;
mod bench_cli;
mod cli_errors;
mod cli_output;
mod cpu_fast;
mod creases;
mod docs;
mod export_net;
mod formats;
mod fuzz;
mod g1_patch;
mod gpu;
mod mesh_input;
mod msh;
mod obj_fuzz;
mod paper;
mod readers;
mod render;
mod render_shader;
mod schemes;
mod shaders;
mod source_rules;
mod stats_certified;
mod stitch;
mod tessellator;
mod tessellator_levels;
mod unit_eval;
mod unit_mesh;
mod unit_output;
mod unit_patch;
mod unit_tess;
mod validity;
mod viewer;
