"""Surface builders: point clouds and adapted Delaunay triangulation (paper section 3.2)."""

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
