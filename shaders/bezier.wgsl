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

// The patch loop's sample (common.wgsl: LoopPoint, grid_patch_main) at grid point l: the
// basis read from the uniform table grid_u, the normal vector as patch_normal takes it
// (the field where the kind has one, else S_s × S_t).
fn kind_loop_point(b: vec3<real>, l: u32) -> LoopPoint {
    var p = vec3<real>(0.0);
    var ds = vec3<real>(0.0);
    var dt = vec3<real>(0.0);
    for (var j = 0u; j < GEOMETRY; j++) {
        let w = grid_u[l * STRIDE + j];
        p += w.x * loop_cp[j];
        ds += w.y * loop_cp[j];
        dt += w.z * loop_cp[j];
    }
    var field = vec3<real>(0.0);
    for (var j = GEOMETRY; j < STRIDE; j++) {
        field += grid_u[l * STRIDE + j].x * loop_cp[j];
    }
    return LoopPoint(p, select(cross(ds, dt), field, GEOMETRY < STRIDE), real(1.0));
}
