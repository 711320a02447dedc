"""How repeatable an SPH score is: the noise floor below which no ranking means anything.

One thread makes a simulation bit-for-bit repeatable, but not robust: a perturbation far
below any design change - the surface moved by a fraction of a particle spacing along x,
relative to the jet and to the fluid's particle lattice - changes the splashing flow and its
mean force. The study simulates a few surfaces shifted so and compares; the spread of the
differences is the SPH scores' noise. From it, the best Spearman any model could reach
against these SPH scores is estimated by simulation: rank the scores against themselves
with that noise added.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import pandas as pd

from replication.casestudy.jetconfig import JetConfig
from replication.experiments.jet_surfaces import StudySurface
from replication.experiments.rank_stats import spearman
from replication.params import generator

__all__ = ["SHIFTED", "noise_ceiling", "repeat_table", "shifted_jet", "shifted_surface"]

#: Suffix of a shifted copy's name.
SHIFTED = " (shifted)"


def shifted_surface(surface: StudySurface, shift_mm: float) -> StudySurface:
    """The surface moved by ``shift_mm`` along x (the jet stays where it was)."""
    points = np.array(surface.points, dtype=np.float64)
    points[:, 0] += shift_mm
    return replace(surface, name=surface.name + SHIFTED, points=points)


def shifted_jet(jet: JetConfig) -> JetConfig:
    """The jet for shifted copies: no domain (a shifted surface may cross its edge)."""
    return replace(jet, domain=None)


def repeat_table(pairs: Sequence[tuple[StudySurface, Any, Any, float, float]], column: str) -> pd.DataFrame:
    """Per surface: SPH and model force / flux V as it is and shifted, and the differences.

    ``pairs``: (surface, its SPH row, the shifted copy's SPH row, model, shifted model).
    """
    rows = []
    for surface, base, moved, model, model_moved in pairs:
        rows.append({
            "surface": surface.name, "family": surface.family,
            "sph": base[column], "sph_shifted": moved[column], "sph_change": moved[column] - base[column],
            "model": model, "model_shifted": model_moved, "model_change": model_moved - model,
            "status_shifted": moved["sph_status"],
        })  # fmt: skip
    return pd.DataFrame(rows)


def noise_ceiling(
    values: np.ndarray, sigma: float, *, rng: int | np.random.Generator | None, draws: int = 2000
) -> float:
    """Median Spearman of scores against themselves plus noise of standard deviation ``sigma``.

    Notes
    -----
    With ``sigma`` the noise of one score, a perfect model's Spearman against SPH cannot be
    expected above this; the differences of repeated runs carry the noise of two scores,
    so ``sigma`` is their standard deviation over sqrt(2).
    """
    values = np.asarray(values, dtype=np.float64)
    if values.size < 3 or not np.isfinite(sigma):
        return float("nan")
    rng = generator(rng)
    noisy = values + rng.normal(0.0, sigma, size=(draws, values.size))
    return float(np.median(spearman(noisy, np.broadcast_to(values, noisy.shape))))
