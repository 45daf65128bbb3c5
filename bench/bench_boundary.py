"""Benchmark boundary extraction + Algorithm 1 sorting against faultmesh's own
Delaunay triangulation of the same points.

    python bench/bench_boundary.py [--runs 5] [--only NAME ...] [--no-write]

faultmesh must be importable: installed (pip install .), or a development
build selected with FAULTMESH_DEV_BUILD=$PWD/build/<dir>.

For each TIN with holes (built once: faultmesh.delaunay of the points, then
the triangles of a few regions removed) every run times, in this process:
  * faultmesh.delaunay(points)              -- the reference the target is set against;
  * faultmesh.boundary_contours(triangles)  -- edge-frequency extraction plus
    Algorithm 1 sorting into loops, with the full report (open chains, pinch
    vertices, non-manifold / inconsistent edges);
  * faultmesh.boundary_edges(triangles)     -- the extraction alone;
medians over --runs runs (the three calls alternate within a run). Target:
boundary_contours at most 0.25x the Delaunay time.
Correctness is checked on every dataset: the directed boundary edges equal a
numpy reference (edge keys counted with np.unique), every boundary edge lies on
exactly one loop, and the loops' signed areas add up to the triangles' area
(Green's theorem). The markdown table goes to stdout and docs/bench/boundary.md.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from _common import (add_table_args, machine, parse_table_args, pick, table_header, use_dev_build,
                     write_table)

use_dev_build()
import faultmesh  # noqa: E402


# ----------------------------------------------------------------- datasets

def remove_disks(xy, tri, k, radius, seed):
    """Drop the triangles whose centroid lies in one of k random disks."""
    rng = np.random.default_rng(seed)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    c = xy[tri].mean(axis=1)
    keep = np.ones(len(tri), dtype=bool)
    for p in lo + rng.random((k, 2)) * (hi - lo):
        keep &= ((c - p) ** 2).sum(axis=1) > radius * radius
    return np.ascontiguousarray(tri[keep])


def uniform_with_disks():
    xy = np.random.default_rng(1).random((1_000_000, 2)) * 1000.0
    return xy, lambda t: remove_disks(xy, t, 60, 12.0, 2)


def grid_with_blocks():
    k = 1000
    xy = np.stack(np.meshgrid(np.arange(float(k)), np.arange(float(k))), -1).reshape(-1, 2)

    def holes(t):
        # 40 rectangular blocks of cells (axis-aligned holes with straight sides).
        rng = np.random.default_rng(3)
        c = xy[t].mean(axis=1)
        keep = np.ones(len(t), dtype=bool)
        for _ in range(40):
            x0, y0 = rng.integers(10, 950, 2)
            w, h = rng.integers(5, 40, 2)
            keep &= ~((c[:, 0] > x0) & (c[:, 0] < x0 + w) & (c[:, 1] > y0) & (c[:, 1] < y0 + h))
        return np.ascontiguousarray(t[keep])

    return xy, holes


DATASETS = [
    ("Delaunay of 1M uniform points, 60 disk holes", uniform_with_disks),
    ("Delaunay of 1000x1000 grid points, 40 rectangular holes", grid_with_blocks),
]


# ------------------------------------------------------------------- checks

def reference_boundary(tri):
    """Directed boundary edges by numpy: undirected keys counted with np.unique."""
    e = np.stack([tri, np.roll(tri, -1, axis=1)], axis=2).reshape(-1, 2)
    key = np.sort(e, axis=1)
    _, inv, cnt = np.unique(key[:, 0] * (tri.max() + 1) + key[:, 1], return_inverse=True,
                            return_counts=True)
    return e[cnt[inv] == 1]


def check(xy, tri, rep) -> bool:
    ref = reference_boundary(tri)
    got = faultmesh.boundary_edges(tri)
    same_edges = np.array_equal(np.unique(ref, axis=0), np.unique(got, axis=0)) and len(ref) == len(got)
    loop_edges = np.concatenate([np.column_stack([l, np.roll(l, -1)]) for l in rep.loops]) \
        if rep.loops else np.zeros((0, 2), dtype=np.int64)
    on_loops = np.array_equal(np.unique(loop_edges, axis=0), np.unique(got, axis=0)) and \
        len(loop_edges) == len(got) and not rep.open_chains
    p = xy[tri]
    tri_area = 0.5 * np.sum((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                            - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    loop_area = 0.0
    for l in rep.loops:
        q = xy[l]
        r = np.roll(q, -1, axis=0)
        loop_area += 0.5 * np.sum(q[:, 0] * r[:, 1] - q[:, 1] * r[:, 0])
    green = abs(loop_area - tri_area) <= 1e-9 * abs(tri_area)
    return bool(same_edges and on_loops and green)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_table_args(ap, "boundary")
    args = parse_table_args(ap)

    rows = []
    for name, make in pick(DATASETS, args.only):
        xy, holes = make()
        tri = holes(faultmesh.delaunay(xy))
        td, tc, te, cd, cc = [], [], [], [], []
        for _ in range(args.runs):
            c0, t0 = time.process_time(), time.perf_counter()
            faultmesh.delaunay(xy)
            c1, t1 = time.process_time(), time.perf_counter()
            rep = faultmesh.boundary_contours(tri)
            c2, t2 = time.process_time(), time.perf_counter()
            faultmesh.boundary_edges(tri)
            t3 = time.perf_counter()
            td.append(t1 - t0)
            tc.append(t2 - t1)
            te.append(t3 - t2)
            cd.append(c1 - c0)
            cc.append(c2 - c1)
        ok = check(xy, tri, rep)
        row = dict(name=name, n=len(xy), m=len(tri), d=statistics.median(td), c=statistics.median(tc),
                   e=statistics.median(te), loops=len(rep.loops), pinch=len(rep.pinch_vertices),
                   edges=sum(len(l) for l in rep.loops), ok=ok,
                   cd=statistics.median(cd), cc=statistics.median(cc))
        row["ratio"] = row["c"] / row["d"]
        row["ratio_cpu"] = row["cc"] / row["cd"]
        rows.append(row)
        print(f"{name}: delaunay {row['d']:.3f} s, contours {row['c']:.3f} s, ratio {row['ratio']:.3f}, "
              f"checks {'ok' if ok else 'FAILED'}", file=sys.stderr, flush=True)

    lines = table_header("Boundary contours: extraction + Algorithm 1 sorting vs faultmesh's Delaunay", "bench_boundary.py",
                         machine(numpy=True)) + [
        f"Runs: median of {args.runs} runs, in-process through the Python API, the calls alternating.",
        "Target: `boundary_contours` at most 0.25x `delaunay` of the same points.",
        "",
        "`boundary_contours`: edge frequency by a counting sort of the half-edges on their smaller",
        "vertex, then Algorithm 1 (head/tail insertion) into loops, pinches resolved through the",
        "triangle fans, full report. `boundary_edges`: the extraction alone. Checked: boundary edges",
        "equal a numpy reference, every one on exactly one loop, loop areas sum to the TIN's area.",
        "",
        "Wall-clock medians, and medians of the process CPU time (less disturbed by other load).",
        "",
        "| data | points | triangles | delaunay s | boundary_contours s | ratio | delaunay CPU s "
        "| contours CPU s | ratio CPU | boundary_edges s | loops | boundary edges | pinch vertices | checks |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|:---:|",
    ]
    for r in rows:
        lines.append(f"| {r['name']} | {r['n']:,} | {r['m']:,} | {r['d']:.3f} | {r['c']:.3f} | {r['ratio']:.3f} "
                     f"| {r['cd']:.3f} | {r['cc']:.3f} | {r['ratio_cpu']:.3f} "
                     f"| {r['e']:.3f} | {r['loops']} | {r['edges']:,} | {r['pinch']} "
                     f"| {'ok' if r['ok'] else 'FAILED'} |")
    write_table("\n".join(lines) + "\n", "boundary", args)
    return 0 if all(r["ok"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
