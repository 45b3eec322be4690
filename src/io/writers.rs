//! Mesh writers. Every file is written atomically (see [`super::atomic`]).
//!
//! Stitched output ([`crate::tess::stitch`]) streams patch by patch into one of four
//! formats, chosen by the file extension ([`MeshFormat`]), in the precision the samples
//! come in (`[f32; 3]` from the f32 kernels, or `DVec3` rounded once to f32 for the binary
//! formats):
//! - `.obj`: `v` shared positions, `vn` one per vertex record, `f p//r` triangles; each
//!   value in the shortest decimal that reads back to the same value in its precision
//!   (f32 for f32 samples); lines interleaved as the patches arrive (every face only
//!   refers to earlier lines).
//! - `.ply`: binary little-endian, `float x y z nx ny nz` per vertex record, then
//!   `list uchar int vertex_indices` per triangle; the counts come from the plan, so the
//!   header is written first and nothing is held back.
//! - `.stl`: binary, one facet per triangle with the normal of the flat welded triangle
//!   (zero where it is degenerate).
//! - `.glb`: glTF 2.0 binary, one mesh with interleaved f32 POSITION and NORMAL (one per
//!   vertex record) and u32 indices; accessor min/max bounds set. The JSON chunk is reserved
//!   up front and filled in once the bounds are known.
//!
//!
//! Texture coordinates and colours ([`StitchPlan::has_uvs`], [`StitchPlan::has_colors`]) go
//! with the vertex records: OBJ `vt` (one per record, faces `p/r/r`; OBJ has no colours),
//! PLY `float s t` and `uchar red green blue [alpha]` after the normal, glTF `TEXCOORD_0`
//! (float) and `COLOR_0` (float, `VEC3`, or `VEC4` when the input had alpha) interleaved
//! after the normal. STL has none. A mesh without them is written as before.
//!
//! PLY and glTF list every vertex before any triangle: their triangles are regenerated
//! from the plan (topology only), not kept from the stitcher.
//!
//! Files go to the temporary file in blocks written by a thread of their own
//! ([`PipedWriter`], with direct I/O where the file system suits it): the thread that
//! evaluates, stitches and encodes never waits for the write. PLY and glTF files also put
//! their triangles in place while the vertices stream: the face section's offset is known
//! from the plan, so a thread of its own encodes the faces patch by patch into a second
//! writer of the same file from the first page boundary in the section on
//! ([`PipedWriter::split_at`]); the stream writes the section's bytes before that
//! boundary. On standard output, and for face sections under 1 MiB, the faces follow the
//! vertices in the stream, encoded per batch in parallel. Progress is reported through
//! [`Progress`], never drawn here.

use std::io::{self, Write};
use std::path::Path;

use rayon::prelude::*;

use super::atomic::{write_atomic_piped, PipedWriter, TempFiles, PIPED_BYTES};
use crate::eval::{grid_len, grid_triangles, Vector};
use crate::progress::Progress;
use crate::tess::stitch::{Needs, PatchOut, RecordAttributes, StitchPlan, StitchSink};
use crate::{Error, Result};

/// Output mesh formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MeshFormat {
    /// Wavefront OBJ, text.
    Obj,
    /// PLY, binary little-endian.
    Ply,
    /// STL, binary.
    Stl,
    /// glTF 2.0, binary.
    Glb,
}

