"""Stanford ``.ply``, written (binary little-endian) and read (ascii or binary)
by faultmesh. One mesh holding every surface: viewers (MeshLab, CloudCompare,
ParaView) show it as one object; the ``surface_id`` vertex property and the
``comment faultmesh_surface <id> <kind> <name>`` header lines let faultmesh
read the surfaces back with their names and kinds. For one object per surface
in a viewer use ``.obj``, ``.vtu`` or a folder (one ``.ply`` per surface).

Read: the spec's types and their aliases, and ``int64``/``uint64`` (Open3D,
trimesh, plyfile write them); faces of fewer than 3 vertices (points, lines)
are ignored, and faces of more are refused naming the first, as the VTK
reader treats cells. The header ends at a line that is exactly
``end_header``; the indices are ``vertex_indices``/``vertex_index`` or the
face element's only integer list; a fractional or out-of-range index, a
non-finite vertex a face uses, and data left after the last element are
errors naming what is wrong (docs/formats.md).
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Optional

import numpy as np

from ._common import (AtomicFiles, Merged, ModelFileError, _Shared, drop_non_finite, split_merged,
                      walk_starts)

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
              "float64": "f8",
              # not in the PLY spec, written by Open3D, trimesh, plyfile and others
              "int64": "i8", "uint64": "u8"}


# a line holding only end_header; the data start after its newline
_END_HEADER = re.compile(rb"(?:^|\n)[ \t\r]*(end_header)[ \t\r]*(?:\n|\Z)")


class _Element:
    def __init__(self, name: str, count: int) -> None:
        self.name = name
        self.count = count
        self.props: list = []        # (name, type) or (name, ("list", count_type, item_type))


def _parse_header(path: Path, data: bytes):
    """The PLY header: format, elements, faultmesh comments, data offset. A
    header that never ends (a truncated file) is an error, not a hang. The
    header ends at the first line that is ``end_header`` and nothing else
    (white space and a CR aside): the text inside a comment, an element or
    a property name does not end it."""
    m = _END_HEADER.search(data)
    if not data.startswith(b"ply") or m is None:
        raise ModelFileError(path, "not a PLY file (no 'ply' ... 'end_header' header)"
                             if not data.startswith(b"ply") else
                             "the PLY header has no end_header line (truncated file?)")
    end = m.start(1)
    body = m.end()
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
                prop = (p[4], ("list", p[2], p[3]))
            elif len(p) >= 3 and p[1] in _PLY_TYPES:
                prop = (p[2], p[1])
            else:
                raise ModelFileError(path, f"bad property line {s!r}", no)
            if prop[0] in (name for name, _ in elements[-1].props):
                raise ModelFileError(path, f"the {elements[-1].name} element has two properties "
                                           f"named {prop[0]!r}", no)
            elements[-1].props.append(prop)
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


def _shape_at(path, el, data, tokens, pos, order):
    """The lengths of the lists of the record at ``pos`` (a byte offset in
    ``data`` for binary, a token index in ``tokens`` for ascii)."""
    shape = []
    for name, t in el.props:
        if tokens is None:
            if not isinstance(t, tuple):
                pos += np.dtype(_PLY_TYPES[t]).itemsize
                continue
            dt = np.dtype(order + _PLY_TYPES[t[1]])
            if pos + dt.itemsize > len(data):
                raise ModelFileError(path, f"the {el.name} element announces {el.count} "
                                           "records, the file ends first (truncated?)")
            raw = np.frombuffer(data, dt, 1, pos)[0]
            if dt.kind in "iu":
                n = int(raw)          # exact, also a uint64 near 2^64
            else:
                v = float(raw)
                n = int(v) if np.isfinite(v) and v == int(v) else -1
            pos += dt.itemsize + max(n, 0) * np.dtype(_PLY_TYPES[t[2]]).itemsize
        else:
            if not isinstance(t, tuple):
                pos += 1
                continue
            if pos >= len(tokens):
                raise ModelFileError(path, f"the {el.name} element announces {el.count} "
                                           "records, the file ends first")
            try:
                n = int(tokens[pos])      # exact, also 2^64 - 1
            except ValueError:
                try:
                    v = float(tokens[pos])
                except ValueError:
                    raise ModelFileError(path, f"{el.name} {name}: a list length "
                                               f"{tokens[pos].decode('latin-1')!r} is not a "
                                               "number") from None
                n = int(v) if np.isfinite(v) and v == int(v) else -1
            pos += 1 + max(n, 0)
        if n < 0:
            raise ModelFileError(path, f"{el.name} {name}: a list of negative or fractional "
                                       "length")
        if pos > (len(data) if tokens is None else len(tokens)):
            raise ModelFileError(path, f"the {el.name} element announces {el.count} records, "
                                       f"the file ends first (a list of {n} entries)")
        shape.append(n)
    return shape


def _read_element(path, el, data, tokens, pos, order):
    """One element (``tokens`` is None for binary data, else the ascii body's
    tokens): ({scalar property: (count,) array}, {list property: (lengths,
    values one list after the other)}, position after it).

    Read in runs of records of one shape (the lengths of their lists): within
    a run the records have one size and are read at once, a structured view
    of the binary data or a reshape of the ascii numbers, in windows that
    double until a record of another shape starts the next run. A triangle
    mesh is one run; one with a few other faces a few more."""
    scal = {name: [] for name, t in el.props if not isinstance(t, tuple)}
    lists = {name: ([], []) for name, t in el.props if isinstance(t, tuple)}
    if not el.props:
        return scal, lists, pos
    done = 0
    while done < el.count:
        shape = _shape_at(path, el, data, tokens, pos, order)
        # binary: the record's dtype (fields by position: n<i> the length of
        # list i, p<i> property i); ascii: the columns of the list lengths
        fields, cols, c, it = [], [], 0, iter(shape)
        for i, (name, t) in enumerate(el.props):
            if isinstance(t, tuple):
                n = next(it)
                fields += [(f"n{i}", order + _PLY_TYPES[t[1]]),
                           (f"p{i}", order + _PLY_TYPES[t[2]], (n,))]
                cols.append(c)
                c += 1 + n
            else:
                fields.append((f"p{i}", order + _PLY_TYPES[t]))
                c += 1
        dt, width = np.dtype(fields), c
        size = dt.itemsize if tokens is None else width
        chunks, r, w = [], 0, 64
        while done + r < el.count:
            want = min(w, el.count - done - r)
            a = pos + r * size
            if tokens is None:
                k = max(0, min(want, (len(data) - a) // size))
                chunk = np.frombuffer(data, dt, k, a)
                counts = [chunk[f"n{i}"] for i, (_, t) in enumerate(el.props)
                          if isinstance(t, tuple)]
            else:
                k = max(0, min(want, (len(tokens) - a) // width))
                try:
                    chunk = np.array(tokens[a:a + k * width], np.float64).reshape(k, width)
                except ValueError:
                    raise ModelFileError(path, f"the {el.name} element holds values that are "
                                               "not numbers") from None
                counts = [chunk[:, j] for j in cols]
            ok = np.ones(k, bool)
            for cnt, n in zip(counts, shape):
                ok &= cnt == n
            good = int(np.argmin(ok)) if not ok.all() else k
            chunks.append(chunk[:good])
            r += good
            if good < want:       # a record of another shape, or the end of the data
                break
            w *= 2
        if not r:
            raise ModelFileError(path, f"the {el.name} element announces {el.count} records, "
                                       "the file ends first (truncated?)")
        run = np.frombuffer(data, dt, r, pos) if tokens is None else \
            (chunks[0] if len(chunks) == 1 else np.concatenate(chunks))
        c, it = 0, iter(shape)
        for i, (name, t) in enumerate(el.props):
            if tokens is None:
                col = run[f"p{i}"]
                col = col.astype(col.dtype.newbyteorder("="), copy=False)
            if isinstance(t, tuple):
                n = next(it)
                vals = col if tokens is None else run[:, c + 1:c + 1 + n]
                lists[name][0].append(np.full(r, n, np.int64))
                lists[name][1].append(vals.reshape(-1))
                c += 1 + n
            else:
                scal[name].append(col if tokens is None else run[:, c])
                c += 1
        pos += r * size
        done += r
        if done < el.count and len(lists) == 1:
            # a record of another size: walk the rest (one list property)
            s2, l2, pos = _walk_element(path, el, data, tokens, pos, order, el.count - done)
            for k, v in s2.items():
                scal[k].append(v)
            for k, (ln, vals) in l2.items():
                lists[k][0].extend(ln)
                lists[k][1].extend(vals)
            done = el.count

    def cat(parts, dtype=np.float64):
        return parts[0] if len(parts) == 1 else np.concatenate(parts) if parts else \
            np.zeros(0, dtype)

    return ({k: cat(v) for k, v in scal.items()},
            {k: (cat(v[0], np.int64), cat(v[1])) for k, v in lists.items()}, pos)


def _walk_element(path, el, data, tokens, pos, order, count):
    """The next ``count`` records of an element with one list property (a
    face element of mixed sizes), found by a walk over the records
    (:func:`walk_starts`, log2(count) vectorised passes): the list length at
    every place a record could start says where the next would, and the
    walk from ``pos`` picks the records out. Returns what
    :func:`_read_element` does. The run-by-run read took a Python step per
    run: 200,000 faces alternating triangle and line, 9.8 s."""
    li = next(i for i, (_, t) in enumerate(el.props) if isinstance(t, tuple))
    lname, (_, tc, ti) = el.props[li]
    before, after = el.props[:li], el.props[li + 1:]
    binary = tokens is None
    if binary:
        size = [np.dtype(_PLY_TYPES[t]).itemsize for _, t in el.props[:li]], \
            [np.dtype(_PLY_TYPES[t]).itemsize for _, t in after]
        dc, di = np.dtype(order + _PLY_TYPES[tc]), np.dtype(order + _PLY_TYPES[ti])
        raw = np.frombuffer(data, np.uint8, len(data) - pos, pos)
        head, step = dc.itemsize, di.itemsize
    else:
        size = [1] * len(before), [1] * len(after)
        try:
            raw = np.array(tokens[pos:], np.float64)
        except ValueError:
            raise ModelFileError(path, f"the {el.name} element holds values that are not "
                                       "numbers") from None
        head, step = 1, 1
    a, b, total = sum(size[0]), sum(size[1]), len(raw)
    m = total - a - head + 1          # places with a whole list length after them
    if m <= 0:
        raise ModelFileError(path, f"the {el.name} element announces {el.count} records, the "
                                   "file ends first (truncated?)")
    if binary:
        cnt = np.ascontiguousarray(np.lib.stride_tricks.sliding_window_view(raw[a:], head))
        cnt = cnt.view(dc).reshape(-1)[:m]
    else:
        cnt = raw[a:a + m]
    ok = np.isfinite(cnt) & (cnt >= 0) & (cnt <= total) & (cnt == np.floor(cnt)) \
        if cnt.dtype.kind == "f" else (cnt >= 0) & (cnt <= total)
    n = np.where(ok, cnt, 0).astype(np.int64)
    ends = np.arange(m, dtype=np.int64) + a + head + n * step + b
    nxt = np.where(ok & (ends <= total), ends, m)
    starts = walk_starts(nxt, count)
    last = int(starts[-1]) if len(starts) else 0
    if len(starts) < count or not ok[last] or ends[last] > total:
        k = len(starts) - 1
        if not ok[last]:
            raise ModelFileError(path, f"{el.name} {lname}: record {k} has a list of negative, "
                                       f"fractional or impossible length ({cnt[last].item()!r})")
        raise ModelFileError(path, f"the {el.name} element announces {el.count} records, the "
                                   f"file ends first (after {k} of the records walked here)")
    counts = n[starts]

    def take(at, width, dt):
        # values of type dt at the places ``at`` (bytes, or tokens)
        if not binary:
            return raw[at]
        return np.ascontiguousarray(raw[at[:, None] + np.arange(width)]).view(dt).reshape(-1) \
            .astype(dt.newbyteorder("="), copy=False)

    scal, lists = {}, {}
    off = 0
    for (name, t), w in zip(before, size[0]):
        scal[name] = take(starts + off, w, np.dtype(order + _PLY_TYPES[t]))
        off += w
    first = np.repeat(starts + a + head, counts)
    within = np.arange(int(counts.sum()), dtype=np.int64) - np.repeat(np.cumsum(counts) - counts,
                                                                      counts)
    lists[lname] = ([counts], [take(first + within * step, step, np.dtype(order + _PLY_TYPES[ti]))])
    off = 0
    for (name, t), w in zip(after, size[1]):
        scal[name] = take(starts + a + head + counts * step + off, w,
                          np.dtype(order + _PLY_TYPES[t]))
        off += w
    return scal, lists, pos + int(ends[last])


def _face_list(path, el, lists):
    """The face element's index list: ``vertex_indices`` (the spec's name)
    or ``vertex_index``, else its only list of an integer type; else an
    error naming the lists found (a list of float texture coordinates is no
    index list)."""
    for key in ("vertex_indices", "vertex_index"):
        if key in lists:
            return key
    types = {name: t for name, t in el.props if isinstance(t, tuple)}
    ints = [name for name, t in types.items() if np.dtype(_PLY_TYPES[t[2]]).kind in "iu"]
    if len(ints) == 1:
        return ints[0]
    found = ", ".join(f"{name} ({t[2]})" for name, t in types.items()) or "none"
    raise ModelFileError(path, f"the {el.name} element has no vertex_indices list and "
                               f"{'no' if not ints else 'more than one'} integer list to take "
                               f"for it (lists: {found})")


def _check_face_indices(path, idx: np.ndarray, sizes: np.ndarray, n_vertices: int) -> np.ndarray:
    """The index values as int64, after refusing a fractional one (ascii
    values are read as float64; a float index list may be declared) or one
    outside the vertices, naming the face and the value."""
    idx = np.asarray(idx)
    if idx.dtype.kind == "f":
        bad = ~np.isfinite(idx) | (idx != np.floor(idx))
        if bad.any():
            j = int(np.flatnonzero(bad)[0])
            face = int(np.searchsorted(np.cumsum(sizes), j, side="right"))
            raise ModelFileError(path, f"face {face}: vertex index {float(idx[j])!r} is not an "
                                       "integer")
    out = (idx < 0) | (idx >= n_vertices)
    if out.any():
        j = int(np.flatnonzero(out)[0])
        face = int(np.searchsorted(np.cumsum(sizes), j, side="right"))
        v = idx[j].item()
        raise ModelFileError(path, f"face {face}: vertex index {int(v) if v == int(v) else v} "
                                   f"is outside the {n_vertices} vertices (0..{n_vertices - 1})")
    return idx.astype(np.int64)


# A binary file may end with a few bytes after the last element: some
# writers add a newline (or pad with NULs). More than that, or anything
# else, means the header's counts do not describe the data.
_BINARY_TAIL_OK = 8


def _check_rest(path, data: bytes, tokens, pos: int) -> None:
    """PLY allows nothing after the last element. ascii: white space only
    (the tokens hold none); binary: at most a few NUL/newline bytes. More
    means a count of the header is wrong (e.g. a vertex count too large
    reads the first face as a vertex): refused, naming what is left."""
    if tokens is not None:
        if pos < len(tokens):
            raise ModelFileError(path, f"{len(tokens) - pos} value(s) left after the last element "
                                       f"(the header's element counts do not match the data)")
        return
    rest = data[pos:]
    if len(rest) > _BINARY_TAIL_OK or rest.strip(b"\0\r\n"):
        raise ModelFileError(path, f"{len(rest)} byte(s) left after the last element (the "
                                   "header's element counts or types do not match the data)")


def read(path, fmt: str = "ply"):
    """Read a PLY file (ascii or binary) holding vertices and triangle faces.
    Faces of fewer than 3 vertices (points, lines) are ignored and faces of
    more are refused naming the first, as the VTK reader does with cells."""
    from .vtk import _cells_from_offsets, _read_bytes

    path = Path(path)
    data = _read_bytes(path)
    fmt_, elements, comments, pos = _parse_header(path, data)
    verts = face_lists = None
    tokens = data[pos:].split() if fmt_ == "ascii" else None
    if tokens is not None:
        pos = 0
    order = "<" if fmt_ == "binary_little_endian" else ">"
    for el in elements:
        scal, lists, pos = _read_element(path, el, data, tokens, pos, order)
        if el.name == "vertex":
            if "x" not in scal or "y" not in scal:
                raise ModelFileError(path, "the vertex element has no x and y properties")
            z = scal["z"] if "z" in scal else np.zeros(el.count)
            verts = (np.column_stack([np.asarray(scal["x"], np.float64),
                                      np.asarray(scal["y"], np.float64),
                                      np.asarray(z, np.float64)]),
                     {k: v for k, v in scal.items() if k not in ("x", "y", "z")})
        elif el.name == "face":
            if not lists:
                raise ModelFileError(path, "the face element has no vertex index list")
            key = _face_list(path, el, lists)
            face_lists = (key, lists[key])
    _check_rest(path, data, tokens, pos)
    if verts is None:
        raise ModelFileError(path, "no vertex element in this PLY file")
    P, pa = verts
    T = np.zeros((0, 3), np.int64)
    if face_lists is not None:
        key, (sizes, idx) = face_lists
        idx = _check_face_indices(path, idx, sizes, len(P))
        T = _cells_from_offsets(path, idx, np.cumsum(sizes), None, f"face {key}", noun="face")[0]
    P, T, pa = drop_non_finite(path, P, T, pa, noun="vertex")
    names, kinds, model_name, crs = _faultmesh_comments(comments)
    return split_merged(path, P, T, pa, {}, names, kinds, model_name, crs)
