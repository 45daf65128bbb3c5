"""How often faultmesh holds on grounds it was not written for.

    python bench/sweep.py [--seeds N] [--start S] [--jobs J] [--timeout SEC] [--quick]
                          [--out DIR] [--no-write] [--v2 [--holes-only]]

Runs ``faultmesh.grounds.evaluate_ground`` for seeds S .. S+N-1 (default 0 ..
499): each seed draws a random ground (study area, layers, faults, sections,
boreholes, rounding; see faultmesh/grounds.py), writes and reads its dataset,
builds the model, checks it, and measures it (error near the faults vs the
plain TIN, repetition of layers across reverse faults). Every seed runs in its
own forked process with a time limit (--timeout, default 300 s) and a memory
limit (--memory-gb, default 3), so a hang or a crash is recorded as such and
never stops the sweep; --jobs processes run at once (default 2).

Writes docs/bench/sweep.md (the table: shares, failure classes with counts and
three example seeds each, the same shares split by kind, median times) and
docs/bench/sweep.json (every seed's spec and outcome). --render JSON renders
the table again from a sweep.json without running anything. --quick: 8 seeds, the
table to stdout and bench/results/quick/sweep.{md,json}; --no-write: stdout
only. Progress (one line per seed) goes to stderr; the per-seed outcomes are
also appended to <out>/sweep.jsonl as they come, so an interrupted sweep
leaves what it did.

--v2 runs ``faultmesh.grounds.evaluate_ground_v2`` instead: each ground also
written as format 2 without cutoffs (fault sticks, drillhole tables with
deviated holes), its faults derived, built and checked, the derived cutoffs
and the error near the faults compared with the v1 model of the true
cutoffs; writes sweep_v2.md / sweep_v2.json (the v1 sweep's files are not
touched). The v2 dataset carries the v1 dataset's layer data without its
cutoffs: the same holes, and the v1 traces' layer polylines beyond a fault
shadow as layer points (``grounds.trace_picks``). --holes-only leaves those
points out (the layer data only from the holes, none within 20-180 m of the
faults where the v1 traces give them): sweep_v2_holes.md / .json.
"""
from __future__ import annotations

import argparse
import collections
import json
import multiprocessing as mp
import os
import re
import statistics
import sys
import time
from pathlib import Path
from typing import Any, Dict, List, Optional

from _common import ROOT, command_line, machine, today, use_dev_build

use_dev_build()

QUICK_OUT = ROOT / "bench" / "results" / "quick"


#: How a sweep writes each v2 ground: the keyword arguments of
#: grounds.evaluate_ground_v2 it sets (their defaults), kept in a sweep's
#: meta under the same names.
GROUND_OPTIONS = {"fault_form": "sticks", "fault_noise": 0.0, "groups": True, "throw_hints": False}


def _ground_options(source: Dict[str, Any]) -> Dict[str, Any]:
    """The ground options (GROUND_OPTIONS) given in ``source`` (a sweep's
    meta, or the parsed arguments as a dict), defaults for the rest."""
    return {k: source.get(k, v) for k, v in GROUND_OPTIONS.items()}


def _child(seed: int, conn, mem_gb: float, tb_path: str, tb_after: float, v2=False,
           ground: Optional[Dict[str, Any]] = None) -> None:
    try:
        import resource
        lim = int(mem_gb * 2 ** 30)
        resource.setrlimit(resource.RLIMIT_AS, (lim, lim))
    except (ImportError, ValueError, OSError):  # pragma: no cover - not on Linux
        pass
    # Where a seed hangs: the stack shortly before the parent kills it.
    import faulthandler
    tb_file = open(tb_path, "w")
    faulthandler.dump_traceback_later(tb_after, exit=False, file=tb_file)
    import warnings
    warnings.simplefilter("ignore")
    from faultmesh.grounds import evaluate_ground, evaluate_ground_v2
    try:
        out = (evaluate_ground_v2(seed, section_picks=(v2 != "holes"), **(ground or {}))
               if v2 else evaluate_ground(seed))
    except BaseException as e:  # evaluate_ground records failures; this is its own defect
        out = {"seed": seed, "ok": False, "stage": "crash", "error_type": type(e).__name__,
               "error": str(e)[:2000], "pattern": str(e)[:160]}
    conn.send(json.dumps(out, default=float))
    conn.close()


