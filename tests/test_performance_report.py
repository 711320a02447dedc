"""performance.md from synthetic asv results: spread, single-sample runs, failures, the comparison."""

import json
import math
import re

import numpy as np
import pytest

from replication.report.asv_compare import is_different, mann_whitney_u, verdict
from replication.report.asv_results import load_asv_results
from replication.report.performance import format_cell, render_performance

COLUMNS = [
    "result", "params", "version", "started_at", "duration", "stats_ci_99_a", "stats_ci_99_b",
    "stats_q_25", "stats_q_75", "stats_number", "stats_repeat", "samples", "profile",
]  # fmt: skip
BENCHMARKS = {
    "b.T.time_adt": {"type": "time", "unit": "seconds", "param_names": ["n"], "params": [["9", "200"]]},
    "b.time_plain": {"type": "time", "unit": "seconds", "param_names": [], "params": []},
    "b.time_broken": {"type": "time", "unit": "seconds", "param_names": [], "params": []},
    "b.track_bytes": {"type": "track", "unit": "bytes", "param_names": [], "params": []},
}
DAY = 86_400_000  # ms


def timing(values, *, samples=None, repeat=10, ci=None, quartiles=None):
    """One asv row for a timing: values (per parameter), and stats as asv_runner computes them."""
    n = len(values)
    quartiles = quartiles or [(v * 0.95, v * 1.05) for v in values]
    ci = ci or [(v * 0.9, v * 1.1) for v in values]
    row = [values, [["9", "200"]] if n == 2 else [], "v1", 1_700_000_000_000, 2.0]
    row += [[c[0] for c in ci], [c[1] for c in ci], [q[0] for q in quartiles], [q[1] for q in quartiles]]
    row += [[1] * n, [repeat] * n]
    if samples is not None:
        row.append(samples)
    return row


def write_results(tmp_path, commits, machine="m1"):
    """asv's layout: benchmarks.json and one file per commit; commits: [(hash, day, results)]."""
    results = tmp_path / "results"
    (results / machine).mkdir(parents=True, exist_ok=True)
    (results / "benchmarks.json").write_text(json.dumps({**BENCHMARKS, "version": 2}), encoding="utf-8")
    (results / machine / "machine.json").write_text(
        json.dumps({"machine": machine, "version": 1}), encoding="utf-8"
    )
    for commit, day, rows in commits:
        data = {
            "commit_hash": commit, "env_name": "existing-py", "date": 1_700_000_000_000 + day * DAY,
            "params": {"machine": machine}, "result_columns": COLUMNS, "results": rows, "version": 2,
        }  # fmt: skip
        (results / machine / f"{commit[:8]}-existing-py.json").write_text(json.dumps(data), encoding="utf-8")
    return results


def spread_rows():
    rng = np.random.default_rng(0)
    slow = list(2e-3 + 1e-5 * rng.random(10))  # clearly slower: disjoint samples
    fast = list(1e-3 + 1e-5 * rng.random(10))
    return fast, slow


@pytest.fixture
def history(tmp_path):
    fast, slow = spread_rows()
    full_a = {
        "b.T.time_adt": timing([1e-4, 1e-3], samples=[[1e-4] * 10, fast]),
        "b.time_plain": timing([1e-3], quartiles=[(0.9e-3, 1.1e-3)]),  # ±10 %
        "b.time_broken": [None, [], "v1", 1_700_000_000_000, 0.1],  # failed: asv stores one null
        "b.track_bytes": [[1000], [], "v1"],
    }
    full_b = {
        "b.T.time_adt": timing([1e-4, float(np.median(slow))], samples=[[1e-4] * 10, slow]),
        "b.time_plain": [[3e-3], [], "v1", 1_700_000_000_000, 2.0],  # no statistics recorded
        "b.time_broken": timing([5e-4], repeat=1, ci=[(-math.inf, math.inf)]),  # one sample, in a full run
        "b.track_bytes": [[2000], [], "v1"],
    }
    quick = {  # asv run --quick: a single sample of everything, no warm-up
        "b.T.time_adt": timing([3e-4, float("nan")], repeat=1, ci=[(-math.inf, math.inf)] * 2),
        "b.time_plain": timing([9e-3], repeat=1, ci=[(-math.inf, math.inf)]),
    }
    return write_results(
        tmp_path, [("aaaaaaaa11", 1, full_a), ("bbbbbbbb22", 2, full_b), ("cccccccc33", 3, quick)]
    )


