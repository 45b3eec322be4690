// Device-resident tessellation with a level per edge (src/gpu/tessellator.rs:
// GpuTessellator::tessellate_levels): the pattern of tess::layout (OpenSubdiv Bfr's
// non-uniform triangle, integer partitioning) and the numbering of
// tess::stitch::StitchPlan::with_levels, from a per-edge u32 level buffer on the device.
// Appended, like tessellate.wgsl (and instead of it), to the evaluation module of the patch
// kind and the header of src/gpu/tessellator.rs (tess_header); it uses from the evaluation
// module only kind_weights, eval_weights, eval_table, Sample, absolute, grid_ij,
// grid_barycentric, row_start and the group-0 bindings params (per), patch_data, grid_w.
//
// mirrors tess::layout::effective_inner, tess::layout::points, tess::layout::triangles
// mirrors tess::levels::InnerRule::inner, gpu::tessellator::Topology::new
// mirrors gpu::tessellator::level_grid_base
//
// Numbering: every item of the stitched order (a corner record, the record block of an
// edge use, a patch's interior) starts at a + block_off[b] + int_off[c], where (a, b, c)
// are the topology table's (corner records, edge blocks and interiors before it) and
// block_off / int_off the exclusive prefix sums of the blocks' (E − 1) and the interiors'
// (n' − 1)(n' − 2)/2 sample counts, in creation order, computed on the device each time.
//
// Passes, in order: lv_patch_main (per patch: clamped edge levels and inner level),
// lv_scan_main (4 workgroups: the prefix sums of block samples, interior samples, patch
// samples and patch triangles, one workgroup each), lv_finish_main (indirect draw and
// dispatch arguments from the totals), lv_points_main or lv_points_basis_main (one thread
// per sample, dispatched indirectly), lv_triangles_main (one thread per patch, a serial walk of its pattern),
// lv_copy_main (one thread per patch edge: split-normal records take the owner's
// positions).

struct Lv {
    patches: u32,
    blocks: u32,
    edges: u32,
    max_level: u32,
    // 0 max, 1 mean, 2 min (tess::levels::InnerRule); 3: inner levels given in
    // levels[edges + p].
    rule: u32,
    patch_groups_x: u32,
    max_groups: u32,
    // Corner records (the topology's a total).
    corner_records: u32,
    // Offsets (u32) in `state` of the per-patch levels (4 per patch) and of the prefix sums.
    pinfo: u32,
    block_off: u32,
    int_off: u32,
    pt_off: u32,
    tri_off: u32,
    // Workgroups along x of lv_copy_main (3 threads per patch).
    copy_groups_x: u32,
    _pad2: u32,
    _pad3: u32,
}

// Head of `state`: totals (blocks, interiors, points, triangles), the draw arguments
// (DrawIndexedIndirectArgs), the dispatch arguments of lv_points_main, the vertex records,
// the x workgroups of lv_points_main.
const ST_TOTALS: u32 = 0u;
const ST_DRAW: u32 = 4u;
const ST_DISPATCH: u32 = 9u;
const ST_RECORDS: u32 = 12u;
const ST_POINT_GROUPS_X: u32 = 13u;

@group(1) @binding(0) var<uniform> lv: Lv;
@group(1) @binding(1) var<storage, read> topology: array<u32>;
@group(1) @binding(2) var<storage, read_write> vertices: array<f32>;
@group(1) @binding(3) var<storage, read_write> indices: array<u32>;
// patch_edges[3p + k]: the adjacency edge of local edge k; then block_edge[b] at 3 patches.
@group(1) @binding(4) var<storage, read> statics: array<u32>;
@group(1) @binding(5) var<storage, read> levels: array<u32>;
@group(1) @binding(6) var<storage, read_write> state: array<u32>;

fn lv_thread(gid: vec3<u32>, groups_x: u32) -> u32 {
    return gid.y * groups_x * TESS_WORKGROUP + gid.x;
}

fn topo(p: u32, o: u32) -> u32 {
    return topology[p * TOPO_STRIDE + o];
}

fn clamp_level(l: u32) -> u32 {
    return clamp(l, 1u, max(lv.max_level, 1u));
}

fn edge_level(e: u32) -> u32 {
    return clamp_level(levels[e]);
}

// tess::layout::effective_inner.
fn effective_inner(e: vec3<u32>, inner: u32) -> u32 {
    if (e.x == inner && e.y == inner && e.z == inner) {
        return inner;
    }
    return max(inner, 3u);
}