def run_seeds(seeds: List[int], jobs: int, timeout: float, mem_gb: float, jsonl: Path = None,
              v2=False, ground: Optional[Dict[str, Any]] = None) -> List[Dict]:
    """Outcomes of the seeds, each in its own forked process (``v2``: False,
    True, or "holes" for v2 grounds without the trace picks; ``ground``: how
    the v2 grounds are written, GROUND_OPTIONS: ``fault_form``, how they
    give their faults, ``grounds.FAULT_FORMS``; ``fault_noise``, their
    picking error, m; ``groups`` False, the faults without their groups,
    which the derivation must find; ``throw_hints``, each fault with its
    largest true throw as a hint)."""
    import tempfile
    ctx = mp.get_context("fork")
    tb_dir = tempfile.mkdtemp(prefix="sweep-tb-")
    pending = list(seeds)
    running: Dict[int, tuple] = {}
    results: Dict[int, Dict] = {}
    fh = open(jsonl, "w") if jsonl else None
    t_start = time.perf_counter()
    try:
        while pending or running:
            while pending and len(running) < jobs:
                s = pending.pop(0)
                r, w = ctx.Pipe(duplex=False)
                tb = os.path.join(tb_dir, f"seed{s}.txt")
                p = ctx.Process(target=_child, args=(s, w, mem_gb, tb, 0.95 * timeout, v2, ground),
                               daemon=True)
                p.start()
                w.close()
                running[s] = (p, r, time.perf_counter())
            time.sleep(0.05)
            for s in list(running):
                p, r, t0 = running[s]
                out = None
                if r.poll():
                    try:
                        out = json.loads(r.recv())
                    except EOFError:
                        out = None
                    p.join(5.0)
                elif not p.is_alive():
                    p.join()
                    out = {"seed": s, "ok": False, "stage": "crash", "error_type": f"exit {p.exitcode}",
                           "error": f"the process ended with exit code {p.exitcode} (a negative code is "
                                    "the signal: -11 segmentation fault, -9 killed)",
                           "pattern": f"process ended with exit code {p.exitcode}"}
                elif time.perf_counter() - t0 > timeout:
                    p.kill()
                    p.join()
                    where = _hang_site(os.path.join(tb_dir, f"seed{s}.txt"))
                    out = {"seed": s, "ok": False, "stage": "timeout", "error_type": "",
                           "error": f"no result after {timeout:.0f} s; stack: {where}",
                           "pattern": f"no result after {timeout:.0f} s, in {where.split(' <- ')[0]}"}
                else:
                    continue
                if out is None:
                    out = {"seed": s, "ok": False, "stage": "crash", "error_type": "",
                           "error": "no result", "pattern": "no result"}
                out["wall_seconds"] = time.perf_counter() - t0
                r.close()
                del running[s]
                results[s] = out
                if fh:
                    fh.write(json.dumps(out, default=float) + "\n")
                    fh.flush()
                done = len(results)
                el = time.perf_counter() - t_start
                print(f"[{done}/{len(seeds)} {el:.0f}s] seed {s}: {out.get('stage')} "
                      f"{(out.get('pattern') or '')[:90]}", file=sys.stderr, flush=True)
    finally:
        for p, r, _ in running.values():
            p.kill()
        if fh:
            fh.close()
    return [results[s] for s in seeds]


def _hang_site(path: str) -> str:
    """The innermost faultmesh frames of a faulthandler dump: "func
    (file:line) <- caller (file:line) <- ..." (up to 4)."""
    try:
        lines = open(path).read().splitlines()
    except OSError:
        return "?"
    frames = []
    for ln in lines:
        m = re.match(r'\s*File "([^"]+)", line (\d+) in (\S+)', ln)
        if m and "faultmesh" in m.group(1) and not m.group(3).startswith("<"):
            frames.append(f"{m.group(3)} ({os.path.basename(m.group(1))}:{m.group(2)})")
    return " <- ".join(frames[:6]) if frames else "?"


