"""faultmesh.triangulate_polygon: ear clipping of polygons with holes.

Fixtures: tests/data/earcut (mapbox/earcut's test polygons, ISC licence).
Validity is decided by faultmesh.check_polygon (strictly simple, disjoint
rings, holes inside the outer ring); it is cross-checked here against a
brute-force O(n^2) segment test on the smaller fixtures.
"""
from __future__ import annotations

import json
import sys
from concurrent.futures import ThreadPoolExecutor
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st, HealthCheck

import faultmesh as fm
from helpers import tri_set

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
import bench_polygon  # noqa: E402

DATA = Path(__file__).resolve().parent / "data" / "earcut"
EXPECTED = json.loads((DATA / "expected.json").read_text())
NAMES = sorted(p.stem for p in DATA.glob("*.json") if p.stem != "expected")

# Invalid fixtures whose best-effort triangulation does not (yet) reach the
# area deviation earcut's own suite lists for them. Each is still asserted
# to triangulate without crashing into CCW non-degenerate triangles and to
# keep at most n + 2h - 2 triangles; its deviation is reported, not asserted.
# Empty now: issue149 (outer ring with zero-width spikes around the hole)
# and water-huge2 (a hole inside another hole, outer ring crossing itself)
# reach it since the joiner drops spikes and leaves out holes outside the
# region, and the quality order defers ears whose diagonal crosses an edge.
BEST_EFFORT_AREA_GAPS: set[str] = set()


def load(name: str) -> list[np.ndarray]:
    rings = json.loads((DATA / f"{name}.json").read_text())
    return [np.asarray(r, dtype=np.float64).reshape(-1, 2) for r in rings]


def dedup_count(r: np.ndarray) -> int:
    """Vertices after dropping consecutive duplicates (and a closing point)."""
    keep = [r[0]]
    for p in r[1:]:
        if not np.array_equal(p, keep[-1]):
            keep.append(p)
    while len(keep) > 1 and np.array_equal(keep[0], keep[-1]):
        keep.pop()
    return len(keep)


def expected_count(rings) -> int:
    return sum(dedup_count(r) for r in rings) + 2 * (len(rings) - 1) - 2


def exact_twice_area_rings(rings) -> Fraction:
    total = Fraction(0)
    for i, r in enumerate(rings):
        s = Fraction(0)
        for k in range(len(r)):
            x0, y0 = r[k]
            x1, y1 = r[(k + 1) % len(r)]
            s += Fraction(x0) * Fraction(y1) - Fraction(x1) * Fraction(y0)
        total += abs(s) if i == 0 else -abs(s)
    return total


def area_rings_outer(rings) -> Fraction:
    return exact_twice_area_rings(rings[:1])


def earcut_deviation(rings, tris) -> float:
    """Area deviation as earcut's test suite computes it (earcut.deviation):
    |sum of |triangle areas| - polygon area| / polygon area, the polygon area
    being |outer ring| - sum |hole|, each ring's area by the shoelace formula
    (net area for a self-crossing ring). Exact rational arithmetic here; 0 when
    both areas are 0."""
    pts = np.concatenate(rings)
    pa = exact_twice_area_rings(rings)
    ta = Fraction(0)
    for a, b, c in tris:
        ax, ay = map(Fraction, pts[a])
        bx, by = map(Fraction, pts[b])
        cx, cy = map(Fraction, pts[c])
        ta += abs((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))
    if pa == 0 and ta == 0:
        return 0.0
    if pa == 0:
        return float("inf")
    return abs(float((ta - pa) / pa))


def exact_twice_area_tris(pts: np.ndarray, tris: np.ndarray) -> Fraction:
    total = Fraction(0)
    for a, b, c in tris:
        ax, ay = map(Fraction, pts[a])
        bx, by = map(Fraction, pts[b])
        cx, cy = map(Fraction, pts[c])
        total += (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return total


def orient(pts, tris):
    return fm.orient2d(pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]])


