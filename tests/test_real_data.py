"""Real data: Claudius (tests/data/claudius; MIT and EUPL-1.2 licences there)
through examples/claudius/make_dataset.py, end to end: the four horizons'
seismic picks and the 93 fault points written AS THEY ARE into a format-2
dataset (no boreholes, sections, cutoffs or kind), read back, and built;
the library derives the fault (faultmesh.derive).

What is checked: the dataset file holds only the data; the layer order and
the study area the library derives; the derived fault (dip, normal kind,
the one layer it cuts, a tip at one end and the study-area boundary at the
other); Model.check() and the stitched gaps; the built surface steps by the
derived throw across the fault; and the held-out checks of the example --
(a) 10 % of the picks withheld at random, (b) every pick within 300 m (3D)
of a fault point withheld -- against the hand-made interpretation the
example replaced (format v1, sections and cutoffs drawn by a script) and
issue 11's target. The other distances and the map-view distance of check
(b) are in examples/claudius/README.md (the full example takes ~30 s).
"""
from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

import faultmesh
from faultmesh import derive
from faultmesh.dataset import points_in_polygon

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "claudius"
EXAMPLE = ROOT / "examples" / "claudius" / "make_dataset.py"

# One pytest-xdist process runs this file (scripts/test.sh: --dist
# loadgroup): split between two, both built the dataset of `full` (6.2 s
# in a serial run; 15.7 and 14.4 s in the two processes on a loaded machine).
pytestmark = pytest.mark.xdist_group("claudius")


def _load_example():
    # A unique module name: the example's file name is generic.
    name = "faultmesh_example_claudius"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, EXAMPLE)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def md():
    return _load_example()


@pytest.fixture(scope="module")
def data(md):
    return md.read_horizons(DATA), md.read_fault_points(DATA)


@pytest.fixture(scope="module")
def full(md, data, tmp_path_factory):
    """The whole dataset written (v2), read back, derived and built."""
    h, fpts = data
    ds = md.make_dataset(h, fpts)
    js = ds.save(tmp_path_factory.mktemp("claudius") / "dataset", version=2)
    loaded = faultmesh.load_dataset(js)
    derived = derive.derive_faults(loaded)
    model = faultmesh.build_model(derived, fill_holes=True)
    return ds, js, loaded, derived, model


def test_layer_order_and_study_area(md, data):
    h, _ = data
    assert sorted(h) == ["val_0", "val_250", "val_330", "val_60"]
    assert sum(len(p) for p in h.values()) == 21023  # every row with a val
    # Z is elevation (negative below datum): the top layer has the largest Z.
    assert derive.layer_order(h) == ["val_0", "val_60", "val_250", "val_330"]
    ring = derive.study_area(h)
    lo, hi = ring.min(axis=0), ring.max(axis=0)
    for p in h.values():
        assert (p[:, :2].min(axis=0) <= lo + 1e-9).all() and (p[:, :2].max(axis=0) >= hi - 1e-9).all()


def test_dataset_file_holds_the_data_as_they_are(full, data):
    h, fpts = data
    ds, js, loaded, _, _ = full
    doc = json.loads(Path(js).read_text())
    assert doc["faultmesh_dataset"] == 2
    assert "boreholes" not in doc and not doc.get("sections")
    (f,) = doc["faults"]
    assert set(f) == {"name", "points"}  # no kind, traces, tips: derived
    assert doc["layers"] == ["val_0", "val_60", "val_250", "val_330"]
    (lf,) = loaded.faults
    assert lf.kind is None and lf.traces == [] and np.array_equal(lf.points, fpts)
    assert len(loaded.boreholes.z) == 0
    ring = np.asarray(loaded.boundary)
    for lay, p in h.items():
        inside = points_in_polygon(p[:, :2], ring)
        assert len(loaded.points[lay]) == int(inside.sum())


def test_picks_on_the_boundary_build(full, data):
    """Regression: with the study area the exact box the picks cover, picks
    lie ON its boundary; the layer repair failed there once ("boundary piece
    ... is not an edge of the TIN") when the picks near the fault were
    withheld, and the Claudius test used a box 40 m smaller instead. The
    example now uses the exact box (here and with picks withheld, below)."""
    h, _ = data
    ds, _, loaded, _, model = full
    ring = np.asarray(loaded.boundary)
    on = 0
    for p in loaded.points.values():
        on += int(np.sum(np.any(p[:, :2] == ring.min(axis=0), axis=1)
                         | np.any(p[:, :2] == ring.max(axis=0), axis=1)))
    assert on > 0
    model.check()


