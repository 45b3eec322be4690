//! Control nets for solvers: every patch's control points as JSON (`g1tess export-net`),
//! so a boundary-element code can evaluate the patches itself. The format is documented in
//! `docs/formats.md` ("Control nets").

use std::io::Write;
use std::path::Path;

use serde::Serialize;

use super::atomic::{write_atomic, TempFiles};
use crate::mesh::Mesh;
use crate::patch::basis::{bezier_powers, g1_boundary_powers};
use crate::patch::{PatchKind, PatchTable};
use crate::Result;

/// Version of the file format; bumped on any incompatible change.
pub const NETS_VERSION: u32 = 1;

/// What one slot of a patch's control points is.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Slot {
    pub name: String,
    /// "bezier": a Bernstein control point with these powers on (b0, b1, b2);
    /// "gregory": one of the two values of a rational interior point (docs/formats.md, "Control nets");
    /// "normal-field": a coefficient of PN triangles' quadratic normal field.
    pub role: &'static str,
    pub powers: [u32; 3],
}

/// The slots of a patch kind, in table order.
pub fn slots(kind: PatchKind) -> Vec<Slot> {
    let bez = |n: u32, role: &'static str, prefix: &str| -> Vec<Slot> {
        bezier_powers(n)
            .into_iter()
            .map(|p| Slot {
                name: format!("{prefix}{}{}{}", p[0], p[1], p[2]),
                role,
                powers: p,
            })
            .collect()
    };
    match kind {
        PatchKind::Bezier(n) => bez(n, "bezier", "P"),
        PatchKind::PnNormals => {
            let mut s = bez(3, "bezier", "P");
            s.extend(bez(2, "normal-field", "N"));
            s
        }
        PatchKind::Gregory => {
            let mut s: Vec<Slot> = g1_boundary_powers()
                .iter()
                .enumerate()
                .map(|(i, p)| Slot {
                    name: format!("L{},{}", i / 4, i % 4),
                    role: "bezier",
                    powers: *p,
                })
                .collect();
            for m in 0..3 {
                // G_{m,1} and G_{m,2}: the values of the interior point with power 2 on
                // vertex m (G_{m,1}) and on vertex m + 1 (G_{m,2}) seen from edge m.
                let mut p1 = [1u32; 3];
                p1[m] = 2;
                let mut p2 = [1u32; 3];
                p2[(m + 1) % 3] = 2;
                s.push(Slot {
                    name: format!("G{m},1"),
                    role: "gregory",
                    powers: p1,
                });
                s.push(Slot {
                    name: format!("G{m},2"),
                    role: "gregory",
                    powers: p2,
                });
            }
            s
        }
    }
}

fn kind_name(kind: PatchKind) -> &'static str {
    match kind {
        PatchKind::Bezier(_) => "bezier",
        PatchKind::Gregory => "gregory",
        PatchKind::PnNormals => "pn-normals",
    }
}

/// Writes the control nets of `table` (built on `mesh`) to `path`, atomically, one patch
/// at a time (the temporary file listed in `temp`).
pub fn write_nets(path: &Path, temp: &TempFiles, mesh: &Mesh, table: &PatchTable) -> Result<()> {
    // JSON has no infinities: serde_json would write `null`. Tables are built finite, so
    // this only guards a table assembled by hand.
    if let Some(i) = table.points.iter().position(|p| !p.is_finite()) {
        return Err(crate::Error::mesh(
            &mesh.name,
            format!(
                "patch {} has a non-finite control point: no control nets written",
                i / table.stride
            ),
        ));
    }
    let degree = table.kind.layout().degree;
    let header = serde_json::json!({
        "format": "g1tess-control-nets",
        "version": NETS_VERSION,
        "mesh": mesh.name,
        "scheme": table.scheme.to_string(),
        "kind": kind_name(table.kind),
        "degree": degree,
        "stride": table.stride,
        "slots": slots(table.kind),
        "vertex_count": mesh.positions.len(),
        "patch_count": table.len(),
    });
    let header = header.to_string();
    write_atomic(path, temp, |w| {
        // The header's fields, then the arrays, streamed.
        w.write_all(&header.as_bytes()[..header.len() - 1])?;
        w.write_all(b",\n\"vertices\":[")?;
        for (i, p) in mesh.positions.iter().enumerate() {
            if i > 0 {
                w.write_all(b",")?;
            }
            serde_json::to_writer(&mut *w, &p.to_array())?;
        }
        w.write_all(b"],\n\"patches\":[\n")?;
        for (t, tri) in mesh.triangles.iter().enumerate() {
            if t > 0 {
                w.write_all(b",\n")?;
            }
            let points: Vec<[f64; 3]> = table.patch(t).iter().map(|p| p.to_array()).collect();
            serde_json::to_writer(
                &mut *w,
                &serde_json::json!({"vertices": tri, "points": points}),
            )?;
        }
        w.write_all(b"\n]}\n")?;
        Ok(())
    })
}
