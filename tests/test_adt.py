"""ADT, paper section 3.2 steps 4-10: depth axis, projection, triangulation, lifting."""

import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from geometry import assert_valid_delaunay
from replication.errors import DegenerateInputError, DuplicatePointsWarning, InputError
from replication.surfaces import adt, projection_axes, select_depth_axis

X, Y, Z = 0, 1, 2

# every tie pattern of three spreads, with the axis each rule must choose (eq. 7 and 8)
TIE_TABLE = [
    # spreads, min rule, max rule
    ((1, 2, 3), X, Z),
    ((3, 1, 2), Y, X),
    ((2, 3, 1), Z, Y),
    ((1, 1, 2), Y, Z),  # min tie x=y: y (eq. 8 second line)
    ((1, 2, 1), Z, Y),  # min tie x=z: z first
    ((2, 1, 1), Z, X),  # min tie y=z: z first
    ((2, 2, 1), Z, Y),  # max tie x=y: y
    ((2, 1, 2), Y, Z),  # max tie x=z: z
    ((1, 2, 2), X, Z),  # max tie y=z: z
    ((1, 1, 1), Z, Z),  # all equal: z (eq. 8 first line)
]


@pytest.mark.parametrize(("spreads", "expect_min", "expect_max"), TIE_TABLE)
def test_depth_axis_every_tie_pattern(spreads, expect_min, expect_max):
    assert select_depth_axis(spreads, "min") == expect_min
    assert select_depth_axis(spreads, "max") == expect_max


def test_tie_tolerance_is_relative_to_the_largest_spread():
    assert select_depth_axis((1.0, 1.0 + 1e-12, 3.0), "min") == Y  # a tie: y wins
    assert select_depth_axis((1.0, 1.0 + 1e-6, 3.0), "min") == X  # not a tie
    assert select_depth_axis((1.0, 1.0 + 1e-6, 3.0), "min", tie_rtol=1e-3) == Y
    assert select_depth_axis((1.0, 1.0 + 1e-15, 3.0), "min", tie_rtol=0.0) == X


@pytest.mark.parametrize(
    "bad", [(1, 2), (1, 2, np.nan), (1, -2, 3), "abc"], ids=["short", "nan", "negative", "text"]
)
def test_depth_axis_bad_spreads(bad):
    with pytest.raises((InputError, ValueError)):
        select_depth_axis(bad)


def test_depth_axis_bad_rule():
    with pytest.raises(InputError, match="'median'"):
        select_depth_axis((1, 2, 3), "median")


def test_cloud_with_depth_axis_x():
    """Points spread in y and z, thin in x: projected on (y, z), normals towards +x."""
    rng = np.random.default_rng(4)
    cloud = np.column_stack([0.1 * rng.random(50), 10 * rng.random(50), 5 * rng.random(50)])
    s = adt(cloud)
    assert s.depth_axis == X and s.depth_axis_name == "x"
    assert s.projection_axes == (Y, Z)
    np.testing.assert_array_equal(s.points, cloud)  # no duplicates: vertices are the input
    assert_valid_delaunay(s.projected(), s.triangles)
    p = s.points[s.triangles]
    normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.all(normals[:, X] > 0)


@pytest.mark.parametrize(("depth", "axis"), [("min", Z), ("max", X), ("y", Y), ("x", X), ("z", Z)])
def test_depth_rules_on_an_anisotropic_cloud(depth, axis):
    rng = np.random.default_rng(5)
    cloud = rng.random((80, 3)) * [30.0, 20.0, 5.0]
    s = adt(cloud, depth=depth)
    assert s.depth_axis == axis
    assert s.projection_axes == projection_axes(axis)
    assert s.depth_rule == depth
    assert_valid_delaunay(s.projected(), s.triangles)


def test_spreads_are_population_standard_deviations():
    cloud = np.random.default_rng(6).random((30, 3))
    np.testing.assert_allclose(adt(cloud).spreads, np.std(cloud, axis=0))


def test_projection_axes_are_cyclic_and_right_handed():
    for d in range(3):
        u, v = projection_axes(d)
        assert np.cross(np.eye(3)[u], np.eye(3)[v])[d] == 1


def test_known_answer_square_with_centre():
    """Four corners and the centre of a unit square: four triangles meeting at the centre."""
    cloud = np.array([[0, 0, 0.0], [1, 0, 0.2], [1, 1, 0.1], [0, 1, 0.3], [0.5, 0.5, 0.9]])
    s = adt(cloud)
    assert s.depth_axis == Z and s.n_triangles == 4
    assert all(4 in t for t in s.triangles.tolist())
    # lifting: the triangles index the original 3-D points
    np.testing.assert_array_equal(s.points, cloud)
    assert s.to_polydata().n_cells == 4


