"""Every file faultmesh writes, opened by the reader of its format (VTK/PyVista,
resqpy, OpenGeode-GeosciencesIO, omf, geoh5py, meshio) with equal counts,
names and kinds; the pinned corpus of real GOCAD files (tests/data/gocad/);
files written by VTK itself; errors instead of exits; a fuzz target per reader."""
from __future__ import annotations

import gzip
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

import faultmesh
from faultmesh.cli import main
from faultmesh.io import ModelFileError, load_model, save_model
from helpers import fuzz_settings
from test_io import assert_same_geometry, make_model

GOCAD = Path(__file__).resolve().parent / "data" / "gocad"


def surfaces(m):
    return list(m.surfaces.values()) + list(m.faults.values())


def rich_model():
    """make_model with a normal fault, vertex properties (a name with a space,
    a 2-component one) and per-triangle arrays on one layer."""
    m = make_model()
    m.faults["F22"].metadata["kind"] = "normal"
    coal = m.surfaces["coal 8"]
    coal.metadata["vertex_properties"] = {
        "thickness m": np.linspace(0.0, 1.0, coal.n_vertices),
        "grad": np.column_stack([np.arange(coal.n_vertices), -np.arange(coal.n_vertices)]) * 0.5}
    coal.owner = np.arange(coal.n_triangles) % 3          # per-triangle, as Surface.owner
    coal.kinds = (np.arange(coal.n_triangles) % 2).astype(np.int32)
    return m


NAMES = ["top soil", "coal 8", "F22"]
KINDS = ["layer", "layer", "fault"]


# --------------------------------------------------------------------------
# VTK: ParaView's and PyVista's reader (VTK 9) opens every array
# --------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".vtu", ".vtp", ".vtk"])
def test_vtk_files_open_whole_in_vtk(tmp_path, suffix):
    pv = pytest.importorskip("pyvista")  # in the test extra; importorskip names it if absent
    m = rich_model()
    p = tmp_path / f"m{suffix}"
    m.save(p)
    g = pv.read(p)
    S = surfaces(m)
    assert g.n_points == sum(s.n_vertices for s in S) and g.n_cells == sum(s.n_triangles for s in S)
    assert list(g.field_data["surface_names"]) == [s.name for s in S]
    assert list(g.field_data["surface_kinds"]) == KINDS
    assert str(g.field_data["model_name"][0]) == m.name and str(g.field_data["crs"][0]) == m.crs
    sid = np.repeat(np.arange(3), [s.n_triangles for s in S])
    assert np.array_equal(g.cell_data["surface_id"], sid)
    assert np.array_equal(g.cell_data["kind"], (sid == 2).astype(int))
    assert np.array_equal(g.point_data["surface_id"], np.repeat(np.arange(3), [s.n_vertices for s in S]))
    coal = m.surfaces["coal 8"]
    v = np.asarray(g.point_data["thickness m"])
    a, b = S[0].n_vertices, S[0].n_vertices + coal.n_vertices
    assert np.array_equal(v[a:b], coal.metadata["vertex_properties"]["thickness m"])
    assert np.isnan(v[:a]).all() and np.isnan(v[b:]).all()
    assert np.asarray(g.point_data["grad"]).shape == (g.n_points, 2)
    assert "owner" in g.cell_data.keys() and "triangle_kind" in g.cell_data.keys()
    # The coordinates are float64 and exact.
    assert np.array_equal(np.asarray(g.points), np.vstack([s.vertices for s in S]))
    # Back into faultmesh: names, kinds, order, arrays.
    r = load_model(p)
    assert_same_geometry(m, r)
    rc = r.surfaces["coal 8"]
    assert np.array_equal(rc.metadata["vertex_properties"]["thickness m"],
                          coal.metadata["vertex_properties"]["thickness m"])
    assert np.array_equal(rc.metadata["triangle_properties"]["owner"], coal.owner)
    assert np.array_equal(rc.metadata["triangle_properties"]["kind"], coal.kinds)


def test_legacy_vtk_has_no_type_vtk_cannot_read(tmp_path):
    """Regression: meshio wrote cell arrays as 'vtktypeint32', which VTK's
    legacy reader refuses ('Unsupported data type'), dropping them."""
    vtk = pytest.importorskip("vtkmodules.vtkIOLegacy")
    p = tmp_path / "m.vtk"
    make_model().save(p)
    head = re.findall(rb"^[A-Za-z_%0-9 ]+ \d+ \d+ (\w+)$|^SCALARS \S+ (\w+)", p.read_bytes(), re.M)
    assert head and all(t in (b"int", b"double", b"string", b"") for pair in head for t in pair)
    r = vtk.vtkUnstructuredGridReader()
    r.SetFileName(str(p))
    r.ReadAllScalarsOn()
    r.ReadAllFieldsOn()
    r.Update()
    out = r.GetOutput()
    assert out.GetCellData().GetArray("surface_id") is not None
    assert out.GetCellData().GetArray("kind") is not None
    assert out.GetFieldData().GetAbstractArray("surface_names").GetValue(1) == "coal 8"


def _vtk_written(tmp_path, kind: str):
    """A mesh written by VTK's own writers in the many layouts VTK produces."""
    pv = pytest.importorskip("pyvista")
    from vtkmodules import vtkIOLegacy, vtkIOXML

    mesh = pv.Sphere(theta_resolution=12, phi_resolution=9)    # triangles + normals
    ug = mesh.cast_to_unstructured_grid()
    p = tmp_path / f"{kind}"
    if kind.startswith("xml"):
        _, grid, mode, comp = kind.split("-")
        w = vtkIOXML.vtkXMLUnstructuredGridWriter() if grid == "vtu" else vtkIOXML.vtkXMLPolyDataWriter()
        w.SetInputData(ug if grid == "vtu" else mesh)
        p = p.with_suffix("." + grid)
        {"ascii": w.SetDataModeToAscii, "binary": w.SetDataModeToBinary,
         "appended": w.SetDataModeToAppended}[mode]()
        w.EncodeAppendedDataOff()
        if comp == "none":
            w.SetCompressorTypeToNone()
        elif comp == "lzma":
            w.SetCompressorTypeToLZMA()
        else:
            w.SetCompressorTypeToZLib()
        if comp == "u64":
            w.SetHeaderTypeToUInt64()
    else:
        _, grid, version, mode = kind.split("-")
        w = vtkIOLegacy.vtkUnstructuredGridWriter() if grid == "ug" else vtkIOLegacy.vtkPolyDataWriter()
        w.SetInputData(ug if grid == "ug" else mesh)
        w.SetFileVersion(int(version))
        w.SetFileTypeToBinary() if mode == "binary" else w.SetFileTypeToASCII()
        p = p.with_suffix(".vtk")
    w.SetFileName(str(p))
    assert w.Write() == 1
    return mesh, p


@pytest.mark.parametrize("kind", ["xml-vtu-ascii-none", "xml-vtu-binary-none", "xml-vtu-binary-zlib",
                                  "xml-vtu-appended-zlib", "xml-vtu-appended-none", "xml-vtu-appended-u64",
                                  "xml-vtu-binary-lzma", "xml-vtp-appended-zlib", "xml-vtp-binary-none",
                                  "legacy-ug-42-binary", "legacy-ug-51-binary", "legacy-ug-51-ascii",
                                  "legacy-pd-42-ascii", "legacy-pd-51-binary"])
def test_files_written_by_vtk_itself_load(tmp_path, kind):
    pv = pytest.importorskip("pyvista")
    mesh, p = _vtk_written(tmp_path, kind)
    m = load_model(p)
    (s,) = m.surfaces.values()
    assert s.n_vertices == mesh.n_points and s.n_triangles == mesh.n_cells
    # The same values as VTK reads from the same file (VTK's ASCII writers
    # round to 6 digits, so the file, not the mesh in memory, is the reference).
    back = pv.read(p)
    assert np.array_equal(s.vertices, np.asarray(back.points, np.float64))
    cells = back.faces if isinstance(back, pv.PolyData) else back.cells
    assert np.array_equal(s.triangles, np.asarray(cells).reshape(-1, 4)[:, 1:])
    assert s.metadata["vertex_properties"]["Normals"].shape == (mesh.n_points, 3)


