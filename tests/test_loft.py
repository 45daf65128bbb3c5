"""faultmesh.loft: strip triangulation between two polylines (paper 2.3.2)."""
from __future__ import annotations

import itertools
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import faultmesh

DATA = Path(__file__).resolve().parent / "data"


def area3d(p, t):
    x = p[t]
    return float(np.sum(0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)))


def check_strip(t, k, l):
    """Counts, every polyline edge once in the documented direction, and a
    consistent orientation (each directed edge at most once, interior rungs
    in both directions)."""
    assert t.dtype == np.int64 and t.shape == (k + l - 2, 3)
    d = Counter((int(a), int(b)) for tri in t for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])))
    assert all(c == 1 for c in d.values())
    for i in range(k - 1):
        assert d[(i, i + 1)] == 1 and d[(i + 1, i)] == 0
    for j in range(l - 1):
        assert d[(k + j + 1, k + j)] == 1 and d[(k + j, k + j + 1)] == 0
    ends = {(0, k), (k, 0), (k - 1, k + l - 1), (k + l - 1, k - 1)}
    for a, b in d:
        if (a < k) != (b < k) and (a, b) not in ends:
            assert (b, a) in d


coords = st.integers(-50, 50)


@st.composite
def polylines(draw):
    k = draw(st.integers(1, 25))
    l = draw(st.integers(1, 25))
    a = np.array(draw(st.lists(st.tuples(coords, coords, coords), min_size=k, max_size=k)), dtype=float)
    b = np.array(draw(st.lists(st.tuples(coords, coords, coords), min_size=l, max_size=l)), dtype=float)
    a[:, 0] += 10 * np.arange(k)  # roughly along x, as section traces are
    b[:, 0] += 10 * np.arange(l)
    b[:, 1] += 100
    return a, b


@settings(max_examples=80, deadline=None)
@given(polylines())
def test_counts_edges_orientation_and_min_area(ab):
    a, b = ab
    k, l = len(a), len(b)
    t_min = faultmesh.loft(a, b, "min_area")
    t_sd = faultmesh.loft(a, b, method="shortest_diagonal")
    check_strip(t_min, k, l)
    check_strip(t_sd, k, l)
    p = np.vstack([a, b])
    assert area3d(p, t_min) <= area3d(p, t_sd) * (1 + 1e-12)
    assert faultmesh.loft_area(a, b, t_min) == pytest.approx(area3d(p, t_min), rel=1e-12)
    # Metamorphic: integer coordinates make translation by 1e6 and rotation by
    # 90 degrees about z exact, so the answers must be identical.
    shift = np.array([1e6, -1e6, 1e6])
    np.testing.assert_array_equal(faultmesh.loft(a + shift, b + shift), t_min)
    rot = lambda q: np.column_stack([-q[:, 1], q[:, 0], q[:, 2]])  # noqa: E731
    np.testing.assert_array_equal(faultmesh.loft(rot(a), rot(b)), t_min)
    np.testing.assert_array_equal(faultmesh.loft(rot(a), rot(b), "shortest_diagonal"), t_sd)


@settings(max_examples=30, deadline=None)
@given(st.integers(2, 6), st.integers(2, 6), st.integers(0, 2**32 - 1))
def test_min_area_is_optimal(k, l, seed):
    rng = np.random.default_rng(seed)
    a = np.column_stack([np.cumsum(rng.uniform(0.1, 2, k)), rng.normal(0, 0.3, k), rng.normal(0, 0.3, k)])
    b = np.column_stack([np.cumsum(rng.uniform(0.1, 2, l)), 2 + rng.normal(0, 0.3, l), rng.normal(1, 0.3, l)])
    p = np.vstack([a, b])
    best = area3d(p, faultmesh.loft(a, b))
    brute = np.inf
    for adv in itertools.combinations(range(k + l - 2), k - 1):
        i = j = 0
        tri = []
        for s in range(k + l - 2):
            if s in adv:
                tri.append([i, i + 1, k + j])
                i += 1
            else:
                tri.append([i, k + j + 1, k + j])
                j += 1
        brute = min(brute, area3d(p, np.array(tri)))
    assert best == pytest.approx(brute, rel=1e-12)


def test_fan_to_a_fault_tip():
    a = np.array([[0, 0, 0], [1, 0, 0], [2, 0.5, 0], [3, 0, 0.0]])
    tip = np.array([[1.5, 2, 1.0]])
    assert faultmesh.loft(a, tip).tolist() == [[0, 1, 4], [1, 2, 4], [2, 3, 4]]
    assert faultmesh.loft(tip, a, "shortest_diagonal").tolist() == [[0, 2, 1], [0, 3, 2], [0, 4, 3]]
    assert faultmesh.loft(tip, tip).shape == (0, 3)


