"""Integration test of the g1tess Blender add-on in real (headless) Blender: the `bpy`
module from PyPI. Run by scripts/blender_test.sh:

    python blender/tests/test_roundtrip.py path/to/g1tess

It installs the add-on the way a user does (a zip through Blender's "Install from Disk"
operator, into a throw-away user folder), then round-trips an icosphere, a torus and a
subdivided Suzanne (no UV layers: sent as .pn) and a UV sphere and a cube (UV-mapped: sent as
OBJ with their UVs) through the add-on's operators and checks the results against the files
and against `g1tess stats`. Prints `blender: N passed, M failed` and exits non-zero when
anything failed.
"""

import ast
import json
import os
import shutil
import subprocess
import sys
import tempfile
import tomllib
import traceback
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ADDON_DIR = os.path.join(ROOT, "blender", "g1tess_blender")
BINARY = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "target/release/g1tess")
WORK = tempfile.mkdtemp(prefix="g1tess-blender-test-")
# Blender reads its user folder at start-up: keep the real one untouched.
os.environ["BLENDER_USER_RESOURCES"] = os.path.join(WORK, "user")

import bpy  # noqa: E402  (first: it makes bmesh and mathutils importable)
import bmesh  # noqa: E402
import numpy as np  # noqa: E402
from mathutils import Vector  # noqa: E402

LEVEL = 8
G1_LIMIT = 1e-12
# Blender 4.x stores custom normals as two 16-bit angles in each corner's normal space;
# the measured round-trip error on these meshes is at most 1.2e-3 per component (median
# 1e-5). A normal put on the wrong corner would be off by 1e-1 or more.
CUSTOM_NORMAL_TOL = 2e-3

RESULTS = []
STATE = {}


def check(name):
    def run(fn):
        try:
            fn()
        except Exception as e:  # a failed check is reported, the others still run
            RESULTS.append((name, False))
            print("FAIL %s: %s" % (name, e))
            traceback.print_exc(limit=3, file=sys.stdout)
        else:
            RESULTS.append((name, True))
            print("ok   %s" % name)
        return fn

    return run


def g1tess(*args):
    done = subprocess.run([BINARY, *args], capture_output=True, text=True)
    if done.returncode != 0:
        raise AssertionError("g1tess %s failed: %s" % (" ".join(args), done.stderr.strip()))
    return done.stdout


def stats(path):
    return json.loads(g1tess("stats", path, "--json"))


def read_pn(path):
    """Independent reader of the add-on's .pn files (the format of the README)."""
    with open(path, encoding="utf-8") as f:
        lines = [line.split("#")[0].split() for line in f]
    assert lines[0] == ["g1tess-pn", "1"], lines[0]
    body = [ln for ln in lines[1:] if ln]
    assert body[0][0] == "counts"
    nv, nt, nc = map(int, body[0][1:])
    v = np.array([[float(x) for x in ln[1:]] for ln in body if ln[0] == "v"]).reshape(-1, 6)
    t = np.array([[int(x) for x in ln[1:]] for ln in body if ln[0] == "t"]).reshape(-1, 3)
    c = [(int(ln[1]), int(ln[2]), [float(x) for x in ln[3:]]) for ln in body if ln[0] == "c"]
    assert (len(v), len(t), len(c)) == (nv, nt, nc), "counts line does not match the records"
    return v[:, :3], v[:, 3:], t, c


def read_obj(path):
    """Independent reader of g1tess's OBJ output: v, vn, f a//n b//n c//n."""
    v, vn, f, fn = [], [], [], []
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                v.append([float(x) for x in p[1:4]])
            elif p[0] == "vn":
                vn.append([float(x) for x in p[1:4]])
            elif p[0] == "f":
                assert len(p) == 4, "g1tess writes triangles"
                f.append([int(c.split("/")[0]) - 1 for c in p[1:]])
                fn.append([int(c.split("/")[2]) - 1 for c in p[1:]])
    vn = np.array(vn)
    return np.array(v), vn / np.linalg.norm(vn, axis=1)[:, None], np.array(f), np.array(fn)


def mesh_array(collection, attr, n, width, dtype=np.float32):
    out = np.empty(n * width, dtype=dtype)
    collection.foreach_get(attr, out)
    return out.reshape(-1, width) if width > 1 else out


def clear_scene():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for me in list(bpy.data.meshes):
        bpy.data.meshes.remove(me)


def activate(obj):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj


def triangulate(obj):
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.triangulate(bm, faces=bm.faces)
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()


def make_icosphere():
    # No UV layer: G1 Smooth sends such meshes as .pn (meshes with UVs go as OBJ).
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, calc_uvs=False)
    return bpy.context.active_object


