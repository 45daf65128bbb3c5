"""Fuzz target for the dataset reader (issue 10): valid datasets (the built-in
paper-like one and a small synthetic one) mutated at the JSON level (values,
keys, types, deleted and repeated keys) and the CSV level (cells: text, NaN,
inf, huge, empty, quotes; extra and missing columns; BOM, CRLF, truncation,
binary junk). ``load_dataset`` must return a dataset or raise a DatasetError
whose message names the file and the row/field or the JSON item; never
another exception (a numpy RuntimeWarning counts as one), never a hang. A
dataset that loads survives save + load.

CI runs a few derandomized examples (tests/helpers.py: fuzz_settings);
``python bench/fuzz.py -k dataset_reader --examples 5000`` runs it long.
"""
from __future__ import annotations

import json
import re
import shutil
import signal
import tempfile
import warnings
from contextlib import contextmanager
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

import faultmesh as fm
from faultmesh import datasets
from faultmesh.dataset import apply_boundary_policy

from helpers import fuzz_settings

_BASES: dict = {}


def _base(name: str) -> Path:
    """A folder holding the dataset ``name`` in format v1 (made once)."""
    if name not in _BASES:
        if name == "paper_like":
            _BASES[name] = datasets.paper_like_path().parent
        else:
            d = Path(tempfile.mkdtemp(prefix="fm-fuzz-base-"))
            datasets.synthetic(0).save(d)
            _BASES[name] = d
    return _BASES[name]


# ---------------------------------------------------------------------------
# mutations
# ---------------------------------------------------------------------------
_WEIRD_TEXT = st.sampled_from([
    "", " ", "nan", "NaN", "inf", "-inf", "1e400", "-1e999", "1" * 400, "0x10", "1,5", '"',
    '""', "'", "\x00", "\ufeff", "é", "\u2028", "#", "# comment", "top", "L1", "seam_a",
    "\r", "\n", "1e-320", "-0", "   7   ", "9" * 5000, "🙂", "\\", "null", "true"])
_JSON_VALUES = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-(10 ** 30), 10 ** 30),
              st.floats(allow_nan=True, allow_infinity=True), _WEIRD_TEXT,
              st.text(max_size=20)),
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.text(max_size=8), inner, max_size=4)),
    max_leaves=8)


def _paths(doc, prefix=()):
    """Every (path, value) in a JSON document; a path is a tuple of keys/indices."""
    out = [(prefix, doc)]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, prefix + (i,))
    return out


def _parent(doc, path):
    for k in path[:-1]:
        doc = doc[k]
    return doc


def _mutate_json(data, doc):
    paths = _paths(doc)
    path, value = paths[data.draw(st.integers(0, len(paths) - 1), label="json path")]
    op = data.draw(st.sampled_from(["value", "delete", "rename", "wrap", "number", "empty"]),
                   label="json op")
    if not path:                                           # the root
        return data.draw(_JSON_VALUES) if op == "value" else doc
    parent, key = _parent(doc, path), path[-1]
    if op == "value":
        parent[key] = data.draw(_JSON_VALUES, label="new value")
    elif op == "delete":
        del parent[key]
    elif op == "rename" and isinstance(parent, dict):
        new = data.draw(st.sampled_from([key[:-1], key + "s", key.upper(), "", " " + key,
                                         "tip", "layer", "foots", "plain"]), label="new key")
        parent[new] = parent.pop(key)
    elif op == "wrap":
        parent[key] = [value]
    elif op == "number":
        parent[key] = data.draw(st.sampled_from([0, -1, 1e308, -1e308, 2 ** 63, 10 ** 400,
                                                 float("nan"), 0.1, 1e-300]), label="number")
    elif op == "empty":
        parent[key] = type(value)() if isinstance(value, (list, dict, str)) else None
    return doc


def _json_text(data, doc) -> bytes:
    text = json.dumps(doc, allow_nan=True)
    op = data.draw(st.sampled_from(["plain", "plain", "dup", "bom", "crlf", "truncate", "junk"]),
                   label="json text op")
    if op == "dup":
        # Repeat one key (json keeps the last silently; the loader says so).
        keys = list(re.finditer(r'"([A-Za-z_]+)": ', text))
        if keys:
            m = keys[data.draw(st.integers(0, len(keys) - 1), label="dup key")]
            text = text[:m.start()] + m.group(0) + "null, " + text[m.start():]
    raw = text.encode("utf-8", "surrogatepass")
    if op == "bom":
        raw = b"\xef\xbb\xbf" + raw
    elif op == "crlf":
        raw = raw.replace(b", ", b",\r\n")
    elif op == "truncate":
        raw = raw[:data.draw(st.integers(0, max(0, len(raw) - 1)), label="json cut")]
    elif op == "junk":
        at = data.draw(st.integers(0, len(raw)), label="junk at")
        raw = raw[:at] + data.draw(st.binary(min_size=1, max_size=8), label="junk") + raw[at:]
    return raw


