"""faultmesh.delaunay: identical to CGAL's Delaunay_triangulation_2, valid,
canonical, and the Python contract (shapes, dtypes, errors, GIL)."""
from __future__ import annotations

import subprocess
import threading
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import faultmesh as fm
from helpers import claudius_horizons, tri_set

# ----------------------------------------------------------------- helpers


def cgal_triangles(cgal_bin, xy: np.ndarray, tmp_path, tag="pts") -> np.ndarray:
    """Run bench/cgal/cgal_delaunay on xy; returns its (m, 3) triangles."""
    xy = np.ascontiguousarray(xy, dtype="<f8")
    src, dst = tmp_path / f"{tag}.bin", tmp_path / f"{tag}.tri"
    with open(src, "wb") as f:
        f.write(np.int64(len(xy)).astype("<i8").tobytes())
        f.write(xy.tobytes())
    subprocess.run([str(cgal_bin("cgal_delaunay")), str(src), str(dst)], check=True,
                   capture_output=True)
    raw = np.fromfile(dst, dtype="<i8")
    assert raw[0] * 3 == len(raw) - 1
    return raw[1:].reshape(-1, 3)


def assert_same_as_cgal(cgal_bin, xy, tmp_path, tag="pts"):
    info = fm.delaunay(xy, return_info=True)
    ref = cgal_triangles(cgal_bin, xy, tmp_path, tag)
    # CGAL keeps whichever copy of a duplicate it inserts first; map its
    # indices to our representative (the smallest row of each group).
    ref = info.vertex_of_input[ref]
    assert len(info.triangles) == len(ref)
    assert tri_set(info.triangles) == tri_set(ref)
    return info


def check_valid(xy: np.ndarray, info) -> None:
    """Every invariant of a Delaunay triangulation, with exact predicates."""
    xy = np.asarray(xy, dtype=np.float64)
    t, h = info.triangles, info.halfedges
    n, m = len(xy), len(t)
    assert t.dtype == np.int64 and h.dtype == np.int64
    assert t.shape == (m, 3) and h.shape == (3 * m,)
    rep = info.vertex_of_input
    assert np.array_equal(xy[rep], xy)
    assert np.all(rep <= np.arange(n)) and np.array_equal(rep[rep], rep)
    uniq = rep == np.arange(n)
    assert info.n_duplicates == n - uniq.sum()
    used = np.zeros(n, bool)
    used[t.ravel()] = True
    assert np.array_equal(used, uniq), "vertices are exactly the distinct points"
    # counter-clockwise
    a, b, c = xy[t[:, 0]], xy[t[:, 1]], xy[t[:, 2]]
    o = fm.orient2d(a, b, c)
    assert np.all(o > 0)
    # half-edge symmetry and endpoints
    e = np.arange(3 * m)
    nxt = np.where(e % 3 == 2, e - 2, e + 1)
    inner = h >= 0
    assert np.array_equal(h[h[inner]], e[inner])
    flat = t.ravel()
    assert np.array_equal(flat[e[inner]], flat[nxt[h[inner]]])
    assert np.array_equal(flat[nxt[inner]], flat[h[inner]])
    # locally Delaunay: apex across each interior edge not inside (exactly)
    tw = h[inner]
    apex = flat[np.where(nxt[tw] % 3 == 2, nxt[tw] - 2, nxt[tw] + 1)]
    tri_of = e[inner] // 3
    d = fm.incircle(xy[t[tri_of, 0]], xy[t[tri_of, 1]], xy[t[tri_of, 2]], xy[apex])
    assert np.all(d <= 0)
    # Euler characteristic of a disk and the triangle count
    hull = int((~inner).sum())
    edges = (3 * m + hull) // 2
    nv = int(uniq.sum())
    assert nv - edges + m == 1
    assert m == 2 * nv - hull - 2
    # areas add up to the convex hull's (Andrew's monotone chain with exact orient2d)
    area = 0.5 * o.sum()
    hull_area = convex_hull_area(xy[uniq])
    assert area == pytest.approx(hull_area, rel=1e-12 * np.sqrt(m + 1), abs=0)


def convex_hull_area(p: np.ndarray) -> float:
    p = p[np.lexsort((p[:, 1], p[:, 0]))]

    def half(pts):
        out = []
        for q in pts:
            while len(out) >= 2 and fm.orient2d(out[-2][None], out[-1][None], q[None])[0] <= 0:
                out.pop()
            out.append(q)
        return out

    lower, upper = half(p), half(p[::-1])
    ring = np.array(lower[:-1] + upper[:-1])
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


