"""faultmesh.derive: fault cutoffs derived from fault points and layer data
(issue 11, item 2).

The side split (C++ fault_side) is checked against exact rational
arithmetic; the derivation against ground truths (faultmesh.geology): fault
points sampled from the truth's fault surface, layer data from boreholes.
Per ground: the derived kind, the distance of the derived cutoffs from the
true ones (on the same vertical section line), Model.check() and the error
near the fault against the model built from the true cutoffs (the v1 dataset
of the same ground) on the same sample points.
"""
from __future__ import annotations

from dataclasses import replace
from fractions import Fraction
from pathlib import Path
from typing import Tuple

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import faultmesh
from faultmesh import datasets, derive
from faultmesh.dataset import Boreholes, Dataset, DatasetError, Fault, Section, points_in_polygon
from faultmesh.geology import FaultModel, Geology, smooth_field
# One implementation of each measure (faultmesh.grounds), under the names
# these tests have used.
from faultmesh.grounds import cutoff_distance as true_cutoff_distance
from faultmesh.grounds import near_fault_errors as near_fault_error

# Borehole count of the generated grounds: a jittered grid of about 160 m
# over 3 km x 2.5 km. The derived model's error near the fault is 0.45-0.90x
# that of the model built from the exact v1 cutoffs there (ten grounds,
# docs/derive.md); with 60 holes (about 350 m apart) 0.72-1.26x, except the
# curved fault (2.4x), test_sparse_boreholes below.
N_HOLES = 300


# ---------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------
def fault_points(geo: Geology, name: str, ds: Dataset, step_u: float = 120.0,
                 step_z: float = 40.0, margin: float = 60.0):
    """Points on the truth's fault surface (Geology.plane_z), as fault sticks:
    one stick every ``step_u`` m along strike over the fault's extent, points
    every ``step_z`` m in depth over the layers' elevations +- ``margin``."""
    fm = geo.fault(name)
    zs = np.concatenate([derive.layer_data(ds, lay)[:, 2] for lay in ds.layers])
    z = np.arange(zs.max() + margin, zs.min() - margin, -step_z)
    n = max(3, int(np.ceil((fm.u_range[1] - fm.u_range[0]) / step_u)) + 1)
    u = np.linspace(fm.u_range[0], fm.u_range[1], n)
    U, Z = np.meshgrid(u, z)
    U, Z = U.ravel(), Z.ravel()
    w = (fm.z_ref - Z) / fm.tan_dip + fm.bend_offset(U)
    xy = fm.xy(U, w) + geo.origin
    P = np.column_stack([xy, Z])
    # Geology.plane_z is the truth's fault surface: the points lie on it.
    assert np.allclose(geo.plane_z(name, P[:, 0], P[:, 1]), P[:, 2], atol=1e-6)
    return P, np.searchsorted(u, U)


def v2_of(ds: Dataset, **fault_kw) -> Dataset:
    """The ground of ``ds`` with each fault given by points only (no traces,
    no tips, no kind unless ``kind`` is given): what derive_faults starts
    from."""
    faults = []
    fault_kw = dict(fault_kw)
    kind = fault_kw.pop("kind", None)
    for f in ds.faults:
        P, st_ = fault_points(ds.geology, f.name, ds)
        faults.append(Fault(f.name, kind, f.group, points=P, sticks=st_, **fault_kw))
    return Dataset(name=ds.name + "-v2", layers=ds.layers, boundary=ds.boundary,
                   boreholes=ds.boreholes, points=ds.points, sections={}, faults=faults,
                   crs=ds.crs, truth=ds.truth, geology=ds.geology)


def curved_ground(kind: str, dip: float, bend: float = 150.0, seed: int = 0) -> Dataset:
    """A ground whose one fault is curved in map view (its trace bows by
    ``bend`` m at the ends), at UTM-like coordinates, sampled by N_HOLES
    vertical boreholes, with v1 traces on seven sections across it."""
    rng = np.random.default_rng([seed, 77])
    W, H = 3000.0, 2500.0
    origin = np.array([512345.0, 4123456.0])
    top = smooth_field(base=-300.0, gradient=(0.004, -0.003),
                       waves=[(6.0, 2 * np.pi / 2500, 2 * np.pi / 4000, 0.3)])
    names = ["A", "B", "C"]

    def make(i):
        return lambda X, Y: top(X, Y) - 37.5 * i + (2.0 * np.sin(X / 700.0) if i else 0.0)

    surfaces = {n: make(i) for i, n in enumerate(names)}
    zr = float(np.mean([surfaces[n](np.array([1500.0]), np.array([1250.0]))[0] for n in names]))
    fm = FaultModel("F1", kind, anchor=(1500.0, 1250.0), strike=70.0, dip=dip, throw=25.0,
                    u_range=(-1100.0, 1100.0), z_ref=zr, layers={n: 1.0 for n in names}, bend=bend,
                    flat=250.0, decay=400.0)
    ring = np.array([[0, 0], [W, 0], [W, H], [0, H]], dtype=float) + origin
    geo = Geology(names, surfaces, [fm], origin=origin)
    n_side = int(round(np.sqrt(N_HOLES * W / H)))
    m_side = int(round(N_HOLES / n_side))
    GX, GY = np.meshgrid((np.arange(n_side) + 0.5) / n_side * W, (np.arange(m_side) + 0.5) / m_side * H)
    jit = 0.3 * min(W / n_side, H / m_side)
    P = np.column_stack([GX.ravel(), GY.ravel()]) + rng.uniform(-jit, jit, size=(GX.size, 2)) + origin
    bh = datasets._boreholes(geo, [(f"B{i + 1}", x, y, names[-1]) for i, (x, y) in enumerate(P)])
    sd = np.array([np.sin(np.deg2rad(70.0)), np.cos(np.deg2rad(70.0))])
    secs = {}
    for i, u in enumerate(np.linspace(-900.0, 900.0, 7)):
        o = origin + np.array([1500.0, 1250.0]) + u * sd - 1200.0 * np.array([sd[1], -sd[0]])
        secs[f"S{i + 1}"] = Section(f"S{i + 1}", o, 160.0)
    fault = datasets._fault_from_model(geo, fm, list(secs.values()), ring, rng, names[0])
    return Dataset(name="curved", layers=names, boundary=ring, boreholes=bh, sections=secs,
                   faults=[fault], truth=geo.truth, geology=geo)


# ---------------------------------------------------------------------------
# The side split against exact arithmetic
# ---------------------------------------------------------------------------
def _exact_orient(a, b, c):
    d = (Fraction(a[0]) - Fraction(c[0])) * (Fraction(b[1]) - Fraction(c[1])) \
        - (Fraction(a[1]) - Fraction(c[1])) * (Fraction(b[0]) - Fraction(c[0]))
    return (d > 0) - (d < 0)


def _exact_orient3d(a, b, c, d):
    r = [[Fraction(p[i]) - Fraction(d[i]) for i in range(3)] for p in (a, b, c)]
    det = (r[0][2] * (r[1][0] * r[2][1] - r[2][0] * r[1][1])
           + r[1][2] * (r[2][0] * r[0][1] - r[0][0] * r[2][1])
           + r[2][2] * (r[0][0] * r[1][1] - r[1][0] * r[0][1]))
    return (det > 0) - (det < 0)


def _brute_side(V, T, p, axis, hanging_sign):
    """(side, located triangle) by exact rational arithmetic: the smallest
    triangle index whose closed projection contains p; BEYOND if none."""
    iu, iv = (axis + 1) % 3, (axis + 2) % 3
    q = (p[iu], p[iv])
    for t, (i, j, k) in enumerate(T):
        a, b, c = (V[i, iu], V[i, iv]), (V[j, iu], V[j, iv]), (V[k, iu], V[k, iv])
        # Outside the closed bounding box (exact float comparisons): not in it.
        if not (min(a[0], b[0], c[0]) <= q[0] <= max(a[0], b[0], c[0])
                and min(a[1], b[1], c[1]) <= q[1] <= max(a[1], b[1], c[1])):
            continue
        o = _exact_orient(a, b, c)
        if o == 0:
            continue
        if o * _exact_orient(a, b, q) >= 0 and o * _exact_orient(b, c, q) >= 0 and \
                o * _exact_orient(c, a, q) >= 0:
            return hanging_sign * -o * _exact_orient3d(V[i], V[j], V[k], p), t
    return faultmesh.BEYOND_FAULT, -1


@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([0, 1, 2]), st.sampled_from([1, -1]))
def test_fault_side_matches_exact_brute_force(seed, axis, hanging_sign):
    rng = np.random.default_rng(seed)
    # A bumpy fault TIN at UTM-like magnitudes, a function over the plane of
    # the axes (axis + 1, axis + 2).
    n = 30
    uv = rng.uniform(0.0, 500.0, size=(n, 2))
    w = 40.0 * np.sin(uv[:, 0] / 90.0) + 0.3 * uv[:, 1]
    base = np.array([551234.5, 7817654.25, -10234.125])
    iu, iv = (axis + 1) % 3, (axis + 2) % 3
    V = np.empty((n, 3))
    V[:, iu], V[:, iv], V[:, axis] = uv[:, 0] + base[iu], uv[:, 1] + base[iv], w + base[axis]
    T = np.asarray(faultmesh.delaunay(V[:, [iu, iv]]), dtype=np.int64)
    # Queries: on vertices, on edges (a midpoint rounded: on or a hair off
    # the edge), on the surface (barycentric, rounded), near it, and beyond.
    e = T[rng.integers(0, len(T), 20)]
    bary = rng.dirichlet([1, 1, 1], 20)
    on = np.einsum("kj,kjd->kd", bary, V[T[rng.integers(0, len(T), 20)]])
    Q = np.vstack([V[rng.integers(0, n, 10)], 0.5 * (V[e[:, 0]] + V[e[:, 1]]), on,
                   on + rng.normal(0, 1e-9, size=on.shape) * np.abs(on),
                   base + rng.uniform(-100.0, 600.0, size=(20, 3))])
    side, ext, tri, located = faultmesh.fault_side(V, T, Q, axis=axis, hanging_sign=hanging_sign)
    # The same TIN set up once (FaultSide) answers the same, from its own
    # copies: the caller's arrays changed afterwards change nothing.
    once = faultmesh.FaultSide(V.copy(), T.copy(), axis=axis, hanging_sign=hanging_sign)
    Vc, Tc = V.copy(), T.copy()
    kept = faultmesh.FaultSide(Vc, Tc, axis=axis, hanging_sign=hanging_sign)
    Vc[:] = np.nan
    Tc[:] = 0
    for got in (once.sides(Q), kept.sides(Q)):
        for a, b in zip(got, (side, ext, tri, located)):
            assert np.array_equal(a, b)
    for i, p in enumerate(Q):
        want, wt = _brute_side(V, T, p, axis, hanging_sign)
        assert side[i] == want, (i, p)
        assert bool(located[i]) == (wt >= 0)
        if wt >= 0:
            assert tri[i] == wt and ext[i] == want
        else:
            # Beyond: the side of the plane of the triangle chosen to continue the surface.
            a, b, c = V[T[tri[i]]]
            o = _exact_orient((a[iu], a[iv]), (b[iu], b[iv]), (c[iu], c[iv]))
            assert ext[i] == hanging_sign * -o * _exact_orient3d(a, b, c, p)


def test_fault_side_extent_mask_and_errors():
    V = np.array([[0, 0, 0], [10, 0, -5], [0, 10, 0], [10, 10, -5.0]])
    T = np.array([[0, 1, 2], [1, 3, 2]])
    P = np.array([[2, 2, 5.0], [8, 8, -10.0], [20, 5, 0.0]])
    side, ext, tri, loc = faultmesh.fault_side(V, T, P, extent=np.array([True, False]))
    assert side.tolist() == [1, faultmesh.BEYOND_FAULT, faultmesh.BEYOND_FAULT]
    assert tri.tolist()[:2] == [0, 1]
    assert ext.tolist() == [1, -1, 1] and loc.tolist() == [True, True, False]
    with pytest.raises(ValueError, match=r"fault_side: points must have shape \(n, 3\)"):
        faultmesh.fault_side(V, T, P[:, :2])
    with pytest.raises(ValueError, match="axis must be 0"):
        faultmesh.fault_side(V, T, P, axis=3)
    with pytest.raises(ValueError, match="hanging_sign must be"):
        faultmesh.fault_side(V, T, P, hanging_sign=0)
    with pytest.raises(ValueError, match="extent must be a bool array of shape"):
        faultmesh.fault_side(V, T, P, extent=np.array([True]))
    with pytest.raises(ValueError, match=r"fault_side: points row 1 has a non-finite coordinate \(x = nan\)"):
        faultmesh.fault_side(V, T, np.array([[0, 0, 0], [np.nan, 0, 0.0]]))
    with pytest.raises(ValueError, match="triangles row 1 has vertex index 7"):
        faultmesh.fault_side(V, np.array([[0, 1, 2], [1, 7, 2]]), P)
    # A vertical fault has no area in the projection along z.
    Vv = np.array([[0, 0, 0], [10, 0, 0], [0, 0, 10.0]])
    with pytest.raises(faultmesh.GeometryError, match="projection along z"):
        faultmesh.fault_side(Vv, np.array([[0, 1, 2]]), P)
    # FaultSide: the same checks, named after it.
    with pytest.raises(ValueError, match="FaultSide: hanging_sign must be"):
        faultmesh.FaultSide(V, T, hanging_sign=2)
    with pytest.raises(ValueError, match="FaultSide: extent must be a bool array of shape"):
        faultmesh.FaultSide(V, T, extent=np.array([True]))
    with pytest.raises(ValueError, match="FaultSide: triangles row 1 has vertex index 7"):
        faultmesh.FaultSide(V, np.array([[0, 1, 2], [1, 7, 2]]))
    with pytest.raises(faultmesh.GeometryError, match="FaultSide: the fault surface has no triangle"):
        faultmesh.FaultSide(V, np.zeros((0, 3), dtype=np.int64))
    fs = faultmesh.FaultSide(V, T, extent=np.array([True, False]))
    assert fs.n_triangles == 2
    with pytest.raises(ValueError, match=r"FaultSide.sides: points row 0 has a non-finite coordinate"):
        fs.sides(np.array([[np.inf, 0, 0.0]]))
    assert [a.tolist() for a in fs.sides(P)] == [side.tolist(), ext.tolist(), tri.tolist(), loc.tolist()]


def test_fault_fields_validated():
    with pytest.raises(DatasetError, match=r"fault 'F': points must have shape \(m, 3\)"):
        Fault("F", points=np.zeros((4, 2)))
    with pytest.raises(DatasetError, match="fault 'F': sticks has 3 labels for 4 points"):
        Fault("F", points=np.zeros((4, 3)), sticks=[0, 0, 1])
    with pytest.raises(DatasetError, match="fault 'F': point 2 is not finite"):
        Fault("F", points=[[0, 0, 0], [0, np.inf, 0]])
    with pytest.raises(DatasetError, match="throw max must be a number > 0"):
        Fault("F", throw={"max": -1.0})
    with pytest.raises(DatasetError, match="kind must be 'normal', 'reverse' or None"):
        Fault("F", "sideways")
    with pytest.raises(DatasetError, match="surface triangles must be"):
        Fault("F", surface=(np.zeros((3, 3)), np.array([[0, 1, 3]])))
    f = Fault("F", points=np.zeros((4, 3)), throw={"max": 40.0})
    assert f.kind is None and f.traces == [] and derive.needs_derivation(f)
    assert f == Fault("F", points=np.zeros((4, 3)), throw={"max": 40.0})
    assert f != Fault("F", points=np.ones((4, 3)), throw={"max": 40.0})


# ---------------------------------------------------------------------------
# Side surfaces: minimum-curvature grids
# ---------------------------------------------------------------------------
def test_min_curvature_grid_reproduces_a_plane_and_follows_data():
    """A plane has no curvature: the grid reproduces it everywhere (also
    far from the data, with tension towards its own slope); a smooth
    surface is followed closely at and between the data."""
    rng = np.random.default_rng(5)
    xy = rng.uniform(0.0, 1000.0, size=(200, 2)) + np.array([512000.0, 4100000.0])
    frame = derive.GridFrame.around(xy.mean(axis=0), (np.cos(0.3), np.sin(0.3)),
                                    (-900.0, 900.0), (-900.0, 900.0), 25.0)
    plane = 3.0 + 0.02 * (xy[:, 0] - 512000.0) - 0.05 * (xy[:, 1] - 4100000.0)
    q = np.stack(np.meshgrid(np.linspace(-600, 600, 9), np.linspace(-600, 600, 9)), -1).reshape(-1, 2)
    q = q + xy.mean(axis=0)
    want = 3.0 + 0.02 * (q[:, 0] - 512000.0) - 0.05 * (q[:, 1] - 4100000.0)
    for tension in (None, 150.0):
        slope = derive._regional_slope(np.column_stack([xy, plane]), frame)
        nodes, _ = derive._min_curvature(frame, xy, plane, 2.0, tension, slope)
        got = frame.bilinear(q) @ nodes
        # Bilinear cells reproduce a plane exactly; the solve is accurate to
        # about 1e-9 of the values (tens of metres): 1e-6 m.
        assert np.allclose(got, want, atol=1e-6), tension
    # A smooth surface (wavelength 700 m) from 200 points: close at the data
    # (smoothing length 2 m) and between them.
    wave = 20.0 * np.sin((xy[:, 0] - 512000.0) / 110.0) * np.cos((xy[:, 1] - 4100000.0) / 160.0)
    surf = derive.SideSurface(np.column_stack([xy, wave]), frame=frame, ell=2.0)
    assert np.abs(surf(xy) - wave).max() < 1.0


@pytest.mark.parametrize("nu_short", [True, False])
def test_the_throw_fit_by_its_schur_complement_equals_the_joint_solve(nu_short):
    """The fading fit solves the throw through the Schur complement of the
    surface's banded Cholesky factor (derive._CurvatureFit): the same
    surface and throw as one sparse solve of the joint system (SuperLU), on
    a grid longer along u and one longer along w (the factor numbers the
    nodes along the shorter side), at UTM coordinates, with the minimised
    objective reported as it is."""
    import math

    import scipy.sparse as sp
    from scipy.sparse.linalg import spsolve

    rng = np.random.default_rng(17)
    origin = np.array([512000.0, 4100000.0])
    lu, lw = (1600.0, 700.0) if not nu_short else (700.0, 1600.0)
    xy = origin + rng.uniform([-lu / 2, -lw / 2], [lu / 2, lw / 2], size=(300, 2))
    frame = derive.GridFrame.around(origin, (1.0, 0.0), (-lu / 2, lu / 2), (-lw / 2, lw / 2), 30.0)
    assert (frame.nu < frame.nw) == nu_short
    u, w = frame.uw(xy)
    share = np.where(w > 60.0, rng.uniform(0.3, 1.0, len(u)), 0.0)   # of a throw 25 m + 1 cm/m
    z = -800.0 + 0.03 * u - 0.01 * w - share * (25.0 + 0.01 * u) + rng.normal(0.0, 0.3, len(u))
    knots = np.linspace(-lu / 2, lu / 2, 9)
    fit = derive._CurvatureFit(frame, xy, z, 30.0, 400.0, derive._regional_slope(np.column_stack([xy, z]), frame))
    energy = []
    nodes, T = fit.solve(share, knots, 60.0, energy)
    # The joint system as the fit defines it, solved at once.
    N = len(z)
    H = derive._hat(knots, u).multiply(share[:, None]).tocsr() * (-1.0 / math.sqrt(N))
    D2 = derive._second_differences(knots, 60.0)
    K = sp.bmat([[fit.M, fit.B.T @ H], [H.T @ fit.B, H.T @ H + D2.T @ D2]]).tocsc()
    x = spsolve(K, np.r_[fit.rhs, H.T @ ((z - fit.z0) / math.sqrt(N))])
    # Both solves are accurate to about 1e-9 of these values (hundreds of
    # metres, throws of tens): 1e-6 m.
    assert np.allclose(nodes, x[:frame.n] + fit.z0, atol=1e-6)
    assert np.allclose(T, x[frame.n:], atol=1e-6)
    assert np.abs(T - (25.0 + 0.01 * knots)).max() < 2.0, T
    xs, xt = x[:frame.n], x[frame.n:]
    res = fit.B @ xs + H @ xt - (z - fit.z0) / math.sqrt(N)
    want = float(res @ res + np.sum((fit.R @ xs) ** 2) + np.sum((D2 @ xt) ** 2))
    assert energy == [pytest.approx(want, rel=1e-9)]


