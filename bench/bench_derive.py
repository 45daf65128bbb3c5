"""Fault derivation benchmark: ``derive.derive_faults`` against the build of
the model it derives, on the random grounds with the densest fault points and
on the Claudius seismic data.

    python bench/bench_derive.py [--seeds 69 79 91 36] [--runs 3] [--no-claudius]
                                 [--no-write] [--only NAME ...]

Each dataset is the format-2 ground of ``faultmesh.grounds`` (fault sticks on
the truth's surface, drillhole tables, the section picks: what the v2 sweep
derives; ``write_v2(..., section_picks=True)``) or Claudius
(``examples/claudius``: 21k horizon picks and 93 fault points, everything
derived), made once. What is measured, in this one process, medians over
``--runs`` runs, the two sides interleaved:

* ``derive``: ``derive.derive_faults(dataset)`` (fault surfaces, side split,
  side surfaces, sections, cutoffs, throw, tips, kind);
* ``build``: ``build_model(derived, evaluate=False)`` of its result (stratum
  TINs, repair, fault models, stitching: the kernels' work on the same
  ground; the reference);
* ratio: derive / build, the cost of getting the faults in, in units of
  building the model from them.

Writes docs/bench/derive.md (not with --no-write or --only).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Callable, List, Tuple

from _common import ROOT, add_table_args, machine, parse_table_args, pick, table_header, write_table, use_dev_build

use_dev_build()
import faultmesh  # noqa: E402
from faultmesh import derive  # noqa: E402
from faultmesh.dataset import load_dataset  # noqa: E402

DEFAULT_SEEDS = [69, 79, 91, 36]  # seeds 0-99 whose derivation took longest (fault points 1.6-5.3k)


def ground_v2(seed: int, folder: Path):
    import faultmesh.grounds as g

    spec, geo, path1 = g.make_ground(seed, folder)
    ds1 = load_dataset(path1)
    return load_dataset(g.write_v2(ds1, geo, spec, folder / "v2", section_picks=True))


def claudius(folder: Path):
    sys.path.insert(0, str(ROOT / "examples" / "claudius"))
    import make_dataset  # examples/claudius/make_dataset.py

    data = ROOT / "tests" / "data" / "claudius"
    return make_dataset.make_dataset(make_dataset.read_horizons(data), make_dataset.read_fault_points(data))


def counts(ds) -> Tuple[int, int]:
    n_fault = sum(len(f.points) if f.points is not None else 0 for f in ds.faults)
    n_layer = sum(len(p) for p in ds.all_layer_points().values())
    return n_fault, n_layer


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=DEFAULT_SEEDS)
    ap.add_argument("--no-claudius", action="store_true")
    add_table_args(ap, "derive")
    ap.set_defaults(runs=3)
    args = parse_table_args(ap)
    warnings.simplefilter("ignore")
    makers: List[Tuple[str, Callable]] = [(f"ground {s}", (lambda f, s=s: ground_v2(s, f)))
                                          for s in args.seeds]
    if not args.no_claudius:
        makers.append(("claudius", claudius))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, make in pick(makers, args.only):
            ds = make(Path(tmp) / name.replace(" ", "_"))
            n_fault, n_layer = counts(ds)
            t_derive, t_build = [], []
            for _ in range(args.runs):
                t0 = time.perf_counter()
                d = derive.derive_faults(ds)
                t_derive.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                faultmesh.build_model(d, evaluate=False)
                t_build.append(time.perf_counter() - t0)
            md, mb = statistics.median(t_derive), statistics.median(t_build)
            rows.append((name, len(ds.faults), n_fault, n_layer, md, mb, md / mb))
            print(f"{name}: derive {md:.2f} s, build {mb:.2f} s, ratio {md / mb:.1f}", file=sys.stderr)
    lines = table_header("Fault derivation against the build of its model", "bench_derive.py",
                         machine(numpy=True))
    lines += ["", f"Medians over {args.runs} runs in one process, derive and build interleaved; "
              "ratio = derive / build (the build of the derived dataset: the reference run).", "",
              "| dataset | faults | fault points | layer data | derive (s) | build (s) | derive / build |",
              "|---|---:|---:|---:|---:|---:|---:|"]
    lines += [f"| {n} | {nf} | {pf} | {pl} | {d:.2f} | {b:.2f} | {r:.1f} |" for n, nf, pf, pl, d, b, r in rows]
    write_table("\n".join(lines) + "\n", "derive", args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