def make_torus():
    bpy.ops.mesh.primitive_torus_add(major_segments=10, minor_segments=10, generate_uvs=False)
    obj = bpy.context.active_object
    triangulate(obj)
    return obj


def make_suzanne():
    bpy.ops.mesh.primitive_monkey_add(calc_uvs=False)
    obj = bpy.context.active_object
    mod = obj.modifiers.new("Subdivision", "SUBSURF")
    mod.levels = 1
    bpy.ops.object.modifier_apply(modifier=mod.name)
    triangulate(obj)
    return obj


def set_binary(path):
    STATE["prefs"].binary_path = path


# ---------------------------------------------------------------------------------------


@check("add-on installs from a zip through Install from Disk and registers its operators")
def install():
    zpath = os.path.join(WORK, "g1tess_blender.zip")
    with zipfile.ZipFile(zpath, "w") as z:
        for name in sorted(os.listdir(ADDON_DIR)):
            if name.endswith((".py", ".toml")):
                z.write(os.path.join(ADDON_DIR, name), "g1tess_blender/" + name)
    # What Edit > Preferences > Add-ons > Install from Disk... runs in Blender 4.2+.
    r = bpy.ops.extensions.package_install_files(
        filepath=zpath, repo="user_default", enable_on_install=True
    )
    assert r == {"FINISHED"}, r
    names = [a.module for a in bpy.context.preferences.addons if a.module.endswith("g1tess_blender")]
    assert len(names) == 1, names
    STATE["prefs"] = bpy.context.preferences.addons[names[0]].preferences
    set_binary(BINARY)
    assert hasattr(bpy.types, "EXPORT_MESH_OT_g1tess_pn")
    assert hasattr(bpy.types, "OBJECT_OT_g1tess_smooth")
    export_items = [f.__name__ for f in bpy.types.TOPBAR_MT_file_export._dyn_ui_initialize()]
    object_items = [f.__name__ for f in bpy.types.VIEW3D_MT_object._dyn_ui_initialize()]
    assert "menu_export" in export_items and "menu_object" in object_items


