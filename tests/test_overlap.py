"""faultmesh.overlapping_triangles: exact two-stage overlap test and disk growth.

The reference is independent of the C++ code: exact rational (Fraction)
Sutherland-Hodgman clipping gives area(T & R); a triangle overlaps iff that
area is positive (both interiors are open sets).
"""
from __future__ import annotations

from fractions import Fraction as Fr
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import faultmesh

DATA = Path(__file__).resolve().parent / "data"


# ---------------------------------------------------------------- references
def _cross(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _shoelace(poly):
    s = Fr(0)
    for i in range(len(poly)):
        p, q = poly[i], poly[(i + 1) % len(poly)]
        s += p[0] * q[1] - p[1] * q[0]
    return s / 2


def _clip_area(ring, tri):
    """|area(ring & tri)| exactly; ring a simple polygon, tri counter-clockwise."""
    out = [(Fr(x), Fr(y)) for x, y in ring]
    for i in range(3):
        a, b = tri[i], tri[(i + 1) % 3]
        inp, out = out, []
        for j in range(len(inp)):
            p, q = inp[j], inp[(j + 1) % len(inp)]
            sp, sq = _cross(a, b, p), _cross(a, b, q)
            if sp >= 0:
                out.append(p)
            if (sp > 0 > sq) or (sp < 0 < sq):
                t = sp / (sp - sq)
                out.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))
        if not out:
            return Fr(0)
    return abs(_shoelace(out))


def reference_overlap(vertices, triangles, rings, signs):
    """Triangles whose interior meets the region sum(sign_i * ring_i) (rings
    non-crossing, signs +1 for outer rings, -1 for holes)."""
    out = []
    rb = np.vstack(rings)
    lo, hi = rb.min(axis=0), rb.max(axis=0)
    for t, (i, j, k) in enumerate(triangles):
        tri = [(Fr(vertices[v][0]), Fr(vertices[v][1])) for v in (i, j, k)]
        xs = [p[0] for p in tri]
        ys = [p[1] for p in tri]
        if max(xs) < lo[0] or min(xs) > hi[0] or max(ys) < lo[1] or min(ys) > hi[1]:
            continue
        o = _cross(*tri)
        if o == 0:
            continue
        if o < 0:
            tri = [tri[0], tri[2], tri[1]]
        area = sum(s * _clip_area(r, tri) for r, s in zip(rings, signs))
        if area > 0:
            out.append(t)
    return np.array(out, dtype=np.int64)


def _seg_meets(p, q, r, s):
    """Closed segments pq and rs share a point (exact on Fractions)."""
    d1, d2 = _cross(p, q, r), _cross(p, q, s)
    d3, d4 = _cross(r, s, p), _cross(r, s, q)
    if ((d1 > 0 > d2) or (d1 < 0 < d2)) and ((d3 > 0 > d4) or (d3 < 0 < d4)):
        return True

    def on(a, b, c):
        return min(a[0], b[0]) <= c[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= c[1] <= max(a[1], b[1])

    return ((d1 == 0 and on(p, q, r)) or (d2 == 0 and on(p, q, s))
            or (d3 == 0 and on(r, s, p)) or (d4 == 0 and on(r, s, q)))


def _inside(pt, rings):
    """Even-odd parity of a point that is on no ring edge."""
    c = 0
    for ring in rings:
        for i in range(len(ring)):
            a, b = ring[i], ring[(i + 1) % len(ring)]
            if (a[1] > pt[1]) != (b[1] > pt[1]):
                o = _cross(a, b, pt)
                if (b[1] > pt[1] and o > 0) or (a[1] > pt[1] and o < 0):
                    c += 1
    return c % 2 == 1


def _boundary_pieces(rings):
    """The region's true boundary: ring edges split at every ring vertex on
    them, equal pieces cancelling in pairs (a side shared by two rings, or a
    hole side lying on the outer ring, is not boundary)."""
    fr = [[(Fr(x), Fr(y)) for x, y in r] for r in rings]
    verts = {p for r in fr for p in r}
    count = {}
    for r in fr:
        for i in range(len(r)):
            a, b = r[i], r[(i + 1) % len(r)]
            if a == b:
                continue
            on = [v for v in verts if v not in (a, b) and _cross(a, b, v) == 0
                  and min(a[0], b[0]) <= v[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= v[1] <= max(a[1], b[1])]
            pts = sorted([a, b] + on)
            for u, w in zip(pts, pts[1:]):
                count[(u, w)] = count.get((u, w), 0) + 1
    return [k for k, c in count.items() if c % 2 == 1]


def segment_meets_closure(p, q, rings):
    p = (Fr(p[0]), Fr(p[1]))
    q = (Fr(q[0]), Fr(q[1]))
    pieces = _boundary_pieces(rings)
    if any(_seg_meets(p, q, a, b) for a, b in pieces):
        return True
    # Off the boundary: the segment lies in one face; its endpoint's parity
    # (counted on the pieces, so cancelled sides count evenly) decides.
    return _inside(p, [[a, b] for a, b in pieces])


def grid(n, z=True):
    xs, ys = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0))
    v = np.column_stack([xs.ravel(), ys.ravel(), (xs * ys).ravel()])
    tris = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i
            tris += [[a, b, c], [a, c, d]]
    return (v if z else v[:, :2]), np.array(tris, dtype=np.int64)


