"""Cross-sections: analytic answers, degenerate cases, chaining, CSV and picture."""
from __future__ import annotations

import csv

import numpy as np
import pytest

import faultmesh
from faultmesh.model import Model, Surface
from faultmesh.section import _chain, section_direction, section_model, section_surface


def plane_tin(seed=0, n=300, a=0.1, b=-0.2, c=50.0, size=1000.0):
    rng = np.random.default_rng(seed)
    xy = np.vstack([rng.random((n, 2)) * size, [[0, 0], [size, 0], [size, size], [0, size]]])
    tri = faultmesh.delaunay(xy)
    return np.column_stack([xy, a * xy[:, 0] + b * xy[:, 1] + c]), tri


def grid_tin(n=11, step=1.0):
    g = np.arange(n) * step
    X, Y = np.meshgrid(g, g)
    xy = np.column_stack([X.ravel(), Y.ravel()])
    tri = faultmesh.delaunay(xy)
    return np.column_stack([xy, 0.5 * xy[:, 0] + 2.0]), tri


@pytest.mark.parametrize("az", [0.0, 90.0, 33.3, 135.0, 181.0, 270.0, 317.089497, -42.0])
def test_plane_cut_is_a_straight_line_with_the_right_z(az):
    V, T = plane_tin()
    o = np.array([480.0, 515.0])
    res = section_surface(V, T, o, az)
    assert len(res) == 1
    p, s, closed = res[0]
    assert not closed
    d = section_direction(az)
    # On the plane of the surface ...
    assert np.allclose(p[:, 2], 0.1 * p[:, 0] - 0.2 * p[:, 1] + 50.0, atol=1e-9)
    # ... on the vertical section plane, with s the distance along it ...
    assert np.allclose((p[:, :2] - o) @ np.array([d[1], -d[0]]), 0.0, atol=1e-9)
    assert np.allclose(o + s[:, None] * d, p[:, :2], atol=1e-9)
    # ... increasing, from one side of the square to the other.
    assert np.all(np.diff(s) > 0)
    for end in (p[0], p[-1]):
        assert min(end[0], 1000 - end[0], end[1], 1000 - end[1]) < 1e-9


def test_azimuth_convention_north_east_south():
    V, T = plane_tin()
    o = np.array([300.0, 600.0])
    (pn, sn, _), = section_surface(V, T, o, 0.0)      # north: x constant, s = y - y0
    assert np.all(pn[:, 0] == 300.0) and np.allclose(sn, pn[:, 1] - 600.0)
    (pe, se, _), = section_surface(V, T, o, 90.0)     # east: y constant, s = x - x0
    assert np.all(pe[:, 1] == 600.0) and np.allclose(se, pe[:, 0] - 300.0)
    (ps, ss, _), = section_surface(V, T, o, 180.0)    # south: s = y0 - y
    assert np.allclose(ss, 600.0 - ps[:, 1])
    assert section_direction(45.0) == pytest.approx([np.sqrt(0.5), np.sqrt(0.5)])
    assert section_direction(450.0).tolist() == [1.0, 0.0]


def test_vertices_and_edges_exactly_on_the_plane():
    V, T = grid_tin()
    # x = 5 is a grid line: every node on it is a vertex of the TIN and the
    # grid edges between them lie in the plane.
    (p, s, closed), = section_surface(V, T, (5.0, 0.0), 0.0)
    assert not closed
    assert p.tolist() == [[5.0, y, 4.5] for y in range(11)]
    assert s.tolist() == list(map(float, range(11)))
    # The diagonal through grid vertices: crossing vertices and crossing edges alike.
    (p, s, _), = section_surface(V, T, (0.0, 0.0), 45.0)
    assert np.all(np.diff(s) > 0)
    assert np.allclose(p[:, 0], p[:, 1], atol=1e-12)
    on_grid = [q for q in p.tolist() if q[0] == int(q[0]) and q[1] == int(q[1])]
    assert on_grid == [[float(k), float(k), 0.5 * k + 2.0] for k in range(11)]


def test_touching_at_one_vertex_only_gives_nothing():
    V = np.array([[0.0, 0.0, 0.0], [-1.0, -1.0, 0.0], [-1.0, 1.0, 0.0], [-2.0, 0.0, 0.0]])
    T = np.array([[0, 2, 1], [1, 2, 3]])
    # The plane x = 0 meets the surface at vertex 0 only.
    assert section_surface(V, T, (0.0, 5.0), 0.0) == []
    # A plane that misses the surface entirely.
    assert section_surface(V, T, (10.0, 0.0), 0.0) == []


