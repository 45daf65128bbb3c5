"""Derive, build and measure the stress grounds (bench/stress_ground.py).

    python bench/stress.py START END [--out FILE]   # seeds START..END, one JSON line each
    python bench/stress.py --one SEED               # one ground, in this process
    python bench/stress.py --summary FILE [FILE ...]
    python bench/stress.py --compare BASE [BASE ...] -- NEW [NEW ...]   # paired, per seed

Each seed runs in a child process with a timeout of 300 s: stress_ground ->
derive_faults -> build_model -> check(). A line holds the stage reached
("ok", or where it stopped: "derive", "build", "check", "hang", "crash"),
the exception, the derived kind of each fault against the true one, which
layers each fault cuts in the truth and in the derivation, the derived
cutoffs' errors against the true ones (`cut_foot`, `cut_hanging`: mean,
max; `_dense` where a pick of that side lies within 200 m), and the
model's error against the truth at the noise-free picks within 200 m of a
fault (`model_near`) and on a grid (`grid_near`). The summary groups the
seeds by outcome and lists the worst.
"""
from __future__ import annotations

import json
import re
import os
import subprocess
import sys
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))


def one(seed: int, force=None) -> dict:
    import numpy as np
    sys.path.insert(0, HERE)
    from stress_ground import stress_ground
    import faultmesh as fm
    from faultmesh.derive import derive_faults
    from faultmesh.dataset import points_in_polygon
    from faultmesh.report import evaluate_surface

    rec = {"seed": seed, "stage": "gen"}
    t0 = time.time()
    try:
        g = stress_ground(seed, force)
        rec["params"] = g.params
        ds = g.dataset
        ring = np.asarray(ds.boundary, float)
        rec["stage"] = "derive"
        t1 = time.time()
        d = derive_faults(ds)
        rec["t_derive"] = round(time.time() - t1, 2)
        rec["stage"] = "derived"
        # --- kinds and cutoffs
        rec["faults"] = {}
        for k, ft in enumerate(g.faults):
            fd = d.derivation.faults[ft.name]
            fr = {"true_kind": ft.kind, "kind": d.faults[k].kind, "throw": round(ft.throw, 2),
                  "dip": round(ft.dip, 2), "n_warnings": len(fd.warnings),
                  "borrowed": sorted(re.match(r"fault '[^']*', layer '([^']*)'", w).group(1)
                                     for w in fd.warnings if "wall is that of layer" in w),
                  "warnings": sorted({re.sub(r"[-0-9.]+", "#", w[:200]) for w in fd.warnings})[:6],
                  "ends": list(fd.ends), "n_traces": len(d.faults[k].traces)}
            # truly cut layers: both sides' sign change vs fault inside area
            lo, hi = ring.min(0), ring.max(0)
            GX, GY = np.meshgrid(np.linspace(lo[0], hi[0], 150), np.linspace(lo[1], hi[1], 150))
            ins = points_in_polygon(np.column_stack([GX.ravel(), GY.ravel()]), ring)
            GX, GY = GX.ravel()[ins], GY.ravel()[ins]
            fz = ft.z(GX, GY)
            true_cut = []
            for i, lay in enumerate(ds.layers):
                ok = True
                for side in ("foot", "hanging"):
                    z = g.side_z(k, i, side, GX, GY)
                    dd = (z - fz)[np.isfinite(z)]
                    ok &= bool(len(dd) and dd.min() < 0 < dd.max())
                if ok:
                    true_cut.append(lay)
            fr["true_cut"] = true_cut
            fr["derived_cut"] = sorted(fd.cutoffs, key=ds.layers.index)
            mis = {}
            worst = None
            for lay, cd in fd.cutoffs.items():
                i = ds.layers.index(lay)
                T = g.picks[lay]
                tside = T[:, 2] > ft.z(T[:, 0], T[:, 1])
                for side in ("foot", "hanging"):
                    C = np.asarray(cd[side])
                    if not len(C):
                        continue
                    tz = g.side_z(k, i, side, C[:, 0], C[:, 1])
                    e = C[:, 2] - tz
                    S = T[tside == (side == "hanging")]
                    if len(S):
                        dn = np.sqrt(((C[:, None, :2] - S[None, :, :2]) ** 2).sum(-1)).min(1)
                    else:
                        dn = np.full(len(C), np.inf)
                    for j in range(len(C)):
                        if not np.isfinite(e[j]):
                            continue
                        mis.setdefault(side, []).append((float(e[j]), float(dn[j]), lay))
                        if worst is None or abs(e[j]) > abs(worst[0]):
                            worst = (round(float(e[j]), 2), lay, side, round(float(dn[j]), 1),
                                     [round(float(v), 1) for v in C[j]])
            for side, v in mis.items():
                e = np.array([x[0] for x in v])
                dn = np.array([x[1] for x in v])
                dense = dn <= 200.0
                fr[f"cut_{side}"] = {"n": len(e), "signed": round(float(e.mean()), 2),
                                     "mean": round(float(np.abs(e).mean()), 2),
                                     "max": round(float(np.abs(e).max()), 2),
                                     "n_dense": int(dense.sum()),
                                     "max_dense": round(float(np.abs(e[dense]).max()), 2) if dense.any() else None,
                                     "mean_dense": round(float(np.abs(e[dense]).mean()), 2) if dense.any() else None}
            fr["worst_cut"] = worst
            rec["faults"][ft.name] = fr
        rec["kinds_ok"] = all(f["kind"] == f["true_kind"] for f in rec["faults"].values())
        rec["stage"] = "build"
        t2 = time.time()
        m = fm.build_model(d, evaluate=False)
        rec["t_build"] = round(time.time() - t2, 2)
        # what the layer crossing repair changed, per lower layer of a pair
        rec["repair"] = {lay: {k: c.get(k) for k in ("data_above", "max_lowered")}
                         for lay, c in m.metadata.get("repair", {}).items() if c.get("max_lowered")}
        # the model's largest miss of a datum per layer, and the build's warnings
        rec["data_miss"] = {lay: round(r["max_m"], 3) for lay, r in m.metadata["data_fit"].items()
                            if r["off"]}
        rec["build_warnings"] = [w[:300] for w in m.metadata.get("warnings", [])]
        # whether the crossing repair failed and the TINs were built again
        # (without the raise's stack rule, perhaps with the picks under the
        # derived patches left out): build_model's retries
        rec["repair_retry"] = m.metadata.get("repair_retry", "")[:300]
        rec["stage"] = "check"
        m.check()
        rec["stage"] = "ok"
        rec["n_model_faults"] = len(m.faults)
        # --- model accuracy at the picks (noise-free truth)
        near_e, all_e, worst, nan_near = [], [], None, 0
        per_layer = {}
        for i, lay in enumerate(ds.layers):
            T = g.picks[lay]
            a, b, n = evaluate_surface(m.surfaces[lay], T[:, 0], T[:, 1])
            e = np.minimum(np.abs(a - T[:, 2]), np.abs(b - T[:, 2]))
            hd = np.min([f.hdist(T[:, 0], T[:, 1], T[:, 2]) for f in g.faults], axis=0)
            near = hd <= 200.0
            nan_near += int((near & ~np.isfinite(e)).sum())
            fin = np.isfinite(e)
            all_e.append(e[fin])
            near_e.append(e[near & fin])
            if (near & fin).any():
                j = np.argmax(np.where(near & fin, e, -1))
                per_layer[lay] = [round(float(e[near & fin].mean()), 2), round(float(e[j]), 2)]
                if worst is None or e[j] > worst[0]:
                    worst = (round(float(e[j]), 2), lay, [round(float(v), 1) for v in T[j]],
                             round(float(hd[j]), 1), int(n[j]))
        ne, ae = np.concatenate(near_e), np.concatenate(all_e)
        rec["model_near"] = {"n": int(len(ne)), "mean": round(float(ne.mean()), 3) if len(ne) else None,
                             "max": round(float(ne.max()), 2) if len(ne) else None,
                             "p95": round(float(np.percentile(ne, 95)), 2) if len(ne) else None,
                             "nan": nan_near, "worst": worst}
        rec["model_all"] = {"n": int(len(ae)), "mean": round(float(ae.mean()), 3),
                            "max": round(float(ae.max()), 2)}
        rec["model_near_per_layer"] = per_layer
        # --- model vs truth on a grid within 200 m (horizontally) of a fault
        lo, hi = ring.min(0), ring.max(0)
        h = max(hi - lo) / 160.0
        GX, GY = np.meshgrid(np.arange(lo[0] + h / 2, hi[0], h), np.arange(lo[1] + h / 2, hi[1], h))
        GX, GY = GX.ravel(), GY.ravel()
        ins = points_in_polygon(np.column_stack([GX, GY]), ring)
        GX, GY = GX[ins], GY[ins]
        import itertools
        errs, worst, miss = [], None, 0
        per_layer = {}
        for i, lay in enumerate(ds.layers):
            a, b, n = evaluate_surface(m.surfaces[lay], GX, GY)
            el = []
            for sides in itertools.product([False, True], repeat=len(g.faults)):
                z = g.block_z(i, GX, GY, sides)
                ok = g.valid(z, GX, GY, sides)
                hd = np.min([f.hdist(GX, GY, z) for f in g.faults], axis=0)
                ok &= hd <= 200.0
                e = np.minimum(np.abs(a - z), np.abs(b - z))
                miss += int((ok & ~np.isfinite(e)).sum())
                sel = ok & np.isfinite(e)
                el.append(e[sel])
                if sel.any():
                    j = np.argmax(np.where(sel, e, -1))
                    if worst is None or e[j] > worst[0]:
                        worst = (round(float(e[j]), 2), lay, [round(float(GX[j]), 1), round(float(GY[j]), 1),
                                                              round(float(z[j]), 1)], round(float(hd[j]), 1), int(n[j]))
            el = np.concatenate(el)
            if len(el):
                per_layer[lay] = [round(float(el.mean()), 2), round(float(el.max()), 2)]
            errs.append(el)
        ge = np.concatenate(errs)
        rec["grid_near"] = {"n": int(len(ge)), "mean": round(float(ge.mean()), 3) if len(ge) else None,
                            "p95": round(float(np.percentile(ge, 95)), 2) if len(ge) else None,
                            "max": round(float(ge.max()), 2) if len(ge) else None,
                            "missing": miss, "worst": worst}
        rec["grid_near_per_layer"] = per_layer
    except BaseException as ex:  # noqa
        tb = traceback.extract_tb(ex.__traceback__)
        rec["exc_type"] = f"{type(ex).__module__}.{type(ex).__name__}"
        rec["exc"] = str(ex)[:800]
        rec["tb"] = [f"{os.path.basename(fr.filename)}:{fr.lineno}:{fr.name}" for fr in tb[-6:]]
    rec["time"] = round(time.time() - t0, 2)
    return rec


