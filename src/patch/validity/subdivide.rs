//! The subdivision of one patch's domain ([`check_within`], [`CellSearch`]): cells
//! examined depth first, each certified by its bound, split into four, or searched for a
//! witness of a fold.

use super::{jacobian, Cell, Geometry, PatchTable, Verdict, Work, WHOLE, WITNESS_DEPTH};

/// [`check_patch`] by subdivision of the patch (`geom`) down to `max_depth` levels or
/// `max_cells` cells: the verdict, the cells examined, and whether it stopped at `stop`
/// cells (undecided then). It examines the cells in the same order whatever `stop` is,
/// so wherever it examines no more than `stop` cells, the verdict is that without it.
pub(super) fn check_within(
    table: &PatchTable,
    i: usize,
    geom: &Geometry,
    max_depth: u32,
    max_cells: usize,
    stop: usize,
) -> (Verdict, usize, bool) {
    CellSearch::new(i, max_depth, max_cells).run(table, geom, stop)
}

/// A cell of the subdivision waiting to be examined: the cell, its depth, and its bound
/// ([`Geometry::bound`]).
type Pending = (Cell, u32, (f64, [f64; 3], bool));

/// The subdivision of one patch ([`check_within`]), which can stop at a number of cells
/// and go on from there: [`CellSearch::run`] with a larger `stop` examines the cells that
/// a new search would examine after those, in the same order, so a search stopped and run
/// again gives what one run with the larger `stop` gives, without examining its first
/// cells twice ([`shared`] keeps the searches it runs again).
pub(super) struct CellSearch {
    pub(super) i: usize,
    max_depth: u32,
    max_cells: usize,
    /// The cells waiting, depth first (the last is examined next); `None` before the
    /// first run.
    stack: Option<Vec<Pending>>,
    cells: usize,
    undecided: bool,
}

impl CellSearch {
    pub(super) fn new(i: usize, max_depth: u32, max_cells: usize) -> CellSearch {
        CellSearch {
            i,
            max_depth,
            max_cells,
            stack: None,
            cells: 0,
            undecided: false,
        }
    }

    /// Goes on until the verdict, or until `stop` cells in all (undecided and stopped:
    /// the search can go on); `geom` is the patch's [`Geometry`] each time.
    pub(super) fn run(
        &mut self,
        table: &PatchTable,
        geom: &Geometry,
        stop: usize,
    ) -> (Verdict, usize, bool) {
        let i = self.i;
        let witness = |b: [f64; 3]| -> Option<Verdict> {
            let (j, scale) = jacobian(table, i, b);
            // Below −1e-12 |S_s| |S_t|: far beyond the rounding of the evaluation.
            (j < -1e-12 * scale).then_some(Verdict::Folded {
                s: b[1],
                t: b[2],
                jacobian: j,
            })
        };
        let mut work = Work::new();
        let stack = match &mut self.stack {
            Some(stack) => stack,
            None => {
                for b in WHOLE.iter().chain([[1.0 / 3.0; 3]].iter()) {
                    if let Some(v) = witness(*b) {
                        return (v, 0, false);
                    }
                }
                // Each cell with its bound, computed with its siblings' (four lanes,
                // `bound4`) when its parent is split; the whole domain's alone.
                self.stack
                    .insert(vec![(WHOLE, 0u32, geom.bound(&WHOLE, &mut work.one))])
            }
        };
        while let Some(next) = stack.pop() {
            if self.cells >= stop {
                // Put back: the next run examines it first.
                stack.push(next);
                return (Verdict::Undecided, self.cells, true);
            }
            let (cell, depth, (lower, b, suspect)) = next;
            self.cells += 1;
            if lower > 0.0
                || geom
                    .normal_part
                    .as_ref()
                    .is_some_and(|q| q.lower(&cell, &mut work.one) > 0.0)
            {
                continue;
            }
            let leaf = depth >= self.max_depth || self.cells + stack.len() + 4 > self.max_cells;
            // Witnesses (two evaluations of the patch) are looked for where the polynomial
            // part itself fails, deep in the subdivision and at a last cell; elsewhere the
            // cell only needs a smaller remainder, which its children get.
            if suspect || leaf || depth >= WITNESS_DEPTH {
                let centroid =
                    std::array::from_fn(|j| (cell[0][j] + cell[1][j] + cell[2][j]) / 3.0);
                for p in [b, centroid] {
                    if let Some(v) = witness(p) {
                        return (v, self.cells, false);
                    }
                }
            }
            if leaf {
                self.undecided = true;
                continue;
            }
            let children = children(&cell);
            let bounds = geom.bound4(&children, &mut work.four);
            for (child, bound) in children.into_iter().zip(bounds) {
                stack.push((child, depth + 1, bound));
            }
        }
        let v = if self.undecided {
            Verdict::Undecided
        } else {
            Verdict::Valid
        };
        (v, self.cells, false)
    }
}

/// The four children of `cell` in the subdivision (midpoints of its edges): the middle one
/// first, then those at its corners 0, 1 and 2.
pub(super) fn children(cell: &Cell) -> [Cell; 4] {
    let mid = |a: [f64; 3], b: [f64; 3]| std::array::from_fn(|j| 0.5 * (a[j] + b[j]));
    let [u0, u1, u2] = *cell;
    let (m01, m12, m20) = (mid(u0, u1), mid(u1, u2), mid(u2, u0));
    [
        [m12, m20, m01],
        [u0, m01, m20],
        [m01, u1, m12],
        [m20, m12, u2],
    ]
}
