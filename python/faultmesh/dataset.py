"""Datasets: boreholes, section lines and fault traces (DESIGN.md "Dataset format").

The data classes here are the contract between the loader and the modelling
workflow (:func:`faultmesh.build_model`). Loading and saving of format v1 is
added below them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Optional

import numpy as np

FORMAT_VERSION = 1


class DatasetError(ValueError):
    """A malformed dataset. The message names the file and the row (1-based, as a
    person counts the lines of a CSV, header = line 1) and the field, or the
    fault / trace / layer that is wrong."""


@dataclass
class Section:
    """A vertical exploration line: ``origin`` (2,) and ``azimuth`` in degrees
    clockwise from north (+y)."""

    name: str
    origin: np.ndarray
    azimuth: float

    def __post_init__(self) -> None:
        self.origin = np.asarray(self.origin, dtype=np.float64).reshape(2)
        self.azimuth = float(self.azimuth)

    @property
    def direction(self) -> np.ndarray:
        """Unit vector (2,) of the line in XY: (sin az, cos az)."""
        # Exact unit vectors on the compass points, so that east-west and
        # north-south lines do not pick up 1e-16 noise in the other coordinate.
        q = self.azimuth % 360.0
        exact = {0.0: (0.0, 1.0), 90.0: (1.0, 0.0), 180.0: (0.0, -1.0), 270.0: (-1.0, 0.0)}
        if q in exact:
            return np.array(exact[q])
        a = np.deg2rad(self.azimuth)
        return np.array([np.sin(a), np.cos(a)])

    def to_xy(self, s) -> np.ndarray:
        """XY (k, 2) of the points at distances ``s`` (k,) along the line."""
        s = np.asarray(s, dtype=np.float64).reshape(-1)
        return self.origin[None, :] + s[:, None] * self.direction[None, :]

    def to_s(self, xy) -> np.ndarray:
        """Distance along the line (k,) of the orthogonal projection of ``xy`` (k, 2)."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return (xy - self.origin[None, :]) @ self.direction


