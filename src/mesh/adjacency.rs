//! Edge adjacency: which triangles use each edge, and what is wrong with the topology.
//!
//! Two forms of the same edges, in the same order (by lower vertex, then upper vertex; the
//! uses of an edge by triangle, then local edge):
//! - [`EdgeIndex`]: compact (4 bytes per half-edge and per vertex), built without sorting
//!   the whole mesh, walked in order by [`EdgeIndex::edges`]. Streaming consumers (the
//!   continuity statistics, crease curves) use it.
//! - [`Adjacency`]: every edge materialised as a [`MeshEdge`] (32 bytes each, uses stored
//!   inline), for code that indexes edges.

use std::ops::Deref;
use std::sync::atomic::{AtomicU64, Ordering};

use rayon::prelude::*;

/// One use of an edge by a triangle: the triangle and its local edge k (from corner k to
/// corner k+1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeUse {
    pub triangle: u32,
    pub local: u8,
}

impl EdgeUse {
    /// The use of half-edge `h` = 3 × triangle + local edge.
    #[inline]
    pub fn from_half_edge(h: u32) -> EdgeUse {
        EdgeUse {
            triangle: h / 3,
            local: (h % 3) as u8,
        }
    }

    /// Its half-edge index, 3 × triangle + local edge.
    #[inline]
    pub fn half_edge(self) -> u32 {
        3 * self.triangle + self.local as u32
    }
}

/// The uses of one edge: up to two stored inline (every manifold edge), more on the heap.
/// Dereferences to `[EdgeUse]`.
#[derive(Clone, PartialEq, Eq)]
pub struct EdgeUses(UsesRepr);

#[derive(Clone, PartialEq, Eq)]
enum UsesRepr {
    Inline(u8, [EdgeUse; 2]),
    Heap(Box<[EdgeUse]>),
}

const NO_USE: EdgeUse = EdgeUse {
    triangle: 0,
    local: 0,
};

impl EdgeUses {
    pub fn new(uses: &[EdgeUse]) -> EdgeUses {
        EdgeUses(match *uses {
            [] => UsesRepr::Inline(0, [NO_USE; 2]),
            [a] => UsesRepr::Inline(1, [a, NO_USE]),
            [a, b] => UsesRepr::Inline(2, [a, b]),
            _ => UsesRepr::Heap(uses.into()),
        })
    }
}

impl Deref for EdgeUses {
    type Target = [EdgeUse];
    #[inline]
    fn deref(&self) -> &[EdgeUse] {
        match &self.0 {
            UsesRepr::Inline(n, u) => &u[..*n as usize],
            UsesRepr::Heap(u) => u,
        }
    }
}

impl<'a> IntoIterator for &'a EdgeUses {
    type Item = &'a EdgeUse;
    type IntoIter = std::slice::Iter<'a, EdgeUse>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl From<Vec<EdgeUse>> for EdgeUses {
    fn from(v: Vec<EdgeUse>) -> EdgeUses {
        EdgeUses::new(&v)
    }
}

impl std::fmt::Debug for EdgeUses {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

/// An undirected edge between welded vertices `v[0] < v[1]` and its uses.
#[derive(Clone, Debug)]
pub struct MeshEdge {
    pub v: [u32; 2],
    pub uses: EdgeUses,
}

impl MeshEdge {
    /// Used by exactly two triangles.
    pub fn is_interior(&self) -> bool {
        self.uses.len() == 2
    }
}

/// The counts of edges by kind that the statistics report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EdgeCounts {
    /// Edges used by exactly two triangles.
    pub interior: usize,
    /// Edges used by one triangle.
    pub boundary: usize,
    /// Edges used by three or more triangles.
    pub nonmanifold: usize,
    /// Interior edges whose two triangles run along it in the same direction (inconsistent
    /// orientation).
    pub misoriented: usize,
}

/// The edges of a triangle mesh in compact form: the half-edges (3 × triangle + local edge)
/// grouped by their lower vertex, each group sorted by upper vertex then half-edge. An
/// edge is a run of equal upper vertices in a group.
#[derive(Clone, Debug)]
pub struct EdgeIndex<'a> {
    triangles: &'a [[u32; 3]],
    /// Group of vertex v: `half_edges[offsets[v]..offsets[v + 1]]`.
    offsets: Vec<u32>,
    half_edges: Vec<u32>,
    /// Number of edges.
    pub edges: usize,
    pub counts: EdgeCounts,
}

