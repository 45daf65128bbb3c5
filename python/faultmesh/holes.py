"""Data holes of a layer, filled smoothly before its TIN is final.

A layer's continuous TIN (:class:`faultmesh.LayerTin`, the Delaunay TIN of
its data) is linear in every triangle. Where the data are dense that is
what the data say; across a *hole* -- a region many data spacings wide
without data (a gap in the seismic coverage, picks withheld or not
picked near a fault, an area no borehole reached) -- the TIN bridges the
hole with a few long triangles, a plane between the data on its rim, also
where the layer curves (a dome, a syncline). :func:`hole_fill` finds such
holes and returns points inside them from a minimum-curvature surface
through the data around each hole (the interpolant of the derived side
surfaces, :func:`faultmesh.derive._min_curvature`), which the build
inserts into the TIN (:func:`faultmesh.build.stratum_tins`,
``build_model(fill_holes=True)``, off by default). Only holes get points: a
TIN of data without holes is left as it is (the detection costs one pass
over its triangles), and outside a hole the TIN's triangles are the
data's. In a fault's zone the filled points are replaced with the rest of
the layer there by the fault patch.
"""
from __future__ import annotations

import math
from typing import Optional, Tuple

import numpy as np

__all__ = ["hole_fill", "HOLE_RADIUS", "FILL_RADIUS"]

#: A hole is an empty circle (no datum, no TIN vertex inside) of radius
#: above HOLE_RADIUS data spacings (the median edge length of the TIN).
#: For data scattered at random (a Poisson process, the most irregular
#: data without holes) the chance that a given point has no datum within r
#: is exp(-pi r^2 rho); with the median TIN edge about 1.1 / sqrt(rho) (in
#: a Poisson Delaunay triangulation), 5 spacings is a disk of 5.5^2 pi =
#: 95 mean data areas, exp(-95): never, for any number of data. Regular
#: data (seismic lines) have empty circles of about 0.7 spacings.
HOLE_RADIUS = 5.0
#: Inside a hole, points are placed where the nearest TIN vertex is more
#: than FILL_RADIUS data spacings away: the TIN stays linear across the
#: rim's last FILL_RADIUS spacings (where the nearest data decide), and
#: the filled points never crowd the data. Measured on Claudius (every
#: pick within 300 m of the fault withheld, val_330 median error at those
#: picks): 1.5, 2, 2.5, 3 spacings: 11.4, 11.0, 11.3, 11.7 m.
FILL_RADIUS = 2.0
#: Cell of the minimum-curvature grid, in data spacings (median TIN edges,
#: about 1.5 nearest-neighbour distances): a third, so that neighbouring
#: data fall in different cells (with coarser cells the nearly
#: interpolating fit has to reconcile several data per cell and rings
#: across the hole).
CELL = 1.0 / 3.0


