"""Fault derivation on block-faulted grounds from a generator of their own,
independent of :mod:`faultmesh.grounds` (whose faults bend their hanging
walls: a throw constant near the fault that fades away from it).

Here a fault is a plane with the same throw everywhere (a block offset:
no drag, no taper), the layers are planes or smooth undulations, the
horizon picks lie on a jittered grid with a gap on both sides of the fault
(as seismic picks stop short of it), noisy by a few decimetres and rounded
to the centimetre, and the fault comes as sticks; half of the grounds at UTM
coordinates. What the derivation can know is then exact: on plane layers
the cutoffs are the planes' intersections with the fault, so their error
is the data's noise carried across the gap, nothing else.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

import faultmesh as fm
import faultmesh.faults as faults_module
from faultmesh.dataset import Dataset, Fault, load_dataset, points_in_polygon
from faultmesh.derive import derive_faults

#: Standard deviation (m) of the picks' noise: a seismic horizon picked to
#: a few milliseconds.
NOISE = 0.3


@dataclass
class BlockGround:
    dataset: Dataset
    kind: str
    throw: float                                   # vertical, > 0, of the top layer
    layer_z: Callable[[int, np.ndarray, np.ndarray], np.ndarray]   # unfaulted top of layer i
    throw_growth: float = 0.0                      # the throw's growth per layer down

    def side_z(self, i: int, side: str, x, y) -> np.ndarray:
        """The true elevation of layer ``i`` on ``side`` ("foot", "hanging")."""
        t = self.throw + self.throw_growth * i
        dz = 0.0 if side == "foot" else (-t if self.kind == "normal" else t)
        return self.layer_z(i, np.asarray(x, float), np.asarray(y, float)) + dz


def block_ground(seed: int, undulation: bool = True, sparse_every: int = 1,
                 throw_growth: float = 0.0) -> BlockGround:
    """Ground ``seed``: 1-4 layers 15-80 m thick dipping up to 0.08 (with
    ``undulation``, plus a sine of amplitude up to 20 m and wavelength
    0.8-3 km), one plane fault (dip 40-80 degrees, any strike, through the
    middle third of a 1.5-5 km area) with a constant vertical throw of 8-60
    m, normal (70 %) or reverse; picks every 40-120 m (sparser on large
    areas: at most about 1,000 per layer), none within 0-300 m
    (horizontally, at the layer's elevation) of the fault; sticks every
    150-300 m along strike, points 25 m apart from 100 m above the top layer
    to 100 m below the bottom one. ``sparse_every`` > 1: every layer but the
    top one is known only at every ``sparse_every``-th pick place along both
    grid axes (drillholes under a horizon picked on seismic sections).
    ``throw_growth``: each layer's throw is this much (m) larger than the
    one's above (a throw that grows with depth: the hanging wall's layers
    thicker than the footwall's)."""
    rng = np.random.default_rng([seed, 77])
    W, H = rng.uniform(1500.0, 5000.0, 2)
    off = np.array([rng.uniform(3e5, 7e5), rng.uniform(4e6, 7e6)]) if rng.random() < 0.5 \
        else np.zeros(2)
    nl = int(rng.integers(1, 5))
    thick = rng.uniform(15.0, 80.0, nl)
    gx, gy = rng.uniform(-0.08, 0.08, 2)
    amp = rng.uniform(0.0, 20.0) if undulation else 0.0
    wl, ph = rng.uniform(800.0, 3000.0), rng.uniform(0.0, 2 * np.pi, 2)
    top = -500.0

    def layer_z(i, X, Y):
        X, Y = X - off[0], Y - off[1]
        return (top - thick[:i].sum() + gx * (X - W / 2) + gy * (Y - H / 2)
                + amp * np.sin(2 * np.pi * X / wl + ph[0]) * np.cos(2 * np.pi * Y / wl + ph[1]))

    kind = "normal" if rng.random() < 0.7 else "reverse"
    throw = float(rng.uniform(8.0, 60.0))
    tan = np.tan(np.deg2rad(rng.uniform(40.0, 80.0)))
    a = np.deg2rad(rng.uniform(0.0, 180.0))
    along, down = np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])
    anchor = off + np.array([W, H]) * rng.uniform(0.35, 0.65, 2)
    z_mid = top - thick.sum() / 2

    def fault_z(X, Y):
        return z_mid - ((X - anchor[0]) * down[0] + (Y - anchor[1]) * down[1]) * tan

    # at most about 1,000 picks per layer (a test's time: the derivation
    # takes 3-5 s for 1,000 picks on 3 layers, 40 s for 2,400 over 3.6 km x
    # 3.2 km), so 50 m apart on the smallest areas, 160 m on the largest
    spacing = max(rng.uniform(40.0, 120.0), float(np.sqrt(W * H / 1000.0)))
    gap = rng.uniform(0.0, 300.0)
    X, Y = np.meshgrid(np.arange(spacing / 2, W, spacing), np.arange(spacing / 2, H, spacing))
    I, J = np.meshgrid(np.arange(X.shape[1]), np.arange(X.shape[0]))
    coarse = ((I % sparse_every == 0) & (J % sparse_every == 0)).ravel()
    X = off[0] + X.ravel() + rng.uniform(-0.3, 0.3, X.size) * spacing
    Y = off[1] + Y.ravel() + rng.uniform(-0.3, 0.3, Y.size) * spacing
    ring = off + np.array([[0.0, 0.0], [W, 0.0], [W, H], [0.0, H]])
    inside = points_in_polygon(np.column_stack([X, Y]), ring)
    X, Y, coarse = X[inside], Y[inside], coarse[inside]
    points = {}
    for i in range(nl):
        z0, f = layer_z(i, X, Y), fault_z(X, Y)
        dz_hang = -(throw + throw_growth * i) if kind == "normal" else throw + throw_growth * i
        known = coarse if i else np.ones(len(X), dtype=bool)
        foot = known & (z0 < f) & ((f - z0) / tan >= gap)
        hang = known & (z0 + dz_hang > f) & ((z0 + dz_hang - f) / tan >= gap)
        P = np.vstack([np.column_stack([X, Y, z0])[foot], np.column_stack([X, Y, z0 + dz_hang])[hang]])
        P[:, 2] += rng.normal(0.0, NOISE, len(P))
        points[f"L{i + 1}"] = np.round(P, 2)
    L = float(np.hypot(W, H))
    zs = np.arange(top - thick.sum() - 100.0, top + 101.0, 25.0)
    centres = anchor[None, :] + np.arange(-L, L, rng.uniform(150.0, 300.0))[:, None] * along[None, :]
    FP = np.array([[*(c + down * (z_mid - z) / tan), z] for c in centres for z in zs])
    stick = np.repeat(np.arange(len(centres)), len(zs))
    near = points_in_polygon(FP[:, :2], off + np.array([[-100.0, -100.0], [W + 100, -100.0],
                                                         [W + 100, H + 100], [-100.0, H + 100]]))
    keep = np.isin(stick, np.unique(stick[near]))
    ds = Dataset(name=f"block-{seed}", layers=list(points), boundary=ring, points=points,
                 faults=[Fault("F1", points=np.round(FP[keep], 2), sticks=stick[keep])])
    return BlockGround(ds, kind, throw, layer_z, throw_growth)


def fault_surfaces(ds: Dataset) -> list:
    """The derivation's surface of each fault of ``ds``
    (:func:`faultmesh.derive.fault_surface`) over the layer data's depth
    range: what :func:`faultmesh.derive._conformable_points` takes."""
    from faultmesh.derive import fault_surface, layer_data
    ring = np.asarray(ds.boundary, dtype=np.float64)
    zs = np.concatenate([layer_data(ds, lay)[:, 2] for lay in ds.layers])
    return [fault_surface(f, ring, (float(zs.min()), float(zs.max())), warnings=[]) for f in ds.faults]


def misfits_by_layer(g: BlockGround, derived: Dataset) -> dict:
    """(layer index, side) -> z (m) of each derived cutoff point above the
    true layer of its side ("foot", "hanging") at its XY (the point lies on
    the fault, so this is its distance from the true cutoff line measured
    vertically)."""
    out: dict = {}
    for tr in derived.faults[0].traces:
        for i, lay in enumerate(g.dataset.layers):
            for side, P in tr.layers.get(lay, {}).items():
                c = P[-1] if side == "foot" else P[0]
                out.setdefault((i, side), []).append(float(c[2] - g.side_z(i, side, c[0], c[1])))
    return {k: np.asarray(v) for k, v in out.items()}


def cutoff_misfits(g: BlockGround, derived: Dataset) -> dict:
    """side -> the misfits of :func:`misfits_by_layer` of every layer."""
    m = misfits_by_layer(g, derived)
    return {side: np.concatenate([v for (_, sd), v in m.items() if sd == side] or [np.zeros(0)])
            for side in ("foot", "hanging")}


def assert_sparse_layers_as_good_as_the_top(g: BlockGround, derived: Dataset, slack: float = 2.0) -> None:
    """Each side's mean absolute cutoff misfit of the layers under the top
    one within ``slack`` m of the top layer's on that side."""
    m = {k: np.abs(v) for k, v in misfits_by_layer(g, derived).items()}
    for side in ("foot", "hanging"):
        top = m[0, side].mean()
        sparse = np.concatenate([v for (i, sd), v in m.items() if i > 0 and sd == side])
        assert len(sparse) >= 4, side
        assert sparse.mean() <= top + slack, (side, sparse.mean(), top)


