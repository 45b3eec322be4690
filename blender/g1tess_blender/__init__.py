# SPDX-License-Identifier: MIT OR Apache-2.0
"""g1tess for Blender: export full-precision point-normal meshes (`.pn`) and turn the
selected mesh into a smooth G1 surface with the g1tess program.

- File > Export > g1tess Point-Normal (.pn)
- Object > G1 Smooth: exports the active mesh (as `.pn`, or, when it has a UV layer, as OBJ
  with the active layer's texture coordinates per corner), runs
  `g1tess tessellate FILE.pn --scheme S --level N -o OUT.obj --json` (or, with Detail set
  to Tolerance, `--tolerance-rel R --max-level M` instead of `--level N`: levels per edge
  chosen so that the flat triangles stay within R x the bounding-box diagonal of the
  curved surface), and imports the result as a new object beside the original, shaded
  smooth, with g1tess's normals as custom normals and, when the output file has texture
  coordinates (`vt`), its UVs as the UV map "UVMap".
- The path of the g1tess binary is set in the add-on's preferences (empty: `g1tess` on
  the PATH).
"""

bl_info = {
    "name": "g1tess: G1 smooth surfaces",
    "author": "g1tess contributors",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "File > Export > g1tess Point-Normal (.pn); Object > G1 Smooth",
    "description": "Full-precision point-normal export, and G1 curved surfaces "
    "(Walton-Meek) computed by the g1tess program",
    "category": "Import-Export",
}

import json
import os
import re
import shutil
import subprocess
import tempfile

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper
from mathutils import Vector

from . import pnio

# The names g1tess uses on its command line (`--scheme`).
SCHEMES = [
    ("g1", "G1 (Walton-Meek)", "Bezier G1 patches: tangent plane shared across edges"),
    ("pn", "PN triangles", "Vlachos et al. 2001: cubic geometry"),
    ("phong", "Phong tessellation", "Boubekeur & Alexa 2008: quadratic, alpha 3/4"),
    ("nagata", "Nagata", "Nagata 2005: quadratic"),
    ("nagata-guarded", "Nagata (guarded)", "Nagata with a guard for near-parallel normals"),
    ("nlsa", "NLSA", "Barrera, Hast & Bengtsson 2002: quadratic"),
    ("flat", "Flat", "The flat triangles, for comparison"),
]

NORMAL_MODES = [
    (
        "AUTO",
        "Auto",
        "Vertex normals; per-corner normals where the mesh has sharp edges or custom "
        "normals (faces shaded flat are treated as smooth)",
    ),
    ("VERTEX", "Vertex", "One normal per vertex (ignores sharp edges and custom normals)"),
    ("CORNER", "Corner", "Blender's corner normals exactly as shaded (flat faces give creases)"),
]

# Corner normals closer than this to their vertex's normal (per component) are the same
# normal computed in another order: they are written once, as the vertex normal.
SAME_NORMAL = 1e-5


class G1TessError(Exception):
    """A failure to report to the user as one line."""


class G1TessPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    binary_path: StringProperty(
        name="g1tess binary",
        description="Path of the g1tess program (empty: 'g1tess' found on the PATH)",
        subtype="FILE_PATH",
        default="",
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "binary_path")
        found = shutil.which("g1tess")
        if not self.binary_path:
            layout.label(text="On the PATH: %s" % (found or "not found"))


def find_binary(context):
    """The g1tess executable: the preference if set, else `g1tess` on the PATH."""
    addon = context.preferences.addons.get(__package__)
    path = addon.preferences.binary_path if addon and addon.preferences else ""
    if path:
        path = bpy.path.abspath(path)
        if not os.path.isfile(path):
            raise G1TessError(
                "g1tess binary not found at '%s' (set it in Edit > Preferences > Add-ons "
                "> g1tess)" % path
            )
        if not os.access(path, os.X_OK):
            raise G1TessError("g1tess binary '%s' is not executable" % path)
        return path
    found = shutil.which("g1tess")
    if not found:
        raise G1TessError(
            "g1tess binary not found: set its path in Edit > Preferences > Add-ons > "
            "g1tess, or put it on the PATH"
        )
    return found


def _has_split_normals(me):
    if me.has_custom_normals:
        return True
    attr = me.attributes.get("sharp_edge")
    if attr is None or attr.domain != "EDGE" or attr.data_type != "BOOLEAN":
        return False
    sharp = np.zeros(len(me.edges), dtype=bool)
    attr.data.foreach_get("value", sharp)
    return bool(sharp.any())


