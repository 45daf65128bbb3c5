"""Wavefront ``.obj``, read and written by faultmesh (Blender, MeshLab, Rhino).

Written: one object per surface (``o <name>``, as Blender and MeshLab list
them), its vertices (``v x y z``, shortest round-trip decimals: exact) and
triangles (``f a b c``, 1-based, counter-clockwise as in the model); comments
``# faultmesh_model <name>`` and ``# faultmesh_surface <kind>`` keep what OBJ
has no place for. Read: ``v`` and ``f`` (``i``, ``i/t``, ``i//n``, ``i/t/n``;
a negative index counts back from the last vertex read so far, as the OBJ
spec says, so files that interleave ``v`` and ``f`` per object are exact);
keywords may be followed by spaces or tabs, and ``#`` starts a comment on a
``v`` or ``f`` line too; ``o`` (or, in a file without ``o``, ``g``) starts a
new surface with its own vertices; an ``o`` object with neither vertices nor
faces is an empty surface (what the writer writes for one), an object or
group with vertices but no faces is not a surface; every other statement is
ignored. Faces of more than three vertices are refused (triangulate first).
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import List, Optional

import numpy as np

from ._common import (AtomicFiles, ModelFileError, _Shared, format_floats, model_surfaces,
                      read_text, split_lines)

SUFFIXES = (".obj",)
_SLASH = re.compile(r"/\S*")


def _bare(s: str) -> str:
    return " ".join(str(s).split()) or "unnamed"


def obj_lines(model) -> List[str]:
    out = ["# faultmesh multi-layer model (Wavefront OBJ): one object per surface",
           f"# faultmesh_model {_bare(model.name)}"]
    if model.crs:
        out.append(f"# faultmesh_crs {_bare(model.crs)}")
    off = 1
    for surf, kind in model_surfaces(model):
        out += [f"# faultmesh_surface {kind}", f"o {_bare(surf.name)}"]
        if not surf.n_triangles:
            # An object without vertices or faces, which the reader takes for
            # an empty surface (vertices no face uses are never read back).
            continue
        out.extend("v " + row for row in format_floats(surf.vertices))
        out.extend(f"f {a} {b} {c}" for a, b, c in (surf.triangles + off).tolist())
        off += surf.n_vertices
    return out


def write(model, path, fmt: str = "obj", files: Optional[AtomicFiles] = None) -> Path:
    path = Path(path)
    lines = obj_lines(model)
    with (AtomicFiles() if files is None else _Shared(files)) as f:
        f.open(path).write("\n".join(lines) + "\n")
    return path


def read(path, fmt: str = "obj"):
    from ..model import Model, Surface

    path = Path(path)
    lines = split_lines(read_text(path))
    v_lines: List[str] = []
    v_nos: List[int] = []
    f_lines: List[str] = []
    f_nos: List[int] = []
    f_seen: List[int] = []         # vertices read before each face (negative indices)
    groups: List[tuple] = []       # (name, kind, first face, first vertex)
    g_groups: List[tuple] = []
    model_name, crs, pending_kind = "", "", None
    for no, raw in enumerate(lines, start=1):
        s = raw.strip()
        if not s:
            continue
        # Any whitespace ends the keyword: exporters write 'v\t0 0 0' too.
        key, *more = s.split(None, 1)
        rest = more[0] if more else ""
        if key == "v":
            # An inline '# ...' after the numbers is a comment (the spec and
            # every common reader allow it); names on o/g lines keep their '#'.
            v_lines.append(rest.partition("#")[0])
            v_nos.append(no)
        elif key == "f":
            f_lines.append(rest.partition("#")[0])
            f_nos.append(no)
            f_seen.append(len(v_lines))
        elif key == "o":
            groups.append((rest.strip() or f"object_{len(groups)}", pending_kind, len(f_lines),
                           len(v_lines)))
            pending_kind = None
        elif key == "g":
            g_groups.append((rest.strip() or f"group_{len(g_groups)}", None, len(f_lines),
                             len(v_lines)))
        elif key == "#":
            p = rest.split(None, 1)
            if p and p[0] == "faultmesh_model" and len(p) > 1:
                model_name = p[1].strip()
            elif p and p[0] == "faultmesh_crs" and len(p) > 1:
                crs = p[1].strip()
            elif p and p[0] == "faultmesh_surface" and len(p) > 1:
                pending_kind = p[1].strip()
    if not v_lines and not groups:
        raise ModelFileError(path, "no vertices ('v x y z' lines) in this OBJ file")
    V = _numbers(path, v_lines, v_nos, "vertex") if v_lines else np.zeros((0, 3))
    F = _faces(path, f_lines, f_nos, len(V), np.array(f_seen, np.int64))
    objects = bool(groups)
    if not groups:
        groups = g_groups or [(path.stem, None, 0, 0)]
        if groups[0][2] > 0:
            groups.insert(0, (path.stem, None, 0, 0))
    elif groups[0][2] > 0:
        groups.insert(0, (path.stem, None, 0, 0))
    bounds = [g[2] for g in groups] + [len(F)]
    vbounds = [g[3] for g in groups[1:]] + [len(V)]
    layers, faults = {}, {}
    for (name, kind, start, vstart), end, vend in zip(groups, bounds[1:], vbounds):
        tris = F[start:end]
        # An 'o' object with neither vertices nor faces is an empty surface
        # (the writer's form of one, since OBJ has no other); an object or a
        # group with vertices but no faces (points, lines) is no surface.
        if not len(tris) and not (objects and vend == vstart):
            continue
        used, inv = np.unique(tris.reshape(-1), return_inverse=True)
        target = faults if kind == "fault" else layers
        base, n = name, 2
        while name in target:
            name, n = f"{base} ({n})", n + 1
        target[name] = Surface(name=name, vertices=V[used], triangles=inv.reshape(-1, 3),
                               kind="fault" if kind == "fault" else "layer")
    if not layers and not faults:
        raise ModelFileError(path, "no triangles ('f a b c' lines) in this OBJ file")
    return Model(name=model_name or path.stem, surfaces=layers, faults=faults, crs=crs)


def _numbers(path, lines, nos, what) -> np.ndarray:
    try:
        rows = [ln.split() for ln in lines]
        width = {len(r) for r in rows}
        if width <= {3, 4, 6, 7}:
            # x y z [w] or x y z r g b: the coordinates are the first three
            return np.array([r[:3] for r in rows], dtype=np.float64).reshape(-1, 3) \
                if len(width) > 1 else np.array(rows, dtype=np.float64)[:, :3].copy()
    except ValueError:
        pass
    for ln, no in zip(lines, nos):
        p = ln.split()
        try:
            ok = len(p) >= 3 and all(np.isfinite(float(t)) for t in p[:3])
        except ValueError:
            ok = False
        if not ok:
            raise ModelFileError(path, f"expected a vertex 'v x y z', got {('v ' + ln).strip()!r}", no)
    raise ModelFileError(path, "vertices have an unexpected number of values", nos[0])


def _faces(path, lines, nos, nv, seen) -> np.ndarray:
    """Faces as 0-based indices; ``seen[i]`` is the number of vertices read
    before face ``i`` (what its negative indices count back from)."""
    if not lines:
        return np.zeros((0, 3), np.int64)
    joined = _SLASH.sub("", " ".join(lines))
    counts = [len(ln.split()) for ln in lines]
    bad = [i for i, c in enumerate(counts) if c != 3]
    if bad:
        i = bad[0]
        raise ModelFileError(path, f"face with {counts[i]} vertices: faultmesh reads triangles "
                                   "(triangulate the mesh first)", nos[i])
    try:
        idx = np.array(joined.split(), dtype=np.int64).reshape(-1, 3)
    except ValueError:
        for ln, no in zip(lines, nos):
            try:
                [int(t) for t in _SLASH.sub("", ln).split()]
            except ValueError:
                raise ModelFileError(path, f"expected vertex numbers in 'f {ln.strip()}'", no) from None
        raise  # pragma: no cover
    # 1-based; a negative number counts back from the last vertex read before
    # this face line (OBJ spec), not from the file's last vertex: with v/f
    # interleaved per object, '-1' is this object's last vertex.
    idx = np.where(idx > 0, idx - 1, np.where(idx < 0, seen[:, None] + idx, -1))
    badrow = np.flatnonzero(((idx < 0) | (idx >= nv)).any(axis=1))
    if len(badrow):
        i = int(badrow[0])
        raise ModelFileError(path, f"face refers to a vertex outside 1..{nv} (negative: "
                                   f"-1..-{seen[i]} at this line): 'f {lines[i].strip()}'", nos[i])
    return idx
