//! The input weld: one rule for every source of a mesh (OBJ and `.pn` files, in-memory
//! soups, the built-in meshes).
//!
//! Two vertices are the same point when their coordinates are equal as numbers, so `-0.0`
//! equals `0.0` (a zero's sign never splits a vertex; the welded position carries `+0.0`).
//! Every vertex maps to the first vertex of the input at its position; triangles that then
//! repeat a vertex or have no area (collinear corners, or an area that underflows in f64:
//! no normal) are dropped as degenerate, and so are the vertices no remaining triangle uses. The
//! vertices kept are numbered in input order or in order of first use ([`Order`]). Every
//! reader numbers them in input order, so a mesh written and read back keeps its numbering,
//! and with it the rounding of its patches, which follows vertex ids.
//! Output-side welding (tessellated samples) is a
//! different thing and lives with the writers.

use glam::DVec3;
use rayon::prelude::*;

use super::LoadReport;
use crate::{Error, Result};

/// The weld key of a position: its coordinates' bits with `-0.0` folded into `0.0`.
#[inline]
fn key(p: DVec3) -> [u64; 3] {
    let q = p + DVec3::ZERO; // -0.0 + 0.0 = +0.0; every other value is unchanged
    [q.x.to_bits(), q.y.to_bits(), q.z.to_bits()]
}

#[inline]
fn hash(k: [u64; 3]) -> u64 {
    // Multiply-xor mixing of the three words, then the 64-bit finaliser of MurmurHash3.
    let mut h = k[0].wrapping_mul(0x9e37_79b9_7f4a_7c15)
        ^ k[1].wrapping_mul(0xc2b2_ae3d_27d4_eb4f).rotate_left(23)
        ^ k[2].wrapping_mul(0x1656_67b1_9e37_79f9).rotate_left(43);
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    h ^ (h >> 33)
}

/// How the welded vertices are numbered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// In the order of the input vertices.
    Input,
    #[cfg(test)]
    /// In the order the triangles first use them.
    FirstUse,
}

/// For every vertex, the first vertex of `positions` at the same point (itself when it is
/// the first).
pub fn representatives(positions: &[DVec3]) -> Vec<u32> {
    const EMPTY: u32 = u32::MAX;
    let bits = (2 * positions.len())
        .max(16)
        .next_power_of_two()
        .trailing_zeros();
    let mask = (1usize << bits) - 1;
    let mut table = vec![EMPTY; mask + 1];
    let mut rep = Vec::with_capacity(positions.len());
    for (v, &p) in positions.iter().enumerate() {
        let k = key(p);
        let mut slot = (hash(k) >> (64 - bits)) as usize;
        loop {
            let s = table[slot];
            if s == EMPTY {
                table[slot] = v as u32;
                rep.push(v as u32);
                break;
            }
            if key(positions[s as usize]) == k {
                rep.push(s);
                break;
            }
            slot = (slot + 1) & mask;
        }
    }
    rep
}

/// Welds `positions` (see the module documentation) and returns the welded positions.
///
/// `triangles` index into `positions`; they are rewritten in place to index the returned
/// positions, with the degenerate triangles (a repeated welded vertex, no area) removed.
/// `payload` holds one
/// entry per input triangle (corner normals, for instance) and is filtered alongside; pass an
/// empty vector for none. The counts of what changed are added to `report`
/// (`vertices_welded`, `unused_vertices_dropped`, `degenerate_triangles_dropped`).
///
/// An index out of range or a payload of the wrong length is an error (callers check their
/// input first, to name the line or element).
pub fn weld<P>(
    positions: &[DVec3],
    triangles: &mut Vec<[u32; 3]>,
    payload: &mut Vec<P>,
    order: Order,
    report: &mut LoadReport,
) -> Result<Vec<DVec3>> {
    weld_with(positions, triangles, payload, order, report)
}