def centroids_inside(rings, tris, pts) -> np.ndarray:
    """Even-odd rule for the triangle centroids (never on a ring for a valid polygon)."""
    c = pts[tris].mean(axis=1)
    inside = np.zeros(len(c), dtype=bool)
    for r in rings:
        a, b = r, np.roll(r, -1, axis=0)
        for (x0, y0), (x1, y1) in zip(a, b):
            if y0 == y1:
                continue
            cond = (y0 > c[:, 1]) != (y1 > c[:, 1])
            xint = x0 + (c[:, 1] - y0) * (x1 - x0) / (y1 - y0)
            inside ^= cond & (c[:, 0] < xint)
    return inside


def brute_force_simple(rings) -> bool:
    """O(n^2) check with the exact orient2d: no two non-consecutive edges meet."""
    segs = []
    for ri, r in enumerate(rings):
        k = dedup_count(r)
        rr = []
        for p in r:
            if not rr or not np.array_equal(p, rr[-1]):
                rr.append(p)
        rr = np.array(rr[:k])
        for i in range(k):
            segs.append((ri, i, k, rr[i], rr[(i + 1) % k]))
    n = len(segs)
    p0 = np.array([s[3] for s in segs])
    p1 = np.array([s[4] for s in segs])
    for i in range(n):
        ri, ki, kk = segs[i][:3]
        j = np.arange(i + 1, n)
        consecutive = np.array([segs[t][0] == ri and ((ki + 1) % kk == segs[t][1] or (segs[t][1] + 1) % kk == ki)
                                for t in j], dtype=bool)
        A = np.repeat(p0[i:i + 1], len(j), 0)
        B = np.repeat(p1[i:i + 1], len(j), 0)
        o1 = np.sign(fm.orient2d(A, B, p0[j]))
        o2 = np.sign(fm.orient2d(A, B, p1[j]))
        o3 = np.sign(fm.orient2d(p0[j], p1[j], A))
        o4 = np.sign(fm.orient2d(p0[j], p1[j], B))
        proper = (o1 * o2 < 0) & (o3 * o4 < 0)

        def on(a, b, q, o):
            lo, hi = np.minimum(a, b), np.maximum(a, b)
            return (o == 0) & np.all((q >= lo) & (q <= hi), axis=1)

        touch = on(A, B, p0[j], o1) | on(A, B, p1[j], o2) | on(p0[j], p1[j], A, o3) | on(p0[j], p1[j], B, o4)
        # Consecutive edges share exactly their common vertex; anything more is a defect.
        shared_only = consecutive & ~proper
        if consecutive.any():
            # overlap of consecutive edges: the far endpoints collinear and on the same side
            pass
        bad = proper | (touch & ~shared_only)
        if bad.any():
            return False
    return True


# ----------------------------------------------------------------- fixtures


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("opts", [dict(refine=False, order="plain"), dict(refine=False), dict()],
                         ids=["plain", "quality", "quality+refine"])
def test_fixture_invariants(name, opts):
    rings = load(name)
    pts = np.concatenate(rings)
    valid, message, _, _ = fm.check_polygon(rings)
    tris = fm.triangulate_polygon(rings, **opts)
    assert tris.dtype == np.int64 and tris.ndim == 2 and tris.shape[1] == 3
    assert tris.size == 0 or (tris.min() >= 0 and tris.max() < len(pts))
    if len(tris):
        assert (orient(pts, tris) > 0).all(), "every triangle strictly counter-clockwise"
    assert len(tris) <= max(expected_count(rings), 0)
    area_rings = exact_twice_area_rings(rings)
    area_tris = exact_twice_area_tris(pts, tris)
    err = EXPECTED["errors"].get(name, 0.0)
    if valid:
        assert name not in BEST_EFFORT_AREA_GAPS
        assert len(tris) == expected_count(rings), message
        # Exact rational arithmetic: a valid polygon is covered exactly.
        assert area_tris == area_rings
        assert centroids_inside(rings, tris, pts).all()
    elif area_rings <= 0:
        # No region: a degenerate outer ring, or holes as large as the outer
        # ring (a hole identical to it). earcut returns no triangles either
        # (its suite checks no deviation when it expects 0 triangles).
        assert len(tris) == 0, f"{name}: {len(tris)} triangles for a polygon of area {float(area_rings)}"
    else:
        dev = earcut_deviation(rings, tris)
        if name not in BEST_EFFORT_AREA_GAPS:
            assert dev <= err, f"{name}: deviation {dev} > earcut's {err} ({message})"


