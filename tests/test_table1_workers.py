"""Table 1's untimed work on worker processes: the same results as in one process."""

from __future__ import annotations

import dataclasses
from functools import partial

import pandas as pd
import pytest

from replication.casestudy.evaluate import executor
from replication.errors import InputError
from replication.experiments import table1
from replication.experiments.storage import storage_monte_carlo
from replication.experiments.table1 import Table1Config, continuous_cloud, run_table1, table1_cloud
from replication.kernels import release_threads
from workerfaults import broken_cloud

CONFIG = dataclasses.replace(Table1Config.quick_config(), ns=(9, 45), mc_seeds=3)
#: Columns of the Monte Carlo data that are timings (they differ from run to run).
TIMINGS = {"adt_s", "nurbs_geomdl_s", "nurbs_fast_s", "time_ratio_geomdl", "time_ratio_fast",
           "time_difference_geomdl"}  # fmt: skip


def _recorded(events, name, real):
    """``real``, appending ``name`` to ``events`` at each call."""

    def call(*args, **kwargs):
        events.append(name)
        return real(*args, **kwargs)

    return call


def _no_progress(items, description, total):
    return items


class _Finished:
    """A progress hook that records the bars whose loop ran to its end (a bar the caller never
    asked for its last item stopped at 19/20 instead of saying "done")."""

    def __init__(self):
        self.started, self.finished = [], []

    def __call__(self, items, description, total):
        self.started.append(description)
        yield from items
        self.finished.append(description)


@pytest.mark.filterwarnings(
    "ignore::replication.errors.DuplicatePointsWarning"
)  # lattice merges (run_table1 too)
def test_monte_carlo_statistics_on_workers_match_one_process():
    bars = _Finished()
    here = table1._monte_carlo(CONFIG, bars, 1)
    there = table1._monte_carlo(CONFIG, _no_progress, 2)
    assert bars.finished == bars.started and len(bars.started) == 2
    assert len(here) == len(CONFIG.ns) * CONFIG.mc_seeds
    assert list(here.columns) == list(there.columns)
    assert {"a_t_p", "b_wilcoxon_p", "a_equivalent", "b_rms_pct"} <= set(here.columns)
    kept = [c for c in here.columns if c not in TIMINGS]
    pd.testing.assert_frame_equal(here[kept], there[kept])
    # each row holds the statistics of its own cloud, not of a neighbour's
    one = here[(here["n"] == 45) & (here["replicate"] == 2)].iloc[0]
    row = table1.monte_carlo_statistics(CONFIG, (45, 2))
    assert row["a_t_p"] == one["a_t_p"] and row["b_rms_pct"] == one["b_rms_pct"]


def test_storage_sizes_on_workers_match_one_process():
    kinds = {"lattice": partial(table1_cloud, CONFIG), "continuous": partial(continuous_cloud, CONFIG)}
    here = storage_monte_carlo(CONFIG.ns, 3, kinds)
    release_threads()
    with executor("process", workers=2) as pool:
        there = storage_monte_carlo(CONFIG.ns, 3, kinds, executor=pool, chunksize=4)
    assert len(here) == len(CONFIG.ns) * 3 * 2
    pd.testing.assert_frame_equal(here, there)


def test_scale_file_sizes_on_workers_match_one_process(tmp_path):
    config = dataclasses.replace(CONFIG, scale_ns=(1_000, 3_000, 10_000), scale_max_files=3_000,
                                 scale_max_fast=1_000, scale_repeats=1)  # fmt: skip
    bars = _Finished()
    here = table1._scale_sweep(config, bars, tmp_path, 1)
    there = table1._scale_sweep(config, _no_progress, tmp_path, 2)
    assert bars.finished == bars.started and "scale sweep: file sizes" in bars.finished
    files = here[here["bytes"].notna()]
    assert list(zip(files["n"], files["method"])) == [
        (1_000, "ADT file (.vtp)"), (1_000, "ADT file (.vtk)"), (1_000, "NURBS file (.smesh)"),
        (3_000, "ADT file (.vtp)"), (3_000, "ADT file (.vtk)"),
    ]  # fmt: skip
    assert list(here.columns) == list(there.columns) and list(here["method"]) == list(there["method"])
    pd.testing.assert_frame_equal(files, there[there["bytes"].notna()])
    assert list(tmp_path.iterdir()) == []  # the .vtp files measured are removed
    with pytest.raises(ValueError, match="unknown scale-sweep file"):
        table1.scale_file_size(config, str(tmp_path), (1_000, "PLY"))


