//! Stanford PLY input: ASCII, binary little-endian and binary big-endian.
//!
//! Read from the `vertex` element: `x y z` (required), `nx ny nz` (vertex normals, used
//! when all three are present, renormalised), texture coordinates (`s t`, `u v`,
//! `texture_u texture_v` or `texture_s texture_t`) and colours (`red green blue` and
//! optionally `alpha`: integers scaled by their type's maximum, e.g. bytes by 255, floats
//! as they are). From the `face` element: the list `vertex_indices` (or `vertex_index`);
//! polygons are triangulated as fans, like OBJ faces; a `texcoord` list of 2 numbers per
//! corner (per-corner UVs, as MeshLab writes them) is read too. Triangle strips are read
//! from a `tristrips` element's `vertex_indices` list (as Stanford's strip files, e.g.
//! `igea.ply`, hold them), with or without a `face` element: strips are separated by -1,
//! every other triangle of a strip is flipped to keep the strip's orientation (the
//! OpenGL order), and triangles with a repeated corner (a strip's joins and turns) are
//! skipped. Every other property and element is skipped and listed in
//! [`super::LoadReport::notes`].
//!
//! Counts in the header are checked against the file size before anything is allocated
//! for them; errors name the header line (ASCII body: the line) or the element and its
//! index (binary body). The body must end with the last record the header declares: a
//! non-blank line (ASCII) or bytes (binary) after it are an error, not data dropped.

use std::path::Path;

use glam::DVec3;

use super::text::{self, echo};
use super::{normals, LoadOptions, LoadReport, Mesh, Soup, Source};
use crate::{Error, Result};

/// Scalar types of PLY properties.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    fn parse(s: &str) -> Option<Ty> {
        Some(match s {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }

    fn is_int(self) -> bool {
        !matches!(self, Ty::F32 | Ty::F64)
    }

    /// The largest value of an integer type (colour scaling).
    fn max(self) -> f64 {
        match self {
            Ty::I8 => 127.0,
            Ty::U8 => 255.0,
            Ty::I16 => 32767.0,
            Ty::U16 => 65535.0,
            Ty::I32 => 2147483647.0,
            Ty::U32 => 4294967295.0,
            Ty::F32 | Ty::F64 => 1.0,
        }
    }

    /// Decodes a value from exactly `self.size()` bytes.
    fn decode(self, b: &[u8], big: bool) -> f64 {
        macro_rules! get {
            ($t:ty, $n:expr) => {{
                let mut a = [0u8; $n];
                a.copy_from_slice(&b[..$n]);
                if big {
                    <$t>::from_be_bytes(a) as f64
                } else {
                    <$t>::from_le_bytes(a) as f64
                }
            }};
        }
        match self {
            Ty::I8 => b[0] as i8 as f64,
            Ty::U8 => b[0] as f64,
            Ty::I16 => get!(i16, 2),
            Ty::U16 => get!(u16, 2),
            Ty::I32 => get!(i32, 4),
            Ty::U32 => get!(u32, 4),
            Ty::F32 => get!(f32, 4),
            Ty::F64 => get!(f64, 8),
        }
    }
}

/// What a property is used for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    /// Position, normal, UV or colour channel `k` of the vertex record (see [`VERTEX_SLOTS`]).
    Vertex(usize),
    /// The face's corner list.
    Indices,
    /// The face's per-corner texture coordinates.
    TexcoordList,
    Ignored,
}

/// Slots of the vertex record: x y z, nx ny nz, u v, r g b a.
const VERTEX_SLOTS: usize = 12;
const NX: usize = 3;
const U: usize = 6;
const R: usize = 8;
const A: usize = 11;

