// The lavapipe / device ceiling of `bench`: the least an evaluation shader does. Samples
// of 24 bytes (an f32 position and normal, in the evaluation output's layout: positions in
// out[0 .. 3 count], normals after them) computed from their index alone, reading nothing,
// stored two ways; `bench` takes the faster as the ceiling. Bindings as common.wgsl (only
// params and out, or out4, are used); WORKGROUP comes from a generated line
// (src/gpu/shaders.rs: ceiling_source).

struct Params {
    count: u32,
    first_local: u32,
    level: u32,
    per: u32,
    groups_x: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(3) var<storage, read_write> out: array<f32>;
// The same output seen as vec4s (ceiling_quads_main), as grid_patch_main sees it.
@group(0) @binding(7) var<storage, read_write> out4: array<vec4<f32>>;

// One sample per invocation, its six values stored one by one.
@compute @workgroup_size(WORKGROUP)
fn ceiling_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = gid.y * params.groups_x * WORKGROUP + gid.x;
    if (t >= params.count) {
        return;
    }
    let x = f32(t);
    let o = t * 3u;
    out[o] = x;
    out[o + 1u] = x;
    out[o + 2u] = x;
    let m = (params.count + t) * 3u;
    out[m] = 0.0;
    out[m + 1u] = 0.0;
    out[m + 2u] = 1.0;
}

// Four samples per invocation (count a multiple of 4), stored as grid_patch_main stores
// them: the four positions as three vec4s, the four normals likewise; a vector store
// costs lavapipe one pass over the SIMD lanes for its 4 values instead of one per value.
@compute @workgroup_size(WORKGROUP)
fn ceiling_quads_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = gid.y * params.groups_x * WORKGROUP + gid.x;
    if (t >= params.count / 4u) {
        return;
    }
    let x = f32(t);
    let o = t * 3u;
    out4[o] = vec4<f32>(x);
    out4[o + 1u] = vec4<f32>(x);
    out4[o + 2u] = vec4<f32>(x);
    let m = (params.count / 4u + t) * 3u;
    out4[m] = vec4<f32>(0.0, 0.0, 1.0, 0.0);
    out4[m + 1u] = vec4<f32>(0.0, 1.0, 0.0, 0.0);
    out4[m + 2u] = vec4<f32>(1.0, 0.0, 0.0, 1.0);
}
