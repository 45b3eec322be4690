//! The subdivision of one patch's domain ([`CellSearch`]): cells
//! examined depth first, each certified by its bound, split into four, or searched for a
//! witness of a fold; and the subdivisions of many patches within shared budgets
//! ([`check_listed`]).

use rayon::prelude::*;

use super::{
    jacobian, Cell, Geometry, PatchTable, Stage, Verdict, Work, DEEP_CELLS, DEEP_DEPTH, DEEP_FLOOR,
    DEEP_SHARE, FIRST_FLOOR, FIRST_SHARE, MAX_CELLS, MAX_DEPTH, WHOLE, WITNESS_DEPTH,
    WITNESS_FLOOR, WITNESS_SHARE,
};

/// [`super::check_patch`] by subdivision of the patch (`geom`) down to `max_depth` levels or
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
) -> Outcome {
    CellSearch::new(i, max_depth, max_cells).run(table, geom, stop)
}

/// What a search gives: the verdict, the cells examined, whether it stopped at its share.
type Outcome = (Verdict, usize, bool);

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

#[derive(Clone, Copy, Default)]
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

/// What [`CellSearch::run`] did with a cell (a split cell's children are on its stack).
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
    /// The result once the search has ended (not stopped): a search run again gives it.
    done: Option<Outcome>,
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
            done: None,
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

    /// What a recording search recorded since its last stop (a search stopped drops what
    /// it recorded and records afresh from where it goes on, so memory stays with the
    /// searches running).
    pub(super) fn take_memo(&mut self) -> Option<CellMemo> {
        self.memo.take()
    }

    /// Goes on until the verdict, or until `stop` cells in all (undecided and stopped:
    /// the search can go on); `geom` is the patch's [`Geometry`] each time.
    pub(super) fn run(&mut self, table: &PatchTable, geom: &Geometry, stop: usize) -> Outcome {
        if let Some(r) = self.done {
            return r;
        }
        let r = self.go_on(table, geom, stop);
        if !r.2 {
            // Ended: its waiting cells are not needed again.
            self.done = Some(r);
            self.stack = Some(Vec::new());
        }
        r
    }

    /// [`CellSearch::run`] of a search not ended.
    fn go_on(&mut self, table: &PatchTable, geom: &Geometry, stop: usize) -> Outcome {
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
                Some(m) if !records => m.take(&cell).copied(),
                _ => None,
            }
            .unwrap_or_default();
            let mut found = Memo::default();
            let step = 'cell: {
                if lower > 0.0 {
                    break 'cell Step::Certified;
                }
                if let Some(q) = &geom.normal_part {
                    let l = known
                        .normal_part
                        .unwrap_or_else(|| q.lower(&cell, &mut work.one));
                    found.normal_part = Some(l);
                    if l > 0.0 {
                        break 'cell Step::Certified;
                    }
                }
                let leaf = depth >= self.max_depth || self.cells + stack.len() + 4 > self.max_cells;
                // Witnesses (two evaluations of the patch) are looked for where the
                // polynomial part itself fails, deep in the subdivision and at a last cell;
                // elsewhere the cell only needs a smaller remainder, which its children get.
                if (suspect || leaf || depth >= WITNESS_DEPTH) && !known.no_witness {
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
                let children = children(&cell);
                let bounds =
                    (known.children).unwrap_or_else(|| geom.bound4(&children, &mut work.four));
                found.children = Some(bounds);
                for (child, bound) in children.into_iter().zip(bounds) {
                    stack.push((child, depth + 1, bound));
                }
                Step::Split
            };
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

