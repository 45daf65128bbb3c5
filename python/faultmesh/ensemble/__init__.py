"""Ensembles of model realizations on Dask (docs/ensemble.md).

:func:`ensemble` perturbs a dataset ``n`` times (:class:`Perturbation`),
builds and samples each realization on Dask workers (a local cluster of
worker processes, or any cluster given by its address) and reduces the
samples as they arrive into streaming statistics whose memory does not grow
with ``n``. The result (:class:`EnsembleResult`) writes ``ensemble.nc``
(CF-NetCDF4), pictures and a JSON summary.

Needs the optional extra ``faultmesh[ensemble]`` (dask[distributed],
xarray, netCDF4, pyproj); ``workers=0`` runs in-process without Dask.

Note: ``faultmesh.ensemble`` is the function; import the package's names
with ``from faultmesh.ensemble import Perturbation, ...``.
"""
from __future__ import annotations

import os
import time
import uuid
from typing import Any, Callable, Dict, List, Mapping, Optional, Union

import numpy as np

from ..dataset import Dataset, Section
from .perturbation import (FaultPerturbation, Perturbation, _copy_dataset, perturb,
                           realization_dataset, realization_seed)
from .reduction import QUANTILES, Reducer, StreamingStats  # noqa: F401  (QUANTILES re-exported)
from .result import EnsembleResult
from .sampling import Grid, Sampler, Samples, SectionLine, run_realization

__all__ = ["ensemble", "Perturbation", "FaultPerturbation", "Grid", "EnsembleResult",
           "perturb", "realization_dataset", "realization_seed", "StreamingStats",
           "run_realization", "reduce_in_order"]

# Quantile estimator settings (docs/ensemble.md "Quantiles"): the first 64
# samples of a node are kept and give exact quantiles; then 17 P-squared
# markers (refine=4) per node. 33 markers (refine=8) cut the error by about
# a quarter but cost the client ~2.5x the reduction time per realization,
# which on a machine whose cores run the workers is taken from them.
_REFINE = 4
_EXACT = 64


def _dask_missing(e: ImportError) -> ImportError:
    return ImportError(f"faultmesh.ensemble needs Dask: pip install 'faultmesh[ensemble]' ({e})")


def _sections_of(dataset: Dataset, sections, samples: int) -> List[SectionLine]:
    if sections is None:
        # The dataset's sections that cross the study area (one that misses
        # it has nothing to sample; asked for by name it is an error).
        out = []
        for s in dataset.sections.values():
            try:
                out.append(SectionLine.across(s, dataset.boundary, samples))
            except ValueError:
                continue
        return out
    else:
        if isinstance(sections, (str, Section)):
            sections = [sections]
        if isinstance(sections, Mapping):
            sections = list(sections.values())
        chosen = []
        for s in sections:
            if isinstance(s, str):
                if s not in dataset.sections:
                    raise ValueError(f"ensemble: no section {s!r} in dataset {dataset.name!r}; "
                                     f"sections are {list(dataset.sections)}")
                s = dataset.sections[s]
            if not isinstance(s, Section):
                raise TypeError(f"ensemble: sections must be names or Section objects, got "
                                f"{type(s).__name__}")
            chosen.append(s)
    names = [s.name for s in chosen]
    if len(set(names)) != len(names):
        raise ValueError(f"ensemble: repeated section names {names}")
    return [SectionLine.across(s, dataset.boundary, samples) for s in chosen]


def _points_of(dataset: Dataset, points) -> Optional[Dict[str, np.ndarray]]:
    if points is None:
        return None
    if isinstance(points, str):
        if points != "boreholes":
            raise ValueError(f"ensemble: points must be 'boreholes', a mapping name -> (x, y) "
                             f"or an array (k, 2), got {points!r}")
        b = dataset.boreholes
        out: Dict[str, np.ndarray] = {}
        for h, xy in zip(b.hole_id, b.xy):
            out.setdefault(str(h), xy)
        return out
    if isinstance(points, Mapping):
        return {str(k): np.asarray(v, dtype=np.float64).reshape(2) for k, v in points.items()}
    P = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return {f"p{i}": p for i, p in enumerate(P)}


