"""`g1tess export-msh` read back by Gmsh itself (the `gmsh` module from PyPI): element types
and node counts of every order, the node order against Gmsh's reference nodes, Gmsh's
Jacobians on the test meshes at order 3, physical groups and the per-element views."""

import json
import os

import gmsh
import numpy as np
import pytest

from conftest import DATA, MESHES

TRI = {1: 2, 2: 9, 3: 21, 4: 23, 5: 25}
LINE = {1: 1, 2: 8, 3: 26, 4: 27, 5: 28}


@pytest.fixture
def g():
    gmsh.initialize(["gmsh", "-v", "0"])
    yield gmsh
    gmsh.finalize()


def export(cli, tmp_path, mesh, order, *extra):
    stem = os.path.basename(mesh).replace(".", "_").replace(":", "_")
    out = tmp_path / f"{stem}-{order}.msh"
    s = json.loads(cli("export-msh", mesh, "--order", order, "--json", "-o", out, *extra).stdout)
    return out, s


@pytest.mark.parametrize("binary", [False, True])
def test_every_order_reads_back(cli, tmp_path, g, binary):
    fandisk = str(DATA / "fandisk.obj")
    extra = ["--crease-angle", "30"] + (["--binary"] if binary else [])
    for p in range(1, 6):
        out, s = export(cli, tmp_path, fandisk, p, *extra)
        g.clear()
        g.open(str(out))
        types, tags, nodes = g.model.mesh.getElements()
        assert sorted(types) == sorted([TRI[p], LINE[p]])
        k = list(types).index(TRI[p])
        name, dim, order, per, _, _ = g.model.mesh.getElementProperties(TRI[p])
        assert (dim, order, per) == (2, p, (p + 1) * (p + 2) // 2)
        assert len(tags[k]) == 12946 == s["triangles"]
        assert len(nodes[k]) == 12946 * per
        lk = 1 - k
        assert len(tags[lk]) == s["crease_lines"] and len(nodes[lk]) == s["crease_lines"] * (p + 1)
        node_tags, coords, _ = g.model.mesh.getNodes()
        assert len(node_tags) == s["nodes"]
        groups = {(d, t): g.model.getPhysicalName(d, t) for d, t in g.model.getPhysicalGroups()}
        assert groups == {(2, 1): "surface", (1, 1): "creases"}
        assert len(g.model.getEntitiesForPhysicalGroup(1, 1)) == 1


def test_node_order_matches_gmsh_reference_nodes(cli, tmp_path, g):
    # The flat scheme puts every node at its reference point's affine image, so each node
    # must be x0 + u (x1 − x0) + v (x2 − x0) with Gmsh's own (u, v) of that node.
    for p in range(2, 6):
        out, _ = export(cli, tmp_path, str(DATA / "spot.obj"), p, "--scheme", "flat")
        g.clear()
        g.open(str(out))
        _, _, _, per, local, _ = g.model.mesh.getElementProperties(TRI[p])
        uv = np.array(local).reshape(per, 2)
        _, enodes = g.model.mesh.getElementsByType(TRI[p])
        tags, coords, _ = g.model.mesh.getNodes()
        pos = dict(zip(tags, np.array(coords).reshape(-1, 3)))
        el = np.array([[pos[t] for t in e] for e in np.array(enodes).reshape(-1, per)[:500]])
        x0, x1, x2 = el[:, 0:1], el[:, 1:2], el[:, 2:3]
        want = x0 + uv[None, :, 0:1] * (x1 - x0) + uv[None, :, 1:2] * (x2 - x0)
        scale = np.abs(el).max()
        # f64 rounding of the affine map (ours and this one), relative to the coordinates.
        assert np.abs(el - want).max() <= 1e-14 * scale


# Elements our conservative bound flags at order 3 after `--repair-folds` (deterministic).
# The repair certifies every G1 patch and refuses patches whose cubic element may fold, so
# none is left. Suzanne's doubled triangle (elements 270 and 271: the same three vertices
# in both orders, standing in the symmetry plane x = 0, on its non-manifold edges) is
# degenerate without the repair, its input normals lying in its plane. The repair splits
# it off the surface: each copy gets its own face normal at its corners (a flat patch),
# and the surface's normals at the ends of the edge it stands on turn perpendicular to
# that edge, so all four uses of that non-manifold edge share one straight curve.
REPAIRED_FLAGGED = {"stanford-bunny.obj": 0, "suzanne.obj": 0, "spot.obj": 0, "fandisk.obj": 0}
# Suzanne's doubled triangle (element tags).
DOUBLED = {270, 271}


def test_gmsh_jacobians_on_the_test_meshes(cli, tmp_path, g):
    for m in MESHES:
        flagged_by = {}
        for extra in ([], ["--repair-folds"]):
            out, s = export(cli, tmp_path, str(DATA / m), 3, *extra)
            g.clear()
            g.open(str(out))
            tags, _ = g.model.mesh.getElementsByType(21)
            assert len(tags) == s["triangles"]
            # Gmsh's Jacobian determinants of the surface elements at the Gauss points of
            # degree 6 (for elements in 3-D, |x_u × x_v|): positive everywhere.
            pts, _ = g.model.mesh.getIntegrationPoints(21, "Gauss6")
            _, dets, _ = g.model.mesh.getJacobians(21, pts)
            assert dets.min() > 0, m
            # Gmsh's signed bound (minDetJac, relative to the straight element, refined by
            # subdivision): every element it finds non-positive, our conservative bound
            # flags.
            q = g.model.mesh.getElementQualities(tags, "minDetJac")
            flagged = {int(t) for t in tags[q <= 0]}
            (_, views) = read_views(g)
            ours = {int(t) for t, v in views["min scaled Jacobian"].items() if v <= 0}
            assert flagged <= ours, (m, extra)
            assert len(ours) == s["nonpositive_jacobian_elements"]
            flagged_by[bool(extra)] = (flagged, ours)
            if m in ("spot.obj", "fandisk.obj") or (extra and REPAIRED_FLAGGED[m] == 0):
                # Smooth input, or repaired: no element folds; Gmsh agrees.
                assert not flagged and not ours and s["min_scaled_jacobian"] > 0, (m, extra)
        # The repair leaves fewer elements that Gmsh or our bound finds non-positive, and
        # exactly as many as it leaves folded patches imply (see REPAIRED_FLAGGED).
        (f0, o0), (f1, o1) = flagged_by[False], flagged_by[True]
        assert len(o1) == REPAIRED_FLAGGED[m], m
        assert len(f1) <= len(f0) and len(o1) <= len(o0), m
        if m in ("stanford-bunny.obj", "suzanne.obj"):
            assert len(f1) < len(f0), m
        if m == "suzanne.obj":
            # The doubled triangle is flagged without the repair (by our bound), not after.
            assert DOUBLED <= o0 and not DOUBLED & o1, (o0, o1)


def read_views(g):
    """The $ElementData views Gmsh read: name -> {element tag: value}."""
    out = {}
    for v in g.view.getTags():
        kind, tags, data, _, _ = g.view.getModelData(v, 0)
        assert kind == "ElementData"
        name = g.option.getString(f"View[{g.view.getIndex(v)}].Name")
        out[name] = dict(zip(tags, np.array(data).ravel()))
    return len(out), out


def test_geometric_error_falls_with_the_order_on_sphere320(cli, tmp_path, g):
    errs = []
    for p in range(1, 6):
        out, s = export(cli, tmp_path, "sphere320", p)
        g.clear()
        g.open(str(out))
        n, views = read_views(g)
        assert n == 2
        d = views["max distance to patch"]
        assert len(d) == 320
        assert max(d.values()) == s["max_distance"]
        errs.append(s["max_distance"])
    assert all(b < 0.6 * a for a, b in zip(errs, errs[1:])), errs
