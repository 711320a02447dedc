"""Paired statistics of depth deviations between two surfaces (paper section 4).

The paper runs Student's paired t-test and the Wilcoxon signed-rank test on the z
coordinates of the ADT and NURBS surfaces at the same (x, y), "with the hypotheses that both
the sets do not have significant difference", and concludes "with 95% confidence that
surfaces generated from ADT and NURBS are similar". Failing to reject a null hypothesis of no
difference is not evidence of similarity (absence of evidence is not evidence of absence),
so beside the paper's two tests and its verdict this module reports what that logic lacks:

* the mean difference with its 95 % confidence interval, and Cohen's d_z (mean / sd);
* RMS and maximum absolute deviation, also as percentages of the cloud's depth range;
* a normality check of the differences (Shapiro-Wilk; D'Agostino-Pearson above 5000
  pairs, where Shapiro-Wilk's p-value is unreliable), naming the appropriate test;
* a two one-sided tests (TOST) equivalence test with margin +-5 % of the depth range (the
  paper's "under 5 %"): the surfaces are declared equivalent when both one-sided t-tests
  reject, i.e. when the (1 - 2 alpha) confidence interval of the mean (``tost_ci``, 90 % at
  the paper's alpha) lies inside the margin. ``ci95`` is always the 95 % interval.

Edge cases are settled explicitly: when every difference is zero the tests cannot be
computed by scipy; their p-values are then 1 (no evidence of a difference) and TOST declares
equivalence (zero spread, zero mean).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from replication.errors import InputError
from replication.params import real

__all__ = [
    "MAGNITUDE_ROUNDING",
    "ROUNDING_FRACTION",
    "PairedStatistics",
    "TestResult",
    "check_alpha",
    "paired_statistics",
    "rounding_tolerance",
]


@dataclass(frozen=True)
class TestResult:
    """One hypothesis test: statistic, p-value, and the verdict under the paper's logic.

    ``similar`` is True when the test fails to reject "no difference" at level alpha: the
    paper's reading, kept for comparison (it is not evidence of similarity).
    """

    statistic: float
    p_value: float
    similar: bool


#: Deviations of at most this fraction of the depth range are float64 rounding (depths carry
#: about 16 significant digits; evaluation and interpolation lose a few).
ROUNDING_FRACTION = 1e-12
#: ... plus this fraction of the depths' own size (64 machine epsilons): depths offset far from
#: zero round on their own scale. Shifting Table 1's random clouds by 1e3 to 3e12 moved their
#: ADT - NURBS deviations by at most 3.2 epsilons of the offset (both pairings, 9-200 points),
#: so 64 leaves a margin of 20 while real deviations keep their ranks: a tolerance of
#: ROUNDING_FRACTION of the depths' size (4500 epsilons) made ties of deviations 1e-3 apart at
#: an offset of 1e9 and changed the Wilcoxon p-value.
MAGNITUDE_ROUNDING = 64 * float(np.finfo(np.float64).eps)


def rounding_tolerance(depth_range: float, magnitude: float) -> float:
    """The largest deviation that is float64 rounding between depths of this range and size.

    ``ROUNDING_FRACTION * depth_range + MAGNITUDE_ROUNDING * magnitude``: proportional to the
    units (a power-of-two change of units scales it exactly), and growing with an offset only
    as fast as the rounding of the depths themselves.
    """
    return ROUNDING_FRACTION * depth_range + MAGNITUDE_ROUNDING * magnitude


@dataclass(frozen=True)
class PairedStatistics:
    """Every statistic of one set of paired depth differences d = a - b (paper section 4).

    Attributes
    ----------
    n : int
        Number of pairs.
    alpha : float
        Significance level of the tests.
    mean_difference, sd_difference : float
        Mean and sample standard deviation of d.
    ci95 : tuple of float
        The 95 % confidence interval of the mean difference, whatever ``alpha`` is.
    cohens_dz : float
        Effect size: mean over standard deviation of d.
    rms, max_abs : float
        Root mean square and largest absolute difference; ``rms_percent`` and
        ``max_abs_percent`` are the same relative to ``depth_range``.
    depth_range : float
        The cloud's range along the depth axis.
    t_test, wilcoxon : TestResult
        Paired t-test and Wilcoxon signed-rank test (statistic, p-value, and whether the
        samples are similar: the test does not reject at ``alpha``).
    normality_test, normality_p :
        The test of normality of d (Shapiro-Wilk, or its stand-in) and its p-value;
        ``recommended_test`` is the paired test that suits them.
    margin, margin_fraction : float
        The equivalence margin, absolute and as a fraction of ``depth_range``.
    tost_p, tost_ci, equivalent :
        The equivalence test (two one-sided t-tests): its p-value, the (1 - 2 alpha)
        interval of the mean difference, and whether that interval lies inside the margin.
    magnitude : float
        The largest |depth| of either sample (what float64 rounding is relative to).
    """

    n: int
    alpha: float
    mean_difference: float
    sd_difference: float
    ci95: tuple[float, float]
    cohens_dz: float
    rms: float
    max_abs: float
    depth_range: float
    rms_percent: float
    max_abs_percent: float
    t_test: TestResult
    wilcoxon: TestResult
    normality_test: str
    normality_p: float
    recommended_test: str
    margin: float
    margin_fraction: float
    tost_p: float
    tost_ci: tuple[float, float]
    equivalent: bool
    magnitude: float = 0.0  # the largest |depth| of either sample

    @property
    def rounding_tolerance(self) -> float:
        """The largest deviation that is float64 rounding here (:func:`rounding_tolerance`)."""
        return rounding_tolerance(self.depth_range, self.magnitude)

    @property
    def rounding_only(self) -> bool:
        """True when every deviation is at most :attr:`rounding_tolerance`: float64 rounding
        of depths of this range and size. Both tests then report no evidence of a difference
        (p = 1): on the raw noise the paper's t-test rejected or not with the units and offset
        (a plane on a lattice: ADT and NURBS agree to 7e-16, yet the t-test rejected at
        p = 0.00025; p = 0.54 in mm, 0.012 in m)."""
        return self.max_abs <= self.rounding_tolerance

    @property
    def paper_verdict(self) -> str:
        """'similar' when both of the paper's tests fail to reject, else 'different'."""
        return "similar" if self.t_test.similar and self.wilcoxon.similar else "different"

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready dictionary (floats, bools, lists; NaN and infinities become None)."""

        def clean(value: Any) -> Any:
            if isinstance(value, dict):
                return {k: clean(v) for k, v in value.items()}
            if isinstance(value, (list, tuple)):
                return [clean(v) for v in value]
            if isinstance(value, float) and not np.isfinite(value):
                return None
            return value

        d = clean(asdict(self))
        d["paper_verdict"] = self.paper_verdict
        d["rounding_only"] = self.rounding_only
        return d


#: Largest sample for which scipy's ``wilcoxon(method="auto")`` runs an exact sign-flip
#: permutation test when the differences have ties or zeros (all 2**n sign patterns).
_PERMUTATION_MAX_N = 13


def _snapped(d: np.ndarray, tolerance: float) -> np.ndarray:
    """``d`` with rounding-level distinctions removed: ``|d|`` at most ``tolerance`` becomes 0,
    and magnitudes within ``tolerance`` of the next smaller one (a chain of them) take the
    smallest magnitude of their run, keeping their signs.

    The signed-rank test ranks ``|d|`` and treats equal values as ties and zeros as no
    difference, by exact equality: without this the same depths in metres and in millimetres
    (or shifted by 1000) can rank differently (0.2 and 0.2 in mm are 0.0002 and
    0.00019999999999999998 in m) and flip the verdict.
    """
    magnitude = np.abs(d)
    magnitude[magnitude <= tolerance] = 0.0
    order = np.argsort(magnitude, kind="stable")
    ranked = magnitude[order]
    starts = np.concatenate([[True], np.diff(ranked) > tolerance])
    snapped = np.empty_like(magnitude)
    snapped[order] = ranked[starts][np.cumsum(starts) - 1]
    return np.copysign(snapped, d)


def _wilcoxon(a: np.ndarray, b: np.ndarray, tolerance: float = 0.0) -> tuple[float, float]:
    """``scipy.stats.wilcoxon(a, b)``'s statistic and p-value, the permutation case vectorised.

    With ties or zeros among at most 13 differences scipy enumerates all ``2**n`` sign flips
    and calls its statistic once per flip (0.1 s at n = 9, most of a Monte Carlo replicate's
    statistics). Flipping signs leaves ``|d|`` and so the ranks unchanged: the signed-rank
    sum of every flip is one matrix product, handed to the same ``permutation_test`` as
    ``vectorized`` statistic. The null distribution holds the same sums of half-integer
    ranks, so the p-value is identical to scipy's (tested on random samples with ties and
    zeros); every other case is scipy's own call.
    """
    from scipy import stats

    d = a - b
    snapped = _snapped(d, tolerance) if tolerance > 0 else d
    if not np.array_equal(snapped, d):  # rounding-level ties and zeros made exact
        a, b, d = snapped, np.zeros_like(snapped), snapped
        if not d.any():  # every difference is rounding: no evidence of a difference at all
            return 0.0, 1.0
    nonzero = d != 0
    magnitudes = np.abs(d[nonzero])
    ties = np.unique(magnitudes).size < magnitudes.size
    zeros = magnitudes.size < d.size
    if d.size > _PERMUTATION_MAX_N or not (ties or zeros):
        w = stats.wilcoxon(a, b)
        return float(w.statistic), float(w.pvalue)
    ranks = np.zeros_like(d)
    ranks[nonzero] = stats.rankdata(magnitudes)  # average ranks of tied |d|; zeros are dropped

    def rank_sum_positive(flipped: np.ndarray, axis: int = -1) -> np.ndarray:
        return np.sum((flipped > 0) * ranks, axis=axis)

    r_plus = float(rank_sum_positive(d))
    r_minus = float(np.sum((d < 0) * ranks))
    test = stats.permutation_test(
        (d,), rank_sum_positive, permutation_type="samples", vectorized=True, alternative="two-sided"
    )
    return min(r_plus, r_minus), float(test.pvalue)


def check_alpha(alpha: Any) -> float:
    """``alpha`` as a float in (0, 0.5): the equivalence test's interval has confidence
    1 - 2 alpha, which must be positive (at 0.6 it came out inverted and still said
    "equivalent")."""
    alpha = real(alpha, "alpha")
    if not 0 < alpha < 0.5:
        raise InputError(
            "alpha must be in (0, 0.5): the equivalence test's interval has confidence 1 - 2 alpha, "
            f"got {alpha=}"
        )
    return alpha


def _sample(values: ArrayLike, name: str) -> np.ndarray:
    """One paired sample as float64 of shape (n,), refused as :func:`.as_cloud` refuses a cloud:
    masked values (numpy would use the values under the mask), booleans, complex numbers, text
    or dates, and another shape (a 2-D array was flattened without a word)."""
    if isinstance(values, np.ma.MaskedArray) and np.ma.is_masked(values):
        raise InputError(
            f"paired sample {name}: {int(np.ma.count_masked(values))} masked value(s): numpy would use the "
            "values hidden under the mask; drop those pairs first"
        )
    array = np.asarray(values)
    if array.dtype.kind in "bcmMUSV":  # numbers numpy would make of them without a word
        raise InputError(f"paired sample {name} must be real numbers, got dtype {array.dtype}")
    if array.ndim != 1:
        raise InputError(f"paired sample {name} must have shape (n,), got shape {array.shape}")
    try:  # (objects such as Fractions or large Python ints convert)
        return array.astype(np.float64, copy=False)
    except (TypeError, ValueError) as exc:
        raise InputError(f"paired sample {name} must be real numbers: {exc}") from None


def paired_statistics(
    a: ArrayLike,
    b: ArrayLike,
    *,
    depth_range: float,
    margin_fraction: float = 0.05,
    alpha: float = 0.05,
) -> PairedStatistics:
    """Paired tests, effect sizes and an equivalence test for depths ``a`` and ``b``.

    Parameters
    ----------
    a, b : array_like, shape (n,)
        Paired depths (for example ADT and NURBS at the same positions); n >= 3.
    depth_range : float
        The cloud's range along the depth axis; deviations are also reported relative to it.
    margin_fraction : float
        Equivalence margin as a fraction of ``depth_range`` (default 0.05, the paper's 5 %).
    alpha : float
        Significance level in (0, 0.5) (default 0.05, the paper's 95 %).

    Returns
    -------
    PairedStatistics

    Raises
    ------
    InputError
        Samples of other lengths, shapes or types (masked, boolean, complex), fewer than 3
        pairs, NaN or infinite values, a bad depth range, alpha or margin.

    Notes
    -----
    Paper section 4 (paired t-test and Wilcoxon signed-rank test on the z deviations).
    """
    depth_range = real(depth_range, "depth_range")
    alpha = check_alpha(alpha)
    margin_fraction = real(margin_fraction, "margin_fraction")
    a, b = _sample(a, "a"), _sample(b, "b")
    if a.shape != b.shape:
        raise InputError(f"paired samples must have equal length, got {a.size} and {b.size}")
    if a.size < 3:
        raise InputError(f"need at least 3 pairs for the paired tests, got n={a.size}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise InputError("paired samples contain NaN or infinite values")
    if not (np.isfinite(depth_range) and depth_range > 0):
        raise InputError(f"depth range must be positive and finite, got {depth_range=}")
    if not margin_fraction > 0:
        raise InputError(f"equivalence margin must be positive, got {margin_fraction=}")

    k = _exact_scaling(a, b, depth_range)
    if k:  # squares of these depths under- or overflow: compute at a scale where they do not
        scaled = _paired(
            np.ldexp(a, k), np.ldexp(b, k), float(np.ldexp(depth_range, k)), margin_fraction, alpha
        )
        return _rescaled(scaled, -k)
    return _paired(a, b, float(depth_range), margin_fraction, alpha)


#: Differences whose largest magnitude lies outside [2**-LIMIT, 2**LIMIT] are scaled first: their
#: squares (variance, RMS) would under- or overflow float64 (2**-1074 .. 2**1024).
_SCALING_LIMIT = 400


def _exact_scaling(a: np.ndarray, b: np.ndarray, depth_range: float) -> int:
    """An even power of two that brings the differences near 1, or 0 where none is needed.

    Scaling by 2**k with k even is exact for every operation of the tests: sums, products,
    quotients and square roots (sqrt(4**j x) = 2**j sqrt(x) exactly), so the statistics are
    those of the data as given, without their squares under- or overflowing. Normal data
    are never scaled (their results are unchanged to the bit).
    """
    largest = float(np.max(np.abs(a - b)))
    if largest == 0.0 or 2.0**-_SCALING_LIMIT <= largest <= 2.0**_SCALING_LIMIT:
        return 0
    k = -(np.frexp(largest)[1] // 2) * 2
    fits = all(np.isfinite(np.ldexp(float(np.max(np.abs(x))), k)) for x in (a, b, np.array(depth_range)))
    return int(k) if fits else 0


def _rescaled(result: PairedStatistics, k: int) -> PairedStatistics:
    """``result`` with every quantity in the depths' unit multiplied by ``2**k`` (exactly)."""

    def s(value: float) -> float:
        return float(np.ldexp(value, k))

    return dataclasses.replace(
        result,
        mean_difference=s(result.mean_difference),
        sd_difference=s(result.sd_difference),
        ci95=(s(result.ci95[0]), s(result.ci95[1])),
        rms=s(result.rms),
        max_abs=s(result.max_abs),
        depth_range=s(result.depth_range),
        margin=s(result.margin),
        tost_ci=(s(result.tost_ci[0]), s(result.tost_ci[1])),
        magnitude=s(result.magnitude),
    )


def _paired(
    a: np.ndarray, b: np.ndarray, depth_range: float, margin_fraction: float, alpha: float
) -> PairedStatistics:
    from scipy import stats  # on first use: scipy.stats alone costs ~0.4 s of start-up (issue 15 item 2)

    d = a - b
    n = d.size
    mean = float(d.mean())
    sd = float(d.std(ddof=1))
    t95 = float(stats.t.ppf(0.975, n - 1))  # the 95 % interval whatever alpha is
    t_tost = float(stats.t.ppf(1 - alpha, n - 1))  # the (1 - 2 alpha) interval TOST is equivalent to
    margin = margin_fraction * depth_range
    rms = float(np.sqrt(np.mean(d**2)))
    max_abs = float(np.max(np.abs(d)))
    magnitude = float(max(np.max(np.abs(a)), np.max(np.abs(b))))

    rounding = rounding_tolerance(depth_range, magnitude)  # as PairedStatistics.rounding_tolerance
    if sd <= 1e-12 * max(max_abs, np.finfo(float).tiny):
        # constant differences (up to rounding): scipy's tests are undefined or meaningless
        sd = 0.0
        if max_abs <= rounding:  # a constant offset at rounding level: no evidence either (rounding_only)
            t_res = w_res = TestResult(0.0, 1.0, True)
        else:
            t_res = TestResult(np.inf if mean else 0.0, 0.0 if mean else 1.0, mean == 0.0)
            # every signed rank on one side: the exact test's smallest p-value, 2 / 2**n (0.25 at n = 3)
            w_p = min(1.0, 2.0 ** (1 - n)) if mean else 1.0
            w_res = TestResult(0.0, w_p, bool(w_p >= alpha))
        normality_name, normality_p = "constant differences", float("nan")
        tost_p = 0.0 if abs(mean) < margin else 1.0
        dz = float("inf") * np.sign(mean) if mean else 0.0
    else:
        if max_abs <= rounding:  # PairedStatistics.rounding_only
            # nothing but rounding noise, whose mean over its spread is set by the units and the
            # offset (a plane: p = 0.54 in mm, 0.012 in m): no evidence, as in the Wilcoxon test
            t_res = TestResult(0.0, 1.0, True)
        else:
            t = stats.ttest_rel(a, b)
            t_res = TestResult(float(t.statistic), float(t.pvalue), bool(t.pvalue >= alpha))
        # ties and zeros up to rounding of the depths, so that units and offsets decide nothing
        w_statistic, w_p = _wilcoxon(a, b, rounding)
        w_res = TestResult(w_statistic, w_p, bool(w_p >= alpha))
        if n > 5000:
            normality_name, normality_p = "D'Agostino-Pearson", float(stats.normaltest(d).pvalue)
        else:
            # scipy's Shapiro-Wilk computes in float32, whose squares underflow for depths
            # near 1e-20 and below: test the differences scaled by a power of two (exact, and
            # the test is scale-free) to a largest magnitude in [0.5, 1)
            unit = np.ldexp(d, -int(np.frexp(max_abs)[1]))
            normality_name, normality_p = "Shapiro-Wilk", float(stats.shapiro(unit).pvalue)
        lower = stats.ttest_1samp(d, -margin, alternative="greater").pvalue
        upper = stats.ttest_1samp(d, margin, alternative="less").pvalue
        tost_p = float(max(lower, upper))
        dz = mean / sd
    recommended = "t-test" if not normality_p < alpha else "Wilcoxon signed-rank"
    return PairedStatistics(
        n=n,
        alpha=alpha,
        mean_difference=mean,
        sd_difference=sd,
        ci95=(float(mean - t95 * sd / math.sqrt(n)), float(mean + t95 * sd / math.sqrt(n))),
        cohens_dz=float(dz),
        rms=rms,
        max_abs=max_abs,
        depth_range=float(depth_range),
        rms_percent=100.0 * rms / depth_range,
        max_abs_percent=100.0 * max_abs / depth_range,
        t_test=t_res,
        wilcoxon=w_res,
        normality_test=normality_name,
        normality_p=normality_p,
        recommended_test=recommended,
        margin=margin,
        margin_fraction=margin_fraction,
        tost_p=tost_p,
        tost_ci=(float(mean - t_tost * sd / math.sqrt(n)), float(mean + t_tost * sd / math.sqrt(n))),
        equivalent=bool(tost_p < alpha),
        magnitude=magnitude,
    )
