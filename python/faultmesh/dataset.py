"""Datasets: boreholes, section lines and fault traces (docs/design.md §3, docs/dataset.md).

The data classes here are the contract between the loader and the modelling
workflow (:func:`faultmesh.build_model`). Loading and saving of formats v1
and v2 (docs/dataset.md) is added below them.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

#: The format version :meth:`Dataset.save` writes by default (when the
#: dataset holds nothing that needs version 2).
FORMAT_VERSION = 1
#: The format versions :func:`load_dataset` reads (docs/dataset.md).
FORMAT_VERSIONS = (1, 2)


class DatasetError(ValueError):
    """A malformed dataset. The message names the file and the row (1-based, as a
    person counts the lines of a CSV, header = line 1) and the field, or the
    fault / trace / layer that is wrong."""


def _arr_eq(a, b) -> bool:
    a = np.asarray(a)
    b = np.asarray(b)
    return a.shape == b.shape and bool(np.array_equal(a, b))


@dataclass(eq=False)
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

    def __eq__(self, other) -> bool:
        if not isinstance(other, Section):
            return NotImplemented
        return (self.name == other.name and _arr_eq(self.origin, other.origin)
                and self.azimuth == other.azimuth)

    __hash__ = None  # type: ignore[assignment]

    def to_s(self, xy) -> np.ndarray:
        """Distance along the line (k,) of the orthogonal projection of ``xy`` (k, 2)."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return (xy - self.origin[None, :]) @ self.direction


@dataclass(eq=False)
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

    def __eq__(self, other) -> bool:
        if not isinstance(other, Trace):
            return NotImplemented
        if self.section != other.section or not _arr_eq(self.plane, other.plane):
            return False
        if list(self.layers) != list(other.layers):
            return False
        for lay, sides in self.layers.items():
            o = other.layers[lay]
            if sorted(sides) != sorted(o) or not all(_arr_eq(sides[k], o[k]) for k in sides):
                return False
        return True

    __hash__ = None  # type: ignore[assignment]


@dataclass(eq=False)
class Fault:
    """A fault: ``kind`` is "normal", "reverse" or None (derived from the data
    by :func:`faultmesh.derive.derive_faults`); faults sharing a ``group``
    value are modelled together (T- or X-crossings); ``tips`` (t, 2) are the
    pinch-out points in XY (t may be 0); ``traces`` are ordered along strike.

    The fault's geometry may also (or instead) be given as ``points`` (m, 3)
    on the fault surface (e.g. seismic fault picks), optionally grouped into
    fault sticks by ``sticks`` (m,) (any labels; None: no sticks), or as a
    triangulated ``surface`` (vertices (n, 3), triangles (t, 3)); traces
    without ``layers`` contribute their ``plane``. ``throw`` (e.g.
    ``{"max": 40.0}``, metres) is a hint used only where a side of the fault
    has no data near it. The cutoffs of such a fault are derived by
    :func:`faultmesh.derive.derive_faults` (``build_model`` calls it).
    ``derived``: the traces' cutoffs were derived by
    :func:`~faultmesh.derive.derive_faults` (which sets it) from the layer
    data, so the fault's patches stand for those data near it (the builder
    leaves the layer data under a derived fault's patches out of the
    continuous TINs and the patches honour them, :mod:`faultmesh.build`);
    format 2 saves it as ``"derived": true``, so that a saved derived dataset
    builds the model its source builds."""

    name: str
    kind: Optional[str] = None
    group: Optional[str] = None
    tips: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    traces: List[Trace] = field(default_factory=list)
    points: Optional[np.ndarray] = None
    sticks: Optional[np.ndarray] = None
    surface: Optional[Tuple[np.ndarray, np.ndarray]] = None
    throw: Optional[Dict[str, float]] = None
    derived: bool = False

    def __post_init__(self) -> None:
        self.tips = np.asarray(self.tips, dtype=np.float64).reshape(-1, 2)
        if self.kind not in ("normal", "reverse", None):
            raise DatasetError(f"fault {self.name!r}: kind must be 'normal', 'reverse' or None "
                               f"(derive it), got {self.kind!r}")
        if self.points is not None:
            pts = np.asarray(self.points, dtype=np.float64)
            if pts.ndim != 2 or pts.shape[1] != 3:
                raise DatasetError(f"fault {self.name!r}: points must have shape (m, 3), "
                                   f"got {pts.shape}")
            bad = ~np.isfinite(pts).all(axis=1)
            if bad.any():
                raise DatasetError(f"fault {self.name!r}: point {int(np.flatnonzero(bad)[0]) + 1} "
                                   "is not finite")
            far = ~(np.abs(pts) <= COORD_MAX).all(axis=1)
            if far.any():
                raise DatasetError(f"fault {self.name!r}: point {int(np.flatnonzero(far)[0]) + 1} "
                                   f"has a coordinate beyond +-{COORD_MAX:g}")
            self.points = pts
            if self.sticks is not None:
                self.sticks = np.asarray(self.sticks).reshape(-1)
                if len(self.sticks) != len(pts):
                    raise DatasetError(f"fault {self.name!r}: sticks has {len(self.sticks)} "
                                       f"labels for {len(pts)} points")
        elif self.sticks is not None:
            raise DatasetError(f"fault {self.name!r}: sticks given without points")
        if self.surface is not None:
            try:
                V, T = self.surface
            except (TypeError, ValueError):
                raise DatasetError(f"fault {self.name!r}: surface must be (vertices, "
                                   "triangles)") from None
            V = np.asarray(V, dtype=np.float64)
            T = np.asarray(T)
            if V.ndim != 2 or V.shape[1] != 3 or not np.isfinite(V).all():
                raise DatasetError(f"fault {self.name!r}: surface vertices must be finite (n, 3)")
            far = ~(np.abs(V) <= COORD_MAX).all(axis=1)
            if far.any():
                raise DatasetError(f"fault {self.name!r}: surface vertex "
                                   f"{int(np.flatnonzero(far)[0]) + 1} has a coordinate beyond "
                                   f"+-{COORD_MAX:g}")
            if T.ndim != 2 or T.shape[1] != 3 or (T.size and (T.min() < 0 or T.max() >= len(V))):
                raise DatasetError(f"fault {self.name!r}: surface triangles must be (t, 3) "
                                   f"indices into its {len(V)} vertices")
            self.surface = (V, T.astype(np.int64))
        if self.throw is not None:
            if not isinstance(self.throw, dict) or set(self.throw) - {"max"}:
                raise DatasetError(f"fault {self.name!r}: throw must be a dict like "
                                   f"{{'max': 40.0}}, got {self.throw!r}")
            m = self.throw.get("max")
            if m is not None and not (isinstance(m, (int, float)) and np.isfinite(m) and m > 0):
                raise DatasetError(f"fault {self.name!r}: throw max must be a number > 0, got {m!r}")

    def __eq__(self, other) -> bool:
        if not isinstance(other, Fault):
            return NotImplemented
        def opt(a, b):
            return (a is None) == (b is None) and (a is None or _arr_eq(a, b))
        return (self.name == other.name and self.kind == other.kind
                and self.group == other.group and _arr_eq(self.tips, other.tips)
                and self.traces == other.traces and opt(self.points, other.points)
                and opt(self.sticks, other.sticks) and self.throw == other.throw
                and (self.surface is None) == (other.surface is None)
                and (self.surface is None or all(_arr_eq(a, b) for a, b in
                                                 zip(self.surface, other.surface))))

    __hash__ = None  # type: ignore[assignment]


