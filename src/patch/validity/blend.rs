//! Bounds on the Gregory blend of corner m on a cell of the subdivision: its extent there
//! ([`blend_extent`]) and what its Taylor polynomial at the cell's centroid leaves out
//! ([`blend_corners`], the linearised blend of [`super::Geometry::bound`], for the three
//! corners at once; `blend_terms`, one corner at a time, is its readable reference in the
//! tests).

use super::lanes::Lanes;
use super::Cell;

/// What the bounds on corner m's Gregory blend need of `cell` (x, y, z = b_m, b_{m+1},
/// b_{m+2}): the largest x, y and z at its corners (affine, so on the cell), the range of
/// φ = y/(y + z) over the corners where y + z > 0 (infinite where there are none), and the
/// smallest y + z at a corner.
pub(super) struct BlendExtent {
    pub xm: f64,
    pub ym: f64,
    pub zm: f64,
    pub lo: f64,
    pub hi: f64,
    pub smin: f64,
}

/// [`BlendExtent`] of corner m on `cell`.
pub(super) fn blend_extent(m: usize, cell: &Cell) -> BlendExtent {
    let (im, iy, iz) = (m, (m + 1) % 3, (m + 2) % 3);
    let mut e = BlendExtent {
        xm: 0.0,
        ym: 0.0,
        zm: 0.0,
        lo: f64::INFINITY,
        hi: f64::NEG_INFINITY,
        smin: f64::INFINITY,
    };
    for u in cell {
        e.xm = e.xm.max(u[im]);
        e.ym = e.ym.max(u[iy]);
        e.zm = e.zm.max(u[iz]);
        let s = u[iy] + u[iz];
        e.smin = e.smin.min(s);
        if s > 0.0 {
            let f = u[iy] / s;
            e.lo = e.lo.min(f);
            e.hi = e.hi.max(f);
        }
    }
    e
}

