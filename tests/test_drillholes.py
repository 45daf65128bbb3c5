"""Drillhole tables (collars, surveys, intervals), desurveying by minimum
curvature and layer tops: faultmesh.drillholes."""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from helpers import fuzz_settings

from faultmesh.dataset import Boreholes, DatasetError, load_dataset
from faultmesh.datasets import synthetic
from faultmesh.drillholes import (HORIZONTAL_DIP, TOUCH_TOLERANCE, CollarTable, Drillholes,
                                  SurveyTable, load_drillholes, read_collars, read_intervals,
                                  read_surveys)


def hole(stations=(), collar=(0.0, 0.0, 0.0)) -> Drillholes:
    """One hole "H" with survey stations [(depth, azimuth, dip), ...]."""
    c = CollarTable(["H"], [collar])
    s = None
    if stations:
        d, a, p = zip(*stations)
        s = SurveyTable(["H"] * len(d), d, a, p)
    return Drillholes(c, s)


# ---------------------------------------------------------------------------
# Desurveying against minimum curvature worked by hand
# ---------------------------------------------------------------------------
# Direction of a station: t = (cos(dip) sin(az), cos(dip) cos(az), sin(dip))
# in (east, north, up). Between stations t1, t2 at depths d1 < d2: dogleg
# DL = angle(t1, t2), ratio factor RF = 2/DL tan(DL/2) (1 if DL = 0), step
# (d2 - d1)/2 * RF * (t1 + t2). The numbers below are that arithmetic done
# with a pocket calculator's precision (8 decimals).

def test_vertical_hole_without_surveys():
    # No stations: straight down from the collar, z = 150 - depth.
    h = hole(collar=(1000.0, 2000.0, 150.0))
    p = h.positions("H", [0.0, 37.5, 250.0])
    assert np.array_equal(p, [[1000.0, 2000.0, 150.0], [1000.0, 2000.0, 112.5],
                              [1000.0, 2000.0, -100.0]])


def test_vertical_hole_with_surveys_keeps_the_collar_xy_exactly():
    # dip -90 is straight down whatever the azimuth says.
    h = hole([(0.0, 123.4, -90.0), (50.0, 300.0, -90.0)], collar=(1000.0, 2000.0, 150.0))
    p = h.positions("H", [10.0, 50.0, 77.25])
    assert np.array_equal(p[:, :2], [[1000.0, 2000.0]] * 3)
    assert np.array_equal(p[:, 2], [140.0, 100.0, 72.75])


@pytest.mark.parametrize("stations",
                         [[(0.0, 45.0, -60.0), (50.0, 45.0, -60.0), (100.0, 45.0, -60.0)],
                          [(20.0, 45.0, -60.0), (60.0, 45.0, -60.0)]],
                         ids=["from_collar", "first_station_deeper"])
def test_straight_inclined_hole(stations):
    # t = (cos60 sin45, cos60 cos45, -sin60) = (0.35355339, 0.35355339,
    # -0.86602540); DL = 0 so RF = 1 and every step is length * t. Above the
    # first station the hole runs along its direction, below the last straight on.
    # depth 80:  80 t = (28.28427125, 28.28427125, -69.28203230)
    # depth 130: 130 t = (45.96194078, 45.96194078, -112.58330249)
    h = hole(stations, collar=(500.0, 600.0, 10.0))
    p = h.positions("H", [80.0, 130.0]) - [500.0, 600.0, 10.0]
    np.testing.assert_allclose(p, [[28.28427125, 28.28427125, -69.28203230],
                                   [45.96194078, 45.96194078, -112.58330249]], atol=1e-8)


def test_constant_curvature_hole_is_the_exact_circle():
    # Stations every 30 m building 9 degrees per station toward the east (az 90):
    # dips -90, -81, -72, -63. Each segment: DL = 9 deg = 0.15707963 rad,
    # RF = 2/0.15707963 * tan(0.07853982) = 12.73239545 * 0.07870171 = 1.00206125,
    # first step 15 * RF * ((0, 0, -1) + (sin 9, 0, -cos 9))
    #   = 15.03091879 * (0.15643447, 0, -1.98768834) = (2.35135374, 0, -29.87678206).
    # The hole is the circle of radius R = 30 / 0.15707963 = 190.98593171 m
    # tangent to the vertical at the collar: east = R (1 - cos(s/R)),
    # z = -R sin(s/R) at arc length s; at s = 30: (2.35135374, -29.87678206), the
    # step above. Depths between stations lie on the arc, not on the chord:
    # at s = 15 the circle is at (0.58874589, -14.98458350), the chord's midpoint
    # at (1.17567687, -14.93839103), 0.59 m away.
    h = hole([(0.0, 90.0, -90.0), (30.0, 90.0, -81.0), (60.0, 90.0, -72.0), (90.0, 90.0, -63.0)])
    s = np.array([15.0, 30.0, 45.0, 60.0, 90.0])
    p = h.positions("H", s)
    expect = [[0.58874589, -14.98458350], [2.35135374, -29.87678206], [5.27695650, -44.58478032],
              [9.34751684, -59.01789859], [20.81622053, -86.70579858]]
    np.testing.assert_allclose(p[:, [0, 2]], expect, atol=1e-8)
    np.testing.assert_allclose(p[:, 1], 0.0, atol=1e-12)
    # The same against the circle evaluated here, at many depths.
    R = 30.0 / math.radians(9.0)
    s = np.linspace(0.0, 90.0, 181)
    p = h.positions("H", s)
    np.testing.assert_allclose(p[:, 0], R * (1 - np.cos(s / R)), atol=1e-9)
    np.testing.assert_allclose(p[:, 2], -R * np.sin(s / R), atol=1e-9)
    # The direction along the arc turns uniformly: at s, dip = -90 + 9 s / 30.
    t = h.directions("H", [45.0])[0]
    a = math.radians(13.5)
    np.testing.assert_allclose(t, [math.sin(a), 0.0, -math.cos(a)], atol=1e-12)


