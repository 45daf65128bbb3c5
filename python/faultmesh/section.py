"""Vertical cross-sections of a model (the paper's Figure 7).

A section is the vertical plane through ``origin`` (x, y) whose horizontal
direction has ``azimuth`` degrees clockwise from north (+y): direction
``(sin az, cos az)``, so 0 = north, 90 = east. ``s`` is the signed distance
along that direction from ``origin``.

Every triangle edge is classified against the plane with the exact
``faultmesh.orient2d`` predicate on the vertices' XY, so triangles that share
an edge always agree on where the surface crosses: the cut is topologically
consistent even for vertices exactly on the plane. The crossing points are
then interpolated in floating point. Segments are chained into maximal
polylines without a Python loop per triangle or per segment (list ranking by
pointer jumping over half-edges).

Degenerate cases: a vertex on the plane is a polyline node (a surface that
only touches the plane at a vertex contributes no segment); an edge lying in
the plane is one segment, however many triangles share it; a triangle lying in
the plane (vertical, in the plane) contributes its three edges. A node where
more than two segments meet ends the polylines that reach it.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import numpy as np

__all__ = ["CrossSection", "SectionLine", "section_model", "section_surface", "section_direction"]


def section_direction(azimuth: float) -> np.ndarray:
    """Unit vector (2,) of ``azimuth`` (degrees clockwise from north): (sin, cos).

    Exact on the compass points so that north-south and east-west sections do
    not pick up 1e-16 noise in the other coordinate.
    """
    az = float(azimuth)
    if not np.isfinite(az):
        raise ValueError(f"section: azimuth must be a finite number of degrees, got {azimuth!r}")
    q = az % 360.0
    exact = {0.0: (0.0, 1.0), 90.0: (1.0, 0.0), 180.0: (0.0, -1.0), 270.0: (-1.0, 0.0)}
    if q in exact:
        return np.array(exact[q], dtype=np.float64)
    a = np.deg2rad(az)
    return np.array([np.sin(a), np.cos(a)], dtype=np.float64)


def _line_step(azimuth: float) -> np.ndarray:
    """The second point of the section line is ``origin + step``.

    On the compass points and the diagonals the step is (0, +-1), (+-1, 0) or
    (+-1, +-1): adding 1 to a coordinate is exact unless it crosses a power of
    two, so the line is then exactly vertical, horizontal or diagonal and
    grid vertices on it are exactly on it. (sin 45 deg and cos 45 deg differ
    in the last bit, which would tilt a diagonal line.) Other azimuths use
    the rounded unit vector: the line is the one through those two points.
    """
    q = float(azimuth) % 360.0
    exact = {0.0: (0, 1), 45.0: (1, 1), 90.0: (1, 0), 135.0: (1, -1), 180.0: (0, -1),
             225.0: (-1, -1), 270.0: (-1, 0), 315.0: (-1, 1)}
    if q in exact:
        return np.array(exact[q], dtype=np.float64)
    return section_direction(azimuth)


def _orient(origin: np.ndarray, step: np.ndarray, xy: np.ndarray) -> np.ndarray:
    from . import orient2d

    n = len(xy)
    a = np.broadcast_to(origin, (n, 2))
    b = np.broadcast_to(origin + step, (n, 2))
    return np.asarray(orient2d(np.ascontiguousarray(a), np.ascontiguousarray(b),
                               np.ascontiguousarray(xy[:, :2])), dtype=np.float64)


def _segments(vertices: np.ndarray, triangles: np.ndarray, origin: np.ndarray,
              step: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Plane-crossing segments of a TIN as pairs of node keys.

    Returns ``(segments (k, 2) int64, node_keys (N,) int64, node_xyz (N, 3))``
    with ``segments`` indexing ``node_keys``. A node key is a vertex index
    ``v`` (vertex on the plane) or ``n + lo * n + hi`` for a crossing edge
    ``lo < hi``: keys are shared by the triangles on both sides of an edge.
    """
    n = len(vertices)
    empty = (np.zeros((0, 2), np.int64), np.zeros(0, np.int64), np.zeros((0, 3)))
    if n == 0 or len(triangles) == 0:
        return empty
    val = _orient(origin, step, vertices)
    side = np.sign(val).astype(np.int8)
    st = side[triangles]
    touch = ~(np.all(st > 0, axis=1) | np.all(st < 0, axis=1))
    T = triangles[touch]
    st = st[touch]
    if len(T) == 0:
        return empty
    # Six candidate node slots per triangle: its three vertices (if on the
    # plane) and its three edges (if strictly crossed).
    a, b = T, np.roll(T, -1, axis=1)                 # edges (0,1), (1,2), (2,0)
    sa, sb = st, np.roll(st, -1, axis=1)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    edge_key = np.where(sa.astype(np.int16) * sb < 0, n + lo * n + hi, -1)
    vert_key = np.where(st == 0, T, -1)
    slots = np.concatenate([vert_key, edge_key], axis=1)  # (m, 6)
    valid = slots >= 0
    count = valid.sum(axis=1)
    # Sort each row so the valid keys come first (keys are >= 0, invalid -1).
    srt = -np.sort(-slots, axis=1)
    segs = [srt[count == 2][:, :2]]
    tri3 = srt[count == 3][:, :3]    # a triangle lying in the plane: its three edges
    if len(tri3):
        segs += [tri3[:, [0, 1]], tri3[:, [1, 2]], tri3[:, [2, 0]]]
    S = np.concatenate(segs, axis=0)
    if len(S) == 0:
        return empty
    S = np.sort(S, axis=1)
    S = np.unique(S, axis=0)
    keys, inv = np.unique(S, return_inverse=True)
    S = inv.reshape(-1, 2).astype(np.int64)
    # Node coordinates.
    xyz = np.empty((len(keys), 3), dtype=np.float64)
    isv = keys < n
    xyz[isv] = vertices[keys[isv]]
    ek = keys[~isv] - n
    elo, ehi = ek // n, ek % n
    # Opposite exact signs make vlo - vhi nonzero and t in [0, 1].
    vlo, vhi = val[elo], val[ehi]
    t = np.clip(vlo / (vlo - vhi), 0.0, 1.0)
    xyz[~isv] = vertices[elo] + t[:, None] * (vertices[ehi] - vertices[elo])
    # On north-south / east-west lines the crossing points get the line's
    # coordinate exactly (interpolation would leave last-bit noise).
    if step[0] == 0.0:
        xyz[~isv, 0] = origin[0]
    elif step[1] == 0.0:
        xyz[~isv, 1] = origin[1]
    return S, keys, xyz


