"""File formats of a :class:`faultmesh.Model`, one module per format.

``threedt`` (``.3dt``, ours, docs/3dt.md), ``gocad`` (``.ts`` TSurf), and
through meshio ``vtk`` (``.vtu``, ``.vtk``), ``obj`` and ``ply``.
:mod:`faultmesh.io` dispatches on the suffix.
"""
from ._common import AtomicFiles, ModelFileError, slug  # noqa: F401
