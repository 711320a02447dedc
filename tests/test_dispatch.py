"""Batched dispatch of fitness evaluations: task sizes, order, failures, broken executors, one pool."""

import concurrent.futures as cf
import contextlib
import functools
import json
import math
import os
import sys
import time

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from replication.casestudy.dispatch import Batching, Dispatcher, Outcome, evaluate_chunk, worker_count
from replication.casestudy.evaluate import Fitness, SerialExecutor, evaluate_batch, executor
from replication.casestudy.ga import GAConfig
from replication.casestudy.runner import run_ga
from replication.errors import InputError
from workerfaults import DiesOnceWhenArmed, assert_no_process_left

SMALL = GAConfig(population=8, generations=4, elites=2, seed=7)
POOLED = GAConfig(population=16, generations=3, elites=2, seed=7)


def pure(genome):
    """A cheap pure fitness with failures: raises on multiples of 7, NaN on multiples of 11."""
    total = int(np.sum(genome))
    if total % 7 == 0:
        raise ValueError(f"bad genome {total}")
    if total % 11 == 0:
        return float("nan")
    return math.sqrt(total) / 3.0


def expected(genomes):
    return [Outcome(*evaluate_chunk(pure, [g])[0][:2]) for g in genomes]


@contextlib.contextmanager
def threads(workers=2):
    with cf.ThreadPoolExecutor(max_workers=workers) as pool:
        yield pool


# ---- the batching rule ----------------------------------------------------------------------


def test_unknown_cost_means_one_evaluation_per_task():
    assert Batching().chunk(48, 2, None) == 1


def test_slow_evaluations_are_one_task_each():
    """An SPH simulation (minutes) never shares a task, however much work is left."""
    assert Batching().chunk(2400, 64, 107.53) == 1
    assert Batching().chunk(48, 2, 0.2) == 1


def test_fast_evaluations_are_batched_and_balanced():
    batching = Batching(task_seconds=0.1, tasks_per_worker=2)
    assert batching.chunk(44, 2, 0.003) == 11  # ceil(44 / 4): balance, under the 33-evaluation cap
    assert batching.chunk(400, 2, 0.003) == 33  # the cap: 0.1 s of 3 ms evaluations
    assert batching.chunk(3, 2, 0.003) == 1  # the end of a generation: single evaluations
    assert batching.chunk(0, 2, 0.003) == 0


@given(
    remaining=st.integers(1, 10_000),
    workers=st.integers(1, 128),
    cost=st.one_of(st.none(), st.floats(0, 1e4)),
)
def test_chunk_is_at_least_one_and_at_most_what_is_left(remaining, workers, cost):
    size = Batching().chunk(remaining, workers, cost)
    assert 1 <= size <= remaining
    if cost is not None and cost * size > Batching().task_seconds:
        assert size == 1  # only a single evaluation may exceed a task's budget


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"task_seconds": 0}, "task_seconds"), ({"tasks_per_worker": 0}, "tasks_per_worker"),
     ({"tasks_per_worker": True}, "tasks_per_worker")],
)  # fmt: skip
def test_batching_refuses_bad_settings(kwargs, match):
    with pytest.raises(InputError, match=match):
        Batching(**kwargs)


def test_worker_count_of_the_executors():
    assert worker_count(SerialExecutor()) == 1
    with threads(3) as pool:
        assert worker_count(pool) == 3


# ---- dispatching ----------------------------------------------------------------------------


@given(st.lists(st.lists(st.integers(0, 50), min_size=3, max_size=3), max_size=60), st.integers(1, 4))
def test_outcomes_come_back_in_order_whatever_the_batching(genomes, workers):
    genomes = [np.asarray(g) for g in genomes]
    with threads(workers) as pool:
        dispatcher = Dispatcher(lambda: contextlib.nullcontext(pool), batching=Batching(task_seconds=1e-3))
        assert dispatcher.evaluate(pure, genomes) == expected(genomes)
        assert dispatcher.evaluate(pure, genomes[::-1]) == expected(genomes[::-1])


