"""The multi-layer model: named triangulated surfaces for layers and faults.

A :class:`Model` is what :func:`faultmesh.build_model` returns and what the
file formats read and write. The methods delegate to the module that owns the
concern (``invariants``, ``section``, ``report``, ``io``) so each stays small.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional

import numpy as np


@dataclass
class Surface:
    """A TIN: ``vertices`` (n, 3) float64, ``triangles`` (m, 3) int64, CCW in XY."""

    name: str
    vertices: np.ndarray
    triangles: np.ndarray
    kind: str = "layer"  # "layer" or "fault"
    metadata: Dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.vertices = np.ascontiguousarray(self.vertices, dtype=np.float64)
        self.triangles = np.ascontiguousarray(self.triangles, dtype=np.int64)
        if self.vertices.ndim != 2 or self.vertices.shape[1] != 3:
            raise ValueError(f"Surface {self.name!r}: vertices must have shape (n, 3), "
                             f"got {self.vertices.shape}")
        if self.triangles.ndim != 2 or self.triangles.shape[1] != 3:
            if self.triangles.size == 0:
                self.triangles = self.triangles.reshape(0, 3)
            else:
                raise ValueError(f"Surface {self.name!r}: triangles must have shape (m, 3), "
                                 f"got {self.triangles.shape}")

    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def n_triangles(self) -> int:
        return int(self.triangles.shape[0])


@dataclass
class Gap:
    """One stitched gap: the polygon between a hole in a layer and a fault patch.

    ``triangles`` are rows of the layer surface's ``triangles`` created by ear
    clipping the gap; ``n_vertices`` and ``n_holes`` describe the gap polygon,
    so ``len(triangles) == n_vertices + 2 * n_holes - 2``.
    """

    fault: str
    layer: str
    triangles: np.ndarray
    n_vertices: int
    n_holes: int
    seconds: float = 0.0
    metadata: Dict[str, Any] = field(default_factory=dict)


@dataclass
class Model:
    """A faulted multi-layer model.

    ``surfaces``: layer name -> :class:`Surface`, top to bottom.
    ``faults``: fault name -> :class:`Surface` (the fault plane).
    ``boundary``: the study area, (k, 2) counter-clockwise.
    ``gaps``: every stitched gap (for the quality report).
    ``truth``: optional ground truth, ``truth(layer, x, y) -> z`` (built-in data).
    """

    name: str
    surfaces: Dict[str, Surface]
    faults: Dict[str, Surface] = field(default_factory=dict)
    boundary: Optional[np.ndarray] = None
    crs: str = ""
    gaps: List[Gap] = field(default_factory=list)
    truth: Optional[Callable[[str, np.ndarray, np.ndarray], np.ndarray]] = None
    metadata: Dict[str, Any] = field(default_factory=dict)

    @property
    def layers(self) -> List[str]:
        return list(self.surfaces)

    def check(self) -> None:
        """Raise ``faultmesh.GeometryError`` naming the surface and the broken invariant."""
        from .invariants import check_model

        check_model(self)

    def section(self, origin, azimuth: float):
        """Polylines where the vertical plane through ``origin`` at ``azimuth``
        (degrees clockwise from north) cuts each surface."""
        from .section import section_model

        return section_model(self, origin, azimuth)

    def quality(self):
        """Per-gap and per-layer mesh quality (the paper's Tables 1 and 2)."""
        from .report import quality

        return quality(self)

    def to_pyvista(self):
        """The model as a ``pyvista.MultiBlock``: one block per surface named
        after it, field data ``kind``/``name``/``order``, per-triangle arrays
        (``owner``, ``kind``) as cell data and vertex properties as point
        data (needs ``pip install 'faultmesh[viz]'``; docs/formats.md)."""
        from .formats.pv import to_pyvista

        return to_pyvista(self)

    def save(self, path, **kwargs) -> None:
        """Write the model; the format follows the suffix (faultmesh.io, docs/formats.md)."""
        from .io import save_model

        save_model(self, path, **kwargs)
