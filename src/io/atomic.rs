//! Atomic file output: write to a temporary file beside the target, then rename, so an
//! interrupted run never leaves a truncated file.
//!
//! - The temporary file is `.NAME.RANDOM.tmp` in the target's folder (NAME the target's
//!   file name, cut to [`TEMP_NAME_PART`] bytes so that any legal name leaves a legal
//!   temporary name; RANDOM 16 hexadecimal digits no other process can guess). It is
//!   created new (`O_CREAT | O_EXCL`: never an existing file, never through a symbolic
//!   link planted at its name), and another name is tried when one is taken. Every live
//!   temporary file is listed in the [`TempFiles`] the caller passes
//!   ([`TempFiles::live_temp_files`]); a program that handles signals removes them with
//!   [`TempFiles::remove_live_temp_files`] before it exits (the command line does, on
//!   SIGINT and SIGTERM). A process killed outright (SIGKILL, power loss) leaves its
//!   `.NAME.RANDOM.tmp` behind; the target is then untouched.
//! - A replaced file keeps its permission bits (read, write and execute for owner, group
//!   and others; on Unix): the temporary file gets them before anything is written into
//!   it. A new file gets the default (0666 less the umask).
//! - Only regular files are replaced: a target that is a directory, a device, a FIFO or a
//!   socket is refused ([`resolve_output`]).
//! - A symbolic link is written through: the temporary file goes beside the link's final
//!   target, which is replaced; the link stays.
//! - The path `-` is standard output, written directly (no temporary file).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use crate::{Error, Result};

/// Temporary files being written, and whether new ones are still allowed.
#[derive(Debug, Default)]
struct Registry {
    live: Vec<PathBuf>,
    closed: bool,
}

/// The list of temporary files that atomic writes are writing now, owned by the caller and
/// passed to every write (`write_atomic` and the writers built on it). Clones share one
/// list: a program that handles signals keeps one handle, gives it to all its writes and
/// calls [`TempFiles::remove_live_temp_files`] from its handler. A caller that does not
/// handle signals passes a fresh one (`&TempFiles::default()`).
#[derive(Clone, Debug, Default)]
pub struct TempFiles(Arc<Mutex<Registry>>);

impl TempFiles {
    fn registry(&self) -> std::sync::MutexGuard<'_, Registry> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The temporary files being written through this list now.
    pub fn live_temp_files(&self) -> Vec<PathBuf> {
        self.registry().live.clone()
    }

    /// Removes every live temporary file and refuses new ones from now on (a write started
    /// afterwards fails). For a signal handler's thread, just before the process exits;
    /// returns the files removed.
    pub fn remove_live_temp_files(&self) -> Vec<PathBuf> {
        let mut r = self.registry();
        r.closed = true;
        let live = std::mem::take(&mut r.live);
        live.into_iter()
            .filter(|p| std::fs::remove_file(p).is_ok())
            .collect()
    }

    /// Creates a new file `dir/PREFIX` + 16 random hexadecimal digits + `SUFFIX` (see
    /// [`create_unique`]) and lists it here, under the list's lock, so that a signal's
    /// [`TempFiles::remove_live_temp_files`] either finds it or refuses to let it be
    /// created. `mode`: the permission bits it gets (Unix), else the default. The error
    /// names the temporary file; after [`TempFiles::remove_live_temp_files`] it says that
    /// the process is exiting.
    pub(crate) fn create_listed(
        &self,
        dir: &Path,
        prefix: &str,
        suffix: &str,
        mode: Option<u32>,
    ) -> std::io::Result<(PathBuf, File)> {
        let mut r = self.registry();
        if r.closed {
            return Err(std::io::Error::other(
                "not written (the process is exiting)",
            ));
        }
        let (tmp, file) = create_unique(dir, prefix, suffix, mode, random_names())?;
        r.live.push(tmp.clone());
        Ok((tmp, file))
    }

    /// Takes `tmp` off the list (once it is renamed or removed).
    pub(crate) fn unlist(&self, tmp: &Path) {
        self.registry().live.retain(|p| p != tmp);
    }
}

/// Bytes of the target's name that its temporary name repeats at most: with the dot, the
/// random part and `.tmp`, a temporary name has at most 122 bytes, well within the 255 of
/// common file systems whatever the target's name.
pub const TEMP_NAME_PART: usize = 100;

/// Names tried at most for one temporary file: each is 64 random bits, so a taken name
/// is a file planted by someone who guessed it (or a squatter on every name).
const TEMP_TRIES: usize = 32;

/// Endless unpredictable 64-bit numbers: SipHash, under the keys std draws from the
/// operating system's random source for each [`RandomState`], of the process, the
/// thread, the time and a counter (no crate and no global state needed).
///
/// [`RandomState`]: std::collections::hash_map::RandomState
fn random_names() -> impl Iterator<Item = u64> {
    use std::hash::{BuildHasher, Hash, Hasher};
    let state = std::collections::hash_map::RandomState::new();
    (0u64..).map(move |n| {
        let mut h = state.build_hasher();
        std::process::id().hash(&mut h);
        std::thread::current().id().hash(&mut h);
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
            .hash(&mut h);
        n.hash(&mut h);
        h.finish()
    })
}

