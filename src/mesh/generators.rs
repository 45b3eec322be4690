//! Built-in meshes of the paper (`docs/cli.md`) and their parametrised
//! forms. Usable wherever a mesh file path is accepted.

use std::collections::HashMap;
use std::f64::consts::TAU;

use glam::DVec3;

use super::{normals, weld, LoadReport, Mesh, NormalWeighting};
use crate::{Error, Result};

/// One line listing the built-in specs, for help texts and errors.
pub const BUILTIN_HELP: &str =
    "sphere320, torus200, icosphere:L (20·4^L triangles, exact normals), \
torus:NxM[:analytic|:averaged] (R 1, r 0.5, 2·N·M triangles)";

/// How the torus gets its vertex normals.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TorusNormals {
    /// The exact surface normal at each vertex.
    Analytic,
    /// Unweighted mean of the incident face normals (the paper's Table 1).
    Averaged,
}

/// Returns the built-in mesh named by `spec`, `None` if `spec` names no built-in (then it
/// is a file path), or an error for a malformed built-in spec.
pub fn from_spec(spec: &str) -> Result<Option<Mesh>> {
    let bad = |why: &str| Error::Invalid(format!("bad built-in mesh '{spec}': {why}"));
    match spec {
        "sphere320" => return Ok(Some(icosphere(2))),
        "torus200" => return Ok(Some(torus(10, 10, 1.0, 0.5, TorusNormals::Averaged))),
        _ => {}
    }
    if let Some(level) = spec.strip_prefix("icosphere:") {
        let level: u32 = level
            .parse()
            .map_err(|_| bad("level must be an integer 0..=7"))?;
        if level > 7 {
            return Err(bad("level must be an integer 0..=7"));
        }
        return Ok(Some(icosphere(level)));
    }
    if let Some(rest) = spec.strip_prefix("torus:") {
        let mut parts = rest.split(':');
        let dims = parts.next().unwrap_or("");
        let (n, m) = dims
            .split_once('x')
            .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)))
            .ok_or_else(|| bad("expected torus:NxM, e.g. torus:10x10"))?;
        if !(3..=2000).contains(&n) || !(3..=2000).contains(&m) {
            return Err(bad("N and M must be in 3..=2000"));
        }
        let normals = match parts.next() {
            None | Some("averaged") => TorusNormals::Averaged,
            Some("analytic") => TorusNormals::Analytic,
            Some(other) => return Err(bad(&format!("unknown normals '{other}'"))),
        };
        if parts.next().is_some() {
            return Err(bad("too many ':' fields"));
        }
        return Ok(Some(torus(n, m, 1.0, 0.5, normals)));
    }
    Ok(None)
}