def test_foreign_quads_and_truncated_vtu_raise_model_file_error(tmp_path):
    pv = pytest.importorskip("pyvista")
    plane = pv.Plane(i_resolution=2, j_resolution=2)          # quads
    plane.save(tmp_path / "quads.vtp")
    with pytest.raises(ModelFileError, match=r"quads.vtp: expected a triangle mesh, .*polygon of 4 points"):
        load_model(tmp_path / "quads.vtp")
    p = tmp_path / "m.vtu"
    make_model().save(p)
    data = p.read_bytes()
    (tmp_path / "cut.vtu").write_bytes(data[: len(data) // 2])
    with pytest.raises(ModelFileError, match=r"cut.vtu: "):
        load_model(tmp_path / "cut.vtu")
    # The CLI documents exit code 2 and one line, no traceback, no sys.exit(1).
    assert main(["convert", str(tmp_path / "cut.vtu"), str(tmp_path / "x.3dt")]) == 2


def test_stl_and_ply_written_by_vtk_load(tmp_path):
    pv = pytest.importorskip("pyvista")
    s = pv.Sphere()
    for name, binary in (("s.stl", True), ("a.stl", False), ("s.ply", True), ("a.ply", False)):
        s.save(tmp_path / name, binary=binary)
        (surf,) = load_model(tmp_path / name).surfaces.values()
        assert (surf.n_vertices, surf.n_triangles) == (s.n_points, s.n_cells), name


# --------------------------------------------------------------------------
# OBJ and PLY: meshio (and viewers) open them; OBJ has one object per surface
# --------------------------------------------------------------------------

def test_obj_has_one_object_per_surface_and_opens_in_meshio(tmp_path):
    meshio = pytest.importorskip("meshio")
    m = rich_model()
    m.save(tmp_path / "m.obj")
    text = (tmp_path / "m.obj").read_text(encoding="utf-8")
    assert re.findall(r"^o (.*)$", text, re.M) == NAMES
    mm = meshio.read(tmp_path / "m.obj")
    assert len(mm.points) == sum(s.n_vertices for s in surfaces(m))
    assert sum(len(c.data) for c in mm.cells if c.type == "triangle") == sum(s.n_triangles for s in surfaces(m))
    assert_same_geometry(m, load_model(tmp_path / "m.obj"))


def test_ply_opens_in_meshio_and_keeps_names_for_faultmesh(tmp_path):
    meshio = pytest.importorskip("meshio")
    m = rich_model()
    m.save(tmp_path / "m.ply")
    mm = meshio.read(tmp_path / "m.ply")
    assert len(mm.points) == sum(s.n_vertices for s in surfaces(m))
    assert np.array_equal(mm.point_data["surface_id"], np.repeat(np.arange(3), [s.n_vertices for s in surfaces(m)]))
    assert_same_geometry(m, load_model(tmp_path / "m.ply"))


# --------------------------------------------------------------------------
# GOCAD: resqpy per surface, OpenGeode's structural model for .ml
# --------------------------------------------------------------------------

def _objects(text: str):
    return ["GOCAD TSurf 1" + t for t in text.split("GOCAD TSurf 1")[1:]]


def test_each_surface_of_a_ts_opens_in_resqpy(tmp_path):
    rq = pytest.importorskip("resqpy.model")
    rqs = pytest.importorskip("resqpy.surface")
    m = rich_model()
    m.save(tmp_path / "m.ts")
    objs = _objects((tmp_path / "m.ts").read_text(encoding="utf-8"))
    assert len(objs) == 3
    for k, (obj, s) in enumerate(zip(objs, surfaces(m))):
        f = tmp_path / f"o{k}.ts"
        f.write_text(obj, encoding="utf-8")
        surf = rqs.Surface(rq.new_model(str(tmp_path / f"o{k}.epc")), tsurf_file=str(f))
        t, p = surf.triangles_and_points()
        assert np.array_equal(t, s.triangles) and np.array_equal(p, s.vertices), s.name


def _opengeode():
    og = pytest.importorskip("opengeode")
    geo = pytest.importorskip("opengeode_geosciences")
    pytest.importorskip("opengeode_geosciencesio")     # registers the GOCAD readers
    return og, geo


def test_ml_opens_as_one_structural_model_in_opengeode(tmp_path):
    og, geo = _opengeode()
    m = rich_model()
    files = save_model(m, tmp_path / "m.ml")
    assert files == [tmp_path / "m.ml", tmp_path / "m_boundary.pl"]
    sm = geo.load_structural_model(str(tmp_path / "m.ml"))
    assert sm.name() == m.name
    assert sm.nb_horizons() == 2 and sm.nb_faults() == 1 and sm.nb_surfaces() == 3
    (f,) = list(sm.faults())
    assert f.name() == "F22" and "NORMAL" in str(f.type())
    got = {h.name(): [(s.mesh().nb_vertices(), s.mesh().nb_polygons()) for s in sm.horizon_items(h)]
           for h in sm.horizons()}
    got["F22"] = [(s.mesh().nb_vertices(), s.mesh().nb_polygons()) for s in sm.fault_items(f)]
    assert got == {s.name: [(s.n_vertices, s.n_triangles)] for s in surfaces(m)}
    assert_same_geometry(m, load_model(tmp_path / "m.ml"))


def test_ts_opens_in_opengeode_with_its_properties(tmp_path):
    og, _ = _opengeode()
    m = rich_model()
    m.save(tmp_path / "m.ts")
    ts = og.load_triangulated_surface3D(str(tmp_path / "m.ts"))
    # OpenGeode's TSurf reader merges every object of a file into one mesh.
    assert ts.nb_vertices() == sum(s.n_vertices for s in surfaces(m))
    assert ts.nb_polygons() == sum(s.n_triangles for s in surfaces(m))
    am = ts.vertex_attribute_manager()
    assert am.attribute_ids_matching_name("thickness m") and am.attribute_ids_matching_name("grad")


def test_ts_to_ts_keeps_vertex_properties_and_fault_kind(tmp_path):
    m = rich_model()
    m.save(tmp_path / "a.ts")
    r = load_model(tmp_path / "a.ts")
    r.save(tmp_path / "b.ts")
    rr = load_model(tmp_path / "b.ts")
    for x in (r, rr):
        vp = x.surfaces["coal 8"].metadata["vertex_properties"]
        src = m.surfaces["coal 8"].metadata["vertex_properties"]
        assert np.array_equal(vp["thickness m"], src["thickness m"])
        assert np.array_equal(vp["grad"], src["grad"])
        assert x.faults["F22"].metadata["kind"] == "normal"
    text = (tmp_path / "b.ts").read_text(encoding="utf-8")
    assert 'PROPERTIES " thickness m" grad' in text and "ESIZES 1 2" in text
    assert "GEOLOGICAL_TYPE normal_fault" in text and text.count("PVRTX ") == m.surfaces["coal 8"].n_vertices
    assert (tmp_path / "a.ts").read_bytes() == (tmp_path / "b.ts").read_bytes()


def test_gocad_name_ending_with_a_brace_keeps_the_header_open(tmp_path):
    """Regression: a header line 'name:a}' closed the header, losing the rest."""
    m = make_model()
    m.surfaces["coal 8"].name = "coal {8}"
    m.save(tmp_path / "m.ts")
    r = load_model(tmp_path / "m.ts")
    assert list(r.surfaces) == ["top soil", "coal {8}"] and r.name == m.name


def test_gocad_names_are_bare_and_line_breaks_refused(tmp_path):
    m = make_model()
    m.save(tmp_path / "m.ml")
    text = (tmp_path / "m.ml").read_text(encoding="utf-8")
    assert "TSURF top soil\n" in text and "TFACE 1 top top soil\n" in text
    assert "TFACE 3 fault F22\n" in text and "name:coal 8\n" in text
    assert not re.search(r'^(name:|TSURF |TFACE |GEOLOGICAL_FEATURE ).*"', text, re.M)
    m.surfaces["top soil"].name = "a\nb"
    with pytest.raises(ValueError, match="line break"):
        m.save(tmp_path / "bad.ts")
    assert not (tmp_path / "bad.ts").exists()


# --------------------------------------------------------------------------
# OMF, RESQML, geoh5: their own packages read what we write
# --------------------------------------------------------------------------

def test_omf_opens_in_omf(tmp_path):
    omf = pytest.importorskip("omf")
    m = rich_model()
    m.save(tmp_path / "m.omf")
    proj = omf.OMFReader(str(tmp_path / "m.omf")).get_project()
    els = proj.elements
    assert [e.name for e in els] == NAMES
    assert [re.search(r"kind=(\w+)", e.description).group(1) for e in els] == KINDS
    for e, s in zip(els, surfaces(m)):
        assert np.array_equal(np.asarray(e.geometry.vertices), s.vertices)
        assert np.array_equal(np.asarray(e.geometry.triangles), s.triangles)
    r = load_model(tmp_path / "m.omf")
    assert_same_geometry(m, r)
    assert r.faults["F22"].metadata["kind"] == "normal"


def test_resqml_opens_in_resqpy(tmp_path):
    rq = pytest.importorskip("resqpy.model")
    rqs = pytest.importorskip("resqpy.surface")
    m = rich_model()
    files = save_model(m, tmp_path / "m.epc")
    assert files == [tmp_path / "m.epc", tmp_path / "m.h5"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], "temporary files left"
    model = rq.Model(str(tmp_path / "m.epc"))
    found = {}
    for uuid in model.uuids(obj_type="TriangulatedSetRepresentation"):
        s = rqs.Surface(model, uuid=uuid)
        t, p = s.triangles_and_points()
        interp = model.type_of_uuid(s.represented_interpretation_root.attrib["uuid"])
        found[s.title] = (len(p), len(t), interp)
    assert found == {s.name: (s.n_vertices, s.n_triangles,
                              "obj_FaultInterpretation" if s.kind == "fault" else "obj_HorizonInterpretation")
                     for s in surfaces(m)}
    r = load_model(tmp_path / "m.epc")
    assert_same_geometry(m, r)
    assert r.crs == "EPSG:2385" and r.faults["F22"].metadata["kind"] == "normal"


def test_geoh5_opens_in_geoh5py(tmp_path):
    pytest.importorskip("geoh5py")
    from geoh5py.objects import Surface as GSurface
    from geoh5py.workspace import Workspace

    m = rich_model()
    m.save(tmp_path / "m.geoh5")
    ws = Workspace(str(tmp_path / "m.geoh5"), mode="r")
    try:
        got = {o.name: (len(o.vertices), len(o.cells), o.parent.name) for o in ws.objects
               if isinstance(o, GSurface)}
    finally:
        ws.close()
    assert got == {s.name: (s.n_vertices, s.n_triangles, "Faults" if s.kind == "fault" else "Layers")
                   for s in surfaces(m)}
    r = load_model(tmp_path / "m.geoh5")
    assert_same_geometry(m, r)
    assert np.array_equal(r.surfaces["coal 8"].metadata["vertex_properties"]["thickness m"],
                          m.surfaces["coal 8"].metadata["vertex_properties"]["thickness m"])


@pytest.mark.parametrize("suffix", [".ts", ".ml", ".vtu", ".vtp", ".vtk", ".obj", ".ply", ".omf",
                                    ".epc", ".geoh5"])
def test_convert_knows_every_format(tmp_path, suffix):
    src = tmp_path / "m.3dt"
    rich_model().save(src)
    assert main(["convert", str(src), str(tmp_path / f"out{suffix}")]) == 0
    assert main(["convert", str(tmp_path / f"out{suffix}"), str(tmp_path / "back.3dt")]) == 0
    assert_same_geometry(load_model(src), load_model(tmp_path / "back.3dt"))


# --------------------------------------------------------------------------
# PyVista objects and the interactive view
# --------------------------------------------------------------------------

def test_to_pyvista_and_back(tmp_path):
    pv = pytest.importorskip("pyvista")
    m = rich_model()
    mb = m.to_pyvista()
    assert isinstance(mb, pv.MultiBlock) and list(mb.keys()) == NAMES
    for name, kind, s in zip(NAMES, KINDS, surfaces(m)):
        b = mb[name]
        assert (b.n_points, b.n_cells) == (s.n_vertices, s.n_triangles)
        assert str(b.field_data["kind"][0]) == kind and str(b.field_data["name"][0]) == name
    assert str(mb["F22"].field_data["fault_kind"][0]) == "normal"
    coal = mb["coal 8"]
    assert np.array_equal(coal.cell_data["owner"], m.surfaces["coal 8"].owner)
    assert np.array_equal(coal.cell_data["kind"], m.surfaces["coal 8"].kinds)
    assert np.array_equal(coal.point_data["thickness m"],
                          m.surfaces["coal 8"].metadata["vertex_properties"]["thickness m"])
    assert str(mb.field_data["model_name"][0]) == m.name      # non-ASCII kept
    r = faultmesh.from_pyvista(mb)
    assert_same_geometry(m, r)
    assert r.name == m.name and r.crs == m.crs and r.faults["F22"].metadata["kind"] == "normal"
    # One merged mesh (what pyvista reads from our .vtu) splits by surface_id.
    m.save(tmp_path / "m.vtu")
    assert_same_geometry(m, faultmesh.from_pyvista(pv.read(tmp_path / "m.vtu")))
    with pytest.raises(ValueError, match="not triangles"):
        faultmesh.from_pyvista(pv.Plane())


def test_plot_interactive_needs_a_display(tmp_path, monkeypatch, capsys):
    pytest.importorskip("pyvista")
    p = tmp_path / "m.3dt"
    make_model().save(p)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    assert main(["plot", str(p), "--interactive"]) == 2
    assert "--interactive needs a display" in capsys.readouterr().err


def test_interactive_view_renders_off_screen(tmp_path):
    pytest.importorskip("pyvista")
    from faultmesh.formats import pv as fpv

    img = fpv.show(make_model(), vertical_exaggeration=2.0, off_screen=True,
                   screenshot=tmp_path / "view.png")
    assert (tmp_path / "view.png").is_file()
    # Something was drawn: more than one colour, and the fault's dark red.
    flat = img.reshape(-1, img.shape[-1])[:, :3].astype(int)
    assert len(np.unique(flat, axis=0)) > 10
    assert np.any((flat[:, 0] > 100) & (flat[:, 1] < 60) & (flat[:, 2] < 60))


# --------------------------------------------------------------------------
# the corpus of real GOCAD files (tests/data/gocad/README.md)
# --------------------------------------------------------------------------

def _corpus_path(tmp_path, rel: str) -> Path:
    p = GOCAD / rel
    if p.suffix == ".gz":
        out = tmp_path / p.stem
        out.write_bytes(gzip.decompress(p.read_bytes()))
        return out
    return p


def _grep_counts(text: str):
    """Per TSurf object, counted from the text alone: (name, geological type,
    vertex lines incl. ATOMs, TRGL lines)."""
    out = []
    for obj in text.split("GOCAD TSurf")[1:]:
        name = re.search(r"^\s*name:\s*(.*?)\s*$", obj, re.M).group(1)
        gt = re.search(r"^GEOLOGICAL_TYPE\s+(\S+)", obj, re.M)
        out.append((name, gt.group(1) if gt else "",
                    len(re.findall(r"^\s*(?:P?VRTX|P?ATOM)\s", obj, re.M)),
                    len(re.findall(r"^\s*TRGL\s", obj, re.M))))
    return out


CORPUS = sorted(str(p.relative_to(GOCAD)) for p in GOCAD.glob("*/*")
                if p.suffix in (".ts", ".gz"))


def test_corpus_is_pinned_with_licences():
    assert len(CORPUS) >= 10
    for d in {Path(c).parts[0] for c in CORPUS}:
        assert any((GOCAD / d).glob("LICENSE*")), d
    readme = (GOCAD / "README.md").read_text(encoding="utf-8")
    for c in CORPUS:
        assert Path(c).name in readme, c


@pytest.mark.parametrize("rel", CORPUS)
def test_corpus_file_loads_with_independent_counts(tmp_path, rel):
    p = _corpus_path(tmp_path, rel)
    expected = _grep_counts(p.read_text(encoding="latin-1"))
    m = load_model(p)
    kept = [e for e in expected if e[1] not in ("boundary", "lease")]
    got = sorted((s.n_vertices, s.n_triangles, s.kind) for s in surfaces(m))
    assert got == sorted((v, t, "fault" if "fault" in gt else "layer") for _, gt, v, t in kept)
    assert sorted(re.sub(r" \(\d+\)$", "", s.name) for s in surfaces(m)) == sorted(n for n, *_ in kept)
    skipped = m.metadata.get("gocad_boundary_surfaces", [])
    assert [s["name"] for s in skipped] == [n for n, gt, *_ in expected if gt in ("boundary", "lease")]


def test_corpus_counts_agree_with_opengeode(tmp_path):
    og, geo = _opengeode()
    for rel in CORPUS:
        p = _corpus_path(tmp_path, rel)
        m = load_model(p)
        if p.suffix == ".ml":
            sm = geo.load_structural_model(str(p))
            tri = {f.name(): sum(s.mesh().nb_polygons() for s in sm.fault_items(f)) for f in sm.faults()}
            tri.update({h.name(): sum(s.mesh().nb_polygons() for s in sm.horizon_items(h))
                        for h in sm.horizons()})
            assert tri == {s.name: s.n_triangles for s in surfaces(m)}, rel
            kinds = {f.name(): str(f.type()) for f in sm.faults()}
            assert all("NORMAL" in kinds[n] and m.faults[n].metadata["kind"] == "normal" for n in m.faults)
        else:
            ts = og.load_triangulated_surface3D(str(p))
            assert ts.nb_vertices() == sum(s.n_vertices for s in surfaces(m)), rel
            assert ts.nb_polygons() == sum(s.n_triangles for s in surfaces(m)), rel


def test_corpus_details(tmp_path):
    """What the issue named: quoted property names, PVRTX ... CNXYZ, ZPOSITIVE
    Depth, several TFACEs, ATOMs, normal_fault loading as a fault."""
    m = load_model(GOCAD / "opengeode" / "ts-2props.ts")
    (s,) = m.surfaces.values()
    assert list(s.metadata["vertex_properties"]) == ["default property", "def-prop"]
    assert np.isnan(s.metadata["vertex_properties"]["def-prop"]).all()   # -99999 = no data
    assert s.vertices[0].tolist() == [-745925.546875, -2618524.8125, 44070.2578125]  # Depth -> elevation
    assert m.crs == "Pdgm_Epic Local"
    w = load_model(GOCAD / "scec_cfm" / "GVFA-WWFZ-MULT-White_Wolf_fault-original.ts")
    (s,) = w.surfaces.values()
    assert s.metadata["tface_parts"] == 2 and s.n_vertices == 372
    a4 = load_model(_corpus_path(tmp_path, "opengeode/modelA4.ml.gz"))
    assert list(a4.faults) == ["F1fault", "F2fault"] and list(a4.surfaces) == ["H1b_horizon", "H2b_horizon", "H3b_horizon"]
    assert a4.name == "modelA4" and len(a4.metadata["gocad_boundary_surfaces"]) == 6


def _ts_with_units(units: str) -> str:
    return ("GOCAD TSurf 1\nHEADER {\nname:f\n}\nGOCAD_ORIGINAL_COORDINATE_SYSTEM\nNAME Default\n"
            f"AXIS_NAME \"X\" \"Y\" \"Z\"\nAXIS_UNIT {units}\nZPOSITIVE Depth\n"
            "END_ORIGINAL_COORDINATE_SYSTEM\nTFACE\nVRTX 1 1000 2000 300\nVRTX 2 1100 2000 300\n"
            "VRTX 3 1000 2100 400\nTRGL 1 2 3\nEND\n")


@pytest.mark.parametrize("units, scale", [('"m" "m" "m"', (1.0, 1.0, 1.0)),
                                          ('"ft" "ft" "ft"', (0.3048,) * 3),
                                          ('"m" "m" "ft"', (1.0, 1.0, 0.3048)),
                                          ('m m Feet', (1.0, 1.0, 0.3048)),
                                          ('"ftUS" "ftUS" "ftUS"', (1200 / 3937,) * 3),
                                          ('"km" "km" "m"', (1000.0, 1000.0, 1.0))])
def test_gocad_axis_units_are_read_in_metres(tmp_path, units, scale):
    """Regression: AXIS_UNIT was ignored, so a TSurf in feet (US data, or
    elevations in feet under metre coordinates) came in 3.28x too large
    along those axes. Each axis is now converted by its own unit."""
    p = tmp_path / "f.ts"
    p.write_text(_ts_with_units(units))
    (s,) = load_model(p).surfaces.values()
    want = np.array([[1000, 2000, -300], [1100, 2000, -300], [1000, 2100, -400]], float) * scale
    assert np.allclose(s.vertices, want, rtol=1e-15, atol=0), s.vertices


def test_an_unknown_gocad_axis_unit_is_refused_naming_its_line(tmp_path):
    """A unit faultmesh cannot convert is no reason to guess metres."""
    p = tmp_path / "f.ts"
    p.write_text(_ts_with_units('"m" "m" "furlong"'))
    with pytest.raises(ModelFileError, match=r"f\.ts, line 8: AXIS_UNIT: unknown unit 'furlong'"):
        load_model(p)
    p.write_text(_ts_with_units('"m" "m"'))
    with pytest.raises(ModelFileError, match=r"line 8: AXIS_UNIT: expected three units"):
        load_model(p)


_CRS_FT = ('GOCAD_ORIGINAL_COORDINATE_SYSTEM\nNAME Default\nAXIS_UNIT "ft" "ft" "ft"\n'
           'ZPOSITIVE Elevation\nEND_ORIGINAL_COORDINATE_SYSTEM\n')
_TS_FT = ("GOCAD TSurf 1\nHEADER {\nname:s\n}\n" + _CRS_FT
          + "VRTX 1 0 0 -100\nVRTX 2 100 0 -100\nVRTX 3 0 100 -110\nTRGL 1 2 3\nEND\n")
_PL_FT = ("GOCAD PLine 1\nHEADER {\nname:boundary\nfaultmesh_role:boundary\n}\n" + _CRS_FT
          + "VRTX 1 0 0 0\nVRTX 2 100 0 0\nVRTX 3 100 100 0\nVRTX 4 0 100 0\n"
          "SEG 1 2\nSEG 2 3\nSEG 3 4\nSEG 4 1\nEND\n")


def test_gocad_units_reach_the_boundary_and_the_surfaces_of_a_model3d(tmp_path):
    """Regressions (fuzz of the AXIS_UNIT reader): the study boundary's PLine
    (in the same file, beside it, or read alone) stayed in feet while the
    surfaces came in metres; a TSurf of a Model3d without a coordinate
    system block of its own ignored the model's AXIS_UNIT (but took its
    CRS name)."""
    (tmp_path / "same.ts").write_text(_TS_FT + _PL_FT)
    (tmp_path / "m.ts").write_text(_TS_FT)
    (tmp_path / "m_boundary.pl").write_text(_PL_FT)
    for name in ("same.ts", "m.ts"):
        m = load_model(tmp_path / name)
        assert np.max(m.surfaces["s"].vertices[:, 0]) == pytest.approx(30.48, rel=1e-15)
        assert np.max(np.asarray(m.boundary)[:, 0]) == pytest.approx(30.48, rel=1e-15), name
    from faultmesh.formats.gocad import read_pl
    pl = read_pl(tmp_path / "m_boundary.pl")
    assert np.max(np.asarray(pl.boundary)[:, 0]) == pytest.approx(30.48, rel=1e-15)
    ml = ('GOCAD Model3d 1\nHEADER {\nname:mdl\n}\n' + _CRS_FT.replace("Default", "MyCRS")
          + 'TSURF s\nTFACE 1 top s\nEND\n'
          'GOCAD TSurf 1\nHEADER {\nname:s\n}\nGEOLOGICAL_TYPE top\nTFACE\n'
          'VRTX 1 0 0 -100\nVRTX 2 100 0 -100\nVRTX 3 0 100 -110\nTRGL 1 2 3\nEND\n')
    (tmp_path / "a.ml").write_text(ml)
    m = load_model(tmp_path / "a.ml")
    assert m.crs == "MyCRS"
    assert np.max(m.surfaces["s"].vertices[:, 0]) == pytest.approx(30.48, rel=1e-15)


def test_gocad_keywords_end_at_any_white_space_and_an_open_crs_block_is_named(tmp_path):
    """Regressions (fuzz): a tab after AXIS_UNIT or ZPOSITIVE made the line
    be ignored (feet read as metres, depths as elevations); a coordinate
    system block never closed swallowed the geometry and the error named
    the object's END; a Kelvin sign read as 'k' (km)."""
    p = tmp_path / "t.ts"
    p.write_text(_TS_FT.replace("AXIS_UNIT ", "AXIS_UNIT\t").replace("ZPOSITIVE Elevation", "ZPOSITIVE\tDepth")
                 .replace("VRTX ", "VRTX\t"))
    (s,) = load_model(p).surfaces.values()
    assert s.vertices[0].tolist() == pytest.approx([0.0, 0.0, 30.48], rel=1e-15)
    p.write_text(_TS_FT.replace("END_ORIGINAL_COORDINATE_SYSTEM\n", ""))
    with pytest.raises(ModelFileError, match=r"line 9: the GOCAD_ORIGINAL_COORDINATE_SYSTEM block "
                                             r"opened at line 5 has no END_ORIGINAL_COORDINATE_SYSTEM"):
        load_model(p)
    p.write_text(_TS_FT.replace('"ft" "ft" "ft"', '"m" "m" "\u212am"'))
    with pytest.raises(ModelFileError, match=r"line 7: AXIS_UNIT: unknown unit"):
        load_model(p)


def test_gocad_property_values_msvc_nan_read_and_ragged_rows_named(tmp_path):
    """Regressions (fuzz of GOCAD exports): MSVC's '-1.#IND' / '1.#INF' in a
    property column refused the file; property rows of different lengths
    (ESIZES changed between PVRTX lines) leaked numpy's "inhomogeneous
    shape" with no line."""
    p = tmp_path / "t.ts"
    p.write_text("GOCAD TSurf 1\nHEADER {\nname:s\n}\nPROPERTIES a\nTFACE\nPVRTX 1 0 0 0 -1.#IND\n"
                 "PVRTX 2 1 0 0 1.#INF\nPVRTX 3 0 1 0 2.5\nTRGL 1 2 3\nEND\n")
    (s,) = load_model(p).surfaces.values()
    a = s.metadata["vertex_properties"]["a"]
    assert np.isnan(a[0]) and a[1] == np.inf and a[2] == 2.5
    p.write_text(p.read_text().replace("PVRTX 2 1 0 0 1.#INF\n", "ESIZES 2\nPVRTX 2 1 0 0 1 2\n")
                 .replace("2.5", "2.5 3"))
    with pytest.raises(ModelFileError, match=r"line 9: this vertex has 2 property value\(s\) where the "
                                             r"first PVRTX \(line 7\) has 1"):
        load_model(p)


# --------------------------------------------------------------------------
# no foreign file makes faultmesh exit
# --------------------------------------------------------------------------

def test_a_library_calling_sys_exit_becomes_model_file_error(tmp_path, monkeypatch):
    """Regression: meshio called sys.exit(1) on a .vtk it could not read, so
    load_model raised SystemExit and the CLI exited 1 with meshio's text."""
    omf = pytest.importorskip("omf")
    p = tmp_path / "m.omf"
    make_model().save(p)

    class Exits:
        def __init__(self, *a, **k):
            sys.exit(1)

    monkeypatch.setattr(omf, "OMFReader", Exits)
    with pytest.raises(ModelFileError, match=r"m.omf: reading it as OMF failed \(the library tried to exit"):
        load_model(p)
    assert main(["convert", str(p), str(tmp_path / "x.3dt")]) == 2


def test_vtk_with_string_arrays_written_by_pyvista_loads(tmp_path):
    """Regression: a .vtk/.vtu written by PyVista/ParaView with string field
    data made meshio exit (SystemExit) or fail with KeyError."""
    pv = pytest.importorskip("pyvista")
    from vtkmodules.vtkCommonCore import vtkStringArray

    mesh = pv.Sphere()
    arr = vtkStringArray()
    arr.SetName("note")
    arr.InsertNextValue("written by pyvista")
    mesh.GetFieldData().AddArray(arr)
    for name in ("s.vtk", "s.vtp"):
        mesh.save(tmp_path / name)
        (s,) = load_model(tmp_path / name).surfaces.values()
        assert (s.n_vertices, s.n_triangles) == (mesh.n_points, mesh.n_cells)


# --------------------------------------------------------------------------
# readers fed files of real tools (fuzz 47 findings)
# --------------------------------------------------------------------------

def test_obj_negative_indices_count_back_from_the_vertices_read_so_far(tmp_path):
    """Regression: with v/f interleaved per object (as many exporters write),
    'f -3 -2 -1' of object A counted back from the file's last vertex and
    gave A the triangle of B."""
    p = tmp_path / "neg.obj"
    p.write_text("o A\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
                 "o B\nv 0 0 -5\nv 1 0 -5\nv 0 1 -5\nf -3 -2 -1\n")
    m = load_model(p)
    assert m.surfaces["A"].vertices[:, 2].tolist() == [0.0, 0.0, 0.0]
    assert m.surfaces["B"].vertices[:, 2].tolist() == [-5.0, -5.0, -5.0]
    # a negative index before enough vertices are read is named with its line
    p.write_text("v 0 0 0\nf -1 -2 -3\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(ModelFileError, match=r"line 2: .*-1\.\.-1"):
        load_model(p)


def test_obj_tab_after_keyword_and_inline_comments_are_read(tmp_path):
    """Regression: 'v\t0 0 0' was not a vertex (no vertices at all) and
    'f 1 2 3 # tri' a face of 5 vertices."""
    p = tmp_path / "t.obj"
    p.write_text("v\t0 0 0\nv\t1 0 0  # corner\nv 0 1 0\nf\t1 2 3 # tri\n")
    (s,) = load_model(p).surfaces.values()
    assert s.vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    assert s.triangles.tolist() == [[0, 1, 2]]


_STL_TRI = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]


def test_stl_keywords_in_any_case_load(tmp_path):
    """Regression: SOLID/FACET/VERTEX (and mixed case) loaded as an empty surface."""
    p = tmp_path / "u.stl"
    p.write_text("SOLID X\n FACET NORMAL 0 0 1\n  OUTER LOOP\n   VERTEX 0 0 0\n   Vertex 1 0 0\n"
                 "   VERTEX 0 1 0\n  ENDLOOP\n ENDFACET\nENDSOLID X\n")
    (s,) = load_model(p).surfaces.values()
    assert sorted(s.vertices.tolist()) == sorted(_STL_TRI) and s.n_triangles == 1


def _binary_stl(header: bytes, corners, count=None, tail: bytes = b"") -> bytes:
    import struct

    rec = np.zeros(len(corners), np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]))
    rec["v"] = corners
    n = len(corners) if count is None else count
    return header.ljust(80) + struct.pack("<I", n) + rec.tobytes() + tail


