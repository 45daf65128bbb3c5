"""PyVista (``pip install 'faultmesh[viz]'``): a model as a ``pyvista.MultiBlock``
and back, and the interactive 3D view of ``faultmesh plot --interactive``.

:func:`to_pyvista` gives one ``PolyData`` block per surface (layers top to
bottom, then faults), the block named after the surface, with field data
``name``, ``kind`` (``layer``/``fault``), ``fault_kind`` (``normal``/
``reverse`` when known) and ``order``; per-triangle arrays (``owner``,
``kind`` from ``Surface.owner``/``Surface.kinds``, and
``metadata["triangle_properties"]``) as cell data and vertex properties as
point data. The MultiBlock's field data holds ``model_name`` and ``crs``.
:func:`from_pyvista` reads such a MultiBlock, any MultiBlock of triangle
meshes, or one mesh (split by a ``surface_id`` point array when it has one).
"""
from __future__ import annotations

import os
import sys
from typing import Dict, Optional

import numpy as np

from ._common import (free_name, model_surfaces, optional_import, split_merged, surface_kind, triangle_arrays,
                      vertex_properties)

_OWN_FIELDS = ("name", "kind", "fault_kind", "order")


def _pv():
    return optional_import("pyvista", "viz", "Model.to_pyvista and faultmesh.from_pyvista")


def _set_strings(ds, key: str, values) -> None:
    """A string field array, through VTK (pyvista refuses non-ASCII text; VTK
    stores UTF-8)."""
    from vtkmodules.vtkCommonCore import vtkStringArray

    arr = vtkStringArray()
    arr.SetName(key)
    for v in values:
        arr.InsertNextValue(str(v))
    ds.GetFieldData().AddArray(arr)


def surface_to_polydata(surf, kind: str, order: int):
    pv = _pv()
    faces = np.column_stack([np.full(surf.n_triangles, 3, np.int64),
                             np.asarray(surf.triangles, np.int64)]).reshape(-1)
    poly = pv.PolyData(np.asarray(surf.vertices, np.float64), faces)
    for name, a in vertex_properties(surf).items():
        poly.point_data[name] = np.asarray(a)
    for name, a in triangle_arrays(surf).items():
        poly.cell_data[name] = np.asarray(a)
    _set_strings(poly, "name", [surf.name])
    _set_strings(poly, "kind", [kind])
    sub = str((surf.metadata or {}).get("kind", "")).lower()
    if kind == "fault" and sub in ("normal", "reverse"):
        _set_strings(poly, "fault_kind", [sub])
    poly.field_data["order"] = np.array([order], np.int32)
    return poly


def to_pyvista(model):
    """The model as a ``pyvista.MultiBlock`` (see the module docstring)."""
    pv = _pv()
    mb = pv.MultiBlock()
    used = set()
    order = {"layer": 0, "fault": 0}
    for surf, kind in model_surfaces(model):
        name = str(surf.name)
        if name in used:            # a layer and a fault may share a name
            name = f"{name} ({kind})"
        used.add(name)
        mb.append(surface_to_polydata(surf, kind, order[kind]), name)
        order[kind] += 1
    _set_strings(mb, "model_name", [model.name])
    _set_strings(mb, "crs", [model.crs or ""])
    return mb


def _field_str(ds, key: str) -> Optional[str]:
    try:
        if key in ds.field_data.keys():
            v = ds.field_data[key]
            return str(v[0]) if len(v) else None
    except Exception:  # pragma: no cover (odd field data)
        return None
    return None


def _triangles(mesh, what: str) -> tuple:
    pv = _pv()
    if isinstance(mesh, pv.UnstructuredGrid):
        # Taken as it is (extract_surface would renumber the points).
        types = np.asarray(mesh.celltypes)
        if mesh.n_cells and not np.all(types == 5):
            raise ValueError(f"from_pyvista: {what} has cells that are not triangles; call "
                             ".triangulate() on it first")
        T = np.asarray(mesh.cells, np.int64).reshape(-1, 4)[:, 1:] if mesh.n_cells else \
            np.zeros((0, 3), np.int64)
        return mesh, np.asarray(mesh.points, np.float64).reshape(-1, 3), T
    if not isinstance(mesh, pv.PolyData):
        try:
            mesh = mesh.extract_surface(algorithm="dataset_surface")
        except TypeError:  # pyvista before 0.47 has no algorithm= (and no warning)
            mesh = mesh.extract_surface()
    if mesh.n_cells and not mesh.is_all_triangles:
        raise ValueError(f"from_pyvista: {what} has cells that are not triangles; call "
                         ".triangulate() on it first")
    V = np.asarray(mesh.points, np.float64).reshape(-1, 3)
    T = np.asarray(mesh.faces, np.int64).reshape(-1, 4)[:, 1:] if mesh.n_cells else \
        np.zeros((0, 3), np.int64)
    return mesh, V, T