/// Per-triangle data the weld filters alongside the triangles: a vector with one entry per
/// input triangle, or an empty one for none; a pair or triple of payloads carries several
/// (corner normals, UVs and colours kept in step).
pub trait Payload {
    /// Whether every part holds `n` entries or none.
    fn fits(&self, n: usize) -> bool;
    /// Moves entry `from` to `to` (`to <= from`).
    fn take(&mut self, to: usize, from: usize);
    /// Keeps the first `n` entries.
    fn keep(&mut self, n: usize);
}

impl<T> Payload for Vec<T> {
    fn fits(&self, n: usize) -> bool {
        self.is_empty() || self.len() == n
    }
    fn take(&mut self, to: usize, from: usize) {
        if !self.is_empty() {
            self.swap(to, from);
        }
    }
    fn keep(&mut self, n: usize) {
        self.truncate(n.min(self.len()));
    }
}

impl<P: Payload + ?Sized> Payload for &mut P {
    fn fits(&self, n: usize) -> bool {
        (**self).fits(n)
    }
    fn take(&mut self, to: usize, from: usize) {
        (**self).take(to, from);
    }
    fn keep(&mut self, n: usize) {
        (**self).keep(n);
    }
}

impl<A: Payload, B: Payload> Payload for (A, B) {
    fn fits(&self, n: usize) -> bool {
        self.0.fits(n) && self.1.fits(n)
    }
    fn take(&mut self, to: usize, from: usize) {
        self.0.take(to, from);
        self.1.take(to, from);
    }
    fn keep(&mut self, n: usize) {
        self.0.keep(n);
        self.1.keep(n);
    }
}

impl<A: Payload, B: Payload, C: Payload> Payload for (A, B, C) {
    fn fits(&self, n: usize) -> bool {
        self.0.fits(n) && self.1.fits(n) && self.2.fits(n)
    }
    fn take(&mut self, to: usize, from: usize) {
        self.0.take(to, from);
        self.1.take(to, from);
        self.2.take(to, from);
    }
    fn keep(&mut self, n: usize) {
        self.0.keep(n);
        self.1.keep(n);
        self.2.keep(n);
    }
}