def test_derived_fault(full):
    _, _, _, derived, _ = full
    fr = derived.derivation.faults["claudius_fault"]
    s = fr.surface
    # A steep, west-dipping, roughly N-S striking fault, triangulated along
    # x (the axis nearest to its normal); its 93 points scatter by about
    # 5.7 m about a smooth surface (derive._point_scatter).
    assert 60.0 < s.dip < 78.0 and s.axis == 0
    assert 4.0 < s.scatter < 8.0, s.scatter
    assert 250.0 < float(np.degrees(np.arctan2(*s.dip_dir)) % 360.0) < 280.0
    assert fr.kind == "normal"
    # Only the deepest horizon is cut: the others pass above the fault's
    # upper tip (z -9695 m).
    assert set(fr.cutoffs) == {"val_330"}
    # North: the fault points stop inside the study area (a tip); south:
    # they pass the picks' edge (the boundary).
    assert fr.ends == ["tip", "boundary"] and len(derived.fault("claudius_fault").tips) == 1
    t = fr.throw["val_330"]["throw"][fr.throw["val_330"]["cut"]]
    assert (t >= 0).all() and t.max() > 80.0


def test_fading_throw_fit_of_the_other_sense_gives_way_to_the_own_surfaces(full):
    """Regression: with all picks, the fading-throw fit (derive._decay_sides,
    used on every section since DECAY_GAP 0) fitted the hanging wall's rise
    towards the fault (drag, or picks smeared across it) as a block offset
    of the other sense (T down to -53 m along the northern half); its
    cutoff throws on the three northern sections, -21, -12, -4 m, were set
    to zero and those sections dropped as beyond the tip (5 sections of 8).
    The own surfaces say +42, +90, +56 m there; a section whose fit says
    the other sense than the fault's (normal) goes back to its own surfaces
    where those say the fault's (derive._own_sense_back)."""
    _, _, _, derived, _ = full
    fr = derived.derivation.faults["claudius_fault"]
    p = fr.throw["val_330"]
    # 8 sections a spacing apart, the halfway sections worth keeping
    # (derive.REFINE_SHARE) and one a tenth of a spacing inside the end on
    # the boundary (derive.END_SECTION_INSET; the other end is a tip), where
    # a cutoff of val_330 lies at the edge of the study area: not cut with
    # the fault's TIN through its points as given, cut since the TIN
    # follows their smoothed positions (derive._smoothed_points).
    assert fr.ends == ["tip", "boundary"]
    assert 9 < len(p["u"]) < 16 and p["cut"][:-1].all()
    # Every section keeps a throw of the normal sense (at least min_throw, 3 m).
    assert (p["throw"] >= 3.0).all(), p["throw"]
    assert not [w for w in fr.warnings if "has the sign of a reverse fault" in w], fr.warnings
    assert len(fr.sections) == len(p["u"])


def test_model_check_and_stitched_gaps(full):
    ds, _, _, _, model = full
    model.check()
    assert list(model.surfaces) == ds.layers
    assert sorted({g.layer for g in model.gaps}) == ["val_330"]
    for g in model.gaps:
        assert len(g.triangles) == g.n_vertices + 2 * g.n_holes - 2 + 2 * g.n_interior > 0
    for lay in ("val_0", "val_60", "val_250"):
        assert model.surfaces[lay].metadata["n_gap_triangles"] == 0
    ends = model.metadata["faults"]["claudius_fault"]["layers"]["val_330"]["ends"]
    assert ends[0] == "tip"


def test_the_model_s_fit_to_the_picks(full):
    """The model passes within 3.3 m of each of its 21,018 picks. Where
    val_330 has picks and val_250 none within 978 m (a hole in its picks),
    val_250's surface, filled by minimum curvature, lay up to 75 m below
    val_330's picks, and the crossing repair lowered 19 of them that far
    (the build warned). val_250 is raised to them there now
    (build._raise_over_data): its surface there is an extrapolation, the
    picks are measurements."""
    _, _, _, _, model = full
    fit = model.metadata["data_fit"]
    assert sum(r["data"] for r in fit.values()) > 21000
    assert max(r["max_m"] for r in fit.values()) < 5.0, fit
    assert sum(r["off"] for r in fit.values()) < 50, fit
    assert model.metadata["tins"]["val_250"]["raised_over_data"] > 10
    assert "warnings" not in model.metadata


