"""SPH as the GA's fitness (``replication casestudy --solver sph``, issue 11 item 3).

:class:`SPHFitness` scores a genome as :class:`~replication.casestudy.evaluate.Fitness` does,
with an SPH simulation in place of the thin-sheet model: picklable, so the command's
dispatcher sends it to a process pool or a dask cluster, where each evaluation (seconds to
minutes) is a task of its own. Every simulation goes through the SPH cache
(:mod:`.sph_batch`), so an interrupted generation resumes with the simulations it finished;
a failed simulation raises, which the dispatcher records as a failed evaluation (the GA gives
it the worst fitness and carries on). :func:`estimate` measures one simulation (the flat
plate, itself cached) and projects the cost of a whole GA before it starts.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from replication.casestudy.ga import GAConfig, points_from_genome
from replication.errors import DuplicatePointsWarning, InputError, SimulationError

__all__ = ["Estimate", "SPHFitness", "estimate"]


@dataclass(frozen=True)
class SPHFitness:
    """The GA's objective scored by SPH: the quasi-steady axial force (N) on a genome's surface.

    Parameters
    ----------
    config : GAConfig
    settings : SPHSettings
    cache_dir : str
        The SPH cache (absolute, and shared by the workers of a cluster).
    timeout : float or None
        Wall-clock limit of one simulation (s); None: the backend's default.
    simulate : callable, optional
        Replaces :func:`~.sph.sph_force` (tests; picklable by reference).

    Notes
    -----
    Paper section 6: every individual of the GA scored by an SPH simulation.
    """

    config: GAConfig
    settings: Any
    cache_dir: str
    timeout: float | None = None
    simulate: Any = None

    def __post_init__(self) -> None:
        from replication.casestudy.sph.settings import SPHSettings

        if not isinstance(self.settings, SPHSettings):
            raise InputError(f"settings must be SPHSettings, got {type(self.settings).__name__}")

    def __call__(self, genome: np.ndarray) -> float:
        from replication.casestudy.sph_batch import SurfaceTask, score_surfaces
        from replication.surfaces import adt

        points = points_from_genome(genome, self.config)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DuplicatePointsWarning)
            surface = adt(points, depth="z", duplicates=self.config.duplicates)  # type: ignore[arg-type]
        (scored,) = score_surfaces(
            [SurfaceTask.from_surface("individual", surface)], self.settings, jet=self.config.jet,
            cache_dir=self.cache_dir, timeout=self.timeout, simulate=self.simulate,
        )  # fmt: skip
        if not scored.ok:
            raise SimulationError(f"SPH simulation failed ({scored.status}): {scored.reason}")
        return float(scored.result.mean_axial)


@dataclass(frozen=True)
class Estimate:
    """The projected cost of a GA scored by SPH."""

    seconds_per_simulation: float  # measured on the flat plate at the run's settings
    evaluations: int  # at most runs x generations x population (the genome cache saves some)
    workers: int
    cached: bool  # the measurement was read from the cache (a simulation of an earlier run)

    @property
    def hours(self) -> float:
        return self.evaluations * self.seconds_per_simulation / self.workers / 3600


def estimate(fitness: SPHFitness, *, workers: int) -> Estimate:
    """Measure one simulation (the flat plate, cached) and project the whole GA's cost.

    Raises
    ------
    SimulationError
        When the measuring simulation fails: the settings do not work for this jet.
    """
    from replication.casestudy.shapes import flat_plate_surface
    from replication.casestudy.sph_batch import SurfaceTask, score_surfaces

    (scored,) = score_surfaces(
        [SurfaceTask.from_surface("flat plate", flat_plate_surface())], fitness.settings,
        jet=fitness.config.jet, cache_dir=fitness.cache_dir, timeout=fitness.timeout,
        simulate=fitness.simulate,
    )  # fmt: skip
    if not scored.ok:
        raise SimulationError(
            f"the SPH simulation of the flat plate that measures the cost failed ({scored.status}): "
            f"{scored.reason}"
        )
    c = fitness.config
    seconds = float(scored.result.wall_seconds)
    if not (math.isfinite(seconds) and seconds > 0):
        seconds = 0.0
    return Estimate(seconds, c.runs * c.generations * c.population, max(1, int(workers)), scored.cached)