fn vertex_slot(name: &str) -> Option<usize> {
    Some(match name {
        "x" => 0,
        "y" => 1,
        "z" => 2,
        "nx" => 3,
        "ny" => 4,
        "nz" => 5,
        "s" | "u" | "texture_u" | "texture_s" => 6,
        "t" | "v" | "texture_v" | "texture_t" => 7,
        "red" => 8,
        "green" => 9,
        "blue" => 10,
        "alpha" => 11,
        _ => return None,
    })
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    ty: Ty,
    /// The count type of a list property.
    list: Option<Ty>,
    role: Role,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
    /// Header line of the `element` statement.
    line: usize,
}

impl Element {
    /// Bytes of the smallest binary record (lists empty).
    fn min_binary(&self) -> usize {
        self.props
            .iter()
            .map(|p| p.list.unwrap_or(p.ty).size())
            .sum()
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Format {
    Ascii,
    Binary { big: bool },
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset of the body.
    body: usize,
    /// Line of the body's first record (ASCII).
    body_line: usize,
}

/// The longest header read.
const MAX_HEADER: usize = 1 << 20;

fn header(path: &Path, data: &[u8], report: &mut LoadReport) -> Result<Header> {
    let end = find_end_header(data).ok_or_else(|| {
        if data.starts_with(b"ply") {
            Error::parse(
                path,
                1,
                format!(
                    "no 'end_header' line in the first {} MiB (truncated header)",
                    MAX_HEADER >> 20
                ),
            )
        } else {
            Error::parse(path, 1, "not a PLY file (it does not start with 'ply')")
        }
    })?;
    let text = text::utf8(path, &data[..end], 1)?;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut lines = 0;
    for (i, raw) in text.split('\n').enumerate() {
        let line = i + 1;
        lines = line;
        let l = raw.trim_end_matches('\r');
        let err = |m: String| Error::parse(path, line, m);
        let unsupported = |m: String| Error::unsupported(format!("{}:{line}", path.display()), m);
        let mut tok = l.split_ascii_whitespace();
        let kw = tok.next().unwrap_or("");
        if i == 0 {
            if l.trim_end() != "ply" {
                return Err(err("not a PLY file (it does not start with 'ply')".into()));
            }
            continue;
        }
        match kw {
            "" | "comment" | "obj_info" => {}
            "end_header" => break,
            "format" => {
                let f = tok.next().unwrap_or("");
                format = Some(match f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Binary { big: false },
                    "binary_big_endian" => Format::Binary { big: true },
                    _ => return Err(unsupported(format!("unknown format '{}'", echo(f)))),
                });
                if tok.next() != Some("1.0") {
                    return Err(unsupported("unsupported PLY version (1.0 expected)".into()));
                }
            }
            "element" => {
                let name = tok.next().unwrap_or("").to_string();
                let count = tok
                    .next()
                    .and_then(|c| c.parse::<usize>().ok())
                    .ok_or_else(|| {
                        err(format!("element '{}' without a valid count", echo(&name)))
                    })?;
                if name.is_empty() {
                    return Err(err("element without a name".into()));
                }
                elements.push(Element {
                    name,
                    count,
                    props: Vec::new(),
                    line,
                });
            }
            "property" => {
                let Some(el) = elements.last_mut() else {
                    return Err(err("property before any element".into()));
                };
                let first = tok.next().unwrap_or("");
                let (list, ty_s) = if first == "list" {
                    let c = tok.next().unwrap_or("");
                    let cty = Ty::parse(c)
                        .ok_or_else(|| err(format!("unknown property type '{}'", echo(c))))?;
                    if !cty.is_int() {
                        return Err(err(format!(
                            "list count type '{}' is not an integer type",
                            echo(c)
                        )));
                    }
                    (Some(cty), tok.next().unwrap_or(""))
                } else {
                    (None, first)
                };
                let ty = Ty::parse(ty_s)
                    .ok_or_else(|| err(format!("unknown property type '{}'", echo(ty_s))))?;
                let name = tok.next().unwrap_or("").to_string();
                if name.is_empty() {
                    return Err(err("property without a name".into()));
                }
                let role = match (el.name.as_str(), list, name.as_str()) {
                    ("vertex", None, n) => vertex_slot(n).map_or(Role::Ignored, Role::Vertex),
                    ("face" | "tristrips", Some(_), "vertex_indices" | "vertex_index") => {
                        if !ty.is_int() {
                            return Err(err(format!(
                                "{} {name}: index type '{ty_s}' is not an integer type",
                                el.name
                            )));
                        }
                        Role::Indices
                    }
                    ("face", Some(_), "texcoord") => Role::TexcoordList,
                    _ => Role::Ignored,
                };
                if el
                    .props
                    .iter()
                    .any(|p| p.role == role && role != Role::Ignored)
                {
                    return Err(err(format!(
                        "element '{}' has property '{}' twice",
                        echo(&el.name),
                        echo(&name)
                    )));
                }
                el.props.push(Property {
                    name,
                    ty,
                    list,
                    role,
                });
            }
            _ => return Err(err(format!("unknown header keyword '{}'", echo(kw)))),
        }
    }
    let format = format.ok_or_else(|| Error::parse(path, 1, "no 'format' line in the header"))?;
    let vertex = elements.iter().find(|e| e.name == "vertex");
    match vertex {
        None => return Err(Error::parse(path, 1, "no 'vertex' element in the header")),
        Some(v) => {
            for (slot, c) in [(0, 'x'), (1, 'y'), (2, 'z')] {
                if !v.props.iter().any(|p| p.role == Role::Vertex(slot)) {
                    return Err(Error::parse(
                        path,
                        v.line,
                        format!("element 'vertex' has no property '{c}'"),
                    ));
                }
            }
        }
    }
    let has_indices = |e: &&Element| e.props.iter().any(|p| p.role == Role::Indices);
    let strips = elements
        .iter()
        .find(|e| e.name == "tristrips")
        .filter(has_indices);
    match elements.iter().find(|e| e.name == "face") {
        None if strips.is_some() => {}
        None => {
            return Err(Error::parse(
                path,
                1,
                "no 'face' element in the header (nor 'tristrips' with 'vertex_indices')",
            ))
        }
        Some(f) if !f.props.iter().any(|p| p.role == Role::Indices) => {
            return Err(Error::parse(
                path,
                f.line,
                "element 'face' has no list property 'vertex_indices'",
            ))
        }
        Some(_) => {}
    }
    // Notes: what is read but not used.
    for e in &elements {
        let ignored: Vec<&str> = e
            .props
            .iter()
            .filter(|p| p.role == Role::Ignored)
            .map(|p| p.name.as_str())
            .collect();
        let strips_read = strips.is_some_and(|s| std::ptr::eq(s, e));
        if e.name != "vertex" && e.name != "face" && !strips_read {
            if e.count > 0 {
                report.notes.push(format!(
                    "element '{}' ({} records) ignored",
                    echo(&e.name),
                    e.count
                ));
            }
        } else if !ignored.is_empty() {
            report.notes.push(format!(
                "{} properties ignored: {}",
                echo(&e.name),
                echo(&ignored.join(" "))
            ));
        }
    }
    Ok(Header {
        format,
        elements,
        body: end,
        body_line: lines + 1,
    })
}

/// The byte just after the `end_header` line, if within [`MAX_HEADER`].
fn find_end_header(data: &[u8]) -> Option<usize> {
    let lim = &data[..data.len().min(MAX_HEADER)];
    let mut start = 0;
    while start < lim.len() {
        let nl = lim[start..].iter().position(|&b| b == b'\n')?;
        let l = &lim[start..start + nl];
        let l = l.strip_suffix(b"\r").unwrap_or(l);
        if l.trim_ascii() == b"end_header" {
            return Some(start + nl + 1);
        }
        start += nl + 1;
    }
    None
}

/// What the body holds, per vertex.
#[derive(Default)]
struct Body {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    uvs: Vec<[f32; 2]>,
    colors: Vec<[f32; 4]>,
    triangles: Vec<[u32; 3]>,
    /// Per-corner UVs from a face `texcoord` list, per triangle.
    face_uvs: Vec<[[f32; 2]; 3]>,
    polygons: usize,
}

/// Reads a PLY file; see the module documentation.
pub fn load_ply(src: Source<'_>, opts: &LoadOptions) -> Result<Mesh> {
    let path = src.path();
    let data = src.data()?;
    let mut report = LoadReport::default();
    let h = header(path, &data, &mut report)?;
    let vertex = h.elements.iter().find(|e| e.name == "vertex").cloned();
    let vertex = vertex.expect("header checked");
    let has = |s: usize| vertex.props.iter().any(|p| p.role == Role::Vertex(s));
    let use_normals = (NX..NX + 3).all(has);
    if !use_normals && (NX..NX + 3).any(has) {
        report
            .notes
            .push("vertex normals incomplete (not all of nx ny nz): estimated".into());
    }
    let use_uv = has(U) && has(U + 1);
    let use_color = (R..R + 3).all(has);
    let alpha = use_color && has(A);
    // Bound every count by the bytes left before allocating for it.
    let body_bytes = data.len() - h.body;
    let mut remaining = body_bytes;
    for e in &h.elements {
        let min = match h.format {
            Format::Binary { .. } => e.min_binary(),
            // A value and a separator per property, the last separator may be missing.
            Format::Ascii => 2 * e.props.len(),
        };
        let need = (e.count as u128) * (min as u128);
        let need = need.saturating_sub(u128::from(h.format == Format::Ascii && e.count > 0));
        if need > remaining as u128 {
            return Err(Error::parse(
                path,
                e.line,
                format!(
                    "element '{}' counts {} records, which need at least {need} bytes, but \
                     only {remaining} bytes remain (truncated file, or a count that lies)",
                    echo(&e.name),
                    e.count
                ),
            ));
        }
        remaining -= need as usize;
    }
    let mut body = Body::default();
    let nv = vertex.count;
    body.positions.reserve(nv);
    if use_normals {
        body.normals.reserve(nv);
    }
    if use_uv {
        body.uvs.reserve(nv);
    }
    if use_color {
        body.colors.reserve(nv);
    }
    let want = Want {
        normals: use_normals,
        uv: use_uv,
        color: use_color,
        alpha,
        nv,
    };
    match h.format {
        Format::Binary { big } => {
            binary(path, &data[h.body..], &h.elements, big, &want, &mut body)?
        }
        Format::Ascii => {
            let text = text::utf8(path, &data[h.body..], h.body_line)?;
            ascii(path, text, h.body_line, &h.elements, &want, &mut body)?
        }
    }
    report.polygons_triangulated = body.polygons;
    if body.triangles.is_empty() {
        return Err(Error::mesh(
            path.display().to_string(),
            "empty mesh: no faces",
        ));
    }
    let name = super::display_name(path);
    let face_uvs = std::mem::take(&mut body.face_uvs);
    let mut soup = Soup {
        corner_uvs: None,
        positions: body.positions,
        triangles: body.triangles,
        normals: use_normals.then_some(body.normals),
        uvs: use_uv.then_some(body.uvs),
        colors: use_color.then_some(body.colors),
        alpha,
        report,
    };
    if !face_uvs.is_empty() {
        // Per-corner UVs from the faces win over per-vertex ones.
        soup.uvs = None;
        soup.corner_uvs = Some(face_uvs);
    }
    soup.check(&path.display().to_string())?;
    soup.build(name, opts)
}

/// Which vertex data the caller wants.
struct Want {
    normals: bool,
    uv: bool,
    color: bool,
    alpha: bool,
    nv: usize,
}

/// Takes a decoded vertex record into the body, naming vertex `i` on error.
fn push_vertex(
    slots: &[f64; VERTEX_SLOTS],
    tys: &[Ty; VERTEX_SLOTS],
    want: &Want,
    body: &mut Body,
    err: &dyn Fn(String) -> Error,
) -> Result<()> {
    let p = DVec3::new(slots[0], slots[1], slots[2]);
    if !p.is_finite() {
        return Err(err("non-finite coordinate".into()));
    }
    if p.abs().max_element() > normals::MAX_COORD {
        return Err(err(format!(
            "coordinate above {:e} in magnitude (products of such coordinates overflow)",
            normals::MAX_COORD
        )));
    }
    body.positions.push(p);
    if want.normals {
        let n = DVec3::new(slots[NX], slots[NX + 1], slots[NX + 2]);
        body.normals
            .push(normals::unit(n).ok_or_else(|| err("zero or non-finite normal".into()))?);
    }
    if want.uv {
        let uv = [slots[U] as f32, slots[U + 1] as f32];
        if !uv.iter().all(|x| x.is_finite()) {
            return Err(err("non-finite texture coordinate".into()));
        }
        body.uvs.push(uv);
    }
    if want.color {
        let c = std::array::from_fn(|k| {
            if k == 3 && !want.alpha {
                1.0
            } else {
                (slots[R + k] / tys[R + k].max()) as f32
            }
        });
        let c: [f32; 4] = c;
        if !c.iter().all(|x| x.is_finite()) {
            return Err(err("non-finite colour".into()));
        }
        body.colors.push(c);
    }
    Ok(())
}

/// Takes a face's corner list (and per-corner UVs) into the body as a fan.
fn push_face(
    idx: &[f64],
    uv: Option<&[f64]>,
    nv: usize,
    body: &mut Body,
    err: &dyn Fn(String) -> Error,
) -> Result<()> {
    if idx.len() < 3 {
        return Err(err(format!(
            "face needs at least 3 corners, found {}",
            idx.len()
        )));
    }
    let mut v = Vec::with_capacity(idx.len());
    for &i in idx {
        if i < 0.0 || i >= nv as f64 {
            return Err(err(format!(
                "vertex index {i} out of range (the file has {nv} vertices)"
            )));
        }
        v.push(i as u32);
    }
    let uv = match uv {
        Some(u) if u.len() != 2 * idx.len() => {
            return Err(err(format!(
                "texcoord list of {} numbers for {} corners (2 per corner expected)",
                u.len(),
                idx.len()
            )))
        }
        Some(u) => {
            if u.iter().any(|x| !(*x as f32).is_finite()) {
                return Err(err("non-finite texture coordinate".into()));
            }
            Some(u)
        }
        None => None,
    };
    for k in 2..v.len() {
        body.triangles.push([v[0], v[k - 1], v[k]]);
        if let Some(u) = uv {
            let c = |j: usize| [u[2 * j] as f32, u[2 * j + 1] as f32];
            body.face_uvs.push([c(0), c(k - 1), c(k)]);
        }
    }
    body.polygons += usize::from(v.len() > 3);
    Ok(())
}

/// Takes a `tristrips` record's index list into the body: strips separated by -1, the
/// triangle at position k of a strip (counted from the strip's start) is (k, k+1, k+2) for
/// even k and (k+1, k, k+2) for odd k, so that all keep the first one's orientation;
/// triangles with a repeated corner are skipped.
fn push_strips(
    idx: &[f64],
    nv: usize,
    body: &mut Body,
    err: &dyn Fn(String) -> Error,
) -> Result<()> {
    for &i in idx {
        if i != -1.0 && (i < 0.0 || i >= nv as f64) {
            return Err(err(format!(
                "vertex index {i} out of range (the file has {nv} vertices; -1 ends a strip)"
            )));
        }
    }
    for strip in idx.split(|&i| i == -1.0) {
        for (k, w) in strip.windows(3).enumerate() {
            let [a, b, c] = [w[0], w[1], w[2]].map(|x| x as u32);
            if a == b || b == c || a == c {
                continue;
            }
            body.triangles
                .push(if k % 2 == 0 { [a, b, c] } else { [b, a, c] });
        }
    }
    Ok(())
}

/// One record's values, as the binary and the ASCII reader collect them.
struct Record {
    slots: [f64; VERTEX_SLOTS],
    /// The vertex indices of a face.
    list: Vec<f64>,
    /// A face's texture coordinates (`texcoord` list), when it has them.
    uvlist: Vec<f64>,
    has_uvlist: bool,
}

impl Record {
    fn new() -> Record {
        Record {
            slots: [f64::NAN; VERTEX_SLOTS],
            list: Vec::new(),
            uvlist: Vec::new(),
            has_uvlist: false,
        }
    }

