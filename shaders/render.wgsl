// Pictures of the normal field (src/render/pipeline.rs): vertices mapped by the
// orthographic camera (render::Camera::rows), fragments coloured by one component of the
// interpolated, renormalised normal through the colour ramp.
//
// The module is headed by constants generated from render::RAMP (render::shader_source):
//   STOPS: array<vec3<f32>, N> (the ramp's stops, 0..255), SEGMENTS: f32 (N − 1),
//   LAST_SEGMENT: u32 (N − 2).
// mirrors render::ramp

struct Uniforms {
    // Rows of the orthographic map: clip = (dot(x.xyz, p) + x.w, dot(y.xyz, p) + y.w, ...).
    x: vec4<f32>,
    y: vec4<f32>,
    z: vec4<f32>,
    // The normal component drawn: 0, 1 or 2.
    component: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
};

@group(0) @binding(0) var<uniform> u: Uniforms;

struct VsOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) n: vec3<f32>,
};

@vertex
fn vs(@location(0) p: vec3<f32>, @location(1) n: vec3<f32>) -> VsOut {
    var out: VsOut;
    out.pos = vec4<f32>(
        dot(u.x.xyz, p) + u.x.w,
        dot(u.y.xyz, p) + u.y.w,
        dot(u.z.xyz, p) + u.z.w,
        1.0,
    );
    out.n = n;
    return out;
}

fn ramp(v: f32) -> vec3<f32> {
    let t = clamp((v + 1.0) * (0.5 * SEGMENTS), 0.0, SEGMENTS);
    let i = min(u32(floor(t)), LAST_SEGMENT);
    let f = t - f32(i);
    return mix(STOPS[i], STOPS[i + 1u], f) / 255.0;
}

@fragment
fn fs(in: VsOut) -> @location(0) vec4<f32> {
    let n = normalize(in.n);
    return vec4<f32>(ramp(n[u.component]), 1.0);
}
