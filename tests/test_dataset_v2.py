"""Dataset format version 2 (docs/dataset.md): drillhole tables, optional
boreholes, fault points / surface / throw, optional kind and traces; the
writer (``Dataset.save(version=...)``) and round trips; deviated drillholes
against the equivalent ``hole_id,x,y,layer,z`` table through ``build_model``;
a fuzz target on mutated v2 JSON."""
from __future__ import annotations

import json
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helpers import fuzz_settings

import faultmesh as fm
from faultmesh.dataset import (Boreholes, Dataset, DatasetError, Fault, apply_boundary_policy, load_dataset)
from faultmesh.datasets import synthetic
from faultmesh.model import Model, Surface

# The ground-tracing helpers of the drillhole tests (one implementation):
# hole paths by minimum curvature computed independently of faultmesh,
# contacts with a generated ground, the three tables as a logging program
# writes them, the exact tops by the rule.
from test_drillholes import expected_tops, ground_holes, trace, write_tables


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


# ---------------------------------------------------------------------------
# A small v2 dataset using every key
# ---------------------------------------------------------------------------
# Flat layers: A's top at z 100 (the collars), B's at 80, C's at 60. Holes H1-H3
# vertical; H4 straight at azimuth 45, dip -60, so its contacts lie 20 / sin 60
# = 23.094 m apart along the hole (logged to 1 mm).
COLLARS = """hole_id,x,y,z,max_depth
H1,100,100,100,70
H2,900,150,100,
H3,500,850,100,70
H4,300,500,100,80
"""
SURVEYS = """hole_id,depth,azimuth,dip
H4,0,45,-60
H4,50,45,-60
"""
INTERVALS = """hole_id,from,to,unit
H1,0,20,A
H1,20,40,B
H1,40,70,C
H2,0,20,A
H2,20,40,B
H2,40,60,C
H3,0,2,cover
H3,2,20,A
H3,20,40,B
H3,40,70,C
H4,0,23.094,A
H4,23.094,46.188,B
H4,46.188,80,C
"""
# Fault F1: two sticks, one point 100 m beyond the boundary's east side.
F1_POINTS = """x,y,z,stick
400,0,100,s1
430,0,50,s1
460,0,0,s1
600,1000,100,s2
630,1000,50,s2
1100,1000,0,s2
"""
TOPO = "x,y,z\n0,0,100\n1000,0,100\n1000,1000,100\n0,1000,100\n"


def f2_surface() -> Model:
    V = np.array([[700.0, 0, 100], [700, 1000, 100], [750, 0, 0], [750, 1000, 0]])
    T = np.array([[0, 2, 1], [1, 2, 3]])
    return Model(name="f2", surfaces={}, faults={"F2": Surface("F2", V, T, kind="fault")})


def full_doc() -> dict:
    return {
        "faultmesh_dataset": 2, "name": "every_key", "crs": "EPSG:32650",
        "snap_distance": 0.01, "description": "all v2 keys",
        "layers": ["A", "B", "C"],
        "boundary": [[0, 0], [1000, 0], [1000, 1000], [0, 1000]],
        "boreholes": {"collars": "collars.csv", "surveys": "surveys.csv",
                      "intervals": "intervals.csv", "other_units": ["cover"],
                      "comment": "from the drillhole database"},
        "points": {"A": "topo.csv"},
        "sections": [{"name": "S1", "origin": [0, 500], "azimuth": 90.0}],
        "faults": [
            {"name": "F1", "group": "g", "tips": [[450, 20]], "points": "f1.csv",
             "throw": {"max": 40.0},
             "traces": [{"section": "S1", "plane": [[440, 100], [470, 0]]}]},
            {"name": "F2", "kind": "normal", "surface": "f2.ts", "comment": "a TSurf"},
            {"name": "F3", "kind": "reverse", "throw": {"max": 5},
             "traces": [{"section": "S1", "plane": [[200, 100], [230, 0]],
                         "layers": {"B": {"foot": [[150, 80], [215, 80]],
                                          "hanging": [[215, 75], [300, 75]]}}}]},
        ],
    }


@pytest.fixture
def v2_dir(tmp_path):
    d = tmp_path / "v2"
    d.mkdir()
    write(d / "collars.csv", COLLARS)
    write(d / "surveys.csv", SURVEYS)
    write(d / "intervals.csv", INTERVALS)
    write(d / "topo.csv", TOPO)
    write(d / "f1.csv", F1_POINTS)
    fm.formats.gocad.write_ts(f2_surface(), d / "f2.ts")
    write(d / "dataset.json", json.dumps(full_doc(), indent=1))
    return d


def edit(d: Path, fn) -> Path:
    doc = json.loads((d / "dataset.json").read_text())
    fn(doc)
    (d / "dataset.json").write_text(json.dumps(doc))
    return d / "dataset.json"


