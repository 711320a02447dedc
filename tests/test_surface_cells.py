"""Surface files made of other faces than triangles: flat polygons and triangle strips are read."""

import numpy as np
import pytest
import pyvista as pv
from hypothesis import given, settings
from hypothesis import strategies as hst

from replication.casestudy.jet import JetConfig, jet_force
from replication.errors import CloudFileError
from replication.io import read_surface
from replication.io.vtk import FLAT_POLYGON


def _area(points, triangles):
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum()


def _sorted_triangles(triangles):
    return np.unique(np.sort(triangles, axis=1), axis=0)


def _plate(tmp_path, name, mesh):
    mesh.save(tmp_path / name)
    return read_surface(tmp_path / name)


@pytest.mark.parametrize("suffix", [".vtk", ".vtp"])
def test_a_plate_of_quads_strips_or_triangles_is_the_same_surface(tmp_path, suffix):
    # was: "the surface must consist of triangles only; it holds 16 polygon(s) of 4 corners"
    quads = pv.Plane(center=(18, 0, 5), i_size=30, j_size=30, i_resolution=4, j_resolution=4)  # mm
    triangulated = quads.triangulate()
    strips = triangulated.strip()
    assert strips.n_strips > 0 and strips.GetNumberOfPolys() == 0
    read = {name: _plate(tmp_path, name + suffix, mesh) for name, mesh in
            (("quads", quads), ("triangles", triangulated), ("strips", strips))}  # fmt: skip
    points, triangles = read["triangles"]
    for name in ("quads", "strips"):
        np.testing.assert_array_equal(read[name][0], points)  # the points are kept as they are
        assert len(read[name][1]) == 32
        np.testing.assert_allclose(_area(*read[name]), 30.0 * 30.0, rtol=1e-6)  # float32 points
    np.testing.assert_array_equal(_sorted_triangles(read["strips"][1]), _sorted_triangles(triangles))
    # a flat plate across the jet takes the jet's whole momentum flux rho Q V, however it is cut
    config = JetConfig(full_jet=True)
    flux = 1000.0 * np.pi * 0.009**2 * 4.34**2
    for name in read:
        force = jet_force(*read[name], config)
        np.testing.assert_allclose(force.axial_force, flux, rtol=1e-9)


def test_a_flat_concave_polygon_is_read_whole(tmp_path):
    corners = np.array(
        [[0, 0, 1], [2, 0, 1], [2, 1, 1], [1, 1, 1], [1, 2, 1], [0, 2, 1]], dtype=float
    )  # an L
    mesh = pv.PolyData(corners, faces=np.array([6, 0, 1, 2, 3, 4, 5]))
    points, triangles = _plate(tmp_path, "l.vtp", mesh)
    assert len(triangles) == 4
    np.testing.assert_allclose(_area(points, triangles), 3.0, rtol=1e-12)  # not the hull's 3.5


def test_a_mesh_of_triangles_and_strips_keeps_both(tmp_path):
    # was: pyvista calls such a mesh "all triangles", and the strips were dropped without a word
    # (1 triangle of 33 read, and a force of 0 N)
    plate = pv.Plane(center=(18, 0, 5), i_size=30, j_size=30, i_resolution=4, j_resolution=4).triangulate()
    half = plate.extract_cells(range(16)).extract_surface(algorithm="dataset_surface")
    strips = plate.extract_cells(range(16, 32)).extract_surface(algorithm="dataset_surface").strip()
    mixed = half.merge(strips, merge_points=True)
    assert mixed.n_strips > 0 and mixed.GetNumberOfPolys() == 16 and mixed.is_all_triangles
    points, triangles = _plate(tmp_path, "mixed.vtp", mixed)
    assert len(triangles) == 32
    np.testing.assert_allclose(_area(points, triangles), 30.0 * 30.0, rtol=1e-6)


def test_a_polygon_that_crosses_itself_is_refused_by_name(tmp_path):
    # was: "triangle 0 (vertices [0, 1, 2]) is clockwise ...", a triangle the file never held
    corners = np.array([[0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1], [2, 0, 1]], dtype=float)
    bow_tie = pv.PolyData(
        corners, faces=np.array([3, 1, 4, 3, 4, 0, 1, 2, 3])
    )  # a triangle, then the bow tie
    bow_tie.save(tmp_path / "b.vtp")
    with pytest.raises(
        CloudFileError, match=r"1 polygon\(s\) cross themselves \(cell 1, counted from 0, encloses an"
    ):
        read_surface(tmp_path / "b.vtp")
    square = pv.PolyData(corners, faces=np.array([3, 1, 4, 3, 4, 0, 1, 3, 2]))  # the same corners in order
    assert len(_plate(tmp_path, "s.vtp", square)[1]) == 3


