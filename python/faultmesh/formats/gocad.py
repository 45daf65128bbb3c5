"""GOCAD ASCII files: TSurf (``.ts``), Model3d (``.ml``) and PLine (``.pl``).

Writing (docs/formats.md, "GOCAD"):

* ``.ts``: one ``GOCAD TSurf 1`` object per surface (layers top to bottom,
  then faults), each with its own vertex numbering from 1, so every object is
  a complete surface for readers that take one surface per file (resqpy).
  ``HEADER`` with the name written bare as SKUA does (``name:coal 8``), the
  colour of faultmesh's pictures and faultmesh's own keys (``faultmesh_kind``,
  ``faultmesh_order``, ``faultmesh_model``; other programs ignore unknown
  header keys); the ``GOCAD_ORIGINAL_COORDINATE_SYSTEM`` block with the
  model's CRS as ``NAME`` (``Default`` when it has none) and ``ZPOSITIVE
  Elevation``; the vertex property header when the surface has vertex
  properties (``PVRTX`` lines then); ``GEOLOGICAL_FEATURE`` (the name) and
  ``GEOLOGICAL_TYPE``: ``top`` for a layer (a horizon, as SKUA writes
  horizons), ``normal_fault``/``reverse_fault`` for a fault whose metadata
  ``kind`` says so, else ``fault``; one ``TFACE``, ``VRTX``/``PVRTX`` and
  ``TRGL``.
* ``.ml``: a ``GOCAD Model3d 1`` header listing every surface (``TSURF``,
  ``TFACE <id> <type> <name>`` with its key triangle, ``SURFACE`` feature
  lists) followed by the same TSurf objects, so the file opens as one
  structural model with named horizons and faults (OpenGeode's
  StructuralModel reader, SKUA).
* the study boundary, when the model has one, goes to its own file
  ``<stem>_boundary.pl`` beside the ``.ts``/``.ml``: a closed ``GOCAD PLine``
  at the model's highest elevation (a frame over the model), with
  ``faultmesh_role:boundary``.

Reading accepts what other tools write (SKUA/GOCAD, SCEC CFM, OpenGeode,
RMS): ``.ts``, ``.ml`` and ``.pl`` by content, not by suffix. ``PVRTX`` with
properties named by ``PROPERTIES`` (GOCAD quoting, ``" default property"``),
sized by ``ESIZES``, ``NO_DATA_VALUES`` and MSVC's ``-1.#IND``/``1.#INF``
read as NaN and infinity, trailing flags such as ``CNXYZ`` ignored
(``properties=False`` skips the values: a fault surface's reader); ``ATOM``/``PATOM`` (a new vertex id on the position of an
existing one: copied by default so the file's topology is kept, or merged with
``atoms="merge"``); several ``TFACE`` parts (one surface); ``ZPOSITIVE
Depth`` (z negated to elevations); ``AXIS_UNIT`` other than metres (feet,
US survey feet, kilometres: each axis converted to metres, an unknown unit
refused naming its line); ``GEOLOGICAL_TYPE`` containing ``fault``
gives a fault (``normal_fault``/``reverse_fault`` set ``metadata["kind"]``),
``boundary``/``lease`` surfaces (the box of a SKUA model) are not layers:
they are listed in ``model.metadata["gocad_boundary_surfaces"]`` and left out;
every other type is a layer. ``#`` comments, brace blocks, ``BSTONE``,
``BORDER``, ``REGION``, ``ARI`` blocks and any unknown keyword are ignored;
objects of other types (``VSet``, ``GSurf``, ...) are skipped; a header
closed on its last key line (``*solid*color:1 0 0 1 }``) is closed there; a
trailing DOS end-of-file byte (Ctrl-Z) is ignored. Refused naming the line:
a vertex id beyond int64, a number with ``_`` in it (``1_000``, which
Python's ``float`` takes), a header never closed (naming the line that
opened it), property rows of different lengths.
"""
from __future__ import annotations

from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ._common import AtomicFiles, ModelFileError, _Shared, format_floats, read_text, split_lines

SUFFIXES = (".ts", ".ml", ".pl")

# Colours of faultmesh's pictures (plots.layer_color) in GOCAD's 0..1 RGBA.
_FAULT_RGBA = "0.55 0.1 0.1 1"
# GOCAD's usual no-data value for vertex properties (NaN is written as this).
_NO_DATA = -99999.0
_BOUNDARY_TYPES = ("boundary", "lease")
# Metres per unit of the AXIS_UNIT names GOCAD and the tools that write it
# use (lower case). faultmesh's models are in metres (the writer says "m");
# a file in feet is read in metres. The US survey foot is 1200/3937 m.
_AXIS_UNITS = {"m": 1.0, "meter": 1.0, "meters": 1.0, "metre": 1.0, "metres": 1.0,
               "km": 1000.0, "ft": 0.3048, "feet": 0.3048, "foot": 0.3048,
               "ftus": 1200.0 / 3937.0, "us_ft": 1200.0 / 3937.0, "us-ft": 1200.0 / 3937.0,
               "usft": 1200.0 / 3937.0}


