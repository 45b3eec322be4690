//! Bounds: the Jacobian bound of the cubic Lagrange element through a patch (which the
//! search also asks to be positive), and the lower bound of the normal change of any
//! repair that keeps G1 (reported; see docs/repair.md for the proof).

use std::collections::HashMap;

use glam::DVec3;

use super::geometry::{angle_deg, max_min_direction};
use super::groups::Groups;
use crate::mesh::adjacency::EdgeIndex;
use crate::mesh::creases::normal_key;
use crate::mesh::Mesh;
use crate::patch::basis::Weights;
use crate::patch::lagrange::{triangle_nodes, JacobianBound};
use crate::patch::{PatchKind, PatchTable, Scheme};

/// Smallest [`ElementBound::of`] the search accepts: far above the rounding of this and of
/// `export-msh`'s computation of the same coefficients.
pub(super) const LAGRANGE_MARGIN: f64 = 1e-6;

/// Scaled Jacobian of the cubic Lagrange element ([`ElementBound::of`]) that the
/// crease-free phase's measure aims at for G1 patches: a margin above [`LAGRANGE_MARGIN`].
const LAGRANGE_AIM: f64 = 0.01;

/// The bound `export-msh` reports as the minimum scaled Jacobian of the cubic Lagrange
/// triangle through a patch at its nodes (the element of order 3 that `export-msh`
/// writes): where it is positive the element cannot fold. Built once per repair.
pub(super) struct ElementBound {
    bound: JacobianBound,
    /// The element's nodes (barycentric).
    nodes: Vec<[f64; 3]>,
    /// The G1 basis weights at the nodes (G1's kind is the only one the search asks
    /// about; any other is evaluated plainly, bitwise the same).
    gregory: Vec<Weights>,
}

impl ElementBound {
    pub(super) fn new() -> ElementBound {
        let nodes: Vec<[f64; 3]> = triangle_nodes(3)
            .iter()
            .map(|&[a, b]| {
                let (u, v) = (a as f64 / 3.0, b as f64 / 3.0);
                [1.0 - u - v, u, v]
            })
            .collect();
        ElementBound {
            bound: JacobianBound::new(3),
            gregory: nodes
                .iter()
                .map(|&b| PatchKind::Gregory.weights(b))
                .collect(),
            nodes,
        }
    }

    /// The bound ([`crate::patch::lagrange::JacobianBound`]) of the cubic Lagrange
    /// triangle through patch `i` of `table` at its nodes.
    pub(super) fn of(&self, table: &PatchTable, i: usize) -> f64 {
        let x: Vec<DVec3> = if table.kind != PatchKind::Gregory {
            self.nodes.iter().map(|&b| table.eval(i, b).p).collect()
        } else {
            self.gregory
                .iter()
                .map(|w| table.eval_weights(i, w).p)
                .collect()
        };
        self.bound.min_scaled(&x, table.flat_normals[i])
    }

    /// The crease-free phase's addition to the grid measure for G1: for each patch whose
    /// cubic Lagrange element's bound is below [`LAGRANGE_AIM`], 10 times its shortfall
    /// (the certificate's refusals there sit between the grid's points, or in the element).
    pub(super) fn shortfall(&self, table: &PatchTable) -> f64 {
        if table.scheme != Scheme::G1 {
            return 0.0;
        }
        (0..table.len())
            .map(|i| 10.0 * (LAGRANGE_AIM - self.of(table, i)).max(0.0))
            .sum()
    }
}

/// Largest smallest cosine below which a set of unit face normals counts as fitting in no
/// open hemisphere ([`max_min_direction`]): far below any cosine a certified corner needs
/// (J at a corner is proportional to its square) and far above the rounding of face
/// normals (two copies of one triangle in both orders give exactly opposite normals, or
/// opposite to about 1e-16).
const NO_HEMISPHERE: f64 = 1e-12;

/// What any repair that keeps G1 (turns no smooth edge into a crease) must change, from
/// the input's corner normals and face normals: the report's
/// [`super::RepairReport::normal_change_lower_bound_deg`] (in degrees), and the groups
/// whose triangles' face normals fit in no open hemisphere (a crease is forced there;
/// [`super::RepairReport::crease_forced_groups`] counts them).
///
/// At each corner not between two crease edges the repaired normal must be within 90° of
/// the face normal or beyond it, with one choice per component of triangles joined by
/// smooth edges (docs/repair.md, "What no repair that keeps G1 can avoid"): the bound is
/// the largest, over components, of the smaller of the largest θ − 90° and the largest
/// 90° − θ over their corners (θ the input angle between normal and face normal).
pub(super) fn corner_bound(mesh: &Mesh, faces: &[DVec3], groups: &Groups) -> (f64, Vec<bool>) {
    let nt = mesh.triangles.len();
    // Crease half-edges (an interior edge whose two uses disagree on an end's normal) and
    // the components of triangles joined by smooth interior edges (union–find).
    let mut crease = vec![false; 3 * nt];
    let mut parent: Vec<u32> = (0..nt as u32).collect();
    fn root(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for e in EdgeIndex::new(&mesh.triangles).edges() {
        if !e.is_interior() {
            continue;
        }
        let [u0, u1] = [e.use_at(0), e.use_at(1)];
        let split = e.v.iter().any(|&v| {
            normal_key(crate::mesh::creases::use_normal(mesh, u0, v))
                != normal_key(crate::mesh::creases::use_normal(mesh, u1, v))
        });
        if split {
            crease[e.half_edges[0] as usize] = true;
            crease[e.half_edges[1] as usize] = true;
        } else {
            let (a, b) = (
                root(&mut parent, u0.triangle),
                root(&mut parent, u1.triangle),
            );
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    // Per component: the largest θ − 90° and 90° − θ over its constrained corners.
    let mut worst: HashMap<u32, (f64, f64)> = HashMap::new();
    for t in 0..nt {
        for k in 0..3 {
            if (crease[3 * t + k] && crease[3 * t + (k + 2) % 3])
                || faces[t].length_squared() < 0.25
            {
                continue;
            }
            let theta = angle_deg(mesh.corner_normals[t][k], faces[t]);
            let r = root(&mut parent, t as u32);
            let e = worst.entry(r).or_insert((0.0, 0.0));
            e.0 = e.0.max(theta - 90.0);
            e.1 = e.1.max(90.0 - theta);
        }
    }
    let bound = worst.values().map(|&(p, q)| p.min(q)).fold(0.0, f64::max);
    let forced = (0..groups.list.len() as u32)
        .map(|g| {
            // Degenerate triangles (zero face normal) face every way.
            let f: Vec<DVec3> = groups.face_normals(g, faces).collect();
            let n = groups.normal(mesh, g);
            // Quick case: the group's own normal faces all of them.
            if f.iter().all(|x| x.dot(n) > NO_HEMISPHERE) {
                return false;
            }
            max_min_direction(&f).is_none_or(|(_, v)| v <= NO_HEMISPHERE)
        })
        .collect();
    (bound, forced)
}
