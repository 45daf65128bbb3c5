"""VTK files, read and written by faultmesh itself (no VTK or meshio needed).

Written (the merged layout of :class:`._common.Merged`: every surface in one
mesh, in model order):

* ``.vtu`` (XML UnstructuredGrid) and ``.vtp`` (XML PolyData): arrays inline
  as base64 binary (float64 coordinates, exact), little-endian, UInt64 headers;
* ``.vtk`` (legacy, version 4.2, BINARY, UNSTRUCTURED_GRID): the types VTK's
  legacy reader knows (``int``, ``double``, ``string``), so VTK 8/9, ParaView
  and PyVista read every array.

Point data ``surface_id`` and the surfaces' vertex properties; cell data
``surface_id``, ``kind`` (0 layer, 1 fault) and the per-triangle arrays; field
data (string arrays, shown by ParaView's Information panel)
``surface_names``, ``surface_kinds`` (``layer``/``fault``), ``model_name``
and ``crs``, from which the reader gives the surfaces back with their names.

Read: ``.vtu``, ``.vtp`` (ascii, inline binary or appended raw/base64 data,
uncompressed or zlib/lzma compressed, UInt32/UInt64 headers, either byte
order) and legacy ``.vtk`` (ASCII or BINARY, versions 2 to 5.1, POLYDATA or
UNSTRUCTURED_GRID) as written by VTK, ParaView, PyVista, meshio and us.
Triangles are kept, and so are triangle strips (PolyData strips and strip
cells of an unstructured grid), as the triangles VTK makes of them
(orientation alternating along the strip), each with the cell data of its
strip; vertices, lines and poly-lines are ignored; any other cell (quads,
polygons, volumes) is an error naming it. A ``.vtm`` (XML multiblock) of
``.vtp``/``.vtu`` blocks is read by :func:`read_vtm`, one block after another.
Every problem raises :class:`ModelFileError` naming the file (and the line in
legacy headers).
"""
from __future__ import annotations

import base64
import copy
import re
import stat
import zlib
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import numpy as np

from ._common import (AtomicFiles, Merged, ModelFileError, _Shared, drop_non_finite, free_name,
                      split_merged, surface_kind, walk_starts)

SUFFIXES = (".vtu", ".vtp", ".vtk")
VTK_TRIANGLE = 5
VTK_TRIANGLE_STRIP = 6
# Cells faultmesh ignores when reading: vertex, poly-vertex, line, poly-line.
_IGNORED_CELLS = {1, 2, 3, 4}
_CELL_NAMES = {6: "triangle strip", 7: "polygon", 8: "pixel", 9: "quad", 10: "tetra",
               11: "voxel", 12: "hexahedron", 13: "wedge", 14: "pyramid"}
_FIELD_STRINGS = ("surface_names", "surface_kinds", "model_name", "crs")


# --------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------

_XML_TYPES = {np.dtype(np.int32): "Int32", np.dtype(np.float64): "Float64",
              np.dtype(np.int64): "Int64", np.dtype(np.uint8): "UInt8"}


