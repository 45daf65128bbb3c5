"""Random grounds: datasets from ground truths faultmesh was not written for.

:func:`random_ground` draws, from ``np.random.default_rng(seed)`` alone, a
ground truth (a :class:`faultmesh.geology.Geology`) and samples a format-v1
dataset from it, the way a survey would record it:

* a study area 1.5-6 km across: an axis-parallel or rotated rectangle, an L
  or U shape, or a random simple polygon of 5-12 vertices; at local
  coordinates (origin near 0), UTM-sized ones (x ~ 5e5, y ~ 7e6) or other big
  offsets (Gauss-Krueger, zone-prefixed, negative);
* 1-6 layers with smooth non-planar tops, intervals from a few metres to a
  few hundred;
* one to four dip-slip faults of any strike, dip 30-85 degrees (gentle
  30-45 degree reverse faults often), normal and reverse: inside the area
  (two tips), across it (both ends on the boundary, the paper's F22 kind) or
  ending on the boundary at one end; a T-crossing (one abuts the other) or
  an X-crossing pair in one ``group``; otherwise faults far enough apart to
  be independent, or deliberately too close (zones overlapping, different
  groups: the builder must reject the dataset naming both);
* sections across each fault (one exploration grid of parallel lines, or a
  family per fault; a fault end on the boundary sometimes has its end trace
  ON the boundary, along the side it crosses), fault traces with footwall
  and hanging-wall polylines to the cutoffs, tips where a fault dies out
  inside, boreholes (some stopping early, some placed where a reverse fault
  repeats a layer, so that they hit it twice) and sometimes a topographic
  survey of the top layer;
* coordinates rounded as surveyors write them (boundary, traces, collars and
  elevations each to 1 cm, 1 mm or 0.1 mm, the boundary sometimes not at
  all): the dataset is written with :meth:`Dataset.save` and read back with
  :func:`faultmesh.load_dataset` (trace points sometimes as section-local
  ``[s, z]``, digitised to the same precision), so the loader's path is part
  of every ground.

Everything written comes from the truth: borehole tops are the truth's
sheets at the (rounded) collar, trace polylines are the truth's sides of the
fault, cutoffs lie on the truth's fault surface (up to the rounding).
What was drawn is recorded in a :class:`GroundSpec` (``dataset.spec``;
``spec.describe()`` says it in one line).

Measures for a built model (used by ``bench/sweep.py`` and the tests):
:func:`repetition_coverage`, :func:`near_fault_accuracy`, and
:func:`evaluate_ground`, which runs one seed from drawing to the checks and
says where it stopped (:func:`failure_class`).

**Format 2 without cutoffs** (issue 11): :func:`write_v2` (or
``random_ground(seed, path, version=2)``) writes the same ground again as
the data geologists have, for :func:`faultmesh.derive.derive_faults`:

* each fault as fault sticks on the truth's fault surface (one every
  60-140 m along strike within the fault's extent near the study area,
  points every 15-35 m down the stick over the layers' depths; a fault that
  abuts another only on its side of it), rounded like the traces; no
  traces, no kind, no tips (the group is kept);
* the layer tops as collar, survey and interval tables of the v1 holes
  (same ids and collar x, y; collar z the top layer's truth rounded as
  v1's tops): half vertical, a quarter straight and inclined (dip -60 to
  -85, any azimuth), a quarter curved (stations every 30 m); the intervals
  logged from the truth along each desurveyed path (contacts bisected with
  the fault block fixed, :meth:`Geology.tops_in_block`), depths to 1 mm,
  angles to 0.01 degree, fault rock (:data:`FAULT_ROCK`) where a hole
  crosses a fault and the unit changes, :data:`COVER` above the top layer
  under a thrust; so a hole through a reverse fault's repetition enters the
  layer twice, and the reader gives both tops (of the top layer only one:
  nothing lies above it);
* the v1 topography as points.

It draws from its own generator (``default_rng([seed, 2])``): the v1 files
do not change. :func:`evaluate_ground_v2` builds and checks both versions of
a seed and compares them: :func:`cutoff_distance` (derived against true
cutoffs), :func:`near_fault_errors` (each model's error near the faults,
on the same points) and their ratio (limit :data:`V2_RATIO`);
``bench/sweep.py --v2`` runs it over many seeds.
"""
from __future__ import annotations

import json
import math
import re
import tempfile
import time
import traceback
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .dataset import Boreholes, Dataset, DatasetError, Fault, Section, Trace, points_in_polygon
from .geology import FaultModel, Geology, layer_stack, smooth_field

__all__ = ["GroundSpec", "random_ground", "make_ground", "draw_plan", "KINDS",
           "repetition_coverage", "near_fault_accuracy", "evaluate_ground", "failure_class",
           "COVERAGE_THRESHOLD", "write_v2", "evaluate_ground_v2", "cutoff_distance",
           "near_fault_errors", "V2_RATIO", "FAULT_ROCK", "COVER"]

#: A reverse fault "repeats" a layer if the model folds (footwall, strip,
#: hanging wall) over at least this share of the places where the truth has
#: the layer twice AND the data say so (between consecutive traces, inside
#: the quadrilateral of their cutoffs: ``share_data`` of
#: :func:`repetition_coverage`). Where the data say nothing (beyond the end
#: traces, or where the band wanders with the layer's folds between sections
#: hundreds of metres apart) no builder can know; there ``share`` (the whole
#: truth band) is reported but not held to a threshold. 95 % leaves room for
#: the sampling at the band's edges (the cutoff segments are straight, the
#: truth's band edges are not) and is far above the 72 % the robustness issue
#: reports.
COVERAGE_THRESHOLD = 0.95

#: The categories a ground is drawn from (``GroundSpec.tags`` uses them).
KINDS: Dict[str, Tuple[str, ...]] = {
    "coords": ("local", "utm", "offset"),
    "area": ("rectangle", "rotated_rectangle", "L", "U", "polygon"),
    "n_faults": ("1", "2", "3", "4"),
    "pair": ("none", "T", "X", "too_close"),
    "fault": ("normal", "reverse", "gentle_reverse"),
    "extent": ("inside", "crossing", "one_end"),
    "boundary_end": ("on_boundary", "extended"),
    "sections": ("grid", "per_fault"),
    "trace_format": ("xyz", "sz"),
}

_DECIMALS = (2, 3, 4)  # 1 cm, 1 mm, 0.1 mm


# ---------------------------------------------------------------------------
# What was drawn
# ---------------------------------------------------------------------------
@dataclass
class GroundSpec:
    """What :func:`random_ground` drew for one seed (JSON-serialisable via
    :meth:`to_dict`). ``faults`` has one dict per fault: name, kind, dip,
    strike, throw, extent ("inside", "crossing", "one_end"), ends (per end
    "tip", "on_boundary" or "extended"), group, abuts, layers (displaced),
    traces (count). ``pair`` = {"relation": "T" / "X" / "too_close",
    "faults": [older, younger]} or None. ``expect`` is "build" or "reject"
    (a too-close pair: the builder must raise a DatasetError naming both)."""

    seed: int
    coords: str = "local"
    origin: Tuple[float, float] = (0.0, 0.0)
    area: str = "rectangle"
    size: float = 0.0
    n_vertices: int = 4
    layers: List[str] = field(default_factory=list)
    thinnest: float = 0.0
    thickest: float = 0.0
    n_holes: int = 0
    n_band_holes: int = 0
    topography: bool = False
    sections: str = "per_fault"
    trace_format: str = "xyz"
    rounding: Dict[str, Optional[int]] = field(default_factory=dict)
    faults: List[Dict[str, Any]] = field(default_factory=list)
    pair: Optional[Dict[str, Any]] = None
    expect: str = "build"

    def to_dict(self) -> Dict[str, Any]:
        d = asdict(self)
        d["origin"] = [float(v) for v in self.origin]
        return d

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "GroundSpec":
        d = dict(d)
        d["origin"] = tuple(d.get("origin", (0.0, 0.0)))
        return cls(**d)

    def tags(self) -> Dict[str, List[str]]:
        """Per category of :data:`KINDS`, the values this ground has (a
        category may have several: one per fault or fault end)."""
        kinds = []
        for f in self.faults:
            kinds.append(f["kind"])
            if f["kind"] == "reverse" and f["dip"] <= 45.0:
                kinds.append("gentle_reverse")
        ends = [e for f in self.faults for e in f["ends"] if e != "tip"]
        return {"coords": [self.coords], "area": [self.area], "n_faults": [str(len(self.faults))],
                "pair": [self.pair["relation"] if self.pair else "none"],
                "fault": sorted(set(kinds)),
                "extent": sorted({f["extent"] for f in self.faults}),
                "boundary_end": sorted(set(ends)),
                "sections": [self.sections], "trace_format": [self.trace_format]}

    def describe(self) -> str:
        """One line, e.g. "seed 7: 2 faults, X-crossing F1+F2, UTM, rotated
        rectangle 3.2 km, F1 reverse 38 deg crossing (ends on_boundary,
        extended), F2 normal 71 deg inside; 4 layers (thinnest 3.1 m), 85
        holes, per-fault sections, rounding boundary 1 mm / traces 0.1 mm"."""
        def dec(v):
            return {None: "none", 0: "1 m", 1: "1 dm", 2: "1 cm", 3: "1 mm", 4: "0.1 mm"}.get(v, f"1e-{v}")

        parts = [f"{len(self.faults)} fault{'s' if len(self.faults) != 1 else ''}"]
        if self.pair:
            rel = {"T": "T-crossing", "X": "X-crossing", "too_close": "too close"}[self.pair["relation"]]
            parts.append(f"{rel} {'+'.join(self.pair['faults'])}")
        parts.append({"local": "local", "utm": "UTM", "offset": "big offset"}[self.coords])
        parts.append(f"{self.area.replace('_', ' ')} {self.size / 1000.0:.1f} km")
        for f in self.faults:
            ends = "" if f["extent"] == "inside" else f" (ends {', '.join(f['ends'])})"
            parts.append(f"{f['name']} {f['kind']} {f['dip']:.0f} deg {f['extent']}{ends}")
        lay = (f"{len(self.layers)} layers (thinnest {self.thinnest:.1f} m)" if len(self.layers) > 1
               else "1 layer")
        tail = (f"{lay}, {self.n_holes} holes, "
                f"{self.sections.replace('_', '-')} sections, traces {self.trace_format}, "
                f"rounding boundary {dec(self.rounding.get('boundary'))} / traces "
                f"{dec(self.rounding.get('traces'))}")
        if self.expect == "reject":
            tail += "; must be rejected"
        return f"seed {self.seed}: " + ", ".join(parts) + "; " + tail


# ---------------------------------------------------------------------------
# The plan: the categories of a ground
# ---------------------------------------------------------------------------
_PLAN_KEYS = ("coords", "area", "size", "n_faults", "pair", "n_layers", "sections",
              "trace_format", "rounding", "kinds", "dips", "extents", "boundary_ends",
              "n_holes", "topography")


def _choice(rng: np.random.Generator, values: Sequence, p: Sequence[float]):
    p = np.asarray(p, dtype=np.float64)
    return values[int(rng.choice(len(values), p=p / p.sum()))]


def draw_plan(rng: np.random.Generator, **overrides) -> Dict[str, Any]:
    """The categories of a ground (what :data:`KINDS` lists, plus sizes and
    rounding), drawn from ``rng``; ``overrides`` replace drawn values (the
    draws still happen, so other values do not change). Keys: coords, area,
    size (m), n_faults, pair, n_layers, sections ("grid" is a wish: faults
    whose strikes do not allow one grid get a family each), trace_format,
    rounding (dict: boundary, traces, holes, z -> decimals or None), kinds,
    dips, extents, boundary_ends (lists, one item per fault), n_holes,
    topography."""
    bad = sorted(set(overrides) - set(_PLAN_KEYS))
    if bad:
        raise ValueError(f"random_ground: unknown override(s) {bad}; known: {list(_PLAN_KEYS)}")
    p: Dict[str, Any] = {}
    p["coords"] = _choice(rng, KINDS["coords"], [0.45, 0.4, 0.15])
    p["area"] = _choice(rng, KINDS["area"], [0.2, 0.25, 0.15, 0.15, 0.25])
    p["n_faults"] = int(_choice(rng, [1, 2, 3, 4], [0.3, 0.35, 0.2, 0.15]))
    pair = _choice(rng, KINDS["pair"], [0.4, 0.25, 0.2, 0.15])
    p["n_layers"] = int(rng.integers(1, 7))
    p["sections"] = _choice(rng, KINDS["sections"], [0.35, 0.65])
    p["trace_format"] = _choice(rng, KINDS["trace_format"], [0.75, 0.25])
    rb = _choice(rng, [None, 2, 3, 4], [0.2, 0.3, 0.3, 0.2])
    rt = _choice(rng, list(_DECIMALS), [0.3, 0.35, 0.35])
    p["rounding"] = {"boundary": rb, "traces": rt,
                     "holes": _choice(rng, [2, 3], [0.6, 0.4]),
                     "z": _choice(rng, [2, 3], [0.6, 0.4])}
    kinds, dips, extents, ends = [], [], [], []
    for _ in range(4):
        if rng.random() < 0.55:
            kinds.append("reverse")
            dips.append(float(rng.uniform(30.0, 45.0) if rng.random() < 0.6 else rng.uniform(45.0, 80.0)))
        else:
            kinds.append("normal")
            dips.append(float(rng.uniform(35.0, 85.0)))
        extents.append(_choice(rng, KINDS["extent"], [0.4, 0.35, 0.25]))
        ends.append(_choice(rng, KINDS["boundary_end"], [0.5, 0.5]))
    p["kinds"], p["dips"], p["extents"], p["boundary_ends"] = kinds, dips, extents, ends
    p["n_holes"] = int(round(math.exp(rng.uniform(math.log(15.0), math.log(250.0)))))
    p["topography"] = bool(rng.random() < 0.25)
    size_u = float(rng.random())
    p.update(overrides)
    n = int(p["n_faults"])
    if not 1 <= n <= 4:
        raise ValueError(f"random_ground: n_faults must be 1..4, got {n}")
    if "pair" not in overrides:
        pair = pair if n >= 2 else "none"
    else:
        pair = overrides["pair"]
    if pair not in KINDS["pair"]:
        raise ValueError(f"random_ground: pair must be one of {KINDS['pair']}, got {pair!r}")
    if pair != "none" and n < 2:
        raise ValueError(f"random_ground: pair {pair!r} needs n_faults >= 2")
    p["pair"] = pair
    for key in ("kinds", "dips", "extents", "boundary_ends"):
        v = list(p[key])
        if len(v) < n:
            raise ValueError(f"random_ground: {key} needs {n} items, got {len(v)}")
        p[key] = v[:n]
    for k in p["kinds"]:
        if k not in ("normal", "reverse"):
            raise ValueError(f"random_ground: kinds must be 'normal' or 'reverse', got {k!r}")
    for d in p["dips"]:
        if not 30.0 <= float(d) <= 85.0:
            raise ValueError(f"random_ground: dips must be in [30, 85] degrees, got {d}")
    for key, allowed in (("coords", KINDS["coords"]), ("area", KINDS["area"]),
                         ("sections", KINDS["sections"]), ("trace_format", KINDS["trace_format"])):
        if p[key] not in allowed:
            raise ValueError(f"random_ground: {key} must be one of {allowed}, got {p[key]!r}")
    for e in p["extents"]:
        if e not in KINDS["extent"]:
            raise ValueError(f"random_ground: extents must be in {KINDS['extent']}, got {e!r}")
    if not 1 <= int(p["n_layers"]) <= 6:
        raise ValueError(f"random_ground: n_layers must be 1..6, got {p['n_layers']}")
    # Room for the faults: a larger area for more (independent) faults.
    lo = {1: 1500.0, 2: 2200.0, 3: 3200.0, 4: 4200.0}[n]
    if p["area"] in ("L", "U"):
        lo = min(6000.0, lo + 500.0)  # a notch takes room the faults need
    if "size" not in overrides:
        p["size"] = lo + size_u * (6000.0 - lo)
    if not 1500.0 <= float(p["size"]) <= 6000.0:
        raise ValueError(f"random_ground: size must be in [1500, 6000] m, got {p['size']}")
    return p