/// For corner m's blend φ = y/(y + z) (x, y, z = b_m, b_{m+1}, b_{m+2}) on `cell`: the
/// coefficients ℓ (on b_0, b_1, b_2) of its Taylor polynomial φ̂ at the centroid, and bounds
/// on |∂ρ/∂s| and |∂ρ/∂t| over the cell for ρ = 12 x² y z (φ − φ̂).
///
/// The readable form, one corner at a time; the bound uses [`blend_corners`], which gives
/// the same bits for the three corners at once (test `blend_corners_are_blend_terms`).
#[cfg(test)]
pub(super) fn blend_terms(m: usize, cell: &Cell) -> ([f64; 3], f64, f64) {
    let (im, iy, iz) = (m, (m + 1) % 3, (m + 2) % 3);
    let c: [f64; 3] = std::array::from_fn(|j| (cell[0][j] + cell[1][j] + cell[2][j]) / 3.0);
    let (cy, cz) = (c[iy], c[iz]);
    let cs = cy + cz;
    let phi_c = cy / cs;
    // Gradient of φ at the centroid along (y, z) (φ does not depend on x).
    let (gy, gz) = (cz / (cs * cs), -cy / (cs * cs));
    // φ̂(b) = φ(c) + g·(b − c), written as Σ_k ℓ_k b_k (Σ b_k = 1).
    let mut ell = [0.0; 3];
    for (k, e) in ell.iter_mut().enumerate() {
        let mut ek = [0.0; 3];
        ek[k] = 1.0;
        *e = phi_c + gy * (ek[iy] - cy) + gz * (ek[iz] - cz);
    }
    let lin = |b: &[f64; 3]| phi_c + gy * (b[iy] - cy) + gz * (b[iz] - cz);
    let BlendExtent {
        xm,
        ym,
        zm,
        lo,
        hi,
        smin,
    } = blend_extent(m, cell);
    let (mut dy, mut dz) = (0.0f64, 0.0f64);
    let (mut llo, mut lhi) = (f64::INFINITY, f64::NEG_INFINITY);
    for u in cell {
        dy = dy.max((u[iy] - cy).abs());
        dz = dz.max((u[iz] - cz).abs());
        let l = lin(u);
        llo = llo.min(l);
        lhi = lhi.max(l);
    }
    // φ ranges over [lo, hi] on the cell (a linear fraction: extremes at the corners, the
    // pole excluded), φ̂ over [llo, lhi] (affine).
    let mut e0 = (hi - llo).max(lhi - lo).max(0.0);
    // |y z (∂φ/∂y − ∂φ̂/∂y)| ≤ y (z/s)² + y z |g_y|; likewise for z.
    let mut ey = ym + ym * zm * gy.abs();
    let mut ez = zm + ym * zm * gz.abs();
    if smin > 0.0 {
        // Taylor, s ≥ smin on the cell: φ_yy = −2z/s³, φ_yz = (y − z)/s³, φ_zz = 2y/s³, so
        // |φ_yy| ≤ 2 z_max/s³ ≤ 2/s², |φ_yz| ≤ w/s³ ≤ 1/s² (w: the largest |y − z|, at a
        // corner, y − z being affine) and |φ_zz| ≤ 2 y_max/s³ ≤ 2/s²; each bound below is
        // the smaller of the two forms.
        let s2 = smin * smin;
        let s3 = s2 * smin;
        let w = cell
            .iter()
            .map(|u| (u[iy] - u[iz]).abs())
            .fold(0.0, f64::max);
        e0 = e0
            .min((dy * dy + dy * dz + dz * dz) / s2)
            .min((zm * dy * dy + w * dy * dz + ym * dz * dz) / s3);
        ey = ey
            .min(ym * zm * (2.0 * dy + dz) / s2)
            .min(ym * zm * (2.0 * zm * dy + w * dz) / s3);
        ez = ez
            .min(ym * zm * (dy + 2.0 * dz) / s2)
            .min(ym * zm * (w * dy + 2.0 * ym * dz) / s3);
    }
    // ∂ρ/∂x = 24 x y z (φ − φ̂); ∂ρ/∂y = 12 x² [z (φ − φ̂) + y z (∂_y φ − ∂_y φ̂)];
    // ∂ρ/∂z = 12 x² [y (φ − φ̂) + y z (∂_z φ − ∂_z φ̂)].
    let mut d = [0.0; 3];
    d[im] = 24.0 * xm * ym * zm * e0;
    d[iy] = 12.0 * xm * xm * (zm * e0 + ey);
    d[iz] = 12.0 * xm * xm * (ym * e0 + ez);
    // ∂/∂s = ∂/∂b1 − ∂/∂b0, ∂/∂t = ∂/∂b2 − ∂/∂b0.
    (ell, d[1] + d[0], d[2] + d[0])
}

/// Corner of each lane ([`Lanes`]: lane m holds corner m's value, lane 3 repeats corner 0's).
const LANE_CORNER: [usize; 4] = [0, 1, 2, 0];