/// One edge as [`EdgeIndex::edges`] yields it.
#[derive(Clone, Copy, Debug)]
pub struct EdgeRef<'a> {
    /// End vertices, `v[0] < v[1]`.
    pub v: [u32; 2],
    /// Its half-edges (3 × triangle + local edge), increasing.
    pub half_edges: &'a [u32],
}

impl EdgeRef<'_> {
    /// Used by exactly two triangles.
    #[inline]
    pub fn is_interior(&self) -> bool {
        self.half_edges.len() == 2
    }

    /// Use `i` of the edge.
    #[inline]
    pub fn use_at(&self, i: usize) -> EdgeUse {
        EdgeUse::from_half_edge(self.half_edges[i])
    }
}

#[inline]
fn ends(triangles: &[[u32; 3]], h: u32) -> (u32, u32) {
    let tri = triangles[(h / 3) as usize];
    let k = (h % 3) as usize;
    (tri[k], tri[(k + 1) % 3])
}

impl<'a> EdgeIndex<'a> {
    /// Groups the half-edges of `triangles` (a counting sort by lower vertex, then a sort
    /// of each small group), in parallel: ranges of triangles are counted and scattered
    /// each by one task, ranges of vertices sorted and counted each by one task. The
    /// result does not depend on the number of threads (each group is sorted by a key that
    /// orders all its half-edges). Meshes are limited to 2³² / 3 triangles (half-edge ids
    /// are u32), as [`EdgeUse::triangle`] is.
    pub fn new(triangles: &'a [[u32; 3]]) -> EdgeIndex<'a> {
        let n = triangles.len();
        let vertices = triangles
            .par_iter()
            .with_min_len(1 << 14)
            .map(|t| t[0].max(t[1]).max(t[2]))
            .max()
            .map_or(0, |m| m as usize + 1);
        let threads = rayon::current_num_threads().max(1);
        // Triangle ranges: per range, how many of its half-edges each vertex is the lower
        // end of, then (below) where the range writes the first of them.
        let per = n.div_ceil(threads.min(n.div_ceil(1 << 14)).max(1)).max(1);
        let mut cursors: Vec<Vec<u32>> = triangles
            .par_chunks(per)
            .map(|range| {
                let mut count = vec![0u32; vertices];
                for tri in range {
                    for k in 0..3 {
                        count[tri[k].min(tri[(k + 1) % 3]) as usize] += 1;
                    }
                }
                count
            })
            .collect();
        let mut offsets = vec![0u32; vertices + 1];
        let mut total = 0u32;
        for v in 0..vertices {
            offsets[v] = total;
            for c in cursors.iter_mut() {
                let k = c[v];
                c[v] = total;
                total += k;
            }
        }
        offsets[vertices] = total;
        // Each half-edge as the key (upper vertex, half-edge), at its range's cursor in its
        // lower vertex's group: every slot is written by exactly one range.
        let keys: Vec<AtomicU64> = (0..3 * n)
            .into_par_iter()
            .map(|_| AtomicU64::new(0))
            .collect();
        triangles
            .par_chunks(per)
            .zip(cursors.par_iter_mut())
            .enumerate()
            .for_each(|(r, (range, cursor))| {
                for (i, tri) in range.iter().enumerate() {
                    let t = r * per + i;
                    for k in 0..3 {
                        let (a, b) = (tri[k], tri[(k + 1) % 3]);
                        let lo = a.min(b) as usize;
                        let key = (a.max(b) as u64) << 32 | (3 * t + k) as u64;
                        keys[cursor[lo] as usize].store(key, Ordering::Relaxed);
                        cursor[lo] += 1;
                    }
                }
            });
        drop(cursors);
        let mut keys: Vec<u64> = keys.into_iter().map(AtomicU64::into_inner).collect();
        // Vertex ranges: each group ordered by upper vertex, ties by half-edge (that is, by
        // triangle then local edge), and its edges counted.
        let pieces = (4 * threads).clamp(1, vertices.max(1));
        let mut slices = Vec::with_capacity(pieces);
        let mut rest: &mut [u64] = &mut keys;
        for i in 0..pieces {
            let (v0, v1) = (i * vertices / pieces, (i + 1) * vertices / pieces);
            let len = (offsets[v1] - offsets[v0]) as usize;
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(len);
            slices.push((v0..v1, head));
            rest = tail;
        }
        let offsets_ref = &offsets;
        let (edges, counts) = slices
            .into_par_iter()
            .map(|(range, keys)| {
                let base = offsets_ref[range.start] as usize;
                let mut edges = 0usize;
                let mut counts = EdgeCounts::default();
                for v in range {
                    let g = &mut keys
                        [offsets_ref[v] as usize - base..offsets_ref[v + 1] as usize - base];
                    g.sort_unstable();
                    let mut j = 0;
                    while j < g.len() {
                        let upper = g[j] >> 32;
                        let mut e = j + 1;
                        while e < g.len() && g[e] >> 32 == upper {
                            e += 1;
                        }
                        edges += 1;
                        match e - j {
                            1 => counts.boundary += 1,
                            2 => {
                                counts.interior += 1;
                                let forward = |key: u64| ends(triangles, key as u32).0 == v as u32;
                                if forward(g[j]) == forward(g[j + 1]) {
                                    counts.misoriented += 1;
                                }
                            }
                            _ => counts.nonmanifold += 1,
                        }
                        j = e;
                    }
                }
                (edges, counts)
            })
            .reduce(
                || (0, EdgeCounts::default()),
                |a, b| {
                    (
                        a.0 + b.0,
                        EdgeCounts {
                            interior: a.1.interior + b.1.interior,
                            boundary: a.1.boundary + b.1.boundary,
                            nonmanifold: a.1.nonmanifold + b.1.nonmanifold,
                            misoriented: a.1.misoriented + b.1.misoriented,
                        },
                    )
                },
            );
        let half_edges: Vec<u32> = keys.par_iter().map(|&k| k as u32).collect();
        EdgeIndex {
            triangles,
            offsets,
            half_edges,
            edges,
            counts,
        }
    }

    /// The triangles this index was built from.
    pub fn triangles(&self) -> &'a [[u32; 3]] {
        self.triangles
    }

