"""Random perturbations of a dataset: one realization's input (docs/ensemble.md).

A :class:`Perturbation` states the uncertainty of the data; :func:`perturb`
draws one perturbed copy of a dataset from a random generator, and
:func:`realization_dataset` the copy of realization ``index`` of an ensemble
with seed ``seed`` (its own stream, ``SeedSequence(seed, spawn_key=(index,))``,
the ``index``-th child of ``SeedSequence(seed).spawn``), so a realization is
the same whatever worker computes it, in whatever order.

The random numbers are drawn in a fixed layout whatever the sigmas are (zero
sigmas still draw), so changing one sigma leaves the other sources' draws of
a realization unchanged (common random numbers across settings):
borehole rows, then extra points (layer by layer, dataset order), then per
fault (dataset order): position, one jitter per trace, dip, throw.

Each source is applied only where its sigma is non-zero, so an all-zero
perturbation returns a dataset equal (bit for bit) to the input.
"""
from __future__ import annotations

import copy
import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any, Dict, Mapping, Optional, Tuple

import numpy as np

from ..dataset import Dataset, DatasetError, Fault, Trace, points_in_polygon

__all__ = ["Perturbation", "FaultPerturbation", "perturb", "realization_dataset",
           "realization_seed", "fault_frame"]

# A trace whose section runs within ~6 degrees of the fault's strike
# (|cos| of the angle between the trace's horizontal direction and the
# fault's dip direction under 0.1) shows an apparent dip that says nothing
# about the true dip; its dip is left unchanged.
_MIN_COS_BETA = 0.1
# The perturbed true dip is kept within [1, 90] degrees: a fault never turns
# flat or overturned (the plane trace must stay top down).
_MIN_DIP_DEG = 1.0
_MAX_DIP_DEG = 90.0


def _check_sigma(name: str, v) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"Perturbation: {name} must be a number, got {v!r}") from None
    if not (math.isfinite(f) and f >= 0.0):
        raise ValueError(f"Perturbation: {name} must be a finite number >= 0, got {v!r}")
    return f


@dataclass(frozen=True)
class FaultPerturbation:
    """Per-fault overrides of the fault sigmas of :class:`Perturbation`
    (None: use the global value). Units as there."""

    sigma_position: Optional[float] = None
    sigma_position_trace: Optional[float] = None
    sigma_dip: Optional[float] = None
    sigma_throw: Optional[float] = None

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if v is not None:
                object.__setattr__(self, f.name, _check_sigma(f.name, v))