@check("manifest validates with Blender's extension tool and matches bl_info")
def manifest():
    tool = os.path.join(bpy.utils.system_resource("SCRIPTS"), "addons_core", "bl_pkg", "cli", "blender_ext.py")
    done = subprocess.run([sys.executable, tool, "validate", ADDON_DIR], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    with open(os.path.join(ADDON_DIR, "blender_manifest.toml"), "rb") as f:
        m = tomllib.load(f)
    # Blender drops bl_info from add-ons installed as extensions: read it from the source.
    with open(os.path.join(ADDON_DIR, "__init__.py"), encoding="utf-8") as f:
        tree = ast.parse(f.read())
    info = next(
        ast.literal_eval(node.value)
        for node in tree.body
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "bl_info"
    )
    assert m["version"] == ".".join(map(str, info["version"])), (m["version"], info["version"])
    assert m["blender_version_min"] == ".".join(map(str, info["blender"]))


def round_trip(label, make, triangles_in):
    """G1 Smooth at level 8 through the add-on; checks counts, positions, normals and the
    continuity of the exported point-normal data."""
    clear_scene()
    obj = make()
    me = obj.data
    assert len(me.polygons) == triangles_in, "%s has %d faces" % (label, len(me.polygons))
    assert all(len(p.vertices) == 3 for p in me.polygons)
    nv, ne = len(me.vertices), len(me.edges)
    co = mesh_array(me.vertices, "co", nv, 3)
    keep = os.path.join(WORK, label)
    activate(obj)
    r = bpy.ops.object.g1tess_smooth(scheme="g1", level=LEVEL, keep_dir=keep)
    assert r == {"FINISHED"}, r
    new = bpy.context.active_object
    assert new is not obj and new.name == obj.name + ".g1", new.name
    info = new["g1tess"]
    nme = new.data

    # Counts: what g1tess reported, and what level 8 must give.
    assert len(nme.vertices) == info["vertices"], (len(nme.vertices), info["vertices"])
    assert len(nme.polygons) == info["triangles"], (len(nme.polygons), info["triangles"])
    assert all(len(p.vertices) == 3 for p in nme.polygons)
    assert info["triangles"] == triangles_in * LEVEL**2, info["triangles"]
    per_patch = triangles_in * (LEVEL + 1) * (LEVEL + 2) // 2
    welded = nv + ne * (LEVEL - 1) + triangles_in * (LEVEL - 1) * (LEVEL - 2) // 2
    assert info["vertices"] == welded, (info["vertices"], welded, per_patch)
    layout = "welded"

    # Positions and triangles are those of the g1tess file (Blender keeps f32).
    pos, nrm, faces, face_n = read_obj(info["output"])
    bco = mesh_array(nme.vertices, "co", len(nme.vertices), 3)
    assert np.array_equal(bco, pos.astype(np.float32)), "positions differ from the file"
    assert np.abs(bco - pos).max() <= 1e-7 * max(1.0, np.abs(pos).max())
    loops = mesh_array(nme.loops, "vertex_index", len(nme.loops), 1, np.int32).reshape(-1, 3)
    assert np.array_equal(loops, faces), "triangles differ from the file"

    # Shaded smooth with the file's normals as custom normals.
    assert nme.has_custom_normals
    assert all(p.use_smooth for p in nme.polygons)
    cn = mesh_array(nme.corner_normals, "vector", len(nme.loops), 3).astype(np.float64)
    err = np.abs(cn - nrm[face_n.ravel()]).max()
    assert err <= CUSTOM_NORMAL_TOL, "custom normals off by %g" % err

    # Beside the original.
    shift = new.matrix_world.translation.x - obj.matrix_world.translation.x
    xs = [(obj.matrix_world @ Vector(c)).x for c in obj.bound_box]
    assert abs(shift - 1.25 * (max(xs) - min(xs))) < 1e-5, shift

    # The exported point-normal file: Blender's f32 coordinates exactly, and G1.
    ppos, pnrm, ptri, pc = read_pn(info["input"])
    assert np.array_equal(ppos, co.astype(np.float64)), "exported positions are not exact"
    assert len(ptri) == triangles_in and not pc
    assert np.abs(np.linalg.norm(pnrm, axis=1) - 1).max() < 1e-15
    s = stats(info["input"])
    assert s["triangles"] == triangles_in and s["vertices"] == nv, (s["triangles"], s["vertices"])
    one_minus = 1 - s["cos"]["min"]
    print(
        "     %s: %d -> %d vertices (%s), %d triangles; stats: 1 - min cos = %.3e, "
        "max 1 - |cos| = %.3e, max gap = %.3e, custom normal error %.1e, interior %d, "
        "boundary %d, non-manifold %d, misoriented %d"
        % (
            label, nv, info["vertices"], layout, info["triangles"], one_minus,
            s["max_one_minus_abs_cos"], s["max_gap"], err, s["interior_edges"],
            s["boundary_edges"], s["nonmanifold_edges"], s["misoriented_edges"],
        )
    )
    assert s["misoriented_edges"] == 0 and s["folded"] == 0
    assert one_minus <= G1_LIMIT, "1 - min cos = %g" % one_minus
    assert s["max_gap"] <= 1e-12 * s["diagonal"], s["max_gap"]
    return obj, s


@check("icosphere (subdivisions 3, 320 triangles): G1 Smooth round trip at level 8")
def icosphere():
    round_trip("icosphere", make_icosphere, 320)


@check("torus 10 x 10 (200 triangles): G1 Smooth round trip at level 8")
def torus():
    round_trip("torus", make_torus, 200)


@check("Suzanne, one subdivision level, triangulated: G1 Smooth round trip at level 8")
def suzanne():
    _, s = round_trip("suzanne", make_suzanne, 3936)
    # Blender's Suzanne is open (eye holes and the separate eyes have boundaries).
    assert s["boundary_edges"] > 0 and s["nonmanifold_edges"] == 0


@check("G1 Smooth with Detail = Tolerance: per-edge levels within the measured tolerance")
def tolerance_detail():
    clear_scene()
    obj = make_icosphere()
    activate(obj)
    keep = os.path.join(WORK, "tolerance")
    r = bpy.ops.object.g1tess_smooth(
        scheme="g1", detail="TOLERANCE", tolerance=1e-3, max_level=16, keep_dir=keep
    )
    assert r == {"FINISHED"}, r
    new = bpy.context.active_object
    info = new["g1tess"]
    # What g1tess measured (10 points in every output triangle) is within what was asked.
    assert info["adaptive_tolerance_met"]
    assert info["adaptive_max_deviation"] <= info["adaptive_tolerance"]
    assert info["adaptive_measured_triangles"] == info["triangles"]
    # The tolerance is relative to the diagonal of the exported mesh's bounding box.
    ppos, _, _, _ = read_pn(info["input"])
    diagonal = float(np.linalg.norm(ppos.max(axis=0) - ppos.min(axis=0)))
    # Blender's FloatProperty holds single precision: the add-on passes 1e-3 as the f32
    # nearest to it (0.0010000000474974513), which g1tess multiplies by the diagonal in f64.
    rel = float(np.float32(1e-3))
    assert abs(info["adaptive_tolerance"] - rel * diagonal) <= 1e-12 * diagonal
    # The object is the file, and the file has the reported counts.
    pos, _, faces, _ = read_obj(info["output"])
    assert len(faces) == info["triangles"] == len(new.data.polygons)
    assert len(pos) == info["vertices"] == len(new.data.vertices)
    # Fewer triangles than level 8 gives.
    assert info["triangles"] < 320 * LEVEL**2, info["triangles"]


@check("Blender's own OBJ export of the torus (4-decimal normals) is G1 in g1tess")
def blender_obj_export():
    clear_scene()
    obj = make_torus()
    obj.data.shade_smooth()
    activate(obj)
    path = os.path.join(WORK, "torus-blender.obj")
    r = bpy.ops.wm.obj_export(
        filepath=path, export_selected_objects=True, export_normals=True, export_uv=False,
        export_materials=False,
    )
    assert r == {"FINISHED"}, r
    with open(path) as f:
        vn = [line.split()[1:] for line in f if line.startswith("vn ")]
    assert vn and all(len(x.split(".")[-1]) <= 4 for n in vn for x in n), "not 4 decimals"
    length = np.linalg.norm(np.array(vn, dtype=np.float64), axis=1)
    assert np.abs(length - 1).max() > 1e-6, "normals unexpectedly unit"  # renormalising matters
    s = stats(path)
    one_minus = 1 - s["cos"]["min"]
    print(
        "     Blender OBJ torus: %d vn lines, max ||n| - 1| = %.2e; stats: %d triangles, "
        "1 - min cos = %.3e" % (len(vn), np.abs(length - 1).max(), s["triangles"], one_minus)
    )
    assert s["triangles"] == 200 and s["vertices"] == 100
    assert one_minus <= G1_LIMIT, one_minus


@check("export operator: world space, mirroring transform keeps the orientation")
def world_space():
    clear_scene()
    obj = make_torus()
    obj.location = (0.5, -2.0, 3.0)
    obj.rotation_euler = (0.3, -0.7, 1.1)
    obj.scale = (1.5, -0.5, 2.0)  # non-uniform, mirroring
    bpy.context.view_layer.update()
    activate(obj)
    path = os.path.join(WORK, "torus-world.pn")
    r = bpy.ops.export_mesh.g1tess_pn(filepath=path, use_world_space=True)
    assert r == {"FINISHED"}, r
    pos, nrm, tri, c = read_pn(path)
    mw = obj.matrix_world
    nmat = mw.to_3x3().inverted().transposed()
    want_p = np.array([list(mw @ v.co) for v in obj.data.vertices])
    want_n = np.array([list((nmat @ v.normal).normalized()) for v in obj.data.vertices])
    assert np.abs(pos - want_p).max() < 1e-5, np.abs(pos - want_p).max()
    assert np.abs(nrm - want_n).max() < 1e-5, np.abs(nrm - want_n).max()
    # Counter-clockwise seen from the normals' side: face normal · vertex normals > 0.
    a, b, cc = pos[tri[:, 0]], pos[tri[:, 1]], pos[tri[:, 2]]
    fn = np.cross(b - a, cc - a)
    assert (np.einsum("ij,ij->i", fn, nrm[tri].sum(axis=1)) > 0).all(), "flipped triangles"
    s = stats(path)
    assert s["misoriented_edges"] == 0 and 1 - s["cos"]["min"] <= G1_LIMIT, s["cos"]
    # Local space writes the mesh's own coordinates.
    r = bpy.ops.export_mesh.g1tess_pn(filepath=path, use_world_space=False)
    pos, _, _, _ = read_pn(path)
    co = mesh_array(obj.data.vertices, "co", len(obj.data.vertices), 3)
    assert np.array_equal(pos, co.astype(np.float64)), "local-space positions are not exact"


@check("export operator: sharp edges and flat faces give per-corner normals")
def corner_normals():
    clear_scene()
    bpy.ops.mesh.primitive_cube_add()
    obj = bpy.context.active_object
    me = obj.data
    me.shade_smooth()
    attr = me.attributes.new("sharp_edge", "BOOLEAN", "EDGE")
    attr.data.foreach_set("value", [True] * len(me.edges))
    me.update()
    activate(obj)
    path = os.path.join(WORK, "cube.pn")
    counts = {}
    for mode in ("AUTO", "VERTEX"):
        assert bpy.ops.export_mesh.g1tess_pn(filepath=path, normals=mode) == {"FINISHED"}
        pos, nrm, tri, c = read_pn(path)
        counts[mode] = len(c)
        # Vertex normals of a cube: the diagonals.
        assert np.abs(np.abs(nrm) - 1 / np.sqrt(3)).max() < 1e-6
    assert counts == {"AUTO": 36, "VERTEX": 0}, counts
    bpy.ops.export_mesh.g1tess_pn(filepath=path, normals="AUTO")
    pos, nrm, tri, c = read_pn(path)
    for t, k, n in c:  # every corner carries its face's normal
        p = pos[tri[t]]
        f = np.cross(p[1] - p[0], p[2] - p[0])
        assert np.abs(np.array(n) - f / np.linalg.norm(f)).max() < 1e-6
    s = stats(path)
    assert s["triangles"] == 12 and s["vertices"] == 8
    # Flat-shaded icosphere: AUTO ignores flat shading, CORNER keeps it (face normals).
    clear_scene()
    obj = make_icosphere()
    activate(obj)
    for mode, want in (("AUTO", 0), ("CORNER", 960)):
        bpy.ops.export_mesh.g1tess_pn(filepath=path, normals=mode)
        assert len(read_pn(path)[3]) == want, (mode, len(read_pn(path)[3]))


@check("export operator: custom normals become the exported vertex normals")
def custom_normals():
    clear_scene()
    obj = make_torus()
    me = obj.data
    me.shade_smooth()
    vn = mesh_array(me.vertices, "normal", len(me.vertices), 3).astype(np.float64)
    tilted = vn + np.array([0.4, 0.0, 0.0])
    tilted /= np.linalg.norm(tilted, axis=1)[:, None]
    me.normals_split_custom_set_from_vertices(tilted.tolist())
    activate(obj)
    path = os.path.join(WORK, "torus-custom.pn")
    assert bpy.ops.export_mesh.g1tess_pn(filepath=path) == {"FINISHED"}
    pos, nrm, tri, c = read_pn(path)
    assert not c, "one custom normal per vertex: no corner records"
    assert np.abs(nrm - tilted).max() < CUSTOM_NORMAL_TOL, np.abs(nrm - tilted).max()
    assert np.abs(nrm - vn).max() > 0.1
    s = stats(path)
    assert 1 - s["cos"]["min"] <= G1_LIMIT, s["cos"]


@check("G1 Smooth reports a missing binary and a failing binary, and adds nothing")
def errors():
    clear_scene()
    obj = make_icosphere()
    activate(obj)
    n_objects = len(bpy.data.objects)
    fake = os.path.join(WORK, "fake-g1tess")
    with open(fake, "w") as f:
        f.write("#!/bin/sh\necho 'error: mesh.pn:3: boom' >&2\nexit 3\n")
    os.chmod(fake, 0o755)
    cases = [
        (os.path.join(WORK, "no-such-g1tess"), "g1tess binary not found at"),
        (fake, "g1tess failed (exit 3): error: mesh.pn:3: boom"),
    ]
    try:
        for path, want in cases:
            set_binary(path)
            try:
                bpy.ops.object.g1tess_smooth(level=2)
            except RuntimeError as e:
                assert want in str(e), str(e)
            else:
                raise AssertionError("no error for %s" % path)
            assert len(bpy.data.objects) == n_objects
    finally:
        set_binary(BINARY)
    # A mesh without faces cannot be exported.
    me = bpy.data.meshes.new("points")
    me.from_pydata([(0, 0, 0), (1, 0, 0)], [], [])
    pts = bpy.data.objects.new("points", me)
    bpy.context.scene.collection.objects.link(pts)
    activate(pts)
    try:
        bpy.ops.export_mesh.g1tess_pn(filepath=os.path.join(WORK, "points.pn"))
    except RuntimeError as e:
        assert "has no faces" in str(e), str(e)
    else:
        raise AssertionError("no error for a mesh without faces")


def smooth_with_fake_output(name, obj_text):
    """Runs G1 Smooth on an icosphere through a stand-in for g1tess that writes `obj_text`
    as its output (4 vertices, 2 triangles), and returns the imported mesh data."""
    fake = os.path.join(WORK, name)
    with open(fake, "w") as f:
        f.write(
            "#!%s\nimport json, sys\nout = sys.argv[sys.argv.index('-o') + 1]\n"
            "open(out, 'w').write(%r)\n"
            "print(json.dumps({'output': out, 'vertices': 4, 'triangles': 2}))\n"
            % (sys.executable, obj_text)
        )
    os.chmod(fake, 0o755)
    clear_scene()
    obj = make_icosphere()
    activate(obj)
    set_binary(fake)
    try:
        assert bpy.ops.object.g1tess_smooth(level=2) == {"FINISHED"}
    finally:
        set_binary(BINARY)
    me = bpy.context.active_object.data
    assert (len(me.vertices), len(me.polygons)) == (4, 2)
    return me


@check("G1 Smooth imports split normals (welded output with a crease) per corner")
def split_normals_import():
    # A stand-in for g1tess that writes a welded square folded along its diagonal, with
    # one normal per face (the crease splits the normals of vertices 1 and 3).
    s = 1 / np.sqrt(2)
    obj_text = (
        "v 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0\n"
        "vn 0 0 1\nvn %r 0 %r\nvn 0 0 2\n"
        "f 1//1 2//1 3//2\nf 1//1 3//3 4//1\n" % (s, s)
    )
    me = smooth_with_fake_output("fake-welded-g1tess", obj_text)
    cn = mesh_array(me.corner_normals, "vector", len(me.loops), 3)
    want = np.array([[0, 0, 1], [0, 0, 1], [s, 0, s], [0, 0, 1], [0, 0, 1], [0, 0, 1]])
    assert np.abs(cn - want).max() < CUSTOM_NORMAL_TOL, cn


@check("G1 Smooth imports the output's texture coordinates as the UV map")
def uv_import():
    # A stand-in for g1tess that writes a welded square whose two triangles have their own
    # texture coordinates at the shared vertices 1 and 3 (a UV seam along the diagonal).
    obj_text = (
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\n"
        "vt 0 0\nvt 0.5 0\nvt 0.5 0.5\nvt 0.625 0.125\nvt 1 0.5\nvt 0.625 0.625\n"
        "f 1/1/1 2/2/1 3/3/1\nf 1/4/1 3/5/1 4/6/1\n"
    )
    me = smooth_with_fake_output("fake-uv-g1tess", obj_text)
    assert [layer.name for layer in me.uv_layers] == ["UVMap"]
    uv = mesh_array(me.uv_layers["UVMap"].data, "uv", len(me.loops), 2)
    want = np.array([[0, 0], [0.5, 0], [0.5, 0.5], [0.625, 0.125], [1, 0.5], [0.625, 0.625]])
    # Exact: every value is a short binary fraction, stored as f32.
    assert np.array_equal(uv, want.astype(np.float32)), uv

def read_obj_input(path):
    """Independent reader of the OBJ input the add-on writes for meshes with UVs:
    v, vn, vt and f v/vt/vn (1-based)."""
    v, vn, vt, f = [], [], [], []
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            p = line.split("#")[0].split()
            if not p:
                continue
            rows = {"v": v, "vn": vn, "vt": vt}
            if p[0] in rows:
                rows[p[0]].append([float(x) for x in p[1:]])
            else:
                assert p[0] == "f" and len(p) == 4, line
                f.append([[int(x) - 1 for x in c.split("/")] for c in p[1:]])
    return np.array(v), np.array(vn), np.array(vt), np.array(f, dtype=np.int64)


def triangle_uvs(me):
    """(T, 3) vertex ids and (T, 3, 2) f32 UVs of the active layer at the corners of the
    mesh's loop triangles (the add-on's triangle order)."""
    me.calc_loop_triangles()
    nt = len(me.loop_triangles)
    tri = mesh_array(me.loop_triangles, "vertices", nt, 3, np.int32)
    loops = mesh_array(me.loop_triangles, "loops", nt, 3, np.int32)
    uv = mesh_array(me.uv_layers.active.data, "uv", len(me.loops), 2)
    return tri, uv[loops]


UV_LEVEL = 3


@check("G1 Smooth carries a UV sphere's UVs (seam, poles) through g1tess at level 3")
def uv_round_trip():
    clear_scene()
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, calc_uvs=True)
    obj = bpy.context.active_object
    triangulate(obj)  # bmesh keeps the UV layer
    me = obj.data
    nv, ne, nt = len(me.vertices), len(me.edges), len(me.polygons)
    assert (nv, nt) == (16 * 7 + 2, 16 * 6 * 2 + 2 * 16), (nv, nt)
    co = mesh_array(me.vertices, "co", nv, 3)
    tri, tuv = triangle_uvs(me)
    assert (tuv >= 0).all() and (tuv <= 1).all()
    activate(obj)
    r = bpy.ops.object.g1tess_smooth(scheme="g1", level=UV_LEVEL, keep_dir=os.path.join(WORK, "uv"))
    assert r == {"FINISHED"}, r
    new = bpy.context.active_object
    info = new["g1tess"]
    nme = new.data

    # The input went as OBJ: Blender's f32 positions and UVs exactly, one vt per loop.
    assert info["input"].endswith(".obj"), info["input"]
    pv, pvn, pvt, pf = read_obj_input(info["input"])
    assert np.array_equal(pv, co.astype(np.float64)), "exported positions are not exact"
    assert len(pvt) == len(me.loops) and len(pf) == nt
    assert np.array_equal(pf[:, :, 0], tri), "exported triangles differ"
    assert np.array_equal(pvt[pf[:, :, 1]], tuv.astype(np.float64)), "exported UVs not exact"
    assert np.abs(np.linalg.norm(pvn, axis=1) - 1).max() < 1e-15
    # The same normals as the .pn export: g1tess measures the same surface from both.
    pn = os.path.join(WORK, "uv-sphere.pn")
    activate(obj)
    assert bpy.ops.export_mesh.g1tess_pn(filepath=pn, use_world_space=False) == {"FINISHED"}
    ppos, pnrm, ptri, pc = read_pn(pn)
    want_n = pnrm[ptri]
    for t, k, n in pc:
        want_n[t, k] = n
    assert np.array_equal(ppos, pv) and np.array_equal(ptri, pf[:, :, 0])
    assert np.array_equal(pvn[pf[:, :, 2]], want_n), "corner normals differ from the .pn"
    s_obj, s_pn = stats(info["input"]), stats(pn)
    for key in ("vertices", "triangles", "interior_edges", "boundary_edges"):
        assert s_obj[key] == s_pn[key], (key, s_obj[key], s_pn[key])
    # g1tess renormalises OBJ normals (the .pn's are taken as written): an ulp apart.
    for a, b in ((s_obj["cos"]["min"], s_pn["cos"]["min"]), (s_obj["max_gap"], s_pn["max_gap"])):
        assert abs(a - b) <= 1e-15, (a, b)
    assert 1 - s_obj["cos"]["min"] <= G1_LIMIT, s_obj["cos"]

    # Watertight by position: one output vertex per welded sample, seams included.
    welded = nv + ne * (UV_LEVEL - 1) + nt * (UV_LEVEL - 1) * (UV_LEVEL - 2) // 2
    assert len(nme.vertices) == info["vertices"] == welded, (len(nme.vertices), welded)
    assert len(nme.polygons) == info["triangles"] == nt * UV_LEVEL**2
    assert [layer.name for layer in nme.uv_layers] == ["UVMap"]
    nco = mesh_array(nme.vertices, "co", len(nme.vertices), 3)
    nloop_v = mesh_array(nme.loops, "vertex_index", len(nme.loops), 1, np.int32).reshape(-1, 3)
    nuv = mesh_array(nme.uv_layers["UVMap"].data, "uv", len(nme.loops), 2).reshape(-1, 3, 2)
    parent = np.arange(len(nloop_v)) // UV_LEVEL**2  # g1tess writes patch after patch

    # At the input corners the UVs are the input UVs of that corner of the same triangle.
    index = {tuple(p): i for i, p in enumerate(co.tolist())}
    corner_err, corners_seen = 0.0, 0
    for t, k in np.ndindex(nloop_v.shape):
        v = index.get(tuple(nco[nloop_v[t, k]].tolist()))
        if v is None:
            continue
        pt = parent[t]
        at = np.nonzero(tri[pt] == v)[0]
        assert len(at) == 1, "output corner at vertex %d is not a corner of triangle %d" % (v, pt)
        corner_err = max(corner_err, float(np.abs(nuv[t, k] - tuv[pt, at[0]]).max()))
        corners_seen += 1
    assert corners_seen == nt * 3, corners_seen  # each patch has its 3 corners once
    # g1tess interpolates in f64 and writes f32 values; Blender stores f32 (the ulp of a UV
    # in [0, 1] is at most 6e-8).
    assert corner_err <= 1e-6, corner_err
    # Linear in each patch: every UV lies within its input triangle's UV bounding box.
    lo, hi = tuv.min(axis=1)[parent], tuv.max(axis=1)[parent]
    outside = max(float((lo[:, None] - nuv).max()), float((nuv - hi[:, None]).max()))
    assert outside <= 1e-6, outside  # the same f32 rounding as above

    # A seam stays a seam: the input vertices and edges whose triangles disagree on the UV
    # keep every one of their UVs in the output, and no other output vertex is split.
    def distinct(vert_ids, uvs):
        sets = {}
        for v, uv in zip(vert_ids.ravel().tolist(), uvs.reshape(-1, 2).tolist()):
            sets.setdefault(v, set()).add(tuple(uv))
        return sets

    in_sets = distinct(tri, tuv)
    seam_vertices = {v for v, uvs in in_sets.items() if len(uvs) > 1}
    edge_uvs = {}
    for t in range(nt):
        for k in range(3):
            a, b = int(tri[t, k]), int(tri[t, (k + 1) % 3])
            key = (min(a, b), max(a, b))
            ends = (tuple(tuv[t, k]), tuple(tuv[t, (k + 1) % 3]))
            edge_uvs.setdefault(key, set()).add(ends if a < b else ends[::-1])
    assert len(edge_uvs) == ne
    seam_edges = sum(len(x) > 1 for x in edge_uvs.values())
    out_sets = distinct(nloop_v, nuv)
    split = sum(len(x) > 1 for x in out_sets.values())
    for v in seam_vertices:
        w = nloop_v.ravel()[np.nonzero((nco[nloop_v.ravel()] == co[v]).all(axis=1))[0][0]]
        assert out_sets[int(w)] == in_sets[v], (v, out_sets[int(w)], in_sets[v])
    print(
        "     UV sphere: %d -> %d vertices, %d triangles; %d seam vertices, %d seam edges, "
        "%d split output vertices; corner UV error %.1e, outside the triangle's UV box %.1e"
        % (nv, len(nme.vertices), len(nme.polygons), len(seam_vertices), seam_edges, split,
           corner_err, outside)
    )
    assert seam_edges > 0 and len(seam_vertices) > 0
    assert split == len(seam_vertices) + seam_edges * (UV_LEVEL - 1), split


