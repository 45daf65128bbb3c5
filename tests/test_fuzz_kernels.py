"""Fuzz targets, one per C++ kernel (issue 10): random and hostile input --
shapes, dtypes, NaN/inf, coordinates beyond the limit and tiny ones,
duplicates, degenerate geometry, wrong index ranges. Every call either returns
a result that satisfies the kernel's invariants (checked exactly where the
kernel claims exactness), or raises ValueError / GeometryError whose message
names the function (and, for malformed input, the argument). Never a crash,
never another exception type, never a silent wrong result -- in particular
input outside the documented range is never accepted silently.

CI runs each target with a few hundred derandomized examples (about 1-3 s);
``python bench/fuzz.py -k <target> --examples 20000`` runs them longer.
"""
from __future__ import annotations

import threading
from collections import Counter
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import strategies as st
from hypothesis import given

import faultmesh as fm
from faultmesh.invariants import check_surface
from faultmesh.model import Surface
from helpers import fuzz_settings, loft_sequence, tri_set

LIMIT = 1e60  # faultmesh::kMaxCoordinate (predicates.hpp)
SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, 1e60, -1e60, 1e61, -1e100, 1e155, 1e300, 5e-324, -5e-324,
           2.2250738585072014e-308, 1e-300, np.nan, np.inf, -np.inf, 5.5e5, 7.8e6, 2.0 ** 53, 0.1]
# Scales and offsets: tiny (products underflow), ordinary, UTM-sized, near
# and beyond the limit.
SCALES = [1.0, 1.0, 1.0, 1e-300, 2.0 ** -1000, 1e-20, 1e6, 1e59, 1e61]
OFFSETS = [0.0, 0.0, 5.5e5, 7.8e6, -1e3]


# ------------------------------------------------------------------ helpers
def call(names, args, f, *a, **k):
    """(result, None) or (None, error) for a ValueError whose message names one
    of `names` (the function) and, unless it is a GeometryError, one of `args`
    (the argument). Any other exception fails the test."""
    try:
        return f(*a, **k), None
    except ValueError as e:
        msg = str(e)
        assert any(n in msg for n in names), f"message does not name the function: {msg!r}"
        if not isinstance(e, fm.GeometryError):
            assert any(n in msg for n in args), f"message does not name the argument: {msg!r}"
        return None, e


def in_range(a) -> bool:
    a = np.asarray(a, dtype=np.float64)
    return bool(np.all(np.abs(a) <= LIMIT))  # False for NaN


def exact_orient(a, b, c) -> int:
    ax, ay, bx, by, cx, cy = map(Fraction, (*a, *b, *c))
    d = (ax - cx) * (by - cy) - (ay - cy) * (bx - cx)
    return (d > 0) - (d < 0)


def twice_area(P, T) -> Fraction:
    """Exact sum of twice the signed XY areas of triangles T over points P."""
    s = Fraction(0)
    for a, b, c in T.tolist():
        (ax, ay), (bx, by), (cx, cy) = (map(Fraction, P[i][:2]) for i in (a, b, c))
        s += (bx - ax) * (cy - ay) - (cx - ax) * (by - ay)
    return s


def ring_twice_area(P) -> Fraction:
    s = Fraction(0)
    for k in range(len(P)):
        x0, y0 = map(Fraction, P[k][:2])
        x1, y1 = map(Fraction, P[(k + 1) % len(P)][:2])
        s += x0 * y1 - x1 * y0
    return s


def orient_rows(P, T):
    return fm.orient2d(P[T[:, 0], :2], P[T[:, 1], :2], P[T[:, 2], :2])


@st.composite
def point_sets(draw, min_n=0, max_n=25, cols=2, hostile=True):
    """(n, cols) float64: grids (duplicates, collinear), uniform, near-collinear
    slivers and ulp clusters, at a random scale and offset; sometimes a few
    hostile values (NaN, inf, beyond the limit, subnormal)."""
    n = draw(st.integers(min_n, max_n))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kind = draw(st.sampled_from(["grid", "uniform", "line", "cluster"]))
    if kind == "grid":
        p = rng.integers(-3, 4, (n, cols)).astype(float)
    elif kind == "uniform":
        p = rng.random((n, cols))
    elif kind == "line":
        t = rng.random(n)
        p = np.c_[t, t * 0.75, rng.random((n, cols - 2))]
        p[:, :2] += rng.integers(-2, 3, (n, 2)) * np.spacing(1.0)
    else:
        p = 0.5 + rng.integers(-3, 4, (n, cols)) * np.spacing(0.5)
    p = p * draw(st.sampled_from(SCALES)) + draw(st.sampled_from(OFFSETS))
    if hostile and n and draw(st.integers(0, 3)) == 0:
        for _ in range(draw(st.integers(1, 2))):
            p[draw(st.integers(0, n - 1)), draw(st.integers(0, cols - 1))] = draw(st.sampled_from(SPECIAL))
    return p


PRESENTATIONS = ["as_is"] * 6 + ["list", "float32", "fortran", "strided", "str", "1d", "3d", "cols+1", "none"]


def present(draw, a):
    """How an array reaches the binding; returns (argument, float64 value the
    binding sees, or None if the argument is malformed)."""
    how = draw(st.sampled_from(PRESENTATIONS))
    a = np.asarray(a, dtype=np.float64)
    if how == "as_is":
        return a, a
    if how == "list":
        return a.tolist(), (a if a.size else None)  # [] has shape (0,): no columns
    if how == "float32":
        with np.errstate(over="ignore"):
            b = a.astype(np.float32)
        return b, b.astype(np.float64)
    if how == "fortran":
        return np.asfortranarray(a), a
    if how == "strided":
        big = np.repeat(a, 2, axis=0)
        return big[::2], a
    if how == "str":
        return a.astype(str), a
    if how == "1d":
        return a.ravel(), None
    if how == "3d":
        return a[None], None
    if how == "cols+1":  # well-formed, but maybe not for this argument: the oracle checks the shape
        b = np.c_[a, np.ones(len(a))] if a.ndim == 2 else a
        return b, b
    return None, None


@st.composite
def presented_points(draw, **kw):
    p = draw(point_sets(**kw))
    arg, eff = present(draw, p)
    return arg, eff


def index_presentation(draw, t, n):
    """Index arrays as integers, exact floats, or hostile: 0.5 offsets, NaN,
    negative, beyond n, huge, unsigned, bool, str."""
    t = np.asarray(t, dtype=np.int64)
    how = draw(st.sampled_from(["as_is"] * 6 + ["float", "int32", "list", "half", "nan", "neg", "beyond",
                                                "huge", "uint64", "bool", "str"]))
    if how == "as_is":
        return t, t
    if how == "float":
        b = t.astype(float)  # exact below 2^53
        return b, (t if np.all(b.astype(np.int64) == t) else None)
    if how == "int32":
        b = t.astype(np.int32)  # wraps beyond 2^31: the binding sees the wrapped values
        return b, b.astype(np.int64)
    if how == "list":
        return t.tolist(), (t if t.size else None)  # [] has shape (0,)
    if t.size == 0:
        return t, t
    i = draw(st.integers(0, t.size - 1))
    if how == "half":
        b = t.astype(float)
        b.flat[i] += 0.5
        return b, None
    if how == "nan":
        b = t.astype(float)
        b.flat[i] = np.nan
        return b, None
    if how in ("neg", "beyond", "huge"):
        b = t.copy()
        b.flat[i] = {"neg": -1, "beyond": n + draw(st.integers(0, 3)), "huge": 2**62}[how]
        return b, b  # well-formed: the kernel decides (range errors or a result)
    if how == "uint64":
        b = t.astype(np.uint64)
        b.flat[i] = np.uint64(2**64 - 1)
        return b, None
    if how == "bool":
        return t.astype(bool), None
    return t.astype(str), None


# ------------------------------------------------------------ predicates
@pytest.mark.fuzz
@fuzz_settings(200)
@given(data=st.data(), n=st.integers(0, 4))
def test_fuzz_orient2d_incircle(data, n):
    coord = st.one_of(st.integers(-3, 3).map(float), st.sampled_from(SPECIAL),
                      st.floats(allow_nan=True, allow_infinity=True),
                      st.integers(-3, 3).map(lambda k: k * 2.0 ** -1070))
    pts = [np.array(data.draw(st.lists(st.tuples(coord, coord), min_size=n, max_size=n)), dtype=float).reshape(n, 2)
           for _ in range(4)]
    for fn, k in ((fm.orient2d, 3), (fm.incircle, 4)):
        name = fn.__name__
        args = pts[:k]
        r, err = call([name], ["a row", "b row", "c row", "d row"], fn, *args)
        if err is not None:
            assert not all(in_range(p) for p in args), f"{name} rejected in-range input: {err}"
            assert "row" in str(err)
            continue
        assert all(in_range(p) for p in args), f"{name} accepted out-of-range input"
        assert r.shape == (n,)
        for i in range(n):
            if fn is fm.orient2d:
                want = exact_orient(args[0][i], args[1][i], args[2][i])
            else:
                rows = []
                for p in args[:3]:
                    dx, dy = Fraction(p[i][0]) - Fraction(args[3][i][0]), Fraction(p[i][1]) - Fraction(args[3][i][1])
                    rows.append((dx, dy, dx * dx + dy * dy))
                (a1, a2, a3), (b1, b2, b3), (c1, c2, c3) = rows
                d = a1 * (b2 * c3 - b3 * c2) - a2 * (b1 * c3 - b3 * c1) + a3 * (b1 * c2 - b2 * c1)
                want = (d > 0) - (d < 0)
            assert np.sign(r[i]) == want, (name, [a[i] for a in args])


