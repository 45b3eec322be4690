//! Hostile inputs to the readers: special files (FIFOs, devices, directories, links to
//! them) refused before they are opened, glTF buffer URIs confined to the glTF's folder and
//! read to exactly their declared length, data a reader used to drop silently refused, and
//! the messages of a truncated binary STL, an upper-case ASCII STL and a singular glTF
//! transform. `gltf_uri_mutants` is the URI fuzzer `scripts/fuzz.sh` runs at length.
//!
//! A FIFO is watched while a reader is given it ([`FifoWatch`]): anything that opens it for
//! reading is unblocked at once and counted, so a reader that opens one fails the test
//! instead of hanging it; no assertion depends on a timeout.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use g1tess::{LoadOptions, Mesh};
use proptest::prelude::*;
use proptest::test_runner::{TestCaseError, TestRunner};
use serde_json::json;

fn dir(sub: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("hardening_readers")
        .join(sub);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn load(p: &Path) -> g1tess::Result<Mesh> {
    Mesh::load(p.to_str().unwrap(), &LoadOptions::default())
}

/// The error of loading `p`, asserted to be one line without control characters.
fn load_err(p: &Path) -> String {
    let e = match load(p) {
        Ok(m) => panic!("{} loaded ({} triangles)", p.display(), m.triangles.len()),
        Err(e) => e.to_string(),
    };
    assert!(!e.chars().any(|c| c.is_control()), "one line: {e:?}");
    e
}

/// A FIFO at `p` (replacing what is there).
fn mkfifo(p: &Path) {
    let _ = std::fs::remove_file(p);
    let ok = std::process::Command::new("mkfifo")
        .arg(p)
        .status()
        .unwrap()
        .success();
    assert!(ok, "mkfifo {}", p.display());
}

/// `link` made a symbolic link to `target` (replacing what is there).
fn symlink(target: &Path, link: &Path) {
    let _ = std::fs::remove_file(link);
    std::os::unix::fs::symlink(target, link).unwrap();
}

/// Watches a FIFO while it lives: whenever something has it open for reading, the watch
/// opens it for writing (non-blocking, so it never waits itself) and closes it again, which
/// unblocks that reader with an empty stream, and counts it.
struct FifoWatch {
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<usize>>,
}

impl FifoWatch {
    fn new(fifo: &Path) -> FifoWatch {
        use std::os::unix::fs::OpenOptionsExt;
        let stop = Arc::new(AtomicBool::new(false));
        let (stop2, fifo) = (stop.clone(), fifo.to_path_buf());
        let thread = std::thread::spawn(move || {
            let mut opened = 0;
            while !stop2.load(Ordering::Relaxed) {
                // ENXIO while no reader has it open.
                let w = std::fs::OpenOptions::new()
                    .write(true)
                    .custom_flags(libc::O_NONBLOCK)
                    .open(&fifo);
                if w.is_ok() {
                    opened += 1;
                }
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            opened
        });
        FifoWatch {
            stop,
            thread: Some(thread),
        }
    }

    /// How many times a reader had the FIFO open; stops the watch.
    fn opened(mut self) -> usize {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.take().unwrap().join().unwrap()
    }
}

// ---------------------------------------------------------------------------------------
// Special files

#[test]
fn fifos_devices_and_directories_are_refused_before_opening() {
    let d = dir("special");
    let fifo = d.join("pipe");
    mkfifo(&fifo);
    let watch = FifoWatch::new(&fifo);
    // A FIFO under every name a reader is chosen by, and through links.
    let mut names = Vec::new();
    for name in [
        "m.obj", "m.pn", "m.gltf", "m.glb", "m.ply", "m.stl", "noext", "m.OBJ",
    ] {
        let p = d.join(name);
        mkfifo(&p);
        names.push(p);
    }
    let link = d.join("link.obj");
    symlink(&d.join("m.obj"), &link);
    let link2 = d.join("link-noext");
    symlink(&fifo, &link2);
    names.push(link);
    names.push(link2);
    let watches: Vec<FifoWatch> = names.iter().map(|p| FifoWatch::new(p)).collect();
    for p in &names {
        let e = load_err(p);
        assert_eq!(
            e,
            format!(
                "{}: not a regular file but a FIFO (save what it gives to a file first)",
                p.display()
            )
        );
    }
    for (p, w) in names.iter().zip(watches) {
        assert_eq!(w.opened(), 0, "{} was opened", p.display());
    }
    assert_eq!(watch.opened(), 0, "the linked FIFO was opened");
    // A character device, a directory, a link to each.
    assert_eq!(
        load_err(Path::new("/dev/null")),
        "/dev/null: not a regular file but a character device (save what it gives to a \
         file first)"
    );
    let sub = d.join("folder.obj");
    std::fs::create_dir_all(&sub).unwrap();
    assert_eq!(
        load_err(&sub),
        format!("{}: not a regular file but a directory", sub.display())
    );
    let zero = d.join("zero.stl");
    symlink(Path::new("/dev/zero"), &zero);
    assert!(load_err(&zero).ends_with(
        "zero.stl: not a regular file but a character device (save what it gives to a file first)"
    ));
    // The format sniffing of a public entry point does not open one either.
    let w = FifoWatch::new(&d.join("noext"));
    let e = g1tess::InputFormat::detect(&d.join("noext")).unwrap_err();
    assert!(
        e.to_string()
            .contains("noext: not a regular file but a FIFO"),
        "{e}"
    );
    assert_eq!(w.opened(), 0);
}

/// The command line reads a glTF scene's JSON for its memory estimate before the load: a
/// FIFO named like one is not opened there either.
#[cfg(feature = "cli")]
#[test]
fn the_command_line_does_not_open_a_fifo_named_like_a_gltf() {
    let d = dir("cli-fifo");
    for name in ["scene.gltf", "scene.glb", "scene.obj"] {
        let p = d.join(name);
        mkfifo(&p);
        let w = FifoWatch::new(&p);
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_g1tess"))
            .args(["stats", p.to_str().unwrap()])
            .output()
            .unwrap();
        assert_eq!(w.opened(), 0, "{name} was opened");
        assert_eq!(out.status.code(), Some(1));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(&format!("{name}: not a regular file but a FIFO")),
            "{err}"
        );
    }
}

// ---------------------------------------------------------------------------------------
// glTF buffers

/// The tetrahedron as a glTF buffer: positions (0..48), normals (48..96), u16 indices
/// (96..120).
fn tetra_bin() -> Vec<u8> {
    let p: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let t: [u16; 12] = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];
    let mut b: Vec<u8> = p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    // Each vertex's normal: its direction from the centroid (1/4, 1/4, 1/4).
    for q in p {
        let n = q.map(|x| x - 0.25);
        b.extend(n.iter().flat_map(|x| x.to_le_bytes()));
    }
    b.extend(t.iter().flat_map(|i| i.to_le_bytes()));
    b
}