def test_every_v2_key_loads(v2_dir):
    ds = load_dataset(v2_dir)
    assert (ds.name, ds.crs, ds.layers, ds.snap_distance) == ("every_key", "EPSG:32650",
                                                              ["A", "B", "C"], 0.01)
    # Drillholes: H3's first layer top is below a cover (no top: that contact
    # was logged against a unit that is not a layer); H4's tops lie along
    # the inclined hole, each at its own XY.
    b = ds.boreholes
    assert b.desurveyed and b.source == "intervals.csv"
    assert list(zip(b.hole_id.tolist(), b.layer.tolist())) == [
        ("H1", "A"), ("H1", "B"), ("H1", "C"), ("H2", "A"), ("H2", "B"), ("H2", "C"),
        ("H3", "B"), ("H3", "C"), ("H4", "A"), ("H4", "B"), ("H4", "C")]
    h4 = b.hole_id == "H4"
    step = 23.094 * math.cos(math.radians(60)) / math.sqrt(2)   # per axis, per contact
    np.testing.assert_allclose(b.xy[h4], [[300, 500], [300 + step, 500 + step],
                                         [300 + 2 * step, 500 + 2 * step]], atol=1e-9)
    np.testing.assert_allclose(b.z[h4], [100, 100 - 23.094 * math.sin(math.radians(60)),
                                         100 - 2 * 23.094 * math.sin(math.radians(60))],
                               atol=1e-9)
    assert b.rows[h4].tolist() == [12, 13, 14]          # the interval rows of the tops
    assert ds.drillholes is not None and ds.drillholes.other_units == ("cover",)
    assert ds.points["A"].shape == (4, 3)
    f1, f2, f3 = ds.faults
    # F1: no kind (derived), points with sticks, a throw, a plane-only trace.
    assert f1.kind is None and f1.group == "g" and f1.throw == {"max": 40.0}
    np.testing.assert_array_equal(f1.points[:, 0], [400, 430, 460, 600, 630, 1100])
    assert f1.sticks.tolist() == ["s1"] * 3 + ["s2"] * 3
    assert f1.surface is None and len(f1.traces) == 1 and f1.traces[0].layers == {}
    np.testing.assert_array_equal(f1.traces[0].plane, [[440, 500, 100], [470, 500, 0]])
    # F2: a surface, no traces.
    assert f2.kind == "normal" and f2.traces == [] and f2.points is None and f2.throw is None
    V, T = f2.surface
    np.testing.assert_array_equal(V, f2_surface().faults["F2"].vertices)
    np.testing.assert_array_equal(T, [[0, 2, 1], [1, 2, 3]])
    # F3: v1-style cutoffs, an integer throw read as a float.
    assert f3.kind == "reverse" and f3.throw == {"max": 5.0} and list(f3.traces[0].layers) == ["B"]
    # The fault point beyond the boundary is kept, and noted once.
    kept = [a for a in ds.adjustments if a.what == "kept"]
    assert [(a.item, a.distance) for a in kept] == [("fault 'F1' points", 100.0)]
    assert "1 of 6 points" in kept[0].note and "point 6" in kept[0].note
    assert len(ds.faults[0].points) == 6


def test_policy_is_idempotent_with_kept_records(v2_dir):
    ds = load_dataset(v2_dir)
    again = apply_boundary_policy(ds)
    assert again.adjustments == ds.adjustments and again == ds
    rec = fm.dataset.input_record(again)
    assert rec["counts"]["kept"] == {"count": 1, "largest_distance": 100.0}
    assert "kept for the fault surface fit" in rec["summary"]


def test_fault_of_points_only_is_not_dropped_with_its_traces(v2_dir):
    # F1's only trace lies beyond the boundary: the trace goes, the fault
    # (its points) stays; a fault of traces only would be dropped.
    def fn(doc):
        doc["faults"][0]["traces"][0]["plane"] = [[1200, 100], [1300, 0]]
    ds = load_dataset(edit(v2_dir, fn))
    f1 = ds.fault("F1")
    assert f1.traces == [] and len(f1.points) == 6
    assert any(a.what == "dropped" and a.item == "fault 'F1' trace 1 plane" for a in ds.adjustments)
    assert not any(a.item == "fault 'F1'" for a in ds.adjustments)


def test_tops_beyond_the_boundary_are_dropped_naming_the_interval_row(v2_dir):
    # H2's tops (x 900) are beyond a boundary cut at x 800.
    def fn(doc):
        doc["boundary"] = [[0, 0], [800, 0], [800, 1000], [0, 1000]]
    ds = load_dataset(edit(v2_dir, fn))
    assert "H2" not in ds.boreholes.hole_id.tolist()
    dropped = [a.item for a in ds.adjustments if a.what == "dropped" and "H2" in a.item]
    assert dropped == ["intervals.csv row 5 (hole 'H2', layer 'A')",
                       "intervals.csv row 6 (hole 'H2', layer 'B')",
                       "intervals.csv row 7 (hole 'H2', layer 'C')"]


def test_plain_table_in_v2_and_no_surveys(v2_dir):
    def fn(doc):
        doc["boreholes"] = "holes.csv"
    write(v2_dir / "holes.csv", "hole_id,x,y,layer,z\nP1,0,0,A,100\nP1,0,0,B,80\n"
          "P2,1000,0,B,80\nP3,0,1000,B,80\nP3,0,1000,C,60\nP4,1000,1000,C,60\nP5,500,500,C,60\n")
    ds = load_dataset(edit(v2_dir, fn))
    assert not ds.boreholes.desurveyed and ds.drillholes is None and len(ds.boreholes) == 7

    def fn2(doc):
        doc["boreholes"] = {"collars": "collars.csv", "intervals": "intervals.csv",
                            "other_units": ["cover"]}
    ds = load_dataset(edit(v2_dir, fn2))
    h4 = ds.boreholes.hole_id == "H4"                     # vertical without surveys
    assert np.all(ds.boreholes.xy[h4] == [300, 500])
    np.testing.assert_allclose(ds.boreholes.z[h4], [100, 100 - 23.094, 100 - 46.188])


