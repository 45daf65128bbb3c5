"""The modelling workflow: :func:`build_model` (docs/design.md, "Workflow").

Steps 2 and 3 -- stratum TINs and the layer-crossing repair -- are the C++
:class:`faultmesh.LayerTin` and :func:`faultmesh.repair_crossings`
(cpp/include/faultmesh/layer_tin.hpp), driven by :func:`continuous_layers`.
Steps 4-7: fault patches (:mod:`faultmesh.faults`) stitched into each layer by
the C++ :class:`faultmesh.Stitcher` (overlap, growth, boundary contours,
bridging, ear clipping, merge), one fault group after another.
"""
from __future__ import annotations

import math
import time
from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np

from ._core import AabbTree, GeometryError, LayerTin, Stitcher, StudyArea, TriangleKind, repair_crossings
from .dataset import points_in_polygon
from .model import Gap, Model, StitchedPatch, Surface

__all__ = ["build_model", "continuous_layers", "stratum_tins", "LayerTin", "repair_crossings",
           "gap_quality", "fault_accuracy", "surface_z"]


def _ccw_ring(ring: np.ndarray) -> np.ndarray:
    """The study-area ring (k, 2), counter-clockwise, without a closing point."""
    return np.ascontiguousarray(StudyArea(np.asarray(ring, dtype=np.float64).reshape(-1, 2)).ring)


# ---------------------------------------------------------------------------
# Steps 2 and 3: stratum TINs and the layer-crossing repair
# ---------------------------------------------------------------------------
def stratum_tins(dataset, area: StudyArea, spacing: Optional[float] = None, repair: bool = True,
                 max_repair_rounds: int = 50, progress=None) -> Tuple[Dict[str, LayerTin], Dict[str, Any]]:
    """Steps 2 and 3: the continuous TIN of every layer over the study area
    (:class:`faultmesh.LayerTin`), then, top down, each layer made to lie
    nowhere above the one over it (:func:`faultmesh.repair_crossings`).
    Returns (layer -> LayerTin, metadata with per-layer counts)."""
    prog = _progress_fn(progress)
    layers = list(dataset.layers)
    tins: Dict[str, LayerTin] = {}
    for i, lay in enumerate(layers):
        prog("stratum TINs", i, len(layers))
        tins[lay] = LayerTin(lay, dataset.layer_points(lay), area, spacing)
    prog("stratum TINs", len(layers), len(layers))
    meta: Dict[str, Any] = {"tins": {lay: {"data_points": int(t.n_data), "outside_ignored": int(t.n_outside),
                                           "boundary_data": int(t.n_boundary_data),
                                           "boundary_spacing": float(t.spacing)}
                                     for lay, t in tins.items()},
                            "repair": {}}
    if repair:
        for i, (up, lo) in enumerate(zip(layers[:-1], layers[1:])):
            prog("layer repair", i, len(layers) - 1)
            meta["repair"][lo] = repair_crossings(tins[up], tins[lo], max_repair_rounds)
        prog("layer repair", len(layers) - 1, len(layers) - 1)
    return tins, meta


def continuous_layers(dataset, *, spacing: Optional[float] = None, repair: bool = True,
                      max_repair_rounds: int = 50) -> Dict[str, Surface]:
    """The continuous layer surfaces of ``dataset`` before any fault (steps 2
    and 3 of :func:`build_model`, same code and defaults)."""
    area = StudyArea(np.asarray(dataset.boundary, dtype=np.float64))
    tins, _ = stratum_tins(dataset, area, spacing, repair, max_repair_rounds)
    return {lay: Surface(lay, *t.mesh(), kind="layer") for lay, t in tins.items()}