# --------------------------------------------------------------------------
# names and quoting
# --------------------------------------------------------------------------

def _bare(s: str, what: str) -> str:
    """A name as SKUA writes it: bare, the rest of the line. GOCAD has no
    escape, so a line break cannot be written and a double quote (which the
    readers strip) is written as a single quote."""
    s = str(s)
    if "\n" in s or "\r" in s:
        raise ValueError(f"GOCAD: {what} {s!r} contains a line break, which GOCAD files cannot hold")
    return s.replace('"', "'").strip() or "unnamed"


def _quoted(s: str, what: str) -> str:
    """A token in GOCAD's quoting: bare without white space, else ``" name"``
    (a quote, a space, the name, a quote: what GOCAD and OpenGeode write)."""
    s = _bare(s, what)
    return f'" {s}"' if any(c.isspace() for c in s) else s


# Keywords that end an object's coordinate system block by their presence:
# geometry, a new part, the object's end or a new object.
_NOT_IN_CRS = frozenset(("VRTX", "PVRTX", "ATOM", "PATOM", "TRGL", "SEG", "TFACE", "ILINE", "END",
                         "GOCAD", "HEADER", "PROPERTIES"))


def _keyword(s: str) -> Tuple[str, str]:
    """(keyword, the rest) of a stripped GOCAD line: the keyword ends at the
    first white space of any kind (a tab, too)."""
    parts = s.split(None, 1)
    return (parts[0], parts[1]) if len(parts) == 2 else (s, "")


def split_quoted(s: str) -> List[str]:
    """Tokens of a GOCAD line: white-space separated, a ``"..."`` group is one
    token (GOCAD writes ``" name"``; the quotes and the white space inside at
    either end are dropped)."""
    out: List[str] = []
    i, n = 0, len(s)
    while i < n:
        if s[i].isspace():
            i += 1
            continue
        if s[i] == '"':
            j = s.find('"', i + 1)
            if j < 0:          # unclosed quote: the rest of the line
                out.append(s[i + 1:].strip())
                break
            out.append(s[i + 1:j].strip())
            i = j + 1
        else:
            j = i
            while j < n and not s[j].isspace():
                j += 1
            out.append(s[i:j])
            i = j
    return out


def _unquote(s: str) -> str:
    s = s.strip()
    if len(s) >= 2 and s[0] == s[-1] and s[0] in "\"'":
        return s[1:-1].strip()
    return s


# --------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------

def _rgba(color) -> str:
    from matplotlib.colors import to_rgba

    return " ".join(f"{c:.6g}" for c in to_rgba(color))


def _crs_block(crs: str) -> List[str]:
    name = _quoted(crs, "CRS name") if crs else "Default"
    return ["GOCAD_ORIGINAL_COORDINATE_SYSTEM", f"NAME {name}", 'AXIS_NAME "X" "Y" "Z"',
            'AXIS_UNIT "m" "m" "m"', "ZPOSITIVE Elevation", "END_ORIGINAL_COORDINATE_SYSTEM"]


def geological_type(surf, kind: str) -> str:
    """``top`` for a layer; ``normal_fault``/``reverse_fault``/``fault`` for a
    fault, from its metadata ``kind`` (what build_model records)."""
    if kind != "fault":
        return "top"
    sub = str((surf.metadata or {}).get("kind", "")).lower()
    return {"normal": "normal_fault", "reverse": "reverse_fault"}.get(sub, "fault")


def _entries(model) -> List[Tuple[object, str, int]]:
    return [(s, "layer", i) for i, s in enumerate(model.surfaces.values())] + \
           [(s, "fault", i) for i, s in enumerate(model.faults.values())]


def _vertex_properties(surf) -> Dict[str, np.ndarray]:
    """The surface's vertex properties as float (n, k) arrays; a property of
    the wrong length is an error naming it."""
    props = (surf.metadata or {}).get("vertex_properties") or {}
    out: Dict[str, np.ndarray] = {}
    for name, val in props.items():
        a = np.asarray(val, dtype=np.float64)
        a = a.reshape(len(a), -1) if a.ndim >= 1 else a.reshape(1, 1)
        if a.shape[0] != surf.n_vertices:
            raise ValueError(f"GOCAD: vertex property {name!r} of surface {surf.name!r} has "
                             f"{a.shape[0]} values for {surf.n_vertices} vertices")
        out[str(name)] = a
    return out