# ------------------------------------------------------------ delaunay
def convex_hull_twice_area(P) -> Fraction:
    """Exact twice the area of the convex hull (monotone chain, exact orient)."""
    pts = sorted(set(map(tuple, P.tolist())))
    if len(pts) < 3:
        return Fraction(0)

    def half(seq):
        h = []
        for p in seq:
            while len(h) >= 2 and exact_orient(h[-2], h[-1], p) <= 0:
                h.pop()
            h.append(p)
        return h

    lower, upper = half(pts), half(pts[::-1])
    return ring_twice_area(np.array(lower[:-1] + upper[:-1]))


def check_delaunay(P, T):
    n = len(P)
    assert T.dtype == np.int64 and T.ndim == 2 and T.shape[1] == 3
    assert T.size and T.min() >= 0 and T.max() < n
    # A group of equal rows is represented by its smallest index.
    first = {}
    for i, p in enumerate(map(tuple, P.tolist())):
        first.setdefault(p, i)
    assert set(T.ravel().tolist()) == set(first.values()), "every distinct point is a vertex"
    assert np.all(orient_rows(P, T) > 0), "counter-clockwise, non-degenerate"
    assert twice_area(P, T) == convex_hull_twice_area(P), "the triangles tile the convex hull"
    # Empty circumcircles: no vertex strictly inside (ties are cocircular).
    V = np.array(sorted(first.values()))
    tt, vv = np.repeat(np.arange(len(T)), len(V)), np.tile(V, len(T))
    inc = fm.incircle(P[T[tt, 0]], P[T[tt, 1]], P[T[tt, 2]], P[vv])
    assert not np.any(inc > 0), "a vertex inside a circumcircle"


@pytest.mark.fuzz
@fuzz_settings(300)
@given(data=st.data(), info=st.booleans())
def test_fuzz_delaunay(data, info):
    arg, P = data.draw(presented_points())
    r, err = call(["delaunay"], ["xy"], fm.delaunay, arg, return_info=info)
    if err is not None:
        if P is not None and P.ndim == 2 and P.shape[1] == 2 and in_range(P):
            assert isinstance(err, fm.GeometryError), err
            assert convex_hull_twice_area(P) == 0, "rejected a set with a non-degenerate hull"
        return
    assert P is not None and P.ndim == 2 and P.shape[1] == 2 and in_range(P), "accepted malformed input"
    T = r.triangles if info else r
    check_delaunay(P, T)
    if info:
        h = r.halfedges
        inner = h >= 0
        assert np.array_equal(h[h[inner]], np.flatnonzero(inner))
        assert r.n_duplicates == len(P) - len(set(map(tuple, P.tolist())))


# ------------------------------------------------------------ Tin
def check_tin(tin):
    V, T = tin.vertices, tin.triangles
    assert len(np.unique(V[:, :2], axis=0)) == len(V)
    assert tri_set(T) == tri_set(fm.delaunay(V[:, :2]))


def check_queries(tin, q):
    V, T = tin.vertices, tin.triangles
    loc, z = tin.locate(q), tin.interpolate(q)
    assert loc.shape == z.shape == (len(q),)
    assert np.all((loc >= -1) & (loc < len(T)))
    inside = loc >= 0
    if inside.any():
        t = T[loc[inside]]
        p = q[inside, :2]
        for k in range(3):
            assert np.all(fm.orient2d(V[t[:, k], :2], V[t[:, (k + 1) % 3], :2], p) >= 0), "locate: not containing"
        zt = V[t, 2]
        zi = z[inside]
        ok = np.all(np.isfinite(zt), axis=1)
        assert not np.any(np.isnan(zi[ok])), "NaN inside the hull"
        assert np.all((zi[ok] >= zt[ok].min(axis=1)) & (zi[ok] <= zt[ok].max(axis=1))), "z outside its triangle's range"
    assert np.all(np.isnan(z[~inside]))


@pytest.mark.fuzz
@fuzz_settings(150)
@given(data=st.data())
def test_fuzz_tin_insert_locate_interpolate(data):
    """Tin with inserts, locates, interpolations and set_z interleaved."""
    arg, P = data.draw(presented_points(min_n=0, max_n=15, cols=3))
    tin, err = call(["Tin"], ["xyz"], fm.Tin, arg)
    if err is not None:
        if P is not None and P.ndim == 2 and P.shape[1] == 3 and in_range(P[:, :2]):
            assert isinstance(err, fm.GeometryError) and convex_hull_twice_area(P[:, :2]) == 0, err
        return
    assert P is not None and P.ndim == 2 and P.shape[1] == 3 and in_range(P[:, :2])
    check_tin(tin)
    for _ in range(data.draw(st.integers(1, 4))):
        op = data.draw(st.sampled_from(["insert", "query", "query", "set_z"]))
        if op == "insert":
            qa, Q = data.draw(presented_points(max_n=6, cols=3))
            n0 = tin.n_vertices
            r, err = call(["Tin.insert"], ["xyz"], tin.insert, qa)
            if err is not None:
                assert tin.n_vertices == n0, "a failed insert changed the Tin"
                assert Q is None or Q.ndim != 2 or Q.shape[1] != 3 or not in_range(Q[:, :2])
            else:
                assert Q is not None and Q.ndim == 2 and Q.shape[1] == 3 and in_range(Q[:, :2])
                V = tin.vertices
                assert np.array_equal(V[r, :2], Q[:, :2]), "insert maps each row to its XY"
                check_tin(tin)
        elif op == "query":
            V = tin.vertices
            sel = data.draw(st.lists(st.integers(0, len(V) - 1), max_size=4))
            own = V[sel, :2]
            check_queries(tin, np.r_[data.draw(point_sets(max_n=8)), own])
            assert np.array_equal(tin.interpolate(own), V[sel, 2], equal_nan=True), "a vertex's z is exact"
        else:
            n = tin.n_vertices
            idx = np.array(data.draw(st.lists(st.integers(-1, n), max_size=4)), dtype=np.int64)
            zv = np.array(data.draw(st.lists(st.sampled_from([0.0, 1e10, -3.5, np.nan, 1e300]),
                                             min_size=len(idx), max_size=len(idx))))
            before = tin.z
            r, err = call(["Tin.set_z"], ["vertices", "vertex index"], tin.set_z, idx, zv)
            if err is not None:
                assert np.array_equal(before, tin.z, equal_nan=True), "a failed set_z changed z"
                assert np.any((idx < 0) | (idx >= n))
            else:
                assert np.all((idx >= 0) & (idx < n))


