//! WGSL sources of the evaluation shaders and how a module is assembled:
//! a precision header (`alias real`, the kind's `STRIDE` and `GEOMETRY`), then the
//! scheme's file, then `shaders/common.wgsl` (entry points `grid_main`, `points_main`).
//! Pipelines are keyed on the [`PatchKind`] and the scheme's file.

use crate::patch::{PatchKind, Scheme};
use crate::{Error, Result};

use super::Precision;

/// One WGSL file of `shaders/`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShaderFile {
    /// File name in `shaders/`.
    pub name: &'static str,
    pub source: &'static str,
    /// The patch kinds this file evaluates.
    pub kinds: &'static [PatchKind],
}

/// Shared code and entry points.
pub const COMMON: &str = include_str!("../../shaders/common.wgsl");

pub const G1: ShaderFile = ShaderFile {
    name: "g1.wgsl",
    source: include_str!("../../shaders/g1.wgsl"),
    kinds: &[PatchKind::Gregory],
};
pub const FLAT: ShaderFile = ShaderFile {
    name: "flat.wgsl",
    source: include_str!("../../shaders/flat.wgsl"),
    kinds: &[PatchKind::Bezier(1)],
};
pub const PHONG: ShaderFile = ShaderFile {
    name: "phong.wgsl",
    source: include_str!("../../shaders/phong.wgsl"),
    kinds: &[PatchKind::Bezier(2)],
};
pub const NAGATA: ShaderFile = ShaderFile {
    name: "nagata.wgsl",
    source: include_str!("../../shaders/nagata.wgsl"),
    kinds: &[PatchKind::Bezier(2)],
};
pub const NLSA: ShaderFile = ShaderFile {
    name: "nlsa.wgsl",
    source: include_str!("../../shaders/nlsa.wgsl"),
    kinds: &[PatchKind::Bezier(2)],
};
pub const PN: ShaderFile = ShaderFile {
    name: "pn.wgsl",
    source: include_str!("../../shaders/pn.wgsl"),
    kinds: &[PatchKind::Bezier(3), PatchKind::PnNormals],
};

/// Every scheme file.
pub const FILES: [ShaderFile; 6] = [G1, FLAT, PHONG, NAGATA, NLSA, PN];

/// Every (file, kind) pair a pipeline can be built for.
pub fn variants() -> Vec<(ShaderFile, PatchKind)> {
    FILES
        .iter()
        .flat_map(|f| f.kinds.iter().map(move |k| (*f, *k)))
        .collect()
}

/// The shader file of a scheme: by the scheme's name (`phong`, `nagata*`, `nlsa`, `pn*`,
/// `g1`, `flat`), else the file of its patch kind when only one file has it. Errors when
/// the file cannot evaluate `kind`.
pub fn scheme_file(scheme: Scheme, kind: PatchKind) -> Result<ShaderFile> {
    let name = scheme.name();
    let by_name = FILES.iter().find(|f| {
        let stem = f.name.trim_end_matches(".wgsl");
        name == stem || name.starts_with(&format!("{stem}-"))
    });
    let file = match by_name {
        Some(f) => *f,
        None => {
            let with_kind: Vec<_> = FILES.iter().filter(|f| f.kinds.contains(&kind)).collect();
            match with_kind.as_slice() {
                [only] => **only,
                _ => {
                    return Err(Error::Gpu(format!(
                        "no shader file for scheme '{name}' (patch kind {kind:?})"
                    )))
                }
            }
        }
    };
    if !file.kinds.contains(&kind) {
        return Err(Error::Gpu(format!(
            "shaders/{} cannot evaluate patch kind {kind:?} (scheme '{name}')",
            file.name
        )));
    }
    Ok(file)
}

/// Leading control points that are geometry (the rest: PN's normal field).
pub fn geometry_points(kind: PatchKind) -> usize {
    kind.geometry()
}

/// The precision header of a module.
pub fn header(kind: PatchKind, precision: Precision) -> String {
    let (real, tiny, huge) = match precision {
        Precision::F32 => ("f32", "1e-30", "3.0e38"),
        Precision::F64 => ("f64", "1e-300lf", "1.0e308lf"),
    };
    format!(
        "// generated header: {kind:?}, {precision}\n\
         alias real = {real};\n\
         const TINY: real = {tiny};\n\
         const HUGE: real = {huge};\n\
         const STRIDE: u32 = {}u;\n\
         const GEOMETRY: u32 = {}u;\n",
        kind.stride(),
        geometry_points(kind)
    )
}

/// Complete WGSL source of the module evaluating `kind` with `file`.
pub fn module_source(file: ShaderFile, kind: PatchKind, precision: Precision) -> String {
    format!(
        "{}\n// ---- shaders/{} ----\n{}\n// ---- shaders/common.wgsl ----\n{}",
        header(kind, precision),
        file.name,
        file.source,
        COMMON
    )
}

/// Parses and validates a module with naga (what wgpu does on shader creation), with the
/// f64 capability only for f64 modules. The error is naga's report.
pub fn validate(source: &str, precision: Precision) -> Result<naga::Module> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| Error::Gpu(format!("WGSL parse: {}", e.emit_to_string(source))))?;
    let caps = match precision {
        Precision::F32 => naga::valid::Capabilities::empty(),
        Precision::F64 => naga::valid::Capabilities::FLOAT64,
    };
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
        .validate(&module)
        .map_err(|e| Error::Gpu(format!("WGSL validation: {}", e.emit_to_string(source))))?;
    Ok(module)
}
