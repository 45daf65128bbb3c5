"""Random grounds as format 2 without cutoffs (faultmesh.grounds.write_v2,
issue 11 item 4): fault sticks on the truth's fault surface, layer tops as
collar/survey/interval tables with deviated holes, and the model derived
from them against the model built from the true cutoffs."""
from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

import faultmesh as fm
from faultmesh import grounds as gr
from faultmesh.build import surface_z


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """Ground seed -> (spec, geology, v1 dataset, v2 dataset), written once."""
    cache = {}

    def get(seed):
        if seed not in cache:
            d = tmp_path_factory.mktemp(f"v2ground{seed}")
            spec, geo, p = gr.make_ground(seed, d)
            with warnings.catch_warnings():
                warnings.simplefilter("error")  # the writer writes no unknown keys
                ds1 = fm.load_dataset(p)
                ds2 = fm.load_dataset(gr.write_v2(ds1, geo, spec, d / "v2"))
            cache[seed] = (spec, geo, ds1, ds2)
        return cache[seed]

    return get


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory):
    """(seed, section_picks=True) -> (gr.evaluate_ground_v2's record, the
    objects it built: geo, ds1, ds2, derived, m1, m2), evaluated once: two
    tests each evaluate grounds 52 and 86 alike, and seven look further into
    a ground's derived dataset or model, which they made again from the
    same files (the tests of grounds 0, 42, 52, 86, 89, 103 and 143: 107 s
    -> 69 s, serial, on a loaded machine)."""
    cache = {}

    def get(seed, section_picks=True):
        if (seed, section_picks) not in cache:
            built = {}
            out = gr.evaluate_ground_v2(seed, tmp_path_factory.mktemp(f"evaluated{seed}"),
                                        section_picks=section_picks, built=built)
            cache[seed, section_picks] = (out, built)
        return cache[seed, section_picks]

    return get


def cutoffs_moved(ds, dx: float, dy: float):
    """``ds`` with every cutoff polyline of its faults (and so its patches'
    outlines) moved by (dx, dy) in XY."""
    from dataclasses import replace

    faults = [replace(f, traces=[replace(t, layers={lay: {side: np.asarray(a) + [dx, dy, 0.0]
                                                          for side, a in sd.items()}
                                                    for lay, sd in t.layers.items()})
                                 for t in f.traces]) for f in ds.faults]
    return replace(ds, faults=faults)


def vertical_holes(ds2) -> set:
    """Ids of the holes without a survey station off the vertical."""
    s = ds2.drillholes.holes.surveys
    tilted = set(s.hole_id[s.dip != -90.0].tolist())
    return set(ds2.drillholes.holes.collars.hole_id.tolist()) - tilted


# Seeds: a reverse fault across the area with holes in its repetition band
# (0), a steep normal fault (18), an X-crossing pair of a reverse and a
# normal fault (8), four faults at a big coordinate offset (4).
TOPS_SEEDS = [0, 18, 8, 4]


@pytest.mark.parametrize("seed", TOPS_SEEDS)
def test_vertical_holes_give_the_v1_tops(pair, seed):
    """The tables' vertical holes give the v1 table's rows: same layers in
    the same order, the same x, y; the collar top is the collar elevation
    (surveyed as v1's tops are, to the same rounding: equal), every other top
    within 1 mm of the truth's sheet (depths logged to 1 mm) and so within
    1 mm plus v1's rounding of v1's row. What v1 has and v2 cannot: a second
    top of the TOP layer under a thrust, whose footwall has no layer above it
    (logged as grounds.COVER, not a layer: no top)."""
    spec, geo, ds1, ds2 = pair(seed)
    b1, b2 = ds1.boreholes, ds2.boreholes
    zt = 0.5 * 10.0 ** -spec.rounding["z"]
    rank = {lay: i for i, lay in enumerate(ds1.layers)}
    vert = vertical_holes(ds2)
    assert len(vert) >= 5
    compared = cover = 0
    for h in sorted(vert):
        m1 = np.flatnonzero(b1.hole_id == h)
        m2 = np.flatnonzero(b2.hole_id == h)
        deep = max(rank[v] for v in b1.layer[m1])
        m2 = m2[[rank[v] <= deep for v in b2.layer[m2]]]
        # v1's second top of the top layer (after another of its rows): not in v2.
        top = ds1.layers[0]
        second_top = [k for i, k in enumerate(m1) if b1.layer[k] == top and i > 0]
        cover += len(second_top)
        m1 = np.array([k for k in m1 if k not in second_top], dtype=np.int64)
        assert b2.layer[m2].tolist() == b1.layer[m1].tolist(), h
        assert np.array_equal(b2.xy[m2], b1.xy[m1]), h
        assert b2.z[m2[0]] == b1.z[m1[0]], h          # the collar
        if len(m1) > 1:
            assert np.abs(b2.z[m2[1:]] - b1.z[m1[1:]]).max() <= zt + 1e-3, h
            rest = m2[1:]
            for k in rest:
                S = geo.sheets(b2.layer[k], b2.xy[k:k + 1, 0], b2.xy[k:k + 1, 1])
                assert np.nanmin(np.abs(S - b2.z[k])) <= 1e-3, (h, b2.layer[k])
        compared += len(m1)
    assert compared > 20
    if seed == 0:
        # The band holes of its reverse fault meet L2 twice in v2 too; L1's
        # footwall top under the thrust is the cover case.
        assert any(np.sum((b2.hole_id == h) & (b2.layer == "L2")) == 2 for h in vert)
        assert cover > 0


@pytest.mark.parametrize("seed", TOPS_SEEDS)
def test_deviated_holes_tops_lie_on_the_truth(pair, seed):
    """Tops of the deviated holes, at the positions the reader desurveys,
    lie within 1 mm of a sheet of their layer at their own x, y (or of the
    truth in a normal fault's gap); the collar tops are the surveyed collar
    elevation. The holes really are deviated, and on seeds 0 and 8 some
    cross a fault (fault rock logged)."""
    spec, geo, ds1, ds2 = pair(seed)
    b2 = ds2.boreholes
    vert = vertical_holes(ds2)
    dev = ~np.isin(b2.hole_id, sorted(vert))
    first = np.r_[True, b2.hole_id[1:] != b2.hole_id[:-1]]
    n = 0
    for lay in ds2.layers:
        m = (b2.layer == lay) & dev & ~first
        if not m.any():
            continue
        x, y = b2.xy[m, 0], b2.xy[m, 1]
        cand = np.column_stack([geo.sheets(lay, x, y), geo.truth(lay, x, y)])
        dz = np.nanmin(np.abs(cand - b2.z[m][:, None]), axis=1)
        assert dz.max() <= 1e-3, (lay, dz.max())
        n += int(m.sum())
    assert n >= 10
    collars = ds2.drillholes.holes.collars
    c_xy = dict(zip(collars.hole_id.tolist(), collars.xyz[:, :2].tolist()))
    off = np.hypot(*(b2.xy[dev] - np.array([c_xy[h] for h in b2.hole_id[dev]])).T)
    assert off.max() > 5.0  # seed 0: a stack 5 m thick, 9.7 m
    it = ds2.drillholes.holes.intervals
    if seed in (0, 8):  # holes of these cross a fault where it changes the unit
        assert gr.FAULT_ROCK in set(it.unit.tolist())
    # Logged as a logging program writes them: depths to 1 mm, angles to 0.01 degree.
    assert np.array_equal(it.depth_from, np.round(it.depth_from, 3))
    s = ds2.drillholes.holes.surveys
    assert np.array_equal(s.dip, np.round(s.dip, 2)) and np.array_equal(s.azimuth, np.round(s.azimuth, 2))


@pytest.mark.parametrize("seed", [0, 8])
def test_trace_picks_are_the_v1_layer_polylines_without_cutoffs(pair, seed, tmp_path):
    """With section_picks, the v2 dataset gets the v1 traces' layer
    polylines as layer points (grounds.trace_picks): every point of each
    polyline whose horizontal distance from its cutoff is at least the
    ground's fault shadow, none nearer (the cutoff itself never), and
    nothing else; the layer tops are the same holes' either way."""
    spec, geo, ds1, ds2 = pair(seed)
    picks, shadow = gr.trace_picks(ds1, spec.seed)
    assert gr.SHADOW[0] <= shadow <= gr.SHADOW[1]
    want, near = {}, 0
    for f in ds1.faults:
        for t in f.traces:
            for lay, sides in t.layers.items():
                for side, P in sides.items():
                    cut = P[-1] if side == "foot" else P[0]
                    d = np.hypot(*(P[:, :2] - cut[:2]).T)
                    want.setdefault(lay, []).append(P[d >= shadow])
                    near += int(np.sum(d < shadow))
    assert near > 0  # every polyline has its cutoff at d = 0
    assert sorted(picks) == sorted(lay for lay, v in want.items() if sum(map(len, v)))
    for lay, P in picks.items():
        np.testing.assert_array_equal(P, np.vstack(want[lay]))
    d = tmp_path / "v2"
    ds3 = fm.load_dataset(gr.write_v2(ds1, geo, spec, d, section_picks=True))
    for lay in ds1.layers:
        extra = ds3.points.get(lay, np.zeros((0, 3)))
        base = ds2.points.get(lay, np.zeros((0, 3)))
        np.testing.assert_array_equal(extra[:len(base)], base)
        np.testing.assert_allclose(extra[len(base):], picks.get(lay, np.zeros((0, 3))), atol=0)
    np.testing.assert_array_equal(ds3.boreholes.z, ds2.boreholes.z)


def test_section_picks_on_both_sheets_stay_out_of_the_continuous_tin(tmp_path):
    """Regression (random_ground(96) as v2 with its section picks: a T pair
    of reverse faults of 35 and 48 m throw, 6 layers down to 4.2 m thick,
    picks up to a 13 m fault shadow): in L2's repetition band its own
    hanging-wall picks lay in the shadow, so its continuous TIN there came
    from its footwall picks, 43 m below L3's hanging-wall picks; the
    crossing repair gave up ("the layers still cross after 16022 inserted
    points"). A layer's extra points inside a reverse fault's patch, where
    they were picked on both of its sheets, now stay out of its continuous
    TIN (build.stratum_tins), which the patch replaces there: derived,
    built, check() passes. Its error near the faults is 1.7x the true
    cutoffs' model (the T pair's derivation: open), so only the build is
    held here."""
    out = gr.evaluate_ground_v2(96, tmp_path)
    assert out["stage"] in ("ok", "ratio"), (out["stage"], out["error"])
    assert out["kind_ok"], out["kinds"]


