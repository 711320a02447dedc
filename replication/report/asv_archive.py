"""The asv results kept with the reports: ``reports/data/performance_asv.csv``.

asv's results directory (``.asv/results``) is git-ignored and local to one machine: a fresh
checkout has none, and a page drawn from it alone would drop the history the committed page
showed. Every value of :mod:`replication.report.performance` is therefore kept in this CSV,
committed with the reports. ``replication report --performance`` merges asv's files into it
(a value asv holds again replaces the archived one: same machine, commit, environment,
benchmark and parameters) and draws the page from the merge, so a checkout without asv's
files redraws the same page and one with new results adds to the history.

The columns are those of :func:`replication.report.asv_results.load_asv_results`, plus
``source``: ``asv`` for values read from asv's files, ``page`` for values recovered from an
earlier page (:func:`rows_from_page`), which show three significant digits and a rounded
spread, and carry no samples or confidence interval, so no comparison can test them.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import pandas as pd

from replication.errors import ReportDataError
from replication.report.asv_cells import BYTE_UNITS, TIME_UNITS
from replication.report.asv_results import COLUMNS, param_grid, params_text
from replication.report.store import read_csv, write_csv

__all__ = [
    "ARCHIVE", "ARCHIVE_COLUMNS", "KEY", "merge_results", "read_archive", "rows_from_page", "write_archive",
]  # fmt: skip

#: The archive's file name, under the reports' ``data/`` directory.
ARCHIVE = "performance_asv.csv"
#: Its columns: asv's values, and where each came from (``asv`` or ``page``).
ARCHIVE_COLUMNS = (*COLUMNS, "source")
#: One value per key: a newer reading of the same key replaces the archived one.
KEY = ["machine", "commit", "env", "benchmark", "params"]
_TEXT = ("machine", "commit", "env", "benchmark", "kind", "params", "unit", "status", "source")
_FLOATS = ("value", "repeat", "number", "q_25", "q_75", "ci_low", "ci_high", "duration")


def _samples_text(samples: object) -> str:
    if samples is None or (isinstance(samples, float) and math.isnan(samples)):
        return ""
    return " ".join(repr(float(s)) for s in samples)  # repr: the float back exactly


def write_archive(frame: pd.DataFrame, path: str | os.PathLike[str]) -> int:
    """Write the archive atomically (floats to full precision, samples space-separated).

    Parameters
    ----------
    frame : DataFrame
        Columns :data:`ARCHIVE_COLUMNS` (as :func:`merge_results` returns them).
    path : path
        The CSV file.

    Returns
    -------
    int
        Bytes written.
    """
    out = frame.reindex(columns=list(ARCHIVE_COLUMNS)).copy()
    out["samples"] = [_samples_text(s) for s in out["samples"]]
    for column in ("date", "started_at"):
        out[column] = [_stamp(t) for t in out[column]]
    return write_csv(out, path)


def _stamp(value: object) -> str:
    return "" if value is None or pd.isna(value) else pd.Timestamp(value).isoformat()


def read_archive(path: str | os.PathLike[str]) -> pd.DataFrame:
    """The archive as :func:`load_asv_results` returns asv's files (plus ``source``).

    Raises
    ------
    ReportDataError
        A file that is not a readable archive (missing columns, a bad date, number or
        sample list), named.
    """
    path = Path(path)
    frame = read_csv(path, ARCHIVE_COLUMNS, text=(*_TEXT, "samples", "date", "started_at"))
    try:
        for column in _FLOATS:
            frame[column] = pd.to_numeric(frame[column], errors="raise").astype(float)
        frame["param_index"] = pd.to_numeric(frame["param_index"], errors="raise").astype(int)
        for column in ("date", "started_at"):
            frame[column] = pd.to_datetime(frame[column].replace("", None), utc=True, format="ISO8601")
        frame["samples"] = [
            tuple(float(s) for s in text.split()) if text else None for text in frame["samples"]
        ]
    except (TypeError, ValueError, OverflowError) as exc:
        raise ReportDataError(
            f"{path}: not a readable performance archive ({' '.join(str(exc).split())})"
        ) from exc
    if frame["date"].isna().any():
        line = int(frame.index[frame["date"].isna()][0]) + 2  # the header is line 1
        raise ReportDataError(f"{path}: line {line} has no commit date (the file is damaged)")
    for column, allowed in (("source", ("asv", "page")), ("status", ("ok", "failed", "skipped"))):
        bad = frame.index[~frame[column].isin(allowed)]
        if len(bad):
            raise ReportDataError(
                f"{path}: line {int(bad[0]) + 2} has {column} {frame.loc[bad[0], column]!r} "
                f"(expected one of {', '.join(allowed)})"
            )
    return frame.reindex(columns=list(ARCHIVE_COLUMNS))


def _standing(frame: pd.DataFrame) -> pd.Series:
    """How much a reading says: 2 a measurement (a timing of several samples, or any tracked
    or memory value), 1 a single-sample timing (``asv run --quick``), 0 a failure or skip."""
    ok = frame["status"] == "ok"
    single = (frame["kind"] == "time") & (frame["repeat"] == 1)
    return ok.astype(int) * 2 - (ok & single).astype(int)


def merge_results(archive: pd.DataFrame | None, fresh: pd.DataFrame | None) -> pd.DataFrame:
    """The archive with asv's fresh values added, one reading per :data:`KEY`.

    Parameters
    ----------
    archive : DataFrame or None
        :func:`read_archive`'s table.
    fresh : DataFrame or None
        :func:`replication.report.asv_results.load_asv_results`'s table (``source`` asv).

    Returns
    -------
    DataFrame
        Columns :data:`ARCHIVE_COLUMNS`. Of two readings of one key the one that says more
        is kept (a measurement over a single sample over a failure or skip: a quick or broken
        re-run of a measured commit never erases its measurement); of two that say as much,
        the later measured (``started_at``; a page-recovered value has none and is older),
        and of those the fresh one. Rows are in the archive's order, new keys after.
    """
    parts = []
    if archive is not None and not archive.empty:
        parts.append(archive.reindex(columns=list(ARCHIVE_COLUMNS)))
    if fresh is not None and not fresh.empty:
        parts.append(fresh.assign(source="asv").reindex(columns=list(ARCHIVE_COLUMNS)))
    if not parts:
        return pd.DataFrame(columns=list(ARCHIVE_COLUMNS))
    merged = pd.concat(parts, ignore_index=True) if len(parts) > 1 else parts[0].reset_index(drop=True)
    ranked = merged.assign(
        _standing=_standing(merged),
        _started=pd.to_datetime(merged["started_at"], utc=True).fillna(pd.Timestamp(0, tz="UTC")),
        _order=range(len(merged)),
        _place=merged.groupby(KEY, sort=False).ngroup(),  # keys numbered as they first appear
    )
    best = ranked.sort_values(["_standing", "_started", "_order"]).drop_duplicates(KEY, keep="last")
    best = best.sort_values("_place").drop(columns=["_standing", "_started", "_order", "_place"])
    return best.reset_index(drop=True)


# the suffixes format_cell writes, back to their scale
_UNITS = {suffix: scale for scale, suffix in (*TIME_UNITS, (1e-9, "ns"), *BYTE_UNITS, (1.0, "B"))}
_CELL = re.compile(
    r"^(?P<number>-?[0-9][0-9,]*(?:\.[0-9]+)?(?:e[+-]?[0-9]+)?)(?: (?P<suffix>\S+))?(?P<rest>.*)$"
)
_HEAD = re.compile(
    r"^`(?P<commit>[0-9a-f]+)` \((?P<date>[0-9-]+)(?:, n=(?P<n>[0-9]+)(?P<range>–[0-9]+)?)?\)$"
)


def _cell(text: str, unit: str) -> dict | None:
    """One cell of a page's history table as archive fields; None for a value not measured."""
    text = text.strip()
    if text in ("–", ""):
        return None
    if text in ("n/a", "failed"):
        return {"status": "skipped" if text == "n/a" else "failed", "value": math.nan}
    if unit not in ("seconds", "bytes"):  # a tracked value: the number and its unit, as typed
        number = text[: -len(unit) - 1] if unit and text.endswith(f" {unit}") else text
        return {"status": "ok", "value": float(number.replace(",", ""))}
    match = _CELL.match(text)
    if match is None:
        raise ValueError(f"cannot read the value {text!r}")
    value = float(match["number"].replace(",", ""))
    suffix, rest = match["suffix"] or "", match["rest"].strip()
    if unit in ("seconds", "bytes"):
        if suffix not in _UNITS:
            raise ValueError(f"cannot read the unit of {text!r}")
        value *= _UNITS[suffix]
    fields = {"status": "ok", "value": value}
    spread = re.fullmatch(r"±([0-9.]+) %", rest)
    if spread:
        half = float(spread[1]) / 100 * value
        fields.update(q_25=value - half, q_75=value + half)
    elif rest == "(1 sample)":
        fields["repeat"] = 1.0
    elif rest not in ("", "(no spread recorded)"):
        raise ValueError(f"cannot read {rest!r} in {text!r}")
    return fields


