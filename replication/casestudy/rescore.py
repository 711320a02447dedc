"""The thin-sheet GA's best surfaces re-scored by SPH, the fitness of record (issue 11 item 3).

The jet-model validation study found that the thin-sheet model overestimates rough, faceted
surfaces (the GA's winners by about 1.4x) and ranks them unlike SPH, so the GA's winners by the model are only
candidates: :func:`rescore_runs` takes the ``top`` best *distinct* surfaces of the final
population of each run (:func:`top_distinct`: repeated elites and genomes whose ADT surfaces
coincide count once) and scores them, with the flat plate and the Pelton-bucket
approximation as references at the same settings, through
:func:`~replication.casestudy.sph_batch.score_surfaces`: content-addressed on disk, so a
rerun after an interruption simulates only what is missing, and a failed simulation is a row
with its reason.
"""

from __future__ import annotations

import concurrent.futures as cf
import math
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from replication.casestudy.checkpoints import GARun
from replication.casestudy.ga import GAConfig, points_from_genome
from replication.errors import DuplicatePointsWarning, InputError

__all__ = ["Candidate", "RescoreConfig", "RescoreResults", "rescore_runs", "top_distinct"]

#: Names of the two reference shapes, as in the case study's shape table.
REFERENCES = ("flat plate", "pelton bucket")


@dataclass(frozen=True)
class RescoreConfig:
    """What is re-scored and how.

    Attributes
    ----------
    top : int
        Distinct surfaces re-scored per GA run (the best by the thin-sheet fitness).
    settings : SPHSettings
        SPH settings of every simulation (the references' too).
    timeout : float or None
        Wall-clock limit of one simulation (s); None: the SPH backend's default.
    cache_dir : str
        The SPH cache (see :mod:`.sph_batch`).
    """

    top: int = 5
    settings: Any = None  # SPHSettings; None: the backend's defaults
    timeout: float | None = None
    cache_dir: str = ".sph-cache"

    def __post_init__(self) -> None:
        from replication.casestudy.sph.settings import SPHSettings

        if isinstance(self.top, bool) or not isinstance(self.top, (int, np.integer)) or self.top < 1:
            raise InputError(f"top must be a positive integer (surfaces per run), got top={self.top!r}")
        object.__setattr__(self, "top", int(self.top))
        settings = SPHSettings() if self.settings is None else self.settings
        if not isinstance(settings, SPHSettings):
            raise InputError(f"settings must be SPHSettings, got {type(settings).__name__}")
        object.__setattr__(self, "settings", settings)
        if self.timeout is not None and not (isinstance(self.timeout, (int, float)) and self.timeout > 0):
            raise InputError(f"timeout must be a positive number of seconds, got {self.timeout!r}")
        object.__setattr__(self, "cache_dir", str(self.cache_dir))


@dataclass(frozen=True)
class Candidate:
    """One distinct surface of a run's final population: its rank by the thin-sheet fitness."""

    run: int
    rank: int  # 1 = the best
    index: int  # position in the final population
    fitness: float  # thin-sheet axial force (N)
    points: np.ndarray = field(repr=False)
    triangles: np.ndarray = field(repr=False)

    @property
    def name(self) -> str:
        return f"GA run {self.run} #{self.rank}"


def _adt(points: np.ndarray, duplicates: str) -> Any:
    from replication.surfaces import adt

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        return adt(points, depth="z", duplicates=duplicates)  # type: ignore[arg-type]


def top_distinct(state: GARun, config: GAConfig, top: int) -> list[Candidate]:
    """The ``top`` best distinct surfaces of a run's final population.

    Individuals are ranked by their thin-sheet fitness (ties: population order; failed
    evaluations never count); one is kept when its ADT surface differs from every better
    one's (same vertices and triangles), so elites repeated in the population, and genomes
    that list the same points in another order, are one surface. Fewer than ``top`` come
    back when the population holds fewer distinct surfaces.

    Notes
    -----
    Paper section 6: the GA's optimised surfaces (Fig. 9).
    """
    from replication.casestudy.mesh import surface_signature

    if isinstance(top, bool) or not isinstance(top, (int, np.integer)) or top < 1:
        raise InputError(f"top must be a positive integer, got top={top!r}")
    out: list[Candidate] = []
    seen: set[str] = set()
    for i in np.argsort(-state.fitness, kind="stable"):
        if not math.isfinite(float(state.fitness[i])):
            break  # sorted: the failed evaluations are last
        s = _adt(points_from_genome(state.population[i], config), config.duplicates)
        signature = surface_signature(s.points, s.triangles)
        if signature in seen:
            continue
        seen.add(signature)
        out.append(Candidate(state.run, len(seen), int(i), float(state.fitness[i]), s.points, s.triangles))
        if len(out) == top:
            break
    return out


