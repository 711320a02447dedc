"""Paired statistics: agreement with scipy, TOST behaviour, edge cases."""

import functools

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as hst
from hypothesis.extra import numpy as st_np
from scipy import stats

from replication import stats as ours
from replication.errors import InputError
from replication.stats import paired_statistics, rounding_tolerance


@pytest.fixture
def samples():
    rng = np.random.default_rng(0)
    a = rng.normal(5.0, 1.0, 60)
    b = a + rng.normal(0.1, 0.3, 60)
    return a, b


def test_agrees_with_direct_scipy_calls(samples):
    a, b = samples
    st = paired_statistics(a, b, depth_range=10.0)
    t = stats.ttest_rel(a, b)
    w = stats.wilcoxon(a, b)
    assert st.t_test.statistic == pytest.approx(t.statistic, rel=1e-12)
    assert st.t_test.p_value == pytest.approx(t.pvalue, rel=1e-12)
    assert st.wilcoxon.statistic == pytest.approx(w.statistic, rel=1e-12)
    assert st.wilcoxon.p_value == pytest.approx(w.pvalue, rel=1e-12)
    assert st.normality_p == pytest.approx(stats.shapiro(a - b).pvalue, rel=1e-12)
    d = a - b
    assert st.mean_difference == pytest.approx(d.mean())
    assert st.sd_difference == pytest.approx(d.std(ddof=1))
    assert st.cohens_dz == pytest.approx(d.mean() / d.std(ddof=1))
    assert st.rms == pytest.approx(np.sqrt(np.mean(d**2)))
    assert st.max_abs == pytest.approx(np.abs(d).max())
    assert st.rms_percent == pytest.approx(10 * st.rms)  # 100 / depth range 10
    ci = stats.ttest_rel(a, b).confidence_interval(0.95)
    np.testing.assert_allclose(st.ci95, (ci.low, ci.high), rtol=1e-12)
    ci90 = stats.ttest_rel(a, b).confidence_interval(0.90)
    np.testing.assert_allclose(st.tost_ci, (ci90.low, ci90.high), rtol=1e-12)


def test_tost_matches_two_one_sided_scipy_tests(samples):
    a, b = samples
    st = paired_statistics(a, b, depth_range=10.0, margin_fraction=0.05)
    d = a - b
    p1 = stats.ttest_1samp(d, -0.5, alternative="greater").pvalue
    p2 = stats.ttest_1samp(d, 0.5, alternative="less").pvalue
    assert st.margin == pytest.approx(0.5)
    assert st.tost_p == pytest.approx(max(p1, p2), rel=1e-12)
    # TOST at alpha <=> the 90% CI lies within the margin
    assert st.equivalent == (-0.5 < st.tost_ci[0] and st.tost_ci[1] < 0.5)


def test_tost_declares_identical_surfaces_with_noise_equivalent():
    rng = np.random.default_rng(1)
    a = rng.random(200) * 13
    st = paired_statistics(a, a + rng.normal(0, 0.05, 200), depth_range=13.0)
    assert st.equivalent and st.tost_p < 1e-10


def test_tost_refuses_surfaces_offset_beyond_the_margin():
    rng = np.random.default_rng(2)
    a = rng.random(200) * 13
    st = paired_statistics(a, a + 1.0 + rng.normal(0, 0.05, 200), depth_range=13.0)  # margin 0.65
    assert not st.equivalent
    # ...while the paper's logic would call large offsets "different", it calls a noisy small
    # sample "similar": failing to reject is not evidence of similarity
    small = paired_statistics(a[:5], a[:5] + rng.normal(0, 3.0, 5), depth_range=13.0)
    assert small.paper_verdict == "similar" and not small.equivalent


def test_normality_picks_the_test():
    rng = np.random.default_rng(3)
    a = rng.random(300)
    normal = paired_statistics(a, a + rng.normal(0, 0.1, 300), depth_range=1.0)
    skewed = paired_statistics(a, a + rng.exponential(0.1, 300) ** 3, depth_range=1.0)
    assert normal.recommended_test == "t-test"
    assert skewed.recommended_test == "Wilcoxon signed-rank"


def test_large_samples_use_dagostino():
    rng = np.random.default_rng(4)
    a = rng.random(6000)
    b = a + rng.normal(0, 0.1, 6000)
    st = paired_statistics(a, b, depth_range=1.0)
    assert st.normality_test == "D'Agostino-Pearson"
    assert st.normality_p == pytest.approx(stats.normaltest(a - b).pvalue, rel=1e-12)