def test_validity_decisions_match_brute_force():
    """check_polygon agrees with an O(n^2) exact segment test (small fixtures)."""
    checked = 0
    for name in NAMES:
        rings = load(name)
        if sum(len(r) for r in rings) > 700:
            continue
        if any(dedup_count(r) < 3 for r in rings):
            assert not fm.check_polygon(rings)[0]
            continue
        valid = fm.check_polygon(rings)[0]
        if brute_force_simple(rings) is False:
            assert not valid, name
        checked += 1
    assert checked > 30


def test_valid_fixture_list_is_not_empty():
    valid = [n for n in NAMES if fm.check_polygon(load(n))[0]]
    assert {"building", "dude", "earcut", "eberly-6", "hilbert", "issue35"} <= set(valid)


# ----------------------------------------------------------------- CDT


def ring_edge_set(rings):
    edges = set()
    off = 0
    for r in rings:
        k = len(r)
        idx = [off]
        for i in range(1, k):
            if not np.array_equal(r[i], r[idx[-1] - off]):
                idx.append(off + i)
        while len(idx) > 1 and np.array_equal(r[idx[0] - off], r[idx[-1] - off]):
            idx.pop()
        for i in range(len(idx)):
            a, b = idx[i], idx[(i + 1) % len(idx)]
            edges.add((min(a, b), max(a, b)))
        off += k
    return edges


def non_delaunay_edges(pts, tris, constrained) -> int:
    """Interior, non-ring edges whose opposite vertex is strictly inside the circumcircle."""
    half = {}
    for t, (a, b, c) in enumerate(tris):
        for u, v, w in ((a, b, c), (b, c, a), (c, a, b)):
            half[(u, v)] = w
    A, B, C, D = [], [], [], []
    for (u, v), w in half.items():
        if u < v and (v, u) in half and (u, v) not in constrained:
            A.append(u)
            B.append(v)
            C.append(w)
            D.append(half[(v, u)])
    if not A:
        return 0
    ic = fm.incircle(pts[A], pts[B], pts[C], pts[D])
    return int((ic > 0).sum())


@pytest.mark.parametrize("name", [n for n in NAMES if n in {"building", "dude", "earcut", "eberly-6", "hilbert",
                                                               "issue16", "issue29", "issue35", "issue52"}])
def test_refined_is_constrained_delaunay(name):
    rings = load(name)
    pts = np.concatenate(rings)
    cons = ring_edge_set(rings)
    tris = fm.triangulate_polygon(rings)
    assert non_delaunay_edges(pts, tris, cons) == 0
    raw = fm.triangulate_polygon(rings, refine=False)
    # The flips change the plain ear clipping here (so the check is not vacuous) ...
    if name in {"dude", "earcut", "eberly-6"}:
        assert non_delaunay_edges(pts, raw, cons) > 0
    # ... and flipping the unrefined result gives the refined one.
    flipped = fm.flip_to_constrained_delaunay(pts, raw, np.array(sorted(cons), dtype=np.int64))
    assert tri_set(flipped) == tri_set(tris)


def run_cgal(exe, rings):
    """CGAL's constrained Delaunay triangulation of the polygon (the bench's runner)."""
    return bench_polygon.run_cgal(exe, rings, runs=1)[1]


