"""STL (``.stl``, ASCII or binary), read by faultmesh: one surface named after
the file (STL keeps no names or data). STL repeats every corner in every
facet; corners with identical coordinates become one vertex.

ASCII or binary is decided from the content, not from the leading ``solid``
(many binary exporters start their 80-byte header with ``solid``, and pad or
append bytes after the facets): a file of text only that starts with
``solid`` is ASCII (keywords in any case, as the format's readers accept);
anything else of at least 84 bytes is binary, whose facet count (bytes
80-84) must fit in the file (bytes after the facets are ignored).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ._common import ModelFileError, split_merged

SUFFIXES = (".stl",)
# STL keywords are case-insensitive in practice (SolidWorks and older CAD
# exporters write SOLID/FACET/VERTEX): match them in any case.
_VERTEX = re.compile(rb"^\s*vertex\s+(\S+)\s+(\S+)\s+(\S+)\s*$", re.M | re.I)
_ENDLOOP = re.compile(rb"^\s*endloop\b", re.M | re.I)
_FACET = re.compile(rb"^\s*facet\b", re.M | re.I)
# Bytes that never occur in an ASCII STL (controls other than tab, newlines,
# vertical tab, form feed). Binary float data nearly always has some (a 0.0 or
# any small integer coordinate has NUL bytes); UTF-8 in a solid name stays text.
_NOT_TEXT = re.compile(rb"[\x00-\x08\x0e-\x1f\x7f]")
_REC = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])


def _ascii(path, data: bytes):
    """Corners (3 per facet) of an ASCII STL; ``None`` if it has no facet."""
    found = _VERTEX.findall(data)
    n_facets = len(_ENDLOOP.findall(data))
    if not found and not n_facets and not _FACET.search(data):
        return None
    if len(found) % 3 or len(found) != 3 * n_facets:
        raise ModelFileError(path, f"ASCII STL: {len(found)} 'vertex' lines for {n_facets} "
                                   "closed facets (each needs 3; truncated file?)")
    try:
        return np.array(found, dtype=np.float64).reshape(-1, 3)
    except ValueError:
        raise ModelFileError(path, "ASCII STL: a vertex has coordinates that are not "
                                   "numbers") from None


def _binary(path, data: bytes):
    n = int(np.frombuffer(data[80:84], "<u4")[0])
    need = 84 + 50 * n
    if need > len(data):
        have = (len(data) - 84) // 50
        raise ModelFileError(path, f"binary STL: the header announces {n} facets "
                                   f"(84 + 50 x {n} = {need} bytes), the file has {len(data)} "
                                   f"bytes ({have} whole facets): truncated file?")
    rec = np.frombuffer(data, _REC, count=n, offset=84)
    return rec["v"].astype(np.float64).reshape(-1, 3)


def read(path, fmt: str = "stl"):
    from .vtk import _read_bytes

    path = Path(path)
    data = _read_bytes(path)
    is_text = _NOT_TEXT.search(data) is None
    if is_text and data.lstrip()[:5].lower() == b"solid":
        corners = _ascii(path, data)
        if corners is None:
            # Text without facets: an empty ASCII solid. (It cannot be a
            # binary STL: a facet count read from text bytes, >= 0x09090909,
            # never fits the file.)
            corners = np.zeros((0, 3))
    elif is_text:
        raise ModelFileError(path, "not an STL file: text that does not start with 'solid'")
    elif len(data) < 84:
        raise ModelFileError(path, f"not an STL file: neither 'solid ...' text nor a binary "
                                   f"STL (84-byte header + 50 bytes a facet; the file has "
                                   f"{len(data)} bytes)")
    else:
        corners = _binary(path, data)
    if not np.all(np.isfinite(corners)):
        i = int(np.flatnonzero(~np.all(np.isfinite(corners), axis=1))[0])
        raise ModelFileError(path, f"STL: non-finite coordinates in facet {i // 3} "
                                   f"(corner {i % 3}: {corners[i].tolist()})")
    P, inv = np.unique(corners, axis=0, return_inverse=True)
    return split_merged(path, P, inv.reshape(-1, 3), {}, {})