def test_a_throw_the_hanging_walls_data_leave_undetermined_is_a_singular_fit():
    """Regression (stress ground 69): hanging-wall data that weigh the
    throw at one place along strike only leave its slope free (the second
    differences do not fix a line), and none leave it free altogether.
    SuperLU returned throws of kilometres for such systems instead of its
    NaN; the Schur complement's pivots name them (derive.SingularFit)."""
    rng = np.random.default_rng(3)
    xy = rng.uniform(0.0, 1000.0, size=(200, 2)) + np.array([300000.0, 6200000.0])
    frame = derive.GridFrame.around(xy.mean(axis=0), (1.0, 0.0), (-520.0, 520.0), (-520.0, 520.0), 40.0)
    u, w = frame.uw(xy)
    z = 100.0 + 0.02 * u
    knots = np.linspace(-520.0, 520.0, 7)
    fit = derive._CurvatureFit(frame, xy, z, 40.0, 400.0, np.zeros(2))
    one = np.zeros(len(z))
    one[np.argmin(np.abs(u - knots[3]))] = 1.0       # a single hanging-wall datum
    for share in (np.zeros(len(z)), one):
        with pytest.raises(derive.SingularFit):
            fit.solve(share, knots, 80.0)
    # Two hanging-wall data at different places along strike fix the line.
    two = one.copy()
    two[np.argmax(u)] = 1.0
    _, T = fit.solve(two, knots, 80.0)
    assert np.all(np.isfinite(T)) and np.abs(T).max() < 1.0, T


def test_tension_keeps_a_dipping_layer_level_across_a_gap():
    """Regression (found on paper_like(0): 4F2 came out reverse): with
    tension towards flat, each side of a dipping, unfaulted layer relaxes
    to level across a data gap at a fault and the two sides meet it at
    different elevations -- a spurious throw. The tension pulls towards the
    layer's regional slope instead: no step."""
    rng = np.random.default_rng(8)
    xy = rng.uniform(0.0, 2000.0, size=(400, 2))
    z = -500.0 + 0.05 * xy[:, 0] + 0.01 * xy[:, 1]
    D = np.column_stack([xy, z])
    foot, hang = xy[:, 0] < 800.0, xy[:, 0] > 1200.0     # a 400 m gap at x = 1000
    frame = derive.GridFrame.around((1000.0, 1000.0), (0.0, 1.0), (-1000.0, 1000.0),
                                    (-1000.0, 1000.0), 40.0)
    split = {"foot": foot, "hanging": hang}
    sides = derive._side_surfaces(D[foot | hang], {k: v[foot | hang] for k, v in split.items()},
                                  frame, 12)
    at = np.column_stack([np.full(5, 1000.0), np.linspace(300.0, 1700.0, 5)])
    step = sides["foot"](at) - sides["hanging"](at)
    assert np.abs(step).max() < 0.05, step
    # The same sides relaxing towards flat (no regional slope) open a step
    # of metres: what the regional slope is for.
    flat = {k: derive.SideSurface(D[m], 12, frame, tension=3.0 * derive._median_spacing(D[m]))
            for k, m in split.items()}
    assert np.abs(flat["foot"](at) - flat["hanging"](at)).min() > 2.0


@pytest.mark.xfail(strict=True, reason="open: the fading-throw fit's throw is underdetermined "
                   "where S may bend (docs/derive.md, accuracy)")
def test_fading_throw_fit_recovers_the_throw_at_the_fault():
    """Reproducer of what derive._decay_sides does not do yet (strict: a fix
    shows here). A hanging wall whose throw (25 m) fades within 250 m of the
    fault, sampled every 150 m, shows it only at its few data nearest the
    fault; its own surface extrapolates the fading bend towards the fault
    (3.4 m off at the fault here). The joint fit with a throw that fades
    into the hanging wall should find the throw at the fault, but its
    throw T(u) is poorly determined: the surface S, which follows the data
    closely, absorbs part of the offset (T 0-28 m along strike where it is
    25 m; 10.7 m off at the fault; with the profile chosen on the full grid
    instead of the coarse one 8.7 m; with T held level along strike, 13 m
    everywhere; with S ten times smoother 2.5 m, but random grounds get
    worse: docs/derive.md). derive uses the fit only where the hanging wall's data stop
    more than a data spacing from the cutoff, where its own surface is no
    better (random grounds as v2, seeds 0-99: 21 of 91 better by more than
    0.05 in ratio, 8 worse)."""
    rng = np.random.default_rng(3)
    tan60 = np.tan(np.deg2rad(60.0))
    # A plane fault striking north, dipping 60 degrees east (the hanging
    # wall is east), through x = 1000 at z = -500: sticks every 100 m.
    ys, zs = np.meshgrid(np.arange(-200.0, 2201.0, 100.0), np.arange(-300.0, -701.0, -25.0))
    P = np.column_stack([1000.0 + (-500.0 - zs.ravel()) / tan60, ys.ravel(), zs.ravel()])
    ring = np.array([[0.0, 0.0], [2000.0, 0.0], [2000.0, 2000.0], [0.0, 2000.0]])
    fs = derive.fault_surface(Fault("F", points=P, sticks=np.searchsorted(np.unique(ys), ys.ravel())),
                              ring, (-700.0, -300.0))
    # A layer dipping gently west, sampled on a jittered 150 m grid; the
    # hanging wall lowered by 25 m up to 50 m from the fault, fading over
    # the next 200 m (a profile of derive.DECAY_PROFILES).
    g = np.arange(75.0, 2000.0, 150.0)
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2) + rng.uniform(-40.0, 40.0, (len(g) ** 2, 2))
    z0 = -500.0 + 0.02 * xy[:, 0]
    z = z0.copy()
    for _ in range(3):  # the distance from the fault at the datum's own elevation
        d = xy[:, 0] - (1000.0 + (-500.0 - z) / tan60)
        z = z0 - np.where(d > 0, 25.0 * derive._decay_share(d, (50.0, 200.0)), 0.0)
    D = np.column_stack([xy, z])
    ext = fs.side(D)[1]
    split = {"hanging": ext >= 0, "foot": ext <= 0}
    frame = derive._side_frame(fs, ring, 600.0, 75.0)
    dec = derive._decay_sides(D, split, frame, 12, 250.0, fs, ring)
    own = derive._side_surfaces(D, split, frame, 12)
    # The hanging wall 5 m from the fault at its elevation, along strike.
    yq = np.linspace(300.0, 1700.0, 8)
    want = -500.0 + 0.02 * 1000.0 - 25.0
    xq = 1000.0 + (-500.0 - want) / tan60 + 5.0
    q = np.column_stack([np.full(8, xq), yq])
    want = want + 0.02 * (xq - 1000.0)
    err_dec = np.abs(dec["hanging"](q) - want)
    err_own = np.abs(own["hanging"](q) - want)
    print(f"hanging wall at the fault: fading-throw fit {err_dec.max():.2f} m, own surface "
          f"{err_own.max():.2f} m; profile {dec['hanging'].profile}")
    # Wanted: within 2.5 m (a tenth of the throw) at the fault, and better
    # than the hanging wall's own surface.
    assert err_dec.max() < 2.5 and err_dec.max() < err_own.max(), (err_dec, err_own)
    assert dec["hanging"].profile is not None  # a fading profile, not a block offset
    # The footwall is the layer as it would be without the fault: the
    # hanging wall's data beyond the fading zone lie on it too.
    far = xy[:, 0] > 1500.0
    assert np.abs(dec["foot"](xy[far]) - z0[far]).max() < 0.5


def test_side_frame_covers_both_sides_of_the_fault():
    """Regression: the grid's second axis is the strike vector turned by
    +90 degrees (up dip here); measuring the fault's footprint and the
    study area down dip instead mirrored the clipped box about the fault:
    for a fault near the study area's edge, the grid stopped short of the
    fault on the wide side."""
    # A N-S fault dipping 60 degrees east, 300 m from the east edge of a
    # 3 km x 2 km study area.
    ring = np.array([[0.0, 0.0], [3000.0, 0.0], [3000.0, 2000.0], [0.0, 2000.0]]) + 5e5
    y = np.linspace(200.0, 1800.0, 9)
    z = np.linspace(-100.0, -400.0, 7)
    Y, Z = np.meshgrid(y, z)
    X = 2700.0 + (-100.0 - Z) / np.tan(np.radians(60.0)) - 150.0
    P = np.column_stack([X.ravel() + 5e5, Y.ravel() + 5e5, Z.ravel()])
    fs = derive.fault_surface(Fault("F", points=P), ring, (-500.0, 0.0), reach=0.0)
    pad = 400.0
    frame = derive._side_frame(fs, ring, pad, 20.0)
    V, _ = fs.own
    # Points up to 0.9 pad from the footprint across strike, both ways,
    # inside the study area: all on the grid.
    q = np.vstack([V[:, :2] + t * np.array([1.0, 0.0]) for t in (-0.9 * pad, -0.5 * pad, 0.5 * pad)])
    q = q[points_in_polygon(q, ring)]
    assert len(q) > 0 and frame.inside(q).all()
    # The side test set up once (FaultSurface.locator) answers as the
    # function, also after a pickle round trip (which drops the C++ object).
    import pickle

    Q = np.c_[q, np.full(len(q), -250.0)]
    want = faultmesh.fault_side(fs.vertices, fs.triangles, Q, axis=fs.axis,
                                hanging_sign=fs.hanging_sign, extent=fs.extent)
    for surf in (fs, pickle.loads(pickle.dumps(fs))):
        assert all(np.array_equal(a, b) for a, b in zip(surf.sides(Q), want))
    assert "locator" not in pickle.loads(pickle.dumps(fs)).__dict__


# ---------------------------------------------------------------------------
# Grounds
# ---------------------------------------------------------------------------
GROUNDS = {
    "normal-35": lambda: datasets.synthetic(0, kind="normal", dip=35.0, n_boreholes=N_HOLES),
    "reverse-60": lambda: datasets.synthetic(1, kind="reverse", dip=60.0, n_boreholes=N_HOLES),
    "reverse-85-steep": lambda: datasets.synthetic(0, kind="reverse", dip=85.0, n_boreholes=N_HOLES),
    "curved-normal-45": lambda: curved_ground("normal", 45.0),
}


@pytest.fixture(scope="module", params=sorted(GROUNDS))
def ground(request):
    ds = GROUNDS[request.param]()
    d = derive.derive_faults(v2_of(ds))
    return request.param, ds, d


def test_derived_cutoffs_kind_and_accuracy(ground):
    name, ds, d = ground
    (ftrue,) = ds.faults
    fr = d.derivation.faults[ftrue.name]
    assert fr.kind == ftrue.kind, (name, fr.warnings)
    assert fr.warnings == [], fr.warnings
    # Projected along the axis nearest to the fault's normal: z at 35
    # degrees, x or y at 60 and 85.
    assert fr.surface.axis == int(np.argmax(np.abs(fr.surface.normal)))
    if name in ("normal-35",):
        assert fr.surface.axis == 2
    elif name in ("reverse-60", "reverse-85-steep"):
        assert fr.surface.axis in (0, 1)
    # Both ends are tips inside the study area (the truth's throw tapers to 0).
    assert fr.ends == ["tip", "tip"] and len(d.fault(ftrue.name).tips) == 2
    # Every layer is displaced, and cut on most sections.
    assert set(fr.cutoffs) == set(ds.layers)
    dist = np.concatenate([true_cutoff_distance(ds.geology, ftrue.name, lay, side, cl[side],
                                                fr.surface.dip_dir)
                           for lay, cl in fr.cutoffs.items() for side in ("foot", "hanging")])
    assert np.isfinite(dist).all()
    print(f"{name}: cutoff distance mean {dist.mean():.2f} max {dist.max():.2f}")
    assert dist.mean() <= 2.0 and dist.max() <= 12.0, (name, dist.mean(), dist.max())
    m1 = faultmesh.build_model(ds, evaluate=False)
    m2 = faultmesh.build_model(d, evaluate=False)
    m1.check()
    m2.check()
    e1, e2 = near_fault_error([m1, m2], ds.geology, np.asarray(ds.boundary))
    print(f"{name}: near-fault error v1 {e1:.3f} derived {e2:.3f} ratio {e2 / e1:.2f}")
    assert e2 <= 1.25 * e1, (name, e1, e2)


# Ground, and the largest error ratio allowed: issue 11's 1.25 for all
# three since the fading-throw fit (derive._decay_sections; normal-60-s1
# was at 1.26 before it).
SPARSE = {
    "normal-35": (lambda: datasets.synthetic(0, kind="normal", dip=35.0, n_boreholes=60), 1.25),
    "reverse-60": (lambda: datasets.synthetic(1, kind="reverse", dip=60.0, n_boreholes=60), 1.25),
    "normal-60-s1": (lambda: datasets.synthetic(1, kind="normal", dip=60.0, n_boreholes=60), 1.25),
}


@pytest.mark.parametrize("name", sorted(SPARSE))
def test_sparse_boreholes(name):
    """60 boreholes, about 350 m apart: each side is extrapolated over
    a few hundred metres to its cutoff. Measured ratios 0.89, 0.81, 0.78
    (normal-35, reverse-60, normal-60-s1; 0.99, 1.00, 0.84 with the
    fading-throw fit only on sections with a data gap at the hanging-wall
    cutoff, derive.DECAY_GAP 1; before the fading-throw fit on
    sections with a data gap at the hanging-wall cutoff 1.10, 1.10, 1.26;
    before the minimum-curvature side surfaces: 1.70, 1.58, 1.85); the
    curved fault of curved_ground with 60 holes, not tested here, is at
    2.30 (3.05 before the fit; docs/derive.md)."""
    make, limit = SPARSE[name]
    ds = make()
    d = derive.derive_faults(v2_of(ds))
    (ftrue,) = ds.faults
    fr = d.derivation.faults[ftrue.name]
    assert fr.kind == ftrue.kind and set(fr.cutoffs) == set(ds.layers)
    m1 = faultmesh.build_model(ds, evaluate=False)
    m2 = faultmesh.build_model(d, evaluate=False)
    m2.check()
    e1, e2 = near_fault_error([m1, m2], ds.geology, np.asarray(ds.boundary))
    print(f"{name} (60 holes): near-fault error v1 {e1:.3f} derived {e2:.3f} ratio {e2 / e1:.2f}")
    assert e2 <= limit * e1, (name, e1, e2)


