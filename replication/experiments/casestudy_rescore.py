"""The cost of SPH as the case study's fitness: measured here, projected to the paper's GA.

:func:`rescore_cost` sets the thin-sheet model's cost per evaluation beside the SPH
simulations' of the re-scoring (issue 11 item 3) and projects what scoring every individual
of the paper's GA by SPH (3 runs x 50 generations x 48 individuals, less the evaluations the
GA's genome cache saves) would take on 1 worker, this machine's cores, 8 and 64 workers, each
simulation on one core (ideal scaling: an upper bound on the speed-up).
"""

from __future__ import annotations

import math

import pandas as pd

from replication.casestudy.ga import GAConfig

__all__ = ["PAPER_EVALUATIONS", "rescore_cost"]

#: Individuals of the paper's full GA: 3 runs x 50 generations x 48 (section 6).
PAPER_EVALUATIONS = 3 * 50 * 48
#: Worker counts of the projection, besides this machine's cores.
PROJECTED_WORKERS = (1, 8, 64)


def rescore_cost(
    surfaces: pd.DataFrame,
    *,
    wall_seconds: float,
    thin_sheet_seconds: float,
    runs: pd.DataFrame,
    config: GAConfig,
    cores: int,
    workers: int,
) -> pd.DataFrame:
    """One table of (item, value, unit, note) rows: measured costs, then the projections.

    Parameters
    ----------
    surfaces : DataFrame
        The re-scored surfaces (``key``, ``status``, ``cached``, ``sph_wall_s``).
    wall_seconds : float
        Wall time of the re-scoring.
    thin_sheet_seconds : float
        Median time of one thin-sheet evaluation (s).
    runs : DataFrame
        The GA runs (``evaluations``, ``cache_hits``): the share of individuals the genome
        cache saved, known exactly for the paper's settings and estimated otherwise.
    config : GAConfig
    cores, workers : int
        CPUs of this machine; simulations run at once in the re-scoring.

    Notes
    -----
    Paper section 6: 107.53 s per SPH simulation on a GPU; the full GA's individuals.
    """
    surfaces = surfaces.drop_duplicates("key")  # a surface listed twice was simulated once
    ok = surfaces[surfaces["status"] == "ok"]
    per_sim = float(ok["sph_wall_s"].median()) if len(ok) else math.nan
    spread = (float(ok["sph_wall_s"].min()), float(ok["sph_wall_s"].max())) if len(ok) else (math.nan,) * 2
    run_now = int((~surfaces["cached"]).sum())
    cached = int(surfaces["cached"].sum())
    failed = int((surfaces["status"] != "ok").sum())
    evaluations, hits = int(runs["evaluations"].sum()), int(runs["cache_hits"].sum())
    paper = config == GAConfig()
    share = hits / (evaluations + hits) if evaluations + hits else 0.0
    projected = evaluations if paper else round(PAPER_EVALUATIONS * (1 - share))
    source = (
        "this run's distinct evaluations (the paper's settings)"
        if paper
        else f"{PAPER_EVALUATIONS} less {100 * share:.1f} % saved by the genome cache in this run (an "
        f"estimate: the share depends on the GA's size; at most {PAPER_EVALUATIONS})"
    )
    rows = [
        ("thin-sheet evaluation", 1e3 * thin_sheet_seconds, "ms", "median (ADT + jet model)"),
        ("SPH simulation", per_sim, "s", f"median wall time over {len(ok)} simulations "
         f"(range {spread[0]:.3g}-{spread[1]:.3g} s), one core each" if len(ok)
         else "no simulation succeeded: no time to project from"),
        ("SPH / thin-sheet", per_sim / thin_sheet_seconds if thin_sheet_seconds > 0 else math.nan, "x", ""),
        ("simulations run", run_now, "", f"{workers} at once"),
        ("simulations read from the cache", cached, "", ""),
        ("failed simulations", failed, "", "recorded with their reason"),
        ("re-scoring wall time", wall_seconds, "s", "simulations and cache reads"),
        ("--solver sph evaluations (paper's GA)", projected, "", source),
    ]  # fmt: skip
    for n in sorted({*PROJECTED_WORKERS, cores}):
        hours = projected * per_sim / n / 3600
        label = f"--solver sph, {n} worker{'s' if n > 1 else ''}"
        note = "this machine's cores" if n == cores else "extrapolated, ideal scaling"
        rows.append((label, hours, "h", note))
    return pd.DataFrame(rows, columns=["item", "value", "unit", "note"])
