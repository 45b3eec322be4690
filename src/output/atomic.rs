//! Atomic file output: write to a temporary file beside the target, then rename, so an
//! interrupted run never leaves a truncated file.
//!
//! - The temporary file is `.NAME.tmp-PID` in the target's folder (NAME the target's file
//!   name, PID the writing process). Every live temporary file is listed in a registry
//!   ([`live_temp_files`]); a program that handles signals removes them with
//!   [`remove_live_temp_files`] before it exits (the command line does, on SIGINT and
//!   SIGTERM). A process killed outright (SIGKILL, power loss) leaves its `.NAME.tmp-PID`
//!   behind; the target is then untouched.
//! - Only regular files are replaced: a target that is a directory, a device, a FIFO or a
//!   socket is refused ([`resolve_output`]).
//! - A symbolic link is written through: the temporary file goes beside the link's final
//!   target, which is replaced; the link stays.
//! - The path `-` is standard output, written directly (no temporary file).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::{Error, Result};

/// Temporary files being written, and whether new ones are still allowed.
struct Registry {
    live: Vec<PathBuf>,
    closed: bool,
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry {
    live: Vec::new(),
    closed: false,
});

fn registry() -> std::sync::MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner())
}

/// The temporary files this process is writing now.
pub fn live_temp_files() -> Vec<PathBuf> {
    registry().live.clone()
}

/// Removes every live temporary file and refuses new ones from now on (a write started
/// afterwards fails). For a signal handler's thread, just before the process exits; returns
/// the files removed.
pub fn remove_live_temp_files() -> Vec<PathBuf> {
    let mut r = registry();
    r.closed = true;
    let live = std::mem::take(&mut r.live);
    live.into_iter()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .collect()
}

fn register(tmp: &Path) -> bool {
    let mut r = registry();
    if r.closed {
        return false;
    }
    r.live.push(tmp.to_path_buf());
    true
}

fn unregister(tmp: &Path) {
    registry().live.retain(|p| p != tmp);
}

/// Whether `path` names standard output (`-`).
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// What kind of file a non-regular file is, in words.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        } else if t.is_block_device() {
            return "a block device";
        } else if t.is_fifo() {
            return "a FIFO";
        } else if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Whether two existing files are the same file (device and inode).
#[cfg(unix)]
fn same_inode(a: &std::fs::Metadata, b: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}

#[cfg(not(unix))]
fn same_inode(_: &std::fs::Metadata, _: &std::fs::Metadata) -> bool {
    false
}

/// The file an output path will replace: `path` itself, or the final target of a chain of
/// symbolic links (relative links resolve against their own folder). Fails when that
/// target exists and is not a regular file, or when the links loop.
pub fn resolve_output(path: &Path) -> Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let link = std::fs::read_link(&p).map_err(|e| Error::io(path, e))?;
                p = match p.parent() {
                    Some(dir) if link.is_relative() => dir.join(link),
                    _ => link,
                };
            }
            Ok(m) if m.is_file() => return Ok(p),
            Ok(m) => {
                let via = if p == path {
                    String::new()
                } else {
                    format!(" (the link's target {})", p.display())
                };
                return Err(Error::Invalid(format!(
                    "{}{via}: is {}, not a regular file; refusing to replace it",
                    path.display(),
                    kind_of(&m)
                )));
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(p),
            Err(e) => return Err(Error::io(path, e)),
        }
    }
    Err(Error::Invalid(format!(
        "{}: too many levels of symbolic links",
        path.display()
    )))
}

/// Fails when `output` is the same file as `input` (same device and inode when both exist,
/// or the same canonical path, symbolic links followed): writing would replace the input.
pub fn refuse_same_file(output: &Path, input: &Path) -> Result<()> {
    if is_stdout(output) {
        return Ok(());
    }
    let inode = match (std::fs::metadata(output), std::fs::metadata(input)) {
        (Ok(a), Ok(b)) => same_inode(&a, &b),
        _ => false,
    };
    let same = inode || {
        let canon = |p: &Path| -> Option<PathBuf> {
            let target = resolve_output(p).ok()?;
            let dir = match target.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            };
            Some(std::fs::canonicalize(dir).ok()?.join(target.file_name()?))
        };
        matches!((canon(output), canon(input)), (Some(a), Some(b)) if a == b)
    };
    if same {
        return Err(Error::Invalid(format!(
            "{}: is the input {}; refusing to overwrite the input",
            output.display(),
            input.display()
        )));
    }
    Ok(())
}

