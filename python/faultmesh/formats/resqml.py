"""RESQML 2.0.1 (``.epc`` with its ``.h5``: Petrel, RMS, resqpy) through
``resqpy`` (``pip install 'faultmesh[resqml]'``).

Written: a ``LocalDepth3dCrs`` (z up: elevations; the model's CRS as its
title, and as its EPSG code when it is ``EPSG:<n>``), and per surface a
``TriangulatedSetRepresentation`` titled with its name that represents a
``HorizonInterpretation`` of a ``GeneticBoundaryFeature`` (layers) or a
``FaultInterpretation`` of a ``TectonicBoundaryFeature`` (faults, ``is_normal``
from the fault's metadata kind). Both files appear together: the ``.epc``
refers to ``<stem>.h5`` by name. Read: every TriangulatedSetRepresentation,
points in the global frame of its CRS (offsets and rotation applied), in
metres (x, y from the CRS's ``xy_units``, z from its ``z_units``, as the
GOCAD reader does for ``AXIS_UNIT``), depths turned into elevations, a fault
when it represents a FaultInterpretation. A missing ``.h5`` is a
ModelFileError naming the ``.epc`` and the ``.h5``.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import List, Optional

import numpy as np

from ._common import (AtomicFiles, ModelFileError, _Shared, free_name, guarded, model_surfaces,
                      optional_import)

SUFFIXES = (".epc",)


def _rq():
    optional_import("resqpy", "resqml", "RESQML files (.epc)")
    import resqpy.crs as rqc
    import resqpy.model as rq
    import resqpy.organize as rqo
    import resqpy.surface as rqs

    return rq, rqc, rqo, rqs


def _write_into(model, epc: Path) -> None:
    rq, rqc, rqo, rqs = _rq()
    rmodel = rq.new_model(str(epc))
    crs_name = str(model.crs or "")
    epsg = crs_name.split(":", 1)[1] if crs_name.upper().startswith("EPSG:") and \
        crs_name.split(":", 1)[1].isdigit() else None
    crs = rqc.Crs(rmodel, z_inc_down=False, xy_units="m", z_units="m", epsg_code=epsg,
                  title=crs_name or "faultmesh local")
    crs.create_xml()
    for surf, kind in model_surfaces(model):
        name = str(surf.name)
        if kind == "fault":
            sub = str((surf.metadata or {}).get("kind", "")).lower()
            feat = rqo.TectonicBoundaryFeature(rmodel, kind="fault", feature_name=name)
            feat.create_xml()
            interp = rqo.FaultInterpretation(
                rmodel, title=name, tectonic_boundary_feature=feat,
                is_normal={"normal": True, "reverse": False}.get(sub))
        else:
            feat = rqo.GeneticBoundaryFeature(rmodel, kind="horizon", feature_name=name)
            feat.create_xml()
            interp = rqo.HorizonInterpretation(rmodel, title=name, genetic_boundary_feature=feat)
        interp.create_xml()
        rs = rqs.Surface(rmodel, crs_uuid=crs.uuid, title=name)
        rs.set_from_triangles_and_points(np.asarray(surf.triangles, np.int64),
                                         np.asarray(surf.vertices, np.float64))
        rs.set_represented_interpretation_root(interp.root)
        rs.write_hdf5()
        rs.create_xml()
    rmodel.store_epc()


def write(model, path, fmt: str = "epc", files: Optional[AtomicFiles] = None) -> List[Path]:
    """Write ``path`` (``.epc``) and ``<stem>.h5`` beside it, atomically together."""
    path = Path(path)
    h5 = path.with_suffix(".h5")
    path.parent.mkdir(parents=True, exist_ok=True)
    # resqpy writes both files itself and the .epc names the .h5: write them
    # with their final names in a private folder, then hand them to AtomicFiles.
    work = Path(tempfile.mkdtemp(prefix=f".{path.stem}.", suffix=".tmp", dir=path.parent))
    try:
        _write_into(model, work / path.name)
        with (AtomicFiles() if files is None else _Shared(files)) as f:
            for src, target in ((work / path.name, path), (work / h5.name, h5)):
                os.replace(src, f.temp_path(target))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return [path, h5]


def _to_global_metres(path: Path, crs, P: np.ndarray, title) -> np.ndarray:
    """Local CRS coordinates ``P`` as global x, y, elevation in metres."""
    import resqpy.weights_and_measures as wam

    # resqpy converts in place (and returns None): rotation, then the offsets
    # (RESQML gives them in the CRS's own units, so before the unit change),
    # then the axis order. global_z_inc_down=the CRS's own: resqpy does not
    # flip z here; the one flip (depth -> elevation) is below, after units.
    crs.local_to_global_array(P, global_z_inc_down=bool(crs.z_inc_down))
    for cols, units in ((slice(0, 2), crs.xy_units), (slice(2, 3), crs.z_units)):
        if units in (None, "", "m"):
            continue
        try:
            P[:, cols] = wam.convert_lengths(P[:, cols], str(units), "m")
        except Exception:  # noqa: BLE001 (resqpy raises assorted types for a unit it lacks)
            raise ModelFileError(path, f"surface {title!r}: CRS length unit {units!r} "
                                       "cannot be converted to metres") from None
    if crs.z_inc_down:
        P[:, 2] = -P[:, 2]
    return P


def _check_h5(path: Path, rmodel) -> None:
    """The .h5 the .epc names must exist: say so (resqpy's FileNotFoundError
    would otherwise surface from deep inside an array read)."""
    try:
        h5 = rmodel.h5_file_name(file_must_exist=False)
    except Exception:  # noqa: BLE001 (no external part: nothing to check here)
        return
    if h5 and not Path(h5).exists():
        raise ModelFileError(path, f"its HDF5 file {str(h5)!r} (which holds the coordinates) "
                                   "is missing: keep the .h5 beside the .epc")


def _read(path: Path):
    from ..model import Model, Surface

    rq, rqc, rqo, rqs = _rq()
    rmodel = rq.Model(str(path))
    _check_h5(path, rmodel)
    layers, faults = {}, {}
    crs_name = ""
    for uuid in rmodel.uuids(obj_type="TriangulatedSetRepresentation"):
        rs = rqs.Surface(rmodel, uuid=uuid)
        T, P = rs.triangles_and_points()
        T = np.asarray(T, np.int64).reshape(-1, 3)
        P = np.asarray(P, np.float64).reshape(-1, 3).copy()
        if rs.crs_uuid is not None:
            crs = rqc.Crs(rmodel, uuid=rs.crs_uuid)
            P = _to_global_metres(path, crs, P, rs.title)
            crs_name = crs_name or (f"EPSG:{crs.epsg_code}" if crs.epsg_code else
                                    ("" if crs.title in (None, "faultmesh local") else str(crs.title)))
        kind, meta = "layer", {}
        root = rs.represented_interpretation_root
        if root is not None:
            iuuid = root.attrib.get("uuid")
            itype = str(rmodel.type_of_uuid(iuuid) or "") if iuuid else ""
            if "FaultInterpretation" in itype:
                kind = "fault"
                fi = rqo.FaultInterpretation(rmodel, uuid=iuuid)
                if fi.is_normal is True:
                    meta["kind"] = "normal"
                elif fi.is_normal is False:
                    meta["kind"] = "reverse"
        target = faults if kind == "fault" else layers
        name = str(rs.title or f"surface_{len(layers) + len(faults)}")
        name = free_name(name, target)
        if T.size and (T.min() < 0 or T.max() >= len(P)):
            raise ModelFileError(path, f"surface {name!r}: triangle vertex index outside "
                                       f"0..{len(P) - 1}")
        target[name] = Surface(name=name, vertices=P, triangles=T, kind=kind, metadata=meta)
    if not layers and not faults:
        raise ModelFileError(path, "no TriangulatedSetRepresentation in this RESQML file")
    title = ""
    return Model(name=title or path.stem, surfaces=layers, faults=faults, crs=crs_name)


def read(path, fmt: str = "epc"):
    path = Path(path)
    _rq()
    try:
        return guarded(path, "reading it as RESQML (resqpy)", _read, path)
    except FileNotFoundError as e:
        if not path.exists():
            raise   # the .epc itself: io reports a missing file as such
        # Another file the .epc refers to (an .h5 not named as the main one).
        raise ModelFileError(path, f"a file it refers to is missing: {e}") from None
