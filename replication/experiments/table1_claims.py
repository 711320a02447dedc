"""The Table 1 / Fig. 6 claims of the paper beside ours, decided by the rules of :mod:`.claims`.

Sizes come from the Monte Carlo clouds (many per n) in every representation family
(:mod:`.storage`); times from the interleaved harness on the Table 1 cloud (many repeats),
NURBS built with geomdl as the paper-faithful reference unless stated; trends from the
per-cloud Monte Carlo values. The ``paper`` column holds the paper's words verbatim.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from replication.experiments.claims import (
    FACTOR_TOLERANCE,
    MAJORITY,
    MIN_TIMING_PAIRS,
    PAPER,
    Trend,
    combine,
    factor_verdict,
    median_interval,
    share_verdict,
    storage_overall,
    timing_factor_verdict,
    trend_verdict,
)
from replication.experiments.paper import PAPER_TABLE1_STATEMENTS as WORDS
from replication.experiments.paper import PaperStatement, PaperValue
from replication.experiments.storage import COORDINATES, EQUAL_PRECISION, FAMILIES
from replication.experiments.timing import TIMING_DRIFT

__all__ = ["STORAGE_HEADLINE", "table1_claims"]

#: The claim (prefix) of the headline storage row.
STORAGE_HEADLINE = "ADT needs almost half the storage of NURBS, across representation families"
SHORT = {
    "ascii_exact": "shortest exact ASCII",
    "ascii_6": "6 significant digits",
    "binary32": "float32 binary",
    "floor": "information floor",
}
WHY_ABSOLUTE = (
    "the paper does not state its file formats, number precision or machine (MATLAB); only "
    "orders of magnitude can be set side by side"
)


@dataclass(frozen=True)
class _Row:
    claim: str
    paper: PaperValue | PaperStatement | None
    ours: float
    ours_q1: float
    ours_q3: float
    unit: str
    verdict: str
    why: str

    def as_dict(self) -> dict[str, object]:
        numeric = isinstance(self.paper, PaperValue) and np.isfinite(self.ours)
        ratio = self.ours / self.paper.value if numeric else np.nan  # a statement has no number
        return {
            "claim": self.claim,
            "paper": self.paper.quote if self.paper else None,
            "ours": self.ours,
            "ours_q1": self.ours_q1,
            "ours_q3": self.ours_q3,
            "unit": self.unit,
            "ratio_ours_to_paper": ratio,
            "verdict": self.verdict,
            "why": self.why,
        }


def _mc(frame: pd.DataFrame, n: int, quantity: str) -> tuple[float, float, float, float]:
    """(median, q1, q3, count) of a summarised quantity at n, NaN when absent."""
    row = frame[(frame["n"] == n) & (frame["quantity"] == quantity)]
    if row.empty:
        return (np.nan, np.nan, np.nan, np.nan)
    r = row.iloc[0]
    return float(r["median"]), float(r["q1"]), float(r["q3"]), float(r.get("count", np.nan))


def _fraction(mc: pd.DataFrame, n: int, quantity: str) -> float:
    row = mc[(mc["n"] == n) & (mc["quantity"] == quantity)]
    return float(row.iloc[0]["fraction"]) if not row.empty else np.nan


def _num(value: float, spec: str, suffix: str = "") -> str:
    """A number for the explanation texts; 'n/a' where it could not be computed."""
    return f"{value:{spec}}{suffix}" if np.isfinite(value) else "n/a (fewer than 3 pairs)"


def _by_n(values: dict[int, float], spec: str, suffix: str = "") -> str:
    return ", ".join(f"{n}: {_num(v, spec, suffix)}" for n, v in values.items())


def _ns(ns: list[int]) -> str:
    return ", ".join(str(n) for n in ns) if ns else "none"


def _trend(raw: pd.DataFrame | None, column: str, direction: int, drift: float = 1.0) -> Trend:
    if raw is None or column not in raw:
        return trend_verdict(np.array([]), np.array([]), direction=direction)
    return trend_verdict(raw["n"].to_numpy(), raw[column].to_numpy(), direction=direction, drift=drift)


def _factor_rows(per_n: dict[int, tuple[float, float, float, float]], paper: float, smaller: bool) -> dict:
    """Factor verdicts by n of an exact quantity (file sizes; timings: ``timing_factor_verdict``)."""
    return {
        n: factor_verdict(v[0], paper, smaller_is_adt_better=smaller, interval=median_interval(*v))
        for n, v in per_n.items()
    }


def _storage_rows(storage: pd.DataFrame, ns: tuple[int, ...]) -> list[_Row]:
    """One row per (family, coordinates) and the headline row across families."""
    large = max(ns)
    rows, verdicts, ratios, half = [], {}, {}, {}
    kinds = [(k, d) for k, d in COORDINATES if (storage["coordinates"] == k).any()]
    for family, description in FAMILIES:
        for kind, kind_text in kinds:
            sel = storage[(storage["family"] == family) & (storage["coordinates"] == kind)].set_index("n")
            per_n = {n: tuple(float(sel.loc[n, c]) for c in ("ratio", "ratio_q1", "ratio_q3", "count"))
                     for n in ns if n in sel.index}  # fmt: skip
            by_n = _factor_rows(per_n, PAPER["size_ratio"].value, True)
            verdicts[family, kind] = combine(list(by_n.values()))
            ratios[family, kind] = {n: v[0] for n, v in per_n.items()}
            half[family, kind] = [n for n, v in by_n.items() if v == "holds"]
            smaller = [n for n, v in by_n.items() if v in ("holds", "partly holds")]
            rows.append(_Row(
                f"ADT needs almost half the storage of NURBS: {description}, {kind_text} coordinates "
                f"(ADT/NURBS size, median at n = {large}; decided over n = {min(ns)}..{large})",
                PAPER["size_ratio"], *per_n.get(large, (np.nan,) * 4)[:3], "ratio", verdicts[family, kind],
                f"ADT/NURBS by n: {_by_n(ratios[family, kind], '.2f')}; about half (x1.5) at "
                f"n = {_ns(half[family, kind])}; ADT more than 10 % smaller at n = {_ns(smaller)}",
            ))  # fmt: skip
    overall = storage_overall(verdicts)
    equal = ", ".join(
        f"{' / '.join(_num(ratios[f, k].get(large, np.nan), '.2f') for k, _ in kinds)} ({SHORT[f]})"
        for f in EQUAL_PRECISION
    )
    why = (
        f"at equal precision: ADT/NURBS at n = {large} is {equal} with "
        f"{' / '.join(k for k, _ in kinds)} coordinates; "
    )
    groups: dict[tuple[str, tuple[int, ...]], list[str]] = {}
    for (f, k), at in half.items():
        if at:
            groups.setdefault((f, tuple(at)), []).append(k)
    parts = []
    for (f, at), where in groups.items():
        by_n = (
            ", ".join(_num(r, ".2f") for r in ratios[f, where[0]].values()) + f" over n = {min(ns)}..{large}"
            if len(where) == 1
            else " / ".join(_num(ratios[f, k].get(at[0], np.nan), ".2f") for k in where)
        )
        parts.append(f"{SHORT[f]} with {' and '.join(where)} coordinates at n = {_ns(list(at))} ({by_n})")
    why += "ADT is about half only in: " + "; ".join(parts) if parts else "ADT is about half in no family"
    label = f"{STORAGE_HEADLINE} (decided at equal precision; n = {min(ns)}..{large})"
    rows.append(_Row(label, PAPER["size_ratio"], np.nan, np.nan, np.nan, "ratio", overall, why))
    return rows


def _paper_file_reading(storage: pd.DataFrame | None, key: str) -> str:
    """What the paper's 9-point file sizes say about how its numbers were written."""
    if storage is None or key not in ("adt_bytes_9", "nurbs_bytes_9") or 9 not in set(storage["n"]):
        return ""
    paper = PAPER[key]
    rows = storage[(storage["n"] == 9) & storage["family"].isin(["ascii_exact", "ascii_6"])]
    sizes = {(r["coordinates"], r["family"]): r for _, r in rows.iterrows()}
    if key == "nurbs_bytes_9":
        per = ", ".join(
            f"{r['nurbs_bytes'] / r['control_points']:.0f} ({k}, {SHORT[f]})" for (k, f), r in sizes.items()
        )
        first = next(iter(sizes.values()))
        return (
            f"; {paper.quote} for a {int(first['control_points'])}-point net is "
            f"{paper.value / first['control_points']:.0f} bytes per control point, against ours: {per}"
        )
    nearest = min(sizes, key=lambda key: abs(sizes[key]["adt_bytes"] - paper.value))
    parts = ", ".join(f"{int(round(r['adt_bytes']))} bytes ({k}, {SHORT[f]})" for (k, f), r in sizes.items())
    text = f"; our 9-point files: {parts}; {paper.quote} is nearest to {nearest[0]} coordinates"
    lattice = sizes.get(("lattice", "ascii_exact"))
    if lattice is not None:
        overhead = lattice["adt_bytes"] - lattice["adt_point_bytes"]
        chars = (paper.value - overhead) / (3 * lattice["vertices"])
        per = ", ".join(
            f"{r['adt_point_bytes'] / (3 * r['vertices']):.1f} ({k}, {SHORT[f]})"
            for (k, f), r in sizes.items()
        )
        text += (
            f": after our header and triangle lines ({int(round(overhead))} bytes) it leaves "
            f"{chars:.1f} characters per coordinate with its separator, against ours: {per}"
        )
    return text


