//! The pieces of `render` that need no GPU device: its WGSL (feature `gpu`) (`shaders/render.wgsl` under the
//! header generated from the colour ramp) validates with naga as wgpu would on shader
//! creation, its uniform block matches the Rust struct byte for byte, the ramp has one
//! source, and the orthographic camera maps the bounding box onto the panel as documented.

use glam::DVec3;

use crate::render::camera::{Camera, DEPTH_MARGIN, MARGIN};
#[cfg(feature = "gpu")]
use crate::render::pipeline::shader_source;
#[cfg(feature = "gpu")]
use crate::render::pipeline::{Uniforms, RENDER_WGSL};
use crate::render::{ramp, RAMP};

#[cfg(feature = "gpu")]
use crate::tests::common;

#[cfg(feature = "gpu")]
fn module() -> naga::Module {
    let src = shader_source();
    let module = naga::front::wgsl::parse_str(&src)
        .unwrap_or_else(|e| panic!("render.wgsl: {}", e.emit_to_string(&src)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("render.wgsl: {}", e.emit_to_string(&src)));
    module
}

#[test]
#[cfg(feature = "gpu")]
fn render_shader_validates_with_naga() {
    let m = module();
    let stages: Vec<(String, naga::ShaderStage)> = m
        .entry_points
        .iter()
        .map(|e| (e.name.clone(), e.stage))
        .collect();
    assert_eq!(
        stages,
        [
            ("vs".to_string(), naga::ShaderStage::Vertex),
            ("fs".to_string(), naga::ShaderStage::Fragment)
        ]
    );
}

#[test]
#[cfg(feature = "gpu")]
fn uniform_block_matches_the_rust_struct() {
    let m = module();
    let (members, span) = m
        .types
        .iter()
        .find_map(|(_, t)| match &t.inner {
            naga::TypeInner::Struct { members, span } if t.name.as_deref() == Some("Uniforms") => {
                Some((members.clone(), *span))
            }
            _ => None,
        })
        .expect("struct Uniforms");
    assert_eq!(span as usize, std::mem::size_of::<Uniforms>());
    let layout: Vec<(String, u32)> = members
        .iter()
        .map(|mb| (mb.name.clone().unwrap(), mb.offset))
        .collect();
    let expect = [("x", 0), ("y", 16), ("z", 32), ("component", 48)];
    assert_eq!(
        layout[..4],
        expect.map(|(n, o)| (n.to_string(), o)),
        "WGSL member offsets"
    );
    // The Rust side: three rows of 16 bytes, then the component as a u32 (not f32 bits).
    assert_eq!(std::mem::offset_of!(Uniforms, component), 48);
    assert!(matches!(
        m.types[members[3].ty].inner,
        naga::TypeInner::Scalar(naga::Scalar {
            kind: naga::ScalarKind::Uint,
            width: 4
        })
    ));
}

/// The value of a constant expression that is a vector of f32 literals.
#[cfg(feature = "gpu")]
fn vec3_of(m: &naga::Module, h: naga::Handle<naga::Expression>) -> [f32; 3] {
    let naga::Expression::Compose { components, .. } = &m.global_expressions[h] else {
        panic!("not a vector: {:?}", m.global_expressions[h]);
    };
    let lit = |h: &naga::Handle<naga::Expression>| match m.global_expressions[*h] {
        naga::Expression::Literal(naga::Literal::F32(v)) => v,
        ref e => panic!("not an f32 literal: {e:?}"),
    };
    [
        lit(&components[0]),
        lit(&components[1]),
        lit(&components[2]),
    ]
}

#[test]
#[cfg(feature = "gpu")]
fn render_wgsl_names_the_rust_function_it_mirrors() {
    let names = common::mirrored_functions("shaders/render.wgsl", RENDER_WGSL);
    assert_eq!(names, ["render::ramp"]);
}

/// The shader's stops are generated from `RAMP` (the file holds no copy of them).
#[test]
#[cfg(feature = "gpu")]
fn the_ramp_has_one_source() {
    for decl in ["var<private> STOPS", "const SEGMENTS", "const LAST_SEGMENT"] {
        assert!(!RENDER_WGSL.contains(decl), "render.wgsl declares {decl}");
    }
    for [r, g, b] in RAMP {
        assert!(!RENDER_WGSL.contains(&format!("{r}.0, {g}.0, {b}.0")));
    }
    let m = module();
    let (_, stops) = m
        .global_variables
        .iter()
        .find(|(_, g)| g.name.as_deref() == Some("STOPS"))
        .expect("STOPS");
    let init = stops.init.expect("STOPS has an initialiser");
    let naga::Expression::Compose { components, .. } = &m.global_expressions[init] else {
        panic!("STOPS is not an array constructor");
    };
    let got: Vec<[f32; 3]> = components.iter().map(|&h| vec3_of(&m, h)).collect();
    let want: Vec<[f32; 3]> = RAMP.iter().map(|c| c.map(|v| v as f32)).collect();
    assert_eq!(got, want);
}

#[test]
fn ramp_hits_its_stops_and_interpolates_between_them() {
    // Nine stops over [−1, 1]: stop k at −1 + k/4.
    for (k, stop) in RAMP.iter().enumerate() {
        assert_eq!(ramp(-1.0 + k as f64 / 4.0), *stop, "stop {k}");
    }
    // Half-way between stops 2 and 3: the rounded mean of the two colours.
    let mid = ramp(-1.0 + 2.5 / 4.0);
    for c in 0..3 {
        let mean = (RAMP[2][c] as f64 + RAMP[3][c] as f64) / 2.0;
        assert_eq!(mid[c], mean.round() as u8);
    }
    // Clamped outside [−1, 1].
    assert_eq!(ramp(-7.0), RAMP[0]);
    assert_eq!(ramp(3.0), RAMP[8]);
}

/// The eight corners of the box [−2, 2] × [−1, 1] × [−0.5, 0.5] shifted by `shift`.
fn box_corners(shift: DVec3) -> Vec<DVec3> {
    (0..8)
        .map(|i| {
            let s = |b: usize| if i >> b & 1 == 1 { 1.0 } else { -1.0 };
            DVec3::new(2.0 * s(0), s(1), 0.5 * s(2)) + shift
        })
        .collect()
}

#[test]
fn camera_fits_the_bounding_box_into_the_panel() {
    let shift = DVec3::new(10.0, -3.0, 7.0);
    let points = box_corners(shift);
    let cam = Camera::fit(
        &points,
        DVec3::new(0.0, 0.0, 3.0),
        DVec3::new(0.0, 2.0, 1.0),
    )
    .unwrap();
    assert_eq!(
        (cam.right, cam.up, cam.towards),
        (DVec3::X, DVec3::Y, DVec3::Z)
    );
    // Across the view: the larger half extent (2, along x) with the margin; y keeps the
    // same scale (square panels). Depth: nearer (larger z) smaller.
    let near_right_top = cam.clip(DVec3::new(2.0, 1.0, 0.5) + shift);
    let far_left_bottom = cam.clip(DVec3::new(-2.0, -1.0, -0.5) + shift);
    let close = |a: DVec3, b: DVec3| (a - b).abs().max_element() < 1e-12; // f64 rounding
    assert!(close(
        near_right_top,
        DVec3::new(1.0 / MARGIN, 0.5 / MARGIN, 0.5 - 0.5 / DEPTH_MARGIN)
    ));
    assert!(close(
        far_left_bottom,
        DVec3::new(-1.0 / MARGIN, -0.5 / MARGIN, 0.5 + 0.5 / DEPTH_MARGIN)
    ));
    // The shader's f32 rows give the same map: their entries are rounded to f32 once
    // (relative 6e-8), and the rows' products and sums of values of size ≤ 20 add a few
    // ulps of that size: 1e-5 bounds it.
    let rows = cam.rows();
    for p in &points {
        let c = cam.clip(*p);
        for (i, row) in rows.iter().enumerate() {
            let v = row[0] as f64 * p.x + row[1] as f64 * p.y + row[2] as f64 * p.z + row[3] as f64;
            assert!((v - c[i]).abs() < 1e-5, "row {i} at {p}: {v} vs {}", c[i]);
        }
    }
}

#[test]
fn camera_frame_is_orthonormal_for_any_view_and_rejects_bad_input() {
    let points = box_corners(DVec3::ZERO);
    for (view, up) in [
        (DVec3::new(0.5, -1.0, 0.7), DVec3::Z),
        // Up along the view: any perpendicular is taken.
        (DVec3::Y, DVec3::Y),
    ] {
        let c = Camera::fit(&points, view, up).unwrap();
        // Unit, perpendicular, right-handed, within f64 rounding of a few operations.
        let eps = 1e-12;
        for v in [c.right, c.up, c.towards] {
            assert!((v.length() - 1.0).abs() < eps);
        }
        assert!(c.right.dot(c.up).abs() < eps && c.up.dot(c.towards).abs() < eps);
        assert!((c.right.cross(c.up) - c.towards).length() < eps);
        assert!((c.towards - view.normalize()).length() < eps);
    }
    assert!(Camera::fit(&points, DVec3::ZERO, DVec3::Y).is_err());
    assert!(Camera::fit(&[], DVec3::Z, DVec3::Y).is_err());
    assert!(Camera::fit(&[DVec3::new(f64::NAN, 0.0, 0.0)], DVec3::Z, DVec3::Y).is_err());
}