def _circumradius2(V: np.ndarray, T: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Squared circumradius (t,) and squared length of one edge (t,) of the
    triangles T of V (XY): R^2 = a^2 b^2 c^2 / (4 (2 area)^2), no square
    root (the detection runs on every layer's TIN, holes or not)."""
    a, b, c = V[T[:, 0], :2], V[T[:, 1], :2], V[T[:, 2], :2]
    ab, ac, bc = b - a, c - a, c - b
    l2ab = np.einsum("ij,ij->i", ab, ab)
    l2ac = np.einsum("ij,ij->i", ac, ac)
    l2bc = np.einsum("ij,ij->i", bc, bc)
    cross = ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        R2 = l2ab * l2ac * l2bc / (4.0 * cross * cross)
    R2[~np.isfinite(R2)] = np.inf
    return R2, l2bc


def _circumcentres(V: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Circumcentres (t, 2) of the triangles T of V (XY)."""
    a, b, c = V[T[:, 0], :2], V[T[:, 1], :2], V[T[:, 2], :2]
    ab, ac = b - a, c - a
    d = 2.0 * (ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0])
    r2b, r2c = np.sum(ab * ab, axis=1), np.sum(ac * ac, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        cx = (ac[:, 1] * r2b - ab[:, 1] * r2c) / d
        cy = (ab[:, 0] * r2c - ac[:, 0] * r2b) / d
    return a + np.stack([cx, cy], axis=1)


def hole_fill(vertices: np.ndarray, triangles: np.ndarray, data: np.ndarray, ring: np.ndarray, *,
              hole_radius: float = HOLE_RADIUS, fill_radius: float = FILL_RADIUS,
              tension: Optional[float] = None, anchors: Optional[np.ndarray] = None) -> np.ndarray:
    """Points (k, 3) that fill the data holes of a layer TIN (module doc).

    vertices (n, 3), triangles (t, 3): the layer's TIN (e.g.
    ``LayerTin.mesh()``); data (m, 3): its data points; ring: the study
    area. A hole: an empty circumcircle of the TIN of radius above
    ``hole_radius`` data spacings, its centre in the study area. Filled:
    the nodes of a grid of one data spacing that lie in the study area, in
    a connected region of nodes farther than ``fill_radius`` spacings from
    every TIN vertex, that region holding a hole. Their z: the
    minimum-curvature surface (:func:`faultmesh.derive._min_curvature`,
    smoothing length :data:`faultmesh.derive.SMOOTHING` spacings, as the
    derived side surfaces) through the data within the hole's radius of
    the region's box. Without tension by default: a hole is enclosed by
    data (or by data and the study-area boundary, where the TIN has its
    own extrapolated vertices), and the rim's curvature carried into it is
    what a syncline or dome needs (the test ground's 700 m hole in a
    syncline: median error 33 m for the TIN, 15 m with the side surfaces'
    tension of 3 spacings, 8.8 m without). ``tension`` (m): the slope
    relaxes over that length towards the plane of the data around the
    hole. ``anchors`` (k, 3): points the TIN already holds besides the
    data (its study-area boundary vertices, z extrapolated from the data),
    fitted as data: where a hole reaches the boundary the fill joins the
    TIN's own extrapolation there instead of continuing the rim's slope
    (Claudius val_250, a hole open to the boundary: 7160 repair
    insertions in val_330 below it without anchors, 766 without the fill).
    Empty (0, 3) when there is no hole."""
    from scipy import ndimage
    from scipy.spatial import cKDTree

    from .dataset import points_in_polygon
    from .derive import SMOOTHING, GridFrame, _min_curvature, one_blas_thread

    V = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    D = np.asarray(data, dtype=np.float64).reshape(-1, 3)
    none = np.zeros((0, 3))
    if len(T) == 0 or len(D) < 3:
        return none
    if anchors is not None:
        D = np.concatenate([D, np.asarray(anchors, dtype=np.float64).reshape(-1, 3)])
    R2, L2 = _circumradius2(V, T)
    # The data spacing: the median TIN edge (one edge per triangle samples
    # the edges evenly: each inner edge belongs to two triangles).
    s = math.sqrt(float(np.median(L2)))
    if not s > 0:
        return none
    big = R2 > (hole_radius * s) ** 2
    if not big.any():
        return none
    ring = np.asarray(ring, dtype=np.float64).reshape(-1, 2)
    big[big] = points_in_polygon(_circumcentres(V, T[big]), ring)
    if not big.any():
        return none
    R = np.sqrt(R2)
    # The fill region lies in triangles whose circumradius exceeds the fill
    # radius (inside a triangle the nearest vertex is at most its
    # circumradius away); its box bounds the grid.
    cand = R > fill_radius * s
    lo = np.maximum(V[T[cand]].reshape(-1, 3)[:, :2].min(axis=0), ring.min(axis=0))
    hi = np.minimum(V[T[cand]].reshape(-1, 3)[:, :2].max(axis=0), ring.max(axis=0))
    g = s
    nx, ny = int(math.floor((hi[0] - lo[0]) / g)) + 1, int(math.floor((hi[1] - lo[1]) / g)) + 1
    gx, gy = lo[0] + g * np.arange(nx), lo[1] + g * np.arange(ny)
    G = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1).reshape(-1, 2)
    dist = cKDTree(V[:, :2]).query(G)[0].reshape(nx, ny)
    mask = dist > fill_radius * s
    labels, n = ndimage.label(mask)
    if n == 0:
        return none
    # Regions holding a hole (a node farther than hole_radius from every
    # vertex, up to the grid's cell: s / sqrt(2) from the hole's centre).
    far = ndimage.maximum(dist, labels, index=np.arange(1, n + 1))
    out = []
    for k in np.flatnonzero(far > hole_radius * s - 0.75 * g) + 1:
        ii, jj = np.nonzero(labels == k)
        P = np.stack([gx[ii], gy[jj]], axis=1)
        P = P[points_in_polygon(P, ring)]
        if not len(P):
            continue
        radius = float(far[k - 1])
        blo, bhi = P.min(axis=0) - radius, P.max(axis=0) + radius
        near = np.flatnonzero(np.all((D[:, :2] >= blo) & (D[:, :2] <= bhi), axis=1))
        if len(near) < 3:
            continue
        W = D[near]
        frame = GridFrame.around(P[0], (1.0, 0.0), (blo[0] - P[0, 0], bhi[0] - P[0, 0]),
                                 (blo[1] - P[0, 1], bhi[1] - P[0, 1]), CELL * s)
        # The plane of the data around the hole: the slope a tension
        # relaxes to (dz/du, dz/dw of the frame; e_u is x).
        A = np.c_[np.ones(len(W)), W[:, :2] - W[:, :2].mean(axis=0)]
        slope = np.linalg.lstsq(A, W[:, 2], rcond=None)[0][1:]
        nodes, _ = one_blas_thread(_min_curvature)(frame, W[:, :2], W[:, 2], SMOOTHING * s, tension, slope)
        out.append(np.c_[P, frame.bilinear(P) @ nodes])
    return np.concatenate(out) if out else none
