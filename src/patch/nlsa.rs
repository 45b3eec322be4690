//! NLSA triangles ("near least squares acceleration", Barrera, Hast & Bengtsson 2002) —
//! a **reconstruction**: the original text could not be consulted.
//!
//! The form used here (`docs/schemes.md`) is a quadratic Bézier triangle with
//! corners P_i and edge points
//! C_ij = (P_i + P_j)/2 − ¼[((P_j − P_i)·n_i) n_i − ((P_j − P_i)·n_j) n_j].
//! It reproduces the paper's NLSA rows of Table 1 to every printed digit, which is the
//! evidence it is the scheme the paper measured. It coincides with Phong tessellation at
//! α = 1/2 (`tests/schemes.rs` checks that). The normal is the exact normal of the geometry.

use glam::DVec3;

use super::quadratic::QuadraticBuilder;
use super::{SchemeOptions, TriangleBuilder};
use crate::mesh::Mesh;
use crate::Result;

/// Edge point of the edge from (pi, ni) to (pj, nj).
pub fn edge_point(pi: DVec3, ni: DVec3, pj: DVec3, nj: DVec3) -> DVec3 {
    let e = pj - pi;
    0.5 * (pi + pj) - 0.25 * (e.dot(ni) * ni - e.dot(nj) * nj)
}

/// The scheme prepared for `mesh` (no options, no fallbacks).
pub fn prepare<'a>(mesh: &'a Mesh, _: &SchemeOptions) -> Result<Box<dyn TriangleBuilder + 'a>> {
    Ok(Box::new(QuadraticBuilder {
        mesh,
        edge_point: |pi, ni, pj, nj| (edge_point(pi, ni, pj, nj), false),
    }))
}