fn interior_count(n: u32) -> u32 {
    return (n - 1u) * (n - 2u) / 2u;
}

fn triangle_count(e: vec3<u32>, n: u32) -> u32 {
    return (n - 3u) * (n - 3u) + e.x + e.y + e.z + 3u * (n - 3u);
}

// Edge levels and inner level of patch p (written by lv_patch_main).
fn patch_edges_levels(p: u32) -> vec3<u32> {
    let o = lv.pinfo + 4u * p;
    return vec3<u32>(state[o], state[o + 1u], state[o + 2u]);
}

fn patch_inner(p: u32) -> u32 {
    return state[lv.pinfo + 4u * p + 3u];
}

// One thread per patch: its clamped edge levels and its inner level (by rule, or given).
@compute @workgroup_size(TESS_WORKGROUP)
fn lv_patch_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = lv_thread(gid, lv.patch_groups_x);
    if (p >= lv.patches) {
        return;
    }
    let e = vec3<u32>(
        edge_level(statics[3u * p]),
        edge_level(statics[3u * p + 1u]),
        edge_level(statics[3u * p + 2u]),
    );
    var inner = max(max(e.x, e.y), e.z);
    if (lv.rule == 1u) {
        inner = (e.x + e.y + e.z + 1u) / 3u;
    } else if (lv.rule == 2u) {
        inner = min(min(e.x, e.y), e.z);
    } else if (lv.rule == 3u) {
        inner = clamp_level(levels[lv.edges + p]);
    }
    let o = lv.pinfo + 4u * p;
    state[o] = e.x;
    state[o + 1u] = e.y;
    state[o + 2u] = e.z;
    state[o + 3u] = inner;
}

// Value q of scan `which`: 0 samples of block q, 1 interior samples, 2 samples and 3
// triangles of patch q.
fn scan_value(which: u32, q: u32) -> u32 {
    if (which == 0u) {
        return edge_level(statics[3u * lv.patches + q]) - 1u;
    }
    let e = patch_edges_levels(q);
    let n = effective_inner(e, patch_inner(q));
    if (which == 1u) {
        return interior_count(n);
    }
    if (which == 2u) {
        return 3u + e.x + e.y + e.z - 3u + interior_count(n);
    }
    if (e.x == n && e.y == n && e.z == n) {
        return n * n;
    }
    return triangle_count(e, n);
}

const SCAN_THREADS: u32 = 256u;
var<workgroup> scan_sums: array<u32, 256>;

// Workgroup w computes the exclusive prefix sums of scan w: each thread sums a contiguous
// run serially, the runs' sums are scanned in shared memory, then each run is written.
@compute @workgroup_size(256)
fn lv_scan_main(
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let which = wid.x;
    var count = lv.patches;
    var out = lv.int_off;
    if (which == 0u) {
        count = lv.blocks;
        out = lv.block_off;
    } else if (which == 2u) {
        out = lv.pt_off;
    } else if (which == 3u) {
        out = lv.tri_off;
    }
    let chunk = (count + SCAN_THREADS - 1u) / SCAN_THREADS;
    let start = min(lid.x * chunk, count);
    let end = min(start + chunk, count);
    var sum = 0u;
    for (var q = start; q < end; q++) {
        sum += scan_value(which, q);
    }
    scan_sums[lid.x] = sum;
    workgroupBarrier();
    for (var d = 1u; d < SCAN_THREADS; d *= 2u) {
        var v = 0u;
        if (lid.x >= d) {
            v = scan_sums[lid.x - d];
        }
        workgroupBarrier();
        scan_sums[lid.x] += v;
        workgroupBarrier();
    }
    var acc = scan_sums[lid.x] - sum;
    for (var q = start; q < end; q++) {
        state[out + q] = acc;
        acc += scan_value(which, q);
    }
    if (lid.x == SCAN_THREADS - 1u) {
        state[ST_TOTALS + which] = scan_sums[SCAN_THREADS - 1u];
    }
}