/// The subdivisions of the patches `listed` of `table` (patch index and first stage,
/// neither [`Stage::Done`], in increasing order), within the budgets of a range of `n`
/// patches ([`check_range`]): per listed patch, its verdict, the cells examined, and
/// whether a search stopped at its share. The verdicts depend on the listed patches, their
/// order and `n` only, so a caller may list patches of a table that holds nothing else.
pub(super) fn check_listed(
    table: &PatchTable,
    listed: &[(usize, Stage)],
    n: usize,
) -> Vec<Outcome> {
    let budget = |floor: usize, per_patch: usize| floor.max(per_patch.saturating_mul(n));
    let of = |kind: Stage| -> Vec<usize> {
        (0..listed.len()).filter(|&k| listed[k].1 == kind).collect()
    };
    // Each search keeps its waiting cells between rounds; its patch's geometry is built
    // again for each round (a small part of a round's cells).
    let start =
        |depth: u32, cells: usize| move |k: usize| CellSearch::new(listed[k].0, depth, cells);
    let search = |s: &mut CellSearch, stop: usize| {
        let geom = Geometry::new(table, s.i);
        s.run(table, &geom, stop)
    };
    // A first subdivision records what its cells give; where it leaves its patch undecided
    // (not stopped), the deeper one reads that instead of computing it again, within
    // [`MEMO_CELLS`] cells in all. Which memos are kept can vary from run to run; the
    // verdicts cannot (a memo holds what the computation gives, bit for bit).
    let memos = std::sync::Mutex::new(std::collections::HashMap::new());
    let room = std::sync::atomic::AtomicUsize::new(MEMO_CELLS);
    let first_search = |s: &mut CellSearch, stop: usize| {
        let r = search(s, stop);
        if !r.2 {
            // Finished: the memo goes with it, or to the deeper subdivision.
            let memo = s.take_memo();
            if let (Verdict::Undecided, Some(mut m)) = (r.0, memo) {
                // Charged by what it holds.
                m.cells.shrink_to_fit();
                use std::sync::atomic::Ordering::Relaxed;
                let fits = room
                    .fetch_update(Relaxed, Relaxed, |left| left.checked_sub(m.len()))
                    .is_ok();
                if fits && m.len() > 0 {
                    memos.lock().expect("memo table").insert(s.i, m);
                }
            }
        }
        r
    };
    let mut out = vec![(Verdict::Undecided, 0, false); listed.len()];
    let mut store = |ks: &[usize], results: Vec<Outcome>| {
        for (&k, (v, cells, stopped)) in ks.iter().zip(results) {
            let o = &mut out[k];
            *o = (v, o.1 + cells, stopped);
        }
    };
    // The first subdivisions; those they leave undecided (not stopped) go deeper.
    let ks = of(Stage::First);
    let results = shared(
        &ks,
        budget(FIRST_FLOOR, FIRST_SHARE),
        |k| start(MAX_DEPTH, MAX_CELLS)(k).recording(),
        first_search,
    );
    let deeper: Vec<usize> = ks
        .iter()
        .zip(&results)
        .filter(|(_, r)| r.0 == Verdict::Undecided && !r.2)
        .map(|(&k, _)| k)
        .collect();
    store(&ks, results);
    let ks = of(Stage::Witness);
    let results = shared(
        &ks,
        budget(WITNESS_FLOOR, WITNESS_SHARE),
        start(MAX_DEPTH, MAX_CELLS),
        search,
    );
    store(&ks, results);
    let results = shared(
        &deeper,
        budget(DEEP_FLOOR, DEEP_SHARE),
        |k| {
            let s = start(DEEP_DEPTH, DEEP_CELLS)(k);
            match memos.lock().expect("memo table").remove(&s.i) {
                Some(m) => s.reading(m),
                None => s,
            }
        },
        search,
    );
    store(&deeper, results);
    out
}

/// Cells whose bounds the first subdivisions of a range keep for the deeper ones
/// ([`check_listed`]), at most: about 260 bytes each, so about 70 MB (each memo shrunk to
/// what it holds before it is charged). A first subdivision running records at most
/// [`super::MAX_CELLS`] cells (about 1 MB) until it ends.
const MEMO_CELLS: usize = 1 << 18;

/// Cells of each search in the first round of [`shared`], at most: most patches need a
/// few.
const FIRST_ROUND: usize = 64;

/// Searches that [`shared`] keeps from one round to the next, at most, and runs at once:
/// each holds its waiting cells (at most 3 per level of its subdivision and one more, about
/// 120 bytes each, in a vector of at most 64: about 8 KB), so the kept searches and those
/// running hold at most about 64 MB. Past this many, a search stopped is run again from its
/// start in the next round, which gives the same result for more work.
const KEPT_SEARCHES: usize = 4096;

/// `search(state, stop)` (the verdict, the cells examined, whether it stopped at `stop`) of
/// every patch of `ids`, in parallel, within `budget` cells, each from its `start(i)`. The
/// first round gives each search an equal share of the budget, at most [`FIRST_ROUND`]
/// cells; each further round runs the searches that stopped again, each with an equal
/// share of what the finished ones left over, while that share at least doubles. A search
/// examines its cells in the same order whatever its share, and one that stops goes on
/// from its state in the next round (or, past [`KEPT_SEARCHES`], starts again, repeating
/// its start); only its last count is charged: the work is at most twice the budget, plus
/// the first round.
pub(super) fn shared<S, F>(
    ids: &[usize],
    budget: usize,
    start: impl Fn(usize) -> S + Sync,
    search: F,
) -> Vec<Outcome>
where
    S: Send,
    F: Fn(&mut S, usize) -> Outcome + Sync,
{
    let mut out = vec![(Verdict::Undecided, 0, false); ids.len()];
    // Positions in `ids` of the searches not finished (with the state of those kept), and
    // the cells the finished used.
    let mut open: Vec<(usize, Option<S>)> = (0..ids.len()).map(|k| (k, None)).collect();
    let mut used = 0usize;
    let mut share = 0usize;
    while !open.is_empty() {
        let even = budget.saturating_sub(used) / open.len();
        let next = if share == 0 {
            even.min(FIRST_ROUND)
        } else {
            even
        };
        if next == 0 || next < 2 * share {
            break;
        }
        share = next;
        // In batches of [`KEPT_SEARCHES`], so that the states alive at once stay bounded;
        // a search's state is dropped where it finishes, and the first stopped ones kept.
        let (mut still, mut kept) = (Vec::new(), 0usize);
        let mut rest = open.into_iter();
        loop {
            let batch: Vec<(usize, Option<S>)> = rest.by_ref().take(KEPT_SEARCHES).collect();
            if batch.is_empty() {
                break;
            }
            let results: Vec<(usize, Option<S>, Outcome)> = batch
                .into_par_iter()
                .map(|(k, state)| {
                    let mut state = state.unwrap_or_else(|| start(ids[k]));
                    let r = search(&mut state, share);
                    (k, r.2.then_some(state), r)
                })
                .collect();
            for (k, state, r) in results {
                out[k] = r;
                if r.2 {
                    let keep = kept < KEPT_SEARCHES;
                    kept += keep as usize;
                    still.push((k, state.filter(|_| keep)));
                } else {
                    used += r.1;
                }
            }
        }
        open = still;
    }
    out
}
