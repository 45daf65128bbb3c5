"""Claudius on dataset format v2: the real data as they are, the library does
the rest.

    PYTHONPATH=python python examples/claudius/make_dataset.py [--data tests/data/claudius]
        [--out examples/claudius/out] [--quick]

The data (tests/data/claudius, licences there): ``claudius.csv`` holds the
picks of four horizons on 3D seismic (Carnarvon Basin, NW Australia;
columns X,Y,Z,val,feature_name; Z is elevation, so the shallowest horizon
has the LARGEST Z), ``fault_points.csv`` 93 points on the fault that cuts
them. This script writes them into a format-2 dataset without any
interpretation: each horizon's picks are that layer's ``points``, the 93
fault points are the fault's ``"points"``; no boreholes (no pseudo-wells),
no sections, no cutoffs, no kind. The two things a dataset must name and
the data do not, the layer order and the study area, come from the
library's helpers (:func:`faultmesh.derive.layer_order`: by mean
elevation; :func:`faultmesh.derive.study_area`: the box every horizon's
picks cover). ``faultmesh.build_model`` derives the fault surface, its
sections, cutoffs, throw, kind and ends (:mod:`faultmesh.derive`,
docs/derive.md) and builds the model.

Then the held-out checks (README.md beside this file prints their numbers):

(a) 10 % of the picks farther than 500 m (map view) from every fault point
    withheld at random (seed 0): median |dz| at the withheld picks per layer.
(b) every pick within 200, 300, 500 m of the fault withheld, with two
    definitions of the distance: ``3d``, the 3D distance to the nearest
    fault point; ``2d``, the map-view distance to the fault's trace at the
    pick's elevation (the contour of the fault surface, the TIN of its
    points, at that elevation; a pick at an elevation the fault does not
    reach is not near it). The derived kind and the median |dz| of every
    layer with withheld picks (the deepest, val_330, is the one the fault
    cuts).

Each check builds its own model from the remaining picks (from the
dataset in memory; the full dataset goes through its file and back).
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path
from typing import Callable, Dict, Optional

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
if __name__ == "__main__":
    sys.path.insert(0, str(REPO / "python"))

import faultmesh  # noqa: E402
from faultmesh import derive  # noqa: E402
from faultmesh.dataset import Boreholes, Dataset, Fault, points_in_polygon  # noqa: E402

FAULT = "claudius_fault"
CRS = "UTM (zone 50S assumed; the source gives no CRS); Z = elevation, m"
#: Distances (m) within which every pick is withheld in check (b).
NEAR_DISTANCES = (200.0, 300.0, 500.0)
#: Check (a): the fraction withheld, the seed, the clearance (m, map view)
#: from every fault point and the margin (m) inside the study area's
#: boundary outside which picks are candidates: a pick withheld at the
#: boundary is extrapolated, not interpolated. The same as the hand-made
#: interpretation this example replaced (its study area was the box 40 m
#: inside the picks' box), so that the numbers compare.
HOLDOUT_FRACTION, HOLDOUT_SEED, HOLDOUT_CLEARANCE, HOLDOUT_MARGIN = 0.1, 0, 500.0, 40.0
#: Medians of check (a) the hand-made interpretation (format v1, sections,
#: cutoffs and kind drawn by a script) reached, rounded up: the bar.
HAND_MADE_MEDIANS = {"val_0": 0.8, "val_60": 0.7, "val_250": 0.8, "val_330": 3.0}


# ---------------------------------------------------------------------------
# The data as they are
# ---------------------------------------------------------------------------
def read_horizons(data_dir: Path) -> Dict[str, np.ndarray]:
    """The picks (n, 3) of each horizon, named ``val_<val>``. Rows without
    a ``val`` (25 orientation rows: normals nx, ny, nz) are no picks."""
    rows: Dict[str, list] = {}
    with open(Path(data_dir) / "claudius.csv", newline="") as f:
        for r in csv.DictReader(f):
            if r["val"]:
                rows.setdefault(f"val_{int(float(r['val']))}", []).append(
                    (float(r["X"]), float(r["Y"]), float(r["Z"])))
    return {k: np.array(v) for k, v in rows.items()}


def read_fault_points(data_dir: Path) -> np.ndarray:
    """The 93 fault points (x, y, z)."""
    return np.loadtxt(Path(data_dir) / "fault_points.csv", delimiter=",", skiprows=1,
                      usecols=(0, 1, 2))


def make_dataset(horizons: Dict[str, np.ndarray], fault_points: np.ndarray,
                 boundary: Optional[np.ndarray] = None) -> Dataset:
    """The format-2 dataset in memory: picks as layer points, the fault as
    its points; layer order and (by default) study area from the library."""
    layers = derive.layer_order(horizons)
    ring = derive.study_area(horizons) if boundary is None else boundary
    no_holes = Boreholes(np.zeros(0, dtype=str), np.zeros((0, 2)), np.zeros(0, dtype=str),
                         np.zeros(0))
    return Dataset(name="claudius", layers=layers, boundary=ring, boreholes=no_holes,
                   points={lay: horizons[lay] for lay in layers},
                   faults=[Fault(FAULT, points=fault_points)], crs=CRS)


# ---------------------------------------------------------------------------
# Distances to the fault
# ---------------------------------------------------------------------------
def distance_3d(fault_points: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """P (n, 3) -> 3D distance to the nearest fault point."""
    from scipy.spatial import cKDTree

    tree = cKDTree(fault_points)
    return lambda P: np.asarray(tree.query(np.asarray(P, dtype=np.float64))[0])


def distance_2d(vertices: np.ndarray, triangles: np.ndarray,
                chunk: int = 2000) -> Callable[[np.ndarray], np.ndarray]:
    """P (n, 3) -> map-view distance from each point to the contour of the
    fault surface (``vertices``, ``triangles``) at the point's elevation:
    the fault's trace at that level. inf where the surface does not reach
    the point's elevation. Per chunk of points, all triangles at once."""
    V = np.asarray(vertices, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64)
    A, B, C = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    edges = ((A, B), (B, C), (C, A))

    def dist(P):
        P = np.asarray(P, dtype=np.float64).reshape(-1, 3)
        out = np.full(len(P), np.inf)
        for s in range(0, len(P), chunk):
            p = P[s:s + chunk]
            z = p[:, 2][:, None]                                    # (m, 1)
            ends = []
            for a, b in edges:
                above_a, above_b = a[None, :, 2] >= z, b[None, :, 2] >= z
                cross = above_a != above_b                          # (m, t)
                with np.errstate(divide="ignore", invalid="ignore"):
                    t = (z - a[None, :, 2]) / (b[None, :, 2] - a[None, :, 2])
                t = np.where(cross, t, 0.0)
                ends.append((cross, a[None, :, :2] + t[..., None] * (b - a)[None, :, :2]))
            # A triangle the level crosses has exactly two crossed edges: the
            # contour segment between their crossings.
            n_cross = sum(c.astype(int) for c, _ in ends)
            seg = n_cross == 2
            first = np.where(ends[0][0][..., None], ends[0][1], ends[1][1])
            second = np.where(ends[2][0][..., None], ends[2][1], ends[1][1])
            d = second - first                                      # (m, t, 2)
            w = p[:, None, :2] - first
            L2 = np.sum(d * d, axis=2)
            with np.errstate(divide="ignore", invalid="ignore"):
                tt = np.clip(np.where(L2 > 0, np.sum(w * d, axis=2) / L2, 0.0), 0.0, 1.0)
            r = np.linalg.norm(w - tt[..., None] * d, axis=2)
            out[s:s + chunk] = np.min(np.where(seg, r, np.inf), axis=1)
        return out

    return dist


