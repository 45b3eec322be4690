//! The search of the fair G1 optimiser (`crate::analysis::fair` is its public entry; the
//! method, its sources and its measurements are in `docs/fair.md`).
//!
//! It changes only what keeps the surface G1 and watertight by construction: the normals of
//! whole normal groups ([`Groups`]: a group is never split, so a smooth edge stays smooth
//! and no crease is made) and the arm factors of interior edges, the same in both uses (the
//! arm step's rule, `arm.rs`). Every change is kept only where [`Checker::judge`] certifies
//! every patch it touches that was certified before, so no certified patch is lost, and
//! no undecided patch folds; a patch not certified may become certified on the way.
//!
//! 1. *Start*: where the input has uncertified patches, the repair's crease-free phase and
//!    its arm step (never cuts, isolations or flattenings), then every bounded normal
//!    brought back within its bound.
//! 2. *Sweeps*: each normal group in turn (a fixed order), its normal n = normalise(n₀ +
//!    a t₁ + b t₂) over (a, b): four compass points at ± h and the Newton point of the
//!    parabolas through them (per axis), the best of those that lowers the energy of the
//!    patches around the group ([`Energy`]) tried under the certificate;
//!    then each interior edge's two arm factors (log scale) alike. Trials compare first
//!    the number of patches with a node where they fold (fewer is better), then the sum of
//!    the others' energies ([`Score`]). The step h of each
//!    group or edge follows its last move and halves where nothing helps; a move widens
//!    the steps of its neighbours again.
//! 3. The sweeps stop after the given number or when one lowers the total by less than the
//!    tolerance (relative).
//!
//! Sequential in a fixed order (each patch energy of a trial in parallel, summed in
//! order): the result does not depend on the threads. Each trial builds and integrates the
//! few patches around one group or edge, so a sweep is linear in the mesh.

use glam::DVec3;
use rayon::prelude::*;

use super::arm::{arm_summary, set_edge_arms, Edge};
use super::check::Checker;
use super::driver::Search;
use super::geometry::{angle_deg, new_creases};
use super::groups::{set_group, Groups};
use crate::mesh::Mesh;
use crate::patch::validity::Verdict;
use crate::patch::{PatchTable, Scheme, SchemeOptions};
use crate::progress::Progress;
use crate::Result;

/// The energy of one patch from its control points (+∞ where it folds).
pub(crate) type Energy<'a> = &'a (dyn Fn(&[DVec3]) -> f64 + Sync);

/// First step of a normal (radians along the tangent plane) and of a log arm factor.
const FIRST_STEP: [f64; 2] = [0.05, 0.1];
/// Largest step (radians; log factor).
const MAX_STEP: [f64; 2] = [0.25, 0.5];
/// A group or edge whose step falls below this is left alone until a neighbour moves.
const MIN_STEP: f64 = 1e-3;
/// Patches per block where the whole mesh is judged or integrated (bounded memory).
const BLOCK: usize = 1 << 15;

/// What the search is given.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Params {
    /// Largest angle (degrees) between a group's normal and its input one; `None`: free.
    pub bound_deg: Option<f64>,
    /// Most sweeps.
    pub sweeps: usize,
    /// Stop when a sweep lowers the energy by less than this fraction.
    pub tolerance: f64,
    /// Whether the arm factors are searched too.
    pub arms: bool,
    /// Smallest and largest arm factor.
    pub arm_range: [f64; 2],
    /// The G1 scheme's options.
    pub scheme_options: SchemeOptions,
}

/// What the search did.
#[derive(Clone, Debug, Default)]
pub(crate) struct Outcome {
    /// Patches the crease-free start left uncertified (the search's verdict).
    pub start_left: usize,
    /// Groups where the input forces a crease (their triangles' face normals fit in no
    /// open hemisphere); 0 where every input patch is certified.
    pub forced_groups: usize,
    /// Lower bound of the normal change of any repair keeping G1 (degrees).
    pub lower_bound_deg: f64,
    /// Groups whose normal was brought back to the bound after the start.
    pub clamped_groups: usize,
    /// Sweeps run.
    pub sweeps: usize,
    /// Moves kept: normals, arm pairs.
    pub normal_moves: usize,
    pub arm_moves: usize,
    /// Best trials the certificate refused.
    pub refused: usize,
    /// Groups left alone: at a hub.
    pub groups_left_out: usize,
    /// Energy of the patches where it is finite, after the start and at the end.
    pub objective: [f64; 2],
    /// Largest angle between a group's normal and its input one (degrees).
    pub max_normal_change_deg: f64,
    /// Interior edges that are creases at the end and were not in the input.
    pub creases_made: usize,
    /// Interior edges with scaled arms and their factors' range.
    pub arm_edges_scaled: usize,
    pub arm_scale_range: [f64; 2],
}