/// `blend_terms` of corners 0, 1 and 2 on `cell`, bit for bit: the same operations in
/// the same order, with the corners side by side in lanes so that the twelve divisions of
/// each corner are four-lane divisions where the caller is compiled for AVX (the bound's
/// four-lane path). The branches become selects, both sides computed (a division by zero
/// on the side not taken is dropped).
#[inline(always)]
pub(super) fn blend_corners(cell: &Cell) -> [([f64; 3], f64, f64); 3] {
    let c: [f64; 3] = std::array::from_fn(|j| (cell[0][j] + cell[1][j] + cell[2][j]) / 3.0);
    // Each corner of the cell as x, y and z of each lane's blend.
    let (mut ux, mut uy, mut uz) = ([[0.0; 4]; 3], [[0.0; 4]; 3], [[0.0; 4]; 3]);
    let (mut cy, mut cz) = ([0.0; 4], [0.0; 4]);
    // Whether b_k is the lane's y (or z): ∂b_k/∂y of φ̂'s coefficients.
    let (mut ky, mut kz) = ([[0.0; 4]; 3], [[0.0; 4]; 3]);
    for (l, &m) in LANE_CORNER.iter().enumerate() {
        let (iy, iz) = ((m + 1) % 3, (m + 2) % 3);
        for (v, u) in cell.iter().enumerate() {
            ux[v][l] = u[m];
            uy[v][l] = u[iy];
            uz[v][l] = u[iz];
        }
        cy[l] = c[iy];
        cz[l] = c[iz];
        ky[iy][l] = 1.0;
        kz[iz][l] = 1.0;
    }
    let (mut phi_c, mut gy, mut gz): (Lanes, Lanes, Lanes) = ([0.0; 4], [0.0; 4], [0.0; 4]);
    for l in 0..4 {
        let cs = cy[l] + cz[l];
        phi_c[l] = cy[l] / cs;
        gy[l] = cz[l] / (cs * cs);
        gz[l] = -cy[l] / (cs * cs);
    }
    let mut ell = [[0.0; 4]; 3];
    for (k, e) in ell.iter_mut().enumerate() {
        for l in 0..4 {
            e[l] = phi_c[l] + gy[l] * (ky[k][l] - cy[l]) + gz[l] * (kz[k][l] - cz[l]);
        }
    }
    // As `blend_extent`, then the loop over the corners of `blend_terms`.
    let (mut xm, mut ym, mut zm) = ([0.0f64; 4], [0.0f64; 4], [0.0f64; 4]);
    let (mut lo, mut hi, mut smin) = (
        [f64::INFINITY; 4],
        [f64::NEG_INFINITY; 4],
        [f64::INFINITY; 4],
    );
    for v in 0..3 {
        for l in 0..4 {
            xm[l] = xm[l].max(ux[v][l]);
            ym[l] = ym[l].max(uy[v][l]);
            zm[l] = zm[l].max(uz[v][l]);
            let s = uy[v][l] + uz[v][l];
            smin[l] = smin[l].min(s);
            let f = uy[v][l] / s;
            lo[l] = if s > 0.0 { lo[l].min(f) } else { lo[l] };
            hi[l] = if s > 0.0 { hi[l].max(f) } else { hi[l] };
        }
    }
    let (mut dy, mut dz) = ([0.0f64; 4], [0.0f64; 4]);
    let (mut llo, mut lhi) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4]);
    let mut w = [0.0f64; 4];
    // Lanes outermost: with the corners outermost, rustc 1.95 built for AVX-512 (as
    // `-C target-cpu=native` does on such a CPU) drops a corner from some lanes' maxima
    // (`blend_corners_are_blend_terms` checks that build where the CPU has it).
    for l in 0..4 {
        for v in 0..3 {
            dy[l] = dy[l].max((uy[v][l] - cy[l]).abs());
            dz[l] = dz[l].max((uz[v][l] - cz[l]).abs());
            let lin = phi_c[l] + gy[l] * (uy[v][l] - cy[l]) + gz[l] * (uz[v][l] - cz[l]);
            llo[l] = llo[l].min(lin);
            lhi[l] = lhi[l].max(lin);
            w[l] = w[l].max((uy[v][l] - uz[v][l]).abs());
        }
    }
    let (mut dx, mut dyr, mut dzr) = ([0.0f64; 4], [0.0f64; 4], [0.0f64; 4]);
    for l in 0..4 {
        let (dy, dz, ym, zm, w) = (dy[l], dz[l], ym[l], zm[l], w[l]);
        let mut e0 = (hi[l] - llo[l]).max(lhi[l] - lo[l]).max(0.0);
        let mut ey = ym + ym * zm * gy[l].abs();
        let mut ez = zm + ym * zm * gz[l].abs();
        let s2 = smin[l] * smin[l];
        let s3 = s2 * smin[l];
        let taylor = smin[l] > 0.0;
        let t0 = e0
            .min((dy * dy + dy * dz + dz * dz) / s2)
            .min((zm * dy * dy + w * dy * dz + ym * dz * dz) / s3);
        let ty = ey
            .min(ym * zm * (2.0 * dy + dz) / s2)
            .min(ym * zm * (2.0 * zm * dy + w * dz) / s3);
        let tz = ez
            .min(ym * zm * (dy + 2.0 * dz) / s2)
            .min(ym * zm * (w * dy + 2.0 * ym * dz) / s3);
        e0 = if taylor { t0 } else { e0 };
        ey = if taylor { ty } else { ey };
        ez = if taylor { tz } else { ez };
        let xm = xm[l];
        dx[l] = 24.0 * xm * ym * zm * e0;
        dyr[l] = 12.0 * xm * xm * (zm * e0 + ey);
        dzr[l] = 12.0 * xm * xm * (ym * e0 + ez);
    }
    std::array::from_fn(|m| {
        let mut d = [0.0; 3];
        d[m] = dx[m];
        d[(m + 1) % 3] = dyr[m];
        d[(m + 2) % 3] = dzr[m];
        ([ell[0][m], ell[1][m], ell[2][m]], d[1] + d[0], d[2] + d[0])
    })
}