def test_duplicate_policies():
    cloud = np.array(
        [[0, 0, 1.0], [4, 0, 0.0], [0, 4, 0.0], [0, 0, 3.0], [4, 4, 0.5], [0, 0, 2.0]]
    )  # rows 0, 3, 5 share (x, y) = (0, 0); depth axis z
    expected = {"mean": 2.0, "min": 1.0, "max": 3.0, "first": 1.0}
    for policy, depth in expected.items():
        with pytest.warns(DuplicatePointsWarning, match="merged 2 point"):
            s = adt(cloud, duplicates=policy)
        assert s.n_vertices == 4 and s.n_merged == 2 and s.duplicate_policy == policy
        np.testing.assert_array_equal(s.vertex_of_input, [0, 1, 2, 0, 3, 0])
        np.testing.assert_array_equal(s.merged_inputs, [0, 3, 5])
        assert s.points[0, Z] == depth
        np.testing.assert_array_equal(s.points[1:], cloud[[1, 2, 4]])


@given(st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=3, max_size=7), st.randoms())
def test_a_merged_mean_has_the_same_bits_in_any_row_order(depths, random):
    """Floating-point sums depend on their order: 0.1 + 0.2 + 0.7 and 0.7 + 0.2 + 0.1 differ in
    the last bit, and the mean of a group of duplicates followed the file's rows."""
    group = [[0.0, 0.0, d] for d in depths]
    cloud = np.array([*group, [4, 0, 0.0], [0, 4, 0.0], [4, 4, 0.5]])
    means = []
    for _ in range(3):
        rows = list(range(len(cloud)))
        random.shuffle(rows)
        with pytest.warns(DuplicatePointsWarning):
            s = adt(cloud[rows], depth="z")
        means.append(s.points[s.vertex_of_input[rows.index(0)], Z])
    assert means[0] == means[1] == means[2]
    assert means[0] == pytest.approx(sum(sorted(depths)) / len(depths), rel=1e-12, abs=1e-9)


def test_duplicate_policy_raise_names_the_rows():
    cloud = np.array([[0, 0, 1.0], [4, 0, 0.0], [0, 4, 0.0], [0, 0, 3.0]])
    with pytest.raises(InputError, match=r"rows 0, 3"):
        adt(cloud, duplicates="raise")


def test_unknown_duplicate_policy():
    with pytest.raises(InputError, match="'median'"):
        adt(np.eye(3), duplicates="median")


def test_no_warning_without_duplicates():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        adt(np.random.default_rng(0).random((20, 3)))


def test_negative_zero_equals_zero():
    cloud = np.array([[0.0, 0.0, 1.0], [-0.0, 0.0, 3.0], [1, 0, 0], [0, 1, 0]])
    with pytest.warns(DuplicatePointsWarning):
        assert adt(cloud, depth="z").n_vertices == 3


@pytest.mark.parametrize(
    ("cloud", "match"),
    [
        (np.array([[0, 0, 1.0], [0, 0, 2.0], [1, 1, 0.0], [1, 1, 1.0]]), "at least 3 distinct"),
        (np.array([[0, 0, 0.0], [1, 1, 0.0], [2, 2, 1.0], [3, 3, 0.0]]), r"collinear.*\(x, y\)"),
    ],
    ids=["two-positions", "collinear"],
)
def test_degenerate_clouds(cloud, match):
    with pytest.warns(DuplicatePointsWarning) if "distinct" in match else warnings.catch_warnings():
        with pytest.raises(DegenerateInputError, match=match):
            adt(cloud, depth="z")


@pytest.mark.parametrize(
    ("cloud", "match"),
    [
        (np.zeros((4, 2)), r"shape \(n, 3\), got shape \(4, 2\)"),
        (np.zeros((0, 3)), "empty"),
        ([[0, 0, 0], [1, 0, np.nan], [0, 1, 0], [1, np.inf, 1]], r"2 row\(s\), counted from 0: 1, 3"),
        ([["a", "b", "c"]], r"holds text \(such as 'a'\), not numbers"),
    ],
    ids=["shape", "empty", "nan", "text"],
)
def test_bad_clouds(cloud, match):
    with pytest.raises(InputError, match=match):
        adt(cloud)


def test_unknown_depth_rule():
    with pytest.raises(InputError, match="'w'"):
        adt(np.eye(3), depth="w")


def test_surface_is_immutable():
    s = adt(np.random.default_rng(0).random((10, 3)))
    with pytest.raises(ValueError, match="read-only"):
        s.points[0, 0] = 1.0
    with pytest.raises(AttributeError):
        s.depth_axis = 0


def test_backends_agree_on_the_same_cloud():
    cloud = np.random.default_rng(9).random((300, 3))
    a, b = adt(cloud, backend="sweephull"), adt(cloud, backend="scipy")
    assert a.backend == "sweephull" and b.backend == "scipy"
    assert {tuple(sorted(t)) for t in a.triangles.tolist()} == {
        tuple(sorted(t)) for t in b.triangles.tolist()
    }


