"""The case-study GA: operators, determinism, interruption and resume, failures, executors."""

import functools
import json
import math

import numpy as np
import pytest

from replication.casestudy.evaluate import Fitness, executor
from replication.casestudy.ga import (
    GAConfig,
    genome_bounds,
    genome_from_points,
    initial_population,
    mutate,
    next_generation,
    points_from_genome,
    random_genome,
    select_parents,
    two_point_crossover,
)
from replication.casestudy.runner import GARun, load_run, run_ga
from replication.casestudy.shapes import flat_plate_cloud, pelton_bucket_cloud
from replication.errors import InputError, OutputError
from workerfaults import DiesOnceWhenArmed, pickled_by_value

SMALL = GAConfig(population=8, generations=4, elites=2, seed=7)
serial = functools.partial(executor, "serial")


def _same_run(a: GARun, b: GARun) -> None:
    """Bit-identical state (wall-clock times excluded)."""
    state_a, state_b = a.state(), b.state()
    state_a.pop("seconds")
    state_b.pop("seconds")
    assert json.dumps(state_a, sort_keys=True) == json.dumps(state_b, sort_keys=True)


# ---- operators ------------------------------------------------------------------------------


def test_two_point_crossover_swaps_one_segment():
    rng = np.random.default_rng(0)
    a, b = np.zeros(303, dtype=np.int64), np.ones(303, dtype=np.int64)
    for _ in range(200):
        c1, c2 = two_point_crossover(a, b, rng=rng)
        assert c1.shape == c2.shape == (303,)
        np.testing.assert_array_equal(c1 + c2, a + b)  # every gene comes from one parent
        swapped = np.flatnonzero(c1 == 1)
        assert swapped.size >= 1 and np.all(np.diff(swapped) == 1)  # one contiguous segment
        assert swapped[0] >= 1 and swapped[-1] <= 301  # cuts strictly inside


def test_crossover_preserves_genes_of_real_genomes():
    rng = np.random.default_rng(1)
    a, b = random_genome(SMALL, rng=rng), random_genome(SMALL, rng=rng)
    c1, c2 = two_point_crossover(a, b, rng=rng)
    assert all(x in (p, q) for x, p, q in zip(c1, a, b))
    np.testing.assert_array_equal(np.sort(np.r_[c1, c2]), np.sort(np.r_[a, b]))


def test_mutation_rate_matches_its_probability():
    rng = np.random.default_rng(2)
    bounds = genome_bounds(SMALL)
    genome = random_genome(SMALL, rng=rng)
    changed = 0
    trials = 2000
    for _ in range(trials):
        out = mutate(genome, 0.05, bounds, rng=rng)
        changed += int(np.count_nonzero(out != genome))
        assert np.all((out >= 0) & (out <= bounds))
    n = trials * genome.size
    expected = 0.05 * n
    assert abs(changed - expected) < 4 * math.sqrt(n * 0.05 * 0.95)  # 4 sigma


def test_mutation_draws_every_other_value_uniformly():
    rng = np.random.default_rng(3)
    genome = np.array([5, 5, 5] * 101)
    bounds = genome_bounds(SMALL)  # 36, 30, 13
    draws = np.concatenate([mutate(genome, 1.0, bounds, rng=rng)[2::3] for _ in range(300)])  # z genes
    values, counts = np.unique(draws, return_counts=True)
    np.testing.assert_array_equal(values, [v for v in range(14) if v != 5])  # never the current value
    assert counts.min() > 0.7 * counts.mean() and counts.max() < 1.3 * counts.mean()


def test_paper_mutation_rate_is_nearly_no_mutation():
    rng = np.random.default_rng(4)
    genome = random_genome(GAConfig(), rng=rng)
    changes = sum(
        int(np.any(mutate(genome, 1e-4, genome_bounds(GAConfig()), rng=rng) != genome)) for _ in range(3000)
    )
    assert 40 < changes < 140  # 1 - (1 - 1e-4)^303 = 3.0 % of children


def test_select_parents_distinct_and_uniform():
    rng = np.random.default_rng(5)
    pairs = [select_parents(6, rng=rng) for _ in range(3000)]
    assert all(i != j for i, j in pairs)
    counts = np.bincount(np.ravel(pairs), minlength=6)
    assert counts.min() > 0.85 * counts.mean()


