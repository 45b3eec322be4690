//! Wavefront OBJ input.
//!
//! A parser of its own rather than `tobj`: `tobj` silently invents a normal (the previous
//! corner's) for face corners that give none when other faces do, and its errors carry no
//! line number. Here every defect names the file and the line, and a corner without a
//! normal gets an estimated one.
//!
//! The file is read in chunks of whole statements, each split into blocks parsed in parallel.
//! A block does not know how many vertices came before it, so relative (negative) indices
//! are kept relative to the block and resolved when the blocks are joined in order. Any
//! defect sends the whole file through the same parser once more, sequentially with exact
//! counts, which reports the first defect of the file with its line: errors cost a second
//! pass, valid files do not. Plain `v`, `vn` and `f` statements (what writers emit) are
//! read in one pass over their bytes ([`Block::fast`]); anything else, defects included,
//! goes through the general path, so results and messages do not depend on the shortcut.

use std::path::Path;

use glam::DVec3;
use rayon::prelude::*;

use super::text::{self, echo, Tokens};
use super::{normals, weld, CornerAttributes, LoadOptions, LoadReport, Mesh, Source};
use crate::{Error, Result};

/// Marks a corner without a normal.
const NONE: i64 = i64::MAX;
/// Offset of an index relative to its block (stored as `r - REL`, always below `-REL / 2`).
const REL: i64 = 1 << 40;

/// Counts of `v`, `vt` and `vn` records.
type Counts = [usize; 3];
const V: usize = 0;
const VT: usize = 1;
const VN: usize = 2;
const WHAT: [&str; 3] = ["vertex", "texture coordinate", "normal"];
const PLURAL: [&str; 3] = ["vertices", "texture coordinates", "normals"];

/// What one block of statements holds.
#[derive(Default)]
struct Block {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    texcoords: Vec<[f32; 2]>,
    /// Position index of each triangle corner: absolute (>= 0) or relative to the block
    /// (`r - REL`).
    tris: Vec<[i64; 3]>,
    /// Normal index of each corner, as `tris` or [`NONE`]; empty until a face gives one
    /// (files without normals pay nothing), then one entry per triangle.
    tri_normals: Vec<[i64; 3]>,
    /// Texture coordinate index of each corner, as `tris`; empty until a face gives one
    /// (files without `vt` indices pay nothing), then one entry per triangle.
    tri_uvs: Vec<[i64; 3]>,
    polygons: usize,
    /// Largest absolute index of each kind (-1 if none).
    max_abs: [i64; 3],
    /// Smallest relative index of each kind (0 if none): it must not reach before the file.
    min_rel: [i64; 3],
}

/// How a block is parsed.
#[derive(Clone, Copy)]
struct Mode {
    /// Counts before the block when known (sequential pass): indices resolve exactly.
    base: Option<Counts>,
    /// The file's final counts, when a sequential pass checks forward references.
    totals: Option<Counts>,
    /// Whether plain statements may take [`Block::fast`] (not while a sequential pass
    /// checks forward references: that needs [`Block::index`]).
    fast: bool,
}

/// Outcome of a pass: a parallel pass only learns that something is wrong.
enum Fail {
    Error(Error),
    Retry,
}

impl From<Error> for Fail {
    fn from(e: Error) -> Fail {
        Fail::Error(e)
    }
}

impl Block {
    fn new() -> Block {
        Block {
            max_abs: [-1; 3],
            ..Default::default()
        }
    }

    fn count(&self, kind: usize) -> usize {
        match kind {
            V => self.positions.len(),
            VT => self.texcoords.len(),
            _ => self.normals.len(),
        }
    }