def test_a_survey_of_the_upper_sheet_stays_in_the_continuous_tin():
    """The rule above leaves out only points of a patch some of which lie on
    its lower sheet. random_ground(421)'s topographic survey of L1 (the
    upper sheet only) lies partly in a reverse fault's patch and stays in
    L1's TIN: left out, it cost 16 % near the faults (1.17 -> 1.36 m)."""
    ds = gr.random_ground(421)
    assert ds.spec.topography and any(f.kind == "reverse" for f in ds.faults)
    m = fm.build_model(ds)
    assert m.metadata["tins"]["L1"]["points_in_fault_patches"] == 0
    # ... while the same rule does take out picks of both sheets (ground 96).
    ds2 = gr.random_ground(96, version=2)
    ds2.points = {lay: np.vstack([ds2.points[lay], P]) if lay in ds2.points else P
                  for lay, P in gr.trace_picks(gr.random_ground(96), 96)[0].items()}
    m2 = fm.build_model(ds2)
    assert sum(t["points_in_fault_patches"] for t in m2.metadata["tins"].values()) > 0


@pytest.mark.parametrize("seed", [0, 8])
def test_v2_faults_are_sticks_on_the_truth(pair, seed):
    """Each fault is given by sticks only (no trace, kind or tip; the group
    kept), on the truth's fault surface up to the written rounding (a
    horizontal rounding of r moves a point up to tan(dip) r sqrt 2 across
    the surface), within the fault's extent along strike."""
    spec, geo, ds1, ds2 = pair(seed)
    assert ds2.sections == {}
    rt = 0.5 * 10.0 ** -spec.rounding["traces"]
    rz = 0.5 * 10.0 ** -spec.rounding["z"]
    for f1, f2 in zip(ds1.faults, ds2.faults):
        assert f2.name == f1.name and f2.kind is None and f2.traces == [] and len(f2.tips) == 0
        assert f2.group == f1.group and f2.sticks is not None
        fmod = geo.fault(f2.name)
        P = f2.points
        dz = np.abs(geo.plane_z(f2.name, P[:, 0], P[:, 1]) - P[:, 2])
        assert dz.max() <= rt * math.sqrt(2.0) * fmod.tan_dip + rz + 1e-9, f2.name
        u, _ = fmod.uw(*geo.local(P[:, 0], P[:, 1]))
        assert u.min() >= fmod.u_range[0] - 1.0 and u.max() <= fmod.u_range[1] + 1.0
        assert len(np.unique(f2.sticks)) >= 4


def test_v1_dataset_unchanged_by_the_v2_writer(tmp_path):
    """write_v2 draws from its own generator: the v1 files of a ground are
    the same bytes whether or not v2 was written after them, and v2 itself
    is deterministic per seed."""
    spec, geo, p = gr.make_ground(11, tmp_path / "a")
    before = {q.name: q.read_bytes() for q in (tmp_path / "a").iterdir() if q.is_file()}
    ds1 = fm.load_dataset(p)
    gr.write_v2(ds1, geo, spec, tmp_path / "a" / "v2")
    gr.write_v2(ds1, geo, spec, tmp_path / "b")
    after = {q.name: q.read_bytes() for q in (tmp_path / "a").iterdir() if q.is_file()}
    assert after == before
    for q in (tmp_path / "b").iterdir():
        assert (tmp_path / "a" / "v2" / q.name).read_bytes() == q.read_bytes(), q.name
    ds2 = gr.random_ground(11, tmp_path / "c", version=2)
    assert ds2.name == "ground-11-v2" and ds2.drillholes is not None and ds2.geology is not None


# ---------------------------------------------------------------------------
# Derived against true cutoffs (issue 11, item 4)
# ---------------------------------------------------------------------------
# The stated bound of the derived cutoffs' distance from the true ones (on
# the derived sections), as on the hand-made grounds of tests/test_derive.py.
CUTOFF_MEAN, CUTOFF_MAX = 2.0, 12.0

# Grounds of seeds 0-99 on which the derived model holds: two single
# faults, a reverse one at 77 degrees with 234 holes (27, ratio 0.37) and a
# normal one at 40 degrees across the area (59, ratio 1.02), and three
# independent faults (7, 1.16); and a reverse fault across a rotated
# rectangle (0, ratio 1.03: derive's outline test dropped 5 of its 8
# sections until it used the stitcher's). The T-crossing pairs 3, 24 and
# 68 are within 1.25 too, but with cutoffs up to 18-29 m from the true ones
# (docs/bench/sweep_v2.md).
#
# Ground 0 held at ratio 0.90 until the stitcher put the layer data back into
# the gaps (issue 10): the true cutoffs' model gained (0.634 -> 0.445 m), the
# derived one did not (0.573 m), ratio 1.29; the hanging wall's share of
# the fading throw taken at its own elevation (derive.SideSurface) brought
# the derived one to 0.535 m: ratio 1.20.
# 34 (normal fault at 73 degrees, 166 holes, one layer) was the reproducer
# of a throw that decays over 100-350 m into the hanging wall: its kind
# came out reverse until the cutoff throws decided up to `near`, then 2.1x,
# 1.85x with the fading-throw fit on the sections with a data gap at the
# cutoff, 1.78x at e1a79b7; 0.95x (cutoff mean 1.8 m, max 7.1 m) since the
# sections between hanging-wall data that show the throw take the fit
# however far apart those data are (derive._decay_sections); 1.55x since
# the fading-throw fit tries flat parts every 25 m (derive.DECAY_PROFILES),
# now among DERIVE_FAILS below. 63 (reverse fault at 36 degrees inside a
# polygon, 163 holes about 340 m apart, two layers, throw fading over
# 100-350 m into the hanging wall) took its place then: 1.35 -> 0.80x,
# cutoffs mean 2.4 -> 1.1 m, max 9.2 -> 3.2 m. It was the reproducer of the
# hanging wall's own surface extrapolating the fading bend towards the
# fault where its data stop more than a data spacing from the cutoff
# (1.54x; 1.22x with the fading-throw fit on those sections, 1.27x once
# the stitcher put the layer data back into the gaps and the true cutoffs'
# model gained, a strict xfail until then).
HOLDING_V2 = [27, 59, 7, 0, 63]


@pytest.mark.parametrize("seed", HOLDING_V2)
def test_derived_model_holds(seed, tmp_path):
    out = gr.evaluate_ground_v2(seed, tmp_path, section_picks=False)
    assert out["stage"] == "ok", (out["stage"], out["error"])  # derived, built, check() passed
    assert out["kind_ok"], out["kinds"]
    assert out["cutoff_mean"] <= CUTOFF_MEAN and out["cutoff_max"] <= CUTOFF_MAX, \
        (out["cutoff_mean"], out["cutoff_max"])
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


# Grounds as v2 with their section picks (grounds.trace_picks: the v1
# dataset's layer data without its cutoffs, issue 11 item 4's comparison,
# `python bench/sweep.py --v2`) whose derived model holds: within 1.25x of
# the true cutoffs' model near the faults, the kind right, cutoffs within
# the bounds below. One or two reverse faults across or inside the area
# (27, 63, 22: 63 and 22 fail as holes only, above), normal at 73 degrees
# (34, a holes-only failure above), a T pair of reverse faults (85), one
# normal fault across the area (51). Ratios on the sweep of 2026-12-02
# with the extra end sections and the dip continuation of derive: 0.29,
# 0.48, 0.59, 0.88, 0.99, 0.60 (51: cutoffs mean 0.86 m, max 10.1 m). Seed
# 16 (also one normal fault across the area, grid sections)
# was the sixth until the extra end sections of derive._fill_boundary_ends:
# its model got better (0.59 -> 0.44x) but those sections' cutoffs, near
# the boundary where the true traces stop 174 m short, lie up to 12.8 m
# from the truth (mean over the seed 1.24 -> 2.03 m), over CUTOFF_MAX.
# Seed 85 (a T pair of reverse faults) was the fifth until the fading-throw
# fit ran in the fault blocks of crossing faults: its model got better
# (0.74 -> 0.66x), but F2's hanging-wall cutoff at its seventh section moved
# along the fault's skirt (past its points, where the derived surface lies
# 9.6 m below the truth's bent one) and lies 14.4 m from the true cutoff
# (8.2 m before; its throw 36.3 m, the truth's 36.8 m): its own test below.
HOLDING_V2_PICKS = [27, 63, 22, 34, 51]


def _v1_and_v2_with_picks(seed, folder):
    """Ground ``seed``: its truth, and its datasets loaded as v1 and as v2
    with its section picks."""
    spec, geo, path1 = gr.make_ground(seed, folder)
    ds1 = fm.load_dataset(path1)
    return geo, ds1, fm.load_dataset(gr.write_v2(ds1, geo, spec, folder / "v2", section_picks=True))


@pytest.mark.parametrize("seed", HOLDING_V2_PICKS)
def test_derived_model_from_section_picks_holds(seed, tmp_path):
    out = gr.evaluate_ground_v2(seed, tmp_path)
    assert out["v2"]["section_picks"], out["v2"]
    assert out["stage"] == "ok", (out["stage"], out["error"])  # derived, built, check() passed
    assert out["kind_ok"], out["kinds"]
    assert out["cutoff_mean"] <= CUTOFF_MEAN and out["cutoff_max"] <= CUTOFF_MAX, \
        (out["cutoff_mean"], out["cutoff_max"])
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_a_t_pair_of_reverse_faults_from_section_picks_holds_but_past_its_points(evaluated):
    """Ground 85 as v2 with section picks (F2, reverse, abuts F1, reverse):
    the model within 1.25x, the kinds right, the cutoffs' mean within
    CUTOFF_MEAN; the largest distance is over CUTOFF_MAX where a
    hanging-wall cutoff lies on F2's skirt, the surface continued past its
    points (above: HOLDING_V2_PICKS), so the bound there is the skirt's
    error, not the throw's: those cutoffs lie off the truth's fault, and
    every cutoff that lies on it (within 1 m) is within CUTOFF_MAX. F2's
    end on F1 is no tip (FaultSurface.abuts; the report says "partner"),
    and no section's throw is tapered towards it: F2's hanging-wall data
    there lie only behind the end section along strike, and the truth keeps
    26 m up to F1. Until F2's end on F1 was known as such, the taper
    towards a tip there cut that section's throw to 13.9 m (14.8 m off; the
    model 0.75x, now 0.63x)."""
    out, built = evaluated(85)
    tapered = [float(w.split("section at u=")[1].split(":")[0]) for w in out["warnings"]
               if w.startswith("fault 'F2'") and "towards the tip" in w]
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["kind_ok"], out["kinds"]
    assert out["cutoff_mean"] <= CUTOFF_MEAN, out["cutoff_mean"]
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])
    geo, rep = built["geo"], built["derived"].derivation
    assert not [u for u in tapered if u > sum(rep.faults["F2"].surface.u_range) / 2], out["warnings"]
    assert rep.faults["F2"].ends[1] == "partner" and rep.faults["F2"].surface.abuts == [None, "F1"]
    for name, fr in rep.faults.items():
        for lay, cl in fr.cutoffs.items():
            for side in ("foot", "hanging"):
                P = np.asarray(cl[side])
                on = np.abs(P[:, 2] - geo.plane_z(name, P[:, 0], P[:, 1])) <= 1.0
                d = np.asarray(out["cutoffs"][name][lay][side], dtype=np.float64)
                assert np.all(d[on] <= CUTOFF_MAX), (name, lay, side, d, on)


