"""Sampling one realization's model where the ensemble statistics are kept.

Runs on the Dask workers: :func:`run_realization` perturbs the dataset,
builds the model and returns only the samples (:class:`Samples`), a few
hundred kilobytes, never the model.

What is sampled (docs/ensemble.md):

* layer elevations on the grid nodes inside the study area: where the
  vertical line through a node meets the layer more than once (a reverse
  fault's repetition band) the UPPER sheet is the sample (what a vertical
  borehole meets first, the sheet ``Geology.truth`` reports); the lower
  sheet is sampled too when asked (``lower_sheet``), and whether the line
  meets two sheets more than 1 mm apart is recorded;
* the fault side of each node at each layer (:func:`fault_sides`);
* each layer's (upper-sheet) elevation at sample points along each section
  line and at given points (e.g. the borehole collars).
"""
from __future__ import annotations

import math
import time
import traceback
from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..dataset import Dataset, Section, points_in_polygon
from .perturbation import Perturbation, fault_frame, realization_dataset

__all__ = ["Grid", "SectionLine", "Sampler", "Samples", "sample_model", "fault_sides",
           "run_realization", "SIDE_NONE", "SIDE_FOOT", "SIDE_HANGING"]

SIDE_NONE, SIDE_FOOT, SIDE_HANGING = 0, 1, 2

# Two sheets of a layer above one node count as a repetition when they are
# more than 1 mm apart: far below any geological thickness, far above the
# rounding of barycentric interpolation (~1e-12 relative).
_REPEAT_TOL = 1e-3


@dataclass
class Grid:
    """A regular grid of nodes: ``x`` (nx,) and ``y`` (ny,) increasing node
    coordinates (cell centres), in the dataset's coordinates."""

    x: np.ndarray
    y: np.ndarray

    def __post_init__(self) -> None:
        self.x = np.asarray(self.x, dtype=np.float64).reshape(-1)
        self.y = np.asarray(self.y, dtype=np.float64).reshape(-1)
        for name, v in (("x", self.x), ("y", self.y)):
            if len(v) < 1 or not np.all(np.isfinite(v)):
                raise ValueError(f"Grid: {name} must be at least one finite coordinate")
            if len(v) > 1 and not np.all(np.diff(v) > 0):
                raise ValueError(f"Grid: {name} must be strictly increasing")

    @classmethod
    def over(cls, boundary, nodes: Optional[int] = None, spacing: Optional[float] = None) -> "Grid":
        """Square cells over the bounding box of ``boundary`` (a ring (k, 2) or
        a Dataset): ``nodes`` along its longer side (default 100) or a given
        ``spacing``; nodes at cell centres."""
        ring = boundary.boundary if isinstance(boundary, Dataset) else np.asarray(boundary, float)
        lo, hi = ring.min(axis=0), ring.max(axis=0)
        if spacing is None:
            nodes = 100 if nodes is None else int(nodes)
            if nodes < 1:
                raise ValueError(f"Grid.over: nodes must be >= 1, got {nodes}")
            spacing = float(max(hi - lo)) / nodes
        elif not (spacing > 0 and math.isfinite(spacing)):
            raise ValueError(f"Grid.over: spacing must be > 0, got {spacing}")
        nx = max(1, int(math.floor(float(hi[0] - lo[0]) / spacing + 1e-9)))
        ny = max(1, int(math.floor(float(hi[1] - lo[1]) / spacing + 1e-9)))
        return cls(lo[0] + spacing * (np.arange(nx) + 0.5), lo[1] + spacing * (np.arange(ny) + 0.5))

    @property
    def shape(self) -> Tuple[int, int]:
        return (len(self.y), len(self.x))

    def xy(self) -> np.ndarray:
        """Node coordinates (ny * nx, 2), row by row (y outer, x inner)."""
        X, Y = np.meshgrid(self.x, self.y)
        return np.column_stack([X.ravel(), Y.ravel()])


