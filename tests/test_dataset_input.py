"""The input tolerance policy (snap distance, data beyond the study area,
records) and the loader's checks of the data themselves (issue 10)."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import faultmesh as fm
from faultmesh import datasets
from faultmesh.dataset import (SNAP_ABSOLUTE, Adjustment, Boreholes, Dataset, Fault, Trace,
                               apply_boundary_policy, check_layer_order, default_snap_distance,
                               on_boundary_tolerance, points_in_polygon, summarize_adjustments)

DATA = Path(__file__).resolve().parent / "data"
SMALL = DATA / "datasets" / "small"
REPRO = DATA / "repro"


def _dist_to_ring(P, ring):
    """Distance of points (m, 2) to the closed ring, plain numpy (the test's
    own measure, independent of the code under test)."""
    P = np.asarray(P, dtype=np.float64).reshape(-1, 2)
    a, b = ring, np.roll(ring, -1, axis=0)
    d = b - a
    t = np.clip(np.einsum("mki,ki->mk", P[:, None] - a[None], d) / np.einsum("ki,ki->k", d, d),
                0, 1)
    c = a[None] + t[..., None] * d[None]
    return np.hypot(*(P[:, None] - c).transpose(2, 0, 1)).min(axis=1)


def _dataset(ring, hole_xy=(), extra=(), faults=(), layers=("L0", "L1")):
    """A small in-memory dataset on ``ring``: one row per layer at each hole
    (z falling with the layer index), extra points on the first layer."""
    hole_xy = np.asarray(hole_xy, dtype=np.float64).reshape(-1, 2)
    n = len(hole_xy)
    ids = np.repeat([f"H{i}" for i in range(n)], len(layers))
    xy = np.repeat(hole_xy, len(layers), axis=0)
    lay = np.tile(list(layers), n)
    z = np.tile(-100.0 * np.arange(len(layers)), n)
    pts = {layers[0]: np.column_stack([np.asarray(extra, dtype=np.float64).reshape(-1, 2),
                                       np.zeros(len(extra))])} if len(extra) else {}
    return Dataset("t", list(layers), ring, Boreholes(ids, xy, lay, z), points=pts,
                   faults=list(faults))


# ---------------------------------------------------------------------------
# the numbers
# ---------------------------------------------------------------------------
def test_default_snap_distance_is_absolute_and_relative():
    assert default_snap_distance([[0, 0], [2500, 0], [2500, 2500]]) == SNAP_ABSOLUTE == 0.02
    utm = np.array([[5e5, 7e6], [5e5 + 6000, 7e6], [5e5 + 6000, 7e6 + 4000]])
    assert default_snap_distance(utm) == 0.02            # offsets do not matter, sizes do
    assert default_snap_distance([[0, 0], [1, 0], [1, 1]]) == pytest.approx(1e-5 * 2 ** 0.5)
    assert default_snap_distance([[0, 0], [1000, 0], [1000, 800]]) == pytest.approx(
        1e-5 * np.hypot(1000, 800))
    # The on-boundary tolerance is a few units in the last place, far below it.
    assert on_boundary_tolerance(utm) < 1e-7


# ---------------------------------------------------------------------------
# the regression dataset
# ---------------------------------------------------------------------------
def test_boundary_rounding_dataset_loads_with_its_traces_on_the_boundary():
    # Was: DatasetError "trace 1 plane point 1 ... lies outside the study-area
    # boundary" (the trace written to 0.1 mm, 0.006 mm outside).
    ds = fm.load_dataset(REPRO / "boundary-rounding")
    snapped = [a for a in ds.adjustments if a.what == "snapped"]
    assert snapped and all(a.what == "snapped" for a in ds.adjustments)
    assert max(a.distance for a in snapped) < 1e-4          # rounding to 0.1 mm
    x_east = ds.boundary[:, 0].max()
    f0 = ds.fault("F0")
    # On the east side exactly (an axis-parallel side: the x is copied).
    assert np.all(f0.traces[0].plane[:, 0] == x_east)
    assert snapped[0].item == "fault 'F0' trace 1 plane point 1"
    assert snapped[0].after == (x_east, 1130.0696)
    ring = ds.boundary
    for f in ds.faults:
        for tr in f.traces:
            for arr in [tr.plane] + [s for sides in tr.layers.values() for s in sides.values()]:
                assert points_in_polygon(arr[:, :2], ring).all()
    # Idempotent: the policy on its own result changes and records nothing.
    again = apply_boundary_policy(ds)
    assert again == ds and again.adjustments == ds.adjustments
    assert "snapped onto the study-area boundary" in summarize_adjustments(ds.adjustments)


def test_snap_distance_key_and_argument(tmp_path):
    d = tmp_path / "br"
    shutil.copytree(REPRO / "boundary-rounding", d)
    # snap=0: nothing is moved, the rounded trace points lie beyond: clipped/dropped.
    ds0 = fm.load_dataset(d, snap=0.0)
    assert ds0.snap_distance == 0.0
    assert not any(a.what == "snapped" for a in ds0.adjustments)
    assert any(a.what == "dropped" for a in ds0.adjustments)
    doc = json.loads((d / "dataset.json").read_text())
    doc["snap_distance"] = 0.0
    (d / "dataset.json").write_text(json.dumps(doc))
    assert fm.load_dataset(d).adjustments == ds0.adjustments
    # The argument wins over the key.
    assert all(a.what == "snapped" for a in fm.load_dataset(d, snap=0.001).adjustments)
    doc["snap_distance"] = -1
    (d / "dataset.json").write_text(json.dumps(doc))
    with pytest.raises(fm.DatasetError, match="snap_distance: must be >= 0"):
        fm.load_dataset(d)
    with pytest.raises(fm.DatasetError, match="snap"):
        fm.load_dataset(SMALL, snap=float("nan"))
    # Saved and loaded again, the key is kept.
    ds = fm.load_dataset(SMALL, snap=0.5)
    back = fm.load_dataset(ds.save(tmp_path / "s"))
    assert back.snap_distance == 0.5


# ---------------------------------------------------------------------------
# snapping and clipping on hand-made geometry
# ---------------------------------------------------------------------------
SQUARE = np.array([[0.0, 0.0], [3000.0, 0.0], [3000.0, 3000.0], [0.0, 3000.0]])


def test_points_near_the_boundary_snap_inside_and_outside_and_onto_corners():
    holes = [[1500.0, 0.004], [1500.0, -0.004], [2999.99, 1000.0], [3000.005, 3000.004],
             [1500.0, 1500.0], [1500.0, 0.5]]
    ds = apply_boundary_policy(_dataset(SQUARE, holes))
    xy = ds.boreholes.xy[::2]
    assert xy[0].tolist() == [1500.0, 0.0] and xy[1].tolist() == [1500.0, 0.0]
    assert xy[2].tolist() == [3000.0, 1000.0]
    assert xy[3].tolist() == [3000.0, 3000.0]                 # the corner, exactly
    assert xy[4].tolist() == [1500.0, 1500.0] and xy[5].tolist() == [1500.0, 0.5]
    snaps = [a for a in ds.adjustments if a.what == "snapped"]
    assert len(snaps) == 8                                      # 4 holes x 2 layer rows
    assert snaps[0].item == "borehole row 1 (hole 'H0', layer 'L0')"
    assert snaps[0].distance == pytest.approx(0.004)


def test_rows_points_and_tips_beyond_the_boundary_are_dropped_and_recorded():
    tr = Trace(None, [[1000, 1000, 0], [1010, 1000, -50]],
               {"L0": {"foot": [[900, 1000, -10], [1000, 1000, -12]],
                       "hanging": [[1010, 1000, -20], [1100, 1000, -21]]}})
    f = Fault("F", "normal", tips=[[1000, -5], [1000, 2000]], traces=[tr])
    ds = _dataset(SQUARE, [[10, 10], [20, 20], [30, 30], [-1, 500]], extra=[[5, 5], [3500, 5]],
                  faults=[f])
    out = apply_boundary_policy(ds)
    assert "H3" not in out.boreholes.hole_id and len(out.boreholes) == 6
    assert out.points["L0"].tolist() == [[5.0, 5.0, 0.0]]
    assert out.fault("F").tips.tolist() == [[1000.0, 2000.0]]
    items = {a.item: a for a in out.adjustments}
    assert items["borehole row 7 (hole 'H3', layer 'L0')"].what == "dropped"
    assert items["borehole row 7 (hole 'H3', layer 'L0')"].distance == pytest.approx(1.0)
    assert items["points['L0'] point 2"].before == (3500.0, 5.0)
    assert items["fault 'F' tip 1"].distance == pytest.approx(5.0)
    assert ds.fault("F").tips.shape == (2, 2)                  # the input is not changed
    assert apply_boundary_policy(out).adjustments == out.adjustments


def test_loaded_rows_are_named_by_file_and_line(tmp_path):
    d = tmp_path / "small"
    shutil.copytree(SMALL, d)
    with open(d / "boreholes.csv", "a") as fh:
        fh.write("B10,1500,400,top,50.0\n")                     # 500 m beyond x = 1000
    ds = fm.load_dataset(d)
    (a,) = ds.adjustments
    assert a.item == "boreholes.csv row 31 (hole 'B10', layer 'top')"
    assert (a.what, a.after) == ("dropped", None) and a.distance == pytest.approx(500.0)


def _cross(ring, a, b):
    """A fault whose plane trace and layer polylines run from a to b."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    line = lambda t0, t1, z: [list(a + t * (b - a)) + [z - 10 * t] for t in np.linspace(t0, t1, 5)]
    tr = Trace(None, line(0, 1, 0.0), {"L0": {"foot": line(0, 0.5, -20.0),
                                               "hanging": line(0.5, 1, -30.0)}})
    return Fault("F", "normal", traces=[tr])


