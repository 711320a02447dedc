"""``reports/performance.md``: the asv benchmark history with its spread, and one comparison.

Every number is read from asv's result files (:mod:`replication.report.asv_results`), kept
with the reports in an archive that each run merges them into
(:mod:`replication.report.asv_archive`), or computed from them; nothing is typed. Choices,
so that the page cannot fool its reader:

* **Spread next to every timing.** A cell reads ``1.23 ms ±4 %``: asv's median of its
  samples, and half the interquartile range of the samples relative to the median (asv's
  own "±"). The column head gives the number of samples behind each value.
* **Single-sample timings are separated.** ``asv run --quick`` measures each benchmark
  once, without warm-up: such a commit is not put beside measured ones (where its values
  would read as changes) but in its own section; a single-sample value inside a measured
  commit is marked "(1 sample)".
* **One comparison, with asv's significance rule** (:mod:`replication.report.asv_compare`):
  the two most recent measured commits of each machine (or the pair asked for), every
  value measured at both with ratio, verdict and the test that decided it (values measured
  at one of them only are counted, not compared).
* **Goals judged by the spread** (:mod:`replication.report.speed_goals`), and values
  recovered from an earlier page (no samples) named as such.
"""

from __future__ import annotations

import os
from pathlib import Path

import pandas as pd

from replication.errors import CloudFileError
from replication.report.asv_archive import ARCHIVE, merge_results, read_archive, write_archive
from replication.report.asv_cells import format_cell
from replication.report.asv_compare import P_THRESHOLD, VERDICTS, verdict
from replication.report.asv_results import load_asv_results, single_sample
from replication.report.markdown import table, write_report
from replication.report.speed_goals import RULE, Goal, goal_rows, speed_lines

__all__ = ["FACTOR", "format_cell", "load_asv_results", "render_performance", "speed_table"]

#: Ratio within which a comparison calls two values the same (asv's default ``--factor``).
FACTOR = 1.1


def _samples_note(group: pd.DataFrame) -> str:
    counts = group.loc[(group["kind"] == "time") & (group["status"] == "ok"), "repeat"].dropna()
    if counts.empty:
        return ""
    low, high = int(counts.min()), int(counts.max())
    return f", n={low}" if low == high else f", n={low}–{high}"


