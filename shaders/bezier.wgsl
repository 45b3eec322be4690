// Bézier triangles: PatchKind::Bezier(n) (flat, Phong, Nagata, NLSA, PN: the exact normal
// S_s × S_t of the geometry) and PatchKind::PnNormals (the cubic with its quadratic normal
// field: GEOMETRY < STRIDE, the reported normal is the normalised field, see eval_weights in
// common.wgsl). Every scheme whose table has one of these kinds runs this one module; the
// control points come from src/patch/, this file only evaluates them.
//
// mirrors patch::PatchKind::weights, patch::basis::pn_normals
// (patch::basis::bezier itself is in common.wgsl.)
// DEGREE, STRIDE and GEOMETRY come from the generated header (PatchKind::layout).

fn kind_weights(b: vec3<real>) -> Weights {
    if (GEOMETRY < STRIDE) {
        return pn_normals(b);
    }
    return bezier(DEGREE, b);
}

// PatchKind::PnNormals: the basis of degree DEGREE with derivatives in slots 0..GEOMETRY,
// the basis values of degree DEGREE − 1 (the normal field) in slots GEOMETRY..STRIDE
// (basis.rs: pn_normals).
fn pn_normals(b: vec3<real>) -> Weights {
    let field = bezier(DEGREE - 1u, b);
    var out = bezier(DEGREE, b);
    for (var k = 0u; k < STRIDE - GEOMETRY; k++) {
        out.w[GEOMETRY + k] = field.w[k];
    }
    return out;
}
