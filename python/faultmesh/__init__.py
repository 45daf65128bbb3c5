"""faultmesh: 3D geological models of layered ground cut by faults, as TINs.

The numerical kernels live in the C++ extension ``faultmesh._core`` and are
re-exported here; the modelling workflow, file formats, reports and the CLI are
Python modules of this package.
"""
from __future__ import annotations

import os as _os
from pathlib import Path as _Path

# Developer hook: FAULTMESH_DEV_BUILD names a CMake build directory holding a
# freshly built ``_core`` extension, which then wins over an installed one.
if _os.environ.get("FAULTMESH_DEV_BUILD"):
    __path__.insert(0, _os.environ["FAULTMESH_DEV_BUILD"])  # type: ignore[name-defined]

from ._core import *  # noqa: E402,F401,F403  (C++ kernels, docs/design.md §7)
from ._core import GeometryError, __version__  # noqa: E402,F401


def cmake_dir() -> str:
    """Directory of ``faultmeshConfig.cmake`` for ``find_package(faultmesh)``.

    Pass it as ``-Dfaultmesh_DIR=...`` (or its grandparent's parent, the package
    folder, on ``CMAKE_PREFIX_PATH``) to link ``faultmesh::faultmesh`` from C++.
    """
    d = _Path(__file__).resolve().parent / "lib" / "cmake" / "faultmesh"
    if not (d / "faultmeshConfig.cmake").is_file():
        raise FileNotFoundError(
            f"faultmesh.cmake_dir: no faultmeshConfig.cmake under {d}; the C++ SDK is "
            "installed with the wheel (pip install faultmesh), not with a development build")
    return str(d)


def include_dir() -> str:
    """Directory of the public C++ headers (``<faultmesh/...>``)."""
    return str(_Path(__file__).resolve().parent / "include")


from .dataset import Dataset, DatasetError, load_dataset  # noqa: E402,F401  (re-exported)
from . import datasets  # noqa: E402,F401  (re-exported)
from .io import load_model  # noqa: E402,F401  (re-exported)
from .formats.pv import from_pyvista  # noqa: E402,F401  (needs faultmesh[viz] when called)
from .model import Model, Surface, Gap  # noqa: E402,F401  (re-exported)
from .build import build_model  # noqa: E402,F401  (re-exported)
from .ensemble import ensemble, Perturbation  # noqa: E402,F401  (Dask is imported only when used)
