"""Method comparison on the built-in dataset: the paper's Tables 1 and 2.

    python bench/compare.py [--out DIR] [--repeat 5] [--seed 0] [--docs]

For every stitched gap (fault x layer) of ``faultmesh.datasets.paper_like``:

* Table 1 -- triangles created, and Table 2 -- share of them whose smallest
  interior angle (3D, as in the paper; XY in the JSON) is under 10 and under
  20 degrees, for four methods:

  - **faultmesh, paper order**: ``build_model(..., stitch_order="plain",
    refine=False, clearance=0.0)`` -- the paper's method: only the triangles
    that overlap the fault patch are removed, Eberly's ear order, no refinement;
  - **faultmesh, quality order + CDT**: ``build_model`` defaults -- quality ear
    order and constrained-Delaunay flips;
  - **CGAL CDT**: the same gap polygon (outer loop + holes, taken from the
    boundary loops of the gap's triangles) triangulated by CGAL's
    Constrained_Delaunay_triangulation_2 (``bench/cgal/cgal_gap_cdt.cpp``);
  - **cutting baseline**: the continuous layer cut along its intersection line
    with each fault surface, re-triangulated with the line as a constraint
    and the hanging wall moved (``faultmesh.cutting.cut_model``; the paper's
    comparison method). Its count is the layer triangles the cut created.

* time per stitch (per fault and layer) and for the whole model.

Checks printed with the tables: every gap's triangle count equals CGAL's, and
the quality-order shares are not above CGAL's.

Output in ``--out`` (default ``bench/results/compare``): ``compare.md``,
``compare.json`` and ``compare_min_angles.png`` (histogram and cumulative
distribution of the smallest angle per method); ``--docs`` also writes
``docs/bench/compare.md``, ``compare.json`` and ``compare_min_angles.png``.
"""
from __future__ import annotations

import argparse
import json
import statistics
import struct
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from _common import (ROOT, cgal_program as _cgal_program, machine as _machine, run_program, today,
                     use_dev_build)

use_dev_build()
import faultmesh  # noqa: E402
from faultmesh.report import min_angles  # noqa: E402

METHODS = [("paper", "faultmesh paper order"),
           ("quality", "faultmesh quality order + CDT"),
           ("cgal", "CGAL CDT of the gap"),
           ("cutting", "cutting baseline")]

# The paper's own numbers (Gao et al. 2025, Tables 1 and 2), for reference:
# (fault, layer) -> (triangles, share < 10 deg, share < 20 deg); None = not given.
PAPER_OURS = {("2F4", "coal 8"): (14, 0.0, 0.75), ("2F4", "coal 10"): (11, 0.0, 0.25),
              ("2F1", "coal 10"): (17, 0.352941, 0.588235),
              ("F22", "coal 8"): (15, 0.333333, 0.533333), ("F22", "coal 10"): (15, 0.4, 0.733333),
              ("4F2-2F1", "coal 8"): (24, 0.541667, 0.666667)}
PAPER_CUTTING = {("2F4", "coal 8"): (38, 0.394737, 0.605263), ("2F4", "coal 10"): (49, 0.510204, 0.673469),
                 ("2F1", "coal 8"): (107, 0.579439, 0.728972), ("2F1", "coal 10"): (95, 0.642105, 0.768421),
                 ("4F2", "coal 8"): (104, 0.625, 0.846154),
                 ("F22", "coal 8"): (127, 0.464567, 0.622047), ("F22", "coal 10"): (112, 0.571429, 0.785714)}


def paper_key(fault: str, layer: str) -> Tuple[str, str]:
    """Our (fault, layer) in the paper's naming (a T-crossing gap is "4F2-2F1")."""
    if "2F1" in fault and "4F2" in fault:
        return ("4F2-2F1", layer)
    return (fault, layer)


# ----------------------------------------------------------------------------
# CGAL reference program
# ----------------------------------------------------------------------------
def cgal_program(name: str = "cgal_gap_cdt") -> Path:
    """Build bench/cgal (Release) into $FAULTMESH_CGAL_BUILD or build/cgal and
    return the path of one program."""
    return _cgal_program(name)


