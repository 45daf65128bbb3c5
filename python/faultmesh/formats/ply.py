"""Stanford ``.ply`` (binary little-endian), written by faultmesh, read through
meshio. One mesh holding every surface: viewers (MeshLab, CloudCompare,
ParaView) show it as one object; the ``surface_id`` vertex property and the
``comment faultmesh_surface <id> <kind> <name>`` header lines let faultmesh
read the surfaces back with their names and kinds. For one object per surface
in a viewer use ``.obj``, ``.vtu`` or a folder (one ``.ply`` per surface).
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np

from ._common import (AtomicFiles, Merged, ModelFileError, _Shared, guarded, split_merged)

SUFFIXES = (".ply",)


def _one_line(s: str) -> str:
    return " ".join(str(s).split())


def ply_bytes(model) -> bytes:
    m = Merged.of(model)
    n, k = len(m.points), len(m.triangles)
    head = ["ply", "format binary_little_endian 1.0",
            "comment faultmesh multi-layer model: surface_id = position in the model "
            "(layers top to bottom, then faults)",
            f"comment faultmesh_model {_one_line(m.name)}"]
    if m.crs:
        head.append(f"comment faultmesh_crs {_one_line(m.crs)}")
    head += [f"comment faultmesh_surface {i} {kind} {_one_line(name)}"
             for i, (name, kind) in enumerate(zip(m.names, m.kinds))]
    head += [f"element vertex {n}", "property double x", "property double y", "property double z",
             "property int surface_id", f"element face {k}",
             "property list uchar int vertex_indices", "end_header"]
    vdt = np.dtype([("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("s", "<i4")])
    v = np.empty(n, vdt)
    v["x"], v["y"], v["z"] = m.points[:, 0], m.points[:, 1], m.points[:, 2]
    v["s"] = m.point_arrays["surface_id"]
    fdt = np.dtype([("n", "u1"), ("i", "<i4", (3,))])
    f = np.empty(k, fdt)
    f["n"] = 3
    f["i"] = m.triangles
    return ("\n".join(head) + "\n").encode("utf-8") + v.tobytes() + f.tobytes()


def write(model, path, fmt: str = "ply", files: Optional[AtomicFiles] = None) -> Path:
    path = Path(path)
    data = ply_bytes(model)
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        f.open(path, "wb").write(data)
    return path


def _header_comments(path: Path):
    names, kinds, model_name, crs = {}, {}, "", ""
    with open(path, "rb") as fh:
        for _ in range(100000):
            raw = fh.readline()
            if not raw or raw.strip() == b"end_header":
                break
            s = raw.decode("utf-8", "replace").strip()
            p = s.split(None, 2)
            if len(p) >= 2 and p[0] == "comment" and p[1] == "faultmesh_model":
                model_name = p[2].strip() if len(p) > 2 else ""
            elif len(p) >= 2 and p[0] == "comment" and p[1] == "faultmesh_crs":
                crs = p[2].strip() if len(p) > 2 else ""
            elif len(p) == 3 and p[0] == "comment" and p[1] == "faultmesh_surface":
                q = p[2].split(None, 2)
                if len(q) >= 2 and q[0].isdigit():
                    names[int(q[0])] = q[2] if len(q) > 2 else f"surface_{q[0]}"
                    kinds[int(q[0])] = q[1]
    if names and sorted(names) == list(range(len(names))):
        return [names[i] for i in range(len(names))], [kinds[i] for i in range(len(names))], \
            model_name, crs
    return None, None, model_name, crs


def read(path, fmt: str = "ply"):
    from . import _meshio

    path = Path(path)
    mesh, P, T = _meshio.read_mesh(path, "ply")
    names, kinds, model_name, crs = guarded(path, "reading the PLY header", _header_comments, path)
    pa = {k: np.asarray(v) for k, v in mesh.point_data.items()}
    return split_merged(path, P, T, pa, {}, names, kinds, model_name, crs)
