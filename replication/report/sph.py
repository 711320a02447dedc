"""The SPH report: ``sph.md`` with its figures, from the data the SPH study saved.

:func:`save_sph_data` writes the study's tables as CSV/JSON under ``data/``;
:func:`render_sph` reads only those files.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from replication.report.markdown import fmt, provenance_section, table, write_report
from replication.report.sph_figures import convergence_figure, run_label, series_figure
from replication.report.store import data_set, read_csv, read_provenance, write_csv, write_json

__all__ = ["TABLES", "load_sph_data", "render_sph", "save_sph_data"]

TABLES = ("runs", "series", "shapes", "hypotheses")
#: The columns of the tables that hold text; the others must hold numbers (see :func:`.store.read_csv`).
TEXT_COLUMNS = frozenset({"hypothesis", "why", "verdict", "shape", "method", "status", "reason", "key"})


def save_sph_data(results: Any, out_dir: str | os.PathLike[str]) -> Path:
    """Write the SPH study's tables and provenance under ``out_dir/data``."""
    data = Path(out_dir) / "data"
    with data_set(data, "sph_provenance.json", checksums=True) as staged:
        for name in TABLES:
            write_csv(getattr(results, name), staged / f"sph_{name}.csv")
        write_json(results.provenance, staged / "sph_provenance.json")
    return data


def load_sph_data(out_dir: str | os.PathLike[str]) -> dict[str, Any]:
    data = Path(out_dir) / "data"
    loaded: dict[str, Any] = {
        name: read_csv(data / f"sph_{name}.csv", strings=TEXT_COLUMNS) for name in TABLES
    }
    loaded["provenance"] = read_provenance(data, "sph_provenance.json", "replication sph")
    return loaded


def _ordering(d: dict[str, Any]) -> str:
    """A paragraph on the paper's flat > bucket ordering, from the numbers."""
    h = d["hypotheses"].set_index("hypothesis")
    mean = h.loc["quasi-steady mean force (DFSPH, incompressible)"]
    peak = h.loc["first-impact peak (WCSPH, c = 10 V)"]
    reverse = mean["bucket_N"] > mean["flat_N"]
    text = (
        f"In the quasi-steady mean the bucket takes {fmt(mean['bucket_N'], '.3g')} N against the flat "
        f"plate's {fmt(mean['flat_N'], '.3g')} N: "
        + (
            "the cup turns the sheet back, as momentum theory says, and the order is the reverse of the "
            "paper's. "
            if reverse
            else "the paper's order. "
        )
    )
    if np.isfinite(peak["flat_N"]) and np.isfinite(peak["bucket_N"]):
        paper_order = peak["flat_N"] > peak["bucket_N"]
        text += (
            "At the first impact of the weakly compressible solver the flat plate takes "
            f"{fmt(peak['flat_N'], '.3g')} N and the bucket {fmt(peak['bucket_N'], '.3g')} N, "
            + (
                "the paper's order: the jet's flat front strikes the whole plate at once (a water hammer), "
                "while the bucket's 13 mm splitter ridge meets it along a line and the cup fills over "
                "milliseconds, so the bucket has no comparable spike. "
                if paper_order
                else "not the paper's order either. "
            )
        )
    matched = h[h["verdict"] == "consistent"]
    text += (
        f"No reading gives both the paper's {fmt(peak['paper_flat_N'], '.4g')} N and "
        f"{fmt(peak['paper_bucket_N'], '.4g')} N."
        if matched.empty
        else f"The reading that matches both: {', '.join(matched.index)}."
    )
    return text


