# SPDX-License-Identifier: MIT OR Apache-2.0
"""File formats of the g1tess add-on, without Blender: the point-normal format `.pn`
(version 1, written here, read by g1tess), the OBJ input written for meshes with texture
coordinates, and the OBJ files g1tess writes (read here).

The `.pn` format (documented in the repository README):

    g1tess-pn 1
    # comments and blank lines anywhere after the header
    counts V T C
    v x y z nx ny nz      V lines: position and vertex normal of vertex i (0-based, file order)
    t a b c               T lines: triangle, 0-based vertex ids, counter-clockwise
    c t k nx ny nz        C lines: normal of corner k (0, 1, 2) of triangle t, replacing the
                          vertex normal there (sharp edges, custom split normals)

Every number is written with Python's `repr(float)`, the shortest decimal form that reads
back as the same f64, so nothing is lost between Blender and g1tess.
"""

import os

import numpy as np

HEADER = "g1tess-pn 1"


def _fmt(row):
    return " ".join(map(repr, row))


def write_pn(path, positions, vertex_normals, triangles, corners=(), comment=None):
    """Writes a `.pn` file atomically (temporary file in the same folder, then rename).

    positions, vertex_normals: (V, 3) float arrays; triangles: (T, 3) int array of 0-based
    vertex ids; corners: iterable of (triangle, corner, (nx, ny, nz)).
    Returns (V, T, C).
    """
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    vertex_normals = np.asarray(vertex_normals, dtype=np.float64).reshape(-1, 3)
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    corners = list(corners)
    if len(positions) != len(vertex_normals):
        raise ValueError("one vertex normal per position is needed")
    if not (np.isfinite(positions).all() and np.isfinite(vertex_normals).all()):
        raise ValueError("non-finite position or normal")
    tmp = "%s.tmp%d" % (path, os.getpid())
    try:
        with open(tmp, "w", encoding="utf-8", newline="\n") as f:
            f.write(HEADER + "\n")
            if comment:
                for line in str(comment).splitlines():
                    f.write("# %s\n" % line)
            f.write("counts %d %d %d\n" % (len(positions), len(triangles), len(corners)))
            rows = np.hstack([positions, vertex_normals]).tolist()
            f.writelines("v %s\n" % _fmt(r) for r in rows)
            f.writelines("t %d %d %d\n" % tuple(t) for t in triangles.tolist())
            f.writelines(
                "c %d %d %s\n" % (t, k, _fmt(float(x) for x in n)) for t, k, n in corners
            )
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    return len(positions), len(triangles), len(corners)


def write_obj(
    path, positions, vertex_normals, triangles, corners, uvs, triangle_uv_ids, comment=None
):
    """Writes the input g1tess reads when the mesh has texture coordinates, as OBJ,
    atomically: `v` per vertex, `vn` per vertex normal then one per entry of `corners`
    (the per-corner normals of the `.pn` format), `vt` per entry of `uvs` (one per Blender
    loop) and `f v/vt/vn` per triangle, every number in `repr(float)` form.

    triangle_uv_ids: (T, 3) 0-based index into uvs of every triangle corner.
    Returns (V, T, C).
    """
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    vertex_normals = np.asarray(vertex_normals, dtype=np.float64).reshape(-1, 3)
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    uvs = np.asarray(uvs, dtype=np.float64).reshape(-1, 2)
    uv_ids = np.asarray(triangle_uv_ids, dtype=np.int64).reshape(-1, 3)
    corners = list(corners)
    if len(positions) != len(vertex_normals):
        raise ValueError("one vertex normal per position is needed")
    if uv_ids.shape != triangles.shape:
        raise ValueError("one texture coordinate id per triangle corner is needed")
    if len(uv_ids) and (uv_ids.min() < 0 or uv_ids.max() >= len(uvs)):
        raise ValueError("texture coordinate id out of range")
    if not (
        np.isfinite(positions).all()
        and np.isfinite(vertex_normals).all()
        and np.isfinite(uvs).all()
    ):
        raise ValueError("non-finite position, normal or texture coordinate")
    # Normal ids: the vertex's normal, or the corner's own (after the V vertex normals).
    normal_ids = triangles.copy()
    for j, (t, k, _) in enumerate(corners):
        normal_ids[t, k] = len(positions) + j
    faces = np.stack([triangles + 1, uv_ids + 1, normal_ids + 1], axis=2).reshape(-1, 9)
    tmp = "%s.tmp%d" % (path, os.getpid())
    try:
        with open(tmp, "w", encoding="utf-8", newline="\n") as f:
            if comment:
                for line in str(comment).splitlines():
                    f.write("# %s\n" % line)
            f.writelines("v %s\n" % _fmt(r) for r in positions.tolist())
            f.writelines("vn %s\n" % _fmt(r) for r in vertex_normals.tolist())
            f.writelines("vn %s\n" % _fmt(float(x) for x in n) for _, _, n in corners)
            f.writelines("vt %s\n" % _fmt(r) for r in uvs.tolist())
            f.writelines("f %d/%d/%d %d/%d/%d %d/%d/%d\n" % tuple(r) for r in faces.tolist())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    return len(positions), len(triangles), len(corners)


