// The lavapipe / device ceiling of `bench`: the least an evaluation shader does. Each
// invocation writes one sample's 24 bytes (an f32 position and normal, in the evaluation
// output's layout: positions in out[0 .. 3 count], normals after them) computed from its
// index alone, reading nothing. Bindings as common.wgsl (only params and out are used);
// WORKGROUP comes from a generated line (src/gpu/shaders.rs: ceiling_source).

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
