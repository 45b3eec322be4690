//! Bounds on the Gregory blend of corner m on a cell of the subdivision: its extent there
//! ([`blend_extent`]) and what its Taylor polynomial at the cell's centroid leaves out
//! ([`blend_terms`], the linearised blend of [`super::Geometry::bound`]).

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