# ------------------------------------------------------- CGAL comparisons


@pytest.mark.parametrize("n", [3, 10, 100, 1000, 10_000, 100_000])
def test_identical_to_cgal_uniform_random(cgal_bin, tmp_path, n):
    xy = np.random.default_rng(n).random((n, 2))
    info = assert_same_as_cgal(cgal_bin, xy, tmp_path)
    if n <= 10_000:
        check_valid(xy, info)


def test_identical_to_cgal_300x300_integer_grid(cgal_bin, tmp_path):
    # Every cell is 4 exactly cocircular points: the symbolic perturbation
    # must pick CGAL's diagonal in each of the 89 401 cells.
    g = np.stack(np.meshgrid(np.arange(300.0), np.arange(300.0)), -1).reshape(-1, 2)
    info = assert_same_as_cgal(cgal_bin, g, tmp_path)
    assert len(info.triangles) == 2 * 300 * 300 - 4 * 299 - 2


def test_identical_to_cgal_shuffled_utm_grid_with_duplicates(cgal_bin, tmp_path):
    rng = np.random.default_rng(3)
    g = np.stack(np.meshgrid(np.arange(80.0), np.arange(60.0)), -1).reshape(-1, 2) * 12.5
    g += [550_000.0, 7_820_000.0]
    g = np.concatenate([g, g[rng.choice(len(g), 300)]])
    g = g[rng.permutation(len(g))]
    info = assert_same_as_cgal(cgal_bin, g, tmp_path)
    assert info.n_duplicates == len(g) - len(np.unique(g, axis=0))


@pytest.mark.parametrize("val", ["0.0", "60.0", "250.0", "330.0"])
def test_identical_to_cgal_claudius_horizon(cgal_bin, tmp_path, data_dir, val):
    xy = claudius_horizons(data_dir)[val]
    info = assert_same_as_cgal(cgal_bin, xy, tmp_path, tag=f"claudius{val}")
    check_valid(xy, info)


def test_identical_to_cgal_clustered(cgal_bin, tmp_path):
    rng = np.random.default_rng(5)
    centres = rng.random((20, 2)) * 1000
    xy = np.concatenate([c + rng.normal(scale=s, size=(2000, 2))
                         for c, s in zip(centres, np.geomspace(1e-3, 30, 20))])
    assert_same_as_cgal(cgal_bin, xy, tmp_path)


# Small integer coordinates: duplicates, collinear and cocircular points galore.
int_points = st.lists(st.tuples(st.integers(-6, 6), st.integers(-6, 6)), min_size=3, max_size=80)


def non_degenerate(pts) -> bool:
    p = np.unique(np.asarray(pts, float), axis=0)
    if len(p) < 3:
        return False
    return bool(np.any(fm.orient2d(np.repeat(p[:1], len(p), 0), np.repeat(p[1:2], len(p), 0), p) != 0))


@settings(max_examples=40, deadline=None)
@given(int_points.filter(non_degenerate))
def test_identical_to_cgal_degenerate_integer_sets(cgal_bin, pts):
    xy = np.asarray(pts, dtype=np.float64)
    with tempfile.TemporaryDirectory() as tmp:
        info = assert_same_as_cgal(cgal_bin, xy, Path(tmp))
    check_valid(xy, info)


# ------------------------------------------------- properties (no CGAL)


@settings(max_examples=60, deadline=None)
@given(int_points.filter(non_degenerate), st.randoms(use_true_random=False))
def test_valid_and_independent_of_row_order(pts, rnd):
    xy = np.asarray(pts, dtype=np.float64)
    info = fm.delaunay(xy, return_info=True)
    check_valid(xy, info)
    perm = list(range(len(xy)))
    rnd.shuffle(perm)
    perm = np.array(perm)
    shuffled = fm.delaunay(xy[perm], return_info=True)
    # Compare as point groups: duplicates may be represented by another row.
    rep_old = info.vertex_of_input
    mapped = rep_old[perm[shuffled.triangles]]
    assert tri_set(mapped) == tri_set(info.triangles)


@settings(max_examples=40, deadline=None)
@given(int_points.filter(non_degenerate), st.sampled_from([1e6, -3.5e5, 7.8e6]),
       st.integers(-30, 30))