def test_refined_equals_cgal_cdt(cgal_bin):
    exe = cgal_bin("cgal_polygon_cdt")
    compared = 0
    for name in NAMES:
        rings = load(name)
        if not fm.check_polygon(rings)[0]:
            continue
        ours = fm.triangulate_polygon(rings)
        ref = run_cgal(exe, rings)
        assert len(ours) == len(ref), name
        # Ties (hilbert is a grid) are decided by CGAL's own perturbation rule,
        # so the sets agree on every valid fixture, not only generic ones.
        assert tri_set(ours) == tri_set(ref), name
        compared += 1
    for seed in range(3):
        rings = star_polygon(np.random.default_rng(seed), 300, 5)
        assert tri_set(fm.triangulate_polygon(rings)) == tri_set(run_cgal(exe, rings))
        compared += 1
    assert compared >= 15


# ----------------------------------------------------------------- properties


def star_polygon(rng, n_outer, n_holes):
    """Star-shaped outer ring (radius 0.6..1) and small convex holes on the circle r = 0.3."""
    ang = np.sort(rng.uniform(0, 2 * np.pi, n_outer))
    rad = rng.uniform(0.6, 1.0, n_outer)
    rings = [np.c_[rad * np.cos(ang), rad * np.sin(ang)]]
    for h in range(n_holes):
        c = 0.3 * np.array([np.cos(2 * np.pi * h / max(n_holes, 1)), np.sin(2 * np.pi * h / max(n_holes, 1))])
        k = int(rng.integers(3, 7))
        a = np.sort(rng.uniform(0, 2 * np.pi, k))
        size = min(0.08, 0.25 * np.pi * 0.3 / max(n_holes, 1))
        rings.append(c + size * np.c_[np.cos(a), np.sin(a)])
    return rings


@st.composite
def polygons(draw):
    n = draw(st.integers(3, 40))
    angles = draw(st.lists(st.integers(0, 4095), min_size=n, max_size=n, unique=True))
    radii = draw(st.lists(st.integers(600, 1000), min_size=n, max_size=n))
    ang = np.sort(np.array(angles)) * (2 * np.pi / 4096)
    # Coordinates on a 1/1024 grid: exactly representable, also after +1e6.
    outer = np.round(np.c_[np.array(radii) * np.cos(ang), np.array(radii) * np.sin(ang)]) / 1024.0
    h = draw(st.integers(0, 4))
    rings = [outer]
    for i in range(h):
        c = 300 * np.array([np.cos(2 * np.pi * i / max(h, 1)), np.sin(2 * np.pi * i / max(h, 1))])
        k = draw(st.integers(3, 6))
        a = np.sort(np.array(draw(st.lists(st.integers(0, 359), min_size=k, max_size=k, unique=True)))) * np.pi / 180
        size = draw(st.integers(20, 60))
        rings.append(np.round(c + size * np.c_[np.cos(a), np.sin(a)]) / 1024.0)
    return rings