def from_pyvista(obj, name: Optional[str] = None):
    """A :class:`faultmesh.Model` from a ``pyvista.MultiBlock`` (one surface per
    block, names and kinds from :func:`to_pyvista`'s field data or the block
    names) or from one PyVista mesh (split by its ``surface_id`` point array)."""
    from ..model import Model, Surface

    pv = _pv()
    if isinstance(obj, pv.MultiBlock):
        layers: Dict[str, Surface] = {}
        faults: Dict[str, Surface] = {}
        entries = []
        for i in range(obj.n_blocks):
            block = obj[i]
            if block is None or block.n_points == 0:
                continue
            if isinstance(block, pv.MultiBlock):
                raise ValueError(f"from_pyvista: block {i} is itself a MultiBlock; flatten "
                                 "it first (MultiBlock.flatten())")
            label = obj.get_block_name(i) or f"surface_{i}"
            mesh, V, T = _triangles(block, f"block {label!r}")
            sname = _field_str(mesh, "name") or label
            kind = surface_kind(_field_str(mesh, "kind"))
            meta: Dict[str, object] = {}
            fk = _field_str(mesh, "fault_kind")
            if fk:
                meta["kind"] = fk
            vp = {k: np.asarray(mesh.point_data[k]) for k in mesh.point_data.keys()
                  if np.asarray(mesh.point_data[k]).dtype.kind in "biuf"}
            tp = {k: np.asarray(mesh.cell_data[k]) for k in mesh.cell_data.keys()
                  if np.asarray(mesh.cell_data[k]).dtype.kind in "biuf"}
            if vp:
                meta["vertex_properties"] = vp
            if tp:
                meta["triangle_properties"] = tp
            try:
                order = int(np.asarray(mesh.field_data["order"])[0]) \
                    if "order" in mesh.field_data.keys() else i
            except (ValueError, TypeError, IndexError):
                order = i
            entries.append((kind, order, i, Surface(sname, V, T, kind=kind, metadata=meta)))
        for kind, _, _, s in sorted(entries, key=lambda e: (e[0] == "fault", e[1], e[2])):
            target = faults if kind == "fault" else layers
            s.name = free_name(s.name, target)
            target[s.name] = s
        if not layers and not faults:
            raise ValueError("from_pyvista: the MultiBlock holds no mesh")
        return Model(name=name or _field_str(obj, "model_name") or "pyvista",
                     surfaces=layers, faults=faults, crs=_field_str(obj, "crs") or "")
    if not hasattr(obj, "points") or not hasattr(obj, "n_cells"):
        raise TypeError(f"from_pyvista: expected a pyvista MultiBlock or mesh, got "
                        f"{type(obj).__name__}")
    mesh, V, T = _triangles(obj, "the mesh")
    names = list(map(str, mesh.field_data["surface_names"])) \
        if "surface_names" in mesh.field_data.keys() else None
    kinds = list(map(str, mesh.field_data["surface_kinds"])) \
        if "surface_kinds" in mesh.field_data.keys() else None
    pa = {k: np.asarray(mesh.point_data[k]) for k in mesh.point_data.keys()
          if np.asarray(mesh.point_data[k]).dtype.kind in "biuf"}
    ca = {k: np.asarray(mesh.cell_data[k]) for k in mesh.cell_data.keys()
          if np.asarray(mesh.cell_data[k]).dtype.kind in "biuf"}
    m = split_merged(name or "pyvista", V, T, pa, ca, names, kinds,
                     _field_str(mesh, "model_name") or (name or "pyvista"),
                     _field_str(mesh, "crs") or "")
    return m


def has_display() -> bool:
    """Whether an interactive window can open (a display on X11/Wayland; on
    Windows and macOS there always is one)."""
    if sys.platform.startswith(("win", "darwin")):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def show(model, vertical_exaggeration: Optional[float] = None, off_screen: bool = False,
         screenshot=None):
    """Open the model in an interactive PyVista window (layers in the colours
    of faultmesh's pictures, faults dark red). ``off_screen=True`` renders
    without a window (``screenshot``: a PNG path or None); returns the image."""
    from ..plots import layer_color

    pv = _pv()
    if not off_screen and not has_display():
        raise RuntimeError("an interactive window needs a display, and none is set (DISPLAY/"
                           "WAYLAND_DISPLAY); draw a picture with --png instead")
    mb = to_pyvista(model)
    ve = 1.0 if vertical_exaggeration is None else float(vertical_exaggeration)
    plotter = pv.Plotter(off_screen=off_screen, title=f"faultmesh: {model.name}")
    n_layers = len(model.surfaces)
    for i in range(mb.n_blocks):
        block = mb[i]
        kind = _field_str(block, "kind")
        order = int(np.asarray(block.field_data["order"])[0])
        color = layer_color(order, n_layers) if kind == "layer" else (0.55, 0.1, 0.1)
        plotter.add_mesh(block, color=color, label=mb.get_block_name(i),
                         opacity=1.0 if kind == "layer" else 0.8)
    plotter.set_scale(zscale=ve)
    plotter.add_legend()
    plotter.show_grid()
    if off_screen:
        img = plotter.screenshot(screenshot, return_img=True)
        plotter.close()
        return img
    plotter.show()
    return None
