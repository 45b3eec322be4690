//! `g1tess export-msh` and `io::msh`: Gmsh MSH 4.1 of order 1 to 5, read back here by an
//! independent parser (ASCII and binary); node order against Gmsh's own reference nodes;
//! order-3 G1 edges equal to the boundary cubics; the error falling with the order; the
//! Jacobian bound against dense sampling; physical groups on a mesh with a boundary.

use crate::common;

use std::collections::HashMap;
#[cfg(feature = "cli")]
use std::path::PathBuf;
#[cfg(feature = "cli")]
use std::process::Command;

use glam::DVec3;

use g1tess::msh::{
    build, lagrange_triangle, triangle_node_count, triangle_nodes, write_msh, HighOrderMesh,
};
use g1tess::NoProgress;
use g1tess::{LoadOptions, Mesh};
use g1tess::{PatchTable, Scheme, SchemeOptions};

#[cfg(feature = "cli")]
fn out(name: &str) -> PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("g1tess-msh-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// What this file's reader takes from an MSH 4.1 file.
#[derive(Debug, Default, PartialEq)]
struct Msh {
    binary: bool,
    physical_names: Vec<(i32, i32, String)>,
    /// tag → position.
    nodes: HashMap<u64, [f64; 3]>,
    /// (entity dim, entity tag, element type, element tag, node tags).
    elements: Vec<(i32, i32, i32, u64, Vec<u64>)>,
    /// View name → (element tag, value).
    element_data: Vec<(String, Vec<(u64, f64)>)>,
}

/// A cursor over the file: text tokens or little-endian binary values.
struct Cur<'a> {
    b: &'a [u8],
    at: usize,
}

impl Cur<'_> {
    fn line(&mut self) -> String {
        let end = self.b[self.at..].iter().position(|&c| c == b'\n').unwrap() + self.at;
        let s = String::from_utf8(self.b[self.at..end].to_vec()).unwrap();
        self.at = end + 1;
        s
    }
    fn take(&mut self, n: usize) -> &[u8] {
        self.at += n;
        &self.b[self.at - n..self.at]
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take(8).try_into().unwrap())
    }
}

