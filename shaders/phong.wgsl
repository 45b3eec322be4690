// Phong tessellation (Boubekeur & Alexa 2008) as its quadratic Bézier triangle
// (PatchKind::Bezier(2)); the control points come from src/patch/, this file only
// evaluates them with the quadratic Bernstein basis of common.wgsl.

fn kind_weights(b: vec3<real>) -> Weights {
    return bezier(2u, b);
}
