"""Scale benchmark: 200 fault patches stitched one after another into a layer
TIN of 1M points (DESIGN.md step 7 at scale; issue 5, item 4).

    python bench/bench_scale.py [--points 1000000] [--faults 200] [--repeat 5]
                                [--locality] [--docs] [--out DIR]

What is measured (all in this one process, medians over ``--repeat`` runs):

* ``delaunay``: ``faultmesh.delaunay`` of the same points (the reference);
* ``stitch total``: building the stitcher on the TIN (adjacency and AABB tree),
  the 200 stitches one after another, and the final compacted mesh -- what a
  user pays to get the faulted layer from the TIN;
* per stitch: median and maximum over the 200 stitches;
* peak memory: the process's peak resident set (VmHWM) during a stitching
  run (reset just before it through /proc/self/clear_refs), maximum over the
  runs, and the resident set before the runs;
* ratio: stitch total / delaunay (target <= 2).

``--locality``: the same 50 faults (fewer if the smallest area cannot hold them) (same places, same patches) stitched into
TINs of the same point density but 1/4, 1/2 and the full area: if each stitch
touches only the neighbourhood of its fault, the time per stitch does not grow
with the mesh.

The data are synthetic and generated here (fixed seed): points uniform in a
square of side ``sqrt(points) * 10`` m (10 m mean spacing) with a smooth
surface z(x, y); the study area is the square (its corners are data points).
The faults sit in a grid of cells, one per cell, with random strike, dip 45 to
70 degrees, throw 5 to 25 m, alternating normal and reverse. Each patch is
lofted (``faultmesh.loft``, minimum area) between three traces 150 m apart
along strike (zero throw at the two ends, full throw in the middle); a trace
is the footwall polyline (100 m, to the footwall cutoff) followed by the
hanging-wall polyline (from the hanging-wall cutoff, 100 m), points every
10 m. The fault strip of a reverse fault runs backwards in XY
(the repetition band), as in real data.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Dict, List, Tuple

import numpy as np

from _common import (ROOT, machine as _machine, proc_status_mib, reset_peak_rss, time_runs, today,
                     use_dev_build)

use_dev_build()
import faultmesh  # noqa: E402

SPACING = 10.0  # mean point spacing (m)


# ----------------------------------------------------------------------------
# Synthetic data
# ----------------------------------------------------------------------------
def surface_z(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A smooth layer top: a gentle dip with folds of 1-3 km wavelength."""
    return (-400.0 - 0.01 * x + 0.006 * y + 12.0 * np.sin(x / 900.0) * np.cos(y / 1300.0)
            + 5.0 * np.sin((x + 2 * y) / 2100.0))


def make_points(n: int, side: float, seed: int) -> np.ndarray:
    """n points (n, 3): the square's 4 corners and n - 4 uniform points."""
    rng = np.random.default_rng([seed, 0x5CA1E])
    xy = np.vstack([[[0.0, 0.0], [side, 0.0], [side, side], [0.0, side]],
                    rng.uniform(0.0, side, size=(n - 4, 2))])
    return np.column_stack([xy, surface_z(xy[:, 0], xy[:, 1])])


def fault_patch(center: np.ndarray, strike: float, dip: float, throw: float, kind: str,
                length: float = 300.0, reach: float = 100.0, step: float = SPACING
                ) -> Tuple[np.ndarray, np.ndarray]:
    """One fine fault model: (vertices (k, 3), triangles (m, 3)), lofted
    (``faultmesh.loft``, minimum area) between three traces at -length/2, 0
    and +length/2 along strike. The middle trace has the full throw; the two
    end traces have zero throw (the footwall and hanging-wall cutoffs
    coincide), which is how a fault dies out along strike and what keeps the
    outline of a reverse fault's patch simple in XY."""
    s = np.array([np.sin(np.deg2rad(strike)), np.cos(np.deg2rad(strike))])  # strike direction
    d = np.array([s[1], -s[0]])  # dip direction (right of strike)
    nf = int(round(reach / step))
    traces = []
    for u, t in ((-0.5 * length, 0.0), (0.0, throw), (0.5 * length, 0.0)):
        base = center + u * s
        heave = t / np.tan(np.deg2rad(dip))
        xf = np.linspace(-reach, 0.0, nf + 1)  # footwall: far end -> cutoff at 0
        if kind == "normal":  # hanging wall beyond the cutoff, down by the throw
            xh = np.linspace(heave, heave + reach, nf + 1)
            zf, zh = +0.5 * t, -0.5 * t
        else:  # reverse: hanging-wall cutoff back over the footwall, up by the throw
            xh = np.linspace(-heave, reach, nf + 1)
            zf, zh = -0.5 * t, +0.5 * t
        if t == 0.0:
            xh = xh[1:]  # the hanging-wall cutoff is the footwall cutoff
        pts = []
        for xs, dz in ((xf, zf), (xh, zh)):
            p = base[None, :] + xs[:, None] * d[None, :]
            pts.append(np.column_stack([p, surface_z(p[:, 0], p[:, 1]) + dz]))
        traces.append(np.vstack(pts))
    off = np.cumsum([0] + [len(t) for t in traces])
    tris = [np.asarray(faultmesh.loft(a, b, method="min_area"), dtype=np.int64).reshape(-1, 3)
            for a, b in zip(traces[:-1], traces[1:])]
    # Strip i indexes trace i then trace i + 1: shift into the shared numbering.
    tri = np.vstack([t + off[i] for i, t in enumerate(tris)])
    return np.vstack(traces), tri


