"""The jet-model validation study: the thin-sheet model against SPH on the GA's own surfaces.

Issue: the GA optimises the thin-sheet model's force, so its result means something only
if the model ranks surfaces as a converged SPH simulation does. The study

1. builds the surfaces of :mod:`.jet_surfaces` (plates, cups, the GA's winners, random
   lattice surfaces);
2. runs a **resolution study**: a few surfaces spanning the range at several particle radii,
   to show whether the SPH ranking and forces have converged at the radius then used;
3. scores **every surface** with SPH at that radius (SPlisHSPlasH, cached on disk by
   content, see :mod:`replication.casestudy.sph_batch`) and with the thin-sheet model;
4. tabulates per surface, and the rank agreement (:mod:`.rank_stats`) overall and by family.

Nothing here writes a file but the SPH cache's entries; the tables go to the report layer.
"""

from __future__ import annotations

import concurrent.futures as cf
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from replication.casestudy.ga import GAConfig
from replication.casestudy.jet import jet_force
from replication.casestudy.jetconfig import JetConfig
from replication.errors import InputError
from replication.experiments.jet_surface_set import study_surfaces
from replication.experiments.jet_surfaces import MAX_INCLINATION_DEG, StudySurface
from replication.provenance import provenance

__all__ = ["ValidationConfig", "ValidationResults", "model_scores", "run_validation"]