# ---------------------------------------------------------------------------
# Study area and coordinates
# ---------------------------------------------------------------------------
def _rotate(P: np.ndarray, angle_deg: float, centre: np.ndarray) -> np.ndarray:
    a = np.deg2rad(angle_deg)
    R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    return (P - centre) @ R.T + centre


def _ccw(ring: np.ndarray) -> np.ndarray:
    x, y = ring[:, 0] - ring[0, 0], ring[:, 1] - ring[0, 1]
    a = np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)
    return ring if a > 0 else ring[::-1].copy()


def _area_ring(rng: np.random.Generator, shape: str, size: float) -> np.ndarray:
    """A simple counter-clockwise polygon (local coordinates, lower-left
    corner of its box at about (0, 0)) whose box's longer side is ``size``."""
    W = size
    H = size * float(rng.uniform(0.55, 1.0))
    if rng.random() < 0.5:
        W, H = H, W
    if shape == "rectangle":
        ring = np.array([[0, 0], [W, 0], [W, H], [0, H]], dtype=np.float64)
    elif shape == "rotated_rectangle":
        ring = np.array([[0, 0], [W, 0], [W, H], [0, H]], dtype=np.float64)
        ring = _rotate(ring, float(rng.uniform(8.0, 82.0)), np.array([W / 2, H / 2]))
    elif shape == "L":
        a, b = rng.uniform(0.35, 0.6, size=2)
        ring = np.array([[0, 0], [W, 0], [W, (1 - b) * H], [(1 - a) * W, (1 - b) * H],
                         [(1 - a) * W, H], [0, H]], dtype=np.float64)
        # Which corner is cut away, and sometimes not axis-parallel.
        ring = _rotate(ring, 90.0 * int(rng.integers(0, 4)), np.array([W / 2, H / 2]))
        if rng.random() < 0.5:
            ring = _rotate(ring, float(rng.uniform(5.0, 85.0)), ring.mean(axis=0))
    elif shape == "U":
        c = float(rng.uniform(0.25, 0.45))
        d = float(rng.uniform(0.35, 0.6))
        x0 = float(rng.uniform(0.2, 0.8 - c))
        ring = np.array([[0, 0], [W, 0], [W, H], [(x0 + c) * W, H], [(x0 + c) * W, (1 - d) * H],
                         [x0 * W, (1 - d) * H], [x0 * W, H], [0, H]], dtype=np.float64)
        ring = _rotate(ring, 90.0 * int(rng.integers(0, 4)), np.array([W / 2, H / 2]))
        if rng.random() < 0.5:
            ring = _rotate(ring, float(rng.uniform(5.0, 85.0)), ring.mean(axis=0))
    elif shape == "polygon":
        n = int(rng.integers(5, 13))
        while True:  # star-shaped around the centre: simple by construction
            ang = np.sort(rng.uniform(0.0, 2 * np.pi, n))
            gaps = np.diff(np.r_[ang, ang[0] + 2 * np.pi])
            if gaps.min() > 2 * np.pi / (3 * n) and gaps.max() < 0.8 * np.pi:
                break
        r = rng.uniform(0.6, 1.0, n)
        ring = np.column_stack([np.cos(ang) * r, np.sin(ang) * r]) * np.array([W / 2, H / 2])
        ring = _rotate(ring, float(rng.uniform(0.0, 180.0)), np.zeros(2))
    else:  # pragma: no cover - checked in draw_plan
        raise ValueError(shape)
    ring = ring - ring.min(axis=0)
    ext = float((ring.max(axis=0) - ring.min(axis=0)).max())
    return _ccw(ring * (size / ext))


def _origin(rng: np.random.Generator, coords: str) -> np.ndarray:
    if coords == "local":
        if rng.random() < 0.5:
            return np.zeros(2)
        return np.round(rng.uniform(-800.0, 800.0, 2), 0)
    if coords == "utm":
        return np.round(np.array([rng.uniform(2.5e5, 7.5e5), rng.uniform(6.3e6, 7.9e6)]),
                        int(rng.integers(0, 3)))
    k = int(rng.integers(0, 3))
    if k == 0:  # Gauss-Krueger (zone digit in front of the easting)
        return np.round(np.array([rng.uniform(3.4e6, 4.6e6), rng.uniform(5.2e6, 6.1e6)]), 1)
    if k == 1:  # Chinese 3-degree zones: zone number in front (x ~ 3.9e7)
        return np.round(np.array([rng.uniform(3.84e7, 3.86e7), rng.uniform(3.0e6, 4.4e6)]), 0)
    return np.round(np.array([rng.uniform(-9e5, -2e5), rng.uniform(-3.5e6, -1e6)]), 0)


def _runs(p0: np.ndarray, d: np.ndarray, ring: np.ndarray) -> np.ndarray:
    """Sorted parameters t where the line p0 + t d crosses the ring's sides
    (a vertex on the line counts once per side it ends)."""
    a = ring
    b = np.roll(ring, -1, axis=0)
    e = b - a
    den = d[0] * e[:, 1] - d[1] * e[:, 0]
    r = a - p0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (r[:, 0] * e[:, 1] - r[:, 1] * e[:, 0]) / den
        s = (r[:, 0] * d[1] - r[:, 1] * d[0]) / den
    ok = (np.abs(den) > 1e-12) & (s >= 0) & (s < 1)
    return np.sort(t[ok])


def _single_run(p0: np.ndarray, d: np.ndarray, ring: np.ndarray) -> Optional[Tuple[float, float]]:
    """The one interval of the line inside the area, or None if it has none
    or several (a concave area it leaves and re-enters)."""
    t = _runs(p0, d, ring)
    if len(t) != 2:
        return None
    return float(t[0]), float(t[1])


# ---------------------------------------------------------------------------
# Layers
# ---------------------------------------------------------------------------
def _layer_stack(rng: np.random.Generator, n: int, size: float):
    """Names, surfaces (local coordinates, each with ``max_slope``) of ``n``
    layers: a folded top and intervals that are thin (2.5-8 m), medium
    (12-60 m) or thick (80-300 m; the whole stack at most ~700 m)."""
    def wave(amp):
        wl = float(rng.uniform(0.4, 1.5)) * size
        az = float(rng.uniform(0.0, np.pi))
        k = 2 * np.pi / wl
        return (amp, k * np.sin(az), k * np.cos(az), float(rng.uniform(0.0, 2 * np.pi)))

    g = float(rng.uniform(0.0, 0.05))
    ga = float(rng.uniform(0.0, 2 * np.pi))
    bumps = [(float(rng.choice([-1.0, 1.0]) * rng.uniform(5.0, 30.0)), float(rng.uniform(0, size)),
              float(rng.uniform(0, size)), float(rng.uniform(0.1, 0.3) * size))
             for _ in range(int(rng.integers(0, 3)))]
    top = smooth_field(base=float(rng.uniform(-300.0, 150.0)), gradient=(g * np.cos(ga), g * np.sin(ga)),
                       waves=[wave(float(rng.uniform(1.0, 20.0))), wave(float(rng.uniform(0.5, 8.0)))],
                       bumps=bumps)
    kinds = [_choice(rng, ["thin", "medium", "thick"], [0.25, 0.5, 0.25]) for _ in range(n - 1)]
    base = np.array([rng.uniform(2.5, 8.0) if k == "thin" else rng.uniform(12.0, 60.0) if k == "medium"
                     else rng.uniform(80.0, 300.0) for k in kinds])
    if base.sum() > 700.0:
        thick = np.array([k == "thick" for k in kinds])
        excess = base.sum() - 700.0
        base[thick] = np.maximum(80.0, base[thick] - excess * base[thick] / base[thick].sum())
    thick_f = []
    for b in base:
        # Waves of at most 35 % and a thinning bump of at most 40 % of the
        # mean: every interval stays at least a quarter of its mean thick.
        bump = [(-float(rng.uniform(0.0, 0.4)) * b, float(rng.uniform(0, size)), float(rng.uniform(0, size)),
                 float(rng.uniform(0.1, 0.3) * size))] if rng.random() < 0.4 else []
        thick_f.append(smooth_field(base=float(b), waves=[wave(float(rng.uniform(0.0, 0.35)) * b)], bumps=bump))
    names = [f"L{i + 1}" for i in range(n)]
    return names, layer_stack(names, top, thick_f)


# ---------------------------------------------------------------------------
# Faults
# ---------------------------------------------------------------------------
@dataclass
class _Placed:
    """A fault model with what the placement computed about it."""

    model: FaultModel
    extent: str
    ends: List[str]
    d_lo: float            # footprint across strike (d), data and zone
    d_hi: float
    u_lo: float            # footprint along strike (inside the area's reach)
    u_hi: float
    block: List[str]
    boundary_style: str


def _cutoff_d(surf, anchor, sdir, ndir, bend_fn, z_ref, tan_dip, us) -> np.ndarray:
    """Distance d (into the hanging wall) from the reference trace at which
    the unfaulted layer ``surf`` meets the fault surface, per u (fixed-point
    iteration; converges because layer slopes are well below tan(dip))."""
    d = np.zeros_like(us)
    c = bend_fn(us)
    for _ in range(5):
        p = anchor[None, :] + us[:, None] * sdir[None, :] + (c + d)[:, None] * ndir[None, :]
        d = (z_ref - surf(p[:, 0], p[:, 1])) / tan_dip
    return d


def _make_fault(name: str, kind: str, dip: float, strike: float, anchor: np.ndarray,
                u_range: Tuple[float, float], block: List[str], surfaces, throw: float,
                bend: float, decay: float, tips: Tuple[str, ...], z_ref: Optional[float] = None,
                group: Optional[str] = None, abuts: Optional[Tuple[str, str]] = None,
                factors: Optional[Dict[str, float]] = None, u_eval: Optional[Tuple[float, float]] = None):
    """A FaultModel whose flat part reaches past every cutoff of its block,
    and its footprint across strike (d_lo, d_hi): from the highest possible
    cutoff minus the heave and the data reach (170 m) to the end of the zone."""
    tan_d = math.tan(math.radians(dip))
    a = math.radians(strike)
    sdir = np.array([math.sin(a), math.cos(a)])
    ndir = np.array([math.cos(a), -math.sin(a)])
    if z_ref is None:
        z_ref = float(np.mean([surfaces[l](anchor[0:1], anchor[1:2])[0] for l in block]))
    um = 0.5 * (u_range[0] + u_range[1])
    hl = 0.5 * (u_range[1] - u_range[0])

    def bend_fn(u):
        return bend * ((u - um) / hl) ** 2

    lo_u, hi_u = u_eval if u_eval is not None else u_range
    # 25 samples along strike: the layers' folds are 0.4 x the area or longer
    # (the 20 m added to flat covers what falls between samples).
    us = np.linspace(lo_u, hi_u, 25)
    ds = np.concatenate([_cutoff_d(surfaces[l], anchor, sdir, ndir, bend_fn, z_ref, tan_d, us)
                         for l in block])
    fmax = max((factors or {l: 1.0 for l in block}).values())
    heave = throw * fmax / tan_d
    flat = float(ds.max()) + heave + 20.0
    model = FaultModel(name, kind, anchor=anchor, strike=strike, dip=dip, throw=throw,
                       u_range=u_range, z_ref=z_ref,
                       layers=dict(factors) if factors else {l: 1.0 for l in block},
                       bend=bend, flat=flat, decay=decay, abuts=abuts, group=group, tips=tips)
    return model, float(ds.min()) - heave - 170.0, flat + decay


def _footprint_ok_inside(fm: FaultModel, d_lo, d_hi, u_lo, u_hi, ring_local, step=40.0) -> bool:
    """The footprint {u in [u_lo, u_hi], d in [d_lo, d_hi]} lies inside the area."""
    nu = max(2, int(math.ceil((u_hi - u_lo) / step)) + 1)
    nd = max(2, int(math.ceil((d_hi - d_lo) / step)) + 1)
    uu = np.linspace(u_lo, u_hi, nu)
    dd = np.linspace(d_lo, d_hi, nd)
    U = np.concatenate([uu, uu, np.full(nd, u_lo), np.full(nd, u_hi)])
    Dd = np.concatenate([np.full(nu, d_lo), np.full(nu, d_hi), dd, dd])
    P = fm.xy(U, Dd + fm.bend_offset(U))
    return bool(_fast_inside(P, ring_local).all())


def _footprint_mask(fm: FaultModel, d_lo, d_hi, GX, GY, margin: float) -> np.ndarray:
    u, w = fm.uw(GX, GY)
    d = w - fm.bend_offset(u)
    return ((u >= fm.u_range[0] - margin) & (u <= fm.u_range[1] + margin)
            & (d >= d_lo - margin) & (d <= d_hi + margin))


class _Retry(Exception):
    """A geometric draw that does not fit; draw again."""