def _section(text, title):
    return text.split(title, 1)[1].split("\n## ", 1)[0]


def test_loader_reads_statuses_samples_and_stats(history):
    frame = load_asv_results(history)
    adt = frame[(frame.benchmark == "b.T.time_adt") & (frame.commit == "aaaaaaaa")]
    assert list(adt.params) == ["n=9", "n=200"] and list(adt.repeat) == [10, 10]
    assert adt.samples.iloc[1] == tuple(spread_rows()[0])
    broken = frame[(frame.benchmark == "b.time_broken") & (frame.commit == "aaaaaaaa")]
    assert list(broken.status) == ["failed"]
    skipped = frame[(frame.commit == "cccccccc") & (frame.params == "n=200")]
    assert list(skipped.status) == ["skipped"]
    plain_b = frame[(frame.benchmark == "b.time_plain") & (frame.commit == "bbbbbbbb")].iloc[0]
    assert plain_b.value == 3e-3 and math.isnan(plain_b["repeat"]) and plain_b.samples is None


def test_cells_show_spread_single_samples_and_failures():
    base = {"status": "ok", "kind": "time", "unit": "seconds", "value": 1.23e-3, "repeat": 10}
    assert format_cell({**base, "q_25": 1.23e-3 * 0.96, "q_75": 1.23e-3 * 1.04}) == "1.23 ms ±4 %"
    assert format_cell({**base, "q_25": 1.23e-3, "q_75": 1.23e-3 * 1.01}) == "1.23 ms ±0.5 %"
    assert format_cell({**base, "repeat": 1, "q_25": 1.23e-3, "q_75": 1.23e-3}) == "1.23 ms (1 sample)"
    nan = float("nan")
    assert format_cell({**base, "repeat": nan, "q_25": nan, "q_75": nan}) == "1.23 ms (no spread recorded)"
    assert format_cell({**base, "status": "failed"}) == "failed"
    assert format_cell({**base, "status": "skipped"}) == "n/a"
    assert format_cell({**base, "kind": "track", "unit": "bytes", "value": 2000.0}) == "2,000 B"


def test_quick_runs_are_kept_apart_from_measured_ones(history, tmp_path):
    text = render_performance(history, tmp_path / "out").read_text(encoding="utf-8")
    measured = _section(text, "## Machine `m1`")
    quick = _section(text, "## Single-sample runs (`asv run --quick`) on machine `m1`")
    assert "`cccccccc`" not in measured and "`cccccccc`" in quick  # never beside measured columns
    assert "`aaaaaaaa` (" in measured and "`bbbbbbbb` (" in measured
    assert "| – | 1 ms ±10 % | 3 ms (no spread recorded) |" in measured
    assert "| – | failed | 500 µs (1 sample) |" in measured  # a single sample inside a full run
    assert "| – | 1,000 B | 2,000 B |" in measured
    assert "| n=200 | n/a |" in quick and "9 ms (1 sample)" in quick
    assert "`aaaaaaaa` (2023-11-15, n=10)" in measured  # samples per value in the column head


def test_comparison_of_the_two_latest_measured_commits(history, tmp_path):
    text = render_performance(history, tmp_path / "out").read_text(encoding="utf-8")
    comparison = _section(text, "## Comparison `aaaaaaaa` → `bbbbbbbb` (machine `m1`)")
    rows = {tuple(c.strip() for c in line.split("|")[1:3]): line for line in comparison.splitlines()}
    fast, slow = spread_rows()
    ratio = np.median(slow) / 1e-3
    slower = rows[("`b.T.time_adt`", "n=200")]
    assert f"| {ratio:.2f} | slower | U test: p = " in slower
    p = float(re.search(r"p = ([0-9.e-]+)", slower).group(1))
    assert p == pytest.approx(mann_whitney_u(fast, slow)[1], rel=0.05) and p < 0.002
    assert "| 1.00 | same |" in rows[("`b.T.time_adt`", "n=9")]
    assert "| 3.00 | cannot tell |" in rows[("`b.time_plain`", "–")]  # no statistics on one side
    assert "| failed |" in rows[("`b.time_broken`", "–")]
    assert "| 2.00 | higher |" in rows[("`b.track_bytes`", "–")]
    assert "1 slower, 1 higher, 1 same, 1 cannot tell, 1 failed" in comparison


