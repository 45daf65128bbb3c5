"""Shared helpers of the file formats: errors, atomic writes, exact floats, names.

Every writer goes through :class:`AtomicFiles`: the content is written to a
temporary file beside the target and renamed over it only once every file of
the write is complete, so an error (or a Ctrl-C) never leaves a half-written
model behind and never clobbers a good older file.
"""
from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path
from typing import IO, Dict, Iterable, List, Optional, Sequence, Tuple

import numpy as np


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m


_UMASK = _umask()


class ModelFileError(ValueError):
    """A model file that cannot be read: the message names the file, the line
    (1-based) when there is one, what was expected and what was found."""

    def __init__(self, path, message: str, line: Optional[int] = None) -> None:
        self.path = str(path)
        self.line = line
        where = f"{self.path}, line {line}" if line is not None else self.path
        super().__init__(f"{where}: {message}")


class AtomicFiles:
    """Context manager collecting files written under temporary names.

    ``open(target)`` returns a text (or binary) handle on a temporary file in
    the target's folder; ``temp_path(target)`` just reserves a temporary path
    (for writers that want a file name, like meshio). On a clean exit every
    temporary file is renamed onto its target (``os.replace``, atomic on one
    file system; see :meth:`_commit` for a rename failing half-way); on an
    exception every temporary file is deleted and no target is touched.
    """

    def __init__(self) -> None:
        self._pending: List[Tuple[Path, Path]] = []
        self._handles: List[IO] = []

    def temp_path(self, target) -> Path:
        target = Path(target)
        target.parent.mkdir(parents=True, exist_ok=True)
        # Keep the real suffix last: some writers infer the format from it.
        fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=f".tmp{target.suffix}",
                                   dir=target.parent)
        os.close(fd)
        # mkstemp creates 0600; give the file the permissions a plain open() would.
        os.chmod(tmp, 0o666 & ~_UMASK)
        self._pending.append((Path(tmp), target))
        return Path(tmp)

    def pending(self, target) -> bool:
        """Whether ``target`` is already written by this set of files."""
        target = Path(target)
        return any(t == target for _, t in self._pending)

    def open(self, target, mode: str = "w") -> IO:
        tmp = self.temp_path(target)
        if "b" in mode:
            fh = open(tmp, mode)
        else:
            # newline="\n": the same bytes on every platform (diff-able files).
            fh = open(tmp, mode, encoding="utf-8", newline="\n")
        self._handles.append(fh)
        return fh

    def __enter__(self) -> "AtomicFiles":
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        for fh in self._handles:
            if not fh.closed:
                if exc_type is None:
                    fh.flush()
                    os.fsync(fh.fileno())
                fh.close()
        if exc_type is None:
            self._commit()
        else:
            self._cleanup()
        return False

    def _commit(self) -> None:
        """Rename every temporary file onto its target. If a rename fails
        half-way, the targets already replaced get their old content back
        (kept as hard links, or copies where links are not possible) and new
        ones are removed, so a multi-file write is all-or-nothing."""
        import shutil

        backups: List[Tuple[Path, Optional[Path]]] = []
        try:
            for tmp, target in self._pending:
                bak: Optional[Path] = None
                if target.exists():
                    bak = target.with_name(f".{target.name}.{os.getpid()}.bak")
                    try:
                        if bak.exists():
                            bak.unlink()
                        os.link(target, bak)
                    except OSError:
                        shutil.copy2(target, bak)
                try:
                    os.replace(tmp, target)
                except BaseException:
                    if bak is not None:
                        bak.unlink()
                    raise
                backups.append((target, bak))
        except BaseException:
            for target, bak in reversed(backups):
                try:
                    if bak is not None:
                        os.replace(bak, target)
                    else:
                        target.unlink()
                except OSError:  # pragma: no cover (best effort on a failing disk)
                    pass
            self._cleanup()
            raise
        for _, bak in backups:
            if bak is not None:
                try:
                    bak.unlink()
                except OSError:  # pragma: no cover
                    pass

    def _cleanup(self) -> None:
        for tmp, _ in self._pending:
            try:
                tmp.unlink()
            except FileNotFoundError:
                pass


