"""Geoscience ANALYST ``.geoh5`` through ``geoh5py`` (``pip install
'faultmesh[geoh5]'``).

Written: a workspace with two container groups, ``Layers`` and ``Faults``
(as the model orders them), each surface a ``Surface`` object named after it
with its vertices (float64, exact), triangles and vertex properties as float
data, and object data ``faultmesh_order`` (geoh5 keeps no order) and
``faultmesh_fault_kind``. Read: every ``Surface`` object (in faultmesh's order,
else by name); a fault when one of its parent groups is named like "fault",
vertex float data as vertex properties.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np

from ._common import (AtomicFiles, ModelFileError, _Shared, free_name, guarded, model_surfaces,
                      optional_import, vertex_properties)

SUFFIXES = (".geoh5",)


def _g():
    optional_import("geoh5py", "geoh5", "Geoscience ANALYST files (.geoh5)")
    from geoh5py.groups import ContainerGroup
    from geoh5py.objects import Surface as GSurface
    from geoh5py.workspace import Workspace

    return Workspace, ContainerGroup, GSurface


def _write_into(model, tmp: Path) -> None:
    Workspace, ContainerGroup, GSurface = _g()
    ws = Workspace.create(str(tmp))
    try:
        groups = {"layer": ContainerGroup.create(ws, name="Layers"),
                  "fault": ContainerGroup.create(ws, name="Faults")}
        for k, (surf, kind) in enumerate(model_surfaces(model)):
            gs = GSurface.create(ws, name=str(surf.name), parent=groups[kind],
                                 vertices=np.asarray(surf.vertices, np.float64),
                                 cells=np.asarray(surf.triangles, np.uint32))
            # geoh5 keeps no order of objects: faultmesh's own object data do.
            own = {"faultmesh_order": {"values": np.array([k], np.int32), "association": "OBJECT"}}
            sub = str((surf.metadata or {}).get("kind", "")).lower()
            if kind == "fault" and sub in ("normal", "reverse"):
                own["faultmesh_fault_kind"] = {"values": sub, "association": "OBJECT",
                                               "type": "text"}
            gs.add_data(own)
            for name, a in vertex_properties(surf).items():
                a = np.asarray(a, np.float64).reshape(surf.n_vertices, -1)
                for c in range(a.shape[1]):
                    gs.add_data({name if a.shape[1] == 1 else f"{name}[{c}]":
                                 {"values": a[:, c].astype(np.float64), "association": "VERTEX"}})
    finally:
        ws.close()


def write(model, path, fmt: str = "geoh5", files: Optional[AtomicFiles] = None) -> Path:
    path = Path(path)
    if any(s.n_vertices >= 2 ** 32 for s, _ in model_surfaces(model)):  # pragma: no cover
        raise ValueError("geoh5: a surface has more than 2^32 vertices")
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        tmp = f.temp_path(path)
        tmp.unlink()          # geoh5py creates the file itself
        _write_into(model, tmp)
    return path


def _read(path: Path):
    from ..model import Model, Surface

    Workspace, ContainerGroup, GSurface = _g()
    ws = Workspace(str(path), mode="r")
    try:
        layers, faults = {}, {}
        objs = [o for o in ws.objects if isinstance(o, GSurface)]

        def own(o, name):
            for d in getattr(o, "children", []) or []:
                if d.name == name and str(getattr(d, "association", "")).upper().endswith("OBJECT"):
                    return d.values
            return None

        def position(o):
            v = own(o, "faultmesh_order")
            try:
                return (0, int(np.asarray(v).reshape(-1)[0]), str(o.name))
            except (TypeError, ValueError, IndexError):
                return (1, 0, str(o.name))     # foreign objects: by name

        for obj in sorted(objs, key=position):
            V = np.asarray(obj.vertices, np.float64).reshape(-1, 3)
            T = np.asarray(obj.cells if obj.cells is not None else np.zeros((0, 3)),
                           np.int64).reshape(-1, 3)
            parents, p = [], obj.parent
            while p is not None and p is not ws and hasattr(p, "name"):
                parents.append(str(p.name).lower())
                p = getattr(p, "parent", None)
            kind = "fault" if any("fault" in n for n in parents) else "layer"
            fk = own(obj, "faultmesh_fault_kind")
            props = {}
            for d in getattr(obj, "children", []):
                vals = getattr(d, "values", None)
                if vals is not None and str(getattr(d, "association", "")).upper().endswith(
                        "VERTEX") and np.asarray(vals).dtype.kind in "biuf" and len(vals) == len(V):
                    props[str(d.name)] = np.asarray(vals, np.float64)
            target = faults if kind == "fault" else layers
            name = str(obj.name)
            name = free_name(name, target)
            if T.size and (T.min() < 0 or T.max() >= len(V)):
                raise ModelFileError(path, f"surface {name!r}: triangle vertex index outside "
                                           f"0..{len(V) - 1}")
            meta = {"vertex_properties": props} if props else {}
            if kind == "fault" and str(fk) in ("normal", "reverse"):
                meta["kind"] = str(fk)
            target[name] = Surface(name=name, vertices=V, triangles=T, kind=kind, metadata=meta)
    finally:
        ws.close()
    if not layers and not faults:
        raise ModelFileError(path, "no Surface object in this geoh5 workspace")
    return Model(name=path.stem, surfaces=layers, faults=faults)


def read(path, fmt: str = "geoh5"):
    path = Path(path)
    _g()
    return guarded(path, "reading it as geoh5 (geoh5py)", _read, path)
