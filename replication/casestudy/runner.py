"""GA runs that survive interruption: the generation loop, checkpoints and resume.

After every generation the full state of a run (population, fitness, the generator's state,
the history, the genome cache and the failures) is written atomically to
``run_dir/run-<k>.json``; ``run_dir/config.json`` records the configuration, and resuming
with another configuration is refused (see :mod:`.rundir` and :mod:`.checkpoints`, which
validate both on load). A resumed run continues from the last checkpoint and ends
bit-identical to an uninterrupted one, because the generator's state is restored exactly
and evaluations are pure functions of the genome. Wall-clock times are kept apart from the state so that they
do not break that identity.

Ctrl-C stops a run between evaluations (:mod:`.interrupts`): the generation under way is
dropped, nothing of it is recorded (an interrupted evaluation is not a failure), and the
last checkpoint stays the run's state.
"""

from __future__ import annotations

import contextlib
import json
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from replication.casestudy.checkpoints import WORST, GARun, checkpoint_path, genome_key, load_run
from replication.casestudy.dispatch import Dispatcher, ExecutorFactory
from replication.casestudy.ga import GAConfig, initial_population, next_generation
from replication.casestudy.interrupts import InterruptGuard
from replication.casestudy.rundir import read_config, write_config
from replication.errors import OutputError
from replication.io.atomic import atomic_write_text

__all__ = [
    "Dispatcher",
    "ExecutorFactory",
    "GARun",
    "check_run_dir",
    "genome_key",
    "iter_runs",
    "load_run",
    "read_config",
    "run_ga",
]


def check_run_dir(run_dir: str | os.PathLike[str], config: GAConfig) -> Path:
    """Create the run directory or check that it holds a run of the same configuration."""
    return write_config(run_dir, config)


def _evaluate(
    state: GARun,
    genomes: np.ndarray,
    fitness: Callable[[np.ndarray], float],
    dispatcher: Dispatcher,
    guard: InterruptGuard,
) -> dict[str, int]:
    """Fitness of a population into ``state.fitness``, reusing the cache; returns the counts."""
    keys = [genome_key(g) for g in genomes]
    todo: dict[str, np.ndarray] = {}
    for key, genome in zip(keys, genomes):
        if key not in state.cache and key not in todo:
            todo[key] = genome
    outcomes = dispatcher.evaluate(fitness, list(todo.values()), interrupted=guard.requested)
    failed = 0
    for (key, genome), outcome in zip(todo.items(), outcomes):
        state.cache[key] = outcome.value
        if outcome.error is not None:
            failed += 1
            state.failures.append({"generation": state.generation + 1, "key": key, "error": outcome.error,
                                   "genome": genome.tolist()})  # fmt: skip
    state.fitness = np.array([WORST if state.cache[k] is None else state.cache[k] for k in keys])
    return {"evaluations": len(todo), "cache_hits": len(keys) - len(todo), "failures": failed}


def _record(state: GARun, counts: dict[str, int]) -> None:
    finite = state.fitness[np.isfinite(state.fitness)]
    best = float(state.fitness.max())
    state.history.append({
        "generation": state.generation, "best": best,
        "best_so_far": max([h["best"] for h in state.history] + [best]),
        "mean": float(finite.mean()) if finite.size else None,
        "median": float(np.median(finite)) if finite.size else None, **counts,
    })  # fmt: skip


def run_ga(
    config: GAConfig,
    run: int,
    *,
    run_dir: str | os.PathLike[str],
    pool_factory: ExecutorFactory | None = None,
    dispatcher: Dispatcher | None = None,
    fitness: Callable[[np.ndarray], float] | None = None,
    resume: bool = False,
    on_generation: Callable[[GARun], None] | None = None,
) -> GARun:
    """Run (or resume) GA run number ``run`` to ``config.generations`` generations.

    Parameters
    ----------
    config : GAConfig
    run : int
        Run number; the run's generator is seeded with ``[config.seed, run]``.
    run_dir : path-like
        Where ``config.json`` and the checkpoints live.
    pool_factory : callable, optional
        Returns a context manager yielding the executor (see :func:`.evaluate.executor`);
        the executor is opened for this run and closed at its end.
    dispatcher : Dispatcher, optional
        Instead of ``pool_factory``: an open dispatcher shared with other runs (one
        executor for a whole command); it stays open. Give exactly one of the two.
    fitness : callable, optional
        Genome -> fitness, picklable for process pools (default: the jet force,
        :class:`.evaluate.Fitness`).
    resume : bool
        Continue from the run's last checkpoint. Without it an existing checkpoint of this
        run is an error (nothing is overwritten).
    on_generation : callable, optional
        Called with the state after each checkpoint (progress display; tests interrupt here).

    Returns
    -------
    GARun

    Notes
    -----
    Paper section 6: population 48, 50 generations, 4 elites, random selection, two-point
    crossover, 0.01 % mutation.
    """
    from replication.casestudy.evaluate import Fitness

    if (pool_factory is None) == (dispatcher is None):
        raise TypeError("run_ga needs exactly one of pool_factory and dispatcher")
    run_dir = check_run_dir(run_dir, config)
    fitness = fitness or Fitness(config)
    state = load_run(run_dir, run, config)
    if state is not None and not resume:
        raise OutputError(
            f"{checkpoint_path(run_dir, run)} exists: pass --resume to continue it, or use another directory"
        )
    if state is not None and state.generation >= config.generations:
        return state
    if state is not None:
        state.seed = [int(config.seed), int(run)]  # checked by load_run when recorded; recorded from now on
    # a dispatcher of this run's own is closed with the exception that ends the run, if any
    # (Ctrl-C: the executor says that it waits for the work under way); a shared one stays open
    dispatching = Dispatcher(pool_factory) if pool_factory is not None else contextlib.nullcontext(dispatcher)
    with dispatching as pool:
        assert pool is not None
        with InterruptGuard() as guard:
            while state is None or state.generation < config.generations:
                if state is None:
                    rng = np.random.default_rng([config.seed, run])
                    genomes = initial_population(config, rng=rng)
                    state = GARun(run, 0, genomes, np.full(config.population, WORST), rng.bit_generator.state)
                    state.seed = [int(config.seed), int(run)]
                else:
                    rng = np.random.default_rng()
                    rng.bit_generator.state = state.rng_state
                    genomes = next_generation(state.population, state.fitness, config, rng=rng)
                started = time.perf_counter()
                # on Ctrl-C this raises before anything of the generation is recorded
                counts = _evaluate(state, genomes, fitness, pool, guard)
                state.population = genomes
                state.generation += 1
                state.rng_state = rng.bit_generator.state
                _record(state, counts)
                state.seconds.append(time.perf_counter() - started)
                atomic_write_text(checkpoint_path(run_dir, run), json.dumps(state.state()) + "\n")
                if on_generation is not None:
                    on_generation(state)
                guard.check()  # a stop requested while checkpointing: the generation is saved
    return state


def iter_runs(run_dir: str | os.PathLike[str], runs: int) -> Iterator[GARun]:
    """The checkpointed runs 0..runs-1 that exist (validated against ``config.json``)."""
    config = read_config(run_dir)
    for k in range(runs):
        state = load_run(run_dir, k, config)
        if state is not None:
            yield state
