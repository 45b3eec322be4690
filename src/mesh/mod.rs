//! Triangle meshes with per-corner unit normals: loading, welding, normals, adjacency and
//! the built-in meshes of the paper.

pub mod adjacency;
#[cfg(test)]
mod bytes_tests;
pub mod creases;
pub mod generators;
pub mod gltf;
pub mod normals;
pub mod obj;
pub mod ply;
pub mod pn_file;
pub mod stl;
pub mod weld;

use glam::DVec3;
use std::path::Path;

pub use adjacency::{Adjacency, EdgeUse};
pub use normals::NormalWeighting;

use crate::{Error, Result};

/// A welded triangle mesh. Every position is unique (welded by exact coordinates) and used
/// by at least one triangle; normals live on triangle corners so a vertex may carry
/// different normals in different faces (split normals, creases).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Name shown in reports: the file name or the built-in spec.
    pub name: String,
    /// Vertex positions, each unique and used by a triangle.
    pub positions: Vec<DVec3>,
    /// Counter-clockwise seen from the side the normals point to.
    pub triangles: Vec<[u32; 3]>,
    /// Unit normal at each corner of each triangle (always renormalised).
    pub corner_normals: Vec<[DVec3; 3]>,
    /// Per-corner texture coordinates and colours, in step with `triangles` (empty when
    /// the input gave none); set them through [`Mesh::set_corner_uvs`] and
    /// [`Mesh::set_corner_colors`], which check their length.
    pub attributes: CornerAttributes,
    /// What loading changed or found (dropped vertices, estimated normals, ...).
    pub load_report: LoadReport,
}

/// What the loader did to the input, for the statistics output.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct LoadReport {
    /// Input vertices that no face uses (dropped).
    pub unused_vertices_dropped: usize,
    /// Input vertices merged into another one at the same position.
    pub vertices_welded: usize,
    /// Triangles dropped because two of their corners are the same welded vertex, or their
    /// corners are collinear (no area in f64, so no normal).
    pub degenerate_triangles_dropped: usize,
    /// Polygons with more than three corners that were triangulated.
    pub polygons_triangulated: usize,
    /// Corners whose normal was estimated (the file gave none for them).
    pub normals_estimated: usize,
    /// What the reader read but does not use, or filled in (properties ignored, corners
    /// without a texture coordinate, ...): one line each, for the user.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// Per-corner attributes a mesh may carry besides normals, one entry per triangle of
/// [`Mesh::triangles`], kept in step with them through the weld (which drops collapsed
/// triangles and their attributes together).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CornerAttributes {
    /// Texture coordinates (u, v) of each corner.
    pub uvs: Option<Vec<[[f32; 2]; 3]>>,
    /// Colour (red, green, blue, alpha) of each corner, each in [0, 1] as the file gives
    /// it (bytes divided by 255); alpha 1 where the file has none.
    pub colors: Option<Vec<[[f32; 4]; 3]>>,
    /// Whether the file gave an alpha channel.
    pub alpha: bool,
    /// Tangent-length factors of the G1 boundary curves (`None`: all 1): for edge k of
    /// each triangle (corner k to corner k + 1), the factors of its Walton–Meek arms at
    /// corner k and at corner k + 1. Set by the fold repair; an interior edge's shared curve
    /// takes the factors of its first use (see `patch::g1::shared_curve`).
    pub arm_scales: Option<Vec<[[f64; 2]; 3]>>,
}

/// The file formats [`Mesh::load`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputFormat {
    /// Wavefront OBJ (text).
    Obj,
    /// The point-normal format `.pn`.
    Pn,
    /// Stanford PLY: ASCII, binary little- or big-endian.
    Ply,
    /// STL: ASCII or binary.
    Stl,
    /// glTF 2.0: `.gltf` (JSON, with `.bin` files or data URIs) or `.glb` (binary).
    Gltf,
}

/// Formats recognised by extension but not read, with the name an error gives them.
const UNSUPPORTED: &[(&str, &str)] = &[
    ("off", "OFF"),
    ("fbx", "FBX"),
    ("dae", "COLLADA"),
    ("3ds", "3DS"),
    ("blend", "Blender"),
    ("usd", "USD"),
    ("usda", "USD"),
    ("usdc", "USD"),
    ("usdz", "USD"),
    ("abc", "Alembic"),
    ("3mf", "3MF"),
    ("amf", "AMF"),
    ("x3d", "X3D"),
    ("wrl", "VRML"),
    ("vtk", "VTK"),
    ("step", "STEP"),
    ("stp", "STEP"),
    ("iges", "IGES"),
    ("igs", "IGES"),
];

/// What [`Mesh::load`] reads.
const SUPPORTED: &str = "OBJ, PLY, STL, glTF (.gltf, .glb), .pn";

impl InputFormat {
    /// The format of the file at `path`: by extension, and by content when the extension is
    /// not one of the formats read (`ply`, `glTF` or `{`, a binary STL's size, `solid`,
    /// `g1tess-pn`; anything else is read as OBJ text). A known format that is not read is
    /// an error naming it.
    pub fn detect(path: &Path) -> Result<InputFormat> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("obj") => return Ok(InputFormat::Obj),
            Some("pn") => return Ok(InputFormat::Pn),
            Some("ply") => return Ok(InputFormat::Ply),
            Some("stl") => return Ok(InputFormat::Stl),
            Some("gltf") | Some("glb") => return Ok(InputFormat::Gltf),
            Some(e) => {
                if let Some((_, name)) = UNSUPPORTED.iter().find(|(x, _)| *x == e) {
                    return Err(Error::unsupported(
                        path.display().to_string(),
                        format!("{name} files are not supported (supported: {SUPPORTED})"),
                    ));
                }
            }
            None => {}
        }
        Self::sniff(path)
    }

    /// The format by content.
    fn sniff(path: &Path) -> Result<InputFormat> {
        use std::io::Read;
        let len = regular_file(path)?.len();
        let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let mut head = Vec::with_capacity(256);
        file.take(256)
            .read_to_end(&mut head)
            .map_err(|e| Error::io(path, e))?;
        let head = head
            .strip_prefix(b"\xef\xbb\xbf".as_slice())
            .unwrap_or(&head);
        let text_start = head
            .iter()
            .position(|b| !b.is_ascii_whitespace())
            .map_or(&head[..0], |i| &head[i..]);
        if head.starts_with(b"ply") {
            return Ok(InputFormat::Ply);
        }
        if head.starts_with(b"glTF") || text_start.starts_with(b"{") {
            return Ok(InputFormat::Gltf);
        }
        if stl::is_binary_size(head, len) {
            return Ok(InputFormat::Stl);
        }
        if stl::starts_solid(text_start) {
            return Ok(InputFormat::Stl);
        }
        if head.starts_with(pn_file::HEADER.as_bytes()) {
            return Ok(InputFormat::Pn);
        }
        if head.starts_with(b"OFF") || head.starts_with(b"COFF") || head.starts_with(b"NOFF") {
            return Err(Error::unsupported(
                path.display().to_string(),
                format!("OFF files are not supported (supported: {SUPPORTED})"),
            ));
        }
        if head.starts_with(b"Kaydara FBX Binary") {
            return Err(Error::unsupported(
                path.display().to_string(),
                format!("FBX files are not supported (supported: {SUPPORTED})"),
            ));
        }
        Ok(InputFormat::Obj)
    }
}