@dataclass(frozen=True, eq=False)
class RescoreResults:
    """The re-scored surfaces (one row each, references included) and what it cost."""

    surfaces: pd.DataFrame
    wall_seconds: float  # of the re-scoring (simulations and cache reads)
    workers: int


def _row(name: str, kind: str, run: Any, rank: Any, model: float, scored: Any, rho_q_v: float) -> dict:
    r = scored.result
    ok = scored.ok
    sph = float(r.mean_axial) if ok else math.nan
    return {
        "surface": name, "kind": kind, "run": run, "rank": rank, "thin_sheet_N": model,
        "sph_N": sph, "sph_over_rho_q_v": sph / rho_q_v if ok else math.nan,
        "sph_over_measured_flux": float(r.mean_axial / r.measured_momentum_flux) if ok else math.nan,
        "sph_std_N": float(r.std_axial) if ok else math.nan,
        "status": scored.status, "reason": scored.reason or "", "cached": bool(scored.cached),
        "sph_wall_s": float(r.wall_seconds) if r is not None else math.nan, "key": scored.key,
    }  # fmt: skip


def rescore_runs(
    states: Sequence[GARun],
    config: GAConfig,
    rescore: RescoreConfig,
    *,
    executor: cf.Executor | None = None,
    workers: int = 1,
    on_result: Callable[[Any], None] | None = None,
    simulate: Callable[..., Any] | None = None,
    on_plan: Callable[[Any], None] | None = None,
) -> RescoreResults:
    """SPH scores of the ``rescore.top`` best distinct surfaces of each run and of the references.

    Parameters
    ----------
    states : sequence of GARun
        The finished runs.
    config : GAConfig
        Their configuration (jet, lattice, duplicate policy).
    rescore : RescoreConfig
    executor : concurrent.futures.Executor, optional
        Where the simulations run (the command's executor); default: in this process.
    workers : int
        Simulations in flight at once (each uses one core in its own child process).
    on_result : callable, optional
        Called with each :class:`~.sph_batch.Scored` as it becomes known (progress).
    simulate : callable, optional
        Replaces :func:`~.sph.sph_force` (tests).
    on_plan : callable, optional
        Called before any simulation with the :class:`~.sph_batch.Plan`: the distinct
        surfaces read from the cache and to be simulated, and how many at once.

    Returns
    -------
    RescoreResults
        Rows in order: the references, then each run's surfaces by thin-sheet rank;
        ``same_as`` names the first earlier row with the same surface (simulated once).

    Notes
    -----
    Paper section 6 scores every surface by SPH; here SPH judges the thin-sheet GA's winners.
    """
    from replication.casestudy.jet import surface_force
    from replication.casestudy.shapes import flat_plate_surface, pelton_bucket_surface
    from replication.casestudy.sph_batch import SurfaceTask, score_surfaces

    started = time.perf_counter()
    refs = dict(zip(REFERENCES, (flat_plate_surface(), pelton_bucket_surface())))
    entries: list[tuple[str, str, Any, Any, float]] = []
    tasks: list[SurfaceTask] = []
    for name, surface in refs.items():
        model = surface_force(surface, config.jet, resolution=config.resolution).axial_force
        entries.append((name, "reference", pd.NA, pd.NA, float(model)))
        tasks.append(SurfaceTask.from_surface(name, surface))
    for state in states:
        for c in top_distinct(state, config, rescore.top):
            entries.append((c.name, "GA", c.run, c.rank, c.fitness))
            tasks.append(SurfaceTask(c.name, c.points, c.triangles))
    scored = score_surfaces(
        tasks, rescore.settings, jet=config.jet, cache_dir=rescore.cache_dir, executor=executor,
        max_parallel=max(1, int(workers)), timeout=rescore.timeout, on_result=on_result, simulate=simulate,
        on_plan=on_plan,
    )  # fmt: skip
    rho_q_v = config.jet.momentum_flux
    rows = [_row(*entry, s, rho_q_v) for entry, s in zip(entries, scored)]
    first: dict[str, str] = {}
    for row in rows:  # a GA winner may be a reference shape itself, or another run's winner
        row["same_as"] = first.setdefault(row["key"], row["surface"])
        if row["same_as"] == row["surface"]:
            row["same_as"] = ""
    frame = pd.DataFrame(rows).astype({"run": "Int64", "rank": "Int64"})
    return RescoreResults(frame, time.perf_counter() - started, max(1, int(workers)))