def rows_from_page(text: str, benchmarks: dict[str, dict], dates: dict[str, pd.Timestamp]) -> pd.DataFrame:
    """The history tables of an earlier ``performance.md`` as archive rows (``source`` page).

    Parameters
    ----------
    text : str
        The page.
    benchmarks : dict
        asv's ``benchmarks.json`` (type, unit and parameters of each benchmark); a benchmark
        the page names but this does not is refused.
    dates : dict
        The commit date of each commit the page names (by its 8-character hash).

    Returns
    -------
    DataFrame
        Columns :data:`ARCHIVE_COLUMNS`, ``source`` page.

    Raises
    ------
    ValueError
        A page this cannot read: a benchmark or parameters not in ``benchmarks``, a commit
        without a date, a value or column head in another format, a table cut short.

    Notes
    -----
    Only the measured history is read (not single-sample runs, nor the comparison, whose
    values repeat the history's). The values carry what the page shows: three significant
    digits, a spread rounded to 1 % (0.1 % below 1 %) as quartiles around the value, and the
    column's sample count where the page gave one count (not a range) for the column.
    """
    try:
        return _page_rows(text, benchmarks, dates)
    except (KeyError, IndexError) as exc:  # a commit without a date, a table cut short
        raise ValueError(f"cannot read the page: {type(exc).__name__} {exc}") from exc


