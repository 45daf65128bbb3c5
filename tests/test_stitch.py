"""faultmesh.Stitcher / faultmesh.stitch / triangles_touching_region (stitch.hpp).

Layer meshes are Delaunay TINs of jittered grids; patches are lofted from
section polylines like real fault models (footwall -> strip -> hanging wall,
closed by fans at pinch-out tips). Every stitched surface is checked with the
model invariants (faultmesh.invariants.check_surface).
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import faultmesh
from faultmesh.invariants import check_surface
from faultmesh.model import Surface
from helpers import loft_sequence

SQUARE = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])


def tin(seed=1, n_side=21, jitter=200, boundary=SQUARE):
    """A TIN over the square: grid (boundary points exact) + random interior points."""
    rng = np.random.default_rng(seed)
    g = np.linspace(0.0, 100.0, n_side)
    X, Y = np.meshgrid(g, g)
    pts = np.column_stack([X.ravel(), Y.ravel()])
    pts = np.vstack([pts, rng.uniform(1.0, 99.0, (jitter, 2))])
    z = 0.01 * pts[:, 0] + 0.02 * pts[:, 1] + 0.5 * np.sin(pts[:, 0] / 9.0)
    t = faultmesh.Tin(np.column_stack([pts, z]))
    return np.asarray(t.vertices), np.asarray(t.triangles)


def trace(y, x0=30.0, kind="reverse", w=1.0, z0=0.0, xs=None):
    """One section polyline across a fault at ordinate y, footwall far end ->
    cutoff -> strip -> hanging-wall cutoff -> far end (x grows along it)."""
    if xs is None:
        if kind == "reverse":   # the strip runs backwards: 50 -> 42
            xs = [0, 15, 20, 12, 17, 40]
            zs = [0, 0, 0, -1, 1, 1]
        else:
            xs = [0, 15, 20, 25, 30, 40]
            zs = [0, 0, 0, -3, -3, -3]
    else:
        zs = [0.0] * len(xs)
    return np.array([[x0 + w * x, y, z0 + z + 0.02 * y] for x, z in zip(xs, zs)], dtype=np.float64)


def patch(polys, tips=(None, None)):
    """Loft consecutive polylines (with optional tip points) into one patch."""
    seq = ([np.asarray(tips[0], dtype=float)[None, :]] if tips[0] is not None else []) + list(polys) \
        + ([np.asarray(tips[1], dtype=float)[None, :]] if tips[1] is not None else [])
    return loft_sequence(seq)


def reverse_patch(x0=30.0, y0=40.0, y1=60.0, ty=10.0):
    P = [trace(y0, x0), trace(y1, x0)]
    tips = ([x0 + 16, y0 - ty, 0.3 + 0.02 * (y0 - ty)], [x0 + 16, y1 + ty, 0.3 + 0.02 * (y1 + ty)])
    return patch(P, tips)


def surface_of(st, name="L"):
    m = st.mesh()
    return Surface(name, m.vertices, m.triangles, kinds=m.kinds, owner=m.owners), m


def orient_xy(V, T):
    return faultmesh.orient2d(V[T[:, 0], :2], V[T[:, 1], :2], V[T[:, 2], :2])


# ---------------------------------------------------------------------------
def test_reverse_patch_stitched_folds_and_keeps_invariants():
    V, T = tin()
    PV, PT = reverse_patch()
    st = faultmesh.Stitcher(V, T, SQUARE, name="L")
    rep = st.stitch(PV, PT, name="F1")
    S, m = surface_of(st)
    check_surface(S, SQUARE)
    (gap,) = rep.gaps
    assert gap.n_holes == 1
    assert len(gap.triangles) == gap.n_vertices + 2 * gap.n_holes - 2 + 2 * gap.n_interior
    # The fault strip of the reverse fault is clockwise in XY; the areas still
    # add up to the study area (footwall + strip - hanging wall cancel).
    o = orient_xy(S.vertices, S.triangles)
    assert (o < 0).sum() > 0
    assert abs(0.5 * o.sum() - 100.0 * 100.0) < 1e-6
    # Every patch vertex is in the surface, unchanged (shared, not copied).
    assert (m.kinds == faultmesh.TriangleKind.patch).sum() == len(PT)
    got = S.vertices[m.vertex_map[rep.patch_vertex_offset:]]
    assert np.array_equal(got, PV)
    # Gap triangles use only existing vertices: layer or patch ones.
    assert len(S.vertices) <= len(V) + len(PV)


def test_typed_report_and_mesh():
    V, T = tin()
    PV, PT = reverse_patch()
    st = faultmesh.Stitcher(V, T, SQUARE, name="L")
    rep = st.stitch(PV, PT, name="F1")
    assert isinstance(rep, faultmesh.StitchReport)
    assert (rep.patch_id, rep.patch_name, rep.patch_vertex_offset, rep.patch_triangle_offset) == \
        (0, "F1", len(V), len(T))
    assert isinstance(rep.patch_flipped, bool) and rep.grow_rounds >= 1 and rep.n_candidates > 0
    assert rep.removed.dtype == np.int64 and np.all(np.diff(rep.removed) > 0)
    assert rep.merged_gaps.dtype == np.int64 and len(rep.merged_gaps) == 0
    (g,) = rep.gaps
    assert isinstance(g, faultmesh.StitchGap)
    assert g.id == 0 and g.triangles.dtype == np.int64 and list(g.patches) == [0]
    assert "StitchReport(patch_id=0, patch_name='F1'" in repr(rep) and "StitchGap(id=0" in repr(g)
    m = st.mesh()
    assert isinstance(m, faultmesh.StitchedMesh)
    assert m.vertices.shape[1] == 3 and m.triangles.shape[1] == 3
    assert m.kinds.dtype == np.int8 and m.owners.dtype == np.int64 and len(m.kinds) == len(m.triangles)
    # The kinds are TriangleKind values; the gap's rows map to its gap triangles.
    K = faultmesh.TriangleKind
    assert [int(k) for k in K] == [0, 1, 2] and [k.name for k in K] == ["layer", "patch", "gap"]
    rows = m.triangle_map[g.triangles]
    assert np.all(m.kinds[rows] == K.gap) and np.all(m.owners[rows] == g.id)
    assert np.all(m.owners[m.kinds == K.layer] == -1)
    assert np.all(m.owners[m.kinds == K.patch] == rep.patch_id)
    # Regression: patch_names raised TypeError (no converter for a list of strings).
    assert st.patch_names == ["F1"]
    assert isinstance(S := Surface("L", m.vertices, m.triangles, kinds=m.kinds, owner=m.owners), Surface)
    check_surface(S, SQUARE)


def test_far_triangles_unchanged_and_locality():
    V, T = tin(n_side=41, jitter=1500)
    PV, PT = reverse_patch(x0=10.0, y0=20.0, y1=30.0, ty=5.0)
    st = faultmesh.Stitcher(V, T, SQUARE)
    rep = st.stitch(PV, PT, name="F1")
    S, m = surface_of(st)
    check_surface(S, SQUARE)
    removed = rep.removed
    # Only triangles near the patch are touched: removed ones lie within a
    # small margin of the patch's box, and the AABB candidates are a small
    # fraction of the mesh.
    c = V[T[removed], :2].mean(axis=1)
    lo, hi = PV[:, :2].min(axis=0), PV[:, :2].max(axis=0)
    assert np.all((c >= lo - 10) & (c <= hi + 10))
    frac = float(np.prod(hi - lo)) / 100.0 ** 2
    assert rep.n_candidates < 2.0 * frac * len(T) + 50
    # Triangles away from the patch are exactly the original ones, in order.
    keep = np.ones(len(T), bool)
    keep[removed] = False
    tm = m.triangle_map[: len(T)]
    assert np.all(tm[keep] >= 0) and np.all(tm[removed] < 0)
    orig = V[T[keep]]
    now = S.vertices[S.triangles[tm[keep]]]
    assert np.array_equal(orig, now)


def test_overlapping_patches_raise_and_leave_the_mesh_unchanged():
    V, T = tin()
    st = faultmesh.Stitcher(V, T, SQUARE, name="coal8")
    PV, PT = reverse_patch()
    st.stitch(PV, PT, name="2F4")
    before = st.mesh()
    with pytest.raises(faultmesh.GeometryError, match=r"coal8.*'2F1'.*overlaps.*'2F4'"):
        st.stitch(PV + [5.0, 3.0, 0.0], PT, name="2F1")
    after = st.mesh()
    assert np.array_equal(before.triangles, after.triangles)
    assert np.array_equal(before.vertices, after.vertices)
    # Touching counts too: a patch sharing one outline point with the first.
    tip = PV[0].copy()
    QV = np.array([tip, tip + [10, -5, 0], tip + [12, 3, 0]])
    with pytest.raises(faultmesh.GeometryError, match="overlaps \\(or touches\\)"):
        st.stitch(QV, np.array([[0, 1, 2]]), name="F3")


def test_close_patches_merge_into_one_gap_with_two_holes():
    V, T = tin()
    st = faultmesh.Stitcher(V, T, SQUARE)
    PV, PT = reverse_patch()
    r1 = st.stitch(PV, PT, name="A")
    xs = [0, 4, 6, 3, 5, 10.5]
    QV, QT = patch([trace(42, 18, xs=xs), trace(58, 18, xs=xs)],
                   ([23, 35, 0.3], [23, 65, 0.3]))
    r2 = st.stitch(QV, QT, name="B")
    S, m = surface_of(st)
    check_surface(S, SQUARE)
    assert list(r2.merged_gaps) == [r1.gaps[0].id]
    (g,) = r2.gaps
    assert g.n_holes == 2 and sorted(g.patches) == [0, 1]
    assert list(g.merged_gaps) == [r1.gaps[0].id]
    rows = np.flatnonzero(m.kinds == faultmesh.TriangleKind.gap)
    assert len(rows) == g.n_vertices + 2 * 2 - 2 + 2 * g.n_interior
    assert set(m.owners[rows]) == {g.id}
    # Both patches keep their own triangles, owned by their ids.
    for r in (r1, r2):
        assert (m.owners[m.kinds == faultmesh.TriangleKind.patch] == r.patch_id).sum() > 0


@pytest.mark.parametrize("kind", ["normal", "reverse"])
def test_patch_reaching_the_boundary_keeps_it(kind):
    V, T = tin()
    # Last trace ON the study boundary x = 100 (a fault without pinch-out at
    # the boundary, paper F22): a polygon without a hole.
    def tr(x):
        ys = [30, 35, 38, 45] if kind == "normal" else [30, 38, 34, 45]
        zs = [0, 0, -1, -1] if kind == "normal" else [0, 0, 1, 1]
        return np.array([[x, y, z] for y, z in zip(ys, zs)], float)
    PV, PT = patch([tr(85.0), tr(100.0)], ([75.0, 37.0, 0.0], None))
    st = faultmesh.Stitcher(V, T, SQUARE)
    rep = st.stitch(PV, PT, name="F22")
    S, _ = surface_of(st)
    check_surface(S, SQUARE)
    (g,) = rep.gaps
    assert g.n_holes == 0
    assert len(g.triangles) == g.n_vertices - 2
    # The patch's boundary trace is part of the surface's outer boundary.
    (loop,) = faultmesh.boundary_loops(S.triangles)
    bxy = {tuple(p) for p in S.vertices[loop, :2]}
    assert all((100.0, y) in bxy for y in (30.0, 45.0))


def test_non_convex_study_area_and_boundary_patch():
    ring = np.array([[0, 0], [100, 0], [100, 100], [60, 100], [50, 60], [40, 100], [0, 100]], float)
    lt = faultmesh.build.LayerTin("L", np.column_stack([np.random.default_rng(3).uniform(1, 99, (300, 2)),
                                                        np.zeros(300)]), ring, spacing=8.0)
    V, T = lt.mesh()
    check_surface(Surface("L", V, T), ring)
    a = np.array([[90.0, y, z] for y, z in zip([20, 26, 29, 35], [0, 0, -2, -2])])
    b = np.array([[100.0, y, z] for y, z in zip([20, 26, 29, 35], [0, 0, -2, -2])])
    PV, PT = patch([a, b], ([80.0, 27.0, 0.0], None))
    st = faultmesh.Stitcher(V, T, ring)
    st.stitch(PV, PT, name="F")
    S, _ = surface_of(st)
    check_surface(S, ring)


def test_patch_touching_the_boundary_at_a_vertex_pinches_the_gap():
    # An end carried onto the boundary around the corner (100, 0): the
    # extension's points land on the side y = 0, the trace's last point
    # (100, 3) already lies on the side x = 100 and is shared. The patch's
    # chord (90, 0)-(100, 3) cuts the corner off, so the gap touches itself
    # at (100, 3): a corner triangle and the rest. The boundary piece D
    # covers on x = 100 ran through (100, 3) as one edge, and the gap polygon
    # crossed itself (sweep seeds 112, 145, 183, 242, 271, 397: "ear clipping
    # the gap polygon ... gave 62 triangles instead of 63").
    V, T = tin()
    a = np.array([[80.0, 10.0, -1.0], [85.0, 8.0, -1.0], [92.0, 6.0, -1.0], [100.0, 3.0, -1.0]])
    b = np.array([[78.0, 0.0, -1.0], [83.0, 0.0, -1.0], [90.0, 0.0, -1.0], [100.0, 3.0, -1.0]])
    t = np.asarray(faultmesh.loft(a, b))
    t = np.where(t == 7, 3, t)                      # b's last point is a's
    PT = t[(t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 2] != t[:, 0])]
    PV = np.vstack([a, b[:3]])
    st = faultmesh.Stitcher(V, T, SQUARE)
    rep = st.stitch(PV, PT, name="F")
    S, m = surface_of(st)
    check_surface(S, SQUARE)
    assert len(rep.gaps) == 2
    for g in rep.gaps:
        assert len(g.triangles) == g.n_vertices + 2 * g.n_holes - 2 + 2 * g.n_interior
    # One gap is the corner: (90, 0) -- chord -- (100, 3) and the boundary.
    is_gap = m.kinds == faultmesh.TriangleKind.gap
    xy = [S.vertices[np.unique(S.triangles[is_gap & (m.owners == g.id)]), :2] for g in rep.gaps]
    corner = [p for p in xy if (p[:, 0] >= 90.0).all() and (p[:, 1] <= 3.0).all()]
    assert len(corner) == 1 and {(90.0, 0.0), (100.0, 0.0), (100.0, 3.0)} <= {tuple(q) for q in corner[0]}
    # (100, 3) is on the surface's boundary, between (100, 0) and the rest.
    (loop,) = faultmesh.boundary_loops(S.triangles)
    bxy = [tuple(p) for p in S.vertices[loop, :2]]
    assert (100.0, 3.0) in bxy and (100.0, 0.0) in bxy


def test_patch_leaving_a_non_convex_study_area_is_named():
    # A fault that runs out of the study area and back in between two traces
    # (across the notch of the ring below): the patch's outline edge crosses
    # the notch. The gap polygon then crossed itself and ear clipping said so
    # in its own words (sweep seeds 418, 454); the stitcher names the cause.
    ring = np.array([[0, 0], [100, 0], [100, 100], [60, 100], [50, 60], [40, 100], [0, 100]], float)
    lt = faultmesh.build.LayerTin("L", np.column_stack([np.random.default_rng(3).uniform(1, 99, (300, 2)),
                                                        np.zeros(300)]), ring, spacing=8.0)
    V, T = lt.mesh()
    a = np.array([[45.0, y, z] for y, z in zip([50, 60, 64, 75], [0, 0, -2, -2])])
    b = np.array([[55.0, y, z] for y, z in zip([50, 60, 64, 75], [0, 0, -2, -2])])
    PV, PT = patch([a, b])
    st = faultmesh.Stitcher(V, T, ring)
    with pytest.raises(faultmesh.GeometryError,
                       match=r"patch 'F': the patch leaves the study area: its outline edge .* crosses "
                             r"the study-area side from \(50, 60\) to \(40, 100\)"):
        st.stitch(PV, PT, name="F")
    # Nothing changed: the same patch moved clear of the notch stitches.
    PV2 = PV.copy()
    PV2[:, 1] -= 20.0
    st.stitch(PV2, PT, name="F")
    S, _ = surface_of(st)
    check_surface(S, ring)


def test_errors_name_the_problem():
    V, T = tin()
    with pytest.raises(ValueError, match="vertices must have shape"):
        faultmesh.Stitcher(V[:, :2], T, SQUARE)
    bad = T.copy()
    bad[5, 1] = len(V) + 3
    with pytest.raises(ValueError, match="triangles row 5 has vertex index"):
        faultmesh.Stitcher(V, bad, SQUARE)
    with pytest.raises(ValueError, match="halfedges must have shape"):
        faultmesh.Stitcher(V, T, SQUARE, halfedges=np.zeros(5, np.int64))
    with pytest.raises(ValueError, match="order must be"):
        faultmesh.Stitcher(V, T, SQUARE, order="best")
    st = faultmesh.Stitcher(V, T, SQUARE, name="L")
    PV, PT = reverse_patch()
    with pytest.raises(ValueError, match="patch_triangles row 0 has vertex index"):
        st.stitch(PV, PT + 1000, name="F")
    # Outside the study area.
    with pytest.raises(faultmesh.GeometryError, match="lies outside the study area"):
        st.stitch(PV + [80.0, 0.0, 0.0], PT, name="F")
    # A reverse fault that ends at a trace with throw inside the area: its
    # outline folds back on itself.
    QV, QT = patch([trace(40.0), trace(60.0)])
    with pytest.raises(faultmesh.GeometryError, match="outline is not simple"):
        st.stitch(QV, QT, name="F")
    # Nothing was changed by the failed calls.
    st.stitch(PV, PT, name="F")
    check_surface(surface_of(st)[0], SQUARE)


def test_clockwise_layer_triangle_is_reported_when_touched():
    V, T = tin()
    PV, PT = reverse_patch()
    # One flipped triangle: its neighbours disagree (found by the adjacency).
    c = V[T, :2].mean(axis=1)
    r = int(np.argmin(np.hypot(c[:, 0] - 46, c[:, 1] - 50)))
    T2 = T.copy()
    T2[r] = T2[r, ::-1]
    with pytest.raises(faultmesh.GeometryError, match="used twice in the same direction"):
        faultmesh.Stitcher(V, T2, SQUARE)
    # A consistently clockwise mesh: the stitcher verifies each triangle it
    # relies on (lazily, at the first stitch that touches it).
    st = faultmesh.Stitcher(V, T[:, ::-1], SQUARE)
    with pytest.raises(faultmesh.GeometryError, match="triangle row [0-9]+ is clockwise"):
        st.stitch(PV, PT, name="F")
    # Wrong half-edges likewise.
    tinobj = faultmesh.Tin(V)
    H = np.asarray(tinobj.halfedges).copy()
    T3 = np.asarray(tinobj.triangles)
    c = V[T3, :2].mean(axis=1)
    r = int(np.argmin(np.hypot(c[:, 0] - 46, c[:, 1] - 50)))
    H[3 * r] = H[3 * r + 1]
    st = faultmesh.Stitcher(V, T3, SQUARE, halfedges=H)
    with pytest.raises(ValueError, match="is not the opposite half-edge"):
        st.stitch(PV, PT, name="F")


def test_given_halfedges_and_computed_adjacency_agree():
    V, _ = tin()
    t = faultmesh.Tin(V)
    T, H = np.asarray(t.triangles), np.asarray(t.halfedges)
    PV, PT = reverse_patch()
    out = []
    for h in (H, None):
        st = faultmesh.Stitcher(V, T, SQUARE, halfedges=h)
        st.stitch(PV, PT)
        out.append(st.mesh())
    assert np.array_equal(out[0].triangles, out[1].triangles)


@pytest.mark.parametrize("refine,order", [(True, "quality"), (False, "plain"), (True, "plain"),
                                          (False, "quality")])
def test_ear_clipping_options_and_clearance(refine, order):
    V, T = tin()
    PV, PT = reverse_patch()
    res = {}
    for clearance in (0.0, 12.0):
        st = faultmesh.Stitcher(V, T, SQUARE, refine=refine, order=order, bridge="eberly",
                                clearance=clearance)
        rep = st.stitch(PV, PT)
        S, _ = surface_of(st)
        check_surface(S, SQUARE)
        res[clearance] = rep
    # The clearance only ever removes more.
    assert set(res[0.0].removed) <= set(res[12.0].removed)
    assert len(res[12.0].removed) > len(res[0.0].removed)


def test_one_shot_stitch():
    V, T = tin()
    PV, PT = reverse_patch()
    V2, T2, rows = faultmesh.stitch(V, T, PV, PT, SQUARE)
    check_surface(Surface("L", V2, T2), SQUARE)
    assert rows.dtype == np.int64 and len(rows) > 0
    assert np.all(orient_xy(V2, T2[rows]) > 0)
    # Without a boundary: the mesh's own outer boundary is the study area.
    V3, T3, rows3 = faultmesh.stitch(V, T, PV, PT)
    assert np.array_equal(T2, T3) and np.array_equal(rows, rows3)


# ---------------------------------------------------------------------------
# triangles_touching_region: exact, against a Fraction reference
# ---------------------------------------------------------------------------
def _orient_f(a, b, c):
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def _on_seg_f(a, b, p):
    return (_orient_f(a, b, p) == 0 and min(a[0], b[0]) <= p[0] <= max(a[0], b[0])
            and min(a[1], b[1]) <= p[1] <= max(a[1], b[1]))


def _seg_meet_f(a, b, c, d):
    o1, o2, o3, o4 = _orient_f(a, b, c), _orient_f(a, b, d), _orient_f(c, d, a), _orient_f(c, d, b)
    if o1 * o2 < 0 and o3 * o4 < 0:
        return True
    return _on_seg_f(a, b, c) or _on_seg_f(a, b, d) or _on_seg_f(c, d, a) or _on_seg_f(c, d, b)


def _in_poly_f(ring, p):
    inside = False
    n = len(ring)
    for i in range(n):
        u, v = ring[i], ring[(i + 1) % n]
        if (u[1] > p[1]) != (v[1] > p[1]):
            x = u[0] + (p[1] - u[1]) * (v[0] - u[0]) / (v[1] - u[1])
            if x > p[0]:
                inside = not inside
    return inside


def _touch_ref(tri, ring):
    tri = [tuple(map(Fraction, p)) for p in tri]
    ring = [tuple(map(Fraction, p)) for p in ring]
    for i in range(len(ring)):
        u, v = ring[i], ring[(i + 1) % len(ring)]
        for j in range(3):
            if _seg_meet_f(u, v, tri[j], tri[(j + 1) % 3]):
                return True
    if _in_poly_f(ring, tri[0]):
        return True
    a, b, c = tri
    o = _orient_f(a, b, c)
    p = ring[0]
    s = [_orient_f(a, b, p), _orient_f(b, c, p), _orient_f(c, a, p)]
    return o != 0 and all(x * o >= 0 for x in s)


def test_touching_region_cases():
    ring = [np.array([[0, 0], [4, 0], [4, 4], [0, 4]], float)]
    V = np.array([[4, 4], [6, 4], [6, 6],      # shares the corner only -> touches
                  [5, 0], [7, 0], [6, 2],      # disjoint
                  [1, 1], [2, 1], [1, 2],      # inside
                  [-1, -1], [9, -1], [-1, 9]],  # contains the region
                 float)
    T = np.arange(12).reshape(4, 3)
    assert faultmesh.triangles_touching_region(V, T, ring).tolist() == [0, 2, 3]


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.integers(-6, 6), st.integers(-6, 6)), min_size=3, max_size=3),
       st.integers(0, 3))
def test_touching_region_matches_exact_reference(tri, which):
    rings = [[(0, 0), (4, 0), (4, 4), (0, 4)], [(0, 0), (5, 1), (2, 2), (1, 5)],
             [(-3, -3), (3, -3), (0, 0)], [(1, 1), (2, 1), (2, 2)]]
    ring = rings[which]
    V = np.array(tri, float)
    got = faultmesh.triangles_touching_region(V, np.array([[0, 1, 2]]), [np.array(ring, float)])
    assert (len(got) == 1) == _touch_ref(tri, ring)


# ---------------------------------------------------------------------------
# Hypothesis: random patches (normal / reverse, sizes, places) into random TINs
# ---------------------------------------------------------------------------
@settings(max_examples=25, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), x0=st.floats(2, 55), y0=st.floats(12, 60),
       length=st.floats(8, 25), width=st.floats(0.4, 1.0), reverse=st.booleans(),
       n_traces=st.integers(2, 4), clearance=st.sampled_from([0.0, 3.0]))
def test_random_patches_keep_invariants(seed, x0, y0, length, width, reverse, n_traces, clearance):
    V, T = tin(seed=seed, n_side=11, jitter=150)
    ys = np.linspace(y0, y0 + length, n_traces)
    kind = "reverse" if reverse else "normal"
    polys = [trace(y, x0, kind=kind, w=width) for y in ys]
    tips = ([x0 + 16 * width, y0 - 8, 0.2], [x0 + 16 * width, y0 + length + 8, 0.2])
    PV, PT = patch(polys, tips)
    st_ = faultmesh.Stitcher(V, T, SQUARE, clearance=clearance)
    rep = st_.stitch(PV, PT, name="F")
    S, m = surface_of(st_)
    check_surface(S, SQUARE)
    for g in rep.gaps:
        assert len(g.triangles) == g.n_vertices + 2 * g.n_holes - 2 + 2 * g.n_interior
    o = orient_xy(S.vertices, S.triangles)
    assert ((o < 0).sum() > 0) == reverse


def test_patch_names_and_every_property_of_stitcher():
    """Regression (issue 10): Stitcher.patch_names always raised TypeError (no
    STL caster for std::vector<std::string>)."""
    V, T = tin()
    st = faultmesh.Stitcher(V, T, SQUARE, name="L")
    assert st.patch_names == []
    PV, PT = reverse_patch()
    st.stitch(PV, PT, name="F1")
    assert st.patch_names == ["F1"]
    assert st.name == "L"
    assert st.n_vertices == len(V) + len(PV)
    assert st.n_live_triangles < st.n_triangles
    props = sorted(k for k in dir(faultmesh.Stitcher) if isinstance(getattr(faultmesh.Stitcher, k), property))
    assert props == ["n_live_triangles", "n_triangles", "n_vertices", "name", "patch_names"]


def test_coordinates_beyond_the_limit_are_value_errors():
    """Regression (issue 10): one coordinate limit (1e60), named in the message."""
    V, T = tin()
    big = V.copy()
    big[7, 0] = 1e70
    with pytest.raises(ValueError, match=r"Stitcher\('layer'\): vertices row 7 has a coordinate beyond \+-1e\+60"):
        faultmesh.Stitcher(big, T, SQUARE)
    with pytest.raises(ValueError, match=r"boundary row 2 has a coordinate beyond"):
        faultmesh.Stitcher(V, T, SQUARE * [1, 1e70])
    st = faultmesh.Stitcher(V, T, SQUARE)
    PV, PT = reverse_patch()
    bad = PV.copy()
    bad[3, 1] = np.inf
    with pytest.raises(ValueError, match=r"patch_vertices row 3 has a non-finite coordinate \(y = inf\)"):
        st.stitch(bad, PT, name="F")
    with pytest.raises(ValueError, match=r"triangles_touching_region: ring point 1 has a coordinate beyond"):
        faultmesh.triangles_touching_region(V, T, [np.array([[0, 0], [1e61, 0], [0, 1.0]])])
    st.stitch(PV, PT, name="F")  # nothing changed by the failures


def test_stitcher_owns_its_inputs():
    """The stitcher copies what it keeps: changing the caller's arrays later
    changes nothing (and float index arrays must hold integers)."""
    V, T = tin()
    st = faultmesh.Stitcher(V, T, SQUARE)
    ref = st.mesh()
    V[:] = np.nan
    T[:] = 10**12
    m = st.mesh()
    assert np.array_equal(m.triangles, ref.triangles)
    assert np.array_equal(m.vertices, ref.vertices)
    V2, T2 = tin()
    with pytest.raises(ValueError, match=r"Stitcher: triangles row 0 has the value 0.5, not an integer"):
        faultmesh.Stitcher(V2, np.where(np.arange(T2.size).reshape(T2.shape) == 0, 0.5, T2), SQUARE)
    faultmesh.Stitcher(V2, T2.astype(float), SQUARE)  # exact integers as floats are fine


def test_concurrent_stitches_into_one_layer_are_serialised():
    """stitch() runs with the GIL released and a LayerStitcher is not
    thread-safe: the binding locks, so patches stitched from several Python
    threads into one layer give a valid surface (no data race)."""
    import threading
    V, T = tin(n_side=31, jitter=600)
    st = faultmesh.Stitcher(V, T, SQUARE)
    patches = [reverse_patch(x0=x0, y0=y0, y1=y0 + 12, ty=4.0)
               for x0 in (5.0, 50.0) for y0 in (10.0, 60.0)]
    errors = []

    def work(k):
        try:
            PV, PT = patches[k]
            st.stitch(PV, PT, name=f"F{k}")
            for _ in range(3):
                st.mesh()
                st.patch_names
        except Exception as exc:  # surfaced below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(len(patches))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert sorted(st.patch_names) == [f"F{k}" for k in range(len(patches))]
    check_surface(surface_of(st)[0], SQUARE)


def test_patch_triangle_repeating_a_vertex_is_named():
    """Regression (fuzzing, issue 10): a patch triangle (2, 2, 0) was reported
    by the outline extraction as 'boundary_contours: triangles row 1 repeats
    vertex 2', naming neither the stitch nor the patch."""
    V, T = tin()
    st = faultmesh.Stitcher(V, T, SQUARE, name="L")
    PV, PT = reverse_patch()
    bad = PT.copy()
    bad[1] = [2, 2, 0]
    with pytest.raises(ValueError, match=r"stitch: layer 'L', patch 'F': patch_triangles row 1 repeats vertex 2"):
        st.stitch(PV, bad, name="F")
    st.stitch(PV, PT, name="F")


def test_patch_triangle_collinear_in_3d_is_rejected():
    """Regression (fuzzing, issue 10): a tip point on the line of its trace
    lofts into triangles whose vertices are collinear in 3D; they were
    stitched into the layer, which then failed check() ('zero area'). The
    stitch now raises GeometryError naming the row; nothing changes."""
    V, T = tin()
    st = faultmesh.Stitcher(V, T, SQUARE, name="L")
    a = np.array([[40.0, 50.0, 0.0], [45.0, 50.0, 0.0], [50.0, 50.0, 0.0]])
    b = a + [0.0, 3.0, -1.0]
    tip = np.array([[35.0, 50.0, 0.0]])  # on the line of a
    PV, PT = patch([a, b], tips=(tip[0], None))
    before = st.mesh()
    with pytest.raises(faultmesh.GeometryError, match=r"patch 'F': patch_triangles row 0 is degenerate"):
        st.stitch(PV, PT, name="F")
    assert np.array_equal(st.mesh().triangles, before.triangles)
    PV2, PT2 = patch([a, b], tips=([35.0, 49.0, 0.0], None))
    st.stitch(PV2, PT2, name="F")
    check_surface(surface_of(st)[0], SQUARE)
