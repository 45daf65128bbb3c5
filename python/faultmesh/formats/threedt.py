"""The ``.3dt`` format: faultmesh's own text format for a multi-layer model.

The specification is ``docs/3dt.md``; this module is its reference reader and
writer. In short::

    3DT 1
    # comments and blank lines are ignored anywhere
    MODEL name="demo" crs="EPSG:32650" surfaces=2 gaps=0
    META {"any": "json object"}
    BOUNDARY points=4
    0.0 0.0
    ...
    SURFACE name="coal8" kind=layer order=0 vertices=3 triangles=1
    VERTICES
    0.0 0.0 -120.5
    ...
    TRIANGLES
    0 1 2
    END SURFACE
    GAP fault="F22" layer="coal8" polygon_vertices=14 holes=1 seconds=0.0021 triangles=16
    0 1 2 3 ...
    END GAP
    END MODEL

Coordinates are written with the shortest decimal that reads back as the same
double, so a write/read round trip is exact. Version 2 (written only for a
model that has them) adds the stitching records: per layer an ``OWNERS``
block (kind and owner of every triangle, ``Surface.kinds``/``Surface.owner``),
``PATCH`` statements (``Model.patches``) and the ``id``/``patches`` of each
``GAP``; version 1 files read as before.
"""
from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from ._common import (AtomicFiles, ModelFileError, _Shared, format_floats, format_ints,
                      parse_numbers, read_text, split_lines)

MAGIC = "3DT"
VERSION = 2          # the newest version; read: 1 and 2
SUFFIX = ".3dt"

# key=value, value a JSON string (with escapes), a JSON array (version 2:
# strings or integers, written without spaces) or a bare token.
_ATTR = re.compile(r'\s*([A-Za-z_][A-Za-z0-9_]*)=("(?:[^"\\]|\\.)*"|\[(?:[^\]"]|"(?:[^"\\]|\\.)*")*\]|[^\s"]+)')


def _json_default(o: Any):
    if isinstance(o, np.ndarray):
        if o.dtype.kind == "f" and not np.all(np.isfinite(o)):
            # JSON has no NaN: missing values (e.g. GOCAD no-data vertex
            # properties) are written as null.
            return np.where(np.isfinite(o), o, None).tolist()
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, (set, tuple)):
        return list(o)
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"metadata value of type {type(o).__name__} is not JSON-serialisable")


