"""Streaming statistics: memory independent of the number of realizations.

:class:`StreamingStats` keeps, per node of a flat array, the count, mean and
standard deviation (Welford's update; NaN samples are skipped per node), the
minimum and maximum, and quantiles by the P-squared algorithm (Jain and
Chlamtac 1985) in its extended form for several quantiles (Raatikainen
1987), vectorised over the nodes: ``M`` markers per node whose heights
follow the quantiles at probabilities ``marker_probs`` (0, the requested
ones, points between them, 1), each adjusted by a piecewise-parabolic
prediction as samples arrive. Until a node has ``M`` samples they are kept
and its quantiles are exact (numpy's default linear interpolation); after
that the estimate's error is documented in docs/ensemble.md and tested
against ``np.percentile`` of the stored samples.

Both the Welford update and the P-squared markers depend on the order of
the samples (in the last bits, and in the estimate respectively), so the
ensemble feeds them in realization order: bit-identical results for any
number of workers. :class:`Reducer` also counts fault sides and fault
blocks (integer counts: order-independent).
"""
from __future__ import annotations

from typing import Dict, Optional, Sequence

import numpy as np

from .sampling import SIDE_FOOT, SIDE_HANGING, Samples

__all__ = ["StreamingStats", "marker_probabilities", "Reducer", "QUANTILES"]

#: The quantiles the ensemble reports (P10, P50, P90).
QUANTILES = (0.1, 0.5, 0.9)


def marker_probabilities(probs: Sequence[float], refine: int = 2) -> np.ndarray:
    """Marker probabilities: 0, ``probs``, 1 and ``refine`` - 1 evenly spaced
    points inside each interval between them (refine=2: the midpoints of the
    extended P-squared algorithm; more markers follow the distribution's
    shape more closely at the cost of memory)."""
    p = np.unique(np.r_[0.0, np.asarray(probs, dtype=np.float64), 1.0])
    if p[0] < 0 or p[-1] > 1:
        raise ValueError(f"marker_probabilities: probabilities must lie in [0, 1], got {probs}")
    out = [p[0]]
    for a, b in zip(p[:-1], p[1:]):
        out += list(a + (b - a) * np.arange(1, refine) / refine) + [b]
    return np.array(out)