/// The fair mesh and what the search did (see the module documentation).
/// Reports its phases to `progress`: the crease-free start (no count), the first judging
/// and integration (patches) and each sweep (normal groups, then interior edges).
pub(crate) fn run(
    mesh: &Mesh,
    params: &Params,
    energy: Energy<'_>,
    progress: &dyn Progress,
) -> Result<(Mesh, Outcome)> {
    let mut out = Outcome::default();
    progress.start("fair: start", 0);
    let mut work = match Search::start(mesh, Scheme::G1, &params.scheme_options)? {
        Err(_) => mesh.clone(),
        Ok(mut search) => {
            search.crease_free()?;
            search.bad = search.uncertified();
            if !search.bad.is_empty() {
                search.arm()?;
            }
            out.forced_groups = search.forced.iter().filter(|&&x| x).count();
            out.lower_bound_deg = search.lower_bound_deg();
            search.work
        }
    };
    let groups = Groups::new(mesh);
    let input: Vec<DVec3> = (0..groups.list.len() as u32)
        .map(|g| groups.normal(mesh, g))
        .collect();
    if let Some(b) = params.bound_deg {
        out.clamped_groups = clamp_to_bound(&mut work, &groups, &input, b);
    }
    let cx = Checker::new(mesh, Scheme::G1, &params.scheme_options);
    progress.start("fair: judging", mesh.triangles.len() as u64);
    let (ok, e) = judge_and_integrate(&work, &cx, energy, progress)?;
    out.start_left = ok.iter().filter(|x| x[0] > 0).count();
    let mut st = State {
        work,
        groups,
        input,
        cx,
        energy,
        ok,
        e,
        params: *params,
        steps: Vec::new(),
        edge_steps: Vec::new(),
        sink: Vec::new(),
    };
    st.steps = vec![FIRST_STEP[0]; st.groups.list.len()];
    let edges = interior_edges(&st.work, &st.cx.twins);
    st.edge_steps = vec![FIRST_STEP[1]; edges.len()];
    out.objective[0] = st.objective();
    out.groups_left_out = (0..st.groups.list.len() as u32)
        .filter(|&g| st.ring(g).is_none())
        .count();
    let mut now = out.objective[0];
    let ng = st.groups.list.len();
    let items = ng + if params.arms { edges.len() } else { 0 };
    for sweep in 0..params.sweeps {
        out.sweeps += 1;
        progress.start(
            &format!("fair: sweep {}/{}", sweep + 1, params.sweeps),
            items as u64,
        );
        for g in 0..ng as u32 {
            progress.inc(1);
            match st.normal_step(g)? {
                Step::Moved => out.normal_moves += 1,
                Step::Refused => out.refused += 1,
                Step::Still => {}
            }
        }
        if params.arms {
            for (i, edge) in edges.iter().enumerate() {
                progress.inc(1);
                match st.arm_step(i, edge)? {
                    Step::Moved => out.arm_moves += 1,
                    Step::Refused => out.refused += 1,
                    Step::Still => {}
                }
            }
        }
        let next = st.objective();
        let done = now - next <= params.tolerance * now.abs();
        now = next;
        if done {
            break;
        }
    }
    out.objective[1] = now;
    let State {
        mut work,
        groups,
        input,
        ..
    } = st;
    out.max_normal_change_deg = (0..groups.list.len() as u32)
        .map(|g| angle_deg(input[g as usize], groups.normal(&work, g)))
        .fold(0.0, f64::max);
    if arm_summary(&work).0 == 0 {
        work.attributes.arm_scales = None;
    }
    (out.arm_edges_scaled, out.arm_scale_range) = arm_summary(&work);
    out.creases_made = new_creases(mesh, &work);
    Ok((work, out))
}

