"""The format-v1 dataset loader, validator and writer (faultmesh.dataset)."""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import faultmesh as fm
from faultmesh.dataset import Section, points_in_polygon

DATA = Path(__file__).resolve().parent / "data" / "datasets"
SMALL = DATA / "small"
INVALID = DATA / "invalid"


# ---------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------
@pytest.fixture
def small_copy(tmp_path):
    """A writable copy of the small dataset; returns the JSON path."""
    d = tmp_path / "small"
    shutil.copytree(SMALL, d)
    return d / "dataset.json"


def edit_json(path: Path, fn) -> Path:
    doc = json.loads(path.read_text())
    fn(doc)
    path.write_text(json.dumps(doc))
    return path


def edit_csv_line(path: Path, line_no: int, text: str) -> None:
    """Replace the 1-based physical line ``line_no`` of a CSV."""
    lines = path.read_text().splitlines()
    lines[line_no - 1] = text
    path.write_text("\n".join(lines) + "\n")


def expect_error(path, *fragments):
    with pytest.raises(fm.DatasetError) as ei:
        fm.load_dataset(path)
    msg = str(ei.value)
    for frag in fragments:
        assert frag in msg, f"{frag!r} not in message {msg!r}"
    return msg


# ---------------------------------------------------------------------------
# loading valid datasets
# ---------------------------------------------------------------------------
def test_load_small_contents():
    ds = fm.load_dataset(SMALL / "dataset.json")
    assert ds.name == "small"
    assert ds.crs == "local grid, metres"
    assert ds.layers == ["top", "seam_a", "seam_b"]
    assert ds.path == SMALL / "dataset.json"
    assert ds.truth is None and ds.geology is None
    b = ds.boreholes
    assert len(b) == 27 and b.n_holes == 9
    assert b.xy.dtype == np.float64 and b.xy.shape == (27, 2)
    assert set(b.layer) == {"top", "seam_a", "seam_b"}
    # Boundary given clockwise in the file, returned counter-clockwise.
    r = ds.boundary
    area2 = np.sum(r[:, 0] * np.roll(r[:, 1], -1) - np.roll(r[:, 0], -1) * r[:, 1])
    assert area2 == pytest.approx(2 * 800_000.0)
    assert {tuple(p) for p in r} == {(0, 0), (1000, 0), (1000, 800), (0, 800)}
    assert ds.points["top"].shape == (6, 3)
    assert list(ds.sections) == ["L1", "L2"]
    assert ds.sections["L2"].azimuth == 30.0
    assert [f.name for f in ds.faults] == ["F1", "F2"]
    f1, f2 = ds.faults
    assert (f1.kind, f1.group, f1.tips.shape) == ("reverse", "north", (2, 2))
    assert (f2.kind, f2.group, f2.tips.shape) == ("normal", None, (0, 2))
    assert [t.section for t in f1.traces] == ["L1", "L2"]
    assert f2.traces[0].section is None


def test_load_directory_equals_file():
    assert fm.load_dataset(SMALL) == fm.load_dataset(SMALL / "dataset.json")
    assert fm.load_dataset(str(SMALL)) == fm.load_dataset(SMALL)


def test_section_local_points_are_converted():
    ds = fm.load_dataset(SMALL)
    t = ds.faults[0].traces[0]  # on L1: origin (100, 0), azimuth 0 (north)
    np.testing.assert_array_equal(
        t.plane, [[100, 380, -50], [100, 392, -80], [100, 400, -100], [100, 420, -150]])
    np.testing.assert_array_equal(t.layers["seam_a"]["foot"][:, 1], [300, 350, 400])
    np.testing.assert_array_equal(t.layers["seam_a"]["hanging"][0], [100, 392, -80])
    # On L2 (azimuth 30) the file gives XYZ; they lie on the line.
    t2 = ds.faults[0].traces[1]
    sec = ds.sections["L2"]
    s = sec.to_s(t2.plane[:, :2])
    np.testing.assert_allclose(sec.to_xy(s), t2.plane[:, :2], atol=1e-9)
    np.testing.assert_allclose(s, [380, 400, 420], atol=1e-9)


