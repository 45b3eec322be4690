// Shared code of every evaluation shader (see src/gpu/shaders.rs, which assembles a module
// as: a generated header, then the kind's file (bezier.wgsl or gregory.wgsl), then this
// file).
//
// mirrors patch::PatchTable::eval_weights, patch::unit_normal
// mirrors patch::basis::monomial, patch::basis::bezier
// mirrors eval::pattern::grid_index, eval::pattern::grid_barycentrics
//
// The header is generated from PatchKind::layout(), patch::basis::MAX_POINTS and
// patch::MIN_NORMAL_LEN_F32 / _F64 (never copy those numbers here; tests/shaders.rs checks):
//   alias real = f32 | f64;            the working precision
//   const STRIDE, GEOMETRY, DEGREE;    the kind's layout (GEOMETRY < STRIDE: PN's normal
//                                      field follows the geometry)
//   const MAX_POINTS;                  slots of Weights (the most control points of a kind)
//   const WORKGROUP;                   threads per workgroup (gpu::eval::WORKGROUP)
//   const MIN_NORMAL_LEN, MAX_REAL;    a usable vector length is > MIN_NORMAL_LEN and
//                                      <= MAX_REAL (finite), else the fallback normal
//   const PATCH_VECS, SLOT_FLAT_NORMAL, SLOT_ORIGIN_LO, SLOT_CORNERS: the patch upload
// The kind's file defines
//   fn kind_weights(b: vec3<real>) -> Weights
// mirroring PatchKind::weights in src/patch/mod.rs.
//
// Input: one patch upload per patch, PATCH_VECS vectors: STRIDE control points (geometry
// points relative to the patch's first control point, so f32 keeps its digits far from
// the origin; the normal field as it is), the flat unit normal (SLOT_FLAT_NORMAL), the low
// part of the first control point (SLOT_ORIGIN_LO: c0 − real(c0), zero in f64), and the
// three corners in absolute coordinates rounded once to real (SLOT_CORNERS + k; corner 0
// is also the high part of the origin).
// Output of a dispatch of `count` samples: positions (absolute: origin + evaluation) in
// out[0 .. 3 count], unit normals in out[3 count .. 6 count]. Corner samples are the
// uploaded corners bit for bit.


// Basis values and tangent-direction derivatives (src/patch/basis.rs: Weights).
struct Weights {
    w: array<real, MAX_POINTS>,
    ws: array<real, MAX_POINTS>,
    wt: array<real, MAX_POINTS>,
}

