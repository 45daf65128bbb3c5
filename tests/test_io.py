"""Model files: .3dt, GOCAD .ts, meshio formats, folders, errors, atomic writes."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import faultmesh
from faultmesh.io import ModelFileError, load_model, save_model
from faultmesh.model import Gap, Model, Surface


def _tin(rng, n, x0=0.0, y0=0.0, size=1000.0, z=lambda x, y: 0.0 * x):
    xy = np.round(rng.random((n, 2)) * size, 3) + [x0, y0]
    xy = np.vstack([xy, [[x0, y0], [x0 + size, y0], [x0 + size, y0 + size], [x0, y0 + size]]])
    tri = faultmesh.delaunay(xy)
    return np.column_stack([xy, z(xy[:, 0], xy[:, 1])]), tri


def make_model(seed: int = 7) -> Model:
    """Two layers (names with a space and non-ASCII), one fault, a gap with
    metadata, boundary and CRS, and coordinates of UTM magnitude."""
    rng = np.random.default_rng(seed)
    x0, y0 = 512400.0, 3926800.0
    v1, t1 = _tin(rng, 60, x0, y0, z=lambda x, y: 35.0 + 1e-3 * (x - x0) + 0.1 * np.sin(y / 97.0))
    v2, t2 = _tin(rng, 40, x0, y0, z=lambda x, y: -420.0 - 0.01 * (y - y0))
    fv = np.array([[x0 + 400, y0, -300.0], [x0 + 400, y0 + 1000, -300.0],
                   [x0 + 450, y0, -600.0], [x0 + 450, y0 + 1000, -600.0]])
    ft = np.array([[0, 2, 1], [1, 2, 3]])
    boundary = np.array([[x0, y0], [x0 + 1000, y0], [x0 + 1000, y0 + 1000], [x0, y0 + 1000]])
    return Model(
        name="test model «α»",
        surfaces={"top soil": Surface("top soil", v1, t1, metadata={"source": "boreholes"}),
                  "coal 8": Surface("coal 8", v2, t2)},
        faults={"F22": Surface("F22", fv, ft, kind="fault")},
        boundary=boundary, crs="EPSG:2385",
        gaps=[Gap("F22", "coal 8", np.array([3, 5, 8]), 5, 0, 0.0125,
                  metadata={"bridge": [1, 2]})],
        metadata={"dataset": "unit test", "seed": seed})


def assert_same_geometry(a: Model, b: Model, names: bool = True) -> None:
    sa = list(a.surfaces.values()) + list(a.faults.values())
    sb = list(b.surfaces.values()) + list(b.faults.values())
    assert len(sa) == len(sb)
    for x, y in zip(sa, sb):
        # Bit-for-bit: compare the raw float64 bits, not just values.
        assert x.vertices.shape == y.vertices.shape
        assert np.array_equal(x.vertices.view(np.int64), y.vertices.view(np.int64)), x.name
        assert np.array_equal(x.triangles, y.triangles), x.name
        assert y.triangles.dtype == np.int64 and y.vertices.dtype == np.float64
        if names:
            assert x.name == y.name
            assert x.kind == y.kind


# --------------------------------------------------------------------------
# .3dt
# --------------------------------------------------------------------------

def test_3dt_round_trip_is_exact(tmp_path):
    m = make_model()
    p = tmp_path / "m.3dt"
    m.save(p)
    r = load_model(p)
    assert_same_geometry(m, r)
    assert r.name == m.name and r.crs == m.crs
    assert list(r.surfaces) == list(m.surfaces) and list(r.faults) == list(m.faults)
    assert np.array_equal(r.boundary, m.boundary)
    assert r.metadata == {"dataset": "unit test", "seed": 7}
    assert r.surfaces["top soil"].metadata == {"source": "boreholes"}
    (g,) = r.gaps
    assert (g.fault, g.layer, g.n_vertices, g.n_holes, g.seconds) == ("F22", "coal 8", 5, 0, 0.0125)
    assert g.triangles.tolist() == [3, 5, 8] and g.metadata == {"bridge": [1, 2]}
    # Writing the read model again gives the same bytes.
    p2 = tmp_path / "m2.3dt"
    r.save(p2)
    assert p.read_bytes() == p2.read_bytes()


def test_3dt_gap_interior_round_trip(tmp_path):
    """Regression (issue 10): a gap with layer vertices put back inside it
    (n_interior = k, n + 2h - 2 + 2k triangles) is written as GAP interior=k
    and read back; a GAP record without it (files written before) reads as
    k = 0. Without the attribute a saved model failed check() on the count."""
    m = make_model()
    m.gaps = [Gap("F22", "coal 8", np.arange(7), 5, 0, 0.0125, n_interior=2)]
    p = tmp_path / "m.3dt"
    m.save(p)
    assert "interior=2 " in p.read_text(encoding="utf-8")
    (g,) = load_model(p).gaps
    assert (g.n_vertices, g.n_holes, g.n_interior, len(g.triangles)) == (5, 0, 2, 7)
    old = tmp_path / "old.3dt"
    make_model().save(old)  # k = 0: the record as before, no interior attribute
    assert "interior=" not in old.read_text(encoding="utf-8")
    (g0,) = load_model(old).gaps
    assert g0.n_interior == 0


def test_3dt_awkward_floats_survive(tmp_path):
    vals = np.array([[0.1, -0.0, 5e-324], [1.7976931348623157e308, -2.2250738585072014e-308, 1 / 3],
                     [513398.61512345678, 3930237.1000000001, -349.62396600000001]])
    m = Model("f", {"a": Surface("a", vals, np.array([[0, 1, 2]]))})
    m.save(tmp_path / "f.3dt")
    r = load_model(tmp_path / "f.3dt")
    assert np.array_equal(r.surfaces["a"].vertices.view(np.int64), vals.view(np.int64))


def test_3dt_header_is_human_readable(tmp_path):
    make_model().save(tmp_path / "m.3dt")
    lines = (tmp_path / "m.3dt").read_text(encoding="utf-8").splitlines()
    assert lines[0] == "3DT 1"
    assert any(ln.startswith('MODEL name="test model «α»" crs="EPSG:2385" surfaces=3 gaps=1')
               for ln in lines)
    assert 'SURFACE name="top soil" kind=layer order=0 vertices=64' in "\n".join(lines)
    assert lines[-1] == "END MODEL"


GOOD_3DT = """\
3DT 1
# a comment
MODEL name="m" crs="" surfaces=1 gaps=1