def _fast_inside(P: np.ndarray, ring: np.ndarray) -> np.ndarray:
    """Crossing-number point-in-polygon test in floating point: for drawing
    positions only (what is written is checked with the exact test)."""
    P = np.asarray(P, dtype=np.float64).reshape(-1, 2)
    a = ring
    b = np.roll(ring, -1, axis=0)
    px, py = P[:, 0:1], P[:, 1:2]
    cond = (a[None, :, 1] > py) != (b[None, :, 1] > py)
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = a[None, :, 0] + (py - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (b[None, :, 1] - a[None, :, 1])
    return (np.sum(cond & (px < xs), axis=1) % 2) == 1


def _inside_point(rng: np.random.Generator, ring: np.ndarray, shrink: float = 1.0) -> np.ndarray:
    """A uniform random point of the area shrunk towards its centroid by
    ``shrink``."""
    c = ring.mean(axis=0)
    R = c + shrink * (ring - c)
    lo, hi = R.min(axis=0), R.max(axis=0)
    for _ in range(100):
        P = rng.uniform(lo, hi, size=(32, 2))
        ok = P[_fast_inside(P, R)]
        if len(ok):
            return ok[0]
    raise _Retry("no point inside")  # pragma: no cover


class _Placer:
    """Places the faults of a plan one by one (local coordinates)."""

    def __init__(self, rng, plan, ring, names, surfaces, size):
        self.rng = rng
        self.plan = plan
        self.ring = ring
        self.names = names
        self.surfaces = surfaces
        self.size = size
        h = size / 150.0
        lo = ring.min(axis=0) - 300.0
        hi = ring.max(axis=0) + 300.0
        self.GX, self.GY = np.meshgrid(np.arange(lo[0], hi[0], h), np.arange(lo[1], hi[1], h))
        inside = _fast_inside(np.column_stack([self.GX.ravel(), self.GY.ravel()]), ring)
        gi = self.GX.ravel()[inside], self.GY.ravel()[inside]
        z = np.array([surfaces[n](*gi) for n in names])
        # Thinnest interval between consecutive layers over the area.
        self.min_thick = [float(np.min(z[i] - z[i + 1])) for i in range(len(names) - 1)]
        c = ring.mean(axis=0)
        # Grid points of the area shrunk to 80 % about its centroid (anchors).
        self.core = _fast_inside(np.column_stack([self.GX.ravel(), self.GY.ravel()]),
                                 c + 0.8 * (ring - c)).reshape(self.GX.shape)
        self.taken = np.zeros(self.GX.shape, dtype=bool)  # independent faults' footprints
        self.slope = max(surfaces[n].max_slope for n in names)
        self.relax = 0  # raised after failed attempts: narrower zones
        self.attempt = 0
        self.strikes: List[float] = []  # of the faults placed so far
        self.trend = float(rng.uniform(0.0, 180.0))  # of the region's fault set

    def throw_decay(self) -> Tuple[float, float]:
        """A throw (m) and a decay length (m); smaller ones (narrower zones)
        after many failed placements."""
        t_hi = (50.0, 35.0, 20.0, 12.0)[min(self.relax, 3)]
        d_hi = (350.0, 250.0, 180.0, 130.0)[min(self.relax, 3)]
        return float(self.rng.uniform(5.0, t_hi)), float(self.rng.uniform(100.0, d_hi))

    # -- pieces ------------------------------------------------------------
    def block(self, dip: float, kind: str, throw: float, whole: bool) -> Tuple[List[str], float]:
        """Displaced layers (a contiguous block) and the throw: the block's
        thickness fits the area at this dip; a layer just outside the block
        is far enough from it that the throw cannot make them cross."""
        n = len(self.names)
        if whole:
            return list(self.names), throw
        rng = self.rng
        k1 = int(rng.integers(0, n))
        k2 = n - 1 if rng.random() < 0.75 else int(rng.integers(k1, n))
        if self.relax >= 2:
            k2 = k1
        budget = math.tan(math.radians(dip)) * (0.15 if self.relax == 0 else 0.08) * self.size
        c = self.ring.mean(axis=0)
        z = [float(self.surfaces[l](c[0:1], c[1:2])[0]) for l in self.names]
        while k2 > k1 and z[k1] - z[k2] > budget:
            if rng.random() < 0.5:
                k1 += 1
            else:
                k2 -= 1
        # The margin allows for the heave along which the block slides (the
        # layers' slope times it) plus 10 m; computed with the drawn throw,
        # which only gets smaller here.
        heave = throw / math.tan(math.radians(dip))
        margin = 10.0 + self.slope * heave
        if kind == "reverse":
            while k1 > 0 and self.min_thick[k1 - 1] < throw + margin:
                if self.min_thick[k1 - 1] - margin >= 6.0:
                    throw = self.min_thick[k1 - 1] - margin
                    break
                k1 -= 1  # the layer above moves with the block
        else:
            while k2 < n - 1 and self.min_thick[k2] < throw + margin:
                if self.min_thick[k2] - margin >= 6.0:
                    throw = self.min_thick[k2] - margin
                    break
                k2 += 1  # the layer below moves with the block
        return self.names[k1:k2 + 1], throw

    def runs(self, anchor, strike, d_lo, d_hi):
        """In-area intervals along strike of the footprint's edge lines and
        middle line (all must be single intervals): (A_in, B_in) where the
        whole band is inside, (A_out, B_out) where any of it is."""
        a = math.radians(strike)
        sdir = np.array([math.sin(a), math.cos(a)])
        ndir = np.array([math.cos(a), -math.sin(a)])
        rs = []
        for d in (d_lo, 0.5 * (d_lo + d_hi), d_hi, 0.0):
            r = _single_run(anchor + d * ndir, sdir, self.ring)
            if r is None:
                raise _Retry("band leaves and re-enters the area")
            rs.append(r)
        return (max(r[0] for r in rs), min(r[1] for r in rs)), (min(r[0] for r in rs), max(r[1] for r in rs))

    def free(self, fm, d_lo, d_hi, ignore: Sequence[np.ndarray] = ()) -> bool:
        """The footprint (plus 100 m) is clear of the independent faults'."""
        m = _footprint_mask(fm, d_lo, d_hi, self.GX, self.GY, 100.0)
        return not np.any(m & self.taken)

    def take(self, fm, d_lo, d_hi) -> None:
        from scipy.ndimage import distance_transform_edt
        self.taken |= _footprint_mask(fm, d_lo, d_hi, self.GX, self.GY, 100.0)
        # Distance (in cells) of every grid point from the taken footprints.
        self.clear = distance_transform_edt(~self.taken)

    # -- one fault -----------------------------------------------------------
    def place(self, name, kind, dip, extent, style, whole=False, strike=None, anchor=None,
              group=None, u_fix=None):
        """A fault of ``extent`` through ``anchor`` (random if None) along
        ``strike`` (random if None). u_fix: (lo, hi) of u that the in-area part
        must contain (an X-crossing point at u = 0)."""
        rng = self.rng
        if strike is None:
            # Faults of a region often share a trend (a fault set); most
            # independent faults strike within 20 degrees of it, either dip
            # direction. Faults that span the area cross each other unless
            # they are about parallel: after failed attempts, draw near an
            # existing fault's strike.
            if rng.random() < 0.7:
                strike = (self.trend + float(rng.uniform(-20.0, 20.0)) + float(rng.choice([0.0, 180.0]))) % 360.0
            else:
                strike = float(rng.uniform(0.0, 360.0))
            if self.strikes and rng.random() < min(0.9, self.attempt / 25.0):
                strike = (float(rng.choice(self.strikes)) + float(rng.uniform(-25.0, 25.0))
                          + float(rng.choice([0.0, 180.0]))) % 360.0
        if anchor is None:
            if self.taken.any():
                # Anchors in the larger free spaces: at least half the largest
                # distance from the faults placed so far.
                free = self.core & (self.clear >= 0.5 * self.clear[self.core].max()) & (self.clear > 0)
                cand = np.column_stack([self.GX[free], self.GY[free]])
                if len(cand) == 0:
                    raise _Retry("no free point")
                anchor = cand[int(rng.integers(0, len(cand)))] + rng.uniform(-1.0, 1.0, 2)
            else:
                anchor = _inside_point(rng, self.ring, 0.8)
        throw, decay = self.throw_decay()
        block, throw = self.block(dip, kind, throw, whole)
        bend = float(rng.uniform(-1.0, 1.0)) * min(60.0, 0.03 * self.size)
        # A first footprint from the reference line's run, then the real one.
        a = math.radians(strike)
        sdir = np.array([math.sin(a), math.cos(a)])
        r0 = _single_run(anchor, sdir, self.ring)
        if r0 is None:
            raise _Retry("fault line leaves and re-enters the area")
        fm0, d_lo, d_hi = _make_fault(name, kind, dip, strike, anchor, (r0[0] - 10.0, r0[1] + 10.0),
                                      block, self.surfaces, throw, 0.0, decay, ())
        if extent == "crossing" and group is None and not self.free(fm0, d_lo, d_hi):
            # Across the whole area it already meets an independent fault.
            raise _Retry("meets another fault")
        (A_in, B_in), (A_out, B_out) = self.runs(anchor, strike, d_lo, d_hi)
        m = 100.0
        # Along strike, where the band meets an independent fault already
        # placed (cells of its footprint, padded by 250 m: the masks' 100 m
        # margin, a grid cell and the bend): a tip end stays clear of them.
        blocked = np.zeros(0)
        if group is None and self.taken.any():
            mk = _footprint_mask(fm0, d_lo, d_hi, self.GX, self.GY, 100.0) & self.taken
            blocked = np.sort(fm0.uw(self.GX[mk], self.GY[mk])[0])
        if extent == "inside":
            # The free stretch (of [A_in + m, B_in - m]) the fault goes in.
            cuts = np.concatenate([[A_in + m - 250.0], blocked, [B_in - m + 250.0]])
            gaps = [(a + 250.0, b - 250.0) for a, b in zip(cuts[:-1], cuts[1:]) if b - a - 500.0 >= 700.0]
            if not gaps:
                raise _Retry("meets another fault" if len(blocked) else "no room for an inside fault")
            A_in, B_in = gaps[int(rng.integers(0, len(gaps)))]
            A_in, B_in = A_in - m, B_in + m
            room = B_in - A_in - 2 * m
            L = float(rng.uniform(700.0, min(room, 0.9 * self.size)))
            lo1, hi1 = A_in + m, B_in - m - L
            if u_fix is not None:  # the crossing point 300 m inside both ends
                lo1, hi1 = max(lo1, u_fix[1] + 300.0 - L), min(hi1, u_fix[0] - 300.0)
                if hi1 < lo1:
                    raise _Retry("crossing point not inside the fault")
            u1 = float(rng.uniform(lo1, hi1))
            u_range = (u1, u1 + L)
            tips = ("start", "end")
        elif extent == "crossing":
            span = B_out - A_out
            if span < 600.0:
                raise _Retry("too short a crossing")
            u_range = (A_out - float(rng.uniform(0.15, 0.6)) * span,
                       B_out + float(rng.uniform(0.15, 0.6)) * span)
            tips = ()
        else:  # one_end
            if B_in - A_in - 2 * m < 600.0:
                raise _Retry("no room for a tip")
            span = B_out - A_out
            start = rng.random() < 0.5
            if u_fix is not None:  # the crossing point 300 m inside the tip end
                start = u_fix[0] - 300.0 >= A_in + m
            # The tip end between what the band meets and the boundary the
            # other end runs through (if the band meets an independent fault).
            lo_tip, hi_tip = A_in + m, B_in - m
            if len(blocked):
                if blocked[-1] + 250.0 <= B_in - m - 600.0:
                    start, lo_tip = True, max(lo_tip, blocked[-1] + 250.0)
                elif blocked[0] - 250.0 >= A_in + m + 600.0:
                    start, hi_tip = False, min(hi_tip, blocked[0] - 250.0)
                else:
                    raise _Retry("meets another fault")
            if start:
                hi1 = hi_tip - 600.0 if u_fix is None else min(hi_tip - 600.0, u_fix[0] - 300.0)
                u1 = float(rng.uniform(lo_tip, hi1)) if hi1 > lo_tip else lo_tip
                u_range = (u1, B_out + float(rng.uniform(0.15, 0.6)) * span)
                tips = ("start",)
            else:
                lo2 = lo_tip + 600.0 if u_fix is None else max(lo_tip + 600.0, u_fix[1] + 300.0)
                u2 = float(rng.uniform(lo2, hi_tip)) if hi_tip > lo2 else hi_tip
                u_range = (A_out - float(rng.uniform(0.15, 0.6)) * span, u2)
                tips = ("end",)
        if u_fix is not None and not (u_range[0] + 300.0 <= u_fix[0] and u_fix[1] <= u_range[1] - 300.0):
            raise _Retry("crossing point not inside the fault")
        u_eval = (max(u_range[0], A_out), min(u_range[1], B_out))
        fm, d_lo, d_hi = _make_fault(name, kind, dip, strike, anchor, u_range, block, self.surfaces,
                                     throw, bend, decay, tips, group=group, u_eval=u_eval)
        if extent == "inside" and not _footprint_ok_inside(fm, d_lo, d_hi, u_range[0] - 50.0,
                                                           u_range[1] + 50.0, self.ring):
            raise _Retry("inside fault's footprint leaves the area")
        if extent == "one_end":
            u_t = u_range[0] if tips == ("start",) else u_range[1]
            if not _footprint_ok_inside(fm, d_lo, d_hi, u_t - 50.0, u_t + 300.0, self.ring) or \
                    not _footprint_ok_inside(fm, d_lo, d_hi, u_t - 300.0, u_t + 50.0, self.ring):
                raise _Retry("tip end's footprint leaves the area")
        ends = {"inside": ["tip", "tip"], "crossing": [style, style],
                "one_end": ["tip", style] if tips == ("start",) else [style, "tip"]}[extent]
        return _Placed(fm, extent, ends, d_lo, d_hi, u_eval[0], u_eval[1], block, style)

    # -- pairs ---------------------------------------------------------------
    def on_trace(self, p: _Placed) -> Tuple[float, np.ndarray]:
        """A point on the in-area part of p's reference trace, away from its
        ends and where its throw is at least half the maximum: (u, local XY)."""
        fm = p.model
        lo = max(p.u_lo + 300.0, fm.um - 0.7 * fm.hl)
        hi = min(p.u_hi - 300.0, fm.um + 0.7 * fm.hl)
        if hi <= lo:
            raise _Retry("no room on the older fault")
        u = float(self.rng.uniform(lo, hi))
        return u, fm.xy([u], fm.bend_offset([u]))[0]

    def place_T(self, A: _Placed, name, kind, dip, extent, style, group) -> _Placed:
        """A younger fault abutting A at a point of A's trace, its body on one
        side of A (``abuts = (A, side)``), its far end a tip inside or on the
        boundary."""
        rng = self.rng
        fa = A.model
        _, J = self.on_trace(A)
        side = "foot" if rng.random() < 0.5 else "hanging"
        strike = (fa.strike + float(rng.choice([-1.0, 1.0])) * float(rng.uniform(40.0, 90.0))) % 360.0
        a = math.radians(strike)
        sdir = np.array([math.sin(a), math.cos(a)])
        # The body (u < 0) must lie on `side` of A: -sdir points to A's
        # footwall (-ndir_A) for "foot".
        if (float(np.dot(sdir, fa.ndir)) > 0) != (side == "foot"):
            strike = (strike + 180.0) % 360.0
            sdir = -sdir
        throw, decay = self.throw_decay()
        bend = float(rng.uniform(-1.0, 1.0)) * min(40.0, 0.02 * self.size)
        e = float(rng.uniform(150.0, 400.0))
        r0 = _single_run(J, sdir, self.ring)
        if r0 is None or -r0[0] < 700.0:
            raise _Retry("no room for the abutting fault")
        _, d_lo, d_hi = _make_fault(name, kind, dip, strike, J, (r0[0], e), A.block, self.surfaces,
                                    throw, 0.0, decay, (), z_ref=fa.z_ref)
        (A_in, _), (A_out, _) = self.runs(J, strike, d_lo, d_hi)
        if extent == "inside":
            reach = -A_in - 100.0
            if reach < 700.0:
                raise _Retry("no room for the abutting fault's tip")
            Lb = float(rng.uniform(700.0, min(reach, 0.9 * self.size)))
            tips = ("start",)
            ext, ends = "inside", ["tip", "abuts"]
        else:
            Lb = -A_out + float(rng.uniform(0.2, 0.6)) * (-A_out)
            tips = ()
            ext, ends = "one_end", [style, "abuts"]
        u_range = (-Lb, e)
        u_eval = (max(-Lb, A_out), 0.0)
        fm, d_lo, d_hi = _make_fault(name, kind, dip, strike, J, u_range, A.block, self.surfaces, throw,
                                     bend, decay, tips, z_ref=fa.z_ref, group=group,
                                     abuts=(fa.name, side), u_eval=u_eval)
        if ext == "inside" and not _footprint_ok_inside(fm, d_lo, d_hi, -Lb - 50.0, -Lb + 300.0, self.ring):
            raise _Retry("abutting fault's tip leaves the area")
        if not self.free(fm, d_lo, d_hi):
            raise _Retry("abutting fault meets another fault")
        return _Placed(fm, ext, ends, d_lo, d_hi, u_eval[0], u_eval[1], A.block, style)

    def place_X(self, A: _Placed, name, kind, dip, extent, style, group) -> _Placed:
        """A younger fault crossing A (one group, neither abuts the other)."""
        rng = self.rng
        _, X = self.on_trace(A)
        strike = (A.model.strike + float(rng.choice([-1.0, 1.0])) * float(rng.uniform(35.0, 90.0))) % 360.0
        p = self.place(name, kind, dip, extent, style, whole=True, strike=strike, anchor=X,
                       group=group, u_fix=(0.0, 0.0))
        if not self.free(p.model, p.d_lo, p.d_hi):
            raise _Retry("crossing fault meets another fault")
        return p

    def place_close(self, A: _Placed, name, kind, dip, extent, style) -> _Placed:
        """A fault of another group whose zone overlaps A's: parallel and
        close, or crossing it."""
        rng = self.rng
        fa = A.model
        if rng.random() < 0.7:
            strike = (fa.strike + float(rng.uniform(-12.0, 12.0))) % 360.0
            u, P = self.on_trace(A)
            off = float(rng.choice([-1.0, 1.0])) * float(rng.uniform(0.25, 0.7)) * (A.d_hi - A.d_lo)
            anchor = P + off * fa.ndir
            if not points_in_polygon(anchor[None, :], self.ring)[0]:
                raise _Retry("close fault's anchor outside")
        else:
            _, anchor = self.on_trace(A)
            strike = (fa.strike + float(rng.choice([-1.0, 1.0])) * float(rng.uniform(30.0, 90.0))) % 360.0
        p = self.place(name, kind, dip, extent, style, whole=True, strike=strike, anchor=anchor)
        if not self.free(p.model, p.d_lo, p.d_hi):
            raise _Retry("close fault meets a third fault")
        return p


def _place_faults(rng, plan, ring, names, surfaces, size):
    """All faults of the plan (oldest first) and the pair description. A
    fault that finds no place makes all of them start again (three times),
    then the caller draws a new area and layers."""
    for _ in range(3):
        try:
            return _place_faults_once(rng, plan, ring, names, surfaces, size)
        except _Retry:
            continue
    raise _Retry("could not place the faults")


def _place_faults_once(rng, plan, ring, names, surfaces, size):
    P = _Placer(rng, plan, ring, names, surfaces, size)
    n = plan["n_faults"]
    kinds, dips, extents, styles = plan["kinds"], plan["dips"], plan["extents"], plan["boundary_ends"]
    rel = plan["pair"]
    placed: List[_Placed] = []
    pair = None
    for i in range(n):
        name = f"F{i + 1}"
        for attempt in range(100):
            P.relax = attempt // 25
            P.attempt = attempt
            try:
                if rel != "none" and i == 1:
                    A = placed[0]
                    group = f"{A.model.name}+{name}"
                    if rel == "T":
                        p = P.place_T(A, name, kinds[i], dips[i], extents[i], styles[i], group)
                    elif rel == "X":
                        p = P.place_X(A, name, kinds[i], dips[i], extents[i], styles[i], group)
                    else:
                        p = P.place_close(A, name, kinds[i], dips[i], extents[i], styles[i])
                else:
                    p = P.place(name, kinds[i], dips[i], extents[i], styles[i], whole=(rel != "none" and i == 0))
                    if not P.free(p.model, p.d_lo, p.d_hi):
                        raise _Retry("meets another fault")
                break
            except _Retry:
                continue
        else:
            raise _Retry(f"could not place fault {name}")
        placed.append(p)
        P.strikes.append(p.model.strike)
        if rel != "none" and i == 1:
            if rel in ("T", "X"):
                placed[0].model.group = p.model.group
            pair = {"relation": rel, "faults": [placed[0].model.name, name]}
            P.take(placed[0].model, placed[0].d_lo, placed[0].d_hi)
            P.take(p.model, p.d_lo, p.d_hi)
        elif rel == "none" or i >= 2:
            P.take(p.model, p.d_lo, p.d_hi)
    return placed, pair, P


# ---------------------------------------------------------------------------
# Sections, traces, boreholes
# ---------------------------------------------------------------------------
def _azimuth(d: np.ndarray) -> float:
    """Azimuth (degrees clockwise from north) of direction d; exact 0/90/180/270
    for axis-parallel directions."""
    if d[0] == 0.0:
        return 0.0 if d[1] > 0 else 180.0
    if d[1] == 0.0:
        return 90.0 if d[0] > 0 else 270.0
    return float(np.degrees(np.arctan2(d[0], d[1])) % 360.0)


def _line_sections(prefix: str, az: float, through: np.ndarray, ring_g: np.ndarray,
                   rng: np.random.Generator) -> List[Section]:
    """Sections of azimuth ``az`` through the global points ``through``, each
    starting (origin, surveyed to 1 cm) some metres before it enters the area."""
    a = math.radians(az)
    d = np.array([math.sin(a), math.cos(a)])
    out = []
    for k, p in enumerate(through):
        t = _runs(p, d, ring_g)
        t0 = float(t[0]) if len(t) else 0.0
        origin = np.round(p + (t0 - float(rng.uniform(0.0, 60.0))) * d, 2)
        out.append(Section(f"{prefix}{k + 1}", origin, round(az, 6)))
    return out


def _throw_part(fm: FaultModel, lo: float, hi: float) -> Tuple[float, float]:
    """The part of [lo, hi] (u) where the fault's largest throw is at least
    4 m (sections there get a trace; MIN_TRACE_THROW is 3 m)."""
    from .datasets import MIN_TRACE_THROW
    fmax = fm.throw * max(fm.layers.values())
    x = math.sqrt(max(0.0, 1.0 - (MIN_TRACE_THROW + 1.0) / fmax)) if fmax > MIN_TRACE_THROW + 1.0 else 0.0
    return max(lo, fm.um - x * fm.hl), min(hi, fm.um + x * fm.hl)


def _boundary_section(p: _Placed, end: int, ring_g: np.ndarray, origin: np.ndarray) -> Optional[Section]:
    """A section along the boundary side where fault end ``end`` leaves the
    area, if the whole band of the fault crosses that one side (30 m from its
    corners); None otherwise."""
    fm = p.model
    sdir = fm.sdir if end == 1 else -fm.sdir
    hits = []
    k = len(ring_g)
    u_mid = 0.5 * (p.u_lo + p.u_hi)
    for d in (p.d_lo, 0.0, p.d_hi):
        # The side hit by the ray from the middle of the band's edge (or
        # centre) line along the strike direction: where that line leaves.
        q_in = fm.xy([u_mid], [d + float(fm.bend_offset(u_mid))])[0] + origin
        best = None
        for i in range(k):
            a, b = ring_g[i], ring_g[(i + 1) % k]
            e = b - a
            den = sdir[0] * e[1] - sdir[1] * e[0]
            if abs(den) < 1e-12:
                continue
            r = a - q_in
            t = (r[0] * e[1] - r[1] * e[0]) / den
            s = (r[0] * sdir[1] - r[1] * sdir[0]) / den
            if t > 0 and 0 <= s <= 1 and (best is None or t < best[0]):
                best = (t, i, s * float(np.hypot(*e)), float(np.hypot(*e)))
        if best is None:
            return None
        hits.append(best)
    sides = {h[1] for h in hits}
    if len(sides) != 1:
        return None
    _, i, _, L = hits[0]
    if min(h[2] for h in hits) < 30.0 or max(h[2] for h in hits) > L - 30.0:
        return None
    a, b = ring_g[i], ring_g[(i + 1) % k]
    return Section(f"{fm.name}-edge{end + 1}", a.copy(), _azimuth(b - a))


def _inside_or_on(ring_g: np.ndarray):
    """Inside test that also accepts points within 64 ulps of the largest
    coordinate of a side (points computed on a boundary section)."""
    from ._core import nearest_segment
    from .invariants import on_boundary_tolerance
    tol = on_boundary_tolerance(ring_g)

    def f(xy):
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        ok = points_in_polygon(xy, ring_g)
        if not ok.all():
            out = ~ok
            dist = nearest_segment(xy[out], ring_g, np.roll(ring_g, -1, axis=0))[1]
            ok[np.flatnonzero(out)[dist <= tol]] = True
        return ok

    return f


def _holes(rng, plan, geo: Geology, ring_g: np.ndarray, sections: List[Section],
           placed: List[_Placed]) -> Tuple[List[Tuple[str, float, float, str]], int]:
    """Borehole collars (id, x, y, deepest layer), rounded, and how many were
    placed in reverse-fault overlap bands."""
    from .datasets import _band_point
    names = geo.layers
    n = int(plan["n_holes"])
    x, y = ring_g[:, 0] - ring_g[0, 0], ring_g[:, 1] - ring_g[0, 1]
    area = 0.5 * abs(float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)))
    sp = math.sqrt(area / n)
    lo, hi = ring_g.min(axis=0), ring_g.max(axis=0)
    layout = _choice(rng, ["random", "grid", "sections"], [0.4, 0.3, 0.3])
    pts: List[np.ndarray] = []
    if layout == "grid":
        gx = np.arange(lo[0] + sp / 2, hi[0], sp)
        gy = np.arange(lo[1] + sp / 2, hi[1], sp)
        G = np.array([(a, b) for b in gy for a in gx]).reshape(-1, 2)
        G = G + rng.uniform(-0.3 * sp, 0.3 * sp, size=G.shape)
        pts = list(G[points_in_polygon(G, ring_g)])
    elif layout == "sections" and sections:
        for sec in sections:
            t = _runs(sec.origin, sec.direction, ring_g)
            for a, b in zip(t[0::2], t[1::2]):
                s = np.arange(a + 0.5 * sp * float(rng.random()), b, sp)
                P = sec.to_xy(s) + rng.uniform(-15.0, 15.0, size=(len(s), 1)) * \
                    np.array([sec.direction[1], -sec.direction[0]])
                pts += list(P[points_in_polygon(P, ring_g)])
        pts = pts[:max(n, 3)]
    if len(pts) < n:
        # Random collars at least 0.35 x the mean spacing apart: of every
        # closer pair (candidates in draw order) the later one goes.
        from scipy.spatial import cKDTree
        C = rng.uniform(lo, hi, size=(8 * n, 2))
        C = C[points_in_polygon(C, ring_g)]
        C = np.vstack([np.array(pts).reshape(-1, 2), C])
        pairs = cKDTree(C).query_pairs(0.35 * sp, output_type="ndarray")
        drop = np.zeros(len(C), dtype=bool)
        drop[pairs.max(axis=1)] = True
        drop[:len(pts)] = False
        pts = list(C[~drop][:max(n, len(pts))])
    prefix = str(rng.choice(["BH", "ZK", "DH"]))
    holes = []
    for i, p in enumerate(pts):
        deep = names[-1] if rng.random() < 0.85 else names[int(rng.integers(0, len(names)))]
        holes.append((f"{prefix}{i + 1:03d}", float(p[0]), float(p[1]), deep))
    n_band = 0
    for p in placed:
        fm = p.model
        if fm.kind != "reverse":
            continue
        lo_u, hi_u = _throw_part(fm, p.u_lo, p.u_hi)
        for _ in range(int(rng.integers(0, 4))):
            if hi_u <= lo_u:
                break
            lay = p.block[int(rng.integers(0, len(p.block)))]
            q = _band_point(geo, fm, float(rng.uniform(lo_u, hi_u)), lay)
            if q is not None and points_in_polygon(q[None, :], ring_g)[0]:
                n_band += 1
                holes.append((f"R{n_band}", float(q[0]), float(q[1]), names[-1]))
    # Surveyed collars: rounded; one hole per position.
    dec = int(plan["rounding"]["holes"])
    out, seen = [], set()
    for h, hx, hy, deep in holes:
        key = (round(hx, dec), round(hy, dec))
        if key in seen:
            continue
        seen.add(key)
        out.append((h, key[0], key[1], deep))
    return out, n_band


