"""Drillholes: collar, survey and interval tables, desurveying, layer tops.

Dataset format v2 (docs/dataset.md, "Drillhole tables") may give the
boreholes as the three tables that drillhole databases export (Leapfrog,
acQuire, Micromine, GemPy's ``subsurface``):

* collars ``hole_id,x,y,z[,max_depth]``: ``z`` is the collar elevation,
  ``max_depth`` the depth of the end of the hole (optional column; an empty
  cell means not known);
* surveys ``hole_id,depth,azimuth,dip``: ``depth`` along the hole, ``azimuth``
  in degrees clockwise from north (0 to 360), ``dip`` in degrees from the
  horizontal (-90 straight down, +90 straight up); a hole without survey rows
  is vertical (downward);
* intervals ``hole_id,from,to,unit``: depths along the hole.

:func:`read_collars`, :func:`read_surveys` and :func:`read_intervals` read and
check one table each; :class:`Drillholes` checks the tables against each
other, desurveys the holes by minimum curvature (:meth:`Drillholes.positions`,
vectorised over any number of holes and depths) and derives the layer tops in
the form of the v1 boreholes (:meth:`Drillholes.tops`, a
:class:`faultmesh.dataset.Boreholes`). :func:`load_drillholes` does all of it.

Every error is a :class:`~faultmesh.dataset.DatasetError` naming the file, the
row (1-based line, header = 1, as a spreadsheet counts) and the field, like
the v1 loader's.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, List, Optional, Sequence, Tuple

import numpy as np

from .dataset import Boreholes, DatasetError, _check_csv_field, _csv_numbers, _Ctx, _read_csv

__all__ = ["CollarTable", "SurveyTable", "IntervalTable", "Drillholes", "DrillholeTables",
           "read_collars", "read_surveys", "read_intervals", "read_drillholes", "load_drillholes",
           "TOUCH_TOLERANCE", "HORIZONTAL_DIP"]

#: Two depths closer than this (metres) are the same depth: consecutive
#: intervals that close to each other touch (no gap, no overlap), and an
#: interval may end this far past ``max_depth``. Logged depths are written to
#: 1 cm, at best 1 mm; two values meant to be equal but computed differently
#: (e.g. ``from = previous to`` and ``to = from + thickness`` in a
#: spreadsheet) differ by floating-point noise far below 0.5 mm, while a real
#: gap or overlap is at least one unit of the finest resolution in use, 1 mm.
TOUCH_TOLERANCE = 0.5e-3

#: A contact where the hole is within this many degrees of horizontal gives
#: no top: whether the hole goes down or up there (which decides which unit
#: lies below the contact) is beyond what a survey measures (downhole survey
#: tools read dip to about 0.1 degree).
HORIZONTAL_DIP = 0.1

#: Two consecutive survey directions within this many degrees of opposite are
#: rejected: survey angles are recorded to 0.01 degree at best, so such a pair
#: is opposite as far as the data can tell, and the plane of the turn between
#: them -- hence the hole's path -- is undetermined.
_OPPOSITE_DEG = 0.01

#: Depths past this (metres) are rejected as typing errors: it is eight
#: times the deepest hole ever drilled (Kola SG-3, 12,262 m), and it keeps
#: every desurveyed position finite.
_DEEPEST = 1e5

_COLLAR_COLUMNS = ("hole_id", "x", "y", "z")
_SURVEY_COLUMNS = ("hole_id", "depth", "azimuth", "dip")
_INTERVAL_COLUMNS = ("hole_id", "from", "to", "unit")


def _r(v) -> str:
    """repr of a table value as plain Python (numpy 2 prints np.float64(...))."""
    return repr(v.item() if isinstance(v, np.generic) else v)


def _where(file, line: int, field: str) -> str:
    return f"{file}, row {int(line)}, field {field!r}"


def _default_lines(n: int) -> np.ndarray:
    """Rows as if the table were a CSV with a header and no blank lines."""
    return np.arange(2, n + 2, dtype=np.int64)


# ---------------------------------------------------------------------------
# Tables
# ---------------------------------------------------------------------------
@dataclass(eq=False)
class CollarTable:
    """Collars: ``hole_id`` (h,) str, ``xyz`` (h, 3) (z = collar elevation),
    ``max_depth`` (h,) with NaN where not given. ``file`` and ``lines`` (the
    1-based CSV line of each row) are for messages; for tables made in memory
    ``lines`` defaults to 2, 3, ... (a header on line 1)."""

    hole_id: np.ndarray
    xyz: np.ndarray
    max_depth: Optional[np.ndarray] = None
    file: Optional[Path] = None
    lines: Optional[np.ndarray] = None

    def __post_init__(self) -> None:
        self.hole_id = np.asarray(self.hole_id, dtype=str).reshape(-1)
        n = len(self.hole_id)
        self.xyz = np.asarray(self.xyz, dtype=np.float64).reshape(-1, 3)
        self.max_depth = (np.full(n, np.nan) if self.max_depth is None
                          else np.asarray(self.max_depth, dtype=np.float64).reshape(-1))
        self.lines = _default_lines(n) if self.lines is None else \
            np.asarray(self.lines, dtype=np.int64).reshape(-1)
        self.file = "collars" if self.file is None else self.file
        if not (len(self.xyz) == len(self.max_depth) == len(self.lines) == n):
            raise ValueError("CollarTable: hole_id, xyz, max_depth and lines must have the same "
                             f"number of rows, got {n}, {len(self.xyz)}, {len(self.max_depth)}, "
                             f"{len(self.lines)}")
        _check_collars(self)

    def __len__(self) -> int:
        return int(len(self.hole_id))


@dataclass(eq=False)
class SurveyTable:
    """Survey stations: ``hole_id`` (m,), ``depth`` (m,) along the hole,
    ``azimuth`` (m,) degrees clockwise from north, ``dip`` (m,) degrees from
    the horizontal (-90 = down). ``file`` and ``lines`` as in
    :class:`CollarTable`."""

    hole_id: np.ndarray
    depth: np.ndarray
    azimuth: np.ndarray
    dip: np.ndarray
    file: Optional[Path] = None
    lines: Optional[np.ndarray] = None

    def __post_init__(self) -> None:
        self.hole_id = np.asarray(self.hole_id, dtype=str).reshape(-1)
        n = len(self.hole_id)
        self.depth = np.asarray(self.depth, dtype=np.float64).reshape(-1)
        self.azimuth = np.asarray(self.azimuth, dtype=np.float64).reshape(-1)
        self.dip = np.asarray(self.dip, dtype=np.float64).reshape(-1)
        self.lines = _default_lines(n) if self.lines is None else \
            np.asarray(self.lines, dtype=np.int64).reshape(-1)
        self.file = "surveys" if self.file is None else self.file
        if not (len(self.depth) == len(self.azimuth) == len(self.dip) == len(self.lines) == n):
            raise ValueError("SurveyTable: hole_id, depth, azimuth, dip and lines must have the "
                             "same number of rows")
        _check_surveys(self)

    def __len__(self) -> int:
        return int(len(self.hole_id))


@dataclass(eq=False)
class IntervalTable:
    """Logged intervals: ``hole_id`` (k,), ``depth_from`` and ``depth_to``
    (k,) along the hole (the CSV's ``from`` and ``to``), ``unit`` (k,) str.
    ``file`` and ``lines`` as in :class:`CollarTable`."""

    hole_id: np.ndarray
    depth_from: np.ndarray
    depth_to: np.ndarray
    unit: np.ndarray
    file: Optional[Path] = None
    lines: Optional[np.ndarray] = None

    def __post_init__(self) -> None:
        self.hole_id = np.asarray(self.hole_id, dtype=str).reshape(-1)
        n = len(self.hole_id)
        self.depth_from = np.asarray(self.depth_from, dtype=np.float64).reshape(-1)
        self.depth_to = np.asarray(self.depth_to, dtype=np.float64).reshape(-1)
        self.unit = np.asarray(self.unit, dtype=str).reshape(-1)
        self.lines = _default_lines(n) if self.lines is None else \
            np.asarray(self.lines, dtype=np.int64).reshape(-1)
        self.file = "intervals" if self.file is None else self.file
        if not (len(self.depth_from) == len(self.depth_to) == len(self.unit)
                == len(self.lines) == n):
            raise ValueError("IntervalTable: hole_id, depth_from, depth_to, unit and lines must "
                             "have the same number of rows")
        _check_intervals(self)

    def __len__(self) -> int:
        return int(len(self.hole_id))


def _first_bad(bad: np.ndarray, lines: np.ndarray) -> int:
    """Index of the flagged row that comes first in the file."""
    idx = np.flatnonzero(bad)
    return int(idx[np.argmin(lines[idx])])


def _check_ids(hole_id: np.ndarray, file, lines: np.ndarray) -> None:
    empty = np.char.str_len(hole_id) == 0 if hole_id.size else np.zeros(0, bool)
    if empty.any():
        k = _first_bad(empty, lines)
        raise DatasetError(f"{_where(file, lines[k], 'hole_id')}: missing value")


def _check_finite(v: np.ndarray, file, lines: np.ndarray, field: str) -> None:
    bad = ~np.isfinite(v)
    if bad.any():
        k = _first_bad(bad, lines)
        raise DatasetError(f"{_where(file, lines[k], field)}: {_r(v[k])} is not a finite number")


def _check_deepest(v: np.ndarray, file, lines: np.ndarray, field: str) -> None:
    bad = v > _DEEPEST
    if bad.any():
        k = _first_bad(bad, lines)
        raise DatasetError(f"{_where(file, lines[k], field)}: {_r(v[k])} m is deeper than any "
                           f"hole ({_DEEPEST:g} m); a typing error?")


def _check_collars(t: CollarTable) -> None:
    _check_ids(t.hole_id, t.file, t.lines)
    for j, f in enumerate("xyz"):
        _check_finite(t.xyz[:, j], t.file, t.lines, f)
    bad = ~(t.max_depth > 0) & ~np.isnan(t.max_depth)
    if bad.any():
        k = _first_bad(bad, t.lines)
        raise DatasetError(f"{_where(t.file, t.lines[k], 'max_depth')}: {_r(t.max_depth[k])} is "
                           "not a positive finite depth (leave the cell empty if not known)")
    _check_deepest(t.max_depth, t.file, t.lines, "max_depth")
    # Duplicate hole ids: every row after the first one of its id (in file order).
    order = np.lexsort((t.lines, t.hole_id))
    ids = t.hole_id[order]
    dup = np.zeros(len(ids), dtype=bool)
    dup[1:] = ids[1:] == ids[:-1]
    if dup.any():
        pos = np.flatnonzero(dup)
        k = int(order[pos[np.argmin(t.lines[order[pos]])]])
        first = int(np.min(t.lines[t.hole_id == t.hole_id[k]]))
        raise DatasetError(f"{_where(t.file, t.lines[k], 'hole_id')}: hole {_r(t.hole_id[k])} "
                           f"already has a collar (row {first})")


def _same_hole_runs(hole_id: np.ndarray, lines: np.ndarray, key: np.ndarray):
    """Rows ordered by hole, then by ``key``, then by line; and a mask of the
    rows whose predecessor in that order belongs to the same hole."""
    order = np.lexsort((lines, key, hole_id))
    ids = hole_id[order]
    same = np.zeros(len(order), dtype=bool)
    same[1:] = ids[1:] == ids[:-1]
    return order, same


def _check_surveys(t: SurveyTable) -> None:
    _check_ids(t.hole_id, t.file, t.lines)
    for v, f in ((t.depth, "depth"), (t.azimuth, "azimuth"), (t.dip, "dip")):
        _check_finite(v, t.file, t.lines, f)
    for bad, field, why in ((t.depth < 0, "depth", "is negative; depths are measured along "
                             "the hole from the collar"),
                            ((t.azimuth < 0) | (t.azimuth > 360), "azimuth",
                             "is outside 0..360 degrees (clockwise from north)"),
                            ((t.dip < -90) | (t.dip > 90), "dip",
                             "is outside -90..90 degrees (from the horizontal, -90 = down)")):
        if bad.any():
            k = _first_bad(bad, t.lines)
            v = {"depth": t.depth, "azimuth": t.azimuth, "dip": t.dip}[field][k]
            raise DatasetError(f"{_where(t.file, t.lines[k], field)}: {_r(v)} {why}")
    _check_deepest(t.depth, t.file, t.lines, "depth")
    # Depths strictly increasing down the file within each hole.
    order, same = _same_hole_runs(t.hole_id, t.lines, t.lines)
    d = t.depth[order]
    bad = np.zeros(len(order), dtype=bool)
    bad[1:] = same[1:] & ~(d[1:] > d[:-1])
    if bad.any():
        pos = np.flatnonzero(bad)
        p = int(pos[np.argmin(t.lines[order[pos]])])
        k, prev = int(order[p]), int(order[p - 1])
        raise DatasetError(f"{_where(t.file, t.lines[k], 'depth')}: {_r(t.depth[k])} is not "
                           f"greater than the previous survey depth {_r(t.depth[prev])} of hole "
                           f"{_r(t.hole_id[k])} (row {t.lines[prev]}); survey rows of a hole must "
                           "go down the hole")
    # A turn back onto itself between consecutive stations has no defined arc.
    if len(order) > 1:
        tv = _directions(t.azimuth[order], t.dip[order])
        beta = _dogleg(tv[:-1], tv[1:])
        bad = np.zeros(len(order), dtype=bool)
        bad[1:] = same[1:] & (beta > np.pi - np.deg2rad(_OPPOSITE_DEG))
        if bad.any():
            pos = np.flatnonzero(bad)
            p = int(pos[np.argmin(t.lines[order[pos]])])
            k, prev = int(order[p]), int(order[p - 1])
            raise DatasetError(f"{_where(t.file, t.lines[k], 'azimuth')} and 'dip': the hole "
                               f"turns back onto itself (direction opposite to row "
                               f"{t.lines[prev]}); the path between the two stations is undefined")


def _check_intervals(t: IntervalTable) -> None:
    _check_ids(t.hole_id, t.file, t.lines)
    _check_finite(t.depth_from, t.file, t.lines, "from")
    _check_finite(t.depth_to, t.file, t.lines, "to")
    empty = np.char.str_len(t.unit) == 0 if t.unit.size else np.zeros(0, bool)
    if empty.any():
        k = _first_bad(empty, t.lines)
        raise DatasetError(f"{_where(t.file, t.lines[k], 'unit')}: missing value")
    bad = t.depth_from < 0
    if bad.any():
        k = _first_bad(bad, t.lines)
        raise DatasetError(f"{_where(t.file, t.lines[k], 'from')}: {_r(t.depth_from[k])} is "
                           "negative; depths are measured along the hole from the collar")
    _check_deepest(t.depth_to, t.file, t.lines, "to")
    bad = ~(t.depth_to > t.depth_from)
    if bad.any():
        k = _first_bad(bad, t.lines)
        raise DatasetError(f"{_where(t.file, t.lines[k], 'to')}: {_r(t.depth_to[k])} is not "
                           f"greater than 'from' {_r(t.depth_from[k])}")
    # Consecutive intervals of a hole (ordered by 'from') must touch.
    order, same = _same_hole_runs(t.hole_id, t.lines, t.depth_from)
    a, b = t.depth_from[order], t.depth_to[order]
    step = np.zeros(len(order))
    step[1:] = a[1:] - b[:-1]          # > 0 gap, < 0 overlap
    bad = same & (np.abs(step) > TOUCH_TOLERANCE)
    if bad.any():
        pos = np.flatnonzero(bad)
        p = int(pos[np.argmin(t.lines[order[pos]])])
        k, prev = int(order[p]), int(order[p - 1])
        what = "gap" if step[p] > 0 else "overlap"
        raise DatasetError(
            f"{_where(t.file, t.lines[k], 'from')}: {what} of {abs(step[p]):.6g} m in hole "
            f"{_r(t.hole_id[k])}: this interval starts at {_r(a[p])} but the one above it (row "
            f"{t.lines[prev]}) ends at {_r(t.depth_to[prev])}; consecutive intervals of a hole "
            f"must touch (within {TOUCH_TOLERANCE * 1e3:g} mm; log unlogged or lost core as a "
            "unit such as 'unknown' and list it in other_units)")


# ---------------------------------------------------------------------------
# Readers
# ---------------------------------------------------------------------------
def _table(file: Path, label: str, columns: Sequence[str], optional: Sequence[str],
           ctx: Optional[_Ctx]):
    """Header-checked body of a CSV: ({column: [text]}, lines (n,) int)."""
    file = Path(file)
    ctx = ctx if ctx is not None else _Ctx(file)
    rows, lines = _read_csv(file, label, ctx)
    if not rows:
        raise DatasetError(f"{file}: empty file (expected header {','.join(columns)})")
    header = [h.lower() for h in rows[0]]
    missing = [c for c in columns if c not in header]
    if missing:
        raise DatasetError(f"{file}, row {lines[0]}: header lacks column(s) {missing}; "
                           f"expected {','.join(columns)}"
                           + (f" (optional: {','.join(optional)})" if optional else ""))
    for c in list(columns) + list(optional):
        if header.count(c) > 1:
            raise DatasetError(f"{file}, row {lines[0]}: column {c!r} appears more than once "
                               "in the header")
    body, bl = rows[1:], lines[1:]
    for r, ln in zip(body, bl):
        if len(r) != len(header):
            raise DatasetError(f"{file}, row {ln}: expected {len(header)} fields, got {len(r)}")
    cols = {c: [r[header.index(c)] for r in body]
            for c in list(columns) + [c for c in optional if c in header]}
    return cols, np.asarray(bl, dtype=np.int64)


def _numbers(file: Path, col: List[str], lines: np.ndarray, field: str) -> np.ndarray:
    if not col:
        return np.zeros(0)
    return _csv_numbers(file, col, list(lines), field)


def read_collars(path, *, ctx: Optional[_Ctx] = None,
                 label: str = "boreholes collars") -> CollarTable:
    """Read a collar CSV ``hole_id,x,y,z[,max_depth]`` (header row, extra
    columns ignored; an empty ``max_depth`` cell means not known).

    ``ctx`` and ``label`` name the JSON key in the message of a missing file
    (the v2 loader passes its own)."""
    file = Path(path)
    cols, lines = _table(file, label, _COLLAR_COLUMNS, ("max_depth",), ctx)
    xyz = np.column_stack([_numbers(file, cols[c], lines, c) for c in "xyz"]).reshape(-1, 3)
    md = np.full(len(lines), np.nan)
    if "max_depth" in cols:
        given = np.array([v != "" for v in cols["max_depth"]], dtype=bool)
        if given.any():
            md[given] = _numbers(file, [v for v, g in zip(cols["max_depth"], given) if g],
                                 lines[given], "max_depth")
    return CollarTable(np.array(cols["hole_id"], dtype=str), xyz, md, file, lines)


def read_surveys(path, *, ctx: Optional[_Ctx] = None,
                 label: str = "boreholes surveys") -> SurveyTable:
    """Read a survey CSV ``hole_id,depth,azimuth,dip`` (header row, extra
    columns ignored). A header-only file is allowed (every hole vertical)."""
    file = Path(path)
    cols, lines = _table(file, label, _SURVEY_COLUMNS, (), ctx)
    return SurveyTable(np.array(cols["hole_id"], dtype=str),
                       _numbers(file, cols["depth"], lines, "depth"),
                       _numbers(file, cols["azimuth"], lines, "azimuth"),
                       _numbers(file, cols["dip"], lines, "dip"), file, lines)


def read_intervals(path, *, ctx: Optional[_Ctx] = None,
                   label: str = "boreholes intervals") -> IntervalTable:
    """Read an interval CSV ``hole_id,from,to,unit`` (header row, extra columns
    ignored). Units are checked against the layers by :meth:`Drillholes.tops`."""
    file = Path(path)
    cols, lines = _table(file, label, _INTERVAL_COLUMNS, (), ctx)
    return IntervalTable(np.array(cols["hole_id"], dtype=str),
                         _numbers(file, cols["from"], lines, "from"),
                         _numbers(file, cols["to"], lines, "to"),
                         np.array(cols["unit"], dtype=str), file, lines)


# ---------------------------------------------------------------------------
# Geometry of minimum curvature
# ---------------------------------------------------------------------------
def _directions(azimuth, dip) -> np.ndarray:
    """Unit vectors (n, 3) (east, north, up) of holes at ``azimuth`` (clockwise
    from north) and ``dip`` (from the horizontal, -90 = down), in degrees. A
    dip of exactly +-90 gives exactly (0, 0, +-1), so that a vertical hole keeps
    its collar's x, y to the last bit whatever azimuth is written."""
    a = np.deg2rad(np.asarray(azimuth, dtype=np.float64))
    p = np.deg2rad(np.asarray(dip, dtype=np.float64))
    vertical = np.abs(np.asarray(dip, dtype=np.float64)) == 90.0
    c = np.where(vertical, 0.0, np.cos(p))
    up = np.where(vertical, np.sign(np.asarray(dip, dtype=np.float64)), np.sin(p))
    return np.column_stack([c * np.sin(a), c * np.cos(a), up]).reshape(-1, 3)


def _dogleg(t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """Angle (radians) between unit vectors, accurate for tiny and for nearly
    opposite directions (unlike arccos of the dot product)."""
    return 2.0 * np.arctan2(np.linalg.norm(t1 - t0, axis=1), np.linalg.norm(t1 + t0, axis=1))


def _ratio_factor(beta: np.ndarray) -> np.ndarray:
    """Minimum curvature's ratio factor RF = 2/beta * tan(beta/2), 1 at beta = 0."""
    h = 0.5 * np.asarray(beta, dtype=np.float64)
    # tan(h)/h = 1 + h^2/3 + 2h^4/15 + ...; below h = 1e-4 the h^4 term (1e-17)
    # is under double precision, so the two-term series is exact to rounding.
    small = h < 1e-4
    hs = np.where(small, 1.0, h)
    return np.where(small, 1.0 + h * h / 3.0, np.tan(hs) / hs)


def _slerp_weights(f: np.ndarray, beta: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Weights (a, b) of the direction ``a t1 + b t2`` a fraction ``f`` of the
    way along the great circle from ``t1`` to ``t2`` (angle ``beta`` < pi):
    a = sin((1-f) beta) / sin(beta), b = sin(f beta) / sin(beta), written
    with numpy's normalised sinc so that they stay exact as beta -> 0 (where
    they tend to 1 - f and f)."""
    f = np.asarray(f, dtype=np.float64)
    beta = np.asarray(beta, dtype=np.float64)
    den = np.sinc(beta / np.pi)
    a = (1.0 - f) * np.sinc((1.0 - f) * beta / np.pi) / den
    b = f * np.sinc(f * beta / np.pi) / den
    return a, b


# ---------------------------------------------------------------------------
# Holes
# ---------------------------------------------------------------------------
class Drillholes:
    """Collars, surveys and intervals checked against each other, and the
    holes' paths by minimum curvature.

    Desurveying. Survey stations of a hole, ordered by depth, each give a
    direction. Between two consecutive stations the hole is the circular arc
    that leaves the first in its direction and arrives at the second in its
    direction (minimum curvature: dogleg angle ``DL`` between the two
    directions ``t1``, ``t2``, ratio factor ``RF = 2/DL * tan(DL/2)`` (1 when
    ``DL = 0``), and the step ``(d2 - d1)/2 * RF * (t1 + t2)``). Positions at
    any depth lie on that arc (not on the chord): a depth ``s`` into the
    segment is the end of a sub-arc of angle ``DL * s / (d2 - d1)`` whose end
    direction is the spherical interpolation of ``t1`` and ``t2``. From the
    collar down to the first station the hole runs straight in the first
    station's direction; below the last station it runs straight on in the
    last station's direction; a hole without stations is vertical (down).

    ``positions`` and ``directions`` work on any number of (hole, depth)
    pairs at once with numpy (no Python loop per hole or per depth).
    """

    def __init__(self, collars: CollarTable, surveys: Optional[SurveyTable] = None,
                 intervals: Optional[IntervalTable] = None) -> None:
        self.collars = collars
        self.surveys = surveys if surveys is not None else SurveyTable([], [], [], [])
        self.intervals = intervals if intervals is not None else IntervalTable([], [], [], [])
        ids = collars.hole_id
        self._sorted_ids = np.argsort(ids, kind="stable")
        self._survey_hole = self._hole_index(self.surveys.hole_id, self.surveys.file,
                                             self.surveys.lines)
        self._interval_hole = self._hole_index(self.intervals.hole_id, self.intervals.file,
                                               self.intervals.lines)
        self._check_ends()
        self._build_stations()

    # -- cross-table checks -------------------------------------------------
    def _hole_index(self, hole_id: np.ndarray, file, lines: np.ndarray) -> np.ndarray:
        """Rows of ``hole_id`` in the collar table; unknown ids are an error."""
        ids = self.collars.hole_id
        if len(hole_id) == 0:
            return np.zeros(0, dtype=np.int64)
        if len(ids) == 0:
            raise DatasetError(f"{_where(file, lines[0], 'hole_id')}: unknown hole "
                               f"{_r(hole_id[0])}; the collar table ({self.collars.file}) is empty")
        srt = ids[self._sorted_ids]
        pos = np.minimum(np.searchsorted(srt, hole_id), len(srt) - 1)
        ok = srt[pos] == hole_id
        if not ok.all():
            k = _first_bad(~ok, lines)
            raise DatasetError(f"{_where(file, lines[k], 'hole_id')}: unknown hole "
                               f"{_r(hole_id[k])}: it has no collar in {self.collars.file}")
        return self._sorted_ids[pos].astype(np.int64)

    def _check_ends(self) -> None:
        md = self.collars.max_depth
        s, h = self.surveys, self._survey_hole
        bad = s.depth > md[h] + TOUCH_TOLERANCE  # NaN (not given) compares False
        if bad.any():
            k = _first_bad(bad, s.lines)
            raise DatasetError(f"{_where(s.file, s.lines[k], 'depth')}: {_r(s.depth[k])} is past "
                               f"the end of hole {_r(s.hole_id[k])} (max_depth {_r(md[h[k]])}, "
                               f"{self.collars.file} row {self.collars.lines[h[k]]})")
        t, h = self.intervals, self._interval_hole
        bad = t.depth_to > md[h] + TOUCH_TOLERANCE
        if bad.any():
            k = _first_bad(bad, t.lines)
            raise DatasetError(f"{_where(t.file, t.lines[k], 'to')}: {_r(t.depth_to[k])} is past "
                               f"the end of hole {_r(t.hole_id[k])} (max_depth {_r(md[h[k]])}, "
                               f"{self.collars.file} row {self.collars.lines[h[k]]})")

    # -- stations -------------------------------------------------------------
    def _build_stations(self) -> None:
        """Stations of every hole, sorted by (hole, depth), with positions.

        Each hole gets a station at depth 0 (the collar) unless it has a survey
        there: in the first survey's direction, or straight down for a hole
        without surveys."""
        n_holes = len(self.collars)
        s = self.surveys
        sh = self._survey_hole
        t = _directions(s.azimuth, s.dip)
        order = np.lexsort((s.depth, sh))
        sh, sd, t = sh[order], s.depth[order], t[order]
        first = np.ones(len(sh), dtype=bool)
        first[1:] = sh[1:] != sh[:-1]
        # Direction at the collar: the first station's, or down.
        col_dir = np.tile([0.0, 0.0, -1.0], (n_holes, 1))
        col_dir[sh[first]] = t[first]
        has_zero = np.zeros(n_holes, dtype=bool)
        has_zero[sh[first & (sd == 0.0)]] = True
        virt = np.flatnonzero(~has_zero)
        hole = np.concatenate([virt, sh])
        depth = np.concatenate([np.zeros(len(virt)), sd])
        tdir = np.vstack([col_dir[virt], t]).reshape(-1, 3)
        o = np.lexsort((depth, hole))
        self._st_hole, self._st_depth, self._st_dir = hole[o], depth[o], tdir[o]
        n = len(self._st_hole)
        nxt = np.zeros(n, dtype=bool)
        nxt[:-1] = self._st_hole[1:] == self._st_hole[:-1]
        self._has_next = nxt
        # Segment k runs from station k to k + 1 (when nxt[k]).
        beta = np.zeros(n)
        step = np.zeros((n, 3))
        if n > 1:
            t0, t1 = self._st_dir[:-1], self._st_dir[1:]
            b = _dogleg(t0, t1)
            length = self._st_depth[1:] - self._st_depth[:-1]
            st = (0.5 * length * _ratio_factor(b))[:, None] * (t0 + t1)
            beta[:-1] = np.where(nxt[:-1], b, 0.0)
            step[:-1] = np.where(nxt[:-1, None], st, 0.0)
        self._st_beta = beta
        # Positions: the collar plus the steps above, summed in order down each
        # hole, all holes at once station rank by station rank (a loop over
        # the rank of a station in its hole, not over holes or depths). Unlike
        # a cumulative sum over the whole table, this gives a hole the same
        # bits whatever other holes the table holds.
        start = np.ones(n, dtype=bool)
        start[1:] = ~nxt[:-1]
        rank = np.arange(n) - np.maximum.accumulate(np.where(start, np.arange(n), 0))
        by_rank = np.argsort(rank, kind="stable")
        cuts = np.searchsorted(rank[by_rank], np.arange(int(rank.max(initial=0)) + 2))
        pos = np.empty((n, 3))
        pos[start] = self.collars.xyz[self._st_hole[start]]
        for r in range(1, len(cuts) - 1):
            idx = by_rank[cuts[r]:cuts[r + 1]]
            pos[idx] = pos[idx - 1] + step[idx - 1]
        self._st_pos = pos

    # -- queries ----------------------------------------------------------------
    @property
    def hole_id(self) -> np.ndarray:
        return self.collars.hole_id

    def _hole_rows(self, hole) -> np.ndarray:
        h = np.asarray(hole)
        if h.dtype.kind in "iu":
            h = h.astype(np.int64).reshape(-1)
            if h.size and (h.min() < 0 or h.max() >= len(self.collars)):
                raise ValueError(f"Drillholes: hole index out of range 0..{len(self.collars) - 1}")
            return h
        h = np.asarray(h, dtype=str).reshape(-1)
        ids = self.collars.hole_id
        srt = ids[self._sorted_ids]
        if h.size and not len(srt):
            raise ValueError(f"Drillholes: unknown hole {_r(h[0])} (no collars)")
        pos = np.minimum(np.searchsorted(srt, h), max(len(srt) - 1, 0))
        ok = srt[pos] == h if h.size else np.zeros(0, bool)
        if not ok.all():
            raise ValueError(f"Drillholes: unknown hole {_r(h[~ok][0])}")
        return self._sorted_ids[pos].astype(np.int64)

    def _locate(self, hole, depth):
        """For each (hole, depth): the last station at or above the depth."""
        h = self._hole_rows(hole)
        d = np.asarray(depth, dtype=np.float64).reshape(-1)
        if len(h) == 1 and len(d) != 1:
            h = np.repeat(h, len(d))
        if len(h) != len(d):
            raise ValueError(f"Drillholes: {len(h)} holes but {len(d)} depths")
        if d.size and not (np.all(np.isfinite(d)) and d.min() >= 0.0):
            raise ValueError("Drillholes: depths must be finite and >= 0")
        n = len(self._st_hole)
        # Merge stations and queries in (hole, depth) order, stations first at
        # equal depth; the running maximum of station indices is then, at each
        # query, the last station of its hole at or above it (every hole has a
        # station at depth 0 <= any query depth).
        allh = np.concatenate([self._st_hole, h])
        alld = np.concatenate([self._st_depth, d])
        kind = np.concatenate([np.zeros(n, np.int8), np.ones(len(d), np.int8)])
        o = np.lexsort((kind, alld, allh))
        tag = np.where(o < n, o, -1)
        run = np.maximum.accumulate(tag)
        j = np.empty(len(d), dtype=np.int64)
        j[o[o >= n] - n] = run[o >= n]
        return j, d

    def _evaluate(self, hole, depth):
        j, d = self._locate(hole, depth)
        t0 = self._st_dir[j]
        s = d - self._st_depth[j]
        nxt = self._has_next[j]
        jn = np.where(nxt, j + 1, j)
        length = np.where(nxt, self._st_depth[jn] - self._st_depth[j], 1.0)
        beta = np.where(nxt, self._st_beta[j], 0.0)
        f = np.where(nxt, s / length, 0.0)
        theta = f * beta
        # Direction at the depth: spherical interpolation along the arc.
        a, b = _slerp_weights(f, beta)
        t = np.where(nxt[:, None], a[:, None] * t0 + b[:, None] * self._st_dir[jn], t0)
        t = t / np.linalg.norm(t, axis=1)[:, None]
        # Position: the sub-arc from the station is itself a minimum-curvature
        # segment of length s and angle theta.
        p = self._st_pos[j] + (0.5 * s * _ratio_factor(theta))[:, None] * (t0 + t)
        return p, t

    def positions(self, hole, depth) -> np.ndarray:
        """Positions (q, 3) at ``depth`` (q,) along the holes ``hole`` (q,):
        hole ids (str) or row indices of the collar table (int), or one hole
        for all depths."""
        return self._evaluate(hole, depth)[0]

    def directions(self, hole, depth) -> np.ndarray:
        """Unit direction vectors (q, 3) (east, north, up) of the holes at ``depth``."""
        return self._evaluate(hole, depth)[1]

    def stations(self) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The desurveyed stations, collars included: hole ids (n,), depths
        (n,) and positions (n, 3), sorted by hole row and depth."""
        return self.collars.hole_id[self._st_hole], self._st_depth.copy(), self._st_pos.copy()

    # -- layer tops ---------------------------------------------------------------
    def tops(self, layers: Sequence[str], other_units: Iterable[str] = ()) -> Boreholes:
        """Layer tops in the form of the v1 boreholes.

        ``layers`` are the dataset's layers top to bottom; every interval's
        unit must be a layer or one of ``other_units`` (units that are not
        layers: e.g. "fault gouge", "unknown", "no core"; none by default, so
        that a misspelt layer name is an error rather than a silent gap).

        A top is where the hole crosses a contact from a layer into the layer
        below it in the stratigraphy: at the start (``from``) of an interval
        whose unit is a layer, when the interval just above it in the same hole
        is a layer that comes EARLIER in ``layers`` (the hole goes down there),
        or, for a hole going up there, at the start of an interval of an
        earlier layer after one of a later layer (the top of the later one). A
        contact where the order is inverted (a reverse fault puts older over
        younger rock; overturned beds) gives no top; a contact next to a unit
        of ``other_units`` gives none either (its position or nature is not
        known). The first interval of a hole, when it starts at the collar
        (``from`` within :data:`TOUCH_TOLERANCE` of 0) and the hole goes down
        there, gives the top of its unit at the collar. So a hole crossing a
        reverse fault that repeats a layer gives that layer a second top.

        A row per top: ``hole_id`` the hole's id (all tops of a hole keep it,
        so :meth:`Dataset.layer_points` keeps one hit per hole and layer as
        for v1), ``xy`` and ``z`` the desurveyed position of the top (a
        deviated hole's tops have their own x, y), ``layer`` the unit. Rows
        are ordered by hole (collar table order), then by depth. ``source``
        is the interval table's file and ``rows`` the line of the interval
        each top starts; ``desurveyed`` is True.
        """
        layers = [str(v) for v in layers]
        other = [str(v) for v in other_units]
        both = sorted(set(layers) & set(other))
        if both:
            raise DatasetError(f"other units {both} are also layers; a unit is either a layer "
                               "or not")
        it = self.intervals
        rank = {lay: i for i, lay in enumerate(layers)}
        rank.update({u: -1 for u in other})
        ok = np.array([u in rank for u in it.unit], dtype=bool) if len(it) else np.zeros(0, bool)
        if not ok.all():
            k = _first_bad(~ok, it.lines)
            extra = f", other units are {other}" if other else \
                " (list units that are not layers, such as 'unknown', in other_units)"
            raise DatasetError(f"{_where(it.file, it.lines[k], 'unit')}: unknown unit "
                               f"{_r(it.unit[k])}; layers are {layers}{extra}")
        empty = Boreholes.empty(str(it.file), desurveyed=True)
        if not len(it):
            return empty
        r = np.array([rank[u] for u in it.unit], dtype=np.int64)
        h = self._interval_hole
        order = np.lexsort((it.lines, it.depth_from, h))
        h, r, dfrom = h[order], r[order], it.depth_from[order]
        rows = order
        same = np.zeros(len(h), dtype=bool)
        same[1:] = h[1:] == h[:-1]
        prev_r = np.full(len(h), -2, dtype=np.int64)
        prev_r[1:] = r[:-1]
        contact = same & (r >= 0) & (prev_r >= 0) & (r != prev_r)
        at_collar = ~same & (r >= 0) & (dfrom <= TOUCH_TOLERANCE)
        cand = np.flatnonzero(contact | at_collar)
        if not cand.size:
            return empty
        pos, tdir = self._evaluate(h[cand], dfrom[cand])
        # Down / up beyond the survey's resolution (HORIZONTAL_DIP).
        lim = np.sin(np.deg2rad(HORIZONTAL_DIP))
        down = tdir[:, 2] < -lim
        up = tdir[:, 2] > lim
        is_contact = contact[cand]
        flat = is_contact & ~down & ~up
        if flat.any():
            k = int(rows[cand[flat]][np.argmin(it.lines[rows[cand[flat]]])])
            raise DatasetError(
                f"{_where(it.file, it.lines[k], 'from')}: hole {_r(it.hole_id[k])} is within "
                f"{HORIZONTAL_DIP:g} degrees of horizontal at this contact "
                f"({_r(it.unit[k])} after another layer), so which unit lies below it is not "
                "known; a layer top needs a hole that goes down (or up) through the contact")
        cr, pr = r[cand], prev_r[cand]
        # Going down: the deeper interval's unit is below the contact; going up:
        # the shallower one's is.
        top_down = is_contact & down & (pr < cr)
        top_up = is_contact & up & (cr < pr)
        # Contacts against the order: a reverse fault or an overturned limb
        # gives a few; more of them than contacts with the order (at least
        # three) is a layer list given bottom to top, or the intervals' units
        # swapped, and would leave layers without tops and a build failing
        # later for "too few data" with no word of why.
        inverted = is_contact & ((down & (pr > cr)) | (up & (cr > pr)))
        n_inv, n_ok = int(inverted.sum()), int((top_down | top_up).sum())
        if n_inv >= 3 and n_inv > n_ok:
            # Holes that go up at most of these contacts: the surveys' dips
            # written positive downwards (a common other convention).
            n_up = int((inverted & up).sum())
            dips_hint = (f" Or are the surveys' dips positive downwards? {n_up} of these contacts "
                         "lie where the hole goes up; here a dip is from the horizontal, -90 "
                         "straight down") if 2 * n_up > n_inv else ""
            k = int(rows[cand[inverted]][np.argmin(it.lines[rows[cand[inverted]]])])
            j = int(np.flatnonzero(rows[cand] == k)[0])
            above, below = layers[int(pr[j])], layers[int(cr[j])]
            if up[j]:
                above, below = below, above
            raise DatasetError(
                f"{it.file}: {n_inv} of the {n_inv + n_ok} contacts between layers in the holes "
                f"put a layer below one that 'layers' lists under it (e.g. row {it.lines[k]}, hole "
                f"{_r(it.hole_id[k])}: {below!r} below {above!r}; 'layers' is {layers}); such "
                "a contact gives no top. Is 'layers' listed bottom to top instead of top to "
                "bottom?" + dips_hint)
        top_collar = ~is_contact & down
        keep = top_down | top_up | top_collar
        unit_rank = np.where(top_up, pr, cr)[keep]
        p = pos[keep]
        hole = h[cand][keep]
        lay = np.array(layers, dtype=str)[unit_rank]
        # Each top names the interval row it starts (for the input policy's
        # and the checks' messages).
        return Boreholes(self.collars.hole_id[hole], p[:, :2], lay, p[:, 2], str(it.file),
                         it.lines[rows[cand][keep]], True)


def read_drillholes(collars, surveys, intervals, *, ctx: Optional[_Ctx] = None,
                    labels: Sequence[str] = ("boreholes collars", "boreholes surveys",
                                             "boreholes intervals")) -> Drillholes:
    """Read the three tables (``surveys`` may be None: every hole vertical)
    and check them against each other. ``ctx`` and ``labels`` name the JSON
    keys in the message of a missing file."""
    ct = read_collars(collars, ctx=ctx, label=labels[0])
    st = read_surveys(surveys, ctx=ctx, label=labels[1]) if surveys is not None else None
    it = read_intervals(intervals, ctx=ctx, label=labels[2])
    return Drillholes(ct, st, it)


def load_drillholes(collars, surveys, intervals, layers: Sequence[str], *,
                    other_units: Iterable[str] = (), ctx: Optional[_Ctx] = None) -> Boreholes:
    """Read the three tables (``surveys`` may be None: every hole vertical),
    check them and return the layer tops as :class:`~faultmesh.dataset.Boreholes`
    (see :meth:`Drillholes.tops`)."""
    return read_drillholes(collars, surveys, intervals, ctx=ctx).tops(layers, other_units)


@dataclass(eq=False)
class DrillholeTables:
    """The drillhole tables a dataset's boreholes come from (format v2
    ``"boreholes": {"collars": ..., "surveys": ..., "intervals": ...}``):
    ``holes`` (:class:`Drillholes`, the three tables checked and desurveyed)
    and ``other_units`` (interval units that are not layers). Kept on the
    :class:`~faultmesh.dataset.Dataset` (``drillholes``) so that
    :meth:`~faultmesh.dataset.Dataset.save` writes the tables back."""

    holes: Drillholes
    other_units: Tuple[str, ...] = ()

    def __post_init__(self) -> None:
        self.other_units = tuple(str(u) for u in self.other_units)

    def tops(self, layers: Sequence[str]) -> Boreholes:
        """The layer tops (:meth:`Drillholes.tops`)."""
        return self.holes.tops(layers, self.other_units)

    def csv_texts(self) -> Tuple[str, Optional[str], str]:
        """The collar, survey and interval tables as CSV text, every number as
        its shortest round-trip decimal (read back bit for bit, so the tops
        desurveyed again are the same); rows in table order. The survey text
        is None when no hole has a survey station."""
        rep = float.__repr__
        c, s, i = self.holes.collars, self.holes.surveys, self.holes.intervals
        for ids, f in ((c.hole_id, "collar hole_id"), (s.hole_id, "survey hole_id"),
                       (i.hole_id, "interval hole_id"), (i.unit, "interval unit")):
            for v in np.unique(ids).tolist():
                _check_csv_field(v, f, first_column=f.endswith("hole_id"))
        md = ["" if np.isnan(v) else rep(v) for v in c.max_depth.tolist()]
        has_md = any(md)
        ct = ["hole_id,x,y,z" + (",max_depth" if has_md else "")]
        ct += [f"{h},{rep(x)},{rep(y)},{rep(z)}" + (f",{m}" if has_md else "")
               for h, (x, y, z), m in zip(c.hole_id.tolist(), c.xyz.tolist(), md)]
        st = None
        if len(s):
            st = ["hole_id,depth,azimuth,dip"]
            st += [f"{h},{rep(d)},{rep(a)},{rep(p)}" for h, d, a, p in
                   zip(s.hole_id.tolist(), s.depth.tolist(), s.azimuth.tolist(), s.dip.tolist())]
        it = ["hole_id,from,to,unit"]
        it += [f"{h},{rep(a)},{rep(b)},{u}" for h, a, b, u in
               zip(i.hole_id.tolist(), i.depth_from.tolist(), i.depth_to.tolist(),
                   i.unit.tolist())]
        return ("\n".join(ct) + "\n", None if st is None else "\n".join(st) + "\n",
                "\n".join(it) + "\n")
