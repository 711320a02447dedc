"""Rows and sentences of the validation report, every number read from the saved tables."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from replication.report.markdown import fmt, table

__all__ = [
    "AGREEMENT_HEADER",
    "GOAL",
    "NOISE_HEADER",
    "REPEAT_HEADER",
    "noise_rows",
    "resolution_limit",
    "sph_winners",
    "repeat_rows",
    "agreement_rows",
    "convergence_rows",
    "findings",
    "ga_versus_bucket",
    "resolution_rows",
    "surface_rows",
    "surrogate_section",
]

#: The surrogate's goal (issue 11): Spearman with SPH on the held-out half.
GOAL = 0.9
SPH = "sph_over_measured_flux"
AGREEMENT_HEADER = ["surfaces", "n", "Spearman [95 % CI]", "Kendall [95 % CI]", "top 3", "top 5", "top 10"]


def _linear_factor(coarse: float, fine: float) -> float:
    """The residual bound per unit of the last change, r1 / (r2 - r1) for the finest radius r1
    and the next r2 (the table's bounds and the findings' sentence both use it)."""
    return float(fine) / (float(coarse) - float(fine))


def _ci(value: Any, low: Any, high: Any) -> str:
    return f"{fmt(value, '.2f')} [{fmt(low, '.2f')}, {fmt(high, '.2f')}]"


def _top(r: pd.Series, k: int) -> str:
    if pd.isna(r.get(f"top{k}")):
        return "–"
    return f"{int(r[f'top{k}'])} of {k} (chance {r[f'top{k}_chance']:.1f})"


def agreement_rows(d: dict[str, Any], frame: pd.DataFrame | None = None) -> list[list[str]]:
    frame = d["agreement"] if frame is None else frame
    return [
        [r["scope"], fmt(r["n"], "int"), _ci(r["spearman"], r["spearman_low"], r["spearman_high"]),
         _ci(r["kendall"], r["kendall_low"], r["kendall_high"]), _top(r, 3), _top(r, 5), _top(r, 10)]
        for _, r in frame.iterrows()
    ]  # fmt: skip


def resolution_rows(d: dict[str, Any]) -> list[list[str]]:
    res = d["resolution"]
    if res.empty:
        return []
    wide = res.pivot_table(index="surface", columns="radius_mm", values=SPH, sort=False)
    radii = sorted(wide.columns, reverse=True)
    first = res.drop_duplicates("surface").set_index("surface")
    ranks = wide.rank(ascending=False)  # 1: the highest force at that radius
    rows = []
    for name in dict.fromkeys(res["surface"]):
        values = [wide.loc[name, r] if name in wide.index else np.nan for r in radii]
        last = values[-1] - values[-2] if len(values) >= 2 else np.nan
        bound = abs(last) * _linear_factor(radii[-2], radii[-1]) if len(values) >= 2 else np.nan
        rank = (
            f"{fmt(ranks.loc[name, radii[-2]], '.0f')} -> {fmt(ranks.loc[name, radii[-1]], '.0f')}"
            if len(radii) >= 2 and name in ranks.index
            else "–"
        )
        model = fmt(first.loc[name, "model_over_rho_q_v"], ".3f")
        rows.append([name, first.loc[name, "family"], model, *[fmt(v, ".3f") for v in values],
                     fmt(last, "+.3f"), rank, fmt(bound, ".3f")])  # fmt: skip
    return rows


def resolution_limit(d: dict[str, Any]) -> str:
    """The residual resolution error stated plainly: no radius finer than the study's was run."""
    conv, res = d["convergence"], d["resolution"]
    if len(conv) < 2 or res.empty:
        return ""
    radii = sorted(res["radius_mm"].unique())
    fine, coarse = radii[0], radii[1]
    row = conv[conv["radius_mm"] == coarse].iloc[0]
    return (
        f"**The limit of this study.** No radius finer than r = {fine:g} mm was simulated (0.4 mm costs "
        "about twice as much per simulation and did not fit the study's time), so the error left at "
        f"r = {fine:g} mm is not bounded by a further refinement: it is estimated from the last change, "
        f"{coarse:g} -> {fine:g} mm, per surface in the table above (force / flux V, the change, the "
        f"surface's rank among the {int(row['n'])} and the residual bound it implies if the force "
        f"converges only linearly in r). Over these surfaces that change is at most "
        f"{fmt(row['max_change'], '.3f')} (median {fmt(row['median_change'], '.3f')}), and the ranking at "
        f"{coarse:g} mm agrees with that at {fine:g} mm with Spearman "
        f"{_ci(row['spearman'], row['spearman_low'], row['spearman_high'])}. Differences between "
        "surfaces smaller than their residual bounds are within SPH's resolution error."
    )


