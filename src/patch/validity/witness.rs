//! The grid searched for a witness of a fold before any subdivision ([`grid_witness`]),
//! with the buffers of the certificate's first stage ([`FirstWork`]).

use glam::DVec3;

use super::{basis, jacobian_with, PatchKind, PatchTable, Scratch, Verdict};

/// Level of the grid searched for a witness before any subdivision.
const WITNESS_GRID: u32 = 8;

/// The points of the grid searched for a witness: (a, b, n − a − b) / n, a and then b
/// rising (n = [`WITNESS_GRID`]).
fn witness_grid() -> impl Iterator<Item = [f64; 3]> {
    let n = WITNESS_GRID;
    (0..=n)
        .flat_map(move |a| (0..=n - a).map(move |b| [a, b, n - a - b].map(|k| k as f64 / n as f64)))
}

/// The buffers of [`super::classify`]: the restriction's, and the basis of a patch kind
/// at the points of [`witness_grid`] (the same for every patch of the kind: computed at
/// the first patch that needs them, instead of at every point of every patch).
pub(super) struct FirstWork {
    pub(super) scratch: Scratch<[DVec3; 2]>,
    grid: Option<(PatchKind, Vec<basis::Weights>)>,
}

impl FirstWork {
    pub(super) fn new() -> FirstWork {
        FirstWork {
            scratch: Scratch::new([DVec3::ZERO; 2]),
            grid: None,
        }
    }

    /// The basis of `kind` at the points of [`witness_grid`], in order.
    fn grid(&mut self, kind: PatchKind) -> &[basis::Weights] {
        if self.grid.as_ref().map(|g| g.0) != Some(kind) {
            self.grid = Some((kind, witness_grid().map(|b| kind.weights(b)).collect()));
        }
        self.grid.as_ref().map_or(&[], |g| &g.1)
    }
}

/// A witness of a fold (as the subdivision takes them: J below −1e-12 |S_s| |S_t| by the
/// patch's own f64 evaluation) at a point of the barycentric grid of level
/// [`WITNESS_GRID`], if there is one: most folded patches show one there, and then need
/// no subdivision. The basis at the grid's points comes from `work`.
pub(super) fn grid_witness(table: &PatchTable, i: usize, work: &mut FirstWork) -> Option<Verdict> {
    witness_grid()
        .zip(work.grid(table.kind))
        .find_map(|(p, w)| {
            let (j, scale) = jacobian_with(table, i, w);
            (j < -1e-12 * scale).then_some(Verdict::Folded {
                s: p[1],
                t: p[2],
                jacobian: j,
            })
        })
}

#[cfg(test)]
mod tests {
    use super::{jacobian_with, witness_grid, FirstWork};
    use crate::{LoadOptions, Mesh, PatchTable, SchemeOptions};

    /// The witness grid's J from the basis computed once per kind ([`FirstWork`]) and
    /// the tangents alone is bitwise J from the patch's whole evaluation at each point
    /// (what the grid search took before), on every Suzanne patch of every scheme.
    #[test]
    fn the_witness_grid_is_the_patch_evaluation() {
        let path = format!("{}/tests/data/suzanne.obj", env!("CARGO_MANIFEST_DIR"));
        let mesh = Mesh::load(&path, &LoadOptions::default()).unwrap();
        let mut work = FirstWork::new();
        let (mut compared, mut patches) = (0, 0);
        for scheme in crate::Scheme::all() {
            let table = PatchTable::build(&mesh, scheme, &SchemeOptions::default()).unwrap();
            let grid = work.grid(table.kind).to_vec();
            assert_eq!(grid.len(), witness_grid().count());
            assert_eq!(grid.len(), 45);
            patches += table.len();
            for i in 0..table.len() {
                for (b, w) in witness_grid().zip(&grid) {
                    let p = table.eval(i, b);
                    let want = (
                        p.ds.cross(p.dt).dot(table.flat_normals[i]),
                        p.ds.length() * p.dt.length(),
                    );
                    let got = jacobian_with(&table, i, w);
                    assert_eq!(got.0.to_bits(), want.0.to_bits(), "{scheme} {i} {b:?}");
                    assert_eq!(got.1.to_bits(), want.1.to_bits(), "{scheme} {i} {b:?}");
                    compared += 1;
                }
            }
        }
        assert_eq!(compared, 45 * patches);
    }
}