@dataclass(frozen=True)
class Perturbation:
    """The uncertainty of a dataset, as standard deviations of Gaussian errors.

    Every sigma defaults to 0 (that source is not perturbed).

    * ``sigma_z`` (m): elevation error of each borehole row (one layer top in
      one hole), independent per row.
    * ``sigma_z_points`` (m): elevation error of each extra data point
      (``Dataset.points``: seismic picks, survey points), independent per
      point; None (default) = ``sigma_z``.
    * ``sigma_position`` (m): position of each fault across its strike: all
      of the fault's traces and tips move together by one draw along the
      horizontal normal of the strike (positive towards the hanging wall).
    * ``sigma_position_trace`` (m): an extra independent shift of each trace
      along the same normal (interpretation jitter from section to section).
    * ``sigma_dip`` (degrees): change of the fault's true dip, one draw per
      fault applied to each of its traces: the trace is sheared in its own
      vertical plane about its point at the mean depth of its layer cutoffs,
      so that its true dip becomes dip + change (kept within [1, 90] degrees);
      the cutoffs, the strip and the wall polylines move with the plane
      (every point moves horizontally by the plane's move at its depth).
    * ``sigma_throw`` (relative): the hanging-wall offset at each cutoff is
      scaled by ``f = exp(sigma * xi - sigma**2 / 2)`` (xi standard normal; a
      lognormal factor with mean 1 and relative standard deviation ~sigma for
      small sigma, never negative, so a normal fault stays normal and a
      reverse one reverse), one draw per fault: the hanging-wall cutoff slides
      along the fault plane to its new depth and the hanging-wall polyline
      moves with it.
    * ``faults``: fault name -> :class:`FaultPerturbation` overriding the four
      fault sigmas for that fault.

    Units are those of the dataset's coordinates (metres for the formats
    faultmesh reads).
    """

    sigma_z: float = 0.0
    sigma_z_points: Optional[float] = None
    sigma_position: float = 0.0
    sigma_position_trace: float = 0.0
    sigma_dip: float = 0.0
    sigma_throw: float = 0.0
    faults: Mapping[str, FaultPerturbation] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("sigma_z", "sigma_position", "sigma_position_trace", "sigma_dip",
                     "sigma_throw"):
            object.__setattr__(self, name, _check_sigma(name, getattr(self, name)))
        if self.sigma_z_points is not None:
            object.__setattr__(self, "sigma_z_points",
                               _check_sigma("sigma_z_points", self.sigma_z_points))
        fp = {}
        for k, v in dict(self.faults).items():
            if isinstance(v, Mapping):
                v = FaultPerturbation(**v)
            if not isinstance(v, FaultPerturbation):
                raise TypeError(f"Perturbation: faults[{k!r}] must be a FaultPerturbation or a "
                                f"mapping, got {type(v).__name__}")
            fp[str(k)] = v
        object.__setattr__(self, "faults", fp)

    def for_fault(self, name: str) -> Dict[str, float]:
        """The four fault sigmas in force for fault ``name``."""
        o = self.faults.get(name, FaultPerturbation())
        out = {}
        for k in ("sigma_position", "sigma_position_trace", "sigma_dip", "sigma_throw"):
            v = getattr(o, k)
            out[k] = getattr(self, k) if v is None else v
        return out

    @property
    def is_zero(self) -> bool:
        """True when nothing is perturbed."""
        zp = self.sigma_z if self.sigma_z_points is None else self.sigma_z_points
        if self.sigma_z or zp:
            return False
        return not any(self.for_fault(n)[k] for n in set(self.faults) | {""}
                       for k in ("sigma_position", "sigma_position_trace", "sigma_dip",
                                 "sigma_throw"))

    def check_faults(self, dataset: Dataset) -> None:
        """Raise ValueError if an override names a fault the dataset lacks."""
        names = [f.name for f in dataset.faults]
        bad = sorted(set(self.faults) - set(names))
        if bad:
            raise ValueError(f"Perturbation: no fault {bad[0]!r} in dataset {dataset.name!r}; "
                             f"faults are {names}")

    def to_dict(self) -> Dict[str, Any]:
        d = asdict(self)
        d["faults"] = {k: asdict(v) for k, v in self.faults.items()}
        return d


# ---------------------------------------------------------------------------
# Seeds
# ---------------------------------------------------------------------------
def realization_seed(seed: int, index: int) -> np.random.SeedSequence:
    """The seed sequence of realization ``index``: the ``index``-th child of
    ``SeedSequence(seed).spawn(...)``, built directly (O(1))."""
    return np.random.SeedSequence(int(seed), spawn_key=(int(index),))


# ---------------------------------------------------------------------------
# Fault geometry helpers
# ---------------------------------------------------------------------------
def _unit2(v) -> Optional[np.ndarray]:
    v = np.asarray(v, dtype=np.float64)[:2]
    n = float(np.hypot(v[0], v[1]))
    return None if n == 0.0 or not math.isfinite(n) else v / n


def fault_frame(fault: Fault) -> Tuple[np.ndarray, np.ndarray]:
    """(nu, strike): unit horizontal vectors of ``fault``. ``nu`` is the
    normal of the strike pointing to the hanging-wall side (from the wall
    polylines: hanging far end minus footwall far end; without layers the
    plane's top-to-bottom direction); ``strike`` is the direction from the
    first trace to the last (or ``nu`` turned by 90 degrees for one trace)."""
    hw = np.zeros(2)
    for tr in fault.traces:
        for sides in tr.layers.values():
            hw += np.asarray(sides["hanging"])[-1, :2] - np.asarray(sides["foot"])[0, :2]
    if not np.any(hw):
        for tr in fault.traces:
            hw += tr.plane[-1, :2] - tr.plane[0, :2]
    hw_u = _unit2(hw)
    centres = [tr.plane[:, :2].mean(axis=0) for tr in fault.traces]
    strike = _unit2(centres[-1] - centres[0]) if len(centres) >= 2 else None
    if strike is None:
        if hw_u is None:
            raise DatasetError(f"fault {fault.name!r}: cannot tell its strike (one trace with no "
                               "horizontal extent and no wall polylines)")
        return hw_u, np.array([-hw_u[1], hw_u[0]])
    nu = np.array([-strike[1], strike[0]])
    if hw_u is not None and float(nu @ hw_u) < 0.0:
        nu = -nu
    return nu, strike


