//! The distance study of the paper's figures 17–18 (`docs/schemes.md`): every
//! scheme sampled on the barycentric grid of each patch, the distance of each sample to the
//! analytic surface the mesh was taken from, and the observed convergence order as the
//! mesh is refined.

use glam::DVec3;
use serde::Serialize;

use crate::eval::{Evaluator, Pattern};
use crate::mesh::generators::{icosphere, torus, TorusNormals};
use crate::mesh::Mesh;
use crate::patch::{PatchTable, Scheme, SchemeOptions};
use crate::Result;

/// Segments per patch edge of the paper's sampling (153 points per triangle).
pub const STUDY_LEVEL: u32 = 16;

/// Major and tube radii of the study's tori.
pub const TORUS_R: f64 = 1.0;
pub const TORUS_TUBE: f64 = 0.5;

/// An analytic surface with an exact distance function.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Surface {
    /// Sphere of this radius about the origin.
    Sphere { radius: f64 },
    /// Torus about the z axis: major radius `big_r`, tube radius `r`.
    Torus { big_r: f64, r: f64 },
}

impl Surface {
    /// Euclidean distance from `p` to the surface.
    pub fn distance(&self, p: DVec3) -> f64 {
        match *self {
            Surface::Sphere { radius } => (p.length() - radius).abs(),
            Surface::Torus { big_r, r } => {
                let rho = (p.x * p.x + p.y * p.y).sqrt() - big_r;
                ((rho * rho + p.z * p.z).sqrt() - r).abs()
            }
        }
    }
}

/// Mean and largest distance of a sampled surface to the analytic one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Distance {
    pub samples: usize,
    pub mean: f64,
    pub max: f64,
}

/// Samples every patch of `table` on the grid of `level` with `evaluator` and measures the
/// distance of each sample to `surface`.
pub fn distance(
    table: &PatchTable,
    surface: &Surface,
    level: u32,
    evaluator: &dyn Evaluator,
) -> Result<Distance> {
    let (mut n, mut sum, mut max) = (0usize, 0.0f64, 0.0f64);
    evaluator.evaluate(table, &Pattern::Grid { level }, &mut |chunk| {
        for p in chunk.positions {
            let d = surface.distance(*p);
            n += 1;
            sum += d;
            max = max.max(d);
        }
        Ok(())
    })?;
    Ok(Distance {
        samples: n,
        mean: if n > 0 { sum / n as f64 } else { 0.0 },
        max,
    })
}

/// One family of meshes of the study, refined step by step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Series {
    /// Icospheres of 20·4^L triangles, exact normals (figure 17).
    Icosphere,
    /// n × n tori with analytic normals (figure 18).
    TorusAnalytic,
    /// n × n tori with averaged normals (unweighted mean of the face normals).
    TorusAveraged,
}

impl Series {
    pub fn all() -> [Series; 3] {
        [
            Series::Icosphere,
            Series::TorusAnalytic,
            Series::TorusAveraged,
        ]
    }

    pub fn name(self) -> &'static str {
        match self {
            Series::Icosphere => "icosphere",
            Series::TorusAnalytic => "torus-analytic",
            Series::TorusAveraged => "torus-averaged",
        }
    }

    /// The analytic surface the series' meshes sample.
    pub fn surface(self) -> Surface {
        match self {
            Series::Icosphere => Surface::Sphere { radius: 1.0 },
            _ => Surface::Torus {
                big_r: TORUS_R,
                r: TORUS_TUBE,
            },
        }
    }

    /// The refinement steps of the paper's study: icosphere levels 0..=4 (20…5120
    /// triangles), torus n = 5..=30.
    pub fn default_steps(self) -> Vec<u32> {
        match self {
            Series::Icosphere => (0..=4).collect(),
            _ => (5..=30).collect(),
        }
    }

    /// The mesh of one step (icosphere level, or torus n for an n × n grid).
    pub fn mesh(self, step: u32) -> Mesh {
        match self {
            Series::Icosphere => icosphere(step),
            Series::TorusAnalytic => torus(step, step, TORUS_R, TORUS_TUBE, TorusNormals::Analytic),
            Series::TorusAveraged => torus(step, step, TORUS_R, TORUS_TUBE, TorusNormals::Averaged),
        }
    }
}