def test_an_end_on_the_boundary_gets_its_own_section(evaluated):
    """Regression (random_ground(0) as v2 with section picks: a reverse
    fault across the area, both ends on the boundary; its outermost derived
    sections lay half a spacing short of the boundary and the builder
    carried their patches unchanged onto it: 1.29x the true cutoffs' error
    near the fault, all the excess in the two end sixteenths of the fault;
    0.89x with a section a tenth of a spacing inside each end)."""
    from faultmesh.derive import END_SECTION_INSET
    out, built = evaluated(0)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])
    # The sections: 8 a spacing apart plus one near each end.
    fr = built["derived"].derivation.faults["F1"]
    assert fr.ends == ["boundary", "boundary"]
    u = np.sort(next(iter(fr.throw.values()))["u"])
    assert len(u) == 10, u
    step = float(np.median(np.diff(u[1:-1])))
    # end section -> first regular one: (0.5 - inset) of a spacing, up to the
    # 128-cut grid that finds the extent's edge
    assert abs((u[1] - u[0]) / step - (0.5 - END_SECTION_INSET)) < 0.05, (u, step)
    assert abs((u[-1] - u[-2]) / step - (0.5 - END_SECTION_INSET)) < 0.05, (u, step)


def test_a_layer_leaving_the_area_obliquely_gets_a_section_near_where_it_does(evaluated):
    """Regression (random_ground(52) as v2 with section picks: F1, a reverse
    fault of 31 degrees whose SW end runs out of the L-shaped area
    obliquely; the deepest layer L3's cutoffs lie outside the area on the
    outer sections, its outermost cut section was 76 m (0.29 of a spacing)
    short of the true model's, and the builder carried that section's
    patch 240 m along strike onto the boundary (the true model 143 m):
    1.52x the true cutoffs' error near the faults, 0.29 m of the 0.35 m
    excess in that carried stretch of L3. derive._fill_boundary_ends adds a
    section for L3 as far out as both its cutoffs lie inside: 1.18x)."""
    out, built = evaluated(52)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])
    ds1, d2 = built["ds1"], built["derived"]
    fr = d2.derivation.faults["F1"]
    assert fr.ends[0] == "boundary"
    fs = fr.surface

    def outermost(ds):
        f = next(f for f in ds.faults if f.name == "F1")
        return min(float(fs.u(np.asarray(t.plane)[:, :2]).mean()) for t in f.traces if "L3" in t.layers)

    u = np.sort(next(iter(fr.throw.values()))["u"])
    step = float(np.max(np.diff(u)))  # the regular spacing (halfway sections are nearer)
    # The derived one no more than a tenth of a spacing short of the true
    # one (before: 0.29 of a spacing short; with the halfway sections of
    # derive.REFINE_SHARE it lies 55 m beyond it, at -262 m against -207 m).
    assert outermost(d2) < outermost(ds1) + 0.1 * step, (outermost(d2), outermost(ds1), step)
    # The report (the model's metadata) is JSON: the extra section has no
    # throw of the other layers, None there, not NaN (which made
    # Model.save(".3dt") fail on Claudius).
    import json
    rep = d2.derivation.as_dict()
    json.dumps(rep, allow_nan=False)
    assert None in rep["F1"]["throw"]["L1"]["throw"], rep["F1"]["throw"]["L1"]


def test_cutoffs_a_little_past_the_fault_points_in_depth_are_cut(evaluated):
    """Regression (random_ground(86) as v2 with section picks: F2, a normal
    fault with 38 m of throw whose sticks stop 13 m above its hanging-wall
    cutoffs on the middle five of its eight sections; there the cutoffs lay
    on the skirt, the layer was left uncut and the patch spanned the three
    outer sections only: 1.39x the true cutoffs' error near the faults.
    derive._dip_continuation counts the fault as continued a quarter of its
    picked length up and down dip: all eight sections, 0.56x)."""
    out, built = evaluated(86)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])
    prof = built["derived"].derivation.faults["F2"].throw["L1"]
    assert prof["cut"].all(), prof


def test_later_patch_merges_the_gap_around_a_carried_end_touching_the_boundary_at_a_vertex(tmp_path):
    """Regression (random_ground(704) as v2, found by the v2 sweep of seeds
    500-799): F2 of the X pair F1+F2 has no L5 cutoff on its west end
    section (its sticks stop 2.6 m above the hanging-wall cutoff), so its L5
    patch is carried from the next section 752 m along strike onto the
    study-area boundary, across F1; clipped by F1's outline, one triangle
    of it is left, touching the boundary at one point. Its own stitch
    pinched the gap there, but F3's stitch, whose removed region swallowed
    that gap, stopped: 'the removed region meets itself at vertex 343
    (538.98, 2614.77) ... an earlier fault patch is in the way'. The
    stitcher now keeps that pinch (stitch.hpp; ctest
    Stitch.LaterPatchMergesTheGapAroundAPieceTouchingTheBoundaryAtAVertex):
    derived, built, check() passes. Its error near the faults is 1.93x the
    true cutoffs' model (no warning; the class of seed 22 below), so it is
    not held to the ratio here."""
    out = gr.evaluate_ground_v2(704, tmp_path, section_picks=False)
    assert out["stage"] in ("ok", "ratio"), (out["stage"], out["error"])  # derived, built, checked
    assert out["kind_ok"], out["kinds"]
    assert out["kinds"]["F1"] == ["reverse", "reverse"] and out["kinds"]["F2"] == ["normal", "normal"]


def test_layer_repair_ends_where_an_upper_boundary_vertex_lies_an_ulp_outside_the_lower_hull(tmp_path):
    """Regression (random_ground(968), found by the v2 sweep of seeds 800-999
    as its reference, the v1 model, failing): L1's boundary vertex on a
    slanted side lay 1 ulp outside L2's hull, in a sliver triangle of L2's
    TIN beyond the study area, which put L2 there 3.4 mm above that very
    vertex's own copy in L2; the repair's rule 1b inserted it again every
    round ("'L2' still crosses 'L1' after 50 rounds"). LayerTin.interpolate
    now gives every point on the study-area boundary its boundary piece's
    elevation (ctest LayerTinInterpolate.PointsOnTheBoundaryGetTheirPiecesElevation):
    both models build and pass check()."""
    out = gr.evaluate_ground_v2(968, tmp_path, section_picks=False)
    assert out["stage"] in ("ok", "ratio"), (out["stage"], out["error"])
    assert out["kind_ok"], out["kinds"]


# One seed per class of derive's failures on these grounds that is still
# open (sweep_v2.md; the classes of seeds 0, 29, 75 and 34's kind are
# fixed, tests/test_derive.py): reproducers that must start to hold
# (strict: a fix shows here and moves the seed to HOLDING_V2).
DERIVE_FAILS = {
    # Reverse fault at 35 degrees, 82 holes, no warning, cutoffs within
    # 1.5 m (mean): error near the fault 0.50 m against 0.30 m (1.68x).
    22: "no warning, ratio 1.68",
    # Reverse fault at 34 degrees across the area, 28 holes: cutoff throws
    # of a normal fault (5-12 m) on six layer sections (set to zero),
    # ratio 4.1.
    12: "cutoff throws of the wrong sign",
    # Normal fault at 49 degrees, 35 holes over 1.7 km: no hanging-wall
    # data within about 420 m of the cutoffs on six layer sections
    # (extrapolated), ratio 2.1.
    43: "no hanging-wall data near the fault",
    # Three faults, 20 holes over 4.7 km. The derived patches of F2 and F3
    # (independent) overlapped until the far ends kept to their share of
    # the room between faults; it now builds, but F1 (normal, 79 degrees)
    # comes out reverse from data that sparse, ratio 8.1.
    91: "kind derived wrong (20 holes over 4.7 km)",
    # Normal fault at 73 degrees, 166 holes, one layer; the throw stays
    # whole for about 50 m into the hanging wall and fades over the next
    # 120 m. The fading-throw fit's objective hardly tells its profiles
    # apart (the least five within 1.6x of each other): the least is (50,
    # 150) m, whose shares at the data 100-132 m from the fault are
    # 0.1-0.15 above the truth's, and the throw at the cutoffs comes out
    # 20 % short (29 m where the truth has 38 m), hanging-wall cutoffs up
    # to 9 m off, ratio 1.55. On the coarser grid of profiles (0, 200) m
    # won, 7 % too much throw, 0.95x.
    34: "fading profile weakly determined, throw 20 % short",
}


@pytest.mark.parametrize("seed", sorted(DERIVE_FAILS))
def test_derive_failure_reproducers(seed, tmp_path, request):
    request.applymarker(pytest.mark.xfail(strict=True, reason=DERIVE_FAILS[seed]))
    out = gr.evaluate_ground_v2(seed, tmp_path, section_picks=False)
    assert out["stage"] == "ok", (out["stage"], out["pattern"])