/// A glTF document of the tetrahedron in buffer 0 (`uri`, `byte_length`), nodes given.
fn tetra_json(uri: &str, byte_length: u64, nodes: serde_json::Value) -> Vec<u8> {
    serde_json::to_vec(&json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
        "buffers": [{"byteLength": byte_length, "uri": uri}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 96},
            {"buffer": 0, "byteOffset": 96, "byteLength": 24}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 1]},
            {"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}
        ]
    }))
    .unwrap()
}

/// A scene folder for the URI tests: `scene/` holding `tetra.bin`, a subfolder `sub`, a
/// FIFO `fifo.bin`, links `link-in.bin` (to `tetra.bin`), `link-out.bin` (to
/// `../outside.bin`), `link-zero.bin` (to `/dev/zero`), `link-fifo.bin` (to the FIFO) and
/// a sparse `big.bin` of `big` bytes starting with the tetrahedron; beside the folder, a
/// valid `outside.bin`. Returns the scene folder.
fn scene_folder(name: &str, big: u64) -> PathBuf {
    let root = dir(name);
    let s = root.join("scene");
    std::fs::create_dir_all(s.join("sub")).unwrap();
    std::fs::write(s.join("tetra.bin"), tetra_bin()).unwrap();
    std::fs::write(root.join("outside.bin"), tetra_bin()).unwrap();
    mkfifo(&s.join("fifo.bin"));
    symlink(Path::new("tetra.bin"), &s.join("link-in.bin"));
    symlink(Path::new("../outside.bin"), &s.join("link-out.bin"));
    symlink(Path::new("/dev/zero"), &s.join("link-zero.bin"));
    symlink(Path::new("fifo.bin"), &s.join("link-fifo.bin"));
    let f = std::fs::File::create(s.join("big.bin")).unwrap();
    std::io::Write::write_all(&mut &f, &tetra_bin()).unwrap();
    f.set_len(big).unwrap();
    s
}