def test_section_geometry():
    east = Section("E", [10.0, 20.0], 90.0)
    np.testing.assert_array_equal(east.to_xy([0, 5]), [[10, 20], [15, 20]])  # exact on compass points
    south = Section("S", [0.0, 0.0], 180.0)
    np.testing.assert_array_equal(south.to_xy([3]), [[0, -3]])
    ne = Section("NE", [1.0, 2.0], 45.0)
    xy = ne.to_xy([np.sqrt(2.0)])
    np.testing.assert_allclose(xy, [[2.0, 3.0]], atol=1e-12)
    np.testing.assert_allclose(ne.to_s(xy), [np.sqrt(2.0)], atol=1e-12)
    # Azimuth is clockwise from north: 300 degrees points west-north-west.
    d = Section("W", [0, 0], 300.0).direction
    assert d[0] < 0 and d[1] > 0


def test_layer_points_keep_shallowest_repeated_hit():
    ds = fm.load_dataset(SMALL)
    pts = ds.layer_points("seam_a")
    # B5 hits seam_a twice (-78.0 hanging wall, -100.5 footwall): one point, the upper.
    at_b5 = pts[(pts[:, 0] == 520) & (pts[:, 1] == 398)]
    np.testing.assert_array_equal(at_b5, [[520, 398, -78.0]])
    assert len(pts) == 9
    # Extra points are appended after the borehole hits.
    top = ds.layer_points("top")
    assert len(top) == 9 + 6
    np.testing.assert_array_equal(top[-6:], ds.points["top"])
    assert ds.layer_points("seam_b").shape == (8, 3)  # B3 does not reach seam_b
    with pytest.raises(fm.DatasetError, match="unknown layer 'nope'"):
        ds.layer_points("nope")


def test_layer_points_independent_of_row_order(small_copy):
    csv = small_copy.parent / "boreholes.csv"
    lines = csv.read_text().splitlines()
    # Put B5's footwall hit before its hanging-wall hit.
    i = lines.index("B5,520,398,seam_a,-78.0")
    j = lines.index("B5,520,398,seam_a,-100.5")
    lines[i], lines[j] = lines[j], lines[i]
    csv.write_text("\n".join(lines) + "\n")
    a = fm.load_dataset(small_copy).layer_points("seam_a")
    b = fm.load_dataset(SMALL).layer_points("seam_a")
    np.testing.assert_array_equal(a, b)


def test_fault_groups():
    ds = fm.load_dataset(SMALL)
    assert [[f.name for f in g] for g in ds.fault_groups()] == [["F1"], ["F2"]]
    ds.faults[1].group = "north"
    ds.faults.append(fm.dataset.Fault("F3", "normal", None, np.zeros((0, 2)), []))
    assert [[f.name for f in g] for g in ds.fault_groups()] == [["F1", "F2"], ["F3"]]


def test_default_boundary_is_bounding_box_ccw():
    ds = fm.load_dataset(DATA / "bbox")
    np.testing.assert_array_equal(ds.boundary, [[0, 0], [400, 0], [400, 300], [0, 300]])
    assert ds.faults == [] and ds.sections == {}
    assert ds.name == "bbox"


def test_closed_boundary_ring_is_accepted(small_copy):
    edit_json(small_copy, lambda d: d["boundary"].append(d["boundary"][0]))
    assert len(fm.load_dataset(small_copy).boundary) == 4


def test_points_csv_without_header_and_inline_points(small_copy):
    topo = small_copy.parent / "topo.csv"
    topo.write_text("\n".join(topo.read_text().splitlines()[1:]) + "\n")
    a = fm.load_dataset(small_copy)
    np.testing.assert_array_equal(a.points["top"], fm.load_dataset(SMALL).points["top"])
    edit_json(small_copy, lambda d: d["points"].update({"seam_b": [[10, 10, -150], [20, 30, -151]]}))
    assert fm.load_dataset(small_copy).points["seam_b"].shape == (2, 3)


def test_unknown_top_level_key_is_an_error_with_a_suggestion(small_copy):
    # Was a warning only; an unknown key is now an error at every depth
    # (test_dataset_input.py has the nested ones).
    edit_json(small_copy, lambda d: d.update({"boundry": [[0, 0], [1, 0], [1, 1]]}))
    expect_error(small_copy, "unknown key 'boundry'", "did you mean 'boundary'?")


