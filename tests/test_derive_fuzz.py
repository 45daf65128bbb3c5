"""Property test of fault derivation end to end (derive_faults + build_model
+ Model.check) on inputs the derivation was not written for, and the
regression tests of what it found.

The property (the project's contract): on any input, derive_faults and
build_model either return a model whose check() passes, or raise a
DatasetError / GeometryError that names the fault or the layer. Nothing else
(IndexError, ZeroDivisionError, LinAlgError, a ValueError from scipy, ...).
"""
from __future__ import annotations

import math
from typing import Any, Callable, Dict

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import faultmesh
from faultmesh import derive
from faultmesh.dataset import Boreholes, Dataset, DatasetError, Fault, points_in_polygon

# ---------------------------------------------------------------------------
# The generator
# ---------------------------------------------------------------------------
# A case is a dict of choices (``case_params``) drawn through ``pick``; the
# committed test draws them from a seeded numpy RNG (``seeded_params``), the
# seed from hypothesis, and so does a local run over many seeds.
CHOICES: Dict[str, Any] = {
    "utm": [False, True],             # coordinates offset to x ~ 5e5, y ~ 7e6
    "rounding": [None, 0.01, 1.0],    # surveyors' rounding (m)
    "ring": ["rect", "skewed"],
    "size": [(600.0, 500.0), (3000.0, 2500.0), (8000.0, 3000.0)],
    "n_layers": [1, 2, 3, 4],
    "thickness": [5.0, 30.0, 120.0],
    "holes": ["sparse", "medium", "dense"],   # 3-10, 20-40, 80-150 vertical holes
    "holes_where": ["all", "one_side", "gap"],
    "n_faults": [1, 1, 1, 2],
    "second": ["crossing", "close"],
}
# More choices, drawn after those above; a missing key (e.g. in a regression
# test's explicit choices) takes the first option, the generator's behaviour
# before they were added.
EXTRAS: Dict[str, Any] = {
    # (options repeated: drawn more often; the cases that can only end in a
    # named error -- a layer without data, a fault wholly outside -- rarer)
    "tiny": [False, False, False, True],  # a 6 m x 5 m area, layers 0.5 m apart
    "layer_data": ["holes", "points", "both"],    # boreholes and/or extra points
    "odd_holes": [None, "duplicated", "on_fault", "on_ring"],
    "empty_layer": [False] * 7 + [True],  # a layer without any datum
    "group": [None, "G"],             # the two faults in one group
}


# Drawn after every choice above, so that those stay the ones the same seed
# drew before it was added: the top layer also picked on a grid (a seismic
# horizon over holes; the layers below take its shape,
# derive._conformable_points).
LAST: Dict[str, Any] = {"top_picks": [False, True],
                        # each fault's throw hint: none, its largest true
                        # throw, a hair or far too much; with or without its
                        # kind (the sense of its larger throws)
                        "hint": [None, None, "true", "tiny", "huge"],
                        "hint_kind": [False, True]}


def _fault_choices():
    return {
        "dip": ["gentle", "mid", "steep"],        # 5-20, 30-80, 85-89.9 degrees
        "shape": ["plane", "curved", "noisy"],
        "points": ["sticks", "scatter", "few", "duplicated", "collinear"],
        "length": ["short", "area", "long"],      # 0.2, 0.8-1.2, 3x the area
        "ends_inside": [False, True],
        "throw": ["normal", "reverse", "zero", "huge"],
    }


def _fault_extras():
    return {
        "axis_strike": [False, True],     # strike a multiple of 90 degrees
        "odd_points": [None, None, None, "vertical", "flat", "one_stick", "stick_per_point",
                       "outside"],
        # the fault points' elevations: over the layers and beyond, ending a
        # quarter of a layer thickness above or below them (a layer thick),
        # or a slice a quarter of a layer thick
        "depth": ["span", "above", "below", "thin"],
        # the throw along strike: constant, dying out to both ends, or
        # changing sense (a scissor fault)
        "profile": ["const", "fading", "scissor"],
    }


def case_params(pick: Callable[[str, Any], Any]) -> Dict[str, Any]:
    """The choices of one case; ``pick(name, options)`` picks one of the
    list ``options`` or, for a (lo, hi) tuple, a float in it."""
    p = {k: pick(k, v) for k, v in CHOICES.items()}
    p["faults"] = []
    for i in range(p["n_faults"]):
        fp = {k: pick(f"f{i}_{k}", v) for k, v in _fault_choices().items()}
        fp["strike"] = pick(f"f{i}_strike", (0.0, 360.0))
        fp["dip_t"] = pick(f"f{i}_dip_t", (0.0, 1.0))
        fp["anchor"] = (pick(f"f{i}_ax", (0.2, 0.8)), pick(f"f{i}_ay", (0.2, 0.8)))
        p["faults"].append(fp)
    p["seed"] = int(pick("seed", (0.0, 2.0 ** 31)))
    p.update({k: pick(k, v) for k, v in EXTRAS.items()})
    for i, fp in enumerate(p["faults"]):
        fp.update({k: pick(f"f{i}_{k}", v) for k, v in _fault_extras().items()})
    p.update({k: pick(k, v) for k, v in LAST.items()})
    return p


def _opt(p, key):
    """Choice ``key`` of ``p``; its first option when missing (EXTRAS, LAST)."""
    if key in p:
        return p[key]
    return {**EXTRAS, **_fault_extras(), **LAST}[key][0]


DIPS = {"gentle": (5.0, 20.0), "mid": (30.0, 80.0), "steep": (85.0, 89.9)}


def _fault_geometry(fp, p, W, H, i):
    """Anchor (2,), strike unit vector, unit normal (pointing to the hanging
    wall), dip in degrees of fault ``i``."""
    strike = fp["strike"]
    if _opt(fp, "axis_strike"):
        strike = 90.0 * round(strike / 90.0)
    if i == 1:
        first = p["faults"][0]["strike"]
        # crossing: strike differs by 40-90 degrees; close: nearly parallel.
        strike = first + (40.0 + 50.0 * fp["dip_t"] if p["second"] == "crossing" else 5.0)
    lo, hi = DIPS[fp["dip"]]
    dip = lo + (hi - lo) * fp["dip_t"]
    odd = _opt(fp, "odd_points")
    if odd == "vertical":
        dip = 90.0
    elif odd == "flat":
        dip = 0.5 + 4.5 * fp["dip_t"]
    a = np.deg2rad(strike)
    s = np.array([np.sin(a), np.cos(a)])
    d = np.array([s[1], -s[0]])                  # dip direction (right of strike)
    anchor = np.array([fp["anchor"][0] * W, fp["anchor"][1] * H])
    if i == 1 and p["second"] == "close":
        f0 = p["faults"][0]
        anchor = np.array([f0["anchor"][0] * W, f0["anchor"][1] * H]) + 0.04 * min(W, H) * d
    return anchor, s, d, dip


