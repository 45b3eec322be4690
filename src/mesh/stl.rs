//! STL input, ASCII and binary.
//!
//! STL lists every facet with its own three corners and a facet normal. Corners are welded
//! by exact position through the one input weld ([`super::weld`]), and vertex normals are
//! estimated as for an OBJ file without normals (`opts.weighting`): a facet normal is the
//! flat triangle's, not a vertex normal, so it is not used.
//!
//! A file whose size is `84 + 50 × count` (the count at byte 80) is binary, even when its
//! header starts with `solid` (as some exporters write); otherwise a file starting with
//! `solid` (in any case) and without a NUL byte in its first 84 bytes is ASCII, its
//! keywords read in any case. Errors name the facet (binary) or the line (ASCII); a vertex
//! line with more than 3 numbers is an error, not a vertex with its rest dropped.

use std::path::Path;

use glam::DVec3;

use super::text::{self, echo, Tokens};
use super::{normals, LoadOptions, Mesh, Soup, Source};
use crate::{Error, Result};

/// Bytes of a binary STL header (80 bytes of text and the facet count).
const HEADER: u64 = 84;
/// Bytes of one binary facet: normal, three corners (f32), attribute byte count (u16).
const FACET: u64 = 50;

/// Whether `head` (the file's first bytes) and the file size `len` make a binary STL.
pub(crate) fn is_binary_size(head: &[u8], len: u64) -> bool {
    head.len() >= HEADER as usize && {
        let n = u32::from_le_bytes([head[80], head[81], head[82], head[83]]) as u64;
        HEADER + FACET * n == len
    }
}

/// Reads an STL file (ASCII or binary): corners welded by exact position, degenerate
/// facets dropped and counted, vertex normals estimated with `opts.weighting`.
pub fn load_stl(src: Source<'_>, opts: &LoadOptions) -> Result<Mesh> {
    let path = src.path();
    let data = src.data()?;
    let name = super::display_name(path);
    let len = data.len() as u64;
    let corners = if is_binary_size(&data, len) || !is_ascii(&data) {
        binary(path, &data)?
    } else {
        ascii(path, &data)?
    };
    let positions: Vec<DVec3> = corners;
    let triangles: Vec<[u32; 3]> = (0..positions.len() as u32 / 3)
        .map(|f| [3 * f, 3 * f + 1, 3 * f + 2])
        .collect();
    if triangles.is_empty() {
        return Err(Error::mesh(
            path.display().to_string(),
            "empty mesh: no facets",
        ));
    }
    Soup {
        positions,
        triangles,
        ..Soup::default()
    }
    .build(name, opts)
}

/// Whether `data` starts with `solid` in any case (after blanks).
pub(crate) fn starts_solid(data: &[u8]) -> bool {
    let t = data
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .map_or(&data[..0], |i| &data[i..]);
    t.get(..5).is_some_and(|w| w.eq_ignore_ascii_case(b"solid"))
}

/// Whether a file that is not binary by its size is read as ASCII: it starts with `solid`
/// (in any case) and its first 84 bytes hold no NUL. A binary header may start with
/// `solid` too; its facet count at byte 80 has a zero byte below 2^24 facets (and the
/// header is often padded with zeros), which ASCII text never holds: such a file is a
/// binary STL whose size does not match its count, and is named so.
fn is_ascii(data: &[u8]) -> bool {
    starts_solid(data) && !data[..data.len().min(HEADER as usize)].contains(&0)
}

/// Checks one corner coordinate.
fn coordinate(x: f64) -> std::result::Result<f64, String> {
    if !x.is_finite() {
        Err("non-finite coordinate".into())
    } else if x.abs() > normals::MAX_COORD {
        Err(format!(
            "coordinate above {:e} in magnitude (products of such coordinates overflow)",
            normals::MAX_COORD
        ))
    } else {
        Ok(x)
    }
}