def test_without_boreholes_the_area_is_the_points_box(tmp_path):
    d = tmp_path / "p"
    d.mkdir()
    write(d / "a.csv", "x,y,z\n10,20,5\n110,20,5\n10,220,6\n60,90,5\n")
    write(d / "b.csv", "x,y,z\n15,25,-5\n105,30,-5\n20,200,-4\n130,250,-6\n")
    write(d / "dataset.json", json.dumps({"faultmesh_dataset": 2, "name": "p",
                                          "layers": ["a", "b"],
                                          "points": {"a": "a.csv", "b": "b.csv"}}))
    ds = load_dataset(d)
    assert len(ds.boreholes) == 0
    np.testing.assert_array_equal(ds.boundary, [[10, 20], [130, 20], [130, 250], [10, 250]])
    # Version 1 still needs the boreholes key.
    edit(d, lambda doc: doc.update({"faultmesh_dataset": 1}))
    with pytest.raises(DatasetError, match=r"dataset\.json: missing key 'boreholes'"):
        load_dataset(d)


def test_desurveyed_tops_skip_the_one_xy_per_hole_check(v2_dir):
    # The same rows as a plain table: hole H4 "at two places" is an error
    # there (a repeated id), while desurveyed tops of one hole differ in XY.
    ds = load_dataset(v2_dir)
    b = ds.boreholes
    rows = "".join(f"{h},{x!r},{y!r},{lay},{z!r}\n" for h, (x, y), lay, z in
                   zip(b.hole_id.tolist(), b.xy.tolist(), b.layer.tolist(), b.z.tolist()))
    write(v2_dir / "tops.csv", "hole_id,x,y,layer,z\n" + rows)
    with pytest.raises(DatasetError, match=r"tops\.csv: hole 'H4' is at two places: row 10 .*"
                                           r"and row 11"):
        load_dataset(edit(v2_dir, lambda doc: doc.update({"boreholes": "tops.csv"})))
    fm.dataset.check_hole_positions(ds)                   # desurveyed: no error
    with pytest.raises(DatasetError, match="is at two places"):
        fm.dataset.check_hole_positions(replace(ds, boreholes=replace(b, desurveyed=False)))


# ---------------------------------------------------------------------------
# Errors: JSON path, file, row and field
# ---------------------------------------------------------------------------
def _set(path, value):
    def fn(doc):
        d = doc
        for k in path[:-1]:
            d = d[k]
        if value is _DEL:
            del d[path[-1]]
        else:
            d[path[-1]] = value
    return fn


_DEL = object()

JSON_ERRORS = [
    (("faults", 0, "throw"), {"maxi": 4}, ["fault 'F1' throw", "unknown key 'maxi'",
                                          "did you mean 'max'", "faults[0].throw.maxi"]),
    (("faults", 0, "throw"), {"max": -4}, ["fault 'F1' throw max", "must be a throw > 0"]),
    (("faults", 0, "throw"), {"max": "40"}, ["fault 'F1' throw max", "'40' is not a number"]),
    (("faults", 0, "throw"), {}, ["fault 'F1' throw", "missing key 'max'"]),
    (("faults", 0, "throw"), 40, ["fault 'F1' throw", "must be a JSON object"]),
    (("faults", 0, "throws"), 40, ["unknown key 'throws'", "did you mean 'throw'",
                                   "faults[0].throws"]),
    (("faults", 0, "kind"), "normall", ["fault 'F1' kind", "or left out: derived from the data",
                                        "'normall'"]),
    (("faults", 1, "surface"), _DEL, ["fault 'F2'", "needs its geometry"]),
    (("faults", 1, "surface"), "nope.ts", ["fault 'F2' surface", "nope.ts", "not found"]),
    (("faults", 1, "surface"), "../f2.ts", ["fault 'F2' surface", "leaves the dataset folder"]),
    (("faults", 0, "points"), "/etc/hosts", ["fault 'F1' points", "is an absolute path"]),
    (("faults", 0, "points"), 7, ["fault 'F1' points", "must be a non-empty string"]),
    (("boreholes", "collar"), "collars.csv", ["unknown key 'collar'", "did you mean 'collars'",
                                              "boreholes.collar"]),
    (("boreholes", "intervals"), _DEL, ["boreholes", "missing key 'intervals'"]),
    # Regression (fuzz): a null table crashed with a TypeError.
    (("boreholes", "collars"), None, ["boreholes.collars", "must be a non-empty string, got None"]),
    (("boreholes", "surveys"), "../surveys.csv", ["boreholes.surveys",
                                                  "leaves the dataset folder"]),
    (("boreholes", "other_units"), "cover", ["boreholes.other_units", "must be a JSON list"]),
    (("boreholes", "other_units"), ["cover", "B"], ["boreholes.other_units", "'B' is also a layer"]),
    (("boreholes", "other_units"), [], ["intervals.csv, row 8, field 'unit'",
                                        "unknown unit 'cover'"]),
    (("boreholes",), 3, ["boreholes", "must be a non-empty string"]),
]


@pytest.mark.parametrize("path,value,words", JSON_ERRORS,
                         ids=[".".join(map(str, e[0])) + f"={e[1]!r}"[:20] for e in JSON_ERRORS])
def test_json_errors_name_the_item(v2_dir, path, value, words):
    js = edit(v2_dir, _set(path, value))
    with pytest.raises(DatasetError) as e:
        load_dataset(js)
    msg = str(e.value)
    assert str(js) in msg or "intervals.csv" in msg, msg
    for w in words:
        assert w in msg, (w, msg)


