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

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from replication.errors import InputError

__all__ = ["ROUNDING_FRACTION", "TestResult", "PairedStatistics", "paired_statistics"]


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


@dataclass(frozen=True)
class PairedStatistics:
    """Every statistic of one set of paired depth differences (a - b)."""

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
    def rounding_scale(self) -> float:
        """What rounding is measured against: the larger of the depth range and the depths."""
        return max(self.depth_range, self.magnitude)

    @property
    def rounding_only(self) -> bool:
        """True when every deviation is at most :data:`ROUNDING_FRACTION` of the depth range
        or of the depths themselves, whichever is larger: float64 rounding, so the tests
        compare rounding noise and their verdicts say nothing about the surfaces (a plane on a
        lattice: ADT and NURBS agree to 7e-16, yet the t-test rejects at p = 0.00025)."""
        return self.max_abs <= ROUNDING_FRACTION * self.rounding_scale

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


def _wilcoxon(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
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
        Significance level (default 0.05, the paper's 95 %).

    Returns
    -------
    PairedStatistics

    Notes
    -----
    Paper section 4 (paired t-test and Wilcoxon signed-rank test on the z deviations).
    """
    a = np.asarray(a, dtype=np.float64).ravel()
    b = np.asarray(b, dtype=np.float64).ravel()
    if a.shape != b.shape:
        raise InputError(f"paired samples must have equal length, got {a.size} and {b.size}")
    if a.size < 3:
        raise InputError(f"need at least 3 pairs for the paired tests, got n={a.size}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise InputError("paired samples contain NaN or infinite values")
    if not (np.isfinite(depth_range) and depth_range > 0):
        raise InputError(f"depth range must be positive and finite, got {depth_range=}")
    if not 0 < alpha < 1:
        raise InputError(f"alpha must be in (0, 1), got {alpha=}")
    if not margin_fraction > 0:
        raise InputError(f"equivalence margin must be positive, got {margin_fraction=}")

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

    if sd <= 1e-12 * max(float(np.max(np.abs(d))), np.finfo(float).tiny):
        # constant differences (up to rounding): scipy's tests are undefined or meaningless
        sd = 0.0
        t_res = TestResult(np.inf if mean else 0.0, 0.0 if mean else 1.0, mean == 0.0)
        w_res = TestResult(0.0, 0.0 if mean else 1.0, mean == 0.0)
        normality_name, normality_p = "constant differences", float("nan")
        tost_p = 0.0 if abs(mean) < margin else 1.0
        dz = float("inf") * np.sign(mean) if mean else 0.0
    else:
        t = stats.ttest_rel(a, b)
        t_res = TestResult(float(t.statistic), float(t.pvalue), bool(t.pvalue >= alpha))
        w_statistic, w_p = _wilcoxon(a, b)
        w_res = TestResult(w_statistic, w_p, bool(w_p >= alpha))
        if n > 5000:
            normality_name, normality_p = "D'Agostino-Pearson", float(stats.normaltest(d).pvalue)
        else:
            normality_name, normality_p = "Shapiro-Wilk", float(stats.shapiro(d).pvalue)
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
        ci95=(mean - t95 * sd / np.sqrt(n), mean + t95 * sd / np.sqrt(n)),
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
        tost_ci=(mean - t_tost * sd / np.sqrt(n), mean + t_tost * sd / np.sqrt(n)),
        equivalent=bool(tost_p < alpha),
        magnitude=float(max(np.max(np.abs(a)), np.max(np.abs(b)))),
    )