    /// Parses one statement.
    fn statement(&mut self, path: &Path, mode: Mode, line: usize, stmt: &str) -> Result<()> {
        if mode.fast && self.fast(stmt) {
            return Ok(());
        }
        let err = |msg: String| Error::parse(path, line, msg);
        let mut tok = Tokens::new(stmt);
        let Some(kw) = tok.next() else {
            return Ok(());
        };
        match kw.as_bytes() {
            b"v" => {
                let p = numbers::<3>(tok.clone(), "vertex", &err)?;
                if let Some(k) = p.iter().position(|x| x.abs() > normals::MAX_COORD) {
                    let s = tok.nth(k).unwrap_or_default();
                    return Err(err(format!(
                        "vertex: coordinate '{}' above {:e} in magnitude (products of such \
                         coordinates overflow)",
                        echo(s),
                        normals::MAX_COORD
                    )));
                }
                self.positions.push(DVec3::from_array(p));
            }
            b"vn" => {
                let n = DVec3::from_array(numbers::<3>(tok, "normal", &err)?);
                let n = normals::unit(n).ok_or_else(|| err("zero-length normal".into()))?;
                self.normals.push(n);
            }
            b"vt" => {
                let [u] = numbers::<1>(tok.clone(), "texture coordinate", &err)?;
                let v = match tok.nth(1) {
                    None => 0.0,
                    Some(t) => match text::parse_f64(t) {
                        Some(v) if v.is_finite() => v,
                        _ => {
                            return Err(err(format!(
                                "texture coordinate: '{}' is not a finite number",
                                echo(t)
                            )))
                        }
                    },
                };
                let uv = [u as f32, v as f32];
                if !uv.iter().all(|x| x.is_finite()) {
                    return Err(err("texture coordinate beyond the f32 range".into()));
                }
                self.texcoords.push(uv);
            }
            b"f" => self.face(mode, tok, &err)?,
            _ => {}
        }
        Ok(())
    }

    fn face(&mut self, mode: Mode, tok: Tokens, err: &dyn Fn(String) -> Error) -> Result<()> {
        let mut n = 0usize;
        let mut first = [NONE; 3];
        let mut prev = [NONE; 3];
        for c in tok {
            let malformed = || err(format!("malformed face corner '{}'", echo(c)));
            let mut parts = [""; 3];
            let (mut np, mut start) = (0, 0);
            for (i, &b) in c.as_bytes().iter().enumerate() {
                if b == b'/' {
                    if np == 2 {
                        return Err(malformed());
                    }
                    parts[np] = &c[start..i];
                    np += 1;
                    start = i + 1;
                }
            }
            parts[np] = &c[start..];
            if parts[0].is_empty() {
                return Err(malformed());
            }
            let mut idx = [NONE; 3];
            for (slot, s) in parts.into_iter().enumerate() {
                if !s.is_empty() {
                    idx[slot] = self.index(mode, c, s, slot, err)?;
                }
            }
            let cur = [idx[V], idx[VN], idx[VT]];
            match n {
                0 => first = cur,
                1 => {}
                _ => self.push_triangle(first, prev, cur),
            }
            prev = cur;
            n += 1;
        }
        if n < 3 {
            return Err(err(format!("face needs at least 3 corners, found {n}")));
        }
        self.polygons += usize::from(n > 3);
        Ok(())
    }

    /// Appends the triangle of corners `a`, `b`, `c`, each (position, normal, texture
    /// coordinate) index.
    #[inline]
    fn push_triangle(&mut self, a: [i64; 3], b: [i64; 3], c: [i64; 3]) {
        self.tris.push([a[0], b[0], c[0]]);
        for (list, k) in [(&mut self.tri_normals, 1), (&mut self.tri_uvs, 2)] {
            let corners = [a[k], b[k], c[k]];
            if !list.is_empty() || corners != [NONE; 3] {
                list.resize(self.tris.len() - 1, [NONE; 3]);
                list.push(corners);
            }
        }
    }