def test_polyline_leaving_the_area_is_cut_at_the_crossing():
    f = _cross(SQUARE, [2000, 1000], [4000, 1000])     # leaves through x = 3000 at t = 0.5
    out = apply_boundary_policy(_dataset(SQUARE, [[10, 10], [20, 20], [30, 30]], faults=[f]))
    tr = out.fault("F").traces[0]
    # The plane keeps t in [0, 0.5]: 3 vertices, the last one on the side.
    assert tr.plane[:, 0].tolist() == [2000.0, 2500.0, 3000.0]
    assert tr.plane[-1].tolist() == [3000.0, 1000.0, -5.0]
    # The footwall ends at t = 0.5 (its cutoff, on the side) and the hanging
    # wall starts there, but lies beyond it from then on: nothing of it but
    # its cutoff is inside, so the layer goes from the trace.
    assert "L0" not in tr.layers
    whats = [(a.what, a.item) for a in out.adjustments]
    assert ("dropped", "fault 'F' trace 1 plane point 4") in whats
    assert ("dropped", "fault 'F' trace 1 layer 'L0' hanging") in whats
    assert "only its cutoff at the fault (point 1)" in out.adjustments[-1].note


def test_footwall_keeps_its_cutoff_and_is_clipped_at_its_far_end():
    tr = Trace(None, [[2900, 1000, 0], [2910, 1000, -50]],
               {"L0": {"foot": [[3100, 1000, -10], [2950, 1000, -11], [2905, 1000, -12]],
                       "hanging": [[2910, 1000, -30], [2800, 1000, -31]]}})
    f = Fault("F", "normal", traces=[tr])
    out = apply_boundary_policy(_dataset(SQUARE, [[10, 10], [20, 20], [30, 30]], faults=[f]))
    foot = out.fault("F").traces[0].layers["L0"]["foot"]
    assert foot[0].tolist() == [3000.0, 1000.0, pytest.approx(-10 - 100 / 150)]
    assert foot[1:].tolist() == [[2950, 1000, -11], [2905, 1000, -12]]
    clip = [a for a in out.adjustments if a.what == "clipped"]
    assert [c.item for c in clip] == ["fault 'F' trace 1 layer 'L0' foot between points 1 and 2"]
    assert clip[0].before == (3100.0, 1000.0) and clip[0].after == (3000.0, 1000.0)
    assert clip[0].distance == pytest.approx(100.0)


