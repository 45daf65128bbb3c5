"""The surface-cutting baseline of the paper's comparison (section 4.1.1).

The methods the paper compares against (GOCAD-style "cut and slide",
GeoSIS) build one continuous surface per layer, cut it by each fault surface
along their intersection line, re-triangulate the cut triangles with that line
as a constraint and move the hanging-wall side by the fault's displacement.
This module runs that workflow on our kernels so that its triangle counts and
shapes can be compared with faultmesh's stitching (``bench/compare.py``). It
is a baseline, not the modelling method: the cut layers have a crack along
each intersection line (two banks of vertices), so they do not keep the
topological-disk invariant of :func:`faultmesh.build_model`'s layers.

The geometry is :func:`faultmesh.cut_layer` (C++, ``cutting.hpp``); this module
feeds it the continuous layers and the fault surfaces of a dataset, takes each
fault's displacement on each layer from its traces and records what every cut
created.
"""
from __future__ import annotations

import time
from typing import Dict, Iterable, List, Mapping, Optional, Tuple

import numpy as np

from ._core import cut_layer
from .build import build_model, continuous_layers  # noqa: F401  (re-exported)
from .model import Gap, Model, Surface

__all__ = ["cut_surface", "fault_displacement", "cut_surfaces", "continuous_layers", "cut_model"]


def cut_surface(layer: Surface, fault: Surface, *, displacement: float = 0.0,
                taper_length: float = 0.0, extension: float = 0.0, refine: bool = True,
                order: str = "quality") -> Tuple[Surface, Dict[str, object]]:
    """Cut one layer surface by one fault surface.

    Returns the cut surface (same name and kind, metadata copied) and the raw
    result of :func:`faultmesh.cut_layer` (``created`` rows, ``removed`` input
    rows, the intersection polylines, ...)."""
    r = cut_layer(layer.vertices, layer.triangles, fault.vertices, fault.triangles,
                  displacement=float(displacement), taper_length=float(taper_length),
                  extension=float(extension), refine=refine, order=order)
    out = Surface(layer.name, r["vertices"], r["triangles"], kind=layer.kind,
                  metadata=dict(layer.metadata))
    return out, r


def fault_displacement(fault, layer: str) -> Optional[float]:
    """The fault's vertical displacement of ``layer``: the mean over its traces
    of (hanging-wall cutoff z - footwall cutoff z), negative for a normal
    fault's throw. The footwall polyline ends at its cutoff and the
    hanging-wall polyline starts at its cutoff (dataset format v1). ``None``
    if no trace interprets the layer."""
    d = []
    for tr in fault.traces:
        sides = tr.layers.get(layer)
        if not sides or "foot" not in sides or "hanging" not in sides:
            continue
        foot, hang = np.asarray(sides["foot"]), np.asarray(sides["hanging"])
        if len(foot) and len(hang):
            d.append(float(hang[0, 2] - foot[-1, 2]))
    return float(np.mean(d)) if d else None


