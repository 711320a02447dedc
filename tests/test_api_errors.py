"""The library's functions given the wrong kind of argument: one clear line naming it."""

import numpy as np
import pytest

import replication as rp
from replication.casestudy.jet import surface_force
from replication.errors import InputError


@pytest.fixture(scope="module")
def built():
    cloud = rp.random_cloud(45, rng=3)
    return cloud, rp.adt(cloud), rp.fit_nurbs(cloud, tessellation=None)


def test_wrong_kinds_of_argument_are_named(built, tmp_path):
    # each was an AttributeError ("'numpy.ndarray' object has no attribute 'points'", ...)
    cloud, surface, nurbs = built
    cases = [
        (
            lambda: rp.write_vtk(cloud, tmp_path / "a.vtk"),
            r"triangles .*got ndarray; a point cloud with save_cloud\(\)",
        ),
        (
            lambda: rp.write_vtp(nurbs, tmp_path / "n.vtp"),
            r"got NurbsSurface; a NURBS is written with write_nurbs\(\)",
        ),
        (
            lambda: rp.write_nurbs(cloud, tmp_path / "x.smesh"),
            r"takes a NurbsPatch or the NurbsSurface of fit_nurbs, got ndarray",
        ),
        (
            lambda: surface_force(cloud),
            r"surface must be a Surface from adt\(points, depth='z'\), got ndarray",
        ),
        (lambda: rp.random_cloud(10, 5), r"box must be a Box or its 6 bounds .*got 5; a seed goes in rng="),
        (lambda: rp.random_cloud(10, "box"), r"box must be a Box or its 6 bounds .*got 'box'$"),
        (lambda: rp.random_cloud(10, (0, 1)), r"a box needs 6 bounds"),
    ]
    for call, match in cases:
        with pytest.raises(InputError, match=match) as caught:
            call()
        assert "\n" not in str(caught.value)
    assert list(tmp_path.iterdir()) == []


def test_a_box_may_be_given_as_its_bounds():
    bounds = (0.0, 1.0, 2.0, 3.0, -1.0, 0.0)
    np.testing.assert_array_equal(
        rp.random_cloud(20, bounds, rng=1), rp.random_cloud(20, rp.Box.from_bounds(bounds), rng=1)
    )


def test_write_nurbs_takes_the_result_of_fit_nurbs(built, tmp_path):
    _, _, nurbs = built
    assert rp.write_nurbs(nurbs, tmp_path / "a.smesh") == rp.write_nurbs(nurbs.patch, tmp_path / "b.smesh")
    assert (tmp_path / "a.smesh").read_bytes() == (tmp_path / "b.smesh").read_bytes()


@pytest.mark.parametrize(
    ("write", "name", "match"),
    [
        (
            lambda s, p: rp.write_surface(s, p, fmt="vtp"),
            "s.vtk",
            r"names a \.vtk file, but the format asked for is vtp",
        ),
        (
            lambda s, p: rp.write_vtk(s, p),
            "s.VTP",
            r"names a \.vtp file, but the format written is vtk \(legacy VTK\)",
        ),
        (
            lambda s, p: rp.write_vtp(s, p),
            "s.vtk",
            r"names a \.vtk file, but the format written is vtp \(VTK XML\)",
        ),
        (
            lambda n, p: rp.write_nurbs(n, p, fmt="smesh"),
            "n.json",
            r"names a \.json file, but the format asked for is smesh",
        ),
    ],
)
def test_a_format_that_contradicts_the_file_s_suffix_is_refused(built, tmp_path, write, name, match):
    # was: VTK XML written into s.vtk, which read_surface (going by the suffix) then refused
    _, surface, nurbs = built
    with pytest.raises(InputError, match=match):
        write(nurbs if name.endswith(".json") else surface, tmp_path / name)
    assert list(tmp_path.iterdir()) == []
    assert rp.write_vtk(surface, tmp_path / "plain.txt") > 0  # a suffix of no format: the caller's choice


def test_a_comparison_is_frozen_through_and_through_and_its_intervals_are_floats():
    # was: C.statistics["x"] = 1 worked on a frozen Comparison; ci95 held np.float64
    result = rp.compare(rp.random_cloud(60, rng=2))
    with pytest.raises(TypeError):
        result.statistics["x"] = 1
    with pytest.raises(TypeError):
        result.pairings["x"] = 1
    stats = result.statistics["cloud-points"]
    assert all(type(v) is float for v in (*stats.ci95, *stats.tost_ci))


def test_an_empty_cloud_is_named_empty_and_pandas_index_column_is_pointed_at(tmp_path):
    import pandas as pd

    from replication.errors import CloudFileError

    # was: "need at least 3 points", where saving 2 points works
    with pytest.raises(InputError, match=r"points is empty: no points$"):
        rp.save_cloud(np.empty((0, 3)), tmp_path / "e.csv")
    pd.DataFrame(np.random.default_rng(0).random((5, 3)), columns=list("xyz")).to_csv(tmp_path / "p.csv")
    with pytest.raises(
        CloudFileError, match=r"names 4 columns, .*; its first column is pandas' row index: save "
    ):
        rp.load_cloud(tmp_path / "p.csv")