def polygon_edges_present(rings, tris) -> bool:
    present = {tuple(sorted(e)) for t in tris for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    return ring_edge_set(rings) <= present


def assert_triangulates(rings, tris, refine):
    """n + 2h - 2 counter-clockwise triangles inside the polygon, covering its
    exact area, every ring edge present; refined: constrained-Delaunay."""
    pts = np.concatenate(rings)
    assert len(tris) == expected_count(rings)
    assert (orient(pts, tris) > 0).all()
    assert exact_twice_area_tris(pts, tris) == exact_twice_area_rings(rings)
    assert centroids_inside(rings, tris, pts).all()
    assert polygon_edges_present(rings, tris)
    if refine:
        assert non_delaunay_edges(pts, tris, ring_edge_set(rings)) == 0


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(polygons(), st.sampled_from(["plain", "quality"]), st.booleans(), st.sampled_from(["extreme", "eberly"]))
def test_property_random_polygon(rings, order, refine, bridge):
    tris = fm.triangulate_polygon(rings, refine=refine, order=order, bridge=bridge)
    if fm.check_polygon(rings)[0]:  # rounding to the grid can make a tiny hole degenerate
        assert_triangulates(rings, tris, refine)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(polygons(), st.sampled_from([0, 1]), st.booleans())
def test_property_split_halves(rings, threads, refine):
    """Plain order with split_min=4: every loop is split along an inside
    diagonal (when one is found) and the halves are clipped, concurrently
    with threads=0. The same invariants hold, and the triangles do not
    depend on the thread count."""
    tris = fm.triangulate_polygon(rings, refine=refine, order="plain", split_min=4, threads=threads)
    other = fm.triangulate_polygon(rings, refine=refine, order="plain", split_min=4, threads=1 - threads)
    assert np.array_equal(tris, other)
    if not fm.check_polygon(rings)[0]:
        return
    assert_triangulates(rings, tris, refine)
    if refine:
        # The CDT is unique (ties broken by the same perturbation): the split
        # changes the ears, not the refined triangulation.
        assert tri_set(tris) == tri_set(fm.triangulate_polygon(rings, refine=True, order="plain", split_min=0))


def jagged_star(rng, n_outer, n_hole):
    """The bench polygon's shape: radius 1000 +- 25% (7-fold wave) +- 5% noise
    per vertex, four round holes."""
    ang = np.sort(rng.uniform(0, 2 * np.pi, n_outer))
    rad = 1000.0 * (1.0 + 0.25 * np.sin(7 * ang) + rng.uniform(-0.05, 0.05, n_outer))
    rings = [np.c_[rad * np.cos(ang), rad * np.sin(ang)]]
    for h in range(4):
        c = 350.0 * np.array([np.cos(np.pi / 2 * h + 0.3), np.sin(np.pi / 2 * h + 0.3)])
        a = np.linspace(0, 2 * np.pi, n_hole, endpoint=False)[::-1]
        rings.append(c + 120.0 * np.c_[np.cos(a), np.sin(a)])
    return rings


@pytest.mark.parametrize("seed", [1, 2])
def test_large_plain_polygon_is_split(seed):
    """At the default split_min (4096) a 10k-vertex polygon is split: the
    triangles differ from the unsplit clipping, do not depend on threads,
    and keep every invariant (exact area, count, orientation, ring edges)."""
    rings = jagged_star(np.random.default_rng(seed), 9000, 250)
    assert fm.check_polygon(rings)[0]
    tris = fm.triangulate_polygon(rings, refine=False, order="plain")
    assert np.array_equal(tris, fm.triangulate_polygon(rings, refine=False, order="plain", threads=1))
    assert not np.array_equal(tris, fm.triangulate_polygon(rings, refine=False, order="plain", split_min=0))
    assert_triangulates(rings, tris, refine=False)


def test_split_half_needing_fallbacks_clips_whole():
    """water3 (invalid: crossing rings that neither touch nor block a bridge)
    looks valid to the joiner; with split_min=4 a half meets a case for the
    fallbacks, which the halves cannot run, so the polygon is clipped whole:
    the same triangles as without the split."""
    rings = load("water3")
    for threads in (0, 1):
        split = fm.triangulate_polygon(rings, refine=False, order="plain", split_min=4, threads=threads)
        assert np.array_equal(split, fm.triangulate_polygon(rings, refine=False, order="plain", split_min=0))


def test_split_options_are_checked():
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    with pytest.raises(ValueError, match="threads"):
        fm.triangulate_polygon([sq], threads=2)
    with pytest.raises(ValueError, match="split_min"):
        fm.triangulate_polygon([sq], split_min=-1)


@settings(max_examples=30, deadline=None)
@given(polygons())
def test_metamorphic_translate_rotate_duplicate(rings):
    if not fm.check_polygon(rings)[0]:
        return
    base = fm.triangulate_polygon(rings)
    # Translation by 1e6 is exact on the 1/1024 grid and keeps the
    # lexicographic order, so even ties are decided the same way.
    moved = fm.triangulate_polygon([r + 1e6 for r in rings])
    assert tri_set(moved) == tri_set(base)
    # Rotation by 90 degrees (exact): the same count; the same triangles when
    # no four points of an interior edge are cocircular (ties are decided
    # by the lexicographic order, which a rotation changes).
    rot = [np.c_[-r[:, 1], r[:, 0]] for r in rings]
    rtris = fm.triangulate_polygon(rot)
    assert len(rtris) == len(base)
    pts = np.concatenate(rings)
    if not has_cocircular_edge(pts, base):
        assert tri_set(rtris) == tri_set(base)
    # Duplicate side by side: the copy gives the same triangles, twice the count.
    width = float(np.ptp(pts[:, 0])) * 2 + 1
    copy = fm.triangulate_polygon([r + np.array([width, 0.0]) for r in rings])
    both = np.concatenate([base, copy + len(pts)])
    assert len(both) == 2 * len(base)
    assert tri_set(copy) == tri_set(base)


def has_cocircular_edge(pts, tris) -> bool:
    half = {}
    for a, b, c in tris:
        for u, v, w in ((a, b, c), (b, c, a), (c, a, b)):
            half[(u, v)] = w
    quads = [(u, v, w, half[(v, u)]) for (u, v), w in half.items() if u < v and (v, u) in half]
    if not quads:
        return False
    q = np.array(quads)
    return bool((fm.incircle(pts[q[:, 0]], pts[q[:, 1]], pts[q[:, 2]], pts[q[:, 3]]) == 0).any())


# ----------------------------------------------------------------- API contract


def test_square_with_hole_and_orientations():
    outer = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    hole = np.array([[3, 3], [6, 3], [6, 6], [3, 6]], float)
    for o in (outer, outer[::-1]):
        for h in (hole, hole[::-1]):
            t = fm.triangulate_polygon([o, h])
            assert t.shape == (8, 3) and t.dtype == np.int64
            pts = np.concatenate([o, h])
            assert (orient(pts, t) > 0).all()
    assert fm.triangulate_polygon(outer).shape == (2, 3)  # one (n, 2) array = no holes


def test_collinear_vertices_and_closing_point():
    # Collinear vertices are kept (every vertex is used), no zero-area triangle.
    ring = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [3, 1], [0, 1], [0, 0]], float)
    t = fm.triangulate_polygon([ring], refine=False)
    assert len(t) == 4
    assert (orient(ring, t) > 0).all()
    assert set(np.unique(t)) == set(range(6))


