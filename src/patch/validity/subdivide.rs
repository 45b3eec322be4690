//! The subdivision of one patch's domain ([`CellSearch`]): cells
//! examined depth first, each certified by its bound, split into four, or searched for a
//! witness of a fold.

use super::{jacobian, Cell, Geometry, PatchTable, Verdict, Work, WHOLE, WITNESS_DEPTH};

/// [`check_patch`] by subdivision of the patch (`geom`) down to `max_depth` levels or
/// `max_cells` cells: the verdict, the cells examined, and whether it stopped at `stop`
/// cells (undecided then). It examines the cells in the same order whatever `stop` is,
/// so wherever it examines no more than `stop` cells, the verdict is that without it.
#[cfg(test)]
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

/// A cell's bound ([`Geometry::bound`]).
type Bound = (f64, [f64; 3], bool);

/// A cell of the subdivision waiting to be examined: the cell, its depth, and its bound.
type Pending = (Cell, u32, Bound);

/// What a subdivision found on the cells it examined, kept so that a deeper subdivision of
/// the same patch ([`super::DEEP_DEPTH`]), which examines the same cells in the same order
/// (with the subtrees of the cells it splits further between them), need not compute it
/// again: per cell, in the order examined, its children's bounds where it was split, its
/// normal part's lower bound where it was computed, and whether its witness points were
/// evaluated (without a fold, or the subdivision would have ended there). Each is what the
/// computation gives, bit for bit, so a subdivision that reads it gives what one without
/// it gives.
#[derive(Default)]
pub(super) struct CellMemo {
    cells: Vec<(Cell, Memo)>,
    /// The next of `cells` that a reading search has not met.
    next: usize,
}

#[derive(Default)]
struct Memo {
    children: Option<[Bound; 4]>,
    normal_part: Option<f64>,
    no_witness: bool,
}

impl CellMemo {
    /// Cells remembered.
    pub(super) fn len(&self) -> usize {
        self.cells.len()
    }

    /// What was found on `cell`, if it is the next cell remembered (a cell is met once).
    fn take(&mut self, cell: &Cell) -> Option<&Memo> {
        let (c, m) = self.cells.get(self.next)?;
        if c != cell {
            return None;
        }
        self.next += 1;
        Some(m)
    }
}

/// A recording search records the cells it examines after this many: most subdivisions
/// end before (on the 2 M-triangle ogre, the first subdivisions that leave their patch
/// undecided take 797 to 4,093 cells), and recording costs a little on each cell.
const RECORD_AFTER: usize = 512;

/// What [`CellSearch::run`] does with a cell (a split cell's children's bounds are in its
/// [`Memo`]).
enum Step {
    Certified,
    Folded(Verdict),
    Leaf,
    Split,
}

/// The subdivision of one patch ([`super::check_patch`]), which can stop at a number of cells
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
    /// What the cells examined gave, where the search records it ([`CellSearch::recording`])
    /// or reads it ([`CellSearch::reading`]).
    memo: Option<CellMemo>,
    /// Whether `memo` is being written (else read).
    records: bool,
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
            memo: None,
            records: false,
        }
    }

    /// A search that records what its cells give ([`CellSearch::take_memo`]).
    pub(super) fn recording(mut self) -> CellSearch {
        self.memo = Some(CellMemo::default());
        self.records = true;
        self
    }

    /// A search that reads what `memo` (recorded by a search of the same patch) holds
    /// instead of computing it again.
    pub(super) fn reading(mut self, memo: CellMemo) -> CellSearch {
        self.memo = Some(memo);
        self.records = false;
        self
    }

    /// What a recording search recorded (nothing after a stop: a search stopped records
    /// afresh from where it goes on, so memory stays with the searches running).
    pub(super) fn take_memo(&mut self) -> Option<CellMemo> {
        self.memo.take()
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
        let records = self.records;
        while let Some(next) = stack.pop() {
            if self.cells >= stop {
                // Put back: the next run examines it first.
                stack.push(next);
                if records {
                    // What it held is dropped; the search records again from here.
                    self.memo = Some(CellMemo::default());
                }
                return (Verdict::Undecided, self.cells, true);
            }
            let (cell, depth, (lower, b, suspect)) = next;
            self.cells += 1;
            // What a recording search found here (read by a deeper one).
            let known = match &mut self.memo {
                Some(m) if !records => m
                    .take(&cell)
                    .map(|m| (m.normal_part, m.children, m.no_witness)),
                _ => None,
            };
            let (known_np, known_children, no_witness) = known.unwrap_or((None, None, false));
            let mut found = Memo::default();
            let step = 'cell: {
                if lower > 0.0 {
                    break 'cell Step::Certified;
                }
                if let Some(q) = &geom.normal_part {
                    let l = known_np.unwrap_or_else(|| q.lower(&cell, &mut work.one));
                    found.normal_part = Some(l);
                    if l > 0.0 {
                        break 'cell Step::Certified;
                    }
                }
                let leaf = depth >= self.max_depth || self.cells + stack.len() + 4 > self.max_cells;
                // Witnesses (two evaluations of the patch) are looked for where the
                // polynomial part itself fails, deep in the subdivision and at a last cell;
                // elsewhere the cell only needs a smaller remainder, which its children get.
                if (suspect || leaf || depth >= WITNESS_DEPTH) && !no_witness {
                    let centroid =
                        std::array::from_fn(|j| (cell[0][j] + cell[1][j] + cell[2][j]) / 3.0);
                    for p in [b, centroid] {
                        if let Some(v) = witness(p) {
                            break 'cell Step::Folded(v);
                        }
                    }
                    found.no_witness = true;
                }
                if leaf {
                    break 'cell Step::Leaf;
                }
                let bounds =
                    known_children.unwrap_or_else(|| geom.bound4(&children(&cell), &mut work.four));
                found.children = Some(bounds);
                Step::Split
            };
            if let Step::Split = step {
                let bounds = found.children.expect("a split cell's children's bounds");
                for (child, bound) in children(&cell).into_iter().zip(bounds) {
                    stack.push((child, depth + 1, bound));
                }
            }
            if let (true, Some(m)) = (records && self.cells > RECORD_AFTER, &mut self.memo) {
                if found.normal_part.is_some() || found.children.is_some() || found.no_witness {
                    m.cells.push((cell, found));
                }
            }
            match step {
                Step::Folded(v) => return (v, self.cells, false),
                Step::Leaf => self.undecided = true,
                Step::Certified | Step::Split => {}
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