/// The error of `scene/NAME.gltf` with buffer 0 at `uri` declaring `len` bytes.
fn uri_err(scene: &Path, name: &str, uri: &str, len: u64) -> String {
    let p = scene.join(name);
    std::fs::write(&p, tetra_json(uri, len, json!([{"mesh": 0}]))).unwrap();
    load_err(&p)
}

#[test]
fn gltf_buffer_uris_stay_inside_the_gltf_folder() {
    let s = scene_folder("uris", 1 << 20);
    let watch = FifoWatch::new(&s.join("fifo.bin"));
    let outside = s.parent().unwrap().join("outside.bin");
    let abs = outside.to_str().unwrap().to_string();
    let only = "(only files inside the glTF's folder and data URIs are read)";
    let climbs = format!("climbs out of the glTF's folder with '..' {only}");
    let cases: Vec<(&str, String)> = vec![
        ("../outside.bin", climbs.clone()),
        ("sub/../../outside.bin", climbs.clone()),
        ("%2e%2e/outside.bin", climbs.clone()),
        ("./../outside.bin", climbs),
        ("/dev/zero", format!("is an absolute path {only}")),
        ("/dev/urandom", format!("is an absolute path {only}")),
        (&abs, format!("is an absolute path {only}")),
        (
            "link-out.bin",
            format!("leads out of the glTF's folder through a symbolic link {only}"),
        ),
        (
            "link-zero.bin",
            format!("leads out of the glTF's folder through a symbolic link {only}"),
        ),
        ("fifo.bin", "names a FIFO, not a regular file".into()),
        ("link-fifo.bin", "names a FIFO, not a regular file".into()),
        ("sub", "names a directory, not a regular file".into()),
    ];
    for (k, (uri, why)) in cases.iter().enumerate() {
        let name = format!("case{k}.gltf");
        let e = uri_err(&s, &name, uri, 120);
        // The URI is echoed cut to 80 characters (the absolute one may be longer).
        let shown: String = uri.chars().take(80).collect();
        let head = format!("{}: buffer 0: URI '{shown}", s.join(&name).display());
        assert!(
            e.starts_with(&head) && e.ends_with(&format!("' {why}")),
            "{e}"
        );
    }
    assert_eq!(watch.opened(), 0, "the FIFO was opened");
    // Inside the folder: the file, through a link inside, through a subfolder and back.
    for uri in [
        "tetra.bin",
        "link-in.bin",
        "sub/../tetra.bin",
        "./tetra.bin",
    ] {
        let p = s.join("ok.gltf");
        std::fs::write(&p, tetra_json(uri, 120, json!([{"mesh": 0}]))).unwrap();
        let m = load(&p).unwrap();
        assert_eq!(m.triangles.len(), 4, "{uri}");
        assert_eq!(m.positions[1], glam::DVec3::X, "{uri}");
    }
}

#[test]
fn gltf_buffers_are_read_to_their_declared_length_only() {
    // A sparse file of 1 TiB starting with the tetrahedron: reading it whole could not even
    // be allocated (it would fail, or exhaust memory); exactly byteLength (120) is read.
    let s = scene_folder("lengths", 1 << 40);
    let p = s.join("big.gltf");
    std::fs::write(&p, tetra_json("big.bin", 120, json!([{"mesh": 0}]))).unwrap();
    let m = load(&p).unwrap();
    assert_eq!(m.triangles.len(), 4);
    // A byteLength beyond the file: refused from the file's size, nothing read.
    let e = uri_err(&s, "long.gltf", "tetra.bin", 1 << 40);
    assert!(
        e.ends_with(
            "long.gltf: buffer 0: URI 'tetra.bin' names a file of 120 bytes, 1099511627776 \
             declared (truncated)"
        ),
        "{e}"
    );
    // Too long by one.
    let e = uri_err(&s, "long1.gltf", "tetra.bin", 121);
    assert!(
        e.ends_with("names a file of 120 bytes, 121 declared (truncated)"),
        "{e}"
    );
    std::fs::remove_file(s.join("big.bin")).unwrap();
}