def test_join_holes_returns_weakly_simple_loop():
    outer = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    hole = np.array([[3, 3], [6, 3], [6, 6], [3, 6]], float)
    for bridge in ("extreme", "eberly"):
        loop, bridges, skipped = fm.join_holes([outer, hole], bridge=bridge)
        assert len(loop) == 4 + 4 + 2 and bridges.shape == (1, 2) and len(skipped) == 0
        a, b = bridges[0]
        assert a < 4 <= b
        assert list(loop).count(a) == 2 and list(loop).count(b) == 2


def test_extreme_point_bridge_is_used_when_visible():
    # The hole's max-x vertex and the outer's max-x vertex see each other.
    outer = np.array([[0, 0], [10, 0], [12, 5], [10, 10], [0, 10]], float)
    hole = np.array([[3, 4], [8, 5], [3, 6]], float)
    _, bridges, _ = fm.join_holes([outer, hole], bridge="extreme")
    assert tuple(bridges[0]) == (2, 6)


def test_errors_name_the_problem():
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    with pytest.raises(ValueError, match=r"rings\[1\].*shape"):
        fm.triangulate_polygon([sq, np.zeros((3, 3))])
    with pytest.raises(ValueError, match="order"):
        fm.triangulate_polygon([sq], order="fast")
    with pytest.raises(ValueError, match="bridge"):
        fm.triangulate_polygon([sq], bridge="nearest")
    with pytest.raises(ValueError, match="non-finite"):
        fm.triangulate_polygon([np.array([[0, 0], [1, np.nan], [1, 1]])])
    bow = np.array([[0, 0], [1, 1], [1, 0], [0, 1]], float)
    with pytest.raises(fm.GeometryError, match="outer ring 0"):
        fm.triangulate_polygon([bow], strict=True)
    outside = np.array([[5, 5], [6, 5], [6, 6]], float)
    with pytest.raises(fm.GeometryError, match="ring 1 lies outside"):
        fm.triangulate_polygon([sq, outside], strict=True)
    # Best effort without strict: no crash, the outside hole is left out.
    assert len(fm.triangulate_polygon([sq, outside])) == 2
    assert fm.triangulate_polygon([np.array([[0, 0], [1, 1], [2, 2]], float)]).shape == (0, 3)
    assert fm.triangulate_polygon([]).shape == (0, 3)


