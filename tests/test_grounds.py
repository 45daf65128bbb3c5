"""Random grounds (faultmesh.grounds): the generator's own properties, its
measures, a fixed set of seeds covering every kind of ground, and the four
datasets of the robustness issue (tests/data/repro/)."""
from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import faultmesh as fm
from faultmesh import grounds as gr
from faultmesh.dataset import points_in_polygon

DATA = Path(__file__).resolve().parent / "data" / "repro"


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """Grounds written once per module: seed -> (spec, geology, json path)."""
    cache = {}

    def get(seed, **ov):
        key = (seed, tuple(sorted(ov.items())))
        if key not in cache:
            d = tmp_path_factory.mktemp(f"ground{seed}")
            cache[key] = gr.make_ground(seed, d, **ov)
        return cache[key]

    return get


def load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the generator writes no unknown keys
        return fm.load_dataset(path)


# ---------------------------------------------------------------------------
# the generator
# ---------------------------------------------------------------------------
def test_plan_draws_every_kind():
    """Over 300 seeds, every value of every category is drawn (the plan is
    what the seed fixes first; the geometry is drawn after it)."""
    seen = {k: set() for k in gr.KINDS}
    for seed in range(300):
        p = gr.draw_plan(np.random.default_rng(seed))
        seen["coords"].add(p["coords"])
        seen["area"].add(p["area"])
        seen["n_faults"].add(str(p["n_faults"]))
        seen["pair"].add(p["pair"])
        seen["sections"].add(p["sections"])
        seen["trace_format"].add(p["trace_format"])
        for k, d, e, b in zip(p["kinds"], p["dips"], p["extents"], p["boundary_ends"]):
            seen["fault"].add(k)
            if k == "reverse" and d <= 45.0:
                seen["fault"].add("gentle_reverse")
            seen["extent"].add(e)
            seen["boundary_end"].add(b)
        assert 1500.0 <= p["size"] <= 6000.0
        assert all(30.0 <= d <= 85.0 for d in p["dips"])
    for k, values in gr.KINDS.items():
        assert seen[k] == set(values), k


def test_overrides_are_checked():
    with pytest.raises(ValueError, match="unknown override"):
        gr.draw_plan(np.random.default_rng(0), colour="red")
    with pytest.raises(ValueError, match="pair 'T' needs n_faults >= 2"):
        gr.draw_plan(np.random.default_rng(0), n_faults=1, pair="T")
    with pytest.raises(ValueError, match="dips must be in"):
        gr.draw_plan(np.random.default_rng(0), n_faults=1, dips=[20.0])
    p = gr.draw_plan(np.random.default_rng(0), area="U", coords="utm", n_faults=2, pair="X")
    assert (p["area"], p["coords"], p["n_faults"], p["pair"]) == ("U", "utm", 2, "X")


