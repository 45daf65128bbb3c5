"""Readers of fault geometry given as data (dataset v2 draft): fault points
CSV with optional sticks, fault surface as GOCAD TSurf (faultmesh.fault_inputs)."""
from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from helpers import fuzz_settings

from faultmesh.dataset import DatasetError
from faultmesh.fault_inputs import FaultPoints, read_fault_points, read_fault_surface
from faultmesh.model import Model, Surface


# ---------------------------------------------------------------------------
# Fault points
# ---------------------------------------------------------------------------
def test_claudius_fault_points(data_dir):
    # The real Claudius fault picks: header X,Y,Z,surface (the extra column
    # is ignored), 93 points, no sticks.
    f = data_dir / "claudius" / "fault_points.csv"
    fp = read_fault_points(f)
    assert isinstance(fp, FaultPoints) and fp.sticks is None
    want = np.loadtxt(f, delimiter=",", skiprows=1, usecols=(0, 1, 2))
    assert fp.points.shape == (93, 3)
    np.testing.assert_array_equal(fp.points, want)


def test_points_with_sticks(tmp_path):
    f = tmp_path / "f.csv"
    f.write_text("stick,x,y,z\n1,0,0,0\n1,1,0,-10\n1,2,0,-20\nB,0,50,0\nB,1.5,50,-15\n")
    points, sticks = read_fault_points(f)
    assert points.tolist() == [[0, 0, 0], [1, 0, -10], [2, 0, -20], [0, 50, 0], [1.5, 50, -15]]
    assert sticks.tolist() == ["1", "1", "1", "B", "B"]


def test_points_without_header(tmp_path):
    f = tmp_path / "f.csv"
    f.write_text("# picks\n0,0,0\n1,0,-10\n0,1,-5\n")
    points, sticks = read_fault_points(f)
    assert points.shape == (3, 3) and sticks is None


POINT_ERRORS = [
    ("x,y,z\n0,0,0\n1,0,0\n", None, None, "2 fault point(s); a fault surface needs at least 3"),
    ("x,y,z\n0,0,0\n1,zero,0\n0,1,0\n", 3, "y", "'zero' is not a number"),
    ("x,y,z\n0,0,0\n1,0\n0,1,0\n", 3, None, "expected 3 fields, got 2"),
    ("x,y,z,stick\n0,0,0,a\n1,0,0,\n0,1,0,b\n", 3, "stick", "missing value"),
    ("x,y,z,stick\n0,0,0,a\n1,0,-1,a\n0,9,0,b\n0,9,-1,b\n2,0,-2,a\n3,0,-3,a\n", 6, "stick",
     "stick 'a' resumes after other sticks (it started at row 2)"),
    ("x,y,z,stick\n0,0,0,a\n1,0,-1,a\n0,9,0,b\n", 4, "stick", "stick 'b' has one point"),
    ("x,y,z,stick\n0,0,0,a\n0,0,0,a\n0,9,0,b\n0,9,-1,b\n", 3, None,
     "repeats the previous point of stick 'a' (row 2)"),
    ("x,y,z,x\n0,0,0,0\n1,0,0,0\n0,1,0,0\n", 1, None, "column 'x' appears more than once"),
]


@pytest.mark.parametrize("text,row,field,words", POINT_ERRORS,
                         ids=[e[3].split(";")[0][:30] for e in POINT_ERRORS])
def test_point_errors_name_file_row_and_field(tmp_path, text, row, field, words):
    f = tmp_path / "fault.csv"
    f.write_text(text)
    with pytest.raises(DatasetError) as e:
        read_fault_points(f)
    msg = str(e.value)
    assert msg.startswith(str(f)), msg
    if row is not None:
        assert f", row {row}" in msg, msg
    if field is not None:
        assert f"field {field!r}" in msg, msg
    assert words in msg, msg


def test_missing_points_file_names_the_key(tmp_path):
    with pytest.raises(DatasetError, match=r"fault 'F1' points: file .*nope\.csv' not found"):
        read_fault_points(tmp_path / "nope.csv", label="fault 'F1' points")


@pytest.mark.fuzz
@fuzz_settings(100)
@given(st.lists(st.tuples(st.sampled_from(["0", "1.5", "-20", "", "x", "nan", "1e400", "a", "b"]),
                          st.sampled_from(["0", "2", "", "1", "y"]),
                          st.sampled_from(["-1", "-2", "0", "inf", ""]),
                          st.sampled_from(["a", "b", "1", "", "a"])), max_size=8),
       st.booleans())