def gap_rings(surface, gap) -> List[np.ndarray]:
    """The gap polygon as vertex-index rings of ``surface``: the outer loop
    (counter-clockwise) first, then the holes (clockwise) -- the boundary loops
    of the gap's triangles (bridges are interior edges, used twice)."""
    tri = surface.triangles[np.asarray(gap.triangles, dtype=np.int64)]
    loops = [np.asarray(l, dtype=np.int64) for l in
             faultmesh.boundary_loops(tri, strict=False, n_vertices=surface.n_vertices)]
    if not loops:
        raise ValueError(f"compare: gap {gap.fault}/{gap.layer} has no boundary loop")
    xy = surface.vertices[:, :2]

    def area(loop):
        p = xy[loop]
        return 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))

    outer = [l for l in loops if area(l) > 0]
    holes = [l for l in loops if area(l) <= 0]
    if len(outer) != 1:
        raise ValueError(f"compare: gap {gap.fault}/{gap.layer} has {len(outer)} outer loops "
                         "(one polygon expected per gap)")
    return outer + holes


def gap_interior(surface, gap, rings: List[np.ndarray]) -> np.ndarray:
    """The gap's interior vertices (indices of ``surface``): the layer data put
    back inside it by the stitcher (``Gap.n_interior``), on no ring."""
    tri = surface.triangles[np.asarray(gap.triangles, dtype=np.int64)]
    return np.setdiff1d(np.unique(tri), np.concatenate(rings))


def run_cgal(exe: Path, polygons: Sequence[Tuple[np.ndarray, List[np.ndarray]]], repeat: int = 5
             ) -> Tuple[List[np.ndarray], List[Dict[str, Any]]]:
    """CGAL CDT of each polygon (vertices (n, 3), rings of vertex indices; a
    ring of one index is a point inside the polygon, inserted without a
    constraint: a gap's interior vertex).
    Returns the triangles as indices into each polygon's ``vertices`` and the
    per-polygon JSON records (points, vertices, triangles, seconds)."""
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = Path(tmp) / "gaps.bin", Path(tmp) / "gaps.out"
        with open(src, "wb") as f:
            f.write(struct.pack("<q", len(polygons)))
            for V, rings in polygons:
                f.write(struct.pack("<q", len(rings)))
                for r in rings:
                    f.write(struct.pack("<q", len(r)))
                for r in rings:
                    f.write(np.ascontiguousarray(V[r, :2], dtype="<f8").tobytes())
        info, _ = run_program([exe, src, dst, "--repeat", repeat])
        data = np.fromfile(dst, dtype="<i8")
    out, pos = [], 0
    for V, rings in polygons:
        m = int(data[pos])
        local = data[pos + 1: pos + 1 + 3 * m].reshape(m, 3)
        pos += 1 + 3 * m
        ids = np.concatenate(rings)
        out.append(ids[local])
    return out, info["polygons"]


# ----------------------------------------------------------------------------
# The comparison
# ----------------------------------------------------------------------------
def _stats(V: np.ndarray, T: np.ndarray) -> Dict[str, Any]:
    m3, m2 = min_angles(V, T), min_angles(V[:, :2], T)
    n = len(T)
    f = (lambda a, t: float(np.count_nonzero(a < t) / n)) if n else (lambda a, t: float("nan"))
    return {"triangles": int(n), "lt10": f(m3, 10), "lt20": f(m3, 20), "lt10_xy": f(m2, 10),
            "lt20_xy": f(m2, 20), "_min": m3}


def _canon(T: np.ndarray) -> set:
    """Triangles as a set of rotation-normalised tuples."""
    out = set()
    for a, b, c in np.asarray(T).tolist():
        k = min((a, b, c), (b, c, a), (c, a, b))
        out.add(k)
    return out


def timed_build(ds, repeat: int, **kw):
    """build_model ``repeat`` times (without the ground-truth evaluation, which
    is analysis, not modelling); the last model, its gaps' ``seconds`` set to
    the median over the runs, and the wall times."""
    runs, model, per_gap = [], None, []
    for _ in range(repeat):
        t0 = time.perf_counter()
        model = faultmesh.build_model(ds, evaluate=False, **kw)
        runs.append(time.perf_counter() - t0)
        per_gap.append([g.seconds for g in model.gaps])
    # Per-gap stitch time: the median over the runs (gaps come in a fixed order).
    for i, g in enumerate(model.gaps):
        g.seconds = statistics.median(r[i] for r in per_gap)
    return model, runs