// One dispatch. Grid: thread t evaluates sample first_local + t counted from the first
// point of patch upload 0 (per samples per patch). Points: thread t evaluates points[t].
struct Params {
    count: u32,
    first_local: u32,
    level: u32,
    per: u32,
    // Workgroups along x: dispatches wider than the adapter's per-dimension limit are
    // folded into y.
    groups_x: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// An explicit evaluation point: barycentrics and the patch upload it refers to.
struct Point {
    b0: real,
    b1: real,
    b2: real,
    patch_index: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> patch_data: array<real>;
@group(0) @binding(2) var<storage, read> points: array<Point>;
@group(0) @binding(3) var<storage, read_write> out: array<real>;
// Basis values of the grid (grid_table_main): value (j * 3 + k) * per + local is, for
// grid point `local` and control point j, w (k = 0), ∂w/∂s (k = 1) or ∂w/∂t (k = 2),
// computed once on the CPU by src/patch/basis.rs (src/eval/cpu.rs: grid_weights).
@group(0) @binding(4) var<storage, read> grid_w: array<real>;

// The grid's basis for grid_patch_main: entry l * STRIDE + j holds (w, ∂w/∂s, ∂w/∂t, 0)
// of control point j at grid point l (src/eval/gpu.rs: uniform_table). A uniform buffer:
// lavapipe reads uniform buffers with vector gathers, storage buffers one lane at a time.
@group(0) @binding(5) var<uniform> grid_u: array<vec4<real>, GRID_U_VECS>;

struct Sample {
    p: vec3<real>,
    n: vec3<real>,
}

// ---- Bernstein helpers (src/patch/basis.rs) ----

fn factorial(n: u32) -> real {
    var f = real(1.0);
    for (var x = 2u; x <= n; x++) {
        f *= real(x);
    }
    return f;
}

// x^e by repeated products (basis.rs: pw), 1 for e = 0.
fn ipow(x: real, e: u32) -> real {
    var r = real(1.0);
    for (var k = 0u; k < e; k++) {
        r *= x;
    }
    return r;
}

// d/dx x^e (0 for e = 0).
fn dpow(x: real, e: u32) -> real {
    if (e == 0u) {
        return real(0.0);
    }
    return real(e) * ipow(x, e - 1u);
}

struct Mono {
    v: real,
    g: vec3<real>,
}

// Value and homogeneous gradient of c · b0^p0 b1^p1 b2^p2 (basis.rs: monomial).
fn monomial(c: real, p: vec3<u32>, b: vec3<real>) -> Mono {
    let v = vec3<real>(ipow(b.x, p.x), ipow(b.y, p.y), ipow(b.z, p.z));
    let d = vec3<real>(dpow(b.x, p.x), dpow(b.y, p.y), dpow(b.z, p.z));
    return Mono(
        c * v.x * v.y * v.z,
        vec3<real>(c * d.x * v.y * v.z, c * v.x * d.y * v.z, c * v.x * v.y * d.z),
    );
}

// Bernstein basis of degree n with tangent derivatives, points in bezier_powers order:
// i (power on b0) from n down to 0, then j from n - i down to 0 (basis.rs: bezier).
fn bezier(n: u32, b: vec3<real>) -> Weights {
    var out: Weights;
    let nf = factorial(n);
    var idx = 0u;
    for (var i = i32(n); i >= 0; i--) {
        for (var j = i32(n) - i; j >= 0; j--) {
            let p = vec3<u32>(u32(i), u32(j), n - u32(i) - u32(j));
            let c = nf / (factorial(p.x) * factorial(p.y) * factorial(p.z));
            let m = monomial(c, p, b);
            out.w[idx] = m.v;
            out.ws[idx] = m.g.y - m.g.x;
            out.wt[idx] = m.g.z - m.g.x;
            idx++;
        }
    }
    return out;
}

// ---- patch evaluation (src/patch/mod.rs) ----

// Vector `slot` of patch upload i (control point j < STRIDE, then the extra slots).
fn patch_vec(i: u32, slot: u32) -> vec3<real> {
    let o = (i * PATCH_VECS + slot) * 3u;
    return vec3<real>(patch_data[o], patch_data[o + 1u], patch_data[o + 2u]);
}

fn control_point(i: u32, j: u32) -> vec3<real> {
    return patch_vec(i, j);
}

fn flat_normal(i: u32) -> vec3<real> {
    return patch_vec(i, SLOT_FLAT_NORMAL);
}

// Usable length: above the threshold, finite, not NaN (patch/mod.rs: unit_normal).
fn usable(len: real) -> bool {
    return len > MIN_NORMAL_LEN && len <= MAX_REAL;
}

// No corner: the third of corner_of_b and corner_of_local's answers.
const NO_CORNER: u32 = 3u;

// Which corner b is (b = the unit vector e_k), or NO_CORNER.
fn corner_of_b(b: vec3<real>) -> u32 {
    for (var k = 0u; k < 3u; k++) {
        var unit = true;
        for (var m = 0u; m < 3u; m++) {
            let e = select(real(0.0), real(1.0), m == k);
            unit = unit && b[m] == e;
        }
        if (unit) {
            return k;
        }
    }
    return NO_CORNER;
}

// Which corner grid point `local` of level n is: index 0 is b = e_0, index n (i = n, j = 0)
// is e_1, the last index (j = n) is e_2.
fn corner_of_local(n: u32, local: u32) -> u32 {
    if (local == 0u) {
        return 0u;
    }
    if (local == n) {
        return 1u;
    }
    if (local == params.per - 1u) {
        return 2u;
    }
    return NO_CORNER;
}

// The sample in absolute coordinates: the origin added to the patch-relative position as
// high part + (low part + position), or the uploaded corner exactly at a corner.
fn absolute(i: u32, s: Sample, corner: u32) -> Sample {
    if (corner < NO_CORNER) {
        return Sample(patch_vec(i, SLOT_CORNERS + corner), s.n);
    }
    let hi = patch_vec(i, SLOT_CORNERS);
    let lo = patch_vec(i, SLOT_ORIGIN_LO);
    return Sample(hi + (lo + s.p), s.n);
}

// patch/mod.rs: unit_normal. S_s × S_t normalised, the flat normal where it vanishes.
fn unit_normal(ds: vec3<real>, dt: vec3<real>, fallback: vec3<real>) -> vec3<real> {
    let c = cross(ds, dt);
    let len = length(c);
    if (usable(len)) {
        return c / len;
    }
    return fallback;
}

// patch/mod.rs: the normal of PatchTable::eval_weights. Kinds with a normal field
// (GEOMETRY < STRIDE) report the normalised field, the others the exact normal; the flat
// normal where either vanishes.
fn patch_normal(i: u32, ds: vec3<real>, dt: vec3<real>, field: vec3<real>) -> vec3<real> {
    if (GEOMETRY < STRIDE) {
        let len = length(field);
        if (usable(len)) {
            return field / len;
        }
        return flat_normal(i);
    }
    return unit_normal(ds, dt, flat_normal(i));
}

// patch/mod.rs: PatchTable::eval_weights.
fn eval_weights(i: u32, w: Weights) -> Sample {
    var p = vec3<real>(0.0);
    var ds = vec3<real>(0.0);
    var dt = vec3<real>(0.0);
    for (var j = 0u; j < GEOMETRY; j++) {
        let cj = control_point(i, j);
        p += w.w[j] * cj;
        ds += w.ws[j] * cj;
        dt += w.wt[j] * cj;
    }
    // The PN normal field (slots GEOMETRY..STRIDE), if the kind has one.
    var field = vec3<real>(0.0);
    for (var j = GEOMETRY; j < STRIDE; j++) {
        field += w.w[j] * control_point(i, j);
    }
    return Sample(p, patch_normal(i, ds, dt, field));
}

// ---- sample layout ----

// Thread index of a dispatch folded into x and y.
fn thread_index(gid: vec3<u32>) -> u32 {
    return gid.y * params.groups_x * WORKGROUP + gid.x;
}

// First grid index of row j (pattern.rs: grid_index(n, 0, j)).
fn row_start(n: u32, j: u32) -> u32 {
    return j * (n + 1u) - j * select(0u, j - 1u, j > 0u) / 2u;
}

// Grid index -> (i, j) with b1 = i/n, b2 = j/n: rows of constant j, i increasing.
fn grid_ij(n: u32, k: u32) -> vec2<u32> {
    // Solve row_start(j) <= k in floating point, then settle exactly in integers.
    let a = f32(2u * n + 3u);
    var j = u32(max(floor((a - sqrt(max(a * a - 8.0 * f32(k), 0.0))) * 0.5), 0.0));
    j = min(j, n);
    loop {
        if (j > 0u && row_start(n, j) > k) {
            j -= 1u;
        } else if (j < n && row_start(n, j + 1u) <= k) {
            j += 1u;
        } else {
            break;
        }
    }
    return vec2<u32>(k - row_start(n, j), j);
}

// Barycentrics of grid point (i, j): ((n − i − j)/n, i/n, j/n) (pattern.rs).
fn grid_barycentric(n: u32, ij: vec2<u32>) -> vec3<real> {
    let nf = real(n);
    return vec3<real>(real(n - ij.x - ij.y) / nf, real(ij.x) / nf, real(ij.y) / nf);
}

// Position t in the first half of `out`, normal t in the second.
fn store(t: u32, s: Sample) {
    let o = t * 3u;
    out[o] = s.p.x;
    out[o + 1u] = s.p.y;
    out[o + 2u] = s.p.z;
    let m = (params.count + t) * 3u;
    out[m] = s.n.x;
    out[m + 1u] = s.n.y;
    out[m + 2u] = s.n.z;
}

@compute @workgroup_size(WORKGROUP)
fn grid_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = thread_index(gid);
    if (t >= params.count) {
        return;
    }
    let q = params.first_local + t;
    let i = q / params.per;
    let local = q - i * params.per;
    let b = grid_barycentric(params.level, grid_ij(params.level, local));
    store(t, absolute(i, eval_weights(i, kind_weights(b)), corner_of_local(params.level, local)));
}

// eval_weights with the basis of grid point `local` read from the precomputed table as
// it is used (no local arrays: drivers that keep them in scratch memory run far slower).
fn eval_table(i: u32, local: u32) -> Sample {
    let per = params.per;
    var p = vec3<real>(0.0);
    var ds = vec3<real>(0.0);
    var dt = vec3<real>(0.0);
    for (var j = 0u; j < GEOMETRY; j++) {
        let cj = control_point(i, j);
        p += grid_w[(j * 3u) * per + local] * cj;
        ds += grid_w[(j * 3u + 1u) * per + local] * cj;
        dt += grid_w[(j * 3u + 2u) * per + local] * cj;
    }
    // The PN normal field (slots GEOMETRY..STRIDE), if the kind has one.
    var field = vec3<real>(0.0);
    for (var j = GEOMETRY; j < STRIDE; j++) {
        field += grid_w[(j * 3u) * per + local] * control_point(i, j);
    }
    return Sample(p, patch_normal(i, ds, dt, field));
}

// As grid_main, with the basis read from the precomputed table instead of computed.
@compute @workgroup_size(WORKGROUP)
fn grid_table_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = thread_index(gid);
    if (t >= params.count) {
        return;
    }
    let q = params.first_local + t;
    let i = q / params.per;
    let local = q - i * params.per;
    store(t, absolute(i, eval_table(i, local), corner_of_local(params.level, local)));
}