def _load(paths) -> dict:
    """The records of result files (one JSON line per seed), by seed; a
    later file's line for a seed replaces an earlier one's."""
    recs = {}
    for path in paths:
        with open(path) as fh:
            for line in fh:
                r = json.loads(line)
                recs[r["seed"]] = r
    return recs


def summary(paths) -> None:
    """The seeds of the result files, by outcome, and the worst of them."""
    from collections import defaultdict

    recs = _load(paths)
    print("seeds:", len(recs))
    groups = defaultdict(list)
    for s, r in sorted(recs.items()):
        if r["stage"] in ("ok", "hang", "crash", "runner"):
            groups[r["stage"]].append(s)
        else:
            msg = re.sub(r"[-0-9.]+", "#", r.get("exc", ""))[:70]
            groups[f'{r["stage"]}|{r.get("exc_type")}|{msg}'].append(s)
    for k, v in groups.items():
        print(f"{len(v):4d}  {k}  {v[:25]}")
    print("kinds wrong:")
    for s, r in sorted(recs.items()):
        for n, f in (r.get("faults") or {}).items():
            if f["kind"] != f["true_kind"]:
                print(f"  {s} {n}: {f['true_kind']} derived {f['kind']}")
    print("worst model_near (max, mean, seed, worst):")
    rows = [(r["model_near"]["max"], r["model_near"]["mean"], s, r["model_near"]["worst"])
            for s, r in recs.items() if r.get("model_near") and r["model_near"]["n"]]
    for row in sorted(rows, reverse=True)[:10]:
        print("  ", row)
    # Between the picks: the grid near the faults, which the picks do not see
    # (stress ground 17: 0.67 m at most at its picks, 89 m on average there).
    rows = [(r["grid_near"]["mean"], r["grid_near"]["max"], s, r["grid_near"]["worst"])
            for s, r in recs.items() if (r.get("grid_near") or {}).get("n")]
    if rows:
        means = sorted(x[0] for x in rows)
        print(f"grid within 200 m of a fault: mean error per seed, median {means[len(means) // 2]:.3f} m, "
              f"{sum(x[1] > 100.0 for x in rows)} of {len(rows)} seeds over 100 m somewhere")
        print("worst grid_near (mean, max, seed, worst):")
        for row in sorted(rows, reverse=True)[:10]:
            print("  ", row)
    heights = [_order_height(r) for r in recs.values() if r.get("stage") == "ok"]
    if heights:
        print(f"layer-order warnings: {sum(h > 0 for h in heights)} of {len(heights)} models, "
              f"{sum(h > 20.0 for h in heights)} by over 20 m")