def _unit(n):
    length = np.linalg.norm(n, axis=1)
    if not (length > 0).all() or not np.isfinite(length).all():
        raise G1TessError("the mesh has a zero or non-finite normal (degenerate faces?)")
    return n / length[:, None]


def mesh_arrays(context, obj, use_world_space=True, normals="AUTO", apply_modifiers=True):
    """The point-normal data of a mesh object as f64 arrays.

    Returns (positions (V, 3), vertex normals (V, 3), triangles (T, 3), corners) where
    corners lists (triangle, corner, normal) for the triangle corners whose normal is not
    their vertex's normal.
    """
    return mesh_data(context, obj, use_world_space, normals, apply_modifiers)[:4]


def mesh_data(context, obj, use_world_space=True, normals="AUTO", apply_modifiers=True):
    """`mesh_arrays` and the texture coordinates of the active UV layer: returns
    (positions, vertex normals, triangles, corners, uvs, triangle loops) where uvs is
    (L, 2) f64, one per Blender loop (None without a UV layer), and triangle loops (T, 3)
    the loop of every triangle corner (in the order of `triangles`)."""
    if obj is None or obj.type != "MESH":
        raise G1TessError("select a mesh object")
    if obj.mode == "EDIT":
        obj.update_from_editmode()
    depsgraph = context.evaluated_depsgraph_get()
    source = obj.evaluated_get(depsgraph) if apply_modifiers else obj
    me = bpy.data.meshes.new_from_object(source)
    try:
        if normals != "CORNER":
            me.shade_smooth()  # flat shading must not turn normals into face normals
        me.calc_loop_triangles()
        nv, nl, nt = len(me.vertices), len(me.loops), len(me.loop_triangles)
        if nt == 0:
            raise G1TessError("'%s' has no faces" % obj.name)
        co = np.empty(nv * 3, dtype=np.float32)
        me.vertices.foreach_get("co", co)
        vn = np.empty(nv * 3, dtype=np.float32)
        me.vertices.foreach_get("normal", vn)
        tri = np.empty(nt * 3, dtype=np.int32)
        me.loop_triangles.foreach_get("vertices", tri)
        tri_loops = np.empty(nt * 3, dtype=np.int32)
        me.loop_triangles.foreach_get("loops", tri_loops)
        use_corners = normals == "CORNER" or (normals == "AUTO" and _has_split_normals(me))
        if use_corners:
            ln = np.empty(nl * 3, dtype=np.float32)
            me.corner_normals.foreach_get("vector", ln)
            loop_vert = np.empty(nl, dtype=np.int32)
            me.loops.foreach_get("vertex_index", loop_vert)
        uv = None
        uv_layer = me.uv_layers.active
        if uv_layer is not None:
            uv = np.empty(nl * 2, dtype=np.float32)
            uv_layer.data.foreach_get("uv", uv)
    finally:
        bpy.data.meshes.remove(me)

    positions = co.reshape(-1, 3).astype(np.float64)
    vnormals = vn.reshape(-1, 3).astype(np.float64)
    triangles = tri.reshape(-1, 3).astype(np.int64)
    corner_of = tri_loops.reshape(-1, 3)
    uvs = uv.reshape(-1, 2).astype(np.float64) if uv is not None else None
    corner_normal = None
    if use_corners:
        ln = ln.reshape(-1, 3).astype(np.float64)
        # A vertex whose corners all carry (nearly) one normal gets that normal as its
        # vertex normal; the others keep Blender's vertex normal and list their corners.
        ref = vnormals.copy()
        ref[loop_vert] = ln
        spread = np.zeros(nv)
        np.maximum.at(spread, loop_vert, np.abs(ln - ref[loop_vert]).max(axis=1))
        uniform = spread <= SAME_NORMAL
        vnormals[uniform] = ref[uniform]
        corner_normal = ln[corner_of]  # (T, 3, 3)
        differs = np.abs(corner_normal - vnormals[triangles]).max(axis=2) > SAME_NORMAL
    if use_world_space:
        m = np.array(obj.matrix_world, dtype=np.float64)
        a = m[:3, :3]
        if abs(np.linalg.det(a)) < 1e-30:
            raise G1TessError("'%s' has a singular transform (zero scale)" % obj.name)
        normal_matrix = np.linalg.inv(a).T
        positions = positions @ a.T + m[:3, 3]
        vnormals = vnormals @ normal_matrix.T
        if corner_normal is not None:
            corner_normal = corner_normal @ normal_matrix.T
        if np.linalg.det(a) < 0:
            # A mirroring transform: keep the triangles counter-clockwise seen from the
            # normals' side.
            order = [0, 2, 1]
            triangles = triangles[:, order]
            corner_of = corner_of[:, order]
            if corner_normal is not None:
                corner_normal = corner_normal[:, order]
                differs = differs[:, order]
    # Loose vertices (no face) may have a zero normal; g1tess drops them anyway.
    loose = np.ones(len(vnormals), dtype=bool)
    loose[triangles.ravel()] = False
    vnormals[loose] = (0.0, 0.0, 1.0)
    vnormals = _unit(vnormals)
    corners = []
    if corner_normal is not None:
        flat = _unit(corner_normal.reshape(-1, 3)).reshape(-1, 3, 3)
        for t, k in zip(*np.nonzero(differs)):
            corners.append((int(t), int(k), flat[t, k]))
    if not np.isfinite(positions).all():
        raise G1TessError("'%s' has a non-finite vertex position" % obj.name)
    if uvs is not None and not np.isfinite(uvs).all():
        raise G1TessError("'%s' has a non-finite texture coordinate" % obj.name)
    return positions, vnormals, triangles, corners, uvs, corner_of