def test_dog_leg_hole():
    # Vertical to 100 m, a 30 degree dog-leg toward the east by 130 m
    # (az 90, dip -60), then straight to 200 m.
    # 100 -> 130: DL = 30 deg = 0.52359878, RF = 2/0.52359878 * tan(15 deg)
    #   = 3.81971863 * 0.26794919 = 1.02349052; step = 15 * RF * ((0,0,-1) +
    #   (0.5, 0, -0.86602540)) = 15.35235785 * (0.5, 0, -1.86602540)
    #   = (7.67617893, 0, -28.64788976); at 130: (7.67617893, 0, -128.64788976).
    # 130 -> 200: DL = 0, step 70 * (0.5, 0, -0.86602540) = (35, 0, -60.62177826);
    #   at 200: (42.67617893, 0, -189.26966802).
    # At 115, half-way round the arc of radius 30 / 0.52359878 = 57.29577951 m:
    #   (R (1 - cos 15), -100 - R sin 15) = (1.95230634, -114.82923894).
    h = hole([(0.0, 0.0, -90.0), (100.0, 0.0, -90.0), (130.0, 90.0, -60.0), (200.0, 90.0, -60.0)])
    p = h.positions("H", [100.0, 115.0, 130.0, 200.0, 250.0])
    np.testing.assert_allclose(p, [[0.0, 0.0, -100.0], [1.95230634, 0.0, -114.82923894],
                                   [7.67617893, 0.0, -128.64788976],
                                   [42.67617893, 0.0, -189.26966802],
                                   [42.67617893 + 25.0, 0.0, -189.26966802 - 43.30127019]],
                               atol=1e-8)


def test_dog_leg_turning_in_azimuth():
    # az 0 -> az 90 at dip -60: t1 = (0, 0.5, -0.86602540), t2 = (0.5, 0, -0.86602540),
    # cos DL = t1.t2 = 0.75, DL = 0.72273425 rad, tan(DL/2) = sqrt(0.25/1.75)
    # = 0.37796447, RF = 2 * 0.37796447 / 0.72273425 = 1.04592933; step over
    # 100 m: 50 * RF * (0.5, 0.5, -1.73205081) = (26.14823320, 26.14823320, -90.58013685).
    h = hole([(0.0, 0.0, -60.0), (100.0, 90.0, -60.0)], collar=(10.0, 20.0, 30.0))
    p = h.positions("H", [100.0])[0] - [10.0, 20.0, 30.0]
    np.testing.assert_allclose(p, [26.14823320, 26.14823320, -90.58013685], atol=1e-8)


def test_azimuth_wraps_around_north():
    # az 359 -> 1 at dip -45 turns by 2 degrees of azimuth, not 358:
    # |t2 - t1| = 2 cos45 sin1, DL = 2 asin(cos45 sin1) = 0.02468206 rad,
    # RF = 1.00005077; the east components cancel and the step over 100 m is
    # 50 * RF * (0, 2 cos45 cos1, -2 sin45) = (0, 70.70349798, -70.71426811).
    h = hole([(0.0, 359.0, -45.0), (100.0, 1.0, -45.0)])
    p = h.positions("H", [100.0])[0]
    np.testing.assert_allclose(p, [0.0, 70.70349798, -70.71426811], atol=1e-8)
    # Mid-way the hole heads due north: the arc is symmetric about it.
    t = h.directions("H", [50.0])[0]
    assert abs(t[0]) < 1e-12 and t[1] > 0
    # The mirror hole (1 -> 359) is the mirror image.
    m = hole([(0.0, 1.0, -45.0), (100.0, 359.0, -45.0)])
    q = m.positions("H", np.linspace(0, 150, 7))
    r = h.positions("H", np.linspace(0, 150, 7))
    np.testing.assert_allclose(q, r * [-1.0, 1.0, 1.0], atol=1e-12)


def test_positions_vectorised_over_holes_equal_one_hole_at_a_time():
    rng = np.random.default_rng(3)
    n = 40
    ids = [f"H{i}" for i in range(n)]
    c = CollarTable(ids, rng.uniform(-1e3, 1e3, size=(n, 3)) + [5e5, 6e6, 0.0])
    sid, sd, sa, sp = [], [], [], []
    for i in range(n):
        k = int(rng.integers(0, 5))
        sid += [ids[i]] * k
        sd += list(np.cumsum(rng.uniform(5.0, 60.0, size=k)))
        sa += list(rng.uniform(0.0, 360.0, size=k))
        sp += list(rng.uniform(-89.0, -30.0, size=k))
    d = Drillholes(c, SurveyTable(sid, sd, sa, sp))
    qh = rng.integers(0, n, size=500)
    qd = rng.uniform(0.0, 300.0, size=500)
    together = d.positions(qh, qd)
    for i in range(n):
        sel = qh == i
        one = Drillholes(CollarTable([ids[i]], c.xyz[i:i + 1]),
                         SurveyTable([x for x in sid if x == ids[i]],
                                     [v for x, v in zip(sid, sd) if x == ids[i]],
                                     [v for x, v in zip(sid, sa) if x == ids[i]],
                                     [v for x, v in zip(sid, sp) if x == ids[i]]))
        np.testing.assert_array_equal(one.positions(ids[i], qd[sel]), together[sel])
    # Hole ids and row indices address the same holes.
    np.testing.assert_array_equal(d.positions(np.array(ids)[qh], qd), together)


