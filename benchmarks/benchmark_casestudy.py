"""The case study (paper section 6): one jet-force evaluation and one GA generation."""

import numpy as np

from replication.casestudy.evaluate import Fitness, SerialExecutor, evaluate_batch
from replication.casestudy.ga import GAConfig, initial_population, next_generation, points_from_genome
from replication.casestudy.jet import surface_force
from replication.casestudy.shapes import pelton_bucket_surface

from .common import quiet

#: The jet force's compiled kernels (replication._aot names).
_JET_KERNELS = ("sheet_prepare", "locate", "sheet_trace")


class JetForce:
    """One evaluation of the force model on 101-point surfaces, by either compiled tracer.

    ``ahead-of-time``: the kernels compiled when the package was built, which a process runs
    until it has loaded numba (a script's calls, the ``force`` command). ``numba``: numba's
    kernels, which the GA, ``reproduce`` and the tests load (``warm_up``). Either runs the
    jet's two pieces on two threads (the ahead-of-time kernels held the GIL, and ran them one
    after the other, up to 59f22e5).
    asv runs each parameter combination in a process of its own.
    """

    params = [["pelton bucket", "random"], ["ahead-of-time", "numba"]]
    param_names = ["surface", "kernel"]
    timeout = 300  # loading numba's kernels compiles them in a fresh environment (about 30 s)

    def setup(self, surface, kernel):
        quiet()
        from replication import _aot
        from replication.surfaces import adt

        if kernel == "numba":
            for name in _JET_KERNELS:
                _aot.load_numba(name)

        if surface == "pelton bucket":
            self.surface = pelton_bucket_surface()
        else:
            genome = np.random.default_rng(1234).integers(0, [37, 31, 14] * 101)
            self.surface = adt(points_from_genome(genome, GAConfig()), depth="z")
        surface_force(self.surface)
        numba_runs = [_aot.is_numba(_aot.kernel(name)) for name in _JET_KERNELS]
        if numba_runs != [kernel == "numba"] * len(_JET_KERNELS):
            raise NotImplementedError(f"not the {kernel} kernels (the ahead-of-time module is not built?)")

    def time_surface_force(self, surface, kernel):
        surface_force(self.surface)

    def track_axial_force(self, surface, kernel):
        return surface_force(self.surface).axial_force

    track_axial_force.unit = "N"


class GAGeneration:
    """One generation of the paper's GA: 48 new individuals (operators + ADT + force), serial."""

    def setup(self):
        quiet()
        self.config = GAConfig()
        rng = np.random.default_rng(2019)
        self.population = initial_population(self.config, rng=rng)
        self.fitness = Fitness(self.config)
        values = evaluate_batch(SerialExecutor(), self.fitness, list(self.population))
        self.values = np.array([v.value for v in values])
        self.state = rng.bit_generator.state

    def time_generation(self):
        rng = np.random.default_rng()
        rng.bit_generator.state = self.state
        children = next_generation(self.population, self.values, self.config, rng=rng)
        evaluate_batch(SerialExecutor(), self.fitness, list(children))

    def time_operators_only(self):
        rng = np.random.default_rng()
        rng.bit_generator.state = self.state
        next_generation(self.population, self.values, self.config, rng=rng)


class GAGenerationOnWorkers:
    """One generation of the paper's GA (48 individuals) dispatched in batches (issue 15 item 1).

    ``serial`` evaluates in the benchmark's process; ``process-2`` on a pool of 2 worker
    processes started (and warmed up) in ``setup``, so the time is the dispatch and the
    evaluations, not the pool's start-up. Their ratio is the GA's parallel speed-up; the
    whole command's is measured by ``python -m benchmarks.casestudy_speedup``.
    """

    params = [["serial", "process-2"]]
    param_names = ["executor"]
    timeout = 180

    def setup(self, kind):
        import functools

        from replication.casestudy.dispatch import Dispatcher
        from replication.casestudy.evaluate import executor

        quiet()
        self.config = GAConfig()
        workers = None if kind == "serial" else 2
        self.dispatcher = Dispatcher(functools.partial(executor, kind.split("-")[0], workers=workers))
        self.fitness = Fitness(self.config)
        rng = np.random.default_rng(2019)
        population = initial_population(self.config, rng=rng)
        values = self.dispatcher.evaluate(self.fitness, list(population))  # starts and warms the workers
        fitness = np.array([v.value for v in values])
        # a generation of new children (no cache here: every individual is evaluated)
        self.children = list(next_generation(population, fitness, self.config, rng=rng))

    def teardown(self, kind):
        self.dispatcher.close()

    def time_generation(self, kind):
        self.dispatcher.evaluate(self.fitness, self.children)