def test_points_in_polygon_exact_on_boundary():
    ring = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    pts = np.array([[0.5, 0.5], [0, 0.5], [1, 1], [1 + 1e-15, 0.5], [0.5, -1e-300], [2, 2]])
    np.testing.assert_array_equal(points_in_polygon(pts, ring),
                                  [True, True, True, False, False, False])
    # A concave ring: the notch is outside.
    l_shape = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], dtype=float)
    np.testing.assert_array_equal(points_in_polygon([[1.5, 1.5], [0.5, 1.5], [1.5, 0.5]], l_shape),
                                  [False, True, True])


# ---------------------------------------------------------------------------
# validation errors: message names file, row/field or fault/trace/layer
# ---------------------------------------------------------------------------
def test_error_unknown_layer_in_boreholes_names_file_row_field():
    expect_error(INVALID / "unknown_layer.json", "unknown_layer.csv", "row 5", "field 'layer'",
                 "'coal_9'")


def test_error_nan_value():
    expect_error(INVALID / "nan_z.json", "nan_z.csv", "row 4", "field 'z'", "not a finite number")


def test_error_non_numeric_value(small_copy):
    csv = small_copy.parent / "boreholes.csv"
    edit_csv_line(csv, 7, "B3,9O0,90,top,50.1")  # letter O instead of zero
    expect_error(small_copy, "boreholes.csv", "row 7", "field 'x'", "'9O0' is not a number")


def test_error_row_numbers_count_blank_and_comment_lines(small_copy):
    csv = small_copy.parent / "boreholes.csv"
    # Line 12 comes after a blank line (10) and a comment line (11).
    assert csv.read_text().splitlines()[11].startswith("B4,120,410,top")
    edit_csv_line(csv, 12, "B4,120,410,top,")
    expect_error(small_copy, "boreholes.csv", "row 12", "field 'z'", "missing value")


def test_error_nan_in_points_csv(small_copy):
    edit_csv_line(small_copy.parent / "topo.csv", 3, "1000,nan,49.0")
    expect_error(small_copy, "topo.csv", "row 3", "field 'y'", "not a finite number")


def test_error_wrong_field_count_and_header(small_copy):
    csv = small_copy.parent / "boreholes.csv"
    edit_csv_line(csv, 4, "B1,100,100,seam_b")
    expect_error(small_copy, "boreholes.csv", "row 4", "expected 5 fields, got 4")
    edit_csv_line(csv, 1, "hole,x,y,layer,z")
    expect_error(small_copy, "boreholes.csv", "row 1", "header lacks column(s) ['hole_id']")


def test_error_empty_hole_id(small_copy):
    edit_csv_line(small_copy.parent / "boreholes.csv", 2, ",100,100,top,52.0")
    expect_error(small_copy, "row 2", "field 'hole_id'", "missing value")


def test_error_self_intersecting_boundary():
    expect_error(INVALID / "bowtie.json", "bowtie.json", "boundary", "self-intersecting",
                 "edge 0", "edge 2")


@pytest.mark.parametrize("ring, why", [
    ([[0, 0], [10, 0], [10, 10], [5, 0], [0, 10]], "self-intersecting"),       # touches itself
    ([[0, 0], [4, 0], [5, 5], [6, 0], [10, 0], [10, 10], [5, 5], [0, 10]],
     "self-intersecting"),                                                     # repeated vertex
    ([[0, 0], [10, 0], [10, 10], [0, 10], [10, 0]], "fold back"),             # spike at vertex 0
    ([[0, 0], [10, 0], [10, 0], [0, 10]], "vertices 1 and 2 coincide"),
    ([[0, 0], [5, 0], [10, 0]], "collinear"),
    ([[0, 0], [10, 0], [5, 0], [5, 5]], "fold back"),
    ([[0, 0], [10, 0]], "at least 3 vertices"),
])
def test_error_degenerate_boundaries(small_copy, ring, why):
    edit_json(small_copy, lambda d: d.update({"boundary": ring}))
    expect_error(small_copy, "dataset.json", "boundary", why)


def test_error_boundary_nan_value(small_copy):
    edit_json(small_copy, lambda d: d["boundary"][2].__setitem__(1, "x"))
    expect_error(small_copy, "boundary point 3 y", "is not a number")


