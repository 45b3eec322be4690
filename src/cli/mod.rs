//! The command line: one file per command. `main` prints errors as one line and exits
//! non-zero; nothing a user can type makes it panic.

mod bench;
pub(crate) mod common;
mod compare;
mod export_msh;
mod export_net;
pub(crate) mod out;
pub mod paper;
mod progress;
mod render;
mod stats;
mod sweep;
mod tessellate;

use std::process::ExitCode;
use std::sync::LazyLock;

use clap::{Parser, Subcommand};

pub use common::{BackendArgs, Budget, InputArgs, MemoryArgs};

/// The command line's temporary files: every file it writes lists its temporary file
/// here, and the signal handler removes those still live.
pub(crate) static TEMP_FILES: LazyLock<crate::io::TempFiles> = LazyLock::new(Default::default);

#[derive(Parser)]
#[command(
    name = "g1tess",
    version,
    about = "Smooth G1 curved surfaces from triangle meshes with vertex normals",
    long_about = "Smooth G1 curved surfaces from triangle meshes with vertex normals.\n\n\
                  With no command, runs the default job (docs/cli.md).",
    args_conflicts_with_subcommands = true
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    /// Options of the default job (no command).
    #[command(flatten)]
    pub paper: paper::PaperArgs,
}

#[derive(Subcommand)]
pub enum Command {
    /// Evaluate every patch on a barycentric grid (one level, or levels chosen for a
    /// tolerance) and write the surface: positions, normals, and the input's texture
    /// coordinates and colours.
    Tessellate(tessellate::TessellateArgs),
    /// Continuity statistics across shared edges (Table 1 protocol).
    Stats(stats::StatsArgs),
    /// Write every patch's control points as JSON (for boundary-element solvers).
    ExportNet(export_net::ExportNetArgs),
    /// Curved Lagrange triangles of order 1 to 5 as Gmsh MSH 4.1, with per-element quality.
    ExportMsh(export_msh::ExportMshArgs),
    /// Pictures of the normal field: n_x, n_y, n_z of the evaluated surface (PNG, Vulkan).
    Render(render::RenderArgs),
    /// Table 1: continuity statistics of every scheme on each mesh (markdown or JSON).
    Compare(compare::CompareArgs),
    /// Distance to the analytic surface on refined icospheres and tori (figures 17–18):
    /// CSV, JSON and log–log plots.
    Sweep(sweep::SweepArgs),
    /// Throughput of the CPU and GPU evaluators against the memory write bandwidth.
    Bench(bench::BenchArgs),
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Some(Command::Stats(a)) => stats::run(&a),
        Some(Command::Tessellate(a)) => tessellate::run(&a),
        Some(Command::ExportNet(a)) => export_net::run(&a),
        Some(Command::ExportMsh(a)) => export_msh::run(&a),
        Some(Command::Render(a)) => render::run(&a),
        Some(Command::Compare(a)) => compare::run(&a),
        Some(Command::Sweep(a)) => sweep::run(&a),
        Some(Command::Bench(a)) => bench::run(&a),
        None => paper::run_args(&cli.paper),
    }
}

/// On SIGINT or SIGTERM: remove the temporary files being written ([`TEMP_FILES`],
/// [`crate::io::TempFiles::remove_live_temp_files`]) and exit with 128 + the signal's
/// number (130, 143), as a shell reports a process the signal ended. The signal is
/// received on a thread of its own (signal-hook), where removing files is safe.
#[cfg(unix)]
fn install_signal_handler() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) else {
        return;
    };
    // A thread that cannot start leaves nothing to clean up with; the run goes on.
    let _ = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(sig) = signals.forever().next() {
                TEMP_FILES.remove_live_temp_files();
                std::process::exit(128 + sig);
            }
        });
}

/// The same where signal-hook has no signal iterator (Windows: Ctrl-C is SIGINT): the
/// handler only records the signal, and a thread of its own, looking every 50 ms, removes
/// the files and exits with 128 + its number.
#[cfg(not(unix))]
fn install_signal_handler() {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    let received = Arc::new(AtomicUsize::new(0));
    for sig in [SIGINT, SIGTERM] {
        if signal_hook::flag::register_usize(sig, received.clone(), sig as usize).is_err() {
            return;
        }
    }
    let _ = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || loop {
            let sig = received.load(Ordering::SeqCst);
            if sig != 0 {
                TEMP_FILES.remove_live_temp_files();
                std::process::exit(128 + sig as i32);
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        });
}

/// The arguments with `--schemes` lists made whole: "g1, pn" (quoted) loses its spaces,
/// and `--schemes g1, pn` (unquoted, split by the shell after the comma) is joined into
/// "g1,pn", so every command reads the list the same way.
pub fn normalize_args(args: Vec<std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    let mut out: Vec<std::ffi::OsString> = Vec::with_capacity(args.len());
    let mut in_list = false;
    for arg in args {
        let Some(s) = arg.to_str().map(str::to_string) else {
            in_list = false;
            out.push(arg);
            continue;
        };
        if in_list {
            let last = out.last_mut().expect("a value precedes");
            let mut joined = last.to_string_lossy().into_owned();
            joined.push_str(&s);
            let squeezed: String = joined
                .split(',')
                .map(str::trim)
                .collect::<Vec<_>>()
                .join(",");
            in_list = squeezed.ends_with(',');
            *last = squeezed.into();
            continue;
        }
        if s == "--schemes" {
            out.push(arg);
            in_list = true;
            // The value follows; the first one always joins.
            out.push(std::ffi::OsString::new());
            continue;
        }
        if let Some(v) = s.strip_prefix("--schemes=") {
            let squeezed: String = v.split(',').map(str::trim).collect::<Vec<_>>().join(",");
            in_list = squeezed.ends_with(',');
            out.push(format!("--schemes={squeezed}").into());
            continue;
        }
        out.push(arg);
    }
    if in_list && out.last().is_some_and(|l| l.is_empty()) {
        // `--schemes` last, with no value: let clap say so.
        out.pop();
    }
    out
}

