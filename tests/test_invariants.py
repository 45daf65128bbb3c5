"""faultmesh.invariants: every check passes on good surfaces and catches a
deliberately broken one, naming the surface, the invariant and an element."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import faultmesh
from faultmesh.invariants import check_gaps, check_model, check_surface, on_boundary_tolerance
from faultmesh.model import Gap, Model, Surface

SQ = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])


def grid(n=4, z=None):
    """An n x n grid of squares over SQ, two CCW triangles each."""
    g = np.linspace(0.0, 4.0, n + 1)
    X, Y = np.meshgrid(g, g)
    V = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size) if z is None else z(X.ravel(), Y.ravel())])
    T = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            b, c, d = a + 1, a + n + 2, a + n + 1
            T += [[a, b, c], [a, c, d]]
    return V, np.array(T, dtype=np.int64)


def S(V, T, name="bed", kind="layer"):
    return Surface(name, V, T, kind=kind)


def test_good_surface_passes():
    V, T = grid(z=lambda x, y: 0.3 * x - y)
    check_surface(S(V, T), SQ)
    check_surface(S(V, T, kind="fault"), None)


def test_translated_utm_magnitudes_pass():
    off = np.array([550000.0, 7820000.0])
    V, T = grid()
    V[:, :2] += off
    check_surface(S(V, T), SQ + off)


@pytest.mark.parametrize("seed", range(5))
def test_area_at_big_offsets_passes(seed):
    """A star polygon of 5 km with random (unrounded) vertices at 3.8e7 m:
    the study area's own shoelace sum must not err by more than the check
    allows (sweep seeds 13, 98, 108: products x*y of 1.5e14 m^2 rounded by
    0.02 m^2 each made good layers fail 'area')."""
    rng = np.random.default_rng(seed)
    ang = np.sort(rng.uniform(0.0, 2.0 * np.pi, 40))
    r = rng.uniform(1500.0, 2500.0, 40)
    ring = np.column_stack([r * np.cos(ang), r * np.sin(ang)]) + [38428624.6, 3349209.05]
    tri = faultmesh.triangulate_polygon([ring])
    V = np.column_stack([ring, rng.uniform(-50.0, 0.0, len(ring))])
    check_surface(S(V, tri), ring)


@pytest.mark.parametrize("breakage,invariant,element", [
    ("index", "conforming", "triangle 3"),
    ("repeat", "conforming", "repeats a vertex"),
    ("unused", "conforming", "not used by any triangle"),
    ("duplicate", "conforming", "duplicates"),
    ("collinear3d", "conforming", "zero area"),
    ("nonmanifold", "conforming", "is used by 3 triangles"),
    ("nan", "conforming", "non-finite"),
    ("flip", "consistent orientation", "used twice in the same direction"),
    ("pieces", "topological disk", "edge-connected pieces"),
    ("pinch", "topological disk", "pinch vertex"),
    ("hole", "topological disk", "loops"),
    ("closed", "topological disk", "closed"),
    ("shrunk", "boundary on the study area", "off the study-area boundary"),
    ("chord", "boundary on the study area", "cuts across"),
    ("reversed", "area", "signed XY areas add up to -16"),
])
def test_each_invariant_catches_a_broken_surface(breakage, invariant, element):
    V, T = grid()
    n = len(V)
    if breakage == "index":
        T[3, 1] = n + 5
    elif breakage == "repeat":
        T[2, 2] = T[2, 0]
    elif breakage == "unused":
        V = np.vstack([V, [[9.0, 9.0, 9.0]]])
    elif breakage == "duplicate":
        # A copy of vertex 7 used by one of its triangles, the original by the others.
        V = np.vstack([V, V[7:8]])
        t = int(np.flatnonzero((T == 7).any(axis=1))[0])
        T[t][T[t] == 7] = n
    elif breakage == "collinear3d":
        # Flat in XY and in 3D: three points on a line (a strip's zero-area triangle).
        V = np.vstack([V, [[5.0, 5.0, 0.0], [6.0, 6.0, 1.0], [7.0, 7.0, 2.0]]])
        T = np.vstack([T, [[n, n + 1, n + 2]]])
    elif breakage == "nonmanifold":
        V = np.vstack([V, [[1.0, 1.0, 5.0]]])
        T = np.vstack([T, [[0, 6, n]]])   # third triangle on the interior edge (0, 6)
    elif breakage == "nan":
        V[4, 2] = np.nan
    elif breakage == "flip":
        T[5] = T[5, ::-1]
    elif breakage == "pieces":
        W = V.copy()
        W[:, 0] += 10.0
        V = np.vstack([V, W])
        T = np.vstack([T, T + n])
    elif breakage == "pinch":
        # Remove the cells (1, 1) and (2, 2): around their common vertex
        # (2, 2) the rest forms two fans (the surface stays edge-connected).
        cells = np.repeat(np.arange(16), 2)
        T = T[(cells != 5) & (cells != 10)]
    elif breakage == "hole":
        # Remove the four triangles around the centre vertex: an annulus.
        centre = 12
        T = T[~(T == centre).any(axis=1)]
        V = V.copy()
        used = np.unique(T)
        remap = -np.ones(n, int)
        remap[used] = np.arange(len(used))
        V, T = V[used], remap[T]
    elif breakage == "closed":
        V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
        T = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    elif breakage == "shrunk":
        V[:, :2] = 0.5 + 0.75 * V[:, :2]
    elif breakage == "chord":
        # Cut off the corner triangle at (4, 0): boundary edge across the square.
        corner = 4
        T = T[~(T == corner).any(axis=1)]
        keep = np.unique(T)
        remap = -np.ones(n, int)
        remap[keep] = np.arange(len(keep))
        V, T = V[keep], remap[T]
    elif breakage == "reversed":
        T = T[:, ::-1]
    with pytest.raises(faultmesh.GeometryError) as ei:
        check_surface(S(V, T), SQ)
    msg = str(ei.value)
    assert "surface 'bed'" in msg
    assert f"invariant '{invariant}'" in msg
    assert element in msg


def test_reverse_fold_cancels_in_the_area():
    # A fold along x: footwall 0 -> 1 -> 3 (z 0), fault strip back 3 -> 2 -> 1
    # (clockwise in XY, z 0 -> -2), hanging wall 1 -> 3 -> 4 (z -2), lofted
    # between y = 0 and y = 4: the band 1..3 is covered three times and the
    # signed areas add up to one cover.
    xs = [0.0, 1.0, 3.0, 2.0, 1.0, 3.0, 4.0]
    zs = [0, 0, 0, -1, -2, -2, -2]
    row0 = np.array([[x, 0.0, z] for x, z in zip(xs, zs)])
    row1 = np.array([[x, 4.0, z] for x, z in zip(xs, zs)])
    V = np.vstack([row0, row1])
    k = len(xs)
    T = []
    for i in range(k - 1):
        a, b, c, d = i, i + 1, k + i + 1, k + i
        T += [[a, b, c], [a, c, d]]
    T = np.array(T)
    check_surface(S(V, T), SQ)
    o = faultmesh.orient2d(V[T[:, 0], :2], V[T[:, 1], :2], V[T[:, 2], :2])
    assert (o < 0).sum() == 4 and (o > 0).sum() == len(T) - 4


# A rectangle 5 x 4 with a notch from its west side whose tip (2.5, 2) is a
# reflex corner; a reverse fault's band 2 <= x <= 3 holds the tip, the notch
# enters it across x = 2 only.
NOTCHED = np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 4.0], [0.0, 4.0], [0.0, 2.5], [2.5, 2.0], [0.0, 1.5]])


def fold_round_the_notch(band=(2.0, 3.0)):
    """The layer folded by that fault, in the notched area: footwall (z 0)
    where x <= a, strip (z 1 -> 0, clockwise in XY) where b <= x <= a,
    hanging wall (z 1) where x >= b, glued along x = a and x = b. The notch
    tip lies in the band and the notch crosses x = b only, so the strip and
    the hanging wall both run round the tip: an annulus whose second
    boundary loop runs along the notch's sides, out on one sheet and back on
    the other (sweep seed 677)."""
    b, a = band
    ring = [tuple(p) for p in NOTCHED]

    def part(lo, hi):
        # The notched area cut to lo <= x <= hi (vertices where the sides
        # cross those lines), by Sutherland-Hodgman against both lines.
        pts = ring
        for x0, keep_right in ((lo, True), (hi, False)):
            out = []
            for i in range(len(pts)):
                p, q = pts[i], pts[(i + 1) % len(pts)]
                ip, iq = (p[0] >= x0) == keep_right, (q[0] >= x0) == keep_right
                if ip:
                    out.append(p)
                if ip != iq:
                    t = (x0 - p[0]) / (q[0] - p[0])
                    out.append((x0, p[1] + t * (q[1] - p[1])))
            pts = out
        r = np.array(pts, dtype=np.float64)
        keep = np.ones(len(r), dtype=bool)
        keep[1:] = (np.abs(np.diff(r, axis=0)) > 0).any(axis=1)
        return r[keep]

    Vs, Ts, off = [], [], 0
    for lo, hi, z, flip in ((-1.0, a, lambda x: 0.0 * x, False), (b, a, lambda x: (a - x) / (a - b), True),
                            (b, 6.0, lambda x: 1.0 + 0.0 * x, False)):
        r = part(lo, hi)
        t = np.asarray(faultmesh.triangulate_polygon([r]), dtype=np.int64)
        Vs.append(np.column_stack([r, z(r[:, 0])]))
        Ts.append((t[:, ::-1] if flip else t) + off)
        off += len(r)
    V, T = np.vstack(Vs), np.vstack(Ts)
    # Glue the sheets: one vertex per (x, y, z).
    V, inv = np.unique(V, axis=0, return_inverse=True)
    return V, inv.reshape(-1)[T]


@pytest.mark.parametrize("offset", [(0.0, 0.0), (550000.3, 7820000.7)])
def test_fold_round_a_reflex_corner_passes(offset):
    V, T = fold_round_the_notch()
    from faultmesh import boundary_contours
    assert len(boundary_contours(T, n_vertices=len(V)).loops) == 2
    # At UTM-sized coordinates too (the loop's vertices then sit off the
    # notch's sides by the rounding of the offset).
    V[:, :2] += offset
    check_surface(S(V, T), NOTCHED + offset)
    # Not so without the study area, nor for a fault surface.
    with pytest.raises(faultmesh.GeometryError, match="topological disk.*2 loops"):
        check_surface(S(V, T), None)
    with pytest.raises(faultmesh.GeometryError, match="topological disk.*2 loops"):
        check_surface(S(V, T, kind="fault"), None)


def test_second_loop_must_run_along_the_area_and_enclose_nothing():
    V, T = fold_round_the_notch()
    # The notch moved 0.1 east: the second loop is off the study area.
    moved = NOTCHED.copy()
    moved[5, 0] += 0.1
    with pytest.raises(faultmesh.GeometryError, match="topological disk.*2 loops.*not on the study-area"):
        check_surface(S(V, T), moved)
    # The strip's side of the notch cut short (its tip vertex moved onto the
    # side nearer x = b, still on the polygon): the loop encloses a sliver.
    tip = np.flatnonzero((V[:, 0] == 2.5) & (V[:, 1] == 2.0) & (V[:, 2] == 0.5))
    assert len(tip) == 1
    W = V.copy()
    W[tip[0], :2] = [2.25, 2.05]
    with pytest.raises(faultmesh.GeometryError, match="topological disk.*encloses"):
        check_surface(S(W, T), NOTCHED)


def test_vertical_strip_has_zero_xy_area_but_is_not_degenerate():
    # A vertical fault strip: footwall cutoff and hanging-wall cutoff at the
    # same XY, different z. Zero XY area is fine; zero 3D area is not.
    xs = [0.0, 2.0, 2.0, 4.0]
    zs = [0.0, 0.0, -1.0, -1.0]
    V = np.vstack([np.array([[x, 0.0, z] for x, z in zip(xs, zs)]),
                   np.array([[x, 4.0, z] for x, z in zip(xs, zs)])])
    T = []
    for i in range(3):
        a, b, c, d = i, i + 1, 4 + i + 1, 4 + i
        T += [[a, b, c], [a, c, d]]
    check_surface(S(V, np.array(T)), SQ)


def test_boundary_tolerance_is_relative_to_magnitude():
    assert on_boundary_tolerance(SQ) == pytest.approx(64 * 2.0 ** -53 * 4.0)
    big = SQ + 7.8e6
    assert on_boundary_tolerance(big) < 1e-6


def test_gap_checks():
    V, T = grid()
    surf = S(V, T)
    check_gaps(surf, [Gap("F", "bed", np.arange(4), n_vertices=6, n_holes=0)])
    with pytest.raises(faultmesh.GeometryError, match="gap triangle count.*n \\+ 2h - 2 \\+ 2k = 6"):
        check_gaps(surf, [Gap("F", "bed", np.arange(5), n_vertices=6, n_holes=1)])
    with pytest.raises(faultmesh.GeometryError, match="outside"):
        check_gaps(surf, [Gap("F", "bed", np.array([0, 1, 99]), n_vertices=5, n_holes=0)])
    W, U = V.copy(), T.copy()
    U[1] = U[1, ::-1]
    with pytest.raises(faultmesh.GeometryError, match="gap triangles CCW.*clockwise"):
        check_gaps(S(W, U), [Gap("F", "bed", np.arange(3), n_vertices=5, n_holes=0)])


def test_check_model_names_the_bad_surface():
    V, T = grid()
    fault_V = np.array([[1, 1, 0], [3, 1, 0], [1, 1, -2], [3, 1, -2]], float)
    fault_T = np.array([[0, 1, 3], [0, 3, 2]])
    m = Model("m", {"bed": S(V, T)}, faults={"F1": S(fault_V, fault_T, "F1", "fault")}, boundary=SQ)
    m.check()
    check_model(m)
    bad = fault_T.copy()
    bad[1] = bad[1, ::-1]
    m.faults["F1"] = S(fault_V, bad, "F1", "fault")
    with pytest.raises(faultmesh.GeometryError, match="surface 'F1'.*consistent orientation"):
        m.check()
    m.faults.clear()
    m.gaps.append(Gap("F9", "nope", np.arange(1), 3, 0))
    with pytest.raises(faultmesh.GeometryError, match="unknown layers"):
        m.check()


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([0.0, 5.0e5, 7.8e6]), st.sampled_from([1.0, 40.0, 3000.0]))
def test_nearest_segment_matches_every_pair(seed, offset, length):
    """faultmesh.nearest_segment (C++, a walk over the segments sorted by x)
    against the distance to every segment (numpy): the same distance and,
    among ties, the lowest index; random and repeated segments, zero-length
    ones, points on segments and at their ends, UTM-sized offsets."""
    from faultmesh.invariants import _point_segment_distance

    rng = np.random.default_rng(seed)
    m, n = int(rng.integers(1, 60)), int(rng.integers(1, 80))
    A = offset + rng.uniform(-500, 500, size=(m, 2))
    ang = rng.uniform(0, 2 * np.pi, m)
    B = A + rng.uniform(0, length, m)[:, None] * np.c_[np.cos(ang), np.sin(ang)]
    B[: m // 10] = A[: m // 10]                          # zero-length segments
    if m > 2:
        A[-1], B[-1] = A[0], B[0]                        # a repeated segment
    P = np.vstack([offset + rng.uniform(-800, 800, size=(n, 2)), A[:5], B[:5],
                   0.5 * (A[:5] + B[:5])])
    idx, dist = faultmesh.nearest_segment(P, A, B)
    every = _point_segment_distance(P, A, B)
    assert np.allclose(dist, every.min(axis=1), rtol=1e-12, atol=1e-9 * max(1.0, offset))
    # The chosen segment is at that distance (ties: any of the nearest within rounding).
    assert np.allclose(every[np.arange(len(P)), idx], every.min(axis=1), rtol=1e-12,
                       atol=1e-9 * max(1.0, offset))


def test_nearest_segment_edge_cases_and_errors():
    idx, dist = faultmesh.nearest_segment(np.array([[0.0, 0.0]]), np.zeros((0, 2)), np.zeros((0, 2)))
    assert idx.tolist() == [-1] and np.isinf(dist[0])
    # Two identical segments: the lower index; x, y of (k, 3) arrays only.
    idx, dist = faultmesh.nearest_segment(np.array([[1.0, 1.0, 99.0]]), np.array([[0, 0, 5], [0, 0, 7.0]]),
                                          np.array([[2, 0, 5], [2, 0, 7.0]]))
    assert idx.tolist() == [0] and dist.tolist() == [1.0]
    with pytest.raises(ValueError, match=r"nearest_segment: starts and ends must have the same number of rows"):
        faultmesh.nearest_segment(np.zeros((1, 2)), np.zeros((2, 2)), np.zeros((1, 2)))
    with pytest.raises(ValueError, match=r"nearest_segment: points row 1 has a non-finite coordinate"):
        faultmesh.nearest_segment(np.array([[0, 0], [np.nan, 0.0]]), np.zeros((1, 2)), np.ones((1, 2)))
    with pytest.raises(ValueError, match=r"nearest_segment: ends row 0 has a coordinate beyond"):
        faultmesh.nearest_segment(np.zeros((1, 2)), np.zeros((1, 2)), np.array([[1e61, 0.0]]))