def _plane_xy_at(plane: np.ndarray, z: np.ndarray) -> np.ndarray:
    """XY (k, 2) of the plane polyline (top down) at depths ``z`` (k,):
    linear along the polyline, continued along the end segments beyond its
    ends. Horizontal pieces (equal z) keep their first point."""
    P = plane[np.r_[True, np.diff(plane[:, 2]) < 0]]   # strictly descending z
    z = np.asarray(z, dtype=np.float64).reshape(-1)
    if len(P) == 1:
        return np.repeat(P[:1, :2], len(z), axis=0)
    zs = P[::-1, 2]                                     # increasing
    out = np.column_stack([np.interp(z, zs, P[::-1, 0]), np.interp(z, zs, P[::-1, 1])])
    for sel, a, b in ((z > P[0, 2], P[0], P[1]), (z < P[-1, 2], P[-2], P[-1])):
        if sel.any():
            t = (z[sel] - a[2]) / (b[2] - a[2])
            out[sel] = a[None, :2] + t[:, None] * (b[:2] - a[:2])[None, :]
    return out


def _pivot_depth(tr: Trace) -> float:
    """Mean depth of the trace's layer cutoffs (the plane's middle depth
    when the trace has no layer)."""
    zs = [0.5 * (float(s["foot"][-1, 2]) + float(s["hanging"][0, 2])) for s in tr.layers.values()]
    if zs:
        return float(np.mean(zs))
    return 0.5 * (float(tr.plane[0, 2]) + float(tr.plane[-1, 2]))


# ---------------------------------------------------------------------------
# The three fault moves (each maps a trace to a new trace)
# ---------------------------------------------------------------------------
def _scale_throw(tr: Trace, factor: float) -> None:
    """Slide each hanging-wall cutoff along the plane so that its vertical
    offset from the footwall cutoff is scaled by ``factor``; the hanging-wall
    polyline moves with it (in place)."""
    for sides in tr.layers.values():
        cf, ch = sides["foot"][-1], sides["hanging"][0]
        z_new = cf[2] + factor * (ch[2] - cf[2])
        xy = _plane_xy_at(tr.plane, np.array([ch[2], z_new]))
        move = np.array([xy[1, 0] - xy[0, 0], xy[1, 1] - xy[0, 1], z_new - ch[2]])
        sides["hanging"] = sides["hanging"] + move[None, :]


def _shear_dip(tr: Trace, nu: np.ndarray, delta_deg: float) -> None:
    """Change the trace's true dip by ``delta_deg``: every point moves along
    the trace's horizontal direction e by (z_p - z) (cot dip' - cot dip) /
    cos(beta), z_p the pivot depth, beta the angle between e and the dip
    direction ``nu`` (in place)."""
    plane = tr.plane
    e = _unit2(plane[-1, :2] - plane[0, :2])
    if e is None:                                   # vertical plane trace
        e = nu.copy()
    cosb = abs(float(e @ nu))
    if cosb < _MIN_COS_BETA:
        return
    horiz = float(np.hypot(*(plane[-1, :2] - plane[0, :2])))
    drop = float(plane[0, 2] - plane[-1, 2])
    if drop <= 0.0:                                 # a flat trace: no dip to change
        return
    if float(e @ nu) < 0.0:                         # plane going towards the footwall: dip > 90
        return
    dip = math.atan2(drop / cosb, horiz) if horiz > 0 else math.pi / 2
    new = min(max(dip + math.radians(delta_deg), math.radians(_MIN_DIP_DEG)),
              math.radians(_MAX_DIP_DEG))

    def cot(a: float) -> float:
        return 0.0 if a >= math.pi / 2 else math.cos(a) / math.sin(a)

    k = (cot(new) - cot(dip)) / cosb
    if k == 0.0:
        return
    zp = _pivot_depth(tr)

    def move(p: np.ndarray) -> np.ndarray:
        d = (zp - p[:, 2]) * k
        out = p.copy()
        out[:, :2] += d[:, None] * e[None, :]
        return out

    tr.plane = move(plane)
    for sides in tr.layers.values():
        for s in ("foot", "hanging"):
            sides[s] = move(sides[s])


