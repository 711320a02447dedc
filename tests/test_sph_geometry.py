"""SPH scene geometry (no engine needed): closed solids, mirror images, the jet column, files."""

import collections
import json
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from replication.casestudy import JetConfig, pelton_bucket_surface
from replication.casestudy.mesh import check_height_field
from replication.casestudy.sph.geometry import (
    closed_solid,
    jet_column,
    mirror_about_y,
    obj_text,
    pda_text,
    signed_volume,
)
from replication.casestudy.sph.scene import write_scene
from replication.casestudy.sph.settings import SPHSettings, timeline
from replication.errors import DuplicatePointsWarning
from replication.surfaces import adt, random_cloud


def directed_edges(triangles):
    return collections.Counter(
        (int(a), int(b)) for t in triangles for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))
    )


def assert_closed(points, triangles):
    """Watertight and consistently oriented: every directed edge once, its reverse once."""
    edges = directed_edges(triangles)
    assert all(count == 1 for count in edges.values())
    assert all((b, a) in edges for a, b in edges)


def volume_under(points, triangles, bottom):
    """Exact volume between a height field (linear on each triangle) and the plane z = bottom."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    return float(np.sum(area * ((a[:, 2] + b[:, 2] + c[:, 2]) / 3 - bottom)))


def adt_quiet(cloud):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        return adt(cloud, depth="z")


def test_closed_solid_of_the_bucket():
    s = pelton_bucket_surface()
    pts, tri = s.points * 1e-3, np.asarray(s.triangles)
    solid_pts, solid_tri = closed_solid(pts, tri, 0.004)
    assert_closed(solid_pts, solid_tri)
    assert solid_pts[:, 2].min() == pytest.approx(-0.004)
    assert signed_volume(solid_pts, solid_tri) == pytest.approx(volume_under(pts, tri, -0.004), rel=1e-12)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(4, 60), st.floats(0.5, 5.0))
def test_closed_solid_of_any_adt_surface_is_watertight(seed, n, depth_mm):
    s = adt_quiet(random_cloud(n, step=1.0, rng=seed))
    pts, tri = s.points * 1e-3, np.asarray(s.triangles)
    solid_pts, solid_tri = closed_solid(pts, tri, depth_mm * 1e-3)
    assert_closed(solid_pts, solid_tri)
    bottom = pts[:, 2].min() - depth_mm * 1e-3
    assert signed_volume(solid_pts, solid_tri) == pytest.approx(volume_under(pts, tri, bottom), rel=1e-9)


def test_mirror_joins_the_halves_on_the_plane():
    s = pelton_bucket_surface()
    pts, tri = s.points * 1e-3, np.asarray(s.triangles)
    both, tri2 = mirror_about_y(pts, tri)
    on_plane = int(np.sum(pts[:, 1] == 0))
    assert both.shape[0] == 2 * pts.shape[0] - on_plane and tri2.shape[0] == 2 * tri.shape[0]
    # a valid height field (counter-clockwise, no overlap) over both sides of y = 0
    checked, convex = check_height_field(both, tri2)
    np.testing.assert_array_equal(checked, tri2)
    assert convex
    # the mirror image of every vertex is a vertex
    image = {tuple(p) for p in (both * [1, -1, 1]).round(12)}
    assert image == {tuple(p) for p in both.round(12)}
    # the joined solid is closed: the seam on y = 0 is interior
    assert_closed(*closed_solid(both, tri2, 0.005))


@pytest.mark.parametrize("radius_mm", [0.5, 0.75, 1.0, 1.3])
def test_jet_column_is_symmetric_about_the_axis(radius_mm):
    r = radius_mm * 1e-3
    center, radius, length = (0.018, 0.0), 0.009, 0.05
    pos, layers = jet_column(center, radius, 0.02, length, 2 * r)
    assert layers == round(length / (2 * r)) and pos.shape[0] % layers == 0
    per_layer = pos.shape[0] // layers
    xy = pos[:per_layer, :2] - center
    assert np.all(np.hypot(xy[:, 0], xy[:, 1]) <= radius + 1e-15)
    for flip in ([1, -1], [-1, 1]):  # mirror images of the cross-section are in it
        assert {tuple(p) for p in (xy * flip).round(12)} == {tuple(p) for p in xy.round(12)}
    np.testing.assert_allclose(xy.mean(axis=0), 0.0, atol=1e-15)
    # each lattice cell stands for (2r)^2 of the cross-section: the area within a few cells' worth
    assert per_layer * (2 * r) ** 2 == pytest.approx(np.pi * radius**2, rel=4 * (2 * r) / radius)
    z = np.unique(pos[:, 2])
    np.testing.assert_allclose(np.diff(z), 2 * r, rtol=1e-9)
    assert z[0] == pytest.approx(0.02 + r)


def test_obj_and_pda_texts_round_trip():
    s = pelton_bucket_surface()
    pts, tri = closed_solid(s.points * 1e-3, np.asarray(s.triangles), 0.004)
    lines = obj_text(pts, tri).splitlines()
    v = np.array([[float(x) for x in line.split()[1:]] for line in lines if line.startswith("v ")])
    f = np.array([[int(i) - 1 for i in line.split()[1:]] for line in lines if line.startswith("f ")])
    np.testing.assert_array_equal(v, pts)
    np.testing.assert_array_equal(f, tri)
    column, _ = jet_column((0.018, 0.0), 0.009, 0.02, 0.01, 0.002)
    text = pda_text(column).split("BEGIN DATA\n")
    assert text[0].split() == [
        "ATTRIBUTES",
        "position",
        "TYPES",
        "V",
        "NUMBER_OF_PARTICLES:",
        str(len(column)),
    ]
    back = np.array([[float(x) for x in line.split()] for line in text[1].splitlines()])
    np.testing.assert_array_equal(back, column.astype(np.float32))  # the engine reads single precision


def test_scene_files(tmp_path):
    s = pelton_bucket_surface()
    pts, tri = mirror_about_y(s.points * 1e-3, np.asarray(s.triangles))
    jet = JetConfig(full_jet=True, domain=None)
    settings_ = SPHSettings(particle_radius=1e-3, duration=0.016, method="wcsph", sound_speed=50.0)
    scene = write_scene(tmp_path, pts, tri, jet, settings_)
    doc = json.loads((tmp_path / "scene.json").read_text())
    conf = doc["Configuration"]
    assert conf["simulationMethod"] == 0 and conf["boundaryHandlingMethod"] == 0 and not conf["enableZSort"]
    assert conf["WCSPH"]["stiffness"] == pytest.approx(1000 * 50.0**2 / 7)  # c^2 = gamma B / rho
    assert conf["cflMaxTimeStepSize"] == pytest.approx(0.4 * 2e-3 / (50.0 + 4.34))
    assert conf["gravitation"] == [0.0, 0.0, -9.81] and conf["stopAt"] == 0.016
    assert doc["FluidModels"][0]["initialVelocity"] == [0.0, 0.0, -4.34]
    for key, name in (("RigidBodies", "geometryFile"), ("FluidModels", "particleFile")):
        path = doc[key][0][name]
        assert path.startswith(str(tmp_path.resolve())) and (tmp_path / path.rsplit("/", 1)[1]).is_file()
    times = timeline(settings_, 4.34, 0.018)
    assert scene.timeline == times and times.gap == pytest.approx(0.006)
    # the column's bottom lies one gap above the surface's highest point, its tail arrives at the end
    rows = (tmp_path / "column.pda").read_text().split("BEGIN DATA\n")[1].splitlines()
    column = np.array([[float(x) for x in line.split()] for line in rows])
    assert column[:, 2].min() == pytest.approx(0.013 + 0.006 + 1e-3, rel=1e-6)
    assert scene.column_layers * 2e-3 == pytest.approx(4.34 * (0.016 - times.contact), abs=1e-3)
    job = json.loads((tmp_path / "job.json").read_text())
    assert job["max_speed"] == pytest.approx(43.4) and job["min_time_step"] == 1e-8
