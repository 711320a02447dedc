"""A timing harness for side-by-side comparisons (Table 1's computation times).

Tasks are timed in the same process, interleaved within each repeat and in a rotating order
so that slow drifts of the machine (frequency scaling, other load) affect every task alike;
each is warmed up first (imports, JIT caches) and the garbage collector is paused while a
task runs. Before the repeats only the young generations are collected: a full collection
walks every object of the process (0.15-0.2 s once numba's kernels are loaded, about 10 % of a
quick Table 1 run over its 8 timed sets) and could not touch a timing anyway, since the
collector never runs inside one; old garbage is collected between tasks, untimed.
Results are long-form DataFrames; summaries are the median and inter-quartile range, and
ratios are formed per repeat pair before summarising.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Callable, Mapping

import numpy as np
import pandas as pd

__all__ = ["TIMING_DRIFT", "drifted", "interleaved", "summarize", "ratio_per_repeat"]

#: How far (as a factor, either way) the machine's load moves a ratio of two timings between
#: runs, beyond its interval within a run (see :mod:`replication.experiments.claims`).
TIMING_DRIFT = 1.2


def drifted(low: float, high: float, drift: float = TIMING_DRIFT) -> tuple[float, float]:
    """``(low / drift, high * drift)``: a ratio's range widened by the drift between runs; a
    lower bound at or below 0 (a ratio known only to be below ``high``) stays as it is."""
    return (low / drift if low > 0 else low), high * drift


def interleaved(tasks: Mapping[str, Callable[[], object]], *, repeats: int, warmup: int = 2) -> pd.DataFrame:
    """Time every task ``repeats`` times, interleaved; return columns repeat, task, position, seconds."""
    if repeats < 1 or warmup < 0:
        raise ValueError(f"need repeats >= 1 and warmup >= 0, got {repeats=}, {warmup=}")
    names = list(tasks)
    for _ in range(warmup):
        for name in names:
            tasks[name]()
    rows = []
    gc.collect(1)  # the garbage of the warm-up runs; not a full collection (see the module notes)
    enabled = gc.isenabled()
    try:
        for r in range(repeats):
            k = r % len(names)
            for position, name in enumerate(names[k:] + names[:k]):
                gc.disable()
                start = time.perf_counter()
                tasks[name]()
                elapsed = time.perf_counter() - start
                if enabled:
                    gc.enable()
                rows.append((r, name, position, elapsed))
    finally:
        if enabled:
            gc.enable()
    return pd.DataFrame(rows, columns=["repeat", "task", "position", "seconds"])


def summarize(values: pd.Series) -> dict[str, float]:
    """Median, quartiles and count of a sample."""
    v = np.asarray(values, dtype=float)
    q1, median, q3 = np.percentile(v, [25, 50, 75])
    return {"median": float(median), "q1": float(q1), "q3": float(q3), "count": int(v.size)}


def ratio_per_repeat(timings: pd.DataFrame, numerator: str, denominator: str) -> pd.Series:
    """numerator / denominator seconds, paired by repeat (and by any other index columns)."""
    keys = [c for c in timings.columns if c not in ("task", "position", "seconds")]
    wide = timings.pivot_table(index=keys, columns="task", values="seconds")
    return wide[numerator] / wide[denominator]