def test_a_warped_quad_is_refused_and_named(tmp_path):
    quads = pv.Plane(i_resolution=3, j_resolution=1)
    quads.points[7, 2] = 0.1  # lifts one corner of cell 2 only (points 2, 3, 7, 6)
    quads.save(tmp_path / "w.vtp")
    with pytest.raises(CloudFileError) as caught:
        read_surface(tmp_path / "w.vtp")
    message = str(caught.value)
    assert "1 of its 3 polygon(s) of more than 3 corners are not flat (cell 2, counted from 0" in message
    assert "mesh.triangulate()" in message and "\n" not in message


def test_flat_quads_are_flat_to_their_own_precision(tmp_path):
    # were refused as warped: a tilted float32 plane (its rounding bends the quads by 1e-8 of
    # their size), and float64 quads 0.37 wide at UTM-like coordinates (the corners' cross
    # products cancelled: bends of 1e-4 to 1e-2)
    tilted = pv.Plane(direction=(1, 2, 5), i_resolution=4, j_resolution=4)
    assert tilted.points.dtype == np.float32
    assert len(_plate(tmp_path, "tilted.vtp", tilted)[1]) == 32
    far = pv.Plane(direction=(1, 2, 5), i_size=0.37, j_size=0.37, i_resolution=4, j_resolution=4)
    far.points = far.points.astype(np.float64) + np.array([5e6, 4e5, 1e3])
    points, triangles = _plate(tmp_path, "far.vtp", far)
    assert len(triangles) == 32 and points.dtype == np.float64
    np.testing.assert_allclose(_area(points - points.mean(axis=0), triangles), 0.37**2, rtol=1e-6)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (
            "POLYGONS 2 7\n3 0 1 2\n2 1 3\n",
            r"faces of three or more corners; it holds 1 polygon\(s\) of 2 corners",
        ),
        ("POLYGONS 1 9\n8 0 1 3 2 0 1 3 2\n", r"its faces make 6 triangle\(s\), but only 0 could be cut"),
    ],
)
def test_faces_that_cannot_be_cut_into_triangles_are_refused(tmp_path, text, match):
    # a polygon of 2 corners was "unexpected ValueError: cannot reshape array of size 7 into shape (4)";
    # a polygon going round twice gave no triangles and "triangles must have shape (m, 3) with m >= 1"
    head = "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 4 double\n"
    head += "0 0 0\n1 0 0\n0 1 0\n1 1 0\n"
    (tmp_path / "m.vtk").write_text(head + text)
    with pytest.raises(CloudFileError, match=match) as caught:
        read_surface(tmp_path / "m.vtk")
    assert "\n" not in str(caught.value)


@settings(max_examples=40, deadline=None)
@given(
    corners=hst.integers(4, 9),
    tilt=hst.tuples(*[hst.floats(-1, 1) for _ in range(3)]).filter(lambda v: np.linalg.norm(v) > 0.1),
    scale=hst.sampled_from([1e-6, 1.0, 1e4]),
    offset=hst.floats(-1e3, 1e3),
    lift=hst.floats(1e-4, 0.5),
)
def test_flat_polygons_in_any_plane_are_read_and_lifted_ones_refused(tmp_path_factory, corners, tilt, scale,
                                                                     offset, lift):  # fmt: skip
    """A convex polygon in a random plane, at any scale, is flat; one corner lifted off it is not."""
    normal = np.asarray(tilt) / np.linalg.norm(tilt)
    u = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    angles = np.linspace(0, 2 * np.pi, corners, endpoint=False)
    points = scale * (np.cos(angles)[:, None] * u + np.sin(angles)[:, None] * v) + offset * scale
    faces = np.concatenate([[corners], np.arange(corners)])
    scratch = tmp_path_factory.mktemp("poly")
    flat = read_surface(_save(pv.PolyData(points, faces=faces), scratch / "flat.vtp"))
    assert len(flat[1]) == corners - 2
    lifted = points.copy()
    lifted[0] += lift * scale * normal  # off the plane by lift of the polygon's radius
    assert lift / 2 > FLAT_POLYGON  # the polygon's size is its diameter
    with pytest.raises(CloudFileError, match="not flat"):
        read_surface(_save(pv.PolyData(lifted, faces=faces), scratch / "lifted.vtp"))


def _save(mesh, path):
    mesh.save(path)
    return path