def render_sph(out_dir: str | os.PathLike[str]) -> Path:
    """Render ``sph.md`` and its figures from the saved data in ``out_dir``."""
    out = Path(out_dir)
    figures = out / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    d = load_sph_data(out)
    prov = d["provenance"]
    config = prov["config"]
    series_figure(d, figures / "sph_series")
    convergence_figure(d, figures / "sph_convergence")
    runs = d["runs"]
    rho_q_v = float(runs["rho_q_v_N"].iloc[0])
    shape_rows = [
        [
            r["shape"],
            fmt(r["thin_sheet_N"], ".4g"),
            fmt(r["sph_mean_N"], ".4g"),
            fmt(r["sph_radius_mm"], "g"),
            fmt(r["wcsph_peak_N"], ".4g"),
            fmt(r["paper_N"], ".4g"),
        ]
        for _, r in d["shapes"].iterrows()
    ]
    conv = runs[runs["method"] == "dfsph"]
    conv_rows = [
        [
            r["shape"],
            fmt(r["radius_mm"], "g"),
            r["status"],
            fmt(r["mean_N"], ".4g"),
            fmt(r["std_N"], ".2g"),
            fmt(r["mean_over_rho_q_v"], ".3f"),
            fmt(r["mean_over_measured_flux"], ".3f"),
            fmt(r["mass_flow_kg_s"] / r["nominal_mass_flow_kg_s"], ".3f"),
            fmt(r["peak_N"], ".3g"),
            fmt(r["peak_N"] / r["rho_q_v_N"], ".3g"),
            fmt(r["max_step_N"], ".3g"),
            fmt(r["fluid_particles"], "int"),
            fmt(r["steps"], "int"),
            fmt(r["wall_s"], ".3g"),
            fmt(r["wall_s_per_simulated_ms"], ".3g"),
        ]
        for _, r in conv.iterrows()
    ]
    wc = runs[runs["method"] == "wcsph"]
    wc_rows = [
        [
            r["shape"],
            fmt(r["radius_mm"], "g"),
            fmt(r["sound_speed_m_s"], ".3g"),
            r["status"],
            fmt(r["mean_N"], ".4g"),
            fmt(r["mean_over_rho_q_v"], ".3f"),
            fmt(r["peak_N"], ".4g"),
            fmt(r["peak_over_rho_c_v_a"], ".3f"),
            fmt(r["max_step_N"], ".4g"),
            fmt(r["steps"], "int"),
            fmt(r["wall_s"], ".3g"),
        ]
        for _, r in wc.iterrows()
    ]
    hyp_rows = [
        [
            r["hypothesis"],
            fmt(r["flat_N"], ".4g"),
            fmt(r["paper_flat_N"], ".4g"),
            fmt(r["bucket_N"], ".4g"),
            fmt(r["paper_bucket_N"], ".4g"),
            f"**{r['verdict']}**",
            r["why"],
        ]
        for _, r in d["hypotheses"].iterrows()
    ]
    cost = conv.groupby("radius_mm", sort=False).agg(
        wall=("wall_s", "median"),
        per_ms=("wall_s_per_simulated_ms", "median"),
        n=("wall_s", "size"),
        particles=("fluid_particles", "median"),
    )
    cost_rows = [
        [
            fmt(r, "g"),
            fmt(c["particles"], "int"),
            fmt(c["wall"], ".3g"),
            fmt(c["per_ms"], ".3g"),
            fmt(c["n"], "int"),
        ]
        for r, c in cost.iterrows()
    ]
    failed = runs[runs["status"] != "ok"]
    failures = "".join(
        f"\n- {r['shape']}, {run_label(r)}: **{r['status']}**: {r['reason']}" for _, r in failed.iterrows()
    )
    quick = (
        "\n> **Quick run** (coarse particles only): a smoke test, not the report's settings.\n"
        if prov.get("quick")
        else ""
    )
    duration = 1e3 * config["duration"]
    full_mark, quick_mark = ("the full study", " (this report)") if prov.get("quick") else ("this report", "")
    cache_note = _cache_note(prov, len(runs))
    at_once = int(prov.get("simulations_at_once", 1))  # data saved before it was recorded: one at a time
    beside = "one at a time" if at_once == 1 else f"{at_once} at a time, each on its own core"
    base = prov["sph_settings"]
    failure_section = f"\n## Failed simulations\n{failures}\n\n" if failures else "\n"
    text = f"""# The case study on a real SPH solver (SPlisHSPlasH)

Generated by `replication sph` from the data in `data/sph_*.csv`; every number below is read from
those files (re-render with `replication report`). Do not edit by hand.
{quick}
## What was simulated

The paper (section 6) scores every surface with DualSPHysics (weakly compressible SPH, half the
domain with a symmetry plane, 0.07 s per simulation). Here the two reference shapes are simulated
with SPlisHSPlasH {prov.get("engine")} (its Python bindings, the optional extra `sph`), each run in a
child process of its own (`replication.casestudy.sph`):

- **Jet**: an 18 mm free water column falling at 4.34 m/s along -z onto the surface, long enough to
  flow for the whole run ({duration:g} ms); particles on a cubic lattice of spacing 2r centred on the jet
  axis. (The engine's emitter is unreliable: a free column gives a clean jet of known mass flux.)
- **Surface**: the ADT surface as the top of a closed solid (vertical walls, a flat bottom), a static
  body with particle boundaries (Akinci 2012) sampled on a regular triangle pattern.
- **Half jet**: SPlisHSPlasH has no symmetry plane, so the whole jet is simulated on the surface
  joined to its mirror image in y = 0, and every force (and the mass flux) is halved.
- **Force**: the engine gives no force on a static body; the force of the water on the surface is
  the fluid's momentum balance, -(dP/dt - M g), per time step (the fluid's internal forces cancel).
  Gravity acts along -z. The quasi-steady mean is taken from {1e3 * base["settle_time"]:g} ms after the
  front reaches the surface to one jet diameter's travel before the column's tail does; its spread is
  the standard deviation of {1e3 * base["bin_width"]:g} ms means. The first-impact peak is the largest
  mean over {1e3 * base["peak_window"]:g} ms before that window. Time steps: CFL factor
  {base["cfl_factor"]:g}, at most {1e6 * base["max_time_step"]:g} us; one engine thread.
- **Solvers**: DFSPH (incompressible, SPlisHSPlasH's default) for the convergence study; WCSPH (Tait
  equation, gamma 7, stiffness from the stated numerical sound speed c, time step within the acoustic
  CFL limit) for the impact peak, which in a weakly compressible fluid depends on the numerical
  sound speed c (a water hammer exerts rho c V A).
- **Normalisation**: rho Q V = {rho_q_v:.4g} N is the nominal momentum flux of the half jet; the
  particle lattice carries a slightly different mass flux (measured: the column's particle mass per unit
  length times V), so forces are also given over the measured flux times V.

## Reference shapes: the thin-sheet model, SPH and the paper

Axial force of the half jet (data: `data/sph_shapes.csv`); SPH mean at the finest DFSPH particles,
WCSPH impact peak at the finest radius with c = 10 V.

{
        table(
            shape_rows,
            [
                "shape",
                "thin-sheet model [N]",
                "SPH quasi-steady mean [N]",
                "at r [mm]",
                "WCSPH first-impact peak [N]",
                "paper (DualSPHysics) [N]",
            ],
        )
    }

## Convergence (DFSPH)

(data: `data/sph_runs.csv`, `data/sph_series.csv`.) Mass flux ratio: measured over nominal rho Q.{cache_note}

{
        table(
            conv_rows,
            [
                "shape",
                "r [mm]",
                "status",
                "mean [N]",
                "std [N]",
                "mean / rho Q V",
                "mean / measured flux V",
                "mass flux / rho Q",
                "impact peak [N]",
                "peak / rho Q V",
                "largest step [N]",
                "fluid particles",
                "steps",
                "wall [s]",
                "wall per simulated ms [s]",
            ],
        )
    }

![SPH force series](figures/sph_series.png)

([SVG](figures/sph_series.svg).) Axial force against time (1 ms means), with the thin-sheet model's
value and the paper's.

![Convergence](figures/sph_convergence.png)

([SVG](figures/sph_convergence.svg).)

## Weakly compressible runs (WCSPH)

rho c V A is the water-hammer force of the half jet's flat front striking a wall at once.

{
        table(
            wc_rows,
            [
                "shape",
                "r [mm]",
                "c [m/s]",
                "status",
                "mean [N]",
                "mean / rho Q V",
                "impact peak [N]",
                "peak / rho c V A",
                "largest step [N]",
                "steps",
                "wall [s]",
            ],
        )
    }

## The paper's forces examined

(data: `data/sph_hypotheses.csv`.) A reading is **consistent** when both shapes lie within 15 % of
the paper's values and the flat plate takes more than the bucket, as in the paper.

{
        table(
            hyp_rows,
            [
                "hypothesis",
                "flat, ours [N]",
                "flat, paper [N]",
                "bucket, ours [N]",
                "bucket, paper [N]",
                "verdict",
                "why",
            ],
            "lrrrrll",
        )
    }

**The ordering.** {_ordering(d)}

## Cost of a simulation

Wall time of one simulation of {duration:g} ms (median over the shapes; one engine thread; simulations
{beside}; {_cost_context(prov, len(runs))}):

{
        table(
            cost_rows,
            [
                "particle radius [mm]",
                "fluid particles",
                "wall per simulation [s]",
                "wall per simulated ms [s]",
                "simulations",
            ],
        )
    }
{failure_section}## Reproduce

```bash
python -m pip install ".[sph]"
replication sph                 # {full_mark} (also run by `replication reproduce` when installed)
replication sph --quick         # coarse particles only, into reports-quick/{quick_mark}
replication force flat.csv --solver sph --particle-radius 0.75 --json   # one surface
```

{provenance_section(prov, "data/sph_provenance.json")}
"""
    path = out / "sph.md"
    write_report(path, text)
    return path