def test_elites_survive_unchanged_and_population_size_kept():
    rng = np.random.default_rng(6)
    population = np.vstack([random_genome(SMALL, rng=rng) for _ in range(8)])
    fitness = np.array([1.0, 5.0, 3.0, -math.inf, 4.0, 0.0, 2.0, 5.0])
    children = next_generation(population, fitness, SMALL, rng=rng)
    assert children.shape == population.shape
    np.testing.assert_array_equal(children[0], population[1])  # ties: lower index first
    np.testing.assert_array_equal(children[1], population[7])


def test_initial_population_contains_flat_plate_and_bucket():
    population = initial_population(GAConfig(), rng=np.random.default_rng(0))
    assert population.shape == (48, 303)
    np.testing.assert_array_equal(points_from_genome(population[0], GAConfig()), flat_plate_cloud())
    np.testing.assert_array_equal(points_from_genome(population[1], GAConfig()), pelton_bucket_cloud())
    assert np.all(population >= 0) and np.all(population <= genome_bounds(GAConfig()))


def test_genome_round_trip_and_errors():
    cloud = pelton_bucket_cloud()
    np.testing.assert_array_equal(
        points_from_genome(genome_from_points(cloud, GAConfig()), GAConfig()), cloud
    )
    with pytest.raises(InputError, match="lattice"):
        genome_from_points(cloud + 0.5, GAConfig())
    with pytest.raises(InputError, match="outside"):
        genome_from_points(cloud + [0, 0, 20], GAConfig())


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"population": 3}, "at least 4"),
        ({"elites": 48}, "elites"),
        # --population 4 said "elites must be in [0, population)", elites being no CLI option
        ({"population": 4}, r"population must be larger than its elites \(the 4 fittest .*got population=4"),
        # 1e8 filled the memory at 60 MB/s while the first population was drawn, deaf to Ctrl-C
        ({"population": 10**8}, r"at most 100,000 \(its genomes alone take 226 GiB\)"),
        ({"mutation_rate": 1.5}, "probability"),
        ({"generations": 0}, "generations"),
        ({"box": (0, 36, 0, 30, 13, 0)}, "min < max"),
        ({"duplicates": "raise"}, "merge"),
        # the case study scores its reference shapes at 4x: 100 failed only there, after the runs
        ({"resolution": 65}, r"at most 64 .* got resolution=65"),
        ({"step": 1e-300}, r"too fine for the range"),
    ],
)
def test_config_validation(kwargs, match):
    with pytest.raises(InputError, match=match):
        GAConfig(**kwargs)


@pytest.mark.parametrize(
    "draw",
    [
        lambda rng: random_genome(SMALL, rng=rng),
        lambda rng: initial_population(SMALL, rng=rng),
        lambda rng: np.array(select_parents(10, rng=rng)),
        lambda rng: np.concatenate(two_point_crossover(np.arange(40), np.arange(40, 80), rng=rng)),
        lambda rng: mutate(np.zeros(30, dtype=np.int64), 0.5, np.full(30, 7), rng=rng),
        lambda rng: next_generation(
            initial_population(SMALL, rng=0), np.arange(SMALL.population, dtype=float), SMALL, rng=rng
        ),  # fmt: skip
    ],
    ids=["random_genome", "initial_population", "select_parents", "crossover", "mutate", "next_generation"],
)
def test_every_stochastic_step_takes_a_seed_or_a_generator(draw):
    """The project's rule for randomness: rng is an int, a Generator or None (default_rng once)."""
    assert np.array_equal(draw(7), draw(np.random.default_rng(7)))
    assert np.array_equal(draw(7), draw(7))
    generator = np.random.default_rng(7)
    assert not np.array_equal(draw(generator), draw(generator))  # a generator is advanced, not copied
    draw(None)


# ---- runs -----------------------------------------------------------------------------------


def test_run_is_deterministic_and_independent_of_global_state(tmp_path, restore_global_rng):
    np.random.seed(0)
    a = run_ga(SMALL, 0, run_dir=tmp_path / "a", pool_factory=serial)
    np.random.seed(99)
    b = run_ga(SMALL, 0, run_dir=tmp_path / "b", pool_factory=serial)
    _same_run(a, b)
    assert a.generation == 4 and len(a.history) == 4
    c = run_ga(SMALL, 1, run_dir=tmp_path / "a", pool_factory=serial)
    assert not np.array_equal(a.population, c.population)  # runs differ by their seed