def sph_winners(d: dict[str, Any], k: int = 5) -> str:
    """SPH's k best surfaces, and how many of them are GA winners."""
    s = d["surfaces"]
    ok = s[s["sph_status"] == "ok"].sort_values(SPH, ascending=False)
    if len(ok) < 2 * k:
        return ""
    top = ok.head(k)
    ga = ok[ok["family"] == "GA winner"]
    names = ", ".join(f"{r['surface']} ({fmt(r[SPH], '.3f')})" for _, r in top.iterrows())
    n_ga = int((top["family"] == "GA winner").sum())
    best_model = ok.loc[ok["model_over_rho_q_v"].idxmax()]
    rank = int((ok[SPH] > best_model[SPH]).sum()) + 1
    return (
        f"- **SPH's winners.** SPH's {k} best surfaces: {names}. GA winners among them: {n_ga} "
        f"(of {len(ga)} scored). The model's best surface, {best_model['surface']}, ranks "
        f"{rank} of {len(ok)} by SPH."
    )


def convergence_rows(d: dict[str, Any]) -> list[list[str]]:
    conv = d["convergence"]
    return [
        [f"r = {r['radius_mm']:g} mm", fmt(r["n"], "int"),
         _ci(r["spearman"], r["spearman_low"], r["spearman_high"]),
         _ci(r["kendall"], r["kendall_low"], r["kendall_high"]), fmt(r["max_change"], ".3f"),
         fmt(r["median_change"], ".3f"), fmt(r["model_spearman"], ".2f")]
        for _, r in conv.iterrows()
    ]  # fmt: skip


REPEAT_HEADER = ["surface", "family", "SPH", "SPH shifted", "change", "model", "model shifted", "change"]
NOISE_HEADER = [
    "surfaces", "n", "repeats", "noise of one SPH score", "largest change", "spread of the SPH scores",
    "best Spearman",
]  # fmt: skip


def repeat_rows(d: dict[str, Any]) -> list[list[str]]:
    rep = d.get("repeatability")
    if rep is None:
        return []
    return [
        [r["surface"], r["family"], fmt(r["sph"], ".3f"), fmt(r["sph_shifted"], ".3f"),
         fmt(r["sph_change"], "+.3f"), fmt(r["model"], ".3f"), fmt(r["model_shifted"], ".3f"),
         fmt(r["model_change"], "+.3f")]
        for _, r in rep.iterrows()
    ]  # fmt: skip


def noise_rows(d: dict[str, Any]) -> list[list[str]]:
    noise = d.get("noise")
    if noise is None:
        return []
    return [
        [r["scope"], fmt(r["n"], "int"), fmt(r["repeats"], "int"), fmt(r["sigma"], ".3f"),
         fmt(r["largest_change"], ".3f"), fmt(r["spread"], ".3f"), fmt(r["spearman_ceiling"], ".2f")]
        for _, r in noise.iterrows()
    ]  # fmt: skip


def surface_rows(d: dict[str, Any]) -> list[list[str]]:
    s = d["surfaces"]
    return [
        [r["surface"], r["family"], fmt(r["ga_fitness_N"], ".4g"), fmt(r["model_over_rho_q_v"], ".3f"),
         fmt(r[SPH], ".3f") if r["sph_status"] == "ok" else f"*{r['sph_status']}*",
         fmt(r["sph_std_N"] / r["sph_N"] * r[SPH], ".2f") if r["sph_status"] == "ok" else "–",
         fmt(r.get("sph_drift"), "+.2f"), fmt(r["model_over_sph"], ".2f"), fmt(r["sph_wall_s"], ".0f")]
        for _, r in s.iterrows()
    ]  # fmt: skip


def ga_versus_bucket(d: dict[str, Any]) -> dict[str, float]:
    """SPH and model scores of the bucket, the best GA winner and the best random surface."""
    s = d["surfaces"]
    ok = s[s["sph_status"] == "ok"]
    out: dict[str, float] = {}
    groups = {
        "bucket": ok[ok["surface"] == "Pelton bucket"],
        "ga": ok[ok["family"] == "GA winner"],
        "random": ok[ok["family"] == "random lattice"],
        "flat": ok[ok["surface"] == "flat plate"],
    }
    for label, rows in groups.items():
        out[f"{label}_sph"] = float(rows[SPH].max()) if len(rows) else math.nan
        out[f"{label}_model"] = float(rows["model_over_rho_q_v"].max()) if len(rows) else math.nan
        out[f"{label}_sph_median"] = float(rows[SPH].median()) if len(rows) else math.nan
    return out