def test_binary_stl_with_a_solid_header_and_trailing_bytes_loads(tmp_path):
    """Regression: a binary STL whose header starts with 'solid' (SolidWorks,
    many CAD exporters) and whose size is not exactly 84 + 50 n loaded empty."""
    p = tmp_path / "b.stl"
    p.write_bytes(_binary_stl(b"solid part", [_STL_TRI], tail=b"\0"))
    (s,) = load_model(p).surfaces.values()
    assert sorted(s.vertices.tolist()) == sorted(_STL_TRI) and s.n_triangles == 1
    p.write_bytes(_binary_stl(b"solid part", [_STL_TRI]))   # exact size, same result
    assert load_model(p).surfaces["b"].n_triangles == 1


def test_truncated_binary_stl_names_the_file_and_the_counts(tmp_path):
    p = tmp_path / "cut.stl"
    p.write_bytes(_binary_stl(b"solid part", [_STL_TRI, _STL_TRI])[:150])
    with pytest.raises(ModelFileError, match=r"cut\.stl: binary STL: the header announces 2 "
                                             r"facets \(84 \+ 50 x 2 = 184 bytes\), the file "
                                             r"has 150 bytes"):
        load_model(p)


@pytest.mark.parametrize("name, text", [
    ("nan.vtk", "# vtk DataFile Version 4.2\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n"
                "0 0 0 1 0 nan 0 1 0\nPOLYGONS 1 4\n3 0 1 2\n"),
    ("inf.vtp", '<?xml version="1.0"?>\n<VTKFile type="PolyData" version="0.1">\n<PolyData>\n'
                '<Piece NumberOfPoints="3" NumberOfPolys="1">\n<Points><DataArray type="Float64" '
                'NumberOfComponents="3" format="ascii">0 0 0 1 0 inf 0 1 0</DataArray></Points>\n'
                '<Polys><DataArray type="Int64" Name="connectivity" format="ascii">0 1 2'
                '</DataArray><DataArray type="Int64" Name="offsets" format="ascii">3</DataArray>'
                '</Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n')])
