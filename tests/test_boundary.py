"""faultmesh.boundary_loops / boundary_contours / boundary_edges / sort_segments."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import faultmesh

DATA = Path(__file__).resolve().parent / "data"


def grid_tris(n, removed=()):
    """(n+1)^2 grid vertices, 2 CCW triangles per cell; `removed` cells left out."""
    removed = set(removed)
    t = []
    for j in range(n):
        for i in range(n):
            if (i, j) in removed:
                continue
            a, b, c, d = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i
            t += [[a, b, c], [a, c, d]]
    return np.array(t, dtype=np.int64).reshape(-1, 3)


def grid_xy(n):
    xs, ys = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0))
    return np.column_stack([xs.ravel(), ys.ravel()])


def signed_area(xy, loop):
    p = xy[loop]
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]))


def canonical(loop):
    """Rotate a loop to start at its smallest (from, to) edge, as the library does."""
    loop = list(loop)
    k = len(loop)
    best = min(range(k), key=lambda i: (loop[i], loop[(i + 1) % k]))
    return loop[best:] + loop[:best]


def block_loop(n, i0, j0, i1, j1):
    """Clockwise vertex loop around the removed block of cells [i0,i1) x [j0,j1)."""
    vid = lambda i, j: j * (n + 1) + i  # noqa: E731
    pts = [vid(i, j0) for i in range(i0, i1)] + [vid(i1, j) for j in range(j0, j1)]
    pts += [vid(i, j1) for i in range(i1, i0, -1)] + [vid(i0, j) for j in range(j1, j0, -1)]
    return canonical(pts[::-1])


@st.composite
def blocks(draw):
    """Rectangular blocks, each inside its own 4x4 tile with a margin, so holes
    never touch each other or the outer boundary."""
    tiles = draw(st.lists(st.tuples(st.integers(0, 3), st.integers(0, 3)), max_size=6, unique=True))
    out = []
    for ti, tj in tiles:
        i0 = 4 * ti + 1 + draw(st.integers(0, 1))
        j0 = 4 * tj + 1 + draw(st.integers(0, 1))
        out.append((i0, j0, i0 + draw(st.integers(1, 4 * ti + 3 - i0)), j0 + draw(st.integers(1, 4 * tj + 3 - j0))))
    return out


@settings(max_examples=60, deadline=None)
@given(blocks(), st.randoms(use_true_random=False))
def test_grid_with_rectangular_holes(bl, rnd):
    n = 16
    removed = [(i, j) for i0, j0, i1, j1 in bl for i in range(i0, i1) for j in range(j0, j1)]
    t = grid_tris(n, removed)
    # Shuffle the triangles and rotate each: the loops must not change.
    order = list(range(len(t)))
    rnd.shuffle(order)
    t = np.array([np.roll(t[k], rnd.randrange(3)) for k in order], dtype=np.int64)
    loops = faultmesh.boundary_loops(t)
    xy = grid_xy(n)
    outer = [l for l in loops if signed_area(xy, l) > 0]
    holes = sorted(canonical(l.tolist()) for l in loops if signed_area(xy, l) < 0)
    assert len(outer) == 1 and signed_area(xy, outer[0]) == n * n
    assert holes == sorted(block_loop(n, *b) for b in bl)
    assert all(l.dtype == np.int64 for l in loops)
    # Duplicating the mesh (second copy with its own vertices) doubles the loops.
    nv = (n + 1) ** 2
    loops2 = faultmesh.boundary_loops(np.vstack([t, t + nv]))
    assert len(loops2) == 2 * len(loops)
    assert sorted(map(tuple, (l.tolist() for l in loops2))) == sorted(
        [tuple(l.tolist()) for l in loops] + [tuple((l + nv).tolist()) for l in loops])


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(20, 300))
def test_delaunay_tin_with_holes_green_theorem(seed, npts):
    """Random Delaunay TIN with triangles removed around random centres.
    Whatever the topology (pinches included), the loops of the full report
    cover every boundary edge once and, by Green's theorem, their signed areas
    add up to the area of the triangles."""
    rng = np.random.default_rng(seed)
    xy = rng.integers(0, 200, size=(npts, 2)).astype(float)
    t = faultmesh.delaunay(xy)
    cen = xy[t].mean(axis=1)
    c = rng.uniform(0, 200, size=(3, 2))
    keep = np.all(np.linalg.norm(cen[:, None, :] - c[None], axis=2) > rng.uniform(10, 40), axis=1)
    t = t[keep]
    if len(t) == 0:
        return
    rep = faultmesh.boundary_contours(t)
    assert rep.open_chains == [] and rep.inconsistent_edges.shape == (0, 2)
    edges = sorted(map(tuple, faultmesh.boundary_edges(t).tolist()))
    loop_edges = sorted((int(l[i]), int(l[(i + 1) % len(l)])) for l in rep.loops for i in range(len(l)))
    assert loop_edges == edges
    p = xy[t]
    tri_area = 0.5 * np.sum((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                            - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    assert sum(signed_area(xy, l) for l in rep.loops) == pytest.approx(tri_area, rel=1e-12)
    if rep.pinch_vertices.size == 0:
        assert len(faultmesh.boundary_loops(t)) == len(rep.loops)
    else:
        with pytest.raises(faultmesh.GeometryError, match=f"vertex {rep.pinch_vertices[0]}"):
            faultmesh.boundary_loops(t)
        assert len(faultmesh.boundary_loops(t, strict=False)) == len(rep.loops)


def test_real_data_claudius_horizon():
    rows = [r for r in csv.DictReader(open(DATA / "claudius" / "claudius.csv")) if r["val"] == "60.0"]
    xy = np.array([[float(r["X"]), float(r["Y"])] for r in rows])
    t = faultmesh.delaunay(xy)
    loops = faultmesh.boundary_loops(t)
    assert len(loops) == 1 and signed_area(xy, loops[0]) > 0  # convex hull, CCW
    p = xy[t]
    tri_area = 0.5 * np.sum((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                            - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    # Removing the triangles whose centroid lies in a box leaves a hole whose
    # boundary touches itself: a pinch, reported and resolved through the fans.
    cen = xy[t].mean(axis=1)
    box = (cen[:, 0] > 550000) & (cen[:, 0] < 551000) & (cen[:, 1] > 7818000) & (cen[:, 1] < 7819000)
    rep = faultmesh.boundary_contours(t[~box])
    assert rep.pinch_vertices.size > 0 and rep.open_chains == []
    with pytest.raises(faultmesh.GeometryError, match=f"vertex {rep.pinch_vertices[0]}"):
        faultmesh.boundary_loops(t[~box])
    q = xy[t[box]]
    box_area = 0.5 * np.sum((q[:, 1, 0] - q[:, 0, 0]) * (q[:, 2, 1] - q[:, 0, 1])
                            - (q[:, 1, 1] - q[:, 0, 1]) * (q[:, 2, 0] - q[:, 0, 0]))
    assert sum(signed_area(xy, l) for l in rep.loops) == pytest.approx(tri_area - box_area, rel=1e-9)
    # The workflow's way: remove a grown disk -> exactly one CW hole loop.
    region = np.array([[550000, 7818000], [551000, 7818000], [551000, 7819000], [550000, 7819000.0]])
    removed = faultmesh.overlapping_triangles(xy, t, region, grow_to_disk=True)
    kept = np.setdiff1d(np.arange(len(t)), removed)
    loops = faultmesh.boundary_loops(t[kept])
    areas = sorted(signed_area(xy, l) for l in loops)
    assert len(loops) == 2 and areas[0] < 0 < areas[1]
    assert areas[1] == pytest.approx(signed_area(xy, faultmesh.boundary_loops(t)[0]), rel=1e-12)
    hole = faultmesh.boundary_loops(t[removed])
    assert len(hole) == 1 and sorted(hole[0].tolist()) == sorted(min(loops, key=len).tolist())


def test_pinch_vertex_strict_and_report():
    t = np.array([[0, 1, 2], [0, 3, 4]])
    with pytest.raises(faultmesh.GeometryError, match="vertex 0"):
        faultmesh.boundary_loops(t)
    assert issubclass(faultmesh.GeometryError, ValueError)
    rep = faultmesh.boundary_contours(t)
    assert [l.tolist() for l in rep.loops] == [[0, 1, 2], [0, 3, 4]]
    assert rep.pinch_vertices.tolist() == [0]
    assert not rep.clean
    assert [l.tolist() for l in faultmesh.boundary_loops(t, strict=False)] == [[0, 1, 2], [0, 3, 4]]


def test_open_chains_and_bad_edges_reported():
    flipped = np.array([[0, 1, 2], [1, 2, 3]])  # shared edge used twice in one direction
    rep = faultmesh.boundary_contours(flipped)
    assert rep.inconsistent_edges.tolist() == [[1, 2]]
    assert len(rep.open_chains) > 0
    with pytest.raises(faultmesh.GeometryError, match="inconsistent"):
        faultmesh.boundary_loops(flipped)
    nm = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    assert faultmesh.boundary_contours(nm).nonmanifold_edges.tolist() == [[0, 1]]
    with pytest.raises(faultmesh.GeometryError, match="non-manifold"):
        faultmesh.boundary_loops(nm)


def test_sort_segments_algorithm1():
    rng = np.random.default_rng(0)
    seg = np.array([[i, (i + 1) % 12] for i in range(12)] + [[30, 31], [31, 32]])
    for _ in range(5):
        s = seg[rng.permutation(len(seg))]
        rep = faultmesh.sort_segments(s)
        assert [l.tolist() for l in rep.loops] == [list(range(12))]
        assert [c.tolist() for c in rep.open_chains] == [[30, 31, 32]]


def test_contract():
    t = grid_tris(3)
    e = faultmesh.boundary_edges(t)
    assert e.dtype == np.int64 and e.shape == (12, 2)
    assert faultmesh.boundary_loops(t.astype(np.int32))[0].dtype == np.int64
    assert faultmesh.boundary_loops(np.zeros((0, 3), dtype=np.int64)) == []
    with pytest.raises(ValueError, match=r"shape \(m, 3\)"):
        faultmesh.boundary_loops(np.zeros((4, 2), dtype=np.int64))
    with pytest.raises(ValueError, match="row 1"):
        faultmesh.boundary_loops(np.array([[0, 1, 2], [0, -1, 2]]))
    with pytest.raises(ValueError, match="repeats vertex"):
        faultmesh.boundary_loops(np.array([[0, 1, 1]]))
    with pytest.raises(ValueError, match="out of range"):
        faultmesh.boundary_loops(np.array([[0, 1, 7]]), n_vertices=5)


def test_n_vertices_must_be_a_positive_integer():
    """Regression (issue 10): n_vertices=3.5 gave a pybind11 cast error."""
    t = np.array([[0, 1, 2]])
    for bad in (3.5, "3", -1, 0, True, np.nan):
        with pytest.raises(ValueError, match=r"boundary_loops: n_vertices must be a positive integer"):
            faultmesh.boundary_loops(t, n_vertices=bad)
    assert len(faultmesh.boundary_loops(t, n_vertices=np.int32(3))) == 1
    assert len(faultmesh.boundary_loops(t, n_vertices=3.0)) == 1
    with pytest.raises(ValueError, match=r"boundary_contours: triangles row 1 has vertex index 3 out of range \[0, 3\)"):
        faultmesh.boundary_contours(np.array([[0, 1, 2], [1, 3, 2]]), n_vertices=3)


def test_huge_indices_never_allocate_by_the_largest_index():
    """Regression (issue 10): boundary_loops([[0, 1, 2**31 - 2]]) raised
    bad_alloc (tables sized by the largest index). The used vertices are
    renumbered internally; the output is the same as for small numbers."""
    big = [2**31 - 2, 2**40, 2**62]
    for b in big:
        t = np.array([[0, 1, b]])
        assert [list(x) for x in faultmesh.boundary_loops(t)] == [[0, 1, b]]
        assert [list(x) for x in faultmesh.boundary_loops(t, n_vertices=b + 1)] == [[0, 1, b]]
    # A mesh whose upper vertex numbers are moved far away (a monotone map):
    # the same report and edge order, mapped.
    t = np.array(faultmesh.delaunay(np.random.default_rng(3).random((300, 2))))
    far = np.where(t >= 150, t + 10**15, t)
    m = dict(zip(t.ravel(), far.ravel()))
    ref, got = faultmesh.boundary_contours(t), faultmesh.boundary_contours(far)
    assert [[m[v] for v in l] for l in ref.loops] == [list(l) for l in got.loops]
    edges = faultmesh.boundary_edges(t)
    assert np.array_equal(np.vectorize(m.get)(edges), faultmesh.boundary_edges(far))


def test_index_arrays_must_hold_non_negative_integers():
    """Regression (issue 10): float index arrays were truncated silently
    (0.5 -> 0); negative indices must name the row."""
    with pytest.raises(ValueError, match=r"boundary_loops: triangles row 1 has the value 2.5, not an integer"):
        faultmesh.boundary_loops(np.array([[0, 1, 2], [1, 2.5, 3]]))
    with pytest.raises(ValueError, match=r"sort_segments: segments row 2 has a negative vertex index -4"):
        faultmesh.sort_segments(np.array([[0, 1], [1, 2], [2, -4]]))
    with pytest.raises(ValueError, match=r"boundary_edges: triangles row 0 has index 18446744073709551615, beyond"):
        faultmesh.boundary_edges(np.array([[0, 1, 2**64 - 1]], np.uint64))
    with pytest.raises(ValueError, match=r"boundary_loops: triangles must hold integers, got dtype <U1"):
        faultmesh.boundary_loops(np.array([["0", "1", "2"]]))
    assert len(faultmesh.boundary_loops(np.array([[0.0, 1.0, 2.0]]))) == 1


def test_every_property_of_the_report():
    rep = faultmesh.boundary_contours(np.array([[0, 1, 2], [0, 3, 4]]))  # a pinch at vertex 0
    props = sorted(k for k in dir(faultmesh.BoundaryContours)
                   if isinstance(getattr(faultmesh.BoundaryContours, k), property))
    values = {k: getattr(rep, k) for k in props}
    assert list(values["pinch_vertices"]) == [0] and values["clean"] is False
    assert len(values["loops"]) == 2 and values["open_chains"] == []
    for k in ("nonmanifold_edges", "inconsistent_edges"):
        assert values[k].shape == (0, 2)
    assert values["chain_break_vertices"].shape == (0,)
    assert "BoundaryContours(loops=2" in repr(rep)