impl std::fmt::Display for Series {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One (series, mesh, scheme) measurement of the study.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SweepRow {
    pub series: Series,
    pub mesh: String,
    pub scheme: Scheme,
    pub triangles: usize,
    /// Mesh size h = 1/√triangles (only ratios matter).
    pub h: f64,
    pub samples: usize,
    pub mean: f64,
    pub max: f64,
    /// Observed order log(e_prev/e)/log(h_prev/h) of the mean distance against the previous
    /// step of the same series and scheme (none for the first step).
    pub order_mean: Option<f64>,
    /// The same for the largest distance.
    pub order_max: Option<f64>,
}

/// What to measure.
#[derive(Clone, Debug)]
pub struct SweepPlan {
    pub series: Vec<(Series, Vec<u32>)>,
    pub schemes: Vec<Scheme>,
    pub level: u32,
    pub options: SchemeOptions,
}

impl Default for SweepPlan {
    /// The paper's study: every scheme, every series, level 16.
    fn default() -> Self {
        SweepPlan {
            series: Series::all()
                .into_iter()
                .map(|s| (s, s.default_steps()))
                .collect(),
            schemes: Scheme::all(),
            level: STUDY_LEVEL,
            options: SchemeOptions::default(),
        }
    }
}

impl SweepPlan {
    /// Number of (mesh, scheme) measurements.
    pub fn jobs(&self) -> usize {
        self.series.iter().map(|(_, s)| s.len()).sum::<usize>() * self.schemes.len()
    }
}

/// Observed convergence order between two (h, error) pairs; none where it is undefined.
pub fn observed_order(h0: f64, e0: f64, h1: f64, e1: f64) -> Option<f64> {
    let o = (e0 / e1).ln() / (h0 / h1).ln();
    (o.is_finite() && e0 > 0.0 && e1 > 0.0).then_some(o)
}

/// Runs the study. `progress` is called once per finished measurement.
pub fn sweep(
    plan: &SweepPlan,
    evaluator: &dyn Evaluator,
    progress: &mut dyn FnMut(&SweepRow),
) -> Result<Vec<SweepRow>> {
    let mut rows: Vec<SweepRow> = Vec::with_capacity(plan.jobs());
    for (series, steps) in &plan.series {
        let surface = series.surface();
        // Previous (h, mean, max) of each scheme in this series.
        let mut prev: Vec<Option<(f64, f64, f64)>> = vec![None; plan.schemes.len()];
        for &step in steps {
            let mesh = series.mesh(step);
            let triangles = mesh.triangles.len();
            let h = 1.0 / (triangles as f64).sqrt();
            for (k, &scheme) in plan.schemes.iter().enumerate() {
                let table = PatchTable::build(&mesh, scheme, &plan.options)?;
                let d = distance(&table, &surface, plan.level, evaluator)?;
                let (order_mean, order_max) = match prev[k] {
                    Some((h0, m0, x0)) => (
                        observed_order(h0, m0, h, d.mean),
                        observed_order(h0, x0, h, d.max),
                    ),
                    None => (None, None),
                };
                prev[k] = Some((h, d.mean, d.max));
                let row = SweepRow {
                    series: *series,
                    mesh: mesh.name.clone(),
                    scheme,
                    triangles,
                    h,
                    samples: d.samples,
                    mean: d.mean,
                    max: d.max,
                    order_mean,
                    order_max,
                };
                progress(&row);
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

/// The rows as CSV (header line, one line per row; an order that is undefined is empty).
pub fn to_csv(rows: &[SweepRow]) -> String {
    let mut s =
        String::from("series,mesh,scheme,triangles,h,samples,mean,max,order_mean,order_max\n");
    let opt = |o: Option<f64>| o.map(|x| format!("{x:.6}")).unwrap_or_default();
    for r in rows {
        s += &format!(
            "{},{},{},{},{:.9e},{},{:.9e},{:.9e},{},{}\n",
            r.series,
            r.mesh,
            r.scheme,
            r.triangles,
            r.h,
            r.samples,
            r.mean,
            r.max,
            opt(r.order_mean),
            opt(r.order_max)
        );
    }
    s
}