# ---------------------------------------------------------------------------
# Properties
# ---------------------------------------------------------------------------
@st.composite
def hole_surveys(draw, max_turn=30.0):
    """A hole: (depth, azimuth, dip) stations with realistic doglegs (up to
    ``max_turn`` degrees of azimuth and 20 of dip between stations at least
    10 m apart)."""
    k = draw(st.integers(1, 6))
    d0 = draw(st.floats(0.0, 50.0))
    steps = draw(st.lists(st.floats(10.0, 100.0), min_size=k - 1, max_size=k - 1))
    az = draw(st.floats(0.0, 360.0))
    dip = draw(st.floats(-90.0, -5.0))
    out = [(d0, az, dip)]
    for s in steps:
        az = (az + draw(st.floats(-max_turn, max_turn))) % 360.0
        dip = float(np.clip(dip + draw(st.floats(-20.0, 20.0)), -90.0, 90.0))
        out.append((out[-1][0] + s, az, dip))
    return out


@given(hole_surveys())
def test_path_length_equals_measured_depth(stations):
    # Minimum curvature is a chain of circular arcs and straight lines with
    # the measured length: the polyline through 0.05 m steps is that long up
    # to the chord-vs-arc deficit (kappa h)^2 / 24 per unit length, below
    # 3e-7 for curvatures up to 36 degrees per 10 m.
    h = hole(stations, collar=(3e5, 4e6, 100.0))
    end = stations[-1][0] + 20.0
    s = np.linspace(0.0, end, int(end / 0.05) + 1)
    p = h.positions("H", s)
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    assert np.all(seg <= np.diff(s) * (1 + 1e-12) + 1e-9)   # a chord is never longer
    assert abs(seg.sum() - end) <= 1e-6 * end
    # The directions along the path are unit vectors.
    t = np.linalg.norm(h.directions("H", s[::50]), axis=1)
    np.testing.assert_allclose(t, 1.0, atol=1e-12)


@given(st.lists(st.tuples(st.floats(1.0, 80.0), st.floats(0.0, 360.0)), min_size=1, max_size=6),
       st.lists(st.floats(0.0, 500.0), min_size=1, max_size=20))
def test_vertical_hole_gives_the_collar_xy(steps, depths):
    sd = np.cumsum([s for s, _ in steps])
    h = hole([(float(d), a, -90.0) for d, (_, a) in zip(sd, steps)], collar=(612345.5, 4.2e6, 80.0))
    p = h.positions("H", depths)
    assert np.array_equal(p[:, :2], np.tile([612345.5, 4.2e6], (len(depths), 1)))
    np.testing.assert_allclose(p[:, 2], 80.0 - np.asarray(depths), atol=1e-9)


@given(hole_surveys(), st.floats(0.0, 360.0))
def test_rotating_azimuths_rotates_plan_positions(stations, c):
    collar = np.array([1000.0, 2000.0, 50.0])
    h = hole(stations, collar=collar)
    r = hole([(d, (a + c) % 360.0, p) for d, a, p in stations], collar=collar)
    s = np.linspace(0.0, stations[-1][0] + 30.0, 50)
    p = h.positions("H", s) - collar
    q = r.positions("H", s) - collar
    # Azimuth + c turns plan vectors clockwise by c: (x, y) ->
    # (x cos c + y sin c, -x sin c + y cos c).
    a = math.radians(c)
    rot = np.column_stack([p[:, 0] * math.cos(a) + p[:, 1] * math.sin(a),
                           -p[:, 0] * math.sin(a) + p[:, 1] * math.cos(a)])
    np.testing.assert_allclose(q[:, :2], rot, atol=1e-9)
    np.testing.assert_allclose(q[:, 2], p[:, 2], atol=1e-9)


# ---------------------------------------------------------------------------
# Tops
# ---------------------------------------------------------------------------
def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def tables(tmp_path, collars, surveys, intervals):
    return (write(tmp_path / "collars.csv", collars),
            write(tmp_path / "surveys.csv", surveys) if surveys is not None else None,
            write(tmp_path / "intervals.csv", intervals))


def test_tops_reverse_fault_repeats_a_layer(tmp_path):
    # Vertical hole logged A, B, C, then across a reverse fault A, B, C again.
    # Tops: A at the collar, B and C; the C -> A contact (older over younger)
    # is the fault, no top; A -> B and B -> C give B and C their second tops.
    c, s, i = tables(tmp_path, "hole_id,x,y,z,max_depth\nH1,100,200,50,120\n", None,
                     "hole_id,from,to,unit\nH1,0,10,A\nH1,10,30,B\nH1,30,40,C\nH1,40,45,A\n"
                     "H1,45,50,B\nH1,50,70,C\nH1,70,120,unknown\n")
    b = load_drillholes(c, s, i, ["A", "B", "C"], other_units=["unknown"])
    assert b.hole_id.tolist() == ["H1"] * 5
    assert b.layer.tolist() == ["A", "B", "C", "B", "C"]
    np.testing.assert_array_equal(b.z, [50.0, 40.0, 20.0, 5.0, 0.0])
    np.testing.assert_array_equal(b.xy, [[100.0, 200.0]] * 5)


# Two holes 100 m apart, each logged A, B, C from its collar down.
_TWO_COLLARS = "hole_id,x,y,z\nH1,0,0,50\nH2,100,0,50\n"
_TWO_HOLES_A_B_C = ("hole_id,from,to,unit\nH1,0,10,A\nH1,10,30,B\nH1,30,40,C\n"
                    "H2,0,12,A\nH2,12,25,B\nH2,25,40,C\n")


