// Table 1's continuity statistics on the device (appended to an evaluation module, after
// common.wgsl; src/eval/gpu_stats.rs). Only the aggregates leave the device.
//
// mirrors analysis::stats::edge_pairs, analysis::stats::continuity
//
// Thread t is edge sample t of the dispatch: points[2t] on the edge's first patch,
// points[2t + 1] the same point on the second, each evaluated as points_main does (corners
// exactly the uploaded corners). The high bit of the second point's patch index marks a
// crease edge: its samples count only towards the crease gap. Each workgroup folds its
// samples in thread order the way the CPU's statistics fold a block (Part::push in
// src/output/stats.rs: cos sums with the first cos subtracted) and writes one record of
// STATS_REALS reals at out[STATS_REALS × workgroup]: n, shift, Σd, Σd², min, max,
// max 1 − |cos|, max gap², folded (cos < 0), crease n, crease max gap². The host merges
// the records (Chan et al.'s update, as Totals::merge).

// STATS_REALS and CREASE_BIT come from a generated line (src/gpu/shaders.rs:
// stats_source).

var<workgroup> s_valid: array<u32, WORKGROUP>;
var<workgroup> s_cos: array<real, WORKGROUP>;
var<workgroup> s_gap2: array<real, WORKGROUP>;

@compute @workgroup_size(WORKGROUP)
fn stats_main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let t = thread_index(gid);
    // 0: no sample, 1: a sample, 2: a crease sample.
    var kind = 0u;
    var c = real(0.0);
    var gap2 = real(0.0);
    if (t < params.count) {
        let pa = points[2u * t];
        let pb = points[2u * t + 1u];
        let ia = pa.patch_index;
        let ib = pb.patch_index & ~CREASE_BIT;
        let ba = vec3<real>(pa.b0, pa.b1, pa.b2);
        let bb = vec3<real>(pb.b0, pb.b1, pb.b2);
        let sa = absolute(ia, eval_weights(ia, kind_weights(ba)), corner_of_b(ba));
        let sb = absolute(ib, eval_weights(ib, kind_weights(bb)), corner_of_b(bb));
        let d = sa.p - sb.p;
        gap2 = dot(d, d);
        c = dot(sa.n, sb.n);
        kind = select(1u, 2u, (pb.patch_index & CREASE_BIT) != 0u);
    }
    s_valid[li] = kind;
    s_cos[li] = c;
    s_gap2[li] = gap2;
    workgroupBarrier();
    if (li != 0u) {
        return;
    }
    var n = real(0.0);
    var shift = real(0.0);
    var s1 = real(0.0);
    var s2 = real(0.0);
    var lo = MAX_REAL;
    var hi = -MAX_REAL;
    var worst = real(0.0);
    var g2 = real(0.0);
    var folded = real(0.0);
    var crease_n = real(0.0);
    var crease_g2 = real(0.0);
    for (var k = 0u; k < WORKGROUP; k++) {
        let v = s_valid[k];
        let ck = s_cos[k];
        let gk = s_gap2[k];
        if (v == 2u) {
            crease_n += real(1.0);
            crease_g2 = max(crease_g2, gk);
        } else if (v == 1u) {
            if (n == real(0.0)) {
                shift = ck;
            }
            let dk = ck - shift;
            n += real(1.0);
            s1 += dk;
            s2 += dk * dk;
            lo = min(lo, ck);
            hi = max(hi, ck);
            worst = max(worst, real(1.0) - abs(ck));
            g2 = max(g2, gk);
            folded += select(real(0.0), real(1.0), ck < real(0.0));
        }
    }
    let groups = wid.y * params.groups_x + wid.x;
    let o = groups * STATS_REALS;
    out[o] = n;
    out[o + 1u] = shift;
    out[o + 2u] = s1;
    out[o + 3u] = s2;
    out[o + 4u] = lo;
    out[o + 5u] = hi;
    out[o + 6u] = worst;
    out[o + 7u] = g2;
    out[o + 8u] = folded;
    out[o + 9u] = crease_n;
    out[o + 10u] = crease_g2;
}
