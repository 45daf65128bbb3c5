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
from typing import IO, Iterable, List, Optional, Sequence, Tuple

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
    if a.size and not np.all(np.isfinite(a)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(a.reshape(len(a), -1)), axis=1))[0])
        raise ValueError(f"cannot write non-finite coordinates (row {bad}: {a[bad].tolist()})")
    rep = float.__repr__
    return [" ".join(map(rep, row)) for row in a.reshape(len(a), -1).tolist()]


def format_ints(a: np.ndarray, offset: int = 0) -> List[str]:
    a = np.asarray(a, dtype=np.int64)
    return [" ".join(map(str, row)) for row in (a.reshape(len(a), -1) + offset).tolist()]


_SLUG = re.compile(r"[^A-Za-z0-9._-]+")


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
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        # GOCAD files from Windows tools are often Latin-1; the geometry is ASCII.
        try:
            return data.decode("latin-1")
        except UnicodeDecodeError:  # pragma: no cover (latin-1 decodes any byte)
            raise ModelFileError(path, f"not a text file ({e})") from None