def _chain(segments: np.ndarray, n_nodes: int) -> List[Tuple[np.ndarray, bool]]:
    """Chain undirected segments into maximal polylines: [(node ids, closed)].

    Half-edge ``2e`` runs ``segments[e, 0] -> segments[e, 1]``, ``2e + 1`` the
    other way. A half-edge's successor continues through its head node when
    that node has degree 2. List ranking by pointer jumping gives every
    half-edge its chain's last half-edge and its distance to it; cycles are
    cut at their smallest half-edge first. Each chain exists in both
    directions; the one whose last half-edge is smaller than its twin's is kept.
    """
    k = len(segments)
    if k == 0:
        return []
    H = 2 * k
    org = np.empty(H, dtype=np.int64)
    dst = np.empty(H, dtype=np.int64)
    org[0::2], dst[0::2] = segments[:, 0], segments[:, 1]
    org[1::2], dst[1::2] = segments[:, 1], segments[:, 0]
    deg = np.bincount(org, minlength=n_nodes)
    order = np.argsort(org, kind="stable")
    start = np.searchsorted(org[order], np.arange(n_nodes))
    succ = np.full(H, -1, dtype=np.int64)
    two = np.flatnonzero(deg == 2)
    o1, o2 = order[start[two]], order[start[two] + 1]
    succ[o1 ^ 1] = o2        # arriving along o1's segment, leave along o2's
    succ[o2 ^ 1] = o1
    steps = int(np.ceil(np.log2(H + 1))) + 1
    ids = np.arange(H)

    def jump(nxt: np.ndarray):
        p = np.where(nxt >= 0, nxt, ids)
        r = (nxt >= 0).astype(np.int64)
        for _ in range(steps):
            r = r + r[p]
            p = p[p]
        return p, r

    last, rank = jump(succ)
    cyc = succ[last] >= 0
    closed_he = np.zeros(H, dtype=bool)
    if cyc.any():
        # Minimum half-edge id of each cycle, then cut the link into it.
        m = np.where(cyc, ids, H)
        q = np.where(succ >= 0, succ, ids)
        for _ in range(steps):
            m = np.minimum(m, m[q])
            q = q[q]
        cut = np.flatnonzero(cyc & (succ == m))   # the predecessor of each cycle minimum
        closed_he[m[cut]] = True                  # mark chain heads of former cycles
        succ = succ.copy()
        succ[cut] = -1
        last, rank = jump(succ)
    keep = last < last[ids ^ 1]
    he = np.flatnonzero(keep)
    if len(he) == 0:
        return []
    srt = np.lexsort((-rank[he], last[he]))
    he = he[srt]
    bounds = np.flatnonzero(np.diff(last[he])) + 1
    out = []
    for grp in np.split(he, bounds):
        nodes = np.concatenate([org[grp], dst[grp[-1:]]])
        out.append((nodes, bool(closed_he[grp[0]] or closed_he[grp[-1] ^ 1])))
    return out


