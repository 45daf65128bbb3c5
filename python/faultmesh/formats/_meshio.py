"""The folder layout of one file per surface (``<folder>/<NN>_<kind>_<name>.<ext>``,
``NN`` the surface's position: layers top down, then faults), which keeps
names, kinds and order for viewers that show one object per file.

(The module kept its old name; faultmesh reads and writes every mesh format
itself now, meshio is no longer used.)
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import List, Optional

from ._common import AtomicFiles, ModelFileError, _Shared, model_surfaces, slug

_PIECE = re.compile(r"^(\d+)_(layer|fault)_(.+)$")


def write_folder(model, folder, fmt: str, files: Optional[AtomicFiles] = None) -> List[Path]:
    """One file per surface: ``<folder>/<NN>_<kind>_<name>.<fmt>``."""
    from ..io import FILE_FORMATS
    from ..model import Model

    folder = Path(folder)
    writer = FILE_FORMATS["." + fmt][0]
    written = []
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        for k, (s, kind) in enumerate(model_surfaces(model)):
            target = folder / f"{k:02d}_{kind}_{slug(s.name)}.{fmt}"
            one = Model(name=s.name, surfaces={s.name: s} if kind == "layer" else {},
                        faults={s.name: s} if kind == "fault" else {}, crs=model.crs)
            writer(one, target, files=f)
            written.append(target)
    return written


def read_folder(folder, fmts=("vtu", "vtk", "vtp", "obj", "ply", "stl")):
    """Read a folder of per-surface files (``write_folder``'s naming; other
    mesh files become layers named after the file, after the named ones)."""
    from ..io import FILE_FORMATS
    from ..model import Model

    folder = Path(folder)
    entries = []
    for p in sorted(folder.iterdir()):
        ext = p.suffix.lower().lstrip(".")
        if not p.is_file() or ext not in fmts or p.name.startswith("."):  # hidden: temp files
            continue
        m = _PIECE.match(p.stem)
        order, kind, name = (int(m.group(1)), m.group(2), m.group(3)) if m else \
            (10 ** 9, "layer", p.stem)
        sub = FILE_FORMATS["." + ext][1](p)
        inside = list(sub.surfaces.values()) + list(sub.faults.values())
        for s in inside:
            # A name or kind kept inside the file (ours) wins over the file name.
            if len(inside) == 1 and s.name == p.stem:
                s.name = name
            if m and s.kind == "layer":
                s.kind = kind
            entries.append((order, p.name, s))
    if not entries:
        raise ModelFileError(folder, f"no surface files ({', '.join('.' + f for f in fmts)}) "
                                     "in this folder")
    entries.sort(key=lambda e: (e[0], e[1]))
    layers = {e[2].name: e[2] for e in entries if e[2].kind == "layer"}
    faults = {e[2].name: e[2] for e in entries if e[2].kind == "fault"}
    return Model(name=folder.name, surfaces=layers, faults=faults)
