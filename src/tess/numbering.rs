//! The numbering of the stitched output, from the topology alone and independent of the
//! levels: which records and positions each patch makes or takes, where every item starts
//! at any levels, and which grid point is which corner, edge sample or interior point. The
//! CPU stitcher ([`crate::tess::stitch::StitchPlan`]) resolves it for one set of levels;
//! the GPU tessellator's topology table (`gpu::tessellator::Topology`) is filled from it
//! and resolved on the device at every level.
//!
//! **Order.** Patches are visited in order, and within a patch corners 0, 1, 2, edges 0, 1,
//! 2, then the interior. Each visit makes an *item* or takes one made before:
//! - a corner takes the corner item of its (vertex, corner normal, corner attributes), made
//!   by the first corner with that key;
//! - an edge use takes the block of its edge's first use (its *owner*), or makes its own
//!   where the edge is split (its triangles disagree on an end normal or an end's
//!   attributes: a crease, a UV seam); a block holds the edge's samples from its lower vertex
//!   id to the other (canonical order);
//! - every patch makes its interior (its points in grid order).
//!
//! Records follow that order ([`Numbering::records()`]); positions follow the same order with
//! one corner item per vertex and one block per edge ([`Numbering::positions`]).
//!
//! **Level independence.** An item is known by what was made before it ([`Item`]): a corner
//! items, b blocks and c interiors. Its first id is a plus the sizes of those b blocks and c
//! interiors ([`Bases`]): `a + b (n − 1) + c (n − 1)(n − 2)/2` on the grid of level n, prefix
//! sums of the blocks' E − 1 and the interiors' sample counts with per-edge levels.

use std::collections::HashMap;
use std::ops::Range;
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering::Relaxed};

use rayon::prelude::*;

use crate::eval::pattern::grid_index;
use crate::mesh::creases::{normal_key, split_ends};
use crate::mesh::{Adjacency, CornerAttributes, EdgeUse, Mesh};
use crate::par::filled_with;
use crate::{Error, Result};

const NONE: u32 = u32::MAX;

/// An item of the stitched order, by what was made before it: `a` corner items, `b` blocks
/// and `c` interiors (c is the patch that made it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Item {
    pub a: u32,
    pub b: u32,
    pub c: u32,
}

/// The sizes items take: every block and interior alike (a grid level), or each its own
/// (per-edge levels), as exclusive prefix sums.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Bases {
    /// Ids per block and per interior.
    Uniform { block: u64, interior: u64 },
    /// `blocks[b]`: ids in blocks 0..b; `interiors[c]`: ids in interiors 0..c.
    Prefix {
        blocks: Vec<u64>,
        interiors: Vec<u64>,
    },
}

/// Interior points of the grid of level n: (n − 1)(n − 2)/2.
pub fn interior_len(n: u32) -> u64 {
    let n = n.max(1) as u64;
    (n - 1) * n.saturating_sub(2) / 2
}

impl Bases {
    /// The grid of level n (≥ 1) everywhere: n − 1 samples per block, (n − 1)(n − 2)/2 per
    /// interior.
    pub fn grid(n: u32) -> Bases {
        Bases::Uniform {
            block: n.max(1) as u64 - 1,
            interior: interior_len(n),
        }
    }

    /// Each block and interior its own size, in the order they were made.
    pub fn prefix(
        blocks: impl IntoIterator<Item = u64>,
        interiors: impl IntoIterator<Item = u64>,
    ) -> Bases {
        let scan = |sizes: &mut dyn Iterator<Item = u64>| {
            let mut sum = 0u64;
            let mut out = vec![0];
            out.extend(sizes.map(|s| {
                sum += s;
                sum
            }));
            out
        };
        Bases::Prefix {
            blocks: scan(&mut blocks.into_iter()),
            interiors: scan(&mut interiors.into_iter()),
        }
    }

    /// First id of `item` (at the end of the order: the total).
    pub fn base(&self, item: Item) -> u64 {
        let (a, b, c) = (item.a as u64, item.b as usize, item.c as usize);
        match self {
            Bases::Uniform { block, interior } => a + b as u64 * block + c as u64 * interior,
            Bases::Prefix { blocks, interiors } => a + blocks[b] + interiors[c],
        }
    }
}