    /// The common statements in one pass over their bytes: `v` and `vn` with exactly three
    /// plain numbers, `f` with up to [`FAST_CORNERS`] corners of positive indices, blanks
    /// between tokens and nothing after them. Returns false, having changed nothing, for
    /// anything else (another keyword, a comment, a value out of range, a defect), which
    /// [`Block::statement`]'s general path then reads: results and errors are the same
    /// whichever path reads a statement.
    #[inline]
    fn fast(&mut self, stmt: &str) -> bool {
        match stmt.as_bytes() {
            [b'v', b' ' | b'\t', ..] => {
                let Some(p) = text::plain_numbers::<3>(&stmt[2..]) else {
                    return false;
                };
                if p.iter().any(|x| x.abs() > normals::MAX_COORD) {
                    return false;
                }
                self.positions.push(DVec3::from_array(p));
            }
            [b'v', b'n', b' ' | b'\t', ..] => {
                let Some(n) = text::plain_numbers::<3>(&stmt[3..])
                    .and_then(|n| normals::unit(DVec3::from_array(n)))
                else {
                    return false;
                };
                self.normals.push(n);
            }
            [b'f', b' ' | b'\t', rest @ ..] => {
                let mut corners = [[NONE; 3]; FAST_CORNERS];
                let mut n = 0;
                let mut i = 0;
                loop {
                    while i < rest.len() && text::is_blank(rest[i]) {
                        i += 1;
                    }
                    if i == rest.len() {
                        break;
                    }
                    if n == FAST_CORNERS {
                        return false;
                    }
                    // v, v/vt, v//vn or v/vt/vn, each a positive index.
                    let mut idx = [NONE; 3];
                    for slot in [V, VT, VN] {
                        let start = i;
                        let mut k = 0i64;
                        while i < rest.len() && rest[i].is_ascii_digit() && i - start < 18 {
                            k = k * 10 + i64::from(rest[i] - b'0');
                            i += 1;
                        }
                        if i > start {
                            if k == 0 {
                                return false;
                            }
                            idx[slot] = k - 1;
                        } else if slot == V {
                            return false;
                        }
                        if slot == VN || i == rest.len() || rest[i] != b'/' {
                            break;
                        }
                        i += 1;
                    }
                    if i < rest.len() && !text::is_blank(rest[i]) {
                        return false;
                    }
                    if idx[VT] == NONE && idx[VN] == NONE && i > 0 && rest[i - 1] == b'/' {
                        return false;
                    }
                    corners[n] = [idx[V], idx[VN], idx[VT]];
                    n += 1;
                }
                if n < 3 {
                    return false;
                }
                for c in &corners[..n] {
                    // (position, normal, texture coordinate) into max_abs's V, VN, VT.
                    for (e, slot) in c.iter().zip([V, VN, VT]) {
                        if *e != NONE {
                            self.max_abs[slot] = self.max_abs[slot].max(*e);
                        }
                    }
                }
                for k in 2..n {
                    self.push_triangle(corners[0], corners[k - 1], corners[k]);
                }
                self.polygons += usize::from(n > 3);
            }
            _ => return false,
        }
        true
    }

    /// Resolves index text `s` of kind `slot` in corner `c`.
    fn index(
        &mut self,
        mode: Mode,
        c: &str,
        s: &str,
        slot: usize,
        err: &dyn Fn(String) -> Error,
    ) -> Result<i64> {
        let k = text::parse_i64(s).ok_or_else(|| {
            err(format!(
                "face corner '{}': '{}' is not an index",
                echo(c),
                echo(s)
            ))
        })?;
        let what = WHAT[slot];
        if k > 0 {
            let abs = k - 1;
            if let Some(total) = mode.totals.map(|t| t[slot]) {
                if abs as u64 >= total as u64 {
                    return Err(err(format!(
                        "face corner '{}': {what} index {k} out of range (the file has \
                         {total} {})",
                        echo(c),
                        PLURAL[slot]
                    )));
                }
            }
            self.max_abs[slot] = self.max_abs[slot].max(abs);
            return Ok(abs);
        }
        if k == 0 {
            return Err(err(format!(
                "face corner '{}': index 0 (OBJ counts from 1)",
                echo(c)
            )));
        }
        let local = self.count(slot);
        match mode.base {
            Some(base) => {
                let have = base[slot] + local;
                if k.unsigned_abs() > have as u64 {
                    return Err(err(format!(
                        "face corner '{}': {what} index {k} out of range (only {have} {} so far)",
                        echo(c),
                        PLURAL[slot]
                    )));
                }
                Ok(have as i64 + k)
            }
            None => {
                // Within the range of relative values (|k| below 2^39): larger ones are
                // out of range anyway and are reported by the sequential pass.
                let r = local as i64 + k.max(-(REL / 2));
                self.min_rel[slot] = self.min_rel[slot].min(r);
                Ok(r - REL)
            }
        }
    }
}