impl MeshFormat {
    /// The format named by `path`'s extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<MeshFormat> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        match ext.as_str() {
            "obj" => Ok(MeshFormat::Obj),
            "ply" => Ok(MeshFormat::Ply),
            "stl" => Ok(MeshFormat::Stl),
            "glb" => Ok(MeshFormat::Glb),
            _ => Err(Error::unsupported(
                path.display().to_string(),
                format!("unknown output format '{ext}' (known: .obj, .ply, .stl, .glb)"),
            )),
        }
    }

    /// Vertices as the file's reader counts them: OBJ and STL positions, PLY and glTF
    /// vertex records (positions repeated where normals are split).
    pub fn file_vertices(self, plan: &StitchPlan) -> usize {
        match self {
            MeshFormat::Obj | MeshFormat::Stl => plan.positions,
            MeshFormat::Ply | MeshFormat::Glb => plan.records,
        }
    }

    /// Whether the format can be written to standard output (`-o -`): OBJ, PLY and STL
    /// stream front to back (their counts come from the plan); glTF's JSON chunk holds the
    /// bounds, known only at the end, so it needs a file it can seek in.
    pub fn streams(self) -> bool {
        self != MeshFormat::Glb
    }

    /// What the format's writer reads of each patch.
    pub fn needs(self) -> Needs {
        match self {
            MeshFormat::Obj => Needs {
                positions: true,
                triangles: true,
                grid_positions: false,
            },
            MeshFormat::Ply | MeshFormat::Glb => Needs::RECORDS,
            MeshFormat::Stl => Needs {
                positions: false,
                triangles: false,
                grid_positions: true,
            },
        }
    }

    /// Bytes the writer holds at `level` besides the stitcher's output, as (while the
    /// patches stream in, afterwards): the file's blocks (`PIPED_BYTES`), OBJ's text
    /// (flushed every `TEXT_FLUSH` bytes), STL's facets of one patch; PLY and glTF also
    /// write their faces while the vertices stream (a second writer's blocks and one
    /// patch's triangles), or, where that writer cannot be had (standard output), encode
    /// them per batch (`face_batch`) once every vertex is written.
    pub fn buffer_bytes(self, level: u32, patches: usize) -> (u64, u64) {
        let n2 = level as u64 * level as u64;
        let file_buffer = PIPED_BYTES;
        match self {
            MeshFormat::Obj => (file_buffer + 2 * TEXT_FLUSH as u64, 0),
            MeshFormat::Stl => (file_buffer + n2 * 50, 0),
            MeshFormat::Ply | MeshFormat::Glb => {
                // Per patch: grid triangles, triangles, encoded bytes, local ids.
                let patch = n2 * (12 + 12 + 13) + grid_len(level) as u64 * 8;
                let batch = face_batch(level).min(patches.max(1)) as u64;
                let faces = n2 * 12 + batch * (n2 * (12 + 13) + grid_len(level) as u64 * 8);
                (2 * file_buffer + patch, file_buffer + faces)
            }
        }
    }

    /// Size of a binary file, where the format limits it.
    fn check(self, plan: &StitchPlan, path: &Path, title: &str) -> Result<()> {
        let too_big = |why: &str| {
            Err(Error::Invalid(format!(
                "{}: {} vertices / {} triangles are too many for {why}",
                path.display(),
                plan.records,
                plan.triangles
            )))
        };
        match self {
            MeshFormat::Ply if plan.records > i32::MAX as usize => too_big("PLY's int indices"),
            MeshFormat::Stl if plan.triangles > u32::MAX as usize => {
                too_big("STL's 32-bit triangle count")
            }
            MeshFormat::Glb if glb_layout(plan, title).total > u32::MAX as u64 => {
                too_big("a glTF binary (4 GiB)")
            }
            _ => Ok(()),
        }
    }
}

