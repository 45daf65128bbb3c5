"""Stanford ``.ply`` (binary) through meshio (MeshLab, CloudCompare). A merged
file carries ``surface_id`` as a vertex property. See :mod:`._meshio`."""
from __future__ import annotations

from . import _meshio

SUFFIXES = (".ply",)


def write(model, path, fmt: str = "ply", files=None):
    return _meshio.write_merged(model, path, "ply", files)


def read(path, fmt: str = "ply"):
    return _meshio.read_merged(path, "ply")