def export_pn(context, obj, filepath, use_world_space=True, normals="AUTO", apply_modifiers=True):
    """Writes the object's point-normal data to `filepath`; returns (V, T, C)."""
    p, n, t, c = mesh_arrays(context, obj, use_world_space, normals, apply_modifiers)
    comment = "%s, %s space, normals %s, Blender %s" % (
        obj.name,
        "world" if use_world_space else "local",
        normals.lower(),
        bpy.app.version_string,
    )
    try:
        return pnio.write_pn(filepath, p, n, t, c, comment=comment)
    except OSError as e:
        raise G1TessError("cannot write %s: %s" % (filepath, e.strerror or e)) from None


def export_input(context, obj, stem, use_world_space=True, normals="AUTO", apply_modifiers=True):
    """Writes the input g1tess reads for G1 Smooth: `stem.obj` (positions, per-corner
    normals and the active UV layer's texture coordinates) when the mesh has a UV layer,
    else `stem.pn`. Returns the path written."""
    p, n, t, c, uv, loops = mesh_data(context, obj, use_world_space, normals, apply_modifiers)
    path = stem + (".pn" if uv is None else ".obj")
    comment = "%s, %s space, normals %s, Blender %s" % (
        obj.name,
        "world" if use_world_space else "local",
        normals.lower(),
        bpy.app.version_string,
    )
    try:
        if uv is None:
            pnio.write_pn(path, p, n, t, c, comment=comment)
        else:
            pnio.write_obj(path, p, n, t, c, uv, loops, comment=comment)
    except OSError as e:
        raise G1TessError("cannot write %s: %s" % (path, e.strerror or e)) from None
    return path


def tessellate_command(
    binary, pn_path, out_path, scheme, level, tolerance_rel=None, max_level=64, fair=False
):
    """The `g1tess tessellate` command line: a uniform level, or (tolerance_rel given) levels
    per edge for a tolerance of tolerance_rel x the bounding-box diagonal, capped at
    max_level; with fair, the fair G1 surface (--fair)."""
    cmd = [binary, "tessellate", pn_path, "--scheme", scheme]
    if tolerance_rel is None:
        cmd += ["--level", str(level)]
    else:
        cmd += ["--tolerance-rel", repr(float(tolerance_rel)), "--max-level", str(max_level)]
    if fair:
        cmd += ["--fair"]
    return cmd + ["-o", out_path, "--json"]


def _flatten(summary, key):
    """Moves the fields of the object summary[key] to the top with the prefix key + "_",
    those of its objects with key + "_" + their key + "_"."""
    inner = summary.pop(key, None)
    if not isinstance(inner, dict):
        return
    for k, v in inner.items():
        if isinstance(v, dict):
            for k2, v2 in v.items():
                summary["%s_%s_%s" % (key, k, k2)] = v2
        else:
            summary["%s_%s" % (key, k)] = v