def rect(x0, y0, x1, y1, ccw=True):
    r = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)
    return r if ccw else r[::-1].copy()


# ---------------------------------------------------------------- strategies
@st.composite
def star_region(draw, n):
    """A simple star-shaped polygon with half-integer vertices (exact contacts
    with the grid are frequent), possibly extending outside the mesh."""
    cx = draw(st.integers(2, 2 * n - 2)) / 2
    cy = draw(st.integers(2, 2 * n - 2)) / 2
    k = draw(st.integers(3, 8))
    pts = draw(st.lists(st.tuples(st.integers(-2, 2 * n + 2), st.integers(-2, 2 * n + 2)),
                        min_size=k, max_size=k, unique=True))
    pts = [(x / 2, y / 2) for x, y in pts if (x / 2, y / 2) != (cx, cy)]
    pts.sort(key=lambda p: np.arctan2(p[1] - cy, p[0] - cx))
    c = (cx, cy)
    # Strict turn around the centre between consecutive vertices: distinct
    # directions and every angular gap < pi, so the polygon is simple.
    assume(len(pts) >= 3)
    for i in range(len(pts)):
        assume(_cross(c, pts[i], pts[(i + 1) % len(pts)]) > 0)
    return np.array(pts, dtype=float)


@st.composite
def block_region(draw, n):
    """Disjoint axis-aligned rectangles (sharing sides allowed), optionally one
    with a hole; returns rings and their signs."""
    rings, signs = [], []
    cells = draw(st.lists(st.tuples(st.integers(0, n // 2 - 1), st.integers(0, n // 2 - 1)),
                          min_size=1, max_size=4, unique=True))
    half = draw(st.booleans())
    for i, j in cells:
        x0, y0 = 2 * i + (0.5 if half else 0), 2 * j
        rings.append(rect(x0, y0, x0 + 2, y0 + 2, ccw=draw(st.booleans())))
        signs.append(1)
    if draw(st.booleans()):
        i, j = cells[0]
        x0, y0 = 2 * i + (0.5 if half else 0), 2 * j
        rings.append(rect(x0 + 0.5, y0 + 0.5, x0 + 1.5, y0 + 1.5 + draw(st.sampled_from([0, 0.5]))))
        signs.append(-1)
    return rings, signs


N = 8
V, T = grid(N)


# ---------------------------------------------------------------- exactness
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(star_region(N))
def test_star_regions_equal_exact_reference(ring):
    got = faultmesh.overlapping_triangles(V, T, ring)
    assert got.dtype == np.int64
    np.testing.assert_array_equal(got, reference_overlap(V, T, [ring], [1]))


@settings(max_examples=40, deadline=None)
@given(block_region(N))
def test_block_regions_with_holes_equal_exact_reference(region):
    rings, signs = region
    got = faultmesh.overlapping_triangles(V, T, rings)
    np.testing.assert_array_equal(got, reference_overlap(V, T, rings, signs))


def test_touching_only_does_not_count():
    # Square on grid lines: exactly the 2 * 3 * 3 triangles of its cells.
    got = faultmesh.overlapping_triangles(V, T, rect(2, 3, 5, 6))
    cells = [(i, j) for j in range(3, 6) for i in range(2, 5)]
    want = sorted(2 * (j * N + i) + k for i, j in cells for k in (0, 1))
    assert got.tolist() == want
    # A region that only touches the mesh at one vertex from outside.
    assert faultmesh.overlapping_triangles(V, T, [[8, 8], [9, 8], [9, 9]]).size == 0
    # A mesh triangle as the region: only itself.
    assert faultmesh.overlapping_triangles(V, T, V[T[37], :2]).tolist() == [37]


def test_ring_formats_and_tree_reuse():
    ring = [[1.5, 1.5], [4.5, 1.0], [3.0, 4.0]]
    a = faultmesh.overlapping_triangles(V, T, ring)  # list of points
    b = faultmesh.overlapping_triangles(V, T, np.array(ring))  # one array
    c = faultmesh.overlapping_triangles(V, T, [np.array(ring)])  # list of rings
    d = faultmesh.overlapping_triangles(V[:, :2], T.astype(np.int32), [ring + [ring[0]]])  # closed, 2D, int32
    tree = faultmesh.AabbTree(V, T)
    e = faultmesh.overlapping_triangles(V, T, ring, tree=tree)
    for x in (b, c, d, e):
        np.testing.assert_array_equal(a, x)
    offsets, idx = tree.query_polygons([ring, [rect(0, 0, 1, 1)]], refine=True)
    np.testing.assert_array_equal(idx[offsets[0]:offsets[1]], a)


# ---------------------------------------------------------------- metamorphic
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(star_region(N))
def test_translation_rotation_and_duplication(ring):
    base = faultmesh.overlapping_triangles(V, T, ring)
    # Translation by 1e6 is exact for these half-integer coordinates.
    shift = np.array([1e6, -1e6])
    Vt = V.copy()
    Vt[:, :2] += shift
    np.testing.assert_array_equal(faultmesh.overlapping_triangles(Vt, T, ring + shift), base)
    # Rotation by 90 degrees, (x, y) -> (-y, x), is exact.
    Vr = V.copy()
    Vr[:, 0], Vr[:, 1] = -V[:, 1], V[:, 0]
    rr = np.column_stack([-ring[:, 1], ring[:, 0]])
    np.testing.assert_array_equal(faultmesh.overlapping_triangles(Vr, T, rr), base)
    # Two disjoint copies of mesh and region: twice the answer.
    off = np.array([100.0, 0.0])
    V2 = np.vstack([V, V + np.array([100.0, 0.0, 0.0])])
    T2 = np.vstack([T, T + len(V)])
    got = faultmesh.overlapping_triangles(V2, T2, [ring, ring + off])
    np.testing.assert_array_equal(got, np.concatenate([base, base + len(T)]))


# ---------------------------------------------------------------- growth
def _euler(tris):
    e = {tuple(sorted(x)) for t in tris for x in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    return len(np.unique(tris)) - len(e) + len(tris)


def check_disk(vertices, triangles, removed, rings, allow_boundary=False):
    sub = triangles[removed]
    assert _euler(sub) == 1
    loops = faultmesh.boundary_loops(sub)  # strict: raises on pinch / open chain
    assert len(loops) == 1
    mesh_bnd = {tuple(sorted(e)) for e in faultmesh.boundary_edges(triangles).tolist()}
    for a, b in faultmesh.boundary_edges(sub).tolist():
        if allow_boundary and tuple(sorted((a, b))) in mesh_bnd:
            continue
        assert not segment_meets_closure(vertices[a], vertices[b], rings), (a, b)
    # The kept part stays one pinch-free piece: the mesh's outer loop plus the
    # hole left by the removed disk, or a single loop if the disk reaches the
    # mesh boundary.
    kept = np.setdiff1d(np.arange(len(triangles)), removed)
    c = faultmesh.boundary_contours(triangles[kept])
    touches = bool(np.isin(sub, np.unique(list(mesh_bnd))).any())
    assert c.clean and len(c.loops) == (1 if touches else 2)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(star_region(12))
def test_grow_to_disk_properties(ring):
    v, t = grid(12)
    plain = faultmesh.overlapping_triangles(v, t, ring)
    assume(plain.size > 0)
    try:
        grown = faultmesh.overlapping_triangles(v, t, ring, grow_to_disk=True)
    except faultmesh.GeometryError as e:
        assert "allow_mesh_boundary" in str(e)
        grown = faultmesh.overlapping_triangles(v, t, ring, grow_to_disk=True, allow_mesh_boundary=True)
        assert np.isin(grown, plain).sum() == plain.size
        check_disk(v, t, grown, [ring], allow_boundary=True)
        return
    assert np.all(np.isin(plain, grown))
    check_disk(v, t, grown, [ring])
    # Metamorphic: translation and rotation give the same grown set.
    vr = v.copy()
    vr[:, 0], vr[:, 1] = -v[:, 1] + 1e6, v[:, 0]
    rr = np.column_stack([-ring[:, 1] + 1e6, ring[:, 0]])
    np.testing.assert_array_equal(faultmesh.overlapping_triangles(vr, t, rr, grow_to_disk=True), grown)


@settings(max_examples=25, deadline=None)
@given(block_region(10))
def test_grow_blocks_joins_and_fills(region):
    rings, _ = region
    v, t = grid(15)
    rings = [r + 2.0 for r in rings]  # keep the grown set away from the mesh boundary
    grown = faultmesh.overlapping_triangles(v, t, rings, grow_to_disk=True)
    check_disk(v, t, grown, rings)


def test_mesh_boundary_needs_the_option():
    v, t = grid(10)
    strip = rect(-1, 4, 3, 6)
    with pytest.raises(faultmesh.GeometryError, match="allow_mesh_boundary"):
        faultmesh.overlapping_triangles(v, t, strip, grow_to_disk=True)
    grown = faultmesh.overlapping_triangles(v, t, strip, grow_to_disk=True, allow_mesh_boundary=True)
    check_disk(v, t, grown, [strip], allow_boundary=True)


def test_real_data_claudius_horizon_and_fault_outline():
    import csv
    rows = list(csv.DictReader(open(DATA / "claudius" / "claudius.csv")))
    xyz = np.array([[float(r["X"]), float(r["Y"]), float(r["Z"])] for r in rows if r["val"] == "0.0"])
    tri = faultmesh.delaunay(xyz[:, :2])
    fp = np.loadtxt(DATA / "claudius" / "fault_points.csv", delimiter=",", skiprows=1, usecols=(0, 1))
    # The fault's XY outline: convex hull of its points (gift wrapping with
    # exact orientation via faultmesh.orient2d is overkill here; scipy does it).
    from scipy.spatial import ConvexHull
    hull = fp[ConvexHull(fp).vertices]
    got = faultmesh.overlapping_triangles(xyz, tri, hull)
    np.testing.assert_array_equal(got, reference_overlap(xyz, tri, [hull], [1]))
    assert got.size > 0
    # The fault's outline runs past the horizon data's southern edge: the
    # paper's boundary-fault case (F22).
    with pytest.raises(faultmesh.GeometryError, match="allow_mesh_boundary"):
        faultmesh.overlapping_triangles(xyz, tri, hull, grow_to_disk=True)
    grown = faultmesh.overlapping_triangles(xyz, tri, hull, grow_to_disk=True, allow_mesh_boundary=True)
    check_disk(xyz, tri, grown, [hull], allow_boundary=True)
    # The same outline moved 2 km north lies inside the study area.
    inner = hull + np.array([0.0, 2000.0])
    got = faultmesh.overlapping_triangles(xyz, tri, inner)
    np.testing.assert_array_equal(got, reference_overlap(xyz, tri, [inner], [1]))
    grown = faultmesh.overlapping_triangles(xyz, tri, inner, grow_to_disk=True)
    check_disk(xyz, tri, grown, [inner])


# ---------------------------------------------------------------- contract
def test_bad_input_messages():
    with pytest.raises(ValueError, match="vertices"):
        faultmesh.overlapping_triangles(np.zeros((3, 4)), T, rect(0, 0, 1, 1))
    bad = T.copy()
    bad[5, 1] = 10_000
    with pytest.raises(ValueError, match="row 5"):
        faultmesh.overlapping_triangles(V, bad, rect(0, 0, 1, 1))
    with pytest.raises(ValueError, match=r"rings\[1\] must have shape"):
        faultmesh.overlapping_triangles(V, T, [rect(0, 0, 1, 1), np.zeros((3, 5))])
    nan = rect(0, 0, 1, 1)
    nan[2, 0] = np.nan
    with pytest.raises(ValueError, match="ring 0 point 2 has a non-finite coordinate"):
        faultmesh.overlapping_triangles(V, T, nan)
    with pytest.raises(ValueError, match="tree"):
        faultmesh.overlapping_triangles(V, T[:5], rect(0, 0, 1, 1), tree=faultmesh.AabbTree(V, T))
    # Degenerate regions have no interior.
    assert faultmesh.overlapping_triangles(V, T, [[1, 1], [2, 2], [3, 3]]).size == 0
    assert faultmesh.overlapping_triangles(V, T, []).size == 0


def test_coordinates_beyond_the_limit_are_value_errors():
    """Regression (issue 10): one coordinate limit for every kernel."""
    V = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], float)
    T = np.array([[0, 1, 2], [1, 3, 2]])
    with pytest.raises(ValueError, match=r"overlapping_triangles: vertices row 3 has a coordinate beyond \+-1e\+60"):
        faultmesh.overlapping_triangles(V * [[1], [1], [1], [1e70]], T, rect(0, 0, 1, 1))
    with pytest.raises(ValueError, match=r"overlapping_triangles: ring 0 point 2 has a coordinate beyond"):
        faultmesh.overlapping_triangles(V, T, rect(0, 0, 1, 1e155))
    with pytest.raises(ValueError, match=r"triangle_overlaps_region: c row 1 has a non-finite coordinate"):
        faultmesh.triangle_overlaps_region(V[:2], V[1:3], np.array([[0, 1], [np.inf, 0]]), rect(0, 0, 1, 1))
    with pytest.raises(ValueError, match=r"overlapping_triangles: triangles row 0 has a negative vertex index"):
        faultmesh.overlapping_triangles(V, -T, rect(0, 0, 1, 1))
