"""The surrogate of the validation study: the thin-sheet model with losses, fitted on half.

Issue 11, item 2. The model's :class:`~replication.casestudy.losses.SheetLosses` (speed lost
at concave creases and at re-impacts) are fitted to SPH on the calibration half of the
study's surfaces (:func:`~.surrogate.split_halves`, seeded and stratified) and judged on the
held-out half, which the fit never sees. Beside it, the features of each surface that the
model's excess over SPH follows are tabulated (where the model departs from SPH).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from replication.casestudy.jet import jet_force
from replication.casestudy.jetconfig import JetConfig
from replication.casestudy.losses import SheetLosses
from replication.experiments.jet_surfaces import StudySurface
from replication.experiments.jet_validation_tables import SPH_COLUMN
from replication.experiments.rank_stats import spearman
from replication.experiments.surrogate import (
    CALIBRATION,
    calibrate,
    judge,
    parameter_frame,
    split_halves,
    surrogate_table,
)

__all__ = ["GRID", "MEANINGS", "departures", "fit_surrogate"]

#: The fit's grid (each axis starts at today's model, no loss); refined about its best.
GRID = {"crease": (0.0, 0.25, 0.5, 1.0, 2.0, 4.0), "reimpact": (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)}
MEANINGS = {
    "crease": "speed x max(0, 1 - crease (1 - cos turn)) across a concave crease",
    "reimpact": "fraction of the speed lost at a re-impact",
}


def _force(jet: JetConfig) -> Any:
    def force(points: np.ndarray, triangles: np.ndarray, params: dict[str, float]) -> float:
        return jet_force(points, triangles, jet, losses=SheetLosses(**params)).axial_force / jet.momentum_flux

    return force


def fit_surrogate(
    table: pd.DataFrame,
    surfaces: Sequence[StudySurface],
    jet: JetConfig,
    *,
    resamples: int,
    rng: int | np.random.Generator | None,
    split_seed: Any,
) -> dict[str, pd.DataFrame] | None:
    """Fit on the calibration half, judge on the held-out half; None with too few SPH scores.

    Returns the tables ``surrogate_surfaces``, ``surrogate_params``, ``surrogate_agreement``
    (scopes held out, calibration, all; Spearman, Kendall with bootstrap intervals, top-k).

    Notes
    -----
    Paper section 6 scores surfaces by SPH; the surrogate is judged by how it ranks them.
    """
    halves = split_halves(table, rng=split_seed)
    ok = table[table["sph_status"] == "ok"]
    cal = ok[ok["surface"].map(halves) == CALIBRATION]
    if len(cal) < 3:
        return None
    geometry = {s.name: (s.points, s.triangles) for s in surfaces}
    force = _force(jet)
    fit = calibrate([geometry[n] for n in cal["surface"]], cal[SPH_COLUMN].to_numpy(), force, dict(GRID))
    per_surface = surrogate_table(table, geometry, force, fit.params, halves)
    judged = judge(per_surface, halves, "surrogate_over_rho_q_v", resamples=resamples, rng=rng)
    return {
        "surrogate_surfaces": per_surface,
        "surrogate_params": parameter_frame(fit, MEANINGS),
        "surrogate_agreement": judged,
    }


def _tilt_deg(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)[np.asarray(triangles)]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return np.degrees(np.arccos(np.abs(n[:, 2]) / np.linalg.norm(n, axis=1)))


def departures(table: pd.DataFrame, surfaces: Sequence[StudySurface]) -> pd.DataFrame:
    """Spearman of per-surface features with the model's excess over SPH (model / SPH - 1)."""
    ok = table[table["sph_status"] == "ok"].set_index("surface")
    by = {s.name: s for s in surfaces if s.name in ok.index}
    names = list(by)
    excess = ok.loc[names, "model_over_sph"].to_numpy() - 1.0
    features = {
        "model force / rho Q V": (ok.loc[names, "model_over_rho_q_v"].to_numpy(), "the model's own score"),
        "sheet parcels traced": (
            ok.loc[names, "model_parcels"].to_numpy(dtype=np.float64),
            "parcels after re-impact splits (more: more re-impacts)",
        ),
        "relief (mm)": (np.array([np.ptp(by[n].points[:, 2]) for n in names]), "height range of the surface"),
        "mean facet tilt (deg)": (
            np.array([_tilt_deg(by[n].points, by[n].triangles).mean() for n in names]),
            "mean angle of the facets from the horizontal",
        ),
    }
    rows = []
    for name, (values, what) in features.items():
        rho = spearman(values, excess) if len(names) >= 3 and np.ptp(values) > 0 else float("nan")
        rows.append({"feature": name, "spearman_with_excess": rho, "n": len(names), "what": what})
    return pd.DataFrame(rows)