/// One numbering of the stitched order (records or positions): the item each corner and
/// edge use takes, and where each item was made.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Order {
    /// Per corner 3t + k: its corner item.
    pub corner: Vec<u32>,
    /// Per corner item: the corner (3t + k) that made it.
    pub corner_first: Vec<u32>,
    /// Per edge use 3t + k: its block.
    pub block: Vec<u32>,
    /// Per block: the edge use that made it.
    pub block_first: Vec<u32>,
    /// Per patch: the corner items and blocks made before its interior.
    pub interior: Vec<[u32; 2]>,
}

/// An empty vector with room for `n` items, its memory mapped in on the pool
/// ([`filled_with`]): the walks below, which push in one task, find its pages mapped.
/// Those page faults were about a third of the 2-thread walk's samples on a 2 M-triangle
/// mesh.
fn room<T: Default + Send>(n: usize) -> Vec<T> {
    let mut v = filled_with(n, T::default);
    v.clear();
    v
}

impl Order {
    fn with_capacity(patches: usize) -> Order {
        Order {
            corner: room(3 * patches),
            block: room(3 * patches),
            interior: room(patches),
            ..Order::default()
        }
    }

    fn make_corner(&mut self, corner: usize) -> u32 {
        self.corner_first.push(corner as u32);
        self.corner_first.len() as u32 - 1
    }

    fn make_block(&mut self, edge_use: usize) -> u32 {
        self.block_first.push(edge_use as u32);
        self.block_first.len() as u32 - 1
    }

    /// Ends the corners of a patch: its corner items are made.
    fn end_corners(&mut self) {
        self.interior.push([self.corner_first.len() as u32, 0]);
    }

    /// Ends the edges of patch `t` (after [`end_corners`](Self::end_corners) of every
    /// patch): its blocks are made.
    fn end_patch(&mut self, t: usize) {
        self.interior[t][1] = self.block_first.len() as u32;
    }

    /// The item of corner `corner` (3t + k).
    pub fn corner_item(&self, corner: usize) -> Item {
        let a = self.corner[corner];
        let c = self.corner_first[a as usize] / 3;
        // Made among patch c's corners: after every block of the patches before.
        let b = match c {
            0 => 0,
            _ => self.interior[c as usize - 1][1],
        };
        Item { a, b, c }
    }

    /// The block of edge use `edge_use` (3t + k).
    pub fn block_item(&self, edge_use: usize) -> Item {
        let b = self.block[edge_use];
        let c = self.block_first[b as usize] / 3;
        // Made among patch c's edges: after all its corners.
        Item {
            a: self.interior[c as usize][0],
            b,
            c,
        }
    }

    /// The interior of patch `p`.
    pub fn interior_item(&self, p: usize) -> Item {
        let [a, b] = self.interior[p];
        Item { a, b, c: p as u32 }
    }

    /// The end of the order: every corner item, block and interior.
    pub fn end(&self) -> Item {
        Item {
            a: self.corner_first.len() as u32,
            b: self.block_first.len() as u32,
            c: self.interior.len() as u32,
        }
    }

    /// Whether corner `corner` made its item.
    pub fn makes_corner(&self, corner: usize) -> bool {
        self.corner_first[self.corner[corner] as usize] == corner as u32
    }

    /// Whether edge use `edge_use` made its block.
    pub fn makes_block(&self, edge_use: usize) -> bool {
        self.block_first[self.block[edge_use] as usize] == edge_use as u32
    }
}

/// The level-independent numbering of the stitched output of a mesh.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Numbering {
    /// Per edge use 3t + k: the edge (index in the adjacency).
    pub use_edge: Vec<u32>,
    /// Per edge use: its local direction (corner k → k + 1) runs from the higher to the
    /// lower vertex id, against the canonical sample order.
    pub use_rev: Vec<bool>,
    /// Per edge: whether its uses have a block each (split normals or attributes).
    pub split: Vec<bool>,
    /// Vertex records: one corner item per (vertex, normal, attributes), a block per edge
    /// and one per extra use of a split edge; `None` where they are the positions (no
    /// vertex has a second group, no edge is split): see [`Numbering::records`].
    pub records: Option<Order>,
    /// Positions: one corner item per vertex, one block per edge.
    pub positions: Order,
}