class _Shared:
    """Use an outer :class:`AtomicFiles` inside ``with``: commit/cleanup is left
    to the outer one (several files written all-or-nothing)."""

    def __init__(self, files: AtomicFiles) -> None:
        self.files = files

    def __enter__(self) -> AtomicFiles:
        return self.files

    def __exit__(self, *exc) -> bool:
        return False


def format_floats(a: np.ndarray) -> List[str]:
    """Rows of ``a`` (n, k) as space-separated shortest round-trip decimals.

    Python's ``repr`` of a float is the shortest string that reads back as the
    identical double (at most 17 significant digits), so a write/read cycle
    keeps every coordinate bit for bit. ``tolist`` gives Python floats (numpy
    scalars would print as ``np.float64(...)``).
    """
    a = np.asarray(a, dtype=np.float64)
    if not len(a):
        # An empty surface (no vertices) is a valid model part: no rows. (numpy
        # cannot reshape size 0 to (0, -1).)
        return []
    if a.size and not np.all(np.isfinite(a)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(a.reshape(len(a), -1)), axis=1))[0])
        raise ValueError(f"cannot write non-finite coordinates (row {bad}: {a[bad].tolist()})")
    rep = float.__repr__
    return [" ".join(map(rep, row)) for row in a.reshape(len(a), -1).tolist()]


def format_ints(a: np.ndarray, offset: int = 0) -> List[str]:
    a = np.asarray(a, dtype=np.int64)
    if not len(a):
        return []   # an empty surface: no rows (see format_floats)
    return [" ".join(map(str, row)) for row in (a.reshape(len(a), -1) + offset).tolist()]


_SLUG = re.compile(r"[^A-Za-z0-9._-]+")


def free_name(name: str, taken, counters: Optional[Dict[str, int]] = None) -> str:
    """``name``, or ``name (2)``, ``name (3)``... the first not in ``taken``:
    readers keep two surfaces of one name (a file may repeat one) apart.

    ``counters`` (one dict per ``taken``, kept by the caller across calls)
    remembers the next number to try for each name, so that n surfaces of one
    name cost n look-ups in all, not n^2/2 (a .vtm of 5,000 blocks of one
    name took 9 s)."""
    if name not in taken:
        return name
    n = counters.get(name, 2) if counters is not None else 2
    out = f"{name} ({n})"
    while out in taken:
        n += 1
        out = f"{name} ({n})"
    if counters is not None:
        counters[name] = n + 1
    return out


def surface_kind(text: Optional[str]) -> str:
    """``layer`` or ``fault`` from a file's kind field (``fault`` when it
    names a fault: ``Fault``, ``fault_surface``...; else ``layer``)."""
    k = (text or "layer").strip().lower()
    return k if k in ("layer", "fault") else ("fault" if "fault" in k else "layer")


def slug(name: str) -> str:
    """A file-name-safe form of a surface or model name (other characters -> ``_``)."""
    s = _SLUG.sub("_", str(name)).strip("._")
    return s or "unnamed"


def parse_numbers(path, lines: Sequence[str], linenos: Sequence[int], ncols: int, what: str,
                  kind=float, context: str = "") -> np.ndarray:
    """Parse ``lines`` (each exactly ``ncols`` numbers) into an (n, ncols) array.

    Fast path: one bulk conversion. If that fails (or a row has the wrong
    number of fields), walk the rows to report the first bad one with its
    1-based line number (``linenos[i]`` is the number of ``lines[i]``).
    ``context`` is appended to the message (e.g. which block announced the rows).
    """
    n = len(lines)
    dtype = np.float64 if kind is float else np.int64
    if n == 0:
        return np.zeros((0, ncols), dtype=dtype)
    try:
        flat = np.array(" ".join(lines).split(), dtype=dtype)
        # The total can be right while one row is short and the next long, so
        # the per-row field counts are checked too (cheap next to parsing).
        if flat.size == n * ncols and all(ln.count(" ") + 1 == ncols or len(ln.split()) == ncols
                                          for ln in lines):
            out = flat.reshape(n, ncols)
            if kind is not float or np.all(np.isfinite(out)):
                return out
    except (ValueError, OverflowError):
        pass
    noun = "numbers" if kind is float else "integers"
    for i, ln in enumerate(lines):
        parts = ln.split()
        if len(parts) != ncols:
            raise ModelFileError(path, f"expected {ncols} {noun} ({what}), got {len(parts)} "
                                       f"field(s): {ln.strip()!r}{context}", linenos[i])
        try:
            vals = [kind(p) for p in parts]
        except (ValueError, OverflowError):
            raise ModelFileError(path, f"expected {ncols} {noun} ({what}), got {ln.strip()!r}"
                                       f"{context}", linenos[i]) from None
        if kind is float and not all(np.isfinite(vals)):
            raise ModelFileError(path, f"non-finite {what} in {ln.strip()!r}{context}", linenos[i])
    raise AssertionError("parse_numbers: unreachable")  # pragma: no cover


