"""The compiled part of g1tess: arrays cross as numpy arrays (inputs read in place, outputs
handed over without a copy). Use the package ``g1tess`` instead."""

from typing import Optional, Tuple

import numpy as np
import numpy.typing as npt

__version__: str

class Mesh:
    def __init__(
        self,
        name: str,
        vertices: npt.NDArray[np.float64],
        triangles: npt.NDArray[np.uint32],
        normals: Optional[npt.NDArray[np.float64]] = None,
        *,
        normal_weighting: str = "angle",
        recompute_normals: bool = False,
        crease_angle: Optional[float] = None,
        phong_alpha: float = 0.75,
    ) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def vertices(self) -> npt.NDArray[np.float64]: ...
    @property
    def triangles(self) -> npt.NDArray[np.uint32]: ...
    @property
    def corner_normals(self) -> npt.NDArray[np.float64]: ...
    def tessellate(
        self,
        scheme: str = "g1",
        level: Optional[int] = None,
        *,
        tolerance: Optional[float] = None,
        tolerance_rel: Optional[float] = None,
        max_level: Optional[int] = None,
        backend: str = "cpu",
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.uint32], npt.NDArray[np.float32]]: ...
    def write_tessellation(
        self,
        path: str,
        scheme: str = "g1",
        level: Optional[int] = None,
        *,
        tolerance: Optional[float] = None,
        tolerance_rel: Optional[float] = None,
        max_level: Optional[int] = None,
        backend: str = "cpu",
    ) -> Tuple[int, int]: ...
    def stats_json(self, scheme: str = "g1", *, backend: str = "cpu") -> str: ...
    def export_msh(self, path: str, order: int, binary: bool, scheme: str) -> str: ...
    def repair_folds(self, scheme: str) -> Tuple[Mesh, str]: ...
    def fair(self, normal_bound_deg: float) -> Tuple[Mesh, str]: ...

def load(
    path: str,
    *,
    normal_weighting: str = "angle",
    recompute_normals: bool = False,
    crease_angle: Optional[float] = None,
    phong_alpha: float = 0.75,
) -> Mesh: ...