def test_explicit_pair_and_no_pair(history, tmp_path):
    text = render_performance(history, tmp_path / "out", compare=("bbbbbbbb22", "aaaaaaaa")).read_text(
        encoding="utf-8"
    )
    assert "## Comparison `bbbbbbbb` → `aaaaaaaa`" in text and "| faster |" in text
    text = render_performance(history, tmp_path / "out", compare=("aaaaaaaa", "cccccccc")).read_text(
        encoding="utf-8"
    )  # a quick run is not compared
    assert "## Comparison" not in text and "no measured results of `aaaaaaaa` or `cccccccc`" in text
    one = write_results(tmp_path / "one", [("dddddddd", 1, {"b.track_bytes": [[5], [], "v1"]})])
    text = render_performance(one, tmp_path / "out1").read_text(encoding="utf-8")
    assert "## Comparison" not in text and "| – | 5 B |" in text


def test_noise_beyond_the_factor_is_not_a_change():
    a = [1e-3 * (1 + k / 10) for k in range(10)]  # 1.0 ... 1.9 ms
    b = [0.85 * x for x in a]  # the medians differ by 15 %...
    row = {"status": "ok", "kind": "time", "repeat": 10, "ci_low": 0.0, "ci_high": 1.0}
    v = verdict({**row, "value": np.median(a), "samples": a}, {**row, "value": np.median(b), "samples": b})
    assert v.ratio < 1 / 1.1 and v.word == "noise" and v.difference.p > 0.002  # ...but the U test says no
    # one sample each: asv would call a 0.65x ratio a change; here nobody can tell
    one = {"status": "ok", "kind": "time", "repeat": 1, "ci_low": -math.inf, "ci_high": math.inf}
    assert verdict({**one, "value": 1.0}, {**one, "value": 0.65}).word == "cannot tell"
    # no samples: the 99 % confidence intervals decide
    ci = {"status": "ok", "kind": "time", "repeat": 10, "samples": None}
    apart = verdict(
        {**ci, "value": 1.0, "ci_low": 0.9, "ci_high": 1.1},
        {**ci, "value": 2.0, "ci_low": 1.8, "ci_high": 2.2},
    )
    overlap = verdict(
        {**ci, "value": 1.0, "ci_low": 0.5, "ci_high": 1.9},
        {**ci, "value": 2.0, "ci_low": 1.8, "ci_high": 2.2},
    )
    assert (apart.word, apart.difference.test) == ("slower", "99 % CIs") and overlap.word == "noise"


@pytest.mark.parametrize("sizes", [(6, 6), (10, 10), (5, 12), (25, 30)])
def test_significance_agrees_with_asv(sizes):
    asv_stats = pytest.importorskip("asv._stats")
    rng = np.random.default_rng(sizes)
    for shift in (0.0, 0.3, 1.0, 3.0):
        x = list(np.round(rng.normal(size=sizes[0]), 1))  # rounded: ties happen
        y = list(np.round(rng.normal(shift, size=sizes[1]), 1))
        assert mann_whitney_u(x, y) == pytest.approx(asv_stats.mann_whitney_u(x, y), rel=1e-9)
        stats = {"ci_99_a": min(x), "ci_99_b": max(x)}, {"ci_99_a": min(y), "ci_99_b": max(y)}
        for samples in ((x, y), (None, None)):
            ours = is_different(*samples, tuple(stats[0].values()), tuple(stats[1].values()))
            assert ours.different == asv_stats.is_different(*samples, *stats)


def test_bad_arguments():
    with pytest.raises(ValueError, match="factor"):
        verdict({"status": "ok"}, {"status": "ok"}, factor=0.5)
    with pytest.raises(ValueError, match="sizes 0 and 2"):
        mann_whitney_u([], [1.0, 2.0])


