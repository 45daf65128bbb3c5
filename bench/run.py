"""Run the faultmesh benchmarks in sequence, then assemble docs/benchmarks.md.

    python bench/run.py [NAME ...] [--runs N] [--quick] [--build-dir DIR] [--dry-run]

NAME: any of delaunay, polygon, aabb, boundary, compare, scale, model, ensemble,
derive, sweep (default: all, in that order). Each benchmark is its own script (bench/bench_<name>.py,
bench/compare.py), run here as a subprocess with the same Python and
environment (set FAULTMESH_DEV_BUILD=$PWD/build/<dir> to bench a development
build); see bench/README.md for what each one measures.

Full runs (the default) write their tables to docs/bench/<name>.md; then
bench/collect_docs.py concatenates those into docs/benchmarks.md.

--quick: small inputs and one run per side unless --runs is given -- a check
that the harness works, not numbers to publish. Quick runs leave docs/bench/
alone (tables go to stdout, or to bench/results/quick/ for the scripts that
always write files); docs/benchmarks.md is still re-assembled from the tables
that are there.

--build-dir DIR: where the C++ programs are built (the Delaunay driver in
DIR, the CGAL programs in DIR/cgal); default: each script's own default.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Dict, List, Tuple

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "bench"
QUICK_OUT = BENCH / "results" / "quick"

# name -> (script, its option for the number of runs, extra arguments of a
# full run, extra arguments of a quick run). In the default order.
BENCHMARKS: Dict[str, Tuple[str, str, List[str], List[str]]] = {
    # faultmesh::delaunay (C++ driver) vs CGAL Delaunay_triangulation_2.
    "delaunay": ("bench_delaunay.py", "--runs", [],
                 ["--no-write", "--only", "uniform 10k", "uniform 100k", "Claudius"]),
    # triangulate_polygon vs mapbox_earcut, triangle and CGAL's CDT.
    "polygon": ("bench_polygon.py", "--runs", [],
                ["--sizes", "1000", "10000", "--no-fixtures", "--out", str(QUICK_OUT / "polygon.md")]),
    # AabbTree build + box queries vs CGAL AABB_tree / box_intersection_d.
    "aabb": ("bench_aabb.py", "--runs", [], ["--no-write", "--only", "Claudius"]),
    # boundary_contours vs delaunay of the same points (quick: the 1M-point grid only).
    "boundary": ("bench_boundary.py", "--runs", [], ["--no-write", "--only", "grid"]),
    # Paper Tables 1 and 2: faultmesh's two orders vs CGAL's CDT vs surface cutting.
    "compare": ("compare.py", "--repeat", ["--docs"], ["--out", str(QUICK_OUT / "compare")]),
    # 200 faults stitched into a 1M-point layer, and the locality check.
    "scale": ("bench_scale.py", "--repeat", ["--locality", "--docs"],
              ["--points", "100000", "--faults", "20", "--out", str(QUICK_OUT / "scale")]),
    # build_model against the Delaunay triangulations of its layers' points
    # (5 layers x 100k points: target ratio 2; 10 x 1M x 200 faults: pass
    # --sizes to bench_model.py directly, its dataset takes long to generate).
    "model": ("bench_model.py", "--repeat", ["--docs", "--sizes", "3x10000x3", "5x100000x3",
                                             "5x100000x30"], ["--quick"]),
    # faultmesh.ensemble on local Dask clusters of 1 and 2 workers: throughput,
    # overhead per realization, client memory for two n.
    "ensemble": ("bench_ensemble.py", "--runs", [], ["--quick"]),
    # derive_faults against the build of the model it derives (dense fault
    # points of the random grounds, Claudius; quick: ground 0 alone).
    "derive": ("bench_derive.py", "--runs", [], ["--seeds", "0", "--no-claudius", "--no-write"]),
    # Random grounds: >= 500 seeds built and checked, failures classified
    # (--runs does not apply: each seed runs once; --quick: 8 seeds).
    "sweep": ("sweep.py", "", [], ["--quick"]),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("names", nargs="*", metavar="NAME",
                    help=f"benchmarks: {', '.join(BENCHMARKS)} (default: all)")
    ap.add_argument("--runs", type=int, default=None,
                    help="runs (repeats) per side, passed to every script (default: 5, 1 with --quick)")
    ap.add_argument("--quick", action="store_true", help="small inputs; does not touch docs/bench/")
    ap.add_argument("--build-dir", type=Path, default=None, help="build folder for the C++ programs")
    ap.add_argument("--dry-run", action="store_true", help="print the commands only")
    args = ap.parse_args(argv)
    unknown = [n for n in args.names if n not in BENCHMARKS]
    if unknown:
        ap.error(f"unknown benchmark(s) {', '.join(unknown)}; choose from {', '.join(BENCHMARKS)}")
    if args.runs is not None and args.runs < 1:
        ap.error("--runs must be >= 1")
    runs = args.runs if args.runs is not None else (1 if args.quick else None)
    names = args.names or list(BENCHMARKS)

    env = dict(os.environ)
    build = {}
    if args.build_dir is not None:
        bd = args.build_dir.resolve()
        env["FAULTMESH_CGAL_BUILD"] = str(bd / "cgal")  # polygon, compare
        build = {"delaunay": ["--build-dir", str(bd)], "aabb": ["--build-dir", str(bd / "cgal")]}
    if args.quick and not args.dry_run:
        QUICK_OUT.mkdir(parents=True, exist_ok=True)

    failed = []
    for name in names:
        script, runs_flag, full, quick = BENCHMARKS[name]
        cmd = [sys.executable, str(BENCH / script),
               *([runs_flag, str(runs)] if runs is not None and runs_flag else []),
               *(quick if args.quick else full), *build.get(name, [])]
        print(f"== {name}: {' '.join(cmd[1:])}", file=sys.stderr, flush=True)
        if args.dry_run:
            continue
        t0 = time.perf_counter()
        rc = subprocess.run(cmd, cwd=ROOT, env=env).returncode
        print(f"== {name}: exit {rc} after {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
        if rc != 0:
            failed.append(name)

    cmd = [sys.executable, str(BENCH / "collect_docs.py")]
    print(f"== collect: {' '.join(cmd[1:])}", file=sys.stderr, flush=True)
    if not args.dry_run and subprocess.run(cmd, cwd=ROOT, env=env).returncode != 0:
        failed.append("collect_docs")
    if failed:
        print(f"failed (non-zero exit: a check or a run failed): {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
