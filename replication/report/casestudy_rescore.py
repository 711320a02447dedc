"""The GA's best surfaces ranked by SPH: a section of ``casestudy.md``, present only with its data.

``replication casestudy --rescore sph`` writes ``data/casestudy_rescore.csv`` (one row per
re-scored surface, the references included) and ``data/casestudy_rescore_cost.csv``; this
module saves them and renders the section from them. Without them the section is empty, so
a case study run without re-scoring renders exactly as before.
"""

from __future__ import annotations

import contextlib
import math
from pathlib import Path
from typing import Any

import pandas as pd

from replication.report.markdown import fmt, table
from replication.report.store import read_csv, write_csv

__all__ = ["RESCORE_FILES", "rescore_section", "save_rescore_data"]

RESCORE_FILES = ("casestudy_rescore.csv", "casestudy_rescore_cost.csv")
COLUMNS = ("surface", "kind", "run", "rank", "thin_sheet_N", "sph_N", "sph_over_rho_q_v", "sph_std_N",
           "status", "reason", "cached", "same_as")  # fmt: skip
#: The reference shapes' names in the data.
REFERENCES = ("flat plate", "pelton bucket")


def save_rescore_data(results: Any, data: Path) -> None:
    """Write the re-scoring's tables, or remove those of an earlier run when there are none."""
    if getattr(results, "rescore", None) is None:
        for name in RESCORE_FILES:
            with contextlib.suppress(FileNotFoundError):
                (data / name).unlink()
        return
    write_csv(results.rescore, data / RESCORE_FILES[0])
    write_csv(results.rescore_cost, data / RESCORE_FILES[1])


def _settings_line(prov: dict[str, Any]) -> str:
    info = prov.get("rescore") or {}
    s = info.get("settings") or {}
    if not s:
        return "SPH settings not recorded"
    return (
        f"SPlisHSPlasH ({str(s.get('method', '?')).upper()}), particle radius "
        f"{1e3 * float(s['particle_radius']):g} mm, {1e3 * float(s['duration']):g} ms simulated, "
        f"{int(s.get('threads', 1))} thread per simulation; top {info.get('top', '?')} distinct "
        "surfaces per run"
    )


def _verdict(ranked: pd.DataFrame) -> str:
    ok = ranked[ranked["status"] == "ok"]
    if ok.empty:
        return "No simulation finished, so SPH ranks nothing here."
    best = ok.iloc[0]
    lines = [f"Best by SPH: **{best['surface']}**, {fmt(best['sph_N'], '.4g')} N "
             f"({fmt(best['sph_over_rho_q_v'], '.3g')} rho Q V)."]  # fmt: skip
    bucket = ok[ok["surface"] == "pelton bucket"]
    ga = ok[(ok["kind"] == "GA") & ~ok["same_as"].isin(REFERENCES)]  # the bucket itself beats nothing
    if bucket.empty:
        lines.append("Whether a GA surface beats the bucket by SPH is not known (its simulation failed).")
    elif ga.empty:
        lines.append("No GA surface other than the reference shapes themselves has an SPH score.")
    else:
        b, g = bucket.iloc[0], ga.iloc[0]
        beats = ga[ga["sph_N"] > b["sph_N"]]
        noise = math.hypot(float(g["sph_std_N"]), float(b["sph_std_N"]))
        if len(beats):
            lines.append(
                f"{len(beats)} of {len(ga)} GA surfaces beat the bucket by SPH: the best, {g['surface']}, "
                f"by {fmt(g['sph_N'] - b['sph_N'], '.3g')} N (bucket {fmt(b['sph_N'], '.4g')} N; the "
                f"quasi-steady standard deviations of the two combine to {fmt(noise, '.2g')} N)."
            )
        else:
            lines.append(
                f"No GA surface beats the bucket by SPH: the best, {g['surface']}, reaches "
                f"{fmt(g['sph_N'], '.4g')} N against the bucket's {fmt(b['sph_N'], '.4g')} N."
            )
    return " ".join(lines)


def rescore_section(out: Path) -> str:
    """The section (markdown ending in a blank line), or "" when there is no re-scoring data."""
    data = Path(out) / "data"
    if not all((data / name).is_file() for name in RESCORE_FILES):
        return ""
    from replication.report.store import read_json

    d = read_csv(data / RESCORE_FILES[0], COLUMNS)
    cost = read_csv(data / RESCORE_FILES[1], ("item", "value", "unit", "note"))
    prov = read_json(data / "casestudy_provenance.json")
    d = d.assign(_ok=d["status"] == "ok", same_as=d["same_as"].astype(object).where(d["same_as"].notna(), ""))
    ranked = d.sort_values(["_ok", "sph_N"], ascending=[False, False], kind="stable").reset_index(drop=True)
    rows = []
    for i, r in ranked.iterrows():
        ok = r["status"] == "ok"
        thin_rank = "reference" if r["kind"] == "reference" else f"run {int(r['run'])} #{int(r['rank'])}"
        name = r["surface"] + (f" (= {r['same_as']})" if r["same_as"] else "")
        rows.append([
            str(i + 1) if ok else "–", name, thin_rank, fmt(r["thin_sheet_N"], ".4g"),
            fmt(r["sph_N"], ".4g") if ok else "–", fmt(r["sph_over_rho_q_v"], ".3g") if ok else "–",
            fmt(r["sph_std_N"], ".2g") if ok else "–",
            "ok" if ok else f"{r['status']}: {r['reason']}", "yes" if bool(r["cached"]) else "no",
        ])  # fmt: skip
    cost_rows = [
        [r["item"], fmt(r["value"], ".4g"), "" if pd.isna(r["unit"]) else str(r["unit"]),
         "" if pd.isna(r["note"]) else str(r["note"])]
        for _, r in cost.iterrows()
    ]  # fmt: skip
    headers = ["SPH rank", "surface", "thin-sheet rank", "thin-sheet [N]", "SPH [N]", "SPH / (rho Q V)",
               "SPH std [N]", "simulation", "from cache"]  # fmt: skip
    return f"""## The GA's best surfaces re-scored by SPH

The jet-model validation found that the thin-sheet model overestimates rough, faceted surfaces
such as the GA's winners and ranks them unlike SPH, so SPH is the fitness of record: the best
distinct surfaces of each run's final population by the thin-sheet fitness (repeated elites and
coinciding surfaces counted once) were simulated, with the flat plate and the bucket as
references at the same settings ({_settings_line(prov)}).
SPH forces are quasi-steady means of the half jet (data: `data/casestudy_rescore.csv`); a
surface equal to an earlier one ("= ...") was simulated once.

{table(rows, headers, "rllrrrrll")}

{_verdict(ranked)}

Cost (data: `data/casestudy_rescore_cost.csv`; times on this machine, which may have been loaded;
the projections assume one core per simulation and ideal scaling):

{table(cost_rows, ["item", "value", "unit", "note"], "lrll")}

"""