def _profile(g, xy):
    """The share (n,) of a fault's throw at ``xy`` along its strike."""
    anchor, s, L, kind = g[0], g[4], g[5], g[6]
    u = np.clip((xy - anchor) @ s / (0.5 * L), -1.0, 1.0)
    return {"const": np.ones(len(xy)), "fading": 1.0 - np.abs(u), "scissor": u}[kind]


def make_case(p: Dict[str, Any]) -> Dataset:
    """The dataset (format 2: faults as points only) of choices ``p``."""
    rng = np.random.default_rng(p["seed"])
    W, H = p["size"]
    thick = p["thickness"]
    if _opt(p, "tiny"):
        W, H, thick = 6.0, 5.0, 0.5
    origin = np.array([512345.67, 7012345.89]) if p["utm"] else np.zeros(2)
    if p["ring"] == "rect":
        ring = np.array([[0, 0], [W, 0], [W, H], [0, H]], dtype=float)
    else:
        ring = np.array([[0.15 * W, 0], [W, 0.1 * H], [0.85 * W, H], [0, 0.8 * H]])
    layers = [f"L{i + 1}" for i in range(p["n_layers"])]
    gx, gy = rng.uniform(-0.05, 0.05, 2)
    top = -200.0 + rng.uniform(-50, 50)

    def base(X, Y, li):
        return top - li * thick + gx * (X - W / 2) + gy * (Y - H / 2)

    z_lo = top - p["n_layers"] * thick - 0.05 * (W + H)
    z_hi = top + 0.05 * (W + H)
    geoms, faults, throws = [], [], []
    for i, fp in enumerate(p["faults"]):
        anchor, s, d, dip = _fault_geometry(fp, p, W, H, i)
        zr = base(anchor[0], anchor[1], 0) - 0.5 * (p["n_layers"] - 1) * thick
        tan = np.tan(np.deg2rad(dip))
        L = {"short": 0.2, "area": rng.uniform(0.8, 1.2), "long": 3.0}[fp["length"]] * max(W, H)
        u0, u1 = (-0.5 * L, 0.5 * L)
        if fp["ends_inside"]:
            u1 = rng.uniform(0.05, 0.3) * L
        bend = 0.1 * L if fp["shape"] == "curved" else 0.0

        def fault_xyz(U, Z, anchor=anchor, s=s, d=d, tan=tan, zr=zr, bend=bend, L=L):
            w = (zr - Z) / tan + bend * (2.0 * U / L) ** 2
            xy = anchor + U[:, None] * s + w[:, None] * d
            return np.column_stack([xy, Z])

        zmid = top - 0.5 * (p["n_layers"] - 1) * thick
        z_bot = top - (p["n_layers"] - 1) * thick
        zl, zh = {"span": (z_lo, z_hi), "above": (top + 0.25 * thick, top + 1.25 * thick),
                  "below": (z_bot - 1.25 * thick, z_bot - 0.25 * thick),
                  "thin": (zmid - 0.125 * thick, zmid + 0.125 * thick)}[_opt(fp, "depth")]
        kind_pts = fp["points"]
        odd = _opt(fp, "odd_points")
        if kind_pts == "sticks":
            nu, nz = rng.integers(3, 9), rng.integers(3, 8)
            U, Z = np.meshgrid(np.linspace(u0, u1, nu), np.linspace(zh, zl, nz))
            U, Z = U.ravel(), Z.ravel()
            sticks = np.searchsorted(np.unique(U), U)
        elif kind_pts == "few":
            n = rng.integers(3, 5)
            U, Z = rng.uniform(u0, u1, n), rng.uniform(zl, zh, n)
            sticks = None
        elif kind_pts == "collinear":
            t = np.linspace(0.0, 1.0, rng.integers(3, 12))
            U, Z = u0 + t * (u1 - u0), zh + t * (zl - zh)
            sticks = None
        else:
            n = rng.integers(15, 80)
            U, Z = rng.uniform(u0, u1, n), rng.uniform(zl, zh, n)
            sticks = None
        P = fault_xyz(U, Z)
        if fp["shape"] == "noisy":
            P = P + rng.normal(0.0, 0.01 * (zh - zl), P.shape)
        if kind_pts == "duplicated":
            P = np.concatenate([P, P[: max(1, len(P) // 3)]])
        if odd == "one_stick":
            sticks = np.zeros(len(P), dtype=np.int64)
        elif odd == "stick_per_point":
            sticks = np.arange(len(P))
        elif odd == "outside":
            P = P + np.append(2.0 * max(W, H) * d, 0.0)
        if sticks is not None and len(sticks) != len(P):
            sticks = np.resize(sticks, len(P))
        th = {"normal": 1.0, "reverse": -1.0, "zero": 0.0, "huge": 8.0}[fp["throw"]]
        throws.append(th * thick * rng.uniform(0.3, 1.0))
        geoms.append((anchor, d, tan, zr, s, L, _opt(fp, "profile")))
        faults.append((f"F{i + 1}", P, sticks))

    n_holes = {"sparse": rng.integers(3, 11), "medium": rng.integers(20, 41),
               "dense": rng.integers(80, 151)}[p["holes"]]
    xy = rng.uniform([0, 0], [W, H], size=(4 * n_holes + 20, 2))
    xy = xy[points_in_polygon(xy, ring)]

    def hanging_side(XY, Z, g):
        anchor, d, tan, zr = g[:4]
        # the fault's elevation under (x, y): above it is the hanging wall
        w = (XY - anchor) @ d
        if np.isinf(tan):
            return w > 0
        return Z > zr - w * tan

    a0 = geoms[0]
    wdist = (xy - a0[0]) @ a0[1]
    if p["holes_where"] == "one_side":
        xy = xy[wdist < 0]
    elif p["holes_where"] == "gap":
        xy = xy[np.abs(wdist) > 0.1 * min(W, H)]
    xy = xy[:n_holes]
    odd = _opt(p, "odd_holes")
    if odd == "duplicated" and len(xy):
        xy = np.concatenate([xy, xy[: max(1, len(xy) // 4)]])
    elif odd == "on_fault":
        # holes right on the first fault's trace at the layers' mid elevation
        a, d = geoms[0][:2]
        t = rng.uniform(-0.5, 0.5, 5) * min(W, H)
        s0 = np.array([-d[1], d[0]])
        xy = np.concatenate([xy, a + t[:, None] * s0])
        xy = xy[points_in_polygon(xy, ring)]
    elif odd == "on_ring":
        xy = np.concatenate([xy, ring, 0.5 * (ring + np.roll(ring, 1, axis=0))])
    def own_side_copies(XY, li):
        """Layer ``li`` at the places ``XY``: each copy (footwall: z0;
        hanging wall: z0 - throw) where it lies on its own side of every
        fault (a repeat or a gap otherwise), as (indices, z) per copy."""
        z0 = base(XY[:, 0], XY[:, 1], li)
        out = []
        for sides in range(2 ** len(geoms)):
            hang = [(sides >> j) & 1 for j in range(len(geoms))]
            z = z0 - sum(t * _profile(g, XY) for t, g, h in zip(throws, geoms, hang) if h)
            ok = np.ones(len(XY), dtype=bool)
            for g, h in zip(geoms, hang):
                ok &= hanging_side(XY, z, g) == bool(h)
            out.append((np.flatnonzero(ok), z[ok]))
        return out

    ids, xs, lays, zs = [], [], [], []
    for li, lay in enumerate(layers):
        if _opt(p, "empty_layer") and li == len(layers) // 2:
            continue
        for idx, z in own_side_copies(xy, li):
            for j, zj in zip(idx, z):
                ids.append(f"B{j + 1}")
                xs.append(xy[j])
                lays.append(lay)
                zs.append(zj)
    picks = np.zeros((0, 3))
    if _opt(p, "top_picks") and not (_opt(p, "empty_layer") and len(layers) == 1):
        # L1 also on a 24 x 24 grid (a seismic horizon)
        gxy = np.stack(np.meshgrid(np.linspace(0, W, 24), np.linspace(0, H, 24)), -1).reshape(-1, 2)
        gxy = gxy[points_in_polygon(gxy, ring)]
        for idx, z in own_side_copies(gxy, 0):
            picks = np.vstack([picks, np.column_stack([gxy[idx] + origin, z])])
    xs = np.asarray(xs, dtype=float).reshape(-1, 2) + origin
    zs = np.asarray(zs, dtype=float)
    ring = ring + origin
    r = p["rounding"]
    if r:
        xs, zs, ring = np.round(xs / r) * r, np.round(zs / r) * r, np.round(ring / r) * r
    flts = []
    hint = _opt(p, "hint")
    for (name, P, sticks), th in zip(faults, throws):
        P = P + np.append(origin, 0.0)
        if r:
            P = np.round(P / r) * r
        group = _opt(p, "group") if len(faults) > 1 else None
        # 1 micrometre and 100 km: a hint that moves nothing, and one that
        # moves a side past every elevation of the study area.
        size = {None: None, "true": max(abs(th), 0.01), "tiny": 1e-6, "huge": 1e5}[hint]
        kind = ("normal" if th >= 0.0 else "reverse") if _opt(p, "hint_kind") else None
        flts.append(Fault(name, kind, points=P, sticks=sticks, group=group,
                          throw=None if size is None else {"max": size}))
    lays = np.asarray(lays, dtype=str)
    ids = np.asarray(ids, dtype=str)
    points = {}
    if _opt(p, "layer_data") != "holes":
        # the same tops as extra points of each layer (all of them, or every
        # other hole's while the rest stay boreholes)
        sel = np.ones(len(ids), dtype=bool)
        if _opt(p, "layer_data") == "both":
            sel = np.array([h[-1] in "13579" for h in ids], dtype=bool)
        points = {lay: np.column_stack([xs[sel & (lays == lay)], zs[sel & (lays == lay)]])
                  for lay in layers}
        xs, zs, lays, ids = xs[~sel], zs[~sel], lays[~sel], ids[~sel]
    if len(picks):
        if r:
            picks = np.round(picks / r) * r
        points["L1"] = np.vstack([points["L1"], picks]) if "L1" in points else picks
    bh = Boreholes(ids, xs, lays, zs)
    return Dataset(name="fuzz", layers=layers, boundary=ring, boreholes=bh, points=points,
                   faults=flts)


def check_case(ds: Dataset) -> str:
    """Derive and build ``ds``: "ok" (the model's check() passed) or
    "error: ..." (a DatasetError / GeometryError naming a fault or a layer).
    Anything else raises (the property fails)."""
    names = [f.name for f in ds.faults] + list(ds.layers)
    try:
        d = derive.derive_faults(ds)
        m = faultmesh.build_model(d, evaluate=False)
    except (DatasetError, faultmesh.GeometryError) as e:
        msg = str(e)
        assert any(repr(n) in msg or f"'{n}'" in msg for n in names), \
            f"{type(e).__name__} names no fault or layer: {msg}"
        return f"error: {msg}"
    m.check()
    return "ok"


def seeded_params(seed: int) -> Dict[str, Any]:
    """The choices of case ``seed``: every pick from one numpy RNG (a case
    found locally is rerun by its seed)."""
    rng = np.random.default_rng([seed, 99])

    def pick(name, options):
        if isinstance(options, tuple):
            return float(rng.uniform(*options))
        return options[int(rng.integers(len(options)))]
    return case_params(pick)


# 40 cases, about 17 s. Locally its versions ran 2,139 cases (seeds 0-399,
# 1000-1338, 2000-2399, 3000-3399, 4000-4299, 5000-5299; the last 300 with
# this generator and the fixes: 162 built, 138 named errors, none other).
# Then 2,441 more: seeds 20000-21499 with every throw "huge" (866 built
# before the fixes; one MemoryError and 3 stitcher errors of a vertical
# fault on the boundary, all 4 building since) and 30000-30940 as drawn
# (562 built before; 1 of the stitcher's, building since). With the throw
# hints (LAST), seeds 91380-91679: 187 of 300 cases with a hint, 156 built,
# 144 named errors, none other.
@settings(max_examples=40, deadline=None, derandomize=True, database=None)
@given(st.integers(0, 2 ** 31))
def test_fuzz_derive_faults(seed):
    """Property: derive + build on generated format-2 grounds (module doc)
    either pass check() or raise a named DatasetError / GeometryError."""
    check_case(make_case(seeded_params(seed)))


# ---------------------------------------------------------------------------
# Regressions found by the property
# ---------------------------------------------------------------------------
def _flat_ground(fault_points, sticks=None, n=5):
    """Two flat layers (-100 m, -130 m, no offset anywhere) on an n x n grid
    of vertical holes over 1 km x 1 km, and fault F1 given by points."""
    g = (np.arange(n) + 0.5) * 1000.0 / n
    X, Y = np.meshgrid(g, g)
    xy = np.column_stack([X.ravel(), Y.ravel()])
    m = len(xy)
    bh = Boreholes(np.tile([f"B{i}" for i in range(m)], 2), np.vstack([xy, xy]),
                   np.repeat(["A", "B"], m), np.repeat([-100.0, -130.0], m))
    ring = np.array([[0, 0], [1000, 0], [1000, 1000], [0, 1000]], dtype=float)
    return Dataset(name="flat", layers=["A", "B"], boundary=ring, boreholes=bh,
                   faults=[Fault("F1", points=fault_points, sticks=sticks)])


def test_derived_dataset_of_a_fault_cutting_no_layer_builds():
    """Regression (fuzz: 4 noisy points of a 5 degree fault over a 600 m x
    500 m area, 3 layers 5 m thick, 8 holes, no layer cut at the fault):
    derive_faults gives the fault one plane trace of 2 points (no layer cut,
    warned); build_model of that derived dataset derived the fault again,
    now from that trace alone, and raised "fault 'F1': 2 point(s); a fault
    surface needs at least 3", although build_model of the original dataset
    passed. A fault an earlier derive_faults derived is not derived again,
    and its report is kept."""
    p = {"utm": False, "rounding": None, "ring": "skewed", "size": (600.0, 500.0),
         "n_layers": 3, "thickness": 5.0, "holes": "sparse", "holes_where": "all",
         "n_faults": 1, "second": "crossing", "seed": 1413342137,
         "faults": [{"dip": "gentle", "shape": "noisy", "points": "few", "length": "long",
                     "ends_inside": False, "throw": "huge", "strike": 284.2575,
                     "dip_t": 0.0466, "anchor": (0.5004, 0.6997)}]}
    d = derive.derive_faults(make_case(p))
    assert [len(t.plane) for t in d.faults[0].traces] == [2]
    assert any("no layer is cut" in w for w in d.derivation.warnings)
    m = faultmesh.build_model(d, evaluate=False)
    m.check()
    assert "no layer is cut" in " ".join(m.metadata["derived_faults"]["F1"]["warnings"])
    assert derive.derive_faults(d).derivation.faults["F1"] is d.derivation.faults["F1"]


def test_derived_fault_without_any_trace_is_left_out():
    """Regression (fuzz: 3 fault points of a 10 degree fault whose triangle
    lies mostly outside the study area, no throw in the data): the derived fault had no trace at
    all, and build_model raised "fault 'F1' has no trace" (fault_ends). Like
    a derived fault with plane traces only, it is left out of the model (the
    derivation warned that no layer is cut)."""
    P = np.array([[-549.0, 883.0, -391.0], [-299.0, -454.0, -428.0], [1201.0, -61.0, -140.0]])
    ds = _flat_ground(P)
    d = derive.derive_faults(ds)
    assert not d.faults[0].traces
    for data in (ds, d):
        m = faultmesh.build_model(data, evaluate=False)
        m.check()
        assert not m.faults



def test_derived_fault_with_equal_plane_traces_is_left_out():
    """Regression (fuzz: a 13 degree fault given by 3-4 noisy points on one
    stick, one layer, 3-10 holes all on the footwall side): no layer is cut,
    and the fault's 9 plane traces of 3 points gave two equal centres, so
    build_model raised a GeometryError naming nothing, "faults: zero-length
    direction" (fault_ends, the strike between the first two traces). A
    derived fault that cuts no layer has no patch and no surface in the
    model, so build_model now leaves it out before taking its ends."""
    p = {"utm": False, "rounding": None, "ring": "skewed", "size": (8000.0, 3000.0),
         "n_layers": 1, "thickness": 30.0, "holes": "sparse", "holes_where": "one_side",
         "n_faults": 1, "second": "crossing", "seed": 1219653818, "odd_holes": None,
         "faults": [{"dip": "gentle", "shape": "noisy", "points": "few", "length": "long",
                     "ends_inside": True, "throw": "huge", "strike": 359.490136238668,
                     "dip_t": 0.610972055786287, "anchor": (0.7749434644804292, 0.41285301069865976),
                     "odd_points": "one_stick"}]}
    ds = make_case(p)
    d = derive.derive_faults(ds)
    assert d.faults[0].traces and not any(tr.layers for tr in d.faults[0].traces)
    for data in (ds, d):
        m = faultmesh.build_model(data, evaluate=False)
        m.check()
        assert not m.faults


def test_steep_fault_carried_onto_the_boundary_builds():
    """Regression (fuzz seed 2287 of generator v2, here with a fault of 87.5
    degrees: 600 m x 500 m, 1 m rounding, one layer, holes away from the
    fault and at the ring's corners and side midpoints, throw fading along
    strike, fault points in a 30 m slice): derive (kind normal) made L1's
    patch reach x = 0 with three outline vertices at one XY, (0, 375.42),
    and the stitcher rejected it ("stitch: layer 'L1', patch 'F1': the
    patch outline is not simple in XY: edges (11, 12) and (13, 14) meet":
    (13, 14) has zero length; at 90 degrees the same with four vertices at
    (600, 43.57); seed 4005, a vertical fault, on a slanted side). derive's
    own check of the patch (_patch_problem -> faults._outline_crossings)
    exempted every pair of outline edges whose four ends are on the
    boundary; the stitcher (stitch_outline.cpp) only pairs of edges each
    running along one side between two different positions. The check now
    follows the stitcher, and derive drops L1 from the sections that made
    the patch cross itself (2 warnings), so the model builds with F1."""
    p = {"utm": False, "rounding": 1.0, "ring": "rect", "size": (600.0, 500.0), "n_layers": 1,
         "thickness": 120.0, "holes": "medium", "holes_where": "gap", "n_faults": 1,
         "second": "close", "seed": 566205726, "tiny": False, "layer_data": "holes",
         "odd_holes": "on_ring", "empty_layer": False, "group": "G",
         "faults": [{"dip": "steep", "shape": "plane", "points": "sticks", "length": "area",
                     "ends_inside": False, "throw": "normal", "strike": 118.97643867452724,
                     "dip_t": 0.5, "anchor": (0.2822838654385024, 0.5653426466236346),
                     "axis_strike": False, "odd_points": None, "depth": "thin",
                     "profile": "fading"}]}
    d = derive.derive_faults(make_case(p))
    m = faultmesh.build_model(d, evaluate=False)
    m.check()
    assert "F1" in m.faults and "L1" in m.metadata["faults"]["F1"]["layers"]

def test_fault_crossing_the_area_at_one_cut_gets_sections_a_cut_step_apart():
    """Regression (fuzz seed 21032 with every throw "huge": F2 given by 9
    points on a line 7 km long, 0.3 m of noise off it, in a 30 m slice):
    its fitted surface is a sliver whose extent crosses the study area at
    one of _section_grid's 128 cuts along strike, so the crossing had
    length 0 (floored at 1e-9 of u), the section spacing an eighth of that
    (6e-8 m), and _joint_setup's throw knots every half spacing over the
    fit's frame asked for 1.1e11 values: MemoryError (812 GiB) out of
    derive_faults. A crossing shorter than one cut step now spans that
    step around its cuts (spacing 6.8 m); the fault cuts no layer there
    (warned) and the model builds without it."""
    p = {"utm": False, "rounding": 0.01, "ring": "skewed", "size": (3000.0, 2500.0), "n_layers": 2,
         "thickness": 120.0, "holes": "sparse", "holes_where": "all", "n_faults": 2,
         "second": "crossing", "seed": 377938614, "tiny": False, "layer_data": "holes",
         "odd_holes": "on_ring", "empty_layer": False, "group": None,
         "faults": [{"dip": "steep", "shape": "noisy", "points": "duplicated", "length": "short",
                     "ends_inside": True, "throw": "huge", "strike": 99.79835810569857,
                     "dip_t": 0.4863853884707513, "anchor": (0.6378751249320556, 0.5640206018540508),
                     "axis_strike": False, "odd_points": None, "depth": "thin", "profile": "fading"},
                    {"dip": "steep", "shape": "noisy", "points": "collinear", "length": "long",
                     "ends_inside": True, "throw": "huge", "strike": 304.15165131976715,
                     "dip_t": 0.19507504678011678, "anchor": (0.5743373589354267, 0.7266132653277215),
                     "axis_strike": False, "odd_points": None, "depth": "thin", "profile": "const"}]}
    d = derive.derive_faults(make_case(p))
    assert any("'F2': no layer is cut" in w for w in d.derivation.warnings)
    faultmesh.build_model(d, evaluate=False).check()


def test_a_derived_fault_that_cuts_no_layer_meets_no_other_fault_s_patches():
    """Regression (the test above on a fresh install, numpy 2.4.6 and scipy
    1.17.1): F2 cuts no layer, so derive gives it no traces, and the check
    whether the patches of two faults that meet touch (derive._patches_meet)
    asked for its ends first: "GeometryError: fault 'F2' has no trace" out
    of derive_faults. A fault with no layer in common with the other has no
    patch to meet."""
    ring = np.array([[0.0, 0.0], [1000.0, 0.0], [1000.0, 800.0], [0.0, 800.0]])
    a = Fault("F1", kind="normal", derived=True)
    b = Fault("F2", kind="reverse", derived=True)
    assert derive._patches_meet(a, b, ring) is None


# Its derived faults cut no layer: derive took the largest throw of layers
# with only NaN throws through np.nanmax, which warned "All-NaN slice
# encountered" (now without the warning).
@pytest.mark.filterwarnings("error:All-NaN slice:RuntimeWarning")
def test_crossing_layers_name_where_and_the_faults_that_cut_nothing(monkeypatch):
    """Found by the property (fuzz seed 20826 with every throw "huge": 4
    layers 120 m apart, a 3 degree fault given in a 30 m slice and a
    vertical one given 30-150 m above the layers, throws of 370-960 m): an
    unbuildable input -- neither fault's points reach the layers, derive
    warns that each cuts no layer and the builder leaves both out, so the
    continuous layers carry the whole offset and cross. The error named
    only the layers and asked whether their order was right
    ("repair_crossings('L3', 'L4'): ... 'L4' lies above 'L3' over a large
    area; is the layer order right?"), where L3 and L4 did not even cross
    before the repair (L1/L2 did, by 356 m). It now says where each pair
    from the top crosses before the repair, and that F1 and F2 cut no layer
    and are left out of the model.

    Since the derived points go into the built model, this case builds: L1
    (holes 457 m apart) takes the shape of L2 (281 m), offsets included, and
    no longer crosses it. The message is tested on the case as it was, with
    no layer taken as sparse, and with the repair's former insertion budget
    (here its floor, 10,000 points: the layers have a few hundred vertices
    each): with the present one (32 per
    vertex of both layers; layer_tin.hpp, RepairOptions) the repair ends on
    that case as well, with each layer under the one above where they
    crossed (L2 lies above L1 at fewer than half its data, so the layer
    order stands); and with the former budget too, now that a layer with no
    datum near a datum of the layer under it that lies above it is raised
    to it first (build._raise_over_data), so the message is tested with
    that off as well."""
    p = {"utm": True, "rounding": 0.01, "ring": "rect", "size": (8000.0, 3000.0), "n_layers": 4,
         "thickness": 120.0, "holes": "dense", "holes_where": "gap", "n_faults": 2, "second": "close",
         "seed": 1841981165, "tiny": False, "layer_data": "both", "odd_holes": None,
         "empty_layer": False, "group": None,
         "faults": [{"dip": "steep", "shape": "curved", "points": "duplicated", "length": "long",
                     "ends_inside": False, "throw": "huge", "strike": 201.068569695313,
                     "dip_t": 0.4884599518033078, "anchor": (0.3560846993655812, 0.6108481032891144),
                     "axis_strike": False, "odd_points": "flat", "depth": "thin", "profile": "const"},
                    {"dip": "steep", "shape": "curved", "points": "collinear", "length": "short",
                     "ends_inside": True, "throw": "huge", "strike": 109.031254598627,
                     "dip_t": 0.346959065768478, "anchor": (0.5352610052850173, 0.5379839722625801),
                     "axis_strike": False, "odd_points": "vertical", "depth": "above",
                     "profile": "const"}]}
    assert check_case(make_case(p)) == "ok"
    monkeypatch.setattr(derive, "CONFORMABLE_SPARSE", math.inf)
    assert check_case(make_case(p)) == "ok"
    former = faultmesh.build.repair_stack
    monkeypatch.setattr(faultmesh.build, "repair_stack",
                        lambda *a, **k: former(*a, max_inserted_per_vertex=0.0, **k))
    assert check_case(make_case(p)) == "ok"
    monkeypatch.setattr(faultmesh.build, "UPPER_DATA_GAP", math.inf)
    msg = check_case(make_case(p))
    assert msg.startswith("error: repair_crossings('L3', 'L4')"), msg
    assert "before the repair 'L2' lies up to 356.3 m above 'L1', most at (516476.7, 7013831.3)" in msg
    assert "fault(s) 'F1', 'F2' cut no layer" in msg


# ---------------------------------------------------------------------------
# Found by the property: a named error on input that should build (fixed)
# ---------------------------------------------------------------------------
def test_holes_at_midpoints_of_slanted_sides_build():
    """Regression (fuzz, no fault needed): holes exactly at the midpoints of
    two sides of a skewed quadrilateral, e.g. (2775, 1375) on (3000, 250) ->
    (2550, 2500): the builder raised "LayerTin('A'): cannot protect the
    study-area boundary near (2775, 1375): a data point lies on the boundary
    within rounding but was not snapped onto it". The point is exactly on
    the side (the policy rightly leaves it); StudyArea.locate gives it arc
    length 1147.2793905583765, the side's densification point L * j / k
    (k even, which depends on the data count) 1147.2793905583767: both were
    placed at (2775, 1375), the LayerTin kept both (it merged equal arc
    lengths only), and the protection could not split the zero-length
    piece. LayerTin now lets a datum replace a densification point within
    its shortest piece (ctest LayerTin.DataAtTheMidpointsOfSlantedSides...)."""
    ring = np.array([[450.0, 0.0], [3000.0, 250.0], [2550.0, 2500.0], [0.0, 2000.0]])
    mids = 0.5 * (ring + np.roll(ring, 1, axis=0))
    xy = np.vstack([np.random.default_rng(0).uniform([800, 600], [2200, 1800], (8, 2)), mids[[1, 2]]])
    n = len(xy)
    bh = Boreholes([f"B{i}" for i in range(n)], xy, ["A"] * n, -100.0 + 0.01 * xy[:, 0])
    faultmesh.build_model(Dataset(name="mid", layers=["A"], boundary=ring, boreholes=bh),
                          evaluate=False).check()


# ---------------------------------------------------------------------------
# Found by the property: the stitcher (C++)
# ---------------------------------------------------------------------------
def test_vertical_fault_carried_onto_the_boundary_builds():
    """Regression (fuzz seed 20903 with every throw "huge"; also 20811,
    21103 and, with the generator's own throws, 30741: 4 of 2,441 cases,
    every one a vertical fault, dip 90, whose patch is carried along strike
    onto the study boundary). A vertical fault's footwall and hanging-wall cutoffs
    lie at one XY; carried onto the boundary they become two outline
    vertices at one point of it, (127.133, 0) here at z -261.02 and
    -260.97 (throw 0.05 m), joined by an outline edge of length 0. derive's
    patch check passes it (faults._outline_crossings: the outline edges on
    either side run along the side between different positions), the
    stitcher rejects it: "stitch: layer 'L1', patch 'F1': the gap polygon
    touches itself at vertex (512472.8034, 7012345.89) (the fault patch is
    too close to another patch or to the boundary)" -- at a layer vertex
    (stitch_contours.cpp, build_gap_polygons' chaining). The stitcher's
    outline step (stitch_outline.cpp) classified that edge as inside the
    area, since its ends have the same position on the side, and it went
    into the gap polygon. An edge whose ends are one point of a side now
    runs along that side (ctest
    Stitch.VerticalFaultCarriedOntoTheStudyBoundaryStitches): all four
    cases build and pass check() (moving the second vertex 1 cm along the
    side had done the same). derive's check follows: it no longer drops
    the layers of the end sections of such a patch (here 15 drops)."""
    p = {"utm": True, "rounding": None, "ring": "rect", "size": (600.0, 500.0), "n_layers": 3,
         "thickness": 5.0, "holes": "medium", "holes_where": "all", "n_faults": 1,
         "second": "crossing", "seed": 1948886327, "tiny": False, "layer_data": "both",
         "odd_holes": "on_ring", "empty_layer": False, "group": None,
         "faults": [{"dip": "gentle", "shape": "curved", "points": "sticks", "length": "area",
                     "ends_inside": False, "throw": "huge", "strike": 181.19174945446585,
                     "dip_t": 0.018239964067449543, "anchor": (0.2650415617755283, 0.43926457220709225),
                     "axis_strike": True, "odd_points": "vertical", "depth": "span", "profile": "const"}]}
    d = derive.derive_faults(make_case(p))
    # derive's patch check is the stitcher's (triangles_at_outline_crossings):
    # it dropped the layers of 5 end sections, 15 warnings, before.
    assert not any("made the patch cross itself" in w for w in d.derivation.warnings)
    faultmesh.build_model(d, evaluate=False).check()


def test_fault_points_nearly_on_a_line_are_named_as_such():
    """Regression (fuzz case 20024: 3-11 collinear points of a gentle fault
    3x the area long, above the layers, rounded to the centimetre): the
    rounding lifts the points off their line by 0.3 m over 6.6 km, past
    fault_surface's one-line test, and the sliver they span crosses the
    area at no section. The error said only that its extent does not cross
    the study area; it now also says why."""
    out = check_case(make_case(seeded_params(20024)))
    assert out.startswith("error: ") and "'F1'" in out, out
    assert "nearly on one line" in out and "does not cross the study area" in out, out


def test_a_short_thin_steep_curved_fault_is_not_refused_as_flat():
    """Regression (fuzz case 61216, found comparing 1,250 new cases between
    the nineteenth and twentieth stops' code; the other 1,249 gave the same
    outcome): a steep fault curved along strike, short and thin (its sticks
    span little depth), given as sticks with a vertical odd point, was
    refused: "its points lie in a horizontal plane" (its least-squares
    plane crossed its bend). The mean of its picks' local orientations
    (derive._mean_orientation) has another projection axis and is its
    normal now: it derives, builds and passes check()."""
    assert check_case(make_case(seeded_params(61216))) == "ok"


def test_a_fault_point_far_off_the_others_is_named():
    """Regression (the fuzz of the v2 input: one of ten fault points with
    z = 1e14, inside the accepted coordinate range): the error said the
    points lie on one line, which is untrue of the nine; it names the far
    one now."""
    P = np.array([[480.0 + 20.0 * (i % 2), 100.0 * i, -100.0 - 30.0 * (i % 2)] for i in range(10)])
    P[6, 2] = 1e14
    with pytest.raises(faultmesh.GeometryError, match=r"lie on one line .*; the point \(480, 600, "
                                                      r"1e\+14\) lies 1e\+14 m from the others' median"):
        derive.derive_faults(_stepped_ground(P))


def test_a_saved_derived_dataset_whose_faults_cut_no_layer_builds_the_same_model(tmp_path):
    # Case 47001: both faults' points miss the layers ("no layer is cut",
    # plane traces only); the build leaves them out. Saved, such a fault
    # was read back as one to derive again from its plane traces (its
    # points used up), and a fault marked derived was at first refused for
    # having no cutoffs: it is a derived fault that cuts nothing.
    from dataclasses import replace

    from faultmesh.dataset import load_dataset

    # Its faults' points come one stick per point, which no file may hold
    # (test_sticks_a_file_refuses_are_refused_in_memory_too); without the
    # labels the derivation is the same (a stick of one point adds no
    # segment to densify).
    ds = make_case(seeded_params(47001))
    ds = replace(ds, faults=[replace(f, sticks=None) for f in ds.faults])
    d = derive.derive_faults(ds)
    assert [(f.derived, any(t.layers for t in f.traces)) for f in d.faults] == [(True, False)] * 2
    m = faultmesh.build_model(d, evaluate=False)
    back = load_dataset(d.save(tmp_path / "o", version=2))
    assert [f.derived for f in back.faults] == [True, True]
    assert not any(derive.needs_derivation(f) for f in back.faults)
    m2 = faultmesh.build_model(back, evaluate=False)
    m2.check()
    assert set(m.surfaces) == set(m2.surfaces)
    for k in m.surfaces:
        np.testing.assert_allclose(m2.surfaces[k].vertices, m.surfaces[k].vertices, rtol=0, atol=1e-6)
        np.testing.assert_array_equal(m2.surfaces[k].triangles, m.surfaces[k].triangles)


def test_a_layer_with_two_data_is_refused_by_the_build_as_by_the_loader(tmp_path):
    # Case 47040: layer L1 has 2 data points inside the study area. The
    # loader refuses such a layer (a stratum TIN needs 3), but build_model
    # built it in memory (the C++ TIN takes any number >= 1), so a dataset
    # that built could not be loaded back once saved. One rule now
    # (dataset.check_layer_data), the same message from both.
    from faultmesh.dataset import DatasetError, load_dataset

    ds = make_case(seeded_params(47040))
    assert len(ds.layer_points("L1")) == 2
    with pytest.raises(DatasetError, match=r"layer 'L1': has 2 data point\(s\) inside the study area .* "
                                           "needs at least 3"):
        faultmesh.build_model(ds, evaluate=False)
    ds.save(tmp_path / "o", version=2)
    with pytest.raises(DatasetError, match=r"dataset.json: layer 'L1': has 2 data point\(s\) inside"):
        load_dataset(tmp_path / "o" / "dataset.json")


@pytest.mark.parametrize("seed, fault, point, why, row_why", [
    # Every point its own stick (odd_points "stick_per_point").
    (51007, "F1", 0, r"stick '0' has one point; a stick is a polyline of at least 2 points",
     r"row 2, field 'stick': stick '0' has one point"),
    # One stick of collinear points rounded to 1 m: two consecutive points coincide.
    (51020, "F2", 1, r"the point repeats the previous point of stick '0' \(point 0\)",
     r"row 3, fields 'x', 'y', 'z': the point repeats the previous point of stick '0' \(row 2\)"),
])
def test_sticks_a_file_refuses_are_refused_in_memory_too(tmp_path, seed, fault, point, why, row_why):
    # Fuzz cases 51007 and 51020: derive and build took a fault whose sticks
    # a fault-points file may not have (a stick of one point, a point that
    # repeats the one before it on its stick), so the dataset saved and its
    # loader refused it (12 of the 100 cases 51000-51099). One rule now
    # (fault_inputs.stick_problem, dataset.check_fault_sticks), naming the
    # fault and the point in memory, the file's row when loaded.
    from faultmesh.dataset import DatasetError, load_dataset

    ds = make_case(seeded_params(seed))
    msg = rf"fault '{fault}', point {point}: {why}"
    with pytest.raises(DatasetError, match=msg):
        derive.derive_faults(ds)
    with pytest.raises(DatasetError, match=msg):
        faultmesh.build_model(ds, evaluate=False)
    ds.save(tmp_path / "o", version=2)
    with pytest.raises(DatasetError, match=rf"fault_{fault}_points.csv, {row_why}"):
        load_dataset(tmp_path / "o" / "dataset.json")


def test_stick_rules_in_memory_follow_each_stick_through_interleaved_points():
    # In memory a stick's points may be interleaved with another's (save
    # writes them stick by stick): the rules apply to each stick's own
    # sequence, not to neighbouring rows.
    from faultmesh.fault_inputs import stick_problem

    P = np.array([[0.0, 0, 0], [5, 0, 0], [0, 1, -1], [5, 1, -1], [0, 1, -1], [5, 2, -2]])
    # a: rows 0, 2, 4; b: rows 1, 3, 5. Rows 2 and 4 coincide and are consecutive on stick a.
    assert stick_problem(P, np.array(["a", "b", "a", "b", "a", "b"])) == \
        (4, 2, "the point repeats the previous point of stick 'a'")
    # Rows 3 and 4 coincide in x only: fine.
    assert stick_problem(P[:4], np.array(["a", "b", "a", "b"])) is None
    # Labels compared as text, as a file's: 1 and "1" are one stick.
    assert stick_problem(P[:3], np.array([1, "1", 2], dtype=object)) == \
        (2, None, "stick '2' has one point; a stick is a polyline of at least 2 points")


def test_folded_patch_reaching_past_its_outline_loses_sections_in_derive_not_the_build(monkeypatch):
    # Fuzz case 51074: a nearly vertical (89.4 degrees) reverse fault given
    # as one stick, throw several layer thicknesses; derive replaced two
    # sections' wrong-sense throws and handed over an L1 patch whose outline
    # was simple but whose sheets did not cover their XY image once, which
    # the stitcher refuses ("does not cover its XY image once"). derive's
    # patch check now asks the stitcher's third question too, and drops the
    # sections that make it so: the model builds and passes check(). The
    # case was found with the fading-throw fit's former grid of profiles,
    # with which its cutoffs still make such a patch (with the fit's former
    # smoothing, a twentieth of the data spacing, derive.DECAY_SMOOTHING
    # 0); on today's grid and smoothing they do not (tests/test_build.py
    # has what they make there instead).
    ds = make_case(seeded_params(51074))
    assert check_case(ds) == "ok"
    former = tuple((a, b) for a in (0.0, 50.0, 150.0) for b in (100.0, 200.0, 350.0, 600.0)) + (None,)
    monkeypatch.setattr(derive, "DECAY_PROFILES", former)
    monkeypatch.setattr(derive, "DECAY_SMOOTHING", 0.0)
    assert check_case(ds) == "ok"
    d = derive.derive_faults(ds)
    assert any("reach past its outline" in w for w in d.derivation.warnings)


def test_a_saved_derived_fault_without_any_trace_loads_and_is_left_out(tmp_path):
    # Fuzz case 52053: F2's 50 points (duplicated, a gentle plane, no throw)
    # give no plane trace in the study area; the derived dataset keeps F2
    # without geometry and the build leaves it out. Saved, its loader
    # refused the fault ("needs its geometry"). A fault marked derived may
    # have none; loaded, it is left out of the same model.
    from faultmesh.dataset import load_dataset

    d = derive.derive_faults(make_case(seeded_params(52053)))
    f2 = d.fault("F2")
    assert f2.derived and not f2.traces and f2.points is None and f2.surface is None
    m = faultmesh.build_model(d, evaluate=False)
    back = load_dataset(d.save(tmp_path / "o", version=2))
    assert back.fault("F2").derived and not back.fault("F2").traces
    m2 = faultmesh.build_model(back, evaluate=False)
    m2.check()
    assert set(m.faults) == set(m2.faults) and set(m.surfaces) == set(m2.surfaces)
    for k in m.surfaces:
        np.testing.assert_allclose(m2.surfaces[k].vertices, m.surfaces[k].vertices, rtol=0, atol=1e-6)
        np.testing.assert_array_equal(m2.surfaces[k].triangles, m.surfaces[k].triangles)


def _stepped_ground(fault_points, sticks=None, n=6):
    """Two layers offset 20 m across x = 500 (holes on an n x n grid over
    1 km x 1 km) and fault F1 given by points."""
    g = (np.arange(n) + 0.5) * 1000.0 / n
    X, Y = np.meshgrid(g, g)
    xy = np.column_stack([X.ravel(), Y.ravel()])
    m = len(xy)
    drop = np.where(xy[:, 0] > 500.0, -20.0, 0.0)
    bh = Boreholes(np.tile([f"B{i}" for i in range(m)], 2), np.vstack([xy, xy]),
                   np.repeat(["A", "B"], m), np.r_[-100.0 + drop, -130.0 + drop])
    ring = np.array([[0, 0], [1000, 0], [1000, 1000], [0, 1000]], dtype=float)
    return Dataset(name="stepped", layers=["A", "B"], boundary=ring, boreholes=bh,
                   faults=[Fault("F1", points=fault_points, sticks=sticks)])


def test_a_fault_a_centimetre_long_gets_no_more_throw_knots_than_its_frame_resolves(monkeypatch):
    """Regression (the fuzz of the v2 input: three fault points 1 cm apart
    derived for a minute, 1 mm apart for over ten): the throw's knots went
    every half section spacing (an eighth of the fault's length) over the
    whole frame of the layer's data -- 1.1e7 knots on a grid of 6 x 6
    nodes, 20 s per solve. They go no closer than an eighth of the frame's
    cell now."""
    seen = []
    real = derive._joint_setup

    def spy(D, split, frame, spacing, *rest):
        out = real(D, split, frame, spacing, *rest)
        if out is not None:
            seen.append((len(out[-1]), frame.nu))
        return out

    monkeypatch.setattr(derive, "_joint_setup", spy)
    P = np.array([[500.0, 500.0, -50.0], [500.0, 500.01, -50.0], [500.005, 500.0, -50.01]])
    try:
        derive.derive_faults(_stepped_ground(P))
    except (DatasetError, ValueError):
        pass        # what it says of such a fault is not the point; how long it takes is
    assert seen and all(k <= 8 * (nu - 1) + 2 for k, nu in seen), seen


def test_sticks_a_millimetre_apart_are_split_into_few_pieces():
    """Regression (the fuzz of the v2 input: two sticks 160 m tall 1 cm
    apart, 92 s of derivation; 1 mm apart, over 5 min): densified to the
    median spacing of their points, the sticks' spacing, 16 000 points per
    stick. A segment goes into at most STICK_SPLIT_MAX pieces."""
    P = np.array([[x, 500.0 + dy, z] for dy in (0.0, 0.001) for x, z in ((450.0, 20.0), (500.0, -60.0),
                                                                          (550.0, -140.0))])
    sticks = np.repeat(["s0", "s1"], 3)
    out = derive._densify_sticks(P, sticks)
    assert len(P) < len(out) <= len(P) + 4 * (derive.STICK_SPLIT_MAX - 1)
    # Sticks sampled evenly are left as they are.
    even = np.array([[x, y, -x] for y in (0.0, 300.0) for x in (0.0, 100.0, 200.0)])
    assert len(derive._densify_sticks(even, np.repeat(["a", "b"], 3))) == 6


def test_a_spacing_that_asks_for_too_many_sections_is_refused_naming_the_fault():
    """Regression (the fuzz of the v2 input: `faultmesh derive --spacing
    1e-9` ended in a MemoryError of 7 TiB, --spacing 0.001 ran for
    minutes)."""
    P = np.array([[x, y, -100.0 - (x - 500.0) * 1.7] for x in (480.0, 520.0) for y in (-50.0, 500.0, 1050.0)])
    with pytest.raises(ValueError, match=r"spacing 1e-09 m gives \d+ sections along fault 'F1' "
                                         r"\(.* m along strike in the study area\); at most 10000"):
        derive.derive_faults(_stepped_ground(P), spacing=1e-9)