def _start_client(client, workers: Optional[int]):
    """(client, cluster or None, own): a Client from ``client`` (a Client, a
    scheduler address) or a new LocalCluster of ``workers`` processes."""
    try:
        from distributed import Client, LocalCluster
    except ImportError as e:  # pragma: no cover - exercised without the extra
        raise _dask_missing(e) from None
    if client is not None and not isinstance(client, str):
        return client, None, False
    if isinstance(client, str):
        return Client(client, timeout="30s"), None, True
    k = workers if workers is not None else (len(os.sched_getaffinity(0))
                                             if hasattr(os, "sched_getaffinity") else os.cpu_count())
    # dashboard_address ":0": the scheduler's HTTP server (health, metrics and,
    # with bokeh installed, the dashboard) on a free port; None would still
    # try the default port 8787 and warn when another cluster holds it.
    cluster = LocalCluster(n_workers=int(k), threads_per_worker=1, processes=True,
                           dashboard_address=":0")
    return Client(cluster), cluster, True


def reduce_in_order(submit: Callable[[int], Any], n: int, window: int,
                    result_of: Callable[[int, Any], Any], take: Callable[[Any], None],
                    arrived: Optional[Callable[[int], None]] = None) -> int:
    """Run tasks 0..n-1 (``submit(i)`` -> a Dask future) and hand their
    results to ``take`` in index order as they arrive
    (``distributed.as_completed``). At most ``window`` tasks beyond the
    oldest one not yet taken are submitted, so if that one is slow (or its
    worker died and Dask runs it again) at most ``window`` results wait for
    it. ``result_of(i, future)`` turns a future into a result; ``arrived(k)``
    is called after the k-th arrival. Returns the largest number of results
    that waited at once."""
    from distributed import as_completed

    index_of: Dict[str, int] = {}

    def go(i: int):
        fut = submit(i)
        index_of[fut.key] = i
        return fut

    nxt = min(window, n)
    ac = as_completed([go(i) for i in range(nxt)])
    waiting: Dict[int, Any] = {}
    expect = 0
    most = 0
    done = 0
    for fut in ac:
        i = index_of.pop(fut.key)
        waiting[i] = result_of(i, fut)
        fut.release()
        most = max(most, len(waiting))
        while expect in waiting:
            take(waiting.pop(expect))
            expect += 1
        while nxt < n and nxt < expect + window:
            ac.add(go(nxt))
            nxt += 1
        done += 1
        if arrived is not None:
            arrived(done)
    if expect != n or waiting:  # pragma: no cover - as_completed yields every future
        raise RuntimeError(f"ensemble: {n - expect} realizations never arrived")
    return most