def test_identical_samples_are_settled_explicitly():
    a = np.arange(10.0)
    st = paired_statistics(a, a, depth_range=9.0)
    assert st.t_test.p_value == 1.0 and st.wilcoxon.p_value == 1.0
    assert st.equivalent and st.paper_verdict == "similar" and st.cohens_dz == 0.0


def test_constant_offset():
    a = np.arange(10.0)
    st = paired_statistics(a, a - 2.0, depth_range=9.0)
    assert st.t_test.p_value == 0.0 and not st.equivalent and st.paper_verdict == "different"


def test_as_dict_is_json_ready(samples):
    import json

    d = paired_statistics(*samples, depth_range=10.0).as_dict()
    assert d["paper_verdict"] in ("similar", "different")
    assert set(d["t_test"]) == {"statistic", "p_value", "similar"}
    json.dumps(d)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"a": [1, 2], "b": [1, 2]}, "at least 3 pairs"),
        ({"a": [1, 2, 3], "b": [1, 2]}, "equal length"),
        ({"a": [1, 2, np.nan], "b": [1, 2, 3]}, "NaN"),
        ({"depth_range": 0.0}, "depth range"),
        ({"alpha": 1.5}, "alpha"),
        # the equivalence interval (1 - 2 alpha) was inverted and still said "equivalent"
        ({"alpha": 0.6}, r"alpha must be in \(0, 0.5\): the equivalence test's interval has confidence"),
        ({"alpha": 0.5}, r"alpha must be in \(0, 0.5\)"),
        ({"margin_fraction": 0.0}, "margin"),
        # these were used as numpy converts them: the values under the mask, real parts,
        # booleans as 0 and 1, a 2-D array flattened
        (
            {"a": np.ma.masked_array([1.0, 2, 3, 4], mask=[0, 0, 1, 1])},
            r"paired sample a: 2 masked value\(s\): numpy would use the values hidden under the mask",
        ),
        ({"b": np.array([1.0, 2, 3, 4]) + 1j}, r"paired sample b must be real numbers, got dtype complex128"),
        ({"a": np.array([True, False, True, True])}, r"paired sample a must be real numbers, got dtype bool"),
        ({"a": ["1", "2", "3", "4"]}, r"paired sample a must be real numbers, got dtype <U1"),
        (
            {"a": np.ones((2, 2)), "b": np.ones((2, 2))},
            r"paired sample a must have shape \(n,\), got shape \(2, 2\)",
        ),
    ],
)
def test_bad_arguments(kwargs, match):
    args = {"a": [1.0, 2.0, 3.5, 4.0], "b": [1.1, 2.0, 3.0, 4.2], "depth_range": 3.0} | kwargs
    with pytest.raises(InputError, match=match):
        paired_statistics(args.pop("a"), args.pop("b"), **args)


def test_ci95_is_always_95_percent_and_tost_ci_follows_alpha(samples):
    a, b = samples
    default = paired_statistics(a, b, depth_range=10.0)
    loose = paired_statistics(a, b, depth_range=10.0, alpha=0.2)
    np.testing.assert_allclose(loose.ci95, default.ci95, rtol=1e-12)
    ci60 = stats.ttest_rel(a, b).confidence_interval(0.6)  # TOST at alpha 0.2 <=> 60 % interval
    np.testing.assert_allclose(loose.tost_ci, (ci60.low, ci60.high), rtol=1e-12)


def test_constant_offset_with_rounding_noise_is_constant():
    a = np.linspace(0.1, 0.9, 20)
    b = a - 0.3  # a - b is 0.3 up to an ulp or two
    st = paired_statistics(a, b, depth_range=1.0)
    assert st.sd_difference == 0.0 and np.isinf(st.cohens_dz) and not st.equivalent


def test_as_dict_is_strict_json():
    import json

    st = paired_statistics(np.arange(10.0), np.arange(10.0), depth_range=9.0)  # NaN normality p
    json.dumps(st.as_dict(), allow_nan=False)
    assert st.as_dict()["normality_p"] is None


# samples of 3-13 pairs on a coarse grid: ties and zero differences are common, so scipy's
# wilcoxon takes its exact sign-flip permutation path that ours vectorises
_small_grid_samples = st_np.arrays(
    np.float64, hst.integers(3, 13), elements=hst.sampled_from([0.0, 0.5, 1.0, 1.5, 2.0, 3.25])
)