# ----------------------------------------------------------------- the table
def _pct(k: int, n: int) -> str:
    return f"{k} / {n} ({100.0 * k / n:.1f} %)" if n else "-"


def _flags(o: Dict) -> Dict[str, Any]:
    spec = o.get("spec") or {}
    reject = spec.get("expect") == "reject"
    cov = o.get("coverage_min")
    return {"reject": reject, "loaded": o.get("stage") not in ("generate", "load", "timeout", "crash") or
            o.get("stage") == "rejected",
            "built": bool(o.get("built")), "checked": bool(o.get("checked")),
            "beats": bool((o.get("accuracy") or {}).get("beats")),
            "has_rev": cov is not None, "repeats": cov is not None and cov >= o.get("threshold", 0.95),
            "ok": bool(o.get("ok")), "rejected": bool(o.get("rejected_ok"))}


def summary_rows(outs: List[Dict]) -> List[tuple]:
    """(label, text) rows of the overall shares."""
    F = [_flags(o) for o in outs]
    build = [f for f in F if not f["reject"]]
    rej = [f for f in F if f["reject"]]
    nb = len(build)
    rev = [f for f in build if f["checked"] and f["has_rev"]]
    rows = [("seeds", str(len(outs))),
            ("**pass** (built, check() passed, beats the TIN, repeats reverse-fault layers; "
             "or, for a too-close pair, rejected naming it)", _pct(sum(f["ok"] for f in F), len(F))),
            ("datasets that must build", str(nb)),
            ("- loaded", _pct(sum(f["loaded"] for f in build), nb)),
            ("- built", _pct(sum(f["built"] for f in build), nb)),
            ("- built and `check()` passed", _pct(sum(f["checked"] for f in build), nb)),
            ("- beats the plain TIN near the faults (mean \\|dz\\|)",
             _pct(sum(f["beats"] and f["checked"] for f in build), nb)),
            ("- with reverse-fault bands in the data: repeats them (share_data >= 95 %)",
             _pct(sum(f["repeats"] for f in rev), len(rev))),
            ("- all of the above", _pct(sum(f["ok"] for f in build), nb)),
            ("datasets that must be rejected (two faults of different groups, zones overlapping)", str(len(rej))),
            ("- rejected with a DatasetError naming both", _pct(sum(f["rejected"] for f in rej), len(rej))),
            ("- built instead (the overlap missed the data's patches), checked and better than the TIN",
             _pct(sum(f["ok"] and not f["rejected"] for f in rej), len(rej))),
            ("- either", _pct(sum(f["ok"] for f in rej), len(rej)))]
    return rows


def failure_classes(outs: List[Dict]):
    cls: Dict[tuple, List[Dict]] = collections.defaultdict(list)
    for o in outs:
        if o.get("ok"):
            continue
        key = (o.get("stage") or "?", o.get("error_type") or "", o.get("pattern") or "")
        cls[key].append(o)
    return sorted(cls.items(), key=lambda kv: (-len(kv[1]), kv[0]))


def split_rows(outs: List[Dict]) -> Dict[str, List[tuple]]:
    from faultmesh.grounds import KINDS
    by: Dict[str, Dict[str, List[Dict]]] = {k: collections.defaultdict(list) for k in KINDS}
    for o in outs:
        for cat, vals in (o.get("tags") or {}).items():
            for v in vals:
                if cat in by:
                    by[cat][v].append(o)
    out = {}
    for cat, values in KINDS.items():
        rows = []
        for v in values:
            os_ = by[cat].get(v, [])
            F = [_flags(o) for o in os_]
            b = [f for f in F if not f["reject"]]
            rev = [f for f in b if f["checked"] and f["has_rev"]]
            rows.append((v, len(os_), _pct(sum(f["ok"] for f in F), len(F)),
                         _pct(sum(f["built"] for f in b), len(b)), _pct(sum(f["checked"] for f in b), len(b)),
                         _pct(sum(f["beats"] and f["checked"] for f in b), len(b)),
                         _pct(sum(f["repeats"] for f in rev), len(rev))))
        out[cat] = rows
    return out


