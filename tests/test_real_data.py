"""Real data: the Claudius seismic interpretation (tests/data/claudius; MIT,
EUPL-1.2 licences there) converted by examples/claudius/make_dataset.py into
a faultmesh dataset and built.

What is checked: the conversion's interpretation (layer order by elevation,
fault plane fit, normal sense of offset), the dataset round trip through
``Dataset.save``/``load_dataset``, ``Model.check()`` on the built model,
interpolation of HELD-OUT real picks away from the fault (median |dz| within
stated tolerances and no worse than the nearest-pick estimate), and that the
fault was stitched into exactly the layers it cuts with a vertical step of
the interpreted size across it.
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

import faultmesh
from faultmesh.dataset import apply_boundary_policy

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "claudius"
EXAMPLE = ROOT / "examples" / "claudius" / "make_dataset.py"

# Held-out accuracy tolerances (m), median |dz| per layer. Measured with
# seed 0: 0.77, 0.68, 0.85, 2.90 (nearest remaining pick: 2.37, 2.57, 4.15,
# 10.79); the deepest horizon (val_330) has the most
# relief (a 700 m high anticline west of the fault) and the sparsest picks.
MEDIAN_TOL = {"val_0": 1.5, "val_60": 1.5, "val_250": 1.5, "val_330": 4.5}
P90_TOL = {"val_0": 4.0, "val_60": 4.0, "val_250": 5.0, "val_330": 20.0}


def _load_example():
    # A unique module name: the example's file name is generic.
    name = "faultmesh_example_claudius"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, EXAMPLE)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod  # dataclasses look the module up while executing it
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def md():
    return _load_example()


@pytest.fixture(scope="module")
def built(md, tmp_path_factory):
    """Held-out conversion (10 % of the picks farther than 500 m from the
    fault withheld, seed 0), saved, reloaded and built."""
    conv = md.convert(DATA, holdout=0.1, seed=0)
    out = tmp_path_factory.mktemp("claudius")
    js = conv.dataset.save(out)
    ds = faultmesh.load_dataset(js)
    model = faultmesh.build_model(ds)
    return conv, ds, model


def test_layers_ordered_top_down_by_elevation(md):
    h = md.read_horizons(DATA)
    assert sorted(h) == [0.0, 60.0, 250.0, 330.0]
    order = md.order_layers(h)
    med = [float(np.median(h[v][:, 2])) for v in order]
    # Z is elevation (negative below datum): top layer has the largest Z.
    assert med == sorted(med, reverse=True)
    assert order == [0.0, 60.0, 250.0, 330.0]


def test_fault_plane_fit(md, built):
    conv, _, _ = built
    p = conv.plane
    assert len(conv.fault_points) == 93
    # A steep, west-dipping, roughly N-S striking plane; the points scatter
    # about it by ~20 m RMS (the surface is gently curved).
    assert 60.0 < p.dip < 78.0
    assert 250.0 < p.dip_direction < 280.0
    rms = float(np.sqrt(np.mean(p.residuals ** 2)))
    assert rms < 30.0
    # Every fault point is within 100 m of the plane.
    assert float(np.abs(p.residuals).max()) < 100.0


def test_interpretation(built):
    conv, ds, _ = built
    assert ds.layers == ["val_0", "val_60", "val_250", "val_330"]
    (fault,) = ds.faults
    # The hanging wall (west) is down: a normal fault.
    assert fault.kind == "normal"
    resolved = [v for s in conv.info["sections"] for v in s["layers"].values() if v["resolved"]]
    assert len(resolved) >= 2
    assert all(v["throw"] > 40.0 for v in resolved)
    # The fault's interpreted depth range (-10920..-9695 m) holds only the
    # deepest horizon; the three shallower ones pass above its upper tip.
    cut = {lay for tr in fault.traces for lay in tr.layers}
    assert cut == {"val_330"}
    # One end closes at a tip inside the study area, the other reaches the
    # study boundary (the fault points pass the southern edge of the picks).
    assert len(fault.tips) == 1
    closures = sorted(e["closure"] for e in conv.info["ends"].values())
    assert closures == ["extended to the study boundary", "tip"]
    # Every layer has picks near every side of the study area, except one
    # known hole: val_250 has no picks in a C-shaped area that opens onto the
    # east side (x > ~551,300 m, y ~7,818,000-7,821,000), so its surface is
    # extrapolated there; val_330 has smaller holes (up to ~340 m from a
    # pick) touching every side. Sides: south, east, north, west.
    ring = np.asarray(ds.boundary)
    sides = ["south", "east", "north", "west"]
    assert np.allclose(ring[1] - ring[0], [ring[1, 0] - ring[0, 0], 0.0])  # side 0 runs east
    t = np.linspace(0.0, 1.0, 41)[:, None]
    for lay in ds.layers:
        # Every pick of the conversion, those beyond the boundary too (the
        # loader drops them: docs/dataset.md "Tolerance policy").
        tree = cKDTree(conv.dataset.layer_points(lay)[:, :2])
        for side, a, b in zip(sides, ring, np.roll(ring, -1, axis=0)):
            d, _ = tree.query(a + t * (b - a))
            if (lay, side) == ("val_250", "east"):
                assert np.mean(d < 150.0) < 0.6 and d.max() > 500.0
            else:
                assert np.mean(d < 150.0) > 0.75 and d.max() < 400.0, (lay, side)


def test_model_check_and_stitched_gaps(built):
    conv, ds, model = built
    model.check()
    assert list(model.surfaces) == ds.layers
    gap_layers = sorted({g.layer for g in model.gaps})
    assert gap_layers == ["val_330"]
    for g in model.gaps:
        assert len(g.triangles) == g.n_vertices + 2 * g.n_holes - 2 > 0
    assert model.surfaces["val_330"].metadata["n_gap_triangles"] > 0
    assert model.surfaces["val_330"].metadata["n_patch_triangles"] > 0
    for lay in ("val_0", "val_60", "val_250"):
        assert model.surfaces[lay].metadata["n_gap_triangles"] == 0
    ends = model.metadata["faults"]["claudius_fault"]["layers"]["val_330"]["ends"]
    assert sorted(ends) == ["extended", "tip"]
    assert "claudius_fault" in model.faults


def test_step_across_the_fault(md, built):
    """On each section with a resolved offset, the built val_330 surface just
    outside the two cutoffs differs by about the interpreted throw."""
    conv, ds, model = built
    from faultmesh.report import evaluate_surface

    surf = model.surfaces["val_330"]
    checked = 0
    for s in conv.info["sections"]:
        v = s["layers"].get("val_330")
        if v is None or not v["resolved"]:
            continue
        sec = ds.sections[s["name"]]
        tr = next(t for t in ds.faults[0].traces if t.section == s["name"])
        foot, hang = tr.layers["val_330"]["foot"], tr.layers["val_330"]["hanging"]
        sf = float(sec.to_s(foot[-1:, :2])[0])
        sh = float(sec.to_s(hang[:1, :2])[0])
        xy = sec.to_xy([sf - 30.0, sh + 30.0])
        lo, hi, nh = evaluate_surface(surf, xy[:, 0], xy[:, 1])
        assert (nh > 0).all()
        # The trace lies on the section line, so these points sit on patch
        # edges (two hits); the surface is continuous there (lo == hi).
        z = 0.5 * (lo + hi)
        step = float(z[0] - z[1])
        assert step == pytest.approx(v["throw"], abs=0.35 * v["throw"]), s["name"]
        checked += 1
    assert checked >= 2


def test_held_out_picks(md, built):
    conv, ds, model = built
    mis = md.surface_misfit(model, conv.held_out)
    assert set(mis) == set(ds.layers)
    for lay, m in mis.items():
        n_held = len(conv.held_out[lay])
        assert n_held > 300
        assert m["n"] == n_held  # every held-out pick lies inside the model
        assert m["median"] < MEDIAN_TOL[lay], (lay, m)
        assert m["p90"] < P90_TOL[lay], (lay, m)
        # No worse than taking the nearest remaining pick's z.
        pts = ds.layer_points(lay)
        _, i = cKDTree(pts[:, :2]).query(conv.held_out[lay][:, :2])
        nn = float(np.median(np.abs(pts[i, 2] - conv.held_out[lay][:, 2])))
        assert m["median"] <= nn, (lay, m["median"], nn)


def test_full_conversion_round_trip(md, tmp_path):
    """Without hold-out the dataset holds every pick and survives save/load
    as the input policy leaves it (the loader drops the picks beyond the
    shrunk study area, which the builder never used)."""
    conv = md.convert(DATA)
    js = conv.dataset.save(tmp_path / "claudius.json")
    back = faultmesh.load_dataset(js)
    assert back.allclose(apply_boundary_policy(conv.dataset), atol=1e-6)
    for lay in conv.dataset.layers:
        assert len(conv.dataset.points[lay]) == len(conv.horizons[lay])