def _round_trace(t: Trace, dec: int) -> Trace:
    return Trace(t.section, np.round(t.plane, dec),
                 {lay: {k: np.round(v, dec) for k, v in sides.items()} for lay, sides in t.layers.items()})


def _realise(seed: int, plan: Dict[str, Any], rng: np.random.Generator, folder: Path):
    from .dataset import _boundary_problem, _json_dump
    from .datasets import _boreholes, _fault_traces, _tip_xy

    size = float(plan["size"])
    ring_local = _area_ring(rng, plan["area"], size)
    origin = _origin(rng, plan["coords"])
    ring_g = ring_local + origin
    rb = plan["rounding"]["boundary"]
    if rb is not None:
        ring_g = np.round(ring_g, rb)
    if _boundary_problem(ring_g) is not None:  # pragma: no cover - rounding 1e-2 of km sides
        raise _Retry("rounded boundary is not simple")
    ring_local = ring_g - origin
    names, surfaces = _layer_stack(rng, int(plan["n_layers"]), size)
    placed, pair, placer = _place_faults(rng, plan, ring_local, names, surfaces, size)
    geo = Geology(names, surfaces, [p.model for p in placed], origin=origin)

    # Independence as the geology itself sees it (zones of influence on a grid).
    GX, GY = placer.GX + origin[0], placer.GY + origin[1]
    expect = "build"
    if pair is not None and pair["relation"] == "too_close":
        expect = "reject"
        try:
            geo.check_disjoint(GX, GY)
        except ValueError as e:
            if not all(f"'{n}'" in str(e) for n in pair["faults"]):
                raise _Retry("a third fault overlaps") from None
        else:
            raise _Retry("the close pair does not overlap after all")
        gmod = [FaultModel(**{**{k: getattr(p.model, k) for k in (
            "name", "kind", "anchor", "strike", "dip", "throw", "u_range", "z_ref", "layers", "bend",
            "flat", "decay", "abuts", "tips")}, "group": "pair" if p.model.name in pair["faults"] else None})
            for p in placed]
        try:
            Geology(names, surfaces, gmod, origin=origin).check_disjoint(GX, GY)
        except ValueError:
            raise _Retry("a third fault overlaps") from None
    else:
        try:
            geo.check_disjoint(GX, GY)
        except ValueError:
            raise _Retry("zones overlap") from None

    # Sections.
    secs_of: Dict[str, List[Section]] = {p.model.name: [] for p in placed}
    all_secs: List[Section] = []
    sections_kind = plan["sections"]
    spacing: Dict[str, float] = {}
    if sections_kind == "grid":
        alpha = (placed[0].model.strike + 90.0 + float(rng.uniform(-20.0, 20.0))) % 360.0
        ang = [abs(math.sin(math.radians(alpha - p.model.strike))) for p in placed]
        if min(ang) < math.sin(math.radians(45.0)):
            sections_kind = "per_fault"
        else:
            lens = [(lambda a, b: b - a)(*_throw_part(p.model, p.u_lo, p.u_hi)) * s for p, s in zip(placed, ang)]
            sp = float(np.clip(min(lens) / float(rng.uniform(3.5, 7.0)), 100.0, 500.0))
            a = math.radians(alpha)
            nrm = np.array([math.cos(a), -math.sin(a)])
            c = ring_g.mean(axis=0)
            proj = (ring_g - c) @ nrm
            offs = np.arange(proj.min() + float(rng.uniform(0.2, 0.8)) * sp, proj.max(), sp)
            through = c[None, :] + offs[:, None] * nrm[None, :]
            grid = [s for s in _line_sections("E", alpha, through, ring_g, rng)
                    if len(_runs(s.origin, s.direction, ring_g)) >= 2]
            all_secs += grid
            for p in placed:
                secs_of[p.model.name] = list(grid)
                spacing[p.model.name] = sp
    if sections_kind == "per_fault":
        for p in placed:
            fm = p.model
            ua, ub = _throw_part(fm, p.u_lo, p.u_hi)
            n_sec = int(rng.integers(3, 9))
            sp = (ub - ua) / n_sec
            if sp < 100.0:
                n_sec = int((ub - ua) // 100.0)
                if n_sec < 2:
                    raise _Retry(f"fault {fm.name} too short for two sections")
                sp = (ub - ua) / n_sec
            us = ua + (np.arange(n_sec) + 0.5) * sp
            through = fm.xy(us, fm.bend_offset(us)) + origin
            through = through[_fast_inside(through, ring_g)]  # a concave area's notch
            az = (fm.strike + 90.0 + float(rng.uniform(-25.0, 25.0))) % 360.0
            fam = _line_sections(f"{fm.name}-", az, through, ring_g, rng)
            secs_of[fm.name] = fam
            all_secs += fam
            spacing[fm.name] = sp
    edge: Dict[Tuple[str, int], Section] = {}
    for p in placed:
        for e in (0, 1):
            if p.ends[e] == "on_boundary":
                s = _boundary_section(p, e, ring_g, origin)
                if s is None:
                    p.ends[e] = "extended"
                else:
                    edge[(p.model.name, e)] = s

    # Traces.
    far_lo = float(rng.uniform(20.0, 80.0))
    far = (far_lo, far_lo + float(rng.uniform(20.0, 100.0)))
    n_lo = int(rng.integers(3, 6))
    npts = (n_lo, n_lo + int(rng.integers(1, 9)))
    inside = _inside_or_on(ring_g)
    faults: List[Fault] = []
    for p in placed:
        fm = p.model
        own = list(secs_of[fm.name]) + [edge[(fm.name, e)] for e in (0, 1) if (fm.name, e) in edge]
        # A 5 m scan brackets each side's cutoff (each difference changes
        # sign once near the fault); Illinois then refines it to 1e-9 m.
        traces = _fault_traces(geo, fm, own, ring_g, rng, far=far, npts=npts, inside=inside,
                               legacy_draws=False, cut_step=5.0)
        # Near the other fault of a pair both move the layers, and the offset
        # seen across this fault on a section can take the other fault's
        # sense; nobody would draw that trace as this fault's: leave it out.
        sense = 1.0 if fm.kind == "reverse" else -1.0
        traces = [t for t in traces
                  if all(sense * (sd["hanging"][0, 2] - sd["foot"][-1, 2]) > 0 for sd in t.layers.values())]
        for e in (0, 1):
            s = edge.get((fm.name, e))
            if s is None:
                continue
            if not any(t.section == s.name for t in traces):
                p.ends[e] = "extended"
                continue
            all_secs.append(s)
            # Family traces close to (or across) the edge trace would fold the
            # lofted patch: drop them.
            a = s.origin
            b = a + 1e4 * s.direction
            from ._core import nearest_segment
            keep = []
            for t in traces:
                if t.section == s.name:
                    keep.append(t)
                    continue
                P = np.vstack([t.plane[:, :2]] + [v[:, :2] for sd in t.layers.values() for v in sd.values()])
                dist = float(nearest_segment(P, a[None, :], b[None, :])[1].min())
                if dist >= 0.4 * spacing[fm.name]:
                    keep.append(t)
            traces = keep
        if len(traces) < 2:
            raise _Retry(f"fault {fm.name} has {len(traces)} trace(s)")
        tips = []
        for e, end in enumerate(("start", "end")):
            if p.ends[e] == "tip":
                q = _tip_xy(geo, fm, fm.u_range[e], p.block[0])
                if not points_in_polygon(q[None, :], ring_g)[0]:
                    raise _Retry(f"tip of {fm.name} outside")
                tips.append(q)
        faults.append(Fault(fm.name, fm.kind, fm.group, np.array(tips).reshape(-1, 2), traces))

    # Boreholes (tops from the truth at the rounded collars) and topography.
    holes, n_band = _holes(rng, plan, geo, ring_g, [s for s in all_secs if "-edge" not in s.name], placed)
    zdec = int(plan["rounding"]["z"])
    bh = _boreholes(geo, holes)
    for lay in names:
        if np.sum(bh.layer == lay) < 3:
            raise _Retry(f"layer {lay} has fewer than 3 borehole tops")
    bh = Boreholes(bh.hole_id, bh.xy, bh.layer, np.round(bh.z, zdec))
    points = {}
    if plan["topography"]:
        sp = size / 25.0
        lo, hi = ring_g.min(axis=0), ring_g.max(axis=0)
        G = np.array([(a, b) for b in np.arange(lo[1] + sp / 2, hi[1], sp)
                      for a in np.arange(lo[0] + sp / 2, hi[0], sp)])
        G = np.round(G + rng.uniform(-0.3 * sp, 0.3 * sp, size=G.shape), int(plan["rounding"]["holes"]))
        G = G[points_in_polygon(G, ring_g)]
        points[names[0]] = np.column_stack([G, np.round(geo.truth(names[0], G[:, 0], G[:, 1]), zdec)])

    # Write as surveyed: rounded coordinates.
    rt = int(plan["rounding"]["traces"])
    written = [Fault(f.name, f.kind, f.group, np.round(f.tips, rt), [_round_trace(t, rt) for t in f.traces])
               for f in faults]
    crs = {"local": "local grid, metres", "utm": "UTM-like projected grid, metres",
           "offset": "projected grid with a large false origin, metres"}[plan["coords"]]
    ds = Dataset(name=f"ground-{seed}", layers=names, boundary=ring_g, boreholes=bh, points=points,
                 sections={s.name: s for s in all_secs}, faults=written, crs=crs)
    folder = Path(folder)
    path = ds.save(folder)
    if plan["trace_format"] == "sz":
        # Digitised on the section views: [s, z] to the same precision.
        doc = json.loads(path.read_text(encoding="utf-8"))
        for fd, f in zip(doc["faults"], faults):
            for td, t in zip(fd["traces"], f.traces):
                if t.section is None:
                    continue
                sec = ds.sections[t.section]

                def sz(arr):
                    s = sec.to_s(arr[:, :2])
                    return [[float(np.round(a, rt)), float(np.round(b, rt))] for a, b in zip(s, arr[:, 2])]

                td["plane"] = sz(t.plane)
                for lay, sides in t.layers.items():
                    td["layers"][lay] = {k: sz(v) for k, v in sides.items()}
        path.write_text(_json_dump(doc), encoding="utf-8")

    # What was drawn.
    zs = np.array([surfaces[n](placer.GX.ravel(), placer.GY.ravel()) for n in names])
    ins = _fast_inside(np.column_stack([placer.GX.ravel(), placer.GY.ravel()]), ring_local)
    th = [float(np.min(zs[i, ins] - zs[i + 1, ins])) for i in range(len(names) - 1)]
    thk = [float(np.max(zs[i, ins] - zs[i + 1, ins])) for i in range(len(names) - 1)]
    fspecs = []
    for p, f in zip(placed, faults):
        fm = p.model
        fspecs.append({"name": fm.name, "kind": fm.kind, "dip": round(fm.dip, 2),
                       "strike": round(fm.strike, 2), "throw": round(fm.throw, 2), "extent": p.extent,
                       "ends": list(p.ends), "group": fm.group,
                       "abuts": list(fm.abuts) if fm.abuts else None, "layers": list(p.block),
                       "traces": len(f.traces), "tips": int(len(f.tips))})
    spec = GroundSpec(seed=int(seed), coords=plan["coords"], origin=(float(origin[0]), float(origin[1])),
                      area=plan["area"], size=round(size, 1), n_vertices=int(len(ring_g)),
                      layers=list(names), thinnest=round(min(th), 2) if th else 0.0,
                      thickest=round(max(thk), 2) if thk else 0.0, n_holes=int(bh.n_holes),
                      n_band_holes=n_band, topography=bool(points), sections=sections_kind,
                      trace_format=plan["trace_format"],
                      rounding={k: (None if v is None else int(v)) for k, v in plan["rounding"].items()},
                      faults=fspecs, pair=pair, expect=expect)
    (folder / "spec.json").write_text(json.dumps(spec.to_dict(), indent=1) + "\n", encoding="utf-8")
    return spec, geo, path


def make_ground(seed: int, folder, **overrides) -> Tuple[GroundSpec, Geology, Path]:
    """Draw ground ``seed`` and write its dataset (format v1, plus
    ``spec.json``) into ``folder``: (spec, geology, dataset.json path). The
    dataset is not read back here (:func:`random_ground` does)."""
    seed = int(seed)
    rng = np.random.default_rng(seed)
    plan = draw_plan(rng, **overrides)
    why = ""
    for _ in range(40):
        try:
            return _realise(seed, plan, rng, Path(folder))
        except _Retry as e:
            why = str(e)
    raise RuntimeError(f"random_ground: seed {seed}: could not realise {plan} (last: {why})")


def random_ground(seed: int, path=None, version: int = 1, **overrides) -> Dataset:
    """The dataset of ground ``seed``: drawn (see the module docstring),
    written to ``path`` (a folder; a temporary one if None) and read back
    with :func:`faultmesh.load_dataset`. ``dataset.truth`` /
    ``dataset.geology`` are the ground truth, ``dataset.spec`` the
    :class:`GroundSpec`. ``overrides`` (see :func:`draw_plan`) fix parts of
    the draw, e.g. ``random_ground(3, coords="utm", area="L", n_faults=2,
    pair="X")``. Raises the loader's :class:`DatasetError` if it rejects
    what was written. ``version=2``: the same ground as format 2 without
    cutoffs (:func:`write_v2`, into ``path/v2``; the v1 dataset is written
    too, unchanged)."""
    from .dataset import load_dataset
    if version not in (1, 2):
        raise ValueError(f"random_ground: version must be 1 or 2, got {version!r}")
    if path is None:
        with tempfile.TemporaryDirectory(prefix="faultmesh-ground-") as tmp:
            return random_ground(seed, tmp, version, **overrides)
    spec, geo, p = make_ground(seed, path, **overrides)
    ds = load_dataset(p)
    if version == 2:
        ds = load_dataset(write_v2(ds, geo, spec, Path(path) / "v2"))
    ds.truth = geo.truth
    ds.geology = geo
    ds.spec = spec
    return ds


# ---------------------------------------------------------------------------
# Measures
# ---------------------------------------------------------------------------
def _folded(vertices: np.ndarray, triangles: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """True where a point lies in a triangle whose XY projection is
    clockwise: the strip of a fold. A valid layer surface covers the study
    area once counting signs (footwall +, strip -, hanging wall +), so a
    point under a clockwise triangle is covered by the layer three times."""
    from ._core import AabbTree
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64)
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    out = np.zeros(len(xy), dtype=bool)
    if len(T) == 0 or len(xy) == 0:
        return out
    a, b, c = V[T[:, 0], :2], V[T[:, 1], :2], V[T[:, 2], :2]
    area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    neg = np.flatnonzero(area2 < 0)
    if len(neg) == 0:
        return out
    TN = T[neg]
    tree = AabbTree(V, TN)
    off, idx = tree.query(np.column_stack([xy, xy]))
    off = np.asarray(off)
    idx = np.asarray(idx)
    q = np.repeat(np.arange(len(xy)), np.diff(off))
    P = V[TN[idx]]
    p = xy[q]
    A, B, C = P[:, 0], P[:, 1], P[:, 2]
    den = (B[:, 0] - A[:, 0]) * (C[:, 1] - A[:, 1]) - (B[:, 1] - A[:, 1]) * (C[:, 0] - A[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = ((p[:, 0] - A[:, 0]) * (C[:, 1] - A[:, 1]) - (p[:, 1] - A[:, 1]) * (C[:, 0] - A[:, 0])) / den
        l2 = ((B[:, 0] - A[:, 0]) * (p[:, 1] - A[:, 1]) - (B[:, 1] - A[:, 1]) * (p[:, 0] - A[:, 0])) / den
    # Barycentric coordinates err by ~1e-12 relative; points on an edge of
    # the strip count as inside it.
    eps = 1e-10
    ok = (den != 0) & (l1 >= -eps) & (l2 >= -eps) & (1.0 - l1 - l2 >= -eps)
    out[q[ok]] = True
    return out


def _data_band(dataset, fault: str, layer: str, P: np.ndarray) -> np.ndarray:
    """True for points inside the band the data give: the quadrilaterals
    between consecutive traces' cutoff segments (footwall cutoff to
    hanging-wall cutoff) of ``layer``, where the lofted strip goes."""
    out = np.zeros(len(P), dtype=bool)
    try:
        f = dataset.fault(fault)
    except KeyError:
        return out
    cuts = [(np.asarray(t.layers[layer]["foot"])[-1, :2], np.asarray(t.layers[layer]["hanging"])[0, :2])
            for t in f.traces if layer in t.layers]
    for (a0, a1), (b0, b1) in zip(cuts[:-1], cuts[1:]):
        out |= _fast_inside(P, np.array([a0, a1, b1, b0]))
    return out


def repetition_coverage(model, geology: Geology, faults: Optional[Sequence[str]] = None,
                        du: Optional[float] = None, dataset=None) -> Dict[str, Dict[str, Dict[str, float]]]:
    """Per reverse fault and displaced layer: where the truth has the layer
    twice across that fault, the share of places where the model's layer
    surface also has it more than once (a fold: footwall, strip, hanging
    wall; see :func:`_folded`).

    Sampling: rows across the fault every ``du`` metres along strike (default:
    1/200 of the fault's length, 5-20 m) over its part inside the study area;
    on each row the truth's footwall and hanging-wall cutoffs of the layer
    (roots of side value minus fault surface), and between them at least 12
    points (at most 2 m apart). A point counts where both sides of the fault
    give the layer there (``Geology.side_value`` below/above the fault
    surface) and it lies inside the study area. Returns {fault: {layer:
    {"points": n, "covered": k, "share": k / n}}} (share NaN for n = 0).

    With ``dataset``, also ``points_data`` / ``covered_data`` /
    ``share_data``: the same restricted to the band the data give (between
    consecutive traces, the quadrilateral of their cutoffs; see
    :func:`_data_band`). ``share`` also counts what the data cannot tell
    (the band between sections drawn hundreds of metres apart wanders with
    the layer's folds, and beyond the end traces); ``share_data`` is what the
    builder must get right from the data it has."""
    from .datasets import _roots_near
    ring = np.asarray(model.boundary, dtype=np.float64)
    out: Dict[str, Dict[str, Dict[str, float]]] = {}
    gx, gy = geology.origin
    for fm in geology.faults:
        if fm.kind != "reverse" or (faults is not None and fm.name not in faults):
            continue
        # Along strike: the part of the fault inside the study area's box.
        corners = ring - geology.origin
        uc = (corners - fm.anchor) @ fm.sdir
        lo_u = max(fm.u_range[0], float(uc.min()))
        hi_u = min(fm.u_range[1], float(uc.max()))
        res: Dict[str, Dict[str, float]] = {}
        out[fm.name] = res
        for lay, fac in fm.layers.items():
            if fac <= 0.0 or lay not in model.surfaces:
                continue
            if hi_u <= lo_u:
                res[lay] = {"points": 0, "covered": 0, "share": float("nan")}
                if dataset is not None:
                    res[lay].update(points_data=0, covered_data=0, share_data=float("nan"))
                continue
            step = du if du is not None else float(np.clip((hi_u - lo_u) / 200.0, 5.0, 20.0))
            us = np.arange(lo_u + 0.5 * step, hi_u, step)
            # Rows along the dip direction through the reference trace.
            O = fm.xy(us, fm.bend_offset(us)) + geology.origin
            D = np.broadcast_to(fm.ndir, O.shape)
            # Where the unfaulted layer meets the fault, roughly: the window.
            w0 = np.zeros(len(us))
            for _ in range(6):  # fixed point: layer slopes are well below tan(dip)
                q = O + w0[:, None] * fm.ndir[None, :]
                w0 = (fm.z_ref - geology.unfaulted(lay, q[:, 0], q[:, 1])) / fm.tan_dip
            reach = fm.throw * fac / fm.tan_dip + 60.0

            def g_side(side):
                def g(xy):
                    return geology.side_value(lay, fm.name, side, xy[:, 0], xy[:, 1]) - \
                        geology.plane_z(fm.name, xy[:, 0], xy[:, 1])
                return g

            # Each side's difference changes sign once near its cutoff: a
            # coarse scan finds the bracket, Illinois the root.
            step_w = 5.0
            wf = _roots_near(g_side("foot"), O, D, w0, w0 - 2 * reach - 100.0, w0 + 2 * reach + 100.0, step_w)
            wh = _roots_near(g_side("hanging"), O, D, w0, w0 - 2 * reach - 100.0, w0 + 2 * reach + 100.0, step_w)
            ok = np.isfinite(wf) & np.isfinite(wh) & (np.abs(wh - wf) > 0)
            pts = []
            for r in np.flatnonzero(ok):
                a, b = sorted((wf[r], wh[r]))
                n = max(12, int(math.ceil((b - a) / 2.0)))
                # Interior points of the band (its edges are the cutoffs).
                w = a + (b - a) * (np.arange(n) + 0.5) / n
                pts.append(O[r][None, :] + w[:, None] * fm.ndir[None, :])
            if not pts:
                res[lay] = {"points": 0, "covered": 0, "share": float("nan")}
                if dataset is not None:
                    res[lay].update(points_data=0, covered_data=0, share_data=float("nan"))
                continue
            P = np.vstack(pts)
            zf = geology.side_value(lay, fm.name, "foot", P[:, 0], P[:, 1])
            zh = geology.side_value(lay, fm.name, "hanging", P[:, 0], P[:, 1])
            pz = geology.plane_z(fm.name, P[:, 0], P[:, 1])
            twice = np.isfinite(zf) & np.isfinite(zh) & (zf <= pz) & (zh > pz)
            twice &= points_in_polygon(P, ring)
            P = P[twice]
            surf = model.surfaces[lay]
            cov = _folded(surf.vertices, surf.triangles, P)
            n = int(len(P))
            k = int(cov.sum())
            res[lay] = {"points": n, "covered": k, "share": (k / n) if n else float("nan")}
            if dataset is not None:
                inb = _data_band(dataset, fm.name, lay, P)
                nd, kd = int(inb.sum()), int((cov & inb).sum())
                res[lay].update(points_data=nd, covered_data=kd, share_data=(kd / nd) if nd else float("nan"))
    return out


def near_fault_accuracy(model) -> Dict[str, Any]:
    """What ``build_model`` recorded in ``metadata["accuracy"]`` (mean |dz|
    against the truth near the faults, the stitched model vs the plain
    continuous TINs on the same samples), with ``beats``: the stitched
    model's mean |dz| is below the continuous TIN's, overall (None when
    there were no samples)."""
    acc = dict(model.metadata.get("accuracy") or {})
    ms, mc = acc.get("mean_abs_stitched"), acc.get("mean_abs_continuous")
    beats = None
    if ms is not None and mc is not None and np.isfinite(ms) and np.isfinite(mc) and acc.get("samples", 0) > 0:
        beats = bool(ms < mc)
    return {"samples": int(acc.get("samples", 0)), "mean_abs_stitched": ms,
            "mean_abs_continuous": mc, "beats": beats,
            "layers": {k: (v.get("mean_abs_stitched"), v.get("mean_abs_continuous"))
                       for k, v in acc.get("layers", {}).items()}}


# ---------------------------------------------------------------------------
# One seed, end to end
# ---------------------------------------------------------------------------
_NUM = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_QUOTED = re.compile(r"'[^']*'|\"[^\"]*\"")


def _record(seed: int, **measures: Any) -> Dict[str, Any]:
    """An evaluation's record of ``seed`` before it runs: the fields every
    evaluation has (spec, outcome, error, times), then its own ``measures``."""
    return {"seed": int(seed), "spec": None, "describe": "", "tags": {}, "ok": False, "stage": None,
            "error_type": None, "error": None, "pattern": None, **measures, "seconds": {}}


def _work_folder(folder, prefix: str) -> Tuple[Optional[tempfile.TemporaryDirectory], Path]:
    """(temporary directory or None, the folder to write the ground into):
    ``folder`` itself, or a new temporary directory (the caller cleans it up)."""
    if folder is not None:
        return None, Path(folder)
    tmp = tempfile.TemporaryDirectory(prefix=prefix)
    return tmp, Path(tmp.name)


def _failed(out: Dict[str, Any], stage: str, e: BaseException) -> Dict[str, Any]:
    """``out`` (an evaluation's record) for a seed stopped at ``stage`` by
    the exception ``e``: its type, message (cut) and pattern; the traceback
    too where the generator itself failed."""
    out["stage"] = stage
    out["error_type"] = type(e).__name__
    out["error"] = str(e)[:2000]
    out["pattern"] = normalise_message(str(e))
    if stage.startswith("generate"):
        out["traceback"] = traceback.format_exc()[-3000:]
    return out


def _missed(out: Dict[str, Any], stage: str, pattern: str, error: Optional[str] = None) -> Dict[str, Any]:
    """``out`` for a seed that built and checked but missed a measure."""
    out["stage"], out["error_type"], out["pattern"] = stage, "", pattern
    if error is not None:
        out["error"] = error
    return out


def _held(out: Dict[str, Any]) -> Dict[str, Any]:
    out["ok"], out["stage"] = True, "ok"
    return out


def normalise_message(msg: str) -> str:
    """An error message cut at its first "; " with names and numbers replaced
    (names in quotes -> 'S', numbers -> N, file paths -> PATH; invariant
    names kept), so that messages of one defect compare equal across seeds."""
    m = str(msg).splitlines()[0] if msg else ""
    # What follows a "; " is an example or a hint (which triangles, what to
    # do), not the kind of failure.
    m = m.split("; ")[0]
    m = re.sub(r"/\S*?(dataset\.json|\.csv)", "PATH", m)
    # Invariant names say what is wrong: keep them.
    keep = re.findall(r"invariant '([^']+)'", m)
    m = _QUOTED.sub("'S'", m)
    for k in keep:
        m = m.replace("invariant 'S'", f"invariant <{k}>", 1)
    m = _NUM.sub("N", m)
    m = re.sub(r"invariant <([^>]+)>", r"invariant '\1'", m)
    m = re.sub(r"\(N( point\(s\) outside)\)", r"(N\1)", m)
    return m[:160]


def failure_class(outcome: Dict[str, Any]) -> Optional[Tuple[str, str, str]]:
    """(stage, exception type, message pattern) of a failed outcome of
    :func:`evaluate_ground`, None if it passed. Stages: generate, load,
    build:<step> (stratum TINs, layer repair, fault models, stitching,
    evaluation), check,
    accuracy (built and checked, not better than the plain TIN near the
    faults), repetition (a reverse fault repeats a layer on less than
    :data:`COVERAGE_THRESHOLD` of the truth's band), timeout, crash."""
    if outcome.get("ok"):
        return None
    return (outcome.get("stage") or "?", outcome.get("error_type") or "",
            outcome.get("pattern") or "")


def evaluate_ground(seed: int, folder=None, coverage_threshold: float = COVERAGE_THRESHOLD,
                    **overrides) -> Dict[str, Any]:
    """Run ground ``seed`` from drawing to the checks; never raises for a
    failure of faultmesh (it is recorded). Returns a JSON-serialisable dict:
    seed, spec (:meth:`GroundSpec.to_dict`), describe, tags, ok, stage (where
    it stopped, see :func:`failure_class`), error_type, error, pattern,
    built, checked, rejected_ok (a too-close pair rejected naming both;
    one that built instead has overlap_built and is judged as any other),
    accuracy (:func:`near_fault_accuracy`), coverage
    (:func:`repetition_coverage` with the dataset), coverage_min (the
    smallest ``share_data``: what the threshold applies to),
    coverage_truth_min (the smallest ``share``), seconds (generate, load,
    build, check, measures)."""
    from ._core import GeometryError
    from .build import build_model
    from .dataset import load_dataset

    out = _record(seed, built=False, checked=False, rejected_ok=None, accuracy=None, coverage=None,
                  coverage_min=None)

    def fail(stage, e):
        return _failed(out, stage, e)

    tmp, folder = _work_folder(folder, "faultmesh-ground-")
    try:
        t0 = time.perf_counter()
        try:
            spec, geo, path = make_ground(seed, folder, **overrides)
        except Exception as e:  # a defect of the generator itself
            return fail("generate", e)
        out["seconds"]["generate"] = time.perf_counter() - t0
        out["spec"] = spec.to_dict()
        out["describe"] = spec.describe()
        out["tags"] = spec.tags()
        close = spec.pair["faults"] if spec.expect == "reject" else None

        def rejected(e) -> bool:
            return close is not None and isinstance(e, DatasetError) and all(n in str(e) for n in close)

        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ds = load_dataset(path)
        except Exception as e:
            if rejected(e):
                out.update(ok=True, stage="rejected", rejected_ok=True, error=str(e)[:2000])
                return out
            return fail("load", e)
        ds.truth = geo.truth
        out["seconds"]["load"] = time.perf_counter() - t0

        step = {"name": "start"}

        def progress(name, i, n):
            step["name"] = name

        t0 = time.perf_counter()
        try:
            model = build_model(ds, progress=progress)
        except Exception as e:
            if rejected(e):
                out.update(ok=True, stage="rejected", rejected_ok=True, error=str(e)[:2000])
                return out
            return fail(f"build:{step['name']}", e)
        out["seconds"]["build"] = time.perf_counter() - t0
        out["built"] = True
        if close is not None:
            # Not rejected: the overlap of the two zones did not reach the
            # patches the data give (sparse traces). Such a model is judged
            # like any other (the robustness issue's criterion: rejected
            # naming the pair, or built, checked and better than the TIN).
            out["rejected_ok"] = False
            out["overlap_built"] = True

        t0 = time.perf_counter()
        try:
            model.check()
            out["checked"] = True
        except GeometryError as e:
            fail("check", e)
            m = re.search(r"invariant '([^']+)'", str(e))
            if m:
                out["invariant"] = m.group(1)
        out["seconds"]["check"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        acc = near_fault_accuracy(model)
        out["accuracy"] = acc
        cov = repetition_coverage(model, geo, dataset=ds)
        out["coverage"] = cov
        shares = [v["share_data"] for f in cov.values() for v in f.values() if v["points_data"] > 0]
        out["coverage_min"] = min(shares) if shares else None
        truth = [v["share"] for f in cov.values() for v in f.values() if v["points"] > 0]
        out["coverage_truth_min"] = min(truth) if truth else None
        out["seconds"]["measures"] = time.perf_counter() - t0
        if not out["checked"]:
            return out
        if acc["beats"] is False:
            return _missed(out, "accuracy",
                           "stitched model not better than the plain TIN near the faults")
        if out["coverage_min"] is not None and out["coverage_min"] < coverage_threshold:
            worst = min(((fn, ln, v["share_data"]) for fn, f in cov.items() for ln, v in f.items()
                         if v["points_data"] > 0), key=lambda t: t[2])
            return _missed(out, "repetition",
                           f"reverse fault repeats a layer on less than "
                           f"{100 * coverage_threshold:.0f} % of the band the data give",
                           f"fault {worst[0]!r}, layer {worst[1]!r}: {100 * worst[2]:.1f} %")
        return _held(out)
    finally:
        if tmp is not None:
            tmp.cleanup()


# ---------------------------------------------------------------------------
# Format v2: the same ground as fault points and drillhole tables
# ---------------------------------------------------------------------------
#: Interval unit logged where a v2 drillhole crosses a fault surface and the
#: unit changes across it (listed in ``other_units``). A contact between two
#: layers in stratigraphic order that is in fact a fault (a normal fault
#: cutting out layers, or a reverse fault where a younger layer lies below)
#: would otherwise be read as a layer top on the fault (docs/dataset.md,
#: "Layer tops"); logging the fault rock is what the format asks for.
FAULT_ROCK = "fault"

#: Interval unit logged above the top layer below the collar: in the
#: footwall of a reverse fault that repeats the top layer, between the fault
#: and the footwall's top layer (the truth has no layer above its top one).
#: It is not a layer, so the footwall's second top of the top layer is not
#: given (docs/dataset.md: a contact next to an other unit gives no top; a
#: cover logged as a layer would give it), unlike the v1 borehole table.
COVER = "cover"

#: Half the thickness (m) of the fault rock logged at a crossing: 1 cm either
#: side of it, the thinnest gouge a log records at the depths' 1 mm
#: resolution. It hides a stratigraphic contact only where the hole crosses
#: the fault within 1 cm of it (a hole through a cutoff line).
_FAULT_ROCK_HALF = 0.01

#: Depth step (m) of the scan along the holes before bisection. Within one
#: fault block a layer's top is crossed once by a hole steeper than 55
#: degrees (the hole sinks by sin(55) = 0.82 m per metre, a top of slope
#: below 1.6 -- layer slope plus the drag of a decaying throw -- rises by at
#: most 0.57 m per metre along it), so the scan brackets each top of each
#: layer separately, also a layer thinner than the step; fault surfaces
#: (planes bent along strike) are crossed once by a straight or gently
#: curved hole.
_SCAN_STEP = 2.0

#: Bisection steps: 2 m / 2**52 is below the spacing of doubles at the
#: depths of the holes; the contacts are exact to rounding.
_BISECT = 52

#: The kinds of v2 drillholes (share of the holes): vertical, straight and
#: inclined (dip -60..-85), curved (stations every 30 m, turning by up to 1.5
#: degrees in dip and 2 in azimuth between stations, always steeper than 55).
_HOLE_KINDS = ("vertical", "inclined", "curved")
_HOLE_SHARES = (0.5, 0.25, 0.25)


def _bisect(f, lo: np.ndarray, hi: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Shrink brackets [lo, hi] (depths) to the change of the predicate
    ``f(depths) -> bool`` (True at lo); vectorised over brackets."""
    lo, hi = lo.copy(), hi.copy()
    for _ in range(_BISECT):
        if not len(lo):
            break
        mid = 0.5 * (lo + hi)
        same = f(mid)
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    return lo, hi


def _hole_contacts(geo: Geology, holes, length: np.ndarray):
    """Where the holes of ``holes`` (:class:`faultmesh.drillholes.Drillholes`,
    desurveyed) meet the truth down to ``length`` (per hole): the unit at the
    collar (rank in ``geo.layers``, -1 above the top layer) and the events
    (hole, depth, unit below, crossing a fault?) sorted by hole and depth.

    The scan samples every hole every :data:`_SCAN_STEP` m. Fault crossings:
    where the side of some fault surface changes between samples, bisected.
    They cut each hole into stretches in one fault block; in each, every
    layer's top in that block (:meth:`Geology.tops_in_block`) minus the
    hole's elevation changes sign where the hole crosses it, bisected with
    the block fixed. The unit at a point is the number of its block's tops at
    or above it minus one."""
    H = len(length)
    n_s = np.floor(length / _SCAN_STEP).astype(np.int64) + 2
    hole = np.repeat(np.arange(H), n_s)
    k = np.arange(len(hole)) - np.repeat(np.cumsum(n_s) - n_s, n_s)
    depth = np.minimum(k * _SCAN_STEP, length[hole])
    P = holes.positions(hole, depth)
    S = geo.hanging(P[:, 0], P[:, 1], P[:, 2])
    # Fault crossings.
    j = np.flatnonzero((hole[1:] == hole[:-1]) & np.any(S[1:] != S[:-1], axis=1))
    fh, S_up = hole[j], S[j]

    def upper(d):
        Q = holes.positions(fh, d)
        return np.all(geo.hanging(Q[:, 0], Q[:, 1], Q[:, 2]) == S_up, axis=1)

    f_lo, f_hi = _bisect(upper, depth[j], depth[j + 1])
    Q_lo, Q_hi = holes.positions(fh, f_lo), holes.positions(fh, f_hi)
    # Nodes: the samples and both ends of every crossing; a stretch (block)
    # starts at the lower end of each crossing.
    n_hole = np.concatenate([hole, fh, fh])
    n_depth = np.concatenate([depth, f_lo, f_hi])
    n_P = np.vstack([P, Q_lo, Q_hi])
    S_dn = geo.hanging(Q_hi[:, 0], Q_hi[:, 1], Q_hi[:, 2])
    f_unit = (geo.tops_in_block(Q_hi[:, 0], Q_hi[:, 1], S_dn) - Q_hi[:, 2:3] >= 0.0).sum(axis=1) - 1
    n_S = np.vstack([S, S_up, S_dn])
    tie = np.concatenate([np.full(len(hole), 2), np.zeros(len(fh)), np.ones(len(fh))])
    o = np.lexsort((tie, n_depth, n_hole))
    n_hole, n_depth, n_P, n_S, tie = n_hole[o], n_depth[o], n_P[o], n_S[o], tie[o]
    block = np.cumsum(tie == 1)
    G = geo.tops_in_block(n_P[:, 0], n_P[:, 1], n_S) - n_P[:, 2:3]
    unit = (G >= 0.0).sum(axis=1) - 1
    a = np.flatnonzero((n_hole[1:] == n_hole[:-1]) & (block[1:] == block[:-1])
                       & np.all(n_S[1:] == n_S[:-1], axis=1))
    ba, lay = np.nonzero((G[a] >= 0.0) != (G[a + 1] >= 0.0))
    ba = a[ba]
    th, tS, t_up = n_hole[ba], n_S[ba], G[ba, lay] >= 0.0

    def above_top(d):
        Q = holes.positions(th, d)
        g = geo.tops_in_block(Q[:, 0], Q[:, 1], tS)[np.arange(len(d)), lay] - Q[:, 2]
        return (g >= 0.0) == t_up

    t_lo, t_hi = _bisect(above_top, n_depth[ba], n_depth[ba + 1])
    Q = holes.positions(th, t_hi)
    t_unit = (geo.tops_in_block(Q[:, 0], Q[:, 1], tS) - Q[:, 2:3] >= 0.0).sum(axis=1) - 1
    collar_unit = unit[np.r_[0, np.flatnonzero(n_hole[1:] != n_hole[:-1]) + 1]]
    ev_hole = np.concatenate([th, fh])
    ev_depth = np.concatenate([t_hi, f_hi])
    ev_unit = np.concatenate([t_unit, f_unit])
    ev_fault = np.concatenate([np.zeros(len(th), bool), np.ones(len(fh), bool)])
    o = np.lexsort((ev_depth, ev_hole))
    return collar_unit, ev_hole[o], ev_depth[o], ev_unit[o], ev_fault[o]


def _fault_grid(geo: Geology, fm: FaultModel, ring: np.ndarray, z_range: Tuple[float, float],
                rng: np.random.Generator, noise: Optional[np.random.Generator] = None, sigma: float = 0.0):
    """The interpreter's sampling of the truth's fault surface: one stick
    every 60-140 m along strike over the fault's extent (its ``u_range``,
    cut to the study area's reach along strike plus up to 100 m), points
    every 15-35 m down the stick over ``z_range``; with ``sigma`` > 0, each
    point then moved across strike (horizontally) by a normal error of that
    standard deviation drawn from ``noise`` (an interpreter's picking error;
    ``rng``'s draws stay the same). Returns (xy (n*k, 2) local, Z (n*k,),
    n sticks, k levels, keep (n*k,) bool: on its side of the fault it abuts,
    all True otherwise); stick by stick, top down."""
    uc = (ring - geo.origin - fm.anchor) @ fm.sdir
    m = float(rng.uniform(0.0, 100.0))
    lo, hi = max(fm.u_range[0], float(uc.min()) - m), min(fm.u_range[1], float(uc.max()) + m)
    n = max(4, int(math.ceil((hi - lo) / float(rng.uniform(60.0, 140.0)))) + 1)
    u = np.linspace(lo, hi, n)
    step_z = float(rng.uniform(15.0, 35.0))
    z = np.arange(z_range[1] - float(rng.uniform(0.0, step_z)), z_range[0], -step_z)
    U, Z = (a.ravel() for a in np.meshgrid(u, z, indexing="ij"))
    xy = fm.xy(U, (fm.z_ref - Z) / fm.tan_dip + fm.bend_offset(U))
    keep = np.ones(len(U), dtype=bool)
    if fm.abuts is not None:
        parent = geo.fault(fm.abuts[0])
        keep = (Z > parent.plane_z(xy[:, 0], xy[:, 1])) == (fm.abuts[1] == "hanging")
    if sigma > 0.0:
        xy = xy + noise.normal(0.0, sigma, len(U))[:, None] * fm.ndir[None, :]
    return xy, Z, n, len(z), keep


def _fault_sticks(geo: Geology, fm: FaultModel, ring: np.ndarray, z_range: Tuple[float, float],
                  rng: np.random.Generator, dec_xy: int, dec_z: int, **noise) -> Tuple[np.ndarray, np.ndarray]:
    """Fault sticks on the truth's fault surface, as a seismic interpreter
    picks them (:func:`_fault_grid`, ``noise``: its noise and sigma); a
    fault that abuts another only on its side of it. Rounded to ``dec_xy``
    (the traces' rounding) and ``dec_z`` decimals. Returns (points (m, 3),
    stick labels (m,) 1, 2, ...)."""
    xy, Z, n, k, keep = _fault_grid(geo, fm, ring, z_range, rng, **noise)
    stick = np.repeat(np.arange(1, n + 1), k)
    P = np.column_stack([np.round(xy + geo.origin, dec_xy), np.round(Z, dec_z)])[keep]
    stick = stick[keep]
    count = np.bincount(stick, minlength=n + 1)
    keep = count[stick] >= 2  # a stick has at least two points
    return P[keep], stick[keep]


def _fault_surface(geo: Geology, fm: FaultModel, ring: np.ndarray, z_range: Tuple[float, float],
                   rng: np.random.Generator, dec_xy: int, dec_z: int, **noise) -> Tuple[np.ndarray, np.ndarray]:
    """The truth's fault surface as an interpreter's triangulated surface
    (a GOCAD TSurf): the grid of :func:`_fault_grid`, two triangles per
    cell, the diagonals alternating; a fault that abuts another keeps the
    triangles whose corners all lie on its side of it (a ragged edge short
    of the other fault by up to a cell, as a surface clipped by hand).
    Rounded like the sticks. Returns (vertices (v, 3), triangles (t, 3))."""
    xy, Z, n, k, keep = _fault_grid(geo, fm, ring, z_range, rng, **noise)
    idx = np.arange(n * k).reshape(n, k)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    flip = ((np.arange(n - 1)[:, None] + np.arange(k - 1)[None, :]) % 2).astype(bool)
    t1 = np.where(flip[..., None], np.stack([a, b, d], -1), np.stack([a, b, c], -1)).reshape(-1, 3)
    t2 = np.where(flip[..., None], np.stack([b, c, d], -1), np.stack([a, c, d], -1)).reshape(-1, 3)
    T = np.vstack([t1, t2])
    T = T[keep[T].all(axis=1)]
    used, T = np.unique(T, return_inverse=True)
    V = np.column_stack([np.round(xy + geo.origin, dec_xy), np.round(Z, dec_z)])[used]
    return V, T.reshape(-1, 3).astype(np.int64)


def _v2_drillholes(geo: Geology, ds1: Dataset, spec: GroundSpec, rng: np.random.Generator):
    """Collar, survey and interval tables of the v1 dataset's holes (same ids
    and collar x, y; collar z the top layer's truth, rounded as v1's tops), a
    share of them deviated (:data:`_HOLE_KINDS`; the holes placed in
    reverse-fault bands stay vertical), logged from the truth along their
    desurveyed paths: depths to 1 mm, angles to 0.01 degree; fault rock
    (:data:`FAULT_ROCK`) where a hole crosses a fault and the unit changes,
    and at the collar of a hole collared in the top layer's normal-fault gap
    (on the fault); :data:`COVER` above the top layer under a thrust. A hole ends a little below the last top of the deepest
    layer its v1 rows reach (before the next contact; a curved hole at its
    next survey station). Returns (DrillholeTables, hole kinds)."""
    from .drillholes import CollarTable, Drillholes, DrillholeTables, IntervalTable, SurveyTable
    b = ds1.boreholes
    layers = list(ds1.layers)
    ids, first, inv = np.unique(b.hole_id, return_index=True, return_inverse=True)
    srt = np.argsort(first)  # holes in table order
    rank_of = np.argsort(srt)
    hi_ = rank_of[inv]
    ids, first = ids[srt], first[srt]
    H = len(ids)
    li = np.array([layers.index(v) for v in b.layer.tolist()], dtype=np.int64)
    deep = np.full(H, -1)
    np.maximum.at(deep, hi_, li)
    z_low = np.full(H, np.inf)
    np.minimum.at(z_low, hi_, b.z)
    xy = b.xy[first]
    zdec = int(spec.rounding["z"])
    zc = np.round(geo.truth(layers[0], xy[:, 0], xy[:, 1]), zdec)
    kind = np.array(_HOLE_KINDS)[rng.choice(len(_HOLE_KINDS), size=H, p=_HOLE_SHARES)]
    kind[np.char.startswith(ids.astype(str), "R")] = "vertical"  # the band holes
    length = np.where(kind == "vertical", zc - z_low + 20.0, (zc - z_low + 150.0) / 0.8)
    st_h, st_d, st_a, st_p = [], [], [], []
    for h in range(H):
        if kind[h] == "vertical":
            if rng.random() < 0.5:
                st_h.append(h), st_d.append(0.0), st_a.append(0.0), st_p.append(-90.0)
            continue
        az, dip = float(rng.uniform(0.0, 360.0)), float(rng.uniform(-85.0, -60.0))
        if kind[h] == "inclined":
            step = float(length[h]) + 1.0 if rng.random() < 0.5 else 50.0
            for d in np.arange(0.0, length[h], step):
                st_h.append(h), st_d.append(float(d)), st_a.append(round(az, 2)), st_p.append(round(dip, 2))
            continue
        for d in np.arange(0.0, length[h] + 30.0, 30.0):
            st_h.append(h), st_d.append(float(d)), st_a.append(round(az % 360.0, 2)), st_p.append(round(dip, 2))
            az += float(rng.uniform(-2.0, 2.0))
            dip = float(np.clip(dip + rng.uniform(-1.5, 1.5), -89.5, -55.0))
    st_h = np.array(st_h, dtype=np.int64)
    st_d, st_a, st_p = (np.array(v, dtype=np.float64) for v in (st_d, st_a, st_p))
    collars = CollarTable(ids, np.column_stack([xy, zc]))
    path = Drillholes(collars, SurveyTable(ids[st_h], st_d, st_a, st_p))
    c_unit, e_hole, e_depth, e_unit, e_fault = _hole_contacts(geo, path, length)
    gap = geo.n_sheets(layers[0], xy[:, 0], xy[:, 1]) == 0
    margin = rng.uniform(1.0, 8.0, size=H)
    cuts = np.searchsorted(e_hole, np.arange(H + 1))
    rows = []          # (hole, from, to, unit)
    end = np.zeros(H)
    names = layers + [FAULT_ROCK, COVER]  # unit -1 (above the top layer): COVER
    for h in range(H):  # per hole: its dozen events
        ev = range(cuts[h], cuts[h + 1])
        cur = max(int(c_unit[h]), 0)
        starts = [(0.0, cur)]
        zones = [(0.0, _FAULT_ROCK_HALF)] if gap[h] else []
        last_top = 0.0
        for k in ev:
            d, u = float(e_depth[k]), int(e_unit[k])
            if u == cur:
                continue
            if e_fault[k]:
                zones.append((d - _FAULT_ROCK_HALF, d + _FAULT_ROCK_HALF))
            elif cur < u <= deep[h]:
                last_top = d
            starts.append((d, u))
            cur = u
        nxt = np.array([a for a, _ in starts[1:] if a > last_top])  # the next change of unit
        room = (float(nxt[0]) if len(nxt) else float(length[h])) - last_top
        e = last_top + min(float(margin[h]), 0.5 * room)
        if kind[h] == "curved":
            sd = st_d[st_h == h]
            e = float(sd[sd >= e][0]) if np.any(sd >= e) else e
        e = round(e, 3)
        end[h] = e
        segs = [(a, bnd, u) for (a, u), (bnd, _) in zip(starts, starts[1:] + [(e, -2)]) if a < e]
        segs = [(a, min(bnd, e), u) for a, bnd, u in segs]
        for z0, z1 in zones:  # paint the fault rock over what it hides
            z0, z1 = max(z0, 0.0), min(z1, e)
            if z1 <= z0:
                continue
            out = []
            for a, bnd, u in segs:
                if bnd <= z0 or a >= z1:
                    out.append((a, bnd, u))
                    continue
                if a < z0:
                    out.append((a, z0, u))
                if bnd > z1:
                    out.append((z1, bnd, u))
            out.append((z0, z1, len(layers)))
            segs = sorted(out)
        merged = []
        for a, bnd, u in segs:  # logged to 1 mm
            a, bnd = round(a, 3), round(bnd, 3)
            if bnd <= a:
                continue
            if merged and merged[-1][2] == u and merged[-1][1] == a:
                merged[-1] = (merged[-1][0], bnd, u)
            elif merged:
                merged.append((merged[-1][1], bnd, u))
            else:
                merged.append((a, bnd, u))
        rows += [(h, a, bnd, names[u]) for a, bnd, u in merged]
    keep = st_d <= end[st_h]
    collars = CollarTable(ids, np.column_stack([xy, zc]), end)
    surveys = SurveyTable(ids[st_h[keep]], st_d[keep], st_a[keep], st_p[keep])
    R = np.array([r[0] for r in rows], dtype=np.int64)
    intervals = IntervalTable(ids[R], [r[1] for r in rows], [r[2] for r in rows], [r[3] for r in rows])
    tables = DrillholeTables(Drillholes(collars, surveys, intervals), (FAULT_ROCK, COVER))
    return tables, kind


#: The fault shadow of :func:`trace_picks`: horizontal distances from the
#: cutoff within which an interpreter picks no horizon on a section. Seismic
#: reflections are smeared next to a fault over about a Fresnel zone (tens
#: of metres at the depths of these grounds), and picks there are the ones
#: a careful interpreter deletes; 10-50 m brackets that, drawn per ground.
SHADOW = (10.0, 50.0)


def trace_picks(ds1: Dataset, seed: int) -> Tuple[Dict[str, np.ndarray], float]:
    """The layer observations of ground ``seed``'s v1 traces without the
    cutoffs: every point of each footwall and hanging-wall polyline whose
    horizontal distance from its cutoff (the polyline's fault end) is at
    least the ground's fault shadow (drawn from :data:`SHADOW` by
    ``default_rng([seed, 3])``), as layer points -- what an interpreter
    picks on seismic sections, where the v1 dataset gives the same lines
    drawn up to the fault. Both sheets of a layer a reverse fault repeats
    are kept, as picked. Returns (layer -> (n, 3) points, shadow in m)."""
    shadow = float(np.random.default_rng([int(seed), 3]).uniform(*SHADOW))
    out: Dict[str, List[np.ndarray]] = {}
    for f in ds1.faults:
        for t in f.traces:
            for lay, sides in t.layers.items():
                for side, P in sides.items():
                    P = np.asarray(P, dtype=np.float64).reshape(-1, 3)
                    cut = P[-1] if side == "foot" else P[0]
                    far = np.hypot(P[:, 0] - cut[0], P[:, 1] - cut[1]) >= shadow
                    out.setdefault(lay, []).append(P[far])
    return {lay: np.vstack(v) for lay, v in out.items() if sum(len(a) for a in v)}, shadow


#: How :func:`write_v2` gives a fault's geometry: its sticks (points with a
#: stick column), the same points without sticks, or a triangulated surface.
FAULT_FORMS = ("sticks", "points", "surface")


def write_v2(ds1: Dataset, geo: Geology, spec: GroundSpec, folder, section_picks: bool = False,
             fault_form: str = "sticks", fault_noise: float = 0.0, groups: bool = True,
             throw_hints: bool = False) -> Path:
    """Write ground ``spec.seed`` (its v1 dataset ``ds1`` as loaded, its truth
    ``geo``) as a format-2 dataset into ``folder`` without cutoffs: each fault
    as fault sticks on the truth's surface (:func:`_fault_sticks`; with
    ``fault_form`` "points" the same points without their stick column,
    "surface" a TSurf (:func:`_fault_surface`); ``fault_noise`` (m): the
    standard deviation of a picking error across strike, drawn from
    ``default_rng([seed, 4])``; no traces, no kind, no tips: :func:`faultmesh.derive.derive_faults` derives them;
    the group kept, or with ``groups`` False left out: the derivation
    finds the faults that meet; with ``throw_hints`` each fault's ``throw``
    hint, its largest true throw over the layers it displaces, to 0.1 m, as
    a geologist's estimate would give it), the layer tops as collar, survey and interval tables of
    the same holes with a share of them deviated (:func:`_v2_drillholes`),
    the v1 topography as points and, with ``section_picks``, the v1 traces'
    layer polylines beyond a fault shadow as points
    (:func:`trace_picks`): the v1 dataset's data without its cutoffs
    (what :func:`evaluate_ground_v2` compares by default). Without them
    (the default here: the layer data of the holes only, the grounds the
    derivation's sparse-data tests are written for) the v2 dataset lacks
    every layer datum the v1 traces give within 20-180 m of the faults,
    where the models are compared. Drawn
    from ``np.random.default_rng([seed, 2])`` (the shadow from ``[seed,
    3]``), so the v1 dataset (and the sweep) does not change. Returns the
    JSON path; the hole kinds, point counts and shadow are written to
    ``v2.json`` beside it."""
    from dataclasses import replace
    from .dataset import apply_boundary_policy
    rng = np.random.default_rng([int(spec.seed), 2])
    folder = Path(folder)
    b = ds1.boreholes
    margin = float(rng.uniform(20.0, 80.0))
    z_range = (float(b.z.min()) - margin, float(b.z.max()) + margin)
    ring = np.asarray(ds1.boundary, dtype=np.float64)
    if fault_form not in FAULT_FORMS:
        raise ValueError(f"write_v2: fault_form must be one of {FAULT_FORMS}, got {fault_form!r}")
    faults = []
    noise = {"noise": np.random.default_rng([int(spec.seed), 4]), "sigma": float(fault_noise)}
    for f in ds1.faults:
        dec = (int(spec.rounding["traces"]), int(spec.rounding["z"]))
        group = f.group if groups else None
        fm = geo.fault(f.name)
        hint = {"max": round(fm.throw * max(fm.layers.values(), default=0.0), 1)} if throw_hints else None
        if hint is not None and not hint["max"] > 0.0:
            hint = None
        if fault_form == "surface":
            V, T = _fault_surface(geo, fm, ring, z_range, rng, *dec, **noise)
            faults.append(Fault(f.name, None, group, surface=(V, T), throw=hint))
            continue
        P, st = _fault_sticks(geo, fm, ring, z_range, rng, *dec, **noise)
        faults.append(Fault(f.name, None, group, points=P, sticks=st if fault_form == "sticks" else None,
                            throw=hint))
    tables, kinds = _v2_drillholes(geo, ds1, spec, rng)
    points = {lay: np.asarray(v, dtype=np.float64).reshape(-1, 3) for lay, v in ds1.points.items()}
    picks, shadow = trace_picks(ds1, spec.seed) if section_picks else ({}, None)
    for lay, P in picks.items():
        points[lay] = np.vstack([points[lay], P]) if lay in points else P
    ds2 = Dataset(name=f"{ds1.name}-v2", layers=list(ds1.layers), boundary=ring,
                  boreholes=tables.tops(ds1.layers), points=points, faults=faults,
                  crs=ds1.crs, drillholes=tables)
    # The tops as the loader will give them (beyond the boundary dropped):
    # what save checks the tables against.
    ds2.boreholes = apply_boundary_policy(replace(ds2, points={}, faults=[], adjustments=[])).boreholes
    path = ds2.save(folder, version=2)
    info = {"holes": {k: int(np.sum(kinds == k)) for k in _HOLE_KINDS},
            "fault_points": {f.name: int(len(f.points) if f.points is not None else len(f.surface[0]))
                             for f in faults},
            "section_picks": {lay: int(len(P)) for lay, P in picks.items()}, "shadow": shadow}
    (folder / "v2.json").write_text(json.dumps(info, indent=1) + "\n", encoding="utf-8")
    return path


# ---------------------------------------------------------------------------
# Derived against true cutoffs
# ---------------------------------------------------------------------------
#: A v2 model "holds" when its error near the faults is at most this
#: multiple of the error of the model built from the true cutoffs (issue 11).
V2_RATIO = 1.25


def cutoff_distance(geo: Geology, fault: str, layer: str, side: str, P: np.ndarray,
                    direction: np.ndarray, half: float = 400.0, step: float = 1.0) -> np.ndarray:
    """3D distance from each derived cutoff point P (k, 3) to the true cutoff
    of ``side`` ("foot" or "hanging") of ``layer`` on ``fault``, on the
    vertical section line through it along ``direction`` (unit XY, e.g. the
    fault's dip direction): the root of side value minus fault elevation
    nearest to P within ``half`` m, bracketed on a ``step`` m grid and
    refined linearly. NaN where the section has none (the layer not cut
    there by the truth)."""
    P = np.asarray(P, dtype=np.float64).reshape(-1, 3)
    d = np.asarray(direction, dtype=np.float64).reshape(2)
    s = np.arange(-half, half + step, step)
    k, m = len(P), len(s)
    xy = (P[:, None, :2] + s[None, :, None] * d[None, None, :]).reshape(-1, 2)
    g = (geo.side_value(layer, fault, side, xy[:, 0], xy[:, 1])
         - geo.plane_z(fault, xy[:, 0], xy[:, 1])).reshape(k, m)
    ok = np.isfinite(g[:, :-1]) & np.isfinite(g[:, 1:]) & ((g[:, :-1] > 0) != (g[:, 1:] > 0))
    out = np.full(k, np.nan)
    rows = np.flatnonzero(ok.any(axis=1))
    if not len(rows):
        return out
    # The bracket nearest to P on each section.
    dist = np.where(ok[rows], np.abs(s[:-1])[None, :], np.inf)
    j = np.argmin(dist, axis=1)
    g0, g1 = g[rows, j], g[rows, j + 1]
    t = g0 / (g0 - g1)
    q = P[rows, :2] + (s[j] + t * step)[:, None] * d[None, :]
    qz = geo.plane_z(fault, q[:, 0], q[:, 1])
    out[rows] = np.linalg.norm(np.column_stack([q, qz]) - P[rows], axis=1)
    return out


def near_fault_errors(models, geo: Geology, ring: np.ndarray, near: float = 150.0,
                      samples: int = 200) -> List[float]:
    """Mean |dz| of each model's upper sheet against the truth on the SAME
    grid points: those within ``near`` m (on a ``samples``-cell grid over the
    study area's box) of where some layer of the truth is absent or doubled
    (the fault bands), as build_model's ``metadata["accuracy"]`` measures,
    but independent of the models' patch footprints, so that two models are
    compared on equal terms. NaN for a model when no point has a finite z in
    every model."""
    from scipy.ndimage import distance_transform_edt
    from .build import surface_z
    ring = np.asarray(ring, dtype=np.float64)
    lo, hi = ring.min(axis=0), ring.max(axis=0)
    h = float(max(hi - lo)) / samples
    X, Y = np.meshgrid(np.arange(lo[0] + h / 2, hi[0], h), np.arange(lo[1] + h / 2, hi[1], h))
    P = np.column_stack([X.ravel(), Y.ravel()])
    inside = points_in_polygon(P, ring)
    errs: List[List[np.ndarray]] = [[] for _ in models]
    for lay in geo.layers:
        band = (geo.n_sheets(lay, P[:, 0], P[:, 1]) != 1).reshape(X.shape)
        if not band.any():
            continue
        sel = np.flatnonzero((distance_transform_edt(~band).ravel() * h <= near) & inside)
        t = geo.truth(lay, P[sel, 0], P[sel, 1])
        zs = [surface_z(m.surfaces[lay].vertices, m.surfaces[lay].triangles, P[sel])[1] for m in models]
        ok = np.isfinite(t) & np.all([np.isfinite(z) for z in zs], axis=0)
        for e, z in zip(errs, zs):
            e.append(np.abs(z[ok] - t[ok]))
    return [float(np.concatenate(e).mean()) if e and sum(len(v) for v in e) else float("nan")
            for e in errs]


def _derive_symptom(out: Dict[str, Any]) -> str:
    """What derive got visibly wrong on a seed whose v2 model is too far off
    (for the failure classes): a wrong kind, else its most frequent warning
    (normalised), else "no warning"."""
    if out.get("kind_ok") is False:
        return "kind derived wrong"
    pats = [normalise_message(re.sub(r"^fault '[^']*'(, layer '[^']*')?(, section [^:]*)?: ", "", w))
            for w in out.get("warnings") or []]
    if not pats:
        return "no warning"
    best = max(sorted(set(pats)), key=pats.count)
    return f"warns: {best}"


def evaluate_ground_v2(seed: int, folder=None, ratio_limit: float = V2_RATIO, section_picks: bool = True,
                       built: Optional[Dict[str, Any]] = None, fault_form: str = "sticks",
                       fault_noise: float = 0.0, groups: bool = True, throw_hints: bool = False,
                       **overrides) -> Dict[str, Any]:
    """Ground ``seed`` as v1 (true cutoffs) and as v2 without cutoffs
    (:func:`write_v2`, with or without ``section_picks``, its faults in
    ``fault_form``, picked with ``fault_noise``, with or without their
    ``groups``, with or without ``throw_hints``), each loaded,
    built and checked; never raises for a failure of faultmesh (it is
    recorded). Returns a JSON-serialisable dict:
    seed, spec, describe, tags, v2 (hole kinds, fault points), ok (v2 derived,
    built, checked, error ratio <= ``ratio_limit``), stage (where it stopped:
    generate, load:v1, build:v1, check:v1 -- the v1 model is the reference,
    these are the robustness sweep's failures --, generate:v2, load:v2,
    derive, build:v2:<step>, check:v2, ratio; "reject" for a too-close pair,
    not run), error_type, error, pattern, kinds ({fault: [true, derived]}),
    kind_ok, cutoffs ({fault: {layer: {side: [distances]}}} over the derived
    cutoff points; NaN where the truth has no cutoff on that section),
    cutoff_mean / cutoff_max (over the finite distances), cutoff_nan (count),
    uncut (true (fault, layer) pairs that no derived section cuts), error_v1,
    error_v2 (:func:`near_fault_errors`), ratio, warnings (derive's),
    seconds. ``built``, a dict, receives the objects as far as they were
    made: geo (the true geology), ds1 and ds2 (the datasets loaded), derived
    (ds2 with its derived faults), m1 and m2 (the models), for a caller (the
    tests) that looks further into them."""
    from ._core import GeometryError  # noqa: F401  (check() raises it)
    from .build import build_model
    from .dataset import load_dataset
    from .derive import derive_faults

    out = _record(seed, v2=None, kinds={}, kind_ok=None, cutoffs={}, cutoff_mean=None, cutoff_max=None,
                  cutoff_nan=None, uncut=[], error_v1=None, error_v2=None, ratio=None, warnings=[])

    def fail(stage, e):
        return _failed(out, stage, e)

    tmp, folder = _work_folder(folder, "faultmesh-ground-v2-")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.perf_counter()
            try:
                spec, geo, path1 = make_ground(seed, folder, **overrides)
            except Exception as e:
                return fail("generate", e)
            out["spec"], out["describe"], out["tags"] = spec.to_dict(), spec.describe(), spec.tags()
            if spec.expect == "reject":
                out["stage"] = "reject"
                return out
            try:
                ds1 = load_dataset(path1)
            except Exception as e:
                return fail("load:v1", e)
            kept = built if built is not None else {}
            kept["geo"], kept["ds1"] = geo, ds1
            try:
                path2 = write_v2(ds1, geo, spec, folder / "v2", section_picks=section_picks,
                                 fault_form=fault_form, fault_noise=fault_noise, groups=groups,
                                 throw_hints=throw_hints)
                out["v2"] = json.loads((folder / "v2" / "v2.json").read_text())
            except Exception as e:
                return fail("generate:v2", e)
            out["seconds"]["generate"] = time.perf_counter() - t0
            try:
                ds2 = load_dataset(path2)
            except Exception as e:
                return fail("load:v2", e)
            kept["ds2"] = ds2
            t0 = time.perf_counter()
            try:
                m1 = build_model(ds1, evaluate=False)
            except Exception as e:
                return fail("build:v1", e)
            kept["m1"] = m1
            try:
                m1.check()
            except Exception as e:
                return fail("check:v1", e)
            out["seconds"]["v1"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            try:
                d2 = derive_faults(ds2)
            except Exception as e:
                return fail("derive", e)
            kept["derived"] = d2
            out["seconds"]["derive"] = time.perf_counter() - t0
            rep = d2.derivation
            out["warnings"] = [str(w)[:300] for w in rep.warnings]
            out["kinds"] = {f.name: [geo.fault(f.name).kind, rep.faults[f.name].kind]
                            for f in ds2.faults if f.name in rep.faults}
            out["kind_ok"] = all(a == b for a, b in out["kinds"].values())
            dists = []
            for name, fr in rep.faults.items():
                fm = geo.fault(name)
                res: Dict[str, Dict[str, List[float]]] = {}
                for lay, cl in fr.cutoffs.items():
                    res[lay] = {}
                    for side in ("foot", "hanging"):
                        dd = cutoff_distance(geo, name, lay, side, cl[side], fr.surface.dip_dir)
                        res[lay][side] = [round(float(v), 4) for v in dd]
                        dists.append(dd)
                out["cutoffs"][name] = res
                out["uncut"] += [[name, lay] for lay, fac in fm.layers.items()
                                 if fac > 0.0 and lay not in fr.cutoffs]
            D = np.concatenate(dists) if dists else np.zeros(0)
            out["cutoff_nan"] = int(np.sum(~np.isfinite(D)))
            if np.isfinite(D).any():
                out["cutoff_mean"] = float(np.nanmean(D))
                out["cutoff_max"] = float(np.nanmax(D))
            step = {"name": "start"}

            def progress(name, i, n):
                step["name"] = name

            t0 = time.perf_counter()
            try:
                m2 = build_model(d2, evaluate=False, progress=progress)
            except Exception as e:
                return fail(f"build:v2:{step['name']}", e)
            kept["m2"] = m2
            try:
                m2.check()
            except Exception as e:
                return fail("check:v2", e)
            out["seconds"]["v2"] = time.perf_counter() - t0
            # The models' largest miss of a datum (build._data_fit) and the
            # derived model's build warnings.
            out["data_miss"] = [max((r["max_m"] for r in m.metadata["data_fit"].values()), default=0.0)
                                for m in (m1, m2)]
            out["build_warnings"] = [str(w)[:300] for w in m2.metadata.get("warnings", [])]
            e1, e2 = near_fault_errors([m1, m2], geo, np.asarray(ds1.boundary))
            out["error_v1"], out["error_v2"] = e1, e2
            out["ratio"] = e2 / e1 if e1 > 0 else float("nan")
            if not out["ratio"] <= ratio_limit:
                return _missed(out, "ratio",
                               f"error near the faults above {ratio_limit:g} x the model from the "
                               "true cutoffs; " + _derive_symptom(out),
                               f"v1 {e1:.3f} m, v2 {e2:.3f} m, ratio {out['ratio']:.2f}")
            return _held(out)
    finally:
        if tmp is not None:
            tmp.cleanup()