def test_a_layer_list_given_bottom_to_top_is_named_as_the_cause(tmp_path):
    """Regression (fuzz of the v2 input): holes logged A, B, C with 'layers'
    given as [C, B, A] gave no tops at all (every contact against the order)
    and the build stopped at "layer 'C' has 0 data points" without saying
    why. Now the tops refuse it, naming the file, a row and the order; a
    hole going up is judged by the way it goes. One reverse fault in one
    hole (above) is no such case."""
    c, s, i = tables(tmp_path, _TWO_COLLARS, None, _TWO_HOLES_A_B_C)
    with pytest.raises(DatasetError, match=r"intervals\.csv: 4 of the 4 contacts between layers "
                                           r".*row 3, hole 'H1': 'B' below 'A'.*bottom to top"):
        load_drillholes(c, s, i, ["C", "B", "A"])
    # Up-going holes drilled from inside C (as in the test below) with the
    # list reversed: the same message, judged by the way the holes go.
    c, s, i = tables(tmp_path, "hole_id,x,y,z\nU1,0,0,-100\nU2,50,0,-100\n",
                     "hole_id,depth,azimuth,dip\nU1,0,0,30\nU2,0,0,30\n",
                     "hole_id,from,to,unit\nU1,0,20,C\nU1,20,50,B\nU1,50,60,A\n"
                     "U2,0,20,C\nU2,20,50,B\nU2,50,60,A\n")
    assert load_drillholes(c, s, i, ["A", "B", "C"]).layer.tolist() == ["C", "B", "C", "B"]
    with pytest.raises(DatasetError, match=r"4 of the 4 contacts.*hole 'U1': 'C' below 'B'"):
        load_drillholes(c, s, i, ["C", "B", "A"])


def test_surveys_with_dips_positive_downwards_are_named_as_a_possible_cause(tmp_path):
    """Regression (fuzz of drillhole tables): surveys written with dips
    positive downwards (+60 for a hole going down at 60 degrees) send the
    holes up; the error asked only whether 'layers' was bottom to top.
    Now it also names the dip convention, with how many contacts lie where
    the holes go up."""
    c, s, i = tables(tmp_path, _TWO_COLLARS, "hole_id,depth,azimuth,dip\nH1,0,90,60\nH2,0,90,60\n",
                     _TWO_HOLES_A_B_C)
    with pytest.raises(DatasetError, match=r"4 of the 4 contacts.*bottom to top.*dips positive "
                                           r"downwards\? 4 of these contacts lie where the hole goes up"):
        load_drillholes(c, s, i, ["A", "B", "C"])
    # Down-going holes with the list reversed: no word of the dips.
    c, s, i = tables(tmp_path, _TWO_COLLARS, "hole_id,depth,azimuth,dip\nH1,0,90,-60\nH2,0,90,-60\n",
                     _TWO_HOLES_A_B_C)
    with pytest.raises(DatasetError, match=r"bottom to top instead of top to bottom\?$"):
        load_drillholes(c, s, i, ["C", "B", "A"])


def test_tops_of_a_deviated_hole_have_their_own_xy(tmp_path):
    # Straight hole at az 90, dip -60: depth d is at (x0 + d/2, y0, z0 - d sqrt3/2).
    c, s, i = tables(tmp_path, "hole_id,x,y,z\nD1,300,200,40\n",
                     "hole_id,depth,azimuth,dip\nD1,0,90,-60\nD1,100,90,-60\n",
                     "hole_id,from,to,unit\nD1,0,20,A\nD1,20,35,B\nD1,35,60,gouge\nD1,60,80,C\n")
    b = load_drillholes(c, s, i, ["A", "B", "C"], other_units=["gouge", "unknown"])
    # The gouge (a unit that is not a layer) hides the position of C's top.
    assert b.layer.tolist() == ["A", "B"]
    np.testing.assert_allclose(b.xy, [[300.0, 200.0], [310.0, 200.0]], atol=1e-12)
    np.testing.assert_allclose(b.z, [40.0, 40.0 - 20.0 * math.sqrt(3) / 2], atol=1e-12)


def test_tops_of_a_hole_going_up(tmp_path):
    # An underground hole drilled upward at dip +30 from inside C: it leaves C
    # through C's top (into B) and B through B's top (into A). The collar is
    # no top (the hole goes up there).
    c, s, i = tables(tmp_path, "hole_id,x,y,z\nU1,0,0,-100\n",
                     "hole_id,depth,azimuth,dip\nU1,0,0,30\n",
                     "hole_id,from,to,unit\nU1,0,20,C\nU1,20,50,B\nU1,50,60,A\n")
    b = load_drillholes(c, s, i, ["A", "B", "C"])
    assert b.layer.tolist() == ["C", "B"]
    np.testing.assert_allclose(b.z, [-100.0 + 20 * 0.5, -100.0 + 50 * 0.5], atol=1e-12)
    np.testing.assert_allclose(b.xy[:, 1], [20 * math.sqrt(3) / 2, 50 * math.sqrt(3) / 2],
                               atol=1e-12)


def test_first_interval_below_the_collar_gives_no_top(tmp_path):
    c, s, i = tables(tmp_path, "hole_id,x,y,z\nH,0,0,0\n", None,
                     "hole_id,from,to,unit\nH,5,10,A\nH,10,20,B\n")
    b = load_drillholes(c, s, i, ["A", "B"])
    assert b.layer.tolist() == ["B"] and b.z.tolist() == [-10.0]