def surface_lines(surf, kind: str, order: int, model, n_layers: int) -> List[str]:
    """One ``GOCAD TSurf 1`` object (numbered from 1) as lines."""
    from ..plots import layer_color

    color = _rgba(layer_color(order, n_layers)) if kind == "layer" else _FAULT_RGBA
    name = _bare(surf.name, "surface name")
    out = ["GOCAD TSurf 1", "HEADER {", f"name:{name}", f"*solid*color:{color}",
           f"faultmesh_kind:{kind}", f"faultmesh_order:{order}",
           f"faultmesh_model:{_bare(model.name, 'model name')}", "}"]
    out += _crs_block(model.crs)
    props = _vertex_properties(surf)
    if props:
        names = [_quoted(p, "property name") for p in props]
        cols = np.hstack(list(props.values()))
        finite = cols[np.isfinite(cols)]
        # NaN is written as the no-data value; pick one the data does not use.
        nodata = _NO_DATA
        while finite.size and np.any(finite == nodata):
            nodata = nodata * 10 - 9
        cols = np.where(np.isfinite(cols), cols, nodata)
        k = len(props)
        out += ["PROPERTIES " + " ".join(names),
                "PROP_LEGAL_RANGES " + " ".join(["**none** **none**"] * k),
                "NO_DATA_VALUES " + " ".join([repr(nodata)] * k),
                "PROPERTY_CLASSES " + " ".join(names),
                "PROPERTY_KINDS " + " ".join(["unknown"] * k),
                "PROPERTY_SUBCLASSES " + " ".join(["QUANTITY Float"] * k),
                "ESIZES " + " ".join(str(a.shape[1]) for a in props.values()),
                "UNITS " + " ".join(["none"] * k)]
    out += [f"GEOLOGICAL_FEATURE {name}", f"GEOLOGICAL_TYPE {geological_type(surf, kind)}", "TFACE"]
    ids = range(1, surf.n_vertices + 1)
    xyz = format_floats(surf.vertices)
    if props:
        pv = format_floats(cols)
        out.extend(f"PVRTX {i} {a} {b}" for i, a, b in zip(ids, xyz, pv))
    else:
        out.extend(f"VRTX {i} {a}" for i, a in zip(ids, xyz))
    out.extend(f"TRGL {a} {b} {c}" for a, b, c in (surf.triangles + 1).tolist())
    out.append("END")
    return out


def model_lines(model) -> List[str]:
    """The ``.ts`` text: one TSurf object per surface."""
    out: List[str] = []
    n_layers = len(model.surfaces)
    for surf, kind, order in _entries(model):
        out += surface_lines(surf, kind, order, model, n_layers)
    return out


def model3d_lines(model) -> List[str]:
    """The ``.ml`` text: the Model3d header, then the TSurf objects."""
    entries = _entries(model)
    names = [_bare(s.name, "surface name") for s, _, _ in entries]
    seen: Dict[str, str] = {}
    for (s, kind, _), n in zip(entries, names):
        # OpenGeode and SKUA find a TSurf by its name: names must be unique.
        if n in seen:
            raise ValueError(f"GOCAD Model3d: two surfaces are named {n!r} (a {seen[n]} and a "
                             f"{kind}); names must be unique in a .ml file")
        seen[n] = kind
    out = ["GOCAD Model3d 1", "HEADER {", f"name:{_bare(model.name, 'model name')}", "}"]
    out += _crs_block(model.crs)
    out += [f"TSURF {n}" for n in names]
    for k, ((s, kind, _), n) in enumerate(zip(entries, names), start=1):
        out.append(f"TFACE {k} {geological_type(s, kind)} {n}")
        if s.n_triangles:   # the key triangle: SKUA identifies the face by it
            out.extend("  " + row for row in format_floats(s.vertices[s.triangles[0]]))
    for k, n in enumerate(names, start=1):
        out += [f"SURFACE {n}", f"  {k} 0"]
    out.append("END")
    return out + model_lines(model)


def pline_lines(name: str, xyz: np.ndarray, crs: str, *, closed: bool = False,
                header: Sequence[str] = (), color: str = "0 0 0 1") -> List[str]:
    """One ``GOCAD PLine 1`` object: a polyline through the points ``xyz``
    (k, 3) in order (one ``ILINE``; ``closed`` adds the segment back to the
    first point), named ``name``, with the extra ``header`` lines (``key:value``)
    and the CRS block."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    out = ["GOCAD PLine 1", "HEADER {", f"name:{_bare(name, 'name')}", f"*line*color:{color}",
           *header, "}"]
    out += _crs_block(crs)
    out.append("ILINE")
    out.extend(f"VRTX {i} {p}" for i, p in enumerate(format_floats(xyz), start=1))
    k = len(xyz)
    out.extend(f"SEG {i} {i % k + 1}" for i in range(1, k + (1 if closed else 0)))
    out.append("END")
    return out


def boundary_lines(model) -> List[str]:
    """The study boundary as a closed PLine at the model's highest elevation."""
    b = np.asarray(model.boundary, dtype=np.float64).reshape(-1, 2)
    tops = [s.vertices[:, 2].max() for s, _, _ in _entries(model) if s.n_vertices]
    z = float(max(tops)) if tops else 0.0
    return pline_lines(str(model.name) + " boundary", np.column_stack([b, np.full(len(b), z)]),
                       model.crs, closed=True,
                       header=["faultmesh_role:boundary",
                               f"faultmesh_model:{_bare(model.name, 'model name')}"])