# Grounds drawn so that a test takes a few seconds (at most about 1,000
# picks on at most 3 layers); 9 and 7 failed before the footwall's fix below.
PLANE_SEEDS = [9, 7, 4]


@pytest.mark.parametrize("seed", PLANE_SEEDS)
def test_cutoffs_of_a_block_fault_through_plane_layers_are_unbiased(seed):
    """Plane layers and a plane fault with one throw: each side is a plane,
    so a derived cutoff is off only by the picks' noise carried across the
    gap, and neither side is off one way more than the other. Bounds: the
    mean of the signed misfits of a side within 0.35 m of zero (the noise
    is 0.3 m; the side surfaces follow the picks closely, so the slope
    they carry into the gap is the last picks' noise over their spacing, up
    to about 0.01, over 0-300 m); the mean misfit 0.75 m, the largest 2 m.
    Measured on these and two other grounds: signed -0.28 to +0.29 m, mean
    0.21-0.61 m, max 0.43-1.20 m.

    Regression: the footwall's tension pulled its slope towards the plane
    through both sides' data, which the fault's offset tilts down dip, so
    the footwall of a normal fault dropped towards it: signed -0.57 m
    (seed 9), -0.61 m (seed 7), mean 0.67 and 0.61 m against the hanging
    walls' 0.34 and 0.33 m. The footwall's regional slope now comes from a
    plane with a step between the sides (:func:`faultmesh.derive._regional_slope`)."""
    g = block_ground(seed, undulation=False)
    d = derive_faults(g.dataset)
    assert d.faults[0].kind == g.kind
    for side, m in cutoff_misfits(g, d).items():
        assert len(m) >= 4, side
        assert abs(m.mean()) <= 0.35, (side, "signed", m.mean())
        assert np.abs(m).mean() <= 0.75 and np.abs(m).max() <= 2.0, (side, np.abs(m).mean(), np.abs(m).max())


@pytest.mark.parametrize("seed", [4, 12])
def test_block_faults_through_undulating_layers_build(seed):
    """Undulating layers: the derived model passes check(), the kind is
    right, and every layer the fault displaces is cut."""
    g = block_ground(seed)
    d = derive_faults(g.dataset)
    assert d.faults[0].kind == g.kind
    assert set(d.derivation.faults["F1"].cutoffs) == set(g.dataset.layers)
    m = fm.build_model(d, evaluate=False)
    m.check()
    assert len(m.faults) == 1


@pytest.mark.parametrize("seed", [5, 3])
def test_a_layer_known_from_holes_only_follows_the_picked_horizon_to_its_cutoffs(seed):
    """The top layer picked on a grid, the layers below known only at every
    fourth place along both axes (holes): the layers are conformable, so a
    sparse layer's cutoffs are as good as the picked one's when its shape
    near the fault comes from the picked horizon
    (:func:`faultmesh.derive._conformable_points`). Bound: each side's mean
    misfit of the sparse layers within 2 m of the top layer's on that side.
    Measured: seed 5 0.77 / 1.45 m against the top layer's 0.94 / 1.22 m,
    seed 3 2.64 / 1.71 m against 2.21 / 2.02 m.

    Regression: each sparse layer extrapolated on its own, 16 times
    sparser: seed 5 7.01 / 5.06 m (foot / hanging), seed 3 3.58 / 17.17 m."""
    g = block_ground(seed, sparse_every=4)
    d = derive_faults(g.dataset)
    assert d.faults[0].kind == g.kind
    # The report says which layers took whose shape, and what the gates saw.
    for lay in g.dataset.layers[1:]:
        rec = d.derivation.layers[lay]
        assert rec["reference"] == "L1" and rec["points"] > 0, rec
        assert rec["cv_rms"] < 0.8 * rec["own_cv_rms"] and abs(rec["steps"]["F1"]) < 3.0, rec
    assert_sparse_layers_as_good_as_the_top(g, d)


@pytest.mark.parametrize("seed", [5, 0])
def test_a_sparse_layer_whose_throw_differs_by_metres_keeps_the_step(seed):
    """As above, but each layer's throw 3 m larger than the one's above
    (growth: the hanging wall's layers thicker): the offset from the top
    layer steps across the fault by 3, 6, 9 m. The step is measured, taken
    out of the interpolated offset and put back on each side
    (:data:`faultmesh.derive.CONFORMABLE_STEP_MAX`). Bounds: each measured
    step within 1 m of the true one, and each side's mean misfit of the
    sparse layers within 2 m of the top layer's. Measured: seed 5 steps
    -3.3, -6.2, -9.6 m, misfits 0.81 / 1.48 m against the top layer's 0.94
    / 1.22 m; seed 0 3.2, 5.5, 8.7 m, 2.11 / 0.52 m against 1.36 / 0.53 m.

    Regression: every such step refused the reference, and the sparse
    layers extrapolated on their own: seed 5 7.01 / 5.03 m, seed 0 3.62 /
    2.43 m."""
    g = block_ground(seed, sparse_every=4, throw_growth=3.0)
    d = derive_faults(g.dataset)
    assert d.faults[0].kind == g.kind
    sign = -1.0 if g.kind == "normal" else 1.0
    kept = 0
    for i, lay in enumerate(g.dataset.layers[1:], start=1):
        rec = d.derivation.layers[lay]
        assert rec["reference"] == "L1" and rec.get("points", 0) > 0, rec
        assert abs(rec["steps"]["F1"] - sign * 3.0 * i) <= 1.0, (lay, rec["steps"])
        kept += rec.get("steps_kept") == ["F1"]
    assert kept >= 2
    assert_sparse_layers_as_good_as_the_top(g, d)


def test_the_built_model_of_a_sparse_layer_follows_the_picked_horizon(tmp_path):
    """The derived points go into the built model too
    (``Dataset.derived_points``): the sparse layers' continuous TINs take
    them after their own data, and the derivation's data do not
    (:func:`faultmesh.derive.layer_data`). Bound: each sparse layer's mean
    vertical error against the truth, on a 120 x 120 grid where the surface
    has one sheet, at most 1 m and at most half of that of the same model
    without them. Measured: 0.52, 0.48, 0.52 m against 1.84, 1.79, 1.82 m
    (the top layer's 0.40 m either way)."""
    from dataclasses import replace

    from faultmesh.derive import layer_data
    from faultmesh.report import evaluate_surface
    g = block_ground(5, sparse_every=4)
    d = derive_faults(g.dataset)
    for lay in g.dataset.layers[1:]:
        n = d.derivation.layers[lay]["points"]
        assert len(d.derived_points[lay]) == n > 0
        assert len(layer_data(d, lay)) == len(g.dataset.layer_points(lay))
        assert len(d.layer_points(lay)) == len(g.dataset.layer_points(lay)) + n
    ring = np.asarray(d.boundary, dtype=np.float64)
    lo, hi = ring.min(axis=0) + 10.0, ring.max(axis=0) - 10.0
    X, Y = np.meshgrid(np.linspace(lo[0], hi[0], 120), np.linspace(lo[1], hi[1], 120))
    X, Y = X.ravel(), Y.ravel()

    def errors(model):
        out = []
        for i, lay in enumerate(d.layers):
            a, b, n = evaluate_surface(model.surfaces[lay], X, Y)
            z = 0.5 * (a + b)
            e = np.minimum(np.abs(z - g.side_z(i, "foot", X, Y)), np.abs(z - g.side_z(i, "hanging", X, Y)))
            out.append(float(e[n == 1].mean()))
        return np.array(out)

    with_pts = fm.build_model(d, evaluate=False)
    with_pts.check()
    without = fm.build_model(replace(d, derived_points={}), evaluate=False)
    e1, e0 = errors(with_pts), errors(without)
    assert np.all(e1[1:] <= 1.0) and np.all(e1[1:] <= 0.5 * e0[1:]), (e1, e0)
    # Saved, they are written with the layer's points (docs/dataset.md), and
    # the dataset read back builds the same model.
    back = fm.load_dataset(d.save(tmp_path / "derived"))
    for lay in g.dataset.layers[1:]:
        assert np.allclose(back.layer_points(lay), d.layer_points(lay), rtol=0.0, atol=1e-9)
    rebuilt = fm.build_model(back, evaluate=False)
    for lay in d.layers:
        a1, _, n1 = evaluate_surface(with_pts.surfaces[lay], X, Y)
        a2, _, n2 = evaluate_surface(rebuilt.surfaces[lay], X, Y)
        assert np.array_equal(n1, n2) and np.allclose(a1[n1 > 0], a2[n2 > 0], rtol=0.0, atol=1e-6), lay