def test_three_samples_a_side_and_no_intervals_cannot_tell():
    # too few samples for the U test (p >= 0.05 at best) and no CIs: it said "slower, 99 % CIs apart"
    row = {"status": "ok", "kind": "time", "repeat": 3, "ci_low": None, "ci_high": None}
    v = verdict(
        {**row, "value": 1e-3, "samples": [1e-3] * 3}, {**row, "value": 1.5e-3, "samples": [1.5e-3] * 3}
    )
    assert v.word == "cannot tell" and v.ratio == pytest.approx(1.5)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda d: d.pop("date"), "no commit date"),  # was dated 1970, so the newer commit became the base
        (lambda d: d.update(date="2026-01-01"), "no commit date"),
        (lambda d: d.update(results=None), "'results' is not an object"),
        (lambda d: d["results"]["b.time_plain"].__setitem__(11, [[None, "x"]]), "not an asv result file"),
        (lambda d: d["results"]["b.time_plain"].__setitem__(3, 1e20), "not an asv result file"),
    ],
)
def test_odd_asv_files_are_one_line_errors_naming_the_file(tmp_path, change, match):
    from replication.errors import ReportDataError

    results = write_results(
        tmp_path, [("aaaaaaaa11", 1, {"b.time_plain": timing([1e-3], samples=[[1e-3, 2e-3]])})]
    )
    path = results / "m1" / "aaaaaaaa-existing-py.json"
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))
    with pytest.raises(ReportDataError, match=match) as info:
        load_asv_results(results)
    assert "aaaaaaaa-existing-py.json" in str(info.value)
    path.write_bytes(b"{bad json\xff")
    with pytest.raises(ReportDataError, match="not a readable asv file"):
        load_asv_results(results)
    (results / "benchmarks.json").write_text("[1, 2]")
    with pytest.raises(ReportDataError, match="expected a JSON object, got list"):
        load_asv_results(results)


def test_archive_round_trip_keeps_every_field(history, tmp_path):
    from pandas.testing import assert_frame_equal

    from replication.report.asv_archive import read_archive, write_archive

    frame = load_asv_results(history).assign(source="asv")
    write_archive(frame, tmp_path / "a.csv")
    back = read_archive(tmp_path / "a.csv")
    assert list(back.samples) == list(frame.samples)  # tuples of exact floats, or None
    assert_frame_equal(back.drop(columns="samples"), frame.drop(columns="samples"), check_dtype=False)
    assert back.started_at.dt.tz is not None and back.date.dt.tz is not None


def test_the_page_keeps_its_history_without_asvs_files(history, tmp_path):
    """performance.md drawn again where asv's files are gone (a fresh checkout) is the same page;
    new results add a commit to the history instead of replacing it."""
    import shutil

    out = tmp_path / "out"
    first = render_performance(history, out).read_text(encoding="utf-8")
    assert (out / "data" / "performance_asv.csv").is_file()
    shutil.rmtree(history)
    assert render_performance(None, out).read_text(encoding="utf-8") == first
    fast, slow = spread_rows()
    newer = write_results(tmp_path / "new", [("dddddddd44", 4, {"b.T.time_adt": timing([1e-4, 2e-3], samples=[
        [1e-4] * 10, slow])})])  # fmt: skip
    text = render_performance(newer, out).read_text(encoding="utf-8")
    measured = _section(text, "## Machine `m1`")
    assert all(f"`{c}` (" in measured for c in ("aaaaaaaa", "bbbbbbbb", "dddddddd"))
    assert "## Comparison `bbbbbbbb` → `dddddddd`" in text
    comparison = _section(text, "## Comparison `bbbbbbbb` → `dddddddd`")
    assert "(3 values measured at only one of the two, not compared)" in comparison  # d ran one benchmark
    assert "`b.time_plain`" not in comparison and "| n/a |" not in comparison
    assert "| 1 ms ±10 % | 3 ms (no spread recorded) |" in measured  # b.time_plain: not measured at d
    # asv holding a value again replaces the archived one, never doubles it
    again = write_results(tmp_path / "again", [("dddddddd44", 4, {"b.T.time_adt": timing([1e-4, 4e-3])})])
    text = render_performance(again, out).read_text(encoding="utf-8")
    assert "4 ms ±5 %" in _section(text, "## Machine `m1`") and "2 ms ±" not in _section(text, "### `b.T")