def cut_surfaces(layers: Mapping[str, Surface],
                 cuts: Iterable[Tuple[str, Surface, Mapping[str, float]]], *,
                 taper_length: float = 0.0, extension: float = 0.0, refine: bool = True,
                 order: str = "quality") -> Tuple[Dict[str, Surface], List[Gap]]:
    """Cut layer surfaces by faults, one fault after another.

    ``cuts``: (fault name, fault surface, {layer: displacement}) in cutting
    order; a fault cuts only the layers named in its mapping. Returns the cut
    layers and one :class:`~faultmesh.model.Gap` per (fault, layer) cut:
    ``triangles`` are the rows (in the final surface) of the triangles that cut
    created and that later cuts did not replace; ``metadata`` holds what the
    cut did at the time it was made -- ``created`` (triangles), ``removed``,
    ``split`` (tip triangles split in two), ``line_points``, ``displacement``,
    and ``min_angle`` / ``min_angle_xy`` (degrees, per created triangle,
    measured right after the cut, hanging wall displaced).
    """
    from .report import min_angles

    out = dict(layers)
    # Per layer, the gap id that created each row (-1: an original triangle),
    # carried through the later cuts so that gap rows stay right.
    tags = {name: np.full(s.n_triangles, -1, dtype=np.int64) for name, s in out.items()}
    gaps: List[Gap] = []
    for fname, fsurf, disp in cuts:
        for lname, dz in disp.items():
            if lname not in out:
                raise ValueError(f"cut_surfaces: fault {fname!r} names layer {lname!r}, "
                                 f"which is not among {list(out)}")
            t0 = time.perf_counter()
            surf, r = cut_surface(out[lname], fsurf, displacement=dz, taper_length=taper_length,
                                  extension=extension, refine=refine, order=order)
            sec = time.perf_counter() - t0
            keep = np.ones(out[lname].n_triangles, dtype=bool)
            keep[np.asarray(r["removed"], dtype=np.int64)] = False
            created = np.asarray(r["created"], dtype=np.int64)
            gid = len(gaps)
            tags[lname] = np.concatenate([tags[lname][keep], np.full(len(created), gid, dtype=np.int64)])
            out[lname] = surf
            ct = surf.triangles[created]
            gaps.append(Gap(
                fault=fname, layer=lname, triangles=created, n_vertices=int(len(np.unique(ct))),
                n_holes=0, seconds=sec,
                metadata={"method": "cutting", "created": int(len(created)),
                          "removed": int(len(r["removed"])), "split": int(len(r["split"])),
                          "line_points": int(len(r["footwall_line"])),
                          "lines": int(len(r["line_offsets"]) - 1), "displacement": float(dz),
                          "min_angle": min_angles(surf.vertices, ct),
                          "min_angle_xy": min_angles(surf.vertices[:, :2], ct)}))
    for g_id, g in enumerate(gaps):
        g.triangles = np.flatnonzero(tags[g.layer] == g_id).astype(np.int64)
    return out, gaps


def cut_model(dataset, *, layers: Optional[Mapping[str, Surface]] = None,
              faults: Optional[Mapping[str, Surface]] = None, taper_length: float = 150.0,
              extension: float = 100.0, refine: bool = True, order: str = "quality") -> Model:
    """The cutting baseline on a dataset: its continuous layers cut by its faults.

    ``layers`` (name -> continuous layer surface) defaults to
    :func:`continuous_layers`; ``faults`` (name -> fault surface) to the fault
    surfaces :func:`faultmesh.build_model` lofts from the fault-plane traces,
    so both methods start from the same surfaces. Faults are applied in
    dataset order (the members of a T-crossing group one after the other),
    each to the layers its traces interpret, with the displacement of
    :func:`fault_displacement` tapered over ``taper_length`` metres from the
    line's tips. A fault surface that ends within ``extension`` metres of the
    study-area boundary cuts the layer up to it (``CutOptions::extension``;
    faultmesh's own workflow likewise carries such faults to the boundary).
    Returns a :class:`~faultmesh.model.Model` whose ``gaps`` are
    the cuts (see :func:`cut_surfaces`) and whose ``metadata["seconds"]`` is
    the time of all cuts (building the surfaces it starts from not counted).
    """
    if layers is None:
        layers = continuous_layers(dataset)
    if faults is None:
        faults = build_model(dataset, evaluate=False).faults
    cuts = []
    for f in dataset.faults:
        if f.name not in faults:
            raise ValueError(f"cut_model: no surface for fault {f.name!r} (have {list(faults)})")
        disp = {}
        for lname in dataset.layers:
            dz = fault_displacement(f, lname)
            if dz is not None:
                disp[lname] = dz
        cuts.append((f.name, faults[f.name], disp))
    t0 = time.perf_counter()
    cut, gaps = cut_surfaces(layers, cuts, taper_length=taper_length, extension=extension,
                             refine=refine, order=order)
    seconds = time.perf_counter() - t0
    boundary = getattr(dataset, "boundary", None)
    return Model(name=f"{dataset.name} (cutting baseline)", surfaces=cut, faults=dict(faults),
                 boundary=None if boundary is None else np.asarray(boundary, dtype=np.float64),
                 crs=getattr(dataset, "crs", ""), gaps=gaps, truth=getattr(dataset, "truth", None),
                 metadata={"method": "cutting baseline", "taper_length": taper_length,
                           "extension": extension,
                           "refine": refine, "order": order, "seconds": seconds})
