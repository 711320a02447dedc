"""Figures of the validation study: model against SPH (with the 1:1 line), resolution study."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from replication.report.figures import new_figure, save_figure

__all__ = ["MARKERS", "resolution_figure", "scatter_figure"]

#: Marker and colour of each family.
MARKERS = {
    "plate": ("s", "C0"),
    "cup": ("o", "C1"),
    "GA winner": ("*", "C3"),
    "random lattice": ("^", "C2"),
}


def _scatter(ax: Any, table: Any, x: str, y: str, title: str, held_out: Any = None) -> None:
    ok = table[table["sph_status"] == "ok"]
    for family, (marker, color) in MARKERS.items():
        rows = ok[ok["family"] == family]
        if rows.empty:
            continue
        if held_out is not None:
            held = rows["surface"].isin(held_out)
            ax.scatter(rows.loc[~held, x], rows.loc[~held, y], marker=marker, color=color, s=40,
                       facecolors="none", label=f"{family} (calibration)")  # fmt: skip
            ax.scatter(rows.loc[held, x], rows.loc[held, y], marker=marker, color=color, s=40,
                       label=f"{family} (held out)")  # fmt: skip
        else:
            ax.scatter(rows[x], rows[y], marker=marker, color=color, s=40, label=family)
    lo = 0.8
    hi = max(2.0, float(np.nanmax(ok[[x, y]].to_numpy()))) + 0.05 if len(ok) else 2.05
    ax.plot([lo, hi], [lo, hi], color="0.4", lw=1, ls="--", label="1:1")
    ax.axhline(2.0, color="0.8", lw=0.8)
    ax.axvline(2.0, color="0.8", lw=0.8)
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=6, loc="upper left")


def scatter_figure(d: dict[str, Any], stem: Path) -> None:
    """Model (and surrogate, when calibrated) against SPH, force / rho Q V, with the 1:1 line."""
    table = d["surfaces"]
    surrogate = d.get("surrogate_surfaces")
    panels = 1 if surrogate is None else 2
    fig = new_figure((5.2 * panels, 5.0))
    axes = np.atleast_1d(fig.subplots(1, panels))
    _scatter(axes[0], table, "sph_over_measured_flux", "model_over_rho_q_v", "thin-sheet model (today)")
    axes[0].set_ylabel("thin-sheet model: force / rho Q V")
    if surrogate is not None:
        held = surrogate.loc[surrogate["half"] == "held out", "surface"]
        merged = table.merge(surrogate[["surface", "surrogate_over_rho_q_v"]], on="surface")
        _scatter(axes[1], merged, "sph_over_measured_flux", "surrogate_over_rho_q_v",
                 "surrogate (calibrated on the open markers)", held_out=set(held))  # fmt: skip
        axes[1].set_ylabel("surrogate: force / rho Q V")
    for ax in axes:
        ax.set_xlabel("SPH: mean force / (measured mass flux x V)")
    fig.suptitle("Force on each surface (half jet): model against SPH", fontsize=10)
    fig.tight_layout()
    save_figure(fig, stem)


def resolution_figure(d: dict[str, Any], stem: Path) -> None:
    """SPH force / flux V of the resolution study's surfaces against particle radius."""
    res = d["resolution"]
    res = res[res["sph_status"] == "ok"]
    fig = new_figure((6.4, 4.2))
    ax = fig.subplots()
    for i, (name, rows) in enumerate(res.groupby("surface", sort=False)):
        rows = rows.sort_values("radius_mm")
        marker, _ = MARKERS.get(rows["family"].iloc[0], ("o", None))
        ax.plot(rows["radius_mm"], rows["sph_over_measured_flux"], marker=marker, ls="-", color=f"C{i}",
                label=f"{name} (model {rows['model_over_rho_q_v'].iloc[0]:.2f})")  # fmt: skip
    ax.set_xlabel("particle radius [mm] (finer to the right)")
    ax.set_ylabel("SPH: mean force / (measured mass flux x V)")
    ax.invert_xaxis()
    ax.legend(fontsize=7)
    ax.set_title("Resolution study: does the SPH ranking settle?", fontsize=10)
    fig.tight_layout()
    save_figure(fig, stem)
