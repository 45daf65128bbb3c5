"""faultmesh.StudyArea: the one place that decides which points lie on the
study-area boundary and where the builder places points on it."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, strategies as st

import faultmesh
from faultmesh import StudyArea, orient2d


def _rect(x0, y0, w, h):
    return np.array([[x0, y0], [x0 + w, y0], [x0 + w, y0 + h], [x0, y0 + h]])


def test_ring_is_ccw_and_errors_name_the_problem():
    a = StudyArea(_rect(0, 0, 10, 5)[::-1])
    r = a.ring
    assert 0.5 * np.sum(r[:, 0] * np.roll(r[:, 1], -1) - np.roll(r[:, 0], -1) * r[:, 1]) > 0
    assert a.n_sides == 4 and a.perimeter == 30.0
    with pytest.raises(ValueError, match="at least 3 distinct"):
        StudyArea([[0, 0], [1, 1]])
    with pytest.raises(faultmesh.GeometryError, match="zero area"):
        StudyArea([[0, 0], [1, 1], [2, 2]])
    with pytest.raises(ValueError, match="tolerance"):
        StudyArea(_rect(0, 0, 1, 1), tolerance=-1.0)
    with pytest.raises(ValueError, match="not a side"):
        StudyArea(_rect(0, 0, 1, 1)).place([4], [0.5])


@given(off=st.sampled_from([0.0, 5e5, 7e6, 4.21e6 + 0.37]),
       u=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=20),
       w=st.floats(100.0, 6000.0), h=st.floats(100.0, 6000.0))
def test_points_placed_on_axis_parallel_sides_are_exactly_on_them(off, u, w, h):
    a = StudyArea(_rect(off, off + 3.25, w, h))
    u = np.asarray(u)
    for side in range(4):
        s = u * a.perimeter / 4.0
        s = np.minimum(s, [w, h, w, h][side])
        p = a.place(np.full(len(u), side), s)
        r = a.ring
        o = orient2d(np.repeat(r[side][None], len(p), 0), np.repeat(r[(side + 1) % 4][None], len(p), 0), p)
        assert np.all(o == 0.0)
        assert a.on_boundary(p).all() and a.contains(p).all()
        # A point on the boundary is its own ray hit, whatever the direction.
        t, sd, _, xy = a.ray_hit(p, [[0.3, -0.7]])
        assert np.all(t == 0.0) and np.array_equal(xy, p)


@given(off=st.sampled_from([0.0, 5e5, 7e6]), angle=st.floats(0.0, 3.1),
       seed=st.integers(0, 2 ** 16))
def test_rays_from_inside_land_on_the_boundary_of_rotated_and_concave_areas(off, angle, seed):
    rng = np.random.default_rng(seed)
    c, s = np.cos(angle), np.sin(angle)
    base = np.array([[0, 0], [3000, 0], [3000, 1000], [1200, 1000], [1200, 2800], [0, 2800]], float)
    ring = off + base @ np.array([[c, s], [-s, c]])
    a = StudyArea(ring)
    inner = off + (np.array([[600.0, 600.0]]) + rng.uniform(-300, 300, (20, 2))) @ np.array([[c, s], [-s, c]])
    assert a.contains(inner).all()
    d = rng.normal(size=(20, 2))
    t, side, sarc, xy = a.ray_hit(inner, d)
    assert np.all(np.isfinite(t)) and np.all(t > 0)
    assert a.on_boundary(xy).all()
    assert np.array_equal(xy, a.place(side, sarc))
    # Nothing of the boundary lies between the point and its hit.
    mid = inner + 0.5 * t[:, None] * d
    assert a.contains(mid).all()


def test_locate_and_nearest():
    a = StudyArea(_rect(0, 0, 10, 5))
    side, s = a.locate([[5, 0], [10, 0], [10, 2.5], [5, 2]])
    assert side.tolist() == [0, 1, 1, -1]
    assert s[:3].tolist() == [5.0, 0.0, 2.5] and np.isnan(s[3])
    side, s, d = a.nearest([[5, -0.01], [5, 2]], 0.1)
    assert side.tolist() == [0, -1] and s[0] == 5.0 and d[0] == pytest.approx(0.01)


def test_clip_surface_cuts_a_patch_across_a_notch_at_utm_offsets():
    """A fault patch lofted across the notch of a concave study area (sweep
    seeds 418, 454) is cut to the area: the notch's part (area 2 of 16) goes,
    the new vertices lie on the notch's walls with the patch's z there, and
    the outline runs along them; at UTM-sized offsets too."""
    for off in (0.0, 5e5, 7e6):
        ring = np.array([[0, 0], [10, 0], [10, 10], [6, 10], [5, 4], [4, 10], [0, 10]]) + off
        a = StudyArea(ring)
        V = np.array([[1, 6, 1], [9, 6, 9], [9, 8, 9], [1, 8, 1]], dtype=float)
        V[:, :2] += off
        T = np.array([[0, 1, 2], [0, 2, 3]])
        W, U, vertex_of, n_cut, n_out = a.clip_surface(V, T, "F1")
        assert (n_cut, n_out) == (2, 0)
        xy = W[:, :2] - off
        o = orient2d(W[U[:, 0], :2], W[U[:, 1], :2], W[U[:, 2], :2])
        assert (o > 0).all()
        area = 0.5 * np.sum((xy[U[:, 1], 0] - xy[U[:, 0], 0]) * (xy[U[:, 2], 1] - xy[U[:, 0], 1])
                            - (xy[U[:, 1], 1] - xy[U[:, 0], 1]) * (xy[U[:, 2], 0] - xy[U[:, 0], 0]))
        assert area == pytest.approx(14.0, rel=1e-9)
        new = vertex_of < 0
        assert new.sum() == 6 and a.on_boundary(W[new]).all()
        np.testing.assert_allclose(W[:, 2], xy[:, 0], atol=1e-6)  # z = x was linear
        assert (vertex_of[~new] == np.arange(4)).all()
    with pytest.raises(ValueError, match="out of range"):
        a.clip_surface(V, [[0, 1, 7]])
