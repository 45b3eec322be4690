//! glTF 2.0 input: `.gltf` (JSON with external `.bin` files or base64 data URIs) and `.glb`.
//!
//! The JSON is parsed and validated by the `gltf` crate (without its `import` feature, so
//! no image decoder comes in); the GLB container, the buffers and the accessors are read
//! here, every offset and length checked against the data present, so a malformed file is
//! an error naming the buffer, accessor or primitive, never a panic.
//!
//! Every triangle primitive of the default scene (scene 0 when none is named) is read,
//! with its node's transform applied: positions by the world matrix, normals by the
//! inverse transpose of its linear part, renormalised; a transform that mirrors (negative
//! determinant) reverses the triangles' winding, as glTF specifies. Indexed and
//! non-indexed primitives, triangle strips and fans; `NORMAL`, `TEXCOORD_0` and `COLOR_0`
//! (float, or normalised unsigned bytes and shorts). Points and lines are skipped with a
//! note; sparse accessors, a triangle list whose corner count is not a multiple of 3 and a
//! mesh placed by a singular transform (a scale of 0) are refused. Primitives are joined and
//! welded by exact position.
//!
//! A buffer URI is a base64 data URI or a file inside the glTF file's folder, as glTF
//! validators require: absolute paths, `..` climbing out of the folder and symbolic links
//! leading out of it are refused, and so is anything but a regular file (checked before it
//! is opened). Exactly the `byteLength` the buffer declares is read, never the file to its
//! end; a caller with a memory budget checks the declared lengths first ([`scene_size`]).

use std::path::Path;

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::Mode;
use ::gltf::Semantic;
use glam::{DMat3, DMat4, DVec3};

use super::{normals, LoadOptions, LoadReport, Mesh, Soup, Source};
use crate::{Error, Result};

/// Deepest node nesting followed (a cycle is refused rather than followed forever).
const MAX_DEPTH: usize = 256;

/// Reads a glTF 2.0 file (`.gltf` or `.glb`); see the module documentation.
pub fn load_gltf(src: Source<'_>, opts: &LoadOptions) -> Result<Mesh> {
    let path = src.path();
    let file = path.display().to_string();
    let err = |m: String| Error::mesh(&file, m);
    let data = src.data()?;
    let (json, blob) = if data.starts_with(b"glTF") {
        let (j, b) = glb(&data).map_err(err)?;
        (j, b)
    } else {
        (&data[..], None)
    };
    let doc = document(json).map_err(err)?;
    let buffers = load_buffers(src, &doc, blob).map_err(err)?;
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| err("no scene to read".into()))?;
    let mut gathered = Gathered::default();
    walk_nodes(&scene, doc.nodes().count(), |node, world, origin| {
        let Some(mesh) = node.mesh() else {
            return Ok(());
        };
        let placement = Placement::new(world);
        if placement.singular {
            return Err(singular(node.index(), mesh.index(), origin));
        }
        for prim in mesh.primitives() {
            let what = format!("mesh {} primitive {}", mesh.index(), prim.index());
            gathered
                .primitive(&buffers, &prim, &placement, &what)
                .map_err(|m| format!("{what}: {m}"))?;
        }
        Ok(())
    })
    .map_err(err)?;
    let soup = gathered.into_soup().map_err(err)?;
    soup.build(super::display_name(path), opts)
}

