"""Closed ADT surfaces from a split plane (paper section 3.2)."""

import numpy as np
import pytest

from replication.errors import DegenerateInputError, InputError
from replication.surfaces import SplitPlane, closed_adt, parse_split
from replication.surfaces.closed import edge_use_counts


def _ellipsoid_cloud(m=24, n_cap=60, seed=0):
    """A ring of m points on the plane z = 0 and caps above and below, inside the ring."""
    rng = np.random.default_rng(seed)
    t = 2 * np.pi * np.arange(m) / m
    ring = np.column_stack([np.cos(t), np.sin(t), np.zeros(m)])
    r = np.cos(np.pi / m) * np.sqrt(rng.random(2 * n_cap)) * 0.99  # inside the inscribed polygon
    a = 2 * np.pi * rng.random(2 * n_cap)
    h = 0.5 * np.sqrt(1 - r**2)
    caps = np.column_stack([r * np.cos(a), r * np.sin(a), np.r_[h[:n_cap], -h[n_cap:]]])
    return np.vstack([ring, caps]), m


def _signed_volume(points, triangles):
    p = points[triangles]
    return np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0


def test_closed_ellipsoid_is_watertight_and_outward():
    cloud, m = _ellipsoid_cloud()
    s = closed_adt(cloud, "z=0")
    assert s.split == SplitPlane(2, 0.0)
    assert s.n_on_plane == m and s.n_shared == m
    assert s.n_vertices == cloud.shape[0]
    assert s.is_closed
    assert np.all(edge_use_counts(s.triangles) == 2)
    # a closed genus-0 surface: V - E + F = 2
    edges = np.unique(np.sort(s.triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    assert s.n_vertices - len(edges) + s.n_triangles == 2
    # consistently oriented outwards: positive enclosed volume, below that of the ellipsoid
    volume = _signed_volume(s.points, s.triangles)
    assert 0 < volume < 4 / 3 * np.pi * 0.5
    assert s.upper.depth_axis == 2 and s.lower.depth_axis == 2
    assert s.to_polydata().n_cells == s.n_triangles


def test_split_along_another_axis():
    cloud, _ = _ellipsoid_cloud(seed=1)
    rotated = cloud[:, [2, 0, 1]]  # the ring now lies on the plane x = 0
    s = closed_adt(rotated, SplitPlane("x", 0.0))
    assert s.is_closed and _signed_volume(s.points, s.triangles) > 0


def test_not_watertight_when_a_cap_point_leaves_the_ring():
    cloud, _ = _ellipsoid_cloud()
    cloud = np.vstack([cloud, [[1.5, 0.0, 0.2]]])  # projects outside the ring
    s = closed_adt(cloud, "z=0")
    assert not s.is_closed


def test_tolerance_puts_near_plane_points_in_both_halves():
    cloud, m = _ellipsoid_cloud()
    cloud[:m, 2] += 1e-12
    assert closed_adt(cloud, "z=0").n_on_plane == m
    assert closed_adt(cloud, "z=0", tol=0.0).n_on_plane == 0


def test_empty_half_is_reported():
    cloud, _ = _ellipsoid_cloud()
    upper_only = cloud[cloud[:, 2] >= 0]
    with pytest.raises(DegenerateInputError, match="lower half of split z=-0.5"):
        closed_adt(upper_only, "z=-0.5")


@pytest.mark.parametrize(
    ("text", "axis", "offset"), [("z=0.5", 2, 0.5), ("X:1", 0, 1.0), (" y = -2e-3", 1, -0.002)]
)
def test_parse_split(text, axis, offset):
    assert parse_split(text) == SplitPlane(axis, offset)


@pytest.mark.parametrize("text", ["z", "w=1", "z=abc", "z=nan", "=1"])
def test_parse_split_errors(text):
    with pytest.raises(InputError):
        parse_split(text)


def test_bad_tolerance():
    cloud, _ = _ellipsoid_cloud()
    with pytest.raises(InputError, match="tol=-1"):
        closed_adt(cloud, "z=0", tol=-1.0)
