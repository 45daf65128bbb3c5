"""The method comparison's key checks (bench/compare.py): every stitched gap has
exactly as many triangles as CGAL's constrained Delaunay triangulation of the
same gap polygon, and the quality-order + CDT gaps are at least as good as
CGAL's in minimum-angle shares (they are the same triangulation)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import faultmesh
from faultmesh.model import Gap, Model, Surface

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
import bench_scale  # noqa: E402
import compare  # noqa: E402


def stitched_model(order: str, refine: bool, n_points=6000, n_faults=4, seed=3) -> Model:
    """A synthetic layer (random points, 10 m spacing) with fault patches of
    both kinds stitched by the Stitcher, as a Model with its gaps."""
    side = float(np.sqrt(n_points) * bench_scale.SPACING)
    P = bench_scale.make_points(n_points, side, seed)
    T = faultmesh.delaunay(P[:, :2])
    rng = np.random.default_rng(seed)
    st = faultmesh.Stitcher(P, T, np.array([[0, 0], [side, 0], [side, side], [0, side]], float),
                            order=order, refine=refine)
    gaps = []
    for k in range(n_faults):
        c = np.array([side * (0.25 + 0.5 * (k % 2)), side * (0.25 + 0.5 * (k // 2))])
        V, F = bench_scale.fault_patch(c, strike=rng.uniform(0, 360), dip=rng.uniform(45, 70),
                                       throw=rng.uniform(5, 25), kind=("normal", "reverse")[k % 2],
                                       length=200.0, reach=60.0)
        rep = st.stitch(V, F, name=f"F{k}")
        gaps += [(f"F{k}", g) for g in rep.gaps]
    mesh = st.mesh()
    surf = Surface("layer", mesh.vertices, mesh.triangles, kinds=mesh.kinds, owner=mesh.owners)
    model_gaps = [Gap(fault=f, layer="layer", triangles=mesh.triangle_map[g.triangles],
                      n_vertices=int(g.n_vertices), n_holes=int(g.n_holes), id=int(g.id),
                      n_interior=int(g.n_interior),
                      patches=[int(p) for p in g.patches])
                  for f, g in gaps]
    assert all((g.triangles >= 0).all() for g in model_gaps)
    return Model(name="synthetic", surfaces={"layer": surf}, gaps=model_gaps)


@pytest.fixture(scope="module")
def cgal_gap(cgal_bin):
    return cgal_bin("cgal_gap_cdt")


@pytest.mark.parametrize("order,refine", [("quality", True), ("plain", False)])
def test_stitched_gaps_have_cgal_counts(cgal_gap, order, refine):
    model = stitched_model(order, refine)
    recs = compare.gap_table(model, with_cgal=cgal_gap, cgal_repeat=1)
    assert len(recs) == 4
    assert sum(r["n_interior"] for r in recs) > 0  # the case the CGAL input must carry
    for r in recs:
        n = r["stats"]["triangles"]
        # The layer vertices put back inside a gap (k = len(interior)) are
        # given to CGAL too, as unconstrained points: 2 triangles each.
        k = len(r["interior"])
        assert k == r["n_interior"]
        assert n == r["n_vertices"] + 2 * r["n_holes"] - 2 + 2 * k
        assert n == r["cgal_stats"]["triangles"], (r["fault"], n, r["cgal_stats"]["triangles"])
        # The polygon given to CGAL is the gap's: its ring sizes add up to n_vertices.
        assert sum(len(x) for x in r["rings"]) == r["n_vertices"]
        assert r["cgal_vertices"] == len(np.unique(np.concatenate(r["rings"]))) + k
        if refine:
            # Quality order + CDT flips is CGAL's CDT, triangle for triangle.
            assert r["cgal_identical"], r["fault"]
            for k in ("lt10", "lt20"):
                assert r["stats"][k] <= r["cgal_stats"][k]


def test_gap_rings_and_cgal_on_a_polygon_with_a_hole(cgal_gap):
    """A hand-made gap: square minus square, the ring extraction and CGAL
    numbering round trip (8 vertices, 1 hole -> 8 triangles)."""
    V = np.array([[0, 0, 0], [4, 0, 0], [4, 4, 1], [0, 4, 1], [1, 1, 0], [3, 1, 0], [3, 3, 1], [1, 3, 1]],
                 float)
    tri = faultmesh.triangulate_polygon([V[:4, :2], V[4:, :2]])
    s = Surface("s", V, tri)
    g = Gap("f", "s", np.arange(len(tri)), 8, 1)
    rings = compare.gap_rings(s, g)
    assert len(rings) == 2 and sorted(np.concatenate(rings).tolist()) == list(range(8))
    tris, info = compare.run_cgal(cgal_gap, [(V, rings)], repeat=1)
    assert len(tris[0]) == 8 and info[0]["vertices"] == 8
    assert compare._canon(tris[0]) == compare._canon(tri)


def test_builtin_dataset_gaps_equal_cgal(cgal_gap):
    """The comparison's key checks on the built-in dataset (bench/compare.py
    with one run): every gap of build_model's model has CGAL's triangle count,
    the quality-order gaps are CGAL's CDT, and the paper-order gaps are the
    same polygons (same counts)."""
    res = compare.compare(faultmesh.datasets.paper_like(0), repeat=1, cgal_exe=cgal_gap)
    ch = res["checks"]
    assert ch["gaps"] >= 7
    assert ch["counts_equal_cgal"], ch["mismatches"]
    assert ch["identical_to_cgal"] == ch["gaps"]
    assert ch["quality_not_worse_than_cgal"], ch["worse"]
    for row in res["rows"]:
        if "quality" in row:
            assert row["quality"]["triangles"] == row["cgal"]["triangles"]
            assert row["paper"]["triangles"] == row["paper_cgal"]["triangles"]
        assert "cutting" in row  # every faultmesh gap has its cutting counterpart
    md = compare.markdown(res, "python bench/compare.py", "x.png")
    assert "Table 1" in md and "Machine:" in md and "Date:" in md