def _meta_line(meta: Dict[str, Any], owner: str) -> Optional[str]:
    if not meta:
        return None
    try:
        return "META " + json.dumps(meta, default=_json_default, sort_keys=True,
                                    ensure_ascii=False, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise ValueError(f"save .3dt: metadata of {owner} cannot be written as JSON: {e}") from None


def _q(s: str) -> str:
    return json.dumps(str(s), ensure_ascii=False)


def _jlist(items) -> str:
    return json.dumps(list(items), ensure_ascii=False, separators=(",", ":"))


def _has_owners(surf) -> bool:
    return getattr(surf, "kinds", None) is not None and getattr(surf, "owner", None) is not None


def _version(model, surfaces) -> int:
    """2 if the model has stitching records (kinds and owners of triangles,
    patches, gap ids), else 1: a model without them stays readable by
    faultmesh versions that read version 1 only."""
    stitched = (any(_has_owners(s) for s, _, _ in surfaces) or bool(getattr(model, "patches", None))
                or any(getattr(g, "id", -1) >= 0 or getattr(g, "patches", None) for g in model.gaps))
    return 2 if stitched else 1


def model_lines(model) -> List[str]:
    """The ``.3dt`` text of ``model`` as a list of lines (no end-of-line characters)."""
    from .. import __version__

    surfaces = [(s, "layer", i) for i, s in enumerate(model.surfaces.values())]
    surfaces += [(s, "fault", i) for i, s in enumerate(model.faults.values())]
    version = _version(model, surfaces)
    patches = list(getattr(model, "patches", None) or []) if version >= 2 else []
    out: List[str] = [f"{MAGIC} {version}",
                      f"# faultmesh {__version__} multi-layer model; format: docs/3dt.md",
                      "# surfaces: layers top to bottom, then faults; triangle indices are "
                      "0-based rows of VERTICES, counter-clockwise seen from above"]
    out.append(f"MODEL name={_q(model.name)} crs={_q(model.crs or '')} "
               f"surfaces={len(surfaces)} gaps={len(model.gaps)}"
               + (f" patches={len(patches)}" if version >= 2 else ""))
    m = _meta_line(model.metadata, f"model {model.name!r}")
    if m:
        out.append(m)
    if model.boundary is not None:
        b = np.asarray(model.boundary, dtype=np.float64).reshape(-1, 2)
        out.append(f"BOUNDARY points={len(b)}")
        out.extend(format_floats(b))
    for surf, kind, order in surfaces:
        out.append(f"SURFACE name={_q(surf.name)} kind={kind} order={order} "
                   f"vertices={surf.n_vertices} triangles={surf.n_triangles}")
        m = _meta_line(surf.metadata, f"surface {surf.name!r}")
        if m:
            out.append(m)
        out.append("VERTICES")
        out.extend(format_floats(surf.vertices))
        out.append("TRIANGLES")
        out.extend(format_ints(surf.triangles))
        if version >= 2 and _has_owners(surf):
            out.append("OWNERS")
            out.extend(format_ints(np.column_stack([np.asarray(surf.kinds, dtype=np.int64),
                                                    np.asarray(surf.owner, dtype=np.int64)])))
        out.append("END SURFACE")
    for p in patches:
        out.append(f"PATCH layer={_q(p.layer)} id={int(p.id)} name={_q(p.name)} "
                   f"faults={_jlist(str(f) for f in p.faults)} triangles={int(p.n_triangles)}")
    for gap in model.gaps:
        rows = np.asarray(gap.triangles, dtype=np.int64).reshape(-1)
        ids = (f" id={int(gap.id)} patches={_jlist(int(x) for x in gap.patches)}"
               if version >= 2 and getattr(gap, "id", -1) >= 0 else "")
        out.append(f"GAP fault={_q(gap.fault)} layer={_q(gap.layer)} "
                   f"polygon_vertices={int(gap.n_vertices)} holes={int(gap.n_holes)} "
                   + (f"interior={int(gap.n_interior)} " if getattr(gap, "n_interior", 0) else "") +
                   f"seconds={float(gap.seconds)!r} triangles={len(rows)}{ids}")
        m = _meta_line(gap.metadata, f"gap {gap.fault!r}/{gap.layer!r}")
        if m:
            out.append(m)
        # 20 row indices per line keeps lines short and the file diff-able.
        for k in range(0, len(rows), 20):
            out.append(" ".join(map(str, rows[k:k + 20].tolist())))
        out.append("END GAP")
    out.append("END MODEL")
    return out


def write_3dt(model, path, files: Optional[AtomicFiles] = None) -> Path:
    """Write ``model`` to ``path`` atomically (temp file + rename; with ``files``
    the rename happens when that shared :class:`AtomicFiles` commits)."""
    path = Path(path)
    lines = model_lines(model)  # build everything first: errors leave no file behind
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        fh = f.open(path)
        fh.write("\n".join(lines))
        fh.write("\n")
    return path


class _Reader:
    """Statement-level cursor over the significant lines of a ``.3dt`` file."""

    def __init__(self, path: Path, text: str) -> None:
        self.path = path
        self.nums: List[int] = []
        self.lines: List[str] = []
        for no, raw in enumerate(split_lines(text), start=1):
            s = raw.strip()
            if s and not s.startswith("#"):
                self.nums.append(no)
                self.lines.append(s)
        self.i = 0

    def error(self, msg: str, at: Optional[int] = None) -> ModelFileError:
        if at is None:
            at = self.i
        line = self.nums[at] if at < len(self.nums) else (self.nums[-1] if self.nums else None)
        if at >= len(self.nums):
            msg = f"unexpected end of file: {msg}"
        return ModelFileError(self.path, msg, line)

    def peek(self) -> Optional[str]:
        return self.lines[self.i] if self.i < len(self.lines) else None

    def next(self, expected: str) -> str:
        if self.i >= len(self.lines):
            raise self.error(f"expected {expected}")
        s = self.lines[self.i]
        self.i += 1
        return s

    def statement(self, keyword: str) -> Dict[str, str]:
        """Read ``KEYWORD key=value ...`` and return the attributes (raw strings)."""
        at = self.i
        s = self.next(keyword)
        word, _, rest = s.partition(" ")
        if word != keyword:
            raise self.error(f"expected {keyword}, got {s[:60]!r}", at)
        return self.attributes(rest, keyword, at)

    def attributes(self, rest: str, keyword: str, at: int) -> Dict[str, str]:
        attrs: Dict[str, str] = {}
        pos = 0
        rest = rest.rstrip()
        while pos < len(rest):
            m = _ATTR.match(rest, pos)
            if not m:
                raise self.error(f"{keyword}: expected key=value, got {rest[pos:pos + 40].strip()!r}", at)
            key, val = m.group(1), m.group(2)
            if val.startswith('"') or val.startswith("["):
                try:
                    val = json.loads(val)
                except json.JSONDecodeError as e:
                    raise self.error(f"{keyword}: bad quoted value for {key}: {e}", at) from None
            if key in attrs:
                raise self.error(f"{keyword}: attribute {key!r} given twice", at)
            attrs[key] = val
            pos = m.end()
        return attrs

    def need(self, attrs: Dict[str, str], key: str, keyword: str, at: int, kind=str):
        if key not in attrs:
            raise self.error(f"{keyword}: missing attribute {key}=", at)
        val = attrs[key]
        if kind in (list, "ints"):
            if not isinstance(val, list) or not all(
                    isinstance(x, int) and not isinstance(x, bool) and x >= 0 if kind == "ints"
                    else isinstance(x, str) for x in val):
                noun = "non-negative integers" if kind == "ints" else "strings"
                raise self.error(f"{keyword}: {key} must be a JSON array of {noun}, got {val!r}", at)
            return val
        if isinstance(val, list):
            raise self.error(f"{keyword}: {key} must be a single value, got an array", at)
        try:
            if kind is int:
                v = int(val)
                if v < 0:
                    raise ValueError
                return v
            if kind is float:
                v = float(val)
                if not np.isfinite(v):
                    raise ValueError
                return v
        except ValueError:
            noun = "a non-negative integer" if kind is int else "a finite number"
            raise self.error(f"{keyword}: {key} must be {noun}, got {val!r}", at) from None
        return str(val)

    def meta(self) -> Dict[str, Any]:
        s = self.peek()
        if s is None or not (s == "META" or s.startswith("META ")):
            return {}
        at = self.i
        self.i += 1
        try:
            val = json.loads(s[4:].strip() or "null")
        except json.JSONDecodeError as e:
            raise self.error(f"META: expected a JSON object on one line ({e})", at) from None
        if not isinstance(val, dict):
            raise self.error(f"META: expected a JSON object, got {type(val).__name__}", at)
        return val

    def block(self, n: int, ncols: int, what: str, kind, context: str) -> np.ndarray:
        lines = self.lines[self.i:self.i + n]
        nums = self.nums[self.i:self.i + n]
        if len(lines) < n:
            raise self.error(f"expected {n} {what} rows{context}, the file ends after {len(lines)}",
                             len(self.lines))
        arr = parse_numbers(self.path, lines, nums, ncols, what, kind=kind, context=context)
        self.i += n
        return arr

    def keyword_line(self, expected: str) -> None:
        at = self.i
        s = self.next(expected)
        if s != expected:
            raise self.error(f"expected {expected!r}, got {s[:60]!r}", at)


def read_3dt(path):
    """Read a ``.3dt`` file into a :class:`faultmesh.Model`."""
    from .._core import TriangleKind
    from ..model import Gap, Model, StitchedPatch, Surface

    path = Path(path)
    r = _Reader(path, read_text(path))
    if not r.lines:
        raise ModelFileError(path, f"empty file, expected the header '{MAGIC} {VERSION}'", 1)
    head = r.lines[0].split()
    if len(head) != 2 or head[0] != MAGIC:
        raise ModelFileError(path, f"not a .3dt file: expected the header '{MAGIC} {VERSION}', "
                                   f"got {r.lines[0][:60]!r}", r.nums[0])
    try:
        version = int(head[1])
    except ValueError:
        raise ModelFileError(path, f"bad .3dt version {head[1]!r}, expected an integer",
                             r.nums[0]) from None
    if version not in (1, 2):
        raise ModelFileError(path, f"unsupported .3dt version {version}; this faultmesh reads "
                                   f"versions 1 and {VERSION}", r.nums[0])
    r.i = 1
    at = r.i
    attrs = r.statement("MODEL")
    name = r.need(attrs, "name", "MODEL", at)
    crs = str(attrs.get("crs", ""))
    n_surf = r.need(attrs, "surfaces", "MODEL", at, int)
    n_gaps = r.need(attrs, "gaps", "MODEL", at, int)
    n_patches = r.need(attrs, "patches", "MODEL", at, int) if version >= 2 else 0
    model_meta = r.meta()

    boundary = None
    if r.peek() is not None and r.peek().split(" ", 1)[0] == "BOUNDARY":
        at = r.i
        battrs = r.statement("BOUNDARY")
        k = r.need(battrs, "points", "BOUNDARY", at, int)
        boundary = r.block(k, 2, "boundary x y", float,
                           f" (BOUNDARY at line {r.nums[at]} announced {k} points)")

    layers: List[Tuple[int, Surface]] = []
    faults: List[Tuple[int, Surface]] = []
    seen = set()
    for _ in range(n_surf):
        at = r.i
        sattrs = r.statement("SURFACE")
        sname = r.need(sattrs, "name", "SURFACE", at)
        kind = r.need(sattrs, "kind", "SURFACE", at)
        if kind not in ("layer", "fault"):
            raise r.error(f"SURFACE {sname!r}: kind must be 'layer' or 'fault', got {kind!r}", at)
        order = r.need(sattrs, "order", "SURFACE", at, int)
        nv = r.need(sattrs, "vertices", "SURFACE", at, int)
        nt = r.need(sattrs, "triangles", "SURFACE", at, int)
        if (kind, sname) in seen:
            raise r.error(f"SURFACE: a {kind} named {sname!r} was already defined", at)
        seen.add((kind, sname))
        meta = r.meta()
        ctx = f" (SURFACE {sname!r} at line {r.nums[at]})"
        r.keyword_line("VERTICES")
        verts = r.block(nv, 3, "vertex x y z", float, ctx)
        t_at = r.i
        r.keyword_line("TRIANGLES")
        tris = r.block(nt, 3, "triangle vertex indices", int, ctx)
        if tris.size and (tris.min() < 0 or tris.max() >= nv):
            row = int(np.flatnonzero((tris < 0).any(axis=1) | (tris >= nv).any(axis=1))[0])
            raise r.error(f"SURFACE {sname!r}: triangle {row} has vertex index "
                          f"{tris[row].tolist()} outside 0..{nv - 1}", t_at + 1 + row)
        kinds = owner = None
        if version >= 2 and r.peek() == "OWNERS":
            o_at = r.i
            r.i += 1
            own = r.block(nt, 2, "triangle kind and owner", int, ctx)
            valid = np.isin(own[:, 0], [int(k) for k in TriangleKind])
            if not valid.all():
                row = int(np.flatnonzero(~valid)[0])
                raise r.error(f"SURFACE {sname!r}: OWNERS row {row}: kind {int(own[row, 0])} is not a "
                              f"TriangleKind value (0 layer, 1 patch, 2 gap)", o_at + 1 + row)
            kinds, owner = own[:, 0], own[:, 1]
        r.keyword_line("END SURFACE")
        surf = Surface(name=sname, vertices=verts, triangles=tris, kind=kind, metadata=meta,
                       kinds=kinds, owner=owner)
        (layers if kind == "layer" else faults).append((order, surf))

    layer_map = {s.name: s for _, s in sorted(layers, key=lambda t: t[0])}
    patches: List[StitchedPatch] = []
    for _ in range(n_patches):
        at = r.i
        pattrs = r.statement("PATCH")
        layer = r.need(pattrs, "layer", "PATCH", at)
        if layer not in layer_map:
            raise r.error(f"PATCH: layer {layer!r} is not a layer surface of this file "
                          f"(layers: {list(layer_map)})", at)
        patches.append(StitchedPatch(layer=layer, id=r.need(pattrs, "id", "PATCH", at, int),
                                     name=r.need(pattrs, "name", "PATCH", at),
                                     faults=r.need(pattrs, "faults", "PATCH", at, list),
                                     n_triangles=r.need(pattrs, "triangles", "PATCH", at, int)))
    gaps: List[Gap] = []
    for _ in range(n_gaps):
        at = r.i
        gattrs = r.statement("GAP")
        fault = r.need(gattrs, "fault", "GAP", at)
        layer = r.need(gattrs, "layer", "GAP", at)
        if layer not in layer_map:
            raise r.error(f"GAP: layer {layer!r} is not a layer surface of this file "
                          f"(layers: {list(layer_map)})", at)
        npoly = r.need(gattrs, "polygon_vertices", "GAP", at, int)
        holes = r.need(gattrs, "holes", "GAP", at, int)
        secs = r.need(gattrs, "seconds", "GAP", at, float) if "seconds" in gattrs else 0.0
        interior = r.need(gattrs, "interior", "GAP", at, int) if "interior" in gattrs else 0
        k = r.need(gattrs, "triangles", "GAP", at, int)
        gid = r.need(gattrs, "id", "GAP", at, int) if "id" in gattrs else -1
        gpatches = r.need(gattrs, "patches", "GAP", at, "ints") if "patches" in gattrs else []
        meta = r.meta()
        rows: List[int] = []
        while len(rows) < k:
            row_at = r.i
            s = r.next(f"{k} triangle rows of GAP at line {r.nums[at]}")
            try:
                vals = [int(v) for v in s.split()]
            except ValueError:
                raise r.error(f"GAP: expected triangle row indices (integers), got {s[:60]!r}",
                              row_at) from None
            rows.extend(vals)
            if len(rows) > k:
                raise r.error(f"GAP: announced {k} triangle rows, found more", row_at)
        arr = np.asarray(rows, dtype=np.int64)
        nt = layer_map[layer].n_triangles
        if arr.size and (arr.min() < 0 or arr.max() >= nt):
            raise r.error(f"GAP {fault!r}/{layer!r}: triangle row outside 0..{nt - 1} of layer "
                          f"{layer!r}", at)
        r.keyword_line("END GAP")
        gaps.append(Gap(fault=fault, layer=layer, triangles=arr, n_vertices=npoly,
                        n_holes=holes, n_interior=interior, seconds=secs, metadata=meta, id=gid,
                        patches=gpatches))
    at = r.i
    s = r.next("END MODEL")
    if s != "END MODEL":
        word = s.split(" ", 1)[0]
        extra = (f" (MODEL at the top announced surfaces={n_surf} gaps={n_gaps}"
                 + (f" patches={n_patches}" if version >= 2 else "") + ")"
                 if word in ("SURFACE", "GAP", "PATCH") else "")
        raise r.error(f"expected 'END MODEL', got {s[:60]!r}{extra}", at)
    if r.i < len(r.lines):
        raise r.error(f"unexpected content after END MODEL: {r.lines[r.i][:60]!r}")

    return Model(name=name, surfaces=layer_map,
                 faults={s.name: s for _, s in sorted(faults, key=lambda t: t[0])},
                 boundary=boundary, crs=crs, gaps=gaps, metadata=model_meta, patches=patches)