def test_cutoff_beyond_the_boundary_drops_the_layer_from_the_trace():
    tr = Trace(None, [[2900, 1000, 0], [2990, 1000, -50]],
               {"L0": {"foot": [[2900, 1000, -10], [3050, 1000, -12]],      # cutoff outside
                       "hanging": [[2990, 1000, -30], [2800, 1000, -31]]},
                "L1": {"foot": [[2800, 1000, -110], [2950, 1000, -112]],
                       "hanging": [[2960, 1000, -130], [2700, 1000, -131]]}})
    out = apply_boundary_policy(_dataset(SQUARE, [[10, 10], [20, 20], [30, 30]],
                                         faults=[Fault("F", "normal", traces=[tr])]))
    assert list(out.fault("F").traces[0].layers) == ["L1"]
    (a,) = [a for a in out.adjustments if a.what == "dropped"]
    assert a.item == "fault 'F' trace 1 layer 'L0' foot"
    assert "cutoff at the fault (point 2) lies beyond the boundary" in a.note


def test_trace_and_fault_wholly_outside_are_dropped():
    out = apply_boundary_policy(_dataset(
        SQUARE, [[10, 10], [20, 20], [30, 30]],
        faults=[_cross(SQUARE, [3100, 100], [3500, 100]),
                Fault("G", "reverse", traces=[Trace(None, [[10, 10, 0], [12, 10, -5]]),
                                              Trace(None, [[-50, 10, 0], [-60, 10, -5]])])]))
    assert [f.name for f in out.faults] == ["G"] and len(out.fault("G").traces) == 1
    items = [(a.what, a.item) for a in out.adjustments]
    assert ("dropped", "fault 'F'") in items and ("dropped", "fault 'G' trace 2 plane") in items


