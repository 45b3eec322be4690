"""The command line's input, tolerance and backend options in the g1tess package: the same
numbers as `g1tess` with the same flags, and the geometry they stand for."""

import json

import numpy as np
import pytest

import g1tess
from conftest import DATA
from test_package import read_ply

SPOT = DATA / "spot.obj"
FANDISK = DATA / "fandisk.obj"

# The corner tetrahedron: three faces in the coordinate planes, one on x + y + z = 1.
TET_V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
TET_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def face_normals(v, f):
    p = v[f]
    return unit(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]))


def cli_stats(cli, mesh, *flags):
    return json.loads(cli("stats", mesh, "--backend", "cpu", "--json", *flags).stdout)


# Crease edges of fandisk (12946 triangles, no normals in the file) as `g1tess stats
# --crease-angle DEG` counts them; without the option the estimated normals leave none.
@pytest.mark.parametrize("angle, creases", [(20, 876), (30, 722), (60, 700)])
def test_crease_angle_as_the_cli(cli, angle, creases):
    got = g1tess.load(FANDISK, crease_angle=angle).stats()
    assert got == cli_stats(cli, FANDISK, "--crease-angle", angle)
    assert got["crease_edges"] == creases
    assert g1tess.load(FANDISK).stats()["crease_edges"] == 0


def test_crease_angle_on_the_tetrahedron():
    # Face normals meet at 90° across the three edges at the origin and at
    # arccos(-1/√3) = 125.26° across the three edges of the slanted face.
    assert np.degrees(np.arccos(-1 / np.sqrt(3))) == pytest.approx(125.264, abs=1e-3)
    for angle, creases in [(80, 6), (100, 3), (130, 0)]:
        mesh = g1tess.Mesh(TET_V, TET_F, crease_angle=angle)
        assert mesh.stats()["crease_edges"] == creases, angle
    # Every edge a crease: each corner takes its face's normal (f64 rounding of the
    # normalisation: 1e-15).
    mesh = g1tess.Mesh(TET_V, TET_F, crease_angle=80)
    want = np.repeat(face_normals(TET_V, TET_F)[:, None, :], 3, axis=1)
    np.testing.assert_allclose(mesh.corner_normals, want, atol=1e-15)


@pytest.mark.parametrize("weighting", ["angle", "area", "unweighted"])
def test_normal_weighting_on_the_tetrahedron(weighting):
    # Vertex 1 = (1, 0, 0) lies on the faces z = 0, y = 0 (area 1/2, corner angle 45°) and
    # x + y + z = 1 (area √3/2, corner angle 60°).
    n = face_normals(TET_V, TET_F)
    w = {
        "angle": [np.pi / 4, np.pi / 4, 0, np.pi / 3],
        "area": [0.5, 0.5, 0, np.sqrt(3) / 2],
        "unweighted": [1, 1, 0, 1],
    }[weighting]
    want = unit(np.array(w) @ n)
    mesh = g1tess.Mesh(TET_V, TET_F, normal_weighting=weighting)
    corners = [(t, list(f).index(1)) for t, f in enumerate(TET_F) if 1 in f]
    for t, k in corners:
        # f64 sums of three unit vectors, normalised: a few ulps.
        np.testing.assert_allclose(mesh.corner_normals[t, k], want, atol=1e-15)


def vertex_normals(v, f, weighting):
    """Unit vertex normals: unit face normals summed with weights per corner (the corner's
    angle, the face's area, or 1). suzanne's vertex 135 lies only on its doubled triangle
    (the same corners in both orders), whose two normals cancel: it gets +z."""
    p = v[f]
    cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n = unit(cross)
    if weighting == "area":
        w = np.repeat(0.5 * np.linalg.norm(cross, axis=1)[:, None], 3, axis=1)
    elif weighting == "angle":
        e1 = unit(np.roll(p, -1, axis=1) - p)
        e2 = unit(np.roll(p, -2, axis=1) - p)
        w = np.arccos(np.clip((e1 * e2).sum(axis=2), -1, 1))
    else:
        w = np.ones(f.shape)
    acc, plain = np.zeros_like(v), np.zeros_like(v)
    for k in range(3):
        np.add.at(acc, f[:, k], w[:, k, None] * n)
        np.add.at(plain, f[:, k], n)
    # Where the weighted sum vanishes, the plain sum, and failing that +z.
    zero = ~np.linalg.norm(acc, axis=1).astype(bool)
    acc[zero] = plain[zero]
    zero = ~np.linalg.norm(acc, axis=1).astype(bool)
    acc[zero] = [0, 0, 1]
    return unit(acc)


