"""Benchmark faultmesh.ensemble on Dask: throughput, overhead, client memory.

    python bench/bench_ensemble.py [--runs 5] [--n 40] [--quick] [--no-write]

On the built-in paper-like dataset (faultmesh.datasets.paper_like_path(),
100 x 100 grid, its 9 sections), with every perturbation source on:

* realizations per minute through a local Dask cluster of 1 and of 2 worker
  processes (one thread each), medians over --runs ensembles of --n
  realizations, the runs of the two clusters alternating (both clusters stay
  up, warmed by a small ensemble first); and in this process without Dask
  (workers=0) for reference;
* the per-realization overhead (scheduling, transfer, reduction): wall time
  per realization per worker (wall x K / n) minus the median perturb +
  build + sample time measured on the worker, against that time;
* peak memory of the client process for several n (--memory-n, default 50,
  200 and 400) on a 2-worker cluster, each in a fresh subprocess: tracemalloc's peak
  of the ensemble() call (Python and numpy allocations of the client: the
  statistics, the samples waiting to be reduced) and the process's VmHWM
  (the LocalCluster's scheduler runs in the client process and is counted).

The machine is shared: wall-clock numbers include other load; the worker
CPU times (thread CPU time of each realization) are given beside them.
The markdown table goes to stdout and docs/bench/ensemble.md (not with
--quick or --no-write).
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
import tracemalloc

from _common import (ROOT, machine, proc_status_mib, table_header, use_dev_build)

use_dev_build()
import faultmesh  # noqa: E402
from faultmesh.ensemble import Perturbation  # noqa: E402

PERT = Perturbation(sigma_z=2.0, sigma_position=10.0, sigma_position_trace=3.0, sigma_dip=4.0,
                    sigma_throw=0.15)


def _dataset():
    return faultmesh.load_dataset(faultmesh.datasets.paper_like_path())


def memory_child(n: int, grid: int) -> None:
    """Run one ensemble of n on a fresh 2-worker local cluster; print JSON."""
    ds = _dataset()
    base_rss = proc_status_mib("VmRSS")
    tracemalloc.start()
    t0 = time.perf_counter()
    res = faultmesh.ensemble(ds, n, PERT, workers=2, grid=grid, seed=1)
    wall = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    print(json.dumps({"n": n, "succeeded": res.succeeded, "wall": wall,
                      "tracemalloc_peak_mib": peak / 2 ** 20,
                      "statistics_mib": res.reducer.nbytes / 2 ** 20,
                      "vmhwm_mib": proc_status_mib("VmHWM"), "rss_before_mib": base_rss}))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=5, help="ensembles per cluster size (median)")
    ap.add_argument("--n", type=int, default=40, help="realizations per timed ensemble")
    ap.add_argument("--grid", type=int, default=100, help="grid nodes along the longer side")
    ap.add_argument("--memory-n", type=int, nargs="+", default=[50, 200, 400], metavar="N",
                    help="n of the client-memory runs (default 50 200 400: below and above "
                         "the quantile estimator's 64-sample start-up)")
    ap.add_argument("--quick", action="store_true",
                    help="small: n=8, 1 run, 40-node grid, memory for n=10 and 80; no docs")
    ap.add_argument("--no-write", action="store_true", help="do not write docs/bench/ensemble.md")
    ap.add_argument("--memory-child", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.memory_child:
        memory_child(args.memory_child, args.grid)
        return 0
    if args.quick:
        args.n, args.grid, args.memory_n = 8, 40, [10, 80]
        if "--runs" not in sys.argv:
            args.runs = 1
    if args.runs < 1 or args.n < 1:
        ap.error("--runs and --n must be >= 1")

    import os

    from distributed import Client, LocalCluster

    load0 = os.getloadavg()
    ds = _dataset()
    kw = dict(grid=args.grid, seed=0)
    clusters = {}
    for k in (1, 2):
        cl = LocalCluster(n_workers=k, threads_per_worker=1, processes=True, dashboard_address=":0")
        clusters[k] = (cl, Client(cl))
        faultmesh.ensemble(ds, 2 * k, PERT, client=clusters[k][1], **kw)     # warm-up
    runs = {0: [], 1: [], 2: []}
    checks = {}
    try:
        for r in range(args.runs):
            for k in (1, 2):
                t0 = time.perf_counter()
                res = faultmesh.ensemble(ds, args.n, PERT, client=clusters[k][1], **kw)
                runs[k].append((time.perf_counter() - t0, res.timings, res.succeeded))
                checks.setdefault(k, res.grid("mean"))
                print(f"run {r + 1} K={k}: {runs[k][-1][0]:.1f} s, {res.succeeded}/{args.n} ok",
                      file=sys.stderr, flush=True)
        same = bool(((checks[1] == checks[2]) | (checks[1] != checks[1])).all())
    finally:
        for cl, c in clusters.values():
            c.close()
            cl.close()
    n_in = max(4, args.n // 4)
    for r in range(max(1, args.runs // 2)):
        t0 = time.perf_counter()
        res = faultmesh.ensemble(ds, n_in, PERT, workers=0, **kw)
        runs[0].append((time.perf_counter() - t0, res.timings, res.succeeded))
    mem = []
    for n in args.memory_n:
        out = subprocess.run([sys.executable, __file__, "--memory-child", str(n), "--grid",
                              str(args.grid)], capture_output=True, text=True, cwd=ROOT)
        if out.returncode != 0:
            print(out.stderr, file=sys.stderr)
            return 1
        mem.append(json.loads(out.stdout.strip().splitlines()[-1]))
        print(f"memory n={n}: {mem[-1]}", file=sys.stderr, flush=True)

    def med(xs):
        return statistics.median(xs)

    rows = []
    rate = {}
    for k in (0, 1, 2):
        nn = n_in if k == 0 else args.n
        walls = [w for w, _, _ in runs[k]]
        per = med(walls) / nn
        rate[k] = 60.0 / per
        work = med([t["build_seconds_median"] + t["sample_seconds_median"] for _, t, _ in runs[k]])
        build = med([t["build_seconds_median"] for _, t, _ in runs[k]])
        cpu = med([t["worker_cpu_seconds_median"] for _, t, _ in runs[k]])
        red = med([t["reduce_seconds"] for _, t, _ in runs[k]]) / nn
        slot = per * max(k, 1)                 # wall per realization per worker
        over = slot - work
        rows.append((k, nn, len(walls), rate[k], work, build, cpu, red, over, over / work))
    lines = table_header("Ensembles on Dask: throughput, overhead, client memory", "bench_ensemble.py",
                         machine(numpy=True) + ", dask " + __import__("dask").__version__)
    lines += [
        f"Runs: median of {args.runs} ensembles of {args.n} realizations per cluster size, the two "
        "clusters alternating; in-process reference: "
        f"{len(runs[0])} ensembles of {n_in}.",
        f"Data: built-in paper-like dataset (4 layers, 4 faults), grid {args.grid} nodes along the "
        f"longer side, 9 sections x 200 samples; perturbation {PERT.to_dict()}.",
        "",
        "K = local Dask worker processes (1 thread each; 0 = in this process, no Dask). work = "
        "median perturb + build + sample time of a realization measured on the worker (wall "
        "clock); CPU = its thread CPU time. overhead = wall time per realization per worker "
        "(wall x K / n) - work: scheduling, transfer, the client's reduction and, on a shared "
        "machine, waiting for a core.",
        "",
        "| K | n | runs | realizations / min | work s | of which build s | worker CPU s | client "
        "reduce s / realization | overhead s / realization | overhead / work |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for k, nn, nr, rt, work, build, cpu, red, over, rel in rows:
        lines.append(f"| {k} | {nn} | {nr} | {rt:.0f} | {work:.3f} | {build:.3f} | {cpu:.3f} | "
                     f"{red:.4f} | {over:+.3f} | {100 * rel:+.0f} % |")
    load1 = os.getloadavg()
    lines += ["", f"Speed-up of 2 workers over 1: **{rate[2] / rate[1]:.2f}x** (target 1.7x). "
              f"Statistics of the 1- and 2-worker runs bit-identical: {'yes' if same else 'NO'}. "
              f"Load average (1 min) at the start and the end of the timed runs: {load0[0]:.1f}, "
              f"{load1[0]:.1f} on {os.cpu_count()} cores (other jobs' processes wanting a core "
              "make the workers wait: compare the work wall time with the worker CPU time).",
              "", "Client memory (fresh process, 2-worker local cluster, same grid). The "
              "quantile estimator keeps the first 64 samples of every node (exact quantiles) "
              "and frees them once every node has 64; its markers are sorted out of them at the "
              "64th realization, the moment of the peak for n >= 64:", "",
              "| n | succeeded | wall s | tracemalloc peak MiB | statistics MiB | VmHWM MiB | RSS "
              "before MiB |", "|---:|---:|---:|---:|---:|---:|---:|"]
    for m in mem:
        lines.append(f"| {m['n']} | {m['succeeded']} | {m['wall']:.1f} | "
                     f"{m['tracemalloc_peak_mib']:.1f} | {m['statistics_mib']:.1f} | "
                     f"{m['vmhwm_mib']:.0f} | {m['rss_before_mib']:.0f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.quick and not args.no_write:
        out = ROOT / "docs" / "bench" / "ensemble.md"
        out.write_text(text)
        print(f"wrote {out.relative_to(ROOT)}", file=sys.stderr)
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