def _shift(tr: Trace, v: np.ndarray) -> None:
    tr.plane = tr.plane + np.r_[v, 0.0][None, :]
    for sides in tr.layers.values():
        for s in ("foot", "hanging"):
            sides[s] = sides[s] + np.r_[v, 0.0][None, :]


# ---------------------------------------------------------------------------
# Validity at the study-area boundary
# ---------------------------------------------------------------------------
def _clip_wall(poly: np.ndarray, ring: np.ndarray, cutoff_last: bool) -> Optional[np.ndarray]:
    """The part of a wall polyline inside the study area that is connected
    to its cutoff, ended at the boundary (the inside end of a bisection of
    the crossing segment down to 1 mm); None if the cutoff itself is
    outside or nothing but the cutoff is left."""
    p = poly[::-1] if cutoff_last else poly        # from the cutoff outwards
    inside = points_in_polygon(p[:, :2], ring)
    if inside.all():
        return poly
    if not inside[0]:
        return None
    j = int(np.flatnonzero(~inside)[0])
    a, b = p[j - 1].copy(), p[j].copy()
    # 1 mm: far below any survey precision, and a point that close to the
    # boundary is still inside by the exact test (we keep the inside end).
    for _ in range(64):
        if float(np.hypot(*(b[:2] - a[:2]))) <= 1e-3:
            break
        m = 0.5 * (a + b)
        if points_in_polygon(m[None, :2], ring)[0]:
            a = m
        else:
            b = m
    kept = p[:j]
    if float(np.hypot(*(a[:2] - kept[-1, :2]))) > 1e-3:
        kept = np.vstack([kept, a[None, :]])
    if len(kept) < 2:
        return None
    return kept[::-1].copy() if cutoff_last else kept


def _enforce_inside(fault: Fault, ring: np.ndarray, base: Fault) -> None:
    """Make a perturbed fault's data lie in the study area (in place):
    wall polylines are cut at the boundary, tips pulled back towards their
    unperturbed position; a plane point or cutoff outside is an error."""
    for j, tr in enumerate(fault.traces):
        out = ~points_in_polygon(tr.plane[:, :2], ring)
        if out.any():
            k = int(np.flatnonzero(out)[0])
            raise DatasetError(f"fault {fault.name!r} trace {j + 1} plane point {k + 1} "
                               f"({tr.plane[k, 0]:.3f}, {tr.plane[k, 1]:.3f}) lies outside the "
                               "study area after the perturbation")
        for lay, sides in tr.layers.items():
            for side, last in (("foot", True), ("hanging", False)):
                c = _clip_wall(sides[side], ring, last)
                if c is None:
                    q = sides[side][-1 if last else 0]
                    raise DatasetError(f"fault {fault.name!r} trace {j + 1} layer {lay!r}: the "
                                       f"{side} cutoff ({q[0]:.3f}, {q[1]:.3f}) lies outside (or "
                                       "on) the study area after the perturbation")
                sides[side] = c
    if len(fault.tips):
        tips = fault.tips.copy()
        for i in range(len(tips)):
            for _ in range(60):
                if points_in_polygon(tips[i][None, :], ring)[0]:
                    break
                tips[i] = 0.5 * (tips[i] + base.tips[i])
            else:
                raise DatasetError(f"fault {fault.name!r} tip {i + 1} lies outside the study "
                                   "area after the perturbation")
        fault.tips = tips