// One thread: the draw arguments, the vertex record count and the dispatch of
// lv_points_main (workgroups folded into y beyond max_groups).
@compute @workgroup_size(1)
fn lv_finish_main() {
    state[ST_DRAW] = 3u * state[ST_TOTALS + 3u];
    state[ST_DRAW + 1u] = 1u;
    state[ST_DRAW + 2u] = 0u;
    state[ST_DRAW + 3u] = 0u;
    state[ST_DRAW + 4u] = 0u;
    let g = max((state[ST_TOTALS + 2u] + TESS_WORKGROUP - 1u) / TESS_WORKGROUP, 1u);
    let x = min(g, max(lv.max_groups, 1u));
    state[ST_DISPATCH] = x;
    state[ST_DISPATCH + 1u] = (g + x - 1u) / x;
    state[ST_DISPATCH + 2u] = 1u;
    state[ST_POINT_GROUPS_X] = x;
    state[ST_RECORDS] = lv.corner_records + state[ST_TOTALS] + state[ST_TOTALS + 1u];
    // block_off has one entry more, the total: the interiors of the last patches come
    // after every block.
    state[lv.block_off + lv.blocks] = state[ST_TOTALS];
}

// First record of the item whose (a, b, c) is at offset o of patch p's entry.
fn item_base(p: u32, o: u32) -> u32 {
    return topo(p, o) + state[lv.block_off + topo(p, o + 1u)] + state[lv.int_off + topo(p, o + 2u)];
}

fn interior_base(p: u32) -> u32 {
    return topo(p, TOPO_INTERIOR) + state[lv.block_off + topo(p, TOPO_INTERIOR + 1u)]
        + state[lv.int_off + p];
}

struct LvRec {
    id: u32,
    flags: u32,
}

// Record of local sample `local` of patch p (tess::layout's local order: corners, the
// E_k − 1 samples of local edge k from corner k, the interior in grid order).
fn local_record(p: u32, e: vec3<u32>, local: u32) -> LvRec {
    if (local < 3u) {
        let o = TOPO_CORNER + 4u * local;
        return LvRec(item_base(p, o), topo(p, o + 3u));
    }
    var q = local - 3u;
    for (var k = 0u; k < 3u; k++) {
        let m = e[k] - 1u;
        if (q < m) {
            let o = TOPO_EDGE + 7u * k;
            let flags = topo(p, o + 3u);
            // Step i = q + 1 from corner k; canonical sample E − 1 − i on a reversed use.
            let c = select(q, m - 1u - q, (flags & FLAG_REVERSED) != 0u);
            return LvRec(item_base(p, o) + c, flags);
        }
        q -= m;
    }
    return LvRec(interior_base(p) + q, FLAG_WRITE);
}

// The sample of thread t: its patch, local index and record, and its grid level and grid
// point (every sample of the pattern is a point of the grid of some level: a corner of
// level 1, edge k's sample i of the grid of level E_k, an interior point of level n').
struct LvSample {
    p: u32,
    local: u32,
    rec: LvRec,
    level: u32,
    ij: vec2<u32>,
}

fn lv_sample(t: u32) -> LvSample {
    // The patch: the last whose first sample is at or before t.
    var lo = 0u;
    var hi = lv.patches - 1u;
    loop {
        if (lo >= hi) {
            break;
        }
        let mid = (lo + hi + 1u) / 2u;
        if (state[lv.pt_off + mid] <= t) {
            lo = mid;
        } else {
            hi = mid - 1u;
        }
    }
    let p = lo;
    let local = t - state[lv.pt_off + p];
    let e = patch_edges_levels(p);
    let n = effective_inner(e, patch_inner(p));
    let r = local_record(p, e, local);
    if (local < 3u) {
        let ij = array<vec2<u32>, 3>(vec2<u32>(0u, 0u), vec2<u32>(1u, 0u), vec2<u32>(0u, 1u));
        return LvSample(p, local, r, 1u, ij[local]);
    }
    var q = local - 3u;
    for (var k = 0u; k < 3u; k++) {
        let m = e[k] - 1u;
        if (q < m) {
            // Step i from corner k: b_k = (E − i)/E, b_{k+1} = i/E.
            let i = q + 1u;
            let l = e[k];
            var ij = vec2<u32>(i, 0u);
            if (k == 1u) {
                ij = vec2<u32>(l - i, i);
            } else if (k == 2u) {
                ij = vec2<u32>(0u, l - i);
            }
            return LvSample(p, local, r, l, ij);
        }
        q -= m;
    }
    return LvSample(p, local, r, n, grid_ij(n - 3u, q) + vec2<u32>(1u, 1u));
}

// Writes the record of sample `x` evaluated (patch-relative) as `ev`.
fn lv_store(x: LvSample, ev: Sample) {
    let s = absolute(x.p, ev, select(3u, x.local, x.local < 3u));
    let o = x.rec.id * 6u;
    if ((x.rec.flags & FLAG_COPY) == 0u) {
        vertices[o] = f32(s.p.x);
        vertices[o + 1u] = f32(s.p.y);
        vertices[o + 2u] = f32(s.p.z);
    }
    vertices[o + 3u] = f32(s.n.x);
    vertices[o + 4u] = f32(s.n.y);
    vertices[o + 5u] = f32(s.n.z);
}

