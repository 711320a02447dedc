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

CONFIG = dataclasses.replace(Table1Config.quick_config(), ns=(9, 45), mc_seeds=3)


def _no_progress(items, description, total):
    return items


def _two_workers():
    release_threads()  # forked workers, as in the command
    return executor("process", workers=2)


@pytest.fixture(scope="module")
def pool():
    with _two_workers() as p:
        yield p


@pytest.mark.filterwarnings("ignore::replication.errors.DuplicatePointsWarning")  # lattice merges (run_table1 too)
def test_monte_carlo_statistics_on_workers_match_one_process():
    timing_columns = {"adt_s", "nurbs_geomdl_s", "nurbs_fast_s", "time_ratio_geomdl", "time_ratio_fast",
                      "time_difference_geomdl"}  # fmt: skip
    here = table1._monte_carlo(CONFIG, _no_progress, lambda: executor("serial"))
    there = table1._monte_carlo(CONFIG, _no_progress, _two_workers)
    assert len(here) == len(CONFIG.ns) * CONFIG.mc_seeds
    assert list(here.columns) == list(there.columns)
    assert {"a_t_p", "b_wilcoxon_p", "a_equivalent", "b_rms_pct"} <= set(here.columns)
    kept = [c for c in here.columns if c not in timing_columns]
    pd.testing.assert_frame_equal(here[kept], there[kept])
    # each row holds the statistics of its own cloud, not of a neighbour's
    one = here[(here["n"] == 45) & (here["replicate"] == 2)].iloc[0]
    row = table1.monte_carlo_statistics(CONFIG, (45, 2))
    assert row["a_t_p"] == one["a_t_p"] and row["b_rms_pct"] == one["b_rms_pct"]


def test_storage_sizes_on_workers_match_one_process(pool):
    kinds = {"lattice": partial(table1_cloud, CONFIG), "continuous": partial(continuous_cloud, CONFIG)}
    here = storage_monte_carlo(CONFIG.ns, 3, kinds)
    there = storage_monte_carlo(CONFIG.ns, 3, kinds, executor=pool, chunksize=4)
    assert len(here) == len(CONFIG.ns) * 3 * 2
    pd.testing.assert_frame_equal(here, there)


def test_scale_file_sizes_on_workers_match_one_process(tmp_path):
    config = dataclasses.replace(CONFIG, scale_ns=(1_000, 3_000, 10_000), scale_max_files=3_000,
                                 scale_max_fast=1_000, scale_repeats=1)  # fmt: skip
    here = table1._scale_sweep(config, _no_progress, tmp_path, lambda: executor("serial"))
    there = table1._scale_sweep(config, _no_progress, tmp_path, _two_workers)
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


def test_a_failing_cloud_fails_the_run_with_its_own_error(pool):
    kinds = {"lattice": partial(_broken_cloud, "bad input")}
    with pytest.raises(ValueError, match="bad input"):
        storage_monte_carlo((9,), 2, kinds, executor=pool)


def _broken_cloud(message, n, k):
    raise ValueError(message)


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
