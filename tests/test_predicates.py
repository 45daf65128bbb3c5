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


# Any double within the coordinate limit, subnormals included, and tiny
# scales where products of differences underflow (issue 10: the filter
# returned 0 for orient2d((1e-200, 0), (0, 1e-200), (0, 0))).
LIMIT = 1e60
wide = st.floats(min_value=-LIMIT, max_value=LIMIT, allow_nan=False, allow_subnormal=True)
tiny = st.integers(-9, 9).flatmap(lambda k: st.sampled_from([k * 2.0 ** -1070, k * 2.0 ** -600, k * 1e-160]))
any_coord = st.one_of(wide, tiny, coord)
any_point = st.tuples(any_coord, any_coord)


@settings(max_examples=300, deadline=None)
@given(any_point, any_point, any_point)
def test_orient2d_sign_is_exact_over_the_whole_range(a, b, c):
    got = faultmesh.orient2d(np.array([a]), np.array([b]), np.array([c]))[0]
    assert np.sign(got) == exact_orient(a, b, c)


@settings(max_examples=300, deadline=None)
@given(any_point, any_point, any_point, any_point)
def test_incircle_sign_is_exact_over_the_whole_range(a, b, c, d):
    if exact_orient(a, b, c) < 0:
        a, b = b, a
    got = faultmesh.incircle(np.array([a]), np.array([b]), np.array([c]), np.array([d]))[0]
    assert np.sign(got) == exact_incircle(a, b, c, d)


def test_underflowing_products_keep_their_sign():
    """Regression (issue 10 fuzzing): every product below the smallest subnormal."""
    for s in (1e-200, 5e-324, 2.0 ** -600):
        assert faultmesh.orient2d([[s, 0]], [[0, s]], [[0, 0]])[0] > 0
        assert faultmesh.orient2d([[0, s]], [[s, 0]], [[0, 0]])[0] < 0
        # d just inside the circle through a, b, c (the unit circle scaled by s).
        got = faultmesh.incircle([[s, 0]], [[0, s]], [[-s, 0]], [[0, -0.5 * s]])[0]
        assert got > 0 and exact_incircle((s, 0), (0, s), (-s, 0), (0, -0.5 * s)) == 1


@pytest.mark.parametrize("fn,n_args", [(faultmesh.orient2d, 3), (faultmesh.incircle, 4)])
def test_coordinates_beyond_the_limit_are_value_errors(fn, n_args):
    """Regression (issue 10): incircle gave NaN at 1e78. The limit is checked
    and the message names the function, the argument, the row and the limit."""
    name = fn.__name__
    args = [np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[1.0, 0.0], [0.0, 1.0]]),
            np.array([[0.0, 1.0], [-1.0, 0.0]]), np.array([[0.5, 0.5], [0.0, -0.5]])][:n_args]
    args[1] = args[1] * 1e78
    with pytest.raises(ValueError, match=rf"{name}: b row 0 has a coordinate beyond \+-1e\+60 "
                                         r"\(x = 1e\+78\).*kMaxCoordinate"):
        fn(*args)
    args[1] = np.array([[1.0, 0.0], [0.0, np.nan]])
    with pytest.raises(ValueError, match=rf"{name}: b row 1 has a non-finite coordinate \(y = nan\)"):
        fn(*args)
    args[1] = np.array([[1.0, 0.0], [0.0, 1e60]])  # the limit itself is accepted
    assert np.all(np.isfinite(fn(*args)))
