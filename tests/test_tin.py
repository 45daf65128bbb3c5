"""faultmesh.Tin: incremental insertion equals rebuilding, duplicate policy,
batched locate / interpolate, the workflow's layer operations, contract."""
from __future__ import annotations

import threading

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import faultmesh as fm
from helpers import claudius_horizons, tri_set


def plane(xy):
    xy = np.asarray(xy, dtype=float)
    return 100.0 + 0.5 * xy[:, 0] - 0.25 * xy[:, 1]


def with_z(xy, f=plane):
    return np.c_[xy, f(xy)]


def check_tin(tin: fm.Tin) -> None:
    v, t, h = tin.vertices, tin.triangles, tin.halfedges
    assert v.shape == (tin.n_vertices, 3) and v.dtype == np.float64
    assert t.shape == (tin.n_triangles, 3) and t.dtype == np.int64
    assert h.shape == (3 * tin.n_triangles,) and h.dtype == np.int64
    assert len(tin) == tin.n_vertices
    assert len(np.unique(v[:, :2], axis=0)) == len(v), "no duplicate vertices"
    assert np.all(fm.orient2d(v[t[:, 0], :2], v[t[:, 1], :2], v[t[:, 2], :2]) > 0)
    e = np.arange(len(h))
    inner = h >= 0
    assert np.array_equal(h[h[inner]], e[inner])
    # Same triangulation as delaunay() of the vertices' XY.
    assert tri_set(t) == tri_set(fm.delaunay(v[:, :2]))


# --------------------------------------------------------- insert == rebuild


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(-8, 8), st.integers(-8, 8)), min_size=4, max_size=70, unique=True),
       st.data())
def test_insert_equals_rebuild_on_degenerate_integer_sets(pts, data):
    xy = np.asarray(pts, dtype=float)
    first = data.draw(st.integers(3, len(xy)))
    head = xy[:first]
    o = fm.orient2d(np.repeat(head[:1], len(head), 0), np.repeat(head[1:2], len(head), 0), head)
    if not np.any(o != 0):
        with pytest.raises(fm.GeometryError):
            fm.Tin(with_z(head))
        return
    tin = fm.Tin(with_z(head))
    rest = xy[first:]
    split = data.draw(st.integers(0, len(rest)))
    idx1 = tin.insert(with_z(rest[:split]))
    idx2 = tin.insert(with_z(rest[split:]))
    assert np.array_equal(np.r_[idx1, idx2], np.arange(first, len(xy)))
    whole = fm.Tin(with_z(xy))
    assert np.array_equal(tin.vertices, whole.vertices)
    assert tri_set(tin.triangles) == tri_set(whole.triangles)
    check_tin(tin)


def test_claudius_horizon_grown_equals_rebuilt(data_dir):
    h = claudius_horizons(data_dir, z=True)["60.0"]
    rng = np.random.default_rng(0)
    h = h[rng.permutation(len(h))]
    tin = fm.Tin(h[:500])
    for chunk in np.array_split(h[500:], 7):
        tin.insert(chunk)
    whole = fm.Tin(h)
    assert np.array_equal(tin.vertices, whole.vertices)
    assert tri_set(tin.triangles) == tri_set(whole.triangles)
    check_tin(tin)


def test_single_point_inserts_equal_batch():
    rng = np.random.default_rng(1)
    p = with_z(rng.random((400, 2)))
    a = fm.Tin(p[:50])
    for row in p[50:]:
        a.insert(row[None])
    b = fm.Tin(p[:50])
    b.insert(p[50:])
    assert tri_set(a.triangles) == tri_set(b.triangles)


# -------------------------------------------------------------- duplicates


def test_duplicate_policy_existing_vertex_and_z_are_kept():
    p = np.array([[0, 0, 1.0], [10, 0, 2], [0, 10, 3], [10, 10, 4], [0, 0, 99]])
    tin = fm.Tin(p)
    assert tin.n_vertices == 4 and tin.n_duplicates == 1
    assert np.array_equal(tin.vertex_of_input, [0, 1, 2, 3, 0])
    assert tin.vertices[0, 2] == 1.0
    idx = tin.insert([[10, 10, -7.0], [5, 5, 8], [5, 5, 9], [0, 10, 0]])
    assert idx.dtype == np.int64
    assert np.array_equal(idx, [3, 4, 4, 2])
    assert tin.n_vertices == 5 and tin.n_duplicates == 4
    assert tin.vertices[3, 2] == 4.0 and tin.vertices[4, 2] == 8.0
    assert tin.n_triangles == 4
    check_tin(tin)