def findings(d: dict[str, Any]) -> str:
    """The study's findings as bullet points, each number from the tables."""
    s = d["surfaces"]
    ok = s[s["sph_status"] == "ok"]
    overall = d["agreement"].iloc[0]
    lines = [
        f"- **Ranking.** Over the {int(overall['n'])} surfaces SPH scored, the thin-sheet model's ranking "
        "agrees with SPH's with Spearman "
        f"{_ci(overall['spearman'], overall['spearman_low'], overall['spearman_high'])} "
        f"and Kendall {_ci(overall['kendall'], overall['kendall_low'], overall['kendall_high'])}; "
        f"its top 5 share {_top(overall, 5)} with SPH's top 5."
    ]
    ratio = ok.groupby("family", sort=False)["model_over_sph"].agg(["min", "median", "max"])
    parts = [
        f"{f}: {fmt(r['median'], '.2f')} ({fmt(r['min'], '.2f')}-{fmt(r['max'], '.2f')})"
        for f, r in ratio.iterrows()
    ]
    lines.append(
        "- **Where the model departs.** Model / SPH by family, median (range): " + "; ".join(parts) + "."
    )
    g = ga_versus_bucket(d)
    if not math.isnan(g["ga_sph"]) and not math.isnan(g["bucket_sph"]):
        better = g["ga_sph"] > g["bucket_sph"]
        lines.append(
            f"- **The case study's claim.** By the thin-sheet model the GA's winners beat the bucket "
            f"({fmt(g['ga_model'], '.3f')} against {fmt(g['bucket_model'], '.3f')} rho Q V). By SPH the "
            f"best GA winner scores {fmt(g['ga_sph'], '.3f')} (median of the winners "
            f"{fmt(g['ga_sph_median'], '.3f')}) against "
            f"the bucket's {fmt(g['bucket_sph'], '.3f')} and the best random lattice surface's "
            f"{fmt(g['random_sph'], '.3f')}: "
            + (
                "**the GA's winners beat the bucket in SPH too**."
                if better
                else "**the GA's winners do not beat the bucket in SPH**: the GA has optimised the model's "
                "idealisation, not the force."
            )  # fmt: skip
        )
    winners = sph_winners(d)
    if winners:
        lines.append(winners)
    conv = d["convergence"]
    if len(conv) >= 2:
        coarse = conv.iloc[-2]
        lines.append(
            f"- **Resolution.** Between r = {coarse['radius_mm']:g} mm and the finest radius the SPH "
            f"ranking of the resolution study's {int(coarse['n'])} surfaces has Spearman "
            f"{fmt(coarse['spearman'], '.2f')}; "
            f"the largest change of force / flux V is {fmt(coarse['max_change'], '.3f')} (median "
            f"{fmt(coarse['median_change'], '.3f')}); no finer radius was simulated, so the error left "
            "at the finest radius is estimated from this change (the resolution study's residual bounds: "
            f"{_linear_factor(coarse['radius_mm'], conv.iloc[-1]['radius_mm']):.3g} times it, if the force "
            "converges only linearly in r)."
        )
    sur = d.get("surrogate_agreement")
    if sur is not None and len(sur):
        held = sur[sur["scope"] == "held out"].iloc[0]
        reached = held["spearman"] >= GOAL
        lines.append(
            f"- **Surrogate.** Calibrated on half of the surfaces, it ranks the held-out half with Spearman "
            f"{_ci(held['spearman'], held['spearman_low'], held['spearman_high'])} (goal {GOAL}): "
            + ("**goal reached**." if reached else "**goal not reached: SPH must be the fitness of record**.")
        )
    return "\n".join(lines)


def surrogate_section(d: dict[str, Any]) -> str:
    """The surrogate's section: departures by feature, parameters, held-out judgement."""
    sur, params, departures = d.get("surrogate_agreement"), d.get("surrogate_params"), d.get("departures")
    if sur is None or params is None:
        return ""
    param_rows = [[r["parameter"], fmt(r["value"], ".3g"), r["meaning"]] for _, r in params.iterrows()]
    dep = ""
    if departures is not None and len(departures):
        dep_rows = [[r["feature"], fmt(r["spearman_with_excess"], ".2f"), fmt(r["n"], "int"), r["what"]]
                    for _, r in departures.iterrows()]  # fmt: skip
        dep = (
            "Where the model departs from SPH, by feature (Spearman of each per-surface feature of the "
            "model's sheet with the excess model / SPH - 1, over all surfaces SPH scored; data: "
            "`data/jet_validation_departures.csv`):\n\n"
            + table(dep_rows, ["feature", "Spearman with the excess", "n", "what it counts"], "lrrl")
            + "\n\n"
        )
    return f"""## A surrogate that ranks like SPH?

{dep}Parameters calibrated on the calibration half (data: `data/jet_validation_surrogate_params.csv`; every
parameter at 0 is today's model exactly):

{table(param_rows, ["parameter", "value", "meaning"], "lrl")}

Judged on the held-out half with no tuning there (data: `data/jet_validation_surrogate_agreement.csv`,
`_surrogate_surfaces.csv`):

{table(agreement_rows(d, sur), AGREEMENT_HEADER)}
"""