def test_deterministic_per_seed(tmp_path):
    a = gr.make_ground(11, tmp_path / "a")
    b = gr.make_ground(11, tmp_path / "b")
    for name in ("dataset.json", "boreholes.csv", "spec.json"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    assert a[0] == b[0]
    c = gr.make_ground(12, tmp_path / "c")
    assert (tmp_path / "c" / "dataset.json").read_bytes() != (tmp_path / "a" / "dataset.json").read_bytes()
    assert c[0].seed == 12


@pytest.mark.parametrize("seed", [1, 3])
def test_round_trip_through_save_and_load(made, tmp_path, seed):
    spec, geo, path = made(seed)
    ds = load(path)
    assert ds.name == f"ground-{seed}" and ds.layers == spec.layers
    assert [f.name for f in ds.faults] == [f["name"] for f in spec.faults]
    back = load(ds.save(tmp_path / "again"))
    assert back == ds
    assert gr.GroundSpec.from_dict(json.loads((path.parent / "spec.json").read_text())) == spec


def _tolerances(spec):
    """Rounding of what was written: (z of boreholes, trace xy / z)."""
    r = spec.rounding
    return 0.5 * 10.0 ** -r["z"], 0.5 * 10.0 ** -r["traces"]


# Seeds whose grounds have reverse faults with boreholes in their bands,
# normal faults, an sz trace format, UTM and local coordinates, T and X
# pairs (checked below that they do).
TRUTH_SEEDS = [1, 3, 5, 8]


@pytest.mark.parametrize("seed", TRUTH_SEEDS)
def test_truth_is_what_the_data_say(made, seed):
    spec, geo, path = made(seed)
    ds = load(path)
    zt, tt = _tolerances(spec)
    b = ds.boreholes
    # Every borehole top is a sheet of the truth at the (written) collar, and
    # every hole lists every sheet of every layer down to where it stops.
    for lay in ds.layers:
        sel = b.layer == lay
        S = geo.sheets(lay, b.xy[sel, 0], b.xy[sel, 1])
        assert np.all(np.nanmin(np.abs(S - b.z[sel][:, None]), axis=1) <= zt * (1 + 1e-9)), lay
    holes, first, hi = np.unique(b.hole_id, return_index=True, return_inverse=True)
    li = np.array([ds.layers.index(l) for l in b.layer])
    deepest = np.full(len(holes), -1)
    np.maximum.at(deepest, hi, li)
    for k, lay in enumerate(ds.layers):
        n_truth = geo.n_sheets(lay, b.xy[first, 0], b.xy[first, 1])
        n_rows = np.bincount(hi[li == k], minlength=len(holes))
        reach = deepest >= k
        np.testing.assert_array_equal(n_rows[reach], n_truth[reach], err_msg=lay)
    for k in range(len(holes)):
        assert np.all(np.diff(b.z[hi == k]) <= 0), holes[k]  # top down
    # Traces: cutoffs on the truth's fault surface, polylines on the truth's
    # sides, plane points on the surface, all up to the written rounding
    # (a horizontal rounding of tt moves a point up to tan(dip) * tt * sqrt 2
    # across a surface; layers dip far less than the faults).
    for f in ds.faults:
        fmod = geo.fault(f.name)
        tol = tt * (1.0 + math.sqrt(2.0) * fmod.tan_dip) + 1e-9
        assert f.kind == fmod.kind and f.group == fmod.group
        for t in f.traces:
            pz = geo.plane_z(f.name, t.plane[:, 0], t.plane[:, 1])
            assert np.all(np.abs(pz - t.plane[:, 2]) <= tol), (f.name, t.section)
            for lay, sides in t.layers.items():
                for side, arr in sides.items():
                    cut = arr[-1] if side == "foot" else arr[0]
                    assert abs(geo.plane_z(f.name, cut[0], cut[1]) - cut[2]) <= tol
                    rest = arr[:-1] if side == "foot" else arr[1:]
                    zs = geo.side_value(lay, f.name, side, rest[:, 0], rest[:, 1])
                    assert np.all(np.abs(zs - rest[:, 2]) <= tt * 3.0 + 1e-9), (f.name, lay, side)
                throw = sides["hanging"][0, 2] - sides["foot"][-1, 2]
                assert (throw > 0) if f.kind == "reverse" else (throw < 0)
            assert np.all(points_in_polygon(t.plane[:, :2], ds.boundary)) or \
                any(e == "on_boundary" for e in spec.faults[[g["name"] for g in spec.faults].index(f.name)]["ends"])
        # Tips: where the cutoff of the fault's top displaced layer meets the
        # fault at the end of the taper.
        top = next(l for l in geo.layers if fmod.layers.get(l, 0) > 0)
        for q in f.tips:
            d = geo.unfaulted(top, q[0], q[1]) - geo.plane_z(f.name, q[0], q[1])
            assert abs(d) <= tol, (f.name, q)


def test_truth_seeds_cover_what_they_should(made):
    tags = {}
    for s in TRUTH_SEEDS:
        spec, geo, path = made(s)
        for k, v in spec.tags().items():
            tags.setdefault(k, set()).update(v)
        ds = load(path)
        if spec.n_band_holes:
            b = ds.boreholes
            ids, layers = b.hole_id, b.layer
            assert any(np.sum((ids == h) & (layers == l)) == 2 for h in np.unique(ids) for l in ds.layers)
    assert {"normal", "reverse", "gentle_reverse"} <= tags["fault"]
    assert {"local", "utm"} <= tags["coords"]
    assert {"T", "X"} <= tags["pair"]
    assert "sz" in tags["trace_format"]


def test_too_close_pairs_really_overlap(made):
    spec, geo, path = made(2, n_faults=2, pair="too_close")
    assert spec.expect == "reject" and spec.pair["relation"] == "too_close"
    a, b = spec.pair["faults"]
    assert geo.fault(a).group is None and geo.fault(b).group is None
    lo, hi = geo.origin - 2000.0, geo.origin + 8000.0
    X, Y = np.meshgrid(np.linspace(lo[0], hi[0], 200), np.linspace(lo[1], hi[1], 200))
    with pytest.raises(ValueError, match=f"'{a}' and '{b}' overlap"):
        geo.check_disjoint(X, Y)


def test_T_and_X_pairs_are_groups(made):
    spec, geo, _ = made(4, n_faults=2, pair="T")
    a, b = spec.pair["faults"]
    assert geo.fault(b).abuts[0] == a and geo.fault(a).group == geo.fault(b).group is not None
    spec, geo, _ = made(4, n_faults=2, pair="X")
    a, b = spec.pair["faults"]
    assert geo.fault(b).abuts is None and geo.fault(a).group == geo.fault(b).group is not None


# ---------------------------------------------------------------------------
# measures
# ---------------------------------------------------------------------------
def test_folded_counts_points_under_clockwise_triangles():
    # A strip folding back: footwall (ccw), strip (cw), hanging wall (ccw).
    V = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0],      # footwall to x = 10
                  [6, 0, -5], [6, 10, -5],                              # hanging-wall cutoff at x = 6
                  [16, 0, -5], [16, 10, -5]], dtype=np.float64)
    T = np.array([[0, 1, 2], [0, 2, 3],            # footwall
                  [1, 4, 5], [1, 5, 2],            # strip from x = 10 back to x = 6 (clockwise)
                  [4, 6, 7], [4, 7, 5]])           # hanging wall
    xy = np.array([[8.0, 5.0], [3.0, 5.0], [12.0, 5.0], [6.0, 5.0], [10.0, 5.0]])
    np.testing.assert_array_equal(gr._folded(V, T, xy), [True, False, False, True, True])


