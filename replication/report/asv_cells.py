"""One asv value as the performance page shows it: ``1.23 ms ±4 %``, ``(1 sample)``, ``failed``.

Shared by :mod:`replication.report.performance` (history and comparison) and
:mod:`replication.report.speed_goals` (the goals table).
"""

from __future__ import annotations

import math

import pandas as pd

__all__ = ["BYTE_UNITS", "TIME_UNITS", "format_cell", "spread_percent"]

#: The units a timing is shown in, largest first (below the last: ns).
TIME_UNITS = ((1.0, "s"), (1e-3, "ms"), (1e-6, "µs"))
#: The units a size is shown in, largest first (below the last: B).
BYTE_UNITS = ((2.0**30, "GiB"), (2.0**20, "MiB"))


def _format(value: float, unit: str) -> str:
    if unit == "seconds":
        for scale, suffix in TIME_UNITS:
            if value >= scale:
                return f"{value / scale:.3g} {suffix}"
        return f"{value * 1e9:.3g} ns"
    if unit == "bytes":
        for scale, suffix in BYTE_UNITS:
            if value >= scale:
                return f"{value / scale:.3g} {suffix}"
        return f"{value:,.0f} B"
    if value == int(value) and abs(value) < 1e15:
        return f"{value:,.0f} {unit}".strip()
    return f"{value:.3g} {unit}".strip()


def spread_percent(row: pd.Series | dict) -> float:
    """Half the interquartile range of a timing's samples, in % of its median (NaN if unknown)."""
    q25, q75, value = row["q_25"], row["q_75"], row["value"]
    if any(not math.isfinite(x) for x in (q25, q75, value)) or value <= 0:
        return math.nan
    return 100 * (q75 - q25) / 2 / value


def format_cell(row: pd.Series | dict) -> str:
    """One value as the page shows it: ``1.23 ms ±4 %``, ``(1 sample)``, ``failed``, ``n/a``."""
    if row["status"] != "ok":
        return "failed" if row["status"] == "failed" else "n/a"
    text = _format(float(row["value"]), row["unit"])
    if row["kind"] != "time":
        return text  # memory and tracked values: one measurement by design
    if row["repeat"] == 1:
        return f"{text} (1 sample)"
    spread = spread_percent(row)
    if spread != spread:
        return f"{text} (no spread recorded)"
    return f"{text} ±{spread:.1f} %" if spread < 0.95 else f"{text} ±{spread:.0f} %"