/// Creates a new file `dir/PREFIX` + `name` (16 hexadecimal digits) + `SUFFIX` for the
/// first of `names` that is free, with `O_CREAT | O_EXCL` (`create_new`): an existing file,
/// directory or symbolic link at that name is never opened or followed, the next name is
/// tried instead, [`TEMP_TRIES`] at most. `mode` (Unix): the permission bits the file gets
/// exactly (set after creating it, which the umask would narrow), before anything is
/// written. Errors name the temporary file and say what failed, on one line, but for a
/// missing folder (the plain error, which the caller names the output path in).
fn create_unique(
    dir: &Path,
    prefix: &str,
    suffix: &str,
    mode: Option<u32>,
    names: impl Iterator<Item = u64>,
) -> std::io::Result<(PathBuf, File)> {
    let mut last = None;
    for name in names.take(TEMP_TRIES) {
        let tmp = dir.join(format!("{prefix}{name:016x}{suffix}"));
        let mut options = std::fs::OpenOptions::new();
        options.write(true).create_new(true);
        #[cfg(unix)]
        if let Some(mode) = mode {
            use std::os::unix::fs::OpenOptionsExt;
            // Never wider than the final bits while the file is being filled.
            options.mode(mode);
        }
        match options.open(&tmp) {
            Ok(file) => {
                #[cfg(unix)]
                if let Some(mode) = mode {
                    use std::os::unix::fs::PermissionsExt;
                    if let Err(e) = file.set_permissions(std::fs::Permissions::from_mode(mode)) {
                        drop(file);
                        let _ = std::fs::remove_file(&tmp);
                        return Err(temp_error(&tmp, "cannot set the mode of", e));
                    }
                }
                #[cfg(not(unix))]
                let _ = mode;
                return Ok((tmp, file));
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(tmp),
            // A missing folder is the output path's own problem: the error stays the one
            // the output path gets (as before temporary names were random, whose message
            // would differ on every run).
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Err(e),
            Err(e) => return Err(temp_error(&tmp, "cannot create", e)),
        }
    }
    let taken = last.map_or_else(|| dir.display().to_string(), |t| t.display().to_string());
    Err(std::io::Error::new(
        std::io::ErrorKind::AlreadyExists,
        format!("cannot create a temporary file: {TEMP_TRIES} random names in a row were taken (the last {taken})"),
    ))
}

/// An I/O error of a temporary file, naming it: "cannot create the temporary file
/// DIR/.NAME.RANDOM.tmp: Permission denied (os error 13)".
fn temp_error(tmp: &Path, what: &str, e: std::io::Error) -> std::io::Error {
    std::io::Error::new(
        e.kind(),
        format!("{what} the temporary file {}: {e}", tmp.display()),
    )
}

/// The temporary name's copy of a target's file name: its first [`TEMP_NAME_PART`]
/// bytes at most, cut at a character (names that are not UTF-8 are shown lossily).
fn temp_name_part(name: &std::ffi::OsStr) -> String {
    let name = name.to_string_lossy();
    let mut end = name.len().min(TEMP_NAME_PART);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    name[..end].to_string()
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

/// Whether `a` and `b` are the same file: the same device and inode when both exist, or
/// the same canonical path (symbolic links followed; the file itself may not exist yet).
fn same_file(a: &Path, b: &Path) -> bool {
    let inode = match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(a), Ok(b)) => same_inode(&a, &b),
        _ => false,
    };
    inode || {
        let canon = |p: &Path| -> Option<PathBuf> {
            let target = resolve_output(p).ok()?;
            let dir = match target.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            };
            Some(std::fs::canonicalize(dir).ok()?.join(target.file_name()?))
        };
        matches!((canon(a), canon(b)), (Some(a), Some(b)) if a == b)
    }
}

/// Fails when `output` is the same file as `input` (same device and inode when both exist,
/// or the same canonical path, symbolic links followed): writing would replace the input.
pub fn refuse_same_file(output: &Path, input: &Path) -> Result<()> {
    if !is_stdout(output) && same_file(output, input) {
        return Err(Error::Invalid(format!(
            "{}: is the input {}; refusing to overwrite the input",
            output.display(),
            input.display()
        )));
    }
    Ok(())
}