def test_step_across_the_fault(full):
    """On each derived section with a throw of more than 40 m, the built
    val_330 surface 2 m outside the two cutoffs steps by the derived throw
    (farther out each side's own slope adds to the step: D1, near the tip,
    41.8 m at 2 m, 63 m at 30 m)."""
    from faultmesh.report import evaluate_surface

    _, _, _, derived, model = full
    surf = model.surfaces["val_330"]
    checked = 0
    for tr in derived.fault("claudius_fault").traces:
        if "val_330" not in tr.layers:
            continue
        sides = tr.layers["val_330"]
        throw = float(sides["foot"][-1, 2] - sides["hanging"][0, 2])
        if throw < 40.0:
            continue
        sec = derived.sections[tr.section]
        sf = float(sec.to_s(sides["foot"][-1:, :2])[0])
        sh = float(sec.to_s(sides["hanging"][:1, :2])[0])
        xy = sec.to_xy([sf - 2.0, sh + 2.0])
        lo, hi, nh = evaluate_surface(surf, xy[:, 0], xy[:, 1])
        assert (nh > 0).all()
        step = float(0.5 * (lo[0] + hi[0]) - 0.5 * (lo[1] + hi[1]))
        # Over 2 m each side's slope (up to 0.4 here) changes the step by
        # under 2 m.
        assert step == pytest.approx(throw, abs=2.0), tr.section
        checked += 1
    assert checked >= 3


def test_random_holdout_no_worse_than_the_hand_made_dataset(md, data, full):
    """Check (a): the same withheld picks as the hand-made interpretation's
    test (seed 0, layers top down, 10 % of the picks farther than 500 m from
    every fault point and 40 m inside the boundary)."""
    h, fpts = data
    ring = np.asarray(full[0].boundary)
    used, held = md.random_holdout(h, fpts, ring)
    r = md.run_check(h, fpts, ring, used, held)
    assert r["kind"] == "normal" and r["cut"] == ["val_330"]
    # Measured 0.76, 0.67, 0.82, 2.90 m; the hand-made dataset's 0.77, 0.68,
    # 0.85, 2.90 m on the same picks (issue 11 rounds them to 0.8, 0.7, 0.8,
    # 3.0).
    hand_made = {"val_0": 0.77, "val_60": 0.68, "val_250": 0.85, "val_330": 2.90}
    for lay, m in r["misfit"].items():
        assert m["n"] > 400
        assert m["median"] <= hand_made[lay] + 0.005, (lay, m)
        # No worse than taking the nearest remaining pick's z.
        _, i = cKDTree(used[lay][:, :2]).query(held[lay][:, :2])
        nn = float(np.median(np.abs(used[lay][i, 2] - held[lay][:, 2])))
        assert m["median"] <= nn, (lay, m["median"], nn)


def test_picks_near_the_fault_withheld(md, data, full):
    """Check (b) at 300 m (3D distance to the nearest fault point): the
    derived kind and the deepest horizon's error at the withheld picks."""
    h, fpts = data
    ring = np.asarray(full[0].boundary)
    used, held = md.near_fault_holdout(h, ring, md.distance_3d(fpts), 300.0)
    assert len(held["val_330"]) > 200
    r = md.run_check(h, fpts, ring, used, held)
    # The hand-made interpretation labelled the fault reverse here (issue 11).
    assert r["kind"] == "normal"
    # Measured 10.92 m (10.61 m before the joint fit across the data gap
    # chose its smoothing length by cross-validation; 10.94 m before the
    # fault's picks were smoothed; 11.07 m when first measured, 11.36 m while the hole fill was fitted to the TIN's
    # boundary vertices in the fault's zone, test below; 12.0 m before the
    # layers' data holes were filled, faultmesh.holes; 16.4 m with each side
    # extrapolated on its own by local plane fits; the hand-made
    # interpretation 24.8 m; LoopStructural 1.9 11.1 m). Issue 11's target is
    # 11 m: met by 0.08 m. Of the 238 withheld picks, the 50 beyond the
    # fault's northern tip (where the layer is continuous, in a hole the fill
    # bridges) have a median error of 25 m (39 m with the TIN's linear
    # bridge), the others 9.3 m (examples/claudius/README.md).
    assert r["misfit"]["val_330"]["median"] <= 11.2, r["misfit"]


