//! Curved Lagrange triangles for solvers: Gmsh MSH 4.1 (ASCII or binary) of order 1 to 5,
//! every node on the scheme's surface (`g1tess export-msh`).
//!
//! A triangle of order P has (P+1)(P+2)/2 nodes at the points (a/P, b/P) of its reference
//! triangle, in Gmsh's order ([`triangle_nodes`]): the three vertices, then P − 1 nodes
//! along each edge (corner 0→1, 1→2, 2→0), then the interior nodes, which are themselves a
//! triangle of order P − 3 in the same order, recursively. Gmsh's reference point (u, v) is
//! the patch's barycentric point (1 − u − v, u, v), so corner k of the input triangle is
//! vertex k of the element. Every node is the f64 evaluation of the patch there; vertices
//! are the input positions bit for bit. Shared nodes are written once: an edge's nodes are
//! evaluated by its first triangle (the lowest index), at fractions j/P from its lower vertex
//! id, and every triangle on the edge refers to them. The exception is a non-manifold edge
//! (three or more triangles) whose triangles disagree on an end's normal: the patch schemes
//! join only the two triangles of an interior edge into one boundary curve, so there each
//! triangle's patch has a boundary curve of its own, and each triangle gets edge nodes of
//! its own on that edge, evaluated on its own patch.
//!
//! For each element two numbers are computed and written as `$ElementData` views (and the
//! worst of each returned in [`MshSummary`]):
//! - the minimum scaled Jacobian: J = (x_u × x_v)·n̂, n̂ the unit normal of the straight
//!   triangle through the element's vertices, is a polynomial of degree 2P − 2; its Bernstein
//!   coefficients bound it (every value of J lies between the smallest and the largest
//!   coefficient), and the reported value is min c / max |c|. It is 1 for a straight
//!   element, at most the true min J / max |J| (a conservative lower bound: never above the
//!   truth), and ≤ 0 where the element may fold over;
//! - the largest distance between the element and its patch: |X(b) − S(b)| at the same
//!   reference point b, on the barycentric grid of level 4P (three points between
//!   neighbouring nodes, where the interpolation error lives; zero at the nodes). As a
//!   point-to-point distance it bounds the distance from the element's points to the patch
//!   from above at those samples.
//!
//! Physical groups: the surface (dimension 2, tag 1, "surface"), and, where the mesh has
//! them, the crease edges (dimension 1, tag 1, "creases": interior edges whose triangles
//! disagree on an end normal) and the boundary edges (dimension 1, tag 2, "boundary": edges
//! of one triangle), each edge a line element of order P (types 1, 8, 26, 27, 28) through
//! the nodes the triangles use. Every node is written in one block of the surface entity.

use std::io::Write;
use std::path::Path;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use super::atomic::{write_atomic_with, TempFiles};
use crate::mesh::{creases, EdgeUse, Mesh};
use crate::patch::basis::Weights;
use crate::patch::PatchTable;
use crate::progress::Progress;
use crate::{Error, Result};

use crate::patch::lagrange::{grid, JacobianBound};
pub use crate::patch::lagrange::{lagrange_triangle, triangle_node_count, triangle_nodes, Shapes};

/// Highest element order written (Gmsh's complete triangles go on, but solvers stop here).
pub const MAX_ORDER: u32 = 5;

/// Gmsh element type of the complete triangle of order `p` (1..=5): 2, 9, 21, 23, 25.
pub fn triangle_type(p: u32) -> i32 {
    [2, 9, 21, 23, 25][p as usize - 1]
}

/// Gmsh element type of the line of order `p` (1..=5): 1, 8, 26, 27, 28.
pub fn line_type(p: u32) -> i32 {
    [1, 8, 26, 27, 28][p as usize - 1]
}

/// Triangles per step of progress.
const CHUNK: usize = 1 << 14;

/// `0..n` in runs of [`CHUNK`].
fn chunks(n: usize) -> impl Iterator<Item = std::ops::Range<usize>> {
    (0..n).step_by(CHUNK).map(move |s| s..(s + CHUNK).min(n))
}

