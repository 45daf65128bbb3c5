"""Reading and writing models: the format follows the file's suffix.

=========  ==============================================  =====================
suffix     format                                          keeps
=========  ==============================================  =====================
``.3dt``   faultmesh's own text format (docs/3dt.md)       everything: surfaces,
                                                           kinds, order, gaps,
                                                           boundary, metadata
``.ts``    GOCAD TSurf, one object per surface             surfaces, names,
                                                           kinds, order, CRS,
                                                           boundary (PLine)
``.vtu``   VTK XML unstructured grid (meshio), merged      surfaces by
``.vtk``   VTK legacy (meshio), merged                     ``surface_id``, kind
``.ply``   PLY binary (meshio), merged                     ``surface_id``
``.obj``   Wavefront OBJ (meshio), merged                  geometry only
folder     every format: ``<name>.3dt``, ``<name>.ts``,     see above; the
           ``<name>.vtu``, and ``obj/``, ``ply/`` with one  per-surface files
           file per surface ``<NN>_<kind>_<name>.<ext>``   keep names
=========  ==============================================  =====================

All writes are atomic: files are written under temporary names and renamed
only when every file of the call is complete. Every vertex coordinate and
triangle reads back exactly from ``.3dt``, ``.ts`` and the meshio formats.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, List, Optional

from .formats import gocad, obj, ply, threedt, vtk
from .formats import _meshio
from .formats._common import AtomicFiles, ModelFileError, slug

__all__ = ["save_model", "load_model", "ModelFileError", "FILE_FORMATS", "FOLDER_FORMATS"]

#: suffix -> (writer, reader); every writer takes ``(model, path, files=None)``.
FILE_FORMATS = {
    ".3dt": (threedt.write_3dt, threedt.read_3dt),
    ".ts": (gocad.write_ts, gocad.read_ts),
    ".vtu": (lambda m, p, files=None: vtk.write(m, p, "vtu", files), lambda p: vtk.read(p, "vtu")),
    ".vtk": (lambda m, p, files=None: vtk.write(m, p, "vtk", files), lambda p: vtk.read(p, "vtk")),
    ".obj": (obj.write, obj.read),
    ".ply": (ply.write, ply.read),
}
#: the formats a folder target receives by default
FOLDER_FORMATS = ("3dt", "ts", "vtu", "obj", "ply")
_PER_SURFACE = ("obj", "ply")


def _is_folder_target(path: Path) -> bool:
    return path.is_dir() or (path.suffix == "" and not path.is_file()) or \
        str(path).endswith(("/", "\\"))


def save_model(model, path, *, formats: Optional[Iterable[str]] = None) -> List[Path]:
    """Write ``model`` to ``path`` and return the files written.

    ``path`` with a suffix from :data:`FILE_FORMATS` writes that one file. A
    folder (an existing directory, or a path without a suffix) receives every
    format of ``formats`` (default :data:`FOLDER_FORMATS`): ``.3dt``, ``.ts``,
    ``.vtu`` and ``.vtk`` as ``<folder>/<model name>.<ext>``; ``obj`` and
    ``ply`` as one file per surface in ``<folder>/<ext>/``. All files of one
    call are written atomically together.
    """
    path = Path(path)
    if not _is_folder_target(path):
        suffix = path.suffix.lower()
        if suffix not in FILE_FORMATS:
            raise ValueError(f"save_model: unknown format {path.suffix!r} for {path}; use one of "
                             f"{', '.join(FILE_FORMATS)} or a folder")
        if formats is not None:
            raise ValueError("save_model: formats= applies to a folder target only")
        FILE_FORMATS[suffix][0](model, path)
        return [path]
    fmts = [f.lower().lstrip(".") for f in (FOLDER_FORMATS if formats is None else formats)]
    for f in fmts:
        if "." + f not in FILE_FORMATS:
            raise ValueError(f"save_model: unknown format {f!r}; formats are "
                             f"{[s.lstrip('.') for s in FILE_FORMATS]}")
    written: List[Path] = []
    stem = slug(model.name)
    with AtomicFiles() as files:
        for f in fmts:
            if f in _PER_SURFACE:
                written += _meshio.write_folder(model, path / f, f, files)
            else:
                target = path / f"{stem}.{f}"
                FILE_FORMATS["." + f][0](model, target, files=files)
                written.append(target)
    return written


def _run_model(folder: Path, kwargs):
    """The model of the folder's current run (faultmesh.runs: ``run.json``),
    or None when the folder has no manifest or its run wrote no model file."""
    from .runs import RunFolderError, current_run

    for attempt in range(3):
        try:
            view = current_run(folder)
        except RunFolderError as e:
            raise ModelFileError(folder, str(e)) from None
        if view is None or not view.model:
            return None
        target = view.path(view.model)
        suffix = target.suffix.lower()
        if suffix not in FILE_FORMATS:
            raise ModelFileError(folder, f"run manifest names model {view.model!r} of an "
                                         "unknown format")
        try:
            return FILE_FORMATS[suffix][1](target, **kwargs)
        except FileNotFoundError:
            # A run swapping itself in moved the file between our look-up
            # and the open: look again (three times at most).
            if not view.swapping or attempt == 2:
                raise
    return None  # pragma: no cover


def load_model(path, **kwargs):
    """Read a model written by :func:`save_model` (or by another tool).

    ``.3dt`` and ``.ts`` give the whole model; ``.vtu``/``.vtk``/``.ply``/
    ``.obj`` give the surfaces they hold (see :mod:`faultmesh.io`). A folder
    written by ``faultmesh build``/``demo``: the model file its run manifest
    (``run.json``, :mod:`faultmesh.runs`) names. Another folder: its ``.3dt``
    file if it has exactly one, else its ``.ts`` file, else one surface per
    mesh file (``<NN>_<kind>_<name>.<ext>`` names keep order and kind);
    hidden files (temporary files among them) are never read. Keyword arguments go to the reader (``atoms=`` for ``.ts``).
    Raises :class:`ModelFileError` (a ``ValueError``) naming the file and line.
    """
    path = Path(path)
    if path.is_dir():
        model = _run_model(path, kwargs)
        if model is not None:
            return model
        # A folder without a run manifest: hidden files (our temporary
        # ".NAME.XXXXXXXX.tmp.EXT" among them) are never taken for the model.
        for suffix in (".3dt", ".ts"):
            found = sorted(p for p in path.glob("*" + suffix) if not p.name.startswith("."))
            if len(found) == 1:
                return FILE_FORMATS[suffix][1](found[0], **kwargs)
            if len(found) > 1:
                raise ModelFileError(path, f"several {suffix} files in this folder "
                                           f"({', '.join(p.name for p in found)}); name one")
        try:
            return _meshio.read_folder(path)
        except ModelFileError:
            for sub in _PER_SURFACE:
                if (path / sub).is_dir():
                    return _meshio.read_folder(path / sub)
            raise
    suffix = path.suffix.lower()
    if suffix not in FILE_FORMATS:
        raise ValueError(f"load_model: unknown format {path.suffix!r} for {path}; readable: "
                         f"{', '.join(FILE_FORMATS)} or a folder")
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file")
    return FILE_FORMATS[suffix][1](path, **kwargs)