def test_two_separate_faults_close_in_map_view_build_apart(tmp_path):
    """Regression (random ground 206 as v2 with section picks, found in a
    sweep of the unseen seeds 200-399; failed alike on 06b57d4): F1
    (normal, 80 degrees) and F3 (reverse, 39 degrees), not a group, end near
    each other. F3's section nearest its tip put its L1 footwall far end 2 m
    from F1's L1 hanging-wall far end, and the stitcher stopped the build
    ("faults too close"). Each far end kept to its fault's share of the room
    (derive._room_between_faults, ROOM_SHARE 0.4), measured between the two
    faults' traces at its own cutoff's elevation; F3's trace moves 1.2 m per
    metre of elevation, and the two cutoffs lie tens of metres apart in z.
    The room is now also bounded by the other fault's traces at the
    elevations the layer has along the polyline: it builds, 1.18x."""
    out = gr.evaluate_ground_v2(206, tmp_path)
    assert out["stage"] in ("ok", "ratio"), (out["stage"], out["error"])
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_noisy_picks_of_four_faults_build(tmp_path):
    """Regression (random ground 69 as v2 with section picks, its fault
    sticks picked with a 3 m error across strike; bench/sweep.py --v2
    --fault-noise 3): four faults, F1+F2 an X-crossing pair at 83 and 76
    degrees, F4 a normal fault at 50 degrees whose L6 throw is about 3 m.
    With the picks smoothed by unweighted fits of their 32 nearest others,
    the derived patches of F4 and of the pair met in L6 and the build
    stopped ("faults too close"); with the fits weighted by distance over
    64 (derive.SCATTER_NEIGHBOURS) it builds, 1.25x the true cutoffs'
    model (through the picks as given, 3.2x)."""
    out = gr.evaluate_ground_v2(69, tmp_path, fault_noise=3.0)
    assert out["stage"] in ("ok", "ratio"), (out["stage"], out["error"])
    assert out["ratio"] < 2.0, (out["error_v1"], out["error_v2"])


@pytest.mark.parametrize("seed", [86, 79])
def test_derived_patches_honour_the_picks_under_them(seed, evaluated):
    """Regression (random grounds as v2 with section picks): a fault's patch
    replaced the continuous TIN and every pick under it; between two derived
    sections its loft ran straight past the picks of the true sections.
    86 (a reverse and a normal fault) was 1.39x the true cutoffs' error
    near the faults, 79 (four faults) 1.49x; with the picks placed in the
    patches (build._honour_layer_data) 0.92x and 1.14x."""
    out, _ = evaluated(seed)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_picks_on_a_patch_edge_are_honoured(evaluated):
    """Regression (random ground 42 as v2 with section picks): five L2
    picks 7.5 m apart on a true section line lay on the edge of F1's patch
    where the derivation put a section on that line, and
    insert_patch_data left out every datum within a hundredth of a
    triangle's height of an edge: the model passed 34-35 m under them. A
    datum on or that near one edge now goes onto it (patch_data.hpp), and
    the model passes within 2 cm of every datum (0.95 -> 0.93x the true
    cutoffs' error near the faults)."""
    out, built = evaluated(42)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    fit = built["m2"].metadata["data_fit"]
    assert max(r["max_m"] for r in fit.values()) < 0.05, fit
    # No warning but the layer order's (L2 up to 11.1 m above L1, in F1's
    # patch under L1's own surface, at 4 places).
    assert not [w for w in built["m2"].metadata.get("warnings", []) if "lies above" not in w]


def test_data_left_out_for_a_patch_that_does_not_cover_them_go_back(tmp_path):
    """Regression (random ground 24 as v2 with section picks, a reverse
    fault): L2 and L3 picks in the reverse fault's footprint were left out
    of the continuous TINs (both sheets picked there), but the patch as
    built, clipped and extended, does not cover 46 of them; they lay in
    the stitched gap, where only the TIN's data are put back, and the model
    missed them by up to 26.5 m. They now go back into the TIN as data
    (build_model, LayerTin.insert(as_data=True)); the largest miss is 0.1 m
    (0.92 -> 0.85x the true cutoffs' error near the faults)."""
    built = {}
    out = gr.evaluate_ground_v2(24, tmp_path, built=built)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    m = built["m2"]
    given = {lay: t["given_back"] for lay, t in m.metadata["tins"].items() if t.get("given_back")}
    assert given.keys() == {"L2", "L3"} and sum(given.values()) > 30, given
    assert max(r["max_m"] for r in m.metadata["data_fit"].values()) < 0.5, m.metadata["data_fit"]
    assert "warnings" not in m.metadata


@pytest.mark.parametrize("seed", [93, 52])
def test_halfway_sections_follow_the_fault_along_strike(seed, evaluated):
    """Regression (random grounds as v2 with section picks): on sections an
    eighth of the fault apart the builder's loft, straight along strike,
    missed how the throw and the band change between them (93: a T pair,
    1.29x the true cutoffs' error near the faults; 52: two reverse faults,
    one ending at a tip, 1.43x). With the halfway sections where a cutoff
    departs from its neighbours' straight line by more than
    derive.REFINE_SHARE of the layer's throw: 0.88x and 1.04x."""
    out, _ = evaluated(seed)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


@pytest.mark.parametrize("seed", [103, 143])
def test_layers_crossing_near_a_derived_normal_fault_build(seed, evaluated):
    """Regression (random grounds 103 and 143 as v2 with section picks: a
    normal fault, and an X pair of normal faults, with layers 3.4 and 2.4 m
    thick; each continuous TIN interpolated across a fault from other
    picks, L4's lay above L3's over a band, and the crossing repair gave
    up: "repair_crossings('L3', 'L4'): ..."). build_model built the TINs
    again with every pick under a derived patch left out of them (the
    patches take the picks back): 0.79x and 0.73x the true cutoffs' error
    near the faults. Since the layer TINs' boundary slope gives way to the
    layer's regional one far from the data (layer_tin.cpp), 103's first
    build no longer crosses; since the repair's budget counts the upper
    layer's vertices too (layer_tin.hpp, RepairOptions), 143's repair ends
    (0.67x). Neither needs the retry now (the next test keeps it tested)."""
    out, built = evaluated(seed)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])
    m = built["m2"]  # build_model(derive_faults(ds2), evaluate=False)
    assert "repair_retry" not in m.metadata, m.metadata["repair_retry"]


def test_a_crossing_repair_that_gives_up_is_retried_without_the_picks_under_derived_patches(monkeypatch,
                                                                                             tmp_path):
    """Ground 143 as v2 with section picks (the previous test) under the
    repair's former budget (its floor of 10,000 points here) still gives
    up in the first build; build_model builds the TINs again with each
    layer's picks under a derived patch left out (_in_fault_zones,
    every_derived) and says so in ``metadata["repair_retry"]``. Measured:
    0.73x the true cutoffs' error near the faults."""
    import faultmesh.build as fb

    former = fb.repair_stack
    monkeypatch.setattr(fb, "repair_stack", lambda *a, **k: former(*a, max_inserted_per_vertex=0.0, **k))
    built = {}
    out = gr.evaluate_ground_v2(143, tmp_path, built=built)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])
    m = built["m2"]
    assert "repair_crossings('L3', 'L4')" in m.metadata["repair_retry"]
    assert sum(t["points_in_fault_patches"] for t in m.metadata["tins"].values()) > 0


@pytest.mark.parametrize("seed, holds", [(4, True), (75, False)])
def test_the_kind_follows_the_layers_with_data_at_the_fault(seed, holds, tmp_path):
    """Regression (random grounds as v2 with section picks): where one
    layer has both sides' data at the fault and others have none on one
    side, the others' offsets, bridged across hundreds of metres, decided
    the kind. 4: F4, reverse, L3 -14 m at the fault, L1/L2 +21 m bridged:
    normal, 1.26x the true cutoffs' error near the faults. 75: F3, normal,
    L5 +13 m at the fault, L2 -78 m bridged: reverse. With only the layers
    with data at the fault voting: both right, 4 at 0.63x (75 fails the
    ratio for other reasons: F2's L2 cutoffs)."""
    out = gr.evaluate_ground_v2(seed, tmp_path)
    assert out["kind_ok"], out["kinds"]
    if holds:
        assert out["stage"] == "ok", (out["stage"], out["error"])
        assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_a_layer_whose_cutoffs_lie_past_the_fault_points_on_one_side_all_along_is_cut(evaluated):
    """Regression (random_ground(42) as v2 with section picks: F4, a normal
    fault at 45 degrees with 93 m of sticks in depth; L2's footwall cutoffs
    lie in the sticks' extent, its hanging-wall cutoffs 31-38 m below them,
    past derive.DIP_CONTINUATION on every section: no layer was cut, F4 got
    plane traces only, no kind, 1.61x the true cutoffs' error near the
    faults). A layer otherwise uncut whose other cutoff lies within
    derive.DIP_PARTNER on at least half of the sections is cut there:
    1.03x, F4 normal; L2 cut on most sections."""
    out, built = evaluated(42)
    assert out["stage"] == "ok", (out["stage"], out["error"])
    assert out["kind_ok"], out["kinds"]
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])
    prof = built["derived"].derivation.faults["F4"].throw["L2"]
    assert prof["cut"].mean() >= 0.5, prof


def test_polylines_stay_in_their_block_of_a_crossing_fault(tmp_path):
    """Regression (random_ground(90) as v2 with section picks: F2, a
    reverse fault abutting F1 (a T pair); F1's hanging-wall polylines
    reached 236 m from their cutoffs, past F2, where the layer lies 13-33 m
    higher than F1's hanging-wall surface says: 1.75x the true cutoffs'
    error near the faults). Every vertex of F1's polylines lies on its
    cutoff's side of F2 at its own elevation (1.42x: the hanging wall near
    F2 still misses the layer's rise towards it)."""
    from faultmesh.derive import derive_faults

    _, _, ds2 = _v1_and_v2_with_picks(90, tmp_path)
    d2 = derive_faults(ds2)
    f2 = d2.derivation.faults["F2"].surface
    f1 = next(f for f in d2.faults if f.name == "F1")
    n = 0
    for tr in f1.traces:
        for lay, walls in tr.layers.items():
            for wall in ("foot", "hanging"):
                P = np.asarray(walls[wall], dtype=np.float64)
                k = f2.side(P)[1]
                cutoff_side = k[-1] if wall == "foot" else k[0]
                if cutoff_side != 0:
                    assert np.all((k == cutoff_side) | (k == 0)), (tr.section, lay, wall, k)
                    n += 1
    assert n > 0