/// Quality of one element.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ElementQuality {
    /// min c / max |c| over the Bernstein coefficients c of the Jacobian determinant (see
    /// the module documentation): 1 for a straight element, ≤ 0 where it may fold.
    pub min_scaled_jacobian: f64,
    /// Largest |element − patch| at the same reference point, sampled (module documentation).
    pub max_distance: f64,
}

/// The curved mesh of one order, in memory.
#[derive(Clone, Debug)]
pub struct HighOrderMesh {
    /// Order P of the elements (1..=[`MAX_ORDER`]).
    pub order: u32,
    /// Node positions; node tag = index + 1. The input vertices first (same order), then the
    /// edge nodes (P − 1 per edge, edges in the adjacency's order, from the lower vertex id;
    /// P − 1 per triangle on a non-manifold edge with split normals, in the edge's use
    /// order: see the module documentation), then the interior nodes of each triangle.
    pub nodes: Vec<DVec3>,
    /// [`triangle_node_count`] node indices per triangle, in Gmsh's order; triangle t of the
    /// mesh is element t.
    pub triangles: Vec<u32>,
    /// P + 1 node indices per crease edge (ends from the lower vertex id, then the inner
    /// nodes in order).
    pub creases: Vec<u32>,
    /// P + 1 node indices per boundary edge, in the direction of its triangle.
    pub boundary: Vec<u32>,
    /// Per triangle.
    pub quality: Vec<ElementQuality>,
}

impl HighOrderMesh {
    /// Node indices of element `t`.
    pub fn element(&self, t: usize) -> &[u32] {
        let n = triangle_node_count(self.order);
        &self.triangles[t * n..(t + 1) * n]
    }
}

/// Places the nodes of the order-`order` elements of `table` (built for `mesh`) on the
/// surface and measures every element. `progress` gets the phases "placing nodes" and
/// "measuring elements" over the triangles.
pub fn build(
    mesh: &Mesh,
    table: &PatchTable,
    order: u32,
    progress: &dyn Progress,
) -> Result<HighOrderMesh> {
    if !(1..=MAX_ORDER).contains(&order) {
        return Err(Error::Invalid(format!(
            "element order {order} is not supported (1 to {MAX_ORDER})"
        )));
    }
    let nt = mesh.triangles.len();
    if table.len() != nt {
        return Err(Error::Invalid(format!(
            "{}: a table of {} patches for {nt} triangles",
            mesh.name,
            table.len()
        )));
    }
    let p = order;
    let adjacency = mesh.adjacency();
    let split = creases::split_ends(mesh, &adjacency);
    let layout = NodeLayout::new(mesh, &adjacency, &split, p);
    let total = layout.total();
    if total > u32::MAX as usize {
        return Err(Error::mesh(
            &mesh.name,
            format!("{total} nodes at order {p} are too many for 32-bit node indices"),
        ));
    }
    progress.start("placing nodes", nt as u64);
    let nodes = place_nodes(mesh, table, &adjacency, &layout, progress)?;
    let triangles = layout.connectivity();
    let (crease_lines, boundary) = edge_lines(mesh, &adjacency, &split, &layout);
    progress.start("measuring elements", nt as u64);
    let quality = measure(mesh, table, p, &nodes, &triangles, progress)?;
    Ok(HighOrderMesh {
        order,
        nodes,
        triangles,
        creases: crease_lines,
        boundary,
        quality,
    })
}

/// The error for a patch that evaluates to a non-finite point.
fn non_finite(mesh: &Mesh, t: usize) -> Error {
    Error::mesh(
        &mesh.name,
        format!("patch {t} evaluates to a non-finite position"),
    )
}

/// A node on patch t: its position, finite or an error naming the patch.
fn position(mesh: &Mesh, table: &PatchTable, t: usize, b: [f64; 3]) -> Result<DVec3> {
    let x = table.eval(t, b).p;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(non_finite(mesh, t))
    }
}

