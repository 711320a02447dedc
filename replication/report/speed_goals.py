"""The speed goals of the project against asv's latest measurement of each.

The table is drawn from the asv archive (:mod:`replication.report.asv_archive`): for each goal
the newest measured commit that has the benchmark's value, with asv's spread, and a verdict that
a loaded machine cannot fake. A timing meets its goal only when its upper quartile does, misses
it only when its lower quartile does, and is *within the spread* otherwise. A ratio of two
timings (median of a few alternated pairs in one run) has no spread of its own, but it drifts
between runs (asv read 1.48-1.59x for ``fit_nurbs``/``adt()`` and 10.5-11.1x for 1e7/1e6 on
unchanged code): it is given :data:`~replication.experiments.timing.TIMING_DRIFT` (x1.2) either way, as
the speed claims of Table 1 are. A peak of memory is compared as it is. ``performance.md`` shows
the table for each machine and ``replication report --performance`` writes it into a checkout's
README between :data:`START` and :data:`END`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pandas as pd

from replication.experiments.timing import TIMING_DRIFT, drifted
from replication.report.asv_cells import format_cell
from replication.report.markdown import table

__all__ = ["END", "GOALS", "RULE", "START", "Goal", "goal_rows", "goal_verdict", "speed_lines"]

START, END = "<!-- speed:start -->", "<!-- speed:end -->"
#: How a timing is judged against its goal (the page and the README say it in these words).
RULE = (
    "A timing meets its goal when its upper quartile does, misses it when its lower quartile does, "
    "and is *within the spread* otherwise; a ratio of two timings, measured in one run, is taken "
    f"within x{TIMING_DRIFT:g} of its value either way, its drift between runs"
)


@dataclass(frozen=True)
class Goal:
    """One row: an asv benchmark value and the goal set for it (issues 14 and 15).

    ``limit`` is in the benchmark's unit (seconds, bytes, a ratio); ``at_least`` says that the
    value must reach it rather than stay under it; ``ratio`` marks a ratio of two timings
    (judged with the drift between runs). A row without a limit is shown for scale.
    """

    task: str
    benchmark: str
    params: str = ""
    goal: str = ""
    limit: float | None = None
    at_least: bool = False
    ratio: bool = False


GOALS = (
    Goal("`adt()` in memory, 200 points", "benchmark_adt.ADTPaperSizes.time_adt", "n=200, backend=sweephull",
         "<= 0.1 ms", 1e-4),
    Goal("`adt()` in memory, 1e6 points", "benchmark_adt.ADTLarge.time_adt", "n=1000000"),
    Goal("Shewchuk's Triangle time over `adt()`'s, 1e6 points (one run)",
         "benchmark_adt.ADTvsTriangle.track_speedup_over_triangle", "n=1000000", ">= 3x", 3.0, at_least=True,
         ratio=True),
    Goal("`adt()` 1e7 time over 1e6 time (one run)", "benchmark_adt.ADTGrowth.track_time_ratio_1e7_over_1e6",
         "", "<= 11x", 11.0, ratio=True),
    Goal("the same ratio in user CPU time (the kernel's page faults left out)",
         "benchmark_adt.ADTGrowth.track_user_cpu_ratio_1e7_over_1e6"),
    Goal("`adt()` and a binary `write_vtp`, 1e6 points", "benchmark_adt.ADTScale.time_adt_write_vtp",
         "n=1000000"),
    Goal("`adt()` peak memory of the process, 1e6 points", "benchmark_adt.ADTLarge.peakmem_adt", "n=1000000"),
    Goal("`adt()` peak memory of the process, 1e7 points", "benchmark_adt.ADTLarge.peakmem_adt", "n=10000000",
         "<= 1.5 GiB", 1.5 * 2**30),
    Goal("`fit_nurbs(evaluator=\"fast\")` time over `adt()`'s, 1e6 points (one run)",
         "benchmark_nurbs.NURBSOverADT.track_nurbs_fast_over_adt", "", "<= 1.5x", 1.5, ratio=True),
    Goal("thin-sheet force `surface_force`, 101-point random surface, numba's kernels (the GA's; 2 threads)",
         "benchmark_casestudy.JetForce.time_surface_force", "surface=random, kernel=numba", "<= 1 ms", 1e-3),
    Goal("the same, ahead-of-time kernels (a process without numba)",
         "benchmark_casestudy.JetForce.time_surface_force", "surface=random, kernel=ahead-of-time", "<= 1 ms",
         1e-3),
    Goal("`replication --help`, fresh interpreter", "benchmark_startup.timeraw_help", "", "<= 0.3 s", 0.3),
    Goal("`replication adt --random 200 -o x.vtk`, fresh interpreter",
         "benchmark_startup.WarmADTCommand.timeraw_adt_200_aot", "", "<= 0.6 s", 0.6),
)  # fmt: skip


def goal_verdict(row: pd.Series | dict, goal: Goal) -> str:
    """Whether a reading meets its goal.

    Parameters
    ----------
    row : Series or dict
        An ``ok`` reading of the archive: ``value``, ``kind`` and, for a timing, ``q_25``
        and ``q_75``.
    goal : Goal

    Returns
    -------
    str
        ``met``, ``not met``, ``within the spread`` (a timing whose quartiles straddle the
        limit, or a ratio within x :data:`TIMING_DRIFT` of it), or ``""`` for a row without a
        limit.
    """
    if goal.limit is None:
        return ""
    value = float(row["value"])
    low, high = float(row.get("q_25", math.nan)), float(row.get("q_75", math.nan))
    if row.get("kind") != "time" or not (math.isfinite(low) and math.isfinite(high)):
        low = high = value
    if goal.ratio and row.get("kind") != "time":  # one run's ratio: its drift between runs
        low, high = drifted(value, value)
    if goal.at_least:
        low, high = -high, -low
        limit = -goal.limit
    else:
        limit = goal.limit
    if high <= limit:
        return "met"
    if low > limit:
        return "not met"
    return "within the spread"


def goal_rows(frame: pd.DataFrame, measured: list[str]) -> list[tuple[Goal, pd.Series | None]]:
    """Each goal of :data:`GOALS` with its reading: the newest of the ``measured`` commits
    (oldest first) that ran the benchmark, ok or failed (a skip is no reading), or None.

    Parameters
    ----------
    frame : DataFrame
        One machine's rows of the asv archive (:mod:`replication.report.asv_archive`).
    measured : list of str
        The machine's measured commits, oldest first (single-sample runs left out).

    Returns
    -------
    list of (Goal, Series or None)
    """
    rank = {c: k for k, c in enumerate(measured)}
    ran = frame[frame["status"].isin(("ok", "failed")) & frame["commit"].isin(rank)]
    ran = ran.assign(_rank=ran["commit"].map(rank)).sort_values(["_rank", "started_at"], na_position="first")
    found = []
    for goal in GOALS:
        rows = ran[(ran["benchmark"] == goal.benchmark) & (ran["params"] == goal.params)]
        found.append((goal, rows.iloc[-1] if not rows.empty else None))
    return found


def speed_lines(found: list[tuple[Goal, pd.Series | None]]) -> list[str]:
    """The goals table (markdown) of :func:`goal_rows`'s readings.

    Parameters
    ----------
    found : list of (Goal, Series or None)
        Each goal with its reading, as :func:`goal_rows` returns them.

    Returns
    -------
    list of str
        The table's lines; a failed newest reading shows as failed, not an older value.
    """
    rows = []
    for goal, row in found:
        name = f"`{_short(goal.benchmark)}`"
        if row is None:
            rows.append([goal.task, name, "not measured", goal.goal or "–", ""])
            continue
        measured_at = f"{format_cell(row)} at `{row['commit']}` ({row['date']:%Y-%m-%d})"
        verdict = goal_verdict(row, goal) if row["status"] == "ok" else ("failed" if goal.limit else "")
        rows.append([goal.task, name, measured_at, goal.goal or "–", verdict])
    return [table(rows, ["task", "asv benchmark", "measured", "goal", "verdict"], "llrll")]


def _short(name: str) -> str:
    return name.removeprefix("benchmark_")
