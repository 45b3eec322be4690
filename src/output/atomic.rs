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
    replace_atomically(path, |file| {
        let mut w = BufWriter::with_capacity(1 << 20, file);
        f(&mut w)?;
        w.into_inner().map_err(|e| io(e.into_error()))
    })
}

/// [`write_atomic_with`] through a [`PipedWriter`]: the writes to the file (the copy into
/// the page cache) happen on a thread of their own, in large blocks, while `f` goes on
/// producing. For a producer that is itself the bottleneck (a surface evaluated and
/// encoded as it is written). The same temporary file, fsync and rename.
pub fn write_atomic_piped<F>(path: &Path, f: F) -> Result<()>
where
    F: FnOnce(&mut PipedWriter) -> Result<()>,
{
    let io = |e: std::io::Error| Error::io(path, e);
    if is_stdout(path) {
        let mut w = PipedWriter::direct(stdout_file(path)?);
        f(&mut w)?;
        return w.finish().map(drop).map_err(io);
    }
    replace_atomically(path, |file| {
        let mut w = PipedWriter::spawn(file);
        f(&mut w)?;
        w.finish().map_err(io)
    })
}

/// Writes the target of `path` through a temporary file: `write` gets the new file and
/// gives it back written; then fsync and rename. On any failure the temporary file is
/// removed.
fn replace_atomically(path: &Path, write: impl FnOnce(File) -> Result<File>) -> Result<()> {
    let io = |e: std::io::Error| Error::io(path, e);
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
        let written = write(file);
        drop(writeback);
        let file = written?;
        file.sync_all().map_err(io)?;
        drop(file);
        std::fs::rename(&tmp, &target).map_err(io)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    unregister(&tmp);
    result
}

/// Bytes per block a [`PipedWriter`] hands to its thread (one `write` each): small enough
/// that the blocks in flight stay in the cache (larger blocks measured more system time
/// for the same bytes), large enough that the calls are few.
const PIPE_BLOCK: usize = 512 << 10;
/// Blocks in flight at most: one being filled, one queued, one being written, one handed
/// back.
const PIPE_BLOCKS: usize = 4;

/// A writer whose bytes reach the file from a thread of its own: `write` copies into a
/// block of [`PIPE_BLOCK`] bytes, a full block goes to the thread, which writes it whole
/// and hands it back for reuse, so at most [`PIPE_BLOCKS`] blocks (2 MiB) exist. The
/// thread's first error comes back from the next `write` (or [`PipedWriter::finish`]),
/// after which nothing more is written. Writes at given offsets
/// ([`PipedWriter::write_at_end`]) wait for the end of the stream.
pub struct PipedWriter {
    buf: Vec<u8>,
    inner: Option<Inner>,
    /// (offset, bytes) written after the stream.
    at_end: Vec<(u64, Vec<u8>)>,
}

enum Inner {
    /// Blocks written from the calling thread (standard output, or no thread available).
    Direct(File),
    Thread {
        tx: std::sync::mpsc::SyncSender<Vec<u8>>,
        back: std::sync::mpsc::Receiver<Vec<u8>>,
        thread: std::thread::JoinHandle<std::io::Result<File>>,
        blocks: usize,
    },
}

impl PipedWriter {
    /// Writes from the calling thread, in blocks.
    pub fn direct(file: File) -> PipedWriter {
        PipedWriter {
            buf: Vec::with_capacity(PIPE_BLOCK),
            inner: Some(Inner::Direct(file)),
            at_end: Vec::new(),
        }
    }

