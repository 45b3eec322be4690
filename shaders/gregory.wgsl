// Bézier G1 patch (PatchKind::Gregory): 3 × DEGREE quartic boundary points L_{k,0..3}
// (BOUNDARY), then the Gregory points G_{0,1}, G_{0,2}, G_{1,1}, G_{1,2}, G_{2,1}, G_{2,2}.
// Line for line:
// mirrors patch::basis::g1_boundary_powers, patch::basis::g1
// DEGREE comes from the generated header (PatchKind::layout).

// Boundary points: DEGREE per edge (L_{k,0..DEGREE−1}; L_{k,DEGREE} is L_{k+1,0}).
const BOUNDARY: u32 = 3u * DEGREE;

fn kind_weights(b: vec3<real>) -> Weights {
    return g1(b);
}

// Powers (on b0, b1, b2) of boundary point idx: edge k = idx / DEGREE, point
// j = idx % DEGREE (power DEGREE − j on vertex k, j on vertex k + 1).
fn g1_boundary_power(idx: u32) -> vec3<u32> {
    let k = idx / DEGREE;
    let j = idx % DEGREE;
    var p = vec3<u32>(0u);
    p[k] = DEGREE - j;
    p[(k + 1u) % 3u] = j;
    return p;
}

fn g1(b_in: vec3<real>) -> Weights {
    var b = b_in;
    var out: Weights;
    let nf = factorial(DEGREE);
    for (var idx = 0u; idx < BOUNDARY; idx++) {
        let p = g1_boundary_power(idx);
        let c = nf / (factorial(p.x) * factorial(p.y) * factorial(p.z));
        let m = monomial(c, p, b);
        out.w[idx] = m.v;
        out.ws[idx] = m.g.y - m.g.x;
        out.wt[idx] = m.g.z - m.g.x;
    }
    for (var m = 0u; m < 3u; m++) {
        let im = m;
        let iy = (m + 1u) % 3u;
        let iz = (m + 2u) % 3u;
        let x = b[im];
        let y = b[iy];
        let z = b[iz];
        let s = y + z;
        // Homogeneous gradient by (x, y, z) of alpha_m and beta_m; all tend to 0 at s = 0.
        var a = real(0.0);
        var da = vec3<real>(0.0);
        var be = real(0.0);
        var dbe = vec3<real>(0.0);
        if (s > real(0.0)) {
            let s2 = s * s;
            a = real(12.0) * x * x * y * y * z / s;
            da = vec3<real>(
                real(24.0) * x * y * y * z / s,
                real(12.0) * x * x * y * z * (y + real(2.0) * z) / s2,
                real(12.0) * x * x * y * y * y / s2,
            );
            be = real(12.0) * x * x * y * z * z / s;
            dbe = vec3<real>(
                real(24.0) * x * y * z * z / s,
                real(12.0) * x * x * z * z * z / s2,
                real(12.0) * x * x * y * z * (z + real(2.0) * y) / s2,
            );
        }
        // Map (x, y, z) derivatives back onto (b0, b1, b2).
        var ga = vec3<real>(0.0);
        var gb = vec3<real>(0.0);
        var slots = vec3<u32>(im, iy, iz);
        for (var slot = 0u; slot < 3u; slot++) {
            let bi = slots[slot];
            ga[bi] = da[slot];
            gb[bi] = dbe[slot];
        }
        // alpha_m weighs G_{m,1}; beta_m weighs G_{m-1,2}, stored at slot
        // BOUNDARY + 1 + 2(m − 1).
        let sa = BOUNDARY + 2u * m;
        let sb = BOUNDARY + 1u + 2u * ((m + 2u) % 3u);
        out.w[sa] = a;
        out.ws[sa] = ga.y - ga.x;
        out.wt[sa] = ga.z - ga.x;
        out.w[sb] = be;
        out.ws[sb] = gb.y - gb.x;
        out.wt[sb] = gb.z - gb.x;
    }
    return out;
}

// ---- the patch loop (grid_patch_main in common.wgsl) ----
// g1 above fills arrays, which drivers that keep them in scratch memory run far slower; the
// patch loop evaluates the same patch straight-line instead, with no table and no array
// but the control points. The patch is homogeneous of degree DEGREE in b (the Bernstein
// terms, and each Gregory term 12 x²y²z/(y + z) = degree 5 over degree 1), so by Euler's
// theorem P = Σ_k b_k ∂P/∂b_k / DEGREE: only the gradient is summed, a quarter of it (the
// factors DEGREE and 3 of the quartic's derivatives folded into the weights), and the
// position follows from it. The weights below are the quartic's (DEGREE = 4).

