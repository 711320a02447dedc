"""The asv suite imports, runs a quick subset, and its results render as performance.md."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from replication.cli import main

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.slow


def _asv(*args, home, config=None, timeout=600):
    env = dict(os.environ, HOME=str(home))  # asv keeps its machine file in $HOME
    cmd = [sys.executable, "-m", "asv", *args]
    if config:
        cmd += ["--config", str(config)]
    return subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def asv_results(tmp_path_factory):
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("asv needs the git checkout of the project")
    tmp = tmp_path_factory.mktemp("asv")
    conf = json.loads((ROOT / "asv.conf.json").read_text())
    conf.update(results_dir=str(tmp / "results"), html_dir=str(tmp / "html"), env_dir=str(tmp / "env"))
    config = tmp / "asv.conf.json"
    config.write_text(json.dumps(conf))
    # benchmark_dir and repo are relative to the config file: point them at the project
    conf.update(repo=str(ROOT), benchmark_dir=str(ROOT / "benchmarks"))
    # asv resolves its configured branches even with --python=same (where no range may be
    # given): a clone need not have a branch named main, or any branch (a detached HEAD)
    conf.update(branches=["HEAD"])
    config.write_text(json.dumps(conf))
    head = subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout
    machine = _asv("machine", "--yes", "--machine", "pytest-machine", home=tmp, config=config)
    assert machine.returncode == 0, machine.stderr
    run = _asv(
        "run", "--python=same", "--quick", "--machine", "pytest-machine", "--set-commit-hash", head.strip(),
        "--bench", r"ADTPaperSizes\.(time_adt|track_adt_vtk_bytes)\(200, 'sweephull'\)", "--show-stderr",
        home=tmp, config=config,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    return tmp / "results", run.stdout


def test_asv_check_passes(tmp_path):
    result = _asv("check", "--python=same", home=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "No problems found" in result.stdout


def test_quick_asv_run_records_results(asv_results):
    results, stdout = asv_results
    assert "time_adt" in stdout and "failed" not in stdout.lower()
    assert (results / "benchmarks.json").is_file()
    assert list((results / "pytest-machine").glob("*.json"))


def test_performance_report_from_asv_results(asv_results, tmp_path, capsys, monkeypatch):
    results, _ = asv_results
    code = main(["report", "--performance", "--asv-results", str(results), "--output-dir", str(tmp_path)])
    assert code == 0
    assert not (tmp_path / "table1.md").exists()  # no Table 1 data there: only performance + index
    assert "[Performance history](performance.md)" in (tmp_path / "index.md").read_text()
    text = (tmp_path / "performance.md").read_text()
    assert "## Machine `pytest-machine`" in text
    assert "### `benchmark_adt.ADTPaperSizes.time_adt`" in text
    assert "n=200, backend=sweephull" in text
    assert "### `benchmark_adt.ADTPaperSizes.track_adt_vtk_bytes`" in text and " B |" in text
    # a --quick run is one sample per benchmark: kept apart from measurements, and marked
    quick = text.split("## Single-sample runs (`asv run --quick`) on machine `pytest-machine`", 1)[1]
    assert "(1 sample)" in quick and "No measured commits." in text
    # a checkout without asv's files (the default .asv/results absent) redraws it from the archive
    assert (tmp_path / "data" / "performance_asv.csv").is_file()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert main(["report", "--performance", "--output-dir", str(tmp_path)]) == 0
    assert (tmp_path / "performance.md").read_text() == text
    # asked for by name, a missing results directory is an error, and the page stays
    capsys.readouterr()
    code = main(["report", "--performance", "--asv-results", "nowhere", "--output-dir", str(tmp_path)])
    assert code != 0 and "no asv results in nowhere" in capsys.readouterr().err
    assert (tmp_path / "performance.md").read_text() == text


def test_the_side_by_side_peak_is_the_child_s_own_however_large_the_caller(monkeypatch):
    """On Linux a child's ru_maxrss starts at its parent's peak (it survives fork and exec):
    a caller holding a 1e7-point cloud made the 1e7 row read the caller's memory."""
    import numpy as np

    from replication.surfaces import random_cloud

    monkeypatch.syspath_prepend(str(ROOT))
    from benchmarks.issue14 import adt_peak

    ballast = np.ones(2**30 // 16)  # 0.5 GiB, every page touched
    peak = adt_peak(random_cloud(1000, rng=np.random.default_rng(3)))
    assert ballast.sum() == ballast.size
    assert 0 < peak["before_gib"] <= peak["peak_gib"] < 0.45, peak
    assert peak["cloud_gib"] == 1000 * 3 * 8 / 2**30


def test_case_study_speed_ups_are_over_one_core_whichever_configurations_run(monkeypatch):
    """``--workers 1`` runs its kernels on numba's threads (both cores): the reference of the
    speed-ups is one core, run first whatever ``--only`` asks for, and one core only."""
    monkeypatch.syspath_prepend(str(ROOT))
    from benchmarks.casestudy_speedup import CONFIGS, chosen, summarize

    first = next(iter(CONFIGS))
    assert dict(CONFIGS[first].env) == {"NUMBA_NUM_THREADS": "1"} and CONFIGS[first].options == (
        "--workers",
        "1",
    )
    assert all("NUMBA_NUM_THREADS" not in dict(c.env) for name, c in CONFIGS.items() if name != first)
    assert chosen(None) == list(CONFIGS)
    assert chosen(["dask", "pool"]) == [first, "pool", "dask"]
    assert chosen([first]) == [first]
    runs = {
        "one core": [
            {"command_s": 10.0, "ga_s": 8.0, "cpu_s": 10.0},
            {"command_s": 12.0, "ga_s": 8.0, "cpu_s": 12.0},
        ],
        "pool": [
            {"command_s": 5.0, "ga_s": 4.0, "cpu_s": 11.0},
            {"command_s": 8.0, "ga_s": 2.0, "cpu_s": 12.0},
        ],
    }
    text = summarize(runs, [2.0, 1.9])
    row = next(line for line in text.splitlines() if line.startswith("| pool |"))
    # medians 11 / 6.5 = 1.69x; per round 2.0 and 1.5; GA: 8 / 3 = 2.67x, per round 2 and 4
    assert "| 1.69x; 1.75 [1.50, 2.00] | 2.67x; 3.00 [2.00, 4.00] |" in row
    assert "Speed-ups over the first row, one core." in text
    # everything but the GA: median of 2 and 4 = 3 s; bound (3 + 8) / (3 + 4) = 1.57x
    assert "bound the command at 1.57x over the first row" in text


def test_median_ratio_takes_the_clock_it_is_given():
    """The user-CPU ratio of ADTGrowth uses median_ratio's clock: a fake clock that each call
    advances by a known amount gives the known ratio, and the median of uneven pairs."""
    from benchmarks.benchmark_adt import _user_cpu, median_ratio

    now = [0.0]
    steps = iter([3.0, 1.0, 30.0, 1.0, 5.0, 1.0])  # pairs 3, 30 and 5: median 5

    def work():
        now[0] += next(steps)

    assert median_ratio(work, work, repeats=3, clock=lambda: now[0]) == 5.0
    import time

    before, start = _user_cpu(), time.perf_counter()
    while _user_cpu() == before and time.perf_counter() - start < 10:  # (accounted by ticks: work on)
        sum(i * i for i in range(100_000))
    assert _user_cpu() > before
