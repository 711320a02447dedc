"""Points that share a projected position: grouping and the merge policies.

A 2-D Delaunay triangulation has one vertex per distinct position, so points of the cloud
that project onto the same (u, v) position cannot all lie on the ADT surface. scipy's Qhull
drops such points without a word; this module makes the choice explicit (paper section 3.2,
step 7, promises that every point lies on the surface, which is only possible after merging).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Literal

import numpy as np

from replication.errors import DuplicatePointsWarning, InputError, shown

__all__ = [
    "DUPLICATE_POLICIES",
    "DuplicatePolicy",
    "Merge",
    "apply_policy",
    "group_positions",
    "groups_from_pairs",
    "merge_duplicates",
]

DuplicatePolicy = Literal["mean", "min", "max", "first", "raise"]
DUPLICATE_POLICIES: tuple[str, ...] = ("mean", "min", "max", "first", "raise")


def group_positions(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Group points by exactly equal (u, v) position.

    Parameters
    ----------
    u, v : ndarray of float64, shape (n,)
        Finite projected coordinates.

    Returns
    -------
    group : ndarray of int64, shape (n,)
        Group of each point, numbered in order of first occurrence.
    first : ndarray of int64, shape (n_groups,)
        Index of the first point of each group.

    Notes
    -----
    Equality is exact (``-0.0`` equals ``0.0``); a hash table makes this O(n). The
    sweep-hull triangulator finds the same groups from its own sort
    (:func:`groups_from_pairs`); this is the reference, and the scipy backend's grouping.
    """
    # adding 0.0 turns -0.0 into +0.0 so that equal values have equal bits
    ubits = np.ascontiguousarray(np.asarray(u, dtype=np.float64) + 0.0).view(np.uint64)
    vbits = np.ascontiguousarray(np.asarray(v, dtype=np.float64) + 0.0).view(np.uint64)
    from replication.surfaces._grouping import _group_bits  # numba: imported when used

    return _group_bits(ubits, vbits)