/// Corners a face may have for [`Block::fast`].
const FAST_CORNERS: usize = 8;

/// `N` numbers from the statement's tokens (more are ignored), finite.
fn numbers<const N: usize>(
    mut tok: Tokens,
    what: &str,
    err: &dyn Fn(String) -> Error,
) -> Result<[f64; N]> {
    let mut s = [""; N];
    for (k, slot) in s.iter_mut().enumerate() {
        *slot = tok
            .next()
            .ok_or_else(|| err(format!("{what} needs {N} numbers, found {k}")))?;
    }
    let mut out = [0.0; N];
    for (x, s) in out.iter_mut().zip(s) {
        *x = text::parse_f64(s)
            .ok_or_else(|| err(format!("{what}: '{}' is not a number", echo(s))))?;
        if !x.is_finite() {
            return Err(err(format!("{what}: non-finite coordinate '{}'", echo(s))));
        }
    }
    Ok(out)
}

/// Everything the file holds, joined.
struct Raw {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    texcoords: Vec<[f32; 2]>,
    tris: Vec<[u32; 3]>,
    /// Normal index of each corner (`u32::MAX` for none), empty when no face gives one.
    tri_normals: Vec<[u32; 3]>,
    /// Texture coordinate index of each corner (`u32::MAX` for none), empty when no face
    /// gives one.
    tri_uvs: Vec<[u32; 3]>,
    polygons: usize,
    max_abs: [i64; 3],
}

impl Raw {
    fn counts(&self) -> Counts {
        [
            self.positions.len(),
            self.texcoords.len(),
            self.normals.len(),
        ]
    }

    /// Appends a block parsed after everything so far; `Retry` when one of its relative
    /// indices reaches before the start of the file.
    fn join(&mut self, b: Block) -> std::result::Result<(), Fail> {
        let base = self.counts();
        if (0..3).any(|k| (base[k] as i64) + b.min_rel[k] < 0) {
            return Err(Fail::Retry);
        }
        let resolve = |e: i64, base: usize| -> u32 {
            if e == NONE {
                u32::MAX
            } else if e < 0 {
                (e + REL + base as i64) as u32
            } else {
                e as u32
            }
        };
        let (done, more) = (self.tris.len(), b.tris.len());
        for (list, given, base) in [
            (&mut self.tri_normals, &b.tri_normals, base[VN]),
            (&mut self.tri_uvs, &b.tri_uvs, base[VT]),
        ] {
            if !given.is_empty() || !list.is_empty() {
                list.resize(done, [u32::MAX; 3]);
                list.extend(given.iter().map(|t| t.map(|e| resolve(e, base))));
                list.resize(done + more, [u32::MAX; 3]);
            }
        }
        self.tris
            .extend(b.tris.iter().map(|t| t.map(|e| resolve(e, base[V]))));
        self.positions.extend_from_slice(&b.positions);
        self.normals.extend_from_slice(&b.normals);
        self.texcoords.extend_from_slice(&b.texcoords);
        self.polygons += b.polygons;
        self.max_abs = [0, 1, 2].map(|a| self.max_abs[a].max(b.max_abs[a]));
        Ok(())
    }