def test_a_layer_the_fault_does_not_displace_takes_the_shape_not_the_throw_of_one_it_does():
    """The fault offsets the picked top layer (31 m) but dies out above the
    sparse layers (their data unfaulted). Their offsets from the top layer
    step by the whole throw across the fault: more than
    :data:`faultmesh.derive.CONFORMABLE_STEP_MAX`, so the fault is a
    barrier and the offset is interpolated in each of its blocks apart.
    The extra points then carry the top layer's shape and none of its
    throw: within 2.5 m of the unfaulted truth (measured 1.3 m; the
    throw carried would put them 31 m off; with one step per fault, a
    throw that fades misplaced them by up to its size, which is why such a
    step refused the reference before barriers). The same ground with
    every layer displaced uses the reference without a barrier."""
    from dataclasses import replace

    from faultmesh.derive import _conformable_points
    g = block_ground(5, sparse_every=4)
    ds = g.dataset
    fs = fault_surfaces(ds)
    log: dict = {}
    assert set(_conformable_points(ds, fs, log)) == set(ds.layers[1:])
    assert not any("barriers" in r for r in log.values())
    pts = dict(ds.points)
    for i, lay in enumerate(ds.layers[1:], start=1):
        P = np.array(pts[lay])
        P[:, 2] = g.layer_z(i, P[:, 0], P[:, 1])   # no throw
        pts[lay] = P
    log = {}
    extra = _conformable_points(replace(ds, points=pts), fs, log)
    assert set(extra) == set(ds.layers[1:])
    for lay, E in extra.items():
        assert log[lay]["barriers"] == ["F1"]
        i = ds.layers.index(lay)
        err = np.abs(E[:, 2] - g.layer_z(i, E[:, 0], E[:, 1]))
        assert err.max() <= 2.5, (lay, err.max())


def with_gap_picks(g: BlockGround, every: float = 30.0) -> BlockGround:
    """``g`` (a normal fault) with its top layer also picked on the fault
    in the fault's gap, every ``every`` m on a grid: a horizon picked (or
    auto-tracked) straight across the fault, whose top there is the fault
    itself (the generated grounds' section picks have such points too).
    The fault's plane is fitted to its points (rounded to 1 cm)."""
    from dataclasses import replace
    ds = g.dataset
    FP = np.asarray(ds.faults[0].points)
    A = np.column_stack([FP[:, :2], np.ones(len(FP))])
    c, *_ = np.linalg.lstsq(A, FP[:, 2], rcond=None)
    ring = np.asarray(ds.boundary)
    lo, hi = ring.min(axis=0), ring.max(axis=0)
    X, Y = np.meshgrid(np.arange(lo[0] + every / 6, hi[0], every / 3),
                       np.arange(lo[1] + every / 6, hi[1], every / 3))
    X, Y = X.ravel(), Y.ravel()
    fz = c[0] * X + c[1] * Y + c[2]
    gap = (g.side_z(0, "hanging", X, Y) < fz) & (fz < g.side_z(0, "foot", X, Y))
    Q = np.round(np.column_stack([X, Y, fz])[gap][::3], 2)
    pts = dict(ds.points)
    pts["L1"] = np.vstack([pts["L1"], Q])
    return BlockGround(replace(ds, points=pts), g.kind, g.throw, g.layer_z, g.throw_growth)


@pytest.mark.parametrize("seed", [5, 10])
def test_picks_on_the_fault_are_no_reference_for_a_sparse_layer(seed):
    """Regression (random_ground(49) as v2: L1 picked on sections across
    F1, its points in F1's gap on the fault): the sparse layers took their
    shape from every L1 datum, also from those on the fault, whose offset
    by the isochore put L2-L5 points 12-20 m below the footwall beside the
    fault; F1's L2-L4 footwall cutoffs came out 12-38 m too deep (error
    near the faults 1.37x the true cutoffs' model; now 1.03x). A datum on
    a fault is now neither a thickness sample nor a reference point
    (:func:`faultmesh.derive._conformable_points`). Bound: every extra
    point within 2.5 m of its layer's truth on one side or the other
    (picks carry 0.3 m of noise, the isochore is interpolated). Measured:
    at most 1.74 m (seed 5), 2.04 m (seed 10); before 15.3 and 15.2 m."""
    from faultmesh.derive import _conformable_points
    g = with_gap_picks(block_ground(seed, sparse_every=4))
    assert g.kind == "normal"
    ds = g.dataset
    extra = _conformable_points(ds, fault_surfaces(ds))
    assert set(extra) == set(ds.layers[1:])
    for i, lay in enumerate(ds.layers[1:], start=1):
        P = extra[lay]
        err = np.minimum(np.abs(P[:, 2] - g.side_z(i, "foot", P[:, 0], P[:, 1])),
                         np.abs(P[:, 2] - g.side_z(i, "hanging", P[:, 0], P[:, 1])))
        assert err.max() <= 2.5, (lay, err.max())


def test_picks_on_the_fault_beside_the_footwall_cutoff_join_the_footwall():
    """Regression: block ground 5 (a normal fault, throw 31 m) with its top
    layer also picked in the fault's gap (:func:`with_gap_picks`, 71
    points). 67 of them lie under the footwall's surface and are left out
    (the gap); four lie a little above it, beside the footwall's cutoff,
    and the exact side test put two of them in the hanging wall, which they
    pulled up onto the footwall's cutoff: as the only data near the
    cutoffs they made the fault reverse and L1's cutoffs came out in the
    middle of the gap (mean misfit 12.6 m foot, 18.7 m hanging). A datum
    on the fault outside the gap now goes to the side whose surface passes
    nearer (:func:`faultmesh.derive._data_sides`). Bounds: the kind
    normal, each side's mean misfit of L1 within 4 m, the sparse layers as
    good as the top one. Measured: 2.81 / 2.33 m (without the gap picks
    0.94 / 1.22 m: the four stay in the footwall)."""
    g = with_gap_picks(block_ground(5, sparse_every=4))
    d = derive_faults(g.dataset)
    assert d.faults[0].kind == g.kind == "normal"
    m = misfits_by_layer(g, d)
    for side in ("foot", "hanging"):
        assert np.abs(m[0, side]).mean() <= 4.0, (side, m[0, side])
    assert_sparse_layers_as_good_as_the_top(g, d)


def test_a_step_is_kept_only_where_it_predicts_better_than_a_smooth_offset():
    """derive._steps_predict on 40 draws of offsets at 80 random places,
    with a fault line through them: a thickness wave of 3-8 m (wavelength
    0.6-1.5 times the area) alone seldom predicts better with a step (at
    most 4 of 40; measured 3, and the standard-error rule alone keeps 5:
    together, as derive._conformable_points asks both, none); the same wave
    plus a step of 4-9 m across the line does in at least 36 (measured 39,
    both rules 37)."""
    from scipy.interpolate import RBFInterpolator
    from faultmesh.derive import _steps_predict
    kept = {False: 0, True: 0}
    for seed in range(40):
        rng = np.random.default_rng([seed, 3])
        xy = rng.uniform(0.0, 2000.0, (80, 2))
        c = xy.mean(axis=0)
        side = (xy[:, 0] + 0.3 * xy[:, 1] > 1300.0).astype(np.float64)
        wl, amp = rng.uniform(1200.0, 3000.0), rng.uniform(3.0, 8.0)
        wave = amp * np.sin(2 * np.pi * xy[:, 0] / wl + rng.uniform(0, 6)) * np.cos(2 * np.pi * xy[:, 1] / wl)
        A = np.column_stack([np.ones(len(xy)), xy[:, 0] - c[0], xy[:, 1] - c[1], side])
        fold = np.random.default_rng(0).permutation(len(xy)) % 5
        step = rng.uniform(4.0, 9.0)

        def spline(sel, v):
            return RBFInterpolator(xy[sel] - c, v[sel], kernel="thin_plate_spline", degree=1)

        for with_step in (False, True):
            off = -20.0 + wave + (step * side if with_step else 0.0)
            kept[with_step] += _steps_predict(spline, xy - c, fold, off, A, np.array([3]))
    assert kept[False] <= 4 and kept[True] >= 36, kept


def test_a_block_fault_whose_hanging_wall_data_stand_off_keeps_its_throw():
    """One plane layer, one plane normal fault with the same throw (22.6
    m) everywhere, dense picks (tests/data/derive/block_fault_sparse_hanging_wall.npz):
    over half the fault the hanging wall's nearest picks lie 60-150 m
    from it. The fading-throw fit smoothed its layer S at a twentieth of
    the data spacing: S then fits the picks' noise, and S and the throw T
    trade for nothing where only the hanging wall's S - T is known -- T
    rose to 88 m, five sections got throws of 48-101 m, hanging-wall
    cutoffs 41-76 m too deep, without a warning (the fit's objective 7 %
    below the true solution's, by noise fitting). Bounds: every hanging-wall
    cutoff within 10 m of the truth (those next to the boundary, where both
    sides extrapolate, are 5-9 m off), the median within 2 m."""
    f = np.load(Path(__file__).parent / "data" / "derive" / "block_fault_sparse_hanging_wall.npz")
    ds = Dataset(name="block-sparse-hanging", layers=["L2"], boundary=f["boundary"],
                 points={"L2": f["points"]},
                 faults=[Fault("F1", points=f["fault_points"], sticks=f["sticks"])])
    got = derive_faults(ds)
    fd = got.derivation.faults["F1"]
    assert fd.kind == "normal"
    z0, gx, gy = f["layer_plane"]
    H = np.asarray(fd.cutoffs["L2"]["hanging"])
    err = np.abs(H[:, 2] - (z0 + gx * H[:, 0] + gy * H[:, 1] - float(f["throw"])))
    assert len(err) >= 10
    assert err.max() <= 10.0 and np.median(err) <= 2.0, np.round(err, 1)


