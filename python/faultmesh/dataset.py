"""Datasets: boreholes, section lines and fault traces (DESIGN.md "Dataset format").

The data classes here are the contract between the loader and the modelling
workflow (:func:`faultmesh.build_model`). Loading and saving of format v1 is
added below them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np

FORMAT_VERSION = 1


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
    :func:`faultmesh.derive.derive_faults` (``build_model`` calls it)."""

    name: str
    kind: Optional[str] = None
    group: Optional[str] = None
    tips: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    traces: List[Trace] = field(default_factory=list)
    points: Optional[np.ndarray] = None
    sticks: Optional[np.ndarray] = None
    surface: Optional[Tuple[np.ndarray, np.ndarray]] = None
    throw: Optional[Dict[str, float]] = None

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


@dataclass(eq=False)
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

    def __eq__(self, other) -> bool:
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
    """A dataset in memory (format v1 of DESIGN.md). ``boreholes`` may have no
    rows when ``points`` carry the layer data."""

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
    #: The ground-truth model (:class:`faultmesh.geology.Geology`) of a generated
    #: dataset, None for loaded ones. ``truth`` is its ``truth`` method.
    geology: Optional[Any] = None
    #: The report of :func:`faultmesh.derive.derive_faults` on a dataset it
    #: returned (None otherwise); not compared.
    derivation: Optional[Any] = None

    def __post_init__(self) -> None:
        self.layers = [str(v) for v in self.layers]
        self.boundary = np.asarray(self.boundary, dtype=np.float64).reshape(-1, 2)
        self.points = {str(k): np.asarray(v, dtype=np.float64).reshape(-1, 3)
                       for k, v in self.points.items()}

    def __eq__(self, other) -> bool:
        """Equal data (name, crs, layers, boundary, boreholes, points, sections,
        faults); ``path``, ``truth`` and ``geology`` are not compared."""
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
        for f, g in zip(self.faults, other.faults):
            if (f.name, f.kind, f.group) != (g.name, g.kind, g.group) or not close(f.tips, g.tips) \
                    or len(f.traces) != len(g.traces):
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

    def save(self, path, *, section_coords: bool = False) -> Path:
        """Write format v1 and return the JSON path.

        ``path`` ending in ``.json`` names the JSON file, CSVs are written
        beside it as ``<stem>_boreholes.csv`` and ``<stem>_points_<layer>.csv``;
        any other ``path`` is a directory (created if needed) that receives
        ``dataset.json``, ``boreholes.csv`` and ``points_<layer>.csv``.
        ``section_coords=True`` writes trace points as section-local ``[s, z]``
        where a trace names a section and its points lie on that section's line
        (within 1 mm), as interpreted section views are usually digitised.
        Atomic: every file goes to a temporary name first; the files are renamed
        into place only when all were written, the JSON last, so an error
        leaves no half-written dataset (and the previous files untouched)."""
        return save_dataset(self, path, section_coords=section_coords)




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
    """Exact test: True for points (m, 2) inside or on the closed ring (k, 2)."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    R = np.asarray(ring, dtype=np.float64).reshape(-1, 2)
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
# Loading
# ---------------------------------------------------------------------------
_BOREHOLE_COLUMNS = ("hole_id", "x", "y", "layer", "z")
_TOP_KEYS = {"faultmesh_dataset", "name", "crs", "layers", "boundary", "boreholes",
             "points", "sections", "faults", "description", "comment"}


class _Ctx:
    """Where we are in the JSON, for messages: file plus a readable key path."""

    def __init__(self, file: Path):
        self.file = file

    def err(self, where: str, msg: str) -> DatasetError:
        return DatasetError(f"{self.file}: {where}: {msg}" if where else f"{self.file}: {msg}")

    def num(self, v, where: str) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.err(where, f"{v!r} is not a number")
        f = float(v)
        if not np.isfinite(f):
            raise self.err(where, f"{v!r} is not a finite number")
        return f

    def string(self, v, where: str) -> str:
        if not isinstance(v, str) or not v.strip():
            raise self.err(where, f"must be a non-empty string, got {v!r}")
        return v

    def obj(self, v, where: str) -> dict:
        if not isinstance(v, dict):
            raise self.err(where, f"must be a JSON object, got {type(v).__name__}")
        return v

    def lst(self, v, where: str) -> list:
        if not isinstance(v, list):
            raise self.err(where, f"must be a JSON list, got {type(v).__name__}")
        return v

    def need(self, d: dict, key: str, where: str):
        if key not in d:
            raise self.err(where, f"missing key {key!r}")
        return d[key]

    def xy_list(self, v, where: str) -> np.ndarray:
        out = []
        for i, p in enumerate(self.lst(v, where)):
            w = f"{where} point {i + 1}"
            if not isinstance(p, list) or len(p) != 2:
                raise self.err(w, f"must be [x, y], got {p!r}")
            out.append([self.num(p[0], w + " x"), self.num(p[1], w + " y")])
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
                raise self.err(w, f"must be [x, y, z] or [s, z], got {p!r}")
            if len(p) == 3:
                out[i] = [self.num(p[0], w + " x"), self.num(p[1], w + " y"),
                          self.num(p[2], w + " z")]
            else:
                if section is None:
                    raise self.err(w, "an [s, z] point needs the trace to name a section")
                s = self.num(p[0], w + " s")
                out[i, :2] = section.to_xy([s])[0]
                out[i, 2] = self.num(p[1], w + " z")
        same = np.all(out[1:] == out[:-1], axis=1)
        if same.any():
            i = int(np.flatnonzero(same)[0])
            raise self.err(where, f"points {i + 1} and {i + 2} coincide")
        return out


def _read_csv(file: Path, label: str, ctx: _Ctx):
    """Rows of a CSV with their 1-based line numbers (header = line 1). Blank
    lines and lines starting with '#' are skipped."""
    import csv
    if not file.is_file():
        raise ctx.err(label, f"file {str(file)!r} not found")
    rows, lines = [], []
    try:
        with open(file, newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            for row in reader:
                if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
                    continue
                rows.append([c.strip() for c in row])
                lines.append(reader.line_num)
    except (UnicodeDecodeError, csv.Error) as e:
        raise DatasetError(f"{file}: cannot read as UTF-8 CSV: {e}") from None
    return rows, lines


def _csv_numbers(file: Path, col: List[str], lines: List[int], field_name: str) -> np.ndarray:
    """Column ``col`` as float64; an error names file, row and field."""
    try:
        a = np.array(col, dtype=np.float64)
    except ValueError:
        a = None
    if a is not None and np.all(np.isfinite(a)):
        return a
    for v, ln in zip(col, lines):
        if v == "":
            raise DatasetError(f"{file}, row {ln}, field {field_name!r}: missing value")
        try:
            f = float(v)
        except ValueError:
            raise DatasetError(f"{file}, row {ln}, field {field_name!r}: {v!r} is not a number") from None
        if not np.isfinite(f):
            raise DatasetError(f"{file}, row {ln}, field {field_name!r}: {v!r} is not a finite number")
    raise AssertionError("unreachable")  # pragma: no cover


def _load_boreholes(file: Path, layers: List[str], ctx: _Ctx) -> Boreholes:
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
        return Boreholes(np.zeros(0, dtype=str), np.zeros((0, 2)), np.zeros(0, dtype=str),
                         np.zeros(0))
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
            raise DatasetError(f"{file}, row {ln}, field 'layer': unknown layer {v!r}; "
                               f"layers are {layers}")
    x = _csv_numbers(file, cols["x"], bl, "x")
    y = _csv_numbers(file, cols["y"], bl, "y")
    z = _csv_numbers(file, cols["z"], bl, "z")
    return Boreholes(np.array(cols["hole_id"], dtype=str), np.column_stack([x, y]),
                     np.array(cols["layer"], dtype=str), z)


def _load_points_csv(file: Path, layer: str, ctx: _Ctx) -> np.ndarray:
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
        return np.zeros((0, 3))
    return np.column_stack([_csv_numbers(file, [r[i] for r in rows], lines, c)
                            for i, c in zip(idx, names)])


def _find_json(d: Path) -> Path:
    if (d / "dataset.json").is_file():
        return d / "dataset.json"
    cands = sorted(d.glob("*.json"))
    if len(cands) == 1:
        return cands[0]
    if not cands:
        raise DatasetError(f"{d}: directory holds no dataset JSON file")
    raise DatasetError(f"{d}: directory holds several JSON files {[c.name for c in cands]} "
                       "and no dataset.json; pass the file")


def load_dataset(path) -> Dataset:
    """Load and validate a format-v1 dataset (DESIGN.md "Dataset format").

    ``path`` is the JSON file or a directory holding ``dataset.json`` (or a
    single ``*.json``); CSV paths in it are relative to the JSON. Section-local
    ``[s, z]`` trace points become XYZ through the trace's section. The boundary
    defaults to the boreholes' bounding box and is returned counter-clockwise.
    Raises :class:`DatasetError` naming the file, the row (1-based line of the
    CSV, header = 1) and field, or the fault / trace / layer that is wrong.
    """
    import json
    import warnings

    p = Path(path)
    if p.is_dir():
        p = _find_json(p)
    if not p.is_file():
        raise DatasetError(f"{p}: dataset file not found")
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except UnicodeDecodeError as e:
        raise DatasetError(f"{p}: not UTF-8 text: {e}") from None
    except json.JSONDecodeError as e:
        raise DatasetError(f"{p}: not valid JSON: {e.msg} at line {e.lineno}, column {e.colno}") from None
    ctx = _Ctx(p)
    ctx.obj(doc, "")
    if "faultmesh_dataset" not in doc:
        raise ctx.err("", "missing key 'faultmesh_dataset' (the format version, 1); "
                      "is this a faultmesh dataset?")
    version = doc["faultmesh_dataset"]
    if isinstance(version, bool) or version != FORMAT_VERSION:
        raise ctx.err("faultmesh_dataset", f"unsupported format version {version!r}; "
                      f"this faultmesh reads version {FORMAT_VERSION}")
    unknown = sorted(set(doc) - _TOP_KEYS)
    if unknown:
        warnings.warn(f"{p}: ignoring unknown key(s) {unknown}", stacklevel=2)
    name = ctx.string(doc["name"], "name") if "name" in doc else p.stem
    crs = doc.get("crs", "")
    if not isinstance(crs, str):
        raise ctx.err("crs", f"must be a string, got {crs!r}")

    # Layers.
    layers = ctx.lst(ctx.need(doc, "layers", ""), "layers")
    if not layers:
        raise ctx.err("layers", "needs at least one layer")
    layers = [ctx.string(v, f"layers[{i}]") for i, v in enumerate(layers)]
    dup = sorted({v for v in layers if layers.count(v) > 1})
    if dup:
        raise ctx.err("layers", f"repeated layer name(s) {dup}")

    # Boreholes.
    bfile = ctx.string(ctx.need(doc, "boreholes", ""), "boreholes")
    boreholes = _load_boreholes(p.parent / bfile, layers, ctx)

    # Extra points.
    points: Dict[str, np.ndarray] = {}
    for lay, v in ctx.obj(doc.get("points", {}), "points").items():
        if lay not in layers:
            raise ctx.err(f"points[{lay!r}]", f"unknown layer {lay!r}; layers are {layers}")
        if isinstance(v, str):
            points[lay] = _load_points_csv(p.parent / v, lay, ctx)
        else:  # inline [[x, y, z], ...]
            rows = ctx.lst(v, f"points[{lay!r}]")
            arr = np.empty((len(rows), 3))
            for i, q in enumerate(rows):
                w = f"points[{lay!r}] point {i + 1}"
                if not isinstance(q, list) or len(q) != 3:
                    raise ctx.err(w, f"must be [x, y, z], got {q!r}")
                arr[i] = [ctx.num(c, w + f" {k}") for c, k in zip(q, "xyz")]
            points[lay] = arr

    # Sections.
    sections: Dict[str, Section] = {}
    for i, sd in enumerate(ctx.lst(doc.get("sections", []), "sections")):
        w = f"sections[{i}]"
        ctx.obj(sd, w)
        sname = ctx.string(ctx.need(sd, "name", w), w + " name")
        w = f"section {sname!r}"
        if sname in sections:
            raise ctx.err(w, "repeated section name")
        org = ctx.lst(ctx.need(sd, "origin", w), w + " origin")
        if len(org) != 2:
            raise ctx.err(w + " origin", f"must be [x, y], got {org!r}")
        origin = [ctx.num(org[0], w + " origin x"), ctx.num(org[1], w + " origin y")]
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
        if len(boreholes.z) == 0:
            raise ctx.err("boundary", "not given, and there are no borehole rows to take the "
                          "default (the boreholes' bounding box) from")
        lo = boreholes.xy.min(axis=0)
        hi = boreholes.xy.max(axis=0)
        if not np.all(hi > lo):
            raise ctx.err("boundary", "not given, and the boreholes' bounding box (the default) "
                          "has zero width or height")
        ring = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    if _ring_orientation(ring) < 0:
        ring = ring[::-1].copy()

    # Faults.
    faults: List[Fault] = []
    seen = set()
    for i, fd in enumerate(ctx.lst(doc.get("faults", []), "faults")):
        w = f"faults[{i}]"
        ctx.obj(fd, w)
        fname = ctx.string(ctx.need(fd, "name", w), w + " name")
        w = f"fault {fname!r}"
        if fname in seen:
            raise ctx.err(w, "repeated fault name")
        seen.add(fname)
        kind = ctx.need(fd, "kind", w)
        if kind not in ("normal", "reverse"):
            raise ctx.err(w + " kind", f"must be 'normal' or 'reverse', got {kind!r}")
        group = fd.get("group")
        if group is not None:
            group = ctx.string(group, w + " group")
        tips = ctx.xy_list(fd.get("tips", []), w + " tips")
        tds = ctx.lst(ctx.need(fd, "traces", w), w + " traces")
        if not tds:
            raise ctx.err(w + " traces", "needs at least one trace")
        traces: List[Trace] = []
        for j, td in enumerate(tds):
            tw = f"{w} trace {j + 1}"
            ctx.obj(td, tw)
            sec = None
            sname = td.get("section")
            if sname is not None:
                sname = ctx.string(sname, tw + " section")
                if sname not in sections:
                    raise ctx.err(tw, f"unknown section {sname!r}; sections are {sorted(sections)}")
                sec = sections[sname]
            plane = ctx.polyline(ctx.need(td, "plane", tw), tw + " plane", sec)
            if np.any(np.diff(plane[:, 2]) > 0):
                k = int(np.flatnonzero(np.diff(plane[:, 2]) > 0)[0])
                raise ctx.err(tw + " plane", f"must go top down, but point {k + 2} is higher "
                              f"than point {k + 1}")
            tl: Dict[str, Dict[str, np.ndarray]] = {}
            for lay, sides in ctx.obj(td.get("layers", {}), tw + " layers").items():
                lw = f"{tw} layer {lay!r}"
                if lay not in layers:
                    raise ctx.err(lw, f"unknown layer {lay!r}; layers are {layers}")
                ctx.obj(sides, lw)
                extra = sorted(set(sides) - {"foot", "hanging"})
                if extra:
                    raise ctx.err(lw, f"unknown key(s) {extra}; expected 'foot' and 'hanging'")
                tl[lay] = {side: ctx.polyline(ctx.need(sides, side, lw), f"{lw} {side}", sec)
                           for side in ("foot", "hanging")}
            traces.append(Trace(sname, plane, tl))
        fault = Fault(fname, kind, group, tips, traces)
        _check_inside(fault, ring, ctx)
        faults.append(fault)

    ds = Dataset(name=name, layers=layers, boundary=ring, boreholes=boreholes, points=points,
                 sections=sections, faults=faults, crs=crs, path=p)
    for lay in layers:
        n = len(ds.layer_points(lay))
        if n < 3:
            raise ctx.err(f"layer {lay!r}", f"has {n} data point(s) (borehole hits plus extra "
                          "points); a stratum TIN needs at least 3")
    return ds


def _check_inside(fault: Fault, ring: np.ndarray, ctx: _Ctx) -> None:
    """Every tip and trace point of ``fault`` lies inside or on the boundary."""
    labels, pts = [], []
    for i, t in enumerate(fault.tips):
        labels.append(f"tip {i + 1}")
        pts.append(t)
    for j, tr in enumerate(fault.traces):
        for k, q in enumerate(tr.plane):
            labels.append(f"trace {j + 1} plane point {k + 1}")
            pts.append(q[:2])
        for lay, sides in tr.layers.items():
            for side, arr in sides.items():
                for k, q in enumerate(arr):
                    labels.append(f"trace {j + 1} layer {lay!r} {side} point {k + 1}")
                    pts.append(q[:2])
    if not pts:
        return
    P = np.array(pts)
    inside = points_in_polygon(P, ring)
    if not inside.all():
        k = int(np.flatnonzero(~inside)[0])
        n_out = int(np.sum(~inside))
        raise ctx.err(f"fault {fault.name!r}", f"{labels[k]} ({P[k, 0]:.3f}, {P[k, 1]:.3f}) lies "
                      f"outside the study-area boundary ({n_out} point(s) outside)")


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


def save_dataset(ds: Dataset, path, *, section_coords: bool = False) -> Path:
    """Write ``ds`` in format v1; see :meth:`Dataset.save`."""
    import os
    import tempfile

    path = Path(path)
    if path.suffix.lower() == ".json":
        folder, jname, prefix = path.parent, path.name, path.stem + "_"
    else:
        folder, jname, prefix = path, "dataset.json", ""
    folder.mkdir(parents=True, exist_ok=True)

    files: Dict[str, str] = {}  # file name -> content
    b = ds.boreholes
    lines = [",".join(_BOREHOLE_COLUMNS)]
    for h, (x, y), lay, z in zip(b.hole_id, b.xy, b.layer, b.z):
        for v, what in ((h, "hole_id"), (lay, "layer")):
            if any(c in str(v) for c in ',"\n\r') or str(v) != str(v).strip() or not str(v):
                raise DatasetError(f"Dataset.save: borehole {what} {str(v)!r} cannot be written "
                                   "to CSV (empty, surrounding spaces, comma, quote or newline)")
        lines.append(f"{h},{_fmt(x)},{_fmt(y)},{lay},{_fmt(z)}")
    bname = prefix + "boreholes.csv"
    files[bname] = "\n".join(lines) + "\n"
    pmap: Dict[str, str] = {}
    used = {bname}
    for lay, arr in ds.points.items():
        fname = f"{prefix}points_{_safe(lay)}.csv"
        k = 2
        while fname in used:
            fname = f"{prefix}points_{_safe(lay)}_{k}.csv"
            k += 1
        used.add(fname)
        pmap[lay] = fname
        files[fname] = "x,y,z\n" + "".join(f"{_fmt(x)},{_fmt(y)},{_fmt(z)}\n" for x, y, z in arr)

    doc = {"faultmesh_dataset": FORMAT_VERSION, "name": ds.name}
    if ds.crs:
        doc["crs"] = ds.crs
    doc["layers"] = list(ds.layers)
    doc["boundary"] = [[float(x), float(y)] for x, y in ds.boundary]
    doc["boreholes"] = bname
    if pmap:
        doc["points"] = pmap
    doc["sections"] = [{"name": s.name, "origin": [float(s.origin[0]), float(s.origin[1])],
                        "azimuth": float(s.azimuth)} for s in ds.sections.values()]
    fl = []
    for f in ds.faults:
        fd = {"name": f.name, "kind": f.kind}
        if f.group is not None:
            fd["group"] = f.group
        if len(f.tips):
            fd["tips"] = [[float(x), float(y)] for x, y in f.tips]
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
        fd["traces"] = tl
        fl.append(fd)
    doc["faults"] = fl
    files[jname] = _json_dump(doc)

    # mkstemp creates files readable by the owner only; give the final files
    # the permissions an ordinary open() would (0666 minus the umask).
    umask = os.umask(0)
    os.umask(umask)
    tmps: Dict[str, str] = {}
    try:
        for fname, text in files.items():
            fd_, tmp = tempfile.mkstemp(prefix=f".{fname}.", suffix=".tmp", dir=folder)
            tmps[fname] = tmp
            with os.fdopen(fd_, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(text)
            os.chmod(tmp, 0o666 & ~umask)
        # Swap the files in, JSON last (a reader never sees a JSON whose CSVs
        # are not in place yet). Files being overwritten are first moved aside
        # and put back if any rename fails, so the previous dataset survives.
        backups: Dict[str, str] = {}
        done: List[str] = []
        try:
            for fname in sorted(tmps, key=lambda n: n == jname):
                dst = folder / fname
                if dst.exists():
                    bak = str(folder / f".{fname}.{os.getpid()}.bak")
                    os.replace(dst, bak)
                    backups[fname] = bak
                os.replace(tmps[fname], dst)
                del tmps[fname]
                done.append(fname)
        except BaseException:
            for fname in done:
                try:
                    os.unlink(folder / fname)
                except OSError:
                    pass
            for fname, bak in backups.items():
                os.replace(bak, folder / fname)
            raise
        for bak in backups.values():
            try:
                os.unlink(bak)
            except OSError:
                pass
    finally:
        for tmp in tmps.values():
            try:
                os.unlink(tmp)
            except OSError:
                pass
    return folder / jname


def _json_dump(doc) -> str:
    """JSON with one point per line: readable, diffable, compact."""
    import json
    import re
    text = json.dumps(doc, indent=1)
    # Collapse innermost numeric lists ([x, y(, z)]) onto one line.
    return re.sub(r"\[\s*(-?[\d.eE+-]+(?:,\s*-?[\d.eE+-]+)*)\s*\]",
                  lambda m: "[" + ", ".join(t.strip() for t in m.group(1).split(",")) + "]",
                  text) + "\n"