/// Mesa's Vulkan loader prints "error: XDG_RUNTIME_DIR is invalid or not set" to every user
/// whose session has no runtime directory (containers, ssh, CI), though nothing is wrong.
/// Where the variable is unset, point it at a private directory of our own, as the
/// freedesktop spec asks (owned by the user, mode 0700). Runs first, before any thread
/// exists, so changing the environment is safe.
fn quiet_vulkan_loader() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
        let uid = std::fs::metadata("/proc/self")
            .map(|m| m.uid())
            .unwrap_or(0);
        let dir = std::env::temp_dir().join(format!("g1tess-xdg-{uid}"));
        let _ = std::fs::DirBuilder::new().mode(0o700).create(&dir);
        let ours = std::fs::symlink_metadata(&dir)
            .is_ok_and(|m| m.is_dir() && m.uid() == uid && m.permissions().mode() & 0o777 == 0o700);
        if ours {
            // SAFETY: called at the start of main, before any other thread is started.
            unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
        }
    }
}

/// `s` with every '…'-quoted part passed through the readers' echo (control characters
/// escaped, cut to 80 characters), and any other control character escaped.
fn quote_quoted(s: &str) -> String {
    let mut out = String::new();
    for (i, part) in s.split('\'').enumerate() {
        if i > 0 {
            out.push('\'');
        }
        if i % 2 == 1 {
            out.push_str(&crate::mesh::text::echo(part));
        } else {
            out.extend(part.chars().flat_map(|c| {
                let esc: Vec<char> = if c.is_control() {
                    c.escape_default().collect()
                } else {
                    vec![c]
                };
                esc
            }));
        }
    }
    out
}

/// Help and version go to stdout as clap writes them; a usage error is one line on stderr
/// (clap's first line, which names the argument and what is wrong, then clap's tips, such as
/// "a similar argument exists: '--tolerance'", and where to find help), with exit code 2.
fn usage_error(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(
        e.kind(),
        ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
            // On stderr: a failed write there is ignored.
            let _ = e.print();
            return ExitCode::from(2);
        }
        // Help and version on stdout: a failed write ends the run as any other does.
        let printed = e
            .print()
            .and_then(|()| std::io::Write::flush(&mut std::io::stdout()));
        return match printed {
            Ok(()) => ExitCode::SUCCESS,
            Err(cause) => fail(&out::StdoutError(cause).into()),
        };
    }
    // clap's first paragraph: the message and what it lists (missing arguments, possible
    // values), joined on one line, then its tips ("a similar argument exists: '--level'");
    // its usage is left to --help.
    let text = e.render().to_string();
    let first = text
        .lines()
        .take_while(|l| !l.trim().is_empty())
        .map(str::trim)
        .collect::<Vec<_>>()
        .join(" ");
    let first = first.trim_start_matches("error: ").trim_end_matches(':');
    let first = if first.is_empty() {
        "invalid arguments"
    } else {
        first
    };
    let tips: String = text
        .lines()
        .map(str::trim)
        .filter(|l| l.starts_with("tip:"))
        .map(|l| format!("; {l}"))
        .collect();
    // clap quotes the argument as given: escape control characters (an argument must not
    // drive the terminal) and cut what it echoes (a 5 MB argument gives a short line).
    let first = quote_quoted(&format!("{first}{tips}"));
    // The arguments as the system gives them: one that is not UTF-8 is no command name.
    let sub = std::env::args_os()
        .skip(1)
        .find(|a| !a.as_encoded_bytes().starts_with(b"-"))
        .and_then(|a| a.into_string().ok())
        .filter(|a| {
            <Cli as clap::CommandFactory>::command()
                .get_subcommands()
                .any(|c| c.get_name() == a)
        });
    let usage = match sub {
        Some(sub) => format!("g1tess {sub}"),
        None => "g1tess".into(),
    };
    out::stderr_line(&format!("error: {first} (see '{usage} --help')"));
    ExitCode::from(2)
}

/// Standard output closed early (`g1tess stats … | head`): end quietly, as other Unix tools
/// do, instead of panicking on the failed write. Rust ignores SIGPIPE by default; restore
/// the default action (terminate) before anything is printed.
fn default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called at the start of main, before any other thread exists; SIG_DFL is a
    // valid disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Runs the `g1tess` command line on this process's arguments and returns its exit code.
pub fn main() -> ExitCode {
    default_sigpipe();
    quiet_vulkan_loader();
    install_signal_handler();
    let cli = match Cli::try_parse_from(normalize_args(std::env::args_os().collect())) {
        Ok(cli) => cli,
        Err(e) => return usage_error(e),
    };
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(&e),
    }
}

/// The failed run's one line on stderr, "error: " and the chain of causes, its control
/// characters escaped (names in library messages too); exit status 1. A reader of
/// standard output that went away (broken pipe) ends the run quietly.
fn fail(e: &anyhow::Error) -> ExitCode {
    let broken_pipe = e
        .downcast_ref::<out::StdoutError>()
        .is_some_and(out::StdoutError::is_broken_pipe);
    if !broken_pipe {
        let chain: Vec<String> = e.chain().map(|c| c.to_string()).collect();
        out::stderr_line(&format!("error: {}", chain.join(": ")));
    }
    ExitCode::FAILURE
}
