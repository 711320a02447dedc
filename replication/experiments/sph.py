"""The case study on a real SPH solver: convergence, and the paper's forces examined.

Simulates the two reference shapes (the flat plate and the Pelton-bucket approximation, the
paper's half jet) with SPlisHSPlasH: with the incompressible solver (DFSPH) at several
particle sizes (a convergence study of the quasi-steady mean and the impact peak, and the
cost of a simulation), and with the weakly compressible one (WCSPH, as DualSPHysics) at
given numerical sound speeds, whose first-impact peak scales with rho c V A. The tables go
to :mod:`replication.experiments.sph_claims`, which sets each reading of the paper's
21.96 N and 19.08 N beside ours. Nothing here writes a file but the simulations' own.
"""

from __future__ import annotations

import concurrent.futures as cf
import functools
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from replication.casestudy.jet import JetConfig, surface_force
from replication.casestudy.shapes import PAPER_SPH_FORCES, flat_plate_surface, pelton_bucket_surface
from replication.errors import InputError
from replication.provenance import provenance

__all__ = ["SHAPES", "Run", "SPHStudyConfig", "SPHStudyResults", "run_sph_study"]

SHAPES: dict[str, Callable[[], Any]] = {
    "flat plate": flat_plate_surface,
    "pelton bucket": pelton_bucket_surface,
}


@dataclass(frozen=True)
class Run:
    """One simulation of the study."""

    shape: str
    method: str  # "dfsph" or "wcsph"
    radius: float  # particle radius (m)
    sound_factor: float | None = None  # wcsph: c / V

    def settings(self, duration: float, jet_speed: float) -> Any:
        """The simulation's settings: the defaults with this run's solver, particles and c."""
        from replication.casestudy.sph import SPHSettings

        c = None if self.sound_factor is None else self.sound_factor * jet_speed
        return SPHSettings(particle_radius=self.radius, duration=duration, method=self.method, sound_speed=c)

    @property
    def label(self) -> str:
        c = "" if self.sound_factor is None else f", c = {self.sound_factor:g} V"
        return f"{self.shape}, {self.method.upper()}, r = {1e3 * self.radius:g} mm{c}"


@dataclass(frozen=True)
class SPHStudyConfig:
    """What the study simulates (SI units); the defaults are the report's."""

    radii: tuple[float, ...] = (1.0e-3, 0.75e-3, 0.5e-3)
    wcsph: tuple[tuple[float, float], ...] = (
        (1.0e-3, 10.0),
        (0.75e-3, 10.0),
        (1.0e-3, 20.0),
        (0.75e-3, 20.0),
    )
    duration: float = 0.020
    timeout: float = 3600.0
    jet: JetConfig = JetConfig()

    def __post_init__(self) -> None:
        if not self.radii or any(not (0 < r <= 5e-3) for r in self.radii):
            raise InputError(f"study radii must be positive (m) and at most 5 mm, got {self.radii}")
        if any(not (0 < r <= 5e-3 and c > 1) for r, c in self.wcsph):
            raise InputError(f"wcsph runs must be (radius <= 5 mm, c / V > 1) pairs, got {self.wcsph}")
        # a run listed twice is one simulation (the cache gives the second), counted as run twice
        for name, runs in (("radii", self.radii), ("wcsph runs", self.wcsph)):
            if len(set(runs)) != len(runs):
                raise InputError(f"study {name} must be distinct, got {runs}")
        if self.jet.full_jet:
            raise InputError("the study examines the paper's half jet: use JetConfig(full_jet=False)")

    @classmethod
    def quick(cls) -> SPHStudyConfig:
        """Coarse particles only: a smoke test of the whole study in well under a minute."""
        return cls(radii=(1.25e-3,), wcsph=((1.25e-3, 10.0),), duration=0.014)

    def runs(self) -> list[Run]:
        out = [Run(s, "dfsph", r) for r in sorted(self.radii, reverse=True) for s in SHAPES]
        out += [Run(s, "wcsph", r, c) for r, c in self.wcsph for s in SHAPES]
        return out

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True, eq=False)
class SPHStudyResults:
    """Raw and summarised results of the SPH study."""

    config: SPHStudyConfig
    runs: pd.DataFrame  # one row per simulation
    series: pd.DataFrame  # binned force of every simulation
    shapes: pd.DataFrame  # reference shapes: thin-sheet model, SPH, the paper
    hypotheses: pd.DataFrame  # what the paper's forces can be, with verdicts
    provenance: dict[str, Any] = field(default_factory=dict)


