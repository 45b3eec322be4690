"""g1tess: smooth G1 curved surfaces from triangle meshes with vertex normals.

>>> import numpy as np, g1tess
>>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
>>> f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
>>> V, F, N = g1tess.Mesh(v, f).tessellate("g1", level=4)
>>> V.shape, F.shape, N.shape
((34, 3), (64, 3), (34, 3))

Every call releases the GIL while the library works, so threads (and Dask's threaded
workers) run meshes in parallel. Errors are ``ValueError`` (bad input) or ``OSError``
(files: ``FileNotFoundError`` for a missing one), with the message the command line prints
after ``error:``.

The package evaluates on the CPU: ``backend`` takes ``"cpu"`` (the default) or ``"auto"``,
which here means the CPU too (the command line's GPU backend is not part of the package).
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

from . import _native
from ._native import __version__

__all__ = ["Mesh", "load", "__version__"]

PathLike = Union[str, "os.PathLike[str]"]


def _triples(name: str, a: Any, dtype: Any) -> np.ndarray:
    """``a`` as a C-contiguous (N, 3) array of ``dtype``, or ValueError naming ``name``."""
    arr = np.asarray(a)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {arr.shape}")
    return np.ascontiguousarray(arr, dtype=dtype)


class Mesh:
    """A triangle mesh with per-corner unit normals, welded exactly like file input.

    ``vertices``: (N, 3) floats; ``triangles``: (M, 3) integer indices into them,
    counter-clockwise seen from outside; ``normals``: optional (N, 3), one per vertex
    (estimated from the faces when omitted). The keyword options are ``load``'s. Arrays
    already C-contiguous of the right dtype (float64, uint32) are read in place, with the
    GIL released: write them from no other thread until the constructor returns.
    """

    def __init__(
        self,
        vertices: Any,
        triangles: Any,
        normals: Optional[Any] = None,
        *,
        name: str = "mesh",
        normal_weighting: str = "angle",
        recompute_normals: bool = False,
        crease_angle: Optional[float] = None,
        phong_alpha: float = 0.75,
    ) -> None:
        v = _triples("vertices", vertices, np.float64)
        t = np.asarray(triangles)
        if t.ndim != 2 or t.shape[1] != 3:
            raise ValueError(f"triangles must have shape (M, 3), got {t.shape}")
        if t.size and not np.issubdtype(t.dtype, np.integer):
            raise ValueError(f"triangles must hold integers, got {t.dtype}")
        if t.dtype != np.uint32:  # uint32 indices are all in range (and read in place)
            t = t.astype(np.int64, copy=False)
            hi = np.iinfo(np.uint32).max
            if t.size and (t.min() < 0 or t.max() > hi):
                bad = int(np.argmax((t < 0).any(axis=1) | (t > hi).any(axis=1)))
                idx = int(t[bad][(t[bad] < 0) | (t[bad] > hi)][0])
                raise ValueError(
                    f"{name}: triangle {bad} has vertex index {idx}, out of range "
                    f"(the soup has {len(v)} vertices)"
                )
        t = np.ascontiguousarray(t, dtype=np.uint32)
        n = None if normals is None else _triples("normals", normals, np.float64)
        self._native = _native.Mesh(
            name,
            v,
            t,
            n,
            **_load_options(normal_weighting, recompute_normals, crease_angle, phong_alpha),
        )

    @classmethod
    def _wrap(cls, native: _native.Mesh) -> "Mesh":
        m = cls.__new__(cls)
        m._native = native
        return m

    @property
    def name(self) -> str:
        """The name shown in reports (the file name, or ``name=``)."""
        return self._native.name

    @property
    def vertices(self) -> np.ndarray:
        """Welded vertex positions, (N, 3) float64."""
        return self._native.vertices

    @property
    def triangles(self) -> np.ndarray:
        """Triangles as indices into ``vertices``, (M, 3) uint32."""
        return self._native.triangles

    @property
    def corner_normals(self) -> np.ndarray:
        """Unit normal of each corner of each triangle, (M, 3, 3) float64."""
        return self._native.corner_normals

    def tessellate(
        self,
        scheme: str = "g1",
        level: Optional[int] = None,
        *,
        tolerance: Optional[float] = None,
        tolerance_rel: Optional[float] = None,
        max_level: Optional[int] = None,
        backend: str = "cpu",
    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The stitched surface of ``scheme`` (f32, as ``g1tess tessellate --backend cpu``
        writes it to PLY): positions (V, 3) float32, triangles (F, 3) uint32 indexing
        them, unit normals (V, 3) float32.

        The grid is ``level`` (8 when neither it nor a tolerance is given), or, as
        ``g1tess tessellate --tolerance EPS`` / ``--tolerance-rel R`` / ``--max-level N``,
        levels chosen per edge and per patch so that the flat triangles deviate from the
        surface by at most ``tolerance`` (the mesh's units) or ``tolerance_rel`` times the
        bounding box's diagonal, each level at most ``max_level`` (default 64). A
        tolerance the levels up to ``max_level`` do not meet is a ``ValueError``.
        ``backend``: ``"cpu"`` or ``"auto"`` (the package runs on the CPU)."""
        grid = _grid(level, tolerance, tolerance_rel, max_level)
        return self._native.tessellate(scheme, **grid, backend=backend)

    def write_tessellation(
        self,
        path: PathLike,
        scheme: str = "g1",
        level: Optional[int] = None,
        *,
        tolerance: Optional[float] = None,
        tolerance_rel: Optional[float] = None,
        max_level: Optional[int] = None,
        backend: str = "cpu",
    ) -> Tuple[int, int]:
        """Writes the stitched surface to ``path`` (.obj, .ply, .stl, .glb), atomically,
        as ``g1tess tessellate`` does; returns (vertices, triangles) as the file counts
        them. The grid and ``backend`` as for ``tessellate``; a tolerance not met is a
        ``ValueError`` after the file is written (as the command line fails)."""
        grid = _grid(level, tolerance, tolerance_rel, max_level)
        return self._native.write_tessellation(os.fspath(path), scheme, **grid, backend=backend)

    def stats(self, scheme: str = "g1", *, backend: str = "cpu") -> Dict[str, Any]:
        """Continuity statistics: the object ``g1tess stats --backend cpu --json`` prints.
        ``backend``: ``"cpu"`` or ``"auto"`` (the package runs on the CPU)."""
        return json.loads(self._native.stats_json(scheme, backend=backend))

    def export_msh(
        self,
        path: PathLike,
        order: int = 3,
        *,
        scheme: str = "g1",
        binary: bool = False,
    ) -> Dict[str, Any]:
        """Curved Lagrange triangles of ``order`` (1 to 5) as Gmsh MSH 4.1 (``g1tess
        export-msh``); returns its JSON summary (worst scaled Jacobian, distance, ...)."""
        if not isinstance(order, int) or isinstance(order, bool) or not 1 <= order <= 5:
            raise ValueError(f"element order {order} is not supported (1 to 5)")
        return json.loads(self._native.export_msh(os.fspath(path), order, bool(binary), scheme))

    def repair_folds(self, scheme: str = "g1") -> Tuple["Mesh", Dict[str, Any]]:
        """The mesh with its normals changed as little as needed so that every ``scheme``
        patch is certified valid (what ``--repair-folds`` does), and the repair's report
        (the ``repair`` object of ``g1tess stats --repair-folds --json``). A mesh whose
        patches are all valid comes back unchanged. Tessellate, take statistics or export
        the returned mesh as any other (it keeps this mesh's ``phong_alpha``)."""
        native, report = self._native.repair_folds(scheme)
        return Mesh._wrap(native), json.loads(report)

    def fair(self, normal_bound: float = 15.0, sweeps: int = 6) -> Tuple["Mesh", Dict[str, Any]]:
        """The fair G1 surface (what ``--fair`` does): vertex normals and tangent lengths
        chosen to lower the bending energy, the vertices kept, every patch certified valid
        and no crease made; normals given in the file move at most ``normal_bound``
        degrees, estimated ones are free; at most ``sweeps`` sweeps (``--fair-sweeps``;
        each costs about as much as the first). Returns the mesh, to tessellate, take
        statistics of or export as any other, and the report (the ``fair`` object of
        ``g1tess stats --fair --json``: energies before and after, largest normal change,
        creases made, sweeps run)."""
        bound = float(normal_bound)
        if not 0.0 <= bound <= 180.0:
            raise ValueError(f"normal_bound must be between 0 and 180 degrees, got {normal_bound!r}")
        if not isinstance(sweeps, int) or isinstance(sweeps, bool) or not 0 <= sweeps <= 1000:
            raise ValueError(f"sweeps must be an integer from 0 to 1000, got {sweeps!r}")
        native, report = self._native.fair(bound, sweeps)
        return Mesh._wrap(native), json.loads(report)

    def __repr__(self) -> str:
        return f"<g1tess.Mesh {self.name!r}>"


