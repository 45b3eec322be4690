// The patch loop's bound (`bench`: gpu_loop_bound): grid_patch_main of common.wgsl as a
// kind runs it, with a kind_loop_point that evaluates nothing. The kind's module is
// assembled as usual but for its own kind_loop_point, renamed (src/gpu/shaders.rs:
// loop_bound_source). What is left is what every evaluation in the patch loop does: read
// the patch's control points (their sum, once per patch at its first grid point, keeps
// every load), compute each grid point's barycentrics, make a unit normal and an absolute
// position of distinct values per sample, and store them as the kind's evaluation does. No
// evaluation of the patch can run faster in this loop; the samples are meaningless.

var<private> bound_sum: vec3<real>;

fn kind_loop_point(b: vec3<real>, l: u32) -> LoopPoint {
    // l = 0 is the first grid point every thread evaluates of its patch (grid_patch_main).
    if (l == 0u) {
        bound_sum = vec3<real>(0.0);
        for (var j = 0u; j < STRIDE; j++) {
            bound_sum += loop_cp[j];
        }
    }
    return LoopPoint(
        b.x * bound_sum + b.y * loop_cp[1u] + b.z * loop_cp[2u],
        cross(b, bound_sum + b),
        real(1.0),
    );
}
