"""The case-study report: Figs. 8 and 9 and ``casestudy.md`` from the saved data.

:func:`save_casestudy_data` writes the results as CSV/JSON under ``data/``;
:func:`render_casestudy` reads only those files (the best individuals are rebuilt into ADT
surfaces for drawing, which is geometry, not science).
"""

from __future__ import annotations

import functools
import os
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.patches import Wedge

from replication.errors import DuplicatePointsWarning, ReportDataError
from replication.experiments.casestudy import differences_from_paper
from replication.report.casestudy_rescore import RESCORE_FILES, rescore_section, save_rescore_data  # issue 11
from replication.report.casestudy_validation import fitness_note, validation_section  # issue 11
from replication.report.figures import clear_figures, figure_files, new_figure, save_figure
from replication.report.markdown import fmt, iqr, provenance_section, table, write_report
from replication.report.parallel import run_figure_tasks
from replication.report.render3d import render_views
from replication.report.store import data_set, read_csv, read_provenance, write_csv, write_json

__all__ = ["save_casestudy_data", "load_casestudy_data", "render_casestudy"]

TABLES = ("history", "runs", "shapes", "evaluation", "claims")
#: Columns the renderer reads from each table.
COLUMNS: dict[str, tuple[str, ...]] = {
    "history": ("run", "generation", "best", "best_so_far", "mean"),
    "runs": ("run", "seed", "best_N", "best_generation", "evaluations", "cache_hits", "failures",
             "wall_s", "seconds_per_evaluation"),
    "shapes": ("shape", "axial_N", "axial_4x_N", "refinement_change_pct", "over_rho_q_v",
               "full_jet_mirrored_N", "paper_sph", "rho_q_v_N"),
    "evaluation": ("individual", "median", "q1", "q3", "vtk_bytes"),
    "claims": ("claim", "paper", "ours", "verdict", "why"),
    "best": ("run", "x_mm", "y_mm", "z_mm"),
}  # fmt: skip
#: The columns of the case study's tables that hold text; the others must hold numbers.
TEXT_COLUMNS = frozenset(
    {"seed", "shape", "paper_sph", "individual", "claim", "paper", "ours", "verdict", "why"}
)


def save_casestudy_data(results: Any, out_dir: str | os.PathLike[str]) -> Path:
    """Write the case study's tables, best individuals and provenance under ``out_dir/data``."""
    data = Path(out_dir) / "data"
    stale = RESCORE_FILES if getattr(results, "rescore", None) is None else ()
    with data_set(data, "casestudy_provenance.json", stale=stale, checksums=True) as staged:
        for name in TABLES:
            write_csv(getattr(results, name), staged / f"casestudy_{name}.csv")
        best = pd.concat(
            [
                pd.DataFrame(points, columns=["x_mm", "y_mm", "z_mm"]).assign(run=k)
                for k, points in results.best.items()
            ],
            ignore_index=True,
        )
        write_csv(best, staged / "casestudy_best.csv")
        write_json(results.provenance, staged / "casestudy_provenance.json")
        save_rescore_data(results, staged)  # issue 11: the best surfaces by SPH, when re-scored
    return data


def load_casestudy_data(out_dir: str | os.PathLike[str]) -> dict[str, Any]:
    data = Path(out_dir) / "data"
    loaded: dict[str, Any] = {
        name: read_csv(data / f"casestudy_{name}.csv", COLUMNS[name], strings=TEXT_COLUMNS)
        for name in (*TABLES, "best")
    }
    loaded["provenance"] = read_provenance(data, "casestudy_provenance.json", "replication casestudy")
    _check_history(loaded, data / "casestudy_history.csv")
    return loaded


def _check_history(loaded: dict[str, Any], path: Path) -> None:
    """Refuse a history that lacks a run's generations: Fig. 8 would draw the gap as a line.

    Every run of the runs table has one row per generation, 1 to the configured number
    (the provenance's ``config.generations``; the run's last row where it is not recorded).
    """
    history, runs = loaded["history"], loaded["runs"]
    configured = (loaded["provenance"].get("config") or {}).get("generations")
    for run in runs["run"]:
        generations = history.loc[history["run"] == run, "generation"].to_numpy()
        last = int(configured) if configured is not None else int(generations.max(initial=0))
        expected = np.arange(1, last + 1)
        if generations.shape != expected.shape or not np.array_equal(generations, expected):
            missing = np.setdiff1d(expected, generations)
            stray = generations[~np.isin(generations, expected)]
            values, counts = np.unique(generations, return_counts=True)
            if np.isnan(stray.astype(float)).any():
                what = "has a row without its generation"
            elif stray.size:
                what = f"has generation(s) {_listed(stray)} outside 1-{last}"
            elif missing.size:
                what = f"lacks generation(s) {_listed(missing)}"
            elif np.any(counts > 1):
                what = f"has generation(s) {_listed(values[counts > 1])} more than once"
            else:
                what = "has rows out of order"
            raise ReportDataError(
                f"{path}: run {run} {what} (generations 1-{last} expected; the file is damaged); "
                "regenerate the report data"
            )


