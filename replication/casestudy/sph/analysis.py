"""From the per-step force of a simulation to its summary: bins, quasi-steady mean, peaks.

The force is constant within a time step (it is the step's momentum change over its
length), so the impulse is piecewise linear in time and every average over an interval is
exact: (I(b) - I(a)) / (b - a).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from replication.errors import CloudFileError

__all__ = ["ForceSummary", "read_steps", "running_mean_max", "summarize_force"]


@dataclass(frozen=True, eq=False)
class ForceSummary:
    """Averages of the axial force (N, positive along the jet) and the binned series."""

    bin_time: np.ndarray  # (k,) start of each bin (s)
    bin_force: np.ndarray  # (k, 3) mean force of each bin (N)
    mean_force: np.ndarray  # (3,) mean force over the quasi-steady window
    std_axial: float  # standard deviation of the window's bin means
    peak_axial: float  # largest running mean before the window (first impact)
    peak_time: float  # start of the averaging interval of that peak
    max_axial: float  # largest running mean over the whole run
    max_step_axial: float  # largest force of a single step


def read_steps(path: str | Path) -> dict[str, np.ndarray]:
    """The columns of a ``steps.csv`` written by the driver (an empty run gives empty arrays;
    a row cut short by a crash is dropped)."""
    path = Path(path)
    if not path.is_file():
        raise CloudFileError(f"no force series: {path} is missing")
    text = path.read_text()
    lines = text.splitlines()[1:]
    if lines and not text.endswith("\n"):  # a crash can cut the last row short
        lines.pop()
    data = np.loadtxt(lines, delimiter=",", ndmin=2) if lines else np.empty((0, 7))
    names = ("step", "time", "dt", "fx", "fy", "fz", "max_speed")
    return {name: data[:, i] for i, name in enumerate(names)}


def _cumulative(time: np.ndarray, dt: np.ndarray, force: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Knots (s) and cumulative impulse (N s) at them, starting from (t0, 0)."""
    knots = np.concatenate([[time[0] - dt[0]], time])
    impulse = np.vstack([np.zeros((1, force.shape[1])), np.cumsum(force * dt[:, None], axis=0)])
    return knots, impulse


def _mean(knots: np.ndarray, impulse: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Mean force over [a, b] for arrays of interval ends (one column per force component)."""
    ia = np.column_stack([np.interp(a, knots, impulse[:, k]) for k in range(impulse.shape[1])])
    ib = np.column_stack([np.interp(b, knots, impulse[:, k]) for k in range(impulse.shape[1])])
    return (ib - ia) / (b - a)[:, None]


def running_mean_max(
    time: np.ndarray, dt: np.ndarray, force: np.ndarray, width: float, start: float, stop: float
) -> tuple[float, float]:
    """Largest mean of ``force`` (1-D) over an interval of ``width`` inside [start, stop].

    The running mean is piecewise linear in the interval's start, so its maximum lies where
    an end of the interval meets a step boundary: those candidates are all evaluated.
    Returns (maximum, start of its interval); (nan, nan) when no interval fits.
    """
    if time.size == 0 or stop - start < width:
        return float("nan"), float("nan")
    knots, impulse = _cumulative(time, dt, force[:, None])
    candidates = np.concatenate([knots, knots - width, [start, stop - width]])
    candidates = np.unique(candidates[(candidates >= start) & (candidates <= stop - width)])
    means = _mean(knots, impulse, candidates, candidates + width)[:, 0]
    i = int(np.argmax(means))
    return float(means[i]), float(candidates[i])


def summarize_force(
    steps: dict[str, np.ndarray],
    window: tuple[float, float],
    *,
    bin_width: float,
    peak_window: float,
    scale: float = 1.0,
) -> ForceSummary:
    """Bins, quasi-steady mean and spread, impact peak and maxima of a force series.

    Parameters
    ----------
    steps
        From :func:`read_steps`: the force of the fluid on the surface per step.
    window
        Quasi-steady averaging window (s); the first-impact peak is looked for before it.
    scale
        Factor applied to every force (1/2 for a half jet simulated as a whole one).

    Notes
    -----
    Paper section 6: the force of the jet on the surface, the GA's objective.
    """
    time, dt = steps["time"], steps["dt"]
    force = scale * np.column_stack([steps["fx"], steps["fy"], steps["fz"]])
    end = float(time[-1]) if time.size else 0.0
    a, b = window
    nan = float("nan")
    if time.size == 0:
        return ForceSummary(np.empty(0), np.empty((0, 3)), np.full(3, nan), nan, nan, nan, nan, nan)
    knots, impulse = _cumulative(time, dt, force)
    starts = np.arange(0.0, end - bin_width * (1 - 1e-9), bin_width)
    bins = _mean(knots, impulse, starts, starts + bin_width) if starts.size else np.empty((0, 3))
    if end < b:  # a run that stopped early: its bins, but no window
        return ForceSummary(starts, bins, np.full(3, nan), nan, nan, nan, nan, nan)
    mean = _mean(knots, impulse, np.array([a]), np.array([b]))[0]
    k = int((b - a) / bin_width + 1e-9)
    inner = a + bin_width * np.arange(k)
    spread = (
        float(np.std(-_mean(knots, impulse, inner, inner + bin_width)[:, 2], ddof=1))
        if k > 1
        else float("nan")
    )
    axial = -force[:, 2]
    peak, peak_time = running_mean_max(time, dt, axial, peak_window, float(knots[0]), a)
    largest, _ = running_mean_max(time, dt, axial, peak_window, float(knots[0]), end)
    return ForceSummary(
        bin_time=starts,
        bin_force=bins,
        mean_force=mean,
        std_axial=spread,
        peak_axial=peak,
        peak_time=peak_time,
        max_axial=largest,
        max_step_axial=float(axial.max()),
    )