/// One format's streaming writer.
trait FormatWriter<V> {
    /// What the format reads of each patch.
    fn needs(&self) -> Needs;
    fn begin(&mut self, w: &mut PipedWriter) -> io::Result<()>;
    /// Writes a patch; false when a value it wrote is not finite as written (only a
    /// writer that [`FormatWriter::checks_finite`] says so; the others give true).
    fn patch(&mut self, w: &mut PipedWriter, out: &PatchOut<'_, V>) -> io::Result<bool>;
    fn finish(&mut self, w: &mut PipedWriter, progress: &dyn Progress) -> io::Result<()>;
    /// Whether the writer checks [`check_finite`]'s rule itself as it encodes (else the
    /// patch is checked before it is written).
    fn checks_finite(&self) -> bool {
        false
    }
    /// Where the triangles go when their place is known before the vertices are written:
    /// the offset of the face section and their encoding (PLY, glTF).
    fn face_section(&self) -> Option<(u64, FaceCodec)> {
        None
    }
    /// What follows the triangles when [`FormatWriter::face_section`] wrote them (instead
    /// of [`FormatWriter::finish`]).
    fn after_faces(&mut self, _: &mut PipedWriter) -> io::Result<()> {
        Ok(())
    }
}

/// Writes the stitched output of `plan` to `path` in `format`, atomically, from samples of
/// precision `V`. `produce` must run the evaluation and feed every patch, in order, to the
/// sink it is given (see [`crate::tess::stitch::stitch_into`], which also reports the
/// evaluation to `progress`). `title` goes into the file's comment/header. PLY and glTF
/// report a second phase, "writing faces", over the patches. The temporary file is listed
/// in `temp` while it exists.
pub fn write_stitched<V: Vector>(
    path: &Path,
    temp: &TempFiles,
    format: MeshFormat,
    plan: &StitchPlan,
    title: &str,
    progress: &dyn Progress,
    produce: &mut dyn FnMut(&mut dyn StitchSink<V>) -> Result<()>,
) -> Result<()> {
    format.check(plan, path, title)?;
    if super::atomic::is_stdout(path) && !format.streams() {
        return Err(Error::Invalid(format!(
            "{}: {format:?} cannot be streamed to standard output (its header holds the \
             bounds, known only at the end); write it to a file",
            path.display()
        )));
    }
    let mut writer: Box<dyn FormatWriter<V> + '_> = match format {
        MeshFormat::Obj => Box::new(ObjWriter {
            plan,
            title,
            text: String::new(),
        }),
        MeshFormat::Ply => Box::new(PlyWriter {
            plan,
            title,
            buf: Vec::new(),
        }),
        MeshFormat::Stl => Box::new(StlWriter {
            plan,
            title,
            buf: Vec::new(),
        }),
        MeshFormat::Glb => Box::new(GlbWriter {
            plan,
            title,
            buf: Vec::new(),
            min: [f32::INFINITY; 3],
            max: [f32::NEG_INFINITY; 3],
        }),
    };
    write_atomic_piped(path, temp, |w| {
        let io = |e: io::Error| Error::io(path, e);
        writer.begin(w).map_err(io)?;
        struct Adapter<'w, 'x, V> {
            writer: &'x mut dyn FormatWriter<V>,
            w: &'w mut PipedWriter,
            path: &'x Path,
            format: MeshFormat,
        }
        impl<V: Vector> StitchSink<V> for Adapter<'_, '_, V> {
            fn needs(&self) -> Needs {
                self.writer.needs()
            }
            fn patch(&mut self, out: &PatchOut<'_, V>) -> Result<()> {
                let checks = self.writer.checks_finite();
                if !checks {
                    check_finite(self.format, self.path, out)?;
                }
                let finite = self
                    .writer
                    .patch(self.w, out)
                    .map_err(|e| Error::io(self.path, e))?;
                if !finite {
                    // The same rule names the value.
                    check_finite(self.format, self.path, out)?;
                    return Err(Error::Invalid(format!(
                        "{}: patch {} has a non-finite value",
                        self.path.display(),
                        out.patch
                    )));
                }
                Ok(())
            }
        }
        let faces = writer.face_section().and_then(|(offset, encode)| {
            let bytes = plan.triangles as u64 * encode.size() as u64;
            // The split writer starts at the first page boundary in the face section; the
            // stream writes the section's bytes before it.
            let split = offset.next_multiple_of(SPLIT_ALIGN);
            (bytes >= SPLIT_MIN_BYTES && split < offset + bytes)
                .then(|| w.split_at(split))
                .flatten()
                .map(|side| (offset, split, encode, side))
        });
        let Some((offset, split, encode, mut side)) = faces else {
            produce(&mut Adapter {
                writer: writer.as_mut(),
                w,
                path,
                format,
            })?;
            return writer.finish(w, progress).map_err(io);
        };
        // The faces go from a thread of their own, at their place in the file, while the
        // vertices stream.
        let cancel = std::sync::atomic::AtomicBool::new(false);
        let done = std::sync::atomic::AtomicUsize::new(0);
        std::thread::scope(|scope| -> Result<()> {
            /// Stops the face thread however the vertices end (an error, a panic).
            struct Cancel<'c>(&'c std::sync::atomic::AtomicBool);
            impl Drop for Cancel<'_> {
                fn drop(&mut self) {
                    self.0.store(true, std::sync::atomic::Ordering::Relaxed);
                }
            }
            let (cancel, done) = (&cancel, &done);
            let thread = std::thread::Builder::new()
                .name("g1tess-faces".into())
                .spawn_scoped(scope, move || -> io::Result<(u64, Vec<u8>)> {
                    let skip = split - offset;
                    write_face_bytes(plan, encode, skip, u64::MAX, &mut side, cancel, done)?;
                    side.finish_at()
                })
                .map_err(io)?;
            let guard = Cancel(cancel);
            produce(&mut Adapter {
                writer: writer.as_mut(),
                w,
                path,
                format,
            })?;
            let no = std::sync::atomic::AtomicUsize::new(0);
            let never = std::sync::atomic::AtomicBool::new(false);
            write_face_bytes(plan, encode, 0, split - offset, w, &never, &no).map_err(io)?;
            progress.start("writing faces", plan.patches() as u64);
            let mut shown = 0;
            while !thread.is_finished() {
                std::thread::sleep(std::time::Duration::from_millis(10));
                let now = done.load(std::sync::atomic::Ordering::Relaxed);
                progress.inc((now - shown) as u64);
                shown = now;
            }
            let (at, rest) = thread
                .join()
                .map_err(|_| {
                    Error::Invalid(format!("{}: the face thread stopped", path.display()))
                })?
                .map_err(io)?;
            progress.inc((plan.patches() - shown) as u64);
            drop(guard);
            w.write_at_end(at, rest);
            writer.after_faces(w).map_err(io)
        })
    })
}

/// The face section goes to a second writer ([`PipedWriter::split_at`]) from this page
/// boundary in it on.
const SPLIT_ALIGN: u64 = 4096;

/// Face sections smaller than this are written after the vertices, in the stream.
const SPLIT_MIN_BYTES: u64 = 1 << 20;

/// The encoding of a face section's triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FaceCodec {
    /// A count byte (3), then three little-endian i32 record ids.
    Ply,
    /// Three little-endian u32 record ids.
    Glb,
}

impl FaceCodec {
    /// Bytes of one triangle.
    fn size(self) -> usize {
        match self {
            FaceCodec::Ply => 13,
            FaceCodec::Glb => 12,
        }
    }

    /// Encodes a triangle into `b` ([`FaceCodec::size`] bytes).
    #[inline]
    fn put(self, t: [u32; 3], b: &mut [u8]) {
        match self {
            FaceCodec::Ply => {
                b[0] = 3;
                for (k, i) in t.into_iter().enumerate() {
                    b[1 + 4 * k..5 + 4 * k].copy_from_slice(&(i as i32).to_le_bytes());
                }
            }
            FaceCodec::Glb => {
                for (k, i) in t.into_iter().enumerate() {
                    b[4 * k..4 * k + 4].copy_from_slice(&i.to_le_bytes());
                }
            }
        }
    }