FILE_ERRORS = [
    ("intervals.csv", "H1,20,40,B", "H1,21,40,B", "intervals.csv, row 3, field 'from'",
     "gap of 1 m in hole 'H1'"),
    ("collars.csv", "H2,900,150,100,", "H2,900,east,100,", "collars.csv, row 3, field 'y'",
     "'east' is not a number"),
    ("surveys.csv", "H4,50,45,-60", "H4,50,45,-100", "surveys.csv, row 3, field 'dip'",
     "outside -90..90"),
    ("intervals.csv", "H4,46.188,80,C", "H4,46.188,81,C", "intervals.csv, row 14, field 'to'",
     "past the end of hole 'H4'"),
    ("f1.csv", "430,0,50,s1", "430,0,5e,s1", "f1.csv, row 3, field 'z'", "'5e' is not a number"),
    ("f1.csv", "430,0,50,s1", "430,0,50,s2", "f1.csv, row 4, field 'stick'", "stick 's1' resumes"),
    ("f2.ts", "TRGL 1 3 2", "TRGL 1 3 9", "f2.ts", "line"),
    # Found by the fuzz of the v2 input: an unclosed quote swallowed the rest
    # of the file and the field count's error named its last row; "9_00"
    # and other scripts' digits were read as numbers (Python's float()).
    ("collars.csv", "H2,900,150,100,", 'H2,"900,150,100,', "collars.csv, row 3",
     "a quoted field runs over lines 3-"),
    ("collars.csv", "H2,900,150,100,", "H2,9_00,150,100,", "collars.csv, row 3, field 'x'",
     "'9_00' is not a number"),
    ("collars.csv", "H2,900,150,100,", "H2,900,١٥٠,100,", "collars.csv, row 3, field 'y'",
     "is not a number"),
]


@pytest.mark.parametrize("file,old,new,where,words", FILE_ERRORS,
                         ids=[f"{e[0]}:{e[2]}" for e in FILE_ERRORS])
def test_data_file_errors_name_file_row_and_field(v2_dir, file, old, new, where, words):
    p = v2_dir / file
    text = p.read_text()
    assert old in text
    p.write_text(text.replace(old, new, 1))
    with pytest.raises(DatasetError) as e:
        load_dataset(v2_dir)
    msg = str(e.value)
    assert where in msg and words in msg, msg


def test_a_fault_surface_with_a_byte_order_mark_loads_as_without(v2_dir):
    # Found by the fuzz of the v2 input: refused with "line 1: expected
    # 'GOCAD <type> 1'" although line 1 was exactly that after the BOM.
    plain = load_dataset(v2_dir).faults[1].surface
    p = v2_dir / "f2.ts"
    p.write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
    bom = load_dataset(v2_dir).faults[1].surface
    np.testing.assert_array_equal(bom[0], plain[0])
    np.testing.assert_array_equal(bom[1], plain[1])


def test_regression_surface_error_quotes_no_line_of_the_file(v2_dir):
    # A surface path naming another file (here a CSV): the GOCAD reader's
    # message quoted the file's first line ("got 'x,y,z,stick'"); the dataset
    # messages name the file and line only.
    js = edit(v2_dir, _set(("faults", 1, "surface"), "f1.csv"))
    with pytest.raises(DatasetError) as e:
        load_dataset(js)
    msg = str(e.value)
    assert f"{v2_dir / 'f1.csv'}, line 1: expected 'GOCAD <type> 1' to start an object" in msg
    assert "x,y,z" not in msg, msg


@pytest.mark.parametrize("key,value", [("points", "f1.csv"), ("surface", "f2.ts"),
                                       ("throw", {"max": 3.0})])
def test_v1_refuses_v2_keys_saying_so(v2_dir, key, value):
    def fn(doc):
        doc["faultmesh_dataset"] = 1
        doc["boreholes"] = "holes.csv"
        f3 = {k: v for k, v in doc["faults"][2].items() if k != "throw"}
        doc["faults"] = [dict(f3, **{key: value})]
    write(v2_dir / "holes.csv", "hole_id,x,y,layer,z\n")
    with pytest.raises(DatasetError, match=rf"faults\[0\]: key '{key}' \(JSON path "
                                           rf"faults\[0\]\.{key}\) needs format version 2"):
        load_dataset(edit(v2_dir, fn))


def test_v1_refuses_drillhole_tables_and_missing_kind(v2_dir):
    with pytest.raises(DatasetError, match="boreholes: drillhole tables .* need format version 2"):
        load_dataset(edit(v2_dir, lambda doc: doc.update({"faultmesh_dataset": 1})))

    def fn(doc):
        doc["boreholes"] = "holes.csv"
        del doc["faults"][2]["kind"]
        del doc["faults"][2]["throw"]
        doc["faults"] = [doc["faults"][2]]
    write(v2_dir / "holes.csv", "hole_id,x,y,layer,z\n")
    with pytest.raises(DatasetError, match=r"dataset\.json: fault 'F3': missing key 'kind'"):
        load_dataset(edit(v2_dir, fn))


def test_v1_files_load_unchanged(tmp_path):
    # A version 1 file is read as before (the same data; a v1 file relabelled
    # 2 is the same dataset too, v2 being a superset).
    ds = synthetic(0, n_boreholes=20)
    js = ds.save(tmp_path / "v1")
    assert json.loads(js.read_text())["faultmesh_dataset"] == 1
    one = load_dataset(js)
    assert one == ds and one.drillholes is None and not one.boreholes.desurveyed
    edit(js.parent, lambda doc: doc.update({"faultmesh_dataset": 2}))
    assert load_dataset(js) == one