def test_fast_evaluations_share_tasks():
    genomes = [np.array([k, 1, 2]) for k in range(200)]
    with threads() as pool:
        dispatcher = Dispatcher(lambda: contextlib.nullcontext(pool))
        assert dispatcher.evaluate(pure, genomes) == expected(genomes)
    assert dispatcher.cost is not None and dispatcher.measured == 200
    assert dispatcher.tasks < 50  # microsecond evaluations: a few large tasks


def slow(genome):
    time.sleep(0.03)
    return float(genome[0])


def test_slow_evaluations_get_a_task_each():
    genomes = [np.array([k]) for k in range(8)]
    with threads() as pool:
        dispatcher = Dispatcher(lambda: contextlib.nullcontext(pool), batching=Batching(task_seconds=0.01))
        assert [o.value for o in dispatcher.evaluate(slow, genomes)] == list(range(8))
    assert dispatcher.tasks == 8 and dispatcher.cost >= 0.03


class Poisoned(cf.ThreadPoolExecutor):
    """A task holding genome 12 fails as a whole (as dask's KilledWorker does after a worker
    died three times on it)."""

    def submit(self, fn, /, *args, **kwargs):
        if fn is evaluate_chunk and any(int(g[0]) == 12 for g in args[1]):
            future = cf.Future()
            future.set_exception(RuntimeError("worker killed while running the task"))
            return future
        return super().submit(fn, *args, **kwargs)


def test_a_task_failing_as_a_whole_costs_only_the_evaluation_at_fault():
    genomes = [np.array([k, 0, 1]) for k in range(40)]
    with Poisoned(max_workers=2) as pool:
        dispatcher = Dispatcher(lambda: contextlib.nullcontext(pool))
        dispatcher.cost = 1e-5  # known to be fast: tasks of several evaluations from the start
        outcomes = dispatcher.evaluate(pure, genomes)
    assert outcomes[12] == Outcome(None, "RuntimeError: worker killed while running the task")
    others = [k for k in range(40) if k != 12]
    assert [outcomes[k] for k in others] == [expected(genomes)[k] for k in others]


class BreaksAfter(cf.ThreadPoolExecutor):
    """Breaks like a process pool whose worker died: after ``n`` tasks, the tasks in flight fail
    with BrokenExecutor and so does every later submission."""

    def __init__(self, n, on_submit):
        super().__init__(max_workers=2)
        self.n, self.on_submit = n, on_submit

    def submit(self, fn, /, *args, **kwargs):
        self.n -= 1
        if self.n == 0 and self.on_submit:
            raise cf.BrokenExecutor("a worker died")
        if self.n <= 0:
            future = cf.Future()
            future.set_exception(cf.BrokenExecutor("a worker died"))
            return future
        return super().submit(fn, *args, **kwargs)


@pytest.mark.parametrize("on_submit", [True, False])
def test_a_broken_executor_is_replaced_and_only_lost_work_runs_again(on_submit):
    made = []

    @contextlib.contextmanager
    def factory():
        pool = BreaksAfter(5, on_submit) if not made else cf.ThreadPoolExecutor(max_workers=2)
        made.append(pool)
        with pool:
            yield pool

    genomes = [np.array([k, 2, 3]) for k in range(60)]
    dispatcher = Dispatcher(factory)
    dispatcher.cost = 1e-5
    with dispatcher:
        assert dispatcher.evaluate(pure, genomes) == expected(genomes)
    assert len(made) == 2 and dispatcher.replaced == 1


def test_an_executor_breaking_every_time_is_an_error():
    @contextlib.contextmanager
    def factory():
        with BreaksAfter(1, True) as pool:
            yield pool

    with Dispatcher(factory, retries=2) as dispatcher, pytest.raises(cf.BrokenExecutor):
        dispatcher.evaluate(pure, [np.array([k, 2, 3]) for k in range(5)])
    assert dispatcher.replaced == 3


