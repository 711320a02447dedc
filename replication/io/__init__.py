"""File formats: point clouds, surfaces, and atomic writes."""

from replication.io.atomic import atomic_path, atomic_write_bytes, atomic_write_text
from replication.io.clouds import CLOUD_SUFFIXES, load_cloud, save_cloud
from replication.io.vtk import (
    SURFACE_FORMATS,
    format_number,
    legacy_vtk_text,
    read_surface,
    surface_format,
    write_surface,
    write_vtk,
    write_vtp,
)

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
    "surface_format",
    "write_surface",
    "write_vtk",
    "write_vtp",
]
