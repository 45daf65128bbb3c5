"""A ground-truth geology: smooth layer tops cut by dip-slip faults.

The generated datasets (:mod:`faultmesh.datasets`) are sampled from a
:class:`Geology`, so a model built from them can be scored against the truth.

Model
-----
* Each layer has an *unfaulted* top ``z0(layer, X, Y)``, a smooth function of
  local coordinates (metres from ``Geology.origin``).
* A fault has a reference trace (its line at elevation ``z_ref``): a straight
  chord through ``anchor`` with azimuth ``strike`` (degrees clockwise from
  north), bent sideways by ``c(u) = bend * ((u - um) / hl)**2``. With ``u`` the
  along-strike and ``w`` the dip-direction coordinate (dip direction = strike +
  90 degrees) and ``d = w - c(u)``, the fault surface is
  ``z_plane = z_ref - d * tan(dip)``: points above it are the hanging wall (HW),
  points below the footwall (FW).
* Displacement is pure dip-slip of the hanging wall, defined by its exact
  inverse: a final HW point at map position p came from
  ``p - sgn * h * n`` (n = dip direction, h = t / tan(dip)) and elevation
  ``z + sgn * t`` (``sgn`` = +1 normal: the HW went down, -1 reverse: it went
  up). ``t = throw * factor[layer] * taper(u) * decay(d)``: ``taper`` is
  ``1 - xi**2`` between the tips (zero at them: the fault pinches out),
  ``decay`` is 1 up to ``flat`` metres into the hanging wall and falls to 0 over
  ``decay`` metres (a cosine), so a fault moves rock only near itself. Because
  the slip vector lies in the fault surface, the surface maps onto itself: the
  construction is kinematically consistent and needs no root finding. The
  footwall does not move. ``factor`` may differ per layer (e.g. 0 for a layer
  the fault does not reach).
* Several faults: faults act in list order (oldest first) and their surfaces
  are fixed in the final state. Independent faults must have disjoint zones of
  influence (``Geology.check_disjoint``). A fault may *abut* an older one
  (a T-crossing): it then displaces only rock on one side (``"foot"`` or
  ``"hanging"``) of the older fault's surface.

At a map point a layer can have several sheets (values): one away from
faults, two in the overlap band of a reverse fault (hanging-wall copy above
the footwall copy: a vertical borehole hits the layer twice), none in the gap
of a normal fault. :meth:`Geology.sheets` lists them; :meth:`Geology.truth`
returns ONE value per point:

* one sheet: that value;
* reverse-fault overlap band: the UPPER sheet, i.e. the hanging-wall value
  (what a vertical borehole meets first, and what
  :meth:`faultmesh.Dataset.layer_points` keeps);
* normal-fault gap: the elevation of the fault surface, i.e. the fault strip
  that joins the footwall cutoff to the hanging-wall cutoff in a faulted layer
  surface.

:meth:`Geology.in_fault_band` says where a layer is absent or multi-valued.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

__all__ = ["FaultModel", "Geology", "smooth_field"]


def smooth_field(base: float = 0.0, gradient: Sequence[float] = (0.0, 0.0),
                 waves: Sequence[Sequence[float]] = (),
                 bumps: Sequence[Sequence[float]] = ()) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """A smooth, non-planar scalar field of local coordinates (X, Y):
    ``base + gx X + gy Y + sum amp sin(kx X + ky Y + phase)
    + sum amp exp(-r^2 / (2 sigma^2))`` with ``waves`` rows (amp, kx, ky, phase)
    (k in radians per metre) and ``bumps`` rows (amp, cx, cy, sigma). The
    returned function carries ``max_slope``, an upper bound of its gradient's
    length (see :class:`Geology`)."""
    waves_a = np.asarray(waves, dtype=np.float64).reshape(-1, 4)
    bumps_a = np.asarray(bumps, dtype=np.float64).reshape(-1, 4)
    g = np.asarray(gradient, dtype=np.float64).reshape(2)

    def f(X, Y):
        X = np.asarray(X, dtype=np.float64)
        Y = np.asarray(Y, dtype=np.float64)
        z = base + g[0] * X + g[1] * Y
        for a, kx, ky, ph in waves_a:
            z = z + a * np.sin(kx * X + ky * Y + ph)
        for a, cx, cy, s in bumps_a:
            z = z + a * np.exp(-((X - cx) ** 2 + (Y - cy) ** 2) / (2.0 * s * s))
        return z

    # An upper bound of |grad f| everywhere (Geology uses it to skip faults
    # that provably cannot act at a point): |g| + sum |amp| |k| over the waves
    # + sum |amp| / sigma * exp(-1/2) over the bumps (the largest slope of a
    # Gaussian, at r = sigma).
    f.max_slope = float(np.hypot(*g) + np.sum(np.abs(waves_a[:, 0]) * np.hypot(waves_a[:, 1], waves_a[:, 2]))
                        + np.sum(np.abs(bumps_a[:, 0]) / np.abs(bumps_a[:, 3])) * np.exp(-0.5))
    return f


def layer_stack(names: Sequence[str], top, thicknesses: Sequence) -> Dict[str, Callable]:
    """Layer surfaces (top to bottom) from the top surface and the interval
    thicknesses below it: layer i lies ``sum(thicknesses[:i])`` below
    ``top``. Each surface carries ``max_slope`` (the sum of its parts')."""
    def make(i):
        def f(X, Y):
            z = top(X, Y)
            for t in thicknesses[:i]:
                z = z - t(X, Y)
            return z
        f.max_slope = top.max_slope + sum(t.max_slope for t in thicknesses[:i])
        return f

    return {name: make(i) for i, name in enumerate(names)}


@dataclass
class FaultModel:
    """One dip-slip fault of a :class:`Geology` (see the module docstring).

    Coordinates are local (metres from ``Geology.origin``). ``u_range`` is the
    along-strike extent (u measured from ``anchor`` along ``strike``): the
    throw tapers to zero at both ends; an end outside the study area makes the
    fault reach the boundary. ``layers`` maps the layers the fault displaces to
    a throw factor (others are not displaced). ``abuts = (older_fault, side)``
    restricts the displacement to the ``side`` ("foot" or "hanging") of an
    older fault (T-crossing). ``tips`` names which ends ("start", "end") are
    pinch-out points inside the area (reported as the dataset's tips)."""

    name: str
    kind: str
    anchor: Sequence[float]
    strike: float
    dip: float
    throw: float
    u_range: Tuple[float, float]
    z_ref: float
    layers: Dict[str, float]
    bend: float = 0.0
    flat: float = 150.0
    decay: float = 500.0
    abuts: Optional[Tuple[str, str]] = None
    group: Optional[str] = None
    tips: Tuple[str, ...] = ("start", "end")

    def __post_init__(self) -> None:
        if self.kind not in ("normal", "reverse"):
            raise ValueError(f"FaultModel {self.name!r}: kind must be 'normal' or 'reverse'")
        if not (0.0 < self.dip < 90.0):
            raise ValueError(f"FaultModel {self.name!r}: dip must be in (0, 90) degrees, got {self.dip}")
        u1, u2 = map(float, self.u_range)
        if not u1 < u2:
            raise ValueError(f"FaultModel {self.name!r}: u_range must be increasing, got {self.u_range}")
        self.u_range = (u1, u2)
        self.anchor = np.asarray(self.anchor, dtype=np.float64).reshape(2)
        a = np.deg2rad(self.strike)
        self.sdir = np.array([np.sin(a), np.cos(a)])    # along strike
        self.ndir = np.array([np.cos(a), -np.sin(a)])   # dip direction (strike + 90)
        self.tan_dip = float(np.tan(np.deg2rad(self.dip)))
        self.sgn = 1.0 if self.kind == "normal" else -1.0
        self.um = 0.5 * (u1 + u2)
        self.hl = 0.5 * (u2 - u1)

    # -- local frame ------------------------------------------------------
    def uw(self, X, Y) -> Tuple[np.ndarray, np.ndarray]:
        dX = np.asarray(X, dtype=np.float64) - self.anchor[0]
        dY = np.asarray(Y, dtype=np.float64) - self.anchor[1]
        return dX * self.sdir[0] + dY * self.sdir[1], dX * self.ndir[0] + dY * self.ndir[1]

    def xy(self, u, w) -> np.ndarray:
        """Local XY (k, 2) of fault-frame coordinates (u, w)."""
        u = np.asarray(u, dtype=np.float64).reshape(-1)
        w = np.asarray(w, dtype=np.float64).reshape(-1)
        return self.anchor[None, :] + u[:, None] * self.sdir[None, :] + w[:, None] * self.ndir[None, :]

    def bend_offset(self, u) -> np.ndarray:
        return self.bend * ((np.asarray(u, dtype=np.float64) - self.um) / self.hl) ** 2

    def d(self, X, Y) -> np.ndarray:
        """Signed horizontal distance into the hanging wall from the reference trace."""
        u, w = self.uw(X, Y)
        return w - self.bend_offset(u)

    def plane_z(self, X, Y) -> np.ndarray:
        """Elevation of the fault surface above local (X, Y)."""
        return self.z_ref - self.d(X, Y) * self.tan_dip

    def taper(self, u) -> np.ndarray:
        xi = (np.asarray(u, dtype=np.float64) - self.um) / self.hl
        return np.clip(1.0 - xi * xi, 0.0, None)

    def decay_factor(self, d) -> np.ndarray:
        d = np.asarray(d, dtype=np.float64)
        r = np.clip((d - self.flat) / self.decay, 0.0, 1.0)
        return 0.5 * (1.0 + np.cos(np.pi * r))

    def throw_at(self, layer: str, X, Y) -> np.ndarray:
        """Vertical throw (m, >= 0) of ``layer`` at hanging-wall position (X, Y)."""
        f = float(self.layers.get(layer, 0.0))
        u, w = self.uw(X, Y)
        if f == 0.0:
            return np.zeros_like(u)
        d = w - self.bend_offset(u)
        return self.throw * f * self.taper(u) * self.decay_factor(d)

    def backward(self, layer: str, X, Y):
        """Pre-fault position of a final hanging-wall point of ``layer``:
        returns (X', Y', dz) with z_before = z_after + dz."""
        t = self.throw_at(layer, X, Y)
        h = t / self.tan_dip
        return (np.asarray(X) - self.sgn * h * self.ndir[0],
                np.asarray(Y) - self.sgn * h * self.ndir[1], self.sgn * t)


@dataclass
class Geology:
    """Layers (top to bottom) with unfaulted tops, cut by faults (oldest first).

    Public methods take GLOBAL coordinates (x, y) and subtract ``origin``;
    fault parameters and ``surfaces`` use local coordinates."""

    layers: List[str]
    surfaces: Dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]]
    faults: List[FaultModel] = field(default_factory=list)
    origin: np.ndarray = field(default_factory=lambda: np.zeros(2))
    #: Upper bound of the slope |grad z0| of each layer's unfaulted top (None:
    #: taken from the surface functions' ``max_slope`` attribute, which
    #: :func:`smooth_field` sets, where there is one). Only used to skip work:
    #: with a bound, faults that provably cannot decide a point's sheets are
    #: left out of the enumeration (same results, see ``_states``).
    slopes: Optional[Dict[str, Optional[float]]] = None

    def __post_init__(self) -> None:
        self.origin = np.asarray(self.origin, dtype=np.float64).reshape(2)
        names = [f.name for f in self.faults]
        if len(set(names)) != len(names):
            raise ValueError(f"Geology: duplicate fault names {names}")
        self._index = {f.name: i for i, f in enumerate(self.faults)}
        for i, f in enumerate(self.faults):
            if f.abuts is not None:
                parent, side = f.abuts
                if parent not in self._index or self._index[parent] >= i:
                    raise ValueError(f"Geology: fault {f.name!r} abuts {parent!r}, which must be an "
                                     "older fault (earlier in the list)")
                if side not in ("foot", "hanging"):
                    raise ValueError(f"Geology: fault {f.name!r}: abut side must be 'foot' or 'hanging'")
            for lay in f.layers:
                if lay not in self.layers:
                    raise ValueError(f"Geology: fault {f.name!r} displaces unknown layer {lay!r}")
        missing = [lay for lay in self.layers if lay not in self.surfaces]
        if missing:
            raise ValueError(f"Geology: no surface for layers {missing}")
        given = dict(self.slopes or {})
        self.slopes = {}
        for lay in self.layers:
            v = given.get(lay, getattr(self.surfaces[lay], "max_slope", None))
            if v is not None and not (np.isfinite(v) and v >= 0.0):
                raise ValueError(f"Geology: slope bound of layer {lay!r} must be finite and >= 0, got {v}")
            self.slopes[lay] = None if v is None else float(v)

    # -- helpers ------------------------------------------------------------
    def fault(self, name: str) -> FaultModel:
        return self.faults[self._index[name]]

    def local(self, x, y) -> Tuple[np.ndarray, np.ndarray]:
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        return x - self.origin[0], y - self.origin[1]

    def _check_layer(self, layer: str) -> None:
        if layer not in self.surfaces:
            raise KeyError(f"Geology: unknown layer {layer!r}; layers are {self.layers}")

    def unfaulted(self, layer: str, x, y) -> np.ndarray:
        """Elevation of ``layer`` before faulting, at global (x, y)."""
        self._check_layer(layer)
        X, Y = self.local(x, y)
        return np.asarray(self.surfaces[layer](X, Y), dtype=np.float64) * np.ones_like(X)

    def plane_z(self, fault: str, x, y) -> np.ndarray:
        """Elevation of the surface of ``fault`` above global (x, y)."""
        X, Y = self.local(x, y)
        return self.fault(fault).plane_z(X, Y)

    def throw(self, fault: str, layer: str, x, y) -> np.ndarray:
        """Throw (m) of ``layer`` on ``fault`` at global (x, y) (0 outside its zone)."""
        X, Y = self.local(x, y)
        return self.fault(fault).throw_at(layer, X, Y)

    def _relevant(self, layer: str) -> List[int]:
        """Faults that displace ``layer``, plus the older faults they abut
        (whose side decides whether they act). Computed on first use."""
        cache = self.__dict__.setdefault("_relevant_cache", {})
        if layer not in cache:
            cache[layer] = self._relevant_faults(layer)
        return cache[layer]

    def _relevant_faults(self, layer: str) -> List[int]:
        rel = set()
        for i, f in enumerate(self.faults):
            if f.layers.get(layer, 0.0) > 0.0:
                rel.add(i)
                if f.abuts is not None:
                    rel.add(self._index[f.abuts[0]])
        return sorted(rel)

    def _max_heave(self, i: int, layer: str) -> float:
        """Largest horizontal distance (m) by which fault ``i`` moves a point
        of ``layer`` (its heave where taper and decay are 1)."""
        f = self.faults[i]
        return f.throw * float(f.layers.get(layer, 0.0)) / f.tan_dip

    # States of a fault at a point (``_states``).
    _DROP, _HANGING, _FREE = 0, 1, 2
    #: Points are classified in chunks of this many (neighbours in Z order):
    #: a fault that provably cannot decide any point of a chunk (bounds over
    #: the chunk's bounding box) is dropped for the whole chunk without a
    #: per-point test, so the per-point work is per nearby fault, not per fault.
    _CHUNK = 256

    def _layer_table(self, layer: str) -> Dict[str, np.ndarray]:
        """Parameters of the faults relevant to ``layer`` (``_relevant``
        order), as arrays for the classification of ``_states``. Computed on
        first use: the faults must not be changed after a Geology evaluated
        them."""
        cache = self.__dict__.setdefault("_layer_tables", {})
        t = cache.get(layer)
        if t is not None:
            return t
        rel = self._relevant(layer)
        fs = [self.faults[i] for i in rel]

        def arr(get, dtype=np.float64):
            return np.array([get(f) for f in fs], dtype=dtype).reshape(len(fs))

        pos = {i: j for j, i in enumerate(rel)}
        parent = arr(lambda f: pos[self._index[f.abuts[0]]] if f.abuts is not None else -1, np.intp)
        is_parent = np.zeros(len(rel), dtype=bool)
        is_parent[parent[parent >= 0]] = True
        fac = arr(lambda f: float(f.layers.get(layer, 0.0)))
        t = dict(rel=rel,
                 ax=arr(lambda f: f.anchor[0]), ay=arr(lambda f: f.anchor[1]),
                 s0=arr(lambda f: f.sdir[0]), s1=arr(lambda f: f.sdir[1]),
                 n0=arr(lambda f: f.ndir[0]), n1=arr(lambda f: f.ndir[1]),
                 um=arr(lambda f: f.um), hl=arr(lambda f: f.hl), bend=arr(lambda f: f.bend),
                 reach=arr(lambda f: f.flat + f.decay), tan=arr(lambda f: f.tan_dip),
                 zref=arr(lambda f: f.z_ref),
                 heave=np.array([self._max_heave(i, layer) for i in rel], dtype=np.float64).reshape(len(rel)),
                 tmax=arr(lambda f: f.throw * float(f.layers.get(layer, 0.0))),
                 reverse=arr(lambda f: f.kind == "reverse", bool),
                 abutter=parent >= 0, parent=parent, is_parent=is_parent, zero=fac == 0.0)
        cache[layer] = t
        return t

    @staticmethod
    def _chunks(X: np.ndarray, Y: np.ndarray, size: int) -> Tuple[np.ndarray, np.ndarray]:
        """(order, chunk): the points in Z (Morton) order of their position and
        the chunk of ``size`` consecutive points each of them falls in."""
        n = X.size
        if n <= size:
            return np.arange(n), np.zeros(n, dtype=np.intp)
        lo_x, lo_y = X.min(), Y.min()
        span = max(float(X.max() - lo_x), float(Y.max() - lo_y), 1e-300)

        def spread(v):  # 16 bits -> every other bit of 32
            v = (v | (v << np.uint64(8))) & np.uint64(0x00FF00FF)
            v = (v | (v << np.uint64(4))) & np.uint64(0x0F0F0F0F)
            v = (v | (v << np.uint64(2))) & np.uint64(0x33333333)
            return (v | (v << np.uint64(1))) & np.uint64(0x55555555)

        qx = np.clip((X - lo_x) / span * 65535.0, 0, 65535).astype(np.uint64)
        qy = np.clip((Y - lo_y) / span * 65535.0, 0, 65535).astype(np.uint64)
        order = np.argsort(spread(qx) | (spread(qy) << np.uint64(1)), kind="stable")
        return order, np.arange(n) // size

    @staticmethod
    def _bound(S, r_all, tt, zabs):
        """How far (m) an elevation can be from the unfaulted top z0 (see
        ``_states``): S R_all + T, plus 1e-6 m and 1e-12 relative, far above
        the rounding of these sums."""
        return S * r_all + tt + 1e-6 + 1e-12 * (zabs + S * r_all + tt)

    def _moving(self, t, S, x0, x1, y0, y1, z_lo, z_hi, ex):
        """The chunk level of ``_states``: for boxes [x0, x1] x [y0, y1]
        (local) where the unfaulted top lies within [z_lo, z_hi] (used only
        with a slope bound S), which faults of the layer table ``t`` can act
        somewhere in each box: (mov (C, F) bool, the sums of the faults that
        can move: ry (C, F) of the younger ones, r_all, t_up, t_dn (C,))."""
        F = len(t["rel"])
        C = len(x0)
        eps = 1e-6  # metres: far above the rounding of u, w, d at these magnitudes

        # Chunk level, (C, F): ranges of u, w (linear: over the box corners),
        # of the bend offset and of d, and of the fault surface's elevation.
        def lin(a, b):
            vals = [(cx[:, None] - t["ax"]) * a + (cy[:, None] - t["ay"]) * b
                    for cx, cy in ((x0, y0), (x1, y0), (x0, y1), (x1, y1))]
            return np.minimum.reduce(vals) - eps, np.maximum.reduce(vals) + eps

        u_lo, u_hi = lin(t["s0"], t["s1"])
        w_lo, w_hi = lin(t["n0"], t["n1"])
        off_max = np.maximum(np.abs(u_lo - t["um"]), np.abs(u_hi - t["um"]))
        off_min = np.where((u_lo <= t["um"]) & (t["um"] <= u_hi), 0.0,
                           np.minimum(np.abs(u_lo - t["um"]), np.abs(u_hi - t["um"])))
        ca, cb = t["bend"] * (off_min / t["hl"]) ** 2, t["bend"] * (off_max / t["hl"]) ** 2
        d_lo = w_lo - np.maximum(ca, cb) - eps
        d_hi = w_hi - np.minimum(ca, cb) + eps
        kb = np.abs(t["bend"]) / (t["hl"] * t["hl"])
        never = t["zero"].copy()
        if S is not None:
            z_abs = np.maximum(np.abs(z_lo), np.abs(z_hi))
            pz_lo = t["zref"] - d_hi * t["tan"] - eps

        def sums(mov):
            hv = np.where(mov, t["heave"], 0.0)
            ry = np.cumsum(hv[:, ::-1], axis=1)[:, ::-1] - hv  # younger faults that can move
            r_all = hv.sum(axis=1)
            t_up = np.where(mov & t["reverse"], t["tmax"], 0.0).sum(axis=1)
            t_dn = np.where(mov & ~t["reverse"], t["tmax"], 0.0).sum(axis=1)
            return ry, r_all, t_up, t_dn

        mov = np.broadcast_to(~never, (C, F)).copy()
        if ex >= 0:
            mov[:, ex] = True
        act = np.arange(C)  # chunks whose set changed in the last round
        while len(act):
            m = mov[act]
            ry, r_all, t_up, _ = sums(m)
            dead = (off_min[act] >= t["hl"] + ry + eps) | \
                (d_lo[act] - ry - kb * ry * (2.0 * off_max[act] + ry) >= t["reach"] + eps)
            if S is not None:
                dead |= (pz_lo[act] >= (z_hi[act] + self._bound(S, r_all, t_up, z_abs[act]))[:, None]) & \
                    ~t["is_parent"]
            if ex >= 0:
                dead[:, ex] = False
            changed = (m & dead).any(axis=1)
            mov[act] = m & ~dead
            act = act[changed]
        sm = sums(mov)
        # The parent of a fault that may act must be kept (it has zero throw
        # there or was never dropped by the slope test, so the sums hold).
        for j in np.flatnonzero(t["abutter"]):
            mov[:, t["parent"][j]] |= mov[:, j]
        return (mov,) + sm

    def _states(self, layer: str, X: np.ndarray, Y: np.ndarray, exclude: Optional[int]):
        """How each fault relevant to ``layer`` enters the enumeration at each
        (finite) point: returns (pt, j, state) for the faults that are not
        dropped there (pt: point index, j: position in ``_relevant(layer)``,
        sorted by pt then j; state ``_FREE``: both sides tried, ``_HANGING``:
        only its hanging wall can be valid); every other fault is ``_DROP``
        there (only its footwall can be valid and its slip does not change
        the elevation). Both shortcuts give the same valid elevations as
        trying both sides, bit for bit:

        * zero throw: a fault undoes its slip at the position left by undoing
          the younger faults, within R of the final point, R the sum of the
          largest heaves of the younger faults that can move (not dropped).
          Where its throw is exactly zero on that whole disk (outside the
          taper's along-strike range, or beyond flat + decay into the hanging
          wall, where ``taper`` and ``decay_factor`` return exact zeros), its
          backward step is the identity (x - 0.0 = x), so both side
          assignments give the same elevation and exactly one passes its side
          test: drop it.
        * far from its surface (layers with a slope bound S): in every
          assignment that leaves the dropped faults on their footwall, an
          elevation lies within [z0 - S R_all - T_normal, z0 + S R_all +
          T_reverse] of the unfaulted top z0 at the point (R_all: the sum of
          the largest heaves of the faults that can move, the farthest a
          pre-image can be; T_normal / T_reverse: the sums of their largest
          throws, normal faults lower the rock, reverse ones lift it). A
          fault surface above that range makes its hanging wall invalid and
          its footwall valid in every such assignment (drop); below it, the
          reverse (hanging wall only; not for a fault that abuts another,
          whose activity depends on its parent's side).

        Dropping a fault shrinks the sums, which may drop more faults: this
        is iterated to a fixed point, per chunk of points (``_CHUNK``, bounds
        over the chunk's bounding box and its range of z0), then each point
        of a chunk tests the chunk's remaining faults once with the chunk's
        sums. The excluded fault (``side_value``) is never dropped; an older
        fault that another one abuts is not dropped by the slope test (it
        may have to be tried on both sides after all: the side of the parent
        of every fault that is not dropped at a point stays free there)."""
        t = self._layer_table(layer)
        F = len(t["rel"])
        ex = t["rel"].index(exclude) if exclude is not None and exclude in t["rel"] else -1
        fin = np.isfinite(X) & np.isfinite(Y)
        # Non-finite points: every side test is False there, so they have no
        # valid elevation whatever the states; leave them out.
        pts = np.flatnonzero(fin)
        Xf, Yf = X[pts], Y[pts]
        S = self.slopes.get(layer)
        z0 = np.asarray(self.surfaces[layer](Xf, Yf), dtype=np.float64) * np.ones_like(Xf) \
            if S is not None else None
        order, chunk = self._chunks(Xf, Yf, self._CHUNK)
        n = len(order)
        if n == 0 or F == 0:
            e = np.zeros(0, dtype=np.intp)
            return e, e, np.zeros(0, dtype=np.int8)
        starts = np.arange(0, n, self._CHUNK)
        Xo, Yo = Xf[order], Yf[order]
        x0, x1 = np.minimum.reduceat(Xo, starts), np.maximum.reduceat(Xo, starts)
        y0, y1 = np.minimum.reduceat(Yo, starts), np.maximum.reduceat(Yo, starts)
        if S is not None:
            zo = z0[order]
            z_lo, z_hi = np.minimum.reduceat(zo, starts), np.maximum.reduceat(zo, starts)
        else:
            z_lo = z_hi = None
        mov, ry, r_all, t_up, t_dn = self._moving(t, S, x0, x1, y0, y1, z_lo, z_hi, ex)
        eps = 1e-6  # metres: far above the rounding of u, w, d at these magnitudes
        kb = np.abs(t["bend"]) / (t["hl"] * t["hl"])
        C = len(starts)

        def bound(r_all, tt, zabs):
            return self._bound(S, r_all, tt, zabs)

        # Point level: every point against its chunk's remaining faults.
        cc, cj = np.nonzero(mov)                       # (chunk, fault), chunk-major
        per_chunk = np.bincount(cc, minlength=C)
        first = np.concatenate([[0], np.cumsum(per_chunk)[:-1]])
        cnt = per_chunk[chunk]                         # per point in Z order
        tot = int(cnt.sum())
        pstart = np.concatenate([[0], np.cumsum(cnt)[:-1]])
        k = np.arange(tot) - np.repeat(pstart, cnt)
        pair = np.repeat(first[chunk], cnt) + k        # index into (cc, cj)
        pc, j = cc[pair], cj[pair]
        po = np.repeat(np.arange(n), cnt)              # point in Z order
        px, py = Xo[po], Yo[po]
        u = (px - t["ax"][j]) * t["s0"][j] + (py - t["ay"][j]) * t["s1"][j]
        w = (px - t["ax"][j]) * t["n0"][j] + (py - t["ay"][j]) * t["n1"][j]
        off = np.abs(u - t["um"][j])
        d = w - t["bend"][j] * ((u - t["um"][j]) / t["hl"][j]) ** 2
        r = ry[pc, j]
        drop = (off >= t["hl"][j] + r + eps) | \
            (d - r - kb[j] * r * (2.0 * off + r) >= t["reach"][j] + eps)
        state = np.full(tot, self._FREE, dtype=np.int8)
        if S is not None:
            pz = t["zref"][j] - d * t["tan"][j]
            zp = zo[po]
            drop |= pz >= zp + bound(r_all[pc], t_up[pc], np.abs(zp))
            hang = (pz < zp - bound(r_all[pc], t_dn[pc], np.abs(zp))) & ~t["abutter"][j]
            state[hang] = self._HANGING
        if ex >= 0:
            drop &= j != ex
            state[j == ex] = self._FREE
        state[drop] = self._DROP
        # The parent of every fault that is not dropped at a point stays free.
        rank = np.cumsum(mov, axis=1) - 1
        child = np.flatnonzero(t["abutter"][j] & (state != self._DROP))
        if len(child):
            q = pstart[po[child]] + rank[pc[child], t["parent"][j[child]]]
            state[q] = self._FREE
        keep = state != self._DROP
        return pts[order[po[keep]]], j[keep], state[keep]

    def _combos(self, layer: str, X: np.ndarray, Y: np.ndarray, exclude: Optional[int] = None):
        """Yield (sides, z, valid, idx) for every assignment of a side (0 foot,
        1 hanging wall) to the relevant faults, at the points ``idx``: ``z``
        and ``valid`` are given for those points only. ``valid`` says where the
        point (X, Y, z) really lies on the assigned sides; the own-side test of
        fault ``exclude`` is skipped (used to extend one side up to its
        cutoff). Points are grouped by the faults' states there (``_states``):
        only free faults are branched on, so faults far away (the usual case
        with many independent faults) do not multiply the work; ``sides``
        holds the free and hanging-wall-only faults. Non-finite points are
        left out (no side test holds there)."""
        rel = self._relevant(layer)
        surf = self.surfaces[layer]
        n = X.size
        if not rel:
            z = np.asarray(surf(X, Y), dtype=np.float64) * np.ones_like(X)
            yield {}, z, np.ones(n, dtype=bool), np.arange(n)
            return
        pt, jj, stt = self._states(layer, X, Y, exclude)
        live = np.flatnonzero(np.isfinite(X) & np.isfinite(Y))
        if len(live) == 0:
            return
        # Each point's pattern: its (fault, state) pairs, in fault order (the
        # pairs of a point are consecutive and sorted by fault).
        code = (jj * 3 + stt).astype(np.int64)
        new_pt = np.r_[True, pt[1:] != pt[:-1]] if len(pt) else np.zeros(0, dtype=bool)
        heads = np.flatnonzero(new_pt)
        cnt = np.diff(np.r_[heads, len(pt)])
        width = max(1, int(cnt.max()) if len(cnt) else 1)
        # Rows: the points with pairs (in the order _states gives them), then
        # the points with none (every fault dropped).
        has = np.zeros(X.size, dtype=bool)
        has[pt[heads]] = True
        rest = live[~has[live]]
        rows = np.concatenate([pt[heads], rest])
        M = np.full((len(rows), width), -1, dtype=np.int64)
        M[np.repeat(np.arange(len(heads)), cnt), np.arange(len(pt)) - np.repeat(heads, cnt)] = code
        # A dense key per row: the codes (0 .. 3F-1, -1 padding) as digits of
        # base 3F + 1 when they fit in 62 bits, else refined column by column.
        base = 3 * len(rel) + 1
        if width * np.log2(base) < 62:
            key = np.zeros(len(rows), dtype=np.int64)
            for c in range(width):
                key = key * base + (M[:, c] + 1)
            _, first, inv = np.unique(key, return_index=True, return_inverse=True)
        else:
            inv = np.zeros(len(rows), dtype=np.int64)
            for c in range(width):
                _, inv = np.unique(inv * base + (M[:, c] + 1), return_inverse=True)
                inv = inv.reshape(-1).astype(np.int64)
            _, first = np.unique(inv, return_index=True)
        inv = inv.reshape(-1)
        pats = M[first]
        grp = np.argsort(inv, kind="stable")
        bounds = np.flatnonzero(np.diff(inv[grp])) + 1
        # Two passes: the side assignments and pre-images of every pattern
        # first, then ONE evaluation of the surface at all of them (per call
        # of the surface, not per assignment: the layer stacks are sums of
        # several fields), then the side tests.
        jobs = []   # (side, idx, planes, used, active, key into the evaluations, dz)
        evx: List[np.ndarray] = []
        evy: List[np.ndarray] = []
        for pat, sel in zip(pats, np.split(grp, bounds)):
            idx = rows[sel]
            pat = pat[pat >= 0]
            col = dict(zip((pat // 3).tolist(), (pat % 3).tolist()))
            lrel = [rel[j] for j, s in col.items() if s == self._FREE]
            hang = [rel[j] for j, s in col.items() if s == self._HANGING]
            used = [rel[j] for j in col]
            Xs, Ys = X[idx], Y[idx]
            planes = {i: self.faults[i].plane_z(Xs, Ys) for i in used}
            base = None
            for bits in itertools.product((0, 1), repeat=len(lrel)):
                side = dict(zip(lrel, bits))
                side.update({i: 1 for i in hang})
                # A fault that abuts an older one acts only on its allowed side of it.
                active = {}
                ok = True
                for i in used:
                    f = self.faults[i]
                    act = True
                    if f.abuts is not None:
                        p = self._index[f.abuts[0]]
                        want = 0 if f.abuts[1] == "foot" else 1
                        act = side[p] == want  # _states keeps the parent free
                    if not act and side[i] == 1:
                        ok = False
                    active[i] = act
                if not ok:
                    continue
                Xc, Yc = Xs, Ys
                dz = np.zeros_like(Xs)
                moved = False
                for i in reversed(used):  # undo the youngest fault first
                    if side[i] == 1 and active[i]:
                        Xc, Yc, s = self.faults[i].backward(layer, Xc, Yc)
                        dz = dz + s
                        moved = True
                if moved:
                    key = len(evx)
                    evx.append(Xc)
                    evy.append(Yc)
                else:
                    if base is None:
                        base = len(evx)
                        evx.append(Xs)
                        evy.append(Ys)
                    key = base
                jobs.append((side, idx, planes, used, active, key, dz))
        if not jobs:
            return
        lens = [len(v) for v in evx]
        zall = np.asarray(surf(np.concatenate(evx), np.concatenate(evy)), dtype=np.float64) * \
            np.ones(sum(lens))
        zev = np.split(zall, np.cumsum(lens)[:-1])
        for side, idx, planes, used, active, key, dz in jobs:
            z = zev[key] - dz
            valid = np.ones(idx.shape, dtype=bool)
            for i in used:
                if i == exclude or not active[i]:
                    continue
                # Hanging wall strictly above the surface, footwall on or below:
                # with zero throw exactly one side is valid.
                valid &= (z > planes[i]) if side[i] == 1 else (z <= planes[i])
            yield side, z, valid, idx

    def near(self, fault: str, boxes) -> "Geology":
        """The same ground with only the faults that can matter inside
        ``boxes`` (rows x0, x1, y0, y1, global coordinates) when ``fault`` is
        excluded from its own side test or not: every other fault is provably
        dropped there (``_states``, with the bounds of the full fault set), so
        ``sheets``, ``truth`` and ``side_value`` (of ``fault``) at points
        inside the boxes are the same as this Geology's, bit for bit, at a
        cost that does not grow with the number of faults elsewhere."""
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        k = self._index[fault]
        keep = {k}
        x0, x1 = boxes[:, 0] - self.origin[0], boxes[:, 1] - self.origin[0]
        y0, y1 = boxes[:, 2] - self.origin[1], boxes[:, 3] - self.origin[1]
        for layer in self.layers:
            t = self._layer_table(layer)
            if not t["rel"]:
                continue
            S = self.slopes.get(layer)
            z_lo = z_hi = None
            if S is not None:
                # |z0(p) - z0(centre)| <= S |p - centre| in a box (plus 1e-6 m
                # for the rounding of z0).
                zc = np.asarray(self.surfaces[layer](0.5 * (x0 + x1), 0.5 * (y0 + y1)),
                                dtype=np.float64) * np.ones_like(x0)
                r = S * 0.5 * np.hypot(x1 - x0, y1 - y0) + 1e-6
                z_lo, z_hi = zc - r, zc + r
            ex = t["rel"].index(k) if k in t["rel"] else -1
            mov = self._moving(t, S, x0, x1, y0, y1, z_lo, z_hi, ex)[0]
            keep |= {t["rel"][j] for j in np.flatnonzero(mov.any(axis=0))}
        while True:  # with the older faults the kept ones abut
            more = {self._index[self.faults[i].abuts[0]] for i in keep if self.faults[i].abuts}
            if more <= keep:
                break
            keep |= more
        if len(keep) == len(self.faults):
            return self
        return Geology(list(self.layers), self.surfaces, [f for i, f in enumerate(self.faults) if i in keep],
                       origin=self.origin, slopes=dict(self.slopes))

    # -- sheets and truth -----------------------------------------------------
    def sheets(self, layer: str, x, y) -> np.ndarray:
        """All elevations of ``layer`` above each global (x, y): array (n, m),
        top down, NaN-padded (m = the largest number of sheets found; 2 in a
        reverse-fault overlap band, a row of NaN in a normal-fault gap)."""
        self._check_layer(layer)
        X, Y = self.local(np.ravel(x), np.ravel(y))
        n = X.size
        cols: List[np.ndarray] = []       # NaN-padded value columns
        count = np.zeros(n, dtype=np.int64)
        for _, z, valid, idx in self._combos(layer, X, Y):
            if not valid.any():
                continue
            rows = idx[valid]
            slot = count[rows]
            while len(cols) <= int(slot.max()):
                cols.append(np.full(n, np.nan))
            for k in np.unique(slot):
                sel = slot == k
                cols[int(k)][rows[sel]] = z[valid][sel]
            count[rows] += 1
        if not cols:
            return np.full((n, 1), np.nan)
        A = np.column_stack(cols)
        # NaN sorts last; negate for top-down order.
        A = -np.sort(-A, axis=1)
        m = max(1, int(np.max(count)))
        return A[:, :m]

    def n_sheets(self, layer: str, x, y) -> np.ndarray:
        """Number of sheets of ``layer`` above each point: 1 normally, 2 in a
        reverse overlap band, 0 in a normal gap."""
        return np.sum(~np.isnan(self.sheets(layer, x, y)), axis=1)

    def side_value(self, layer: str, fault: str, side: str, x, y) -> np.ndarray:
        """Elevation of ``layer`` on ``side`` ("foot" or "hanging") of ``fault``
        at global (x, y), continued up to (and past) that side's cutoff: the own
        side test of ``fault`` is skipped, those of the other faults are kept.
        NaN where the other faults leave no sheet."""
        self._check_layer(layer)
        k = self._index[fault]
        want = 0 if side == "foot" else 1
        X, Y = self.local(np.ravel(x), np.ravel(y))
        out = np.full(X.shape, np.nan)
        if k not in self._relevant(layer):
            if want == 1:
                return out
            return np.ravel(self.truth(layer, x, y))
        for sides, z, valid, idx in self._combos(layer, X, Y, exclude=k):
            if sides[k] != want:
                continue
            o = out[idx]
            out[idx] = np.where(valid & ~(o >= z), z, o)
        return out

    def hanging(self, x, y, z) -> np.ndarray:
        """(n, F) bool: True where the 3D point (x, y, z) lies strictly above
        the surface of fault i (its hanging wall; on the surface counts as
        footwall, as in the side tests of :meth:`sheets`)."""
        x, y, z = (np.ravel(np.asarray(v, dtype=np.float64)) for v in (x, y, z))
        X, Y = self.local(x, y)
        out = np.zeros((len(X), len(self.faults)), dtype=bool)
        for i, f in enumerate(self.faults):
            out[:, i] = z > f.plane_z(X, Y)
        return out

    def tops_in_block(self, x, y, hanging: np.ndarray) -> np.ndarray:
        """(n, L): every layer's top at global (x, y) in the fault block given
        per point by ``hanging`` ((n, F) bool, e.g. :meth:`hanging` of a 3D
        point), continued past its cutoffs within that block as
        :meth:`side_value` continues one side. Within a block the tops keep
        the layer order, so the unit a 3D point lies in is the number of its
        block's tops at or above it, minus one. The undoing of the slip is
        :meth:`_combos`' (youngest fault first; a fault that abuts another
        acts only on its side of it), for one given block per point instead
        of every block."""
        X, Y = self.local(np.ravel(x), np.ravel(y))
        H = np.asarray(hanging, dtype=bool).reshape(len(X), len(self.faults))
        out = np.empty((len(X), len(self.layers)))
        for k, lay in enumerate(self.layers):
            Xc, Yc, dz = X, Y, np.zeros_like(X)
            for i in reversed(self._relevant(lay)):
                f = self.faults[i]
                act = H[:, i]
                if f.abuts is not None:
                    act = act & (H[:, self._index[f.abuts[0]]] == (f.abuts[1] == "hanging"))
                if f.layers.get(lay, 0.0) <= 0.0 or not act.any():
                    continue  # zero throw: backward() is the identity
                Xb, Yb, s = f.backward(lay, Xc, Yc)
                Xc, Yc = np.where(act, Xb, Xc), np.where(act, Yb, Yc)
                dz = dz + np.where(act, s, 0.0)
            out[:, k] = np.asarray(self.surfaces[lay](Xc, Yc), dtype=np.float64) - dz
        return out

    def truth(self, layer: str, x, y) -> np.ndarray:
        """Ground-truth elevation of ``layer`` at global (x, y), one value per
        point: the single sheet; in a reverse-fault overlap band the upper
        (hanging-wall) sheet; in a normal-fault gap the fault surface (the
        strip joining the two cutoffs)."""
        shape = np.shape(np.asarray(x, dtype=np.float64) + np.asarray(y, dtype=np.float64))
        S = self.sheets(layer, x, y)
        z = S[:, 0].copy()
        gap = np.isnan(z)
        if gap.any():
            xg = np.ravel(np.broadcast_to(x, shape))[gap]
            yg = np.ravel(np.broadcast_to(y, shape))[gap]
            zg = np.full(xg.shape, np.nan)
            for f in self.faults:
                if f.kind != "normal" or f.layers.get(layer, 0.0) <= 0.0:
                    continue
                foot = self.side_value(layer, f.name, "foot", xg, yg)
                hang = self.side_value(layer, f.name, "hanging", xg, yg)
                pz = self.plane_z(f.name, xg, yg)
                inside = np.isnan(zg) & (foot > pz) & (hang <= pz)
                zg = np.where(inside, pz, zg)
            still = np.isnan(zg)
            if still.any():  # not expected; fall back to the unfaulted top
                zg[still] = self.unfaulted(layer, xg[still], yg[still])
            z[gap] = zg
        return z.reshape(shape)

    def in_fault_band(self, layer: str, x, y, margin: float = 0.0) -> np.ndarray:
        """True where ``layer`` is absent (normal-fault gap) or multi-valued
        (reverse-fault overlap band) at global (x, y). With ``margin`` > 0, also
        where such a point lies within ``margin`` metres horizontally; this is
        sampled (the point itself, offsets along every fault's dip direction in
        steps of at most 5 m, and 16 directions at the full margin)."""
        x = np.ravel(np.asarray(x, dtype=np.float64))
        y = np.ravel(np.asarray(y, dtype=np.float64))
        band = self.n_sheets(layer, x, y) != 1
        if margin > 0.0:
            offs = [np.array([0.0, 0.0])]
            steps = max(1, int(np.ceil(margin / 5.0)))
            for f in self.faults:
                for j in range(1, steps + 1):
                    r = margin * j / steps
                    offs += [r * f.ndir, -r * f.ndir]
            for a in np.linspace(0.0, 2 * np.pi, 16, endpoint=False):
                offs.append(margin * np.array([np.cos(a), np.sin(a)]))
            for o in offs[1:]:
                band |= self.n_sheets(layer, x + o[0], y + o[1]) != 1
        return band

    # -- consistency checks ---------------------------------------------------
    def influence(self, fault: str, x, y) -> np.ndarray:
        """True where ``fault`` can move rock of some layer at global (x, y)."""
        X, Y = self.local(x, y)
        f = self.fault(fault)
        u, w = f.uw(X, Y)
        d = w - f.bend_offset(u)
        t = f.taper(u) * f.decay_factor(d)
        # The hanging wall of a layer at elevation z starts at
        # d = (z_ref - z) / tan(dip); above the highest displaced layer nothing moves.
        ztop = np.full(np.shape(X), -np.inf)
        for lay, fac in f.layers.items():
            if fac > 0:
                ztop = np.maximum(ztop, self.surfaces[lay](X, Y) + f.throw)
        return (t > 0) & (f.z_ref - d * f.tan_dip < ztop)

    def check_disjoint(self, x, y) -> None:
        """Raise ValueError if two faults that are neither abutting nor in one
        group both move rock at one of the sample points (x, y)."""
        inf = {f.name: self.influence(f.name, x, y) for f in self.faults}
        for a, b in itertools.combinations(self.faults, 2):
            related = (a.abuts is not None and a.abuts[0] == b.name) or \
                      (b.abuts is not None and b.abuts[0] == a.name) or \
                      (a.group is not None and a.group == b.group)
            if not related and np.any(inf[a.name] & inf[b.name]):
                raise ValueError(f"Geology: the zones of influence of faults {a.name!r} and "
                                 f"{b.name!r} overlap")
