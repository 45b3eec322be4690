//! Nagata patches (Nagata 2005), `docs/schemes.md`.
//!
//! Each edge becomes the quadratic x(t) = P_i + (dx − c) t + c t² whose tangents are
//! orthogonal to n_i at t = 0 and to n_j at t = 1 (in the least-squares sense of Nagata's
//! generalised inverse). With dx = P_j − P_i, v = (n_i + n_j)/2, Δv = (n_i − n_j)/2,
//! d = dx·v, Δd = dx·Δv and Δc = n_i·Δv = (1 − n_i·n_j)/2, the curvature coefficient is
//! c = Δd/(1 − Δc) v + d/Δc Δv, and the quadratic Bézier triangle has edge points
//! C_ij = (P_i + P_j)/2 − c/2. The normal is the exact normal of this geometry.
//!
//! Two named schemes:
//! - [`Guard::None`] — "ξ = 0", the paper's row: no crease or singularity treatment. A
//!   term whose denominator is exactly 0 (identical or opposite normals) is 0, and that
//!   edge counts as a fallback. Nearly parallel normals whose edge is not perpendicular to
//!   them make d/Δc blow up: that is the scheme as measured, not a bug.
//! - [`Guard::Bounded`] (`nagata-guarded`) — a guard against that blow-up. Neto et al.
//!   (2013) address this singularity; their text could not be consulted, so the rule here is
//!   ours, stated exactly: the edge is left straight (c = 0, counted as a fallback) where
//!   Nagata's coefficient is both longer than the edge, |c| > |dx| (the edge curve would
//!   turn by more than about 90°), and more than [`GUARD_FACTOR`] times the bend the two
//!   normals imply, |c| > 4 |dx| tan(θ/2) with θ the angle between n_i and n_j
//!   (tan(θ/2) = |Δv|/|v|; a circular arc has exactly |c| = |dx| tan(θ/2)). On the
//!   averaged-normal tori of the distance study it straightens exactly the edges of the
//!   ring on top of the tube (n divisible by 4), where ξ = 0 folds the surface; it never
//!   triggers on the icospheres or on analytic normals. Never substituted for the paper's
//!   row.

use glam::DVec3;

use super::quadratic::QuadraticBuilder;
use super::{SchemeOptions, TriangleBuilder};
use crate::mesh::Mesh;
use crate::Result;

/// How many times the bend implied by the normals (|dx| tan(θ/2)) the guarded variant
/// accepts before it straightens an edge.
pub const GUARD_FACTOR: f64 = 4.0;

/// Singularity treatment of the curvature coefficient.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Guard {
    /// ξ = 0: the bare formula (vanishing denominators only).
    None,
    /// Straight edge where |c| > |dx| and |c| > [`GUARD_FACTOR`] |dx| tan(θ/2).
    Bounded,
}

/// Curvature coefficient c of the edge from (pi, ni) to (pj, nj), and whether a fallback
/// was taken.
pub fn curvature(pi: DVec3, ni: DVec3, pj: DVec3, nj: DVec3, guard: Guard) -> (DVec3, bool) {
    let dx = pj - pi;
    let v = 0.5 * (ni + nj);
    let dv = 0.5 * (ni - nj);
    let d = dx.dot(v);
    let dd = dx.dot(dv);
    let dc = ni.dot(dv);
    let mut fallback = false;
    let mut c = DVec3::ZERO;
    let den = 1.0 - dc;
    if den != 0.0 {
        c += (dd / den) * v;
    } else {
        fallback = true;
    }
    if dc != 0.0 {
        c += (d / dc) * dv;
    } else if ni != nj {
        // Δc can round to 0 for distinct normals; identical normals are the ordinary flat
        // case (Δv = 0), not a fallback.
        fallback = true;
    }
    if guard == Guard::Bounded {
        let (lc, ldx) = (c.length(), dx.length());
        if lc > ldx && lc * v.length() > GUARD_FACTOR * ldx * dv.length() {
            return (DVec3::ZERO, true);
        }
    }
    (c, fallback)
}

/// Edge point C_ij = (P_i + P_j)/2 − c/2.
pub fn edge_point(pi: DVec3, ni: DVec3, pj: DVec3, nj: DVec3, guard: Guard) -> (DVec3, bool) {
    let (c, fallback) = curvature(pi, ni, pj, nj, guard);
    (0.5 * (pi + pj) - 0.5 * c, fallback)
}

fn prepare_with<'a>(mesh: &'a Mesh, guard: Guard) -> Result<Box<dyn TriangleBuilder + 'a>> {
    Ok(Box::new(QuadraticBuilder {
        mesh,
        edge_point: move |pi, ni, pj, nj| edge_point(pi, ni, pj, nj, guard),
    }))
}

/// `nagata`: ξ = 0 ([`Guard::None`]), the paper's row.
pub fn prepare<'a>(mesh: &'a Mesh, _: &SchemeOptions) -> Result<Box<dyn TriangleBuilder + 'a>> {
    prepare_with(mesh, Guard::None)
}

/// `nagata-guarded` ([`Guard::Bounded`]).
pub fn prepare_guarded<'a>(
    mesh: &'a Mesh,
    _: &SchemeOptions,
) -> Result<Box<dyn TriangleBuilder + 'a>> {
    prepare_with(mesh, Guard::Bounded)
}
