//! Continuity statistics across shared edges (Table 1 protocol of
//! `spec/EVALUATION.md`): 21 points per interior edge, cos of the two patches'
//! unit normals, and the position gap between them.
//!
//! Crease edges (the two triangles give an end vertex different normals, see
//! [`crate::mesh::creases`]) are meant to break the tangent plane: they are left out of the
//! cos statistics and reported on their own (`crease_edges`, `crease_max_gap`).

use glam::DVec3;
use serde::Serialize;

use crate::eval::{Evaluator, PatchPoint, Pattern};
use crate::mesh::creases::crease_edges;
use crate::mesh::{Adjacency, LoadReport, Mesh};
use crate::patch::PatchTable;
use crate::Result;

/// Samples per edge, end points included (t = 0, 0.05, ..., 1).
pub const SAMPLES_PER_EDGE: u32 = 21;

/// cos of the angle between the two patches' normals over all edge samples. Best values:
/// all 1 and std 0; a cos below 0 is a folded patch.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct CosStats {
    pub min: f64,
    pub max: f64,
    pub mean: f64,
    /// Ordinary sample standard deviation (n − 1), as Table 1.
    pub std: f64,
}

/// Continuity of a surface across its interior edges.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct Continuity {
    /// Edge samples (each a pair of evaluations).
    pub samples: usize,
    pub cos: CosStats,
    /// Largest 1 − |cos|: 0 when the tangent plane is shared (G1), even where folded.
    pub max_one_minus_abs_cos: f64,
    /// Largest distance between the two patches' positions (0 = watertight).
    pub max_gap: f64,
    /// Samples with cos < 0 (folded patches).
    pub folded: usize,
    /// Interior edges that are creases (left out of everything above).
    pub crease_edges: usize,
    /// Edge samples on crease edges.
    pub crease_samples: usize,
    /// Largest distance between the two patches' positions on crease edges.
    pub crease_max_gap: f64,
}

/// The evaluation points of every interior edge: for each edge and each t, the point on the
/// first triangle then the same point on the second.
pub fn edge_points(mesh: &Mesh, adjacency: &Adjacency) -> Vec<PatchPoint> {
    edge_points_where(mesh, adjacency, &|_| true)
}

/// [`edge_points`] of the interior edges whose index in `adjacency.edges` passes `keep`.
pub fn edge_points_where(
    mesh: &Mesh,
    adjacency: &Adjacency,
    keep: &dyn Fn(usize) -> bool,
) -> Vec<PatchPoint> {
    let n = SAMPLES_PER_EDGE - 1;
    let mut out = Vec::with_capacity(adjacency.interior * SAMPLES_PER_EDGE as usize * 2);
    for (_, e) in adjacency
        .edges
        .iter()
        .enumerate()
        .filter(|(i, e)| e.is_interior() && keep(*i))
    {
        for i in 0..=n {
            // Parameter from e.v[0] (t = 0) to e.v[1] (t = 1), both ends exact.
            let t = i as f64 / n as f64;
            let s = (n - i) as f64 / n as f64;
            for u in &e.uses {
                let tri = mesh.triangles[u.triangle as usize];
                let k = u.local as usize;
                let mut b = [0.0; 3];
                if tri[k] == e.v[0] {
                    b[k] = s;
                    b[(k + 1) % 3] = t;
                } else {
                    b[k] = t;
                    b[(k + 1) % 3] = s;
                }
                out.push(PatchPoint {
                    patch: u.triangle,
                    b,
                });
            }
        }
    }
    out
}

/// Streaming accumulator of cos and gap samples (Welford's mean and variance).
#[derive(Default)]
struct Acc {
    n: usize,
    mean: f64,
    m2: f64,
    min: f64,
    max: f64,
    worst_abs: f64,
    gap: f64,
    folded: usize,
}

impl Acc {
    fn push(&mut self, p: [DVec3; 2], n: [DVec3; 2]) {
        let c = n[0].dot(n[1]);
        if self.n == 0 {
            self.min = c;
            self.max = c;
        }
        self.n += 1;
        let d = c - self.mean;
        self.mean += d / self.n as f64;
        self.m2 += d * (c - self.mean);
        self.min = self.min.min(c);
        self.max = self.max.max(c);
        self.worst_abs = self.worst_abs.max(1.0 - c.abs());
        self.gap = self.gap.max(p[0].distance(p[1]));
        if c < 0.0 {
            self.folded += 1;
        }
    }

    fn finish(self) -> Continuity {
        Continuity {
            samples: self.n,
            cos: CosStats {
                min: self.min,
                max: self.max,
                mean: self.mean,
                std: if self.n > 1 {
                    (self.m2 / (self.n - 1) as f64).sqrt()
                } else {
                    0.0
                },
            },
            max_one_minus_abs_cos: self.worst_abs,
            max_gap: self.gap,
            folded: self.folded,
            ..Default::default()
        }
    }
}

