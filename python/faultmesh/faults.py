"""Fine fault models (docs/design.md §4.6, paper 2.3.2).

Per fault and per layer, each trace gives ONE polyline in section order:
the footwall polyline (far end -> footwall cutoff), the fault-plane trace
points strictly between the two cutoffs (the fault strip), and the
hanging-wall polyline (hanging-wall cutoff -> far end). Consecutive polylines
are lofted (:func:`faultmesh.loft`, minimum area by default or shortest
diagonal) into one connected patch. For a reverse fault the strip runs
backwards in XY, so the patch folds: footwall (+), strip (-), hanging wall (+)
cover the repetition band three times and their signed areas add up to one
cover. A normal fault's strip is positive.

Each end of a fault is closed in one of four ways:

* ``tip``: a pinch-out point of the dataset (the tip nearest to that end)
  closes the patch with a fan. The tip is given in XY for one layer (the
  one whose cutoff line it continues); for every other layer it is moved by
  that layer's cutoff offset on the end trace (a deeper layer meets a dipping
  fault further down dip; where that puts it on the inner side of the end
  trace it is put beyond it, along strike at the same distance), and its z is the mean of the end trace's two
  cutoffs plus the change of the continuous layer TIN between them.
* ``zero_throw``: the end trace has zero throw (its cutoffs coincide): the
  patch simply ends there.
* ``extended``: no tip and non-zero throw: the end trace is carried along
  strike (each point along the strike direction of the last two traces, from
  their plane points at equal elevations) onto
  the nearest target within reach: the study-area boundary (paper: F22, a
  fault "without pinching at the boundary") or, for faults of one group, the
  outline of the partner fault that this one abuts (T-crossing). z follows
  the continuous layer TIN's change along the way. A reverse fault is not
  carried onto a partner: its fold would fold back along the partner's
  outline, and clipped there its sheets would end at different places; a
  pinch-out halfway to the partner closes it (kind ``synthetic_tip``,
  metadata ``end<i>_tip_short_of``).
* ``synthetic_tip``: nothing within reach: a tip half a trace spacing
  further along strike closes the patch (recorded in the metadata:
  ``end<i>_tip``). Both pinch-outs are decided in one place
  (:func:`_pinch_out`), and the fault surface's end trace is moved onto the
  layers' pinch-out points, which become its vertices.

Between two traces (and between an end trace and its extension) the patch
follows the continuous layer surface: with ``along_step`` (``build_model``
gives two of the layer's data spacings) polylines are put in between, at most
that far apart, each point on the straight XY line between a pair of points
of the two polylines (paired part by part: footwall, strip, hanging wall;
resampled along a part where the two have different counts) with z the
straight line's plus the continuous TIN's departure from its own straight
line there -- where that departure exceeds the fault's throw somewhere
between the two (the TIN interpolates across the fault, so its error there
is up to the throw; a smaller departure is no evidence, and the plain loft
stands). A plain loft between traces kilometres apart cut through what the
layer does in between (sweep seed 381: a layer rising 80 m between two traces
2.5 km apart, throw about 20 m). So did a tip's fan: it is filled in the same
way, the tip standing for a polyline of that point repeated with the end
polyline's cutoffs (sweep seed 986: the layer 50 m below F1's fan, 600 m
long, halfway to the tip). A fan that comes within a data spacing of a
group partner's patch is filled only where the departure also exceeds the
partner's throw: the TIN interpolates across the partner there too
(:class:`PartnerZone`, :func:`_fans_near_partners`).

Faults of one group (T- or X-crossings) are modelled together as ONE patch
per layer (:func:`group_patch`): faults that abut no partner come first; each
later fault is clipped by the XY outlines of the earlier ones (every
triangle whose closed XY projection touches them is removed, exactly, then
pinch vertices are cleaned up), so the group's patch is a set of disjoint
pieces that the stitcher treats as one region: one removed set, one gap
polygon with every piece as a hole. A folded patch is not left to that clip
(a fold cannot end along a line inside the area, and the clean-up removed
it far from the partner): the builder makes a later folded patch clear of
the earlier outlines where it is lofted (``clear_of``, :func:`_clear_of`),
and an earlier patch yields its sheets where a later folded member's band
lies (``yield_to``, :func:`_yield_to`, :func:`band_quads`).

Each layer's patch is then clipped to the study area in XY
(:meth:`StudyArea.clip_surface`, exact): a loft between two traces is a chord
that can run out of a concave area and back in across a notch; the cut puts
the patch's outline on the boundary there, as at an extended end.

The fault surface itself is lofted from the fault-plane traces, closed at a
tip by the end plane trace moved to the tip, and extended like the layers.
"""
from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, NamedTuple, Optional, Sequence, Tuple

import numpy as np

from ._core import (GeometryError, StudyArea, TouchingRegion, boundary_contours, boundary_edges, loft,
                    orient2d, triangles_at_outline_crossings, triangles_not_covered_once,
                    triangles_touching_region)

__all__ = ["LayerPatch", "FaultEnds", "EndMove", "EndMoveKind", "fault_ends", "trace_polyline",
           "layer_patch", "fault_surface", "group_patch", "group_order", "is_folded", "band_quads",
           "patch_outline", "PartnerZone", "layer_throw"]


@dataclass
class FaultEnds:
    """How each end of a fault is closed: ``tip`` (2,) or None per end and the
    outward along-strike direction (2,) per end."""

    tips: List[Optional[np.ndarray]]
    directions: List[np.ndarray]
    spacing: float


class EndMoveKind(enum.Enum):
    """How :func:`fault_surface` extends one end of a fault plane like the
    layers' patches were extended there (see :class:`EndMove`)."""

    ray = "ray"      # each point of the end trace carried along a direction onto the study-area boundary
    shift = "shift"  # the end trace moved by a vector (to an end extended onto a partner)
    pinch = "pinch"  # the end trace moved onto the layers' pinch-out points (synthetic tips)


@dataclass(frozen=True, eq=False)
class EndMove:
    """One end move of a fault plane: ``kind`` and its ``vector`` (2,) -- the
    direction of the ray (``EndMoveKind.ray``) or the displacement
    (``EndMoveKind.shift``; for ``EndMoveKind.pinch`` the layers' mean
    displacement). A pinch also has ``cutoffs`` and ``tips`` (k, 3): per
    layer, the cutoff midpoint on the end trace and the pinch-out point it
    moves to (:attr:`LayerPatch.pinch_outs`)."""

    kind: EndMoveKind
    vector: np.ndarray
    cutoffs: Optional[np.ndarray] = None
    tips: Optional[np.ndarray] = None

    @classmethod
    def ray(cls, direction) -> "EndMove":
        return cls(EndMoveKind.ray, np.asarray(direction, dtype=np.float64).reshape(2))

    @classmethod
    def shift(cls, offset) -> "EndMove":
        return cls(EndMoveKind.shift, np.asarray(offset, dtype=np.float64).reshape(2))

    @classmethod
    def pinch(cls, cutoffs, tips) -> "EndMove":
        c = np.asarray(cutoffs, dtype=np.float64).reshape(-1, 3)
        t = np.asarray(tips, dtype=np.float64).reshape(-1, 3)
        if len(c) == 0 or c.shape != t.shape:
            raise ValueError(f"EndMove.pinch: cutoffs and tips must be (k, 3) with k >= 1, got "
                             f"{c.shape} and {t.shape}")
        return cls(EndMoveKind.pinch, (t - c)[:, :2].mean(axis=0), c, t)


@dataclass
class LayerPatch:
    """The fine model of one fault (or group) in one layer."""

    fault: str
    layer: str
    vertices: np.ndarray
    triangles: np.ndarray
    ends: List[str] = field(default_factory=list)         # closing kind per end
    abuts: List[str] = field(default_factory=list)        # partners reached by an extension
    metadata: Dict[str, Any] = field(default_factory=dict)
    #: per end closed by a synthetic tip: (the end trace's cutoff midpoint,
    #: the pinch-out point) (3,) each, from :func:`_pinch_out`
    pinch_outs: Dict[int, Tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)


# ---------------------------------------------------------------------------
# Polylines
# ---------------------------------------------------------------------------
def _merge_tol(p: np.ndarray) -> float:
    # Two computed points closer than 1e-9 of the polyline's extent (1 um for
    # a 1 km trace) are one point: a zero-throw trace's cutoffs, or a plane
    # point that coincides with a cutoff up to the root finder's rounding.
    ext = float(np.ptp(p, axis=0).max()) if len(p) > 1 else 1.0
    return 1e-9 * max(1.0, ext)


def trace_polyline(trace, layer: str, area: Optional[StudyArea] = None
                   ) -> Optional[Tuple[np.ndarray, float]]:
    """(polyline (k, 3), throw distance) of ``layer`` on ``trace``: footwall
    -> strip (plane points strictly between the cutoffs) -> hanging wall,
    consecutive coincident points merged. None if the trace lacks the layer.
    :func:`trace_cutoffs` gives the cutoffs' positions in the polyline.
    ``area``: the study area (a polyline carried past a reverse fault's
    band stops on its boundary, as in :func:`layer_patch`)."""
    r = _trace_polyline(trace, layer, area)
    return None if r is None else (r[0], r[1])


def trace_cutoffs(trace, layer: str, area: Optional[StudyArea] = None) -> Optional[Tuple[int, int]]:
    """Indices in :func:`trace_polyline` of the footwall and the hanging-wall
    cutoff (equal for a zero-throw trace)."""
    r = _trace_polyline(trace, layer, area)
    return None if r is None else r[2]


def _reach_past_the_band(foot: np.ndarray, hang: np.ndarray,
                         area: Optional[StudyArea] = None) -> Tuple[np.ndarray, np.ndarray]:
    """Where a reverse fault repeats the layer (the hanging-wall cutoff lies
    behind the footwall cutoff along the section: the overlap band), the
    footwall polyline must start before the band and the hanging-wall one end
    after it, or the patch's far end lies over the patch itself and its
    outline crosses itself in XY (a hanging-wall line drawn 42 m long across
    a 54 m band: grounds seed 4). A polyline that stops inside (or just at
    the edge of) the band is carried on along its last segment's slope to one
    band width beyond it. Sections are drawn as lines: the direction along
    the section is that of the footwall polyline (else the hanging-wall one).
    With ``area`` a polyline is carried no further than the study-area
    boundary (a section that ends at the boundary inside the band: the
    patch ends on the boundary there; carried past it, its vertex lay outside
    the study area: sweep seeds 117, 377)."""
    fc, hc = foot[-1, :2], hang[0, :2]
    d = fc - foot[0, :2] if len(foot) > 1 else hang[-1, :2] - hc
    n = float(np.hypot(d[0], d[1]))
    if n == 0.0:
        return foot, hang
    d = d / n
    band = float((fc - hc) @ d)      # > 0: the hanging-wall cutoff is behind (a fold)
    if not band > _merge_tol(np.vstack([foot, hang])):
        return foot, hang

    def carried(end: np.ndarray, inner: np.ndarray, target_u: float) -> Optional[np.ndarray]:
        u_end = float((end[:2] - fc) @ d)
        du = target_u - u_end
        # z along the polyline's last segment (its slope along the section).
        seg_u = float((end[:2] - inner[:2]) @ d)
        slope = (end[2] - inner[2]) / seg_u if abs(seg_u) > 0.0 else 0.0
        if area is not None and not area.contains((end[:2] + du * d)[None, :])[0]:
            # Stop on the boundary: placed there by the ray's hit.
            way = d if du > 0.0 else -d
            t, _, _, xy = area.ray_hit(end[None, :2], way[None, :])
            if not np.isfinite(t[0]) or t[0] == 0.0:
                return None  # the end is on the boundary already
            return np.r_[xy[0], end[2] + slope * (float(t[0]) if du > 0.0 else -float(t[0]))]
        return np.r_[end[:2] + du * d, end[2] + slope * du]

    if float((hang[-1, :2] - fc) @ d) < band:
        inner = hang[-2] if len(hang) > 1 else (foot[-2] if len(foot) > 1 else hang[-1])
        c = carried(hang[-1], inner, band)
        if c is not None:
            hang = np.vstack([hang, c])
    if float((foot[0, :2] - fc) @ d) > -2.0 * band:
        inner = foot[1] if len(foot) > 1 else (hang[1] if len(hang) > 1 else foot[0])
        c = carried(foot[0], inner, -2.0 * band)
        if c is not None:
            foot = np.vstack([c, foot])
    return foot, hang


def _trace_polyline(trace, layer: str, area: Optional[StudyArea] = None):
    sides = trace.layers.get(layer)
    if sides is None:
        return None
    foot = np.asarray(sides["foot"], dtype=np.float64).reshape(-1, 3)
    hang = np.asarray(sides["hanging"], dtype=np.float64).reshape(-1, 3)
    if len(foot) == 0 or len(hang) == 0:
        return None
    foot, hang = _reach_past_the_band(foot, hang, area)
    cf, ch = foot[-1], hang[0]
    throw = float(np.linalg.norm(ch - cf))
    plane = np.asarray(trace.plane, dtype=np.float64).reshape(-1, 3)
    lo, hi = min(cf[2], ch[2]), max(cf[2], ch[2])
    strip = plane[(plane[:, 2] > lo) & (plane[:, 2] < hi)]
    # From the footwall cutoff to the hanging-wall cutoff.
    strip = strip[np.argsort(-strip[:, 2])] if cf[2] > ch[2] else strip[np.argsort(strip[:, 2])]
    pts = np.vstack([foot, strip, hang])
    i_fw, i_hw = len(foot) - 1, len(foot) + len(strip)
    tol = _merge_tol(pts)
    pts, pos = _merge_coincident(pts, tol)
    if throw <= tol:
        throw = 0.0
    return np.ascontiguousarray(pts), throw, (int(pos[i_fw]), int(pos[i_hw]))


def _merge_coincident(pts: np.ndarray, tol: float) -> Tuple[np.ndarray, np.ndarray]:
    """``pts`` with every point within ``tol`` of the last point kept
    dropped, and per input point its position in the result. A point is
    compared with the last one kept, not with its neighbour: a run of points
    each within ``tol`` of the next merges only as far as ``tol`` reaches."""
    d = np.diff(pts, axis=0)
    step = np.sqrt(np.einsum("ij,ij->i", d, d))
    if not (step <= tol).any():  # nothing to merge (the common case): one pass
        return pts, np.arange(len(pts), dtype=np.int64)
    keep = [0]
    pos = np.zeros(len(pts), dtype=np.int64)
    for i in range(1, len(pts)):  # polyline points only where some coincide
        if np.linalg.norm(pts[i] - pts[keep[-1]]) > tol:
            keep.append(i)
        pos[i] = len(keep) - 1
    return pts[keep], pos


def _cut_mid(trace, layer: str) -> Optional[np.ndarray]:
    sides = trace.layers.get(layer)
    if sides is None:
        return None
    return 0.5 * (np.asarray(sides["foot"])[-1] + np.asarray(sides["hanging"])[0])


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.hypot(v[0], v[1]))
    if n == 0.0:
        raise GeometryError("faults: zero-length direction")
    return np.asarray(v[:2], dtype=np.float64) / n


def as_study_area(ring) -> StudyArea:
    """The study area as a :class:`faultmesh.StudyArea` (built from a ring (k, 2) once)."""
    return ring if isinstance(ring, StudyArea) else StudyArea(np.asarray(ring, dtype=np.float64))


def _pull_inside(area: StudyArea, origin: np.ndarray, xy: np.ndarray, what: str) -> np.ndarray:
    """``xy`` moved back towards ``origin`` (which must be in the study area)
    until it lies in the study area: halved moves, then the origin itself."""
    xy = np.asarray(xy, dtype=np.float64).copy()
    for _ in range(60):
        if area.contains(xy[None, :])[0]:
            return xy
        xy = origin + 0.5 * (xy - origin)
    if area.contains(origin[None, :2])[0]:
        return np.asarray(origin[:2], dtype=np.float64).copy()
    raise GeometryError(f"faults: {what} at ({origin[0]:.3f}, {origin[1]:.3f}) lies outside "
                        "the study area")