/// How to obtain a mesh: options shared by every command that reads one.
///
/// Built from [`LoadOptions::default()`] and the `with_*` methods:
///
/// ```
/// use g1tess::{LoadOptions, NormalWeighting};
/// let opts = LoadOptions::default()
///     .with_weighting(NormalWeighting::Area)
///     .with_crease_angle(Some(30.0));
/// assert!(!opts.recompute_normals);
/// ```
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct LoadOptions {
    /// Weighting of face normals when a vertex normal must be estimated (default
    /// [`NormalWeighting::Angle`]).
    pub weighting: NormalWeighting,
    /// Estimate normals even where the file gives them (default false).
    pub recompute_normals: bool,
    /// Mark edges with a dihedral angle above this many degrees as creases and estimate
    /// normals per smoothing group (default `None`: no creases from angles).
    pub crease_angle: Option<f64>,
}

impl LoadOptions {
    /// Sets [`LoadOptions::weighting`].
    pub fn with_weighting(mut self, weighting: NormalWeighting) -> Self {
        self.weighting = weighting;
        self
    }

    /// Sets [`LoadOptions::recompute_normals`].
    pub fn with_recompute_normals(mut self, recompute_normals: bool) -> Self {
        self.recompute_normals = recompute_normals;
        self
    }

    /// Sets [`LoadOptions::crease_angle`] (degrees).
    pub fn with_crease_angle(mut self, crease_angle: Option<f64>) -> Self {
        self.crease_angle = crease_angle;
        self
    }
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            weighting: NormalWeighting::Angle,
            recompute_normals: false,
            crease_angle: None,
        }
    }
}

/// What `path` is, links followed, refusing anything but a regular file before it is
/// opened: opening a FIFO blocks until a writer comes, and a device such as `/dev/zero`
/// never ends. Every reader's path to a file goes through here (the input itself, the
/// format sniffing, a glTF's external buffers); the error names the path and what it is.
pub(crate) fn regular_file(path: &Path) -> Result<std::fs::Metadata> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_file() {
        return Ok(meta);
    }
    let kind = kind_of(&meta);
    let hint = if meta.is_dir() {
        ""
    } else {
        " (save what it gives to a file first)"
    };
    Err(Error::Invalid(format!(
        "{}: not a regular file but {kind}{hint}",
        path.display()
    )))
}

/// What a file that is not a regular file is, in words.
pub(crate) fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO";
        } else if t.is_char_device() {
            return "a character device";
        } else if t.is_block_device() {
            return "a block device";
        } else if t.is_socket() {
            return "a socket";
        }
    }
    "a special file"
}

/// Reads a file whole after [`regular_file`] has checked what it is.
pub(crate) fn read_regular(path: &Path) -> Result<Vec<u8>> {
    regular_file(path)?;
    std::fs::read(path).map_err(|e| Error::io(path, e))
}

/// Where a reader's bytes come from: a file, or bytes in memory ([`Mesh::from_bytes`]). Both
/// are read by the same code; `path()` is what errors and the mesh's name give (the file's
/// path, or the name given with the bytes).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Source<'a> {
    /// A file, read through [`regular_file`] (refusing FIFOs and devices).
    File(&'a Path),
    /// Bytes in memory and the name they go by.
    Bytes { name: &'a Path, bytes: &'a [u8] },
}

impl<'a> Source<'a> {
    /// The path (or name) errors and the mesh's name give.
    pub(crate) fn path(&self) -> &'a Path {
        match *self {
            Source::File(path) => path,
            Source::Bytes { name, .. } => name,
        }
    }

    /// The whole input: the file read after [`regular_file`] has checked it, or the bytes.
    pub(crate) fn data(&self) -> Result<std::borrow::Cow<'a, [u8]>> {
        match *self {
            Source::File(path) => read_regular(path).map(std::borrow::Cow::Owned),
            Source::Bytes { bytes, .. } => Ok(std::borrow::Cow::Borrowed(bytes)),
        }
    }

    /// The input's length in bytes.
    pub(crate) fn len(&self) -> Result<u64> {
        match *self {
            Source::File(path) => std::fs::metadata(path)
                .map(|m| m.len())
                .map_err(|e| Error::io(path, e)),
            Source::Bytes { bytes, .. } => Ok(bytes.len() as u64),
        }
    }
}

/// The name a mesh read from `path` carries in reports: its file name.
pub(crate) fn display_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