def renormalise(outs: List[Dict]) -> None:
    """Recompute the message patterns from the stored messages (a table
    rendered again from sweep.json uses the current normalisation)."""
    from faultmesh.grounds import normalise_message
    for o in outs:
        if o.get("error_type") and o.get("error") and o.get("stage") not in ("timeout", "crash"):
            o["pattern"] = normalise_message(o["error"])
        if str(o.get("stage")).endswith("timeout") and "stack: " in (o.get("error") or ""):
            # One hang, wherever in its loop the stack was caught: named by
            # the step of build_model it is in (the frame below build_model).
            frames = [re.sub(r" \((\S+?):\d+\)", r" (\1)", f)
                      for f in o["error"].split("stack: ", 1)[1].split(" <- ") if not f.startswith("<")]
            names = [f.split(" ")[0] for f in frames]
            k = names.index("build_model") - 1 if "build_model" in names else len(frames) - 1
            o["pattern"] = o["pattern"].split(", in ")[0] + f", in {frames[max(k, 0)]}"


def fill_specs(outs: List[Dict]) -> None:
    """Seeds that ended without an outcome (timeout, crash) get their spec by
    drawing the ground again (deterministic per seed)."""
    import tempfile
    import warnings
    from faultmesh.grounds import make_ground
    for o in outs:
        if o.get("spec"):
            continue
        with tempfile.TemporaryDirectory() as d, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                spec, _, _ = make_ground(o["seed"], d)
            except Exception:  # pragma: no cover - the generator failed in the child too
                continue
        o["spec"], o["describe"], o["tags"] = spec.to_dict(), spec.describe(), spec.tags()


def mark_rejects(outs: List[Dict]) -> None:
    """A seed that had to be rejected (a too-close pair) and was not gets its
    stage prefixed with "must reject:" (e.g. a GeometryError at the stitching
    step names the pair, but it is not the DatasetError before any work)."""
    for o in outs:
        if (o.get("spec") or {}).get("expect") == "reject" and not o.get("ok") and \
                not str(o.get("stage", "")).startswith("must reject"):
            o["stage"] = f"must reject: {o.get('stage')}"


def _header(title: str, outs: List[Dict], meta: Dict[str, Any]) -> List[str]:
    """The first lines of a sweep's table: title, command, date, machine,
    seeds and limits."""
    seeds = [o["seed"] for o in outs]
    return ["## " + title, "", f"Command: `{meta['command']}`  ", f"Date: {meta['date']}  ",
            f"Machine: {meta['machine']}  ",
            f"Seeds: {min(seeds)}-{max(seeds)} ({len(seeds)}), {meta['jobs']} processes, "
            f"time limit {meta['timeout']:.0f} s and {meta['memory_gb']:g} GiB per seed; "
            f"wall time {meta['elapsed'] / 60.0:.1f} min.  ", ""]


