"""GOCAD ASCII TSurf (``.ts``) reader and writer.

A ``.ts`` file holds one or more objects, each ``GOCAD <Type> 1`` ... ``END``.
Writing: one ``GOCAD TSurf 1`` object per surface (layers top to bottom, then
faults), ``HEADER { name: ... }`` with the surface's colour and faultmesh's own
keys (``faultmesh_kind``, ``faultmesh_order``, ``faultmesh_model``,
``faultmesh_crs``; other programs ignore unknown header keys), the
``GOCAD_ORIGINAL_COORDINATE_SYSTEM`` block (Z positive up: elevations),
``GEOLOGICAL_TYPE`` ``top`` for layers and ``fault`` for faults, one ``TFACE``,
``VRTX id x y z`` with 1-based ids and ``TRGL a b c``. The study-area boundary
is written as a closed ``GOCAD PLine 1`` object (``faultmesh_role: boundary``).

Reading accepts what other tools write: ``PVRTX`` (vertex properties, kept in
``Surface.metadata["vertex_properties"]``), ``ATOM``/``PATOM`` (a new vertex id
on the position of an existing one: copied by default so the file's topology is
kept, or merged with ``atoms="merge"``), several ``TFACE`` parts (one surface),
``ZPOSITIVE Depth`` (z negated to elevations), ``#`` comments, property and
header blocks in braces, ``BSTONE``/``BORDER`` and any unknown keyword
(ignored), and objects of other types (``VSet``, ``PLine``, ``GSurf``; skipped,
except faultmesh's boundary PLine).
"""
from __future__ import annotations

from pathlib import Path
from typing import Dict, List, Optional, Tuple

import numpy as np

from ._common import AtomicFiles, ModelFileError, _Shared, format_floats, read_text, split_lines

SUFFIX = ".ts"

# Colours of faultmesh's pictures (plots.layer_color) in GOCAD's 0..1 RGBA.
_FAULT_RGBA = "0.55 0.1 0.1 1"


def _header_value(s: str) -> str:
    s = str(s)
    if s == "" or any(c.isspace() for c in s) or '"' in s or s != s.strip():
        return '"' + s.replace('"', "'") + '"'
    return s


def _unquote(s: str) -> str:
    s = s.strip()
    if len(s) >= 2 and s[0] == s[-1] and s[0] in "\"'":
        return s[1:-1]
    return s


def _crs_block(crs: str) -> List[str]:
    name = crs if crs and not any(c.isspace() for c in crs) else "Default"
    return ["GOCAD_ORIGINAL_COORDINATE_SYSTEM", f"NAME {name}", 'AXIS_NAME "X" "Y" "Z"',
            'AXIS_UNIT "m" "m" "m"', "ZPOSITIVE Elevation", "END_ORIGINAL_COORDINATE_SYSTEM"]


def _rgba(color) -> str:
    from matplotlib.colors import to_rgba

    return " ".join(f"{c:.6g}" for c in to_rgba(color))


def model_lines(model) -> List[str]:
    from ..plots import layer_color

    out: List[str] = []
    layer_names = list(model.surfaces)
    entries = [(s, "layer", i) for i, s in enumerate(model.surfaces.values())]
    entries += [(s, "fault", i) for i, s in enumerate(model.faults.values())]
    for surf, kind, order in entries:
        color = _rgba(layer_color(order, len(layer_names))) if kind == "layer" else _FAULT_RGBA
        out += ["GOCAD TSurf 1", "HEADER {", f"name: {_header_value(surf.name)}",
                f"*solid*color: {color}", f"faultmesh_kind: {kind}",
                f"faultmesh_order: {order}", f"faultmesh_model: {_header_value(model.name)}"]
        if model.crs:
            out.append(f"faultmesh_crs: {_header_value(model.crs)}")
        out.append("}")
        out += _crs_block(model.crs)
        out += [f"GEOLOGICAL_FEATURE {_header_value(surf.name)}",
                f"GEOLOGICAL_TYPE {'fault' if kind == 'fault' else 'top'}", "TFACE"]
        ids = np.arange(1, surf.n_vertices + 1)
        for i, xyz in zip(ids.tolist(), format_floats(surf.vertices)):
            out.append(f"VRTX {i} {xyz}")
        t = surf.triangles + 1
        out.extend(f"TRGL {a} {b} {c}" for a, b, c in t.tolist())
        out.append("END")
    if model.boundary is not None and len(model.boundary) >= 3:
        b = np.asarray(model.boundary, dtype=np.float64).reshape(-1, 2)
        out += ["GOCAD PLine 1", "HEADER {", f"name: {_header_value(str(model.name) + '_boundary')}",
                "faultmesh_role: boundary", f"faultmesh_model: {_header_value(model.name)}", "}"]
        out += _crs_block(model.crs)
        out.append("ILINE")
        pts = np.column_stack([b, np.zeros(len(b))])
        for i, xyz in enumerate(format_floats(pts), start=1):
            out.append(f"VRTX {i} {xyz}")
        k = len(b)
        out.extend(f"SEG {i} {i % k + 1}" for i in range(1, k + 1))
        out.append("END")
    return out