/// The numbering of an order-P mesh's nodes: the input vertices, then the blocks of edge
/// nodes, then the interior nodes of each triangle.
struct NodeLayout<'a> {
    mesh: &'a Mesh,
    p: u32,
    /// Blocks of edge nodes: one per edge, or one per use of a non-manifold edge whose uses
    /// disagree on an end's normal (each use's patch has its own boundary curve there). A
    /// block is (edge, the use that evaluates it).
    blocks: Vec<(usize, EdgeUse)>,
    /// Block of each half-edge (3t + k).
    use_block: Vec<u32>,
    /// Reference points (a, b) of a triangle's interior nodes, in Gmsh's order.
    interior: Vec<[u32; 2]>,
}

impl<'a> NodeLayout<'a> {
    fn new(
        mesh: &'a Mesh,
        adjacency: &crate::mesh::Adjacency,
        split: &[[bool; 2]],
        p: u32,
    ) -> Self {
        let mut blocks: Vec<(usize, EdgeUse)> = Vec::with_capacity(adjacency.edges.len());
        let mut use_block = vec![0u32; 3 * mesh.triangles.len()];
        for (e, edge) in adjacency.edges.iter().enumerate() {
            let own = edge.uses.len() > 2 && (split[e][0] || split[e][1]);
            for (i, u) in edge.uses.iter().enumerate() {
                if own || i == 0 {
                    blocks.push((e, *u));
                }
                use_block[u.half_edge() as usize] = (blocks.len() - 1) as u32;
            }
        }
        let per_edge = p as usize - 1;
        let interior = triangle_nodes(p)[3 + 3 * per_edge..].to_vec();
        NodeLayout {
            mesh,
            p,
            blocks,
            use_block,
            interior,
        }
    }

    /// Inner nodes of an edge: P − 1.
    fn per_edge(&self) -> usize {
        self.p as usize - 1
    }

    /// Index of the first edge node.
    fn edge_start(&self) -> usize {
        self.mesh.positions.len()
    }

    /// Index of the first interior node.
    fn interior_start(&self) -> usize {
        self.edge_start() + self.blocks.len() * self.per_edge()
    }

    fn total(&self) -> usize {
        self.interior_start() + self.mesh.triangles.len() * self.interior.len()
    }

    /// Node i (1..p) of the way along element edge k of triangle t.
    fn edge_node(&self, t: usize, k: usize, i: usize) -> u32 {
        let tri = self.mesh.triangles[t];
        let e = self.use_block[3 * t + k];
        let forward = tri[k] < tri[(k + 1) % 3];
        let j = if forward { i - 1 } else { self.per_edge() - i };
        (self.edge_start() + e as usize * self.per_edge()) as u32 + j as u32
    }

    /// The node indices of every element, in Gmsh's order.
    fn connectivity(&self) -> Vec<u32> {
        let per_tri = self.interior.len();
        let mut triangles =
            Vec::with_capacity(self.mesh.triangles.len() * triangle_node_count(self.p));
        for (t, tri) in self.mesh.triangles.iter().enumerate() {
            triangles.extend_from_slice(tri);
            for k in 0..3 {
                for i in 1..self.p as usize {
                    triangles.push(self.edge_node(t, k, i));
                }
            }
            let base = (self.interior_start() + t * per_tri) as u32;
            triangles.extend(base..base + per_tri as u32);
        }
        triangles
    }

    /// The line element along edge k of triangle t: its ends, then its inner nodes, all
    /// reversed when `reverse`.
    fn line(&self, t: usize, k: usize, reverse: bool) -> Vec<u32> {
        let tri = self.mesh.triangles[t];
        let (a, b) = (tri[k], tri[(k + 1) % 3]);
        let mut l = vec![a, b];
        l.extend((1..self.p as usize).map(|i| self.edge_node(t, k, i)));
        if reverse {
            l.swap(0, 1);
            l[2..].reverse();
        }
        l
    }
}