/// Bits of corner k of triangle t's attributes (0 for absent parts; −0 as 0), the key
/// records and seams are split by.
pub fn attribute_key(attrs: &CornerAttributes, t: usize, k: usize) -> [u32; 6] {
    let bits = |x: f32| if x == 0.0 { 0 } else { x.to_bits() };
    let mut key = [0; 6];
    if let Some(u) = &attrs.uvs {
        key[0] = bits(u[t][k][0]);
        key[1] = bits(u[t][k][1]);
    }
    if let Some(c) = &attrs.colors {
        for (d, &x) in key[2..].iter_mut().zip(&c[t][k]) {
            *d = bits(x);
        }
    }
    key
}

/// Per edge, whether its uses disagree on an end normal, or (with `attrs`) on an end's
/// attributes (a seam).
fn split_edges(mesh: &Mesh, adjacency: &Adjacency, attrs: Option<&CornerAttributes>) -> Vec<bool> {
    let mut split: Vec<bool> = split_ends(mesh, adjacency)
        .iter()
        .map(|s| s[0] || s[1])
        .collect();
    if let Some(attrs) = attrs {
        for (e, edge) in adjacency.edges.iter().enumerate() {
            let ends = |u: &crate::mesh::EdgeUse| {
                let (t, k) = (u.triangle as usize, u.local as usize);
                let a = attribute_key(attrs, t, k);
                let b = attribute_key(attrs, t, (k + 1) % 3);
                if mesh.triangles[t][k] == edge.v[0] {
                    (a, b)
                } else {
                    (b, a)
                }
            };
            if let Some((first, rest)) = edge.uses.split_first() {
                let f = ends(first);
                split[e] |= rest.iter().any(|u| ends(u) != f);
            }
        }
    }
    split
}

/// Numbers the corners of every patch, in order, into `positions` (one item per vertex)
/// and `records` (one item per (vertex, normal, attributes)), ending each patch's corners;
/// returns how many record items are a vertex's second or later group (creases, seams).
/// `records` stays `None` while it would equal `positions` (every vertex seen so far has
/// one group), and is made from `positions` at the first corner of a second group.
fn number_corners(
    mesh: &Mesh,
    attrs: Option<&CornerAttributes>,
    records: &mut Option<Order>,
    positions: &mut Order,
) -> usize {
    // Per vertex: its position item, and the record item of its first (normal, attributes)
    // group (the position item while `records` is `None`); the other groups (few vertices)
    // by key.
    let mut vertex_item = filled_with(mesh.positions.len(), || NONE);
    let mut first_group: Vec<u32> = Vec::new();
    let mut groups: HashMap<(u32, [u64; 3], [u32; 6]), u32> = HashMap::new();
    let key_of = |c: usize| {
        let (t, k) = (c / 3, c % 3);
        let akey = attrs.map_or([0; 6], |a| attribute_key(a, t, k));
        (normal_key(mesh.corner_normals[t][k]), akey)
    };
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for (k, &v) in tri.iter().enumerate() {
            let c = 3 * t + k;
            let slot = &mut vertex_item[v as usize];
            let made = *slot == NONE;
            if made {
                *slot = positions.make_corner(c);
            }
            let slot = *slot;
            if records.is_none() {
                if made || key_of(positions.corner_first[slot as usize] as usize) == key_of(c) {
                    positions.corner.push(slot);
                    continue;
                }
                // The first corner of a vertex's second group: from here on the records
                // are numbered apart, from the positions so far.
                first_group = vertex_item.clone();
            }
            let records = records.get_or_insert_with(|| positions.clone());
            positions.corner.push(slot);
            let first = &mut first_group[v as usize];
            let r = if *first == NONE {
                *first = records.make_corner(c);
                *first
            } else if key_of(records.corner_first[*first as usize] as usize) == key_of(c) {
                *first
            } else {
                let (n, a) = key_of(c);
                *groups
                    .entry((v, n, a))
                    .or_insert_with(|| records.make_corner(c))
            };
            records.corner.push(r);
        }
        if let Some(records) = records {
            records.end_corners();
        }
        positions.end_corners();
    }
    groups.len()
}