    /// Appends the triangles' bytes to `buf`.
    fn encode(self, tris: &[[u32; 3]], buf: &mut Vec<u8>) {
        let size = self.size();
        for &t in tris {
            let mut b = [0u8; 13];
            self.put(t, &mut b[..size]);
            buf.extend_from_slice(&b[..size]);
        }
    }
}

/// Most bytes [`put_each`] encodes per item.
const MAX_ITEM: usize = 64;

/// Writes `size` bytes per item (at most [`MAX_ITEM`]), encoded by `enc` straight into
/// the writer's blocks (an item across two blocks goes through a copy).
fn put_each<T>(
    w: &mut PipedWriter,
    items: &[T],
    size: usize,
    mut enc: impl FnMut(&T, &mut [u8]),
) -> io::Result<()> {
    let mut i = 0;
    while i < items.len() {
        let spare = w.spare()?;
        let fit = spare.len() / size;
        let k = fit.min(items.len() - i);
        for (item, b) in items[i..i + k].iter().zip(spare.chunks_exact_mut(size)) {
            enc(item, b);
        }
        w.commit(k * size);
        i += k;
        if i < items.len() && k == fit {
            let mut b = [0u8; MAX_ITEM];
            enc(&items[i], &mut b[..size]);
            w.write_all(&b[..size])?;
            i += 1;
        }
    }
    Ok(())
}

/// Writes bytes `skip..skip + take` of the face section (every patch's triangles, record
/// ids, in order, encoded by `codec`) to `w`, counting finished patches in `done`; stops
/// early (Ok) once `cancel` is set.
fn write_face_bytes(
    plan: &StitchPlan,
    codec: FaceCodec,
    skip: u64,
    take: u64,
    w: &mut PipedWriter,
    cancel: &std::sync::atomic::AtomicBool,
    done: &std::sync::atomic::AtomicUsize,
) -> io::Result<()> {
    use std::sync::atomic::Ordering::Relaxed;
    let grid = grid_triangles(plan.level);
    let mut scratch = (Vec::new(), Vec::new());
    let (mut ids, mut bytes) = (Vec::new(), Vec::new());
    let size = codec.size() as u64;
    let end = skip.saturating_add(take);
    let mut at = 0u64;
    for p in 0..plan.patches() {
        if at >= end || cancel.load(Relaxed) {
            break;
        }
        ids.clear();
        plan.patch_triangles(p, &grid, &mut scratch, &mut ids);
        let next = at + ids.len() as u64 * size;
        if at >= skip && next <= end {
            // The whole patch, straight into the blocks.
            put_each(w, &ids, size as usize, |&t, b| codec.put(t, b))?;
        } else if next > skip {
            bytes.clear();
            codec.encode(&ids, &mut bytes);
            let from = skip.saturating_sub(at) as usize;
            let to = (end.min(next) - at) as usize;
            w.write_all(&bytes[from..to])?;
        }
        at = next;
        done.store(p + 1, Relaxed);
    }
    Ok(())
}

/// Bytes of OBJ text held before they go to the file.
pub const TEXT_FLUSH: usize = 1 << 20;

/// Patches whose faces PLY and glTF encode per parallel batch: 256, fewer at high levels
/// so that a batch holds about 2^20 triangles (a few MiB at level 32, bounded at any level).
pub fn face_batch(level: u32) -> usize {
    let per = (level as usize).saturating_mul(level as usize).max(1);
    ((1usize << 20) / per).clamp(1, 256)
}

/// Fails when a value of `out` that `format` writes is not finite in the precision it is
/// written in (f32 for the binary formats; the samples' own for OBJ), naming the patch.
fn check_finite<V: Vector>(format: MeshFormat, path: &Path, out: &PatchOut<'_, V>) -> Result<()> {
    let written = |v: V| -> bool {
        match format {
            MeshFormat::Obj => v.to_dvec3().is_finite(),
            _ => v.to_f32().iter().all(|x| x.is_finite()),
        }
    };
    let fail = |what: &str, v: V| {
        let why = if V::NAME == "f32" || v.to_dvec3().is_finite() {
            "coordinates too large for f32"
        } else {
            "the evaluation overflowed"
        };
        Err(Error::Invalid(format!(
            "{}: patch {} (input triangle {}) has a non-finite {what} ({why})",
            path.display(),
            out.patch,
            out.patch + 1
        )))
    };
    // The common case first, without a branch per value (this runs on the thread that
    // feeds the file, for every sample); only then is the first offender looked for.
    let obj = format == MeshFormat::Obj;
    if all_finite(out.new_positions.iter().copied(), obj)
        && all_finite(out.grid_positions.iter().copied(), obj)
        && all_finite(out.new_records.iter().map(|r| r.position), obj)
        && (format == MeshFormat::Stl || all_finite(out.new_records.iter().map(|r| r.normal), obj))
    {
        return Ok(());
    }
    let positions = out
        .new_positions
        .iter()
        .chain(out.grid_positions)
        .chain(out.new_records.iter().map(|r| &r.position));
    for &p in positions {
        if !written(p) {
            return fail("position", p);
        }
    }
    if format != MeshFormat::Stl {
        for r in out.new_records {
            if !written(r.normal) {
                return fail("normal", r.normal);
            }
        }
    }
    Ok(())
}