// Quarter gradient by (b0, b1, b2).
struct G1Grad {
    g0: vec3<real>,
    g1: vec3<real>,
    g2: vec3<real>,
}

// Quarter partial derivatives of edge k's four Bernstein terms (points a..d = L_{k,0..3},
// powers DEGREE − j on u = b_k and j on v = b_{k+1}): by u (du) and by v (dv).
struct G1EdgeGrad {
    du: vec3<real>,
    dv: vec3<real>,
}

fn g1_edge(
    u: real, v: real, a: vec3<real>, b: vec3<real>, c: vec3<real>, d: vec3<real>,
) -> G1EdgeGrad {
    let u2 = u * u;
    let v2 = v * v;
    let u3 = u2 * u;
    let v3 = v2 * v;
    let w1 = real(3.0) * u2 * v;
    let w2 = real(3.0) * u * v2;
    return G1EdgeGrad(u3 * a + w1 * b + w2 * c + v3 * d, u3 * b + w1 * c + w2 * d);
}

// Quarter partial derivatives by (x, y, z) = (b_m, b_{m+1}, b_{m+2}) of corner m's two
// Gregory terms, alpha_m G_{m,1} + beta_m G_{m-1,2} (p1, p2), in g0, g1, g2; with
// s = y + z: alpha_m = 12 x²y²z/s, beta_m = 12 x²yz²/s (g1 above), whose derivatives
// all tend to 0 where s = 0 (there y = z = 0 and every weight below is 0).
fn g1_corner(x: real, y: real, z: real, p1: vec3<real>, p2: vec3<real>) -> G1Grad {
    let s = y + z;
    let inv = real(1.0) / select(real(1.0), s, s > real(0.0));
    let k = real(3.0) * x * x * inv * inv;
    let kyz = k * y * z;
    let r = real(6.0) * x * y * z * inv;
    return G1Grad(
        (r * y) * p1 + (r * z) * p2,
        (kyz * (y + real(2.0) * z)) * p1 + (k * z * z * z) * p2,
        (k * y * y * y) * p1 + (kyz * (real(2.0) * y + z)) * p2,
    );
}

// The quarter gradient of the patch at b: edge k's points are slots k·DEGREE + j, corner
// m's Gregory points G_{m,1} (slot BOUNDARY + 2m) and G_{m-1,2} (slot BOUNDARY + 1 +
// 2((m + 2) mod 3)), as g1 above weighs them.
fn g1_quarter_gradient(b: vec3<real>) -> G1Grad {
    let e0 = g1_edge(b.x, b.y, loop_cp[0u], loop_cp[1u], loop_cp[2u], loop_cp[3u]);
    let e1 = g1_edge(
        b.y, b.z,
        loop_cp[DEGREE], loop_cp[DEGREE + 1u], loop_cp[DEGREE + 2u], loop_cp[DEGREE + 3u],
    );
    const K2: u32 = 2u * DEGREE;
    let e2 = g1_edge(
        b.z, b.x,
        loop_cp[K2], loop_cp[K2 + 1u], loop_cp[K2 + 2u], loop_cp[K2 + 3u],
    );
    let m0 = g1_corner(b.x, b.y, b.z, loop_cp[BOUNDARY], loop_cp[BOUNDARY + 1u + 2u * 2u]);
    let m1 = g1_corner(b.y, b.z, b.x, loop_cp[BOUNDARY + 2u], loop_cp[BOUNDARY + 1u]);
    let m2 = g1_corner(b.z, b.x, b.y, loop_cp[BOUNDARY + 2u * 2u], loop_cp[BOUNDARY + 3u]);
    return G1Grad(
        e0.du + e2.dv + m0.g0 + m1.g2 + m2.g1,
        e0.dv + e1.du + m0.g1 + m1.g0 + m2.g2,
        e1.dv + e2.du + m0.g2 + m1.g1 + m2.g0,
    );
}

// The patch loop's sample (common.wgsl: LoopPoint) at b: P from Euler's theorem, and
// ∂S/∂s × ∂S/∂t = DEGREE² (G1 − G0) × (G2 − G0), returned without the factor (scale).
fn kind_loop_point(b: vec3<real>, l: u32) -> LoopPoint {
    let g = g1_quarter_gradient(b);
    let p = b.x * g.g0 + b.y * g.g1 + b.z * g.g2;
    return LoopPoint(p, cross(g.g1 - g.g0, g.g2 - g.g0), real(DEGREE * DEGREE));
}