class ObjData:
    """What `read_obj` found: positions (V, 3), normals (N, 3) (may be empty), triangles
    (T, 3) vertex ids and, per triangle corner, a normal id or -1 (T, 3); texture
    coordinates (U, 2) (may be empty) and per corner a texture coordinate id or -1 (T, 3)."""

    def __init__(self, positions, normals, triangles, corner_normal_ids, uvs=None, corner_uv_ids=None):
        self.positions = positions
        self.normals = normals
        self.triangles = triangles
        self.corner_normal_ids = corner_normal_ids
        self.uvs = np.zeros((0, 2)) if uvs is None else uvs
        if corner_uv_ids is None:
            corner_uv_ids = np.full(triangles.shape, -1, dtype=np.int64)
        self.corner_uv_ids = corner_uv_ids

    def corner_uvs(self):
        """(T*3, 2) texture coordinate of every triangle corner, in triangle order (Blender
        loop order of a mesh built by from_pydata), or None when the file has no `vt` or a
        corner has none."""
        if len(self.uvs) == 0 or len(self.corner_uv_ids) == 0 or (self.corner_uv_ids < 0).any():
            return None
        return self.uvs[self.corner_uv_ids.ravel()]

    def vertex_normals(self):
        """One normal per vertex when every corner of a vertex uses the same normal value
        (as g1tess writes smooth surfaces), else None (split normals: use corner_normals)."""
        if len(self.normals) == 0 or (self.corner_normal_ids < 0).any():
            return None
        vn = np.full((len(self.positions), 3), np.nan)
        tri = self.triangles.ravel()
        nrm = self.normals[self.corner_normal_ids.ravel()]
        vn[tri] = nrm
        if not np.array_equal(vn[tri], nrm) or np.isnan(vn[tri]).any():
            return None
        return vn

    def corner_normals(self):
        """(T*3, 3) normal of every triangle corner, in triangle order (Blender loop order
        of a mesh built by from_pydata), or None without normals."""
        if len(self.normals) == 0 or (self.corner_normal_ids < 0).any():
            return None
        return self.normals[self.corner_normal_ids.ravel()]


def _index(text, count, what):
    i = int(text)
    if i == 0 or i < -count:
        raise ValueError("%s index %d out of range" % (what, i))
    return i - 1 if i > 0 else count + i


def read_obj(path):
    """Reads the `v`, `vn`, `vt` and `f` lines of an OBJ file (any face form, negative
    indices, polygons fan-triangulated). Raises ValueError naming the file and line on bad
    input."""
    positions, normals, uvs, tris, tri_n, tri_t = [], [], [], [], [], []
    with open(path, "r", encoding="utf-8") as f:
        for lineno, line in enumerate(f, 1):
            parts = line.split("#", 1)[0].split()
            if not parts:
                continue
            kw = parts[0]
            try:
                if kw == "v":
                    positions.append([float(x) for x in parts[1:4]])
                    if len(positions[-1]) != 3:
                        raise ValueError("'v' needs 3 numbers")
                elif kw == "vn":
                    normals.append([float(x) for x in parts[1:4]])
                    if len(normals[-1]) != 3:
                        raise ValueError("'vn' needs 3 numbers")
                elif kw == "vt":
                    uv = [float(x) for x in parts[1:3]]
                    if not uv:
                        raise ValueError("'vt' needs a number")
                    uvs.append(uv + [0.0] * (2 - len(uv)))
                elif kw == "f":
                    vs, ns, ts = [], [], []
                    for corner in parts[1:]:
                        fields = corner.split("/")
                        vs.append(_index(fields[0], len(positions), "vertex"))
                        if len(fields) == 3 and fields[2]:
                            ns.append(_index(fields[2], len(normals), "normal"))
                        else:
                            ns.append(-1)
                        if len(fields) >= 2 and fields[1]:
                            ts.append(_index(fields[1], len(uvs), "texture coordinate"))
                        else:
                            ts.append(-1)
                    if len(vs) < 3:
                        raise ValueError("face with fewer than 3 corners")
                    for i in range(1, len(vs) - 1):
                        tris.append([vs[0], vs[i], vs[i + 1]])
                        tri_n.append([ns[0], ns[i], ns[i + 1]])
                        tri_t.append([ts[0], ts[i], ts[i + 1]])
            except ValueError as e:
                raise ValueError("%s:%d: %s" % (path, lineno, e)) from None
    positions = np.array(positions, dtype=np.float64).reshape(-1, 3)
    normals = np.array(normals, dtype=np.float64).reshape(-1, 3)
    triangles = np.array(tris, dtype=np.int64).reshape(-1, 3)
    corner_ids = np.array(tri_n, dtype=np.int64).reshape(-1, 3)
    uvs = np.array(uvs, dtype=np.float64).reshape(-1, 2)
    corner_uv_ids = np.array(tri_t, dtype=np.int64).reshape(-1, 3)
    if len(triangles) and (triangles.min() < 0 or triangles.max() >= len(positions)):
        raise ValueError("%s: face vertex index out of range" % path)
    if len(corner_ids) and corner_ids.max() >= len(normals):
        raise ValueError("%s: face normal index out of range" % path)
    if len(normals):
        length = np.linalg.norm(normals, axis=1)
        if not (length > 0).all():
            raise ValueError("%s: zero-length normal" % path)
        normals = normals / length[:, None]
    return ObjData(positions, normals, triangles, corner_ids, uvs, corner_uv_ids)
