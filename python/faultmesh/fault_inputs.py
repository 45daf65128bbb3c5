"""Readers of a fault's geometry given as data (dataset format v2, docs/dataset.md).

Besides hand-drawn ``traces``, a v2 fault may give its geometry as

* ``"points": "F.csv"`` -- points on the fault surface (e.g. seismic fault
  picks), read by :func:`read_fault_points`: CSV ``x,y,z[,stick]``; the
  optional ``stick`` column groups the points into fault sticks (the
  interpreter's polylines down the fault on seismic lines);
* ``"surface": "F.ts"`` -- a triangulated fault surface in GOCAD TSurf format,
  read by :func:`read_fault_surface` through the GOCAD reader
  (:func:`faultmesh.formats.gocad.read_ts`).

Errors are :class:`~faultmesh.dataset.DatasetError` naming the file and, for
CSV, the row (1-based line, header = 1) and the field.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import NamedTuple, Optional, Tuple

import numpy as np

from .dataset import (_QUOTE_MAX, DatasetError, _csv_numbers, _Ctx, _read_csv,
                      _read_regular_file)

__all__ = ["FaultPoints", "FaultSurface", "read_fault_points", "read_fault_surface"]


class FaultPoints(NamedTuple):
    """Points on a fault: ``points`` (m, 3); ``sticks`` (m,) str, the stick
    label of each point (points of one stick consecutive, in order along the
    stick), or None when the file has no ``stick`` column."""

    points: np.ndarray
    sticks: Optional[np.ndarray]


class FaultSurface(NamedTuple):
    """A triangulated fault surface: ``vertices`` (n, 3) float64, ``triangles``
    (m, 3) int64 rows of ``vertices``."""

    vertices: np.ndarray
    triangles: np.ndarray


def read_fault_points(path, *, ctx: Optional[_Ctx] = None,
                      label: str = "fault points") -> FaultPoints:
    """Read a fault-points CSV ``x,y,z[,stick]``.

    A header row naming ``x``, ``y``, ``z`` (and optionally ``stick``; other
    columns are ignored) is expected; a file without one is read as plain
    ``x,y,z`` rows, as the v1 ``points`` CSVs. ``stick`` labels are compared as
    text (``1`` and ``01`` are different sticks). Checks: at least 3 points;
    with sticks, every row has a label, the rows of a stick are consecutive
    (their order is the stick's polyline; a label that comes back after
    another stick is an error), a stick has at least 2 points and no two
    consecutive points of a stick coincide. ``ctx`` and ``label`` name the
    JSON key in the message of a missing file.
    """
    file = Path(path)
    rows, lines = _read_csv(file, label, ctx if ctx is not None else _Ctx(file))
    header = [h.lower() for h in rows[0]] if rows else []
    if rows and all(c in header for c in "xyz"):
        for c in ("x", "y", "z", "stick"):
            if header.count(c) > 1:
                raise DatasetError(f"{file}, row {lines[0]}: column {c!r} appears more than "
                                   "once in the header")
        idx = {c: header.index(c) for c in ("x", "y", "z", "stick") if c in header}
        ncol = len(header)
        rows, lines = rows[1:], lines[1:]
    else:  # no header: x, y, z
        idx, ncol = {"x": 0, "y": 1, "z": 2}, 3
    for r, ln in zip(rows, lines):
        if len(r) != ncol:
            raise DatasetError(f"{file}, row {ln}: expected {ncol} fields, got {len(r)}")
    if len(rows) < 3:
        raise DatasetError(f"{file}: {len(rows)} fault point(s); a fault surface needs at "
                           "least 3")
    pts = np.column_stack([_csv_numbers(file, [r[idx[c]] for r in rows], lines, c)
                           for c in "xyz"])
    if "stick" not in idx:
        return FaultPoints(pts, None)
    sticks = np.array([r[idx["stick"]] for r in rows], dtype=str)
    ln = np.asarray(lines, dtype=np.int64)
    empty = np.char.str_len(sticks) == 0
    if empty.any():
        k = int(np.flatnonzero(empty)[0])
        raise DatasetError(f"{file}, row {ln[k]}, field 'stick': missing value (every row needs "
                           "a stick label when the column is there)")
    start = np.ones(len(sticks), dtype=bool)
    start[1:] = sticks[1:] != sticks[:-1]
    run_rows = np.flatnonzero(start)
    # A label that starts a second run: the stick resumes after another one
    # (a loop over sticks, not over points).
    seen = {}
    for k in run_rows.tolist():
        lab = str(sticks[k])
        if lab in seen:
            raise DatasetError(f"{file}, row {ln[k]}, field 'stick': stick {lab!r} resumes after "
                               f"other sticks (it started at row {ln[seen[lab]]}); the rows of a "
                               "stick must be consecutive, in order along the stick")
        seen[lab] = k
    bad = stick_problem(pts, sticks)
    if bad is not None:
        k, prev, why = bad
        if prev is None:
            raise DatasetError(f"{file}, row {ln[k]}, field 'stick': {why}")
        raise DatasetError(f"{file}, row {ln[k]}, fields 'x', 'y', 'z': {why} (row {ln[prev]})")
    return FaultPoints(pts, sticks)


def stick_problem(points: np.ndarray, sticks) -> Optional[Tuple[int, Optional[int], str]]:
    """The first break of the rules a stick keeps (the file's and the
    in-memory ``Fault``'s: one rule, so that a dataset that derives also
    loads once saved): a stick has at least 2 points, and no two
    consecutive points of a stick coincide. ``sticks`` (m,): the label of
    each point (compared as text, as a file's are); a stick's points are
    those of its label in their order (in memory they may be interleaved
    with another stick's; a file has them consecutive). Returns None, or
    (point index, index of the point it repeats or None, what is wrong) --
    the first stick of one point (in order of first appearance), else the
    first repeated point (in stick order)."""
    lab = np.asarray(sticks).astype(str).reshape(-1)
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not len(lab):
        return None
    _, first, inv, count = np.unique(lab, return_index=True, return_inverse=True, return_counts=True)
    one = np.flatnonzero(count < 2)
    if len(one):
        k = int(first[one[np.argmin(first[one])]])
        return k, None, f"stick {str(lab[k])!r} has one point; a stick is a polyline of at least 2 points"
    # The points stick by stick (sticks in order of first appearance).
    rank = np.argsort(np.argsort(first, kind="stable"), kind="stable")
    order = np.argsort(rank[inv], kind="stable")
    a, b = order[:-1], order[1:]
    same = np.flatnonzero((lab[a] == lab[b]) & np.all(P[a] == P[b], axis=1))
    if len(same):
        k, prev = int(b[same[0]]), int(a[same[0]])
        return k, prev, f"the point repeats the previous point of stick {str(lab[k])!r}"
    return None


def read_fault_surface(path, *, ctx: Optional[_Ctx] = None,
                       label: str = "fault surface") -> FaultSurface:
    """Read a fault surface from a GOCAD ``.ts`` file.

    Every ``TSurf`` object of the file is part of the one fault: a fault
    exported in several patches (several TSurf objects, or several TFACE parts
    of one) is read as the union of its triangles. Vertices with exactly equal
    coordinates are merged into one vertex (GOCAD's ATOMs, patch seams), so
    patches that share a border are connected; vertices come patch by patch,
    the TSurfs marked as faults first, each group in file order. Other object
    types (PLine, VSet) are ignored. The file must hold at least one TSurf,
    each with triangles; a triangle with two corners at the same position is
    an error.
    Errors of the GOCAD reader come back as :class:`DatasetError` naming the
    file and line; ``ctx`` and ``label`` name the JSON key in the message of a
    missing file.
    """
    from .formats import ModelFileError
    from .formats.gocad import read_ts

    file = Path(path)
    # The file's type first, with the loader's messages (missing, a folder, a
    # FIFO -- which must not be opened --, a dangling symlink ...).
    _read_regular_file(file, f"{(ctx if ctx is not None else _Ctx(file)).file}: {label}")
    try:
        # The geometry alone: a property column is no business of a fault's.
        model = read_ts(file, atoms="merge", properties=False)
    except ModelFileError as e:
        # The GOCAD reader quotes the line it could not read; a dataset's
        # messages quote no line of a file (the path may name a file that is
        # not a fault surface) and at most _QUOTE_MAX characters of a token.
        where = f"{file}, line {e.line}" if e.line is not None else str(file)
        why = str(e)[len(f"{e.path}, line {e.line}: " if e.line is not None else f"{e.path}: "):]
        why = why.split(", got ")[0]
        why = re.sub(r"'([^']{%d})[^']+'" % _QUOTE_MAX, r"'\1...'", why)
        raise DatasetError(f"{where}: {why}") from None
    except (OSError, ValueError) as e:
        raise DatasetError(f"{file}: cannot read as a GOCAD TSurf file: {e}") from None
    # Patches marked as faults (GEOLOGICAL_TYPE fault) first, then the others,
    # each in file order (as the GOCAD reader sorts them).
    surfaces = list(model.faults.values()) + list(model.surfaces.values())
    verts, tris, names, off = [], [], [], 0
    for s in surfaces:
        if s.n_triangles == 0:
            raise DatasetError(f"{file}: TSurf {s.name!r} has no triangles")
        verts.append(s.vertices)
        tris.append(s.triangles + off)
        names.append(s.name)
        off += s.n_vertices
    V = np.vstack(verts)
    T = np.vstack(tris)
    # Merge exactly coincident vertices (first occurrence order kept).
    uniq, first, inverse = np.unique(V, axis=0, return_index=True, return_inverse=True)
    keep = np.argsort(first, kind="stable")       # unique rows in file order
    rank = np.empty(len(keep), dtype=np.int64)
    rank[keep] = np.arange(len(keep))
    V = uniq[keep]
    T = rank[inverse.reshape(-1)][T]
    degenerate = (T[:, 0] == T[:, 1]) | (T[:, 1] == T[:, 2]) | (T[:, 0] == T[:, 2])
    if degenerate.any():
        k = int(np.flatnonzero(degenerate)[0])
        owner = np.repeat(np.arange(len(tris)), [len(t) for t in tris])[k]
        local = k - sum(len(t) for t in tris[:owner])
        raise DatasetError(f"{file}: TSurf {names[owner]!r} triangle {local + 1} "
                           f"(corners {V[T[k]].tolist()}) has two corners at the same position")
    T = _wound_alike(T, V, file)
    return FaultSurface(np.ascontiguousarray(V), np.ascontiguousarray(T, dtype=np.int64))


def _wound_alike(T: np.ndarray, V: np.ndarray, file: Path) -> np.ndarray:
    """The triangles ``T`` of a fault surface, each connected part wound
    like its first triangle; a triangle repeated (the same three corners,
    e.g. a fault exported twice into one file) kept once. The winding of a
    TSurf carries no data, and exporters mix it (a quad as two triangles
    wound opposite ways); with it mixed the surface has no outline (every
    edge inside). A :class:`DatasetError` naming ``file`` and the corners
    where the triangles are no surface: an edge shared by three or more
    triangles (overlapping patches), or a part that cannot be wound alike
    (one-sided, as a Moebius strip). Vectorised: the parity of the flips
    along a path of the triangles' adjacency from each part's first
    triangle is a shortest-path length (scipy's Dijkstra) with edges that
    keep the winding weighing 2 and those that flip it 3."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components, dijkstra

    from ._core import boundary_contours, halfedge_twins

    T = np.asarray(T, dtype=np.int64)
    _, first = np.unique(np.sort(T, axis=1), axis=0, return_index=True)
    T = T[np.sort(first)]
    m, n = len(T), int(V.shape[0])
    bad_edges = boundary_contours(T, n_vertices=n).nonmanifold_edges
    if len(bad_edges):
        lo, hi = (int(v) for v in bad_edges[0])
        count = int(np.sum((T == lo).any(axis=1) & (T == hi).any(axis=1)))
        raise DatasetError(f"{file}: the fault's triangles are no surface: the edge between "
                           f"{V[lo].tolist()} and {V[hi].tolist()} is shared by "
                           f"{count} triangles (overlapping patches?)")
    # The library's one adjacency, pairing the two uses of each edge
    # whatever their directions.
    twins = halfedge_twins(T, n_vertices=n, orientation="any")
    e1 = np.flatnonzero(twins > np.arange(3 * m))
    e2 = twins[e1]
    t1, t2 = e1 // 3, e2 // 3
    a = T.reshape(-1)                   # half-edge e runs from a[e] to b[e]
    b = T[:, [1, 2, 0]].reshape(-1)
    same = a[e1] == a[e2]               # both use the edge in the same direction
    w = np.where(same, 3.0, 2.0)
    G = coo_matrix((np.r_[w, w], (np.r_[t1, t2], np.r_[t2, t1])), shape=(m, m)).tocsr()
    _, part = connected_components(G, directed=False)
    roots = np.unique(part, return_index=True)[1]      # each part's first triangle
    dist = dijkstra(G, directed=False, indices=roots, min_only=True)
    flip = (np.rint(dist).astype(np.int64) % 2) == 1
    T = np.where(flip[:, None], T[:, [0, 2, 1]], T)
    bad = (flip[t1] ^ flip[t2]) != same
    if bad.any():
        j = e1[np.argmax(bad)]
        p, q = sorted((int(a[j]), int(b[j])))
        raise DatasetError(f"{file}: the fault's triangles cannot all be wound alike (a one-sided "
                           f"surface) at the edge between {V[p].tolist()} and {V[q].tolist()}")
    return T
