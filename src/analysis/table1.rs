//! Table 1 of the paper: the continuity protocol of [`super::stats`] run for every scheme
//! on each mesh, rendered as markdown beside the values the paper printed.

use crate::analysis::stats::{EdgeStats, StatsReport};
use crate::eval::Evaluator;
use crate::mesh::{LoadOptions, Mesh};
use crate::patch::{Scheme, SchemeOptions};
use crate::Result;

/// The values the paper printed (min, max, mean, std) for a built-in mesh and scheme, as
/// transcribed in `spec/EVALUATION.md`; `None` where the paper has no row.
pub fn paper_row(mesh: &str, scheme: Scheme) -> Option<[f64; 4]> {
    use Scheme::*;
    Some(match (mesh, scheme) {
        ("sphere320", Phong) => [0.995723, 0.998740, 0.997072, 7.657330e-4],
        ("sphere320", Nagata) => [0.999988, 1.000000, 0.999996, 3.276020e-6],
        ("sphere320", Nlsa) => [0.999958, 1.000000, 0.999979, 9.690380e-6],
        ("sphere320", Pn) => [0.999975, 1.000000, 0.999991, 6.656300e-6],
        ("sphere320", G1) => [0.999999, 1.000000, 1.000000, 1.927585e-16],
        ("torus200", Phong) => [0.915295, 0.999999, 0.987918, 1.578150e-2],
        ("torus200", Nagata) => [0.938828, 1.000000, 0.997556, 8.603600e-3],
        ("torus200", Nlsa) => [0.969450, 1.000000, 0.994738, 6.790900e-3],
        ("torus200", Pn) => [0.989164, 1.000000, 0.998873, 1.846800e-3],
        ("torus200", G1) => [0.999999, 1.000000, 0.999999, 1.710914e-10],
        _ => return None,
    })
}

/// Continuity reports of every scheme in `schemes` on one mesh.
pub fn compare_mesh(
    mesh: &Mesh,
    schemes: &[Scheme],
    opts: &SchemeOptions,
    evaluator: &dyn Evaluator,
) -> Result<Vec<StatsReport>> {
    let stats = EdgeStats::new(mesh);
    schemes
        .iter()
        .map(|&s| stats.report(s, opts, evaluator))
        .collect()
}

/// Loads each mesh and compares every scheme on it (reports mesh by mesh, schemes in order).
pub fn compare(
    meshes: &[String],
    load: &LoadOptions,
    schemes: &[Scheme],
    opts: &SchemeOptions,
    evaluator: &dyn Evaluator,
) -> Result<Vec<StatsReport>> {
    let mut out = Vec::new();
    for spec in meshes {
        let mesh = Mesh::load(spec, load)?;
        out.extend(compare_mesh(&mesh, schemes, opts, evaluator)?);
    }
    Ok(out)
}

/// The reports as markdown: one table per mesh, with the paper's printed row (where it has
/// one) under ours.
pub fn to_markdown(reports: &[StatsReport]) -> String {
    let mut s = String::new();
    let mut current: Option<&str> = None;
    for r in reports {
        if current != Some(r.mesh.as_str()) {
            if current.is_some() {
                s.push('\n');
            }
            current = Some(&r.mesh);
            s += &format!(
                "**{}** ({} triangles, {} interior edges, {} samples)\n\n\
                 | scheme | cos min | cos max | cos mean | cos std | max 1 − cos | max gap |\n\
                 |---|---|---|---|---|---|---|\n",
                r.mesh, r.triangles, r.interior_edges, r.samples
            );
        }
        s += &format!(
            "| {} | {:.6} | {:.6} | {:.6} | {:.6e} | {:.1e} | {:.1e} |\n",
            r.scheme,
            r.cos.min,
            r.cos.max,
            r.cos.mean,
            r.cos.std,
            1.0 - r.cos.min,
            r.max_gap
        );
        let scheme = Scheme::parse(&r.scheme).ok();
        if let Some(p) = scheme.and_then(|sc| paper_row(&r.mesh, sc)) {
            s += &format!(
                "| *paper* | *{:.6}* | *{:.6}* | *{:.6}* | *{:.6e}* | | |\n",
                p[0], p[1], p[2], p[3]
            );
        }
    }
    s
}