@check("G1 Smooth of a UV-mapped cube with sharp edges: the OBJ input keeps the corner normals")
def uv_corner_normals():
    clear_scene()
    bpy.ops.mesh.primitive_cube_add(calc_uvs=True)
    obj = bpy.context.active_object
    me = obj.data
    me.shade_smooth()
    attr = me.attributes.new("sharp_edge", "BOOLEAN", "EDGE")
    attr.data.foreach_set("value", [True] * len(me.edges))
    me.update()
    activate(obj)
    r = bpy.ops.object.g1tess_smooth(scheme="g1", level=2, keep_dir=os.path.join(WORK, "uv-cube"))
    assert r == {"FINISHED"}, r
    info = bpy.context.active_object["g1tess"]
    pv, pvn, pvt, pf = read_obj_input(info["input"])
    # 8 vertex normals, then one normal per corner that differs: all 36 (face normals).
    assert (len(pv), len(pvn), len(pvt), len(pf)) == (8, 8 + 36, 24, 12)
    for t in range(12):
        p = pv[pf[t, :, 0]]
        fn = np.cross(p[1] - p[0], p[2] - p[0])
        assert np.abs(pvn[pf[t, :, 2]] - fn / np.linalg.norm(fn)).max() < 1e-6
    pn = os.path.join(WORK, "uv-cube.pn")
    activate(obj)
    assert bpy.ops.export_mesh.g1tess_pn(filepath=pn, use_world_space=False) == {"FINISHED"}
    s_obj, s_pn = stats(info["input"]), stats(pn)
    for key in ("vertices", "triangles", "interior_edges", "crease_edges"):
        assert s_obj[key] == s_pn[key], (key, s_obj[key], s_pn[key])
    assert s_obj["crease_edges"] == 12, s_obj["crease_edges"]  # the cube's 12 edges
    new = bpy.data.objects[obj.name + ".g1"]
    assert [layer.name for layer in new.data.uv_layers] == ["UVMap"]


