"""STL (``.stl``, ASCII or binary), read by faultmesh: one surface named after
the file (STL keeps no names or data). STL repeats every corner in every
facet; corners with identical coordinates become one vertex.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ._common import ModelFileError, split_merged

SUFFIXES = (".stl",)
_VERTEX = re.compile(rb"^\s*vertex\s+(\S+)\s+(\S+)\s+(\S+)\s*$", re.M)


def read(path, fmt: str = "stl"):
    from .vtk import _read_bytes

    path = Path(path)
    data = _read_bytes(path)
    corners = None
    if len(data) >= 84:
        n = int(np.frombuffer(data[80:84], "<u4")[0])
        if len(data) == 84 + 50 * n:       # binary: the size says so exactly
            rec = np.frombuffer(data[84:], np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)),
                                                     ("a", "<u2")]))
            corners = rec["v"].astype(np.float64).reshape(-1, 3)
    if corners is None:
        if not data.lstrip().lower().startswith(b"solid"):
            raise ModelFileError(path, "not an STL file: neither 'solid ...' text nor a binary "
                                       "STL of 84 + 50 x facets bytes")
        found = _VERTEX.findall(data)
        n_facets = len(re.findall(rb"^\s*endloop\b", data, re.M))
        if len(found) % 3 or len(found) != 3 * n_facets:
            raise ModelFileError(path, f"ASCII STL: {len(found)} 'vertex' lines for {n_facets} "
                                       "closed facets (each needs 3; truncated file?)")
        try:
            corners = np.array(found, dtype=np.float64).reshape(-1, 3)
        except ValueError:
            raise ModelFileError(path, "ASCII STL: a vertex has coordinates that are not "
                                       "numbers") from None
    if not np.all(np.isfinite(corners)):
        raise ModelFileError(path, "STL: non-finite vertex coordinates")
    P, inv = np.unique(corners, axis=0, return_inverse=True)
    return split_merged(path, P, inv.reshape(-1, 3), {}, {})