impl Mesh {
    /// Loads a mesh from a built-in spec (see [`generators::from_spec`]) or a file: OBJ,
    /// PLY, STL, glTF (`.gltf`, `.glb`) or the point-normal format `.pn`, chosen by
    /// extension and by content when the extension is none of these
    /// ([`InputFormat::detect`]). What a reader ignored is listed in
    /// [`LoadReport::notes`].
    pub fn load(spec: &str, opts: &LoadOptions) -> Result<Mesh> {
        let mut mesh = if let Some(m) = generators::from_spec(spec)? {
            m
        } else {
            let path = Path::new(spec);
            if !path.exists() {
                return Err(Error::Invalid(format!(
                    "{spec}: no such file, and not a built-in mesh (built-ins: {})",
                    generators::BUILTIN_HELP
                )));
            }
            // Before anything opens it (the format sniffing does): a FIFO would block.
            regular_file(path)?;
            Self::read(Source::File(path), InputFormat::detect(path)?, opts)?
        };
        mesh.apply_options(opts)?;
        Ok(mesh)
    }

    /// Loads a mesh from bytes in memory in the given format, the way [`Mesh::load`] reads
    /// a file of that format: the same readers, so the same mesh bit for bit, the same
    /// [`LoadReport`] and the same one-line errors, with `name` (e.g. the name of the
    /// file the bytes came from) where file loading gives the path, beside the line or
    /// element. No file system is touched, so this is how a browser (wasm32) loads a file
    /// the user opened or dropped. The mesh is named by `name`'s file name.
    ///
    /// A glTF (`.gltf`) whose buffers are external files cannot be read this way (an error
    /// says so): only a GLB's binary chunk and `data:` URIs are.
    ///
    /// ```
    /// use g1tess::{InputFormat, LoadOptions, Mesh};
    /// let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    /// let mesh = Mesh::from_bytes("tri.obj", obj, InputFormat::Obj, &LoadOptions::default())?;
    /// assert_eq!((mesh.positions.len(), mesh.triangles.len()), (3, 1));
    /// assert_eq!(mesh.name, "tri.obj");
    /// let bad = Mesh::from_bytes("bad.obj", b"v 0 0\n", InputFormat::Obj, &LoadOptions::default());
    /// assert!(bad.unwrap_err().to_string().starts_with("bad.obj:1: "));
    /// # Ok::<(), g1tess::Error>(())
    /// ```
    pub fn from_bytes(
        name: &str,
        bytes: &[u8],
        format: InputFormat,
        opts: &LoadOptions,
    ) -> Result<Mesh> {
        let name = Path::new(name);
        let mut mesh = Self::read(Source::Bytes { name, bytes }, format, opts)?;
        mesh.apply_options(opts)?;
        Ok(mesh)
    }

    /// The reader of `format` on `src`.
    fn read(src: Source<'_>, format: InputFormat, opts: &LoadOptions) -> Result<Mesh> {
        match format {
            InputFormat::Obj => obj::load_obj(src, opts),
            InputFormat::Pn => pn_file::load_pn(src),
            InputFormat::Ply => ply::load_ply(src, opts),
            InputFormat::Stl => stl::load_stl(src, opts),
            InputFormat::Gltf => gltf::load_gltf(src, opts),
        }
    }

    /// What every source does last: the options' normal recomputation and crease split,
    /// then [`Mesh::validate`].
    fn apply_options(&mut self, opts: &LoadOptions) -> Result<()> {
        if opts.recompute_normals {
            let n = normals::vertex_normals(&self.positions, &self.triangles, opts.weighting);
            self.corner_normals = self
                .triangles
                .iter()
                .map(|t| t.map(|v| n[v as usize]))
                .collect();
        }
        if let Some(angle) = opts.crease_angle {
            creases::split_normals_by_angle(self, angle, opts.weighting)?;
        }
        self.validate()
    }

    /// Builds a mesh from an in-memory triangle soup, the way a renderer or another library
    /// holds one: `positions`, `triangles` indexing them (counter-clockwise seen from the
    /// outside) and, optionally, one normal per position.
    ///
    /// The input is checked first: a non-finite coordinate or one above
    /// `normals::MAX_COORD` in magnitude, a zero or non-finite normal, a
    /// normal count that differs from the position count or a triangle index out of range is
    /// an error naming the element (`"NAME: vertex 12 has a non-finite coordinate"`). The soup
    /// is then welded exactly like file input (`weld::weld`: equal coordinates, `-0.0`
    /// equal to `0.0`, so a split-vertex mesh comes out closed); triangles that collapse or
    /// have no area (collinear corners) and
    /// unused vertices are dropped and counted in [`Mesh::load_report`]. Each corner keeps
    /// the normal given for its input vertex (renormalised), so split normals survive the
    /// weld; without normals they are estimated with `opts.weighting`. The options'
    /// normal recomputation and crease angle apply as for [`Mesh::load`].
    ///
    /// ```
    /// use g1tess::{Evaluator, Pattern};
    /// use g1tess::CpuEvaluator;
    /// use g1tess::{LoadOptions, Mesh};
    /// use g1tess::{PatchTable, Scheme, SchemeOptions};
    ///
    /// // A tetrahedron, outward, without normals (they are estimated).
    /// let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    /// let triangles = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    /// let mesh = Mesh::from_soup("tetra", &positions, &triangles, None, &LoadOptions::default())?;
    /// let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default())?;
    /// let (points, normals) =
    ///     CpuEvaluator::default().evaluate_all(&table, &Pattern::Grid { level: 8 })?;
    /// assert_eq!(points.len(), 4 * 45); // 45 samples per patch at level 8
    /// assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-12));
    /// # Ok::<(), g1tess::Error>(())
    /// ```
    pub fn from_soup<P: Copy + Into<DVec3>>(
        name: impl Into<String>,
        positions: &[P],
        triangles: &[[u32; 3]],
        normals: Option<&[P]>,
        opts: &LoadOptions,
    ) -> Result<Mesh> {
        let name = name.into();
        let mut soup = Soup {
            positions: positions.iter().map(|&p| p.into()).collect(),
            triangles: triangles.to_vec(),
            ..Soup::default()
        };
        soup.check(&name)?;
        let nv = soup.positions.len();
        let unit: Option<Vec<DVec3>> = match normals {
            None => None,
            Some(n) if n.len() != nv => {
                return Err(Error::mesh(
                    &name,
                    format!(
                        "{} normals for {nv} vertices (one per vertex expected)",
                        n.len()
                    ),
                ))
            }
            Some(n) => Some(
                n.iter()
                    .enumerate()
                    .map(|(i, &n)| {
                        normals::unit(n.into()).ok_or_else(|| {
                            Error::mesh(&name, format!("normal {i} is zero or non-finite"))
                        })
                    })
                    .collect::<Result<_>>()?,
            ),
        };
        soup.normals = unit;
        soup.build(name, opts)
    }