CONCAVE = np.array([[0, 0], [3000, 0], [3000, 3000], [2000, 3000], [2000, 1000], [1000, 1000],
                    [1000, 3000], [0, 3000]], dtype=float)       # a U: the notch x in (1000, 2000)


def test_polyline_through_a_notch_keeps_one_part():
    # Plane from the left arm across the notch into the right arm (y = 2000):
    # two inside parts of 800 m and 500 m; the longest is kept.
    tr = Trace(None, [[200, 2000, 0], [2500, 2000, -100]],
               {"L0": {"foot": [[200, 2000, -10], [2900, 2000, -20]],   # cutoff in the right arm
                       "hanging": [[2950, 2000, -30], [2990, 2000, -31]]}})
    out = apply_boundary_policy(_dataset(CONCAVE, [[10, 10], [20, 20], [30, 30]],
                                         faults=[Fault("F", "normal", traces=[tr])]))
    t = out.fault("F").traces[0]
    assert t.plane[:, 0].tolist() == [200.0, 1000.0]
    assert t.plane[1, 2] == pytest.approx(-800 / 2300 * 100)
    foot = t.layers["L0"]["foot"]
    assert foot[:, 0].tolist() == [2000.0, 2900.0]                   # the part with the cutoff
    assert apply_boundary_policy(out).adjustments == out.adjustments


# ---------------------------------------------------------------------------
# property: rounded points on any boundary snap onto it; 1 m beyond is cut
# ---------------------------------------------------------------------------
def _ring_strategy():
    shapes = st.sampled_from(["rectangle", "rotated", "concave", "rotated concave"])
    return st.tuples(shapes, st.floats(2500, 6000), st.floats(2500, 6000), st.floats(1, 89),
                     st.sampled_from([0.0, 5e5, 7e6]), st.sampled_from([0.0, 5e5, 7e6]))


def _make_ring(shape, w, h, angle, ox, oy):
    """Rectangles (axis-parallel or rotated) and a U-shaped concave area."""
    if "concave" in shape:
        r = np.array([[0, 0], [w, 0], [w, h], [0.6 * w, h], [0.6 * w, 0.4 * h], [0.3 * w, 0.4 * h],
                      [0.3 * w, h], [0, h]])
    else:
        r = np.array([[0, 0], [w, 0], [w, h], [0, h]])
    if "rotated" in shape:
        a = np.deg2rad(angle)
        r = r @ np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])
    return r + [ox, oy]