def test_interrupt_stops_a_batch_and_cancels_what_is_pending():
    calls = []

    def stop_after_two():
        calls.append(1)
        return len(calls) > 2

    with pytest.raises(KeyboardInterrupt):
        evaluate_batch(
            SerialExecutor(), pure, [np.array([k, 1, 1]) for k in range(10)], interrupted=stop_after_two
        )


class CountingFactory:
    """An executor factory that counts the executors it opened and closed."""

    def __init__(self):
        self.opened = self.closed = 0

    @contextlib.contextmanager
    def __call__(self):
        self.opened += 1
        try:
            yield SerialExecutor()
        finally:
            self.closed += 1


def test_one_executor_for_every_run_of_a_command(tmp_path):
    from replication.experiments.casestudy import run_casestudy

    factory = CountingFactory()
    config = GAConfig(population=6, generations=2, runs=3, elites=1, seed=5)
    results = run_casestudy(config, run_dir=tmp_path, pool_factory=factory, timing_repeats=1)
    assert len(results.runs) == 3
    assert (factory.opened, factory.closed) == (1, 1)


def test_run_calls_returns_every_result_in_order_and_raises_a_failing_call():
    calls = [functools.partial(pow, k, 2) for k in range(7)]
    for factory in (lambda: contextlib.nullcontext(SerialExecutor()), threads):
        with Dispatcher(factory) as dispatcher:
            assert dispatcher.run_calls(calls) == [k * k for k in range(7)]
            assert dispatcher.run_calls([]) == []
            with pytest.raises(ZeroDivisionError):
                dispatcher.run_calls([functools.partial(divmod, 1, 0)])


def test_one_executor_serves_the_reference_work_and_every_run(tmp_path):
    """The reference shapes and the timing go to the GA's executor, opened once for all of it."""
    from replication.experiments.casestudy import run_casestudy

    factory = CountingFactory()
    config = GAConfig(population=6, generations=2, runs=2, elites=1, seed=5)
    results = run_casestudy(config, run_dir=tmp_path, pool_factory=factory, timing_repeats=3)
    assert (factory.opened, factory.closed) == (1, 1)
    assert list(results.shapes["shape"]) == ["flat plate", "pelton bucket"]
    assert results.provenance["evaluation_timing"] == {"repeats": 3, "workers_at_once": 1}


def test_run_ga_needs_exactly_one_executor_source(tmp_path):
    with pytest.raises(TypeError, match="exactly one"):
        run_ga(SMALL, 0, run_dir=tmp_path)


# ---- real worker processes --------------------------------------------------------------------


def _state(run):
    state = run.state()
    state.pop("seconds")
    return json.dumps(state, sort_keys=True)


@pytest.mark.slow
def test_process_pool_batches_and_survives_a_dead_worker_bit_identically(tmp_path):
    """Batched on a process pool, a worker killed in generation 2: the pool is replaced, the lost
    evaluations run again, and the run equals the serial one bit for bit."""
    serial = functools.partial(executor, "serial")
    reference = run_ga(POOLED, 0, run_dir=tmp_path / "serial", pool_factory=serial)
    armed, died = tmp_path / "armed", tmp_path / "died"

    def arm(state):
        if state.generation == 1:
            armed.touch()

    with Dispatcher(functools.partial(executor, "process", workers=2)) as dispatcher:
        killed = DiesOnceWhenArmed(Fitness(POOLED), armed, died)
        survived = run_ga(POOLED, 0, run_dir=tmp_path / "pool", dispatcher=dispatcher,
                          fitness=killed, on_generation=arm)  # fmt: skip
    assert died.exists() and dispatcher.replaced == 1
    assert _state(survived) == _state(reference) and survived.failures == []
    assert dispatcher.tasks < survived.evaluations  # several evaluations per task