    /// Texture coordinates (u, v) of each corner of each triangle, in step with
    /// [`Mesh::triangles`], when the input gave them.
    pub fn corner_uvs(&self) -> Option<&[[[f32; 2]; 3]]> {
        self.attributes.uvs.as_deref()
    }

    /// Colour (red, green, blue, alpha in [0, 1]) of each corner of each triangle, in step
    /// with [`Mesh::triangles`], when the input gave colours (alpha 1 where it gave none;
    /// see [`Mesh::colors_have_alpha`]).
    pub fn corner_colors(&self) -> Option<&[[[f32; 4]; 3]]> {
        self.attributes.colors.as_deref()
    }

    /// Whether the input's colours had an alpha channel.
    pub fn colors_have_alpha(&self) -> bool {
        self.attributes.alpha
    }

    /// All per-corner attributes besides normals.
    pub fn attributes(&self) -> &CornerAttributes {
        &self.attributes
    }

    /// Sets (or, with `None`, removes) the per-corner texture coordinates: one entry per
    /// triangle, finite.
    pub fn set_corner_uvs(&mut self, uvs: Option<Vec<[[f32; 2]; 3]>>) -> Result<()> {
        if let Some(u) = &uvs {
            self.check_corner_data(u.len(), u.iter().flatten().flatten(), "texture coordinate")?;
        }
        self.attributes.uvs = uvs;
        Ok(())
    }

    /// Sets (or, with `None`, removes) the per-corner colours: one entry per triangle,
    /// finite; `alpha` says whether the fourth channel is meaningful.
    pub fn set_corner_colors(
        &mut self,
        colors: Option<Vec<[[f32; 4]; 3]>>,
        alpha: bool,
    ) -> Result<()> {
        if let Some(c) = &colors {
            self.check_corner_data(c.len(), c.iter().flatten().flatten(), "colour")?;
        }
        self.attributes.alpha = alpha && colors.is_some();
        self.attributes.colors = colors;
        Ok(())
    }

    fn check_corner_data<'a>(
        &self,
        len: usize,
        mut values: impl Iterator<Item = &'a f32>,
        what: &str,
    ) -> Result<()> {
        if len != self.triangles.len() {
            return Err(Error::mesh(
                &self.name,
                format!(
                    "{len} triangles of {what}s for {} triangles",
                    self.triangles.len()
                ),
            ));
        }
        if values.any(|x| !x.is_finite()) {
            return Err(Error::mesh(&self.name, format!("a non-finite {what}")));
        }
        Ok(())
    }

    /// Checks the invariants every later stage relies on: at least one triangle, indices in
    /// range, finite coordinates, unit normals.
    pub fn validate(&self) -> Result<()> {
        if self.triangles.is_empty() {
            return Err(Error::mesh(&self.name, "empty mesh: no triangles"));
        }
        if self.corner_normals.len() != self.triangles.len() {
            return Err(Error::mesh(&self.name, "normals do not match triangles"));
        }
        // In parallel; each error names the first element at fault, as a walk in order would.
        let positions = &self.positions;
        if let Some(i) = crate::par::first_index(positions.len(), |i| !positions[i].is_finite()) {
            return Err(Error::mesh(
                &self.name,
                format!("vertex {i} has a non-finite coordinate"),
            ));
        }
        let nv = self.positions.len() as u32;
        let unit = |n: &DVec3| n.is_finite() && (n.length() - 1.0).abs() <= 1e-9;
        let fault = crate::par::first_index(self.triangles.len(), |t| {
            self.triangles[t].iter().any(|&v| v >= nv) || !self.corner_normals[t].iter().all(unit)
        });
        if let Some(t) = fault {
            let what = if self.triangles[t].iter().any(|&v| v >= nv) {
                "a vertex index out of range"
            } else {
                "a zero or non-finite normal"
            };
            return Err(Error::mesh(&self.name, format!("triangle {t} has {what}")));
        }
        Ok(())
    }

    /// Axis-aligned bounding box (min, max) of the positions.
    pub fn bbox(&self) -> (DVec3, DVec3) {
        self.positions.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        )
    }

    /// Length of the bounding-box diagonal.
    pub fn diagonal(&self) -> f64 {
        let (lo, hi) = self.bbox();
        (hi - lo).length()
    }

    /// Edge adjacency of the triangles.
    pub fn adjacency(&self) -> Adjacency {
        Adjacency::new(&self.triangles)
    }
}

/// A triangle soup as the readers and [`Mesh::from_soup`] hand it over: per-vertex data
/// (normals unit when given), triangles indexing it, what reading already counted.
#[derive(Default)]
pub(crate) struct Soup {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Unit normals, or zero for a vertex without one (estimated).
    pub normals: Option<Vec<DVec3>>,
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Per-corner UVs (one entry per triangle), used instead of `uvs` when given.
    pub corner_uvs: Option<Vec<[[f32; 2]; 3]>>,
    pub colors: Option<Vec<[f32; 4]>>,
    pub alpha: bool,
    pub report: LoadReport,
}

