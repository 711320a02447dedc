"""Reproducible replication of "adapted Delaunay triangulation" (ADT) surfaces.

The public API: point clouds, ADT and NURBS surfaces (:mod:`replication.surfaces`), their
paired comparison (:mod:`replication.compare`, :mod:`replication.stats`), file formats
(:mod:`replication.io`) and the error hierarchy (:mod:`replication.errors`).

Every public name is imported on first use (:mod:`replication._lazy`): ``import replication``
costs a few milliseconds, and numba, scipy or pyvista load only when a function needs them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from replication._lazy import attach

_EXPORTS = {
    "Comparison": "replication.compare",
    "compare": "replication.compare",
    "CloudFileError": "replication.errors",
    "DegenerateInputError": "replication.errors",
    "DuplicatePointsWarning": "replication.errors",
    "InputError": "replication.errors",
    "OutputError": "replication.errors",
    "ReplicationError": "replication.errors",
    "load_cloud": "replication.io.clouds",
    "save_cloud": "replication.io.clouds",
    "read_surface": "replication.io.vtk",
    "write_surface": "replication.io.vtk",
    "write_vtk": "replication.io.vtk",
    "write_vtp": "replication.io.vtk",
    "read_nurbs": "replication.io.nurbs",
    "write_nurbs": "replication.io.nurbs",
    "PairedStatistics": "replication.stats",
    "paired_statistics": "replication.stats",
    "Box": "replication.surfaces.cloud",
    "random_cloud": "replication.surfaces.cloud",
    "ClosedSurface": "replication.surfaces.closed",
    "SplitPlane": "replication.surfaces.closed",
    "closed_adt": "replication.surfaces.closed",
    "Surface": "replication.surfaces.adt",
    "adt": "replication.surfaces.adt",
    "select_depth_axis": "replication.surfaces.adt",
    "NurbsPatch": "replication.surfaces.nurbs",
    "NurbsSurface": "replication.surfaces.nurbs",
    "fit_nurbs": "replication.surfaces.nurbs",
}

__all__ = [
    "Box",
    "ClosedSurface",
    "CloudFileError",
    "Comparison",
    "DegenerateInputError",
    "DuplicatePointsWarning",
    "InputError",
    "NurbsPatch",
    "NurbsSurface",
    "OutputError",
    "PairedStatistics",
    "ReplicationError",
    "SplitPlane",
    "Surface",
    "__version__",
    "adt",
    "closed_adt",
    "compare",
    "fit_nurbs",
    "load_cloud",
    "paired_statistics",
    "random_cloud",
    "read_nurbs",
    "read_surface",
    "save_cloud",
    "select_depth_axis",
    "write_nurbs",
    "write_surface",
    "write_vtk",
    "write_vtp",
]

_getattr, __dir__ = attach(__name__, _EXPORTS)


def __getattr__(name: str) -> object:
    if name == "__version__":
        globals()["__version__"] = value = _version()
        return value
    return _getattr(name)


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("replication")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "0+unknown"


if TYPE_CHECKING:  # what the names are, for type checkers and editors
    from replication.compare import Comparison, compare
    from replication.errors import (
        CloudFileError,
        DegenerateInputError,
        DuplicatePointsWarning,
        InputError,
        OutputError,
        ReplicationError,
    )
    from replication.io.clouds import load_cloud, save_cloud
    from replication.io.nurbs import read_nurbs, write_nurbs
    from replication.io.vtk import read_surface, write_surface, write_vtk, write_vtp
    from replication.stats import PairedStatistics, paired_statistics
    from replication.surfaces.adt import Surface, adt, select_depth_axis
    from replication.surfaces.closed import ClosedSurface, SplitPlane, closed_adt
    from replication.surfaces.cloud import Box, random_cloud
    from replication.surfaces.nurbs import NurbsPatch, NurbsSurface, fit_nurbs
