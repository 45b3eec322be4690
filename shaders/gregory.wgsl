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