#[cfg(test)]
mod tests {
    use super::{blend_corners, blend_terms};
    use crate::patch::validity::{children, Cell};

    /// [`blend_corners`] is [`blend_terms`] of each corner, bit for bit, in every build this
    /// CPU can run (portable, AVX, AVX-512), on every cell of seven levels of the midpoint
    /// subdivision (21,845 cells: those at the domain's
    /// corners, where y + z vanishes at a cell corner and the Taylor branch is not taken,
    /// among them) and on cells with a corner in the middle of an edge or on no edge.
    #[test]
    fn blend_corners_are_blend_terms() {
        let mut level: Vec<Cell> = vec![[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]];
        let mut all = level.clone();
        for _ in 0..7 {
            level = level.iter().flat_map(children).collect();
            all.extend(&level);
        }
        all.push([[0.5, 0.5, 0.0], [0.0, 1.0, 0.0], [0.2, 0.3, 0.5]]);
        all.push([[0.1, 0.2, 0.7], [0.3, 0.3, 0.4], [0.6, 0.1, 0.3]]);
        assert_eq!(all.len(), 21_847);
        let bits = |(ell, bs, bt): ([f64; 3], f64, f64)| {
            [ell[0], ell[1], ell[2], bs, bt].map(f64::to_bits)
        };
        for cell in &all {
            #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
            let mut builds = vec![("portable", blend_corners(cell))];
            #[cfg(target_arch = "x86_64")]
            {
                if cpu_has!("avx") {
                    // SAFETY: the CPU has AVX (checked just above).
                    builds.push(("avx", unsafe { avx(cell) }));
                }
                if cpu_has!("avx512f", "avx512vl") {
                    // SAFETY: the CPU has AVX-512F and VL (checked just above).
                    builds.push(("avx512", unsafe { avx512(cell) }));
                }
            }
            for (build, lanes) in builds {
                for (m, &terms) in lanes.iter().enumerate() {
                    assert_eq!(
                        bits(terms),
                        bits(blend_terms(m, cell)),
                        "{build}: {cell:?} corner {m}"
                    );
                }
            }
        }
    }

    /// [`blend_corners`] built for AVX, as the four-lane bound's AVX path builds it.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn avx(cell: &Cell) -> [([f64; 3], f64, f64); 3] {
        blend_corners(cell)
    }

    /// [`blend_corners`] built for AVX-512, as `-C target-cpu=native` builds everything on
    /// such a CPU (rustc 1.95 once built it wrong: see the loop over the corners).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl")]
    fn avx512(cell: &Cell) -> [([f64; 3], f64, f64); 3] {
        blend_corners(cell)
    }
}