def split_lines(text: str) -> List[str]:
    """Lines of a model file: split on ``\n`` only (``\r\n`` tolerated).

    ``str.splitlines`` would also split on characters such as U+0085, U+001E
    or U+2028, which may legally occur inside a quoted name."""
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    return [ln[:-1] if ln.endswith("\r") else ln for ln in lines]


def iter_numbered(text: str) -> Iterable[Tuple[int, str]]:
    """(1-based line number, line without the end-of-line) pairs."""
    return enumerate(split_lines(text), start=1)


def read_text(path) -> str:
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise ModelFileError(path, "is a directory, expected a file") from None
    try:
        return data.decode("utf-8-sig")  # a byte-order mark (Windows editors) is no content
    except UnicodeDecodeError as e:
        # GOCAD files from Windows tools are often Latin-1; the geometry is ASCII.
        try:
            return data.decode("latin-1")
        except UnicodeDecodeError:  # pragma: no cover (latin-1 decodes any byte)
            raise ModelFileError(path, f"not a text file ({e})") from None


# --------------------------------------------------------------------------
# calling other libraries
# --------------------------------------------------------------------------

def guarded(path, what: str, fn, *args, **kwargs):
    """Call a reader or writer of another library on ``path``; whatever it
    raises (meshio calls ``sys.exit`` on some files, h5py and VTK raise their
    own types) becomes a :class:`ModelFileError` naming the file and ``what``
    was being done; so does a MemoryError ("too large to read").
    KeyboardInterrupt, a missing optional package (ImportError), a missing
    file and a ModelFileError of ours pass through as they are."""
    try:
        return fn(*args, **kwargs)
    except (KeyboardInterrupt, ModelFileError, ImportError, FileNotFoundError):
        raise
    except MemoryError as e:
        # A reader asked for more memory than there is (a file too large for
        # this machine, or a header count no check caught): an error naming
        # the file, not a bare MemoryError from deep inside numpy.
        detail = str(e).strip().splitlines()[0] if str(e).strip() else "out of memory"
        raise ModelFileError(path, f"{what} failed: too large to read in the memory available "
                                   f"({detail})") from None
    except SystemExit as e:
        raise ModelFileError(path, f"{what} failed (the library tried to exit with status "
                                   f"{e.code!r})") from None
    except BaseException as e:  # noqa: BLE001 (any library error names the file)
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ModelFileError(path, f"{what} failed: {type(e).__name__}: {msg}") from None


