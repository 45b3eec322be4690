// PN triangles (Vlachos et al. 2001): the cubic geometry (PatchKind::Bezier(3), exact normal
// S_s × S_t) or the cubic with its quadratic normal field (PatchKind::PnNormals, GEOMETRY =
// 10 < STRIDE = 16: the reported normal is the normalised field, see eval_weights).

fn kind_weights(b: vec3<real>) -> Weights {
    if (GEOMETRY < STRIDE) {
        return pn_normals(b);
    }
    return bezier(3u, b);
}
