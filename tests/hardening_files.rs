//! Files that must not be modified: temporary files whose names an attacker could predict
//! (`.NAME.tmp-PID` beside outputs, `g1tess-bench-PID.*` of `bench --end-to-end`) with a
//! symbolic link planted there, the mode of a replaced output, a 250-byte output name,
//! `render` over its own input, and an output over a glTF's external buffer. Expected
//! errors are printed with the prefix "expected error: ".

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

/// A tetrahedron with one normal per corner (what `tessellate` needs, nothing computed).
const TETRA: &str = "v 1 1 1\nv 1 -1 -1\nv -1 1 -1\nv -1 -1 1\n\
vn 1 1 1\nvn 1 -1 -1\nvn -1 1 -1\nvn -1 -1 1\n\
f 1//1 2//2 3//3\nf 1//1 4//4 2//2\nf 1//1 3//3 4//4\nf 2//2 4//4 3//3\n";

/// Links planted per name: the PID the child has and the next ones (a child that forked
/// again, or a run that took another PID, would meet them too).
const PIDS_PLANTED: u32 = 32;

fn bin_path() -> &'static str {
    env!("CARGO_BIN_EXE_g1tess")
}

fn bin() -> Command {
    let mut cmd = Command::new(bin_path());
    cmd.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    cmd
}

