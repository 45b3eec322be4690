// The flat triangle (PatchKind::Bezier(1)): the linear Bernstein basis of common.wgsl.

fn kind_weights(b: vec3<real>) -> Weights {
    return bezier(1u, b);
}