def test_vtk_non_finite_point_is_refused_naming_the_point(tmp_path, name, text):
    """Regression: NaN/inf coordinates loaded as they were (and failed later,
    far from the file); refused like the GOCAD and STL readers do."""
    p = tmp_path / name
    p.write_text(text)
    with pytest.raises(ModelFileError, match=rf"{re.escape(name)}: point 1 has non-finite"):
        load_model(p)


def test_vtk_non_finite_point_no_triangle_uses_is_dropped(tmp_path):
    p = tmp_path / "unused.vtk"
    p.write_text("# vtk DataFile Version 4.2\nx\nASCII\nDATASET POLYDATA\nPOINTS 4 double\n"
                 "0 0 0 nan nan nan 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 2 3\n")
    (s,) = load_model(p).surfaces.values()
    assert s.vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    assert s.triangles.tolist() == [[0, 1, 2]]


@pytest.mark.parametrize("suffix", [".obj", ".ts", ".ml", ".3dt", ".vtu", ".vtp", ".vtk", ".ply",
                                    ".omf"])
def test_convert_of_an_empty_surface_writes_it(tmp_path, suffix, capsys):
    """Regression: an empty surface (an empty .vtp as VTK writes it: the
    readers of VTK, STL and geoh5 keep it) made convert fail in format_floats
    with "cannot reshape array of size 0" and no file named; .omf failed in
    omf's validation; .obj was written and refused when read back."""
    pv = pytest.importorskip("pyvista")
    if suffix == ".omf":
        pytest.importorskip("omf")
    src = tmp_path / "empty.vtp"
    pv.PolyData().save(src)
    assert main(["convert", str(src), str(tmp_path / f"out{suffix}")]) == 0
    (s,) = surfaces(load_model(tmp_path / f"out{suffix}"))
    assert (s.name, s.n_vertices, s.n_triangles) == ("empty", 0, 0)


def test_vtp_with_base64_appended_data_says_so(tmp_path):
    """Regression: VTK's default XML writer (appended, base64-encoded) got
    "appended array without a valid offset" instead of the documented message."""
    pytest.importorskip("vtkmodules.vtkIOXML")
    from vtkmodules.vtkFiltersSources import vtkPlaneSource
    from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

    src = vtkPlaneSource()
    src.Update()
    w = vtkXMLPolyDataWriter()
    w.SetInputData(src.GetOutput())
    w.SetFileName(str(tmp_path / "d.vtp"))
    w.SetDataModeToAppended()
    w.EncodeAppendedDataOn()      # VTK's default: base64 appended data
    assert w.Write() == 1
    with pytest.raises(ModelFileError, match="appended base64 data is not supported"):
        load_model(tmp_path / "d.vtp")


def _empty(name, kind="layer"):
    return faultmesh.Surface(name, np.zeros((0, 3)), np.zeros((0, 3), np.int64), kind=kind)


def test_obj_empty_surfaces_come_back_empty_with_their_names(tmp_path):
    """Regression: a model of empty surfaces was written as OBJ (an 'o' line
    each) and its reader refused the file ("no vertices"); an empty surface
    among others vanished on reading."""
    allempty = faultmesh.Model(name="e", surfaces={"a b": _empty("a b"), "c": _empty("c")},
                               faults={"F": _empty("F", "fault")})
    mixed = make_model()
    mixed.surfaces = {"top soil": mixed.surfaces["top soil"], "gone": _empty("gone"),
                      "coal 8": mixed.surfaces["coal 8"]}
    for m in (allempty, mixed):
        m.save(tmp_path / "m.obj")
        assert_same_geometry(m, load_model(tmp_path / "m.obj"))
    # A surface with vertices but no triangles is written as an empty object.
    lonely = faultmesh.Model(name="l", surfaces={"lonely": faultmesh.Surface(
        "lonely", np.eye(3), np.zeros((0, 3), np.int64))})
    lonely.save(tmp_path / "l.obj")
    assert [(s.name, s.n_vertices) for s in surfaces(load_model(tmp_path / "l.obj"))] == [
        ("lonely", 0)]
    # An object with vertices but no faces (points, a line) is still no surface.
    (tmp_path / "pts.obj").write_text("o points\nv 5 5 5\nl 1 1\no tri\nv 0 0 0\nv 1 0 0\n"
                                      "v 0 1 0\nf 2 3 4\n")
    assert [s.name for s in surfaces(load_model(tmp_path / "pts.obj"))] == ["tri"]