def test_deterministic_and_independent_of_global_random_state(restore_global_rng):
    cloud = np.random.default_rng(10).random((100, 3))
    np.random.seed(1)
    a = adt(cloud)
    np.random.seed(2)
    b = adt(cloud)
    np.testing.assert_array_equal(a.triangles, b.triangles)


coords = st.one_of(
    st.integers(0, 5).map(float),  # a coarse lattice: many shared projected positions
    st.floats(-100, 100).map(lambda v: round(v, 4)),
)


@given(
    arrays(np.float64, st.tuples(st.integers(3, 60), st.just(3)), elements=coords),
    st.sampled_from(["min", "max"]),
)
def test_property_invariants(cloud, rule):
    """Every point (after merging) is a vertex, no degenerate triangle, the hull is tiled."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        try:
            s = adt(cloud, depth=rule)
        except DegenerateInputError:
            axis = select_depth_axis(np.std(cloud, axis=0), rule)
            uv = np.unique(cloud[:, list(projection_axes(axis))], axis=0)
            assert uv.shape[0] < 3 or np.linalg.matrix_rank(uv - uv[0]) < 2
            return
    uv_in = cloud[:, list(s.projection_axes)]
    # each input point is represented by the vertex at its projected position
    np.testing.assert_array_equal(s.projected()[s.vertex_of_input], uv_in)
    assert s.n_vertices == np.unique(uv_in, axis=0).shape[0]
    # unmerged points keep their exact coordinates
    counts = np.bincount(s.vertex_of_input)
    alone = counts[s.vertex_of_input] == 1
    np.testing.assert_array_equal(s.points[s.vertex_of_input[alone]], cloud[alone])
    # merged depths lie within their group's range (mean policy)
    depth = cloud[:, s.depth_axis]
    vd = s.points[s.vertex_of_input, s.depth_axis]
    lo = np.full(s.n_vertices, np.inf)
    hi = np.full(s.n_vertices, -np.inf)
    np.minimum.at(lo, s.vertex_of_input, depth)
    np.maximum.at(hi, s.vertex_of_input, depth)
    assert np.all((vd >= lo[s.vertex_of_input] - 1e-9) & (vd <= hi[s.vertex_of_input] + 1e-9))
    assert_valid_delaunay(s.projected(), s.triangles)


def test_spreads_of_a_large_cloud_are_exact_enough_and_thread_independent():
    import numba

    from replication.surfaces._spread import column_spreads

    cloud = np.random.default_rng(3).normal(5.0, [1.0, 2.0, 3.0], size=(300_000, 3))
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        serial, finite = column_spreads(cloud)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        parallel, _ = column_spreads(cloud)
    finally:
        numba.set_num_threads(threads)
    assert finite and np.array_equal(serial, parallel)
    np.testing.assert_allclose(serial, np.std(cloud, axis=0), rtol=1e-12)
    assert not column_spreads(np.where(np.arange(300_000)[:, None] == 7, np.nan, cloud))[1]


def test_spreads_of_columns_of_very_different_magnitudes_are_each_right():
    """One scale for the whole cloud made a column of ones beside one of 1e200 read a spread of
    0 (its squared deviations underflowed): the spreads a surface reports were wrong."""
    from replication.surfaces._spread import validated_cloud

    x = np.array([-1e200, 1e200, -1e200, 1e200])
    y = np.array([0.0, 1e-9, 0.0, 2e-9])
    z = np.array([0.0, 1.0, 2.0, 3.0])
    _, spreads = validated_cloud(np.column_stack([x, y, z]))
    expected = [np.std(v / s) * s for v, s in ((x, 1e200), (y, 1e-9), (z, 1.0))]
    np.testing.assert_allclose(spreads, expected, rtol=1e-14)  # before: (1e200, 0, 0)


@given(st.integers(0, 2**32 - 1), st.integers(-1000, 1000))
def test_the_depth_axis_and_surface_do_not_depend_on_the_units(seed, exponent):
    """Squared deviations underflowed (every spread 0 at 1e-170: the tie rule chose z) or
    overflowed (a cloud at 1e160 was refused); a power-of-two scale changes nothing."""
    from replication.surfaces import random_cloud

    cloud = random_cloud(30, rng=seed) * [0.1, 1.0, 0.8]
    reference = adt(cloud)
    scaled = adt(np.ldexp(cloud, exponent))
    assert scaled.depth_axis == reference.depth_axis == 0
    np.testing.assert_array_equal(scaled.triangles, reference.triangles)
    np.testing.assert_array_equal(scaled.points, np.ldexp(reference.points, exponent))