@dataclass
class Trace:
    """A fault's interpretation on one section (or a free vertical cut).

    ``plane`` (k, 3) is the fault-plane trace, top down. ``layers[layer]`` has
    ``"foot"`` (k, 3), the footwall polyline from its far end to the cutoff on
    the fault, and ``"hanging"`` (k, 3), the hanging-wall polyline from the
    cutoff to its far end. A layer may be absent from a trace (not displaced
    there, or not interpreted)."""

    section: Optional[str]
    plane: np.ndarray
    layers: Dict[str, Dict[str, np.ndarray]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.plane = np.asarray(self.plane, dtype=np.float64).reshape(-1, 3)
        self.layers = {
            str(layer): {side: np.asarray(pts, dtype=np.float64).reshape(-1, 3)
                         for side, pts in sides.items()}
            for layer, sides in self.layers.items()}


@dataclass
class Fault:
    """A fault: ``kind`` is "normal" or "reverse"; faults sharing a ``group``
    value are modelled together (T- or X-crossings); ``tips`` (t, 2) are the
    pinch-out points in XY (t may be 0); ``traces`` are ordered along strike."""

    name: str
    kind: str
    group: Optional[str] = None
    tips: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    traces: List[Trace] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.tips = np.asarray(self.tips, dtype=np.float64).reshape(-1, 2)
        if self.kind not in ("normal", "reverse"):
            raise DatasetError(f"fault {self.name!r}: kind must be 'normal' or 'reverse', "
                               f"got {self.kind!r}")


@dataclass
class Boreholes:
    """Borehole layer tops, one row per hit: ``hole_id`` (n,) str, ``xy`` (n, 2),
    ``layer`` (n,) str, ``z`` (n,) elevation of the top of ``layer``. A
    (hole_id, layer) pair may repeat (reverse-fault repetition)."""

    hole_id: np.ndarray
    xy: np.ndarray
    layer: np.ndarray
    z: np.ndarray

    def __post_init__(self) -> None:
        self.hole_id = np.asarray(self.hole_id, dtype=str).reshape(-1)
        self.xy = np.asarray(self.xy, dtype=np.float64).reshape(-1, 2)
        self.layer = np.asarray(self.layer, dtype=str).reshape(-1)
        self.z = np.asarray(self.z, dtype=np.float64).reshape(-1)
        n = len(self.hole_id)
        if not (len(self.xy) == len(self.layer) == len(self.z) == n):
            raise DatasetError("Boreholes: hole_id, xy, layer and z must have the same number "
                               f"of rows, got {n}, {len(self.xy)}, {len(self.layer)}, {len(self.z)}")

    def __len__(self) -> int:
        return int(len(self.hole_id))

    @property
    def n_holes(self) -> int:
        return int(len(np.unique(self.hole_id)))


@dataclass
class Dataset:
    """A dataset in memory (format v1 of DESIGN.md)."""

    name: str
    layers: List[str]
    boundary: np.ndarray
    boreholes: Boreholes
    points: Dict[str, np.ndarray] = field(default_factory=dict)
    sections: Dict[str, Section] = field(default_factory=dict)
    faults: List[Fault] = field(default_factory=list)
    crs: str = ""
    path: Optional[Path] = None
    truth: Optional[Callable[[str, np.ndarray, np.ndarray], np.ndarray]] = None

    def layer_points(self, layer: str) -> np.ndarray:
        """The data points (n, 3) of ``layer`` for the CONTINUOUS stratum model.

        Borehole hits plus the extra points of the layer. A hole that hits the
        layer more than once (repetition across a reverse fault) keeps ONE hit:
        the shallowest (largest z). A vertical hole through a reverse fault
        meets the hanging-wall copy of the layer first, above the footwall copy,
        so keeping the upper hit keeps the hole's first intersection with the
        layer, the same branch that the built-in ground truth reports in the
        overlap band; the region around the fault is replaced by the fine fault
        model later anyway. The choice is deterministic and independent of the
        row order in the CSV.
        """
        if layer not in self.layers:
            raise DatasetError(f"dataset {self.name!r}: unknown layer {layer!r}; "
                               f"layers are {self.layers}")
        b = self.boreholes
        sel = np.flatnonzero(b.layer == layer)
        out = np.zeros((0, 3))
        if sel.size:
            ids = b.hole_id[sel]
            # Sort by hole, then by decreasing z: the first row of each hole is
            # its shallowest hit.
            order = np.lexsort((-b.z[sel], ids))
            sel = sel[order]
            ids = ids[order]
            first = np.ones(len(sel), dtype=bool)
            first[1:] = ids[1:] != ids[:-1]
            sel = np.sort(sel[first])  # back to file order
            out = np.column_stack([b.xy[sel], b.z[sel]])
        extra = self.points.get(layer)
        if extra is not None and len(extra):
            out = np.vstack([out, np.asarray(extra, dtype=np.float64).reshape(-1, 3)])
        return np.ascontiguousarray(out, dtype=np.float64)

    def fault_groups(self) -> List[List[Fault]]:
        """Faults grouped for modelling: faults with the same ``group`` value
        together (in dataset order), faults without a group alone. Groups come
        in the order of their first fault."""
        groups: List[List[Fault]] = []
        index: Dict[str, int] = {}
        for f in self.faults:
            if f.group is None or f.group == "":
                groups.append([f])
            elif f.group in index:
                groups[index[f.group]].append(f)
            else:
                index[f.group] = len(groups)
                groups.append([f])
        return groups

    def fault(self, name: str) -> Fault:
        """The fault called ``name``."""
        for f in self.faults:
            if f.name == name:
                return f
        raise KeyError(f"dataset {self.name!r}: no fault {name!r}; faults are "
                       f"{[f.name for f in self.faults]}")

    def save(self, path) -> Path:
        """Write format v1: ``path`` is the JSON file (or a directory, which then
        receives ``<name>.json``); CSVs are written beside it. Atomic: every
        file is written to a temporary name first and renamed only when all
        of them are complete. Returns the JSON path."""
        return save_dataset(self, path)


def load_dataset(path) -> Dataset:
    """Load and validate a format-v1 dataset (JSON + CSVs); see DESIGN.md."""
    raise NotImplementedError("load_dataset: loader being written (data classes published first)")


def save_dataset(ds: Dataset, path) -> Path:
    raise NotImplementedError("Dataset.save: writer being written (data classes published first)")
