//! [`Mesh::from_bytes`] against [`Mesh::load`]: the same readers on bytes in memory give the
//! same mesh bit for bit (positions, triangles, corner normals, attributes, report) for
//! OBJ, ASCII and binary PLY, STL, GLB and a glTF with a data URI; errors name the name
//! given with the bytes on one line; a glTF whose buffer is an external file is refused.

use std::path::{Path, PathBuf};

use crate::tests::common::tmp_dir;
use crate::{
    stitch_in, stitch_into, write_stitched, CpuEvaluator, InputFormat, LoadOptions, Mesh,
    MeshFormat, NoProgress, PatchTable, Scheme, SchemeOptions, TempFiles,
};

/// A file of the shared test meshes.
fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// Everything the readers produce, floats as bits (so `-0.0` and `0.0` differ).
type Bits = (Vec<[u64; 3]>, Vec<[u32; 3]>, Vec<[[u64; 3]; 3]>);

fn bits(m: &Mesh) -> Bits {
    (
        m.positions
            .iter()
            .map(|p| p.to_array().map(f64::to_bits))
            .collect(),
        m.triangles.clone(),
        m.corner_normals
            .iter()
            .map(|c| c.map(|n| n.to_array().map(f64::to_bits)))
            .collect(),
    )
}

/// Loads `path` from the file and from its bytes (named by its file name) and checks that
/// both give the same mesh; returns it.
fn same_both_ways(path: &Path, format: InputFormat, opts: &LoadOptions) -> Mesh {
    let file = Mesh::load(path.to_str().unwrap(), opts).unwrap();
    let bytes = std::fs::read(path).unwrap();
    let name = path.file_name().unwrap().to_str().unwrap();
    let mem = Mesh::from_bytes(name, &bytes, format, opts).unwrap();
    let what = path.display();
    assert!(bits(&mem) == bits(&file), "{what}: geometry differs");
    assert_eq!(mem.attributes, file.attributes, "{what}");
    assert_eq!(mem.name, file.name, "{what}");
    assert_eq!(
        serde_json::to_string(&mem.load_report).unwrap(),
        serde_json::to_string(&file.load_report).unwrap(),
        "{what}"
    );
    file
}

#[test]
fn obj_from_bytes_is_the_file_bit_for_bit() {
    // The bunny (2.4 MB) goes through the parallel blocks of a chunk; fandisk with a crease
    // angle through the crease split as well.
    for (name, opts) in [
        ("spot.obj", LoadOptions::default()),
        ("stanford-bunny.obj", LoadOptions::default()),
        (
            "fandisk.obj",
            LoadOptions::default().with_crease_angle(Some(30.0)),
        ),
    ] {
        let m = same_both_ways(&data(name), InputFormat::Obj, &opts);
        assert!(m.triangles.len() > 5000, "{name}: {}", m.triangles.len());
    }
}

/// Writes spot tessellated at level 2 (f32 samples) in the format `path` names.
fn write_spot(path: &Path) {
    let mesh = Mesh::load(data("spot.obj").to_str().unwrap(), &LoadOptions::default()).unwrap();
    let table = PatchTable::build(&mesh, Scheme::G1, &SchemeOptions::default()).unwrap();
    let eval = CpuEvaluator::default();
    let (_, plan, _) = stitch_in::<[f32; 3]>(&mesh, &table, &eval, 2).unwrap();
    write_stitched::<[f32; 3]>(
        path,
        &TempFiles::default(),
        MeshFormat::from_path(path).unwrap(),
        &plan,
        "test",
        &NoProgress,
        &mut |sink| stitch_into(&plan, &table, &eval, sink, &NoProgress).map(|_| ()),
    )
    .unwrap();
}

/// An ASCII PLY of `mesh`: positions and vertex normals (the first corner's) as Rust's
/// shortest round-trip decimals, and the triangles.
fn ascii_ply(mesh: &Mesh) -> String {
    let mut normal = vec![glam::DVec3::ZERO; mesh.positions.len()];
    for (t, n) in mesh.triangles.iter().zip(&mesh.corner_normals) {
        for k in 0..3 {
            normal[t[k] as usize] = n[k];
        }
    }
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\n\
         property double z\nproperty double nx\nproperty double ny\nproperty double nz\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.triangles.len()
    );
    for (p, n) in mesh.positions.iter().zip(&normal) {
        s += &format!(
            "{:?} {:?} {:?} {:?} {:?} {:?}\n",
            p.x, p.y, p.z, n.x, n.y, n.z
        );
    }
    for t in &mesh.triangles {
        s += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    s
}

