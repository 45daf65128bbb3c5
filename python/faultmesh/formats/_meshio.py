"""Surfaces through meshio: VTU/VTK (ParaView, PyVista), OBJ, PLY.

Two layouts (docs/3dt.md, "Other formats"):

* **one file** (``model.vtu``): every surface in one mesh, vertices not shared
  between surfaces, in the model's surface order (layers top to bottom, then
  faults). ``surface_id`` (the index in that order) is written as point data
  and, where the format has cell data (VTU, VTK), as cell data together with
  ``kind`` (0 layer, 1 fault). meshio has no place for names in these
  formats, so a file read back gives surfaces called ``surface_<id>``. OBJ
  keeps no data at all: it reads back as one surface.
* **one file per surface in a folder** (``<folder>/<NN>_<kind>_<name>.<ext>``,
  ``NN`` the surface index): names, kinds and order survive, and every viewer
  opens the pieces as separate objects.

Coordinates are float64 in binary VTU/VTK/PLY and shortest round-trip
decimals in OBJ, so they read back exactly.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import numpy as np

from ._common import AtomicFiles, ModelFileError, _Shared, slug

FORMATS = {".vtu": "vtu", ".vtk": "vtk", ".obj": "obj", ".ply": "ply"}
_PIECE = re.compile(r"^(\d+)_(layer|fault)_(.+)$")


def _surfaces(model) -> List[Tuple[object, str]]:
    return [(s, "layer") for s in model.surfaces.values()] + \
           [(s, "fault") for s in model.faults.values()]


def _meshio():
    import meshio

    return meshio


def _mesh(points: np.ndarray, tris: np.ndarray, fmt: str, point_data=None, cell_data=None):
    meshio = _meshio()
    # PLY has no 64-bit integers; the indices fit in int32 for any mesh meshio
    # can hold in memory anyway, and casting here avoids meshio's warning.
    cells = [("triangle", tris.astype(np.int32 if fmt == "ply" else np.int64))]
    return meshio.Mesh(points, cells, point_data=point_data or {},
                       cell_data=cell_data or {})


def write_merged(model, path, fmt: str, files: Optional[AtomicFiles] = None) -> Path:
    """All surfaces in one file (see the module docstring)."""
    path = Path(path)
    surfs = _surfaces(model)
    pts, tris, sid_p, sid_c, kind_c = [], [], [], [], []
    off = 0
    for k, (s, kind) in enumerate(surfs):
        pts.append(s.vertices)
        tris.append(s.triangles + off)
        sid_p.append(np.full(s.n_vertices, k, dtype=np.int32))
        sid_c.append(np.full(s.n_triangles, k, dtype=np.int32))
        kind_c.append(np.full(s.n_triangles, 1 if kind == "fault" else 0, dtype=np.int32))
        off += s.n_vertices
    P = np.vstack(pts) if pts else np.zeros((0, 3))
    T = np.vstack(tris) if tris else np.zeros((0, 3), dtype=np.int64)
    point_data = {} if fmt == "obj" else {"surface_id": np.concatenate(sid_p) if sid_p
                                          else np.zeros(0, np.int32)}
    cell_data = {}
    if fmt in ("vtu", "vtk"):
        cell_data = {"surface_id": [np.concatenate(sid_c) if sid_c else np.zeros(0, np.int32)],
                     "kind": [np.concatenate(kind_c) if kind_c else np.zeros(0, np.int32)]}
    mesh = _mesh(P, T, fmt, point_data, cell_data)
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        tmp = f.temp_path(path)
        _meshio().write(str(tmp), mesh, file_format=fmt)
    return path


def write_folder(model, folder, fmt: str, files: Optional[AtomicFiles] = None) -> List[Path]:
    """One file per surface: ``<folder>/<NN>_<kind>_<name>.<fmt>``."""
    folder = Path(folder)
    written = []
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        for k, (s, kind) in enumerate(_surfaces(model)):
            target = folder / f"{k:02d}_{kind}_{slug(s.name)}.{fmt}"
            tmp = f.temp_path(target)
            _meshio().write(str(tmp), _mesh(s.vertices, s.triangles, fmt), file_format=fmt)
            written.append(target)
    return written


def _read_mesh(path: Path, fmt: str):
    meshio = _meshio()
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    try:
        mesh = meshio.read(str(path), file_format=fmt)
    except Exception as e:  # meshio raises many types; name the file and the reason
        raise ModelFileError(path, f"cannot be read as {fmt.upper()}: {e}") from None
    tris = []
    for block in mesh.cells:
        if block.type == "triangle":
            tris.append(np.asarray(block.data, dtype=np.int64))
        elif block.type in ("vertex", "line"):
            continue
        else:
            raise ModelFileError(path, f"expected a triangle mesh, found {len(block.data)} "
                                       f"{block.type!r} cells")
    T = np.vstack(tris) if tris else np.zeros((0, 3), dtype=np.int64)
    P = np.asarray(mesh.points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] not in (2, 3):
        raise ModelFileError(path, f"expected points (n, 3), got shape {P.shape}")
    if P.shape[1] == 2:
        P = np.column_stack([P, np.zeros(len(P))])
    if T.size and (T.min() < 0 or T.max() >= len(P)):
        raise ModelFileError(path, f"triangle vertex index outside 0..{len(P) - 1}")
    return mesh, P, T


def read_merged(path, fmt: str):
    """Read one meshio file into a Model (split by ``surface_id`` when present)."""
    from ..model import Model, Surface

    path = Path(path)
    mesh, P, T = _read_mesh(path, fmt)
    sid = mesh.point_data.get("surface_id")
    layers: Dict[str, Surface] = {}
    faults: Dict[str, Surface] = {}
    if sid is None:
        layers[path.stem] = Surface(name=path.stem, vertices=P, triangles=T)
        return Model(name=path.stem, surfaces=layers)
    sid = np.asarray(sid).astype(np.int64).reshape(-1)
    kind_c = None
    if "kind" in mesh.cell_data:
        kind_c = np.concatenate([np.asarray(a).reshape(-1) for a in mesh.cell_data["kind"]])
        if len(kind_c) != len(T):
            kind_c = None
    tsid = sid[T] if len(T) else np.zeros((0, 3), np.int64)
    if len(T) and not np.all(tsid == tsid[:, :1]):
        row = int(np.flatnonzero(~np.all(tsid == tsid[:, :1], axis=1))[0])
        raise ModelFileError(path, f"triangle {row} joins vertices of different surface_id "
                                   f"values {tsid[row].tolist()}")
    for k in np.unique(sid).tolist():
        vsel = np.flatnonzero(sid == k)
        remap = np.full(len(P), -1, dtype=np.int64)
        remap[vsel] = np.arange(len(vsel))
        tsel = np.flatnonzero(tsid[:, 0] == k) if len(T) else np.zeros(0, np.int64)
        is_fault = kind_c is not None and len(tsel) and int(kind_c[tsel[0]]) == 1
        name = f"surface_{k}"
        surf = Surface(name=name, vertices=P[vsel], triangles=remap[T[tsel]],
                       kind="fault" if is_fault else "layer")
        (faults if is_fault else layers)[name] = surf
    return Model(name=path.stem, surfaces=layers, faults=faults)


def read_folder(folder, fmts=("vtu", "vtk", "obj", "ply")):
    """Read a folder of per-surface files (``write_folder``'s naming; other
    mesh files become layers named after the file, after the named ones)."""
    from ..model import Model, Surface

    folder = Path(folder)
    entries = []
    for p in sorted(folder.iterdir()):
        ext = p.suffix.lower().lstrip(".")
        if not p.is_file() or ext not in fmts or p.name.startswith("."):  # hidden: temp files
            continue
        m = _PIECE.match(p.stem)
        order, kind, name = (int(m.group(1)), m.group(2), m.group(3)) if m else (10 ** 9, "layer", p.stem)
        _, P, T = _read_mesh(p, ext)
        entries.append((order, p.name, Surface(name=name, vertices=P, triangles=T, kind=kind)))
    if not entries:
        raise ModelFileError(folder, f"no surface files ({', '.join('.' + f for f in fmts)}) "
                                     "in this folder")
    entries.sort(key=lambda e: (e[0], e[1]))
    layers = {e[2].name: e[2] for e in entries if e[2].kind == "layer"}
    faults = {e[2].name: e[2] for e in entries if e[2].kind == "fault"}
    return Model(name=folder.name, surfaces=layers, faults=faults)
