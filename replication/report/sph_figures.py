"""Figures of the SPH report: force series of every run, and DFSPH convergence."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from replication.report.figures import new_figure, save_figure

__all__ = ["convergence_figure", "run_label", "series_figure"]


def run_label(r: pd.Series) -> str:
    if r["method"] == "wcsph":
        return f"WCSPH c = {r['sound_speed_m_s']:.3g} m/s, r = {r['radius_mm']:g} mm"
    return f"DFSPH, r = {r['radius_mm']:g} mm"


def series_figure(d: dict[str, Any], stem: Path) -> None:
    runs, series = d["runs"], d["series"]
    shapes = list(dict.fromkeys(runs["shape"]))
    fig = new_figure((11, 4.2))
    axes = np.atleast_1d(fig.subplots(1, len(shapes), sharey=True))
    for ax, shape in zip(axes, shapes):
        for i, (_, r) in enumerate(runs[(runs["shape"] == shape) & (runs["status"] == "ok")].iterrows()):
            rows = series[
                (series["shape"] == shape)
                & (series["method"] == r["method"])
                & np.isclose(series["radius_mm"], r["radius_mm"])
                & np.isclose(
                    series["sound_speed_m_s"].fillna(-1),
                    -1 if np.isnan(r["sound_speed_m_s"]) else r["sound_speed_m_s"],
                )
            ]
            style = "-" if r["method"] == "dfsph" else "--"
            ax.step(
                rows["t_start_ms"], rows["axial_N"], where="post", ls=style, color=f"C{i}", label=run_label(r)
            )
            ax.plot([r["peak_time_ms"] + r["peak_window_ms"] / 2], [r["peak_N"]], "v", color=f"C{i}")
        shape_row = d["shapes"].set_index("shape").loc[shape]
        ax.axhline(shape_row["thin_sheet_N"], color="0.3", ls=":", label="thin-sheet model")
        ax.axhline(shape_row["paper_N"], color="red", ls="-.", label="paper (DualSPHysics)")
        ax.set_title(shape)
        ax.set_xlabel("time [ms]")
        first = runs[runs["shape"] == shape].iloc[0]
        ax.axvspan(first["window_start_ms"], first["window_end_ms"], color="0.9", zorder=0,
                   label="quasi-steady window")  # fmt: skip
        ax.set_ylim(bottom=0)
    axes[0].set_ylabel("axial force of the half jet [N]")
    axes[-1].legend(fontsize=6)
    fig.suptitle("Force on the surface: 1 ms means (lines), first-impact peaks (triangles)")
    fig.tight_layout()
    save_figure(fig, stem)


def convergence_figure(d: dict[str, Any], stem: Path) -> None:
    runs = d["runs"]
    dfsph = runs[(runs["method"] == "dfsph") & (runs["status"] == "ok")]
    fig = new_figure((11, 3.8))
    ax1, ax2, ax3 = fig.subplots(1, 3)
    for i, (shape, rows) in enumerate(dfsph.groupby("shape", sort=False)):
        rows = rows.sort_values("radius_mm")
        ax1.plot(
            rows["radius_mm"], rows["mean_over_rho_q_v"], "o-", color=f"C{i}", label=f"{shape}, / rho Q V"
        )
        ax1.plot(
            rows["radius_mm"],
            rows["mean_over_measured_flux"],
            "s--",
            color=f"C{i}",
            mfc="none",
            label=f"{shape}, / measured flux x V",
        )
        ax2.plot(rows["radius_mm"], rows["peak_N"], "o-", color=f"C{i}", label=f"{shape}, DFSPH")
        ax3.plot(rows["radius_mm"], rows["wall_s_per_simulated_ms"], "o-", color=f"C{i}", label=shape)
        wcsph = runs[(runs["method"] == "wcsph") & (runs["status"] == "ok") & (runs["shape"] == shape)]
        for k, (c, group) in enumerate(wcsph.groupby("sound_speed_m_s")):
            group = group.sort_values("radius_mm")
            style = {"marker": "v", "ls": "--" if k == 0 else ":", "color": f"C{i}"}
            ax2.plot(group["radius_mm"], group["peak_N"], label=f"{shape}, WCSPH c = {c:.3g} m/s", **style)
            if i == 0:  # the water-hammer force rho c V A of the half jet at this c
                rcva = float((group["peak_N"] / group["peak_over_rho_c_v_a"]).iloc[0])
                ax2.axhline(rcva, color="0.5", lw=0.8, ls=":")
                ax2.annotate(f"rho c V A, c = {c:.3g} m/s", (0.02, rcva), xycoords=("axes fraction", "data"),
                             fontsize=6, va="bottom", color="0.4")  # fmt: skip
    ax1.set_ylabel("quasi-steady mean force")
    ax2.set_ylabel("first-impact peak [N] (0.1 ms mean)")
    ax2.set_ylim(bottom=0)
    ax3.set_ylabel("wall time per simulated ms [s]")
    ax3.set_yscale("log")
    for ax in (ax1, ax2, ax3):
        ax.set_xlabel("particle radius [mm]")
        ax.invert_xaxis()
        ax.legend(fontsize=6, loc="center right" if ax is ax2 else "best")
    fig.suptitle("Convergence with particle size (half jet; finer particles to the right)")
    fig.tight_layout()
    save_figure(fig, stem)