/// Icosphere of radius 1: the icosahedron with every triangle split into four `level`
/// times, new vertices projected onto the sphere after each split; normals exact.
pub fn icosphere(level: u32) -> Mesh {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut pos: Vec<DVec3> = [
        (-1.0, phi, 0.0),
        (1.0, phi, 0.0),
        (-1.0, -phi, 0.0),
        (1.0, -phi, 0.0),
        (0.0, -1.0, phi),
        (0.0, 1.0, phi),
        (0.0, -1.0, -phi),
        (0.0, 1.0, -phi),
        (phi, 0.0, -1.0),
        (phi, 0.0, 1.0),
        (-phi, 0.0, -1.0),
        (-phi, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(tris.len() * 4);
        let mut midpoint = |a: u32, b: u32, pos: &mut Vec<DVec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                pos.push(((pos[a as usize] + pos[b as usize]) * 0.5).normalize());
                (pos.len() - 1) as u32
            })
        };
        for t in &tris {
            let ab = midpoint(t[0], t[1], &mut pos);
            let bc = midpoint(t[1], t[2], &mut pos);
            let ca = midpoint(t[2], t[0], &mut pos);
            next.extend([[t[0], ab, ca], [t[1], bc, ab], [t[2], ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    orient_outward(&pos, &mut tris, DVec3::ZERO);
    let normals = pos.clone();
    let name = match level {
        2 => "sphere320".to_string(),
        _ => format!("icosphere:{level}"),
    };
    with_vertex_normals(name, pos, &normals, tris)
}

/// Torus with major radius `big_r` around the z axis and tube radius `r`: an n × m grid,
/// u_i = 2πi/n around the axis, v_j = 2πj/m around the tube (v = 0 on the outer equator),
/// each quad split along one diagonal.
pub fn torus(n: u32, m: u32, big_r: f64, r: f64, normals: TorusNormals) -> Mesh {
    let mut pos = Vec::with_capacity((n * m) as usize);
    let mut analytic = Vec::with_capacity((n * m) as usize);
    for i in 0..n {
        let u = TAU * i as f64 / n as f64;
        for j in 0..m {
            let v = TAU * j as f64 / m as f64;
            pos.push(DVec3::new(
                (big_r + r * v.cos()) * u.cos(),
                (big_r + r * v.cos()) * u.sin(),
                r * v.sin(),
            ));
            analytic.push(DVec3::new(v.cos() * u.cos(), v.cos() * u.sin(), v.sin()));
        }
    }
    let idx = |i: u32, j: u32| (i % n) * m + (j % m);
    let mut tris = Vec::with_capacity((2 * n * m) as usize);
    for i in 0..n {
        for j in 0..m {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    let (vn, tag) = match normals {
        TorusNormals::Analytic => (analytic, "analytic"),
        TorusNormals::Averaged => (
            normals::vertex_normals(&pos, &tris, NormalWeighting::Unweighted),
            "averaged",
        ),
    };
    let name = if (n, m, normals) == (10, 10, TorusNormals::Averaged) {
        "torus200".to_string()
    } else {
        format!("torus:{n}x{m}:{tag}")
    };
    with_vertex_normals(name, pos, &vn, tris)
}

/// A built-in mesh with one normal per vertex, renormalised on every corner, through the
/// input weld like every other source (a no-op for these meshes: their vertices are
/// distinct and all used).
fn with_vertex_normals(
    name: String,
    positions: Vec<DVec3>,
    normals: &[DVec3],
    mut triangles: Vec<[u32; 3]>,
) -> Mesh {
    let mut corner_normals: Vec<[DVec3; 3]> = triangles
        .iter()
        .map(|t| t.map(|v| normals[v as usize].normalize()))
        .collect();
    let mut load_report = LoadReport::default();
    let positions = weld::weld(
        &positions,
        &mut triangles,
        &mut corner_normals,
        weld::Order::Input,
        &mut load_report,
    )
    .expect("built-in meshes index their own vertices");
    Mesh {
        name,
        positions,
        triangles,
        corner_normals,
        attributes: Default::default(),
        load_report,
    }
}

/// Flips triangles whose normal points towards `centre` (convex, star-shaped meshes).
fn orient_outward(pos: &[DVec3], tris: &mut [[u32; 3]], centre: DVec3) {
    for t in tris.iter_mut() {
        let p = t.map(|v| pos[v as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        if n.dot(p[0] + p[1] + p[2] - 3.0 * centre) < 0.0 {
            t.swap(1, 2);
        }
    }
}

/// Triangles of the built-in mesh named by `spec`, without building it; `None` when `spec`
/// names no well-formed built-in (then [`from_spec`] says what is wrong, or it is a file).
pub fn spec_triangles(spec: &str) -> Option<u64> {
    match spec {
        "sphere320" => return Some(320),
        "torus200" => return Some(200),
        _ => {}
    }
    if let Some(level) = spec.strip_prefix("icosphere:") {
        let level: u32 = level.parse().ok().filter(|&l| l <= 7)?;
        return Some(20 << (2 * level));
    }
    let rest = spec.strip_prefix("torus:")?;
    let dims = rest.split(':').next()?;
    let (n, m) = dims.split_once('x')?;
    let (n, m): (u64, u64) = (n.parse().ok()?, m.parse().ok()?);
    let dims = 3..=2000;
    (dims.contains(&n) && dims.contains(&m)).then_some(2 * n * m)
}