def test_error_trace_with_fewer_than_two_points(small_copy):
    def f(d):
        d["faults"][0]["traces"][1]["plane"] = [[800, 346.41016151377545, -100]]
    edit_json(small_copy, f)
    expect_error(small_copy, "dataset.json", "fault 'F1' trace 2 plane", "at least two points, got 1")


def test_error_layer_polyline_with_one_point(small_copy):
    def f(d):
        d["faults"][1]["traces"][0]["layers"]["seam_b"]["hanging"] = [[703, 630, -130]]
    edit_json(small_copy, f)
    expect_error(small_copy, "fault 'F2' trace 1 layer 'seam_b' hanging", "at least two points")


def test_fault_tip_outside_study_area_is_dropped_and_recorded():
    # Was an error ("outside the study-area boundary"); the input policy
    # drops a tip beyond the boundary (that end then reaches the boundary).
    ds = fm.load_dataset(INVALID / "outside.json")
    assert ds.fault("FX").tips.shape == (0, 2)
    (a,) = ds.adjustments
    assert (a.what, a.item, a.before, a.after) == ("dropped", "fault 'FX' tip 1", (1200.0, 500.0),
                                                   None)
    assert a.distance == pytest.approx(200.0)


def test_trace_polyline_leaving_the_study_area_is_clipped(small_copy):
    def f(d):
        d["faults"][1]["traces"][0]["layers"]["seam_b"]["hanging"][1] = [710, 880, -131]
    edit_json(small_copy, f)
    ds = fm.load_dataset(small_copy)
    hang = ds.fault("F2").traces[0].layers["seam_b"]["hanging"]
    # Cut at y = 800 (the boundary), z interpolated along the segment.
    t = (800 - 630) / (880 - 630)
    assert hang[0].tolist() == [703, 630, -130]
    assert hang[1, 1] == 800.0
    assert hang[1, 0] == pytest.approx(703 + 7 * t) and hang[1, 2] == pytest.approx(-130 - t)
    kinds = sorted(a.what for a in ds.adjustments)
    assert kinds == ["clipped", "dropped"]
    clip = next(a for a in ds.adjustments if a.what == "clipped")
    assert clip.item == "fault 'F2' trace 1 layer 'seam_b' hanging between points 1 and 2"
    assert clip.before == (710.0, 880.0) and clip.distance == pytest.approx(80.0)


def test_error_missing_files(tmp_path, small_copy):
    expect_error(tmp_path / "nothing.json", "nothing.json", "not found")
    os.remove(small_copy.parent / "topo.csv")
    expect_error(small_copy, "dataset.json", "points['top']", "topo.csv", "not found")
    os.remove(small_copy.parent / "boreholes.csv")
    expect_error(small_copy, "boreholes", "boreholes.csv", "not found")


def test_error_unknown_section(small_copy):
    edit_json(small_copy, lambda d: d["faults"][0]["traces"][1].update({"section": "L9"}))
    expect_error(small_copy, "fault 'F1' trace 2", "unknown section 'L9'", "['L1', 'L2']")


@pytest.mark.parametrize("version", [3, 0, "1", True, None, 2.0])
def test_error_wrong_version(small_copy, version):
    edit_json(small_copy, lambda d: d.update({"faultmesh_dataset": version}))
    expect_error(small_copy, "dataset.json", "faultmesh_dataset", "unsupported format version")


@pytest.mark.parametrize("drop, where", [
    (lambda d: d.pop("faultmesh_dataset"), "missing key 'faultmesh_dataset'"),
    (lambda d: d.pop("layers"), "missing key 'layers'"),
    (lambda d: d.pop("boreholes"), "missing key 'boreholes'"),
    (lambda d: d["sections"][1].pop("azimuth"), "section 'L2': missing key 'azimuth'"),
    (lambda d: d["faults"][1].pop("kind"), "fault 'F2': missing key 'kind'"),
    (lambda d: d["faults"][0].pop("traces"), "fault 'F1': missing key 'traces'"),
    (lambda d: d["faults"][0]["traces"][0].pop("plane"), "fault 'F1' trace 1: missing key 'plane'"),
    (lambda d: d["faults"][0]["traces"][0]["layers"]["seam_a"].pop("hanging"),
     "fault 'F1' trace 1 layer 'seam_a': missing key 'hanging'"),
])
def test_error_missing_keys(small_copy, drop, where):
    edit_json(small_copy, drop)
    expect_error(small_copy, "dataset.json", where)


