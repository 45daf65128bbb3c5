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
        (whose side decides whether they act)."""
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

    def _states(self, layer: str, rel: List[int], X: np.ndarray, Y: np.ndarray,
                exclude: Optional[int]) -> np.ndarray:
        """(len(rel), n) int8: how fault rel[j] enters the enumeration at each
        point: ``_FREE`` (both sides tried), ``_HANGING`` (only its hanging
        wall can be valid) or ``_DROP`` (only its footwall can be valid and its
        slip does not change the elevation). Both shortcuts give the same valid
        elevations as trying both sides, bit for bit:

        * zero throw: a fault undoes its slip at the position left by undoing
          the younger faults, within R (the sum of their largest heaves) of
          the final point. Where its throw is exactly zero on that whole disk
          (outside the taper's along-strike range, or beyond flat + decay into
          the hanging wall, where ``taper`` and ``decay_factor`` return exact
          zeros), its backward step is the identity (x - 0.0 = x), so both
          side assignments give the same elevation and exactly one passes its
          side test: drop it.
        * far from its surface (layers with a slope bound S): every candidate
          elevation lies within S * R_all + T_all of the unfaulted top at the
          point (R_all: the sum of all relevant faults' largest heaves, the
          farthest a pre-image can be; T_all: the sum of their largest
          throws). A fault surface above that range makes every hanging-wall
          candidate invalid and every footwall candidate valid (drop); below
          it, the reverse (hanging wall only; not for a fault that abuts
          another, whose activity depends on its parent's side).

        The excluded fault (``side_value``) and every older fault that a
        non-dropped fault abuts (its side decides whether the younger one
        acts) stay free."""
        st = np.full((len(rel), X.size), self._FREE, dtype=np.int8)
        pos = {i: j for j, i in enumerate(rel)}
        S = self.slopes.get(layer)
        if S is not None:
            R_all = sum(self._max_heave(i, layer) for i in rel)
            T_all = sum(self.faults[i].throw * float(self.faults[i].layers.get(layer, 0.0)) for i in rel)
            z0 = np.asarray(self.surfaces[layer](X, Y), dtype=np.float64) * np.ones_like(X)
            # 1e-6 m plus 1e-12 relative: far above the rounding of these sums.
            B = S * R_all + T_all + 1e-6 + 1e-12 * (np.abs(z0) + S * R_all + T_all)
        younger = 0.0
        for j in range(len(rel) - 1, -1, -1):
            i = rel[j]
            f = self.faults[i]
            R = younger
            younger += self._max_heave(i, layer)
            if i == exclude:
                continue
            if R == 0.0:
                # The fault's own position is its pre-image: the exact test.
                dead = f.throw_at(layer, X, Y) == 0.0
            else:
                # Bounds over the disk of radius R (plus 1e-6 m for the
                # rounding of u, w at these magnitudes).
                u, w = f.uw(X, Y)
                off = np.abs(u - f.um)
                dead = off >= f.hl + R + 1e-6
                dc = abs(f.bend) / (f.hl * f.hl) * R * (2.0 * off + R)
                d = w - f.bend_offset(u)
                dead |= d - R - dc >= f.flat + f.decay + 1e-6
            if S is not None:
                pz = f.plane_z(X, Y)
                dead |= pz >= z0 + B
                if f.abuts is None:
                    st[j][(pz < z0 - B) & ~dead] = self._HANGING
            st[j][dead] = self._DROP
        for j in range(len(rel) - 1, -1, -1):
            f = self.faults[rel[j]]
            if f.abuts is not None:
                p = self._index[f.abuts[0]]
                if p in pos:
                    st[pos[p]][st[j] != self._DROP] = self._FREE
        return st

    def _combos(self, layer: str, X: np.ndarray, Y: np.ndarray, exclude: Optional[int] = None):
        """Yield (sides, z, valid, idx) for every assignment of a side (0 foot,
        1 hanging wall) to the relevant faults, at the points ``idx``: ``z``
        and ``valid`` are given for those points only. ``valid`` says where the
        point (X, Y, z) really lies on the assigned sides; the own-side test of
        fault ``exclude`` is skipped (used to extend one side up to its
        cutoff). Points are grouped by the faults' states there (``_states``):
        only free faults are branched on, so faults far away (the usual case
        with many independent faults) do not multiply the work; ``sides``
        holds the free and hanging-wall-only faults."""
        rel = self._relevant(layer)
        surf = self.surfaces[layer]
        n = X.size
        if not rel:
            z = np.asarray(surf(X, Y), dtype=np.float64) * np.ones_like(X)
            yield {}, z, np.ones(n, dtype=bool), np.arange(n)
            return
        st = self._states(layer, rel, X, Y, exclude)
        code = np.zeros(n, dtype=np.int64)
        for j in range(len(rel)):
            code = code * 3 + st[j]
        pats, first, inv = np.unique(code, return_index=True, return_inverse=True)
        inv = inv.reshape(-1)
        for pi in range(len(pats)):
            idx = np.flatnonzero(inv == pi)
            col = st[:, first[pi]]
            lrel = [i for j, i in enumerate(rel) if col[j] == self._FREE]
            hang = [i for j, i in enumerate(rel) if col[j] == self._HANGING]
            used = [i for j, i in enumerate(rel) if col[j] != self._DROP]
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
                    z = np.asarray(surf(Xc, Yc), dtype=np.float64) * np.ones_like(Xs) - dz
                else:
                    if base is None:
                        base = np.asarray(surf(Xs, Ys), dtype=np.float64) * np.ones_like(Xs) - dz
                    z = base
                valid = np.ones(Xs.shape, dtype=bool)
                for i in used:
                    if i == exclude or not active[i]:
                        continue
                    # Hanging wall strictly above the surface, footwall on or below:
                    # with zero throw exactly one side is valid.
                    valid &= (z > planes[i]) if side[i] == 1 else (z <= planes[i])
                yield side, z, valid, idx

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
