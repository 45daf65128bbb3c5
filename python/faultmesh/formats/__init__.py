"""File formats of a :class:`faultmesh.Model`, one module per format.

``threedt`` (``.3dt``, ours, docs/3dt.md), ``gocad`` (``.ts``/``.ml``/``.pl``),
``vtk`` (``.vtu``/``.vtp``/``.vtk``), ``obj``, ``ply``, ``stl`` (read), and
through optional packages ``omf`` (``.omf``), ``resqml`` (``.epc``), ``geoh5``
(``.geoh5``) and ``pv`` (PyVista objects). :mod:`faultmesh.io` dispatches on
the suffix; docs/formats.md says what each keeps and which programs open it.
"""
from ._common import AtomicFiles, ModelFileError, slug  # noqa: F401