def _xml_escape(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def _b64(a: np.ndarray) -> str:
    """Inline binary: one base64 block of the UInt64 byte count and the data
    (the layout meshio writes; VTK reads it)."""
    data = np.ascontiguousarray(a).astype(a.dtype.newbyteorder("<"), copy=False).tobytes()
    return base64.b64encode(np.uint64(len(data)).tobytes() + data).decode("ascii")


def _xml_array(name: Optional[str], a: np.ndarray, ncomp: int = 1) -> str:
    a = np.asarray(a)
    if a.dtype not in _XML_TYPES:
        a = a.astype(np.float64)
    attrs = f'type="{_XML_TYPES[a.dtype]}"'
    if name is not None:
        attrs += f' Name="{_xml_escape(name)}"'
    if ncomp != 1:
        attrs += f' NumberOfComponents="{ncomp}"'
    return f'<DataArray {attrs} format="binary">{_b64(a.reshape(-1))}</DataArray>'


def _xml_strings(name: str, values: List[str]) -> str:
    # VTK's XML string arrays: the bytes (as signed chars) of each UTF-8
    # string followed by a 0.
    raw = b"".join(v.encode("utf-8") + b"\0" for v in values)
    codes = np.frombuffer(raw, dtype=np.int8)
    return (f'<Array type="String" Name="{_xml_escape(name)}" NumberOfTuples="{len(values)}" '
            f'format="ascii">{" ".join(map(str, codes.tolist()))}</Array>')


def _field_strings(m: Merged) -> Dict[str, List[str]]:
    return {"surface_names": m.names, "surface_kinds": m.kinds, "model_name": [m.name],
            "crs": [m.crs]}


def _data_section(tag: str, arrays: Dict[str, np.ndarray]) -> List[str]:
    out = [f"<{tag}>"]
    for n, a in arrays.items():
        a = np.asarray(a)
        out.append(_xml_array(n, a, 1 if a.ndim == 1 else a.shape[1]))
    out.append(f"</{tag}>")
    return out


def xml_text(model, kind: str) -> str:
    """The ``.vtu`` (``kind="vtu"``) or ``.vtp`` (``"vtp"``) text of ``model``."""
    m = Merged.of(model)
    grid = "UnstructuredGrid" if kind == "vtu" else "PolyData"
    n, k = len(m.points), len(m.triangles)
    out = ['<?xml version="1.0"?>',
           f'<VTKFile type="{grid}" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
           f"<{grid}>", "<FieldData>"]
    out += [_xml_strings(name, vals) for name, vals in _field_strings(m).items()]
    out.append("</FieldData>")
    if kind == "vtu":
        out.append(f'<Piece NumberOfPoints="{n}" NumberOfCells="{k}">')
    else:
        out.append(f'<Piece NumberOfPoints="{n}" NumberOfVerts="0" NumberOfLines="0" '
                   f'NumberOfStrips="0" NumberOfPolys="{k}">')
    out += _data_section("PointData", m.point_arrays)
    out += _data_section("CellData", m.cell_arrays)
    out += ["<Points>", _xml_array("Points", np.asarray(m.points, np.float64), 3), "</Points>"]
    conn = np.asarray(m.triangles, np.int64).reshape(-1)
    offsets = np.arange(3, 3 * k + 1, 3, dtype=np.int64)
    if kind == "vtu":
        out += ["<Cells>", _xml_array("connectivity", conn), _xml_array("offsets", offsets),
                _xml_array("types", np.full(k, VTK_TRIANGLE, np.uint8)), "</Cells>"]
    else:
        out += ["<Polys>", _xml_array("connectivity", conn), _xml_array("offsets", offsets),
                "</Polys>"]
    out += ["</Piece>", f"</{grid}>", "</VTKFile>", ""]
    return "\n".join(out)


def _legacy_name(s: str) -> str:
    """An array name as VTK's legacy writer encodes it: white space, ``%``
    and non-ASCII bytes as ``%XX``."""
    return "".join(chr(b) if 32 < b < 127 and b != 0x25 else f"%{b:02X}"
                   for b in s.encode("utf-8")) or "%00"


def _legacy_string(s: str) -> bytes:
    """A string of a binary legacy ``string`` array: VTK's length prefix (the
    top two bits of the first byte give its size), then the UTF-8 bytes."""
    b = s.encode("utf-8")
    n = len(b)
    if n < 1 << 6:
        head = bytes([0xC0 | n])
    elif n < 1 << 14:
        head = (0x8000 | n).to_bytes(2, "big")
    elif n < 1 << 30:
        head = (0x40000000 | n).to_bytes(4, "big")
    else:  # pragma: no cover (a gigabyte name)
        head = n.to_bytes(8, "big")
    return head + b


def _legacy_field(title: str, arrays: Dict[str, np.ndarray]) -> bytes:
    out = [f"FIELD {title} {len(arrays)}\n".encode()]
    for n, a in arrays.items():
        a = np.asarray(a)
        ncomp = 1 if a.ndim == 1 else a.shape[1]
        if a.dtype == np.int32:
            t, data = "int", a.astype(">i4")
        else:
            t, data = "double", a.astype(">f8")
        out.append(f"{_legacy_name(n)} {ncomp} {len(a)} {t}\n".encode())
        out.append(data.tobytes() + b"\n")
    return b"".join(out)


def legacy_bytes(model) -> bytes:
    """The legacy ``.vtk`` bytes of ``model`` (BINARY, big-endian as the format says)."""
    m = Merged.of(model)
    title = f"faultmesh model {m.name}".replace("\n", " ").replace("\r", " ")
    title = title.encode("utf-8")[:250].decode("utf-8", "ignore")
    out = [b"# vtk DataFile Version 4.2\n", title.encode("utf-8") + b"\n",
           b"BINARY\nDATASET UNSTRUCTURED_GRID\n"]
    strings = _field_strings(m)
    out.append(f"FIELD FieldData {len(strings)}\n".encode())
    for n, vals in strings.items():
        out.append(f"{n} 1 {len(vals)} string\n".encode())
        out.append(b"".join(_legacy_string(v) for v in vals) + b"\n")
    n, k = len(m.points), len(m.triangles)
    out.append(f"POINTS {n} double\n".encode())
    out.append(np.asarray(m.points, ">f8").tobytes() + b"\n")
    if k and int(np.max(m.triangles)) >= 2 ** 31:  # pragma: no cover (2 billion vertices)
        raise ValueError("legacy .vtk: more than 2^31 vertices; write .vtu instead")
    cells = np.column_stack([np.full(k, 3), np.asarray(m.triangles).reshape(k, 3)])
    out.append(f"CELLS {k} {4 * k}\n".encode())
    out.append(cells.astype(">i4").tobytes() + b"\n")
    out.append(f"CELL_TYPES {k}\n".encode())
    out.append(np.full(k, VTK_TRIANGLE, ">i4").tobytes() + b"\n")
    out.append(f"POINT_DATA {n}\n".encode())
    out.append(_legacy_field("FieldData", m.point_arrays))
    out.append(f"CELL_DATA {k}\n".encode())
    out.append(_legacy_field("FieldData", m.cell_arrays))
    return b"".join(out)


def write(model, path, fmt: str = "vtu", files: Optional[AtomicFiles] = None) -> Path:
    """Write ``model`` to ``path`` as ``fmt`` (``vtu``, ``vtp`` or ``vtk``), atomically."""
    path = Path(path)
    if fmt not in ("vtu", "vtp", "vtk"):
        raise ValueError(f"vtk.write: format must be vtu, vtp or vtk, got {fmt!r}")
    if fmt == "vtk":
        data = legacy_bytes(model)
    else:
        data = xml_text(model, fmt).encode("utf-8")
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        f.open(path, "wb").write(data)
    return path


# --------------------------------------------------------------------------
# reading: XML (.vtu, .vtp)
# --------------------------------------------------------------------------

_NP_TYPES = {"Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2", "Int32": "i4",
             "UInt32": "u4", "Int64": "i8", "UInt64": "u8", "Float32": "f4", "Float64": "f8"}


class _Xml:
    def __init__(self, path: Path, data: bytes) -> None:
        import xml.etree.ElementTree as ET

        self.path = path
        self.appended = b""
        self.appended_b64 = False
        i = data.find(b"<AppendedData")
        if i >= 0:
            j = data.find(b">", i)
            k = data.find(b"_", j)
            end = data.rfind(b"</AppendedData>")
            if j < 0 or k < 0:
                raise ModelFileError(path, "AppendedData: no '_' marker before the data")
            head = data[i:j + 1].decode("latin-1")
            self.appended_b64 = 'encoding="base64"' in head
            self.appended = data[k + 1:end if end > k else len(data)]
            data = data[:i] + b"</VTKFile>"
        try:
            self.root = ET.fromstring(data)
        except ET.ParseError as e:
            raise ModelFileError(path, f"not a readable VTK XML file: {e}") from None
        if self.root.tag != "VTKFile":
            raise ModelFileError(path, f"not a VTK XML file: the root element is "
                                       f"<{self.root.tag}>, expected <VTKFile>")
        self.order = "<" if self.root.get("byte_order", "LittleEndian") == "LittleEndian" else ">"
        ht = self.root.get("header_type", "UInt32")
        if ht not in ("UInt32", "UInt64"):
            raise ModelFileError(path, f"header_type {ht!r} is not UInt32 or UInt64")
        self.header = np.dtype(self.order + _NP_TYPES[ht])
        comp = self.root.get("compressor", "")
        self.decompress = None
        if comp == "vtkZLibDataCompressor":
            self.decompress = lambda b, n: zlib.decompressobj().decompress(b, n)
        elif comp == "vtkLZMADataCompressor":
            import lzma

            self.decompress = lambda b, n: lzma.LZMADecompressor().decompress(b, n)
        elif comp:
            raise ModelFileError(path, f"compressor {comp} is not supported (zlib and lzma are); "
                                       "save the file uncompressed or with zlib")

    def err(self, msg: str) -> ModelFileError:
        return ModelFileError(self.path, msg)

    def _blocks(self, head: np.ndarray, body: bytes) -> bytes:
        """Uncompress ``body`` given the compression header (nblocks, block
        size, last block size, compressed sizes)."""
        nb = int(head[0])
        sizes = head[3:3 + nb].astype(np.int64)
        if len(sizes) != nb or int(sizes.sum()) > len(body):
            raise self.err("compressed data shorter than its header says")
        # the uncompressed size of each block: the header's block size, the
        # last one its own (0: a full block). The output is capped at it, so
        # a stream inflating to more (a zlib bomb) stops there, refused.
        full, last = int(head[1]), int(head[2])
        out, pos = [], 0
        for i, s in enumerate(sizes.tolist()):
            want = last if i == nb - 1 and last else full
            try:
                block = self.decompress(body[pos:pos + s], want + 1)
            except Exception as e:
                raise self.err(f"compressed data cannot be uncompressed: {e}") from None
            if len(block) > want:
                raise self.err(f"compressed block {i} holds more than the {want} bytes its "
                               "header announces")
            out.append(block)
            pos += s
        return b"".join(out)

    def _inline(self, text: str) -> bytes:
        """Decode inline binary: header and data base64-encoded separately (VTK)
        or together (meshio)."""
        t = "".join(text.split()).encode("ascii", "replace")
        hs = self.header.itemsize
        try:
            if self.decompress is None:
                hchars = -(-hs // 3) * 4
                if t[:hchars].endswith(b"="):
                    n = int(np.frombuffer(base64.b64decode(t[:hchars]), self.header)[0])
                    body = base64.b64decode(t[hchars:])
                else:
                    raw = base64.b64decode(t)
                    n = int(np.frombuffer(raw[:hs], self.header)[0])
                    body = raw[hs:]
                if n > len(body):
                    raise self.err(f"binary array announces {n} bytes, holds {len(body)}")
                return body[:n]
            hchars = -(-3 * hs // 3) * 4
            first = np.frombuffer(base64.b64decode(t[:hchars])[:3 * hs], self.header)
            nb = int(first[0])
            hbytes = (3 + nb) * hs
            hchars = -(-hbytes // 3) * 4
            head = np.frombuffer(base64.b64decode(t[:hchars])[:hbytes], self.header)
            return self._blocks(head, base64.b64decode(t[hchars:]))
        except ModelFileError:
            raise
        except (ValueError, IndexError, TypeError) as e:
            raise self.err(f"binary array is not valid base64 data: {e}") from None

    def _appended(self, offset: int) -> bytes:
        hs = self.header.itemsize
        data = self.appended
        if self.appended_b64:
            raise self.err("appended base64 data is not supported; save the file with raw "
                           "appended data or inline binary")
        if offset < 0 or offset + hs > len(data):
            raise self.err(f"appended data offset {offset} outside the data ({len(data)} bytes)")
        if self.decompress is None:
            n = int(np.frombuffer(data[offset:offset + hs], self.header)[0])
            if offset + hs + n > len(data):
                raise self.err(f"appended array at offset {offset} announces {n} bytes past "
                               "the end of the file")
            return data[offset + hs:offset + hs + n]
        nb = int(np.frombuffer(data[offset:offset + hs], self.header)[0])
        if nb < 0 or offset + (3 + nb) * hs > len(data):
            raise self.err(f"appended compressed array at offset {offset}: bad block count {nb}")
        head = np.frombuffer(data[offset:offset + (3 + nb) * hs], self.header)
        return self._blocks(head, data[offset + (3 + nb) * hs:])

    def array(self, el) -> np.ndarray:
        t = el.get("type", "")
        name = el.get("Name", "")
        fmt = el.get("format", "ascii")
        ncomp = _count_attr(self.path, el, "NumberOfComponents", f"array {name!r}", 1)
        if t == "String":
            raw = self._raw(el, fmt, "i1")
            parts = raw.tobytes().split(b"\0")
            if parts and parts[-1] == b"":
                parts.pop()
            return np.array([p.decode("utf-8", "replace") for p in parts], dtype=object)
        if t not in _NP_TYPES:
            raise self.err(f"array {name!r}: type {t!r} is not supported")
        a = self._raw(el, fmt, _NP_TYPES[t])
        if ncomp < 1 or len(a) % ncomp:
            raise self.err(f"array {name!r}: {len(a)} values do not make {ncomp}-component tuples")
        return a.reshape(-1, ncomp) if ncomp > 1 else a

    def _raw(self, el, fmt: str, code: str) -> np.ndarray:
        name = el.get("Name", "")
        if fmt == "ascii":
            try:
                vals = np.array((el.text or "").split(), dtype=np.float64)
            except ValueError:
                raise self.err(f"array {name!r}: ascii values are not numbers") from None
            return vals.astype(code) if code[0] in "iu" else vals.astype(code)
        if fmt == "binary":
            raw = self._inline(el.text or "")
        elif fmt == "appended":
            try:
                offset = int(el.get("offset", ""))
            except ValueError:
                raise self.err(f"array {name!r}: appended array without a valid offset") from None
            # Outside the try: _appended's own ModelFileError (a ValueError,
            # e.g. "base64 appended data not supported") must reach the user.
            raw = self._appended(offset)
        else:
            raise self.err(f"array {name!r}: format {fmt!r} is not ascii, binary or appended")
        dt = np.dtype(self.order + code)
        if len(raw) % dt.itemsize:
            raise self.err(f"array {name!r}: {len(raw)} bytes are not whole {code} values")
        return np.frombuffer(raw, dt).astype(dt.newbyteorder("="))


def _count_attr(path: Path, el, attr: str, where: str, default: int = 0) -> int:
    """The count attribute ``attr`` of ``el`` (NumberOfPolys, NumberOfComponents...),
    or a ModelFileError naming ``where``, the attribute and its value."""
    text = el.get(attr)
    if text is None or not text.strip():
        return default
    try:
        v = int(text)
    except ValueError:
        raise ModelFileError(path, f"{where}: {attr}={text!r} is not a count") from None
    if v < 0 or v >= 2 ** 62:
        raise ModelFileError(path, f"{where}: {attr}={text!r} is not a count "
                                   f"({'negative' if v < 0 else 'too large'})")
    return v


def _arrays(x: _Xml, el) -> Dict[str, np.ndarray]:
    out: Dict[str, np.ndarray] = {}
    if el is None:
        return out
    for a in el:
        if a.tag in ("DataArray", "Array"):
            arr = x.array(a)
            if arr.dtype != object:
                out[a.get("Name") or f"array_{len(out)}"] = arr
    return out


def _cells_from_offsets(path: Path, conn: np.ndarray, offsets: np.ndarray, types=None,
                        what: str = "cells", noun: str = "cell") -> Tuple[np.ndarray, np.ndarray]:
    """Triangles from a connectivity/offsets pair (``offsets`` the end of each
    cell, one per cell: a caller holding the legacy 5.1 / PLY form starting
    with 0 drops that 0) and, for each, the index of its cell; other cells
    ignored (vertices, lines: also any cell of fewer than 3 points without
    ``types``) or refused naming the first. Triangle strips (type 6) become
    the triangles VTK makes of them, each with the index of its strip.

    The form of ``offsets`` is the caller's to say, never guessed from the
    values: end offsets starting with 0 are those of an empty first cell,
    whose cell data must not move to the next one."""
    conn = np.asarray(conn, np.int64).reshape(-1)
    ends = np.asarray(offsets, np.int64).reshape(-1)
    starts = np.concatenate([[0], ends[:-1]]) if len(ends) else ends
    if len(ends) and (np.any(ends < starts) or ends[-1] > len(conn) or starts[0] < 0):
        raise ModelFileError(path, f"{what}: offsets are not increasing within the "
                                   f"{len(conn)} connectivity entries")
    size = ends - starts
    if types is None:
        types = np.where(size == 3, VTK_TRIANGLE, np.where(size <= 2, 3, 7))
    types = np.asarray(types).reshape(-1)
    if len(types) != len(size):
        raise ModelFileError(path, f"{what}: {len(types)} cell types for {len(size)} cells")
    strip = types == VTK_TRIANGLE_STRIP
    if strip.any():
        # strips (a .vtu or legacy UNSTRUCTURED_GRID may hold them as cells):
        # their triangles join the others in cell order, as VTK's
        # triangulate() gives them
        t1, s1 = _cells_from_offsets(path, conn, ends, np.where(strip, 3, types), what, noun)
        which = np.flatnonzero(strip)
        t2, s2 = _strips(path, conn, ends[which], starts[which], what)
        src = np.concatenate([s1, which[s2]])
        order = np.argsort(src, kind="stable")
        return np.vstack([t1, t2])[order], src[order]
    tri = types == VTK_TRIANGLE
    poly3 = (types == 7) & (size == 3)
    bad = ~(tri | poly3 | np.isin(types, list(_IGNORED_CELLS)))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        t = int(types[i])
        raise ModelFileError(path, f"expected a triangle mesh, found {int(bad.sum())} other "
                                   f"{noun}(s), the first a {_CELL_NAMES.get(t, f'VTK type {t}')} "
                                   f"of {int(size[i])} points ({noun} {i}); triangulate it first "
                                   "(ParaView: Triangulate)")
    keep = tri | poly3
    if np.any(size[keep] != 3):
        i = int(np.flatnonzero(keep & (size != 3))[0])
        raise ModelFileError(path, f"{what}: triangle {noun} {i} has {int(size[i])} points")
    if keep.all() and len(size) and starts[0] == 0 and ends[-1] == 3 * len(size):
        # only triangles, one after the other (the usual file): a reshape
        return conn[:ends[-1]].reshape(-1, 3), np.arange(len(size))
    src = np.flatnonzero(keep)
    s = starts[src]
    return np.column_stack([conn[s], conn[s + 1], conn[s + 2]]).reshape(-1, 3), src


def _strips(path: Path, conn: np.ndarray, offsets: np.ndarray, starts=None,
            what: str = "Strips") -> Tuple[np.ndarray, np.ndarray]:
    """Triangles of triangle strips, as VTK makes them (vtkTriangleStrip):
    triangle i of the strip p0..pn is (p_i, p_i+1, p_i+2) for even i and
    (p_i+1, p_i, p_i+2) for odd i, so that all turn one way; and for each
    triangle the index of its strip. A strip of fewer than 3 points has none.
    ``offsets`` are the strips' ends; ``starts`` their starts when the strips
    are not one after the other (strips among other cells)."""
    conn = np.asarray(conn, np.int64).reshape(-1)
    ends = np.asarray(offsets, np.int64).reshape(-1)
    if starts is None:
        starts = np.concatenate([[0], ends[:-1]]) if len(ends) else ends
    starts = np.asarray(starts, np.int64).reshape(-1)
    if len(ends) and (np.any(ends < starts) or np.any(ends > len(conn)) or np.any(starts < 0)):
        raise ModelFileError(path, f"{what}: offsets are not increasing within the "
                                   f"{len(conn)} connectivity entries")
    n = np.maximum(ends - starts - 2, 0)
    strip = np.repeat(np.arange(len(n)), n)
    local = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    i = starts[strip] + local
    even = local % 2 == 0
    tri = np.column_stack([np.where(even, conn[i], conn[i + 1]),
                           np.where(even, conn[i + 1], conn[i]), conn[i + 2]])
    return tri.reshape(-1, 3), strip


def _sized(path: Path, arrays: Dict[str, np.ndarray], n: int, where: str, noun: str):
    """``arrays``, after refusing one whose length is not ``n`` (one value per
    point or cell), naming it: VTK refuses or truncates such an array, and
    dropping it silently would lose data without a word."""
    for k, v in arrays.items():
        if len(v) != n:
            raise ModelFileError(path, f"{where}: array {k!r} has {len(v)} tuples for the {n} "
                                       f"{noun}")
    return arrays


def _check_indices(path: Path, tri: np.ndarray, src: np.ndarray, n: int, where: str) -> None:
    """Refuse a triangle whose point index is outside 0..n-1, naming the
    index and its cell (the value found, also a negative one)."""
    if not tri.size:
        return
    out = (tri < 0) | (tri >= n)
    if out.any():
        row = int(np.flatnonzero(out.any(axis=1))[0])
        v = int(tri[row][out[row]][0])
        raise ModelFileError(path, f"cell {int(src[row])} refers to point {v}; {where} has "
                                   f"{n} points (0..{n - 1})")


def read_xml(path, fmt: Optional[str] = None):
    """Read a ``.vtu`` or ``.vtp`` file into a :class:`faultmesh.Model`."""
    path = Path(path)
    return _assemble(path, *_xml_parts(path))


def _xml_parts(path: Path):
    """The pieces of a ``.vtu``/``.vtp`` file: points, triangles, point and
    cell arrays per piece, and the field data (name -> list)."""
    data = _read_bytes(path)
    x = _Xml(path, data)
    grid_type = x.root.get("type", "")
    if grid_type not in ("UnstructuredGrid", "PolyData"):
        raise ModelFileError(path, f"VTK XML type {grid_type!r}: faultmesh reads UnstructuredGrid "
                                   "(.vtu) and PolyData (.vtp)")
    grid = x.root.find(grid_type)
    if grid is None:
        raise ModelFileError(path, f"no <{grid_type}> element")
    fields: Dict[str, list] = {}
    fd = grid.find("FieldData")
    if fd is not None:
        for a in fd:
            arr = x.array(a)
            fields[a.get("Name", "")] = arr.tolist()
    pieces = grid.findall("Piece")
    if not pieces:
        raise ModelFileError(path, f"<{grid_type}> has no <Piece>")
    P, T, PA, CA = [], [], [], []
    off = 0
    for no, piece in enumerate(pieces):
        where = f"piece {no}"
        pts_el = piece.find("Points")
        if pts_el is None or pts_el.find("DataArray") is None:
            npts = _count_attr(path, piece, "NumberOfPoints", where)
            if npts:
                raise ModelFileError(path, f"{where}: a <Piece> without <Points>")
            pts = np.zeros((0, 3))
        else:
            pel = pts_el.find("DataArray")
            if pel.get("type", "") not in _NP_TYPES:
                raise ModelFileError(path, f"{where}: Points of type {pel.get('type', '')!r}, "
                                           "expected a numeric type (Float32, Float64...)")
            nc = _count_attr(path, pel, "NumberOfComponents", f"{where} Points", 1)
            if nc != 3:
                # VTK refuses such a file too (points are 3-D)
                raise ModelFileError(path, f"{where}: Points have NumberOfComponents={nc}, "
                                           "expected 3")
            pts = np.asarray(x.array(pel), np.float64).reshape(-1, 3)
        if grid_type == "UnstructuredGrid":
            cells = piece.find("Cells")
            c = _arrays(x, cells) if cells is not None else {}
            if len(pts) and not {"connectivity", "offsets", "types"} <= set(c):
                raise ModelFileError(path, "Cells: expected connectivity, offsets and types arrays")
            tri, src = _cells_from_offsets(path, c.get("connectivity", []),
                                           c.get("offsets", []), c.get("types", []), "Cells")
            n_cells = len(c.get("types", []))
        else:
            # VTK numbers the cells of a PolyData verts, lines, polys, strips
            # (whatever the order of the elements in the file); cell data
            # follows that order.
            tri_parts, src_parts = [], []
            n_cells = 0
            for tag in ("Verts", "Lines", "Polys", "Strips"):
                el = piece.find(tag)
                c = _arrays(x, el) if el is not None else {}
                cnt = _count_attr(path, piece, f"NumberOf{tag}", where)
                if cnt and not {"connectivity", "offsets"} <= set(c):
                    raise ModelFileError(path, f"{where}: NumberOf{tag}={cnt} but <{tag}> has no "
                                               "connectivity and offsets arrays")
                n_off = len(c.get("offsets", []))
                if n_off != cnt:
                    # VTK reads NumberOf<tag> cells whatever the arrays
                    # hold: a mismatch is a broken file, and the cell data
                    # would go to the wrong triangles
                    raise ModelFileError(path, f"{where}: NumberOf{tag}={cnt} but the {tag} "
                                               f"offsets array has {n_off} entries")
                if not cnt:
                    continue
                if tag in ("Verts", "Lines"):
                    # ignored, but checked as VTK would use them: offsets
                    # increasing within the connectivity, indices of points
                    conn = np.asarray(c["connectivity"]).reshape(-1)
                    ends = np.asarray(c["offsets"]).reshape(-1)
                    if np.any(np.diff(ends) < 0) or ends[0] < 0 or ends[-1] > len(conn):
                        raise ModelFileError(path, f"{where}: {tag}: offsets are not increasing "
                                                   f"within the {len(conn)} connectivity entries")
                    used = conn[:int(ends[-1])]
                    if used.size and (used.min() < 0 or used.max() >= len(pts)):
                        v = used[(used < 0) | (used >= len(pts))][0]
                        raise ModelFileError(path, f"{where}: {tag}: a cell refers to point "
                                                   f"{v}; the piece has {len(pts)} points")
                if tag in ("Polys", "Strips"):
                    t, i = (_cells_from_offsets(path, c["connectivity"], c["offsets"], None, tag)
                            if tag == "Polys" else _strips(path, c["connectivity"], c["offsets"]))
                    tri_parts.append(t)
                    src_parts.append(i + n_cells)
                n_cells += cnt
            tri = np.vstack(tri_parts) if tri_parts else np.zeros((0, 3), np.int64)
            src = np.concatenate(src_parts) if src_parts else np.zeros(0, np.int64)
        _check_indices(path, tri, src, len(pts), where if len(pieces) > 1 else "the piece")
        pa = _sized(path, _arrays(x, piece.find("PointData")), len(pts), f"{where} PointData",
                    "points")
        # each triangle takes the values of its cell (the strip it is part of)
        ca = {k: v[src] for k, v in _sized(path, _arrays(x, piece.find("CellData")), n_cells,
                                           f"{where} CellData", "cells").items()}
        P.append(pts)
        T.append(tri + off)
        PA.append(pa)
        CA.append(ca)
        off += len(pts)
    return P, T, PA, CA, fields


def read_vtm(path, fmt: Optional[str] = None):
    """Read a ``.vtm`` (VTK XML multiblock: PyVista's ``MultiBlock.save``,
    ParaView) whose blocks are ``.vtp``/``.vtu`` files, each through the XML
    reader, in the order of the file (nested blocks too). A block of one mesh
    is one surface named after its ``name`` field data (as
    :func:`faultmesh.formats.pv.to_pyvista` writes it), else the block's
    name, else its file's; ``kind``/``fault_kind`` field data give a fault
    and its type. A block that is a faultmesh merged file keeps its
    surfaces' names and kinds. A block without a file (an empty block) is
    skipped. Block files are found relative to the ``.vtm``'s folder."""
    from ..model import Model

    path = Path(path)
    x = _Xml(path, _read_bytes(path))
    if x.root.get("type") != "vtkMultiBlockDataSet":
        raise ModelFileError(path, f"VTK XML type {x.root.get('type', '')!r}: a .vtm is a "
                                   "vtkMultiBlockDataSet")
    # the MultiBlock's own field data (PyVista and VTK 9 write it)
    fd = x.root.find("FieldData")
    own = {a.get("Name", ""): x.array(a).tolist() for a in fd} if fd is not None else {}
    layers: Dict[str, object] = {}
    faults: Dict[str, object] = {}
    crs = str((own.get("crs") or [""])[0])
    counters: Dict[str, Dict[str, int]] = {"layer": {}, "fault": {}}
    cache: Dict[Tuple[int, int], tuple] = {}
    for ds in x.root.iter("DataSet"):
        rel = ds.get("file")
        if not rel:
            continue
        block = path.parent / rel
        label = ds.get("name") or block.stem
        if block.suffix.lower() not in (".vtp", ".vtu"):
            raise ModelFileError(path, f"block {label!r}: {block} is not a .vtp or .vtu file "
                                       "(faultmesh reads surface blocks)")
        try:
            st = block.stat()
        except FileNotFoundError:
            raise ModelFileError(path, f"block {label!r}: its file {block} does not exist") \
                from None
        except OSError as e:     # a name too long, a symlink loop, no permission...
            raise ModelFileError(path, f"block {label!r}: its file {block} cannot be opened "
                                       f"({e.strerror or e})") from None
        if not stat.S_ISREG(st.st_mode):
            what = "a directory" if stat.S_ISDIR(st.st_mode) else "not a regular file"
            raise ModelFileError(path, f"block {label!r}: its file {block} is {what}")
        if st.st_ino and (st.st_dev, st.st_ino) in cache:
            # the same file again (a .vtm may name one block file many times):
            # parsed once, each block its own copy
            parts = copy.deepcopy(cache[(st.st_dev, st.st_ino)])
        else:
            try:
                parts = _xml_parts(block)
            except (ModelFileError, MemoryError, KeyboardInterrupt):
                raise
            except Exception as e:  # noqa: BLE001 (name the block, not only the .vtm)
                raise ModelFileError(path, f"block {label!r}: reading its file {block} failed: "
                                           f"{type(e).__name__}: {e}") from None
            cache[(st.st_dev, st.st_ino)] = copy.deepcopy(parts)
        fields = parts[-1]
        sub = _assemble(block, *parts)
        crs = crs or sub.crs or ""
        inside = list(sub.surfaces.values()) + list(sub.faults.values())
        if "surface_names" not in fields and len(inside) == 1:
            s = inside[0]
            s.name = str((fields.get("name") or [label])[0])
            s.kind = surface_kind(str((fields.get("kind") or ["layer"])[0]))
            fk = str((fields.get("fault_kind") or [""])[0]).lower()
            if s.kind == "fault" and fk in ("normal", "reverse"):
                s.metadata["kind"] = fk
        for s in inside:
            target = faults if s.kind == "fault" else layers
            s.name = free_name(s.name, target, counters["fault" if s.kind == "fault" else "layer"])
            target[s.name] = s
    if not layers and not faults:
        raise ModelFileError(path, "no block with a file (.vtp/.vtu) in this multiblock")
    return Model(name=str((own.get("model_name") or [path.stem])[0]), surfaces=layers,
                 faults=faults, crs=crs)


def _assemble(path, P, T, PA, CA, fields):
    def common(dicts):
        keys = set(dicts[0]) if dicts else set()
        for d in dicts[1:]:
            keys &= set(d)
        return {k: np.concatenate([np.asarray(d[k]) for d in dicts]) for k in sorted(keys)}

    sizes = [len(p) for p in P]
    P = np.vstack(P) if P else np.zeros((0, 3))
    T = np.vstack(T) if T else np.zeros((0, 3), np.int64)     # indices into the stacked P
    pa = common(PA)
    P, T, pa = drop_non_finite(path, P, T, pa, sizes)
    names = fields.get("surface_names")
    kinds = fields.get("surface_kinds")
    mname = fields.get("model_name") or [""]
    crs = fields.get("crs") or [""]
    return split_merged(path, P, T, pa, common(CA),
                        [str(s) for s in names] if names else None,
                        [str(s) for s in kinds] if kinds else None,
                        str(mname[0]) if mname else "", str(crs[0]) if crs else "")


def _read_bytes(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise ModelFileError(path, "is a directory, expected a file") from None


# --------------------------------------------------------------------------
# reading: legacy (.vtk)
# --------------------------------------------------------------------------

_LEGACY_TYPES = {"bit": None, "unsigned_char": "u1", "char": "i1", "signed_char": "i1",
                 "unsigned_short": "u2", "short": "i2", "unsigned_int": "u4", "int": "i4",
                 "unsigned_long": "u8", "long": "i8", "float": "f4", "double": "f8",
                 "vtkidtype": "i4", "vtktypeint8": "i1", "vtktypeuint8": "u1",
                 "vtktypeint16": "i2", "vtktypeuint16": "u2", "vtktypeint32": "i4",
                 "vtktypeuint32": "u4", "vtktypeint64": "i8", "vtktypeuint64": "u8",
                 "vtktypefloat32": "f4", "vtktypefloat64": "f8",
                 "unsigned_long_long": "u8", "long_long": "i8"}
_PCT = re.compile(rb"%([0-9A-Fa-f]{2})")


def _pct_decode(b: bytes) -> str:
    return _PCT.sub(lambda m: bytes([int(m.group(1), 16)]), b).decode("utf-8", "replace")


class _Legacy:
    """Cursor over a legacy file: text lines (numbered) and binary blocks."""

    def __init__(self, path: Path, data: bytes) -> None:
        self.path = path
        self.data = data
        self.pos = 0
        self.line = 0
        self.binary = False
        self.version = (4, 2)

    def err(self, msg: str) -> ModelFileError:
        return ModelFileError(self.path, msg, self.line or None)

    def raw_line(self) -> Optional[bytes]:
        if self.pos >= len(self.data):
            return None
        j = self.data.find(b"\n", self.pos)
        if j < 0:
            j = len(self.data)
        s = self.data[self.pos:j]
        self.pos = j + 1
        self.line += 1
        return s.rstrip(b"\r")

    def next_line(self) -> Optional[str]:
        """The next non-blank text line."""
        while True:
            s = self.raw_line()
            if s is None:
                return None
            if s.strip():
                try:
                    return s.decode("ascii").strip()
                except UnicodeDecodeError:
                    raise self.err("expected a keyword line, found binary data (is the "
                                   "announced size of the previous block wrong?)") from None

    def numbers(self, count: int, code: str, what: str) -> np.ndarray:
        dt = np.dtype(">" + code)
        if self.binary:
            n = count * dt.itemsize
            if self.pos + n > len(self.data):
                raise self.err(f"{what}: expected {count} binary values, the file ends first")
            a = np.frombuffer(self.data[self.pos:self.pos + n], dt).astype(dt.newbyteorder("="))
            self.pos += n
            # the newline that ends a binary block
            if self.pos < len(self.data) and self.data[self.pos:self.pos + 1] == b"\n":
                self.pos += 1
            return a
        vals: List[bytes] = []
        start = self.line
        while len(vals) < count:
            s = self.raw_line()
            if s is None:
                raise self.err(f"{what}: expected {count} values from line {start + 1}, the "
                               f"file ends after {len(vals)}")
            vals += s.split()
        if len(vals) > count:
            raise self.err(f"{what}: expected {count} values, the block holds {len(vals)}")
        try:
            a = np.array(vals, dtype=np.float64)
        except ValueError:
            raise self.err(f"{what}: values are not numbers") from None
        dt = np.dtype(code)
        if dt.kind in "iu" and len(a):
            # an integer block: a fraction or a value the type cannot hold
            # (99999999999 as int) is named, not truncated or wrapped around
            info = np.iinfo(dt)
            bad = ~np.isfinite(a) | (a != np.floor(a)) | (a < info.min) | (a > info.max)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise self.err(f"{what}: value {vals[i].decode('latin-1')!r} (number {i}) is not "
                               f"an integer of type {dt.name}")
        return a.astype(code)

    def strings(self, count: int, what: str) -> List[str]:
        out: List[str] = []
        if not self.binary:
            for _ in range(count):
                s = self.raw_line()
                if s is None:
                    raise self.err(f"{what}: expected {count} strings, the file ends first")
                out.append(_pct_decode(s))
            return out
        d = self.data
        for _ in range(count):
            if self.pos >= len(d):
                raise self.err(f"{what}: expected {count} strings, the file ends first")
            top = d[self.pos] >> 6
            size = {3: 1, 2: 2, 1: 4, 0: 8}[top]
            n = int.from_bytes(d[self.pos:self.pos + size], "big") & \
                ((1 << (8 * size - 2)) - 1 if size < 8 else (1 << 64) - 1)
            self.pos += size
            if self.pos + n > len(d):
                raise self.err(f"{what}: a string runs past the end of the file")
            out.append(d[self.pos:self.pos + n].decode("utf-8", "replace"))
            self.pos += n
        if self.pos < len(d) and d[self.pos:self.pos + 1] == b"\n":
            self.pos += 1
        return out


def _ltype(r: _Legacy, t: str, what: str) -> str:
    code = _LEGACY_TYPES.get(t.lower())
    if code is None:
        raise r.err(f"{what}: data type {t!r} is not supported")
    return code


def _int_type(r: _Legacy, t: str, what: str) -> str:
    code = _ltype(r, t, what)
    if code[0] not in "iu":
        raise r.err(f"{what}: data type {t!r} is not an integer type")
    return code


def _int(r: _Legacy, tok: str, what: str) -> int:
    try:
        v = int(tok)
    except ValueError:
        raise r.err(f"{what}: expected a count, got {tok!r}") from None
    if v < 0:
        raise r.err(f"{what}: negative count {v}")
    return v


def _legacy_cells(r: _Legacy, toks: List[str], what: str) -> Tuple[np.ndarray, np.ndarray]:
    """A CELLS/POLYGONS/... block: (connectivity, end offsets)."""
    if len(toks) < 3:
        raise r.err(f"{what}: expected '{toks[0]} n size'")
    n = _int(r, toks[1], what)
    size = _int(r, toks[2], what)
    if r.version >= (5, 0):
        s = r.next_line() or ""
        p = s.split()
        if len(p) < 2 or p[0] != "OFFSETS":
            raise r.err(f"{what}: expected 'OFFSETS <type>', got {s[:40]!r}")
        offsets = r.numbers(n, _int_type(r, p[1], "OFFSETS"), "OFFSETS").astype(np.int64)
        s = r.next_line() or ""
        p = s.split()
        if len(p) < 2 or p[0] != "CONNECTIVITY":
            raise r.err(f"{what}: expected 'CONNECTIVITY <type>', got {s[:40]!r}")
        conn = r.numbers(size, _int_type(r, p[1], "CONNECTIVITY"), "CONNECTIVITY").astype(np.int64)
        if n == 0:
            return conn, np.zeros(0, np.int64)
        # version 5: n+1 offsets, the first 0 (the start of cell 0), the
        # others the end of each cell; the 0 is dropped here, never guessed
        # from the values (end offsets start with 0 after an empty first cell)
        if offsets[0] != 0:
            raise r.err(f"{what}: OFFSETS start with {int(offsets[0])}, expected 0")
        return conn, offsets[1:]
    # Before reading anything: each cell takes at least one entry (its
    # count), so a count of cells over the size announced cannot be right,
    # and a size is checked against the data by r.numbers before any array
    # is made. (A header count is never allocated or looped over as such.)
    if n > size:
        raise r.err(f"{what}: {n} cells announced in {size} entries (each cell takes at least "
                    "one, its point count)")
    flat = r.numbers(size, "i4", what).astype(np.int64)
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    k = int(flat[0]) if len(flat) else -1
    if k >= 0 and len(flat) == n * (k + 1) and np.all(flat[::k + 1] == k):
        # every cell has k points (the usual case): a reshape
        return flat.reshape(n, k + 1)[:, 1:].reshape(-1), np.arange(1, n + 1) * k
    starts = _walk_counts(flat, n)
    m = len(flat)
    c, last = len(starts), int(starts[-1])
    if c < n or last + 1 + flat[last] != m:
        # where the walk left the list: a negative count, a count past the
        # end, the list ending before n cells, or entries left after them
        if flat[last] < 0:
            raise r.err(f"{what}: cell {c - 1} has a negative point count {int(flat[last])}")
        if last + 1 + flat[last] > m:
            raise r.err(f"{what}: cell {c - 1} announces {int(flat[last])} points, past the "
                        f"end of the {size} entries")
        if c < n:
            raise r.err(f"{what}: {n} cells announced, the list ends after {c}")
        raise r.err(f"{what}: size {size} does not match the {n} cells listed")
    counts = flat[starts]
    keep = np.ones(len(flat), bool)
    keep[starts] = False
    return flat[keep], np.cumsum(counts)


def _walk_counts(flat: np.ndarray, n: int) -> np.ndarray:
    """The start of each of the first ``n`` cells of a legacy cell list
    (each cell its point count, then the points): the walk 0, 1 + flat[0],
    ... (:func:`walk_starts`). Stops early (fewer than ``n`` starts) at a
    negative count or one running past the end; the last start returned is
    then the cell at fault."""
    m = len(flat)
    nxt = np.arange(m, dtype=np.int64) + 1 + flat
    # m marks "no next cell": a bad count, or the end of the list
    nxt[(flat < 0) | (nxt >= m)] = m
    return walk_starts(nxt, n)


def _legacy_attributes(r: _Legacy, count: int, out: Dict[str, np.ndarray]) -> Optional[str]:
    """Attribute sections after POINT_DATA/CELL_DATA; returns the keyword line
    that ends them (another section) or None at the end of the file."""
    while True:
        s = r.next_line()
        if s is None:
            return None
        p = s.split()
        key = p[0].upper()
        if key in ("POINT_DATA", "CELL_DATA"):
            return s
        if key == "SCALARS":
            if len(p) < 3:
                raise r.err(f"SCALARS: expected 'SCALARS name type [components]', got {s!r}")
            nc = _int(r, p[3], "SCALARS") if len(p) > 3 else 1
            code = _ltype(r, p[2], "SCALARS")
            s2 = r.next_line() or ""
            if not s2.upper().startswith("LOOKUP_TABLE"):
                raise r.err(f"SCALARS {p[1]}: expected LOOKUP_TABLE, got {s2[:40]!r}")
            a = r.numbers(count * nc, code, f"SCALARS {p[1]}")
            out[_pct_decode(p[1].encode())] = a.reshape(count, nc) if nc > 1 else a
        elif key == "LOOKUP_TABLE":
            n = _int(r, p[2] if len(p) > 2 else "", "LOOKUP_TABLE")
            r.numbers(4 * n, "u1" if r.binary else "f4", "LOOKUP_TABLE")
        elif key == "COLOR_SCALARS":
            nc = _int(r, p[2] if len(p) > 2 else "", "COLOR_SCALARS")
            r.numbers(count * nc, "u1" if r.binary else "f4", "COLOR_SCALARS")
        elif key in ("VECTORS", "NORMALS"):
            if len(p) < 3:
                raise r.err(f"{key}: expected '{key} name type', got {s!r}")
            out[_pct_decode(p[1].encode())] = r.numbers(
                3 * count, _ltype(r, p[2], key), key).reshape(count, 3)
        elif key == "TEXTURE_COORDINATES":
            if len(p) < 4:
                raise r.err(f"{key}: expected '{key} name dim type', got {s!r}")
            d = _int(r, p[2], key)
            r.numbers(d * count, _ltype(r, p[3], key), key)
        elif key == "TENSORS" or key == "TENSORS6":
            if len(p) < 3:
                raise r.err(f"{key}: expected '{key} name type', got {s!r}")
            r.numbers((9 if key == "TENSORS" else 6) * count, _ltype(r, p[2], key), key)
        elif key in ("GLOBAL_IDS", "PEDIGREE_IDS"):
            if len(p) < 3:
                raise r.err(f"{key}: expected '{key} name type', got {s!r}")
            r.numbers(count, _ltype(r, p[2], key), key)
        elif key == "FIELD":
            _legacy_field_arrays(r, p, out)
        elif key == "METADATA":
            _skip_metadata(r)
        else:
            raise r.err(f"unknown keyword {p[0]!r} in the point/cell data")


def _skip_metadata(r: _Legacy) -> None:
    """METADATA blocks (VTK 9 writes them after arrays) end at a blank line."""
    while True:
        s = r.raw_line()
        if s is None or not s.strip():
            return


def _legacy_field_arrays(r: _Legacy, p: List[str], out: Dict[str, object]) -> None:
    if len(p) < 3:
        raise r.err("FIELD: expected 'FIELD name n_arrays'")
    n = _int(r, p[2], "FIELD")
    for _ in range(n):
        s = r.next_line()
        if s is None:
            raise r.err(f"FIELD: {n} arrays announced, the file ends first")
        q = s.split()
        if q[0].upper() == "METADATA":
            _skip_metadata(r)
            s = r.next_line()
            if s is None:
                raise r.err(f"FIELD: {n} arrays announced, the file ends first")
            q = s.split()
        if len(q) < 4:
            raise r.err(f"FIELD array: expected 'name components tuples type', got {s[:60]!r}")
        name = _pct_decode(q[0].encode())
        nc, nt = _int(r, q[1], "FIELD array"), _int(r, q[2], "FIELD array")
        if q[3].lower() in ("string", "utf8_string"):
            out[name] = r.strings(nc * nt, f"FIELD array {name}")
            continue
        a = r.numbers(nc * nt, _ltype(r, q[3], f"FIELD array {name}"), f"FIELD array {name}")
        out[name] = a.reshape(nt, nc) if nc > 1 else a


def read_legacy(path, fmt: Optional[str] = None):
    """Read a legacy ``.vtk`` file (POLYDATA or UNSTRUCTURED_GRID) into a Model."""
    path = Path(path)
    r = _Legacy(path, _read_bytes(path))
    head = r.raw_line()
    if head is None or not head.lower().startswith(b"# vtk datafile version"):
        raise r.err("not a legacy VTK file: expected '# vtk DataFile Version x.y' on line 1")
    m = re.search(rb"(\d+)\.(\d+)", head)
    r.version = (int(m.group(1)), int(m.group(2))) if m else (2, 0)
    title = r.raw_line()
    if title is None:
        raise r.err("unexpected end of file after the header")
    mode = (r.next_line() or "").upper()
    if mode not in ("ASCII", "BINARY"):
        raise r.err(f"expected ASCII or BINARY, got {mode[:40]!r}")
    r.binary = mode == "BINARY"
    s = r.next_line() or ""
    p = s.split()
    if len(p) < 2 or p[0].upper() != "DATASET":
        raise r.err(f"expected 'DATASET <type>', got {s[:40]!r}")
    dtype = p[1].upper()
    if dtype not in ("POLYDATA", "UNSTRUCTURED_GRID"):
        raise r.err(f"DATASET {p[1]}: faultmesh reads POLYDATA and UNSTRUCTURED_GRID")
    fields: Dict[str, object] = {}
    pts = None
    # PolyData cells by kind: (triangles, index of the cell within its kind, count)
    poly_cells: Dict[str, List[Tuple[np.ndarray, np.ndarray, int]]] = {}
    types = None
    ucells = None
    pa: Dict[str, np.ndarray] = {}
    ca: Dict[str, np.ndarray] = {}
    s = r.next_line()
    while s is not None:
        p = s.split()
        key = p[0].upper()
        if key == "FIELD":
            _legacy_field_arrays(r, p, fields)
        elif key == "METADATA":
            _skip_metadata(r)
        elif key == "POINTS":
            if len(p) < 3:
                raise r.err("POINTS: expected 'POINTS n type'")
            n = _int(r, p[1], "POINTS")
            pts = r.numbers(3 * n, _ltype(r, p[2], "POINTS"), "POINTS").astype(np.float64)
            pts = pts.reshape(n, 3)
        elif key in ("VERTICES", "LINES", "POLYGONS", "TRIANGLE_STRIPS") and dtype == "POLYDATA":
            conn, ends = _legacy_cells(r, p, key)
            if key == "POLYGONS":
                tri, src = _cells_from_offsets(path, conn, ends, None, key)
            elif key == "TRIANGLE_STRIPS":
                tri, src = _strips(path, conn, ends)
            else:
                tri, src = np.zeros((0, 3), np.int64), np.zeros(0, np.int64)
            # a second block of one kind replaces the first, as in VTK's reader
            poly_cells[key] = [(tri, src, len(ends))]
        elif key == "CELLS" and dtype == "UNSTRUCTURED_GRID":
            ucells = _legacy_cells(r, p, key)
        elif key == "CELL_TYPES":
            n = _int(r, p[1] if len(p) > 1 else "", "CELL_TYPES")
            types = r.numbers(n, "i4", "CELL_TYPES").astype(np.int64)
        elif key in ("POINT_DATA", "CELL_DATA"):
            n = _int(r, p[1] if len(p) > 1 else "", key)
            target = pa if key == "POINT_DATA" else ca
            tmp: Dict[str, object] = {}
            s = _legacy_attributes(r, n, tmp)
            for k, v in tmp.items():
                if isinstance(v, np.ndarray) and len(v) == n:
                    target[k] = v
            continue
        else:
            raise r.err(f"unknown keyword {p[0]!r}")
        s = r.next_line()
    if pts is None:
        raise r.err("no POINTS in this file")
    tri, src = np.zeros((0, 3), np.int64), np.zeros(0, np.int64)
    if dtype == "UNSTRUCTURED_GRID":
        n_cells = 0 if ucells is None else len(ucells[1])
        if ucells is not None:
            if types is None:
                raise r.err("CELLS without CELL_TYPES")
            tri, src = _cells_from_offsets(path, ucells[0], ucells[1], types, "CELLS")
    else:
        # VTK numbers the cells verts, lines, polys, strips, whatever the
        # order of the blocks in the file; CELL_DATA follows that order.
        tris, srcs, n_cells = [], [], 0
        for key in ("VERTICES", "LINES", "POLYGONS", "TRIANGLE_STRIPS"):
            for t, i, n in poly_cells.get(key, []):
                tris.append(t)
                srcs.append(i + n_cells)
                n_cells += n
        if tris:
            tri, src = np.vstack(tris), np.concatenate(srcs)
    _check_indices(path, tri, src, len(pts), "the file")
    # each triangle takes the values of its cell (the strip it is part of)
    ca = {k: v[src] for k, v in ca.items() if len(v) == n_cells}
    sfields = {k: v for k, v in fields.items() if isinstance(v, list)}
    return _assemble(path, [pts], [tri], [pa], [ca], sfields)


def read(path, fmt: str = "vtu"):
    """Read ``path`` as ``fmt`` (``vtu``/``vtp``: XML, ``vtk``: legacy)."""
    return read_legacy(path) if fmt == "vtk" else read_xml(path)
