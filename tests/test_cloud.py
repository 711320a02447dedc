"""Random point clouds in a box (paper eq. 1-4)."""

import re

import numpy as np
import pytest

from replication.errors import InputError
from replication.surfaces import CASE_STUDY_BOX, Box, random_cloud
from replication.surfaces.cloud import lattice_values


def test_continuous_cloud_in_box():
    box = Box(-1, 2, 10, 11, 0, 0.5)
    c = random_cloud(1000, box, rng=0)
    assert c.shape == (1000, 3)
    assert np.all(c >= box.lower) and np.all(c <= box.upper)
    # uniform: each coordinate's mean near the box centre
    np.testing.assert_allclose(c.mean(axis=0), (box.lower + box.upper) / 2, atol=0.05 * 3)


def test_lattice_cloud_uses_every_node_uniformly():
    c = random_cloud(37000, CASE_STUDY_BOX, step=1.0, rng=1)
    assert np.all(c == np.round(c))
    xs, counts = np.unique(c[:, 0], return_counts=True)
    np.testing.assert_array_equal(xs, np.arange(37.0))  # 0..36 inclusive
    assert counts.min() > 800 and counts.max() < 1200  # ~1000 each
    assert set(np.unique(c[:, 2])) == set(np.arange(14.0))


def test_lattice_values_include_the_upper_bound():
    np.testing.assert_allclose(lattice_values(0.0, 1.0, 0.1), np.arange(11) / 10)
    np.testing.assert_array_equal(lattice_values(0.0, 1.0, 0.3), [0, 0.3, 0.6, 0.8999999999999999])
    np.testing.assert_array_equal(lattice_values(2.0, 2.0, 1.0), [2.0])


def test_seeded_clouds_are_reproducible_and_ignore_global_state(restore_global_rng):
    np.random.seed(0)
    a = random_cloud(50, rng=42)
    np.random.seed(1)
    b = random_cloud(50, rng=42)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, random_cloud(50, rng=np.random.default_rng(42)))
    assert not np.array_equal(a, random_cloud(50, rng=43))


def test_flat_box_side():
    c = random_cloud(20, Box(0, 1, 0, 1, 3, 3), rng=0)
    assert np.all(c[:, 2] == 3)


@pytest.mark.parametrize("n", [0, -3, 2.5, True, "10"])
def test_bad_point_count(n):
    with pytest.raises(InputError, match="positive integer"):
        random_cloud(n)


@pytest.mark.parametrize("step", [0.0, -1.0, np.inf, np.nan])
def test_bad_step(step):
    with pytest.raises(InputError, match="step"):
        random_cloud(5, step=step)


@pytest.mark.parametrize("step", [1e-300, 5e-324, 36 / 2**53])
def test_a_step_too_fine_for_the_box_is_named_not_a_memory_error(step):
    """The lattice was built in full before the draws: a step of 1e-300 asked numpy for 3.6e301
    values ('Maximum allowed size exceeded'), and one of 1e-9 for 288 GB."""
    with pytest.raises(InputError, match=r"step .* is too fine for the range \[0, 36\]: .* at most 2\^53"):
        random_cloud(5, step=step)


@pytest.mark.parametrize("step", [1.0, 0.3, 1e-9])
def test_lattice_draws_are_the_lattice_s_values(step):
    """Drawn without building the lattice, the coordinates are exactly those of lattice_values
    at the same draws (the committed reports' seeded clouds do not change)."""
    box = Box(-1.5, 2.0, 0.0, 30.0, 3.0, 3.0)
    cloud = random_cloud(400, box, step=step, rng=7)
    gen = np.random.default_rng(7)
    for axis in range(3):
        lo, hi = box.lower[axis], box.upper[axis]
        if step < 1e-6:  # the lattice is too big to build here: lattice_values' formula
            k = gen.integers(0, int(np.floor((hi - lo) / step * (1 + 1e-12) + 1e-9)) + 1, size=400)
            np.testing.assert_array_equal(cloud[:, axis], lo + step * k.astype(np.float64))
        else:
            values = lattice_values(lo, hi, step)
            np.testing.assert_array_equal(cloud[:, axis], values[gen.integers(0, values.size, size=400)])


def test_bad_boxes():
    with pytest.raises(InputError, match="xmin > xmax"):
        Box(1, 0, 0, 1, 0, 1)
    with pytest.raises(InputError, match="finite"):
        Box(0, np.inf, 0, 1, 0, 1)
    with pytest.raises(InputError, match="6 bounds"):
        Box.from_bounds([0, 1, 0, 1])