SURFACE name="a" kind=layer order=0 vertices=3 triangles=1
VERTICES
0 0 0
1 0 0
0 1 0.5
TRIANGLES
0 1 2
END SURFACE
GAP fault="F" layer="a" polygon_vertices=3 holes=0 seconds=0.5 triangles=1
0
END GAP
END MODEL
"""


def test_3dt_hand_written_file_with_comments_and_blank_lines(tmp_path):
    p = tmp_path / "h.3dt"
    p.write_text(GOOD_3DT)
    m = load_model(p)
    assert m.surfaces["a"].vertices[2].tolist() == [0.0, 1.0, 0.5]
    assert m.gaps[0].seconds == 0.5


@pytest.mark.parametrize("old, new, line, fragment", [
    ("3DT 1", "3DT 3", 1, "unsupported .3dt version 3"),
    ("3DT 1", "TSURF 1", 1, "not a .3dt file"),
    ('MODEL name="m" crs="" surfaces=1 gaps=1', 'MODEL crs="" surfaces=1 gaps=1', 3,
     "missing attribute name="),
    ("surfaces=1 gaps=1", "surfaces=x gaps=1", 3, "surfaces must be a non-negative integer"),
    ("1 0 0\n", "1 0\n", 8, "expected 3 numbers (vertex x y z), got 2"),
    ("0 1 0.5\n", "0 1 zz\n", 9, "got '0 1 zz'"),
    ("0 1 0.5\n", "0 1 nan\n", 9, "non-finite"),
    ("TRIANGLES\n0 1 2", "TRIANGLES\n0 1 3", 11, "vertex index [0, 1, 3] outside 0..2"),
    ("kind=layer", "kind=horizon", 5, "kind must be 'layer' or 'fault'"),
    ("END SURFACE", "END", 12, "expected 'END SURFACE'"),
    ("seconds=0.5 triangles=1\n0\n", "seconds=0.5 triangles=1\n7\n", 13, "triangle row outside 0..0"),
    ('layer="a"', 'layer="b"', 13, "layer 'b' is not a layer surface"),
    ("END MODEL\n", "END MODEL\nSURFACE\n", 17, "unexpected content after END MODEL"),
    ("END GAP\nEND MODEL\n", "END GAP\n", 15, "unexpected end of file: expected END MODEL"),
    ("surfaces=1 gaps=1", "surfaces=1 gaps=0", 13, "expected 'END MODEL', got 'GAP"),
])
def test_3dt_malformed_files_name_line_and_problem(tmp_path, old, new, line, fragment):
    assert old in GOOD_3DT
    p = tmp_path / "bad.3dt"
    p.write_text(GOOD_3DT.replace(old, new, 1))
    with pytest.raises(ModelFileError) as ei:
        load_model(p)
    msg = str(ei.value)
    assert msg.startswith(f"{p}, line {line}: "), msg
    assert fragment in msg, msg
    assert ei.value.line == line


def test_3dt_truncated_vertex_block(tmp_path):
    p = tmp_path / "t.3dt"
    p.write_text(GOOD_3DT.replace("vertices=3", "vertices=5"))
    with pytest.raises(ModelFileError, match=r"line 10: expected 3 numbers \(vertex x y z\), got 1 "
                                             r"field\(s\): 'TRIANGLES' \(SURFACE 'a' at line 5\)"):
        load_model(p)
    p.write_text(GOOD_3DT.split("TRIANGLES")[0].replace("vertices=3", "vertices=5"))
    with pytest.raises(ModelFileError, match=r"line 9: unexpected end of file: expected 5 vertex "
                                             r"x y z rows \(SURFACE 'a' at line 5\)"):
        load_model(p)


def test_empty_and_binary_files(tmp_path):
    p = tmp_path / "e.3dt"
    p.write_text("")
    with pytest.raises(ModelFileError, match="empty file"):
        load_model(p)


# --------------------------------------------------------------------------
# GOCAD TSurf
# --------------------------------------------------------------------------

def test_ts_round_trip_is_exact(tmp_path):
    m = make_model()
    p = tmp_path / "m.ts"
    m.save(p)
    r = load_model(p)
    assert_same_geometry(m, r)
    assert r.name == m.name and r.crs == "EPSG:2385"
    assert np.array_equal(r.boundary, m.boundary)
    text = p.read_text(encoding="utf-8")
    # Names bare as SKUA writes them; the boundary in its own file.
    assert text.startswith("GOCAD TSurf 1\nHEADER {\nname:top soil\n")
    assert text.count("GOCAD TSurf 1") == 3 and "PLine" not in text
    assert "NAME EPSG:2385" in text and "ZPOSITIVE Elevation" in text
    assert "GEOLOGICAL_TYPE fault" in text and "GEOLOGICAL_TYPE top" in text
    pl = (tmp_path / "m_boundary.pl").read_text(encoding="utf-8")
    assert pl.startswith("GOCAD PLine 1") and pl.count("SEG ") == 4
    # Every object numbers its vertices from 1 to its vertex count.
    for obj, surf in zip(text.split("GOCAD TSurf 1")[1:], list(m.surfaces.values()) + [m.faults["F22"]]):
        vids = [int(ln.split()[1]) for ln in obj.splitlines() if ln.startswith("VRTX")]
        assert vids == list(range(1, surf.n_vertices + 1))
        tids = [int(t) for ln in obj.splitlines() if ln.startswith("TRGL") for t in ln.split()[1:]]
        assert min(tids) == 1 and max(tids) <= surf.n_vertices


FOREIGN_TS = """\
# exported by some other tool
GOCAD TSurf 1
HEADER {
name:Fault A
*solid*color:0 0 0.5 1
}
GOCAD_ORIGINAL_COORDINATE_SYSTEM
NAME " gocad Local"
AXIS_NAME "X" "Y" "Z"
AXIS_UNIT "m" "m" "m"
ZPOSITIVE Depth
END_ORIGINAL_COORDINATE_SYSTEM
GEOLOGICAL_FEATURE A
GEOLOGICAL_TYPE fault
PROPERTIES is_latest dip
PROP_LEGAL_RANGES **none** **none** **none** **none**
NO_DATA_VALUES -99999 -99999
ESIZES 1 1
PROPERTY_CLASS_HEADER Z {
is_z:on
}
TFACE
PVRTX 10 0 0 100 1 45
PVRTX 11 10 0 100 1 46
PVRTX 12 0 10 120 0 47
TRGL 10 11 12
TFACE
PATOM 13 11 0 50
PVRTX 14 10 10 130 1 48
TRGL 13 14 12
BSTONE 10
BORDER 15 10 11
END
GOCAD VSet 1
HEADER {name:points}
VRTX 1 5 5 5
END
GOCAD TSurf 1
HEADER {name:"horizon B"; *solid*color:1 0 0 1}
TFACE
VRTX 1 0 0 -5 CNXYZ
VRTX 2 1 0 -5 CNXYZ
VRTX 3 0 1 -5
ATOM 4 2
VRTX 5 1 1 -5
TRGL 1 2 3
TRGL 3 4 5
END
"""


def test_ts_reads_files_of_other_tools(tmp_path):
    p = tmp_path / "foreign.ts"
    p.write_text(FOREIGN_TS)
    m = load_model(p)
    assert list(m.faults) == ["Fault A"] and list(m.surfaces) == ["horizon B"]
    a = m.faults["Fault A"]
    # ZPOSITIVE Depth: z becomes elevation; PATOM 13 copies vertex 11's position.
    assert a.vertices.tolist() == [[0, 0, -100], [10, 0, -100], [0, 10, -120], [10, 0, -100],
                                   [10, 10, -130]]
    assert a.triangles.tolist() == [[0, 1, 2], [3, 4, 2]]
    assert a.metadata["tface_parts"] == 2
    props = a.metadata["vertex_properties"]
    assert props["dip"].tolist() == [45, 46, 47, 50, 48] and props["is_latest"].tolist() == [1, 1, 0, 0, 1]
    b = m.surfaces["horizon B"]
    assert b.vertices.shape == (5, 3) and b.triangles.tolist() == [[0, 1, 2], [2, 3, 4]]
    # GOCAD's quoting: '" gocad Local"' is the name "gocad Local".
    assert m.crs == "gocad Local"
    # atoms="merge": the ATOM is the vertex it references.
    mm = load_model(p, atoms="merge")
    assert mm.surfaces["horizon B"].triangles.tolist() == [[0, 1, 2], [2, 1, 3]]
    assert mm.faults["Fault A"].triangles.tolist() == [[0, 1, 2], [1, 3, 2]]


@pytest.mark.parametrize("old, new, line, fragment", [
    ("TRGL 10 11 12", "TRGL 10 11 99", 26, "TRGL refers to vertex id 99, which is not defined"),
    ("PVRTX 11 10 0 100 1 46", "PVRTX 11 10 0", 24, "PVRTX: expected 'id x y z'"),
    ("PVRTX 12 0 10 120 0 47", "PVRTX 11 0 10 120 0 47", 25, "vertex id 11 defined twice"),
    ("PVRTX 12 0 10 120 0 47", "PVRTX 12 0 ten 120 0 47", 25, "expected a number for y, got 'ten'"),
    ("PVRTX 12 0 10 120 0 47", "PVRTX 12 0 10 nan 0 47", 25, "non-finite vertex coordinates"),
    ("TRGL 10 11 12", "TRGL 10 11 x", 26, "expected an integer TRGL vertex id, got 'x'"),
    ("ZPOSITIVE Depth", "ZPOSITIVE Up", 11, "ZPOSITIVE must be Elevation or Depth"),
    ("ATOM 4 2", "ATOM 4 9", 44, "ATOM 4 refers to vertex 9, which is not defined before it"),
    ("# exported by some other tool", "TFACE", 1, "expected 'GOCAD <type> 1'"),
])
def test_ts_malformed_files_name_line(tmp_path, old, new, line, fragment):
    assert old in FOREIGN_TS
    p = tmp_path / "bad.ts"
    p.write_text(FOREIGN_TS.replace(old, new, 1))
    with pytest.raises(ModelFileError) as ei:
        load_model(p)
    assert str(ei.value).startswith(f"{p}, line {line}: "), str(ei.value)
    assert fragment in str(ei.value)


def test_ts_missing_end_and_no_surface(tmp_path):
    p = tmp_path / "noend.ts"
    p.write_text("GOCAD TSurf 1\nTFACE\nVRTX 1 0 0 0\n")
    with pytest.raises(ModelFileError, match=r"line 3: unexpected end of file: the TSurf object "
                                             r"started at line 1 has no END"):
        load_model(p)
    p.write_text("GOCAD VSet 1\nVRTX 1 0 0 0\nEND\n")
    with pytest.raises(ModelFileError, match="no 'GOCAD TSurf' object found"):
        load_model(p)
    p.write_text("GOCAD TSurf 1\nTFACE\nVRTX 1 0 0 0\nGOCAD TSurf 1\nEND\n")
    with pytest.raises(ModelFileError, match=r"line 4: 'GOCAD TSurf 1' starts a new object, but "
                                             r"the TSurf object started at line 1 has no END"):
        load_model(p)


# --------------------------------------------------------------------------
# meshio formats and folders
# --------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".vtu", ".vtp", ".vtk", ".ply", ".obj"])
def test_merged_mesh_formats_round_trip_with_names_and_kinds(tmp_path, suffix):
    m = make_model()
    p = tmp_path / f"m{suffix}"
    m.save(p)
    r = load_model(p)
    assert_same_geometry(m, r)          # names and kinds too
    assert r.name == m.name and r.crs == m.crs


def test_folder_target_writes_every_format_and_reads_back(tmp_path):
    m = make_model()
    out = tmp_path / "out"
    files = save_model(m, out)
    names = sorted(str(f.relative_to(out)) for f in files)
    stem = "test_model"
    assert names == sorted([f"{stem}.3dt", f"{stem}.ts", f"{stem}_boundary.pl", f"{stem}.vtu",
                            "obj/00_layer_top_soil.obj", "obj/01_layer_coal_8.obj",
                            "obj/02_fault_F22.obj", "ply/00_layer_top_soil.ply",
                            "ply/01_layer_coal_8.ply", "ply/02_fault_F22.ply"])
    assert all(f.is_file() for f in files)
    assert not [p for p in out.rglob(".*")], "temporary files left behind"
    assert_same_geometry(m, load_model(out))           # the folder's .3dt
    assert (out / f"{stem}_boundary.pl").is_file() and out / f"{stem}_boundary.pl" in files
    for sub in ("obj", "ply"):
        r = load_model(out / sub)       # names kept inside the files
        assert list(r.surfaces) == ["top soil", "coal 8"] and list(r.faults) == ["F22"]
        assert_same_geometry(m, r)


def test_unknown_suffix_and_missing_file(tmp_path):
    m = make_model()
    with pytest.raises(ValueError, match=r"save_model: unknown format '.xyz'"):
        m.save(tmp_path / "m.xyz")
    with pytest.raises(ValueError, match=r"save_model: .stl is read-only"):
        m.save(tmp_path / "m.stl")
    with pytest.raises(FileNotFoundError, match="no such file"):
        load_model(tmp_path / "nope.3dt")
    with pytest.raises(ValueError, match="load_model: unknown format '.xyz'"):
        load_model(tmp_path / "m.xyz")


# --------------------------------------------------------------------------
# atomic writes
# --------------------------------------------------------------------------

def _listing(d: Path):
    return sorted((str(p.relative_to(d)), p.read_bytes()) for p in d.rglob("*") if p.is_file())


def test_failed_write_leaves_old_file_and_no_temp(tmp_path):
    m = make_model()
    p = tmp_path / "m.3dt"
    m.save(p)
    before = _listing(tmp_path)
    bad = make_model()
    bad.surfaces["coal 8"].vertices[5, 2] = np.nan
    for suffix in (".3dt", ".ts"):
        with pytest.raises(ValueError, match="non-finite"):
            bad.save(tmp_path / f"m{suffix}")
    assert _listing(tmp_path) == before


def test_failed_folder_write_is_all_or_nothing(tmp_path, monkeypatch):
    m = make_model()
    out = tmp_path / "out"
    save_model(m, out, formats=["3dt", "ts"])
    before = _listing(out)
    from faultmesh.formats import ply

    def boom(*a, **k):
        raise OSError("disk full (simulated)")

    monkeypatch.setattr(ply, "ply_bytes", boom)
    m2 = make_model(seed=8)
    with pytest.raises(OSError, match="disk full"):
        save_model(m2, out)              # 3dt, ts, vtu and obj are written before the ply ones
    assert _listing(out) == before


def test_rename_failure_half_way_restores_the_old_files(tmp_path, monkeypatch):
    m = make_model()
    out = tmp_path / "out"
    save_model(m, out, formats=["3dt", "ts"])
    before = _listing(out)
    real_replace = os.replace
    calls = {"n": 0}

    def flaky(src, dst):
        # Fail the second rename of a temporary file onto its target.
        if ".tmp" in str(src):
            calls["n"] += 1
            if calls["n"] == 2:
                raise OSError("rename failed (simulated)")
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", flaky)
    with pytest.raises(OSError, match="rename failed"):
        save_model(make_model(seed=9), out, formats=["3dt", "ts"])
    monkeypatch.setattr(os, "replace", real_replace)
    assert _listing(out) == before


def test_written_files_have_normal_permissions(tmp_path):
    make_model().save(tmp_path / "m.3dt")
    mode = (tmp_path / "m.3dt").stat().st_mode & 0o777
    um = os.umask(0)
    os.umask(um)
    assert mode == 0o666 & ~um


def test_the_example_in_the_format_documentation_loads(tmp_path):
    doc = (Path(__file__).resolve().parents[1] / "docs" / "3dt.md").read_text(encoding="utf-8")
    example = doc.split("```\n", 2)[1]
    assert example.startswith("3DT 1\n")
    p = tmp_path / "doc.3dt"
    p.write_text(example, encoding="utf-8")
    m = load_model(p)
    assert list(m.surfaces) == ["coal 8", "coal 10"] and list(m.faults) == ["F22"]
    assert m.faults["F22"].metadata == {"kind": "normal"}
    assert m.gaps[0].triangles.tolist() == [1] and m.metadata["builtin_dataset"]["name"] == "paper_like"
    # The writer reproduces the documented layout line for line (after the comment).
    p2 = tmp_path / "again.3dt"
    m.save(p2)
    assert p2.read_text(encoding="utf-8").splitlines()[3:] == example.splitlines()[2:]


from hypothesis import given, settings, strategies as st  # noqa: E402

_finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=40, deadline=None)
@given(coords=st.lists(st.tuples(_finite, _finite, _finite), min_size=3, max_size=12),
       name=st.text(min_size=1, max_size=12).filter(lambda s: s.strip() == s and '"' not in s
                                                     and "\n" not in s and "\r" not in s))
def test_any_doubles_and_names_round_trip_exactly(tmp_path_factory, coords, name):
    V = np.array(coords, dtype=np.float64)
    T = np.array([[0, 1, 2], [len(V) - 1, 0, 1]], dtype=np.int64)
    m = Model(name, {name: Surface(name, V, T)})
    d = tmp_path_factory.mktemp("rt")
    for suffix in (".3dt", ".ts"):
        m.save(d / f"m{suffix}")
        r = load_model(d / f"m{suffix}")
        (s,) = r.surfaces.values()
        assert s.name == name
        assert np.array_equal(s.vertices.view(np.int64), V.view(np.int64))
        assert np.array_equal(s.triangles, T)
