"""The invariants every layer surface of a model must keep (docs/design.md §5).

:func:`check_surface` checks one surface, :func:`check_model` every surface
and every stitched gap of a :class:`~faultmesh.model.Model`
(``Model.check()``). A violated invariant raises
:class:`faultmesh.GeometryError` whose message names the surface, the
invariant and an offending element (vertex, edge or triangle), e.g.::

    check_surface: surface 'coal8': invariant 'conforming' violated: edge (12, 40)
    is used by 3 triangles (rows 7, 9, 311)

Layer surfaces (``kind == "layer"``):

conforming
    triangle indices in range and distinct; every vertex finite and used;
    no two vertices with identical (x, y, z); no triangle of zero area --
    decided exactly: a triangle is degenerate iff its three projections on the
    XY, YZ and ZX planes all have ``orient2d == 0`` (collinear in 3D). Zero
    *XY* area alone is legitimate: a vertical fault strip projects to a
    segment; each edge in at most two triangles.
consistent orientation
    in 3D, through edge directions: every interior edge is used once in each
    direction. The XY orientation of single triangles is not required: the
    fault strip of a reverse fault is legitimately clockwise in XY (the
    surface folds back over itself in the repetition band).
topological disk
    edge-connected; around every vertex the triangles form one fan (no pinch
    or "bow-tie" vertex); one boundary loop; Euler characteristic
    ``V - E + F == 1``. A connected orientable surface with one boundary
    component and characteristic 1 has genus 0: a disk. One exception, for
    a layer checked against its study area: a layer folded round a reflex
    corner of the area (the corner inside a reverse fault's band, its notch
    entering the band across one cutoff line only) is an annulus, with a
    second loop along the notch's sides; loops beyond the outer one are
    allowed where each lies wholly on the study-area polygon and encloses no
    XY area (:func:`_loops_off_the_area`), with ``V - E + F == 2 - loops``
    (genus 0).
boundary on the study area
    every boundary vertex lies on the study-area polygon and every boundary
    edge along one of its sides (tolerance below).
area
    the signed XY areas of the triangles add up to the study area: the
    projection covers the study area exactly once, counting the fold of a
    reverse fault as footwall (+), strip (-), hanging wall (+).

Fault surfaces (``kind == "fault"``) are checked for the first three groups
only (they are near-vertical: no XY requirement).

Gaps (:class:`~faultmesh.model.Gap`, ``triangles`` = row indices into the
layer surface's triangles): a gap polygon with ``n`` vertices and ``h`` holes
and ``k`` layer data put back inside it (``Gap.n_interior``) has exactly
``n + 2h - 2 + 2k`` triangles, each counter-clockwise with non-zero area in
XY (the gap is ear-clipped in XY, then each point splits a triangle).
"""
from __future__ import annotations

import math
from typing import Iterable, Optional

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ._core import GeometryError, nearest_segment, orient2d

# Unit roundoff of IEEE double (2^-53).
_EPS = 2.0 ** -53


def _fail(name: str, invariant: str, detail: str) -> None:
    raise GeometryError(f"check_surface: surface {name!r}: invariant '{invariant}' "
                        f"violated: {detail}")