def optional_import(module: str, extra: str, purpose: str):
    """Import an optional dependency or raise ImportError saying which extra
    installs it (``pip install faultmesh[<extra>]``)."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise ImportError(f"{purpose} needs the {module!r} package: pip install "
                          f"'faultmesh[{extra}]' ({e})") from None


# --------------------------------------------------------------------------
# per-surface arrays and the merged layout shared by the mesh formats
# --------------------------------------------------------------------------

#: Surface attributes holding one value per triangle, and their array names.
TRIANGLE_ATTRIBUTES = {"owner": "owner", "kinds": "kind"}


def model_surfaces(model) -> List[Tuple[object, str]]:
    """(surface, kind) in model order: layers top to bottom, then faults."""
    return [(s, "layer") for s in model.surfaces.values()] + \
           [(s, "fault") for s in model.faults.values()]


def _numeric(a) -> Optional[np.ndarray]:
    try:
        arr = np.asarray(a)
    except Exception:  # pragma: no cover (ragged objects)
        return None
    if arr.dtype.kind in "biuf":
        return arr
    return None


def vertex_properties(surf) -> Dict[str, np.ndarray]:
    """Numeric per-vertex arrays of a surface (``metadata["vertex_properties"]``)."""
    out: Dict[str, np.ndarray] = {}
    for name, val in ((surf.metadata or {}).get("vertex_properties") or {}).items():
        a = _numeric(val)
        if a is not None and a.ndim in (1, 2) and len(a) == surf.n_vertices:
            out[str(name)] = a
    return out


def triangle_arrays(surf) -> Dict[str, np.ndarray]:
    """Numeric per-triangle arrays of a surface: the ``owner``/``kinds``
    attributes when the surface has them (as ``owner``/``kind``) and
    ``metadata["triangle_properties"]``."""
    out: Dict[str, np.ndarray] = {}
    for attr, name in TRIANGLE_ATTRIBUTES.items():
        a = _numeric(getattr(surf, attr, None)) if getattr(surf, attr, None) is not None else None
        if a is not None and a.ndim == 1 and len(a) == surf.n_triangles:
            out[name] = a
    for name, val in ((surf.metadata or {}).get("triangle_properties") or {}).items():
        a = _numeric(val)
        if a is not None and a.ndim in (1, 2) and len(a) == surf.n_triangles:
            out.setdefault(str(name), a)
    return out


class Merged:
    """Every surface of a model in one mesh (vertices not shared between
    surfaces), with ``surface_id`` (model order) on points and cells, ``kind``
    (0 layer, 1 fault) on cells, the surfaces' own arrays (NaN where a surface
    lacks one), and the names and kinds for the file's field data."""

    def __init__(self, points, triangles, point_arrays, cell_arrays, names, kinds, name, crs):
        self.points = points
        self.triangles = triangles
        self.point_arrays: Dict[str, np.ndarray] = point_arrays
        self.cell_arrays: Dict[str, np.ndarray] = cell_arrays
        self.names: List[str] = names
        self.kinds: List[str] = kinds
        self.name = name
        self.crs = crs

    @classmethod
    def of(cls, model) -> "Merged":
        surfs = model_surfaces(model)
        nv = [s.n_vertices for s, _ in surfs]
        nt = [s.n_triangles for s, _ in surfs]
        offs = np.concatenate([[0], np.cumsum(nv)]).astype(np.int64)
        P = np.vstack([s.vertices for s, _ in surfs]) if surfs else np.zeros((0, 3))
        T = np.vstack([s.triangles + offs[k] for k, (s, _) in enumerate(surfs)]) if surfs \
            else np.zeros((0, 3), np.int64)
        sid = np.arange(len(surfs), dtype=np.int32)
        parrays = {"surface_id": np.repeat(sid, nv)}
        carrays = {"surface_id": np.repeat(sid, nt),
                   "kind": np.repeat(np.array([1 if k == "fault" else 0 for _, k in surfs],
                                              dtype=np.int32), nt)}
        _merge_arrays(parrays, [vertex_properties(s) for s, _ in surfs], nv, "vertex")
        _merge_arrays(carrays, [triangle_arrays(s) for s, _ in surfs], nt, "triangle")
        return cls(P, T, parrays, carrays, [str(s.name) for s, _ in surfs], [k for _, k in surfs],
                   str(model.name), str(model.crs or ""))


def _merge_arrays(out: Dict[str, np.ndarray], table: List[Dict[str, np.ndarray]],
                  counts: List[int], prefix: str) -> None:
    """Stack each named array over the surfaces (NaN rows where a surface has
    none or one of another width); a name faultmesh uses itself gets ``prefix_``."""
    names: List[str] = []
    for t in table:
        names += [n for n in t if n not in names]
    for n in names:
        width = max(t[n].reshape(len(t[n]), -1).shape[1] for t in table if n in t)
        cols = []
        for t, c in zip(table, counts):
            a = t[n].reshape(c, -1) if n in t else None
            cols.append(a.astype(np.float64) if a is not None and a.shape[1] == width
                        else np.full((c, width), np.nan))
        a = np.vstack(cols) if cols else np.zeros((0, width))
        key = n if n not in out else f"{prefix}_{n}"
        out[key] = a[:, 0] if width == 1 else a


def _unprefix(arrays: Dict[str, np.ndarray], prefix: str, reserved: Tuple[str, ...]):
    return {(k[len(prefix) + 1:] if k.startswith(prefix + "_") and k[len(prefix) + 1:] in reserved
             else k): v for k, v in arrays.items()}


