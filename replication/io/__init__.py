"""File formats: point clouds, surfaces, and atomic writes.

Names are imported on first use (:mod:`replication._lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from replication._lazy import attach

_EXPORTS = {
    "atomic_path": "replication.io.atomic",
    "atomic_write_bytes": "replication.io.atomic",
    "atomic_write_text": "replication.io.atomic",
    "CLOUD_SUFFIXES": "replication.io.clouds",
    "load_cloud": "replication.io.clouds",
    "save_cloud": "replication.io.clouds",
    "SURFACE_FORMATS": "replication.io.vtk",
    "format_number": "replication.io.vtk",
    "legacy_vtk_text": "replication.io.vtk",
    "read_surface": "replication.io.vtk",
    "shortest_decimals": "replication.io.vtk",
    "surface_format": "replication.io.vtk",
    "write_surface": "replication.io.vtk",
    "write_vtk": "replication.io.vtk",
    "write_vtp": "replication.io.vtk",
}

__all__ = [
    "CLOUD_SUFFIXES",
    "SURFACE_FORMATS",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "format_number",
    "legacy_vtk_text",
    "load_cloud",
    "read_surface",
    "save_cloud",
    "shortest_decimals",
    "surface_format",
    "write_surface",
    "write_vtk",
    "write_vtp",
]

__getattr__, __dir__ = attach(__name__, _EXPORTS)

if TYPE_CHECKING:  # what the names are, for type checkers and editors
    from replication.io.atomic import atomic_path, atomic_write_bytes, atomic_write_text
    from replication.io.clouds import CLOUD_SUFFIXES, load_cloud, save_cloud
    from replication.io.vtk import (
        SURFACE_FORMATS,
        format_number,
        legacy_vtk_text,
        read_surface,
        shortest_decimals,
        surface_format,
        write_surface,
        write_vtk,
        write_vtp,
    )
