"""What the case study's numbers rest on: the fitness that produced them, and SPH beside them.

A section of ``casestudy.md`` and a line of the headline, both read from the validation
study's data (``data/jet_validation_*.csv``, written by ``replication validate-jet``) when
they are there. No claim about optimal shapes is left resting on the thin-sheet model alone:
where the study shows that SPH ranks the GA's winners differently, the section says so.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pandas as pd

from replication.report.markdown import fmt, table
from replication.report.store import read_csv

__all__ = ["OPTIMUM_CLAIM", "fitness_note", "validation_headline", "validation_section"]

#: The case study's claim about the GA's optimum (``casestudy_claims.csv``), which the model
#: alone cannot establish.
OPTIMUM_CLAIM = "neither the flat plate nor the bucket is the optimum"

SPH = "sph_over_measured_flux"
GOAL = 0.9


def _load(out: Path) -> dict[str, pd.DataFrame] | None:
    data = out / "data"
    # tables without their provenance (a save cut short, a removed file) are not drawn: unchecked
    if (
        not (data / "jet_validation_surfaces.csv").is_file()
        or not (data / "jet_validation_provenance.json").is_file()
    ):
        return None
    loaded = {"surfaces": read_csv(data / "jet_validation_surfaces.csv")}
    loaded["agreement"] = read_csv(data / "jet_validation_agreement.csv")
    path = data / "jet_validation_surrogate_agreement.csv"
    loaded["surrogate"] = read_csv(path) if path.is_file() else None
    return loaded


def _verdicts(d: dict[str, pd.DataFrame]) -> dict[str, Any]:
    s = d["surfaces"]
    ok = s[s["sph_status"] == "ok"]
    ga = ok[ok["family"] == "GA winner"]
    bucket = ok[ok["surface"] == "Pelton bucket"]
    flat = ok[ok["surface"] == "flat plate"]
    overall = d["agreement"].iloc[0]
    out = {
        "n": int(overall["n"]),
        "spearman": overall["spearman"], "low": overall["spearman_low"], "high": overall["spearman_high"],
        "top5": overall.get("top5"),
        "ga_sph": float(ga[SPH].max()) if len(ga) else math.nan,
        "ga_model": float(ga["model_over_rho_q_v"].max()) if len(ga) else math.nan,
        "bucket_sph": float(bucket[SPH].iloc[0]) if len(bucket) else math.nan,
        "bucket_model": float(bucket["model_over_rho_q_v"].iloc[0]) if len(bucket) else math.nan,
        "flat_sph": float(flat[SPH].iloc[0]) if len(flat) else math.nan,
        "best_sph": ok.loc[ok[SPH].idxmax(), "surface"] if len(ok) else None,
    }  # fmt: skip
    known = not (math.isnan(out["ga_sph"]) or math.isnan(out["bucket_sph"]))
    out["ga_beats_bucket_sph"] = bool(out["ga_sph"] > out["bucket_sph"]) if known else None
    sur = d.get("surrogate")
    held = None if sur is None else sur[sur["scope"] == "held out"]
    out["surrogate"] = None if held is None or held.empty else float(held.iloc[0]["spearman"])
    return out


def fitness_note(out_dir: str | Path, claim: str) -> str:
    """What to add to a claim's explanation: for the GA's optimum, which fitness decides it.

    The GA's verdict on its optimum is the thin-sheet model's; the note says so and gives
    what the validation study's SPH says of the GA's winners against the bucket, or that SPH
    has not checked it. Other claims get no note ("").
    """
    if claim != OPTIMUM_CLAIM:
        return ""
    d = _load(Path(out_dir))
    v = None if d is None else _verdicts(d)
    head = ". The verdict is the thin-sheet model's (the GA's fitness)"
    if v is None or v["ga_beats_bucket_sph"] is None:
        return head + "; SPH has not checked it (jet_validation.md): it holds for the model only."
    sph = "holds" if v["ga_beats_bucket_sph"] else "does not hold"
    return (
        f"{head}; by SPH it **{sph}**: best GA winner {v['ga_sph']:.2f}, bucket {v['bucket_sph']:.2f} "
        "x measured flux V (jet_validation.md)."
    )


def validation_headline(out_dir: str | Path) -> list[str]:
    """The headline line of the validation study, or nothing without its data."""
    d = _load(Path(out_dir))
    if d is None:
        return []
    v = _verdicts(d)
    surrogate = (
        ""
        if v["surrogate"] is None
        else f"; a surrogate calibrated on half of the surfaces ranks the other half with Spearman "
        f"{v['surrogate']:.2f} (goal {GOAL})"
        + ("" if v["surrogate"] >= GOAL else ", so SPH must be the fitness of record")
    )
    if v["ga_beats_bucket_sph"] is None:
        optimum = "; the study scored no GA winner against the bucket"
    elif v["ga_beats_bucket_sph"]:
        optimum = (
            f"; by SPH the GA's best winner ({v['ga_sph']:.2f} rho Q V) beats the bucket "
            f"({v['bucket_sph']:.2f}) too"
        )
    else:
        optimum = (
            f"; by SPH the GA's winners (at best {v['ga_sph']:.2f} rho Q V) do not beat the bucket "
            f"({v['bucket_sph']:.2f}): the optimum found is the model's, not the flow's"
        )
    return [
        f"- **Jet model checked against SPH** ({v['n']} surfaces): the thin-sheet model ranks surfaces like "
        f"SPH {_strength(v)}"
        f"{optimum}{surrogate}."
    ]


def _strength(v: dict[str, Any], interval: str = "an interval") -> str:
    """The rank agreement in words: Spearman's rho and its interval, "only weakly" when the
    interval reaches zero."""
    rho = f"Spearman {v['spearman']:.2f} [{v['low']:.2f}, {v['high']:.2f}]"
    if v["low"] <= 0:
        return f"only weakly, with {rho} ({interval} that includes no agreement)"
    return f"with {rho}" + ("" if interval == "an interval" else f" ({interval})")


def validation_section(out_dir: str | Path) -> str:
    """The section of ``casestudy.md``: which fitness made the numbers, and what SPH says of them."""
    out = Path(out_dir)
    d = _load(out)
    head = (
        "## Which fitness produced these numbers\n\n"
        "Every force in this report (the GA's history, its best surfaces, the reference shapes) is the "
        "**thin-sheet model's**, the fitness the GA maximised; the paper's numbers are DualSPHysics's. "
    )
    if d is None:
        return head + (
            "Whether the model ranks surfaces as an SPH simulation does is checked by `replication "
            "validate-jet` (jet_validation.md, not generated in this directory): until then, no claim about "
            "optimal shapes here rests on more than the model.\n"
        )
    v = _verdicts(d)
    s = d["surfaces"]
    ok = s[s["sph_status"] == "ok"]
    rows = []
    for name in ("flat plate", "Pelton bucket"):
        r = ok[ok["surface"] == name]
        if len(r):
            r = r.iloc[0]
            rows.append([name, fmt(r["model_over_rho_q_v"], ".3f"), fmt(r[SPH], ".3f")])
    for family in ("GA winner", "random lattice"):
        part = ok[ok["family"] == family]
        if len(part):
            model, sph = part["model_over_rho_q_v"], part[SPH]
            rows.append([
                f"{family}s ({len(part)}): best / median",
                f"{fmt(model.max(), '.3f')} / {fmt(model.median(), '.3f')}",
                f"{fmt(sph.max(), '.3f')} / {fmt(sph.median(), '.3f')}",
            ])  # fmt: skip
    if v["ga_beats_bucket_sph"] is None:
        claim = (
            "The study scored no GA winner against the bucket: it says nothing yet about the GA's optimum."
        )
    elif v["ga_beats_bucket_sph"]:
        claim = "By SPH the GA's best winner also beats the bucket: the optimum holds beyond the model."
    else:
        claim = (
            "**By SPH none of the GA's winners beats the bucket**: the GA has optimised the thin-sheet "
            "model's idealisation (a sheet kept at full speed through every sharp crease and re-impact), and "
            "the case study's result, that the GA finds surfaces better than the bucket, holds for the "
            "model only."
        )
    surrogate = ""
    if v["surrogate"] is not None:
        reached = v["surrogate"] >= GOAL
        surrogate = (
            f" A surrogate with the missing losses, calibrated on half of the surfaces, ranks the held-out "
            f"half with Spearman {v['surrogate']:.2f} (goal {GOAL}): "
            + (
                "it may stand in for SPH as the fitness."
                if reached
                else "**SPH must be the fitness of record**."
            )
        )
    same = _same_runs(out, ok)
    return (
        head + f"The validation study ([jet_validation.md](jet_validation.md)) scored {v['n']} surfaces both "
        f"ways: the model ranks them like SPH {_strength(v, 'a 95 % bootstrap interval')}.{surrogate}\n\n"
        + table(rows, ["surface", "thin-sheet model, force / rho Q V", "SPH, force / (measured flux x V)"])
        + f"\n\n{claim}{same}\n"
    )


def _same_runs(out: Path, ok: pd.DataFrame) -> str:
    """Whether the study's GA winners are this report's: the best fitness of each run compared."""
    path = out / "data" / "casestudy_runs.csv"
    ga = ok[ok["family"] == "GA winner"]
    if not path.is_file() or ga.empty:
        return ""
    runs = read_csv(path)
    best = {f"GA run {int(r['run'])} #1": float(r["best_N"]) for _, r in runs.iterrows()}
    study = ga.set_index("surface")["ga_fitness_N"]
    pairs = [(best[k], float(study[k])) for k in best if k in study.index]
    if pairs and all(abs(a - b) <= 1e-9 * abs(a) for a, b in pairs):
        return " (The study scored the winners of these very runs: their best fitness values agree.)"
    return (
        " (The study's GA winners come from runs with the case study's settings made by the code that "
        "built the study's surfaces; their best fitness differs from this report's runs, so the winners "
        "drawn above may not be the ones SPH scored.)"
    )