def test_touching_tolerance(tmp_path):
    # 0.4 mm apart: touching (the deeper interval's 'from' is the contact).
    c, s, i = tables(tmp_path, "hole_id,x,y,z\nH,0,0,0\n", None,
                     "hole_id,from,to,unit\nH,0,10.0004,A\nH,10,20,B\n")
    b = load_drillholes(c, s, i, ["A", "B"])
    assert b.z.tolist() == [0.0, -10.0]
    assert TOUCH_TOLERANCE == 0.5e-3


# ---------------------------------------------------------------------------
# Validation: every error names the file, the row and the field
# ---------------------------------------------------------------------------
COLLARS = "hole_id,x,y,z,max_depth\nH1,0,0,100,80\nH2,50,0,100,\n"
SURVEYS = "hole_id,depth,azimuth,dip\nH1,0,90,-80\nH1,40,95,-75\nH2,10,0,-60\n"
INTERVALS = ("hole_id,from,to,unit\nH1,0,30,A\nH1,30,60,B\nH1,60,80,C\n"
             "H2,0,25,A\nH2,25,40,unknown\nH2,40,90,B\n")


def edit(text: str, line: int, new: str) -> str:
    rows = text.splitlines()
    rows[line - 1] = new
    return "\n".join(rows) + "\n"


BAD = [
    # (table, line, replacement, file, row, field, words in the message)
    ("collars", 3, "H1,50,0,100,", "collars", 3, "hole_id", "already has a collar (row 2)"),
    ("collars", 2, "H1,abc,0,100,80", "collars", 2, "x", "not a number"),
    ("collars", 2, "H1,0,0,100,-5", "collars", 2, "max_depth", "not a positive"),
    ("collars", 2, ",0,0,100,80", "collars", 2, "hole_id", "missing value"),
    ("surveys", 4, "H9,10,0,-60", "surveys", 4, "hole_id", "unknown hole 'H9'"),
    ("surveys", 3, "H1,0,95,-75", "surveys", 3, "depth", "not greater than the previous"),
    ("surveys", 2, "H1,-1,90,-80", "surveys", 2, "depth", "negative"),
    ("surveys", 3, "H1,40,360.5,-75", "surveys", 3, "azimuth", "outside 0..360"),
    ("surveys", 3, "H1,40,-0.5,-75", "surveys", 3, "azimuth", "outside 0..360"),
    ("surveys", 3, "H1,40,95,-90.5", "surveys", 3, "dip", "outside -90..90"),
    ("surveys", 3, "H1,90,95,-75", "surveys", 3, "depth", "past the end of hole 'H1'"),
    ("surveys", 3, "H1,40,270,80", "surveys", 3, "azimuth", "turns back onto itself"),
    ("intervals", 5, "H7,0,25,A", "intervals", 5, "hole_id", "unknown hole 'H7'"),
    ("intervals", 2, "H1,-2,30,A", "intervals", 2, "from", "negative"),
    ("intervals", 3, "H1,30,30,B", "intervals", 3, "to", "not greater than 'from'"),
    ("intervals", 3, "H1,31,60,B", "intervals", 3, "from", "gap of 1 m"),
    ("intervals", 3, "H1,29.9,60,B", "intervals", 3, "from", "overlap of 0.1 m"),
    ("intervals", 7, "H2,40,90,D", "intervals", 7, "unit", "unknown unit 'D'"),
    ("intervals", 4, "H1,60,80.7,C", "intervals", 4, "to", "past the end of hole 'H1'"),
]


@pytest.mark.parametrize("table,line,new,file,row,field,words", BAD,
                         ids=[f"{b[0]}-{b[5]}-{b[6].split()[0]}" for b in BAD])
def test_errors_name_file_row_and_field(tmp_path, table, line, new, file, row, field, words):
    base = tmp_path / "base"
    base.mkdir()
    load_drillholes(*tables(base, COLLARS, SURVEYS, INTERVALS), ["A", "B", "C"],
                    other_units=["unknown"])  # the unedited tables load
    text = {"collars": COLLARS, "surveys": SURVEYS, "intervals": INTERVALS}
    text[table] = edit(text[table], line, new)
    c, s, i = tables(tmp_path, text["collars"], text["surveys"], text["intervals"])
    with pytest.raises(DatasetError) as e:
        load_drillholes(c, s, i, ["A", "B", "C"], other_units=["unknown"])
    msg = str(e.value)
    assert str(tmp_path / f"{file}.csv") in msg, msg
    assert f"row {row}," in msg and f"field {field!r}" in msg, msg
    assert words in msg, msg


def test_error_contact_in_a_horizontal_hole(tmp_path):
    c, s, i = tables(tmp_path, "hole_id,x,y,z\nH,0,0,0\n",
                     "hole_id,depth,azimuth,dip\nH,0,0,-0.05\n",
                     "hole_id,from,to,unit\nH,0,10,A\nH,10,20,B\n")
    with pytest.raises(DatasetError, match=re.escape(f"{i}, row 3, field 'from'") +
                       ".*within 0.1 degrees of horizontal"):
        load_drillholes(c, s, i, ["A", "B"])
    assert HORIZONTAL_DIP == 0.1


def test_error_header_and_row_shape(tmp_path):
    c = write(tmp_path / "c.csv", "hole_id,x,y\nH,0,0\n")
    with pytest.raises(DatasetError, match=re.escape(f"{c}, row 1: header lacks column(s) ['z']")):
        read_collars(c)
    s = write(tmp_path / "s.csv", "# survey export\nhole_id,depth,azimuth,dip\nH,0,0\n")
    with pytest.raises(DatasetError, match=re.escape(f"{s}, row 3: expected 4 fields, got 3")):
        read_surveys(s)
    i = write(tmp_path / "i.csv", "hole_id,from,to,unit,from\nH,0,1,A,0\n")
    with pytest.raises(DatasetError, match=re.escape(f"{i}, row 1: column 'from' appears more")):
        read_intervals(i)
    with pytest.raises(DatasetError, match="not found"):
        read_intervals(tmp_path / "missing.csv")


