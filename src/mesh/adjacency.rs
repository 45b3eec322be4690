//! Edge adjacency: which triangles use each edge, and what is wrong with the topology.
//!
//! Two forms of the same edges, in the same order (by lower vertex, then upper vertex; the
//! uses of an edge by triangle, then local edge):
//! - [`EdgeIndex`]: compact (4 bytes per half-edge and per vertex), built without sorting
//!   the whole mesh, walked in order by [`EdgeIndex::edges`]. Streaming consumers (the
//!   continuity statistics, crease curves) use it.
//! - [`Adjacency`]: every edge materialised as a [`MeshEdge`] (32 bytes each, uses stored
//!   inline), for code that indexes edges.

use std::ops::{Deref, Range};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::par::filled_with;
use rayon::prelude::*;

/// One use of an edge by a triangle: the triangle and its local edge k (from corner k to
/// corner k+1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeUse {
    /// The triangle.
    pub triangle: u32,
    /// Its local edge, 0..3: from corner `local` to corner `local + 1` (mod 3).
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
    /// The uses listed in `uses`, in that order.
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
    /// Its welded vertices, the smaller first.
    pub v: [u32; 2],
    /// The triangles that use it (two for an interior manifold edge).
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

impl EdgeCounts {
    /// The counts of two sets of edges together.
    fn merge(self, o: EdgeCounts) -> EdgeCounts {
        EdgeCounts {
            interior: self.interior + o.interior,
            boundary: self.boundary + o.boundary,
            nonmanifold: self.nonmanifold + o.nonmanifold,
            misoriented: self.misoriented + o.misoriented,
        }
    }
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
    /// Ranges of lower vertices, in order, covering them all, and the number of edges of
    /// each (where [`Adjacency::new`] splits its work).
    pieces: Vec<(Range<usize>, usize)>,
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
        let offsets = group_offsets(&mut cursors, vertices);
        // Each half-edge as the key (upper vertex, half-edge), at its range's cursor in its
        // lower vertex's group: every slot is written by exactly one range.
        let keys: Vec<AtomicU64> = filled_with(3 * n, || AtomicU64::new(0));
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
        let mut keys = crate::par::into_values(keys, AtomicU64::into_inner);
        // Vertex ranges: each group ordered by upper vertex, ties by half-edge (that is, by
        // triangle then local edge), and its edges counted.
        let pieces = (4 * threads).clamp(1, vertices.max(1));
        let ranges: Vec<Range<usize>> = (0..pieces)
            .map(|i| i * vertices / pieces..(i + 1) * vertices / pieces)
            .collect();
        let lens = ranges
            .iter()
            .map(|r| (offsets[r.end] - offsets[r.start]) as usize);
        let parts = split_by(&mut keys, lens);
        let slices: Vec<_> = ranges.iter().cloned().zip(parts).collect();
        let offsets_ref = &offsets;
        let per_piece: Vec<(usize, EdgeCounts)> = slices
            .into_par_iter()
            .map(|(range, keys)| {
                let base = offsets_ref[range.start] as usize;
                let mut edges = 0usize;
                let mut counts = EdgeCounts::default();
                for v in range.clone() {
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
            .collect();
        let edges = per_piece.iter().map(|p| p.0).sum();
        let counts = per_piece
            .iter()
            .fold(EdgeCounts::default(), |a, p| a.merge(p.1));
        let pieces = ranges
            .into_iter()
            .zip(per_piece.iter().map(|p| p.0))
            .collect();
        let half_edges: Vec<u32> = keys.par_iter().map(|&k| k as u32).collect();
        EdgeIndex {
            triangles,
            offsets,
            half_edges,
            edges,
            counts,
            pieces,
        }
    }

    /// Every edge in order (lower vertex, then upper vertex).
    pub fn edges(&self) -> Edges<'_> {
        self.edges_from(0..self.offsets.len() - 1)
    }

    /// The edges whose lower vertex is in `vertices`, in order.
    fn edges_from(&self, vertices: Range<usize>) -> Edges<'_> {
        Edges {
            index: self,
            vertex: vertices.start,
            pos: self.offsets[vertices.start] as usize,
            end: vertices.end,
        }
    }
}

/// `items` cut into consecutive parts of `lens` items each (the lengths must sum to at
/// most its length).
fn split_by<T>(items: &mut [T], lens: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    let mut rest = items;
    lens.map(|len| {
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(len);
        rest = tail;
        head
    })
    .collect()
}

