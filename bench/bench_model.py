"""Whole-model benchmark: ``build_model`` against the Delaunay triangulations
of its layers' points, at several sizes (issue 12, item 7).

    python bench/bench_model.py [--sizes 5x100000x3 10x1000000x200 ...] [--repeat 3]
                                [--docs] [--out DIR] [--quick]

A size ``LxNxF`` is ``datasets.synthetic(seed, n_layers=L, n_boreholes=N,
n_faults=F, ...)``: L layers whose data are the N borehole tops of each layer
(one per hole and layer), F parallel faults across a square study area whose
side grows with N (a data spacing of about 25 m), and further where F faults
would not fit across it (``make_dataset``). What is measured, in this
one process, medians over ``--repeat`` runs, the runs of the two sides
interleaved:

* ``delaunay``: ``faultmesh.delaunay`` of each layer's XY, summed over the layers
  (the reference: what the layers' TINs cost at the least);
* ``build``: ``faultmesh.build_model(dataset, evaluate=False)`` -- stratum
  TINs, crossing repair, fault models, stitching -- and its own step timings
  (``model.metadata["timings"]``, median per step);
* ratio: build / delaunay (targets: <= 2 for 5 layers x 100k points, <= 3 at
  10 layers x 1M points);
* peak memory: the process's peak resident set (VmHWM) during the builds
  (reset before them through /proc/self/clear_refs), and the resident set
  before them (the dataset in memory);
* the time to generate the dataset (``datasets.synthetic``), once.
"""
from __future__ import annotations

import argparse
import gc
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Dict, List, Tuple

from _common import ROOT, machine as _machine, proc_status_mib, reset_peak_rss, today, use_dev_build

use_dev_build()
import faultmesh  # noqa: E402

DEFAULT_SIZES = ["3x10000x3", "5x100000x3", "5x100000x30", "10x1000000x200"]
QUICK_SIZES = ["3x10000x3", "5x20000x3"]
SPACING = 25.0  # mean data spacing (m) of the generated layers


def parse_size(s: str) -> Tuple[int, int, int]:
    try:
        L, N, F = (int(v) for v in s.lower().split("x"))
    except ValueError:
        raise SystemExit(f"bench_model: a size is LAYERSxPOINTSxFAULTS, e.g. 5x100000x3, got {s!r}")
    return L, N, F


def make_dataset(L: int, N: int, F: int, seed: int = 0):
    side = float(max(2000.0, SPACING * N ** 0.5))
    # F parallel faults displacing L layers need room across strike (about
    # 350 m each at 10 layers, dip 60): where they do not fit, the square
    # grows by 25 % steps (the data spacing with it; 10 x 1M x 200: 25 km ->
    # about 76 km). Sizes that fit keep the 25 m spacing.
    while True:
        try:
            return faultmesh.datasets.synthetic(seed, n_layers=L, n_faults=F, n_boreholes=N,
                                                area=(side, side))
        except ValueError as e:
            if "do not fit" not in str(e) or side > 1e6:
                raise
            side *= 1.25


def run(size: str, repeat: int, seed: int = 0) -> Dict[str, object]:
    L, N, F = parse_size(size)
    t0 = time.perf_counter()
    ds = make_dataset(L, N, F, seed)
    gen_s = time.perf_counter() - t0
    pts = [ds.layer_points(lay)[:, :2].copy() for lay in ds.layers]
    gc.collect()
    rss_before = proc_status_mib("VmRSS")
    reset_peak_rss()
    threads = faultmesh.build._threads(None, L)
    dl, bl, b1, steps = [], [], [], []
    model = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        for p in pts:
            faultmesh.delaunay(p)
        dl.append(time.perf_counter() - t0)
        for th, runs in ((1, b1), (None, bl)):
            if th is None and threads == 1:
                continue
            del model
            gc.collect()
            t0 = time.perf_counter()
            model = faultmesh.build_model(ds, evaluate=False, threads=th)
            runs.append(time.perf_counter() - t0)
            if th is None or threads == 1:
                steps.append(dict(model.metadata["timings"]))
    if threads == 1:
        bl = b1
    peak = proc_status_mib("VmHWM")
    step_names = [k for k in steps[0] if k != "total"]
    d, b, one = statistics.median(dl), statistics.median(bl), statistics.median(b1)
    return {"size": size, "layers": L, "points_per_layer": N, "faults": F,
            "data_points": int(sum(len(p) for p in pts)),
            "triangles": int(sum(s.n_triangles for s in model.surfaces.values())),
            "gaps": len(model.gaps), "generate_s": gen_s, "delaunay_s": d, "build_s": b,
            "ratio": b / d, "threads": threads, "build_1_thread_s": one, "ratio_1_thread": one / d,
            "delaunay_runs": dl, "build_runs": bl, "build_1_thread_runs": b1,
            "steps_s": {k: statistics.median(s[k] for s in steps) for k in step_names},
            "rss_before_mib": rss_before, "peak_rss_mib": peak}


