"""Closed ADT surfaces from a split plane (paper section 3.2)."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

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


# --- closing the halves: a strip of triangles joins their rims (issue 13 item 3) -------------


def _ellipsoid_points(n, axes=(1.0, 1.0, 1.0), seed=0, gap=0.01):
    """n random points on an ellipsoid (uniform directions), none within ``gap`` of z = 0."""
    rng = np.random.default_rng(seed)
    found = np.zeros((0, 3))
    while len(found) < n:
        p = rng.normal(size=(2 * n, 3))
        p /= np.linalg.norm(p, axis=1)[:, None]
        found = np.vstack([found, p[np.abs(p[:, 2]) >= gap]])
    return found[:n] * np.asarray(axes)


def _check_closed_surface(s, centre=(0.0, 0.0, 0.0)):
    """Every edge in two triangles in opposite directions, one fan per vertex, outward, V - E + F = 2."""
    t = s.triangles
    assert s.is_closed and s.not_closed_reason == ""
    assert np.all(edge_use_counts(t) == 2)
    directed = t[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    assert len(np.unique(directed, axis=0)) == len(directed)  # each directed edge once: consistent
    assert s.euler_characteristic == 2
    assert len(np.unique(t)) == s.n_vertices  # every vertex is used
    # the strip (the last n_strip triangles) faces away from the centre of a convex body
    p = s.points[t[len(t) - s.n_strip :]]
    normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.all(np.einsum("ij,ij->i", normals, p.mean(axis=1) - np.asarray(centre)) > 0)
    volume = _signed_volume(s.points, t)
    assert volume > 0  # outwards
    return volume


@pytest.mark.parametrize(("axes", "seed"), [((1, 1, 1), 0), ((1, 1, 1), 1), ((3, 2, 1), 2), ((1.5, 2, 4), 3)])
def test_random_points_on_sphere_and_ellipsoid_close(axes, seed):
    cloud = _ellipsoid_points(2000, axes, seed)
    s = closed_adt(cloud, "z=0")
    assert s.n_on_plane == 0 and s.n_shared == 0 and s.n_strip > 0
    assert s.n_vertices == 2000  # no point added
    volume = _check_closed_surface(s)
    exact = 4 / 3 * np.pi * np.prod(axes)
    assert abs(volume - exact) <= 0.05 * exact


def test_pyvista_sphere_example_closes():
    examples = pytest.importorskip("pyvista.examples")
    cloud = np.asarray(examples.load_sphere().points, dtype=np.float64)  # no ring on z = 0
    for split in ("z=0", "x=0"):
        s = closed_adt(cloud, split)
        volume = _check_closed_surface(s)
        radius = np.linalg.norm(cloud, axis=1).mean()
        assert abs(volume - 4 / 3 * np.pi * radius**3) <= 0.05 * 4 / 3 * np.pi * radius**3


def test_oblique_split_plane_closes_a_sphere():
    cloud = _ellipsoid_points(1500, seed=4, gap=0.0)
    normal = np.array([1.0, 2.0, 2.0]) / 3.0
    cloud = cloud[np.abs(cloud @ normal) >= 0.01]
    s = closed_adt(cloud, "1,2,2=0")
    assert not s.split.aligned and s.split.depth_name.startswith("normal")
    volume = _check_closed_surface(s)
    assert abs(volume - 4 / 3 * np.pi) <= 0.05 * 4 / 3 * np.pi
    # vertices are the input points, exactly
    assert {tuple(p) for p in s.points} == {tuple(p) for p in cloud}


def test_normal_along_an_axis_is_that_axis():
    assert SplitPlane((0, 0, 2.5), 1.0) == SplitPlane("z", 1.0)
    assert SplitPlane((1, 1, 0), 0.5).normal == pytest.approx([2**-0.5, 2**-0.5, 0])
    assert parse_split("1,1,0=0.5") == SplitPlane((1, 1, 0), 0.5)
    assert str(SplitPlane((0, 3, 4), 1)) == "0,0.6,0.8=1"
    frame = SplitPlane((0, 3, 4), 1).frame()
    np.testing.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(frame) == pytest.approx(1.0)  # right-handed: CCW rims stay CCW
    for bad in ("0,0,0=1", "1,1=0", "1,a,0=1"):
        with pytest.raises(InputError):
            parse_split(bad)


def test_a_normal_of_huge_or_tiny_numbers_is_a_direction_like_any_other():
    # was: "must be 3 finite numbers, not all zero" for (1e300, 1e300, 0) (its squares overflowed,
    # with numpy's overflow warning) and for (1e-200, 1e-200, 0) (they underflowed to zero)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for big in (1e300, 1e-200, 5e-324):
            assert SplitPlane((big, big, 0), 0.5) == SplitPlane((1, 1, 0), 0.5)
            assert SplitPlane((0, 0, big), 1.0) == SplitPlane("z", 1.0)
        assert parse_split("1e308,1e308,0=1") == SplitPlane((1, 1, 0), 1.0)
        assert SplitPlane((1e200, 2e200, 2e200), 0).normal == pytest.approx([1 / 3, 2 / 3, 2 / 3])
    for bad in ((0, 0, 0), (np.inf, 0, 1), (np.nan, 1, 1)):
        with pytest.raises(InputError, match="finite numbers, not all zero"):
            SplitPlane(bad, 0.0)


def test_clouds_that_cannot_be_closed_say_why_in_one_line():
    cloud, _ = _ellipsoid_cloud()
    pinched = closed_adt(np.vstack([cloud, [[1.5, 0.0, 0.2]]]), "z=0")  # a cap point beyond the ring
    assert not pinched.is_closed and pinched.n_strip == 0
    assert "touch itself" in pinched.not_closed_reason and "\n" not in pinched.not_closed_reason
    rng = np.random.default_rng(5)
    upper = np.column_stack([rng.random((30, 2)), 1 + rng.random(30)])
    lower = np.column_stack([rng.random((30, 2)) + [5.0, 0.0], -1 - rng.random(30)])
    apart = closed_adt(np.vstack([upper, lower]), "z=0")  # footprints side by side
    assert not apart.is_closed and "do not overlap" in apart.not_closed_reason
    assert "\n" not in apart.not_closed_reason
    # a ring on the plane whose edge is also an inner edge of the lower half: the halves touch
    ring = np.array([[1.0, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]])
    caps = np.array([[0.1, 0.1, 0.5], [-0.1, 0.2, 0.4], [0.2, -0.1, 0.6]])
    below = np.array([[1.2, 1.2, -0.3], [0.0, 0.0, -0.8], [-0.2, 0.1, -0.7]])
    touching = closed_adt(np.vstack([ring, caps, below]), "z=0")
    assert not touching.is_closed and "touch" in touching.not_closed_reason


@settings(deadline=None, max_examples=40)
@given(
    st.integers(0, 2**32 - 1),
    st.integers(8, 120),
    st.integers(8, 120),
    st.floats(0.2, 3.0),
    st.floats(-0.8, 0.8),
)
def test_any_two_height_fields_over_overlapping_footprints_close(seed, n_up, n_lo, size, shift):
    """Random height fields above and below the plane, over different overlapping discs."""
    rng = np.random.default_rng(seed)

    def disc(n, radius, centre):
        r = radius * np.sqrt(rng.random(n))
        a = 2 * np.pi * rng.random(n)
        return np.column_stack([centre + r * np.cos(a), r * np.sin(a)])

    # both footprints hold a small triangle round the origin, so they overlap
    core = 0.05 * np.column_stack([np.cos([0, 2.1, 4.2]), np.sin([0, 2.1, 4.2])])
    up = np.vstack([core, disc(n_up - 3, 1.0, 0.0)])
    lo = np.vstack([core[:, ::-1], disc(n_lo - 3, size, shift)])
    cloud = np.vstack([
        np.column_stack([up, 0.01 + rng.random(n_up)]),
        np.column_stack([lo, -0.01 - rng.random(n_lo)]),
    ])  # fmt: skip
    s = closed_adt(cloud, "z=0")
    assert s.is_closed, s.not_closed_reason
    assert s.euler_characteristic == 2 and np.all(edge_use_counts(s.triangles) == 2)
    directed = s.triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    assert len(np.unique(directed, axis=0)) == len(directed)
    assert s.n_vertices == n_up + n_lo


def test_cli_split_reports_the_closing_strip(capsys, tmp_path):
    from replication.cli import main
    from replication.io import save_cloud

    save_cloud(_ellipsoid_points(300, (3, 2, 1), seed=6), tmp_path / "e.xyz")
    assert main(["adt", str(tmp_path / "e.xyz"), "--split", "z=0", "-o", str(tmp_path / "e.vtk")]) == 0
    out = capsys.readouterr().out
    assert "closed (watertight), the halves' rims joined by" in out
    assert main(["adt", str(tmp_path / "e.xyz"), "--split", "z=0", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["closed"] is True and report["not_closed_reason"] is None
    assert report["closing_triangles"] > 0 and report["vertices"] == 300 and report["depth_axis"] == "z"
    cloud, _ = _ellipsoid_cloud()
    save_cloud(np.vstack([cloud, [[1.5, 0.0, 0.2]]]), tmp_path / "p.xyz")
    assert main(["adt", str(tmp_path / "p.xyz"), "--split", "z=0"]) == 0
    out = capsys.readouterr().out
    assert "NOT watertight: the point" in out and "touch itself" in out


TETRAHEDRON = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])


def test_mesh_defect_known_answers():
    from replication.surfaces._closing import mesh_defect

    assert mesh_defect(TETRAHEDRON) == ""
    assert "used by 1 triangle(s)" in mesh_defect(TETRAHEDRON[:3])
    flipped = TETRAHEDRON.copy()
    flipped[0] = flipped[0, ::-1]
    assert "inconsistent orientation" in mesh_defect(flipped)
    # two tetrahedra sharing vertex 0: closed edges, but the surface touches itself there
    twins = np.vstack([TETRAHEDRON, np.where(TETRAHEDRON == 0, 0, TETRAHEDRON + 3)])
    assert "touches itself at vertex 0" in mesh_defect(twins)
    # checked only near vertices 4-6, the second tetrahedron's far side is not looked at
    assert mesh_defect(np.vstack([TETRAHEDRON, [[4, 5, 6]]]), near=np.array([0, 1, 2, 3])) == ""


def test_boundary_loop_of_a_fan():
    from replication.surfaces._closing import boundary_loop

    fan = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4]])
    np.testing.assert_array_equal(boundary_loop(fan), [0, 1, 2, 3, 4])
    with pytest.raises(ValueError, match="boundary"):
        boundary_loop(TETRAHEDRON)  # closed: no boundary at all


def test_the_closed_mesh_is_read_only():
    from replication.surfaces.closed import closed_adt

    t = 2 * np.pi * np.arange(16) / 16
    ring = np.column_stack([np.cos(t), np.sin(t), np.zeros(16)])
    caps = np.array([[0.1, 0.2, 0.5], [-0.3, 0.1, 0.4], [0.0, -0.2, -0.5], [0.2, 0.3, -0.3]])
    closed = closed_adt(np.vstack([ring, caps]), split="z=0")
    assert not closed.points.flags.writeable and not closed.triangles.flags.writeable