def test_hanging_wall_and_footwall_hits_of_a_double_hole():
    """A hole through a reverse fault's overlap band meets a layer twice: the
    upper top is split to the hanging wall, the lower to the footwall."""
    ds = datasets.synthetic(1, kind="reverse", dip=60.0)
    v2 = v2_of(ds)
    fs = derive.fault_surface(v2.faults[0], ds.boundary, (-1e4, 1e4))
    b = ds.boreholes
    rows = np.flatnonzero(b.hole_id == "RF1")
    lay = ds.layers[len(ds.layers) // 2]
    hits = rows[b.layer[rows] == lay]
    assert len(hits) == 2
    D = np.column_stack([b.xy[hits], b.z[hits]])
    split = derive.split_by_side(fs, D)
    upper = int(np.argmax(D[:, 2]))
    assert split["hanging"][upper] and not split["foot"][upper]
    assert split["foot"][1 - upper] and not split["hanging"][1 - upper]
    assert not split["beyond"].any()


def test_build_model_derives_faults_given_by_points():
    ds = datasets.synthetic(2, kind="normal", dip=60.0, n_boreholes=120, n_layers=2)
    model = faultmesh.build_model(v2_of(ds))
    model.check()
    rep = model.metadata["derived_faults"]["F1"]
    assert rep["kind"] == "normal" and rep["given_kind"] is None and rep["source"] == "sticks"
    assert model.surfaces[ds.layers[0]].metadata["n_patch_triangles"] > 0
    # A v1 dataset is not derived.
    assert "derived_faults" not in faultmesh.build_model(ds, evaluate=False).metadata


def test_derived_dataset_keeps_what_the_given_one_says():
    """derive_faults returns the given dataset with derived faults, not a
    new one made of some of its fields: the snap distance, the
    adjustments, the point sources (messages name file and row) and the
    drillhole tables stay. Regression: it kept ten fields and dropped
    these four (a derived dataset's messages named no file, and a build
    from it took the default snap distance)."""
    ds = datasets.synthetic(2, kind="normal", dip=60.0, n_boreholes=120, n_layers=2)
    v2 = replace(v2_of(ds), snap_distance=0.25, point_sources={ds.layers[0]: ("top.csv", None)},
                 drillholes=object())
    d = derive.derive_faults(v2)
    assert d.snap_distance == 0.25 and d.point_sources == v2.point_sources
    assert d.drillholes is v2.drillholes and d.adjustments == v2.adjustments
    assert d.derivation is not None and d.faults[0].traces


def test_given_kind_contradicted_is_a_warning():
    ds = datasets.synthetic(0, kind="normal", dip=60.0, n_boreholes=120, n_layers=2)
    v2 = v2_of(ds)
    v2.faults[0].kind = "reverse"
    d = derive.derive_faults(v2)
    fr = d.derivation.faults["F1"]
    assert fr.kind == "normal" and fr.given_kind == "reverse"
    assert any("given as reverse but the data say normal" in w for w in fr.warnings)
    # The derived fault is of the data's kind, its geometry and its label
    # alike (a patch labelled with the other kind folds onto itself: the
    # Y-graben of tests/test_derive_blocks.py given as normal); the report
    # keeps the user's word.
    assert d.faults[0].kind == "normal"
    # The derived fault is what the builder consumes: no second derivation.
    assert not derive.needs_derivation(d.faults[0]) and d.faults[0].points is None


def test_hand_drawn_cutoffs_win():
    ds = datasets.synthetic(0, kind="normal", dip=60.0, n_boreholes=120, n_layers=2)
    P, st_ = fault_points(ds.geology, "F1", ds)
    given = ds.faults[0].traces[2]
    keep_layer = ds.layers[0]
    hand = type(given)(given.section, given.plane, {keep_layer: given.layers[keep_layer]})
    v2 = Dataset(name="mixed", layers=ds.layers, boundary=ds.boundary, boreholes=ds.boreholes,
                 sections=ds.sections, faults=[Fault("F1", None, points=P, sticks=st_, traces=[hand])],
                 truth=ds.truth, geology=ds.geology)
    d = derive.derive_faults(v2)
    out = [t for t in d.faults[0].traces if t.section == given.section]
    assert len(out) == 1
    (t,) = out
    # The hand-drawn layer is kept as given, the missing one derived on that section.
    assert np.array_equal(t.layers[keep_layer]["foot"], given.layers[keep_layer]["foot"])
    assert np.array_equal(t.layers[keep_layer]["hanging"], given.layers[keep_layer]["hanging"])
    other = ds.layers[1]
    assert other in t.layers
    sec = ds.sections[given.section]
    for side in ("foot", "hanging"):
        assert np.allclose(sec.to_xy(sec.to_s(t.layers[other][side][:, :2])), t.layers[other][side][:, :2])
    # The derived cutoffs of the other layer agree with the hand-drawn (true) ones.
    assert np.linalg.norm(t.layers[other]["foot"][-1] - given.layers[other]["foot"][-1]) < 5.0
    # No derived section closer than half a spacing to the given one.
    u = d.derivation.faults["F1"].surface.u
    ug = float(u(given.plane[:, :2]).mean())
    for tr in d.faults[0].traces:
        if tr is not t:
            assert abs(float(u(tr.plane[:, :2]).mean()) - ug) > 100.0
    faultmesh.build_model(d, evaluate=False).check()


def test_throw_hint_where_a_side_has_no_data():
    """Without hanging-wall data near the fault the hanging wall is
    extrapolated (warning); a throw hint is used there instead."""
    ds = datasets.synthetic(0, kind="normal", dip=60.0, n_boreholes=N_HOLES, n_layers=2)
    fm = ds.geology.fault("F1")
    b = ds.boreholes
    X, Y = ds.geology.local(b.xy[:, 0], b.xy[:, 1])
    d_hw = fm.d(X, Y)
    # Remove every hole within 500 m on the hanging-wall side of the trace.
    drop = (d_hw > -50.0) & (d_hw < 500.0)
    keep = ~np.isin(b.hole_id, np.unique(b.hole_id[drop]))
    sparse = Dataset(name="sparse", layers=ds.layers, boundary=ds.boundary,
                     boreholes=Boreholes(b.hole_id[keep], b.xy[keep], b.layer[keep], b.z[keep]),
                     truth=ds.truth, geology=ds.geology, faults=ds.faults)
    d0 = derive.derive_faults(v2_of(sparse))
    assert any("no hanging-wall data within" in w for w in d0.derivation.faults["F1"].warnings)
    d1 = derive.derive_faults(v2_of(sparse, throw={"max": 20.0}))
    fr = d1.derivation.faults["F1"]
    assert any("used the throw hint 20 m" in w for w in fr.warnings)
    # Where the hint was used the throw is the hint (the hanging wall follows
    # the footwall 20 m down).
    used = [w for w in fr.warnings if "used the throw hint" in w]
    lay = ds.layers[0]
    t = fr.throw[lay]["throw"][fr.throw[lay]["cut"]]
    assert len(used) > 0 and np.any(np.abs(t - 20.0) < 1.0), t
    faultmesh.build_model(d1, evaluate=False).check()


def _one_side_only(ds: Dataset, keep: str) -> Dataset:
    """``ds`` with every hole on the other side of its fault F1 (and within
    50 m of its trace on this one) taken out: a fault whose ``keep`` wall
    ("foot" or "hanging") alone has data, in every layer."""
    d_hw = _hanging_wall_distance(ds)
    drop = d_hw > -50.0 if keep == "foot" else d_hw < 50.0
    b = ds.boreholes
    return _with_rows(ds, ~np.isin(b.hole_id, np.unique(b.hole_id[drop])), f"{keep} only")


def _hanging_wall_distance(ds: Dataset) -> np.ndarray:
    """Each borehole row's signed distance from the fault F1 of ``ds``'s
    truth (positive on its hanging wall)."""
    b = ds.boreholes
    return ds.geology.fault("F1").d(*ds.geology.local(b.xy[:, 0], b.xy[:, 1]))


def _with_rows(ds: Dataset, keep: np.ndarray, name: str) -> Dataset:
    """``ds`` with only the borehole rows ``keep`` (bool per row)."""
    b = ds.boreholes
    return Dataset(name=name, layers=ds.layers, boundary=ds.boundary,
                   boreholes=Boreholes(b.hole_id[keep], b.xy[keep], b.layer[keep], b.z[keep]),
                   truth=ds.truth, geology=ds.geology, faults=ds.faults)


@pytest.mark.parametrize("kind,keep", [("normal", "foot"), ("reverse", "hanging")])
def test_throw_hint_where_a_side_has_no_data_at_all(kind, keep):
    """A fault with no datum on one side in any layer: without a hint it cuts
    no layer (its throw is unknowable from the data; warning); with a throw
    hint that side is the other shifted by the hint, in the given kind's
    sense, and the fault is in the model -- nearer the truth than the model
    without it."""
    from faultmesh.grounds import near_fault_errors

    ds = datasets.synthetic(0, kind=kind, dip=60.0, n_boreholes=N_HOLES, n_layers=2, throw=20.0)
    half = _one_side_only(ds, keep)
    d0 = derive.derive_faults(v2_of(half))
    assert any("no layer is cut" in w for w in d0.derivation.faults["F1"].warnings)
    d1 = derive.derive_faults(v2_of(half, throw={"max": 20.0}, kind=kind))
    fr = d1.derivation.faults["F1"]
    gone = "hanging" if keep == "foot" else "foot"
    assert fr.kind == kind, fr.warnings
    assert any(f"0 {gone}-wall data; that wall is the other's surface shifted by the throw hint 20 m "
               f"as a {kind} fault" in w for w in fr.warnings), fr.warnings
    sgn = 1.0 if kind == "normal" else -1.0
    for lay in ds.layers:
        t = sgn * fr.throw[lay]["throw"][fr.throw[lay]["cut"]]
        # The synthetic fault dies out at two tips inside the area: the hint
        # in the middle, less towards the tips (_hint_share), never more.
        assert len(t) >= 5 and np.all(t > 0.0) and np.all(t <= 20.0 + 1e-6), (lay, t)
        mid = len(t) // 2
        assert t.max() > 19.0 and t[0] < 0.5 * t[mid] and t[-1] < 0.5 * t[mid], (lay, t)
    m0 = faultmesh.build_model(d0, evaluate=False)
    m1 = faultmesh.build_model(d1, evaluate=False)
    m1.check()
    e0, e1 = near_fault_errors([m0, m1], ds.geology, np.asarray(ds.boundary))
    assert e1 < 0.5 * e0, (e0, e1)
    # Without a kind the sense is the one a 60-degree fault usually has
    # (normal), and said so.
    d2 = derive.derive_faults(v2_of(half, throw={"max": 20.0}))
    assert any("(no kind given; no data show it; it dips 60 degrees" in w
               for w in d2.derivation.faults["F1"].warnings), d2.derivation.faults["F1"].warnings
    assert d2.derivation.faults["F1"].kind == "normal"


def _without_layer_data(ds: Dataset, layer: str, d_lo: float, d_hi: float) -> Dataset:
    """``ds`` without the data of ``layer`` whose signed distance from the
    fault F1 (positive on its hanging wall) lies in (d_lo, d_hi)."""
    d_hw = _hanging_wall_distance(ds)
    return _with_rows(ds, ~((ds.boreholes.layer == layer) & (d_hw > d_lo) & (d_hw < d_hi)),
                      f"{layer} thinned")


@pytest.mark.parametrize("hint", [None, {"max": 20.0}])
def test_a_layer_between_displaced_layers_takes_their_throw(hint):
    """The middle of three layers has no hanging-wall datum within 800 m of
    a 20 m normal fault (its other data are as dense as the others'): on
    each section its hanging-wall cutoff is the footwall's shifted by the
    throw of the layers above and below (conformable layers), said in a
    warning, where its own far data extrapolated gave throws under 1 m and
    left it uncut without a word (error near the fault 2.34 m against 0.17
    with all data; 0.24 now). A throw hint changes nothing: data-based
    throws come first."""
    from faultmesh.grounds import near_fault_errors

    ds = datasets.synthetic(2, kind="normal", dip=60.0, n_boreholes=N_HOLES, n_layers=3, throw=20.0)
    mid = ds.layers[1]
    thin = derive.derive_faults(v2_of(_without_layer_data(ds, mid, 0.0, 800.0), throw=hint))
    fr = thin.derivation.faults["F1"]
    assert fr.kind == "normal"
    said = [w for w in fr.warnings if w.startswith(f"fault 'F1', layer '{mid}'")
            and "the throw of the layers above and below on this section" in w]
    assert len(said) >= 5, fr.warnings
    cut = fr.throw[mid]["cut"]
    t_mid = fr.throw[mid]["throw"]
    t_nb = 0.5 * (fr.throw[ds.layers[0]]["throw"] + fr.throw[ds.layers[2]]["throw"])
    assert cut.sum() >= 5
    both = cut & fr.throw[ds.layers[0]]["cut"] & fr.throw[ds.layers[2]]["cut"]
    # Within 1 m of its neighbours' mean on most sections (the end sections
    # have data near and keep their own).
    assert np.count_nonzero(np.abs(t_mid - t_nb)[both] < 1.0) >= 0.75 * both.sum(), (t_mid, t_nb)
    full = derive.derive_faults(v2_of(ds))
    models = [faultmesh.build_model(d, evaluate=False) for d in (full, thin)]
    for m in models:
        m.check()
    e_full, e_thin = near_fault_errors(models, ds.geology, np.asarray(ds.boundary))
    assert e_thin < 2.0 * e_full + 0.1, (e_full, e_thin)


def test_a_throw_hint_gives_way_to_the_throw_of_the_next_layer():
    """The top layer has no hanging-wall datum within 800 m of a 20 m
    normal fault whose throw dies out towards two tips: without a hint its
    far data are extrapolated (said); with the fault's largest throw as
    the hint, each section without data near takes the throw the layer
    below shows there (at most the hint), not the hint's share along
    strike: error near the fault 1.13 m without the hint, 0.40 m with it."""
    from faultmesh.grounds import near_fault_errors

    ds = datasets.synthetic(2, kind="normal", dip=60.0, n_boreholes=N_HOLES, n_layers=3, throw=20.0)
    top, nxt = ds.layers[0], ds.layers[1]
    thin = _without_layer_data(ds, top, 0.0, 800.0)
    plain = derive.derive_faults(v2_of(thin))
    assert any(w.startswith(f"fault 'F1', layer '{top}'") and "extrapolated (give a throw hint" in w
               for w in plain.derivation.faults["F1"].warnings)
    hinted = derive.derive_faults(v2_of(thin, throw={"max": 20.0}))
    fr = hinted.derivation.faults["F1"]
    used = [w for w in fr.warnings if w.startswith(f"fault 'F1', layer '{top}'")
            and f"used the throw of layer '{nxt}' on this section" in w]
    assert len(used) >= 4, fr.warnings
    assert not any(w.startswith(f"fault 'F1', layer '{top}'") and "used the throw hint" in w
                   for w in fr.warnings), fr.warnings
    t_top, t_nxt = fr.throw[top]["throw"], fr.throw[nxt]["throw"]
    assert np.all(t_top <= 20.0 + 1e-6)
    assert np.count_nonzero(np.abs(t_top - t_nxt) < 0.5) >= len(used), (t_top, t_nxt)
    full = derive.derive_faults(v2_of(ds))
    models = [faultmesh.build_model(d, evaluate=False) for d in (full, plain, hinted)]
    for m in models[1:]:
        m.check()
    e_full, e_plain, e_hinted = near_fault_errors(models, ds.geology, np.asarray(ds.boundary))
    assert e_hinted < 0.5 * e_plain, (e_full, e_plain, e_hinted)


@pytest.mark.parametrize("kind,dip", [("reverse", 32.0), ("normal", 58.0)])
def test_throw_hint_without_kind_takes_the_sense_of_the_dip(kind, dip):
    """A fault with data on one side only, a throw hint and no kind: no
    data show its sense, so it is the one its dip suggests (Anderson:
    reverse faults dip about 30 degrees, normal ones about 60), said in a
    warning, and the model is as near the truth as with the kind given
    (holes-only random_ground(67), F2 reverse at 33 degrees, came out
    normal)."""
    from faultmesh.grounds import near_fault_errors

    ds = datasets.synthetic(1, kind=kind, dip=dip, n_boreholes=N_HOLES, n_layers=2, throw=20.0)
    keep = "foot" if kind == "normal" else "hanging"
    half = _one_side_only(ds, keep)
    given = derive.derive_faults(v2_of(half, throw={"max": 20.0}, kind=kind))
    unsaid = derive.derive_faults(v2_of(half, throw={"max": 20.0}))
    fr = unsaid.derivation.faults["F1"]
    assert fr.kind == kind, fr.warnings
    assert any(f"as a {kind} fault (no kind given; no data show it; it dips {dip:.0f} degrees" in w
               for w in fr.warnings), fr.warnings
    models = [faultmesh.build_model(d, evaluate=False) for d in (given, unsaid)]
    for m in models:
        m.check()
    e_given, e_unsaid = near_fault_errors(models, ds.geology, np.asarray(ds.boundary))
    assert e_unsaid <= 1.05 * e_given + 0.05, (e_given, e_unsaid)


def _east_dipping_plane(name: str, x_at_200: float, dip: float, ring: np.ndarray,
                        ys: Tuple[float, float] = (100.0, 1900.0)):
    """The fault surface of a N-S plane dipping ``dip`` degrees east, at
    x = ``x_at_200`` (local, + 5e5) 200 m down, from points on sticks
    between y = ``ys``."""
    y = np.linspace(ys[0], ys[1], 10)
    z = np.linspace(-50.0, -400.0, 8)
    Y, Z = np.meshgrid(y, z)
    X = x_at_200 + (-200.0 - Z) / np.tan(np.radians(dip))
    P = np.column_stack([X.ravel() + 5e5, Y.ravel() + 5e5, Z.ravel()])
    return derive.fault_surface(Fault(name, points=P), ring, (-500.0, 0.0), reach=0.0)


def test_holes_that_repeat_a_section_across_a_fault_say_it_is_reverse():
    """A hole that enters a layer twice, first on a fault's hanging wall and
    again below it on its footwall, crossed that fault with a repeated
    section: only a reverse fault makes one. Not where both tops lie on one
    side, nor where another fault lies between them too (either could have
    repeated them), nor for a layer met once."""
    ring = np.array([[0.0, 0.0], [3000.0, 0.0], [3000.0, 2000.0], [0.0, 2000.0]]) + 5e5
    f1 = _east_dipping_plane("F1", 1500.0, 40.0, ring)
    f2 = _east_dipping_plane("F2", 1550.0, 40.0, ring, ys=(100.0, 600.0))
    # At (1500, y) F1 lies 200 m down; F2, 50 m east of it and only
    # between y = 100 and 600, 158 m down.
    holes = [("R1", 1500.0, 1000.0, "A", -150.0), ("R1", 1500.0, 1000.0, "B", -180.0),
             ("R1", 1500.0, 1000.0, "A", -260.0),         # A again under F1: repeated
             ("R2", 1400.0, 900.0, "A", -60.0), ("R2", 1400.0, 900.0, "A", -90.0),  # both above F1 (-116 m)
             ("R3", 1500.0, 400.0, "A", -100.0), ("R3", 1500.0, 400.0, "A", -300.0),  # F2 and F1 between
             ("R4", 1520.0, 1200.0, "B", -150.0), ("R4", 1520.0, 1200.0, "B", -300.0)]  # repeated
    b = Boreholes([h[0] for h in holes], np.array([h[1:3] for h in holes]) + 5e5,
                  [h[3] for h in holes], [h[4] for h in holes])
    assert derive._repeated_section(b, f1, [f2]) == [("R1", "A"), ("R4", "B")]
    # Without F2 R3's repetition is F1's; F2's only without F1.
    assert derive._repeated_section(b, f1, []) == [("R1", "A"), ("R3", "A"), ("R4", "B")]
    assert derive._repeated_section(b, f2, [f1]) == []
    assert derive._repeated_section(b, f2, []) == [("R3", "A")]
    # Tops beyond the fault's extent (F1's points end 400 m down, 238 m
    # east of 200 m down): not its repetition.
    far = Boreholes(["H"] * 2, np.full((2, 2), 2400.0 + 5e5), ["A", "A"], [-150.0, -1000.0])
    assert derive._repeated_section(far, f1, []) == []
    # No repeated layer at all, and no rows.
    one = Boreholes(["H"] * 2, np.full((2, 2), 1500.0 + 5e5), ["A", "B"], [-150.0, -260.0])
    assert derive._repeated_section(one, f1, []) == []
    assert derive._repeated_section(Boreholes.empty(), f1, []) == []


def test_a_repeated_section_gives_the_throw_hint_its_sense(monkeypatch):
    """A reverse fault dipping 58 degrees (the dip of a normal fault) with
    data on its hanging wall only in its lower layer, a throw hint and no
    kind: the hint's side is shifted in the sense the dip suggests
    (normal) -- unless holes cross the fault and repeat the upper layer,
    which only a reverse fault does: then in the reverse sense, and the
    warning names the holes. The fault is reverse either way (the crossing
    holes' tops are data near it on both sides of the upper layer)."""
    ds = datasets.synthetic(1, kind="reverse", dip=58.0, n_boreholes=N_HOLES, n_layers=2, throw=20.0)
    half = _one_side_only(ds, "hanging")
    plain = derive.derive_faults(v2_of(half, throw={"max": 20.0}))
    assert plain.derivation.faults["F1"].kind == "normal"
    # Holes where the truth has two sheets of the top layer (the reverse
    # fault's overlap): both tops, hanging wall over footwall.
    geo, lay = ds.geology, ds.layers[0]
    lo, hi = np.asarray(ds.boundary).min(axis=0), np.asarray(ds.boundary).max(axis=0)
    g = np.stack(np.meshgrid(np.linspace(lo[0], hi[0], 400), np.linspace(lo[1], hi[1], 80)), -1).reshape(-1, 2)
    two = g[geo.n_sheets(lay, g[:, 0], g[:, 1]) == 2]
    two = two[np.linspace(0, len(two) - 1, 3).astype(int)]
    sheets = np.asarray(geo.sheets(lay, two[:, 0], two[:, 1]))
    rows = [(f"X{k}", p, z) for k, p in enumerate(two) for z in np.sort(sheets[k][np.isfinite(sheets[k])])[::-1][:2]]
    b = half.boreholes
    crossing = replace(half, boreholes=Boreholes(
        np.r_[b.hole_id, [r[0] for r in rows]], np.vstack([b.xy, [r[1] for r in rows]]),
        np.r_[b.layer, [lay] * len(rows)], np.r_[b.z, [r[2] for r in rows]]))
    d = derive.derive_faults(v2_of(crossing, throw={"max": 20.0}))
    fr = d.derivation.faults["F1"]
    assert fr.kind == "reverse", fr.warnings
    hinted = [w for w in fr.warnings if "shifted by the throw hint" in w]
    assert hinted and all("as a reverse fault (no kind given; hole(s) X0 (" in w and "repeated section" in w
                          for w in hinted), fr.warnings
    faultmesh.build_model(d, evaluate=False).check()
    # Without the rule, the same data's hint would be normal.
    monkeypatch.setattr(derive, "_repeated_section", lambda *a: [])
    blind = derive.derive_faults(v2_of(crossing, throw={"max": 20.0})).derivation.faults["F1"]
    assert any("as a normal fault (no kind given; no data show it; it dips 58" in w
               for w in blind.warnings), blind.warnings


@pytest.mark.parametrize("strike_deg", [0.0, 30.0])
def test_sticks_picked_to_the_edge_of_the_survey_reach_the_boundary(strike_deg):
    """A fault picked on sticks every 100 m up to within 9 m of the study
    area's edge (the survey's; the default study area is the data's
    bounding box) runs out of the area: both ends on the boundary. The end
    was taken as reaching it only when the median distance of the points
    of its last tenth (here 400 m of a 4 km fault) was within a stick
    spacing, which is about half that tenth more than the gap: tips at
    both ends, and the throw tapered to nothing there (a probe's ground,
    31.6 m off near the boundary). Sticks that stop 500 m short, where the
    fault dies out, end at a tip."""
    a = np.radians(strike_deg)
    e_s, e_d = np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])  # strike, dip dir.
    centre = np.array([512345.67, 6012345.67])
    half = 2000.0

    def fault(lo: float, hi: float):
        s_ = np.arange(lo, hi + 1e-9, 100.0)
        z = np.linspace(-100.0, -500.0, 9)
        S, Z = np.meshgrid(s_, z, indexing="ij")
        D = (-300.0 - Z) / np.tan(np.radians(60.0))   # 60 degrees, through the centre at 300 m
        xy = centre + S.ravel()[:, None] * e_s + D.ravel()[:, None] * e_d
        return Fault("F", points=np.c_[xy, Z.ravel()], sticks=np.repeat(np.arange(len(s_)), len(z)))

    # The study area: a square of side 2 x half around the centre, turned
    # with the fault (its edges square to strike at both ends).
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float) * half
    ring = centre + corners[:, :1] * e_s + corners[:, 1:] * e_d
    ring = np.round(ring, 2)
    # Sticks at -1991 ... 1991 m along strike: the last ones 9 m inside.
    through = derive.fault_surface(fault(-half + 9.0, half - 9.0), ring, (-600.0, 0.0))
    assert through.ends == ["boundary", "boundary"]
    tipped = derive.fault_surface(fault(-half + 500.0, half - 9.0), ring, (-600.0, 0.0))
    assert tipped.ends == ["inside", "boundary"]