/// A fresh, empty folder for one test, with three folders in it: `input` (holding the
/// tetrahedron `tetra.obj`), `out` (the outputs) and `victims` (files outside the output's
/// folder that links point at, holding `victim`). Returns the folder, `out`, `victims` and
/// the mesh.
fn dirs(name: &str) -> (PathBuf, PathBuf, PathBuf, PathBuf) {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!(
        "g1tess-hardening-files-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&root);
    let (out, victims) = (root.join("out"), root.join("victims"));
    for d in [&out, &victims, &root.join("input")] {
        std::fs::create_dir_all(d).unwrap();
    }
    let mesh = root.join("input").join("tetra.obj");
    std::fs::write(&mesh, TETRA).unwrap();
    std::fs::write(victims.join("victim"), b"victim\n").unwrap();
    (root, out, victims, mesh)
}

/// Names in `d`, sorted.
fn listing(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// `g1tess ARGS` started held: a shell (`umask 022`) waits for a line on its standard
/// input, then `exec`s g1tess, which keeps the shell's PID. So the PID is known before
/// g1tess runs, and links can be planted at the names it would have used.
fn held(args: &[&str]) -> Child {
    Command::new("sh")
        .args(["-c", "umask 022; read go; exec \"$0\" \"$@\"", bin_path()])
        .args(args)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Lets a [`held`] child run, and waits for it.
fn release(mut child: Child) -> Output {
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(b"go\n").unwrap();
    drop(stdin);
    child.wait_with_output().unwrap()
}

fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "{:?}: {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Plants, for each name `name(pid)` of the PIDs `pid..pid + PIDS_PLANTED`, a symbolic
/// link in `dir`: the even ones to the existing `victim`, the odd ones to a file that
/// does not exist yet in `victims` (which writing through the link would create).
fn plant(dir: &Path, victims: &Path, pid: u32, name: impl Fn(u32) -> String) -> Vec<String> {
    let mut planted = Vec::new();
    for p in pid..pid + PIDS_PLANTED {
        let n = name(p);
        let to = if p % 2 == 0 {
            victims.join("victim")
        } else {
            victims.join(format!("new-{n}"))
        };
        std::os::unix::fs::symlink(&to, dir.join(&n)).unwrap();
        planted.push(n);
    }
    planted
}

/// Asserts that nothing outside `out` was written: `root` holds its three folders only,
/// `victims` the victim only, with its bytes.
fn assert_victims_untouched(root: &Path, victims: &Path) {
    assert_eq!(listing(root), ["input", "out", "victims"]);
    assert_eq!(
        listing(victims),
        ["victim"],
        "files created outside the output's folder"
    );
    let victim = std::fs::read(victims.join("victim")).unwrap();
    assert!(
        victim == b"victim\n",
        "the victim was overwritten with {} bytes",
        victim.len()
    );
}

/// Asserts a one-line refusal with exit status 1 containing every one of `needles`.
fn expect_error(out: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr).trim().to_string();
    assert_eq!(out.status.code(), Some(1), "{:?}: {stderr}", out.status);
    let lines: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(lines.len(), 1, "one error line: {stderr}");
    for n in needles {
        assert!(lines[0].contains(n), "{n:?} not in {stderr}");
    }
    eprintln!("expected error: {}", lines[0].trim_start_matches("error: "));
}

/// The bytes `g1tess ARGS -q -o NAME` writes in a clean folder of its own.
fn reference_output(root: &Path, args: &[&str], name: &str) -> Vec<u8> {
    let clean = root.join("clean");
    std::fs::create_dir_all(&clean).unwrap();
    let path = clean.join(name);
    let out = bin()
        .args(args)
        .arg("-q")
        .arg("-o")
        .arg(&path)
        .output()
        .unwrap();
    assert_success(&out);
    let bytes = std::fs::read(&path).unwrap();
    std::fs::remove_dir_all(&clean).unwrap();
    bytes
}

/// `tessellate MESH --level 3 --backend cpu`.
fn tessellate(mesh: &Path) -> [&str; 6] {
    let m = mesh.to_str().unwrap();
    ["tessellate", m, "--level", "3", "--backend", "cpu"]
}

/// Links planted at `.NAME.tmp-PID` for the child's PID and the next ones, pointing outside
/// the output's folder, are never followed: tessellate (OBJ, PLY through the piped
/// writer), export-net and export-msh write their outputs as regular files with the same
/// bytes as a clean run, the victim keeps its bytes, no file appears outside the output's
/// folder, and no temporary file is left.
#[test]
fn links_at_the_old_temporary_names_are_not_followed() {
    let (root, out, victims, mesh) = dirs("links");
    let m = mesh.to_str().unwrap();
    let runs: [(&str, Vec<&str>); 4] = [
        ("out.obj", tessellate(&mesh).to_vec()),
        ("out.ply", tessellate(&mesh).to_vec()),
        ("net.json", vec!["export-net", m]),
        ("out.msh", vec!["export-msh", m]),
    ];
    let mut planted = Vec::new();
    for (name, command) in &runs {
        let target = out.join(name);
        let mut args = command.clone();
        args.extend(["-q", "-o", target.to_str().unwrap()]);
        let child = held(&args);
        planted.extend(plant(&out, &victims, child.id(), |p| {
            format!(".{name}.tmp-{p}")
        }));
        let result = release(child);
        assert_success(&result);
        assert_victims_untouched(&root, &victims);
        let meta = std::fs::symlink_metadata(&target).unwrap();
        assert!(meta.file_type().is_file(), "{name} is not a regular file");
        let want = reference_output(&root, command, name);
        assert!(std::fs::read(&target).unwrap() == want, "{name} differs");
    }
    let mut want: Vec<String> = runs.iter().map(|r| r.0.to_string()).collect();
    want.extend(planted);
    want.sort();
    assert_eq!(
        listing(&out),
        want,
        "only the outputs and the planted links"
    );
    std::fs::remove_dir_all(&root).unwrap();
}

/// `bench --end-to-end` with links planted at `g1tess-bench-PID.{plain,piped,ply,obj}` in
/// its `--dir`: none is followed, nothing is written outside that folder, and the run
/// leaves nothing behind there.
#[test]
fn bench_end_to_end_does_not_follow_planted_links() {
    let (root, out, victims, _) = dirs("bench");
    let child = held(&[
        "bench",
        "sphere320",
        "--end-to-end",
        "--tess-level",
        "3",
        "--stats-level",
        "1",
        "--dir",
        out.to_str().unwrap(),
        "--json",
        "--quiet",
    ]);
    let mut planted = Vec::new();
    for ext in ["plain", "piped", "ply", "obj"] {
        planted.extend(plant(&out, &victims, child.id(), |p| {
            format!("g1tess-bench-{p}.{ext}")
        }));
    }
    let result = release(child);
    assert_success(&result);
    let report: serde_json::Value = serde_json::from_slice(&result.stdout).unwrap();
    assert_eq!(report["triangles"], 320);
    assert_victims_untouched(&root, &victims);
    planted.sort();
    assert_eq!(listing(&out), planted, "only the planted links are left");
    std::fs::remove_dir_all(&root).unwrap();
}

/// A replaced output keeps its permission bits (0600 and 0640 stay so, through a link
/// too); a new one gets the default of the umask the shell set (022: 0644).
#[test]
fn a_replaced_output_keeps_its_mode() {
    use std::os::unix::fs::PermissionsExt;
    let (root, out, _, mesh) = dirs("mode");
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o7777;
    let want = reference_output(&root, &tessellate(&mesh), "m.obj");
    for (bits, via_link) in [(0o600, false), (0o640, false), (0o600, true)] {
        let target = out.join(format!("m{bits:o}{via_link}.obj"));
        std::fs::write(&target, b"old").unwrap();
        std::fs::set_permissions(&target, std::fs::Permissions::from_mode(bits)).unwrap();
        let named = if via_link {
            let link = out.join("link.obj");
            let _ = std::fs::remove_file(&link);
            std::os::unix::fs::symlink(&target, &link).unwrap();
            link
        } else {
            target.clone()
        };
        let child = held(&[
            "tessellate",
            mesh.to_str().unwrap(),
            "--level",
            "3",
            "--backend",
            "cpu",
            "-q",
            "-o",
            named.to_str().unwrap(),
        ]);
        assert_success(&release(child));
        assert_eq!(mode(&target), bits, "{}", target.display());
        assert!(std::fs::read(&target).unwrap() == want);
    }
    let fresh = out.join("fresh.obj");
    let child = held(&[
        "tessellate",
        mesh.to_str().unwrap(),
        "--level",
        "3",
        "--backend",
        "cpu",
        "-q",
        "-o",
        fresh.to_str().unwrap(),
    ]);
    assert_success(&release(child));
    assert_eq!(mode(&fresh), 0o644, "0666 less the umask 022");
    std::fs::remove_dir_all(&root).unwrap();
}

/// A legal 250-byte output name (255 bytes is the limit of common file systems) is written,
/// with the bytes of a short name's output, and its temporary file is gone.
#[test]
fn a_250_byte_output_name_is_written() {
    let (root, out, _, mesh) = dirs("long-name");
    for ext in ["obj", "ply"] {
        let name = format!("{}.{ext}", "n".repeat(250 - 1 - ext.len()));
        assert_eq!(name.len(), 250);
        let target = out.join(&name);
        let result = bin()
            .args([
                "tessellate",
                mesh.to_str().unwrap(),
                "--level",
                "3",
                "--backend",
                "cpu",
                "-q",
                "-o",
            ])
            .arg(&target)
            .output()
            .unwrap();
        assert_success(&result);
        let want = reference_output(&root, &tessellate(&mesh), &format!("short.{ext}"));
        assert!(std::fs::read(&target).unwrap() == want, "{ext} differs");
    }
    assert_eq!(listing(&out).len(), 2, "{:?}", listing(&out));
    std::fs::remove_dir_all(&root).unwrap();
}

/// `render m.png -o m.png` (an OBJ named `.png`) is refused as the other commands refuse
/// writing over their input, directly and through a link either way, before any GPU work;
/// the input keeps its bytes.
#[test]
fn render_refuses_to_overwrite_its_input() {
    let (root, out, _, _) = dirs("render");
    let mesh = out.join("m.png");
    std::fs::write(&mesh, TETRA).unwrap();
    let link = out.join("link.png");
    std::os::unix::fs::symlink("m.png", &link).unwrap();
    let (m, l) = (mesh.to_str().unwrap(), link.to_str().unwrap());
    for (input, output) in [(m, m), (m, l), (l, m)] {
        let result = bin()
            .args(["render", input, "-o", output, "--size", "16"])
            .output()
            .unwrap();
        expect_error(
            &result,
            &["is the input", "refusing to overwrite the input"],
        );
        assert_eq!(std::fs::read_to_string(&mesh).unwrap(), TETRA);
    }
    assert_eq!(listing(&out), ["link.png", "m.png"]);
    std::fs::remove_dir_all(&root).unwrap();
}

/// `tessellate scene.gltf -o scene_buf.bin --format glb` is refused: the glTF's external
/// buffer is an input too (by its name, through a link, or a hard link); the buffer keeps
/// its bytes, and the same scene tessellates into another name.
#[test]
fn an_output_over_a_gltf_buffer_is_refused() {
    let (root, out, _, _) = dirs("gltf-buffer");
    // The tetrahedron: 4 positions (48 bytes), then 12 u16 indices (24 bytes).
    let p: [[f32; 3]; 4] = [[1., 1., 1.], [1., -1., -1.], [-1., 1., -1.], [-1., -1., 1.]];
    let mut buf: Vec<u8> = p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    for i in [0u16, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2] {
        buf.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(out.join("scene_buf.bin"), &buf).unwrap();
    let gltf = format!(
        r#"{{"asset":{{"version":"2.0"}},
        "buffers":[{{"uri":"scene_buf.bin","byteLength":{}}}],
        "bufferViews":[{{"buffer":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":24}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3",
                       "min":[-1,-1,-1],"max":[1,1,1]}},
                     {{"bufferView":1,"componentType":5123,"count":12,"type":"SCALAR"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#,
        buf.len()
    );
    let scene = out.join("scene.gltf");
    std::fs::write(&scene, gltf).unwrap();
    std::os::unix::fs::symlink("scene_buf.bin", out.join("link.glb")).unwrap();
    std::fs::hard_link(out.join("scene_buf.bin"), out.join("hard.glb")).unwrap();
    let tessellate = |output: &str, format: &[&str]| {
        bin()
            .args(["tessellate", scene.to_str().unwrap(), "--level", "2", "-q"])
            .args(["--backend", "cpu", "-o"])
            .arg(out.join(output))
            .args(format)
            .output()
            .unwrap()
    };
    for output in ["scene_buf.bin", "link.glb", "hard.glb"] {
        let format: &[&str] = if output.ends_with(".bin") {
            &["--format", "glb"]
        } else {
            &[]
        };
        let result = tessellate(output, format);
        expect_error(
            &result,
            &["is the buffer file", "scene_buf.bin", "scene.gltf"],
        );
        assert!(std::fs::read(out.join("scene_buf.bin")).unwrap() == buf);
    }
    assert_success(&tessellate("other.glb", &[]));
    assert!(std::fs::read(out.join("other.glb"))
        .unwrap()
        .starts_with(b"glTF"));
    std::fs::remove_dir_all(&root).unwrap();
}

/// A directory squatting on the old temporary name `.pre.obj.tmp-PID` (and the next PIDs')
/// is no obstacle: the output is written. Where the output's folder is missing, the
/// one-line error names the output path, as it did before (no random name in it).
#[test]
fn a_squatting_directory_is_no_obstacle_and_errors_name_the_temporary_file() {
    let (root, out, _, mesh) = dirs("squat");
    let target = out.join("pre.obj");
    let mut args = tessellate(&mesh).to_vec();
    args.extend(["-q", "-o", target.to_str().unwrap()]);
    let child = held(&args);
    for p in child.id()..child.id() + PIDS_PLANTED {
        std::fs::create_dir(out.join(format!(".pre.obj.tmp-{p}"))).unwrap();
    }
    assert_success(&release(child));
    assert!(
        std::fs::read(&target).unwrap() == reference_output(&root, &tessellate(&mesh), "pre.obj")
    );
    assert_eq!(listing(&out).len(), 1 + PIDS_PLANTED as usize);
    let missing = out.join("missing").join("pre.obj");
    let mut args = tessellate(&mesh).to_vec();
    args.extend(["-q", "-o", missing.to_str().unwrap()]);
    let result = bin().args(&args).output().unwrap();
    expect_error(&result, &["missing/pre.obj: No such file or directory"]);
    assert!(!String::from_utf8_lossy(&result.stderr).contains(".tmp"));
    std::fs::remove_dir_all(&root).unwrap();
}