def test_omf_empty_surface_is_an_empty_grid_that_omf_reads(tmp_path):
    """Regression: writing an empty surface to .omf failed inside omf's
    validation (SurfaceGeometry takes the min of its triangles); it is
    written as a SurfaceElement with a grid of no cells, and read back empty."""
    omf = pytest.importorskip("omf")
    m = make_model()
    m.surfaces["empty one"] = _empty("empty one")
    m.faults["F0"] = _empty("F0", "fault")
    m.save(tmp_path / "m.omf")
    proj = omf.OMFReader(str(tmp_path / "m.omf")).get_project()
    proj.validate()
    by_name = {el.name: el for el in proj.elements}
    assert list(by_name) == ["top soil", "coal 8", "empty one", "F22", "F0"]
    for name in ("empty one", "F0"):
        assert type(by_name[name].geometry).__name__ == "SurfaceGridGeometry"
        assert by_name[name].geometry.num_cells == 0
    assert_same_geometry(m, load_model(tmp_path / "m.omf"))


def _ply(fmt: str, faces, vertex_props=(("uint64", "Q"), ("int64", "q")),
         index=("uint64", "Q")) -> bytes:
    """A PLY file per the spec (the header, then the elements' records) with
    four vertices, the given vertex properties (default int64/uint64), an
    index list of type ``index`` (default uint64), a uchar after it, and an
    'edge' element after the faces."""
    o = {"binary_little_endian": "<", "binary_big_endian": ">"}.get(fmt)
    props = [f"property {t} p{i}" for i, (t, _) in enumerate(vertex_props)]
    head = ["ply", f"format {fmt} 1.0", "element vertex 4", "property double x",
            "property double y", "property double z", *props, f"element face {len(faces)}",
            f"property list uchar {index[0]} vertex_indices", "property uchar red",
            "element edge 1", "property int vertex1", "property int vertex2", "end_header", ""]
    V = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 1.0, 0.5)]
    big = [2 ** 63 + 3, -(2 ** 62) - 5]          # values float64 cannot hold exactly
    if o is None:
        body = "".join(" ".join(map(str, [*v, *big[:len(props)]])) + "\n" for v in V)
        body += "".join(" ".join(map(str, [len(f), *f, 7])) + "\n" for f in faces) + "0 1\n"
        return "\n".join(head).encode() + body.encode()
    import struct

    codes = "".join(c for _, c in vertex_props)
    body = b"".join(struct.pack(o + "ddd" + codes, *v, *big[:len(props)]) for v in V)
    body += b"".join(struct.pack(f"{o}B{len(f)}{index[1]}B", len(f), *f, 7) for f in faces)
    return "\n".join(head).encode() + body + struct.pack(o + "ii", 0, 1)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_int64_and_uint64_properties_are_read(tmp_path, fmt):
    """Regression: 'property uint64 ...'/'int64' (Open3D, trimesh, plyfile)
    was refused as a bad property line."""
    p = tmp_path / "m.ply"
    p.write_bytes(_ply(fmt, [[0, 1, 2], [1, 3, 2]]))
    (s,) = load_model(p).surfaces.values()
    assert s.vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.5]]
    assert s.triangles.tolist() == [[0, 1, 2], [1, 3, 2]]
    vp = s.metadata["vertex_properties"]
    if fmt != "ascii":     # binary: the integers as written, bit for bit
        assert vp["p0"].dtype == np.uint64 and vp["p0"].tolist() == [2 ** 63 + 3] * 4
        assert vp["p1"].dtype == np.int64 and vp["p1"].tolist() == [-(2 ** 62) - 5] * 4
    else:
        assert np.allclose(vp["p0"], 2.0 ** 63) and np.allclose(vp["p1"], -(2.0 ** 62))


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_faces_of_fewer_than_3_vertices_are_ignored_larger_ones_named(tmp_path, fmt):
    """Regression: a line (a face of 2 vertices) in the face list was refused
    (ascii: "announces 4 records, the file ends first"; binary: every later
    record misread). As the VTK reader treats vertices and lines, faces of
    fewer than 3 vertices are ignored; one of more is refused naming it."""
    p = tmp_path / "m.ply"
    p.write_bytes(_ply(fmt, [[0, 1], [0, 1, 2], [3], [], [1, 3, 2], [0, 1]], (), ("int", "i")))
    (s,) = load_model(p).surfaces.values()
    assert s.triangles.tolist() == [[0, 1, 2], [1, 3, 2]]
    assert s.n_vertices == 4
    p.write_bytes(_ply(fmt, [[0, 1, 2], [0, 1], [0, 1, 3, 2]], (), ("int", "i")))
    with pytest.raises(ModelFileError, match=r"m\.ply: expected a triangle mesh, found 1 other "
                                             r"face\(s\), the first a polygon of 4 points \(face 2\)"):
        load_model(p)


def test_vtm_of_pyvista_reads_each_block_as_a_surface(tmp_path):
    """Regression: no reader of .vtm (VTK XML multiblock). Blocks are read by
    the XML reader, named after the block (or the 'name' field data that
    to_pyvista writes), in file order, nested blocks too; a missing block
    file names the .vtm and the block's file."""
    import pyvista as pv
    from faultmesh.formats import vtk

    mb = pv.MultiBlock()
    mb["top one"] = pv.Sphere(theta_resolution=6, phi_resolution=5)
    inner = pv.MultiBlock()
    inner["base"] = pv.Plane(i_resolution=2, j_resolution=2).triangulate()
    mb["group"] = inner
    mb["nothing"] = None
    mb.save(tmp_path / "mb.vtm")
    m = load_model(tmp_path / "mb.vtm")
    assert [(s.name, s.kind, s.n_vertices, s.n_triangles) for s in surfaces(m)] == [
        ("top one", "layer", mb["top one"].n_points, mb["top one"].n_cells),
        ("base", "layer", 9, 8)]
    # faultmesh's own MultiBlock: names, kinds, fault type, model name, CRS
    model = rich_model()
    model.to_pyvista().save(tmp_path / "fm.vtm")
    back = vtk.read_vtm(tmp_path / "fm.vtm")
    assert_same_geometry(model, back)
    assert (back.name, back.crs) == (model.name, model.crs)
    assert back.faults["F22"].metadata["kind"] == "normal"
    assert np.array_equal(back.surfaces["coal 8"].metadata["vertex_properties"]["thickness m"],
                          model.surfaces["coal 8"].metadata["vertex_properties"]["thickness m"])
    block = tmp_path / "mb" / "mb_1.vtp"
    block.unlink()
    with pytest.raises(ModelFileError, match=rf"mb\.vtm: block 'base': its file .*"
                                             rf"{re.escape(str(block))} does not exist"):
        vtk.read_vtm(tmp_path / "mb.vtm")


@pytest.mark.parametrize("suffix", [".vtp", ".vtk"])
def test_vtk_triangle_strips_with_polygons_match_vtk_and_keep_cell_data(tmp_path, suffix):
    """Regression: a .vtp with strips and polygons gave the strips' triangles
    first (VTK numbers cells verts, lines, polys, strips), and cell data was
    dropped whenever strips were present. The triangles are those of VTK's
    triangulate() in its order; each takes the cell data of its cell."""
    pv = pytest.importorskip("pyvista")
    pts = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0.5], [2, 0, 0], [2, 1, 0.2],
                    [3, 0, 1], [10, 0, 0], [11, 0, 0], [10, 1, 0], [11, 1, 0]], float)
    mesh = pv.PolyData(pts, faces=np.array([3, 7, 8, 9, 3, 8, 10, 9]), lines=np.array([2, 0, 6]),
                       strips=np.array([6, 0, 1, 2, 3, 4, 5, 3, 4, 5, 6]))
    mesh.cell_data["cid"] = np.arange(mesh.n_cells, dtype=np.int32)   # line, 2 polys, 2 strips
    p = tmp_path / f"s{suffix}"
    mesh.save(p)
    ref = pv.read(p).triangulate()
    F = np.asarray(ref.faces).reshape(-1, 4)[:, 1:]
    (s,) = load_model(p).surfaces.values()
    assert np.array_equal(s.vertices[s.triangles], np.asarray(ref.points)[F])
    # strip (0..5) gives (0 1 2) (2 1 3) (2 3 4) (4 3 5): orientation alternates
    assert s.triangles[2:6].tolist() == [[0, 1, 2], [2, 1, 3], [2, 3, 4], [4, 3, 5]]
    assert s.metadata["triangle_properties"]["cid"].tolist() == [1, 2, 3, 3, 3, 3, 4]


def _epc(tmp_path, name, points, **crs):
    """A one-surface .epc written by resqpy with a CRS of the given keywords."""
    import resqpy.crs as rqc
    import resqpy.model as rq
    import resqpy.surface as rqs

    rm = rq.new_model(str(tmp_path / f"{name}.epc"))
    c = rqc.Crs(rm, **crs)
    c.create_xml()
    s = rqs.Surface(rm, crs_uuid=c.uuid, title="H1")
    s.set_from_triangles_and_points(np.array([[0, 1, 2]]), np.asarray(points, float))
    s.write_hdf5()
    s.create_xml()
    rm.store_epc()
    return tmp_path / f"{name}.epc"


_LOCAL = [[0.0, 0.0, 1000.0], [10.0, 0.0, 1000.0], [0.0, 10.0, 1000.0]]


def test_resqml_missing_h5_names_the_epc_and_the_h5(tmp_path):
    """Regression: resqpy's FileNotFoundError escaped."""
    p = _epc(tmp_path, "noh5", _LOCAL)
    (tmp_path / "noh5.h5").unlink()
    with pytest.raises(ModelFileError, match=r"noh5\.epc: .*noh5\.h5.* is missing"):
        load_model(p)


def test_resqml_crs_in_feet_is_read_in_metres(tmp_path):
    """Regression: a depth CRS in feet (z_units ft) gave z in feet; xy_units
    are converted too, as the GOCAD reader does for AXIS_UNIT."""
    p = _epc(tmp_path, "ft", _LOCAL, z_inc_down=True, xy_units="ft", z_units="ft")
    (s,) = load_model(p).surfaces.values()
    # 1 ft = 0.3048 m exactly; a few ulp for the multiplication
    assert np.allclose(s.vertices, np.array(_LOCAL) * [0.3048, 0.3048, -0.3048], rtol=1e-15, atol=0)