/// Continuity statistics of `table` over the interior edges of `mesh`, evaluated by
/// `evaluator`: cos and gap over the non-crease edges, the gap alone over crease edges.
pub fn continuity(
    mesh: &Mesh,
    adjacency: &Adjacency,
    table: &PatchTable,
    evaluator: &dyn Evaluator,
) -> Result<Continuity> {
    let creases = crease_edges(mesh, adjacency);
    let mut points = edge_points_where(mesh, adjacency, &|i| !creases[i]);
    let smooth_pairs = points.len() / 2;
    points.extend(edge_points_where(mesh, adjacency, &|i| creases[i]));
    let mut acc = Acc::default();
    let mut crease = Acc::default();
    let mut pairs = 0usize;
    let mut pending: Option<(DVec3, DVec3)> = None;
    evaluator.evaluate(table, &Pattern::Points(points), &mut |chunk| {
        for (p, n) in chunk.positions.iter().zip(chunk.normals) {
            match pending.take() {
                None => pending = Some((*p, *n)),
                Some((p0, n0)) => {
                    let target = if pairs < smooth_pairs {
                        &mut acc
                    } else {
                        &mut crease
                    };
                    target.push([p0, *p], [n0, *n]);
                    pairs += 1;
                }
            }
        }
        Ok(())
    })?;
    let mut c = acc.finish();
    c.crease_edges = creases.iter().filter(|&&x| x).count();
    c.crease_samples = crease.n;
    c.crease_max_gap = crease.gap;
    Ok(c)
}

/// Everything `g1tess stats --json` prints for one mesh and scheme.
#[derive(Clone, Debug, Serialize)]
pub struct StatsReport {
    pub mesh: String,
    pub scheme: String,
    pub triangles: usize,
    pub vertices: usize,
    pub interior_edges: usize,
    /// Interior edges that are creases: left out of samples, cos, max_gap and folded.
    pub crease_edges: usize,
    pub boundary_edges: usize,
    pub nonmanifold_edges: usize,
    /// Interior edges whose two triangles disagree in orientation.
    pub misoriented_edges: usize,
    pub samples: usize,
    pub cos: CosStats,
    pub max_one_minus_abs_cos: f64,
    pub max_gap: f64,
    /// max_gap divided by the bounding-box diagonal.
    pub max_gap_relative: f64,
    pub diagonal: f64,
    pub folded: usize,
    /// Edge samples on crease edges.
    pub crease_samples: usize,
    /// Largest position gap between the two patches on crease edges.
    pub crease_max_gap: f64,
    pub backend: String,
    /// Edges where the construction took a documented fallback.
    pub fallbacks: usize,
    pub load: LoadReport,
}

impl StatsReport {
    pub fn new(
        mesh: &Mesh,
        adjacency: &Adjacency,
        table: &PatchTable,
        c: Continuity,
        backend: String,
    ) -> StatsReport {
        let diagonal = mesh.diagonal();
        StatsReport {
            mesh: mesh.name.clone(),
            scheme: table.scheme.to_string(),
            triangles: mesh.triangles.len(),
            vertices: mesh.positions.len(),
            interior_edges: adjacency.interior,
            crease_edges: c.crease_edges,
            boundary_edges: adjacency.boundary,
            nonmanifold_edges: adjacency.nonmanifold,
            misoriented_edges: adjacency.misoriented,
            samples: c.samples,
            cos: c.cos,
            max_one_minus_abs_cos: c.max_one_minus_abs_cos,
            max_gap: c.max_gap,
            max_gap_relative: if diagonal > 0.0 {
                c.max_gap / diagonal
            } else {
                0.0
            },
            diagonal,
            folded: c.folded,
            crease_samples: c.crease_samples,
            crease_max_gap: c.crease_max_gap,
            backend,
            fallbacks: table.fallbacks,
            load: mesh.load_report.clone(),
        }
    }

    /// Human-readable summary, several lines.
    pub fn to_text(&self) -> String {
        format!(
            "mesh {} · scheme {} · backend {}\n\
             triangles {} · vertices {} · interior edges {} · boundary edges {} · non-manifold edges {} · misoriented edges {}\n\
             samples {} (21 per non-crease interior edge)\n\
             cos  min {:.9}  max {:.9}  mean {:.9}  std {:.6e}\n\
             max 1-|cos| {:.3e} · folded samples (cos < 0) {}\n\
             max gap {:.3e} ({:.3e} × bbox diagonal){}",
            self.mesh,
            self.scheme,
            self.backend,
            self.triangles,
            self.vertices,
            self.interior_edges,
            self.boundary_edges,
            self.nonmanifold_edges,
            self.misoriented_edges,
            self.samples,
            self.cos.min,
            self.cos.max,
            self.cos.mean,
            self.cos.std,
            self.max_one_minus_abs_cos,
            self.folded,
            self.max_gap,
            self.max_gap_relative,
            if self.crease_edges > 0 {
                format!(
                    "\ncrease edges {} (left out of the above) · {} samples · max gap {:.3e}",
                    self.crease_edges, self.crease_samples, self.crease_max_gap
                )
            } else {
                String::new()
            },
        )
    }
}