@dataclass
class SectionLine:
    """Sample points along one section line: distances ``s`` (m,) from the
    section's origin, ``xy`` (m, 2); ``inside`` marks those in the study area."""

    name: str
    origin: np.ndarray
    azimuth: float
    s: np.ndarray
    xy: np.ndarray
    inside: np.ndarray

    @classmethod
    def across(cls, section: Section, ring: np.ndarray, samples: int = 200) -> "SectionLine":
        """``samples`` evenly spaced points over the stretch of the line
        between its first and last crossing of the study-area boundary."""
        d = section.direction
        a = ring
        b = np.roll(ring, -1, axis=0)
        e = b - a
        o = section.origin
        den = d[0] * e[:, 1] - d[1] * e[:, 0]
        w = a - o[None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / den
            u = (w[:, 0] * d[1] - w[:, 1] * d[0]) / den
        ok = (den != 0) & (u >= 0) & (u <= 1)
        if not ok.any():
            raise ValueError(f"section {section.name!r} does not cross the study area")
        s = np.linspace(float(t[ok].min()), float(t[ok].max()), int(samples))
        xy = section.to_xy(s)
        return cls(section.name, section.origin.copy(), section.azimuth, s, xy,
                   points_in_polygon(xy, ring))


@dataclass
class Sampler:
    """Where a realization is sampled; built once on the client and shipped
    to the workers with the dataset."""

    grid: Grid
    inside: np.ndarray                 # (ny * nx,) bool
    layers: List[str]
    faults: List[str]
    cuts: np.ndarray                   # (n_layers, n_faults) bool: some trace of the fault has the layer
    sections: List[SectionLine] = field(default_factory=list)
    point_names: List[str] = field(default_factory=list)
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    lower_sheet: bool = False

    @classmethod
    def build(cls, dataset: Dataset, grid: Grid, sections: Sequence[SectionLine] = (),
              points: Optional[Mapping[str, Sequence[float]]] = None,
              lower_sheet: bool = False) -> "Sampler":
        inside = points_in_polygon(grid.xy(), dataset.boundary)
        if not inside.any():
            raise ValueError("ensemble: no grid node lies inside the study area")
        faults = [f.name for f in dataset.faults]
        cuts = np.array([[any(lay in tr.layers for tr in f.traces) for f in dataset.faults]
                         for lay in dataset.layers], dtype=bool).reshape(len(dataset.layers),
                                                                         len(faults))
        names = list(points) if points else []
        P = np.array([np.asarray(points[k], dtype=np.float64).reshape(2) for k in names]
                     ).reshape(-1, 2)
        return cls(grid, inside, list(dataset.layers), faults, cuts, list(sections), names, P,
                   bool(lower_sheet))

    @property
    def n_inside(self) -> int:
        return int(self.inside.sum())


@dataclass
class Samples:
    """What one realization sends back (see module doc); ``error`` set and no
    arrays when it failed."""

    index: int
    grid: Optional[np.ndarray] = None          # (L, N) upper sheet at inside nodes
    grid_lower: Optional[np.ndarray] = None    # (L, N) lower sheet (lower_sheet only)
    repeated: Optional[np.ndarray] = None      # (L, N) bool: two sheets > 1 mm apart
    sides: Optional[np.ndarray] = None         # (L, F, N) int8 SIDE_*
    sections: Optional[np.ndarray] = None      # (S, L, M) upper sheet along each section
    points: Optional[np.ndarray] = None        # (L, K)
    build_seconds: float = 0.0                 # perturb + build_model, wall clock on the worker
    sample_seconds: float = 0.0                # sample_model, wall clock
    cpu_seconds: float = 0.0                   # the worker thread's CPU time for all of it
    error: Optional[str] = None

    @property
    def ok(self) -> bool:
        return self.error is None


def _sheets(surface, xy: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    from ..build import surface_z

    lo, hi, _ = surface_z(surface.vertices, surface.triangles, xy)
    return lo, hi


def fault_sides(model, dataset: Dataset, sampler: Sampler, xy: np.ndarray,
                z: np.ndarray) -> np.ndarray:
    """Side of each point (x, y, z[layer]) relative to each fault: (L, F, K)
    int8, ``SIDE_HANGING`` (2), ``SIDE_FOOT`` (1) or ``SIDE_NONE`` (0).

    For fault f and layer L: NONE where f displaces L nowhere (no trace of
    f has L), where f has no surface in the model, where the layer has no
    value, or where the point lies beyond the fault's ends (its projection on
    the fault's strike falls outside that of the fault surface). Elsewhere
    the point is in the HANGING wall when it lies above the fault: above the
    fault surface where the vertical line through it meets the surface,
    else on the upper side of the surface's best-fit plane (normal oriented
    to the hanging-wall side of the data); on the surface counts as
    footwall."""
    L, K = len(sampler.layers), len(xy)
    out = np.zeros((L, len(sampler.faults), K), dtype=np.int8)
    for fi, name in enumerate(sampler.faults):
        surf = model.faults.get(name)
        if surf is None or surf.n_triangles == 0 or not sampler.cuts[:, fi].any():
            continue
        V = surf.vertices
        C = V.mean(axis=0)
        nu, _ = fault_frame(dataset.fault(name))
        # Best-fit plane: the normal is the singular vector of the smallest
        # singular value of the centred vertices.
        _, _, vt = np.linalg.svd(V - C, full_matrices=False)
        n = vt[-1]
        h = float(n[:2] @ nu)
        if h < 0 or (h == 0 and n[2] < 0):
            n = -n
        strike = np.array([-nu[1], nu[0]])
        u_v = (V[:, :2] - C[:2]) @ strike
        u = (xy - C[:2]) @ strike
        within = (u >= u_v.min()) & (u <= u_v.max())
        _, zf = _sheets(surf, xy)
        for li in np.flatnonzero(sampler.cuts[:, fi]):
            zl = z[li]
            ok = within & np.isfinite(zl)
            above_surf = zl > zf                                   # NaN zf -> False
            off = (xy - C[:2]) @ n[:2] + (zl - C[2]) * n[2]
            above = np.where(np.isfinite(zf), above_surf, off > 0)
            out[li, fi] = np.where(ok, np.where(above, SIDE_HANGING, SIDE_FOOT), SIDE_NONE)
    return out


def sample_model(model, dataset: Dataset, sampler: Sampler) -> Dict[str, np.ndarray]:
    """The samples (arrays of :class:`Samples`) of one built model."""
    xy = sampler.grid.xy()[sampler.inside]
    L = len(sampler.layers)
    up = np.full((L, len(xy)), np.nan)
    low = np.full((L, len(xy)), np.nan) if sampler.lower_sheet else None
    rep = np.zeros((L, len(xy)), dtype=bool)
    sec = np.full((len(sampler.sections), L, len(sampler.sections[0].s) if sampler.sections else 0),
                  np.nan)
    pts = np.full((L, len(sampler.points)), np.nan)
    for li, lay in enumerate(sampler.layers):
        surf = model.surfaces[lay]
        lo, hi = _sheets(surf, xy)
        up[li] = hi
        rep[li] = (hi - lo) > _REPEAT_TOL
        if low is not None:
            low[li] = lo
        for si, sl in enumerate(sampler.sections):
            z = np.full(len(sl.s), np.nan)
            if sl.inside.any():
                z[sl.inside] = _sheets(surf, sl.xy[sl.inside])[1]
            sec[si, li] = z
        if len(sampler.points):
            pts[li] = _sheets(surf, sampler.points)[1]
    sides = fault_sides(model, dataset, sampler, xy, up)
    return {"grid": up, "grid_lower": low, "repeated": rep, "sides": sides, "sections": sec,
            "points": pts}


def run_realization(dataset: Dataset, sampler: Sampler, perturbation: Perturbation, seed: int,
                    index: int, build_options: Optional[Dict[str, Any]] = None) -> Samples:
    """Perturb, build and sample realization ``index`` (a Dask task). An
    exception is caught and returned as ``Samples(error=...)`` so the client
    counts it with its seed; only the samples travel back."""
    from ..build import build_model

    t0 = time.perf_counter()
    c0 = time.thread_time()
    try:
        ds = realization_dataset(dataset, perturbation, seed, index)
        # One thread per build: the ensemble's parallelism is its workers.
        model = build_model(ds, **{"evaluate": False, "threads": 1, **(build_options or {})})
        t1 = time.perf_counter()
        arrays = sample_model(model, ds, sampler)
        t2 = time.perf_counter()
    except Exception as e:  # a failed realization is reported, never fatal
        tb = traceback.extract_tb(e.__traceback__)
        where = f" (at {tb[-1].filename.rsplit('/', 1)[-1]}:{tb[-1].lineno})" if tb else ""
        return Samples(index=index, error=f"{type(e).__name__}: {e}{where}",
                       build_seconds=time.perf_counter() - t0,
                       cpu_seconds=time.thread_time() - c0)
    return Samples(index=index, build_seconds=t1 - t0, sample_seconds=t2 - t1,
                   cpu_seconds=time.thread_time() - c0, **arrays)