@compute @workgroup_size(WORKGROUP)
fn points_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = thread_index(gid);
    if (t >= params.count) {
        return;
    }
    let pt = points[t];
    let b = vec3<real>(pt.b0, pt.b1, pt.b2);
    store(t, absolute(pt.patch_index, eval_weights(pt.patch_index, kind_weights(b)), corner_of_b(b)));
}

// The output of grid_patch_main seen as vec4s (the same buffer as `out`; only that entry
// point uses it): a vector store costs drivers that store one SIMD lane at a time (lavapipe)
// one pass over the lanes for its 4 values instead of one per value.
@group(0) @binding(7) var<storage, read_write> out4: array<vec4<real>>;

// A sample of the patch loop from the kind's file (kind_loop_point): the position relative
// to the patch's first control point, and the vector whose direction is the normal, scale
// times its length being the length patch_normal tests (the kinds' files say which).
struct LoopPoint {
    p: vec3<real>,
    v: vec3<real>,
    scale: real,
}

// The control points of grid_patch_main's patch (kind_loop_point reads them).
var<private> loop_cp: array<vec3<real>, STRIDE>;

// What grid_patch_main keeps of a patch besides its control points.
struct LoopPatch {
    fallback: vec3<real>,
    hi: vec3<real>,
    lo: vec3<real>,
    c1: vec3<real>,
    c2: vec3<real>,
}