def _level(level: int, what: str = "level") -> int:
    if not isinstance(level, int) or isinstance(level, bool) or level < 1:
        raise ValueError(f"{what} must be an integer of at least 1, got {level!r}")
    if level > 1 << 16:
        raise ValueError(f"{what} {level} is too large")
    return level


def _distance(value: Optional[float], what: str) -> Optional[float]:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise ValueError(f"{what} must be a number, got {value!r}")
    return float(value)


def _grid(
    level: Optional[int],
    tolerance: Optional[float],
    tolerance_rel: Optional[float],
    max_level: Optional[int],
) -> Dict[str, Any]:
    """The grid arguments checked for their types (the extension checks the rest)."""
    return dict(
        level=None if level is None else _level(level),
        tolerance=_distance(tolerance, "tolerance"),
        tolerance_rel=_distance(tolerance_rel, "tolerance_rel"),
        max_level=None if max_level is None else _level(max_level, "max_level"),
    )


def _load_options(
    normal_weighting: str,
    recompute_normals: bool,
    crease_angle: Optional[float],
    phong_alpha: float,
) -> Dict[str, Any]:
    return dict(
        normal_weighting=normal_weighting,
        recompute_normals=bool(recompute_normals),
        crease_angle=_distance(crease_angle, "crease_angle"),
        phong_alpha=_distance(phong_alpha, "phong_alpha"),
    )


def load(
    path: PathLike,
    *,
    normal_weighting: str = "angle",
    recompute_normals: bool = False,
    crease_angle: Optional[float] = None,
    phong_alpha: float = 0.75,
) -> Mesh:
    """Reads a mesh file (.obj, .ply, .stl, .gltf/.glb, .pn) or a built-in mesh
    (``sphere320``, ``icosphere:3``, ...), as the command line does with the same options:

    - ``normal_weighting`` (``--normals``): how face normals are weighted where vertex
      normals are estimated: ``"angle"``, ``"area"`` or ``"unweighted"``;
    - ``recompute_normals`` (``--recompute-normals``): estimate normals even where the
      file gives them;
    - ``crease_angle`` (``--crease-angle DEG``): edges whose dihedral angle exceeds it
      become creases, normals are estimated per smoothing group;
    - ``phong_alpha`` (``--phong-alpha``): Phong tessellation's shape factor, kept with
      the mesh for every later call.

    ``--repair-folds`` is ``Mesh.repair_folds``. A missing file is ``FileNotFoundError``."""
    return Mesh._wrap(
        _native.load(
            os.fspath(path),
            **_load_options(normal_weighting, recompute_normals, crease_angle, phong_alpha),
        )
    )