@pytest.mark.parametrize("seed, holds", [(62, True), (94, True)])
def test_a_cutoff_throw_of_the_wrong_sense_takes_the_throw_along_strike(seed, holds, evaluated):
    """Regression (random grounds as v2 with section picks): a section
    whose cutoff throw has the other sense than the fault's got zero throw
    (merged cutoffs). 62: F2, a normal fault of 26 m, its one layer's
    hanging wall without data within 420-840 m of the cutoffs on the four
    sections towards the end on the boundary (a strip with one hole between
    the fault and the boundary): the hanging wall extrapolated from the
    south gave -9 to -32 m, set to zero, 2.14x the true cutoffs' error near
    the faults. Now the side whose cutoff lies farther from the line of the
    sections that show the throw (here the hanging wall) is the other
    side's surface shifted by their throw (held beyond them towards an end
    on the boundary): 1.59x, then 1.45x, failing for F3 (below, in
    test_sections_between_pick_lines_take_the_fading_throw_fit), and 1.21x
    since. 94: F3's L1 at its
    tip (-10 and -22 m past the last section showing 3 m): towards a tip the
    throw dies out, so these stay at zero and the tip where it was, 1.23x
    (holding 3.1 m there kept the sections, cutoffs 17 m off: 1.37x)."""
    out, _ = evaluated(seed)
    assert out["kind_ok"], out["kinds"]
    if holds:
        assert out["stage"] == "ok", (out["stage"], out["error"])
        assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])
    else:
        assert out["stage"] == "ratio", (out["stage"], out["error"])
        assert out["ratio"] < 1.8, (out["error_v1"], out["error_v2"])
        wrong = [w for w in out["warnings"] if "F2" in w and "has the sign" in w]
        assert wrong and all("from the throw" in w for w in wrong), wrong


def test_sections_between_pick_lines_take_the_fading_throw_fit(evaluated):
    """Regression (random ground 62 as v2 with section picks: F3, a normal
    fault of 30-40 m across the area, its one layer picked on lines 4
    section spacings apart). The three sections between two lines had no
    hanging-wall datum within a section spacing along strike that shows the
    throw, so they kept their own hanging walls, which rose to a hole 250 m
    from the fault: throws 14-15 m where the lines show 29-34 m, two
    hanging-wall cutoffs 26 and 29 m off (the model 1.45x the true
    cutoffs' error near the faults). A section with such data on both
    sides along strike now takes the fading-throw fit, whose throw
    interpolates theirs (derive._decay_sections): every F3 cutoff within
    9 m (measured at most 5.9 m, on the hanging wall; 8.4 m since the
    fading-throw fit's finer grid of profiles, where the section's own
    footwall, 590 m from its data, lies 5 m low; ratio 1.09 -> 1.11x)."""
    out, _ = evaluated(62)
    assert out["ratio"] is not None, (out["stage"], out["error"])
    for side in ("foot", "hanging"):
        d = np.asarray(out["cutoffs"]["F3"]["L1"][side], dtype=np.float64)
        assert np.nanmax(d) <= 9.0, (side, d)


def test_the_throw_tapers_to_a_tip_past_the_data(evaluated):
    """Regression (random_ground(89) as v2 with section picks: F1, a normal
    fault of 35 m inside the area whose throw tapers to zero at both ends
    of its 750 m; L4's and L5's hanging-wall data near it lie along its
    middle 200 m only, the footwall's 360 m away or more. Each side's
    surface continued the whole throw to the fault's ends: the end sections
    kept 38-43 m where the truth has 9-22 m, hanging-wall cutoffs up to 34
    m too deep, 2.50x the true cutoffs' error near the faults). Past the
    last section with data near a cutoff, towards an end inside the area,
    the throw is held under a straight taper to zero at the extent's edge:
    the outermost sections within 3.4 m of the truth, 1.83x (the hanging
    wall farther from the fault still misses, so the ground still fails).
    2.16x since the side surfaces relax towards the regional slope of a
    plane with a step at the fault (4ec8ca3): the footwall's data lie 360 m
    from F1, and extrapolated along that slope its cutoffs rise (45 m of
    throw at the middle section, 39 m before, the truth 35 m); the bound
    on the ratio guards the taper, not that extrapolation. The taper
    follows the fault's throw profile (1 - x^2 along strike between the
    tips, derive._throw_profile), not a straight line from the last
    section's throw to zero, which lies under any concave profile: L5's
    throws on the four sections past its data towards the end at u = 1193
    3.8-7.9 m short of the truth's, now within 0.7 m; 1.31 -> 1.28x."""
    out, built = evaluated(89)
    geo = built["geo"]
    f1 = next(f for f in built["derived"].faults if f.name == "F1")
    truth = geo.fault("F1")
    for lay in ("L4", "L5"):
        off = {}
        for tr in f1.traces:
            walls = tr.layers.get(lay)
            if walls is None:
                continue
            foot, hang = np.asarray(walls["foot"])[-1], np.asarray(walls["hanging"])[0]
            u, _ = truth.uw(*(0.5 * (foot[:2] + hang[:2]) - geo.origin))
            off[float(u)] = abs((foot[2] - hang[2]) - truth.throw * float(truth.taper(u)))
        ends = sorted(off)
        assert len(ends) >= 6
        assert off[ends[0]] < 6.0 and off[ends[-1]] < 6.0, (lay, off)
        if lay == "L5":
            assert max(off[u] for u in ends[-4:]) < 2.0, off
    assert out["kind_ok"], out["kinds"]
    assert out["stage"] == "ratio" and out["ratio"] < 2.3, (out["stage"], out["ratio"])


def test_data_only_behind_a_section_near_a_tip_do_not_hold_its_throw(evaluated):
    """Regression (held-out random_ground(178) as v2 with section picks: F1,
    a normal fault of about 24 m with a tip inside the area. The section
    50 m from the tip has hanging-wall data within a section spacing of its
    cutoff (102 m), but all 85 m behind it along strike, where the throw is
    still 10 m; the hanging wall's surface carried that on to the section
    (10.4 m of throw where the truth has about 4 m; its hanging-wall
    cutoffs 5.7 and 6.8 m too deep, 2.16x the true cutoffs' error near the
    fault). Only data at or past a section towards the tip hold its throw
    (derive._tip_side_datum): that section is tapered from the next one
    in, its hanging-wall cutoffs within 1.4 m of the truth (the ground
    still failed at 1.70x, past the tip: the layer TIN's boundary
    extrapolation, whose slope now gives way to the regional one far from
    the data: 1.23x)."""
    out, built = evaluated(178)
    geo = built["geo"]
    fr = built["derived"].derivation.faults["F1"]
    assert "tip" in fr.ends
    tip = np.asarray(fr.tips[0])
    for lay in ("L1", "L2"):
        hang = np.asarray(fr.cutoffs[lay]["hanging"])
        near = hang[[int(np.argmin(np.hypot(*(hang[:, :2] - tip).T)))]]
        assert np.hypot(*(near[0, :2] - tip)) < 100.0, near    # the section nearest the tip
        d = gr.cutoff_distance(geo, "F1", lay, "hanging", near, fr.surface.dip_dir)
        assert d[0] < 2.5, (lay, d)         # 5.7 (L1) and 6.8 m (L2) before
    assert any("F1" in w and "towards the tip" in w for w in out["warnings"]), out["warnings"]
    assert out["kind_ok"], out["kinds"]


def test_a_clump_of_picks_far_from_the_boundary_does_not_set_its_slope(evaluated):
    """Regression (held-out random_ground(146) as v2 with section picks: a
    rotated 5.1 km rectangle at UTM coordinates, F2's picks end 250 m from
    its boundary). The derivation was right (cutoffs within 1 m); the model's
    L2 lay up to 61 m off the truth along the edge beside F2's tip, 2.17x the
    true cutoffs' error near the faults. The layer TIN's boundary vertices
    there took the plane of their 12 nearest data, 500 m off: 11 picks along
    one section line across F2 (a 5 m step, 6 m of spread across the line)
    and one pick far along it, whose slope across the line (0.39) ran out to
    the clamp. Now past three standard deviations of the neighbours' spread
    along an axis their slope gives way to the layer's regional one
    (layer_tin.cpp, plane_fit_z): the model is within the bound."""
    out, built = evaluated(146)
    geo, m2 = built["geo"], built["m2"]
    ring = np.asarray(built["ds1"].boundary, dtype=float)
    # Points along the study area's edges, 20 m inside, within 600 m of the
    # corner beside F2's southern tip (the one nearest (384700, 6603700)).
    k = int(np.argmin(np.hypot(ring[:, 0] - 384700.0, ring[:, 1] - 6603700.0)))
    centre = ring.mean(axis=0)
    pts = []
    for j in (k - 1, k + 1):
        a, b = ring[k], ring[j % len(ring)]
        u = (b - a) / np.hypot(*(b - a))
        for s in np.arange(50.0, 600.0, 25.0):
            p = a + s * u
            pts.append(p + 20.0 * (centre - p) / np.hypot(*(centre - p)))
    pts = np.asarray(pts)
    z = surface_z(m2.surfaces["L2"].vertices, m2.surfaces["L2"].triangles, pts)[1]
    t = geo.truth("L2", pts[:, 0], pts[:, 1])
    ok = np.isfinite(z) & np.isfinite(t)
    assert ok.sum() > 20, ok.sum()
    assert np.max(np.abs(z[ok] - t[ok])) < 6.0, np.max(np.abs(z[ok] - t[ok]))   # 61 m before
    assert out["ratio"] <= 1.25, out["ratio"]                                    # 2.17 before


def test_a_hanging_wall_without_data_near_its_cutoff_takes_the_throw_along_strike(evaluated, tmp_path):
    """Regression (random grounds as v2 with section picks: the layers are
    picked along the true sections only, a few hundred metres apart).
    61: F3, a normal fault of 14-35 m with an end on the boundary 200 m past
    its last pick line; its hanging-wall cutoffs lay within 8 m of the
    truth at the pick lines and 50-60 m too deep between and beyond them
    (its footwall's within 1 m): L1's on the section 240 m from the nearest
    pick, 60.4 m. Now a section with no hanging-wall datum within half a
    section spacing of its cutoff takes the throw of the sections that have
    one, along strike: within 8 m there (the ground fails for other
    reasons, 2.03x -> 1.75x); 9.9 m since the side surfaces' smoothing
    length is at least a tenth of a cell (2026-12-05: the section at u =
    47 m, with data of both sides within 70 m, shows 45 m of throw where
    the truth has 34 m, and the end sections take it; the ground 1.52 ->
    1.42x), so the bound is 12 m, far under the 60 m of the defect. 69:
    F1's cutoff throws 11-30 m between its pick lines where the truth has
    40-45 m, 1.42x; now 1.00x."""
    out, built = evaluated(61)
    geo, f3 = built["geo"], next(f for f in built["derived"].faults if f.name == "F3")
    off = []
    for tr in f3.traces:
        walls = tr.layers.get("L1")
        if walls is None:
            continue
        h = np.asarray(walls["hanging"])[0]
        off.append(abs(h[2] - geo.side_value("L1", "F3", "hanging", h[None, 0], h[None, 1])[0]))
    assert len(off) >= 8 and off[0] < 12.0, off      # the end on the boundary
    assert any("F3" in w and "no hanging-wall data near it" in w for w in out["warnings"])
    out = gr.evaluate_ground_v2(69, tmp_path)
    assert out["stage"] == "ok" and out["ratio"] <= gr.V2_RATIO, (out["stage"], out["ratio"])