impl Soup {
    /// Checks positions (finite, below [`normals::MAX_COORD`]) and indices, naming the
    /// vertex or triangle; per-vertex attributes are checked by the callers.
    pub fn check(&self, name: &str) -> Result<()> {
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::mesh(
                name,
                format!("vertex {i} has a non-finite coordinate"),
            ));
        }
        if let Some(i) = self
            .positions
            .iter()
            .position(|p| p.abs().max_element() > normals::MAX_COORD)
        {
            return Err(Error::mesh(
                name,
                format!(
                    "vertex {i} has a coordinate above {:e} in magnitude (products of such \
                     coordinates overflow)",
                    normals::MAX_COORD
                ),
            ));
        }
        let nv = self.positions.len();
        if let Some((t, v)) = self
            .triangles
            .iter()
            .enumerate()
            .find_map(|(t, tri)| tri.iter().find(|&&v| v as usize >= nv).map(|&v| (t, v)))
        {
            return Err(Error::mesh(
                name,
                format!(
                    "triangle {t} has vertex index {v}, out of range (the soup has {nv} vertices)"
                ),
            ));
        }
        Ok(())
    }

    /// Welds (input order), drops, estimates missing normals, applies the options. The
    /// per-vertex normals, UVs and colours become per-corner data kept in step with the
    /// triangles.
    pub fn build(self, name: String, opts: &LoadOptions) -> Result<Mesh> {
        let Soup {
            positions,
            mut triangles,
            normals: unit,
            uvs,
            corner_uvs,
            colors,
            alpha,
            mut report,
        } = self;
        if corner_uvs
            .as_ref()
            .is_some_and(|u| u.len() != triangles.len())
        {
            return Err(Error::mesh(
                &name,
                "texture coordinates not one per triangle",
            ));
        }
        fn per_corner<T: Copy>(triangles: &[[u32; 3]], data: &Option<Vec<T>>) -> Vec<[T; 3]> {
            match data {
                Some(d) => triangles.iter().map(|t| t.map(|v| d[v as usize])).collect(),
                None => Vec::new(),
            }
        }
        let mut corner_normals: Vec<[DVec3; 3]> = per_corner(&triangles, &unit);
        let has_uvs = uvs.is_some() || corner_uvs.is_some();
        let mut corner_uvs: Vec<[[f32; 2]; 3]> = match corner_uvs {
            Some(c) => c,
            None => per_corner(&triangles, &uvs),
        };
        let mut corner_colors: Vec<[[f32; 4]; 3]> = per_corner(&triangles, &colors);
        let positions = weld::weld_with(
            &positions,
            &mut triangles,
            &mut (&mut corner_normals, &mut corner_uvs, &mut corner_colors),
            weld::Order::Input,
            &mut report,
        )?;
        if triangles.is_empty() {
            return Err(Error::mesh(
                &name,
                if report.degenerate_triangles_dropped > 0 {
                    "empty mesh: every triangle is degenerate"
                } else {
                    "empty mesh: no triangles"
                },
            ));
        }
        if unit.is_none() {
            report.normals_estimated = 3 * triangles.len();
            let n = normals::vertex_normals(&positions, &triangles, opts.weighting);
            corner_normals = triangles.iter().map(|t| t.map(|v| n[v as usize])).collect();
        } else {
            // Zero marks a vertex without a normal (glTF primitives without NORMAL).
            let missing = corner_normals
                .iter()
                .flatten()
                .filter(|n| **n == DVec3::ZERO)
                .count();
            if missing > 0 {
                report.normals_estimated = missing;
                let n = normals::vertex_normals(&positions, &triangles, opts.weighting);
                for (t, c) in triangles.iter().zip(corner_normals.iter_mut()) {
                    for k in 0..3 {
                        if c[k] == DVec3::ZERO {
                            c[k] = n[t[k] as usize];
                        }
                    }
                }
            }
        }
        let attributes = CornerAttributes {
            uvs: has_uvs.then_some(corner_uvs),
            alpha: alpha && colors.is_some(),
            colors: colors.is_some().then_some(corner_colors),
            arm_scales: None,
        };
        let mut mesh = Mesh {
            name,
            positions,
            triangles,
            corner_normals,
            attributes,
            load_report: report,
        };
        mesh.apply_options(opts)?;
        Ok(mesh)
    }
}

/// Reading input text fast: chunks of whole statements, statements with their line numbers,
/// ASCII tokens, and input echoed safely in messages. Shared by the OBJ and `.pn` readers.
pub(crate) mod text {
    use std::io::Read;
    use std::path::Path;

    use crate::{Error, Result};

    /// Bytes read per chunk.
    pub const CHUNK: usize = 8 << 20;

    /// The longest statement (line, or lines joined by continuations) a mesh file may hold:
    /// a longer one is not mesh data (and reading it whole would be unbounded).
    pub const MAX_LINE: usize = 1 << 20;

    /// The error for a statement longer than [`MAX_LINE`] starting at `line`.
    pub fn too_long(path: &Path, line: usize) -> Error {
        Error::parse(
            path,
            line,
            format!("line longer than {} MiB: not a mesh file", MAX_LINE >> 20),
        )
    }

    /// Whether the terminator byte at `i` (`\n` or `\r`) ends a statement: not the `\r` of a
    /// `\r\n`, not a `\r` that may be followed by `\n` in data not yet read, and not the end
    /// of a line continued by a backslash. Returns the index just after it.
    fn boundary_at(buf: &[u8], i: usize, eof: bool) -> Option<usize> {
        if buf[i] == b'\r' {
            match buf.get(i + 1) {
                Some(b'\n') => return None,
                None if !eof => return None,
                _ => {}
            }
        }
        let end = if buf[i] == b'\n' && i > 0 && buf[i - 1] == b'\r' {
            i - 1
        } else {
            i
        };
        (end == 0 || buf[end - 1] != b'\\').then_some(i + 1)
    }

    /// The end of the last whole statement of `buf`, if any.
    fn last_boundary(buf: &[u8]) -> Option<usize> {
        let mut i = buf.len();
        while i > 0 {
            i -= 1;
            if (buf[i] == b'\n' || buf[i] == b'\r') && boundary_at(buf, i, false).is_some() {
                return Some(i + 1);
            }
        }
        None
    }

    /// The first statement boundary at or after `from` (`buf.len()` if none).
    fn next_boundary(buf: &[u8], from: usize) -> usize {
        (from..buf.len())
            .find(|&i| (buf[i] == b'\n' || buf[i] == b'\r') && boundary_at(buf, i, true).is_some())
            .map_or(buf.len(), |i| i + 1)
    }

