"""faultmesh.AabbTree: batched box / polygon queries equal brute force."""
from __future__ import annotations

import threading
import time
from fractions import Fraction as Fr

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import faultmesh


def brute(boxes, q):
    """Closed-box hits of each query, as lists."""
    hit = ((boxes[None, :, 0] <= q[:, None, 2]) & (boxes[None, :, 2] >= q[:, None, 0])
           & (boxes[None, :, 1] <= q[:, None, 3]) & (boxes[None, :, 3] >= q[:, None, 1]))
    return [np.flatnonzero(h) for h in hit]


def split(offsets, idx):
    return [idx[offsets[i]:offsets[i + 1]] for i in range(len(offsets) - 1)]


def tri_boxes(v, t):
    p = v[t][:, :, :2]
    return np.column_stack([p[:, :, 0].min(1), p[:, :, 1].min(1), p[:, :, 0].max(1), p[:, :, 1].max(1)])


def exact_tri_meets_box(tri, box):
    """Closed triangle meets closed box, exactly (Fractions, separating axes)."""
    t = [(Fr(x), Fr(y)) for x, y in tri]
    x0, y0, x1, y1 = map(Fr, box)
    xs, ys = [p[0] for p in t], [p[1] for p in t]
    if max(xs) < x0 or min(xs) > x1 or max(ys) < y0 or min(ys) > y1:
        return False
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]

    def cr(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    o = cr(*t)
    if o == 0:
        lo, hi = min(t), max(t)
        if lo == hi:
            return True
        s = [cr(lo, hi, c) for c in corners]
        return not (all(x > 0 for x in s) or all(x < 0 for x in s))
    for i in range(3):
        a, b = t[i], t[(i + 1) % 3]
        if all(cr(a, b, c) * o < 0 for c in corners):
            return False
    return True


boxes_st = st.lists(st.tuples(st.integers(0, 60), st.integers(0, 60), st.integers(0, 8), st.integers(0, 8)),
                    min_size=0, max_size=300)


@settings(max_examples=60, deadline=None)
@given(boxes_st, boxes_st)
def test_box_tree_equals_brute_force(bs, qs):
    # Integer boxes: many exact touches, equal boxes, zero-size boxes.
    b = np.array([[x, y, x + w, y + h] for x, y, w, h in bs], dtype=float).reshape(-1, 4)
    q = np.array([[x, y, x + w, y + h] for x, y, w, h in qs], dtype=float).reshape(-1, 4)
    tree = faultmesh.AabbTree.from_boxes(b)
    assert len(tree) == len(b) and tree.kind == "boxes"
    off, idx = tree.query(q)
    assert off.dtype == np.int64 and idx.dtype == np.int64 and off.shape == (len(q) + 1,)
    for got, want in zip(split(off, idx), brute(b, q)):
        np.testing.assert_array_equal(got, want)
    off2, idx2 = tree.query(q, sorted=False)
    np.testing.assert_array_equal(off2, off)
    for got, want in zip(split(off2, idx2), split(off, idx)):
        np.testing.assert_array_equal(np.sort(got), want)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(3, 400))
def test_triangle_tree_box_and_exact_queries(seed, npts):
    rng = np.random.default_rng(seed)
    xy = rng.integers(0, 100, size=(npts, 2)).astype(float)
    try:
        t = faultmesh.delaunay(xy)
    except faultmesh.GeometryError:  # all collinear
        return
    v = np.column_stack([xy, rng.normal(size=npts)])  # z is ignored
    tree = faultmesh.AabbTree(v, t)
    q = rng.integers(-5, 105, size=(150, 2)).astype(float)
    q = np.column_stack([q, q + rng.integers(0, 15, size=(150, 2))])
    off, idx = tree.query(q)
    for got, want in zip(split(off, idx), brute(tri_boxes(v, t), q)):
        np.testing.assert_array_equal(got, want)
    off_e, idx_e = tree.query(q, exact=True)
    for i, got in enumerate(split(off_e, idx_e)):
        cand = idx[off[i]:off[i + 1]]
        want = [c for c in cand if exact_tri_meets_box(xy[t[c]], q[i])]
        np.testing.assert_array_equal(got, want)