/// Per edge use 3t + k: its edge in `adjacency` (the last edge that lists it, as a walk of
/// the edges in order writing each use's edge would leave it; `NONE` where none does), and
/// whether its local direction runs against the edge's (from `v[1]` to `v[0]`); or the
/// first use the adjacency lists (in its order) that is no corner of the mesh (a walk would
/// index out of it).
fn edge_uses(
    mesh: &Mesh,
    adjacency: &Adjacency,
) -> std::result::Result<(Vec<u32>, Vec<bool>), EdgeUse> {
    let nf = mesh.triangles.len();
    let beyond_mesh = |u: &EdgeUse| u.local >= 3 || u.triangle as usize >= nf;
    // Edge e + 1, 0 for none: the largest is the last in order.
    let edge_of = atomics(3 * nf, 0);
    // The first edge that lists a use beyond the mesh.
    let beyond = AtomicUsize::new(usize::MAX);
    adjacency
        .edges
        .par_iter()
        .enumerate()
        .for_each(|(e, edge)| {
            for u in &edge.uses {
                if beyond_mesh(u) {
                    beyond.fetch_min(e, Relaxed);
                    continue;
                }
                let i = 3 * u.triangle as usize + u.local as usize;
                edge_of[i].fetch_max(e as u32 + 1, Relaxed);
            }
        });
    let first_beyond = adjacency.edges.get(beyond.into_inner());
    if let Some(u) = first_beyond.and_then(|edge| edge.uses.iter().find(|u| beyond_mesh(u))) {
        return Err(*u);
    }
    // Edge e, NONE for none.
    let use_edge = crate::par::into_values(edge_of, |e| e.into_inner().wrapping_sub(1));
    let use_rev = use_edge
        .par_iter()
        .enumerate()
        .map(|(u, &e)| match adjacency.edges.get(e as usize) {
            Some(edge) => mesh.triangles[u / 3][u % 3] != edge.v[0],
            None => false,
        })
        .collect();
    Ok((use_edge, use_rev))
}

/// The corners numbered in order ([`number_corners`]): corner items and blocks are
/// numbered apart (each patch's corners come before its edges), the corners of every
/// patch first.
struct WalkedCorners {
    records: Option<Order>,
    positions: Order,
    other_groups: usize,
}

impl WalkedCorners {
    fn of(mesh: &Mesh, attrs: Option<&CornerAttributes>) -> WalkedCorners {
        let mut records = None;
        let mut positions = Order::with_capacity(mesh.triangles.len());
        positions.corner_first = room(mesh.positions.len());
        let other_groups = number_corners(mesh, attrs, &mut records, &mut positions);
        WalkedCorners {
            records,
            positions,
            other_groups,
        }
    }
}

/// Threads from which [`Numbering::new`] numbers the positions in parallel
/// ([`number_single`]): its passes read the mesh several times where the walk in order
/// reads it once. Stitch plans of the 2 M-triangle ogre (level 4) on 16 Xeon cores, walk
/// against passes: 0.18–0.29 s against 0.08–0.09 s on 16 threads, 0.20–0.24 against
/// 0.13–0.15 on 8, 0.28–0.32 against 0.22–0.26 on 4, and 0.25–0.33 against 0.36–0.44 on 2.
const PARALLEL_THREADS: usize = 4;

/// The positions' numbering that [`number_corners`] and the edge walk of
/// [`Numbering::new`] make where every vertex has one normal (its corners' normals equal
/// bit for bit) and there are no attributes, made in parallel: a corner makes its
/// vertex's item where it is the vertex's first corner, an edge use makes its edge's block
/// where it is the edge's first use, and the items are numbered in that order. `None`
/// where some vertex has a second normal (the records are then numbered apart, in order).
fn number_single(mesh: &Mesh, edges: usize, use_edge: &[u32]) -> Option<Order> {
    let tris = &mesh.triangles;
    let vertex = |c: usize| tris[c / 3][c % 3] as usize;
    let first_corner = first_uses(mesh.positions.len(), 3 * tris.len(), vertex);
    let key = |c: usize| normal_key(mesh.corner_normals[c / 3][c % 3]);
    let single = crate::par::all_indices(3 * tris.len(), |c| {
        let f = first_corner[vertex(c)] as usize;
        f == c || key(f) == key(c)
    });
    if !single {
        return None;
    }
    let (corner_first, corner) = items(&first_corner, 3 * tris.len(), vertex);
    let edge = |u: usize| use_edge[u] as usize;
    let first_use = first_uses(edges, use_edge.len(), edge);
    let (block_first, block) = items(&first_use, use_edge.len(), edge);
    // Per patch, the corner items and blocks made by its corners and uses and those
    // before: a walk along both lists (in order), in ranges of patches.
    const RANGE: usize = 1 << 12;
    let mut interior = vec![[0u32; 2]; tris.len()];
    interior
        .par_chunks_mut(RANGE)
        .enumerate()
        .for_each(|(k, out)| {
            let first = 3 * (k * RANGE) as u32;
            let mut a = corner_first.partition_point(|&c| c < first);
            let mut b = block_first.partition_point(|&u| u < first);
            for (j, slot) in out.iter_mut().enumerate() {
                let end = first + 3 * j as u32 + 3;
                while corner_first.get(a).is_some_and(|&c| c < end) {
                    a += 1;
                }
                while block_first.get(b).is_some_and(|&u| u < end) {
                    b += 1;
                }
                *slot = [a as u32, b as u32];
            }
        });
    Some(Order {
        corner,
        corner_first,
        block,
        block_first,
        interior,
    })
}