def test_picks_on_a_derived_patch_outline_are_in_it_whatever_the_last_bits(evaluated, monkeypatch):
    """Regression (random ground 2 as v2 with section picks): derive places
    end sections on the pick lines, so picks lie on a patch's outline. Which
    side of it they fell on was decided by the last bits of the outline:
    moving the derived cutoffs by 1e-10 m (another root finder) put two of
    L3's picks into F1's patch, the layer's TIN lost them, its boundary
    spacing (from the data count) changed and with it every boundary
    vertex; the error near the faults moved by 6 %. Within
    build.ON_OUTLINE of the outline a point is in the patch (as one
    exactly on it is): the same model for cutoffs moved by +-1e-10 m, and
    the same counts for +-1e-7 m (which, without the rule, moves the picks
    on the outline out of or into the patch on any machine: +-1e-10 m did
    so on the one the test was written on, and not on an Intel Xeon where
    the derivation's last bits differ)."""

    import faultmesh
    from faultmesh import build

    _, built = evaluated(2)
    derived = built["derived"]

    def nudged(d):
        return cutoffs_moved(derived, d, d)

    def in_patches(step):
        out = []
        for d in (-step, 0.0, step):
            ds = nudged(d)
            area = faultmesh.StudyArea(build._ccw_ring(ds.boundary))
            out.append([int(build._in_fault_zones(ds, lay, area, ds.layer_points(lay), kind="reverse",
                                                  both_sheets=True).sum()) for lay in ds.layers])
        return out

    for step in (1e-10, 1e-7):
        counts = in_patches(step)
        assert counts[0] == counts[1] == counts[2], (step, counts)
    # The rule is what holds it: without it (only the points the patch's
    # closed triangles contain) the counts differ.
    with monkeypatch.context() as mp:
        mp.setattr(build, "ON_OUTLINE", -1.0)
        off = in_patches(1e-7)
    assert not off[0] == off[1] == off[2], off
    m = faultmesh.build_model(nudged(1e-10), evaluate=False)
    m0 = built["m2"]
    for lay in m0.surfaces:
        assert m.surfaces[lay].vertices.shape == m0.surfaces[lay].vertices.shape, lay


def test_folded_patch_kept_clear_of_its_partner_needs_no_clean_up_whatever_the_last_bits(evaluated, monkeypatch):
    """Regression (random ground 24 as v2 with section picks): F2, a reverse
    fault abutting F1, is made clear of F1's patch in L1 (faults._clear_of):
    the loft that touches F1 is left out and the two runs either side are
    closed. Each run was simple, but the run beyond F1 (the end section
    carried onto the boundary, closed back towards F1) crossed the other's
    closure; group_patch's clean-up then removed 112-148 of the patch's 253
    triangles, how many decided by the cutoffs' last bits (error near the
    faults 1.09-1.18x the true cutoffs' model for cutoffs moved by
    +-1e-10 m). A variant whose runs cross is not taken: the patch reaches
    the group clip simple, the clip removes nothing, and the model keeps
    its error whatever the last bits."""

    from faultmesh import faults

    out, built = evaluated(24)
    derived, geo = built["derived"], built["geo"]
    removed = []
    clip = faults.clip_patch

    def counted(V, T, rings, *a, **k):
        got = clip(V, T, rings, *a, **k)
        removed.append(len(T) - len(got[1]))
        return got

    monkeypatch.setattr(faults, "clip_patch", counted)

    def nudged(d):
        return cutoffs_moved(derived, *d)

    ratios = []
    for d in ((0.0, 0.0), (-1e-10, 0.0), (0.0, 1e-10), (0.0, -1e-10)):
        removed.clear()
        m = fm.build_model(nudged(d), evaluate=False)
        assert removed and sum(removed) == 0, (d, removed)
        e1, e2 = gr.near_fault_errors([built["m1"], m], geo, derived.boundary)
        ratios.append(e2 / e1)
    assert max(ratios) - min(ratios) < 0.01, ratios
    assert max(ratios) <= gr.V2_RATIO, ratios


def test_derivation_takes_the_same_decisions_whatever_the_last_bits_of_the_fault_points(tmp_path, monkeypatch):
    """Regression (random ground 91 as v2 with section picks): fault points
    moved by 1e-9 m (as another machine's libraries, or a round trip
    through a file, may move them) changed two discrete choices of the
    derivation, and F3's L1 cutoffs moved by up to 11 m:
    - the fading-throw fit's profile: seven of its 13 profiles give F3's L1
      hanging-wall data the same shares, their objectives differed in the
      last bits only, and the least of them was taken (now the first of the
      tied ones, derive.PROFILE_TIE);
    - whether a section 1.5 section spacings past the last supported one
      takes the hanging-wall rule (bound: 1.5 spacings; the distance 1.5
      spacings but for rounding; derive.ON_GRID).
    Now the same profiles and the same rules apply for every such nudge.
    (Sticks are densified with the same slack: evenly sampled sticks' segments
    as long as the median spacing were split or not at random.)"""
    from dataclasses import replace

    from faultmesh import derive

    spec, geo, path1 = gr.make_ground(91, tmp_path)
    ds2 = fm.load_dataset(gr.write_v2(fm.load_dataset(path1), geo, spec, tmp_path / "v2", section_picks=True))
    profiles = []
    decay = derive._decay_sides

    def recorded(D, split, frame, k, spacing, fs, ring, *rest):
        got = decay(D, split, frame, k, spacing, fs, ring, *rest)
        profiles.append((fs.name, len(D), None if got is None else got["hanging"].profile))
        return got

    monkeypatch.setattr(derive, "_decay_sides", recorded)
    seen = []
    for draw in range(4):
        rng = np.random.default_rng(draw)
        ds = ds2 if draw == 0 else replace(ds2, faults=[
            replace(f, points=np.asarray(f.points) + rng.uniform(-1e-9, 1e-9, np.shape(f.points)))
            if f.points is not None else f for f in ds2.faults])
        profiles.clear()
        d = derive.derive_faults(ds)
        seen.append((list(profiles), sorted(d.derivation.warnings)))
    assert all(s == seen[0] for s in seen[1:])


def test_sparse_layers_take_no_shape_from_picks_on_a_fault(tmp_path):
    """Regression (random_ground(49) as v2 with section picks: L1 picked
    along sections, L2-L6 from holes only, conformable to L1): L1's picks
    in F1's gap lie on the fault, and offset by the isochore they put L2-L5
    points 12-20 m below the footwall beside F1; F1's footwall cutoffs of
    L2-L5 came out up to 46 m from the true ones (error near the faults
    1.37x the true cutoffs' model, now 0.90x). Data on a fault are now no
    reference (derive._conformable_points). Checked on the extra points
    themselves (the derivation of this ground takes 20 s): those of L2,
    L3 and L5 all within 10 m of the truth, at most 5 of L2-L5 over 10 m.
    Measured: none of L2, L3, L5 (before 5, 5, 8), 5 of L4 (before 9: L4
    keeps a step across F1 that the truth does not have, Open)."""
    from faultmesh import derive
    geo, _, ds = _v1_and_v2_with_picks(49, tmp_path)
    ring = np.asarray(ds.boundary, dtype=np.float64)
    zs = np.concatenate([derive.layer_data(ds, lay)[:, 2] for lay in ds.layers])
    surfs = [derive.fault_surface(f, ring, (float(zs.min()) - 100.0, float(zs.max()) + 100.0),
                                  warnings=[]) for f in ds.faults]
    extra = derive._conformable_points(ds, surfs)
    over = {}
    for lay in ("L2", "L3", "L4", "L5"):
        P = extra[lay]
        over[lay] = int(np.sum(np.abs(P[:, 2] - geo.truth(lay, P[:, 0], P[:, 1])) > 10.0))
    assert over["L2"] == over["L3"] == over["L5"] == 0 and sum(over.values()) <= 5, over


def test_a_thickness_wave_is_no_step_across_a_fault_that_cuts_neither_layer(evaluated):
    """Regression (random_ground(89) as v2 with section picks: F1 cuts L4
    and L5 only, F2 every layer alike; L2 and L3 are known from holes and
    made conformable to the picked L1). Their offsets from L1, fitted as a
    plane plus a step per fault, stepped by -4.6 / -4.2 m across F1 and
    +3.9 / +3.7 m across F2, at 3 and 2.5 standard errors: the plane's
    residuals (a thickness that varies in waves) are not independent, so
    the error flattered the steps, and whole blocks of L2 and L3 moved by
    them (error near the faults 2.16x the true cutoffs' model). A step is
    now kept only where it also predicts the offsets better in the gate's
    cross-validation (derive._steps_predict): refused here, 1.68x (the
    ground still fails on F1's L4/L5 hanging wall)."""
    out, built = evaluated(89)
    rep = built["derived"].derivation
    for lay in ("L2", "L3"):
        rec = rep.layers[lay]
        assert rec["reference"] == "L1" and rec.get("points", 0) > 0, rec
        assert "steps_kept" not in rec and set(rec["steps_refused"]) == {"F1", "F2"}, rec
    assert out["ratio"] < 1.9, (out["error_v1"], out["error_v2"])


