//! Per-edge tessellation levels ([`Levels`]): a level per mesh edge and an inner level per
//! patch, given per edge, from a function of the edge, or uniform. How they are chosen
//! (for a tolerance, [`crate::tess::adaptive`]; from the screen, [`crate::tess::screen`])
//! and stitched ([`crate::tess::stitch`]) lives beside.

use glam::DVec3;

use crate::mesh::{Adjacency, Mesh};
use crate::tess::layout::MAX_LEVEL;
use crate::{Error, Result};

/// How a patch's inner level follows from its three edge levels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InnerRule {
    /// The largest edge level (the default: the patch is never coarser inside than on its
    /// finest edge).
    #[default]
    Max,
    /// The mean of the edge levels, rounded to the nearest integer (halves up).
    Mean,
    /// The smallest edge level.
    Min,
}

impl InnerRule {
    /// The inner level for edge levels `e`.
    pub fn inner(self, e: [u32; 3]) -> u32 {
        match self {
            InnerRule::Max => e[0].max(e[1]).max(e[2]),
            InnerRule::Min => e[0].min(e[1]).min(e[2]),
            InnerRule::Mean => ((e[0] as u64 + e[1] as u64 + e[2] as u64 + 1) / 3) as u32,
        }
    }
}

/// One edge, as a level function sees it.
#[derive(Clone, Copy, Debug)]
pub struct EdgeInfo {
    /// Index in the adjacency.
    pub index: usize,
    /// Its vertices, lower id first.
    pub v: [u32; 2],
    /// Their positions.
    pub p: [DVec3; 2],
    /// Triangles using it (1 on a boundary, 3 or more where non-manifold).
    pub triangles: usize,
}

/// A level per edge (indexed like [`Adjacency::edges`]) and an inner level per patch
/// (triangle).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Levels {
    /// Level of each edge, in 1..=[`MAX_LEVEL`].
    pub edges: Vec<u32>,
    /// Inner level of each patch, in 1..=[`MAX_LEVEL`].
    pub inner: Vec<u32>,
}

/// Edge index (in the adjacency) of local edge k of triangle t, at 3t + k.
pub fn patch_edges(triangles: usize, adjacency: &Adjacency) -> Vec<u32> {
    let mut out = vec![u32::MAX; 3 * triangles];
    for (e, edge) in adjacency.edges.iter().enumerate() {
        for u in &edge.uses {
            if let Some(slot) = out.get_mut(3 * u.triangle as usize + u.local as usize) {
                *slot = e as u32;
            }
        }
    }
    out
}

impl Levels {
    /// Every edge and patch at `level`.
    pub fn uniform(adjacency: &Adjacency, triangles: usize, level: u32) -> Levels {
        Levels {
            edges: vec![level; adjacency.edges.len()],
            inner: vec![level; triangles],
        }
    }

    /// Levels from an array per edge; inner levels by `rule`.
    pub fn from_edges(
        mesh: &Mesh,
        adjacency: &Adjacency,
        edges: Vec<u32>,
        rule: InnerRule,
    ) -> Result<Levels> {
        if edges.len() != adjacency.edges.len() {
            return Err(Error::Invalid(format!(
                "{}: {} edge levels for {} edges",
                mesh.name,
                edges.len(),
                adjacency.edges.len()
            )));
        }
        let mut levels = Levels {
            edges,
            inner: Vec::new(),
        };
        levels.set_inner(mesh, adjacency, |_, e| rule.inner(e));
        levels.check(mesh, adjacency)?;
        Ok(levels)
    }

    /// Levels from a function of each edge; inner levels by `rule`.
    pub fn from_fn(
        mesh: &Mesh,
        adjacency: &Adjacency,
        mut level: impl FnMut(&EdgeInfo) -> u32,
        rule: InnerRule,
    ) -> Result<Levels> {
        let edges = adjacency
            .edges
            .iter()
            .enumerate()
            .map(|(index, e)| {
                level(&EdgeInfo {
                    index,
                    v: e.v,
                    p: e.v.map(|v| mesh.positions[v as usize]),
                    triangles: e.uses.len(),
                })
            })
            .collect();
        Levels::from_edges(mesh, adjacency, edges, rule)
    }

    /// Sets every patch's inner level from a function of the patch and its local edge
    /// levels (corner k → k + 1).
    pub fn set_inner(
        &mut self,
        mesh: &Mesh,
        adjacency: &Adjacency,
        mut inner: impl FnMut(usize, [u32; 3]) -> u32,
    ) {
        let pe = patch_edges(mesh.triangles.len(), adjacency);
        self.inner = (0..mesh.triangles.len())
            .map(|t| {
                let e =
                    [0, 1, 2].map(|k| self.edges.get(pe[3 * t + k] as usize).copied().unwrap_or(1));
                inner(t, e)
            })
            .collect();
    }

    /// The level, where every edge and inner level equal it.
    pub fn uniform_level(&self) -> Option<u32> {
        let mut all = self.edges.iter().chain(&self.inner);
        let first = *all.next().unwrap_or(&1);
        all.all(|&l| l == first).then_some(first)
    }

    /// Checks the lengths against `mesh` and every level against 1..=[`MAX_LEVEL`].
    pub fn check(&self, mesh: &Mesh, adjacency: &Adjacency) -> Result<()> {
        if self.edges.len() != adjacency.edges.len() || self.inner.len() != mesh.triangles.len() {
            return Err(Error::Invalid(format!(
                "{}: levels for {} edges and {} patches, the mesh has {} and {}",
                mesh.name,
                self.edges.len(),
                self.inner.len(),
                adjacency.edges.len(),
                mesh.triangles.len()
            )));
        }
        let bad = |what: &str, i: usize, l: u32| {
            Error::Invalid(format!(
                "{}: {what} {i} has level {l} (1..={MAX_LEVEL} expected)",
                mesh.name
            ))
        };
        if let Some((i, &l)) = self
            .edges
            .iter()
            .enumerate()
            .find(|(_, &l)| l == 0 || l > MAX_LEVEL)
        {
            return Err(bad("edge", i, l));
        }
        if let Some((i, &l)) = self
            .inner
            .iter()
            .enumerate()
            .find(|(_, &l)| l == 0 || l > MAX_LEVEL)
        {
            return Err(bad("patch", i, l));
        }
        Ok(())
    }
}