def test_the_whole_experiment_on_workers_matches_one_process(monkeypatch):
    """run_table1 end to end on a tiny configuration: every table but the timings is equal.
    With workers, a pool opens after each stage of timings, never before: the Monte Carlo
    statistics and the storage comparison (no timing between them) share one."""
    config = dataclasses.replace(CONFIG, repeats=1, warmup=0, mc_seeds=2, scale_ns=(1_000, 3_000),
                                 scale_repeats=1, scale_max_files=3_000)  # fmt: skip
    one = run_table1(config, workers=1)
    events = []
    for name in ("_worker_pool", "interleaved", "storage_monte_carlo"):
        monkeypatch.setattr(table1, name, _recorded(events, name, getattr(table1, name)))
    two = run_table1(config, workers=2)
    stages = [name for k, name in enumerate(events) if name != "interleaved" or events[k - 1 : k] != [name]]
    # single sample and Monte Carlo timings, a pool for the statistics and the storage, the
    # scale sweep's timings, a pool for its file sizes
    assert stages == ["interleaved", "_worker_pool", "storage_monte_carlo", "interleaved", "_worker_pool"]
    assert (one.provenance["workers"], two.provenance["workers"]) == (1, 2)
    for name in ("sizes", "clouds", "stats", "storage_raw", "storage"):
        pd.testing.assert_frame_equal(getattr(one, name), getattr(two, name))
    kept = [c for c in one.montecarlo_raw.columns if c not in TIMINGS]
    pd.testing.assert_frame_equal(one.montecarlo_raw[kept], two.montecarlo_raw[kept])
    files = [frame[frame["bytes"].notna()] for frame in (one.scale_raw, two.scale_raw)]
    pd.testing.assert_frame_equal(*files)
    untimed = ~one.claims["claim"].str.contains("time|faster")  # the timing claims may differ
    assert untimed.sum() >= 10
    pd.testing.assert_frame_equal(one.claims[untimed], two.claims[untimed])


def test_a_failing_cloud_fails_the_run_with_its_own_error():
    kinds = {"lattice": partial(broken_cloud, "bad input")}
    with pytest.raises(ValueError, match="bad input"):
        storage_monte_carlo((9,), 2, kinds)
    release_threads()
    with executor("process", workers=2) as pool, pytest.raises(ValueError, match="bad input"):
        storage_monte_carlo((9,), 2, kinds, executor=pool)


def test_one_worker_stops_at_the_first_interrupt(monkeypatch):
    """With one worker the untimed work is a plain loop: Ctrl-C stops it at once (an executor's
    map would first run every job, the interrupt kept in a future)."""
    calls = []

    def interrupted(config, job):
        calls.append(job)
        raise KeyboardInterrupt

    monkeypatch.setattr(table1, "monte_carlo_statistics", interrupted)
    monkeypatch.setattr(table1, "_monte_carlo_timings", lambda config, progress: [
        {"n": n, "replicate": k} for k in (1, 2, 3) for n in config.ns])  # fmt: skip
    with pytest.raises(KeyboardInterrupt):
        table1._monte_carlo(CONFIG, _no_progress, 1)
    assert len(calls) == 1


@pytest.mark.parametrize(
    "jobs, workers, chunk", [(20, 2, 3), (1000, 2, 25), (1, 2, 1), (40, 1, 10), (0, 2, 1)]
)
def test_chunks_leave_every_worker_work(jobs, workers, chunk):
    assert table1._chunk(jobs, workers, 25) == chunk


@pytest.mark.parametrize("workers", [0, -1, 1.5, True, "2"])
def test_run_table1_rejects_bad_worker_counts(workers):
    with pytest.raises(InputError, match="workers"):
        run_table1(CONFIG, workers=workers)


def test_workers_option_of_the_commands(capsys):
    from replication.cli import main

    for command in ("table1", "reproduce"):
        with pytest.raises(SystemExit) as exc:
            main([command, "--workers", "0"])
        assert exc.value.code == 2
        assert "--workers" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["table1", "reproduce", "casestudy", "sph", "validate-jet"])
def test_a_worker_count_beyond_the_machine_is_refused_before_anything_starts(
    command, capsys, tmp_path, monkeypatch
):
    """``casestudy --workers 100000`` started worker processes until memory ran out."""
    from replication.cli import main
    from replication.cli.common import WORKERS_PER_CPU, usable_cpus

    monkeypatch.chdir(tmp_path)
    limit = WORKERS_PER_CPU * usable_cpus()
    with pytest.raises(SystemExit) as exc:
        main([command, "--workers", str(limit + 1)])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.count("\n") == 1, err
    assert f"at most {limit} worker processes" in err and f"got {limit + 1}" in err
    assert list(tmp_path.iterdir()) == []  # no run or output directory made
