"""STL (``.stl``, ASCII or binary) read through meshio: one surface named after
the file (STL keeps no names or data; its duplicated corners are merged by
meshio)."""
from __future__ import annotations

from pathlib import Path

from ._common import split_merged

SUFFIXES = (".stl",)


def read(path, fmt: str = "stl"):
    from . import _meshio

    path = Path(path)
    _, P, T = _meshio.read_mesh(path, "stl")
    return split_merged(path, P, T, {}, {})