    /// After the first chunk, reserves room for the whole file at the same density, so the
    /// arrays grow once instead of doubling past what they need.
    fn reserve_for(&mut self, read: usize, file_len: u64) {
        let scale = file_len as f64 / read.max(1) as f64 * 1.02;
        let more = |n: usize| ((n as f64 * scale) as usize).saturating_sub(n);
        self.positions.reserve(more(self.positions.len()));
        self.normals.reserve(more(self.normals.len()));
        self.tris.reserve(more(self.tris.len()));
        self.tri_normals.reserve(more(self.tri_normals.len()));
    }
}

/// One pass over the file: parallel (`totals` = None, any defect gives `Retry`) or
/// sequential (exact errors).
fn pass(src: Source<'_>, parallel: bool, totals: Option<Counts>) -> std::result::Result<Raw, Fail> {
    let path = src.path();
    let file_len = src.len()?;
    let mut raw = Raw {
        positions: Vec::new(),
        normals: Vec::new(),
        texcoords: Vec::new(),
        tris: Vec::new(),
        tri_normals: Vec::new(),
        tri_uvs: Vec::new(),
        polygons: 0,
        max_abs: [-1; 3],
    };
    let mut read = 0usize;
    let mut retry = false;
    let blocks = if parallel {
        2 * rayon::current_num_threads()
    } else {
        1
    };
    let done = text::for_each_chunk(src, |chunk, first_line| {
        let pieces = if chunk.len() < 1 << 16 {
            vec![chunk]
        } else {
            text::split(chunk, blocks)
        };
        let mut lines = 0;
        if parallel {
            let parsed: Vec<Option<(Block, usize)>> = pieces
                .par_iter()
                .map(|piece| {
                    let mode = Mode {
                        base: None,
                        totals: None,
                        fast: true,
                    };
                    let mut b = Block::new();
                    let text = std::str::from_utf8(piece).ok()?;
                    let n = text::statements(path, text, 0, true, |line, s| {
                        b.statement(path, mode, line, s)
                    })
                    .ok()?;
                    Some((b, n))
                })
                .collect();
            for p in parsed {
                match p.map(|(b, n)| raw.join(b).map(|()| n)) {
                    Some(Ok(n)) => lines += n,
                    _ => {
                        // Stop reading: the sequential pass starts over.
                        retry = true;
                        return Err(Error::Invalid(String::new()));
                    }
                }
            }
        } else {
            for piece in pieces {
                let text = text::utf8(path, piece, first_line + lines)?;
                let mode = Mode {
                    base: Some(raw.counts()),
                    totals,
                    fast: totals.is_none(),
                };
                let mut b = Block::new();
                lines += text::statements(path, text, first_line + lines, true, |line, s| {
                    b.statement(path, mode, line, s)
                })?;
                if raw.join(b).is_err() {
                    return Err(Error::Invalid(format!(
                        "{}: internal error: an index resolved before the file",
                        path.display()
                    )));
                }
            }
        }
        if read == 0 {
            raw.reserve_for(chunk.len(), file_len);
        }
        read += chunk.len();
        Ok(lines)
    });
    match (done, retry) {
        (_, true) => Err(Fail::Retry),
        (Err(e), false) => Err(Fail::Error(e)),
        (Ok(()), false) => Ok(raw),
    }
}

