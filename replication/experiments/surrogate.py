"""A surrogate that ranks like SPH: the thin-sheet model with losses, calibrated on half the surfaces.

Issue 11, item 2. The validation study's surfaces are split in two halves, seeded and
stratified (every stratum - plates, cups, the winners of each GA run, random lattices - in
both halves, in proportion). The loss parameters of the model (:class:`SheetLosses`) are
fitted on the calibration half only; the held-out half is then scored once, with no tuning,
and judged by Spearman and Kendall with SPH (bootstrap intervals) and by its top-k.

The fit minimises the spread of log(SPH / surrogate) over the calibration half, that is the
squared error of the forces up to one common factor: rankings do not depend on that factor,
and SPH's flat plate sits a few per cent above rho Q V at the study's resolution, which a
loss cannot and should not absorb.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from replication.errors import InputError
from replication.experiments.jet_validation_tables import SPH_COLUMN, agreement_row
from replication.params import generator

__all__ = [
    "CALIBRATION",
    "HELD_OUT",
    "Calibration",
    "calibrate",
    "judge",
    "split_halves",
]

CALIBRATION, HELD_OUT = "calibration", "held out"

#: Force function: (points mm, triangles, parameter values) -> force / rho Q V.
ForceFunction = Callable[[np.ndarray, np.ndarray, dict[str, float]], float]


def split_halves(table: pd.DataFrame, *, rng: int | np.random.Generator | None) -> pd.Series:
    """A seeded split of the surfaces into a calibration and a held-out half, by stratum.

    Within each stratum (column ``stratum``) the surfaces are shuffled and the first half
    (rounded up and down in turn across strata, so the halves differ by at most one surface)
    goes to calibration. A stratum of one surface goes to calibration.

    Returns
    -------
    pandas.Series
        ``CALIBRATION`` or ``HELD_OUT``, indexed by surface name.
    """
    rng = generator(rng)
    half = pd.Series(CALIBRATION, index=table["surface"].to_numpy(), dtype=object)
    up = True
    for _, group in table.groupby("stratum", sort=True):
        names = group["surface"].to_numpy()
        order = rng.permutation(names.size)
        n_cal = (names.size + (1 if up else 0)) // 2 if names.size > 1 else 1
        if names.size % 2:
            up = not up
        half[names[order[n_cal:]]] = HELD_OUT
    return half


@dataclass(frozen=True)
class Calibration:
    """The fitted parameters, the objective there, and the grid it was found on."""

    params: dict[str, float]
    objective: float  # standard deviation of log(SPH / surrogate) on the calibration half
    scale: float  # exp(mean log(SPH / surrogate)): the common factor the fit leaves free
    evaluations: int


def _objective(sph: np.ndarray, surrogate: np.ndarray) -> tuple[float, float]:
    if np.any(surrogate <= 0):
        return np.inf, np.nan
    log_ratio = np.log(sph) - np.log(surrogate)
    return float(np.std(log_ratio)), float(np.exp(np.mean(log_ratio)))


def calibrate(
    surfaces: Sequence[tuple[np.ndarray, np.ndarray]],
    sph: Sequence[float],
    force: ForceFunction,
    grid: dict[str, Sequence[float]],
    *,
    refine: int = 2,
) -> Calibration:
    """Fit the loss parameters on the calibration half: a grid search, refined about its best.

    Parameters
    ----------
    surfaces : sequence of (points, triangles)
        The calibration half (mm).
    sph : sequence of float
        Their SPH force / flux V.
    force : callable
        The surrogate: (points, triangles, parameters) -> force / rho Q V.
    grid : dict
        Values of each parameter to try (every combination); the first value of each must be
        today's model (no loss), so the fit can never do worse than the model itself.
    refine : int
        Rounds of a finer grid (a third of the step) about the best point.
    """
    sph = np.asarray(sph, dtype=np.float64)
    if len(surfaces) != sph.size or sph.size < 3 or not np.all(sph > 0):
        raise InputError(f"need positive SPH values for at least 3 calibration surfaces, got {sph.size}")
    names = list(grid)
    axes = {k: np.unique(np.asarray(v, dtype=np.float64)) for k, v in grid.items()}
    cache: dict[tuple[float, ...], tuple[float, float]] = {}

    def score(point: tuple[float, ...]) -> tuple[float, float]:
        if point not in cache:
            params = dict(zip(names, point))
            values = np.array([force(p, t, params) for p, t in surfaces])
            cache[point] = _objective(sph, values)
        return cache[point]

    best = min(itertools.product(*(axes[k] for k in names)), key=lambda p: score(p)[0])
    for _ in range(refine):
        local = []
        for k, value in zip(names, best):
            steps = np.diff(axes[k])
            step = (steps.min() if steps.size else 0.0) / 3
            lo, hi = axes[k].min(), axes[k].max()
            local.append(np.unique(np.clip([value - step, value, value + step], lo, hi)))
            axes[k] = np.unique(np.concatenate([axes[k], local[-1]]))
        best = min(itertools.product(*local), key=lambda p: score(p)[0])
    objective, scale = score(best)
    return Calibration(dict(zip(names, (float(v) for v in best))), objective, scale, len(cache))


def judge(
    table: pd.DataFrame,
    halves: pd.Series,
    column: str,
    *,
    resamples: int,
    rng: int | np.random.Generator | None,
) -> pd.DataFrame:
    """Rank agreement of a scoring with SPH on the held-out half, the calibration half and all.

    Only surfaces SPH scored count. ``column`` holds the scoring (force / rho Q V).
    """
    rng = generator(rng)
    ok = table[table["sph_status"] == "ok"]
    rows = []
    for scope, part in (
        (HELD_OUT, ok[ok["surface"].map(halves) == HELD_OUT]),
        (CALIBRATION, ok[ok["surface"].map(halves) == CALIBRATION]),
        ("all surfaces", ok),
    ):
        rows.append(agreement_row(scope, part[SPH_COLUMN].to_numpy(), part[column].to_numpy(),
                                  resamples=resamples, rng=rng))  # fmt: skip
    return pd.DataFrame(rows)


def surrogate_table(
    table: pd.DataFrame, surfaces: dict[str, tuple[np.ndarray, np.ndarray]], force: ForceFunction,
    params: dict[str, float], halves: pd.Series,
) -> pd.DataFrame:  # fmt: skip
    """Per surface: its half, the model's and the surrogate's force / rho Q V, SPH's."""
    rows = []
    for _, r in table.iterrows():
        points, triangles = surfaces[r["surface"]]
        rows.append({
            "surface": r["surface"], "family": r["family"], "half": halves[r["surface"]],
            "model_over_rho_q_v": r["model_over_rho_q_v"],
            "surrogate_over_rho_q_v": force(points, triangles, params),
            SPH_COLUMN: r[SPH_COLUMN], "sph_status": r["sph_status"],
        })  # fmt: skip
    return pd.DataFrame(rows)


def parameter_frame(calibration: Calibration, meanings: dict[str, str]) -> pd.DataFrame:
    """The fitted parameters with their meaning, and the fit's spread and common factor."""
    rows = [
        {"parameter": k, "value": v, "meaning": meanings.get(k, "")} for k, v in calibration.params.items()
    ]
    rows.append({"parameter": "fit: spread of log(SPH / surrogate)", "value": calibration.objective,
                 "meaning": "on the calibration half (0: forces proportional)"})  # fmt: skip
    rows.append({"parameter": "fit: common factor SPH / surrogate", "value": calibration.scale,
                 "meaning": "left free by the fit; rankings do not depend on it"})  # fmt: skip
    return pd.DataFrame(rows)