def test_error_sz_point_without_section():
    expect_error(INVALID / "sz_without_section.json", "sz_without_section.json",
                 "fault 'F9' trace 1 layer 'seam_a' foot point 1",
                 "an [s, z] point needs the trace to name a section")


def test_error_unknown_layer_in_trace_and_points(small_copy):
    def f(d):
        d["faults"][0]["traces"][0]["layers"]["coal"] = d["faults"][0]["traces"][0]["layers"]["seam_a"]
    edit_json(small_copy, f)
    expect_error(small_copy, "fault 'F1' trace 1 layer 'coal'", "unknown layer 'coal'")
    shutil.copy(SMALL / "dataset.json", small_copy)
    edit_json(small_copy, lambda d: d["points"].update({"coal": "topo.csv"}))
    expect_error(small_copy, "points['coal']", "unknown layer 'coal'")


def test_error_bad_values_in_json(small_copy):
    edit_json(small_copy, lambda d: d["faults"][0]["traces"][0]["plane"][2].__setitem__(1, "deep"))
    expect_error(small_copy, "fault 'F1' trace 1 plane point 3 z", "'deep' is not a number")
    shutil.copy(SMALL / "dataset.json", small_copy)
    edit_json(small_copy, lambda d: d["faults"][1].update({"kind": "thrust"}))
    expect_error(small_copy, "fault 'F2' kind", "'normal' or 'reverse'", "'thrust'")
    shutil.copy(SMALL / "dataset.json", small_copy)
    edit_json(small_copy, lambda d: d["sections"][0].update({"origin": [1, 2, 3]}))
    expect_error(small_copy, "section 'L1' origin", "must be [x, y]")


def test_error_plane_not_top_down(small_copy):
    edit_json(small_copy, lambda d: d["faults"][0]["traces"][0]["plane"].reverse())
    expect_error(small_copy, "fault 'F1' trace 1 plane", "top down", "point 2 is higher")


def test_error_repeated_names(small_copy):
    edit_json(small_copy, lambda d: d["faults"][1].update({"name": "F1"}))
    expect_error(small_copy, "fault 'F1'", "repeated fault name")
    shutil.copy(SMALL / "dataset.json", small_copy)
    edit_json(small_copy, lambda d: d["layers"].append("top"))
    expect_error(small_copy, "layers", "repeated layer name(s) ['top']")


def test_error_invalid_json(small_copy):
    small_copy.write_text('{"faultmesh_dataset": 1,\n "layers": ["a",]\n}')
    expect_error(small_copy, "dataset.json", "not valid JSON", "line 2")


def test_error_layer_without_enough_points(small_copy):
    edit_json(small_copy, lambda d: d["layers"].append("seam_c"))
    expect_error(small_copy, "layer 'seam_c'", "has 0 data point(s)")


def test_error_degenerate_default_boundary(tmp_path):
    (tmp_path / "h.csv").write_text("hole_id,x,y,layer,z\nA,0,0,c,1\nB,5,0,c,2\nC,9,0,c,3\n")
    (tmp_path / "d.json").write_text('{"faultmesh_dataset": 1, "layers": ["c"], "boreholes": "h.csv"}')
    expect_error(tmp_path / "d.json", "boundary", "zero width or height")


# ---------------------------------------------------------------------------
# saving
# ---------------------------------------------------------------------------
def test_round_trip_small_exact(tmp_path):
    ds = fm.load_dataset(SMALL)
    p = ds.save(tmp_path / "out")
    assert p == tmp_path / "out" / "dataset.json"
    assert sorted(os.listdir(p.parent)) == ["boreholes.csv", "dataset.json", "points_top.csv"]
    back = fm.load_dataset(p)
    assert back == ds
    assert back.path == p
    # Saving what was loaded gives the same files again.
    p2 = back.save(tmp_path / "again.json")
    assert fm.load_dataset(p2) == ds
    assert (tmp_path / "again_boreholes.csv").read_text() == (p.parent / "boreholes.csv").read_text()