def make_faults(n_faults: int, side: float, seed: int, region: float = 1.0
                ) -> List[Tuple[str, np.ndarray, np.ndarray]]:
    """n_faults patches, one per cell of a grid over the lower-left
    ``region`` x ``region`` part of the square (cells >= 450 m, so patches --
    at most ~390 m across -- never overlap)."""
    rng = np.random.default_rng([seed, 0xFA17])
    extent = side * region
    ny = max(1, int(np.floor(np.sqrt(n_faults * extent / extent))))
    nx = int(np.ceil(n_faults / ny))
    cw, ch = extent / nx, extent / ny
    if min(cw, ch) < 450.0:
        raise ValueError(f"make_faults: {n_faults} faults do not fit in {extent:.0f} m "
                         f"(cells {cw:.0f} x {ch:.0f} m, need >= 450 m)")
    out = []
    for k in range(n_faults):
        i, j = k % nx, k // nx
        c = np.array([(i + 0.5) * cw, (j + 0.5) * ch])
        c += rng.uniform(-0.5, 0.5, 2) * np.maximum(np.array([cw, ch]) - 420.0, 0.0)
        kind = "normal" if k % 2 == 0 else "reverse"
        v, t = fault_patch(c, strike=rng.uniform(0.0, 360.0), dip=rng.uniform(45.0, 70.0),
                           throw=rng.uniform(5.0, 25.0), kind=kind)
        out.append((f"F{k + 1:03d}-{kind}", v, t))
    return out


# ----------------------------------------------------------------------------
# Measurement helpers
# ----------------------------------------------------------------------------
def machine() -> str:
    return _machine(faultmesh=True)


def time_delaunay(xy: np.ndarray, repeat: int) -> List[float]:
    return time_runs(lambda: faultmesh.delaunay(xy), repeat)


def stitch_all(V: np.ndarray, T: np.ndarray, halfedges: np.ndarray, boundary: np.ndarray,
               faults) -> Dict[str, object]:
    """Build a stitcher, stitch every fault, compact: times of each phase."""
    t0 = time.perf_counter()
    st = faultmesh.Stitcher(V, T, boundary, halfedges=halfedges, name="layer")
    t1 = time.perf_counter()
    per, removed = [], []
    for name, pv, pt in faults:
        a = time.perf_counter()
        rep = st.stitch(pv, pt, name=name)
        per.append(time.perf_counter() - a)
        removed.append(len(rep.removed))
    t2 = time.perf_counter()
    mesh = st.mesh()
    t3 = time.perf_counter()
    nt = len(mesh.triangles)
    return {"build": t1 - t0, "stitches": per, "mesh": t3 - t2, "total": t3 - t0,
            "removed": removed, "triangles_out": nt}


def run(n_points: int, n_faults: int, repeat: int, seed: int, region: float = 1.0,
        delaunay_repeat: int = None) -> Dict[str, object]:
    side = float(np.sqrt(n_points) * SPACING)
    P = make_points(n_points, side, seed)
    boundary = np.array([[0.0, 0.0], [side, 0.0], [side, side], [0.0, side]])
    faults = make_faults(n_faults, side, seed, region=region)
    info = faultmesh.delaunay(P[:, :2], return_info=True)
    T, H = np.asarray(info.triangles), np.asarray(info.halfedges)
    rss_before = proc_status_mib("VmRSS")
    # Delaunay and stitching runs alternate, so that both see the same load
    # on a shared machine. The peak is reset before each stitching run.
    d_runs, runs, peaks = [], [], []
    for i in range(repeat):
        if i < (delaunay_repeat or repeat):
            d_runs += time_delaunay(P[:, :2], 1)
        peak_ok = reset_peak_rss()
        runs.append(stitch_all(P, T, H, boundary, faults))
        peaks.append(proc_status_mib("VmHWM") if peak_ok else float("nan"))
    peak = max(peaks)
    per_all = [statistics.median(r["stitches"]) for r in runs]
    max_all = [max(r["stitches"]) for r in runs]
    return {
        "points": n_points, "side_m": side, "faults": n_faults, "layer_triangles": int(len(T)),
        "patch_triangles": int(sum(len(f[2]) for f in faults)),
        "removed_per_stitch_median": float(np.median(runs[0]["removed"])),
        "triangles_out": runs[0]["triangles_out"],
        "delaunay_s": statistics.median(d_runs), "delaunay_runs": d_runs,
        "build_s": statistics.median(r["build"] for r in runs),
        "stitch_sum_s": statistics.median(sum(r["stitches"]) for r in runs),
        "mesh_s": statistics.median(r["mesh"] for r in runs),
        "total_s": statistics.median(r["total"] for r in runs),
        "total_runs": [r["total"] for r in runs],
        "per_stitch_median_s": statistics.median(per_all),
        "per_stitch_max_s": statistics.median(max_all),
        "first_stitch_s": statistics.median(r["stitches"][0] for r in runs),
        "later_max_s": statistics.median(max(r["stitches"][1:] or [0.0]) for r in runs),
        "rss_before_mib": rss_before, "peak_rss_stitching_mib": peak,
        "repeat": repeat,
    }