# ---------------------------------------------------------------------------
# Evaluation helpers (used by build_model, usable by the report)
# ---------------------------------------------------------------------------
def surface_z(vertices: np.ndarray, triangles: np.ndarray, xy: np.ndarray):
    """z of a TIN at points xy (k, 2): (z_low, z_high, hits). Where the
    surface folds (a reverse fault's repetition band) several triangles cover
    a point: z_low/z_high are the lowest/highest sheet; NaN where none does.
    AABB candidates, then barycentric coordinates (a point on a shared edge
    is counted once per triangle; both give the same z)."""
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64)
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    lo = np.full(len(xy), np.nan)
    hi = np.full(len(xy), np.nan)
    hits = np.zeros(len(xy), dtype=np.int64)
    if len(T) == 0 or len(xy) == 0:
        return lo, hi, hits
    tree = AabbTree(V, T)
    off, idx = tree.query(np.column_stack([xy, xy]))
    off = np.asarray(off)
    idx = np.asarray(idx)
    q = np.repeat(np.arange(len(xy)), np.diff(off))
    P = V[T[idx]]
    p = xy[q]
    a, b, c = P[:, 0], P[:, 1], P[:, 2]
    den = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = ((p[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (p[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])) / den
        l2 = ((b[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (p[:, 0] - a[:, 0])) / den
    l0 = 1.0 - l1 - l2
    # Barycentric coordinates err by ~1e-12 relative at these magnitudes;
    # accept points on an edge up to that.
    eps = 1e-10
    ok = (den != 0) & (l0 >= -eps) & (l1 >= -eps) & (l2 >= -eps)
    z = l0 * a[:, 2] + l1 * b[:, 2] + l2 * c[:, 2]
    q, z = q[ok], z[ok]
    zl = np.full(len(xy), np.inf)
    zh = np.full(len(xy), -np.inf)
    np.minimum.at(zl, q, z)
    np.maximum.at(zh, q, z)
    np.add.at(hits, q, 1)
    has = hits > 0
    lo[has] = zl[has]
    hi[has] = zh[has]
    return lo, hi, hits


def _min_angles(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Smallest interior angle (degrees) of each triangle, in 3D."""
    A, B, C = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]

    def ang(u, v):
        cr = np.cross(u, v)
        return np.degrees(np.arctan2(np.linalg.norm(cr, axis=1), np.einsum("ij,ij->i", u, v)))

    return np.minimum(np.minimum(ang(B - A, C - A), ang(C - B, A - B)), ang(A - C, B - C))


def gap_quality(model: Model) -> Dict[str, Any]:
    """Share of stitched gap triangles whose smallest 3D angle is under 10 and
    under 20 degrees (the paper's Table 2), overall and per gap."""
    per = []
    all_min = []
    for g in model.gaps:
        s = model.surfaces[g.layer]
        rows = np.asarray(g.triangles, dtype=np.int64).reshape(-1)
        ma = _min_angles(s.vertices, s.triangles[rows]) if len(rows) else np.zeros(0)
        all_min.append(ma)
        per.append({"fault": g.fault, "layer": g.layer, "triangles": int(len(rows)),
                    "lt10": float(np.mean(ma < 10.0)) if len(ma) else 0.0,
                    "lt20": float(np.mean(ma < 20.0)) if len(ma) else 0.0})
    ma = np.concatenate(all_min) if all_min else np.zeros(0)
    return {"triangles": int(len(ma)),
            "lt10": float(np.mean(ma < 10.0)) if len(ma) else 0.0,
            "lt20": float(np.mean(ma < 20.0)) if len(ma) else 0.0,
            "gaps": per}


def fault_accuracy(model: Model, continuous: Dict[str, Surface], truth=None, near: float = 150.0,
                   samples: int = 250) -> Dict[str, Any]:
    """Vertical error against the ground truth near the faults, stitched model
    vs the continuous TINs (no fault models), on the SAME sample points.

    Samples: a regular grid (``samples`` cells along the longer side) inside
    the study area. Near a fault: within ``near`` metres (measured on the grid)
    of the XY footprint of the fault patches stitched into that layer. The
    truth reports the upper sheet in a reverse fault's repetition band (the
    hanging wall), so the stitched model's upper sheet is compared there; the
    continuous TIN keeps the shallowest borehole hit, the same sheet. Samples
    where the truth has no value are left out."""
    from scipy.ndimage import distance_transform_edt

    truth = truth if truth is not None else model.truth
    if truth is None:
        raise ValueError("fault_accuracy: no ground truth")
    ring = _ccw_ring(model.boundary)
    lo, hi = ring.min(axis=0), ring.max(axis=0)
    h = float(max(hi - lo)) / samples
    gx = np.arange(lo[0] + h / 2, hi[0], h)
    gy = np.arange(lo[1] + h / 2, hi[1], h)
    X, Y = np.meshgrid(gx, gy)
    P = np.column_stack([X.ravel(), Y.ravel()])
    inside = points_in_polygon(P, ring)
    out: Dict[str, Any] = {"near_m": near, "grid_spacing_m": h, "layers": {}}
    tot = {"stitched": [], "continuous": []}
    for layer, surf in model.surfaces.items():
        is_patch = surf.kinds == TriangleKind.patch if surf.kinds is not None else None
        if is_patch is None or not is_patch.any():
            continue
        PT = surf.triangles[is_patch]
        _, _, hits = surface_z(surf.vertices, PT, P)
        foot = (hits > 0).reshape(X.shape)
        dist = distance_transform_edt(~foot) * h
        nearm = (dist.ravel() <= near) & inside
        sel = np.flatnonzero(nearm)
        t = np.asarray(truth(layer, P[sel, 0], P[sel, 1]), dtype=np.float64)
        _, z_s, hs = surface_z(surf.vertices, surf.triangles, P[sel])
        c = continuous[layer]
        _, z_c, hc = surface_z(c.vertices, c.triangles, P[sel])
        ok = np.isfinite(t) & np.isfinite(z_s) & np.isfinite(z_c)
        es, ec = np.abs(z_s[ok] - t[ok]), np.abs(z_c[ok] - t[ok])
        tot["stitched"].append(es)
        tot["continuous"].append(ec)
        out["layers"][layer] = {
            "samples": int(ok.sum()),
            "rmse_stitched": float(np.sqrt(np.mean(es ** 2))) if len(es) else float("nan"),
            "rmse_continuous": float(np.sqrt(np.mean(ec ** 2))) if len(ec) else float("nan"),
            "mean_abs_stitched": float(es.mean()) if len(es) else float("nan"),
            "mean_abs_continuous": float(ec.mean()) if len(ec) else float("nan"),
            "max_abs_stitched": float(es.max()) if len(es) else float("nan"),
            "max_abs_continuous": float(ec.max()) if len(ec) else float("nan")}
    es = np.concatenate(tot["stitched"]) if tot["stitched"] else np.zeros(0)
    ec = np.concatenate(tot["continuous"]) if tot["continuous"] else np.zeros(0)
    out["samples"] = int(len(es))
    out["rmse_stitched"] = float(np.sqrt(np.mean(es ** 2))) if len(es) else float("nan")
    out["rmse_continuous"] = float(np.sqrt(np.mean(ec ** 2))) if len(ec) else float("nan")
    out["mean_abs_stitched"] = float(es.mean()) if len(es) else float("nan")
    out["mean_abs_continuous"] = float(ec.mean()) if len(ec) else float("nan")
    return out


# ---------------------------------------------------------------------------
# build_model
# ---------------------------------------------------------------------------
def _clearance(clearance: Optional[float], tin: "LayerTin") -> float:
    if clearance is not None:
        if not clearance >= 0.0:
            raise ValueError(f"build_model: clearance must be >= 0, got {clearance}")
        return float(clearance)
    return _CLEARANCE_FACTOR * tin.spacing


# Default clearance between the patch outline and the hole's boundary, as a
# fraction of the layer's data spacing. A layer vertex closer to the outline
# than this leaves sliver gap triangles; removing it costs little data (the
# fine fault model is the better information there). On the paper-like data
# (seeds 0-3) 0.4 cuts the share of gap triangles under 20 degrees from
# 0.41-0.49 to about 0.19-0.21 and under 10 degrees from 0.22-0.29 to
# 0.06-0.11, while the vertical error near the faults rises by ~0.4 m RMSE.
_CLEARANCE_FACTOR = 0.4


def _progress_fn(progress) -> Callable[[str, int, int], None]:
    if progress is None or progress is False:
        return lambda step, i, n: None
    if progress is True:
        try:
            from tqdm.auto import tqdm
        except ImportError:  # pragma: no cover - tqdm is a dependency
            return lambda step, i, n: None
        state: Dict[str, Any] = {"bar": None, "step": None}

        def fn(step: str, i: int, n: int) -> None:
            if state["step"] != step:
                if state["bar"] is not None:
                    state["bar"].close()
                state["bar"] = tqdm(total=n, desc=step, leave=False)
                state["step"] = step
            bar = state["bar"]
            bar.n = i
            bar.refresh()
            if i >= n:
                bar.close()
                state["bar"] = None
                state["step"] = None

        return fn
    if not callable(progress):
        raise TypeError("build_model: progress must be None, True or a callable(step, i, n)")
    return progress


def build_model(dataset, progress=None, loft_method: str = "min_area", refine: bool = True,
                stitch_order: str = "quality", bridge: str = "extreme", repair: bool = True,
                max_repair_rounds: int = 50, spacing: Optional[float] = None,
                evaluate: bool = True, clearance: Optional[float] = None) -> Model:
    """Build the faulted multi-layer model of ``dataset`` (DESIGN.md steps 2-7).

    progress: None, True (a tqdm bar per step) or ``callable(step, i, n)``.
    loft_method: "min_area" (Fuchs-Kedem-Uselton) or "shortest_diagonal".
    refine / stitch_order / bridge: ear clipping of the gaps ("quality" order
    with constrained-Delaunay refinement by default; ``refine=False,
    stitch_order="plain"`` is the paper's plain Eberly order).
    repair: step 3 (layer-crossing repair). spacing: boundary vertex spacing
    (default: about the layer's data spacing). clearance: the removed region
    grows until its boundary vertices are at least this far (m) from the
    patch outline (default: 0.4 x the layer's data spacing; 0 = only the
    triangles touching the patch, the paper's rule). evaluate: with a ground truth
    (built-in datasets), compare the model with the continuous TINs near the
    faults (``metadata["accuracy"]``).

    Returns a :class:`~faultmesh.Model`: ``surfaces`` (layer -> Surface, top
    down), ``faults`` (fault -> Surface), ``boundary``, ``gaps`` (one
    :class:`~faultmesh.Gap` per stitched gap polygon), ``truth``, and
    ``metadata``: repair counts, per-fault end handling, stitch statistics,
    timings, gap quality and (with a truth) accuracy.
    """
    from . import faults as fm

    if loft_method not in ("min_area", "shortest_diagonal"):
        raise ValueError(f"build_model: loft_method must be 'min_area' or 'shortest_diagonal', "
                         f"got {loft_method!r}")
    if stitch_order not in ("quality", "plain"):
        raise ValueError(f"build_model: stitch_order must be 'quality' or 'plain', got {stitch_order!r}")
    prog = _progress_fn(progress)
    t_start = time.perf_counter()
    timings: Dict[str, float] = {}
    layers = list(dataset.layers)
    if not layers:
        raise ValueError(f"build_model: dataset {dataset.name!r} has no layer")
    ring = _ccw_ring(dataset.boundary)
    area = StudyArea(ring)
    ring = area.ring
    meta: Dict[str, Any] = {"options": {"loft_method": loft_method, "refine": refine,
                                        "stitch_order": stitch_order, "bridge": bridge,
                                        "repair": repair}}

    # Steps 2 and 3: stratum TINs, layer-crossing repair.
    t0 = time.perf_counter()
    tins, tin_meta = stratum_tins(dataset, area, spacing, repair, max_repair_rounds, prog)
    meta.update(tin_meta)
    timings["stratum_tins_and_repair"] = time.perf_counter() - t0
    continuous = {lay: Surface(lay, *tins[lay].mesh(), kind="layer") for lay in layers}

    # Step 4: fine fault models, per group and layer.
    t0 = time.perf_counter()
    groups = dataset.fault_groups()
    ends = {f.name: fm.fault_ends(f) for f in dataset.faults}
    # The patch of each group, named after the group: its "group" value, else
    # its members' names joined with "+" (a display name; the members stay a list).
    group_names = [g[0].group if len(g) > 1 and g[0].group else "+".join(f.name for f in g)
                   for g in groups]
    patches: Dict[str, List[Tuple[str, List[str], np.ndarray, np.ndarray]]] = {lay: [] for lay in layers}
    fault_meta: Dict[str, Any] = {f.name: {"kind": f.kind, "layers": {}} for f in dataset.faults}
    end_moves: Dict[str, List[Optional[fm.EndMove]]] = {f.name: [None, None] for f in dataset.faults}
    for gi, (group, gname) in enumerate(zip(groups, group_names)):
        prog("fault models", gi, len(groups))
        for lay in layers:
            zf = tins[lay].interpolate
            core = {f.name: fm.layer_patch(f, lay, ends[f.name], area, zf, loft_method)
                    for f in group}
            core = {k: v for k, v in core.items() if v is not None}
            if not core:
                continue
            if len(core) > 1:
                outl = {k: fm.patch_outline(v.vertices, v.triangles) for k, v in core.items()}
                for f in group:
                    p = core.get(f.name)
                    if p is None or not any(k in ("extended", "synthetic_tip") for k in p.ends):
                        continue
                    partners = {k: r for k, r in outl.items() if k != f.name}
                    core[f.name] = fm.layer_patch(f, lay, ends[f.name], area, zf, loft_method,
                                                  partners=partners)
            plist = [core[f.name] for f in group if f.name in core]
            for p in plist:
                fault_meta[p.fault]["layers"][lay] = {"ends": p.ends, "abuts": p.abuts,
                                                      "triangles": int(len(p.triangles)), **p.metadata}
                f = dataset.fault(p.fault)
                for e in (0, 1):
                    if p.ends[e] == "extended" and end_moves[p.fault][e] is None:
                        if p.metadata.get(f"end{e}_extended_to") == "boundary":
                            end_moves[p.fault][e] = fm.EndMove.ray(ends[p.fault].directions[e])
                        else:
                            end_moves[p.fault][e] = fm.EndMove.shift(ends[p.fault].directions[e]
                                                                     * p.metadata[f"end{e}_extension"])
                    elif p.ends[e] == "synthetic_tip" and end_moves[p.fault][e] is None:
                        end_moves[p.fault][e] = fm.EndMove.shift(ends[p.fault].directions[e]
                                                                 * 0.5 * ends[p.fault].spacing)
            if len(plist) == 1:
                V, T = plist[0].vertices, plist[0].triangles
            else:
                V, T, info = fm.group_patch(plist)
                meta.setdefault("groups", {}).setdefault(gname, {})[lay] = info
            if len(T):
                patches[lay].append((gname, [p.fault for p in plist], V, T))
    prog("fault models", len(groups), len(groups))
    fault_surfaces: Dict[str, Surface] = {}
    for f in dataset.faults:
        res = fm.fault_surface(f, ends[f.name], area, loft_method, end_moves[f.name])
        if res is not None:
            fault_surfaces[f.name] = Surface(f.name, res[0], res[1], kind="fault",
                                             metadata={"kind": f.kind, "group": f.group or ""})
    meta["faults"] = fault_meta
    timings["fault_models"] = time.perf_counter() - t0

    # Steps 5-7: stitch every group's patch into every layer.
    t0 = time.perf_counter()
    surfaces: Dict[str, Surface] = {}
    gaps: List[Gap] = []
    stitched: List[StitchedPatch] = []
    stitch_meta: Dict[str, Any] = {}
    n_jobs = sum(len(v) for v in patches.values())
    job = 0
    for lay in layers:
        V, T = continuous[lay].vertices, continuous[lay].triangles
        st = Stitcher(V, T, boundary=ring, name=lay, refine=refine, order=stitch_order,
                      bridge=bridge, clearance=_clearance(clearance, tins[lay]))
        live_gaps: Dict[int, Tuple[Any, float]] = {}  # gap id -> (StitchGap, seconds)
        layer_patches: Dict[int, StitchedPatch] = {}
        stitch_meta[lay] = []
        for gname, members, PV, PT in patches[lay]:
            prog("stitching", job, n_jobs)
            job += 1
            ts = time.perf_counter()
            rep = st.stitch(PV, PT, name=gname)
            secs = time.perf_counter() - ts
            layer_patches[rep.patch_id] = StitchedPatch(layer=lay, id=int(rep.patch_id), name=gname,
                                                        faults=list(members), n_triangles=int(len(PT)))
            for g in rep.merged_gaps:
                live_gaps.pop(int(g), None)
            for g in rep.gaps:
                live_gaps[int(g.id)] = (g, secs / max(1, len(rep.gaps)))
            stitch_meta[lay].append({"fault": gname, "removed": int(len(rep.removed)),
                                     "candidates": int(rep.n_candidates),
                                     "grow_rounds": int(rep.grow_rounds),
                                     "gaps": len(rep.gaps),
                                     "merged_gaps": int(len(rep.merged_gaps)),
                                     "patch_flipped": bool(rep.patch_flipped),
                                     "seconds": secs})
        mesh = st.mesh()
        surf = Surface(lay, mesh.vertices, mesh.triangles, kind="layer", kinds=mesh.kinds, owner=mesh.owners,
                       metadata={"n_patch_triangles": int(np.sum(mesh.kinds == TriangleKind.patch)),
                                 "n_gap_triangles": int(np.sum(mesh.kinds == TriangleKind.gap))})
        surfaces[lay] = surf
        for gid, (g, secs) in sorted(live_gaps.items()):
            rows = np.flatnonzero((surf.kinds == TriangleKind.gap) & (surf.owner == gid))
            owners = [layer_patches[int(p)] for p in g.patches]
            names = list(dict.fromkeys(f for p in owners for f in p.faults))
            gaps.append(Gap(fault="+".join(p.name for p in owners) or "?", layer=lay,
                            triangles=rows.astype(np.int64), n_vertices=int(g.n_vertices),
                            n_holes=int(g.n_holes), seconds=secs,
                            metadata={"faults": names, "merged_gaps": len(g.merged_gaps)},
                            id=gid, patches=[p.id for p in owners]))
        stitched.extend(layer_patches.values())
    prog("stitching", n_jobs, n_jobs)
    timings["stitching"] = time.perf_counter() - t0
    meta["stitch"] = stitch_meta

    model = Model(name=dataset.name, surfaces=surfaces, faults=fault_surfaces, boundary=ring,
                  crs=getattr(dataset, "crs", ""), gaps=gaps,
                  truth=getattr(dataset, "truth", None), metadata=meta, patches=stitched)
    t0 = time.perf_counter()
    meta["quality"] = gap_quality(model)
    if evaluate and model.truth is not None:
        try:
            meta["accuracy"] = fault_accuracy(model, continuous)
        except Exception as e:  # pragma: no cover - evaluation must never break a build
            meta["accuracy"] = {"error": f"{type(e).__name__}: {e}"}
    timings["evaluation"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start
    meta["timings"] = timings
    return model