def table1_claims(
    montecarlo: pd.DataFrame,
    timings: pd.DataFrame,
    ns: tuple[int, ...],
    *,
    montecarlo_raw: pd.DataFrame | None = None,
    storage: pd.DataFrame | None = None,
) -> pd.DataFrame:
    """Every claim with the paper's value (verbatim), ours (median and quartiles), ratio and verdict.

    Parameters
    ----------
    montecarlo, montecarlo_raw : DataFrame
        Summarised and per-cloud Monte Carlo results (sizes in the headline formats, times,
        statistics); the per-cloud values decide the trend claims.
    timings : DataFrame
        Summarised interleaved timings of the Table 1 clouds.
    ns : tuple of int
    storage : DataFrame, optional
        :func:`replication.experiments.storage.summarize_storage` of the Monte Carlo clouds.

    Notes
    -----
    Paper section 4 (Table 1) and section 5, items 1 and 2.
    """
    rows: list[_Row] = []
    small, large = min(ns), max(ns)
    if small == 9:
        for key, label, unit, source in (
            ("adt_bytes_9", "ADT file size, 9 points", "bytes", ("mc", "adt_bytes")),
            ("nurbs_bytes_9", "NURBS file size, 9 points", "bytes", ("mc", "nurbs_bytes")),
            ("adt_s_9", "ADT computation time, 9 points", "s", ("t", "adt [s]")),
            ("nurbs_s_9", "NURBS computation time (geomdl), 9 points", "s", ("t", "nurbs_geomdl [s]")),
        ):
            med, q1, q3, _ = _mc(montecarlo if source[0] == "mc" else timings, 9, source[1])
            why = WHY_ABSOLUTE + _paper_file_reading(storage, key)
            rows.append(_Row(label, PAPER[key], med, q1, q3, unit, "cannot be compared", why))
    if large == 200:
        med, q1, q3, _ = _mc(montecarlo, 200, "size_difference")
        rows.append(_Row("NURBS minus ADT file size, 200 points", PAPER["size_difference_200"], med, q1, q3,
                         "bytes", "cannot be compared", WHY_ABSOLUTE))  # fmt: skip
        g, a = _mc(timings, 200, "nurbs_geomdl [s]"), _mc(timings, 200, "adt [s]")
        label = "NURBS minus ADT computation time (geomdl), 200 points (the Table 1 cloud's timings)"
        rows.append(_Row(label, PAPER["time_difference_200"], g[0] - a[0], np.nan, np.nan, "s",
                         "cannot be compared", WHY_ABSOLUTE))  # fmt: skip

    if storage is not None:
        rows += _storage_rows(storage, ns)

    # "almost 3 times faster" (NURBS / ADT build time, per repeat pair, with the median's interval)
    for label, quantity in (
        ("geomdl, the paper-faithful NURBS", "nurbs_geomdl/adt"),
        ("fast NdBSpline evaluator", "nurbs_fast/adt"),
    ):
        per_n = {n: _mc(timings, n, quantity) for n in ns}
        by_n = {n: timing_factor_verdict(*v, PAPER["speed_ratio"].value) for n, v in per_n.items()}
        pairs = {int(v[3]) for v in per_n.values() if np.isfinite(v[3])}
        few = (
            f"; only {'/'.join(str(p) for p in sorted(pairs))} repeat pairs per n: a timing claim is "
            f"decided from at least {MIN_TIMING_PAIRS} (a quick run's ratios move more between runs "
            "than their interval shows)"
            if pairs and min(pairs) < MIN_TIMING_PAIRS
            else ""
        )
        rows.append(_Row(
            f"ADT is almost 3 times faster than NURBS ({label}; NURBS/ADT time, median at n = {large}; "
            f"decided over n = {small}..{large})",
            PAPER["speed_ratio"], *per_n[large][:3], "ratio", combine(list(by_n.values())),
            "NURBS/ADT time by n: " + ", ".join(f"{n}: {v[0]:.1f}" for n, v in per_n.items())
            + f"; 'almost 3' taken as within x{FACTOR_TOLERANCE:g} for the 95 % interval of the median, "
            f"widened x{TIMING_DRIFT:g} for the drift of timings between runs; verdicts by n: "
            + ", ".join(f"{n}: {v}" for n, v in by_n.items()) + few,
        ))  # fmt: skip

    # "the difference grows with the number of points": fitted trends over the clouds
    for label, quantity, unit, drift in (
        ("file size (shortest exact ASCII)", "size_difference", "bytes", 1.0),  # exact
        ("computation time (geomdl)", "time_difference_geomdl", "s", TIMING_DRIFT),
    ):
        medians = {n: _mc(montecarlo, n, quantity)[0] for n in ns}
        trend = _trend(montecarlo_raw, quantity, +1, drift)
        rows.append(_Row(
            f"the NURBS-ADT difference in {label} grows with n (Monte Carlo median at n = {large})",
            WORDS["difference_grows"], medians[large], np.nan, np.nan, unit, trend.verdict,
            f"{trend.describe((small, large))}; Monte Carlo medians by n: "
            + ", ".join(f"{n}: {m:.4g}" for n, m in medians.items()),
        ))  # fmt: skip

    # statistics: the paper's reading, and what it does not show
    for prefix, pairing in (("a_", "NURBS samples"), ("b_", "cloud points")):
        both = {n: _fraction(montecarlo, n, f"{prefix}both_similar") for n in ns}
        equivalent = {n: _fraction(montecarlo, n, f"{prefix}equivalent") for n in ns}
        rms = {n: _mc(montecarlo, n, f"{prefix}rms_pct") for n in ns}
        rows.append(_Row(
            f"t-test and Wilcoxon find the surfaces 'similar' at 95 % (pairing at {pairing}; "
            f"fraction of clouds at n = {large}; decided over n = {small}..{large})",
            WORDS["similar"], both[large], np.nan, np.nan, "fraction",
            share_verdict(both, lambda f: f >= MAJORITY),
            "fraction of clouds where neither test rejects, by n: "
            + _by_n(both, ".2f")
            + "; failing to reject a difference is not evidence of similarity",
        ))  # fmt: skip
        rows.append(_Row(
            f"equivalent within 5 % of the depth range (TOST on the mean difference; pairing at {pairing}; "
            f"fraction of clouds at n = {large}; decided over n = {small}..{large})",
            WORDS["under_5_statistically"], equivalent[large], np.nan, np.nan, "fraction",
            share_verdict(equivalent, lambda f: f >= MAJORITY),
            "fraction of clouds shown equivalent, by n: " + _by_n(equivalent, ".2f"),
        ))  # fmt: skip
        rows.append(_Row(
            f"deviation under 5 % (RMS deviation as % of the depth range; pairing at {pairing}; "
            f"median at n = {large}; decided over n = {small}..{large})",
            PAPER["deviation_pct"], *rms[large][:3], "%",
            share_verdict({n: v[0] for n, v in rms.items()}, lambda r: r < PAPER["deviation_pct"].value),
            "median RMS deviation by n: " + _by_n({n: v[0] for n, v in rms.items()}, ".1f", " %")
            + "; the surfaces agree on average, not point by point",
        ))  # fmt: skip
        trend = _trend(montecarlo_raw, f"{prefix}rms_pct", -1)
        rows.append(_Row(
            f"the deviation shrinks as n grows (pairing at {pairing}; median RMS % at n = {large})",
            WORDS["deviation_reduced"], rms[large][0], np.nan, np.nan, "%", trend.verdict,
            f"{trend.describe((small, large))}; median RMS deviation by n: "
            + _by_n({n: v[0] for n, v in rms.items()}, ".1f", " %"),
        ))  # fmt: skip
    return pd.DataFrame([r.as_dict() for r in rows])
