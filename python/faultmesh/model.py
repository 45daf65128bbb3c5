"""The multi-layer model: named triangulated surfaces for layers and faults.

A :class:`Model` is what :func:`faultmesh.build_model` returns and what the
file formats read and write. The methods delegate to the module that owns the
concern (``invariants``, ``section``, ``report``, ``io``) so each stays small.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional

import numpy as np

from ._core import TriangleKind


@dataclass
class Surface:
    """A TIN: ``vertices`` (n, 3) float64, ``triangles`` (m, 3) int64, CCW in XY.

    A stitched layer also knows where each triangle came from (None when that
    is not known, e.g. a surface read from a file that does not keep it):
    ``kinds`` (m,) int8 :class:`faultmesh.TriangleKind` values -- ``layer``
    (the continuous TIN), ``patch`` (a fault patch) or ``gap`` (ear-clipped
    between the hole and the patch) -- and ``owner`` (m,) int64: the
    :class:`StitchedPatch` id of a patch triangle, the :class:`Gap` id of a
    gap triangle, -1 for a layer triangle.
    """

    name: str
    vertices: np.ndarray
    triangles: np.ndarray
    kind: str = "layer"  # "layer" or "fault"
    metadata: Dict[str, Any] = field(default_factory=dict)
    kinds: Optional[np.ndarray] = None
    owner: Optional[np.ndarray] = None

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
        m = self.n_triangles
        if self.kinds is not None:
            kinds = np.asarray(self.kinds)
            if kinds.shape != (m,):
                raise ValueError(f"Surface {self.name!r}: kinds must have shape ({m},) (one per "
                                 f"triangle), got {kinds.shape}")
            valid = np.isin(kinds, [int(k) for k in TriangleKind])
            if not valid.all():
                row = int(np.flatnonzero(~valid)[0])
                raise ValueError(f"Surface {self.name!r}: kinds[{row}] = {kinds[row]} is not a "
                                 f"TriangleKind value ({', '.join(f'{k.name}={int(k)}' for k in TriangleKind)})")
            self.kinds = np.ascontiguousarray(kinds, dtype=np.int8)
        if self.owner is not None:
            owner = np.asarray(self.owner)
            if owner.shape != (m,) or (owner.size and owner.dtype.kind not in "iu"):
                raise ValueError(f"Surface {self.name!r}: owner must be an integer array of shape "
                                 f"({m},) (one per triangle), got {owner.dtype} {owner.shape}")
            self.owner = np.ascontiguousarray(owner, dtype=np.int64)

    @property
    def n_vertices(self) -> int:
        return int(self.vertices.shape[0])

    @property
    def n_triangles(self) -> int:
        return int(self.triangles.shape[0])


@dataclass
class StitchedPatch:
    """A fault patch stitched into a layer (paper 2.6): the fine fault model of
    one fault, or of a group of crossing faults modelled together.

    Its triangles are the rows of ``model.surfaces[layer]`` whose ``kinds`` is
    ``TriangleKind.patch`` and whose ``owner`` is ``id`` (ids count the patches
    stitched into that layer from 0). ``name``: the fault's name, or the
    group's (its ``group`` value, else its members' names joined with "+");
    ``faults``: the names of the faults it models.
    """

    layer: str
    id: int
    name: str
    faults: List[str]
    n_triangles: int = 0


@dataclass
class Gap:
    """One stitched gap: the polygon between a hole in a layer and a fault patch.

    ``triangles`` are rows of the layer surface's ``triangles`` created by ear
    clipping the gap; ``n_vertices`` and ``n_holes`` describe the gap polygon
    and ``n_interior`` counts the removed layer data put back inside it,
    so ``len(triangles) == n_vertices + 2 * n_holes - 2 + 2 * n_interior``. ``id``: the
    ``owner`` of its triangles in the layer surface (-1 if not known);
    ``patches``: the ids of the :class:`StitchedPatch` es of that layer whose
    outline is part of the gap (its holes, or its side along the study-area
    boundary). ``fault`` names them for reports (the patches' names joined
    with "+"; :meth:`Model.patches_of` gives the records).
    """

    fault: str
    layer: str
    triangles: np.ndarray
    n_vertices: int
    n_holes: int
    seconds: float = 0.0
    metadata: Dict[str, Any] = field(default_factory=dict)
    id: int = -1
    patches: List[int] = field(default_factory=list)
    n_interior: int = 0


@dataclass
class Model:
    """A faulted multi-layer model.

    ``surfaces``: layer name -> :class:`Surface`, top to bottom.
    ``faults``: fault name -> :class:`Surface` (the fault plane).
    ``boundary``: the study area, (k, 2) counter-clockwise.
    ``gaps``: every stitched gap (for the quality report).
    ``truth``: optional ground truth, ``truth(layer, x, y) -> z`` (built-in data).
    ``patches``: every fault patch stitched into a layer (:class:`StitchedPatch`).
    """

    name: str
    surfaces: Dict[str, Surface]
    faults: Dict[str, Surface] = field(default_factory=dict)
    boundary: Optional[np.ndarray] = None
    crs: str = ""
    gaps: List[Gap] = field(default_factory=list)
    truth: Optional[Callable[[str, np.ndarray, np.ndarray], np.ndarray]] = None
    metadata: Dict[str, Any] = field(default_factory=dict)
    patches: List[StitchedPatch] = field(default_factory=list)

    @property
    def layers(self) -> List[str]:
        return list(self.surfaces)

    def patches_of(self, gap: Gap) -> List[StitchedPatch]:
        """The stitched patches whose outline is part of ``gap`` (in the gap's order)."""
        by_id = {p.id: p for p in self.patches if p.layer == gap.layer}
        return [by_id[i] for i in gap.patches if i in by_id]

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
