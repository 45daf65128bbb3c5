"""The dataset reader against bad files and bad JSON (issue 10): unknown keys
at any depth, repeated keys, paths leaving the dataset folder, messages that
never echo a foreign file, byte-order marks, special files."""
from __future__ import annotations

import json
import os
import shutil
import threading
from pathlib import Path

import pytest

import faultmesh as fm

SMALL = Path(__file__).resolve().parent / "data" / "datasets" / "small"


@pytest.fixture
def small(tmp_path):
    d = tmp_path / "small"
    shutil.copytree(SMALL, d)
    return d / "dataset.json"


def edit(js: Path, fn) -> Path:
    doc = json.loads(js.read_text())
    fn(doc)
    js.write_text(json.dumps(doc))
    return js


def error(path, **kw) -> str:
    with pytest.raises(fm.DatasetError) as ei:
        fm.load_dataset(path, **kw)
    return str(ei.value)


# ---------------------------------------------------------------------------
# unknown and repeated keys
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("where, key, path, hint", [
    (lambda d: d["faults"][0], "tip", "faults[0].tip", "did you mean 'tips'?"),
    (lambda d: d["faults"][0]["traces"][1], "plain", "faults[0].traces[1].plain",
     "did you mean 'plane'?"),
    (lambda d: d["sections"][1], "azimut", "sections[1].azimut", "did you mean 'azimuth'?"),
    (lambda d: d["faults"][0]["traces"][0]["layers"]["seam_a"], "foots",
     "faults[0].traces[0].layers['seam_a'].foots", "did you mean 'foot'?"),
    (lambda d: d, "fault", "fault", "did you mean 'faults'?"),
], ids=["fault", "trace", "section", "layer-side", "top"])
def test_unknown_keys_at_any_depth_name_the_json_path(small, where, key, path, hint):
    # Was: ignored inside faults, traces and sections ("tip" for "tips" gave no tips).
    edit(small, lambda d: where(d).update({key: 1}))
    msg = error(small)
    assert f"unknown key {key!r}" in msg and f"JSON path {path}" in msg and hint in msg, msg


def test_unknown_layer_names_suggest_the_nearest(small):
    edit(small, lambda d: d["faults"][0]["traces"][0]["layers"].update(
        {"seam_c": d["faults"][0]["traces"][0]["layers"]["seam_a"]}))
    msg = error(small)
    assert "unknown layer 'seam_c'" in msg and "(did you mean 'seam_" in msg


def test_notes_are_allowed_where_people_write_them(small):
    def f(d):
        d["description"] = "a note"
        d["faults"][0]["comment"] = "picked by A."
        d["faults"][0]["traces"][0]["description"] = "x"
        d["sections"][0]["comment"] = "y"
    edit(small, f)
    assert fm.load_dataset(small).fault("F1").tips.shape == (2, 2)


def test_a_key_given_twice_is_an_error(small):
    text = small.read_text().replace('"kind": "reverse",', '"kind": "reverse", "kind": "normal",')
    small.write_text(text)
    msg = error(small)
    assert "fault" in msg and "key 'kind' is given more than once" in msg and "faults[0]" in msg


# ---------------------------------------------------------------------------
# paths that leave the dataset folder
# ---------------------------------------------------------------------------
def test_csv_paths_must_stay_in_the_dataset_folder(small, tmp_path):
    outside = tmp_path / "elsewhere.csv"
    shutil.copy(small.parent / "boreholes.csv", outside)
    edit(small, lambda d: d.update({"boreholes": "../elsewhere.csv"}))
    msg = error(small)
    assert "boreholes: '../elsewhere.csv' leaves the dataset folder" in msg
    assert "allow_outside_paths=True" in msg and "--allow-outside-paths" in msg
    assert fm.load_dataset(small, allow_outside_paths=True).boreholes.n_holes == 9
    edit(small, lambda d: d.update({"boreholes": str(outside)}))
    assert "is an absolute path" in error(small)
    assert fm.load_dataset(small, allow_outside_paths=True).boreholes.n_holes == 9
    # A symlink in the folder that resolves outside it.
    os.symlink(outside, small.parent / "link.csv")
    edit(small, lambda d: d.update({"boreholes": "link.csv"}))
    assert "leaves the dataset folder" in error(small)
    # Paths through sub-folders that stay inside are fine.
    (small.parent / "sub").mkdir()
    edit(small, lambda d: d.update({"boreholes": "sub/../boreholes.csv"}))
    assert fm.load_dataset(small).boreholes.n_holes == 9


def test_messages_never_echo_a_foreign_file(small, tmp_path):
    # Was: the error quoted the other file's content (its whole header line).
    secret = tmp_path / "secret.txt"
    token = "TOKEN-" + "s3cr3t" * 30
    secret.write_text(f"user,{token},x\nroot,{token},y\n")
    edit(small, lambda d: d.update({"boreholes": str(secret)}))
    msg = error(small, allow_outside_paths=True)
    assert "header lacks column(s)" in msg and "s3cr3t" not in msg
    # A long offending field is cut to about 40 characters.
    secret.write_text(f"hole_id,x,y,layer,z\nB1,1,2,{token},3\n")
    msg = error(small, allow_outside_paths=True)
    assert "row 2, field 'layer'" in msg
    assert token[:30] in msg and token[:60] not in msg
    secret.write_text(f"hole_id,x,y,layer,z\nB1,{token},2,top,3\n")
    msg = error(small, allow_outside_paths=True)
    assert "field 'x'" in msg and token[:60] not in msg
    # JSON values too.
    edit(small, lambda d: d.update({"boreholes": "boreholes.csv", "crs": ["x" * 500]}))
    msg = error(small)
    assert "crs" in msg and "x" * 60 not in msg