def ensemble(dataset: Dataset, n: int, perturbation: Optional[Perturbation] = None, *,
             client=None, seed: int = 0, grid: Union[None, int, Grid] = None,
             sections=None, points=None, lower_sheet: bool = False,
             workers: Optional[int] = None, window: Optional[int] = None,
             progress: Optional[Callable[[int, int, int], None]] = None,
             build_options: Optional[Dict[str, Any]] = None) -> EnsembleResult:
    """Build ``n`` perturbed realizations of ``dataset`` and reduce their samples.

    perturbation: a :class:`Perturbation` (default: nothing perturbed).
    client: a ``distributed.Client``, a scheduler address (``"tcp://host:8786"``)
    or None: a local cluster of ``workers`` worker processes (default: the
    machine's cores), closed at the end; ``workers=0`` runs in this process
    without Dask. seed: realization i uses the stream
    ``SeedSequence(seed, spawn_key=(i,))``, so results do not depend on the
    number or order of the workers. grid: a :class:`Grid`, or the number of
    nodes along the longer side of the study area (default 100).
    sections: section names or :class:`~faultmesh.dataset.Section` objects
    sampled along their lines (default: all of the dataset's; ``()`` none).
    points: ``"boreholes"`` (the collars), a mapping name -> (x, y) or an
    array (k, 2): each layer's elevation there. lower_sheet: also keep
    statistics of the lower sheet where a layer is repeated. window: most
    realizations submitted ahead of the reduction (default 4 per worker
    thread, at least 8); their samples are the only ones held at once.
    progress: ``callable(done, n, failed)`` after each arrival.
    build_options: keywords for :func:`faultmesh.build_model`.

    A realization that raises is counted in the result (``failures``: index,
    seed and error) and left out of the statistics; a worker that dies has
    its tasks run again by Dask.
    """
    t_start = time.perf_counter()
    if not isinstance(dataset, Dataset):
        raise TypeError(f"ensemble: dataset must be a faultmesh Dataset, got {type(dataset).__name__}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"ensemble: n must be a positive integer, got {n!r}")
    n = int(n)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"ensemble: seed must be an integer >= 0, got {seed!r}")
    seed = int(seed)
    perturbation = perturbation if perturbation is not None else Perturbation()
    if not isinstance(perturbation, Perturbation):
        raise TypeError("ensemble: perturbation must be a faultmesh.ensemble.Perturbation")
    perturbation.check_faults(dataset)
    if grid is None or isinstance(grid, (int, np.integer)):
        grid = Grid.over(dataset, nodes=grid)
    elif not isinstance(grid, Grid):
        raise TypeError("ensemble: grid must be None, an int or a faultmesh.ensemble.Grid")
    lines = _sections_of(dataset, sections, 200)
    sampler = Sampler.build(dataset, grid, lines, _points_of(dataset, points), lower_sheet)
    # The workers get the data only (a generated dataset's ground truth is
    # a closure over its geology: not needed, and heavy to ship).
    data = _copy_dataset(dataset)
    reducer = Reducer(len(dataset.layers), len(dataset.faults), sampler.n_inside, len(lines),
                      len(lines[0].s) if lines else 0, len(sampler.points), lower_sheet,
                      refine=_REFINE, exact=_EXACT)
    failures: List[Dict[str, Any]] = []
    info: Dict[str, Any] = {}
    t_reduce = 0.0
    done = 0

    def take(res: Samples) -> None:
        nonlocal t_reduce
        t0 = time.perf_counter()
        if res.ok:
            reducer.add(res)
        else:
            failures.append({"index": res.index, "seed": [seed, res.index], "error": res.error})
        t_reduce += time.perf_counter() - t0

    if workers == 0 and client is None:
        info["mode"] = "in-process"
        info["workers"] = 0
        for i in range(n):
            take(run_realization(data, sampler, perturbation, seed, i, build_options))
            done += 1
            if progress is not None:
                progress(done, n, len(failures))
    else:
        cl, cluster, own = _start_client(client, workers)
        try:
            nthreads = cl.nthreads()
            info["mode"] = "dask"
            info["scheduler"] = cl.scheduler.address
            info["workers"] = len(nthreads)
            info["worker_threads"] = int(sum(nthreads.values()))
            w = window if window is not None else max(8, 4 * max(1, info["worker_threads"]))
            ds_f = cl.scatter(data, broadcast=True, hash=False)
            sm_f = cl.scatter(sampler, broadcast=True, hash=False)
            token = uuid.uuid4().hex[:12]

            def submit(i: int):
                return cl.submit(run_realization, ds_f, sm_f, perturbation, seed, i, build_options,
                                 key=f"faultmesh-realization-{token}-{i}", pure=False)

            def result_of(i: int, fut) -> Samples:
                if fut.status == "finished":
                    return fut.result()
                try:    # the task itself failed in Dask (e.g. KilledWorker)
                    exc = fut.exception()
                    err = f"{type(exc).__name__}: {exc}"
                except Exception as e:  # pragma: no cover - cancelled futures
                    err = f"{type(e).__name__}: {e}"
                return Samples(index=i, error=err)

            def arrived(done_: int) -> None:
                nonlocal done
                done = done_
                if progress is not None:
                    progress(done, n, len(failures))

            info["most_waiting"] = reduce_in_order(submit, n, w, result_of, take, arrived)
        finally:
            if own:
                cl.close()
                if cluster is not None:
                    cluster.close()
    wall = time.perf_counter() - t_start
    timings = {"wall_seconds": wall, "reduce_seconds": t_reduce,
               "per_realization_wall_seconds": wall / n}
    if reducer.succeeded:
        timings.update({
            "build_seconds_median": float(reducer.build_time.quantile(0.5)[0]),
            "build_seconds_mean": float(reducer.build_time.mean()[0]),
            "sample_seconds_median": float(reducer.sample_time.quantile(0.5)[0]),
            "sample_seconds_mean": float(reducer.sample_time.mean()[0]),
            "worker_cpu_seconds_median": float(reducer.cpu_time.quantile(0.5)[0])})
    failures.sort(key=lambda f: f["index"])
    return EnsembleResult(dataset=data, n=n, seed=seed, perturbation=perturbation,
                          sampler=sampler, reducer=reducer, failures=failures,
                          timings=timings, run=info)