/// Whether every value is finite as written: in its own precision for OBJ (`obj`), in f32
/// otherwise ([`check_finite`]'s rule), with no early exit.
#[inline]
fn all_finite<V: Vector>(values: impl Iterator<Item = V>, obj: bool) -> bool {
    if obj {
        values.fold(true, |ok, v| ok & v.to_dvec3().is_finite())
    } else {
        values.fold(true, |ok, v| {
            ok & v.to_f32().iter().fold(true, |o, x| o & x.is_finite())
        })
    }
}

/// Writes every patch's triangles (record ids), in order, each patch encoded by `codec`;
/// batches of patches are encoded in parallel (rayon), then written in order. Reports the
/// phase "writing faces" to `progress`.
fn write_triangles(
    plan: &StitchPlan,
    progress: &dyn Progress,
    w: &mut PipedWriter,
    codec: FaceCodec,
) -> io::Result<()> {
    let batch = face_batch(plan.level);
    struct Slot {
        bytes: Vec<u8>,
        scratch: (Vec<u32>, Vec<u32>),
        tris: Vec<[u32; 3]>,
    }
    let grid = grid_triangles(plan.level);
    let patches = plan.patches();
    let mut slots: Vec<Slot> = (0..batch.min(patches))
        .map(|_| Slot {
            bytes: Vec::new(),
            scratch: (Vec::new(), Vec::new()),
            tris: Vec::with_capacity(grid.len()),
        })
        .collect();
    progress.start("writing faces", patches as u64);
    let mut start = 0;
    while start < patches {
        let len = batch.min(patches - start);
        slots[..len]
            .par_iter_mut()
            .enumerate()
            .for_each(|(j, slot)| {
                slot.tris.clear();
                plan.patch_triangles(start + j, &grid, &mut slot.scratch, &mut slot.tris);
                slot.bytes.clear();
                codec.encode(&slot.tris, &mut slot.bytes);
            });
        for slot in &slots[..len] {
            w.write_all(&slot.bytes)?;
        }
        progress.inc(len as u64);
        start += len;
    }
    Ok(())
}

/// Appends a vertex record's position and normal as six f32, little-endian.
#[inline]
fn push_record<V: Vector>(buf: &mut Vec<u8>, position: V, normal: V) {
    let mut b = [0u8; 24];
    for (k, x) in position
        .to_f32()
        .into_iter()
        .chain(normal.to_f32())
        .enumerate()
    {
        b[4 * k..4 * k + 4].copy_from_slice(&x.to_le_bytes());
    }
    buf.extend_from_slice(&b);
}

/// Bytes of a vertex record's attributes in PLY (f32 texture coordinates, byte colours)
/// or glTF (f32 texture coordinates and colours).
fn attribute_bytes(plan: &StitchPlan, byte_colors: bool) -> usize {
    let channels = if plan.colors_have_alpha() { 4 } else { 3 };
    let color = if byte_colors { channels } else { 4 * channels };
    8 * plan.has_uvs() as usize + color * plan.has_colors() as usize
}

