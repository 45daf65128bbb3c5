"""Run outputs of `faultmesh build`/`demo` (issue 10): one run's files are
replaced together (staging folder, manifest, swap), temporary files are never
read and are removed by the next run, a kill at any moment leaves a complete
run; dataset options and the input summary on the command line."""
from __future__ import annotations

import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from faultmesh import runs
from faultmesh.cli import main
from faultmesh.io import load_model
from faultmesh.runs import MANIFEST, SWAP, RunFolderError, RunWriter, current_run, verify

from test_cli import _env

SMALL = Path(__file__).resolve().parent / "data" / "datasets" / "small"
FULL = ["build", "synthetic", "-q"]                               # every format
SMALLER = ["build", "synthetic", "-q", "--formats", "3dt,vtu", "--loft", "shortest_diagonal"]


def _leftovers(out: Path):
    """Our temporary names anywhere under ``out``."""
    return sorted(str(p.relative_to(out)) for p in out.rglob("*") if runs.is_temp_name(p.name))


def _check_complete(out: Path):
    view = current_run(out)
    assert view is not None
    assert verify(view) == [], verify(view)
    m = load_model(out)
    assert m.surfaces and m.name == "synthetic-0"
    return view


# ---------------------------------------------------------------------------
# manifest and replacement
# ---------------------------------------------------------------------------
def test_a_new_run_replaces_the_old_one_together(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(FULL + ["-o", str(out)]) == 0
    first = _check_complete(out)
    assert first.model == "synthetic-0.3dt" and "obj/00_layer_L1.obj" in first.files
    assert json.loads((out / "quality.json").read_text())["input"]["counts"]["snapped"]["count"] == 0
    # A user's own files beside the run, visible and hidden, are never touched.
    (out / "notes.txt").write_text("mine")
    (out / ".keep").write_text("")
    (out / "obj" / "mine.obj").write_text("# mine")
    assert main(SMALLER + ["-o", str(out)]) == 0
    second = _check_complete(out)
    assert sorted(second.files) == ["quality.csv", "quality.json", "quality.md",
                                    "synthetic-0.3dt", "synthetic-0.vtu"]
    names = sorted(str(p.relative_to(out)) for p in out.rglob("*"))
    # The old run's obj/, ply/ and .ts are gone (they were in its manifest).
    assert names == [".keep", "notes.txt", "obj", "obj/mine.obj", "quality.csv", "quality.json",
                     "quality.md", "run.json", "synthetic-0.3dt", "synthetic-0.vtu"]
    assert "shortest_diagonal" in second.manifest["argv"]
    capsys.readouterr()
    assert main(["quality", str(out)]) == 0
    assert "# Mesh quality: synthetic-0" in capsys.readouterr().out


def test_temp_files_are_never_read_and_are_removed_by_the_next_run(tmp_path, capsys):
    # Was: `faultmesh quality DIR` read a killed run's ".NAME.XXXX.tmp.3dt" as
    # the model, or failed on "several .3dt files".
    out = tmp_path / "out"
    assert main(FULL + ["-o", str(out)]) == 0
    junk = [out / ".synthetic-0.abcd1234.tmp.3dt", out / "obj" / ".00_layer_L1.x1y2z3w4.tmp.obj",
            out / ".quality.json.12345.bak"]
    for j in junk:
        j.write_text("half a file")
    stage = out / ".faultmesh-run.abcd_123.tmp"
    stage.mkdir()
    (stage / "synthetic-0.3dt").write_text("3DT 1\nhalf")
    # A folder without a manifest (an older faultmesh) is read the same way.
    legacy = tmp_path / "legacy"
    shutil.copytree(out, legacy)
    (legacy / MANIFEST).unlink()
    for folder in (out, legacy):
        assert load_model(folder).name == "synthetic-0"
        assert main(["quality", str(folder)]) == 0
    assert "half" not in capsys.readouterr().err
    assert main(SMALLER + ["-o", str(out)]) == 0
    assert _leftovers(out) == [] and not stage.exists()
    for j in junk:
        assert not j.exists()


def test_o_must_name_a_folder(tmp_path, capsys):
    # Was: "unknown format ''".
    f = tmp_path / "taken"
    f.write_text("x")
    assert main(["build", "synthetic", "-q", "-o", str(f)]) == 2
    err = capsys.readouterr().err
    assert f"-o {f}: is a file" in err and "writes several files into a folder" in err
    assert f.read_text() == "x"
    loop = tmp_path / "loop"
    os.symlink(loop.name, loop)
    assert main(["demo", "-q", "-o", str(loop)]) == 2
    assert "is not a folder" in capsys.readouterr().err


def test_a_second_run_into_the_same_folder_is_refused(tmp_path):
    out = tmp_path / "out"
    with RunWriter(out, command="build"):
        with pytest.raises(RunFolderError, match="another faultmesh run is writing"):
            with RunWriter(out, command="build"):
                pass
    with RunWriter(out, command="build") as run:             # free again
        (run.stage / "a.txt").write_text("a")
        run.commit()
    assert current_run(out).files == ["a.txt"]


def test_a_broken_manifest_is_a_clear_error_and_the_next_run_replaces_it(tmp_path, capsys):
    out = tmp_path / "out"
    with RunWriter(out, command="test") as run:
        (run.stage / "a.txt").write_text("a")
        run.commit()
    (out / MANIFEST).write_text('{"faultmesh_run": 1, "files": [{"path": "../../victim"}]}')
    victim = tmp_path / "victim"
    victim.write_text("keep me")
    assert main(["quality", str(out)]) == 2
    assert "run.json" in capsys.readouterr().err
    with RunWriter(out, command="test") as run:             # deletes nothing outside
        (run.stage / "b.txt").write_text("b")
        run.commit()
    assert victim.read_text() == "keep me" and current_run(out).files == ["b.txt"]
    (out / MANIFEST).write_text("{not json")
    with pytest.raises(Exception, match="run.json: not a readable run manifest"):
        load_model(out)
    with RunWriter(out, command="test") as run:
        run.commit()
    assert current_run(out).files == []


# ---------------------------------------------------------------------------
# a kill at every step of the swap
# ---------------------------------------------------------------------------
class _Killed(BaseException):
    pass


def _write_run(out: Path, files: dict, kill_at=None, monkeypatch=None):
    """A run of ``files`` (name -> text); ``kill_at``: the os.replace call
    (1 = the commit rename) at which the process "dies" (nothing after it
    runs, no clean-up either)."""
    calls = {"n": 0}
    real = os.replace

    def replace(a, b):
        calls["n"] += 1
        if calls["n"] == kill_at:
            raise _Killed()
        return real(a, b)

    if kill_at is not None:
        monkeypatch.setattr(runs.os, "replace", replace)
        monkeypatch.setattr(runs, "_rmtree", lambda p: None)   # a dead process cleans nothing
    try:
        with RunWriter(out, command="test") as run:
            for name, text in files.items():
                (run.stage / name).parent.mkdir(parents=True, exist_ok=True)
                (run.stage / name).write_text(text)
            run.commit(model=None)
    except _Killed:
        pass
    finally:
        monkeypatch.undo() if monkeypatch is not None else None
    return calls["n"]


OLD = {"model.3dt": "old model", "quality.md": "old quality", "sub/old_only.obj": "old piece"}
NEW = {"model.3dt": "new model", "quality.md": "new quality", "sub/new_only.obj": "new piece",
       "picture.png": "new picture"}


def test_a_kill_at_every_step_of_the_swap_leaves_one_complete_run(tmp_path, monkeypatch):
    # Steps: 1 commit rename, 2..5 moving the 4 new files, 6 the manifest.
    for kill_at in range(1, 8):
        out = tmp_path / f"k{kill_at}"
        _write_run(out, OLD)
        (out / "mine.txt").write_text("user")
        _write_run(out, NEW, kill_at, monkeypatch)
        view = current_run(out)
        assert verify(view) == []
        contents = {f: view.path(f).read_text() for f in view.files}
        assert contents in (OLD, NEW), (kill_at, contents)
        assert contents == (OLD if kill_at == 1 else NEW)     # after the commit: the new run
        # The next run finishes the swap, cleans up, and writes its own.
        _write_run(out, {"model.3dt": "third"})
        view = current_run(out)
        assert {f: view.path(f).read_text() for f in view.files} == {"model.3dt": "third"}
        left = sorted(str(p.relative_to(out)) for p in out.rglob("*"))
        assert left == ["mine.txt", "model.3dt", "run.json"], (kill_at, left)


# ---------------------------------------------------------------------------
# the real thing: SIGKILL while `faultmesh build` writes
# ---------------------------------------------------------------------------
def _start(argv, out):
    return subprocess.Popen([sys.executable, "-m", "faultmesh"] + argv + ["-o", str(out)],
                            env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _wait_for(p, cond, deadline):
    while p.poll() is None and time.monotonic() < deadline and not cond():
        time.sleep(0.0005)


def _has_files(folder: Path) -> bool:
    try:
        return any(folder.iterdir())
    except OSError:         # renamed away or not a folder yet
        return False


def test_sigkill_while_writing_leaves_the_old_or_the_new_run(tmp_path):
    """Runs killed with SIGKILL at seeded moments: during the swap, while
    writing into the staging folder, at any moment; after each the folder
    holds one complete run (every file matches the manifest), old or new,
    and the next run cleans up and succeeds. The dataset is a saved
    synthetic one: no ground truth, so no error sampling to wait for."""
    from faultmesh import datasets

    rng = random.Random(10)
    out = tmp_path / "out"
    js = str(datasets.synthetic(0).save(tmp_path / "ds"))
    FULL = ["build", js, "-q"]
    SMALLER = ["build", js, "-q", "--formats", "3dt,vtu", "--loft", "shortest_diagonal"]
    # The kill moments scale with this machine's speed: "any" kills inside
    # the measured duration of a run, "writing" right after the first file
    # of the staging folder appears (a fixed sleep let fast runs finish first).
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "faultmesh"] + SMALLER + ["-o", str(tmp_path / "t")],
                       env=_env(), capture_output=True, text=True, timeout=300)
    t_smaller = time.monotonic() - t0
    assert r.returncode == 0, r.stderr
    r = subprocess.run([sys.executable, "-m", "faultmesh"] + FULL + ["-o", str(out)],
                       env=_env(), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    argvs = {tuple(FULL + ["-o", str(out)]), tuple(SMALLER + ["-o", str(out)])}
    killed = []
    for mode, argv in (("swap", SMALLER), ("writing", FULL), ("any", SMALLER)):
        seen = {q.name for q in out.iterdir()}
        p = _start(argv, out)
        deadline = time.monotonic() + 120
        if mode == "any":
            time.sleep(rng.uniform(0.2, 0.8) * t_smaller)
        else:
            # This run's own staging folder (a killed run's may still be there).
            def staging():
                return [q for q in out.iterdir()
                        if runs._STAGING_NAME.match(q.name) and q.name not in seen]
            _wait_for(p, lambda: bool(staging()), deadline)
            if mode == "writing":
                _wait_for(p, lambda: any(_has_files(s) for s in staging()), deadline)
                time.sleep(rng.uniform(0.0, 0.01))
            else:
                _wait_for(p, lambda: os.path.lexists(out / SWAP), deadline)
        if p.poll() is None:
            p.send_signal(signal.SIGKILL)
            killed.append(mode)
        p.wait(timeout=120)
        view = current_run(out)
        assert verify(view) == [], (mode, verify(view))
        assert tuple(view.manifest["argv"]) in argvs
        if mode == "swap" and killed[-1:] == ["swap"]:
            assert view.swapping and tuple(view.manifest["argv"][:-2]) == tuple(argv)
        assert load_model(out).name == "synthetic-0"
    assert len(killed) >= 2, killed
    r = subprocess.run([sys.executable, "-m", "faultmesh"] + SMALLER + ["-o", str(out)],
                       env=_env(), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    view = _check_complete(out)
    assert _leftovers(out) == []
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*")) == sorted(
        view.files + [MANIFEST])


# ---------------------------------------------------------------------------
# dataset options and the input summary
# ---------------------------------------------------------------------------
def test_build_prints_the_input_summary_and_honours_dataset_options(tmp_path, capsys):
    d = tmp_path / "ds" / "small"
    shutil.copytree(SMALL, d)
    shutil.move(str(d / "boreholes.csv"), str(tmp_path / "ds" / "boreholes.csv"))
    js = d / "dataset.json"
    doc = json.loads(js.read_text())
    doc["boreholes"] = "../boreholes.csv"
    js.write_text(json.dumps(doc))
    out = tmp_path / "out"
    assert main(["build", str(js), "-q", "-o", str(out), "--formats", "3dt"]) == 2
    err = capsys.readouterr().err
    assert "leaves the dataset folder" in err and "--allow-outside-paths" in err
    assert not out.exists() or not any(out.iterdir())
    # Topography points 4 mm beyond the east side (x = 1000) are snapped.
    (d / "topo.csv").write_text((d / "topo.csv").read_text() + "1000.004,400,50.0\n")
    assert main(["build", str(js), "-q", "-o", str(out), "--formats", "3dt",
                 "--allow-outside-paths"]) == 0
    text = capsys.readouterr().out
    assert "input (snap distance 12.8 mm): 1 point(s) snapped onto the study-area boundary " \
           "(largest move 4.0 mm)." in text
    q = json.loads((out / "quality.json").read_text())
    (a,) = q["input"]["adjustments"]
    assert a["item"].startswith("topo.csv row ") and a["after"] == [1000.0, 400.0]
    assert current_run(out).manifest["input"]["counts"]["snapped"]["count"] == 1
    # --snap 0: the point is beyond the boundary and dropped.
    assert main(["build", str(js), "-q", "-o", str(out), "--formats", "3dt",
                 "--allow-outside-paths", "--snap", "0"]) == 0
    assert "1 item(s) dropped (farthest 4.0 mm beyond the boundary)" in capsys.readouterr().out
