"""The validation study's report: ``jet_validation.md`` with its figures, from the saved data.

:func:`save_jet_validation_data` writes the study's tables as CSV/JSON under ``data/``;
:func:`render_jet_validation` reads only those files. The sections' prose that states a
finding is built from the numbers (:mod:`.jet_validation_text`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pandas as pd

from replication.report.jet_validation_figures import resolution_figure, scatter_figure
from replication.report.jet_validation_text import (
    AGREEMENT_HEADER,
    NOISE_HEADER,
    REPEAT_HEADER,
    agreement_rows,
    convergence_rows,
    findings,
    noise_rows,
    repeat_rows,
    resolution_limit,
    resolution_rows,
    surface_rows,
    surrogate_section,
)
from replication.report.markdown import provenance_section, table, write_report
from replication.report.store import data_set, read_csv, read_provenance, write_csv, write_json

__all__ = [
    "OPTIONAL",
    "TABLES",
    "load_jet_validation_data",
    "render_jet_validation",
    "save_jet_validation_data",
    "saved_study",
]

TABLES = (
    "surfaces", "resolution", "convergence", "agreement", "vertices", "triangles", "series", "repeatability",
    "noise",
)  # fmt: skip
#: Tables of the surrogate (present once it is calibrated).
OPTIONAL = ("surrogate_surfaces", "surrogate_params", "surrogate_agreement", "departures")
PREFIX = "jet_validation"
#: The columns of the tables that hold text; the others must hold numbers (see :func:`.store.read_csv`).
TEXT_COLUMNS = frozenset({
    "scope", "feature", "what", "surface", "family", "status_shifted", "sph_status", "sph_reason", "sph_key",
    "stratum", "half", "parameter", "meaning",
})  # fmt: skip
RESOLUTION_HEADER = ["surface", "family", "model", "last change", "rank (last two radii)", "residual bound"]
CONVERGENCE_HEADER = [
    "SPH at", "n", "Spearman vs finest [95 % CI]", "Kendall vs finest [95 % CI]", "largest change",
    "median change", "model vs SPH (Spearman)",
]  # fmt: skip
SURFACE_HEADER = [
    "surface",
    "family",
    "GA fitness [N]",
    "model",
    "SPH",
    "SPH spread",
    "SPH drift",
    "model / SPH",
    "SPH wall [s]",
]


def save_jet_validation_data(results: Any, out_dir: str | os.PathLike[str]) -> Path:
    """Write the study's tables and provenance under ``out_dir/data``."""
    data = Path(out_dir) / "data"
    absent = [name for name in TABLES + OPTIONAL if getattr(results, name, None) is None]
    # the tables of an earlier run that this one does not have are removed
    with data_set(
        data, f"{PREFIX}_provenance.json", stale=[f"{PREFIX}_{n}.csv" for n in absent], checksums=True
    ) as staged:
        for name in TABLES + OPTIONAL:
            if name not in absent:
                write_csv(getattr(results, name), staged / f"{PREFIX}_{name}.csv")
        write_json(results.provenance, staged / f"{PREFIX}_provenance.json")
    return data


def saved_study(out_dir: str | os.PathLike[str]) -> bool:
    """Whether ``out_dir/data`` holds a saved study (every table and the provenance)."""
    data = Path(out_dir) / "data"
    names = [f"{PREFIX}_{name}.csv" for name in TABLES] + [f"{PREFIX}_provenance.json"]
    return all((data / name).is_file() for name in names)


def load_jet_validation_data(out_dir: str | os.PathLike[str]) -> dict[str, Any]:
    data = Path(out_dir) / "data"
    loaded: dict[str, Any] = {
        name: read_csv(data / f"{PREFIX}_{name}.csv", strings=TEXT_COLUMNS) for name in TABLES
    }
    for name in OPTIONAL:
        path = data / f"{PREFIX}_{name}.csv"
        loaded[name] = read_csv(path, strings=TEXT_COLUMNS) if path.is_file() else None
    loaded["provenance"] = read_provenance(data, f"{PREFIX}_provenance.json", "replication validate-jet")
    return loaded