_PLURAL = {"vertex": "vertices"}


def drop_non_finite(path, P: np.ndarray, T: np.ndarray, point_arrays: Dict[str, np.ndarray],
                    sizes: Optional[Sequence[int]] = None, noun: str = "point"):
    """NaN/inf coordinates make no surface (every quantity derived from the
    triangles touching them is NaN) and no writer can store them: a point a
    triangle uses is refused, naming it (``noun`` and its index; ``sizes``,
    the point counts of a file's pieces, give the piece too), as the GOCAD
    and STL readers do; one no triangle uses (a placeholder some tools
    write) is dropped. Returns (points, triangles, point arrays)."""
    bad = ~np.all(np.isfinite(P), axis=1)
    if not bad.any():
        return P, T, point_arrays
    used = np.zeros(len(P), bool)
    used[np.asarray(T, np.int64).reshape(-1)] = True
    hit = np.flatnonzero(bad & used)
    if len(hit):
        j = int(hit[0])
        sizes = list(sizes) if sizes is not None else [len(P)]
        piece = int(np.searchsorted(np.cumsum(sizes), j, side="right"))
        where = f"{noun} {j - sum(sizes[:piece])}" + (f" of piece {piece}" if len(sizes) > 1
                                                       else "")
        raise ModelFileError(path, f"{where} has non-finite coordinates {P[j].tolist()} "
                                   f"({len(hit)} such {_PLURAL.get(noun, noun + 's')} used by "
                                   "triangles)")
    keep = ~bad
    remap = np.cumsum(keep) - 1
    return P[keep], remap[T], {k: np.asarray(v)[keep] for k, v in point_arrays.items()}


def walk_starts(nxt: np.ndarray, n: int) -> np.ndarray:
    """The first ``n`` positions of the walk 0, nxt[0], nxt[nxt[0]], ... over
    records of varying length (``nxt[j]``: where the record starting at j
    would end, ``len(nxt)`` or more where no record can start at j: a bad
    count, or one running past the data). Pointer doubling: log2(n)
    vectorised passes, not a Python step per record (legacy VTK cell lists,
    PLY faces of mixed sizes). Stops early, with fewer than ``n`` positions,
    where the walk reaches such a j; the last position returned is then the
    record at fault."""
    m = len(nxt)
    if n == 0 or m == 0:
        return np.zeros(0, np.int64)
    idx = np.int32 if m < 2 ** 31 - 1 else np.int64     # half the memory traffic
    jump = np.append(np.minimum(np.asarray(nxt, np.int64), m), m).astype(idx)   # jump[m] = m
    starts = np.zeros(1, idx)                # the records 0 .. 2^k - 1
    while len(starts) < n:
        starts = np.concatenate([starts, jump[starts]])
        jump = jump[jump]
    starts = starts[:n].astype(np.int64)
    ended = np.flatnonzero(starts >= m)
    return starts[:ended[0]] if len(ended) else starts


def _all_nan(a: np.ndarray) -> bool:
    return a.size > 0 and a.dtype.kind == "f" and bool(np.isnan(a).all())