def test_closed_polyline_through_vertices_and_in_plane_edges():
    # An octahedron: the plane x = 0 passes through four vertices and four edges.
    V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    T = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4],
                  [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    (p, s, closed), = section_surface(V, T, (0.0, 0.0), 0.0)
    assert closed and len(p) == 5 and p[0].tolist() == p[-1].tolist()
    assert sorted(map(tuple, p[:-1].tolist())) == sorted([(0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)])
    # A plane through the interior: a closed quadrilateral of edge crossings.
    (p, s, closed), = section_surface(V, T, (0.5, 0.0), 0.0)
    assert closed and len(p) == 5
    assert np.allclose(np.abs(p[:-1, 1]) + np.abs(p[:-1, 2]), 0.5)


def test_triangle_lying_in_the_plane_contributes_its_edges():
    V = np.array([[0, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 0.5]], float)
    T = np.array([[0, 1, 2], [0, 3, 1]])
    res = section_surface(V, T, (0.0, 0.0), 0.0)
    pts = np.vstack([p for p, _, _ in res])
    assert sorted(set(map(tuple, pts.tolist()))) == [(0, 0, 0), (0, 0, 1), (0, 1, 0)]
    n_segments = sum(len(p) - 1 for p, _, _ in res)
    assert n_segments == 3


def folded_surface():
    """A reverse-fault-like Z fold in x: footwall (x 0..5), a strip going back
    to x = 4 while rising, the hanging wall (x 4..10) above. The strip
    triangles are clockwise in XY, the two walls overlap for x in 4..5."""
    xs = [0, 1, 2, 3, 4, 5, 4, 5, 6, 7, 8, 9, 10]
    zs = [0, 0, 0, 0, 0, 0, 10, 10, 10, 10, 10, 10, 10]
    ys = [0.0, 1.0, 2.0]
    V = np.array([[x, y, z] for y in ys for x, z in zip(xs, zs)], float)
    n = len(xs)
    T = []
    for j in range(len(ys) - 1):
        for i in range(n - 1):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1
            T += [[a, b, d], [a, d, c]]
    return V, np.array(T)


def test_folded_surface_gives_one_polyline_going_back_and_forth():
    V, T = folded_surface()
    # Along the middle grid row (vertices and edges in the plane) ...
    (p, s, closed), = section_surface(V, T, (0.0, 1.0), 90.0)
    assert not closed
    assert p[:, 0].tolist() == [0, 1, 2, 3, 4, 5, 4, 5, 6, 7, 8, 9, 10]
    assert np.all(p[:, 1] == 1.0)
    assert (np.diff(s) < 0).sum() == 1          # the strip runs backwards
    # ... and between rows (edge crossings only): one polyline, the same shape.
    (p, s, closed), = section_surface(V, T, (0.0, 1.5), 90.0)
    assert np.all(p[:, 1] == 1.5)
    assert p[0, 0] == 0.0 and p[-1, 0] == 10.0
    assert np.sum(np.diff(np.sign(np.diff(s))) != 0) == 2     # forward, back, forward


def brute_force_segments(V, T, o, az):
    """Per triangle, the crossing points by plain floating point (general position)."""
    d = section_direction(az)
    n = np.array([d[1], -d[0]])
    dist = (V[:, :2] - o) @ n
    segs = []
    for t in T:
        pts = []
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            if dist[a] * dist[b] < 0:
                u = dist[a] / (dist[a] - dist[b])
                pts.append(V[a] + u * (V[b] - V[a]))
        if len(pts) == 2:
            segs.append(pts)
    return segs


@pytest.mark.parametrize("seed", range(5))
def test_random_tins_match_a_brute_force_cut(seed):
    rng = np.random.default_rng(seed)
    xy = rng.random((200, 2)) * 100
    V = np.column_stack([xy, np.sin(xy[:, 0] / 9) * 5 + rng.random(200)])
    T = faultmesh.delaunay(xy)
    o, az = rng.random(2) * 100, rng.uniform(0, 360)
    res = section_surface(V, T, o, az)
    ref = brute_force_segments(V, T, o, az)
    total = sum(np.linalg.norm(p[1] - p[0]) for p in ref)
    got = sum(np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p, _, _ in res)
    assert got == pytest.approx(total, rel=1e-12)
    assert sum(len(p) - 1 for p, _, _ in res) == len(ref)
    # A convex TIN cut by a line through its hull: a single polyline.
    assert len(res) <= 1


def test_chain_handles_branches_and_cycles():
    assert _chain(np.zeros((0, 2), np.int64), 0) == []
    out = _chain(np.array([[0, 1], [1, 2], [2, 0], [3, 4], [4, 5]]), 6)
    kinds = sorted((len(nodes), closed) for nodes, closed in out)
    assert kinds == [(3, False), (4, True)]
    # A node of degree 3 ends the three polylines that meet there.
    out = _chain(np.array([[0, 1], [1, 2], [1, 3], [3, 4]]), 5)
    assert sorted(len(n) for n, _ in out) == [2, 2, 3]


def test_section_model_csv_and_plot(tmp_path):
    V1, T1 = plane_tin(c=0.0)
    V2, T2 = plane_tin(seed=1, c=-100.0)
    fault = Surface("F 1", np.array([[500, -10, 100], [500, 1010, 100], [520, -10, -300],
                                     [520, 1010, -300.0]]), np.array([[0, 2, 1], [1, 2, 3]]),
                    kind="fault")
    m = Model("two layers", {"upper": Surface("upper", V1, T1), "lower": Surface("lower", V2, T2)},
              {"F 1": fault})
    sec = m.section((0.0, 500.0), 90.0)
    assert [ln.surface for ln in sec.lines] == ["upper", "lower", "F 1"]
    assert sec.polylines("F 1")[0].kind == "fault"
    (f,) = sec.polylines("F 1")
    assert f.xyz[:, 0].min() == pytest.approx(500.0) and f.xyz[:, 0].max() == pytest.approx(520.0)
    p = sec.to_csv(tmp_path / "cut.csv")
    rows = list(csv.DictReader(p.open()))
    assert list(rows[0]) == ["surface", "kind", "part", "s", "x", "y", "z"]
    assert len(rows) == sum(len(ln.s) for ln in sec.lines)
    up = [r for r in rows if r["surface"] == "upper"]
    # Exact floats in the CSV.
    assert [float(r["z"]) for r in up] == sec.polylines("upper")[0].xyz[:, 2].tolist()
    fig = sec.plot(tmp_path / "cut.png", vertical_exaggeration=3)
    assert (tmp_path / "cut.png").stat().st_size > 10_000
    assert fig.axes[0].get_aspect() == 3.0
    with pytest.raises(ValueError, match="origin must be two finite numbers"):
        m.section((1.0, 2.0, 3.0), 0.0)
    with pytest.raises(ValueError, match="azimuth must be a finite number"):
        section_model(m, (1.0, 2.0), float("nan"))
