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
    (k in radians per metre) and ``bumps`` rows (amp, cx, cy, sigma)."""
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

    return f


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

    def _combos(self, layer: str, X: np.ndarray, Y: np.ndarray, exclude: Optional[int] = None):
        """Yield (sides, z, valid) for every assignment of a side (0 foot, 1
        hanging wall) to the relevant faults. ``valid`` says where the point
        (X, Y, z) really lies on the assigned sides; the own-side test of fault
        ``exclude`` is skipped (used to extend one side up to its cutoff)."""
        rel = self._relevant(layer)
        surf = self.surfaces[layer]
        planes = {i: self.faults[i].plane_z(X, Y) for i in rel}
        for bits in itertools.product((0, 1), repeat=len(rel)):
            side = dict(zip(rel, bits))
            # A fault that abuts an older one acts only on its allowed side of it.
            active = {}
            ok = True
            for i in rel:
                f = self.faults[i]
                act = True
                if f.abuts is not None:
                    p = self._index[f.abuts[0]]
                    want = 0 if f.abuts[1] == "foot" else 1
                    act = side[p] == want
                if not act and side[i] == 1:
                    ok = False
                active[i] = act
            if not ok:
                continue
            Xc, Yc = X, Y
            dz = np.zeros_like(X)
            for i in reversed(rel):  # undo the youngest fault first
                if side[i] == 1 and active[i]:
                    Xc, Yc, s = self.faults[i].backward(layer, Xc, Yc)
                    dz = dz + s
            z = np.asarray(surf(Xc, Yc), dtype=np.float64) * np.ones_like(X) - dz
            valid = np.ones(X.shape, dtype=bool)
            for i in rel:
                if i == exclude or not active[i]:
                    continue
                # Hanging wall strictly above the surface, footwall on or below:
                # with zero throw exactly one side is valid.
                valid &= (z > planes[i]) if side[i] == 1 else (z <= planes[i])
            yield side, z, valid

    # -- sheets and truth -----------------------------------------------------
    def sheets(self, layer: str, x, y) -> np.ndarray:
        """All elevations of ``layer`` above each global (x, y): array (n, m),
        top down, NaN-padded (m = the largest number of sheets found; 2 in a
        reverse-fault overlap band, a row of NaN in a normal-fault gap)."""
        self._check_layer(layer)
        X, Y = self.local(np.ravel(x), np.ravel(y))
        vals = []
        for _, z, valid in self._combos(layer, X, Y):
            if valid.any():
                vals.append(np.where(valid, z, np.nan))
        if not vals:
            return np.full((X.size, 1), np.nan)
        A = np.column_stack(vals)
        # NaN sorts last; negate for top-down order.
        A = -np.sort(-A, axis=1)
        m = max(1, int(np.max(np.sum(~np.isnan(A), axis=1))))
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
        for sides, z, valid in self._combos(layer, X, Y, exclude=k):
            if sides[k] != want:
                continue
            out = np.where(valid & ~(out >= z), z, out)
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