def _factorize(a: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """``np.unique(a, return_inverse=True)`` of a 1-D str array, without
    sorting every string: the rows are grouped by a 64-bit hash of their code
    points (one integer sort), the grouping is verified string by string (a
    hash collision falls back to np.unique), and only the distinct strings are
    sorted. A 10M-row table of 1M hole ids: seconds instead of tens."""
    a = np.asarray(a).reshape(-1)
    n = len(a)
    if n < 100_000 or a.dtype.kind != "U" or a.dtype.itemsize == 0:
        names, inv = np.unique(a, return_inverse=True)
        return names, inv.reshape(-1)
    cp = np.ascontiguousarray(a).view(np.uint32).reshape(n, -1)  # UCS-4, zero padded
    h = np.full(n, 0xCBF29CE484222325, dtype=np.uint64)
    with np.errstate(over="ignore"):
        for k in range(cp.shape[1]):  # FNV-1a over the code points (wraps mod 2^64)
            h ^= cp[:, k]
            h *= np.uint64(0x100000001B3)
    # A column of few distinct values (layer names): the distinct hashes of a
    # sample, and every row found among them by binary search -- no sort of
    # the whole column. Otherwise (hole ids) one integer sort.
    few = np.unique(h[:: max(1, n // 4096)])
    pos = np.minimum(np.searchsorted(few, h), len(few) - 1) if len(few) <= 256 else None
    if pos is not None and np.array_equal(few[pos], h):
        inv = pos
        first = np.full(len(few), n, dtype=np.int64)
        np.minimum.at(first, inv, np.arange(n, dtype=np.int64))
    else:
        # Tables list a hole's rows together: one integer sort of the runs'
        # hashes instead of the rows' (a value's first run holds its first row).
        heads = np.flatnonzero(np.r_[True, h[1:] != h[:-1]])
        _, first_run, run_inv = np.unique(h[heads], return_index=True, return_inverse=True)
        first = heads[first_run]
        inv = np.repeat(run_inv.reshape(-1), np.diff(np.r_[heads, n]))
    reps = a[first]
    if not np.array_equal(reps[inv], a):  # two strings with one hash
        names, inv = np.unique(a, return_inverse=True)
        return names, inv.reshape(-1)
    names, rank = np.unique(reps, return_inverse=True)
    return names, rank.reshape(-1)[inv]


@dataclass(eq=False)
class Boreholes:
    """Borehole layer tops, one row per hit: ``hole_id`` (n,) str, ``xy`` (n, 2),
    ``layer`` (n,) str, ``z`` (n,) elevation of the top of ``layer``. A
    (hole_id, layer) pair may repeat (reverse-fault repetition).

    ``desurveyed``: the rows are layer tops desurveyed along the holes of
    collar/survey/interval tables (:mod:`faultmesh.drillholes`), so the rows
    of one deviated hole have their own XY; False for a plain
    ``hole_id,x,y,layer,z`` table, whose rows of one hole must share one XY
    (:func:`check_hole_positions`)."""

    hole_id: np.ndarray
    xy: np.ndarray
    layer: np.ndarray
    z: np.ndarray
    #: Where the rows come from, for messages: the CSV's name and each row's
    #: 1-based line number in it (header = 1). None for data made in memory.
    source: Optional[str] = None
    rows: Optional[np.ndarray] = None
    desurveyed: bool = False

    def __post_init__(self) -> None:
        self.hole_id = np.asarray(self.hole_id, dtype=str).reshape(-1)
        self.xy = np.asarray(self.xy, dtype=np.float64).reshape(-1, 2)
        self.layer = np.asarray(self.layer, dtype=str).reshape(-1)
        self.z = np.asarray(self.z, dtype=np.float64).reshape(-1)
        n = len(self.hole_id)
        if not (len(self.xy) == len(self.layer) == len(self.z) == n):
            raise DatasetError("Boreholes: hole_id, xy, layer and z must have the same number "
                               f"of rows, got {n}, {len(self.xy)}, {len(self.layer)}, {len(self.z)}")
        if self.rows is not None:
            self.rows = np.asarray(self.rows, dtype=np.int64).reshape(-1)
            if len(self.rows) != n:
                self.rows = None  # numbering no longer matches: fall back to row indices

    @classmethod
    def empty(cls, source: Optional[str] = None, desurveyed: bool = False) -> "Boreholes":
        """No rows (the layer data come from ``points`` alone)."""
        return cls(np.zeros(0, dtype=str), np.zeros((0, 2)), np.zeros(0, dtype=str), np.zeros(0),
                   source, None if source is None else np.zeros(0, dtype=np.int64), desurveyed)

    @property
    def codes(self):
        """(layer names, layer code per row, hole code per row, hole names):
        the string columns as integers, computed once (the arrays must not be
        changed in place afterwards)."""
        cache = self.__dict__.get("_codes")
        if cache is None:
            names, lc = _factorize(self.layer)
            holes, hc = _factorize(self.hole_id)
            cache = (list(names), lc.astype(np.int64), hc.astype(np.int64), holes)
            self.__dict__["_codes"] = cache
        return cache

    @property
    def hole_rows(self):
        """(first, inverse): the first row of each hole (by hole code) and,
        per row, its hole's index into ``first``; computed once like
        :attr:`codes`."""
        cache = self.__dict__.get("_hole_rows")
        if cache is None:
            _, _, hcode, holes = self.codes
            # np.unique(hcode, return_index=True, return_inverse=True) without
            # its sort: the first row of each code by a minimum, the present
            # codes (a subset may have lost holes) numbered in order.
            n = len(hcode)
            by_code = np.full(len(holes), n, dtype=np.int64)
            np.minimum.at(by_code, hcode, np.arange(n, dtype=np.int64))
            present = by_code < n
            cache = (by_code[present], (np.cumsum(present) - 1)[hcode])
            self.__dict__["_hole_rows"] = cache
        return cache

    @property
    def hole_offset(self) -> np.ndarray:
        """float (n,): each row's map distance from its hole's first row
        (0 exactly where the XY are equal), computed once like :attr:`codes`."""
        cache = self.__dict__.get("_hole_offset")
        if cache is None:
            first, inv = self.hole_rows
            ref = self.xy[first[inv]]
            cache = np.hypot(self.xy[:, 0] - ref[:, 0], self.xy[:, 1] - ref[:, 1])
            self.__dict__["_hole_offset"] = cache
        return cache

    def row_label(self, i: int) -> str:
        """A readable name of row ``i``: ``boreholes.csv row 17 (hole 'BH3', layer 'L0')``."""
        what = f"hole {str(self.hole_id[i])!r}, layer {str(self.layer[i])!r}"
        if self.source is not None and self.rows is not None:
            return f"{self.source} row {int(self.rows[i])} ({what})"
        return f"borehole row {i + 1} ({what})"

    @property
    def shallowest(self):
        """bool (n,): the rows that are their hole's shallowest hit of their
        layer (ties: the first such row), computed once like :attr:`codes`.
        One sort of the whole table: per layer it would cost a sort each."""
        cache = self.__dict__.get("_shallowest")
        if cache is None:
            _, lc, hc, holes = self.codes
            cache = np.zeros(len(lc), dtype=bool)
            cells = len(holes) * max(1, len(self.codes[0]))
            if len(lc) and cells <= 8 * len(lc):
                # Usually no (layer, hole) pair repeats (no reverse fault hit
                # twice): every row is its pair's shallowest, seen by marking
                # the pairs on a dense grid, without the sort below.
                seen = np.zeros(cells, dtype=bool)
                seen[hc * max(1, len(self.codes[0])) + lc] = True
                if int(np.count_nonzero(seen)) == len(lc):
                    cache[:] = True
                    self.__dict__["_shallowest"] = cache
                    return cache
            if len(lc):
                # Groups (layer, hole) by one stable integer sort (a lexsort
                # with z as a third key costs 8x more), the group maxima of z
                # by reduceat, then the first row of each group at its maximum.
                order = np.argsort(lc * np.int64(len(holes)) + hc, kind="stable")
                key = (lc * np.int64(len(holes)) + hc)[order]
                start = np.r_[True, key[1:] != key[:-1]]
                grp = np.cumsum(start) - 1
                zs = self.z[order]
                top = np.flatnonzero(zs == np.maximum.reduceat(zs, np.flatnonzero(start))[grp])
                g = grp[top]
                cache[order[top[np.r_[True, g[1:] != g[:-1]]]]] = True
            self.__dict__["_shallowest"] = cache
        return cache

    def moved(self, xy: np.ndarray) -> "Boreholes":
        """The same rows at the positions ``xy`` (n, 2) (string codes kept,
        and the caches that do not depend on XY: :attr:`hole_rows`,
        :attr:`shallowest`)."""
        out = Boreholes(self.hole_id, xy, self.layer, self.z, self.source, self.rows,
                        self.desurveyed)
        out.__dict__["_codes"] = self.codes
        for key in ("_hole_rows", "_shallowest"):
            if key in self.__dict__:
                out.__dict__[key] = self.__dict__[key]
        return out

    def subset(self, keep: np.ndarray) -> "Boreholes":
        """The rows where ``keep`` (bool (n,)) is True, with their source rows."""
        out = Boreholes(self.hole_id[keep], self.xy[keep], self.layer[keep], self.z[keep],
                        self.source, None if self.rows is None else self.rows[keep],
                        self.desurveyed)
        # The string columns' codes stay valid for a subset (a hole left with
        # no rows keeps its code): computed once for the whole table and
        # carried (np.unique of strings is the slowest step of preparing a
        # 500k-row table, and the input policy takes several subsets).
        names, lc, hc, holes = self.codes
        out.__dict__["_codes"] = (names, lc[keep], hc[keep], holes)
        return out

    def __len__(self) -> int:
        return int(len(self.hole_id))

    def __eq__(self, other) -> bool:
        """Equal rows (``source``, ``rows`` and ``desurveyed``, where the rows
        come from, are not compared)."""
        if not isinstance(other, Boreholes):
            return NotImplemented
        return (_arr_eq(self.hole_id, other.hole_id) and _arr_eq(self.xy, other.xy)
                and _arr_eq(self.layer, other.layer) and _arr_eq(self.z, other.z))

    __hash__ = None  # type: ignore[assignment]

    @property
    def n_holes(self) -> int:
        return int(len(np.unique(self.hole_id)))


@dataclass(eq=False)
class Dataset:
    """A dataset in memory (formats v1 and v2, docs/dataset.md). ``boreholes``
    may have no rows, or be None (taken as no rows), when ``points`` carry the
    layer data."""

    name: str
    layers: List[str]
    boundary: np.ndarray
    boreholes: Optional[Boreholes] = None
    points: Dict[str, np.ndarray] = field(default_factory=dict)
    sections: Dict[str, Section] = field(default_factory=dict)
    faults: List[Fault] = field(default_factory=list)
    crs: str = ""
    path: Optional[Path] = None
    truth: Optional[Callable[[str, np.ndarray, np.ndarray], np.ndarray]] = None
    #: The ground-truth model (:class:`faultmesh.geology.Geology`) of a generated
    #: dataset, None for loaded ones. ``truth`` is its ``truth`` method.
    geology: Optional[Any] = None
    #: The snap distance set for this dataset (the JSON key ``snap_distance``
    #: or ``load_dataset(snap=...)``); None = the default (:func:`default_snap_distance`).
    snap_distance: Optional[float] = None
    #: What the input policy changed or noticed (:class:`Adjustment` records:
    #: points snapped onto the boundary, data clipped or dropped beyond it,
    #: warnings about the layer order), in the order they were made.
    adjustments: List["Adjustment"] = field(default_factory=list)
    #: Where each layer's extra points come from, for messages: layer ->
    #: (CSV name, 1-based line numbers) or (JSON label, None) for inline points.
    point_sources: Dict[str, Tuple[str, Optional[np.ndarray]]] = field(default_factory=dict)
    #: The report of :func:`faultmesh.derive.derive_faults` on a dataset it
    #: returned (None otherwise); not compared.
    derivation: Optional[Any] = None
    #: The collar/survey/interval tables the boreholes were desurveyed from
    #: (:class:`faultmesh.drillholes.DrillholeTables`, format v2), None for a
    #: plain ``hole_id,x,y,layer,z`` table or data made in memory. Kept so that
    #: :meth:`save` writes the tables back; not compared (the tops are).
    drillholes: Optional[Any] = None
    #: Points the fault derivation adds to a layer known much more sparsely
    #: than another (layer -> (m, 3)): the layer conformable to that one
    #: (:func:`faultmesh.derive._conformable_points`, docs/derive.md). Not
    #: data: :func:`faultmesh.derive.layer_data` leaves them out (unless
    #: asked with ``derived=True``, as the side surfaces and patches do), the
    #: continuous TIN (:meth:`layer_points`) takes them after the layer's
    #: own points; not compared; :meth:`save` writes them with the layer's
    #: points (the saved dataset's faults carry the derived cutoffs, so
    #: nothing is derived from it again: the points stay as data).
    derived_points: Dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.boreholes is None:
            self.boreholes = Boreholes.empty()
        elif not isinstance(self.boreholes, Boreholes):
            raise DatasetError(f"Dataset {self.name!r}: boreholes must be a Boreholes table or None, "
                               f"got {type(self.boreholes).__name__}")
        self.layers = [str(v) for v in self.layers]
        self.boundary = np.asarray(self.boundary, dtype=np.float64).reshape(-1, 2)
        self.points = {str(k): np.asarray(v, dtype=np.float64).reshape(-1, 3)
                       for k, v in self.points.items()}
        self.derived_points = {str(k): np.asarray(v, dtype=np.float64).reshape(-1, 3)
                               for k, v in self.derived_points.items()}
        self.adjustments = list(self.adjustments)

    def point_label(self, layer: str, i: int) -> str:
        """A readable name of extra point ``i`` of ``layer``: ``topo.csv row 5``
        or ``points['top'] point 5``."""
        label, rows = self.point_sources.get(layer, (f"points[{layer!r}]", None))
        if rows is not None and i < len(rows):
            return f"{label} row {int(rows[i])}"
        return f"{label} point {i + 1}"

    def __eq__(self, other) -> bool:
        """Equal data (name, crs, layers, boundary, boreholes, points, sections,
        faults, with their points, sticks, surface and throw); ``path``,
        ``truth``, ``geology``, ``snap_distance``, ``adjustments``,
        ``point_sources``, ``derived_points`` and ``drillholes`` (the source
        tables: the tops desurveyed from them are compared) are not compared."""
        if not isinstance(other, Dataset):
            return NotImplemented
        return (self.name == other.name and self.crs == other.crs
                and self.layers == other.layers
                and _arr_eq(self.boundary, other.boundary)
                and self.boreholes == other.boreholes
                and self.points.keys() == other.points.keys()
                and all(_arr_eq(self.points[k], other.points[k]) for k in self.points)
                and self.sections == other.sections
                and self.faults == other.faults)

    __hash__ = None  # type: ignore[assignment]

    def allclose(self, other: "Dataset", atol: float = 1e-6) -> bool:
        """Like ``==`` but coordinates may differ by ``atol`` (e.g. after a
        save with ``section_coords=True``, which converts XY to [s, z])."""
        def close(a, b):
            a = np.asarray(a, dtype=np.float64)
            b = np.asarray(b, dtype=np.float64)
            return a.shape == b.shape and bool(np.allclose(a, b, rtol=0.0, atol=atol))

        if not (self.name == other.name and self.crs == other.crs and self.layers == other.layers
                and close(self.boundary, other.boundary)
                and _arr_eq(self.boreholes.hole_id, other.boreholes.hole_id)
                and _arr_eq(self.boreholes.layer, other.boreholes.layer)
                and close(self.boreholes.xy, other.boreholes.xy)
                and close(self.boreholes.z, other.boreholes.z)
                and self.points.keys() == other.points.keys()
                and all(close(self.points[k], other.points[k]) for k in self.points)
                and list(self.sections) == list(other.sections)
                and all(a.name == b.name and close(a.origin, b.origin) and a.azimuth == b.azimuth
                        for a, b in zip(self.sections.values(), other.sections.values()))
                and len(self.faults) == len(other.faults)):
            return False
        def opt_close(a, b):
            return (a is None) == (b is None) and (a is None or close(a, b))

        for f, g in zip(self.faults, other.faults):
            if (f.name, f.kind, f.group) != (g.name, g.kind, g.group) or not close(f.tips, g.tips) \
                    or len(f.traces) != len(g.traces):
                return False
            if not (opt_close(f.points, g.points) and f.throw == g.throw
                    and ((f.sticks is None) == (g.sticks is None))
                    and (f.sticks is None or _arr_eq(f.sticks, g.sticks))
                    and (f.surface is None) == (g.surface is None)
                    and (f.surface is None or (close(f.surface[0], g.surface[0])
                                               and _arr_eq(f.surface[1], g.surface[1])))):
                return False
            for s, t in zip(f.traces, g.traces):
                if s.section != t.section or not close(s.plane, t.plane) \
                        or list(s.layers) != list(t.layers):
                    return False
                for lay in s.layers:
                    if sorted(s.layers[lay]) != sorted(t.layers[lay]) or not all(
                            close(s.layers[lay][k], t.layers[lay][k]) for k in s.layers[lay]):
                        return False
        return True

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
        names, lcode, _, _ = b.codes
        out = np.zeros((0, 3))
        if layer in names:
            # Each hole's shallowest hit of the layer, in file order.
            sel = np.flatnonzero((lcode == names.index(layer)) & b.shallowest)
            out = np.column_stack([b.xy[sel], b.z[sel]])
        return self._with_extra_points(layer, out)

    def _with_extra_points(self, layer: str, hits: np.ndarray, derived: bool = True) -> np.ndarray:
        """A layer's borehole hits (n, 3) followed by its extra points and
        then (with ``derived``) its derived points."""
        for extra in (self.points.get(layer), self.derived_points.get(layer) if derived else None):
            if extra is not None and len(extra):
                hits = np.vstack([hits, np.asarray(extra, dtype=np.float64).reshape(-1, 3)])
        return np.ascontiguousarray(hits, dtype=np.float64)

    def all_layer_points(self) -> Dict[str, np.ndarray]:
        """:meth:`layer_points` of every layer (layer -> (n, 3)), the same
        arrays, from one pass over the borehole table: the shallowest hits
        grouped by layer with one stable integer sort (a radix sort), instead
        of a scan of the whole table per layer."""
        b = self.boreholes
        names, lcode, _, _ = b.codes
        sel = np.flatnonzero(b.shallowest)
        # 16-bit keys: numpy's stable sort of them is a radix sort.
        key = lcode[sel].astype(np.int16 if len(names) < 2**15 else np.int64)
        order = sel[np.argsort(key, kind="stable")]
        cut = np.searchsorted(lcode[order], np.arange(len(names) + 1))
        # One gather of every selected row; each layer is a contiguous slice.
        allp = np.empty((len(order), 3))
        allp[:, :2] = b.xy[order]
        allp[:, 2] = b.z[order]
        out: Dict[str, np.ndarray] = {}
        for lay in self.layers:
            pts = np.zeros((0, 3))
            if lay in names:
                k = names.index(lay)
                pts = allp[cut[k]:cut[k + 1]]
            out[lay] = self._with_extra_points(lay, pts)
        return out

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

    def save(self, path, *, section_coords: bool = False, version: Optional[int] = None) -> Path:
        """Write the dataset and return the JSON path.

        ``version``: the format version, 1 or 2; None (default) writes
        version 1 unless the dataset needs version 2 (a fault without kind or
        traces, or with points, a surface or a throw; boreholes from
        drillhole tables). ``version=1`` for a dataset that needs 2 is a
        :class:`DatasetError` saying why. Version 2 writes fault points as
        ``fault_<name>_points.csv`` and fault surfaces as
        ``fault_<name>_surface.ts`` (GOCAD TSurf), and boreholes loaded from
        drillhole tables as those tables (``collars.csv``, ``surveys.csv``,
        ``intervals.csv``) as long as they still give the boreholes (else,
        and for ``version=1``, the tops as a ``hole_id,x,y,layer,z`` table,
        which fails for the tops of deviated holes: a table row's hole has
        one XY); a dataset without borehole rows gets no ``boreholes`` key.

        ``path`` ending in ``.json`` names the JSON file, data files are
        written beside it as ``<stem>_boreholes.csv``, ``<stem>_points_<layer>.csv``
        and so on; any other ``path`` is a directory (created if needed) that
        receives ``dataset.json``, ``boreholes.csv``, ``points_<layer>.csv`` ...
        ``section_coords=True`` writes trace points as section-local ``[s, z]``
        where a trace names a section and its points lie on that section's line
        (within 1 mm), as interpreted section views are usually digitised.
        Atomic: every file goes to a temporary name first; the files are renamed
        into place only when all were written, the JSON last, so an error
        leaves no half-written dataset (and the previous files untouched)."""
        return save_dataset(self, path, section_coords=section_coords, version=version)




# ---------------------------------------------------------------------------
# Exact 2D geometry on the boundary (orientation decisions via orient2d)
# ---------------------------------------------------------------------------
def _orient_sign(a, b, c) -> np.ndarray:
    from ._core import orient2d
    a = np.ascontiguousarray(np.asarray(a, dtype=np.float64).reshape(-1, 2))
    b = np.ascontiguousarray(np.asarray(b, dtype=np.float64).reshape(-1, 2))
    c = np.ascontiguousarray(np.asarray(c, dtype=np.float64).reshape(-1, 2))
    if len(a) == 0:
        return np.zeros(0)
    return np.sign(orient2d(a, b, c))


def _ring_orientation(ring: np.ndarray) -> float:
    """+1 counter-clockwise, -1 clockwise, for a simple ring (exact: the turn
    at the lexicographically smallest vertex, which is convex)."""
    i = int(np.lexsort((ring[:, 1], ring[:, 0]))[0])
    n = len(ring)
    return float(_orient_sign(ring[(i - 1) % n], ring[i], ring[(i + 1) % n])[0])


def _segments_intersect(p1, p2, q1, q2) -> np.ndarray:
    """Closed segments p1p2 and q1q2 (arrays (m, 2)) share a point; exact."""
    o1 = _orient_sign(p1, p2, q1)
    o2 = _orient_sign(p1, p2, q2)
    o3 = _orient_sign(q1, q2, p1)
    o4 = _orient_sign(q1, q2, p2)
    hit = (o1 * o2 <= 0) & (o3 * o4 <= 0)
    col = (o1 == 0) & (o2 == 0) & (o3 == 0) & (o4 == 0)
    if col.any():
        # Collinear: they meet iff their bounding boxes overlap (exact comparisons).
        lo_p = np.minimum(p1, p2)
        hi_p = np.maximum(p1, p2)
        lo_q = np.minimum(q1, q2)
        hi_q = np.maximum(q1, q2)
        overlap = np.all((lo_p <= hi_q) & (lo_q <= hi_p), axis=1)
        hit = np.where(col, overlap, hit)
    return hit


def _boundary_problem(ring: np.ndarray) -> Optional[str]:
    """Why ``ring`` (k, 2), implicitly closed, is not a simple polygon, or None."""
    n = len(ring)
    if n < 3:
        return f"needs at least 3 vertices, got {n}"
    nxt = np.roll(ring, -1, axis=0)
    same = np.all(ring == nxt, axis=1)
    if same.any():
        i = int(np.flatnonzero(same)[0])
        return f"vertices {i} and {(i + 1) % n} coincide"
    # Spikes: consecutive edges that fold back onto each other.
    prv = np.roll(ring, 1, axis=0)
    turn = _orient_sign(prv, ring, nxt)
    if np.all(turn == 0):
        return "all vertices are collinear (zero area)"
    for i in np.flatnonzero(turn == 0):
        p, q, r = prv[i], ring[i], nxt[i]
        k = 0 if p[0] != q[0] else 1
        if (p[k] < q[k]) == (r[k] < q[k]):
            return f"edges at vertex {i} fold back onto each other"
    # Non-adjacent edges must not meet (this also catches repeated vertices
    # and rings touching themselves).
    ii, jj = np.triu_indices(n, k=2)
    keep = ~((ii == 0) & (jj == n - 1))
    ii, jj = ii[keep], jj[keep]
    if len(ii):
        hit = _segments_intersect(ring[ii], nxt[ii], ring[jj], nxt[jj])
        if hit.any():
            k = int(np.flatnonzero(hit)[0])
            a, b = int(ii[k]), int(jj[k])
            return (f"is self-intersecting: edge {a} ({a}-{(a + 1) % n}) meets edge {b} "
                    f"({b}-{(b + 1) % n})")
    return None


def points_in_polygon(points, ring) -> np.ndarray:
    """Exact test: True for points (m, 2) inside or on the closed ring (k, 2).

    For a polygon with area this is :meth:`faultmesh.StudyArea.contains`
    with tolerance 0 (exact winding, O(log k) per point); a degenerate ring
    (fewer than 3 distinct points, zero area) is tested here directly."""
    from ._core import StudyArea

    P = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    R = np.asarray(ring, dtype=np.float64).reshape(-1, 2)
    try:
        area = StudyArea(R, tolerance=0.0)
    except ValueError:  # GeometryError is a ValueError
        area = None
    if area is not None:
        return area.contains(P)
    m, k = len(P), len(R)
    if m == 0:
        return np.zeros(0, dtype=bool)
    A = np.repeat(R[None, :, :], m, axis=0).reshape(-1, 2)
    B = np.repeat(np.roll(R, -1, axis=0)[None, :, :], m, axis=0).reshape(-1, 2)
    Q = np.repeat(P, k, axis=0)
    o = _orient_sign(A, B, Q).reshape(m, k)
    A = A.reshape(m, k, 2)
    B = B.reshape(m, k, 2)
    Q = Q.reshape(m, k, 2)
    on = (o == 0) & np.all((np.minimum(A, B) <= Q) & (Q <= np.maximum(A, B)), axis=2)
    ay, by, qy = A[..., 1], B[..., 1], Q[..., 1]
    up = (ay <= qy) & (qy < by) & (o > 0)      # upward edge, point strictly left
    down = (by <= qy) & (qy < ay) & (o < 0)    # downward edge, point strictly right
    winding = up.sum(axis=1) - down.sum(axis=1)
    return (winding != 0) | on.any(axis=1)


# ---------------------------------------------------------------------------
# The input tolerance policy: snap distance, data beyond the boundary, records
# ---------------------------------------------------------------------------
#: Absolute cap of the default snap distance, in metres (dataset units).
#: Surveyed coordinates are written to 0.1 mm .. 1 cm. A point on a side
#: rounded to 1 cm is at most 0.5 cm x sqrt(2) = 7.1 mm from the side (slanted
#: side, both coordinates off by half a unit); the same holds when the boundary
#: was rounded and the point was not, and 14.1 mm when both were rounded to
#: 1 cm independently. 2 cm covers all of these with margin and is still below
#: what a collar survey can resolve (GNSS RTK: 1-2 cm horizontally) and three
#: orders of magnitude below any triangle of a model (tens of metres).
SNAP_ABSOLUTE = 0.02
#: Relative cap of the default snap distance: this share of the diagonal of
#: the boundary's bounding box. The builder spaces boundary vertices at least
#: perimeter / 4000 apart (build.LayerTin), about 1e-3 of the area's size, so
#: a move of 1e-5 of it stays ~100x below the finest boundary spacing: it never
#: changes which part of a side a point belongs to, and a hand-made test
#: geometry of a few units is moved by no more than 1e-5 of its size. For the
#: 2.5-6 km areas of real studies this is 2.5-8.5 cm, so SNAP_ABSOLUTE rules.
SNAP_RELATIVE = 1e-5


def default_snap_distance(boundary) -> float:
    """The default snap distance of a study area: ``min(SNAP_ABSOLUTE,
    SNAP_RELATIVE x the diagonal of the boundary's bounding box)`` (2 cm for
    any area wider than 2 km; see the constants for why)."""
    b = np.asarray(boundary, dtype=np.float64).reshape(-1, 2)
    if len(b) == 0:
        return SNAP_ABSOLUTE
    diag = float(np.hypot(*(b.max(axis=0) - b.min(axis=0))))
    return min(SNAP_ABSOLUTE, SNAP_RELATIVE * diag)


def on_boundary_tolerance(boundary) -> float:
    """Distance under which a point counts as ON the boundary without being
    moved: 64 units in the last place of the largest coordinate, the builder's
    own on-side tolerance (build._on_segment_tol). A point moved onto a slanted
    side lands within a few units in the last place of it (the projection is
    rounded), so the policy leaves such points where they are the second time
    (idempotent), and the builder takes them as boundary vertices."""
    b = np.asarray(boundary, dtype=np.float64)
    return 64.0 * 2.0 ** -53 * max(1.0, float(np.abs(b).max()) if b.size else 1.0)


@dataclass(frozen=True)
class Adjustment:
    """One change (or remark) the input policy made.

    ``what``: ``"snapped"`` (moved onto the boundary), ``"clipped"`` (a
    polyline cut where it leaves the study area: ``after`` is the new end on
    the boundary, ``before`` the vertex beyond it), ``"dropped"`` (removed:
    beyond the boundary, or a part left without the data it needs),
    ``"kept"`` (data beyond the boundary deliberately left as they are: a
    fault's points or surface vertices; ``before`` = ``after`` = the farthest
    one, ``distance`` its distance from the boundary) or ``"warning"``
    (nothing changed; ``note`` says what looks wrong).
    ``item``: a readable name, e.g. ``fault 'F0' trace 1 layer 'L0' foot point 3``
    or ``boreholes.csv row 17 (hole 'BH3', layer 'L0')``. ``before``/``after``:
    XY, or None. ``distance``: for ``snapped`` the length of the move, for
    ``clipped``/``dropped`` how far ``before`` lies from the boundary (m)."""

    what: str
    item: str
    before: Optional[Tuple[float, float]] = None
    after: Optional[Tuple[float, float]] = None
    distance: Optional[float] = None
    note: str = ""

    def to_dict(self) -> Dict[str, Any]:
        return {"what": self.what, "item": self.item,
                "before": None if self.before is None else [float(v) for v in self.before],
                "after": None if self.after is None else [float(v) for v in self.after],
                "distance": None if self.distance is None else float(self.distance),
                "note": self.note}


def _xy(p) -> Tuple[float, float]:
    return (float(p[0]), float(p[1]))


def _fmt_len(d: float) -> str:
    if d < 1e-3:
        return f"{d * 1e3:.3g} mm"
    if d < 1.0:
        return f"{d * 1e3:.1f} mm"
    return f"{d:.3f} m"


def adjustment_counts(adjustments: Sequence[Adjustment]) -> Dict[str, Dict[str, Any]]:
    """Per kind (snapped, clipped, dropped, kept, warning): ``count`` and the
    largest ``distance`` (None when no record of the kind has one)."""
    out: Dict[str, Dict[str, Any]] = {}
    for what in ("snapped", "clipped", "dropped", "kept", "warning"):
        sel = [a for a in adjustments if a.what == what]
        ds = [a.distance for a in sel if a.distance is not None]
        out[what] = {"count": len(sel), "largest_distance": max(ds) if ds else None}
    return out


def summarize_adjustments(adjustments: Sequence[Adjustment],
                          snap: Optional[float] = None) -> str:
    """One paragraph for people: counts per kind and the largest distances."""
    c = adjustment_counts(adjustments)
    parts = []
    if c["snapped"]["count"]:
        parts.append(f"{c['snapped']['count']} point(s) snapped onto the study-area boundary "
                     f"(largest move {_fmt_len(c['snapped']['largest_distance'])})")
    if c["clipped"]["count"]:
        parts.append(f"{c['clipped']['count']} fault polyline(s) clipped at the boundary "
                     f"(farthest vertex cut off {_fmt_len(c['clipped']['largest_distance'])} "
                     "beyond it)")
    if c["dropped"]["count"]:
        d = c["dropped"]["largest_distance"]
        far = f" (farthest {_fmt_len(d)} beyond the boundary)" if d is not None else ""
        parts.append(f"{c['dropped']['count']} item(s) dropped{far}")
    if c["kept"]["count"]:
        parts.append(f"fault data beyond the boundary kept for the fault surface fit "
                     f"({c['kept']['count']} fault source(s), farthest point "
                     f"{_fmt_len(c['kept']['largest_distance'])} beyond it)")
    snap_txt = f" (snap distance {_fmt_len(snap)})" if snap is not None else ""
    if not parts:
        text = f"input: all data lie inside the study area{snap_txt}; nothing was snapped, " \
               "clipped or dropped."
    else:
        text = f"input{snap_txt}: " + "; ".join(parts) + "."
    warns = [a for a in adjustments if a.what == "warning"]
    if warns:
        text += f" {len(warns)} warning(s): " + " ".join(
            f"{a.item}: {a.note}" for a in warns[:3]) + (" ..." if len(warns) > 3 else "")
    return text


def _chunks(m: int, k: int, budget: int = 1_000_000):
    step = max(1, budget // max(1, k))
    for s in range(0, m, step):
        yield s, min(m, s + step)


def _nearest_on_boundary(P: np.ndarray, area, within: float = np.inf):
    """Distance (m,), side index (m,) and nearest point (m, 2) of points P on
    the boundary of ``area`` (a :class:`faultmesh.StudyArea`; sides numbered
    along its counter-clockwise ring). The point is placed on its side by
    :meth:`StudyArea.place`: corners and axis-parallel sides are hit exactly,
    so a point moved there has an exact orient2d of 0 against its side."""
    P = np.ascontiguousarray(np.asarray(P, dtype=np.float64).reshape(-1, 2))
    if len(P) == 0:
        return np.empty(0), np.empty(0, dtype=np.int64), np.empty((0, 2))
    side, s, dist = area.nearest(P, within)
    far = side < 0                        # nothing within `within`: distance inf, Q = P
    side[far] = 0
    s[far] = 0.0
    Q = area.place(side, s)
    Q[far] = P[far]
    # A point exactly on its side (distance 0 by the exact test) is its own
    # nearest point; elsewhere the distance is that of the placed point.
    on = dist == 0.0
    Q[on] = P[on]
    dist = np.where(on, 0.0, np.hypot(P[:, 0] - Q[:, 0], P[:, 1] - Q[:, 1]))
    dist[far] = np.inf
    return dist, side, Q


def _inside_or_on(P: np.ndarray, ring: np.ndarray) -> np.ndarray:
    return points_in_polygon(P, ring)


class _Snapper:
    """Classification of points against the study area under the policy."""

    def __init__(self, ring: np.ndarray, snap: float) -> None:
        from ._core import StudyArea

        self.area = StudyArea(ring)
        self.ring = ring = np.ascontiguousarray(self.area.ring)  # counter-clockwise, as its sides
        self.snap = float(snap)
        self.on_tol = on_boundary_tolerance(ring)
        a = ring
        d = np.roll(ring, -1, axis=0) - a
        self.slanted = (d[:, 0] != 0.0) & (d[:, 1] != 0.0)

    def classify(self, P: np.ndarray):
        """For points P (m, 2): (new XY, moved (m,) bool, distance of the
        original point from the boundary (m,), in (m,) bool: inside, on, or
        within the snap distance)."""
        P = np.asarray(P, dtype=np.float64).reshape(-1, 2)
        # Only the points near the boundary need their nearest boundary
        # point; the distance of the few outside ones is found after.
        dist, side, Q = _nearest_on_boundary(P, self.area, 2.0 * max(self.snap, self.on_tol))
        same = np.all(Q == P, axis=1)
        # Already on a slanted side up to rounding: left alone (idempotence).
        interior_of_side = ~(np.all(Q == self.ring[side], axis=1)
                             | np.all(Q == np.roll(self.ring, -1, axis=0)[side], axis=1))
        on_slanted = self.slanted[side] & interior_of_side & (dist <= self.on_tol) if len(P) \
            else np.zeros(0, dtype=bool)
        moved = (dist <= self.snap) & ~same & ~on_slanted
        new = np.where(moved[:, None], Q, P)
        inside = (dist <= max(self.snap, self.on_tol)) | _inside_or_on(P, self.ring)
        far = ~inside & ~np.isfinite(dist)
        if far.any():
            dist[far] = _nearest_on_boundary(P[far], self.area)[0]
        return new, moved, dist, inside

    def inside(self, P: np.ndarray) -> np.ndarray:
        """Inside, on, or within on_tol of the boundary (for points made here)."""
        P = np.asarray(P, dtype=np.float64).reshape(-1, 2)
        if len(P) == 0:
            return np.zeros(0, dtype=bool)
        dist, _, _ = _nearest_on_boundary(P, self.area, 2.0 * self.on_tol)
        return (dist <= self.on_tol) | _inside_or_on(P, self.ring)

    def onto(self, P: np.ndarray) -> np.ndarray:
        """Points made on the boundary (crossings) moved onto their nearest side."""
        return _nearest_on_boundary(P, self.area)[2]


def _segment_params(p: np.ndarray, q: np.ndarray, ring: np.ndarray):
    """For segments p -> q (s, 2): (segment index, parameter t in [0, 1])
    pairs where a segment meets a boundary side. Whether they meet is decided
    exactly (orient2d on the closed segments); the parameter is rounded. A
    collinear overlap gives both ends of the side (clipped to [0, 1])."""
    s, k = len(p), len(ring)
    segs, ts = [np.zeros(0, dtype=np.int64)], [np.zeros(0)]
    a_all = ring
    b_all = np.roll(ring, -1, axis=0)
    for s0, s1 in _chunks(s, k):
        n = s1 - s0
        P1 = np.repeat(p[s0:s1], k, axis=0)
        P2 = np.repeat(q[s0:s1], k, axis=0)
        A = np.tile(a_all, (n, 1))
        B = np.tile(b_all, (n, 1))
        hit = np.flatnonzero(_segments_intersect(P1, P2, A, B))
        if not hit.size:
            continue
        P1, P2, A, B = P1[hit], P2[hit], A[hit], B[hit]
        seg = hit // k + s0
        d = P2 - P1
        e = B - A
        L2 = np.einsum("ij,ij->i", d, d)
        with np.errstate(all="ignore"):            # non-finite parameters are dropped
            w = A - P1
            t_cross = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / (d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0])
            t_a = np.einsum("ij,ij->i", A - P1, d) / L2
            t_b = np.einsum("ij,ij->i", B - P1, d) / L2
        col = (_orient_sign(P1, P2, A) == 0) & (_orient_sign(P1, P2, B) == 0)
        ok = (L2 > 0.0) & np.isfinite(L2)                # a zero-length segment has no parameter
        cross = ok & ~col & np.isfinite(t_cross)
        both = ok & col & np.isfinite(t_a) & np.isfinite(t_b)
        segs += [seg[cross], seg[both], seg[both]]
        ts += [np.clip(t_cross[cross], 0.0, 1.0), np.clip(t_a[both], 0.0, 1.0),
               np.clip(t_b[both], 0.0, 1.0)]
    return np.concatenate(segs), np.concatenate(ts)


def _inside_intervals(p: np.ndarray, q: np.ndarray, snapper: _Snapper):
    """Which parts of the segments p -> q (s, 2) lie in the study area
    (inside, on, or within on_tol of the boundary).

    Returns ``(whole, parts)``: ``whole`` (s,) bool, the segment is in the
    area from end to end; ``parts``: for the other segments, segment index ->
    list of parameter intervals ``(t0, t1)`` in the area (maybe empty)."""
    s = len(p)
    if s == 0:
        return np.zeros(0, dtype=bool), {}
    seg, t = _segment_params(p, q, snapper.ring)
    L = np.hypot(*(q - p).T)
    # Parameters closer than on_tol along the segment are one crossing (a
    # corner met from two sides; an end snapped onto a side): those that
    # close to an end, or to the parameter before them, are left out.
    with np.errstate(divide="ignore"):
        tol = snapper.on_tol / L
    keep = (t > tol[seg]) & (t < 1.0 - tol[seg])
    seg, t = seg[keep], t[keep]
    order = np.lexsort((t, seg))
    seg, t = seg[order], t[order]
    dup = np.zeros(len(seg), dtype=bool)
    dup[1:] = (seg[1:] == seg[:-1]) & (t[1:] - t[:-1] <= tol[seg[1:]])
    seg, t = seg[~dup], t[~dup]
    # Cuts per segment: 0, its parameters, 1; one interval between each two.
    counts = np.bincount(seg, minlength=s)
    offs = np.concatenate([[0], np.cumsum(counts + 2)])
    cuts = np.empty(offs[-1])
    cuts[offs[:-1]] = 0.0
    cuts[offs[1:] - 1] = 1.0
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])
    cuts[offs[seg] + 1 + (np.arange(len(seg)) - first[seg])] = t
    start = np.ones(len(cuts), dtype=bool)
    start[offs[1:] - 1] = False                           # the last cut of a segment
    i0 = np.flatnonzero(start)
    owner = np.repeat(np.arange(s), counts + 1)
    t0, t1 = cuts[i0], cuts[i0 + 1]
    tm = 0.5 * (t0 + t1)
    mids = p[owner] + tm[:, None] * (q[owner] - p[owner])
    ins = snapper.inside(mids)
    whole = (counts == 0) & ins[offs[:-1] - np.arange(s)]  # one interval, in the area
    parts: Dict[int, List[Tuple[float, float]]] = {}
    for k in np.flatnonzero(~whole):
        sel = np.flatnonzero(owner == k)
        out: List[Tuple[float, float]] = []
        for a, b, ok in zip(t0[sel], t1[sel], ins[sel]):
            if not ok:
                continue
            if out and out[-1][1] == a:
                out[-1] = (out[-1][0], float(b))
            else:
                out.append((float(a), float(b)))
        parts[int(k)] = out
    return whole, parts


def _clip_polyline(P3: np.ndarray, vin: np.ndarray, intervals):
    """Pieces of a polyline (k, 3) inside the study area.

    ``vin``: per vertex, inside (after snapping); ``intervals``: per segment,
    its inside parameter intervals. Returns a list of pieces, each a list of
    entries ``("v", i)`` (vertex i) or ``("x", seg, t, beyond)`` (a crossing on
    segment seg at parameter t; ``beyond`` is the vertex on the outer side)."""
    n = len(P3)
    if n == 1:
        return [[("v", 0)]] if vin[0] else []
    pieces: List[list] = []
    cur: Optional[list] = None
    cur_open = False          # the current piece ends at vertex s (continues into segment s)
    for s in range(n - 1):
        for t0, t1 in intervals[s]:
            if cur is not None and cur_open and t0 == 0.0:
                pass                                    # continue through vertex s
            else:
                if cur is not None:
                    pieces.append(cur)
                cur = [("v", s) if t0 == 0.0 else ("x", s, t0, s)]
            cur.append(("v", s + 1) if t1 == 1.0 else ("x", s, t1, s + 1))
            cur_open = t1 == 1.0
        if not (intervals[s] and intervals[s][-1][1] == 1.0):
            cur_open = False
    if cur is not None:
        pieces.append(cur)
    return pieces


def apply_boundary_policy(ds: Dataset, snap: Optional[float] = None) -> Dataset:
    """Apply the input tolerance policy (docs/dataset.md "Tolerance policy")
    and return a new :class:`Dataset`; ``ds`` is not changed.

    * Every point (borehole rows, extra points, fault tips and every vertex of
      every fault polyline) within the snap distance of the study-area
      boundary is moved onto the nearest point of the nearest side (onto the
      corner when that is nearest; axis-parallel sides and corners exactly).
    * Beyond the snap distance: borehole rows, extra points and tips outside
      are dropped; fault polylines (plane, foot, hanging) are cut where they
      leave the area (the new end is the crossing, on the boundary, z
      interpolated along the segment) and their outside parts dropped. A
      footwall (hanging-wall) polyline keeps the part that holds its cutoff at
      the fault, its last (first) point; if that point lies beyond the boundary
      the layer is dropped from the trace (its cutoff, the datum the model
      needs, is not in the area). A fault-plane trace keeps its longest inside
      part; a trace whose plane trace lies wholly outside is dropped with its
      layers, and a fault left with no trace (and no fault points or surface)
      is dropped.
    * Fault points and fault-surface vertices (format v2) are never moved or
      dropped: the fault surface is fitted to all of them, and data a little
      beyond the boundary still tell where the fault runs inside it; the
      model built from them is cut at the boundary anyway. A fault with some
      beyond the boundary gets one ``kept`` record per source (points,
      surface).
    * Every change is appended to ``adjustments`` of the result.

    ``snap``: the snap distance (m); None = ``ds.snap_distance`` if set, else
    :func:`default_snap_distance`. Idempotent: applied to its own result it
    changes nothing and records nothing.
    """
    if snap is None:
        snap = ds.snap_distance
    explicit = snap
    if snap is None:
        snap = default_snap_distance(ds.boundary)
    snap = _check_snap(snap, "apply_boundary_policy: snap")
    ring = np.asarray(ds.boundary, dtype=np.float64).reshape(-1, 2)
    if len(ring) > 1 and np.array_equal(ring[0], ring[-1]):
        ring = ring[:-1]
    sn = _Snapper(ring, snap)
    adj: List[Adjustment] = []

    # Boreholes.
    b = ds.boreholes
    new_xy, moved, dist, inside = _classify_rows(sn, b)
    for i in np.flatnonzero(moved & inside):
        adj.append(Adjustment("snapped", b.row_label(int(i)), _xy(b.xy[i]), _xy(new_xy[i]),
                              float(dist[i])))
    for i in np.flatnonzero(~inside):
        adj.append(Adjustment("dropped", b.row_label(int(i)), _xy(b.xy[i]), None, float(dist[i]),
                              "beyond the study-area boundary"))
    if not inside.all():
        boreholes = b.moved(new_xy).subset(inside)
    elif moved.any():
        boreholes = b.moved(new_xy)  # no row dropped: no copy of the columns
    else:
        boreholes = b

    # Extra points.
    points: Dict[str, np.ndarray] = {}
    sources = dict(ds.point_sources)
    for lay, arr in ds.points.items():
        arr = np.asarray(arr, dtype=np.float64).reshape(-1, 3)
        nxy, mv, dd, ins = sn.classify(arr[:, :2])
        for i in np.flatnonzero(mv & ins):
            adj.append(Adjustment("snapped", ds.point_label(lay, int(i)), _xy(arr[i]),
                                  _xy(nxy[i]), float(dd[i])))
        for i in np.flatnonzero(~ins):
            adj.append(Adjustment("dropped", ds.point_label(lay, int(i)), _xy(arr[i]), None,
                                  float(dd[i]), "beyond the study-area boundary"))
        if mv.any() or not ins.all():
            arr = np.column_stack([nxy, arr[:, 2]])[ins]
            if lay in sources and sources[lay][1] is not None:
                sources[lay] = (sources[lay][0], sources[lay][1][ins])
        points[lay] = arr

    faults = [_fault_policy(f, sn, adj) for f in ds.faults]
    faults = [f for f in faults if f is not None]
    # A "kept" record notes data left as they are; applied again, the policy
    # finds the same data and must not note them twice (idempotence).
    adj = [a for a in adj if not (a.what == "kept" and a in ds.adjustments)]

    from dataclasses import replace
    return replace(ds, boreholes=boreholes, points=points, faults=faults,
                   adjustments=list(ds.adjustments) + adj, point_sources=sources,
                   snap_distance=explicit)


def _classify_rows(sn: "_Snapper", b: Boreholes):
    """``sn.classify(b.xy)``, computed once per hole position: the rows of a
    plain table repeat their hole's XY (one row per layer), and a row at
    exactly its hole's first row's XY gets that row's result; the others
    (rounded differently, desurveyed holes) are classified on their own."""
    if len(b) < 2:
        return sn.classify(b.xy)
    first, inv = b.hole_rows
    same = b.hole_offset == 0.0  # hypot is 0 only for equal XY
    if same.sum() < 2 * len(first):  # hardly any repeats: nothing to save
        return sn.classify(b.xy)
    new_f, moved_f, dist_f, inside_f = sn.classify(b.xy[first])
    new_xy, moved, dist, inside = new_f[inv], moved_f[inv], dist_f[inv], inside_f[inv]
    other = np.flatnonzero(~same)
    if other.size:
        n2, m2, d2, i2 = sn.classify(b.xy[other])
        new_xy[other], moved[other], dist[other], inside[other] = n2, m2, d2, i2
    return new_xy, moved, dist, inside


def _check_snap(snap, what: str) -> float:
    if isinstance(snap, bool) or not isinstance(snap, (int, float, np.floating, np.integer)):
        raise DatasetError(f"{what}: must be a number (metres), got {_short(snap)}")
    snap = float(snap)
    if not np.isfinite(snap) or snap < 0:
        raise DatasetError(f"{what}: must be a finite distance >= 0, got {snap!r}")
    return snap


def _kept_beyond(label: str, noun: Tuple[str, str], P: np.ndarray, sn: _Snapper,
                 adj: List[Adjustment]) -> None:
    """One ``kept`` record when some of the points P (m, 3) of a fault's data
    (fault points, surface vertices) lie beyond the boundary; they are used as
    they are (see apply_boundary_policy)."""
    P = np.asarray(P, dtype=np.float64).reshape(-1, 3)
    if not len(P):
        return
    _, _, dist, inside = sn.classify(P[:, :2])
    out = np.flatnonzero(~inside)
    if not out.size:
        return
    far = int(out[np.argmax(dist[out])])
    first = ", ".join(str(int(i) + 1) for i in out[:5]) + (", ..." if out.size > 5 else "")
    adj.append(Adjustment(
        "kept", label, _xy(P[far]), _xy(P[far]), float(dist[far]),
        f"{out.size} of {len(P)} {noun[1]} lie beyond the study-area boundary ({noun[1]} "
        f"{first}; the farthest is {noun[0]} {far + 1}); kept as they are: the fault's surface "
        "is fitted to all of its data, and only the model built from it is cut at the "
        "boundary"))


def _fault_policy(f: Fault, sn: _Snapper, adj: List[Adjustment]) -> Optional[Fault]:
    """The policy on one fault (see apply_boundary_policy); None = dropped."""
    fw = f"fault {f.name!r}"
    # Fault points and surface vertices are never moved or dropped (the fault
    # surface is fitted to all of them); those beyond the boundary are noted.
    if f.points is not None:
        _kept_beyond(f"{fw} points", ("point", "points"), f.points, sn, adj)
    if f.surface is not None:
        _kept_beyond(f"{fw} surface", ("vertex", "vertices"), f.surface[0], sn, adj)
    has_data = f.points is not None or f.surface is not None
    # Every XY point of the fault at once: tips, then each polyline's vertices.
    lines: List[Tuple[int, Optional[str], str, np.ndarray]] = []   # (trace, layer, side, pts)
    for j, tr in enumerate(f.traces):
        lines.append((j, None, "plane", np.asarray(tr.plane, dtype=np.float64).reshape(-1, 3)))
        for lay, sides in tr.layers.items():
            for side in ("foot", "hanging"):
                if side in sides:
                    lines.append((j, lay, side,
                                  np.asarray(sides[side], dtype=np.float64).reshape(-1, 3)))
    tips = np.asarray(f.tips, dtype=np.float64).reshape(-1, 2)
    nt = len(tips)
    allxy = np.vstack([tips] + [pts[:, :2] for *_, pts in lines])
    new, moved, dist, inside = sn.classify(allxy)
    offs = [nt]
    for *_, pts in lines:
        offs.append(offs[-1] + len(pts))

    # Inside parameter intervals of every segment of every polyline, at once.
    seg_p = [new[offs[li]:offs[li + 1] - 1] for li in range(len(lines))]
    seg_q = [new[offs[li] + 1:offs[li + 1]] for li in range(len(lines))]
    whole_seg, parts = _inside_intervals(np.vstack(seg_p + [np.zeros((0, 2))]),
                                         np.vstack(seg_q + [np.zeros((0, 2))]), sn)
    seg0 = np.concatenate([[0], np.cumsum([len(sp) for sp in seg_p])])

    # Outcome per polyline: ("whole", xyz) | ("clip", piece, xyz) | ("none", why).
    outcome: List[tuple] = []
    for li, (j, lay, side, pts) in enumerate(lines):
        o, k = offs[li], len(pts)
        vin = inside[o:o + k]
        xyz = pts.copy()
        xyz[:, :2] = new[o:o + k]
        if vin.all() and whole_seg[seg0[li]:seg0[li + 1]].all():
            outcome.append(("whole", xyz))
            continue
        ivs = [[(0.0, 1.0)] if whole_seg[g] else parts[g] for g in range(seg0[li], seg0[li + 1])]
        cands = []
        for pc in _clip_polyline(xyz, vin, ivs):
            q = _piece_points(pc, xyz, sn)
            if len(q) >= 2 or (k == 1 and len(q) == 1):
                cands.append((pc, q))
        if side in ("foot", "hanging"):
            anchor = k - 1 if side == "foot" else 0
            keep = [c for c in cands if (c[0][-1] if side == "foot" else c[0][0]) == ("v", anchor)]
            why = (f"its cutoff at the fault (point {anchor + 1}) lies beyond the boundary"
                   if not vin[anchor] else
                   f"only its cutoff at the fault (point {anchor + 1}) lies in the study area, "
                   "the polyline runs beyond the boundary from there")
            why += f"; layer {lay!r} is dropped from trace {j + 1}"
        else:
            keep = sorted(cands, key=lambda c: -float(np.sum(np.linalg.norm(
                np.diff(c[1], axis=0), axis=1))))[:1]
            why = (f"wholly outside the study area; trace {j + 1} is dropped"
                   + (f" with its layer(s) {list(f.traces[j].layers)}" if f.traces[j].layers
                      else ""))
        outcome.append(("clip", keep[0][0], keep[0][1]) if keep else ("none", why))

    if not (moved.any() or any(oc[0] != "whole" for oc in outcome) or not inside[:nt].all()):
        return f                                # nothing to do

    # Tips.
    for i in range(nt):
        if not inside[i]:
            adj.append(Adjustment("dropped", f"{fw} tip {i + 1}", _xy(tips[i]), None,
                                  float(dist[i]), "beyond the study-area boundary; that end of "
                                  "the fault now reaches the boundary"))
        elif moved[i]:
            adj.append(Adjustment("snapped", f"{fw} tip {i + 1}", _xy(tips[i]), _xy(new[i]),
                                  float(dist[i])))
    new_tips = new[:nt][inside[:nt]]

    def record(li: int, label: str) -> None:
        pts, oc = lines[li][3], outcome[li]
        o, k = offs[li], len(pts)
        if oc[0] == "none":
            near = int(np.argmin(dist[o:o + k])) if k else 0
            adj.append(Adjustment("dropped", label, _xy(pts[near]) if k else None, None,
                                  float(dist[o + near]) if k else None, oc[1]))
            return
        kept = np.ones(k, dtype=bool)
        if oc[0] == "clip":
            kept[:] = False
            kept[[e[1] for e in oc[1] if e[0] == "v"]] = True
        for i in np.flatnonzero(kept & moved[o:o + k]):
            adj.append(Adjustment("snapped", f"{label} point {i + 1}", _xy(pts[i]),
                                  _xy(new[o + i]), float(dist[o + i])))
        for i in np.flatnonzero(~kept):
            adj.append(Adjustment(
                "dropped", f"{label} point {i + 1}", _xy(pts[i]), None, float(dist[o + i]),
                "beyond the study-area boundary" if not inside[o + i] else
                "on a part of the polyline cut off by the boundary"))
        if oc[0] == "clip":
            crossings = [e for e in oc[1] if e[0] == "x"]
            for e in crossings:
                _, s, t, beyond = e
                p = new[o + s] + t * (new[o + s + 1] - new[o + s])
                after = sn.onto(p[None])[0]
                adj.append(Adjustment("clipped", f"{label} between points {s + 1} and {s + 2}",
                                      _xy(pts[beyond]), _xy(after), float(dist[o + beyond]),
                                      f"cut where it leaves the study area (point {beyond + 1} "
                                      "lies beyond it)"))

    # Rebuild the traces, recording as we go.
    traces: List[Trace] = []
    li = 0
    for j, tr in enumerate(f.traces):
        tw = f"{fw} trace {j + 1}"
        plane_li = li
        li += 1
        layer_lis: Dict[str, Dict[str, int]] = {}
        for lay, sides in tr.layers.items():
            layer_lis[lay] = {}
            for side in ("foot", "hanging"):
                if side in sides:
                    layer_lis[lay][side] = li
                    li += 1
        if outcome[plane_li][0] == "none":
            record(plane_li, f"{tw} plane")
            continue
        record(plane_li, f"{tw} plane")
        layers: Dict[str, Dict[str, np.ndarray]] = {}
        for lay, sl in layer_lis.items():
            lost = [side for side, i in sl.items() if outcome[i][0] == "none"]
            if lost:
                # The layer's cutoff lies beyond the boundary: the other side
                # is no use alone, so the layer goes from this trace.
                record(sl[lost[0]], f"{tw} layer {lay!r} {lost[0]}")
                continue
            for side, i in sl.items():
                record(i, f"{tw} layer {lay!r} {side}")
            layers[lay] = {side: outcome[i][-1] for side, i in sl.items()}
        traces.append(Trace(tr.section, outcome[plane_li][-1], layers))
    if not traces and not has_data:
        adj.append(Adjustment("dropped", fw, None, None, None,
                              "no trace left inside the study area"))
        return None
    from dataclasses import replace
    return replace(f, tips=new_tips, traces=traces)


def _piece_points(pc, pts3: np.ndarray, sn: _Snapper) -> np.ndarray:
    """XYZ of a piece from _clip_polyline: vertices as they are, crossings
    interpolated along their segment (z too) and moved onto the boundary side
    they lie on. Consecutive equal points are merged."""
    out = []
    for e in pc:
        if e[0] == "v":
            out.append(pts3[e[1]].copy())
        else:
            _, s, t, _ = e
            p = pts3[s] + t * (pts3[s + 1] - pts3[s])
            p[:2] = sn.onto(p[None, :2])[0]
            out.append(p)
    arr = np.array(out).reshape(-1, 3)
    keep = np.ones(len(arr), dtype=bool)
    keep[1:] = np.any(arr[1:] != arr[:-1], axis=1)
    return arr[keep]


# ---------------------------------------------------------------------------
# Checks of the data themselves: hole positions, layer order
# ---------------------------------------------------------------------------
#: Up to this many holes are named in a message.
_NAME_HOLES = 4


def _hole_rows(b: Boreholes, idx) -> str:
    if b.rows is not None and b.source is not None:
        return ", ".join(f"row {int(b.rows[i])}" for i in idx)
    return ", ".join(f"row {int(i) + 1}" for i in idx)


def check_hole_positions(ds: Dataset, tol: Optional[float] = None) -> None:
    """Every row of one ``hole_id`` has the same XY, up to ``tol`` (default:
    the dataset's snap distance, the rounding the policy accepts on any point).
    Two holes that share an id at different places are a :class:`DatasetError`
    naming both rows (a repeated id is usually a copy-paste slip, and which of
    the two the model would use is arbitrary).

    Only for a plain ``hole_id,x,y,layer,z`` table: tops desurveyed from
    drillhole tables (``Boreholes.desurveyed``) lie along deviated holes,
    each at its own XY, and a hole's identity comes from its collar row
    (a repeated collar is an error of :mod:`faultmesh.drillholes`)."""
    b = ds.boreholes
    if len(b) < 2 or b.desurveyed:
        return
    if tol is None:
        tol = ds.snap_distance if ds.snap_distance is not None else \
            default_snap_distance(ds.boundary)
    first, inv = b.hole_rows
    d = b.hole_offset
    bad = np.flatnonzero(d > tol)
    if bad.size:
        i = int(bad[0])
        j = int(first[inv[i]])
        src = f"{b.source}: " if b.source else ""
        raise DatasetError(
            f"{src}hole {_short(str(b.hole_id[i]))} is at two places: {_hole_rows(b, [j])} at "
            f"({b.xy[j, 0]:.3f}, {b.xy[j, 1]:.3f}) and {_hole_rows(b, [i])} at "
            f"({b.xy[i, 0]:.3f}, {b.xy[i, 1]:.3f}), {d[i]:.3f} m apart; a hole_id must name one "
            f"hole (its rows may differ in XY by rounding, at most {tol:g} m)"
            + (f"; {bad.size - 1} more row(s) like this" if bad.size > 1 else ""))


def check_layer_order(ds: Dataset) -> List[Adjustment]:
    """Does the layer order (top to bottom) agree with the boreholes?

    For each pair of adjacent layers (upper U, lower L) the holes that hit
    both vote, each with its SHALLOWEST hit of each layer: a hole that crosses
    a reverse fault sees a layer twice, and its first hit of each layer is on
    the same (upper) block, so the shallowest hits keep the stratigraphic
    order; a hole that misses a layer does not vote on its pairs. A hole
    agrees when U's hit is higher than L's, disagrees when it is lower (equal
    elevations, a pinched-out layer, do not vote). When MORE holes disagree
    than agree (a strict majority of the votes) the order is contradicted: a
    :class:`DatasetError` naming the layers and some of the holes (reversed
    list, two layers swapped, depths given as elevations). Fewer disagreeing
    holes (bad picks) give a ``warning`` :class:`Adjustment` each pair, which
    is returned (not raised)."""
    b = ds.boreholes
    layers = list(ds.layers)
    if len(b) == 0 or len(layers) < 2:
        return []
    names, lcode, hole_idx, hole_names = b.codes
    li = {lay: i for i, lay in enumerate(layers)}
    lay_idx = np.array([li.get(str(v), -1) for v in names], dtype=np.int64)[lcode]
    # Each hole's shallowest hit of each layer: one row per (layer, hole)
    # (Boreholes.shallowest, cached for the build's later steps).
    sel = np.flatnonzero((lay_idx >= 0) & b.shallowest)
    H = np.full((len(hole_names), len(layers)), -np.inf)
    H[hole_idx[sel], lay_idx[sel]] = b.z[sel]
    def row_of(h: int, i: int) -> int:
        """The row of hole h's shallowest hit of layer i (for messages only)."""
        rows = np.flatnonzero((hole_idx == h) & (lay_idx == i))
        return int(rows[np.argmax(b.z[rows])])

    warnings: List[Adjustment] = []
    problems = []
    n_pairs = 0
    for i in range(len(layers) - 1):
        up, lo = H[:, i], H[:, i + 1]
        both = np.isfinite(up) & np.isfinite(lo)
        if not both.any():
            continue
        n_pairs += 1
        agree = np.flatnonzero(both & (up > lo))
        disagree = np.flatnonzero(both & (up < lo))
        if not disagree.size:
            continue
        U, L = layers[i], layers[i + 1]
        # The holes that disagree most first.
        worst = disagree[np.argsort(up[disagree] - lo[disagree])][:_NAME_HOLES]
        names = "; ".join(
            f"hole {_short(str(hole_names[h]))}: {U!r} at z {up[h]:.2f} "
            f"({_hole_rows(b, [row_of(h, i)])}), {L!r} at z {lo[h]:.2f} ({_hole_rows(b, [row_of(h, i + 1)])})"
            for h in worst)
        more = f" and {disagree.size - len(worst)} more" if disagree.size > len(worst) else ""
        counts = (f"{disagree.size} of the {agree.size + disagree.size} holes that hit both "
                  f"(shallowest hit of each) find {L!r} higher")
        if disagree.size > agree.size:
            problems.append((U, L, f"layers {U!r} and {L!r}: the order says {U!r} lies above "
                                   f"{L!r}, but {counts}: {names}{more}"))
        else:
            warnings.append(Adjustment("warning", f"layers {U!r} and {L!r}",
                                       note=f"{counts} (bad picks?): {names}{more}"))
    if problems:
        src = f"{b.source}: " if b.source else ""
        hint = ("every pair of layers is upside down: is the layer list reversed, or are the "
                "z values depths (positive down) instead of elevations?"
                if len(problems) == n_pairs and n_pairs > 0 else
                "check the order of 'layers' (top to bottom) against the boreholes")
        raise DatasetError(f"{src}the layer order contradicts the boreholes: "
                           + " | ".join(p[2] for p in problems[:3])
                           + (f" | and {len(problems) - 3} more pair(s)" if len(problems) > 3 else "")
                           + f"; {hint}")
    return warnings


def check_layer_data(ds: Dataset) -> None:
    """Every layer has at least 3 data inside the study area (borehole hits,
    extra points and, in a derived dataset, the conformable points): the
    least that fixes a surface's dip; with fewer its TIN would be flat or a
    guess across the whole area. One rule for :func:`load_dataset` and
    :func:`faultmesh.build_model` (a dataset built in memory must load back
    once saved). Run on a dataset the boundary policy has been applied to
    (points beyond the area dropped). Raises :class:`DatasetError` naming
    the layer."""
    for lay, pts in ds.all_layer_points().items():     # one pass over the borehole table
        n = len(pts)
        if n < 3:
            raise DatasetError(f"layer {lay!r}: has {n} data point(s) inside the study area "
                               "(borehole hits plus extra points); a stratum TIN needs at least 3")


def check_fault_sticks(ds: Dataset) -> None:
    """Every fault's sticks keep the rules of a fault-points file
    (:func:`faultmesh.fault_inputs.stick_problem`: at least 2 points per
    stick, no point repeating the one before it on its stick): one rule for
    :func:`load_dataset` (which names the file's row) and a dataset made in
    memory (:func:`prepare_for_build`, :func:`faultmesh.derive.derive_faults`;
    it must load back once saved). Raises :class:`DatasetError` naming the
    fault, the point (its index in ``Fault.points``) and the stick."""
    from .fault_inputs import stick_problem

    for f in ds.faults:
        if f.points is None or f.sticks is None:
            continue
        bad = stick_problem(f.points, f.sticks)
        if bad is not None:
            k, prev, why = bad
            raise DatasetError(f"fault {f.name!r}, point {k}: {why}"
                               + (f" (point {prev})" if prev is not None else ""))


def prepare_for_build(ds: Dataset):
    """What :func:`faultmesh.build_model` runs first, before any repair:
    the data checks (:func:`check_hole_positions`, :func:`check_fault_sticks`,
    :func:`check_layer_order`, raising :class:`DatasetError`),
    :func:`apply_boundary_policy` and
    :func:`check_layer_data` on its result.

    Returns ``(dataset, record)``: the dataset as the policy leaves it (the
    same data for a loaded dataset, the policy being idempotent) and the
    JSON-ready record for ``model.metadata["input"]``: ``snap_distance``,
    ``counts`` per kind, ``summary`` and every ``adjustment``."""
    check_hole_positions(ds)
    check_fault_sticks(ds)
    warns = [w for w in check_layer_order(ds) if w not in ds.adjustments]
    out = apply_boundary_policy(ds)
    check_layer_data(out)
    if warns:
        out.adjustments.extend(warns)
    return out, input_record(out)


def input_record(ds: Dataset) -> Dict[str, Any]:
    """The JSON-ready record of the input policy for ``ds`` (see prepare_for_build)."""
    snap = ds.snap_distance if ds.snap_distance is not None else \
        default_snap_distance(ds.boundary)
    return {"snap_distance": float(snap),
            "counts": adjustment_counts(ds.adjustments),
            "summary": summarize_adjustments(ds.adjustments, snap),
            "adjustments": [a.to_dict() for a in ds.adjustments]}


# ---------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------
_BOREHOLE_COLUMNS = ("hole_id", "x", "y", "layer", "z")
# "description" and "comment" are free text wherever a person may want a note.
_NOTES = {"description", "comment"}
_TOP_KEYS = {"faultmesh_dataset", "name", "crs", "layers", "boundary", "boreholes",
             "points", "sections", "faults", "snap_distance"} | _NOTES
_SECTION_KEYS = {"name", "origin", "azimuth"} | _NOTES
_FAULT_KEYS = {"name", "kind", "group", "tips", "traces"} | _NOTES
#: Keys of a fault that only format version 2 knows.
_FAULT_KEYS_V2_ONLY = {"points", "surface", "throw", "derived"}
_FAULT_KEYS_V2 = _FAULT_KEYS | _FAULT_KEYS_V2_ONLY
#: ``"boreholes": {...}`` in version 2: drillhole tables.
_DRILLHOLE_KEYS = {"collars", "surveys", "intervals", "other_units"} | _NOTES
_THROW_KEYS = {"max"}
_TRACE_KEYS = {"section", "plane", "layers"} | _NOTES
_SIDE_KEYS = {"foot", "hanging"}

#: Largest coordinate (x, y, z, s) the loader accepts, in absolute value. Far
#: beyond any survey in any unit (UTM in millimetres is ~1e10), and small
#: enough that products of two coordinates (orientations, areas, squared
#: distances: ~1e30) stay far inside the double range, so no step of the
#: policy or the builder overflows; the kernels refuse |c| > 1e60 anyway, and
#: here the message names the field.
COORD_MAX = 1e15

#: Values quoted in messages are cut to this many characters: a message names
#: the offending field, it never reproduces a file (a CSV path may point at a
#: file that is not ours).
_QUOTE_MAX = 40


def _short(v, limit: int = _QUOTE_MAX) -> str:
    """repr of ``v``, cut to about ``limit`` characters."""
    if isinstance(v, str):
        return repr(v) if len(v) <= limit else repr(v[:limit]) + "..."
    if isinstance(v, (list, dict)):
        r = f"a JSON {'list' if isinstance(v, list) else 'object'} of {len(v)} item(s)"
        try:
            text = repr(v)
        except RecursionError:  # pragma: no cover - json bounds nesting first
            return r
        return text if len(text) <= limit else r
    r = repr(v)
    return r if len(r) <= limit else r[:limit] + "..."


def _suggest(word: str, choices) -> str:
    import difflib
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


class _JsonObject(dict):
    """A JSON object that remembers keys given more than once (json keeps the
    last silently; a repeated key is almost always an editing slip)."""

    def __init__(self, pairs):
        super().__init__()
        self.repeated: List[str] = []
        for k, v in pairs:
            if k in self:
                self.repeated.append(k)
            self[k] = v


class _Ctx:
    """Where we are in the JSON, for messages: file plus a readable key path."""

    def __init__(self, file: Path, allow_outside_paths: bool = False):
        self.file = file
        self.base = file.parent
        self.allow_outside = allow_outside_paths
        # Changes the reader itself makes (repeated trace points merged);
        # they join Dataset.adjustments.
        self.adjustments: List[Adjustment] = []

    def err(self, where: str, msg: str) -> DatasetError:
        return DatasetError(f"{self.file}: {where}: {msg}" if where else f"{self.file}: {msg}")

    def num(self, v, where: str, coord: bool = False) -> float:
        """A finite number; ``coord``: a coordinate, at most COORD_MAX in size."""
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.err(where, f"{_short(v)} is not a number")
        try:
            f = float(v)
        except OverflowError:
            f = float("inf")
        if not np.isfinite(f):
            raise self.err(where, f"{_short(v)} is not a finite number")
        if coord and abs(f) > COORD_MAX:
            raise self.err(where, f"{_short(v)} is beyond the coordinate range "
                           f"(|value| <= {COORD_MAX:g})")
        return f

    def string(self, v, where: str) -> str:
        if not isinstance(v, str) or not v.strip():
            raise self.err(where, f"must be a non-empty string, got {_short(v)}")
        return v

    def obj(self, v, where: str, jpath: Optional[str] = None, keys=None) -> dict:
        """``v`` must be a JSON object; with ``keys``, only those keys (an
        unknown one names its JSON path and the nearest valid key)."""
        if not isinstance(v, dict):
            raise self.err(where, f"must be a JSON object, got {_json_type(v)}")
        rep = getattr(v, "repeated", None)
        if rep:
            raise self.err(where, f"key {_short(rep[0])} is given more than once"
                           + (f" (JSON path {jpath})" if jpath else ""))
        if keys is not None:
            for k in v:
                if k not in keys:
                    at = f"{jpath}.{k}" if jpath else str(k)
                    at = at if len(at) <= 2 * _QUOTE_MAX else at[:2 * _QUOTE_MAX] + "..."
                    raise self.err(where, f"unknown key {_short(k)}{_suggest(k, keys)} at JSON "
                                   f"path {at}; allowed keys: {sorted(keys)}")
        return v

    def lst(self, v, where: str) -> list:
        if not isinstance(v, list):
            raise self.err(where, f"must be a JSON list, got {_json_type(v)}")
        return v

    def need(self, d: dict, key: str, where: str):
        if key not in d:
            raise self.err(where, f"missing key {key!r}")
        return d[key]

    def layer(self, lay, layers: List[str], where: str) -> str:
        if lay not in layers:
            raise self.err(where, f"unknown layer {_short(lay)}{_suggest(lay, layers)}; "
                           f"layers are {layers}")
        return lay

    def xy_list(self, v, where: str) -> np.ndarray:
        out = []
        for i, p in enumerate(self.lst(v, where)):
            w = f"{where} point {i + 1}"
            if not isinstance(p, list) or len(p) != 2:
                raise self.err(w, f"must be [x, y], got {_short(p)}")
            out.append([self.num(p[0], w + " x", True), self.num(p[1], w + " y", True)])
        return np.array(out, dtype=np.float64).reshape(-1, 2)

    def polyline(self, v, where: str, section: Optional[Section]) -> np.ndarray:
        """A trace polyline: [x, y, z] points, or [s, z] through ``section``."""
        pts = self.lst(v, where)
        if len(pts) < 2:
            raise self.err(where, f"a trace polyline needs at least two points, got {len(pts)}")
        out = np.empty((len(pts), 3))
        for i, p in enumerate(pts):
            w = f"{where} point {i + 1}"
            if not isinstance(p, list) or len(p) not in (2, 3):
                raise self.err(w, f"must be [x, y, z] or [s, z], got {_short(p)}")
            if len(p) == 3:
                out[i] = [self.num(p[0], w + " x", True), self.num(p[1], w + " y", True),
                          self.num(p[2], w + " z", True)]
            else:
                if section is None:
                    raise self.err(w, "an [s, z] point needs the trace to name a section")
                s = self.num(p[0], w + " s", True)
                out[i, :2] = section.to_xy([s])[0]
                out[i, 2] = self.num(p[1], w + " z", True)
        big = ~np.all(np.abs(out) <= COORD_MAX, axis=1)
        if big.any():
            i = int(np.flatnonzero(big)[0])
            raise self.err(f"{where} point {i + 1}", "is beyond the coordinate range "
                           f"(|value| <= {COORD_MAX:g}) once placed on its section")
        # A point repeating the one before it (digitised twice, or two points
        # that a surveyor's rounding made equal) carries no information: it
        # is merged into the first and reported. Only exact repeats: points
        # that differ at all are the data and stay.
        same = np.all(out[1:] == out[:-1], axis=1)
        if same.any():
            for i in np.flatnonzero(same):
                self.adjustments.append(Adjustment(
                    "dropped", f"{where} point {int(i) + 2}", _xy(out[i + 1]), None, None,
                    note=f"repeats point {int(i) + 1}"))
            out = out[np.r_[True, ~same]]
            if len(out) < 2:
                raise self.err(where, "a trace polyline needs at least two distinct points, "
                               f"got {len(out)}")
        return out

    def data_file(self, v, label: str) -> Tuple[Path, str]:
        """The path of a data file (CSV, TSurf) named in the JSON (relative to
        the JSON's folder) and the name to use in messages. A path leaving the dataset folder
        (absolute, ``..``, or a symlink resolving outside) is an error unless
        outside paths are allowed."""
        rel = self.string(v, label)
        if "\x00" in rel:
            raise self.err(label, "a path cannot contain a NUL character")
        file = self.base / rel
        if not self.allow_outside:
            how = "allow it with load_dataset(..., allow_outside_paths=True) or " \
                  "--allow-outside-paths"
            if Path(rel).is_absolute():
                raise self.err(label, f"{_short(rel, 120)} is an absolute path; data file paths "
                               f"must be relative to the dataset folder ({how})")
            try:
                base = self.base.resolve()
                target = file.resolve()
            except (RuntimeError, OSError):
                raise self.err(label, f"file {_short(str(file), 200)}: symlink loop") from None
            if not (target == base or _is_within(target, base)):
                raise self.err(label, f"{_short(rel, 120)} leaves the dataset folder {str(base)!r}"
                               f" (resolves to {_short(str(target), 200)}); {how}")
        return file, rel


def _is_within(p: Path, base: Path) -> bool:
    try:
        p.relative_to(base)
        return True
    except ValueError:
        return False


def _json_type(v) -> str:
    return {dict: "object", list: "list", str: "string", bool: "boolean", int: "number",
            float: "number", type(None): "null"}.get(type(v), type(v).__name__) \
        if not isinstance(v, dict) else "object"


def _read_regular_file(file: Path, what: str) -> bytes:
    """The bytes of ``file``, which must be a regular file. A directory, a
    FIFO, a device, a socket, a symlink loop or a dangling symlink is a clear
    DatasetError; the file type is checked (stat) before opening, and the open
    does not block (O_NONBLOCK: opening a FIFO for reading would wait for a
    writer), and the opened file is checked again (fstat) against a swap."""
    import errno
    import os
    import stat as st

    name = _short(str(file), 200)
    try:
        info = os.stat(file)
    except FileNotFoundError:
        if os.path.islink(file):
            raise DatasetError(f"{what}: file {name} is a symlink to a missing file") from None
        raise DatasetError(f"{what}: file {name} not found") from None
    except OSError as e:
        if e.errno == errno.ELOOP:
            raise DatasetError(f"{what}: file {name}: symlink loop") from None
        if e.errno == errno.ENOTDIR:
            raise DatasetError(f"{what}: file {name} not found (a part of the path is not a "
                               "folder)") from None
        raise DatasetError(f"{what}: file {name} cannot be read: {e.strerror}") from None
    except ValueError as e:  # e.g. an embedded NUL
        raise DatasetError(f"{what}: file {name}: invalid path ({e})") from None

    def kind(mode) -> Optional[str]:
        if st.S_ISREG(mode):
            return None
        if st.S_ISDIR(mode):
            return "is a directory, expected a file"
        if st.S_ISFIFO(mode):
            return "is not a regular file (a FIFO)"
        if st.S_ISCHR(mode) or st.S_ISBLK(mode):
            return "is not a regular file (a device)"
        if st.S_ISSOCK(mode):
            return "is not a regular file (a socket)"
        return "is not a regular file"

    k = kind(info.st_mode)
    if k:
        raise DatasetError(f"{what}: file {name} {k}")
    try:
        fd = os.open(file, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except OSError as e:
        raise DatasetError(f"{what}: file {name} cannot be opened: {e.strerror}") from None
    try:
        k = kind(os.fstat(fd).st_mode)
        if k:
            raise DatasetError(f"{what}: file {name} {k}")
        with os.fdopen(fd, "rb", closefd=False) as fh:
            return fh.read()
    except OSError as e:
        raise DatasetError(f"{what}: file {name} cannot be read: {e.strerror}") from None
    finally:
        os.close(fd)


def _decode(data: bytes, file: Path) -> str:
    """UTF-8 text; a byte-order mark at the start (Excel, Notepad) is dropped."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise DatasetError(f"{file}, row {line}: not UTF-8 text (byte {e.start + 1} of the file "
                           "cannot be decoded)") from None


def _read_csv(file: Path, label: str, ctx: _Ctx):
    """Rows of a CSV with their 1-based line numbers (header = line 1). Blank
    lines and lines starting with '#' are skipped."""
    import csv
    import io

    data = _read_regular_file(file, f"{ctx.file}: {label}")
    text = _decode(data, file)
    rows, lines = [], []
    reader = csv.reader(io.StringIO(text, newline=""))
    end = 0         # the line the previous record ended on
    try:
        for row in reader:
            start, end = end + 1, reader.line_num
            if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
                continue
            if end > start and any("\n" in c or "\r" in c for c in row):
                # A quoted field over several lines: no field of a dataset
                # holds a line break, an unclosed quote swallows the rest of
                # the file (the field count's error then named its last row).
                raise DatasetError(f"{file}, row {start}: a quoted field runs over lines {start}-"
                                   f"{end} (an unclosed '\"'?)")
            rows.append([c.strip() for c in row])
            lines.append(start)
    except csv.Error as e:
        raise DatasetError(f"{file}, row {reader.line_num + 1}: cannot read as CSV: {e}") from None
    return rows, lines


#: A number as a CSV file of a dataset may write it: ASCII digits, a
#: decimal point, an exponent (and nan/inf, refused below as not finite).
#: Python's float() (and numpy's) also read "1_00" and other scripts'
#: digits as 100, which no spreadsheet or GIS does: a typo read silently.
_NUMBER_RE = r"(?:[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:nan|inf|infinity))"
_NUMBER = re.compile(_NUMBER_RE, re.IGNORECASE | re.ASCII)
# A whole column at once (joined by newlines, which no field holds): one
# scan in C instead of one call per value.
_NUMBERS = re.compile(rf"{_NUMBER_RE}(?:\n{_NUMBER_RE})*", re.IGNORECASE | re.ASCII)


def _csv_numbers(file: Path, col: List[str], lines: List[int], field_name: str) -> np.ndarray:
    """Column ``col`` as float64; an error names file, row and field."""
    try:
        a = np.array(col, dtype=np.float64)
    except (ValueError, OverflowError):
        a = None
    if a is not None and np.all(np.abs(a) <= COORD_MAX) \
            and (not col or _NUMBERS.fullmatch("\n".join(col))):    # the bound: False for NaN too
        return a
    for v, ln in zip(col, lines):
        if v == "":
            raise DatasetError(f"{file}, row {ln}, field {field_name!r}: missing value")
        try:
            if not _NUMBER.fullmatch(v):
                raise ValueError(v)
            f = float(v)
        except (ValueError, OverflowError):
            raise DatasetError(f"{file}, row {ln}, field {field_name!r}: {_short(v)} is not a "
                               "number") from None
        if not np.isfinite(f):
            raise DatasetError(f"{file}, row {ln}, field {field_name!r}: {_short(v)} is not a "
                               "finite number")
        if abs(f) > COORD_MAX:
            raise DatasetError(f"{file}, row {ln}, field {field_name!r}: {_short(v)} is beyond "
                               f"the coordinate range (|value| <= {COORD_MAX:g})")
    raise AssertionError("unreachable")  # pragma: no cover


def _load_boreholes(file: Path, name: str, layers: List[str], ctx: _Ctx) -> Boreholes:
    rows, lines = _read_csv(file, "boreholes", ctx)
    if not rows:
        raise DatasetError(f"{file}: empty file (expected header {','.join(_BOREHOLE_COLUMNS)})")
    header = [h.lower() for h in rows[0]]
    missing = [c for c in _BOREHOLE_COLUMNS if c not in header]
    if missing:
        raise DatasetError(f"{file}, row {lines[0]}: header lacks column(s) {missing}; "
                           f"expected {','.join(_BOREHOLE_COLUMNS)}")
    idx = {c: header.index(c) for c in _BOREHOLE_COLUMNS}
    body, bl = rows[1:], lines[1:]
    if not body:
        # Allowed: data may come from `points` alone (seismic picks, DEMs);
        # the boundary must then be given (checked by the caller).
        return Boreholes.empty(name)
    for r, ln in zip(body, bl):
        if len(r) != len(header):
            raise DatasetError(f"{file}, row {ln}: expected {len(header)} fields, got {len(r)}")
    cols = {c: [r[i] for r in body] for c, i in idx.items()}
    for r, ln in zip(body, bl):
        if r[idx["hole_id"]] == "":
            raise DatasetError(f"{file}, row {ln}, field 'hole_id': missing value")
    known = set(layers)
    for v, ln in zip(cols["layer"], bl):
        if v not in known:
            raise DatasetError(f"{file}, row {ln}, field 'layer': unknown layer {_short(v)}"
                               f"{_suggest(v, layers)}; layers are {layers}")
    x = _csv_numbers(file, cols["x"], bl, "x")
    y = _csv_numbers(file, cols["y"], bl, "y")
    z = _csv_numbers(file, cols["z"], bl, "z")
    return Boreholes(np.array(cols["hole_id"], dtype=str), np.column_stack([x, y]),
                     np.array(cols["layer"], dtype=str), z, name, np.array(bl, dtype=np.int64))


def _load_points_csv(file: Path, layer: str, ctx: _Ctx) -> Tuple[np.ndarray, np.ndarray]:
    rows, lines = _read_csv(file, f"points[{layer!r}]", ctx)
    names = ["x", "y", "z"]
    if rows and all(c in [h.lower() for h in rows[0]] for c in names):
        header = [h.lower() for h in rows[0]]
        idx = [header.index(c) for c in names]
        ncol = len(header)
        rows, lines = rows[1:], lines[1:]
    else:  # no header: x, y, z
        idx, ncol = [0, 1, 2], 3
    for r, ln in zip(rows, lines):
        if len(r) != ncol:
            raise DatasetError(f"{file}, row {ln}: expected {ncol} fields, got {len(r)}")
    if not rows:
        return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    return (np.column_stack([_csv_numbers(file, [r[i] for r in rows], lines, c)
                             for i, c in zip(idx, names)]), np.array(lines, dtype=np.int64))


def _is_hidden(p: Path) -> bool:
    # Our own temporary files (AtomicFiles: ".NAME.XXXXXXXX.tmp.EXT") and any
    # other hidden file are never taken for a dataset.
    return p.name.startswith(".")


def _find_json(d: Path) -> Path:
    import os
    if os.path.lexists(d / "dataset.json"):
        return d / "dataset.json"
    cands = sorted(c for c in d.glob("*.json") if not _is_hidden(c))
    if len(cands) == 1:
        return cands[0]
    if not cands:
        raise DatasetError(f"{d}: folder holds no dataset JSON file")
    raise DatasetError(f"{d}: folder holds several JSON files {[c.name for c in cands]} "
                       "and no dataset.json; pass the file")


def _load_drillhole_tables(spec: dict, layers: List[str], ctx: _Ctx):
    """Version 2 ``"boreholes": {"collars": F, "surveys": F, "intervals": F,
    "other_units": [...]}``: the tables read, checked and desurveyed
    (:mod:`faultmesh.drillholes`). Returns (the layer tops as Boreholes, the
    :class:`~faultmesh.drillholes.DrillholeTables` kept on the Dataset)."""
    from .drillholes import DrillholeTables, read_drillholes

    ctx.obj(spec, "boreholes", "boreholes", _DRILLHOLE_KEYS)
    files = {}
    for key in ("collars", "surveys", "intervals"):
        if key == "surveys" and spec.get(key) is None:
            files[key] = None                    # every hole vertical
        else:
            files[key] = ctx.data_file(ctx.need(spec, key, "boreholes"), f"boreholes.{key}")
    other = ctx.lst(spec.get("other_units", []), "boreholes.other_units")
    other = [ctx.string(u, f"boreholes.other_units[{i}]") for i, u in enumerate(other)]
    both = [u for u in other if u in layers]
    if both:
        raise ctx.err("boreholes.other_units", f"{_short(both[0])} is also a layer; a unit of "
                      "the intervals is either a layer or not")
    holes = read_drillholes(files["collars"][0],
                            None if files["surveys"] is None else files["surveys"][0],
                            files["intervals"][0], ctx=ctx,
                            labels=("boreholes.collars", "boreholes.surveys",
                                    "boreholes.intervals"))
    tables = DrillholeTables(holes, tuple(other))
    tops = tables.tops(layers)
    tops.source = files["intervals"][1]      # messages name the table as the JSON does
    return tops, tables


def _load_fault_data(fd: dict, w: str, jf: str, ctx: _Ctx):
    """Version 2 fault keys ``points``, ``surface`` and ``throw``: (points
    (m, 3) or None, sticks (m,) or None, (vertices, triangles) or None, throw
    dict or None)."""
    from .fault_inputs import read_fault_points, read_fault_surface

    points = sticks = surface = throw = None
    if fd.get("points") is not None:
        f, _ = ctx.data_file(fd["points"], f"{w} points")
        points, sticks = read_fault_points(f, ctx=ctx, label=f"{w} points")
    if fd.get("surface") is not None:
        f, rel = ctx.data_file(fd["surface"], f"{w} surface")
        V, T = read_fault_surface(f, ctx=ctx, label=f"{w} surface")
        big = ~np.all(np.abs(V) <= COORD_MAX, axis=1)
        if big.any():
            raise ctx.err(f"{w} surface", f"{_short(rel, 120)}: vertex {int(np.flatnonzero(big)[0]) + 1}"
                          f" is beyond the coordinate range (|value| <= {COORD_MAX:g})")
        surface = (V, T)
    if fd.get("throw") is not None:
        td = ctx.obj(fd["throw"], f"{w} throw", f"{jf}.throw", _THROW_KEYS)
        m = ctx.num(ctx.need(td, "max", f"{w} throw"), f"{w} throw max")
        if not m > 0:
            raise ctx.err(f"{w} throw max", f"must be a throw > 0 (metres), got {_short(m)}")
        throw = {"max": m}
    return points, sticks, surface, throw


def load_dataset(path, *, snap: Optional[float] = None,
                 allow_outside_paths: bool = False) -> Dataset:
    """Load and validate a dataset of format version 1 or 2 (docs/dataset.md).

    ``path`` is the JSON file or a folder holding ``dataset.json`` (or a
    single ``*.json``); data file paths in it are relative to the JSON, and
    must stay inside its folder unless ``allow_outside_paths``. Section-local
    ``[s, z]`` trace points become XYZ through the trace's section. The
    boundary defaults to the boreholes' bounding box (version 2 without
    borehole rows: the layers' points' bounding box) and is returned
    counter-clockwise.

    Version 2: drillhole tables are read, checked and desurveyed
    (:mod:`faultmesh.drillholes`; the tops become ``boreholes``, marked
    ``desurveyed``, and the tables are kept in ``Dataset.drillholes``); fault
    points and surfaces are read by :mod:`faultmesh.fault_inputs` into
    ``Fault.points``/``sticks``/``surface``; ``kind`` may be None.

    The data are checked (:func:`check_hole_positions`,
    :func:`check_layer_order`) and the input tolerance policy is applied
    (:func:`apply_boundary_policy` with ``snap``, default: the dataset's
    ``snap_distance`` key, else :func:`default_snap_distance`); what it
    changed is in ``Dataset.adjustments``.

    Raises :class:`DatasetError` naming the file, the row (1-based line of the
    CSV, header = 1) and field, or the JSON path / fault / trace / layer.
    """
    import json
    import os

    p = Path(path)
    try:
        is_dir = p.is_dir()
    except OSError:
        is_dir = False
    if is_dir and p.suffix.lower() == ".json":
        raise DatasetError(f"{p}: dataset: file {str(p)!r} is a directory, expected a file")
    if is_dir:
        p = _find_json(p)
    if not os.path.lexists(p):
        raise DatasetError(f"{p}: dataset file not found")
    data = _read_regular_file(p, f"{p}: dataset")
    text = _decode(data, p)
    try:
        doc = json.loads(text, object_pairs_hook=_JsonObject)
    except json.JSONDecodeError as e:
        raise DatasetError(f"{p}: not valid JSON: {e.msg} at line {e.lineno}, column {e.colno}") from None
    except RecursionError:
        raise DatasetError(f"{p}: not valid JSON for a dataset: nested too deeply") from None
    except ValueError as e:  # e.g. an integer with more digits than Python reads
        raise DatasetError(f"{p}: not valid JSON: {_short(str(e), 80)}") from None
    ctx = _Ctx(p, allow_outside_paths)
    if not isinstance(doc, dict):
        raise ctx.err("", f"the top level must be a JSON object, got {_json_type(doc)}")
    if "faultmesh_dataset" not in doc:
        raise ctx.err("", "missing key 'faultmesh_dataset' (the format version, 1 or 2); "
                      "is this a faultmesh dataset?")
    version = doc["faultmesh_dataset"]
    if isinstance(version, bool) or not isinstance(version, int) or version not in FORMAT_VERSIONS:
        raise ctx.err("faultmesh_dataset", f"unsupported format version {_short(version)}; "
                      f"this faultmesh reads versions {', '.join(map(str, FORMAT_VERSIONS))}")
    ctx.obj(doc, "", "", _TOP_KEYS)
    name = ctx.string(doc["name"], "name") if "name" in doc else p.stem
    crs = doc.get("crs", "")
    if not isinstance(crs, str):
        raise ctx.err("crs", f"must be a string, got {_short(crs)}")
    snap_key = None
    if doc.get("snap_distance") is not None:
        snap_key = ctx.num(doc["snap_distance"], "snap_distance")
        if snap_key < 0:
            raise ctx.err("snap_distance", f"must be >= 0 (metres), got {snap_key!r}")
    if snap is not None:
        snap = _check_snap(snap, f"{p}: load_dataset snap")

    # Layers.
    layers = ctx.lst(ctx.need(doc, "layers", ""), "layers")
    if not layers:
        raise ctx.err("layers", "needs at least one layer")
    layers = [ctx.string(v, f"layers[{i}]") for i, v in enumerate(layers)]
    dup = sorted({v for v in layers if layers.count(v) > 1}) if len(set(layers)) < len(layers) \
        else []
    if dup:
        raise ctx.err("layers", f"repeated layer name(s) {[d[:_QUOTE_MAX] for d in dup]}")

    # Boreholes: a hole_id,x,y,layer,z table; in version 2 also drillhole
    # tables, or none at all (the layer data come from `points`).
    drillholes = None
    if version == 1:
        bspec = ctx.need(doc, "boreholes", "")
        if isinstance(bspec, dict):
            raise ctx.err("boreholes", "drillhole tables (collars, surveys, intervals) need "
                          'format version 2 ("faultmesh_dataset": 2)')
    else:
        bspec = doc.get("boreholes")
    if bspec is None and version == 2:
        boreholes = Boreholes.empty()
    elif isinstance(bspec, dict):
        boreholes, drillholes = _load_drillhole_tables(bspec, layers, ctx)
    else:
        bfile, bname = ctx.data_file(bspec, "boreholes")
        boreholes = _load_boreholes(bfile, bname, layers, ctx)

    # Extra points.
    points: Dict[str, np.ndarray] = {}
    sources: Dict[str, Tuple[str, Optional[np.ndarray]]] = {}
    for lay, v in ctx.obj(doc.get("points", {}), "points", "points").items():
        ctx.layer(lay, layers, f"points[{_short(lay)}]")
        if isinstance(v, str):
            f, rel = ctx.data_file(v, f"points[{lay!r}]")
            points[lay], rows = _load_points_csv(f, lay, ctx)
            sources[lay] = (rel, rows)
        else:  # inline [[x, y, z], ...]
            rows = ctx.lst(v, f"points[{lay!r}]")
            arr = np.empty((len(rows), 3))
            for i, q in enumerate(rows):
                w = f"points[{lay!r}] point {i + 1}"
                if not isinstance(q, list) or len(q) != 3:
                    raise ctx.err(w, f"must be [x, y, z], got {_short(q)}")
                arr[i] = [ctx.num(c, w + f" {k}", True) for c, k in zip(q, "xyz")]
            points[lay] = arr
            sources[lay] = (f"points[{lay!r}]", None)

    # Sections.
    sections: Dict[str, Section] = {}
    for i, sd in enumerate(ctx.lst(doc.get("sections", []), "sections")):
        w = f"sections[{i}]"
        ctx.obj(sd, w, w, _SECTION_KEYS)
        sname = ctx.string(ctx.need(sd, "name", w), w + " name")
        w = f"section {_short(sname)}"
        if sname in sections:
            raise ctx.err(w, "repeated section name")
        org = ctx.lst(ctx.need(sd, "origin", w), w + " origin")
        if len(org) != 2:
            raise ctx.err(w + " origin", f"must be [x, y], got {_short(org)}")
        origin = [ctx.num(org[0], w + " origin x", True), ctx.num(org[1], w + " origin y", True)]
        az = ctx.num(ctx.need(sd, "azimuth", w), w + " azimuth")
        sections[sname] = Section(sname, np.array(origin), az)

    # Boundary.
    if "boundary" in doc and doc["boundary"] is not None:
        ring = ctx.xy_list(doc["boundary"], "boundary")
        if len(ring) >= 2 and np.all(ring[0] == ring[-1]):
            ring = ring[:-1]  # an explicitly closed ring
        why = _boundary_problem(ring)
        if why:
            raise ctx.err("boundary", why)
    else:
        # Default: the boreholes' bounding box; in version 2 without borehole
        # rows, the bounding box of the layers' points.
        what = "the boreholes' bounding box"
        xy = boreholes.xy
        if len(xy) == 0 and version == 2:
            what = "the bounding box of the layers' points (there are no borehole rows)"
            xy = np.vstack([np.zeros((0, 2))] + [a[:, :2] for a in points.values()])
        if len(xy) == 0:
            raise ctx.err("boundary", "not given, and there are no borehole rows "
                          + ("or points " if version == 2 else "")
                          + "to take the default (the boreholes' bounding box) from")
        lo = xy.min(axis=0)
        hi = xy.max(axis=0)
        if not np.all(hi > lo):
            raise ctx.err("boundary", f"not given, and {what} (the default) has zero width or "
                          "height")
        ring = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    if _ring_orientation(ring) < 0:
        ring = ring[::-1].copy()

    # Faults.
    faults: List[Fault] = []
    seen = set()
    for i, fd in enumerate(ctx.lst(doc.get("faults", []), "faults")):
        w = f"faults[{i}]"
        jf = f"faults[{i}]"
        if version == 1 and isinstance(fd, dict):
            v2only = sorted(k for k in fd if k in _FAULT_KEYS_V2_ONLY)
            if v2only:
                raise ctx.err(w, f"key {v2only[0]!r} (JSON path {jf}.{v2only[0]}) needs format "
                              'version 2 ("faultmesh_dataset": 2)')
        ctx.obj(fd, w, jf, _FAULT_KEYS if version == 1 else _FAULT_KEYS_V2)
        fname = ctx.string(ctx.need(fd, "name", w), w + " name")
        w = f"fault {_short(fname)}"
        if fname in seen:
            raise ctx.err(w, "repeated fault name")
        seen.add(fname)
        # Version 2: kind may be left out (or null): derived from the data.
        kind = ctx.need(fd, "kind", w) if version == 1 else fd.get("kind")
        if kind is not None or version == 1:
            if kind not in ("normal", "reverse"):
                raise ctx.err(w + " kind", "must be 'normal' or 'reverse'"
                              + (" (or left out: derived from the data)" if version == 2 else "")
                              + f", got {_short(kind)}")
        group = fd.get("group")
        if group is not None:
            group = ctx.string(group, w + " group")
        tips = ctx.xy_list(fd.get("tips", []), w + " tips")
        fpoints = fsticks = fsurface = throw = None
        if version == 2:
            fpoints, fsticks, fsurface, throw = _load_fault_data(fd, w, jf, ctx)
        if version == 1:
            tds = ctx.lst(ctx.need(fd, "traces", w), w + " traces")
            if not tds:
                raise ctx.err(w + " traces", "needs at least one trace")
        derived = fd.get("derived", False)
        if not isinstance(derived, bool):
            raise ctx.err(f"{w} derived", f"must be true or false, got {_short(derived)}")
        if version != 1:
            tds = ctx.lst(fd.get("traces", []), w + " traces")
            # A derived fault may have none: its derivation found no plane
            # trace in the study area, and the build leaves it out, as it
            # does the same dataset in memory (a dataset that builds loads
            # back once saved: fuzz case 52053).
            if not tds and fpoints is None and fsurface is None and not derived:
                raise ctx.err(w, "needs its geometry: 'traces' (at least one), 'points' (a CSV "
                              "of points on the fault) or 'surface' (a GOCAD TSurf)")
        traces: List[Trace] = []
        for j, td in enumerate(tds):
            tw = f"{w} trace {j + 1}"
            jt = f"{jf}.traces[{j}]"
            ctx.obj(td, tw, jt, _TRACE_KEYS)
            sec = None
            sname = td.get("section")
            if sname is not None:
                sname = ctx.string(sname, tw + " section")
                if sname not in sections:
                    raise ctx.err(tw, f"unknown section {_short(sname)}{_suggest(sname, sections)};"
                                  f" sections are {sorted(sections)}")
                sec = sections[sname]
            plane = ctx.polyline(ctx.need(td, "plane", tw), tw + " plane", sec)
            if np.any(np.diff(plane[:, 2]) > 0):
                k = int(np.flatnonzero(np.diff(plane[:, 2]) > 0)[0])
                raise ctx.err(tw + " plane", f"must go top down, but point {k + 2} is higher "
                              f"than point {k + 1}")
            tl: Dict[str, Dict[str, np.ndarray]] = {}
            for lay, sides in ctx.obj(td.get("layers", {}), tw + " layers", jt + ".layers").items():
                lw = f"{tw} layer {_short(lay)}"
                ctx.layer(lay, layers, lw)
                ctx.obj(sides, lw, f"{jt}.layers[{_short(lay)}]", _SIDE_KEYS)
                tl[lay] = {side: ctx.polyline(ctx.need(sides, side, lw), f"{lw} {side}", sec)
                           for side in ("foot", "hanging")}
            traces.append(Trace(sname, plane, tl))
        faults.append(Fault(fname, kind, group, tips, traces, points=fpoints, sticks=fsticks,
                            surface=fsurface, throw=throw, derived=derived))

    ds = Dataset(name=name, layers=layers, boundary=ring, boreholes=boreholes, points=points,
                 sections=sections, faults=faults, crs=crs, path=p, snap_distance=snap_key,
                 point_sources=sources, drillholes=drillholes)
    # The data checks first (on every row, inside the area or not), then the
    # tolerance policy; messages of the checks name the CSV and its rows.
    try:
        check_hole_positions(ds, snap if snap is not None else None)
        ds.adjustments = ctx.adjustments + check_layer_order(ds)
    except DatasetError as e:
        raise DatasetError(f"{p}: {e}") from None
    ds = apply_boundary_policy(ds, snap)
    try:
        check_layer_data(ds)
    except DatasetError as e:
        raise DatasetError(f"{p}: {e}") from None
    return ds


# ---------------------------------------------------------------------------
# Saving
# ---------------------------------------------------------------------------
def _safe(name: str) -> str:
    import re
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "layer"


def _fmt(v: float) -> str:
    return repr(float(v))  # shortest repr: reads back bit-identical


def _trace_points(arr: np.ndarray, sec: Optional[Section], section_coords: bool):
    if section_coords and sec is not None:
        s = sec.to_s(arr[:, :2])
        back = sec.to_xy(s)
        # 1 mm: far below any survey or interpretation precision; points
        # further off the line are not on the section and stay XYZ.
        if np.all(np.hypot(*(back - arr[:, :2]).T) <= 1e-3):
            return [[float(a), float(b)] for a, b in zip(s, arr[:, 2])]
    return [[float(a), float(b), float(c)] for a, b, c in arr]


def _check_csv_field(v, what: str, first_column: bool = False) -> None:
    """A text field :meth:`Dataset.save` writes into a CSV must read back as
    itself: not empty, no surrounding spaces (the reader strips them), no
    comma, quote or line break, and in the first column no leading '#' (the
    reader takes such a line for a comment)."""
    v = str(v)
    if any(c in v for c in ',"\n\r') or v != v.strip() or not v \
            or (first_column and v.startswith("#")):
        raise DatasetError(f"Dataset.save: {what} {_short(v)} cannot be written to CSV (empty, "
                           "surrounding spaces, comma, quote or newline"
                           + (", or starting with '#', read as a comment" if first_column else "")
                           + ")")


def _tables_give_boreholes(ds: Dataset) -> bool:
    """Do the drillhole tables kept on ``ds`` still give its boreholes (the
    tops desurveyed from them, after the input policy under ``ds``'s boundary
    and snap distance)? False when the boreholes were changed in memory after
    loading (then the tables no longer describe them)."""
    if ds.drillholes is None:
        return False
    try:
        tops = ds.drillholes.tops(ds.layers)
    except DatasetError:
        return False           # a unit is no longer a layer
    from dataclasses import replace
    probe = replace(ds, boreholes=tops, points={}, faults=[], adjustments=[])
    return apply_boundary_policy(probe).boreholes == ds.boreholes


def _v2_only(ds: Dataset) -> List[str]:
    """What in ``ds`` format version 1 cannot hold (empty: v1 can)."""
    out = []
    for f in ds.faults:
        fw = f"fault {f.name!r}"
        if f.kind is None:
            out.append(f"{fw} has no kind (derived from the data)")
        if f.points is not None:
            out.append(f"{fw} has fault points")
        if f.surface is not None:
            out.append(f"{fw} has a fault surface")
        if f.throw is not None:
            out.append(f"{fw} has a throw")
        if f.derived:
            out.append(f"{fw} has derived cutoffs")
        if not f.traces:
            out.append(f"{fw} has no trace")
    return out


def _plain_table_problem(b: Boreholes, ds: Dataset) -> Optional[str]:
    """Why the boreholes cannot be written as a ``hole_id,x,y,layer,z``
    table (the rows of one hole at different XY, as desurveyed tops of a
    deviated hole are), or None."""
    if not b.desurveyed:
        return None
    from dataclasses import replace
    try:
        check_hole_positions(replace(ds, boreholes=replace(b, desurveyed=False)))
    except DatasetError as e:
        return str(e)
    return None


def save_dataset(ds: Dataset, path, *, section_coords: bool = False,
                 version: Optional[int] = None) -> Path:
    """Write ``ds`` in format ``version`` (1, 2 or None: 1 unless the
    dataset needs 2); see :meth:`Dataset.save`."""
    v2_only = _v2_only(ds)
    tables = _tables_give_boreholes(ds)
    if version is None:
        version = 2 if (v2_only or tables) else 1
    if isinstance(version, bool) or version not in FORMAT_VERSIONS:
        raise DatasetError(f"Dataset.save: version must be one of {list(FORMAT_VERSIONS)} (or "
                           f"None: the lowest that holds the dataset), got {_short(version)}")
    if version == 1 and v2_only:
        raise DatasetError("Dataset.save: format version 1 cannot hold this dataset: "
                           + "; ".join(v2_only[:3]) + (" ..." if len(v2_only) > 3 else "")
                           + "; save with version=2")
    write_tables = tables and version == 2
    if not write_tables:
        why = _plain_table_problem(ds.boreholes, ds)
        if why:
            raise DatasetError(
                "Dataset.save: the boreholes are tops desurveyed along deviated holes and cannot "
                "be written as a hole_id,x,y,layer,z table (" + why + ")"
                + ("; the drillhole tables they were loaded from no longer give them (the "
                   "boreholes were changed after loading)" if ds.drillholes is not None and not
                   tables else "")
                + ("; save with version=2 to write the drillhole tables" if tables else ""))

    path = Path(path)
    if path.suffix.lower() == ".json":
        folder, jname, prefix = path.parent, path.name, path.stem + "_"
    else:
        folder, jname, prefix = path, "dataset.json", ""

    files: Dict[str, str] = {}  # file name -> content
    used = set()

    def name_for(stem: str, ext: str) -> str:
        fname = f"{prefix}{stem}.{ext}"
        k = 2
        while fname in used or fname == jname:
            fname = f"{prefix}{stem}_{k}.{ext}"
            k += 1
        used.add(fname)
        return fname

    b = ds.boreholes
    bspec: Any = None
    if write_tables:
        ctext, stext, itext = ds.drillholes.csv_texts()
        bspec = {"collars": name_for("collars", "csv")}
        files[bspec["collars"]] = ctext
        if stext is not None:
            bspec["surveys"] = name_for("surveys", "csv")
            files[bspec["surveys"]] = stext
        bspec["intervals"] = name_for("intervals", "csv")
        files[bspec["intervals"]] = itext
        if ds.drillholes.other_units:
            bspec["other_units"] = list(ds.drillholes.other_units)
    elif version == 1 or len(b):
        lines = [",".join(_BOREHOLE_COLUMNS)]
        for v in np.unique(b.hole_id).tolist():
            _check_csv_field(v, "borehole hole_id", first_column=True)
        for v in np.unique(b.layer).tolist():
            _check_csv_field(v, "borehole layer")
        rep = float.__repr__
        lines += [f"{h},{rep(x)},{rep(y)},{lay},{rep(z)}" for h, (x, y), lay, z in
                  zip(b.hole_id.tolist(), b.xy.tolist(), b.layer.tolist(), b.z.tolist())]
        bspec = name_for("boreholes", "csv")
        files[bspec] = "\n".join(lines) + "\n"
    pmap: Dict[str, str] = {}
    # A derived dataset's derived points (Dataset.derived_points) go with the
    # layer's points: the saved dataset's faults carry the derived cutoffs,
    # and its layers the points the model was built from.
    for lay in list(ds.points) + [lay for lay in ds.derived_points if lay not in ds.points]:
        arr = ds.points.get(lay, np.zeros((0, 3)))
        if lay in ds.derived_points:
            arr = np.vstack([arr, ds.derived_points[lay]])
        fname = name_for(f"points_{_safe(lay)}", "csv")
        pmap[lay] = fname
        files[fname] = "x,y,z\n" + "".join(f"{_fmt(x)},{_fmt(y)},{_fmt(z)}\n" for x, y, z in arr)
    fault_files: Dict[str, Dict[str, str]] = {}
    for f in ds.faults:
        ff = fault_files.setdefault(f.name, {})
        if f.points is not None:
            ff["points"] = name_for(f"fault_{_safe(f.name)}_points", "csv")
            files[ff["points"]] = _fault_points_csv(f)
        if f.surface is not None:
            ff["surface"] = name_for(f"fault_{_safe(f.name)}_surface", "ts")
            files[ff["surface"]] = _fault_surface_ts(f, ds.crs)

    doc = {"faultmesh_dataset": version, "name": ds.name}
    if ds.crs:
        doc["crs"] = ds.crs
    if ds.snap_distance is not None:
        doc["snap_distance"] = float(ds.snap_distance)
    doc["layers"] = list(ds.layers)
    doc["boundary"] = [[float(x), float(y)] for x, y in ds.boundary]
    if bspec is not None:
        doc["boreholes"] = bspec
    if pmap:
        doc["points"] = pmap
    doc["sections"] = [{"name": s.name, "origin": [float(s.origin[0]), float(s.origin[1])],
                        "azimuth": float(s.azimuth)} for s in ds.sections.values()]
    fl = []
    for f in ds.faults:
        fd = {"name": f.name}
        if f.kind is not None:
            fd["kind"] = f.kind
        if f.group is not None:
            fd["group"] = f.group
        if len(f.tips):
            fd["tips"] = [[float(x), float(y)] for x, y in f.tips]
        fd.update(fault_files[f.name])
        if f.throw is not None:
            fd["throw"] = {k: float(v) for k, v in f.throw.items()}
        if f.derived:
            fd["derived"] = True
        tl = []
        for t in f.traces:
            sec = ds.sections.get(t.section) if t.section is not None else None
            td = {}
            if t.section is not None:
                td["section"] = t.section
            td["plane"] = _trace_points(t.plane, sec, section_coords)
            if t.layers:
                td["layers"] = {lay: {side: _trace_points(sides[side], sec, section_coords)
                                      for side in ("foot", "hanging")}
                                for lay, sides in t.layers.items()}
            tl.append(td)
        if tl or version == 1:
            fd["traces"] = tl
        fl.append(fd)
    doc["faults"] = fl
    files[jname] = _json_dump(doc)
    folder.mkdir(parents=True, exist_ok=True)

    # One atomic multi-file write (formats._common.AtomicFiles, as for model
    # files): every file goes to a temporary name beside its target, and they
    # are renamed into place only when all were written, the JSON last (the
    # commit follows the order of opening), so a reader never sees a JSON
    # whose CSVs are not in place; a failing rename puts the old files back.
    from .formats._common import AtomicFiles

    with AtomicFiles() as out:
        for fname in sorted(files, key=lambda n: n == jname):
            out.open(folder / fname).write(files[fname])
    return folder / jname


def _fault_points_csv(f: Fault) -> str:
    """A fault's points as the CSV ``x,y,z[,stick]`` that
    :func:`faultmesh.fault_inputs.read_fault_points` reads."""
    rep = float.__repr__
    P = np.asarray(f.points, dtype=np.float64).reshape(-1, 3).tolist()
    if f.sticks is None:
        return "x,y,z\n" + "".join(f"{rep(x)},{rep(y)},{rep(z)}\n" for x, y, z in P)
    labels = [str(v) for v in np.asarray(f.sticks).reshape(-1).tolist()]
    for v in set(labels):
        _check_csv_field(v, f"fault {f.name!r} stick label")
    # Each stick's rows together, the sticks in order of first appearance,
    # each stick's points in their order: the file wants a stick's rows
    # consecutive (read_fault_points), in memory they may be interleaved
    # (derive takes a stick's points in their order either way).
    first: Dict[str, int] = {}
    for i, k in enumerate(labels):
        first.setdefault(k, i)
    order = sorted(range(len(labels)), key=lambda i: (first[labels[i]], i))
    return "x,y,z,stick\n" + "".join(f"{rep(P[i][0])},{rep(P[i][1])},{rep(P[i][2])},{labels[i]}\n"
                                     for i in order)


def _fault_surface_ts(f: Fault, crs: str) -> str:
    """A fault's surface as a GOCAD TSurf (faultmesh's GOCAD writer: shortest
    round-trip decimals, so the vertices read back bit for bit)."""
    from .formats.gocad import model_lines
    from .model import Model, Surface

    V, T = f.surface
    surf = Surface(_safe(f.name), V, T, kind="fault", metadata={"kind": f.kind or ""})
    try:
        lines = model_lines(Model(name=_safe(f.name), surfaces={}, faults={surf.name: surf},
                                  crs=crs))
    except ValueError as e:
        raise DatasetError(f"Dataset.save: fault {f.name!r} surface: {e}") from None
    return "\n".join(lines) + "\n"


def _json_dump(doc) -> str:
    """JSON with one point per line: readable, diffable, compact."""
    import json
    import re
    text = json.dumps(doc, indent=1)
    # Collapse innermost numeric lists ([x, y(, z)]) onto one line.
    return re.sub(r"\[\s*(-?[\d.eE+-]+(?:,\s*-?[\d.eE+-]+)*)\s*\]",
                  lambda m: "[" + ", ".join(t.strip() for t in m.group(1).split(",")) + "]",
                  text) + "\n"