def _commits(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per commit, oldest first (commit date, then when it was measured)."""
    first = frame.groupby("commit", sort=False).agg(date=("date", "first"), started=("started_at", "min"))
    return first.reset_index().sort_values(["date", "started", "commit"])


def _latest(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per (commit, benchmark, params): the latest measured, when several environments ran."""
    return frame.sort_values("started_at", na_position="first").drop_duplicates(
        ["commit", "benchmark", "params"], keep="last"
    )


def _shown(frame: pd.DataFrame, order: list[str], count: int) -> pd.DataFrame:
    """The rows a history of ``count`` commits shows: for each benchmark, the latest rows of
    the ``count`` most recent of the commits ``order`` (oldest first) that measured it. A run
    of a few benchmarks on a new commit then hides no other benchmark's history."""
    frame = _latest(frame[frame["commit"].isin(order)])
    rank = {c: k for k, c in enumerate(order)}
    kept = []
    for _, bench in frame.groupby("benchmark", sort=True):
        recent = sorted(set(bench["commit"]), key=rank.__getitem__)[-count:]
        kept.append(bench[bench["commit"].isin(recent)])
    return pd.concat(kept) if kept else frame


def _history(shown: pd.DataFrame, order: list[str]) -> list[str]:
    """One table per benchmark of the rows ``shown`` (:func:`_shown`), its commits in ``order``."""
    lines: list[str] = []
    for name, bench in shown.groupby("benchmark", sort=True):
        by_commit = {c: g for c, g in bench.groupby("commit")}
        heads, columns = [], [c for c in order if c in by_commit]
        for c in columns:
            heads.append(f"`{c}` ({by_commit[c]['date'].iloc[0]:%Y-%m-%d}{_samples_note(by_commit[c])})")
        rows = []
        for params, group in bench.sort_values("param_index").groupby("params", sort=False):
            cells = {r["commit"]: format_cell(r) for _, r in group.iterrows()}
            rows.append([params or "–"] + [cells.get(c, "–") for c in columns])
        lines += [f"### `{name}`", "", table(rows, ["parameters", *heads]), ""]
    return lines


def _recovered_note(shown: pd.DataFrame, goals: list[tuple[Goal, pd.Series | None]]) -> list[str]:
    """Which of the values shown (the history's and comparison's rows ``shown``, the goals
    table's readings ``goals``) were recovered from an earlier page rather than read from asv."""
    rows = [shown]
    rows += [row.to_frame().T for _, row in goals if row is not None]
    shown_rows = pd.concat(rows, ignore_index=True)
    if shown_rows.empty or not (shown_rows["source"] == "page").any():
        return []
    whole, partly = [], []
    for commit, group in shown_rows.groupby("commit", sort=False):
        if (group["source"] == "page").all():
            whole.append(commit)
        elif (group["source"] == "page").any():
            partly.append(commit)
    names = [f"all values of {_names(whole)}"] if whole else []
    names += [f"the values of {_names(partly)} that asv has not measured again"] if partly else []
    return [
        f"Recovered from an earlier version of this page, whose asv files were not kept: "
        f"{' and '.join(names)}. They show three significant digits, a rounded spread and the column's "
        "sample count where the page gave one count (not a range); without samples, no comparison "
        "can test them.",
        "",
    ]


def _names(commits: list[str]) -> str:
    return ", ".join(f"`{c}`" for c in sorted(commits))


def _quick_commits(frame: pd.DataFrame) -> set[str]:
    """Commits whose every timing has a single sample (``asv run --quick``)."""
    timed = frame[(frame["kind"] == "time") & (frame["status"] == "ok")]
    quick = single_sample(timed).groupby(timed["commit"]).all()
    return set(quick[quick].index)


def _split_commits(frame: pd.DataFrame) -> tuple[list[str], set[str], list[str]]:
    """One machine's commits oldest first, its quick ones, and the measured rest (in order)."""
    quick = _quick_commits(frame)
    order = _commits(frame)["commit"].tolist()
    return order, quick, [c for c in order if c not in quick]


def _pick(order: list[str], compare: tuple[str, str] | None) -> tuple[str, str] | None:
    if compare is None:
        return (order[-2], order[-1]) if len(order) >= 2 else None
    found = [next((c for c in order if c.startswith(w[:8]) or w.startswith(c)), None) for w in compare]
    return (found[0], found[1]) if None not in found else None


def _test_text(v) -> str:
    if v.difference is None:
        return "–"
    if v.difference.p is not None:
        return f"U test: p = {v.difference.p:.2g}"
    return "99 % CIs apart" if v.difference.different else "99 % CIs overlap"


def _comparison(frame: pd.DataFrame, base: str, head: str, machine: str, factor: float) -> list[str]:
    before = _latest(frame[frame["commit"] == base]).set_index(["benchmark", "params"])
    after = _latest(frame[frame["commit"] == head]).set_index(["benchmark", "params"])
    rows, counts = [], dict.fromkeys(VERDICTS, 0)
    grid = {**after["param_index"].to_dict(), **before["param_index"].to_dict()}
    one_sided = 0  # measured at one commit only (a benchmark added, or a run of a subset)
    for key in sorted(grid, key=lambda k: (k[0], grid[k])):
        if key not in before.index or key not in after.index:
            one_sided += 1
            continue
        b, a = before.loc[key].to_dict(), after.loc[key].to_dict()
        v = verdict(b, a, factor=factor)
        counts[v.word] += 1
        ratio = "–" if v.ratio != v.ratio else f"{v.ratio:.2f}"
        cells = [format_cell(b), format_cell(a)]
        row = [f"`{key[0]}`", key[1] or "–", *cells, ratio, v.word, _test_text(v)]
        rows.append((VERDICTS.index(v.word), row))
    rows.sort(key=lambda r: r[0])
    summary = ", ".join(f"{n} {word}" for word, n in counts.items() if n) or "none"
    if one_sided:
        plural = "s" if one_sided > 1 else ""
        summary += f" ({one_sided} value{plural} measured at only one of the two, not compared)"
    return [
        f"## Comparison `{base}` → `{head}` (machine `{machine}`)",
        "",
        f"Verdicts with asv's rule at a factor of {factor:g}: {summary}. The ratio is `{head}` / "
        f"`{base}`. A timing is *slower*/*faster* only when the ratio passes the factor and the "
        f"samples differ significantly (Mann-Whitney U, p < {P_THRESHOLD:g}, or 99 % confidence "
        "intervals of the medians apart); *noise* passes the factor but not the test; *cannot "
        "tell*: a single sample or no statistics, so no test is possible. A peak of memory or a "
        "tracked value (asv keeps one number, no samples) is *higher*/*lower* on the factor alone "
        "(test '–').",
        "",
        table(
            [r for _, r in rows],
            ["benchmark", "parameters", f"`{base}`", f"`{head}`", "ratio", "verdict", "test"],
            "llrrrll",
        ),
        "",
    ]


def _method(factor: float) -> list[str]:
    return [
        "## Comparing two commits without mistaking noise for change",
        "",
        "Run both commits in one asv session on a quiet machine, interleaving their rounds so "
        "that a change of load hits both alike, and record the samples so that asv can test "
        "them (`asv continuous` records them by default):",
        "",
        "```bash",
        f"asv continuous --interleave-rounds -a rounds=4 --factor {factor:g} --split BASE HEAD",
        f"asv compare --split --factor {factor:g} BASE HEAD     # again, from the saved results",
        "replication report --performance                # this page: the latest two commits",
        "```",
        "",
        "`asv continuous` exits with status 1 when a benchmark got slower beyond the factor and "
        "significantly. Never compare `--quick` results: one sample per benchmark, no test. "
        "The ratios of a single run on a loaded machine are not evidence; the test decides, "
        "and *noise* means a difference the samples do not support.",
        "",
    ]


def render_performance(
    results_dir: str | os.PathLike[str] | None,
    out_dir: str | os.PathLike[str],
    *,
    commits: int = 5,
    compare: tuple[str, str] | None = None,
    factor: float = FACTOR,
) -> Path:
    """Write ``performance.md`` from asv's results and the archive of earlier ones.

    asv's values are merged into ``data/performance_asv.csv`` under ``out_dir``
    (:mod:`replication.report.asv_archive`), which is written first; the page is drawn from
    the merge, so results that asv no longer holds (another machine, a fresh checkout) stay.

    Parameters
    ----------
    results_dir : path or None
        asv's results directory; None: draw the page from the archive alone.
    out_dir : path
        The reports directory: ``performance.md`` goes there, the archive in its ``data/``.
    commits : int
        How many commits each benchmark's history shows: the most recent measured commits
        of its machine that measured it.
    compare : (str, str), optional
        The commits to compare (hash prefixes, older first); by default the two most recent
        measured commits of each machine.
    factor : float
        Ratio within which values count as the same (asv's ``--factor``).

    Raises
    ------
    CloudFileError
        When ``results_dir`` holds no asv results, or is None and there is no archive.
    ReportDataError
        An asv file or an archive that cannot be read, named.

    Notes
    -----
    Performance tracking of the paper's pipelines; no section of the paper.
    """
    if commits < 1:
        raise ValueError(f"commits must be positive, got {commits=}")
    out = Path(out_dir)
    kept = out / "data" / ARCHIVE
    archive = read_archive(kept) if kept.is_file() else None
    if results_dir is None and archive is None:
        raise CloudFileError(f"no asv results and no archive {kept} (run `asv run` first; see the README)")
    fresh = load_asv_results(results_dir) if results_dir is not None else None
    frame = merge_results(archive, fresh)
    if fresh is not None:
        kept.parent.mkdir(parents=True, exist_ok=True)
        write_archive(frame, kept)
    lines = [
        "# Performance history (asv)",
        "",
        "Generated by `replication report --performance` from the asv results kept in "
        f"[`data/{ARCHIVE}`](data/{ARCHIVE}), into which each run merges asv's own files "
        "(`.asv/results` by default: machine-local, not committed).",
        "Each value is asv's median over its samples; for timings, `±` is half the interquartile",
        "range of the samples as a percentage of the median, and `n` in a column head is the",
        "number of samples behind each value. Single-sample (`asv run --quick`) runs are listed",
        "apart: they are smoke tests, not measurements.",
        "",
    ]
    if frame.empty:
        lines += ["No benchmark results recorded yet.", ""]
    for machine, by_machine in frame.groupby("machine", sort=True):
        order, quick, measured = _split_commits(by_machine)
        lines += [f"## Machine `{machine}`", ""]
        pair = _pick(measured, compare)
        goals = goal_rows(by_machine, measured)
        history = _shown(by_machine, measured, commits)
        compared = _latest(by_machine[by_machine["commit"].isin(pair or ())])
        lines += _recovered_note(pd.concat([history, compared], ignore_index=True), goals)
        if measured:
            lines += [
                "### Against the goals",
                "",
                f"Each goal's value at the newest measured commit that has it. {RULE}; a peak of "
                "memory is a single value.",
                "",
                *speed_lines(goals),
                "",
            ]
        lines += _history(history, measured) if measured else ["No measured commits.", ""]
        if pair:
            lines += _comparison(by_machine, *pair, machine, factor)
        elif compare is not None:
            missing = " or ".join(f"`{c}`" for c in compare)
            lines += [f"No comparison on machine `{machine}`: no measured results of {missing}.", ""]
        if quick:
            lines += [
                f"## Single-sample runs (`asv run --quick`) on machine `{machine}`",
                "",
                "One sample per benchmark, no warm-up: these show that the suite runs, not how fast.",
                "",
            ]
            quick_order = [c for c in order if c in quick]
            lines += _history(_shown(by_machine, quick_order, commits), quick_order)
    lines += _method(factor)
    out.mkdir(parents=True, exist_ok=True)
    return write_report(out / "performance.md", "\n".join(lines).rstrip("\n") + "\n")


def speed_table(out_dir: str | os.PathLike[str]) -> list[str]:
    """The goals table (:mod:`replication.report.speed_goals`) of the machine with the newest
    measured commit, from the archive under ``out_dir``: the README's speed block.

    Parameters
    ----------
    out_dir : path
        The reports directory (the archive is in its ``data/``).

    Returns
    -------
    list of str
        A sentence naming the machine and the table, or a line saying nothing was measured.

    Raises
    ------
    ReportDataError
        When the archive is missing or cannot be read.

    Notes
    -----
    Performance tracking of the paper's pipelines; no section of the paper.
    """
    frame = read_archive(Path(out_dir) / "data" / ARCHIVE)
    newest = None
    for machine, by_machine in frame.groupby("machine", sort=True):
        order = _split_commits(by_machine)[2]
        if order:
            date = by_machine.loc[by_machine["commit"] == order[-1], "date"].max()
            if newest is None or date > newest[0]:
                newest = (date, machine, by_machine, order)
    if newest is None:
        return ["No measured commits yet (see Performance tracking below)."]
    _, machine, by_machine, order = newest
    return [
        f"asv's latest measurements on machine `{machine}`, drawn by `replication report --performance` "
        "from [reports/data/performance_asv.csv](reports/data/performance_asv.csv), which keeps every "
        "measured commit; [reports/performance.md](reports/performance.md) shows the latest commits' "
        f"values with the spread of each timing. {RULE}.",
        "",
        *speed_lines(goal_rows(by_machine, order)),
    ]
