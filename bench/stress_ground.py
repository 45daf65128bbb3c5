"""stress_ground(seed): block-faulted grounds in regimes that neither
faultmesh.grounds nor block_ground (tests/test_derive_blocks.py) covers:
5-10 layers of which about half are 2-10 m thin, under throws of 20-120 m;
one or two plane faults of 20-40, 40-80 or 80-89 degrees (two never meet
within 500 m of the area), normal or reverse; study areas of 5-9 vertices,
convex or not, half at UTM offsets; horizon picks at uniform random places,
in clusters or on 3-8 seismic lines, each layer on a random share of them,
none within a random 0-150 m of a fault (noise 0.3 m, rounded to the
centimetre); fault points on sticks or scattered over the fault.

The truth is analytic: conformable layers (a plane and a gentle sine), each
fault with a constant vertical throw (the footwall unchanged, the hanging
wall lower by the throw for a normal fault, higher for a reverse one).
Every point and depth lies in one block: z of a layer in a block is the
unfaulted z plus the offsets of the faults whose hanging wall it is in,
valid where it lies on that side of each fault. bench/stress.py derives,
builds and measures grounds against it; tests/data/derive holds grounds
that broke the build, as regressions.

    python bench/stress_ground.py START END   # print the grounds' parameters
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, List

import numpy as np

from faultmesh.dataset import Dataset, Fault, points_in_polygon

NOISE = 0.3


@dataclass
class FaultTruth:
    name: str
    kind: str
    throw: float
    dip: float
    anchor: np.ndarray
    down: np.ndarray      # horizontal unit vector towards which the fault dips
    along: np.ndarray
    z_mid: float

    @property
    def tan(self):
        return float(np.tan(np.deg2rad(self.dip)))

    @property
    def dz(self):
        return -self.throw if self.kind == "normal" else self.throw

    def z(self, X, Y):
        X, Y = np.asarray(X, float), np.asarray(Y, float)
        return self.z_mid - ((X - self.anchor[0]) * self.down[0] + (Y - self.anchor[1]) * self.down[1]) * self.tan

    def hdist(self, X, Y, Z):
        """horizontal distance from (X,Y,Z) to the fault at elevation Z."""
        return np.abs(np.asarray(Z, float) - self.z(X, Y)) / self.tan


@dataclass
class StressGround:
    seed: int
    dataset: Dataset
    faults: List[FaultTruth]
    layer_z0: Callable            # (i, X, Y) -> unfaulted top of layer i
    picks: dict                   # layer -> (n,3) noise-free true picks (same order as dataset points)
    params: dict = field(default_factory=dict)

    def block_z(self, i, X, Y, sides):
        """z of layer i in the block with ``sides`` (tuple of bool: hanging of fault k)."""
        z = self.layer_z0(i, X, Y)
        for f, h in zip(self.faults, sides):
            if h:
                z = z + f.dz
        return z

    def valid(self, z, X, Y, sides):
        ok = np.ones(np.shape(z), dtype=bool)
        for f, h in zip(self.faults, sides):
            fz = f.z(X, Y)
            ok &= (z > fz) if h else (z < fz)
        return ok

    def side_z(self, k, i, side, X, Y):
        """True z of layer i on ``side`` of fault k at XY (the other faults'
        sides chosen consistently; NaN if no consistent block)."""
        X, Y = np.asarray(X, float), np.asarray(Y, float)
        out = np.full(X.shape, np.nan)
        others = [j for j in range(len(self.faults)) if j != k]
        import itertools
        for combo in itertools.product([False, True], repeat=len(others)):
            sides = [None] * len(self.faults)
            sides[k] = side == "hanging"
            for j, h in zip(others, combo):
                sides[j] = h
            z = self.block_z(i, X, Y, sides)
            ok = np.ones(X.shape, bool)
            for j in others:
                fz = self.faults[j].z(X, Y)
                ok &= (z > fz) if sides[j] else (z < fz)
            out = np.where(np.isnan(out) & ok, z, out)
        return out


def _polygon(rng, R, concave):
    n = int(rng.integers(5, 10))
    while True:
        a = np.sort(rng.uniform(0, 2 * np.pi, n))
        gaps = np.diff(np.concatenate([a, [a[0] + 2 * np.pi]]))
        if gaps.min() > 0.25 * 2 * np.pi / n and gaps.max() < np.pi * 0.9:
            break
    r = R * (rng.uniform(0.72, 1.0, n) if concave else np.ones(n))
    P = np.column_stack([r * np.cos(a), r * np.sin(a)])
    asp = rng.uniform(0.65, 1.35)
    P[:, 0] *= asp
    P[:, 1] /= asp
    return P


def stress_ground(seed: int, force: dict | None = None) -> StressGround:
    force = force or {}
    rng = np.random.default_rng([seed, 2828])
    p = {}
    # --- area
    nf = force.get("nfaults", 2 if rng.random() < 0.4 else 1)
    R = rng.uniform(1600.0, 2500.0) if nf == 2 else rng.uniform(900.0, 2300.0)
    concave = bool(rng.random() < 0.5)
    utm = bool(rng.random() < 0.5)
    off = np.array([rng.uniform(3e5, 7e5), rng.uniform(4e6, 7e6)]) if utm else rng.uniform(-500, 500, 2) + R
    rot = rng.uniform(0, 2 * np.pi)
    P = _polygon(rng, R, concave)
    c, s = np.cos(rot), np.sin(rot)
    ring = P @ np.array([[c, s], [-s, c]]) + off
    ring = np.round(ring, 2)
    p.update(R=R, concave=concave, utm=utm, nverts=len(ring), nfaults=nf)
    # --- layers
    nl = int(force.get("nl", rng.integers(5, 11)))
    thin = rng.random(nl) < 0.5
    thick = np.where(thin, rng.uniform(2.0, 10.0, nl), rng.uniform(10.0, 40.0, nl))
    gx, gy = rng.uniform(-0.05, 0.05, 2)
    amp = rng.uniform(0.0, 10.0) if rng.random() < 0.6 else 0.0
    wl, ph = rng.uniform(1500.0, 4000.0), rng.uniform(0.0, 2 * np.pi, 2)
    top = -800.0
    ztops = top - np.concatenate([[0.0], np.cumsum(thick)[:-1]])
    p.update(nl=nl, thick=np.round(thick, 2).tolist(), grad=[float(gx), float(gy)], amp=float(amp))

    def layer_z0(i, X, Y):
        X, Y = np.asarray(X, float) - off[0], np.asarray(Y, float) - off[1]
        return (ztops[i] + gx * X + gy * Y
                + amp * np.sin(2 * np.pi * X / wl + ph[0]) * np.cos(2 * np.pi * Y / wl + ph[1]))

    z_mid = top - thick[:-1].sum() / 2
    # --- faults
    def draw_dip():
        r = rng.random()
        if r < 0.42:
            return "low", rng.uniform(20.0, 40.0)
        if r < 0.84:
            return "steep", rng.uniform(80.0, 89.0)
        return "mid", rng.uniform(40.0, 80.0)

    regime, dip = force.get("dip", draw_dip())
    if "dipval" in force:
        dip = force["dipval"]
    a = rng.uniform(0.0, np.pi)
    along, down = np.array([np.sin(a), np.cos(a)]), np.array([np.cos(a), -np.sin(a)])
    if rng.random() < 0.5:
        down = -down
    anchor = off + rng.uniform(-0.25, 0.25, 2) * R
    faults = []

    def kind_throw():
        return ("normal" if rng.random() < 0.65 else "reverse"), float(rng.uniform(20.0, 120.0))

    k1, t1 = kind_throw()
    faults.append(FaultTruth("F1", k1, t1, dip, anchor, down, along, z_mid))
    p["dips"] = [(regime, round(float(dip), 2))]
    if nf == 2:
        for attempt in range(50):
            da = np.deg2rad(rng.uniform(-6.0, 6.0))
            a2 = a + da
            along2 = np.array([np.sin(a2), np.cos(a2)])
            down2 = np.array([np.cos(a2), -np.sin(a2)])
            if down2 @ down < 0:
                down2 = -down2
            antithetic = dip >= 70 and rng.random() < 0.5
            if antithetic:
                down2 = -down2
            dip2 = float(np.clip(dip + rng.uniform(-4.0, 4.0), 20.0, 89.0))
            sep = rng.uniform(800.0, 1300.0) * (1 if rng.random() < 0.5 else -1)
            anchor2 = anchor + sep * down
            k2, t2 = kind_throw()
            f2 = FaultTruth("F2", k2, t2, dip2, anchor2, down2, along2, z_mid)
            # they must not meet within the area's bbox+500 over the depth range
            lo, hi = ring.min(0) - 500, ring.max(0) + 500
            gxs, gys = np.meshgrid(np.linspace(lo[0], hi[0], 60), np.linspace(lo[1], hi[1], 60))
            d1 = faults[0].z(gxs, gys)
            d2 = f2.z(gxs, gys)
            zlo = top - thick.sum() - 400
            zhi = top + 400
            inrange = ((d1 > zlo) & (d1 < zhi)) | ((d2 > zlo) & (d2 < zhi))
            # sign of (d1 - d2) must be constant where either is in range
            sg = np.sign(d1 - d2)[inrange]
            # also the second fault's trace must cross the area
            inside2 = points_in_polygon(np.array([anchor2]), ring)[0]
            if len(sg) and (np.all(sg > 0) or np.all(sg < 0)) and inside2:
                faults.append(f2)
                p["dips"].append(("anti" if antithetic else "syn", round(dip2, 2)))
                p["sep"] = float(sep)
                break
        else:
            p["nfaults"] = 1
    p["kinds"] = [f.kind for f in faults]
    p["throws"] = [round(f.throw, 2) for f in faults]
    # --- pick places
    lo, hi = ring.min(0), ring.max(0)
    area_wh = hi - lo
    mode = force.get("picks", ["uniform", "clustered", "lines"][int(rng.integers(0, 3))])
    n_target = int(rng.uniform(300, 900))
    if mode == "uniform":
        XY = lo + rng.uniform(0, 1, (int(n_target * 2.2), 2)) * area_wh
    elif mode == "clustered":
        nc = int(rng.integers(6, 20))
        C = lo + rng.uniform(0, 1, (nc, 2)) * area_wh
        sd = rng.uniform(80.0, 350.0)
        lab = rng.integers(0, nc, int(n_target * 2.2))
        XY = C[lab] + rng.normal(0, sd, (len(lab), 2))
    else:
        nlines = int(rng.integers(3, 9))
        step = rng.uniform(12.5, 40.0)
        L = float(np.hypot(*area_wh))
        pts = []
        for _ in range(nlines):
            o = lo + rng.uniform(0.15, 0.85, 2) * area_wh
            az = rng.uniform(0, np.pi)
            d = np.array([np.sin(az), np.cos(az)])
            t = np.arange(-L, L, step)
            pts.append(o + t[:, None] * d)
        XY = np.vstack(pts)
        p["lines"] = nlines
        p["line_step"] = round(float(step), 1)
    XY = XY[points_in_polygon(XY, ring)]
    if mode != "lines" and len(XY) > n_target:
        XY = XY[:n_target]
    gap = float(rng.uniform(0.0, 150.0))
    p.update(picks=mode, n_places=int(len(XY)), gap=round(gap, 1))
    X, Y = XY[:, 0], XY[:, 1]
    import itertools
    combos = list(itertools.product([False, True], repeat=len(faults)))
    points, truth = {}, {}
    g = StressGround(seed, None, faults, layer_z0, {}, p)
    frac = rng.uniform(0.6, 1.0, nl)
    for i in range(nl):
        keep_i = rng.random(len(X)) < frac[i]
        Ps = []
        for sides in combos:
            z = g.block_z(i, X, Y, sides)
            ok = g.valid(z, X, Y, sides) & keep_i
            for f in faults:
                ok &= f.hdist(X, Y, z) >= gap
            Ps.append(np.column_stack([X, Y, z])[ok])
        T = np.vstack(Ps)
        N = T.copy()
        N[:, 2] += rng.normal(0.0, NOISE, len(N))
        N = np.round(N, 2)
        points[f"L{i + 1}"] = N
        truth[f"L{i + 1}"] = T
    g.picks = truth
    # --- fault points
    fmode = force.get("fpoints", "sticks" if rng.random() < 0.5 else "scattered")
    p["fpoints"] = fmode
    zbot = top - thick.sum() - max([f.throw for f in faults if f.kind == "normal"] + [0.0]) - 100.0
    ztop = top + max([f.throw for f in faults if f.kind == "reverse"] + [0.0]) + 100.0
    # layer planes tilt: add gradient span
    span = abs(gx) * area_wh[0] + abs(gy) * area_wh[1] + amp
    zbot -= span / 2
    ztop += span / 2
    flts = []
    Lh = float(np.hypot(*area_wh))
    bb = np.array([[lo[0] - 100, lo[1] - 100], [hi[0] + 100, lo[1] - 100],
                   [hi[0] + 100, hi[1] + 100], [lo[0] - 100, hi[1] + 100]])
    for f in faults:
        if fmode == "sticks":
            zstep = rng.uniform(10.0, 40.0)
            zs = np.arange(zbot, ztop + 0.1, zstep)
            centres = f.anchor[None, :] + np.arange(-Lh, Lh, rng.uniform(100.0, 300.0))[:, None] * f.along[None, :]
            FP = np.array([[*(cc + f.down * (f.z_mid - z) / f.tan), z] for cc in centres for z in zs])
            stick = np.repeat(np.arange(len(centres)), len(zs))
            near = points_in_polygon(FP[:, :2], bb)
            keep = np.isin(stick, np.unique(stick[near]))
            # trim each stick to its part near the area (low-angle sticks run far)
            keep &= points_in_polygon(FP[:, :2], bb + np.array([[-400, -400], [400, -400], [400, 400], [-400, 400]]))
            FP, stick = FP[keep], stick[keep]
            # drop sticks of < 2 points
            u, cnt = np.unique(stick, return_counts=True)
            ok = np.isin(stick, u[cnt >= 2])
            flts.append(Fault(f.name, points=np.round(FP[ok], 2), sticks=stick[ok]))
        else:
            n = int(rng.uniform(150, 600))
            # uniform in (along, z) over the area's extent
            t = rng.uniform(-Lh / 2 - 200, Lh / 2 + 200, n * 3)
            z = rng.uniform(zbot, ztop, n * 3)
            XYf = f.anchor[None, :] + t[:, None] * f.along[None, :] + ((f.z_mid - z) / f.tan)[:, None] * f.down[None, :]
            ok = points_in_polygon(XYf, bb)
            FP = np.column_stack([XYf, z])[ok][:n]
            flts.append(Fault(f.name, points=np.round(FP, 2)))
    ds = Dataset(name=f"stress-{seed}", layers=list(points), boundary=ring, points=points, faults=flts)
    g.dataset = ds
    return g


if __name__ == "__main__":
    import sys
    for s in range(int(sys.argv[1]), int(sys.argv[2])):
        g = stress_ground(s)
        print(s, g.params, {k: len(v) for k, v in g.dataset.points.items()},
              [len(f.points) for f in g.dataset.faults])