/// Reads the sections `$MeshFormat`, `$PhysicalNames`, `$Nodes`, `$Elements` and
/// `$ElementData` of an MSH 4.1 file as the format documentation lays them out.
fn read_msh(bytes: &[u8]) -> Msh {
    let mut c = Cur { b: bytes, at: 0 };
    let mut m = Msh::default();
    loop {
        if c.at >= bytes.len() {
            break;
        }
        let head = c.line();
        match head.as_str() {
            "$MeshFormat" => {
                let v = c.line();
                assert!(v.starts_with("4.1 "), "{v}");
                m.binary = v.split_whitespace().nth(1) == Some("1");
                assert_eq!(v.split_whitespace().nth(2), Some("8"));
                if m.binary {
                    assert_eq!(c.i32(), 1, "endianness word");
                    assert_eq!(c.line(), "");
                }
                assert_eq!(c.line(), "$EndMeshFormat");
            }
            "$PhysicalNames" => {
                let n: usize = c.line().trim().parse().unwrap();
                for _ in 0..n {
                    let l = c.line();
                    let mut w = l.splitn(3, ' ');
                    let dim = w.next().unwrap().parse().unwrap();
                    let tag = w.next().unwrap().parse().unwrap();
                    let name = w.next().unwrap().trim_matches('"').to_string();
                    m.physical_names.push((dim, tag, name));
                }
                assert_eq!(c.line(), "$EndPhysicalNames");
            }
            "$Nodes" if m.binary => {
                let (blocks, n) = (c.u64(), c.u64());
                let (_min, _max) = (c.u64(), c.u64());
                for _ in 0..blocks {
                    let (_dim, _tag, param) = (c.i32(), c.i32(), c.i32());
                    assert_eq!(param, 0);
                    let k = c.u64() as usize;
                    let tags: Vec<u64> = (0..k).map(|_| c.u64()).collect();
                    for t in tags {
                        m.nodes.insert(t, [c.f64(), c.f64(), c.f64()]);
                    }
                }
                assert_eq!(m.nodes.len() as u64, n);
                assert_eq!(c.line(), "");
                assert_eq!(c.line(), "$EndNodes");
            }
            "$Nodes" => {
                let h = c.line();
                let h: Vec<u64> = h.split_whitespace().map(|x| x.parse().unwrap()).collect();
                for _ in 0..h[0] {
                    let b: Vec<usize> = c
                        .line()
                        .split_whitespace()
                        .map(|x| x.parse().unwrap())
                        .collect();
                    let tags: Vec<u64> = (0..b[3]).map(|_| c.line().parse().unwrap()).collect();
                    for t in tags {
                        let x: Vec<f64> = c
                            .line()
                            .split_whitespace()
                            .map(|x| x.parse().unwrap())
                            .collect();
                        m.nodes.insert(t, [x[0], x[1], x[2]]);
                    }
                }
                assert_eq!(m.nodes.len() as u64, h[1]);
                assert_eq!(c.line(), "$EndNodes");
            }
            "$Elements" if m.binary => {
                let (blocks, n) = (c.u64(), c.u64());
                let (_min, _max) = (c.u64(), c.u64());
                for _ in 0..blocks {
                    let (dim, tag, ty) = (c.i32(), c.i32(), c.i32());
                    let k = c.u64();
                    let per = nodes_of_type(ty);
                    for _ in 0..k {
                        let e = c.u64();
                        let nodes = (0..per).map(|_| c.u64()).collect();
                        m.elements.push((dim, tag, ty, e, nodes));
                    }
                }
                assert_eq!(m.elements.len() as u64, n);
                assert_eq!(c.line(), "");
                assert_eq!(c.line(), "$EndElements");
            }
            "$Elements" => {
                let h: Vec<u64> = c
                    .line()
                    .split_whitespace()
                    .map(|x| x.parse().unwrap())
                    .collect();
                for _ in 0..h[0] {
                    let b: Vec<i64> = c
                        .line()
                        .split_whitespace()
                        .map(|x| x.parse().unwrap())
                        .collect();
                    for _ in 0..b[3] {
                        let v: Vec<u64> = c
                            .line()
                            .split_whitespace()
                            .map(|x| x.parse().unwrap())
                            .collect();
                        assert_eq!(v.len(), 1 + nodes_of_type(b[2] as i32));
                        m.elements.push((
                            b[0] as i32,
                            b[1] as i32,
                            b[2] as i32,
                            v[0],
                            v[1..].to_vec(),
                        ));
                    }
                }
                assert_eq!(m.elements.len() as u64, h[1]);
                assert_eq!(c.line(), "$EndElements");
            }
            "$ElementData" => {
                // String tags (the name), real tags (the time), integer tags (step,
                // components, count), one per line.
                assert_eq!(c.line(), "1");
                let name = c.line().trim_matches('"').to_string();
                let head: Vec<String> = (0..6).map(|_| c.line()).collect();
                assert_eq!(&head[..5], ["1", "0", "3", "0", "1"]);
                let n: usize = head[5].parse().unwrap();
                let mut vals = Vec::new();
                for _ in 0..n {
                    if m.binary {
                        vals.push((c.i32() as u64, c.f64()));
                    } else {
                        let l = c.line();
                        let mut s = l.split_whitespace();
                        vals.push((
                            s.next().unwrap().parse().unwrap(),
                            s.next().unwrap().parse().unwrap(),
                        ));
                    }
                }
                if m.binary {
                    assert_eq!(c.line(), "");
                }
                assert_eq!(c.line(), "$EndElementData");
                m.element_data.push((name, vals));
            }
            s if s.starts_with('$') && !s.starts_with("$End") => {
                // A section this reader skips ($Comments, $Entities): up to its end line.
                let end = format!("$End{}", &s[1..]);
                let pos = bytes[c.at..]
                    .windows(end.len())
                    .position(|w| w == end.as_bytes())
                    .unwrap();
                c.at += pos;
                assert_eq!(c.line(), end);
            }
            other => panic!("unexpected line {other:?}"),
        }
    }
    m
}

