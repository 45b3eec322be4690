//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

use g1tess::{LoadOptions, Mesh};

/// A new folder `PREFIX-N` under `parent`, N counting this process's calls: the suite's tests
/// run at once in one process, and two that shared a folder or a file name in it would
/// rewrite or remove it under each other.
pub fn fresh_dir(parent: &Path, prefix: &str) -> PathBuf {
    static CALLS: AtomicUsize = AtomicUsize::new(0);
    let dir = parent.join(format!("{prefix}-{}", CALLS.fetch_add(1, Relaxed)));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A mesh of `tests/data` (copies of the project's shared test meshes, provenance in
/// `tests/data/PROVENANCE.md`), so the tests pass from a plain clone.
pub fn shared_mesh(name: &str) -> PathBuf {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    assert!(p.exists(), "test mesh {} is missing", p.display());
    p
}

/// The unit cube's corners: corner i at the bits of i (x = bit 0, y = bit 1, z = bit 2).
pub fn cube_corners() -> Vec<[f64; 3]> {
    (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
        .collect()
}

/// The unit cube's faces as quads of [`cube_corners`], counter-clockwise seen from outside.
pub const CUBE_QUADS: [[u32; 4]; 6] = [
    [0, 2, 3, 1],
    [4, 5, 7, 6],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 4, 6, 2],
    [1, 3, 7, 5],
];

/// The outward normal of each face of [`CUBE_QUADS`].
pub const CUBE_FACE_NORMALS: [[i32; 3]; 6] = [
    [0, 0, -1],
    [0, 0, 1],
    [0, -1, 0],
    [0, 1, 0],
    [-1, 0, 0],
    [1, 0, 0],
];

/// The unit cube as OBJ text: its 8 corners and 6 quads, with (`flat`) one `vn` per face
/// or without normals.
pub fn cube_obj(flat: bool) -> String {
    let mut s = String::new();
    for p in cube_corners() {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    if flat {
        for n in CUBE_FACE_NORMALS {
            s += &format!("vn {} {} {}\n", n[0], n[1], n[2]);
        }
    }
    for (i, q) in CUBE_QUADS.iter().enumerate() {
        let c: Vec<String> = q
            .iter()
            .map(|v| match flat {
                true => format!("{}//{}", v + 1, i + 1),
                false => format!("{}", v + 1),
            })
            .collect();
        s += &format!("f {}\n", c.join(" "));
    }
    s
}

/// [`shared_mesh`] as the string `Mesh::load` and the command line take.
pub fn shared_spec(name: &str) -> String {
    shared_mesh(name).display().to_string()
}

/// Loads a built-in mesh or a mesh of `tests/data` (estimated angle-weighted normals where the file
/// has none).
pub fn load(spec: &str) -> Mesh {
    let spec = if spec.ends_with(".obj") {
        shared_mesh(spec).display().to_string()
    } else {
        spec.to_string()
    };
    Mesh::load(&spec, &LoadOptions::default()).expect("mesh loads")
}

/// A small deterministic pseudo-random generator (SplitMix64) so tests need no seed files.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// A random interior barycentric point, each coordinate at least `margin`.
    pub fn interior_b(&mut self, margin: f64) -> [f64; 3] {
        loop {
            let (s, t) = (self.f64(), self.f64());
            let b = [1.0 - s - t, s, t];
            if b.iter().all(|&x| x >= margin) {
                return b;
            }
        }
    }
}

/// The Rust source file of module path `segments` (e.g. ["patch", "basis"] →
/// src/patch/basis.rs or src/patch/basis/mod.rs), if any.
fn rust_file(segments: &[&str]) -> Option<String> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src");
    let dir = segments.iter().fold(root, |p, s| p.join(s));
    [dir.with_extension("rs"), dir.join("mod.rs")]
        .iter()
        .find_map(|p| std::fs::read_to_string(p).ok())
}

/// The paths named by the `// mirrors a::b::f, c::g` lines of WGSL `source` (the file
/// `file`), after asserting that there is at least one and that each names a Rust function
/// that exists: `fn f(` in the longest module prefix that is a file (the rest may be a type,
/// e.g. `patch::PatchTable::eval_weights`).
pub fn mirrored_functions(file: &str, source: &str) -> Vec<String> {
    let names: Vec<String> = source
        .lines()
        .filter_map(|l| l.trim().strip_prefix("// mirrors "))
        .flat_map(|l| l.split(','))
        .map(|s| s.trim().to_string())
        .collect();
    assert!(!names.is_empty(), "{file} names no mirrored function");
    for path in &names {
        let segments: Vec<&str> = path.split("::").collect();
        let (func, modules) = segments.split_last().unwrap();
        let src = (1..=modules.len())
            .rev()
            .find_map(|n| rust_file(&modules[..n]))
            .unwrap_or_else(|| panic!("{file}: no Rust module for {path}"));
        assert!(
            src.contains(&format!("fn {func}(")),
            "{file}: mirrors {path}, which does not exist"
        );
    }
    names
}

/// Every `.rs` file under `dir`, sorted.
pub fn rust_files(dir: &std::path::Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The tests' GPU: one context per test process, opened on first use (device creation is
/// slow on software drivers); the error, if any, is remembered.
#[cfg(feature = "gpu")]
pub fn shared_gpu() -> g1tess::Result<std::sync::Arc<g1tess::GpuContext>> {
    static SHARED: std::sync::OnceLock<Result<std::sync::Arc<g1tess::GpuContext>, String>> =
        std::sync::OnceLock::new();
    SHARED
        .get_or_init(|| {
            g1tess::GpuContext::new()
                .map(std::sync::Arc::new)
                .map_err(|e| e.to_string())
        })
        .clone()
        .map_err(g1tess::Error::Invalid)
}

/// The JSON a successful `g1tess ARGS` prints (the binary of this build, with a runtime
/// directory for the Vulkan loader); a failing run fails the test with its stderr.
#[cfg(feature = "cli")]
pub fn g1tess_json(args: &[&str]) -> serde_json::Value {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_g1tess"))
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "g1tess {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}