def _mutate_csv(data, raw: bytes) -> bytes:
    op = data.draw(st.sampled_from(["cell", "cell", "cell", "add column", "drop column",
                                    "bom", "crlf", "truncate", "junk", "duplicate row",
                                    "header", "quote"]), label="csv op")
    if op == "bom":
        return b"\xef\xbb\xbf" + raw
    if op == "crlf":
        return raw.replace(b"\n", b"\r\n")
    if op == "truncate":
        return raw[:data.draw(st.integers(0, max(0, len(raw) - 1)), label="csv cut")]
    if op == "junk":
        at = data.draw(st.integers(0, len(raw)), label="csv junk at")
        return raw[:at] + data.draw(st.binary(min_size=1, max_size=8), label="junk") + raw[at:]
    lines = raw.decode("utf-8").split("\n")
    body = [i for i, ln in enumerate(lines) if ln]
    if not body:
        return raw
    i = body[data.draw(st.integers(0, len(body) - 1), label="csv line")]
    cells = lines[i].split(",")
    j = data.draw(st.integers(0, len(cells) - 1), label="csv column")
    if op == "cell":
        cells[j] = data.draw(st.one_of(_WEIRD_TEXT, st.text(max_size=12)), label="cell")
    elif op == "quote":
        cells[j] = '"' + cells[j]
    elif op == "add column":
        cells.insert(j, data.draw(_WEIRD_TEXT, label="extra cell"))
    elif op == "drop column" and len(cells) > 1:
        del cells[j]
    elif op == "duplicate row":
        lines.insert(i, lines[i])
    elif op == "header":
        lines[0] = ",".join(data.draw(st.permutations(lines[0].split(",")), label="header"))
    if op not in ("duplicate row", "header"):
        lines[i] = ",".join(cells)
    return "\n".join(lines).encode("utf-8", "surrogatepass")


# ---------------------------------------------------------------------------
# the check
# ---------------------------------------------------------------------------
#: What a message may name as the place of the problem (besides "row N" /
#: "line N"): the JSON's keys and items.
_PLACES = ("faultmesh_dataset", "name", "crs", "layers", "layer ", "boundary", "boreholes",
           "points", "section", "fault", "trace", "tips", "snap_distance", "header",
           "empty file", "top level", "hole ", "JSON path", "key ")


@contextmanager
def _no_hang(seconds: float):
    """A load that takes longer than this is a hang (a FIFO-like block, an
    endless loop): SIGALRM turns it into a failure instead of a stuck run."""
    def on_alarm(signum, frame):
        raise TimeoutError(f"load_dataset did not return within {seconds} s")

    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _check_mutated(data, base_name: str) -> None:
    base = _base(base_name)
    with tempfile.TemporaryDirectory(prefix="fm-fuzz-") as tmp:
        d = Path(tmp) / "ds"
        shutil.copytree(base, d)
        js = d / "dataset.json"
        csvs = sorted(p for p in d.glob("*.csv"))
        for _ in range(data.draw(st.integers(1, 3), label="mutations")):
            if data.draw(st.booleans(), label="json?"):
                try:
                    doc = json.loads(js.read_bytes().decode("utf-8-sig"))
                except (ValueError, UnicodeDecodeError):
                    continue                               # already broken: leave it
                js.write_bytes(_json_text(data, _mutate_json(data, doc)))
            else:
                f = csvs[data.draw(st.integers(0, len(csvs) - 1), label="csv file")]
                try:
                    f.write_bytes(_mutate_csv(data, f.read_bytes()))
                except UnicodeDecodeError:
                    continue
        try:
            # A numpy warning (overflow, invalid value) is a finding too.
            with _no_hang(30.0), warnings.catch_warnings():
                warnings.simplefilter("error", RuntimeWarning)
                ds = fm.load_dataset(d)
        except fm.DatasetError as e:
            msg = str(e)
            assert str(d) in msg, f"message names no file of the dataset: {msg!r}"
            assert (re.search(r"\b(row|line) \d+", msg) or any(w in msg for w in _PLACES)), \
                f"message names no row, field or JSON item: {msg!r}"
            assert len(msg) < 3000, f"message too long ({len(msg)} chars)"
            return
        # Loaded: the policy is idempotent, and what loaded survives save + load.
        again = apply_boundary_policy(ds)
        assert again == ds and again.adjustments == ds.adjustments
        out = Path(tmp) / "saved"
        try:
            ds.save(out)
        except fm.DatasetError:
            return                                         # e.g. a hole id CSV cannot hold
        back = fm.load_dataset(out)
        assert back == ds


@pytest.mark.fuzz
@fuzz_settings(80)
@given(data=st.data())
def test_fuzz_dataset_reader_paper_like(data):
    _check_mutated(data, "paper_like")


@pytest.mark.fuzz
@fuzz_settings(150)
@given(data=st.data())
def test_fuzz_dataset_reader_synthetic(data):
    _check_mutated(data, "synthetic")