// Sample at grid index l = (i, j) of the patch: absolute(), and patch_normal without
// branches (the flat normal where the vector is unusable, the corners as uploaded).
fn loop_sample(x: LoopPatch, l: u32, ij: vec2<u32>) -> Sample {
    let n = params.level;
    let q = kind_loop_point(grid_barycentric(n, ij), l);
    let len = length(q.v);
    let normal = select(x.fallback, q.v / len, usable(q.scale * len));
    var pos = x.hi + (x.lo + q.p);
    pos = select(pos, x.hi, l == 0u);
    pos = select(pos, x.c1, l == n);
    pos = select(pos, x.c2, l == params.per - 1u);
    return Sample(pos, normal);
}

// The grid index after ij (rows of constant j, i increasing).
fn next_ij(n: u32, ij: vec2<u32>) -> vec2<u32> {
    let wrap = ij.x + ij.y >= n;
    return select(vec2<u32>(ij.x + 1u, ij.y), vec2<u32>(0u, ij.y + 1u), wrap);
}

// store() through out4: sample t's six values one by one.
fn store_one(t: u32, s: Sample) {
    let o = t * 3u;
    let m = (params.count + t) * 3u;
    for (var c = 0u; c < 3u; c++) {
        out4[(o + c) / 4u][(o + c) % 4u] = s.p[c];
        out4[(m + c) / 4u][(m + c) % 4u] = s.n[c];
    }
}