def write_polylines(path, lines: Sequence[Tuple[str, np.ndarray, Sequence[str]]], crs: str,
                    files: Optional[AtomicFiles] = None) -> List[Path]:
    """A ``.pl`` file of open polylines: ``lines`` = (name, xyz (k, 3),
    extra header lines) per polyline, each its own PLine object (what
    :func:`read_pl` and SKUA/GOCAD read as one named line each)."""
    path = Path(path)
    text: List[str] = []
    for name, xyz, header in lines:
        text += pline_lines(name, xyz, crs, header=header)
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        f.open(path).write("\n".join(text) + "\n")
    return [path]


def boundary_path(path) -> Path:
    """Where the boundary of ``path`` (a ``.ts``/``.ml``) is written: ``<stem>_boundary.pl``."""
    path = Path(path)
    return path.with_name(f"{path.stem}_boundary.pl")


def _write(model, path, lines: List[str], files: Optional[AtomicFiles]) -> List[Path]:
    path = Path(path)
    written = [path]
    blines = None
    if model.boundary is not None and len(model.boundary) >= 3:
        blines = boundary_lines(model)
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        fh = f.open(path)
        fh.write("\n".join(lines) + "\n")
        if blines is not None:
            bp = boundary_path(path)
            if not f.pending(bp):    # a folder write gives .ts and .ml the same boundary
                fb = f.open(bp)
                fb.write("\n".join(blines) + "\n")
            written.append(bp)
    return written


def write_ts(model, path, files: Optional[AtomicFiles] = None) -> List[Path]:
    """Write every surface of ``model`` to ``path`` (``.ts``) and the boundary
    to ``<stem>_boundary.pl``, atomically; returns the files written."""
    return _write(model, path, model_lines(model), files)


def write_ml(model, path, files: Optional[AtomicFiles] = None) -> List[Path]:
    """Write ``model`` as a GOCAD Model3d ``.ml`` (and ``<stem>_boundary.pl``)."""
    return _write(model, path, model3d_lines(model), files)


# --------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------

class _Object:
    def __init__(self, kind: str, line: int) -> None:
        self.kind = kind  # "TSurf", "PLine", "Model3d", ...
        self.line = line
        self.header: Dict[str, str] = {}
        self.crs_name = ""
        self.z_sign = 1.0
        self.axis_scale = (1.0, 1.0, 1.0)  # metres per unit of x, y, z (AXIS_UNIT)
        self.crs_line = 0  # the line of its own GOCAD_ORIGINAL_COORDINATE_SYSTEM, 0: none
        self.geological_type = ""
        self.prop_names: List[str] = []
        self.esizes: List[int] = []
        self.no_data: List[float] = []
        self.ids: List[int] = []          # file id of each vertex row
        self.xyz: List[Tuple[float, float, float]] = []
        self.props: List[List[float]] = []
        self.alias: Dict[int, int] = {}   # merged ATOM id -> vertex row
        self.id_row: Dict[int, int] = {}
        self.tri_ids: List[Tuple[int, int, int]] = []
        self.tri_lines: List[int] = []
        self.vlines: List[int] = []       # line of each vertex row (for error messages)
        self.seg_ids: List[Tuple[int, int]] = []
        self.parts = 0
        # Model3d header: TSURF names and TFACE (id, type, name)
        self.tsurfs: List[str] = []
        self.tfaces: List[Tuple[str, str]] = []

    def n_props(self) -> int:
        if not self.prop_names:
            return 0
        if len(self.esizes) == len(self.prop_names):
            return sum(self.esizes)
        return len(self.prop_names)


# Vertex ids are stored as int64 (numpy's id arrays); a larger one in a file
# is refused by name rather than overflowing in the conversion.
_ID_MIN, _ID_MAX = -(1 << 63), (1 << 63) - 1

# Windows' C runtime (MSVC before 2015) printed NaN and infinity so; GOCAD
# exports of that age carry them in property columns.
_MSVC_SPECIAL = {"1.#inf": np.inf, "-1.#inf": -np.inf, "1.#ind": np.nan, "-1.#ind": np.nan,
                 "1.#qnan": np.nan, "-1.#qnan": np.nan, "1.#snan": np.nan, "-1.#snan": np.nan}


def _property_value(tok: str) -> float:
    """A property value: a number, or one of MSVC's spellings of NaN and
    infinity; ValueError otherwise."""
    special = _MSVC_SPECIAL.get(tok.lower())
    if special is not None:
        return float(special)
    if "_" in tok:   # float() takes "1_000"; no GOCAD writer does
        raise ValueError(tok)
    return float(tok)