def test_segments_and_polygon_queries():
    v = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [5, 5], [6, 7.0]])
    seg = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5]])
    tree = faultmesh.AabbTree.from_segments(v, seg)
    assert tree.kind == "segments" and tree.bounds == (0.0, 0.0, 6.0, 7.0)
    off, idx = tree.query(np.array([[1, -1, 1, 1], [2, 2, 3, 3], [5.5, 5, 5.5, 5.2]]))
    assert [x.tolist() for x in split(off, idx)] == [[0], [1, 2], [4]]
    # Exact: the box of segment (5,5)-(6,7) contains (5.5, 5.1), the segment
    # does not; it passes (5.5, 6).
    off, idx = tree.query(np.array([[1, 1, 1, 1], [5.5, 5, 5.5, 5.2], [5.5, 5.9, 5.5, 6.1]]), exact=True)
    assert [x.tolist() for x in split(off, idx)] == [[], [], [4]]
    off, idx = tree.query_polygons([np.array([[1.5, 1.5], [3, 1.5], [3, 3]]), [[[4, 4], [7, 4], [7, 8]]]])
    assert [x.tolist() for x in split(off, idx)] == [[1, 2], [4]]
    with pytest.raises(ValueError, match="refine"):
        tree.query_polygons([[[0, 0], [1, 0], [1, 1]]], refine=True)


def test_contract_and_errors():
    v = np.array([[0, 0], [1, 0], [0, 1.0]])
    with pytest.raises(ValueError, match=r"row 0 .*out of range"):
        faultmesh.AabbTree(v, np.array([[0, 1, 3]]))
    with pytest.raises(ValueError, match=r"triangles must have shape \(m, 3\)"):
        faultmesh.AabbTree(v, np.array([[0, 1]]))
    nanv = v.copy()
    nanv[2, 1] = np.nan
    with pytest.raises(ValueError, match=r"vertices row 2 \(used by row 0\) has a non-finite"):
        faultmesh.AabbTree(nanv, np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match="box 0"):
        faultmesh.AabbTree.from_boxes(np.array([[1, 0, 0, 1.0]]))
    tree = faultmesh.AabbTree(v, np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match=r"boxes must have shape \(n, 4\)"):
        tree.query(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="exact"):
        faultmesh.AabbTree.from_boxes(np.zeros((1, 4))).query(np.zeros((1, 4)), exact=True)
    off, idx = tree.query(np.zeros((0, 4)))
    assert off.tolist() == [0] and idx.size == 0
    empty = faultmesh.AabbTree(v, np.zeros((0, 3), dtype=np.int64))
    assert len(empty) == 0 and empty.query(np.ones((2, 4)))[0].tolist() == [0, 0, 0]
    # A NaN or inverted query box meets nothing.
    off, idx = tree.query(np.array([[np.nan, 0, 1, 1], [1, 1, 0, 0]]))
    assert idx.size == 0


def test_metamorphic_translate_rotate_duplicate():
    rng = np.random.default_rng(4)
    xy = rng.integers(0, 50, size=(300, 2)).astype(float)
    t = faultmesh.delaunay(xy)
    q = rng.integers(0, 50, size=(100, 2)).astype(float)
    q = np.column_stack([q, q + rng.integers(0, 6, size=(100, 2))])
    base = faultmesh.AabbTree(xy, t).query(q, exact=True)
    s = np.array([1e6, 1e6])
    shifted = faultmesh.AabbTree(xy + s, t).query(q + np.tile(s, 2), exact=True)
    rot = np.column_stack([-xy[:, 1], xy[:, 0]])
    qr = np.column_stack([-q[:, 3], q[:, 0], -q[:, 1], q[:, 2]])
    rotated = faultmesh.AabbTree(rot, t).query(qr, exact=True)
    dup = faultmesh.AabbTree(np.vstack([xy, xy]), np.vstack([t, t + len(xy)])).query(q, exact=True)
    for x in (shifted, rotated):
        np.testing.assert_array_equal(x[0], base[0])
        np.testing.assert_array_equal(x[1], base[1])
    np.testing.assert_array_equal(dup[0], 2 * base[0])
    for got, want in zip(split(*dup), split(*base)):
        np.testing.assert_array_equal(got, np.concatenate([want, want + len(t)]))


def test_gil_released_during_build_and_query():
    rng = np.random.default_rng(1)
    b = rng.uniform(0, 1000, size=(600_000, 2))
    boxes = np.column_stack([b, b + 1.0])
    done = threading.Event()
    result = {}

    def work():
        tree = faultmesh.AabbTree.from_boxes(boxes)
        result["hits"] = tree.query(boxes)[1].size
        done.set()

    th = threading.Thread(target=work)
    ticks = 0
    th.start()
    time.sleep(0.01)
    while not done.is_set():
        ticks += 1
    th.join()
    assert result["hits"] >= len(boxes)
    # Without releasing the GIL the main thread could only run between the
    # two C++ calls (a few switch intervals); released, it spins throughout.
    assert ticks > 1000


