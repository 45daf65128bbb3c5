"""Helpers shared by test modules (imported as a sibling: ``from helpers import
...``; pytest puts tests/ on sys.path)."""
from __future__ import annotations

import csv

import numpy as np


def loft_sequence(seq) -> tuple[np.ndarray, np.ndarray]:
    """Consecutive polylines (k_i, 3) lofted pair by pair with
    faultmesh.loft into one patch: (vertices, triangles)."""
    import faultmesh

    offs = np.cumsum([0] + [len(p) for p in seq])
    tris = []
    for i in range(len(seq) - 1):
        t = np.asarray(faultmesh.loft(seq[i], seq[i + 1]))
        k = len(seq[i])
        tris.append(np.where(t < k, t + offs[i], t - k + offs[i + 1]))
    return np.vstack(seq), np.vstack(tris)


def tri_set(t) -> set[tuple[int, int, int]]:
    """Triangles as a set, each rotated so that its smallest index is first
    (orientation kept)."""
    t = np.asarray(t, dtype=np.int64).reshape(-1, 3)
    k = np.argmin(t, axis=1)
    rows = np.arange(len(t))
    r = np.stack([t[rows, (k + i) % 3] for i in range(3)], axis=1)
    return set(map(tuple, r.tolist()))


def claudius_horizons(data_dir, z: bool = False) -> dict[str, np.ndarray]:
    """The Claudius horizons of tests/data/claudius/claudius.csv by their "val"
    label: (n, 2) XY, or (n, 3) XYZ with ``z=True``."""
    cols = ("X", "Y", "Z") if z else ("X", "Y")
    rows: dict[str, list] = {}
    with open(data_dir / "claudius" / "claudius.csv", newline="") as f:
        for r in csv.DictReader(f):
            if r["val"]:
                rows.setdefault(r["val"], []).append(tuple(float(r[c]) for c in cols))
    return {k: np.array(v) for k, v in rows.items()}


def fuzz_settings(examples: int = 200, **kwargs):
    """Hypothesis settings for a fuzz target (tests marked ``@pytest.mark.fuzz``).

    In CI a target runs ``examples`` derandomized examples (bounded time, the
    same inputs on every run). ``bench/fuzz.py`` sets ``FAULTMESH_FUZZ_EXAMPLES``
    (examples per target) and ``FAULTMESH_FUZZ_SEED`` (a fresh random seed,
    printed so a failure can be replayed) to run the same targets for longer.
    """
    import os

    from hypothesis import HealthCheck, settings

    n = int(os.environ.get("FAULTMESH_FUZZ_EXAMPLES", examples))
    long_run = "FAULTMESH_FUZZ_EXAMPLES" in os.environ
    base = dict(max_examples=n, deadline=None, database=None,
                derandomize=not long_run,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.filter_too_much])
    base.update(kwargs)
    return settings(**base)