def run_g1tess(
    binary, pn_path, out_path, scheme, level, tolerance_rel=None, max_level=64, fair=False
):
    """Runs `g1tess tessellate` and returns its --json summary (a tolerance run's
    "adaptive" fields flattened with the prefix "adaptive_", a fair run's "fair" report
    with "fair_")."""
    cmd = tessellate_command(
        binary, pn_path, out_path, scheme, level, tolerance_rel, max_level, fair
    )
    try:
        done = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as e:
        raise G1TessError("cannot run g1tess binary '%s': %s" % (binary, e.strerror or e)) from None
    if done.returncode != 0:
        lines = [line for line in done.stderr.splitlines() if line.strip()]
        detail = " | ".join(lines[-3:]) if lines else "no message"
        raise G1TessError("g1tess failed (exit %d): %s" % (done.returncode, detail[:500]))
    lines = [line for line in done.stdout.splitlines() if line.strip()]
    try:
        summary = json.loads(lines[-1])
        int(summary["vertices"]), int(summary["triangles"])
    except (IndexError, ValueError, KeyError, TypeError):
        raise G1TessError(
            "g1tess printed no JSON summary (is '%s' a g1tess binary?)" % binary
        ) from None
    _flatten(summary, "adaptive")
    _flatten(summary, "fair")
    return summary


def build_object(context, name, data, original, place_beside):
    """A new object from the g1tess output `data` (pnio.ObjData), shaded smooth with its
    normals as custom normals, linked beside `original`."""
    me = bpy.data.meshes.new(name)
    me.from_pydata(data.positions.tolist(), [], data.triangles.tolist())
    me.shade_smooth()
    vn = data.vertex_normals()
    if vn is not None:
        me.normals_split_custom_set_from_vertices(vn.tolist())
    else:
        cn = data.corner_normals()
        if cn is not None:
            me.normals_split_custom_set(cn.tolist())
    uv = data.corner_uvs()
    if uv is not None:
        # g1tess's texture coordinates (interpolated in each patch, split at seams).
        layer = me.uv_layers.new(name="UVMap")
        layer.data.foreach_set("uv", uv.astype(np.float32).ravel())
    me.update()
    obj = bpy.data.objects.new(name, me)
    collections = original.users_collection or (context.scene.collection,)
    for coll in collections:
        coll.objects.link(obj)
    obj.matrix_world = original.matrix_world.copy()
    if place_beside:
        corners = [original.matrix_world @ Vector(c) for c in original.bound_box]
        width = max(c.x for c in corners) - min(c.x for c in corners)
        m = obj.matrix_world.copy()
        t = m.translation
        t.x += 1.25 * width if width > 0 else 1.0
        m.translation = t
        obj.matrix_world = m
    return obj


class EXPORT_MESH_OT_g1tess_pn(bpy.types.Operator, ExportHelper):
    """Export the active mesh's positions, normals and triangles at full precision"""

    bl_idname = "export_mesh.g1tess_pn"
    bl_label = "Export g1tess Point-Normal"
    bl_options = {"PRESET"}

    filename_ext = ".pn"
    filter_glob: StringProperty(default="*.pn", options={"HIDDEN"})
    use_world_space: BoolProperty(
        name="World Space",
        description="Apply the object's transform (else write local coordinates)",
        default=True,
    )
    normals: EnumProperty(name="Normals", items=NORMAL_MODES, default="AUTO")
    apply_modifiers: BoolProperty(name="Apply Modifiers", default=True)

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and obj.type == "MESH"

    def execute(self, context):
        obj = context.active_object
        try:
            v, t, c = export_pn(
                context, obj, self.filepath, self.use_world_space, self.normals,
                self.apply_modifiers,
            )
        except G1TessError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report(
            {"INFO"}, "wrote %s: %d vertices, %d triangles, %d corner normals"
            % (self.filepath, v, t, c)
        )
        return {"FINISHED"}