def test_agrees_with_cgal(cgal_bin, tmp_path):
    """Same triangles and boxes through CGAL (bench/cgal/cgal_aabb.cpp): the
    AABB_tree answers (exact triangle/box hits) equal query(exact=True) query
    by query, and box_intersection_d's pair count equals query()'s."""
    import csv
    import subprocess
    from pathlib import Path

    data = Path(__file__).resolve().parent / "data" / "claudius" / "claudius.csv"
    xy = np.array([[float(r["X"]), float(r["Y"])] for r in csv.DictReader(open(data)) if r["val"] == "330.0"])
    t = faultmesh.delaunay(xy)
    rng = np.random.default_rng(8)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    c = lo + rng.random((3000, 2)) * (hi - lo)
    q = np.column_stack([c, c + rng.random((3000, 2)) * 200.0])
    # Boxes whose corners are mesh vertices: exact contacts on both sides.
    v = xy[rng.integers(0, len(xy), 500)]
    q = np.vstack([q, np.column_stack([v, v + 50.0]), np.column_stack([v - 50.0, v])])

    def write(name, a, dtype):
        p = tmp_path / name
        a = np.ascontiguousarray(a, dtype=dtype)
        with open(p, "wb") as f:
            f.write(np.int64(len(a)).tobytes())
            f.write(a.tobytes())
        return str(p)

    files = [write("v.bin", xy, "<f8"), write("t.bin", t, "<i8"), write("q.bin", q, "<f8")]
    tree = faultmesh.AabbTree(xy, t)
    exe = str(cgal_bin("cgal_aabb"))
    out = tmp_path / "hits.bin"
    subprocess.run([exe, "tree", *files, str(out)], check=True, capture_output=True)
    a = np.fromfile(out, dtype="<i8")
    off, idx = tree.query(q, exact=True)
    assert a[0] == idx.size
    np.testing.assert_array_equal(a[1:2 + len(q)], off)
    np.testing.assert_array_equal(a[2 + len(q):], idx)
    r = subprocess.run([exe, "boxd", *files], check=True, capture_output=True, text=True)
    import json
    assert json.loads(r.stdout)["hits"] == tree.query(q)[1].size


def test_tree_owns_its_arrays():
    """Regression (issue 10): the tree kept the caller's arrays; changing them
    afterwards made query(exact=True) read out of bounds (ASan:
    heap-buffer-overflow in triangle_meets_box)."""
    rng = np.random.default_rng(11)
    V = rng.random((500, 2))
    T = faultmesh.delaunay(V)
    S = np.ascontiguousarray(T[:, :2])
    tree = faultmesh.AabbTree(V, T)
    stree = faultmesh.AabbTree.from_segments(V, S)
    q = np.c_[rng.random((200, 2)) * 0.9, rng.random((200, 2)) * 0.9]
    q = np.c_[np.minimum(q[:, :2], q[:, 2:]), np.maximum(q[:, :2], q[:, 2:])]
    ref = [np.concatenate(t.query(q, exact=True)) for t in (tree, stree)]
    T[:] = 2**40
    S[:] = 2**40
    V[:] = np.nan
    got = [np.concatenate(t.query(q, exact=True)) for t in (tree, stree)]
    assert all(np.array_equal(a, b) for a, b in zip(ref, got))


def test_every_property_and_the_coordinate_limit():
    v = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], float)
    tree = faultmesh.AabbTree(v, np.array([[0, 1, 2], [1, 3, 2]]))
    assert (tree.size, len(tree), tree.kind, tree.depth, tree.node_count) == (2, 2, "triangles", 1, 0)
    assert tree.bounds == (0.0, 0.0, 1.0, 1.0)
    assert faultmesh.AabbTree.from_boxes(np.zeros((1, 4))).kind == "boxes"
    with pytest.raises(ValueError, match=r"AabbTree.from_triangles: vertices row 3 \(used by row 1\) has a "
                                         r"coordinate beyond \+-1e\+60 \(x = 1e\+61\)"):
        faultmesh.AabbTree(v * [[1], [1], [1], [1e61]], np.array([[0, 1, 2], [1, 3, 2]]))
    with pytest.raises(ValueError, match=r"AabbTree.query\(exact=True\): boxes row 1 has a coordinate beyond"):
        tree.query(np.array([[0, 0, 1, 1], [0, 0, 1e300, 1]]), exact=True)
    # Plain box queries only compare: any box is fine there.
    assert list(tree.query(np.array([[-np.inf, -np.inf, np.inf, np.inf]]))[1]) == [0, 1]
    with pytest.raises(ValueError, match=r"AabbTree: triangles row 1 has a negative vertex index -1"):
        faultmesh.AabbTree(v, np.array([[0, 1, 2], [1, -1, 2]]))
    with pytest.raises(ValueError, match=r"AabbTree: triangles row 0 has the value 1.5, not an integer"):
        faultmesh.AabbTree(v, np.array([[0, 1.5, 2]]))
    with pytest.raises(ValueError, match=r"AabbTree: triangles must hold integers, got dtype bool"):
        faultmesh.AabbTree(v, np.ones((1, 3), bool))