#[cfg(feature = "cli")]
#[test]
fn gltf_buffer_lengths_count_in_the_memory_budget() {
    // 1 GiB + 120 bytes, sparse, the tetrahedron first.
    let s = scene_folder("budget", (1 << 30) + 120);
    let p = s.join("whole.gltf");
    std::fs::write(
        &p,
        tetra_json("big.bin", (1 << 30) + 120, json!([{"mesh": 0}])),
    )
    .unwrap();
    let stats = |p: &Path, extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_g1tess"))
            .args(["stats", p.to_str().unwrap(), "--backend", "cpu"])
            .args(extra)
            .output()
            .unwrap()
    };
    // Declared whole: over a 64 MiB budget, refused before the load (which would read it).
    let out = stats(&p, &["--max-memory", "64M"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains(
            "whole.gltf needs about 1.0 GiB (estimated), over the memory budget of 64.0 MiB"
        ),
        "{err}"
    );
    // Declared as its first 120 bytes: within the budget, read.
    let p = s.join("head.gltf");
    std::fs::write(&p, tetra_json("big.bin", 120, json!([{"mesh": 0}]))).unwrap();
    let out = stats(&p, &["--max-memory", "64M"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::remove_file(s.join("big.bin")).unwrap();
}

// ---------------------------------------------------------------------------------------
// Data that was dropped silently

/// An ASCII PLY header for `nv` vertices (x y z floats) and `nf` faces.
fn ply_header(format: &str, nv: usize, nf: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\n\
         property float z\nelement face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

const TETRA_P: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];
const TETRA_T: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

#[test]
fn ply_data_past_the_declared_records_is_refused() {
    let d = dir("ply");
    let mut body = String::new();
    for p in TETRA_P {
        body += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for t in TETRA_T {
        body += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    // 2 faces declared, 4 held: header 9 lines, vertices 10-13, faces 14-17.
    let p = d.join("two.ply");
    std::fs::write(&p, ply_header("ascii", 4, 2) + &body).unwrap();
    assert_eq!(
        load_err(&p),
        format!(
            "{}:16: a line after the last record the header declares (element 'face' counts \
             2 records): more records than declared, or data that is not part of the mesh",
            p.display()
        )
    );
    // 4 declared and held, blank lines after them: read.
    let p = d.join("four.ply");
    std::fs::write(&p, ply_header("ascii", 4, 4) + &body + "\n  \n").unwrap();
    assert_eq!(load(&p).unwrap().triangles.len(), 4);
    // Binary, followed by 1 MiB of garbage.
    let mut bin = ply_header("binary_little_endian", 4, 4).into_bytes();
    for p in TETRA_P {
        bin.extend(p.iter().flat_map(|x| x.to_le_bytes()));
    }
    for t in TETRA_T {
        bin.push(3);
        bin.extend(t.iter().flat_map(|i| (*i as i32).to_le_bytes()));
    }
    let p = d.join("exact.ply");
    std::fs::write(&p, &bin).unwrap();
    assert_eq!(load(&p).unwrap().triangles.len(), 4);
    bin.extend(std::iter::repeat_n(0xAB, 1 << 20));
    let p = d.join("garbage.ply");
    std::fs::write(&p, &bin).unwrap();
    assert_eq!(
        load_err(&p),
        format!(
            "{}: 1048576 bytes after the last record the header declares (element 'face' \
             counts 4 records): more records than declared, or data that is not part of the \
             mesh",
            p.display()
        )
    );
}

/// Puts STL text in some case.
type Case = fn(&str) -> String;

/// The tetrahedron as ASCII STL, keywords in the case `case` gives them.
fn stl_ascii(case: Case) -> String {
    let mut s = case("solid t\n");
    for t in TETRA_T {
        s += &case(" facet normal 0 0 0\n  outer loop\n");
        for v in t {
            let p = TETRA_P[v as usize];
            s += &format!("   {} {} {} {}\n", case("vertex"), p[0], p[1], p[2]);
        }
        s += &case("  endloop\n endfacet\n");
    }
    s + &case("endsolid t\n")
}

#[test]
fn an_stl_vertex_with_a_fourth_number_is_refused() {
    let d = dir("stl");
    let text = stl_ascii(|s| s.to_string());
    // Line 5 is the second vertex of the first facet: "   vertex 0 1 0".
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    assert_eq!(lines[4], "   vertex 0 1 0");
    lines[4] += " 99";
    let p = d.join("four.stl");
    std::fs::write(&p, lines.join("\n")).unwrap();
    assert_eq!(
        load_err(&p),
        format!(
            "{}:5: vertex: a fourth value '99' (a vertex has 3 coordinates)",
            p.display()
        )
    );
}

/// A glTF of the tetrahedron whose index accessor holds `count` u16 indices (the 12 of
/// the tetrahedron, then 0, 1, 2, ... again), as `mode` (4 triangles, 5 strip, 6 fan).
fn indexed_gltf(count: usize, mode: u32) -> Vec<u8> {
    let mut bin = tetra_bin();
    bin.truncate(96);
    let t: Vec<u16> = (0..count)
        .map(|k| {
            TETRA_T
                .iter()
                .flatten()
                .copied()
                .chain(0..4)
                .cycle()
                .nth(k)
                .unwrap() as u16
        })
        .collect();
    bin.extend(t.iter().flat_map(|i| i.to_le_bytes()));
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let uri = format!("data:application/octet-stream;base64,{}", b64(&bin));
    serde_json::to_vec(&json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": mode}]}],
        "buffers": [{"byteLength": bin.len(), "uri": uri}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 2 * count}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5123, "count": count, "type": "SCALAR"}
        ]
    }))
    .unwrap()
}