# ---------------------------------------------------------------------------
# build_model on faults to derive
# ---------------------------------------------------------------------------
def test_build_derives_what_a_fault_lacks():
    from faultmesh.derive import derive_faults

    ds = synthetic(0, n_boreholes=20)
    f = ds.faults[0]
    pts = np.vstack([t.plane for t in f.traces])
    # Without cutoffs (plane traces and points, points only) or without kind:
    # build_model derives them (faultmesh.derive) and the model checks.
    for fault in (replace(f, traces=[replace(t, layers={}) for t in f.traces], points=pts),
                  replace(f, traces=[], points=pts), replace(f, kind=None)):
        m = fm.build_model(replace(ds, faults=[fault]), evaluate=False)
        m.check()
        assert m.metadata["derived_faults"]["F1"]["kind"] == f.kind
    # Fault points beside hand-drawn cutoffs: the hand-drawn cutoffs win (every
    # trace of the input is in the derived dataset as it was).
    d = derive_faults(replace(ds, faults=[replace(f, points=pts, throw={"max": 30.0})]))
    g = d.faults[0]
    for t in f.traces:
        assert any(u.section == t.section and list(u.layers) == list(t.layers)
                   and all(np.array_equal(u.layers[lay][side], t.layers[lay][side])
                           for lay in t.layers for side in ("foot", "hanging"))
                   for u in g.traces), t.section


# ---------------------------------------------------------------------------
# Writing: version choice and round trips
# ---------------------------------------------------------------------------
def test_save_v2_round_trip_writes_the_tables_back(v2_dir, tmp_path):
    ds = load_dataset(v2_dir)
    js = ds.save(tmp_path / "out")
    doc = json.loads(js.read_text())
    assert doc["faultmesh_dataset"] == 2
    assert doc["boreholes"] == {"collars": "collars.csv", "surveys": "surveys.csv",
                                "intervals": "intervals.csv", "other_units": ["cover"]}
    f1, f2, f3 = doc["faults"]
    assert "kind" not in f1 and f1["points"] == "fault_F1_points.csv"
    assert f1["throw"] == {"max": 40.0}
    assert f2["surface"] == "fault_F2_surface.ts" and "traces" not in f2
    back = load_dataset(js)
    assert back == ds and back.allclose(ds)
    assert back.fault("F1").sticks.tolist() == ds.fault("F1").sticks.tolist()
    assert back.adjustments == ds.adjustments
    # Version 1 cannot hold it: the reason is named.
    with pytest.raises(DatasetError, match=r"version 1 cannot hold this dataset: fault 'F1' has "
                                           r"no kind.*save with version=2"):
        ds.save(tmp_path / "v1", version=1)
    assert not (tmp_path / "v1").exists()                 # nothing written
    with pytest.raises(DatasetError, match="version must be one of"):
        ds.save(tmp_path / "v3", version=3)


def test_save_of_changed_boreholes(v2_dir, tmp_path):
    ds = load_dataset(v2_dir)
    # Tops changed in memory: the tables no longer give them. Deviated
    # hole H4's tops cannot be one XY per hole: an error saying why.
    fewer = replace(ds, boreholes=ds.boreholes.subset(ds.boreholes.layer != "C"))
    with pytest.raises(DatasetError, match=r"tops desurveyed along deviated holes.*hole 'H4' is at "
                                           r"two places.*no longer give them"):
        fewer.save(tmp_path / "a")
    # Without H4 the tops are a plain table (vertical holes: one XY each).
    vert = replace(ds, boreholes=ds.boreholes.subset(ds.boreholes.hole_id != "H4"))
    js = vert.save(tmp_path / "b")
    assert json.loads(js.read_text())["boreholes"] == "boreholes.csv"
    assert load_dataset(js) == vert
    # Unchanged tops but the v1 format asked for: the tables' hole H4 cannot go
    # into a plain table; the message points at version 2.
    only_traces = replace(ds, faults=[replace(ds.faults[2], throw=None)])
    with pytest.raises(DatasetError, match="save with version=2 to write the drillhole tables"):
        only_traces.save(tmp_path / "c", version=1)
    assert json.loads(only_traces.save(tmp_path / "d").read_text())["faultmesh_dataset"] == 2


def test_save_v1_stays_v1(tmp_path):
    ds = synthetic(0, n_boreholes=20)
    js = ds.save(tmp_path / "a.json")
    doc = json.loads(js.read_text())
    assert doc["faultmesh_dataset"] == 1 and doc["boreholes"] == "a_boreholes.csv"
    assert load_dataset(js) == ds
    js2 = ds.save(tmp_path / "b", version=2)
    assert json.loads(js2.read_text())["faultmesh_dataset"] == 2
    assert load_dataset(js2) == ds


_coord = st.floats(10.0, 990.0, allow_nan=False).map(lambda v: round(v, 3))


@st.composite
def v2_faults(draw):
    """Faults with any mix of v2 data: points (with or without sticks), a
    surface, a throw, no kind; each with at least one source of geometry."""
    faults = []
    for i in range(draw(st.integers(1, 3))):
        n = draw(st.integers(3, 8))
        pts = draw(st.lists(st.tuples(_coord, _coord, st.floats(-500, 500).map(
            lambda v: round(v, 2))), min_size=n, max_size=n, unique=True))
        pts = np.array(pts, dtype=np.float64)
        sticks = None
        if draw(st.booleans()):
            cut = draw(st.integers(2, n - 1)) if n >= 4 else n
            sticks = np.array(["a"] * cut + ["b"] * (n - cut))
            if n - cut == 1:
                sticks[-1] = "a"
        surface = None
        if draw(st.booleans()):
            surface = (pts[:3].copy(), np.array([[0, 1, 2]]))
        use_points = draw(st.booleans()) or surface is None
        faults.append(Fault(f"F{i}", draw(st.sampled_from([None, "normal", "reverse"])),
                            draw(st.sampled_from([None, "g"])),
                            points=pts if use_points else None,
                            sticks=sticks if use_points else None, surface=surface,
                            throw=draw(st.sampled_from([None, {"max": 12.5}]))))
    return faults