@pytest.mark.parametrize("rng", [-1, "seed", 1.5])
def test_bad_seeds_are_input_errors(rng):
    with pytest.raises(InputError, match="seed"):
        random_cloud(5, rng=rng)


@pytest.mark.parametrize("rng", [True, -1, 2.5, "7"])
def test_every_stochastic_function_names_a_bad_rng(rng):
    # numpy's default_rng takes True for seed 1; -1, 2.5 and "7" raised numpy's own errors
    from replication.casestudy.ga import GAConfig, random_genome
    from replication.errors import InputError
    from replication.experiments.rank_stats import bootstrap_interval, spearman
    from replication.surfaces import random_cloud

    calls = [
        lambda: random_cloud(5, rng=rng),
        lambda: random_genome(GAConfig(), rng=rng),
        lambda: bootstrap_interval([1.0, 2.0, 3.0], [1.0, 3.0, 2.0], spearman, rng=rng),
    ]
    for call in calls:
        with pytest.raises(InputError, match=f"rng must be a seed .* got {re.escape(repr(rng))}"):
            call()


def _frame(columns):
    import pandas as pd

    return pd.DataFrame(columns)


@pytest.mark.parametrize(
    "make",
    [
        lambda: np.array([["1_000", "2", "3"], ["4", "5", "6"], ["7", "8", "1"]]),
        lambda: np.array([[b"1", b"2", b"3"], [b"4", b"5", b"6"], [b"7", b"8", b"1"]]),
        lambda: [["1_000", "2", "3"], ["4", "5", "6"], ["7", "8", "1"]],
        lambda: np.array([[1.0, 2.0, 3.0], [4.0, " 5 ", 6.0], [7.0, 8.0, 1.0]], dtype=object),
        lambda: _frame({"x": ["1_000", "4", "7"], "y": [2.0, 5, 8], "z": [3.0, 6, 1]}),
        lambda: _frame({"z": ["3", "6", "1"], "y": ["2", "5", "8"], "x": ["1", "4", "7"]}),
        lambda: _frame({"x": ["1", "4", "7"], "y": [2.0, 5, 8], "z": [3, 6, 1]}).astype({"x": "string"}),
    ],
    ids=["str", "bytes", "list", "object", "frame", "reordered-frame", "string-dtype"],
)
def test_text_coordinates_are_refused_as_a_file_of_them_is(make):
    """numpy converted text by its own rules ('1_000' is 1000, ' 5 ' is 5) where a cloud file
    and a .npy of text are refused: one cloud gave other points in memory than from its file."""
    from replication.surfaces import adt
    from replication.surfaces.cloud import as_cloud

    for build in (as_cloud, adt):
        with pytest.raises(InputError, match=r"^points holds text \(such as .*\), not numbers"):
            build(make())


@pytest.mark.parametrize(
    "points",
    [
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.5], [0.0, 1.0, 0.25]],
        np.array([[0, 0, 0], [1, 0, 0.5], [0, 1, 0.25]], dtype=object),
        (np.zeros(3), np.array([1.0, 0.0, 0.5]), np.array([0.0, 1.0, 0.25])),
    ],
    ids=["list", "object-of-numbers", "tuple-of-arrays"],
)
def test_numbers_in_lists_and_object_arrays_still_read(points):
    from replication.surfaces.cloud import as_cloud

    np.testing.assert_array_equal(as_cloud(points), [[0, 0, 0], [1, 0, 0.5], [0, 1, 0.25]])


def test_text_is_refused_from_any_array_like_and_other_shapes_keep_their_errors():
    import collections

    import pandas as pd

    from replication.surfaces.cloud import as_cloud

    class Wrapped:  # an array-like (as xarray's DataArray is) holding text
        def __array__(self, dtype=None, copy=None):
            return np.array([["1_000", "2", "3"], ["4", "5", "6"], ["7", "8", "1"]])

    rows = [["1_000", "2", "3"], ["4", " 5 ", "6"], ["7", "8", "1"]]
    for points in (collections.deque(rows), Wrapped()):
        with pytest.raises(InputError, match=r"holds text \(such as '1_000'\)"):
            as_cloud(points)
    with pytest.raises(InputError, match=r"must have shape \(n, 3\), got shape \(3,\)"):
        as_cloud(pd.Series([1.0, 2.0, 3.0]))  # (a Series was a TypeError of the text check)


def test_an_empty_text_array_is_called_empty():
    from replication.surfaces.cloud import as_cloud

    with pytest.raises(InputError, match="points is empty: no points"):
        as_cloud(np.zeros((0, 3), dtype="U1"))