/// Per vertex, where its group of half-edges starts (the last entry: their number), from
/// `cursors`, per range of triangles how many of its half-edges each vertex is the lower
/// end of; each count is replaced by where its range writes the first of them (the groups
/// in vertex order, within a group the ranges in order). In blocks of vertices on the
/// pool, each block from the sum of the counts before it, so the result is the walk's.
fn group_offsets(cursors: &mut [Vec<u32>], vertices: usize) -> Vec<u32> {
    const BLOCK: usize = 1 << 14;
    let blocks = vertices.div_ceil(BLOCK);
    let sums: Vec<u32> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            let r = b * BLOCK..((b + 1) * BLOCK).min(vertices);
            cursors
                .iter()
                .map(|c| c[r.clone()].iter().sum::<u32>())
                .sum()
        })
        .collect();
    let mut starts = Vec::with_capacity(blocks);
    let mut total = 0u32;
    for s in sums {
        starts.push(total);
        total += s;
    }
    // Each block's part of every range's counts.
    let mut parts: Vec<Vec<&mut [u32]>> = (0..blocks).map(|_| Vec::new()).collect();
    for c in cursors.iter_mut() {
        for (part, chunk) in parts.iter_mut().zip(c.chunks_mut(BLOCK)) {
            part.push(chunk);
        }
    }
    let mut offsets = vec![0u32; vertices + 1];
    offsets[..vertices]
        .par_chunks_mut(BLOCK)
        .zip(parts)
        .zip(starts)
        .for_each(|((out, mut part), mut at)| {
            for (v, o) in out.iter_mut().enumerate() {
                *o = at;
                for c in part.iter_mut() {
                    let k = c[v];
                    c[v] = at;
                    at += k;
                }
            }
        });
    offsets[vertices] = total;
    offsets
}