def render(outs: List[Dict], meta: Dict[str, Any]) -> str:
    L = _header("Random grounds: how often faultmesh holds", outs, meta)
    L += ["Each seed is a ground truth drawn by `faultmesh.grounds.random_ground(seed)` (study area, layers, "
          "faults, sections, boreholes, survey rounding), written with `Dataset.save` and read back with "
          "`load_dataset`, built with `build_model` (default options), checked with `Model.check()`, then "
          "measured: mean \\|dz\\| near the faults against the truth, stitched model vs the plain "
          "continuous TIN (`metadata[\"accuracy\"]`), and per reverse fault and layer the share of the "
          "truth's repetition band where the model's layer folds (footwall, strip, hanging wall): "
          "`share_data` over the band the data give (between consecutive traces, inside the "
          "quadrilateral of their cutoffs; threshold 95 %) and `share` over the whole truth band "
          "(reported only). `python -c \"import faultmesh.grounds as g; print(g.evaluate_ground(SEED))\"` "
          "reruns one seed.", ""]
    L += ["| | seeds |", "|---|---:|"] + [f"| {a} | {b} |" for a, b in summary_rows(outs)] + [""]
    gen = [o["seconds"]["generate"] for o in outs if (o.get("seconds") or {}).get("generate") is not None]
    bld = [o["seconds"]["build"] for o in outs if (o.get("seconds") or {}).get("build") is not None]
    cov_t = [o["coverage_truth_min"] for o in outs if o.get("coverage_truth_min") is not None]
    cov_d = [o["coverage_min"] for o in outs if o.get("coverage_min") is not None]
    L += [f"Median build time (`build_model`, with its evaluation): "
          f"{statistics.median(bld):.2f} s (max {max(bld):.1f} s, {len(bld)} builds); median generation "
          f"time {statistics.median(gen):.2f} s (max {max(gen):.1f} s)." if bld and gen else "", ""]
    if cov_d:
        L += [f"Repetition of reverse-fault layers, smallest share per seed (seeds with a band): "
              f"`share_data` median {100 * statistics.median(cov_d):.0f} %, "
              f"`share` (whole truth band) median {100 * statistics.median(cov_t):.0f} %.", ""]
    L += ["### Failure classes", "",
          "Stage: where the seed stopped (`load`, `build:<step>` with the step `build_model` was in, "
          "`check`: the invariant named, `accuracy`, `repetition`, `not rejected`, `timeout`, `crash`). "
          "Pattern: the message with names ('S') and numbers (N) replaced.", "",
          "| # | stage | exception | pattern | seeds | examples |", "|---:|---|---|---|---:|---|"]
    for i, ((stage, et, pat), os_) in enumerate(failure_classes(outs), 1):
        ex = "<br>".join(f"{o.get('describe') or ('seed %d' % o['seed'])}"
                         + (f" -- {o['error'][:160]}" if o.get("error") else "") for o in os_[:3])
        pat_md = pat.replace("|", "\\|")
        ex = ex.replace("|", "\\|")
        L.append(f"| {i} | {stage} | {et} | {pat_md} | {len(os_)} | {ex} |")
    L += ["", "### By kind", "",
          "A seed counts under every value it has (one per fault or fault end). built / check / beats: "
          "of the seeds of that kind that must build; repeats: of those that passed `check()` and have "
          "reverse-fault bands in their data.", ""]
    titles = {"coords": "coordinates", "area": "study area", "n_faults": "number of faults",
              "pair": "fault pair", "fault": "fault kind (gentle_reverse: reverse, dip <= 45 deg)",
              "extent": "fault extent", "boundary_end": "fault end on the boundary (on_boundary: end trace "
              "on the boundary side; extended: the builder extends the last trace)",
              "sections": "sections", "trace_format": "trace points written as"}
    for cat, rows in split_rows(outs).items():
        L += [f"**{titles.get(cat, cat)}**", "",
              "| kind | seeds | pass | built | check | beats TIN | repeats |",
              "|---|---:|---:|---:|---:|---:|---:|"]
        L += [f"| {v} | {n} | {a} | {b} | {c} | {d} | {e} |" for v, n, a, b, c, d, e in rows]
        L.append("")
    return "\n".join(L).rstrip() + "\n"


def _quantiles(v: List[float], fmt: str = "{:.2f}") -> str:
    """min / median / 90th percentile / max of v."""
    if not v:
        return "-"
    v = sorted(v)
    q = [v[0], statistics.median(v), v[min(len(v) - 1, int(round(0.9 * (len(v) - 1))))], v[-1]]
    return " / ".join(fmt.format(x) for x in q)