def _strike_between(a: np.ndarray, b: np.ndarray, ca: np.ndarray, cb: np.ndarray) -> np.ndarray:
    """The unit XY direction from fault-plane trace ``a`` (k, 3) to trace
    ``b``, compared at the same elevations: the mean XY offset of the two
    traces' points at equal z over the z range they share (on a planar
    fault a horizontal line in the plane: the strike). Without a shared z
    range, the direction between the traces' centres ``ca``, ``cb``.

    Why not the centres alone: a trace whose section stops at the study
    area's boundary records only part of the plane (one layer's depth), and
    its centre then lies down-dip of the other's; the centre line is turned
    off strike by the offset. Sweep seed 338: F1's northern trace only
    reaches L2, its centre line ran 13 degrees off the fault's strike, and
    L1's patch, carried 805 m along it onto the boundary, put the fault
    ~185 m beside the truth's (seed 381: 7 degrees, 1.7 km)."""
    za, zb = a[:, 2], b[:, 2]
    lo, hi = max(float(za.min()), float(zb.min())), min(float(za.max()), float(zb.max()))
    if hi >= lo:
        levels = np.linspace(lo, hi, 9)
        oa, ob = np.argsort(za, kind="stable"), np.argsort(zb, kind="stable")
        pa = np.column_stack([np.interp(levels, za[oa], a[oa, 0]), np.interp(levels, za[oa], a[oa, 1])])
        pb = np.column_stack([np.interp(levels, zb[ob], b[ob, 0]), np.interp(levels, zb[ob], b[ob, 1])])
        d = (pb - pa).mean(axis=0)
        if np.hypot(d[0], d[1]) > 0.0:
            return _unit(d)
    return _unit(cb - ca)


def fault_ends(fault) -> FaultEnds:
    """Tips assigned to the two ends and the outward strike directions."""
    if not fault.traces:
        raise GeometryError(f"fault {fault.name!r} has no trace")
    centres = [np.asarray(tr.plane, dtype=np.float64)[:, :2].mean(axis=0) for tr in fault.traces]
    tips = [np.asarray(t, dtype=np.float64) for t in np.asarray(fault.tips).reshape(-1, 2)]
    end_tips: List[Optional[np.ndarray]] = [None, None]
    if len(centres) >= 2:
        planes = [np.asarray(tr.plane, dtype=np.float64).reshape(-1, 3) for tr in fault.traces]
        d_start = _strike_between(planes[1], planes[0], centres[1], centres[0])
        d_end = _strike_between(planes[-2], planes[-1], centres[-2], centres[-1])
        spacing = float(np.mean([np.hypot(*(b - a)) for a, b in zip(centres[:-1], centres[1:])]))
        for t in tips:
            e = 0 if np.hypot(*(t - centres[0])) <= np.hypot(*(t - centres[-1])) else 1
            if end_tips[e] is None:
                end_tips[e] = t
            elif end_tips[1 - e] is None:
                end_tips[1 - e] = t
    else:
        tr = fault.traces[0]
        poly = np.asarray(tr.plane, dtype=np.float64)
        some = next(iter(tr.layers.values()), None)
        if some is not None:
            dip_dir = np.asarray(some["hanging"])[-1, :2] - np.asarray(some["foot"])[0, :2]
        else:
            dip_dir = poly[-1, :2] - poly[0, :2]
        strike = _unit(np.array([-dip_dir[1], dip_dir[0]]))
        spacing = 2.0 * float(np.hypot(*dip_dir)) if np.hypot(*dip_dir) > 0 else 100.0
        if tips:
            end_tips[0] = tips[0]
            d_start = _unit(tips[0] - centres[0])
            if len(tips) > 1:
                end_tips[1] = tips[1]
                d_end = _unit(tips[1] - centres[0])
            else:
                d_end = -d_start
        else:
            d_start, d_end = -strike, strike
    return FaultEnds(end_tips, [d_start, d_end], spacing)


# ---------------------------------------------------------------------------
# Ends
# ---------------------------------------------------------------------------
def _ray_hits(p: np.ndarray, d: np.ndarray, rings: Sequence[np.ndarray]) -> np.ndarray:
    """Smallest t > 0 with p + t d on one of the rings' edges (inf if none),
    per point of ``p`` (k, 2+); ``d`` one direction (2,) or one per point
    (k, 2). Points x edges at once (numpy), in chunks of about 200k pairs."""
    return _ray_hits_edges(p, d, _ring_edges(rings))


def _ring_edges(rings: Sequence[np.ndarray]) -> np.ndarray:
    """The edges (k, 2, 2) of the closed rings, each from a vertex to the next."""
    segs = []
    for r in rings:
        r = np.asarray(r, dtype=np.float64).reshape(-1, 2)
        segs.append(np.stack([r, np.roll(r, -1, axis=0)], axis=1))
    return np.concatenate(segs) if segs else np.zeros((0, 2, 2))


def _ray_hits_edges(p: np.ndarray, d: np.ndarray, S: np.ndarray) -> np.ndarray:
    """:func:`_ray_hits` against edges ``S`` (k, 2, 2) (:func:`_ring_edges`)."""
    q = np.asarray(p, dtype=np.float64)
    q = q.reshape(len(q), q.shape[-1] if q.ndim > 1 else 2)[:, :2]
    d = np.broadcast_to(np.asarray(d, dtype=np.float64).reshape(-1, 2), q.shape)
    out = np.full(len(q), np.inf)
    if not len(S) or not len(q):
        return out
    a, e = S[:, 0], S[:, 1] - S[:, 0]
    chunk = max(1, 200_000 // len(S))
    for i in range(0, len(q), chunk):
        qi, di = q[i:i + chunk, None, :], d[i:i + chunk, None, :]
        den = di[..., 0] * e[None, :, 1] - di[..., 1] * e[None, :, 0]
        w = a[None] - qi
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[..., 0] * e[None, :, 1] - w[..., 1] * e[None, :, 0]) / den
            u = (w[..., 0] * di[..., 1] - w[..., 1] * di[..., 0]) / den
        ok = (den != 0) & (t > 0) & (u >= 0) & (u <= 1)
        out[i:i + chunk] = np.where(ok, t, np.inf).min(axis=1)
    return out


def _shift_z(pts_old: np.ndarray, xy_new: np.ndarray, surface_z) -> np.ndarray:
    """z of points moved to xy_new: old z plus the continuous surface's change."""
    z = pts_old[:, 2].copy()
    if surface_z is None:
        return z
    z0 = surface_z(pts_old[:, :2])
    z1 = surface_z(xy_new)
    dz = z1 - z0
    return np.where(np.isfinite(dz), z + dz, z)


def _reference_cutoff(tr, tip: np.ndarray, direction: np.ndarray) -> Optional[np.ndarray]:
    """The cutoff midpoint of the trace's reference layer: the layer whose
    cutoff line (through its cutoff midpoint along the strike direction)
    passes closest to ``tip``; None for a trace without layers."""
    best, ref = np.inf, None
    for lay in tr.layers:
        m = _cut_mid(tr, lay)
        off = tip - m[:2]
        dist = abs(direction[0] * off[1] - direction[1] * off[0])
        if dist < best:
            best, ref = dist, m
    return ref


def _layer_tip(fault, traces_with, layer: str, end: int, tip: np.ndarray, direction: np.ndarray,
               ring: np.ndarray, surface_z, end_poly: Optional[np.ndarray] = None) -> np.ndarray:
    """The tip (x, y, z) of ``layer`` at fault end ``end`` (see module doc).

    ``end_poly``: the end trace's polyline in this layer. The tip closes it
    with a fan, which covers the band once only if the tip lies strictly
    beyond the polyline's line, on the side ``direction`` points to (exact
    orient2d). Moved by another layer's cutoff offset, a tip beside a gently
    dipping fault's end trace can land on the inner side, and the fan's edges
    then cross the next loft's ("the patch outline is not simple": sweep
    seeds 48, 350); it is then put at the same distance along ``direction``."""
    tr = traces_with[0] if end == 0 else traces_with[-1]
    mid_l = _cut_mid(tr, layer)
    ref = _reference_cutoff(tr, tip, direction)
    if ref is None:
        ref = mid_l
    v = tip - ref[:2]
    if end_poly is not None and len(end_poly) > 1:
        a = np.ascontiguousarray(end_poly[[0], :2])
        b = np.ascontiguousarray(end_poly[[-1], :2])
        if (a != b).any():
            # The outward side: where a + direction lies (a point, like the
            # tip, at a distance of the polyline's size).
            scale = max(float(np.hypot(*(b[0] - a[0]))), float(np.hypot(*v)))
            side = np.sign(orient2d(a, b, a + scale * direction[None, :]))[0]
            t = np.sign(orient2d(a, b, (mid_l[:2] + v)[None, :]))[0]
            if side != 0 and t != side:
                v = float(np.hypot(*v)) * np.asarray(direction, dtype=np.float64)
    # Keep the tip inside the study area (a deep layer's shifted tip can
    # leave a study area that the fault's tip just fits in).
    xy = _pull_inside(as_study_area(ring), mid_l[:2], mid_l[:2] + v,
                      f"fault {fault.name!r} layer {layer!r}: the cutoff at the end trace")
    sides = tr.layers[layer]
    zc = 0.5 * (float(np.asarray(sides["foot"])[-1, 2]) + float(np.asarray(sides["hanging"])[0, 2]))
    z = zc
    if surface_z is not None:
        dz = float(surface_z(xy[None, :])[0] - surface_z(mid_l[None, :2])[0])
        if np.isfinite(dz):
            z = zc + dz
    return np.array([xy[0], xy[1], z])


def _to_boundary(area: StudyArea, poly: np.ndarray, d: np.ndarray, surface_z):
    """``poly`` carried along ``d`` onto the study-area boundary: (points
    (k, 3) placed on their sides, t (k,) the distances). A point already on
    the boundary stays where it is (t = 0, the same coordinates)."""
    t, side, _, xy = area.ray_hit(poly[:, :2], np.asarray(d, dtype=np.float64)[None, :])
    on = t == 0.0
    xy = np.where(on[:, None], poly[:, :2], xy)
    pts = np.column_stack([xy, _shift_z(poly, xy, surface_z)])
    pts[on] = poly[on]
    return pts, t


def _around_corners(area: StudyArea, pts: np.ndarray,
                    cut: Optional[Tuple[int, int]]) -> Tuple[np.ndarray, Optional[Tuple[int, int]]]:
    """A polyline on the study-area boundary made to follow it: where two
    consecutive points lie on different sides, the corners between them (the
    shorter way round) are inserted, z interpolated along the boundary.
    Without them the patch's edge between the two points is a chord: across
    a reflex corner it runs outside the study area, across a convex one it
    cuts off a sliver of the gap that touches the rest only at the patch's
    vertex (sweep seeds 150, 363, 455). ``cut`` (footwall and hanging-wall
    cutoff positions) is moved to the points' new positions. Polylines not
    wholly on the boundary are returned as they are."""
    if len(pts) < 2:
        return pts, cut
    side, s = area.locate(pts[:, :2])
    if (side < 0).any():
        return pts, cut
    per = float(area.perimeter)
    ring = np.asarray(area.ring, dtype=np.float64)
    t = area.arc_position(side, s)
    tc = area.arc_position(np.arange(len(ring)), np.zeros(len(ring)))
    ta = t[:-1, None]
    fwd = np.mod(t[1:, None] - ta, per)
    forward = fwd <= 0.5 * per
    span = np.where(forward, fwd, per - fwd)                                    # (n-1, 1)
    along = np.where(forward, np.mod(tc[None, :] - ta, per), np.mod(ta - tc[None, :], per))
    # A corner within the merge tolerance of either point is that point
    # (located on the next side up to rounding): nothing to insert.
    tol = _merge_tol(pts)
    da = np.hypot(ring[None, :, 0] - pts[:-1, None, 0], ring[None, :, 1] - pts[:-1, None, 1])
    db = np.hypot(ring[None, :, 0] - pts[1:, None, 0], ring[None, :, 1] - pts[1:, None, 1])
    seg, cor = np.nonzero((along > 0.0) & (along < span) & (da > tol) & (db > tol))
    if len(seg) == 0:
        return pts, cut
    order = np.lexsort((along[seg, cor], seg))
    seg, cor = seg[order], cor[order]
    frac = along[seg, cor] / span[seg, 0]
    z = pts[seg, 2] + frac * (pts[seg + 1, 2] - pts[seg, 2])
    out = np.insert(pts, seg + 1, np.column_stack([ring[cor], z]), axis=0)
    if cut is not None:
        moved = np.arange(len(pts)) + np.searchsorted(seg + 1, np.arange(len(pts)), side="right")
        cut = (int(moved[cut[0]]), int(moved[cut[1]]))
    return np.ascontiguousarray(out), cut


def _pinch_out(fault, layer: str, tr, d: np.ndarray, ahead: float, area: StudyArea,
               surface_z) -> Tuple[np.ndarray, np.ndarray]:
    """The synthetic tip of ``layer`` at a fault end: (the end trace ``tr``'s
    cutoff midpoint (3,), the pinch-out point (3,)). The pinch-out lies
    halfway to what is ahead along ``d`` -- ``ahead`` is the distance to a
    partner's outline, or a trace spacing where nothing is in reach -- kept
    in the study area, z changed as the continuous surface changes. The one
    place that decides it: the layer's patch closes there, and the fault
    surface's end trace is moved onto these points (:attr:`EndMoveKind.pinch`
    in :func:`fault_surface`)."""
    sides = tr.layers[layer]
    cm = 0.5 * (np.asarray(sides["foot"], dtype=np.float64)[-1]
                + np.asarray(sides["hanging"], dtype=np.float64)[0])
    xy = _pull_inside(area, cm[:2], cm[:2] + 0.5 * ahead * d,
                      f"fault {fault.name!r} layer {layer!r}: the end cutoff")
    return cm, np.array([xy[0], xy[1], float(_shift_z(cm[None, :], xy[None, :], surface_z)[0])])


def _pinched(plane: np.ndarray, move: "EndMove") -> Tuple[np.ndarray, np.ndarray]:
    """The end plane trace moved onto the layers' pinch-out points, and where
    each of its points comes from: each plane point moved by the displacement
    (x, y and z) of the layers' cutoffs, taken along z between the layers
    (the nearest layer's beyond them), and the pinch-out points themselves
    put in where their cutoffs' z falls on the trace, so that every layer's
    patch ends ON the fault surface's end (coming from its cutoff). A plane
    point within the merge tolerance of a cutoff's z gives way to the
    pinch-out point (one vertex, not two). A trace whose z is not strictly
    monotone has no place for them: it is moved only."""
    c, t = move.cutoffs, move.tips
    up = np.argsort(c[:, 2], kind="stable")
    off = t[up] - c[up]
    moved = plane.copy()
    for k in range(3):
        moved[:, k] += np.interp(plane[:, 2], c[up, 2], off[:, k])
    z = plane[:, 2]
    dz = np.diff(z)
    if len(plane) < 2 or not (np.all(dz < 0.0) or np.all(dz > 0.0)):
        return moved, plane
    rising = bool(z[-1] > z[0])
    order = up if rising else up[::-1]   # the cutoffs in the trace's order
    c, t = c[order], t[order]
    # The plane points before each cutoff along the trace.
    pos = np.searchsorted(z, c[:, 2]) if rising else len(z) - np.searchsorted(z[::-1], c[:, 2])
    tol = _merge_tol(np.vstack([plane, c]))
    keep = np.abs(z[:, None] - c[None, :, 2]).min(axis=1) > tol
    at = np.searchsorted(np.flatnonzero(keep), pos)
    return (np.ascontiguousarray(np.insert(moved[keep], at, t, axis=0)),
            np.ascontiguousarray(np.insert(plane[keep], at, c, axis=0)))


