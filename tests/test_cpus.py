"""Default worker counts follow the CPUs this process may use, not the machine's count."""

from __future__ import annotations

import argparse
import os

import pytest

from replication.cpus import usable_cpus


@pytest.fixture
def one_of_64(monkeypatch):
    """A process allowed 1 of a machine's 64 CPUs (a container, or ``taskset -c 0``)."""
    monkeypatch.setattr(os, "cpu_count", lambda: 64)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0}, raising=False)


def test_usable_cpus_counts_the_affinity_not_the_machine(one_of_64):
    assert usable_cpus() == 1


@pytest.mark.skipif(not hasattr(os, "sched_getaffinity"), reason="the system has no affinity call")
def test_usable_cpus_is_this_process_affinity():
    assert usable_cpus() == len(os.sched_getaffinity(0)) >= 1


def test_usable_cpus_falls_back_to_the_machine(monkeypatch):
    monkeypatch.setattr(os, "cpu_count", lambda: 6)
    monkeypatch.delattr(os, "sched_getaffinity", raising=False)
    assert usable_cpus() == 6
    monkeypatch.setattr(os, "cpu_count", lambda: None)  # the machine's count unknown
    assert usable_cpus() == 1


def test_usable_cpus_survives_a_refused_affinity_call(monkeypatch):
    def refused(pid):
        raise OSError("not permitted")

    monkeypatch.setattr(os, "cpu_count", lambda: 3)
    monkeypatch.setattr(os, "sched_getaffinity", refused, raising=False)
    assert usable_cpus() == 3


def test_the_automatic_executor_is_serial_on_one_usable_cpu(one_of_64):
    """It used to start 64 worker processes, all on the one core."""
    from replication.casestudy.evaluate import SerialExecutor, executor

    with executor("auto") as pool:
        assert isinstance(pool, SerialExecutor)


def test_an_executor_without_a_size_counts_the_usable_cpus(one_of_64):
    from replication.casestudy.dispatch import worker_count

    assert worker_count(object()) == 1


def test_casestudy_default_workers_are_the_usable_cpus(one_of_64):
    from replication.cli.casestudy import _workers

    args = argparse.Namespace(executor="auto", scheduler=None, workers=None)
    assert _workers(args) == 1
    assert _workers(argparse.Namespace(executor="auto", scheduler=None, workers=3)) == 3


def test_the_workers_option_is_capped_by_the_usable_cpus(one_of_64):
    from replication.cli.common import WORKERS_PER_CPU, worker_count

    assert worker_count(str(WORKERS_PER_CPU)) == WORKERS_PER_CPU
    with pytest.raises(argparse.ArgumentTypeError, match=f"at most {WORKERS_PER_CPU} worker processes"):
        worker_count(str(WORKERS_PER_CPU + 1))
