"""The g1tess Python package: numpy in and out, the command line's results and messages."""

import struct
import threading

import numpy as np
import pytest

import g1tess
from conftest import DATA

SPOT = str(DATA / "spot.obj")


def read_ply(path):
    """Binary little-endian PLY as `g1tess tessellate` writes it: vertex x y z nx ny nz
    (float), then s t (float) when the input has texture coordinates, face list (uchar
    count, int indices). Parsed from its header."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    assert header[1] == "format binary_little_endian 1.0"
    nv = int(next(l for l in header if l.startswith("element vertex")).split()[2])
    nf = int(next(l for l in header if l.startswith("element face")).split()[2])
    props = [l.split()[-1] for l in header if l.startswith("property float")]
    assert props in (["x", "y", "z", "nx", "ny", "nz"], ["x", "y", "z", "nx", "ny", "nz", "s", "t"])
    k = len(props)
    vert = np.frombuffer(data, "<f4", count=k * nv, offset=end).reshape(nv, k)
    faces = np.frombuffer(
        data, np.dtype([("n", "u1"), ("i", "<i4", 3)]), count=nf, offset=end + 4 * k * nv
    )
    assert (faces["n"] == 3).all()
    return vert[:, :3], faces["i"], vert[:, 3:6]


def test_numpy_in_and_out():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    mesh = g1tess.Mesh(v, f)
    assert mesh.vertices.dtype == np.float64 and mesh.vertices.shape == (4, 3)
    np.testing.assert_array_equal(mesh.vertices, v)
    np.testing.assert_array_equal(mesh.triangles, f)
    V, F, N = mesh.tessellate("g1", level=4)
    assert (V.dtype, F.dtype, N.dtype) == (np.float32, np.uint32, np.float32)
    # Level 4: 15 samples per patch, 16 triangles; shared: 4 vertices + 6 edges × 3 + 4 × 3
    # interior positions, more records where the estimated normals split (none here: one
    # normal per vertex).
    assert F.shape == (4 * 16, 3)
    assert V.shape == (4 + 6 * 3 + 4 * 3, 3) and N.shape == V.shape
    assert F.max() == len(V) - 1
    np.testing.assert_allclose(np.linalg.norm(N, axis=1), 1, atol=1e-6)  # f32 unit normals
    # Corner samples are the input vertices (f32-rounded once).
    for p in v.astype(np.float32):
        assert (V == p).all(axis=1).any()
    # Normals given explicitly: float32 and lists accepted.
    m2 = g1tess.Mesh(v.astype(np.float32).tolist(), f.astype(np.int32), normals=v - 0.25)
    assert np.allclose(np.linalg.norm(m2.corner_normals, axis=2), 1)


def test_tessellate_identical_to_cli(cli, tmp_path):
    ply = tmp_path / "spot.ply"
    cli("tessellate", SPOT, "--backend", "cpu", "--level", "5", "-q", "-o", ply)
    V, F, N = g1tess.load(SPOT).tessellate("g1", level=5)
    v, f, n = read_ply(ply)
    np.testing.assert_array_equal(V, v)
    np.testing.assert_array_equal(F, f)
    np.testing.assert_array_equal(N, n)
    # write_tessellation writes the same bytes but for nothing.
    out = tmp_path / "py.ply"
    assert g1tess.load(SPOT).write_tessellation(out, "g1", 5) == (len(v), len(f))
    assert out.read_bytes() == ply.read_bytes()


def test_stats_identical_to_cli(cli):
    import json

    want = json.loads(cli("stats", SPOT, "--backend", "cpu", "--scheme", "pn", "--json").stdout)
    got = g1tess.load(SPOT).stats("pn")
    assert got == want
    assert got["triangles"] == 5856 and got["scheme"] == "pn"


def test_export_msh_identical_to_cli(cli, tmp_path):
    import json

    a, b = tmp_path / "cli.msh", tmp_path / "py.msh"
    s = json.loads(cli("export-msh", SPOT, "--order", "3", "--binary", "--json", "-o", a).stdout)
    t = g1tess.load(SPOT).export_msh(b, order=3, binary=True)
    assert a.read_bytes() == b.read_bytes()
    s.pop("output")
    assert s == t
    assert t["triangle_type"] == 21 and t["triangles"] == 5856


def test_repair_folds_gives_the_cli_repaired_export(cli, tmp_path):
    import json

    bunny = DATA / "stanford-bunny.obj"
    fixed, report = g1tess.load(bunny).repair_folds()
    # The bunny's 7 folded G1 patches, all certified after the repair (tests/validity.rs).
    assert report["before"] == {"valid": 69444, "folded": 7, "undecided": 0}
    assert report["after"] == {"valid": 69451, "folded": 0, "undecided": 0}
    assert report["edges_made_creases"] == 0
    assert fixed.stats()["patches"] == report["after"]
    # The repaired mesh exported from Python is the CLI's `--repair-folds` export, byte for
    # byte, and no element may fold.
    a, b = tmp_path / "cli.msh", tmp_path / "py.msh"
    s = json.loads(
        cli("export-msh", bunny, "--order", "3", "--repair-folds", "--json", "-o", a).stdout
    )
    t = fixed.export_msh(b, order=3)
    assert a.read_bytes() == b.read_bytes()
    s.pop("output")
    assert s == t
    assert t["nonpositive_jacobian_elements"] == 0 and t["crease_lines"] == 0
    # A mesh without folds comes back unchanged.
    spot = g1tess.load(SPOT)
    same, r = spot.repair_folds()
    assert r["vertices_touched"] == 0
    assert np.array_equal(same.corner_normals, spot.corner_normals)


def cli_message(cli, *args):
    p = cli(*args, check=False)
    assert p.returncode != 0
    assert p.stderr.startswith("error: ")
    return p.stderr[len("error: "):].strip()


def test_errors_carry_the_cli_messages(cli, tmp_path):
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    with pytest.raises(ValueError) as e:
        g1tess.load(bad)
    assert str(e.value) == cli_message(cli, "stats", bad)
    # A missing file: FileNotFoundError (an OSError), with the command line's message.
    with pytest.raises(FileNotFoundError) as e:
        g1tess.load(tmp_path / "missing.obj")
    assert str(e.value) == cli_message(cli, "stats", tmp_path / "missing.obj")
    # A malformed built-in mesh stays a ValueError.
    with pytest.raises(ValueError) as e:
        g1tess.load("icosphere:9")
    assert str(e.value) == cli_message(cli, "stats", "icosphere:9")
    # A file that cannot be written: the writer's I/O error.
    nowhere = tmp_path / "no" / "dir" / "x.msh"
    with pytest.raises(OSError) as e:
        g1tess.load(SPOT).export_msh(nowhere)
    assert str(e.value) == cli_message(cli, "export-msh", SPOT, "-o", nowhere)
    with pytest.raises(ValueError) as e:
        g1tess.load(SPOT).tessellate("g2")
    assert str(e.value) == "unknown scheme 'g2' (known: g1, phong, nagata, nagata-guarded, nlsa, pn, pn-normals, flat)"
    with pytest.raises(ValueError, match="level must be"):
        g1tess.load(SPOT).tessellate(level=0)
    with pytest.raises(ValueError, match=r"element order 6 is not supported \(1 to 5\)"):
        g1tess.load(SPOT).export_msh(tmp_path / "x.msh", order=6)


def test_bad_arrays():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    with pytest.raises(ValueError, match=r"vertices must have shape \(N, 3\), got \(4, 2\)"):
        g1tess.Mesh(v[:, :2], f)
    with pytest.raises(ValueError, match=r"triangles must have shape \(M, 3\), got \(12,\)"):
        g1tess.Mesh(v, f.ravel())
    with pytest.raises(ValueError, match=r"normals must have shape"):
        g1tess.Mesh(v, f, normals=v[:3, :1])
    with pytest.raises(ValueError, match="triangles must hold integers"):
        g1tess.Mesh(v, f.astype(float))
    nan = v.copy()
    nan[2, 1] = np.nan
    with pytest.raises(ValueError) as e:
        g1tess.Mesh(nan, f, name="soup")
    assert str(e.value) == "soup: vertex 2 has a non-finite coordinate"
    out = f.copy()
    out[3, 1] = 4
    with pytest.raises(ValueError) as e:
        g1tess.Mesh(v, out, name="soup")
    assert str(e.value) == "soup: triangle 3 has vertex index 4, out of range (the soup has 4 vertices)"
    neg = f.copy()
    neg[1, 2] = -1
    with pytest.raises(ValueError) as e:
        g1tess.Mesh(v, neg, name="soup")
    assert str(e.value) == "soup: triangle 1 has vertex index -1, out of range (the soup has 4 vertices)"
    with pytest.raises(ValueError) as e:
        g1tess.Mesh(v, f, normals=np.zeros((4, 3)), name="soup")
    assert str(e.value) == "soup: normal 0 is zero or non-finite"
    with pytest.raises(ValueError) as e:
        g1tess.Mesh(np.zeros((0, 3)), np.zeros((0, 3), int), name="soup")
    assert str(e.value) == "soup: empty mesh: no triangles"


def test_gil_is_released():
    # While one thread tessellates, another runs Python: with the GIL held through the
    # work, the counter would not move until the call returned.
    mesh = g1tess.load(SPOT)
    done = threading.Event()
    counter = 0

    def work():
        mesh.tessellate("g1", level=32)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        counter += 1
    t.join()
    assert counter > 1000, counter


def test_docstring_example():
    import doctest

    failed, tried = doctest.testmod(g1tess, raise_on_error=False)
    assert tried >= 3 and failed == 0


def test_readme_example(tmp_path):
    # The README's example, on spot: shapes, the stats keys, the summary.
    mesh = g1tess.load(SPOT)
    V, F, N = mesh.tessellate(scheme="g1", level=8)
    assert F.shape == (5856 * 64, 3) and V.shape == N.shape
    stats = mesh.stats()
    assert stats["scheme"] == "g1" and stats["boundary_edges"] == 0
    summary = mesh.export_msh(tmp_path / "spot.msh", order=3)
    assert summary["nonpositive_jacobian_elements"] == 0
    assert mesh.write_tessellation(tmp_path / "spot.ply", level=8)[1] == len(F)