def _extend(poly: np.ndarray, d: np.ndarray, area: StudyArea,
            partners: Dict[str, List[np.ndarray]], max_dist: float,
            surface_z, cut: Optional[Tuple[int, int]] = None) -> Optional[Tuple[np.ndarray, str, float]]:
    """``poly`` carried along ``d`` onto the nearest target: the study-area
    boundary (every point must hit it, its cutoffs ``cut`` -- every point
    without -- within ``max_dist``) or a group partner's outline (every
    point within ``max_dist``). Returns (new polyline, target name, median
    distance) or None.

    On the boundary the reach is the fault's own: where a side runs oblique
    to the fault, the sheets' far ends hit it farther away than the cutoffs
    do, by up to the polyline's length times the obliquity, and they only
    follow the band along the side. Judged at every point, an end short of
    the reach was closed by a pinch-out and the fault's last few hundred
    metres left the layer unfaulted, its data there missed by the whole
    throw (stress ground 78: reverse, 116 m at 23 degrees; L2's last section
    37-323 m from the boundary at its cutoffs, 450 m at its hanging wall's
    far end, 439 m allowed). Both cutoffs, not the nearer one: where the
    band runs nearly along the side, the nearer cutoff can lie on it and
    the farther one a kilometre on (held-out random ground 167: 2 and 1,223
    m; carried, near-fault error 0.80 -> 1.45 m), though a side about 20
    degrees off the strike then keeps stress ground 384's L5 a pinch-out
    (110 and 786 m, 654 m allowed; Open). The nearer one where the two
    cutoffs land on one side or round one corner was tried too: it carries
    384 and leaves 167 (its cutoffs land on the two walls of a notch), but
    stress ground 216's F2 was then carried 465 m to a farther cutoff 1,203
    m on (764 m allowed), onto F1's patch, and the ground no longer built
    ("faults too close"). Not so for a partner: there the
    distance places the fault's end (``EndMove.shift``) or a reverse
    fault's pinch-out halfway, and sheets that reach a partner only far
    beyond the spacing tell of no fault that meets it (sweep seed 31: F2's
    L1, its cutoffs within reach of F1 but the sheets a kilometre away,
    pinched out 512 m ahead of its last section: near-fault error 0.81 ->
    1.01 m)."""
    best = None
    pts, t = _to_boundary(area, poly, d, surface_z)
    reach = float(t[list(cut)].max()) if cut is not None else float(t.max())
    if np.all(np.isfinite(t)) and reach <= max_dist:
        best = (pts, "boundary", float(np.median(t)))
    for name, rings in partners.items():
        if not rings:
            continue
        t = _ray_hits(poly, d, rings)
        if not np.all(np.isfinite(t)) or float(t.max()) > max_dist:
            continue
        med = float(np.median(t))
        if best is None or med < best[2]:
            xy = poly[:, :2] + t[:, None] * d[None, :]
            best = (np.column_stack([xy, _shift_z(poly, xy, surface_z)]), name, med)
    return best


def _resample(p: np.ndarray, m: int) -> np.ndarray:
    """``p`` (k, 3) as ``m`` points at equal steps of its 3D arc length (its
    ends kept exactly); ``p`` itself when it has ``m`` points already."""
    if len(p) == m:
        return p
    d = np.diff(p, axis=0)
    L = np.zeros(len(p))
    np.cumsum(np.sqrt(np.einsum("ij,ij->i", d, d)), out=L[1:])
    if len(p) == 1 or L[-1] == 0.0:
        return np.repeat(p[:1], m, axis=0)
    t = np.linspace(0.0, L[-1], m)
    out = np.empty((m, 3))
    for c in range(3):
        out[:, c] = np.interp(t, L, p[:, c])
    out[0], out[-1] = p[0], p[-1]
    return out


def _pieces(k: int, c: Optional[Tuple[int, int]]) -> List[Tuple[int, int]]:
    """(start, stop) of the footwall, strip and hanging-wall parts of a
    polyline of ``k`` points with cutoffs at ``c`` (sharing the cutoff
    points), or the whole polyline without ``c``."""
    if c is None:
        return [(0, k)]
    fw, hw = c
    return [(0, fw + 1), (fw, hw + 1), (hw, k)]


def _vertical_throw(p: np.ndarray, c: Optional[Tuple[int, int]]) -> float:
    """The vertical throw of a polyline with cutoffs at ``c`` (0 without)."""
    return 0.0 if c is None else abs(float(p[c[0], 2] - p[c[1], 2]))


def _pair_points(a: np.ndarray, b: np.ndarray, ca: Optional[Tuple[int, int]],
                 cb: Optional[Tuple[int, int]], step: float):
    """Where :func:`_between` puts the polylines between ``a`` and ``b``:
    (A, B, c, s, P), the two paired part by part (m points each), the
    cutoffs ``c`` of the polylines between, their positions ``s`` (n, 1, 1)
    from A to B and their points ``P`` (n, m, 3) on the straight lines
    between (z too); None where the pair is at most ``step`` apart."""
    pa, pb = _pieces(len(a), ca), _pieces(len(b), cb)
    if len(pa) != len(pb):
        pa, pb = [(0, len(a))], [(0, len(b))]
    ra, rb, cut = [], [], []
    for (a0, a1), (b0, b1) in zip(pa, pb):
        m = max(a1 - a0, b1 - b0)
        x, y = _resample(a[a0:a1], m), _resample(b[b0:b1], m)
        if ra:  # the part starts at the previous one's last point
            x, y = x[1:], y[1:]
        ra.append(x)
        rb.append(y)
        cut.append(sum(len(r) for r in ra) - 1)
    A, B = np.vstack(ra), np.vstack(rb)
    c = (cut[0], cut[1]) if len(cut) == 3 else None
    gap = float(np.hypot(*(B[:, :2] - A[:, :2]).T).max())
    n = int(math.ceil(gap / step)) - 1
    if n <= 0:
        return None
    s = (np.arange(1, n + 1) / (n + 1))[:, None, None]
    return A, B, c, s, (1.0 - s) * A[None] + s * B[None]


def _departure(s: np.ndarray, z: np.ndarray, m: int) -> np.ndarray:
    """The continuous surface's departure (n, m) from its own straight line
    at the points P of :func:`_pair_points` (positions ``s``), from ``z``:
    the surface at A, B and P stacked (m, m, n * m); 0 where undefined."""
    za, zb, zp = z[:m], z[m:2 * m], z[2 * m:].reshape(len(s), m)
    dz = zp - ((1.0 - s[:, :, 0]) * za[None] + s[:, :, 0] * zb[None])
    return np.where(np.isfinite(dz), dz, 0.0)


def _between(area: StudyArea, a: np.ndarray, b: np.ndarray, ca: Optional[Tuple[int, int]],
             cb: Optional[Tuple[int, int]], surface_z, step: float, floor: float = 0.0
             ) -> Tuple[List[np.ndarray], List[Optional[Tuple[int, int]]]]:
    """Polylines between two consecutive polylines ``a`` and ``b`` of a
    layer's patch, at most ``step`` apart in XY, whose z follows the
    continuous layer surface ``surface_z`` (module doc: "between the
    traces"), with their cutoff positions. Their points pair up part by
    part (footwall, strip, hanging wall; resampled along each part where
    the two have different counts) and lie on the straight XY line between
    their pair; a pair on one side of the study area gives points placed
    on that side (StudyArea.place), an identical pair that point itself
    (an extension keeps the points already on the boundary; so do all the
    polylines between). None (empty lists) where the surface departs from
    its straight line by no more than the larger vertical throw of the two
    polylines: the TIN's own error near the fault (or than ``floor``, the
    throw of a partner the pair comes near: :func:`_fans_near_partners`)."""
    throw = max(_vertical_throw(a, ca), _vertical_throw(b, cb), floor)
    pts = _pair_points(a, b, ca, cb, step)
    if pts is None:
        return [], []
    A, B, c, s, P = pts
    n = len(P)
    # z: the straight line between the pair plus the continuous surface's
    # departure from its own straight line there (where it is defined).
    dz = _departure(s, surface_z(np.vstack([A[:, :2], B[:, :2], P[:, :, :2].reshape(-1, 2)])), len(A))
    # Near a fault the continuous TIN interpolates across it: its error there
    # is up to the fault's throw, and so is the noise of its departure (sweep
    # seed 345, traces 0.4-1.1 km apart over a flat layer, 40 m of throw: the
    # TIN departs 10-25 m from the straight line; followed, the near-fault
    # error rose from 1.27 m to 3.5 m). Only a departure larger than the
    # larger throw of the pair is the layer's shape; below it the loft stands.
    if not np.abs(dz).max() > throw:
        return [], []
    P[:, :, 2] += dz
    # Pairs on one side of the study area: the points placed on that side.
    side_a, sa = area.locate(A[:, :2])
    side_b, sb = area.locate(B[:, :2])
    n_sides = int(area.n_sides)
    ring = np.asarray(area.ring, dtype=np.float64)
    side_len = np.hypot(*(np.roll(ring, -1, axis=0) - ring).T)
    # A corner is the start of its side (locate) and the end of the one before.
    b_on_a = np.where((side_b >= 0) & (side_b == (side_a + 1) % n_sides) & (sb == 0.0),
                      side_a, side_b)
    sb_on_a = np.where(b_on_a != side_b, side_len[np.maximum(side_a, 0)], sb)
    a_on_b = np.where((side_a >= 0) & (side_a == (side_b + 1) % n_sides) & (sa == 0.0),
                      side_b, side_a)
    sa_on_b = np.where(a_on_b != side_a, side_len[np.maximum(side_b, 0)], sa)
    same = (side_a >= 0) & (side_a == b_on_a)
    same_b = ~same & (side_b >= 0) & (side_b == a_on_b)
    for mask, side, s0, s1 in ((same, side_a, sa, sb_on_a), (same_b, side_b, sa_on_b, sb)):
        k = np.flatnonzero(mask)
        if len(k):
            sk = (1.0 - s[:, :, 0]) * s0[k][None] + s[:, :, 0] * s1[k][None]    # (n, len(k))
            P[:, k, :2] = area.place(np.broadcast_to(side[k][None], sk.shape).ravel(),
                                     sk.ravel()).reshape(n, len(k), 2)
    eq = np.all(A == B, axis=1)
    P[:, eq] = A[eq][None]
    return [np.ascontiguousarray(p) for p in P], [c] * n


def _first_look(seq: List[np.ndarray], cuts: List[Optional[Tuple[int, int]]], pairs: List[int],
                surface_z, step: float, floors: Optional[Dict[int, float]] = None) -> set:
    """Of the consecutive pairs ``(seq[i], seq[i + 1])``, i in ``pairs``,
    those that :func:`_between` fills: where the surface departs from the
    straight line by more than the pair's larger throw (and than the pair's
    ``floors`` entry, :func:`_between`'s ``floor``), at the same points
    (:func:`_pair_points`) by the same test, for all pairs in one surface
    call (the fault models of 10 x 1M x 200 spent about a second on one
    call per pair). :func:`_between` then places only the pairs it fills.

    Why the same points: a first look at the points midway between the
    pair's ends and cutoffs only, meant to spare the full test on the pairs
    it would reject, also rejected pairs that the full test fills -- the
    largest departure lay between the cutoffs and the ends (sweep seed 401,
    F1's end trace on the study-area boundary and the next trace 674 m
    away: 8.08 m inside the hanging wall against a throw of 7.38 m, at most
    5.5 m at the keys; the truth departs 5.5-5.9 m from the straight loft
    there). Near-fault mean |dz| 1.048 -> 0.612 m."""
    look: set = set()
    got, xy = [], []
    for i in pairs:
        pts = _pair_points(seq[i], seq[i + 1], cuts[i], cuts[i + 1], step)
        if pts is not None:
            A, B, _, sp, P = pts
            got.append((i, sp, len(A)))
            xy += [A[:, :2], B[:, :2], P[:, :, :2].reshape(-1, 2)]
    if not got:
        return look
    z = surface_z(np.vstack(xy))
    at = 0
    for i, sp, m in got:
        k = (2 + len(sp)) * m
        dz = _departure(sp, z[at:at + k], m)
        at += k
        throw = max(_vertical_throw(seq[i], cuts[i]), _vertical_throw(seq[i + 1], cuts[i + 1]),
                    (floors or {}).get(i, 0.0))
        if np.abs(dz).max() > throw:
            look.add(i)
    return look


class PartnerZone(NamedTuple):
    """A group partner's patch in a layer, as a fan near it sees it:
    ``rings``, its XY outline (:func:`patch_outline`); ``throw``, its largest
    vertical throw in the layer (:func:`layer_throw`); ``reach``, how far
    beyond the outline the continuous layer TIN interpolates across it
    (``build_model`` gives the layer's data spacing: the TIN's triangles
    that straddle the partner reach about that far past its cutoffs)."""
    rings: List[np.ndarray]
    throw: float
    reach: float


def layer_throw(fault, layer: str) -> float:
    """The largest vertical throw of ``fault``'s traces in ``layer`` (0
    where no trace has the layer)."""
    out = 0.0
    for tr in fault.traces:
        r = _trace_polyline(tr, layer)
        if r is not None:
            out = max(out, _vertical_throw(r[0], r[2]))
    return out


def _fans_near_partners(seq: List[np.ndarray], pairs: List[int], zones: Sequence[PartnerZone],
                        method: str) -> Dict[int, float]:
    """Of the consecutive pairs ``(seq[i], seq[i + 1])``, i in ``pairs``, the
    tips' fans (one of the two a single point) whose straight loft comes
    within ``reach`` of a partner's outline (:func:`_touches_any`), each
    with the largest ``throw`` of those partners: :func:`_between`'s floor.

    Why: a fan is filled where the continuous TIN departs from its straight
    line by more than the fault's throw (module doc). Within a data spacing
    of a partner the TIN interpolates across the partner too, so its
    departure there is up to the partner's throw. In X pairs (sweep seeds
    189, 311, 272) the later fault's tip lies past the crossing: its fan
    runs across the partner, the group clip removes the filled fan's
    triangles on the partner, and the piece left beyond it starts at a
    polyline that took the TIN's error beside the partner (189: 10-13 m
    above the layer, the partner's throw 37 m, the fan's own 10 m); the gap
    around that piece lost the layer data. Near-fault mean |dz| 189 1.951
    -> 1.752 m, 311 2.046 -> 1.810, 272 3.973 -> 3.491 (the straight fan's
    values). Only fans: filled lofts between two traces near a partner
    help (with the floor on them too, seeds 24, 207, 265 lost 8-10 %), and
    fans clear of the partner keep their fill (348: with every fan of a
    group member held to the partner's throw, +1.0 %)."""
    out: Dict[int, float] = {}
    for i in pairs:
        if not zones or (len(seq[i]) > 1 and len(seq[i + 1]) > 1):
            continue
        V, T = _assemble([seq[i], seq[i + 1]], method)
        near = [z.throw for z in zones if _touches_any(V, T, z.rings, z.reach)]
        if near:
            out[i] = max(near)
    return out


def _follow_surface(area: StudyArea, seq: List[np.ndarray], cuts: List[Optional[Tuple[int, int]]],
                    surface_z, step: Optional[float], straight_fans: Sequence[int] = (),
                    near_partners: Sequence["PartnerZone"] = (), method: str = "min_area"
                    ) -> Tuple[List[np.ndarray], List[Optional[Tuple[int, int]]]]:
    """``seq`` with polylines :func:`_between` every two consecutive ones
    (towards a single point too: a tip's fan is filled in like a loft
    between traces, the point taken as a polyline of that point repeated,
    with the other polyline's cutoffs, so the polylines between shrink onto
    it part by part). The fans of the ends in ``straight_fans`` (0 first,
    1 last) stay one straight loft: :func:`_straight_fans`. A fan near one
    of ``near_partners`` is filled only where the departure also exceeds
    that partner's throw: :func:`_fans_near_partners`."""
    if surface_z is None or step is None or len(seq) < 2:
        return seq, cuts
    if not step > 0.0:
        raise ValueError(f"layer_patch: along_step must be > 0, got {step}")
    # A fan between two single points is no surface; every other pair is.
    pairs = [i for i in range(len(seq) - 1) if len(seq[i]) > 1 or len(seq[i + 1]) > 1]
    skip = {0 if end == 0 else len(seq) - 2 for end in straight_fans}
    pairs = [i for i in pairs if i not in skip]
    wide, wide_c = list(seq), list(cuts)
    for i in pairs:
        for j, k in ((i, i + 1), (i + 1, i)):
            if len(seq[j]) == 1:
                wide[j] = np.repeat(seq[j], len(seq[k]), axis=0)
                wide_c[j] = cuts[k]
    floors = _fans_near_partners(seq, pairs, near_partners, method)
    look = _first_look(wide, wide_c, pairs, surface_z, step, floors)
    out, out_c = [seq[0]], [cuts[0]]
    for i in range(len(seq) - 1):
        if i in look:
            a, b, ca, cb = seq[i], seq[i + 1], cuts[i], cuts[i + 1]
            if len(a) == 1:
                a, ca = np.repeat(a, len(b), axis=0), cb
            elif len(b) == 1:
                b, cb = np.repeat(b, len(a), axis=0), ca
            mid, mid_c = _between(area, a, b, ca, cb, surface_z, step, floors.get(i, 0.0))
            out += mid
            out_c += mid_c
        out.append(seq[i + 1])
        out_c.append(cuts[i + 1])
    return out, out_c