def _stress_fixture(name: str):
    """A stress generator's ground saved in tests/data/derive (README there):
    its dataset (picks and fault points, no cutoff) and, per layer, the
    noise-free true z at each pick and the pick's horizontal distance to
    the nearest true fault."""
    f = np.load(Path(__file__).parent / "data" / "derive" / name)
    layers = [str(x) for x in f["layers"]]
    names = sorted(k[len("fault_points_"):] for k in f.files if k.startswith("fault_points_"))
    faults = [Fault(n, points=f["fault_points_" + n],
                    sticks=f["sticks_" + n] if "sticks_" + n in f.files else None) for n in names]
    ds = Dataset(name=name.split(".")[0], layers=layers, boundary=f["boundary"],
                 points={lay: f["points_" + lay] for lay in layers}, faults=faults)
    truth = {lay: (f["truth_z_" + lay], f["fault_distance_" + lay]) for lay in layers}
    return ds, truth


def _sheet_error(model, lay: str, xy: np.ndarray, z: np.ndarray) -> np.ndarray:
    """|dz| of layer ``lay``'s surface against ``z`` at the places ``xy``
    (the nearer sheet where a reverse fault folds it); NaN where the model
    does not cover a place."""
    from faultmesh.report import evaluate_surface

    xy = np.asarray(xy)
    lo, hi, _ = evaluate_surface(model.surfaces[lay], xy[:, 0], xy[:, 1])
    return np.minimum(np.abs(lo - z), np.abs(hi - z))


def _largest_error_at_picks(model, ds, truth, lay: str) -> float:
    """The largest |dz| of the model at a layer's picks against the
    noise-free truth (the nearer sheet where a reverse fault folds it);
    infinity if the model does not cover one."""
    err = _sheet_error(model, lay, ds.points[lay], truth[lay][0])
    return float(err.max()) if np.all(np.isfinite(err)) else np.inf


def _miss_at_pick(model, ds, lay: str, x: float, y: float) -> float:
    """How far the model's surface of ``lay`` (either sheet where a reverse
    fault folds it) passes from the layer's pick nearest to (x, y)."""
    from faultmesh.report import evaluate_surface

    P = np.asarray(ds.points[lay])
    k = int(np.argmin(np.hypot(P[:, 0] - x, P[:, 1] - y)))
    lo, hi, _ = evaluate_surface(model.surfaces[lay], P[k:k + 1, 0], P[k:k + 1, 1])
    return float(max(abs(lo[0] - P[k, 2]), abs(hi[0] - P[k, 2])))


def _assert_picks_honoured(model, ds, truth, layers, largest: float, n_near: int, mean_near: float) -> None:
    """Each of ``layers`` within ``largest`` m of the truth at its picks,
    and the mean error at the picks near the faults (more than ``n_near``
    of them) within ``mean_near`` m."""
    for lay in layers:
        assert _largest_error_at_picks(model, ds, truth, lay) <= largest, lay
    err = _error_near_faults(model, ds, truth)
    assert len(err) > n_near and err.mean() <= mean_near, (len(err), err.mean())


def _error_near_faults(model, ds, truth, near: float = 200.0) -> np.ndarray:
    """|dz| of the model at the picks within ``near`` m (horizontally) of a
    true fault, against the noise-free truth (the nearer of the surface's
    sheets where a reverse fault folds it)."""
    out = []
    for lay in ds.layers:
        z, dist = truth[lay]
        sel = dist <= near
        out.append(_sheet_error(model, lay, np.asarray(ds.points[lay])[sel], z[sel]))
    return np.concatenate(out)


def test_thin_layers_under_a_throw_of_many_layer_thicknesses_build():
    """Regression (tests/data/derive/thin_layers_large_throw.npz, a stress
    generator's ground): eight plane layers, five of them under 8 m
    thick, cut by one normal fault of 111 m. The derived cutoffs were
    accurate (0.8 m on the footwall, 2.4 m on the hanging wall where the
    picks are dense), yet the build failed: "repair_crossings('L4', 'L5'):
    the layers still cross after 10003 inserted points". Each layer's
    continuous TIN ramps across its own data gap at the fault, and where
    the gaps of layers a few metres apart lie in different places the TINs
    cross by tens of metres (L2 up to 32.7 m above L1 before the repair),
    in the zone the fault patches replace. The repair converges; its
    insertion budget, counted on the lower layer alone, stopped it. It now
    counts the upper layer's vertices too (layer_tin.hpp, RepairOptions),
    and a wrong layer order is refused by the share of the lower layer's
    data above the upper surface instead. Measured: the model's error at
    the picks within 200 m of the fault, against the noise-free truth,
    0.24 m mean, 0.94 m at most."""
    ds, truth = _stress_fixture("thin_layers_large_throw.npz")
    model = fm.build_model(ds, evaluate=False)
    model.check()
    # The report says what the repair changed: L2 lowered by the 32.7 m it
    # lay above L1 (its TIN vertices, not its data: at most 5 data of a
    # layer lay above the one over it).
    rep = model.metadata["repair"]
    assert 30.0 < rep["L2"]["max_lowered"] < 35.0, rep["L2"]
    assert all(c["data_above"] <= 5 for c in rep.values()), rep
    err = _error_near_faults(model, ds, truth)
    assert len(err) > 300 and np.all(np.isfinite(err))
    assert err.mean() <= 0.5 and err.max() <= 3.0, (err.mean(), err.max())
    # The model passes within 0.15 m of every datum but one (9 of 3.3k
    # missed by over 1 mm, the picks' noise where thin layers' data cross;
    # 57 before data moved onto patch edges had their vertex's z solved
    # for their own XY, insert_patch_data): no warning. The one: since the fault's ends are carried onto the
    # boundary (their cutoffs within reach; they were closed by pinch-outs
    # before, error near the fault the same to the bit), an L2 pick 615 m
    # from the fault lies under the extension's loft, whose triangles there
    # are 280 m long; the placement moves a datum within a hundredth of a
    # triangle's height of an edge onto it (0.31 m here, patch_data.hpp),
    # and the model at the pick's own XY misses it by 1.69 m (its vertex's
    # z is not solved there: not looked into).
    fit = model.metadata["data_fit"]
    assert max(r["max_m"] for r in fit.values()) < 2.0, fit
    assert sorted(r["max_m"] for r in fit.values())[-2] < 1.0, fit
    # No warning but the layer order's: in the fault zone, where the ten
    # layers' patches and gaps overlap under a throw of many thicknesses,
    # a lower layer lies up to 11.7 m above the one over it (L8 under L7,
    # patch over patch) at a few of their vertices; no pick lies there.
    assert not [w for w in model.metadata.get("warnings", []) if "lies above" not in w]


def test_thin_layers_under_two_low_angle_faults_build_through_a_cascade_of_repairs():
    """Regression (tests/data/derive/thin_layers_two_low_angle_faults.npz, a
    stress generator's ground, seed 44): ten plane layers, the lowest four
    3.8-7.5 m apart, cut by two synthetic normal faults of 20 degrees with
    throws of 73 and 59 m, 1.1 km apart. It failed even with the true
    cutoffs: "repair_crossings('L9', 'L10'): the layers still cross after
    13675 inserted points (498 vertices at the start)". Each layer's repair
    converges (L8, L9 and L10 with 3.2k, 12.7k and 22.4k points), but each
    takes the points the one above it got from its own repair, and the
    budget counted the lower layer's own vertices only. Measured now: the
    model's error at the picks within 200 m of a fault 0.27 m mean, 10.4 m
    at most (L8, 46 m from F1)."""
    ds, truth = _stress_fixture("thin_layers_two_low_angle_faults.npz")
    model = fm.build_model(ds, evaluate=False)
    model.check()
    assert sorted(model.faults) == ["F1", "F2"]
    err = _error_near_faults(model, ds, truth)
    assert len(err) > 1000 and np.all(np.isfinite(err))
    assert err.mean() <= 0.5 and np.percentile(err, 95) <= 2.0, (err.mean(), np.percentile(err, 95))



def test_a_repair_with_a_long_tail_of_rounds_ends():
    """Regression (tests/data/derive/thin_layers_reverse_fault_long_repair.npz,
    a stress generator's ground, seed 69): ten layers, five of them under 7
    m thick, cut by a normal fault of 28 m and a reverse one of 106 m, picks
    on eight seismic lines. Once the insertion budget counted both layers,
    L7's repair under L6 still gave up: "'L7' still crosses 'L6' after 50
    rounds". It ends in 85 (1 s, 31.7k points, 2.2 per vertex of the two
    layers): each round after the first looks only at what the last one
    changed, and the tail refines a few edges at a time. The rounds' limit
    is 200 now (layer_tin.hpp, RepairOptions::max_rounds). Measured: the
    model's error at the picks within 200 m of a fault 0.32 m mean, 0.65 m
    at the 95th percentile. Since L6 is raised over L7's data where it has
    none near (build._raise_over_data), L7's repair ends in 20 rounds; the
    long tail is tested with the raise off."""
    ds, truth = _stress_fixture("thin_layers_reverse_fault_long_repair.npz")
    d = derive_faults(ds)   # once for both builds
    model = fm.build_model(d, evaluate=False)
    model.check()
    err = _error_near_faults(model, ds, truth)
    assert len(err) > 500 and np.all(np.isfinite(err))
    assert err.mean() <= 0.5 and np.percentile(err, 95) <= 2.0, (err.mean(), np.percentile(err, 95))
    # The long tail is that of the repair with no upper layer raised over
    # the data under it (build._raise_over_data, later, for either of its
    # reasons: no datum near, or all across a fault): L6 raised over L7's
    # data, L7's repair ends in 20 rounds. On the cutoffs derived when the
    # tail was found, saved beside the ground (..._derived/, README there):
    # today's derivation (a layer between displaced layers takes their
    # throw, noisy picks smoothed) gives L7 a tail of 27 rounds.
    saved = load_dataset(Path(__file__).parent / "data" / "derive" / "thin_layers_reverse_fault_long_repair_derived")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(fm.build, "_raise_over_data", lambda *args: {})
        tail = fm.build_model(saved, evaluate=False)
    tail.check()
    assert tail.metadata["repair"]["L7"]["rounds"] > 50, tail.metadata["repair"]["L7"]