def _row(run: Run, result: Any, jet: JetConfig) -> dict[str, Any]:
    rho_q_v = jet.momentum_flux
    c = result.settings.speed_of_sound(jet.velocity)
    return {
        "shape": run.shape,
        "method": run.method,
        "radius_mm": 1e3 * run.radius,
        "sound_speed_m_s": np.nan if c is None else c,
        "status": result.status,
        "reason": result.reason or "",
        "mean_N": result.mean_axial,
        "std_N": result.std_axial,
        "window_start_ms": 1e3 * result.window[0],
        "window_end_ms": 1e3 * result.window[1],
        "fx_N": result.mean_force[0],
        "fy_N": result.mean_force[1],
        "peak_N": result.peak_axial,
        "peak_time_ms": 1e3 * result.peak_time,
        "peak_window_ms": 1e3 * result.settings.peak_window,
        "max_N": result.max_axial,
        "max_step_N": result.max_step_axial,
        "rho_q_v_N": rho_q_v,
        "mean_over_rho_q_v": result.mean_axial / rho_q_v,
        "mass_flow_kg_s": result.mass_flow,
        "nominal_mass_flow_kg_s": jet.mass_flow,
        "mean_over_measured_flux": result.mean_axial / result.measured_momentum_flux,
        "peak_over_rho_c_v_a": np.nan if c is None else result.peak_axial / (rho_q_v * c / jet.velocity),
        "fluid_particles": result.fluid_particles,
        "boundary_particles": result.boundary_particles,
        "steps": result.steps,
        "simulated_ms": 1e3 * result.simulated_time,
        "wall_s": result.wall_seconds,
        "wall_s_per_simulated_ms": result.wall_seconds / max(1e3 * result.simulated_time, 1e-12),
        "key": result.key,
    }


def _shapes(runs: pd.DataFrame, jet: JetConfig) -> pd.DataFrame:
    """Each reference shape: thin-sheet model, SPH mean (finest DFSPH), WCSPH peak, the paper."""
    rows = []
    ok = runs[runs["status"] == "ok"]
    for name, build in SHAPES.items():
        sheet = surface_force(build(), jet)
        dfsph = ok[(ok["shape"] == name) & (ok["method"] == "dfsph")].sort_values("radius_mm")
        wcsph = ok[(ok["shape"] == name) & (ok["method"] == "wcsph")].sort_values(
            ["sound_speed_m_s", "radius_mm"]
        )
        fine = dfsph.iloc[0] if len(dfsph) else None
        peak = wcsph.iloc[0] if len(wcsph) else None
        rows.append(
            {
                "shape": name,
                "thin_sheet_N": sheet.axial_force,
                "thin_sheet_fx_N": sheet.force[0],
                "thin_sheet_fy_N": sheet.force[1],
                "sph_mean_N": np.nan if fine is None else fine["mean_N"],
                "sph_radius_mm": np.nan if fine is None else fine["radius_mm"],
                "wcsph_peak_N": np.nan if peak is None else peak["peak_N"],
                "wcsph_sound_speed_m_s": np.nan if peak is None else peak["sound_speed_m_s"],
                "wcsph_radius_mm": np.nan if peak is None else peak["radius_mm"],
                "rho_q_v_N": jet.momentum_flux,
                "paper_N": PAPER_SPH_FORCES[name],
            }
        )
    return pd.DataFrame(rows)


def _cached_surface_force(
    surface: Any, jet: JetConfig, settings: Any, *, cache_dir: str, timeout: float | None = None
) -> Any:
    """:func:`~replication.casestudy.sph.surface_sph_force` through the SPH cache (a module-level
    function: a process pool's workers take it by reference)."""
    from replication.casestudy.sph_batch import cached_sph_force

    return cached_sph_force(
        surface.points, surface.triangles, jet, settings, cache_dir=cache_dir, timeout=timeout
    )


def _cache_hits(plan: Sequence[Run], surfaces: dict[str, Any], config: SPHStudyConfig, cache_dir: Any) -> int:
    """The study's simulations that the cache will give as they are (before any is run)."""
    from replication.casestudy.sph_batch import cache_key, read_entry, reusable

    hits = 0
    for run in plan:
        surface = surfaces[run.shape]
        settings = run.settings(config.duration, config.jet.velocity)
        key = cache_key(surface.points, surface.triangles, config.jet, settings)
        hits += reusable(read_entry(cache_dir, key), config.timeout)
    return hits


