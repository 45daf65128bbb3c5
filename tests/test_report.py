"""Quality report: angles, the paper's tables, vertical errors, output files."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

import faultmesh
from faultmesh.model import Gap, Model, Surface
from faultmesh.report import evaluate_surface, min_angles, quality, triangle_angles


def test_triangle_angles_known_triangles():
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, np.sqrt(3) / 2, 0], [3, 0, 0],
                  [0, 4, 0], [2, 0, 0]], float)
    a = triangle_angles(P, [[0, 1, 2], [0, 1, 3], [0, 4, 5], [0, 1, 6]])
    assert a[0] == pytest.approx([90, 45, 45])
    assert a[1] == pytest.approx([60, 60, 60])
    assert a[2] == pytest.approx([90, np.degrees(np.arctan2(4, 3)), np.degrees(np.arctan2(3, 4))])
    assert a[3].min() == 0.0                        # degenerate: collinear
    assert np.allclose(a[:3].sum(axis=1), 180)
    # A needle keeps its tiny angle (atan2 form, not acos).
    n = triangle_angles(np.array([[0, 0], [1, 0], [0.5, 1e-9]]), [[0, 1, 2]])
    assert n.min() == pytest.approx(np.degrees(2e-9), rel=1e-6)
    with pytest.raises(ValueError, match="vertex index outside"):
        triangle_angles(P, [[0, 1, 7]])


def tri_with_min_angle(deg, x0=0.0, z=None):
    """Isosceles triangle with apex angle ``deg`` (its smallest angle if < 60)."""
    h = 0.5 / np.tan(np.radians(deg) / 2)
    P = np.array([[x0, 0, 0], [x0 + 1, 0, 0], [x0 + 0.5, h, 0]], float)
    if z is not None:
        P[:, 2] = z
    return P


def hand_made_model():
    """A layer whose last three triangles are a 'gap': min angles 60, 15, 5 deg
    in XY; the first gap triangle is tilted so that in 3D it is narrow too."""
    parts = [tri_with_min_angle(60, 0, z=[0, 0, 0]), tri_with_min_angle(60, 2, z=[0, 0, 0]),
             tri_with_min_angle(60, 4, z=[0, 0, 30.0]),     # equilateral in XY, steep in 3D
             tri_with_min_angle(15, 6), tri_with_min_angle(5, 8)]
    V = np.vstack(parts)
    T = np.arange(len(V)).reshape(-1, 3)
    m = Model("hand", {"coal": Surface("coal", V, T), "deep": Surface("deep", V - [0, 0, 50], T)},
              gaps=[Gap("F1", "coal", np.array([2, 3]), 4, 0), Gap("F1", "coal", np.array([4]), 3, 0),
                    Gap("F2", "deep", np.array([0, 4]), 4, 0, seconds=0.25)])
    return m


def test_quality_shares_on_a_hand_made_mesh():
    m = hand_made_model()
    rep = quality(m)
    g0, g1, g2 = rep.gaps
    # 3D: the tilted equilateral has a min angle well under 10 deg.
    tilted = min_angles(m.surfaces["coal"].vertices, m.surfaces["coal"].triangles[[2]])[0]
    assert tilted < 10
    assert (g0["triangles"], g0["lt10"], g0["lt20"]) == (2, 0.5, 1.0)
    assert (g0["lt10_xy"], g0["lt20_xy"]) == (0.0, 0.5)
    assert g0["min_angle_xy"] == pytest.approx(15.0)
    assert (g1["lt10"], g1["lt20"], g1["min_angle"]) == (1.0, 1.0, pytest.approx(5.0))
    assert g0["expected_triangles"] == 2 and g2["seconds"] == 0.25
    t = rep.tables()
    assert t["table1"] == [{"fault": "F1", "coal": 3, "deep": None},
                           {"fault": "F2", "coal": None, "deep": 2}]
    f1 = t["table2"][0]
    assert (f1["gap"], f1["triangles"]) == ("F1-coal", 3)
    assert f1["lt10"] == pytest.approx(2 / 3) and f1["lt20"] == 1.0
    assert f1["lt10_xy"] == pytest.approx(1 / 3) and f1["lt20_xy"] == pytest.approx(2 / 3)
    f2 = t["table2"][1]
    assert (f2["lt10"], f2["lt20"]) == (0.5, 0.5)
    coal = next(s for s in rep.surfaces if s["name"] == "coal")
    assert coal["triangles"] == 5 and coal["lt20"] == pytest.approx(3 / 5)
    assert rep.errors == [] and "no ground truth" in rep.notes[0]


def test_report_outputs(tmp_path):
    rep = hand_made_model().quality()
    md = rep.to_markdown()
    assert "## Table 1" in md and "| F1 | 3 | – |" in md
    assert "| F1-coal | 3 | 66.7 % | 100.0 % | 33.3 % | 66.7 % |" in md
    rows = list(csv.DictReader(rep.to_csv(tmp_path / "q.csv").open()))
    assert [r["table"] for r in rows] == ["gap"] * 3 + ["surface"] * 2
    assert float(rows[0]["lt10"]) == 0.5 and rows[3]["name"] == "coal"
    data = json.loads((tmp_path / "q.json").read_text()) if rep.to_json(tmp_path / "q.json") else None
    assert data["tables"]["table1"][0]["fault"] == "F1"
    assert data["model"] == "hand" and len(data["gaps"]) == 3


def test_quality_rejects_bad_gaps():
    m = hand_made_model()
    m.gaps.append(Gap("F9", "coal", np.array([99]), 3, 0))
    with pytest.raises(ValueError, match=r"gap 'F9'/'coal' has triangle rows outside 0..4"):
        quality(m)
    m.gaps[-1] = Gap("F9", "nope", np.array([0]), 3, 0)
    with pytest.raises(ValueError, match="names a layer the model does not have"):
        quality(m)


def grid_surface(n=41, size=1000.0, f=lambda x, y: 0.0 * x):
    g = np.linspace(0, size, n)
    X, Y = np.meshgrid(g, g)
    xy = np.column_stack([X.ravel(), Y.ravel()])
    return np.column_stack([xy, f(xy[:, 0], xy[:, 1])]), faultmesh.delaunay(xy)


def test_vertical_error_away_and_near_faults():
    V, T = grid_surface(f=lambda x, y: 0.02 * x + 10)
    fault = Surface("F", np.array([[500, -5, 20], [500, 1005, 20], [510, -5, -50], [510, 1005, -50]]),
                    np.array([[0, 2, 1], [1, 2, 3]]), kind="fault")
    B = np.array([[0, 0], [1000, 0], [1000, 1000], [0, 1000.0]])
    m = Model("planar", {"a": Surface("a", V, T)}, {"F": fault}, boundary=B)

    # Truth: the same plane, except 3 m higher far east (x > 800, "away") and
    # 1 m higher in a strip close to the fault (x 540..560, "near").
    def truth(layer, x, y):
        return 0.02 * x + 10 + 3.0 * (x > 800) + 1.0 * ((x > 540) & (x < 560))

    rep = quality(m, truth=truth, near=150.0, samples=100)
    rows = {r["region"]: r for r in rep.errors}
    away, near = rows["away"], rows["near"]
    assert rows["overlap"]["samples"] == 0
    assert away["max_abs_dz"] == pytest.approx(3.0) and near["max_abs_dz"] == pytest.approx(1.0)
    # 100 x 100 samples, cell centres; near = within 150 m of x 500..510.
    assert away["samples"] + near["samples"] == 10000
    assert 0.30 <= near["samples"] / 10000 <= 0.33
    assert away["mean_abs_dz"] == pytest.approx(3.0 * 20 / (100 - near["samples"] / 100), rel=1e-9)
    assert rep.settings["grid"] == [100, 100] and rep.settings["near_m"] == 150.0


def test_vertical_error_in_a_reverse_fault_overlap_band():
    # A Z-folded layer (footwall x 0..600 at z 0, strip back to x 500 rising
    # to z 20, hanging wall x 500..1000 at z 20): samples with 500 < x < 600
    # see three sheets; the truth reports the upper one there.
    xs = [0, 100, 200, 300, 400, 500, 600, 500, 600, 700, 800, 900, 1000]
    zs = [0, 0, 0, 0, 0, 0, 0, 20, 20, 20, 20, 20, 20]
    ys = np.linspace(0, 1000, 11)
    V = np.array([[x, y, z] for y in ys for x, z in zip(xs, zs)], float)
    n = len(xs)
    T = []
    for j in range(len(ys) - 1):
        for i in range(n - 1):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1
            T += [[a, b, d], [a, d, c]]
    m = Model("fold", {"a": Surface("a", V, np.array(T))},
              boundary=np.array([[0, 0], [1000, 0], [1000, 1000], [0, 1000.0]]))

    def truth(layer, x, y):
        return np.where(x > 500, 20.0, 0.0)

    rep = quality(m, truth=truth, samples=50)
    rows = {r["region"]: r for r in rep.errors}
    assert rows["overlap"]["samples"] == 50 * 5      # x in (500, 600): 5 sample columns
    assert rows["overlap"]["max_abs_dz"] == 0.0      # the upper sheet matches
    assert rows["away"]["max_abs_dz"] == 0.0

    lo, hi, nh = evaluate_surface(m.surfaces["a"], [530.0, 250.0, 2000.0], [520.0, 520.0, 0.0])
    assert (lo[0], hi[0]) == (0.0, 20.0) and nh[0] == 3
    assert lo[1] == hi[1] == 0.0
    assert np.isnan(lo[2]) and nh[2] == 0


def test_fit_to_the_data_in_the_model_s_layer_order_after_a_3dt_round_trip(tmp_path):
    """The quality report's fit to the data (from the build's
    metadata["data_fit"]) lists the layers top down, also for a model read
    back from a .3dt, whose metadata keys come back sorted; report.data_fit
    compares each datum with the sheet nearest to it."""
    from faultmesh.report import data_fit

    ring = np.array([[0, 0], [1000, 0], [1000, 1000], [0, 1000]], float)
    g = np.linspace(50.0, 950.0, 5)
    X, Y = (a.ravel() for a in np.meshgrid(g, g))
    n = len(X)
    bh = faultmesh.dataset.Boreholes(np.repeat([f"H{i}" for i in range(n)], 2), np.repeat(np.c_[X, Y], 2, axis=0),
                                     np.tile(["Z top", "A base"], n), np.tile([0.0, -20.0], n))
    m = faultmesh.build_model(faultmesh.Dataset("two", ["Z top", "A base"], ring, bh))
    m.save(tmp_path / "m.3dt")
    back = faultmesh.load_model(tmp_path / "m.3dt")
    rep = back.quality()
    assert [r["layer"] for r in rep.data_fit] == ["Z top", "A base"]
    assert all(r["data"] == 25 and r["off"] == 0 for r in rep.data_fit)
    assert "## Fit to the data" in rep.to_markdown() and "data_fit" in rep.to_dict()
    # A datum 3 m off the surface, one outside the study area.
    D = np.array([[500.0, 500.0, 3.0], [2000.0, 0.0, 0.0]])
    fit = data_fit({"Z top": m.surfaces["Z top"]}, {"Z top": D})["Z top"]
    assert (fit["data"], fit["outside"], fit["off"]) == (1, 1, 1)
    assert fit["max_m"] == pytest.approx(3.0)
    assert fit["worst"] == {"x": 500.0, "y": 500.0, "z": 3.0, "model_z": pytest.approx(0.0)}


def _square(z, name, kinds=None):
    """A 100 m square at elevation z(x, y), its centre a vertex (4 triangles)."""
    xy = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0], [50.0, 50.0]])
    V = np.column_stack([xy, [z(x, y) for x, y in xy]])
    T = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    return Surface(name, V, T, kinds=kinds)


def test_layer_order_measures_a_lower_layer_over_the_upper_one_at_its_highest():
    """report.layer_order: the lower layer's highest sheet against the
    upper's at the vertices of both. A peak of the lower layer 7 m over a
    flat upper layer is found at its vertex, exactly, with the kind of its
    triangle; where the upper layer is folded (a reverse fault's two
    sheets) its highest sheet is the one compared; a place the upper layer
    does not cover (a normal fault's gap) is not compared."""
    from faultmesh.report import layer_order

    upper = _square(lambda x, y: 0.0, "A")
    lower = _square(lambda x, y: 7.0 if (x, y) == (50.0, 50.0) else -10.0, "B",
                    kinds=np.full(4, 2, dtype=np.int8))
    rows = layer_order({"A": upper, "B": lower}, ["A", "B"])
    assert rows == [{"upper": "A", "lower": "B", "points": 5, "above": 1, "max_m": pytest.approx(7.0),
                     "at": [50.0, 50.0], "kind": "gap", "upper_kind": None}]
    # In order: nothing above; a layer without a surface is skipped over.
    flat = _square(lambda x, y: -10.0, "B")
    rows = layer_order({"A": upper, "B": flat, "C": None}, ["A", "C", "B"])
    assert rows == [{"upper": "A", "lower": "B", "points": 5, "above": 0, "max_m": 0.0, "at": None,
                     "kind": None, "upper_kind": None}]
    # The upper layer folded: a second sheet 20 m higher over the east half.
    fold = Surface("A", np.vstack([upper.vertices,
                                   [[50.0, 0.0, 20.0], [100.0, 0.0, 20.0], [100.0, 100.0, 20.0],
                                    [50.0, 100.0, 20.0]]]),
                   np.vstack([upper.triangles, [[5, 6, 7], [5, 7, 8]]]))
    rows = layer_order({"A": fold, "B": lower}, ["A", "B"])
    assert rows[0]["above"] == 0 and rows[0]["max_m"] == 0.0
    # The upper layer only over the west half (a gap east of x = 50): the
    # lower layer's east corners are not compared.
    west = Surface("A", np.array([[0.0, 0.0, 0.0], [50.0, 0.0, 0.0], [50.0, 100.0, 0.0], [0.0, 100.0, 0.0]]),
                   np.array([[0, 1, 2], [0, 2, 3]]))
    high_east = Surface("B", np.array([[0.0, 0.0, -10.0], [50.0, 0.0, -10.0], [50.0, 100.0, -10.0],
                                       [0.0, 100.0, -10.0], [100.0, 0.0, 30.0], [100.0, 100.0, 30.0]]),
                        np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]]))
    rows = layer_order({"A": west, "B": high_east}, ["A", "B"])
    assert rows[0]["above"] == 0 and rows[0]["points"] == 4