/// Brings every group's normal in `work` within `bound` degrees of its input normal
/// (`input`, by group) along the great circle between them; returns how many moved.
fn clamp_to_bound(work: &mut Mesh, groups: &Groups, input: &[DVec3], bound: f64) -> usize {
    let mut sink = Vec::new();
    let mut moved = 0;
    for g in 0..groups.list.len() as u32 {
        let (n0, n) = (input[g as usize], groups.normal(work, g));
        if angle_deg(n0, n) <= bound {
            continue;
        }
        let Some(u) = (n - n.dot(n0) * n0).try_normalize() else {
            continue;
        };
        // A hair inside, so that rounding keeps it within the bound.
        let b = (bound * (1.0 - 1e-9)).to_radians();
        set_group(work, groups, g, n0 * b.cos() + u * b.sin(), &mut sink);
        moved += 1;
    }
    moved
}

/// The [`verdicts`] and the energy of every patch of `work`, in blocks (each reported to
/// `progress` when done).
fn judge_and_integrate(
    work: &Mesh,
    cx: &Checker,
    energy: Energy<'_>,
    progress: &dyn Progress,
) -> Result<(Vec<[u8; 2]>, Vec<f64>)> {
    let nt = work.triangles.len() as u32;
    let (mut ok, mut e) = (Vec::new(), Vec::new());
    for start in (0..nt).step_by(BLOCK) {
        let tris: Vec<u32> = (start..(start + BLOCK as u32).min(nt)).collect();
        let table = cx.ring_patches(work, &tris)?;
        ok.par_extend(
            (0..tris.len())
                .into_par_iter()
                .map(|i| verdicts(cx, work, &table, i, tris[i])),
        );
        e.par_extend(
            (0..tris.len())
                .into_par_iter()
                .map(|i| energy(table.patch(i))),
        );
        progress.inc(tris.len() as u64);
    }
    Ok((ok, e))
}

/// Every interior edge of `work` once (by its lower half-edge), in half-edge order.
fn interior_edges(work: &Mesh, twins: &[u32]) -> Vec<Edge> {
    (0..twins.len() as u32)
        .filter(|&h| twins[h as usize] != u32::MAX && h < twins[h as usize])
        .map(|h| {
            let tri = work.triangles[h as usize / 3];
            let k = h as usize % 3;
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            ([h, twins[h as usize]], [a.min(b), a.max(b)])
        })
        .collect()
}

/// What one group's or edge's turn did.
enum Step {
    Moved,
    Refused,
    Still,
}

/// The search's state.
struct State<'a> {
    work: Mesh,
    groups: Groups,
    /// Input normal of each group.
    input: Vec<DVec3>,
    cx: Checker,
    energy: Energy<'a>,
    /// The [`verdicts`] of each patch.
    ok: Vec<[u8; 2]>,
    /// Energy of each patch.
    e: Vec<f64>,
    params: Params,
    /// Step of each group and of each edge.
    steps: Vec<f64>,
    edge_steps: Vec<f64>,
    sink: Vec<u32>,
}