/// Parses and validates the JSON part of the file.
fn document(json: &[u8]) -> std::result::Result<::gltf::Document, String> {
    let root: ::gltf::json::Root = serde_json::from_slice(json)
        .map_err(|e| format!("not valid glTF: {}", one_line(&e.to_string())))?;
    // The gltf crate's validation indexes the POSITION accessor before checking it: check
    // it first.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (k, prim) in mesh.primitives.iter().enumerate() {
            for (sem, acc) in &prim.attributes {
                if acc.value() >= root.accessors.len() {
                    return Err(format!(
                        "mesh {m} primitive {k}: attribute {} names accessor {}, which does \
                         not exist ({} accessors)",
                        super::text::echo(&format!("{sem:?}")),
                        acc.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    ::gltf::Document::from_json(root)
        .map_err(|e| format!("not valid glTF: {}", one_line(&e.to_string())))
}

/// The bytes of every buffer: the GLB binary chunk, a data URI's contents, or exactly the
/// declared `byteLength` of a file inside the glTF's folder ([`load_file`]; refused when the
/// glTF came as bytes, without a folder); each checked to hold at least its declared length.
fn load_buffers(
    src: Source<'_>,
    doc: &::gltf::Document,
    blob: Option<&[u8]>,
) -> std::result::Result<Vec<Vec<u8>>, String> {
    let mut buffers = Vec::new();
    for b in doc.buffers() {
        let i = b.index();
        let bytes = match b.source() {
            ::gltf::buffer::Source::Bin => blob.map(|b| b.to_vec()).ok_or_else(|| {
                format!("buffer {i} refers to a GLB binary chunk the file does not have")
            })?,
            ::gltf::buffer::Source::Uri(uri) => {
                load_uri(src, uri, b.length()).map_err(|m| format!("buffer {i}: {m}"))?
            }
        };
        if bytes.len() < b.length() {
            return Err(format!(
                "buffer {i}: {} bytes declared, {} present (truncated)",
                b.length(),
                bytes.len()
            ));
        }
        buffers.push(bytes);
    }
    Ok(buffers)
}

/// Visits the scene's nodes depth first, children in order, each with its world matrix and
/// the first node on its path (itself or an ancestor) whose own transform is singular, if
/// any. glTF nodes form a forest: a node reached twice (a cycle, or two parents) is
/// refused, which also bounds the walk by the number of nodes (`node_count`).
fn walk_nodes(
    scene: &::gltf::Scene,
    node_count: usize,
    mut visit: impl FnMut(&::gltf::Node, DMat4, Option<usize>) -> std::result::Result<(), String>,
) -> std::result::Result<(), String> {
    let mut stack: Vec<(::gltf::Node, DMat4, usize, Option<usize>)> = scene
        .nodes()
        .map(|n| (n, DMat4::IDENTITY, 0, None))
        .collect();
    stack.reverse();
    let mut seen = vec![false; node_count];
    while let Some((node, parent, depth, origin)) = stack.pop() {
        if depth > MAX_DEPTH {
            return Err(format!(
                "node {}: nested more than {MAX_DEPTH} deep",
                node.index()
            ));
        }
        if std::mem::replace(&mut seen[node.index()], true) {
            return Err(format!(
                "node {} is reached twice in the scene (nodes must form a tree)",
                node.index()
            ));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if !world.is_finite() {
            return Err(format!("node {}: non-finite transform", node.index()));
        }
        let origin = origin.or(Placement::new(local).singular.then_some(node.index()));
        for c in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((c, world, depth + 1, origin));
        }
        visit(&node, world, origin)?;
    }
    Ok(())
}

/// A node's world transform as its primitives use it.
struct Placement {
    world: DMat4,
    /// Inverse transpose of the linear part, for normals.
    normal_m: DMat3,
    /// The transform mirrors (negative determinant): the winding is reversed.
    mirror: bool,
    /// The transform is the identity (the points and normals are kept as read).
    identity: bool,
    /// The linear part is singular (a scale of 0, or a matrix of rank below 3): it flattens
    /// the mesh, and normals have no transform.
    singular: bool,
}

impl Placement {
    fn new(world: DMat4) -> Self {
        let lin = DMat3::from_mat4(world);
        let det = lin.determinant();
        let normal_m = lin.inverse().transpose();
        Placement {
            world,
            normal_m,
            mirror: det < 0.0,
            identity: world == DMat4::IDENTITY,
            singular: det == 0.0 || !det.is_finite() || !normal_m.is_finite(),
        }
    }
}

/// The error for node `node` placing mesh `mesh` by a singular world transform, which
/// comes from the own transform of node `origin` (itself or an ancestor) when that one is
/// singular alone, else from the product of its ancestors' transforms.
fn singular(node: usize, mesh: usize, origin: Option<usize>) -> String {
    let from = match origin {
        Some(k) if k == node => "its own scale or matrix".to_string(),
        Some(k) => format!("the scale or matrix of its ancestor node {k}"),
        None => "the product of its ancestors' transforms".to_string(),
    };
    format!(
        "node {node}: singular transform (from {from}): it flattens mesh {mesh}, whose \
         normals then have no transform"
    )
}

/// The primitives read so far, joined: the soup and the optional per-vertex attributes.
#[derive(Default)]
struct Gathered {
    soup: Soup,
    uvs: Vec<[f32; 2]>,
    colors: Vec<[f32; 4]>,
    normals: Vec<Option<DVec3>>,
    any_uv: bool,
    any_color: bool,
    any_alpha: bool,
    /// Vertices without NORMAL, TEXCOORD_0 and COLOR_0.
    lacking: [usize; 3],
}

impl Gathered {
    /// Adds one primitive (`what` names it in the note for a skipped one); an error is the
    /// message without that name.
    fn primitive(
        &mut self,
        buffers: &[Vec<u8>],
        prim: &::gltf::Primitive,
        place: &Placement,
        what: &str,
    ) -> std::result::Result<(), String> {
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.soup.report.notes.push(format!(
                "{what}: {mode:?} primitive ignored (not triangles)"
            ));
            return Ok(());
        }
        let pos_acc = prim
            .get(&Semantic::Positions)
            .ok_or_else(|| "no POSITION attribute".to_string())?;
        let pos = read(buffers, &pos_acc, &[Dimensions::Vec3], false)?;
        let n = pos.len();
        let base = self.soup.positions.len();
        for (i, p) in pos.iter().enumerate() {
            let p = DVec3::new(p[0], p[1], p[2]);
            let q = if place.identity {
                p
            } else {
                place.world.transform_point3(p)
            };
            if !q.is_finite() || q.abs().max_element() > normals::MAX_COORD {
                return Err(format!(
                    "vertex {i}: non-finite coordinate or one above {:e} in magnitude",
                    normals::MAX_COORD
                ));
            }
            self.soup.positions.push(q);
        }
        self.attributes(buffers, prim, place, base, n)?;
        let idx = corners(buffers, prim, n)?;
        if mode == Mode::Triangles && idx.len() % 3 != 0 {
            return Err(format!(
                "{} {} for TRIANGLES, not a multiple of 3 (the last {} would be dropped)",
                idx.len(),
                if prim.indices().is_some() {
                    "indices"
                } else {
                    "vertices"
                },
                idx.len() % 3
            ));
        }
        push_triangles(
            &mut self.soup.triangles,
            mode,
            &idx,
            base as u32,
            place.mirror,
        );
        if u32::try_from(self.soup.positions.len()).is_err() {
            return Err("more vertices than a mesh can index (u32)".into());
        }
        Ok(())
    }

    /// Reads the `n` vertices' NORMAL, TEXCOORD_0 and COLOR_0 (those present), the
    /// primitive's vertices starting at `base`.
    fn attributes(
        &mut self,
        buffers: &[Vec<u8>],
        prim: &::gltf::Primitive,
        place: &Placement,
        base: usize,
        n: usize,
    ) -> std::result::Result<(), String> {
        let same = |acc: &::gltf::Accessor, name: &str| -> std::result::Result<(), String> {
            if acc.count() != n {
                return Err(format!(
                    "{name} has {} entries for {n} positions",
                    acc.count()
                ));
            }
            Ok(())
        };
        match prim.get(&Semantic::Normals) {
            Some(acc) => {
                same(&acc, "NORMAL")?;
                let v = read(buffers, &acc, &[Dimensions::Vec3], false)?;
                for (i, x) in v.iter().enumerate() {
                    let m = DVec3::new(x[0], x[1], x[2]);
                    let m = if place.identity {
                        m
                    } else {
                        place.normal_m * m
                    };
                    let u = normals::unit(m)
                        .ok_or_else(|| format!("vertex {i}: zero or non-finite normal"))?;
                    self.normals.push(Some(u));
                }
            }
            None => {
                self.lacking[0] += n;
                self.normals.extend(std::iter::repeat_n(None, n));
            }
        }
        match prim.get(&Semantic::TexCoords(0)) {
            Some(acc) => {
                same(&acc, "TEXCOORD_0")?;
                self.any_uv = true;
                let v = read(buffers, &acc, &[Dimensions::Vec2], true)?;
                self.uvs.resize(base, [0.0; 2]);
                self.uvs
                    .extend(v.iter().map(|x| [x[0] as f32, x[1] as f32]));
            }
            None => self.lacking[1] += n,
        }
        match prim.get(&Semantic::Colors(0)) {
            Some(acc) => {
                same(&acc, "COLOR_0")?;
                self.any_color = true;
                self.any_alpha |= acc.dimensions() == Dimensions::Vec4;
                let v = read(buffers, &acc, &[Dimensions::Vec3, Dimensions::Vec4], true)?;
                self.colors.resize(base, [1.0; 4]);
                self.colors.extend(
                    v.iter()
                        .map(|x| [x[0] as f32, x[1] as f32, x[2] as f32, x[3] as f32]),
                );
            }
            None => self.lacking[2] += n,
        }
        Ok(())
    }

    /// The joined soup, with the attributes some primitives lack filled in (and a note
    /// saying how many).
    fn into_soup(self) -> std::result::Result<Soup, String> {
        let Gathered {
            mut soup,
            mut uvs,
            mut colors,
            normals,
            any_uv,
            any_color,
            any_alpha,
            lacking,
        } = self;
        if soup.triangles.is_empty() {
            return Err("empty mesh: no triangles in the scene".into());
        }
        let total = soup.positions.len();
        if lacking[0] < total {
            // Zero marks the vertices of primitives without NORMAL: estimated after the weld.
            soup.normals = Some(
                normals
                    .into_iter()
                    .map(|n| n.unwrap_or(DVec3::ZERO))
                    .collect(),
            );
        }
        if any_uv {
            uvs.resize(total, [0.0; 2]);
            if lacking[1] > 0 {
                soup.report.notes.push(format!(
                    "{} of {total} vertices have no TEXCOORD_0: (0, 0) given",
                    lacking[1]
                ));
            }
            soup.uvs = Some(uvs);
        }
        if any_color {
            colors.resize(total, [1.0; 4]);
            if lacking[2] > 0 {
                soup.report.notes.push(format!(
                    "{} of {total} vertices have no COLOR_0: white given",
                    lacking[2]
                ));
            }
            soup.colors = Some(colors);
            soup.alpha = any_alpha;
        }
        soup.report = LoadReport {
            notes: std::mem::take(&mut soup.report.notes),
            ..LoadReport::default()
        };
        Ok(soup)
    }
}

/// A primitive's corner list: its indices (checked against its `n` vertices), or the
/// vertices in order.
fn corners(
    buffers: &[Vec<u8>],
    prim: &::gltf::Primitive,
    n: usize,
) -> std::result::Result<Vec<u32>, String> {
    let Some(acc) = prim.indices() else {
        return Ok((0..n as u32).collect());
    };
    let v = read(buffers, &acc, &[Dimensions::Scalar], false)?;
    let mut out = Vec::with_capacity(v.len());
    for (k, x) in v.iter().enumerate() {
        if x[0] >= n as f64 {
            return Err(format!(
                "index {k} is {}, out of range ({n} vertices)",
                x[0]
            ));
        }
        out.push(x[0] as u32);
    }
    Ok(out)
}

/// Appends the triangles of a triangle list, strip or fan, its corners `idx` offset by
/// `base`, the winding reversed when the node's transform mirrors.
fn push_triangles(triangles: &mut Vec<[u32; 3]>, mode: Mode, idx: &[u32], base: u32, mirror: bool) {
    let mut tri = |a: u32, b: u32, c: u32| {
        let t = [a, b, c].map(|v| v + base);
        triangles.push(if mirror { [t[0], t[2], t[1]] } else { t });
    };
    match mode {
        Mode::Triangles => idx.chunks_exact(3).for_each(|t| tri(t[0], t[1], t[2])),
        Mode::TriangleStrip => {
            for k in 2..idx.len() {
                if k % 2 == 0 {
                    tri(idx[k - 2], idx[k - 1], idx[k]);
                } else {
                    tri(idx[k - 1], idx[k - 2], idx[k]);
                }
            }
        }
        _ => {
            for k in 2..idx.len() {
                tri(idx[0], idx[k - 1], idx[k]);
            }
        }
    }
}

/// What loading a glTF file will hold, counted from its JSON alone ([`scene_size`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneSize {
    /// Vertices of the default scene (node instances of one mesh count once each).
    pub vertices: u64,
    /// Corners: index entries, or vertices for non-indexed primitives.
    pub corners: u64,
    /// Bytes of the buffers read from files: their declared `byteLength`, each read whole
    /// (and no more) before the scene is built.
    pub file_buffers: u64,
}

/// What loading a glTF file's default scene will hold, counted from its JSON alone (node
/// instances of one mesh count once each): vertices, corners (index entries, or vertices
/// for non-indexed primitives) and the bytes of its buffer files. A mesh instanced by many
/// nodes makes a small file a large mesh, and a small file may declare a huge buffer, so a
/// caller with a memory budget checks this before [`load_gltf`]. `None` when the JSON
/// cannot be read (the load then says what is wrong); a scene that is inconsistent counts
/// its buffers only (the load fails on it after reading them).
pub fn scene_size(path: &Path) -> Option<SceneSize> {
    let json = json_of(path)?;
    let root: ::gltf::json::Root = serde_json::from_slice(&json).ok()?;
    let file_buffers = root
        .buffers
        .iter()
        .filter(|b| b.uri.as_deref().is_some_and(|u| !u.starts_with("data:")))
        .fold(0u64, |sum, b| sum.saturating_add(b.byte_length.0));
    let (vertices, corners) = scene_counts(&root).unwrap_or((0, 0));
    Some(SceneSize {
        vertices,
        corners,
        file_buffers,
    })
}

/// The vertices and corners of the default scene of `root` ([`scene_size`]), `None` when
/// the scene is inconsistent.
fn scene_counts(root: &::gltf::json::Root) -> Option<(u64, u64)> {
    let scene = match root.scene {
        Some(i) => root.scenes.get(i.value())?,
        None => root.scenes.first()?,
    };
    let count = |i: usize| root.accessors.get(i).map(|a| a.count.0);
    let mut seen = vec![false; root.nodes.len()];
    let mut stack: Vec<usize> = scene.nodes.iter().map(|n| n.value()).collect();
    let (mut vertices, mut corners) = (0u64, 0u64);
    // Every node once at most (as the load requires), so the walk is bounded by the nodes.
    while let Some(i) = stack.pop() {
        if std::mem::replace(seen.get_mut(i)?, true) {
            return None;
        }
        let node = &root.nodes[i];
        stack.extend(node.children.iter().flatten().map(|c| c.value()));
        let Some(m) = node.mesh else { continue };
        for prim in &root.meshes.get(m.value())?.primitives {
            let pos = prim
                .attributes
                .get(&::gltf::json::validation::Checked::Valid(
                    ::gltf::json::mesh::Semantic::Positions,
                ))
                .and_then(|a| count(a.value()))?;
            vertices = vertices.saturating_add(pos);
            let c = match prim.indices {
                Some(a) => count(a.value())?,
                None => pos,
            };
            corners = corners.saturating_add(c);
        }
    }
    Some((vertices, corners))
}

/// The files the buffers of the glTF or GLB file at `path` name (URIs other than data
/// URIs, resolved as the load resolves them): inputs too, which an output must not
/// replace. Empty when the file cannot be read as glTF (the load then says what is wrong).
pub fn buffer_files(path: &Path) -> Vec<std::path::PathBuf> {
    let Some(root) =
        json_of(path).and_then(|json| serde_json::from_slice::<::gltf::json::Root>(&json).ok())
    else {
        return Vec::new();
    };
    let dir = path.parent().unwrap_or(Path::new(""));
    root.buffers
        .iter()
        .filter_map(|b| b.uri.as_deref())
        .filter(|uri| !uri.starts_with("data:") && !uri.contains("://"))
        .filter_map(percent_decode)
        .map(|rel| dir.join(rel))
        .collect()
}

/// The JSON of the glTF file at `path`: the whole file, or a GLB's JSON chunk. None for a
/// file that is not regular (checked before opening it, which would block on a FIFO) or
/// that cannot be read.
fn json_of(path: &Path) -> Option<Vec<u8>> {
    use std::io::Read;
    // A device or pipe is not read here (the load refuses it with its own error).
    if !std::fs::metadata(path).ok()?.is_file() {
        return None;
    }
    let mut f = std::fs::File::open(path).ok()?;
    let meta = f.metadata().ok()?;
    if !meta.is_file() {
        return None;
    }
    let len = meta.len();
    let mut head = [0u8; 20];
    let n = f.read(&mut head).ok()?;
    let json = if n >= 4 && &head[..4] == b"glTF" {
        // GLB: only the JSON chunk, the first one, whose length is declared at byte 12.
        if n < 20 {
            return None;
        }
        let clen = u64::from(u32::from_le_bytes([head[12], head[13], head[14], head[15]]));
        if clen > len.saturating_sub(20) {
            return None;
        }
        let mut j = vec![0u8; clen as usize];
        f.read_exact(&mut j).ok()?;
        j
    } else {
        let mut j = head[..n].to_vec();
        f.take(len).read_to_end(&mut j).ok()?;
        j
    };
    Some(json)
}

/// Error text of the gltf crate on one line, control characters escaped, cut to 300
/// characters (a validation error lists every defect).
fn one_line(s: &str) -> String {
    let s = s.split_whitespace().collect::<Vec<_>>().join(" ");
    let mut out = String::new();
    for (n, c) in s.chars().enumerate() {
        if n == 300 {
            out.push('…');
            break;
        }
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

/// The JSON chunk and the binary chunk of a GLB file, every length checked.
fn glb(data: &[u8]) -> std::result::Result<(&[u8], Option<&[u8]>), String> {
    let u32_at = |o: usize| -> Option<u32> {
        data.get(o..o + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let len = data.len();
    let (Some(version), Some(total)) = (u32_at(4), u32_at(8)) else {
        return Err(format!(
            "truncated GLB: {len} bytes, the header alone is 12"
        ));
    };
    if version != 2 {
        return Err(format!("GLB version {version} (2 expected)"));
    }
    if total as usize > len {
        return Err(format!(
            "GLB header says {total} bytes but the file has {len} (truncated)"
        ));
    }
    let data = &data[..total as usize];
    let mut chunks = Vec::new();
    let mut o = 12usize;
    while o < data.len() {
        let (Some(clen), Some(ty)) = (u32_at(o), u32_at(o + 4)) else {
            return Err(format!("GLB chunk at byte {o}: truncated chunk header"));
        };
        let start = o + 8;
        let end = start
            .checked_add(clen as usize)
            .filter(|&e| e <= data.len())
            .ok_or_else(|| {
                format!(
                    "GLB chunk at byte {o}: {clen} bytes declared, {} present (truncated)",
                    data.len() - start.min(data.len())
                )
            })?;
        chunks.push((ty, &data[start..end]));
        o = end;
    }
    const JSON: u32 = 0x4E4F_534A;
    const BIN: u32 = 0x004E_4942;
    match chunks.first() {
        Some(&(JSON, j)) => Ok((j, chunks.get(1).filter(|c| c.0 == BIN).map(|c| c.1))),
        _ => Err("GLB without a JSON chunk first".into()),
    }
}

/// The bytes of a buffer URI declaring `length` bytes: a base64 data URI, or a file inside
/// the glTF file's folder ([`load_file`]).
fn load_uri(src: Source<'_>, uri: &str, length: usize) -> std::result::Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (meta, payload) = rest
            .split_once(',')
            .ok_or_else(|| "data URI without a comma".to_string())?;
        if !meta.ends_with(";base64") {
            return Err("data URI that is not base64".into());
        }
        return base64(payload).ok_or_else(|| "data URI: invalid base64".to_string());
    }
    let shown = super::text::echo(uri);
    let path = match src {
        Source::File(path) => path,
        Source::Bytes { .. } => {
            return Err(format!(
                "URI '{shown}' names an external file, which a glTF loaded from bytes cannot \
                 read (only GLB and data URI buffers are)"
            ))
        }
    };
    if uri.contains("://") {
        return Err(format!(
            "URI '{shown}' is not a relative file (only files inside the glTF's folder and data \
             URIs are read)"
        ));
    }
    let rel = percent_decode(uri).ok_or_else(|| format!("URI '{shown}' is malformed"))?;
    let file = confined(path, &rel).map_err(|m| format!("URI '{shown}' {m}"))?;
    load_file(&file, length).map_err(|m| format!("URI '{shown}' {m}"))
}

/// The file a relative URI names, inside the folder of the glTF file `path`, as glTF
/// validators require: an absolute path, a `..` that climbs out of the folder, or a
/// symbolic link leading out of it (the canonical path outside the folder's) is refused.
/// The error completes "URI 'X' ...".
fn confined(path: &Path, rel: &str) -> std::result::Result<std::path::PathBuf, String> {
    use std::path::Component;
    const ONLY: &str = "(only files inside the glTF's folder and data URIs are read)";
    let mut depth = 0usize;
    for c in Path::new(rel).components() {
        match c {
            Component::Prefix(_) | Component::RootDir => {
                return Err(format!("is an absolute path {ONLY}"));
            }
            Component::ParentDir => {
                depth = depth
                    .checked_sub(1)
                    .ok_or_else(|| format!("climbs out of the glTF's folder with '..' {ONLY}"))?;
            }
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
        }
    }
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let file = folder.join(rel);
    let canon_folder = folder
        .canonicalize()
        .map_err(|e| format!("cannot be resolved: the glTF's folder: {e}"))?;
    let canon = file
        .canonicalize()
        .map_err(|e| format!("cannot be read: {e}"))?;
    if !canon.starts_with(&canon_folder) {
        return Err(format!(
            "leads out of the glTF's folder through a symbolic link {ONLY}"
        ));
    }
    Ok(file)
}

/// Exactly the first `length` bytes of `file`, which must be a regular file (checked before
/// it is opened: a FIFO would block, a device never end) holding at least that many: a
/// buffer is never read to the end of its file, so a huge or endless file costs only what
/// the glTF declares (which a caller with a memory budget checks first, see [`scene_size`]).
/// The error completes "URI 'X' ...".
fn load_file(file: &Path, length: usize) -> std::result::Result<Vec<u8>, String> {
    use std::io::Read;
    let meta = std::fs::metadata(file).map_err(|e| format!("cannot be read: {e}"))?;
    if !meta.is_file() {
        return Err(format!(
            "names {}, not a regular file",
            super::kind_of(&meta)
        ));
    }
    if meta.len() < length as u64 {
        return Err(format!(
            "names a file of {} bytes, {length} declared (truncated)",
            meta.len()
        ));
    }
    let mut out = Vec::new();
    out.try_reserve_exact(length)
        .map_err(|_| format!("declares {length} bytes, more than can be allocated"))?;
    std::fs::File::open(file)
        .and_then(|f| f.take(length as u64).read_to_end(&mut out))
        .map_err(|e| format!("cannot be read: {e}"))?;
    Ok(out)
}

fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let h = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(h, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// Standard base64 (padding optional, no whitespace).
fn base64(s: &str) -> Option<Vec<u8>> {
    let s = s.trim_end_matches('=');
    let mut out = Vec::with_capacity(s.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0u32);
    for c in s.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return None,
        } as u32;
        acc = (acc << 6) | v;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

/// The elements of an accessor as up to four f64 components (the rest 1.0, which only
/// alpha uses), integers normalised when the accessor says so and `normalised_ok`.
fn read(
    buffers: &[Vec<u8>],
    acc: &::gltf::Accessor,
    dims: &[Dimensions],
    normalised_ok: bool,
) -> std::result::Result<Vec<[f64; 4]>, String> {
    let i = acc.index();
    if acc.sparse().is_some() {
        return Err(format!("accessor {i}: sparse accessors are not supported"));
    }
    if !dims.contains(&acc.dimensions()) {
        return Err(format!(
            "accessor {i}: type {:?} where {dims:?} was expected",
            acc.dimensions()
        ));
    }
    let ct = acc.data_type();
    let scalar = acc.dimensions() == Dimensions::Scalar;
    let ok = match ct {
        DataType::F32 => !scalar,
        DataType::U8 | DataType::U16 => scalar || (normalised_ok && acc.normalized()),
        DataType::U32 => scalar,
        DataType::I8 | DataType::I16 => false,
    };
    if !ok {
        return Err(format!(
            "accessor {i}: component type {ct:?}{} is not allowed here",
            if acc.normalized() {
                " (normalised)"
            } else {
                ""
            }
        ));
    }
    let comps = acc.dimensions().multiplicity();
    let csize = ct.size();
    let esize = comps * csize;
    let count = acc.count();
    let Some(view) = acc.view() else {
        // No view: all zeros (glTF), but a mesh needs data.
        return Err(format!("accessor {i}: no buffer view"));
    };
    let stride = view.stride().unwrap_or(esize);
    if stride < esize {
        return Err(format!(
            "accessor {i}: byte stride {stride} below its element size {esize}"
        ));
    }
    let buf = &buffers[view.buffer().index()];
    let view_end = view
        .offset()
        .checked_add(view.length())
        .filter(|&e| e <= buf.len())
        .ok_or_else(|| {
            format!(
                "buffer view {}: bytes {}..+{} beyond its buffer ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                buf.len()
            )
        })?;
    if count == 0 {
        return Ok(Vec::new());
    }
    let start = view.offset().checked_add(acc.offset());
    let end = start
        .and_then(|s| stride.checked_mul(count - 1).and_then(|x| x.checked_add(s)))
        .and_then(|x| x.checked_add(esize))
        .filter(|&e| e <= view_end)
        .ok_or_else(|| {
            format!(
                "accessor {i}: {count} elements of {esize} bytes (stride {stride}) at offset {} \
                 reach beyond buffer view {} ({} bytes)",
                acc.offset(),
                view.index(),
                view.length()
            )
        })?;
    let start = start.unwrap_or(0);
    let data = &buf[start..end];
    let norm = acc.normalized() && !scalar;
    let mut out = Vec::with_capacity(count);
    for e in 0..count {
        let rec = &data[e * stride..e * stride + esize];
        let mut v = [1.0f64; 4];
        for (c, x) in v.iter_mut().enumerate().take(comps) {
            let b = &rec[c * csize..(c + 1) * csize];
            *x = match ct {
                DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                DataType::U8 => b[0] as f64 / if norm { 255.0 } else { 1.0 },
                DataType::U16 => {
                    u16::from_le_bytes([b[0], b[1]]) as f64 / if norm { 65535.0 } else { 1.0 }
                }
                DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                // Refused above; decoded as the format defines them all the same.
                DataType::I8 => (b[0] as i8) as f64,
                DataType::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            };
            if !x.is_finite() {
                return Err(format!("accessor {i}: element {e} is not finite"));
            }
        }
        out.push(v);
    }
    Ok(out)
}