def test_a_plane_with_a_step_is_undetermined_by_data_on_lines():
    """The regional plane (and step) of a layer's data: determined by data
    over an area; not by data on one line, nor by a side on each of two
    parallel lines with a step between them, whatever the rounding of
    their coordinates leaves across the lines (there the fits took slopes
    of 4 to 12 from it, and the side surfaces pulled towards them reached 1
    km above the layer). The slope along the lines is still the data's, the
    slope across them none."""
    rng = np.random.default_rng(7)
    frame = derive.GridFrame.around(np.array([5e5, 6e6]), (1.0, 0.0), (-100.0, 1100.0), (-100.0, 1100.0), 50.0)
    t = np.linspace(0.0, 1000.0, 41)

    def layer(x, y):
        return -200.0 + 0.05 * (x - 5e5) - 0.02 * (y - 6e6)

    # One line along x, y rounded to 1 cm, z to 1 cm.
    xy = np.c_[5e5 + t, 6e6 + 400.0 + rng.uniform(-0.005, 0.005, len(t))]
    D = np.c_[np.round(xy, 2), np.round(layer(xy[:, 0], xy[:, 1]) + rng.normal(0, 0.05, len(t)), 2)]
    coef, determined = derive._plane_step_fit(D, frame)
    assert not determined
    slope = derive._regional_slope(D, frame)
    assert abs(slope[0] - 0.05) < 0.005 and abs(slope[1]) < 0.01, slope
    # Two parallel lines, the second 300 m off and 20 m down (a fault between).
    xy2 = xy + [0.0, 300.0]
    D2 = np.vstack([D, np.c_[np.round(xy2, 2), np.round(layer(xy2[:, 0], xy2[:, 1]) - 20.0, 2)]])
    hw = np.r_[np.zeros(len(D), bool), np.ones(len(D), bool)]
    assert not derive._plane_step_fit(D2, frame, hw)[1]
    slope = derive._regional_slope(D2, frame, hw)
    assert abs(slope[0] - 0.05) < 0.005 and abs(slope[1]) < 0.01, slope
    # Holes over the area: determined, the plane and the step recovered.
    P = rng.uniform([5e5, 6e6], [5e5 + 1000.0, 6e6 + 1000.0], (60, 2))
    h = P[:, 1] > 6e6 + 500.0
    D3 = np.c_[P, layer(P[:, 0], P[:, 1]) - 20.0 * h]
    coef, determined = derive._plane_step_fit(D3, frame, h)
    assert determined
    np.testing.assert_allclose(coef[1:], [0.05, -0.02, -20.0], atol=1e-6)


@pytest.mark.parametrize("folder", ["probe_picks_on_one_line_per_block",
                                    "probe_picks_on_three_lines_step_trades_slope",
                                    "probe_crossing_faults_picks_on_four_lines",
                                    "probe_graben_small_fault_between_masters"])
def test_fault_blocks_with_picks_on_one_line_stay_near_their_layer(folder):
    """Regression, a probe's ground (tests/data/derive/probe_picks_on_one_line_per_block):
    four faults (a graben and two more) grouped as they meet, the layers
    picked on three seismic lines, so that several fault blocks hold the
    picks of one line only. Their regional plane took its slope across the
    line from the rounding of the picks' coordinates, and the block's and
    the fading-throw fit's surfaces followed it: derived polylines down to
    -1,347 m and up to +1,602 m for layers picked between -389 and -198 m
    (the model 731 m off). Every derived trace now lies within 100 m of
    its layer's picks' elevations. The second ground (seed 47 of the same
    generator): where a side lies on each of two lines, the slope along
    them that the plane with its step fitted there (0.25 along 3 km of
    data spanning 66 m) is the step's trade, not the layer's: its side
    surfaces went 322 m past their layer's picks until such a slope was
    dropped. The third (seed 42): two crossing faults, four lines; where
    the fading-throw fit of a section in a fault block said the other
    sense, the section went back to the whole layer's surfaces instead of
    its block's, which mix the blocks across F1's 70 m throw: F2's wall
    polylines 150-280 m off the nearest pick's elevation, 200-590 m off
    the truth. The fourth (seed 81): a graben whose 3.6 m fault F1 lies
    between the masters (72 and 68 m); the joint fit across a data gap of
    F1's block, with a cross-validated smoothing length, got throws of
    -207 to -577 m and L3 cutoffs 218 m off the picks' elevation (120 m
    before that smoothing): such a throw (beyond derive.THROW_RANGE times
    the data's elevation range) is now no fit, as the fading fit's. Every
    point of a derived polyline lies within 100 m of the elevation of its
    layer's nearest pick (XY; the four grounds' throws
    and slopes make up to 88 m of that)."""
    from scipy.spatial import cKDTree

    ds = faultmesh.load_dataset(Path(__file__).parent / "data" / "derive" / folder / "dataset.json")
    d = derive.derive_faults(ds)
    for f in d.faults:
        for tr in f.traces:
            for lay, sides in tr.layers.items():
                picks = ds.points[lay]
                tree = cKDTree(picks[:, :2])
                for side, P in sides.items():
                    dz = np.abs(P[:, 2] - picks[tree.query(P[:, :2])[1], 2])
                    assert dz.max() <= 100.0, (f.name, tr.section, lay, side, dz.max())
    faultmesh.build_model(d, evaluate=False).check()


@pytest.mark.parametrize("seed,fault,kind", [(12, "F1", "reverse"), (15, "F1", "normal")])
def test_a_sense_the_sparse_holes_do_not_show_is_the_dip_s(seed, fault, kind, tmp_path):
    """Holes-only random grounds as v2 (28 and 78 holes over 4-6 km): the
    cutoff throws, each side's surface carried 300-500 m from its nearest
    hole to the fault, show a few metres of either sign (12: L1 -3.8 m,
    L2 +2.0 m, L3 +6.7 m; 15: -1.5 m twice), under 2 % of the distance they
    are carried over (derive.SENSE_MIN): no sense. The kind is then the
    one its dip suggests (12: reverse at 34 degrees; 15: normal at 63),
    the truth's, where the throws' sum had said the other."""
    import faultmesh.grounds as gr

    spec, geo, p1 = gr.make_ground(seed, tmp_path)
    ds = faultmesh.load_dataset(gr.write_v2(faultmesh.load_dataset(p1), geo, spec, tmp_path / "v2",
                                            section_picks=False))
    fr = derive.derive_faults(ds).derivation.faults[fault]
    assert fr.kind == kind, fr.warnings
    assert any("show no sense beyond what the sides' slopes" in w and f"taken as {kind}" in w
               for w in fr.warnings), fr.warnings


def test_a_given_kind_stands_against_weak_data():
    """Regression, a probe's ground (tests/data/derive/probe_holes_given_reverse_fault):
    F4 is given as reverse (the truth: 33 degrees, 12.9 m); the holes'
    sides, carried 430-530 m to its cutoffs, say +13 to +15 m (normal) in
    all three layers, 0.03 of the distance per layer, and overruled the
    given kind (the model 13 m off near it). Such data keep the given kind
    now, said in a warning; data near the fault still overrule a wrong one
    (test_given_kind_contradicted_is_a_warning)."""
    folder = Path(__file__).parent / "data" / "derive" / "probe_holes_given_reverse_fault"
    d = derive.derive_faults(faultmesh.load_dataset(folder / "dataset.json"))
    fr = d.derivation.faults["F4"]
    assert fr.kind == "reverse" and d.fault("F4").kind == "reverse", fr.warnings
    assert any("what it takes to overrule a given kind): taken as reverse (given)" in w
               for w in fr.warnings), fr.warnings
    assert not any("given as reverse but the data say normal" in w for w in fr.warnings)


def test_throw_hint_share_falls_to_zero_at_tips():
    share = derive._hint_share
    ends = (-500.0, 500.0)
    # No tip: the hint all along.
    assert share(-500.0, ends, (False, False)) == share(480.0, ends, (False, False)) == 1.0
    # Two tips: the whole hint in the middle, none at the tips, 1 - x^2 between.
    assert share(0.0, ends, (True, True)) == 1.0
    assert share(-500.0, ends, (True, True)) == share(500.0, ends, (True, True)) == 0.0
    assert share(250.0, ends, (True, True)) == pytest.approx(0.75)
    # One tip: the whole hint at the other end (the largest throw may lie
    # beyond the area), none at the tip.
    assert share(-500.0, ends, (False, True)) == 1.0 and share(500.0, ends, (False, True)) == 0.0
    assert share(0.0, ends, (False, True)) == pytest.approx(0.75)
    assert share(0.0, ends, (True, False)) == pytest.approx(0.75)
    assert share(-500.0, ends, (True, False)) == 0.0
    # Past the extent: nothing (never negative).
    assert share(700.0, ends, (True, True)) == 0.0
    # A degenerate extent: the hint.
    assert share(3.0, (3.0, 3.0), (True, True)) == 1.0


def test_fault_from_surface_or_trace_planes():
    """The same fault given as a triangulated surface or by the planes of
    traces without layers gives the same kind and nearby cutoffs."""
    ds = datasets.synthetic(0, kind="reverse", dip=50.0, n_boreholes=N_HOLES, n_layers=2)
    v2 = v2_of(ds)
    fs = derive.fault_surface(v2.faults[0], ds.boundary, (-1e4, 1e4))
    V, T = fs.own
    planes = [type(t)(t.section, t.plane) for t in ds.faults[0].traces]
    results = {}
    for src, f in (("points", v2.faults[0]), ("surface", Fault("F1", surface=(V, T))),
                   ("traces", Fault("F1", traces=planes))):
        dd = Dataset(name=src, layers=ds.layers, boundary=ds.boundary, boreholes=ds.boreholes,
                     sections=ds.sections, faults=[f], truth=ds.truth, geology=ds.geology)
        d = derive.derive_faults(dd)
        fr = d.derivation.faults["F1"]
        assert fr.kind == "reverse", (src, fr.warnings)
        assert fr.surface.source == ("sticks" if src == "points" else src)
        results[src] = fr
        lay = ds.layers[0]
        dist = true_cutoff_distance(ds.geology, "F1", lay, "hanging", fr.cutoffs[lay]["hanging"],
                                    fr.surface.dip_dir)
        # The trace planes span only the v1 sections' depth range and length:
        # a shorter fault, but its cutoffs lie as close to the true ones.
        assert np.nanmax(dist) < 8.0, (src, dist)
        faultmesh.build_model(d, evaluate=False).check()


def test_fault_reaching_the_boundary_is_extended_to_it():
    """Fault points that stop within `reach` of the study-area boundary:
    that end gets no tip and the builder extends the patches to the boundary."""
    ds = datasets.synthetic(3, kind="normal", dip=60.0, n_boreholes=200, n_layers=2)
    P, st_ = fault_points(ds.geology, "F1", ds)
    fs0 = derive.fault_surface(Fault("F1", points=P), ds.boundary, (-1e4, 1e4), reach=0.0)
    u = fs0.u(P[:, :2])
    # The end at larger u, pushed to 40 m from the boundary along strike.
    hi = u >= u.max() - 1.0
    t = derive._ray_to_ring(P[hi, :2], fs0.strike, np.asarray(ds.boundary))
    shift = float(np.median(t)) - 40.0
    P2 = P.copy()
    P2[hi, :2] += shift * fs0.strike
    assert points_in_polygon(P2[:, :2], ds.boundary)[hi].all()
    v2 = Dataset(name="reach", layers=ds.layers, boundary=ds.boundary, boreholes=ds.boreholes,
                 faults=[Fault("F1", points=P2, sticks=st_)], truth=ds.truth, geology=ds.geology)
    d = derive.derive_faults(v2, reach=100.0)
    fr = d.derivation.faults["F1"]
    assert fr.surface.ends == ["inside", "boundary"] and fr.ends[1] == "boundary"
    assert len(d.faults[0].tips) == 1
    model = faultmesh.build_model(d, evaluate=False)
    model.check()
    # The truth's throw tapers to zero at the end of its fault (the moved
    # stick lies beyond it), so the derived end section's throw is about
    # zero: the builder extends that end to the boundary, or, where the
    # derived throw there is exactly zero (a wrong-signed sliver of throw is
    # set to zero), closes the patch on that zero-throw section.
    for lay in ds.layers:
        ends = model.metadata["faults"]["F1"]["layers"][lay]["ends"]
        assert ends[0] == "tip" and ends[1] in ("extended", "zero_throw"), (lay, ends)
        prof = fr.throw[lay]
        last = prof["throw"][np.argmax(prof["u"])]
        assert abs(last) < 1.0, (lay, last)
        if ends[1] == "zero_throw":
            assert last == 0.0


def test_paper_like_from_fault_points_builds():
    """Regression (found deriving paper_like(0) from fault points): a far end
    clipped to a hair inside the study-area boundary made the builder's
    extension of F22 degenerate and the gap polygon touch itself; the T-
    crossing 2F1/4F2 needs each fault's data kept to its block (4F2 came out
    reverse and its patch crossed 2F1's). Later 4F2 (normal, displacing coal
    8 only) came out reverse again from the median over all sections and
    layers (-0.05 m: coal 10's spurious offsets at the T-junction against
    coal 8's throw); the kind is now the sign of the sum of each displaced
    layer's median. Every kind must come out right and the model must pass
    check()."""
    ds = datasets.paper_like(0)
    d = derive.derive_faults(v2_of(ds))
    for f in ds.faults:
        assert d.derivation.faults[f.name].kind == f.kind, f.name
    assert d.derivation.faults["F22"].ends[1] == "boundary"
    faultmesh.build_model(d, evaluate=False).check()