def _listed(values: np.ndarray, at_most: int = 5) -> str:
    shown = ", ".join(f"{v:g}" for v in values[:at_most])
    return shown + (f" and {values.size - at_most} more" if values.size > at_most else "")


def _surface(points: np.ndarray, duplicates: str) -> Any:
    """The ADT surface an individual was scored on (depth z, the run's duplicate policy)."""
    from replication.surfaces import adt

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        return adt(points, depth="z", duplicates=duplicates)


def _timed_where(prov: dict[str, Any]) -> str:
    """How many rounds timed the evaluations, and where: in one process, or on several of the GA's
    workers at once (the rounds scale with the GA's size, see ``default_timing_repeats``)."""
    timing = prov.get("evaluation_timing") or {}
    workers = int(timing.get("workers_at_once", 1))
    rounds = f"{timing['repeats']} rounds, " if "repeats" in timing else ""
    if workers <= 1:
        return f"{rounds}one process"
    return f"{rounds}timed on {workers} of the GA's workers at once, each on its share of the rounds"


def _fig8(d: dict[str, Any], stem: Path) -> None:
    history, shapes = d["history"], d["shapes"].set_index("shape")
    fig = new_figure((7, 4.2))
    ax = fig.subplots()
    for k, rows in history.groupby("run"):
        ax.plot(rows["generation"], rows["best"], "-o", ms=3, color=f"C{k}", label=f"run {k}: best")
        ax.plot(
            rows["generation"],
            rows["mean"],
            "--",
            color=f"C{k}",
            alpha=0.6,
            label=f"run {k}: population mean",
        )
    ax.axhline(
        shapes.loc["pelton bucket", "axial_N"], color="0.3", ls=":", label="Pelton bucket approximation"
    )
    ax.axhline(shapes.loc["flat plate", "axial_N"], color="0.6", ls=":", label="flat plate")
    ax.set_xlabel("generation")
    ax.set_ylabel("axial force of the half jet [N]")
    ax.set_title("Fig. 8 reproduced: force per generation")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    save_figure(fig, stem)


def _fig9(d: dict[str, Any], stem: Path, config: dict[str, Any]) -> None:
    best = d["best"]
    runs = sorted(best["run"].unique())
    fig = new_figure((4.2 * len(runs), 3.8))
    axes = np.atleast_1d(fig.subplots(1, len(runs)))
    jet = config["jet"]
    cx, cy = (1e3 * v for v in jet["center"])
    radius = 1e3 * jet["diameter"] / 2
    z_low, z_high = config["box"][4], config["box"][5]
    for ax, k in zip(axes, runs):
        pts = best[best["run"] == k][["x_mm", "y_mm", "z_mm"]].to_numpy()
        surface = _surface(pts, config["duplicates"])
        p = surface.points
        levels = np.linspace(z_low, z_high, 14)
        filled = ax.tricontourf(p[:, 0], p[:, 1], surface.triangles, p[:, 2], levels=levels, cmap="cividis")
        ax.triplot(p[:, 0], p[:, 1], surface.triangles, color="k", lw=0.2, alpha=0.4)
        ax.add_patch(Wedge((cx, cy), radius, 0, 180, fill=False, color="red", lw=2))
        force = d["runs"].set_index("run").loc[k, "best_N"]
        ax.set_title(f"run {k}: best surface, {force:.3f} N", fontsize=9)
        ax.set_aspect("equal")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        fig.colorbar(filled, ax=ax, label="z [mm] (blue deep, yellow high)", shrink=0.8)
    fig.suptitle("Fig. 9 reproduced: the jet footprint (half jet) in red")
    fig.tight_layout()
    save_figure(fig, stem)


def _renders(d: dict[str, Any], figures: Path, duplicates: str) -> tuple[list[str], str]:
    views, names = {}, []
    best = d["best"]
    for k in sorted(best["run"].unique()):
        surface = _surface(best[best["run"] == k][["x_mm", "y_mm", "z_mm"]].to_numpy(), duplicates)
        path = figures / f"casestudy_best_run{k}.png"
        views[path] = [("ADT", (surface.points, surface.triangles))]
        names.append(f"![best surface of run {k}](figures/{path.name})")
    return names, render_views(views)