    /// Splits `buf` (whole statements) into at most `n` pieces of whole statements.
    pub fn split(buf: &[u8], n: usize) -> Vec<&[u8]> {
        let mut out = Vec::with_capacity(n);
        let mut start = 0;
        for k in 1..=n {
            let end = if k == n {
                buf.len()
            } else {
                next_boundary(buf, (buf.len() * k / n).max(start))
            };
            if end > start {
                out.push(&buf[start..end]);
                start = end;
            }
        }
        out
    }

    fn fill(file: &mut impl Read, buf: &mut Vec<u8>, want: usize) -> std::io::Result<bool> {
        let target = buf.len() + want;
        buf.reserve(want);
        while buf.len() < target {
            let n = file
                .by_ref()
                .take((target - buf.len()) as u64)
                .read_to_end(buf)?;
            if n == 0 {
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// Reads `src` chunk by chunk, each chunk ending at a statement boundary (a UTF-8 BOM at
    /// the start dropped), and hands each to `f` in order with the number of its first line;
    /// `f` returns how many lines the chunk holds. The next chunk is read while `f` works.
    ///
    /// Only regular files are read, checked before opening ([`super::regular_file`]): the
    /// readers read a file a second time to name the line of a defect, which a pipe or
    /// device cannot give, opening a FIFO blocks, and a device such as `/dev/zero` never
    /// ends. A statement longer than [`MAX_LINE`] is an error naming its line, so
    /// memory stays bounded whatever the file holds. Bytes in memory are cut into the same
    /// chunks as a file holding them.
    pub fn for_each_chunk<F>(src: super::Source<'_>, f: F) -> Result<()>
    where
        F: FnMut(&[u8], usize) -> Result<usize> + Send,
    {
        match src {
            super::Source::File(path) => {
                super::regular_file(path)?;
                let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
                chunks(path, file, f)
            }
            super::Source::Bytes { name, bytes } => chunks(name, bytes, f),
        }
    }

    /// [`for_each_chunk`] on an open reader; `path` names it in errors.
    fn chunks<F>(path: &Path, mut file: impl Read + Send, mut f: F) -> Result<()>
    where
        F: FnMut(&[u8], usize) -> Result<usize> + Send,
    {
        let io = |e| Error::io(path, e);
        let mut cur = Vec::new();
        let mut eof = fill(&mut file, &mut cur, CHUNK).map_err(io)?;
        if cur.starts_with(b"\xef\xbb\xbf") {
            cur.drain(..3);
        }
        let mut line = 1;
        loop {
            let cut = if eof {
                cur.len()
            } else if let Some(c) = last_boundary(&cur) {
                c
            } else if cur.len() > MAX_LINE {
                return Err(too_long(path, line));
            } else {
                // One statement longer than a chunk: read on.
                eof = fill(&mut file, &mut cur, CHUNK).map_err(io)?;
                continue;
            };
            let mut next = Vec::with_capacity(CHUNK + cur.len() - cut);
            next.extend_from_slice(&cur[cut..]);
            let (lines, more) = if eof {
                (f(&cur[..cut], line), Ok(true))
            } else {
                rayon::join(
                    || f(&cur[..cut], line),
                    || fill(&mut file, &mut next, CHUNK),
                )
            };
            line += lines?;
            if eof {
                return Ok(());
            }
            eof = more.map_err(io)?;
            cur = next;
        }
    }

    /// Checks that `buf` is UTF-8; the error names the line of the first bad byte.
    pub fn utf8<'a>(path: &Path, buf: &'a [u8], first_line: usize) -> Result<&'a str> {
        std::str::from_utf8(buf).map_err(|e| {
            let before = &buf[..e.valid_up_to()];
            Error::parse(path, first_line + count_lines(before), "not UTF-8 text")
        })
    }

    /// Line terminators in `buf` (`\n`, `\r\n` and a lone `\r` each count once).
    pub fn count_lines(buf: &[u8]) -> usize {
        let mut n = 0;
        for (i, &b) in buf.iter().enumerate() {
            if b == b'\n' || (b == b'\r' && buf.get(i + 1) != Some(&b'\n')) {
                n += 1;
            }
        }
        n
    }

    /// Calls `f(line, statement)` for each statement of `text` (lines end with `\n`, `\r\n`
    /// or `\r`; with `continuation`, a backslash at the end of a line continues the statement
    /// on the next, also at the end of the text). Returns the number of lines.
    /// A statement longer than [`MAX_LINE`] is an error (from [`too_long`]).
    pub fn statements(
        path: &Path,
        text: &str,
        first_line: usize,
        continuation: bool,
        mut f: impl FnMut(usize, &str) -> Result<()>,
    ) -> Result<usize> {
        let b = text.as_bytes();
        let mut i = 0;
        let mut line = first_line;
        let mut pending = String::new();
        let mut pending_line = 0;
        while i < b.len() {
            let mut j = find_eol(b, i);
            if j - i + pending.len() > MAX_LINE {
                return Err(too_long(
                    path,
                    if pending.is_empty() {
                        line
                    } else {
                        pending_line
                    },
                ));
            }
            let content = &text[i..j];
            let continued = continuation && j > i && b[j - 1] == b'\\';
            if let Some(body) = continued.then(|| &text[i..j - 1]) {
                if pending.is_empty() {
                    pending_line = line;
                }
                pending.push_str(body);
                pending.push(' ');
            } else if !pending.is_empty() {
                pending.push_str(content);
                f(pending_line, &pending)?;
                pending.clear();
            } else {
                f(line, content)?;
            }
            if j < b.len() {
                line += 1;
                j += if b[j] == b'\r' && b.get(j + 1) == Some(&b'\n') {
                    2
                } else {
                    1
                };
            }
            i = j;
        }
        if !pending.is_empty() {
            f(pending_line, &pending)?;
        }
        Ok(line - first_line)
    }

    /// The first `\n` or `\r` at or after `i` (`b.len()` if none), eight bytes at a time.
    #[inline]
    fn find_eol(b: &[u8], mut i: usize) -> usize {
        const ONES: u64 = 0x0101_0101_0101_0101;
        const HIGH: u64 = 0x8080_8080_8080_8080;
        // High bit of each zero byte of v; exact for the lowest one (what is used).
        let zero = |v: u64| v.wrapping_sub(ONES) & !v & HIGH;
        while let Some(word) = b.get(i..i + 8) {
            let w = u64::from_le_bytes(word.try_into().unwrap_or_default());
            let m = zero(w ^ (ONES * b'\n' as u64)) | zero(w ^ (ONES * b'\r' as u64));
            if m != 0 {
                return i + (m.trailing_zeros() / 8) as usize;
            }
            i += 8;
        }
        while i < b.len() && b[i] != b'\n' && b[i] != b'\r' {
            i += 1;
        }
        i
    }

    /// Parses a decimal number like `str::parse::<f64>`, with a shortcut for the plain
    /// decimals mesh files hold: at most 15 significant digits and 22 decimals, no exponent,
    /// are an integer below 2^53 divided by an exact power of ten, one correctly rounded
    /// division (Clinger's fast path), so the result is the same. Anything else goes to std.
    #[inline]
    pub fn parse_f64(s: &str) -> Option<f64> {
        const POW10: [f64; 23] = [
            1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
            1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
        ];
        let b = s.as_bytes();
        let (neg, mut i) = match b.first() {
            Some(b'-') => (true, 1),
            Some(b'+') => (false, 1),
            _ => (false, 0),
        };
        let (mut m, mut digits, mut decimals, mut any, mut dot) =
            (0u64, 0u32, 0usize, false, false);
        while i < b.len() {
            let c = b[i];
            if c.is_ascii_digit() {
                any = true;
                if m != 0 || c != b'0' {
                    digits += 1;
                    if digits > 15 {
                        return s.parse().ok();
                    }
                    m = m * 10 + u64::from(c - b'0');
                }
                decimals += usize::from(dot);
            } else if c == b'.' && !dot {
                dot = true;
            } else {
                return s.parse().ok();
            }
            i += 1;
        }
        if !any || decimals > 22 {
            return s.parse().ok();
        }
        let v = m as f64 / POW10[decimals];
        Some(if neg { -v } else { v })
    }

    /// The blanks between tokens.
    #[inline]
    pub fn is_blank(b: u8) -> bool {
        matches!(b, b' ' | b'\t' | b'\x0b' | b'\x0c')
    }

    /// Exactly `N` finite numbers separated by blanks, nothing else: the one-pass reading
    /// of the plain statements of OBJ and `.pn` files. `None` for anything else (another
    /// form, a comment, a defect), which the readers' general paths then read, so results
    /// and errors do not depend on it.
    #[inline]
    pub fn plain_numbers<const N: usize>(s: &str) -> Option<[f64; N]> {
        let b = s.as_bytes();
        let mut out = [0.0; N];
        let mut i = 0;
        for x in &mut out {
            while i < b.len() && is_blank(b[i]) {
                i += 1;
            }
            let start = i;
            while i < b.len() && matches!(b[i], b'0'..=b'9' | b'.' | b'-' | b'+' | b'e' | b'E') {
                i += 1;
            }
            if i == start || (i < b.len() && !is_blank(b[i])) {
                return None;
            }
            // ASCII bytes: `start` and `i` are character boundaries.
            *x = plain_f64(s.get(start..i)?)?;
            if !x.is_finite() {
                return None;
            }
        }
        b[i..].iter().all(|&c| is_blank(c)).then_some(out)
    }

    /// A number as [`parse_f64`] reads it: straight to the standard library's parser when
    /// the text is too long for the shortcut of `parse_f64` (more than 15 significant
    /// digits: the shortest decimals of f32 and f64 values, mostly), which would scan it
    /// twice.
    #[inline]
    fn plain_f64(s: &str) -> Option<f64> {
        if s.len() > 17 {
            s.parse().ok()
        } else {
            parse_f64(s)
        }
    }

    /// Parses a decimal integer like `str::parse::<i64>`.
    #[inline]
    pub fn parse_i64(s: &str) -> Option<i64> {
        let b = s.as_bytes();
        let (neg, digits) = match b.first() {
            Some(b'-') => (true, &b[1..]),
            Some(b'+') => (false, &b[1..]),
            _ => (false, b),
        };
        if digits.is_empty() || digits.len() > 18 {
            return s.parse().ok();
        }
        let mut v = 0i64;
        for &c in digits {
            if !c.is_ascii_digit() {
                return None;
            }
            v = v * 10 + i64::from(c - b'0');
        }
        Some(if neg { -v } else { v })
    }

    /// Whitespace-separated tokens of a statement up to a `#` comment. ASCII statements are
    /// split on ASCII blanks; others on Unicode whitespace.
    #[derive(Clone)]
    pub enum Tokens<'a> {
        Ascii(&'a str, usize),
        Unicode(std::str::SplitWhitespace<'a>),
    }

    impl<'a> Tokens<'a> {
        pub fn new(stmt: &'a str) -> Tokens<'a> {
            if stmt.is_ascii() {
                Tokens::Ascii(stmt, 0)
            } else {
                Tokens::Unicode(stmt.split('#').next().unwrap_or("").split_whitespace())
            }
        }
    }

    impl<'a> Iterator for Tokens<'a> {
        type Item = &'a str;
        #[inline]
        fn next(&mut self) -> Option<&'a str> {
            match self {
                Tokens::Unicode(it) => it.next(),
                Tokens::Ascii(s, pos) => {
                    let b = s.as_bytes();
                    let mut i = *pos;
                    while i < b.len() && matches!(b[i], b' ' | b'\t' | b'\x0b' | b'\x0c') {
                        i += 1;
                    }
                    if i == b.len() || b[i] == b'#' {
                        *pos = b.len();
                        return None;
                    }
                    let start = i;
                    while i < b.len() && !matches!(b[i], b' ' | b'\t' | b'\x0b' | b'\x0c' | b'#') {
                        i += 1;
                    }
                    *pos = i;
                    Some(&s[start..i])
                }
            }
        }
    }

    /// Input text quoted in a message: control characters escaped, cut to 80 characters.
    pub fn echo(s: &str) -> String {
        let mut out = String::new();
        for (n, c) in s.chars().enumerate() {
            if n == 80 {
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
}

#[cfg(test)]
mod text_tests {
    use crate::mesh::text::{echo, parse_f64, parse_i64, split, statements};

    #[test]
    fn number_parsers_agree_with_std() {
        // Decimal strings of every shape a mesh file holds, and some it should not.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let mut cases: Vec<String> = [
            "0",
            "-0",
            "+0",
            "0.",
            ".5",
            "-.5",
            "+.5",
            ".",
            "-",
            "+",
            "",
            "1.2.3",
            "1e5",
            "-1.5E-3",
            "inf",
            "-infinity",
            "NaN",
            "0x10",
            "1_0",
            " 1",
            "00012.5000",
            "0.30000000000000004",
            "123456789012345",
            "1234567890123456",
            "9007199254740993",
            "0.0000000000000000000001",
            "0.00000000000000000000001",
            "1.7976931348623157e308",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        for _ in 0..20000 {
            let r = next();
            let digits = (r % 20) as usize + 1;
            let point = (r >> 8) as usize % (digits + 1);
            let mut s = String::new();
            if r & (1 << 20) != 0 {
                s.push('-');
            }
            for k in 0..digits {
                if k == point {
                    s.push('.');
                }
                s.push((b'0' + (next() % 10) as u8) as char);
            }
            cases.push(s);
            let x = f64::from_bits(next()).abs();
            if x.is_finite() {
                cases.push(format!("{x:?}"));
                cases.push(format!("{:.6}", x % 1e6));
            }
        }
        for s in &cases {
            let want = s.parse::<f64>().ok().map(f64::to_bits);
            assert_eq!(parse_f64(s).map(f64::to_bits), want, "'{s}'");
            assert_eq!(parse_i64(s), s.parse::<i64>().ok(), "'{s}'");
        }
        for s in [
            "99999999999999999999",
            "-9223372036854775808",
            "9223372036854775807",
            "+7",
        ] {
            assert_eq!(parse_i64(s), s.parse::<i64>().ok(), "'{s}'");
        }
    }

    #[test]
    fn statements_follow_every_line_ending_and_continuations() {
        let collect = |text: &str| {
            let mut out = Vec::new();
            let n = statements(std::path::Path::new("t"), text, 1, true, |line, s| {
                out.push((line, s.to_string()));
                Ok(())
            })
            .unwrap();
            (n, out)
        };
        let want = vec![
            (1, "a".to_string()),
            (2, "b  c".to_string()),
            (4, "d".to_string()),
        ];
        for nl in ["\n", "\r\n", "\r"] {
            let text = format!("a{nl}b \\{nl}c{nl}d{nl}");
            assert_eq!(collect(&text), (4, want.clone()), "{text:?}");
        }
        // A continuation on the last line, with and without a final newline.
        assert_eq!(collect("x\\").1, vec![(1, "x ".to_string())]);
        assert_eq!(collect("x\\\n").1, vec![(1, "x ".to_string())]);
        // Splitting never cuts a statement, a CRLF or a continuation.
        let text = "v 1\r\nv 2 \\\r\n3\rf 1\n\nf 2\\\n\\\nx\r";
        for n in 1..=text.len() {
            let pieces = split(text.as_bytes(), n);
            let mut all = Vec::new();
            let mut line = 1;
            for p in &pieces {
                let p = std::str::from_utf8(p).unwrap();
                line += statements(std::path::Path::new("t"), p, line, true, |l, s| {
                    all.push((l, s.to_string()));
                    Ok(())
                })
                .unwrap();
            }
            assert_eq!((line - 1, all), collect(text), "{n} pieces: {pieces:?}");
        }
    }

    #[test]
    fn echo_escapes_and_cuts() {
        assert_eq!(echo("a\u{1b}[1mb\tc"), "a\\u{1b}[1mb\\tc");
        let long = "x".repeat(200);
        assert_eq!(echo(&long), format!("{}…", "x".repeat(80)));
        assert_eq!(echo("é"), "é");
    }
}

#[cfg(test)]
mod validate_tests {
    use crate::{LoadOptions, Mesh};
    use glam::DVec3;

    /// [`Mesh::validate`] names the first vertex and the first triangle at fault, as a
    /// walk in order does, on a strip of 20,000 triangles (enough for the pool to split
    /// the checks) with faults planted at several places.
    #[test]
    fn validate_names_the_first_fault() {
        let n = 10_001u32;
        let positions: Vec<[f64; 3]> = (0..2 * n)
            .map(|i| [(i / 2) as f64, (i % 2) as f64, 0.0])
            .collect();
        // Counter-clockwise seen from +z.
        let triangles: Vec<[u32; 3]> = (0..2 * n - 2)
            .map(|t| {
                if t % 2 == 0 {
                    [t, t + 2, t + 1]
                } else {
                    [t, t + 1, t + 2]
                }
            })
            .collect();
        let mesh = Mesh::from_soup(
            "strip",
            &positions,
            &triangles,
            None,
            &LoadOptions::default(),
        )
        .unwrap();
        assert_eq!(mesh.triangles.len(), 20_000);
        assert!(mesh.validate().is_ok());
        let err = |m: &Mesh| m.validate().unwrap_err().to_string();
        let mut bad = mesh.clone();
        bad.positions[17_000].y = f64::NAN;
        bad.positions[9_000].x = f64::INFINITY;
        assert_eq!(err(&bad), "strip: vertex 9000 has a non-finite coordinate");
        bad = mesh.clone();
        bad.corner_normals[15_000][2] = DVec3::ZERO;
        bad.triangles[12_345][1] = 4 * n;
        bad.corner_normals[11_111][0] = DVec3::new(0.0, 0.0, 2.0);
        assert_eq!(
            err(&bad),
            "strip: triangle 11111 has a zero or non-finite normal"
        );
        bad.corner_normals[11_111][0] = DVec3::Z;
        assert_eq!(
            err(&bad),
            "strip: triangle 12345 has a vertex index out of range"
        );
        bad.triangles[12_345][1] = 0;
        assert_eq!(
            err(&bad),
            "strip: triangle 15000 has a zero or non-finite normal"
        );
    }
}