def test_invariant_under_exact_translation_and_power_of_two_scaling(pts, shift, k):
    # Integer coordinates / 4: translation by these shifts and scaling by 2^k are exact.
    xy = np.asarray(pts, dtype=np.float64) / 4
    ref = tri_set(fm.delaunay(xy))
    assert tri_set(fm.delaunay(xy + shift)) == ref
    assert tri_set(fm.delaunay(np.ldexp(xy, k))) == ref


def test_valid_on_random_and_grid_inputs():
    rng = np.random.default_rng(0)
    for xy in (rng.random((5000, 2)),
               np.stack(np.meshgrid(np.arange(70.0), np.arange(50.0)), -1).reshape(-1, 2),
               np.round(rng.random((3000, 2)) * 30)):  # many duplicates
        check_valid(xy, fm.delaunay(xy, return_info=True))


def test_collinear_with_one_point_off_the_line():
    k = 50
    xy = np.c_[np.arange(k) * 0.5, np.arange(k) * 0.25]
    xy = np.r_[xy, [[3.0, -9.0]]]
    info = fm.delaunay(xy, return_info=True)
    check_valid(xy, info)
    assert len(info.triangles) == k - 1


def test_duplicates_are_merged_and_reported():
    rng = np.random.default_rng(1)
    base = rng.random((200, 2))
    xy = np.r_[base, base[:30], base[:10]]
    info = fm.delaunay(xy, return_info=True)
    assert info.n_duplicates == 40
    assert np.array_equal(info.vertex_of_input[200:230], np.arange(30))
    assert np.array_equal(info.vertex_of_input[230:], np.arange(10))
    assert tri_set(info.triangles) == tri_set(fm.delaunay(base))
    assert "n_duplicates=40" in repr(info)


# ----------------------------------------------------------- contract


def test_output_dtype_shape_and_input_conversions():
    xy = np.random.default_rng(2).random((100, 2))
    t = fm.delaunay(xy)
    assert t.dtype == np.int64 and t.ndim == 2 and t.shape[1] == 3 and t.flags.c_contiguous
    assert tri_set(fm.delaunay(xy.tolist())) == tri_set(t)
    assert tri_set(fm.delaunay(np.asfortranarray(xy))) == tri_set(t)
    ints = np.array([[0, 0], [2, 0], [0, 2], [2, 2], [1, 1]], dtype=np.int32)
    assert len(fm.delaunay(ints)) == 4


@pytest.mark.parametrize("bad", [np.zeros((5, 3)), np.zeros(10), np.zeros((2, 2, 2))])
def test_wrong_shape_is_a_value_error_naming_function_and_shape(bad):
    with pytest.raises(ValueError, match=r"delaunay: xy must have shape \(n, 2\), got"):
        fm.delaunay(bad)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_coordinate_names_the_row(value):
    xy = np.random.default_rng(3).random((10, 2))
    xy[7, 1] = value
    with pytest.raises(ValueError, match="delaunay: xy row 7 has a non-finite"):
        fm.delaunay(xy)


def test_huge_coordinate_is_rejected_before_the_predicates_could_overflow():
    xy = np.array([[0, 0], [1, 0], [0, 1], [3, 2e61]])
    with pytest.raises(ValueError, match="delaunay: xy row 3 has a coordinate beyond"):
        fm.delaunay(xy)
    xy[3, 1] = 1e60
    assert len(fm.delaunay(xy)) == 2


@pytest.mark.parametrize("xy,msg", [
    ([[0, 0], [1, 1]], "at least 3 distinct"),
    ([[0, 0], [1, 1], [0, 0], [1, 1]], "at least 3 distinct"),
    ([[0, 0], [1, 1], [2, 2], [5, 5]], "collinear"),
    (np.zeros((0, 2)), "at least 3 distinct"),
])
def test_degenerate_input_is_a_geometry_error(xy, msg):
    with pytest.raises(fm.GeometryError, match=msg):
        fm.delaunay(np.asarray(xy, dtype=float))
    assert issubclass(fm.GeometryError, ValueError)


def test_gil_is_released_during_triangulation():
    xy = np.random.default_rng(4).random((400_000, 2))
    done = threading.Event()
    ticks = 0

    def work():
        fm.delaunay(xy)
        done.set()

    th = threading.Thread(target=work)
    th.start()
    # With the GIL held for the whole C++ call this loop could not run until
    # the call returned; released, it keeps ticking meanwhile.
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    th.join()
    assert ticks >= 5