/// [`weld`] with any [`Payload`]: each of its parts holds one entry per input triangle or
/// none.
pub fn weld_with<P: Payload>(
    positions: &[DVec3],
    triangles: &mut Vec<[u32; 3]>,
    payload: &mut P,
    order: Order,
    report: &mut LoadReport,
) -> Result<Vec<DVec3>> {
    let n = positions.len();
    if u32::try_from(n).is_err() {
        return Err(Error::Invalid(format!(
            "{n} vertices: more than a mesh can index (u32)"
        )));
    }
    if !payload.fits(triangles.len()) {
        return Err(Error::Invalid(format!(
            "weld: per-triangle entries that are not one per triangle ({} triangles)",
            triangles.len()
        )));
    }
    if let Some((t, v)) = triangles
        .iter()
        .enumerate()
        .find_map(|(t, tri)| tri.iter().find(|&&v| v as usize >= n).map(|&v| (t, v)))
    {
        return Err(Error::Invalid(format!(
            "triangle {t} has vertex index {v}, out of range ({n} vertices)"
        )));
    }
    let mut rep = representatives(positions);

    // Map corners to representatives, drop degenerate triangles, note which vertices any
    // input triangle references (REF) and which representatives a kept triangle uses (KEEP).
    const REF: u8 = 1;
    const KEEP: u8 = 2;
    // Whether each triangle collapses, in parallel (the loop below is in order).
    let collapsed: Vec<bool> = triangles
        .par_iter()
        .map(|t| {
            let w = t.map(|v| rep[v as usize]);
            w[0] == w[1]
                || w[1] == w[2]
                || w[2] == w[0]
                || !super::normals::has_area(w.map(|v| positions[v as usize]))
        })
        .collect();
    let mut state = vec![0u8; n];
    let mut kept = 0usize;
    for i in 0..triangles.len() {
        let t = triangles[i];
        for v in t {
            state[v as usize] |= REF;
        }
        let w = t.map(|v| rep[v as usize]);
        if collapsed[i] {
            report.degenerate_triangles_dropped += 1;
            continue;
        }
        for v in w {
            state[v as usize] |= KEEP;
        }
        triangles[kept] = w;
        payload.take(kept, i);
        kept += 1;
    }
    triangles.truncate(kept);
    payload.keep(kept);

    let welded = (0..n)
        .filter(|&v| state[v] & REF != 0 && rep[v] != v as u32)
        .count();
    // `rep` is no longer needed: reuse it as the new index of each kept representative.
    let mut out = Vec::new();
    match order {
        Order::Input => {
            for v in 0..n {
                if state[v] & KEEP != 0 {
                    rep[v] = out.len() as u32;
                    out.push(positions[v] + DVec3::ZERO);
                }
            }
        }
        #[cfg(test)]
        Order::FirstUse => {
            rep.fill(u32::MAX);
            for &v in triangles.iter().flatten() {
                if rep[v as usize] == u32::MAX {
                    rep[v as usize] = out.len() as u32;
                    out.push(positions[v as usize] + DVec3::ZERO);
                }
            }
        }
    }
    for t in triangles.iter_mut() {
        *t = t.map(|v| rep[v as usize]);
    }
    report.vertices_welded += welded;
    report.unused_vertices_dropped += n - out.len() - welded;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use crate::mesh::weld::{representatives, weld, Order};
    use crate::LoadReport;
    use glam::DVec3;

    #[test]
    fn signed_zeros_weld_and_counts_add_up() {
        let p = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(-0.0, 0.0, -0.0), // = vertex 0
            DVec3::new(1.0, -0.0, 0.0),  // = vertex 1
            DVec3::new(0.0, 1.0, -0.0),  // = vertex 2
            DVec3::new(7.0, 7.0, 7.0),   // unused
            DVec3::new(0.0, 0.0, 1.0),
        ];
        let mut tris = vec![[0, 1, 2], [3, 4, 7], [3, 0, 5], [5, 3, 7]];
        let mut normals = vec!['a', 'b', 'c', 'd'];
        let mut report = LoadReport::default();
        let out = weld(&p, &mut tris, &mut normals, Order::Input, &mut report).unwrap();
        assert_eq!(out.len(), 4);
        assert_eq!(tris, vec![[0, 1, 2], [0, 1, 3], [2, 0, 3]]);
        assert_eq!(normals, vec!['a', 'b', 'd']);
        assert_eq!(report.degenerate_triangles_dropped, 1);
        assert_eq!(report.vertices_welded, 3);
        assert_eq!(report.unused_vertices_dropped, 1);
        // Welded positions carry +0.0.
        assert!(out
            .iter()
            .flat_map(|q| q.to_array())
            .all(|x| x != 0.0 || x.is_sign_positive()));
        // Numbered by first use: the last kept vertex (7) is used before vertex 2.
        let (mut t1, mut n1, mut r1) = (
            vec![[0, 1, 7], [3, 4, 2]],
            vec![0, 1],
            LoadReport::default(),
        );
        let out1 = weld(&p, &mut t1, &mut n1, Order::FirstUse, &mut r1).unwrap();
        assert_eq!(t1, vec![[0, 1, 2], [0, 1, 3]]);
        assert_eq!(out1[2], p[7]);
        let mut bad = vec![[0, 1, 8]];
        let e = weld(
            &p,
            &mut bad,
            &mut Vec::<()>::new(),
            Order::Input,
            &mut report,
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("triangle 0 has vertex index 8"),
            "{e}"
        );
    }

    #[test]
    fn distinct_points_stay_distinct_under_collisions() {
        // A 40×40×40 integer grid (hash-unfriendly: many equal high bits) plus a copy of it.
        let mut p = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                for k in 0..40 {
                    p.push(DVec3::new(i as f64, j as f64, k as f64));
                }
            }
        }
        let n = p.len();
        p.extend_from_within(..);
        let rep = representatives(&p);
        for v in 0..n {
            assert_eq!(rep[v], v as u32);
            assert_eq!(rep[v + n], v as u32);
        }
    }
}