def test_an_upper_layer_with_no_footwall_datum_borrows_the_layer_below():
    """Regression (tests/data/derive/upper_layers_footwall_sliver.npz, a
    stress generator's ground, seed 27): six layers cut by one normal fault
    of 114 m at 27 degrees. L1-L3's footwall lies in a sliver at the edge
    of the study area with no pick; L4-L6 have footwall picks near the
    fault. With no footwall data L1-L3 were left uncut, their continuous
    TINs took the hanging wall's level across the fault, and the crossing
    repair lowered L4's and L5's footwall picks onto L3 by up to 96 m (the
    model's error near the fault 2.38 m mean, 96 m at most). Their
    footwall is now L4's data shifted by the thickness measured on the
    hanging wall (derive._borrowed_side): every layer is cut, and the model
    passes within centimetres of every pick."""
    ds, truth = _stress_fixture("upper_layers_footwall_sliver.npz")
    d = derive_faults(ds)
    fr = d.derivation.faults["F1"]
    cut = [lay for lay, t in fr.throw.items() if np.asarray(t["cut"]).any()]
    assert cut == ds.layers, cut
    for lay, have in (("L1", 0), ("L2", 0), ("L3", 1)):
        said = [w for w in fr.warnings if w.startswith(f"fault 'F1', layer {lay!r}: {have} foot-wall datum(s)")]
        assert len(said) == 1 and "its foot wall is that of layer 'L4' shifted by" in said[0], \
            (lay, fr.warnings)
        # The truth's throw is constant (114.36 m). The layers with data
        # on both sides get 102-127 m from their own cutoffs; the borrowed
        # ones as close (L3: 105-121 m).
        t = np.asarray(fr.throw[lay]["throw"])[np.asarray(fr.throw[lay]["cut"], bool)]
        assert np.all(np.abs(t - 114.36) < 12.0) and abs(np.median(t) - 114.36) < 8.0, \
            (lay, np.round(t, 1))
    model = fm.build_model(d, evaluate=False)
    model.check()
    err = _error_near_faults(model, ds, truth)
    assert len(err) > 300 and np.all(np.isfinite(err))
    assert err.mean() <= 0.5 and err.max() <= 3.0, (err.mean(), err.max())
    fit = model.metadata["data_fit"]
    assert max(r["max_m"] for r in fit.values()) < 1.0, fit
    # No warning but the layer order's: in the footwall sliver at the
    # boundary, where L1-L3 have no pick, L3's borrowed footwall (a
    # stitched gap there) lies up to 44 m above L2's surface, at 1,085 of
    # the 3,779 places compared (Open: the borrowed side is L4's shifted by
    # one thickness, L2's is the TIN's guess); the other pairs cross by
    # 6-37 m where their patches overlap.
    assert not [w for w in model.metadata.get("warnings", []) if "lies above" not in w], \
        model.metadata["warnings"]


def test_a_fault_that_displaces_one_layer_only_lends_no_side():
    """Regression (v2 random_ground(4) with section picks): F2 displaces
    L2 only (17.7 m); L1 and L3 have no datum on its footwall (the section
    picks are L2's). Borrowed from L2's footwall, shifted by the
    thickness, L1 got throws of 21-42 m it does not have (0.58 -> 0.64x
    the true cutoffs' error near the faults). With one layer alone showing
    the fault on both sides, no side is borrowed (derive._borrowed_side)."""
    from faultmesh import grounds

    built = {}
    out = grounds.evaluate_ground_v2(4, built=built)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    fr = built["derived"].derivation.faults["F2"]
    assert not any("too few for a surface" in w for w in fr.warnings), fr.warnings
    for lay in ("L1", "L3"):
        assert lay not in fr.throw or not np.asarray(fr.throw[lay]["cut"]).any(), fr.throw[lay]
    assert out["ratio"] <= 0.6, out["ratio"]


def test_a_borrowed_side_whose_throw_is_not_the_other_layers_is_dropped():
    """Regression (held-out random ground 148 as v2 with section picks):
    F3 (reverse, 19 m at 31 degrees) displaces L5 and L6 only; L1-L4 have
    no datum on its footwall. Borrowed from L5's footwall with thicknesses
    measured a kilometre or two away (their samples spread by 25-32 m),
    L1-L4 got throws of -35 to -56 m where L5 has -13 m, and the model cut
    four layers the fault does not (the derived cutoffs' mean distance from
    the true ones 1.78 -> 13.6 m; the error near the faults, measured in
    the truth's fault bands only, did not show it). A borrowed side stands
    only where the layer's throw comes out as the other layer's and the
    thickness is known to better than a quarter of the throw."""
    from faultmesh import grounds

    built = {}
    out = grounds.evaluate_ground_v2(148, built=built)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    fr = built["derived"].derivation.faults["F3"]
    for lay in ("L1", "L2", "L3", "L4"):
        said = [w for w in fr.warnings if w.startswith(f"fault 'F3', layer {lay!r}: 0 foot-wall datum(s)")]
        assert len(said) == 1 and "not known to be conformable; the layer is left uncut" in said[0], said
        assert lay not in fr.cutoffs and not np.asarray(fr.throw[lay]["cut"]).any(), lay
    assert out["cutoff_mean"] < 2.0 and not out["cutoff_nan"], (out["cutoff_mean"], out["cutoff_nan"])


def test_a_patch_problem_at_an_end_drops_the_section_nearest_to_it(monkeypatch):
    """Regression (tests/data/derive/low_angle_reverse_fault.npz, a stress
    generator's ground, seed 78): nine layers cut by a reverse fault of 116
    m at 23 degrees (a repetition band about 275 m wide). One triangle of
    L2's patch beside its first section's end did not cover its image once
    (vertices the builder adds there, on no section); the drop rule, which
    looks for the section with the most vertices at the problem, found
    none and went by throw alone, and L2 was dropped from nine sections,
    interior ones first (the picks of one sheet then missed by the whole
    throw: the model's error at the picks within 200 m of the fault 9.9 m
    mean). It now drops the section nearest to the problem: L2 loses its
    two first sections along strike and keeps the rest (4.1 m mean; what is
    left is the picks of the repeated sheet past the end sections)."""
    ds, _ = _stress_fixture("low_angle_reverse_fault.npz")
    # L2 alone shows it (1.5 s; the nine layers take 17 s): on the old rule
    # it kept 1 of its 8 sections.
    ds = replace(ds, layers=["L2"], points={"L2": ds.points["L2"]})
    # The problem was a loft's sliver on the boundary, which the builder now
    # peels off (the next test); kept, it shows the rule its vertices that
    # no section has.
    monkeypatch.setattr(faults_module, "_drop_boundary_slivers", lambda V, T, area: (T, 0))
    d = derive_faults(ds)
    fr = d.derivation.faults["F1"]
    dropped: dict = {}
    for w in fr.warnings:
        m = re.match(r"fault 'F1', layer '(L\d)': dropped from section '(F1/D\d+)'", w)
        if m:
            dropped.setdefault(m.group(1), []).append(m.group(2))
    assert len(dropped.get("L2", [])) <= 2, dropped
    kept = [tr for tr in d.faults[0].traces if "L2" in tr.layers]
    assert len(kept) >= 6, [tr.section for tr in kept]
    # What was dropped lies before every kept section along strike.
    u = {tr.section: float(fr.surface.u(np.asarray(tr.plane)[:, :2]).mean()) for tr in d.faults[0].traces}
    assert all(u[s] < min(u[tr.section] for tr in kept) for s in dropped.get("L2", [])), (dropped, u)


def test_a_low_angle_reverse_fault_keeps_every_section_and_reaches_the_boundary():
    """Regression (tests/data/derive/low_angle_reverse_fault.npz, stress
    ground 78): the reverse fault of 116 m at 23 degrees runs out of the
    study area at both ends, across oblique sides. L2 was dropped from its
    first two sections for a sliver the loft left on the boundary, and at
    the other end L2, L3 and L4 closed by pinch-outs 300 m short of the
    boundary because the far ends of their last sections' sheets lay beyond
    the extension's reach (their cutoffs did not): the picks of the
    repeated sheet there were missed by the whole throw (the model's error
    at the picks within 200 m of the fault 2.6 m mean, 117 m at most). Now
    no section is dropped, every end reaches the boundary and no pick is
    missed by the throw (0.28 m mean, 30 m at most: the end sections'
    cutoffs extrapolated past the data)."""
    ds, truth = _stress_fixture("low_angle_reverse_fault.npz")
    d = derive_faults(ds)
    fr = d.derivation.faults["F1"]
    assert not [w for w in fr.warnings if "dropped from section" in w], fr.warnings
    model = fm.build_model(d, evaluate=False)
    model.check()
    for lay, rec in model.metadata["faults"]["F1"]["layers"].items():
        assert "synthetic_tip" not in rec["ends"], (lay, rec["ends"])
    err = _error_near_faults(model, ds, truth)
    assert len(err) > 500 and np.all(np.isfinite(err))
    assert err.mean() <= 0.5 and err.max() <= 0.5 * 116.3, (err.mean(), err.max())