# ------------------------------------------------------- locate/interpolate


def test_locate_returns_a_containing_triangle_or_minus_one():
    rng = np.random.default_rng(2)
    tin = fm.Tin(with_z(rng.random((3000, 2)) * 200 - 100))
    q = rng.random((20_000, 2)) * 260 - 130
    loc = tin.locate(q)
    assert loc.dtype == np.int64 and loc.shape == (len(q),)
    v, t = tin.vertices[:, :2], tin.triangles
    ins = loc >= 0
    for k in range(3):
        a, b = v[t[loc[ins], k]], v[t[loc[ins], (k + 1) % 3]]
        assert np.all(fm.orient2d(a, b, q[ins]) >= 0)
    # Outside points: strictly outside some hull edge, i.e. not in any triangle.
    out = q[~ins][:300]
    inside_any = np.zeros(len(out), bool)
    for tri in t:
        a, b, c = v[tri]
        inside_any |= ((fm.orient2d(np.broadcast_to(a, out.shape), np.broadcast_to(b, out.shape), out) >= 0)
                       & (fm.orient2d(np.broadcast_to(b, out.shape), np.broadcast_to(c, out.shape), out) >= 0)
                       & (fm.orient2d(np.broadcast_to(c, out.shape), np.broadcast_to(a, out.shape), out) >= 0))
    assert not inside_any.any()
    # (k, 3) queries: z ignored
    assert np.array_equal(tin.locate(np.c_[q[:100], np.full(100, 5.0)]), loc[:100])


def test_interpolate_reproduces_a_plane_and_is_nan_outside():
    rng = np.random.default_rng(3)
    xy = rng.random((2000, 2)) * 1000 + [5.5e5, 7.8e6]
    tin = fm.Tin(with_z(xy))
    q = rng.random((10_000, 2)) * 1200 - 100 + [5.5e5, 7.8e6]
    z = tin.interpolate(q)
    loc = tin.locate(q)
    assert np.array_equal(np.isnan(z), loc < 0)
    np.testing.assert_allclose(z[loc >= 0], plane(q[loc >= 0]), rtol=1e-12, atol=1e-8)


def test_interpolate_matches_scipy_linear_interpolation():
    scipy_interp = pytest.importorskip("scipy.interpolate")
    rng = np.random.default_rng(4)
    xy = rng.random((1500, 2))
    z = np.sin(6 * xy[:, 0]) * np.cos(4 * xy[:, 1])
    tin = fm.Tin(np.c_[xy, z])
    q = rng.random((5000, 2)) * 1.1 - 0.05
    ref = scipy_interp.LinearNDInterpolator(xy, z)(q)  # qhull: same Delaunay in general position
    got = tin.interpolate(q)
    assert np.array_equal(np.isnan(got), np.isnan(ref))
    ok = ~np.isnan(ref)
    np.testing.assert_allclose(got[ok], ref[ok], rtol=0, atol=1e-12)


def test_interpolate_at_vertices_is_exact_and_nan_queries_give_nan(data_dir):
    h = claudius_horizons(data_dir, z=True)["250.0"]
    tin = fm.Tin(h)
    z = tin.interpolate(tin.vertices[:, :2])
    assert np.array_equal(z, tin.vertices[:, 2])
    q = np.array([[np.nan, 7.82e6], [np.inf, 0.0]])
    assert np.all(np.isnan(tin.interpolate(q)))
    assert np.array_equal(tin.locate(q), [-1, -1])


def test_interpolate_in_a_sliver_is_exact_at_its_own_vertices():
    """Regression (issue 10): a sliver that the exact orient2d accepts gave NaN at
    its own vertices (a floating determinant of 1e-17 relative to rounded
    products)."""
    xy = np.array([[0.5118216247002567] * 2, [0.9504636963259353] * 2,
                   [0.14415961271963373, 0.14415961271963376]])
    assert fm.orient2d(xy[[0]], xy[[1]], xy[[2]])[0] != 0
    tin = fm.Tin(np.c_[xy, [1.0, 2.0, 3.0]])
    assert np.array_equal(tin.interpolate(xy), [1.0, 2.0, 3.0])
    # On an edge only the edge's two vertices count: the midpoint of the two
    # points on y = x lies on that edge exactly.
    mid = (xy[[0]] + xy[[1]]) / 2
    assert tin.interpolate(mid)[0] == 1.5