def render_casestudy(out_dir: str | os.PathLike[str], *, workers: int = 1) -> Path:
    """Render ``casestudy.md`` and its figures from the saved data in ``out_dir``.

    The figures are drawn on up to ``workers`` processes at once
    (:func:`.parallel.run_figure_tasks`); the files are the same for any number.
    """
    out = Path(out_dir)
    figures = out / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    d = load_casestudy_data(out)
    prov = d["provenance"]
    config = prov["config"]
    jet = config["jet"]
    earlier = figure_files(figures, "casestudy_")  # those not drawn again are an earlier run's
    drawn = run_figure_tasks(  # the longest first
        [
            functools.partial(_renders, d, figures, config["duplicates"]),
            functools.partial(_fig9, d, figures / "casestudy_fig9", config),
            functools.partial(_fig8, d, figures / "casestudy_fig8"),
        ],
        workers=workers,
    )
    renders, renderer = drawn[0]
    rho_q_v = float(d["shapes"]["rho_q_v_N"].iloc[0])
    jet_part = "whole" if jet["full_jet"] else "half"
    shapes = d["shapes"]
    shape_rows = [
        [r["shape"], fmt(r["axial_N"], ".4g"), fmt(r["axial_4x_N"], ".4g"),
         fmt(r["refinement_change_pct"], ".2g"), fmt(r["over_rho_q_v"], ".3g"),
         fmt(r["full_jet_mirrored_N"], ".4g"), str(r["paper_sph"])]
        for _, r in shapes.iterrows()
    ]  # fmt: skip
    run_rows = [
        [str(r["run"]), r["seed"], fmt(r["best_N"], ".4g"), str(r["best_generation"]),
         fmt(r["evaluations"], "int"), fmt(r["cache_hits"], "int"), fmt(r["failures"], "int"),
         fmt(r["wall_s"], ".3g"), fmt(1e3 * r["seconds_per_evaluation"], ".3g")]
        for _, r in d["runs"].iterrows()
    ]  # fmt: skip
    eval_rows = [
        [r["individual"], iqr(1e3 * r["median"], 1e3 * r["q1"], 1e3 * r["q3"]), fmt(r["vtk_bytes"], "int")]
        for _, r in d["evaluation"].iterrows()
    ]
    claim_rows = [
        [
            r["claim"],
            str(r["paper"]) if pd.notna(r["paper"]) else "–",
            fmt(r["ours"], ".4g"),
            f"**{r['verdict']}**",
            r["why"] + fitness_note(out, r["claim"]),  # issue 11: which fitness says so
        ]
        for _, r in d["claims"].iterrows()
    ]
    total = d["runs"][["evaluations", "cache_hits"]].sum()
    sph_link = (  # the SPH study (optional extra), when its data are here
        "\n  The same shapes on a real SPH solver, and what the paper's forces can be: [sph.md](sph.md)."
        if (out / "data" / "sph_provenance.json").is_file()
        else ""
    )
    differ = differences_from_paper(config)
    kind = "Quick run (a reduced GA for smoke testing)" if prov.get("quick") else "Not the paper's settings"
    quick = (
        f"\n> **{kind}**: {'; '.join(differ)}. The paper's numbers below are for its own settings.\n"
        if differ
        else ""
    )
    solver = prov.get("solver")  # --solver sph (issue 11): the GA's fitness was SPH
    if solver:
        sph = solver.get("settings", {})
        method = str(sph.get("method", "?")).upper()
        radius = 1e3 * float(sph.get("particle_radius", "nan"))
        duration = 1e3 * float(sph.get("duration", "nan"))
        quick += (
            "\n> **Fitness: SPH.** Every individual of the GA was scored by an SPH simulation "
            f"(SPlisHSPlasH, {method}, particle radius {radius:g} mm, {duration:g} ms simulated; a failed "
            "simulation scores worst): the history, the runs and the best surfaces are SPH forces. The "
            "reference shapes, the cost of an evaluation and the model described below are the thin-sheet "
            "model's.\n"
        )
    settings = "the paper's" if not differ else "the paper's except as stated at the top"
    this_run = (
        "replication casestudy               # the paper's settings (this report)"
        if not differ
        else f"replication casestudy               # the paper's settings\n{prov.get('command', '?')}"
        "    # this report"
    )
    text = f"""# Figs. 8 and 9: the water-jet case study

Generated by `replication casestudy` from the data in `data/casestudy_*.csv`; every number
below is read from those files (re-render with `replication report`). Do not edit by hand.
{quick}
## What was run

The paper (section 6) shapes a 101-point ADT surface in a 36 x 30 x 13 mm domain (1 mm lattice)
with a genetic algorithm that maximises the force of an 18 mm water jet at 4.34 m/s, scoring each
individual with the SPH solver DualSPHysics (107.53 s per simulation on a GPU). DualSPHysics cannot
be installed from the package registries and there is no GPU here, so each individual is scored by
an inviscid thin-sheet momentum balance on its faceted surface (`replication.casestudy.jet`),
validated against exact results (flat and inclined plates, a jet into a spherical bowl, mass
conservation, half-jet symmetry; see the tests). The half jet (y >= 0) on the half domain is
modelled, as in the paper. The objective is the force along the jet axis.

Settings ({settings}): population {config["population"]}, {config["generations"]}
generations (the initial population included), {config["runs"]} runs, {config["elites"]} elites,
random selection, two-point crossover, mutation probability {100 * config["mutation_rate"]:g} % per
gene (a gene is one lattice coordinate of one of the {config["points"]} points; a mutation draws
another lattice value of that axis), initial population: the flat plate, the Pelton-bucket
approximation and random surfaces. Each individual becomes a surface by ADT with the depth axis z
(the jet axis) and points sharing an (x, y) node merged ({config["duplicates"]} depth). Jet model
resolution {config["resolution"]}: {config["resolution"]} rings of streamlets across the jet radius and
{4 * config["resolution"]} spreading directions at each impact (see the model's notes).

## The paper's numbers beside ours

(data: `data/casestudy_claims.csv`)

{table(claim_rows, ["claim", "paper", "ours", "verdict", "why"], "lrrll")}

## Reference shapes

Axial force of the {jet_part} jet (data: `data/casestudy_shapes.csv`); rho Q V = {rho_q_v:.4g} N
for the {jet_part} jet. "4x" refines the streamlets and spreading directions four-fold.

{
        table(
            shape_rows,
            [
                "shape",
                "ours [N]",
                "ours, 4x resolution [N]",
                "change [%]",
                "ours / (rho Q V)",
                "full jet on the mirrored shape [N]",
                "paper, SPH",
            ],
        )
    }

## Fig. 8: force per generation

![Fig. 8](figures/casestudy_fig8.png)

([SVG](figures/casestudy_fig8.svg); data: `data/casestudy_history.csv`.) Solid: the best individual
of each generation (elitism makes it non-decreasing); dashed: the population mean.

## Fig. 9: the best surface of each run

![Fig. 9](figures/casestudy_fig9.png)

([SVG](figures/casestudy_fig9.svg); data: `data/casestudy_best.csv`.) Rendered in 3-D with {renderer}:

{table([renders], [f"run {k}" for k in range(len(renders))], "c" * len(renders))}

## Runs

(data: `data/casestudy_runs.csv`.) Evaluations count distinct genomes; the cache saved
{fmt(total["cache_hits"], "int")} evaluations of individuals already scored (elites, repeated children)
against {fmt(total["evaluations"], "int")} done.

{
        table(
            run_rows,
            [
                "run",
                "seed",
                "best force [N]",
                "found in generation",
                "evaluations",
                "saved by cache",
                "failures",
                "wall time [s]",
                "time per evaluation [ms]",
            ],
        )
    }

Cost of one evaluation (ADT + jet model, {_timed_where(prov)}, median [IQR]; data:
`data/casestudy_evaluation.csv`), and the size of the individual's surface as compact legacy VTK:

{table(eval_rows, ["individual", "time [ms]", "ADT file [bytes]"])}

## What differs from the paper, and why

- **Force model.** SPH (transient, viscous, with gravity and splash) against a steady inviscid
  thin-sheet balance. For a stationary surface momentum conservation bounds the steady force of this
  jet by 2 rho Q V; the paper's SPH forces for the flat plate and the bucket exceed even the full
  jet's bound and rank the bucket below the flat plate, which momentum theory does not allow for a
  cup that turns the sheet back. The paper's forces therefore cannot be reproduced by any steady
  momentum balance; the ranking of shapes is what the GA needs, and ours follows momentum theory.{sph_link}
- **Selection.** The paper's random selection puts no pressure on the parents: only the elites
  carry fitness forward, and with 0.01 % mutation per gene almost no child is mutated, so progress
  comes from crossover of the elites with random individuals.
- **Evaluations.** Individuals already scored are not scored again (cache by genome), so our count
  of evaluations is below population x generations.

{validation_section(out)}
{rescore_section(out)}## Reproduce

```bash
{this_run}
replication casestudy --quick       # a reduced GA for smoke testing
replication casestudy --run-dir DIR --resume    # continue an interrupted run
replication report                  # re-render from data/ only
```

{provenance_section(prov, "data/casestudy_provenance.json")}
"""
    path = out / "casestudy.md"
    write_report(path, text)
    clear_figures(figures, "casestudy_", before=earlier)  # e.g. casestudy_best_run2.png of a 3-run report
    return path