def render_jet_validation(out_dir: str | os.PathLike[str]) -> Path:
    """Render ``jet_validation.md`` and its figures from the saved data in ``out_dir``."""
    out = Path(out_dir)
    figures = out / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    d = load_jet_validation_data(out)
    prov = d["provenance"]
    config = prov["config"]
    scatter_figure(d, figures / "jet_validation_scatter")
    if not d["resolution"].empty:
        resolution_figure(d, figures / "jet_validation_resolution")
    surfaces = d["surfaces"]
    failed = surfaces[~surfaces["sph_status"].isin(["ok"])]
    failures = "".join(
        f"\n- {r['surface']}: **{r['sph_status']}**: {r['sph_reason']}" for _, r in failed.iterrows()
    )
    quick = (
        "\n> **Quick run** (three surfaces, coarse particles): a smoke test, not the study's settings.\n"
        if prov.get("quick")
        else ""
    )
    radius = 1e3 * config["radius"]
    duration = 1e3 * config["duration"]
    radii = ", ".join(f"{1e3 * r:g}" for r in sorted(config["resolution_radii"], reverse=True))
    ga = config.get("ga")
    ga_text = (
        f"the {config['ga_top']} best distinct surfaces of the final population of each of the "
        f"{ga['runs']} runs of the case study's GA (thin-sheet fitness, population {ga['population']}, "
        f"{ga['generations']} generations, seed {ga['seed']}: the case study's settings, run by the "
        "code named under 'Surfaces' origin' below)"
        if ga
        else "none (not in this run)"
    )
    counts = surfaces.groupby("family", sort=False).size()
    family_counts = ", ".join(f"{n} {f}" for f, n in counts.items())
    seconds = prov.get("all_simulations_seconds", float("nan"))
    radius_headers = [f"SPH, r = {1e3 * r:g} mm" for r in sorted(config["resolution_radii"], reverse=True)]
    text = f"""# The thin-sheet jet model checked against SPH

Generated by `replication validate-jet` from the data in `data/jet_validation_*.csv`; every
number below is read from those files (re-render with `replication report`). Do not edit by hand.
{quick}
The case study's GA ([casestudy.md](casestudy.md)) maximises the force computed by the thin-sheet
model, an inviscid momentum balance. Its result means something only if the model ranks surfaces
as a converged SPH simulation does. This study scores {len(surfaces)} surfaces ({family_counts}) both
ways and measures how well the rankings agree. **Every force below says which solver produced it.**

## Findings

{findings(d)}

## What was simulated

- **Surfaces** (all height fields in the paper's 36 x 30 x 13 mm domain on y >= 0, valid for both
  solvers; geometry in `data/jet_validation_vertices.csv` and `_triangles.csv`): the flat plate;
  plates inclined along x at {", ".join(f"{a:.3g}" for a in config["angles_deg"]) or "-"} deg; paraboloid
  bowls round the jet axis reaching {", ".join(f"{b:g}" for b in config["bowl_depths_mm"]) or "-"} mm
  at r = 18 mm; the Pelton-bucket approximation; {ga_text}; {config["random_surfaces"]} random
  101-point genomes of the GA's lattice (seeded `[{config["seed"]}, i]`), as in its initial population.
- **SPH**: SPlisHSPlasH {prov.get("engine")} (DFSPH, one thread), the paper's half jet simulated whole
  on the surface joined to its mirror image ([sph.md](sph.md) describes the set-up); {duration:g} ms
  simulated; the mean is taken from {1e3 * config["settle_time"]:g} ms after the jet reaches the surface
  (the sheet on a spiky surface takes that long to settle) to one jet diameter's travel before the end
  (longer and later than the SPH study's runs of the plate and the bucket in sph.md, whose forces
  therefore differ from these by a few per cent).
  SPH forces are given over the **measured** momentum flux of the simulated jet (its particles' mass
  flux x V), the quantity the model's force / rho Q V is; at one particle radius all surfaces get the
  same jet, so rankings are those of the forces.
- **Thin-sheet model**: `jet_force` at its default resolution, the GA's fitness.
- **Agreement**: Spearman's rho and Kendall's tau-b with percentile bootstrap 95 % intervals
  ({config["bootstrap"]:,} resamples of the surfaces, seeded); top-k: how many of the model's k best
  surfaces are among SPH's k best (chance: k^2 / n).
- **Cache**: every simulation is a directory of the SPH cache named by a hash of surface, settings,
  engine version and the SPH code (`replication.casestudy.sph_batch`); {prov.get("simulations", "?")}
  distinct simulations of the scoring and resolution studies took {seconds / 3600:.2f} h of wall time
  (one core each, at most 2 at a time, on a shared 2-core machine under load; the repeatability
  check's shifted runs, whose times were not kept, come on top).{_origin(prov, surfaces)}

## Resolution study

Surfaces spanning the range at particle radii {radii} mm; every surface is then scored at
r = {radius:g} mm. (data: `data/jet_validation_resolution.csv`, `_convergence.csv`.)

{table(resolution_rows(d), RESOLUTION_HEADER[:3] + radius_headers + RESOLUTION_HEADER[3:])}

"Residual bound": |last change| x r1 / (r2 - r1), the error left at the finest radius r1 if the
force converged only linearly in r (the changes shrink faster where they shrink at all, so this is
conservative there).

{table(convergence_rows(d), CONVERGENCE_HEADER)}

{resolution_limit(d)}

![Resolution study](figures/jet_validation_resolution.png)

([SVG](figures/jet_validation_resolution.svg); data: `data/jet_validation_resolution.csv`.)

### Repeatability: the SPH noise floor

The same surfaces moved by {config["repeat_shift_mm"]:g} mm along x (relative to the jet and to the
fluid's particle lattice; a change far below any design change) and simulated again (data:
`data/jet_validation_repeatability.csv`, `_noise.csv`):

{table(repeat_rows(d), REPEAT_HEADER)}

{table(noise_rows(d), NOISE_HEADER)}

"Noise": the standard deviation of one SPH score, from the changes (their root mean square over
sqrt 2). "Best Spearman": the median Spearman of the SPH scores against themselves with that noise
added, the most any model could reach against them.

## Every surface

Force / rho Q V by the thin-sheet model and by SPH at r = {radius:g} mm (data:
`data/jet_validation_surfaces.csv`; the force series in `_series.csv`). SPH spread: standard
deviation of the 1 ms means in the window; drift: the window's second half minus its first
(the flow is not quite steady yet: a common, slow rise).

{table(surface_rows(d), SURFACE_HEADER)}

## Does the model rank the surfaces like SPH?

(data: `data/jet_validation_agreement.csv`)

{table(agreement_rows(d), AGREEMENT_HEADER)}

![Model against SPH](figures/jet_validation_scatter.png)

([SVG](figures/jet_validation_scatter.svg).) Points on the dashed line are scored alike; 2 rho Q V
bounds any steady force of the jet.

{surrogate_section(d)}
{"## Failed simulations" + chr(10) + failures + chr(10) if failures else ""}
## Reproduce

```bash
python -m pip install ".[sph]"
replication validate-jet                 # the study (hours of SPH; resumable, cached in .sph-cache/)
replication validate-jet --from-cache    # re-render from the cache (seconds; fails if one is missing)
replication validate-jet --quick         # three surfaces, coarse particles
```

{provenance_section(prov, "data/jet_validation_provenance.json")}
"""
    path = out / "jet_validation.md"
    write_report(path, text)
    return path