// One thread per sample of every patch: evaluates it with the basis read from the table of
// every grid level up to the cap (grid_w as eval_table reads it, params.per points in all,
// level l's grid after those of the smaller levels: lv_grid_base) and writes its record
// where this patch writes it.
@compute @workgroup_size(TESS_WORKGROUP)
fn lv_points_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = lv_thread(gid, state[ST_POINT_GROUPS_X]);
    if (t >= state[ST_TOTALS + 2u]) {
        return;
    }
    let x = lv_sample(t);
    if ((x.rec.flags & FLAG_WRITE) == 0u) {
        return;
    }
    let local = lv_grid_base(x.level) + row_start(x.level, x.ij.y) + x.ij.x;
    lv_store(x, eval_table(x.p, local));
}

// First point of the grid of level l in the table: the points of the grids of levels
// 1..l − 1, Σ_{m=1}^{l−1} (m + 1)(m + 2)/2 = l (l + 1)(l + 2)/6 − 1
// (gpu::tessellator::level_grid_base).
fn lv_grid_base(l: u32) -> u32 {
    return l * (l + 1u) * (l + 2u) / 6u - 1u;
}

// As lv_points_main with the basis computed in the shader (caps whose table is too large).
@compute @workgroup_size(TESS_WORKGROUP)
fn lv_points_basis_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = lv_thread(gid, state[ST_POINT_GROUPS_X]);
    if (t >= state[ST_TOTALS + 2u]) {
        return;
    }
    let x = lv_sample(t);
    if ((x.rec.flags & FLAG_WRITE) == 0u) {
        return;
    }
    lv_store(x, eval_weights(x.p, kind_weights(grid_barycentric(x.level, x.ij))));
}

// Local index of grid point (i, j) of the grid of level n (tess::layout::local_of): the
// boundary where the edge levels equal n, the interior shifted one step in.
fn local_of(e: vec3<u32>, n: u32, i: u32, j: u32) -> u32 {
    let b0 = 3u;
    let b1 = b0 + e.x - 1u;
    let b2 = b1 + e.y - 1u;
    let ib = b2 + e.z - 1u;
    if (j == 0u) {
        if (i == 0u) {
            return 0u;
        }
        if (i == n) {
            return 1u;
        }
        return b0 + i - 1u;
    }
    if (i + j == n) {
        if (j == n) {
            return 2u;
        }
        return b1 + j - 1u;
    }
    if (i == 0u) {
        return b2 + (n - j) - 1u;
    }
    return ib + row_start(n - 3u, j - 1u) + i - 1u;
}

fn put_triangle(slot: u32, p: u32, e: vec3<u32>, t: vec3<u32>) {
    let o = slot * 3u;
    indices[o] = local_record(p, e, t.x).id;
    indices[o + 1u] = local_record(p, e, t.y).id;
    indices[o + 2u] = local_record(p, e, t.z).id;
}

// Local index of sample i (0..=E_k) of edge k: corner k, its samples, corner k + 1.
fn outer_local(e: vec3<u32>, k: u32, i: u32) -> u32 {
    if (i == 0u) {
        return k;
    }
    if (i == e[k]) {
        return (k + 1u) % 3u;
    }
    var b = 3u;
    for (var q = 0u; q < k; q++) {
        b += e[q] - 1u;
    }
    return b + i - 1u;
}

// Local index of point s of the inner ring's side k: b_k = n − 2 − s, b_{k+1} = 1 + s,
// b_{k+2} = 1 (steps 1/n).
fn inner_local(e: vec3<u32>, n: u32, k: u32, s: u32) -> u32 {
    var c = vec3<u32>(0u);
    c[k] = n - 2u - s;
    c[(k + 1u) % 3u] = 1u + s;
    c[(k + 2u) % 3u] = 1u;
    let ib = 3u + e.x + e.y + e.z - 3u;
    return ib + row_start(n - 3u, c.z - 1u) + c.y - 1u;
}

