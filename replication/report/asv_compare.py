"""Did a benchmark change between two commits, or is it noise? asv compare's rule, made explicit.

``asv compare`` (and ``asv continuous``) of asv 0.6 calls a timing changed when the ratio
of the medians passes ``--factor`` (default 1.1) *and* the two results are statistically
different (``asv/_stats.py``, ``is_different``):

* when both results carry their raw samples (``--record-samples``; the default of
  ``asv continuous``) and there are enough of them for the test to reach the threshold
  (the smallest attainable p, 1 / C(m + n, min(m, n)), below 0.002: at least 6 samples
  on each side when equal), a two-sided Mann-Whitney U test with p < 0.002, exact for up
  to 20 samples per side and by the normal approximation above, ties broken in the least
  significant way;
* otherwise, when the 99 % confidence intervals of the two medians do not overlap.

asv skips the test, and decides on the factor alone, when either side has one sample
(``--quick``) or no statistics (memory and tracked values). That is how a single-sample
``--quick`` run reports 0.65x "PERFORMANCE INCREASED" for a commit that changed nothing
measured. Here a single-sample timing is never called a change: it is "cannot tell".
Values without statistics by design (memory, tracked numbers) are compared on the
factor, as asv does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

__all__ = ["P_THRESHOLD", "Verdict", "is_different", "mann_whitney_u", "verdict"]

#: asv's significance threshold for the Mann-Whitney U test.
P_THRESHOLD = 0.002


@cache
def _u_counts(m: int, n: int) -> tuple[int, ...]:
    """Number of orderings of m x's and n y's with U = 0, 1, ..., m n (exact null law)."""
    if m == 0 or n == 0:
        return (1,)
    # the largest element is an x (which beats all n y's) or a y
    with_x, with_y = _u_counts(m - 1, n), _u_counts(m, n - 1)
    counts = [0] * (m * n + 1)
    for u, c in enumerate(with_x):
        counts[u + n] += c
    for u, c in enumerate(with_y):
        counts[u] += c
    return tuple(counts)


def mann_whitney_u(x: list[float], y: list[float]) -> tuple[int, float]:
    """Two-sided Mann-Whitney U test as asv 0.6 computes it: (U, p).

    Exact p for samples of at most 20, else the normal approximation (no tie correction);
    ties are broken in the direction that makes the result least significant.
    """
    m, n = len(x), len(y)
    if m == 0 or n == 0:
        raise ValueError(f"Mann-Whitney U needs two non-empty samples, got sizes {m} and {n}")
    u = sum(1 for a in x for b in y if a > b)
    ties = sum(1 for a in x for b in y if a == b)
    half = m * n // 2
    if u <= half <= u + ties:  # conservative tie breaking
        ties = half - u
    ux1, ux2 = min(u, m * n - u), min(u + ties, m * n - (u + ties))
    if ux1 >= ux2:
        ux = ux1
    else:
        u, ux = u + ties, ux2
    if max(m, n) <= 20:
        counts, total = _u_counts(m, n), math.comb(m + n, m)
        upper = max(half, m * n - ux - 1)
        p = sum(counts[: ux + 1]) / total + (1.0 - sum(counts[: upper + 1]) / total)
    else:
        z = (ux - m * n / 2) / math.sqrt(m * n * (m + n + 1) / 12)
        p = 2 * 0.5 * math.erfc(-z / math.sqrt(2))
    return u, p


@dataclass(frozen=True)
class Difference:
    """Whether two results differ, and by which test."""

    different: bool
    test: str  # "Mann-Whitney U", "99 % CIs", or "none" (neither could be applied)
    p: float | None = None  # the U test's p-value


def is_different(
    samples_a: list[float] | None,
    samples_b: list[float] | None,
    ci_a: tuple[float, float],
    ci_b: tuple[float, float],
) -> Difference:
    """asv's ``is_different``: the U test when the samples allow it, else CI overlap."""
    if samples_a is not None and samples_b is not None:
        a = [s for s in samples_a if not math.isnan(s)]
        b = [s for s in samples_b if not math.isnan(s)]
        if a and b and 1 / math.comb(len(a) + len(b), min(len(a), len(b))) < P_THRESHOLD:
            _, p = mann_whitney_u(a, b)
            return Difference(p < P_THRESHOLD, "Mann-Whitney U", p)
    if any(c is None or c != c for c in (*ci_a, *ci_b)):  # too few samples and no interval: no test
        return Difference(False, "none")
    overlap = ci_a[1] >= ci_b[0] and ci_a[0] <= ci_b[1]
    return Difference(not overlap, "99 % CIs")


@dataclass(frozen=True)
class Verdict:
    """One benchmark value compared between two commits."""

    word: str  # slower, faster, higher, lower, same, noise, cannot tell, failed, n/a
    ratio: float  # after / before (NaN when either is missing)
    difference: Difference | None = None

    def __post_init__(self) -> None:
        if self.word not in VERDICTS:
            raise ValueError(f"unknown verdict {self.word!r}; choose one of {VERDICTS}")


#: Every verdict, in the order a report lists them.
VERDICTS = ("slower", "faster", "higher", "lower", "noise", "same", "cannot tell", "failed", "n/a")


def verdict(before: dict, after: dict, *, factor: float = 1.1) -> Verdict:
    """Compare two rows of :func:`replication.report.asv_results.load_asv_results`.

    Parameters
    ----------
    before, after : mapping
        ``status``, ``value``, ``kind``, ``repeat``, ``ci_low``, ``ci_high``, ``samples``.
    factor : float
        A change smaller than this ratio either way is "same" (asv's ``--factor``).

    Returns
    -------
    Verdict
        ``slower``/``faster`` (timings) or ``higher``/``lower`` (other values) for a
        change beyond the factor that passes asv's test; ``noise`` for one beyond the
        factor that does not; ``same`` within the factor; ``cannot tell`` when a timing
        beyond the factor has a single sample on either side; ``failed`` when either
        side failed; ``n/a`` when either was skipped or is missing.

    Notes
    -----
    Performance tracking only (no section of the paper).
    """
    if not factor >= 1:
        raise ValueError(f"factor must be at least 1, got {factor=}")
    if "failed" in (before.get("status"), after.get("status")):
        return Verdict("failed", math.nan)
    if before.get("status") != "ok" or after.get("status") != "ok":
        return Verdict("n/a", math.nan)
    a, b = float(before["value"]), float(after["value"])
    ratio = b / a if a else (1.0 if b == a else math.inf)
    if 1 / factor <= ratio <= factor:
        return Verdict("same", ratio)
    timing = before.get("kind") == "time" and after.get("kind") == "time"
    up = "slower" if timing else "higher"
    down = "faster" if timing else "lower"
    if not timing:
        return Verdict(up if ratio > 1 else down, ratio)
    repeats = (before.get("repeat"), after.get("repeat"))
    if any(r is None or r != r or r <= 1 for r in repeats):
        return Verdict("cannot tell", ratio)  # one sample (or no statistics): no test possible
    diff = is_different(
        before.get("samples"),
        after.get("samples"),
        (before["ci_low"], before["ci_high"]),
        (after["ci_low"], after["ci_high"]),
    )
    if diff.test == "none":  # samples too few for the U test, and no intervals recorded
        return Verdict("cannot tell", ratio)
    if not diff.different:
        return Verdict("noise", ratio, diff)
    return Verdict(up if ratio > 1 else down, ratio, diff)