/// Appends a record's attributes as the plan has them: texture coordinates (two f32), then
/// the colour (three or four channels, bytes or f32), little-endian.
fn push_attributes(buf: &mut Vec<u8>, plan: &StitchPlan, a: &RecordAttributes, byte_colors: bool) {
    if plan.has_uvs() {
        for x in a.uv {
            buf.extend_from_slice(&x.to_le_bytes());
        }
    }
    if plan.has_colors() {
        let channels = if plan.colors_have_alpha() { 4 } else { 3 };
        for &c in &a.color[..channels] {
            if byte_colors {
                buf.push((c.clamp(0.0, 1.0) * 255.0).round() as u8);
            } else {
                buf.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
}

/// Appends the f32 little-endian bytes of `v`.
#[inline]
fn push_f32s<V: Vector>(buf: &mut Vec<u8>, v: V) {
    for x in v.to_f32() {
        buf.extend_from_slice(&x.to_le_bytes());
    }
}

struct ObjWriter<'a> {
    plan: &'a StitchPlan,
    title: &'a str,
    text: String,
}

impl<V: Vector> FormatWriter<V> for ObjWriter<'_> {
    fn needs(&self) -> Needs {
        MeshFormat::Obj.needs()
    }

    fn begin(&mut self, w: &mut PipedWriter) -> io::Result<()> {
        writeln!(
            w,
            "# {}\n# stitched: {} positions (v), {} vertex normals (vn), {}{} triangles",
            comment_text(self.title),
            self.plan.positions,
            self.plan.records,
            if self.plan.has_uvs() {
                format!("{} texture coordinates (vt), ", self.plan.records)
            } else {
                String::new()
            },
            self.plan.triangles
        )
    }

    fn patch(&mut self, w: &mut PipedWriter, out: &PatchOut<'_, V>) -> io::Result<bool> {
        use std::fmt::Write as _;
        let t = &mut self.text;
        t.clear();
        // The text goes out every TEXT_FLUSH bytes: a patch at a high level holds no more.
        let flush = |t: &mut String, w: &mut PipedWriter| -> io::Result<()> {
            if t.len() >= TEXT_FLUSH {
                w.write_all(t.as_bytes())?;
                t.clear();
            }
            Ok(())
        };
        for p in out.new_positions {
            t.push('v');
            p.write_text(t);
            t.push('\n');
            flush(t, w)?;
        }
        for r in out.new_records {
            t.push_str("vn");
            r.normal.write_text(t);
            t.push('\n');
            flush(t, w)?;
        }
        let uvs = self.plan.has_uvs();
        if uvs {
            for a in out.new_attributes {
                // The f32 values exactly (see `Vector::write_text`).
                let _ = writeln!(t, "vt {:?} {:?}", f64::from(a.uv[0]), f64::from(a.uv[1]));
                flush(t, w)?;
            }
        }
        for (r, p) in out.triangles.iter().zip(out.position_triangles) {
            flush(t, w)?;
            if uvs {
                let _ = writeln!(
                    t,
                    "f {}/{r0}/{r0} {}/{r1}/{r1} {}/{r2}/{r2}",
                    p[0] + 1,
                    p[1] + 1,
                    p[2] + 1,
                    r0 = r[0] + 1,
                    r1 = r[1] + 1,
                    r2 = r[2] + 1
                );
                continue;
            }
            let _ = writeln!(
                t,
                "f {}//{} {}//{} {}//{}",
                p[0] + 1,
                r[0] + 1,
                p[1] + 1,
                r[1] + 1,
                p[2] + 1,
                r[2] + 1
            );
        }
        w.write_all(t.as_bytes()).map(|_| true)
    }

    fn finish(&mut self, _: &mut PipedWriter, _: &dyn Progress) -> io::Result<()> {
        Ok(())
    }
}

/// `title` for a comment line of a text format: control characters (a line break would
/// end the comment, and what followed would be read as data) replaced by `?`.
fn comment_text(title: &str) -> std::borrow::Cow<'_, str> {
    if title.chars().any(char::is_control) {
        title
            .chars()
            .map(|c| if c.is_control() { '?' } else { c })
            .collect::<String>()
            .into()
    } else {
        title.into()
    }
}

/// The header of a binary PLY file of `plan` (ASCII lines; `title` in the comment, other
/// characters than printable ASCII and space replaced by `?`).
fn ply_header(plan: &StitchPlan, title: &str) -> String {
    let title: String = title
        .chars()
        .map(|c| {
            if c.is_ascii_graphic() || c == ' ' {
                c
            } else {
                '?'
            }
        })
        .collect();
    let mut extra = String::new();
    if plan.has_uvs() {
        extra.push_str("property float s\nproperty float t\n");
    }
    if plan.has_colors() {
        extra.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
        if plan.colors_have_alpha() {
            extra.push_str("property uchar alpha\n");
        }
    }
    format!(
        "ply\nformat binary_little_endian 1.0\ncomment {title}\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n{extra}\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        plan.records, plan.triangles
    )
}

/// Bytes of the binary PLY file [`write_stitched`] writes for `plan` with `title`: the
/// header, a record per vertex (six f32, then the attributes), 13 bytes per triangle.
pub fn ply_file_bytes(plan: &StitchPlan, title: &str) -> u64 {
    ply_header(plan, title).len() as u64
        + plan.records as u64 * (24 + attribute_bytes(plan, true) as u64)
        + plan.triangles as u64 * 13
}

struct PlyWriter<'a> {
    plan: &'a StitchPlan,
    title: &'a str,
    buf: Vec<u8>,
}