# ----------------------------------------------------------------------------
# Report
# ----------------------------------------------------------------------------
def markdown(res: Dict[str, object], loc: List[Dict[str, object]], command: str) -> str:
    r = res
    ratio = r["total_s"] / r["delaunay_s"]
    lines = [
        f"## Scale: {r['faults']} faults stitched into a {r['points']:,}-point layer",
        "",
        f"- Machine: {machine()}",
        f"- Command: `{command}`",
        f"- Date: {today()}",
        f"- Data: {r['points']:,} random points on a {r['side_m'] / 1000:.1f} km square "
        f"({r['layer_triangles']:,} Delaunay triangles), {r['faults']} fault patches "
        f"({r['patch_triangles']:,} triangles), median {r['removed_per_stitch_median']:.0f} "
        "layer triangles removed per stitch. Medians over "
        f"{r['repeat']} runs in one process.",
        "",
        "| step | seconds |",
        "|---|---:|",
        f"| `faultmesh.delaunay` of the points (reference) | {r['delaunay_s']:.3f} |",
        f"| `faultmesh.Stitcher` set-up on the TIN (with its half-edges) | {r['build_s']:.3f} |",
        f"| {r['faults']} stitches | {r['stitch_sum_s']:.3f} |",
        f"| compacted mesh | {r['mesh_s']:.3f} |",
        f"| **stitching total** | **{r['total_s']:.3f}** |",
        f"| time per stitch, median / max | {1e3 * r['per_stitch_median_s']:.2f} ms / "
        f"{1e3 * r['per_stitch_max_s']:.2f} ms |",
        f"| first stitch / max of the later ones | {1e3 * r['first_stitch_s']:.2f} ms / "
        f"{1e3 * r['later_max_s']:.2f} ms |",
        f"| **ratio total / Delaunay** (target <= 2) | **{ratio:.2f}** |",
        "",
        f"Peak resident memory while stitching: {r['peak_rss_stitching_mib']:.0f} MiB "
        f"(resident before: {r['rss_before_mib']:.0f} MiB, holding the points and the TIN).",
        "",
    ]
    if loc:
        lines += [f"Locality: the same {loc[0]['faults']} faults in TINs of equal density and growing area. "
                  "A stitch that touched the whole mesh would grow with the mesh; a local one "
                  "stays flat.", "",
                  "| points | triangles | set-up s | per stitch median ms | first stitch ms | "
                  "max of the later stitches ms |",
                  "|---:|---:|---:|---:|---:|---:|"]
        for x in loc:
            lines.append(f"| {x['points']:,} | {x['layer_triangles']:,} | {x['build_s']:.3f} | "
                         f"{1e3 * x['per_stitch_median_s']:.2f} | {1e3 * x['first_stitch_s']:.2f} | "
                         f"{1e3 * x['later_max_s']:.2f} |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--faults", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--locality", action="store_true", help="also run the locality check")
    ap.add_argument("--out", type=Path, default=ROOT / "bench" / "results" / "scale")
    ap.add_argument("--docs", action="store_true", help="write docs/bench/scale.md")
    args = ap.parse_args(argv)
    command = "python bench/bench_scale.py " + " ".join(argv if argv is not None else sys.argv[1:])

    res = run(args.points, args.faults, args.repeat, args.seed)
    loc = []
    if args.locality:
        # Same density, area 1/4, 1/2, 1: the 50 faults stay in the same
        # lower-left block (its side is the smallest square's).
        block = np.sqrt(args.points * 0.25) * SPACING * 0.999
        n_loc = int(min(50, np.floor(block / 450.0) ** 2))
        for frac in (0.25, 0.5, 1.0):
            n = int(args.points * frac)
            side = np.sqrt(n) * SPACING
            loc.append(run(n, n_loc, args.repeat, args.seed, region=block / side, delaunay_repeat=1))
    args.out.mkdir(parents=True, exist_ok=True)
    md = markdown(res, loc, command)
    (args.out / "scale.md").write_text(md)
    doc = json.dumps({"machine": machine(), "command": command, "date": today(),
                      "result": res, "locality": loc}, indent=2)
    (args.out / "scale.json").write_text(doc)
    if args.docs:
        (ROOT / "docs" / "bench").mkdir(parents=True, exist_ok=True)
        (ROOT / "docs" / "bench" / "scale.md").write_text(md)
        (ROOT / "docs" / "bench" / "scale.json").write_text(doc)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
