"""Perturbed datasets of faultmesh.ensemble: each source moves what it
states and nothing else, the results stay valid, streams are per
realization."""
from __future__ import annotations

import math

import numpy as np
import pytest

import faultmesh
from faultmesh.dataset import Fault, Trace
from faultmesh.ensemble import Perturbation, realization_dataset, realization_seed
from faultmesh.ensemble.perturbation import _enforce_inside, _plane_xy_at, _shear_dip, fault_frame


@pytest.fixture(scope="module")
def paper():
    return faultmesh.load_dataset(faultmesh.datasets.paper_like_path())


def _all_points(fault):
    out = [fault.tips]
    for tr in fault.traces:
        out.append(tr.plane[:, :2])
        for sides in tr.layers.values():
            out += [sides["foot"][:, :2], sides["hanging"][:, :2]]
    return np.vstack(out)


def _dist_to_plane(tr, pts):
    """Horizontal distance of points (k, 3) from the plane polyline at their depth."""
    return np.hypot(*(pts[:, :2] - _plane_xy_at(tr.plane, pts[:, 2])).T)


def test_zero_perturbation_returns_equal_data(paper):
    out = realization_dataset(paper, Perturbation(), 0, 5)
    assert out == paper and out is not paper
    assert out.faults[0] is not paper.faults[0]


def test_streams_are_per_realization_and_reproducible(paper):
    p = Perturbation(sigma_z=1.0, sigma_dip=3.0)
    a = realization_dataset(paper, p, 4, 17)
    assert a == realization_dataset(paper, p, 4, 17)
    assert not a == realization_dataset(paper, p, 4, 18)
    assert not a == realization_dataset(paper, p, 5, 17)
    kids = np.random.SeedSequence(4).spawn(20)
    assert realization_seed(4, 17).generate_state(4).tolist() == kids[17].generate_state(4).tolist()


def test_one_source_does_not_shift_the_draws_of_another(paper):
    """Common random numbers: adding a fault sigma leaves the boreholes'
    draws of the realization unchanged."""
    a = realization_dataset(paper, Perturbation(sigma_z=2.0), 0, 3)
    b = realization_dataset(paper, Perturbation(sigma_z=2.0, sigma_dip=5.0, sigma_throw=0.3), 0, 3)
    assert np.array_equal(a.boreholes.z, b.boreholes.z)
    assert all(np.array_equal(a.points[k], b.points[k]) for k in a.points)


def test_elevation_error_moves_only_z(paper):
    out = realization_dataset(paper, Perturbation(sigma_z=2.0, sigma_z_points=0.5), 0, 1)
    dz = out.boreholes.z - paper.boreholes.z
    assert np.array_equal(out.boreholes.xy, paper.boreholes.xy)
    assert 1.5 < float(np.std(dz)) < 2.5 and len(np.unique(dz)) == len(dz)
    dp = out.points["topsoil"][:, 2] - paper.points["topsoil"][:, 2]
    assert 0.35 < float(np.std(dp)) < 0.65
    assert out.faults == paper.faults


def test_position_moves_each_fault_rigidly_across_its_strike(paper):
    p = Perturbation(sigma_position=20.0)
    out = realization_dataset(paper, p, 0, 2)
    for f, g in zip(out.faults, paper.faults):
        d = _all_points(f) - _all_points(g)
        assert np.allclose(d, d[0], rtol=0, atol=1e-6)            # one vector for everything
        nu, strike = fault_frame(g)
        assert abs(float(d[0] @ strike)) < 1e-6 and abs(float(d[0] @ nu)) > 0
        for t, u in zip(f.traces, g.traces):
            assert np.array_equal(t.plane[:, 2], u.plane[:, 2])


def test_trace_jitter_moves_traces_differently_along_the_normal(paper):
    out = realization_dataset(paper, Perturbation(sigma_position_trace=10.0), 0, 3)
    f, g = out.fault("F22"), paper.fault("F22")
    nu, strike = fault_frame(g)
    shifts = [float((t.plane[0, :2] - u.plane[0, :2]) @ nu) for t, u in zip(f.traces, g.traces)]
    assert len(set(np.round(shifts, 9))) == len(shifts)
    for t, u in zip(f.traces, g.traces):
        assert np.allclose((t.plane[:, :2] - u.plane[:, :2]) @ strike, 0.0, atol=1e-6)
    assert np.array_equal(f.tips, g.tips)      # tips belong to the whole fault


def test_throw_scales_the_vertical_offset_and_keeps_the_sense(paper):
    out = realization_dataset(paper, Perturbation(sigma_throw=0.3), 0, 4)
    for f, g in zip(out.faults, paper.faults):
        ratios = []
        for t, u in zip(f.traces, g.traces):
            assert np.array_equal(t.plane, u.plane)
            for lay, s in t.layers.items():
                o = u.layers[lay]
                assert np.array_equal(s["foot"], o["foot"])
                old = o["hanging"][0, 2] - o["foot"][-1, 2]
                new = s["hanging"][0, 2] - s["foot"][-1, 2]
                if abs(old) > 1e-9:
                    ratios.append(new / old)
                # The hanging wall slid along the plane: its cutoff is still on it
                # and the polyline moved rigidly.
                assert _dist_to_plane(t, s["hanging"][:1])[0] < 1e-6 + _dist_to_plane(u, o["hanging"][:1])[0]
                mv = s["hanging"] - o["hanging"]
                assert np.allclose(mv, mv[0], atol=1e-9)
        assert np.allclose(ratios, ratios[0], rtol=1e-9) and ratios[0] > 0