// One thread per patch: its triangles in tess::layout::triangles order, as record ids.
@compute @workgroup_size(TESS_WORKGROUP)
fn lv_triangles_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = lv_thread(gid, lv.patch_groups_x);
    if (p >= lv.patches) {
        return;
    }
    let e = patch_edges_levels(p);
    let inner = patch_inner(p);
    let n = effective_inner(e, inner);
    var slot = state[lv.tri_off + p];
    if (e.x == inner && e.y == inner && e.z == inner) {
        // The grid of level n (eval::pattern::grid_triangles order).
        for (var j = 0u; j < n; j++) {
            for (var i = 0u; i + j < n; i++) {
                let a = local_of(e, n, i, j);
                let b = local_of(e, n, i + 1u, j);
                let c = local_of(e, n, i, j + 1u);
                put_triangle(slot, p, e, vec3<u32>(a, b, c));
                slot += 1u;
                if (i + j + 1u < n) {
                    put_triangle(slot, p, e, vec3<u32>(b, local_of(e, n, i + 1u, j + 1u), c));
                    slot += 1u;
                }
            }
        }
        return;
    }
    let ib = 3u + e.x + e.y + e.z - 3u;
    // The interior: the grid of level n − 3 shifted one step in.
    if (n >= 4u) {
        let g = n - 3u;
        for (var j = 0u; j < g; j++) {
            for (var i = 0u; i + j < g; i++) {
                let a = ib + row_start(g, j) + i;
                let b = ib + row_start(g, j) + i + 1u;
                let c = ib + row_start(g, j + 1u) + i;
                put_triangle(slot, p, e, vec3<u32>(a, b, c));
                slot += 1u;
                if (i + j + 1u < g) {
                    put_triangle(slot, p, e, vec3<u32>(b, ib + row_start(g, j + 1u) + i + 1u, c));
                    slot += 1u;
                }
            }
        }
    }
    // Cut corners: E_{k−1} ≥ 2, E_k ≥ 2, E_{k−1} + E_k > n.
    var cut = vec3<bool>(false);
    for (var k = 0u; k < 3u; k++) {
        let prev = e[(k + 2u) % 3u];
        let next = e[k];
        cut[k] = prev >= 2u && next >= 2u && prev + next > n;
    }
    for (var k = 0u; k < 3u; k++) {
        if (cut[k]) {
            let kp = (k + 2u) % 3u;
            let first = outer_local(e, k, 1u);
            let last = outer_local(e, kp, e[kp] - 1u);
            put_triangle(slot, p, e, vec3<u32>(k, first, last));
            slot += 1u;
            put_triangle(slot, p, e, vec3<u32>(first, inner_local(e, n, k, 0u), last));
            slot += 1u;
        }
    }
    // The strips: edge k's samples between the cuts against the inner ring's side k,
    // walking both by the midpoints of their segments.
    for (var k = 0u; k < 3u; k++) {
        let a = e[k] - select(0u, 1u, cut[(k + 1u) % 3u]);
        let m = n - 3u;
        var i = select(0u, 1u, cut[k]);
        var s = 0u;
        loop {
            if (!(i < a || s < m)) {
                break;
            }
            if (s == m || (i < a && (2u * i + 1u) * n < 2u * e[k] * (s + 2u))) {
                put_triangle(slot, p, e, vec3<u32>(
                    outer_local(e, k, i),
                    outer_local(e, k, i + 1u),
                    inner_local(e, n, k, s),
                ));
                i += 1u;
            } else {
                put_triangle(slot, p, e, vec3<u32>(
                    outer_local(e, k, i),
                    inner_local(e, n, k, s + 1u),
                    inner_local(e, n, k, s),
                ));
                s += 1u;
            }
            slot += 1u;
        }
    }
}

// One thread per (patch, local edge): split-normal records take the owner's positions
// (written by lv_points_main before).
@compute @workgroup_size(TESS_WORKGROUP)
fn lv_copy_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = lv_thread(gid, lv.copy_groups_x);
    if (t >= 3u * lv.patches) {
        return;
    }
    let p = t / 3u;
    let k = t - 3u * p;
    let o = TOPO_EDGE + 7u * k;
    if ((topo(p, o + 3u) & FLAG_COPY) == 0u) {
        return;
    }
    let m = patch_edges_levels(p)[k] - 1u;
    let dst0 = item_base(p, o);
    let src0 = item_base(p, o + 4u);
    for (var c = 0u; c < m; c++) {
        let dst = (dst0 + c) * 6u;
        let src = (src0 + c) * 6u;
        vertices[dst] = vertices[src];
        vertices[dst + 1u] = vertices[src + 1u];
        vertices[dst + 2u] = vertices[src + 2u];
    }
}