def run_sph_study(
    config: SPHStudyConfig,
    *,
    command: str | None = None,
    quick: bool = False,
    on_run: Callable[[str], None] | None = None,
    score: Callable[..., Any] | None = None,
    executor: cf.Executor | None = None,
    max_parallel: int = 1,
    cache_dir: str | os.PathLike[str] | None = None,
) -> SPHStudyResults:
    """Run every simulation of the study and tabulate.

    Parameters
    ----------
    config : SPHStudyConfig
    command : str, optional
        The invocation recorded in the provenance.
    quick : bool
        Whether this is a reduced smoke-test run (stated in the report).
    on_run : callable, optional
        Called with a run's label when it has finished (progress display).
    score : callable, optional
        Replaces :func:`~replication.casestudy.sph.surface_sph_force` (same signature; with a
        process pool, a module-level function).
    executor : concurrent.futures.Executor, optional
        Where the simulations are driven from (a process pool, see
        :func:`replication.casestudy.evaluate.executor`); default: one after another here.
    max_parallel : int
        Simulations at once. Each uses one core (one engine thread, so its result does not
        depend on what runs beside it); the finest particles go first, so that the longest
        simulations do not come last.
    cache_dir : path, optional
        The SPH cache (:mod:`replication.casestudy.sph_batch`): simulations found there are
        not run again, and each one finished is kept there at once, so a study stopped by
        Ctrl-C loses none of them. None: no cache. Ignored when ``score`` is given.

    Notes
    -----
    Paper section 6: the forces 21.96 N (flat) and 19.08 N (bucket) from DualSPHysics.
    """
    from replication.casestudy.evaluate import SerialExecutor, run_bounded
    from replication.casestudy.sph import SPHSettings, engine_version, surface_sph_force

    if isinstance(max_parallel, bool) or not isinstance(max_parallel, int) or max_parallel < 1:
        raise InputError(f"max_parallel must be a positive integer, got {max_parallel!r}")
    through_cache = score is None and cache_dir is not None
    plan = config.runs()
    surfaces = {name: SHAPES[name]() for name in {run.shape for run in plan}}  # built once each
    velocity = config.jet.velocity
    hits = 0
    if through_cache:
        from replication.casestudy.sph_batch import prepare_cache

        prepare_cache(cache_dir)  # (the scratch a killed study left is removed)
        hits = _cache_hits(plan, surfaces, config, cache_dir)
        score = functools.partial(_cached_surface_force, cache_dir=str(cache_dir))
    score = score or surface_sph_force
    pool = executor if executor is not None else SerialExecutor()
    started = time.perf_counter()
    results: dict[int, Any] = {}

    def finished(k: int, future: cf.Future) -> None:
        results[k] = future.result()
        if on_run is not None:
            on_run(plan[k].label)

    timed = functools.partial(score, timeout=config.timeout)
    tasks = [
        (k, timed, (surfaces[plan[k].shape], config.jet, plan[k].settings(config.duration, velocity)))
        for k in sorted(range(len(plan)), key=lambda k: plan[k].radius)  # finest (longest) first
    ]
    run_bounded(pool, tasks, max_parallel, finished)
    rows, series = [], []
    for k, run in enumerate(plan):
        result = results[k]
        rows.append(_row(run, result, config.jet))
        for t, (fx, fy, fz) in zip(result.time, result.force):
            series.append(
                {
                    "shape": run.shape,
                    "method": run.method,
                    "radius_mm": 1e3 * run.radius,
                    "sound_speed_m_s": rows[-1]["sound_speed_m_s"],
                    "t_start_ms": 1e3 * t,
                    "t_end_ms": 1e3 * (t + result.settings.bin_width),
                    "fx_N": fx,
                    "fy_N": fy,
                    "fz_N": fz,
                    "axial_N": -fz,
                }
            )
    runs = pd.DataFrame(rows)
    from replication.experiments.sph_claims import hypotheses

    shapes = _shapes(runs, config.jet)
    record = provenance(
        command,
        experiment="sph",
        quick=quick,
        config=config.as_dict(),
        engine=engine_version(),
        sph_settings=SPHSettings().as_dict(),
        seeds="none (deterministic: one engine thread)",
        run_seconds=time.perf_counter() - started,
        simulation_seconds=float(runs["wall_s"].sum()),
        simulations_at_once=max_parallel,
        **({"sph_cache": str(cache_dir), "sph_cache_hits": hits} if through_cache else {}),
    )
    return SPHStudyResults(
        config=config,
        runs=runs,
        series=pd.DataFrame(series),
        shapes=shapes,
        hypotheses=hypotheses(runs, shapes, config.jet),
        provenance=record,
    )