class StreamingStats:
    """Count, mean, standard deviation, min, max and quantiles of a stream of
    arrays of ``size`` values (see module doc). Memory: (2 M + 3) float64 per
    node, M = len(marker_probabilities(probs, refine))."""

    def __init__(self, size: int, probs: Sequence[float] = QUANTILES, refine: int = 4,
                 exact: int = 64) -> None:
        self.size = int(size)
        self.probs = tuple(float(v) for v in probs)
        self.p = marker_probabilities(self.probs, refine)
        self.M = len(self.p)
        self.B = max(int(exact), self.M)
        # Initial marker ranks (1-based) in the B first samples: the desired
        # positions 1 + (B - 1) p, rounded, made strictly increasing.
        j = np.arange(self.M)
        r = np.clip(np.rint(1.0 + (self.B - 1) * self.p).astype(np.int64), j + 1,
                    self.B - (self.M - 1 - j))
        for k in range(1, self.M):
            r[k] = max(r[k], r[k - 1] + 1)
        self._rank0 = r
        self._at = {q: int(np.argmin(np.abs(self.p - q))) for q in self.probs}
        self.count = np.zeros(self.size, dtype=np.int64)
        self.mean_ = np.zeros(self.size)
        self._m2 = np.zeros(self.size)
        self._buf: Optional[np.ndarray] = np.zeros((self.B, self.size))  # the first B samples
        self._q = np.zeros((self.M, self.size))        # marker heights
        self._n = np.zeros((self.M, self.size))        # marker positions, 1-based

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.count, self.mean_, self._m2, self._q, self._n,
                                      self._buf if self._buf is not None else self.count[:0]))

    def add(self, x: np.ndarray) -> None:
        """One sample per node (NaN: no sample at that node)."""
        x = np.asarray(x, dtype=np.float64).reshape(-1)
        if x.shape != (self.size,):
            raise ValueError(f"StreamingStats.add: expected {self.size} values, got {x.size}")
        fin = np.isfinite(x)
        idx = np.flatnonzero(fin)
        if len(idx) == 0:
            return
        xv = x[idx]
        c = self.count[idx] + 1
        self.count[idx] = c
        # Welford.
        m = self.mean_[idx]
        d = xv - m
        m = m + d / c
        self.mean_[idx] = m
        self._m2[idx] += d * (xv - m)
        # Start-up: the first B samples are kept; at the B-th the markers
        # start at their desired ranks among them.
        first = c <= self.B
        if first.any():
            if self._buf is None:   # freed earlier; a node got its first sample late
                self._buf = np.zeros((self.B, self.size))
            fi = idx[first]
            self._buf[c[first] - 1, fi] = xv[first]
            full = fi[c[first] == self.B]
            # In chunks of nodes: a sorted copy of the whole buffer would
            # double its memory for a moment.
            for k in range(0, len(full), 4096):
                part = full[k:k + 4096]
                srt = np.sort(self._buf[:, part], axis=0)
                self._q[:, part] = srt[self._rank0 - 1]
                self._n[:, part] = self._rank0.astype(np.float64)[:, None]
        rest = ~first
        if rest.any():
            self._p2(idx[rest], xv[rest], c[rest])
        # The start-up buffer is freed once no node is part-way through it
        # (so memory stays bounded whatever n is).
        if self._buf is not None and not np.any((self.count > 0) & (self.count < self.B)):
            if np.any(self.count >= self.B):
                self._buf = None

    def _p2(self, idx: np.ndarray, x: np.ndarray, c: np.ndarray) -> None:
        full = len(idx) == self.size
        Q = self._q if full else self._q[:, idx]       # views when every node takes part
        N = self._n if full else self._n[:, idx]
        M = self.M
        # Cell k with Q[k] <= x < Q[k+1]; new extremes become the end markers.
        k = np.count_nonzero(Q <= x[None, :], axis=0) - 1
        np.minimum(Q[0], x, out=Q[0])
        np.maximum(Q[-1], x, out=Q[-1])
        np.clip(k, 0, M - 2, out=k)
        N += np.arange(M)[:, None] > k[None, :]
        D = (1.0 + (c - 1).astype(np.float64)[None, :] * self.p[:, None]) - N
        cand = np.abs(D) >= 1.0
        cand[0] = cand[-1] = False
        # Markers are adjusted in order j = 1 .. M-2 (each adjustment sees its
        # lower neighbour's new value, as in the sequential algorithm); only
        # the few nodes whose marker is a position or more off its desired
        # position take part.
        for j in np.flatnonzero(cand.any(axis=1)):
            sel = np.flatnonzero(cand[j])
            d = D[j, sel]
            nj, nl, nh = N[j, sel], N[j - 1, sel], N[j + 1, sel]
            up = (d >= 1.0) & (nh - nj > 1.0)
            dn = (d <= -1.0) & (nl - nj < -1.0)
            mv = up | dn
            if not mv.any():
                continue
            sel, up = sel[mv], up[mv]
            nj, nl, nh = nj[mv], nl[mv], nh[mv]
            qj, ql, qh = Q[j, sel], Q[j - 1, sel], Q[j + 1, sel]
            s = np.where(up, 1.0, -1.0)
            qp = qj + s / (nh - nl) * ((nj - nl + s) * (qh - qj) / (nh - nj)
                                       + (nh - nj - s) * (qj - ql) / (nj - nl))
            lin = qj + s * np.where(up, (qh - qj) / (nh - nj), (ql - qj) / (nl - nj))
            Q[j, sel] = np.where((ql < qp) & (qp < qh), qp, lin)
            N[j, sel] = nj + s
        if not full:
            self._q[:, idx] = Q
            self._n[:, idx] = N

    # -- results --------------------------------------------------------------
    def mean(self) -> np.ndarray:
        return np.where(self.count > 0, self.mean_, np.nan)

    def std(self) -> np.ndarray:
        """Sample standard deviation (ddof = 1); NaN with fewer than 2 samples."""
        with np.errstate(divide="ignore", invalid="ignore"):
            v = self._m2 / (self.count - 1)
        return np.where(self.count > 1, np.sqrt(np.maximum(v, 0.0)), np.nan)

    def quantile(self, q: float) -> np.ndarray:
        """The estimate of quantile ``q`` (one of ``probs``, 0 = min, 1 = max)."""
        q = float(q)
        if q not in self._at and q not in (0.0, 1.0):
            raise ValueError(f"StreamingStats: quantile {q} not tracked; tracked {self.probs}")
        j = 0 if q == 0.0 else (self.M - 1 if q == 1.0 else self._at[q])
        out = np.full(self.size, np.nan)
        big = self.count >= self.B
        out[big] = self._q[j, big]
        for c in np.unique(self.count[(self.count > 0) & ~big]):
            sel = np.flatnonzero(self.count == c)
            out[sel] = np.percentile(self._buf[:c, sel], 100.0 * q, axis=0)
        return out

    def minimum(self) -> np.ndarray:
        return self.quantile(0.0)

    def maximum(self) -> np.ndarray:
        return self.quantile(1.0)


