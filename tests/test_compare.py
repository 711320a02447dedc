"""Paired deviations of ADT and NURBS depths (section 4), both pairings."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

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


@pytest.mark.parametrize("k", [-100, -50, 20, 100])
def test_compare_is_the_same_at_every_power_of_two_scale(k):
    # the NURBS inversion had an absolute tolerance: at 2**100 (or in nm) 12-14 of 30 cloud points
    # were called "outside the NURBS footprint", at 2**-100 the starting guesses were accepted
    from replication import compare, random_cloud

    cloud = random_cloud(30, rng=4)
    base, scaled = compare(cloud), compare(np.ldexp(cloud, k))
    for name in ("cloud-points", "nurbs-samples"):
        p, q = base.pairings[name], scaled.pairings[name]
        assert (q.n, q.n_outside_nurbs) == (p.n, p.n_outside_nurbs)
        np.testing.assert_array_equal(q.nurbs, np.ldexp(p.nurbs, k))
        s, t = base.statistics[name], scaled.statistics[name]
        assert (t.t_test, t.wilcoxon, t.rms_percent) == (s.t_test, s.wilcoxon, s.rms_percent)
    assert base.pairings["cloud-points"].n_outside_nurbs == 0


def test_an_offset_cloud_keeps_every_point_inside_the_nurbs_footprint():
    # 4 of 30 points of a cloud 1e7 mm from the origin were excluded as outside (the grid spans them all)
    from replication import compare, random_cloud

    cloud = random_cloud(30, rng=4)
    far = compare(cloud + [1e7, 1e7, 0]).pairings["cloud-points"]
    assert far.n == 30 and far.n_outside_nurbs == 0


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda c: adt(c, tie_rtol="1e-9"), "tie_rtol must be a finite real number, got '1e-9'"),
        (lambda c: compare(c, alpha="0.05"), "alpha must be a finite real number"),
        (lambda c: compare(c, sample_shape=(2.5, 5)), "sample_shape must be two integers of at least 2"),
        (lambda c: compare(c, sample_shape=(0, 5)), r"got \(0, 5\)"),  # was: no pairing, without a word
        (lambda c: fit_nurbs(c, net="4x5"), "net must be a pair of integers, got '4x5'"),
        (lambda c: fit_nurbs(c, net=(4,)), "net must be a pair of integers"),
    ],
)
def test_settings_of_the_wrong_type_are_input_errors(call, match):
    # were numpy's or Python's own TypeError/ValueError from deep inside
    with pytest.raises(InputError, match=match):
        call(random_cloud(30, rng=4))


def test_the_arrays_of_results_are_read_only():
    # PairedDepths, the NURBS grid and tessellation could be changed in place, putting them out of
    # step with the statistics computed from them (Surface was read-only already)
    cloud = random_cloud(30, rng=4)
    result = compare(cloud)
    nurbs = fit_nurbs(cloud, evaluator="fast")
    arrays = [
        getattr(p, k)
        for p in result.pairings.values()
        if p is not None
        for k in ("positions", "adt", "nurbs")
    ]
    arrays += [nurbs.grid.u, nurbs.grid.v, nurbs.grid.depth, nurbs.grid.filled, nurbs.tessellation]
    for a in arrays:
        with pytest.raises(ValueError, match="read-only"):
            a[...] = 0
    assert cloud.flags.writeable  # the caller's cloud is not frozen


def test_a_shifted_cloud_gives_the_same_wilcoxon_test():
    # one difference was exactly 0.0, and 3.6e-14 after the shift: the p-value moved 0.948 -> 0.969
    cloud = random_cloud(50, rng=3)
    base, shifted = compare(cloud), compare(cloud + [1000.0, -500.0, 37.0])
    assert shifted.statistics["cloud-points"].wilcoxon == base.statistics["cloud-points"].wilcoxon


@pytest.mark.parametrize("offset", [1e6, 1e9])
def test_a_cloud_far_from_zero_gives_the_same_wilcoxon_test(offset):
    # the rounding tolerance was 1e-12 of the depths' size, 1e-3 at an offset of 1e9: deviations
    # that close became ties and the p-value moved 0.985 -> 0.996; the offset itself moves the
    # deviations by about 3 epsilons of it (7e-7 here), far below the 64 of the tolerance
    cloud = random_cloud(50, rng=0)
    base, far = compare(cloud, depth="z"), compare(cloud + [0.0, 0.0, offset], depth="z")
    for name in ("nurbs-samples", "cloud-points"):
        assert far.statistics[name].wilcoxon == base.statistics[name].wilcoxon, name
        assert far.statistics[name].paper_verdict == base.statistics[name].paper_verdict, name


@pytest.mark.parametrize(("n", "seed"), [(12, 61), (20, 0), (20, 2), (200, 3)])
def test_nurbs_samples_on_a_lattice_hull_edge_do_not_depend_on_offset_or_units(n, seed):
    # samples on the hull edge at v = ymin were kept or dropped by the rounding of their
    # evaluated position: 3 pairs, or 2 (no statistics) for the same cloud shifted by (1000, -500, 37)
    cloud = random_cloud(n, rng=seed, step=1)
    warnings.simplefilter("ignore", DuplicatePointsWarning)  # a lattice repeats positions
    counts = {
        name: compare(c).pairings["nurbs-samples"].n
        for name, c in (("mm", cloud), ("shifted", cloud + [1000.0, -500.0, 37.0]), ("m", cloud / 1000))
    }
    assert len(set(counts.values())) == 1, counts


@settings(max_examples=25, deadline=None)
@given(st.integers(9, 200), st.integers(0, 2**32 - 1))
def test_a_lattice_cloud_compares_alike_in_any_row_order(n, seed):
    """Shuffling the rows of a lattice cloud moved the NURBS fit (nodes outside the hull took
    the depth of the first of equally near points in the file: 7 where 1 was the point set's
    answer) and flipped TOST verdicts: 7 of 900 shuffled lattice clouds of 45-200 points. The
    fit is now a function of the point set, up to the order of floating-point sums (a grid
    node on an edge is interpolated in the first triangle holding it, and the triangles'
    numbering follows the rows); merged duplicates have the same depth to the bit."""
    cloud = random_cloud(n, step=1.0, rng=seed)
    order = np.random.default_rng(seed).permutation(n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        first, shuffled = compare(cloud), compare(cloud[order])
    frames = [(list(c.adt.projection_axes), c.adt.depth_axis) for c in (first, shuffled)]
    assert frames[0] == frames[1]
    (uv, d) = frames[0]
    depth_at = [{tuple(p[uv]): p[d] for p in c.adt.points} for c in (first, shuffled)]
    assert depth_at[0] == depth_at[1]
    scale = float(np.ptp(cloud[:, first.adt.depth_axis])) or 1.0
    grids = [c.nurbs.grid for c in (first, shuffled)]
    assert np.array_equal(grids[0].filled, grids[1].filled)
    np.testing.assert_allclose(grids[0].depth, grids[1].depth, rtol=0, atol=1e-13 * scale)
    nets = [c.nurbs.patch.control_points for c in (first, shuffled)]
    np.testing.assert_allclose(nets[0], nets[1], rtol=0, atol=1e-13 * scale)
    for name, stats in first.statistics.items():
        other = shuffled.statistics[name]
        if stats is None:
            assert other is None
            continue
        # the cloud points' pairs come in row order: sums may differ in their last bits
        assert stats.n == other.n and stats.equivalent == other.equivalent
        assert stats.t_test.similar == other.t_test.similar
        assert stats.wilcoxon.similar == other.wilcoxon.similar
        np.testing.assert_allclose(
            [stats.mean_difference, stats.tost_p, stats.t_test.p_value, stats.wilcoxon.p_value],
            [other.mean_difference, other.tost_p, other.t_test.p_value, other.wilcoxon.p_value],
            rtol=1e-9,
            atol=1e-15,
        )