def test_other_units_must_not_be_layers(tmp_path):
    c, s, i = tables(tmp_path, COLLARS, SURVEYS, INTERVALS)
    with pytest.raises(DatasetError, match=r"other units \['A'\] are also layers"):
        load_drillholes(c, s, i, ["A", "B", "C"], other_units=["unknown", "A"])


def test_unknown_unit_suggests_other_units(tmp_path):
    c, s, i = tables(tmp_path, COLLARS, SURVEYS, INTERVALS)
    with pytest.raises(DatasetError, match=re.escape(f"{i}, row 6, field 'unit': unknown unit "
                                                     "'unknown'") + ".*other_units"):
        load_drillholes(c, s, i, ["A", "B", "C"])


def test_holes_without_intervals_and_empty_tables(tmp_path):
    c, s, i = tables(tmp_path, "hole_id,x,y,z\nH,0,0,0\n", "hole_id,depth,azimuth,dip\n",
                     "hole_id,from,to,unit\n")
    b = load_drillholes(c, s, i, ["A"])
    assert len(b) == 0 and b.xy.shape == (0, 2)


# ---------------------------------------------------------------------------
# Equivalence with a known ground
# ---------------------------------------------------------------------------
def _dir(az, dip):
    a, p = np.radians(az), np.radians(dip)
    return np.array([np.cos(p) * np.sin(a), np.cos(p) * np.cos(a), np.sin(p)])


def arc_path(collar, stations, depth):
    """Positions at ``depth`` of the hole through (depth, az, dip) stations,
    built here independently of faultmesh.drillholes: circular arcs in the
    plane of the two stations' directions, p = p1 + R (sin(th) t1 +
    (1 - cos(th)) n) with n the unit normal towards t2 and th = s / R."""
    depth = np.asarray(depth, dtype=float)
    stations = stations or [(0.0, 0.0, -90.0)]  # no stations: vertical
    st_d = [s[0] for s in stations]
    st_t = [_dir(s[1], s[2]) for s in stations]
    if st_d[0] > 0:
        st_d, st_t = [0.0] + st_d, [st_t[0]] + st_t
    pos = [np.asarray(collar, dtype=float)]
    out = np.empty((len(depth), 3))
    for k in range(len(st_d)):
        t1 = st_t[k]
        last = k == len(st_d) - 1
        sel = (depth >= st_d[k]) & (last | (depth < (st_d[k + 1] if not last else 0)))
        if last:
            out[sel] = pos[k] + (depth[sel] - st_d[k])[:, None] * t1
            break
        t2, L = st_t[k + 1], st_d[k + 1] - st_d[k]
        beta = math.acos(float(np.clip(t1 @ t2, -1.0, 1.0)))
        if beta < 1e-12:
            out[sel] = pos[k] + (depth[sel] - st_d[k])[:, None] * t1
            pos.append(pos[k] + L * t1)
            continue
        n = (t2 - math.cos(beta) * t1) / math.sin(beta)
        R = L / beta
        th = (depth[sel] - st_d[k]) / R
        out[sel] = pos[k] + R * (np.sin(th)[:, None] * t1 + (1 - np.cos(th))[:, None] * n)
        pos.append(pos[k] + R * (math.sin(beta) * t1 + (1 - math.cos(beta)) * n))
    return out


def unit_at(geo, P):
    """Rank of the layer the points (n, 3) are in (-1 above the top layer):
    on each point's side of the (single) fault, the number of layer tops at
    or above it, minus one."""
    f = geo.faults[0].name
    hw = P[:, 2] > geo.plane_z(f, P[:, 0], P[:, 1])
    tops = np.empty((len(P), len(geo.layers)))
    for k, lay in enumerate(geo.layers):
        for side, m in (("hanging", hw), ("foot", ~hw)):
            if m.any():
                tops[m, k] = geo.side_value(lay, f, side, P[m, 0], P[m, 1])
    return (tops >= P[:, 2:3]).sum(axis=1) - 1, hw


def trace(geo, holes, total):
    """Contacts of each hole with the ground: {hole: [(depth, unit above,
    unit below, fault contact?)]}, depths to 1e-12 m (bisection of 0.25 m
    brackets, all holes' brackets at once)."""
    def path(which, depth):
        out = np.empty((len(depth), 3))
        for i, (_, collar, stations) in enumerate(holes):
            m = which == i
            if m.any():
                out[m] = arc_path(collar, stations, depth[m])
        return out

    s = np.arange(0.01, total, 0.25)
    which = np.repeat(np.arange(len(holes)), len(s))
    u, _ = unit_at(geo, path(which, np.tile(s, len(holes))))
    u = u.reshape(len(holes), len(s))
    hk, k = np.nonzero(u[:, 1:] != u[:, :-1])
    lo, hi, ulo = s[k], s[k + 1], u[hk, k]
    for _ in range(40):  # 0.25 m / 2**40: 2e-13 m
        mid = 0.5 * (lo + hi)
        same = unit_at(geo, path(hk, mid))[0] == ulo
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    a, ha = unit_at(geo, path(hk, lo))
    b, hb = unit_at(geo, path(hk, hi))
    out = {hid: [] for hid, _, _ in holes}
    for i, d, x, y, p, q in zip(hk, hi, a, b, ha, hb):
        out[holes[i][0]].append((float(d), int(x), int(y), bool(p != q)))
    assert all(u[:, 0] == 0), "every hole starts in the top layer"
    return out