def test_repetition_coverage_sees_a_fold_and_its_absence():
    """A steep reverse fault with dense sections: the model folds over the
    band the data give; the continuous TIN (no fault) never does."""
    ds = fm.datasets.synthetic(7, kind="reverse", n_faults=1, throw=40.0, dip=60.0,
                               area=(3000.0, 2500.0), n_sections=9)
    model = fm.build_model(ds)
    cov = gr.repetition_coverage(model, ds.geology, dataset=ds)
    for lay, v in cov["F1"].items():
        assert v["points"] > 100 and v["points_data"] > 50
        assert 0.0 <= v["share"] <= 1.0
    plain = fm.Model(name="plain", surfaces={lay: fm.Surface(lay, *fm.build.LayerTin(
        lay, ds.layer_points(lay), ds.boundary).mesh(), kind="layer") for lay in ds.layers},
        faults={}, boundary=ds.boundary)
    cov0 = gr.repetition_coverage(plain, ds.geology, dataset=ds)
    assert all(v["covered"] == 0 and v["share"] == 0.0 for v in cov0["F1"].values())
    best = max(v["share_data"] for v in cov["F1"].values())
    assert best > 0.5


def test_normalise_message():
    m = ("/tmp/x/dataset.json: fault 'F3': trace 12 plane point 4 (3663525.160, -5.2e-10) lies "
         "outside the study-area boundary (19 point(s) outside)")
    assert gr.normalise_message(m) == ("PATH: fault 'S': trace N plane point N (N, N) lies outside "
                                       "the study-area boundary (N point(s) outside)")


# ---------------------------------------------------------------------------
# fixed seeds through the whole pipeline
# ---------------------------------------------------------------------------
_OUTCOMES = {}


def outcome(seed, tmp_path_factory):
    """evaluate_ground(seed), once per test session."""
    if seed not in _OUTCOMES:
        _OUTCOMES[seed] = gr.evaluate_ground(seed, tmp_path_factory.mktemp(f"run{seed}"))
    return _OUTCOMES[seed]