def test_fuzz_fault_points(tmp_path_factory, rows, with_stick):
    f = tmp_path_factory.mktemp("fp") / "f.csv"
    head = "x,y,z,stick" if with_stick else "x,y,z"
    body = [",".join(r if with_stick else r[:3]) for r in rows]
    f.write_text("\n".join([head] + body) + "\n")
    try:
        fp = read_fault_points(f)
    except DatasetError as e:
        assert str(e).startswith(str(f)), str(e)
        return
    assert np.all(np.isfinite(fp.points)) and len(fp.points) >= 3


# ---------------------------------------------------------------------------
# Fault surfaces
# ---------------------------------------------------------------------------
TWO_PATCHES = """\
GOCAD TSurf 1
HEADER {
name: F1_part1
}
GEOLOGICAL_TYPE fault
TFACE
VRTX 1 0 0 0
VRTX 2 100 0 0
VRTX 3 0 10 -50
VRTX 4 100 10 -50
TRGL 1 2 3
TRGL 2 4 3
END
GOCAD PLine 1
HEADER {
name: outline
}
ILINE
VRTX 1 0 0 0
VRTX 2 100 0 0
SEG 1 2
END
GOCAD TSurf 1
HEADER {
name: F1_part2
}
GEOLOGICAL_TYPE fault
TFACE
VRTX 7 0 10 -50
VRTX 8 100 10 -50
VRTX 9 50 20 -100
TRGL 7 8 9
END
"""


def test_surface_patches_are_one_fault(tmp_path):
    f = tmp_path / "f1.ts"
    f.write_text(TWO_PATCHES)
    v, t = read_fault_surface(f)
    # The second patch's first two vertices coincide with the first's 3 and 4:
    # merged, so the patches share the edge.
    assert v.tolist() == [[0, 0, 0], [100, 0, 0], [0, 10, -50], [100, 10, -50], [50, 20, -100]]
    assert t.tolist() == [[0, 1, 2], [1, 3, 2], [2, 3, 4]]
    assert t.dtype == np.int64
    # A patch not marked as a fault is still part of it (after the marked ones).
    f.write_text(TWO_PATCHES.replace("GEOLOGICAL_TYPE fault\n", "", 1))
    v, t = read_fault_surface(f)
    assert v.tolist() == [[0, 10, -50], [100, 10, -50], [50, 20, -100], [0, 0, 0], [100, 0, 0]]
    assert t.tolist() == [[0, 1, 2], [3, 4, 0], [4, 1, 0]]


def test_surface_written_by_faultmesh_reads_back(tmp_path):
    rng = np.random.default_rng(5)
    V = np.column_stack([rng.uniform(0, 1000, 30), rng.uniform(0, 1000, 30),
                         rng.uniform(-500, 0, 30)])
    from scipy.spatial import Delaunay
    T = Delaunay(V[:, :2]).simplices.astype(np.int64)
    m = Model(name="m", surfaces={}, faults={"F": Surface("F", V, T, kind="fault")})
    f = tmp_path / "fault.ts"
    m.save(f)
    v, t = read_fault_surface(f)
    np.testing.assert_array_equal(v, V)
    np.testing.assert_array_equal(t, T)


def test_surface_errors_name_the_file(tmp_path):
    f = tmp_path / "f.ts"
    f.write_text("GOCAD VSet 1\nVRTX 1 0 0 0\nEND\n")
    with pytest.raises(DatasetError, match=re.escape(f"{f}: no 'GOCAD TSurf'")):
        read_fault_surface(f)
    f.write_text(TWO_PATCHES.replace("TRGL 2 4 3", "TRGL 2 4 99"))
    with pytest.raises(DatasetError, match=re.escape(f"{f}, line 12: TRGL refers to vertex id 99")):
        read_fault_surface(f)
    f.write_text("GOCAD TSurf 1\nTFACE\nVRTX 1 0 0 0\nVRTX 2 1 0 0\nEND\n")
    with pytest.raises(DatasetError, match=re.escape(f"{f}: TSurf 'surface_0' has no triangles")):
        read_fault_surface(f)
    f.write_text("GOCAD TSurf 1\nTFACE\nVRTX 1 0 0 0\nVRTX 2 1 0 0\nVRTX 3 1 0 0\n"
                 "TRGL 1 2 3\nEND\n")
    with pytest.raises(DatasetError, match=re.escape(f"{f}: TSurf 'surface_0' triangle 1") +
                       ".*two corners at the same position"):
        read_fault_surface(f)
    with pytest.raises(DatasetError,
                       match=r"missing\.ts: fault 'F2' surface: file .*missing\.ts' not found"):
        read_fault_surface(tmp_path / "missing.ts", label="fault 'F2' surface")