@settings(max_examples=12, deadline=None)  # scipy's own call takes 0.1 s
@given(a=_small_grid_samples, data=hst.data())
def test_wilcoxon_is_scipys_exactly_on_small_samples_with_ties_and_zeros(a, data):
    b = data.draw(st_np.arrays(np.float64, a.size, elements=hst.sampled_from([0.0, 0.5, 1.0, 2.0])))
    assume(np.any(a != b) and np.std(a - b) > 0)
    ours = paired_statistics(a, b, depth_range=3.0)
    w = stats.wilcoxon(a, b)
    assert ours.wilcoxon.statistic == w.statistic  # equal, not approximately
    assert ours.wilcoxon.p_value == w.pvalue


def test_wilcoxon_permutation_path_known_case():
    # d = (1, 1, -2, 3, 0, 1, -1, 2, 2): zero and ties, n = 9, so scipy enumerates 2**9 flips
    a = np.array([2.0, 2.0, 0.0, 4.0, 1.0, 3.0, 0.0, 3.0, 5.0])
    b = np.array([1.0, 1.0, 2.0, 1.0, 1.0, 2.0, 1.0, 1.0, 3.0])
    ours = paired_statistics(a, b, depth_range=5.0)
    w = stats.wilcoxon(a, b)
    assert (ours.wilcoxon.statistic, ours.wilcoxon.p_value) == (w.statistic, w.pvalue)
    # |d| without the zero ranks 1 x4 -> 2.5, 2 x3 -> 6, 3 -> 8: r- = 6 + 2.5 = 8.5, r+ = 27.5
    assert ours.wilcoxon.statistic == 8.5
    assert ours.wilcoxon.p_value == 2 * 62 / 512  # 62 of the 2**9 sign flips give r+ <= 8.5


def test_rounding_only_marks_deviations_at_float64_rounding():
    rng = np.random.default_rng(0)
    a = rng.random(50)
    noise = paired_statistics(a, a + rng.choice([-1, 0, 1], 50) * 2.0**-52, depth_range=1.0)
    real = paired_statistics(a, a + rng.normal(0, 1e-6, 50), depth_range=1.0)
    assert noise.rounding_only and noise.as_dict()["rounding_only"] is True
    assert not real.rounding_only and real.as_dict()["rounding_only"] is False
    # depths far from zero round on their own scale: 2 ulp of 2e5 is 5.8e-11, a range of 1 notwithstanding
    far = paired_statistics(a + 2e5, a + 2e5 + rng.choice([-1, 0, 1], 50) * 2.0**-35, depth_range=1.0)
    assert far.rounding_only and far.rounding_tolerance == pytest.approx(
        1e-12 + 64 * 2.0**-52 * 2e5, rel=1e-5
    )


def test_the_rounding_tolerance_follows_the_depths_rounding_not_a_fraction_of_their_size():
    # 64 epsilons of the depths' size, not 1e-12 of it: at an offset of 3e12 a deviation of 0.01
    # (20 units in the last place of 3e12) is rounding, one of 0.1 is not (it was 3 units before)
    a = np.linspace(0.0, 12.7, 30) + 3e12
    noise = paired_statistics(a, a + np.resize([0.01, -0.01, 0.0], 30), depth_range=12.7)
    real = paired_statistics(a, a + np.resize([0.1, -0.1, 0.0], 30), depth_range=12.7)
    assert noise.rounding_only and not real.rounding_only
    assert rounding_tolerance(4.0, 8.0) == 4e-12 + 64 * 2.0**-52 * 8.0
    # exact under power-of-two changes of units
    assert rounding_tolerance(4.0 * 2.0**-30, 8.0 * 2.0**-30) == rounding_tolerance(4.0, 8.0) * 2.0**-30


@pytest.mark.parametrize("n", [3, 4, 5, 6, 12])
def test_constant_differences_give_the_exact_wilcoxon_p_value(n):
    # every signed rank on one side: p = 2 / 2**n, as scipy's exact test; it was 0 (so "different"
    # at n = 3..5, where the test cannot reach 0.05)
    st = paired_statistics(np.ones(n), np.zeros(n), depth_range=10.0)
    expected = stats.wilcoxon(np.ones(n), np.zeros(n)).pvalue if n <= 13 else 2.0 ** (1 - n)
    assert st.wilcoxon.p_value == pytest.approx(expected, rel=1e-12) == 2.0 ** (1 - n)
    assert st.wilcoxon.similar == (2.0 ** (1 - n) >= 0.05)


