"""Mesh-quality report of a model (the paper's Tables 1 and 2, and more).

Angles
    The interior angles of every triangle, in 3D (the mesh as it is: what a
    simulator or a renderer sees) and in XY (the plane in which the gaps were
    ear-clipped). **The headline is 3D**, as in the paper, which measures the
    interior angles "of the triangles in the mesh model". A triangle is
    *narrow* when its smallest angle is under 10 degrees, or under 20 degrees
    (the paper's two thresholds); shares are fractions of the triangles counted.

Tables
    *Table 1*: per fault (rows) and layer (columns), the number of triangles
    created by stitching the gap(s). *Table 2*: per fault and layer, the share
    of those triangles whose smallest angle is under 10 and under 20 degrees.

Vertical error (when ``model.truth`` is set, e.g. built-in datasets)
    The model's layer surfaces are evaluated on a regular grid of sample
    points (cell centres) inside the study-area boundary: each sample is
    located in the layer's triangles in XY and the triangle's plane gives z
    (barycentric interpolation, the TIN's own surface). ``|dz| = |z_model -
    truth|`` is summarised in three regions:

    * ``away``: single-valued samples farther than ``near`` metres (default
      150 m) in XY from every fault surface (its triangles' XY footprint);
    * ``near``: single-valued samples within ``near`` metres of a fault;
    * ``overlap``: samples where the layer surface has several sheets (the
      footwall, fault strip and hanging wall of a reverse fault cover the same
      XY). The ground truth reports the upper (hanging-wall) sheet there, so
      the model's upper sheet (largest z) is compared with it.

    Distances to faults are measured on the sample grid (accurate to about one
    grid spacing). Samples where the model has no triangle or the truth has no
    value (NaN) are left out and counted.
"""
from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from ._core import ON_OUTLINE

__all__ = ["QualityReport", "quality", "triangle_angles", "min_angles", "evaluate_surface",
           "vertical_errors", "accuracy_near_faults", "gap_quality", "data_fit", "data_misses",
           "layer_order"]

THRESHOLDS = (10.0, 20.0)

#: A datum counts as honoured when the model passes within this vertical
#: distance (m) of it: a millimetre, below any survey's or pick's
#: precision and far above the rounding of the TIN's interpolation at a
#: vertex (ulps of the elevation: 1e-10 m at 1 km).
DATA_FIT_TOLERANCE = 1e-3


#: A triangle within this distance (m, XY) of a datum counts as covering it
#: (:func:`data_misses`): a datum placed on a patch's outline lies a rounding
#: off it, where only the other sheets of a fold cover it exactly (held-out
#: random ground 146 as v2: picks on F1's outline "missed" by 31 m, 1e-10 m
#: from their own vertices). The placement's own micrometre
#: (patch_data.hpp, kOnOutline; build.ON_OUTLINE).
DATA_REACH = ON_OUTLINE


