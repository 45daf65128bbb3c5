"""The result of an ensemble: statistics as arrays, xarray, files and pictures."""
from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from .reduction import Reducer
from .sampling import SIDE_FOOT, SIDE_HANGING, Sampler

__all__ = ["EnsembleResult"]

_STATS = ("mean", "std", "p10", "p50", "p90", "min", "max")
_LONG = {"mean": "mean over the realizations", "std": "standard deviation over the realizations "
         "(ddof=1)", "p10": "10th percentile over the realizations",
         "p50": "median over the realizations", "p90": "90th percentile over the realizations",
         "min": "minimum over the realizations", "max": "maximum over the realizations"}
_CELL = {"mean": "realization: mean", "std": "realization: standard_deviation",
         "p50": "realization: median", "min": "realization: minimum",
         "max": "realization: maximum"}
_SIDE_CHAR = {0: "-", SIDE_FOOT: "F", SIDE_HANGING: "H"}


def _stat(st, name: str) -> np.ndarray:
    if name == "mean":
        return st.mean()
    if name == "std":
        return st.std()
    if name == "min":
        return st.minimum()
    if name == "max":
        return st.maximum()
    return st.quantile(int(name[1:]) / 100.0)


def _crs_info(crs: str) -> Tuple[List[Dict[str, Any]], Optional[Dict[str, Any]]]:
    """CF attributes of the x and y coordinates and of the grid-mapping
    variable (None unless pyproj knows the CRS, e.g. an EPSG code)."""
    x = {"standard_name": "projection_x_coordinate", "long_name": "x coordinate (easting)",
         "units": "m", "axis": "X"}
    y = {"standard_name": "projection_y_coordinate", "long_name": "y coordinate (northing)",
         "units": "m", "axis": "Y"}
    if not crs:
        return [x, y], None
    try:
        import pyproj
        c = pyproj.CRS.from_user_input(crs)
    except Exception:
        return [x, y], None   # free text (e.g. "local grid in metres"): no grid mapping
    gm = {k: v for k, v in c.to_cf().items() if v is not None}
    axes = {a.get("axis"): a for a in c.cs_to_cf()}
    out = []
    for want, default in (("X", x), ("Y", y)):
        a = axes.get(want)
        out.append({k: v for k, v in (a or default).items() if v is not None})
    return out, gm