@pytest.mark.parametrize("k", [-960, -540, -401, 401, 520, 900])
def test_statistics_are_the_same_at_every_power_of_two_scale(samples, k):
    # the squares of the differences under- or overflowed: t = inf and "different" at 2**-540,
    # t = 0 and an infinite RMS at 2**520, for data that give p = 0.12 at scale 1
    a, b = samples
    a, b = a[:8], b[:8]
    base = paired_statistics(a, b, depth_range=10.0)
    scaled = paired_statistics(np.ldexp(a, k), np.ldexp(b, k), depth_range=float(np.ldexp(10.0, k)))
    for name in (
        "t_test",
        "wilcoxon",
        "cohens_dz",
        "rms_percent",
        "max_abs_percent",
        "tost_p",
        "normality_p",
    ):
        assert getattr(scaled, name) == getattr(base, name), name
    for name in ("mean_difference", "sd_difference", "rms", "max_abs", "margin", "depth_range", "magnitude"):
        assert getattr(scaled, name) == np.ldexp(getattr(base, name), k), name
    assert scaled.ci95 == tuple(np.ldexp(base.ci95, k)) and scaled.paper_verdict == base.paper_verdict


@pytest.mark.parametrize("depth_range", [None, "1", float("nan"), True])
def test_a_depth_range_that_is_not_a_number_is_named(depth_range):
    with pytest.raises(InputError, match=f"depth_range must be a finite real number, got {depth_range!r}"):
        paired_statistics([1.0, 2.0, 3.0], [1.0, 2.0, 4.0], depth_range=depth_range)


# depths given to 0.1 mm: their differences tie exactly (0.2 and 0.2), but computed in float
# they tie or not depending on the unit; in metres the verdict flipped to "different" (p 0.0488)
_DECIMAL_A = (2.0, 8.1, 6.8, 0.7, 1.1, 10.6, 9.3, 2.1, 7.6, 11.6, 6.8, 7.8)
_DECIMAL_B = (2.3, 7.9, 7.0, 0.5, 1.2, 10.8, 9.7, 2.5, 7.4, 12.0, 6.6, 8.2)


@functools.cache
def _decimal_wilcoxon_p():
    """The exact ties of the decimal data: scipy's p-value on the differences rounded to 0.1 mm.

    It does not depend on the unit, and scipy's exact path (its sign-flip permutations at n = 12)
    takes about a second: computed once for the four units, not once each."""
    return stats.wilcoxon(np.round(np.array(_DECIMAL_A) - np.array(_DECIMAL_B), 10)).pvalue


@pytest.mark.parametrize("unit", [1e-3, 1e3, 1e-6, 25.4])
def test_the_wilcoxon_verdict_does_not_depend_on_units(unit):
    a, b = np.array(_DECIMAL_A), np.array(_DECIMAL_B)
    base = paired_statistics(a, b, depth_range=13.0)
    scaled = paired_statistics(a * unit, b * unit, depth_range=13.0 * unit)
    assert scaled.wilcoxon == base.wilcoxon and scaled.paper_verdict == base.paper_verdict
    assert base.wilcoxon.p_value == pytest.approx(_decimal_wilcoxon_p(), rel=1e-12)


def test_a_constant_offset_at_rounding_level_is_no_evidence_either():
    # every difference 2**-32 next to depths of 1e6 (about 1 unit in the
    # last place): rounding_only, yet the constant-differences case said p = 0 and "different"
    a = np.linspace(0.0, 0.4, 10) + 1e6
    st = paired_statistics(a, a + 2.0**-32, depth_range=0.4)
    assert st.rounding_only and st.sd_difference == 0.0
    assert st.t_test == st.wilcoxon == ours.TestResult(0.0, 1.0, True) and st.paper_verdict == "similar"
    # a real constant offset is still the tests' certain difference
    real = paired_statistics(a, a + 0.01, depth_range=0.4)
    assert not real.rounding_only and real.t_test.p_value == 0.0 and real.paper_verdict == "different"


def test_differences_that_are_all_rounding_give_no_wilcoxon_evidence():
    a = np.linspace(1.0, 2.0, 20)
    st = paired_statistics(a, a + np.tile([2.0**-52, -(2.0**-52)], 10), depth_range=1.0)
    assert st.rounding_only and st.wilcoxon.p_value == 1.0 and st.wilcoxon.similar