/// `n` atomics holding `value`, made on the pool.
fn atomics(n: usize, value: u32) -> Vec<AtomicU32> {
    filled_with(n, || AtomicU32::new(value))
}

/// Per key (of `keys`), the first of `uses` indices whose key (`key_of`) it is; `NONE` for
/// a key that none has.
fn first_uses(keys: usize, uses: usize, key_of: impl Fn(usize) -> usize + Sync) -> Vec<u32> {
    let first = atomics(keys, NONE);
    (0..uses).into_par_iter().for_each(|i| {
        first[key_of(i)].fetch_min(i as u32, Relaxed);
    });
    crate::par::into_values(first, AtomicU32::into_inner)
}

/// The items made by the first use of each key (`first`, from [`first_uses`]): the uses
/// that made them, in order (one item each), and per use the item of its key.
fn items(
    first: &[u32],
    uses: usize,
    key_of: impl Fn(usize) -> usize + Sync,
) -> (Vec<u32>, Vec<u32>) {
    let made: Vec<u32> = (0..uses as u32)
        .into_par_iter()
        .filter(|&i| first[key_of(i as usize)] == i)
        .collect();
    let item = atomics(first.len(), NONE);
    made.par_iter().enumerate().for_each(|(m, &i)| {
        item[key_of(i as usize)].store(m as u32, Relaxed);
    });
    let of_use = (0..uses)
        .into_par_iter()
        .map(|i| item[key_of(i)].load(Relaxed))
        .collect();
    (made, of_use)
}

impl Numbering {
    /// Numbers the stitched output of `mesh` (whose adjacency is `adjacency`); corners and
    /// edges are split by `attrs` too where given.
    pub fn new(
        mesh: &Mesh,
        adjacency: &Adjacency,
        attrs: Option<&CornerAttributes>,
    ) -> Result<Numbering> {
        let nf = mesh.triangles.len();
        if 3 * nf as u64 >= NONE as u64 {
            return Err(Error::Invalid(format!(
                "{}: {nf} triangles are too many for 32-bit indices",
                mesh.name
            )));
        }
        // The corners' walk needs no edges: where the walk numbers the mesh, it runs beside
        // the uses' edges.
        let parallel = attrs.is_none() && rayon::current_num_threads() >= PARALLEL_THREADS;
        let (uses, corners) = if parallel {
            (edge_uses(mesh, adjacency), None)
        } else {
            let (uses, corners) = rayon::join(
                || edge_uses(mesh, adjacency),
                || WalkedCorners::of(mesh, attrs),
            );
            (uses, Some(corners))
        };
        let (use_edge, use_rev) = uses.map_err(|u| {
            Error::Invalid(format!(
                "{}: the adjacency lists edge {} of triangle {}, which the mesh has not",
                mesh.name, u.local, u.triangle
            ))
        })?;
        if let Some(u) = crate::par::first_index(use_edge.len(), |u| use_edge[u] == NONE) {
            return Err(Error::Invalid(format!(
                "{}: edge {} of triangle {} is missing from the adjacency",
                mesh.name,
                u % 3,
                u / 3
            )));
        }
        // Without attributes and with one normal per vertex, the records are the positions
        // and no edge is split: the positions are numbered in parallel where the pool has
        // threads enough ([`PARALLEL_THREADS`]).
        if parallel {
            if let Some(positions) = number_single(mesh, adjacency.edges.len(), &use_edge) {
                return Ok(Numbering {
                    use_edge,
                    use_rev,
                    split: vec![false; adjacency.edges.len()],
                    records: None,
                    positions,
                });
            }
        }
        let corners = corners.unwrap_or_else(|| WalkedCorners::of(mesh, attrs));
        Ok(Self::in_order(
            mesh, adjacency, attrs, use_edge, use_rev, corners,
        ))
    }

