"""The surface-cutting baseline (faultmesh.cut_layer, faultmesh.cutting)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import faultmesh
from faultmesh.cutting import cut_surface, cut_surfaces, fault_displacement
from faultmesh.model import Surface


def layer_grid(n=20, size=100.0, seed=7, zfun=lambda x, y: -50.0 + 0.05 * x + 0.02 * y):
    """A jittered grid on [0, size]^2 (border points stay on the square)."""
    rng = np.random.default_rng(seed)
    h = size / n
    g = np.stack(np.meshgrid(np.arange(n + 1) * h, np.arange(n + 1) * h), -1).reshape(-1, 2)
    inner = (g[:, 0] > 0) & (g[:, 0] < size) & (g[:, 1] > 0) & (g[:, 1] < size)
    g[inner] += rng.uniform(-0.3, 0.3, (int(inner.sum()), 2)) * h
    V = np.column_stack([g, zfun(g[:, 0], g[:, 1])])
    return V, faultmesh.delaunay(g)


def fault_grid(y0, y1, ny, ztop, zbot, nd, x_of):
    """A fault surface gridded over (y, z); x = x_of(y, z)."""
    Y, Z = np.meshgrid(np.linspace(y0, y1, ny + 1), np.linspace(ztop, zbot, nd + 1), indexing="ij")
    V = np.column_stack([x_of(Y, Z).ravel(), Y.ravel(), Z.ravel()])
    T = []
    for j in range(ny):
        for k in range(nd):
            a = j * (nd + 1) + k
            b, c = a + 1, a + nd + 1
            T += [[a, c, b], [b, c, c + 1]]
    return V, np.array(T, dtype=np.int64)


def plane(x0=40.0, dip=60.0):
    return lambda y, z: x0 - z / np.tan(np.radians(dip))


def edge_counts(T):
    e = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    return {tuple(k): int(v) for k, v in zip(u.tolist(), c)}


def check_cut(LV, LT, r, displacement):
    """Conformity, orientation, area, the crack and no crossing of the line."""
    V, T = r["vertices"], r["triangles"]
    n0 = len(LV)
    assert V.dtype == np.float64 and T.dtype == np.int64 and T.shape[1] == 3
    np.testing.assert_array_equal(V[:n0], LV)
    assert len(T) == len(LT) - len(r["removed"]) + len(r["created"])
    o = faultmesh.orient2d(V[T[:, 0], :2], V[T[:, 1], :2], V[T[:, 2], :2])
    assert np.all(o > 0)
    area = lambda V, T: 0.5 * np.sum(faultmesh.orient2d(V[T[:, 0], :2], V[T[:, 1], :2], V[T[:, 2], :2]))
    assert area(V, T) == pytest.approx(area(LV, LT), rel=1e-12)
    old = edge_counts(LT)
    off = r["line_offsets"]
    crack = set()
    for c in range(len(off) - 1):
        for line in (r["footwall_line"], r["hanging_line"]):
            seg = line[off[c]:off[c + 1]]
            crack |= {tuple(sorted(p)) for p in zip(seg[:-1].tolist(), seg[1:].tolist())}
    for e, n in edge_counts(T).items():
        assert n <= 2, e
        if n == 1 and e not in crack:
            if max(e) < n0:
                assert old.get(e) == 1, f"interior edge {e} became a boundary edge"
            else:  # a piece of a border edge split at a line end
                p = V[max(e), :2]
                assert np.isclose(p, 0).any() or np.isclose(p, 100).any()
    f, h, w = r["footwall_line"], r["hanging_line"], r["line_weight"]
    np.testing.assert_array_equal(V[f, :2], V[h, :2])
    np.testing.assert_allclose(V[h, 2] - V[f, 2], displacement * w, atol=1e-9)
    assert np.all(w[f == h] == 0)
    # No triangle edge properly crosses a line segment (exact predicates).
    E = np.unique(np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1), axis=0)
    for c in range(len(off) - 1):
        seg = f[off[c]:off[c + 1]]
        for p, q in zip(seg[:-1], seg[1:]):
            P, Q = np.repeat(V[[p], :2], len(E), 0), np.repeat(V[[q], :2], len(E), 0)
            A, B = V[E[:, 0], :2], V[E[:, 1], :2]
            s1 = np.sign(faultmesh.orient2d(P, Q, A)) * np.sign(faultmesh.orient2d(P, Q, B))
            s2 = np.sign(faultmesh.orient2d(A, B, P)) * np.sign(faultmesh.orient2d(A, B, Q))
            assert not np.any((s1 < 0) & (s2 < 0)), "a triangle crosses the intersection line"


def test_cut_layer_planar_fault_counts_and_invariants():
    LV, LT = layer_grid()
    FV, FT = fault_grid(20, 80, 6, 0, -100, 5, plane())
    r = faultmesh.cut_layer(LV, LT, FV, FT, displacement=-4.0)
    check_cut(LV, LT, r, -4.0)
    assert len(r["line_offsets"]) == 2
    assert len(r["split"]) == 2  # two tips
    # Faces of the cut region: sum of (n - 2) = created - 2 per split triangle.
    assert len(r["created"]) >= len(r["removed"])
    # The created triangles are the last rows.
    np.testing.assert_array_equal(r["created"], np.arange(len(r["triangles"]) - len(r["created"]),
                                                          len(r["triangles"])))
    # Hanging-wall copies (not the tips) moved down by the throw.
    f, h = r["footwall_line"], r["hanging_line"]
    inner = f != h
    assert inner.sum() == len(f) - 2
    np.testing.assert_allclose(r["vertices"][h[inner], 2] - r["vertices"][f[inner], 2], -4.0)


def test_cut_layer_hanging_wall_is_above_the_fault_side():
    """Created triangles with hanging-wall copies lie east of the line (the
    fault dips east, so the block above it is east of the cut)."""
    LV, LT = layer_grid(16, seed=3)
    FV, FT = fault_grid(10, 90, 8, 10, -120, 6, plane())
    r = faultmesh.cut_layer(LV, LT, FV, FT, displacement=5.0)
    check_cut(LV, LT, r, 5.0)
    V, T = r["vertices"], r["triangles"][r["created"]]
    f, h = r["footwall_line"], r["hanging_line"]
    hang = set(h[f != h].tolist())
    foot = set(f[f != h].tolist())
    xline = V[f, 0].mean()
    for t in T:
        hs, fs = any(v in hang for v in t), any(v in foot for v in t)
        assert not (hs and fs)
        if hs:
            assert V[t, 0].mean() > xline - 1.0
        if fs:
            assert V[t, 0].mean() < xline + 1.0


def test_cut_layer_plain_order_same_counts():
    LV, LT = layer_grid()
    FV, FT = fault_grid(20, 80, 6, 0, -100, 5, plane())
    a = faultmesh.cut_layer(LV, LT, FV, FT)
    b = faultmesh.cut_layer(LV, LT, FV, FT, refine=False, order="plain")
    assert len(a["created"]) == len(b["created"])
    np.testing.assert_array_equal(a["removed"], b["removed"])
    check_cut(LV, LT, b, 0.0)


def test_cut_layer_no_crossing_returns_input():
    LV, LT = layer_grid(8)
    FV, FT = fault_grid(20, 80, 3, -200, -300, 2, plane())
    r = faultmesh.cut_layer(LV, LT, FV, FT)
    np.testing.assert_array_equal(r["triangles"], LT)
    assert len(r["created"]) == 0 and len(r["removed"]) == 0


def test_cut_layer_errors():
    LV, LT = layer_grid(6)
    FV, FT = fault_grid(20, 80, 3, 0, -100, 2, plane())
    with pytest.raises(ValueError, match="layer_vertices must have shape"):
        faultmesh.cut_layer(LV[:, :2], LT, FV, FT)
    with pytest.raises(ValueError, match="fault_triangles must have shape"):
        faultmesh.cut_layer(LV, LT, FV, FT[:, :2])
    bad = LT.copy()
    bad[3, 1] = len(LV)
    with pytest.raises(ValueError, match=r"layer_triangles row 3 has vertex index"):
        faultmesh.cut_layer(LV, bad, FV, FT)
    with pytest.raises(ValueError, match="order must be"):
        faultmesh.cut_layer(LV, LT, FV, FT, order="best")
    with pytest.raises(faultmesh.GeometryError, match="not counter-clockwise"):
        faultmesh.cut_layer(LV, LT[:, [0, 2, 1]], FV, FT)


@settings(max_examples=25, deadline=None)
@given(x0=st.floats(20, 60), dip=st.floats(35, 80), y0=st.floats(-20, 40), length=st.floats(15, 90),
       dz=st.floats(-8, 8), taper=st.sampled_from([0.0, 10.0]), seed=st.integers(0, 50),
       nf=st.integers(1, 6))
def test_cut_layer_random_faults_keep_invariants(x0, dip, y0, length, dz, taper, seed, nf):
    LV, LT = layer_grid(14, seed=seed)
    FV, FT = fault_grid(y0, y0 + length, nf, 20, -140, 3, plane(x0, dip))
    r = faultmesh.cut_layer(LV, LT, FV, FT, displacement=dz, taper_length=taper)
    check_cut(LV, LT, r, dz)


def test_cut_surfaces_tracks_rows_through_later_cuts():
    """Two crossing faults cut one layer; each gap's rows are the triangles it
    created that the later cut kept, and they are valid rows of the result."""
    LV, LT = layer_grid(20)
    layer = Surface("L", LV, LT)
    F1 = Surface("F1", *fault_grid(-10, 110, 8, 10, -120, 4, plane(40, 60)), kind="fault")
    # The second fault strikes east-west (x along strike), dipping north.
    V2, T2 = fault_grid(20, 90, 6, 10, -120, 4, lambda y, z: 50 - z / np.tan(np.radians(55)))
    F2 = Surface("F2", V2[:, [1, 0, 2]], T2[:, [0, 2, 1]], kind="fault")
    out, gaps = cut_surfaces({"L": layer}, [("F1", F1, {"L": -3.0}), ("F2", F2, {"L": 2.0})])
    s = out["L"]
    assert [g.fault for g in gaps] == ["F1", "F2"]
    assert gaps[0].metadata["created"] > 0 and gaps[1].metadata["created"] > 0
    # The second cut replaced some of the first cut's triangles.
    assert len(gaps[0].triangles) < gaps[0].metadata["created"]
    assert len(gaps[1].triangles) == gaps[1].metadata["created"]
    rows = np.concatenate([g.triangles for g in gaps])
    assert len(np.unique(rows)) == len(rows) and rows.max() < s.n_triangles
    o = faultmesh.orient2d(*(s.vertices[s.triangles[:, k], :2] for k in range(3)))
    assert np.all(o > 0)
    assert len(gaps[0].metadata["min_angle"]) == gaps[0].metadata["created"]


def test_cut_surface_and_fault_displacement():
    LV, LT = layer_grid(10)
    FV, FT = fault_grid(20, 80, 3, 0, -100, 2, plane())
    cut, r = cut_surface(Surface("L", LV, LT), Surface("F", FV, FT, kind="fault"), displacement=-2.0)
    assert cut.name == "L" and cut.n_triangles == len(r["triangles"])

    class Tr:
        def __init__(self, foot, hang):
            self.layers = {"c8": {"foot": np.array(foot, float), "hanging": np.array(hang, float)}}

    class F:
        traces = [Tr([[0, 0, 5], [1, 0, 4]], [[2, 0, -6], [3, 0, -7]]),
                  Tr([[0, 1, 3], [1, 1, 2]], [[2, 1, -8], [3, 1, -9]]), Tr([[0, 0, 0]], [])]

    assert fault_displacement(F, "c8") == pytest.approx(((-6 - 4) + (-8 - 2)) / 2)
    assert fault_displacement(F, "c10") is None


def test_cut_model_on_the_built_in_dataset():
    """The baseline on paper_like: every fault cuts the layers its traces
    interpret, F22 (a boundary fault) cuts every layer up to the study-area
    boundary (one tip, not two), and the cut surfaces stay conforming and
    counter-clockwise."""
    from faultmesh.cutting import continuous_layers, cut_model

    ds = faultmesh.datasets.paper_like(0)
    m = cut_model(ds)
    cont = continuous_layers(ds)
    pairs = {(g.fault, g.layer) for g in m.gaps}
    for f in ds.faults:
        for layer in ds.layers:
            assert ((f.name, layer) in pairs) == (fault_displacement(f, layer) is not None)
    for g in m.gaps:
        assert g.metadata["created"] > 0 and g.metadata["line_points"] >= 2
        if g.fault == "F22":
            assert g.metadata["split"] == 1, g.layer
            assert g.metadata["displacement"] < 0  # normal fault: hanging wall down
        if g.fault in ("2F4", "2F1"):
            assert g.metadata["displacement"] > 0  # reverse
    for name, s in m.surfaces.items():
        o = faultmesh.orient2d(*(s.vertices[s.triangles[:, k], :2] for k in range(3)))
        assert np.all(o > 0), name
        assert max(edge_counts(s.triangles).values()) <= 2
        # XY area unchanged by cutting (the crack has no area).
        area = lambda S: 0.5 * np.sum(faultmesh.orient2d(
            *(S.vertices[S.triangles[:, k], :2] for k in range(3))))
        assert area(s) == pytest.approx(area(cont[name]), rel=1e-12)


def test_coordinates_beyond_the_limit_are_value_errors():
    """Regression (issue 10): one coordinate limit for every kernel; z enters
    the side tests and the crossing points, so it is checked too."""
    lv = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [10, 10, 0]], float)
    lt = np.array([[0, 1, 2], [1, 3, 2]])
    fv = np.array([[5, -1, -5], [5, 11, -5], [6, -1, 5], [6, 11, 5]], float)
    ft = np.array([[0, 1, 2], [1, 3, 2]])
    big = fv.copy()
    big[3, 2] = -1e61
    with pytest.raises(ValueError, match=r"cut_layer: fault_vertices row 3 has a coordinate beyond \+-1e\+60 "
                                         r"\(z = -1e\+61\)"):
        faultmesh.cut_layer(lv, lt, big, ft)
    with pytest.raises(ValueError, match=r"cut_layer: layer_triangles row 1 has the value 2.25, not an integer"):
        faultmesh.cut_layer(lv, np.array([[0, 1, 2], [1, 3, 2.25]]), fv, ft)
    assert faultmesh.cut_layer(lv, lt, fv, ft)["triangles"].shape[1] == 3