/// Standard base64 with padding (an encoder of the test's own).
fn b64(b: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in b.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            s.push(if k <= c.len() {
                A[(n >> (18 - 6 * k) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    s
}

#[test]
fn a_gltf_triangle_list_must_hold_whole_triangles() {
    let d = dir("gltf-count");
    let p = d.join("fourteen.gltf");
    std::fs::write(&p, indexed_gltf(14, 4)).unwrap();
    assert_eq!(
        load_err(&p),
        format!(
            "{}: mesh 0 primitive 0: 14 indices for TRIANGLES, not a multiple of 3 (the last 2 \
             would be dropped)",
            p.display()
        )
    );
    // 12: the tetrahedron; a strip or a fan of 14 is whole whatever its count.
    std::fs::write(&p, indexed_gltf(12, 4)).unwrap();
    assert_eq!(load(&p).unwrap().triangles.len(), 4);
    std::fs::write(&p, indexed_gltf(14, 6)).unwrap();
    assert!(load(&p).is_ok());
}

// ---------------------------------------------------------------------------------------
// Messages

#[test]
fn a_truncated_binary_stl_with_a_solid_header_is_named_binary() {
    let d = dir("stl-solid");
    let mut header = b"solid tetra exported as binary".to_vec();
    header.resize(80, b' ');
    let mut bin = header;
    bin.extend(4u32.to_le_bytes());
    for t in TETRA_T {
        bin.extend([0u8; 12]);
        for v in t {
            bin.extend(TETRA_P[v as usize].iter().flat_map(|x| x.to_le_bytes()));
        }
        bin.extend([0u8; 2]);
    }
    assert_eq!(bin.len(), 284);
    let p = d.join("whole.stl");
    std::fs::write(&p, &bin).unwrap();
    assert_eq!(load(&p).unwrap().triangles.len(), 4);
    let p = d.join("cut.stl");
    std::fs::write(&p, &bin[..277]).unwrap();
    assert_eq!(
        load_err(&p),
        format!(
            "{}: binary STL header counts 4 facets (284 bytes) but the file has 277 bytes: \
             facet 3 is incomplete (truncated file, or a count that lies)",
            p.display()
        )
    );
    // Cut inside the header.
    let p = d.join("stub.stl");
    std::fs::write(&p, &bin[..82]).unwrap();
    assert!(
        load_err(&p).ends_with("stub.stl: truncated binary STL: 82 bytes, the header alone is 84"),
    );
}

#[test]
fn upper_case_ascii_stl_reads_like_lower_case() {
    let d = dir("stl-case");
    let lower = d.join("lower.stl");
    std::fs::write(&lower, stl_ascii(|s| s.to_string())).unwrap();
    let want = load(&lower).unwrap();
    assert_eq!(want.triangles.len(), 4);
    let cases: [(&str, Case); 2] = [
        ("upper.stl", |s| s.to_uppercase()),
        ("title", |s| {
            // "Solid", "Facet Normal", "Outer Loop", "Vertex", ...
            s.split(' ')
                .map(|w| {
                    let mut c = w.chars();
                    c.next()
                        .map(|f| f.to_uppercase().chain(c).collect())
                        .unwrap_or_default()
                })
                .collect::<Vec<String>>()
                .join(" ")
        }),
    ];
    for (name, case) in cases {
        // "title" has no extension: recognised by its content.
        let p = d.join(name);
        std::fs::write(&p, stl_ascii(case)).unwrap();
        let m = load(&p).unwrap();
        assert_eq!(m.positions, want.positions, "{name}");
        assert_eq!(m.triangles, want.triangles, "{name}");
    }
}

#[test]
fn a_singular_gltf_transform_is_named() {
    let d = dir("gltf-singular");
    std::fs::write(d.join("tetra.bin"), tetra_bin()).unwrap();
    let case = |name: &str, nodes: serde_json::Value| {
        let p = d.join(name);
        std::fs::write(&p, tetra_json("tetra.bin", 120, nodes)).unwrap();
        (load_err(&p), p.display().to_string())
    };
    let tail = "whose normals then have no transform";
    let (e, p) = case("own.gltf", json!([{"scale": [1, 0, 1], "mesh": 0}]));
    assert_eq!(
        e,
        format!("{p}: node 0: singular transform (from its own scale or matrix): it flattens mesh 0, {tail}")
    );
    let (e, p) = case(
        "parent.gltf",
        json!([{"scale": [0, 0, 0], "children": [1]}, {"translation": [1, 2, 3], "mesh": 0}]),
    );
    assert_eq!(
        e,
        format!("{p}: node 1: singular transform (from the scale or matrix of its ancestor node 0): it flattens mesh 0, {tail}")
    );
    // A matrix of rank 2 (z dropped).
    let (e, p) = case(
        "matrix.gltf",
        json!([{"matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1], "mesh": 0}]),
    );
    assert_eq!(
        e,
        format!("{p}: node 0: singular transform (from its own scale or matrix): it flattens mesh 0, {tail}")
    );
    // Two scales of 1e-200 whose product underflows: neither alone is singular.
    let (e, p) = case(
        "product.gltf",
        json!([{"scale": [1e-30, 1e-30, 1e-30], "children": [1]},
               {"scale": [1e-30, 1e-30, 1e-30], "children": [2]},
               {"scale": [1e-30, 1e-30, 1e-30], "children": [3]},
               {"scale": [1e-30, 1e-30, 1e-30], "mesh": 0}]),
    );
    assert_eq!(
        e,
        format!("{p}: node 3: singular transform (from the product of its ancestors' transforms): it flattens mesh 0, {tail}")
    );
    // A node with scale 0 and no mesh below it is no error.
    let p = d.join("hidden.gltf");
    let mut j: serde_json::Value =
        serde_json::from_slice(&tetra_json("tetra.bin", 120, json!([{"mesh": 0}]))).unwrap();
    j["nodes"] = json!([{"mesh": 0}, {"scale": [0, 0, 0]}]);
    j["scenes"][0]["nodes"] = json!([0, 1]);
    std::fs::write(&p, serde_json::to_vec(&j).unwrap()).unwrap();
    assert_eq!(load(&p).unwrap().triangles.len(), 4);
}

// ---------------------------------------------------------------------------------------
// The URI fuzzer

/// Prefixes and names a hostile glTF puts in a buffer URI, joined at random.
const URI_PREFIXES: &[&str] = &[
    "",
    "./",
    "sub/",
    "sub/../",
    "../",
    "../../",
    "../scene/",
    "/",
    "//",
    "%2e%2e/",
    "%2E%2E%2F",
    "sub/%2e%2e/",
    "./sub/../../",
    "file:",
    "file://",
    "http://host/",
    "\\..\\",
];
const URI_NAMES: &[&str] = &[
    "tetra.bin",
    "fifo.bin",
    "link-in.bin",
    "link-out.bin",
    "link-zero.bin",
    "link-fifo.bin",
    "big.bin",
    "outside.bin",
    "missing.bin",
    "sub",
    ".",
    "..",
    "",
    "dev/zero",
    "/dev/zero",
    "/dev/urandom",
    "/proc/self/mem",
    "/etc/passwd",
    "tetra%2ebin",
    "tetra.bin%00",
    "tetra.bin%",
    "%ff",
    "tetra.bin\u{1b}[2J",
    "tetra.bin\n",
];
/// Declared lengths: exact, short, one over, the sparse file's, huge.
const URI_LENGTHS: &[u64] = &[
    120,
    0,
    96,
    121,
    16 << 20,
    (16 << 20) + 1,
    1 << 32,
    6 << 30,
    u64::MAX >> 12,
];

/// Whether `uri` names, once percent-decoded and resolved from `folder`, a file inside
/// `folder` (an independent oracle: the canonical path under the canonical folder, no
/// absolute path, no `..` climbing above the folder).
fn inside(folder: &Path, uri: &str) -> bool {
    let Some(rel) = percent_decode(uri) else {
        return false;
    };
    if rel.starts_with('/') || uri.contains("://") {
        return false;
    }
    let mut depth = 0i32;
    for part in rel.split('/') {
        match part {
            "" | "." => {}
            ".." => depth -= 1,
            _ => depth += 1,
        }
        if depth < 0 {
            return false;
        }
    }
    match folder.join(&rel).canonicalize() {
        Ok(c) => c.starts_with(folder.canonicalize().unwrap()),
        Err(_) => false,
    }
}

fn percent_decode(s: &str) -> Option<String> {
    let mut out = Vec::new();
    let mut it = s.bytes();
    while let Some(b) = it.next() {
        if b == b'%' {
            let h = [it.next()?, it.next()?];
            out.push(u8::from_str_radix(std::str::from_utf8(&h).ok()?, 16).ok()?);
        } else {
            out.push(b);
        }
    }
    String::from_utf8(out).ok()
}

/// glTF buffer URIs of every hostile kind (traversal, absolute paths, devices, FIFOs,
/// links out of the folder, huge lengths): a load never opens the FIFO, never reads a
/// file outside the glTF's folder, reads at most what a buffer declares, and ends in a
/// mesh or a one-line error naming the buffer. `PROPTEST_CASES` sets the cases (default
/// 300; `scripts/fuzz.sh` runs many more).
#[test]
fn gltf_uri_mutants() {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(300);
    let s = scene_folder("uri-fuzz", 16 << 20);
    let watch = FifoWatch::new(&s.join("fifo.bin"));
    let gltf = s.join("mutant.gltf");
    // A prefix, a name, then up to three more of either, concatenated.
    let parts = URI_PREFIXES.len() + URI_NAMES.len();
    let part = |k: usize| {
        URI_PREFIXES
            .get(k)
            .copied()
            .unwrap_or_else(|| URI_NAMES[k - URI_PREFIXES.len()])
    };
    let strategy = (
        0..URI_PREFIXES.len(),
        0..URI_NAMES.len(),
        prop::collection::vec(0..parts, 0..4),
        0..URI_LENGTHS.len(),
    );
    let mut runner = TestRunner::new(ProptestConfig {
        cases,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    let result = runner.run(&strategy, |(pre, name, more, len)| {
        let mut uri = format!("{}{}", URI_PREFIXES[pre], URI_NAMES[name]);
        uri.extend(more.into_iter().map(part));
        let length = URI_LENGTHS[len];
        std::fs::write(&gltf, tetra_json(&uri, length, json!([{"mesh": 0}]))).unwrap();
        match load(&gltf) {
            Ok(m) => {
                prop_assert!(inside(&s, &uri), "{uri:?} read from outside the folder");
                prop_assert!(length <= 16 << 20, "{uri:?} read {length} bytes");
                prop_assert!(!m.triangles.is_empty());
            }
            Err(e) => {
                let e = e.to_string();
                prop_assert!(!e.chars().any(|c| c.is_control()), "{e:?}");
                prop_assert!(e.chars().count() < 600, "long: {e}");
                if !uri.starts_with("data:") {
                    prop_assert!(e.contains("mutant.gltf: "), "{e}");
                }
                if !inside(&s, &uri) {
                    prop_assert!(e.contains("mutant.gltf: buffer 0: URI '"), "{uri:?}: {e}");
                }
            }
        }
        Ok::<(), TestCaseError>(())
    });
    assert_eq!(watch.opened(), 0, "the FIFO was opened");
    std::fs::remove_file(s.join("big.bin")).unwrap();
    if let Err(e) = result {
        panic!("{e}");
    }
}