def _ear_clip_seconds(V: np.ndarray, rings: List[np.ndarray], repeat: int, **kw) -> float:
    """Best-of-``repeat`` time of faultmesh.triangulate_polygon on a gap
    polygon: the step that CGAL's CDT replaces, timed the same way."""
    xy = [np.ascontiguousarray(V[r, :2]) for r in rings]
    best = float("inf")
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        faultmesh.triangulate_polygon(xy, **kw)
        best = min(best, time.perf_counter() - t0)
    return best


def gap_table(model, with_cgal: Optional[Path] = None, cgal_repeat: int = 5,
              ear_clip: Optional[Dict[str, Any]] = None) -> List[Dict[str, Any]]:
    """One record per gap of ``model``: its stats, seconds, polygon (rings) and,
    with a CGAL program, CGAL's triangles of the same polygon and their stats.
    ``ear_clip``: triangulate_polygon options; the gap polygon is then also
    triangulated alone (``clip_seconds``)."""
    recs, polys = [], []
    for g in model.gaps:
        surf = model.surfaces[g.layer]
        T = surf.triangles[np.asarray(g.triangles, dtype=np.int64)]
        rec = {"fault": g.fault, "layer": g.layer, "seconds": float(g.seconds),
               "n_vertices": int(g.n_vertices), "n_holes": int(g.n_holes),
               "n_interior": int(getattr(g, "n_interior", 0)), "tri": T,
               "stats": _stats(surf.vertices, T)}
        if with_cgal is not None or ear_clip is not None:
            rec["rings"] = gap_rings(surf, g)
            rec["interior"] = gap_interior(surf, g, rec["rings"])
        if ear_clip is not None:
            rec["clip_seconds"] = _ear_clip_seconds(surf.vertices, rec["rings"], cgal_repeat, **ear_clip)
        if with_cgal is not None:
            # CGAL gets the same points: the rings as constraints and the
            # interior vertices as one-point rings (no constraint).
            polys.append((surf.vertices, rec["rings"] + [np.array([v]) for v in rec["interior"]]))
        recs.append(rec)
    if with_cgal is not None and polys:
        tris, info = run_cgal(with_cgal, polys, repeat=cgal_repeat)
        for rec, T, inf in zip(recs, tris, info):
            V = model.surfaces[rec["layer"]].vertices
            rec["cgal_tri"] = T
            rec["cgal_stats"] = _stats(V, T)
            rec["cgal_seconds"] = float(inf["seconds"])
            rec["cgal_vertices"] = int(inf["vertices"])
            rec["cgal_points"] = int(inf["points"])
            rec["cgal_identical"] = _canon(T) == _canon(rec["tri"])
    return recs