def render_v2(outs: List[Dict], meta: Dict[str, Any]) -> str:
    """The table of a --v2 sweep: format-2 grounds without cutoffs against
    the same grounds' v1 models."""
    from faultmesh.grounds import V2_RATIO
    holes = meta.get("v2") == "holes"
    form = meta.get("fault_form", "sticks")
    title = "Random grounds as format 2 without cutoffs: derived against true cutoffs"
    L = _header(title + (", layer data from the holes only" if holes else "")
                + ("" if form == "sticks" else f", faults as {form}")
                + (f", fault points with a {meta['fault_noise']:g} m picking error"
                   if meta.get("fault_noise") else "")
                + ("" if meta.get("groups", True) else ", faults without their groups")
                + (", each fault with a throw hint (its largest true throw)" if meta.get("throw_hints") else ""),
                outs, meta)
    L += ["Each seed's ground (`faultmesh.grounds.random_ground(seed)`) is written twice: as its v1 "
          "dataset (hand-drawn traces up to the true cutoffs) and by `faultmesh.grounds.write_v2` as "
          "format 2 without cutoffs (each fault as "
          + {"sticks": "fault sticks on the truth's surface",
             "points": "points on the truth's surface without their stick column",
             "surface": "a triangulated surface (TSurf) of the truth's, cells of the sticks' spacing"}[form]
          + ", no traces, kind "
          "or tips; the layer tops as collar/survey/interval tables of the same holes, about half of "
          "them deviated; "
          + ("no other layer data: nothing of what the v1 traces give within 20-180 m of the faults, "
             "`--holes-only`"
             if holes else
             "the v1 traces' layer polylines as layer points, without the cutoffs and without the "
             "points within a fault shadow of 10-50 m from them, `grounds.trace_picks`")
          + "). Both are loaded, built and checked; the v2 one through "
          "`derive.derive_faults`. Measured: the distance of each derived cutoff point from the true "
          "cutoff on its section (`grounds.cutoff_distance`), the derived kind, and the mean \\|dz\\| "
          "within 150 m of the truth's fault bands of each model (`grounds.near_fault_errors`) and "
          f"their ratio v2 / v1; a seed passes when the v2 model derives, builds, passes `check()` "
          f"and its ratio is at most {V2_RATIO:g}. Too-close pairs (which must be rejected) are not "
          "run. `python -c \"import faultmesh.grounds as g; print(g.evaluate_ground_v2(SEED))\"` reruns "
          "one seed.", ""]
    run = [o for o in outs if o.get("stage") != "reject"]
    n = len(run)
    v1ok = [o for o in run if o.get("stage") not in ("generate", "load:v1", "build:v1", "check:v1",
                                                     "timeout", "crash") or o.get("ok")]
    v1ok = [o for o in v1ok if o.get("stage") not in ("timeout", "crash")]
    nv = len(v1ok)

    def count(pred, pool):
        return _pct(sum(1 for o in pool if pred(o)), len(pool))

    derived = lambda o: o.get("stage") not in ("generate:v2", "load:v2", "derive")
    built = lambda o: derived(o) and not str(o.get("stage")).startswith("build:v2")
    checked = lambda o: built(o) and o.get("stage") != "check:v2"
    rows = [("seeds", str(len(outs))), ("too-close pairs (not run)", str(len(outs) - n)),
            ("grounds run", str(n)),
            ("- v1 reference built and checked (else not compared)", _pct(nv, n)),
            ("of these: v2 written and loaded, faults derived", count(derived, v1ok)),
            ("- v2 built", count(built, v1ok)), ("- v2 built and `check()` passed", count(checked, v1ok)),
            ("- every fault's kind derived right", count(lambda o: checked(o) and o.get("kind_ok"), v1ok)),
            (f"- **error near the faults at most {V2_RATIO:g} x v1's (pass)**", count(lambda o: o.get("ok"), v1ok))]
    L += ["| | seeds |", "|---|---:|"] + [f"| {a} | {b} |" for a, b in rows] + [""]
    done = [o for o in v1ok if o.get("ratio") is not None]
    ratios = [o["ratio"] for o in done if o["ratio"] == o["ratio"]]
    cm = [o["cutoff_mean"] for o in v1ok if o.get("cutoff_mean") is not None]
    cx = [o["cutoff_max"] for o in v1ok if o.get("cutoff_max") is not None]
    L += ["Distributions (min / median / 90th percentile / max over the seeds):", "",
          "| measure | seeds | value |", "|---|---:|---|",
          f"| error ratio v2 / v1 | {len(ratios)} | {_quantiles(ratios)} |",
          f"| error near the faults, v1 (m) | {len(done)} | {_quantiles([o['error_v1'] for o in done])} |",
          f"| error near the faults, v2 (m) | {len(done)} | {_quantiles([o['error_v2'] for o in done])} |",
          f"| excess error near the faults, v2 - v1 (m) | {len(done)} | "
          f"{_quantiles([o['error_v2'] - o['error_v1'] for o in done])} |",
          f"| cutoff distance, mean per seed (m) | {len(cm)} | {_quantiles(cm)} |",
          f"| cutoff distance, max per seed (m) | {len(cx)} | {_quantiles(cx)} |", ""]
    for k in (1, 2, 3, 4):
        sub = [o for o in done if len((o.get("spec") or {}).get("faults") or []) == k]
        if sub:
            r = [o["ratio"] for o in sub]
            L.append(f"{k} fault{'s' if k > 1 else ''}: {len(sub)} compared, "
                     f"{sum(o['ok'] for o in sub)} within {V2_RATIO:g}, ratio median "
                     f"{statistics.median(r):.2f}.  ")
    L += ["", "### Failure classes", "",
          "Stage: where the seed stopped (`load:v1` ... `check:v1`: the reference model, the "
          "robustness sweep's failures; `generate:v2`, `load:v2`: the generator's or the drillhole "
          "reader's; `derive`, `build:v2:<step>`, `check:v2`: derived faults; `ratio`: built and "
          "checked, error near the faults above the limit, with what derive got visibly wrong: the kind, "
          "or its most frequent warning). Pattern: names ('S') and numbers (N) replaced.", "",
          "| # | stage | exception | pattern | seeds | examples |", "|---:|---|---|---|---:|---|"]
    for i, ((stage, et, pat), os_) in enumerate(failure_classes([o for o in outs if o.get("stage") != "reject"]), 1):
        ex = "<br>".join(f"{o.get('describe') or ('seed %d' % o['seed'])}"
                         + (f" -- {o['error'][:160]}" if o.get("error") else "") for o in os_[:3])
        all_seeds = ", ".join(str(o["seed"]) for o in os_)
        L.append(f"| {i} | {stage} | {et} | {pat.replace('|', chr(92) + '|')} | {len(os_)} ({all_seeds}) | "
                 f"{ex.replace('|', chr(92) + '|')} |")
    return "\n".join(L).rstrip() + "\n"