def test_nothing_to_draw_from_is_one_line_error(tmp_path):
    from replication.errors import CloudFileError

    with pytest.raises(CloudFileError, match="no asv results and no archive .*performance_asv.csv"):
        render_performance(None, tmp_path / "out")
    assert not (tmp_path / "out" / "performance.md").exists()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda t: t.replace(",source\n", ",origin\n", 1), "missing column.*source"),
        (lambda t: t.replace(",asv\n", ",elsewhere\n", 1), "line 2 has source 'elsewhere'"),
        (
            lambda t: t.replace(",ok,", ",fine,", 1),
            "line [0-9]+ has status 'fine' .expected one of ok, failed, skipped",
        ),
        (lambda t: t.replace("2023-11-", "yesterday-", 1), "not a readable performance archive"),
        (lambda t: t[: len(t) // 2], "cut short|fields"),
    ],
)
def test_a_damaged_archive_is_one_line_error_naming_it(history, tmp_path, change, match):
    from replication.errors import ReportDataError

    out = tmp_path / "out"
    render_performance(history, out)
    kept = out / "data" / "performance_asv.csv"
    kept.write_text(change(kept.read_text(encoding="utf-8")), encoding="utf-8")
    before = (out / "performance.md").read_bytes()
    with pytest.raises(ReportDataError, match=match) as info:
        render_performance(history, out)
    assert "performance_asv.csv" in str(info.value) and "\n" not in str(info.value)
    assert (out / "performance.md").read_bytes() == before  # nothing rewritten


def test_a_pages_history_is_recovered_as_it_was_shown(history, tmp_path):
    """rows_from_page reads the history tables back: the page drawn from them alone shows the
    same history (values to the page's digits); only the comparison, which needs samples, goes."""
    import pandas as pd

    from replication.report.asv_archive import rows_from_page, write_archive

    text = render_performance(history, tmp_path / "out").read_text(encoding="utf-8")
    frame = load_asv_results(history)
    dates = dict(zip(frame.commit, frame.date))
    rows = rows_from_page(text, {**BENCHMARKS}, dates)
    assert set(rows.source) == {"page"} and set(rows.commit) == {"aaaaaaaa", "bbbbbbbb"}  # not the quick run
    assert rows.samples.isna().all() or all(s is None for s in rows.samples)
    (tmp_path / "page" / "data").mkdir(parents=True)
    write_archive(rows, tmp_path / "page" / "data" / "performance_asv.csv")
    again = render_performance(None, tmp_path / "page").read_text(encoding="utf-8")
    assert (
        "Recovered from an earlier version of this page, whose asv files were not kept: all values of "
        "`aaaaaaaa`, `bbbbbbbb`." in again
    )
    title = "## Comparison `aaaaaaaa` → `bbbbbbbb` (machine `m1`)"
    recovered, shown = _section(again, "## Machine `m1`").split(title)[0].split("\n\n", 2)[1:]
    assert (
        recovered.startswith("Recovered from")
        and shown == _section(text, "## Machine `m1`").split(title)[0][2:]
    )
    assert "| cannot tell |" in _section(again, title) and "| slower |" not in _section(again, title)
    with pytest.raises(ValueError, match="cannot read the page: KeyError 'aaaaaaaa'"):
        rows_from_page(text, BENCHMARKS, {})  # a commit without its date
    with pytest.raises(ValueError, match="b.gone is not in benchmarks.json"):
        rows_from_page(text.replace("b.time_plain", "b.gone"), BENCHMARKS, dates)
    assert isinstance(rows.date.iloc[0], pd.Timestamp)
    assert set(rows[rows.kind == "time"].repeat.dropna()) == {10.0, 1.0}
    # a column head with a range of sample counts: which value had how many is not on the page
    ranged = rows_from_page(text.replace("(2023-11-15, n=10)", "(2023-11-15, n=7–10)"), BENCHMARKS, dates)
    assert ranged[ranged.commit == "aaaaaaaa"].repeat.isna().all()
    assert (ranged[ranged.commit == "bbbbbbbb"].repeat.dropna() > 0).all()