# ---------------------------------------------------------------------------
# Assembly
# ---------------------------------------------------------------------------
def _assemble(seq: List[np.ndarray], method: str,
              cuts: Optional[List[Optional[Tuple[int, int]]]] = None) -> Tuple[np.ndarray, np.ndarray]:
    """Loft consecutive polylines of ``seq`` into one patch.

    ``cuts`` (per polyline, or None): the positions of its footwall and
    hanging-wall cutoffs. Between two polylines that both have them, the
    footwall parts, the fault strips and the hanging-wall parts are lofted
    separately, so the cutoff lines run from cutoff to cutoff: the folded
    band of a reverse fault (or the strip of a normal one) is then exactly
    the band between the cutoff lines the data give, whatever diagonals the
    loft would choose across a whole polyline.

    Consecutive polylines share vertices where they have the same point
    (an end trace that already lies on the study-area
    boundary is its own extension there): such a point is one vertex, and
    the loft triangles that would join it to itself (two corners at one
    vertex: zero area) are not made. The strip between the polylines is
    pinched at the shared point, and the remaining triangles cover it."""
    Vs: List[np.ndarray] = []
    index: List[np.ndarray] = []  # per polyline: vertex index of each point
    n = 0
    for i, p in enumerate(seq):
        idx = np.arange(n, n + len(p))
        if i > 0:
            # A point equal to one of the previous polyline's (an extension
            # keeps the points already on the boundary; corners inserted
            # by _around_corners shift the positions) is that vertex.
            eq = np.all(p[:, None, :] == seq[i - 1][None, :, :], axis=2)
            same = eq.any(axis=1)
            if same.any():
                idx = np.where(same, index[-1][np.argmax(eq, axis=1)], -1)
                new = ~same
                idx[new] = np.arange(n, n + int(new.sum()))
                Vs.append(p[new])
                n += int(new.sum())
                index.append(idx)
                continue
        Vs.append(p)
        n += len(p)
        index.append(idx)

    def pieces(i: int) -> List[Tuple[int, int]]:
        c = cuts[i] if cuts is not None else None
        k = len(seq[i])
        if c is None:
            return [(0, k)]
        fw, hw = c
        return [(0, fw + 1), (fw, hw + 1), (hw, k)]

    tris = []
    for i in range(len(seq) - 1):
        pa, pb = pieces(i), pieces(i + 1)
        if len(pa) != len(pb):
            pa, pb = [(0, len(seq[i]))], [(0, len(seq[i + 1]))]
        for (a0, a1), (b0, b1) in zip(pa, pb):
            a, b = seq[i][a0:a1], seq[i + 1][b0:b1]
            ia, ib = index[i][a0:a1], index[i + 1][b0:b1]
            if len(a) == 1 and len(b) == 1:
                continue  # a zero-width piece (zero throw on both traces)
            t = np.asarray(loft(a, b, method=method), dtype=np.int64)
            k = len(a)
            tris.append(np.where(t < k, ia[np.minimum(t, k - 1)], ib[np.maximum(t - k, 0)]))
    T = np.vstack(tris) if tris else np.zeros((0, 3), dtype=np.int64)
    T = T[(T[:, 0] != T[:, 1]) & (T[:, 1] != T[:, 2]) & (T[:, 2] != T[:, 0])]
    V = np.vstack(Vs) if Vs else np.zeros((0, 3))
    return np.ascontiguousarray(V), np.ascontiguousarray(T)


def _assemble_runs(runs: List[Tuple[List[np.ndarray], List[Optional[Tuple[int, int]]]]],
                   method: str) -> Tuple[np.ndarray, np.ndarray]:
    """:func:`_assemble` of each run (polylines, cuts), the runs side by side
    as separate pieces of one patch."""
    Vs, Ts, off = [], [], 0
    for seq, cuts in runs:
        V, T = _assemble(seq, method, cuts)
        Vs.append(V)
        Ts.append(T + off)
        off += len(V)
    if not Vs:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    return np.ascontiguousarray(np.vstack(Vs)), np.ascontiguousarray(np.vstack(Ts))


def _touches(V: np.ndarray, T: np.ndarray, rings: List[np.ndarray], tol: float) -> np.ndarray:
    """Rows of the triangles that :func:`clip_patch` removes first: those
    whose closed XY projection touches the region ``rings`` (exactly) or
    comes within ``tol`` of its outline."""
    if len(T) == 0 or not rings:
        return np.zeros(0, dtype=np.int64)
    rows = np.asarray(triangles_touching_region(V, T, rings), dtype=np.int64)
    if tol > 0.0:
        rows = np.union1d(rows, _triangles_near_region(V, T, rings, tol))
    return rows


def _touches_any(V: np.ndarray, T: np.ndarray, rings: List[np.ndarray], tol: float,
                 region: Optional[TouchingRegion] = None) -> bool:
    """Whether :func:`_touches` has any row, cheaper: False at once where the
    patch's XY box, grown by ``tol``, misses every ring's box; True at once
    where a triangle comes within ``tol`` of a ring edge; else the exact
    test (:func:`triangles_touching_region`; ``region``: the same built once
    from ``rings``, :class:`TouchingRegion` -- building the region was most
    of each call, and :func:`_closing` makes a thousand per crossing group
    and layer)."""
    if len(T) == 0 or not rings:
        return False
    used = np.asarray(V, dtype=np.float64)[np.asarray(T).ravel(), :2]
    lo, hi = used.min(axis=0) - tol, used.max(axis=0) + tol
    R = [np.asarray(r, dtype=np.float64).reshape(-1, 2) for r in rings]
    if not any(len(r) and (r.max(axis=0) >= lo).all() and (r.min(axis=0) <= hi).all() for r in R):
        return False
    if tol > 0.0 and len(_triangles_near_region(V, T, R, tol)):
        return True
    if region is not None:
        return len(region.touching(V, T)) > 0
    return len(triangles_touching_region(V, T, R)) > 0