def _parse(path: Path, text: str, atoms: str, properties: bool = True) -> List[_Object]:
    """The objects of a GOCAD file. ``properties``: read the PVRTX/PATOM
    property values (False: a reader of the geometry alone ignores them, so
    a property column it does not use cannot refuse the file)."""
    objects: List[_Object] = []
    obj: Optional[_Object] = None
    block_end: Optional[str] = None   # inside HEADER {...} or another brace block
    block_line = 0                    # the line that opened it
    last_header_key = ""              # the key of the block's last key:value line
    in_crs = False
    skip_until: Optional[str] = None  # e.g. BEGIN_ATOM_REGION_INDICATORS ... END_...
    # A trailing Ctrl-Z (DOS's end-of-file byte, left by old Windows tools)
    # is no content.
    lines = split_lines(text.rstrip("\x1a"))

    def err(msg: str, no: int) -> ModelFileError:
        return ModelFileError(path, msg, no)

    def number(tok: str, no: int, what: str) -> float:
        try:
            if "_" in tok:   # float() takes "1_000"; the datasets' CSVs refuse it
                raise ValueError(tok)
            v = float(tok)
        except ValueError:
            raise err(f"expected a number for {what}, got {tok!r}", no) from None
        if not np.isfinite(v):
            raise err(f"non-finite {what} {tok!r}", no)
        return v

    def ident(tok: str, no: int, what: str) -> int:
        try:
            if "_" in tok:
                raise ValueError(tok)
            v = int(tok)
        except ValueError:
            raise err(f"expected an integer {what}, got {tok!r}", no) from None
        if not _ID_MIN <= v <= _ID_MAX:
            raise err(f"{what} {tok!r} is out of range (at most {_ID_MAX})", no)
        return v

    def values(toks: Sequence[str], no: int, key: str) -> List[float]:
        """The property values of a PVRTX/PATOM: the first n_props tokens."""
        n = obj.n_props()
        if len(toks) < n:
            raise err(f"{key}: expected {n} property value(s) after the coordinates "
                      f"(PROPERTIES {' '.join(obj.prop_names)}), got {len(toks)}", no)
        try:
            return [_property_value(t) for t in toks[:n]]
        except ValueError:
            raise err(f"{key}: property values must be numbers, got {list(toks[:n])}", no) from None

    def crs_field(key: str, val: str, no: int) -> None:
        """ZPOSITIVE and AXIS_UNIT, in the coordinate system block or (as some
        writers put them) outside it; other keys there are ignored."""
        if key == "ZPOSITIVE":
            v = val.strip().lower()
            if v not in ("elevation", "depth"):
                raise err(f"ZPOSITIVE must be Elevation or Depth, got {val.strip()!r}", no)
            obj.z_sign = -1.0 if v == "depth" else 1.0
        elif key == "AXIS_UNIT":
            units = split_quoted(val)
            if len(units) != 3:
                raise err(f"AXIS_UNIT: expected three units (x, y, z), got {val.strip()!r}", no)
            # ASCII only: str.lower() maps the Kelvin sign to "k".
            unknown = [u for u in units if not u.isascii() or u.lower() not in _AXIS_UNITS]
            if unknown:
                raise err(f"AXIS_UNIT: unknown unit {unknown[0]!r} (known: m, km, ft, "
                          "ftUS and their spelled-out names)", no)
            obj.axis_scale = tuple(_AXIS_UNITS[u.lower()] for u in units)

    for no, raw in enumerate(lines, start=1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        if obj is None:
            parts = s.split()
            if parts[0] == "GOCAD" and len(parts) >= 2:
                obj = _Object(parts[1], no)
                continue
            raise err(f"expected 'GOCAD <type> 1' to start an object (e.g. 'GOCAD TSurf 1'), "
                      f"got {s[:60]!r}", no)
        if skip_until is not None:
            if s.startswith(skip_until):
                skip_until = None
            continue
        if block_end is not None:
            # Inside HEADER { ... } (or a property class header): key:value
            # lines up to a line starting with "}" (a name may end with "}").
            body = s
            closes = body.startswith("}")
            if closes:
                body = ""
            key = _keyword(s)[0]
            if not closes and key in _NOT_IN_CRS:
                # The object's geometry (or its END) inside the block: the
                # block was closed on its last key line ("color:1 0 0 1 }",
                # as some writers do) or not at all -- which would swallow
                # the object.
                last = obj.header.get(last_header_key, "") if block_end == "HEADER" else ""
                if not (last_header_key and last.rstrip().endswith("}")):
                    raise err(f"the {'HEADER' if block_end == 'HEADER' else 'brace'} block opened "
                              f"at line {block_line} has no closing '}}' before this {key} line",
                              no)
                obj.header[last_header_key] = _unquote(last.rstrip()[:-1])
                block_end = None
            else:
                if block_end == "HEADER" and body:
                    hkey, sep, val = body.partition(":")
                    if sep:
                        last_header_key = hkey.strip()
                        obj.header[last_header_key] = _unquote(val)
                if closes:
                    block_end = None
                continue
        if in_crs:
            key, val = _keyword(s)
            if key == "END_ORIGINAL_COORDINATE_SYSTEM":
                in_crs = False
            elif key in _NOT_IN_CRS:
                # A block never closed would swallow the object's geometry.
                raise err(f"the GOCAD_ORIGINAL_COORDINATE_SYSTEM block opened at line "
                          f"{obj.crs_line} has no END_ORIGINAL_COORDINATE_SYSTEM before this "
                          f"{key} line", no)
            elif key == "NAME":
                obj.crs_name = " ".join(split_quoted(val))
            else:
                crs_field(key, val, no)
            continue
        key, rest = _keyword(s)
        rest = rest.strip()
        if key in ("VRTX", "PVRTX"):
            tok = rest.split()
            if len(tok) < 4:
                raise err(f"{key}: expected 'id x y z', got {s[:80]!r}", no)
            try:  # fast path; the checks below name the bad field
                if "_" in rest or not _ID_MIN <= (vid := int(tok[0])) <= _ID_MAX:
                    raise ValueError(rest)
                xyz = (float(tok[1]), float(tok[2]), float(tok[3]))
            except ValueError:
                vid = ident(tok[0], no, f"{key} id")
                xyz = (number(tok[1], no, "x"), number(tok[2], no, "y"), number(tok[3], no, "z"))
            if vid in obj.id_row or vid in obj.alias:
                raise err(f"{key}: vertex id {vid} defined twice", no)
            obj.id_row[vid] = len(obj.xyz)
            obj.ids.append(vid)
            obj.xyz.append(xyz)
            obj.vlines.append(no)
            # VRTX carries no properties (trailing tokens are flags such as CNXYZ).
            obj.props.append(values(tok[4:], no, key)
                             if properties and key == "PVRTX" and obj.prop_names else [])
        elif key in ("ATOM", "PATOM"):
            tok = rest.split()
            if len(tok) < 2:
                raise err(f"{key}: expected 'id vertex_id', got {s[:80]!r}", no)
            vid = ident(tok[0], no, f"{key} id")
            ref = ident(tok[1], no, f"{key} vertex id")
            if vid in obj.id_row or vid in obj.alias:
                raise err(f"{key}: vertex id {vid} defined twice", no)
            if ref in obj.alias:
                ref_row = obj.alias[ref]
            elif ref in obj.id_row:
                ref_row = obj.id_row[ref]
            else:
                raise err(f"{key} {vid} refers to vertex {ref}, which is not defined before it", no)
            if atoms == "merge":
                obj.alias[vid] = ref_row
            else:
                obj.id_row[vid] = len(obj.xyz)
                obj.ids.append(vid)
                obj.xyz.append(obj.xyz[ref_row])
                obj.vlines.append(no)
                own = (values(tok[2:], no, key)
                       if properties and key == "PATOM" and obj.prop_names else [])
                obj.props.append(own or list(obj.props[ref_row]))
        elif key == "TRGL":
            tok = rest.split()
            if len(tok) < 3:
                raise err(f"TRGL: expected three vertex ids, got {s[:80]!r}", no)
            try:
                tri = (int(tok[0]), int(tok[1]), int(tok[2]))
                if "_" in rest or not (_ID_MIN <= min(tri) and max(tri) <= _ID_MAX):
                    raise ValueError(rest)
                obj.tri_ids.append(tri)
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
            objects.append(obj)
            obj = None
        elif key == "HEADER" or s.endswith("{"):
            inner = s.partition("{")[2]
            if not s.count("{"):
                raise err("HEADER: expected '{'", no)
            block_end = "HEADER" if key == "HEADER" else "OTHER"
            block_line, last_header_key = no, ""
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
        elif key in ("ZPOSITIVE", "AXIS_UNIT"):
            crs_field(key, rest, no)
        elif key == "GOCAD_ORIGINAL_COORDINATE_SYSTEM":
            in_crs = True
            obj.crs_line = no
        elif key == "GEOLOGICAL_TYPE":
            obj.geological_type = _unquote(rest).lower()
        elif key == "PROPERTIES":
            obj.prop_names = split_quoted(rest)
        elif key == "ESIZES":
            try:
                obj.esizes = [int(t) for t in rest.split()]
            except ValueError:
                raise err(f"ESIZES: expected integers, got {rest!r}", no) from None
            if any(e < 1 for e in obj.esizes):
                raise err(f"ESIZES: sizes must be positive, got {rest!r}", no)
        elif key == "NO_DATA_VALUES":
            try:
                obj.no_data = [float(t) for t in rest.split()]
            except ValueError:
                raise err(f"NO_DATA_VALUES: expected numbers, got {rest!r}", no) from None
        elif key in ("TFACE", "ILINE"):
            if obj.kind == "Model3d" and key == "TFACE":
                tok = split_quoted(rest)
                if len(tok) >= 3:
                    obj.tfaces.append((tok[1].lower(), " ".join(tok[2:])))
            else:
                obj.parts += 1
        elif key == "TSURF" and obj.kind == "Model3d":
            obj.tsurfs.append(" ".join(split_quoted(rest)))
        elif key.startswith("BEGIN_"):
            skip_until = "END_" + key[len("BEGIN_"):]
        elif key == "GOCAD":
            raise err(f"'GOCAD {rest}' starts a new object, but the {obj.kind} object started at "
                      f"line {obj.line} has no END", no)
        # Anything else (BSTONE, BORDER, GEOLOGICAL_FEATURE, REGION, ...) is ignored.
    if block_end is not None:
        raise err(f"unexpected end of file: the {'HEADER' if block_end == 'HEADER' else 'brace'} "
                  f"block opened at line {block_line} has no closing '}}'", len(lines))
    if obj is not None:
        raise err(f"unexpected end of file: the {obj.kind} object started at line {obj.line} "
                  f"has no END", len(lines))
    return objects


def _rows(path: Path, obj: _Object, ids: np.ndarray, lines: List[int], what: str) -> np.ndarray:
    """Map file vertex ids to rows (vectorised), naming the line of an unknown id."""
    if not obj.alias and obj.ids:
        # Common case (faultmesh's own files and most exports): ids k0, k0+1, ...
        first = obj.ids[0]
        if obj.ids[-1] - first == len(obj.ids) - 1 and \
                np.array_equal(np.asarray(obj.ids), np.arange(first, first + len(obj.ids))):
            rows = ids - first
            ok = (rows >= 0) & (rows < len(obj.ids))
            if ok.all():
                return rows
    keys = np.array(list(obj.id_row.keys()) + list(obj.alias.keys()), dtype=np.int64)
    vals = np.array(list(obj.id_row.values()) + list(obj.alias.values()), dtype=np.int64)
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


def _xyz(path: Path, obj: _Object) -> np.ndarray:
    xyz = np.array(obj.xyz, dtype=np.float64).reshape(-1, 3)
    bad = ~np.all(np.isfinite(xyz), axis=1)
    if bad.any():   # float() accepts "nan" and "inf" on the fast path
        r = int(np.flatnonzero(bad)[0])
        raise ModelFileError(path, f"non-finite vertex coordinates {xyz[r].tolist()}",
                             obj.vlines[r])
    xyz[:, 2] *= obj.z_sign
    if obj.axis_scale != (1.0, 1.0, 1.0):
        xyz *= np.asarray(obj.axis_scale)
    return xyz


def _properties(path: Path, obj: _Object) -> Dict[str, np.ndarray]:
    if not obj.prop_names or not obj.props or not all(len(p) for p in obj.props):
        return {}
    counts = np.array([len(p) for p in obj.props])
    if np.any(counts != counts[0]):
        # ESIZES (or PROPERTIES) changed between the PVRTX lines.
        r = int(np.flatnonzero(counts != counts[0])[0])
        raise ModelFileError(path, f"this vertex has {counts[r]} property value(s) where the "
                                   f"first PVRTX (line {obj.vlines[0]}) has {counts[0]}",
                             obj.vlines[r])
    sizes = obj.esizes if len(obj.esizes) == len(obj.prop_names) else [1] * len(obj.prop_names)
    allp = np.array(obj.props, dtype=np.float64).reshape(len(obj.props), -1)
    if allp.shape[1] != sum(sizes):
        return {}
    nodata = obj.no_data if len(obj.no_data) == len(obj.prop_names) else [None] * len(sizes)
    props, c = {}, 0
    for pname, sz, nd in zip(obj.prop_names, sizes, nodata):
        col = allp[:, c] if sz == 1 else allp[:, c:c + sz]
        if nd is not None:
            col = np.where(col == nd, np.nan, col)
        name, n = pname or f"property_{c}", 2
        while name in props:
            name, n = f"{pname} ({n})", n + 1
        props[name] = col
        c += sz
    return props


def _boundary_from(path: Path, objects: List[_Object]) -> Optional[np.ndarray]:
    for obj in objects:
        if obj.kind == "PLine" and obj.header.get("faultmesh_role") == "boundary" and obj.xyz:
            return _xyz(path, obj)[:, :2].copy()   # in metres, as the surfaces
    return None


def read_gocad(path, atoms: str = "copy", properties: bool = True):
    """Read the ``TSurf`` objects of a GOCAD ``.ts`` or ``.ml`` file into a
    :class:`faultmesh.Model` (see the module docstring for what is accepted).

    ``atoms``: ``"copy"`` (default) gives every ATOM its own vertex at the
    referenced position, as the file's topology says; ``"merge"`` makes it the
    same vertex as the one it references. The study boundary comes from a
    faultmesh boundary PLine in the file or in ``<stem>_boundary.pl`` beside it.
    ``properties=False`` reads the geometry alone: PVRTX property values are
    not read (nor checked).
    """
    from ..model import Model, Surface

    if atoms not in ("copy", "merge"):
        raise ValueError(f"read_gocad: atoms must be 'copy' or 'merge', got {atoms!r}")
    path = Path(path)
    objects = _parse(path, read_text(path), atoms, properties)
    layers: List[Tuple[float, int, Surface]] = []
    faults: List[Tuple[float, int, Surface]] = []
    skipped: List[Dict[str, object]] = []
    model_name = ""
    crs = ""
    used = set()
    ml_types: Dict[str, str] = {}
    model3d: Optional[_Object] = None
    for obj in objects:
        if obj.kind == "Model3d":
            model_name = model_name or obj.header.get("name", "")
            crs = crs or _crs_of(obj)
            model3d = model3d or obj
            for gtype, name in obj.tfaces:
                ml_types.setdefault(name, gtype)
    if model3d is not None and model3d.crs_line:
        # A TSurf of a Model3d without a coordinate system block of its own
        # is in the model's (its ZPOSITIVE and AXIS_UNIT).
        for obj in objects:
            if obj.kind.lower() == "tsurf" and not obj.crs_line:
                obj.z_sign, obj.axis_scale = model3d.z_sign, model3d.axis_scale
    for k, obj in enumerate(objects):
        if obj.kind.lower() != "tsurf":
            continue
        name = obj.header.get("name", "") or f"surface_{k}"
        gtype = obj.geological_type or ml_types.get(" ".join(name.split()), "")
        xyz = _xyz(path, obj)
        if obj.tri_ids:
            tri = _rows(path, obj, np.array(obj.tri_ids, dtype=np.int64), obj.tri_lines, "TRGL")
        else:
            tri = np.zeros((0, 3), dtype=np.int64)
        if gtype in _BOUNDARY_TYPES and "faultmesh_kind" not in obj.header:
            skipped.append({"name": name, "type": gtype, "vertices": len(xyz),
                            "triangles": len(tri)})
            continue
        base, n = name, 2
        while name in used:
            name = f"{base} ({n})"
            n += 1
        used.add(name)
        meta: Dict[str, object] = {}
        if obj.parts > 1:
            meta["tface_parts"] = obj.parts
        props = _properties(path, obj)
        if props:
            meta["vertex_properties"] = props
        kind = obj.header.get("faultmesh_kind") or ("fault" if "fault" in gtype else "layer")
        if kind not in ("layer", "fault"):
            raise ModelFileError(path, f"faultmesh_kind must be layer or fault, got {kind!r}",
                                 obj.line)
        if gtype in ("normal_fault", "reverse_fault"):
            meta["kind"] = gtype.split("_")[0]
        try:
            order = float(obj.header.get("faultmesh_order", k))
        except ValueError:
            order = float(k)
        model_name = model_name or obj.header.get("faultmesh_model", "")
        crs = crs or obj.header.get("faultmesh_crs", "") or _crs_of(obj)
        surf = Surface(name=name, vertices=xyz, triangles=tri, kind=kind, metadata=meta)
        (layers if kind == "layer" else faults).append((order, k, surf))
    if not layers and not faults:
        what = "no 'GOCAD TSurf' object found" if not skipped else \
            "only boundary surfaces (GEOLOGICAL_TYPE boundary/lease), no layer or fault"
        raise ModelFileError(path, what)
    boundary = _boundary_from(path, objects)
    bp = boundary_path(path)
    if boundary is None and bp.is_file():
        try:
            boundary = _boundary_from(bp, _parse(bp, read_text(bp), atoms))
        except ModelFileError as e:
            raise ModelFileError(bp, f"the boundary file beside {path.name} cannot be read: "
                                     f"{str(e).split(': ', 1)[-1]}", e.line) from None
    layers.sort(key=lambda t: (t[0], t[1]))
    faults.sort(key=lambda t: (t[0], t[1]))
    meta = {"gocad_boundary_surfaces": skipped} if skipped else {}
    return Model(name=model_name or path.stem, surfaces={s.name: s for _, _, s in layers},
                 faults={s.name: s for _, _, s in faults}, boundary=boundary, crs=crs,
                 metadata=meta)


def _crs_of(obj: _Object) -> str:
    return obj.crs_name if obj.crs_name and obj.crs_name != "Default" else ""


# Kept for callers of the old name.
read_ts = read_gocad
read_ml = read_gocad


def read_pl(path):
    """Read a GOCAD ``.pl`` (PLine objects) into a model without surfaces: the
    boundary is a faultmesh boundary PLine, else the first closed line; every
    line is kept in ``model.metadata["polylines"]`` (name -> vertices as
    ``[[x, y, z], ...]`` and 0-based ``segments``)."""
    from ..model import Model

    path = Path(path)
    objects = _parse(path, read_text(path), "copy")
    lines: Dict[str, Dict[str, list]] = {}
    boundary = _boundary_from(path, objects)
    crs = ""
    for k, obj in enumerate(objects):
        if obj.kind.lower() != "pline":
            continue
        xyz = _xyz(path, obj)
        seg = np.zeros((0, 2), dtype=np.int64)
        if obj.seg_ids:
            seg = _rows(path, obj, np.array(obj.seg_ids, dtype=np.int64),
                        [obj.line] * len(obj.seg_ids), "SEG")
        name = obj.header.get("name", "") or f"line_{k}"
        base, n = name, 2
        while name in lines:
            name, n = f"{base} ({n})", n + 1
        lines[name] = {"vertices": xyz.tolist(), "segments": seg.tolist()}
        crs = crs or _crs_of(obj)
        if boundary is None and len(seg) >= 3 and len(seg) == len(xyz):
            # A closed ring written in order: each segment starts where the
            # previous one ends and the last returns to the first vertex.
            if np.array_equal(seg[1:, 0], seg[:-1, 1]) and seg[-1, 1] == seg[0, 0] and \
                    len(np.unique(seg[:, 0])) == len(seg):
                boundary = xyz[seg[:, 0], :2].copy()
    if not lines:
        raise ModelFileError(path, "no 'GOCAD PLine' object found")
    return Model(name=path.stem, surfaces={}, boundary=boundary, crs=crs,
                 metadata={"polylines": lines})
