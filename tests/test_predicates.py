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


@pytest.mark.parametrize("fn,n_args,dim", [(faultmesh.orient2d, 3, 2), (faultmesh.incircle, 4, 2),
                                            (faultmesh.orient3d, 4, 3)])
def test_coordinates_beyond_the_limit_are_value_errors(fn, n_args, dim):
    """Regression (issue 10): incircle gave NaN at 1e78. The limit is checked
    and the message names the function, the argument, the row and the limit
    (orient3d, from main, gets the same check)."""
    name = fn.__name__
    args = [np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
            np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]), np.array([[0.5, 0.5, 1.0], [0.0, -0.5, 1.0]])][:n_args]
    args = [x[:, :dim] for x in args]
    args[1] = args[1] * 1e78
    with pytest.raises(ValueError, match=rf"{name}: b row 0 has a coordinate beyond \+-1e\+60 "
                                         r"\(x = 1e\+78\).*kMaxCoordinate"):
        fn(*args)
    args[1] = np.array([[1.0, 0.0, 0.0], [0.0, np.nan, 0.0]])[:, :dim]
    with pytest.raises(ValueError, match=rf"{name}: b row 1 has a non-finite coordinate \(y = nan\)"):
        fn(*args)
    args[1] = np.array([[1.0, 0.0, 0.0], [0.0, 1e60, 0.0]])[:, :dim]  # the limit itself is accepted
    assert np.all(np.isfinite(fn(*args)))


# ---------------------------------------------------------------------------
# orient3d
# ---------------------------------------------------------------------------
def exact_orient3d(a, b, c, d):
    r = [[Fraction(p[i]) - Fraction(d[i]) for i in range(3)] for p in (a, b, c)]
    det = (r[0][2] * (r[1][0] * r[2][1] - r[2][0] * r[1][1])
           + r[1][2] * (r[2][0] * r[0][1] - r[0][0] * r[2][1])
           + r[2][2] * (r[0][0] * r[1][1] - r[1][0] * r[0][1]))
    return (det > 0) - (det < 0)


# UTM-like magnitudes with sub-nanometre offsets, and general coordinates.
near3 = st.floats(min_value=-1.0, max_value=1.0, allow_nan=False)
point3 = st.one_of(
    st.tuples(near3.map(lambda t: 551234.5 + t * 1e-9), near3.map(lambda t: 7817654.25 + t * 1e-9),
              near3.map(lambda t: -10234.125 + t * 1e-9)),
    st.tuples(*[st.floats(min_value=-1e6, max_value=1e6, allow_nan=False)] * 3))


@settings(max_examples=400, deadline=None)
@given(point3, point3, point3, point3)
def test_orient3d_sign_is_exact(a, b, c, d):
    got = faultmesh.orient3d(np.array([a]), np.array([b]), np.array([c]), np.array([d]))[0]
    assert np.sign(got) == exact_orient3d(a, b, c, d)


@settings(max_examples=300, deadline=None)
@given(point3, point3, point3, st.floats(0.0, 1.0), st.floats(0.0, 1.0),
       st.sampled_from([0.0, 1e-12, -1e-12, 1e-9]))
def test_orient3d_near_coplanar_is_exact(a, b, c, s, t, dz):
    # d on the plane through a, b, c up to rounding (and a tiny lift): the
    # floating-point determinant is unreliable here, the exact stages decide.
    a, b, c = (np.array(p) for p in (a, b, c))
    d = a + s * (b - a) + t * (1.0 - s) * (c - a) + np.array([0.0, 0.0, dz])
    got = faultmesh.orient3d(a[None], b[None], c[None], d[None])[0]
    assert np.sign(got) == exact_orient3d(a, b, c, d)


def test_orient3d_convention_and_shape_errors():
    # d below the counter-clockwise (seen from +z) triangle: positive.
    o = faultmesh.orient3d([[0, 0, 0.0]], [[1, 0, 0.0]], [[0, 1, 0.0]], [[0.2, 0.2, -1.0]])
    assert o[0] > 0
    with pytest.raises(ValueError, match=r"orient3d: c must have shape \(n, 3\)"):
        faultmesh.orient3d(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 2)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="same number of rows"):
        faultmesh.orient3d(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((3, 3)), np.zeros((2, 3)))


any_point3 = st.tuples(any_coord, any_coord, any_coord)


@settings(max_examples=300, deadline=None)
@given(any_point3, any_point3, any_point3, any_point3)
def test_orient3d_sign_is_exact_over_the_whole_range(a, b, c, d):
    got = faultmesh.orient3d(np.array([a]), np.array([b]), np.array([c]), np.array([d]))[0]
    assert np.sign(got) == exact_orient3d(a, b, c, d)


def test_orient3d_underflowing_products_keep_their_sign():
    """Regression: orient3d((s,0,0), (0,s,0), (0,0,0), (0,0,+-s)) with s = 1e-200 -- every
    product of three differences is below the smallest subnormal, so the float stages
    alone returned 0; the exact-integer fallback (as for orient2d/incircle) decides."""
    for s in (1e-120, 1e-200, 5e-324, 2.0 ** -600):
        a, b, c = [[s, 0.0, 0.0]], [[0.0, s, 0.0]], [[0.0, 0.0, 0.0]]
        assert faultmesh.orient3d(a, b, c, [[0.0, 0.0, -s]])[0] > 0  # below the CCW triangle
        assert faultmesh.orient3d(a, b, c, [[0.0, 0.0, s]])[0] < 0
        assert faultmesh.orient3d(a, b, c, [[0.25 * s, 0.25 * s, 0.0]])[0] == 0.0  # coplanar
