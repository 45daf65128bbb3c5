"""Convert the Claudius seismic interpretation into a faultmesh dataset (v1),
build the faulted model and write the section picture and quality report.

    PYTHONPATH=python python examples/claudius/make_dataset.py [--data tests/data/claudius]
        [--out examples/claudius/out]

The data (tests/data/claudius, see its licence files): ``claudius.csv`` holds
four horizons picked on 3D seismic (Carnarvon Basin, NW Australia; columns
X,Y,Z,val,feature_name; Z is elevation in metres, negative downwards, so the
shallowest horizon has the LARGEST Z), ``fault_points.csv`` 93 points on the
one fault surface that cuts them. README.md beside this file explains each
interpretation step; the functions below are those steps, importable (the
test tests/test_real_data.py uses :func:`convert`).
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]

# ---------------------------------------------------------------------------
# Interpretation parameters (metres). Chosen from the data, see README.md.
# ---------------------------------------------------------------------------
#: The study area is the box that every horizon's picks cover, shrunk by this.
SHRINK = 40.0
#: Exploration sections across the fault: spacing along strike, and the half
#: width of the band of picks projected onto each section.
SECTION_SPACING = 200.0
BAND = 90.0
#: Fault points within this distance (along strike) of a section fit its
#: local plane trace.
FAULT_BAND = 150.0
#: Picks used for a cutoff: on each side, between NEAR and FAR from the
#: fault (horizontal distance along the section); NEAR skips the smeared
#: picks right at the fault.
NEAR = 25.0
FAR = 400.0
#: Length of each side's polyline (far end to cutoff) and its vertex spacing.
WALL = 400.0
STEP = 100.0
#: A horizon counts as cut on a section when its cutoffs lie inside the
#: fault's interpreted depth range widened by this margin.
DEPTH_MARGIN = 50.0
#: An offset counts as resolved when it exceeds this many times the larger
#: RMS residual of the two side fits; otherwise the section gets zero throw.
RESOLVE = 2.0
#: Pseudo-wells: one per cell of a 3 x 3 grid over the study area.
WELL_GRID = 3


@dataclass
class Plane:
    """A fitted fault plane: ``centre`` (3,), upward unit ``normal`` (3,)."""

    centre: np.ndarray
    normal: np.ndarray
    residuals: np.ndarray  # signed distances of the fitted points (m)

    @property
    def dip(self) -> float:
        return math.degrees(math.acos(abs(float(self.normal[2]))))

    @property
    def dip_direction(self) -> float:
        """Azimuth (degrees clockwise from north) of the down-dip direction:
        the horizontal part of the upward normal points down dip."""
        return math.degrees(math.atan2(self.normal[0], self.normal[1])) % 360.0

    @property
    def strike(self) -> float:
        """Right-hand-rule strike: dip direction minus 90 degrees."""
        return (self.dip_direction - 90.0) % 360.0


@dataclass
class Conversion:
    """What :func:`convert` returns: the dataset and every number the
    interpretation produced (for the README and the test)."""

    dataset: object
    plane: Plane
    horizons: Dict[str, np.ndarray]
    fault_points: np.ndarray
    sections: List[Dict] = field(default_factory=list)
    held_out: Dict[str, np.ndarray] = field(default_factory=dict)
    info: Dict = field(default_factory=dict)


def _azimuth_vec(az: float) -> np.ndarray:
    a = math.radians(az)
    return np.array([math.sin(a), math.cos(a)])


# ---------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------
def layer_name(val: float) -> str:
    return f"val_{int(round(val))}"


def read_horizons(data_dir: Path) -> Dict[float, np.ndarray]:
    """Picks (n, 3) per ``val`` label. Rows without a val (25 orientation
    rows with normals nx, ny, nz) are not horizon picks and are skipped."""
    out: Dict[float, list] = {}
    with open(Path(data_dir) / "claudius.csv", newline="") as f:
        for r in csv.DictReader(f):
            if r["val"] == "":
                continue
            out.setdefault(float(r["val"]), []).append((float(r["X"]), float(r["Y"]), float(r["Z"])))
    return {k: np.array(v) for k, v in out.items()}


def read_fault_points(data_dir: Path) -> np.ndarray:
    return np.loadtxt(Path(data_dir) / "fault_points.csv", delimiter=",", skiprows=1,
                      usecols=(0, 1, 2))


def read_bbox(data_dir: Path) -> np.ndarray:
    """claudiusbb.txt: two rows (min, max) of x y z."""
    return np.loadtxt(Path(data_dir) / "claudiusbb.txt").reshape(2, 3)


# ---------------------------------------------------------------------------
# Step 1: layers top to bottom
# ---------------------------------------------------------------------------
def order_layers(h: Dict[float, np.ndarray]) -> List[float]:
    """Horizon labels ordered top to bottom by median elevation (Z is
    elevation, larger = shallower)."""
    return sorted(h, key=lambda v: -float(np.median(h[v][:, 2])))


# ---------------------------------------------------------------------------
# Step 2: study area
# ---------------------------------------------------------------------------
def study_area(h: Dict[float, np.ndarray], bbox: np.ndarray, shrink: float = SHRINK) -> np.ndarray:
    """The box covered by every horizon's picks (inside claudiusbb.txt),
    shrunk by ``shrink`` so each layer has picks near every side."""
    lo = np.max([a[:, :2].min(axis=0) for a in h.values()] + [bbox[0, :2]], axis=0) + shrink
    hi = np.min([a[:, :2].max(axis=0) for a in h.values()] + [bbox[1, :2]], axis=0) - shrink
    return np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])


# ---------------------------------------------------------------------------
# Step 3: the fault
# ---------------------------------------------------------------------------
def fit_plane(p: np.ndarray) -> Plane:
    """Least-squares plane (orthogonal distances) through points p (n, 3)."""
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c)
    n = vt[2] if vt[2, 2] >= 0 else -vt[2]
    return Plane(c, n, (p - c) @ n)


@dataclass
class SectionFrame:
    """A vertical section: ``origin`` (2,), unit ``u`` (2,) along the section
    (the fault's dip direction), ``a`` = along-strike position of the section."""

    name: str
    origin: np.ndarray
    azimuth: float
    a: float

    @property
    def u(self) -> np.ndarray:
        return _azimuth_vec(self.azimuth)

    def s(self, xy: np.ndarray) -> np.ndarray:
        return (np.asarray(xy)[:, :2] - self.origin) @ self.u

    def t(self, xy: np.ndarray) -> np.ndarray:
        """Signed distance off the section line (along strike)."""
        u = self.u
        return (np.asarray(xy)[:, :2] - self.origin) @ np.array([-u[1], u[0]])

    def xyz(self, s: np.ndarray, z: np.ndarray) -> np.ndarray:
        s = np.asarray(s, dtype=np.float64).reshape(-1)
        xy = self.origin[None, :] + s[:, None] * self.u[None, :]
        return np.column_stack([xy, np.asarray(z, dtype=np.float64).reshape(-1)])


def plane_trace_fit(sec: SectionFrame, fpts: np.ndarray, plane: Plane,
                    band: float = FAULT_BAND) -> Tuple[float, float, Dict]:
    """The fault trace on ``sec`` as the line s = p0 + p1 * z: least squares
    on the fault points within ``band`` of the section (projected onto it)
    when there are at least 6 of them spanning 300 m of depth, else the
    global plane. Returns (p0, p1, info)."""
    t = sec.t(fpts)
    m = np.abs(t) <= band
    # The global plane on the section: n_h.(o + s u - c_h) + n_z (z - c_z) = 0.
    nh, nz = plane.normal[:2], plane.normal[2]
    k = float(nh @ sec.u)
    g0 = -(float(nh @ (sec.origin - plane.centre[:2])) - nz * plane.centre[2]) / k
    g1 = -nz / k
    info = {"fault_points": int(m.sum())}
    if m.sum() >= 6 and np.ptp(fpts[m, 2]) >= 300.0:
        s = sec.s(fpts[m])
        z = fpts[m, 2]
        A = np.column_stack([np.ones(m.sum()), z])
        (p0, p1), *_ = np.linalg.lstsq(A, s, rcond=None)
        r = s - (p0 + p1 * z)
        info.update(source="local", rms=float(np.sqrt(np.mean(r ** 2))),
                    z_range=[float(z.min()), float(z.max())])
        return float(p0), float(p1), info
    info.update(source="plane", rms=float(np.sqrt(np.mean(plane.residuals ** 2))),
                z_range=[float(fpts[:, 2].min()), float(fpts[:, 2].max())])
    return g0, g1, info


def _side_fit(s: np.ndarray, z: np.ndarray) -> Optional[Tuple[np.ndarray, float]]:
    """Straight-line fit z = c0 + c1 s with one pass of 2.5-sigma outlier
    rejection; None with fewer than 5 points. Returns (coef, rms)."""
    if len(s) < 5:
        return None
    A = np.column_stack([np.ones(len(s)), s])
    c, *_ = np.linalg.lstsq(A, z, rcond=None)
    r = z - A @ c
    sd = float(np.std(r))
    keep = np.abs(r) <= 2.5 * sd + 1e-9
    if keep.sum() >= 5 and not keep.all():
        c, *_ = np.linalg.lstsq(A[keep], z[keep], rcond=None)
        r = z[keep] - A[keep] @ c
    return c, float(np.sqrt(np.mean(r ** 2)))


def _cutoff(c: np.ndarray, p0: float, p1: float) -> Tuple[float, float]:
    """Intersection of z = c0 + c1 s with s = p0 + p1 z."""
    # z = c0 + c1 (p0 + p1 z)  ->  z (1 - c1 p1) = c0 + c1 p0
    z = (c[0] + c[1] * p0) / (1.0 - c[1] * p1)
    return p0 + p1 * z, z


def _wall_polyline(s: np.ndarray, z: np.ndarray, s_cut: float, z_cut: float,
                   direction: int) -> np.ndarray:
    """A side's polyline in section coordinates: vertices every STEP from the
    cutoff out to WALL (median of the picks within STEP/2 of each vertex,
    the fitted line's value where no pick is near), ordered far end ->
    cutoff for the footwall (direction -1: the wall lies at smaller s) and
    cutoff -> far end for the hanging wall (direction +1)."""
    out = [(s_cut, z_cut)]
    n = int(round(WALL / STEP))
    for i in range(1, n + 1):
        sv = s_cut + direction * i * STEP
        m = np.abs(s - sv) <= 0.5 * STEP
        if m.sum() >= 2:
            out.append((sv, float(np.median(z[m]))))
    arr = np.array(out)
    if direction < 0:
        arr = arr[::-1]
    return arr


def fault_sections(plane: Plane, fpts: np.ndarray, h: Dict[str, np.ndarray], ring: np.ndarray,
                   spacing: float = SECTION_SPACING) -> Tuple[List[SectionFrame], List[Dict]]:
    """Exploration sections perpendicular to strike, ordered along strike
    (by increasing along-strike position), and per section the plane trace
    and, for every horizon the fault cuts there, the footwall and
    hanging-wall polylines (section coordinates) with the fits behind them."""
    az = plane.dip_direction
    strike_v = _azimuth_vec(plane.strike)
    c = plane.centre[:2]
    a_f = (fpts[:, :2] - c) @ strike_v
    lo, hi = float(a_f.min()), float(a_f.max())
    n = max(2, int(math.floor((hi - lo - spacing) / spacing)) + 1)
    centre_a = 0.5 * (lo + hi)
    pos = centre_a + (np.arange(n) - 0.5 * (n - 1)) * spacing
    frames, traces = [], []
    u = _azimuth_vec(az)
    for i, a in enumerate(pos):
        # Origin: 1 km up dip of the fault centre line, so s > 0 near the fault.
        origin = c + a * strike_v - 1000.0 * u
        sec = SectionFrame(f"S{i + 1}", origin, az, float(a))
        p0, p1, finfo = plane_trace_fit(sec, fpts, plane)
        zt, zb = finfo["z_range"][1], finfo["z_range"][0]
        tr = {"section": sec.name, "plane_fit": finfo, "p": (p0, p1), "layers": {},
              "skipped": {}}
        for name, pts in h.items():
            inside = _in_ring(pts[:, :2], ring)
            m = (np.abs(sec.t(pts)) <= BAND) & inside
            s, z = sec.s(pts[m]), pts[m, 2]
            d = s - (p0 + p1 * z)  # < 0: footwall (up dip), > 0: hanging wall
            fm = (d <= -NEAR) & (d >= -FAR)
            hm = (d >= NEAR) & (d <= FAR)
            ff, hf = _side_fit(s[fm], z[fm]), _side_fit(s[hm], z[hm])
            if ff is None or hf is None:
                tr["skipped"][name] = f"too few picks (foot {int(fm.sum())}, hanging {int(hm.sum())})"
                continue
            sf, zf = _cutoff(ff[0], p0, p1)
            sh, zh = _cutoff(hf[0], p0, p1)
            if not (zb - DEPTH_MARGIN <= min(zf, zh) and max(zf, zh) <= zt + DEPTH_MARGIN):
                tr["skipped"][name] = (f"cutoffs at z {zf:.0f}/{zh:.0f} outside the fault's "
                                       f"depth range {zb:.0f}..{zt:.0f}")
                continue
            # An offset smaller than twice the scatter of the side fits is
            # not resolved by the picks: zero throw there, both cutoffs at
            # the fault at the mean of the two estimates.
            throw_fit = float(zf - zh)
            resolved = abs(throw_fit) >= RESOLVE * max(ff[1], hf[1])
            if not resolved:
                zf = zh = 0.5 * (zf + zh)
                sf = sh = p0 + p1 * zf
            foot = _wall_polyline(s[d < 0], z[d < 0], sf, zf, -1)
            hang = _wall_polyline(s[d > 0], z[d > 0], sh, zh, +1)
            tr["layers"][name] = {
                "foot": foot, "hanging": hang,
                "throw": float(zf - zh), "heave": float(sh - sf),
                "throw_fit": throw_fit, "resolved": resolved,
                "foot_fit": {"n": int(fm.sum()), "rms": ff[1], "slope": float(ff[0][1])},
                "hanging_fit": {"n": int(hm.sum()), "rms": hf[1], "slope": float(hf[0][1])}}
        # Plane trace top down over the fault's depth range, every ~100 m.
        k = max(2, int(math.ceil((zt - zb) / 100.0)) + 1)
        zz = np.linspace(zt, zb, k)
        tr["plane"] = np.column_stack([p0 + p1 * zz, zz])
        frames.append(sec)
        traces.append(tr)
    return frames, traces


def _in_ring(xy: np.ndarray, ring: np.ndarray) -> np.ndarray:
    from faultmesh.dataset import points_in_polygon

    return points_in_polygon(np.ascontiguousarray(xy[:, :2]), ring)


# ---------------------------------------------------------------------------
# Pseudo-wells (the format requires a boreholes CSV with rows)
# ---------------------------------------------------------------------------
def pseudo_wells(h: Dict[str, np.ndarray], ring: np.ndarray, plane: Plane,
                 grid: int = WELL_GRID, keep_off: float = 600.0) -> List[Tuple[str, float, float, str, float]]:
    """Pseudo-wells at the cell centres of a grid x grid lattice over the
    study area (skipping cells within ``keep_off`` of the fault centre):
    per layer, z at the well is the value of a plane fitted to the layer's
    8 nearest picks (a well that "drills" the interpreted horizons). Rows
    (hole_id, x, y, layer, z)."""
    from scipy.spatial import cKDTree

    lo, hi = ring.min(axis=0), ring.max(axis=0)
    rows = []
    k = 0
    for j in range(grid):
        for i in range(grid):
            xy = lo + (np.array([i, j]) + 0.5) / grid * (hi - lo)
            if np.hypot(*(xy - plane.centre[:2])) < keep_off:
                continue
            k += 1
            for name, pts in h.items():
                tree = cKDTree(pts[:, :2])
                _, idx = tree.query(xy, k=8)
                P = pts[idx]
                A = np.column_stack([np.ones(8), P[:, 0] - xy[0], P[:, 1] - xy[1]])
                coef, *_ = np.linalg.lstsq(A, P[:, 2], rcond=None)
                rows.append((f"PW{k}", float(xy[0]), float(xy[1]), name, float(coef[0])))
    return rows


# ---------------------------------------------------------------------------
# The whole conversion
# ---------------------------------------------------------------------------
def convert(data_dir: Path, holdout: float = 0.0, seed: int = 0,
            holdout_clearance: float = 500.0) -> Conversion:
    """The faultmesh dataset of the Claudius data in ``data_dir``.

    ``holdout`` > 0 withholds that fraction of each layer's picks farther
    than ``holdout_clearance`` (horizontally) from every fault point (the
    region the fault patch replaces) from the dataset; they are returned in
    ``held_out`` to measure how well the surfaces interpolate real picks."""
    from faultmesh.dataset import Boreholes, Dataset, Fault, Section, Trace
    from scipy.spatial import cKDTree

    data_dir = Path(data_dir)
    raw = read_horizons(data_dir)
    order = order_layers(raw)
    h = {layer_name(v): raw[v] for v in order}
    fpts = read_fault_points(data_dir)
    ring = study_area(raw, read_bbox(data_dir))
    plane = fit_plane(fpts)

    held: Dict[str, np.ndarray] = {}
    used = dict(h)
    if holdout > 0:
        rng = np.random.default_rng(seed)
        ftree = cKDTree(fpts[:, :2])
        for name, pts in h.items():
            far = ftree.query(pts[:, :2])[0] > holdout_clearance
            pick = far & (rng.random(len(pts)) < holdout) & _in_ring(pts, ring)
            held[name] = pts[pick]
            used[name] = pts[~pick]

    frames, traces = fault_sections(plane, fpts, used, ring)
    sections = {f.name: Section(f.name, f.origin, f.azimuth) for f in frames}
    cut = [tr for tr in traces if tr["layers"]]
    ds_traces = []
    for f, tr in zip(frames, traces):
        if not tr["layers"]:
            continue
        layers = {name: {"foot": f.xyz(v["foot"][:, 0], v["foot"][:, 1]),
                         "hanging": f.xyz(v["hanging"][:, 0], v["hanging"][:, 1])}
                  for name, v in tr["layers"].items()}
        ds_traces.append(Trace(f.name, f.xyz(tr["plane"][:, 0], tr["plane"][:, 1]), layers))
    if not ds_traces:
        raise RuntimeError("claudius: no section shows a horizon cut by the fault")
    throws = [v["throw"] for tr in cut for v in tr["layers"].values() if v["resolved"]]
    if not throws:
        raise RuntimeError("claudius: the picks resolve no offset on any section")
    kind = "normal" if float(np.median(throws)) > 0 else "reverse"

    # Ends. Along strike (increasing a) the sections run toward the strike
    # azimuth. An end where the fault points stop inside the study area gets
    # a tip on the cutoff line of the deepest cut layer, at the last fault
    # point's along-strike position; an end where they reach (or pass) the
    # study boundary gets no tip: the builder extends the fault to it.
    strike_v = _azimuth_vec(plane.strike)
    a_f = (fpts[:, :2] - plane.centre[:2]) @ strike_v
    a_ring = (ring - plane.centre[:2]) @ strike_v
    tips = []
    ends_info = {}
    cut_frames = [f for f, tr in zip(frames, traces) if tr["layers"]]
    for end, (fr, tr_last, a_end) in enumerate(((cut_frames[0], cut[0], float(a_f.min())),
                                                (cut_frames[-1], cut[-1], float(a_f.max())))):
        # Does the fault reach the boundary at this end? Walk from the end
        # section's cutoff along strike to the fault points' extent.
        lay = list(tr_last["layers"])[-1]
        v = tr_last["layers"][lay]
        mid_s = 0.5 * (v["foot"][-1, 0] + v["hanging"][0, 0])
        mid = fr.xyz([mid_s], [0.0])[0, :2]
        tip_xy = mid + (a_end - fr.a) * strike_v
        reaches = not bool(_in_ring(tip_xy[None, :], ring)[0])
        if reaches:
            ends_info[end] = {"closure": "extended to the study boundary",
                              "fault_point_extent_a": a_end}
        else:
            tips.append(tip_xy)
            ends_info[end] = {"closure": "tip", "tip": tip_xy.tolist(), "layer": lay,
                              "fault_point_extent_a": a_end}
    fault = Fault("claudius_fault", kind, None, np.array(tips).reshape(-1, 2), ds_traces)

    wells = pseudo_wells(h, ring, plane)
    bh = Boreholes(np.array([w[0] for w in wells]), np.array([[w[1], w[2]] for w in wells]),
                   np.array([w[3] for w in wells]), np.array([w[4] for w in wells]))
    ds = Dataset(name="claudius", layers=list(h), boundary=ring, boreholes=bh,
                 points={k: v for k, v in used.items()}, sections=sections, faults=[fault],
                 crs="UTM (zone 50S assumed; the source gives no CRS); Z = elevation, m")
    info = {
        "layers": {name: {"val": float(v), "picks": int(len(raw[v])),
                          "median_z": float(np.median(raw[v][:, 2]))}
                   for name, v in zip(h, order)},
        "boundary": ring.tolist(),
        "plane": {"centre": plane.centre.tolist(), "normal": plane.normal.tolist(),
                  "dip": plane.dip, "dip_direction": plane.dip_direction, "strike": plane.strike,
                  "rms": float(np.sqrt(np.mean(plane.residuals ** 2))),
                  "max_abs": float(np.abs(plane.residuals).max()),
                  "fault_z_range": [float(fpts[:, 2].min()), float(fpts[:, 2].max())]},
        "kind": kind, "ends": ends_info, "wells": len({w[0] for w in wells}),
        "sections": [{"name": f.name, "origin": f.origin.tolist(), "azimuth": f.azimuth,
                      "along_strike": f.a, "plane_fit": tr["plane_fit"],
                      "layers": {k: {kk: vv for kk, vv in v.items() if kk not in ("foot", "hanging")}
                                 for k, v in tr["layers"].items()},
                      "skipped": tr["skipped"]} for f, tr in zip(frames, traces)],
    }
    return Conversion(ds, plane, h, fpts, traces, held, info)


# ---------------------------------------------------------------------------
# Checks used by the example and the test
# ---------------------------------------------------------------------------
def surface_misfit(model, points: Dict[str, np.ndarray]) -> Dict[str, Dict[str, float]]:
    """|dz| between each layer surface and the given picks (per layer:
    median, 90th percentile, max, count; picks no triangle covers are
    skipped)."""
    from faultmesh.report import evaluate_surface

    out = {}
    for name, p in points.items():
        if len(p) == 0:
            continue
        lo, hi, nh = evaluate_surface(model.surfaces[name], p[:, 0], p[:, 1])
        ok = nh > 0
        dz = np.abs(0.5 * (lo[ok] + hi[ok]) - p[ok, 2])
        out[name] = {"n": int(ok.sum()), "median": float(np.median(dz)),
                     "p90": float(np.percentile(dz, 90)), "max": float(dz.max())}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(REPO / "tests" / "data" / "claudius"))
    ap.add_argument("--out", default=str(HERE / "out"))
    args = ap.parse_args(argv)
    import faultmesh

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    conv = convert(Path(args.data))
    js = conv.dataset.save(out / "dataset")
    print(f"dataset written: {js}")
    ds = faultmesh.load_dataset(js)
    model = faultmesh.build_model(ds)
    model.check()
    print("Model.check(): passed")
    model.save(out / "claudius.3dt")
    model.save(out / "claudius.ts")
    rep = model.quality()
    rep.to_markdown_file(out / "quality.md")
    info = dict(conv.info)
    info["check"] = "passed"
    info["fault_ends"] = model.metadata["faults"]
    info["gaps"] = [{"layer": g.layer, "triangles": int(len(g.triangles)),
                     "n_vertices": g.n_vertices, "n_holes": g.n_holes} for g in model.gaps]
    info["timings"] = model.metadata["timings"]
    # Fit to the picks (all of them; the test withholds picks for a fair figure).
    info["misfit_all_picks"] = surface_misfit(model, conv.horizons)
    # Section pictures across the fault: every exploration section (the
    # largest-throw one is section.png).
    best = max(conv.info["sections"],
               key=lambda s: max([abs(v["throw"]) for v in s["layers"].values()] or [0.0]))
    for s in conv.info["sections"]:
        sec = model.section(s["origin"], s["azimuth"])
        thr = ", ".join(f"{k} throw {v['throw']:.0f} m" for k, v in s["layers"].items())
        name = "section.png" if s is best else f"section_{s['name']}.png"
        sec.plot(out / name, title=f"Claudius: section {s['name']} across the fault "
                                   f"(azimuth {s['azimuth']:.0f}; {thr})")
        if s is best:
            sec.to_csv(out / "section.csv")
    with open(out / "report.json", "w") as f:
        json.dump(info, f, indent=1, default=float)
    print(json.dumps({k: info[k] for k in ("plane", "kind", "ends", "check")}, indent=1, default=float))
    for s in info["sections"]:
        print(s["name"], {k: (round(v["throw"], 1), round(v["heave"], 1)) for k, v in s["layers"].items()},
              s["skipped"])
    print("misfit", json.dumps(info["misfit_all_picks"], indent=1))
    print("gaps", info["gaps"])
    print(f"total build {info['timings']['total']:.2f} s")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(REPO / "python"))
    sys.exit(main())