    /// Every edge in order (lower vertex, then upper vertex).
    pub fn edges(&self) -> Edges<'_> {
        Edges {
            index: self,
            vertex: 0,
            pos: 0,
        }
    }
}

/// Iterator over the edges of an [`EdgeIndex`].
#[derive(Clone, Debug)]
pub struct Edges<'i> {
    index: &'i EdgeIndex<'i>,
    vertex: usize,
    pos: usize,
}

impl<'i> Iterator for Edges<'i> {
    type Item = EdgeRef<'i>;

    #[inline]
    fn next(&mut self) -> Option<EdgeRef<'i>> {
        let EdgeIndex {
            triangles,
            offsets,
            half_edges,
            ..
        } = self.index;
        let vertices = offsets.len() - 1;
        while self.vertex < vertices && self.pos >= offsets[self.vertex + 1] as usize {
            self.vertex += 1;
        }
        if self.vertex >= vertices {
            return None;
        }
        let end = offsets[self.vertex + 1] as usize;
        let start = self.pos;
        let upper = |h: u32| {
            let (a, b) = ends(triangles, h);
            a.max(b)
        };
        let hi = upper(half_edges[start]);
        let mut j = start + 1;
        while j < end && upper(half_edges[j]) == hi {
            j += 1;
        }
        self.pos = j;
        Some(EdgeRef {
            v: [self.vertex as u32, hi],
            half_edges: &half_edges[start..j],
        })
    }
}

/// Edges of a triangle mesh with the counts the statistics report.
#[derive(Clone, Debug, Default)]
pub struct Adjacency {
    pub edges: Vec<MeshEdge>,
    /// Edges used by exactly two triangles.
    pub interior: usize,
    /// Edges used by one triangle.
    pub boundary: usize,
    /// Edges used by three or more triangles.
    pub nonmanifold: usize,
    /// Interior edges whose two triangles run along it in the same direction (inconsistent
    /// orientation).
    pub misoriented: usize,
}

impl Adjacency {
    pub fn new(triangles: &[[u32; 3]]) -> Adjacency {
        let index = EdgeIndex::new(triangles);
        let mut buf = Vec::new();
        let edges = index
            .edges()
            .map(|e| {
                buf.clear();
                buf.extend(e.half_edges.iter().map(|&h| EdgeUse::from_half_edge(h)));
                MeshEdge {
                    v: e.v,
                    uses: EdgeUses::new(&buf),
                }
            })
            .collect();
        let c = index.counts;
        Adjacency {
            edges,
            interior: c.interior,
            boundary: c.boundary,
            nonmanifold: c.nonmanifold,
            misoriented: c.misoriented,
        }
    }

    /// The counts by kind.
    pub fn counts(&self) -> EdgeCounts {
        EdgeCounts {
            interior: self.interior,
            boundary: self.boundary,
            nonmanifold: self.nonmanifold,
            misoriented: self.misoriented,
        }
    }

    /// The interior (two-triangle) edges.
    pub fn interior_edges(&self) -> impl Iterator<Item = &MeshEdge> {
        self.edges.iter().filter(|e| e.is_interior())
    }
}