def ground_holes(ds, rng):
    """Deviated holes (id, collar, stations): six on a grid over the area in
    random directions, six collared in the fault's hanging wall at its largest
    throw and drilled towards the footwall (azimuth strike - 90) so that they
    cross the fault at different depths. Stations every 30 m, curving a
    little between stations; angles to 0.01 degree, collars to 1 mm."""
    geo = ds.geology
    fm = geo.faults[0]
    lo, hi = ds.boundary.min(axis=0), ds.boundary.max(axis=0)
    start = [(lo + (hi - lo) * [fx, fy], float(rng.uniform(0, 360)), float(rng.uniform(-85, -55)))
             for fx in (0.2, 0.5, 0.8) for fy in (0.25, 0.75)]
    for w, dip in ((15.0, -60.0), (30.0, -60.0), (45.0, -70.0), (60.0, -60.0), (75.0, -50.0),
                   (90.0, -50.0)):
        start.append((geo.origin + fm.xy(fm.um, w)[0], (fm.strike - 90.0) % 360.0, dip))
    holes = []
    for i, (p, az, dip) in enumerate(start):
        p = np.round(p, 3)
        z = round(float(geo.truth(geo.layers[0], p[0:1], p[1:2])[0]), 3)
        turn = 4.0 if i < 6 else 1.0
        stations = []
        for d in range(0, int(TOTAL) + 1, 30):
            stations.append((float(d), round(az % 360, 2), round(dip, 2)))
            az += float(rng.uniform(-turn, turn))
            dip = min(-40.0, dip + float(rng.uniform(-turn, turn)))
        holes.append((f"D{i + 1}", (p[0], p[1], z), stations))
    return holes


def write_tables(tmp_path, layers, holes, contacts, total):
    """Collar/survey/interval CSVs as a logging program writes them: depths to
    1 mm, angles to 0.01 degree, coordinates to 1 mm."""
    c = ["hole_id,x,y,z,max_depth"]
    s = ["hole_id,depth,azimuth,dip"]
    i = ["hole_id,from,to,unit"]
    for hid, (x, y, z), stations in holes:
        c.append(f"{hid},{x:.3f},{y:.3f},{z:.3f},{total:.3f}")
        s += [f"{hid},{d:.3f},{a:.2f},{p:.2f}" for d, a, p in stations]
        start, unit = 0.0, 0
        for d, _, below, _ in contacts[hid]:
            i.append(f"{hid},{start:.3f},{d:.3f},{layers[unit] if unit >= 0 else 'void'}")
            start, unit = d, below
        i.append(f"{hid},{start:.3f},{total:.3f},{layers[unit] if unit >= 0 else 'void'}")
    return (write(tmp_path / "collars.csv", "\n".join(c) + "\n"),
            write(tmp_path / "surveys.csv", "\n".join(s) + "\n"),
            write(tmp_path / "intervals.csv", "\n".join(i) + "\n"))


def expected_tops(layers, holes, contacts):
    """The tops by the rule (all test holes go down): the collar, and every
    contact from a layer into a later layer. Exact positions."""
    ids, pts, lays = [], [], []
    for hid, collar, stations in holes:
        d = [0.0] + [c[0] for c in contacts[hid] if 0 <= c[1] < c[2]]
        u = [0] + [c[2] for c in contacts[hid] if 0 <= c[1] < c[2]]
        ids += [hid] * len(d)
        pts.append(arc_path(collar, stations, d))
        lays += [layers[k] for k in u]
    P = np.vstack(pts)
    return Boreholes(np.array(ids), P[:, :2], np.array(lays), P[:, 2])


TOTAL = 160.0  # every hole's length: past the lowest layer's top everywhere


@pytest.mark.parametrize("kind", ["normal", "reverse"])
def test_deviated_holes_give_the_grounds_tops(tmp_path, kind):
    ds = synthetic(0, kind=kind)
    geo = ds.geology
    holes = ground_holes(ds, np.random.default_rng(11))
    contacts = trace(geo, holes, TOTAL)
    # The set covers what it should: holes crossing the fault, and (reverse)
    # an older-over-younger contact with a layer repeated below it.
    assert sum(c[3] for cs in contacts.values() for c in cs) >= 4
    if kind == "reverse":
        assert sum(c[3] and c[1] > c[2] for cs in contacts.values() for c in cs) >= 4
    files = write_tables(tmp_path, geo.layers, holes, contacts, TOTAL)
    b = load_drillholes(*files, geo.layers, other_units=["void"])
    want = expected_tops(geo.layers, holes, contacts)
    if kind == "reverse":  # a layer repeated in a hole: a second top
        assert len(set(zip(want.hole_id.tolist(), want.layer.tolist()))) < len(want)
    assert b.hole_id.tolist() == want.hole_id.tolist()
    assert b.layer.tolist() == want.layer.tolist()
    # Within 1 mm of the exact contacts: rounding depths to 1 mm moves a top by
    # at most 0.5 mm along the hole.
    err = np.hypot(np.hypot(*(b.xy - want.xy).T), b.z - want.z)
    assert err.max() <= 1e-3, err.max()
    # And on the ground: within 1 mm of a sheet of the layer at the top's xy
    # (a contact across a normal fault is on the fault, which is the layer's
    # truth in its gap).
    for lay in geo.layers:
        m = b.layer == lay
        x, y = b.xy[m, 0], b.xy[m, 1]
        cand = np.column_stack([geo.sheets(lay, x, y), geo.truth(lay, x, y)])
        dz = np.nanmin(np.abs(cand - b.z[m][:, None]), axis=1)
        assert dz.max() <= 1e-3, (lay, dz.max())
    # Deviated holes really are: their tops do not share the collar's xy.
    _, first, inv = np.unique(b.hole_id, return_index=True, return_inverse=True)
    assert np.any(np.hypot(*(b.xy - b.xy[first[inv]]).T) > 10.0)