    /// Writes from a new thread (from the calling one where no thread can be started).
    pub fn spawn(file: File) -> PipedWriter {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<u8>>(1);
        let (back_tx, back) = std::sync::mpsc::channel::<Vec<u8>>();
        let Ok(writer) = file.try_clone() else {
            return PipedWriter::direct(file);
        };
        let spawned = std::thread::Builder::new()
            .name("g1tess-writer".into())
            .spawn(move || -> std::io::Result<File> {
                let mut file = writer;
                for block in rx {
                    file.write_all(&block)?;
                    // The producer may be gone (an error of its own): then the block drops.
                    let _ = back_tx.send(block);
                }
                Ok(file)
            });
        match spawned {
            Ok(thread) => {
                drop(file);
                PipedWriter {
                    buf: Vec::with_capacity(PIPE_BLOCK),
                    inner: Some(Inner::Thread {
                        tx,
                        back,
                        thread,
                        blocks: 1,
                    }),
                    at_end: Vec::new(),
                }
            }
            Err(_) => PipedWriter::direct(file),
        }
    }

    /// Writes `bytes` at `offset` of the file once the stream is written (a header whose
    /// content is known only at the end); the stream must reach past them.
    pub fn write_at_end(&mut self, offset: u64, bytes: Vec<u8>) {
        self.at_end.push((offset, bytes));
    }

    /// The thread's error, once it has stopped taking blocks.
    fn thread_error(&mut self) -> std::io::Error {
        match self.inner.take() {
            Some(Inner::Thread { tx, thread, .. }) => {
                drop(tx);
                match thread.join() {
                    Ok(Err(e)) => e,
                    _ => std::io::Error::other("the writing thread stopped"),
                }
            }
            _ => std::io::Error::other("the writing thread stopped"),
        }
    }

    /// Hands the filled block on.
    fn send(&mut self) -> std::io::Result<()> {
        if self.buf.is_empty() {
            return Ok(());
        }
        match &mut self.inner {
            Some(Inner::Direct(file)) => {
                file.write_all(&self.buf)?;
                self.buf.clear();
                Ok(())
            }
            Some(Inner::Thread {
                tx, back, blocks, ..
            }) => {
                let full = std::mem::take(&mut self.buf);
                let next = if tx.send(full).is_err() {
                    None
                } else {
                    match back.try_recv() {
                        Ok(b) => Some(b),
                        Err(_) if *blocks < PIPE_BLOCKS => {
                            *blocks += 1;
                            Some(Vec::with_capacity(PIPE_BLOCK))
                        }
                        Err(_) => back.recv().ok(),
                    }
                };
                if let Some(mut b) = next {
                    b.clear();
                    self.buf = b;
                    return Ok(());
                }
                Err(self.thread_error())
            }
            None => Err(std::io::Error::other("the writing thread stopped")),
        }
    }

    /// Writes what is left, waits for the thread, writes the bytes given to
    /// [`PipedWriter::write_at_end`], and gives the file back (not yet synced).
    pub fn finish(mut self) -> std::io::Result<File> {
        use std::io::{Seek, SeekFrom};
        self.send()?;
        let mut file = match self.inner.take() {
            Some(Inner::Direct(file)) => file,
            Some(Inner::Thread { tx, thread, .. }) => {
                drop(tx);
                thread
                    .join()
                    .map_err(|_| std::io::Error::other("the writing thread stopped"))??
            }
            None => return Err(std::io::Error::other("the writing thread stopped")),
        };
        for (offset, bytes) in std::mem::take(&mut self.at_end) {
            file.seek(SeekFrom::Start(offset))?;
            file.write_all(&bytes)?;
        }
        Ok(file)
    }
}

impl Write for PipedWriter {
    fn write(&mut self, data: &[u8]) -> std::io::Result<usize> {
        if self.buf.len() >= PIPE_BLOCK {
            self.send()?;
        }
        let n = data.len().min(PIPE_BLOCK - self.buf.len());
        self.buf.extend_from_slice(&data[..n]);
        Ok(n)
    }

    /// Hands the bytes so far on (to the thread, which writes them soon).
    fn flush(&mut self) -> std::io::Result<()> {
        self.send()
    }
}

impl Drop for PipedWriter {
    /// Stops the thread (after an error, say), writing what it was given.
    fn drop(&mut self) {
        if let Some(Inner::Thread { tx, thread, .. }) = self.inner.take() {
            drop(tx);
            let _ = thread.join();
        }
    }
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