// Three vectors packed into the vec4s o, o + 1, o + 2.
fn store_packed(o: u32, a: vec3<real>, b: vec3<real>, c: vec3<real>, d: vec3<real>) {
    out4[o] = vec4<real>(a, b.x);
    out4[o + 1u] = vec4<real>(b.yz, c.xy);
    out4[o + 2u] = vec4<real>(c.z, d);
}

// store() of samples t .. t + 3, t and params.count multiples of 4: the four positions
// fill the vec4s 3t/4 ..= 3t/4 + 2, the normals likewise after 3 count/4.
fn store_quad(t: u32, a: Sample, b: Sample, c: Sample, d: Sample) {
    store_packed(t / 4u * 3u, a.p, b.p, c.p, d.p);
    store_packed((params.count + t) / 4u * 3u, a.n, b.n, c.n, d.n);
}

// The grid with one thread per patch: thread t evaluates every grid point of patch upload
// first_local / per + t, its control points read once, each point's sample from
// kind_loop_point (Bézier kinds: the basis from grid_u, the same for every thread, so the
// driver's SIMD lanes share it; G1: straight-line). For drivers that run invocations as
// SIMD lanes of a CPU (lavapipe), where each storage-buffer access costs a loop over the
// lanes; GPUs run grid_table_main, one thread per sample. The dispatch's samples are whole
// patches (count a multiple of per). Where count is a multiple of 4, the samples from the
// first multiple of 4 on are stored four at a time as vec4s (store_quad), the others one
// by one.
@compute @workgroup_size(WORKGROUP)
fn grid_patch_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = thread_index(gid);
    let per = params.per;
    let patches = params.count / per;
    // Threads past the last patch evaluate it again and store nothing.
    let valid = t < patches;
    let i = params.first_local / per + min(t, patches - 1u);
    for (var j = 0u; j < STRIDE; j++) {
        loop_cp[j] = control_point(i, j);
    }
    let x = LoopPatch(
        flat_normal(i),
        patch_vec(i, SLOT_CORNERS),
        patch_vec(i, SLOT_ORIGIN_LO),
        patch_vec(i, SLOT_CORNERS + 1u),
        patch_vec(i, SLOT_CORNERS + 2u),
    );
    let n = params.level;
    let first = t * per;
    // Samples before the first quad: up to 3, or all of them when count is not a multiple
    // of 4.
    let head = select(per, min((4u - first % 4u) % 4u, per), params.count % 4u == 0u);
    let quads_end = head + (per - head) / 4u * 4u;
    var ij = vec2<u32>(0u);
    var l = 0u;
    for (; l < head; l++) {
        let s = loop_sample(x, l, ij);
        if (valid) {
            store_one(first + l, s);
        }
        ij = next_ij(n, ij);
    }
    for (; l < quads_end; l += 4u) {
        let s0 = loop_sample(x, l, ij);
        ij = next_ij(n, ij);
        let s1 = loop_sample(x, l + 1u, ij);
        ij = next_ij(n, ij);
        let s2 = loop_sample(x, l + 2u, ij);
        ij = next_ij(n, ij);
        let s3 = loop_sample(x, l + 3u, ij);
        ij = next_ij(n, ij);
        if (valid) {
            store_quad(first + l, s0, s1, s2, s3);
        }
    }
    for (; l < per; l++) {
        let s = loop_sample(x, l, ij);
        if (valid) {
            store_one(first + l, s);
        }
        ij = next_ij(n, ij);
    }
}