def test_interpolate_inside_the_issue10_sliver_is_within_the_vertices_z():
    """Regression (issue 10): inside the sliver of the points below Tin.interpolate
    gave NaN (a floating barycentric determinant). Every query the TIN locates in
    the sliver -- its centroid, an edge midpoint, 500 random convex combinations
    of the corners -- gets a value within the corners' z range [1, 3]."""
    xy = np.array([[0.5118216247002567] * 2, [0.9504636963259353] * 2,
                   [0.14415961271963373, 0.14415961271963376]])
    tin = fm.Tin(np.c_[xy, [1.0, 2.0, 3.0]])
    w = np.random.default_rng(10).dirichlet([1.0, 1.0, 1.0], 500)
    q = np.r_[xy.mean(0)[None], (xy[[1]] + xy[[2]]) / 2, w @ xy]
    inside = tin.locate(q) >= 0
    assert inside[0] and inside[1] and inside.sum() > 100  # the centroid, the midpoint, many others
    z = tin.interpolate(q[inside])
    assert not np.any(np.isnan(z))
    assert np.all((z >= 1.0) & (z <= 3.0))


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 12))
def test_interpolate_is_a_convex_combination_in_slivers(seed, n):
    """Regression (issue 10): z = 2.6e10 came out where the triangle's z lie in
    [-1.07e10, 1.7e10]. Points within a few ulps of the line y = x make every
    triangle a sliver; z must stay within the located triangle's z range, be
    exact at vertices and never NaN inside the hull."""
    rng = np.random.default_rng(seed)
    t = rng.random(n)
    xy = np.c_[t, t] + rng.integers(-3, 4, (n, 2)) * np.spacing(1.0) * 4 * rng.random()
    z = rng.uniform(-1.07e10, 1.7e10, n)
    try:
        tin = fm.Tin(np.c_[xy, z])
    except fm.GeometryError:  # all collinear
        return
    V, T = tin.vertices, tin.triangles
    w = rng.dirichlet([1, 1, 1], (50, len(T)))
    q = np.einsum("ktj,tjd->ktd", w, V[T][:, :, :2]).reshape(-1, 2)
    q = np.r_[q, (V[T[:, 0], :2] + V[T[:, 1], :2]) / 2]
    zq, loc = tin.interpolate(q), tin.locate(q)
    assert np.array_equal(np.isnan(zq), loc < 0)
    inside = loc >= 0
    zt = V[T[loc[inside]], 2]
    assert np.all(zq[inside] >= zt.min(axis=1)) and np.all(zq[inside] <= zt.max(axis=1))
    assert np.array_equal(tin.interpolate(V[:, :2]), V[:, 2])


def test_workflow_layer_operations_on_claudius_horizons(data_dir, z=True):
    """The layer-TIN steps of the workflow: build from points, insert the
    study-area corners (z interpolated from the nearest data), interpolate one
    layer at another's vertices, insert midpoints of crossing edges."""
    layers = claudius_horizons(data_dir, z=True)
    # The lower horizon raised by 400 m so that it pierces the upper one in
    # part of the area: the input of the layer-crossing repair.
    upper, lower = fm.Tin(layers["60.0"]), fm.Tin(layers["250.0"] + [0.0, 0.0, 400.0])
    with open(data_dir / "claudius" / "claudiusbb.txt") as f:
        (x0, y0, _), (x1, y1, _) = [tuple(map(float, line.split())) for line in f]
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    for tin in (upper, lower):
        v = tin.vertices
        near = np.argmin(((v[None, :, :2] - corners[:, None]) ** 2).sum(-1), axis=1)
        idx = tin.insert(np.c_[corners, v[near, 2]])
        assert np.array_equal(idx, np.arange(len(v), len(v) + 4))  # new vertices
        check_tin(tin)
    # Now both layers cover the study area: every point inside gets a value.
    z_up = upper.interpolate(lower.vertices[:, :2])
    assert not np.isnan(z_up).any()
    above = lower.vertices[:, 2] > z_up
    # Crossing edges of the lower layer: insert their midpoints (z from the
    # upper layer), as Rule 2 of the layer-crossing repair does.
    t = lower.triangles
    e = np.sort(np.r_[t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]], axis=1)
    e = np.unique(e, axis=0)
    crossing = e[above[e[:, 0]] != above[e[:, 1]]]
    assert 0 < len(crossing) < len(e)
    mid = lower.vertices[crossing, :2].mean(axis=1)
    before = lower.n_vertices
    idx = lower.insert(np.c_[mid, upper.interpolate(mid)])
    assert len(idx) == len(mid)
    assert lower.n_vertices == before + len(np.unique(mid, axis=0))
    check_tin(lower)


