"""VTK files through meshio: ``.vtu`` (XML unstructured grid, what ParaView and
PyVista prefer) and ``.vtk`` (legacy). Layouts: see :mod:`._meshio`."""
from __future__ import annotations

from . import _meshio

SUFFIXES = (".vtu", ".vtk")


def write(model, path, fmt: str = "vtu", files=None):
    return _meshio.write_merged(model, path, fmt, files)


def read(path, fmt: str = "vtu"):
    return _meshio.read_merged(path, fmt)
