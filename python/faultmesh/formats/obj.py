"""Wavefront ``.obj`` through meshio (Blender, MeshLab). OBJ as written by
meshio has no data arrays: a merged file reads back as one surface; use a
folder (one file per surface) to keep the surfaces apart. See :mod:`._meshio`."""
from __future__ import annotations

from . import _meshio

SUFFIXES = (".obj",)


def write(model, path, fmt: str = "obj", files=None):
    return _meshio.write_merged(model, path, "obj", files)


def read(path, fmt: str = "obj"):
    return _meshio.read_merged(path, "obj")