def test_resqml_crs_offset_and_rotation_give_global_coordinates(tmp_path):
    """Regression: any offset or rotation gave "TypeError: len() of unsized
    object" (resqpy's local_to_global_array works in place, returns None)."""
    # z up with an x offset: shifted, z kept as is (a z-up CRS is not flipped)
    p = _epc(tmp_path, "xoff", _LOCAL, z_inc_down=False, x_offset=512000.0)
    (s,) = load_model(p).surfaces.values()
    assert s.vertices.tolist() == [[512000.0, 0.0, 1000.0], [512010.0, 0.0, 1000.0],
                                   [512000.0, 10.0, 1000.0]]
    # depth CRS rotated 30 degrees (local axes clockwise from east/north),
    # offsets in x, y and z: expected from the RESQML definition, not resqpy
    p = _epc(tmp_path, "rot", _LOCAL, z_inc_down=True, x_offset=500000.0, y_offset=7000000.0,
             z_offset=100.0, rotation=30.0, rotation_units="dega")
    (s,) = load_model(p).surfaces.values()
    a = np.radians(30.0)
    x, y, z = np.array(_LOCAL).T
    want = np.column_stack([500000.0 + x * np.cos(a) + y * np.sin(a),
                            7000000.0 - x * np.sin(a) + y * np.cos(a), -(z + 100.0)])
    # 1e-6 m: rotation by a cos/sin of 30 degrees at 7e6 m (about 1e-9 m of rounding)
    assert np.allclose(s.vertices, want, rtol=0, atol=1e-6)


# --------------------------------------------------------------------------
# fuzz targets: mutated and truncated files load or raise ModelFileError
# --------------------------------------------------------------------------

_LINE_FORMATS = (".ts", ".ml", ".pl", ".obj")
_EXTRA = {}   # files a fuzzed file needs beside it (the .h5 of an .epc), by name


def _base_file(tmp_path_factory, suffix: str) -> bytes:
    d = tmp_path_factory.mktemp("fuzzbase")
    m = make_model()
    m.surfaces["coal 8"].metadata["vertex_properties"] = {"v": np.arange(m.surfaces["coal 8"].n_vertices, dtype=float)}
    if suffix == ".pl":
        m.save(d / "m.ts")
        return (d / "m_boundary.pl").read_bytes()
    if suffix == ".stl":
        pv = pytest.importorskip("pyvista")
        pv.Sphere(theta_resolution=6, phi_resolution=5).save(d / "m.stl", binary=False)
        return (d / "m.stl").read_bytes()
    m.save(d / f"m{suffix}")
    if suffix == ".epc":
        _EXTRA["m.h5"] = (d / "m.h5").read_bytes()
    return (d / f"m{suffix}").read_bytes()


def _mutate(data: bytes, cut: int, pos: int, byte: int, mode: int) -> bytes:
    if not data:
        return data
    pos %= len(data)
    if mode == 0:                                  # truncate
        return data[: cut % (len(data) + 1)]
    if mode == 1:                                  # change one byte
        return data[:pos] + bytes([byte]) + data[pos + 1:]
    if mode == 2:                                  # drop a line (or a chunk)
        j = data.find(b"\n", pos)
        return data[:pos] + (data[j + 1:] if j >= 0 else b"")
    return data[:pos] + data[pos:pos + 40] + data[pos:]   # duplicate a chunk


def _check_load(path: Path, n_lines: int, line_format: bool) -> None:
    try:
        load_model(path)
    except ModelFileError as e:
        assert str(e).startswith(str(path)) or str(e).startswith(str(path.with_name(
            path.stem + "_boundary.pl"))), str(e)
        if line_format and e.line is not None:
            assert 1 <= e.line <= n_lines + 1, (e.line, n_lines)


def _fuzz(suffix: str, examples: int):
    @pytest.mark.fuzz
    @fuzz_settings(examples)
    @given(cut=st.integers(0, 10 ** 6), pos=st.integers(0, 10 ** 6), byte=st.integers(0, 255),
           mode=st.integers(0, 3))
    def target(tmp_path_factory, cut, pos, byte, mode):
        key = f"_base{suffix}"
        if not hasattr(target, key):
            setattr(target, key, _base_file(tmp_path_factory, suffix))
        data = _mutate(getattr(target, key), cut, pos, byte, mode)
        d = tmp_path_factory.mktemp("fuzz")
        p = d / f"m{suffix}"
        p.write_bytes(data)
        if suffix == ".epc":   # the .h5 the .epc names stays intact beside it
            (d / "m.h5").write_bytes(_EXTRA["m.h5"])
        _check_load(p, data.count(b"\n"), suffix in _LINE_FORMATS)

    target.__name__ = f"test_fuzz_{suffix.lstrip('.')}_reader"
    return target


test_fuzz_ts_reader = _fuzz(".ts", 120)
test_fuzz_ml_reader = _fuzz(".ml", 60)
test_fuzz_pl_reader = _fuzz(".pl", 60)
test_fuzz_vtu_reader = _fuzz(".vtu", 120)
test_fuzz_vtp_reader = _fuzz(".vtp", 60)
test_fuzz_vtk_reader = _fuzz(".vtk", 120)
test_fuzz_obj_reader = _fuzz(".obj", 80)
test_fuzz_ply_reader = _fuzz(".ply", 80)
test_fuzz_stl_reader = _fuzz(".stl", 60)
test_fuzz_omf_reader = _fuzz(".omf", 40)
test_fuzz_geoh5_reader = _fuzz(".geoh5", 25)
test_fuzz_epc_reader = _fuzz(".epc", 25)


# --------------------------------------------------------------------------
# reader defects found by the model-reader fuzz (pf48): each test builds its
# file per the spec and fails on the readers before the fix
# --------------------------------------------------------------------------

_QUAD = "0 0 0 1 0 0 0 1 0 1 1 0"          # four points, two triangles 0 1 2 / 1 3 2


def _legacy(body: str, version: str = "4.2", kind: str = "POLYDATA") -> str:
    return f"# vtk DataFile Version {version}\nx\nASCII\nDATASET {kind}\nPOINTS 4 double\n" \
           f"{_QUAD}\n{body}"


def _vtp(polys_conn: str, polys_off: str, n_polys="2", extra_piece="", cell_data="",
         points_attrs='type="Float64" NumberOfComponents="3"', points=_QUAD) -> str:
    return ('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="0.1">\n<PolyData>\n'
            f'<Piece NumberOfPoints="4" NumberOfPolys="{n_polys}"{extra_piece}>\n'
            f'<Points><DataArray {points_attrs} format="ascii">{points}</DataArray></Points>\n'
            f'<CellData>{cell_data}</CellData>\n'
            f'<Polys><DataArray type="Int64" Name="connectivity" format="ascii">{polys_conn}'
            f'</DataArray><DataArray type="Int64" Name="offsets" format="ascii">{polys_off}'
            '</DataArray></Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n')


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("block, n, size, cells, msg", [
    ("POLYGONS", 10 ** 12, 4, [3, 0, 1, 2], r"1000000000000 cells announced in 4 entries"),
    ("LINES", 30_000_000, 2, [-1, 0], r"30000000 cells announced in 2 entries"),
    ("POLYGONS", 2, 5, [3, 0, 1, 2, -1], r"cell 1 has a negative point count -1"),
    ("POLYGONS", 2, 6, [2, 0, 1, 7, 0, 1], r"cell 1 announces 7 points, past the end"),
    ("TRIANGLE_STRIPS", 3, 7, [2, 0, 1, 3, 0, 1, 2], r"3 cells announced, the list ends after 2")])
def test_legacy_vtk_cell_counts_are_checked_against_the_data_first(tmp_path, binary, block, n,
                                                                  size, cells, msg):
    """Regression (D1): a header count of cells was allocated and walked
    before the data were checked: POLYGONS 1e12 raised a MemoryError out of
    load_model; LINES 3e7 over a cell of size -1 took 12 s and 500 MB. Now
    refused at once, naming the file, the block and what does not fit."""
    head = f"# vtk DataFile Version 4.2\nx\n{'BINARY' if binary else 'ASCII'}\n" \
           "DATASET POLYDATA\nPOINTS 4 double\n"
    pts = np.array(_QUAD.split(), float)
    data = head.encode() + (pts.astype(">f8").tobytes() + b"\n" if binary else
                            (_QUAD + "\n").encode())
    data += f"{block} {n} {size}\n".encode()
    data += np.array(cells, ">i4").tobytes() + b"\n" if binary else \
        (" ".join(map(str, cells)) + "\n").encode()
    p = tmp_path / "big.vtk"
    p.write_bytes(data)
    import time

    t = time.perf_counter()
    with pytest.raises(ModelFileError, match=rf"big\.vtk, line \d+: {block}: {msg}"):
        load_model(p)
    assert time.perf_counter() - t < 2.0


def test_legacy_vtk_cells_of_mixed_sizes_are_walked_without_a_loop(tmp_path):
    """The vectorised walk of a legacy cell list of mixed sizes (a line, an
    empty cell, two triangles) gives VTK's cells and their cell data."""
    p = tmp_path / "mixed.vtk"
    p.write_text(_legacy("POLYGONS 4 12\n2 0 1\n0\n3 0 1 2\n3 1 3 2\nCELL_DATA 4\n"
                         "SCALARS c double 1\nLOOKUP_TABLE default\n10 20 30 40\n"))
    (s,) = load_model(p).surfaces.values()
    assert s.triangles.tolist() == [[0, 1, 2], [1, 3, 2]]
    assert s.metadata["triangle_properties"]["c"].tolist() == [30, 40]


def test_a_memory_error_in_a_reader_becomes_a_model_file_error(tmp_path, monkeypatch):
    """Regression (D1): a MemoryError from a reader escaped load_model as it
    was; now a ModelFileError naming the file ("too large to read").
    KeyboardInterrupt still passes through."""
    from faultmesh import io

    p = tmp_path / "m.ply"
    p.write_bytes(b"ply\n")

    def boom(path):
        raise MemoryError("Unable to allocate 7.28 TiB")

    monkeypatch.setitem(io.FILE_FORMATS, ".ply", (None, boom))
    with pytest.raises(ModelFileError, match=r"m\.ply: reading it as \.ply failed: too large "
                                             r"to read .*7\.28 TiB"):
        load_model(p)

    def interrupt(path):
        raise KeyboardInterrupt

    monkeypatch.setitem(io.FILE_FORMATS, ".ply", (None, interrupt))
    with pytest.raises(KeyboardInterrupt):
        load_model(p)


def _ply_bytes(fmt: str, header_extra=(), vertices=((0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)),
               faces=((0, 1, 2), (1, 3, 2)), n_vertices=None, n_faces=None,
               index_type=("int", "i"), lists=None, tail=b"", comment="") -> bytes:
    """A PLY file per the spec: double x y z vertices, a face element with
    'vertex_indices' (or the ``lists``: [(name, type, struct code, values per
    face)]), optional header lines and bytes after the data."""
    o = {"binary_little_endian": "<", "binary_big_endian": ">"}.get(fmt)
    lists = lists or [("vertex_indices", index_type[0], index_type[1], list(faces))]
    head = ["ply", f"format {fmt} 1.0", *([f"comment {comment}"] if comment else []),
            f"element vertex {len(vertices) if n_vertices is None else n_vertices}",
            "property double x", "property double y", "property double z",
            f"element face {len(lists[0][3]) if n_faces is None else n_faces}",
            *[f"property list uchar {t} {name}" for name, t, _, _ in lists], *header_extra,
            "end_header", ""]
    nf = len(lists[0][3])
    if o is None:
        body = "".join(" ".join(map(str, v)) + "\n" for v in vertices)
        body += "".join(" ".join(" ".join(map(str, [len(vals[i]), *vals[i]]))
                                 for _, _, _, vals in lists) + "\n" for i in range(nf))
        return "\n".join(head).encode() + body.encode() + tail
    import struct

    body = b"".join(struct.pack(o + "ddd", *v) for v in vertices)
    for i in range(nf):
        for _, _, code, vals in lists:
            body += struct.pack(f"{o}B{len(vals[i])}{code}", len(vals[i]), *vals[i])
    return "\n".join(head).encode() + body + tail