def write_ts(model, path, files: Optional[AtomicFiles] = None) -> Path:
    """Write every surface of ``model`` to one ``.ts`` file (atomically)."""
    path = Path(path)
    lines = model_lines(model)
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        fh = f.open(path)
        fh.write("\n".join(lines))
        fh.write("\n")
    return path


class _Object:
    def __init__(self, kind: str, line: int) -> None:
        self.kind = kind  # "TSurf", "PLine", ...
        self.line = line
        self.header: Dict[str, str] = {}
        self.crs_name = ""
        self.z_sign = 1.0
        self.geological_type = ""
        self.prop_names: List[str] = []
        self.esizes: List[int] = []
        self.ids: List[int] = []          # file id of each vertex row
        self.xyz: List[Tuple[float, float, float]] = []
        self.props: List[List[float]] = []
        self.alias: Dict[int, int] = {}   # merged ATOM id -> vertex row
        self.tri_ids: List[Tuple[int, int, int]] = []
        self.tri_lines: List[int] = []
        self.vlines: List[int] = []       # line of each vertex row (for error messages)
        self.seg_ids: List[Tuple[int, int]] = []
        self.parts = 0


def _parse(path: Path, text: str, atoms: str) -> List[_Object]:
    objects: List[_Object] = []
    obj: Optional[_Object] = None
    block_end: Optional[str] = None   # inside HEADER {...} or another brace block
    in_crs = False
    id_row: Dict[int, int] = {}
    lines = split_lines(text)

    def err(msg: str, no: int) -> ModelFileError:
        return ModelFileError(path, msg, no)

    def number(tok: str, no: int, what: str) -> float:
        try:
            v = float(tok)
        except ValueError:
            raise err(f"expected a number for {what}, got {tok!r}", no) from None
        if not np.isfinite(v):
            raise err(f"non-finite {what} {tok!r}", no)
        return v

    def ident(tok: str, no: int, what: str) -> int:
        try:
            return int(tok)
        except ValueError:
            raise err(f"expected an integer {what}, got {tok!r}", no) from None

    for no, raw in enumerate(lines, start=1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        if obj is None:
            parts = s.split()
            if parts[0] == "GOCAD" and len(parts) >= 2:
                obj = _Object(parts[1], no)
                id_row = {}
                continue
            raise err(f"expected 'GOCAD <type> 1' to start an object (e.g. 'GOCAD TSurf 1'), "
                      f"got {s[:60]!r}", no)
        if block_end is not None:
            # Inside HEADER { ... } (or a property class header): key:value lines.
            body = s
            closes = body.endswith("}")
            if closes:
                body = body[:-1].strip()
            if block_end == "HEADER" and body:
                key, sep, val = body.partition(":")
                if sep:
                    obj.header[key.strip()] = _unquote(val)
            if closes:
                block_end = None
            continue
        if in_crs:
            if s.startswith("END_ORIGINAL_COORDINATE_SYSTEM"):
                in_crs = False
            else:
                key, _, val = s.partition(" ")
                if key == "NAME":
                    obj.crs_name = _unquote(val)
                elif key == "ZPOSITIVE":
                    v = val.strip().lower()
                    if v not in ("elevation", "depth"):
                        raise err(f"ZPOSITIVE must be Elevation or Depth, got {val.strip()!r}", no)
                    obj.z_sign = -1.0 if v == "depth" else 1.0
            continue
        key, _, rest = s.partition(" ")
        rest = rest.strip()
        if key in ("VRTX", "PVRTX"):
            tok = rest.split()
            if len(tok) < 4:
                raise err(f"{key}: expected 'id x y z', got {s[:80]!r}", no)
            try:  # fast path; the checks below name the bad field
                vid = int(tok[0])
                xyz = (float(tok[1]), float(tok[2]), float(tok[3]))
            except ValueError:
                vid = ident(tok[0], no, f"{key} id")
                xyz = (number(tok[1], no, "x"), number(tok[2], no, "y"), number(tok[3], no, "z"))
            if vid in id_row or vid in obj.alias:
                raise err(f"{key}: vertex id {vid} defined twice", no)
            id_row[vid] = len(obj.xyz)
            obj.ids.append(vid)
            obj.xyz.append(xyz)
            obj.vlines.append(no)
            if key == "PVRTX":
                try:
                    obj.props.append([float(t) for t in tok[4:]])
                except ValueError:
                    raise err(f"PVRTX: property values must be numbers, got {tok[4:]}", no) from None
            else:
                obj.props.append([])
        elif key in ("ATOM", "PATOM"):
            tok = rest.split()
            if len(tok) < 2:
                raise err(f"{key}: expected 'id vertex_id', got {s[:80]!r}", no)
            vid = ident(tok[0], no, f"{key} id")
            ref = ident(tok[1], no, f"{key} vertex id")
            if vid in id_row or vid in obj.alias:
                raise err(f"{key}: vertex id {vid} defined twice", no)
            if ref in obj.alias:
                ref_row = obj.alias[ref]
            elif ref in id_row:
                ref_row = id_row[ref]
            else:
                raise err(f"{key} {vid} refers to vertex {ref}, which is not defined before it", no)
            if atoms == "merge":
                obj.alias[vid] = ref_row
            else:
                id_row[vid] = len(obj.xyz)
                obj.ids.append(vid)
                obj.xyz.append(obj.xyz[ref_row])
                obj.vlines.append(no)
                try:
                    own = [float(t) for t in tok[2:]] if key == "PATOM" else []
                except ValueError:
                    raise err(f"PATOM: property values must be numbers, got {tok[2:]}", no) from None
                obj.props.append(own or list(obj.props[ref_row]))
        elif key == "TRGL":
            tok = rest.split()
            if len(tok) < 3:
                raise err(f"TRGL: expected three vertex ids, got {s[:80]!r}", no)
            try:
                obj.tri_ids.append((int(tok[0]), int(tok[1]), int(tok[2])))
            except ValueError:
                obj.tri_ids.append((ident(tok[0], no, "TRGL vertex id"),
                                    ident(tok[1], no, "TRGL vertex id"),
                                    ident(tok[2], no, "TRGL vertex id")))
            obj.tri_lines.append(no)
        elif key == "SEG":
            tok = rest.split()
            if len(tok) < 2:
                raise err(f"SEG: expected two vertex ids, got {s[:80]!r}", no)
            obj.seg_ids.append((ident(tok[0], no, "SEG vertex id"), ident(tok[1], no, "SEG vertex id")))
        elif key == "END":
            obj.id_row = id_row  # type: ignore[attr-defined]
            objects.append(obj)
            obj = None
        elif key == "HEADER" or s.endswith("{"):
            inner = s.partition("{")[2]
            if not s.count("{"):
                raise err("HEADER: expected '{'", no)
            block_end = "HEADER" if key == "HEADER" else "OTHER"
            if inner.strip():
                closes = inner.strip().endswith("}")
                body = inner.strip()[:-1] if closes else inner
                if block_end == "HEADER":
                    for item in body.split(";"):
                        k, sep, v = item.partition(":")
                        if sep:
                            obj.header[k.strip()] = _unquote(v)
                if closes:
                    block_end = None
        elif key == "GOCAD_ORIGINAL_COORDINATE_SYSTEM":
            in_crs = True
        elif key == "GEOLOGICAL_TYPE":
            obj.geological_type = _unquote(rest).lower()
        elif key == "PROPERTIES":
            obj.prop_names = rest.split()
        elif key == "ESIZES":
            try:
                obj.esizes = [int(t) for t in rest.split()]
            except ValueError:
                raise err(f"ESIZES: expected integers, got {rest!r}", no) from None
        elif key in ("TFACE", "ILINE"):
            obj.parts += 1
        elif key == "GOCAD":
            raise err(f"'GOCAD {rest}' starts a new object, but the {obj.kind} object started at "
                      f"line {obj.line} has no END", no)
        # Anything else (BSTONE, BORDER, GEOLOGICAL_FEATURE, PROPERTY_CLASSES, ...) is ignored.
    if obj is not None:
        raise err(f"unexpected end of file: the {obj.kind} object started at line {obj.line} "
                  f"has no END", len(lines))
    if block_end is not None:  # pragma: no cover (only reachable with obj open)
        raise err("unexpected end of file inside a { } block", len(lines))
    return objects


def _rows(path: Path, obj: _Object, ids: np.ndarray, lines: List[int], what: str) -> np.ndarray:
    """Map file vertex ids to rows (vectorised), naming the line of an unknown id."""
    id_row = obj.id_row  # type: ignore[attr-defined]
    if not obj.alias and obj.ids:
        # Common case (faultmesh's own files and most exports): ids k0, k0+1, ...
        first = obj.ids[0]
        if obj.ids[-1] - first == len(obj.ids) - 1 and \
                np.array_equal(np.asarray(obj.ids), np.arange(first, first + len(obj.ids))):
            rows = ids - first
            ok = (rows >= 0) & (rows < len(obj.ids))
            if ok.all():
                return rows
    keys = np.array(list(id_row.keys()) + list(obj.alias.keys()), dtype=np.int64)
    vals = np.array(list(id_row.values()) + list(obj.alias.values()), dtype=np.int64)
    order = np.argsort(keys)
    keys, vals = keys[order], vals[order]
    pos = np.searchsorted(keys, ids)
    pos_c = np.minimum(pos, max(len(keys) - 1, 0))
    ok = (pos < len(keys)) & (keys[pos_c] == ids) if len(keys) else np.zeros(ids.shape, bool)
    if not ok.all():
        bad = np.argwhere(~ok)[0]
        raise ModelFileError(path, f"{what} refers to vertex id {int(ids[tuple(bad)])}, which is "
                                   f"not defined in this {obj.kind} (started at line {obj.line})",
                             lines[int(bad[0])])
    return vals[pos_c]


def read_ts(path, atoms: str = "copy"):
    """Read every ``TSurf`` object of a ``.ts`` file into a :class:`faultmesh.Model`.

    ``atoms``: ``"copy"`` (default) gives every ATOM its own vertex at the
    referenced position, as the file's topology says; ``"merge"`` makes it the
    same vertex as the one it references.
    """
    from ..model import Model, Surface

    if atoms not in ("copy", "merge"):
        raise ValueError(f"read_ts: atoms must be 'copy' or 'merge', got {atoms!r}")
    path = Path(path)
    objects = _parse(path, read_text(path), atoms)
    layers: List[Tuple[float, int, Surface]] = []
    faults: List[Tuple[float, int, Surface]] = []
    model_name = ""
    crs = ""
    boundary = None
    used = set()
    for k, obj in enumerate(objects):
        if obj.kind == "PLine" and obj.header.get("faultmesh_role") == "boundary":
            xyz = np.array(obj.xyz, dtype=np.float64).reshape(-1, 3)
            boundary = xyz[:, :2].copy()
            continue
        if obj.kind.lower() not in ("tsurf",):
            continue
        name = obj.header.get("name", "") or f"surface_{k}"
        base, n = name, 2
        while name in used:
            name = f"{base} ({n})"
            n += 1
        used.add(name)
        xyz = np.array(obj.xyz, dtype=np.float64).reshape(-1, 3)
        bad = ~np.all(np.isfinite(xyz), axis=1)
        if bad.any():   # float() accepts "nan" and "inf" on the fast path
            r = int(np.flatnonzero(bad)[0])
            raise ModelFileError(path, f"non-finite vertex coordinates {xyz[r].tolist()}",
                                 obj.vlines[r])
        xyz[:, 2] *= obj.z_sign
        if obj.tri_ids:
            tri = _rows(path, obj, np.array(obj.tri_ids, dtype=np.int64), obj.tri_lines, "TRGL")
        else:
            tri = np.zeros((0, 3), dtype=np.int64)
        meta: Dict[str, object] = {}
        if obj.parts > 1:
            meta["tface_parts"] = obj.parts
        if obj.prop_names and obj.props and all(len(p) for p in obj.props):
            widths = {len(p) for p in obj.props}
            sizes = obj.esizes if len(obj.esizes) == len(obj.prop_names) else [1] * len(obj.prop_names)
            if len(widths) == 1 and widths.pop() == sum(sizes):
                allp = np.array(obj.props, dtype=np.float64)
                props, c = {}, 0
                for pname, sz in zip(obj.prop_names, sizes):
                    props[pname] = allp[:, c] if sz == 1 else allp[:, c:c + sz]
                    c += sz
                meta["vertex_properties"] = props
        kind = obj.header.get("faultmesh_kind") or ("fault" if obj.geological_type == "fault"
                                                      else "layer")
        if kind not in ("layer", "fault"):
            raise ModelFileError(path, f"faultmesh_kind must be layer or fault, got {kind!r}",
                                 obj.line)
        try:
            order = float(obj.header.get("faultmesh_order", k))
        except ValueError:
            order = float(k)
        model_name = model_name or obj.header.get("faultmesh_model", "")
        crs = crs or obj.header.get("faultmesh_crs", "") or (
            obj.crs_name if obj.crs_name and obj.crs_name != "Default" else "")
        surf = Surface(name=name, vertices=xyz, triangles=tri, kind=kind, metadata=meta)
        (layers if kind == "layer" else faults).append((order, k, surf))
    if not layers and not faults:
        raise ModelFileError(path, "no 'GOCAD TSurf' object found")
    layers.sort(key=lambda t: (t[0], t[1]))
    faults.sort(key=lambda t: (t[0], t[1]))
    return Model(name=model_name or path.stem, surfaces={s.name: s for _, _, s in layers},
                 faults={s.name: s for _, _, s in faults}, boundary=boundary, crs=crs)