def assert_holds(out):
    """Built, check() passed, better than the plain TIN near the faults, and
    every reverse fault repeats its layers over at least
    COVERAGE_THRESHOLD (95 %) of the band the data give; or, for a too-close
    pair, rejected with a DatasetError naming both faults (or built and
    holding as above: the overlap missed the patches the data give)."""
    what = f"{out['describe']}: {out['stage']} {out.get('error_type') or ''} {(out.get('error') or '')[:300]}"
    if (out.get("spec") or {}).get("expect") == "reject" and out["rejected_ok"]:
        return
    assert out["built"], what
    assert out["checked"], what
    assert out["accuracy"]["beats"], what
    if out["coverage_min"] is not None:
        assert out["coverage_min"] >= gr.COVERAGE_THRESHOLD, what
    assert out["ok"], what


# One seed per kind of ground that holds (bench/sweep.py, docs/bench/sweep.md):
# UTM, a reverse fault across the area with ends on the boundary (0); a
# polygon with a gentle reverse fault inside (1); a T-crossing pair whose
# branch abuts (3); big coordinate offsets, an L-shaped area (4); a too-close
# pair that must be rejected (14); a rectangle (17); a U (37); an X-crossing
# pair (56); and the layers at 3.8e7 m that failed the 'area' check until its
# shoelace sum was taken relative to a local origin (13, 98, 108).
HOLDING_SEEDS = [0, 1, 3, 4, 14, 17, 37, 56, 13, 98, 108]