def test_the_partner_window_does_not_cut_a_layer_against_the_kind(md, data, full):
    """Regression: with every pick within 500 m (3D) of a fault point
    withheld, val_250 (above the fault's points: the fault dies out under
    it) had its footwall cutoffs in the fault's extent and its hanging-wall
    ones within the partner window (derive.DIP_PARTNER) above it on most
    sections, so it was cut, with throws of -10 to -26 m on a fault the
    other data say is normal; the sense rule then set them to zero, and the
    layer crossed the fault cut but not offset (median error at its
    withheld picks 4.38 m, 4.10 m uncut). The partner window admits a
    cutoff past the fault's points because the throw carries it there, so
    only a throw of the fault's sense counts: val_250 stays uncut, val_330
    (cut within the extent) decides the kind."""
    h, fpts = data
    ring = np.asarray(full[0].boundary)
    used, _ = md.near_fault_holdout(h, ring, md.distance_3d(fpts), 500.0)
    derived = derive.derive_faults(md.make_dataset(used, fpts, boundary=ring))
    rep = derived.derivation.faults[md.FAULT]
    assert rep.kind == "normal"
    assert sorted(rep.cutoffs) == ["val_330"], sorted(rep.cutoffs)
    assert not rep.throw["val_250"]["cut"].any()


def test_hole_fill_anchors_skip_the_fault_zone(full):
    """Regression (11.36 -> 11.07 m above): the hole fill's anchors, the
    layer TIN's study-area boundary vertices, are not taken where a fault
    patch replaces the layer (faultmesh.build._in_fault_zones): there the
    TIN's z bridges the fault's offset. The fault reaches the southern
    boundary and cuts val_330 only."""
    from faultmesh.build import _in_fault_zones, stratum_tins

    _, _, _, derived, _ = full
    area = faultmesh.StudyArea(np.asarray(derived.boundary, dtype=np.float64))
    tins, _ = stratum_tins(derived, area, repair=False)
    south = float(area.ring[:, 1].min())
    for lay in ("val_250", "val_330"):
        t = tins[lay]
        anchors = np.asarray(t.vertices)[np.asarray(t.boundary_vertices)]
        zone = _in_fault_zones(derived, lay, area, anchors)
        if lay == "val_250":
            assert not zone.any()  # not cut: no patch
            continue
        # Some, all on the southern boundary, and not all of that side.
        assert 0 < zone.sum() < (anchors[:, 1] == south).sum()
        assert np.all(anchors[zone, 1] == south)


def test_distance_2d_is_the_map_distance_to_the_contour():
    """The example's map-view distance: to the contour of the fault surface
    at the point's elevation; for a plane, |n . (p - c)| / |n_xy|; inf where
    the surface does not reach that elevation."""
    md = _load_example()
    rng = np.random.default_rng(3)
    # A plane dipping 60 degrees towards +x (a fine TIN of it).
    g = np.linspace(0.0, 1000.0, 11)
    X, Y = np.meshgrid(g, g)
    Z = -np.tan(np.radians(60.0)) * X
    V = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    T = np.asarray(faultmesh.delaunay(np.ascontiguousarray(V[:, :2])), dtype=np.int64).reshape(-1, 3)
    P = np.column_stack([rng.uniform(100, 900, 50), rng.uniform(100, 900, 50),
                         rng.uniform(-1500, -200, 50)])
    # The contour at z lies at x = -z / tan 60 (115..866 m: inside the TIN).
    want = np.abs(P[:, 0] + P[:, 2] / np.tan(np.radians(60.0)))
    got = md.distance_2d(V, T, chunk=7)(P)
    assert np.allclose(got, want, atol=1e-6)
    # Above the surface's top (z 0): no contour.
    assert np.isinf(md.distance_2d(V, T)(np.array([[500.0, 500.0, 100.0]])))[0]