def _order_height(rec: dict) -> float:
    """The largest height of a lower layer over the one above it that the
    build warned of (0 if none)."""
    out = 0.0
    for w in rec.get("build_warnings") or []:
        m = re.search(r"lies above .* by up to ([0-9.]+) m", w)
        if m:
            out = max(out, float(m.group(1)))
    return out


def compare(base_paths, new_paths) -> None:
    """Paired change per seed between two runs (the same seeds, e.g. main
    and a branch in the same session): how many build, kinds right, and
    per measure (at the picks near the faults, on the grid near them, the
    layer-order height) the mean over seeds and how many seeds got better
    or worse (by over 0.05 m for means, 1 m for maxima)."""
    a, b = _load(base_paths), _load(new_paths)
    seeds = sorted(set(a) & set(b))
    print(f"seeds {len(seeds)}: ok {sum(a[s]['stage'] == 'ok' for s in seeds)} -> "
          f"{sum(b[s]['stage'] == 'ok' for s in seeds)}, kinds right "
          f"{sum(bool(a[s].get('kinds_ok')) for s in seeds)} -> {sum(bool(b[s].get('kinds_ok')) for s in seeds)}")
    for s in seeds:
        if a[s]["stage"] != b[s]["stage"]:
            print(f"  seed {s}: {a[s]['stage']} -> {b[s]['stage']} {b[s].get('exc', '')[:120]}")
    both = [s for s in seeds if a[s]["stage"] == b[s]["stage"] == "ok"]
    measures = [("picks near, mean", lambda r: r["model_near"]["mean"], 0.05),
                ("picks near, max", lambda r: r["model_near"]["max"], 1.0),
                ("grid near, mean", lambda r: r["grid_near"]["mean"], 0.05),
                ("grid near, max", lambda r: r["grid_near"]["max"], 1.0),
                ("layer order, max", _order_height, 1.0)]
    for name, get, tol in measures:
        pairs = [(get(a[s]), get(b[s]), s) for s in both]
        pairs = [p for p in pairs if p[0] is not None and p[1] is not None]
        if not pairs:
            continue
        x = sum(p[0] for p in pairs) / len(pairs)
        y = sum(p[1] for p in pairs) / len(pairs)
        worse = sorted(((p[1] - p[0], p[2]) for p in pairs if p[1] > p[0] + tol), reverse=True)
        better = sum(p[1] < p[0] - tol for p in pairs)
        print(f"{name}: mean over {len(pairs)} seeds {x:.3f} -> {y:.3f}; better {better}, worse {len(worse)}"
              + (f" (most: seeds {[s for _, s in worse[:5]]})" if worse else ""))


