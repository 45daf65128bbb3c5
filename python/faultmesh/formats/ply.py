"""Stanford ``.ply``, written (binary little-endian) and read (ascii or binary)
by faultmesh. One mesh holding every surface: viewers (MeshLab, CloudCompare,
ParaView) show it as one object; the ``surface_id`` vertex property and the
``comment faultmesh_surface <id> <kind> <name>`` header lines let faultmesh
read the surfaces back with their names and kinds. For one object per surface
in a viewer use ``.obj``, ``.vtu`` or a folder (one ``.ply`` per surface).
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np

from ._common import AtomicFiles, Merged, ModelFileError, _Shared, split_merged

SUFFIXES = (".ply",)


def _one_line(s: str) -> str:
    return " ".join(str(s).split())


def ply_bytes(model) -> bytes:
    m = Merged.of(model)
    n, k = len(m.points), len(m.triangles)
    head = ["ply", "format binary_little_endian 1.0",
            "comment faultmesh multi-layer model: surface_id = position in the model "
            "(layers top to bottom, then faults)",
            f"comment faultmesh_model {_one_line(m.name)}"]
    if m.crs:
        head.append(f"comment faultmesh_crs {_one_line(m.crs)}")
    head += [f"comment faultmesh_surface {i} {kind} {_one_line(name)}"
             for i, (name, kind) in enumerate(zip(m.names, m.kinds))]
    head += [f"element vertex {n}", "property double x", "property double y", "property double z",
             "property int surface_id", f"element face {k}",
             "property list uchar int vertex_indices", "end_header"]
    vdt = np.dtype([("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("s", "<i4")])
    v = np.empty(n, vdt)
    v["x"], v["y"], v["z"] = m.points[:, 0], m.points[:, 1], m.points[:, 2]
    v["s"] = m.point_arrays["surface_id"]
    fdt = np.dtype([("n", "u1"), ("i", "<i4", (3,))])
    f = np.empty(k, fdt)
    f["n"] = 3
    f["i"] = m.triangles
    return ("\n".join(head) + "\n").encode("utf-8") + v.tobytes() + f.tobytes()


def write(model, path, fmt: str = "ply", files: Optional[AtomicFiles] = None) -> Path:
    path = Path(path)
    data = ply_bytes(model)
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        f.open(path, "wb").write(data)
    return path


_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2",
              "int16": "i2", "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4",
              "uint": "u4", "uint32": "u4", "float": "f4", "float32": "f4", "double": "f8",
              "float64": "f8"}


class _Element:
    def __init__(self, name: str, count: int) -> None:
        self.name = name
        self.count = count
        self.props: list = []        # (name, type) or (name, ("list", count_type, item_type))


def _parse_header(path: Path, data: bytes):
    """The PLY header: format, elements, faultmesh comments, data offset. A
    header that never ends (a truncated file) is an error, not a hang."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise ModelFileError(path, "not a PLY file (no 'ply' ... 'end_header' header)"
                             if not data.startswith(b"ply") else
                             "the PLY header has no end_header (truncated file?)")
    nl = data.find(b"\n", end)
    body = nl + 1 if nl >= 0 else len(data)
    fmt, elements, comments = None, [], []
    for no, raw in enumerate(data[:end].split(b"\n"), start=1):
        s = raw.decode("utf-8", "replace").strip()
        p = s.split()
        if not p or p[0] in ("ply", "obj_info"):
            continue
        if p[0] == "comment":
            comments.append(s[len("comment"):].strip())
        elif p[0] == "format":
            if len(p) < 2 or p[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise ModelFileError(path, f"unknown PLY format {s!r}", no)
            fmt = p[1]
        elif p[0] == "element":
            try:
                elements.append(_Element(p[1], int(p[2])))
            except (IndexError, ValueError):
                raise ModelFileError(path, f"bad element line {s!r}", no) from None
            if elements[-1].count < 0:
                raise ModelFileError(path, f"negative element count in {s!r}", no)
        elif p[0] == "property":
            if not elements:
                raise ModelFileError(path, "a property before any element", no)
            if len(p) >= 5 and p[1] == "list" and p[2] in _PLY_TYPES and p[3] in _PLY_TYPES:
                elements[-1].props.append((p[4], ("list", p[2], p[3])))
            elif len(p) >= 3 and p[1] in _PLY_TYPES:
                elements[-1].props.append((p[2], p[1]))
            else:
                raise ModelFileError(path, f"bad property line {s!r}", no)
    if fmt is None:
        raise ModelFileError(path, "the PLY header has no format line")
    return fmt, elements, comments, body


def _faultmesh_comments(comments):
    names, kinds, model_name, crs = {}, {}, "", ""
    for c in comments:
        p = c.split(None, 1)
        if not p:
            continue
        if p[0] == "faultmesh_model":
            model_name = p[1].strip() if len(p) > 1 else ""
        elif p[0] == "faultmesh_crs":
            crs = p[1].strip() if len(p) > 1 else ""
        elif p[0] == "faultmesh_surface" and len(p) > 1:
            q = p[1].split(None, 2)
            if len(q) >= 2 and q[0].isdigit():
                names[int(q[0])] = q[2] if len(q) > 2 else f"surface_{q[0]}"
                kinds[int(q[0])] = q[1]
    if names and sorted(names) == list(range(len(names))):
        return [names[i] for i in range(len(names))], [kinds[i] for i in range(len(names))], \
            model_name, crs
    return None, None, model_name, crs


def _read_binary(path, data, pos, el, order):
    """One element of a binary PLY: a structured read when its lists are all
    triangles (the usual case)."""
    fields = []
    for name, t in el.props:
        if isinstance(t, tuple):
            fields += [(f"{name}__n", order + _PLY_TYPES[t[1]]), (name, order + _PLY_TYPES[t[2]], (3,))]
        else:
            fields.append((name, order + _PLY_TYPES[t]))
    dt = np.dtype(fields)
    n = el.count * dt.itemsize
    if pos + n > len(data):
        raise ModelFileError(path, f"the {el.name} element announces {el.count} records, the "
                                   "file ends first (truncated?)")
    rec = np.frombuffer(data[pos:pos + n], dt)
    for name, t in el.props:
        if isinstance(t, tuple) and el.count and np.any(rec[f"{name}__n"] != 3):
            raise ModelFileError(path, f"{el.name} {name}: a list with other than 3 entries "
                                       "(faultmesh reads triangle meshes; triangulate first)")
    return rec, pos + n


def _read_ascii(path, tokens, pos, el):
    width = 0
    for name, t in el.props:
        width += 4 if isinstance(t, tuple) else 1
    need = el.count * width
    if pos + need > len(tokens):
        raise ModelFileError(path, f"the {el.name} element announces {el.count} records, the "
                                   "file ends first (or a list has other than 3 entries)")
    try:
        a = np.array(tokens[pos:pos + need], dtype=np.float64).reshape(el.count, width)
    except ValueError:
        raise ModelFileError(path, f"the {el.name} element holds values that are not "
                                   "numbers") from None
    out, c = {}, 0
    for name, t in el.props:
        if isinstance(t, tuple):
            if el.count and np.any(a[:, c] != 3):
                raise ModelFileError(path, f"{el.name} {name}: a list with other than 3 entries "
                                           "(faultmesh reads triangle meshes; triangulate first)")
            out[name] = a[:, c + 1:c + 4]
            c += 4
        else:
            out[name] = a[:, c]
            c += 1
    return out, pos + need


def read(path, fmt: str = "ply"):
    """Read a PLY file (ascii or binary) holding vertices and triangle faces."""
    from .vtk import _read_bytes

    path = Path(path)
    data = _read_bytes(path)
    fmt_, elements, comments, pos = _parse_header(path, data)
    verts = faces = None
    tokens = data[pos:].split() if fmt_ == "ascii" else None
    tpos = 0
    order = "<" if fmt_ == "binary_little_endian" else ">"
    for el in elements:
        if fmt_ == "ascii":
            rec, tpos = _read_ascii(path, tokens, tpos, el)
            get = rec.get
        else:
            rec, pos = _read_binary(path, data, pos, el, order)
            get = (lambda r: (lambda k: r[k] if k in r.dtype.names else None))(rec)
        if el.name == "vertex":
            xyz = [get(c) for c in ("x", "y", "z")]
            if any(v is None for v in xyz[:2]):
                raise ModelFileError(path, "the vertex element has no x and y properties")
            z = xyz[2] if xyz[2] is not None else np.zeros(el.count)
            verts = (np.column_stack([np.asarray(xyz[0], np.float64), np.asarray(xyz[1], np.float64),
                                      np.asarray(z, np.float64)]),
                     {name: np.asarray(get(name)) for name, t in el.props
                      if name not in ("x", "y", "z") and not isinstance(t, tuple)})
        elif el.name == "face":
            lists = [name for name, t in el.props if isinstance(t, tuple)]
            if not lists:
                raise ModelFileError(path, "the face element has no vertex index list")
            key = "vertex_indices" if "vertex_indices" in lists else \
                ("vertex_index" if "vertex_index" in lists else lists[0])
            faces = np.asarray(get(key), np.int64).reshape(-1, 3)
    if verts is None:
        raise ModelFileError(path, "no vertex element in this PLY file")
    P, pa = verts
    T = faces if faces is not None else np.zeros((0, 3), np.int64)
    names, kinds, model_name, crs = _faultmesh_comments(comments)
    return split_merged(path, P, T, pa, {}, names, kinds, model_name, crs)