def test_set_z_rule_one_of_the_crossing_repair(data_dir):
    """Rule 1: lower vertices above the upper surface take its elevation."""
    layers = claudius_horizons(data_dir, z=True)
    upper, lower = fm.Tin(layers["60.0"]), fm.Tin(layers["250.0"] + [0.0, 0.0, 400.0])
    tri = lower.triangles
    z_up = upper.interpolate(lower.vertices[:, :2])
    above = np.flatnonzero(lower.z > z_up)
    assert len(above) > 0
    lower.set_z(above, z_up[above])
    assert np.array_equal(lower.triangles, tri)
    assert np.all(~(lower.z > z_up))
    assert np.array_equal(lower.interpolate(lower.vertices[above, :2]), z_up[above])
    with pytest.raises(ValueError, match="Tin.set_z: vertices row 0 has a negative vertex index -1"):
        lower.set_z([-1], [0.0])
    with pytest.raises(ValueError, match="one value per vertex"):
        lower.set_z([0, 1], [0.0])


# ---------------------------------------------------------------- contract


@pytest.mark.parametrize("bad", [np.zeros((5, 2)), np.zeros(9), np.zeros((3, 4))])
def test_wrong_shapes_are_value_errors_naming_function_and_shape(bad):
    with pytest.raises(ValueError, match=r"Tin: xyz must have shape \(n, 3\), got"):
        fm.Tin(bad)
    tin = fm.Tin([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    with pytest.raises(ValueError, match=r"Tin.insert: xyz must have shape \(n, 3\)"):
        tin.insert(bad)
    with pytest.raises(ValueError, match=r"Tin.locate: xy must have shape \(n, 2 or 3\)"):
        tin.locate(np.zeros(4))
    with pytest.raises(ValueError, match=r"Tin.interpolate: xy must have shape"):
        tin.interpolate(np.zeros((2, 5)))


def test_errors_nan_row_and_geometry():
    p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [np.nan, 1, 0]])
    with pytest.raises(ValueError, match="Tin: xyz row 3 has a non-finite"):
        fm.Tin(p)
    with pytest.raises(fm.GeometryError, match="collinear"):
        fm.Tin([[0, 0, 0], [1, 1, 0], [2, 2, 5]])
    tin = fm.Tin(p[:3])
    with pytest.raises(ValueError, match="Tin.insert: xyz row 1 has a non-finite"):
        tin.insert([[0.2, 0.2, 0], [0.3, np.inf, 0]])
    assert tin.n_vertices == 3, "a failed insert changes nothing"
    assert tin.insert(np.zeros((0, 3))).shape == (0,)


def test_concurrent_readers_and_writer():
    rng = np.random.default_rng(5)
    tin = fm.Tin(with_z(rng.random((20_000, 2))))
    q = rng.random((50_000, 2)) * 0.9 + 0.05
    errors = []

    def reader():
        try:
            for _ in range(5):
                z = tin.interpolate(q)
                np.testing.assert_allclose(z, plane(q), rtol=1e-12)
        except Exception as exc:  # surfaced below
            errors.append(exc)

    threads = [threading.Thread(target=reader) for _ in range(2)]
    for t in threads:
        t.start()
    for chunk in np.array_split(with_z(rng.random((20_000, 2))), 10):
        tin.insert(chunk)
    for t in threads:
        t.join()
    assert not errors
    check_tin(tin)
    assert "Tin(n_vertices=40000" in repr(tin)