# ---------------------------------------------------------------------------
# Held-out checks
# ---------------------------------------------------------------------------
def random_holdout(horizons: Dict[str, np.ndarray], fault_points: np.ndarray, ring: np.ndarray,
                   fraction: float = HOLDOUT_FRACTION, seed: int = HOLDOUT_SEED,
                   clearance: float = HOLDOUT_CLEARANCE, margin: float = HOLDOUT_MARGIN):
    """(used, held): ``fraction`` of each layer's picks farther than
    ``clearance`` (map view) from every fault point and at least
    ``margin`` inside the study area ``ring`` (a box), drawn at random
    (layers in the dataset's order, one generator)."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    tree = cKDTree(fault_points[:, :2])
    lo, hi = ring.min(axis=0) + margin, ring.max(axis=0) - margin
    used, held = {}, {}
    for lay in derive.layer_order(horizons):
        p = horizons[lay]
        pick = (tree.query(p[:, :2])[0] > clearance) & (rng.random(len(p)) < fraction) \
            & np.all((p[:, :2] >= lo) & (p[:, :2] <= hi), axis=1)
        used[lay], held[lay] = p[~pick], p[pick]
    return used, held


def near_fault_holdout(horizons: Dict[str, np.ndarray], ring: np.ndarray,
                       distance: Callable[[np.ndarray], np.ndarray], within: float):
    """(used, held): every pick within ``within`` of the fault (by
    ``distance``) withheld; held are those inside the study area."""
    used, held = {}, {}
    for lay, p in horizons.items():
        near = distance(p) <= within
        used[lay], held[lay] = p[~near], p[near & points_in_polygon(p[:, :2], ring)]
    return used, held


def misfit(model, points: Dict[str, np.ndarray]) -> Dict[str, Dict[str, float]]:
    """|dz| between each layer's surface and the given picks: median, 90th
    percentile, count (a pick no triangle covers is an error)."""
    from faultmesh.report import evaluate_surface

    out = {}
    for lay, p in points.items():
        if not len(p):
            continue
        lo, hi, nh = evaluate_surface(model.surfaces[lay], p[:, 0], p[:, 1])
        if not (nh > 0).all():
            raise RuntimeError(f"claudius: {int((nh == 0).sum())} withheld pick(s) of {lay} "
                               "lie outside the model")
        dz = np.abs(0.5 * (lo + hi) - p[:, 2])
        out[lay] = {"n": int(len(p)), "median": float(np.median(dz)),
                    "p90": float(np.percentile(dz, 90))}
    return out


def run_check(horizons, fault_points, ring, used, held) -> Dict:
    """Build a model from ``used`` (the library derives the fault) and
    measure it at ``held``."""
    t0 = time.perf_counter()
    ds = make_dataset(used, fault_points, boundary=ring)
    # The withheld picks leave holes in the layers: filled from a
    # minimum-curvature surface (docs/derive.md, "Data holes of a layer").
    model = faultmesh.build_model(ds, evaluate=False, fill_holes=True)
    model.check()
    rep = model.metadata["derived_faults"][FAULT]
    return {"kind": rep["kind"], "cut": sorted(rep["cutoffs"]), "ends": rep["ends"],
            "warnings": len(rep["warnings"]), "misfit": misfit(model, held),
            "seconds": time.perf_counter() - t0}


def checks(horizons, fault_points, ring, distances=NEAR_DISTANCES,
           kinds=("3d", "2d")) -> Dict[str, Dict]:
    """Check (a) ("random") and check (b) ("3d_300" ...) for the given
    distances and distance definitions."""
    out = {"random": run_check(horizons, fault_points, ring,
                               *random_holdout(horizons, fault_points, ring))}
    fs = derive.fault_surface(Fault(FAULT, points=fault_points), ring,
                              (min(p[:, 2].min() for p in horizons.values()),
                               max(p[:, 2].max() for p in horizons.values())))
    dist = {"3d": distance_3d(fault_points), "2d": distance_2d(*fs.own)}
    for kind in kinds:
        for d in distances:
            out[f"{kind}_{d:.0f}"] = run_check(horizons, fault_points, ring,
                                               *near_fault_holdout(horizons, ring, dist[kind], d))
    return out


# ---------------------------------------------------------------------------
# The example
# ---------------------------------------------------------------------------
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(REPO / "tests" / "data" / "claudius"))
    ap.add_argument("--out", default=str(HERE / "out"))
    ap.add_argument("--quick", action="store_true",
                    help="check (b) at 300 m (3D) only")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    horizons = read_horizons(Path(args.data))
    fpts = read_fault_points(Path(args.data))
    ds = make_dataset(horizons, fpts)
    js = ds.save(out / "dataset", version=2)
    print(f"dataset written: {js}")
    loaded = faultmesh.load_dataset(js)
    derived = derive.derive_faults(loaded)          # what build_model does first
    model = faultmesh.build_model(derived, fill_holes=True)
    model.check()
    print("Model.check(): passed")
    model.save(out / "claudius.3dt")
    model.save(out / "claudius.ts")
    model.quality().to_markdown_file(out / "quality.md")
    fr = derived.derivation.faults[FAULT]
    surf = fr.surface
    info = {
        "layers": {lay: {"picks": int(len(horizons[lay])),
                         "mean_z": float(np.mean(horizons[lay][:, 2]))} for lay in ds.layers},
        "boundary": np.asarray(ds.boundary).tolist(),
        "fault": {"points": int(len(fpts)), "dip": surf.dip,
                  "dip_direction": float(np.degrees(np.arctan2(*surf.dip_dir)) % 360.0),
                  "projection_axis": "xyz"[surf.axis], "kind": fr.kind, "ends": fr.ends,
                  "tips": fr.tips.tolist(), "cut_layers": sorted(fr.cutoffs),
                  "sections": fr.sections, "warnings": fr.warnings,
                  "throw": {lay: {"u": p["u"].tolist(), "throw": p["throw"].tolist()}
                            for lay, p in fr.throw.items() if p["cut"].any()}},
        "check": "passed",
        "gaps": [{"layer": g.layer, "triangles": int(len(g.triangles))} for g in model.gaps],
        "timings": model.metadata["timings"],
    }
    # The section across the fault with the largest throw.
    best = None
    for name in fr.sections:
        tr = next(t for t in derived.fault(FAULT).traces if t.section == name)
        for lay, sides in tr.layers.items():
            t = float(sides["foot"][-1, 2] - sides["hanging"][0, 2])
            if best is None or t > best[2]:
                best = (name, lay, t)
    if best is not None:
        sec = derived.sections[best[0]]
        view = model.section(sec.origin, sec.azimuth)
        view.plot(out / "section.png", title=f"Claudius (v2, derived): section {best[0]} across "
                                              f"the fault ({best[1]} throw {best[2]:.0f} m)")
        view.to_csv(out / "section.csv")
        info["section_png"] = {"section": best[0], "layer": best[1], "throw": best[2]}

    distances = (300.0,) if args.quick else NEAR_DISTANCES
    kinds = ("3d",) if args.quick else ("3d", "2d")
    info["holdout"] = checks(horizons, fpts, np.asarray(ds.boundary, dtype=np.float64),
                             distances, kinds)
    with open(out / "report.json", "w") as f:
        json.dump(info, f, indent=1, default=float)

    fi = info["fault"]
    print(f"fault: dip {fi['dip']:.1f} towards {fi['dip_direction']:.0f}, {fi['kind']}, ends "
          f"{fi['ends']}, cuts {fi['cut_layers']}, {len(fi['sections'])} sections")
    for lay, p in fi["throw"].items():
        print(f"  throw of {lay} along strike (m):", " ".join(f"{t:.0f}" for t in p["throw"]))
    print(f"build {info['timings']['total']:.2f} s; gaps: {info['gaps']}")
    print(f"{'check':10s} {'kind':8s}", " ".join(f"{lay:>16s}" for lay in ds.layers))
    for name, r in info["holdout"].items():
        cells = [(f"{r['misfit'][lay]['median']:6.2f} ({r['misfit'][lay]['n']:4d})"
                  if lay in r["misfit"] else "") for lay in ds.layers]
        print(f"{name:10s} {r['kind']:8s}", " ".join(f"{c:>16s}" for c in cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