def markdown(results: List[Dict[str, object]], command: str) -> str:
    lines = ["## Whole model: build_model against its layers' Delaunay", "",
             f"Machine: {_machine(numpy=True)}. Command: `{command}`. Date: {today()}.", "",
             "Medians of the runs, both sides in one process, interleaved. *delaunay*: "
             "`faultmesh.delaunay` of every layer's points (summed). *build*: "
             "`build_model(dataset, evaluate=False)` with its default threads (the CPUs the "
             "process may use, at most one per layer) and with `threads=1`; the step timings are "
             "those of the default. Targets: ratio <= 2 at 5 x 100k, <= 3 at 10 x 1M; peak "
             "memory <= 8 GiB.", "",
             "| layers x points x faults | gaps | delaunay s | build s (threads) | **ratio** | "
             "build s, 1 thread | ratio, 1 thread | TINs + repair s | "
             "fault models s | stitching s | peak MiB (before) | generate s |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in results:
        st = r["steps_s"]
        lines.append(
            f"| {r['layers']} x {r['points_per_layer']:,} x {r['faults']} | {r['gaps']} | "
            f"{r['delaunay_s']:.3f} | {r['build_s']:.3f} ({r['threads']}) | **{r['ratio']:.2f}** | "
            f"{r['build_1_thread_s']:.3f} | {r['ratio_1_thread']:.2f} | "
            f"{st.get('stratum_tins_and_repair', float('nan')):.3f} | {st.get('fault_models', float('nan')):.3f} | "
            f"{st.get('stitching', float('nan')):.3f} | {r['peak_rss_mib']:.0f} ({r['rss_before_mib']:.0f}) | "
            f"{r['generate_s']:.1f} |")
    lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", nargs="+", default=None, help="LAYERSxPOINTSxFAULTS ...")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="small sizes, one run (a harness check)")
    ap.add_argument("--out", type=Path, default=ROOT / "bench" / "results" / "model")
    ap.add_argument("--docs", action="store_true", help="write docs/bench/model.md")
    args = ap.parse_args(argv)
    sizes = args.sizes or (QUICK_SIZES if args.quick else DEFAULT_SIZES)
    repeat = 1 if args.quick and args.repeat == 3 else args.repeat
    command = "python bench/bench_model.py " + " ".join(argv if argv is not None else sys.argv[1:])
    results = []
    for s in sizes:
        r = run(s, repeat, args.seed)
        print(f"{s}: delaunay {r['delaunay_s']:.3f} s, build {r['build_s']:.3f} s ({r['threads']} threads), "
              f"ratio {r['ratio']:.2f}; 1 thread {r['build_1_thread_s']:.3f} s, ratio {r['ratio_1_thread']:.2f}, "
              f"peak {r['peak_rss_mib']:.0f} MiB", flush=True)
        results.append(r)
    md = markdown(results, command)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "model.md").write_text(md)
    doc = json.dumps({"machine": _machine(), "command": command, "date": today(), "results": results}, indent=2)
    (args.out / "model.json").write_text(doc)
    if args.docs and not args.quick:
        (ROOT / "docs" / "bench").mkdir(parents=True, exist_ok=True)
        (ROOT / "docs" / "bench" / "model.md").write_text(md)
        (ROOT / "docs" / "bench" / "model.json").write_text(doc)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