@dataclass(frozen=True)
class ValidationConfig:
    """What the validation study simulates (SI units for the SPH settings, mm for shapes).

    Attributes
    ----------
    radius : float
        Particle radius (m) at which every surface is scored.
    resolution_radii : tuple of float
        Radii (m) of the resolution study (``radius`` among them).
    resolution_surfaces : tuple of str
        Names of the surfaces of the resolution study.
    duration : float
        Simulated time (s) of each simulation.
    settle_time : float
        The averaging window starts this long after the jet reaches the surface (s): the
        sheet on a spiky surface takes about 10 ms to settle (its cavities fill).
    angles_deg, bowl_depths_mm : tuple of float
        Inclined plates and smooth bowls.
    random_surfaces : int
        Random lattice surfaces, seeded ``[seed, i]``.
    seed : int
        Seeds the random surfaces, the bootstrap and the calibration split.
    ga : GAConfig or None
        The thin-sheet GA whose winners are scored (None: no GA winners).
    ga_top : int
        Distinct winners taken from each GA run.
    repeat_surfaces : tuple of str
        Surfaces simulated again moved by ``repeat_shift_mm`` along x (the SPH noise floor,
        :mod:`.jet_repeatability`): a random lattice and a GA winner, the families whose
        close scores the ranking must separate (two simulations: what the study's time allowed).
    repeat_shift_mm : float
        That shift (mm): half a particle radius at the study's resolution.
    bootstrap : int
        Bootstrap resamples of the rank correlations.
    timeout : float
        Wall-clock limit of one simulation (s).
    jet : JetConfig
        The paper's half jet.
    """

    radius: float = 0.5e-3
    resolution_radii: tuple[float, ...] = (1.0e-3, 0.75e-3, 0.5e-3)
    resolution_surfaces: tuple[str, ...] = (
        "flat plate", "Pelton bucket", "random 00", "random 01", "GA run 0 #1", "GA run 1 #1",
    )  # fmt: skip
    duration: float = 0.024
    settle_time: float = 0.010
    angles_deg: tuple[float, ...] = (5.0, 10.0, MAX_INCLINATION_DEG)
    bowl_depths_mm: tuple[float, ...] = (6.5, 13.0)
    random_surfaces: int = 15
    seed: int = 11
    ga: GAConfig | None = GAConfig()
    ga_top: int = 5
    repeat_surfaces: tuple[str, ...] = ("random 00", "GA run 0 #1")
    repeat_shift_mm: float = 0.25
    bootstrap: int = 10_000
    timeout: float = 3600.0
    jet: JetConfig = JetConfig()

    def __post_init__(self) -> None:
        radii = (self.radius, *self.resolution_radii)
        if any(not (0.1e-3 <= r <= 5e-3) for r in radii):
            raise InputError(
                f"particle radii must lie between 0.1 and 5 mm, got {[1e3 * r for r in radii]} mm"
            )
        if self.resolution_radii and self.radius not in self.resolution_radii:
            raise InputError(
                f"the study radius {1e3 * self.radius:g} mm must be one of the resolution study's radii "
                f"{[1e3 * r for r in self.resolution_radii]} mm"
            )
        for name in ("random_surfaces", "ga_top", "bootstrap", "seed"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise InputError(f"{name} must be a non-negative integer, got {value!r}")
        if self.jet.full_jet:
            raise InputError("the study uses the paper's half jet: JetConfig(full_jet=False)")
        if not (0 < self.repeat_shift_mm <= 2):
            raise InputError(f"repeat_shift_mm must lie in (0, 2] mm, got {self.repeat_shift_mm}")
        if self.ga is not None and self.ga.jet != self.jet:
            raise InputError("the GA's jet must be the study's jet")

    def settings(self, radius: float | None = None) -> Any:
        """SPH settings of a simulation at ``radius`` (default: the study radius)."""
        from replication.casestudy.sph import SPHSettings

        return SPHSettings(
            particle_radius=self.radius if radius is None else radius,
            duration=self.duration,
            settle_time=self.settle_time,
        )

    @classmethod
    def quick(cls) -> ValidationConfig:
        """CI-sized: three surfaces (flat plate, bucket, one random), coarse particles, 14 ms."""
        return cls(
            radius=1.25e-3, resolution_radii=(1.5e-3, 1.25e-3), duration=0.014, settle_time=0.006,
            resolution_surfaces=("flat plate", "Pelton bucket", "random 00"),
            angles_deg=(), bowl_depths_mm=(), random_surfaces=1, ga=None, bootstrap=1000, timeout=600.0,
            repeat_surfaces=("random 00",), repeat_shift_mm=0.6,
        )  # fmt: skip

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        if self.ga is not None:
            d["ga"] = self.ga.as_dict()
        return d


@dataclass(frozen=True, eq=False)
class ValidationResults:
    """Raw and summarised results of the validation study."""

    config: ValidationConfig
    surfaces: pd.DataFrame  # one row per surface: family, model and SPH forces, ratio
    resolution: pd.DataFrame  # one row per (surface, radius) of the resolution study
    convergence: pd.DataFrame  # rank agreement between radii of the resolution study
    agreement: pd.DataFrame  # rank agreement model vs SPH: overall and per family
    vertices: pd.DataFrame  # surface, x, y, z (mm)
    triangles: pd.DataFrame  # surface, a, b, c
    series: pd.DataFrame  # binned SPH force of every study-radius simulation
    repeatability: pd.DataFrame  # surfaces simulated again shifted by a fraction of a particle
    noise: pd.DataFrame  # the SPH noise floor and the Spearman it allows
    provenance: dict[str, Any] = field(default_factory=dict)
    # the surrogate (item 2): None when too few surfaces have an SPH score to fit it
    surrogate_surfaces: pd.DataFrame | None = None
    surrogate_params: pd.DataFrame | None = None
    surrogate_agreement: pd.DataFrame | None = None
    departures: pd.DataFrame | None = None


def _sph_row(scored: Any, jet: JetConfig) -> dict[str, Any]:
    r = scored.result
    nan = float("nan")
    ok = scored.ok
    return {
        "sph_status": scored.status,
        "sph_reason": scored.reason or "",
        "sph_N": r.mean_axial if ok else nan,
        "sph_over_rho_q_v": r.mean_axial / jet.momentum_flux if ok else nan,
        "sph_over_measured_flux": r.mean_axial / r.measured_momentum_flux if ok else nan,
        "sph_std_N": r.std_axial if ok else nan,
        "sph_drift": _drift(r) / r.measured_momentum_flux if ok else nan,
        "sph_fx_N": r.mean_force[0] if ok else nan,
        "sph_peak_N": r.peak_axial if ok else nan,
        "sph_mass_flow_ratio": r.mass_flow / jet.mass_flow if r is not None else nan,
        "sph_fluid_particles": r.fluid_particles if r is not None else None,
        "sph_boundary_particles": r.boundary_particles if r is not None else None,
        "sph_steps": r.steps if r is not None else 0,
        "sph_simulated_ms": 1e3 * r.simulated_time if r is not None else 0.0,
        "sph_wall_s": r.wall_seconds if r is not None else nan,
        "sph_cached": scored.cached,
        "sph_key": scored.key,
    }


def _rekeyed(cache_dir: str | Path, key: Any) -> bool:
    """Whether the cache entry was simulated by earlier SPH code and kept under today's key."""
    from replication.casestudy.sph_batch import entry_path

    return isinstance(key, str) and (entry_path(cache_dir, key) / "rekeyed.json").is_file()


def _drift(result: Any) -> float:
    """Mean axial force of the second half of the averaging window minus that of the first (N):
    how far from steady the flow still is."""
    a, b = result.window
    mid = (a + b) / 2
    width = result.settings.bin_width
    start = result.time
    axial = -result.force[:, 2]
    first = axial[(start >= a - 1e-12) & (start + width <= mid + 1e-12)]
    second = axial[(start >= mid - 1e-12) & (start + width <= b + 1e-12)]
    if first.size == 0 or second.size == 0:
        return float("nan")
    return float(second.mean() - first.mean())


def _geometry(surfaces: Sequence[StudySurface]) -> tuple[pd.DataFrame, pd.DataFrame]:
    v = [pd.DataFrame(s.points, columns=["x_mm", "y_mm", "z_mm"]).assign(surface=s.name) for s in surfaces]
    t = [pd.DataFrame(s.triangles, columns=["a", "b", "c"]).assign(surface=s.name) for s in surfaces]
    cols_v, cols_t = ["surface", "x_mm", "y_mm", "z_mm"], ["surface", "a", "b", "c"]
    return pd.concat(v, ignore_index=True)[cols_v], pd.concat(t, ignore_index=True)[cols_t]


def model_scores(surfaces: Sequence[StudySurface], jet: JetConfig) -> pd.DataFrame:
    """The thin-sheet model's force on every surface (the GA's fitness)."""
    rows = []
    for s in surfaces:
        f = jet_force(s.points, s.triangles, jet)
        rows.append({
            "surface": s.name, "model_N": f.axial_force,
            "model_over_rho_q_v": f.axial_force / jet.momentum_flux,
            "model_hit_fraction": f.mass_flow_hit / f.mass_flow_total, "model_parcels": f.n_parcels,
        })  # fmt: skip
    return pd.DataFrame(rows)


def run_validation(
    config: ValidationConfig,
    *,
    cache_dir: str | Path,
    executor: cf.Executor | None = None,
    max_parallel: int = 2,
    ga_run_dir: str | Path | None = None,
    ga_pool_factory: Any = None,
    retry_failed: bool = False,
    simulate_missing: bool = True,
    rebuild_surfaces: bool = False,
    on_result: Callable[[Any], None] | None = None,
    on_stage: Callable[[str, int], None] | None = None,
    command: str | None = None,
    quick: bool = False,
    simulate: Callable[..., Any] | None = None,
) -> ValidationResults:
    """Run the study: surfaces, resolution study, every surface by SPH and by the model.

    Parameters
    ----------
    config : ValidationConfig
    cache_dir : path
        The SPH cache (:mod:`replication.casestudy.sph_batch`); a rerun reuses its entries.
    executor : concurrent.futures.Executor, optional
        Where simulations run; at most ``max_parallel`` at once.
    ga_run_dir : path, optional
        Directory of another GA's runs (read when complete, else run there), whose winners
        are scored instead of those of the GA kept in the cache.
    rebuild_surfaces : bool
        Build the study's surfaces afresh instead of reading the set stored with the cache
        (:mod:`.jet_surface_set`).
    retry_failed, simulate_missing, simulate
        See :func:`~replication.casestudy.sph_batch.score_surfaces`.
    on_result : callable, optional
        Called with each :class:`~replication.casestudy.sph_batch.Scored` (progress).
    on_stage : callable, optional
        Called with a stage's description and its number of simulations before it starts.

    Notes
    -----
    Paper section 6: the force of the jet, which the paper computes with SPH.
    """
    from replication.casestudy.sph import engine_version
    from replication.casestudy.sph_batch import SurfaceTask, code_digest, score_surfaces
    from replication.experiments.jet_repeatability import repeat_table, shifted_jet, shifted_surface
    from replication.experiments.jet_surrogate import departures, fit_surrogate
    from replication.experiments.jet_validation_tables import (
        SPH_COLUMN,
        agreement_table,
        convergence_table,
        noise_table,
        series_frame,
    )

    started = time.perf_counter()
    surfaces, built_by = study_surfaces(
        config,
        cache_dir=cache_dir,
        ga_run_dir=ga_run_dir,
        pool_factory=ga_pool_factory,
        rebuild=rebuild_surfaces,
    )
    by_name = {s.name: s for s in surfaces}
    model = model_scores(surfaces, config.jet).set_index("surface")

    def score(
        chosen: Sequence[StudySurface], radius: float, stage: str, jet: JetConfig | None = None
    ) -> list[Any]:
        if on_stage is not None:
            on_stage(stage, len(chosen))
        return score_surfaces(
            [SurfaceTask(s.name, s.points, s.triangles) for s in chosen], config.settings(radius),
            jet=jet or config.jet, cache_dir=cache_dir, executor=executor, max_parallel=max_parallel,
            timeout=config.timeout, retry_failed=retry_failed, simulate_missing=simulate_missing,
            on_result=on_result, simulate=simulate,
        )  # fmt: skip

    resolution_rows = []
    chosen = [by_name[n] for n in config.resolution_surfaces]
    for radius in sorted(config.resolution_radii, reverse=True):
        label = f"resolution study, r = {1e3 * radius:g} mm"
        for s, scored in zip(chosen, score(chosen, radius, label)):
            row = {"surface": s.name, "family": s.family, "radius_mm": 1e3 * radius}
            row.update(model.loc[s.name].to_dict())
            resolution_rows.append(row | _sph_row(scored, config.jet))
    resolution = pd.DataFrame(resolution_rows)
    scored_all = score(surfaces, config.radius, f"every surface, r = {1e3 * config.radius:g} mm")
    rows = []
    for s, scored in zip(surfaces, scored_all):
        row = {"surface": s.name, "family": s.family, "stratum": s.stratum, "vertices": s.points.shape[0],
               "triangles": s.triangles.shape[0], "ga_fitness_N": s.ga_fitness}  # fmt: skip
        row.update(model.loc[s.name].to_dict())
        row.update(_sph_row(scored, config.jet))
        sph = row["sph_over_measured_flux"]
        row["model_over_sph"] = row["model_over_rho_q_v"] / sph if sph > 0 else float("nan")
        rows.append(row)
    table = pd.DataFrame(rows)
    table["sph_rekeyed"] = [_rekeyed(cache_dir, k) for k in table["sph_key"]]
    resolution["sph_rekeyed"] = [_rekeyed(cache_dir, k) for k in resolution["sph_key"]]
    unknown = [n for n in config.repeat_surfaces if n not in by_name]
    if unknown:
        raise InputError(f"repeat_surfaces {unknown} are not surfaces of the study")
    repeated = [by_name[n] for n in config.repeat_surfaces]
    moved = [shifted_surface(s, config.repeat_shift_mm) for s in repeated]
    jet_moved = shifted_jet(config.jet)
    label = f"repeatability: {len(moved)} surfaces shifted by {config.repeat_shift_mm:g} mm"
    scored_moved = score(moved, config.radius, label, jet=jet_moved)
    base = table.set_index("surface")
    pairs = [
        (s, base.loc[s.name], _sph_row(sc, jet_moved), float(base.loc[s.name, "model_over_rho_q_v"]),
         jet_force(m.points, m.triangles, jet_moved).axial_force / config.jet.momentum_flux)
        for s, m, sc in zip(repeated, moved, scored_moved)
    ]  # fmt: skip
    repeatability = repeat_table(pairs, SPH_COLUMN)
    vertices, triangles = _geometry(surfaces)
    rng = np.random.default_rng([config.seed, 1])
    surrogate = fit_surrogate(
        table, surfaces, config.jet, resamples=config.bootstrap, rng=np.random.default_rng([config.seed, 3]),
        split_seed=[config.seed, 2],
    ) or {}  # fmt: skip
    ga_seed = config.ga.seed if config.ga else "-"
    record = provenance(
        command,
        experiment="jet_validation",
        quick=quick,
        config=config.as_dict(),
        engine=engine_version(),
        sph_code_digest=code_digest(),
        surfaces_built_by=built_by,
        sph_cache=str(Path(cache_dir).resolve()),
        seeds=(
            f"random surface i: numpy default_rng([{config.seed}, i]); bootstrap: "
            f"default_rng([{config.seed}, 1]); GA run k: default_rng([{ga_seed}, k]); "
            f"calibration halves: default_rng([{config.seed}, 2]); surrogate bootstrap: "
            f"default_rng([{config.seed}, 3]); SPH deterministic (one thread)"
        ),
        run_seconds=time.perf_counter() - started,
        **_simulation_seconds(table, resolution),
    )
    return ValidationResults(
        config=config,
        surfaces=table,
        resolution=resolution,
        convergence=convergence_table(resolution, config, rng=rng),
        agreement=agreement_table(table, config, rng=rng),
        vertices=vertices,
        triangles=triangles,
        series=series_frame(surfaces, scored_all),
        repeatability=repeatability,
        noise=noise_table(table, repeatability, rng=rng),
        provenance=record,
        departures=departures(table, surfaces),
        **surrogate,
    )


def _simulation_seconds(table: pd.DataFrame, resolution: pd.DataFrame) -> dict[str, float]:
    """Wall time of the distinct simulations: all of them, and those run by this invocation."""
    both = pd.concat([table, resolution], ignore_index=True)
    both = both.sort_values("sph_cached", kind="stable").drop_duplicates("sph_key")  # simulated here first
    return {
        "simulation_seconds": float(both.loc[~both["sph_cached"], "sph_wall_s"].sum()),
        "all_simulations_seconds": float(both["sph_wall_s"].sum()),
        "simulations": int(len(both)),
    }


def with_radius(config: ValidationConfig, radius: float) -> ValidationConfig:
    """The same study at another particle radius (the resolution study's radii unchanged)."""
    return replace(config, radius=radius)
