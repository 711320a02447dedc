"""GA checkpoints: the state of a run after each generation, validated when read back.

A run directory holds one checkpoint ``run-<k>.json`` per GA run, rewritten atomically
after every generation (JSON: no pickle, nothing executable), beside its ``config.json``
(:mod:`.rundir`). A checkpoint read back is checked against the configuration before use -
a malformed file, a generation beyond the configuration, lists of the wrong length, genomes
outside the lattice, a fitness that disagrees with the genome cache, an invalid generator
state - and refused with a :class:`~replication.errors.CheckpointError` naming the file and
the fault, so a resumed run never continues from a state no run could reach.
"""

from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from replication.casestudy.ga import GAConfig, genome_bounds
from replication.casestudy.rundir import CONFIG_NAME, read_config, read_json
from replication.errors import CheckpointError

__all__ = ["WORST", "GARun", "checkpoint_path", "genome_key", "load_run"]

WORST = -math.inf  #: fitness given to a failed evaluation
_STATE_KEYS = ("run", "generation", "population", "fitness", "rng_state", "history", "cache", "failures")
_HISTORY_KEYS = ("generation", "best", "best_so_far", "evaluations", "cache_hits", "failures")


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
    seed: list[int] | None = None  # the generator's seed, [config.seed, run]; None in older checkpoints

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
            "seed": self.seed,
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
            seed=state.get("seed"),
        )


def checkpoint_path(run_dir: str | os.PathLike[str], run: int) -> Path:
    return Path(run_dir) / f"run-{run}.json"


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)) and math.isfinite(value)


def _fault(state: Any, config: GAConfig, run: int) -> str | None:
    """What is wrong with a checkpoint's content, or None."""
    if not isinstance(state, dict):
        return f"expected a JSON object, got {type(state).__name__}"
    missing = [k for k in _STATE_KEYS if k not in state]
    if missing:
        return f"missing field(s) {', '.join(missing)}"
    if state["run"] != run:
        return f"it is the checkpoint of run {state['run']!r}, expected run {run}"
    seed = state.get("seed")  # absent from checkpoints written before it was recorded
    if seed is not None and seed != [config.seed, run]:
        return (
            f"it is the checkpoint of a run seeded {seed!r}, expected [{config.seed}, {run}] (the seed of "
            "this run directory's config.json): it comes from another run directory"
        )
    generation = state["generation"]
    if not _is_int(generation) or not 1 <= generation <= config.generations:
        return f"generation {generation!r} is outside 1..{config.generations} (the configured generations)"
    population, fitness = state["population"], state["fitness"]
    if not isinstance(population, list) or len(population) != config.population:
        size = len(population) if isinstance(population, list) else type(population).__name__
        return f"population has {size} genomes, expected {config.population}"
    bounds = genome_bounds(config)
    for i, genome in enumerate(population):
        if not isinstance(genome, list) or len(genome) != config.genes or not all(map(_is_int, genome)):
            return f"genome {i} is not a list of {config.genes} integers"
        g = np.asarray(genome, dtype=np.int64)
        if np.any(g < 0) or np.any(g > bounds):
            gene = int(np.argmax((g < 0) | (g > bounds)))
            return f"genome {i} lies outside the lattice of the configured box (gene {gene} = {g[gene]})"
    if not isinstance(fitness, list) or len(fitness) != config.population:
        size = len(fitness) if isinstance(fitness, list) else type(fitness).__name__
        return f"fitness has {size} values, expected {config.population} (one per genome)"
    if not all(f is None or _is_number(f) for f in fitness):
        return "fitness values must be finite numbers or null (a failed evaluation)"
    cache = state["cache"]
    if not isinstance(cache, dict) or not all(v is None or _is_number(v) for v in cache.values()):
        return "cache must map genome keys to finite numbers or null"
    for i, (genome, value) in enumerate(zip(population, fitness)):
        key = genome_key(np.asarray(genome, dtype=np.int64))
        if key not in cache:
            return f"genome {i} is not in the evaluation cache"
        if cache[key] != value:
            return (
                f"the fitness of genome {i} ({value!r}) differs from its cached evaluation ({cache[key]!r})"
            )
    history = state["history"]
    if not isinstance(history, list) or len(history) != generation:
        size = len(history) if isinstance(history, list) else type(history).__name__
        return f"history has {size} entries for {generation} generation(s)"
    for k, entry in enumerate(history, start=1):
        if not isinstance(entry, dict) or any(key not in entry for key in _HISTORY_KEYS):
            return f"history entry {k} lacks one of {', '.join(_HISTORY_KEYS)}"
        if entry["generation"] != k:
            return f"history entry {k} is labelled generation {entry['generation']!r}"
        for key in ("best", "best_so_far"):  # -inf: every evaluation of the generation failed
            value = entry[key]
            number = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not (number and not math.isnan(value)):
                return f"history entry {k}: {key} must be a number, got {value!r}"
        for key in ("evaluations", "cache_hits", "failures"):
            if not _is_int(entry[key]):
                return f"history entry {k}: {key} must be an integer, got {entry[key]!r}"
    if not isinstance(state["failures"], list):
        return "failures must be a list"
    if not isinstance(state.get("seconds", []), list):
        return "seconds must be a list"
    rng_state = state["rng_state"]
    if not isinstance(rng_state, dict) or rng_state.get("bit_generator") != "PCG64":
        return "rng_state is not the state of numpy's PCG64 generator"
    try:
        np.random.default_rng().bit_generator.state = rng_state
    except (TypeError, ValueError, KeyError, OverflowError) as exc:
        return f"rng_state is not a valid PCG64 state ({exc})"
    return None


def load_run(run_dir: str | os.PathLike[str], run: int, config: GAConfig | None = None) -> GARun | None:
    """The last checkpoint of a run, validated against the configuration, or None.

    Parameters
    ----------
    run_dir : path-like
    run : int
    config : GAConfig, optional
        The run's configuration (default: read from ``run_dir/config.json``).

    Raises
    ------
    CheckpointError
        A checkpoint that is unreadable or inconsistent with the configuration, or a
        checkpoint without ``config.json``.
    """
    path = checkpoint_path(run_dir, run)
    if not path.exists():
        return None
    if config is None:
        config = read_config(run_dir)
        if config is None:  # pragma: no cover - read_config refuses checkpoints without config
            raise CheckpointError(f"{run_dir}: no {CONFIG_NAME}")
    if not path.is_file():
        raise CheckpointError(f"{path}: not a file")
    state = read_json(path, "GA checkpoint")
    fault = _fault(state, config, run)
    if fault is not None:
        raise CheckpointError(f"{path}: not a valid GA checkpoint: {fault}")
    return GARun.from_state(state)
