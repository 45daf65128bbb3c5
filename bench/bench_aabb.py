"""Benchmark faultmesh.AabbTree against CGAL on the same triangles and boxes.

    python bench/bench_aabb.py [--runs 5] [--only NAME ...] [--no-write]

faultmesh must be importable: installed (pip install .), or a development
build selected with FAULTMESH_DEV_BUILD=$PWD/build/<dir>.

For each dataset (a TIN and a batch of query boxes, written once to binary
files) every run times, median over --runs runs, runs alternating between the
sides:
  * faultmesh, in this process through its Python API (the arrays are already
    float64 / int64, so no conversion copy): AabbTree(vertices, triangles)
    ("build") and tree.query(boxes, exact=..., sorted=False) ("query", CSR
    answer, each query's hits in tree order like CGAL's); the default call
    with sorted=True is timed too (its own column);
  * CGAL, bench/cgal/cgal_aabb.cpp (CMake Release), a fresh process per run,
    times measured inside the program around the same two steps, file I/O
    excluded. Two CGAL analogues:
      - "AABB_tree": CGAL::AABB_tree over AABB_triangle_primitive (Epick,
        Triangle_3 at z = 0), queries all_intersected_primitives(Bbox_3):
        the triangles that really meet each closed box. faultmesh side:
        query(boxes, exact=True) (box candidates refined by an exact
        orient2d triangle/box test).
      - "box_intersection_d": CGAL's batch box intersection (closed boxes)
        between the triangles' XY boxes and the query boxes. faultmesh side:
        query(boxes) (box against box, the candidate stage of the overlap
        test).
Both sides report their total number of hits; they must agree (and, for the
AABB_tree mode, the per-query answers are compared one by one on the first
run). Reported: medians, the ratio faultmesh/CGAL of the total (build + query)
medians. The markdown table goes to stdout and to docs/bench/aabb.md.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _common import (ROOT, add_table_args, cgal_program, machine, parse_table_args, pick, run_program,
                     table_header, use_dev_build, write_array, write_table)

use_dev_build()
import faultmesh  # noqa: E402


# ----------------------------------------------------------------- datasets

def boxes_over(xy: np.ndarray, q: int, size: float, seed: int, integer: bool = False) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    c = lo + rng.random((q, 2)) * (hi - lo)
    s = rng.random((q, 2)) * size
    if integer:
        c, s = np.round(c), np.round(s)
    return np.column_stack([c, c + s])


def tin_uniform():
    xy = np.random.default_rng(1).random((500_000, 2)) * 1000.0
    return xy, faultmesh.delaunay(xy), boxes_over(xy, 100_000, 5.0, 11)


def tin_grid():
    k = 708  # 707 x 707 cells, 2 triangles each: 999,698 triangles
    g = np.stack(np.meshgrid(np.arange(float(k)), np.arange(float(k))), -1).reshape(-1, 2)
    return g, faultmesh.delaunay(g), boxes_over(g, 100_000, 4.0, 12, integer=True)


def tin_claudius():
    import csv
    pts = []
    with open(ROOT / "tests" / "data" / "claudius" / "claudius.csv", newline="") as f:
        for r in csv.DictReader(f):
            if r["val"] == "0.0":
                pts.append((float(r["X"]), float(r["Y"])))
    xy = np.array(pts)
    return xy, faultmesh.delaunay(xy), boxes_over(xy, 100_000, 150.0, 13)


DATASETS = [
    ("Delaunay TIN, 500k uniform points (1M triangles)", tin_uniform),
    ("grid TIN 707x707 cells (1M triangles, integer boxes)", tin_grid),
    ("Claudius horizon 0 (real data)", tin_claudius),
]


# -------------------------------------------------------------------- runs

def run_cgal(exe: Path, mode: str, files: list[Path], out: str = "-") -> dict:
    return run_program([exe, mode, *files, out])[0]


def run_fm(xy, tri, q, exact: bool, sort: bool):
    c0, t0 = time.process_time(), time.perf_counter()
    tree = faultmesh.AabbTree(xy, tri)
    t1 = time.perf_counter()
    off, idx = tree.query(q, exact=exact, sorted=sort)
    t2, c2 = time.perf_counter(), time.process_time()
    return t1 - t0, t2 - t1, c2 - c0, off, idx


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_table_args(ap, "aabb")
    ap.add_argument("--build-dir", default=str(ROOT / "build" / "bench-aabb"))
    args = parse_table_args(ap)

    exe = cgal_program("cgal_aabb", Path(args.build_dir))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, make in pick(DATASETS, args.only):
            xy, tri, q = make()
            files = [tmp / "v.bin", tmp / "t.bin", tmp / "q.bin"]
            write_array(files[0], xy, "<f8")
            write_array(files[1], tri, "<i8")
            write_array(files[2], q, "<f8")
            for mode, exact, label in (("tree", True, "AABB_tree, exact triangle/box hits"),
                                       ("boxd", False, "box_intersection_d, box/box hits")):
                fb, fq, cb, cq, ct, fcpu, ccpu, fsort = [], [], [], [], [], [], [], []
                same = True
                for r in range(args.runs):
                    # Like for like: CGAL returns each query's hits unsorted.
                    b, s, c, _, _ = run_fm(xy, tri, q, exact, False)
                    fb.append(b)
                    fq.append(s)
                    fcpu.append(c)
                    # The default API call (hits of each query sorted).
                    b, s, c, off, idx = run_fm(xy, tri, q, exact, True)
                    fsort.append(b + s)
                    out = str(tmp / "cg.hits") if (r == 0 and mode == "tree") else "-"
                    j = run_cgal(exe, mode, files, out)
                    cb.append(j["seconds_build"])
                    cq.append(j["seconds_query"])
                    ct.append(j["seconds"])
                    ccpu.append(j["cpu_seconds_build"] + j["cpu_seconds_query"])
                    hits_cg = j["hits"]
                    if out != "-":
                        a = np.fromfile(out, dtype="<i8")
                        nq = len(q)
                        same = (np.array_equal(a[1:2 + nq], off) and np.array_equal(a[2 + nq:], idx))
                hits_fm = int(idx.size)
                same = same and hits_fm == hits_cg
                ft = [x + y for x, y in zip(fb, fq)]
                row = dict(name=name, mode=label, m=len(tri), q=len(q),
                           fb=statistics.median(fb), fq=statistics.median(fq), ft=statistics.median(ft),
                           cb=statistics.median(cb), cq=statistics.median(cq), ct=statistics.median(ct),
                           fcpu=statistics.median(fcpu), ccpu=statistics.median(ccpu),
                           fsort=statistics.median(fsort),
                           hits_fm=hits_fm, hits_cg=hits_cg, same=same)
                row["ratio"] = row["ft"] / row["ct"]
                row["ratio_cpu"] = row["fcpu"] / row["ccpu"]
                rows.append(row)
                print(f"{name} [{mode}]: faultmesh {row['ft']:.3f} s, CGAL {row['ct']:.3f} s, "
                      f"ratio {row['ratio']:.3f}, hits {hits_fm} / {hits_cg}, agree={same}",
                      file=sys.stderr, flush=True)

    lines = table_header("AABB tree: faultmesh vs CGAL (build + batched box queries)", "bench_aabb.py",
                         machine(compiler=True, cgal=True, numpy=True)) + [
        f"Runs: median of {args.runs} runs per side; sides alternate. Target: faultmesh total at most "
        "0.5x CGAL.",
        "",
        "faultmesh: `faultmesh.AabbTree(vertices, triangles)` then `tree.query(boxes, exact=...,",
        "sorted=False)`, timed in-process through the Python API (CSR answer; like CGAL, each query's",
        "hits in tree order). The column 'fm sorted s' is the default call, `sorted=True` (build +",
        "query), whose answers are the ones compared with CGAL's.",
        "CGAL 'AABB_tree': `AABB_tree<AABB_traits<Epick, AABB_triangle_primitive>>` over Triangle_3",
        "at z = 0, `all_intersected_primitives(Bbox_3)` per query (exact triangle/box test);",
        "faultmesh answers the same question with `exact=True`. CGAL 'box_intersection_d': batch",
        "intersection of the triangles' XY boxes with the query boxes (closed); faultmesh: `exact=False`.",
        "CGAL times are measured inside bench/cgal/cgal_aabb.cpp (Release), excluding file I/O;",
        "its build step includes making the Triangle_3 (resp. Box_d) objects from the index arrays.",
        "",
        "Wall-clock columns are medians of each step; the CPU columns are medians of the process",
        "CPU time of build + query (less disturbed by other load on a shared machine).",
        "",
        "| data | triangles | queries | CGAL analogue | fm build s | fm query s | fm total s "
        "| CGAL build s | CGAL query s | CGAL total s | ratio fm/CGAL | fm CPU s | CGAL CPU s "
        "| ratio CPU | fm sorted s | ratio sorted/CGAL | hits fm | hits CGAL | agree |",
        "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|:---:|",
    ]
    for r in rows:
        lines.append(f"| {r['name']} | {r['m']:,} | {r['q']:,} | {r['mode']} | {r['fb']:.3f} | {r['fq']:.3f} "
                     f"| {r['ft']:.3f} | {r['cb']:.3f} | {r['cq']:.3f} | {r['ct']:.3f} | {r['ratio']:.3f} "
                     f"| {r['fcpu']:.3f} | {r['ccpu']:.3f} | {r['ratio_cpu']:.3f} "
                     f"| {r['fsort']:.3f} | {r['fsort'] / r['ct']:.3f} "
                     f"| {r['hits_fm']:,} | {r['hits_cg']:,} | {'yes' if r['same'] else 'NO'} |")
    write_table("\n".join(lines) + "\n", "aabb", args)
    return 0 if all(r["same"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