/// Every node's position: the input vertices, the edge nodes (evaluated by each block's
/// use) and the interior nodes, in the layout's order.
fn place_nodes(
    mesh: &Mesh,
    table: &PatchTable,
    adjacency: &crate::mesh::Adjacency,
    layout: &NodeLayout,
    progress: &dyn Progress,
) -> Result<Vec<DVec3>> {
    let p = layout.p;
    let mut nodes = Vec::with_capacity(layout.total());
    nodes.extend_from_slice(&mesh.positions);
    let pf = p as f64;
    let edge_nodes: Vec<Vec<DVec3>> = layout
        .blocks
        .par_iter()
        .map(|&(e, u)| {
            let edge = &adjacency.edges[e];
            let t = u.triangle as usize;
            let k = u.local as usize;
            let tri = mesh.triangles[t];
            (1..p)
                .map(|j| {
                    let f = j as f64 / pf;
                    // Fraction f from the lower vertex id, whichever way the triangle runs.
                    let g = if tri[k] == edge.v[0] { f } else { 1.0 - f };
                    let mut b = [0.0; 3];
                    b[k] = 1.0 - g;
                    b[(k + 1) % 3] = g;
                    position(mesh, table, t, b)
                })
                .collect()
        })
        .collect::<Result<_>>()?;
    for e in edge_nodes {
        nodes.extend(e);
    }
    let interior_b: Vec<[f64; 3]> = layout
        .interior
        .iter()
        .map(|&[a, b]| {
            let (u, v) = (a as f64 / pf, b as f64 / pf);
            [1.0 - u - v, u, v]
        })
        .collect();
    for chunk in chunks(mesh.triangles.len()) {
        let interior_nodes: Vec<Vec<DVec3>> = chunk
            .clone()
            .into_par_iter()
            .map(|t| {
                interior_b
                    .iter()
                    .map(|&b| position(mesh, table, t, b))
                    .collect()
            })
            .collect::<Result<_>>()?;
        for n in interior_nodes {
            nodes.extend(n);
        }
        progress.inc(chunk.len() as u64);
    }
    Ok(nodes)
}

/// The line elements of the crease edges (interior edges with a split end, from the lower
/// vertex id) and of the boundary edges (in their triangle's direction).
fn edge_lines(
    mesh: &Mesh,
    adjacency: &crate::mesh::Adjacency,
    split: &[[bool; 2]],
    layout: &NodeLayout,
) -> (Vec<u32>, Vec<u32>) {
    let mut crease_lines = Vec::new();
    let mut boundary_lines = Vec::new();
    for (e, edge) in adjacency.edges.iter().enumerate() {
        let u = edge.uses[0];
        let (t, k) = (u.triangle as usize, u.local as usize);
        let crease = edge.is_interior() && (split[e][0] || split[e][1]);
        if crease {
            let tri = mesh.triangles[t];
            crease_lines.extend(layout.line(t, k, tri[k] != edge.v[0]));
        } else if edge.uses.len() == 1 {
            boundary_lines.extend(layout.line(t, k, false));
        }
    }
    (crease_lines, boundary_lines)
}

/// The quality of every element (module documentation), its nodes `nodes[triangles[..]]`.
fn measure(
    mesh: &Mesh,
    table: &PatchTable,
    p: u32,
    nodes: &[DVec3],
    triangles: &[u32],
    progress: &dyn Progress,
) -> Result<Vec<ElementQuality>> {
    let nt = mesh.triangles.len();
    let npt = triangle_node_count(p);
    let bound = JacobianBound::new(p);
    let dist_points = grid(4 * p);
    let dist_shapes: Vec<Shapes> = dist_points
        .iter()
        .map(|&b| lagrange_triangle(p, b))
        .collect();
    let dist_patch: Vec<Weights> = dist_points.iter().map(|&b| table.kind.weights(b)).collect();
    let mut quality: Vec<ElementQuality> = Vec::with_capacity(nt);
    for chunk in chunks(nt) {
        let len = chunk.len() as u64;
        let part: Vec<ElementQuality> = chunk
            .into_par_iter()
            .map(|t| {
                let ids = &triangles[t * npt..(t + 1) * npt];
                let x: Vec<DVec3> = ids.iter().map(|&i| nodes[i as usize]).collect();
                let min_scaled_jacobian = bound.min_scaled(&x, table.flat_normals[t]);
                let mut max_distance = 0.0f64;
                for (w, wp) in dist_shapes.iter().zip(&dist_patch) {
                    let mut xe = DVec3::ZERO;
                    for (n, xn) in x.iter().enumerate() {
                        xe += w.w[n] * *xn;
                    }
                    let s = table.eval_weights(t, wp).p;
                    max_distance = max_distance.max(xe.distance(s));
                }
                if !max_distance.is_finite() {
                    return Err(non_finite(mesh, t));
                }
                Ok(ElementQuality {
                    min_scaled_jacobian,
                    max_distance,
                })
            })
            .collect::<Result<_>>()?;
        quality.extend(part);
        progress.inc(len);
    }
    Ok(quality)
}