@settings(max_examples=25, deadline=None)
@given(v2_faults())
def test_round_trip_v2_faults(tmp_path_factory, faults):
    base = synthetic(0, n_boreholes=12)
    ring = np.array([[0.0, 0], [1000, 0], [1000, 1000], [0, 1000]])
    b = Boreholes(np.repeat(["a", "b", "c"], 3), np.repeat([[100.0, 100], [900, 200], [500, 800]], 3, 0),
                  ["L1", "L2", "L3"] * 3, [0.0, -10, -20] * 3)
    ds = Dataset("rt", base.layers, ring, b, faults=faults)
    back = load_dataset(ds.save(tmp_path_factory.mktemp("rt")))
    assert back == ds and back.allclose(ds)


def test_interleaved_sticks_save_as_consecutive_rows(tmp_path):
    # In memory a stick's points may be interleaved with another's (the
    # derive fuzz generator makes such faults); the file wants each stick's
    # rows consecutive, so saving wrote a file its loader refused ("stick '0'
    # resumes after other sticks"). Saved now stick by stick, in order of
    # first appearance, each stick's points in their order.
    base = synthetic(0, n_boreholes=12)
    ring = np.array([[0.0, 0], [1000, 0], [1000, 1000], [0, 1000]])
    b = Boreholes(np.repeat(["a", "b", "c"], 3), np.repeat([[100.0, 100], [900, 200], [500, 800]], 3, 0),
                  ["L1", "L2", "L3"] * 3, [0.0, -10, -20] * 3)
    P = np.array([[400, 0, 0], [600, 0, 0], [400, 500, -50], [600, 500, -50], [400, 900, -90.0]])
    f = Fault("F", points=P, sticks=np.array(["s1", "s2", "s1", "s2", "s1"]))
    back = load_dataset(Dataset("rt", base.layers, ring, b, faults=[f]).save(tmp_path / "o"))
    g = back.fault("F")
    assert g.sticks.tolist() == ["s1"] * 3 + ["s2"] * 2
    np.testing.assert_array_equal(g.points, P[[0, 2, 4, 1, 3]])


# ---------------------------------------------------------------------------
# Deviated drillholes vs the equivalent hole_id,x,y,layer,z table: same model
# ---------------------------------------------------------------------------
TOTAL = 160.0   # every hole's length: past the lowest layer's top everywhere


def deviated_holes(ds, rng):
    """Holes (id, collar, stations): 30 on a 6 x 5 grid over the area, in
    random directions, steeper than the fault (dip -65 to -88, fault dip 60),
    and the six of the drillhole tests collared in the hanging wall at the
    largest throw and drilled towards the footwall, across the fault. So
    none re-enters a layer it left: a hole through a normal fault goes from
    its hanging wall into its footwall, from younger into older rock (a layer
    repeated in a hole would be one hit in table form, two in the plain table
    of per-top ids). Stations every 30 m, curving up to 2 degrees between
    stations; angles to 0.01 degree, collars to 1 mm (write_tables writes
    depths to 1 mm)."""
    geo = ds.geology
    ring = ds.boundary
    lo, hi = ring.min(axis=0), ring.max(axis=0)
    holes = []
    for fx in np.linspace(0.1, 0.9, 6):
        for fy in np.linspace(0.12, 0.88, 5):
            p = np.round(lo + (hi - lo) * [fx, fy], 3)
            if not fm.dataset.points_in_polygon(p[None], ring)[0]:
                continue
            z = round(float(geo.truth(geo.layers[0], p[0:1], p[1:2])[0]), 3)
            az, dip = float(rng.uniform(0, 360)), float(rng.uniform(-88, -65))
            stations = []
            for d in range(0, int(TOTAL) + 1, 30):
                stations.append((float(d), round(az % 360, 2), round(dip, 2)))
                az += float(rng.uniform(-2, 2))
                dip = float(np.clip(dip + rng.uniform(-2, 2), -88.0, -65.0))
            holes.append((f"D{len(holes) + 1}", (p[0], p[1], z), stations))
    across = ground_holes(ds, rng)[6:]
    return holes + [(f"X{i + 1}", collar, stations) for i, (_, collar, stations) in
                    enumerate(across)]


