"""Benchmark: polygon triangulation (ear clipping, CDT refinement) against CGAL,
mapbox_earcut and triangle.

    python bench/bench_polygon.py [--runs 5] [--sizes 1000 10000 100000] [--no-fixtures]
                                  [--out docs/bench/polygon.md]

Inputs: deterministic bench polygons (noisy star-shaped outer ring with a few
convex holes, 1k/10k/100k vertices in total) and every earcut fixture
(tests/data/earcut).

What is timed (median over --runs runs, all in this process unless noted):
  faultmesh plain / quality / quality+refine: the Python call
      faultmesh.triangulate_polygon(rings, ...), i.e. the C++ call with the GIL
      released plus the binding's copy of the rings into one array. Plain
      order splits a joined loop of >= 4096 vertices in two along an inside
      diagonal and clips the halves on two threads (default threads=0);
      "fm plain, 1 thread" is the same call with threads=1 (both halves on
      the calling thread; the same triangles).
  mapbox_earcut: the Python call triangulate_float64(vertices, ring_ends)
      (earcut.hpp's C++ plus its binding's conversion); the vertices array is
      concatenated beforehand, outside the timing.
  triangle: the Python call triangle.triangulate(pslg, "p") (Shewchuk's
      Triangle, CDT of the PSLG; hole points prepared outside the timing).
  CGAL CDT: bench/cgal/cgal_polygon_cdt (separate process): its own reported
      wall time of building the CDT and marking the inside faces (file I/O not
      timed). Epick kernel.
Quality: share of triangles whose minimum angle is below 10 and 20 degrees.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
from _common import use_dev_build  # noqa: E402

# Only a dev build loads the package from python/; otherwise the installed one
# (importers such as the tests then keep a sys.path that subprocesses, e.g.
# dask workers, can inherit safely).
use_dev_build()
import faultmesh as fm  # noqa: E402

try:
    import mapbox_earcut
except ImportError:  # pragma: no cover - recorded in the table
    mapbox_earcut = None
try:
    import triangle
except ImportError:  # pragma: no cover
    triangle = None


def bench_polygon(n_total: int, seed: int = 1) -> list[np.ndarray]:
    """Noisy star outer ring (about 90% of the vertices) plus 4 convex-ish holes."""
    rng = np.random.default_rng(seed)
    n_holes = 4
    n_hole = max(3, n_total // 40)
    n_outer = n_total - n_holes * n_hole
    ang = np.sort(rng.uniform(0, 2 * np.pi, n_outer))
    rad = 1.0 + 0.25 * np.sin(7 * ang) + rng.uniform(-0.05, 0.05, n_outer)
    rings = [np.c_[rad * np.cos(ang), rad * np.sin(ang)] * 1000.0]
    for h in range(n_holes):
        c = 0.35 * np.array([np.cos(np.pi / 2 * h + 0.3), np.sin(np.pi / 2 * h + 0.3)])
        a = np.sort(rng.uniform(0, 2 * np.pi, n_hole))
        r = 0.12 * (1 + rng.uniform(-0.03, 0.03, n_hole))
        rings.append((c + np.c_[r * np.cos(a), r * np.sin(a)]) * 1000.0)
    return rings


def clean(rings: list[np.ndarray]) -> list[np.ndarray]:
    """Drop consecutive duplicates and closing points (what every library sees)."""
    out = []
    for r in rings:
        keep = [r[0]]
        for p in r[1:]:
            if not np.array_equal(p, keep[-1]):
                keep.append(p)
        while len(keep) > 1 and np.array_equal(keep[0], keep[-1]):
            keep.pop()
        if len(keep) >= 3:
            out.append(np.array(keep))
    return out


def min_angles(pts: np.ndarray, tris: np.ndarray) -> np.ndarray:
    if len(tris) == 0:
        return np.zeros(0)
    p = pts[tris]
    ang = []
    for i in range(3):
        a, b, c = p[:, i], p[:, (i + 1) % 3], p[:, (i + 2) % 3]
        u, v = b - a, c - a
        cos = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1) + 1e-300)
        ang.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.min(ang, axis=0)


def median_time(fn, runs: int):
    out = fn()
    ts = []
    for _ in range(runs):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts)), out


def interleaved(fns: dict, runs: int) -> dict:
    """Median seconds and last output of each callable, runs interleaved.
    Each round runs them in a new (seeded) random order: a fixed or rotated
    order always puts the same call after another library's, and that call
    comes out slower (up to 20% on the small fixtures: identical faultmesh
    calls differed by that much)."""
    outs = {name: fn() for name, fn in fns.items()}  # warm-up
    ts = {name: [] for name in fns}
    names = list(fns)
    rng = np.random.default_rng(12345)
    for _ in range(runs):
        for k in rng.permutation(len(names)):
            name = names[k]
            fn = fns[name]
            t0 = time.perf_counter()
            outs[name] = fn()
            ts[name].append(time.perf_counter() - t0)
    return {name: (float(np.median(ts[name])), outs[name]) for name in fns}


def deviation(rings, pts, tris) -> float:
    """earcut's area deviation (its test suite's earcut.deviation): |sum of
    |triangle areas| - (|outer| - sum |holes|)| / (|outer| - sum |holes|)."""
    def ring_area(r):
        x, y = r[:, 0], r[:, 1]
        return abs(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)) / 2
    pa = ring_area(rings[0]) - sum(ring_area(r) for r in rings[1:])
    if len(tris):
        a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
        ta = float(np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])).sum() / 2)
    else:
        ta = 0.0
    if pa == 0 and ta == 0:
        return 0.0
    return abs(ta - pa) / pa if pa != 0 else float("inf")


def cgal_exe() -> Path | None:
    build = Path(os.environ.get("FAULTMESH_CGAL_BUILD", ROOT / "build" / "cgal"))
    gen = ["-G", "Ninja"]
    try:
        subprocess.run(["cmake", "-S", str(ROOT / "bench" / "cgal"), "-B", str(build),
                        "-DCMAKE_BUILD_TYPE=Release", *gen], check=True, capture_output=True)
        subprocess.run(["cmake", "--build", str(build), "-j2", "--target", "cgal_polygon_cdt"],
                       check=True, capture_output=True)
    except (subprocess.CalledProcessError, FileNotFoundError):
        return None
    exe = build / "cgal_polygon_cdt"
    return exe if exe.is_file() else None


def run_cgal(exe: Path, rings, runs: int):
    with tempfile.TemporaryDirectory() as d:
        inp, out = os.path.join(d, "in.txt"), os.path.join(d, "out.txt")
        with open(inp, "w") as f:
            f.write(f"{len(rings)}\n")
            for r in rings:
                f.write(f"{len(r)}\n")
                np.savetxt(f, r, fmt="%.17g")
        ts = []
        for _ in range(runs):
            res = subprocess.run([str(exe), inp, out], capture_output=True, text=True, check=True)
            ts.append(json.loads(res.stdout)["seconds"])
        tris = np.loadtxt(out, dtype=np.int64, ndmin=2).reshape(-1, 3)
    return float(np.median(ts)), tris


def hole_points(rings):
    """A point strictly inside each hole (centroid of one of its own triangles)."""
    pts = []
    for h in rings[1:]:
        t = fm.triangulate_polygon([h], refine=False)
        pts.append(h[t[0]].mean(axis=0))
    return np.array(pts).reshape(-1, 2)


def measure(rings, runs: int, exe):
    rings = clean(rings)
    pts = np.concatenate(rings)
    rows = {}

    def add(name, seconds, tris):
        tris = np.asarray(tris).reshape(-1, 3)
        count = len(tris)
        # CGAL adds Steiner vertices where constraints cross (invalid input):
        # angles are taken over the triangles on input vertices only.
        tris = tris[(tris < len(pts)).all(axis=1)]
        ma = min_angles(pts, tris)
        rows[name] = dict(seconds=seconds, triangles=int(count), _tris=tris,
                          lt10=float((ma < 10).mean()) if len(ma) else 0.0,
                          lt20=float((ma < 20).mean()) if len(ma) else 0.0)

    # faultmesh and mapbox_earcut are timed interleaved (one run of each in
    # turn, then the medians), so that load changes on the shared machine hit
    # both sides alike.
    fns = {}
    for name, kw in [("fm plain", dict(refine=False, order="plain")),
                     ("fm plain, 1 thread", dict(refine=False, order="plain", threads=1)),
                     ("fm quality", dict(refine=False, order="quality")),
                     ("fm quality+refine", dict(refine=True, order="quality"))]:
        fns[name] = lambda kw=kw: fm.triangulate_polygon(rings, **kw)
    if mapbox_earcut is not None:
        ends = np.cumsum([len(r) for r in rings]).astype(np.uint32)
        fns["mapbox_earcut"] = lambda: mapbox_earcut.triangulate_float64(pts, ends)
    for name, (sec, out) in interleaved(fns, runs).items():
        add(name, sec, out)
    for name in ("fm plain", "fm plain, 1 thread", "fm quality", "mapbox_earcut"):
        if name in rows:
            rows[name]["dev"] = deviation(rings, pts, np.asarray(rows[name].pop("_tris")).reshape(-1, 3))
    if exe is not None:
        add("CGAL CDT", *run_cgal(exe, rings, runs))
    for r in rows.values():
        r.pop("_tris", None)
    # Triangle crashes the interpreter on PSLGs with duplicate vertices
    # (touching rings): it is run only when all vertices are distinct.
    if triangle is not None and len(np.unique(pts, axis=0)) == len(pts):
        segs, off = [], 0
        for r in rings:
            k = len(r)
            segs.append(np.c_[np.arange(k) + off, (np.arange(k) + 1) % k + off])
            off += k
        pslg = dict(vertices=pts, segments=np.concatenate(segs))
        if len(rings) > 1:
            pslg["holes"] = hole_points(rings)
        s, res = median_time(lambda: triangle.triangulate(pslg, "p"), runs)
        tv = res["vertices"]
        # 'p' adds no vertex to a valid PSLG; if it did, count it as is.
        add("triangle", s, res["triangles"] if len(tv) == len(pts) else np.zeros((0, 3), np.int64))
        if len(tv) != len(pts):
            rows["triangle"]["triangles"] = len(res["triangles"])
        rows["triangle"].pop("_tris", None)
    return len(pts), len(rings) - 1, rows


EXPECTED_ERRORS = json.loads((ROOT / "tests" / "data" / "earcut" / "expected.json").read_text())["errors"]
COLS = ["fm plain", "fm plain, 1 thread", "fm quality", "fm quality+refine", "CGAL CDT", "mapbox_earcut",
        "triangle"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000, 10000, 100000])
    ap.add_argument("--no-fixtures", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "docs" / "bench" / "polygon.md"))
    args = ap.parse_args()
    exe = cgal_exe()
    cases = [(f"bench-{n // 1000}k", bench_polygon(n)) for n in args.sizes]
    if not args.no_fixtures:
        data = ROOT / "tests" / "data" / "earcut"
        for p in sorted(data.glob("*.json")):
            if p.stem == "expected":
                continue
            rings = [np.asarray(r, float).reshape(-1, 2) for r in json.loads(p.read_text())]
            if len(clean(rings)) == 0 or len(clean(rings)[0]) < 3:
                continue
            cases.append((p.stem, rings))
    results = []
    for name, rings in cases:
        valid = fm.check_polygon(clean(rings))[0] if clean(rings) else False
        n, h, rows = measure(rings, args.runs, exe)
        results.append((name, n, h, valid, rows))
        print(name, n, h, valid, {k: (round(v["seconds"] * 1e3, 3), v["triangles"]) for k, v in rows.items()},
              flush=True)

    lines = []
    lines.append("## Polygon triangulation benchmark\n")
    lines.append(f"Command: `python bench/bench_polygon.py --runs {args.runs}`  ")
    lines.append(f"Date: {datetime.date.today().isoformat()}  ")
    cpu = platform.processor() or platform.machine()
    try:
        cpu = next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    lines.append(f"Machine: {cpu}, {os.cpu_count()} cores (shared with other jobs), "
                 f"Python {platform.python_version()}, {platform.system()} {platform.release()}  ")
    lines.append(f"faultmesh {getattr(fm, '__version__', '?')}, mapbox_earcut "
                 f"{getattr(mapbox_earcut, '__version__', 'missing')}, triangle "
                 f"{getattr(triangle, '__version__', 'missing')}, CGAL 5.5 (Debian)\n")
    lines.append("What is timed: see the docstring of bench/bench_polygon.py (faultmesh, mapbox_earcut and "
                 "triangle: the Python call in this process, C++ with the GIL released; CGAL: the program's "
                 "own timer around CDT construction and inside marking, Epick). Median of "
                 f"{args.runs} runs after one warm-up call; faultmesh's three modes and mapbox_earcut run "
                 "interleaved (one call of each in turn) so that load changes on the shared machine hit both "
                 "alike.\n")
    lines.append("`valid`: faultmesh.check_polygon (strictly simple, disjoint rings). "
                 "Columns per library: median ms / triangles / % of triangles with minimum angle < 10° / < 20°. "
                 "triangle is not run on polygons with duplicate vertices (it crashes on them): —.\n")
    lines.append("Area deviation (earcut's test-suite measure, |sum of |triangle areas| - polygon area| / polygon "
                 "area, polygon area = |outer| - sum |holes|, in floating point on the cleaned rings): `dev` "
                 "= fm plain / fm quality / mapbox_earcut / the error tests/data/earcut/expected.json lists "
                 "for the fixture (0 when absent).\n")
    head = ("| polygon | n | holes | valid | " + " | ".join(COLS) +
            " | plain/earcut | plain 1 thread/earcut | refine/CGAL | dev |")
    lines.append(head)
    lines.append("|" + "---|" * (head.count("|") - 1))
    for name, n, h, valid, rows in results:
        cells = []
        for c in COLS:
            r = rows.get(c)
            cells.append("—" if r is None else
                         f"{r['seconds'] * 1e3:.3g} / {r['triangles']} / {100 * r['lt10']:.1f} / {100 * r['lt20']:.1f}")
        ratio1 = (rows["fm plain"]["seconds"] / rows["mapbox_earcut"]["seconds"]
                  if "mapbox_earcut" in rows and rows["mapbox_earcut"]["seconds"] > 0 else float("nan"))
        ratio1t = (rows["fm plain, 1 thread"]["seconds"] / rows["mapbox_earcut"]["seconds"]
                   if "mapbox_earcut" in rows and rows["mapbox_earcut"]["seconds"] > 0 else float("nan"))
        ratio2 = (rows["fm quality+refine"]["seconds"] / rows["CGAL CDT"]["seconds"]
                  if "CGAL CDT" in rows and rows["CGAL CDT"]["seconds"] > 0 else float("nan"))
        devs = " / ".join("—" if k not in rows else f"{rows[k]['dev']:.2g}"
                          for k in ("fm plain", "fm quality", "mapbox_earcut"))
        listed = EXPECTED_ERRORS.get(name, 0.0) if not name.startswith("bench-") else 0.0
        lines.append(f"| {name} | {n} | {h} | {'yes' if valid else 'no'} | " + " | ".join(cells) +
                     f" | {ratio1:.2f} | {ratio1t:.2f} | {ratio2:.2f} | {devs} / {listed:.2g} |")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    # Keep the hand-written sections (from the first "### " heading) of an
    # existing file.
    tail = ""
    if Path(args.out).is_file():
        old = Path(args.out).read_text()
        k = old.find("\n### ")
        if k >= 0:
            tail = old[k:]
    Path(args.out).write_text("\n".join(l for l in lines if l is not None) + "\n" + tail)
    print("wrote", args.out)


if __name__ == "__main__":
    main()
