"""g1tess: smooth G1 curved surfaces from triangle meshes with vertex normals.

>>> import numpy as np, g1tess
>>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
>>> f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
>>> V, F, N = g1tess.Mesh(v, f).tessellate("g1", level=4)
>>> V.shape, F.shape, N.shape
((34, 3), (64, 3), (34, 3))

Every call releases the GIL while the library works, so threads (and Dask's threaded
workers) run meshes in parallel. Errors are ``ValueError`` (bad input) or ``OSError``
(files), with the message the command line prints after ``error:``.
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
    (estimated from the faces when omitted).
    """

    def __init__(
        self,
        vertices: Any,
        triangles: Any,
        normals: Optional[Any] = None,
        *,
        name: str = "mesh",
    ) -> None:
        v = _triples("vertices", vertices, np.float64)
        t = np.asarray(triangles)
        if t.ndim != 2 or t.shape[1] != 3:
            raise ValueError(f"triangles must have shape (M, 3), got {t.shape}")
        if t.size and not np.issubdtype(t.dtype, np.integer):
            raise ValueError(f"triangles must hold integers, got {t.dtype}")
        t = t.astype(np.int64, copy=False)
        if t.size and (t.min() < 0 or t.max() > np.iinfo(np.uint32).max):
            bad = int(np.argmax((t < 0).any(axis=1) | (t > np.iinfo(np.uint32).max).any(axis=1)))
            idx = int(t[bad][(t[bad] < 0) | (t[bad] > np.iinfo(np.uint32).max)][0])
            raise ValueError(
                f"{name}: triangle {bad} has vertex index {idx}, out of range "
                f"(the soup has {len(v)} vertices)"
            )
        t = np.ascontiguousarray(t, dtype=np.uint32)
        n = None if normals is None else _triples("normals", normals, np.float64)
        self._native = _native.from_soup(
            name, v.tobytes(), t.tobytes(), None if n is None else n.tobytes()
        )

    @classmethod
    def _wrap(cls, native: object) -> "Mesh":
        m = cls.__new__(cls)
        m._native = native
        return m

    @property
    def name(self) -> str:
        """The name shown in reports (the file name, or ``name=``)."""
        return _native.name(self._native)

    @property
    def vertices(self) -> np.ndarray:
        """Welded vertex positions, (N, 3) float64."""
        return np.frombuffer(_native.arrays(self._native)[0], np.float64).reshape(-1, 3)

    @property
    def triangles(self) -> np.ndarray:
        """Triangles as indices into ``vertices``, (M, 3) uint32."""
        return np.frombuffer(_native.arrays(self._native)[1], np.uint32).reshape(-1, 3)

    @property
    def corner_normals(self) -> np.ndarray:
        """Unit normal of each corner of each triangle, (M, 3, 3) float64."""
        return np.frombuffer(_native.arrays(self._native)[2], np.float64).reshape(-1, 3, 3)

    def tessellate(
        self, scheme: str = "g1", level: int = 8
    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The stitched surface of ``scheme`` on the grid of ``level`` (f32, as
        ``g1tess tessellate --backend cpu`` writes it to PLY): positions (V, 3) float32,
        triangles (F, 3) uint32 indexing them, unit normals (V, 3) float32."""
        v, f, n = _native.tessellate(self._native, scheme, _level(level))
        return (
            np.frombuffer(v, np.float32).reshape(-1, 3),
            np.frombuffer(f, np.uint32).reshape(-1, 3),
            np.frombuffer(n, np.float32).reshape(-1, 3),
        )

    def write_tessellation(
        self, path: PathLike, scheme: str = "g1", level: int = 8
    ) -> Tuple[int, int]:
        """Writes the stitched surface to ``path`` (.obj, .ply, .stl, .glb), atomically;
        returns (vertices, triangles) as the file counts them."""
        return _native.write_tessellation(self._native, os.fspath(path), scheme, _level(level))

    def stats(self, scheme: str = "g1") -> Dict[str, Any]:
        """Continuity statistics: the object ``g1tess stats --backend cpu --json`` prints."""
        return json.loads(_native.stats_json(self._native, scheme))

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
        return json.loads(
            _native.export_msh(self._native, os.fspath(path), order, bool(binary), scheme)
        )

    def repair_folds(self, scheme: str = "g1") -> Tuple["Mesh", Dict[str, Any]]:
        """The mesh with its normals changed as little as needed so that every ``scheme``
        patch is certified valid (what ``--repair-folds`` does), and the repair's report
        (the ``repair`` object of ``g1tess stats --repair-folds --json``). A mesh whose
        patches are all valid comes back unchanged. Tessellate, take statistics or export
        the returned mesh as any other."""
        native, report = _native.repair_folds(self._native, scheme)
        return Mesh._wrap(native), json.loads(report)

    def __repr__(self) -> str:
        return f"<g1tess.Mesh {self.name!r}>"


def _level(level: int) -> int:
    if not isinstance(level, int) or isinstance(level, bool) or level < 1:
        raise ValueError(f"level must be an integer of at least 1, got {level!r}")
    if level > 1 << 16:
        raise ValueError(f"level {level} is too large")
    return level


def load(path: PathLike) -> Mesh:
    """Reads a mesh file (.obj, .pn, ...) or a built-in mesh (``sphere320``,
    ``icosphere:3``, ...), as the command line does."""
    return Mesh._wrap(_native.load(os.fspath(path)))