def test_deviated_drillholes_give_the_same_model_as_the_plain_table(tmp_path):
    ds = synthetic(0, n_boreholes=30)            # its ground, boundary, sections, faults
    geo = ds.geology
    holes = deviated_holes(ds, np.random.default_rng(5))
    contacts = trace(geo, holes, TOTAL)
    assert sum(c[3] for cs in contacts.values() for c in cs) >= 4   # contacts at the fault
    d = tmp_path / "ds"
    ds.save(d)                               # the v1 dataset, hand-drawn fault traces
    write_tables(d, geo.layers, holes, contacts, TOTAL)
    # The equivalent plain table: the exact tops (contacts found to 1e-12 m
    # on the ground, positions by independent minimum-curvature arcs), at full
    # precision; one id per top (a table row's hole has one XY).
    exact = expected_tops(geo.layers, holes, contacts)
    pairs = list(zip(exact.hole_id.tolist(), exact.layer.tolist()))
    assert len(set(pairs)) == len(pairs)          # no layer met twice in a hole
    write(d / "tops.csv", "hole_id,x,y,layer,z\n" + "".join(
        f"{h}/{lay},{x!r},{y!r},{lay},{z!r}\n"
        for (h, lay), (x, y), z in zip(pairs, exact.xy.tolist(), exact.z.tolist())))

    def as_tables(doc):
        doc["faultmesh_dataset"] = 2
        doc["boreholes"] = {"collars": "collars.csv", "surveys": "surveys.csv",
                            "intervals": "intervals.csv", "other_units": ["void"]}
    tab = load_dataset(edit(d, as_tables))
    plain = load_dataset(edit(d, lambda doc: doc.update({"boreholes": "tops.csv"})))
    # The holes are deviated, and the two forms give the same points within
    # the logging's rounding (depths to 1 mm: a top moves <= 0.5 mm).
    _, first, inv = np.unique(tab.boreholes.hole_id, return_index=True, return_inverse=True)
    assert np.hypot(*(tab.boreholes.xy - tab.boreholes.xy[first[inv]]).T).max() > 10.0
    assert len(tab.boreholes) == len(plain.boreholes) >= 90
    for lay in geo.layers:
        a, b = tab.layer_points(lay), plain.layer_points(lay)
        assert a.shape == b.shape and np.abs(a - b).max() <= 0.5e-3 + 1e-9, lay
    ma = fm.build_model(tab, evaluate=False)
    mb = fm.build_model(plain, evaluate=False)
    ma.check()
    mb.check()
    assert list(ma.surfaces) == list(mb.surfaces) == geo.layers
    for lay in geo.layers:
        sa, sb = ma.surfaces[lay], mb.surfaces[lay]
        np.testing.assert_array_equal(sa.triangles, sb.triangles)
        dz = np.abs(sa.vertices[:, 2] - sb.vertices[:, 2])
        dxy = np.hypot(*(sa.vertices[:, :2] - sb.vertices[:, :2]).T)
        assert dz.max() <= 1e-3 and dxy.max() <= 1e-3, (lay, dz.max(), dxy.max())
        assert ma.metadata["stitch"][lay][0]["gaps"] >= 1     # the fault cuts every layer


# ---------------------------------------------------------------------------
# Points only: no boreholes
# ---------------------------------------------------------------------------
def test_points_only_dataset_builds_and_checks(tmp_path):
    ds = synthetic(0, n_boreholes=30)
    d = tmp_path / "pts"
    ds.save(d)

    def only_points(doc):
        doc["faultmesh_dataset"] = 2
        del doc["boreholes"]
        doc["points"] = {lay: f"picks_{lay}.csv" for lay in ds.layers}
    for lay in ds.layers:
        P = ds.layer_points(lay)
        write(d / f"picks_{lay}.csv", "x,y,z\n" + "".join(f"{x!r},{y!r},{z!r}\n"
                                                          for x, y, z in P.tolist()))
    pts = load_dataset(edit(d, only_points))
    assert len(pts.boreholes) == 0 and pts.faults == ds.faults
    m = fm.build_model(pts, evaluate=False)
    m.check()
    # The same layer data as the boreholes gave (one hit per hole and layer):
    # the same model.
    ref = fm.build_model(ds, evaluate=False)
    for lay in ds.layers:
        np.testing.assert_array_equal(m.surfaces[lay].triangles, ref.surfaces[lay].triangles)
        np.testing.assert_array_equal(m.surfaces[lay].vertices, ref.surfaces[lay].vertices)


def test_a_dataset_made_in_memory_needs_no_boreholes():
    """Format v2 makes ``boreholes`` optional, so does the numpy API: a
    Dataset made in memory with points only (boreholes left out or None)
    builds the model of the same data given as borehole rows. Before, a
    Dataset without boreholes failed in derive_faults with "AttributeError:
    'NoneType' object has no attribute 'layer'"."""
    ds = synthetic(0, n_boreholes=30)
    pts = Dataset(name="pts", layers=ds.layers, boundary=ds.boundary,
                  points={lay: ds.layer_points(lay) for lay in ds.layers}, faults=ds.faults)
    assert len(pts.boreholes) == 0
    m = fm.build_model(pts, evaluate=False)
    m.check()
    ref = fm.build_model(ds, evaluate=False)
    for lay in ds.layers:
        np.testing.assert_array_equal(m.surfaces[lay].vertices, ref.surfaces[lay].vertices)
    with pytest.raises(DatasetError, match="boreholes must be a Boreholes table or None, got dict"):
        Dataset(name="bad", layers=ds.layers, boundary=ds.boundary, boreholes={"collars": "c.csv"})


# ---------------------------------------------------------------------------
# Fuzz: mutated v2 JSON loads or raises a DatasetError naming where
# ---------------------------------------------------------------------------
_JUNK = st.one_of(st.none(), st.booleans(), st.integers(-3, 3), st.floats(allow_nan=True),
                  st.sampled_from(["", "A", "B", "cover", "max", "collars.csv", "f2.ts",
                                   "../x.csv", "normal", "reverse", "nope.csv", "f1.csv"]),
                  st.lists(st.sampled_from(["A", "cover", 1, None]), max_size=3),
                  st.dictionaries(st.sampled_from(["max", "min", "collars", "x"]),
                                  st.sampled_from([1, -1, "a", None]), max_size=2))


def _paths(doc, prefix=()):
    out = [prefix]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, prefix + (i,))
    return out


@st.composite
def mutated_v2_docs(draw):
    doc = full_doc()
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p in _paths(doc) if p]
        path = draw(st.sampled_from(paths))
        parent = doc
        for k in path[:-1]:
            parent = parent[k]
        op = draw(st.sampled_from(["value", "delete", "rename"]))
        if op == "value":
            parent[path[-1]] = draw(_JUNK)
        elif op == "delete":
            del parent[path[-1]]
        elif isinstance(parent, dict):
            parent[path[-1] + draw(st.sampled_from(["s", "_", "X"]))] = parent.pop(path[-1])
    return doc