/// What [`export_msh`] wrote and measured.
#[derive(Clone, Debug, Serialize)]
pub struct MshSummary {
    /// The mesh's name.
    pub mesh: String,
    /// The scheme's name.
    pub scheme: String,
    /// Order P of the elements.
    pub order: u32,
    /// Whether the file is binary MSH (ASCII otherwise).
    pub binary: bool,
    /// Nodes written.
    pub nodes: usize,
    /// Triangle elements: one per triangle of the mesh.
    pub triangles: usize,
    /// Gmsh element type of the triangles.
    pub triangle_type: i32,
    /// Gmsh element type of the crease and boundary lines.
    pub line_type: i32,
    /// Line elements on crease edges (physical group "creases").
    pub crease_lines: usize,
    /// Line elements on boundary edges (physical group "boundary").
    pub boundary_lines: usize,
    /// The worst element's [`ElementQuality::min_scaled_jacobian`] and its element tag.
    pub min_scaled_jacobian: f64,
    /// Tag of that element (triangle index + 1).
    pub min_scaled_jacobian_element: usize,
    /// Elements whose bound is ≤ 0 (may fold over).
    pub nonpositive_jacobian_elements: usize,
    /// The largest [`ElementQuality::max_distance`], its element tag, and it divided by the
    /// mesh's bounding-box diagonal.
    pub max_distance: f64,
    /// Tag of that element (triangle index + 1).
    pub max_distance_element: usize,
    /// That distance divided by the bounding-box diagonal (0 where the diagonal is 0).
    pub max_distance_relative: f64,
}

impl MshSummary {
    /// The summary of `ho`, built from `mesh` with `table`.
    pub fn new(mesh: &Mesh, table: &PatchTable, ho: &HighOrderMesh, binary: bool) -> MshSummary {
        let p = ho.order;
        let (mut sj, mut sj_at, mut d, mut d_at) = (f64::INFINITY, 0, 0.0f64, 0);
        for (t, q) in ho.quality.iter().enumerate() {
            if q.min_scaled_jacobian < sj {
                (sj, sj_at) = (q.min_scaled_jacobian, t);
            }
            if q.max_distance > d {
                (d, d_at) = (q.max_distance, t);
            }
        }
        let diag = mesh.diagonal();
        MshSummary {
            mesh: mesh.name.clone(),
            scheme: table.scheme.to_string(),
            order: p,
            binary,
            nodes: ho.nodes.len(),
            triangles: ho.quality.len(),
            triangle_type: triangle_type(p),
            line_type: line_type(p),
            crease_lines: ho.creases.len() / (p as usize + 1),
            boundary_lines: ho.boundary.len() / (p as usize + 1),
            min_scaled_jacobian: sj,
            min_scaled_jacobian_element: sj_at + 1,
            nonpositive_jacobian_elements: ho
                .quality
                .iter()
                .filter(|q| q.min_scaled_jacobian <= 0.0)
                .count(),
            max_distance: d,
            max_distance_element: d_at + 1,
            max_distance_relative: if diag > 0.0 { d / diag } else { 0.0 },
        }
    }
}

/// Builds the curved mesh of `order` ([`build`]) and writes it to `path` as MSH 4.1
/// (binary or ASCII), atomically (the temporary file listed in `temp`); returns the summary.
pub fn export_msh(
    mesh: &Mesh,
    table: &PatchTable,
    order: u32,
    binary: bool,
    path: &Path,
    temp: &TempFiles,
    progress: &dyn Progress,
) -> Result<MshSummary> {
    let ho = build(mesh, table, order, progress)?;
    let title = format!("{} ({}, order {order})", mesh.name, table.scheme);
    write_atomic_with(path, temp, |w| {
        write_msh(w, &ho, binary, &title).map_err(|e| Error::io(path, e))
    })?;
    Ok(MshSummary::new(mesh, table, &ho, binary))
}