def test_goal_verdicts_need_the_whole_spread_on_one_side():
    from replication.report.speed_goals import Goal, goal_verdict

    under = Goal("t", "b", goal="<= 1 ms", limit=1e-3)
    timing_row = {"kind": "time", "value": 0.9e-3, "q_25": 0.8e-3, "q_75": 0.95e-3}
    assert goal_verdict(timing_row, under) == "met"
    assert goal_verdict({**timing_row, "q_75": 1.2e-3}, under) == "within the spread"  # median under
    assert goal_verdict({**timing_row, "value": 1.1e-3, "q_25": 0.99e-3, "q_75": 1.2e-3}, under) == (
        "within the spread"
    )  # median over, lower quartile under
    assert goal_verdict({**timing_row, "value": 1.2e-3, "q_25": 1.1e-3, "q_75": 1.3e-3}, under) == "not met"
    assert (
        goal_verdict({**timing_row, "value": 1e-3, "q_25": 1e-3, "q_75": 1e-3}, under) == "met"
    )  # at the limit
    nan = float("nan")
    assert goal_verdict({**timing_row, "q_25": nan, "q_75": nan}, under) == "met"  # no spread: the value
    ratio = Goal("r", "b", goal=">= 3x", limit=3.0, at_least=True)
    assert goal_verdict({"kind": "track", "value": 3.5}, ratio) == "met"
    assert goal_verdict({"kind": "track", "value": 2.9}, ratio) == "not met"
    assert (
        goal_verdict({"kind": "time", "value": 3.1, "q_25": 2.9, "q_75": 3.3}, ratio) == "within the spread"
    )
    assert goal_verdict({"kind": "track", "value": 1.0}, Goal("x", "b")) == ""  # no goal: shown for scale


def test_a_ratio_goal_allows_for_the_drift_between_runs():
    """fit_nurbs/adt() measured 1.59x and 1.48x, and 1e7/1e6 10.5x and 11.1x, by asv on commits
    with the same code: the plain rule called each goal met in one run and not met in the other."""
    from replication.experiments.claims import TIMING_DRIFT
    from replication.report.speed_goals import GOALS, Goal, goal_verdict

    under = Goal("r", "b", goal="<= 1.5x", limit=1.5, ratio=True)
    plain = Goal("r", "b", goal="<= 1.5x", limit=1.5)
    runs = [{"kind": "track", "value": v} for v in (1.59, 1.48)]
    assert [goal_verdict(r, plain) for r in runs] == ["not met", "met"]
    assert {goal_verdict(r, under) for r in runs} == {"within the spread"}
    growth = Goal("g", "b", goal="<= 11x", limit=11.0, ratio=True)
    assert {goal_verdict({"kind": "track", "value": v}, growth) for v in (10.5, 11.1)} == {
        "within the spread"
    }
    # clear of the drift, a ratio is decided either way
    assert goal_verdict({"kind": "track", "value": 1.5 / TIMING_DRIFT - 0.01}, under) == "met"
    assert goal_verdict({"kind": "track", "value": 1.5 * TIMING_DRIFT + 0.01}, under) == "not met"
    at_least = Goal("t", "b", goal=">= 3x", limit=3.0, at_least=True, ratio=True)
    assert goal_verdict({"kind": "track", "value": 4.35}, at_least) == "met"
    assert goal_verdict({"kind": "track", "value": 3.3}, at_least) == "within the spread"
    assert goal_verdict({"kind": "track", "value": 2.4}, at_least) == "not met"
    # the ratio goals of the table are marked, and no timing or memory goal is
    assert {g.benchmark.rsplit(".", 1)[1] for g in GOALS if g.ratio} == {
        "track_speedup_over_triangle",
        "track_time_ratio_1e7_over_1e6",
        "track_nurbs_fast_over_adt",
    }


def test_goals_table_takes_each_value_from_the_newest_commit_that_has_it(history, tmp_path, monkeypatch):
    from replication.report import speed_goals
    from replication.report.performance import speed_table

    monkeypatch.setattr(speed_goals, "GOALS", (
        speed_goals.Goal("adt at 200", "b.T.time_adt", "n=200", "<= 1.5 ms", 1.5e-3),
        speed_goals.Goal("plain", "b.time_plain", "", "<= 2 ms", 2e-3),
        speed_goals.Goal("bytes", "b.track_bytes"),
        speed_goals.Goal("gone", "b.time_gone", "", "<= 1 s", 1.0),
    ))  # fmt: skip
    out = tmp_path / "out"
    render_performance(history, out)
    newer = write_results(tmp_path / "new", [("dddddddd44", 4, {"b.T.time_adt": timing([1e-4, 1e-3])})])
    text = render_performance(newer, out).read_text(encoding="utf-8")
    lines = speed_table(out)
    assert "machine `m1`" in lines[0]
    rows = {line.split("|")[1].strip(): line for line in lines[-1].splitlines()[2:]}
    assert "1 ms ±5 % at `dddddddd`" in rows["adt at 200"] and rows["adt at 200"].endswith("| met |")
    # b.time_plain was not run at d: bbbbbbbb's value, which has no spread, decides alone
    assert "3 ms (no spread recorded) at `bbbbbbbb`" in rows["plain"] and "| not met |" in rows["plain"]
    assert "2,000 B at `bbbbbbbb`" in rows["bytes"]  # the quick run cccccccc never counts
    assert "| not measured |" in rows["gone"]
    assert "### Against the goals" in _section(text, "## Machine `m1`")