def test_history_and_cache_accounting(tmp_path):
    run = run_ga(SMALL, 0, run_dir=tmp_path, pool_factory=serial)
    frame = run.history_frame()
    assert list(frame["generation"]) == [1, 2, 3, 4]
    assert np.all(np.diff(frame["best_so_far"]) >= 0)
    assert np.all(frame["best"] <= frame["best_so_far"])
    # the elites (2) are cached from generation 2 on: at most 6 new evaluations per generation
    assert frame["evaluations"].iloc[0] == 8 and np.all(frame["evaluations"].iloc[1:] <= 6)
    assert np.all(frame["evaluations"] + frame["cache_hits"] == 8)
    assert run.evaluations + run.cache_hits == 8 * 4
    assert run.fitness[run.best_index] == frame["best"].iloc[-1]


def test_interrupted_then_resumed_run_is_bit_identical(tmp_path):
    uninterrupted = run_ga(SMALL, 0, run_dir=tmp_path / "full", pool_factory=serial)

    def crash(state):
        if state.generation == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_ga(SMALL, 0, run_dir=tmp_path / "broken", pool_factory=serial, on_generation=crash)
    assert load_run(tmp_path / "broken", 0).generation == 2
    resumed = run_ga(SMALL, 0, run_dir=tmp_path / "broken", pool_factory=serial, resume=True)
    _same_run(uninterrupted, resumed)


def test_checkpoint_is_plain_json(tmp_path):
    run_ga(SMALL, 0, run_dir=tmp_path, pool_factory=serial)
    state = json.loads((tmp_path / "run-0.json").read_text())
    assert set(state) >= {"population", "fitness", "rng_state", "history", "cache", "failures"}
    assert state["rng_state"]["bit_generator"] == "PCG64"
    assert json.loads((tmp_path / "config.json").read_text())["population"] == 8


def test_resume_refuses_another_configuration(tmp_path):
    run_ga(SMALL, 0, run_dir=tmp_path, pool_factory=serial)
    other = GAConfig(population=8, generations=4, elites=2, seed=8)
    with pytest.raises(InputError, match="differs in: seed"):
        run_ga(other, 0, run_dir=tmp_path, pool_factory=serial, resume=True)


def test_existing_checkpoint_needs_resume(tmp_path):
    run_ga(SMALL, 0, run_dir=tmp_path, pool_factory=serial)
    with pytest.raises(OutputError, match="--resume"):
        run_ga(SMALL, 0, run_dir=tmp_path, pool_factory=serial)
    more = run_ga(SMALL, 0, run_dir=tmp_path, pool_factory=serial, resume=True)  # already complete
    assert more.generation == 4


class FailingFitness:
    """The real fitness, except that some genomes raise and some return NaN."""

    def __init__(self, config):
        self.inner = Fitness(config)

    def __call__(self, genome):
        if genome.sum() % 3 == 1:
            raise RuntimeError("solver diverged")
        if genome.sum() % 3 == 2:
            return float("nan")
        return self.inner(genome)


def test_failed_evaluations_are_recorded_and_get_the_worst_fitness(tmp_path):
    run = run_ga(SMALL, 0, run_dir=tmp_path, pool_factory=serial, fitness=FailingFitness(SMALL))
    assert run.generation == SMALL.generations
    errors = {f["error"] for f in run.failures}
    assert "RuntimeError: solver diverged" in errors and any("non-finite" in e for e in errors)
    bad = np.array([g.sum() % 3 in (1, 2) for g in run.population])
    assert np.all(run.fitness[bad] == -math.inf) and np.all(np.isfinite(run.fitness[~bad]))
    assert sum(h["failures"] for h in run.history) == len(run.failures)


class FullDiskFitness:
    """The real fitness, until the file ``full`` exists: then the disk is full."""

    def __init__(self, config, full):
        self.inner, self.full = Fitness(config), str(full)

    def __call__(self, genome):
        import errno
        import os

        if os.path.exists(self.full):
            raise OSError(errno.ENOSPC, "No space left on device")
        return self.inner(genome)


