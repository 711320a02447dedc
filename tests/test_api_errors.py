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
            r"names a \.vtk file, but the format written is vtp \(VTK XML\): name it \.vtp, or use "
            r"write_vtk\(\)",
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
    import copy
    import dataclasses
    import pickle

    result = rp.compare(rp.random_cloud(60, rng=2))
    for change in (
        lambda: result.statistics.__setitem__("x", 1),
        lambda: result.pairings.update(x=1),
        lambda: result.statistics.pop("cloud-points"),
        lambda: result.pairings.clear(),
    ):
        with pytest.raises(TypeError, match="read-only"):
            change()
    # ... and it still leaves its process and copies (a mappingproxy did neither)
    back = pickle.loads(pickle.dumps(result))
    assert back.statistics == result.statistics and type(back.statistics) is type(result.statistics)
    assert copy.deepcopy(result).statistics == result.statistics
    assert (
        dataclasses.asdict(result)["statistics"]["cloud-points"]["n"] == result.statistics["cloud-points"].n
    )
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


def test_a_file_of_the_other_format_can_still_be_read_by_naming_its_format(built, tmp_path):
    """Only writing refuses the contradiction: a file an older version wrote under the other
    suffix is read with its format named."""
    _, _, nurbs = built
    from replication.io.nurbs import read_nurbs, smesh_text

    (tmp_path / "old.json").write_text(smesh_text(nurbs.patch))
    np.testing.assert_array_equal(
        read_nurbs(tmp_path / "old.json", "smesh").control_points, nurbs.patch.control_points
    )


def test_objects_that_are_numbers_are_paired_samples_and_alpha_is_checked_before_any_work():
    from fractions import Fraction

    from replication.experiments.table1 import Table1Config

    a = [Fraction(k, 3) for k in range(1, 9)]
    b = [Fraction(k, 3) + Fraction(1, 10 + k) for k in range(1, 9)]
    ours = rp.paired_statistics(np.array(a, dtype=object), b, depth_range=3.0)
    assert ours == rp.paired_statistics([float(v) for v in a], [float(v) for v in b], depth_range=3.0)
    with pytest.raises(InputError, match=r"paired sample a must be real numbers: "):
        rp.paired_statistics(np.array(["x", 1, 2], dtype=object), [1, 2, 3], depth_range=3.0)
    for alpha in (0.6, 1.6):  # was: refused after both surfaces were built, or a run's Monte Carlo
        with pytest.raises(InputError, match=r"alpha must be in \(0, 0.5\)"):
            rp.compare(np.zeros((0, 3)), alpha=alpha)
        with pytest.raises(InputError, match=r"alpha must be in \(0, 0.5\)"):
            Table1Config(alpha=alpha)


def test_masked_structured_arrays_and_frame_like_objects():
    from replication.surfaces.cloud import as_cloud

    cloud = np.array([[0, 0, 1.0], [1, 0, 2], [0, 1, 3]])
    fields = [("z", "f8"), ("x", "f8"), ("y", "f8")]
    hidden = np.array([(True, False, False), (False,) * 3, (False,) * 3], dtype=[(f, "?") for f, _ in fields])
    records = np.ma.masked_array(np.zeros(3, dtype=fields), mask=hidden)
    with pytest.raises(InputError, match=r"points: 1 masked value\(s\)"):  # was: the hidden values, used
        as_cloud(records)

    class Frame:  # what a DataFrame library other than pandas offers: no .iloc
        columns = ["z", "x", "y"]

        def to_numpy(self):
            return cloud[:, [2, 0, 1]]

        def __array__(self, dtype=None, copy=None):
            return self.to_numpy()

    np.testing.assert_array_equal(as_cloud(Frame()), cloud)  # was: AttributeError: no attribute 'iloc'


def test_underflow_is_not_blamed_for_a_line_and_json_refuses_an_overflowing_net(built, tmp_path):
    from replication.errors import DegenerateInputError
    from replication.surfaces.nurbs import NurbsPatch, clamped_uniform_knots

    line = np.array([[0, 0, 1], [1e-200, 1e-200, 2], [1, 1, 3], [2, 2, 4.0]])
    with pytest.raises(DegenerateInputError, match="collinear") as caught:
        rp.adt(line, depth="z")
    assert "underflow" not in str(caught.value)
    k = clamped_uniform_knots(3, 2)
    patch = NurbsPatch(2, 2, k, k, np.full((3, 3, 3), 1e300), np.full((3, 3), 1e10))
    with pytest.raises(
        InputError, match=r"control point 0 times its weight overflows float64 .*write \.smesh"
    ):
        rp.write_nurbs(patch, tmp_path / "big.json")
    assert rp.write_nurbs(patch, tmp_path / "big.smesh") > 0
    with pytest.raises(InputError, match="of positive width"):  # was: ZeroDivisionError in the writers
        NurbsPatch(2, 2, np.zeros(6), k, np.zeros((3, 3, 3)), np.ones((3, 3)))


def test_a_hand_made_vertex_record_out_of_range_is_named(built):
    import dataclasses

    cloud, surface, _ = built
    bad = dataclasses.replace(surface, vertex_of_input=np.full(len(cloud), 10**6, np.int32))
    with pytest.raises(InputError, match="vertex_of_input does not fit the cloud"):  # was: IndexError
        rp.fit_nurbs(cloud, triangulation=bad)
