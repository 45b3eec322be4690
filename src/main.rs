//! The `g1tess` command line: see `src/cli/`.

fn main() -> std::process::ExitCode {
    g1tess::run_cli()
}