# ------------------------------------------------------------ polygons
@st.composite
def ring_sets(draw):
    """Rings: stars (simple), grid walks (self-touching, duplicates,
    collinear runs), rectangles, empty and 1-2 point rings, holes placed
    inside the outer ring or anywhere, at a random scale and offset, with
    occasional hostile values."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n_rings = draw(st.integers(0, 4))
    rings = []
    for r in range(n_rings):
        kind = draw(st.sampled_from(["star", "star", "grid", "rect", "tiny"]))
        k = draw(st.integers(3, 9))
        c, rad = (np.zeros(2), 10.0) if r == 0 else (rng.uniform(-4, 4, 2), rng.uniform(0.5, 3))
        if kind == "star":
            ang = np.sort(rng.uniform(0, 2 * np.pi, k))
            p = np.c_[np.cos(ang), np.sin(ang)] * rng.uniform(0.3, 1.0, (k, 1)) * rad + c
        elif kind == "grid":
            p = rng.integers(-3, 4, (k, 2)).astype(float) * (rad / 3) + np.round(c)
        elif kind == "rect":
            x0, y0 = np.round(np.asarray(c) - rad / 2)
            p = np.array([[x0, y0], [x0 + rad, y0], [x0 + rad, y0 + rad], [x0, y0 + rad]])
            if draw(st.booleans()):
                p = np.r_[p, p[:1]]  # closing point
        else:
            p = rng.integers(-2, 3, (draw(st.integers(0, 2)), 2)).astype(float)
        if draw(st.booleans()):
            p = p[::-1]
        rings.append(np.ascontiguousarray(p))
    scale, offset = draw(st.sampled_from(SCALES)), draw(st.sampled_from(OFFSETS))
    rings = [r * scale + offset for r in rings]
    if rings and draw(st.integers(0, 4)) == 0:
        r = draw(st.integers(0, len(rings) - 1))
        if len(rings[r]):
            rings[r][draw(st.integers(0, len(rings[r]) - 1)), draw(st.integers(0, 1))] = draw(st.sampled_from(SPECIAL))
    return rings


def dedup(r):
    keep = []
    for p in map(tuple, r.tolist()):
        if not keep or p != keep[-1]:
            keep.append(p)
    while len(keep) > 1 and keep[0] == keep[-1]:
        keep.pop()
    return keep


POLY_NAMES = ["triangulate_polygon", "join_holes", "check_polygon"]
POLY_ARGS = ["rings", "ring "]


@pytest.mark.fuzz
@fuzz_settings(300)
@given(rings=ring_sets(), refine=st.booleans(), order=st.sampled_from(["quality", "plain"]),
       bridge=st.sampled_from(["extreme", "eberly"]), strict=st.booleans())
def test_fuzz_triangulate_check_join_polygon(rings, refine, order, bridge, strict):
    pts = np.concatenate(rings) if rings else np.zeros((0, 2))
    good_outer = bool(rings) and len(rings[0]) >= 3
    chk, err = call(POLY_NAMES, POLY_ARGS, fm.check_polygon, rings)
    if err is not None:
        assert not in_range(pts), err
    else:
        assert in_range(pts), "check_polygon accepted out-of-range input"
        valid, msg, ring, vertex = chk
        assert valid == (msg == "")
        if valid:
            assert ring == vertex == -1
        else:
            assert -1 <= ring < len(rings) and -1 <= vertex < len(pts)
    tris, err = call(POLY_NAMES, POLY_ARGS, fm.triangulate_polygon, rings, refine=refine, order=order,
                     bridge=bridge, strict=strict)
    loop, err2 = call(POLY_NAMES, POLY_ARGS, fm.join_holes, rings, bridge=bridge)
    if rings and not good_outer:
        assert err is not None and err2 is not None and "outer ring" in str(err)
        return
    if chk is None:  # out of range: every entry point says so
        assert err is not None and err2 is not None
        return
    valid = chk[0]
    if err is not None:
        assert strict and isinstance(err, fm.GeometryError) and not valid, err
        return
    assert tris.dtype == np.int64 and tris.ndim == 2 and tris.shape[1] == 3
    if len(tris):
        assert tris.min() >= 0 and tris.max() < len(pts)
    assert err2 is None
    jl, bridges, skipped = loop
    assert len(jl) == 0 or (jl.min() >= 0 and jl.max() < len(pts))
    if not rings:
        assert len(tris) == 0
        return
    if valid:
        n = sum(len(dedup(r)) for r in rings)
        h = len(rings) - 1
        assert len(tris) == n + 2 * h - 2, "a valid polygon gives n + 2h - 2 triangles"
        assert np.all(orient_rows(pts, tris) > 0), "valid polygon: every triangle CCW, non-degenerate"
        want = abs(ring_twice_area(np.array(dedup(rings[0])))) - sum(abs(ring_twice_area(np.array(dedup(r))))
                                                                      for r in rings[1:])
        assert twice_area(pts, tris) == want, "the triangles tile the polygon exactly"
        assert len(skipped) == 0 and len(jl) == n + 2 * h
    else:
        # Best effort: no triangle turns clockwise.
        assert np.all(orient_rows(pts, tris) >= 0) if len(tris) else True


# ------------------------------------------------------------ AABB tree
def box_meets_triangle_exact(box, a, b, c) -> bool:
    """Closed triangle (possibly degenerate) meets closed box: exact."""
    xmin, ymin, xmax, ymax = box
    if max(a[0], b[0], c[0]) < xmin or min(a[0], b[0], c[0]) > xmax or \
       max(a[1], b[1], c[1]) < ymin or min(a[1], b[1], c[1]) > ymax:
        return False
    tri = [a, b, c]
    if any(xmin <= p[0] <= xmax and ymin <= p[1] <= ymax for p in tri):
        return True
    corners = [(xmin, ymin), (xmax, ymin), (xmax, ymax), (xmin, ymax)]
    s = exact_orient(a, b, c)
    if s != 0:
        for q in corners:
            o = [exact_orient(tri[i], tri[(i + 1) % 3], q) * s for i in range(3)]
            if min(o) >= 0:
                return True

    def seg_meet(p, q, r, t):
        o1, o2 = exact_orient(p, q, r), exact_orient(p, q, t)
        o3, o4 = exact_orient(r, t, p), exact_orient(r, t, q)
        if o1 * o2 < 0 and o3 * o4 < 0:
            return True

        def on(u, v, w, o):
            return o == 0 and min(u[0], v[0]) <= w[0] <= max(u[0], v[0]) and min(u[1], v[1]) <= w[1] <= max(u[1], v[1])
        return on(p, q, r, o1) or on(p, q, t, o2) or on(r, t, p, o3) or on(r, t, q, o4)

    return any(seg_meet(tri[i], tri[(i + 1) % 3], corners[j], corners[(j + 1) % 4])
               for i in range(3) for j in range(4))


@pytest.mark.fuzz
@fuzz_settings(150)
@given(data=st.data(), kind=st.sampled_from(["triangles", "segments", "boxes"]))
def test_fuzz_aabb_tree(data, kind):
    P = data.draw(point_sets(min_n=1, max_n=12))
    n = len(P)
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    per = 3 if kind == "triangles" else 2
    E = rng.integers(0, n, (data.draw(st.integers(0, 10)), per))
    if kind == "boxes":
        lo, hi = np.minimum(P[E[:, 0]], P[E[:, 1]]), np.maximum(P[E[:, 0]], P[E[:, 1]])
        B = np.c_[lo, hi]
        barg, Beff = present(data.draw, B)
        tree, err = call(["AabbTree"], ["boxes", "box "], fm.AabbTree.from_boxes, barg)
        if err is not None:
            assert Beff is None or Beff.ndim != 2 or Beff.shape[1] != 4 or np.isnan(Beff).any() or \
                np.any(Beff[:, :2] > Beff[:, 2:])
            return
        assert Beff is not None and not np.isnan(Beff).any()
        boxes = Beff
    else:
        parg, Peff = present(data.draw, P)
        earg, Eeff = index_presentation(data.draw, E, n)
        f = fm.AabbTree if kind == "triangles" else fm.AabbTree.from_segments
        tree, err = call(["AabbTree"], ["vertices", "triangles", "segments"], f, parg, earg)
        ok_input = Peff is not None and Peff.ndim == 2 and Peff.shape[1] in (2, 3) and Eeff is not None
        if err is not None:
            assert not (ok_input and np.all((Eeff >= 0) & (Eeff < len(Peff))) and in_range(Peff[np.unique(Eeff), :2])), err
            return
        assert ok_input and np.all((Eeff >= 0) & (Eeff < len(Peff))) and in_range(Peff[np.unique(Eeff), :2])
        P, E = Peff, Eeff
        boxes = np.c_[P[E, 0].min(1), P[E, 1].min(1), P[E, 0].max(1), P[E, 1].max(1)] if len(E) else np.zeros((0, 4))
    assert tree.size == len(tree) == len(boxes) and tree.kind == kind
    Q = data.draw(point_sets(min_n=0, max_n=6, cols=4))
    Q = np.c_[np.minimum(Q[:, :2], Q[:, 2:]), np.maximum(Q[:, :2], Q[:, 2:])] if data.draw(st.booleans()) else Q
    exact = data.draw(st.booleans()) and kind != "boxes"
    r, err = call(["AabbTree"], ["boxes"], tree.query, Q, exact=exact)
    if err is not None:
        assert exact and not in_range(Q)
        return
    off, idx = r
    assert len(off) == len(Q) + 1 and off[0] == 0 and np.all(np.diff(off) >= 0) and off[-1] == len(idx)
    for j in range(len(Q)):
        got = list(idx[off[j]:off[j + 1]])
        assert got == sorted(got)
        q = Q[j]
        # Closed boxes; an inverted or NaN query box is empty and meets nothing.
        want = [i for i in range(len(boxes)) if q[0] <= q[2] and q[1] <= q[3] and boxes[i, 0] <= q[2]
                and boxes[i, 2] >= q[0] and boxes[i, 1] <= q[3] and boxes[i, 3] >= q[1]]
        if exact:
            want = [i for i in want if box_meets_triangle_exact(q, *(P[E[i, k % per], :2] for k in range(3)))]
        assert got == want, (j, q)


# ------------------------------------------------------------ boundary
@st.composite
def triangle_sets(draw):
    """Triangles of a Delaunay mesh (a random subset: holes, pinches, islands),
    with junk triangles (repeated vertices, inconsistent or non-manifold
    edges) and renumbered vertices (gaps, huge numbers)."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n = draw(st.integers(3, 30))
    T = np.asarray(fm.delaunay(rng.random((n, 2))))
    T = T[rng.random(len(T)) < draw(st.sampled_from([1.0, 0.8, 0.5]))]
    extra = draw(st.integers(0, 3))
    if extra:
        J = rng.integers(0, n, (extra, 3))
        T = np.r_[T, J if draw(st.booleans()) else T[rng.integers(0, max(len(T), 1), extra) % max(len(T), 1)][:, ::-1]
                  if len(T) else J]
    relabel = draw(st.sampled_from(["none", "none", "shift", "huge"]))
    if relabel == "shift":
        T = T * 3 + 7
    elif relabel == "huge":
        T = np.where(T > n // 2, T + 2**40, T)
    return T.astype(np.int64)


def directed_edges(T):
    return [(int(t[k]), int(t[(k + 1) % 3])) for t in T for k in range(3)]


@pytest.mark.fuzz
@fuzz_settings(250)
@given(data=st.data(), nv=st.sampled_from([None, None, "exact", "small", 3.5, "huge"]))
def test_fuzz_boundary(data, nv):
    T = data.draw(triangle_sets())
    targ, Teff = index_presentation(data.draw, T, T.max() + 1 if T.size else 0)
    n_vertices = {None: None, "exact": (int(T.max()) + 1 if T.size else 1), "small": 2, 3.5: 3.5,
                  "huge": 10**15}[nv]
    names, args = ["boundary_"], ["triangles", "n_vertices"]
    rep, err = call(names, args, fm.boundary_contours, targ, n_vertices=n_vertices)
    loops, err2 = call(names, args, fm.boundary_loops, targ, strict=False, n_vertices=n_vertices)
    edges, err3 = call(names, args, fm.boundary_edges, targ, n_vertices=n_vertices)
    if err is not None:
        assert err2 is not None and err3 is not None
        bad = Teff is None or nv == 3.5 or np.any(Teff < 0) or \
            any(len(set(t)) < 3 for t in Teff.tolist()) or \
            (isinstance(n_vertices, int) and Teff.size and Teff.max() >= n_vertices)
        assert bad, err
        return
    assert Teff is not None and np.all(Teff >= 0) and nv != 3.5
    assert not (isinstance(n_vertices, int) and Teff.size and Teff.max() >= n_vertices)
    T = Teff
    # Edge frequency by brute force.
    und = Counter(tuple(sorted(e)) for e in directed_edges(T))
    bnd = sorted(e for e in directed_edges(T) if und[tuple(sorted(e))] == 1)
    assert sorted(map(tuple, edges.tolist())) == bnd
    nm = sorted(tuple(k) for k, c in und.items() if c >= 3)
    assert sorted(map(tuple, rep.nonmanifold_edges.tolist())) == nm
    # Every boundary edge lies on exactly one loop or chain.
    seq = [e for l in rep.loops for e in zip(l.tolist(), np.roll(l, -1).tolist())]
    seq += [e for c in rep.open_chains for e in zip(c[:-1].tolist(), c[1:].tolist())]
    assert sorted(seq) == bnd
    assert [list(l) for l in loops] == [list(l) for l in rep.loops]
    strict, err4 = call(names, args, fm.boundary_loops, T, n_vertices=n_vertices)
    assert (err4 is None) == rep.clean and (err4 is None or isinstance(err4, fm.GeometryError))
    # sort_segments on the boundary edges gives the same edge cover.
    srep = fm.sort_segments(np.array(bnd, dtype=np.int64).reshape(-1, 2))
    sseq = [e for l in srep.loops for e in zip(l.tolist(), np.roll(l, -1).tolist())]
    sseq += [e for c in srep.open_chains for e in zip(c[:-1].tolist(), c[1:].tolist())]
    assert sorted(sseq) == bnd
    # ... and on arbitrary segments (all edges, duplicates, hostile arrays).
    S = np.array(directed_edges(T), dtype=np.int64).reshape(-1, 2)[data.draw(st.sampled_from([slice(None), slice(0, 5)]))]
    sarg, Seff = index_presentation(data.draw, S, T.max() + 1 if T.size else 0)
    srep, err = call(["sort_segments"], ["segments", "n_vertices"], fm.sort_segments, sarg)
    if err is not None:
        assert Seff is None or np.any(Seff < 0), err
    else:
        assert Seff is not None and np.all(Seff >= 0)
        sseq = [e for l in srep.loops for e in zip(l.tolist(), np.roll(l, -1).tolist())]
        sseq += [e for c in srep.open_chains for e in zip(c[:-1].tolist(), c[1:].tolist())]
        assert sorted(sseq) == sorted(map(tuple, Seff.tolist())), "every segment once"


# ------------------------------------------------------------ overlap
@pytest.mark.fuzz
@fuzz_settings(120)
@given(data=st.data(), grow=st.booleans(), use_tree=st.booleans())
def test_fuzz_overlapping_triangles(data, grow, use_tree):
    P = data.draw(point_sets(min_n=3, max_n=25, hostile=False))
    T, err = call(["delaunay"], ["xy"], fm.delaunay, P)
    if err is not None:
        return
    rings = data.draw(ring_sets())
    rings = [r / 10.0 * (np.abs(P).max() or 1.0) + P.mean(0) for r in rings] if data.draw(st.booleans()) else rings
    targ, Teff = index_presentation(data.draw, T, len(P))
    tree = None
    if use_tree and Teff is not None and np.all((Teff >= 0) & (Teff < len(P))):
        tree = fm.AabbTree(P, Teff)
    names, args = ["overlapping_triangles", "AabbTree"], ["vertices", "triangles", "ring", "tree"]
    r, err = call(names, args, fm.overlapping_triangles, P, targ, rings, grow_to_disk=grow,
                  allow_mesh_boundary=data.draw(st.booleans()), tree=tree)
    pts = np.concatenate(rings) if rings else np.zeros((0, 2))
    if err is not None:
        if not isinstance(err, fm.GeometryError):
            assert Teff is None or np.any((Teff < 0) | (Teff >= len(P))) or not in_range(pts), err
        else:
            assert grow, err
        return
    assert Teff is not None and in_range(pts) and np.all((Teff >= 0) & (Teff < len(P)))
    T = Teff
    assert np.all(np.diff(r) > 0) and (len(r) == 0 or (r[0] >= 0 and r[-1] < len(T)))
    if rings:
        ref = np.flatnonzero(fm.triangle_overlaps_region(P[T[:, 0]], P[T[:, 1]], P[T[:, 2]], rings))
    else:
        ref = np.zeros(0, np.int64)
    if not grow:
        assert np.array_equal(r, ref), "stage 1 + 2 differ from the brute-force predicate"
    else:
        assert set(ref.tolist()) <= set(r.tolist()), "the grown set lost an overlapping triangle"
        if len(r):
            assert len(fm.boundary_loops(T[r])) == 1, "the grown set is not a disk"


# ------------------------------------------------------------ loft
def loft_edges_used_once(k, l, t, closed):
    uses = Counter()
    for a, b, c in t.tolist():
        for u, v in ((a, b), (b, c), (c, a)):
            uses[(min(u, v), max(u, v))] += 1
    want = [(i, i + 1) for i in range(k - 1)] + [(k + j, k + j + 1) for j in range(l - 1)]
    if closed:
        want += [(0, k - 1)] if k >= 3 else []
        want += [(k, k + l - 1)] if l >= 3 else []
    return all(uses[e] == 1 for e in want)


@pytest.mark.fuzz
@fuzz_settings(200)
@given(data=st.data(), method=st.sampled_from(["min_area", "shortest_diagonal"]), closed=st.booleans(),
       cols=st.sampled_from([2, 3]))
def test_fuzz_loft(data, method, closed, cols):
    A = data.draw(point_sets(min_n=0, max_n=8, cols=cols))
    B = data.draw(point_sets(min_n=0, max_n=8, cols=cols)) + np.array([0.0, 1.0] + [0.0] * (cols - 2))
    aarg, Aeff = present(data.draw, A)
    r, err = call(["loft"], ["a", "b", "column", "polyline", "contour"], fm.loft, aarg, B, method=method,
                  closed=closed)
    ok_shape = Aeff is not None and Aeff.ndim == 2 and Aeff.shape[1] == cols
    if err is not None:
        assert not ok_shape or not in_range(Aeff) or not in_range(B) or len(Aeff) == 0 or len(B) == 0 or \
            (closed and (len(Aeff) == 2 or len(B) == 2)), err
        return
    assert ok_shape and in_range(Aeff) and in_range(B) and len(Aeff) and len(B)
    k, l = len(Aeff), len(B)
    assert r.dtype == np.int64 and (len(r) == 0 or (r.min() >= 0 and r.max() < k + l))
    if closed:
        assert len(r) == (k if k >= 3 else 0) + (l if l >= 3 else 0)
    else:
        assert len(r) == k + l - 2
    assert loft_edges_used_once(k, l, r, closed)
    if method == "min_area" and not closed:
        other = fm.loft(Aeff, B, method="shortest_diagonal")
        a1, a2 = fm.loft_area(Aeff, B, r), fm.loft_area(Aeff, B, other)
        assert a1 <= a2 * (1 + 1e-12) + 1e-300, "min_area is not minimal"


# ------------------------------------------------------------ stitch
def layer_tin(rng, n_side, jitter, scale, offset):
    """A TIN over the square [0, 100]^2 * scale + offset (grid border exact)."""
    g = np.linspace(0.0, 100.0, n_side)
    X, Y = np.meshgrid(g, g)
    pts = np.r_[np.c_[X.ravel(), Y.ravel()], rng.uniform(1.0, 99.0, (jitter, 2))] * scale + offset
    t = fm.Tin(np.c_[pts, 0.01 * pts[:, 0] - 0.02 * pts[:, 1]])
    return t.vertices, t.triangles


@st.composite
def patches(draw, scale, offset):
    """A fault patch: a lofted strip between two traces (random position,
    direction and width, sometimes crossing the study-area boundary or
    folding back like a reverse fault), with optional tips; or junk."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kind = draw(st.sampled_from(["strip", "strip", "strip", "junk"]))
    if kind == "junk":
        V = rng.uniform(-10, 110, (draw(st.integers(0, 6)), 3))
        T = rng.integers(0, max(len(V), 1), (draw(st.integers(0, 4)), 3))
    else:
        c = rng.uniform(5, 95, 2)
        ang = rng.uniform(0, np.pi)
        d, nrm = np.array([np.cos(ang), np.sin(ang)]), np.array([-np.sin(ang), np.cos(ang)])
        length, width = rng.uniform(2, 40), rng.uniform(0.2, 6) * draw(st.sampled_from([1, 1, -1]))
        k = draw(st.integers(2, 5))
        s = np.linspace(-0.5, 0.5, k)[:, None] * length
        a = np.c_[c + s * d, np.zeros(k)]
        b = np.c_[c + s * d + width * nrm, np.full(k, -1.0)]
        seq = [a, b]
        if draw(st.booleans()):
            seq = [np.r_[c - 0.5 * length * d - 3 * d, 0.0][None, :]] + seq  # a tip
        V, T = loft_sequence(seq)
    V = V.copy()
    V[:, :2] = V[:, :2] * scale + offset
    if len(V) and draw(st.integers(0, 5)) == 0:
        V[draw(st.integers(0, len(V) - 1)), draw(st.integers(0, 2))] = draw(st.sampled_from(SPECIAL))
    return V, T.astype(np.int64)


@pytest.mark.fuzz
@fuzz_settings(60)
@given(data=st.data(), scale=st.sampled_from([1.0, 1.0, 1e-3, 1e3]), offset=st.sampled_from([0.0, 5.5e5, 7.8e6]),
       n_patches=st.integers(1, 3))
def test_fuzz_stitcher(data, scale, offset, n_patches):
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    V, T = layer_tin(rng, data.draw(st.integers(4, 9)), data.draw(st.integers(0, 30)), scale, offset)
    square = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]]) * scale + offset
    st_ = fm.Stitcher(V, T, square, name="L")
    for k in range(n_patches):
        PV, PT = data.draw(patches(scale, offset))
        parg, PVeff = present(data.draw, PV)
        targ, PTeff = index_presentation(data.draw, PT, len(PV))
        before = st_.mesh()
        r, err = call(["stitch"], ["patch_vertices", "patch_triangles", "patch"], st_.stitch, parg, targ,
                      name=f"F{k}")
        after = st_.mesh()
        if err is not None:
            assert all(np.array_equal(getattr(before, key), getattr(after, key))
                       for key in ("vertices", "triangles", "kinds", "owners", "vertex_map", "triangle_map")), \
                "a failed stitch changed the layer"
            if not isinstance(err, fm.GeometryError):
                assert PVeff is None or PTeff is None or PVeff.ndim != 2 or PVeff.shape[1] != 3 or \
                    not in_range(PVeff) or len(PTeff) == 0 or \
                    np.any((PTeff < 0) | (PTeff >= len(PVeff))) or any(len(set(t)) < 3 for t in PTeff.tolist()), err
            continue
        assert PVeff is not None and PTeff is not None and in_range(PVeff)
        assert st_.patch_names[-1] == f"F{k}"
        # check_surface's area sum is a plain shoelace: at a UTM offset and a
        # tiny area it loses more than its tolerance to cancellation. The
        # translation back to the local origin is exact (Sterbenz), so the
        # invariants are checked on the same geometry.
        local = after.vertices - [offset, offset, 0.0]
        check_surface(Surface("L", local, after.triangles), square - offset)


# ------------------------------------------------------------ build_layer_tins
def _mesh_set(tin) -> set:
    """A LayerTin's triangles as corner coordinates from the smallest corner
    (orientation kept): comparable whatever the vertex numbering."""
    V, T = tin.mesh()
    out = set()
    for tri in V[T].tolist():
        c = [tuple(p) for p in tri]
        k = c.index(min(c))
        out.add(tuple(c[k:] + c[:k]))
    return out


@pytest.mark.fuzz
@fuzz_settings(60)
@given(data=st.data(), offset=st.sampled_from([0.0, 5.5e5, 7.8e6]), n_layers=st.integers(1, 4),
       share=st.sampled_from([1.0, 0.97, 0.8, 0.5, 0.0]), rounding=st.sampled_from([None, 0.01, 1.0]))
def test_fuzz_build_layer_tins(data, offset, n_layers, share, rounding):
    """build_layer_tins gives every layer the TIN LayerTin builds alone (same
    triangles, corner coordinates and elevations), or the same error, for
    stacks that share all, most, some or none of their XY points, with
    repeated points, points on the boundary, outside it and on a grid."""
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    side = 100.0
    area = np.array([[0, 0], [side, 0], [side, 40], [40, 40], [40, side], [0, side]], float) + offset
    n = data.draw(st.integers(0, 60))
    if data.draw(st.booleans()):  # a grid: cocircular everywhere
        g = np.linspace(0.0, side, max(2, int(n ** 0.5)))
        base = np.array(np.meshgrid(g, g)).reshape(2, -1).T
    else:
        base = rng.uniform(-5.0, side + 5.0, (n, 2))
    if rounding:
        base = np.round(base / rounding) * rounding
    layers = []
    for k in range(n_layers):
        keep = rng.uniform(size=len(base)) < share
        own = rng.uniform(0.0, side, (int(rng.integers(0, 10)), 2))
        xy = np.vstack([base[keep], own])
        if len(xy) and data.draw(st.booleans()):  # a repeated point, another z
            xy = np.vstack([xy, xy[:1]])
        xy = xy[rng.permutation(len(xy))] + offset
        z = -10.0 * k + 0.05 * (xy[:, 0] - offset) + rng.uniform(-1, 1, len(xy))
        layers.append((f"L{k}", np.c_[xy, z]))
    try:
        stacked = fm.build_layer_tins(layers, area)
    except (fm.GeometryError, ValueError) as e:
        # The same error as the first layer that cannot be built alone.
        for name, pts in layers:
            try:
                fm.LayerTin(name, pts, area)
            except type(e) as alone:
                assert str(alone) == str(e)
                return
        raise AssertionError(f"build_layer_tins raised but every layer builds alone: {e}")
    assert [t.name for t in stacked] == [name for name, _ in layers]
    for t, (name, pts) in zip(stacked, layers):
        alone = fm.LayerTin(name, pts, area)
        assert (t.n_vertices, t.n_data, t.n_outside, t.n_boundary_data) == \
            (alone.n_vertices, alone.n_data, alone.n_outside, alone.n_boundary_data)
        assert _mesh_set(t) == _mesh_set(alone), name


def test_build_layer_tins_rejects_malformed_layers():
    area = np.array([[0, 0], [10, 0], [10, 10], [0, 10.0]])
    pts = np.array([[1, 1, 0], [9, 1, 0], [5, 8, 0.0]])
    with pytest.raises(ValueError, match=r"build_layer_tins: layers\[1\] must be a pair"):
        fm.build_layer_tins([("a", pts), ("b",)], area)
    with pytest.raises(ValueError, match=r"build_layer_tins: data of layer 'b' row 2 has a coordinate beyond"):
        fm.build_layer_tins([("a", pts), ("b", np.r_[pts[:2], [[1e70, 0, 0]]])], area)


# ------------------------------------------------------------ cut_layer
@pytest.mark.fuzz
@fuzz_settings(80)
@given(data=st.data(), refine=st.booleans(), displacement=st.sampled_from([0.0, -3.0, 2.5]),
       taper=st.sampled_from([0.0, 10.0]))
def test_fuzz_cut_layer(data, refine, displacement, taper):
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    n = data.draw(st.integers(3, 9))
    g = np.linspace(0.0, 100.0, n)
    X, Y = np.meshgrid(g, g)
    P = np.c_[X.ravel(), Y.ravel()] + np.r_[rng.uniform(-2, 2, (n * n, 2))] * \
        ((X.ravel() > 0) & (X.ravel() < 100) & (Y.ravel() > 0) & (Y.ravel() < 100))[:, None]
    LV = np.c_[P, -50.0 + 0.05 * P[:, 0]]
    LT = np.asarray(fm.delaunay(P))
    # A dipping fault plane x = x0 - z / tan(dip), gridded over (y, z).
    x0, dip = rng.uniform(10, 90), rng.uniform(30, 85)
    y0, y1 = sorted(rng.uniform(-20, 120, 2))
    ny, nd = data.draw(st.integers(1, 4)), data.draw(st.integers(1, 3))
    Yf, Zf = np.meshgrid(np.linspace(y0, y1 + 1, ny + 1), np.linspace(0.0, -100.0, nd + 1), indexing="ij")
    FV = np.c_[(x0 - Zf / np.tan(np.radians(dip))).ravel(), Yf.ravel(), Zf.ravel()]
    FT = []
    for j in range(ny):
        for k in range(nd):
            a = j * (nd + 1) + k
            FT += [[a, a + nd + 1, a + 1], [a + 1, a + nd + 1, a + nd + 2]]
    FT = np.array(FT, dtype=np.int64)
    if data.draw(st.integers(0, 4)) == 0:
        FV[data.draw(st.integers(0, len(FV) - 1)), data.draw(st.integers(0, 2))] = data.draw(st.sampled_from(SPECIAL))
    farg, FVeff = present(data.draw, FV)
    targ, LTeff = index_presentation(data.draw, LT, len(LV))
    r, err = call(["cut_layer"], ["layer_vertices", "layer_triangles", "fault_vertices", "fault_triangles"],
                  fm.cut_layer, LV, targ, farg, FT, displacement=displacement, taper_length=taper, refine=refine)
    if err is not None:
        if not isinstance(err, fm.GeometryError):
            assert FVeff is None or LTeff is None or FVeff.ndim != 2 or FVeff.shape[1] != 3 or \
                not in_range(FVeff) or np.any((LTeff < 0) | (LTeff >= len(LV))), err
        return
    assert FVeff is not None and LTeff is not None and FVeff.shape[1] == 3 and in_range(FVeff)
    V, T = r["vertices"], r["triangles"]
    assert np.array_equal(V[:len(LV)], LV)
    assert T.dtype == np.int64 and T.shape[1] == 3 and T.min() >= 0 and T.max() < len(V)
    assert len(T) == len(LTeff) - len(r["removed"]) + len(r["created"])
    if np.all(orient_rows(LV, LTeff) > 0):  # a valid CCW layer: the cut keeps it so, and its area
        assert np.all(orient_rows(V, T) > 0), "a cut triangle is clockwise or degenerate"
        a0 = np.sum(orient_rows(LV, LTeff))
        assert abs(np.sum(orient_rows(V, T)) - a0) <= 1e-9 * a0
    f, h = r["footwall_line"], r["hanging_line"]
    assert np.array_equal(V[f, :2], V[h, :2])


# ------------------------------------------------------------ not fuzz: API-wide
def test_every_property_of_every_bound_class():
    """Every property of every class the C++ module binds can be read (issue
    10: Stitcher.patch_names always raised TypeError). A new class without an
    instance here fails the test."""
    import enum

    import faultmesh._core as core
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1]], float)
    t = np.array([[0, 1, 2], [1, 3, 2]])
    st_ = fm.Stitcher(v, t)
    LV, LT = layer_tin(np.random.default_rng(0), 6, 10, 1.0, 0.0)
    layer = fm.Stitcher(LV, LT, name="L")
    report = layer.stitch(np.array([[40, 40, 0], [60, 40, 0], [60, 60, 0], [40, 60, 0.0]]),
                          np.array([[0, 1, 2], [0, 2, 3]]), name="F")
    square = np.array([[0, 0], [100, 0], [100, 100], [0, 100.0]])
    instances = {
        "AabbTree": fm.AabbTree(v, t),
        "FaultSide": fm.FaultSide(v, t),
        "BoundaryContours": fm.boundary_contours(t),
        "DelaunayInfo": fm.delaunay(v[:, :2], return_info=True),
        "LayerTin": fm.LayerTin("L", np.c_[LV[:, :2], LV[:, 2]], square),
        "StitchGap": report.gaps[0],
        "StitchReport": report,
        "StitchedMesh": layer.mesh(),
        "Stitcher": st_,
        "StudyArea": fm.StudyArea(square),
        "Tin": fm.Tin(v),
        "TouchingRegion": fm.TouchingRegion([square]),
    }
    # Enums (TriangleKind) are Python's own enum classes, with no bound properties.
    classes = {k for k, c in vars(core).items()
               if isinstance(c, type) and not issubclass(c, (BaseException, enum.Enum))}
    assert classes == set(instances), "a bound class has no instance in this test"
    for name, obj in instances.items():
        props = [k for k in dir(type(obj)) if isinstance(getattr(type(obj), k), property)]
        assert props, name
        for k in props:
            getattr(obj, k)  # raises on a missing caster
        repr(obj)


def test_kernels_never_read_arrays_another_thread_changes():
    """The kernels run with the GIL released on private copies of their
    inputs: another Python thread rewriting the caller's arrays during the
    calls (indices flipping between valid and out of range, coordinates
    between finite and NaN) can neither crash a kernel nor let it read an
    index it did not validate. (numpy may release the GIL inside a large
    assignment, so the copy a call takes may mix the two contents: the
    result must be well-formed for some such mix, or a ValueError.)"""
    rng = np.random.default_rng(0)
    P = rng.random((3000, 2))
    T = np.asarray(fm.delaunay(P))
    good_T, bad_T = T.copy(), T.copy()
    bad_T[::7, 1] = len(P) + 500 + np.arange(len(T[::7])) % 100  # beyond the vertices, below 3m
    good_P, bad_P = P.copy(), P.copy()
    bad_P[::5] = np.nan
    values = set(good_T.ravel().tolist()) | set(bad_T.ravel().tolist())
    stop = threading.Event()

    # A (n, 3) view whose x, y are P's columns is not possible without a copy,
    # so sample_surface reads P through a 3-column array that flip() rewrites too.
    V3 = np.c_[P, np.zeros(len(P))]
    good_V3, bad_V3 = V3.copy(), V3.copy()
    bad_V3[::5] = np.nan
    Q = np.random.default_rng(1).random((200, 2))

    def flip():
        while not stop.is_set():
            T[:] = bad_T
            P[:] = bad_P
            V3[:] = bad_V3
            T[:] = good_T
            P[:] = good_P
            V3[:] = good_V3

    th = threading.Thread(target=flip)
    th.start()
    try:
        for _ in range(40):
            r, err = call(["boundary_"], ["triangles"], fm.boundary_contours, T)
            assert err is None  # every mix is well-formed
            assert all(set(x.tolist()) <= values for x in r.loops + r.open_chains)
            r, err = call(["AabbTree"], ["vertices", "triangles"], fm.AabbTree, P, T)
            if err is None:
                off, idx = r.query(np.array([[0.2, 0.2, 0.4, 0.4]]), exact=True)
                assert len(idx) and idx.max() < len(T)
            r, err = call(["delaunay"], ["xy"], fm.delaunay, P)
            if err is None:
                assert r.min() >= 0 and r.max() < len(P)
            # main's sample_surface (merged later) gets the same private copies.
            r, err = call(["sample_surface"], ["vertices", "triangles"], fm.sample_surface, V3, T, Q)
            if err is None:
                lo, hi, hits = r
                assert np.all(hits[~np.isnan(lo)] > 0) and np.all(np.nan_to_num(lo) <= np.nan_to_num(hi))
            r, err = call(["nearest_sheet"], ["vertices", "triangles"], fm.nearest_sheet, V3, T,
                          np.c_[Q, np.zeros(len(Q))])
            if err is None:
                z, tri = r
                assert np.all(np.isnan(z) == (tri < 0)) and tri.max() < len(T)
            # FaultSide keeps its copies for its life; nearest_segment copies per call.
            r, err = call(["FaultSide", "fault_side"], ["vertices", "triangles"], fm.FaultSide, V3, T)
            if err is None:
                side, _, tri, _ = r.sides(np.c_[Q, np.ones(len(Q))])
                assert set(side.tolist()) <= {1, -1, 0, fm.BEYOND_FAULT} and tri.max() < len(T)
            r, err = call(["nearest_segment"], ["points", "starts", "ends"], fm.nearest_segment,
                          P, Q[:-1], Q[1:])
            if err is None:
                idx, dist = r
                assert idx.min() >= 0 and idx.max() < len(Q) - 1 and np.all(dist >= 0)
    finally:
        stop.set()
        th.join()


def test_kernels_from_main_share_the_input_contract():
    """The kernels merged from main (orient3d, StudyArea, LayerTin, sample_surface,
    sample_surface_grid, fault_side) follow the same input contract: coordinates beyond
    1e60 or NaN are ValueErrors naming function, argument and row; index arrays hold
    non-negative integers; the caller's arrays are copied (changing them later changes
    nothing)."""
    square = np.array([[0, 0], [100, 0], [100, 100], [0, 100.0]])
    far = square.copy()
    far[2, 1] = 1e61
    with pytest.raises(ValueError, match=r"StudyArea: ring row 2 has a coordinate beyond \+-1e\+60 \(y = 1e\+61\)"):
        fm.StudyArea(far)
    area = fm.StudyArea(square)
    with pytest.raises(ValueError, match=r"StudyArea.contains: points row 1 has a non-finite coordinate"):
        area.contains(np.array([[1.0, 1.0], [np.nan, 0.0]]))
    with pytest.raises(ValueError, match=r"StudyArea.place: side row 0 has the value 0.5, not an integer"):
        area.place(np.array([0.5]), np.array([1.0]))
    with pytest.raises(ValueError, match=r"StudyArea.place: s row 0 is not finite"):
        area.place(np.array([0]), np.array([np.inf]))
    assert np.array_equal(area.place(np.array([1.0]), np.array([50.0])), [[100.0, 50.0]])  # exact integers

    LV, LT = layer_tin(np.random.default_rng(0), 6, 10, 1.0, 0.0)
    bad = LV.copy()
    bad[3, 0] = -1e70
    with pytest.raises(ValueError, match=r"LayerTin: data row 3 has a coordinate beyond \+-1e\+60 \(x = -1e\+70\)"):
        fm.LayerTin("L", bad, square)
    with pytest.raises(ValueError, match=r"LayerTin: boundary row 2 has a coordinate beyond"):
        fm.LayerTin("L", LV, far)
    layer = fm.LayerTin("L", LV, square)
    with pytest.raises(ValueError, match=r"LayerTin.insert: xyz row 0 has a coordinate beyond"):
        layer.insert(np.array([[1e61, 5.0, 0.0]]))

    with pytest.raises(ValueError, match=r"sample_surface: vertices row 3 has a coordinate beyond"):
        fm.sample_surface(bad, LT, np.array([[50.0, 50.0]]))
    with pytest.raises(ValueError, match=r"sample_surface: triangles row 0 has the value 0.5, not an integer"):
        fm.sample_surface(LV, np.where(np.arange(LT.size).reshape(LT.shape) == 0, 0.5, LT), np.array([[1.0, 1.0]]))
    with pytest.raises(ValueError, match=r"nearest_sheet: points row 1 has a non-finite coordinate"):
        fm.nearest_sheet(LV, LT, np.array([[50.0, 50.0, 0.0], [np.nan, 1.0, 0.0]]))
    with pytest.raises(ValueError, match=r"nearest_sheet: points row 0 has a coordinate beyond"):
        fm.nearest_sheet(LV, LT, np.array([[1e61, 50.0, 0.0]]))
    with pytest.raises(ValueError, match=r"nearest_sheet: triangles row 1 has vertex index .* out of range"):
        fm.nearest_sheet(LV, np.r_[LT[:1], [[0, 1, len(LV)]]], np.array([[50.0, 50.0, 0.0]]))
    z, tri = fm.nearest_sheet(LV, LT, np.array([[50.0, 50.0, 0.0], [500.0, 50.0, 0.0]]))
    assert tri[0] >= 0 and np.isfinite(z[0]) and tri[1] == -1 and np.isnan(z[1])
    with pytest.raises(ValueError, match=r"sample_surface_grid: triangles row 1 has vertex index .* out of range"):
        fm.sample_surface_grid(LV, np.r_[LT[:1], [[0, 1, len(LV)]]], (0.0, 0.0), (1.0, 1.0), (2, 2))
    with pytest.raises(ValueError, match=r"sample_surface_grid: the grid's last point .* beyond \+-1e\+60"):
        fm.sample_surface_grid(LV, LT, (0.0, 0.0), (1e59, 1.0), (2, 20))
    # A shape whose node count wraps around size_t left the output arrays too
    # short for the loops (heap overflow); past 2^32 nodes it is an error.
    for shape in ((2**33, 2**31), (2**32 + 1, 1), (1, 2**40)):
        with pytest.raises(ValueError, match=r"sample_surface_grid: shape \(ny, nx\) = .* more than 2\^32 nodes"):
            fm.sample_surface_grid(LV, LT, (0.0, 0.0), (1e-30, 1e-30), shape)
    # Beyond the limit a query is outside every triangle (as for Tin.interpolate).
    lo, hi, hits = fm.sample_surface(LV, LT, np.array([[50.0, 50.0], [1e61, 50.0]]))
    assert hits[0] >= 1 and hits[1] == 0 and np.isnan(lo[1])
    V, T, q = LV.copy(), LT.copy(), np.array([[50.0, 50.0]])
    ref = fm.sample_surface(V, T, q)
    tin = fm.LayerTin("L", V, square)
    z0 = tin.interpolate(q)
    V[:] = np.nan
    assert np.array_equal(tin.interpolate(q), z0)  # the LayerTin keeps its own data

    fv = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0.0]])
    with pytest.raises(ValueError, match=r"fault_side: vertices row 1 has a coordinate beyond \+-1e\+60 \(z = 1e\+61\)"):
        fm.fault_side(fv + [[0, 0, 0], [0, 0, 1e61], [0, 0, 0]], np.array([[0, 1, 2]]), np.array([[1, 1, 1.0]]))
    with pytest.raises(ValueError, match=r"fault_side: triangles row 0 has a negative vertex index -1"):
        fm.fault_side(fv, np.array([[0, 1, -1]]), np.array([[1, 1, 1.0]]))
    assert ref[2][0] >= 1


def test_layer_tin_inserts_from_several_threads():
    """LayerTin.insert runs with the GIL released; the binding's lock serialises
    concurrent inserts into one layer (without it they raced on the TIN's
    arrays). Four threads insert disjoint points: every one becomes a vertex
    (interpolation there gives its own z, 0, not the layer's plane) and the
    vertex count adds up to what the inserts report."""
    square = np.array([[0, 0], [100, 0], [100, 100], [0, 100.0]])
    LV, _ = layer_tin(np.random.default_rng(0), 6, 0, 1.0, 0.0)
    tin = fm.LayerTin("L", LV, square)
    n0 = tin.n_vertices
    rng = np.random.default_rng(5)
    batches = [np.c_[rng.uniform(1.0, 99.0, (300, 2)), np.zeros(300)] for _ in range(4)]
    errors, added = [], []

    def work(b):
        try:
            for chunk in np.array_split(b, 10):
                added.append(tin.insert(chunk))
                tin.interpolate(chunk[:, :2])
        except Exception as e:  # collected: a thread's exception would otherwise be lost
            errors.append(e)

    threads = [threading.Thread(target=work, args=(b,)) for b in batches]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert tin.n_vertices == n0 + sum(added) and sum(added) >= 1200
    assert np.array_equal(tin.interpolate(np.concatenate(batches)[:, :2]), np.zeros(1200))
    V, T = tin.mesh()
    assert np.all(orient_rows(V, T) > 0)


def _random_triangles_on_few_points(data, offset, with_area, hostile, max_triangles):
    """Random triangles (any orientation, repeated vertices, duplicates) on
    3-9 points of a 10 m grid at ``offset``, a 50 m square study area with
    ``with_area``, and the ``hostile`` change: "nan" or "far" (beyond the
    coordinate limit) at a vertex a triangle uses, "index" out of range."""
    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    n = data.draw(st.integers(3, 9))
    V = np.c_[rng.integers(0, 6, (n, 2)).astype(float) * 10.0 + offset, np.zeros(n)]
    m = data.draw(st.integers(1, max_triangles))
    T = rng.integers(0, n, (m, 3))
    area = fm.StudyArea(np.array([[0.0, 0.0], [50.0, 0.0], [50.0, 50.0], [0.0, 50.0]]) + offset) \
        if with_area else None
    if hostile in ("nan", "far"):
        V[T[rng.integers(m), rng.integers(3)], rng.integers(2)] = np.nan if hostile == "nan" else 1e61
    elif hostile == "index":
        T[rng.integers(m), rng.integers(3)] = n + 3
    return V, T, area


@pytest.mark.fuzz
@fuzz_settings(300)
@given(data=st.data(), offset=st.sampled_from([0.0, 5.5e5, 7.8e6]), with_area=st.booleans(),
       hostile=st.sampled_from([None, None, None, "nan", "far", "index", "area"]))
def test_fuzz_triangles_not_covered_once(data, offset, with_area, hostile):
    """Random triangles on few points (duplicates, collinear triples, zero
    areas, folds: any orientation), at UTM offsets too, with or without a
    study area that some of them touch: the rows returned are valid, sorted,
    unique, and a superset of the centroid test's;
    hostile input (NaN, beyond the coordinate limit, an index out of range,
    an area that is no StudyArea) is a ValueError (TypeError for the area)
    naming the function."""
    V, T, area = _random_triangles_on_few_points(data, offset, with_area, hostile, 12)
    m = len(T)
    if hostile == "area":
        with pytest.raises(TypeError, match="triangles_not_covered_once: area must be a StudyArea"):
            fm.triangles_not_covered_once(V, T, area=V)
        return
    r, err = call(["triangles_not_covered_once"], ["vertices", "triangles"],
                  fm.triangles_not_covered_once, V, T, area=area)
    if err is not None:
        assert hostile is not None, err
        return
    assert hostile is None, "hostile input was accepted"
    assert r.dtype == np.int64 and np.array_equal(r, np.unique(r)) and (len(r) == 0 or 0 <= r.min() <= r.max() < m)
    at_centroids = fm.triangles_not_covered_once(V, T, area=area, outline=False)
    assert set(at_centroids.tolist()) <= set(r.tolist())


def _outline_meetings_brute_force(V, T) -> set:
    """The rows triangles_at_outline_crossings should give without a study
    area, by brute force over every pair of outline edges with exact
    rational orientations: edges sharing no vertex meet if their closed
    segments share a point; edges sharing a vertex if they run the same way
    from it along one line."""
    loops = fm.boundary_contours(T, n_vertices=len(V)).loops
    E = [(int(l[i]), int(l[(i + 1) % len(l)])) for l in loops for i in range(len(l))]
    P = [tuple(map(float, v[:2])) for v in V]

    def on_closed(a, b, c):   # c on the closed segment [a, b], given collinear
        return min(a[0], b[0]) <= c[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= c[1] <= max(a[1], b[1])

    def meet(e, f):
        shared = set(e) & set(f)
        if shared:
            (o,) = shared if len(shared) == 1 else (e[0],)
            p = P[e[1] if e[0] == o else e[0]]
            q = P[f[1] if f[0] == o else f[0]]
            O = P[o]
            dot = (Fraction(p[0]) - Fraction(O[0])) * (Fraction(q[0]) - Fraction(O[0])) + \
                (Fraction(p[1]) - Fraction(O[1])) * (Fraction(q[1]) - Fraction(O[1]))
            return exact_orient(O, p, q) == 0 and dot > 0
        a, b, c, d = P[e[0]], P[e[1]], P[f[0]], P[f[1]]
        o1, o2, o3, o4 = exact_orient(a, b, c), exact_orient(a, b, d), exact_orient(c, d, a), exact_orient(c, d, b)
        if o1 * o2 < 0 and o3 * o4 < 0:
            return True
        return (o1 == 0 and on_closed(a, b, c)) or (o2 == 0 and on_closed(a, b, d)) or \
            (o3 == 0 and on_closed(c, d, a)) or (o4 == 0 and on_closed(c, d, b))

    def row(e):
        for key in (e, e[::-1]):
            for t, r in enumerate(T.tolist()):
                if any((r[k], r[(k + 1) % 3]) == key for k in range(3)):
                    return t
        return None

    out = set()
    for i in range(len(E)):
        for j in range(i + 1, len(E)):
            if meet(E[i], E[j]):
                out |= {row(E[i]), row(E[j])} - {None}
    return out


@pytest.mark.fuzz
@fuzz_settings(300)
@given(data=st.data(), offset=st.sampled_from([0.0, 5.5e5, 7.8e6]), with_area=st.booleans(),
       hostile=st.sampled_from([None, None, None, "nan", "far", "index", "area"]))
def test_fuzz_triangles_at_outline_crossings(data, offset, with_area, hostile):
    """Random triangles on few points (duplicates, collinear triples, zero
    areas, folds, pinches, edges used three times: any outline; a row that
    repeats a vertex is named), at UTM
    offsets too: without a study area the rows are those of a brute force
    over all pairs of outline edges in exact rational arithmetic; with one
    (that some points lie on) a subset of them (the pairs along its sides
    are exempt). Hostile input (NaN, beyond the coordinate limit, an index
    out of range, an area that is no StudyArea) is a ValueError (TypeError
    for the area) naming the function."""
    V, T, area = _random_triangles_on_few_points(data, offset, with_area, hostile, 10)
    m = len(T)
    if hostile == "area":
        with pytest.raises(TypeError, match="triangles_at_outline_crossings: area must be a StudyArea"):
            fm.triangles_at_outline_crossings(V, T, area=V)
        return
    repeats = bool(((T[:, 0] == T[:, 1]) | (T[:, 1] == T[:, 2]) | (T[:, 2] == T[:, 0])).any())
    r, err = call(["triangles_at_outline_crossings"], ["vertices", "triangles"],
                  fm.triangles_at_outline_crossings, V, T, area=area)
    if err is not None:
        assert hostile is not None or (repeats and "repeats vertex" in str(err)), err
        return
    assert hostile is None and not repeats, "hostile input was accepted"
    assert r.dtype == np.int64 and np.array_equal(r, np.unique(r)) and (len(r) == 0 or 0 <= r.min() <= r.max() < m)
    want = _outline_meetings_brute_force(V, T)
    if area is None:
        assert set(r.tolist()) == want
    else:
        assert set(r.tolist()) <= want


# ------------------------------------------------------------ patch data
@pytest.mark.fuzz
@fuzz_settings(150)
@given(data=st.data(), scale=st.sampled_from([1.0, 1.0, 1e-3, 1e3]), offset=st.sampled_from([0.0, 5.5e5, 7.8e6]),
       fold=st.booleans(), hostile=st.booleans())
def test_fuzz_insert_patch_data(data, scale, offset, fold, hostile):
    """A patch (a TIN, folded: a second sheet 10 m below, clockwise in XY)
    and data anywhere, on its vertices and edges too: every datum placed
    is a vertex at its own elevation in or on the edge of a triangle it
    was in (at its own XY, or within a hundredth of the triangle's height
    of it, on the edge, with the z that puts its sheet through it at its
    own XY), the XY area of each sheet is kept with its
    orientation, every edge is used twice at most, no triangle is flat in
    XY, a patch vertex changes z only where a datum left out lies near it
    (a corner takes such a datum) or beside a datum moved onto an edge
    (a neighbour takes it where the datum's own vertex weighs too little);
    hostile data (NaN, beyond the coordinate limit) are a ValueError
    naming the function."""
    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    n = data.draw(st.integers(3, 12))
    xy = rng.uniform(0.0, 100.0, (n, 2))
    xy[:3] = [[0.0, 0.0], [100.0, 0.0], [0.0, 100.0]]
    t = fm.Tin(np.c_[xy * scale + offset, 0.1 * xy[:, 0]])
    V, T = t.vertices, t.triangles
    if fold:
        V = np.vstack([V, V - [0.0, 0.0, 10.0]])
        T = np.vstack([T, T[:, ::-1] + len(t.vertices)])
    m = data.draw(st.integers(0, 30))
    P = np.c_[rng.uniform(-10.0, 110.0, (m, 2)) * scale + offset, rng.uniform(-15.0, 15.0, m)]
    if m and data.draw(st.booleans()):
        P[: min(m, 3), :2] = V[: min(m, 3), :2]                   # on vertices
        P[-1, :2] = 0.5 * (V[T[0, 0], :2] + V[T[0, 1], :2])      # on an edge
    if m >= 4 and data.draw(st.booleans()):
        # Picks along a line from a vertex (a seismic line), one of them
        # within a hundredth of an edge: a datum moved onto the edge with
        # another nearly on the line from a corner through it.
        a = V[data.draw(st.integers(0, len(V) - 1)), :2]
        d = rng.normal(size=2)
        P[-4:, :2] = a + np.outer(rng.uniform(0.05, 1.0, 4) * 120.0 * scale, d / np.hypot(*d))
    if hostile and m:
        P[rng.integers(m), rng.integers(3)] = data.draw(st.sampled_from([np.nan, np.inf, 1e61]))
    max_dz = data.draw(st.sampled_from([np.inf, 3.0, 0.0]))
    r, err = call(["insert_patch_data"], ["points"], fm.insert_patch_data, V, T, P, max_dz=max_dz)
    if err is not None:
        assert hostile, err
        return
    V2, T2, placed, tri = r
    assert not (hostile and m), "a coordinate beyond the limit was accepted"
    assert len(V2) == len(V) + len(placed) and len(T2) >= len(T) + len(placed)
    new = V2[len(V):]
    at_own_xy = np.all(new[:, :2] == P[placed, :2], axis=1)
    np.testing.assert_array_equal(new[at_own_xy, 2], P[placed[at_own_xy], 2])
    assert ((tri >= 0).sum() == len(placed)) and (tri[placed] >= 0).all()

    def o2(W, S):
        return fm.orient2d(W[S[:, 0], :2], W[S[:, 1], :2], W[S[:, 2], :2])

    o_old, o_new = o2(V, T), o2(V2, T2)
    assert (o_new != 0).all()
    for sign in (1, -1):
        a, b = o_old[np.sign(o_old) == sign].sum(), o_new[np.sign(o_new) == sign].sum()
        assert abs(a - b) <= 1e-9 * max(abs(a), 1.0) * max(1.0, offset * scale)
    edges = np.sort(np.vstack([T2[:, [0, 1]], T2[:, [1, 2]], T2[:, [2, 0]]]), axis=1)
    assert Counter(map(tuple, edges)).most_common(1)[0][1] <= 2
    # The data moved onto an edge (their vertices come after the data
    # placed inside a triangle, whose z are their own).
    edge_placed = set()
    for k, i in enumerate(placed):
        A, B, C = V[T[tri[i]]]
        M = np.array([[A[0], B[0], C[0]], [A[1], B[1], C[1]], [1.0, 1.0, 1.0]])
        if np.linalg.solve(M, np.r_[new[k, :2], 1.0]).min() < 0.005:   # inside: at least 0.01
            edge_placed.add(len(V) + k)
    # A patch vertex changes z only where a datum left out lies near it
    # (within a hundredth of two edges of a triangle at it, or of one edge
    # by its end: the corner took the datum, patch_data.cpp
    # take_corner_data).
    near_left_out = set()
    for i in np.flatnonzero(tri < 0):
        if not np.isfinite(P[i]).all():
            continue
        for s in T:
            Ms = np.array([V[s, 0], V[s, 1], [1.0, 1.0, 1.0]])
            if abs(np.linalg.det(Ms)) == 0.0:
                continue
            ws = np.linalg.solve(Ms, np.r_[P[i, :2], 1.0])
            if ws.min() > -1e-6 and ws.max() >= 0.98 - 1e-6:
                near_left_out.add(int(s[np.argmax(ws)]))
            if ws.min() <= -1e-6:
                continue
            # Within a hundredth of one edge, projecting within a hundredth
            # of its length of an end: that end's corner (place_on_edges).
            for k in np.flatnonzero(ws < 0.01 + 1e-6):
                a, b = V[s[(k + 1) % 3], :2], V[s[(k + 2) % 3], :2]
                par = np.clip((P[i, :2] - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
                if par <= 0.01 + 1e-6:
                    near_left_out.add(int(s[(k + 1) % 3]))
                if par >= 0.99 - 1e-6:
                    near_left_out.add(int(s[(k + 2) % 3]))
    # Or where a datum moved onto an edge whose own vertex weighs too
    # little at its XY lies nearer that vertex's neighbour (it takes the
    # datum).
    moved_v = np.array([len(V) + k for k, i in enumerate(placed) if not np.array_equal(new[k, :2], P[i, :2])],
                       dtype=np.int64)
    beside_moved = set(T2[np.isin(T2, moved_v).any(axis=1)].ravel().tolist()) - set(range(len(V), len(V2)))
    near_left_out |= beside_moved
    changed = set(np.flatnonzero(V2[:len(V), 2] != V[:, 2]).tolist())
    assert changed <= near_left_out, (changed, near_left_out)
    # A vertex at a datum's own XY that took it has its z (set, not solved).
    at_datum = {c for c in changed
                if any((P[j, :2] == V[c, :2]).all() and P[j, 2] == V2[c, 2] for j in np.flatnonzero(tri < 0))}
    for k, i in enumerate(placed):  # in the sheet nearest to it, within max_dz
        j = tri[i]
        A, B, C = V[T[j]]
        M = np.array([[A[0], B[0], C[0]], [A[1], B[1], C[1]], [1.0, 1.0, 1.0]])
        # The barycentric coordinates of numpy's solve err by ulps of the
        # offset over the triangle's size.
        tol = 1e-9 + 1e-13 * offset / scale
        w = np.linalg.solve(M, np.r_[P[i, :2], 1.0])
        # In it, or at most a micrometre outside an edge (patch_data.hpp,
        # kOnOutline): a weight of -1e-6 m over the height on that edge.
        area2 = abs(np.linalg.det(M))
        edge = np.hypot(*(np.array([[B[0] - C[0], B[1] - C[1]], [C[0] - A[0], C[1] - A[1]],
                                    [A[0] - B[0], A[1] - B[1]]])).T)
        assert (w > -tol - 1.01e-6 * edge / area2).all() and abs(w @ [A[2], B[2], C[2]] - P[i, 2]) <= max_dz + 1e-6
        if not np.array_equal(new[k, :2], P[i, :2]):
            # Moved onto an edge of that triangle, at most a hundredth of its height.
            wn = np.linalg.solve(M, np.r_[new[k, :2], 1.0])
            assert (wn > -tol).all() and np.min(np.abs(wn)) <= tol and np.min(w) <= 0.01 + tol, (w, wn)
            # Its vertex's z puts its sheet through it at its own XY where
            # the new triangle round it (of its triangle's orientation) that
            # holds its XY best gives the vertex at least 1/2 of the weight
            # there and the other moved data at most half of that
            # (patch_data.cpp, kMinOwnWeight and solvable; after the walk of
            # flips towards it, flip_towards_moved_data); elsewhere the
            # vertex's z is the datum's own.
            v = len(V) + k
            S = T2[(T2 == v).any(axis=1) & (np.sign(o_new) == np.sign(o_old[j]))]
            best, z_at = -np.inf, None
            for s in S:
                Ms = np.array([V2[s, 0], V2[s, 1], [1.0, 1.0, 1.0]])
                ws = np.linalg.solve(Ms, np.r_[P[i, :2], 1.0])
                if ws.min() > best:
                    best, z_at = ws.min(), ws @ V2[s, 2]
                    own = ws[list(s).index(v)]
                    # The corners solved too: surely (moved, or a patch
                    # vertex that changed), at most (or one near a datum
                    # left out: it may have taken it and kept its z).
                    surely = sum(ws[c] for c in range(3)
                                 if s[c] != v and (s[c] in edge_placed or s[c] in changed - at_datum))
                    coupled = surely + sum(ws[c] for c in range(3)
                                           if s[c] != v and s[c] in near_left_out - changed)
                    # How far outside it the XY lies (0 inside): a weight
                    # times the height over the opposite edge.
                    area2 = abs(np.linalg.det(Ms))
                    outside = max(0.0, *(-ws[c] * area2 / np.hypot(*(V2[s[(c + 2) % 3], :2] - V2[s[(c + 1) % 3], :2]))
                                         for c in range(3)))
            assert z_at is not None
            zscale = 1.0 + np.abs(V[T[j], 2]).max() + abs(P[i, 2])
            # Clear of the rule's thresholds (a micrometre outside:
            # kOnOutline) by more than rounding.
            if outside < 0.5e-6 and own >= 0.5 + tol and coupled <= 0.5 * own - tol:
                assert abs(z_at - P[i, 2]) <= 1e-6 * zscale + tol * zscale, (z_at, P[i, 2])
            elif outside > 2e-6 or own < 0.5 - tol or surely > 0.5 * own + tol:
                assert new[k, 2] == P[i, 2]