def test_a_datum_whose_upper_layer_lies_across_a_fault_is_not_lowered_under_it():
    """Regression (tests/data/derive/reverse_fault_upper_layer_across_it.npz,
    stress ground 207): nine layers cut by a normal fault of 25 m and a
    reverse one (F2) of 57 m, picked on six seismic lines. An L3 pick 171 m
    from the faults had L2 picks within 40 m, but all across F2: L2's
    continuous TIN there follows F2's other block, 57 m away in z, and the
    crossing repair lowered the pick 54.9 m under it (the model missed it
    by 45.5 m). L2's data near it all lying across a fault (the segments
    to them meet F2's L2 patch in map view), L2 gets a point at the pick's
    elevation first (build._raise_over_data), as where it has no datum
    near at all. Every layer within 2 m of the truth at every pick (L4's
    pick by the boundary: the test below)."""
    ds, truth = _stress_fixture("reverse_fault_upper_layer_across_it.npz")
    model = fm.build_model(derive_faults(ds), evaluate=False)
    model.check()
    assert model.metadata["tins"]["L2"]["raised_over_data"] >= 1
    assert _miss_at_pick(model, ds, "L3", 4250.18, 1705.78) <= 0.5
    _assert_picks_honoured(model, ds, truth, ds.layers, 2.0, 300, 0.35)


def test_a_pick_next_to_the_boundary_in_a_fault_zone_is_honoured():
    """The ground above (stress ground 207): L4's pick at (3525.8, 3884.6),
    8 m inside the study area and 182 m from F2 (reverse, 57 m), lies in
    F2's L4 patch where its end section, carried along strike onto the
    boundary, reaches a boundary vertex at z = -851.0, 26 m under the pick
    (the carry adds the continuous TIN's change, which bridges F2 at the
    section: the picks in a reverse fault's patch are left out of it). The
    pick, 0.5 m from the edge to that vertex, goes onto the edge
    (patch_data.hpp); another pick placed in the same triangle lay 0.04 m
    from the line from the boundary vertex through it, the fan put that
    line between the pick's vertex and its XY (weight 0.07) and the model
    passed 22 m under the pick. The edge is flipped where that helps
    (patch_data.cpp, flip_towards_moved_data) and the pick kept (0.02 m).
    The patch there is still steep (the boundary vertex): Open."""
    ds, truth = _stress_fixture("reverse_fault_upper_layer_across_it.npz")
    model = fm.build_model(derive_faults(ds), evaluate=False)
    assert _largest_error_at_picks(model, ds, truth, "L4") <= 2.0


@pytest.mark.parametrize("lay, x, y", [("L2", 510178.4, 6903539.4), ("L3", 510178.4, 6903539.4),
                                       ("L3", 509997.0, 6903655.3), ("L5", 510178.4, 6903539.4)])
def test_a_pick_near_a_patch_vertex_gives_the_vertex_its_z(lay, x, y):
    """Stress ground 91 (tests/data/derive/normal_fault_picks_near_loft_vertices.npz):
    picks of L2 and L3 lie within a hundredth of their patch triangle's
    size of a loft vertex (weights 0.986-0.990), where a new vertex would
    make slivers; they were left out and the patch passed 28-40 m under
    them (the vertices 32-42 m under). The vertex now takes the nearest
    such datum: its z puts the patch through the datum at the datum's own
    XY (patch_data.cpp, take_corner_data). L5's pick there lies 4.9 m from
    an edge of a 490 m triangle and 9.6 m from the edge's end, and goes
    onto the edge; another datum far off in the triangle left its vertex
    0.18 of the weight at the pick's XY and the end 0.77 (the patch passed
    19.9 m off it): the end takes it (through_moved_data)."""
    ds, _ = _stress_fixture("normal_fault_picks_near_loft_vertices.npz")
    model = fm.build_model(derive_faults(ds), evaluate=False)
    model.check()
    assert _miss_at_pick(model, ds, lay, x, y) < 0.01


def test_a_layer_between_two_cut_layers_stays_cut_whatever_its_borrowed_throw():
    """Stress ground 113 (tests/data/derive/normal_fault_layer_between_cut_layers.npz):
    a normal fault of 53.4 m at 24 degrees cuts all ten layers. L3 has no
    footwall datum near it; its footwall is L5's shifted by the thickness
    between them (the true one, 57.4 m), which gives L3 a throw of 37 m
    against L5's 62 m, beyond the 25 % a borrowed side must agree by
    (derive.BORROW_AGREE, which keeps a fault that dies out between two
    layers from cutting the upper one). L3 was left uncut: its continuous
    TIN took the hanging wall's level into the footwall, 63 m under the
    truth, and the crossing repair lowered an L4 top there 28 m under it
    (missed by 21 m). L2 and L4 above and below it are cut, so L3 is too:
    the borrowed side stands on the sections where both are.

    Since the side surfaces keep to their block of the reverse fault 0.9 km
    away (derive._beside_others), L3's borrowed throw (50.1 m against L5's
    45.7 m) agrees; the rule is held to here with the agreement asked
    tightened to 5 %, which refuses it."""
    import faultmesh.derive as derive_module

    ds, _ = _stress_fixture("normal_fault_layer_between_cut_layers.npz")
    grid = np.load(Path(__file__).parent / "data" / "derive" / "normal_fault_layer_between_cut_layers.npz")["grid_L3"]
    derived = derive_faults(ds)
    assert any("L3" in t.layers for t in derived.fault("F1").traces)
    strict = pytest.MonkeyPatch()
    strict.setattr(derive_module, "BORROW_AGREE", 0.05)
    try:
        kept = derive_faults(ds)
    finally:
        strict.undo()
    assert any("L3" in t.layers for t in kept.fault("F1").traces)
    assert any("'F1', layer 'L3'" in w and "kept on the" in w for w in kept.derivation.warnings)
    model = fm.build_model(derived, evaluate=False)
    model.check()
    assert _miss_at_pick(model, ds, "L4", 1143.51, 940.81) < 0.01
    # An L5 pick 3.3 m from the corner of an 830 m long triangle of F1's
    # patch, by the edge there but projecting past its end: the corner
    # takes it (patch_data.cpp place_on_edges; was left out, 6.5 m).
    assert _miss_at_pick(model, ds, "L5", 1707.03, 2380.28) < 0.01
    # Uncut: mean 4.67 m, largest 63.0 m on the 300 true places within
    # 200 m of a fault; cut: 1.54 and 13.2 m (L1's, cut, are 1.59 / 13.2).
    err = _sheet_error(model, "L3", grid[:, :2], grid[:, 2])
    assert np.nanmean(err) < 2.5 and np.nanmax(err) < 20.0


def test_a_fault_block_picked_on_one_line_takes_the_layers_dip_from_the_other_blocks():
    """Stress ground 267 (tests/data/derive/two_normal_faults_blocks_on_one_line_each.npz):
    two normal faults dipping the same way 1 km apart; the block between
    them and the one beyond F2 have their picks on one seismic line each,
    so their side surfaces take the slope across the line from the layer's
    regional slope. That plane's fit had a step across F2 only: F1's 57 m
    throw tilted it across strike twice as steep as the layer, and F2's
    footwall was fitted through the line between the faults together with
    the picks across F1. F2 came out reverse, every layer 11-16 m off on
    average near the faults (largest 56 m). Now the regional plane steps
    across every fault and a side surface keeps to its fault block of the
    other faults (derive._beside_others): F2 normal, means 0.6-1.9 m."""
    name = "two_normal_faults_blocks_on_one_line_each.npz"
    ds, _ = _stress_fixture(name)
    grids = np.load(Path(__file__).parent / "data" / "derive" / name)
    derived = derive_faults(ds)
    assert derived.fault("F2").kind == "normal"
    model = fm.build_model(derived, evaluate=False)
    model.check()
    for lay in ds.layers:
        g = grids["grid_" + lay]
        err = _sheet_error(model, lay, g[:, :2], g[:, 2])
        assert np.nanmean(err) < 3.0, lay