impl State<'_> {
    /// The energy of the patches where it is finite (in order): the sweeps'
    /// measure of progress.
    fn objective(&self) -> f64 {
        self.e.iter().filter(|e| e.is_finite()).sum()
    }

    /// The patches whose shape the normal of group `g` changes (sorted), or `None` where
    /// the group is left alone: at a hub.
    fn ring(&self, g: u32) -> Option<Vec<u32>> {
        if self.groups.is_hub(self.groups.vertex[g as usize]) {
            return None;
        }
        let mut ring: Vec<u32> = self.groups.triangles_around(g).collect();
        ring.sort_unstable();
        ring.dedup();
        Some(ring)
    }

    /// The [`Score`] of the patches `ring` as they are.
    fn score_of(&self, ring: &[u32]) -> Score {
        score(ring.iter().map(|&t| self.e[t as usize]))
    }

    /// Whether no patch of `ring` gets a worse verdict ([`verdicts`]) on the current mesh:
    /// a certified one stays certified, an undecided one does not fold; where none does,
    /// the verdicts and `es` (the energies) are stored.
    fn keep(&mut self, ring: &[u32], es: Vec<f64>) -> Result<bool> {
        let table = self.cx.ring_patches(&self.work, ring)?;
        let (cx, work) = (&self.cx, &self.work);
        let v: Vec<[u8; 2]> = (0..ring.len())
            .into_par_iter()
            .map(|i| verdicts(cx, work, &table, i, ring[i]))
            .collect();
        let worse = |t: u32, s: &[u8; 2]| {
            let was = self.ok[t as usize];
            s[0] > was[0] || s[1] > was[1]
        };
        if ring.iter().zip(&v).any(|(&t, s)| worse(t, s)) {
            return Ok(false);
        }
        for ((&t, e), s) in ring.iter().zip(es).zip(v) {
            self.ok[t as usize] = s;
            self.e[t as usize] = e;
        }
        Ok(true)
    }

    /// Group `g`'s turn (module documentation, step 2).
    fn normal_step(&mut self, g: u32) -> Result<Step> {
        let h = self.steps[g as usize];
        if h < MIN_STEP {
            return Ok(Step::Still);
        }
        let Some(ring) = self.ring(g) else {
            return Ok(Step::Still);
        };
        let n0 = self.groups.normal(&self.work, g);
        let t1 = n0.any_orthonormal_vector();
        let t2 = n0.cross(t1);
        let at = |x: [f64; 2]| (n0 + x[0] * t1 + x[1] * t2).normalize();
        let (bound, input) = (self.params.bound_deg, self.input[g as usize]);
        let s0 = self.score_of(&ring);
        let trial = compass(h, s0, |x| {
            let n = at(x);
            if bound.is_some_and(|b| angle_deg(input, n) > b) {
                return Ok(None);
            }
            set_group(&mut self.work, &self.groups, g, n, &mut self.sink);
            let es = ring_energies(&self.cx, &self.work, self.energy, &ring);
            set_group(&mut self.work, &self.groups, g, n0, &mut self.sink);
            self.sink.clear();
            es.map(Some)
        })?;
        let Some((x, es)) = trial else {
            self.steps[g as usize] = h / 2.0;
            return Ok(Step::Still);
        };
        set_group(&mut self.work, &self.groups, g, at(x), &mut self.sink);
        self.sink.clear();
        if !self.keep(&ring, es)? {
            set_group(&mut self.work, &self.groups, g, n0, &mut self.sink);
            self.sink.clear();
            self.steps[g as usize] = h / 2.0;
            return Ok(Step::Refused);
        }
        let moved = x[0].hypot(x[1]);
        self.steps[g as usize] = moved.clamp(2.0 * MIN_STEP, MAX_STEP[0]);
        // The groups around may find a better place now.
        for &t in &ring {
            for &v in &self.work.triangles[t as usize] {
                for &o in &self.groups.at_vertex[v as usize] {
                    let s = &mut self.steps[o as usize];
                    *s = s.max(moved.min(MAX_STEP[0]));
                }
            }
        }
        Ok(Step::Moved)
    }

    /// Edge `i`'s turn: its two arm factors (log scale), in both uses.
    fn arm_step(&mut self, i: usize, edge: &Edge) -> Result<Step> {
        let h = self.edge_steps[i];
        let ring = edge.0.map(|h| h / 3);
        if h < MIN_STEP || ring[0] == ring[1] {
            return Ok(Step::Still);
        }
        let ring = [ring[0].min(ring[1]), ring[0].max(ring[1])];
        let x0 = get_arms(&self.work, edge).map(f64::ln);
        let (lo, hi) = (self.params.arm_range[0].ln(), self.params.arm_range[1].ln());
        let s0 = self.score_of(&ring);
        let trial = compass(h, s0, |d| {
            let x = [x0[0] + d[0], x0[1] + d[1]];
            if x.iter().any(|&v| v < lo || v > hi) {
                return Ok(None);
            }
            set_edge_arms(&mut self.work, edge, x.map(f64::exp));
            let es = ring_energies(&self.cx, &self.work, self.energy, &ring);
            set_edge_arms(&mut self.work, edge, x0.map(f64::exp));
            es.map(Some)
        })?;
        let Some((d, es)) = trial else {
            self.edge_steps[i] = h / 2.0;
            return Ok(Step::Still);
        };
        set_edge_arms(
            &mut self.work,
            edge,
            [x0[0] + d[0], x0[1] + d[1]].map(f64::exp),
        );
        if !self.keep(&ring, es)? {
            set_edge_arms(&mut self.work, edge, x0.map(f64::exp));
            self.edge_steps[i] = h / 2.0;
            return Ok(Step::Refused);
        }
        self.edge_steps[i] = d[0].hypot(d[1]).clamp(2.0 * MIN_STEP, MAX_STEP[1]);
        Ok(Step::Moved)
    }
}

/// The [`severity`] of the search's verdict ([`Checker::judge`]) on patch `i` of `table`
/// (triangle `t` of `work`) and of the certificate's alone ([`Checker::certify`]; 0 where
/// the search's is valid): the search counts as undecided a patch whose cubic Lagrange
/// element may fold or that is inside out, whatever the certificate says, so a fold there
/// shows in the second only.
fn verdicts(cx: &Checker, work: &Mesh, table: &PatchTable, i: usize, t: u32) -> [u8; 2] {
    let judged = severity(&cx.judge(table, i, work.corner_normals[t as usize]));
    if judged == 0 {
        return [0, 0];
    }
    [judged, severity(&cx.certify(table, i))]
}

