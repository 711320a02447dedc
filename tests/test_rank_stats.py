"""Rank agreement: Spearman and Kendall equal scipy's (ties included), seeded bootstrap, top-k."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats

from replication.errors import InputError
from replication.experiments.rank_stats import (
    bootstrap_interval,
    kendall_tau_b,
    rank_agreement,
    spearman,
    top_k_overlap,
)

scores = st.lists(st.integers(0, 6), min_size=3, max_size=25)  # small range: many ties


@given(scores, st.randoms(use_true_random=False))
def test_spearman_and_kendall_equal_scipys_with_ties(x, random):
    y = [random.randint(0, 6) for _ in x]
    if len(set(x)) < 2 or len(set(y)) < 2:
        assert np.isnan(spearman(x, y)) and np.isnan(kendall_tau_b(x, y))
        return
    assert spearman(x, y) == pytest.approx(stats.spearmanr(x, y).statistic, abs=1e-12)
    assert kendall_tau_b(x, y) == pytest.approx(stats.kendalltau(x, y).statistic, abs=1e-12)


def test_known_answers():
    x = [1.0, 2.0, 3.0, 4.0, 5.0]
    assert spearman(x, x) == 1.0 and kendall_tau_b(x, x) == 1.0
    assert spearman(x, x[::-1]) == -1.0 and kendall_tau_b(x, x[::-1]) == -1.0
    # one swapped neighbour pair of five: 1 discordant pair of 10; d^2 sum 2
    y = [1.0, 2.0, 4.0, 3.0, 5.0]
    assert kendall_tau_b(x, y) == pytest.approx(0.8)
    assert spearman(x, y) == pytest.approx(1 - 6 * 2 / (5 * 24))
    # rank statistics ignore monotone transformations
    assert spearman(np.exp(x), np.square(y)) == spearman(x, y)


def test_rows_are_scored_independently():
    a = np.array([[1.0, 2, 3, 4], [4, 3, 2, 1]])
    b = np.array([[1.0, 2, 3, 4], [1, 2, 3, 4]])
    np.testing.assert_allclose(spearman(a, b), [1.0, -1.0])
    np.testing.assert_allclose(kendall_tau_b(a, b), [1.0, -1.0])


def test_bootstrap_is_seeded_and_covers_the_estimate():
    rng = np.random.default_rng(3)
    x = rng.normal(size=30)
    y = x + 0.5 * rng.normal(size=30)
    one = bootstrap_interval(x, y, spearman, resamples=2000, rng=7)
    assert one == bootstrap_interval(x, y, spearman, resamples=2000, rng=7)
    assert one != bootstrap_interval(x, y, spearman, resamples=2000, rng=8)
    assert one[0] < spearman(x, y) < one[1] and -1 <= one[0] and one[1] <= 1
    np.random.seed(0)  # the global state plays no part
    agreement = rank_agreement(x, y, resamples=500, rng=11)
    np.random.seed(1)
    assert agreement == rank_agreement(x, y, resamples=500, rng=11)
    assert agreement.n == 30 and agreement.kendall_low < agreement.kendall < agreement.kendall_high


def test_perfect_agreement_has_a_degenerate_interval():
    x = np.arange(10.0)
    assert bootstrap_interval(x, 2 * x, kendall_tau_b, resamples=200, rng=1) == (1.0, 1.0)


def test_top_k_overlap():
    model = [5.0, 4.0, 3.0, 2.0, 1.0]
    sph = [1.0, 4.0, 5.0, 2.0, 3.0]
    assert top_k_overlap(model, sph, 1) == 0  # model's best (index 0) is SPH's worst
    assert top_k_overlap(model, sph, 2) == 1  # {0, 1} vs {2, 1}
    assert top_k_overlap(model, sph, 5) == 5


def test_bad_inputs_name_the_problem():
    with pytest.raises(InputError, match="equal-length"):
        spearman([1, 2, 3], [1, 2])
    with pytest.raises(InputError, match="finite"):
        kendall_tau_b([1, 2, np.nan], [1, 2, 3])
    with pytest.raises(InputError, match="k must lie"):
        top_k_overlap([1, 2, 3], [1, 2, 3], 4)
    with pytest.raises(InputError, match="confidence level"):
        bootstrap_interval([1, 2, 3], [1, 2, 3], spearman, level=1.5)
    # were IndexError, numpy's concatenate or default_rng errors
    with pytest.raises(InputError, match="equal-length scorings of at least 2 surfaces"):
        spearman(1.0, 2.0)
    with pytest.raises(InputError, match="resamples must be an integer of at least 1, got 0"):
        bootstrap_interval([1, 2, 3], [1, 3, 2], spearman, resamples=0)
    with pytest.raises(InputError, match="chunk must be an integer of at least 1, got 0"):
        bootstrap_interval([1, 2, 3], [1, 3, 2], spearman, chunk=0)
    with pytest.raises(InputError, match="rng must be a seed"):
        bootstrap_interval([1, 2, 3], [1, 3, 2], spearman, rng=-1)
    with pytest.raises(InputError, match="two 1-D scorings"):
        bootstrap_interval([[1, 2, 3]], [[1, 3, 2]], spearman)