SUZANNE = DATA / "suzanne.obj"


@pytest.mark.parametrize("weighting", ["angle", "area", "unweighted"])
def test_recompute_normals_as_the_cli(cli, weighting):
    # suzanne's file gives its normals; recomputed, each vertex gets the weighted mean of
    # its faces' normals.
    mesh = g1tess.load(SUZANNE, recompute_normals=True, normal_weighting=weighting)
    assert mesh.stats() == cli_stats(cli, SUZANNE, "--recompute-normals", "--normals", weighting)
    want = vertex_normals(mesh.vertices, mesh.triangles.astype(np.int64), weighting)
    # The same sums in another order and numpy's arccos: 1e-12 is far above f64 rounding
    # and far below the gap to the file's normals (asserted next).
    np.testing.assert_allclose(mesh.corner_normals, want[mesh.triangles], atol=1e-12)
    given = g1tess.load(SUZANNE, normal_weighting=weighting).corner_normals
    assert np.abs(given - want[mesh.triangles]).max() > 0.01


def test_unknown_normal_weighting():
    with pytest.raises(ValueError, match=r"unknown normal weighting 'mean' \(known: angle, "):
        g1tess.load(SPOT, normal_weighting="mean")


def test_phong_alpha_as_the_cli(cli, tmp_path):
    mesh = g1tess.load(SPOT, phong_alpha=0.5)
    assert mesh.stats("phong") == cli_stats(cli, SPOT, "--scheme", "phong", "--phong-alpha", 0.5)
    ply = tmp_path / "cli.ply"
    cli("tessellate", SPOT, "--backend", "cpu", "--scheme", "phong", "--phong-alpha", "0.5",
        "--level", "3", "-q", "-o", ply)
    out = tmp_path / "py.ply"
    mesh.write_tessellation(out, "phong", 3)
    assert out.read_bytes() == ply.read_bytes()
    # α = 0 is the flat triangle itself; α = 0.75 (the default) is not.
    flat = g1tess.load(SPOT).tessellate("flat", 4)[0]
    zero = g1tess.load(SPOT, phong_alpha=0).tessellate("phong", 4)[0]
    default = g1tess.load(SPOT).tessellate("phong", 4)[0]
    # f32 evaluation of two formulas for the same point: a few ulps of coordinates ≤ 1.
    np.testing.assert_allclose(zero, flat, atol=1e-6)
    assert np.abs(default - flat).max() > 1e-3
    # The repaired mesh keeps the option.
    fixed, _ = mesh.repair_folds("phong")
    assert fixed.stats("phong")["cos"] == mesh.stats("phong")["cos"]
    with pytest.raises(ValueError, match="phong_alpha must be a finite number, got NaN"):
        g1tess.load(SPOT, phong_alpha=float("nan"))


def test_tolerance_rel_identical_to_cli(cli, tmp_path):
    ply = tmp_path / "cli.ply"
    s = json.loads(cli("tessellate", SPOT, "--backend", "cpu", "--tolerance-rel", "1e-3",
                       "--json", "-o", ply).stdout)
    mesh = g1tess.load(SPOT)
    V, F, N = mesh.tessellate(tolerance_rel=1e-3)
    v, f, n = read_ply(ply)
    np.testing.assert_array_equal(V, v)
    np.testing.assert_array_equal(F, f)
    np.testing.assert_array_equal(N, n)
    # Levels 1 to 3 per edge: fewer triangles than the uniform level 3 (9 per patch).
    assert s["adaptive"]["edge_levels"] == [1, 3] and s["adaptive"]["tolerance_met"]
    assert len(F) == s["triangles"] == 12074 < 9 * 5856
    out = tmp_path / "py.ply"
    assert mesh.write_tessellation(out, tolerance_rel=1e-3) == (s["file_vertices"], len(F))
    assert out.read_bytes() == ply.read_bytes()