def test_report_performance_fills_the_readmes_speed_block(history, tmp_path, capsys):
    from replication.cli import main
    from replication.report.index import END as HEAD_END
    from replication.report.index import START as HEAD_START
    from replication.report.speed_goals import END, START

    readme = tmp_path / "README.md"
    readme.write_text(
        f"# x\r\n{HEAD_START}\r\nold\r\n{HEAD_END}\r\nmid\r\n{START}\r\nold speed\r\n{END}\r\nend\r\n"
    )
    out = tmp_path / "reports"
    out.mkdir()
    args = ["report", "--performance", "--asv-results", str(history), "--output-dir", str(out)]
    assert main([*args, "--readme", str(readme)]) == 0
    text = readme.read_bytes().decode()
    block = text.split(START)[1].split(END)[0]
    assert "old speed" not in block and "| task | asv benchmark | measured | goal | verdict |" in block
    assert "\n" not in text.replace("\r\n", "") and text.endswith("end\r\n")  # CRLF kept
    assert capsys.readouterr().out.count(f"wrote {readme}") == 1
    # a README with the headline block only: --performance leaves it to the headline
    readme.write_text(f"{HEAD_START}\nold\n{HEAD_END}\n")
    assert main([*args, "--readme", str(readme)]) == 0
    assert START not in readme.read_text() and "old" not in readme.read_text()


def test_a_reading_that_says_less_or_is_older_never_replaces_an_archived_one(history, tmp_path):
    """A stale .asv/results (an older reading), a --quick re-run or a failed re-run of a measured
    commit must not erase its measurement from the archive, the only committed copy."""
    out = tmp_path / "out"
    render_performance(history, out)  # aaaaaaaa: b.time_plain 1 ms ±10 %, measured at t0

    def rerun(name, row):
        return write_results(tmp_path / name, [("aaaaaaaa11", 1, {"b.time_plain": row})])

    older = timing([9e-3], quartiles=[(8e-3, 1e-2)])
    older[3] -= 86_400_000  # started a day before the archived reading
    quick = timing([7e-3], repeat=1, ci=[(-math.inf, math.inf)])
    failed = [None, [], "v1", 1_700_000_000_000 + 5, 0.1]
    for name, row in (("older", older), ("quick", quick), ("failed", failed)):
        text = render_performance(rerun(name, row), out).read_text(encoding="utf-8")
        assert "| – | 1 ms ±10 % | 3 ms (no spread recorded) |" in _section(text, "### `b.time_plain`"), name
    newer = timing([2e-3], quartiles=[(1.9e-3, 2.1e-3)])
    newer[3] += 86_400_000
    text = render_performance(rerun("newer", newer), out).read_text(encoding="utf-8")
    assert "| – | 2 ms ±5 % | 3 ms (no spread recorded) |" in _section(text, "### `b.time_plain`")


def test_the_recovered_note_names_only_what_the_page_shows(history, tmp_path):
    """A commit measured again by asv is not called recovered; one partly measured again is
    named for the rest; commits outside the page's window are not named."""
    from replication.report.asv_archive import rows_from_page, write_archive

    text = render_performance(history, tmp_path / "out").read_text(encoding="utf-8")
    frame = load_asv_results(history)
    rows = rows_from_page(text, BENCHMARKS, dict(zip(frame.commit, frame.date)))
    page = tmp_path / "page"
    (page / "data").mkdir(parents=True)
    write_archive(rows, page / "data" / "performance_asv.csv")
    # asv measures bbbbbbbb's b.T.time_adt again: bbbbbbbb is now only partly recovered
    again = write_results(tmp_path / "again", [("bbbbbbbb22", 2, {"b.T.time_adt": timing([1e-4, 2e-3])})])
    text = render_performance(again, page).read_text(encoding="utf-8")
    assert "all values of `aaaaaaaa` and the values of `bbbbbbbb` that asv has not measured again" in text
    text = render_performance(None, page, commits=1, compare=("bbbbbbbb", "bbbbbbbb")).read_text(
        encoding="utf-8"
    )
    assert "`aaaaaaaa`" not in text.split("### Against the goals")[0]  # outside the window of one commit


