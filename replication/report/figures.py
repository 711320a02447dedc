"""Matplotlib figures (Agg canvas, no global backend change), written atomically as PNG and SVG."""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from replication.experiments.claims import PAPER
from replication.io.atomic import atomic_path

__all__ = ["DPI", "clear_figures", "fig6", "figure_files", "new_figure", "save_figure"]

#: The resolution of the PNG of every matplotlib figure the reports hold.
DPI = 150


def new_figure(figsize: tuple[float, float]) -> Figure:
    """A figure of ``figsize`` inches at the saved files' :data:`DPI`, on an Agg canvas.

    ``tight_layout`` and :func:`save_figure`'s layout pass and bounding box then measure the
    text with one renderer. Matplotlib caches text extents per renderer, so a figure laid out
    at the default 100 dpi and saved at 150 measured every label once more: this takes 10-15 %
    off a figure's build and save (Fig. 9 of the case study: 0.40 to 0.35 s).
    """
    fig = Figure(figsize=figsize, dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def save_figure(
    fig: Figure, stem: str | os.PathLike[str], formats: tuple[str, ...] = ("png", "svg")
) -> list[Path]:
    """Save ``fig`` as ``stem.png`` and ``stem.svg`` atomically (no timestamps in the files).

    Both files are cropped to the figure's tight bounding box (matplotlib's
    ``bbox_inches="tight"``), found once at the PNG's :data:`DPI`. Matplotlib's own "tight"
    lays the figure out again for every format (a pass without drawing, then the bounding
    box): 4 passes for two formats where 3 do, about 15 % of the save. The placeholder
    layout engine ``tight_layout`` leaves would force that pass too, so after the layout
    the figure has no layout engine (the layout saved is the one it keeps).
    """
    if not isinstance(fig.canvas, FigureCanvasAgg):  # one made by new_figure keeps its renderer
        FigureCanvasAgg(fig)
    paths = []
    # no layout engine from the user's matplotlibrc may lay the figure out again (matplotlib
    # sets the figure's engine anew after each save); a fixed salt for the SVG's element ids,
    # so that the same data give byte-identical files
    rc = {"figure.autolayout": False, "figure.constrained_layout.use": False, "svg.hashsalt": "replication"}
    with matplotlib.rc_context(rc):
        fig.set_dpi(DPI)
        fig.draw_without_rendering()  # the layout, as each format's draw will see it
        box = fig.get_tightbbox(fig.canvas.get_renderer()).padded(matplotlib.rcParams["savefig.pad_inches"])
        fig.set_layout_engine(None)  # laid out: no pass before each format's draw
        for ext in formats:
            path = Path(f"{stem}.{ext}")
            metadata = {"Date": None} if ext == "svg" else {"Software": None}
            with atomic_path(path) as tmp:
                fig.savefig(tmp, format=ext, dpi=DPI, metadata=metadata, bbox_inches=box)
            paths.append(path)
    return paths


def _own_figures(directory: Path, prefix: str) -> list[Path]:
    if not directory.is_dir():
        return []
    return [p for p in sorted(directory.glob(f"{prefix}*")) if p.is_file() and p.suffix in (".png", ".svg")]


def _identity(path: Path) -> tuple[int, int]:
    stat = path.stat()
    return stat.st_ino, stat.st_mtime_ns


def figure_files(figures: str | os.PathLike[str], prefix: str) -> dict[Path, tuple[int, int]]:
    """A report's own figures (``prefix*.png``/``.svg``) and their identity (inode, mtime):
    taken before a render, it tells :func:`clear_figures` which files the render did not write
    (every figure is written by an atomic replace, so a rewritten one has a new inode)."""
    return {p: _identity(p) for p in _own_figures(Path(figures), prefix)}


def clear_figures(
    figures: str | os.PathLike[str], prefix: str, *, before: dict[Path, tuple[int, int]] | None = None
) -> list[Path]:
    """Remove a report's own generated figures (``prefix*.png``/``.svg``) that a render left stale.

    A report's set of figures depends on its data (one render per GA run, one per n), so
    a re-render must not leave figures of an earlier run next to its own. Only files named
    with the report's prefix are removed; with ``before`` (:func:`figure_files` taken before
    the render) only those the render did not write again. The renderers call it after a
    render that succeeded, so one that fails on its data removes nothing. Returns the
    removed paths.
    """
    removed = []
    for path in _own_figures(Path(figures), prefix):
        if before is not None and before.get(path) != _identity(path):
            continue  # written by this render
        path.unlink()
        removed.append(path)
    return removed


def _series(mc: pd.DataFrame, quantity: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rows = mc[mc["quantity"] == quantity].sort_values("n")
    n = rows["n"].to_numpy(float)
    med = rows["median"].to_numpy(float)
    err = np.vstack([med - rows["q1"].to_numpy(float), rows["q3"].to_numpy(float) - med])
    return n, med, err


def fig6(montecarlo: pd.DataFrame, stem: str | os.PathLike[str]) -> list[Path]:
    """Fig. 6: storage and computation time against n, with the paper's 9-point values.

    Markers are Monte Carlo medians over the seeds, error bars the inter-quartile range.
    """
    fig = new_figure((10, 4.2))
    ax1, ax2 = fig.subplots(1, 2)
    for quantity, label, color in (
        ("adt_bytes", "ADT (.vtk)", "C0"),
        ("nurbs_bytes", "NURBS (.smesh)", "C1"),
    ):
        n, med, err = _series(montecarlo, quantity)
        ax1.errorbar(n, med, yerr=err, marker="o", capsize=3, color=color, label=f"{label}, ours")
    for key, method, color in (("adt_bytes_9", "ADT", "C0"), ("nurbs_bytes_9", "NURBS", "C1")):
        paper = PAPER[key]
        label = f"{method}, paper: {paper.quote} (9 points)"
        ax1.plot([9], [paper.value], "s", mfc="none", color=color, ms=9, label=label)
    ax1.set_xlabel("number of points n")
    ax1.set_ylabel("file size [bytes]")
    ax1.set_title("(a) storage")
    ax1.legend(fontsize=8)
    for quantity, label, color in (
        ("adt_s", "ADT", "C0"),
        ("nurbs_geomdl_s", "NURBS (geomdl)", "C1"),
        ("nurbs_fast_s", "NURBS (fast evaluator)", "C2"),
    ):
        n, med, err = _series(montecarlo, quantity)
        ax2.errorbar(n, med, yerr=err, marker="o", capsize=3, color=color, label=f"{label}, ours")
    for key, method, color in (("adt_s_9", "ADT", "C0"), ("nurbs_s_9", "NURBS", "C1")):
        paper = PAPER[key]
        label = f"{method}, paper: {paper.quote} (9 points)"
        ax2.plot([9], [paper.value], "s", mfc="none", color=color, ms=9, label=label)
    ax2.set_yscale("log")
    ax2.set_xlabel("number of points n")
    ax2.set_ylabel("computation time [s]")
    ax2.set_title("(b) computation time")
    ax2.legend(fontsize=8)
    fig.suptitle("Fig. 6 reproduced: medians over random clouds, bars = inter-quartile range")
    fig.tight_layout()
    return save_figure(fig, stem)


def scale_figure(scale: pd.DataFrame, stem: str | os.PathLike[str]) -> list[Path]:
    """Build time against n on log-log axes for every method of the scale sweep."""
    fig = new_figure((6, 4.2))
    ax = fig.subplots()
    for i, (method, rows) in enumerate(scale.groupby("method", sort=True)):
        rows = rows.sort_values("n")
        med = rows["median"].to_numpy(float)
        err = np.vstack([med - rows["q1"].to_numpy(float), rows["q3"].to_numpy(float) - med])
        ax.errorbar(rows["n"], med, yerr=err, marker="o", capsize=3, color=f"C{i}", label=method)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("number of points n")
    ax.set_ylabel("build time [s]")
    ax.set_title("Scale sweep (continuous clouds)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, stem)