def test_tolerance_identical_to_cli(cli, tmp_path):
    # OBJ carries the title, which names the tolerance.
    obj = tmp_path / "cli.obj"
    cli("tessellate", SPOT, "--backend", "cpu", "--tolerance", "0.002", "--max-level", "6",
        "-q", "-o", obj)
    out = tmp_path / "py.obj"
    g1tess.load(SPOT).write_tessellation(out, tolerance=0.002, max_level=6)
    assert out.read_bytes() == obj.read_bytes()
    assert b"tolerance 2e-3" in out.read_bytes()[:200]


def test_tolerance_not_met(cli, tmp_path):
    # Level cap 4 is too coarse for 1e-5 × the diagonal: the file is written all the same
    # and the call fails with the command line's message (its option named as in Python).
    a, b = tmp_path / "cli.ply", tmp_path / "py.ply"
    p = cli("tessellate", SPOT, "--backend", "cpu", "--tolerance-rel", "1e-5",
            "--max-level", "4", "-q", "-o", a, check=False)
    assert p.returncode == 1
    want = p.stderr.strip().removeprefix("error: ").replace("--max-level", "max_level")
    with pytest.raises(ValueError) as e:
        g1tess.load(SPOT).write_tessellation(b, tolerance_rel=1e-5, max_level=4)
    assert str(e.value) == want.replace(str(a), str(b))
    assert "5742 patches at the level cap 4" in str(e.value)
    assert b.read_bytes() == a.read_bytes()
    with pytest.raises(ValueError) as e:
        g1tess.load(SPOT).tessellate(tolerance_rel=1e-5, max_level=4)
    assert str(e.value) == want.split("; raise")[0] + "; raise max_level)"


def test_grid_arguments_refused():
    mesh = g1tess.Mesh(TET_V, TET_F)
    with pytest.raises(ValueError, match="level and tolerance"):
        mesh.tessellate(level=4, tolerance=0.1)
    with pytest.raises(ValueError, match="tolerance and tolerance_rel exclude each other"):
        mesh.tessellate(tolerance=0.1, tolerance_rel=0.1)
    with pytest.raises(ValueError, match="max_level caps the levels"):
        mesh.tessellate(max_level=4)
    for bad in (0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="take a positive distance"):
            mesh.tessellate(tolerance=bad)
    with pytest.raises(ValueError, match=r"max_level must be in 1..=4096"):
        mesh.tessellate(tolerance=0.1, max_level=5000)
    with pytest.raises(ValueError, match="max_level must be an integer of at least 1"):
        mesh.tessellate(tolerance=0.1, max_level=0)
    with pytest.raises(ValueError, match="tolerance must be a number"):
        mesh.tessellate(tolerance="0.1")


def test_backend():
    mesh = g1tess.load(SPOT)
    cpu = mesh.tessellate(level=3)
    for a, b in zip(cpu, mesh.tessellate(level=3, backend="auto")):
        np.testing.assert_array_equal(a, b)
    assert mesh.stats(backend="auto") == mesh.stats()
    with pytest.raises(ValueError, match="backend 'gpu' is not available"):
        mesh.tessellate(backend="gpu")
    with pytest.raises(ValueError, match=r"unknown backend 'vulkan' \(known: cpu, auto\)"):
        mesh.stats(backend="vulkan")


def test_unreadable_file_is_oserror(cli, tmp_path):
    locked = tmp_path / "locked.obj"
    locked.write_text("v 0 0 0\n")
    locked.chmod(0)
    try:
        locked.read_bytes()
        pytest.skip("this user reads files of mode 000 (root with CAP_DAC_OVERRIDE)")
    except PermissionError:
        pass
    with pytest.raises(PermissionError) as e:
        g1tess.load(locked)
    p = cli("stats", locked, check=False)
    assert str(e.value) == p.stderr.strip().removeprefix("error: ")