def _planar_fault(dip_deg: float, az_section: float) -> Fault:
    """A planar fault striking east (dipping south) cut by a section at
    ``az_section``; cutoffs on the plane."""
    t = math.tan(math.radians(dip_deg))
    nu = np.array([0.0, -1.0])
    e = np.array([math.sin(math.radians(az_section)), math.cos(math.radians(az_section))])
    if e @ nu < 0:
        e = -e
    cosb = float(e @ nu)

    def on_plane(z, x0):   # the point of the section line through (x0, 0) at depth z
        w = -z / t / cosb  # distance along e from the outcrop line y = 0
        return np.array([x0 + w * e[0], w * e[1], z])

    traces = []
    for x0 in (0.0, 200.0):
        plane = np.array([on_plane(z, x0) for z in (-10.0, -50.0, -90.0, -130.0)])
        cf, ch = on_plane(-60.0, x0), on_plane(-80.0, x0)
        foot = np.array([cf - np.r_[40 * e, 1.0], cf])
        hang = np.array([ch, ch + np.r_[40 * e, -1.0]])
        traces.append(Trace(None, plane, {"a": {"foot": foot, "hanging": hang}}))
    return Fault("f", "normal", traces=traces)


@pytest.mark.parametrize("az", [180.0, 150.0])
def test_dip_shear_changes_the_true_dip_by_delta(az):
    f = _planar_fault(60.0, az)
    nu, _ = fault_frame(f)
    assert np.allclose(nu, [0.0, -1.0])
    for tr in f.traces:
        old = {k: v.copy() for k, v in tr.layers["a"].items()}
        plane0 = tr.plane.copy()
        _shear_dip(tr, nu, 5.0)
        assert np.array_equal(tr.plane[:, 2], plane0[:, 2])
        # True dip from the across-strike (y) drop of the sheared plane.
        p = tr.plane
        dip = math.degrees(math.atan2(p[0, 2] - p[-1, 2], abs(p[-1, 1] - p[0, 1])))
        assert dip == pytest.approx(65.0, abs=1e-9)
        # Pivot at the mean cutoff depth (-70) does not move.
        assert np.allclose(_plane_xy_at(p, np.array([-70.0])), _plane_xy_at(plane0, np.array([-70.0])))
        # Cutoffs stay on the plane; wall polylines move with their depth.
        s = tr.layers["a"]
        assert _dist_to_plane(tr, s["foot"][-1:])[0] < 1e-9
        assert _dist_to_plane(tr, s["hanging"][:1])[0] < 1e-9
        assert np.array_equal(s["foot"][:, 2], old["foot"][:, 2])


def test_walls_are_cut_at_the_boundary():
    """A wall polyline that leaves the study area ends at the boundary (the
    inside end of a bisection to 1 mm); one whose cutoff is outside is an
    error naming the fault, trace, layer and side."""
    ring = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])
    plane = np.array([[90.0, 50.0, 0.0], [95.0, 50.0, -10.0]])
    foot = np.array([[60.0, 50.0, -4.0], [92.0, 50.0, -4.0]])           # far end -> cutoff
    hang = np.array([[93.0, 50.0, -6.0], [105.0, 50.0, -7.0], [130.0, 50.0, -8.0]])
    f = Fault("g", "normal", traces=[Trace(None, plane, {"a": {"foot": foot, "hanging": hang}})])
    base = Fault("g", "normal", traces=[Trace(None, plane, {"a": {"foot": foot, "hanging": hang}})])
    _enforce_inside(f, ring, base)
    h = f.traces[0].layers["a"]["hanging"]
    assert len(h) == 2 and np.array_equal(h[0], hang[0])
    assert 100.0 - 1e-3 <= h[1, 0] <= 100.0 and h[1, 1] == 50.0
    assert h[1, 2] == pytest.approx(-6.0 - (h[1, 0] - 93.0) / 12.0, abs=1e-9)   # z along the piece
    assert np.array_equal(f.traces[0].layers["a"]["foot"], foot)
    bad = Fault("g", "normal", traces=[Trace(None, plane, {"a": {"foot": foot + [[0, 0, 0], [9, 0, 0]],
                                                                  "hanging": hang}})])
    with pytest.raises(faultmesh.DatasetError, match="trace 1 layer 'a': the foot cutoff"):
        _enforce_inside(bad, ring, bad)


def test_a_plane_pushed_out_of_the_study_area_is_an_error(paper):
    with pytest.raises(faultmesh.DatasetError, match=r"fault '.*' trace \d+ plane point \d+ .* "
                                                     "outside the study area after the perturbation"):
        for i in range(20):
            realization_dataset(paper, Perturbation(sigma_position=2000.0), 0, i)


def test_perturbed_realizations_build(paper):
    p = Perturbation(sigma_z=2.0, sigma_position=15.0, sigma_position_trace=5.0, sigma_dip=5.0,
                     sigma_throw=0.25)
    for i in range(3):
        ds = realization_dataset(paper, p, 1, i)
        m = faultmesh.build_model(ds, evaluate=False)
        m.check()