impl<V: Vector> FormatWriter<V> for PlyWriter<'_> {
    fn needs(&self) -> Needs {
        MeshFormat::Ply.needs()
    }

    fn begin(&mut self, w: &mut PipedWriter) -> io::Result<()> {
        w.write_all(ply_header(self.plan, self.title).as_bytes())
    }

    fn checks_finite(&self) -> bool {
        !self.plan.has_attributes()
    }

    fn patch(&mut self, w: &mut PipedWriter, out: &PatchOut<'_, V>) -> io::Result<bool> {
        if !self.plan.has_attributes() {
            // Straight into the file's blocks, checking as it goes.
            let mut finite = true;
            put_each(w, out.new_records, 24, |r, b| {
                let (p, n) = (r.position.to_f32(), r.normal.to_f32());
                for k in 0..3 {
                    b[4 * k..4 * k + 4].copy_from_slice(&p[k].to_le_bytes());
                    b[12 + 4 * k..16 + 4 * k].copy_from_slice(&n[k].to_le_bytes());
                }
                finite &= p.iter().chain(&n).fold(true, |ok, x| ok & x.is_finite());
            })?;
            return Ok(finite);
        }
        self.buf.clear();
        for (r, a) in out.new_records.iter().zip(out.new_attributes) {
            push_record(&mut self.buf, r.position, r.normal);
            push_attributes(&mut self.buf, self.plan, a, true);
        }
        w.write_all(&self.buf).map(|_| true)
    }

    fn finish(&mut self, w: &mut PipedWriter, progress: &dyn Progress) -> io::Result<()> {
        write_triangles(self.plan, progress, w, FaceCodec::Ply)
    }

    fn face_section(&self) -> Option<(u64, FaceCodec)> {
        let vertices = self.plan.records as u64 * (24 + attribute_bytes(self.plan, true) as u64);
        Some((
            ply_header(self.plan, self.title).len() as u64 + vertices,
            FaceCodec::Ply,
        ))
    }
}

struct StlWriter<'a> {
    plan: &'a StitchPlan,
    title: &'a str,
    buf: Vec<u8>,
}

impl<V: Vector> FormatWriter<V> for StlWriter<'_> {
    fn needs(&self) -> Needs {
        MeshFormat::Stl.needs()
    }

    fn begin(&mut self, w: &mut PipedWriter) -> io::Result<()> {
        // The header must not start with "solid" (ASCII STL).
        let mut header = [b' '; 80];
        let text = format!("binary STL from {}", self.title);
        let n = text.len().min(80);
        header[..n].copy_from_slice(&text.as_bytes()[..n]);
        w.write_all(&header)?;
        w.write_all(&(self.plan.triangles as u32).to_le_bytes())
    }

    fn patch(&mut self, w: &mut PipedWriter, out: &PatchOut<'_, V>) -> io::Result<bool> {
        self.buf.clear();
        for t in out.grid_triangles {
            let p = t.map(|i| out.grid_positions[i as usize]);
            // The flat normal from the written positions, computed in f64 and rounded once.
            let d = p.map(Vector::to_dvec3);
            let n = (d[1] - d[0]).cross(d[2] - d[0]).normalize_or_zero();
            push_f32s(&mut self.buf, n);
            for q in p {
                push_f32s(&mut self.buf, q);
            }
            self.buf.extend_from_slice(&[0, 0]);
        }
        w.write_all(&self.buf).map(|_| true)
    }

    fn finish(&mut self, _: &mut PipedWriter, _: &dyn Progress) -> io::Result<()> {
        Ok(())
    }
}

/// Byte sizes of a glTF binary for a plan.
struct GlbLayout {
    /// The JSON chunk, padded with spaces.
    json_bytes: u64,
    vertex_bytes: u64,
    index_bytes: u64,
    total: u64,
}

/// Room reserved for the JSON chunk beyond the placeholder's length: the bounds' six
/// numbers may print longer than the placeholders.
const GLB_JSON_SLACK: usize = 256;

fn glb_layout(plan: &StitchPlan, title: &str) -> GlbLayout {
    let vertex_bytes = plan.records as u64 * glb_stride(plan);
    let index_bytes = plan.triangles as u64 * 12;
    let placeholder = glb_json(plan, title, [-f32::MAX; 3], [-f32::MAX; 3]).len();
    let json_bytes = (placeholder + GLB_JSON_SLACK).next_multiple_of(4) as u64;
    GlbLayout {
        json_bytes,
        vertex_bytes,
        index_bytes,
        total: 12 + 8 + json_bytes + 8 + vertex_bytes + index_bytes,
    }
}

/// Bytes of one interleaved glTF vertex: position, normal, then the attributes.
fn glb_stride(plan: &StitchPlan) -> u64 {
    24 + attribute_bytes(plan, false) as u64
}

fn glb_json(plan: &StitchPlan, title: &str, min: [f32; 3], max: [f32; 3]) -> String {
    let r = plan.records as u64;
    let t = plan.triangles as u64;
    let stride = glb_stride(plan);
    let mut json = serde_json::json!({
        "asset": {"version": "2.0", "generator": "g1tess"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{
            "name": title,
            "primitives": [{
                "attributes": {"POSITION": 0, "NORMAL": 1},
                "indices": 2,
                "mode": 4
            }]
        }],
        "buffers": [{"byteLength": r * stride + t * 12}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": r * stride, "byteStride": stride, "target": 34962},
            {"buffer": 0, "byteOffset": r * stride, "byteLength": t * 12, "target": 34963}
        ],
        "accessors": [
            {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": r,
             "type": "VEC3", "min": min, "max": max},
            {"bufferView": 0, "byteOffset": 12, "componentType": 5126, "count": r,
             "type": "VEC3"},
            {"bufferView": 1, "byteOffset": 0, "componentType": 5125, "count": 3 * t,
             "type": "SCALAR"}
        ]
    });
    // Attributes follow the normal in each vertex, as accessors 3 and on.
    let mut offset = 24;
    let mut add = |name: &str, kind: &str, bytes: u64| {
        let accessors = json["accessors"].as_array_mut().expect("accessors");
        let id = accessors.len();
        accessors.push(serde_json::json!({"bufferView": 0, "byteOffset": offset,
            "componentType": 5126, "count": r, "type": kind}));
        json["meshes"][0]["primitives"][0]["attributes"][name] = id.into();
        offset += bytes;
    };
    if plan.has_uvs() {
        add("TEXCOORD_0", "VEC2", 8);
    }
    if plan.has_colors() {
        if plan.colors_have_alpha() {
            add("COLOR_0", "VEC4", 16);
        } else {
            add("COLOR_0", "VEC3", 12);
        }
    }
    json.to_string()
}