def test_a_failed_newest_reading_shows_in_the_goals_table(history, tmp_path, monkeypatch):
    from replication.report import speed_goals

    monkeypatch.setattr(
        speed_goals, "GOALS", (speed_goals.Goal("plain", "b.time_plain", "", "<= 2 ms", 2e-3),)
    )
    out = tmp_path / "out"
    render_performance(history, out)
    broke = write_results(tmp_path / "broke", [("dddddddd44", 4, {"b.time_plain": [None, [], "v1", 1, 0.1]})])
    text = render_performance(broke, out).read_text(encoding="utf-8")
    goals = text.split("### Against the goals", 1)[1].split("\n### ", 1)[0]
    assert "| failed at `dddddddd` (2023-11-18) | <= 2 ms | failed |" in goals


def test_report_performance_writes_data_only_when_it_merges_asv_results(history, tmp_path, monkeypatch):
    """data/ may sit on a read-only share: drawing the page from the archive alone writes
    nothing there, so only a merge of asv's results asks for it to be writable."""
    from replication.cli import main
    from replication.io import paths

    out = tmp_path / "reports"
    out.mkdir()
    checked = []
    real = paths.check_report_dir
    monkeypatch.setattr(
        paths, "check_report_dir", lambda p, what, subdirs: checked.append(subdirs) or real(p, what, subdirs)
    )
    monkeypatch.chdir(tmp_path)  # no .asv/results here
    assert main(["report", "--performance", "--asv-results", str(history), "--output-dir", str(out)]) == 0
    archive = (out / "data" / "performance_asv.csv").read_bytes()
    assert main(["report", "--performance", "--output-dir", str(out)]) == 0
    assert checked == [("figures", "data"), ("figures",)]
    assert (out / "data" / "performance_asv.csv").read_bytes() == archive


def test_a_run_of_some_benchmarks_on_a_new_commit_hides_no_other_benchmark_s_history(tmp_path):
    """Each benchmark's table shows its own most recent commits: measuring one benchmark on
    three new commits took every other benchmark's table off a five-commit page (asv's whole
    suite had last run on an older commit)."""
    full = {
        "b.T.time_adt": timing([1e-4, 1e-3]),
        "b.time_plain": timing([1e-3]),
        "b.track_bytes": [[1000], [], "v1"],
    }
    runs = [(f"{k}{k}{k}{k}{k}{k}{k}{k}00", int(k), full) for k in "12"]
    runs += [(f"{k}{k}{k}{k}{k}{k}{k}{k}00", 2 + n, {"b.track_bytes": [[1000 + n], [], "v1"]})
             for n, k in enumerate("abc", 1)]  # fmt: skip
    results = write_results(tmp_path, runs)
    for commits, plain_heads, bytes_heads in (
        (5, "11111111 22222222", "11111111 22222222 aaaaaaaa bbbbbbbb cccccccc"),
        (3, "11111111 22222222", "aaaaaaaa bbbbbbbb cccccccc"),  # the old page: the other tables gone
        (2, "11111111 22222222", "bbbbbbbb cccccccc"),
    ):
        text = render_performance(results, tmp_path / f"out{commits}", commits=commits).read_text()
        measured = _section(text, "## Machine `m1`")
        for name, heads in (("b.time_plain", plain_heads), ("b.T.time_adt", plain_heads),
                            ("b.track_bytes", bytes_heads)):  # fmt: skip
            head = measured.split(f"### `{name}`", 1)[1].split("\n\n", 2)[1].splitlines()[0]
            assert re.findall(r"`(\w{8})` \(", head) == heads.split(), (name, commits, head)
    assert "1,003 B" in measured and "1,000 B" not in measured.split("### `b.track_bytes`")[1].split("###")[0]