def _origin(prov: dict[str, Any], surfaces: pd.DataFrame) -> str:
    """Which code built the surfaces (the GA's winners) and ran the re-keyed simulations."""
    built = prov.get("surfaces_built_by") or {}
    text = ""
    if built.get("commit"):
        dirty = " with uncommitted changes" if built.get("dirty") else ""
        text += (
            f"\n- **Surfaces' origin**: built once by the code of commit `{built['commit'][:12]}`{dirty} "
            "and kept with the SPH cache (`surfaces/`, the GA runs in `ga-runs/`); the GA winners are the "
            "winners of the GA as run then (a later change of the model, or of how the triangulator breaks "
            "ties on lattice clouds, would change a new GA run's winners; the study keeps scoring these)."
        )
    rekeyed = int(surfaces.get("sph_rekeyed", pd.Series(dtype=bool)).fillna(False).astype(bool).sum())
    if rekeyed:
        text += (
            f"\n- **Re-keyed simulations**: {rekeyed} of the {len(surfaces)} study-radius simulations (and "
            "those of the resolution study run at the same time) were run by the SPH code before its "
            "millimetre-to-metre conversion was unified (x * 1e-3 then, x / 1000 now: the surface "
            "coordinates at most one unit in the last place apart, far below the repeatability shift "
            "above) and kept under the current code's key (each such cache entry holds `rekeyed.json`)."
        )
    return text


def sph_table(out_dir: str | os.PathLike[str]) -> pd.DataFrame | None:
    """The per-surface table of a saved study, or None when there is none."""
    path = Path(out_dir) / "data" / f"{PREFIX}_surfaces.csv"
    return read_csv(path, strings=TEXT_COLUMNS) if path.is_file() else None