#[test]
fn ply_stl_and_glb_from_bytes_are_the_files_bit_for_bit() {
    let dir = tmp_dir("from-bytes-formats");
    let opts = LoadOptions::default();
    let mut counts = Vec::new();
    for (name, format) in [
        ("spot.ply", InputFormat::Ply),
        ("spot.stl", InputFormat::Stl),
        ("spot.glb", InputFormat::Gltf),
    ] {
        let path = dir.join(name);
        write_spot(&path);
        counts.push(same_both_ways(&path, format, &opts).triangles.len());
    }
    // Spot has 5,856 triangles; level 2 splits each into 4.
    assert_eq!(counts, [4 * 5856; 3]);
    let spot = Mesh::load(data("spot.obj").to_str().unwrap(), &opts).unwrap();
    let path = dir.join("spot-ascii.ply");
    std::fs::write(&path, ascii_ply(&spot)).unwrap();
    let m = same_both_ways(&path, InputFormat::Ply, &opts);
    assert_eq!(m.triangles.len(), 5856);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A tetrahedron as glTF JSON whose one buffer has the URI `uri` (positions, then u16
/// indices), and that buffer's bytes.
fn tetra_gltf(uri: &str) -> (String, Vec<u8>) {
    let mut bin = Vec::new();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]] {
        bin.extend(p.iter().flat_map(|x| x.to_le_bytes()));
    }
    for i in [0u16, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"uri": uri, "byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 24}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}
        ]
    });
    (json.to_string(), bin)
}

#[test]
fn gltf_from_bytes_reads_data_uris_and_refuses_external_buffers() {
    let dir = tmp_dir("from-bytes-gltf");
    let opts = LoadOptions::default();
    let (external, bin) = tetra_gltf("tetra.bin");
    let path = dir.join("tetra.gltf");
    std::fs::write(&path, &external).unwrap();
    std::fs::write(dir.join("tetra.bin"), &bin).unwrap();
    // From the file, the external buffer beside it is read.
    let file = Mesh::load(path.to_str().unwrap(), &opts).unwrap();
    assert_eq!((file.positions.len(), file.triangles.len()), (4, 4));
    // From bytes there is no folder: a one-line error naming the given name and the buffer.
    let err = Mesh::from_bytes(
        "dropped.gltf",
        external.as_bytes(),
        InputFormat::Gltf,
        &opts,
    )
    .unwrap_err()
    .to_string();
    assert_eq!(
        err,
        "dropped.gltf: buffer 0: URI 'tetra.bin' names an external file, which a glTF \
         loaded from bytes cannot read (only GLB and data URI buffers are)"
    );
    // The same buffer as a data URI: read from bytes, the same mesh as the file.
    let b64 = base64_encode(&bin);
    let (inline, _) = tetra_gltf(&format!("data:application/octet-stream;base64,{b64}"));
    let mem = Mesh::from_bytes("tetra.gltf", inline.as_bytes(), InputFormat::Gltf, &opts).unwrap();
    assert!(bits(&mem) == bits(&file));
    assert_eq!(mem.name, "tetra.gltf");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Standard base64 with padding.
fn base64_encode(b: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in b.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

#[test]
fn bad_bytes_give_one_line_errors_naming_the_given_name() {
    let opts = LoadOptions::default();
    let cases: [(&str, &[u8], InputFormat, &str); 7] = [
        (
            "my mesh.obj",
            b"v 0 0 0\nv 1 0\n",
            InputFormat::Obj,
            "my mesh.obj:2: ",
        ),
        (
            "faces.obj",
            b"v 0 0 0\nf 1 2 3\n",
            InputFormat::Obj,
            "faces.obj:2: ",
        ),
        (
            "x.ply",
            b"not a ply\n",
            InputFormat::Ply,
            "x.ply:1: not a PLY file",
        ),
        (
            "x.stl",
            b"solid s\nfacet normal 0 0 1\nouter loop\n",
            InputFormat::Stl,
            "x.stl:",
        ),
        ("x.glb", b"glTF\x02\0\0\0", InputFormat::Gltf, "x.glb: "),
        (
            "x.pn",
            b"something else\n",
            InputFormat::Pn,
            "x.pn:1: not a point-normal file",
        ),
        ("empty.obj", b"", InputFormat::Obj, "empty.obj: empty mesh"),
    ];
    for (name, bytes, format, start) in cases {
        let err = Mesh::from_bytes(name, bytes, format, &opts)
            .unwrap_err()
            .to_string();
        assert!(err.starts_with(start), "{name}: {err}");
        assert!(!err.contains('\n'), "{name}: {err}");
    }
}