/// 0 for a valid patch, 1 for an undecided one, 2 for a folded one.
fn severity(v: &Verdict) -> u8 {
    match v {
        Verdict::Valid => 0,
        Verdict::Undecided => 1,
        Verdict::Folded { .. } => 2,
    }
}

/// How good the energies of a few patches are: the number that are not finite (a node
/// where the patch folds), then the sum of the others; lower is better, in that order.
type Score = (usize, f64);

/// The [`Score`] of energies `es`.
fn score(es: impl Iterator<Item = f64>) -> Score {
    es.fold((0, 0.0), |(n, sum), e| {
        if e.is_finite() {
            (n, sum + e)
        } else {
            (n + 1, sum)
        }
    })
}

/// The energies of the patches `ring` of `work`, each in parallel (in order).
fn ring_energies(cx: &Checker, work: &Mesh, energy: Energy<'_>, ring: &[u32]) -> Result<Vec<f64>> {
    let table = cx.ring_patches(work, ring)?;
    Ok((0..ring.len())
        .into_par_iter()
        .map(|i| energy(table.patch(i)))
        .collect())
}

/// The arm factors of `edge` in `work` at its lower and higher vertex (1 where none).
fn get_arms(work: &Mesh, edge: &Edge) -> [f64; 2] {
    let h = edge.0[0] as usize;
    let (t, k) = (h / 3, h % 3);
    let s = work
        .attributes
        .arm_scales
        .as_ref()
        .map_or([1.0, 1.0], |a| a[t][k]);
    if work.triangles[t][k] == edge.1[0] {
        s
    } else {
        [s[1], s[0]]
    }
}

/// The compass step of one group or edge: the patch energies `f` gives (or `None` where
/// the point is not allowed) at ± `h` along each of the two coordinates and at the Newton
/// point of the parabolas through them and 0 (whose [`Score`] is `s0`), each coordinate at
/// most 2h; the trial of best score where it is better than `s0` (the sum by more than
/// rounding), else `None`.
fn compass(
    h: f64,
    s0: Score,
    mut f: impl FnMut([f64; 2]) -> Result<Option<Vec<f64>>>,
) -> Result<Option<([f64; 2], Vec<f64>)>> {
    let e0 = s0.1;
    let mut best: Option<([f64; 2], Score, Vec<f64>)> = None;
    // The sum at x for the parabolas: −∞ with fewer non-finite energies than at 0, +∞ with
    // more or where x is not allowed.
    let mut offer = |x: [f64; 2], r: Option<Vec<f64>>| -> f64 {
        let Some(es) = r else {
            return f64::INFINITY;
        };
        let s = score(es.iter().copied());
        let b = best.as_ref().map_or(s0, |b| b.1);
        if s.0 < b.0 || (s.0 == b.0 && s.1 < b.1) {
            best = Some((x, s, es));
        }
        match s.0.cmp(&s0.0) {
            std::cmp::Ordering::Less => f64::NEG_INFINITY,
            std::cmp::Ordering::Equal => s.1,
            std::cmp::Ordering::Greater => f64::INFINITY,
        }
    };
    let mut newton = [0.0; 2];
    for axis in 0..2 {
        let mut x = [0.0; 2];
        x[axis] = h;
        let plus = offer(x, f(x)?);
        x[axis] = -h;
        let minus = offer(x, f(x)?);
        let curv = plus + minus - 2.0 * e0;
        newton[axis] = if plus.is_finite() && minus.is_finite() && curv > 0.0 {
            (0.5 * h * (minus - plus) / curv).clamp(-2.0 * h, 2.0 * h)
        } else if plus < e0.min(minus) {
            h
        } else if minus < e0 {
            -h
        } else {
            0.0
        };
    }
    let on_compass =
        (newton[0] == 0.0 && newton[1].abs() == h) || (newton[1] == 0.0 && newton[0].abs() == h);
    if newton != [0.0; 2] && !on_compass {
        offer(newton, f(newton)?);
    }
    Ok(best
        .filter(|b| b.1 .0 < s0.0 || b.1 .1 < e0 - 1e-12 * e0.abs())
        .map(|(x, _, es)| (x, es)))
}
