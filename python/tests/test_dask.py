"""examples/dask_batch.py on the test meshes with a LocalCluster of two workers, one mesh
deliberately broken: it is recorded as failed and every other mesh is written."""

import csv
import shutil
import subprocess
import sys

from conftest import DATA, MESHES, ROOT


def test_dask_batch_with_a_broken_mesh(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    for m in MESHES:
        shutil.copy(DATA / m, src / m)
    (src / "broken.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    (src / "notes.txt").write_text("not a mesh")
    out = tmp_path / "out"
    p = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "dask_batch.py"), src, out,
         "--workers", "2", "--level", "3"],
        capture_output=True, text=True, timeout=600,
    )
    assert p.returncode == 0, p.stderr
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert [r["mesh"] for r in rows] == sorted(MESHES + ["broken.obj"])
    by = {r["mesh"]: r for r in rows}
    assert by["broken.obj"]["status"] == "failed"
    assert by["broken.obj"]["error"].startswith("ValueError: ")
    assert "broken.obj:4:" in by["broken.obj"]["error"]
    for m in MESHES:
        r = by[m]
        assert r["status"] == "ok", r
        ply = out / r["output"]
        assert ply.is_file() and ply.name == m.replace(".obj", ".ply")
        # Level 3: 9 output triangles per input triangle.
        assert int(r["triangles_out"]) == 9 * int(r["triangles_in"])
    # Two worker processes took part.
    assert len({r["worker"] for r in rows}) == 2
    md = (out / "summary.md").read_text().splitlines()
    assert len(md) == 2 + len(rows) and md[0].startswith("| mesh | status |")
    # --strict turns the failure into the exit status.
    p = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "dask_batch.py"), src, out,
         "--workers", "2", "--level", "1", "--strict"],
        capture_output=True, text=True, timeout=600,
    )
    assert p.returncode == 1, p.stderr