@pytest.mark.parametrize("kind", ["serial", "process"])
def test_a_full_disk_stops_the_ga_and_poisons_nothing(tmp_path, kind):
    """An evaluation that met a full disk (an SPH fitness writing its cache) was recorded as a
    failed individual with the worst fitness, kept in the genome cache for good."""
    import errno

    full = tmp_path / "full"
    pool = serial if kind == "serial" else functools.partial(executor, "process", workers=2)

    def fill_after_the_second(state):
        if state.generation == 2:
            full.touch()

    with pytest.raises(OSError) as caught:
        run_ga(SMALL, 0, run_dir=tmp_path / "run", pool_factory=pool, fitness=FullDiskFitness(SMALL, full),
               on_generation=fill_after_the_second)  # fmt: skip
    assert caught.value.errno == errno.ENOSPC
    assert load_run(tmp_path / "run", 0).generation == 2 and not load_run(tmp_path / "run", 0).failures
    full.unlink()  # room again: the resumed run is the uninterrupted one
    resumed = run_ga(SMALL, 0, run_dir=tmp_path / "run", pool_factory=serial, resume=True,
                     fitness=FullDiskFitness(SMALL, full))  # fmt: skip
    _same_run(resumed, run_ga(SMALL, 0, run_dir=tmp_path / "whole", pool_factory=serial))


@pytest.mark.slow
def test_process_pool_gives_identical_results(tmp_path):
    a = run_ga(SMALL, 0, run_dir=tmp_path / "serial", pool_factory=serial)
    b = run_ga(
        SMALL, 0, run_dir=tmp_path / "pool", pool_factory=functools.partial(executor, "process", workers=2)
    )
    _same_run(a, b)


# ---- dask.distributed -------------------------------------------------------------------------


@pytest.fixture
def dask_pickling(port_8787_taken):  # clusters must start beside another program's dashboard
    pytest.importorskip("dask.distributed")
    import sys

    with pickled_by_value(sys.modules[__name__]):  # workers cannot import tests/
        yield


@pytest.mark.slow
def test_dask_local_cluster_gives_identical_results(tmp_path, dask_pickling):
    a = run_ga(SMALL, 0, run_dir=tmp_path / "serial", pool_factory=serial)
    b = run_ga(
        SMALL, 0, run_dir=tmp_path / "dask", pool_factory=functools.partial(executor, "dask", workers=2)
    )
    _same_run(a, b)


@pytest.mark.slow
def test_dask_worker_dying_mid_run_changes_nothing(tmp_path, dask_pickling):
    armed, died = tmp_path / "armed", tmp_path / "died"
    fitness = DiesOnceWhenArmed(Fitness(SMALL), armed, died)

    def arm(state):
        if state.generation == 1:
            armed.touch()

    reference = run_ga(SMALL, 0, run_dir=tmp_path / "serial", pool_factory=serial)
    survived = run_ga(
        SMALL, 0, run_dir=tmp_path / "dask", pool_factory=functools.partial(executor, "dask", workers=2),
        fitness=fitness, on_generation=arm,
    )  # fmt: skip
    assert died.exists()  # a worker really died during generation 2
    _same_run(reference, survived)
    assert survived.failures == []


class DegenerateExceptSeeds:
    """The real fitness, but every random individual is evaluated as all points at one spot."""

    def __init__(self, config):
        self.inner = Fitness(config)
        self.seeds = {tuple(g) for g in initial_population(config, rng=np.random.default_rng(0))[:2]}

    def __call__(self, genome):
        if tuple(genome) in self.seeds:
            return self.inner(genome)
        return self.inner(np.zeros_like(genome))  # ADT raises: fewer than 3 distinct points


def test_degenerate_genome_is_a_recorded_failure_not_a_crash(tmp_path):
    config = GAConfig(population=6, generations=1, elites=1, seed=3)
    run = run_ga(config, 0, run_dir=tmp_path, pool_factory=serial, fitness=DegenerateExceptSeeds(config))
    assert len(run.failures) == 4 and all("DegenerateInputError" in f["error"] for f in run.failures)
    assert np.isfinite(run.fitness[:2]).all() and np.all(run.fitness[2:] == -math.inf)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"points": 50}, "cannot hold them"),
        ({"box": (0, 40, 0, 30, 0, 13)}, "inside the jet domain"),
        ({"seed": -1}, "non-negative"),
        ({"elites": 1.5}, "elites must be an integer"),
    ],
)
def test_config_refuses_settings_that_cannot_run(kwargs, match):
    with pytest.raises(InputError, match=match):
        GAConfig(**kwargs)