    /// [`Numbering::new`] walking the edge uses in order after the corners (`corners`),
    /// from each use's edge and direction.
    fn in_order(
        mesh: &Mesh,
        adjacency: &Adjacency,
        attrs: Option<&CornerAttributes>,
        use_edge: Vec<u32>,
        use_rev: Vec<bool>,
        corners: WalkedCorners,
    ) -> Numbering {
        let nf = mesh.triangles.len();
        let WalkedCorners {
            mut records,
            mut positions,
            other_groups,
        } = corners;
        // A vertex with one normal has no crease at it: without a second (normal,
        // attributes) group at any vertex, no edge is split.
        let split = if other_groups > 0 || attrs.is_some() {
            split_edges(mesh, adjacency, attrs)
        } else {
            vec![false; adjacency.edges.len()]
        };
        // Where an edge is split, the records are numbered apart (made here where no
        // corner made them: split attributes alone).
        if records.is_none() && split.iter().any(|&s| s) {
            records = Some(positions.clone());
        }
        // Per edge: its position block, and its owner's record block.
        let mut edge_item = filled_with(adjacency.edges.len(), || NONE);
        let mut owner_block = match records {
            Some(_) => filled_with(adjacency.edges.len(), || NONE),
            None => Vec::new(),
        };
        // No block is made before this walk.
        positions.block_first = room(adjacency.edges.len());
        for t in 0..nf {
            for k in 0..3 {
                let u = 3 * t + k;
                let e = use_edge[u] as usize;
                let owner = edge_item[e] == NONE;
                if owner {
                    edge_item[e] = positions.make_block(u);
                }
                positions.block.push(edge_item[e]);
                let Some(records) = &mut records else {
                    continue;
                };
                if owner {
                    owner_block[e] = records.make_block(u);
                }
                let b = if split[e] && records.block_first[owner_block[e] as usize] != u as u32 {
                    records.make_block(u)
                } else {
                    owner_block[e]
                };
                records.block.push(b);
            }
            if let Some(records) = &mut records {
                records.end_patch(t);
            }
            positions.end_patch(t);
        }
        Numbering {
            use_edge,
            use_rev,
            split,
            records,
            positions,
        }
    }

    /// The records' numbering: the positions' where no vertex has a second (normal,
    /// attributes) group and no edge is split.
    pub fn records(&self) -> &Order {
        self.records.as_ref().unwrap_or(&self.positions)
    }

    /// Number of patches.
    pub fn patches(&self) -> usize {
        self.positions.interior.len()
    }

    /// The owner of edge use `edge_use`'s edge: the edge's first use.
    pub fn owner(&self, edge_use: usize) -> usize {
        let b = self.positions.block[edge_use];
        self.positions.block_first[b as usize] as usize
    }

    /// The edge of each block of `order`, in the order they were made.
    pub fn block_edges<'a>(&'a self, order: &'a Order) -> impl Iterator<Item = u32> + 'a {
        order.block_first.iter().map(|&u| self.use_edge[u as usize])
    }

    /// Record blocks whose positions are the owner's (the extra blocks of split edges).
    pub fn copied_blocks(&self) -> u32 {
        let r = self.records();
        (0..r.block_first.len())
            .filter(|&b| {
                let u = r.block_first[b] as usize;
                self.owner(u) != u
            })
            .count() as u32
    }
}

/// What grid point (i, j) of the grid of level n (b1 = i/n, b2 = j/n) is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridPoint {
    /// Corner k (b_k = 1).
    Corner(usize),
    /// The sample at step `s` (1..n) from corner k along local edge k (corner k → k + 1).
    Edge(usize, u32),
    /// Interior point number m, in grid order.
    Interior(u32),
}