/// Nodes per element of the Gmsh types written (from the Gmsh documentation's table).
fn nodes_of_type(t: i32) -> usize {
    match t {
        1 => 2,
        8 => 3,
        26 => 4,
        27 => 5,
        28 => 6,
        2 => 3,
        9 => 6,
        21 => 10,
        23 => 15,
        25 => 21,
        _ => panic!("unexpected element type {t}"),
    }
}

#[cfg(feature = "cli")]
fn export(spec: &str, extra: &[&str], name: &str) -> (Msh, serde_json::Value) {
    let path = out(name);
    let o = Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .args(["export-msh", spec, "-o", path.to_str().unwrap(), "--json"])
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    (read_msh(&std::fs::read(&path).unwrap()), summary)
}

fn v(x: [f64; 3]) -> DVec3 {
    DVec3::from_array(x)
}

#[test]
fn node_order_is_gmsh_reference_order() {
    // Gmsh's reference nodes (u, v) of types 21, 23 and 25, times P, as
    // gmsh.model.mesh.getElementProperties lists them.
    let p3 = [
        [0, 0],
        [3, 0],
        [0, 3],
        [1, 0],
        [2, 0],
        [2, 1],
        [1, 2],
        [0, 2],
        [0, 1],
        [1, 1],
    ];
    let p4: [[u32; 2]; 15] = [
        [0, 0],
        [4, 0],
        [0, 4],
        [1, 0],
        [2, 0],
        [3, 0],
        [3, 1],
        [2, 2],
        [1, 3],
        [0, 3],
        [0, 2],
        [0, 1],
        [1, 1],
        [2, 1],
        [1, 2],
    ];
    let p5: [[u32; 2]; 21] = [
        [0, 0],
        [5, 0],
        [0, 5],
        [1, 0],
        [2, 0],
        [3, 0],
        [4, 0],
        [4, 1],
        [3, 2],
        [2, 3],
        [1, 4],
        [0, 4],
        [0, 3],
        [0, 2],
        [0, 1],
        [1, 1],
        [3, 1],
        [1, 3],
        [2, 1],
        [2, 2],
        [1, 2],
    ];
    assert_eq!(triangle_nodes(1), [[0, 0], [1, 0], [0, 1]]);
    assert_eq!(
        triangle_nodes(2),
        [[0, 0], [2, 0], [0, 2], [1, 0], [1, 1], [0, 1]]
    );
    assert_eq!(triangle_nodes(3), p3);
    assert_eq!(triangle_nodes(4), p4);
    assert_eq!(triangle_nodes(5), p5);
    // The shape functions are the Lagrange basis of those nodes: δ at the nodes, partition
    // of unity elsewhere (rounding only: sums of at most 21 terms of size ≤ ~10).
    for p in 1..=5 {
        let nodes = triangle_nodes(p);
        for (i, &[a, b]) in nodes.iter().enumerate() {
            let (u, w) = (a as f64 / p as f64, b as f64 / p as f64);
            let s = lagrange_triangle(p, [1.0 - u - w, u, w]);
            for (j, &x) in s.w.iter().enumerate() {
                assert!(
                    (x - f64::from(u8::from(i == j))).abs() < 1e-12,
                    "p {p} {i} {j}"
                );
            }
        }
        let s = lagrange_triangle(p, [0.3, 0.45, 0.25]);
        assert!((s.w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert!(s.ws.iter().sum::<f64>().abs() < 1e-12);
        assert!(s.wt.iter().sum::<f64>().abs() < 1e-12);
    }
}

#[test]
#[cfg(feature = "cli")]
fn every_order_reads_back_with_shared_nodes_on_the_surface() {
    let mesh = common::load("sphere320");
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let (nv, nt) = (mesh.positions.len(), mesh.triangles.len());
    let ne = mesh.adjacency().edges.len();
    for p in 1..=5u32 {
        let (m, s) = export(
            "sphere320",
            &["--order", &p.to_string()],
            &format!("s{p}.msh"),
        );
        let pu = p as usize;
        // Shared nodes once: vertices, P − 1 per edge, the interior of each triangle.
        let expect = nv + ne * (pu - 1) + nt * (pu - 1) * pu.saturating_sub(2) / 2;
        assert_eq!(m.nodes.len(), expect, "order {p}");
        assert_eq!(s["nodes"], expect);
        assert_eq!(m.elements.len(), nt);
        let ty = [2, 9, 21, 23, 25][pu - 1];
        assert!(m
            .elements
            .iter()
            .all(|e| e.2 == ty && e.4.len() == triangle_node_count(p)));
        assert_eq!(m.physical_names, [(2, 1, "surface".to_string())]);
        // Each node sits on its element's patch at the node's reference point; the vertices
        // are the input bit for bit (ASCII f64 written as the shortest exact text).
        let lattice = triangle_nodes(p);
        for (t, e) in m.elements.iter().enumerate() {
            assert_eq!(e.3 as usize, t + 1);
            for (k, (&tag, &[a, b])) in e.4.iter().zip(&lattice).enumerate() {
                let x = v(m.nodes[&tag]);
                if k < 3 {
                    assert_eq!(x, mesh.positions[mesh.triangles[t][k] as usize]);
                }
                let (u, w) = (a as f64 / p as f64, b as f64 / p as f64);
                let s = table.eval(t, [1.0 - u - w, u, w]).p;
                // A shared edge node is its first triangle's evaluation; the neighbour's own
                // evaluation of the shared boundary curve differs by rounding only.
                assert!(x.distance(s) < 1e-14, "order {p} element {t} node {k}");
            }
        }
        assert_eq!(m.element_data.len(), 2);
        assert_eq!(m.element_data[0].0, "min scaled Jacobian");
        assert_eq!(m.element_data[1].1.len(), nt);
    }
}

#[test]
#[cfg(feature = "cli")]
fn ascii_and_binary_agree() {
    let spot = common::shared_spec("spot.obj");
    let (a, sa) = export(&spot, &["--order", "4"], "spot4.msh");
    let (mut b, sb) = export(&spot, &["--order", "4", "--binary"], "spot4b.msh");
    assert!(b.binary && !a.binary);
    b.binary = false;
    assert_eq!(a, b);
    assert_eq!(sa["min_scaled_jacobian"], sb["min_scaled_jacobian"]);
    assert_eq!(sa["max_distance"], sb["max_distance"]);
}

/// The Lagrange cubic through 4 equally spaced points, at `t` (written out here).
#[cfg(feature = "cli")]
fn cubic(x: [DVec3; 4], t: f64) -> DVec3 {
    let s = 3.0 * t;
    let l = [
        -(s - 1.0) * (s - 2.0) * (s - 3.0) / 6.0,
        s * (s - 2.0) * (s - 3.0) / 2.0,
        -s * (s - 1.0) * (s - 3.0) / 2.0,
        s * (s - 1.0) * (s - 2.0) / 6.0,
    ];
    x.iter().zip(l).map(|(p, w)| w * *p).sum()
}

#[test]
#[cfg(feature = "cli")]
fn order_3_g1_edges_are_the_boundary_cubics() {
    // Walton–Meek boundary curves are cubic, so the element's edge (the cubic through its
    // four edge nodes) is the patch's boundary curve itself. Spot (smooth) and fandisk with
    // creases (shared crease curves).
    for (spec, extra) in [
        (common::shared_spec("spot.obj"), vec![]),
        (
            common::shared_spec("fandisk.obj"),
            vec!["--crease-angle", "30"],
        ),
    ] {
        let mut args = vec!["--order", "3", "--binary"];
        args.extend(&extra);
        let (m, s) = export(&spec, &args, "edges3.msh");
        let opts =
            LoadOptions::default().with_crease_angle(extra.get(1).map(|a| a.parse().unwrap()));
        let mesh = Mesh::load(&spec, &opts).unwrap();
        let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
        let diag = mesh.diagonal();
        let mut worst = 0.0f64;
        for (t, e) in m.elements.iter().filter(|e| e.0 == 2).enumerate() {
            let n = |i: usize| v(m.nodes[&e.4[i]]);
            // Gmsh's edge k: vertex k, its two edge nodes, vertex k + 1.
            for k in 0..3 {
                let x = [n(k), n(3 + 2 * k), n(4 + 2 * k), n((k + 1) % 3)];
                for i in 1..20 {
                    let f = i as f64 / 20.0;
                    let mut b = [0.0; 3];
                    b[k] = 1.0 - f;
                    b[(k + 1) % 3] = f;
                    let d = cubic(x, f).distance(table.eval(t, b).p) / diag;
                    worst = worst.max(d);
                }
            }
        }
        // Equal up to rounding: f64 sums of a few terms of size ~diag.
        assert!(worst <= 1e-12, "{spec}: {worst:e}");
        if !extra.is_empty() {
            let creases = s["crease_lines"].as_u64().unwrap() as usize;
            assert!(creases > 100, "fandisk has creases at 30°: {creases}");
            let lines: Vec<_> = m.elements.iter().filter(|e| e.0 == 1).collect();
            assert_eq!(lines.len(), creases);
            assert!(lines.iter().all(|e| e.2 == 26 && e.1 == 1));
            assert!(m.physical_names.contains(&(1, 1, "creases".to_string())));
        }
    }
}

#[test]
fn error_falls_as_the_order_rises_on_sphere320() {
    let mesh = common::load("sphere320");
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let errors: Vec<f64> = (1..=5)
        .map(|p| {
            let ho = build(&mesh, &table, p, &NoProgress).unwrap();
            ho.quality
                .iter()
                .map(|q| q.max_distance)
                .fold(0.0, f64::max)
        })
        .collect();
    for w in errors.windows(2) {
        assert!(w[1] < 0.6 * w[0], "{errors:?}");
    }
    // Order 1 is the flat triangle: its distance to the patch is at least the sagitta of
    // the G1 surface over the mid-edge (which bulges out towards the unit sphere) and
    // below the largest flat-to-sphere gap 1 − |centroid| of this icosphere plus 1e-2.
    assert!(errors[0] > 1e-3 && errors[0] < 0.07, "{errors:?}");
}

/// Jacobian determinant (x_u × x_v)·n̂ of element `t` of `ho` at `b`, from the nodes.
fn det(ho: &HighOrderMesh, n_hat: DVec3, t: usize, b: [f64; 3]) -> f64 {
    let s = lagrange_triangle(ho.order, b);
    let (mut xu, mut xv) = (DVec3::ZERO, DVec3::ZERO);
    for (k, &i) in ho.element(t).iter().enumerate() {
        xu += s.ws[k] * ho.nodes[i as usize];
        xv += s.wt[k] * ho.nodes[i as usize];
    }
    xu.cross(xv).dot(n_hat)
}

#[test]
fn jacobian_bound_is_conservative() {
    // Spot at order 4: the reported min c / max |c| never exceeds the ratio sampled
    // densely (min J / max |J| over a level-24 grid), and is close to it for these mildly
    // curved elements.
    let mesh = common::load("spot.obj");
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let ho = build(&mesh, &table, 4, &NoProgress).unwrap();
    let mut rng = common::Rng(7);
    for _ in 0..200 {
        let t = (rng.next_u64() % mesh.triangles.len() as u64) as usize;
        let n = 24;
        let mut j = Vec::new();
        for a in 0..=n {
            for b in 0..=n - a {
                let (u, w) = (a as f64 / n as f64, b as f64 / n as f64);
                j.push(det(&ho, table.flat_normals[t], t, [1.0 - u - w, u, w]));
            }
        }
        let lo = j.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = j.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let sampled = lo / hi;
        let bound = ho.quality[t].min_scaled_jacobian;
        // Rounding of the coefficients (a 28×28 solve) only.
        assert!(bound <= sampled + 1e-9, "element {t}: {bound} > {sampled}");
        assert!(
            bound > sampled - 0.5,
            "element {t}: {bound} far below {sampled}"
        );
    }
    // Straight elements: J is constant, the ratio 1.
    let flat = PatchTable::build(&mesh, Scheme::Flat, &SchemeOptions::default()).unwrap();
    let ho = build(&mesh, &flat, 3, &NoProgress).unwrap();
    for q in &ho.quality {
        // Rounding of the Bernstein solve on exact-zero curvature.
        assert!((q.min_scaled_jacobian - 1.0).abs() < 1e-9, "{q:?}");
        assert!(q.max_distance < 1e-12, "{q:?}");
    }
}

/// Three pages of two triangles each around one spine edge (a non-manifold edge), with
/// creases between the pages: each page's G1 patch has its own boundary curve on the spine,
/// so each page's element gets its own spine nodes, on its own patch.
#[test]
fn a_non_manifold_edge_with_split_normals_gets_nodes_per_triangle() {
    let (a, b) = ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    let mut pos = vec![a, b];
    let mut tris = Vec::new();
    for deg in [0.0f64, 100.0, 200.0] {
        let (s, c) = deg.to_radians().sin_cos();
        // C on the page's plane; D out of it, so that the page folds by about 15° at B and
        // its normal at B leans off the spine's perpendicular: the spine curve bends.
        pos.push([c, s, 0.3]);
        pos.push([0.8 * c - 0.25 * s, 0.8 * s + 0.25 * c, 1.6]);
        let (ci, di) = (pos.len() as u32 - 2, pos.len() as u32 - 1);
        tris.push([0, ci, 1]);
        tris.push([1, ci, di]);
    }
    // Pages 100° apart are split by a crease angle of 30°; a page's 15° fold is not.
    let opts = LoadOptions::default().with_crease_angle(Some(30.0));
    let mesh = Mesh::from_soup("book", &pos, &tris, None, &opts).unwrap();
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let ho = build(&mesh, &table, 3, &NoProgress).unwrap();
    // 8 vertices; 2 nodes on each of 12 page edges and on each page's own spine; 1 interior
    // node per triangle.
    assert_eq!(ho.nodes.len(), 8 + 2 * (12 + 3) + 6);
    let mut spines = Vec::new();
    for t in [0, 2, 4] {
        // Element edge 2 runs from corner 2 (B) to corner 0 (A): nodes 7 and 8 of Gmsh's
        // order, at 1/3 and 2/3 of the way.
        let e = ho.element(t);
        let nodes = [ho.nodes[e[7] as usize], ho.nodes[e[8] as usize]];
        // Up to rounding only: the writer places a node at 1 − (1 − j/3), not j/3.
        for (x, b) in nodes
            .iter()
            .zip([[1.0 / 3.0, 0.0, 2.0 / 3.0], [2.0 / 3.0, 0.0, 1.0 / 3.0]])
        {
            let d = x.distance(table.eval(t, b).p);
            assert!(d < 1e-14, "triangle {t}: {d:e} off its patch");
        }
        spines.push(nodes);
    }
    // The three curves differ (by far more than rounding): one shared set of nodes would put
    // two of the elements off their patches.
    for i in 0..3 {
        let j = (i + 1) % 3;
        assert!(spines[i][0].distance(spines[j][0]) > 1e-3, "{spines:?}");
    }
}

#[test]
fn boundary_lines_and_flat_nodes_on_a_square() {
    // Two triangles of the unit square: four boundary edges, one interior diagonal. The flat
    // scheme puts every node at its affine position.
    let pos = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let tris = [[0, 1, 2], [0, 2, 3]];
    let mesh = Mesh::from_soup("square", &pos, &tris, None, &LoadOptions::default()).unwrap();
    let table = PatchTable::build(&mesh, Scheme::Flat, &SchemeOptions::default()).unwrap();
    for p in 1..=5u32 {
        let ho = build(&mesh, &table, p, &NoProgress).unwrap();
        let mut bytes = Vec::new();
        write_msh(&mut bytes, &ho, p % 2 == 0, "square").unwrap();
        let m = read_msh(&bytes);
        assert_eq!(
            m.physical_names,
            [
                (2, 1, "surface".to_string()),
                (1, 2, "boundary".to_string())
            ]
        );
        let lines: Vec<_> = m.elements.iter().filter(|e| e.0 == 1).collect();
        assert_eq!(lines.len(), 4, "order {p}");
        let pf = p as f64;
        let mut length = 0.0;
        for l in &lines {
            assert_eq!(l.2, [1, 8, 26, 27, 28][p as usize - 1]);
            let (a, b) = (v(m.nodes[&l.4[0]]), v(m.nodes[&l.4[1]]));
            length += a.distance(b);
            // Inner nodes at i/P from the first end, in order.
            for (i, tag) in l.4[2..].iter().enumerate() {
                let x = v(m.nodes[tag]);
                let want = a.lerp(b, (i + 1) as f64 / pf);
                assert!(x.distance(want) < 1e-15, "order {p}");
            }
        }
        assert_eq!(length, 4.0);
        // Boundary lines run with their triangle: around the square counter-clockwise.
        let turn: f64 = lines
            .iter()
            .map(|l| {
                let (a, b) = (v(m.nodes[&l.4[0]]), v(m.nodes[&l.4[1]]));
                a.x * b.y - a.y * b.x
            })
            .sum();
        assert_eq!(turn, 2.0);
        let count = triangle_node_count(p);
        // Shared nodes: 4 vertices, 5 edges, 2 interiors.
        let pu = p as usize;
        assert_eq!(
            m.nodes.len(),
            4 + 5 * (pu - 1) + 2 * (pu - 1) * pu.saturating_sub(2) / 2
        );
        for e in m.elements.iter().filter(|e| e.0 == 2) {
            assert_eq!(e.4.len(), count);
            let c: Vec<DVec3> = e.4[..3].iter().map(|t| v(m.nodes[t])).collect();
            for (tag, &[a, b]) in e.4.iter().zip(&triangle_nodes(p)) {
                let want = c[0] + (a as f64 / pf) * (c[1] - c[0]) + (b as f64 / pf) * (c[2] - c[0]);
                assert!(v(m.nodes[tag]).distance(want) < 1e-15);
            }
        }
    }
}

/// The bunny's 7 folded G1 patches (tests/validity.rs) give 7 order-3 elements whose bound
/// is not positive: `export-msh` says so in two warning lines. With `--repair-folds` it
/// prints the repair's report instead, makes no crease (the repair keeps G1 on the bunny)
/// and no element may fold.
#[test]
#[cfg(feature = "cli")]
fn cli_warns_of_folds_and_exports_the_repaired_mesh() {
    let bunny = common::shared_spec("stanford-bunny.obj");
    let run = |extra: &[&str], name: &str| {
        let path = out(name);
        let o = Command::new(env!("CARGO_BIN_EXE_g1tess"))
            .args(["export-msh", &bunny, "--order", "3", "--json", "-o"])
            .arg(&path)
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (String::from_utf8_lossy(&o.stderr).into_owned(), summary)
    };
    let (err, s) = run(&[], "bunny-folded.msh");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(
        lines,
        [
            "warning: stanford-bunny.obj: 7 of 69451 g1 patches are folded (their normal turns \
             over inside the patch), 0 undecided",
            "warning: stanford-bunny.obj: 7 of 69451 elements of order 3 may fold (their \
             Jacobian bound is not positive); --repair-folds repairs folded patches"
        ]
    );
    assert_eq!(s["nonpositive_jacobian_elements"], 7);
    assert_eq!(s["crease_lines"], 0);
    let (err, s) = run(&["--repair-folds"], "bunny-repaired.msh");
    assert!(
        err.starts_with(
            "stanford-bunny.obj: g1 fold repair: 7 folded and 0 undecided patches \
             before, 0 folded and 0 undecided after;"
        ) && err.lines().count() == 1,
        "{err}"
    );
    assert_eq!(s["nonpositive_jacobian_elements"], 0);
    assert!(s["min_scaled_jacobian"].as_f64().unwrap() > 0.0);
    assert_eq!(s["crease_lines"], 0);
}

#[test]
#[cfg(feature = "cli")]
fn cli_refuses_bad_orders_and_writes_stdout() {
    let bin = env!("CARGO_BIN_EXE_g1tess");
    for bad in ["0", "6"] {
        let o = Command::new(bin)
            .args(["export-msh", "sphere320", "--order", bad, "-o", "x.msh"])
            .output()
            .unwrap();
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim(), "error: --order must be 1 to 5");
    }
    let o = Command::new(bin)
        .args(["export-msh", "icosphere:0", "--order", "2", "-o", "-"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let m = read_msh(&o.stdout);
    assert_eq!(m.nodes.len(), 12 + 30);
    assert_eq!(m.elements.len(), 20);
    // The library's own error for an order it does not write names no flag.
    let mesh = common::load("sphere320");
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let e = build(&mesh, &table, 6, &NoProgress)
        .unwrap_err()
        .to_string();
    assert_eq!(e, "element order 6 is not supported (1 to 5)");
}