def test_round_trip_section_coordinates(tmp_path):
    ds = fm.load_dataset(SMALL)
    p = ds.save(tmp_path / "s.json", section_coords=True)
    doc = json.loads(p.read_text())
    # Traces on a section are written as [s, z]; the free trace of F2 stays XYZ.
    assert all(len(q) == 2 for q in doc["faults"][0]["traces"][1]["plane"])
    assert all(len(q) == 3 for q in doc["faults"][1]["traces"][0]["plane"])
    back = fm.load_dataset(p)
    assert back.allclose(ds, atol=1e-9)
    assert not back.allclose(ds, atol=0.0) or back == ds


def test_equality_detects_differences():
    a = fm.load_dataset(SMALL)
    b = fm.load_dataset(SMALL)
    assert a == b
    b.faults[0].traces[0].layers["seam_a"]["foot"][1, 2] += 1e-9
    assert a != b and a.allclose(b, atol=1e-6)
    b = fm.load_dataset(SMALL)
    b.boreholes.z[3] = 0.0
    assert a != b
    b = fm.load_dataset(SMALL)
    b.sections["L1"].azimuth = 1.0
    assert a != b


def test_save_refuses_unwritable_ids_and_leaves_nothing(tmp_path):
    ds = fm.load_dataset(SMALL)
    ids = ds.boreholes.hole_id.astype("<U8")
    ids[0] = "B,1"
    ds.boreholes.hole_id = ids
    out = tmp_path / "bad"
    with pytest.raises(fm.DatasetError, match="hole_id 'B,1'"):
        ds.save(out)
    assert not out.exists() or os.listdir(out) == []


def test_save_is_atomic_when_a_rename_fails(tmp_path, monkeypatch):
    ds = fm.load_dataset(SMALL)
    out = tmp_path / "out"
    ds.save(out)
    before = {n: (out / n).read_bytes() for n in os.listdir(out)}
    changed = fm.load_dataset(out)
    changed.boreholes.z[:] += 1.0
    changed.points["top"][:, 2] += 1.0
    real = os.replace
    calls = {"n": 0}

    def flaky(a, b):
        calls["n"] += 1
        if calls["n"] == 2:  # after the first CSV was swapped in
            raise OSError("disk went away")
        return real(a, b)

    monkeypatch.setattr(os, "replace", flaky)
    with pytest.raises(OSError, match="disk went away"):
        changed.save(out)
    monkeypatch.setattr(os, "replace", real)
    assert {n: (out / n).read_bytes() for n in os.listdir(out)} == before  # no temp files either
    assert fm.load_dataset(out) == ds


def test_saved_files_are_world_readable(tmp_path):
    old = os.umask(0o022)
    try:
        p = fm.load_dataset(SMALL).save(tmp_path / "o")
    finally:
        os.umask(old)
    assert (p.stat().st_mode & 0o777) == 0o644


# ---------------------------------------------------------------------------
# data from `points` alone (seismic picks): a header-only boreholes file
# ---------------------------------------------------------------------------
def _points_only(small_copy, with_boundary=True):
    d = small_copy.parent
    (d / "boreholes.csv").write_text("hole_id,x,y,layer,z\n")
    rng = np.random.default_rng(3)
    xy = rng.random((40, 2)) * [1000, 800]
    for k, layer in enumerate(["top", "seam_a", "seam_b"]):
        np.savetxt(d / f"pts_{layer}.csv", np.c_[xy, -100.0 * k + 0.01 * xy[:, 0]],
                   delimiter=",", header="x,y,z", comments="", fmt="%.17g")

    def fn(doc):
        doc["points"] = {layer: f"pts_{layer}.csv" for layer in ["top", "seam_a", "seam_b"]}
        doc["faults"] = []
        if not with_boundary:
            doc.pop("boundary")
    return edit_json(small_copy, fn)


def test_header_only_boreholes_with_points_and_boundary(small_copy):
    ds = fm.load_dataset(_points_only(small_copy))
    assert len(ds.boreholes.z) == 0
    for layer in ds.layers:
        assert ds.layer_points(layer).shape == (40, 3)


def test_header_only_boreholes_need_a_boundary(small_copy):
    expect_error(_points_only(small_copy, with_boundary=False), "boundary",
                 "no borehole rows")