def on_boundary_tolerance(boundary: np.ndarray) -> float:
    """Distance within which a point counts as lying on the study-area polygon.

    Boundary vertices are computed, not given: a side is densified as
    ``a + t (b - a)`` and trace points on a boundary section are converted
    from ``(s, z)`` as ``origin + s (sin az, cos az)``. Each of these is
    within a few units in the last place of the largest coordinate of the
    exact side (two roundings of a product and a sum), so ``64 eps max|c|``
    accepts every computed point with a wide margin and still rejects any
    point off the side by more than ~1e-7 m at UTM magnitudes (1e7 m).
    Exact tests (orient2d == 0) would reject correctly computed points on
    sides that are not axis-parallel.
    """
    b = np.asarray(boundary, dtype=np.float64)
    scale = max(1.0, float(np.abs(b).max()))
    return 64.0 * _EPS * scale


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances (k, s) of points p (k, 2) to segments a->b (s, 2): every
    pair (the nearest segment alone: :func:`faultmesh._core.nearest_segment`)."""
    d = b - a  # (s, 2)
    ap = p[:, None, :] - a[None, :, :]
    dd = np.einsum("ij,ij->i", d, d)
    t = np.einsum("kij,ij->ki", ap, d) / np.where(dd > 0, dd, 1.0)
    t = np.clip(t, 0.0, 1.0)
    c = a[None, :, :] + t[..., None] * d[None, :, :]
    return np.hypot(p[:, None, 0] - c[..., 0], p[:, None, 1] - c[..., 1])


def _signed_area(poly: np.ndarray) -> float:
    # Relative to the first vertex: at UTM-sized or bigger coordinates the
    # products x*y of absolute coordinates (1e14 m^2 and more) would each be
    # rounded by about 0.01 m^2, more than the area check allows.
    d = poly - poly[0]
    x, y = d[:, 0], d[:, 1]
    return 0.5 * math.fsum(x * np.roll(y, -1) - np.roll(x, -1) * y)


def _boundary_walk(bfrom: np.ndarray, bto: np.ndarray, n: int):
    """Loops of directed boundary edges; returns (n_loops, bad vertex or -1,
    the loop of each boundary vertex: (n,) labels 0, 1, ..., -1 off the
    boundary)."""
    out_deg = np.bincount(bfrom, minlength=n)
    in_deg = np.bincount(bto, minlength=n)
    label = np.full(n, -1, dtype=np.int64)
    bad = np.flatnonzero((out_deg > 1) | (in_deg > 1) | (out_deg != in_deg))
    if bad.size:
        return -1, int(bad[0]), label
    nxt = np.full(n, -1, dtype=np.int64)
    nxt[bfrom] = bto
    loops = 0
    for s in bfrom:
        if label[s] >= 0:
            continue
        v = s
        while label[v] < 0:
            label[v] = loops
            v = nxt[v]
        loops += 1
    return loops, -1, label


def _loops_off_the_area(V: np.ndarray, bfrom: np.ndarray, bto: np.ndarray, label: np.ndarray,
                        loops: int, boundary: np.ndarray) -> Optional[str]:
    """Why a layer surface with ``loops`` > 1 boundary loops is not the
    folded layer of a concave study area, or None if it is.

    The layer is the image of the unfolded layer under the fold of each
    reverse fault (footwall, strip, hanging wall). Where a reflex corner of
    the study area lies inside a repetition band and its notch enters the
    band across one cutoff line only (sweep seed 677: a U-shaped area, the
    notch's tip 60 m into F2's band, the band passing the corner on its
    other side 5-8 m wide, in the truth as in the model), the strip and the
    sheet joined to it along that cutoff line both run round the notch's
    tip and meet again on its other side: the layer in the study area is an
    annulus, not a disk, with a second boundary loop that runs along the
    notch's sides out on one sheet and back on the other. Such a loop lies
    wholly on the study-area polygon and encloses no XY area. A hole inside
    the area (missing triangles) has boundary vertices off the polygon; a
    second cover of the area would enclose it. So: every loop but the one
    enclosing the most must have all its vertices on the polygon (the
    tolerance of :func:`on_boundary_tolerance`) and a signed XY area of zero
    within what those offsets and rounding allow (the bound of the area
    invariant, per loop)."""
    B = np.asarray(boundary, dtype=np.float64).reshape(-1, 2)
    if len(B) >= 2 and np.array_equal(B[0], B[-1]):
        B = B[:-1]
    tol = on_boundary_tolerance(B)
    lab = label[bfrom]
    twice = np.zeros(loops)
    allow = np.zeros(loops)
    for k in range(loops):
        sel = lab == k
        p, q = V[bfrom[sel], :2], V[bto[sel], :2]
        ref = p[0]
        p, q = p - ref, q - ref
        terms = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
        twice[k] = math.fsum(terms)
        perimeter = float(np.hypot(*(q - p).T).sum())
        # Twice the area: each term rounded by a few eps of its permanent
        # (fsum adds them exactly); each vertex up to tol off its side, which
        # moves twice the enclosed area by at most 2 * perimeter * tol --
        # allowed twice over, as the area invariant allows per layer.
        allow[k] = 8.0 * _EPS * math.fsum(np.abs(p[:, 0] * q[:, 1]) + np.abs(q[:, 0] * p[:, 1])) \
            + 4.0 * perimeter * tol
    outer = int(np.argmax(np.abs(twice)))
    for k in range(loops):
        if k == outer:
            continue
        verts = bfrom[lab == k]
        d = nearest_segment(V[verts, :2], B, np.roll(B, -1, axis=0))[1]
        if (d > tol).any():
            v = int(verts[np.argmax(d)])
            return (f"loop {k} (through vertex {v} {V[v, :2].tolist()}) is not on the study-area "
                    f"boundary: a hole in the layer ({d.max():.6g} off the boundary)")
        if abs(twice[k]) > allow[k]:
            v = int(verts[0])
            return (f"loop {k} (through vertex {v} {V[v, :2].tolist()}) lies on the study-area "
                    f"boundary but encloses {twice[k] / 2:.6g} in XY (tolerance {allow[k] / 2:.3g})")
    return None


def check_surface(surface, boundary: Optional[np.ndarray] = None) -> None:
    """Check the invariants (docs/design.md §5) of one surface; raise GeometryError.

    ``boundary`` is the study area (k, 2); it is required for the boundary
    and area invariants of a layer surface and ignored for a fault surface.
    """
    name = surface.name
    V = np.asarray(surface.vertices, dtype=np.float64)
    T = np.asarray(surface.triangles, dtype=np.int64)
    is_layer = getattr(surface, "kind", "layer") != "fault"
    n, m = len(V), len(T)

    # ---------------------------------------------------------- conforming
    if m == 0:
        _fail(name, "conforming", "the surface has no triangles")
    if V.ndim != 2 or V.shape[1] != 3 or T.ndim != 2 or T.shape[1] != 3:
        _fail(name, "conforming", f"vertices {V.shape} / triangles {T.shape} are not (n, 3) / (m, 3)")
    bad = np.flatnonzero(~np.isfinite(V).all(axis=1))
    if bad.size:
        _fail(name, "conforming", f"vertex {bad[0]} has a non-finite coordinate {V[bad[0]].tolist()}")
    bad = np.flatnonzero((T < 0).any(axis=1) | (T >= n).any(axis=1))
    if bad.size:
        _fail(name, "conforming", f"triangle {bad[0]} {T[bad[0]].tolist()} has an index outside "
              f"[0, {n})")
    bad = np.flatnonzero((T[:, 0] == T[:, 1]) | (T[:, 1] == T[:, 2]) | (T[:, 2] == T[:, 0]))
    if bad.size:
        _fail(name, "conforming", f"triangle {bad[0]} {T[bad[0]].tolist()} repeats a vertex")
    used = np.zeros(n, dtype=bool)
    used[T.ravel()] = True
    if not used.all():
        v = int(np.flatnonzero(~used)[0])
        _fail(name, "conforming", f"vertex {v} {V[v].tolist()} is not used by any triangle")
    _, inv, counts = np.unique(V, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    if (counts > 1).any():
        group = int(np.flatnonzero(counts > 1)[0])
        dup = np.flatnonzero(inv == group)[:2]
        _fail(name, "conforming", f"vertices {dup[0]} and {dup[1]} are duplicates at "
              f"{V[dup[0]].tolist()}")
    a, b, c = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    o_xy = orient2d(a[:, [0, 1]], b[:, [0, 1]], c[:, [0, 1]])
    flat = o_xy == 0.0
    if flat.any():
        # Only triangles flat in XY can be degenerate in 3D; test them on the
        # other two coordinate planes (exactly: collinear in 3D iff all three
        # projections are collinear).
        idx = np.flatnonzero(flat)
        o_yz = orient2d(a[idx][:, [1, 2]], b[idx][:, [1, 2]], c[idx][:, [1, 2]])
        o_zx = orient2d(a[idx][:, [2, 0]], b[idx][:, [2, 0]], c[idx][:, [2, 0]])
        deg = idx[(o_yz == 0.0) & (o_zx == 0.0)]
        if deg.size:
            t = int(deg[0])
            _fail(name, "conforming", f"triangle {t} {T[t].tolist()} has zero area "
                  "(its vertices are collinear in 3D)")

    # Half-edges a->b, b->c, c->a of every triangle.
    hf = T.reshape(-1)
    ht = T[:, [1, 2, 0]].reshape(-1)
    htri = np.repeat(np.arange(m), 3)
    lo, hi = np.minimum(hf, ht), np.maximum(hf, ht)
    ukey = lo * n + hi
    order = np.argsort(ukey, kind="stable")
    sk = ukey[order]
    starts = np.flatnonzero(np.r_[True, sk[1:] != sk[:-1]])
    ecount = np.diff(np.r_[starts, len(sk)])
    if (ecount > 2).any():
        g = int(np.flatnonzero(ecount > 2)[0])
        rows = htri[order[starts[g]:starts[g] + ecount[g]]]
        e = (int(lo[order[starts[g]]]), int(hi[order[starts[g]]]))
        _fail(name, "conforming", f"edge {e} is used by {ecount[g]} triangles (rows "
              f"{', '.join(str(int(r)) for r in rows)})")

    # ------------------------------------------------ consistent orientation
    dkey = hf * n + ht
    dsorted = np.sort(dkey)
    dup = np.flatnonzero(dsorted[1:] == dsorted[:-1])
    if dup.size:
        k = int(dsorted[dup[0]])
        e = (k // n, k % n)
        rows = htri[dkey == k]
        _fail(name, "consistent orientation", f"edge {e} is used twice in the same direction "
              f"(triangles {int(rows[0])} and {int(rows[1])}): the neighbours disagree on "
              "which side is up")

    # ------------------------------------------------------ topological disk
    # Pair each half-edge with its twin (interior edges: counts == 2).
    pair_first = order[starts[ecount == 2]]
    pair_second = order[starts[ecount == 2] + 1]
    t1, t2 = htri[pair_first], htri[pair_second]
    n_comp, _ = connected_components(
        coo_matrix((np.ones(len(t1)), (t1, t2)), shape=(m, m)), directed=False)
    if n_comp != 1:
        _, lab = connected_components(
            coo_matrix((np.ones(len(t1)), (t1, t2)), shape=(m, m)), directed=False)
        t = int(np.flatnonzero(lab != lab[0])[0])
        _fail(name, "topological disk", f"the triangles form {n_comp} edge-connected pieces "
              f"(triangle {t} {T[t].tolist()} is not connected to triangle 0)")
    # One fan per vertex: corners (triangle, vertex) joined across interior
    # edges; the corners of a vertex must form one connected component.
    # Corner id: 3 * triangle + position. Half-edge h = 3 t + k runs from
    # corner k to corner (k + 1) % 3 of triangle t.
    def corner(h, step):
        t = h // 3
        return 3 * t + (h % 3 + step) % 3

    h1, h2 = pair_first, pair_second
    # h1 runs u->v, h2 runs v->u (orientation is consistent, checked above).
    ca = np.r_[corner(h1, 0), corner(h1, 1)]
    cb = np.r_[corner(h2, 1), corner(h2, 0)]
    nc = 3 * m
    _, clab = connected_components(coo_matrix((np.ones(len(ca)), (ca, cb)), shape=(nc, nc)),
                                   directed=False)
    cvert = T.reshape(-1)
    fans = np.unique(np.column_stack([cvert, clab]), axis=0)
    nfans = np.bincount(fans[:, 0], minlength=n)
    if (nfans > 1).any():
        v = int(np.flatnonzero(nfans > 1)[0])
        _fail(name, "topological disk", f"vertex {v} {V[v].tolist()} is a pinch vertex: its "
              f"triangles form {nfans[v]} separate fans")
    bsel = order[starts[ecount == 1]]
    bfrom, bto = hf[bsel], ht[bsel]
    if len(bfrom) == 0:
        _fail(name, "topological disk", "the surface is closed (no boundary edge)")
    loops, badv, label = _boundary_walk(bfrom, bto, n)
    if badv >= 0:
        _fail(name, "topological disk", f"vertex {badv} {V[badv].tolist()} is on the boundary "
              "more than once")
    if loops != 1:
        # A layer folded round a reflex corner of the study area has a second
        # loop along the corner's notch (_loops_off_the_area); nothing else may.
        # Without the study area (or on a fault surface) no loop beyond the
        # first is allowed.
        why = (_loops_off_the_area(V, bfrom, bto, label, loops, boundary)
               if is_layer and boundary is not None else "")
        if why is not None:
            _fail(name, "topological disk", f"the boundary has {loops} loops, expected 1 "
                  f"(e.g. a hole around boundary edge ({int(bfrom[-1])}, {int(bto[-1])}))"
                  + (f": {why}" if why else ""))
    n_edges = len(starts)
    chi = n - n_edges + m
    # Connected, orientable, genus 0: V - E + F = 2 - (number of loops).
    if chi != 2 - loops:
        _fail(name, "topological disk", f"Euler characteristic V - E + F = {n} - {n_edges} + "
              f"{m} = {chi}, expected {2 - loops} (genus 0 with {loops} boundary loop"
              f"{'s' if loops > 1 else ''})")

    if not is_layer or boundary is None:
        return

    # --------------------------------------------- boundary on the study area
    B = np.asarray(boundary, dtype=np.float64).reshape(-1, 2)
    if len(B) >= 2 and np.array_equal(B[0], B[-1]):
        B = B[:-1]
    A, Bn = B, np.roll(B, -1, axis=0)
    tol = on_boundary_tolerance(B)
    bverts = np.unique(bfrom)
    on_side = np.zeros((n, len(B)), dtype=bool)
    for lo_ in range(0, len(bverts), 4096):
        chunk = bverts[lo_:lo_ + 4096]
        on_side[chunk] = _point_segment_distance(V[chunk, :2], A, Bn) <= tol
    off = bverts[~on_side[bverts].any(axis=1)]
    if off.size:
        v = int(off[0])
        d = float(nearest_segment(V[v:v + 1, :2], A, Bn)[1][0])
        _fail(name, "boundary on the study area", f"boundary vertex {v} {V[v, :2].tolist()} is "
              f"{d:.6g} off the study-area boundary (tolerance {tol:.3g})")
    along = (on_side[bfrom] & on_side[bto]).any(axis=1)
    if not along.all():
        k = int(np.flatnonzero(~along)[0])
        _fail(name, "boundary on the study area", f"boundary edge ({int(bfrom[k])}, {int(bto[k])}) "
              "cuts across the study area instead of running along one of its sides")

    # ------------------------------------------------------------------ area
    # Sum of twice the signed XY areas, each computed from differences (as
    # orient2d's floating-point filter does). Rounding bound: each term errs
    # by at most ~3 eps * its permanent |dx1 dy2| + |dy1 dx2| (plus eps of the
    # coordinate differences), and math.fsum adds them exactly; boundary
    # vertices may sit up to `tol` off the exact sides, which changes the
    # covered area by at most perimeter * tol. So the sum must match the
    # polygon's area within 8 eps * sum(permanents) + 2 * perimeter * tol.
    dx1, dy1 = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    dx2, dy2 = c[:, 0] - a[:, 0], c[:, 1] - a[:, 1]
    twice = math.fsum(dx1 * dy2 - dy1 * dx2)
    perm = math.fsum(np.abs(dx1 * dy2) + np.abs(dy1 * dx2))
    perimeter = float(np.hypot(*(Bn - A).T).sum())
    want = 2.0 * abs(_signed_area(B))
    allow = 8.0 * _EPS * perm + 2.0 * (2.0 * perimeter * tol) + 8.0 * _EPS * want
    if abs(twice - want) > allow:
        neg = np.flatnonzero(o_xy < 0)
        hint = (f"; {neg.size} triangles are clockwise in XY, e.g. {int(neg[0])} {T[neg[0]].tolist()}"
                if neg.size else "")
        _fail(name, "area", f"the signed XY areas add up to {twice / 2:.12g}, the study area is "
              f"{want / 2:.12g} (difference {abs(twice - want) / 2:.3g}, tolerance "
              f"{allow / 2:.3g}){hint}")


def check_gaps(surface, gaps: Iterable) -> None:
    """Check the stitched gaps of one layer surface: ``Gap.triangles`` are row
    indices into ``surface.triangles``; a polygon with n vertices and h holes
    has n + 2h - 2 of them, plus 2 per removed layer datum put back inside
    (``n_interior``), each counter-clockwise with non-zero area in XY."""
    name = surface.name
    T = np.asarray(surface.triangles, dtype=np.int64)
    V = np.asarray(surface.vertices, dtype=np.float64)
    m = len(T)
    for g in gaps:
        rows = np.asarray(g.triangles, dtype=np.int64).reshape(-1)
        k = int(getattr(g, "n_interior", 0))
        want = int(g.n_vertices) + 2 * int(g.n_holes) - 2 + 2 * k
        label = f"gap of {g.fault!r} in {g.layer!r}"
        if len(rows) != want:
            raise GeometryError(
                f"check_surface: surface {name!r}: invariant 'gap triangle count' violated: "
                f"{label} has {len(rows)} triangles, a polygon with n = {g.n_vertices} vertices "
                f"and h = {g.n_holes} holes and k = {k} interior vertices must have "
                f"n + 2h - 2 + 2k = {want}")
        if len(rows) == 0:
            continue
        if rows.min() < 0 or rows.max() >= m:
            raise GeometryError(
                f"check_surface: surface {name!r}: invariant 'gap triangles in the surface' "
                f"violated: {label} refers to triangle row {int(rows.max() if rows.max() >= m else rows.min())} "
                f"outside [0, {m})")
        if len(np.unique(rows)) != len(rows):
            raise GeometryError(
                f"check_surface: surface {name!r}: invariant 'gap triangles in the surface' "
                f"violated: {label} lists a triangle row twice")
        gt = T[rows]
        o = orient2d(V[gt[:, 0], :2], V[gt[:, 1], :2], V[gt[:, 2], :2])
        if (o <= 0).any():
            k = int(np.flatnonzero(o <= 0)[0])
            raise GeometryError(
                f"check_surface: surface {name!r}: invariant 'gap triangles CCW' violated: "
                f"{label}: triangle row {int(rows[k])} {gt[k].tolist()} is "
                f"{'degenerate' if o[k] == 0 else 'clockwise'} in XY")


def check_model(model) -> None:
    """Check every layer surface (with its gaps) and every fault surface."""
    if not model.surfaces:
        raise GeometryError(f"check_model: model {model.name!r} has no layer surface")
    for layer, surf in model.surfaces.items():
        check_surface(surf, model.boundary)
        check_gaps(surf, [g for g in model.gaps if g.layer == layer])
    for surf in model.faults.values():
        check_surface(surf, None)
    unknown = sorted({g.layer for g in model.gaps} - set(model.surfaces))
    if unknown:
        raise GeometryError(f"check_model: model {model.name!r}: gaps refer to unknown layers "
                            f"{unknown}")