def _check_consistent(fault: Fault, base: Fault) -> None:
    """Plane traces top down; each trace-layer's cutoffs in the same vertical
    order as in the input (hanging below footwall for a normal fault, above
    for a reverse one, as the input had them)."""
    for j, (tr, tb) in enumerate(zip(fault.traces, base.traces)):
        if np.any(np.diff(tr.plane[:, 2]) > 0):
            raise DatasetError(f"fault {fault.name!r} trace {j + 1}: the plane is no longer top "
                               "down after the perturbation")
        for lay, sides in tr.layers.items():
            b = tb.layers[lay]
            was = np.sign(b["foot"][-1, 2] - b["hanging"][0, 2])
            now = np.sign(sides["foot"][-1, 2] - sides["hanging"][0, 2])
            if was != now:
                raise DatasetError(f"fault {fault.name!r} trace {j + 1} layer {lay!r}: the "
                                   "perturbation turned the cutoffs' vertical order")


# ---------------------------------------------------------------------------
# perturb
# ---------------------------------------------------------------------------
def _copy_dataset(ds: Dataset) -> Dataset:
    """A deep copy of the data (not of ``truth``/``geology``, which stay
    with the input and are dropped from the copy)."""
    out = copy.copy(ds)
    out.truth = None
    out.geology = None
    out.boreholes = copy.deepcopy(ds.boreholes)
    out.points = {k: v.copy() for k, v in ds.points.items()}
    out.faults = copy.deepcopy(ds.faults)
    out.sections = dict(ds.sections)
    out.boundary = ds.boundary.copy()
    return out


def perturb(dataset: Dataset, perturbation: Perturbation, rng: np.random.Generator) -> Dataset:
    """A perturbed copy of ``dataset`` (see :class:`Perturbation`); the input
    is not changed. Raises :class:`~faultmesh.DatasetError` naming the fault,
    trace and point when the drawn geometry leaves the study area (a fault
    plane point or cutoff outside it; wall polylines are cut at the boundary
    and tips pulled back inside instead)."""
    p = perturbation
    out = _copy_dataset(dataset)
    b = out.boreholes
    xi = rng.standard_normal(len(b.z))
    if p.sigma_z > 0.0:
        b.z = b.z + p.sigma_z * xi
    sp = p.sigma_z if p.sigma_z_points is None else p.sigma_z_points
    for lay in list(out.points):
        arr = out.points[lay]
        xi = rng.standard_normal(len(arr))
        if sp > 0.0 and len(arr):
            arr = arr.copy()
            arr[:, 2] += sp * xi
            out.points[lay] = arr
    ring = out.boundary
    for f, fb in zip(out.faults, dataset.faults):
        s = p.for_fault(f.name)
        x_pos = float(rng.standard_normal())
        x_trace = rng.standard_normal(len(f.traces))
        x_dip = float(rng.standard_normal())
        x_throw = float(rng.standard_normal())
        if not any(s.values()):
            continue
        nu, _ = fault_frame(fb)
        if s["sigma_throw"] > 0.0:
            g = math.exp(s["sigma_throw"] * x_throw - 0.5 * s["sigma_throw"] ** 2)
            for tr in f.traces:
                _scale_throw(tr, g)
        if s["sigma_dip"] > 0.0:
            for tr in f.traces:
                _shear_dip(tr, nu, s["sigma_dip"] * x_dip)
        if s["sigma_position"] > 0.0 or s["sigma_position_trace"] > 0.0:
            d_f = s["sigma_position"] * x_pos
            for tr, xt in zip(f.traces, x_trace):
                _shift(tr, (d_f + s["sigma_position_trace"] * float(xt)) * nu)
            if len(f.tips):
                f.tips = f.tips + d_f * nu[None, :]
        _enforce_inside(f, ring, fb)
        _check_consistent(f, fb)
    return out


def realization_dataset(dataset: Dataset, perturbation: Perturbation, seed: int,
                        index: int) -> Dataset:
    """The perturbed dataset of realization ``index`` of an ensemble with
    ``seed`` (what :func:`faultmesh.ensemble` builds for it)."""
    return perturb(dataset, perturbation, np.random.default_rng(realization_seed(seed, index)))