_PLY_FORMATS = ["ascii", "binary_little_endian", "binary_big_endian"]


@pytest.mark.parametrize("fmt", _PLY_FORMATS)
@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_ply_non_finite_vertex_is_refused_naming_it_unused_ones_dropped(tmp_path, fmt, bad):
    """Regression (D2): NaN/inf PLY coordinates were loaded (the VTK, GOCAD
    and STL readers refuse them) and failed later in a writer. Refused naming
    the vertex when a triangle uses it, dropped when none does (as VTK)."""
    p = tmp_path / "m.ply"
    V = [(0, 0, 0), (bad, 0, 0), (0, 1, 0), (1, 1, 0), (1, bad, 2)]
    p.write_bytes(_ply_bytes(fmt, vertices=V))
    with pytest.raises(ModelFileError, match=r"m\.ply: vertex 1 has non-finite coordinates"):
        load_model(p)
    p.write_bytes(_ply_bytes(fmt, vertices=[(0, 0, 0), (bad, 0, 0), (1, 0, 0), (0, 1, 0)],
                             faces=[(0, 2, 3)]))
    (s,) = load_model(p).surfaces.values()
    assert s.vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    assert s.triangles.tolist() == [[0, 1, 2]]


@pytest.mark.parametrize("fmt", _PLY_FORMATS)
def test_ply_header_ends_only_at_an_end_header_line(tmp_path, fmt):
    """Regression (D3): the header ended at the first bytes 'end_header'
    anywhere, also inside a comment ("no vertex element in this PLY file"
    for a valid file). Only a line that is exactly end_header ends it (white
    space and a CR around it allowed)."""
    p = tmp_path / "m.ply"
    p.write_bytes(_ply_bytes(fmt, comment="exported before end_header was fixed",
                             header_extra=["element end_header_notes 0", "property int a"]))
    (s,) = load_model(p).surfaces.values()
    assert s.triangles.tolist() == [[0, 1, 2], [1, 3, 2]]
    p.write_bytes(_ply_bytes(fmt).replace(b"\nend_header\n", b"\n end_header \r\n"))
    assert load_model(p).surfaces[p.stem].n_triangles == 2


@pytest.mark.parametrize("name, text", [
    ("e.vtp", _vtp("0 1 2 1 3 2", "0 3 6", n_polys="3",
                   cell_data='<DataArray type="Float64" Name="c" format="ascii">10 20 30'
                             '</DataArray>')),
    ("e42.vtk", _legacy("POLYGONS 3 9\n0\n3 0 1 2\n3 1 3 2\nCELL_DATA 3\nSCALARS c double 1\n"
                        "LOOKUP_TABLE default\n10 20 30\n")),
    ("e51.vtk", _legacy("POLYGONS 4 6\nOFFSETS vtktypeint64\n0 0 3 6\nCONNECTIVITY vtktypeint64\n"
                        "0 1 2 1 3 2\nCELL_DATA 3\nSCALARS c double 1\nLOOKUP_TABLE default\n"
                        "10 20 30\n", version="5.1"))])
def test_vtk_empty_first_polygon_keeps_each_triangle_its_cell_data(tmp_path, name, text):
    """Regression (D4): end offsets starting with 0 (an empty first polygon)
    were taken for the start-offsets form, so each triangle got the cell
    data of the cell before it (c = 10, 20 instead of VTK's 20, 30)."""
    p = tmp_path / name
    p.write_text(text)
    (s,) = load_model(p).surfaces.values()
    assert s.triangles.tolist() == [[0, 1, 2], [1, 3, 2]]
    assert s.metadata["triangle_properties"]["c"].tolist() == [20, 30]


@pytest.mark.parametrize("n_polys, extra, msg", [
    ("1", "", r"piece 0: NumberOfPolys=1 but the Polys offsets array has 2 entries"),
    ("2", ' NumberOfStrips="1"', r"piece 0: NumberOfStrips=1 but <Strips> has no connectivity "
                                 r"and offsets arrays")])
def test_vtp_cell_counts_must_match_the_offsets(tmp_path, n_polys, extra, msg):
    """Regression (D6): NumberOfPolys/NumberOfStrips were not checked against
    the offsets arrays: all offsets were read as cells but the cell data
    numbered by the attribute (the 2nd poly and a strip got the same value)."""
    p = tmp_path / "n.vtp"
    p.write_text(_vtp("0 1 2 1 3 2", "3 6", n_polys=n_polys, extra_piece=extra))
    with pytest.raises(ModelFileError, match=rf"n\.vtp: {msg}"):
        load_model(p)


@pytest.mark.parametrize("fmt", _PLY_FORMATS)
def test_ply_data_left_after_the_last_element_is_refused(tmp_path, fmt):
    """Regression (D10): data after the last element were ignored, so a wrong
    count in the header gave a wrong model silently. Refused naming what is
    left; a trailing newline (and, binary, a few NUL bytes) is tolerated."""
    p = tmp_path / "m.ply"
    p.write_bytes(_ply_bytes(fmt, n_faces=1))
    left = r"4 value\(s\)" if fmt == "ascii" else r"13 byte\(s\)"
    with pytest.raises(ModelFileError, match=rf"m\.ply: {left} left after the last element"):
        load_model(p)
    for tail in (b"\n", b"\r\n") + ((b"\0\0\n", b"\0" * 8) if fmt != "ascii" else (b"  \n\n",)):
        p.write_bytes(_ply_bytes(fmt, tail=tail))
        assert load_model(p).surfaces["m"].n_triangles == 2
    if fmt != "ascii":
        p.write_bytes(_ply_bytes(fmt, tail=b"\0" * 9))
        with pytest.raises(ModelFileError, match=r"9 byte\(s\) left after the last element"):
            load_model(p)


@pytest.mark.parametrize("fmt", _PLY_FORMATS)
def test_ply_face_list_without_vertex_indices_is_the_only_integer_list(tmp_path, fmt):
    """Regression (D11): without vertex_indices the first list was taken,
    float texture coordinates included (0 triangles, silently). The only
    integer list is taken; else an error naming the lists."""
    tex = [(0.5, 0.25), (0.125, 1.0)]
    p = tmp_path / "m.ply"
    p.write_bytes(_ply_bytes(fmt, lists=[("texcoord", "float", "f", tex),
                                         ("indices", "int", "i", [(0, 1, 2), (1, 3, 2)])]))
    assert load_model(p).surfaces["m"].triangles.tolist() == [[0, 1, 2], [1, 3, 2]]
    p.write_bytes(_ply_bytes(fmt, lists=[("a", "int", "i", [(0, 1, 2), (1, 3, 2)]),
                                         ("b", "uint", "I", [(0, 1, 2), (1, 3, 2)])]))
    with pytest.raises(ModelFileError, match=r"m\.ply: the face element has no vertex_indices "
                                             r"list .*\(lists: a \(int\), b \(uint\)\)"):
        load_model(p)


@pytest.mark.parametrize("fmt", _PLY_FORMATS)
def test_ply_fractional_vertex_index_is_refused_naming_the_face(tmp_path, fmt):
    """Regression (D7): a fractional index (ascii 1.5, or a float/double
    index list) was truncated silently into another triangle."""
    p = tmp_path / "m.ply"
    p.write_bytes(_ply_bytes(fmt, faces=[(0, 1, 2), (1, 3, 1.5)], index_type=("double", "d")))
    with pytest.raises(ModelFileError, match=r"m\.ply: face 1: vertex index 1\.5 is not an "
                                             r"integer"):
        load_model(p)
    if fmt == "ascii":   # an int list holding a fraction in the text
        p.write_bytes(_ply_bytes(fmt).replace(b"3 1 3 2\n", b"3 1 3 2.5\n"))
        with pytest.raises(ModelFileError, match=r"face 1: vertex index 2\.5 is not an integer"):
            load_model(p)
    p.write_bytes(_ply_bytes(fmt, faces=[(0, 1, 2), (1, 3, -1)]))
    with pytest.raises(ModelFileError, match=r"m\.ply: face 1: vertex index -1 is outside the 4 "
                                             r"vertices"):
        load_model(p)


def test_ply_huge_list_length_is_named_exactly(tmp_path):
    """Regression (D8c): a list length 2^64 - 1 was reported (through a
    float) as 18446744073709551616."""
    p = tmp_path / "m.ply"
    p.write_bytes(_ply_bytes("ascii", index_type=("uint64", "Q")).replace(
        b"\n3 0 1 2\n", b"\n18446744073709551615 0 1 2\n").replace(b"list uchar", b"list uint64"))
    with pytest.raises(ModelFileError, match=r"a list of 18446744073709551615 entries"):
        load_model(p)


@pytest.mark.parametrize("name, text, msg", [
    ("neg.vtp", _vtp("0 1 2 1 3 -1", "3 6"),
     r"cell 1 refers to point -1; the piece has 4 points \(0\.\.3\)"),
    ("huge.vtk", _legacy("POLYGONS 1 4\n3 0 1 99999999999\n"),
     r"POLYGONS: value '99999999999' \(number 3\) is not an integer of type int32"),
    ("types.vtk", _legacy("CELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n99999999999\n",
                          kind="UNSTRUCTURED_GRID"),
     r"CELL_TYPES: value '99999999999' \(number 0\) is not an integer"),
    ("frac.vtk", _legacy("POLYGONS 1 4\n3 0 1 1.9\n"), r"value '1\.9' \(number 3\) is not an "
                                                       r"integer"),
    ("two.vtp", _vtp("0 1 2 1 3 2", "3 6", n_polys="two"),
     r"piece 0: NumberOfPolys='two' is not a count"),
    ("huge.vtp", _vtp("0 1 2 1 3 2", "3 6", n_polys="99999999999999999999999"),
     r"piece 0: NumberOfPolys='99999999999999999999999' is not a count \(too large\)"),
    ("comp.vtp", _vtp("0 1 2 1 3 2", "3 6", points_attrs='type="Float64" '
                                                        'NumberOfComponents="three"'),
     r"piece 0 Points: NumberOfComponents='three' is not a count"),
    ("str.vtp", _vtp("0 1 2 1 3 2", "3 6", points_attrs='type="String" NumberOfComponents="3"'),
     r"piece 0: Points of type 'String', expected a numeric type"),
    ("comp2.vtp", _vtp("0 1 2 1 3 2", "3 6", points_attrs='type="Float64" NumberOfComponents="2"',
                       points="0 0 1 0 0 1 1 1 0 0 1 0"),
     r"piece 0: Points have NumberOfComponents=2, expected 3")])
def test_vtk_messages_name_the_bad_value_and_where_it_is(tmp_path, name, text, msg):
    """Regression (D8, D9, D13): a -1 index was reported as 'refers to point
    3' (a valid point); 99999999999 overflowed int32 into a valid index or a
    negative cell type; a fraction was truncated; a NumberOf* attribute that
    is no count, String-typed Points gave 'failed: ValueError: ...' without
    the attribute; 2-component Points were read as 3-D (VTK refuses them)."""
    p = tmp_path / name
    p.write_text(text)
    with pytest.raises(ModelFileError, match=rf"{re.escape(name)}(, line \d+)?: .*{msg}"):
        load_model(p)