def data_misses(surface, D: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per point of ``D`` (n, 3): the vertical distance to the sheet of
    ``surface`` nearest to it (0 where no triangle covers it in map view),
    that sheet's z (NaN there) and its triangle (-1 there)
    (:func:`faultmesh.nearest_sheet` within :data:`DATA_REACH`: where a
    reverse fault folds the layer, each datum is compared with its own
    sheet)."""
    from ._core import nearest_sheet

    D = np.ascontiguousarray(np.asarray(D, dtype=np.float64).reshape(-1, 3))
    near, tri = nearest_sheet(surface.vertices, surface.triangles, D, reach=DATA_REACH)
    near, tri = np.asarray(near, dtype=np.float64), np.asarray(tri, dtype=np.int64)
    cov = tri >= 0
    return np.where(cov, np.abs(D[:, 2] - np.where(cov, near, 0.0)), 0.0), near, tri


def data_fit(surfaces, data, tolerance: float = DATA_FIT_TOLERANCE,
             misses: Optional[Dict[str, Tuple[np.ndarray, np.ndarray]]] = None) -> Dict[str, Dict[str, Any]]:
    """How closely each layer surface passes through its own data.

    ``surfaces``: layer -> surface (``vertices``, ``triangles``); ``data``:
    layer -> (n, 3) points. Per layer with data: ``data`` (the points some
    triangle covers in map view; ``outside``: those none does, outside the
    study area), ``off`` (how many lie farther than ``tolerance`` above or
    below every sheet of the surface), ``max_m`` (the largest such distance)
    and ``worst`` (that datum: x, y, z and the model's nearest sheet's z).
    Where a reverse fault folds the layer the datum is compared with the
    sheet nearest to it (:func:`data_misses`).
    ``misses``: a dict that gets each layer's per-datum distances and
    nearest triangles."""
    out: Dict[str, Dict[str, Any]] = {}
    for lay, D in data.items():
        s = surfaces.get(lay)
        D = np.asarray(D, dtype=np.float64).reshape(-1, 3)
        if s is None or not len(D):
            continue
        dz, near, tri = data_misses(s, D)
        cov = tri >= 0
        if misses is not None:
            misses[lay] = (dz, tri)
        off = dz > tolerance
        row: Dict[str, Any] = {"data": int(cov.sum()), "outside": int((~cov).sum()), "off": int(off.sum()),
                               "max_m": float(dz.max()), "worst": None}
        if off.any():
            k = int(np.argmax(dz))
            row["worst"] = {"x": float(D[k, 0]), "y": float(D[k, 1]), "z": float(D[k, 2]),
                            "model_z": float(near[k])}
        out[lay] = row
    return out


def layer_order(surfaces, layers: List[str], tolerance: float = DATA_FIT_TOLERANCE
                ) -> List[Dict[str, Any]]:
    """Where a layer's surface lies above the one over it: per pair of
    consecutive ``layers`` (top down) that both have a surface, ``upper``,
    ``lower``, ``points`` (the XY places compared), ``above`` (how many of
    them have the lower layer's highest sheet more than ``tolerance`` above
    the upper's highest sheet), ``max_m`` (the largest such height; 0 with
    none) and ``at`` (x, y of it, or None).

    The places are the vertices of both surfaces (XY, each once) where both
    cover the point: the difference of two piecewise-linear surfaces takes
    its extremes at the vertices of their overlay, which are these and the
    crossings of their edges, so the largest height is exact up to what
    lies between edge crossings and the nearest vertex. The highest sheets:
    where a reverse fault repeats both layers, the upper's hanging wall lies
    over the lower's; a normal fault's gap leaves the upper layer without a
    sheet where the lower may have one, a place not compared. The
    continuous TINs are ordered by the crossing repair
    (``repair_crossings``); what this finds lies in a fault's patch or
    gap, whose cutoffs and polylines come from the data or the derivation,
    or on a layer the repair did not reach. ``kind`` and ``upper_kind``:
    the lower and the upper layer's triangle kind at the largest height
    (``layer``, ``patch`` or ``gap``; None with none): a lower layer's own
    surface under an upper layer's patch is the upper layer's fault zone
    placed too low."""
    from ._core import sample_surface

    out: List[Dict[str, Any]] = []
    have = [lay for lay in layers if surfaces.get(lay) is not None]
    for upper, lower in zip(have[:-1], have[1:]):
        su, sl = surfaces[upper], surfaces[lower]
        xy = np.unique(np.vstack([np.asarray(su.vertices, dtype=np.float64)[:, :2],
                                  np.asarray(sl.vertices, dtype=np.float64)[:, :2]]), axis=0)
        xy = np.ascontiguousarray(xy)
        zu = np.asarray(sample_surface(su.vertices, su.triangles, xy)[1], dtype=np.float64)
        zl = np.asarray(sample_surface(sl.vertices, sl.triangles, xy)[1], dtype=np.float64)
        both = np.isfinite(zu) & np.isfinite(zl)
        h = np.where(both, zl - zu, -np.inf)
        above = h > tolerance
        row: Dict[str, Any] = {"upper": upper, "lower": lower, "points": int(both.sum()),
                               "above": int(above.sum()), "max_m": 0.0, "at": None,
                               "kind": None, "upper_kind": None}
        if above.any():
            k = int(np.argmax(h))
            row.update(max_m=float(h[k]), at=[float(xy[k, 0]), float(xy[k, 1])],
                       kind=_kind_at(sl, xy[k], zl[k]), upper_kind=_kind_at(su, xy[k], zu[k]))
        out.append(row)
    return out


def _kind_at(surface, xy: np.ndarray, z: float) -> Optional[str]:
    """The kind (``layer``, ``patch``, ``gap``) of the triangle of
    ``surface`` under ``xy`` whose sheet lies at ``z``; None where the
    surface does not know its kinds."""
    from ._core import TriangleKind

    kinds = getattr(surface, "kinds", None)
    if kinds is None or not len(kinds):
        return None
    tri = int(data_misses(surface, np.array([[xy[0], xy[1], z]]))[2][0])
    return TriangleKind(int(np.asarray(kinds)[tri])).name if tri >= 0 else None


def triangle_angles(points, triangles) -> np.ndarray:
    """Interior angles (m, 3) in degrees of triangles (m, 3) over ``points``
    (n, 2) or (n, 3); column k is the angle at vertex k. Uses
    ``atan2(|u x v|, u . v)``, accurate for needle-like triangles; a
    degenerate triangle gets angles 0 (and 180)."""
    P = np.asarray(points, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if P.ndim != 2 or P.shape[1] not in (2, 3):
        raise ValueError(f"triangle_angles: points must have shape (n, 2) or (n, 3), got {P.shape}")
    if P.shape[1] == 2:
        P = np.column_stack([P, np.zeros(len(P))])
    if T.size and (T.min() < 0 or T.max() >= len(P)):
        raise ValueError(f"triangle_angles: vertex index outside 0..{len(P) - 1}")
    A, B, C = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    out = np.empty((len(T), 3), dtype=np.float64)
    for k, (p, q, r) in enumerate(((A, B, C), (B, C, A), (C, A, B))):
        u, v = q - p, r - p
        cr = np.linalg.norm(np.cross(u, v), axis=1)
        dt = np.einsum("ij,ij->i", u, v)
        out[:, k] = np.degrees(np.arctan2(cr, dt))
    return out


def min_angles(points, triangles) -> np.ndarray:
    """Smallest interior angle (m,) in degrees of each triangle."""
    a = triangle_angles(points, triangles)
    return a.min(axis=1) if len(a) else np.zeros(0)


def _shares(minang: np.ndarray) -> Dict[str, float]:
    n = len(minang)
    if n == 0:
        return {"lt10": float("nan"), "lt20": float("nan")}
    return {"lt10": float(np.count_nonzero(minang < 10.0) / n),
            "lt20": float(np.count_nonzero(minang < 20.0) / n)}


# ----------------------------------------------------------------------------
# Evaluating a TIN on a regular grid of samples
# ----------------------------------------------------------------------------

def evaluate_surface(surface, x, y) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """z of a TIN at points ``x``, ``y`` (k,): ``(z_low, z_high, n_hits)``;
    ``z_low == z_high`` where the surface is single-valued, NaN where no
    triangle covers the point (:func:`faultmesh.sample_surface`)."""
    from ._core import sample_surface

    x = np.asarray(x, dtype=np.float64).reshape(-1)
    y = np.asarray(y, dtype=np.float64).reshape(-1)
    lo, hi, nh = sample_surface(surface.vertices, surface.triangles, np.column_stack([x, y]))
    return lo, hi, nh.astype(np.int64)


def _sample_grid(model, n: int):
    """Cell-centred n x n' grid over the boundary's bounding box (square cells),
    with the mask of samples inside the boundary polygon."""
    from matplotlib.path import Path as MplPath

    if model.boundary is not None and len(model.boundary) >= 3:
        B = np.asarray(model.boundary, dtype=np.float64).reshape(-1, 2)
    else:
        allv = np.vstack([s.vertices[:, :2] for s in model.surfaces.values()])
        (xa, ya), (xb, yb) = allv.min(0), allv.max(0)
        B = np.array([[xa, ya], [xb, ya], [xb, yb], [xa, yb]])
    (xa, ya), (xb, yb) = B.min(0), B.max(0)
    h = max(xb - xa, yb - ya) / n
    nx, ny = max(1, int(round((xb - xa) / h))), max(1, int(round((yb - ya) / h)))
    hx, hy = (xb - xa) / nx, (yb - ya) / ny
    x0, y0 = xa + hx / 2, ya + hy / 2
    gx = x0 + hx * np.arange(nx)
    gy = y0 + hy * np.arange(ny)
    X, Y = np.meshgrid(gx, gy)
    inside = MplPath(B).contains_points(np.column_stack([X.ravel(), Y.ravel()]))
    return (x0, y0, hx, hy, nx, ny), X.ravel(), Y.ravel(), inside


def _near_mask(model, grid, radius: float) -> np.ndarray:
    """Samples within ``radius`` (XY) of any fault surface, on the grid."""
    from ._core import sample_surface_grid

    x0, y0, hx, hy, nx, ny = grid
    mark = np.zeros(nx * ny, dtype=bool)
    for f in model.faults.values():
        V, T = f.vertices, f.triangles
        if len(V) == 0:
            continue
        _, _, hits = sample_surface_grid(V, T, (x0, y0), (hx, hy), (ny, nx))
        mark |= hits.ravel() > 0
        # Steep faults have a thin footprint: also mark the cells of points
        # spaced at half a cell along every edge (and the vertices).
        E = np.unique(np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1),
                      axis=0) if len(T) else np.zeros((0, 2), np.int64)
        a, b = V[E[:, 0], :2], V[E[:, 1], :2]
        L = np.linalg.norm(b - a, axis=1)
        k = np.maximum(1, np.ceil(L / (0.5 * min(hx, hy)))).astype(np.int64)
        e = np.repeat(np.arange(len(E)), k + 1)
        t = (np.arange(int((k + 1).sum())) - np.repeat(np.cumsum(k + 1) - (k + 1), k + 1)) / k[e]
        pts = np.vstack([a[e] + t[:, None] * (b[e] - a[e]), V[:, :2]])
        i = np.rint((pts[:, 0] - x0) / hx).astype(np.int64)
        j = np.rint((pts[:, 1] - y0) / hy).astype(np.int64)
        ok = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        mark[j[ok] * nx + i[ok]] = True
    if not mark.any() or radius <= 0:
        return mark
    m2 = mark.reshape(ny, nx)
    out = np.zeros_like(m2)
    ri, rj = int(np.ceil(radius / hx)), int(np.ceil(radius / hy))
    for dj in range(-rj, rj + 1):
        for di in range(-ri, ri + 1):
            if (di * hx) ** 2 + (dj * hy) ** 2 > radius ** 2:
                continue
            src = m2[max(0, -dj):ny - max(0, dj), max(0, -di):nx - max(0, di)]
            out[max(0, dj):ny - max(0, -dj), max(0, di):nx - max(0, -di)] |= src
    return out.ravel()


def vertical_errors(model, truth=None, *, near: float = 150.0, samples: int = 200,
                    surfaces=None) -> Tuple[List[Dict[str, Any]], Dict[str, Any]]:
    """Vertical error of layer surfaces against a ground truth (the module
    doc): rows ``{layer, region, samples, mean_abs_dz, max_abs_dz, rmse}`` per
    layer and region (``away``, ``near``, ``overlap``, ``skipped``) and the
    settings. ``surfaces`` (layer -> Surface) evaluates other surfaces of the
    same layers -- e.g. the continuous TINs before the faults went in -- on
    the SAME samples: the grid and the near-a-fault mask come from ``model``
    (its boundary and fault surfaces), the regions from the surfaces'
    own sheets."""
    from ._core import sample_surface_grid

    truth = truth if truth is not None else model.truth
    if truth is None:
        raise ValueError("vertical_errors: no ground truth")
    surfaces = model.surfaces if surfaces is None else surfaces
    grid, X, Y, inside = _sample_grid(model, samples)
    x0, y0, hx, hy, nx, ny = grid
    nearm = _near_mask(model, grid, near)
    rows: List[Dict[str, Any]] = []
    for layer, surf in surfaces.items():
        zlo, zhi, hits = (a.ravel() for a in sample_surface_grid(
            surf.vertices, surf.triangles, (x0, y0), (hx, hy), (ny, nx)))
        covered = (hits > 0) & inside
        # Sheets further apart than 1 mm are distinct (the overlap band of a
        # reverse fault); closer values are the same sheet seen from the
        # triangles sharing an edge or a vertex.
        multi = covered & (zhi - zlo > 1e-3)
        sel = np.flatnonzero(covered)
        t_full = np.full(nx * ny, np.nan)
        t_full[sel] = np.asarray(truth(layer, X[sel], Y[sel]), dtype=np.float64).reshape(-1)
        valid = covered & np.isfinite(t_full)
        dz = np.abs(zhi - t_full)          # upper sheet == the only sheet where single-valued
        regions = {"away": valid & ~multi & ~nearm, "near": valid & ~multi & nearm,
                   "overlap": valid & multi}
        for region, mask in regions.items():
            d = dz[mask]
            rows.append({"layer": layer, "region": region, "samples": int(d.size),
                         "mean_abs_dz": float(d.mean()) if d.size else float("nan"),
                         "max_abs_dz": float(d.max()) if d.size else float("nan"),
                         "rmse": float(np.sqrt(np.mean(d * d))) if d.size else float("nan"),
                         "_abs_dz": d})
        rows.append({"layer": layer, "region": "skipped", "samples": int(np.count_nonzero(
            inside & ~valid)), "mean_abs_dz": float("nan"), "max_abs_dz": float("nan"),
            "rmse": float("nan"), "_abs_dz": np.zeros(0)})
    settings = {"near_m": near, "grid": [nx, ny], "spacing_m": [hx, hy],
                "samples_inside_boundary": int(inside.sum())}
    return rows, settings


def accuracy_near_faults(model, continuous, truth=None, *, near: float = 150.0,
                         samples: int = 250) -> Dict[str, Any]:
    """The stitched model against the continuous TINs (no fault models) near
    the faults, on the same samples (:func:`vertical_errors`: the samples
    within ``near`` metres of a fault, and the overlap band of a reverse fault
    where the upper sheet is compared), for the layers that a fault model
    was stitched into. Per layer and overall: samples, RMSE, mean and max
    |dz| of each."""
    rs, settings = vertical_errors(model, truth, near=near, samples=samples)
    rc, _ = vertical_errors(model, truth, near=near, samples=samples, surfaces=continuous)

    def near_dz(rows, layer):
        d = [r["_abs_dz"] for r in rows if r["layer"] == layer and r["region"] in ("near", "overlap")]
        return np.concatenate(d) if d else np.zeros(0)

    def stats(d):
        return (float(np.sqrt(np.mean(d ** 2))) if len(d) else float("nan"),
                float(d.mean()) if len(d) else float("nan"),
                float(d.max()) if len(d) else float("nan"))

    out: Dict[str, Any] = {"near_m": near, "grid_spacing_m": settings["spacing_m"][0], "layers": {}}
    all_s, all_c = [], []
    stitched = {g.layer for g in model.gaps}  # layers a fault model went into
    for layer in model.surfaces:
        if layer not in stitched:
            continue
        ds, dc = near_dz(rs, layer), near_dz(rc, layer)
        if not len(ds) or not len(dc):
            continue
        all_s.append(ds)
        all_c.append(dc)
        (rmse_s, mean_s, max_s), (rmse_c, mean_c, max_c) = stats(ds), stats(dc)
        out["layers"][layer] = {"samples": int(len(ds)), "samples_continuous": int(len(dc)),
                                "rmse_stitched": rmse_s, "rmse_continuous": rmse_c,
                                "mean_abs_stitched": mean_s, "mean_abs_continuous": mean_c,
                                "max_abs_stitched": max_s, "max_abs_continuous": max_c}
    es = np.concatenate(all_s) if all_s else np.zeros(0)
    ec = np.concatenate(all_c) if all_c else np.zeros(0)
    out["samples"] = int(len(es))
    (out["rmse_stitched"], out["mean_abs_stitched"], _), (out["rmse_continuous"],
                                                          out["mean_abs_continuous"], _) = stats(es), stats(ec)
    return out


# ----------------------------------------------------------------------------
# The report
# ----------------------------------------------------------------------------

@dataclass
class QualityReport:
    """Result of :func:`quality`: rows of plain dicts, ready for tables.

    ``gaps``: one row per stitched gap; ``surfaces``: one row per layer and
    fault surface; ``errors``: vertical error per layer and region (empty
    without ground truth); ``data_fit``: per layer, how closely the model
    passes through its data (:func:`data_fit`; from the build's metadata,
    empty for a model read from a file); ``layer_order``: per pair of
    consecutive layers, where the lower lies above the upper
    (:func:`layer_order`, from the model's surfaces); ``settings``: how the
    numbers were made.
    """

    model_name: str
    gaps: List[Dict[str, Any]] = field(default_factory=list)
    surfaces: List[Dict[str, Any]] = field(default_factory=list)
    errors: List[Dict[str, Any]] = field(default_factory=list)
    settings: Dict[str, Any] = field(default_factory=dict)
    notes: List[str] = field(default_factory=list)
    data_fit: List[Dict[str, Any]] = field(default_factory=list)
    layer_order: List[Dict[str, Any]] = field(default_factory=list)

    # -- the paper's tables ---------------------------------------------------
    def _pairs(self) -> Dict[Tuple[str, str], Dict[str, Any]]:
        """Gaps aggregated per (fault, layer), in order of first appearance."""
        out: Dict[Tuple[str, str], Dict[str, Any]] = {}
        for g in self.gaps:
            key = (g["fault"], g["layer"])
            a = out.setdefault(key, {"fault": g["fault"], "layer": g["layer"], "triangles": 0,
                                     "n_lt10": 0, "n_lt20": 0, "n_lt10_xy": 0, "n_lt20_xy": 0})
            a["triangles"] += g["triangles"]
            for k in ("n_lt10", "n_lt20", "n_lt10_xy", "n_lt20_xy"):
                a[k] += g[k]
        return out

    def tables(self) -> Dict[str, List[Dict[str, Any]]]:
        """``{"table1": [...], "table2": [...]}`` in the paper's layout.

        Table 1: one row per fault, ``{"fault": name, <layer>: triangles or None}``.
        Table 2: one row per fault and layer, ``{"gap": "<fault>-<layer>",
        "fault", "layer", "triangles", "lt10", "lt20"}`` (3D angles; ``_xy``
        variants too).
        """
        pairs = self._pairs()
        layers = [s["name"] for s in self.surfaces if s["kind"] == "layer"]
        t1: Dict[str, Dict[str, Any]] = {}
        for (fault, layer), a in pairs.items():
            row = t1.setdefault(fault, {"fault": fault, **{ly: None for ly in layers}})
            row[layer] = a["triangles"]
        t2 = []
        for (fault, layer), a in pairs.items():
            n = a["triangles"]
            t2.append({"gap": f"{fault}-{layer}", "fault": fault, "layer": layer, "triangles": n,
                       "lt10": a["n_lt10"] / n if n else float("nan"),
                       "lt20": a["n_lt20"] / n if n else float("nan"),
                       "lt10_xy": a["n_lt10_xy"] / n if n else float("nan"),
                       "lt20_xy": a["n_lt20_xy"] / n if n else float("nan")})
        return {"table1": list(t1.values()), "table2": t2}

    # -- output ---------------------------------------------------------------
    def to_dict(self) -> Dict[str, Any]:
        return {"model": self.model_name, "settings": self.settings, "notes": self.notes,
                "tables": self.tables(), "gaps": self.gaps, "surfaces": self.surfaces,
                "errors": self.errors, "data_fit": self.data_fit, "layer_order": self.layer_order}

    def to_json(self, path=None) -> str:
        """JSON text of :meth:`to_dict` (NaN written as null); written to ``path`` if given."""
        def clean(o):
            if isinstance(o, float) and not np.isfinite(o):
                return None
            if isinstance(o, dict):
                return {k: clean(v) for k, v in o.items()}
            if isinstance(o, (list, tuple)):
                return [clean(v) for v in o]
            if isinstance(o, np.generic):
                return clean(o.item())
            return o

        text = json.dumps(clean(self.to_dict()), indent=2)
        if path is not None:
            _write_text(path, text + "\n")
        return text

    CSV_COLUMNS = ["table", "fault", "layer", "name", "kind", "region", "triangles", "vertices",
                   "polygon_vertices", "holes", "expected_triangles", "seconds",
                   "lt10", "lt20", "lt10_xy", "lt20_xy", "min_angle", "min_angle_xy",
                   "samples", "mean_abs_dz", "max_abs_dz", "rmse"]

    def to_csv(self, path) -> Path:
        """One CSV, one row per gap / surface / error region; the ``table``
        column says which (``gap``, ``surface``, ``error``), other columns are
        empty where they do not apply."""
        import io as _io

        buf = _io.StringIO()
        w = csv.DictWriter(buf, fieldnames=self.CSV_COLUMNS, extrasaction="ignore",
                           lineterminator="\n")
        w.writeheader()

        def fmt(row, table):
            out = {"table": table}
            for k, v in row.items():
                if isinstance(v, float):
                    out[k] = "" if not np.isfinite(v) else repr(v)
                else:
                    out[k] = v
            return out

        for g in self.gaps:
            w.writerow(fmt(g, "gap"))
        for s in self.surfaces:
            w.writerow(fmt(s, "surface"))
        for e in self.errors:
            w.writerow(fmt(e, "error"))
        return _write_text(path, buf.getvalue())

    def to_markdown(self) -> str:
        def pct(v):
            return "–" if v is None or (isinstance(v, float) and not np.isfinite(v)) else f"{100 * v:.1f} %"

        def num(v, d=2):
            return "–" if v is None or (isinstance(v, float) and not np.isfinite(v)) else f"{v:.{d}f}"

        L = [f"# Mesh quality: {self.model_name}", ""]
        L += ["Angles are the interior angles of the triangles **in 3D** (headline, as in the "
              "paper's Table 2); the XY values (the plane of the ear clipping) follow in the "
              "per-gap table. A triangle is narrow when its smallest angle is under 10° or 20°.", ""]
        tabs = self.tables()
        layers = [s["name"] for s in self.surfaces if s["kind"] == "layer"]
        if self.gaps:
            L += ["## Table 1 — triangles created by stitching each gap", ""]
            L += ["| fault | " + " | ".join(layers) + " |",
                  "|---|" + "---:|" * len(layers)]
            for r in tabs["table1"]:
                L.append(f"| {r['fault']} | " + " | ".join("–" if r[ly] is None else str(r[ly])
                                                          for ly in layers) + " |")
            L += ["", "## Table 2 — share of narrow triangles in the stitched gaps", "",
                  "| gap | triangles | < 10° | < 20° | < 10° (XY) | < 20° (XY) |",
                  "|---|---:|---:|---:|---:|---:|"]
            for r in tabs["table2"]:
                L.append(f"| {r['gap']} | {r['triangles']} | {pct(r['lt10'])} | {pct(r['lt20'])} "
                         f"| {pct(r['lt10_xy'])} | {pct(r['lt20_xy'])} |")
            L += ["", "## Gaps", "",
                  "| fault | layer | triangles | polygon vertices | holes | data points put back "
                  "| n + 2h − 2 + 2k | min angle 3D | min angle XY | seconds |",
                  "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
            for g in self.gaps:
                L.append(f"| {g['fault']} | {g['layer']} | {g['triangles']} | "
                         f"{g['polygon_vertices']} | {g['holes']} | {g.get('interior', 0)} | "
                         f"{g['expected_triangles']} | "
                         f"{num(g['min_angle'], 1)}° | {num(g['min_angle_xy'], 1)}° | "
                         f"{num(g['seconds'], 4)} |")
        else:
            L += ["No stitched gaps are recorded in this model (a model read from a file "
                  "other than .3dt carries none).", ""]
        L += ["", "## Surfaces", "",
              "| surface | kind | vertices | triangles | < 10° | < 20° | < 10° (XY) | < 20° (XY) "
              "| min angle 3D |",
              "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
        for s in self.surfaces:
            L.append(f"| {s['name']} | {s['kind']} | {s['vertices']} | {s['triangles']} | "
                     f"{pct(s['lt10'])} | {pct(s['lt20'])} | {pct(s['lt10_xy'])} | "
                     f"{pct(s['lt20_xy'])} | {num(s['min_angle'], 1)}° |")
        if self.errors:
            st = self.settings
            L += ["", "## Vertical error against the ground truth", "",
                  f"Samples: a {st['grid'][0]} × {st['grid'][1]} grid (spacing "
                  f"{st['spacing_m'][0]:.1f} m), inside the study area. *near*: within "
                  f"{st['near_m']:g} m of a fault in XY; *overlap*: several sheets (reverse "
                  "fault), upper sheet compared.", "",
                  "| layer | region | samples | mean \\|dz\\| (m) | max \\|dz\\| (m) | RMSE (m) |",
                  "|---|---|---:|---:|---:|---:|"]
            for e in self.errors:
                if e["region"] == "skipped":
                    continue
                L.append(f"| {e['layer']} | {e['region']} | {e['samples']} | "
                         f"{num(e['mean_abs_dz'], 3)} | {num(e['max_abs_dz'], 3)} | "
                         f"{num(e['rmse'], 3)} |")
        if self.data_fit:
            L += ["", "## Fit to the data", "",
                  f"How far the layer surfaces pass from their own data points (boreholes and picks); "
                  f"*missed*: farther than {1000 * DATA_FIT_TOLERANCE:g} mm.", "",
                  "| layer | data | missed | largest miss (m) | of them lowered by the crossing repair |",
                  "|---|---:|---:|---:|---:|"]
            for r in self.data_fit:
                L.append(f"| {r['layer']} | {r['data']} | {r['off']} | {num(r['max_m'], 3)} | "
                         f"{r.get('lowered', 0)} |")
        if self.layer_order:
            L += ["", "## Layer order", "",
                  "Where a layer's surface lies above the one over it (its highest sheet against the "
                  "upper one's, at the vertices of both); *kind*: each layer's triangle there.", "",
                  "| upper | lower | places compared | lower above | largest height (m) | at (x, y) | "
                  "kind (lower / upper) |",
                  "|---|---|---:|---:|---:|---|---|"]
            for r in self.layer_order:
                at = "" if r["at"] is None else f"{r['at'][0]:.1f}, {r['at'][1]:.1f}"
                kinds = "" if r["at"] is None else f"{r['kind'] or '?'} / {r['upper_kind'] or '?'}"
                L.append(f"| {r['upper']} | {r['lower']} | {r['points']} | {r['above']} | "
                         f"{num(r['max_m'], 3)} | {at} | {kinds} |")
        if self.notes:
            L += ["", "## Notes", ""] + [f"- {n}" for n in self.notes]
        return "\n".join(L) + "\n"

    def to_markdown_file(self, path) -> Path:
        return _write_text(path, self.to_markdown())

    def __repr__(self) -> str:
        return (f"QualityReport({self.model_name!r}: {len(self.gaps)} gaps, "
                f"{len(self.surfaces)} surfaces, {len(self.errors)} error rows)")


def _write_text(path, text: str) -> Path:
    from .formats._common import AtomicFiles

    path = Path(path)
    with AtomicFiles() as files:
        files.open(path).write(text)
    return path


def _angle_row(P: np.ndarray, T: np.ndarray) -> Dict[str, Any]:
    m3 = min_angles(P, T)
    m2 = min_angles(P[:, :2], T)
    s3, s2 = _shares(m3), _shares(m2)
    return {"lt10": s3["lt10"], "lt20": s3["lt20"], "lt10_xy": s2["lt10"], "lt20_xy": s2["lt20"],
            "min_angle": float(m3.min()) if len(m3) else float("nan"),
            "min_angle_xy": float(m2.min()) if len(m2) else float("nan"),
            "n_lt10": int(np.count_nonzero(m3 < 10)), "n_lt20": int(np.count_nonzero(m3 < 20)),
            "n_lt10_xy": int(np.count_nonzero(m2 < 10)), "n_lt20_xy": int(np.count_nonzero(m2 < 20))}


def gap_quality(model) -> Dict[str, Any]:
    """Share of stitched gap triangles whose smallest 3D angle is under 10
    and under 20 degrees (the paper's Table 2), overall and per gap."""
    per, all_min = [], []
    for g in model.gaps:
        s = model.surfaces[g.layer]
        rows = np.asarray(g.triangles, dtype=np.int64).reshape(-1)
        ma = min_angles(s.vertices, s.triangles[rows]) if len(rows) else np.zeros(0)
        all_min.append(ma)
        sh = _shares(ma)
        per.append({"fault": g.fault, "layer": g.layer, "triangles": int(len(rows)),
                    "lt10": sh["lt10"] if len(ma) else 0.0, "lt20": sh["lt20"] if len(ma) else 0.0})
    ma = np.concatenate(all_min) if all_min else np.zeros(0)
    sh = _shares(ma)
    return {"triangles": int(len(ma)), "lt10": sh["lt10"] if len(ma) else 0.0,
            "lt20": sh["lt20"] if len(ma) else 0.0, "gaps": per}


def quality(model, *, near: float = 150.0, samples: int = 200, truth=None) -> QualityReport:
    """Mesh quality of ``model``: per gap, per surface, and (with ground truth,
    ``truth`` or ``model.truth``) vertical errors. ``near``: the distance (m)
    from a fault within which samples count as near; ``samples``: grid
    samples along the longer side of the study area."""
    rep = QualityReport(model_name=model.name)
    for g in model.gaps:
        if g.layer not in model.surfaces:
            raise ValueError(f"quality: gap {g.fault!r}/{g.layer!r} names a layer the model "
                             f"does not have (layers: {list(model.surfaces)})")
        surf = model.surfaces[g.layer]
        rows = np.asarray(g.triangles, dtype=np.int64).reshape(-1)
        if rows.size and (rows.min() < 0 or rows.max() >= surf.n_triangles):
            raise ValueError(f"quality: gap {g.fault!r}/{g.layer!r} has triangle rows outside "
                             f"0..{surf.n_triangles - 1}")
        k = int(getattr(g, "n_interior", 0))  # layer data points put back into the gap
        row = {"fault": g.fault, "layer": g.layer, "triangles": int(rows.size),
               "polygon_vertices": int(g.n_vertices), "holes": int(g.n_holes), "interior": k,
               "expected_triangles": int(g.n_vertices + 2 * g.n_holes - 2 + 2 * k),
               "seconds": float(g.seconds)}
        row.update(_angle_row(surf.vertices, surf.triangles[rows]))
        rep.gaps.append(row)
    for kind, group in (("layer", model.surfaces), ("fault", model.faults)):
        for name, s in group.items():
            row = {"name": name, "kind": kind, "vertices": s.n_vertices, "triangles": s.n_triangles}
            row.update(_angle_row(s.vertices, s.triangles))
            rep.surfaces.append(row)
    fit = (model.metadata or {}).get("data_fit") or {}
    # In the model's layer order (a model read from a .3dt has its metadata's keys sorted).
    rep.data_fit = [{"layer": lay, **{k: v for k, v in fit[lay].items() if k != "worst"}}
                    for lay in model.surfaces if lay in fit]
    rep.layer_order = layer_order(model.surfaces, list(model.surfaces))
    truth = truth if truth is not None else model.truth
    rep.settings = {"angles": "3D headline; XY also given", "thresholds_deg": list(THRESHOLDS)}
    if truth is not None:
        errors, st = vertical_errors(model, truth, near=near, samples=samples)
        rep.errors = [{k: v for k, v in e.items() if k != "_abs_dz"} for e in errors]
        rep.settings.update(st)
    else:
        rep.notes.append("no ground truth attached to the model: vertical errors not computed")
    return rep
