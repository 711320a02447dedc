"""GA runs that survive interruption: the generation loop, checkpoints and resume.

After every generation the full state of a run (population, fitness, the generator's state,
the history, the genome cache and the failures) is written atomically to
``run_dir/run-<k>.json`` (JSON: no pickle, nothing executable). ``run_dir/config.json``
records the configuration; resuming with another configuration is refused. A resumed run
continues from the last checkpoint and ends bit-identical to an uninterrupted one, because
the generator's state is restored exactly and evaluations are pure functions of the genome.
Wall-clock times are kept apart from the state so that they do not break that identity.
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import json
import math
import os
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from replication.casestudy.evaluate import Outcome, evaluate_batch
from replication.casestudy.ga import GAConfig, initial_population, next_generation
from replication.errors import InputError, OutputError
from replication.io.atomic import atomic_write_text

__all__ = ["ExecutorFactory", "GARun", "check_run_dir", "genome_key", "iter_runs", "load_run", "run_ga"]

ExecutorFactory = Callable[[], AbstractContextManager[cf.Executor]]
WORST = -math.inf  #: fitness given to a failed evaluation
MAX_EXECUTOR_RETRIES = 3


def genome_key(genome: np.ndarray) -> str:
    """Cache key of a genome: SHA-256 of its int64 bytes."""
    return hashlib.sha256(np.ascontiguousarray(genome, dtype=np.int64).tobytes()).hexdigest()


@dataclass
class GARun:
    """The state of one GA run (checkpointed after every generation)."""

    run: int
    generation: int  # generations evaluated so far (1 = the initial population)
    population: np.ndarray
    fitness: np.ndarray
    rng_state: dict[str, Any]
    history: list[dict[str, Any]] = field(default_factory=list)
    cache: dict[str, float | None] = field(default_factory=dict)
    failures: list[dict[str, Any]] = field(default_factory=list)
    seconds: list[float] = field(default_factory=list)  # wall time per generation (not state)

    @property
    def best_index(self) -> int:
        return int(np.argmax(self.fitness))

    @property
    def best_genome(self) -> np.ndarray:
        return self.population[self.best_index]

    @property
    def evaluations(self) -> int:
        return int(sum(h["evaluations"] for h in self.history))

    @property
    def cache_hits(self) -> int:
        return int(sum(h["cache_hits"] for h in self.history))

    def history_frame(self) -> pd.DataFrame:
        frame = pd.DataFrame(self.history)
        if self.seconds:
            frame["seconds"] = self.seconds[: len(frame)]
        return frame.assign(run=self.run)

    def state(self) -> dict[str, Any]:
        """The JSON-ready checkpoint (infinite fitness written as null)."""
        return {
            "run": self.run,
            "generation": self.generation,
            "population": self.population.tolist(),
            "fitness": [None if not math.isfinite(f) else f for f in self.fitness.tolist()],
            "rng_state": self.rng_state,
            "history": self.history,
            "cache": self.cache,
            "failures": self.failures,
            "seconds": self.seconds,
        }

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> GARun:
        return cls(
            run=state["run"],
            generation=state["generation"],
            population=np.asarray(state["population"], dtype=np.int64),
            fitness=np.asarray([WORST if f is None else f for f in state["fitness"]], dtype=np.float64),
            rng_state=state["rng_state"],
            history=state["history"],
            cache=state["cache"],
            failures=state["failures"],
            seconds=state.get("seconds", []),
        )


def _checkpoint_path(run_dir: Path, run: int) -> Path:
    return run_dir / f"run-{run}.json"


def _jsonable(config: GAConfig) -> dict[str, Any]:
    return json.loads(json.dumps(config.as_dict()))


def check_run_dir(run_dir: str | os.PathLike[str], config: GAConfig) -> Path:
    """Create the run directory or check that it holds a run of the same configuration."""
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    path = run_dir / "config.json"
    recorded = _jsonable(config)
    if path.is_file():
        previous = json.loads(path.read_text())
        if previous != recorded:
            changed = sorted(k for k in set(previous) | set(recorded) if previous.get(k) != recorded.get(k))
            raise InputError(
                f"{run_dir} holds a run with a different configuration (differs in: {', '.join(changed)}); "
                "use a new run directory, or resume with the same settings"
            )
    else:
        atomic_write_text(path, json.dumps(recorded, indent=2, sort_keys=True) + "\n")
    return run_dir


def load_run(run_dir: str | os.PathLike[str], run: int) -> GARun | None:
    """The last checkpoint of a run, or None."""
    path = _checkpoint_path(Path(run_dir), run)
    if not path.is_file():
        return None
    try:
        return GARun.from_state(json.loads(path.read_text()))
    except (ValueError, KeyError, TypeError) as exc:
        raise InputError(f"{path}: not a readable GA checkpoint ({exc})") from exc


class _Pool:
    """An executor from a factory, replaced when it breaks."""

    def __init__(self, factory: ExecutorFactory) -> None:
        self.factory = factory
        self.context: AbstractContextManager[cf.Executor] | None = None
        self.executor: cf.Executor | None = None

    def get(self) -> cf.Executor:
        if self.executor is None:
            self.context = self.factory()
            self.executor = self.context.__enter__()
        return self.executor

    def close(self) -> None:
        if self.context is not None:
            context, self.context, self.executor = self.context, None, None
            context.__exit__(None, None, None)


def _evaluate(
    state: GARun, genomes: np.ndarray, fitness: Callable[[np.ndarray], float], pool: _Pool
) -> dict[str, int]:
    """Fitness of a population into ``state.fitness``, reusing the cache; returns the counts."""
    keys = [genome_key(g) for g in genomes]
    todo: dict[str, np.ndarray] = {}
    for key, genome in zip(keys, genomes):
        if key not in state.cache and key not in todo:
            todo[key] = genome
    outcomes: list[Outcome] = []
    for attempt in range(MAX_EXECUTOR_RETRIES + 1):
        try:
            outcomes = evaluate_batch(pool.get(), fitness, list(todo.values()))
            break
        except cf.BrokenExecutor:
            pool.close()  # a dead worker took the pool down: retry the batch on a new one
            if attempt == MAX_EXECUTOR_RETRIES:
                raise
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
    pool_factory: ExecutorFactory,
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
    pool_factory : callable
        Returns a context manager yielding the executor (see :func:`.evaluate.executor`).
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

    run_dir = check_run_dir(run_dir, config)
    fitness = fitness or Fitness(config)
    state = load_run(run_dir, run)
    if state is not None and not resume:
        raise OutputError(
            f"{_checkpoint_path(run_dir, run)} exists: pass --resume to continue it, or use another directory"
        )
    if state is not None and state.generation >= config.generations:
        return state
    pool = _Pool(pool_factory)
    try:
        while state is None or state.generation < config.generations:
            if state is None:
                rng = np.random.default_rng([config.seed, run])
                genomes = initial_population(config, rng=rng)
                state = GARun(run, 0, genomes, np.full(config.population, WORST), rng.bit_generator.state)
            else:
                rng = np.random.default_rng()
                rng.bit_generator.state = state.rng_state
                genomes = next_generation(state.population, state.fitness, config, rng=rng)
            started = time.perf_counter()
            counts = _evaluate(state, genomes, fitness, pool)
            state.population = genomes
            state.generation += 1
            state.rng_state = rng.bit_generator.state
            _record(state, counts)
            state.seconds.append(time.perf_counter() - started)
            atomic_write_text(_checkpoint_path(run_dir, run), json.dumps(state.state()) + "\n")
            if on_generation is not None:
                on_generation(state)
    finally:
        pool.close()
    return state


def iter_runs(run_dir: str | os.PathLike[str], runs: int) -> Iterator[GARun]:
    """The checkpointed runs 0..runs-1 that exist."""
    for k in range(runs):
        state = load_run(run_dir, k)
        if state is not None:
            yield state