def _page_rows(text: str, benchmarks: dict[str, dict], dates: dict[str, pd.Timestamp]) -> pd.DataFrame:
    rows: list[dict] = []
    machine = None
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("## "):
            found = re.fullmatch(r"## Machine `(.+)`", line)
            machine = found[1] if found else None  # other sections: nothing to read
        elif machine and line.startswith("### `"):
            name = line[5:-1]
            if name not in benchmarks:
                raise ValueError(f"the page's benchmark {name} is not in benchmarks.json")
            info = benchmarks[name]
            head = [c.strip() for c in lines[i + 2].strip("|").split("|")]
            heads = [_HEAD.match(h) for h in head[1:]]
            if None in heads:
                raise ValueError(f"cannot read the column heads of {name}: {head}")
            names = info.get("param_names", [])
            grid = {params_text(names, combo): j for j, combo in enumerate(param_grid(info.get("params")))}
            i += 4
            while i < len(lines) and lines[i].startswith("|"):
                cells = [c.strip() for c in lines[i].strip("|").split("|")]
                params = "" if cells[0] == "–" else cells[0]
                if params not in grid:
                    raise ValueError(f"{name}: parameters {params!r} are not in benchmarks.json")
                for h, cell in zip(heads, cells[1:]):
                    fields = _cell(cell, info.get("unit", ""))
                    if fields is None:
                        continue
                    commit = h["commit"]
                    # "n=7–10": the page did not say which value had how many samples
                    known = h["n"] and not h["range"] and info.get("type") == "time"
                    repeat = float(h["n"]) if known else math.nan
                    rows.append({
                        "machine": machine, "commit": commit, "date": dates[commit], "env": "",
                        "benchmark": name, "kind": info.get("type", ""), "params": params,
                        "param_index": grid[params], "unit": info.get("unit", ""), "repeat": repeat,
                        "number": math.nan, "q_25": math.nan, "q_75": math.nan, "ci_low": math.nan,
                        "ci_high": math.nan, "samples": None, "started_at": pd.NaT, "duration": math.nan,
                        "source": "page", **fields,
                    })  # fmt: skip
                i += 1
            continue
        i += 1
    return pd.DataFrame(rows, columns=list(ARCHIVE_COLUMNS))