def test_orientation_normal_follows_direction_cross_a_to_b():
    # a along +x at y = 0, b along +x at y = 1 (z = 0): t x (b - a) = +z, so
    # every triangle is counter-clockwise seen from above.
    a = np.column_stack([np.linspace(0, 5, 6), np.zeros(6), np.zeros(6)])
    b = np.column_stack([np.linspace(0, 5, 4), np.ones(4), np.zeros(4)])
    p = np.vstack([a, b])
    for m in ("min_area", "shortest_diagonal"):
        t = faultmesh.loft(a, b, m)
        n = np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]])
        assert np.all(n[:, 2] > 0)


def test_closed_contours():
    k, l = 13, 9
    ta = 2 * np.pi * np.arange(k) / k
    tb = 2 * np.pi * (np.arange(l) + 0.4) / l
    a = np.column_stack([np.cos(ta), np.sin(ta), np.zeros(k)])
    b = np.column_stack([1.5 * np.cos(tb), 1.5 * np.sin(tb), np.ones(l)])
    for m in ("min_area", "shortest_diagonal"):
        t = faultmesh.loft(a, b, m, closed=True)
        assert t.shape == (k + l, 3)
        d = Counter((int(x), int(y)) for tri in t for x, y in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])))
        assert all(c == 1 for c in d.values())
        assert all(d[(i, (i + 1) % k)] == 1 for i in range(k))
        assert all(d[(k + (j + 1) % l, k + j)] == 1 for j in range(l))
    p = np.vstack([a, b])
    assert area3d(p, faultmesh.loft(a, b, closed=True)) <= area3d(
        p, faultmesh.loft(a, b, "shortest_diagonal", closed=True)) * (1 + 1e-12)


def test_real_data_hecho_fault_traces():
    """Loft between two interpreted fault traces of the Hecho section (F2 and
    F3 lines, different point counts) with real coordinates."""
    f2 = np.loadtxt(DATA / "hecho" / "F2Line.csv", delimiter=";", skiprows=1)
    f3 = np.loadtxt(DATA / "hecho" / "F3Line.csv", delimiter=";", skiprows=1)
    f2 = f2[np.argsort(f2[:, 2])]
    f3 = f3[np.argsort(f3[:, 2])]
    for m in ("min_area", "shortest_diagonal"):
        check_strip(faultmesh.loft(f2, f3, m), len(f2), len(f3))
    p = np.vstack([f2, f3])
    assert area3d(p, faultmesh.loft(f2, f3)) <= area3d(p, faultmesh.loft(f2, f3, "shortest_diagonal")) * (1 + 1e-12)


def test_contract():
    a = np.zeros((3, 3))
    with pytest.raises(ValueError, match="method"):
        faultmesh.loft(a, a, "largest_volume")
    with pytest.raises(ValueError, match="no points"):
        faultmesh.loft(np.zeros((0, 3)), a)
    with pytest.raises(ValueError, match="columns"):
        faultmesh.loft(np.zeros((3, 2)), a)
    with pytest.raises(ValueError, match=r"shape \(n, 2 or 3\)"):
        faultmesh.loft(np.zeros((3, 4)), np.zeros((3, 4)))
    bad = a.copy()
    bad[1, 2] = np.inf
    with pytest.raises(ValueError, match=r"loft: b row 1 has a non-finite coordinate"):
        faultmesh.loft(a, bad)
    with pytest.raises(ValueError, match="2 points"):
        faultmesh.loft(np.zeros((2, 3)), a, closed=True)
    # 2-column input: z = 0; any dtype converts.
    assert faultmesh.loft(np.array([[0, 0], [1, 0]]), np.array([[0, 1], [1, 1]])).shape == (2, 3)


def test_coordinates_beyond_the_limit_are_value_errors():
    """Regression (issue 10): loft returned an empty result at 1e100 (3D areas
    overflow). z counts too: it enters the areas."""
    a = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], float)
    b = a + [0, 1, 1]
    for col in range(3):
        big = b.copy()
        big[1, col] = 1e100
        with pytest.raises(ValueError, match=rf"loft: b row 1 has a coordinate beyond \+-1e\+60 "
                                             rf"\({'xyz'[col]} = 1e\+100\)"):
            faultmesh.loft(a, big)
    nan = a.copy()
    nan[2, 2] = np.nan
    with pytest.raises(ValueError, match=r"loft: a row 2 has a non-finite coordinate \(z = nan\)"):
        faultmesh.loft(nan, b)
    assert faultmesh.loft(a * 1e59, b * 1e59).shape == (4, 3)
