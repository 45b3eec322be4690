"""`Mesh.fair`: the fair G1 surface in the package, the same report as `g1tess stats --fair
--json` and the properties it promises, read back from the package's own statistics."""

import json

import numpy as np
import pytest

import g1tess
from conftest import DATA

# The built-in torus of 200 triangles (R = 1, r = 1/2) with averaged vertex normals: given,
# so bounded to 15° by default.
TORUS = "torus200"


def test_fair_is_the_cli_fair(cli):
    mesh = g1tess.load(TORUS)
    fair, report = mesh.fair()
    # The command line runs the same optimiser on the same mesh: the same report, number
    # for number (it is deterministic and does not depend on the threads).
    s = json.loads(cli("stats", TORUS, "--backend", "cpu", "--json", "--fair").stdout)
    assert report == s["fair"]
    assert report["creases_made"] == 0 and report["normal_bound_deg"] == 15.0
    assert 0 < report["max_normal_change_deg"] <= 15.0
    assert report["after"] == {"valid": 200, "folded": 0, "undecided": 0}
    # The torus's own energy, 4π²R² / (r √(R² − r²)) = 91.17, is what a fair surface
    # approaches: the averaged normals give 110.0, the fair surface 94.4 (measured).
    torus = 4 * np.pi**2 / (0.5 * np.sqrt(0.75))
    before = report["energy_before"]["energy"]
    after = report["energy_after"]["energy"]
    assert abs(after - torus) < 0.5 * abs(before - torus), (before, after, torus)
    # The vertices are the input's, bit for bit; only normals (and tangent lengths) change.
    np.testing.assert_array_equal(fair.vertices, mesh.vertices)
    assert not np.array_equal(fair.corner_normals, mesh.corner_normals)
    # The fair mesh's own statistics: G1 to rounding on every edge, every patch certified.
    # They are those the command line printed for its fair surface.
    st = fair.stats()
    assert st["cos"] == s["cos"] and st["patches"] == s["patches"]
    assert 1.0 - st["cos"]["min"] <= 1e-12
    assert st["patches"] == {"valid": 200, "folded": 0, "undecided": 0}


def test_fair_refuses_a_bound_outside_0_to_180():
    mesh = g1tess.load(TORUS)
    with pytest.raises(ValueError, match="normal_bound must be between 0 and 180"):
        mesh.fair(normal_bound=-1)


def test_fair_sweeps_is_the_cli_fair_sweeps(cli):
    # One sweep, in the package and on the command line: the same report, and it says
    # one sweep ran.
    mesh = g1tess.load(TORUS)
    _, report = mesh.fair(sweeps=1)
    s = json.loads(cli("stats", TORUS, "--backend", "cpu", "--json", "--fair", "--fair-sweeps", "1").stdout)
    assert report == s["fair"] and report["sweeps"] == 1
    with pytest.raises(ValueError, match="sweeps must be an integer"):
        mesh.fair(sweeps=-1)
