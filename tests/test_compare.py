"""Paired deviations of ADT and NURBS depths (section 4), both pairings."""

import warnings

import numpy as np
import pytest

from geometry import DIAGONAL_CLOUD
from replication.compare import compare, pair_at_cloud_points, pair_at_nurbs_samples
from replication.errors import DuplicatePointsWarning, InputError
from replication.surfaces import adt, random_cloud
from replication.surfaces.nurbs import fit_nurbs


def _planar_cloud(n=60, seed=0):
    rng = np.random.default_rng(seed)
    xy = np.vstack([[[0, 0], [10, 0], [0, 8], [10, 8]], rng.random((n - 4, 2)) * [10, 8]])
    return np.column_stack([xy, 0.3 * xy[:, 0] - 0.2 * xy[:, 1] + 1.0])


def test_planar_cloud_deviations_are_zero_both_ways():
    result = compare(_planar_cloud(), depth="z")
    for name, pairs in result.pairings.items():
        assert pairs.n > 0, name
        assert np.abs(pairs.differences).max() <= 1e-12, name
        assert pairs.n_outside_adt == pairs.n_outside_nurbs == 0
        st = result.statistics[name]
        assert st.max_abs <= 1e-12 and st.equivalent


def test_pairing_a_excludes_and_counts_samples_outside_the_hull():
    cloud = random_cloud(45, rng=1)
    s = adt(cloud)
    nurbs = fit_nurbs(cloud, tessellation=None, triangulation=s)
    pairs = pair_at_nurbs_samples(s, nurbs, (30, 30))
    assert pairs.n_candidates == 900 and pairs.n + pairs.n_outside_adt == 900
    assert pairs.n_outside_adt > 0  # the corners of the bounding box are outside the hull


def test_pairing_b_uses_every_distinct_position_exactly():
    cloud = random_cloud(100, rng=2)
    s = adt(cloud)
    nurbs = fit_nurbs(cloud, tessellation=None, triangulation=s)
    pairs = pair_at_cloud_points(s, nurbs)
    assert pairs.n == s.n_vertices and pairs.n_outside_nurbs == 0
    np.testing.assert_array_equal(pairs.adt, s.points[:, 2])
    np.testing.assert_array_equal(pairs.positions, s.projected())


def test_duplicates_are_paired_once():
    cloud = random_cloud(169, step=1.0, rng=3)
    with pytest.warns(DuplicatePointsWarning):
        result = compare(cloud)
    assert result.pairings["cloud-points"].n_candidates == result.adt.n_vertices < 169


def test_frames_must_match():
    cloud = random_cloud(50, rng=4)
    with pytest.raises(InputError, match="different planes"):
        pair_at_cloud_points(adt(cloud, depth="x"), fit_nurbs(cloud, depth="z", tessellation=None))


def test_tiny_pairings_have_no_statistics():
    cloud = np.array(
        [
            [0, 0, 0],
            [10, 0, 1],
            [0, 10, 2],
            [10, 10, 3],
            [5, 5, 4],
            [2, 8, 1],
            [8, 2, 0],
            [5, 1, 2],
            [1, 5, 3.0],
        ]
    )
    result = compare(cloud, depth="z", sample_shape=(2, 2))
    assert result.pairings["nurbs-samples"].n == 4 and result.statistics["nurbs-samples"] is not None
    # a thin cloud along the diagonal, sampled 2 x 2 at its bounding-box corners: (0, 0) and
    # (10, 10) are cloud points, (0, 10) and (10, 0) lie outside the hull -> 2 pairs, no tests
    small = DIAGONAL_CLOUD
    result = compare(small, depth="z", sample_shape=(2, 2))
    assert result.pairings["nurbs-samples"].n == 2
    assert result.statistics["nurbs-samples"] is None
    assert result.statistics["cloud-points"] is not None


def test_seeded_comparison_is_deterministic():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        a = compare(random_cloud(100, step=1.0, rng=5))
        b = compare(random_cloud(100, step=1.0, rng=5))
    for name in a.pairings:
        np.testing.assert_array_equal(a.pairings[name].differences, b.pairings[name].differences)
        assert a.statistics[name] == b.statistics[name]


def test_flat_cloud_is_a_clear_error():
    from replication.casestudy.shapes import flat_plate_cloud
    from replication.errors import DegenerateInputError

    with pytest.raises(DegenerateInputError, match="flat along its depth axis z"):
        compare(flat_plate_cloud())
