"""Run folders: the outputs of one ``faultmesh build``/``demo`` run are
replaced together, never mixed with an older run's, never half-read.

A run writes every file into a fresh hidden staging folder inside the output
folder, ``.faultmesh-run.XXXXXXXX.tmp/``, and finishes with a manifest,
``run.json``: the files of the run (size and SHA-256 each), the model file
readers should open, the command, faultmesh version, time and dataset.
Then it is swapped in:

1. the staging folder (holding the new ``run.json`` and a copy of the old
   one) is renamed to ``.faultmesh-swap/``: one atomic rename, the commit
   point. From here on the new run is the folder's run;
2. the files listed in the OLD manifest and absent from the new one are
   deleted (only those: a user's other files are never touched);
3. each new file is renamed into place (``os.replace``, atomic per file);
4. the new ``run.json`` is renamed over the old one; ``.faultmesh-swap/`` is
   removed.

What a kill leaves, and what readers (:func:`current_run`,
``load_model(folder)``, ``faultmesh quality/plot FOLDER``) see:

* before step 1: the old run complete, plus a staging folder (never read);
* during steps 2-4: ``.faultmesh-swap/run.json`` exists and readers take the
  NEW run, each file from ``.faultmesh-swap/`` if it is still there, else
  from the folder (a rename moves each file whole, so every file is
  complete). An ``ls`` may show a mix until the next run finishes the swap;
* after step 4: the new run complete.

The next run that writes into the folder finishes an interrupted swap (roll
forward) and removes stale staging folders and our own temporary files
(``AtomicFiles``: ``.NAME.XXXXXXXX.tmp[.EXT]``, ``.NAME.PID.bak``). A run
holds an exclusive lock (``flock``) on the output folder while it works, so
anything matching those names when it starts was left by a run that died;
a second run into the same folder at the same time is refused. Where file
locks do not exist (Windows), only leftovers older than an hour count as
stale.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, Iterable, List, Optional

MANIFEST = "run.json"
MANIFEST_FORMAT = 1
SWAP = ".faultmesh-swap"
_OLD = ".old-run.json"
_STAGING_PREFIX = ".faultmesh-run."
#: Without file locks, leftovers younger than this may belong to a live run.
STALE_SECONDS = 3600.0

# Our temporary names (tempfile's random part: 8 of [a-z0-9_]):
# AtomicFiles.temp_path ".{stem}.XXXXXXXX.tmp{suffix}", its commit backups
# ".{name}.{pid}.bak", and staging folders ".faultmesh-run.XXXXXXXX.tmp".
_TEMP_NAMES = (re.compile(r"^\..+\.[a-z0-9_]{8}\.tmp(\.[A-Za-z0-9]+)?$"),
               re.compile(r"^\..+\.\d+\.bak$"))
_STAGING_NAME = re.compile(r"^\.faultmesh-run\.[a-z0-9_]{8}\.tmp$")


class RunFolderError(OSError):
    """An output folder that cannot take a run (a file in its place, another
    run writing into it, an unreadable manifest)."""


def is_temp_name(name: str) -> bool:
    """True for names of our temporary files and folders (never results)."""
    return bool(_STAGING_NAME.match(name) or name == SWAP
                or any(p.match(name) for p in _TEMP_NAMES))


# ---------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------
def _read_manifest(path: Path) -> Optional[Dict[str, Any]]:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise RunFolderError(f"{path}: not a readable run manifest ({e})") from None
    if not isinstance(doc, dict) or doc.get("faultmesh_run") != MANIFEST_FORMAT \
            or not isinstance(doc.get("files"), list):
        raise RunFolderError(f"{path}: not a faultmesh run manifest (format {MANIFEST_FORMAT})")
    for f in doc["files"]:
        if not isinstance(f, dict) or not isinstance(f.get("path"), str):
            raise RunFolderError(f"{path}: not a faultmesh run manifest (a file entry without "
                                 "a path)")
        _safe_rel(f["path"], path.parent)
    if doc.get("model") is not None and not isinstance(doc["model"], str):
        raise RunFolderError(f"{path}: not a faultmesh run manifest ('model' is not a path)")
    return doc


def _safe_rel(rel: str, folder: Path) -> Path:
    """A manifest path as a path inside ``folder`` (never outside it)."""
    p = Path(rel)
    if p.is_absolute() or ".." in p.parts or not p.parts:
        raise RunFolderError(f"{folder / MANIFEST}: file {rel[:80]!r} lies outside the run "
                             "folder")
    return p


class RunView:
    """The current run of a folder: ``manifest`` and ``path(rel)``, the file
    to open for each manifest entry (from the swap folder while a swap is
    under way or was interrupted)."""

    def __init__(self, folder: Path, manifest: Dict[str, Any], swapping: bool) -> None:
        self.folder = folder
        self.manifest = manifest
        self.swapping = swapping

    @property
    def files(self) -> List[str]:
        return [str(f["path"]) for f in self.manifest["files"]]

    @property
    def model(self) -> Optional[str]:
        return self.manifest.get("model")

    def path(self, rel: str) -> Path:
        p = _safe_rel(rel, self.folder)
        if self.swapping:
            staged = self.folder / SWAP / p
            if staged.exists():
                return staged
        return self.folder / p


def current_run(folder) -> Optional[RunView]:
    """The run a folder holds (see the module doc), or None for a folder
    without a manifest (written by an older faultmesh, or by hand)."""
    folder = Path(folder)
    m = _read_manifest(folder / SWAP / MANIFEST)
    if m is not None:
        return RunView(folder, m, True)
    m = _read_manifest(folder / MANIFEST)
    return RunView(folder, m, False) if m is not None else None


def verify(view: RunView) -> List[str]:
    """Problems of a run view: files missing or not matching their size and
    SHA-256 in the manifest (empty = the run is complete)."""
    out = []
    for f in view.manifest["files"]:
        p = view.path(f["path"])
        try:
            data = p.read_bytes()
        except OSError as e:
            out.append(f"{f['path']}: {e.strerror or e}")
            continue
        if len(data) != f.get("size") or hashlib.sha256(data).hexdigest() != f.get("sha256"):
            out.append(f"{f['path']}: content differs from the manifest")
    return out


# ---------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------
def _lock(folder: Path):
    """An exclusive, non-blocking flock on the folder (released when the
    process dies, even by SIGKILL); None where flock does not exist."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        return None
    fd = os.open(folder, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise RunFolderError(f"{folder}: another faultmesh run is writing into this folder; "
                             "wait for it to finish or choose another output folder") from None
    except OSError:  # pragma: no cover - a file system without locks
        os.close(fd)
        return None
    return fd


def _unlock(fd) -> None:
    if fd is not None:
        os.close(fd)


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover - not supported for directories here
        pass
    finally:
        os.close(fd)


def _rmtree(p: Path) -> None:
    shutil.rmtree(p, ignore_errors=True)


def _prune_empty_dirs(top: Path, rels: Iterable[Path]) -> None:
    """Remove the (now empty) parent folders of ``rels`` under ``top``."""
    for rel in sorted({r.parent for r in rels if r.parent != Path(".")},
                      key=lambda r: -len(r.parts)):
        d = top / rel
        while d != top:
            try:
                d.rmdir()
            except OSError:
                break
            d = d.parent


def _within(p: Path, folder: Path) -> bool:
    try:
        p.parent.resolve().relative_to(folder.resolve())
        return True
    except (ValueError, OSError, RuntimeError):
        return False


def _finish_swap(folder: Path) -> None:
    """Steps 2-4 of the swap (see the module doc); idempotent, so it also
    finishes a swap a killed run left half done."""
    swap = folder / SWAP
    new = _read_manifest(swap / MANIFEST)
    if new is None:                                  # step 4 was done: only leftovers
        _rmtree(swap)
        return
    try:
        old = _read_manifest(swap / _OLD)
    except RunFolderError:
        old = None
    new_rel = [_safe_rel(str(f["path"]), folder) for f in new["files"]]
    keep = set(new_rel)
    if old is not None:
        gone = []
        for f in old["files"]:
            try:
                rel = _safe_rel(str(f["path"]), folder)
            except RunFolderError:
                continue
            if rel not in keep:
                # Never through a symlinked folder to somewhere else.
                if not _within(folder / rel, folder):
                    continue
                try:
                    (folder / rel).unlink()
                except FileNotFoundError:
                    pass
                except IsADirectoryError:  # pragma: no cover - a user put a folder there
                    continue
                gone.append(rel)
        _prune_empty_dirs(folder, gone)
    for rel in new_rel:
        src = swap / rel
        if src.exists() or src.is_symlink():
            (folder / rel).parent.mkdir(parents=True, exist_ok=True)
            os.replace(src, folder / rel)
    _fsync_dir(folder)
    os.replace(swap / MANIFEST, folder / MANIFEST)
    _fsync_dir(folder)
    _rmtree(swap)


#: Sub-folders that model writers fill (faultmesh.io: one file per surface).
_KNOWN_SUBFOLDERS = ("obj", "ply")


def clean_stale(folder: Path, locked: bool = True) -> List[Path]:
    """Finish an interrupted swap and remove our stale temporary files and
    staging folders in ``folder``, in the sub-folders its run writes
    (``obj/``, ``ply/`` and those in its manifest), and nowhere else; only
    names of our own temporary patterns. ``locked``: the caller holds the
    folder's lock, so every such name is stale; otherwise only those older
    than STALE_SECONDS."""
    folder = Path(folder)
    removed: List[Path] = []
    if (folder / SWAP).exists():
        _finish_swap(folder)
    now = time.time()

    def stale(p: Path) -> bool:
        if locked:
            return True
        try:
            return now - p.lstat().st_mtime > STALE_SECONDS
        except OSError:
            return False

    dirs = {folder} | {folder / d for d in _KNOWN_SUBFOLDERS}
    try:
        view = current_run(folder)
    except RunFolderError:
        view = None
    if view is not None:
        for rel in view.files:
            try:
                dirs.add(folder / _safe_rel(rel, folder).parent)
            except RunFolderError:
                pass
    for d in sorted(dirs):
        try:
            entries = list(os.scandir(d))
        except OSError:
            continue
        for e in entries:
            p = Path(e.path)
            if e.is_dir(follow_symlinks=False):
                if _STAGING_NAME.match(e.name) and stale(p):
                    _rmtree(p)
                    removed.append(p)
                continue
            if _TEMP_NAMES[0].match(e.name):
                ours = True
            elif _TEMP_NAMES[1].match(e.name):
                # ".NAME.PID.bak": an AtomicFiles backup of NAME, only if NAME is there.
                ours = (d / e.name[1:].rsplit(".", 2)[0]).exists()
            else:
                ours = False
            if ours and stale(p):
                try:
                    p.unlink()
                    removed.append(p)
                except OSError:  # pragma: no cover
                    pass
    return removed


def _sha256(p: Path) -> str:
    h = hashlib.sha256()
    with open(p, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


class RunWriter:
    """Write one run into ``folder``: ``with RunWriter(folder, command=...)
    as run:`` write every output under ``run.stage`` (a fresh hidden staging
    folder), then ``run.commit(model=..., dataset=...)`` swaps it in. An
    exception (or a kill) before the commit leaves the folder's old run as
    it was; the staging folder is removed (or, after a kill, by the next
    run)."""

    def __init__(self, folder, *, command: str, argv: Optional[List[str]] = None) -> None:
        self.folder = Path(folder)
        self.command = command
        self.argv = list(argv or [])
        self.stage: Path = Path()
        self._lock = None
        self.manifest: Optional[Dict[str, Any]] = None

    def __enter__(self) -> "RunWriter":
        f = self.folder
        if os.path.lexists(f) and not f.is_dir():
            what = "a file" if f.is_file() else ("a broken or looping symlink" if f.is_symlink()
                                                 else "not a folder")
            raise RunFolderError(f"{f}: is {what}; the output must be a folder "
                                 f"('{self.command}' writes several files)")
        f.mkdir(parents=True, exist_ok=True)
        self._lock = _lock(f)
        try:
            clean_stale(f, locked=self._lock is not None)
            self.stage = Path(tempfile.mkdtemp(prefix=_STAGING_PREFIX, suffix=".tmp", dir=f))
        except BaseException:
            _unlock(self._lock)
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if self.manifest is None and self.stage.exists():
                _rmtree(self.stage)
        finally:
            _unlock(self._lock)
        return False

    def final(self, p) -> Path:
        """Where a file written under the staging folder ends up."""
        return self.folder / Path(p).relative_to(self.stage)

    def commit(self, *, model: Optional[str] = None, dataset: Optional[Dict[str, Any]] = None,
               extra: Optional[Dict[str, Any]] = None) -> Dict[str, Any]:
        """Write the manifest and swap the run in (see the module doc)."""
        from . import __version__

        files = []
        for dirpath, dirnames, filenames in os.walk(self.stage):
            dirnames.sort()
            for name in sorted(filenames):
                p = Path(dirpath) / name
                rel = p.relative_to(self.stage)
                if str(rel) in (MANIFEST, _OLD) or is_temp_name(name):
                    continue
                files.append({"path": rel.as_posix(), "size": p.stat().st_size,
                              "sha256": _sha256(p)})
        if model is not None and model not in {f["path"] for f in files}:
            raise RunFolderError(f"run manifest: the model file {model!r} was not written")
        doc: Dict[str, Any] = {
            "faultmesh_run": MANIFEST_FORMAT,
            "id": os.urandom(8).hex(),
            "command": self.command, "argv": self.argv, "version": __version__,
            "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "dataset": dataset, "model": model, "files": files}
        if extra:
            doc.update(extra)
        # The old manifest goes with the new run (step 2 needs it after a kill).
        old = self.folder / MANIFEST
        if old.is_file():
            try:
                if _read_manifest(old) is not None:
                    shutil.copyfile(old, self.stage / _OLD)
            except RunFolderError:
                pass                                   # unreadable: delete nothing of it
        with open(self.stage / MANIFEST, "w", encoding="utf-8", newline="\n") as fh:
            json.dump(doc, fh, indent=1)
            fh.write("\n")
            fh.flush()
            os.fsync(fh.fileno())
        _fsync_dir(self.stage)
        os.replace(self.stage, self.folder / SWAP)      # step 1: the commit point
        self.manifest = doc
        _fsync_dir(self.folder)
        _finish_swap(self.folder)                       # steps 2-4
        return doc