class OBJECT_OT_g1tess_smooth(bpy.types.Operator):
    """Smooth the active mesh into curved patches with g1tess and add the result as a new
    object beside it"""

    bl_idname = "object.g1tess_smooth"
    bl_label = "G1 Smooth"
    bl_options = {"REGISTER", "UNDO"}

    scheme: EnumProperty(name="Scheme", items=SCHEMES, default="g1")
    detail: EnumProperty(
        name="Detail",
        items=(
            ("LEVEL", "Level", "The same number of segments on every triangle edge"),
            (
                "TOLERANCE",
                "Tolerance",
                "Segments per edge chosen so that the flat triangles stay within the "
                "tolerance of the curved surface (measured by g1tess)",
            ),
        ),
        default="LEVEL",
    )
    level: IntProperty(
        name="Level", description="Segments per triangle edge", default=8, min=1, max=64,
        soft_max=32,
    )
    tolerance: FloatProperty(
        name="Tolerance",
        description="Largest distance of the flat triangles from the curved surface, as a "
        "fraction of the bounding-box diagonal",
        default=1e-3, min=1e-7, max=0.1, precision=6,
    )
    max_level: IntProperty(
        name="Max Level", description="Cap on the segments per edge the tolerance may ask for",
        default=64, min=1, max=4096, soft_max=128,
    )
    fair: BoolProperty(
        name="Fair",
        description="Choose the normals and tangent lengths that lower the bending energy "
        "(g1tess --fair): a surface that looks smooth, not only G1. The vertices stay; "
        "normals from the mesh move at most 15 degrees. G1 scheme only",
        default=False,
    )
    normals: EnumProperty(name="Normals", items=NORMAL_MODES, default="AUTO")
    apply_modifiers: BoolProperty(name="Apply Modifiers", default=True)
    place_beside: BoolProperty(
        name="Place Beside",
        description="Move the new object along X beside the original (else on top of it)",
        default=True,
    )
    keep_dir: StringProperty(
        name="Keep Files In",
        description="Folder that keeps the exchanged .pn or .obj input and the .obj "
        "output (empty: a temporary folder, removed afterwards)",
        subtype="DIR_PATH",
        default="",
    )

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and obj.type == "MESH"

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        obj = context.active_object
        try:
            new = self.smooth(context, obj)
        except G1TessError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        info = new["g1tess"]
        if self.detail == "TOLERANCE":
            detail = "tolerance %g, measured deviation %.3g" % (
                info["adaptive_tolerance"], info["adaptive_max_deviation"]
            )
        else:
            detail = "level %d" % self.level
        self.report(
            {"INFO"}, "%s: %d vertices, %d triangles (%s, %s)"
            % (new.name, info["vertices"], info["triangles"], self.scheme, detail)
        )
        return {"FINISHED"}

    def smooth(self, context, obj):
        if self.fair and self.scheme != "g1":
            raise G1TessError("Fair needs the G1 scheme (scheme is %s)" % self.scheme)
        binary = find_binary(context)
        keep = bpy.path.abspath(self.keep_dir) if self.keep_dir else ""
        if keep:
            os.makedirs(keep, exist_ok=True)
        work = keep or tempfile.mkdtemp(prefix="g1tess-")
        try:
            stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", obj.name) or "mesh"
            out_path = os.path.join(work, "%s.%s.obj" % (stem, self.scheme))
            pn_path = export_input(
                context, obj, os.path.join(work, stem), False, self.normals,
                self.apply_modifiers,
            )
            tolerance = self.tolerance if self.detail == "TOLERANCE" else None
            summary = run_g1tess(
                binary, pn_path, out_path, self.scheme, self.level, tolerance, self.max_level,
                self.fair,
            )
            try:
                data = pnio.read_obj(out_path)
            except (OSError, ValueError) as e:
                raise G1TessError("cannot read g1tess output: %s" % e) from None
            got = (len(data.positions), len(data.triangles))
            want = (int(summary["vertices"]), int(summary["triangles"]))
            if got != want:
                raise G1TessError(
                    "g1tess output %s has %d vertices, %d triangles; g1tess reported %d, %d"
                    % ((out_path,) + got + want)
                )
            new = build_object(
                context, "%s.%s" % (obj.name, self.scheme), data, obj, self.place_beside
            )
        finally:
            if not keep:
                shutil.rmtree(work, ignore_errors=True)
        summary = {k: v for k, v in summary.items() if isinstance(v, (str, int, float))}
        summary["input"] = pn_path
        new["g1tess"] = summary
        obj.select_set(False)
        new.select_set(True)
        context.view_layer.objects.active = new
        return new


def menu_export(self, context):
    self.layout.operator(EXPORT_MESH_OT_g1tess_pn.bl_idname, text="g1tess Point-Normal (.pn)")


def menu_object(self, context):
    self.layout.separator()
    self.layout.operator(OBJECT_OT_g1tess_smooth.bl_idname, text="G1 Smooth")


CLASSES = (G1TessPreferences, EXPORT_MESH_OT_g1tess_pn, OBJECT_OT_g1tess_smooth)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.TOPBAR_MT_file_export.append(menu_export)
    bpy.types.VIEW3D_MT_object.append(menu_object)


def unregister():
    bpy.types.VIEW3D_MT_object.remove(menu_object)
    bpy.types.TOPBAR_MT_file_export.remove(menu_export)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