@pytest.mark.fuzz
@fuzz_settings(150)
@given(mutated_v2_docs())
def test_fuzz_mutated_v2_json(tmp_path_factory, doc):
    import warnings

    d = tmp_path_factory.mktemp("v2fuzz")
    for name, text in (("collars.csv", COLLARS), ("surveys.csv", SURVEYS),
                       ("intervals.csv", INTERVALS), ("topo.csv", TOPO), ("f1.csv", F1_POINTS)):
        write(d / name, text)
    fm.formats.gocad.write_ts(f2_surface(), d / "f2.ts")
    js = write(d / "dataset.json", json.dumps(doc, allow_nan=True))
    with warnings.catch_warnings():
        warnings.simplefilter("error")               # a numpy RuntimeWarning is a bug too
        try:
            ds = load_dataset(js)
        except DatasetError as e:
            msg = str(e)
            assert str(d) in msg, msg                    # names the JSON or the data file
            return
    # A dataset that loads survives save + load.
    back = load_dataset(ds.save(tmp_path_factory.mktemp("v2fuzz_out")))
    assert back == ds


# ---------------------------------------------------------------------------
# The documentation's example
# ---------------------------------------------------------------------------
def test_the_v2_example_of_the_docs_loads(tmp_path):
    # The complete v2 example of docs/dataset.md, with data files made here:
    # flat layers (picks on a grid), two vertical holes, fault picks, sticks
    # and a surface. Every key of the example must be read as documented.
    text = (Path(__file__).parents[1] / "docs" / "dataset.md").read_text()
    block = re.search(r"## Version 2\n.*?```json\n(.*?)```", text, re.S).group(1)
    doc = json.loads(block)
    assert doc["faultmesh_dataset"] == 2
    d = tmp_path / "example"
    d.mkdir()
    write(d / "dataset.json", block)
    grid = [(x, y) for x in (200.0, 2000.0, 3800.0) for y in (200.0, 1500.0, 2800.0)]
    for k, lay in enumerate(doc["layers"]):
        write(d / doc["points"][lay], "x,y,z\n" + "".join(f"{x},{y},{-100.0 * k}\n"
                                                          for x, y in grid))
    write(d / "collars.csv", "hole_id,x,y,z\nW1,500,500,0\nW2,3500,2500,0\n")
    write(d / "surveys.csv", "hole_id,depth,azimuth,dip\nW2,0,0,-90\n")
    write(d / "intervals.csv", "hole_id,from,to,unit\n" + "".join(
        f"{h},{100 * k},{100 * k + 100},{lay}\n" for h in ("W1", "W2")
        for k, lay in enumerate(doc["layers"])) + "W1,400,402,fault gouge\n")
    write(d / "fault_F1.csv", "x,y,z\n2000,0,0\n2050,1500,-300\n2100,3000,-600\n")
    write(d / "fault_F3_sticks.csv", "x,y,z,stick\n1200,1500,-50,1\n1300,1500,-900,1\n"
          "1400,2400,-50,2\n1480,2400,-900,2\n")
    fm.formats.gocad.write_ts(f2_surface(), d / "fault_F2.ts")
    ds = load_dataset(d)
    assert ds.layers == doc["layers"] and ds.crs == "EPSG:23031"
    assert ds.drillholes.other_units == ("unknown", "fault gouge")
    assert ds.boreholes.hole_id.tolist() == ["W1"] * 4 + ["W2"] * 4
    f1, f2, f3 = ds.faults
    assert (f1.kind, f1.throw, f1.traces, f1.sticks) == (None, {"max": 40.0}, [], None)
    assert f2.kind == "normal" and f2.surface is not None and len(f2.tips) == 1
    assert f3.group == "F3-F4" and f3.sticks.tolist() == ["1", "1", "2", "2"]
    assert [list(t.layers) for t in f3.traces] == [["val_250"], []]
    np.testing.assert_array_equal(f3.traces[0].plane[0], [1210, 1500, -50])


def test_derived_key_round_trips_and_bad_values_are_named(v2_dir, tmp_path):
    # F3 has layer cutoffs: marked derived it loads so, and saves so.
    p = edit(v2_dir, lambda doc: doc["faults"][2].update(derived=True))
    ds = load_dataset(p)
    assert [f.derived for f in ds.faults] == [False, False, True]
    back = load_dataset(ds.save(tmp_path / "out"))
    assert [f.derived for f in back.faults] == [False, False, True]
    assert json.loads((tmp_path / "out" / "dataset.json").read_text())["faults"][2]["derived"] is True
    # What makes version 1 refuse it (Dataset.save quotes the first three).
    from faultmesh.dataset import _v2_only
    assert "fault 'F3' has derived cutoffs" in _v2_only(ds)
    # Not a boolean; and true on a fault whose traces have no cutoffs.
    p = edit(v2_dir, lambda doc: doc["faults"][2].update(derived="yes"))
    with pytest.raises(DatasetError, match=r"fault 'F3' derived.*must be true or false, got 'yes'"):
        load_dataset(p)
    # A derived fault that cuts no layer (plane traces only; the build
    # leaves it out) needs no derivation once its points are used up.
    from faultmesh.derive import needs_derivation
    p = edit(v2_dir, lambda doc: (doc["faults"][2].update(derived=False),
                                  doc["faults"][0].update(derived=True)))
    f1 = load_dataset(p).faults[0]
    assert f1.derived and needs_derivation(f1)          # it still has its points
    f1.points = f1.sticks = None
    f1.kind = "normal"
    assert not needs_derivation(f1)