/// Which corner, edge sample or interior point grid point (i, j) of level n is.
pub fn grid_point(n: u32, i: u32, j: u32) -> GridPoint {
    match (i, j) {
        (0, 0) => GridPoint::Corner(0),
        (i, 0) if i == n => GridPoint::Corner(1),
        (0, j) if j == n => GridPoint::Corner(2),
        (i, 0) => GridPoint::Edge(0, i),
        (i, j) if i + j == n => GridPoint::Edge(1, j),
        (0, j) => GridPoint::Edge(2, n - j),
        // Rows j = 1 .. n − 2 hold i = 1 .. n − j − 1.
        (i, j) => GridPoint::Interior((j - 1) * (n - 1) - (j - 1) * j / 2 + i - 1),
    }
}

/// Index in its block (canonical order, from 0) of the sample at step `s` (1..=`samples`)
/// along an edge use, `reversed` where the use runs against the canonical order.
pub fn canonical_sample(samples: u32, s: u32, reversed: bool) -> u32 {
    if reversed {
        samples - s
    } else {
        s - 1
    }
}

/// Grid index of corner k of the grid of level n.
pub fn corner_grid(n: u32, k: usize) -> usize {
    match k {
        0 => grid_index(n, 0, 0),
        1 => grid_index(n, n, 0),
        _ => grid_index(n, 0, n),
    }
}

/// Grid index of the sample at step i (1..n) from corner k along local edge k.
pub fn edge_grid(n: u32, k: usize, i: u32) -> usize {
    match k {
        0 => grid_index(n, i, 0),
        1 => grid_index(n, n - i, i),
        _ => grid_index(n, 0, n - i),
    }
}