    /// Empties it for the next record (the lists keep their memory).
    fn clear(&mut self) {
        self.slots = [f64::NAN; VERTEX_SLOTS];
        self.list.clear();
        self.uvlist.clear();
        self.has_uvlist = false;
    }

    /// Adds the record to `body` when it is a vertex or a face (other elements are
    /// read and skipped).
    fn finish(
        &self,
        el: &Element,
        tys: &[Ty; VERTEX_SLOTS],
        want: &Want,
        body: &mut Body,
        err: &dyn Fn(String) -> Error,
    ) -> Result<()> {
        match el.name.as_str() {
            "vertex" => push_vertex(&self.slots, tys, want, body, err),
            "face" => push_face(
                &self.list,
                self.has_uvlist.then_some(self.uvlist.as_slice()),
                want.nv,
                body,
                err,
            ),
            "tristrips" => push_strips(&self.list, want.nv, body, err),
            _ => Ok(()),
        }
    }
}

fn slot_types(el: &Element) -> [Ty; VERTEX_SLOTS] {
    let mut tys = [Ty::F32; VERTEX_SLOTS];
    for p in &el.props {
        if let Role::Vertex(s) = p.role {
            tys[s] = p.ty;
        }
    }
    tys
}

fn binary(
    path: &Path,
    data: &[u8],
    elements: &[Element],
    big: bool,
    want: &Want,
    body: &mut Body,
) -> Result<()> {
    let file = path.display().to_string();
    let mut pos = 0usize;
    let mut rec = Record::new();
    for el in elements {
        if el.props.is_empty() {
            // Records of nothing: no bytes to read.
            continue;
        }
        let tys = slot_types(el);
        for r in 0..el.count {
            let err = |m: String| Error::mesh(&file, format!("{} {r}: {m}", echo(&el.name)));
            let truncated = || {
                err(format!(
                    "truncated: the file ends inside it ({} of {} records read)",
                    r, el.count
                ))
            };
            rec.clear();
            for p in &el.props {
                match p.list {
                    None => {
                        let n = p.ty.size();
                        let b = data.get(pos..pos + n).ok_or_else(truncated)?;
                        pos += n;
                        if let Role::Vertex(s) = p.role {
                            rec.slots[s] = p.ty.decode(b, big);
                        }
                    }
                    Some(cty) => {
                        let n = cty.size();
                        let b = data.get(pos..pos + n).ok_or_else(truncated)?;
                        pos += n;
                        let count = cty.decode(b, big);
                        if count < 0.0 {
                            return Err(err(format!(
                                "list '{}' with a negative count",
                                echo(&p.name)
                            )));
                        }
                        let bytes = (count as usize)
                            .checked_mul(p.ty.size())
                            .filter(|&b| b <= data.len() - pos)
                            .ok_or_else(truncated)?;
                        let items = &data[pos..pos + bytes];
                        pos += bytes;
                        let target = match p.role {
                            Role::Indices => Some(&mut rec.list),
                            Role::TexcoordList => {
                                rec.has_uvlist = true;
                                Some(&mut rec.uvlist)
                            }
                            _ => None,
                        };
                        if let Some(t) = target {
                            t.extend(items.chunks_exact(p.ty.size()).map(|c| p.ty.decode(c, big)));
                        }
                    }
                }
            }
            rec.finish(el, &tys, want, body, &err)?;
        }
    }
    if pos < data.len() {
        return Err(Error::mesh(
            &file,
            format!(
                "{} bytes after the last record the header declares ({}): more records \
                 than declared, or data that is not part of the mesh",
                data.len() - pos,
                last_counts(elements)
            ),
        ));
    }
    Ok(())
}

/// The declared count of the last element with properties, for the errors about data past
/// the body: "element 'face' counts 2 records".
fn last_counts(elements: &[Element]) -> String {
    elements
        .iter()
        .rev()
        .find(|e| !e.props.is_empty())
        .map_or_else(
            || "no element has properties".to_string(),
            |e| format!("element '{}' counts {} records", echo(&e.name), e.count),
        )
}

fn ascii(
    path: &Path,
    text: &str,
    first_line: usize,
    elements: &[Element],
    want: &Want,
    body: &mut Body,
) -> Result<()> {
    let mut lines = text
        .split('\n')
        .enumerate()
        .map(|(i, l)| (first_line + i, l));
    let mut rec = Record::new();
    let mut last = first_line;
    for el in elements {
        if el.props.is_empty() {
            // Records of nothing: no values to read.
            continue;
        }
        let tys = slot_types(el);
        for r in 0..el.count {
            // The next non-blank line.
            let (line, l) =
                loop {
                    match lines.next() {
                        Some((n, l)) if l.trim_ascii().is_empty() => last = n,
                        Some(x) => break x,
                        None => {
                            return Err(Error::parse(
                                path,
                                last,
                                format!(
                                "truncated: the file ends before {} {r} ({} of {} records read)",
                                echo(&el.name), r, el.count
                            ),
                            ))
                        }
                    }
                };
            last = line;
            if l.len() > text::MAX_LINE {
                return Err(text::too_long(path, line));
            }
            let err = |m: String| Error::parse(path, line, format!("{} {r}: {m}", echo(&el.name)));
            let mut tok = l.split_ascii_whitespace();
            let mut next = |what: &str| -> Result<f64> {
                let t = tok
                    .next()
                    .ok_or_else(|| err(format!("too few values (no {what})")))?;
                text::parse_f64(t)
                    .ok_or_else(|| err(format!("'{}' is not a number ({what})", echo(t))))
            };
            rec.clear();
            for p in &el.props {
                match p.list {
                    None => {
                        let x = next(&echo(&p.name))?;
                        if let Role::Vertex(s) = p.role {
                            rec.slots[s] = x;
                        }
                    }
                    Some(_) => {
                        let c = next(&format!("count of {}", echo(&p.name)))?;
                        if c < 0.0 || c.fract() != 0.0 || c > l.len() as f64 {
                            return Err(err(format!(
                                "list '{}' with count {c}, which the line does not hold",
                                echo(&p.name)
                            )));
                        }
                        if p.role == Role::TexcoordList {
                            rec.has_uvlist = true;
                        }
                        for _ in 0..c as usize {
                            let x = next(&echo(&p.name))?;
                            match p.role {
                                Role::Indices => {
                                    if x.fract() != 0.0 {
                                        return Err(err(format!(
                                            "vertex index {x} is not an integer"
                                        )));
                                    }
                                    rec.list.push(x)
                                }
                                Role::TexcoordList => rec.uvlist.push(x),
                                _ => {}
                            }
                        }
                    }
                }
            }
            if let Some(t) = tok.next() {
                return Err(err(format!(
                    "more values than the header declares ('{}')",
                    echo(t)
                )));
            }
            rec.finish(el, &tys, want, body, &err)?;
        }
    }
    if let Some((line, _)) = lines.find(|(_, l)| !l.trim_ascii().is_empty()) {
        return Err(Error::parse(
            path,
            line,
            format!(
                "a line after the last record the header declares ({}): more records than \
                 declared, or data that is not part of the mesh",
                last_counts(elements)
            ),
        ));
    }
    Ok(())
}
