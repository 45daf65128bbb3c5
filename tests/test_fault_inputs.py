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


_ONE_TRIANGLE = ("GOCAD TSurf 1\nHEADER {\nname:F1\n}\nPROPERTIES a b\nTFACE\n"
                 "PVRTX 1 0 0 0 1 2\nPVRTX 2 100 0 -50 1 2\nPVRTX 3 0 100 0 1 2\nTRGL 1 2 3\nEND\n")


@pytest.mark.parametrize("change", [
    ("PVRTX 2 100 0 -50 1 2", "PVRTX 2 100 0 -50 -1.#IND 2"),   # MSVC's NaN
    ("PVRTX 2 100 0 -50 1 2", "PVRTX 2 100 0 -50 1"),           # a value short
    ("PVRTX 2 100 0 -50 1 2", "PVRTX 2 100 0 -50 n/a 2"),       # text
    ("TFACE", "ESIZES 2 1\nTFACE"),                            # more than given
], ids=["msvc_nan", "short", "text", "esizes"])
def test_a_fault_surface_s_property_columns_cannot_refuse_it(tmp_path, change):
    """Regression (fuzz of GOCAD exports): a property value the fault never
    uses -- MSVC's '-1.#IND', one missing, text -- refused the fault's file."""
    f = tmp_path / "f1.ts"
    f.write_text(_ONE_TRIANGLE.replace(*change))
    v, t = read_fault_surface(f)
    assert v.tolist() == [[0, 0, 0], [100, 0, -50], [0, 100, 0]] and t.tolist() == [[0, 1, 2]]


def test_a_vertex_id_past_int64_is_a_named_error_not_an_overflow(tmp_path):
    """Regression (fuzz): an id of 20 digits raised OverflowError out of the
    loader (numpy's int64 conversion of the triangles' ids)."""
    f = tmp_path / "f1.ts"
    f.write_text(_ONE_TRIANGLE.replace("TRGL 1 2 3", "TRGL 1 2 99999999999999999999"))
    with pytest.raises(DatasetError, match=re.escape(f"{f}, line 10: TRGL vertex id") + ".*out of range"):
        read_fault_surface(f)
    f.write_text(_ONE_TRIANGLE.replace("PVRTX 1 ", "PVRTX 10000000000000000000 "))
    with pytest.raises(DatasetError, match=re.escape(f"{f}, line 7: PVRTX id") + ".*out of range"):
        read_fault_surface(f)


def test_a_header_closed_on_its_last_key_line_reads_and_one_never_closed_is_named(tmp_path):
    """Regression (fuzz): a header closed on its last key line
    ('*solid*color:1 0 0 1 }') swallowed the geometry and the error named
    the end of the file; now it is read, and a header never closed is named
    by the line that opened it."""
    f = tmp_path / "f1.ts"
    f.write_text(_ONE_TRIANGLE.replace("name:F1\n}", "name:F1\n*solid*color:1 0 0 1 }"))
    v, t = read_fault_surface(f)
    assert len(v) == 3 and t.tolist() == [[0, 1, 2]]
    f.write_text(_ONE_TRIANGLE.replace("name:F1\n}", "name:F1"))
    with pytest.raises(DatasetError, match=re.escape(f"{f}, line 4: the HEADER block opened at line 2 "
                                                     "has no closing '}' before this PROPERTIES line")):
        read_fault_surface(f)


def test_an_underscore_in_a_coordinate_is_refused_and_a_trailing_ctrl_z_ignored(tmp_path):
    """Regressions (fuzz): Python's float() read '100_000' as 100000 (the
    datasets' CSVs refuse it); a DOS end-of-file byte after END was read as
    the start of another object."""
    f = tmp_path / "f1.ts"
    f.write_text(_ONE_TRIANGLE.replace("PVRTX 2 100 ", "PVRTX 2 1_00 "))
    with pytest.raises(DatasetError, match=re.escape(f"{f}, line 8: expected a number for x")):
        read_fault_surface(f)
    f.write_text(_ONE_TRIANGLE + "\x1a")
    assert read_fault_surface(f)[1].tolist() == [[0, 1, 2]]


# A quad of two triangles, 0-1-2 and 1-3-2 wound alike (both clockwise in
# map view), 1 km along strike, 300 m down dip.
_QUAD_V = "VRTX 1 0 0 0\nVRTX 2 1000 0 0\nVRTX 3 0 200 -300\nVRTX 4 1000 200 -300\n"