@pytest.mark.parametrize("seed, fault, bound, ratio", [(56, "F1", 9.0, 1.3), (78, "F2", 15.0, gr.V2_RATIO)])
def test_a_fault_of_a_crossing_pair_gets_the_fading_throw_fit_in_each_block(seed, fault, bound, ratio, evaluated):
    """Regression (random grounds as v2 with section picks, a normal fault
    crossing another, X: 56 F1 with F2, 78 F2 with F1): each section of
    such a fault takes its sides from the data of its fault block, and
    those sections never got the fading-throw fit (derive._decay_sides),
    only the block's own surfaces, which extrapolate the fading bend of the
    hanging wall up to the fault: 56 F1's middle section 33 m off, 78 F2's
    hanging wall 14-17 m off on three sections (error near the faults 1.30x
    and 1.40x the true cutoffs' model). The fit now runs once per block on
    the block's data (derive._decay_sections). Bounds: every hanging-wall
    cutoff of that fault within ``bound`` m of the truth (measured at most
    5.4 and 13.2 m; before 33.5 and 17.3 m; 56's 8.3 m since the fading
    fit's smoothing length is a quarter of the data spacing,
    derive.DECAY_SMOOTHING, its ratio 1.13 -> 0.95x), the model within 1.25x (0.75x)
    for 78 and 1.3x for 56: 1.30x before, then 1.23x, and 1.25x since the
    layer TIN's boundary extrapolation changed (both of its models got
    better, the true cutoffs' more: 2.13 -> 2.08 m and 2.63 -> 2.61 m; its
    excess lies along F3 and F4, not F1)."""
    out, _ = evaluated(seed)
    assert out["ratio"] is not None, (out["stage"], out["error"])     # derived, built, checked
    d = np.asarray(out["cutoffs"][fault]["L1"]["hanging"], dtype=np.float64)
    assert np.nanmax(d) <= bound, d
    assert out["ratio"] <= ratio, (out["error_v1"], out["error_v2"])


def test_a_block_offset_whose_throw_changes_sense_gives_way_to_a_fading_throw(evaluated):
    """Regression (random ground 61 as v2 with section picks: F1, normal,
    12 m, crosses F2, reverse, X). F1's L2 in F2's hanging-wall block had a
    few hanging-wall data, most of them hundreds of metres from F1; its
    fading-throw fit took the block offset (profile None), whose throw swung
    from -25 to +38 m along strike and was held at 86 m past its data. Two
    hanging-wall cutoffs came out 32 m from the truth, the model 2.03x the
    true cutoffs' error near the faults. Such a fit now gives way to the
    fading profile of next least objective (derive._one_sense): every L2
    hanging-wall cutoff of F1 within 16 m (14.6 measured), 6.8 -> 3.8 m on
    average; the ground fails for F3 still (1.54x)."""
    out, _ = evaluated(61)
    assert out["ratio"] is not None, (out["stage"], out["error"])
    d = np.asarray(out["cutoffs"]["F1"]["L2"]["hanging"], dtype=np.float64)
    assert np.nanmax(d) <= 16.0 and np.nanmean(d) <= 5.0, d
    assert out["ratio"] <= 1.6, (out["error_v1"], out["error_v2"])


def test_a_datum_within_a_partners_band_is_in_no_fault_block(tmp_path):
    """Regression (random ground 36 as v2 with section picks and a 3 m
    picking error on the fault sticks: F2, reverse, abuts F1, reverse, from
    F1's footwall, a T). An L4 top 2 m from F1, in F1's hanging wall, fell
    on the footwall side of F1's TIN through the noisy picks, into F2's
    hanging-wall block there (F2 does not reach F1's hanging wall); that
    block's L4 throws swung from -10 to -35 m where every other layer has
    -22 to -25 m, F2's L4 hanging-wall cutoffs up to 24 m off, the model
    1.251x the true cutoffs' error near the faults. A datum within a
    partner's band (2.5 picking errors) is now in no fault block: F2's L4
    hanging-wall cutoffs within 1.4 m (measured), 0.93x."""
    out = gr.evaluate_ground_v2(36, tmp_path, fault_noise=3.0)
    assert out["ratio"] is not None, (out["stage"], out["error"])
    d = np.asarray(out["cutoffs"]["F2"]["L4"]["hanging"], dtype=np.float64)
    assert np.nanmax(d) <= 4.0, d
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_a_fault_abutting_a_partner_from_its_hanging_wall_takes_the_partners_drag_out(evaluated):
    """Regression (random ground 90 as v2 with section picks: F2, reverse,
    abuts F1, normal, from F1's hanging wall, a T): F1's hanging wall drops
    by its throw's fading share, 48 m within 400 m of F1, and F2's footwall
    there is a minimum-curvature surface through that drop: it overshot by
    8-16 m over 800 m of F2's strike (F2's footwall cutoffs 4.1-6.0 m from
    the truth on average per layer, up to 22 m; the model 1.37x the true
    cutoffs' error near the faults). F2's blocks now fit their data with
    F1's fading throw (from F1's own fading-throw fit) added back, and take
    it off the surfaces again (derive._block_fades, _restored): 0.9-1.9 m
    on average, 1.07x (1.03x since F2's end on F1 is no tip). Since the
    fading-throw fit's finer grid of profiles 0.5-3.5 m, 1.04x: F1's
    hanging-wall data lie within 100 m of it or beyond 500 m, and between
    them its profile is free; the least objective's (200, 350) m put the
    L1 section where F2 meets F1 24 m off on both sides (the throw right to
    0.1 m), the mean over L1's ten sections 3.5 m. Bound 4 m: the overshoot
    guarded against was 4.1-6.0 m on every layer."""
    out, built = evaluated(90)
    assert out["ratio"] is not None, (out["stage"], out["error"])
    foot = [np.nanmean(np.asarray(out["cutoffs"]["F2"][lay]["foot"], dtype=np.float64))
            for lay in ("L1", "L2", "L3", "L4")]
    assert max(foot) <= 4.0 and np.median(foot) <= 2.5, foot
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_a_partners_drag_is_taken_off_at_the_elevation_it_was_added_at(evaluated, monkeypatch):
    """The partner's fading throw is added to each datum at the datum's own
    elevation (derive._PartnerFade.at_data) and taken off a surface S at
    the elevation z = S - T g(d(z)) it then has (at_surface): the two agree
    where they meet, so a datum restored and put back lands where it was
    (ground 90, F1's drag in F2's blocks, every layer), and the drag is
    whole at F1 and none far into its hanging wall."""
    from faultmesh import derive

    _, built = evaluated(90)
    got = []
    real = derive._block_fades

    def recorded(*a, **k):
        out = real(*a, **k)
        got.extend(f for fs in out.values() for f in fs)
        return out

    monkeypatch.setattr(derive, "_block_fades", recorded)
    derive.derive_faults(built["ds2"])
    assert got and all(f.fs.name == "F1" for f in got)
    rng = np.random.default_rng(5)
    partial = 0
    for fade in got:
        D = fade.side.data
        q = D[rng.integers(0, len(D), 64), :2] + rng.normal(0.0, 30.0, (64, 2))
        s = rng.uniform(-80.0, 80.0, 64)
        z = s - fade.at_surface(q, s)
        back = fade.at_data(np.column_stack([q, z]))
        # 10 cm: at_surface takes the distance from F1 as linear in z over
        # the throw's height (SideSurface._own_share, one line for F1's
        # trace there), at_data reads it off the trace at z: measured up to
        # 1.1 cm apart on these draws with F1's profiles of the coarser
        # grid, 5.2 cm with those of derive.DECAY_PROFILES now ((25, 350)
        # to (200, 350) m). Taken at S instead of z, the share moves by
        # metres.
        np.testing.assert_allclose(back, s - z, atol=0.1)
        partial += int(np.sum((back > 1.0) & (back < np.abs(fade.throw(q)) - 1.0)))
    assert partial > 0        # some points lie where the throw fades
    share = derive._decay_share(np.array([0.0, 5000.0]), got[0].side.profile)
    assert share[0] == 1.0 and share[1] == 0.0


def test_the_fading_throw_falls_to_zero_towards_a_tip(evaluated):
    """Regression (random ground 77 as v2 with section picks: F1, normal,
    tips at both ends): the fading-throw fit's throw was held at its last
    value beyond the hanging-wall data that show it, up to the tip, and the
    fit's hanging wall kept the whole throw where the fault dies out: L2's
    and L3's hanging-wall cutoffs on the section nearest the tip 18 and 17 m
    off (the model 0.87x the true cutoffs'). It now falls straight to zero
    at the extent's edge towards a tip (derive._tip_taper, as the cutoff
    throws' taper): 2 and 1 m, 0.68x."""
    out, _ = evaluated(77)
    assert out["ratio"] is not None, (out["stage"], out["error"])
    for lay in ("L2", "L3"):
        d = np.asarray(out["cutoffs"]["F1"][lay]["hanging"], dtype=np.float64)
        assert np.nanmax(d) <= 6.0, (lay, d)
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_the_tip_taper_keeps_the_throw_towards_the_boundary_and_a_partner(evaluated):
    """derive._tip_taper on ground 90's faults: F1 reaches the boundary at
    both ends, F2 at one and abuts F1 at the other (FaultSurface.abuts):
    neither dies out, the throw is kept whole to the extent's edges. Were
    F2's end on F1 a tip, the share would fall from 1 at the last datum to
    0 at the edge along the fault's throw profile (derive._throw_profile,
    1 - x^2 from the untipped end: above the straight line)."""
    from faultmesh import derive

    _, built = evaluated(90)
    rep = built["derived"].derivation
    f1, f2 = rep.faults["F1"].surface, rep.faults["F2"].surface
    assert f1.abuts == [None, None] and f2.abuts == [None, "F1"], (f1.abuts, f2.abuts)
    assert f2.ends == ["boundary", "inside"] and rep.faults["F2"].ends == ["boundary", "partner"]
    assert not len(built["derived"].fault("F2").tips)
    for fs in (f1, f2):
        u = np.linspace(*fs.u_range, 9)
        np.testing.assert_array_equal(derive._tip_taper(fs, u, np.array([-100.0, 100.0])), 1.0)
    tipped = dataclasses.replace(f2, abuts=[None, None])
    u0, u1 = tipped.u_range
    share = derive._tip_taper(tipped, np.array([0.0, 100.0, 0.5 * (100.0 + u1), u1, u1 + 50.0]),
                              np.array([-100.0, 100.0]))
    mid = 0.5 * (100.0 + u1)
    expect = (1.0 - ((mid - u0) / (u1 - u0)) ** 2) / (1.0 - ((100.0 - u0) / (u1 - u0)) ** 2)
    assert expect > 0.5
    np.testing.assert_allclose(share, [1.0, 1.0, expect, 0.0, 0.0], atol=1e-12)


def test_the_partners_drag_comes_out_whatever_the_faults_order(evaluated):
    """The fault that abuts a partner from its hanging wall is derived
    after it, whichever comes first in the dataset: ground 90 with its
    faults listed F2 before F1 derives the same cutoffs."""
    out, built = evaluated(90)
    ds2 = built["ds2"]
    swapped = dataclasses.replace(ds2, faults=list(reversed(ds2.faults)))
    a = built["derived"].derivation
    from faultmesh.derive import derive_faults
    b = derive_faults(swapped).derivation
    assert list(b.faults) == [f.name for f in swapped.faults]
    for name, fr in a.faults.items():
        for lay, cl in fr.cutoffs.items():
            for side in ("foot", "hanging"):
                np.testing.assert_array_equal(np.asarray(cl[side]), np.asarray(b.faults[name].cutoffs[lay][side]))