def split_merged(path, points: np.ndarray, triangles: np.ndarray,
                 point_arrays: Dict[str, np.ndarray], cell_arrays: Dict[str, np.ndarray],
                 names: Optional[Sequence[str]] = None, kinds: Optional[Sequence[str]] = None,
                 model_name: str = "", crs: str = ""):
    """A :class:`Model` from one mesh: split by the ``surface_id`` point array
    when present (names and kinds from the field data, else ``surface_<id>``
    and the ``kind`` cell array), else one layer named after the file. Other
    point/cell arrays go to each surface's ``metadata["vertex_properties"]`` /
    ``["triangle_properties"]``."""
    from ..model import Model, Surface

    path = Path(path)
    P = np.asarray(points, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if T.size and (T.min() < 0 or T.max() >= len(P)):
        row = int(np.flatnonzero(np.any((T < 0) | (T >= len(P)), axis=1))[0])
        v = int(T[row][(T[row] < 0) | (T[row] >= len(P))][0])
        raise ModelFileError(path, f"triangle {row} refers to vertex {v}, outside "
                                   f"0..{len(P) - 1}")
    pa = {k: np.asarray(v) for k, v in point_arrays.items() if len(v) == len(P)}
    ca = {k: np.asarray(v) for k, v in cell_arrays.items() if len(v) == len(T)}
    sid = pa.pop("surface_id", None)
    ca.pop("surface_id", None)  # the per-vertex ids decide; a cell copy is not an array to keep
    kind_c = ca.pop("kind", None) if sid is not None else None

    def meta(vsel, tsel) -> Dict[str, object]:
        # A surface that lacked an array in the merged file has only NaN
        # there (Merged fills them): it gets no such array back.
        m: Dict[str, object] = {}
        vp = {k: v[vsel] for k, v in pa.items() if not _all_nan(v[vsel])}
        tp = {k: v[tsel] for k, v in ca.items() if not _all_nan(v[tsel])}
        if vp:
            m["vertex_properties"] = _unprefix(vp, "vertex", ("surface_id",))
        if tp:
            m["triangle_properties"] = _unprefix(tp, "triangle", ("surface_id", "kind"))
        return m

    stem = model_name or path.stem
    if sid is None:
        surf = Surface(name=path.stem, vertices=P, triangles=T,
                       metadata=meta(np.arange(len(P)), np.arange(len(T))))
        return Model(name=stem, surfaces={surf.name: surf}, crs=crs)
    sid = np.asarray(sid).reshape(len(P), -1)[:, 0] if len(P) else np.zeros(0, np.int64)
    if not np.all(np.isfinite(sid)) or not np.array_equal(sid, np.round(sid)):
        raise ModelFileError(path, "point array surface_id holds values that are not integers")
    sid = sid.astype(np.int64)
    tsid = sid[T] if len(T) else np.zeros((0, 3), np.int64)
    if len(T) and not np.all(tsid == tsid[:, :1]):
        row = int(np.flatnonzero(~np.all(tsid == tsid[:, :1], axis=1))[0])
        raise ModelFileError(path, f"triangle {row} joins vertices of different surface_id "
                                   f"values {tsid[row].tolist()}")
    layers: Dict[str, Surface] = {}
    faults: Dict[str, Surface] = {}
    counters: Dict[int, Dict[str, int]] = {0: {}, 1: {}}
    ids = np.unique(sid).tolist()
    use_names = names is not None and len(names) > (max(ids) if ids else -1) and min(ids + [0]) >= 0
    if use_names:
        # Every named surface, also one without vertices: an empty surface
        # written by faultmesh comes back (empty) instead of vanishing.
        ids = list(range(len(names)))
    # One group-by of the vertices and of the triangles by surface_id (a
    # stable sort), not a scan of every vertex per id: a file with one id per
    # vertex (50,000 surfaces) took seconds.
    vorder = np.argsort(sid, kind="stable")
    vsorted = sid[vorder]
    local = np.empty(len(P), dtype=np.int64)
    local[vorder] = np.arange(len(P)) - np.searchsorted(vsorted, vsorted, side="left")
    t0 = tsid[:, 0] if len(T) else np.zeros(0, np.int64)
    torder = np.argsort(t0, kind="stable")
    tsorted = t0[torder]
    ida = np.asarray(ids, dtype=np.int64)
    vlo, vhi = np.searchsorted(vsorted, ida, "left"), np.searchsorted(vsorted, ida, "right")
    tlo, thi = np.searchsorted(tsorted, ida, "left"), np.searchsorted(tsorted, ida, "right")
    for j, k in enumerate(ids):
        vsel = vorder[vlo[j]:vhi[j]]
        tsel = torder[tlo[j]:thi[j]]
        if kinds is not None and use_names and k < len(kinds):
            is_fault = str(kinds[k]).lower() == "fault"
        else:
            is_fault = kind_c is not None and len(tsel) and int(np.asarray(kind_c)[tsel[0]]) == 1
        name = str(names[k]) if use_names else f"surface_{k}"
        target = faults if is_fault else layers
        name = free_name(name, target, counters[int(bool(is_fault))])
        target[name] = Surface(name=name, vertices=P[vsel], triangles=local[T[tsel]],
                               kind="fault" if is_fault else "layer", metadata=meta(vsel, tsel))
    return Model(name=stem, surfaces=layers, faults=faults, crs=crs)
