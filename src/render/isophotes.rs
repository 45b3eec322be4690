//! Isophote pictures: each panel's normal component n · L (L = x, y, z, as the normal
//! panels) in bands of 1/[`BANDS_PER_UNIT`], alternately light and dark, so that every
//! band boundary is a curve n · L = k/12. On a surface that is G1 the stripes have no
//! kinks; a jump of curvature (G2 defect) bends them, and a ripple makes them wave: the
//! classic check of a surface's fairness. Drawn by the fragment entry point
//! [`ISOPHOTE_WGSL`] added to the render shader; [`isophote`] is its Rust mirror.

/// Bands per unit of n · L: boundaries at n · L = k / 12.
pub const BANDS_PER_UNIT: u32 = 12;

/// Colour of the bands whose index ⌊12 n · L⌋ is even (light grey, so that the silhouette
/// shows against the white background).
pub const LIGHT: [u8; 3] = [235, 235, 235];

/// Colour of the bands whose index is odd.
pub const DARK: [u8; 3] = [0, 0, 0];

/// Colour of the normal component `v` (in [−1, 1]), as the shader computes it.
pub fn isophote(v: f64) -> [u8; 3] {
    let band = (v * BANDS_PER_UNIT as f64).floor() as i64;
    if band.rem_euclid(2) == 0 {
        LIGHT
    } else {
        DARK
    }
}

/// The isophote fragment entry point `fs_isophotes`, appended to the render shader's
/// source (it uses its `Uniforms`, `u` and `VsOut`), headed by its generated constants.
pub fn isophote_wgsl() -> String {
    let c = |x: u8| format!("{:.9}", x as f64 / 255.0);
    format!(
        "// Generated from render::isophotes.\n\
         const BANDS: f32 = {bands}.0;\n\
         const LIGHT: vec3<f32> = vec3<f32>({l}, {l}, {l});\n\
         const DARK: vec3<f32> = vec3<f32>({d}, {d}, {d});\n{ISOPHOTE_WGSL}",
        bands = BANDS_PER_UNIT,
        l = c(LIGHT[0]),
        d = c(DARK[0]),
    )
}

/// The WGSL of the isophote shading (see [`isophote_wgsl`]).
pub const ISOPHOTE_WGSL: &str = "
// Isophotes of the normal component of the panel: bands of 1/BANDS, alternately light
// and dark (two's complement: band & 1 is the band's parity for negative bands too).
// mirrors render::isophotes::isophote
fn isophote(v: f32) -> vec3<f32> {
    let band = i32(floor(v * BANDS));
    if ((band & 1) == 0) {
        return LIGHT;
    }
    return DARK;
}

@fragment
fn fs_isophotes(in: VsOut) -> @location(0) vec4<f32> {
    let n = normalize(in.n);
    return vec4<f32>(isophote(n[u.component]), 1.0);
}
";