def groups_from_pairs(
    n: int, duplicates: np.ndarray, representatives: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`group_positions`' result from (duplicate, representative) index pairs.

    Parameters
    ----------
    n : int
        Number of points.
    duplicates, representatives : ndarray of int
        Every point that repeats an earlier position, and the first point at that position.

    Returns
    -------
    group, first : ndarray
        As for :func:`group_positions` (in the dtype of ``duplicates``).
    """
    dtype = duplicates.dtype
    if duplicates.size == 0:
        everything = np.arange(n, dtype=dtype)
        return everything, everything
    is_first = np.ones(n, dtype=bool)
    is_first[duplicates] = False
    first = np.flatnonzero(is_first).astype(dtype, copy=False)
    group = (np.cumsum(is_first, dtype=np.int64) - 1).astype(dtype, copy=False)
    group[duplicates] = group[representatives]
    return group, first


@dataclass(frozen=True, eq=False)
class Merge:
    """Outcome of merging points that share a projected position.

    Attributes
    ----------
    vertex_of_input : ndarray of int, shape (n,)
        The vertex that each input point became.
    first : ndarray of int, shape (n_vertices,)
        The input point whose projected position each vertex has (its first occurrence).
    depth : ndarray of float64, shape (n_vertices,)
        The depth coordinate of each vertex after the policy was applied.
    """

    vertex_of_input: np.ndarray
    first: np.ndarray
    depth: np.ndarray

    @property
    def n_merged(self) -> int:
        """Number of input points that did not become a vertex of their own."""
        return int(self.vertex_of_input.shape[0] - self.first.shape[0])


def merge_duplicates(
    u: np.ndarray,
    v: np.ndarray,
    depth: np.ndarray,
    policy: DuplicatePolicy = "mean",
    *,
    axis_names: tuple[str, str, str] = ("u", "v", "depth"),
) -> Merge:
    """Merge points with equal projected position according to ``policy``.

    Parameters
    ----------
    u, v, depth : ndarray of float64, shape (n,)
        Projected coordinates and depth coordinate of each point.
    policy : {"mean", "min", "max", "first", "raise"}
        How a group of points sharing (u, v) becomes one vertex: its depth is the mean,
        minimum or maximum of the group's depths (the mean summed in increasing order of
        depth, so that it is the same bits in any row order), or that of the first point of
        the group;
        ``"raise"`` refuses such clouds with an :class:`~replication.errors.InputError`.
    axis_names : tuple of str
        Names of (u, v, depth) for messages, e.g. ``("x", "y", "z")``.

    Returns
    -------
    Merge

    Warns
    -----
    DuplicatePointsWarning
        When points were merged, with their number.

    Notes
    -----
    Implements the project's duplicate policy for ADT (paper section 3.2, steps 7-10).
    """
    if policy not in DUPLICATE_POLICIES:
        raise InputError(f"unknown duplicate policy {policy!r}; choose one of {DUPLICATE_POLICIES}")
    group, first = group_positions(u, v)
    return apply_policy(group, first, depth, policy, axis_names=axis_names, stacklevel=4)


def apply_policy(
    group: np.ndarray,
    first: np.ndarray,
    depth: np.ndarray,
    policy: DuplicatePolicy = "mean",
    *,
    axis_names: tuple[str, str, str] = ("u", "v", "depth"),
    stacklevel: int = 3,
) -> Merge:
    """Apply a duplicate policy to points grouped by position (see :func:`merge_duplicates`).

    Notes
    -----
    Implements the project's duplicate policy for ADT (paper section 3.2, steps 7-10).
    """
    if policy not in DUPLICATE_POLICIES:
        raise InputError(f"unknown duplicate policy {policy!r}; choose one of {DUPLICATE_POLICIES}")
    n, n_groups = group.shape[0], first.shape[0]
    if n_groups == n:
        return Merge(vertex_of_input=group, first=first, depth=np.asarray(depth, float)[first])
    counts = np.bincount(group, minlength=n_groups)
    un, vn, dn = axis_names
    if policy == "raise":
        shared = np.flatnonzero(counts[group] > 1)
        raise InputError(
            f"{shared.size} points share a projected ({un}, {vn}) position with another point "
            f"(rows {shown(shared)}, counted from 0); choose a duplicate policy other than 'raise' to "
            "merge them"
        )
    depth = np.asarray(depth, dtype=np.float64)
    if policy == "mean" and counts.max() <= 2:  # a + b is b + a: no order to fix
        merged = np.bincount(group, weights=depth, minlength=n_groups) / counts
    elif policy == "mean":
        # each group summed in the order of its depths, not of its rows: floating-point sums
        # of three or more depend on their order, and a cloud file's row order must not move a
        # vertex's depth
        shared = np.flatnonzero(counts[group] > 1)
        shared = shared[np.lexsort((depth[shared], group[shared]))]
        merged = np.zeros(n_groups)
        alone = np.flatnonzero(counts[group] == 1)
        merged[group[alone]] = depth[alone]
        merged += np.bincount(group[shared], weights=depth[shared], minlength=n_groups)
        merged /= counts
    elif policy == "min":
        merged = np.full(n_groups, np.inf)
        np.minimum.at(merged, group, depth)
    elif policy == "max":
        merged = np.full(n_groups, -np.inf)
        np.maximum.at(merged, group, depth)
    else:  # "first"
        merged = depth[first]
    n_merged = n - n_groups
    warnings.warn(
        f"merged {n_merged} point(s) that share a projected ({un}, {vn}) position with another "
        f"point; {int(np.count_nonzero(counts > 1))} vertex/vertices took the {policy} "
        f"{dn} of their group (duplicate policy {policy!r})",
        DuplicatePointsWarning,
        stacklevel=stacklevel,
    )
    return Merge(vertex_of_input=group, first=first, depth=merged)
