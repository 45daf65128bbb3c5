"""Reading and writing models: the format follows the file's suffix.

=========  ================================================  ====================
suffix     format                                            keeps
=========  ================================================  ====================
``.3dt``   faultmesh's own text format (docs/3dt.md)         everything: surfaces,
                                                             kinds, order, gaps,
                                                             boundary, metadata
``.ts``    GOCAD TSurf, one object per surface               surfaces, names,
                                                             kinds, order, CRS,
                                                             vertex properties
``.ml``    GOCAD Model3d (a structural model: horizons       as ``.ts``
           and faults), TSurf objects inline
``.pl``    GOCAD PLine (read; written as the boundary)       lines, boundary
``.vtu``   VTK XML unstructured grid, merged                 names, kinds, arrays
``.vtp``   VTK XML poly data, merged                         names, kinds, arrays
``.vtk``   VTK legacy (binary), merged                       names, kinds, arrays
``.vtm``   VTK XML multiblock of ``.vtp``/``.vtu`` blocks    names (block names),
           (read only; pyvista's ``MultiBlock.save``)        kinds, arrays
``.obj``   Wavefront OBJ, one object per surface             names, kinds
``.ply``   PLY binary, merged (one mesh in viewers)          names, kinds
``.stl``   STL (read only)                                   one surface
``.omf``   Open Mining Format v1 (``faultmesh[omf]``)        names, kinds
``.epc``   RESQML 2.0.1 (+ ``.h5``; ``faultmesh[resqml]``)   names, kinds, CRS
``.geoh5`` Geoscience ANALYST (``faultmesh[geoh5]``)         names, kinds
folder     ``<name>.3dt``, ``<name>.ts``, ``<name>.vtu``,       see above; the
           and ``obj/``, ``ply/`` with one file per surface   per-surface files
           ``<NN>_<kind>_<name>.<ext>``                       keep names
=========  ================================================  ====================

The GOCAD writers put the study boundary in ``<stem>_boundary.pl`` beside the
``.ts``/``.ml``. All writes are atomic: files are written under temporary
names and renamed only when every file of the call is complete. Every vertex
coordinate and triangle reads back exactly (docs/formats.md). Readers raise
:class:`ModelFileError` naming the file, also when another library fails (or
tries to exit) inside.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, List, Optional

from .formats import gocad, obj, ply, stl, threedt, vtk
from .formats import _meshio
from .formats._common import AtomicFiles, ModelFileError, guarded, slug

__all__ = ["save_model", "load_model", "ModelFileError", "FILE_FORMATS", "FOLDER_FORMATS"]


def _lazy(module: str, name: str):
    """A writer/reader of an optional format, imported when used."""
    def call(*args, **kwargs):
        import importlib

        return getattr(importlib.import_module(f".formats.{module}", __package__), name)(*args, **kwargs)

    call.__name__ = name
    return call


#: suffix -> (writer or None for read-only formats, reader); every writer
#: takes ``(model, path, files=None)`` and returns the path or paths written.
FILE_FORMATS = {
    ".3dt": (threedt.write_3dt, threedt.read_3dt),
    ".ts": (gocad.write_ts, gocad.read_gocad),
    ".ml": (gocad.write_ml, gocad.read_gocad),
    ".pl": (None, gocad.read_pl),
    ".vtu": (lambda m, p, files=None: vtk.write(m, p, "vtu", files), vtk.read_xml),
    ".vtp": (lambda m, p, files=None: vtk.write(m, p, "vtp", files), vtk.read_xml),
    ".vtk": (lambda m, p, files=None: vtk.write(m, p, "vtk", files), vtk.read_legacy),
    ".vtm": (None, vtk.read_vtm),
    ".obj": (obj.write, obj.read),
    ".ply": (ply.write, ply.read),
    ".stl": (None, stl.read),
    ".omf": (_lazy("omf", "write"), _lazy("omf", "read")),
    ".epc": (_lazy("resqml", "write"), _lazy("resqml", "read")),
    ".geoh5": (_lazy("geoh5", "write"), _lazy("geoh5", "read")),
}
#: the formats a folder target receives by default
FOLDER_FORMATS = ("3dt", "ts", "vtu", "obj", "ply")
_PER_SURFACE = ("obj", "ply")


def _paths(result, default: Path) -> List[Path]:
    if result is None:
        return [default]
    if isinstance(result, (list, tuple)):
        return [Path(p) for p in result]
    return [Path(result)]


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
        writer = FILE_FORMATS[suffix][0]
        if writer is None:
            raise ValueError(f"save_model: {suffix} is read-only in faultmesh; write one of "
                             f"{', '.join(k for k, v in FILE_FORMATS.items() if v[0])}")
        return _paths(writer(model, path), path)
    fmts = [f.lower().lstrip(".") for f in (FOLDER_FORMATS if formats is None else formats)]
    for f in fmts:
        if "." + f not in FILE_FORMATS or FILE_FORMATS["." + f][0] is None:
            raise ValueError(f"save_model: unknown format {f!r}; formats are "
                             f"{[s.lstrip('.') for s, v in FILE_FORMATS.items() if v[0]]}")
    written: List[Path] = []
    stem = slug(model.name)
    with AtomicFiles() as files:
        for f in fmts:
            if f in _PER_SURFACE:
                written += _meshio.write_folder(model, path / f, f, files)
            else:
                target = path / f"{stem}.{f}"
                for p in _paths(FILE_FORMATS["." + f][0](model, target, files=files), target):
                    if p not in written:
                        written.append(p)
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
    reader = FILE_FORMATS[suffix][1]
    if kwargs and suffix not in (".ts", ".ml"):
        raise TypeError(f"load_model: {suffix} takes no options (got {', '.join(kwargs)})")
    # Our readers raise ModelFileError; the guard also turns what a library
    # inside raises (or a sys.exit in it) into a ModelFileError naming the file.
    return guarded(path, f"reading it as {suffix}", reader, path, **kwargs)