@check("G1 Smooth with Fair (--fair): the torus's vertices kept, other normals; not with PN")
def fair_smooth():
    outputs = {}
    for fair in (False, True):
        clear_scene()
        obj = make_torus()
        activate(obj)
        co = mesh_array(obj.data.vertices, "co", len(obj.data.vertices), 3)
        keep = os.path.join(WORK, "fair" if fair else "plain")
        r = bpy.ops.object.g1tess_smooth(scheme="g1", level=2, fair=fair, keep_dir=keep)
        assert r == {"FINISHED"}, r
        pos, nrm, faces, _ = read_obj(bpy.context.active_object["g1tess"]["output"])
        # Every input vertex is a vertex of the surface, exactly (Blender's f32 in, f32 out).
        found = {tuple(p) for p in pos.astype(np.float32)}
        assert all(tuple(c) in found for c in co), "an input vertex moved"
        outputs[fair] = (pos, nrm, faces)
    (p0, n0, f0), (p1, n1, f1) = outputs[False], outputs[True]
    # Level 2: 4 triangles per input triangle, either way; the fair surface has the same
    # layout but its own normals, so its edge midpoints and normals differ.
    assert len(f0) == len(f1) == 200 * 4 and p0.shape == p1.shape
    assert np.abs(n0 - n1).max() > 1e-3 and np.abs(p0 - p1).max() > 0
    # --fair is the G1 surface's: refused with another scheme, in one message.
    activate(bpy.context.active_object)
    try:
        bpy.ops.object.g1tess_smooth(scheme="pn", level=2, fair=True)
    except RuntimeError as e:
        assert "Fair needs the G1 scheme" in str(e), str(e)
    else:
        raise AssertionError("no error for Fair with PN")


def main():
    passed = sum(ok for _, ok in RESULTS)
    failed = len(RESULTS) - passed
    if failed == 0 and not os.environ.get("G1TESS_KEEP"):
        shutil.rmtree(WORK, ignore_errors=True)
    else:
        print("files kept in %s" % WORK)
    print("blender: %d passed, %d failed" % (passed, failed))
    sys.exit(1 if failed else 0)


main()