def test_sections_whose_cutoffs_cross_are_dropped():
    """Regression (found on Claudius with every pick within 300 m (2D) of the
    fault withheld: wildly extrapolated cutoffs on one section made the
    patch cross itself and the stitcher fail): such a section loses the
    layer, with a warning, and the patch is simple again (one simple outline;
    a normal fault's patch not folded)."""
    ds = datasets.synthetic(0, kind="normal", dip=60.0, n_boreholes=120, n_layers=2)
    d = derive.derive_faults(v2_of(ds))
    f = d.faults[0]
    lay = ds.layers[0]
    with_l = [tr for tr in f.traces if lay in tr.layers]
    bad = with_l[len(with_l) // 2]
    # Swing this section's hanging-wall polyline along strike past its
    # neighbour's: the patch outline now crosses itself.
    sec = d.sections[bad.section]
    along = np.array([sec.direction[1], -sec.direction[0]])
    hw = bad.layers[lay]["hanging"]
    t = np.linspace(0.0, 1.0, len(hw))[:, None]
    hw[:, :2] += t * 700.0 * along[None, :]
    assert not derive._patch_is_simple(f, lay, np.asarray(d.boundary))
    warn = []
    derive._drop_crossing_sections(f, np.asarray(d.boundary), warn)
    assert lay not in bad.layers
    assert derive._patch_is_simple(f, lay, np.asarray(d.boundary))
    assert len(warn) == 1 and "cross itself" in warn[0]


def test_reverse_fault_folding_along_the_boundary_keeps_its_sections():
    """Regression (random_ground(0) written as v2: a reverse fault that runs
    out of a rotated rectangle): its end traces carried onto the boundary
    fold along it, which the stitcher allows, but derive's own outline test
    called that "crossing itself" and dropped the layers from 5 of the 8
    sections (near-fault error 6.0x that of the model from the true
    cutoffs). Derive now uses the stitcher's outline test."""
    from faultmesh import grounds

    ds = grounds.random_ground(0)
    (ftrue,) = ds.faults
    assert ftrue.kind == "reverse"
    d = derive.derive_faults(v2_of(ds))
    fr = d.derivation.faults[ftrue.name]
    assert fr.kind == "reverse" and fr.ends == ["boundary", "boundary"]
    assert not any("cross itself" in w for w in fr.warnings), fr.warnings
    f = d.fault(ftrue.name)
    # Every layer on every regular section; the extra sections at the two
    # ends on the boundary (derive.END_SECTION_INSET, the first and last
    # along strike) go without a layer whose polylines the boundary cuts
    # short (here L1 at one end).
    assert all(set(tr.layers) == set(ds.layers) for tr in f.traces[1:-1])
    assert all(tr.layers for tr in f.traces)
    m1 = faultmesh.build_model(ds, evaluate=False)
    m2 = faultmesh.build_model(d, evaluate=False)
    m2.check()
    e1, e2 = near_fault_error([m1, m2], ds.geology, np.asarray(ds.boundary))
    # The sections dropped gave 6.0x. Since the stitcher puts the layer data
    # back into the gaps (issue 10) the model from the true cutoffs gained
    # (0.634 -> 0.445 m) and the derived one did not (0.668 m both): ratio
    # 1.05 -> 1.50; the end sections (derive.END_SECTION_INSET) brought it
    # to 0.97, the 1.25 target is the test below.
    assert e2 <= 2.0 * e1, (e1, e2)


def test_reverse_fault_folding_along_the_boundary_within_the_v2_ratio():
    """Regression (random_ground(0) as v2, see the test above): the derived
    model's near-fault error within V2_RATIO (1.25) of the true cutoffs'
    model. It was 1.50x (0.668 m against 0.445 m): the outermost derived
    sections lay half a spacing short of the boundary and the builder
    carried their patches unchanged onto it; with a section a tenth of a
    spacing inside each end on the boundary (derive.END_SECTION_INSET)
    0.97x (0.430 m)."""
    from faultmesh import grounds

    ds = grounds.random_ground(0)
    d = derive.derive_faults(v2_of(ds))
    m1 = faultmesh.build_model(ds, evaluate=False)
    m2 = faultmesh.build_model(d, evaluate=False)
    e1, e2 = near_fault_error([m1, m2], ds.geology, np.asarray(ds.boundary))
    assert e2 <= grounds.V2_RATIO * e1, (e1, e2)


def test_derived_polylines_stay_out_of_another_faults_room():
    """Regression (random_ground(6) as v2: two separate normal faults whose
    footwalls face each other, 22 boreholes): with data a kilometre apart the
    derived polylines reached a kilometre from their cutoffs, the two
    faults' patches overlapped and the build raised "faults too close".
    Each far end now stays in its fault's share of the room between them
    (derive._room_between_faults)."""
    from faultmesh import grounds

    ds = grounds.random_ground(6)
    assert len(ds.faults) == 2 and not any(f.group for f in ds.faults)
    d = derive.derive_faults(v2_of(ds))
    m = faultmesh.build_model(d, evaluate=False)
    m.check()
    assert set(m.metadata["derived_faults"]) == {f.name for f in ds.faults}


@pytest.mark.parametrize("case", ["collinear", "horizontal", "beyond_range"])
def test_degenerate_fault_points_are_named_errors(case):
    """Fault points that cannot define a dipping surface (on one line, in a
    horizontal plane) are a GeometryError naming the fault, before any
    triangulation (collinear points used to build a model with the fault
    silently ignored); points beyond the coordinate limit are a
    DatasetError naming the fault and the point."""
    ds = datasets.synthetic(0, kind="normal", dip=60.0, n_boreholes=60, n_layers=2)
    P = v2_of(ds).faults[0].points
    if case == "beyond_range":
        with pytest.raises(DatasetError, match=r"fault 'F1': point 1 has a coordinate beyond"):
            Fault("F1", points=P * 1e70)
        return
    if case == "collinear":
        t = np.linspace(0.0, 1.0, 20)[:, None]
        P = P[0] + t * (P[-1] - P[0])
        want = "lie on one line"
    else:
        P = np.column_stack([P[:, :2], np.full(len(P), -200.0)])
        want = "horizontal plane"
    v2 = Dataset(name="degenerate", layers=ds.layers, boundary=ds.boundary,
                 boreholes=ds.boreholes, sections={}, faults=[Fault("F1", points=P)])
    with pytest.raises(faultmesh.GeometryError, match=rf"fault 'F1'.*{want}"):
        derive.derive_faults(v2)


def test_sparse_crossing_ground_derives_and_builds():
    """Regression (random_ground(75) as v2: an X pair and a third fault, 30
    boreholes over 5.5 km): the joint fit of a gap section had no datum of a
    side in its frame (ZeroDivisionError); then the third fault's derived
    polylines, kilometres long with data that sparse, ran into the pair's
    zone ("faults too close"). A side without data in the frame now keeps
    its own surface, and every far end stays in its fault's share of the
    room (_room_between_faults)."""
    from faultmesh import grounds

    ds = grounds.random_ground(75)
    d = derive.derive_faults(v2_of(ds))
    assert set(d.derivation.faults) == {f.name for f in ds.faults}
    faultmesh.build_model(d, evaluate=False).check()


def test_kind_from_cutoff_throws_where_the_data_are_near():
    """Regression (random_ground(34) as v2, a normal fault at 73 degrees):
    every section's cutoff throw said normal, but where the hanging-wall
    data stopped just over two data spacings from the cutoff the regional
    step decided, and the kind came out reverse. The cutoff throws now
    decide wherever both sides have data within `near` (4 spacings)."""
    from faultmesh import grounds

    d = derive.derive_faults(grounds.random_ground(34, version=2))
    assert d.derivation.faults["F1"].kind == "normal"


def test_plane_traces_above_a_cutoff_still_take_room():
    """Regression (random_ground(2) with every fault given as its v1 traces'
    planes only: no layers, no tips, no kind): F3's planes reach down to
    -591 m, F1's deepest cutoffs lie at -685 m. The room rule measured from
    F3's trace at -685 m, where F3 has none, so F3 took no room and F1's
    footwall far ends (1.2 km long with 26 holes over 5.7 km) ran under
    F3's tip: "faults too close". The other fault's nearest trace (its
    extent's deepest) now stands in."""

    from faultmesh import grounds

    ds = grounds.random_ground(2)
    planes = [replace(f, traces=[replace(t, layers={}) for t in f.traces], kind=None,
                      tips=np.zeros((0, 2))) for f in ds.faults]
    d = derive.derive_faults(replace(ds, faults=planes))
    assert {n for n, r in d.derivation.faults.items() if r.kind} == {"F1", "F2", "F3"}
    faultmesh.build_model(d, evaluate=False).check()


def test_end_not_carried_through_another_fault():
    """Regression (random_ground(249) as v2: four faults, F2 reverse with
    tips, its end 300 m from a corner of the study area where its down-dip
    points pass the boundary): that end counted as reaching the boundary,
    and the builder carried F2's patches 700 m along strike through F3
    ("faults too close"). An end whose way along strike onto the boundary
    crosses a fault of another group now ends where its points do."""
    from faultmesh import grounds

    d = derive.derive_faults(grounds.random_ground(249, version=2))
    rep = d.derivation.faults["F2"]
    assert "tip" in rep.as_dict()["ends"]
    assert any("would cross fault 'F3'" in w for w in rep.warnings)
    faultmesh.build_model(d, evaluate=False).check()


def test_thin_layers_of_deviated_holes_are_repaired():
    """Regression (random_ground(364) as v2: a U-shaped area, 17 holes, half
    of them deviated, layers L4-L6 3-4 m apart, each layer with its own
    boundary spacing): the layer repair never ended ("'L6' still crosses 'L5'
    after 50 rounds"). L6's boundary vertices lay on L5's hull only up to
    rounding, L5's interpolation was NaN there, so rule 1 could not lower
    them and rule 2 halved the edges around them without end. A point on the
    study-area boundary now gets the elevation of the TIN's boundary piece
    it lies on (LayerTin::interpolate)."""
    from faultmesh import grounds

    ds = grounds.random_ground(364, version=2)
    m = faultmesh.build_model(ds, evaluate=False)
    m.check()
    assert m.metadata["repair"]["L6"]["rounds"] >= 1


def test_carried_end_keeps_its_share_of_the_room():
    """Regression (random_ground(411) as v2: four faults, F1+F2 a group;
    F2's south end, 320 m from the boundary, is carried along strike onto
    it and lands 80 m from F3's trace, which runs out there too): the end
    sections' polylines kept to their share of the room at the section
    only; carried onto the boundary, F2's footwall polyline ran onto F3's
    hanging-wall one in L1 ("faults too close"). The end section of an end
    carried to the boundary now keeps to its share all along the way.
    F2's south end is a true tip (its sticks stop 478 m short of the
    boundary, 4 stick spacings): since `reach` defaults to one stick
    spacing it stays one, so the carry is reproduced with the former
    default's reach (a fifth of F2's length, 580 m; 500 m here)."""
    from faultmesh import grounds

    ds = grounds.random_ground(411, version=2)
    assert derive.derive_faults(ds).derivation.faults["F2"].as_dict()["ends"][1] == "tip"
    d = derive.derive_faults(ds, reach=500.0)
    assert d.derivation.faults["F2"].as_dict()["ends"][1] == "boundary"
    faultmesh.build_model(d, evaluate=False).check()


def test_tops_repeated_across_another_fault_stay_in_their_block():
    """Regression (random_ground(489) as v2: three faults, F3 reverse; a
    deviated hole through F3 meets L5 on both of its sides, 0.9 m apart in
    map view and 9.7 m apart in z): F1's hanging-wall surface of L5 went
    through both tops, bent by hundreds of metres away from them, and F1's
    L5 cutoffs came out 260 m apart (the truth: F1 does not displace L5);
    its patch ran into F3's ("faults too close"). A datum across another
    fault with one on this fault's side of it within a grid cell is now
    left out of this fault's side surfaces (_in_own_block)."""
    from faultmesh import grounds

    d = derive.derive_faults(grounds.random_ground(489, version=2))
    throw = d.derivation.faults["F1"].as_dict()["throw"]["L5"]["throw"]
    assert np.nanmax(np.abs(np.array(throw, dtype=float))) < 30.0
    faultmesh.build_model(d, evaluate=False).check()


def test_carried_ends_of_a_pair_and_a_reverse_fault_keep_apart():
    """Regression (random_ground(697) as v2: F1+F2 a group, F4 reverse):
    the same class as random_ground(411). F4's end section, carried 290 m
    along strike onto the boundary, took its 500 m hanging-wall polyline
    of L1 along into F2's patch, whose end is carried onto the boundary
    there too ("faults too close"); now builds and passes check()."""
    from faultmesh import grounds

    d = derive.derive_faults(grounds.random_ground(697, version=2))
    assert d.derivation.faults["F4"].as_dict()["ends"][0] == "boundary"
    faultmesh.build_model(d, evaluate=False).check()


def test_layer_data_in_a_normal_faults_gap_belong_to_neither_side():
    """Regression (random_ground(16) as v2: a normal fault, five L1 points in
    its gap, where the layer's top is the fault surface itself): they went
    into the footwall's data and dragged it down onto the hanging wall's
    cutoff; the footwall cutoffs came out 9-39 m from the true ones on four
    of eight sections (error near the fault 1.96 x the true cutoffs'
    model). Data on the fault with the footwall above them are now left
    out of both sides (_data_sides): cutoffs within 5 m (0.97 x). A datum
    on a reverse fault (random_ground(0): at F1's hanging-wall cutoff,
    0.015 m above the fault) stays."""
    from faultmesh import grounds

    ds = grounds.random_ground(16, version=2)
    geo = ds.geology
    d = derive.derive_faults(ds)
    fr = d.derivation.faults["F1"]
    D = derive.layer_data(ds, "L1")
    on = derive._on_fault(fr.surface, D)
    # Exactly the data the truth puts on the fault (to the 1 cm rounding).
    truth_on = np.abs(D[:, 2] - geo.plane_z("F1", D[:, 0], D[:, 1])) < 0.01
    assert on.sum() == 5 and np.array_equal(on, truth_on)
    for side in ("foot", "hanging"):
        dist = true_cutoff_distance(geo, "F1", "L1", side, fr.cutoffs["L1"][side],
                                    fr.surface.dip_dir)
        assert np.all(np.isfinite(dist)) and dist.max() < 10.0, (side, dist)

    ds = grounds.random_ground(0, version=2)
    fs = derive.fault_surface(ds.faults[0], np.asarray(ds.boundary), (-1e4, 1e4))
    D = derive.layer_data(ds, "L1")
    sp = derive._median_spacing(D)
    frame = derive._side_frame(fs, np.asarray(ds.boundary), 3.0 * sp, sp / 2.0)
    assert derive._on_fault(fs, D).sum() == 1
    gap, ext = derive._data_sides(fs, D, frame, 12)
    # It stays, in the hanging wall (whose surface passes nearer to it).
    assert not gap.any() and ext[derive._on_fault(fs, D)].tolist() == [1]


def test_a_side_surface_on_cells_coarser_than_its_picks_does_not_lever_past_them():
    """Regression (random ground 399 as v2 with section picks): a layer's
    frame has cells of half the layer's data spacing (105 m there: lines of
    picks 120-350 m apart), and a fault block's side with four such lines,
    a pick every 8 m, got its smoothing length from its own spacing (30 m):
    1.5 m, a seventieth of a cell. With next to no roughness the nodes
    beside the picks levered off: F2's L2 footwall 26 m below picks 50 m
    away, its cutoffs 15-38 m off. Here: a curved layer picked on four
    lines across coarse cells, in 40 random turns; the surface 40 m past
    the first line, beside its picks, within 5 m of the layer (before: 13 m
    off at worst)."""
    rng = np.random.default_rng(0)

    def layer(x, y):
        return -60.0 - 1e-4 * (x - 200.0) ** 2 + 0.02 * y + 5.0 * np.sin(x / 150.0)

    frame = derive.GridFrame.around(np.zeros(2), (1.0, 0.0), (-600.0, 400.0), (-600.0, 400.0), 105.0)
    errors = []
    for _ in range(40):
        a = rng.uniform(0.0, np.pi)
        d = np.array([np.cos(a), np.sin(a)])
        n = np.array([-d[1], d[0]])
        P = np.array([-k * rng.uniform(100.0, 130.0) * n + t * d
                      for k in range(4) for t in np.arange(0.0, 60.0, 8.0) + rng.uniform(-20.0, 0.0)])
        side = derive.SideSurface(np.column_stack([P, layer(P[:, 0], P[:, 1])]), 12, frame)
        q = (40.0 * n + 30.0 * d)[None, :]
        errors.append(abs(float(side(q)[0]) - float(layer(q[:, 0], q[:, 1])[0])))
    assert max(errors) <= 5.0, np.round(sorted(errors)[-5:], 1)


def test_the_footwall_of_a_fault_abutting_another_keeps_to_its_picks():
    """Regression (random ground 399 as v2 with section picks: F2, normal,
    abuts F1, reverse, from F1's hanging wall; see the test above): F2's L2
    cutoffs on its four sections next to F1 came out 15-38 m off (the throw
    set to zero, of the wrong sense), L4's hanging-wall ones 82-84 m;
    1.76x the true cutoffs' error near the faults. With the smoothing
    length at least a tenth of the frame's cell: every L2 cutoff within
    8 m, 0.94x."""
    from faultmesh import grounds

    out = grounds.evaluate_ground_v2(399)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["kind_ok"], out["kinds"]
    far = {side: max(out["cutoffs"]["F2"]["L2"][side]) for side in ("foot", "hanging")}
    assert max(far.values()) <= 8.0, far
    assert out["ratio"] <= grounds.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_a_throw_fading_between_the_coarse_profiles_is_fitted():
    """Regression (unseen random ground 378 as v2 with section picks: F1,
    reverse, crosses the area; its throw stays whole for about 90 m into
    the hanging wall and fades over the next 100 m: hanging-wall data show
    96 % of it 112 m from the fault, 22-37 % at 155 m, none at 268 m). On
    the fading-throw fit's former grid of profiles (flat 0, 50, 150 m, fade
    100, 200, 350, 600 m) none fitted: the least objective's (50, 350) took
    the data at 155 m for 79 % of the throw and bent the layer 16 m below
    the footwall at the fault; L3's hanging-wall cutoffs on the sections
    between the data 16-32 m off, 3.09x the true cutoffs' error near the
    faults. With flat every 25 m and fades 1.35x apart it takes (100, 100):
    those sections within 10 m, 1.70x (the rest of the excess on sections
    whose data lie 300 m off)."""
    from faultmesh import grounds

    built = {}
    out = grounds.evaluate_ground_v2(378, built=built)
    assert out["stage"] in ("ok", "ratio"), (out["stage"], out["error"])
    assert out["kind_ok"], out["kinds"]
    fr = built["derived"].derivation.faults["F1"]
    u = fr.surface.u(np.asarray(fr.cutoffs["L3"]["hanging"])[:, :2])
    off = np.asarray(out["cutoffs"]["F1"]["L3"]["hanging"])
    assert len(u) == len(off)
    assert np.max(off[u < 100.0]) <= 10.0, list(zip(u.round(), off.round(1)))
    assert np.max(off) <= 20.0, off
    assert out["ratio"] <= 2.0, (out["error_v1"], out["error_v2"])


def test_a_fault_that_cuts_only_the_sparse_layer_is_a_barrier_to_its_offset():
    """Regression (unseen random ground 264 as v2 with section picks: L1
    picked on sections, L2-L6 from 60 holes; F1 cuts every layer, F2,
    reverse at 35 degrees, only the bottom layer L6). L6's offset from L1
    steps by F2's whole throw (16 m measured) across F2: over
    derive.CONFORMABLE_STEP_MAX, so L6 took no shape from L1 and its
    surfaces came from its own 53 holes: F1's L6 hanging-wall cutoffs 5-10
    m off on 5 of 11 sections, 1.27x the true cutoffs' error near the
    faults. With F2 (and F1, whose step the fading throw confounds) a
    barrier to the offset, L6 takes L1's shape per block: every one within
    5 m, 0.86x."""
    from faultmesh import grounds

    built = {}
    out = grounds.evaluate_ground_v2(264, built=built)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["kind_ok"], out["kinds"]
    layers = built["derived"].derivation.layers
    assert "F2" in layers["L6"].get("barriers", []), layers["L6"]
    off = np.asarray(out["cutoffs"]["F1"]["L6"]["hanging"])
    assert len(off) >= 8 and off.max() <= 5.0, off.round(1)
    assert out["ratio"] <= grounds.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_a_bridged_throw_is_held_past_the_hanging_walls_data():
    """Regression (random ground 340 as v2 with section picks: F1, normal,
    crosses F2 near its end on the boundary; in the block beyond F2 neither
    side of F1 has data within two data spacings of its last sections, so
    both come from one surface through both sides' data with a throw T(u)
    along strike, derive._joint_sides): T continued its trend past the
    last hanging-wall datum of the block (346 and 492 m on the last
    sections, bridged from 57 m by the sections along strike, yet L4's
    throw on the last two cut sections 105 and 192 m, the truth's 29-32 m),
    cutoffs 83-353 m off, 1.38x the true cutoffs' error near the faults.
    Held at its value at the outermost hanging-wall datum (as the
    fading-throw fit's): every cut L4 throw under twice the truth's
    largest (43 m), 1.13x."""
    from faultmesh import grounds

    built = {}
    out = grounds.evaluate_ground_v2(340, built=built)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["kind_ok"], out["kinds"]
    t = built["derived"].derivation.faults["F1"].throw["L4"]
    assert np.max(np.abs(t["throw"][t["cut"]])) < 2 * 42.6, t
    assert out["ratio"] <= grounds.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_a_block_short_of_one_sides_data_keeps_its_own_other_side():
    """Regression (held-out random ground 130 as v2 with section picks: F2,
    reverse, abuts F1, normal; F1's sections next to the junction lie in
    the block on F2's far side, which has 9-11 footwall data of L2 and L3
    and 2 hanging-wall ones): with too few data for both sides the block
    had no side surfaces, and those sections kept the whole layer's, whose
    footwall mixes both blocks across F2. L3's footwall cutoff at u = -763
    m lay at z = 221 m where the layer is at 1 m, L2's on the last three
    sections 35-76 m off. The block's own footwall now stays; only its
    hanging wall comes from the whole layer: within 5 m, the ground's error
    near the faults 1.16 -> 0.72x the true cutoffs'."""
    from faultmesh import grounds

    built = {}
    out = grounds.evaluate_ground_v2(130, built=built)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    fr, geo = built["derived"].derivation.faults["F1"], built["geo"]
    for lay in ("L2", "L3"):
        C = np.asarray(fr.cutoffs[lay]["foot"])
        near = C[fr.surface.u(C[:, :2]) < -700.0]
        off = near[:, 2] - geo.side_value(lay, "F1", "foot", near[:, 0], near[:, 1])
        far = off if lay == "L2" else off[np.argmin(np.abs(fr.surface.u(near[:, :2]) + 763.0))][None]
        assert len(near) and np.max(np.abs(far)) < 6.0, (lay, off)
    assert out["ratio"] <= grounds.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_fading_throw_fit_also_where_the_hanging_walls_data_come_near():
    """Regression (random_ground(46) as v2: a reverse fault at 47 degrees
    across the area, 100 holes about 430 m apart, the throw whole 98 m into
    the hanging wall and fading over the next 181 m): on the sections whose
    hanging-wall data come within a data spacing of the cutoff the hanging
    wall's own surface extrapolated the fading bend (hanging-wall polylines
    7 m too deep 75-150 m from the cutoff), error near the fault 1.52x the
    true cutoffs' model. The fading-throw fit now takes every section where
    a datum that shows the throw is near along strike (derive.DECAY_GAP 0):
    1.19x."""
    from faultmesh import grounds

    out = grounds.evaluate_ground_v2(46, section_picks=False)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["kind_ok"], out["kinds"]
    assert out["ratio"] <= grounds.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_sticks_that_stop_short_of_the_boundary_end_in_a_tip():
    """Regression (random_ground(82) as v2: a reverse fault whose throw dies
    out 250 m short of the study-area boundary; its fault sticks, 0.2 of the
    fault's length from the boundary there, stop at the tip): the old
    default `reach` (a fifth of the fault's length) carried that end onto
    the boundary with the end section's 17-49 m of throw, up to 17 m off
    there, error near the fault 1.60x the true cutoffs' model. With sticks,
    an end is carried only when the boundary lies within one stick spacing
    of its last stick (derive._strike_spacing): a tip, 1.20x."""
    from faultmesh import grounds

    out = grounds.evaluate_ground_v2(82, section_picks=False)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["kind_ok"], out["kinds"]
    assert out["ratio"] <= grounds.V2_RATIO, (out["error_v1"], out["error_v2"])
    # The same sticks with the tip end moved to half a stick spacing from
    # the boundary reach it.
    ds = grounds.random_ground(82, version=2)
    f = ds.faults[0]
    fs0 = derive.fault_surface(f, ds.boundary, (-1e4, 1e4))
    assert fs0.ends[0] == "inside", fs0.ends  # the tip end
    P = np.asarray(f.points, dtype=np.float64)
    u = fs0.u(P[:, :2])
    spc = derive._strike_spacing(P, fs0.strike)
    assert 60.0 <= spc <= 140.0, spc  # the generator's stick spacing
    lo = u <= u.min() + 1e-6 * max(1.0, float(np.ptp(u)))
    t = derive._ray_to_ring(P[lo, :2], -fs0.strike, np.asarray(ds.boundary))
    P2 = P.copy()
    P2[:, :2] -= (float(np.median(t)) - 0.5 * spc) * fs0.strike  # the whole fault moved along strike
    fs2 = derive.fault_surface(Fault(f.name, points=P2, sticks=f.sticks), ds.boundary, (-1e4, 1e4))
    assert fs2.ends[0] == "boundary", fs2.ends


def test_tip_where_the_throw_dies_out():
    """A tip goes where the throw profile, continued straight from the
    last section that shows the throw through the first that does not,
    reaches zero, within the fault's extent (derive._tip_along_strike).
    Until this rule it went where the profile falls to min_throw (3 m):
    random_ground(64) as v2, a normal fault of 5.6 m tapering to zero at
    both ends of its sticks, got tips 367 and 271 m short of the true ones
    (on seeds 0-99, 11 tips 55-1121 m short); now 17 and 24 m (the tip
    lies at the extent's edge here, whose first sampled position along
    strike is 1/128 of the fault's length, 17 m, inside it)."""
    tip = derive._tip_along_strike
    # 1 m at u = 0, 4 m at u = 100: zero at u = -33.3 (the old rule: 66.7).
    assert tip(0.0, 1.0, 100.0, 4.0, -500.0) == pytest.approx(-100.0 / 3.0)
    # Not past the extent's edge; a section without throw is the tip.
    assert tip(0.0, 2.5, 100.0, 3.0, -200.0) == -200.0
    assert tip(0.0, 0.0, 100.0, 4.0, -500.0) == 0.0
    # Mirrored (the other end of the fault).
    assert tip(0.0, 1.0, -100.0, 4.0, 500.0) == pytest.approx(100.0 / 3.0)

    from faultmesh import grounds

    truth = np.asarray(grounds.random_ground(64).faults[0].tips, dtype=np.float64)
    d = derive.derive_faults(grounds.random_ground(64, version=2))
    tips = np.asarray(d.faults[0].tips, dtype=np.float64)
    assert d.derivation.faults["F1"].ends == ["tip", "tip"]
    assert len(truth) == len(tips) == 2
    gap = np.hypot(*(tips[:, None, :] - truth[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    # 50 m: the 17 m of the sampling along strike plus the tip's place on
    # the cutoff line (a third of what the old rule's error was at least).
    assert gap.max() < 50.0, gap


@pytest.mark.parametrize("throw", [25.0, -25.0])
def test_fading_throw_taken_at_the_hanging_walls_own_elevation(throw):
    """Regression: the fading-throw fit (derive._decay_sides) takes each
    hanging-wall datum's share g of the throw T at the datum's own
    elevation (its distance d from a dipping fault depends on it), so its
    hanging wall is z = S - T g(d(xy, z)). SideSurface took g at S - T, the
    elevation of the whole throw: below a normal fault's hanging wall, where
    the fault is nearer (g too large), above a reverse fault's, where it is
    farther (g too small); both came out too low where the throw fades
    (here, a flat S, T = +-25 m whole up to 50 m and fading over 200 m, a
    fault dipping 40 degrees: up to 4.2 m (normal) and 3.4 m (reverse) too
    low). On the v2 random grounds, seeds 0-99, the hanging-wall polylines
    moved towards the truth, e.g. random_ground(25) mean |dz| 0.5 -> 0.3 m,
    ratio 1.49 -> 1.29; (52) 2.3 -> 1.4 m, 1.57 -> 1.43."""
    tan_dip = np.tan(np.radians(40.0))
    prof = (50.0, 200.0)

    def dist(q, z):
        # Horizontal distance from the fault x = -z / tan(dip) (dipping
        # towards +x, the hanging wall) at elevation z.
        return q[:, 0] + z / tan_dip

    def share(q, z):
        return derive._decay_share(dist(q, z), prof)

    frame = derive.GridFrame.around((0.0, 0.0), (0.0, 1.0), (-500.0, 500.0), (-900.0, 100.0), 20.0)
    data = np.array([[600.0, 0.0, 0.0], [700.0, 50.0, 0.0], [650.0, -50.0, 0.0]])
    hs = derive.SideSurface(data, 3, frame, nodes=np.zeros(frame.n),
                            throw=(np.array([-1e4, 1e4]), np.array([throw, throw])), decay=(dist, prof))
    x = np.linspace(-100.0 if throw < 0 else 0.0, 450.0, 111)
    q = np.column_stack([x, np.zeros_like(x)])
    assert frame.inside(q).all()
    z = hs(q)
    # The hanging wall's own elevation: z = S - T g(d(xy, z)), S = 0.
    assert np.abs(z + throw * share(q, z)).max() < 1e-6
    # Where the throw fades, the share at the whole throw's elevation is off.
    old = -throw * share(q, np.full_like(x, -throw))
    assert (z - old).max() > 2.5


def test_halfway_sections_kept_where_the_straight_loft_misses_the_cutoffs():
    """derive._halfway_sections_to_keep on a fault striking along x (traces
    at x = 0, 50, 100, 150, 200; the ones at 50 and 150 halfway): a halfway
    section is kept where a cutoff lies farther than REFINE_SHARE of the
    layer's largest throw from the straight line between its neighbours'
    (x = 50: the throw bulges there), or where the cut layers change (x =
    150: L2 is cut only there); the one on the straight line (x = 50 with
    no bulge) is dropped, and so is one without a trace (past a tip)."""
    from faultmesh.dataset import Fault, Trace
    from faultmesh.derive import REFINE_SHARE, _halfway_sections_to_keep

    class Strike:  # the fault surface's strike coordinate: x
        @staticmethod
        def u(xy):
            return np.asarray(xy, dtype=float)[:, 0]

    def trace(x, throw, layers=("L1",)):
        lays = {lay: {"foot": [[x, -50.0, -100.0], [x, 0.0, -100.0]],
                      "hanging": [[x, 5.0, -100.0 - throw], [x, 50.0, -100.0 - throw]]}
                for lay in layers}
        return Trace(None, [[x, 0.0, 0.0], [x, 10.0, -300.0]], lays)

    def fault(bulge, l2_at_150=True):
        return Fault("F", "normal", None, np.zeros((0, 2)),
                     [trace(0.0, 10.0), trace(50.0, 20.0 + bulge), trace(100.0, 30.0),
                      trace(150.0, 30.0, ("L1", "L2") if l2_at_150 else ("L1",)), trace(200.0, 30.0)])

    halfway = np.array([50.0, 150.0, 250.0])  # 250: no trace there
    big = {"L1": 40.0}
    keep = _halfway_sections_to_keep(fault(0.0, False), Strike, halfway, 100.0, big)
    assert keep.tolist() == []
    dz = 1.5 * REFINE_SHARE * big["L1"]
    keep = _halfway_sections_to_keep(fault(dz), Strike, halfway, 100.0, big)
    assert keep.tolist() == [50.0, 150.0]
    keep = _halfway_sections_to_keep(fault(0.5 * REFINE_SHARE * big["L1"], False), Strike, halfway,
                                     100.0, big)
    assert keep.tolist() == []


def test_dip_continuation_window_past_the_extent_only():
    """derive._dip_continuation: on a trace whose segments 3-5 (of 10, 10 m
    each, straight down) lie in the extent, a cutoff on the skirt counts as
    on the fault within a quarter of the extent part's 30 m (7.5 m) above
    or below it, not in a gap between parts of the extent and not on a
    trace without any."""
    z = -10.0 * np.arange(11)
    pts = np.column_stack([np.zeros(11), np.zeros(11), z])
    real = np.zeros(10, dtype=bool)
    real[3:6] = True
    tr = derive._SectionTrace(np.zeros(2), np.array([1.0, 0.0]), 0.0, pts, np.zeros(11), real,
                              (-1.0, 1.0))
    c = derive._dip_continuation(tr)
    assert np.allclose(c[:, 0], 10.0 * np.arange(11))
    assert np.allclose(c[0, 1:3], [30.0 - 7.5, 60.0 + 7.5])
    assert c[:3, 3].tolist() == [1.0] * 3 and c[3:6, 3].tolist() == [0.0] * 3
    assert c[6:10, 3].tolist() == [1.0] * 4 and c[10, 3] == 0.0
    gap = real.copy()
    gap[4] = False   # a hole in the extent is no continuation
    assert derive._dip_continuation(derive._SectionTrace(tr.origin, tr.direction, 0.0, pts, tr.s, gap,
                                                         tr.interval))[4, 3] == 0.0
    none = derive._dip_continuation(derive._SectionTrace(tr.origin, tr.direction, 0.0, pts, tr.s,
                                                         np.zeros(10, dtype=bool), tr.interval))
    assert not none[:, 3].any() and np.isinf(none[:, 1]).all()
    # _roots: a layer plane crossing the trace 5 m below the extent (arc 65)
    # is on the fault, 11 m below (arc 71: outside the window) is not.
    for zl, on in ((-65.0, True), (-71.0, False), (-45.0, True)):
        r = derive._roots([tr], lambda xy, zl=zl: np.full(len(xy), zl), lambda xy: np.zeros(len(xy)))[0]
        assert r is not None and abs(r[0][2] - zl) < 1e-6 and r[1] is on, (zl, r)


def test_partner_window_admits_the_other_cutoff_of_one_in_the_extent_only():
    """derive._roots / _section_cutoffs(partner=True): with the extent at
    arc 30-60 m of a straight trace, DIP_PARTNER (half the extent part's
    length, 15 m) lets a cutoff at arc 72 m (12 m past the extent, outside
    the DIP_CONTINUATION window of 7.5 m) pair with one in the extent; two
    cutoffs both on the skirt never do, nor one past the wider window."""
    assert derive.DIP_PARTNER == 2.0 * derive.DIP_CONTINUATION
    z = -10.0 * np.arange(11)
    pts = np.column_stack([np.linspace(0.0, 1e-9, 11), np.zeros(11), z])
    real = np.zeros(10, dtype=bool)
    real[3:6] = True
    tr = derive._SectionTrace(np.zeros(2), np.array([1.0, 0.0]), 0.0, pts, np.zeros(11), real,
                              (-1.0, 1.0))
    c = derive._dip_continuation(tr)
    assert np.allclose(c[0, 4:6], [30.0 - 15.0, 60.0 + 15.0])

    def root(zl):
        return derive._roots([tr], lambda xy: np.full(len(xy), zl), lambda xy: np.zeros(len(xy)))[0]

    in_extent, past, far, skirt = root(-45.0), root(-72.0), root(-78.0), root(-66.0)
    assert in_extent[2] and in_extent[3]
    assert not past[1] and past[3] and not past[2]
    assert not far[3]
    assert skirt[1] and not skirt[2]
    assert not derive._section_cutoffs(tr, in_extent, past)[1]
    assert derive._section_cutoffs(tr, in_extent, past, partner=True)[1]
    assert not derive._section_cutoffs(tr, in_extent, far, partner=True)[1]
    # both on the skirt: on the fault by the narrow window, with or without partner
    assert derive._section_cutoffs(tr, skirt, skirt, partner=True)[1]
    assert not derive._section_cutoffs(tr, past, past, partner=True)[1]



@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), at_vertex=st.booleans())
def test_contour_of_a_level_is_every_triangle_it_cuts(seed, at_vertex):
    """derive._contour_xy takes the triangles a level cuts from the fault's
    triangles ordered by lowest z (FaultSurface.own_levels): the same
    segments, in the same order, as a pass over every triangle, also at a
    level through vertices (a vertex at the level counts as above it)."""
    rng = np.random.default_rng(seed)
    # A curved, rough fault from points in sticks, at UTM-sized coordinates.
    o = np.array([512345.0, 7212345.0])
    ys, zs = np.meshgrid(np.arange(0.0, 1201.0, 100.0), np.arange(-100.0, -601.0, -50.0))
    x = 400.0 + (-zs) / np.tan(np.deg2rad(55.0)) + 1e-4 * (ys - 600.0) ** 2 + rng.normal(0.0, 3.0, ys.shape)
    P = np.column_stack([o[0] + x.ravel(), o[1] + ys.ravel(), zs.ravel() + rng.normal(0.0, 1.0, ys.size)])
    ring = o + np.array([[0.0, -100.0], [1500.0, -100.0], [1500.0, 1300.0], [0.0, 1300.0]])
    fs = derive.fault_surface(Fault("F", points=P, sticks=np.searchsorted(np.unique(ys), ys.ravel())),
                              ring, (-700.0, 0.0))
    V, T = fs.own
    levels = (V[rng.integers(0, len(V), 20), 2] if at_vertex
              else rng.uniform(V[:, 2].min() - 10.0, V[:, 2].max() + 10.0, 20))
    for z in levels:
        above = V[:, 2] >= z
        A = above[T]
        Tc = T[A.any(axis=1) & ~A.all(axis=1)]
        want = []
        for tri in Tc:
            seg = []
            for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
                if above[a] != above[b]:
                    t = (z - V[a, 2]) / (V[b, 2] - V[a, 2])
                    seg.append(V[a, :2] + t * (V[b, :2] - V[a, :2]))
            want.append(seg)
        got = derive._contour_xy(fs, float(z))
        assert np.array_equal(got, np.array(want).reshape(-1, 2, 2))
        assert len(got) == len(Tc)


def _curved_sticks(rng, sigma: float, dip: float = 50.0, spacing: float = 100.0, step: float = 20.0,
                   origin=(512_345.6, 7_012_345.6), bend: float = 50.0):
    """Fault sticks on a fault curved along strike (a bend of ``bend`` m
    over its 2 km, striking 30 degrees), each point moved across strike by
    N(0, sigma) m, at UTM-sized coordinates; returns (points, stick labels,
    strike vector)."""
    u = np.arange(-1000.0, 1000.0 + 1e-9, spacing)
    z = np.arange(-50.0, -600.0, -step)
    U, Z = (a.ravel() for a in np.meshgrid(u, z, indexing="ij"))
    w = -Z / np.tan(np.radians(dip)) + bend * (U / 1000.0) ** 2 + rng.normal(0.0, sigma, len(U))
    a = np.radians(30.0)
    s, n = np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])
    xy = np.asarray(origin) + U[:, None] * s + w[:, None] * n
    return np.column_stack([xy, Z]), np.repeat(np.arange(len(u)), len(z)), s


