//! A minimal glTF 2.0 binary of the tessellated surface: the tessellator's interleaved
//! vertices (f32 POSITION, f32 NORMAL; 24 bytes each, as the GPU wrote them) and u32
//! indices, one mesh, one node, one scene.

/// The GLB of `vertices` (24 bytes per vertex: position then normal, little-endian f32)
/// and `indices` (u32 little-endian, 3 per triangle), with the mesh named `name`.
pub fn glb(name: &str, vertices: &[u8], indices: &[u8]) -> Vec<u8> {
    let count = vertices.len() / 24;
    let mut min = [f32::MAX; 3];
    let mut max = [f32::MIN; 3];
    for v in vertices.chunks_exact(24) {
        for k in 0..3 {
            let x = f32::from_le_bytes(v[4 * k..4 * k + 4].try_into().expect("4 bytes"));
            min[k] = min[k].min(x);
            max[k] = max[k].max(x);
        }
    }
    if count == 0 {
        (min, max) = ([0.0; 3], [0.0; 3]);
    }
    let (vb, ib) = (vertices.len(), indices.len());
    let json = format!(
        concat!(
            r#"{{"asset":{{"version":"2.0","generator":"g1tess-web"}},"scene":0,"#,
            r#""scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],"#,
            r#""meshes":[{{"name":{name},"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}},"indices":2,"mode":4}}]}}],"#,
            r#""buffers":[{{"byteLength":{total}}}],"#,
            r#""bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{vb},"byteStride":24,"target":34962}},"#,
            r#"{{"buffer":0,"byteOffset":{vb},"byteLength":{ib},"target":34963}}],"#,
            r#""accessors":[{{"bufferView":0,"byteOffset":0,"componentType":5126,"count":{count},"type":"VEC3","min":{min},"max":{max}}},"#,
            r#"{{"bufferView":0,"byteOffset":12,"componentType":5126,"count":{count},"type":"VEC3"}},"#,
            r#"{{"bufferView":1,"byteOffset":0,"componentType":5125,"count":{indices},"type":"SCALAR"}}]}}"#
        ),
        name = json_string(name),
        total = vb + ib,
        vb = vb,
        ib = ib,
        count = count,
        min = json_vec(min),
        max = json_vec(max),
        indices = ib / 4,
    );
    let mut json = json.into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let bin = vb + ib; // both multiples of 4
    let total = 12 + 8 + json.len() + 8 + bin;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(vertices);
    out.extend_from_slice(indices);
    out
}

/// `[x,y,z]` with Rust's shortest round-trip formatting (valid JSON for finite values).
fn json_vec(v: [f32; 3]) -> String {
    let f = |x: f32| {
        if x.is_finite() {
            format!("{x:?}")
        } else {
            "0".into()
        }
    };
    format!("[{},{},{}]", f(v[0]), f(v[1]), f(v[2]))
}

/// `s` as a JSON string: quotes, backslashes and control characters escaped.
fn json_string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}