@pytest.mark.parametrize("seed", HOLDING_SEEDS)
def test_ground_holds(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# Seeds of the 500-seed sweep that failed with "patch vertex N lies outside
# the study area": a reverse fault's polyline carried past its repetition
# band (faults._reach_past_the_band) left the study area next to its
# boundary (seed 10: 1.6 m beyond it). Stopped on the boundary, the end
# trace of seed 179 could be extended onto it next to a corner, and its
# folded sheets crossed the corner (faults._around_corners). 74 and 314 have a
# crossing pair.
PATCH_INSIDE_SEEDS = [10, 179, 224, 279, 312, 393, 425, 74, 314]


@pytest.mark.parametrize("seed", PATCH_INSIDE_SEEDS)
def test_reverse_fault_near_the_boundary_builds(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# Seed 468 failed in the layer-crossing repair: crossing points on a
# boundary piece a few ulps from its vertices made boundary vertices that
# were no longer TIN edges (LayerTin::insert now merges them).
@pytest.mark.parametrize("seed", [468])
def test_repair_points_on_the_boundary_build(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# Grounds whose gap polygon crossed itself where a fault patch ends on the
# study-area boundary near a corner ("ear clipping the gap polygon ... gave
# 62 triangles instead of 63"): the patch touched a side at a vertex (a
# chord across a convex corner; the stitcher now splits the boundary piece
# there and keeps the pinched rings apart) or cut across a reflex corner
# outside the area (the extension now follows the boundary round it). The
# same chords made a folded patch's outline cross itself ("the patch outline
# is not simple in XY": 57, 60) and a gap hole fall outside its ring ("a hole
# of the gap ... lies in no outer ring": 234, 330).
@pytest.mark.parametrize("seed", [112, 145, 150, 183, 242, 271, 363, 397, 455, 57, 60, 234, 330])
def test_patch_ending_at_a_boundary_corner_holds(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# Grounds whose reverse-fault section ends at the study-area boundary inside
# the repetition band: the polyline carried a band width on ("reach past the
# band") left the study area ("patch vertex ... lies outside the study
# area"); it now stops on the boundary. 117 (sweep class "not simple") and
# 377 (class "ear clipping") failed so once their first error was fixed
# (the others of this kind are in PATCH_INSIDE_SEEDS).
@pytest.mark.parametrize("seed", [117, 377])
def test_band_reaching_the_boundary_holds(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# Crossing pairs with a reverse fault whose repetition was clipped away
# (sweep class "repetition", e.g. seed 42: X-crossing of a normal and a
# reverse fault, 0 % of the band left): group_patch now clips flat patches by
# folded ones rather than the other way round (13 of the 162 T/X seeds of the
# sweep gained, none lost).
@pytest.mark.parametrize("seed", [42, 61, 88, 162])
def test_crossing_pair_keeps_the_reverse_fault_whole(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# A fault crossing a notch of a concave study area between two of its traces:
# the loft between the traces ran out of the area and back in ("the patch
# leaves the study area": 418, a polygon; 454, an L). layer_patch now clips
# the patch to the study area exactly (StudyArea.clip_surface).
@pytest.mark.parametrize("seed", [418, 454])
def test_patch_across_a_notch_of_the_study_area_holds(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# T-crossings where a reverse fault abuts its partner (sweep class "stitching":
# "new triangles: edge ... is used by 4 triangles", 133 177 218; "used twice
# in the same direction", 305; "a hole of the gap lies in no outer ring", 36;
# "the patch outline is not simple", 158): the fold carried onto the
# partner's outline and clipped there by whole triangles ended its sheets at
# different places, reaching past each other and out of the outline, where
# the gap covered them again. layer_patch now closes such a fold by a
# pinch-out halfway to the partner.
@pytest.mark.parametrize("seed", [133, 177, 218, 305, 36, 158])
def test_reverse_fault_abutting_a_partner_holds(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# The same class where the folded sheets are clipped by the partner within
# the traces' band (24: two disjoint folded pieces, yet a gap edge used 4
# times; 147, 395): clip_patch now also removes the triangles where the
# patch does not cover its XY image once (triangles_not_covered_once).
# They build, pass check() and beat the TIN. 395 holds; 24 and 147 lost
# their repetition to that clip (the next test).
@pytest.mark.parametrize("seed", [24, 147, 395])
def test_folded_pieces_clipped_by_a_partner_stitch(seed, tmp_path_factory):
    out = outcome(seed, tmp_path_factory)
    what = f"{out['describe']}: {out['stage']} {(out.get('error') or '')[:300]}"
    assert out["built"] and out["checked"], what
    assert out["accuracy"]["beats"], what


# Sweep class "repetition" (31 of 500 seeds, always F2 of a T or X pair of
# reverse faults): the later member's fold, clipped by the earlier one's
# outline by whole triangles, lost its repetition far from the partner to
# the outline clean-up (F2's share of the band the data give, worst layer:
# 24 T 39 %, 147 T 0 %, 238 T 0 %, 9 X 1.5 %, 321 X 0.1 %). The later
# folded patch is now made clear of the partner where it is lofted
# (faults._clear_of: the touching lofts left out, each side closed by its
# band carried on and a pinch-out; a trace beyond the partner kept, 321)
# and the earlier one yields its sheets where the later band lies
# (faults._yield_to): 24 100 %, 147 99 %, 238 100 %, 9 99 %, 321 99 %
# (24 of the 31 seeds hold; the 7 left are X pairs whose bands cross).
@pytest.mark.parametrize("seed", [24, 147, 238, 9, 321])
def test_crossing_pair_keeps_the_later_fold(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# Of those 7, X pairs of reverse faults whose bands cross: the earlier
# member (F1) yielded its sheets over F2's band only down to band cores
# reaching a quarter of F1's band width past it, and F2's fold, kept clear
# of that outline, was lost over the margin (F2's share of the band the data
# give, worst layer: 8 92.4 %, 451 92.7 %). The cores an earlier patch
# yields to now reach a tenth of the width past the band
# (faults._YIELD_MARGIN): 8 95.0 %, 451 95.3 %.
@pytest.mark.parametrize("seed", [8, 451])
def test_x_crossing_keeps_the_later_fold_up_to_the_partner_band(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# 236, an X pair whose F2 band widens towards the crossing: the closures
# that carry F2's band along its cutoff lines had the larger fold, but one
# of them did not cover its image once, so every such variant of F2's runs
# failed and the band merely moved was taken, leaving a strip along one side
# unrepeated (92.0 %). A closure is now the largest fold among those that
# cover their image once (faults._closing): 97.2 %. 76 and 244 likewise
# (F2 L5 90.6 %, F2 L3 77.0 %): no closure along the cutoff lines covered
# its image once, as the sheets moved with their own cutoff only and the
# footwall sheet no longer reached past the widened band. The core is now
# carried by the similarity that takes its cutoff segment along the lines
# (sheets and strip in proportion): 98.9 %, 97.5 %.
@pytest.mark.parametrize("seed", [236, 76, 244])
def test_x_crossing_closure_follows_a_widening_band(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# 246, an X pair whose narrow F1 band crosses F2's wide band obliquely at
# an F2 trace: F2's runs on both sides, carried the same share of the way
# along both cutoff lines, stopped where the first line met F1 and left
# wedges of F2's band short of F1 (F2 L4 88.2 %). Each cutoff is now also
# carried as far along its own line as that is clear of F1, past the trace
# at the crossing where the other line meets F1 before it
# (faults._closing, _LINE_REACH): 98.6 %, every layer >= 95.9 %.
@pytest.mark.parametrize("seed", [246])
def test_x_crossing_closure_runs_along_an_oblique_partner(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# 350, an X pair where F1 ends by a pinch-out tip inside F2's band: the tip,
# moved back only until its fan was clear of F2's band itself, left a
# sliver of F1's fan over F2's sheets past the band, and F2's fold, kept
# clear of F1, was closed short of F1's band (F2 L4 and L5 85.4 %). The tip
# is now first kept clear of the band widened by half its width on each
# side (faults._yield_to, _FAN_CLEARANCE): 97.6 %, 97.8 %.
@pytest.mark.parametrize("seed", [350])
def test_x_crossing_earlier_tip_clear_of_the_later_sheets(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# 750 (found beyond the 500-seed sweep, seeds 500-999), an X pair whose F2
# runs from the boundary 720 m to its next trace, past F1's band: F2's run
# was closed towards that trace by its band carried a share of the way,
# bisected up to 0.98 of it (0.97 after 3 halvings) -- a fixed share of
# the way, so 22 m of a band 15 m wide were left unrepeated in front of F1
# (F2 L5 93.2 %, L4 95.6 %, L3 95.9 %). The bisection now goes on until
# the stretch left undecided is within a quarter of the band's width
# (faults._CLOSE_TO): L5 96.3 %, L4 99.4 %, L3 100 %; near-fault error
# 7.677 -> 7.691 m (TIN 9.173).
@pytest.mark.parametrize("seed", [750])
def test_x_crossing_closure_carried_up_to_the_partner(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# 189, 311 and 272, X pairs whose later fault F2 has a tip past the
# crossing: its fan runs across F1. Filled like a loft (the TIN's departure
# from the fan's straight line above F2's throw), the fan's piece left
# beyond F1 by the group clip started at a polyline that took the TIN's
# interpolation across F1 (189: 10-13 m above the layer; F1's throw 37 m,
# F2's 10 m), and the gap around that piece lost the layer data. A fan
# within a data spacing of a partner is now filled only where the departure
# also exceeds the partner's throw (faults._fans_near_partners). Near-fault
# mean |dz| with the fan filled -> now: 189 1.951 -> 1.752 m, 311 2.046 ->
# 1.810, 272 3.973 -> 3.491; the bounds lie halfway between.
@pytest.mark.parametrize("seed,bound", [(189, 1.85), (311, 1.93), (272, 3.73)])
def test_x_crossing_fan_past_the_partner_keeps_its_accuracy(seed, bound, tmp_path_factory):
    out = outcome(seed, tmp_path_factory)
    assert_holds(out)
    assert out["accuracy"]["mean_abs_stitched"] < bound, out["accuracy"]


# 401, F1's end trace on the study-area boundary and the next trace 674 m
# away: the layer sags 5.5-5.9 m between them. The first look at the points
# midway between the pair's ends and cutoffs (departure at most 5.5 m there,
# throw 7.38 m) rejected the pair that the full test fills (8.08 m inside
# the hanging wall); it passed before the boundary change of LayerTin::
# interpolate only because a sliver triangle beyond the hull gave the
# boundary trace's points values 1-10 m off the boundary pieces. The first
# look now tests the full test's points (faults._first_look). Near-fault
# mean |dz|: 0.859 m (old extension), 1.048 (main), 0.612 now; the bound
# lies halfway between the last two.
@pytest.mark.parametrize("seed,bound", [(401, 0.83)])
def test_boundary_end_trace_follows_the_layer_sag(seed, bound, tmp_path_factory):
    out = outcome(seed, tmp_path_factory)
    assert_holds(out)
    assert out["accuracy"]["mean_abs_stitched"] < bound, out["accuracy"]


# 803 and 1130 (found beyond the 500-seed sweep, seeds 500-999 and
# 1000-1199): X pairs where F1 crosses F2's band obliquely between two of
# F2's traces, so that F2's two cutoff lines meet F1's outline at different
# shares of the way, and a wedge of F2's band lies between that outline and
# the line that runs on clear. 1130 (6 layers, F2 L2 92.4 %, L3 93.5 % of
# the band the data give): F1's outline has a convex corner inside F2's
# band 7 m in front of F2's trace 4; every straight closure from trace 4
# into the wedge (about 1400 m2 in L2) touched that corner -- the band
# carried on keeps its sheet a quarter of its width past the cutoff, the
# tip's fan reaches over the corner -- and only a bare fan 10 m deep was
# left. 803 (an L-shaped area, F2 L1 94.1 %, L2 92.1 %): F1 touches the
# core of the F2 trace next to it, that trace is dropped, and the wedge lies
# beyond it, where no closure towards that trace went. A closure now also
# bends round the partner (faults._closing, "bend"): the band carried along
# the cutoff line that runs on clear, narrowed on the other side to what
# stays clear of the partner's outline (_BEND_CLEAR), with polylines put in
# round its corners, and on through the traces beyond the next one up to
# the next run (``further``); where a bend goes past the next trace, the
# ways past it come first. 1130: L2 95.2 %, L3 95.1 %, near-fault error
# 5.779 -> 5.772 m (TIN 10.09); 803: L1 98.2 %, L2 95.6 %, 1.650 -> 1.630 m
# (TIN 3.75). The bounds are the errors before.
@pytest.mark.parametrize("seed,bound", [(803, 1.650), (1130, 5.779)])
def test_x_crossing_fold_bends_round_the_partner(seed, bound, tmp_path_factory):
    out = outcome(seed, tmp_path_factory)
    assert_holds(out)
    assert out["accuracy"]["mean_abs_stitched"] < bound, out["accuracy"]


# 677 (found beyond the 500-seed sweep by the v2 runs of seeds 500-799, whose
# v1 reference it is): a U-shaped area whose notch's tip (a reflex corner)
# lies inside F2's repetition band, the notch entering the band across one
# cutoff line only (the band passes the corner on its other side 5-8 m
# wide, in the truth as in the model). There the strip and the hanging wall
# both run round the tip and meet again beyond it: the layer in the study
# area is an annulus, its second boundary loop along the notch's sides, out
# on one sheet and back on the other. check() asked for one loop and failed
# L2 ("topological disk", 2 loops; the model was right). A second loop is
# now allowed where it lies on the study-area polygon and encloses no area
# (invariants._loops_off_the_area); the X pair's F1/F2 pieces were never
# the cause (0.2 m apart, disjoint).
@pytest.mark.parametrize("seed", [677])
def test_band_round_a_reflex_corner_holds(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# A dataset tip moved by a deeper layer's cutoff offset landed beside a
# gently dipping reverse fault's end trace, on its inner side: the fan's edges
# crossed the next loft's ("the patch outline is not simple", 48). The tip
# is now put beyond the end trace (faults._layer_tip).
@pytest.mark.parametrize("seed", [48])
def test_layer_tip_beyond_the_end_trace_holds(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# Grounds that stopped in the fault models once the cover clean-up was in:
# a layer patch wholly clipped away by the study area has no outline (368:
# "boundary_contours: n_vertices must be a positive integer"); a clean-up
# needing more than 50 rounds (494: "could not clean up the clipped
# patch"). They build and pass check(); their repetition is the separate
# "repetition" class.
@pytest.mark.parametrize("seed", [368, 494])
def test_fault_models_of_clipped_groups_build(seed, tmp_path_factory):
    out = outcome(seed, tmp_path_factory)
    what = f"{out['describe']}: {out['stage']} {(out.get('error') or '')[:300]}"
    assert out["built"] and out["checked"], what


# Grounds that built and passed check() but were not better than the plain
# TIN near the faults (sweep class "accuracy"). 338: a T-crossing whose F1
# trace at the north end reaches only the deeper layer; the end direction
# from the traces' centres ran 13 degrees off strike and L1's patch, carried
# 805 m along it onto the boundary, put the fault ~185 m beside the truth's
# (near-fault mean |dz| 1.79 m vs the TIN's 1.77 m; fault_ends now compares
# the traces at equal elevations). 381: a layer rising 80 m between two F1
# traces 2.5 km apart, which the plain loft cut through (10.65 m vs 9.47 m;
# the patch now follows the layer TIN between the traces). 381's F2 fold is
# clipped away by F1 in L2 (the separate "repetition" class of crossing
# pairs), so only build, check() and accuracy are held to here.
@pytest.mark.parametrize("seed", [338])
def test_fault_extended_along_its_strike_beats_the_tin(seed, tmp_path_factory):
    assert_holds(outcome(seed, tmp_path_factory))


# 986 and 617 (found beyond the 500-seed sweep). A tip's fan cut straight
# through the layer (986: F1's L3 fan 600 m long, the layer 50 m below it
# halfway); the fan now follows the layer TIN (8.53 -> 7.87 m, 617 3.11 ->
# 2.89 m). Then the gap lost: the layer data within a data spacing of the
# patch were removed with the triangles touching it and the gap was filled
# linearly from the patch outline to the ring left (986: 7.37 vs the TIN's
# 6.59 m over 46 % of the near-fault samples). The stitcher now puts every
# removed layer vertex inside the gap back into its triangulation
# (gap_points.hpp, stitch_clip.cpp): 986 7.36 m vs the TIN's 7.69 (ratio
# 0.957), 617 2.30 vs 2.77 (0.831), 381 7.19 vs 9.52 (0.756). Putting back
# only the vertices farther than 0.6 of the clearance from the gap rings gave
# 986 7.63 (0.992): a knife edge, which the 3 % margin asked here rejects.
# Since only the layer's data come back (not the TIN's own points, see
# test_gaps_take_back_the_layer_data_only): 986 7.34 (0.954), 617 2.30
# (0.831), 381 7.26 (0.763).
@pytest.mark.parametrize("seed", [381, 986, 617])
def test_patch_between_distant_traces_beats_the_tin(seed, tmp_path_factory):
    out = outcome(seed, tmp_path_factory)
    what = f"{out['describe']}: {out['stage']} {(out.get('error') or '')[:300]}"
    assert out["built"] and out["checked"], what
    assert out["accuracy"]["beats"], what
    acc = out["accuracy"]
    assert acc["mean_abs_stitched"] < 0.97 * acc["mean_abs_continuous"], what


# 75, 107, 357: the sweep after the layer data came back into the gaps had
# their near-fault error +30 / +22 / +19 % (4.62 -> 6.01, 3.14 -> 3.83, 0.46
# -> 0.55 m). The stitcher put back every removed layer vertex, also the
# TIN's own points -- those of the layer-crossing repair (rules 1b and 2),
# whose z is the continuous TINs' across the fault: 75's F1+F2 gap in L2
# took 309 of them, 19.8 m off the truth on average (the 6 data: 0.00 m);
# 107 L3 91, 16-22 m; 357 L2 45, 1.4-3.1 m. A gap now takes back the
# layer's data only (LayerTin::measured): 75 4.27, 107 3.07, 357 0.44 m.
@pytest.mark.parametrize("seed", [75, 107, 357])
def test_gaps_take_back_the_layer_data_only(seed, made):
    _, _, path = made(seed)
    ds = load(path)
    model = fm.build_model(ds, evaluate=False)
    data = ds.all_layer_points()
    back = 0
    for g in model.gaps:
        if not g.n_interior:
            continue
        T = model.surfaces[g.layer].triangles[g.triangles]
        E = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
        e, c = np.unique(E, axis=0, return_counts=True)
        inner = np.setdiff1d(T, e[c == 1])  # off the gap's rings: the vertices put back
        assert len(inner) == g.n_interior, (g.layer, g.fault)
        V = model.surfaces[g.layer].vertices[inner]
        is_datum = (V[:, None, :] == data[g.layer][None, :, :]).all(axis=2).any(axis=1)
        assert is_datum.all(), (g.layer, g.fault, V[~is_datum][:5])
        back += len(inner)
    assert back > 0  # each of these grounds has data under a removed set
