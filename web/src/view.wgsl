// The viewer's drawing: the tessellator's surface (normal colours, lighting, wireframe) and
// the validity overlay (flat input triangles of folded or undecided patches).

struct View {
    view_proj: mat4x4<f32>,
    // xyz: the eye (world); w unused.
    eye: vec4<f32>,
    // x: shading (0 normals, 1 lit, 2 wireframe, 3 validity); yzw unused.
    mode: vec4<u32>,
}

@group(0) @binding(0) var<uniform> view: View;

struct Out {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) world: vec3<f32>,
    @location(2) bary: vec3<f32>,
}

// WGSL entry points cannot be called: `vs` and `vs_wire` share this.
fn project(p: vec3<f32>, n: vec3<f32>) -> Out {
    var out: Out;
    out.clip = view.view_proj * vec4<f32>(p, 1.0);
    out.normal = n;
    out.world = p;
    out.bary = vec3<f32>(1.0);
    return out;
}

@vertex
fn vs(@location(0) p: vec3<f32>, @location(1) n: vec3<f32>) -> Out {
    return project(p, n);
}

// Two-sided headlight: ambient plus diffuse, and a little specular.
fn lit(n_in: vec3<f32>, world: vec3<f32>, base: vec3<f32>) -> vec3<f32> {
    let to_eye = normalize(view.eye.xyz - world);
    var n = normalize(n_in);
    if dot(n, to_eye) < 0.0 {
        n = -n;
    }
    let diffuse = max(dot(n, to_eye), 0.0);
    let specular = pow(diffuse, 40.0);
    return base * (0.15 + 0.85 * diffuse) + vec3<f32>(0.25 * specular);
}

@fragment
fn fs(in: Out) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    switch view.mode.x {
        case 0u: {
            return vec4<f32>(0.5 * n + 0.5, 1.0);
        }
        case 3u: {
            return vec4<f32>(lit(n, in.world, vec3<f32>(0.55, 0.62, 0.7)), 1.0);
        }
        default: {
            return vec4<f32>(lit(n, in.world, vec3<f32>(0.8, 0.78, 0.72)), 1.0);
        }
    }
}

// Wireframe: the vertices and indices pulled from storage (WebGPU has no line polygon
// mode), each triangle's corners given barycentric coordinates for its edges.
@group(1) @binding(0) var<storage, read> vertices: array<f32>;
@group(1) @binding(1) var<storage, read> indices: array<u32>;

@vertex
fn vs_wire(@builtin(vertex_index) vi: u32) -> Out {
    let v = indices[vi] * 6u;
    let p = vec3<f32>(vertices[v], vertices[v + 1u], vertices[v + 2u]);
    let n = vec3<f32>(vertices[v + 3u], vertices[v + 4u], vertices[v + 5u]);
    var out = project(p, n);
    let corner = vi % 3u;
    out.bary = vec3<f32>(f32(corner == 0u), f32(corner == 1u), f32(corner == 2u));
    return out;
}

@fragment
fn fs_wire(in: Out) -> @location(0) vec4<f32> {
    let width = fwidth(in.bary);
    let edge = smoothstep(vec3<f32>(0.0), 1.5 * width, in.bary);
    let line = 1.0 - min(min(edge.x, edge.y), edge.z);
    let fill = lit(in.normal, in.world, vec3<f32>(0.18, 0.2, 0.24));
    return vec4<f32>(mix(fill, vec3<f32>(0.9, 0.95, 1.0), line), 1.0);
}

struct Marked {
    @builtin(position) clip: vec4<f32>,
    @location(0) colour: vec4<f32>,
}

@vertex
fn vs_mark(@location(0) p: vec3<f32>, @location(1) colour: vec4<f32>) -> Marked {
    return Marked(view.view_proj * vec4<f32>(p, 1.0), colour);
}

@fragment
fn fs_mark(in: Marked) -> @location(0) vec4<f32> {
    return in.colour;
}
