"""Open Mining Format v1 (``.omf``: Leapfrog, Deswik, Surpac, Micromine) through
the ``omf`` package (``pip install 'faultmesh[omf]'``).

Written: one ``SurfaceElement`` per surface (layers top to bottom, then
faults) named after it, its vertices (float64, exact) and triangles, the
layer colours of faultmesh's pictures, the surface's vertex properties as
``ScalarData`` on the vertices, and ``description`` ``faultmesh kind=<layer|
fault> [fault_kind=<normal|reverse>]`` (OMF v1 has no surface type). An
empty surface (no triangles) is a ``SurfaceElement`` with an empty grid
(``SurfaceGridGeometry`` of no cells): omf refuses a ``SurfaceGeometry``
without triangles. Read: every ``SurfaceElement`` (geometry and project
origins added), a grid surface without cells as an empty surface (other grid
surfaces are skipped), a fault when its description says ``kind=fault`` (or
its name contains "fault"), vertex ``ScalarData`` as vertex properties; other
elements (points, lines, volumes) are skipped.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Optional

import numpy as np

from ._common import (AtomicFiles, ModelFileError, _Shared, guarded, model_surfaces,
                      optional_import, vertex_properties)

SUFFIXES = (".omf",)
_KIND = re.compile(r"\bkind=(layer|fault)\b")
_FAULT_KIND = re.compile(r"\bfault_kind=(normal|reverse)\b")


def _omf():
    return optional_import("omf", "omf", "Open Mining Format files (.omf)")


def _project(model):
    from ..plots import layer_color
    from matplotlib.colors import to_rgb

    omf = _omf()
    proj = omf.Project(name=str(model.name), description=f"faultmesh model; crs={model.crs or ''}")
    elements = []
    n_layers = len(model.surfaces)
    order = {"layer": 0, "fault": 0}
    for surf, kind in model_surfaces(model):
        desc = f"faultmesh kind={kind}"
        sub = str((surf.metadata or {}).get("kind", "")).lower()
        if kind == "fault" and sub in ("normal", "reverse"):
            desc += f" fault_kind={sub}"
        rgb = to_rgb(layer_color(order[kind], n_layers)) if kind == "layer" else (0.55, 0.1, 0.1)
        order[kind] += 1
        if not surf.n_triangles:
            # omf's SurfaceGeometry validator takes the min of the triangles
            # (fails on none); an empty grid is a SurfaceElement of no cells.
            elements.append(omf.SurfaceElement(
                name=str(surf.name), description=desc,
                color=[int(round(255 * c)) for c in rgb],
                geometry=omf.SurfaceGridGeometry(tensor_u=np.zeros(0), tensor_v=np.zeros(0))))
            continue
        data = []
        for name, a in vertex_properties(surf).items():
            a = np.asarray(a, np.float64).reshape(surf.n_vertices, -1)
            for c in range(a.shape[1]):
                data.append(omf.ScalarData(name=name if a.shape[1] == 1 else f"{name}[{c}]",
                                           array=a[:, c], location="vertices"))
        elements.append(omf.SurfaceElement(
            name=str(surf.name), description=desc, color=[int(round(255 * c)) for c in rgb],
            geometry=omf.SurfaceGeometry(vertices=np.asarray(surf.vertices, np.float64),
                                         triangles=np.asarray(surf.triangles, np.int64)),
            data=data))
    proj.elements = elements
    proj.validate()
    return proj


def write(model, path, fmt: str = "omf", files: Optional[AtomicFiles] = None) -> Path:
    path = Path(path)
    omf = _omf()
    proj = _project(model)
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        tmp = f.temp_path(path)
        omf.OMFWriter(proj, str(tmp))
    return path


def read(path, fmt: str = "omf"):
    from ..model import Model, Surface

    path = Path(path)
    omf = _omf()
    proj = guarded(path, "reading it as OMF", lambda: omf.OMFReader(str(path)).get_project())
    origin = np.asarray(getattr(proj, "origin", None) if getattr(proj, "origin", None) is not None
                        else [0.0, 0.0, 0.0], np.float64).reshape(3)
    layers, faults = {}, {}
    crs = ""
    m = re.search(r"crs=(.*)$", str(getattr(proj, "description", "") or ""))
    if m:
        crs = m.group(1).strip()
    for el in proj.elements:
        if type(el).__name__ != "SurfaceElement":
            continue
        geo = el.geometry
        if type(geo).__name__ == "SurfaceGeometry":
            V = np.asarray(geo.vertices, np.float64).reshape(-1, 3) + \
                np.asarray(geo.origin, np.float64) + origin
            T = np.asarray(geo.triangles, np.int64).reshape(-1, 3)
        elif type(geo).__name__ == "SurfaceGridGeometry" and not (
                len(geo.tensor_u) and len(geo.tensor_v)):
            # a grid of no cells: an empty surface (how faultmesh writes one)
            V, T = np.zeros((0, 3)), np.zeros((0, 3), np.int64)
        else:
            continue   # a grid surface with cells: no triangles to take
        if T.size and (T.min() < 0 or T.max() >= len(V)):
            raise ModelFileError(path, f"element {el.name!r}: triangle vertex index outside "
                                       f"0..{len(V) - 1}")
        desc = str(el.description or "")
        km = _KIND.search(desc)
        kind = km.group(1) if km else ("fault" if "fault" in str(el.name).lower() else "layer")
        meta = {}
        fk = _FAULT_KIND.search(desc)
        if fk:
            meta["kind"] = fk.group(1)
        props = {d.name: np.asarray(d.array, np.float64) for d in (el.data or [])
                 if getattr(d, "location", "") == "vertices" and len(d.array) == len(V)
                 and np.asarray(d.array).dtype.kind in "biuf"}
        if props:
            meta["vertex_properties"] = props
        target = faults if kind == "fault" else layers
        name = str(el.name) or f"surface_{len(layers) + len(faults)}"
        base, n = name, 2
        while name in target:
            name, n = f"{base} ({n})", n + 1
        target[name] = Surface(name=name, vertices=V, triangles=T, kind=kind, metadata=meta)
    if not layers and not faults:
        raise ModelFileError(path, "no triangulated surface element in this OMF project")
    return Model(name=str(proj.name or path.stem), surfaces=layers, faults=faults, crs=crs)