@settings(max_examples=60)
@given(ring=_ring_strategy(), decimals=st.sampled_from([4, 3, 2]),
       picks=st.lists(st.tuples(st.integers(0, 99), st.floats(0.02, 0.98)), min_size=3,
                      max_size=12))
def test_rounded_points_on_the_sides_all_snap_onto_the_boundary(ring, decimals, picks):
    shape, w, h, angle, ox, oy = ring
    R = _make_ring(shape, w, h, angle, ox, oy)
    k = len(R)
    side = np.array([i % k for i, _ in picks])
    t = np.array([t for _, t in picks])
    a, b = R[side], R[(side + 1) % k]
    exact = a + t[:, None] * (b - a)
    rounded = np.round(exact, decimals)
    assert _dist_to_ring(rounded, R).max() <= 0.5 * 10.0 ** -decimals * 2 ** 0.5 + 1e-6
    # Holes, extra points and a vertical fault trace on a side.
    plane = np.column_stack([rounded[[0, 0]], [0.0, -50.0]])
    tr = Trace(None, plane)
    ds = _dataset(R, rounded, extra=rounded, faults=[Fault("F", "normal", tips=rounded[:1],
                                                           traces=[tr])])
    out = apply_boundary_policy(ds)
    assert not [x for x in out.adjustments if x.what != "snapped"], out.adjustments[:3]
    assert len(out.boreholes) == len(ds.boreholes) and len(out.points["L0"]) == len(rounded)
    on_tol = on_boundary_tolerance(R)
    from faultmesh import orient2d
    for P in (out.boreholes.xy[::2], out.points["L0"][:, :2], out.fault("F").tips):
        d = _dist_to_ring(P, R)
        assert d.max() <= 4 * on_tol
        for p, dd in zip(P, d):
            # Against every axis-parallel side the point is on: exactly on it.
            for i in range(k):
                s0, s1 = R[i], R[(i + 1) % k]
                if (s0[0] == s1[0] or s0[1] == s1[1]) and _dist_to_ring(p, np.array([s0, s1]))[0] \
                        <= 4 * on_tol:
                    assert orient2d(s0[None], s1[None], p[None])[0] == 0.0
    again = apply_boundary_policy(out)
    assert again == out and again.adjustments == out.adjustments


@settings(max_examples=40)
@given(ring=_ring_strategy(), picks=st.lists(st.tuples(st.integers(0, 99), st.floats(0.1, 0.9)),
                                             min_size=1, max_size=6))
def test_points_one_metre_beyond_are_dropped_and_polylines_clipped(ring, picks):
    shape, w, h, angle, ox, oy = ring
    R = _make_ring(shape, w, h, angle, ox, oy)
    k = len(R)
    side = np.array([i % k for i, _ in picks])
    t = np.array([t for _, t in picks])
    a, b = R[side], R[(side + 1) % k]
    on = a + t[:, None] * (b - a)
    e = (b - a) / np.hypot(*(b - a).T)[:, None]
    outward = np.column_stack([e[:, 1], -e[:, 0]])          # the ring is counter-clockwise
    beyond = on + 1.0 * outward
    inner = on - 10.0 * outward
    assert not points_in_polygon(beyond, R).any() and points_in_polygon(inner, R).all()
    assert np.all(_dist_to_ring(beyond, R) > 0.99)
    faults = [Fault(f"F{i}", "normal", tips=beyond[i:i + 1],
                    traces=[Trace(None, [list(inner[i]) + [0.0], list(beyond[i]) + [-10.0]])])
              for i in range(len(on))]
    corners = R[:3] + (R.mean(axis=0) - R[:3]) * 0.01          # three holes inside
    ds = _dataset(R, np.vstack([corners, beyond]), extra=beyond, faults=faults)
    out = apply_boundary_policy(ds)
    assert len(out.boreholes) == 2 * 3 and "L0" in out.points and len(out.points["L0"]) == 0
    n = len(on)
    dropped = [x for x in out.adjustments if x.what == "dropped"]
    clipped = [x for x in out.adjustments if x.what == "clipped"]
    assert len(clipped) == n                    # each plane cut once, where it leaves
    # 2 rows per hole beyond, each extra point, each tip, each plane's outer end.
    assert len(dropped) == 2 * n + n + n + n
    assert all(x.distance > 0.99 for x in dropped + clipped)
    on_tol = on_boundary_tolerance(R)
    for f, p_on in zip(out.faults, on):
        end = f.traces[0].plane[-1]
        assert f.tips.shape == (0, 2)
        assert np.hypot(*(end[:2] - p_on)) < 1e-6 * max(1.0, abs(ox), abs(oy))
        assert _dist_to_ring(end[:2], R)[0] <= 4 * on_tol
        assert end[2] == pytest.approx(-10.0 * 10 / 11)
    again = apply_boundary_policy(out)
    assert again == out and again.adjustments == out.adjustments


