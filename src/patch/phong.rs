//! Phong tessellation (Boubekeur & Alexa 2008), `docs/schemes.md`.
//!
//! The linear triangle p(b) = Σ b_i P_i is projected onto the tangent plane of each corner,
//! π_i(q) = q − ((q − P_i)·n_i) n_i, and blended back with shape factor α:
//! S(b) = (1 − α) p(b) + α Σ b_i π_i(p(b)). That is a quadratic Bézier triangle with corners
//! P_i and edge points
//! C_ij = (P_i + P_j)/2 − (α/2)[((P_j − P_i)·n_i) n_i + ((P_i − P_j)·n_j) n_j].
//! α = 3/4 is the paper's value (Table 1 matches only with it); α = 0 is the flat triangle.
//! The normal reported is the exact normal of this geometry, not an interpolated one.

use glam::DVec3;

use super::quadratic::QuadraticBuilder;
use super::{SchemeOptions, TriangleBuilder};
use crate::mesh::Mesh;
use crate::{Error, Result};

/// Edge point of the edge from (pi, ni) to (pj, nj).
pub fn edge_point(pi: DVec3, ni: DVec3, pj: DVec3, nj: DVec3, alpha: f64) -> DVec3 {
    let e = pj - pi;
    0.5 * (pi + pj) - (0.5 * alpha) * (e.dot(ni) * ni + (-e).dot(nj) * nj)
}

/// The scheme prepared for `mesh` with the shape factor of `opts` (which must be finite).
pub fn prepare<'a>(mesh: &'a Mesh, opts: &SchemeOptions) -> Result<Box<dyn TriangleBuilder + 'a>> {
    let alpha = opts.phong_alpha;
    if !alpha.is_finite() {
        return Err(Error::Invalid(format!(
            "phong: shape factor α must be finite, got {alpha}"
        )));
    }
    Ok(Box::new(QuadraticBuilder {
        mesh,
        edge_point: move |pi, ni, pj, nj| (edge_point(pi, ni, pj, nj, alpha), false),
    }))
}
