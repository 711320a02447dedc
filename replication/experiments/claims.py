"""The paper's quantitative claims about Table 1 and Fig. 6, set beside ours with a verdict.

Verdicts follow fixed rules (tested); each is robust to the noise of the measurement, so
two runs of the same code reach the same verdict unless the effect itself sits at a rule's
boundary.

``"cannot be compared"``
    absolute sizes and times: the paper's file formats, number precision, software (MATLAB)
    and machine are not stated, so only their order of magnitude can be set side by side;
    the ratio ours/paper is given.
**Factor claims** ("almost half" the storage, "almost 3 times faster")
    ADT's advantage a (NURBS/ADT time, or NURBS/ADT size) is taken with the 95 % interval of
    its median, median +- 1.57 IQR / sqrt(count) (the notch of a box plot), so a verdict
    rests on the interval, not on one median. With the paper's advantage A (2 or 3):
    *holds* when the interval lies within [A / 1.5, 1.5 A] (``FACTOR_TOLERANCE``);
    *partly holds* when ADT is clearly better (the interval lies above ``EQUAL_BAND``, 1.1:
    more than 10 % better) but the factor is not established; *does not hold* when ADT is
    clearly not better (the interval lies at or below 1.1); *cannot be decided* when the
    interval straddles 1.1.
**Timing ratios drift between runs** more than their interval within one run says (about
    +-1-5 % over 50 interleaved repeats): the machine's state moves the whole distribution. On
    one commit, NURBS(fast)/ADT at n = 200 (200 interleaved pairs) measured 5.05 on this
    two-core machine when quiet, 5.19 beside two CPU-bound processes and 5.79 (+15 %) beside
    three memory-bound ones; in a reproduce beside another busy job it measured 4.0 against
    5.1 quiet. A timing ratio's interval is therefore widened by ``TIMING_DRIFT`` (1.2) on each
    side, and a verdict is given only where the widened interval is decisive: *holds* when it
    lies within the band, *partly holds* when it lies above 1.1 and wholly outside the band,
    *does not hold* when it lies at or below 1.1, and *cannot be decided* when it reaches
    across an edge. Two such verdicts can then contradict each other only if the load moves
    the ratio by more than x1.44 (1.2 squared). File sizes are exact and keep the plain rule.
**A timing ratio from few repeats is not judged** (:func:`timing_factor_verdict`): from fewer
    than ``MIN_TIMING_PAIRS`` (20) repeat pairs a timing claim *cannot be decided*. The notch
    treats the median as normal with a spread read from the quartiles, and the quartiles of a
    handful of pairs are the pairs themselves: the interval then says little about the next
    run. Over 7 quick runs (3 pairs per n) on one commit, NURBS(fast)/ADT at n = 9 measured
    5.1-7.6, beside the band edge 4.5, and the "almost 3 times faster (fast evaluator)" claim
    read *partly holds* 4 times and *cannot be decided* 3 times; the paper-settings run (50
    pairs) has given the same verdict in every run. Whether a timing claim is judged then
    depends on the run's settings, never on the machine's load.
**Several n, several families** (:func:`combine`)
    holds if it holds at every n; does not hold if it does not hold at every n where it could
    be decided; partly holds otherwise - also when it holds at some n and cannot be decided at
    the others (otherwise verdicts that cannot be compared or decided are left out; if none is
    left, the claim cannot be decided). The rule is asymmetric on purpose: a claim of the paper
    is credited only where it is established at every n (leaving undecided n out let a single
    n that the timing noise decided say "holds"), while a claim that no decided n supports
    does not hold.
**Storage across representation families** (:func:`storage_overall`)
    the claim is decided per family (:mod:`.storage`) and kind of coordinates; the headline
    verdict is that of the families at equal precision (fixed digits, binary, information
    floor) for both kinds of coordinates: holds if it holds in all of them, partly holds if
    it holds in some, does not hold if it holds in none (ADT being somewhat smaller is not
    "almost half"). The sentence names the families and n where ADT is about half.
**Trend claims** ("the difference grows with n", "the deviation shrinks")
    :func:`trend_verdict`: a Theil-Sen slope of the per-cloud values on n with its 95 %
    interval, expressed as the change over the range of n relative to the median level.
    *holds* when the interval's bound nearest zero shows a change in the claimed direction
    of more than ``TREND_MARGIN`` (5 %); *does not hold* when it shows a change of more than
    5 % in the opposite direction; *cannot be decided* otherwise - when the interval
    straddles zero, or the change is within the 5 % margin that timing noise can produce.
    A trend of timings is decided on its interval widened for the drift between runs, as a
    timing ratio is: by ``TIMING_DRIFT - 1`` (20 %) of the median level each way, about what a
    level drifting by x1.2 between the ends of the range of n moves the change by (an
    interleaved run's +9 % [+4.4, +13.3] "could not be decided" and a second one's
    [+5.5, +12.4] "held").
    The paper's claims are monotone ("grows with the increase in the number of points"), so a
    fitted trend that holds only *partly holds* when the median moves against it from one n
    to the next by more than the same margin of the median level (the fit alone called the
    NURBS-ADT size difference growing while its medians ran -97, -182, 404, -1352, 4181 bytes).
**Statistical claims**
    hold when at least ``MAJORITY`` (90 %) of the Monte Carlo clouds agree at every n where
    the tests could be computed (at least 3 pairs); "cannot be compared" when they could be
    computed at no n.

:func:`replication.experiments.table1_claims.table1_claims` applies these rules to the Table 1
experiment's data.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from replication.experiments.paper import PAPER_TABLE1
from replication.experiments.storage import EQUAL_PRECISION
from replication.experiments.timing import TIMING_DRIFT, drifted

__all__ = [
    "PAPER",
    "EQUAL_BAND",
    "FACTOR_TOLERANCE",
    "MAJORITY",
    "MIN_TIMING_PAIRS",
    "TIMING_DRIFT",
    "TREND_MARGIN",
    "Trend",
    "combine",
    "factor_verdict",
    "median_interval",
    "share_verdict",
    "storage_overall",
    "theil_sen",
    "timing_factor_verdict",
    "trend_verdict",
]

#: The paper's values, verbatim (see :mod:`.paper`).
PAPER = PAPER_TABLE1
FACTOR_TOLERANCE = 1.5
EQUAL_BAND = 1.1
MAJORITY = 0.9
TREND_MARGIN = 0.05
#: Fewest repeat pairs from which a timing ratio's claim is decided (see the module notes).
MIN_TIMING_PAIRS = 20
NOTCH = 1.57
UNDECIDED = ("cannot be compared", "cannot be decided")


def median_interval(median: float, q1: float, q3: float, count: float) -> tuple[float, float]:
    """95 % interval of a median from its quartiles: median +- 1.57 IQR / sqrt(count)."""
    if not (np.isfinite(median) and count and count > 0):
        return (math.nan, math.nan)
    if not (np.isfinite(q1) and np.isfinite(q3)):
        return (median, median)
    half = NOTCH * (q3 - q1) / math.sqrt(count)
    return (median - half, median + half)


def factor_verdict(
    ours: float,
    paper: float,
    *,
    smaller_is_adt_better: bool,
    interval: tuple[float, float] | None = None,
    drift: float = 1.0,
) -> str:
    """Verdict for one factor claim at one n (see the module notes).

    ``ours`` is the ratio as measured: ADT/NURBS for sizes (``smaller_is_adt_better``) or
    NURBS/ADT for times; ``paper`` the paper's ratio in the same sense (0.5 or 3);
    ``interval`` the 95 % interval of ``ours`` (default: ``ours`` alone); ``drift`` (>= 1)
    widens it to ``(lo / drift, hi * drift)``: :data:`TIMING_DRIFT` for a timing ratio.
    """
    if not drift >= 1.0:  # also refuses NaN
        raise ValueError(f"drift must be a factor of at least 1, got {drift!r}")
    lo, hi = (ours, ours) if interval is None else interval
    lo, hi = drifted(lo, hi, drift)
    if not (np.isfinite(ours) and np.isfinite(lo) and np.isfinite(hi)) or min(ours, hi) <= 0:
        return "cannot be compared"
    # ADT's advantage: larger is better for ADT. An interval reaching down to 0 or below (a wide
    # spread of few timings: the median - 1.57 IQR / sqrt(count) notch) is a measured ratio whose
    # interval is wide, not one that cannot be compared: the ratio is only known to be below hi
    # (an ADT/NURBS size below hi: an advantage above 1 / hi, with no upper bound).
    if smaller_is_adt_better:
        a_lo, a_hi = 1 / hi, (1 / lo if lo > 0 else math.inf)
    else:
        a_lo, a_hi = lo, hi
    target = 1 / paper if smaller_is_adt_better else paper
    low_edge, high_edge = target / FACTOR_TOLERANCE, target * FACTOR_TOLERANCE
    if low_edge <= a_lo and a_hi <= high_edge:
        return "holds"
    if a_lo > EQUAL_BAND and (drift == 1.0 or a_hi < low_edge or a_lo > high_edge):
        # a timing ratio whose widened interval reaches into the band is not decided: the
        # drift alone could carry it in or out (see the module notes)
        return "partly holds"
    if a_hi <= EQUAL_BAND:
        return "does not hold"
    return "cannot be decided"


def timing_factor_verdict(median: float, q1: float, q3: float, count: float, paper: float) -> str:
    """Verdict for a NURBS/ADT timing ratio at one n, from its per-pair summary.

    ``median``, ``q1``, ``q3``: the ratio's median and quartiles over ``count`` repeat pairs;
    ``paper``: the paper's factor (3). *cannot be decided* from fewer than
    :data:`MIN_TIMING_PAIRS` pairs; otherwise :func:`factor_verdict` on the median's interval
    widened by :data:`TIMING_DRIFT` (see the module notes).

    Notes
    -----
    Paper section 5, item 1 ("almost 3 times faster").
    """
    if np.isfinite(median) and np.isfinite(count) and count < MIN_TIMING_PAIRS:
        return "cannot be decided"
    return factor_verdict(
        median,
        paper,
        smaller_is_adt_better=False,
        interval=median_interval(median, q1, q3, count),
        drift=TIMING_DRIFT,
    )


def combine(verdicts: list[str]) -> str:
    """Combine verdicts over n (or families): all hold -> holds; all fail -> does not hold.

    A claim holds only where it holds at every n: one that holds at some n and cannot be
    decided at the others partly holds (leaving those out let a single decided n say "holds",
    and the verdict then turned on which n the timing noise decided). A claim that does not
    hold wherever it could be decided does not hold (no n supports it; see the module notes).
    Otherwise verdicts that could not be compared or decided are left out; if none is left:
    cannot be compared (when nothing could be compared) or cannot be decided.
    """
    decided = [v for v in verdicts if v not in UNDECIDED]
    if not decided:
        nothing = all(v == "cannot be compared" for v in verdicts)
        return "cannot be compared" if nothing else "cannot be decided"
    if all(v == "holds" for v in decided):
        return "holds" if all(v == "holds" or v == "cannot be compared" for v in verdicts) else "partly holds"
    if all(v == "does not hold" for v in decided):
        return "does not hold"
    return "partly holds"


def share_verdict(values: dict[int, float], passes: Callable[[float], bool]) -> str:
    """holds / partly holds / does not hold over the n where the value could be computed."""
    finite = [v for v in values.values() if np.isfinite(v)]
    if not finite:
        return "cannot be compared"
    ok = sum(bool(passes(v)) for v in finite)
    return "holds" if ok == len(finite) else ("does not hold" if ok == 0 else "partly holds")


@dataclass(frozen=True)
class Trend:
    """A fitted trend of per-cloud values on n and the verdict on a claimed direction.

    ``change``, ``change_low``, ``change_high``: the Theil-Sen slope and its 95 % interval
    times the range of n, relative to the median absolute level (0.1 = 10 %). ``against``:
    the consecutive n between which the median moved against the claimed ``direction`` (+1
    grows, -1 shrinks) by more than the margin.
    """

    verdict: str
    slope: float
    slope_low: float
    slope_high: float
    change: float
    change_low: float
    change_high: float
    points: int
    against: tuple[tuple[float, float], ...] = ()
    direction: int = 1
    drift: float = 1.0  # the factor the interval of the level ratio was widened by (timings)

    def describe(self, n_range: tuple[int, int]) -> str:
        if not np.isfinite(self.change):
            return f"no trend can be fitted ({self.points} clouds)"
        text = (
            f"fitted change over n = {n_range[0]}..{n_range[1]}: {100 * self.change:+.1f} % "
            f"[{100 * self.change_low:+.1f}, {100 * self.change_high:+.1f}] of the median level "
            f"(Theil-Sen slope, 95 % interval, {self.points} clouds)"
        )
        if self.drift != 1.0:
            lo, hi = self.change_low - (self.drift - 1), self.change_high + (self.drift - 1)
            text += (
                f", widened x{self.drift:g} for the drift of timings between runs to "
                f"[{100 * lo:+.1f}, {100 * hi:+.1f}] %"
            )
        if self.against:
            moves = "falls" if self.direction > 0 else "rises"
            steps = ", ".join(f"{a:g} to {b:g}" for a, b in self.against)
            text += f"; but the median {moves} from n = {steps}"
        return text


def theil_sen(x: np.ndarray, y: np.ndarray, confidence: float = 0.95) -> tuple[float, float, float]:
    """Theil-Sen slope (median of pairwise slopes) with Sen's confidence interval.

    The interval's variance corrects for ties in x only (Sen 1968, eq. 2.6 without the
    y-tie term), which can only widen it: with many tied values (file sizes in bytes) the
    full correction can make the variance negative.
    """
    from scipy.stats import norm

    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    i, j = np.triu_indices(x.size, k=1)
    dx = x[j] - x[i]
    keep = dx != 0
    slopes = np.sort((y[j] - y[i])[keep] / dx[keep])
    slope = float(np.median(slopes))
    _, ties = np.unique(x, return_counts=True)
    m = x.size
    variance = (m * (m - 1) * (2 * m + 5) - np.sum(ties * (ties - 1) * (2 * ties + 5))) / 18.0
    spread = -norm.ppf((1 - confidence) / 2) * np.sqrt(max(variance, 0.0))
    lo = max(int(np.round((slopes.size - spread) / 2)) - 1, 0)
    hi = min(int(np.round((slopes.size + spread) / 2)), slopes.size - 1)
    return slope, float(slopes[lo]), float(slopes[hi])


def trend_verdict(
    n: np.ndarray, values: np.ndarray, *, direction: int, margin: float = TREND_MARGIN, drift: float = 1.0
) -> Trend:
    """Verdict on "the values grow (``direction=+1``) / shrink (``-1``) with n" (module notes).

    ``drift`` (:data:`~replication.experiments.timing.TIMING_DRIFT` for timings) widens the
    interval of the change by ``drift - 1`` of the median level each way before the verdict
    (x1.2: 20 % of it): the timings of one run drift against another's by more than their
    interval within the run says, and a level that drifts by x1.2 between the ends of the
    range moves the change by about that much.
    """
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if not (math.isfinite(drift) and drift >= 1):
        raise ValueError(f"drift must be a finite factor of at least 1, got {drift!r}")
    n = np.asarray(n, dtype=float)
    values = np.asarray(values, dtype=float)
    keep = np.isfinite(n) & np.isfinite(values)
    n, values = n[keep], values[keep]
    scale = float(np.median(np.abs(values))) if values.size else 0.0
    if np.unique(n).size < 2 or values.size < 3 or not scale > 0:
        nan = math.nan
        return Trend("cannot be decided", nan, nan, nan, nan, nan, nan, int(values.size))
    slope, low, high = theil_sen(n, values)
    span = float(n.max() - n.min()) / scale
    change, c_lo, c_hi = slope * span, low * span, high * span
    d_lo, d_hi = c_lo - (drift - 1), c_hi + (drift - 1)
    toward = sorted((direction * d_lo, direction * d_hi))  # the change in the claimed direction
    against = _steps_against(n, values, direction, margin * scale)
    if toward[0] > margin:
        verdict = "partly holds" if against else "holds"
    elif toward[1] < -margin:
        verdict = "does not hold"
    else:
        verdict = "cannot be decided"
    slopes = (float(slope), float(low), float(high))
    return Trend(verdict, *slopes, change, c_lo, c_hi, int(values.size), against, direction, drift)


def _steps_against(
    n: np.ndarray, values: np.ndarray, direction: int, tolerance: float
) -> tuple[tuple[float, float], ...]:
    """Consecutive n between which the median of the values moves against ``direction`` by
    more than ``tolerance``."""
    levels = np.unique(n)
    medians = [float(np.median(values[n == level])) for level in levels]
    return tuple(
        (float(levels[k]), float(levels[k + 1]))
        for k in range(levels.size - 1)
        if direction * (medians[k + 1] - medians[k]) < -tolerance
    )


def storage_overall(per_family: dict[tuple[str, str], str]) -> str:
    """Headline storage verdict from the verdicts per (family, coordinates) (module notes)."""
    equal = [v for (family, _), v in per_family.items() if family in EQUAL_PRECISION]
    if not equal or all(v in UNDECIDED for v in equal):
        return "cannot be decided"
    if all(v == "holds" for v in equal):
        return "holds"
    return "partly holds" if "holds" in equal else "does not hold"