/// Interior grid points as runs of consecutive grid indices (one per grid row j ≥ 1:
/// i = 1..n − j − 1), in grid order.
pub fn interior_rows(n: u32) -> Vec<Range<usize>> {
    (1..n.saturating_sub(1))
        .map(|j| grid_index(n, 1, j)..grid_index(n, n - j, j))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `grid_point` inverts `corner_grid`, `edge_grid` and `interior_rows`: every grid
    /// point of levels 1..=9 is named once, as the item whose grid index it is.
    #[test]
    fn grid_point_inverts_the_grid_indices() {
        for n in 1..=9u32 {
            let mut named = vec![None; crate::eval::grid_len(n)];
            for k in 0..3 {
                named[corner_grid(n, k)] = Some(GridPoint::Corner(k));
                for s in 1..n {
                    named[edge_grid(n, k, s)] = Some(GridPoint::Edge(k, s));
                }
            }
            let interior = interior_rows(n).into_iter().flatten();
            for (m, g) in interior.enumerate() {
                named[g] = Some(GridPoint::Interior(m as u32));
            }
            assert_eq!(named.len() as u64, 3 + 3 * (n as u64 - 1) + interior_len(n));
            for j in 0..=n {
                for i in 0..=n - j {
                    assert_eq!(
                        Some(grid_point(n, i, j)),
                        named[grid_index(n, i, j)],
                        "level {n} ({i}, {j})"
                    );
                }
            }
        }
    }

    /// Uniform bases are prefix sums of equal sizes.
    #[test]
    fn uniform_bases_are_equal_prefix_sums() {
        for n in [1u32, 2, 3, 7] {
            let prefix = Bases::prefix(vec![n as u64 - 1; 5], vec![interior_len(n); 4]);
            for (a, b, c) in [(0, 0, 0), (3, 2, 1), (9, 5, 4)] {
                let item = Item { a, b, c };
                assert_eq!(Bases::grid(n).base(item), prefix.base(item), "level {n}");
            }
        }
        // Level 4: 2 + 3 blocks of 3 + 2 interiors of 3.
        assert_eq!(Bases::grid(4).base(Item { a: 2, b: 3, c: 2 }), 2 + 9 + 6);
    }

    /// The old edge walk of [`Numbering::new`]: each edge in order writes its uses' edge
    /// and direction.
    fn edge_uses_walked(mesh: &Mesh, adjacency: &Adjacency) -> (Vec<u32>, Vec<bool>) {
        let nf = mesh.triangles.len();
        let (mut use_edge, mut use_rev) = (vec![NONE; 3 * nf], vec![false; 3 * nf]);
        for (e, edge) in adjacency.edges.iter().enumerate() {
            for u in &edge.uses {
                let i = 3 * u.triangle as usize + u.local as usize;
                use_edge[i] = e as u32;
                use_rev[i] = mesh.triangles[u.triangle as usize][u.local as usize] != edge.v[0];
            }
        }
        (use_edge, use_rev)
    }

    /// The parallel numbering is the in-order walk's, field for field, on closed and open
    /// meshes with one normal per vertex, on pools of 1, 4 and 8 threads; meshes with a
    /// second normal at some vertex (Suzanne's file splits some, fandisk split at 30°) and
    /// a mesh with UVs given (spot) take the walk.
    #[test]
    fn the_parallel_numbering_is_the_walk() {
        use crate::tests::common::{load, shared_spec};
        let creased = crate::LoadOptions {
            crease_angle: Some(30.0),
            ..Default::default()
        };
        let fandisk = Mesh::load(&shared_spec("fandisk.obj"), &creased).unwrap();
        let mut open = load("icosphere:2");
        open.triangles.truncate(200);
        open.corner_normals.truncate(200);
        let meshes = [
            (load("stanford-bunny.obj"), true),
            (load("suzanne.obj"), false),
            (load("spot.obj"), true),
            (load("torus:12x8"), true),
            (open, true),
            (fandisk, false),
        ];
        for (mesh, single) in &meshes {
            let adjacency = mesh.adjacency();
            let (use_edge, use_rev) = edge_uses_walked(mesh, &adjacency);
            assert_eq!(
                edge_uses(mesh, &adjacency).unwrap(),
                (use_edge.clone(), use_rev.clone()),
                "{}",
                mesh.name
            );
            let fast = number_single(mesh, adjacency.edges.len(), &use_edge);
            assert_eq!(fast.is_some(), *single, "{}", mesh.name);
            let corners = WalkedCorners::of(mesh, None);
            let walked = Numbering::in_order(mesh, &adjacency, None, use_edge, use_rev, corners);
            if let Some(fast) = fast {
                assert_eq!(fast, walked.positions, "{}", mesh.name);
            }
            // On pools below, at and above PARALLEL_THREADS (the walk, then the passes).
            for threads in [1, PARALLEL_THREADS, 8] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let numbering = pool.install(|| Numbering::new(mesh, &adjacency, None));
                assert_eq!(numbering.unwrap(), walked, "{} {threads}", mesh.name);
            }
            let numbering = walked;
            // One position item per vertex used and one block per edge.
            let used = {
                let mut seen = vec![false; mesh.positions.len()];
                mesh.triangles
                    .iter()
                    .flatten()
                    .for_each(|&v| seen[v as usize] = true);
                seen.iter().filter(|&&s| s).count()
            };
            let p = &numbering.positions;
            assert_eq!(p.corner_first.len(), used, "{}", mesh.name);
            assert_eq!(p.block_first.len(), adjacency.edges.len(), "{}", mesh.name);
            assert_eq!(numbering.records.is_none(), *single, "{}", mesh.name);
        }
        // Spot's UVs split its records: with them, the walk.
        let spot = &meshes[2].0;
        let adjacency = spot.adjacency();
        let attrs = &spot.attributes;
        assert!(attrs.uvs.is_some());
        let n = Numbering::new(spot, &adjacency, Some(attrs)).unwrap();
        let (use_edge, use_rev) = edge_uses_walked(spot, &adjacency);
        assert_eq!(
            n,
            Numbering::in_order(
                spot,
                &adjacency,
                Some(attrs),
                use_edge,
                use_rev,
                WalkedCorners::of(spot, Some(attrs))
            )
        );
        assert!(n.records.is_some());
    }

    /// An adjacency that lists a use beyond the mesh's corners is an error naming it, not
    /// a misfiled use or a panic.
    #[test]
    fn a_use_beyond_the_mesh_is_an_error() {
        use crate::mesh::adjacency::EdgeUses;
        let mesh = crate::tests::common::load("torus:12x8");
        let nf = mesh.triangles.len() as u32;
        for (bad, named) in [
            (
                EdgeUse {
                    triangle: 5,
                    local: 3,
                },
                "edge 3 of triangle 5,",
            ),
            (
                EdgeUse {
                    triangle: nf,
                    local: 0,
                },
                "edge 0 of triangle 192,",
            ),
        ] {
            let mut adjacency = mesh.adjacency();
            adjacency.edges[7].uses = EdgeUses::new(&[adjacency.edges[7].uses[0], bad]);
            let e = Numbering::new(&mesh, &adjacency, None)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(named) && e.contains("which the mesh has not"),
                "{e}"
            );
        }
    }
}