def test_vtm_block_that_is_not_a_readable_file_is_named(tmp_path):
    """Regression (D8d, D9): a block path that is a directory was reported as
    'does not exist', a name too long as 'failed: OSError', an internal
    error inside a block named only the .vtm. Each names the block and its
    file, and what is wrong with it."""
    def vtm(rel):
        (tmp_path / "m.vtm").write_text(
            '<?xml version="1.0"?>\n<VTKFile type="vtkMultiBlockDataSet" version="1.0">\n'
            f'<vtkMultiBlockDataSet><DataSet index="0" name="b" file="{rel}"/>'
            '</vtkMultiBlockDataSet>\n</VTKFile>\n')
        return tmp_path / "m.vtm"

    (tmp_path / "d.vtp").mkdir()
    with pytest.raises(ModelFileError, match=r"m\.vtm: block 'b': its file .*d\.vtp is a "
                                             r"directory"):
        load_model(vtm("d.vtp"))
    with pytest.raises(ModelFileError, match=r"m\.vtm: block 'b': its file .* cannot be opened "
                                             r"\(File name too long\)"):
        load_model(vtm("a" * 300 + ".vtp"))


def test_vtm_of_many_blocks_of_one_name_names_them_in_linear_time(tmp_path):
    """Regression (D12a): free_name tried 'name (2)', 'name (3)'... from 2 for
    every block: 5,000 blocks of one name took 9 s. With a counter per
    target the look-ups are linear; the names are unchanged."""
    from faultmesh.formats._common import free_name

    class Counting(dict):
        looks = 0

        def __contains__(self, key):
            Counting.looks += 1
            return super().__contains__(key)

    taken, counters = Counting(), {}
    for _ in range(2000):
        name = free_name("b", taken, counters)
        taken[name] = None
    assert list(taken)[:3] == ["b", "b (2)", "b (3)"] and len(taken) == 2000
    assert Counting.looks < 3 * 2000
    taken["c (2)"] = None            # a name already taken is skipped, not reused
    assert [free_name("c", taken, counters) for _ in range(1)] == ["c"]
    taken["c"] = None
    assert free_name("c", taken, counters) == "c (3)"
    # through a .vtm: 300 blocks naming one file, one name
    pv = pytest.importorskip("pyvista")
    pv.Plane(i_resolution=1, j_resolution=1).triangulate().save(tmp_path / "s.vtp")
    blocks = "".join(f'<DataSet index="{i}" name="b" file="s.vtp"/>' for i in range(300))
    (tmp_path / "m.vtm").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="vtkMultiBlockDataSet" version="1.0">\n'
        f"<vtkMultiBlockDataSet>{blocks}</vtkMultiBlockDataSet>\n</VTKFile>\n")
    m = load_model(tmp_path / "m.vtm")
    assert list(m.surfaces)[:3] == ["b", "b (2)", "b (3)"] and len(m.surfaces) == 300
    assert all(s.n_triangles == 2 for s in m.surfaces.values())
    m.surfaces["b"].vertices[0, 0] = 99.0      # each block its own arrays
    assert m.surfaces["b (2)"].vertices[0, 0] != 99.0


def test_split_by_surface_id_is_one_group_by(tmp_path, monkeypatch):
    """Regression (D12b): splitting a merged mesh by surface_id scanned every
    vertex per id (a PLY of 50,000 ids took 4 s). Now one sort: no scan per
    surface, and each surface its own vertices and triangles as before."""
    from faultmesh.formats import _common

    n = 500
    rng = np.random.default_rng(0)
    P = rng.random((3 * n, 3))
    sid = np.repeat(rng.permutation(n), 3)
    T = np.arange(3 * n).reshape(n, 3)[:, ::-1]
    calls = []
    real = np.flatnonzero
    monkeypatch.setattr(np, "flatnonzero", lambda *a, **k: calls.append(1) or real(*a, **k))
    m = _common.split_merged(tmp_path / "x.ply", P, T, {"surface_id": sid}, {})
    monkeypatch.undo()
    assert len(calls) < 10
    assert list(m.surfaces) == [f"surface_{k}" for k in range(n)]
    for k in (0, 7, n - 1):
        rows = np.flatnonzero(sid == k)
        s = m.surfaces[f"surface_{k}"]
        assert np.array_equal(s.vertices, P[rows]) and s.triangles.tolist() == [[2, 1, 0]]


def test_vtu_triangle_strip_cells_are_read_as_vtk_triangulates_them(tmp_path):
    """Regression (D15): the docs say strips are kept, but a triangle-strip
    cell (type 6) in a .vtu was refused; now its triangles (as VTK's
    triangulate() makes them) in cell order, each with its cell's data."""
    pv = pytest.importorskip("pyvista")
    pts = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [1, 1, 0.5], [2, 0, 0], [2, 1, 0]], float)
    cells = np.array([3, 0, 1, 4, 5, 0, 1, 2, 3, 4, 3, 3, 5, 4])
    g = pv.UnstructuredGrid(cells, np.array([5, 6, 5], np.uint8), pts)
    g.cell_data["cid"] = np.array([7, 8, 9], np.int32)
    p = tmp_path / "s.vtu"
    g.save(p)
    ref = pv.read(p).triangulate()
    (s,) = load_model(p).surfaces.values()
    F = np.asarray(ref.cells).reshape(-1, 4)[:, 1:]
    assert np.array_equal(s.vertices[s.triangles], np.asarray(ref.points)[F])
    assert s.metadata["triangle_properties"]["cid"].tolist() == [7, 8, 8, 8, 9]


@pytest.mark.parametrize("name, text, msg", [
    ("lines.vtp", _vtp("0 1 2 1 3 2", "3 6", extra_piece=' NumberOfLines="1"').replace(
        "<Polys>", '<Lines><DataArray type="Int64" Name="connectivity" format="ascii">0 1'
                   '</DataArray><DataArray type="Int64" Name="offsets" format="ascii">99'
                   '</DataArray></Lines><Polys>'),
     r"piece 0: Lines: offsets are not increasing within the 2 connectivity entries"),
    ("lidx.vtp", _vtp("0 1 2 1 3 2", "3 6", extra_piece=' NumberOfLines="1"').replace(
        "<Polys>", '<Lines><DataArray type="Int64" Name="connectivity" format="ascii">0 '
                   '1099511627776</DataArray><DataArray type="Int64" Name="offsets" '
                   'format="ascii">2</DataArray></Lines><Polys>'),
     r"piece 0: Lines: a cell refers to point 1099511627776; the piece has 4 points"),
    ("short.vtp", _vtp("0 1 2 1 3 2", "3 6", cell_data='<DataArray type="Float64" Name="c" '
                                                       'format="ascii">1 2 3</DataArray>'),
     r"piece 0 CellData: array 'c' has 3 tuples for the 2 cells"),
    ("float51.vtk", _legacy("POLYGONS 3 6\nOFFSETS float\n0 3.7 6\nCONNECTIVITY vtktypeint64\n"
                            "0 1 2 1 3 2\n", version="5.1"),
     r"OFFSETS: data type 'float' is not an integer type")])
def test_vtk_hostile_cell_arrays_are_refused(tmp_path, name, text, msg):
    """Regression (D13): Verts/Lines offsets and indices were never checked
    (past the end, 2^40 accepted); a cell array of the wrong length was
    dropped silently; legacy 5.1 float OFFSETS were truncated."""
    p = tmp_path / name
    p.write_text(text)
    with pytest.raises(ModelFileError, match=rf"{re.escape(name)}(, line \d+)?: {msg}"):
        load_model(p)


def test_legacy_vtk_second_block_of_a_kind_replaces_the_first(tmp_path):
    """Regression (D13): two POLYGONS blocks were both kept; VTK's reader
    keeps the last (and numbers the cells by it)."""
    p = tmp_path / "twice.vtk"
    p.write_text(_legacy("POLYGONS 1 4\n3 0 1 2\nPOLYGONS 1 4\n3 1 3 2\nCELL_DATA 1\n"
                         "SCALARS c double 1\nLOOKUP_TABLE default\n5\n"))
    (s,) = load_model(p).surfaces.values()
    assert s.vertices[s.triangles].tolist() == [[[1, 0, 0], [1, 1, 0], [0, 1, 0]]]
    assert s.metadata["triangle_properties"]["c"].tolist() == [5]


def test_vtp_compressed_block_inflating_past_its_header_is_refused(tmp_path):
    """Regression (D14): the block sizes of a zlib header were not used: a
    2 MB file whose one '96-byte' block inflates to gigabytes took seconds
    and 2 GB before failing. The output is capped at the announced size."""
    import base64
    import zlib

    def arr(attrs, raw: bytes, inflate_to=None):
        z = zlib.compress(raw if inflate_to is None else bytes(inflate_to))
        head = np.array([1, len(raw), len(raw), len(z)], "<u4").tobytes()
        return (f'<DataArray {attrs} format="binary">{base64.b64encode(head).decode()}'
                f'{base64.b64encode(z).decode()}</DataArray>')

    pts = np.array(_QUAD.split(), "<f8").tobytes()
    conn = np.array([0, 1, 2, 1, 3, 2], "<i8").tobytes()
    off = np.array([3, 6], "<i8").tobytes()

    def vtp(inflate_to=None):
        return ('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="0.1" '
                'byte_order="LittleEndian" compressor="vtkZLibDataCompressor">\n<PolyData>\n'
                '<Piece NumberOfPoints="4" NumberOfPolys="2">\n<Points>'
                + arr('type="Float64" NumberOfComponents="3"', pts, inflate_to) + '</Points>\n'
                '<Polys>' + arr('type="Int64" Name="connectivity"', conn)
                + arr('type="Int64" Name="offsets"', off) + '</Polys>\n</Piece>\n</PolyData>\n'
                '</VTKFile>\n')

    p = tmp_path / "z.vtp"
    p.write_text(vtp())
    assert load_model(p).surfaces["z"].n_triangles == 2
    p.write_text(vtp(inflate_to=50_000_000))
    with pytest.raises(ModelFileError, match=r"z\.vtp: compressed block 0 holds more than the "
                                             r"96 bytes its header announces"):
        load_model(p)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_faces_of_mixed_sizes_are_walked_not_read_run_by_run(tmp_path, fmt, monkeypatch):
    """Faces of mixed sizes were read in runs of one size, a Python step per
    run (fuzz: 200,000 faces alternating triangle and line took 9.8 s, 0.7 s
    walked; measured, not asserted). Past the first run the records are
    walked (ply._walk_element, once): the triangles, in file order, with the
    uchar after each list and the edge element after the faces read right;
    a file cut inside the faces is named."""
    from faultmesh.formats import ply

    calls = []
    walk = ply._walk_element
    monkeypatch.setattr(ply, "_walk_element", lambda *a: calls.append(a[-1]) or walk(*a))
    pattern = [[0, 1, 2], [0, 1], [1, 3, 2], [3], [2, 3, 1], [1, 2]]
    faces = pattern * 300
    p = tmp_path / "m.ply"
    data = _ply(fmt, faces)
    p.write_bytes(data)
    s, = surfaces(load_model(p))
    assert calls == [len(faces) - 1]     # the first run is one triangle
    want = np.array([f for f in faces if len(f) == 3])
    V = np.array([(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 1.0, 0.5)])
    assert np.array_equal(s.vertices[s.triangles], V[want])
    if fmt != "ascii":
        p.write_bytes(data[:len(data) - 8 - 40])     # the edge element and some faces gone
        with pytest.raises(ModelFileError, match=r"m\.ply: the face element announces 1800 "
                                                 r"records, the file ends first"):
            load_model(p)