/// Iterator over the edges of an [`EdgeIndex`].
#[derive(Clone, Debug)]
pub struct Edges<'i> {
    index: &'i EdgeIndex<'i>,
    vertex: usize,
    pos: usize,
    /// The vertex after the last whose edges are walked.
    end: usize,
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
        let vertices = self.end;
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
    /// Every edge, ordered by lower vertex id, then upper.
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
    /// The edges of `triangles` and their counts. The edges are materialised in parallel,
    /// each range of lower vertices of the edge index into its own part of the
    /// list, in order.
    pub fn new(triangles: &[[u32; 3]]) -> Adjacency {
        let index = EdgeIndex::new(triangles);
        let empty = MeshEdge {
            v: [0; 2],
            uses: EdgeUses::new(&[]),
        };
        let mut edges = Vec::new();
        (0..index.edges)
            .into_par_iter()
            .map(|_| empty.clone())
            .collect_into_vec(&mut edges);
        // Each piece of lower vertices fills its own edges, in order.
        let parts = split_by(&mut edges, index.pieces.iter().map(|p| p.1));
        let ranges = index.pieces.iter().map(|p| p.0.clone());
        let parts: Vec<_> = ranges.zip(parts).collect();
        parts.into_par_iter().for_each(|(range, out)| {
            let mut buf = Vec::new();
            let mut written = 0;
            for (slot, e) in out.iter_mut().zip(index.edges_from(range)) {
                buf.clear();
                buf.extend(e.half_edges.iter().map(|&h| EdgeUse::from_half_edge(h)));
                *slot = MeshEdge {
                    v: e.v,
                    uses: EdgeUses::new(&buf),
                };
                written += 1;
            }
            // The piece's count is the number of edges its range walks.
            debug_assert_eq!(written, out.len());
        });
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

#[cfg(test)]
mod tests {
    use crate::mesh::adjacency::{EdgeCounts, EdgeIndex, EdgeUse, EdgeUses, MeshEdge};
    use crate::Adjacency;

    /// The edges by the obvious method: every use keyed by its sorted ends, sorted.
    fn reference(triangles: &[[u32; 3]]) -> Vec<([u32; 2], Vec<EdgeUse>)> {
        let mut uses = Vec::new();
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                uses.push((
                    [a.min(b), a.max(b)],
                    EdgeUse::from_half_edge((3 * t + k) as u32),
                ));
            }
        }
        uses.sort_by_key(|&(v, u)| (v, u.half_edge()));
        let mut out: Vec<([u32; 2], Vec<EdgeUse>)> = Vec::new();
        for (v, u) in uses {
            match out.last_mut() {
                Some(last) if last.0 == v => last.1.push(u),
                _ => out.push((v, vec![u])),
            }
        }
        out
    }

    #[test]
    fn index_matches_the_sorted_uses() {
        // Interior, boundary and non-manifold edges, and an unused vertex id (7).
        let tris = [
            [0, 1, 2],
            [0, 2, 3],
            [0, 3, 4],
            [2, 1, 5],
            [1, 2, 6],
            [0, 3, 8],
            [8, 9, 4],
        ];
        let index = EdgeIndex::new(&tris);
        let adj = Adjacency::new(&tris);
        let expect = reference(&tris);
        assert_eq!(index.edges, expect.len());
        assert_eq!(adj.edges.len(), expect.len());
        for ((e, m), (v, u)) in index.edges().zip(&adj.edges).zip(&expect) {
            assert_eq!(e.v, *v);
            assert_eq!(m.v, *v);
            let got: Vec<EdgeUse> = (0..e.half_edges.len()).map(|i| e.use_at(i)).collect();
            assert_eq!(&got, u);
            assert_eq!(&m.uses[..], &u[..]);
        }
        // Edges: 01 02 03 04 08 12 15 16 23 25 26 34 38 48 49 89 (16); 02 is interior,
        // 03 (triangles 1, 2, 5) and 12 (triangles 0, 3, 4) are non-manifold.
        assert_eq!(
            index.counts,
            EdgeCounts {
                interior: 1,
                boundary: 13,
                nonmanifold: 2,
                misoriented: 0,
            }
        );
        assert_eq!(adj.counts(), index.counts);
        // A reversed copy of a triangle on the same edge is misoriented.
        let flipped = EdgeIndex::new(&[[0, 1, 2], [1, 0, 3]]);
        assert_eq!(flipped.counts.misoriented, 0);
        let same = EdgeIndex::new(&[[0, 1, 2], [0, 1, 3]]);
        assert_eq!(same.counts.misoriented, 1);
    }

    #[test]
    fn parallel_index_matches_the_sorted_uses() {
        // 60000 triangles on 9000 vertex ids (multiples of 5 up to 44995, so that the ids
        // span three blocks of `group_offsets`) from a fixed pseudo-random sequence: up to
        // four triangle ranges (of 15,000 triangles or more) and 4 × threads vertex ranges,
        // interior, boundary, non-manifold and misoriented edges all present.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % 9000) as u32 * 5
        };
        let tris: Vec<[u32; 3]> = (0..60000)
            .map(|_| loop {
                let t = [next(), next(), next()];
                if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                    break t;
                }
            })
            .collect();
        let expect = reference(&tris);
        let mut counts = EdgeCounts::default();
        for (_, u) in &expect {
            match u.len() {
                1 => counts.boundary += 1,
                2 => {
                    counts.interior += 1;
                    let fwd = |u: EdgeUse| {
                        let t = tris[u.triangle as usize];
                        t[u.local as usize] < t[(u.local as usize + 1) % 3]
                    };
                    if fwd(u[0]) == fwd(u[1]) {
                        counts.misoriented += 1;
                    }
                }
                _ => counts.nonmanifold += 1,
            }
        }
        assert!(counts.interior > 0 && counts.nonmanifold > 0 && counts.misoriented > 0);
        for threads in [1, 2, 3, 5, 16] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (index, adj) = pool.install(|| (EdgeIndex::new(&tris), Adjacency::new(&tris)));
            assert_eq!(index.edges, expect.len());
            assert_eq!(index.counts, counts);
            assert_eq!(adj.edges.len(), expect.len());
            assert_eq!(adj.counts(), counts);
            for ((e, m), (v, u)) in index.edges().zip(&adj.edges).zip(&expect) {
                assert_eq!(e.v, *v);
                assert_eq!(m.v, *v);
                let got: Vec<EdgeUse> = (0..e.half_edges.len()).map(|i| e.use_at(i)).collect();
                assert_eq!(&got, u);
                assert_eq!(&m.uses[..], &u[..]);
            }
        }
    }

    #[test]
    fn uses_are_compact() {
        assert!(std::mem::size_of::<MeshEdge>() <= 32);
        let many = [
            EdgeUse::from_half_edge(1),
            EdgeUse::from_half_edge(5),
            EdgeUse::from_half_edge(9),
        ];
        for n in 0..=3 {
            let u = EdgeUses::new(&many[..n]);
            assert_eq!(&u[..], &many[..n]);
            assert_eq!((&u).into_iter().count(), n);
        }
    }
}