# ---------------------------------------------------------------------------
# records in the built model
# ---------------------------------------------------------------------------
def test_build_model_records_the_input_policy():
    ds = datasets.synthetic(0)
    R = ds.boundary
    a, b = R[0], R[1]
    e = (b - a) / np.hypot(*(b - a))
    mid = 0.5 * (a + b)
    xy = ds.boreholes.xy.copy()
    sel = ds.boreholes.hole_id == ds.boreholes.hole_id[0]
    xy[sel] = mid + 0.005 * np.array([e[1], -e[0]])           # 5 mm beyond side 0
    ds.boreholes.xy = xy
    m = fm.build_model(ds, evaluate=False)
    rec = m.metadata["input"]
    assert rec["counts"]["snapped"]["count"] == int(sel.sum())
    assert rec["counts"]["snapped"]["largest_distance"] == pytest.approx(0.005)
    assert rec["snap_distance"] == 0.02 and "snapped" in rec["summary"]
    assert np.hypot(*(np.array(rec["adjustments"][0]["after"]) - mid)) < 1e-6
    json.dumps(rec, allow_nan=False)


# ---------------------------------------------------------------------------
# holes: one id, one place
# ---------------------------------------------------------------------------
def test_two_holes_sharing_an_id_at_different_places_is_an_error(tmp_path):
    # Was: one of them silently dropped.
    d = tmp_path / "small"
    shutil.copytree(SMALL, d)
    with open(d / "boreholes.csv", "a") as fh:
        fh.write("B2,700,300,top,50.0\n")
    with pytest.raises(fm.DatasetError) as ei:
        fm.load_dataset(d)
    msg = str(ei.value)
    for frag in ("boreholes.csv", "hole 'B2' is at two places", "row 5 at (500.000, 120.000)",
                 "row 31 at (700.000, 300.000)"):
        assert frag in msg, msg


def test_rows_of_one_hole_may_differ_by_rounding(tmp_path):
    d = tmp_path / "small"
    shutil.copytree(SMALL, d)
    text = (d / "boreholes.csv").read_text().replace("B2,500,120,seam_a", "B2,500.004,120,seam_a")
    (d / "boreholes.csv").write_text(text)
    ds = fm.load_dataset(d)
    assert ds.boreholes.n_holes == 9


# ---------------------------------------------------------------------------
# the layer order against the boreholes
# ---------------------------------------------------------------------------
def _reorder(src: Path, dst: Path, layers=None, negate=False) -> Path:
    shutil.copytree(src, dst)
    js = dst / "dataset.json"
    doc = json.loads(js.read_text())
    if layers is not None:
        doc["layers"] = layers(doc["layers"])
    if negate:
        lines = (dst / "boreholes.csv").read_text().splitlines()
        out = [lines[0]]
        for ln in lines[1:]:
            if ln and not ln.startswith("#"):
                c = ln.split(",")
                c[4] = repr(-float(c[4]))
                ln = ",".join(c)
            out.append(ln)
        (dst / "boreholes.csv").write_text("\n".join(out) + "\n")
    js.write_text(json.dumps(doc))
    return js