/// The corners of a binary STL, three per facet.
fn binary(path: &Path, data: &[u8]) -> Result<Vec<DVec3>> {
    let file = || path.display().to_string();
    let len = data.len() as u64;
    if len < HEADER {
        return Err(Error::mesh(
            file(),
            format!("truncated binary STL: {len} bytes, the header alone is {HEADER}"),
        ));
    }
    let n = u32::from_le_bytes([data[80], data[81], data[82], data[83]]) as u64;
    let want = HEADER + FACET * n;
    if want != len {
        let whole = (len - HEADER) / FACET;
        return Err(Error::mesh(
            file(),
            if want > len {
                format!(
                    "binary STL header counts {n} facets ({want} bytes) but the file has \
                     {len} bytes: facet {whole} is incomplete (truncated file, or a count \
                     that lies)"
                )
            } else {
                format!(
                    "binary STL header counts {n} facets ({want} bytes) but the file has \
                     {len} bytes: {} bytes after the last facet",
                    len - want
                )
            },
        ));
    }
    let mut out = Vec::with_capacity(3 * n as usize);
    for (f, rec) in data[HEADER as usize..]
        .chunks_exact(FACET as usize)
        .enumerate()
    {
        let x = |k: usize| {
            f32::from_le_bytes([rec[4 * k], rec[4 * k + 1], rec[4 * k + 2], rec[4 * k + 3]]) as f64
        };
        for c in 0..3 {
            let p = [x(3 + 3 * c), x(4 + 3 * c), x(5 + 3 * c)];
            for v in p {
                coordinate(v)
                    .map_err(|m| Error::mesh(file(), format!("facet {f}, corner {c}: {m}")))?;
            }
            out.push(DVec3::from_array(p));
        }
    }
    Ok(out)
}

/// Where the ASCII parser is.
#[derive(Clone, Copy, PartialEq, Eq)]
enum State {
    /// Between solids: `solid` expected.
    Outside,
    /// In a solid: `facet` or `endsolid`.
    Solid,
    /// After `facet normal ...`: `outer loop`.
    Facet,
    /// In the loop: `vertex` or `endloop`.
    Loop,
    /// After `endloop`: `endfacet`.
    EndLoop,
}

/// The keywords of ASCII STL, read in any case (`SOLID`, `Facet`, ... as some exporters
/// write them).
const KEYWORDS: [&str; 7] = [
    "solid", "endsolid", "facet", "endfacet", "outer", "vertex", "endloop",
];

/// `kw` as the lower-case keyword it spells, or itself.
fn keyword(kw: &str) -> &str {
    KEYWORDS
        .iter()
        .find(|k| k.eq_ignore_ascii_case(kw))
        .copied()
        .unwrap_or(kw)
}

/// The corners of an ASCII STL, three per facet.
fn ascii(path: &Path, data: &[u8]) -> Result<Vec<DVec3>> {
    let text = text::utf8(path, data, 1)?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out = Vec::new();
    let mut state = State::Outside;
    let mut corners = 0usize;
    let mut last_line = 1;
    text::statements(path, text, 1, false, |line, s| {
        last_line = line;
        let err = |m: String| Error::parse(path, line, m);
        let mut tok = Tokens::new(s);
        let Some(kw) = tok.next() else {
            return Ok(());
        };
        let expected = |what: &str| err(format!("'{}' where {what} was expected", echo(kw)));
        state = match (state, keyword(kw)) {
            (State::Outside, "solid") => State::Solid,
            (State::Outside, _) => return Err(expected("'solid'")),
            (State::Solid, "facet") => State::Facet,
            (State::Solid, "endsolid") => State::Outside,
            (State::Solid, _) => return Err(expected("'facet' or 'endsolid'")),
            (State::Facet, "outer") => {
                corners = 0;
                State::Loop
            }
            (State::Facet, _) => return Err(expected("'outer loop'")),
            (State::Loop, "vertex") => {
                if corners == 3 {
                    return Err(err(
                        "a fourth vertex in a facet (STL facets are triangles)".into()
                    ));
                }
                let mut p = [0.0; 3];
                for (k, x) in p.iter_mut().enumerate() {
                    let t = tok
                        .next()
                        .ok_or_else(|| err(format!("vertex needs 3 numbers, found {k}")))?;
                    let v = text::parse_f64(t)
                        .ok_or_else(|| err(format!("vertex: '{}' is not a number", echo(t))))?;
                    *x = coordinate(v).map_err(|m| err(format!("vertex: {m} '{}'", echo(t))))?;
                }
                if let Some(t) = tok.next() {
                    return Err(err(format!(
                        "vertex: a fourth value '{}' (a vertex has 3 coordinates)",
                        echo(t)
                    )));
                }
                out.push(DVec3::from_array(p));
                corners += 1;
                State::Loop
            }
            (State::Loop, "endloop") => {
                if corners != 3 {
                    return Err(err(format!(
                        "facet with {corners} vertices (STL facets are triangles)"
                    )));
                }
                State::EndLoop
            }
            (State::Loop, _) => return Err(expected("'vertex' or 'endloop'")),
            (State::EndLoop, "endfacet") => State::Solid,
            (State::EndLoop, _) => return Err(expected("'endfacet'")),
        };
        Ok(())
    })?;
    if matches!(state, State::Facet | State::Loop | State::EndLoop) {
        return Err(Error::parse(
            path,
            last_line,
            "file ends inside a facet (truncated)",
        ));
    }
    // A facet cut short by the end of the file was refused above: whole facets only.
    out.truncate(out.len() / 3 * 3);
    Ok(out)
}