@pytest.mark.parametrize("sigma", [0.0, 1.0, 3.0, 10.0])
def test_point_scatter_estimates_the_picking_error(sigma):
    """derive._point_scatter: the scatter of fault picks about the fault
    they sample (what FaultSurface.band widens the on-fault test by). A
    horizontal error sigma across strike is sigma sin(dip) off the
    surface; the estimate is within 20 % of it on 2,000 picks, and exact
    picks of a fault curved along strike give millimetres (not the 1 m by
    which they leave the plane of 30 neighbours)."""
    rng = np.random.default_rng(7)
    P, _, _ = _curved_sticks(rng, sigma)
    est = derive._point_scatter(P)
    want = sigma * np.sin(np.radians(50.0))
    if sigma == 0.0:
        assert est < 0.01, est
    else:
        assert abs(est - want) <= 0.2 * want, (est, want)
    # Unlabelled and shuffled: the same points, the same estimate.
    assert derive._point_scatter(P[rng.permutation(len(P))]) == pytest.approx(est, rel=1e-9)
    # A short fault of 55 picks (fewer than SCATTER_NEIGHBOURS + 2: with a
    # fixed 64 neighbours it had no estimate, and random ground 27 with a
    # 3 m error went back to 1.42x): all but two as neighbours.
    few, _, _ = _curved_sticks(np.random.default_rng(8), sigma, spacing=500.0, step=50.0)
    assert len(few) == 55
    est_few = derive._point_scatter(few)
    if sigma == 0.0:
        assert est_few < 0.01, est_few
    else:
        assert abs(est_few - want) <= 0.35 * want, (est_few, want)


def _arc_fault(chord: float, sagitta: float, depth: float, dip: float = 90.0, turn: float = 0.0,
               origin=(512_345.6, 4_123_456.7)):
    """Sticks on a fault whose trace is a circular arc (``chord`` m long,
    bowing by ``sagitta`` m), 11 sticks of 7 picks over ``depth`` m, dipping
    ``dip`` degrees towards the arc's centre (a cone), the whole turned by
    ``turn`` degrees, at UTM-sized coordinates. Returns (points, stick
    labels, radius at elevation z, the arc's centre (2,), its half angle,
    the unit vector across its chord)."""
    R = (chord ** 2 / 4 + sagitta ** 2) / (2 * sagitta)
    half = float(np.arcsin(chord / 2 / R))
    a = np.radians(turn)
    across = np.array([np.sin(a), np.cos(a)])
    centre = np.asarray(origin) + np.array([1500.0, 1000.0]) - (R - sagitta) * across

    def radius(z):
        return R + (np.asarray(z) + depth / 2) / np.tan(np.radians(dip))

    th, z = (v.ravel() for v in np.meshgrid(np.linspace(-half, half, 11), np.linspace(-depth, 0.0, 7)))
    r = radius(z)
    P = np.column_stack([centre[0] + r * np.sin(th + a), centre[1] + r * np.cos(th + a), z])
    return P, np.tile(np.arange(11), 7), radius, centre, half, across


@pytest.mark.parametrize("chord,sagitta,depth,dip,turn", [
    (500.0, 200.0, 150.0, 90.0, 0.0), (800.0, 300.0, 100.0, 90.0, 10.0),
    (800.0, 390.0, 100.0, 80.0, 0.0), (1200.0, 500.0, 150.0, 75.0, -10.0)])
def test_a_fault_bent_along_strike_is_projected_across_its_chord(chord, sagitta, depth, dip, turn):
    """derive._mean_orientation: a fault whose trace bends by 120-154
    degrees along strike is triangulated in the projection across its
    chord, where it is a function. Regression: a vertical fault bending by
    200 m over 500 m of strike, picked over 150 m of depth, spans less in z
    than across its bend; the normal of its least-squares plane was
    vertical and the fault was refused as "horizontal plane" (the fuzz of
    the nineteenth stop: near-vertical bent faults refused or projected
    along z); the sign-free sum of the local normals alone led along the
    chord of a 154-degree bend, where the surface folds. The TIN covers the
    arc surface (area within 2 %; every triangle within the sagitta of a
    chord between sticks of the arc) and splits data inside the arc from
    data outside it."""
    P, st_, radius, centre, half, across = _arc_fault(chord, sagitta, depth, dip, turn)
    ring = np.array([[0.0, 0.0], [3000.0, 0.0], [3000.0, 2000.0], [0.0, 2000.0]]) + P[:, :2].min(axis=0) - 1000.0
    warns = []
    fs = derive.fault_surface(Fault("F", points=P, sticks=st_), ring, (-depth - 50.0, 50.0), warnings=warns)
    assert not any("turns past square" in w for w in warns)
    # Unlabelled and shuffled: the same orientation.
    fs2 = derive.fault_surface(Fault("F", points=P[::-1]), ring, (-depth - 50.0, 50.0))
    assert fs2.axis == fs.axis and np.allclose(fs2.normal, fs.normal, atol=1e-9)
    h = fs.normal[:2] / np.hypot(*fs.normal[:2])
    assert abs(h @ across) > 0.999 and fs.axis == int(np.argmax(np.abs(across)))
    V, T = fs.own
    area = 0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]), axis=1).sum()
    slant = depth / np.sin(np.radians(dip))
    assert area == pytest.approx(2 * half * float(radius(-depth / 2)) * slant, rel=0.02)
    C = V[T].mean(axis=1)
    off = np.abs(np.hypot(*(C[:, :2] - centre).T) - radius(C[:, 2]))
    step = 2 * half / 10 * float(radius(-depth))
    assert off.max() < step ** 2 / (8 * float(radius(0.0))) + 1.0, off.max()
    # Data 30 m inside and outside the arc, at mid-depth: opposite sides.
    th = np.linspace(-0.8 * half, 0.8 * half, 9)
    a = np.radians(turn)
    r0 = float(radius(-depth / 2))
    q = [np.column_stack([centre[0] + (r0 + d) * np.sin(th + a), centre[1] + (r0 + d) * np.cos(th + a),
                          np.full(len(th), -depth / 2)]) for d in (-30.0, 30.0)]
    inner, outer = (fs.side(x)[1] for x in q)    # with the skirt beyond the extent
    assert len(set(inner)) == 1 and len(set(outer)) == 1 and inner[0] == -outer[0] != 0


@pytest.mark.parametrize("chord,sagitta,depth,dip,turn", [
    (500.0, 200.0, 150.0, 90.0, 40.0), (800.0, 390.0, 100.0, 80.0, -20.0)])
def test_a_fault_bent_past_square_to_every_axis_is_a_warning(chord, sagitta, depth, dip, turn):
    """A fault bent by 150 degrees and turned 20-40 degrees off the axes
    has no coordinate axis along which it is a function: its TIN, in the
    projection along the nearest one, joins picks across the fold (1.3-1.6
    times the arc's area). The exact predicates need an axis projection, so
    the fault is still triangulated, and the report says where and why
    (before: nothing)."""
    P, st_, *_ = _arc_fault(chord, sagitta, depth, dip, turn)
    ring = np.array([[0.0, 0.0], [3000.0, 0.0], [3000.0, 2000.0], [0.0, 2000.0]]) + P[:, :2].min(axis=0) - 1000.0
    warns = []
    fs = derive.fault_surface(Fault("F", points=P, sticks=st_), ring, (-depth - 50.0, 50.0), warnings=warns)
    assert any(w.startswith(f"fault 'F' turns past square to the {'xyz'[fs.axis]} axis in") for w in warns), warns


@pytest.mark.parametrize("sigma", [0.0, 3.0, 10.0])
def test_mean_orientation_of_picks_of_a_plane_is_its_normal(sigma):
    """derive._mean_orientation on sticks of a plane dipping 50 degrees
    (striking 30 degrees, UTM-sized coordinates) picked with an error of
    0, 3 or 10 m across strike: within 0.5 degrees of the plane's normal
    (as the least-squares plane is), upward; unchanged by the picks' order
    and moved by less than 1e-7 (of a unit vector) by 1e-9 m nudges."""
    rng = np.random.default_rng(11)
    P, _, _ = _curved_sticks(rng, sigma, bend=0.0)
    a = np.radians(30.0)
    n_ = np.array([np.cos(a), -np.sin(a)])
    want = np.r_[np.sin(np.radians(50.0)) * n_, np.cos(np.radians(50.0))]
    got, local = derive._mean_orientation(P, derive._Picks(P))
    assert got[2] > 0 and np.degrees(np.arccos(min(1.0, got @ want))) < 0.5
    assert len(local) > 0.9 * len(P) and (local @ got > 0).all()
    perm = rng.permutation(len(P))
    got2, _ = derive._mean_orientation(P[perm], derive._Picks(P[perm]))
    assert np.allclose(got2, got, atol=1e-12)
    Pn = P + rng.uniform(-1e-9, 1e-9, P.shape)
    got3, _ = derive._mean_orientation(Pn, derive._Picks(Pn))
    assert np.linalg.norm(got3 - got) < 1e-7


