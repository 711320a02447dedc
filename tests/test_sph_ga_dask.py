"""The GA scored by SPH on a dask LocalCluster (issue 11 acceptance): a worker killed in the
middle of an evaluation loses nothing, and an interrupted run resumes to the same result.

The engine is the stand-in of ``sph_fake`` (force 1 + mean height, in milliseconds), so the
test checks the GA, the executor and the SPH cache, not the solver (the real engine runs in
test_rescore.py and test_sph_*.py).
"""

import functools
import json
import sys

import pytest

import sph_fake
from replication.casestudy.checkpoints import load_run
from replication.casestudy.evaluate import executor
from replication.casestudy.ga import GAConfig
from replication.casestudy.runner import run_ga
from replication.casestudy.sph import SPHSettings
from replication.casestudy.sph_fitness import SPHFitness
from workerfaults import DiesOnceWhenArmed, pickled_by_value

CONFIG = GAConfig(population=4, generations=2, elites=2, seed=5)  # the 4 x 2
SETTINGS = SPHSettings(particle_radius=1e-3, duration=0.016)
serial = functools.partial(executor, "serial")
dask2 = functools.partial(executor, "dask", workers=2)


def fitness(cache):
    return SPHFitness(CONFIG, SETTINGS, cache_dir=str(cache), simulate=sph_fake.fake_sph)


def _state(run):
    state = run.state()
    state.pop("seconds")
    return json.dumps(state, sort_keys=True)


@pytest.fixture
def dask_pickling(port_8787_taken):
    pytest.importorskip("dask.distributed")
    with pickled_by_value(sys.modules[__name__], sph_fake):  # workers cannot import tests/
        yield


@pytest.mark.slow
def test_sph_ga_on_dask_loses_nothing_to_a_dead_worker_and_resumes_identically(tmp_path, dask_pickling):
    reference = run_ga(
        CONFIG, 0, run_dir=tmp_path / "serial", pool_factory=serial, fitness=fitness(tmp_path / "c0")
    )
    assert reference.failures == []

    armed, died = tmp_path / "armed", tmp_path / "died"

    def arm(state):
        if state.generation == 1:
            armed.touch()

    killed = DiesOnceWhenArmed(fitness(tmp_path / "c1"), armed, died)
    survived = run_ga(
        CONFIG, 0, run_dir=tmp_path / "dask", pool_factory=dask2, fitness=killed, on_generation=arm
    )
    assert died.exists()  # a worker really died during generation 2
    assert survived.failures == [] and _state(survived) == _state(reference)

    def interrupt(state):
        if state.generation == 1:
            raise KeyboardInterrupt

    cache = tmp_path / "c2"
    with pytest.raises(KeyboardInterrupt):
        run_ga(
            CONFIG,
            0,
            run_dir=tmp_path / "cut",
            pool_factory=dask2,
            fitness=fitness(cache),
            on_generation=interrupt,
        )
    assert load_run(tmp_path / "cut", 0).generation == 1
    resumed = run_ga(
        CONFIG, 0, run_dir=tmp_path / "cut", pool_factory=dask2, fitness=fitness(cache), resume=True
    )
    assert _state(resumed) == _state(reference)