class EnsembleResult:
    """Statistics of an ensemble (what :func:`faultmesh.ensemble` returns).

    ``n`` realizations were asked for, ``succeeded`` entered the statistics,
    ``failures`` lists the others (index, seed ``[seed, index]``, error).
    :meth:`grid` gives a statistic as a (layer, y, x) array (NaN outside the
    study area), :meth:`to_xarray` everything as a CF ``xarray.Dataset``,
    :meth:`save` writes ``ensemble.nc``, ``summary.json`` and the pictures.
    """

    def __init__(self, *, dataset, n: int, seed: int, perturbation, sampler: Sampler,
                 reducer: Reducer, failures: List[Dict[str, Any]], timings: Dict[str, float],
                 run: Dict[str, Any]) -> None:
        self.dataset = dataset
        self.n = n
        self.seed = seed
        self.perturbation = perturbation
        self.sampler = sampler
        self.reducer = reducer
        self.failures = failures
        self.timings = timings
        self.run = run

    @property
    def succeeded(self) -> int:
        return self.reducer.succeeded

    @property
    def failed(self) -> int:
        return len(self.failures)

    @property
    def layers(self) -> List[str]:
        return list(self.sampler.layers)

    @property
    def faults(self) -> List[str]:
        return list(self.sampler.faults)

    def __repr__(self) -> str:
        g = self.sampler.grid
        return (f"EnsembleResult({self.dataset.name!r}, n={self.n}, succeeded={self.succeeded}, "
                f"failed={self.failed}, grid={g.shape[1]}x{g.shape[0]})")

    # -- arrays -----------------------------------------------------------------
    def _expand(self, a: np.ndarray, fill=np.nan) -> np.ndarray:
        """(..., N_inside) -> (..., ny, nx) with ``fill`` outside."""
        ny, nx = self.sampler.grid.shape
        lead = a.shape[:-1]
        out = np.full(lead + (ny * nx,), fill, dtype=np.result_type(a.dtype, np.asarray(fill).dtype))
        out[..., self.sampler.inside] = a
        return out.reshape(lead + (ny, nx))

    def grid(self, stat: str = "mean", sheet: str = "upper") -> np.ndarray:
        """Statistic ``stat`` (mean, std, p10, p50, p90, min, max, count) of the
        layer elevations, (layer, y, x); ``sheet="lower"`` needs lower_sheet."""
        key = {"upper": "grid", "lower": "grid_lower"}[sheet]
        if key not in self.reducer.stats:
            raise ValueError("EnsembleResult.grid: the lower sheet was not sampled "
                             "(ensemble(..., lower_sheet=True))")
        st = self.reducer.stats[key]
        L = len(self.sampler.layers)
        if stat == "count":
            return self._expand(st.count.reshape(L, -1), fill=0)
        return self._expand(_stat(st, stat).reshape(L, -1))

    def section(self, stat: str = "mean") -> np.ndarray:
        """(section, layer, sample) statistic along the section lines."""
        st = self.reducer.stats["sections"]
        return _stat(st, stat).reshape(self.reducer.shape["sections"])

    def points(self, stat: str = "mean") -> np.ndarray:
        """(layer, point) statistic at the sample points."""
        st = self.reducer.stats["points"]
        return _stat(st, stat).reshape(self.reducer.shape["points"])

    def _denominator(self) -> np.ndarray:
        return self.reducer.stats["grid"].count.reshape(len(self.sampler.layers), -1)

    def _prob(self, counts: np.ndarray) -> np.ndarray:
        den = self._denominator()
        den = den.reshape(den.shape[:1] + (1,) * (counts.ndim - 2) + den.shape[1:])
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(den > 0, counts / np.maximum(den, 1), np.nan)

    def hanging_wall_probability(self) -> np.ndarray:
        """(layer, fault, y, x): share of the realizations in which the node,
        on that layer, lies in the fault's hanging wall (docs/ensemble.md)."""
        return self._expand(self._prob(self.reducer.hanging))

    def footwall_probability(self) -> np.ndarray:
        return self._expand(self._prob(self.reducer.foot))

    def repeated_probability(self) -> np.ndarray:
        """(layer, y, x): share of the realizations in which the layer is met
        twice above the node (reverse-fault repetition)."""
        return self._expand(self._prob(self.reducer.repeated))

    def blocks(self) -> Tuple[List[str], np.ndarray, np.ndarray]:
        """(labels, codes, probability (layer, block, y, x)) of the fault
        blocks seen, in code order. A label lists each fault's side:
        ``"2F4:H F22:F 2F1:- 4F2:-"`` (H hanging wall, F footwall, - neither)."""
        codes = sorted(self.reducer.blocks)
        L = len(self.sampler.layers)
        F = len(self.sampler.faults)
        labels = []
        for c in codes:
            parts, v = [], c
            for f in range(F):
                parts.append(f"{self.sampler.faults[f]}:{_SIDE_CHAR[v % 3]}")
                v //= 3
            labels.append(" ".join(parts) if parts else "(no fault)")
        if codes:
            counts = np.stack([self.reducer.blocks[c] for c in codes], axis=1)
        else:
            counts = np.zeros((L, 0, self.sampler.n_inside), dtype=np.int64)
        return labels, np.array(codes, dtype=np.int64), self._expand(self._prob(counts))

    # -- xarray -----------------------------------------------------------------
    def to_xarray(self):
        """Everything as an ``xarray.Dataset`` following the CF conventions
        (see docs/ensemble.md "Output")."""
        import xarray as xr
        from .. import __version__

        ds_in = self.dataset
        g = self.sampler.grid
        (xa, ya), gm = _crs_info(ds_in.crs)
        coords: Dict[str, Any] = {
            "x": ("x", g.x, xa), "y": ("y", g.y, ya),
            "layer": ("layer", np.array(self.layers, dtype=object),
                      {"long_name": "layer (top to bottom)"}),
            "fault": ("fault", np.array(self.faults, dtype=object), {"long_name": "fault"})}
        gmap = {"grid_mapping": "crs"} if gm else {}
        data: Dict[str, Any] = {}
        for st in _STATS:
            attrs = {"long_name": f"elevation of the layer top (upper sheet), {_LONG[st]}",
                     "units": "m", **gmap}
            if st in _CELL:
                attrs["cell_methods"] = _CELL[st]
            if st.startswith("p"):
                attrs["percentile"] = int(st[1:])
            data[st] = (("layer", "y", "x"), self.grid(st), attrs)
        data["count"] = (("layer", "y", "x"), self.grid("count").astype(np.int32),
                         {"long_name": "number of realizations that gave the layer a value at "
                                       "the node", "units": "1", **gmap})
        if "grid_lower" in self.reducer.stats:
            for st in _STATS:
                data[f"lower_{st}"] = (("layer", "y", "x"), self.grid(st, "lower"),
                                       {"long_name": f"elevation of the layer top (lower sheet "
                                                     f"where repeated), {_LONG[st]}", "units": "m",
                                        **gmap})
        data["repeated_probability"] = (
            ("layer", "y", "x"), self.repeated_probability(),
            {"long_name": "probability that the layer is met twice above the node (reverse-"
                          "fault repetition; the statistics use the upper sheet)", "units": "1",
             **gmap})
        data["hanging_wall_probability"] = (
            ("layer", "fault", "y", "x"), self.hanging_wall_probability(),
            {"long_name": "probability that the node, on the layer, lies in the fault's "
                          "hanging wall", "units": "1", **gmap})
        data["footwall_probability"] = (
            ("layer", "fault", "y", "x"), self.footwall_probability(),
            {"long_name": "probability that the node, on the layer, lies in the fault's "
                          "footwall (1 - hanging - footwall: beyond the fault's ends, or the "
                          "fault does not cut the layer)", "units": "1", **gmap})
        if self.reducer.track_blocks:
            labels, codes, prob = self.blocks()
            coords["block"] = ("block", np.array(labels, dtype=object),
                               {"long_name": "fault block: each fault's side (H hanging wall, "
                                             "F footwall, - neither)"})
            coords["block_code"] = ("block", codes,
                                    {"long_name": "sum over faults f (dataset order, from 0) of "
                                                  "side_f * 3**f, side 0 neither, 1 footwall, 2 "
                                                  "hanging wall"})
            data["block_probability"] = (("layer", "block", "y", "x"), prob,
                                         {"long_name": "probability of each fault block at the "
                                                       "node, on the layer", "units": "1", **gmap})
        lines = self.sampler.sections
        if lines:
            coords["section"] = ("section", np.array([s.name for s in lines], dtype=object),
                                 {"long_name": "section line"})
            coords["section_s"] = (("section", "section_sample"), np.stack([s.s for s in lines]),
                                   {"long_name": "distance along the section from its origin",
                                    "units": "m"})
            coords["section_x"] = (("section", "section_sample"), np.stack([s.xy[:, 0] for s in lines]),
                                   dict(xa))
            coords["section_y"] = (("section", "section_sample"), np.stack([s.xy[:, 1] for s in lines]),
                                   dict(ya))
            coords["section_azimuth"] = ("section", np.array([s.azimuth for s in lines]),
                                         {"long_name": "section azimuth, clockwise from north",
                                          "units": "degree"})
            for st in _STATS:
                attrs = {"long_name": f"elevation of the layer top along the section (upper "
                                      f"sheet), {_LONG[st]}", "units": "m",
                         "coordinates": "section_s section_x section_y"}
                if st in _CELL:
                    attrs["cell_methods"] = _CELL[st]
                data[f"section_{st}"] = (("section", "layer", "section_sample"), self.section(st),
                                         attrs)
        if len(self.sampler.points):
            coords["point"] = ("point", np.array(self.sampler.point_names, dtype=object),
                               {"long_name": "sample point"})
            coords["point_x"] = ("point", self.sampler.points[:, 0], dict(xa))
            coords["point_y"] = ("point", self.sampler.points[:, 1], dict(ya))
            for st in _STATS:
                data[f"point_{st}"] = (("layer", "point"), self.points(st),
                                       {"long_name": f"elevation of the layer top at the point "
                                                     f"(upper sheet), {_LONG[st]}", "units": "m",
                                        "coordinates": "point_x point_y"})
        if gm:
            data["crs"] = ((), np.int32(0), gm)
        out = xr.Dataset({k: xr.Variable(*v) for k, v in data.items()},
                         coords={k: xr.Variable(*v) for k, v in coords.items()})
        out.attrs = {
            "Conventions": "CF-1.8",
            "title": f"faultmesh ensemble of {ds_in.name}: {self.succeeded} of {self.n} "
                     "realizations",
            "source": f"faultmesh {__version__} ensemble (docs/ensemble.md)",
            "history": f"{time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())} faultmesh.ensemble",
            "dataset": ds_in.name,
            "dataset_crs": ds_in.crs or "",
            "realizations": self.n,
            "realizations_succeeded": self.succeeded,
            "realizations_failed": self.failed,
            "seed": self.seed,
            "perturbation": json.dumps(self.perturbation.to_dict()),
            "sheet": "upper: where the vertical line through a node meets a layer twice (a "
                     "reverse fault's repetition band) the upper sheet is sampled",
            "quantile_estimator": self._quantile_note(),
        }
        return out

    def _quantile_note(self) -> str:
        st = self.reducer.stats["grid"]
        return (f"exact (linear interpolation) for up to {st.B} realizations; beyond, the "
                f"extended P-squared algorithm with {st.M} markers per node (docs/ensemble.md)")

    # -- summary, files, pictures ---------------------------------------------
    def summary(self) -> Dict[str, Any]:
        from .. import __version__

        g = self.sampler.grid
        return {
            "dataset": self.dataset.name, "faultmesh_version": __version__,
            "n": self.n, "succeeded": self.succeeded, "failed": self.failed,
            "failures": self.failures, "seed": self.seed,
            "perturbation": self.perturbation.to_dict(),
            "grid": {"nx": int(len(g.x)), "ny": int(len(g.y)),
                     "dx": float(g.x[1] - g.x[0]) if len(g.x) > 1 else None,
                     "dy": float(g.y[1] - g.y[0]) if len(g.y) > 1 else None,
                     "nodes_inside": self.sampler.n_inside},
            "sections": [s.name for s in self.sampler.sections],
            "points": len(self.sampler.points),
            "quantile_estimator": self._quantile_note(),
            "statistics_bytes": int(self.reducer.nbytes),
            "run": self.run, "timings": self.timings,
        }

    def save(self, directory, *, pictures: bool = True, base_model=None) -> List[Path]:
        """Write ``ensemble.nc``, ``summary.json`` and (``pictures``)
        ``std_<layer>.png`` per layer and ``section_<name>.png`` per section
        into ``directory``; all or nothing (temporary files renamed into place
        only when every file is written). ``base_model``: the unperturbed
        model for the pictures' fault lines (built here when None)."""
        from ..formats._common import AtomicFiles, slug

        out = Path(directory)
        files: List[Path] = []
        with AtomicFiles() as af:
            nc = out / "ensemble.nc"
            tmp = af.temp_path(nc)
            ds = self.to_xarray()
            enc = {k: {"zlib": True, "complevel": 4} for k, v in ds.data_vars.items()
                   if v.dtype.kind == "f"}
            ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=enc)
            files.append(nc)
            if pictures:
                if base_model is None:
                    base_model = self._base_model()
                for li, lay in enumerate(self.layers):
                    p = out / f"std_{slug(lay)}.png"
                    self._save_fig(self.plot_std(lay, base_model=base_model), af, p)
                    files.append(p)
                for sl in self.sampler.sections:
                    p = out / f"section_{slug(sl.name)}.png"
                    self._save_fig(self.plot_section(sl.name, base_model=base_model), af, p)
                    files.append(p)
            js = out / "summary.json"
            summ = self.summary()
            summ["files"] = [str(f.name) for f in files + [js]]
            with af.open(js) as fh:
                json.dump(summ, fh, indent=1)
                fh.write("\n")
            files.append(js)
        return files

    @staticmethod
    def _save_fig(fig, af, path: Path) -> None:
        import matplotlib.pyplot as plt

        try:
            fig.savefig(af.temp_path(path), dpi=130, format="png", bbox_inches="tight")
        finally:
            plt.close(fig)

    def _base_model(self):
        """The unperturbed model (for fault lines in the pictures); None if it
        does not build."""
        from ..build import build_model

        try:
            return build_model(self.dataset, evaluate=False)
        except Exception:
            return None

    def plot_std(self, layer: str, *, base_model=None):
        """Map of the standard deviation of ``layer``'s elevation: the study
        area, the unperturbed model's fault footprints, the boreholes."""
        from ..plots import FAULT_COLOR, _plain_ticks, _plt

        plt = _plt()
        li = self.layers.index(layer)
        std = self.grid("std")[li]
        g = self.sampler.grid
        fig, ax = plt.subplots(figsize=(7.5, 6.5))
        dx = (g.x[1] - g.x[0]) if len(g.x) > 1 else 1.0
        dy = (g.y[1] - g.y[0]) if len(g.y) > 1 else 1.0
        ext = (g.x[0] - dx / 2, g.x[-1] + dx / 2, g.y[0] - dy / 2, g.y[-1] + dy / 2)
        im = ax.imshow(np.ma.masked_invalid(std), origin="lower", extent=ext, cmap="magma_r",
                       interpolation="nearest")
        fig.colorbar(im, ax=ax, shrink=0.8, label="standard deviation of the elevation (m)")
        ring = np.vstack([self.dataset.boundary, self.dataset.boundary[:1]])
        ax.plot(ring[:, 0], ring[:, 1], color="0.2", lw=1.2)
        if base_model is not None:
            from ..faults import patch_outline

            for name, surf in base_model.faults.items():
                for r in patch_outline(surf.vertices, surf.triangles):
                    rr = np.vstack([r, r[:1]])
                    ax.plot(rr[:, 0], rr[:, 1], color=FAULT_COLOR, lw=1.0)
        b = self.dataset.boreholes
        if len(b):
            ax.plot(b.xy[:, 0], b.xy[:, 1], ".", color="0.35", ms=2.5, label="boreholes")
        for sl in self.sampler.sections:
            ax.plot(sl.xy[sl.inside, 0], sl.xy[sl.inside, 1], color="#1f5fa8", lw=0.6, alpha=0.6)
        ax.set_aspect("equal")
        _plain_ticks(ax)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(f"{layer}: standard deviation over {self.succeeded} realizations",
                     fontsize=11)
        return fig

    def plot_section(self, name: str, *, base_model=None):
        """P10-P90 fan of every layer along section ``name``, its median, and
        the unperturbed model's layers and faults (dashed)."""
        from matplotlib.colors import to_rgb

        from ..plots import FAULT_COLOR, _plt, layer_color

        plt = _plt()
        names = [s.name for s in self.sampler.sections]
        si = names.index(name)
        sl = self.sampler.sections[si]
        p10, p50, p90 = (self.section(k)[si] for k in ("p10", "p50", "p90"))
        fig, ax = plt.subplots(figsize=(12, 5))
        for li, lay in enumerate(self.layers):
            col = np.array(to_rgb(layer_color(li)))
            ax.fill_between(sl.s, p10[li], p90[li], color=col, alpha=0.45, lw=0,
                            label=f"{lay} P10-P90")
            ax.plot(sl.s, p50[li], color=col * 0.7, lw=1.3)
        if base_model is not None:
            cut = base_model.section(sl.origin, sl.azimuth)
            for ln in cut.lines:
                if ln.kind == "fault":
                    ax.plot(ln.s, ln.xyz[:, 2], color=FAULT_COLOR, lw=1.6, ls="--")
                else:
                    ax.plot(ln.s, ln.xyz[:, 2], color="0.25", lw=0.7, ls=":")
        ax.plot([], [], color=FAULT_COLOR, lw=1.6, ls="--", label="faults (unperturbed)")
        ax.plot([], [], color="0.25", lw=0.7, ls=":", label="layers (unperturbed)")
        ax.plot([], [], color="0.3", lw=1.3, label="P50")
        fin = np.isfinite(p10) & np.isfinite(p90)
        if fin.any():
            zlo, zhi = float(np.min(p10[fin])), float(np.max(p90[fin]))
            pad = 0.06 * max(zhi - zlo, 1.0)
            ax.set_ylim(zlo - pad, zhi + pad)
        cols = np.flatnonzero(np.isfinite(p50).any(axis=0))
        if len(cols):
            ax.set_xlim(sl.s[cols[0]], sl.s[cols[-1]])
        ax.set_xlabel(f"distance along section {name} from its origin (m), azimuth {sl.azimuth:g}°")
        ax.set_ylabel("elevation (m)")
        ax.grid(True, color="0.88", lw=0.5)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        ax.set_title(f"Section {name}: P10-P90 of the layer tops over {self.succeeded} "
                     "realizations", fontsize=11)
        fig.tight_layout()
        return fig