def _bent_ground(turn: float = 0.0, nudge: float = 0.0, seed: int = 0):
    """A vertical fault bent by 200 m over 500 m of strike (picked over 150
    m of depth, _arc_fault) inside a 3 km x 2 km area at UTM-sized
    coordinates, two layers dropped by up to 20 m inside the arc (tapering
    to its ends) as layer points on a jittered 100 m grid; the fault points
    moved by up to ``nudge`` m (``seed``). Returns (dataset, truth(xy, z0),
    layers {name: z0}, radius, centre, fine grid (n, 2))."""
    P, st_, radius, centre, half, across = _arc_fault(500.0, 200.0, 150.0, 90.0, turn)
    off = P[:, :2].min(axis=0) - np.array([1000.0, 1000.0])
    ring = np.array([[0.0, 0.0], [3000.0, 0.0], [3000.0, 2000.0], [0.0, 2000.0]]) + off
    rng = np.random.default_rng(0)
    g = np.stack(np.meshgrid(np.arange(50.0, 3000.0, 100.0), np.arange(50.0, 2000.0, 100.0)), -1)
    g = g.reshape(-1, 2) + rng.uniform(-30.0, 30.0, (g.size // 2, 2)) + off
    fine = np.stack(np.meshgrid(np.arange(0.0, 3000.0, 10.0), np.arange(0.0, 2000.0, 10.0)), -1)
    fine = fine.reshape(-1, 2) + off
    a = np.radians(turn)

    def truth(xy, z0):
        d = xy - centre
        ang = np.arctan2(d[:, 0], d[:, 1]) - a
        ang = (ang + np.pi) % (2 * np.pi) - np.pi
        inside = (np.hypot(*d.T) < radius(0.0)) & (np.abs(ang) < half)
        return z0 + 0.01 * (xy[:, 0] - off[0]) - np.where(inside, 20.0 * np.clip(1 - (ang / half) ** 2, 0, 1), 0.0)

    if nudge:
        P = P + np.random.default_rng(seed).uniform(-nudge, nudge, P.shape)
    layers = {"A": -60.0, "B": -100.0}
    ds = Dataset(name="bent", layers=list(layers), boundary=ring,
                 points={n: np.column_stack([g, truth(g, z0)]) for n, z0 in layers.items()},
                 faults=[Fault("F", None, points=P, sticks=st_)])
    return ds, truth, layers, radius, centre, fine


def test_a_dataset_with_a_vertical_fault_bent_along_strike_builds():
    """_bent_ground: the fault is derived with tips at both ends, the model
    builds and passes check(), and its layers' mean |dz| within 200 m of
    the fault is under 1 m (0.53 m measured). Regression: derive refused
    the fault ("its points lie in a horizontal plane")."""
    from faultmesh.build import surface_z

    ds, truth, layers, radius, centre, fine = _bent_ground()
    d = derive.derive_faults(ds)
    assert d.derivation.faults["F"].as_dict()["ends"] == ["tip", "tip"]
    m = faultmesh.build_model(d)
    m.check()
    errs = []
    for n, z0 in layers.items():
        near = np.abs(np.hypot(*(fine - centre).T) - radius(0.0))
        sel = (near < 200.0) & (near > 5.0)
        z = surface_z(m.surfaces[n].vertices, m.surfaces[n].triangles, fine[sel])[1]
        assert np.isfinite(z).mean() > 0.99
        errs.append(np.abs(z - truth(fine[sel], z0))[np.isfinite(z)])
    assert np.concatenate(errs).mean() < 1.0


@pytest.mark.parametrize("turn", [0.0, 10.0])
def test_a_vertical_fault_bent_along_strike_derives_alike_under_nudges(turn):
    """_bent_ground with its fault points moved by up to 1e-9 m (rounding,
    another machine's libraries): the same kind, sections and cutoffs (to
    5 cm: the TIN's diagonals in the projection of a vertical fault's
    stick rows, rectangles, are rounding's, 2 cm measured). Regression: the
    mean normal of a vertical fault leans by 1e-5 to 1e-4 by a sign that
    such nudges changed, and the hanging wall (and the kind, normal or
    reverse, and two sections) flipped with it while the vertical
    convention looked at components of 1e-12 (derive.VERTICAL)."""
    def derived(nudge, seed=0):
        r = derive.derive_faults(_bent_ground(turn, nudge, seed)[0]).derivation.faults["F"]
        return r.kind, r.as_dict()
    kind0, r0 = derived(0.0)
    for seed in range(3):
        kind, r = derived(1e-9, seed)
        assert kind == kind0 and r["ends"] == r0["ends"] and len(r["sections"]) == len(r0["sections"])
        for lay, cut in r0["cutoffs"].items():
            for side, pts in cut.items():
                assert np.abs(np.asarray(r["cutoffs"][lay][side]) - np.asarray(pts)).max() < 0.05


def test_strike_spacing_is_the_stick_spacing_with_or_without_labels():
    """derive._strike_spacing, the default reach of fault_surface: for
    sticks 100 m apart with points 20 m apart down each, 100 m, whether or
    not the stick column is given (before, unlabelled points got a fifth of
    the fault's length, 400 m here); one stick has none (0)."""
    rng = np.random.default_rng(3)
    P, st, s = _curved_sticks(rng, 0.0)
    assert derive._strike_spacing(P, s) == pytest.approx(100.0, rel=0.02)
    one = P[st == 3]
    assert derive._strike_spacing(one, s) == 0.0
    # Denser down the stick than the first neighbours reach (5 m: 40 of a
    # stick's points are nearer than the next stick).
    P5, _, _ = _curved_sticks(rng, 0.0, step=5.0)
    assert derive._strike_spacing(P5, s) == pytest.approx(100.0, rel=0.02)
    # A study area whose sides across strike lie 250 m past the last sticks:
    # 2.5 spacings, a tip at both ends (a fifth of the length carried them).
    n = np.array([s[1], -s[0]])
    uw = np.array([[-1250.0, -2000.0], [1250.0, -2000.0], [1250.0, 2000.0], [-1250.0, 2000.0]])
    ring = np.array([512_345.6, 7_012_345.6]) + uw[:, :1] * s + uw[:, 1:] * n
    a, b = ring[1] - ring[0], ring[2] - ring[0]
    if a[0] * b[1] - a[1] * b[0] < 0:
        ring = ring[::-1]
    for sticks in (st, None):
        fs = derive.fault_surface(Fault("F", points=P, sticks=sticks), ring, (-700.0, 0.0))
        assert fs.ends == ["inside", "inside"], (sticks is None, fs.ends)


def test_noisy_fault_picks_leave_no_datum_by_the_fault_on_the_wrong_side():
    """Random ground 27 as v2 with section picks, its fault sticks picked
    with a 3 m error across strike (grounds.write_v2(fault_noise=3)): the
    TIN through the picks had two footwall tops of L2 and L3, 4.5 and 7.3 m
    under the true fault, above it; they went to the hanging wall, whose L2
    and L3 cutoffs came out up to 10 m off, and the model's error near the
    fault was 0.39x the true cutoffs' model's. Within the fault's band
    (FaultSurface.band: 2.5 x the picks' scatter, here 2.5 x 2.5 m) a datum
    now goes to the side whose surface passes nearer: none of the data
    within 20 m of the true fault lies on the wrong side, 0.22x."""
    from faultmesh import grounds

    built = {}
    out = grounds.evaluate_ground_v2(27, fault_noise=3.0, built=built)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["ratio"] <= 0.3, (out["error_v1"], out["error_v2"])
    geo, ds = built["geo"], built["ds2"]
    fs = built["derived"].derivation.faults["F1"].surface
    sin_dip = np.sin(np.radians(geo.fault("F1").dip))
    assert 0.8 * 3.0 * sin_dip <= fs.scatter <= 1.2 * 3.0 * sin_dip, fs.scatter
    ring = np.asarray(ds.boundary)
    frame = derive._side_frame(fs, ring, 2000.0, 20.0)
    wrong = {}
    for lay in ds.layers:
        D = derive.layer_data(ds, lay)
        gap, ext = derive._data_sides(fs, D, frame, 12)
        hanging = geo.hanging(D[:, 0], D[:, 1], D[:, 2])[:, 0]
        near = np.abs(D[:, 2] - geo.plane_z("F1", D[:, 0], D[:, 1])) < 20.0
        wrong[lay] = int(np.sum(near & ~gap & (ext != 0) & ((ext > 0) != hanging)))
    assert not any(wrong.values()), wrong


def test_a_steep_faults_tin_is_projected_along_a_horizontal_axis():
    """Random ground 27 as v2: F1 dips 77 degrees, its sticks 60-140 m
    apart with picks every 15-35 m down each, 3.5-8 m apart horizontally.
    Triangulated in the projection along z (the rule up to 80 degrees until
    2026-12-04), Delaunay joined picks of different levels across sticks:
    27 % of the TIN's area lay in triangles more than 45 degrees off the
    fault's plane (a mean of 25 degrees). Along the axis nearest to the
    normal (here y) 0.0002 % does, and the noisy picks of the same fault (3 m
    across strike) stay under 1 %."""
    from faultmesh import grounds

    def folded(fs):
        V, T = fs.own
        n = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]])
        a = np.linalg.norm(n, axis=1)
        off = np.abs((n / a[:, None]) @ fs.normal) < np.cos(np.radians(45.0))
        return float(np.average(off, weights=a))

    import tempfile
    from pathlib import Path

    for noise, most in ((0.0, 1e-4), (3.0, 0.01)):
        with tempfile.TemporaryDirectory() as tmp:
            spec, geo, p1 = grounds.make_ground(27, Path(tmp))
            ds1 = faultmesh.load_dataset(p1)
            ds = faultmesh.load_dataset(grounds.write_v2(ds1, geo, spec, Path(tmp) / "v2",
                                                         fault_noise=noise))
        fs = derive.fault_surface(ds.faults[0], np.asarray(ds.boundary), (-1e3, 1e3))
        assert fs.axis == int(np.argmax(np.abs(fs.normal))) != 2, fs.axis
        assert folded(fs) <= most, (noise, folded(fs))
        old = derive.fault_surface(ds.faults[0], np.asarray(ds.boundary), (-1e3, 1e3), max_z_dip=80.0)
        assert old.axis == 2 and folded(old) > 0.2, folded(old)


@pytest.mark.parametrize("sigma", [0.0, 3.0])
def test_smoothed_picks_lie_nearer_the_fault_than_the_picks(sigma):
    """derive._smoothed_points: noisy picks (3 m across strike) moved along
    the projection axis onto the quadric of their neighbours lie at less
    than half their error from the true fault (measured along the axis),
    keeping their projected positions; exact picks (scatter below
    ON_FAULT) stay as they are."""
    rng = np.random.default_rng(11)
    P, _, _ = _curved_sticks(rng, sigma)
    exact, _, _ = _curved_sticks(np.random.default_rng(11), 0.0)
    sc = derive._point_scatter(P)
    c, n = derive._best_plane(P)
    axis = int(np.argmax(np.abs(n)))
    S = derive._smoothed_points(P, sc, axis)
    others = [i for i in range(3) if i != axis]
    assert np.array_equal(S[:, others], P[:, others])
    if sigma == 0.0:
        assert np.array_equal(S, P)
        return
    # The true fault along the axis at the picks' projected positions: the
    # exact sticks' own points moved by the same error lie on it, so the
    # error along the axis is the difference from the exact picks there.
    def along_axis_error(Q):
        from scipy.interpolate import LinearNDInterpolator
        f = LinearNDInterpolator(exact[:, others], exact[:, axis])
        t = f(Q[:, others])
        ok = np.isfinite(t)
        return float(np.sqrt(np.mean((Q[ok, axis] - t[ok]) ** 2)))

    before, after = along_axis_error(P), along_axis_error(S)
    assert after < 0.5 * before, (before, after)


def test_noisy_picks_of_a_steep_normal_fault_keep_its_sections():
    """Random ground 7 as v2, its fault sticks picked with a 3 m error across
    strike: F2 dips 74 degrees, its cutoffs of L1 a heave of about 8 m
    apart. Through the picks as they are (projected along x), the TIN and so
    both cutoff lines zigzagged by the error and crossed: four sections
    dropped ("cutoffs made the patch cross itself"), 1.76x the true
    cutoffs' model. The picks smoothed (derive._smoothed_points), no section
    is dropped and the model is within the issue's 1.25x (0.78x)."""
    from faultmesh import grounds

    built = {}
    out = grounds.evaluate_ground_v2(7, fault_noise=3.0, built=built)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    fr = built["derived"].derivation.faults["F2"]
    assert fr.surface.axis == 0 and fr.surface.scatter > 2.0
    assert not [w for w in fr.warnings if "dropped from section" in w], fr.warnings
    assert out["ratio"] <= 1.0, (out["error_v1"], out["error_v2"])