def _pool(stats: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
    """Stats of several gaps of one (fault, layer) pooled."""
    m = np.concatenate([s["_min"] for s in stats]) if stats else np.zeros(0)
    n = int(sum(s["triangles"] for s in stats))
    out = {"triangles": n}
    for k in ("lt10", "lt20", "lt10_xy", "lt20_xy"):
        out[k] = (float(sum(s[k] * s["triangles"] for s in stats) / n) if n else float("nan"))
    out["_min"] = m
    return out


def _pool_ref(refs: Sequence[Optional[Tuple]]) -> Optional[Tuple]:
    """The paper's (triangles, <10, <20) of several faults pooled (None if none)."""
    refs = [r for r in refs if r is not None]
    if not refs:
        return None
    n = sum(r[0] for r in refs)
    return (n, sum(r[0] * r[1] for r in refs) / n, sum(r[0] * r[2] for r in refs) / n)


def _cut_stats(gaps) -> Optional[Dict[str, Any]]:
    """Pooled stats of cutting-baseline cuts (what each cut created, measured
    right after it)."""
    if not gaps:
        return None
    mins = np.concatenate([g.metadata["min_angle"] for g in gaps])
    mxy = np.concatenate([g.metadata["min_angle_xy"] for g in gaps])
    n = int(sum(g.metadata["created"] for g in gaps))
    sh = (lambda a, t: float(np.count_nonzero(a < t) / n)) if n else (lambda a, t: float("nan"))
    return {"triangles": n, "lt10": sh(mins, 10), "lt20": sh(mins, 20), "lt10_xy": sh(mxy, 10),
            "lt20_xy": sh(mxy, 20), "seconds": float(sum(g.seconds for g in gaps)),
            "removed": int(sum(g.metadata["removed"] for g in gaps)),
            "line_points": int(sum(g.metadata["line_points"] for g in gaps)),
            "faults": [g.fault for g in gaps],
            "displacement": [float(g.metadata["displacement"]) for g in gaps], "_min": mins}


def compare(ds=None, *, repeat: int = 5, cgal_exe: Optional[Path] = None,
            taper_length: float = 150.0, extension: float = 100.0) -> Dict[str, Any]:
    """Run the four methods on ``ds`` (default ``paper_like(0)``) and return
    the comparison as plain data (see ``main`` for the files)."""
    from faultmesh.cutting import cut_model

    ds = ds if ds is not None else faultmesh.datasets.paper_like(0)
    exe = cgal_exe if cgal_exe is not None else cgal_program()
    paper_model, paper_runs = timed_build(ds, repeat, stitch_order="plain", refine=False,
                                          clearance=0.0)
    quality_model, quality_runs = timed_build(ds, repeat)
    paper = gap_table(paper_model, with_cgal=exe, cgal_repeat=repeat,
                      ear_clip={"refine": False, "order": "plain"})
    quality = gap_table(quality_model, with_cgal=exe, cgal_repeat=repeat,
                        ear_clip={"refine": True, "order": "quality"})

    # The cutting baseline starts from the same fault surfaces.
    cut_runs, cut, per_cut = [], None, []
    for _ in range(repeat):
        cut = cut_model(ds, faults=quality_model.faults, taper_length=taper_length,
                        extension=extension)
        cut_runs.append(cut.metadata["seconds"])
        per_cut.append([g.seconds for g in cut.gaps])
    for i, g in enumerate(cut.gaps):
        g.seconds = statistics.median(r[i] for r in per_cut)

    # Fault groups (T-crossings) are one gap in faultmesh and one cut per fault
    # in the baseline: a group row pools its members' cuts.
    members: Dict[str, List[str]] = {}
    for grp in ds.fault_groups():
        if len(grp) > 1 and grp[0].group:
            members[grp[0].group] = [f.name for f in grp]

    keys: List[Tuple[str, str]] = []
    for r in quality + paper:
        if (r["fault"], r["layer"]) not in keys:
            keys.append((r["fault"], r["layer"]))
    for g in cut.gaps:
        if (g.fault, g.layer) not in keys:
            keys.append((g.fault, g.layer))

    rows = []
    checks = {"gaps": 0, "counts_equal_cgal": True, "mismatches": [], "identical_to_cgal": 0,
              "quality_not_worse_than_cgal": True, "worse": []}
    # Every gap of both faultmesh columns (the paper's removal rule gives other
    # gap polygons than the default clearance) against CGAL's CDT of it.
    for method, r in [("quality", r) for r in quality] + [("paper", r) for r in paper]:
        checks["gaps"] += method == "quality"
        if r["stats"]["triangles"] != r["cgal_stats"]["triangles"]:
            checks["counts_equal_cgal"] = False
            checks["mismatches"].append({"method": method, "fault": r["fault"], "layer": r["layer"],
                                         "faultmesh": r["stats"]["triangles"],
                                         "cgal": r["cgal_stats"]["triangles"],
                                         "polygon_points": r["cgal_points"],
                                         "cgal_vertices": r["cgal_vertices"]})
        checks["identical_to_cgal"] += int(r["cgal_identical"]) if method == "quality" else 0
    for fault, layer in keys:
        sel_q = [r for r in quality if (r["fault"], r["layer"]) == (fault, layer)]
        sel_p = [r for r in paper if (r["fault"], r["layer"]) == (fault, layer)]
        names = members.get(fault, [fault])
        sel_c = [g for g in cut.gaps if g.fault in names and g.layer == layer]
        row: Dict[str, Any] = {"fault": fault, "layer": layer, "gaps": len(sel_q),
                               "group_of": names if fault in members else None}
        if sel_p:
            row["paper_cgal"] = _pool([r["cgal_stats"] for r in sel_p])
            row["paper"] = {**_pool([r["stats"] for r in sel_p]),
                            "seconds": float(sum(r["seconds"] for r in sel_p)),
                            "clip_seconds": float(sum(r["clip_seconds"] for r in sel_p))}
        if sel_q:
            row["quality"] = {**_pool([r["stats"] for r in sel_q]),
                              "seconds": float(sum(r["seconds"] for r in sel_q)),
                              "clip_seconds": float(sum(r["clip_seconds"] for r in sel_q))}
            row["cgal"] = {**_pool([r["cgal_stats"] for r in sel_q]),
                           "seconds": float(sum(r["cgal_seconds"] for r in sel_q)),
                           "identical": all(r["cgal_identical"] for r in sel_q)}
            for k in ("lt10", "lt20"):
                if row["quality"][k] > row["cgal"][k] + 1e-12:
                    checks["quality_not_worse_than_cgal"] = False
                    checks["worse"].append({"fault": fault, "layer": layer, "share": k})
        cs = _cut_stats(sel_c)
        if cs is not None:
            row["cutting"] = cs
        if fault in members:
            ours = PAPER_OURS.get(("4F2-2F1", layer))
            row["paper_ours"] = ours if ours is not None else _pool_ref(
                [PAPER_OURS.get((n, layer)) for n in names])
            row["paper_cutting"] = _pool_ref([PAPER_CUTTING.get((n, layer)) for n in names])
        else:
            row["paper_ours"] = PAPER_OURS.get((fault, layer))
            row["paper_cutting"] = PAPER_CUTTING.get((fault, layer))
        rows.append(row)

    def tot(recs, k):
        return float(sum(r[k] for r in recs))

    whole = {"paper": statistics.median(paper_runs), "quality": statistics.median(quality_runs),
             "paper_stitch_sum": tot(paper, "seconds"), "quality_stitch_sum": tot(quality, "seconds"),
             "paper_clip_sum": tot(paper, "clip_seconds"), "quality_clip_sum": tot(quality, "clip_seconds"),
             "cgal": tot(quality, "cgal_seconds"),
             "cutting": statistics.median(sum(r) for r in per_cut)}
    pooled = {"paper": np.concatenate([r["stats"]["_min"] for r in paper] or [np.zeros(0)]),
              "quality": np.concatenate([r["stats"]["_min"] for r in quality] or [np.zeros(0)]),
              "cgal": np.concatenate([r["cgal_stats"]["_min"] for r in quality] or [np.zeros(0)]),
              "cutting": np.concatenate([g.metadata["min_angle"] for g in cut.gaps] or [np.zeros(0)])}
    return {"dataset": ds.name, "rows": rows, "whole": whole, "checks": checks, "_pooled": pooled,
            "runs": {"paper": paper_runs, "quality": quality_runs, "cutting": cut_runs},
            "repeat": repeat, "taper_length": taper_length, "extension": extension}


# ----------------------------------------------------------------------------
# Output
# ----------------------------------------------------------------------------
def machine() -> str:
    return _machine(faultmesh=True)


def _n(row, key):
    v = row.get(key)
    return "—" if not v else str(v["triangles"])


def _sh(row, key, k):
    v = row.get(key)
    if not v or not v["triangles"]:
        return "—"
    return f"{v[k]:.3f}"


def _ms(row, key, field="seconds"):
    v = row.get(key)
    return "—" if not v or field not in v else f"{1e3 * v[field]:.3f}"


def _ref(t, i):
    return "—" if t is None or t[i] is None else (str(t[i]) if i == 0 else f"{t[i]:.3f}")


def _label(row) -> str:
    if row.get("group_of"):
        return f"{row['fault']} (group: {' + '.join(row['group_of'])})"
    return row["fault"]


def markdown(res: Dict[str, Any], command: str, png_name: str) -> str:
    rows, ch, w = res["rows"], res["checks"], res["whole"]
    L = ["## Method comparison: faultmesh vs CGAL CDT vs surface cutting (paper Tables 1 and 2)", "",
         f"- Machine: {machine()}",
         f"- Command: `{command}`",
         f"- Date: {today()}",
         f"- Dataset: `faultmesh.datasets.{res['dataset']}(0)` (the paper's study area re-created "
         "from a ground truth; its numbers are not the paper's, which are shown for reference).",
         "- Methods: **paper order** = `build_model(ds, stitch_order=\"plain\", refine=False, "
         "clearance=0.0)` (the paper's removal rule, ear order and no refinement); "
         "**quality + CDT** = `build_model(ds)` (defaults); **CGAL** = CGAL 5.5 "
         "`Constrained_Delaunay_triangulation_2` of the same gap polygon (outer loop + holes, "
         "from the boundary loops of the gap's triangles); "
         "**cutting** = `faultmesh.cutting.cut_model(ds)`: the continuous layer (the one faultmesh "
         "stitches into) cut along its intersection line with each fault surface (the same fault "
         "surfaces), cut triangles re-triangulated with the line as constraint (ear clipping + "
         "CDT), the line doubled and its hanging-wall copy moved by the traces' mean throw "
         f"(tapered over {res['taper_length']:.0f} m from tips; faults ending within "
         f"{res['extension']:.0f} m of the study boundary cut to it). Faults are cut one by one: "
         "a T-crossing group's row pools its members' cuts. Cutting counts are the layer triangles "
         "each cut created (the paper also counted re-triangulated fault-surface triangles).",
         "- Angles: smallest interior angle of each created triangle in 3D (the paper's measure; "
         "XY shares are in the JSON).",
         f"- Checks: gap triangle count equals CGAL's for **{ch['gaps'] - len(ch['mismatches'])}"
         f" / {ch['gaps']}** gaps; quality-order triangulation identical to CGAL's (triangle for "
         f"triangle) for {ch['identical_to_cgal']} / {ch['gaps']}; quality-order shares <= CGAL's: "
         f"**{'yes' if ch['quality_not_worse_than_cgal'] else 'NO'}**.",
         "",
         "### Table 1: triangles created", "",
         "| fault | layer | gaps | paper order | quality + CDT | CGAL CDT | cutting | paper (ours) | paper (cutting) |",
         "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        L.append(f"| {_label(r)} | {r['layer']} | {r['gaps']} | {_n(r, 'paper')} | {_n(r, 'quality')} | "
                 f"{_n(r, 'cgal')} | {_n(r, 'cutting')} | {_ref(r['paper_ours'], 0)} | "
                 f"{_ref(r['paper_cutting'], 0)} |")
    L += ["", "### Table 2: share of created triangles with smallest angle < 10° / < 20°", "",
          "| fault | layer | paper order | quality + CDT | CGAL CDT | cutting | paper (ours) | paper (cutting) |",
          "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        cell = lambda k: f"{_sh(r, k, 'lt10')} / {_sh(r, k, 'lt20')}"
        ref = lambda t: "—" if t is None else f"{t[1]:.3f} / {t[2]:.3f}"
        L.append(f"| {_label(r)} | {r['layer']} | {cell('paper')} | {cell('quality')} | {cell('cgal')} | "
                 f"{cell('cutting')} | {ref(r['paper_ours'])} | {ref(r['paper_cutting'])} |")
    L += ["", f"### Time per stitch (ms, median of {res['repeat']} runs)", "",
          "*stitch* = one `Stitcher.stitch` call as `build_model` times it (overlap, growth, "
          "contours, bridging, ear clipping, merge; a stitch that makes several gaps is shared "
          "among them); *ear clip* = `triangulate_polygon` of the same gap polygon alone and "
          "*CGAL* = CGAL's CDT of it (the like-for-like pair, best of the repeats); *cut* = one "
          "`cut_layer` call (intersection line, re-triangulation, displacement).", "",
          "| fault | layer | stitch, paper order | stitch, quality | ear clip, paper order | "
          "ear clip, quality + CDT | CGAL CDT | cut |",
          "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        L.append(f"| {_label(r)} | {r['layer']} | {_ms(r, 'paper')} | {_ms(r, 'quality')} | "
                 f"{_ms(r, 'paper', 'clip_seconds')} | {_ms(r, 'quality', 'clip_seconds')} | "
                 f"{_ms(r, 'cgal')} | {_ms(r, 'cutting')} |")
    L += ["", f"Whole model (median of {res['repeat']} runs, without the ground-truth evaluation): "
          f"`build_model` paper order {w['paper']:.3f} s, quality + CDT {w['quality']:.3f} s "
          f"(stitch calls {1e3 * w['paper_stitch_sum']:.2f} ms / {1e3 * w['quality_stitch_sum']:.2f} ms "
          f"of it); all gap polygons: ear clip {1e3 * w['paper_clip_sum']:.3f} ms (paper order) / "
          f"{1e3 * w['quality_clip_sum']:.3f} ms (quality + CDT), CGAL CDT {1e3 * w['cgal']:.3f} ms; "
          f"cutting baseline, all `cut_layer` calls {1e3 * w['cutting']:.2f} ms (the continuous layers and "
          "fault surfaces it starts from are built as in `build_model` and not counted).", "",
          f"![smallest-angle distributions]({png_name})", ""]
    if ch["mismatches"]:
        L += ["Count mismatches with CGAL:", ""]
        for m in ch["mismatches"]:
            L.append(f"- {m['fault']} / {m['layer']}: faultmesh {m['faultmesh']}, CGAL {m['cgal']} "
                     f"(polygon points {m['polygon_points']}, CGAL vertices {m['cgal_vertices']})")
        L.append("")
    return "\n".join(L)


def plot(res: Dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    bins = np.arange(0.0, 62.5, 2.5)
    # Quality order + CDT and CGAL's CDT are usually the same triangulation:
    # CGAL is drawn dashed on top so that both stay visible.
    style = {"paper": ("C0", "-", 1.6), "quality": ("C1", "-", 3.0), "cgal": ("C2", "--", 1.6),
             "cutting": ("C3", "-", 1.6)}
    for key, label in METHODS:
        m = res["_pooled"][key]
        if not len(m):
            continue
        c, ls, lw = style[key]
        ax1.hist(m, bins=bins, histtype="step", lw=lw, ls=ls, color=c, label=f"{label} (n={len(m)})")
        s = np.sort(m)
        ax2.step(s, np.arange(1, len(s) + 1) / len(s), where="post", lw=lw, ls=ls, color=c, label=label)
    for ax in (ax1, ax2):
        for t in (10, 20):
            ax.axvline(t, color="0.5", ls=":", lw=1)
        ax.set_xlabel("smallest interior angle of a created triangle (degrees, 3D)")
        ax.set_xlim(0, 60)
    ax1.set_ylabel("triangles")
    ax1.set_title("histogram")
    ax2.set_ylabel("cumulative share")
    ax2.set_title("cumulative distribution")
    ax1.legend(fontsize=8)
    fig.suptitle(f"Stitched gaps of {res['dataset']}: smallest-angle distributions")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _jsonable(res: Dict[str, Any]) -> Dict[str, Any]:
    def clean(x):
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items() if not k.startswith("_")}
        if isinstance(x, (list, tuple)):
            return [clean(v) for v in x]
        if isinstance(x, (np.integer,)):
            return int(x)
        if isinstance(x, (np.floating,)):
            return float(x)
        if isinstance(x, float) and not np.isfinite(x):
            return None
        return x
    return clean(res)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT / "bench" / "results" / "compare")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--taper", type=float, default=150.0,
                    help="cutting baseline: displacement taper length from the tips (m)")
    ap.add_argument("--extension", type=float, default=100.0,
                    help="cutting baseline: faults ending this close to the study boundary cut to it (m)")
    ap.add_argument("--docs", action="store_true", help="also write docs/bench/compare.md and its plot")
    args = ap.parse_args(argv)
    command = "python bench/compare.py " + " ".join(argv if argv is not None else sys.argv[1:])
    ds = faultmesh.datasets.paper_like(args.seed)
    res = compare(ds, repeat=args.repeat, taper_length=args.taper, extension=args.extension)
    args.out.mkdir(parents=True, exist_ok=True)
    png = "compare_min_angles.png"
    plot(res, args.out / png)
    md = markdown(res, command, png)
    (args.out / "compare.md").write_text(md)
    doc = json.dumps({"machine": machine(), "command": command, "date": today(),
                      **_jsonable(res)}, indent=2)
    (args.out / "compare.json").write_text(doc)
    if args.docs:
        # docs/bench/*.md are concatenated into docs/benchmarks.md
        # (bench/collect_docs.py): the image path is relative to docs/.
        d = ROOT / "docs" / "bench"
        d.mkdir(parents=True, exist_ok=True)
        (d / "compare.md").write_text(markdown(res, command, "bench/" + png))
        (d / "compare.json").write_text(doc)
        plot(res, d / png)
    print(md)
    ok = res["checks"]["counts_equal_cgal"]
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