# ---------------------------------------------------------------------------
# encodings and special files
# ---------------------------------------------------------------------------
def test_a_byte_order_mark_is_accepted(small):
    # Was: "header lacks column(s) ['hole_id']" (the BOM glued to the name).
    for f in ("boreholes.csv", "topo.csv", "dataset.json"):
        p = small.parent / f
        p.write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
    assert fm.load_dataset(small) == fm.load_dataset(SMALL)


def test_crlf_line_ends_are_accepted(small):
    for f in ("boreholes.csv", "topo.csv", "dataset.json"):
        p = small.parent / f
        p.write_bytes(p.read_bytes().replace(b"\n", b"\r\n"))
    assert fm.load_dataset(small) == fm.load_dataset(SMALL)


def test_not_utf8_names_the_row(small):
    p = small.parent / "boreholes.csv"
    p.write_bytes(p.read_bytes().replace(b"B5,520", b"B\xe95,520", 1))
    msg = error(small)
    assert "boreholes.csv, row 15" in msg and "not UTF-8" in msg


def _load_in_thread(path, **kw):
    """load_dataset in a thread: a hang (a FIFO opened for reading blocks)
    shows as a thread still alive, not as a stuck test run."""
    out = {}

    def run():
        try:
            fm.load_dataset(path, **kw)
            out["result"] = "loaded"
        except Exception as e:  # noqa: BLE001 - the test looks at what it was
            out["error"] = e

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(60)
    assert not t.is_alive(), "load_dataset hangs"
    return out


@pytest.mark.parametrize("kind, fragment", [
    ("dir", "is a directory, expected a file"),
    ("fifo", "is not a regular file (a FIFO)"),
    ("device", "is not a regular file (a device)"),
    ("loop", "symlink loop"),
    ("dangling", "is a symlink to a missing file"),
])
@pytest.mark.parametrize("which", ["boreholes.csv", "topo.csv", "dataset.json"])
def test_special_files_are_clear_errors_never_not_found_or_a_hang(small, kind, fragment, which):
    # Was: "not found" for a directory, a loop or a FIFO, and a hang on
    # reading a FIFO.
    p = small.parent / which
    if which == "dataset.json":
        # Keep a readable copy under another name and point load_dataset at p.
        shutil.copy(p, small.parent / "real.json.txt")
    p.unlink()
    if kind == "dir":
        p.mkdir()
    elif kind == "fifo":
        os.mkfifo(p)
    elif kind == "device":
        os.symlink("/dev/null", p)
    elif kind == "loop":
        os.symlink(p.name, p)
    else:
        os.symlink(small.parent / "missing.csv", p)
    # /dev/null lies outside the folder: allow that, to reach the file-type check.
    out = _load_in_thread(p if which == "dataset.json" else small,
                          allow_outside_paths=kind == "device")
    e = out.get("error")
    assert isinstance(e, fm.DatasetError), out
    assert fragment in str(e) and which in str(e), str(e)
    assert "not found" not in str(e) or kind == "dangling"


def test_a_folder_with_our_temp_files_loads_the_real_json(small):
    # A Dataset.save killed half-way leaves ".dataset.XXXXXXXX.tmp.json":
    # never taken for the dataset, never an "several JSON files" error.
    (small.parent / ".dataset.abcd1234.tmp.json").write_text("{")
    small.rename(small.parent / "site.json")
    assert fm.load_dataset(small.parent).name == "small"


@pytest.mark.parametrize("text, fragment", [
    ("[1, 2]", "the top level must be a JSON object"),
    ("[" * 100000, "nested too deeply"),
    ('{"faultmesh_dataset": 1, "layers": [' + "9" * 5000 + "]}", "not valid JSON"),
    ('{"faultmesh_dataset": 1, "layers": ["top", "seam_a", "seam_b"], "boreholes": '
     '"boreholes.csv", "boundary": [[0, 0], [1e400, 0], [0, 1]]}', "is not a finite number"),
    ('{"faultmesh_dataset": 1, "layers": ["top", "seam_a", "seam_b"], "boreholes": '
     '"boreholes.csv", "boundary": [[0, 0], [' + "1" * 400 + ', 0], [0, 1]]}',
     "is not a finite number"),
], ids=["list", "deep", "long-integer", "inf", "huge-integer"])
def test_hostile_json_is_a_dataset_error(small, text, fragment):
    small.write_text(text)
    msg = error(small)
    assert fragment in msg and "dataset.json" in msg and len(msg) < 600, msg


def test_coordinates_beyond_the_range_name_the_field(small):
    # Found by the fuzz target: 1e300 coordinates overflowed inside the
    # boundary policy (a warning, NaN parameters) instead of a clear error.
    p = small.parent / "boreholes.csv"
    p.write_text(p.read_text().replace("B5,520,398,top", "B5,1e300,398,top", 1))
    msg = error(small)
    assert "boreholes.csv, row 15, field 'x'" in msg and "beyond the coordinate range" in msg
    shutil.copy(SMALL / "boreholes.csv", p)
    edit(small, lambda d: d["boundary"].__setitem__(1, [0, 2e15]))
    msg = error(small)
    assert "boundary point 2 y" in msg and "beyond the coordinate range" in msg


def test_save_refuses_a_hole_id_the_reader_would_skip_as_a_comment(tmp_path):
    ds = fm.load_dataset(SMALL)
    ids = ds.boreholes.hole_id.astype("<U8")
    ids[ids == "B1"] = "#1"
    ds.boreholes.hole_id = ids
    with pytest.raises(fm.DatasetError, match="hole_id '#1' cannot be written"):
        ds.save(tmp_path / "o")