def _ts(body: str, name: str = "F1") -> str:
    return f"GOCAD TSurf 1\nHEADER {{\nname: {name}\n}}\nTFACE\n{body}END\n"


def _wound_alike(t: np.ndarray) -> bool:
    """Every edge shared by two triangles runs opposite ways in them."""
    e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    return len({tuple(x) for x in e.tolist()}) == len(e)


def test_a_surface_of_mixed_winding_is_wound_alike(tmp_path):
    """Regression (the fuzz of the v2 input): a quad exported as two
    triangles wound opposite ways loaded, and every derivation and build of
    it stopped at `max() arg is an empty sequence` (its outline: every edge
    counted as inside). The winding carries no data: each connected part is
    wound like its first triangle."""
    f = tmp_path / "f1.ts"
    f.write_text(_ts(_QUAD_V + "TRGL 1 2 3\nTRGL 2 3 4\n"))
    v, t = read_fault_surface(f)
    assert t.tolist() == [[0, 1, 2], [1, 3, 2]]
    # A grid with every third triangle flipped, and two parts apart.
    n = 6
    V = [(x * 100.0, y * 100.0, -y * 50.0) for y in range(n) for x in range(n)]
    tris = []
    for y in range(n - 1):
        for x in range(n - 1):
            a = y * n + x + 1
            tris += [(a, a + 1, a + n), (a + 1, a + n + 1, a + n)]
    tris = [(p, r, q) if k % 3 == 2 else (p, q, r) for k, (p, q, r) in enumerate(tris)]
    far = [(x + 5000.0, y, z) for x, y, z in V[:3]]
    body = "".join(f"VRTX {i + 1} {x} {y} {z}\n" for i, (x, y, z) in enumerate(V + far))
    body += "".join(f"TRGL {p} {q} {r}\n" for p, q, r in tris)
    body += f"TRGL {len(V) + 1} {len(V) + 3} {len(V) + 2}\n"
    f.write_text(_ts(body))
    v, t = read_fault_surface(f)
    assert len(t) == len(tris) + 1 and _wound_alike(t)
    assert t[0].tolist() == [0, 1, n]                  # the first triangle keeps its winding
    assert t[-1].tolist() == [len(V), len(V) + 2, len(V) + 1]


def test_a_fault_exported_twice_into_one_file_is_read_once(tmp_path):
    f = tmp_path / "f1.ts"
    quad = _QUAD_V + "TRGL 1 2 3\nTRGL 2 4 3\n"
    f.write_text(_ts(quad) + _ts(quad, "F1_copy"))
    v, t = read_fault_surface(f)
    assert len(v) == 4 and t.tolist() == [[0, 1, 2], [1, 3, 2]]


def test_triangles_that_are_no_surface_are_refused_naming_the_file_and_edge(tmp_path):
    f = tmp_path / "f1.ts"
    # A third triangle on the quad's diagonal (overlapping patches).
    f.write_text(_ts(_QUAD_V + "VRTX 5 500 500 -500\nTRGL 1 2 3\nTRGL 2 4 3\nTRGL 2 3 5\n"))
    with pytest.raises(DatasetError, match=re.escape(f"{f}: the fault's triangles are no surface: "
                                                     "the edge between [1000.0, 0.0, 0.0] and "
                                                     "[0.0, 200.0, -300.0] is shared by 3")):
        read_fault_surface(f)
    # A Moebius strip: no winding makes every shared edge run opposite ways.
    k = 6
    ang = np.linspace(0.0, 2 * np.pi, k, endpoint=False)
    inner = [(1000 * np.cos(a), 1000 * np.sin(a), -100.0 * (i % 2)) for i, a in enumerate(ang)]
    outer = [(1500 * np.cos(a), 1500 * np.sin(a), -300.0 + 100.0 * (i % 2)) for i, a in enumerate(ang)]
    body = "".join(f"VRTX {i + 1} {x:.3f} {y:.3f} {z:.3f}\n" for i, (x, y, z) in enumerate(inner + outer))
    for i in range(k):
        j = (i + 1) % k
        a, b, c, d = i + 1, j + 1, k + i + 1, k + j + 1
        if j == 0:                      # the half twist: inner and outer swap
            b, d = d, b
        body += f"TRGL {a} {b} {c}\nTRGL {b} {d} {c}\n"
    f.write_text(_ts(body))
    with pytest.raises(DatasetError, match=re.escape(f"{f}: the fault's triangles cannot all be "
                                                     "wound alike (a one-sided surface)")):
        read_fault_surface(f)
