"""Built-in and generated datasets, each sampled from a known ground truth.

* :func:`paper_like` — the study area of Gao et al. (2025), section 3.1,
  re-created from a ground-truth geology: about 4,180 m x 4,170 m, 112
  boreholes, four layers (topsoil, third impervious bed, coal 8, coal 10),
  nine exploration lines and the paper's four faults (2F4 reverse interior,
  F22 normal reaching the boundary, 2F1 reverse and 4F2 normal in a
  T-crossing). The same dataset is shipped on disk in format v1 under
  ``faultmesh/data/paper_like/`` (:func:`paper_like_path`).
* :func:`synthetic` — random but valid datasets with other strikes, dips,
  throws, layer counts and study areas, for workflow tests.
* :func:`random_ground` (implemented in :mod:`faultmesh.grounds`) — grounds
  the code was not written for: random study-area shapes, coordinates,
  layer stacks, one to four faults of every kind and extent, T/X-crossing
  and too-close pairs, survey rounding; written and read back through the
  loader; ``dataset.spec`` says what was drawn.

Every generated :class:`~faultmesh.Dataset` carries ``truth(layer, x, y)`` and
``geology`` (a :class:`faultmesh.geology.Geology`; see there what the truth
returns in reverse-fault overlap bands and normal-fault gaps, and
``geology.in_fault_band`` for where a layer is multi-valued or absent).

Fault traces are derived from the truth along every section line that crosses
a fault where its throw is at least ``MIN_TRACE_THROW``: the fault-plane trace
top down, and per displaced layer the footwall polyline from a far end (60 to
100 m away) to the footwall cutoff and the hanging-wall polyline from the
hanging-wall cutoff to a far end. Cutoffs are found by bracketing and the
Illinois (regula falsi) method to 1e-9 m, so a cutoff point lies on the fault
surface to that precision.

Regenerate the shipped files with ``python -m faultmesh.datasets``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .dataset import Boreholes, Dataset, Fault, Section, Trace, points_in_polygon
from .geology import FaultModel, Geology, layer_stack, smooth_field

__all__ = ["paper_like", "paper_like_path", "synthetic", "random_ground", "MIN_TRACE_THROW"]

#: Sections crossing a fault where every layer's throw is smaller than this
#: (metres) get no trace: such a small offset would not be interpreted on a
#: section drawing, and the fault is then closed by its tip instead.
MIN_TRACE_THROW = 3.0


# ---------------------------------------------------------------------------
# Root finding along lines (vectorised over many roots)
# ---------------------------------------------------------------------------
def _illinois(f, a, b, fa, fb, tol: float = 1e-9) -> np.ndarray:
    """Roots of k functions at once, root r of ``f(r_idx, c)`` in [a[r], b[r]]
    with fa[r], fb[r] of opposite signs (Illinois variant of regula falsi:
    superlinear on smooth functions, never leaves the bracket).

    ``f(idx, c)`` evaluates the functions of the roots ``idx`` (int array) at
    ``c`` (same length). Each root follows exactly the arithmetic of a scalar
    Illinois iteration and stops on its own (``|f| < tol`` or a bracket
    narrower than ``tol``); only the evaluations are batched."""
    a = np.array(a, dtype=np.float64, ndmin=1)
    b = np.array(b, dtype=np.float64, ndmin=1)
    fa = np.array(fa, dtype=np.float64, ndmin=1)
    fb = np.array(fb, dtype=np.float64, ndmin=1)
    n = len(a)
    out = np.full(n, np.nan)
    side = np.zeros(n, dtype=np.int8)
    last = np.full(n, np.nan)
    act = np.arange(n)
    for _ in range(100):
        if len(act) == 0:
            break
        aa, bb, ffa, ffb = a[act], b[act], fa[act], fb[act]
        c = (aa * ffb - bb * ffa) / (ffb - ffa)
        fc = np.array(f(act, c), dtype=np.float64).reshape(-1)
        bad = ~np.isfinite(fc)
        if bad.any():  # pragma: no cover - brackets are finite on both ends
            c[bad] = 0.5 * (aa[bad] + bb[bad])
            fc[bad] = np.array(f(act[bad], c[bad]), dtype=np.float64).reshape(-1)
        last[act] = c
        done = (np.abs(fc) < tol) | (np.abs(bb - aa) < tol)
        out[act[done]] = c[done]
        keep = ~done
        act, c, fc = act[keep], c[keep], fc[keep]
        same = (fc > 0) == (fb[act] > 0)
        r = act[same]                      # b <- c
        b[r] = c[same]
        fb[r] = fc[same]
        fa[r[side[r] == -1]] *= 0.5
        side[r] = -1
        r = act[~same]                     # a <- c
        a[r] = c[~same]
        fa[r] = fc[~same]
        fb[r[side[r] == 1]] *= 0.5
        side[r] = 1
    out[act] = last[act]  # pragma: no cover - not converged in 100 steps
    return out


def _roots_near(g, origins: np.ndarray, dirs: np.ndarray, s0, lo, hi,
                step: float = 2.0) -> np.ndarray:
    """For each row r: the root of ``g(xy)`` along the line
    ``origins[r] + s dirs[r]``, s in [lo[r], hi[r]], closest to s0[r] (NaN if
    g does not change sign there). g is sampled every ``step`` along each line
    (all lines in one call), the sign change closest to s0 (the first of
    equally close ones) is refined by :func:`_illinois`. ``g`` maps points
    (k, 2) to values (k,)."""
    origins = np.asarray(origins, dtype=np.float64).reshape(-1, 2)
    dirs = np.asarray(dirs, dtype=np.float64).reshape(-1, 2)
    n = len(origins)
    s0 = np.broadcast_to(np.asarray(s0, dtype=np.float64), (n,))
    lo = np.broadcast_to(np.asarray(lo, dtype=np.float64), (n,))
    hi = np.broadcast_to(np.asarray(hi, dtype=np.float64), (n,))
    out = np.full(n, np.nan)
    if n == 0:
        return out
    grids = [np.arange(l, h + 0.5 * step, step) for l, h in zip(lo, hi)]
    lens = np.array([len(x) for x in grids])
    S = np.concatenate(grids)
    row = np.repeat(np.arange(n), lens)
    V = np.asarray(g(origins[row] + S[:, None] * dirs[row]), dtype=np.float64).reshape(-1)
    ok = (row[:-1] == row[1:]) & np.isfinite(V[:-1]) & np.isfinite(V[1:]) & \
        ((V[:-1] > 0) != (V[1:] > 0))
    i = np.flatnonzero(ok)
    if len(i) == 0:
        return out
    r = row[i]
    dist = np.abs(0.5 * (S[i] + S[i + 1]) - s0[r])
    # Per row the closest crossing; among equals the first (lexsort is stable).
    order = np.lexsort((dist, r))
    first = np.r_[True, r[order][1:] != r[order][:-1]]
    pick = i[order[first]]
    rows = row[pick]

    def f(k, c):
        rr = rows[k]
        return g(origins[rr] + c[:, None] * dirs[rr])

    out[rows] = _illinois(f, S[pick], S[pick + 1], V[pick], V[pick + 1])
    return out


def _root_near(f, s0: float, lo: float, hi: float, step: float = 2.0) -> Optional[float]:
    """The root of the scalar function ``f`` (vectorised over s) along
    [lo, hi] closest to s0, or None."""
    r = _roots_near(lambda xy: f(xy[:, 0]), [[0.0, 0.0]], [[1.0, 0.0]], s0, lo, hi, step)[0]
    return None if np.isnan(r) else float(r)


def _line_extent(origin: np.ndarray, direction: np.ndarray, ring: np.ndarray) -> Tuple[float, float]:
    """Smallest and largest parameter s where origin + s*direction meets the ring."""
    a = ring
    b = np.roll(ring, -1, axis=0)
    e = b - a
    den = direction[0] * e[:, 1] - direction[1] * e[:, 0]
    ok = np.abs(den) > 1e-12
    r = a - origin
    s = (r[:, 0] * e[:, 1] - r[:, 1] * e[:, 0])
    t = (r[:, 0] * direction[1] - r[:, 1] * direction[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        s = s / den
        t = t / den
    hit = ok & (t >= 0) & (t <= 1)
    if not hit.any():
        raise ValueError("section line misses the study area")
    return float(s[hit].min()), float(s[hit].max())


# ---------------------------------------------------------------------------
# Traces derived from a ground truth
# ---------------------------------------------------------------------------
def _fault_traces(geo: Geology, fm: FaultModel, sections: Sequence[Section], ring: np.ndarray,
                  rng: np.random.Generator, zero_throw_ok: bool = False,
                  far: Tuple[float, float] = (60.0, 100.0), npts: Tuple[int, int] = (4, 6),
                  inside=None, legacy_draws: bool = True, cut_step: float = 2.0) -> List[Trace]:
    """Traces of fault ``fm`` on every section that crosses it with throw.

    Per section: where the section crosses the fault's reference trace (its
    along-strike position must lie within the fault and carry at least
    ``MIN_TRACE_THROW`` of throw), per displaced layer the footwall and the
    hanging-wall cutoff (roots of side value minus fault surface within 500 m,
    bracketed on a ``cut_step`` metre scan),
    a polyline on each side from the cutoff to a far end ``far`` metres away
    (``rng.uniform(*far)``, ``rng.integers(*npts)`` points; shortened by 0.7
    up to 7 times until every point has a value and lies inside), and the
    fault-plane trace through all cutoffs. ``inside(xy) -> bool`` decides
    "inside" (default: the exact test on ``ring``).

    All roots and all evaluations of the truth are batched over the sections
    (and over the layers' polylines). With ``legacy_draws`` the random draws
    happen in the order of a section-by-section loop (section, layer, foot
    then hanging wall; a layer whose footwall polyline fails draws nothing
    for its hanging wall), so a given ``rng`` state gives the same traces as
    that loop (synthetic, paper_like); without, every layer draws for both
    sides and one batch suffices (random_ground)."""
    if inside is None:
        def inside(xy):
            return points_in_polygon(xy, ring)
    gx, gy = geo.origin
    displaced = [lay for lay in geo.layers if fm.layers.get(lay, 0.0) > 0.0]
    secs = list(sections)
    if not secs or not displaced:
        return []
    O = np.array([sec.origin for sec in secs])
    D = np.array([sec.direction for sec in secs])
    ext = np.array([_line_extent(sec.origin, sec.direction, ring) for sec in secs])
    s_in, s_out = ext[:, 0], ext[:, 1]

    def to_xy(k, s):
        return O[k] + s[:, None] * D[k]

    # Where each section crosses the fault's reference trace.
    s_c_all = _roots_near(lambda xy: fm.d(xy[:, 0] - gx, xy[:, 1] - gy), O, D,
                          0.5 * (s_in + s_out), s_in, s_out, step=5.0)
    fmax = fm.throw * max(fm.layers[lay] for lay in displaced)
    kept = []  # (section index, s_c, u_c, zero)
    for k in range(len(secs)):
        s_c = s_c_all[k]
        if np.isnan(s_c):
            continue
        xc = secs[k].to_xy([s_c])[0]
        u_c = float(fm.uw(xc[0] - gx, xc[1] - gy)[0])
        # 1e-6 m of slack: a zero-throw end section crosses at u_range[0 or 1]
        # up to rounding.
        if not (fm.u_range[0] - 1e-6 <= u_c <= fm.u_range[1] + 1e-6):
            continue
        tmax = fmax * float(fm.taper(u_c))
        zero = tmax < 1e-6
        if tmax < MIN_TRACE_THROW and not (zero and zero_throw_ok):
            continue
        kept.append((k, float(s_c), u_c, zero))
    if not kept:
        return []
    K = np.array([k for k, _, _, _ in kept])
    SC = np.array([s for _, s, _, _ in kept])
    LO = np.maximum(s_in[K], SC - 500.0)
    HI = np.minimum(s_out[K], SC + 500.0)
    # Everything below is evaluated within 500 m (cutoffs; the scan may pass
    # the end by half a step) plus at most far[1] (the far ends) of the
    # crossings: the faults that can matter there are enough (the same
    # values, see Geology.near).
    reach = 500.0 + cut_step + float(max(far)) + 1.0
    ends = np.stack([O[K] + (SC - reach)[:, None] * D[K], O[K] + (SC + reach)[:, None] * D[K]])
    geo = geo.near(fm.name, np.column_stack([ends[..., 0].min(axis=0), ends[..., 0].max(axis=0),
                                             ends[..., 1].min(axis=0), ends[..., 1].max(axis=0)]))

    def plane_at(xy):
        return geo.plane_z(fm.name, xy[:, 0], xy[:, 1])

    # Cutoffs of every displaced layer on every kept section.
    cuts: Dict[str, Tuple[np.ndarray, np.ndarray]] = {}
    for lay in displaced:
        r = []
        for side in ("foot", "hanging"):
            def g(xy, lay=lay, side=side):
                return geo.side_value(lay, fm.name, side, xy[:, 0], xy[:, 1]) - plane_at(xy)
            r.append(_roots_near(g, O[K], D[K], SC, LO, HI, step=cut_step))
        cuts[lay] = (r[0], r[1])

    # Far-end polylines: the draws in loop order, the evaluations batched.
    items = []  # (kept index, layer, s_f, s_h)
    for j, (k, s_c, u_c, zero) in enumerate(kept):
        for lay in displaced:
            s_f, s_h = cuts[lay][0][j], cuts[lay][1][j]
            if np.isnan(s_f) or np.isnan(s_h):
                continue
            if zero:
                s_h = s_f = 0.5 * (s_f + s_h)  # zero throw: the cutoffs coincide exactly
            items.append((j, lay, float(s_f), float(s_h)))
    sgn_fw = {j: (-1.0 if float(np.dot(D[k], fm.ndir)) > 0 else 1.0)
              for j, (k, _, _, _) in enumerate(kept)}
    polys = _draw_far_polylines(geo, fm, kept, items, sgn_fw, to_xy, inside, rng, far, npts, legacy_draws)

    layers_of: Dict[int, Dict[str, Dict[str, np.ndarray]]] = {j: {} for j in range(len(kept))}
    cutz_of: Dict[int, List[float]] = {j: [] for j in range(len(kept))}
    for i, (j, lay, _, _) in enumerate(items):
        foot, hang = polys[i]
        if foot is None or hang is None:
            continue
        if kept[j][3]:
            hang[0] = foot[-1]
        layers_of[j][lay] = {"foot": foot, "hanging": hang}
        cutz_of[j] += [foot[-1, 2], hang[0, 2]]
    J = [j for j in range(len(kept)) if layers_of[j]]
    if not J:
        return []

    # Plane traces: from above the highest to below the lowest cutoff, but
    # stopping short of layers this fault does not displace.
    xyc = np.array([secs[kept[j][0]].to_xy([kept[j][1]])[0] for j in J])
    zl_other = {lay: geo.truth(lay, xyc[:, 0], xyc[:, 1]) for lay in geo.layers if lay not in displaced}
    zs_of = []
    for t, j in enumerate(J):
        cut_z = cutz_of[j]
        m_top = m_bot = 50.0
        top_cut, bot_cut = max(cut_z), min(cut_z)
        for lay in geo.layers:
            if lay in displaced:
                continue
            zl = float(zl_other[lay][t])
            if zl > top_cut:
                m_top = min(m_top, 0.5 * (zl - top_cut))
            elif zl < bot_cut:
                m_bot = min(m_bot, 0.5 * (bot_cut - zl))
        zs = np.linspace(top_cut + m_top, bot_cut - m_bot, 6)
        zs = zs[np.min(np.abs(zs[:, None] - np.array(cut_z)[None, :]), axis=1) > 1.0]
        zs_of.append(np.unique(np.concatenate([zs, cut_z]))[::-1])
    # Solve plane(s) = z for all targets of all sections at once (bisection;
    # the plane is monotone in s along a section).
    row = np.concatenate([np.full(len(z), kept[j][0]) for j, z in zip(J, zs_of)])
    sc = np.concatenate([np.full(len(z), kept[j][1]) for j, z in zip(J, zs_of)])
    ZS = np.concatenate(zs_of)
    a = sc - 1500.0
    b = sc + 1500.0
    fa = plane_at(to_xy(row, a)) - ZS
    for _ in range(80):
        m = 0.5 * (a + b)
        fm_ = plane_at(to_xy(row, m)) - ZS
        left = (fm_ > 0) == (fa > 0)
        a = np.where(left, m, a)
        fa = np.where(left, fm_, fa)
        b = np.where(left, b, m)
    SP = 0.5 * (a + b)
    out = []  # (u, Trace)
    off = 0
    for j, zs in zip(J, zs_of):
        k, s_c, u_c, _ = kept[j]
        sp = SP[off:off + len(zs)]
        off += len(zs)
        plane = np.column_stack([secs[k].to_xy(sp), zs])
        # Cutoff points are exactly on the plane trace.
        for lay, sides in layers_of[j].items():
            for q in (sides["foot"][-1], sides["hanging"][0]):
                i = int(np.argmin(np.abs(plane[:, 2] - q[2])))
                if abs(plane[i, 2] - q[2]) < 1e-6:
                    plane[i] = q
        plane = plane[inside(plane[:, :2])]
        if len(plane) < 2:
            continue
        out.append((u_c, Trace(secs[k].name, plane, layers_of[j])))
    out.sort(key=lambda t: t[0])
    return [t for _, t in out]


def _draw_far_polylines(geo, fm, kept, items, sgn_fw, to_xy, inside, rng, far, npts, legacy_draws):
    """Draw the far distance and point count of every item's footwall and
    hanging-wall polyline and build them (:func:`_far_polylines`). With
    ``legacy_draws``, in the order of the old section-by-section loop: an
    item whose footwall polyline fails draws nothing for its hanging wall, so
    every later item's draws move; the items from the first such failure on
    are drawn and built again (until none is left)."""
    n_items = len(items)
    draws: List[List[Optional[Tuple[float, int]]]] = [[None, None] for _ in range(n_items)]
    polys: List[List[Optional[np.ndarray]]] = [[None, None] for _ in range(n_items)]
    states: List[Any] = [None] * (n_items + 1)
    states[0] = rng.bit_generator.state
    skip: set = set()
    start = 0
    while True:
        # Draw from item `start` on (the state before its draws is known).
        rng.bit_generator.state = states[start]
        for i in range(start, n_items):
            states[i] = rng.bit_generator.state
            d_f = (float(rng.uniform(*far)), int(rng.integers(*npts)))
            d_h = None if (legacy_draws and i in skip) else (float(rng.uniform(*far)),
                                                             int(rng.integers(*npts)))
            draws[i] = [d_f, d_h]
        states[n_items] = rng.bit_generator.state
        polys[start:] = _far_polylines(geo, fm, kept, items[start:], draws[start:], sgn_fw, to_xy, inside)
        fail = [i for i in range(start, n_items) if polys[i][0] is None and i not in skip]
        if not legacy_draws or not fail:
            break
        skip.add(fail[0])
        start = fail[0]
    rng.bit_generator.state = states[n_items]
    if legacy_draws:
        for i in skip:  # the loop stopped at the failed footwall
            polys[i][1] = None
    return polys


def _far_polylines(geo, fm, kept, items, draws, sgn_fw, to_xy, inside):
    """The footwall and hanging-wall polylines of every item (see
    :func:`_fault_traces`): per item [foot or None, hanging or None]. Up to
    eight tries, the far distance shortened by 0.7 after a failed one; the
    tries of all items and sides are evaluated together per (layer, side)."""
    res = [[None, None] for _ in items]
    pend = []  # (item, side index, side, s_cut, sgn, dist, n)
    for i, (j, lay, s_f, s_h) in enumerate(items):
        for si, (side, s_cut, sgn) in enumerate((("foot", s_f, sgn_fw[j]), ("hanging", s_h, -sgn_fw[j]))):
            if draws[i][si] is not None:
                pend.append([i, si, side, s_cut, sgn, draws[i][si][0], draws[i][si][1]])
    for _ in range(8):  # shorten until every point is valid and inside
        if not pend:
            break
        ss_of, xy_of = [], []
        for i, si, side, s_cut, sgn, dist, n in pend:
            far_s = s_cut + sgn * dist
            ss = np.linspace(far_s, s_cut, n) if side == "foot" else np.linspace(s_cut, far_s, n)
            ss_of.append(ss)
            xy_of.append(to_xy(np.full(n, kept[items[i][0]][0]), ss))
        z_of: List[Optional[np.ndarray]] = [None] * len(pend)
        groups: Dict[Tuple[str, str], List[int]] = {}
        for q, (i, si, side, *_r) in enumerate(pend):
            groups.setdefault((items[i][1], side), []).append(q)
        for (lay, side), qs in groups.items():
            xy = np.vstack([xy_of[q] for q in qs])
            z = geo.side_value(lay, fm.name, side, xy[:, 0], xy[:, 1])
            o = 0
            for q in qs:
                z_of[q] = z[o:o + len(xy_of[q])].copy()
                o += len(xy_of[q])
        # The cutoff point itself lies on the fault surface.
        icut = [len(ss_of[q]) - 1 if pend[q][2] == "foot" else 0 for q in range(len(pend))]
        pc = np.array([xy_of[q][icut[q]] for q in range(len(pend))])
        zc = geo.plane_z(fm.name, pc[:, 0], pc[:, 1])
        allxy = np.vstack(xy_of)
        ins = inside(allxy)
        nxt, o = [], 0
        for q, e in enumerate(pend):
            z = z_of[q]
            z[icut[q]] = zc[q]
            n = len(z)
            if np.all(np.isfinite(z)) and np.all(ins[o:o + n]):
                res[e[0]][e[1]] = np.column_stack([xy_of[q], z])
            else:
                e[5] *= 0.7
                nxt.append(e)
            o += n
        pend = nxt
    return res


def _tip_xy(geo: Geology, fm: FaultModel, u: float, layer: str) -> np.ndarray:
    """Global XY where the cutoff line of ``layer`` reaches along-strike
    position ``u`` (at a tip the throw is zero, so both cutoffs meet there)."""
    gx, gy = geo.origin

    def f(w):
        p = fm.xy(np.full(w.shape, u), w)
        return geo.unfaulted(layer, p[:, 0] + gx, p[:, 1] + gy) - fm.plane_z(p[:, 0], p[:, 1])

    w0 = float(fm.bend_offset(u))
    w = _root_near(f, w0, w0 - 800.0, w0 + 800.0)
    if w is None:
        raise ValueError(f"fault {fm.name!r}: no cutoff of {layer!r} at its tip")
    p = fm.xy([u], [w])[0]
    return p + geo.origin


def _fault_from_model(geo: Geology, fm: FaultModel, sections, ring, rng, tip_layer,
                      zero_throw_ok=False) -> Fault:
    traces = _fault_traces(geo, fm, sections, ring, rng, zero_throw_ok=zero_throw_ok)
    tips = []
    for end in fm.tips:
        u = fm.u_range[0] if end == "start" else fm.u_range[1]
        tips.append(_tip_xy(geo, fm, u, tip_layer))
    return Fault(fm.name, fm.kind, fm.group, np.array(tips).reshape(-1, 2), traces)


def _boreholes(geo: Geology, holes: List[Tuple[str, float, float, str]]) -> Boreholes:
    """Rows for holes (id, x, y, deepest layer reached): every sheet of every
    layer down to the deepest one, top down (two rows for a layer repeated by a
    reverse fault, none where a normal fault cut it out); equal elevations keep
    the layer order."""
    x = np.array([h[1] for h in holes], dtype=np.float64)
    y = np.array([h[2] for h in holes], dtype=np.float64)
    depth = np.array([geo.layers.index(h[3]) for h in holes], dtype=np.int64)
    # Every layer's sheets side by side: the row-major order of the valid
    # entries is (hole, layer, sheet), as a stable sort by hole would give.
    S, lay_of = [], []
    for li, lay in enumerate(geo.layers):
        s = geo.sheets(lay, x, y)
        s[~(depth >= li)] = np.nan
        S.append(s)
        lay_of.append(np.full(s.shape[1], li))
    S = np.concatenate(S, axis=1)
    lay_of = np.concatenate(lay_of)
    hole_i, col = np.nonzero(np.isfinite(S))
    lay_i = lay_of[col]
    zs = S[hole_i, col]
    # Per hole, top down; ties in z keep (layer, sheet) order as a stable sort
    # would. Holes whose rows already run top down keep them: only the others
    # are sorted (the same order as sorting all).
    bad = (hole_i[1:] == hole_i[:-1]) & (zs[1:] > zs[:-1])
    if bad.any():
        sub = np.flatnonzero(np.isin(hole_i, hole_i[1:][bad]))
        o = sub[np.lexsort((sub, -zs[sub], hole_i[sub]))]
        hole_i[sub], lay_i[sub], zs[sub] = hole_i[o], lay_i[o], zs[o]
    ids = np.array([h[0] for h in holes])
    return Boreholes(ids[hole_i] if len(holes) else np.zeros(0, dtype=str),
                     np.column_stack([x[hole_i], y[hole_i]]) if len(holes) else np.zeros((0, 2)),
                     np.array(geo.layers)[lay_i] if len(holes) else np.zeros(0, dtype=str), zs)


def _band_point(geo: Geology, fm: FaultModel, u: float, layer: str) -> Optional[np.ndarray]:
    """Global XY in the middle of the band (overlap or gap) of ``layer`` at
    along-strike position ``u``."""
    gx, gy = geo.origin
    w0 = float(fm.bend_offset(u))

    def side(name):
        def f(w):
            p = fm.xy(np.full(w.shape, u), w) + geo.origin
            return geo.side_value(layer, fm.name, name, p[:, 0], p[:, 1]) - \
                geo.plane_z(fm.name, p[:, 0], p[:, 1])
        return f

    wf = _root_near(side("foot"), w0, w0 - 600, w0 + 600)
    wh = _root_near(side("hanging"), w0, w0 - 600, w0 + 600)
    if wf is None or wh is None:
        return None
    return fm.xy([u], [0.5 * (wf + wh)])[0] + geo.origin


def _spread_points(rng, ring, n, min_dist, existing, inset, tries=20000):
    """Up to ``n`` random points inside ``ring`` (at least ``inset`` from its
    vertices' bounding box edges and inside), at least ``min_dist`` apart from
    each other and from ``existing``."""
    lo = ring.min(axis=0) + inset
    hi = ring.max(axis=0) - inset
    pts = [np.asarray(p) for p in existing]
    out = []
    for _ in range(tries):
        if len(out) >= n:
            break
        p = rng.uniform(lo, hi)
        if not points_in_polygon(p[None, :], ring)[0]:
            continue
        # Keep ``inset`` from the boundary: test the 4 offset points as well.
        offs = np.array([[inset, 0], [-inset, 0], [0, inset], [0, -inset]])
        if not points_in_polygon(p[None, :] + offs, ring).all():
            continue
        if pts and np.min(np.hypot(*(np.array(pts) - p).T)) < min_dist:
            continue
        pts.append(p)
        out.append(p)
    return out


# ---------------------------------------------------------------------------
# The paper-like study area
# ---------------------------------------------------------------------------
_PAPER_ORIGIN = np.array([512400.0, 3926800.0])
_PAPER_BOUNDARY = np.array([[0, 150], [1200, 0], [2900, 60], [4180, 0], [4150, 1900],
                            [4180, 4170], [2100, 4100], [0, 4170], [60, 2100]], dtype=np.float64)
_PAPER_LINES = ["I", "II", "III", "IV", "V", "VI", "VII", "VIII", "supp6"]
_P1 = (3150.0, 3350.0)   # third impervious bed pinches onto coal 8 here
_P2 = (3450.0, 480.0)    # coal 8 - coal 10 interval thins to a few metres here


def _paper_geology(seed: int) -> Geology:
    rng = np.random.default_rng([seed, 0x6E0])
    ph = rng.uniform(0.0, 2.0 * np.pi, size=12)
    k = lambda wl, az: (2 * np.pi / wl * np.sin(np.deg2rad(az)), 2 * np.pi / wl * np.cos(np.deg2rad(az)))
    # Coal 8: a monocline dipping gently to the south-east, with open folds and
    # two basins (where the thin intervals are).
    coal8 = smooth_field(
        base=-330.0, gradient=(-0.035, -0.018),
        waves=[(14.0, *k(2600, 35), ph[0]), (8.0, *k(1700, 120), ph[1]), (3.0, *k(900, 70), ph[2])],
        bumps=[(-60.0, *_P1, 350.0), (-70.0, *_P2, 350.0), (12.0, 1800.0, 2000.0, 700.0)])
    # Third impervious bed: 125-180 m above coal 8, pinching to 3 m at P1.
    bed3_th = smooth_field(base=150.0, waves=[(25.0, *k(3200, 10), ph[3])])
    # Coal 8 - coal 10 interval: 37-47 m, thinning to 4 m at P2.
    c10_th = smooth_field(base=42.0, waves=[(5.0, *k(2500, 150), ph[4])])

    def pinch(X, Y, c, sigma):
        return 1.0 - np.exp(-((X - c[0]) ** 2 + (Y - c[1]) ** 2) / (2 * sigma * sigma))

    topo = smooth_field(base=40.0, gradient=(0.0008, -0.0006),
                        waves=[(3.0, *k(3000, 60), ph[5]), (1.5, *k(1300, 150), ph[6])])

    def topsoil(X, Y):
        # A river valley meandering west-east.
        yv = 2600.0 + 300.0 * np.sin(2 * np.pi * X / 3000.0 + ph[7])
        return topo(X, Y) - 5.0 * np.exp(-((Y - yv) ** 2) / (2 * 80.0 ** 2))

    def bed3(X, Y):
        return coal8(X, Y) + 3.0 + bed3_th(X, Y) * pinch(X, Y, _P1, 450.0)

    def coal10(X, Y):
        return coal8(X, Y) - (4.0 + c10_th(X, Y) * pinch(X, Y, _P2, 650.0))

    surfaces = {"topsoil": topsoil, "third impervious bed": bed3, "coal 8": coal8, "coal 10": coal10}
    layers = list(surfaces)

    def zref(x, y):
        return float(coal8(np.array(x), np.array(y)))

    c8, c10, b3 = "coal 8", "coal 10", "third impervious bed"
    a21 = np.array([2000.0, 800.0])
    s85 = np.array([np.sin(np.deg2rad(85.0)), np.cos(np.deg2rad(85.0))])
    j = a21 + 200.0 * s85  # where 4F2 meets 2F1
    faults = [
        FaultModel("2F4", "reverse", anchor=(1200.0, 3300.0), strike=100.0, dip=40.0, throw=35.0,
                   u_range=(-650.0, 650.0), z_ref=zref(1200.0, 3300.0), layers={c8: 1.0, c10: 1.0},
                   bend=35.0, flat=150.0, decay=450.0),
        FaultModel("F22", "normal", anchor=(3500.0, 2000.0), strike=80.0, dip=65.0, throw=30.0,
                   u_range=(-900.0, 1500.0), z_ref=zref(3500.0, 2000.0),
                   layers={b3: 0.6, c8: 1.0, c10: 1.0}, bend=-50.0, flat=150.0, decay=450.0,
                   tips=("start",)),
        FaultModel("2F1", "reverse", anchor=tuple(a21), strike=85.0, dip=45.0, throw=30.0,
                   u_range=(-800.0, 800.0), z_ref=zref(*a21), layers={c8: 1.0, c10: 1.0},
                   bend=40.0, flat=150.0, decay=450.0, group="2F1-4F2"),
        # 4F2 abuts 2F1 from its footwall (north) side; coal 10 is not displaced
        # by it (paper, section 3.2).
        FaultModel("4F2", "normal", anchor=tuple(j), strike=150.0, dip=60.0, throw=20.0,
                   u_range=(-1800.0, 500.0), z_ref=zref(*j), layers={c8: 1.0}, bend=-30.0,
                   flat=150.0, decay=400.0, abuts=("2F1", "foot"), group="2F1-4F2",
                   tips=("start",)),
    ]
    return Geology(layers, surfaces, faults, origin=_PAPER_ORIGIN)


def paper_like(seed: int = 0) -> Dataset:
    """The paper's study area (Gao et al. 2025, section 3.1) from a ground truth.

    Deterministic for a given ``seed``: the seed varies the folds of the
    layers, the positions of the boreholes and the far ends of the traces; the
    faults and the exploration lines stay where they are. See the module
    docstring for what is generated and :func:`faultmesh.geology.Geology.truth`
    for the truth.
    """
    geo = _paper_geology(seed)
    rng = np.random.default_rng([seed, 0xB0E])
    ring = _PAPER_BOUNDARY + _PAPER_ORIGIN
    gx, gy = _PAPER_ORIGIN
    lay = geo.layers
    top, b3, c8, c10 = lay

    # Nine parallel exploration lines, azimuth 15 degrees, 475 m apart.
    az = 15.0
    e = np.array([np.cos(np.deg2rad(az)), -np.sin(np.deg2rad(az))])
    dvec = np.array([np.sin(np.deg2rad(az)), np.cos(np.deg2rad(az))])
    sections: Dict[str, Section] = {}
    for name, off in zip(_PAPER_LINES, np.arange(-400.0, 3401.0, 475.0)):
        origin = np.round(_PAPER_ORIGIN + off * e - 300.0 * dvec, 2)
        sections[name] = Section(name, origin, az)

    # Boreholes: along the exploration lines, ...
    holes: List[Tuple[str, float, float, str]] = []
    for sec in sections.values():
        s_in, s_out = _line_extent(sec.origin, sec.direction, ring)
        n = max(2, int(round((s_out - s_in - 160.0) / 430.0)) + 1)
        ss = np.linspace(s_in + 80.0, s_out - 80.0, n)
        for i, s in enumerate(ss):
            s = s + rng.uniform(-50.0, 50.0)
            p = sec.to_xy([s])[0] + rng.uniform(-20.0, 20.0) * np.array([dvec[1], -dvec[0]])
            if points_in_polygon(p[None, :], ring)[0]:
                holes.append((f"{sec.name}-{i + 1}", p[0], p[1], c10))
    # ... a few placed in the overlap bands of the reverse faults (a vertical
    # hole there meets the layer twice), ...
    special = []
    for fname, u, layer in (("2F4", -150.0, c8), ("2F4", 250.0, c8), ("2F4", 50.0, c10),
                            ("2F1", -350.0, c8), ("2F1", 550.0, c8), ("2F1", -50.0, c10)):
        p = _band_point(geo, geo.fault(fname), u, layer)
        if p is not None:
            special.append((f"R{len(special) + 1}", p[0], p[1], c10))
    # ... hydrogeological holes that stop in the third impervious bed and holes
    # that stop at coal 8, among them one each in the two thin-interval areas
    # (where the borehole TINs of neighbouring layers then cross), ...
    special.append(("S1", gx + _P1[0] + 15.0, gy + _P1[1] - 10.0, b3))
    special.append(("S2", gx + _P2[0] - 10.0, gy + _P2[1] + 20.0, c8))
    holes += special
    n_rest = 112 - len(holes)
    pts = _spread_points(rng, ring, n_rest, 190.0, [(h[1], h[2]) for h in holes], inset=60.0)
    stop = [b3] * 4 + [c8] * 6
    for i, p in enumerate(pts):
        holes.append((f"ZK{i + 1}", p[0], p[1], stop[i] if i < len(stop) else c10))
    if len(holes) != 112:  # pragma: no cover - the area has room for many more
        raise RuntimeError(f"paper_like: placed {len(holes)} boreholes, expected 112")
    # Surveyed collar coordinates to the centimetre.
    holes = [(h, round(x, 2), round(y, 2), d) for h, x, y, d in holes]
    boreholes = _boreholes(geo, holes)

    # Topographic survey points for the topsoil: a jittered 200 m grid plus the
    # boundary vertices.
    g = np.arange(100.0, 4180.0, 200.0)
    X, Y = np.meshgrid(g, np.arange(100.0, 4170.0, 200.0))
    P = np.column_stack([X.ravel(), Y.ravel()]) + rng.uniform(-60.0, 60.0, size=(X.size, 2)) + _PAPER_ORIGIN
    P = np.vstack([ring, P[points_in_polygon(P, ring)]])
    P = np.round(P, 2)
    topo = np.column_stack([P, geo.truth(top, P[:, 0], P[:, 1])])

    geo.check_disjoint(*np.meshgrid(np.arange(-200.0, 4400.0, 50.0) + gx,
                                    np.arange(-200.0, 4400.0, 50.0) + gy))
    secs = list(sections.values())
    faults = [_fault_from_model(geo, geo.fault(n), secs, ring, rng, c8)
              for n in ("2F4", "F22", "2F1", "4F2")]
    ds = Dataset(name="paper_like", layers=list(lay), boundary=ring, boreholes=boreholes,
                 points={top: topo}, sections=sections, faults=faults,
                 crs="local projected grid in metres (synthetic, Gauss-Kruger-like magnitudes)",
                 truth=geo.truth, geology=geo)
    return ds


def paper_like_path() -> Path:
    """Path of the shipped format-v1 copy of ``paper_like(0)``."""
    return Path(__file__).resolve().parent / "data" / "paper_like" / "dataset.json"


# ---------------------------------------------------------------------------
# Synthetic datasets
# ---------------------------------------------------------------------------
def synthetic(seed: int = 0, *, n_layers: int = 3, strike: float = 60.0, dip: float = 60.0,
              throw: float = 20.0, kind: str = "normal",
              area: Union[float, Tuple[float, float]] = (3000.0, 2500.0),
              end_traces: str = "tips", n_faults: int = 1, n_sections: int = 5,
              n_boreholes: int = 60, origin: Optional[Sequence[float]] = None) -> Dataset:
    """A random but valid dataset from a ground truth faultmesh has never seen.

    ``n_layers`` layers (1 to 12) with smooth, non-planar tops 20-60 m apart;
    ``n_faults`` parallel faults (spread across the area) of ``kind``
    ("normal", "reverse" or "mixed": alternating) with ``strike`` (degrees
    clockwise from north), ``dip`` (degrees, 20-85) and maximum ``throw`` (m),
    displacing every layer; ``area`` is the size (width, height) of the study
    area (or one number for a square), placed at ``origin`` (random large
    coordinates by default). ``n_sections`` parallel sections run in the dip
    direction, spread along strike. ``end_traces``: "tips" -> each fault ends
    between sections at tip points (dataset ``tips``), "zero_throw" -> each
    fault ends exactly on the first and last section, whose traces have zero
    throw (the two cutoffs coincide) and there are no tips.
    """
    if not 1 <= n_layers <= 12:
        raise ValueError(f"synthetic: n_layers must be 1..12, got {n_layers}")
    if not 20.0 <= dip <= 85.0:
        raise ValueError(f"synthetic: dip must be in [20, 85] degrees, got {dip}")
    if kind not in ("normal", "reverse", "mixed"):
        raise ValueError(f"synthetic: kind must be 'normal', 'reverse' or 'mixed', got {kind!r}")
    if end_traces not in ("tips", "zero_throw"):
        raise ValueError(f"synthetic: end_traces must be 'tips' or 'zero_throw', got {end_traces!r}")
    if n_faults < 0 or n_sections < 3:
        raise ValueError("synthetic: need n_faults >= 0 and n_sections >= 3")
    if not 1.0 <= throw <= 200.0:
        raise ValueError(f"synthetic: throw must be in [1, 200] m, got {throw}")
    W, H = (float(area), float(area)) if np.isscalar(area) else map(float, area)
    if min(W, H) < 500.0:
        raise ValueError(f"synthetic: area must be at least 500 m across, got {area}")
    rng = np.random.default_rng([seed, 0x5E7])
    org = np.asarray(origin, dtype=np.float64) if origin is not None else \
        np.round(rng.uniform([1e5, 1e6], [9e5, 6e6]), 0)

    # Layers: a reference top with folds, then positive intervals.
    ph = rng.uniform(0.0, 2 * np.pi, size=(n_layers + 1, 3))
    wl = rng.uniform(0.6, 1.5, size=3) * max(W, H)
    az = rng.uniform(0.0, 180.0, size=3)
    base = rng.uniform(-600.0, 0.0)
    grad = rng.uniform(-0.01, 0.01, size=2)

    def wave(amp, i, j):
        a = np.deg2rad(az[j])
        return (amp, 2 * np.pi / wl[j] * np.sin(a), 2 * np.pi / wl[j] * np.cos(a), ph[i, j])

    top = smooth_field(base=base, gradient=grad, waves=[wave(8.0, 0, 0), wave(3.0, 0, 1)])
    th_base = rng.uniform(25.0, 50.0, size=n_layers - 1)
    thick = [smooth_field(base=float(b), waves=[wave(5.0, i + 1, 2)]) for i, b in enumerate(th_base)]
    names = [f"L{i + 1}" for i in range(n_layers)]
    surfaces = layer_stack(names, top, thick)

    # Boundary: the rectangle with each side's midpoint pushed in a little
    # (star-shaped around the centre, hence simple).
    ctr = np.array([W / 2, H / 2])
    corners = np.array([[0, 0], [W, 0], [W, H], [0, H]], dtype=np.float64)
    ring_l = []
    for i in range(4):
        a, b = corners[i], corners[(i + 1) % 4]
        mid = 0.5 * (a + b)
        ring_l += [a, mid + (ctr - mid) * rng.uniform(0.0, 0.08)]
    ring_local = np.array(ring_l)
    ring = ring_local + org

    # Faults: parallel, spread along the dip direction through the centre,
    # inside a ring shrunk by 10 % so traces and tips stay inside the area.
    sd = np.array([np.sin(np.deg2rad(strike)), np.cos(np.deg2rad(strike))])
    nd = np.array([np.cos(np.deg2rad(strike)), -np.sin(np.deg2rad(strike))])
    inset = ctr + 0.9 * (ring_local - ctr)
    tan_d = float(np.tan(np.deg2rad(dip)))
    heave = throw / tan_d
    wa, wb = _line_extent(ctr, nd, inset)
    spacing = (wb - wa) / (n_faults + 1)
    w0s = [wa + spacing * (i + 1) for i in range(n_faults)] or [0.0]
    # Cutoffs of the layers lie up to about half the layer stack (plus folds)
    # divided by tan(dip) from a fault's reference trace; the tips are there.
    depth_span = float(np.sum(th_base + 5.0)) + 30.0
    off = 0.5 * depth_span / tan_d + heave + 30.0
    A, B = -np.inf, np.inf
    for w0 in w0s:
        for o in (-off, 0.0, off):
            try:
                a_, b_ = _line_extent(ctr + (w0 + o) * nd, sd, inset)
            except ValueError:
                a_, b_ = 0.0, 0.0
            A, B = max(A, a_), min(B, b_)
    if B - A < 300.0:
        raise ValueError(f"synthetic: faults with dip {dip} and {n_layers} layers do not fit in an "
                         f"area of {W:g} x {H:g} m along strike {strike}; use a larger area, a steeper "
                         "dip or fewer layers")
    sec_az = (strike + 90.0) % 360.0
    if end_traces == "zero_throw":
        u_sec = np.linspace(A, B, n_sections)
        u_range = (float(u_sec[0]), float(u_sec[-1]))
    else:
        step = (B - A) / (n_sections + 1)
        u_sec = A + step * np.arange(1, n_sections + 1)
        u_range = (float(A + 0.5 * step), float(B - 0.5 * step))
    sections: Dict[str, Section] = {}
    for i, u in enumerate(u_sec):
        o = org + ctr + u * sd + (wa - 0.2 * (wb - wa)) * nd
        sections[f"S{i + 1}"] = Section(f"S{i + 1}", o, sec_az)
    faults_m = []
    for i, w0 in enumerate(w0s[:n_faults]):
        anchor = ctr + w0 * nd
        k = kind if kind != "mixed" else ("normal" if i % 2 == 0 else "reverse")
        zr = float(np.mean([surfaces[n](anchor[0:1], anchor[1:2])[0] for n in names]))
        bend = float(rng.uniform(-1.0, 1.0) * min(30.0, 0.03 * (B - A)))
        # Where the layers meet this fault: their distance d from its trace.
        uu = np.linspace(u_range[0], u_range[1], 50)
        pts = anchor[None, :] + uu[:, None] * sd[None, :]
        dl = np.concatenate([(zr - surfaces[n](pts[:, 0], pts[:, 1])) / tan_d for n in names])
        flat = float(dl.max()) + heave + 20.0
        decay = min(600.0, spacing - (flat - float(dl.min())) - 2.0 * heave - 40.0)
        if decay < max(50.0, 3.0 * heave):
            raise ValueError(f"synthetic: {n_faults} fault(s) with dip {dip} and throw {throw} m do "
                             f"not fit in an area of {W:g} x {H:g} m; use fewer faults, a larger "
                             "area, a steeper dip or a smaller throw")
        faults_m.append(FaultModel(
            f"F{i + 1}", k, anchor=anchor, strike=strike, dip=dip, throw=throw,
            u_range=u_range, z_ref=zr, layers={n: 1.0 for n in names}, bend=bend,
            flat=flat, decay=decay, tips=("start", "end") if end_traces == "tips" else ()))
    geo = Geology(names, surfaces, faults_m, origin=org)
    if n_faults:
        gxs = np.linspace(ring[:, 0].min(), ring[:, 0].max(), 80)
        gys = np.linspace(ring[:, 1].min(), ring[:, 1].max(), 80)
        geo.check_disjoint(*np.meshgrid(gxs, gys))

    # Boreholes: a jittered grid, every hole down to the lowest layer, plus one
    # hole in the overlap band of each reverse fault.
    n_side = max(2, int(round(np.sqrt(n_boreholes * W / H))))
    m_side = max(2, int(round(n_boreholes / n_side)))
    gx_ = (np.arange(n_side) + 0.5) / n_side * W
    gy_ = (np.arange(m_side) + 0.5) / m_side * H
    GX, GY = np.meshgrid(gx_, gy_)
    jit = 0.3 * min(W / n_side, H / m_side)
    P = np.column_stack([GX.ravel(), GY.ravel()]) + rng.uniform(-jit, jit, size=(GX.size, 2)) + org
    P = P[points_in_polygon(P, ring)]
    holes = [(f"B{i + 1}", x, y, names[-1]) for i, (x, y) in enumerate(P)]
    for fm in faults_m:
        if fm.kind == "reverse":
            p = _band_point(geo, fm, 0.0, names[len(names) // 2])
            if p is not None and points_in_polygon(p[None, :], ring)[0]:
                holes.append((f"R{fm.name}", p[0], p[1], names[-1]))
    boreholes = _boreholes(geo, holes)

    rng_t = np.random.default_rng([seed, 0x7A])
    secs = list(sections.values())
    faults = [_fault_from_model(geo, fm, secs, ring, rng_t, names[0],
                                zero_throw_ok=end_traces == "zero_throw") for fm in faults_m]
    name = f"synthetic-{seed}"
    return Dataset(name=name, layers=names, boundary=ring, boreholes=boreholes, points={},
                   sections=sections, faults=faults, crs="synthetic local grid, metres",
                   truth=geo.truth, geology=geo)


def _write_shipped() -> Path:  # pragma: no cover - maintenance entry point
    p = paper_like_path()
    return paper_like(0).save(p.parent, section_coords=True)


if __name__ == "__main__":  # pragma: no cover
    print(_write_shipped())


# Random grounds (faultmesh/grounds.py): re-exported here beside synthetic.
from .grounds import random_ground  # noqa: E402