/// A physical group: (dimension, tag, name).
pub type Group = (i32, i32, &'static str);

/// The physical group of the triangles.
pub const SURFACE_GROUP: Group = (2, 1, "surface");
/// The physical group of the crease lines.
pub const CREASE_GROUP: Group = (1, 1, "creases");
/// The physical group of the boundary lines.
pub const BOUNDARY_GROUP: Group = (1, 2, "boundary");

/// An `$ElementData` view: its name and the value it shows.
type View = (&'static str, fn(&ElementQuality) -> f64);

/// Writes `ho` as MSH 4.1 to `w`. `title` goes into a `$Comments` section.
pub fn write_msh<W: Write>(
    w: &mut W,
    ho: &HighOrderMesh,
    binary: bool,
    title: &str,
) -> std::io::Result<()> {
    let mut enc = Enc {
        w,
        binary,
        fresh: true,
    };
    let p = ho.order;
    let npt = triangle_node_count(p);
    let npl = p as usize + 1;
    let nt = ho.triangles.len() / npt;
    let groups: Vec<(Group, &[u32])> = [
        (CREASE_GROUP, ho.creases.as_slice()),
        (BOUNDARY_GROUP, ho.boundary.as_slice()),
    ]
    .into_iter()
    .filter(|(_, l)| !l.is_empty())
    .collect();

    writeln!(enc.w, "$MeshFormat")?;
    writeln!(enc.w, "4.1 {} 8", u8::from(binary))?;
    if binary {
        enc.w.write_all(&1i32.to_le_bytes())?;
        writeln!(enc.w)?;
    }
    writeln!(enc.w, "$EndMeshFormat")?;
    // One line of free text (Gmsh ignores sections it does not know).
    writeln!(enc.w, "$Comments")?;
    writeln!(enc.w, "{}", title.replace(['\n', '\r'], " "))?;
    writeln!(enc.w, "$EndComments")?;
    writeln!(enc.w, "$PhysicalNames")?;
    writeln!(enc.w, "{}", 1 + groups.len())?;
    for (dim, tag, name) in std::iter::once(SURFACE_GROUP).chain(groups.iter().map(|g| g.0)) {
        writeln!(enc.w, "{dim} {tag} \"{name}\"")?;
    }
    writeln!(enc.w, "$EndPhysicalNames")?;

    // Entities: curve k (tag = its physical tag) and surface 1, with bounding boxes.
    let bbox = |ids: &mut dyn Iterator<Item = u32>| {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for i in ids {
            lo = lo.min(ho.nodes[i as usize]);
            hi = hi.max(ho.nodes[i as usize]);
        }
        [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z]
    };
    writeln!(enc.w, "$Entities")?;
    enc.sizes(&[0, groups.len() as u64, 1, 0])?;
    for ((_, tag, _), lines) in &groups {
        enc.int(*tag)?;
        enc.reals(&bbox(&mut lines.iter().copied()))?;
        enc.size(1)?;
        enc.int(*tag)?;
        enc.size(0)?;
        enc.end_line()?;
    }
    enc.int(1)?;
    enc.reals(&bbox(&mut (0..ho.nodes.len() as u32)))?;
    enc.size(1)?;
    enc.int(SURFACE_GROUP.1)?;
    enc.size(0)?;
    enc.end_line()?;
    enc.end_section("Entities")?;

    let nn = ho.nodes.len() as u64;
    writeln!(enc.w, "$Nodes")?;
    enc.sizes(&[1, nn, 1, nn])?;
    enc.ints(&[2, 1, 0])?;
    enc.size(nn)?;
    enc.end_line()?;
    for tag in 1..=nn {
        enc.size(tag)?;
        enc.end_line()?;
    }
    for x in &ho.nodes {
        enc.reals(&[x.x, x.y, x.z])?;
        enc.end_line()?;
    }
    enc.end_section("Nodes")?;

    let nl: usize = groups.iter().map(|(_, l)| l.len() / npl).sum();
    let ne = (nt + nl) as u64;
    writeln!(enc.w, "$Elements")?;
    enc.sizes(&[1 + groups.len() as u64, ne, 1, ne])?;
    enc.ints(&[2, 1, triangle_type(p)])?;
    enc.size(nt as u64)?;
    enc.end_line()?;
    let mut tag = 0u64;
    for el in ho.triangles.chunks(npt) {
        tag += 1;
        enc.size(tag)?;
        for &n in el {
            enc.size(n as u64 + 1)?;
        }
        enc.end_line()?;
    }
    for ((_, ctag, _), lines) in &groups {
        enc.ints(&[1, *ctag, line_type(p)])?;
        enc.size((lines.len() / npl) as u64)?;
        enc.end_line()?;
        for el in lines.chunks(npl) {
            tag += 1;
            enc.size(tag)?;
            for &n in el {
                enc.size(n as u64 + 1)?;
            }
            enc.end_line()?;
        }
    }
    enc.end_section("Elements")?;

    let views: [View; 2] = [
        ("min scaled Jacobian", |q| q.min_scaled_jacobian),
        ("max distance to patch", |q| q.max_distance),
    ];
    for (name, value) in views {
        writeln!(enc.w, "$ElementData")?;
        // String tags: the view's name; real tags: the time; integer tags: time step,
        // components, number of values.
        writeln!(enc.w, "1\n\"{name}\"\n1\n0\n3\n0\n1\n{nt}")?;
        for (t, q) in ho.quality.iter().enumerate() {
            if binary {
                enc.w.write_all(&(t as i32 + 1).to_le_bytes())?;
                enc.w.write_all(&value(q).to_le_bytes())?;
            } else {
                writeln!(enc.w, "{} {:?}", t + 1, value(q))?;
            }
        }
        enc.end_section("ElementData")?;
    }
    Ok(())
}

/// Writes MSH 4.1 values: as text, numbers separated by spaces and lines ended by
/// `end_line`; in binary, little-endian `int` (4 bytes), `size_t` (8) and `double` (8)
/// with no separators, a newline before each `$End…`.
struct Enc<'a, W: Write> {
    w: &'a mut W,
    binary: bool,
    /// Text: nothing written on the current line yet (no separator before the next value).
    fresh: bool,
}

impl<W: Write> Enc<'_, W> {
    /// Text: the space before a value that is not the first of its line.
    fn sep(&mut self) -> std::io::Result<()> {
        let fresh = std::mem::replace(&mut self.fresh, false);
        if self.binary || fresh {
            Ok(())
        } else {
            self.w.write_all(b" ")
        }
    }

    fn int(&mut self, v: i32) -> std::io::Result<()> {
        if self.binary {
            self.w.write_all(&v.to_le_bytes())
        } else {
            self.sep()?;
            write!(self.w, "{v}")
        }
    }

    fn ints(&mut self, v: &[i32]) -> std::io::Result<()> {
        v.iter().try_for_each(|&x| self.int(x))
    }

    fn size(&mut self, v: u64) -> std::io::Result<()> {
        if self.binary {
            self.w.write_all(&v.to_le_bytes())
        } else {
            self.sep()?;
            write!(self.w, "{v}")
        }
    }

    fn sizes(&mut self, v: &[u64]) -> std::io::Result<()> {
        v.iter().try_for_each(|&x| self.size(x))?;
        self.end_line()
    }

    fn reals(&mut self, v: &[f64]) -> std::io::Result<()> {
        for &x in v {
            if self.binary {
                self.w.write_all(&x.to_le_bytes())?;
            } else {
                // Debug: the shortest text that reads back to the same f64.
                self.sep()?;
                write!(self.w, "{x:?}")?;
            }
        }
        Ok(())
    }

    fn end_line(&mut self) -> std::io::Result<()> {
        self.fresh = true;
        if self.binary {
            Ok(())
        } else {
            self.w.write_all(b"\n")
        }
    }

    fn end_section(&mut self, name: &str) -> std::io::Result<()> {
        if self.binary {
            writeln!(self.w)?;
        }
        writeln!(self.w, "$End{name}")
    }
}
