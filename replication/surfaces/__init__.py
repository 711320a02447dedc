"""Surface builders: point clouds and adapted Delaunay triangulation (paper section 3.2).

Names are imported on first use (:mod:`replication._lazy`): the compiled kernels and scipy
load only when a surface is built.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from replication._lazy import attach

_EXPORTS = {
    "AXES": "replication.surfaces.adt",
    "DEFAULT_TIE_RTOL": "replication.surfaces.adt",
    "DEPTH_RULES": "replication.surfaces.adt",
    "Surface": "replication.surfaces.adt",
    "adt": "replication.surfaces.adt",
    "parse_axis": "replication.surfaces.adt",
    "projection_axes": "replication.surfaces.adt",
    "select_depth_axis": "replication.surfaces.adt",
    "ClosedSurface": "replication.surfaces.closed",
    "SplitPlane": "replication.surfaces.closed",
    "closed_adt": "replication.surfaces.closed",
    "parse_split": "replication.surfaces.closed",
    "CASE_STUDY_BOX": "replication.surfaces.cloud",
    "Box": "replication.surfaces.cloud",
    "as_cloud": "replication.surfaces.cloud",
    "random_cloud": "replication.surfaces.cloud",
    "BACKENDS": "replication.surfaces.delaunay",
    "delaunay_2d": "replication.surfaces.delaunay",
    "DUPLICATE_POLICIES": "replication.surfaces.duplicates",
    "merge_duplicates": "replication.surfaces.duplicates",
}

__all__ = [
    "AXES",
    "BACKENDS",
    "Box",
    "CASE_STUDY_BOX",
    "ClosedSurface",
    "DEFAULT_TIE_RTOL",
    "DEPTH_RULES",
    "DUPLICATE_POLICIES",
    "SplitPlane",
    "Surface",
    "adt",
    "as_cloud",
    "closed_adt",
    "delaunay_2d",
    "merge_duplicates",
    "parse_axis",
    "parse_split",
    "projection_axes",
    "random_cloud",
    "select_depth_axis",
]

__getattr__, __dir__ = attach(__name__, _EXPORTS)

if TYPE_CHECKING:  # what the names are, for type checkers and editors
    from replication.surfaces.adt import (
        AXES,
        DEFAULT_TIE_RTOL,
        DEPTH_RULES,
        Surface,
        adt,
        parse_axis,
        projection_axes,
        select_depth_axis,
    )
    from replication.surfaces.closed import ClosedSurface, SplitPlane, closed_adt, parse_split
    from replication.surfaces.cloud import CASE_STUDY_BOX, Box, as_cloud, random_cloud
    from replication.surfaces.delaunay import BACKENDS, delaunay_2d
    from replication.surfaces.duplicates import DUPLICATE_POLICIES, merge_duplicates