def _stem(v2, ground: Optional[Dict[str, Any]] = None) -> str:
    """The file stem of a sweep's outputs (``ground``: its ground options,
    GROUND_OPTIONS)."""
    stem = {False: "sweep", None: "sweep", True: "sweep_v2", "holes": "sweep_v2_holes"}[v2]
    g = _ground_options(ground or {})
    if v2 and g["fault_form"] != "sticks":
        stem += f"_{g['fault_form']}"
    if v2 and g["fault_noise"] > 0.0:
        stem += f"_noise{g['fault_noise']:g}"
    if v2 and not g["groups"]:
        stem += "_nogroups"
    if v2 and g["throw_hints"]:
        stem += "_hints"
    return stem


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=500, help="number of seeds (default 500)")
    ap.add_argument("--start", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--jobs", type=int, default=2, help="processes at once (default 2)")
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds per seed (default 300)")
    ap.add_argument("--memory-gb", type=float, default=3.0, help="address-space limit per seed (GiB)")
    ap.add_argument("--quick", action="store_true", help="8 seeds; results under bench/results/quick/")
    ap.add_argument("--out", type=Path, default=None, help="folder for sweep.md / sweep.json")
    ap.add_argument("--no-write", action="store_true", help="print the table only")
    ap.add_argument("--v2", action="store_true",
                    help="each ground also as format 2 without cutoffs (grounds.evaluate_ground_v2): "
                         "derived against true cutoffs; writes sweep_v2.md / sweep_v2.json")
    ap.add_argument("--holes-only", action="store_true",
                    help="with --v2: the v2 grounds' layer data from the holes only (no trace picks); "
                         "writes sweep_v2_holes.md / sweep_v2_holes.json")
    ap.add_argument("--fault-form", choices=("sticks", "points", "surface"), default="sticks",
                    help="with --v2: each fault as sticks (default), as points without sticks, or as a "
                         "triangulated surface (GOCAD TSurf); a form other than sticks adds it to the "
                         "file stem (sweep_v2_surface.md ...)")
    ap.add_argument("--fault-noise", type=float, default=0.0, metavar="M",
                    help="with --v2: each fault point moved across strike by a normal error of this "
                         "standard deviation (m; an interpreter's picking error); adds _noiseM to the "
                         "file stem")
    ap.add_argument("--no-groups", action="store_true",
                    help="with --v2: the faults written without their groups (T and X pairs), which "
                         "the derivation must find; adds _nogroups to the file stem")
    ap.add_argument("--throw-hints", action="store_true",
                    help="with --v2: each fault written with a throw hint, its largest true throw over "
                         "the layers it displaces; adds _hints to the file stem")
    ap.add_argument("--render", type=Path, default=None, metavar="JSON",
                    help="no sweep: render the table again from a sweep.json (into --out or its folder)")
    args = ap.parse_args(argv)
    if args.render is not None:
        doc = json.loads(args.render.read_text())
        outs = doc["seeds"]
        v2 = doc["meta"].get("v2")
        if not v2:
            renormalise(outs)
            fill_specs(outs)
            mark_rejects(outs)
        text = render_v2(outs, doc["meta"]) if v2 else render(outs, doc["meta"])
        print(text)
        if not args.no_write:
            out = (args.out or args.render.parent) / (_stem(v2, doc["meta"]) + ".md")
            out.write_text(text)
            print(f"wrote {out}", file=sys.stderr)
        return 0
    if args.holes_only and not args.v2:
        ap.error("--holes-only goes with --v2")
    ground = _ground_options({**vars(args), "groups": not args.no_groups})
    if ground != GROUND_OPTIONS and not args.v2:
        ap.error("--fault-form, --fault-noise, --no-groups and --throw-hints go with --v2")
    if not args.fault_noise >= 0.0:
        ap.error("--fault-noise must be at least 0")
    v2 = "holes" if args.holes_only else args.v2
    if args.quick:
        args.seeds = min(args.seeds, 8)
    if args.seeds < 1 or args.jobs < 1 or args.timeout <= 0:
        ap.error("--seeds, --jobs and --timeout must be positive")
    out_dir = args.out or (QUICK_OUT if args.quick else ROOT / "docs" / "bench")
    out_dir.mkdir(parents=True, exist_ok=True)
    seeds = list(range(args.start, args.start + args.seeds))
    t0 = time.perf_counter()
    stem = _stem(v2, ground)
    outs = run_seeds(seeds, args.jobs, args.timeout, args.memory_gb,
                     jsonl=None if args.no_write else out_dir / f"{stem}.jsonl", v2=v2, ground=ground)
    elapsed = time.perf_counter() - t0
    if not args.v2:
        fill_specs(outs)
        mark_rejects(outs)
    meta = {"command": command_line("sweep.py"), "date": today(),
            "machine": machine(numpy=True, faultmesh=True), "jobs": args.jobs, "timeout": args.timeout,
            "memory_gb": args.memory_gb, "elapsed": elapsed, "v2": v2,
            **(ground if args.v2 else {})}
    text = render_v2(outs, meta) if args.v2 else render(outs, meta)
    print(text)
    if not args.no_write:
        (out_dir / f"{stem}.md").write_text(text)
        slim = []
        for o in outs:
            o = {k: v for k, v in o.items() if k != "traceback"}
            slim.append(o)
        doc = {"meta": meta, "seeds": slim}
        (out_dir / f"{stem}.json").write_text(json.dumps(doc, default=float, separators=(",", ":")) + "\n")
        try:
            (out_dir / f"{stem}.jsonl").unlink()
        except OSError:
            pass
        print(f"wrote {out_dir / (stem + '.md')} and {stem}.json", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
