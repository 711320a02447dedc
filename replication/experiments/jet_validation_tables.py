"""Tables of the validation study: convergence of SPH with particle size, model-vs-SPH agreement.

Pure functions of the per-surface tables built by :mod:`.jet_validation`, so the report,
the surrogate's evaluation and the asv benchmark compute agreement the same way.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from replication.experiments.jet_surfaces import FAMILIES
from replication.experiments.rank_stats import rank_agreement, spearman, top_k_overlap
from replication.params import generator

__all__ = [
    "noise_table",
    "SPH_COLUMN",
    "TOP_K",
    "agreement_row",
    "agreement_table",
    "convergence_table",
    "residual_table",
    "series_frame",
]

#: The top-k agreements reported.
TOP_K = (3, 5, 10)
#: The SPH quantity compared: the quasi-steady mean axial force over the momentum flux of the
#: simulated jet (its measured mass flux times V). At one particle radius every surface gets the
#: same jet, so the ranking is that of the force; across radii it removes the error of the
#: particle lattice's mass flux (up to 10 % at coarse radii), and it is what the thin-sheet
#: model's force over rho Q V is.
SPH_COLUMN = "sph_over_measured_flux"


def agreement_row(
    scope: str,
    reference: np.ndarray,
    scoring: np.ndarray,
    *,
    resamples: int,
    rng: int | np.random.Generator | None,
) -> dict[str, Any]:
    """Spearman and Kendall with bootstrap intervals, and the top-k overlaps, of one scope.

    ``top_k`` counts how many of the k best surfaces by ``scoring`` are among the k best by
    ``reference``; ``top_k_chance`` is its expectation for a random ranking, k^2 / n.
    """
    rng = generator(rng)
    reference = np.asarray(reference, dtype=np.float64)
    scoring = np.asarray(scoring, dtype=np.float64)
    n = reference.size
    row: dict[str, Any] = {"scope": scope, "n": n}
    if n >= 3 and np.ptp(reference) > 0 and np.ptp(scoring) > 0:
        row.update(rank_agreement(scoring, reference, resamples=resamples, rng=rng).as_dict())
    else:
        row.update({k: np.nan for k in ("spearman", "spearman_low", "spearman_high", "kendall",
                                          "kendall_low", "kendall_high")})  # fmt: skip
    row["n"] = n
    for k in TOP_K:
        ok = n > 0 and 2 * k <= n  # a top-k overlap means something only among at least 2k surfaces
        row[f"top{k}"] = top_k_overlap(scoring, reference, k) if ok else np.nan
        row[f"top{k}_chance"] = k * k / n if ok else np.nan
    return row


def agreement_table(
    table: pd.DataFrame,
    config: Any,
    *,
    rng: int | np.random.Generator | None,
    column: str = "model_over_rho_q_v",
) -> pd.DataFrame:
    """Rank agreement of a scoring (default: the thin-sheet model) with SPH: all, families, spiky.

    Surfaces whose simulation failed are left out (and counted in the report).
    """
    rng = generator(rng)
    ok = table[table["sph_status"] == "ok"]
    scopes: list[tuple[str, pd.DataFrame]] = [("all surfaces", ok)]
    scopes += [(f"family: {f}", ok[ok["family"] == f]) for f in FAMILIES if (ok["family"] == f).any()]
    spiky = ok[ok["family"].isin(["GA winner", "random lattice"])]
    if 0 < len(spiky) < len(ok):
        scopes.append(("GA winners and random lattices", spiky))
    return pd.DataFrame(
        [
            agreement_row(
                scope,
                part[SPH_COLUMN].to_numpy(),
                part[column].to_numpy(),
                resamples=config.bootstrap,
                rng=rng,
            )
            for scope, part in scopes
            if len(part) or scope == "all surfaces"
        ]
    )


def convergence_table(
    resolution: pd.DataFrame, config: Any, *, rng: int | np.random.Generator | None
) -> pd.DataFrame:
    """Each radius of the resolution study against the finest: ranking and force changes.

    Rows: one per radius, with the Spearman and Kendall of its SPH ranking against that of
    the finest radius, the largest and median change of force / rho Q V against the finest,
    and the Spearman of the thin-sheet model against SPH at that radius.
    """
    rng = generator(rng)
    wide = resolution.pivot_table(index="surface", columns="radius_mm", values=SPH_COLUMN)
    if wide.empty:
        return pd.DataFrame(columns=["scope", "n", "radius_mm", "spearman", "max_change"])
    model = resolution.drop_duplicates("surface").set_index("surface")["model_over_rho_q_v"]
    radii = sorted(wide.columns, reverse=True)
    finest = radii[-1]
    rows = []
    for r in radii:
        both = pd.DataFrame({"r": wide[r], "finest": wide[finest]}).dropna()
        change = (both["r"] - both["finest"]).abs()
        row = agreement_row(f"r = {r:g} mm vs {finest:g} mm", both["finest"].to_numpy(), both["r"].to_numpy(),
                            resamples=config.bootstrap, rng=rng)  # fmt: skip
        at_r = wide[r].dropna()
        row.update({
            "radius_mm": r, "max_change": change.max() if len(change) else np.nan,
            "median_change": change.median() if len(change) else np.nan,
            "model_spearman": spearman(at_r.to_numpy(), model[at_r.index].to_numpy()) if len(at_r) >= 3
            else np.nan,
        })  # fmt: skip
        rows.append(row)
    return pd.DataFrame(rows)


def residual_table(resolution: pd.DataFrame) -> pd.DataFrame:
    """Per surface: force / rho Q V at each radius, the last change and a residual-error bound.

    The residual at the finest radius r1 is bounded by first-order extrapolation in r from
    the two finest radii r1 < r2: |F(r1) - F(r2)| r1 / (r2 - r1). Where the changes shrink
    faster than first order (the flat plate and the bucket of the SPH study do), this
    overestimates the error.
    """
    wide = resolution.pivot_table(index="surface", columns="radius_mm", values=SPH_COLUMN)
    if wide.empty:
        return pd.DataFrame()
    radii = sorted(wide.columns)
    out = wide.rename(columns=lambda r: f"r{r:g}")
    if len(radii) >= 2:
        r1, r2 = radii[0], radii[1]
        last = wide[r1] - wide[r2]
        out["last_change"] = last
        out["residual_bound"] = last.abs() * r1 / (r2 - r1)
    family = resolution.drop_duplicates("surface").set_index("surface")["family"]
    return out.assign(family=family).reset_index()


def noise_table(
    table: pd.DataFrame, repeatability: pd.DataFrame, *, rng: int | np.random.Generator | None
) -> pd.DataFrame:
    """The SPH noise floor and the Spearman it allows a perfect model, overall and for the spiky.

    ``sigma`` is the noise of one SPH score: the standard deviation of the changes of the
    repeated (shifted) runs over sqrt(2) (the root mean square, so that a change's sign does
    not matter). ``spread`` is the standard deviation of the SPH scores themselves.
    """
    rng = generator(rng)
    from replication.experiments.jet_repeatability import noise_ceiling

    changes = repeatability.loc[repeatability["status_shifted"] == "ok", "sph_change"].dropna().to_numpy()
    sigma = float(np.sqrt(np.mean(changes**2) / 2)) if changes.size else float("nan")
    ok = table[table["sph_status"] == "ok"]
    rows = []
    for scope, part in (
        ("all surfaces", ok),
        ("GA winners and random lattices", ok[ok["family"].isin(["GA winner", "random lattice"])]),
    ):
        values = part[SPH_COLUMN].to_numpy()
        rows.append({
            "scope": scope, "n": len(values), "repeats": int(changes.size), "sigma": sigma,
            "largest_change": float(np.abs(changes).max()) if changes.size else float("nan"),
            "spread": float(np.std(values, ddof=1)) if len(values) > 1 else float("nan"),
            "spearman_ceiling": noise_ceiling(values, sigma, rng=rng),
        })  # fmt: skip
    return pd.DataFrame(rows)


def series_frame(surfaces: Sequence[Any], scored: Sequence[Any]) -> pd.DataFrame:
    """The binned axial SPH force of every simulated surface (long format)."""
    rows = []
    for s, sc in zip(surfaces, scored):
        r = sc.result
        if r is None:
            continue
        width = r.settings.bin_width
        for t, f in zip(r.time.tolist(), r.force.tolist()):
            rows.append({"surface": s.name, "family": s.family, "t_start_ms": 1e3 * t,
                         "t_end_ms": 1e3 * (t + width), "axial_N": -f[2]})  # fmt: skip
    return pd.DataFrame(rows, columns=["surface", "family", "t_start_ms", "t_end_ms", "axial_N"])