def _cache_note(prov: dict[str, Any], simulations: int) -> str:
    """What the SPH cache gave the study: its wall times are those of the runs that made the
    entries. A study saved before the hits were counted says so in general terms."""
    if not prov.get("sph_cache"):
        return ""
    hits = prov.get("sph_cache_hits")
    if hits is None:
        return (
            " The simulations were taken from the SPH cache where it held them: a wall time is that of "
            "the run that made the entry."
        )
    if hits == 0:
        return " Every simulation was run for this study (the SPH cache gave none)."
    return (
        f" {hits} of the {simulations} simulations were read from the SPH cache: their wall times are "
        "those of the runs that made the entries."
    )


def _cost_context(prov: dict[str, Any], simulations: int) -> str:
    """Where the wall times were measured, from the provenance (the page said "a shared 2-core
    machine while other work ran" whatever machine ran it), and which came from the cache."""
    cores = prov.get("cores")
    machine = f"{prov.get('cpu') or 'an unnamed CPU'}, " + (
        f"{cores} cores" if isinstance(cores, int) else "an unknown number of cores"
    )
    text = f"measured on {machine}, which may have run other work: indicative times, not benchmarks"
    hits = prov.get("sph_cache_hits")
    if prov.get("sph_cache") and hits is None:
        text += "; simulations read from the SPH cache have the times of the runs that made them"
    elif hits:
        text += (
            f"; {hits} of the {simulations} simulations were read from the SPH cache, with the times "
            "(and the number at once) of the runs that made them"
        )
    return text
