// Screen-space tessellation levels, one per mesh edge: the projected length of the edge in
// pixels over the target length, rounded up and clamped to 1..max_level. An edge with both
// ends behind the eye (clip w <= w_min) gets 1; one crossing the eye plane gets the cap.
// mirrors tess::screen::edge_level
//
// Bindings: 0 parameters (uniform), 1 vertex positions (xyz, w unused), 2 edges (the two
// vertex ids), 3 levels (one u32 per edge, written).

struct Params {
    view_proj: mat4x4<f32>,
    viewport: vec2<f32>,
    target_px: f32,
    max_level: u32,
    edges: u32,
    w_min: f32,
    groups_x: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> edges: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read_write> levels: array<u32>;

const LEVELS_WORKGROUP: u32 = 64u;

fn edge_level(p0: vec3<f32>, p1: vec3<f32>) -> u32 {
    let a = params.view_proj * vec4<f32>(p0, 1.0);
    let b = params.view_proj * vec4<f32>(p1, 1.0);
    let cap = max(params.max_level, 1u);
    let behind_a = a.w <= params.w_min;
    let behind_b = b.w <= params.w_min;
    if behind_a && behind_b {
        return 1u;
    }
    if behind_a || behind_b {
        return cap;
    }
    // Pixels from normalised device coordinates: x and y span 2 across the viewport.
    let dx = (a.x / a.w - b.x / b.w) * 0.5 * params.viewport.x;
    let dy = (a.y / a.w - b.y / b.w) * 0.5 * params.viewport.y;
    let segments = sqrt(dx * dx + dy * dy) / params.target_px;
    // Not finite (NaN fails every comparison).
    if !(segments <= 3.0e38) {
        return cap;
    }
    return u32(clamp(ceil(segments), 1.0, f32(cap)));
}

@compute @workgroup_size(64)
fn levels_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * params.groups_x * LEVELS_WORKGROUP;
    if i >= params.edges {
        return;
    }
    let e = edges[i];
    levels[i] = edge_level(positions[e.x].xyz, positions[e.y].xyz);
}