_RUN = """
import functools, sys
from replication.casestudy.dispatch import Dispatcher
from replication.casestudy.evaluate import executor
from replication.casestudy.ga import GAConfig
from replication.casestudy.runner import run_ga

config = GAConfig(population=6, generations=2, elites=1, seed=3)
with Dispatcher(functools.partial(executor, sys.argv[1], workers=2)) as dispatcher:
    for k in range(2):
        run_ga(config, k, run_dir=sys.argv[2], dispatcher=dispatcher)
print(dispatcher.tasks)
"""


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["process", "dask"])
def test_no_process_is_left_behind(tmp_path, kind, port_8787_taken):
    import subprocess
    import sys

    if kind == "dask":
        pytest.importorskip("dask.distributed")
    process = subprocess.Popen(
        [sys.executable, "-c", _RUN, kind, str(tmp_path / "runs")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    out, err = process.communicate(timeout=300)
    assert process.returncode == 0, err
    assert int(out) > 0 and err == ""  # no warning about leaked resources either
    assert_no_process_left(process.pid)


class TwoWorkersHere(SerialExecutor):
    """Runs tasks here, one after another, but says it has two workers."""

    def worker_count(self):
        return 2


def _square_unless_armed(armed, died, k):
    DiesOnceWhenArmed(lambda v: v * v, armed, died)(k)
    return k * k


@pytest.mark.slow
def test_run_calls_replace_a_broken_pool_and_run_the_lost_calls_again(tmp_path):
    armed, died = tmp_path / "armed", tmp_path / "died"
    armed.touch()
    calls = [functools.partial(_square_unless_armed, str(armed), str(died), k) for k in range(5)]
    with Dispatcher(functools.partial(executor, "process", workers=2)) as dispatcher:
        assert dispatcher.run_calls(calls) == [k * k for k in range(5)]
    assert died.exists() and dispatcher.replaced == 1


def test_reference_work_is_shared_by_the_workers_of_a_pool(tmp_path):
    """With two workers the timing rounds are split in two tasks; the shapes equal the serial ones."""
    from replication.experiments.casestudy import _reference_work

    config = GAConfig(population=6, generations=2, runs=1, elites=1, seed=5)
    with Dispatcher(lambda: contextlib.nullcontext(SerialExecutor())) as serial:
        shapes, evaluation, tasks = _reference_work(config, 4, serial)
    assert tasks == 1
    with Dispatcher(lambda: contextlib.nullcontext(TwoWorkersHere())) as pooled:
        shapes2, evaluation2, tasks2 = _reference_work(config, 5, pooled)
    assert tasks2 == 2
    assert shapes.equals(shapes2)  # forces are pure functions of the shape
    assert list(evaluation2["count"]) == [5, 5, 5]  # every round of both shares is in the summary
    assert list(evaluation2["vtk_bytes"]) == list(evaluation["vtk_bytes"])


# ---- how worker processes start ----------------------------------------------------------------


def test_workers_are_forked_on_linux_when_the_process_runs_one_thread_and_spawned_otherwise():
    import sys
    import threading

    from replication.casestudy.interrupts import quiet_worker_context

    release = threading.Event()
    other = threading.Thread(target=release.wait)
    other.start()
    try:
        assert quiet_worker_context().get_start_method() == "spawn"  # a fork would copy held locks
    finally:
        release.set()
        other.join()
    if threading.active_count() == 1:
        expected = "fork" if sys.platform.startswith("linux") else "spawn"
        assert quiet_worker_context().get_start_method() == expected


def test_released_kernel_threads_let_the_next_pool_fork():
    import sys
    import threading

    from replication.casestudy.interrupts import quiet_worker_context
    from replication.kernels import release_threads
    from replication.surfaces import _threads

    if _threads.threads() < 2:
        pytest.skip("needs 2 kernel threads")
    release_threads()
    before = threading.active_count()  # other tests' threads may still be alive
    assert _threads.run([lambda: 1, lambda: 2, lambda: 3]) == [1, 2, 3]  # starts the pool
    assert threading.active_count() > before and quiet_worker_context().get_start_method() == "spawn"
    release_threads()
    assert threading.active_count() == before
    if before == 1:
        linux = sys.platform.startswith("linux")
        assert quiet_worker_context().get_start_method() == ("fork" if linux else "spawn")
    assert _threads.run([lambda: 4, lambda: 5]) == [4, 5]  # and the pool comes back when needed
    release_threads()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="workers are forked on Linux only")
def test_a_process_pool_stops_the_idle_kernel_threads_so_its_workers_are_forked():
    """A jet force leaves the kernels' pool threads idle (the case study warms its kernels
    so); the GA's process pool must still fork its workers, not spawn them (a second each)."""
    import threading

    from replication.casestudy.jet import surface_force
    from replication.casestudy.shapes import pelton_bucket_surface
    from replication.kernels import release_threads
    from replication.surfaces import _threads

    if _threads.threads() < 2:
        pytest.skip("needs 2 kernel threads")
    release_threads()
    if threading.active_count() > 1:
        pytest.skip("other threads are alive in this process: its workers are spawned anyway")
    surface_force(pelton_bucket_surface())
    assert _threads.pool_threads() > 0  # the force ran on two threads
    with executor("process", workers=1) as pool:
        assert pool._mp_context.get_start_method() == "fork"
        assert pool.submit(os.getpid).result() != os.getpid()


# ---- the timing rounds split over the workers --------------------------------------------------


def test_timing_shares_known_answers():
    from replication.experiments.casestudy import timing_shares

    assert timing_shares(100, 1) == [100]
    assert timing_shares(100, 2) == [50, 50]
    assert timing_shares(5, 2) == [3, 2]
    assert timing_shares(2, 8) == [1, 1]  # never an empty task


def test_timing_rounds_scale_with_the_ga_known_answers():
    """100 rounds for the paper's GA, 21 for --quick's 216 evaluations, 5 for a tiny custom run
    (whose 36 evaluations the old fixed 100 rounds outnumbered eightfold)."""
    from replication.experiments.casestudy import default_timing_repeats, quick_ga_config

    assert default_timing_repeats(GAConfig()) == 100
    assert default_timing_repeats(quick_ga_config()) == 21
    assert default_timing_repeats(GAConfig(runs=2, generations=3, population=6)) == 5
    assert default_timing_repeats(GAConfig(runs=1, generations=10, population=50)) == 50


@given(st.integers(1, 8), st.integers(1, 80), st.integers(5, 100))
def test_timing_rounds_stay_in_range_and_never_outnumber_a_large_gas_evaluations(
    runs, generations, population
):
    from replication.experiments.casestudy import default_timing_repeats

    evaluations = runs * generations * population
    rounds = default_timing_repeats(GAConfig(runs=runs, generations=generations, population=population))
    assert 5 <= rounds <= 100
    if evaluations >= 50:  # each round evaluates three individuals: at most 30 % of the GA's work
        assert 3 * rounds <= 0.3 * evaluations + 1e-9


@given(st.integers(1, 10_000), st.integers(1, 256))
def test_timing_shares_cover_every_round_evenly(repeats, workers):
    from replication.experiments.casestudy import timing_shares

    shares = timing_shares(repeats, workers)
    assert sum(shares) == repeats and len(shares) == min(repeats, workers)
    assert min(shares) >= 1 and max(shares) - min(shares) <= 1


@pytest.mark.parametrize("repeats, workers", [(0, 2), (10, 0), (-1, 1)])
def test_timing_shares_refuse_bad_counts(repeats, workers):
    from replication.experiments.casestudy import timing_shares

    with pytest.raises(ValueError, match=f"repeats={repeats}, workers={workers}"):
        timing_shares(repeats, workers)