/// Fails when writing `output` would replace a file the input mesh `input` is read from:
/// the input itself ([`refuse_same_file`]) or, for a glTF file, one of the external
/// buffer files it names (under any name, through links too).
pub fn refuse_input_files(output: &Path, input: &Path) -> Result<()> {
    use crate::mesh::InputFormat;
    refuse_same_file(output, input)?;
    // The format by name, or by content for a regular file only (opening a FIFO blocks).
    let gltf = std::fs::metadata(input).is_ok_and(|m| m.is_file())
        && InputFormat::detect(input).is_ok_and(|f| f == InputFormat::Gltf);
    if is_stdout(output) || !gltf {
        return Ok(());
    }
    match crate::mesh::gltf::buffer_files(input)
        .into_iter()
        .find(|buffer| same_file(output, buffer))
    {
        Some(buffer) => Err(Error::Invalid(format!(
            "{}: is the buffer file {} of the input {}; refusing to overwrite the input",
            output.display(),
            buffer.display(),
            input.display()
        ))),
        None => Ok(()),
    }
}

/// Writes `path` atomically through `f`, which receives a buffered writer; the temporary
/// file is listed in `temp` while it exists.
pub fn write_atomic<F>(path: &Path, temp: &TempFiles, f: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
{
    write_atomic_with(path, temp, |w| f(w).map_err(|e| Error::io(path, e)))
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
pub fn write_atomic_with<F>(path: &Path, temp: &TempFiles, f: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<()>,
{
    let io = |e: std::io::Error| Error::io(path, e);
    if is_stdout(path) {
        let mut w = BufWriter::with_capacity(1 << 20, stdout_file(path)?);
        f(&mut w)?;
        return w.flush().map_err(io);
    }
    replace_atomically(path, temp, |file| {
        let mut w = BufWriter::with_capacity(1 << 20, file);
        f(&mut w)?;
        w.into_inner().map_err(|e| io(e.into_error()))
    })
}

/// [`write_atomic_with`] through a [`PipedWriter`]: the writes to the file (the copy into
/// the page cache) happen on a thread of their own, in large blocks, while `f` goes on
/// producing. For a producer that is itself the bottleneck (a surface evaluated and
/// encoded as it is written). The same temporary file, fsync and rename.
pub fn write_atomic_piped<F>(path: &Path, temp: &TempFiles, f: F) -> Result<()>
where
    F: FnOnce(&mut PipedWriter) -> Result<()>,
{
    let io = |e: std::io::Error| Error::io(path, e);
    if is_stdout(path) {
        let mut w = PipedWriter::direct(stdout_file(path)?);
        f(&mut w)?;
        return w.finish().map(drop).map_err(io);
    }
    replace_atomically(path, temp, |file| {
        let mut w = PipedWriter::spawn(file);
        f(&mut w)?;
        w.finish().map_err(io)
    })
}

/// Writes the target of `path` through a temporary file: `write` gets the new file and
/// gives it back written; then fsync and rename. On any failure the temporary file is
/// removed. The temporary file is listed in `temp` while it exists.
fn replace_atomically(
    path: &Path,
    temp: &TempFiles,
    write: impl FnOnce(File) -> Result<File>,
) -> Result<()> {
    let io = |e: std::io::Error| Error::io(path, e);
    let target = resolve_output(path)?;
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = target
        .file_name()
        .ok_or_else(|| Error::Invalid(format!("{}: not a file path", path.display())))?;
    let (tmp, file) = temp
        .create_listed(
            &dir,
            &format!(".{}.", temp_name_part(name)),
            ".tmp",
            replaced_mode(&target),
        )
        .map_err(io)?;
    let result = (|| {
        let writeback = EarlyWriteback::start(&file);
        let written = write(file);
        drop(writeback);
        let file = written?;
        file.sync_all().map_err(io)?;
        drop(file);
        std::fs::rename(&tmp, &target).map_err(|e| {
            io(std::io::Error::new(
                e.kind(),
                format!(
                    "cannot rename the temporary file {} to it: {e}",
                    tmp.display()
                ),
            ))
        })
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    temp.unlist(&tmp);
    result
}

/// The permission bits of the regular file `target` that a write replaces (None where it
/// does not exist yet, or off Unix).
fn replaced_mode(target: &Path) -> Option<u32> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let meta = std::fs::metadata(target).ok()?;
        meta.is_file().then_some(meta.permissions().mode() & 0o777)
    }
    #[cfg(not(unix))]
    {
        let _ = target;
        None
    }
}

/// Bytes per block a [`PipedWriter`] hands to its thread (one `write` each) when the file
/// goes through the page cache: small enough that the blocks in flight stay in the CPU's
/// cache (larger blocks measured more system time for the same bytes), large enough that
/// the calls are few.
const PIPE_BLOCK: usize = 512 << 10;
/// Bytes per block with direct I/O ([`DirectIo`]): each `write` waits for the device, so
/// larger blocks keep it busier (measured on ext4 over a virtual disk: 1.60 s for 1.78 GB
/// in 512 KiB writes, 1.26 s in 2 MiB, 1.39 s in 4 MiB).
const PIPE_BLOCK_DIRECT: usize = 2 << 20;
/// Blocks in flight at most: one being filled, one queued, one being written, one handed
/// back.
const PIPE_BLOCKS: usize = 4;
/// Bytes of blocks a [`PipedWriter`] holds at most.
pub const PIPED_BYTES: u64 = (PIPE_BLOCKS * PIPE_BLOCK_DIRECT) as u64;
/// Alignment of buffers, file offsets and lengths that direct I/O is given (the page size,
/// a multiple of every common logical block size).
pub const DIRECT_ALIGN: usize = 4096;

/// One aligned page of a block (direct I/O reads the memory it writes from in place).
#[repr(C, align(4096))]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Page([u8; DIRECT_ALIGN]);

/// A block of bytes on page-aligned memory: the first `len` bytes are filled.
struct Block {
    pages: Vec<Page>,
    len: usize,
}

impl Block {
    fn new(bytes: usize) -> Block {
        Block {
            pages: vec![Page([0; DIRECT_ALIGN]); bytes.div_ceil(DIRECT_ALIGN)],
            len: 0,
        }
    }

    fn capacity(&self) -> usize {
        self.pages.len() * DIRECT_ALIGN
    }

    fn bytes(&self) -> &[u8] {
        &bytemuck::cast_slice::<Page, u8>(&self.pages)[..self.len]
    }

    /// Appends as much of `data` as fits; returns how much did.
    fn push(&mut self, data: &[u8]) -> usize {
        let free = &mut bytemuck::cast_slice_mut::<Page, u8>(&mut self.pages)[self.len..];
        let n = data.len().min(free.len());
        free[..n].copy_from_slice(&data[..n]);
        self.len += n;
        n
    }
}

/// Direct I/O (`O_DIRECT`) on the file a [`PipedWriter`] fills: the device reads the blocks
/// from the process's memory, with no copy into the page cache. That copy, into freshly
/// allocated pages, is most of the system time of writing a large file (measured: a 1.78
/// GB PLY file spent 18-44 % of its CPU time in it; `dd` writes the same bytes in 0.2 s of
/// system time direct, 0.6-2.3 s buffered). Used on local block-device file systems that
/// support it well (ext2/3/4, XFS); elsewhere (tmpfs, network and FUSE file systems, other
/// platforms) the file is written through the page cache as before. Once a write is not
/// aligned (the end of the file, or a flush), or the file system refuses an aligned one,
/// the rest of the file goes through the page cache: the bytes are the same either way.
mod direct {
    use std::fs::File;

    /// Whether direct I/O is worth turning on for `file` (see above).
    #[cfg(target_os = "linux")]
    pub fn suits(file: &File) -> bool {
        use std::os::fd::AsRawFd;
        const EXT_MAGIC: i64 = 0xEF53;
        const XFS_MAGIC: i64 = 0x5846_5342;
        // SAFETY: statfs is plain data, filled by the call on a descriptor we hold.
        let mut st: libc::statfs = unsafe { std::mem::zeroed() };
        if unsafe { libc::fstatfs(file.as_raw_fd(), &mut st) } != 0 {
            return false;
        }
        #[allow(clippy::unnecessary_cast)]
        let kind = st.f_type as i64;
        kind == EXT_MAGIC || kind == XFS_MAGIC
    }

    /// Sets or clears `O_DIRECT` on `file`'s open file (shared by its duplicates); whether
    /// that worked.
    #[cfg(target_os = "linux")]
    pub fn set(file: &File, on: bool) -> bool {
        use std::os::fd::AsRawFd;
        let fd = file.as_raw_fd();
        // SAFETY: fcntl on a descriptor we hold, with integer flags only.
        unsafe {
            let flags = libc::fcntl(fd, libc::F_GETFL);
            if flags < 0 {
                return false;
            }
            let want = if on {
                flags | libc::O_DIRECT
            } else {
                flags & !libc::O_DIRECT
            };
            want == flags || libc::fcntl(fd, libc::F_SETFL, want) == 0
        }
    }

    #[cfg(not(target_os = "linux"))]
    pub fn suits(_: &File) -> bool {
        false
    }

    #[cfg(not(target_os = "linux"))]
    pub fn set(_: &File, on: bool) -> bool {
        !on
    }
}

/// Writes `bytes` (page-aligned memory) at the file's position (or at offset `at`),
/// directly while `*direct` holds and the pieces are aligned, else through the page cache
/// (clearing `O_DIRECT` for good, and `*direct`).
fn write_block(
    file: &mut File,
    bytes: &[u8],
    at: Option<u64>,
    direct: &mut bool,
) -> std::io::Result<()> {
    let mut done = 0;
    let buffered = |file: &File, direct: &mut bool| {
        *direct = false;
        direct::set(file, false)
    };
    while done < bytes.len() {
        let rest = &bytes[done..];
        let piece = if *direct {
            let aligned = rest.len() / DIRECT_ALIGN * DIRECT_ALIGN;
            if aligned == 0 {
                if !buffered(file, direct) {
                    return Err(std::io::Error::other("cannot turn off direct I/O"));
                }
                rest
            } else {
                &rest[..aligned]
            }
        } else {
            rest
        };
        let written = match at {
            None => file.write(piece),
            Some(at) => write_at(file, piece, at + done as u64),
        };
        match written {
            Ok(0) => return Err(std::io::ErrorKind::WriteZero.into()),
            Ok(n) => {
                done += n;
                if *direct && n % DIRECT_ALIGN != 0 && !buffered(file, direct) {
                    return Err(std::io::Error::other("cannot turn off direct I/O"));
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            // The file system's alignment is coarser than ours (EINVAL, the one OS error
            // of kind InvalidInput): through the page cache.
            Err(e) if *direct && e.kind() == std::io::ErrorKind::InvalidInput => {
                if !buffered(file, direct) {
                    return Err(e);
                }
            }
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

#[cfg(unix)]
fn write_at(file: &File, bytes: &[u8], at: u64) -> std::io::Result<usize> {
    std::os::unix::fs::FileExt::write_at(file, bytes, at)
}

#[cfg(not(unix))]
fn write_at(_: &File, _: &[u8], _: u64) -> std::io::Result<usize> {
    Err(std::io::Error::other(
        "positioned writes are not supported here",
    ))
}

/// A writer whose bytes reach the file from a thread of its own: `write` copies into a
/// block ([`PIPE_BLOCK`] bytes, or [`PIPE_BLOCK_DIRECT`] with direct I/O), a full block
/// goes to the thread, which writes it whole and hands it back for reuse, so at most
/// [`PIPE_BLOCKS`] blocks (2 or 8 MiB) exist. The thread's first error comes back from the
/// next `write` (or [`PipedWriter::finish`]), after which nothing more is written. Writes
/// at given offsets ([`PipedWriter::write_at_end`]) wait for the end of the stream. Where
/// the file system suits it, the thread writes with direct I/O (see `direct`).
pub struct PipedWriter {
    buf: Block,
    inner: Option<Inner>,
    /// (offset, bytes) written after the stream.
    at_end: Vec<(u64, Vec<u8>)>,
    /// A duplicate of the file for [`PipedWriter::split_at`], and whether it was opened
    /// for direct I/O (threaded writers on files only).
    split: Option<(File, bool)>,
    /// A writer from [`PipedWriter::split_at`]: the offset of its block's first byte.
    at: Option<u64>,
}

enum Inner {
    /// Blocks written from the calling thread (standard output, or no thread available).
    Direct(File),
    Thread {
        tx: std::sync::mpsc::SyncSender<(Option<u64>, Block)>,
        back: std::sync::mpsc::Receiver<Block>,
        thread: std::thread::JoinHandle<std::io::Result<File>>,
        blocks: usize,
    },
}

impl PipedWriter {
    /// Writes from the calling thread, in blocks, through the page cache.
    pub fn direct(file: File) -> PipedWriter {
        PipedWriter {
            buf: Block::new(PIPE_BLOCK),
            inner: Some(Inner::Direct(file)),
            at_end: Vec::new(),
            split: None,
            at: None,
        }
    }

    /// Writes from a new thread (from the calling one where no thread can be started),
    /// with direct I/O where the file system suits it. On wasm32, which has no threads,
    /// always from the calling thread.
    pub fn spawn(file: File) -> PipedWriter {
        if cfg!(target_arch = "wasm32") {
            return PipedWriter::direct(file);
        }
        let direct = direct::suits(&file) && direct::set(&file, true);
        match PipedWriter::spawn_at(&file, None, direct) {
            Some(mut w) => {
                w.split = Some((file, direct));
                w
            }
            None => {
                direct::set(&file, false);
                PipedWriter::direct(file)
            }
        }
    }

    /// A threaded writer of a duplicate of `file`, from its position (`at` None) or from
    /// offset `at` on; None where no duplicate or thread could be made.
    fn spawn_at(file: &File, at: Option<u64>, mut direct: bool) -> Option<PipedWriter> {
        let (tx, rx) = std::sync::mpsc::sync_channel::<(Option<u64>, Block)>(1);
        let (back_tx, back) = std::sync::mpsc::channel::<Block>();
        let mut writer = file.try_clone().ok()?;
        let block = if direct {
            PIPE_BLOCK_DIRECT
        } else {
            PIPE_BLOCK
        };
        let thread = std::thread::Builder::new()
            .name("g1tess-writer".into())
            .spawn(move || -> std::io::Result<File> {
                for (at, block) in rx {
                    write_block(&mut writer, block.bytes(), at, &mut direct)?;
                    // The producer may be gone (an error of its own): then the block drops.
                    let _ = back_tx.send(block);
                }
                Ok(writer)
            })
            .ok()?;
        Some(PipedWriter {
            buf: Block::new(block),
            inner: Some(Inner::Thread {
                tx,
                back,
                thread,
                blocks: 1,
            }),
            at_end: Vec::new(),
            split: None,
            at,
        })
    }

    /// A second writer of the same file whose bytes go at `offset` on (a multiple of 4096),
    /// from a thread of its own, while this one goes on: a later section of the file whose
    /// place is known, written at the same time as the stream before it. Only whole blocks
    /// are written; [`PipedWriter::finish_at`] gives back the rest. None for standard
    /// output, an unaligned offset, or where no thread can be started.
    pub fn split_at(&self, offset: u64) -> Option<PipedWriter> {
        let (file, direct) = self.split.as_ref()?;
        if !offset.is_multiple_of(DIRECT_ALIGN as u64) || !cfg!(unix) {
            return None;
        }
        PipedWriter::spawn_at(file, Some(offset), *direct)
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
        if self.buf.len == 0 {
            return Ok(());
        }
        match &mut self.inner {
            Some(Inner::Direct(file)) => {
                file.write_all(self.buf.bytes())?;
                self.buf.len = 0;
                Ok(())
            }
            Some(Inner::Thread {
                tx, back, blocks, ..
            }) => {
                let capacity = self.buf.capacity();
                let full = std::mem::replace(
                    &mut self.buf,
                    Block {
                        pages: Vec::new(),
                        len: 0,
                    },
                );
                let at = self.at;
                if let Some(at) = &mut self.at {
                    *at += full.len as u64;
                }
                let next = if tx.send((at, full)).is_err() {
                    None
                } else {
                    match back.try_recv() {
                        Ok(b) => Some(b),
                        Err(_) if *blocks < PIPE_BLOCKS => {
                            *blocks += 1;
                            Some(Block::new(capacity))
                        }
                        Err(_) => back.recv().ok(),
                    }
                };
                if let Some(mut b) = next {
                    b.len = 0;
                    self.buf = b;
                    return Ok(());
                }
                Err(self.thread_error())
            }
            None => Err(std::io::Error::other("the writing thread stopped")),
        }
    }

    /// Writes what is left, waits for the thread, writes the bytes given to
    /// [`PipedWriter::write_at_end`], and gives the file back (not yet synced), through the
    /// page cache from then on.
    pub fn finish(mut self) -> std::io::Result<File> {
        use std::io::{Seek, SeekFrom};
        if self.at.is_some() {
            return Err(std::io::Error::other("a split writer ends with finish_at"));
        }
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
        if !direct::set(&file, false) {
            return Err(std::io::Error::other("cannot turn off direct I/O"));
        }
        for (offset, bytes) in std::mem::take(&mut self.at_end) {
            file.seek(SeekFrom::Start(offset))?;
            file.write_all(&bytes)?;
        }
        Ok(file)
    }
}

impl PipedWriter {
    /// The free bytes of the current block, to encode into in place (a full block is
    /// handed on first, so there is at least one); [`PipedWriter::commit`] counts what was
    /// put there. Blocks are handed on full only (direct I/O stays aligned).
    pub fn spare(&mut self) -> std::io::Result<&mut [u8]> {
        if self.buf.len >= self.buf.capacity() {
            self.send()?;
        }
        let len = self.buf.len;
        Ok(&mut bytemuck::cast_slice_mut::<Page, u8>(&mut self.buf.pages)[len..])
    }

    /// Counts the first `n` bytes of [`PipedWriter::spare`] as written.
    pub fn commit(&mut self, n: usize) {
        self.buf.len = (self.buf.len + n).min(self.buf.capacity());
    }

    /// Ends a writer from [`PipedWriter::split_at`]: waits until its whole blocks are
    /// written and gives back the bytes not yet written (less than a block) with their
    /// offset, for the first writer's [`PipedWriter::write_at_end`].
    pub fn finish_at(mut self) -> std::io::Result<(u64, Vec<u8>)> {
        let at = self
            .at
            .ok_or_else(|| std::io::Error::other("not a split writer"))?;
        let rest = self.buf.bytes().to_vec();
        match self.inner.take() {
            Some(Inner::Thread { tx, thread, .. }) => {
                drop(tx);
                thread
                    .join()
                    .map_err(|_| std::io::Error::other("the writing thread stopped"))??;
            }
            _ => return Err(std::io::Error::other("the writing thread stopped")),
        }
        Ok((at, rest))
    }
}

impl Write for PipedWriter {
    fn write(&mut self, data: &[u8]) -> std::io::Result<usize> {
        if self.buf.len >= self.buf.capacity() {
            self.send()?;
        }
        Ok(self.buf.push(data))
    }

    /// Hands the bytes so far on (to the thread, which writes them soon); a writer from
    /// [`PipedWriter::split_at`] hands on whole blocks only, so this does nothing there.
    fn flush(&mut self) -> std::io::Result<()> {
        if self.at.is_some() {
            return Ok(());
        }
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

#[cfg(test)]
mod tests {
    use std::fs::File;
    use std::io::Write;

    use super::DIRECT_ALIGN;
    use crate::io::atomic::{write_atomic, PipedWriter};
    use crate::TempFiles;

    /// A write lists its temporary file in the `TempFiles` it is given (shared by clones,
    /// not by another list) while it runs; removing the live files deletes it, the write
    /// then fails without creating the target, and later writes through that list are
    /// refused while another list still writes.
    #[test]
    fn temp_files_list_live_writes_and_remove_them() {
        let dir = crate::tests::common::tmp_dir("unit_output_temp_files");
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("out.txt");
        let _ = std::fs::remove_file(&target);
        let (temp, other) = (TempFiles::default(), TempFiles::default());
        let handle = temp.clone();
        let mut seen = None;
        let result = write_atomic(&target, &temp, |w| {
            w.write_all(b"partial")?;
            w.flush()?;
            let live = handle.live_temp_files();
            assert_eq!(live.len(), 1, "{live:?}");
            let tmp = live[0].clone();
            seen = Some(tmp.clone());
            // `.NAME.` + 16 hexadecimal digits + `.tmp`, beside the target.
            assert_eq!(tmp.parent(), Some(dir.as_path()));
            let name = tmp.file_name().unwrap().to_str().unwrap();
            let random = name
                .strip_prefix(".out.txt.")
                .and_then(|r| r.strip_suffix(".tmp"))
                .unwrap_or_else(|| panic!("temporary name {name}"));
            assert!(random.len() == 16 && random.bytes().all(|b| b.is_ascii_hexdigit()));
            assert!(other.live_temp_files().is_empty());
            assert!(tmp.is_file());
            assert_eq!(handle.remove_live_temp_files(), vec![tmp.clone()]);
            Ok(())
        });
        assert!(result.is_err(), "the rename of a removed file must fail");
        let tmp = seen.unwrap();
        assert!(!tmp.exists() && !target.exists());
        assert!(temp.live_temp_files().is_empty());
        let refused = write_atomic(&target, &temp, |w| w.write_all(b"late")).unwrap_err();
        assert!(
            refused.to_string().contains("the process is exiting"),
            "{refused}"
        );
        assert!(!target.exists());
        write_atomic(&target, &other, |w| w.write_all(b"whole")).unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"whole");
        assert!(other.live_temp_files().is_empty());
        std::fs::remove_file(&target).unwrap();
    }

    /// Names already taken (a directory squatting on one, a symbolic link planted at the
    /// next, a plain file) are skipped, never opened or followed: the file gets the first
    /// free name. With every name taken the error says so, on one line naming the folder's
    /// last name tried; a failure to create names the temporary file and the cause, but
    /// for a missing folder.
    #[test]
    fn taken_temporary_names_are_skipped_and_errors_name_the_file() {
        use super::{create_unique, TEMP_TRIES};
        let dir = crate::tests::common::tmp_dir("unit_output_taken_names");
        let victim = dir.join("victim");
        std::fs::write(&victim, b"victim").unwrap();
        let name = |n: u64| dir.join(format!(".t.{n:016x}.tmp"));
        std::fs::create_dir_all(name(1)).unwrap();
        let _ = std::fs::remove_file(name(2));
        #[cfg(unix)]
        std::os::unix::fs::symlink(&victim, name(2)).unwrap();
        std::fs::write(name(3), b"other").unwrap();
        let (tmp, mut file) = create_unique(&dir, ".t.", ".tmp", None, 1..).unwrap();
        assert_eq!(tmp, name(4));
        file.write_all(b"new").unwrap();
        drop(file);
        assert_eq!(std::fs::read(&victim).unwrap(), b"victim");
        assert_eq!(std::fs::read(name(3)).unwrap(), b"other");
        assert!(name(1).is_dir());
        // Every name taken: name 4 again and again.
        let e = create_unique(&dir, ".t.", ".tmp", None, std::iter::repeat(4)).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains(&format!("{TEMP_TRIES} random names in a row were taken"))
                && msg.contains(&name(4).display().to_string())
                && !msg.contains('\n'),
            "{msg}"
        );
        // A folder that does not exist: the plain error, which the output path's message
        // wraps (no random name in it, so the same on every run).
        let missing = dir.join("missing");
        let e = create_unique(&missing, ".t.", ".tmp", None, 7..).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::NotFound);
        assert!(!e.to_string().contains(".tmp"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The temporary name of a 250-byte target name (255 is the usual limit) keeps its
    /// first 100 bytes, cut at a character, so the write goes through; the name part of a
    /// short name is the whole name.
    #[test]
    fn long_target_names_leave_short_temporary_names() {
        use super::{temp_name_part, TEMP_NAME_PART};
        use std::ffi::OsStr;
        assert_eq!(temp_name_part(OsStr::new("out.ply")), "out.ply");
        // 'é' is 2 bytes: 99 of 'a' then 'é' would end at byte 101, so it is left out.
        let accented = format!("{}é{}", "a".repeat(99), "b".repeat(10));
        assert_eq!(temp_name_part(OsStr::new(&accented)), "a".repeat(99));
        let dir = crate::tests::common::tmp_dir("unit_output_long_name");
        let long = format!("{}.obj", "n".repeat(246));
        assert_eq!(long.len(), 250);
        assert_eq!(temp_name_part(OsStr::new(&long)).len(), TEMP_NAME_PART);
        let target = dir.join(&long);
        write_atomic(&target, &TempFiles::default(), |w| w.write_all(b"long")).unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"long");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A replaced file keeps its permission bits (0600, 0755, 0400: still writable through
    /// the open file); a new one gets the default, as `File::create` gives it here.
    #[cfg(unix)]
    #[test]
    fn replaced_files_keep_their_mode() {
        use std::os::unix::fs::PermissionsExt;
        let dir = crate::tests::common::tmp_dir("unit_output_mode");
        let mode =
            |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o7777;
        for bits in [0o600, 0o755, 0o400, 0o640] {
            let target = dir.join(format!("m{bits:o}.txt"));
            std::fs::write(&target, b"old").unwrap();
            std::fs::set_permissions(&target, std::fs::Permissions::from_mode(bits)).unwrap();
            write_atomic(&target, &TempFiles::default(), |w| w.write_all(b"new")).unwrap();
            assert_eq!(std::fs::read(&target).unwrap(), b"new");
            assert_eq!(mode(&target), bits, "{}", target.display());
        }
        let reference = dir.join("reference");
        drop(File::create(&reference).unwrap());
        let fresh = dir.join("fresh.txt");
        write_atomic(&fresh, &TempFiles::default(), |w| w.write_all(b"new")).unwrap();
        assert_eq!(mode(&fresh), mode(&reference));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A glTF's external buffer files are inputs: an output on one of them (by its name,
    /// another spelling or a link) is refused naming it; data URIs and other names pass,
    /// and so does anything for an input that is not glTF.
    #[cfg(unix)]
    #[test]
    fn outputs_on_a_gltf_buffer_are_refused() {
        use super::refuse_input_files;
        let dir = crate::tests::common::tmp_dir("unit_output_gltf_buffers");
        let gltf = dir.join("scene.gltf");
        std::fs::write(
            &gltf,
            r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":4,"uri":"data:application/octet-stream;base64,AAAAAA=="},{"byteLength":4,"uri":"scene%20buf.bin"}]}"#,
        )
        .unwrap();
        let buffer = dir.join("scene buf.bin");
        std::fs::write(&buffer, [0u8; 4]).unwrap();
        let link = dir.join("link.glb");
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink("scene buf.bin", &link).unwrap();
        for out in [buffer.clone(), dir.join("sub/../scene buf.bin"), link] {
            std::fs::create_dir_all(dir.join("sub")).unwrap();
            let e = refuse_input_files(&out, &gltf).unwrap_err().to_string();
            assert!(
                e.contains("is the buffer file") && e.contains("scene buf.bin"),
                "{e}"
            );
        }
        refuse_input_files(&dir.join("out.glb"), &gltf).unwrap();
        let e = refuse_input_files(&gltf, &gltf).unwrap_err().to_string();
        assert!(e.contains("is the input"), "{e}");
        let obj = dir.join("m.obj");
        std::fs::write(&obj, "v 0 0 0\n").unwrap();
        refuse_input_files(&buffer, &obj).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A stream (with or without an unaligned flush half way, which turns direct I/O off),
    /// a second writer from a page boundary on, and the second's rest written at the end
    /// give exactly the bytes written, whether the file system takes direct I/O or not.
    #[test]
    fn piped_and_split_writes_land_in_place() {
        let data: Vec<u8> = (0..5_000_000u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
            .collect();
        // A page boundary; the second writer gets one whole block and a rest.
        let split = 301 * DIRECT_ALIGN;
        for flush in [false, true] {
            let path =
                std::env::temp_dir().join(format!("g1tess-piped-{}-{flush}", std::process::id()));
            let mut w = PipedWriter::spawn(File::create(&path).unwrap());
            let mut side = w.split_at(split as u64).unwrap();
            side.write_all(&data[split..]).unwrap();
            w.write_all(&data[..1000]).unwrap();
            if flush {
                w.flush().unwrap();
            }
            w.write_all(&data[1000..split]).unwrap();
            let (at, rest) = side.finish_at().unwrap();
            assert_eq!(at as usize + rest.len(), data.len());
            w.write_at_end(at, rest);
            drop(w.finish().unwrap());
            let got = std::fs::read(&path).unwrap();
            std::fs::remove_file(&path).unwrap();
            assert!(got == data, "flush {flush}: the file differs");
        }
    }
}