/// Writes `path` atomically through `f`, which receives a buffered writer.
pub fn write_atomic<F>(path: &Path, f: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
{
    write_atomic_with(path, |w| f(w).map_err(|e| Error::io(path, e)))
}

/// Standard output as a [`File`] (a duplicate of descriptor 1).
#[cfg(unix)]
fn stdout_file(path: &Path) -> Result<File> {
    use std::os::fd::AsFd;
    let fd = std::io::stdout()
        .as_fd()
        .try_clone_to_owned()
        .map_err(|e| Error::io(path, e))?;
    Ok(File::from(fd))
}

#[cfg(not(unix))]
fn stdout_file(path: &Path) -> Result<File> {
    Err(Error::Invalid(format!(
        "{}: standard output is not supported on this platform",
        path.display()
    )))
}

/// [`write_atomic`] for a writer that can fail with any [`Error`] (an evaluation streaming
/// into the file, say): on any failure the temporary file is removed and the target is
/// left as it was. See the module documentation for symbolic links, non-regular targets
/// and `-`.
pub fn write_atomic_with<F>(path: &Path, f: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<()>,
{
    let io = |e: std::io::Error| Error::io(path, e);
    if is_stdout(path) {
        let mut w = BufWriter::with_capacity(1 << 20, stdout_file(path)?);
        f(&mut w)?;
        return w.flush().map_err(io);
    }
    let target = resolve_output(path)?;
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = target
        .file_name()
        .ok_or_else(|| Error::Invalid(format!("{}: not a file path", path.display())))?;
    let tmp = dir.join(format!(
        ".{}.tmp-{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    if !register(&tmp) {
        return Err(Error::Invalid(format!(
            "{}: not written (the process is exiting)",
            path.display()
        )));
    }
    let result = (|| {
        let file = File::create(&tmp).map_err(io)?;
        let writeback = EarlyWriteback::start(&file);
        let mut w = BufWriter::with_capacity(1 << 20, file);
        let written = f(&mut w);
        drop(writeback);
        written?;
        w.flush().map_err(io)?;
        w.get_ref().sync_all().map_err(io)?;
        std::fs::rename(&tmp, &target).map_err(io)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    unregister(&tmp);
    result
}

/// Creates `dir` and its parents.
pub fn ensure_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}

/// Starts the kernel's writeback of a file being written while the writing goes on: a
/// thread looks at the file's length every few milliseconds and hands each new 16 MiB to
/// `sync_file_range(SYNC_FILE_RANGE_WRITE)`, which queues the pages for the disk without
/// waiting. Left alone, Linux holds gigabytes of dirty pages until the final `fsync`, which
/// then waits for all of them while nothing else runs; this way the disk works while the
/// surface is evaluated. Purely a hint: errors are ignored, and the final `sync_all` still
/// makes the file durable. A no-op elsewhere than Linux.
struct EarlyWriteback {
    #[cfg(target_os = "linux")]
    stop: Option<(std::sync::mpsc::Sender<()>, std::thread::JoinHandle<()>)>,
}

impl EarlyWriteback {
    #[cfg(target_os = "linux")]
    fn start(file: &File) -> EarlyWriteback {
        use std::os::fd::AsRawFd;
        const STEP: i64 = 16 << 20;
        let Ok(file) = file.try_clone() else {
            return EarlyWriteback { stop: None };
        };
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        let thread = std::thread::Builder::new()
            .name("g1tess-writeback".into())
            .spawn(move || {
                let mut queued: i64 = 0;
                loop {
                    match rx.recv_timeout(std::time::Duration::from_millis(20)) {
                        Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                        _ => return,
                    }
                    let Ok(len) = file.metadata().map(|m| m.len() as i64) else {
                        return;
                    };
                    if len - queued >= STEP {
                        let upto = len - len % STEP;
                        // SAFETY: a plain system call on a descriptor this thread owns
                        // (a duplicate, closed when `file` drops).
                        unsafe {
                            libc::sync_file_range(
                                file.as_raw_fd(),
                                queued,
                                upto - queued,
                                libc::SYNC_FILE_RANGE_WRITE,
                            );
                        }
                        queued = upto;
                    }
                }
            });
        EarlyWriteback {
            stop: thread.ok().map(|t| (tx, t)),
        }
    }

    #[cfg(not(target_os = "linux"))]
    fn start(_: &File) -> EarlyWriteback {
        EarlyWriteback {}
    }
}

impl Drop for EarlyWriteback {
    fn drop(&mut self) {
        #[cfg(target_os = "linux")]
        if let Some((tx, thread)) = self.stop.take() {
            drop(tx);
            let _ = thread.join();
        }
    }
}