def main():
    if sys.argv[1] == "--summary":
        summary(sys.argv[2:])
        return
    if sys.argv[1] == "--compare":
        k = sys.argv.index("--")
        compare(sys.argv[2:k], sys.argv[k + 1:])
        return
    if sys.argv[1] == "--one":
        force = json.loads(sys.argv[3]) if len(sys.argv) > 3 else None
        rec = one(int(sys.argv[2]), force)
        print(json.dumps(rec, default=str))
        return
    a, b = int(sys.argv[1]), int(sys.argv[2])
    out = sys.argv[sys.argv.index("--out") + 1] if "--out" in sys.argv else f"stress_{a}_{b}.jsonl"
    for s in range(a, b + 1):
        t0 = time.time()
        try:
            p = subprocess.run(["timeout", "300", sys.executable, os.path.abspath(__file__), "--one", str(s)],
                               capture_output=True, text=True)
            lines = [l for l in p.stdout.splitlines() if l.startswith("{")]
            if p.returncode == 0 and lines:
                rec = json.loads(lines[-1])
            else:
                rec = {"seed": s, "stage": "hang" if p.returncode == 124 else "crash",
                       "rc": p.returncode, "stderr": p.stderr[-1500:]}
        except Exception as ex:
            rec = {"seed": s, "stage": "runner", "exc": repr(ex)}
        rec["wall"] = round(time.time() - t0, 1)
        with open(out, "a") as fh:
            fh.write(json.dumps(rec, default=str) + "\n")
        print(s, rec.get("stage"), rec.get("exc_type", ""), rec.get("wall"), flush=True)


if __name__ == "__main__":
    main()