@pytest.mark.parametrize("order", ["quality", "plain"])
def test_threads_give_identical_results(order):
    """Concurrent calls from Python threads (the GIL is released); in plain
    order each call also splits the polygon and runs a worker thread."""
    rings = star_polygon(np.random.default_rng(7), 20000, 4)
    kw = dict() if order == "quality" else dict(order="plain", refine=False)
    ref = fm.triangulate_polygon(rings, **kw)
    with ThreadPoolExecutor(2) as ex:
        outs = list(ex.map(lambda _: fm.triangulate_polygon(rings, **kw), range(4)))
    for o in outs:
        assert np.array_equal(o, ref)


def test_empty_outer_ring_is_named():
    """Regression (issue 10): triangulate_polygon([np.zeros((0, 2))]) said 'xy is null'."""
    for fn in (fm.triangulate_polygon, fm.join_holes):
        name = fn.__name__
        for k in (0, 1, 2):
            with pytest.raises(ValueError, match=rf"{name}: rings\[0\] \(the outer ring\) has {k} vert"):
                fn([np.zeros((k, 2))])
    # check_polygon reports it instead (it is the validity report).
    valid, msg, ring, _ = fm.check_polygon([np.zeros((0, 2))])
    assert not valid and ring == 0 and msg
    # A plain list of points is one ring.
    assert fm.triangulate_polygon([[0, 0], [1, 0], [1, 1]]).shape == (1, 3)


def test_coordinates_beyond_the_limit_are_value_errors():
    """Regression (issue 10): at 1e155 triangles came out outside the polygon."""
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    hole = np.array([[0.2, 0.2], [0.4, 0.2], [0.2, 1e155]])
    for fn in (fm.triangulate_polygon, fm.join_holes, fm.check_polygon):
        with pytest.raises(ValueError, match=rf"{fn.__name__}: ring 1 vertex 2 \(point 6\) has a coordinate "
                                             r"beyond \+-1e\+60 \(y = 1e\+155\)"):
            fn([sq, hole])
    with pytest.raises(ValueError, match=r"flip_to_constrained_delaunay: xy row 3 has a coordinate beyond"):
        fm.flip_to_constrained_delaunay(sq * [[1], [1], [1], [1e61]], np.array([[0, 1, 2], [0, 2, 3]]),
                                        np.zeros((0, 2), np.int64))
    with pytest.raises(ValueError, match=r"flip_to_constrained_delaunay: triangles row 1 has vertex index 4 out"):
        fm.flip_to_constrained_delaunay(sq, np.array([[0, 1, 2], [0, 2, 4]]), np.zeros((0, 2), np.int64))
    assert len(fm.triangulate_polygon([sq * 1e60])) == 2