def section_surface(vertices, triangles, origin, azimuth) -> List[Tuple[np.ndarray, np.ndarray, bool]]:
    """Polylines where the vertical plane cuts one TIN: ``[(xyz (k, 3), s (k,), closed)]``.

    Open polylines run in the direction of increasing ``s`` (start ``s`` <= end
    ``s``); closed ones repeat their first point at the end.
    """
    V = np.ascontiguousarray(vertices, dtype=np.float64).reshape(-1, 3)
    T = np.ascontiguousarray(triangles, dtype=np.int64).reshape(-1, 3)
    if T.size and (T.min() < 0 or T.max() >= len(V)):
        raise ValueError(f"section_surface: triangle vertex index outside 0..{len(V) - 1}")
    o = np.asarray(origin, dtype=np.float64).reshape(-1)
    if o.shape != (2,) or not np.all(np.isfinite(o)):
        raise ValueError(f"section: origin must be two finite numbers (x, y), got {origin!r}")
    d = section_direction(azimuth)
    S, keys, xyz = _segments(V, T, o, _line_step(azimuth))
    result = []
    for nodes, closed in _chain(S, len(keys)):
        p = xyz[nodes]
        s = (p[:, :2] - o) @ d
        if not closed and s[-1] < s[0]:
            p, s = p[::-1], s[::-1]
        result.append((p, s, closed))
    # Parts in order along the section (then by elevation), deterministic.
    result.sort(key=lambda r: (float(r[1].min()), -float(r[0][:, 2].max())))
    return result


@dataclass
class SectionLine:
    """One polyline of one surface in a section."""

    surface: str
    kind: str          # "layer" or "fault"
    part: int          # 0, 1, ... per surface, in order along the section
    xyz: np.ndarray    # (k, 3)
    s: np.ndarray      # (k,) distance along the section
    closed: bool = False


@dataclass
class CrossSection:
    """The cut of a model by one vertical plane (see :func:`section_model`)."""

    model_name: str
    origin: np.ndarray
    azimuth: float
    lines: List[SectionLine] = field(default_factory=list)
    layers: List[str] = field(default_factory=list)   # model order, top to bottom
    faults: List[str] = field(default_factory=list)
    name: str = ""

    @property
    def direction(self) -> np.ndarray:
        return section_direction(self.azimuth)

    def polylines(self, surface: str) -> List[SectionLine]:
        """The polylines of ``surface`` (empty if the plane misses it)."""
        return [ln for ln in self.lines if ln.surface == surface]

    def to_rows(self) -> List[Dict[str, object]]:
        rows = []
        for ln in self.lines:
            for sv, (x, y, z) in zip(ln.s.tolist(), ln.xyz.tolist()):
                rows.append({"surface": ln.surface, "kind": ln.kind, "part": ln.part,
                             "s": sv, "x": x, "y": y, "z": z})
        return rows

    def to_csv(self, path) -> Path:
        """CSV with columns surface, kind, part, s, x, y, z (one row per polyline
        vertex, polylines in order; floats exact). Atomic write."""
        from .formats._common import AtomicFiles

        path = Path(path)
        rep = float.__repr__
        with AtomicFiles() as files:
            fh = files.open(path)
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(["surface", "kind", "part", "s", "x", "y", "z"])
            for ln in self.lines:
                for sv, (x, y, z) in zip(ln.s.tolist(), ln.xyz.tolist()):
                    w.writerow([ln.surface, ln.kind, ln.part, rep(sv), rep(x), rep(y), rep(z)])
        return path

    def plot(self, path=None, *, vertical_exaggeration: Optional[float] = None,
             title: Optional[str] = None, ax=None, fill: bool = True):
        """Draw the section (s across, elevation up) and save it to ``path`` (PNG,
        SVG, PDF by suffix). Returns the matplotlib figure. See
        :func:`faultmesh.plots.plot_section`."""
        from .plots import plot_section

        return plot_section(self, path, vertical_exaggeration=vertical_exaggeration,
                            title=title, ax=ax, fill=fill)

    def __repr__(self) -> str:
        per = {}
        for ln in self.lines:
            per[ln.surface] = per.get(ln.surface, 0) + 1
        return (f"CrossSection({self.model_name!r}, origin={self.origin.tolist()}, "
                f"azimuth={self.azimuth}, polylines={per})")


def section_model(model, origin, azimuth: float, name: str = "") -> CrossSection:
    """Cut every surface of ``model`` (layers and faults) by the vertical plane
    through ``origin`` (x, y) at ``azimuth`` degrees clockwise from north."""
    o = np.asarray(origin, dtype=np.float64).reshape(-1)
    if o.shape != (2,) or not np.all(np.isfinite(o)):
        raise ValueError(f"section: origin must be two finite numbers (x, y), got {origin!r}")
    az = float(azimuth)
    section_direction(az)  # validates
    sec = CrossSection(model_name=model.name, origin=o, azimuth=az,
                       layers=list(model.surfaces), faults=list(model.faults), name=name)
    for kind, group in (("layer", model.surfaces), ("fault", model.faults)):
        for sname, surf in group.items():
            for part, (p, s, closed) in enumerate(
                    section_surface(surf.vertices, surf.triangles, o, az)):
                sec.lines.append(SectionLine(sname, kind, part, p, s, closed))
    return sec
