"""Exact predicates against rational arithmetic (fractions.Fraction)."""
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import faultmesh


def exact_orient(a, b, c):
    ax, ay, bx, by, cx, cy = map(Fraction, (*a, *b, *c))
    d = (ax - cx) * (by - cy) - (ay - cy) * (bx - cx)
    return (d > 0) - (d < 0)


def exact_incircle(a, b, c, d):
    rows = []
    for p in (a, b, c):
        dx, dy = Fraction(p[0]) - Fraction(d[0]), Fraction(p[1]) - Fraction(d[1])
        rows.append((dx, dy, dx * dx + dy * dy))
    (a1, a2, a3), (b1, b2, b3), (c1, c2, c3) = rows
    det = a1 * (b2 * c3 - b3 * c2) - a2 * (b1 * c3 - b3 * c1) + a3 * (b1 * c2 - b2 * c1)
    return (det > 0) - (det < 0)


# Coordinates near UTM values with tiny offsets: where naive float predicates fail.
near = st.floats(min_value=-1.0, max_value=1.0, allow_nan=False).map(lambda t: 550000.0 + t * 1e-9)
coord = st.one_of(near, st.floats(min_value=-1e6, max_value=1e6, allow_nan=False))
point = st.tuples(coord, coord)


@settings(max_examples=400, deadline=None)
@given(point, point, point)
def test_orient2d_sign_is_exact(a, b, c):
    got = faultmesh.orient2d(np.array([a]), np.array([b]), np.array([c]))[0]
    assert np.sign(got) == exact_orient(a, b, c)


@settings(max_examples=400, deadline=None)
@given(point, point, point, point)
def test_incircle_sign_is_exact(a, b, c, d):
    if exact_orient(a, b, c) <= 0:
        a, b = b, a
    got = faultmesh.incircle(np.array([a]), np.array([b]), np.array([c]), np.array([d]))[0]
    assert np.sign(got) == exact_incircle(a, b, c, d)


def test_nearly_collinear_grid_of_ulps():
    base = 0.5
    xs = [base]
    for _ in range(63):
        xs.append(np.nextafter(xs[-1], 1.0))
    a = np.array([(x, y) for x in xs for y in xs])
    b = np.tile([12.0, 12.0], (len(a), 1))
    c = np.tile([24.0, 24.0], (len(a), 1))
    got = np.sign(faultmesh.orient2d(a, b, c))
    want = [exact_orient(p, (12.0, 12.0), (24.0, 24.0)) for p in a]
    assert (got == want).all()


def test_shape_errors_name_the_argument():
    with pytest.raises(ValueError, match=r"orient2d: b must have shape \(n, 2\)"):
        faultmesh.orient2d(np.zeros((3, 2)), np.zeros((3, 3)), np.zeros((3, 2)))