@pytest.mark.parametrize("kind", ["normal", "reverse"])
def test_vertical_holes_give_the_v1_rows(tmp_path, kind):
    # The generator's own v1 boreholes (hole_id,x,y,layer,z, written and read
    # back by the v1 loader) against collar + interval tables logged down the
    # same vertical holes: the same rows within 1 mm.
    ds = synthetic(0, kind=kind)
    geo = ds.geology
    v1 = load_dataset(ds.save(tmp_path / "v1")).boreholes
    order = np.sort(np.unique(v1.hole_id, return_index=True)[1])  # first row of each hole
    holes = [(str(v1.hole_id[k]), (round(v1.xy[k, 0], 3), round(v1.xy[k, 1], 3),
                                   round(v1.z[k], 3)), []) for k in order]
    total = float(np.max(v1.z[order]) - v1.z.min()) + 20.0
    contacts = trace(geo, holes, total)
    files = write_tables(tmp_path, geo.layers, holes, contacts, total)
    b = load_drillholes(files[0], None, files[2], geo.layers, other_units=["void"])
    assert b.hole_id.tolist() == v1.hole_id.tolist()
    assert b.layer.tolist() == v1.layer.tolist()
    assert np.abs(b.xy - v1.xy).max() <= 1e-3
    assert np.abs(b.z - v1.z).max() <= 1e-3
    if kind == "reverse":
        assert len(b) > len(np.unique(b.hole_id)) * len(geo.layers)  # a repeated layer


# ---------------------------------------------------------------------------
# Fuzz: mutated tables load or raise DatasetError naming the file and row
# ---------------------------------------------------------------------------
JUNK = ["", " ", "x", "nan", "inf", "-inf", "-1", "0", "1e308", "1e6", "361", "-91", "90", "-90",
        "H1", "H2", "H3", "A", "B", "C", "unknown", '"', '"a,b"', "1,2", "#", "0.0005", "79.9996"]


@st.composite
def mutated_tables(draw):
    """The three valid tables with 1 to 4 edits: a field replaced by junk or
    nudged by a small or large amount (to reach the depth, gap and range
    checks), rows deleted, duplicated, swapped, cut short or extended, blank
    lines, the file truncated; the header is edited in one case out of ten."""
    text = {"collars": COLLARS, "surveys": SURVEYS, "intervals": INTERVALS}
    for _ in range(draw(st.integers(1, 4))):
        name = draw(st.sampled_from(sorted(text)))
        rows = text[name].splitlines()
        if not rows:
            continue
        op = draw(st.sampled_from(["field", "field", "nudge", "nudge", "nudge", "delete",
                                   "duplicate", "swap", "drop_field", "add_field", "blank",
                                   "truncate"]))
        header = len(rows) == 1 or draw(st.integers(0, 9)) == 0
        k = 0 if header else draw(st.integers(1, len(rows) - 1))
        if op in ("field", "nudge"):
            f = rows[k].split(",")
            j = draw(st.integers(0, len(f) - 1))
            if op == "nudge":
                try:
                    v = float(f[j])
                except ValueError:
                    v = 0.0
                dv = draw(st.sampled_from([0.0004, 0.0006, 0.5, 1.0, 10.0, 90.0, 180.0, 400.0]))
                f[j] = repr(v + draw(st.sampled_from([-1.0, 1.0])) * dv)
            else:
                f[j] = draw(st.one_of(st.sampled_from(JUNK),
                                      st.floats(allow_nan=True, allow_infinity=True).map(repr),
                                      st.text(max_size=6)))
            rows[k] = ",".join(f)
        elif op == "delete":
            del rows[k]
        elif op == "duplicate":
            rows.insert(k, rows[k])
        elif op == "swap":
            j = draw(st.integers(1, len(rows) - 1)) if len(rows) > 1 else 0
            rows[k], rows[j] = rows[j], rows[k]
        elif op == "drop_field":
            rows[k] = ",".join(rows[k].split(",")[:-1])
        elif op == "add_field":
            rows[k] = rows[k] + ",7"
        elif op == "blank":
            rows.insert(k, "")
        else:
            rows = rows[:k]
        text[name] = "\n".join(rows) + "\n"
    return text


@pytest.mark.fuzz
@fuzz_settings(200)
@given(mutated_tables())
def test_fuzz_mutated_tables(tmp_path_factory, text):
    d = tmp_path_factory.mktemp("fuzz")
    files = {}
    for name, t in text.items():
        files[name] = d / f"{name}.csv"
        files[name].write_bytes(t.encode("utf-8", "surrogatepass"))
    try:
        b = load_drillholes(files["collars"], files["surveys"], files["intervals"],
                            ["A", "B", "C"], other_units=["unknown"])
    except DatasetError as e:
        msg = str(e)
        named = [n for n in files if str(files[n]) in msg]
        assert named, msg
        assert re.search(r", row \d+", msg) or "empty file" in msg or "cannot read" in msg, msg
        return
    assert isinstance(b, Boreholes)
    assert np.all(np.isfinite(b.xy)) and np.all(np.isfinite(b.z))
    assert set(b.layer.tolist()) <= {"A", "B", "C"}