def test_picks_under_the_fault_zones_of_the_layers_above_are_not_lowered():
    """Stress ground 10 (tests/data/derive/normal_fault_picks_under_upper_patches.npz):
    ten layers cut by one normal fault of 104.5 m at 51 degrees, picked on
    four seismic lines. One place on the footwall, 47 m from the fault, has
    picks of L7, L9 and L10; it lies outside L7's patch but inside the
    map-view footprints of the patches of the layers above (a normal
    fault's upper cutoffs lie towards its footwall), whose continuous TINs
    there interpolate across the fault from the hanging wall. The crossing
    repair lowered the L7 pick 59 m under L6 (missed by 54 m; L9's by 91
    m), and raising L6 alone was capped by L5, low there too. Each layer
    above that lies under the datum, under its own patch's top sheet there,
    is raised with it (build._raise_over_data): the ground's mean error near
    the fault 2.12 -> 0.32 m. L10 still misses a pick by 5.0 m, 28 m from
    an L9 datum (a conflict of the data there, which the repair resolves;
    11 m before build._cascade_pins)."""
    ds, truth = _stress_fixture("normal_fault_picks_under_upper_patches.npz")
    model = fm.build_model(derive_faults(ds), evaluate=False)
    model.check()
    assert all(model.metadata["tins"][lay]["raised_over_data"] >= 1 for lay in ("L5", "L6"))
    for lay in ("L7", "L9"):
        assert _miss_at_pick(model, ds, lay, 2604.01, 1869.5) <= 0.5, lay
    _assert_picks_honoured(model, ds, truth, ds.layers[:9], 2.0, 100, 0.5)


def test_a_datum_is_not_lowered_under_a_layer_the_repair_lowered_past_it(monkeypatch):
    """Stress ground 103 (tests/data/derive/low_angle_normal_fault_hole_cuts_out_a_layer.npz):
    eight thin layers cut by a low-angle normal fault of 41.7 m. One place
    10 m inside the study area has picks of L1-L3 and L5-L8 but none of L4
    (the fault cuts it out there). L4's TIN lay at -835.1 m there, above
    the L5 pick (-836.9 m); L3's TIN, bridging the fault, has vertices of
    both walls (-824 and -851 m) within 1-10 m of its pick, the repair gave
    L4 vertices at -851 m round the place, and L4 there fell to -849.6 m
    though L3 stayed at -824.0 m; the L5 pick went down with it, missed by
    12.0 m. Built again with L4 pinned at its elevation before the repair
    there (build._cascade_pins), every pick is honoured."""
    import faultmesh.build as build_module

    ds, truth = _stress_fixture("low_angle_normal_fault_hole_cuts_out_a_layer.npz")
    derived = derive_faults(ds)
    model = fm.build_model(derived, evaluate=False)
    model.check()
    assert _miss_at_pick(model, ds, "L5", 746.45, 2488.21) <= 1e-3
    assert all(r["max_m"] <= 1e-3 for r in model.metadata["data_fit"].values()), model.metadata["data_fit"]
    assert model.metadata["tins"]["L4"]["cascade_pins"] >= 1
    # Without the pins the cascade is there (the test's ground still shows it).
    monkeypatch.setattr(build_module, "_cascade_pins", lambda *a: {})
    unpinned = fm.build_model(derived, evaluate=False)
    assert _miss_at_pick(unpinned, ds, "L5", 746.45, 2488.21) > 10.0


def test_a_repair_that_fails_after_the_stack_raise_builds_with_the_upper_layer_alone():
    """Stress ground 362 (tests/data/derive/two_normal_faults_stack_raise_repair_fails.npz):
    after the raise's stack rule (build._raise_over_data) put an L8 datum's
    point into L7 and the layers above, the crossing repair did not end
    (L9 still crossed L8 after 200 rounds, both with and without the
    derivation's extra points under the patches): the lower layer, lowered
    onto the raised cones' creases, cannot follow them. The build then
    takes the upper layer's raise alone, as before the stack rule, and
    says so; every pick near the faults is honoured as then. The stack
    attempt's repair stops after build.STACK_REPAIR_ROUNDS rounds."""
    ds, truth = _stress_fixture("two_normal_faults_stack_raise_repair_fails.npz")
    model = fm.build_model(derive_faults(ds), evaluate=False)
    model.check()
    retry = model.metadata["repair_retry"]
    assert f"after {fm.build.STACK_REPAIR_ROUNDS} rounds" in retry, retry
    assert "still crosses" in retry and "raised over the data under it alone" in retry, retry
    assert "left out of its continuous TIN" not in retry, retry
    _assert_picks_honoured(model, ds, truth, ds.layers, 1.5, 300, 0.3)


def test_a_raise_by_the_boundary_takes_the_boundary_vertices_round_it():
    """Stress ground 55 (tests/data/derive/low_angle_normal_fault_pick_at_the_boundary.npz):
    eight layers cut by a normal fault of 93 m at 27 degrees, picked on
    three seismic lines. At one place on a line, 2 m inside the study
    area, only L5 and L6 are picked, 115 m above the picks of L5 round it
    (500 m off) and 500 m from the nearest picks of L1-L4, under their
    fault patches. L1-L4 are raised to its L5 datum
    (build._raise_over_data). With that point alone each became a cone
    whose boundary vertices 2 m off stayed 40 m lower; the repair pushed
    L5's TIN under their flanks, L5's patch came out a ramp there, and the
    L5 datum, moved 0.9 m onto a patch edge, was missed by 5.6 m (2.6 m
    with the boundary vertices raised, before the placement solved the
    moved vertex's z: insert_patch_data). Now every datum is honoured."""
    ds, truth = _stress_fixture("low_angle_normal_fault_pick_at_the_boundary.npz")
    model = fm.build_model(derive_faults(ds), evaluate=False)
    model.check()
    assert all(model.metadata["tins"][lay]["raised_over_data"] >= 2 for lay in ("L1", "L2", "L3", "L4"))
    assert _miss_at_pick(model, ds, "L5", 170.68, 1215.71) <= 0.05
    for lay in ds.layers:
        assert model.metadata["data_fit"][lay]["max_m"] <= 0.05, (lay, model.metadata["data_fit"][lay])
    _assert_picks_honoured(model, ds, truth, ds.layers, 1.0, 50, 0.3)


@pytest.mark.xfail(strict=True, reason="open: an end whose band meets an oblique side within reach but whose "
                   "farther cutoff lies beyond it is closed by a pinch-out (faults._extend)")
def test_a_reverse_fault_oblique_to_the_boundary_carries_its_band_onto_it():
    """Open reproducer (tests/data/derive/reverse_fault_oblique_to_the_boundary.npz,
    stress ground 384): six layers cut by a normal fault of 82 m and a
    reverse one (F2) of 98 m at 23 degrees, which runs out of the study area
    across a side about 19 degrees off its strike. L5's and L6's last
    sections lie 110 and 786 m (16 and 783 m) from that side at their two
    cutoffs, 654 m being the extension's reach: judged at the farther
    cutoff (faults._extend), both are closed by pinch-outs, and the picks of
    the repeated sheet beyond are missed by the whole throw (L5: 98.2 m).
    Judged at the nearer cutoff they are carried onto the side (L5 16.6 m
    at most, L6 0.8 m), but so is held-out random ground 167's F1, whose
    band runs nearly along a side (2 and 1,223 m): 0.80 -> 1.45 m near the
    faults, and the true cutoffs' model 2.93 -> 3.97 m. Judged at the nearer
    cutoff only where the two land on one side or round one corner (167's
    land on the two walls of a notch), stress ground 216's F2 was carried
    onto F1's patch and did not build. Also open: L1 and
    L2 repeat at the area's edge where the derivation has F2 cut no layer
    above L3 (missed by 98 m there)."""
    from faultmesh.report import evaluate_surface

    ds, truth = _stress_fixture("reverse_fault_oblique_to_the_boundary.npz")
    d = derive_faults(ds)
    model = fm.build_model(d, evaluate=False)
    model.check()
    layers = model.metadata["faults"]["F2"]["layers"]
    for lay in ("L5", "L6"):
        assert layers[lay]["ends"] == ["extended", "extended"], (lay, layers[lay]["ends"])
        P = np.asarray(ds.points[lay])
        z, dist = truth[lay]
        sel = dist <= 200.0
        lo, hi, _ = evaluate_surface(model.surfaces[lay], P[sel, 0], P[sel, 1])
        err = np.minimum(np.abs(lo - z[sel]), np.abs(hi - z[sel]))
        assert sel.sum() > 50 and np.all(np.isfinite(err))
        assert err.mean() <= 0.6 and err.max() <= 0.5 * 98.28, (lay, err.mean(), err.max())


def test_a_fold_extended_onto_oblique_sides_keeps_its_trend_without_slivers():
    """Regression (tests/data/derive/two_reverse_faults_folds_to_the_boundary.npz,
    a stress generator's ground, seed 22): eight layers cut by two reverse
    faults of 65 and 89 m at 34-35 degrees, 1.1 km apart, picks on eight
    seismic lines. Once the drop rule dropped the section nearest to a
    patch problem (L5 of F1 and L6 of F2 each keep all but one section;
    by throw alone they had lost 16 and 10), L7's patch of F2, extended
    onto the boundary at both ends along the continuous TIN's trend, no
    longer covered its image once at one triangle, and the stitcher
    refused it: "the patch does not cover its XY image once". That
    triangle was a sliver of the loft on the boundary (three points on one
    side, its zero area given a sign by rounding); the builder peels such
    slivers off (faults._drop_boundary_slivers), and the patch keeps its
    ends along the trend (a fallback that carried them unchanged is gone).
    The sliver's sign depends on the last digits of the derived cutoffs
    (the derivation's solver changed them by 1e-9 and it did not occur), so
    the builder's part is tested on the cutoffs derived when it occurred,
    saved beside the ground (..._derived/, README there)."""
    ds, truth = _stress_fixture("two_reverse_faults_folds_to_the_boundary.npz")
    saved = load_dataset(Path(__file__).parent / "data" / "derive" / "two_reverse_faults_folds_to_the_boundary_derived")
    model = fm.build_model(saved, evaluate=False)
    model.check()
    l7 = model.metadata["faults"]["F2"]["layers"]["L7"]
    assert l7["ends"] == ["extended", "extended"] and l7.get("boundary_slivers_dropped", 0) >= 1, l7
    d = derive_faults(ds)
    dropped = [w for fr in d.derivation.faults.values() for w in fr.warnings if "dropped from section" in w]
    assert len(dropped) <= 2, dropped
    for m in (model, fm.build_model(d, evaluate=False)):
        m.check()
        err = _error_near_faults(m, ds, truth)
        assert len(err) > 1000 and np.all(np.isfinite(err))
        assert err.mean() <= 0.5 and err.max() <= 3.0, (err.mean(), err.max())


