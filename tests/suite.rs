//! The integration tests, one module per file of `tests/`, built as one test binary: the
//! library, wgpu and the other dependencies are linked once instead of once per file, and
//! the harness runs every file's tests in parallel (pick some with a filter, e.g.
//! `cargo test --release --test suite gpu::`).
//!
//! The tests of different files share one process: they keep their temporary files in
//! per-file names under `CARGO_TARGET_TMPDIR`, leave the environment and the global rayon
//! pool alone (a test that needs its own threads builds a local pool), and run the
//! command line as a child process.
//!
//! Files that test only the GPU path build with feature `gpu`, and those that also need
//! the `g1tess` binary or its picture writer with `cli` (which implies `gpu`); the other
//! files gate their GPU tests one by one.

mod common;

#[cfg(feature = "cli")]
mod adaptive;
mod attributes;
#[cfg(feature = "cli")]
mod backend_cli;
#[cfg(feature = "cli")]
mod bench_cli;
#[cfg(feature = "cli")]
mod cli_errors;
#[cfg(feature = "cli")]
mod cli_output;
mod docs;
#[cfg(feature = "cli")]
mod errors;
#[cfg(feature = "cli")]
mod export_net;
#[cfg(feature = "cli")]
mod fair_cli;
#[cfg(feature = "cli")]
mod fairness_cli;
mod formats;
mod fuzz;
#[cfg(feature = "cli")]
mod hardening_cli;
#[cfg(feature = "cli")]
mod hardening_files;
#[cfg(feature = "cli")]
mod hardening_patch;
mod hardening_readers;
#[cfg(feature = "gpu")]
mod host_tessellator;
mod mesh_input;
mod msh;
mod obj_fuzz;
mod paper;
mod readers;
#[cfg(feature = "cli")]
mod render;
mod source_rules;
#[cfg(feature = "cli")]
mod validity;
#[cfg(feature = "cli")]
mod viewer;