/// Reads a Wavefront OBJ file: polygons triangulated as fans, every face form (`v`,
/// `v/vt`, `v//vn`, `v/vt/vn`), negative (relative) indices, all objects and groups merged,
/// positions welded with [`weld`] (exact coordinates, `-0.0` equal to `0.0`), unused
/// vertices dropped, per-corner normals kept (renormalised), missing normals estimated with
/// `opts.weighting`. Lines may end in `\n`, `\r\n` or `\r`; a backslash at the end of a line
/// continues the statement; a UTF-8 byte-order mark is skipped.
pub fn load_obj(src: Source<'_>, opts: &LoadOptions) -> Result<Mesh> {
    let path = src.path();
    let sequential = |totals| match pass(src, false, totals) {
        Ok(raw) => Ok(raw),
        Err(Fail::Error(e)) => Err(e),
        Err(Fail::Retry) => Err(Error::Invalid(format!(
            "{}: internal error: the sequential pass asked for another",
            path.display()
        ))),
    };
    let raw = match pass(src, true, None) {
        Ok(raw) => raw,
        Err(Fail::Error(e)) => return Err(e),
        Err(Fail::Retry) => sequential(None)?,
    };
    // Positive indices may point forward; check them against the final counts (a second,
    // sequential pass names the first face that is out of range).
    let totals = raw.counts();
    if (0..3).any(|k| raw.max_abs[k] >= totals[k] as i64) {
        sequential(Some(totals))?;
        return Err(Error::Invalid(format!(
            "{}: internal error: an index out of range was not found again",
            path.display()
        )));
    }
    build(src, raw, opts)
}

/// The line of the file's first face (a second, sequential read: for an error message).
fn first_face_line(src: Source<'_>) -> Result<usize> {
    let path = src.path();
    let mut found = None;
    text::for_each_chunk(src, |chunk, first_line| {
        let text = text::utf8(path, chunk, first_line)?;
        text::statements(path, text, first_line, true, |line, s| {
            if found.is_none() && Tokens::new(s).next() == Some("f") {
                found = Some(line);
            }
            Ok(())
        })
    })?;
    Ok(found.unwrap_or(1))
}

/// Welds, drops, and gives every corner its normal.
fn build(src: Source<'_>, raw: Raw, opts: &LoadOptions) -> Result<Mesh> {
    let path = src.path();
    let Raw {
        positions,
        normals: normals_in,
        texcoords,
        mut tris,
        mut tri_normals,
        mut tri_uvs,
        polygons,
        ..
    } = raw;
    if tris.is_empty() {
        return Err(Error::mesh(
            path.display().to_string(),
            "empty mesh: no faces ('f' lines)",
        ));
    }
    let mut report = LoadReport {
        polygons_triangulated: polygons,
        ..Default::default()
    };
    let positions = weld::weld_with(
        &positions,
        &mut tris,
        &mut (&mut tri_normals, &mut tri_uvs),
        weld::Order::Input,
        &mut report,
    )?;
    if tris.is_empty() {
        return Err(Error::parse(
            path,
            first_face_line(src)?,
            "every face is degenerate (repeated or collinear corners, or an area below the \
             smallest f64), this one first: empty mesh",
        ));
    }
    // No list: no face gave a normal.
    let missing = if tri_normals.is_empty() {
        3 * tris.len()
    } else {
        tri_normals
            .iter()
            .flatten()
            .filter(|&&n| n == u32::MAX)
            .count()
    };
    report.normals_estimated = missing;
    let estimated = if missing > 0 {
        normals::vertex_normals(&positions, &tris, opts.weighting)
    } else {
        Vec::new()
    };
    let corner_normals = tris
        .par_iter()
        .enumerate()
        .map(|(f, t)| {
            let n = tri_normals.get(f).unwrap_or(&[u32::MAX; 3]);
            std::array::from_fn(|k| match n[k] {
                u32::MAX => estimated[t[k] as usize],
                i => normals_in[i as usize],
            })
        })
        .collect();
    let mut attributes = CornerAttributes::default();
    if !tri_uvs.is_empty() {
        let missing = tri_uvs.iter().flatten().filter(|&&i| i == u32::MAX).count();
        if missing > 0 {
            report.notes.push(format!(
                "{missing} face corners without a texture coordinate: (0, 0) given"
            ));
        }
        attributes.uvs = Some(
            tri_uvs
                .iter()
                .map(|t| t.map(|i| texcoords.get(i as usize).copied().unwrap_or([0.0; 2])))
                .collect(),
        );
    }
    Ok(Mesh {
        name: super::display_name(path),
        positions,
        triangles: tris,
        corner_normals,
        attributes,
        load_report: report,
    })
}