def test_a_row_of_picks_nudged_off_its_line_closes_no_sliver_on_the_outline():
    """Picks of one level lie on one line in a projection along x or y;
    moved by 1e-9 m they closed thin triangles along the TIN's outline
    whose orientation was rounding's, and a contour at that level zigzagged
    through them (random ground 91 as v2: every L4 section of a steep
    normal fault dropped under one such nudge;
    test_grounds_v2.test_derivation_takes_the_same_decisions_whatever_the_last_bits_of_the_fault_points).
    derive._peel_hull_slivers takes them off: the nudged picks' TIN has
    the exact picks' triangle count and no outline triangle thinner than
    a millimetre."""
    y = np.arange(0.0, 1000.0 + 1e-9, 100.0)
    z = np.arange(-100.0, -600.0, -25.0)
    Y, Z = (a.ravel() for a in np.meshgrid(y, z))
    P = np.column_stack([512_000.0 + 0.3 * Z, 7_000_000.0 + Y, Z])   # dipping west, along x
    ring = np.array([[511_000.0, 6_999_000.0], [513_500.0, 6_999_000.0],
                     [513_500.0, 7_002_000.0], [511_000.0, 7_002_000.0]])
    exact = derive.fault_surface(Fault("F", points=P), ring, (-700.0, 0.0), reach=0.0)
    assert exact.axis == 0
    for draw in range(5):
        Q = P + np.random.default_rng(draw).uniform(-1e-9, 1e-9, P.shape)
        fs = derive.fault_surface(Fault("F", points=Q), ring, (-700.0, 0.0), reach=0.0)
        V, T = fs.own
        assert len(T) == len(exact.own[1]), (draw, len(T), len(exact.own[1]))
        uv = V[:, 1:]
        e = np.vstack([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
        opp = np.concatenate([T[:, 2], T[:, 0], T[:, 1]])
        _, inv, cnt = np.unique(np.sort(e, axis=1), axis=0, return_inverse=True, return_counts=True)
        outer = cnt[np.ravel(inv)] == 1
        a, b, c = uv[e[outer, 0]], uv[e[outer, 1]], uv[opp[outer]]
        ab = b - a
        h = np.abs(ab[:, 0] * (c[:, 1] - a[:, 1]) - ab[:, 1] * (c[:, 0] - a[:, 0])) / np.hypot(*ab.T)
        assert h.min() > 1e-3, (draw, h.min())


def _t_pair(a: float, gap: float, cross: float = 0.0, origin=(512_345.6, 7_012_345.6)):
    """Two fault surfaces in a T, turned by ``a`` radians at UTM-sized
    coordinates: F1 (dip 60) across a 4 km square; F2 (dip 70), square to
    it, on F1's hanging-wall side, its sticks 100 m apart along strike and
    its end ``gap`` m short of F1 at every depth (``cross`` m past it
    instead: an X); both as fault sticks."""
    R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    o = np.asarray(origin)
    z = np.arange(-50.0, -650.0, -25.0)
    # F1: strike along local x, dipping towards local +y (its hanging wall).
    xs = np.arange(-1800.0, 1800.1, 100.0)
    X1, Z1 = (v.ravel() for v in np.meshgrid(xs, z, indexing="ij"))
    Y1 = -Z1 / np.tan(np.radians(60.0))
    # F2: strike along local y from F1 (at each depth) into F1's hanging
    # wall, dipping towards local +x.
    P2, s2 = [], []
    for k, zz in enumerate(z):
        y_f1 = -zz / np.tan(np.radians(60.0))
        ys = y_f1 + gap - cross + np.arange(0.0, 1500.0, 100.0)
        x2 = -zz / np.tan(np.radians(70.0)) + 100.0
        P2.append(np.column_stack([np.full(len(ys), x2), ys, np.full(len(ys), zz)]))
        s2.append(np.arange(len(ys)))
    P2 = np.vstack(P2)
    s2 = np.concatenate(s2)
    def world(x, y):
        return o + np.column_stack([x, y]) @ R.T
    P1 = np.column_stack([world(X1, Y1), Z1])
    P2 = np.column_stack([world(P2[:, 0], P2[:, 1]), P2[:, 2]])
    ring = world(np.array([-2000.0, 2000.0, 2000.0, -2000.0]), np.array([-2000.0, -2000.0, 2000.0, 2000.0]))
    f1 = derive.fault_surface(Fault("F1", points=P1, sticks=np.repeat(np.arange(len(xs)), len(z))),
                              ring, (-700.0, 0.0))
    f2 = derive.fault_surface(Fault("F2", points=P2, sticks=s2), ring, (-700.0, 0.0))
    return f1, f2


@pytest.mark.parametrize("draw", range(6))
def test_an_end_on_a_group_partner_is_found_whatever_the_geometry(draw):
    """derive._abutted_partners on generated T's (random turn, UTM-sized
    coordinates): F2's end within its sticks' spacing (100 m) of F1 abuts
    F1, at that end only; 3-5 spacings short of F1 it does not; crossing
    F1 by 300 m (an X) it does not either; F1 abuts nothing (F2 is not on
    one side of F1's ends)."""
    rng = np.random.default_rng(700 + draw)
    a = rng.uniform(0.0, 2.0 * np.pi)
    f1, f2 = _t_pair(a, gap=rng.uniform(0.0, 60.0))
    got = derive._abutted_partners(f2, [f1])
    # The end that abuts is the one nearer F1, the other abuts nothing.
    V = f2.own[0]
    u = f2.u(V[:, :2])
    ends = [V[u <= u.min() + 1.0], V[u >= u.max() - 1.0]]
    near = int(np.argmin([np.min(derive._fault_distance(f1, E)) for E in ends]))
    assert got[near] == "F1" and got[1 - near] is None, (got, near)
    assert derive._abutted_partners(f1, [f2]) == [None, None]
    far = _t_pair(a, gap=rng.uniform(300.0, 500.0))[1]
    assert derive._abutted_partners(far, [f1]) == [None, None]
    crossing = _t_pair(a, gap=0.0, cross=300.0)[1]
    assert derive._abutted_partners(crossing, [f1]) == [None, None]


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), scale=st.floats(0.01, 1e4))
def test_a_throw_of_one_sense_is_told_from_one_that_swings(seed, scale):
    """derive._one_sense, the test that sets a block offset whose throw
    changes sense along strike aside: a throw of one sign (either) has one
    sense at any scale; one whose lesser-sense excursion passes both the
    floor and the share of the other's does not, and the answer is the same
    for -T and for T in any order along strike."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 40))
    T = np.abs(rng.normal(0.0, 1.0, n)) * scale
    assert derive._one_sense(T) and derive._one_sense(-T)
    big = float(T.max())
    # An excursion of the other sense just past the larger of the two bounds.
    lim = max(derive.OFFSET_SENSE_FLOOR, derive.OFFSET_SENSE_SHARE * big)
    for dip, want in ((1.01 * lim, False), (0.99 * lim, True)):
        if dip > big and not want:
            # The excursion is the larger sense then: the bound is its share.
            continue
        S = T.copy()
        S[rng.integers(0, n)] = -dip
        if S.max() < big:
            continue                 # the largest excursion was replaced
        assert derive._one_sense(S) is want, (S, lim)
        assert derive._one_sense(-S[::-1]) is want


@pytest.mark.parametrize("draw", range(4))
def test_data_within_a_partners_band_are_told_whatever_the_turn(draw):
    """derive._in_bands, which keeps a datum out of every fault block of a
    partner whose TIN cannot tell its side (noisy fault picks): on F1 of a
    generated T (random turn, UTM-sized coordinates; dip 60), with a
    picking scatter that makes its band 2.5 x 2 = 5 m, data 0.5-4.5 m from
    the plane along its normal are in the band on either side and data
    5.5-50 m away are not; beyond the fault's extent none is. The block
    keys from the located answers are those of a fresh side test."""
    rng = np.random.default_rng(900 + draw)
    a = rng.uniform(0.0, 2.0 * np.pi)
    f1, f2 = _t_pair(a, gap=30.0)
    f1.scatter = 2.0
    assert f1.band == pytest.approx(5.0)
    R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    o = np.array([512_345.6, 7_012_345.6])
    n_loc = np.array([0.0, np.sin(np.radians(60.0)), np.cos(np.radians(60.0))])   # unit normal, local
    n = np.r_[R @ n_loc[:2], n_loc[2]]
    k = 40
    x = rng.uniform(-1500.0, 1500.0, k)
    z = rng.uniform(-600.0, -100.0, k)
    on = np.column_stack([o + np.column_stack([x, -z / np.tan(np.radians(60.0))]) @ R.T, z])
    near = rng.uniform(0.5, 4.5, k) * rng.choice([-1.0, 1.0], k)
    far = rng.uniform(5.5, 50.0, k) * rng.choice([-1.0, 1.0], k)
    D = np.vstack([on + near[:, None] * n, on + far[:, None] * n])
    got = derive._in_bands([f1], D)
    assert got[:k].all() and not got[k:].any(), (near[~got[:k]], far[got[k:]])
    # Past the extent (5 km along strike beyond the 3.6 km fault): never.
    past = D + np.r_[R @ np.array([5000.0, 0.0]), 0.0]
    assert not derive._in_bands([f1], past).any()
    located = [f.sides(D) for f in (f1, f2)]
    assert np.array_equal(derive._block_keys([f1, f2], D, located), derive._block_keys([f1, f2], D))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), scale=st.floats(0.01, 1e3), reach=st.floats(0.1, 1e4))
def test_the_kind_weighs_a_layer_by_how_far_its_data_lie(seed, scale, reach):
    """derive._sense_offset, whose sign is the fault's kind: the same at
    any scale of throws and of distances (gaps and floor together); a layer
    whose data lie at the fault outweighs layers of the other sense whose
    weighted sum is smaller, however large their throws; a gap under the
    floor counts as the floor; without local evidence the regional offsets
    decide, unweighted; without any, None."""
    rng = np.random.default_rng(seed)
    floor = 0.25 * reach
    near = rng.uniform(0.0, 2.0) * floor
    n_far = int(rng.integers(1, 5))
    far_gaps = rng.uniform(2.0, 10.0, n_far) * floor
    t_near = rng.uniform(1.0, 40.0) * scale
    # The far layers' throws of the other sense, just short of (or just
    # past) outweighing the near one.
    share = rng.dirichlet(np.ones(n_far))
    bound = t_near / max(near, floor)
    for k, want in ((0.98, 1.0), (1.02, -1.0)):
        local = {"near": [(t_near, near)] * 3}
        for j in range(n_far):
            t = k * share[j] * bound * far_gaps[j]
            local[f"far{j}"] = [(-t, far_gaps[j])] * int(rng.integers(1, 4))
        off = derive._sense_offset(local, {"far0": [1e6]}, floor)
        assert np.sign(off) == want, (local, off)
        for sign in (1.0, -1.0):
            flipped = {lay: [(sign * t * 7.0, g * 3.0) for t, g in v] for lay, v in local.items()}
            assert np.sign(derive._sense_offset(flipped, {}, 3.0 * floor)) == sign * want
    assert derive._sense_offset({"a": [(5.0, 0.0)]}, {}, floor) == \
        derive._sense_offset({"a": [(5.0, floor)]}, {}, floor)
    assert derive._sense_offset({}, {"a": [-2.0, -1.0, 9.0], "b": [3.0]}, floor) == 2.0
    assert derive._sense_offset({}, {}, floor) is None


@pytest.mark.parametrize("draw", range(5))
def test_the_tins_chord_error_is_how_far_a_curved_fault_bulges_between_sticks(draw):
    """FaultSurface.chord on generated faults bent along strike (a circular
    arc of radius 2-20 km in map view, dip 50-75 towards its centre's far
    side, sticks 60-140 m apart, turned at random at UTM-sized
    coordinates): between two sticks the true fault lies the arc's sagitta
    L^2 / 8R (horizontally, across strike) off the TIN, sin(dip) of it
    along the normal; the estimate is within 25 % of that. A plane's chord
    is under a millimetre. A datum on the true fault halfway between two
    sticks lies on the fault (_on_fault), one a metre off it does not."""
    rng = np.random.default_rng(8100 + draw)
    R = rng.uniform(2000.0, 20000.0)
    L = rng.uniform(60.0, 140.0)
    dip = np.radians(rng.uniform(50.0, 75.0))
    a = rng.uniform(0.0, 2.0 * np.pi)
    o = np.array([rng.uniform(3e5, 7e5), rng.uniform(6e6, 7e6)])
    Rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    z = np.arange(-20.0, -620.0, -25.0)

    def surface(radius, u, zz):
        """Points at arc length u (m) along the trace at z = 0 and depth zz."""
        if radius is None:
            x, y, nx, ny = u, np.zeros_like(u), np.zeros_like(u), np.ones_like(u)
        else:
            t = u / radius
            x, y = radius * np.sin(t), radius * (1.0 - np.cos(t))
            nx, ny = -np.sin(t), np.cos(t)        # towards the arc's centre
        d = -zz / np.tan(dip)                   # down dip, horizontally
        return np.column_stack([o + np.column_stack([x + d * nx, y + d * ny]) @ Rot.T, zz])

    us = np.arange(-1500.0, 1500.1, L)
    U, Z = (v.ravel() for v in np.meshgrid(us, z, indexing="ij"))
    ring = (o + np.array([[-2500.0, -2500.0], [2500.0, -2500.0], [2500.0, 2500.0], [-2500.0, 2500.0]]) @ Rot.T)
    sticks = np.repeat(np.arange(len(us)), len(z))
    for radius in (R, None):
        fs = derive.fault_surface(Fault("F", points=surface(radius, U, Z), sticks=sticks), ring, (-650.0, 0.0))
        if radius is None:
            assert fs.chord < 1e-3, fs.chord
            continue
        want = L * L / (8.0 * radius) * np.sin(dip)
        assert abs(fs.chord - want) <= 0.25 * want, (fs.chord, want)
        mid = surface(radius, np.array([us[len(us) // 2] + 0.5 * L]), np.array([z[len(z) // 2]]))
        assert derive._on_fault(fs, mid).tolist() == [True], (fs.chord, derive._fault_distance(fs, mid))
        off = mid.copy()
        off[0, 2] -= 1.0 / np.cos(dip)            # a metre off along the normal, about
        assert derive._on_fault(fs, off).tolist() == [False]


def test_tied_fading_profiles_put_the_fade_in_the_middle_of_the_open_stretch():
    """Profiles that give every hanging-wall datum the same share fit the
    same system and tie; the data then leave open where the throw goes
    between the farthest datum that shows all of it and the nearest that
    shows none. The first in order (the shortest) took it away as near the
    fault as the data allow (held-out random ground 185 as v2: the whole
    throw up to 98 m from F1, none from 553 m; (100, 100) m, hanging-wall
    far ends 25-29 m low, 1.37x). The one whose throw is half gone nearest
    the middle of that stretch is taken; without such a stretch, or with
    the block offset first, the first."""
    d = np.array([10.0, 50.0, 98.0, 553.0, 900.0])
    tied = [(100.0, 100.0), (100.0, 150.0), (150.0, 100.0), (200.0, 200.0), (150.0, 350.0)]
    # Middle of (98, 553): 325.5; flat + fade / 2: 150, 175, 200, 300, 325.
    assert derive._middle_profile(tied, d) == (150.0, 350.0)
    assert derive._middle_profile(tied, d[:3]) == (100.0, 100.0)      # nothing shows none
    assert derive._middle_profile([None] + tied, d) is None
    assert derive._middle_profile(tied[:1], d) == (100.0, 100.0)
    # The shares of the tied profiles agree at the data: the choice keeps them.
    got = derive._middle_profile(tied, d)
    np.testing.assert_array_equal(derive._decay_share(d, got), derive._decay_share(d, tied[0]))


def test_a_throw_whose_fade_the_data_leave_open_fades_in_the_middle():
    """Regression (held-out random ground 185 as v2 with section picks; see
    the test above): F1's L3 hanging-wall far ends 25-29 m below the truth,
    every cutoff within 2 m, 1.37x the true cutoffs' error near the faults
    (1.09x on the former grid of profiles, whose first tie was (150, 100));
    with the fade in the middle of the open stretch 0.39x."""
    from faultmesh import grounds

    out = grounds.evaluate_ground_v2(185)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["kind_ok"], out["kinds"]
    assert out["ratio"] <= 1.0, (out["error_v1"], out["error_v2"])


# ---------------------------------------------------------------------------
# Faults that meet: grouped by the derivation
# ---------------------------------------------------------------------------
_MEET_ORIGIN = np.array([612_345.67, 7_012_345.67])


def _plane_fault(name: str, strike_deg: float, dip_deg: float, through, u_range,
                 z_top: float = 0.0, z_bottom: float = -400.0, group=None) -> Fault:
    """Fault sticks every 100 m along strike (points every 25 m down dip,
    rounded to the centimetre as interpreters write them) on a plane that
    strikes ``strike_deg`` (clockwise from north, dipping to its right)
    and passes through ``through`` (XY relative to a UTM-sized origin) at
    z = 0, over ``u_range`` (m along strike from it)."""
    a = np.radians(strike_deg)
    s = np.array([np.sin(a), np.cos(a)])
    d = np.array([s[1], -s[0]])
    u = np.arange(u_range[0], u_range[1] + 1e-9, 100.0)
    z = np.arange(z_top, z_bottom - 1e-9, -25.0)
    U, Z = (v.ravel() for v in np.meshgrid(u, z, indexing="ij"))
    w = 0.0 if dip_deg >= 90.0 else -Z / np.tan(np.radians(dip_deg))
    xy = _MEET_ORIGIN + np.asarray(through, float) + U[:, None] * s + np.asarray(w)[..., None] * d
    P = np.round(np.column_stack([xy, Z]), 2)
    return Fault(name, None, group, points=P, sticks=np.repeat(np.arange(len(u)), len(z)))


def _meets(faults, z_range=(-350.0, -50.0), half: float = 1000.0):
    ring = _MEET_ORIGIN + np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    surfs = {f.name: derive.fault_surface(f, ring, z_range, warnings=[]) for f in faults}
    return derive._faults_that_meet(faults, surfs, ring, z_range)


def test_faults_whose_points_cross_or_abut_are_found_to_meet():
    """What the derivation groups where the data name no group: an X (two
    faults through the centre at right angles), a T (one vertical fault
    ending 5 m short of another, within its sticks' spacing), and neither
    for faults 500 m apart, a graben whose faults meet only below the
    layers (z -200 m, the layers' data down to -150 m), or an X outside the
    study area."""
    f1 = _plane_fault("F1", 10.0, 60.0, (0.0, 0.0), (-1400.0, 1400.0))
    f2 = _plane_fault("F2", 100.0, 50.0, (0.0, 0.0), (-1400.0, 1400.0))
    (m,) = _meets([f1, f2])
    assert (m.a, m.b, m.how) == ("F1", "F2", "cross") and -350.0 <= m.where[2] <= -50.0
    assert np.all(np.abs(m.where[:2] - _MEET_ORIGIN) < 1000.0)
    # Given one group, they are not found again.
    assert _meets([replace(f1, group="G"), replace(f2, group="G")]) == []

    v1 = _plane_fault("V1", 0.0, 90.0, (0.0, 0.0), (-1400.0, 1400.0))
    t = _plane_fault("T", 90.0, 90.0, (5.0, 0.0), (0.0, 1300.0))
    (m,) = _meets([v1, t])
    assert m.how == "abut" and {m.a, m.b} == {"V1", "T"} and m.gap == pytest.approx(5.0, abs=0.05)
    far = _plane_fault("P", 0.0, 90.0, (500.0, 0.0), (-1400.0, 1400.0))
    assert _meets([v1, far]) == []

    # A graben: faults 400 m apart at z = 0 dipping 45 degrees towards each
    # other meet at z = -200 m.
    g1 = _plane_fault("G1", 0.0, 45.0, (-200.0, 0.0), (-1400.0, 1400.0))
    g2 = _plane_fault("G2", 180.0, 45.0, (200.0, 0.0), (-1400.0, 1400.0))
    assert _meets([g1, g2], z_range=(-150.0, -20.0)) == []
    (m,) = _meets([g1, g2], z_range=(-350.0, -20.0))
    assert m.how == "cross" and m.where[2] == pytest.approx(-200.0, abs=1.0)

    # An X whose crossing line lies 1.5 km east of the study area's centre.
    x1 = _plane_fault("X1", 0.0, 90.0, (1500.0, 0.0), (-1400.0, 1400.0))
    x2 = _plane_fault("X2", 90.0, 90.0, (0.0, 0.0), (-800.0, 1800.0))
    assert _meets([x1, x2]) == []


def test_groups_where_faults_meet_join_the_given_ones():
    """A fault meeting a grouped one joins its group (the given name); two
    given groups joined by a meeting take their faults' names; faults that
    meet nothing keep theirs."""
    fs = [Fault("A", None, "G1"), Fault("B", None, "G1"), Fault("C", None, None),
          Fault("D", None, "G2"), Fault("E", None, None), Fault("F", None, "G3"), Fault("H", None, "G3")]
    meet = derive.FaultsMeet
    w = np.zeros(3)
    out, new = derive._grouped_where_they_meet(fs, [meet("C", "B", "cross", w), meet("E", "D", "abut", w, 2.0)])
    assert [f.group for f in out] == ["G1", "G1", "G1", "G2", "G2", "G3", "G3"]
    assert new == {"C": "G1", "E": "G2"}
    out, new = derive._grouped_where_they_meet(fs, [meet("A", "D", "cross", w)])
    assert [f.group for f in out] == ["A+B+D", "A+B+D", None, "A+B+D", None, "G3", "G3"]
    assert [f.name for f in fs] == [f.name for f in out] and fs[0].group == "G1"   # not in place


def test_crossing_faults_given_without_a_group_build_as_a_group():
    """Regression (random_ground(190) as v2 with picks, its X pair F1 and
    F2 written without their group, as fault points carry none): the
    stitcher refused it ("faults too close: fault 'F1' and fault 'F2'
    overlap"). The derivation now finds that they cross, groups them
    (saying so), and the model is the one built from the dataset that
    gave the group."""
    given, bare = _v2_without_groups(190)
    assert [f.group for f in given.faults] == ["F1+F2", "F1+F2", None, None]
    db = derive.derive_faults(bare)
    assert db.derivation.groups == {"F1+F2": ["F1", "F2"]}
    assert [f.group for f in db.faults] == ["F1+F2", "F1+F2", None, None]
    said = [w for w in db.derivation.warnings if "modelled together as group 'F1+F2'" in w]
    assert len(said) == 1 and "fault 'F1' crosses fault 'F2'" in said[0]
    mb = faultmesh.build_model(db, evaluate=False)
    mb.check()
    _same_model(mb, faultmesh.build_model(derive.derive_faults(given), evaluate=False))


def _v2_without_groups(seed: int):
    """Random ground ``seed`` as v2 with section picks, loaded twice: its
    faults with their groups (as the sweeps write it) and without."""
    import tempfile
    from pathlib import Path

    from faultmesh.grounds import make_ground, write_v2

    with tempfile.TemporaryDirectory() as d:
        spec, geo, js1 = make_ground(seed, Path(d) / "v1")
        ds1 = faultmesh.load_dataset(js1)
        given = faultmesh.load_dataset(write_v2(ds1, geo, spec, Path(d) / "g", section_picks=True))
        bare = faultmesh.load_dataset(write_v2(ds1, geo, spec, Path(d) / "n", section_picks=True,
                                               groups=False))
    assert all(f.group is None for f in bare.faults)
    return given, bare


def _same_model(a, b) -> None:
    for lay in a.surfaces:
        assert np.array_equal(a.surfaces[lay].vertices, b.surfaces[lay].vertices), lay
        assert np.array_equal(a.surfaces[lay].triangles, b.surfaces[lay].triangles), lay


def test_a_fault_abutting_another_given_without_a_group_builds_as_a_group():
    """Regression (random_ground(24) as v2, a T: F2, dipping 36 degrees,
    ends against F1, dipping 46, written without their group): refused as
    "faults too close" (their L1 patches overlapped). F2 comes within 2.8 m
    of F1, within its sticks' spacing, and their patches derived apart
    meet, so the derivation derives them again as one group, says so, and
    the model is the one built from the dataset that gave the group."""
    given, bare = _v2_without_groups(24)
    assert [f.group for f in given.faults] == ["F1+F2", "F1+F2"]
    db = derive.derive_faults(bare)
    assert db.derivation.groups == {"F1+F2": ["F1", "F2"]}
    said = [w for w in db.derivation.warnings if "modelled together as group 'F1+F2'" in w]
    assert len(said) == 1 and "their patches in layer 'L1', derived as two faults, met" in said[0]
    mb = faultmesh.build_model(db, evaluate=False)
    mb.check()
    _same_model(mb, faultmesh.build_model(derive.derive_faults(given), evaluate=False))


@pytest.mark.parametrize("seed", [206, 2])
def test_faults_that_meet_but_whose_patches_stay_apart_are_not_grouped(seed):
    """Random ground 206 as v2: F3 comes within 53 m of F1 (within its
    sticks' spacing), apart in the truth; ground 2: F1's and F3's points
    cross at z = -197 m, where neither displaces a layer (each cuts L3
    only, at about -600 m). Their patches derived apart do not meet, so
    they stay two faults (grouped, the error near the faults went from
    0.53 to 0.59x the true cutoffs' on 206, from 0.48 to 0.58x on 2)."""
    given, bare = _v2_without_groups(seed)
    assert all(f.group is None for f in given.faults)
    d = derive.derive_faults(bare)
    assert d.derivation.groups == {} and all(f.group is None for f in d.faults)
    assert not [w for w in d.derivation.warnings if "modelled together" in w]


def test_noisy_picks_on_lines_are_smoothed_not_followed():
    """Seismic picks with 1 m of noise, 20 m apart on lines 334 m apart, of
    a layer cut by a listric normal fault (57.5 m of throw; a probe's own
    generator, tests/data/derive/noisy_picks_listric_normal_fault): the
    side surfaces' default smoothing followed the noise into ripples that
    it extrapolated towards the fault, footwall cutoffs 48-158 m deep where
    the layer lies near 125 m, the model 4.1 m off near the fault (median)
    and 61 m at worst. The smoothing chosen by cross-validation
    (derive._noise_smoothing) takes the noise out: under 1.2 m and 30 m."""
    from faultmesh.build import surface_z

    folder = Path(__file__).parent / "data" / "derive" / "noisy_picks_listric_normal_fault"
    ds = faultmesh.load_dataset(folder / "dataset.json")
    truth = np.loadtxt(folder / "truth_L0.csv", delimiter=",", skiprows=1)
    derived = derive.derive_faults(ds)
    fr = derived.derivation.faults["F0"]
    assert fr.kind == "normal"
    foot = fr.cutoffs["L0"]["foot"][:, 2]
    assert np.all((foot > -150.0) & (foot < -95.0)), foot
    m = faultmesh.build_model(derived, evaluate=False)
    m.check()
    s = m.surfaces["L0"]
    z = surface_z(s.vertices, s.triangles, truth[:, :2])[1]
    err = np.abs(z - truth[:, 2])
    near = truth[:, 3] <= 150.0
    assert np.all(np.isfinite(err)), "the model misses truth places"
    assert np.median(err[near]) < 1.2 and err.max() < 30.0, (np.median(err[near]), err.max())


def test_a_fault_surface_folded_by_a_no_data_vertex_names_a_triangle_at_it():
    """Regression (fuzz of GOCAD exports): a fault TSurf with one vertex at
    z = -99999 (a no-data value) was refused as folded with no word of
    where; the error now gives a triangle of the fewer orientation, whose
    corners show the vertex."""
    from scipy.spatial import Delaunay
    ys, zs = np.meshgrid(np.linspace(0, 1000, 6), np.linspace(-500, 0, 6))
    x = 500 + (-zs) / np.tan(np.radians(60))
    V = np.column_stack([x.ravel(), ys.ravel(), zs.ravel()])
    T = Delaunay(V[:, 1:]).simplices.astype(np.int64)
    ring = np.array([[0, 0], [1000, 0], [1000, 1000], [0, 1000]], float)
    fs = derive.fault_surface(Fault("F", surface=(V.copy(), T)), ring, (-500.0, 0.0))
    assert fs.dip == pytest.approx(60.0, abs=0.5)
    V[14, 2] = -99999.0
    with pytest.raises(faultmesh.GeometryError, match=r"fault 'F': the surface folds over .*triangle \d+ of 50, "
                                            r"corners .*-99999\).*faces the other way"):
        derive.fault_surface(Fault("F", surface=(V, T)), ring, (-500.0, 0.0))
