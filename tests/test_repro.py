"""Regression datasets (tests/data/repro, see its README): grounds that
faultmesh once failed on. Each must build and pass ``Model.check()``."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import faultmesh

REPRO = Path(__file__).resolve().parent / "data" / "repro"


@pytest.mark.parametrize("name", ["boundary-fault-local", "boundary-fault-utm-duplicates",
                                  "boundary-fault-utm-zero-area"])
def test_fault_across_the_study_area_builds_and_checks(name):
    # Traces on the study-area boundary close the patch there (end kind
    # "boundary"); they used to be "extended" from the boundary by a ray that
    # started on it: a synthetic tip 5e-10 m outside (local), a fault surface
    # with the end trace twice (UTM: duplicate vertices) and slivers of zero
    # area (UTM).
    ds = faultmesh.load_dataset(REPRO / name / "dataset.json")
    model = faultmesh.build_model(ds)
    model.check()
    ends = {f: sorted({tuple(v["ends"]) for v in meta["layers"].values()})
            for f, meta in model.metadata["faults"].items()}
    assert ends["F0"] == [("boundary", "boundary")]
    for s in model.faults.values():
        assert len(np.unique(s.vertices, axis=0)) == len(s.vertices)


def test_surveyors_rounding_on_the_boundary_builds_and_checks():
    # The traces on the boundary were written to 0.1 mm, the boundary not:
    # 0.03 mm outside. The loader snaps them onto the boundary (recorded in
    # the input report); the builder then closes the patches there.
    ds = faultmesh.load_dataset(REPRO / "boundary-rounding" / "dataset.json")
    snapped = [a for a in ds.adjustments if a.what == "snapped"]
    assert snapped and max(a.distance for a in snapped) < 1e-4
    model = faultmesh.build_model(ds)
    model.check()
    assert "snapped" in model.metadata["input"]["summary"]


@pytest.mark.parametrize("name", ["reverse-short-hanging-wall", "reverse-ends-pinch"])
def test_reverse_fault_polylines_that_stop_inside_the_band(name):
    # A reverse fault repeats the layer between its cutoffs; a hanging-wall
    # polyline that ends inside that band (or a footwall one that starts in
    # it) is carried on past it, so the patch's outline stays simple in XY.
    model = faultmesh.build_model(faultmesh.load_dataset(REPRO / name / "dataset.json"))
    model.check()