def _cut_centre(poly: np.ndarray, cut: Optional[Tuple[int, int]]) -> np.ndarray:
    """The midpoint of a polyline's cutoffs (x, y, z); its middle point
    without cutoffs (a tip: the point itself)."""
    if cut is None:
        return poly[len(poly) // 2]
    return 0.5 * (poly[cut[0]] + poly[cut[1]])


#: How far past the band a band core reaches (:func:`_band_core`), as a
#: share of the band's width: enough to keep its ends strictly beyond the
#: band (exact orient2d tests decide on the points; a quarter of the width
#: is far above any rounding of the interpolated point), small enough that
#: the core is hardly wider than the band itself.
_CORE_MARGIN = 0.25

#: The band cores' margin where an earlier patch yields its sheets to a
#: later folded member's band (:func:`_yield_to`), as a share of the band's
#: width. Between the earlier band's edge and its core's end the earlier
#: footwall (or hanging-wall) sheet lies over the later band once, and the
#: later fold, kept clear of that outline (:func:`_clear_of`), cannot be
#: there: at an X crossing that margin was most of the later band lost (sweep
#: seed 8: F1's band about 60 m wide, its quarter-width margin 15 m of the
#: 25 m of F2's band left unrepeated in L2; 451 likewise). A tenth of the
#: width still puts the core's ends metres beyond the band (bands are
#: metres to hundreds of metres wide), far above the rounding that the exact
#: orient2d tests on those points have to see past (sweep seed 8, F2's
#: share of the band the data give in L2 92.4 -> 97.2 %, worst layer 95.0 %;
#: 451 F2 L3 92.7 -> 95.3 %).
_YIELD_MARGIN = 0.1

#: How far past a later fault's band an earlier patch's pinch-out fan is
#: first kept (:func:`_yield_to`), as a share of the band's width on each
#: side: twice the later band cores' margin (_CORE_MARGIN), so the fan is
#: clear of the later patch's sheets where they are cut to their cores.
_FAN_CLEARANCE = 2 * _CORE_MARGIN

#: How far (as a share of the way to the next polyline) a closure's cutoff
#: may be carried along its cutoff line, past the next polyline, where the
#: partner's outline crosses the band obliquely: the other cutoff line meets
#: it before the next polyline, this one only beyond (:func:`_closing`).
#: Once more the way, about one trace spacing; the band edge is taken
#: straight over that stretch (the quadrilaterals of consecutive traces'
#: cutoffs bend little from one to the next: seed 246, F2 L4 92.8 % of the
#: band repeated stopping at the next trace, 98.6 % past it).
_LINE_REACH = 2.0

#: How near a closure's band is carried to where it would touch the partner
#: (:func:`_closing`), as a share of the band's width (its cutoff segment
#: in XY): the bisection of the share of the way goes on until the stretch
#: it leaves undecided is no longer than this. It stopped at 0.98 of the
#: way before, after 3 halvings at 0.97: a fixed share of the way to the
#: next trace, so the stretch left unrepeated in front of the partner grew
#: with the trace spacing (sweep seed 750, F2 L5: a band 15 m wide, a way
#: of 720 m, the fold closed 22 m short of F1 -- 93.2 % of the band
#: repeated; 96.3 % with this). A quarter of the width is the band cores'
#: own margin past the band (_CORE_MARGIN): where the partner stops the
#: band's centre, the tip, halfway from the carried band to the partner,
#: ends at most an eighth of the width short of it (decimetres to metres
#: for bands metres to tens of metres wide); every candidate is still
#: tested clear of the partner with the clip's tolerance (clear()).
_CLOSE_TO = _CORE_MARGIN

#: At most this many halvings (each a loft and an exact touch test): from
#: a tenth of the way, 2**-12 of it, a quarter of the width of a 1 m band
#: 10 km away. Cost: the touch tests of building ten X-pair sweep seeds
#: (8 9 76 236 244 246 321 350 451 750) went from 8817 to 9374 (+6 %).
_CLOSE_STEPS = 12


#: How many polylines carry a band bent round a partner's outline per
#: interval between traces (:func:`_closing`, "bend"), at shares growing as
#: (k / steps)^2: six put the first at 1/36 of the way (about 4 m of the
#: 145 m of seed 1130, whose partner corner lies 7 m ahead), and the
#: halvings (_BEND_HALVINGS) add more only where a loft touches.
_BEND_STEPS = 6

#: How far a bent band's blocked side (its cutoff and the sheet past it)
#: stays from the partners' outlines (:func:`_closing`, "bend"), as a share
#: of the band's width: the stitch gap between the two faults' patches is
#: about this wide, and the band in it is not repeated. A twentieth (2 m of
#: a 44 m band) keeps the lofts between the polylines, which cut the
#: outline's offset as chords, clear of it with few polylines put in, and is
#: far above the rounding the exact touch tests see past. Measured (F2's
#: share of the band the data give, worst layer): a tenth, 1130 94.4 %, 803
#: 95.1 %; a twentieth, 95.1 % and 95.6 %; a fiftieth, 95.4 % and 96.1 %
#: but 1130's near-fault error +0.3 % and its build 7 % slower.
_BEND_CLEAR = 0.05

#: Samples of the way from a bent band's free cutoff across it, for its
#: clearance (:func:`_closing`, "bend"): the way is at most the band's
#: width and a tenth, so a 64th of it is within a third of the clearance
#: (the lofts are tested exactly afterwards).
_BEND_SAMPLES = 64

#: At most this many rounds of polylines put halfway between two of a bent
#: band whose loft touches a partner (:func:`_closing`, "bend"): the pair
#: next to a corner of the outline, 1/16 of its share apart after four.
_BEND_HALVINGS = 4


def _close_enough(stretch: float, pts: np.ndarray, cc: Tuple[int, int]) -> bool:
    """Whether ``stretch`` (m) is within ``_CLOSE_TO`` of the width of the
    band of ``pts`` (cutoffs ``cc``) in XY."""
    width = float(np.hypot(*(pts[cc[0], :2] - pts[cc[1], :2])))
    return stretch <= _CLOSE_TO * width


def _band_core(poly: np.ndarray, cut: Optional[Tuple[int, int]], tight: bool = True,
               margin: float = _CORE_MARGIN) -> Optional[Tuple[np.ndarray, Tuple[int, int]]]:
    """The part of a polyline that holds its fault strip and reaches just
    past the band on both sides: (points, cutoffs in them), or None
    (without cutoffs, a band of no width, or a polyline that does not reach
    past the band). Positions are taken along the polyline's direction
    (first to last point). ``tight``: the ends are put on the polyline a
    ``margin`` (default ``_CORE_MARGIN``) of the band's width before the band's near edge
    (footwall side) and after its far edge (hanging-wall side), z linear
    along the segment; otherwise they are the last footwall point before
    the band and the first hanging-wall point after it.

    Why past the band: cut to the strip alone, the outline edges from a
    neighbouring polyline's far ends to the band's ends would cross (the
    band's ends swap sides across a fold), as the polylines themselves reach
    past it (_reach_past_the_band)."""
    if cut is None or len(poly) < 2 or not (poly[0, :2] != poly[-1, :2]).any():
        return None
    fw, hw = cut
    d = poly[-1, :2] - poly[0, :2]
    pos = (poly[:, :2] - poly[fw, :2]) @ d
    lo_band, hi_band = float(pos[fw:hw + 1].min()), float(pos[fw:hw + 1].max())
    if not hi_band > lo_band:
        return None
    m = margin * (hi_band - lo_band) if tight else 0.0
    before = np.flatnonzero(pos[:fw + 1] < lo_band - m)
    after = hw + np.flatnonzero(pos[hw:] > hi_band + m)
    if not len(before) or not len(after):
        return None
    i, j = int(before[-1]), int(after[0])
    if not tight:
        return np.ascontiguousarray(poly[i:j + 1]), (fw - i, hw - i)

    def at(k0: int, k1: int, target: float) -> np.ndarray:
        # The point of segment k0 -> k1 at position target (between theirs).
        t = (target - pos[k0]) / (pos[k1] - pos[k0])
        return poly[k0] + t * (poly[k1] - poly[k0])

    # i + 1 (<= fw) and j - 1 (>= hw) lie within the margin: the ends are
    # on the segments i -> i + 1 and j - 1 -> j.
    pts = np.vstack([at(i, i + 1, lo_band - m)[None, :], poly[i + 1:j], at(j - 1, j, hi_band + m)[None, :]])
    return np.ascontiguousarray(pts), (fw - i, hw - i)


def _drop_boundary_slivers(V: np.ndarray, T: np.ndarray, area: StudyArea) -> Tuple[np.ndarray, int]:
    """``T`` without the slivers a loft leaves on the study-area boundary:
    triangles whose three vertices lie on one side of it (StudyArea.locate;
    a corner lies on both its sides) and that have an edge on the patch's
    outline, peeled until none is left; with the number dropped.

    Such a triangle has no area in XY -- its image is a piece of the side --
    but rounding gives its orientation a sign (the points are placed on the
    side, not exactly on its line). The minimum-area loft makes them where
    an end polyline carried onto a side meets a point of the polyline before
    it that was on the side already: three consecutive points of the carried
    one with that point between them (stress ground 78, a reverse fault of
    116 m at 23 degrees: a sliver of 5e-13 m2 at the hanging-wall sheet's
    end on the boundary counted twice in the covered-once test, and L2 lost
    its first two sections). A vertical wall along the boundary is nothing
    the model has; the outline then runs along the sliver's long edge, on the
    same side. Kept where the peeling would split the patch or pinch it (a
    strip that lies along the boundary joins two sheets)."""
    if len(T) == 0:
        return T, 0
    side, s = area.locate(np.ascontiguousarray(V[:, :2]))
    # The second side of a corner (located at the start of its side).
    other = np.where((side >= 0) & (s == 0.0), (side - 1) % int(area.n_sides), side)
    a, b = side[T], other[T]                                             # (m, 3)
    shared = np.zeros(len(T), dtype=bool)
    for c in (a[:, 0], b[:, 0]):
        shared |= ((c >= 0) & ((a[:, 1] == c) | (b[:, 1] == c)) & ((a[:, 2] == c) | (b[:, 2] == c)))
    if not shared.any():
        return T, 0
    keep = np.ones(len(T), dtype=bool)
    nv = np.int64(len(V))
    while True:
        live = np.flatnonzero(keep)
        # The triangles with an outline edge (an edge of boundary_edges, in
        # its own triangle's direction).
        B = boundary_edges(T[live], n_vertices=len(V))
        E = T[live][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 3, 2)
        outline = np.isin(E[:, :, 0] * nv + E[:, :, 1], B[:, 0] * nv + B[:, 1]).any(axis=1)
        peel = live[outline & shared[live]]
        if not len(peel):
            break
        keep[peel] = False
    if keep.all():
        return T, 0
    kept = T[keep]
    before = boundary_contours(T, n_vertices=len(V))
    after = boundary_contours(kept, n_vertices=len(V))
    if (len(kept) == 0 or len(after.pinch_vertices) > len(before.pinch_vertices)
            or len(after.loops) > len(before.loops)):
        return T, 0
    return np.ascontiguousarray(kept), int(len(T) - len(kept))


def _fold_area(parts, method: str) -> float:
    """XY area of the fold of the polylines ``parts`` ((polyline, cut)
    pairs) lofted: the triangles turned against the patch's orientation."""
    V, T = _assemble([p for p, _ in parts], method, [c for _, c in parts])
    if len(T) == 0:
        return 0.0
    xy = np.ascontiguousarray(V[:, :2])
    o = orient2d(xy[T[:, 0]], xy[T[:, 1]], xy[T[:, 2]])
    return 0.5 * float(np.abs(o[np.sign(o) == -np.sign(o.sum())]).sum())


def _simple_patch(V: np.ndarray, T: np.ndarray, area: StudyArea) -> bool:
    """What the stitcher needs of a patch (clip_patch's clean-up tests): no
    pinch vertex, an outline that does not cross itself, covered once
    counted with orientation."""
    if len(T) == 0 or len(boundary_contours(T, n_vertices=len(V)).pinch_vertices):
        return False
    return not len(_unfit_triangles(V, T, area))


def _unfit_triangles(V: np.ndarray, T: np.ndarray, area: Optional[StudyArea]) -> np.ndarray:
    """Rows of the triangles the stitcher objects to in a patch without
    pinch vertices: those at outline edges that cross (:func:`_outline_crossings`),
    else those where the patch does not cover its XY image once, counted
    with orientation (the stitcher's region is what the outline encloses:
    ``triangles_not_covered_once``); empty if the patch is fit. One test for
    the group clip's clean-up (:func:`clip_patch`), :func:`_simple_patch` and
    derive's patch check (``derive._patch_problem``)."""
    rows = _outline_crossings(V, T, area)
    if rows.size == 0:
        rows = np.asarray(triangles_not_covered_once(V, T, area=area), dtype=np.int64)
    return rows


def _closing(poly: np.ndarray, cut: Optional[Tuple[int, int]], nxt: np.ndarray,
             nxt_cut: Optional[Tuple[int, int]], area: StudyArea, surface_z, rings: List[np.ndarray],
             tol: float, first: bool, method: str, carry: Optional[str] = "follow",
             share: float = 1.0, further: Sequence[Tuple[np.ndarray, Optional[Tuple[int, int]]]] = ()
             ) -> Optional[List[Tuple[np.ndarray, Optional[Tuple[int, int]]]]]:
    """How to close the fold at ``poly`` (its cutoffs ``cut``) towards the
    next polyline ``nxt`` (cutoffs ``nxt_cut``) whose loft would touch
    ``rings``, clear of ``rings``: the polylines (with their cuts) to add
    after ``poly`` (before it with ``first``), or None. ``toward``: the
    next polyline's cutoff midpoint.

    The data say the band runs on towards ``toward``. So ``poly``'s band
    (its strip and the sheets' points just past it, else the whole
    polyline) is first
    carried on towards ``toward`` -- its footwall cutoff along the line to
    the next one's, its hanging-wall cutoff along the hanging-wall cutoffs'
    line, the strip and the sheets in proportion (the similarity that takes
    the one cutoff segment to the other: the band the data give, the
    quadrilateral of the two cutoff segments, widening or narrowing), the
    same share of the way on both lines or (where the partners' outline
    runs oblique to the band) each cutoff as far as its own line is clear,
    past ``nxt`` where the other line meets the outline before it
    (``_LINE_REACH``), else
    simply moved along the line to ``toward`` -- 0.9 of the way to
    ``toward`` or to the partners' outline, whichever is nearer, then
    bisected (nearer, towards the whole way, if that is clear, else back
    towards ``poly``) until the stretch left undecided is within a quarter
    of the band's width (``_CLOSE_TO``); of these ways the one whose fold covers most
    (:func:`_fold_area`) among those whose piece covers its image once
    (else the one whose fold covers most) -- keeping the band's full width there, and closed by a pinch-out
    tip halfway from it to that point; failing that, a pinch-out tip alone
    (a fan from ``poly``) halfway to ``toward``, then nearer and nearer
    (halved, 20 times). ``carry``: "follow" (all of these), "move" (the
    band only moved, not along the cutoff lines) or None (the fan only).
    ``share``: the part of the way to ``toward`` that this closure may take
    (a half where the next polyline's run is closed back towards this one).
    With "follow", the band may also be bent round the partners ("bend":
    carried along the cutoff line that runs on clear, narrowed on the other
    side to what stays clear of them) and followed on past ``nxt`` through
    ``further`` (the polylines after it, in order, up to the next run's
    first); where such a bend goes past ``nxt``, the ways that go past it
    are taken first. z follows the continuous layer surface's change
    (:func:`_shift_z`). Each candidate must lie in the study area, each new
    polyline strictly beyond the one before it on the side ``toward`` is
    (exact orient2d: otherwise the lofts fold back over each other, as a tip
    on the inner side did: :func:`_layer_tip`), and its lofts must stay
    clear of ``rings`` (:func:`_touches`)."""
    c = _cut_centre(poly, cut)
    toward = _cut_centre(nxt, nxt_cut)
    way = np.asarray(toward[:2], dtype=np.float64) - c[:2]
    dist = float(np.hypot(way[0], way[1]))
    if not dist > 0.0:
        return None
    u = way / dist
    hit = float(_ray_hits(c[None, :2], u, rings)[0])
    reach = min(share * dist, hit)
    region = TouchingRegion(rings)

    def beyond(chord: np.ndarray, pts: np.ndarray) -> bool:
        # Every point of pts strictly on the side of chord's line that u points to.
        a = np.ascontiguousarray(chord[[0], :2])
        b = np.ascontiguousarray(chord[[-1], :2])
        if not (a != b).any():
            return True
        side = np.sign(orient2d(a, b, a + u[None, :] * max(dist, 1.0)))[0]
        got = np.sign(orient2d(np.repeat(a, len(pts), 0), np.repeat(b, len(pts), 0),
                               np.ascontiguousarray(pts[:, :2])))
        return side != 0.0 and bool((got == side).all())

    def moved(pts: np.ndarray, by: float) -> np.ndarray:
        xy = pts[:, :2] + by * u[None, :]
        return np.column_stack([xy, _shift_z(pts, xy, surface_z)])

    def clear(parts) -> bool:
        seq = [p for p, _ in parts]
        if not area.contains(np.vstack(seq)[:, :2]).all():
            return False
        V, T = _assemble(seq, method, [c_ for _, c_ in parts])
        return len(T) > 0 and not _touches_any(V, T, rings, tol, region)

    def ordered(parts):
        return parts[::-1] if first else parts

    cores: List[Tuple[np.ndarray, Tuple[int, int]]] = []
    if cut is not None and len(poly) > 1:
        for tight in (True, False):
            core = _band_core(poly, cut, tight)
            if core is not None:
                cores.append(core)
        if not cores:
            cores.append((poly, cut))

    def along_cutoffs(pts: np.ndarray, cc: Tuple[int, int], t: float,
                      t_hw: Optional[float] = None) -> Optional[np.ndarray]:
        # pts (a band core, cutoffs cc) carried a fraction t of the way along
        # the cutoff lines (t_hw along the hanging-wall one, if given; None
        # if the next polyline has no cutoffs): the similarity (rotation and
        # scale in XY) that takes the cutoff segment to the one between
        # those points of the two lines, applied to every point. The
        # sheets' parts across and past the band scale with it: moved with
        # their own cutoff only, the footwall sheet of a band that widens
        # towards the next polyline no longer reached past the hanging-wall
        # cutoff, the piece did not cover its image once and the band was
        # merely moved, its width kept (sweep seed 76, F2 L5: a band 15 m
        # wide at the run's end, 35 m at the next trace, 90.6 % of it
        # repeated).
        if nxt_cut is None:
            return None
        fw, hw = cc
        z = pts[:, 0] + 1j * pts[:, 1]
        a0, b0 = z[hw], z[fw]
        a1 = a0 + (t if t_hw is None else t_hw) * (nxt[nxt_cut[1], 0] + 1j * nxt[nxt_cut[1], 1] - a0)
        b1 = b0 + t * ((nxt[nxt_cut[0], 0] + 1j * nxt[nxt_cut[0], 1]) - b0)
        if not b0 != a0:
            # A band of no width: each side along its own cutoff line.
            zz = np.where(np.arange(len(z)) > fw, z + (a1 - a0), z + (b1 - b0))
        else:
            zz = a1 + (z - a0) * ((b1 - a1) / (b0 - a0))
        xy = np.column_stack([zz.real, zz.imag])
        return np.column_stack([xy, _shift_z(pts, xy, surface_z)])

    def line_reach(pts: np.ndarray, cc: Tuple[int, int]) -> Tuple[float, float]:
        # How far (a share of the way) the core's footwall and hanging-wall
        # cutoffs can go along their cutoff lines before the partners'
        # outlines: at most ``share``; where the other line meets them
        # before the next polyline (they cross the band obliquely between
        # the two), past the next polyline up to _LINE_REACH of the way if
        # the line meets them there (on this side of the partner the band
        # goes on past the next polyline, whose loft is left out). Not past
        # it otherwise (seed 24: a T partner beyond the next polyline, the
        # fold carried past it where the data give no band, near-fault
        # error +4.6 %), nor where the closure takes half the way (closures
        # from both sides meet).
        ends = np.ascontiguousarray(pts[list(cc), :2])
        ways = np.ascontiguousarray(nxt[list(nxt_cut), :2]) - ends
        h = [float(x) for x in _ray_hits(ends, ways, rings)]
        past = share >= 1.0 and min(h) < 1.0
        return tuple(x if past and x <= _LINE_REACH else min(share, x) for x in h)

    def bend_chain(pts: np.ndarray, cc: Tuple[int, int]):
        # The cutoff points (complex XY) of the free and the blocked side
        # from the core through nxt and on through ``further`` (as long as
        # each has cutoffs), and how far along them (intervals) the free
        # side runs clear; None where both sides are stopped alike. Without
        # ``further`` (or with a share below 1): nxt only, by line_reach.
        polys = [(pts, cc), (nxt, nxt_cut)]
        if share >= 1.0:
            for p_, c_ in further:
                if c_ is None:
                    break
                polys.append((p_, c_))
        cut_pts = np.array([[p_[c_[0], 0] + 1j * p_[c_[0], 1], p_[c_[1], 0] + 1j * p_[c_[1], 1]]
                            for p_, c_ in polys])
        if len(polys) == 2:
            h = line_reach(pts, cc)
        else:
            h = []
            for side in (0, 1):
                got = float(len(polys) - 1)
                for i in range(len(polys) - 1):
                    a_, d_ = cut_pts[i, side], cut_pts[i + 1, side] - cut_pts[i, side]
                    x = float(_ray_hits(np.array([[a_.real, a_.imag]]), np.array([d_.real, d_.imag]), rings)[0])
                    if x <= 1.0:
                        got = i + x
                        break
                h.append(got)
            # Not into the next run: at most halfway across the last interval.
            h = [min(x, len(polys) - 1.5) for x in h]
        if not h[0] != h[1]:
            return None
        free = 0 if h[0] > h[1] else 1
        hf = h[free]
        if not (np.isfinite(hf) and hf > 0.0):
            return None
        F, B = cut_pts[:, free], cut_pts[:, 1 - free]
        if not (np.abs(np.diff(F)) > 0.0).all():
            return None
        return F, B, hf

    # The partners' outline edges, for the clearance of a bent band.
    edges = _ring_edges(rings)
    edge_lo, edge_hi = edges.min(axis=1), edges.max(axis=1)

    def edges_near(xy: np.ndarray, by: float) -> np.ndarray:
        # The edges whose box meets the box of xy grown by ``by``.
        lo_, hi_ = xy.min(axis=0) - by, xy.max(axis=0) + by
        return edges[(edge_hi >= lo_).all(axis=1) & (edge_lo <= hi_).all(axis=1)]

    def bent(frac: float, pts: np.ndarray, cc: Tuple[int, int]):
        # The band carried along the cutoff line that runs on clear of the
        # partners (the free one) and narrowed on the other (blocked) side
        # to what is clear there: the fold bends round the partner's
        # outline instead of closing straight. The polyline at share s of
        # the free line's clear reach (bend_chain) is the core taken by the
        # similarity that puts its free cutoff on that line and its blocked
        # cutoff on the way towards where the blocked line is at that share,
        # as far as the way and the sheet past it (cut to _YIELD_MARGIN of
        # the band's width) stay _BEND_CLEAR of the band's width from the
        # partners' outlines: the blocked side's end follows that outline
        # offset by the clearance, round its corners too. _BEND_STEPS
        # polylines per interval at shares growing as (k / steps)^2 (the
        # first stay near ``poly``), and where the loft between two touches
        # a partner (a convex corner of its outline between them: seed
        # 1130, F2 L2, F1's corner 7 m in front of F2's trace 4, which
        # every straight closure touched) one more halfway between, up to
        # _BEND_HALVINGS times. Then a pinch-out tip halfway from the last
        # one's centre to the partners along the free line.
        chain = bend_chain(pts, cc)
        if chain is None:
            return None
        F, B, hf = chain
        z = pts[:, 0] + 1j * pts[:, 1]
        f0, b0 = F[0], B[0]
        w0 = abs(b0 - f0)
        if not w0 > 0.0:
            return None
        gap = _BEND_CLEAR * w0
        # How far each point lies past the blocked cutoff, along the band.
        past = ((z - b0) * np.conj((b0 - f0) / w0)).real
        samples = np.arange(1, _BEND_SAMPLES + 1) / _BEND_SAMPLES

        def at(s: float) -> Optional[np.ndarray]:
            i = min(int(s), len(F) - 2)
            t = s - i
            f = F[i] + t * (F[i + 1] - F[i])
            full = (B[i] + t * (B[i + 1] - B[i])) - f
            if not abs(full) > 0.0:
                return None
            e = full / abs(full)
            # The way from f along e, the band and its sheet past it: as
            # far as it is clear of the outlines by gap (samples of it,
            # numpy; the lofts are tested exactly afterwards).
            reach_ = (1.0 + _YIELD_MARGIN) * abs(full)
            end_ = f + reach_ * e
            near = edges_near(np.array([[f.real, f.imag], [end_.real, end_.imag]]), gap)
            hit = float(_ray_hits_edges(np.array([[f.real, f.imag]]), np.array([e.real, e.imag]), near)[0])
            ts = samples * min(reach_, hit)
            q = np.column_stack([(f + ts * e).real, (f + ts * e).imag])
            d = _point_segment_dist(q[:, None, :], near[None, :, 0], near[None, :, 1]).min(axis=1) \
                if len(near) else np.full(len(ts), np.inf)
            bad = np.flatnonzero(d < gap)
            clear_to = ts[bad[0] - 1] if len(bad) and bad[0] > 0 else (0.0 if len(bad) else ts[-1])
            if len(bad) == 0 and hit <= reach_:
                clear_to = max(0.0, hit - gap)
            w = min(abs(full), clear_to / (1.0 + _YIELD_MARGIN))
            if not w > 0.0:
                return None
            b = f + w * e
            zz = f + (z - f0) * ((b - f) / (b0 - f0))
            beyond_b = np.maximum(past, 0.0) * (w / w0)
            m = float(beyond_b.max())
            if m > _YIELD_MARGIN * w:
                zz = zz - (1.0 - _YIELD_MARGIN * w / m) * beyond_b * e
            xy = np.column_stack([zz.real, zz.imag])
            # A polyline that itself crosses an outline (at the far end,
            # where the band is narrow) cannot be mended by more polylines.
            if (_ray_hits_edges(xy[:-1], xy[1:] - xy[:-1], edges_near(xy, 0.0)) <= 1.0).any():
                return None
            return np.column_stack([xy, _shift_z(pts, xy, surface_z)])

        # Past nxt on its own lines (line_reach), or per interval of the chain.
        steps = _BEND_STEPS * (1 if len(F) == 2 else max(1, int(np.ceil(frac * hf))))
        shares = [frac * hf * (k / steps) ** 2 for k in range(1, steps + 1)]
        made = {s_: at(s_) for s_ in shares}
        if any(v is None for v in made.values()):
            return None
        # The whole first (one loft and touch test); where it touches, pair
        # by pair, halving the pairs that touch (and only their halves).
        if not clear(ordered([(poly, cut)] + [(made[s_], cc) for s_ in shares])):
            def pair_clear(s_a: float, s_b: float) -> bool:
                pa = (poly, cut) if s_a == 0.0 else (made[s_a], cc)
                return clear([pa, (made[s_b], cc)])

            bad = [(s_a, s_b) for s_a, s_b in zip([0.0] + shares[:-1], shares) if not pair_clear(s_a, s_b)]
            for _ in range(_BEND_HALVINGS):
                if not bad:
                    break
                still = []
                for s_a, s_b in bad:
                    s_m = 0.5 * (s_a + s_b)
                    made[s_m] = at(s_m)
                    if made[s_m] is None:
                        return None
                    shares.append(s_m)
                    halves = [(x, y) for x, y in ((s_a, s_m), (s_m, s_b)) if not pair_clear(x, y)]
                    if len(halves) == 2:
                        # Not one corner between them: the band itself runs
                        # into the partner there.
                        return None
                    still += halves
                bad = still
            if bad:
                return None
            shares.sort()
        out = [made[s_] for s_ in shares]
        last = out[-1]
        mid = _cut_centre(last, cc)
        last_i = min(int(frac * hf), len(F) - 2)
        uf = (F[last_i + 1] - F[last_i]) / abs(F[last_i + 1] - F[last_i])
        left = float(_ray_hits(mid[None, :2], np.array([uf.real, uf.imag]), rings)[0])
        if not np.isfinite(left):
            left = (1.0 - frac) * hf * abs(F[last_i + 1] - F[last_i]) + 0.25 * w0
        if not left > 0.0:
            return None
        xy = mid[None, :2] + 0.5 * left * np.array([[uf.real, uf.imag]])
        tip = np.column_stack([xy, _shift_z(mid[None, :], xy, surface_z)])
        chain = [poly] + out + [tip]
        if not all(beyond(p_, q_) for p_, q_ in zip(chain[:-1], chain[1:])):
            return None
        parts = [(o, cc) for o in out] + [(tip, None)]
        return ordered(parts) if clear(ordered([(poly, cut)] + parts)) else None

    def carried_by(frac: float, pts: np.ndarray, cc: Tuple[int, int], how: str):
        if how == "bend":
            return bent(frac, pts, cc)
        if how == "lines":
            # Each cutoff as far along its own line as that line is clear:
            # the carried band's end runs along the partner's outline where
            # that lies oblique to the band (sweep seed 246: F1's narrow
            # band across F2's wide one, and F2's fold, carried the same
            # share of the way on both lines, stopped where its first
            # cutoff line met F1, a wedge of F2's band short of F1).
            h_fw, h_hw = line_reach(pts, cc)
            carried = along_cutoffs(pts, cc, frac * h_fw, frac * h_hw)
            mid = _cut_centre(carried, cc)
            left = float(_ray_hits(mid[None, :2], u, rings)[0])
            if not np.isfinite(left):
                left = share * dist - float((mid[:2] - c[:2]) @ u)
            if not left > 0.0:
                return None
            tip = moved(mid[None, :], 0.5 * left)
        else:
            if how == "follow":
                carried = along_cutoffs(pts, cc, frac * reach / dist)
                if carried is None:
                    return None
            else:
                carried = moved(pts, frac * reach)
            tip = moved(_cut_centre(carried, cc)[None, :], 0.5 * (1.0 - frac) * reach)
        if not (beyond(poly, carried) and beyond(carried, tip)):
            return None
        parts = ordered([(poly, cut), (carried, cc), (tip, None)])
        return ordered([(carried, cc), (tip, None)]) if clear(parts) else None

    if carry and np.isfinite(reach) and reach > 0.0:
        best, best_fold = None, -1.0
        found: List[Tuple[float, Any]] = []
        past_nxt: List[Tuple[float, Any]] = []  # ways that carry the band on past nxt
        bent_on = False  # whether a bend follows the band on past nxt
        ways = []
        for pts, cc in cores:
            if carry == "follow" and nxt_cut is not None:
                ways.append((pts, cc, "follow"))
                # Along each line as far as it is clear, where that differs
                # from the common share of the way.
                if any(abs(h - reach / dist) > 1e-9 for h in line_reach(pts, cc)):
                    ways.append((pts, cc, "lines"))
                if pts is cores[0][0]:
                    # Bent from the first core only: it cuts the sheet on
                    # the partner's side to a tenth of the width anyway, and
                    # each bend costs a loft of many polylines per halving.
                    ways.append((pts, cc, "bend"))
            ways.append((pts, cc, "move"))
        for pts, cc, how in ways:
            # 0.9 of the way, then by bisection: nearer (towards the whole
            # way, where the centre meets the partner) if that is clear,
            # else between it and poly; at least 3 (7) halvings, then on
            # until the stretch left undecided is within _CLOSE_TO of the
            # band's width (_close_enough).
            got = carried_by(0.9, pts, cc, how)
            ok, bad, steps = (0.9, 1.0, 3) if got is not None else (0.0, 0.9, 7)
            for k in range(_CLOSE_STEPS):
                if k >= steps and _close_enough((bad - ok) * reach, pts, cc):
                    break
                mid = 0.5 * (ok + bad)
                better = carried_by(mid, pts, cc, how)
                if better is None:
                    bad = mid
                else:
                    ok, got = mid, better
            if got is None:
                continue
            # Of the ways that are clear, the one whose fold (the band
            # repeated) covers the most.
            f = _fold_area(ordered([(poly, cut)] + ordered(got)), method)
            if how == "bend":
                chain = bend_chain(pts, cc)
                if chain is not None and len(chain[0]) > 2 and ok * chain[2] > 1.0:
                    past_nxt.append((f, got))
                    bent_on = True
            elif how == "lines" and ok * max(line_reach(pts, cc)) > 1.0:
                past_nxt.append((f, got))
            found.append((f, got))
            if f > best_fold:
                best, best_fold = got, f
        # ... among those whose piece covers its image once (exact,
        # triangles_not_covered_once at the centroids; its outline runs
        # back along the folded poly, so the outline is not tested here),
        # if any does. A piece
        # that does not makes its run not simple, and _clear_of then drops
        # every variant whose closures follow the cutoff lines: sweep seeds
        # 236 and 244, where the band widens towards the crossing and the
        # band merely moved left a strip along one side unrepeated.
        # Where a bend follows the band on past nxt (through ``further``),
        # the ways that carry the band past nxt (that bend, or "lines"
        # along the band's lines) come first, by their fold: they repeat
        # band the data give that no way stopping at nxt reaches, and up
        # to where the partner narrows the band a bend keeps its full width
        # as "follow" does. The others' fold counts area off the band too
        # (the band merely moved keeps its width where the band the data
        # give narrows or turns): seed 803, F2 L2, the moved band's fold
        # 3470 m2 against the bend's 3442 m2, but the bend repeats 95.8 %
        # of the band the data give, the moved band 92.1 %.
        first_ways = sorted(past_nxt, key=lambda t: -t[0]) if bent_on else []
        for f, got in first_ways + sorted(found, key=lambda t: -t[0]):
            piece = ordered([(poly, cut)] + ordered(got))
            V, T = _assemble([p for p, _ in piece], method, [c_ for _, c_ in piece])
            if len(T) and not len(triangles_not_covered_once(V, T, outline=False)):
                return got
        if best is not None:
            return best
    by = 0.5 * share * dist
    for _ in range(20):
        tip = moved(c[None, :], by)
        by *= 0.5
        if not beyond(poly, tip):
            continue
        if clear(ordered([(poly, cut), (tip, None)])):
            return [(tip, None)]
    return None


def band_quads(fault, layer: str) -> List[np.ndarray]:
    """The band the data give for ``fault`` in ``layer``: per pair of
    consecutive traces with the layer, the quadrilateral (4, 2) of their
    cutoff segments (footwall cutoff, hanging-wall cutoff, then the next
    trace's hanging-wall and footwall cutoffs). Quadrilaterals without area
    (zero throw at both traces) are left out."""
    cuts = []
    for tr in fault.traces:
        sides = tr.layers.get(layer)
        if sides is None:
            continue
        cuts.append((np.asarray(sides["foot"], dtype=np.float64).reshape(-1, 3)[-1, :2],
                     np.asarray(sides["hanging"], dtype=np.float64).reshape(-1, 3)[0, :2]))
    out = []
    for (a0, a1), (b0, b1) in zip(cuts[:-1], cuts[1:]):
        q = np.ascontiguousarray(np.array([a0, a1, b1, b0]))
        if _area(q) != 0.0:
            out.append(q)
    return out


def _widened_band(quad: np.ndarray, by: float) -> np.ndarray:
    """A band quadrilateral (:func:`band_quads`: footwall cutoff,
    hanging-wall cutoff, then the next trace's hanging-wall and footwall
    cutoffs) widened along its cutoff segments by ``by`` of their length on
    each side; any other ring unchanged."""
    q = np.asarray(quad, dtype=np.float64).reshape(-1, 2)
    if len(q) != 4:
        return q
    return np.ascontiguousarray(np.array([q[0] + by * (q[0] - q[1]), q[1] + by * (q[1] - q[0]),
                                          q[2] + by * (q[2] - q[3]), q[3] + by * (q[3] - q[2])]))


def _fan(t: np.ndarray, poly: np.ndarray, end: int, method: str) -> Tuple[np.ndarray, np.ndarray]:
    """The straight loft between the point ``t`` (3,) and the end polyline
    ``poly`` next to it at ``end`` (0 first, 1 last): a tip's fan."""
    return _assemble([t[None, :], poly] if end == 0 else [poly, t[None, :]], method)


def _touches_one_of(V: np.ndarray, T: np.ndarray, regions: List[np.ndarray]) -> bool:
    """Whether (V, T) touches one of ``regions``, each tested on its own
    exactly (:func:`_touches_any` without tolerance)."""
    return any(_touches_any(V, T, [r], 0.0) for r in regions)


def _straight_fans(seq: List[np.ndarray], regions: List[np.ndarray], method: str) -> List[int]:
    """The ends (0 first, 1 last) of ``seq`` that are a single point (a tip)
    whose straight fan touches one of ``regions`` (exactly, as
    :func:`_yield_to` tests it).

    Why: :func:`_yield_to` moves such a tip back towards its end trace
    until its fan is clear of the later fault's band. It moves the tip along
    the fan from the end trace; a fan filled in by :func:`_follow_surface`
    first has polylines between the trace and the tip, laid out for the
    tip where it was, which would then lie across the band the tip yields
    to (sweep seed 350, F1's pinch-out tip inside F2's band: with the fan
    filled, F2 repeated L4 on 82 % of its band; with it straight and
    moved, 97.6 %)."""
    out = []
    if len(seq) < 2:
        return out
    for end in (0, 1):
        tip, poly = (seq[0], seq[1]) if end == 0 else (seq[-1], seq[-2])
        if len(tip) != 1 or len(poly) < 2:
            continue
        if _touches_one_of(*_fan(tip[0], poly, end, method), regions):
            out.append(end)
    return out


def _yield_to(seq: List[np.ndarray], cuts: List[Optional[Tuple[int, int]]], regions: List[np.ndarray],
              area: StudyArea, method: str
              ) -> Tuple[List[np.ndarray], List[Optional[Tuple[int, int]]], List[int]]:
    """``seq`` with the polylines of every loft that touches one of
    ``regions`` (exactly, :func:`_touches` without tolerance, per region)
    cut to their band cores (:func:`_band_core`, margin
    ``_YIELD_MARGIN``), a pinch-out tip whose fan
    still touches one moved back towards its end trace; (seq, cuts, the
    indices changed).

    Why: the patch that comes first in its group is whole and the later
    ones are kept clear of it (:func:`_clear_of`). Where a later fault
    repeats the layer (its band, as its traces' cutoffs give it) inside the
    earlier patch's outline -- the sheets of the earlier fault's sections
    reach over the later fault's band, T or X -- the later fold could not
    be there at all (seed 8, an X pair: a quarter of F2's band in L2 and L3
    lay under F1's sheets). Cut to their cores, the earlier fault keeps its
    own band and what lies just past it, and the layer TIN's gap takes the
    sheets' far parts."""
    n = len(seq)
    cut_down = set()
    for i in range(n - 1):
        V, T = _assemble(seq[i:i + 2], method, cuts[i:i + 2])
        if _touches_one_of(V, T, regions):
            cut_down.update((i, i + 1))
    seq, cuts = list(seq), list(cuts)
    done = []
    for i in sorted(cut_down):
        core = _band_core(seq[i], cuts[i], margin=_YIELD_MARGIN)
        if core is None:
            continue
        seq[i], cuts[i] = core
        done.append(int(i))
    # A pinch-out tip whose fan still reaches over the later band (seed 350:
    # the earlier fault's tip, far beyond its end trace, lay across the later
    # fault's band) is moved back towards the end trace until its fan is
    # clear of it: 0.9, 0.8, ... 0.1 of the way; strictly beyond the end
    # trace's chord (exact orient2d, as _layer_tip) and in the study area.
    # Clear of the band widened by half its width on each side first (where
    # some such point is): the later patch's sheets reach past its band (its
    # band cores a quarter of the width, _CORE_MARGIN), and a fan just clear
    # of the band itself lay over them, so the later patch left out its
    # lofts there and closed its fold short of the earlier patch's band
    # (seed 350, F2 in L4 and L5: a sliver of F1's fan across F2's sheets,
    # 85 % of F2's band repeated).
    widened = [_widened_band(r, _FAN_CLEARANCE) for r in regions]
    for end in (0, 1):
        if n < 2 or len(seq[0 if end == 0 else -1]) != 1:
            continue
        tip, poly = (seq[0][0], seq[1]) if end == 0 else (seq[-1][0], seq[-2])
        pcut = cuts[1] if end == 0 else cuts[-2]
        if not _touches_one_of(*_fan(tip, poly, end, method), regions):
            continue
        c = _cut_centre(poly, pcut)
        a = np.ascontiguousarray(poly[[0], :2])
        b = np.ascontiguousarray(poly[[-1], :2])
        side = np.sign(orient2d(a, b, np.ascontiguousarray(tip[None, :2])))[0]
        moved = None
        for clear_of in (widened, regions):
            for s_ in (0.9, 0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2, 0.1):
                t = c + s_ * (tip - c)
                if side == 0.0 or np.sign(orient2d(a, b, np.ascontiguousarray(t[None, :2])))[0] != side:
                    continue
                if not area.contains(t[None, :2])[0]:
                    continue
                V, T = _fan(t, poly, end, method)
                if len(T) and not _touches_one_of(V, T, clear_of):
                    moved = t
                    break
            if moved is not None:
                break
        if moved is not None:
            if end == 0:
                seq[0] = moved[None, :]
            else:
                seq[-1] = moved[None, :]
            done.append(0 if end == 0 else n - 1)
    return seq, cuts, sorted(set(done))


def _clear_of(seq: List[np.ndarray], cuts: List[Optional[Tuple[int, int]]],
              clear_of: Dict[str, List[np.ndarray]], area: StudyArea, surface_z, method: str):
    """The polylines of a patch (``seq`` with their ``cuts``) as runs that
    stay clear of the partners' outlines ``clear_of``: (runs, note), each run
    a (polylines, cuts) pair to loft on its own, note None if nothing had to
    change.

    Why: :func:`group_patch` clips a later member of a group by the regions
    of the earlier ones, removing whole triangles. A folded (reverse-fault)
    patch clipped so ends its footwall, strip and hanging-wall sheets at
    different places; the clean-up that makes its outline simple again then
    removes triangles round after round, far from the partner, and the
    repetition goes (sweep class "repetition": 31 of 500 grounds, F2 of a T
    or X pair, 0-87 % of the band the data give left, where the patch alone
    covered all of it). A fold cannot be cut along a line inside the study
    area at all: its three sheets would end on one line, and the layer
    surface would not be a disk there (docs/design.md §5). It can only be
    closed by a pinch-out, as at a fault's tip.

    So the lofts between consecutive polylines (traces, extensions, tips)
    that would touch a partner's region -- decided as :func:`clip_patch`
    decides it, exactly, with the same tolerance -- are left out; every
    remaining run of polylines is kept (a single one too: a trace between
    the partner and the boundary), and each run end where a loft was left
    out is closed towards the next polyline (:func:`_closing`: the band
    carried on most of the way, then a pinch-out; or a pinch-out fan),
    clear of the partners. A run end that cannot be closed so loses its end
    polyline, until one can."""
    rings = [np.asarray(r, dtype=np.float64).reshape(-1, 2) for rs in clear_of.values() for r in rs]
    if not rings or len(seq) < 2:
        return [(seq, cuts)], None
    tol = _clip_tol(np.vstack(seq), rings)
    n = len(seq)

    region = TouchingRegion(rings)

    def touched_lofts(seq_, cuts_) -> np.ndarray:
        out = np.zeros(n - 1, dtype=bool)
        for i in range(n - 1):
            V, T = _assemble(seq_[i:i + 2], method, cuts_[i:i + 2])
            out[i] = _touches_any(V, T, rings, tol, region)
        return out

    touched = touched_lofts(seq, cuts)
    if not touched.any():
        return [(seq, cuts)], None

    def simple(run, rc) -> bool:
        return _simple_patch(*_assemble(run, method, rc), area)

    made: Dict[Any, Any] = {}

    def closing(poly, cut, nxt, nxt_cut, area_, surface_z_, rings_, tol_, first, method_, carry, share,
                further):
        # _closing, once per distinct closure: the variants and the runs made
        # again ask for the same ones (a variant's polylines at a run end are
        # often the same as another's).
        key = (poly.tobytes(), cut, nxt.tobytes(), nxt_cut, first, carry, share,
               tuple((p_.tobytes(), c_) for p_, c_ in further))
        if key not in made:
            made[key] = _closing(poly, cut, nxt, nxt_cut, area_, surface_z_, rings_, tol_, first, method_,
                                 carry, share, further)
        return made[key]

    def runs_of(seq_, cuts_, touched_, carry, halved=frozenset(), straight=frozenset()):
        """Every maximal run of polylines joined by lofts that stay clear,
        closed at a left-out loft (a run end that cannot be closed loses its
        end polyline); (runs, closed polylines, all runs simple). At the
        left-out lofts in ``halved`` each closure takes at most half the
        way. Where the two runs on either side of a left-out loft are
        closed towards each other and their closures meet (the loft touched
        the partner only with its sheets' far parts: seed 350), the runs
        are made again with those closures halved. A closure may bend on
        past its next polyline (_closing, ``further``) through the
        polylines up to the next run of two or more; where it then meets
        the closure of the next run facing it, both are made again without
        (``straight``: their (polyline, side) keys)."""
        runs, closed, ok = [], [], True
        facing: Dict[int, List] = {}  # left-out loft -> the closures at it (polylines with cuts)
        ends: List[Tuple[Any, Any]] = []  # per run: its (key, closure) at the start and at the end
        starts = [0] + [i + 1 for i in np.flatnonzero(touched_)]
        stops = [int(i) for i in np.flatnonzero(touched_)] + [n - 1]
        clear_lofts = np.flatnonzero(~np.asarray(touched_, dtype=bool))
        for a, b in zip(starts, stops):
            # The polylines a closure may bend past its next one through: up
            # to the end of the run of two or more before, the start of the
            # one after (a run of one polyline between may be dropped).
            prev_b = int(clear_lofts[clear_lofts < a - 1].max()) + 1 if (clear_lofts < a - 1).any() else 0
            next_a = int(clear_lofts[clear_lofts > b].min()) if (clear_lofts > b).any() else n - 1
            # A run may be one polyline closed on a side (a trace beyond the
            # partner, between it and the boundary: seed 321).
            while b >= a:
                pre: List[Tuple[np.ndarray, Optional[Tuple[int, int]]]] = []
                if a > 0:
                    got = closing(seq_[a], cuts_[a], seq_[a - 1], cuts_[a - 1], area,
                                  surface_z, rings, tol, True, method, carry,
                                   0.5 if a - 1 in halved else 1.0,
                                   [] if ("pre", a) in straight else
                                   list(zip(seq_[prev_b:a - 1], cuts_[prev_b:a - 1]))[::-1])
                    if got is None:
                        a += 1
                        continue
                    pre = got
                post: List[Tuple[np.ndarray, Optional[Tuple[int, int]]]] = []
                if b < n - 1:
                    got = closing(seq_[b], cuts_[b], seq_[b + 1], cuts_[b + 1], area,
                                  surface_z, rings, tol, False, method, carry,
                                   0.5 if b in halved else 1.0,
                                   [] if ("post", b) in straight else
                                   list(zip(seq_[b + 2:next_a + 1], cuts_[b + 2:next_a + 1])))
                    if got is None:
                        b -= 1
                        continue
                    post = got
                if a == b and not pre and not post:
                    break
                run = [p for p, _ in pre] + list(seq_[a:b + 1]) + [p for p, _ in post]
                rc = [c for _, c in pre] + list(cuts_[a:b + 1]) + [c for _, c in post]
                runs.append((run, rc))
                closed += ([a] if pre else []) + ([b] if post else [])
                ok = ok and simple(run, rc)
                if pre:
                    facing.setdefault(a - 1, []).append(pre + [(seq_[a], cuts_[a])])
                if post:
                    facing.setdefault(b, []).append([(seq_[b], cuts_[b])] + post)
                ends.append(((("pre", a), pre + [(seq_[a], cuts_[a])]) if pre else None,
                             (("post", b), [(seq_[b], cuts_[b])] + post) if post else None))
                break

        def meets(pa, pb) -> bool:
            Va, Ta = _assemble([p for p, _ in pa], method, [c for _, c in pa])
            Vb, Tb = _assemble([p for p, _ in pb], method, [c for _, c in pb])
            return bool(len(Ta) and len(Tb) and _touches_any(Va, Ta, patch_outline(Vb, Tb), tol))

        meet = set()
        for i, pieces in facing.items():
            if len(pieces) == 2 and i not in halved and meets(*pieces):
                meet.add(i)
        if meet:
            return runs_of(seq_, cuts_, touched_, carry, frozenset(halved | meet), straight)
        bent_meet = set()
        for (_, post_), (pre_, _) in zip(ends[:-1], ends[1:]):
            if (post_ is not None and pre_ is not None and pre_[0][1] - 1 != post_[0][1]
                    and not {post_[0], pre_[0]} <= straight and meets(post_[1], pre_[1])):
                bent_meet.update((post_[0], pre_[0]))
        if bent_meet:
            return runs_of(seq_, cuts_, touched_, carry, halved, frozenset(straight | bent_meet))
        return runs, closed, ok

    # Variants: (1) the polylines at a left-out loft cut to their band
    # cores (_band_core, tight or to the next polyline points: the sheets'
    # far parts are what usually reaches the partner; the loft between the
    # cores may then stay clear, and the layer TIN's gap takes the sheets'
    # far parts) and the run ends closed by the band carried on (along the
    # cutoff lines or moved, or moved only: carried along diverging cutoff
    # lines the outline may cross itself); (2) the polylines whole, the band
    # carried on (the same two ways); (3) the polylines whole, closed by
    # pinch-out fans (the outline of a tip's fan). Of those whose runs are
    # all simple, the one whose fold covers most (_fold_area) is taken (the
    # moved-only ones are tried only if no other is simple); if none is,
    # the fans (group_patch's clean-up then has the last word).
    variants = []
    ends_of_left_out = sorted({int(j) for j in np.flatnonzero(touched)} | {int(j) + 1 for j in np.flatnonzero(touched)})
    for tight in (True, False):
        trimmed_seq, trimmed_cuts, trimmed = list(seq), list(cuts), []
        for i in ends_of_left_out:
            core = _band_core(seq[i], cuts[i], tight)
            if core is not None:
                trimmed_seq[i], trimmed_cuts[i] = core
                trimmed.append(i)
        if trimmed:
            t_touched = touched_lofts(trimmed_seq, trimmed_cuts)
            word = "trimmed" if tight else "trimmed to points"
            variants.append((word, trimmed_seq, trimmed_cuts, t_touched, "follow", trimmed))
            variants.append((word + ", moved", trimmed_seq, trimmed_cuts, t_touched, "move", trimmed))
    variants.append(("carried", seq, cuts, touched, "follow", []))
    variants.append(("carried, moved", seq, cuts, touched, "move", []))
    best = None
    # The "follow" variants first (their closings try the moved band too);
    # the "move" ones only if none of those is simple (they cost as much).
    for carries in (("follow",), ("move",)):
        for how, seq_, cuts_, touched_, carry, trimmed in variants:
            if carry not in carries:
                continue
            runs, closed, ok = runs_of(seq_, cuts_, touched_, carry)
            # Each run simple is not enough: the runs side by side must not
            # cross either (a run of the end polyline carried onto the
            # boundary beyond the partner, closed back towards it, crossed
            # the other run's closure: random_ground(24) as v2, F2 in L1;
            # group_patch's clean-up then removed 0 to 148 of its 253
            # triangles, how many depending on the cutoffs' last bits).
            if not ok or (len(runs) > 1 and not _simple_patch(*_assemble_runs(runs, method), area)):
                continue
            fold = sum(_fold_area(list(zip(r, rc)), method) for r, rc in runs)
            if best is None or fold > best[0]:
                best = (fold, how, runs, closed, touched_, trimmed)
        if best is not None:
            break
    if best is None:
        runs, closed, _ = runs_of(seq, cuts, touched, None)
        best = (0.0, "fans", runs, closed, touched, [])
    _, how, runs, closed, touched_, trimmed = best
    note = {"partners": sorted(clear_of), "how": how,
            "lofts_left_out": [int(i) for i in np.flatnonzero(touched_)],
            "trimmed": [int(i) for i in trimmed],
            "closed_at": [int(i) for i in closed], "runs": len(runs), "polylines": n}
    return runs, note


def layer_patch(fault, layer: str, ends: FaultEnds, ring, surface_z=None,
                loft_method: str = "min_area",
                partners: Optional[Dict[str, List[np.ndarray]]] = None,
                max_extension: Optional[float] = None,
                along_step: Optional[float] = None,
                clear_of: Optional[Dict[str, List[np.ndarray]]] = None,
                yield_to: Optional[List[np.ndarray]] = None,
                near_partners: Sequence[PartnerZone] = ()) -> Optional[LayerPatch]:
    """The fine model of ``fault`` in ``layer`` (None if no trace has it).

    ``ring``: the study area (a (k, 2) ring or a :class:`faultmesh.StudyArea`).
    ``surface_z(xy) -> z`` is the continuous layer surface (tips and
    extensions follow its trend); ``partners``: group partners' XY outlines
    in this layer (extension targets besides the study-area boundary).
    ``along_step`` (m, with ``surface_z``): the patch follows the surface
    between consecutive polylines, by polylines at most this far apart
    (module doc); None: a plain loft.
    ``clear_of``: XY outlines (per partner) that the patch must stay clear
    of -- the group members before it in :func:`group_order`, whose region
    :func:`group_patch` would otherwise clip it by (see :func:`_clear_of`:
    the lofts between consecutive polylines that would touch them are left
    out and the fold is closed by a pinch-out short of them). ``yield_to``:
    XY regions (rings) where a later member of the group repeats the layer
    (:func:`band_quads`): the polylines of a loft that touches one are cut
    to their band cores (:func:`_yield_to`). Both act on the polylines
    after ``along_step`` has put its own in. ``near_partners``: the group
    partners' patches in this layer (:class:`PartnerZone`); a tip's fan
    near one is filled only where the layer departs from it by more than
    the partner's throw (:func:`_fans_near_partners`).

    An end trace that lies on the study-area boundary (every point of its
    polyline, by :meth:`StudyArea.on_boundary`) closes the patch there: the
    fault runs out of the study area (end kind ``boundary``)."""
    area = as_study_area(ring)
    with_layer = [tr for tr in fault.traces if layer in tr.layers]
    if not with_layer:
        return None
    polys = [_trace_polyline(tr, layer, area) for tr in with_layer]
    seq = [p for p, _, _ in polys]
    throws = [t for _, t, _ in polys]
    cuts: List[Optional[Tuple[int, int]]] = [c for _, _, c in polys]
    kinds, abuts, meta = [], [], {}
    pinch: Dict[int, Tuple[np.ndarray, np.ndarray]] = {}
    for end in (0, 1):
        poly = seq[0] if end == 0 else seq[-1]
        tip = ends.tips[end]
        d = ends.directions[end]
        add: Optional[np.ndarray] = None
        if tip is not None:
            add = _layer_tip(fault, with_layer, layer, end, tip, d, area, surface_z, poly)[None, :]
            kinds.append("tip")
        elif (throws[0] if end == 0 else throws[-1]) == 0.0:
            kinds.append("zero_throw")
        elif area.on_boundary(poly[:, :2]).all():
            kinds.append("boundary")
        else:
            if max_extension is None:
                max_extension = max(1.5 * ends.spacing, 0.25 * math.sqrt(abs(_area(area.ring))))
            ext = _extend(poly, d, area, partners or {}, max_extension, surface_z,
                          cuts[0] if end == 0 else cuts[-1])
            if (ext is not None and ext[1] != "boundary" and fault.kind == "reverse"
                    and len(ext[0]) > 1):
                # A reverse fault's fold (footwall, strip, hanging wall)
                # carried onto a partner would fold back along the partner's
                # outline; clipped there by whole triangles its sheets end at
                # different places, reaching past each other (sweep class
                # "new triangles: edge used by 4 triangles", seeds 133, 177,
                # 207, 218, 420, 460, ...). It is closed by a pinch-out
                # halfway to the partner instead: the fan ends the fold with
                # a simple outline, clear of the partner, and the gap joins
                # the two. The partner is not reached, so it is not in
                # ``abuts`` (group_patch then orders the fold by its folding).
                _, target, dist = ext
                pinch[end] = _pinch_out(fault, layer, with_layer[0] if end == 0 else with_layer[-1],
                                        d, dist, area, surface_z)
                add = pinch[end][1][None, :]
                kinds.append("synthetic_tip")
                meta[f"end{end}_tip_short_of"] = target
                meta[f"end{end}_tip_distance"] = 0.5 * dist
                meta[f"end{end}_tip"] = pinch[end][1].tolist()
            elif ext is not None:
                add, target, dist = ext
                c_add = cuts[0] if end == 0 else cuts[-1]
                if target == "boundary":
                    add, c_add = _around_corners(area, add, c_add)
                kinds.append("extended")
                meta[f"end{end}_extended_to"] = target
                meta[f"end{end}_extension"] = dist
                if target != "boundary":
                    abuts.append(target)
            else:
                # Nothing within reach: close by a synthetic pinch-out.
                pinch[end] = _pinch_out(fault, layer, with_layer[0] if end == 0 else with_layer[-1],
                                        d, ends.spacing, area, surface_z)
                add = pinch[end][1][None, :]
                kinds.append("synthetic_tip")
                meta[f"end{end}_tip"] = pinch[end][1].tolist()
        if add is not None:
            # An extension is the end polyline carried point by point: its
            # cutoffs sit where the end polyline's do. A tip is one point.
            if kinds[-1] == "extended":
                c = c_add
            else:
                c = (cuts[0] if end == 0 else cuts[-1]) if len(add) == len(poly) else None
            if end == 0:
                seq.insert(0, add)
                cuts.insert(0, c)
            else:
                seq.append(add)
                cuts.append(c)
    seq, cuts = _follow_surface(area, seq, cuts, surface_z, along_step,
                                _straight_fans(seq, yield_to, loft_method) if yield_to else (),
                                near_partners, loft_method)
    if yield_to:
        seq, cuts, cut_down = _yield_to(seq, cuts, yield_to, area, loft_method)
        if cut_down:
            meta["yielded_to_partner_bands"] = cut_down
    if clear_of:
        runs, note = _clear_of(seq, cuts, clear_of, area, surface_z, loft_method)
        if note is not None:
            meta["clear_of"] = note
        V, T = _assemble_runs(runs, loft_method)
    else:
        V, T = _assemble(seq, loft_method, cuts)
    # The loft between two traces is a chord: where the study area is not
    # convex it can run out of the area and back in (across a notch; sweep
    # seeds 418, 454). The patch is cut to the area exactly there, its new
    # outline on the boundary (the stitcher needs a patch inside the area).
    V, T, _, n_cut, n_out = area.clip_surface(V, T, f"fault {fault.name!r} layer {layer!r}")
    if n_cut or n_out:
        meta["clipped_to_study_area"] = {"cut": int(n_cut), "dropped": int(n_out)}
    T, n_slivers = _drop_boundary_slivers(V, T, area)
    if n_slivers:
        V, T = _compact(V, T)
        meta["boundary_slivers_dropped"] = n_slivers
    return LayerPatch(fault.name, layer, V, T, kinds, abuts, meta, pinch)


def fault_surface(fault, ends: FaultEnds, ring, loft_method: str = "min_area",
                  end_moves: Optional[Sequence[Optional[EndMove]]] = None):
    """(vertices, triangles) of the fault surface lofted from its plane
    traces, or None with fewer than two polylines.

    A tip end is closed by the end plane trace moved to the tip (by the
    offset from the cutoff midpoint of the layer whose cutoff line passes
    closest to the tip). ``end_moves`` (per end, None or an :class:`EndMove`:
    ``EndMove.ray(d)``, each point carried along d onto the study-area
    boundary, ``EndMove.shift(v)``, the trace moved by v, or
    ``EndMove.pinch(cutoffs, tips)``, the trace moved onto the layers'
    pinch-out points, which become its vertices: :func:`_pinched`) extends
    an end like the layers' patches. An end plane trace that already lies
    on the boundary stays as it is."""
    area = as_study_area(ring)
    seq = [np.asarray(tr.plane, dtype=np.float64).reshape(-1, 3) for tr in fault.traces]
    seq = [p for p in seq if len(p) >= 1]
    if not seq:
        return None
    for end in (0, 1):
        tr = fault.traces[0] if end == 0 else fault.traces[-1]
        plane = seq[0] if end == 0 else seq[-1]
        tip = ends.tips[end]
        moved = None
        origin = plane  # where each point of the moved trace comes from
        if tip is not None:
            ref = _reference_cutoff(tr, tip, ends.directions[end])
            if ref is None:
                ref = plane[len(plane) // 2]
            moved = plane.copy()
            moved[:, :2] += (tip - ref[:2])[None, :]
        elif area.on_boundary(plane[:, :2]).all():
            moved = None
        elif end_moves is not None and end_moves[end] is not None:
            move = end_moves[end]
            if not isinstance(move, EndMove):
                raise TypeError(f"fault_surface: end_moves[{end}] must be an EndMove or None, "
                                f"got {type(move).__name__}")
            if move.kind is EndMoveKind.ray:
                moved, t = _to_boundary(area, plane, move.vector, None)
                miss = ~np.isfinite(t)
                moved[miss] = plane[miss]
            elif move.kind is EndMoveKind.pinch:
                moved, origin = _pinched(plane, move)
            else:
                moved = plane.copy()
                moved[:, :2] += move.vector[None, :]
        if moved is not None:
            # Keep it inside the study area (halve the move where it leaves).
            inside = area.contains(moved[:, :2])
            for _ in range(60):
                if inside.all():
                    break
                moved[~inside, :2] = 0.5 * (moved[~inside, :2] + origin[~inside, :2])
                inside = area.contains(moved[:, :2])
            else:
                raise GeometryError(f"fault_surface: fault {fault.name!r}: the end plane trace "
                                    "cannot be moved inside the study area")
            if end == 0:
                seq.insert(0, moved)
            else:
                seq.append(moved)
    if len(seq) < 2:
        return None
    return _assemble(seq, loft_method)


def _area(ring) -> float:
    r = np.asarray(ring.ring if isinstance(ring, StudyArea) else ring, dtype=np.float64)
    x, y = r[:, 0] - r[0, 0], r[:, 1] - r[0, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def patch_outline(V: np.ndarray, T: np.ndarray) -> List[np.ndarray]:
    """The XY outline rings (k, 2) of a patch (its boundary loops; none for
    a patch without triangles, e.g. one wholly outside the study area)."""
    if len(T) == 0:
        return []
    c = boundary_contours(T, n_vertices=len(V))
    return [np.ascontiguousarray(V[np.asarray(l), :2]) for l in c.loops]


def _compact(V: np.ndarray, T: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    used = np.zeros(len(V), dtype=bool)
    used[T.ravel()] = True
    remap = np.cumsum(used) - 1
    return V[used], remap[T]


def _clip_tol(V: np.ndarray, rings: List[np.ndarray]) -> float:
    # Points that are ON a partner's outline by construction (the end trace of
    # an abutting fault carried onto it by _extend, p + t d in floating point)
    # miss it by a few ulps of their coordinates, on either side: 2e-10 m for
    # 4F2 on 2F1 in paper_like(0). 1e-9 of the extent (as _merge_tol) or 64
    # ulps of the largest coordinate, whichever is larger, is orders of
    # magnitude above that rounding and far below any real feature.
    P = np.vstack([np.asarray(V, dtype=np.float64)[:, :2]]
                  + [np.asarray(r, dtype=np.float64).reshape(-1, 2) for r in rings])
    ext = float(np.ptp(P, axis=0).max())
    return max(1e-9 * max(1.0, ext), 64.0 * np.finfo(np.float64).eps * float(np.abs(P).max()))


def _point_segment_dist(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """XY distance of points p (..., 2) from segments a-b (..., 2), broadcast."""
    e = b - a
    ee = np.sum(e * e, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(ee > 0, np.sum((p - a) * e, axis=-1) / ee, 0.0)
    t = np.clip(t, 0.0, 1.0)
    d = p - (a + t[..., None] * e)
    return np.hypot(d[..., 0], d[..., 1])


def _triangles_near_region(V: np.ndarray, T: np.ndarray, rings: List[np.ndarray],
                          tol: float) -> np.ndarray:
    """Rows of the triangles whose XY projection comes within ``tol`` of an
    edge of ``rings`` (distance between the triangle's edges and the ring's
    edges; crossings are found exactly by triangles_touching_region)."""
    if len(T) == 0 or not rings:
        return np.zeros(0, dtype=np.int64)
    xy = np.asarray(V, dtype=np.float64)[:, :2]
    segs = []
    for r in rings:
        r = np.asarray(r, dtype=np.float64).reshape(-1, 2)
        segs.append(np.stack([r, np.roll(r, -1, axis=0)], axis=1))
    S = np.concatenate(segs)
    T = np.asarray(T, dtype=np.int64)
    # Only the ring edges whose box meets the patch's box grown by tol can
    # come within tol of it (a partner's outline of hundreds of edges, a
    # closing piece of a few triangles near one end of it: _closing tests
    # such pieces a thousand times per group and layer).
    used = xy[T.ravel()]
    lo_p, hi_p = used.min(axis=0) - tol, used.max(axis=0) + tol
    S = S[np.all(S.max(axis=1) >= lo_p, axis=1) & np.all(S.min(axis=1) <= hi_p, axis=1)]
    if not len(S):
        return np.zeros(0, dtype=np.int64)
    E = np.stack([xy[T], xy[np.roll(T, -1, axis=1)]], axis=2).reshape(-1, 2, 2)  # 3 per triangle
    # Cheap box filter first (patch edges x ring edges can be many).
    lo_e, hi_e = E.min(axis=1) - tol, E.max(axis=1) + tol
    lo_s, hi_s = S.min(axis=1), S.max(axis=1)
    near = np.zeros(len(E), dtype=bool)
    chunk = max(1, 200_000 // max(1, len(S)))
    for i in range(0, len(E), chunk):
        e = E[i:i + chunk]
        box = (np.all(lo_e[i:i + chunk, None, :] <= hi_s[None, :, :], axis=2)
               & np.all(hi_e[i:i + chunk, None, :] >= lo_s[None, :, :], axis=2))
        ie, js = np.nonzero(box)
        if len(ie) == 0:
            continue
        a, b, c, d = e[ie, 0], e[ie, 1], S[js, 0], S[js, 1]
        # Two segments that do not cross are as close as an endpoint of one
        # to the other.
        dist = np.minimum(np.minimum(_point_segment_dist(a, c, d), _point_segment_dist(b, c, d)),
                          np.minimum(_point_segment_dist(c, a, b), _point_segment_dist(d, a, b)))
        hit = ie[dist <= tol]
        near[i + np.unique(hit)] = True
    return np.unique(np.flatnonzero(near) // 3)


def _outline_crossings(V: np.ndarray, T: np.ndarray, area: Optional[StudyArea] = None) -> np.ndarray:
    """Rows of the triangles whose outline edges meet another outline edge of
    the patch in XY where the stitcher needs the outline simple: the
    stitcher's own test (``triangles_at_outline_crossings``, stitch step 1),
    pairs of edges that each run along a side of the study area exempt (a
    reverse fault that runs out of the area folds along it; an edge of length
    0 at a point of a side runs along it)."""
    return np.asarray(triangles_at_outline_crossings(V, T, area=area), dtype=np.int64)


def clip_patch(V: np.ndarray, T: np.ndarray, rings: List[np.ndarray],
               max_rounds: Optional[int] = None, tol: Optional[float] = None,
               area: Optional[StudyArea] = None) -> Tuple[np.ndarray, np.ndarray]:
    """Remove the triangles whose closed XY projection touches the region
    ``rings`` (exactly) or comes within ``tol`` of its outline, then the
    triangles at pinch vertices until every piece has simple boundary loops.
    Returns the compacted remainder (may be empty).

    Why the tolerance: an abutting fault's end trace is carried onto its
    partner's outline (:func:`_extend`), so its end vertices lie ON that
    outline -- up to rounding, on either side of it. The exact test alone
    removes the triangles at the vertices that rounded inside and keeps those
    that rounded outside; a kept one leaves a patch vertex 1e-10 m from the
    partner's outline, and the gap polygon then has two holes that (almost)
    touch, which only a sliver can join (paper_like(0), 2F1-4F2 in "coal 8":
    a gap triangle of 3e-11 degrees in XY). ``tol`` None: :func:`_clip_tol`;
    0: the exact test only. ``max_rounds`` None: as many clean-up rounds as
    it takes (each removes at least one triangle, so at most one per
    triangle; sweep seed 494 needed more than 50)."""
    if len(T) == 0 or not rings:
        return V, T
    if tol is None:
        tol = _clip_tol(V, rings)
    if not tol >= 0.0:
        raise ValueError(f"clip_patch: tol must be >= 0, got {tol}")
    keep = np.ones(len(T), dtype=bool)
    keep[_touches(V, T, rings, tol)] = False
    T = T[keep]
    # Clean-up: triangles at pinch vertices, then -- a folded (reverse-fault)
    # patch is clipped sheet by sheet at different places, and the outlines
    # of its sheets can cross in XY where they meet the partner -- the
    # triangles at crossing outline edges, until the outline is simple; then
    # the triangles where the patch does not cover its image once (a sheet
    # end reaching past the others: triangles_not_covered_once), until none is left.
    for _ in range(len(T) + 1 if max_rounds is None else max_rounds):
        if len(T) == 0:
            break
        c = boundary_contours(T, n_vertices=len(V))
        bad = np.asarray(c.pinch_vertices, dtype=np.int64)
        if bad.size:
            T = T[~np.isin(T, bad).any(axis=1)]
            continue
        # Crossing outline edges, else (where the clip left a sheet reaching
        # past the others: sweep seeds 24, 147, 246, 395, a gap edge used by
        # 4 triangles) the triangles not covering their image once.
        rows = _unfit_triangles(V, T, area)
        if rows.size == 0:
            break
        keep = np.ones(len(T), dtype=bool)
        keep[rows] = False
        T = T[keep]
    else:
        raise GeometryError("clip_patch: could not clean up the clipped patch")
    if len(T) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    return _compact(V, T)


def is_folded(p: LayerPatch) -> bool:
    """The patch has triangles both ways up in XY (exact orient2d): a fold,
    a reverse fault repeating the layer."""
    return folds(p.vertices, p.triangles)


def folds(V: np.ndarray, T: np.ndarray) -> bool:
    """:func:`is_folded` of the triangles ``T`` on the vertices ``V``."""
    if len(T) == 0:
        return False
    xy = np.ascontiguousarray(V[:, :2])
    o = orient2d(xy[T[:, 0]], xy[T[:, 1]], xy[T[:, 2]])
    return bool((o < 0.0).any() and (o > 0.0).any())


def group_order(patches: List[LayerPatch]) -> List[int]:
    """The order in which :func:`group_patch` puts a group's patches
    together (each clipped by the outlines of those before it): faults that
    abut no partner first, then the abutting ones; among each, folded
    patches before flat ones, else in the given order."""
    return sorted(range(len(patches)), key=lambda i: (bool(patches[i].abuts), not is_folded(patches[i]), i))


def group_patch(patches: List[LayerPatch], area: Optional[StudyArea] = None
                ) -> Tuple[np.ndarray, np.ndarray, Dict[str, Any]]:
    """One patch per layer for a group of crossing faults (module doc).

    Order: faults that abut no partner first, then the abutting ones; among
    each, folded patches (a reverse fault repeating the layer) before flat
    ones, else in the given order; each is clipped by the outlines of those
    before it. Why folded first: clipping removes whole triangles, so the
    clipped edges of a folded patch's footwall and hanging-wall sheets run
    side by side across the band and cross each other in XY; the clean-up
    then removes triangles at those crossings round after round, and the
    repetition goes (a normal fault crossing a reverse one: 0 % of the band
    left). A flat patch clipped by a folded outline has no such crossings.
    Returns (vertices, triangles, info) with info["pieces"] listing, per
    fault, the triangles kept and removed."""
    order = group_order(patches)
    Vs, Ts, rings, info = [], [], [], {"order": [patches[i].fault for i in order], "pieces": {}}
    off = 0
    for i in order:
        p = patches[i]
        V, T = p.vertices, p.triangles
        n0 = len(T)
        if rings:
            V, T = clip_patch(V, T, rings, area=area)
        info["pieces"][p.fault] = {"triangles": int(len(T)), "clipped": int(n0 - len(T))}
        if len(T) == 0:
            continue
        rings = rings + patch_outline(V, T)
        Vs.append(V)
        Ts.append(T + off)
        off += len(V)
    if not Vs:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), info
    return np.vstack(Vs), np.vstack(Ts), info