class Reducer:
    """All statistics of an ensemble, fed one :class:`Samples` at a time in
    realization order (:meth:`add`)."""

    def __init__(self, n_layers: int, n_faults: int, n_nodes: int, n_sections: int,
                 n_section_samples: int, n_points: int, lower_sheet: bool,
                 refine: int = 4, exact: int = 64) -> None:
        L, F, N = n_layers, n_faults, n_nodes
        self.shape = {"grid": (L, N), "sections": (n_sections, L, n_section_samples),
                      "points": (L, n_points)}
        kw = {"refine": refine, "exact": exact}
        self.stats: Dict[str, StreamingStats] = {
            "grid": StreamingStats(L * N, **kw),
            "sections": StreamingStats(n_sections * L * n_section_samples, **kw),
            "points": StreamingStats(L * n_points, **kw)}
        if lower_sheet:
            self.shape["grid_lower"] = (L, N)
            self.stats["grid_lower"] = StreamingStats(L * N, **kw)
        # Counts of realizations: int32 holds 2**31 - 1 of them.
        self.repeated = np.zeros((L, N), dtype=np.int32)
        self.hanging = np.zeros((L, F, N), dtype=np.int32)
        self.foot = np.zeros((L, F, N), dtype=np.int32)
        # Fault blocks: code = sum_f side_f * 3**f (int64 holds 39 faults).
        self.track_blocks = F <= 39
        self._pow3 = (3 ** np.arange(F, dtype=np.int64)) if self.track_blocks else None
        self.blocks: Dict[int, np.ndarray] = {}
        # Per-realization times on the workers (their median, P10, P90).
        self.build_time = StreamingStats(1)
        self.sample_time = StreamingStats(1)
        self.cpu_time = StreamingStats(1)
        self.succeeded = 0

    def add(self, s: Samples) -> None:
        """Reduce one successful realization's samples."""
        for name, st in self.stats.items():
            st.add(getattr(s, name).reshape(-1))
        self.repeated += s.repeated
        self.hanging += s.sides == SIDE_HANGING
        self.foot += s.sides == SIDE_FOOT
        if self.track_blocks:
            code = np.einsum("lfn,f->ln", s.sides.astype(np.int64), self._pow3)
            valid = np.isfinite(s.grid)
            for c in np.unique(code[valid]):
                hit = (code == c) & valid
                acc = self.blocks.get(int(c))
                if acc is None:
                    self.blocks[int(c)] = hit.astype(np.int32)
                else:
                    acc += hit
        self.build_time.add(np.array([s.build_seconds]))
        self.sample_time.add(np.array([s.sample_seconds]))
        self.cpu_time.add(np.array([s.cpu_seconds]))
        self.succeeded += 1

    @property
    def nbytes(self) -> int:
        return (sum(st.nbytes for st in self.stats.values()) + self.repeated.nbytes
                + self.hanging.nbytes + self.foot.nbytes
                + sum(a.nbytes for a in self.blocks.values()))