@pytest.mark.parametrize("form", ["points", "surface"])
def test_a_fault_as_unlabelled_points_or_a_tsurf_derives_like_its_sticks(form, tmp_path):
    """The v2 grounds give each fault as sticks; a user may give the same
    picks without their stick column, or the interpreted surface (a GOCAD
    TSurf). Ground 82 (a reverse fault whose throw dies out 250 m short of
    the boundary) from its unlabelled picks went to the boundary with a
    fifth of the fault's length as reach (1.95x the true cutoffs' model);
    the reach is now the picks' spacing along strike, as for sticks. The
    TSurf (saved as a .ts file and read back) and the points give the
    sticks' ends, kind and, within 2 %, their ratio."""
    sticks = gr.evaluate_ground_v2(82, tmp_path / "sticks", built=(b0 := {}))
    other = gr.evaluate_ground_v2(82, tmp_path / form, fault_form=form, built=(b1 := {}))
    assert other["stage"] == "ok", (other["stage"], other["error"])
    f0, f1 = (b["derived"].derivation.faults["F1"] for b in (b0, b1))
    assert f1.surface.source == form
    assert f1.ends == f0.ends == ["tip", "tip"], (f0.ends, f1.ends)
    assert f1.kind == f0.kind == "reverse"
    assert other["ratio"] == pytest.approx(sticks["ratio"], rel=0.02), (sticks["ratio"], other["ratio"])
    if form == "surface":
        assert sorted(p.name for p in (tmp_path / form / "v2").rglob("*.ts")), "no TSurf file written"


def test_the_kind_weighs_each_layers_throw_by_how_far_its_data_lie(tmp_path):
    """Regression (random ground 290 as v2 with section picks, one of the
    unseen seeds 200-399: F2, normal, 32 m, cuts L3 only). L3 showed the
    normal throw (median +28.7 m) with data a median 180 m from its
    cutoffs; L5, which F2 does not cut, showed -32.3 m, each side's slope
    extrapolated over 620 m. The unweighted sum of the layers' medians said
    reverse, L3 was set to zero as of the wrong sense and L5 kept its
    spurious throw (1.29x the true cutoffs' error near the faults). Each
    layer now counts by how far its data lie (derive._sense_offset): F2 is
    normal, L3's cutoffs lie within 3.9 m of the truth (20.5 / 22.5 m
    before; 6.5 m since the fading fit's smoothing length is a quarter of
    the data spacing, derive.DECAY_SMOOTHING, the ratio 0.81 -> 0.60x),
    L5's throws are set to zero as of the wrong sense, 0.80x (measured)."""
    out = gr.evaluate_ground_v2(290, tmp_path)
    assert out["ratio"] is not None, (out["stage"], out["error"])
    assert out["kinds"]["F2"] == ["normal", "normal"], out["kinds"]
    for side in ("foot", "hanging"):
        d = np.asarray(out["cutoffs"]["F2"]["L3"][side], dtype=np.float64)
        assert np.nanmax(d) <= 7.5, (side, d)
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_a_datum_on_the_fault_where_the_tin_bulges_lies_on_it(tmp_path):
    """Regression (random ground 251 as v2 with section picks, one of the
    unseen seeds 200-399: F1, normal, 36 m, a bend of 22 m along strike,
    sticks 60-140 m apart). Between the sticks the fault's TIN lies 0.29 m
    off the true fault; an L1 top picked on the fault (the hanging wall's
    cutoff) lay 0.059 m from the TIN on its footwall side, over the 0.05 m
    within which a datum lies on the fault, went to the footwall and pulled
    its cutoffs down by up to 25 m (cutoffs up to 34 m off, 2.00x the true
    cutoffs' error near the fault). A datum within the TIN's chord error
    (FaultSurface.chord, estimated 0.29 m) now lies on the fault and goes
    to the side whose surface passes nearer: every cutoff within 2.5 m
    (measured), 1.03x."""
    out = gr.evaluate_ground_v2(251, tmp_path)
    assert out["ratio"] is not None, (out["stage"], out["error"])
    for side in ("foot", "hanging"):
        d = np.asarray(out["cutoffs"]["F1"]["L1"][side], dtype=np.float64)
        assert np.nanmax(d) <= 5.0, (side, d)
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_a_fading_throw_beyond_what_the_data_span_is_no_fit(tmp_path):
    """Regression (random ground 207 as v2 with section picks, one of the
    unseen seeds 200-399: F1, normal, 9 m, with F2, reverse, abutting it
    from its hanging wall, a T). In F2's hanging-wall block, F2's drag
    restored, F1's L1 fading-throw fit traded S against T where the data
    leave them undetermined: T from -181 to 1,396 m along strike over data
    spanning 47-75 m, and three hanging-wall cutoffs 144-190 m too deep
    (1.51x the true cutoffs' error near the faults). A throw over
    derive.THROW_RANGE times the data's elevation range is no fit now, and
    the sections keep their own sides: L1's hanging-wall cutoffs within
    0.7 m but for the last two (16 and 18 m), 1.14x (measured). Such a
    throw is no support for the throw along strike either: L5's section at
    u=2187 had 158 m beside a hanging-wall datum 150 m above its cutoff,
    and the sections before it took 44, 82 and 120 m from it (hanging-wall
    cutoffs 37-131 m off); now within 3 m but for the last two, 1.07x."""
    out = gr.evaluate_ground_v2(207, tmp_path)
    assert out["ratio"] is not None, (out["stage"], out["error"])
    d = np.asarray(out["cutoffs"]["F1"]["L1"]["hanging"], dtype=np.float64)
    assert np.nanmax(d[:-2]) <= 2.0 and np.nanmean(d) <= 5.0, d
    d = np.asarray(out["cutoffs"]["F1"]["L5"]["hanging"], dtype=np.float64)
    assert np.nanmax(d[:-2]) <= 5.0, d
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_the_layer_between_the_end_section_and_an_oblique_boundary_keeps_each_wall(tmp_path):
    """Regression (random ground 245 as v2 with section picks, one of the
    unseen seeds 200-399: F1, normal, runs out of the study area at both
    ends, the boundary oblique to it). Between a layer's last cut section
    and the boundary the layer was the continuous TIN's, interpolated
    across the fault between data of both walls (1.75x the true cutoffs'
    error near the faults, all of the excess in two such wedges). The
    derivation now puts points of each wall's side surface there
    (derive._carried_points, ``FaultDerivation.carried``; the derived
    dataset's ``derived_points``): 1.17x (measured). They lie in the study
    area, each within the tension length of the layer's data."""
    from faultmesh.dataset import points_in_polygon

    built = {}
    out = gr.evaluate_ground_v2(245, tmp_path, built=built)
    assert out["ratio"] is not None, (out["stage"], out["error"])
    d = built["derived"]
    fr = d.derivation.faults["F1"]
    assert fr.ends == ["boundary", "boundary"] and fr.carried, (fr.ends, list(fr.carried))
    ring = np.asarray(d.boundary, dtype=np.float64)
    for lay, q in fr.carried.items():
        assert points_in_polygon(q[:, :2], ring).all(), lay
        # They are the derived dataset's points too (after the data's).
        dp = d.derived_points[lay]
        assert len(dp) >= len(q) and np.array_equal(dp[-len(q):], q), lay
    assert out["ratio"] <= gr.V2_RATIO, (out["error_v1"], out["error_v2"])


def test_a_long_wedge_at_an_oblique_boundary_takes_the_hanging_walls_trend(tmp_path):
    """Regression (random ground 164 as v2 with section picks, held out:
    F1, normal, 31 m at L6, ends 1.2 km from where its last section's
    hanging-wall polyline meets the oblique boundary). The continuous TIN
    of that wedge ran 10 m above the hanging wall (2.51x the true cutoffs'
    error near the faults); with the hanging wall's side surface there
    1.57x (measured). It still fails: the side surface itself lies 5 m
    low on average there, data 600 m away (the true cutoffs' model is
    10 m low in part of it too). Bound: 1.8x."""
    built = {}
    out = gr.evaluate_ground_v2(164, tmp_path, built=built)
    assert out["ratio"] is not None, (out["stage"], out["error"])
    assert "L6" in built["derived"].derivation.faults["F1"].carried
    assert out["ratio"] <= 1.8, (out["error_v1"], out["error_v2"])


def test_the_carried_points_are_bounded_however_fine_the_step(tmp_path, monkeypatch):
    """derive.CARRY_MAX bounds the points per polyline: with a step of a
    millionth of the section spacing (as a fault a few centimetres long
    would have), unbounded, ground 245's wedges would ask for about 1e14
    points; bounded, each polyline side gives at most CARRY_MAX."""
    from faultmesh import derive as dv

    _, _, ds2 = _v1_and_v2_with_picks(245, tmp_path)
    monkeypatch.setattr(dv, "CARRY_STEP", 1e-6)
    fr = dv.derive_faults(ds2).derivation.faults["F1"]
    n = {lay: len(q) for lay, q in fr.carried.items()}
    # Two ends, two sides: at most 4 polylines per layer.
    assert n and all(0 < v <= 4 * dv.CARRY_MAX for v in n.values()), n


def test_a_second_derivation_keeps_the_carried_points_of_the_faults_derived_before(tmp_path):
    """derive_faults on a dataset whose F1 an earlier derivation derived
    (ground 164 as v2: F1 and F2 both end on the boundary) and whose F2
    has its points again: the conformable points are made anew, and F1's
    carried points (FaultDerivation.carried) stay in ``derived_points``
    with F2's new ones."""
    from faultmesh.derive import derive_faults

    _, _, ds2 = _v1_and_v2_with_picks(164, tmp_path)
    d = derive_faults(ds2)
    first = d.derivation.faults
    assert first["F1"].carried and first["F2"].carried
    mixed = dataclasses.replace(d, faults=[d.fault("F1"), ds2.fault("F2")])
    again = derive_faults(mixed)
    assert again.fault("F2").derived and again.derivation.faults["F1"] is first["F1"]
    for name in ("F1", "F2"):
        for lay, q in again.derivation.faults[name].carried.items():
            have = {tuple(r) for r in again.derived_points[lay].tolist()}
            assert all(tuple(r) in have for r in q.tolist()), (name, lay)