struct GlbWriter<'a> {
    plan: &'a StitchPlan,
    title: &'a str,
    buf: Vec<u8>,
    min: [f32; 3],
    max: [f32; 3],
}

impl<V: Vector> FormatWriter<V> for GlbWriter<'_> {
    fn needs(&self) -> Needs {
        MeshFormat::Glb.needs()
    }

    fn begin(&mut self, w: &mut PipedWriter) -> io::Result<()> {
        let layout = glb_layout(self.plan, self.title);
        if layout.total > u32::MAX as u64 {
            return Err(io::Error::other("glTF binary over 4 GiB"));
        }
        w.write_all(b"glTF")?;
        w.write_all(&2u32.to_le_bytes())?;
        w.write_all(&(layout.total as u32).to_le_bytes())?;
        w.write_all(&(layout.json_bytes as u32).to_le_bytes())?;
        w.write_all(b"JSON")?;
        w.write_all(&vec![b' '; layout.json_bytes as usize])?;
        let bin = (layout.vertex_bytes + layout.index_bytes) as u32;
        w.write_all(&bin.to_le_bytes())?;
        w.write_all(b"BIN\0")
    }

    fn patch(&mut self, w: &mut PipedWriter, out: &PatchOut<'_, V>) -> io::Result<bool> {
        self.buf.clear();
        for (j, r) in out.new_records.iter().enumerate() {
            let p = r.position.to_f32();
            for (k, x) in p.into_iter().enumerate() {
                self.min[k] = self.min[k].min(x);
                self.max[k] = self.max[k].max(x);
            }
            push_record(&mut self.buf, r.position, r.normal);
            if let Some(a) = out.new_attributes.get(j) {
                push_attributes(&mut self.buf, self.plan, a, false);
            }
        }
        w.write_all(&self.buf).map(|_| true)
    }

    fn finish(&mut self, w: &mut PipedWriter, progress: &dyn Progress) -> io::Result<()> {
        write_triangles(self.plan, progress, w, FaceCodec::Glb)?;
        FormatWriter::<V>::after_faces(self, w)
    }

    fn face_section(&self) -> Option<(u64, FaceCodec)> {
        let layout = glb_layout(self.plan, self.title);
        Some((
            12 + 8 + layout.json_bytes + 8 + layout.vertex_bytes,
            FaceCodec::Glb,
        ))
    }

    fn after_faces(&mut self, w: &mut PipedWriter) -> io::Result<()> {
        let json = glb_json(self.plan, self.title, self.min, self.max);
        if json.len() as u64 > glb_layout(self.plan, self.title).json_bytes {
            return Err(io::Error::other("glTF JSON outgrew its reserved chunk"));
        }
        w.write_at_end(20, json.into_bytes());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{write_stitched, MeshFormat};
    use crate::eval::cpu::CpuEvaluator;
    use crate::io::atomic::TempFiles;
    use crate::progress::NoProgress;
    use crate::tess::stitch::{stitch_into, StitchPlan};
    use crate::{PatchTable, Scheme, SchemeOptions};

    /// A library caller's title with line breaks and an escape stays in the OBJ's comment:
    /// the icosahedron at level 1 has exactly its 12 vertex and 20 face lines, none forged,
    /// and the comment's control characters are `?`.
    #[test]
    fn an_obj_title_cannot_forge_lines() {
        let mesh = crate::tests::common::load("icosphere:0");
        let plan = StitchPlan::new(&mesh, &mesh.adjacency(), 1).unwrap();
        let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
        let path = crate::tests::common::tmp_dir("writers").join("title.obj");
        write_stitched::<[f32; 3]>(
            &path,
            &TempFiles::default(),
            MeshFormat::Obj,
            &plan,
            "x\nv 9 9 9\r\nf 1 1 1\u{1b}[31m",
            &NoProgress,
            &mut |sink| {
                stitch_into(&plan, &table, &CpuEvaluator::default(), sink, &NoProgress)?;
                Ok(())
            },
        )
        .unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.lines().filter(|l| l.starts_with("v ")).count(), 12);
        assert_eq!(text.lines().filter(|l| l.starts_with("f ")).count(), 20);
        assert_eq!(text.lines().next(), Some("# x?v 9 9 9??f 1 1 1?[31m"));
    }
}