def _error_on_grid(model, ds, name: str) -> np.ndarray:
    """|dz| of the model against the truth at the fixture's places near the
    faults (``grid_<layer>``: x, y, true z on a grid within 200 m of a true
    fault, away from the picks as much as at them), the nearer sheet where
    a reverse fault folds the surface; infinity where the model has none."""
    f = np.load(Path(__file__).parent / "data" / "derive" / name)
    out = []
    for lay in ds.layers:
        G = f["grid_" + lay]
        err = _sheet_error(model, lay, G, G[:, 2])
        out.append(np.where(np.isfinite(err), err, np.inf))
    return np.concatenate(out)


def test_a_fault_zone_far_from_the_picks_follows_the_layers_trend():
    """Stress ground 17 (tests/data/derive/normal_fault_picks_on_three_lines_far_from_half_of_it.npz):
    eight layers 2.6-34 m thick cut by one steep normal fault of 57 m,
    picked on three seismic lines in one half of the study area (noise
    0.3 m, none within 134 m of the fault). Along the other half no pick
    lies within 400-1,200 m of the fault, and both sides of each layer come
    from the joint fit of their data (derive._joint_sides). That fit, with
    the side surfaces' shortest smoothing length and no tension, followed
    the picks' noise exactly (0.08 m rms where the noise is 0.3 m), traded
    the throw against a bend of the surface in the data gap (18-36 m where
    the truth has 57 m) and extrapolated that bend linearly: cutoffs 140-420
    m too deep, the model 89 m off on average within 200 m of the fault
    (455 m at most; L2 drawn 621 m above L1). Its smoothing length is now
    chosen by cross-validation (derive._noise_smoothing; 32 times the
    default here, throws 54-58 m): 1.4 m on average, 20 m at most."""
    name = "normal_fault_picks_on_three_lines_far_from_half_of_it.npz"
    ds, truth = _stress_fixture(name)
    model = fm.build_model(derive_faults(ds), evaluate=False)
    model.check()
    err = _error_on_grid(model, ds, name)
    assert err.mean() <= 3.0 and err.max() <= 40.0, (err.mean(), err.max())
    _assert_picks_honoured(model, ds, truth, ds.layers, 2.0, 40, 0.5)


def test_derived_faults_too_close_say_where_their_cutoffs_are_extrapolated():
    """tests/data/derive/two_faults_sparse_lines.npz (a stress generator's
    ground, seed 3): two faults that do not meet, 950 m apart, with the
    layers picked on four seismic lines. Where no hanging-wall pick lies
    within 562 m, both faults' L1 cutoffs are extrapolated 450-770 m from
    the true ones and their patches overlap at the study area's edge. The
    error named the pair and the layer and said "give them one 'group' if
    they cross (T or X), or check their traces" -- traces a derived fault
    does not have. It now says which derived fault has how many sections in
    that layer without data of which side within how far, and that data
    nearer the fault or a throw hint place those cutoffs. (Since the joint
    fit across a data gap chooses its smoothing by cross-validation, L1's
    cutoffs there no longer overlap; L2's, extrapolated as far, did.)

    Since each fault's side surfaces keep to their block of the other
    (derive._beside_others), the ground builds and passes check(); the
    message is held to with the sides fitted through both blocks as
    before."""
    import faultmesh.derive as derive_module

    ds, _ = _stress_fixture("two_faults_sparse_lines.npz")
    fm.build_model(ds, evaluate=False).check()
    both_blocks = pytest.MonkeyPatch()
    both_blocks.setattr(derive_module, "_beside_others", lambda faced, D, ext, keys: np.ones(len(D), dtype=bool))
    try:
        with pytest.raises(fm.DatasetError) as err:
            fm.build_model(ds, evaluate=False)
    finally:
        both_blocks.undo()
    msg = str(err.value)
    m = re.match(r"faults too close: fault 'F1' and fault 'F2' overlap in layer '(L\d+)'", msg)
    assert m, msg
    assert "check their traces" not in msg
    for name in ("F1", "F2"):
        assert re.search(rf"fault '{name}' is derived, and on \d+ of its sections in layer '{m.group(1)}' no "
                         r"hanging-wall data lie within \d+ m of its cutoffs", msg), msg
    assert "a 'throw' hint" in msg


def _graben_master_kept_and_model_holds(d, ds, truth, f1_throw: float) -> None:
    """The Y-graben reproducers' master fault F1 normal with its throw on
    every layer it cuts, and the model of the derived dataset ``d`` checked
    and within 1.5 m of every pick."""
    f1 = d.derivation.faults["F1"]
    assert f1.kind == "normal"
    for lay, p in f1.throw.items():
        t = p["throw"][p["cut"]]
        assert len(t) and np.all(np.abs(t - f1_throw) < 2.0), (lay, t)
    m = fm.build_model(d, evaluate=False)
    m.check()
    for lay in ds.layers:
        assert _largest_error_at_picks(m, ds, truth, lay) < 1.5, lay


@pytest.mark.parametrize("kind", [None, "normal"])
@pytest.mark.parametrize("name, f1_throw, hint", [("graben_antithetic_fault_ends_on_the_other.npz", 23.6, 14.0),
                                                   ("graben_antithetic_fault_picks_past_the_other.npz", 22.9, 27.6)])
def test_a_throw_hint_gives_a_fault_block_the_side_it_lacks(name, f1_throw, hint, kind):
    """The Y-graben reproducers below with F2's true throw as its hint (no
    kind): F2's hanging-wall block (the graben floor) has no pick of L1 and
    fewer than three of L2, and took that side from the whole layer, F1's
    footwall across F1, though the hint was given; its throw was minus F1's
    and no section counted as without data near. A block's lacking side is
    now its other side shifted by the hint (_hinted_sides), and such a
    section votes for no sense (its layer's offset at the fault's scale
    would come from across F1): F2 normal with the hint's throw, F1 as
    before. The same with F2's kind given too: derived apart from F1 its
    data say reverse, and labelled normal its patch folded, lost the
    sections that reach F1 and did not meet F1's, so the two were not
    grouped; the derived fault now has the data's kind (label and geometry
    alike)."""
    ds, truth = _stress_fixture(name)
    faults = [replace(f, throw={"max": hint}, kind=kind) if f.name == "F2" else f for f in ds.faults]
    d = derive_faults(replace(ds, faults=faults))
    assert d.derivation.groups == {"F1+F2": ["F1", "F2"]}
    f2 = d.derivation.faults["F2"]
    assert f2.kind == "normal", f2.warnings
    assert any("no hanging-wall data near the cutoff; used the throw hint" in w for w in f2.warnings)
    for lay, p in f2.throw.items():
        t = p["throw"][p["cut"]]
        assert np.all(np.abs(t - hint) < 0.5), (lay, t)
    _graben_master_kept_and_model_holds(d, ds, truth, f1_throw)


@pytest.mark.xfail(strict=True, reason="open: an antithetic fault ending against another whose hanging-wall "
                   "block has no data takes that side from across the other and comes out reverse")
@pytest.mark.parametrize("name, f1_throw", [("graben_antithetic_fault_ends_on_the_other.npz", 23.6),
                                             ("graben_antithetic_fault_picks_past_the_other.npz", 22.9)])
def test_an_antithetic_fault_ending_against_another_takes_no_data_from_across_it(name, f1_throw):
    """Reproducer (tests/data/derive/graben_*.npz, a narrow graben whose
    antithetic fault F2 ends against F1, the graben floor without picks of
    L1 and L2): F2's hanging wall comes from F1's footwall, across F1,
    where F2 does not exist, so its throw is minus F1's and it comes out a
    reverse fault (17 of 18 such grounds of a probe of close faults). What
    should hold: F2 cuts no layer its data show (it is left out, with a
    warning) or has its own throw, F1 keeps its throw, and the model keeps
    to the picks. Leaving out the data beyond a fault that a fault ends
    against (tried at the thirty-sixth stop) made both pass, left 6 of the
    18 reverse, and made grabens whose faults meet under the layers worse
    (5 of 6): not kept."""
    ds, truth = _stress_fixture(name)
    d = derive_faults(ds)
    f2 = d.derivation.faults["F2"]
    assert f2.kind != "reverse"
    assert any("no layer is cut" in w for w in f2.warnings)
    _graben_master_kept_and_model_holds(d, ds, truth, f1_throw)
