"""The speed goals of the project against asv's latest measurement of each.

The table is drawn from the asv archive (:mod:`replication.report.asv_archive`): for each goal
the newest measured commit that has the benchmark's value, with asv's spread, and a verdict that
a loaded machine cannot fake. A timing meets its goal only when its upper quartile does, misses
it only when its lower quartile does, and is *within the spread* otherwise; a tracked value
(a ratio measured in one run, a peak of memory) is compared as it is. ``performance.md`` shows
the table for each machine and ``replication report --performance`` writes it into a checkout's
README between :data:`START` and :data:`END`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pandas as pd

from replication.report.markdown import table

__all__ = ["END", "GOALS", "START", "Goal", "goal_verdict", "speed_lines"]

START, END = "<!-- speed:start -->", "<!-- speed:end -->"


@dataclass(frozen=True)
class Goal:
    """One row: an asv benchmark value and the goal set for it (issues 14 and 15).

    ``limit`` is in the benchmark's unit (seconds, bytes, a ratio); ``at_least`` says that the
    value must reach it rather than stay under it. A row without a limit is shown for scale.
    """

    task: str
    benchmark: str
    params: str = ""
    goal: str = ""
    limit: float | None = None
    at_least: bool = False


GOALS = (
    Goal("`adt()` in memory, 200 points", "benchmark_adt.ADTPaperSizes.time_adt", "n=200, backend=sweephull",
         "<= 0.1 ms", 1e-4),
    Goal("`adt()` in memory, 1e6 points", "benchmark_adt.ADTLarge.time_adt", "n=1000000"),
    Goal("Shewchuk's Triangle time over `adt()`'s, 1e6 points (one run)",
         "benchmark_adt.ADTvsTriangle.track_speedup_over_triangle", "n=1000000", ">= 3x", 3.0, at_least=True),
    Goal("`adt()` 1e7 time over 1e6 time (one run)", "benchmark_adt.ADTGrowth.track_time_ratio_1e7_over_1e6",
         "", "<= 11x", 11.0),
    Goal("`adt()` and a binary `write_vtp`, 1e6 points", "benchmark_adt.ADTScale.time_adt_write_vtp",
         "n=1000000"),
    Goal("`adt()` peak memory of the process, 1e6 points", "benchmark_adt.ADTLarge.peakmem_adt", "n=1000000"),
    Goal("`adt()` peak memory of the process, 1e7 points", "benchmark_adt.ADTLarge.peakmem_adt", "n=10000000",
         "<= 1.5 GiB", 1.5 * 2**30),
    Goal("`fit_nurbs(evaluator=\"fast\")` time over `adt()`'s, 1e6 points (one run)",
         "benchmark_nurbs.NURBSOverADT.track_nurbs_fast_over_adt", "", "<= 1.5x", 1.5),
    Goal("thin-sheet force `surface_force`, 101-point random surface",
         "benchmark_casestudy.JetForce.time_surface_force", "surface=random", "<= 1 ms", 1e-3),
    Goal("`replication --help`, fresh interpreter", "benchmark_startup.timeraw_help", "", "<= 0.3 s", 0.3),
    Goal("`replication adt --random 200 -o x.vtk`, fresh interpreter",
         "benchmark_startup.WarmADTCommand.timeraw_adt_200_aot", "", "<= 0.6 s", 0.6),
)  # fmt: skip


def goal_verdict(row: pd.Series | dict, goal: Goal) -> str:
    """``met``, ``not met`` or ``within the spread`` (a timing whose quartiles straddle the limit)."""
    if goal.limit is None:
        return ""
    value = float(row["value"])
    low, high = float(row.get("q_25", math.nan)), float(row.get("q_75", math.nan))
    if row.get("kind") != "time" or not (math.isfinite(low) and math.isfinite(high)):
        low = high = value
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


def speed_lines(frame: pd.DataFrame, machine: str, measured: list[str]) -> list[str]:
    """The goals table for ``machine``: each goal's value at the newest of ``measured``
    (commits, oldest first) that has it."""
    from replication.report.performance import format_cell

    rank = {c: k for k, c in enumerate(measured)}
    ok = frame[(frame["machine"] == machine) & (frame["status"] == "ok") & frame["commit"].isin(rank)]
    ok = ok.assign(rank=ok["commit"].map(rank)).sort_values(["rank", "started_at"], na_position="first")
    rows = []
    for goal in GOALS:
        found = ok[(ok["benchmark"] == goal.benchmark) & (ok["params"] == goal.params)]
        if found.empty:
            rows.append([goal.task, f"`{_short(goal.benchmark)}`", "not measured", goal.goal or "–", ""])
            continue
        row = found.iloc[-1]
        measured_at = f"{format_cell(row)} at `{row['commit']}` ({row['date']:%Y-%m-%d})"
        rows.append([goal.task, f"`{_short(goal.benchmark)}`", measured_at, goal.goal or "–",
                     goal_verdict(row, goal)])  # fmt: skip
    return [table(rows, ["task", "asv benchmark", "measured", "goal", "verdict"], "llrll")]


def _short(name: str) -> str:
    return name.removeprefix("benchmark_")