@pytest.fixture(scope="module")
def paper_dir(tmp_path_factory):
    return datasets.paper_like_path().parent


@pytest.mark.parametrize("how, frags", [
    ("reversed", ["every pair of layers is upside down", "layers 'coal 10' and 'coal 8'"]),
    ("swapped", ["layers 'coal 8' and 'third impervious bed'", "find 'third impervious bed' "
                 "higher", "hole '"]),
    ("negated", ["every pair of layers is upside down", "depths"]),
])
def test_a_contradicted_layer_order_is_an_error_at_load(paper_dir, tmp_path, how, frags):
    # Was: the crossing repair ran for minutes into MemoryError.
    if how == "reversed":
        js = _reorder(paper_dir, tmp_path / "d", layers=lambda v: v[::-1])
    elif how == "swapped":
        js = _reorder(paper_dir, tmp_path / "d", layers=lambda v: [v[0], v[2], v[1], v[3]])
    else:
        js = _reorder(paper_dir, tmp_path / "d", negate=True)
    with pytest.raises(fm.DatasetError) as ei:
        fm.load_dataset(js)
    msg = str(ei.value)
    assert "the layer order contradicts the boreholes" in msg and "boreholes.csv" in msg
    assert "row " in msg
    for frag in frags:
        assert frag in msg, msg
    assert len(msg) < 2000


def test_a_contradicted_layer_order_is_an_error_at_build_before_any_repair():
    ds = datasets.synthetic(0)
    ds.layers = ds.layers[::-1]
    calls = []
    with pytest.raises(fm.DatasetError, match="the layer order contradicts the boreholes"):
        fm.build_model(ds, progress=lambda step, i, n: calls.append(step))
    assert calls == []


def test_the_paper_like_order_holds_despite_repeated_layers():
    ds = datasets.paper_like()
    b = ds.boreholes
    pairs = {(h, lay) for h, lay in zip(b.hole_id, b.layer)}
    assert len(b) - len(pairs) == 6                  # six holes hit a layer twice (reverse faults)
    assert check_layer_order(ds) == []
    assert fm.load_dataset(datasets.paper_like_path()).adjustments == []


@pytest.mark.parametrize("name", sorted(p.name for p in REPRO.iterdir() if p.is_dir()))
def test_the_repro_datasets_pass_the_checks(name):
    ds = fm.load_dataset(REPRO / name)
    assert not [a for a in ds.adjustments if a.what == "warning"]


def test_a_few_disagreeing_holes_are_a_warning(tmp_path):
    d = tmp_path / "small"
    shutil.copytree(SMALL, d)
    # B7 gets seam_b above seam_a (a bad pick): 1 of the 8 holes with both disagrees.
    text = (d / "boreholes.csv").read_text().replace("B7,90,720,seam_b,-125.1",
                                                     "B7,90,720,seam_b,-60.0")
    (d / "boreholes.csv").write_text(text)
    ds = fm.load_dataset(d)
    (w,) = ds.adjustments
    assert (w.what, w.item) == ("warning", "layers 'seam_a' and 'seam_b'")
    assert "1 of the 8 holes" in w.note and "hole 'B7'" in w.note
    assert "'seam_a' at z -80.20 (row 23), 'seam_b' at z -60.00 (row 24)" in w.note
    assert "1 warning(s)" in summarize_adjustments(ds.adjustments)
    # The warning reaches the model's record once, not twice.
    _, rec = fm.dataset.prepare_for_build(ds)
    assert rec["counts"]["warning"]["count"] == 1


def test_adjustment_records_are_plain_json():
    a = Adjustment("snapped", "x", (1.0, 2.0), (1.0, 2.5), 0.5)
    assert json.loads(json.dumps(a.to_dict())) == {"what": "snapped", "item": "x",
                                                  "before": [1.0, 2.0], "after": [1.0, 2.5],
                                                  "distance": 0.5, "note": ""}
