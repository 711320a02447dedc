"""asv's result files as one table, with each value's samples and spread.

asv 0.6 keeps one JSON file per (machine, commit, environment) under its results directory
and a ``benchmarks.json`` describing every benchmark (type, unit, parameters). A result
file lists, per benchmark, a row whose fields are named by the file's ``result_columns``:
``result`` (one value per parameter combination: a number, ``null`` when the benchmark
failed, ``NaN`` when it was skipped; or ``null`` for all of them), ``params``, ``version``,
``started_at``, ``duration``, and for timings the statistics asv_runner computed from the
samples: ``stats_ci_99_a``/``stats_ci_99_b`` (a 99 % confidence interval of the median),
``stats_q_25``/``stats_q_75`` (quartiles), ``stats_number`` (calls per sample),
``stats_repeat`` (number of samples), then ``samples`` (only with ``--record-samples``,
the default of ``asv continuous``) and ``profile``. Trailing empty fields are left out.
``asv run --quick`` takes a single sample (``stats_repeat`` 1, an infinite interval).

This module only reads; :mod:`replication.report.asv_compare` decides significance and
:mod:`replication.report.performance` renders.
"""

from __future__ import annotations

import datetime as dt
import itertools
import json
import math
import os
from pathlib import Path

import pandas as pd

from replication.errors import CloudFileError, ReportDataError

__all__ = ["COLUMNS", "load_asv_results", "param_grid", "params_text", "single_sample"]

#: Columns of :func:`load_asv_results`.
COLUMNS = [
    "machine", "commit", "date", "env", "benchmark", "kind", "params", "param_index", "unit", "status",
    "value", "repeat", "number", "q_25", "q_75", "ci_low", "ci_high", "samples", "started_at", "duration",
]  # fmt: skip


def _benchmarks(results_dir: Path) -> dict[str, dict]:
    path = results_dir / "benchmarks.json"
    if not path.is_file():
        raise CloudFileError(f"no asv results in {results_dir} (run `asv run` first; see the README)")
    info = _read(path)
    return {name: b for name, b in info.items() if isinstance(b, dict) and "unit" in b}


def _read(path: Path) -> dict:
    """A JSON object of asv's, or a one-line error naming the file."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ReportDataError(f"{path}: not a readable asv file ({' '.join(str(exc).split())})") from exc
    if not isinstance(data, dict):
        raise ReportDataError(f"{path}: not an asv file (expected a JSON object, got {type(data).__name__})")
    return data


def _field(entry: dict, key: str, j: int, n: int) -> object:
    """Field ``key`` of parameter combination ``j`` (of ``n``); None where not recorded."""
    values = entry.get(key)
    if not isinstance(values, list) or len(values) != n:
        return None
    return values[j]


def _number(value: object) -> float:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else math.nan


def param_grid(params: list[list] | None) -> list[tuple]:
    """Every combination of a benchmark's parameter values, in asv's order (``[()]``: none)."""
    return list(itertools.product(*params)) if params else [()]


def params_text(names: list[str], combo: tuple) -> str:
    """A parameter combination as the page shows it: ``n=9, backend=sweephull``."""
    # asv stores parameter values as their reprs: 'sweephull' with quotes
    return ", ".join(f"{k}={str(v).strip(chr(39))}" for k, v in zip(names, combo))


def _rows(machine: str, data: dict, benchmarks: dict[str, dict]) -> list[dict]:
    columns = data.get("result_columns", ["result", "params"])
    stamp = data.get("date")
    if not isinstance(stamp, (int, float)) or isinstance(stamp, bool):  # the commits are ordered by it
        raise ValueError(f"no commit date (got {stamp!r})")
    date = dt.datetime.fromtimestamp(stamp / 1000, dt.UTC)
    results = data.get("results")
    if not isinstance(results, dict) or not isinstance(columns, list):
        raise ValueError("'results' is not an object of benchmarks")
    rows = []
    for name, record in results.items():
        if name not in benchmarks:
            continue
        info = benchmarks[name]
        entry = dict(zip(columns, record)) if isinstance(record, list) else {"result": record}
        params = entry.get("params") or info.get("params") or []
        combos = param_grid(params)
        results = entry.get("result")
        if not isinstance(results, list):  # all failed: asv stores a single null
            results = [None] * len(combos)
        started = entry.get("started_at")
        for j, (combo, value) in enumerate(zip(combos, results)):
            status = "failed" if value is None else ("skipped" if _number(value) != _number(value) else "ok")
            samples = _field(entry, "samples", j, len(combos))
            rows.append(
                {
                    "machine": machine,
                    "commit": str(data.get("commit_hash", ""))[:8],
                    "date": date,
                    "env": data.get("env_name", ""),
                    "benchmark": name,
                    "kind": info.get("type", name.rsplit(".", 1)[-1].split("_", 1)[0]),
                    "params": params_text(info.get("param_names", []), combo),
                    "param_index": j,  # position in asv's parameter grid, for ordering
                    "unit": info.get("unit", ""),
                    "status": status,
                    "value": _number(value),
                    "repeat": _number(_field(entry, "stats_repeat", j, len(combos))),
                    "number": _number(_field(entry, "stats_number", j, len(combos))),
                    "q_25": _number(_field(entry, "stats_q_25", j, len(combos))),
                    "q_75": _number(_field(entry, "stats_q_75", j, len(combos))),
                    "ci_low": _number(_field(entry, "stats_ci_99_a", j, len(combos))),
                    "ci_high": _number(_field(entry, "stats_ci_99_b", j, len(combos))),
                    "samples": tuple(float(s) for s in samples) if isinstance(samples, list) else None,
                    "started_at": (
                        dt.datetime.fromtimestamp(started / 1000, dt.UTC)
                        if isinstance(started, (int, float))
                        else pd.NaT
                    ),
                    "duration": _number(entry.get("duration")),
                }
            )
    return rows


def load_asv_results(results_dir: str | os.PathLike[str]) -> pd.DataFrame:
    """Every value asv recorded, one row per (result file, benchmark, parameter combination).

    Parameters
    ----------
    results_dir : path
        asv's results directory (``.asv/results``): ``benchmarks.json`` and one directory
        of result files per machine.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`COLUMNS`. ``status`` is ``"ok"``, ``"failed"`` or ``"skipped"``;
        statistics asv did not record (memory and tracked values, older files) are NaN,
        and ``samples`` is None unless asv recorded them.

    Raises
    ------
    CloudFileError
        When there is no ``benchmarks.json`` (asv has not run).
    ReportDataError
        A file that is not asv's (malformed JSON, no commit date, values of the wrong type),
        named.

    Notes
    -----
    Performance tracking of the paper's pipelines (ADT, NURBS: sections 3-4; the case
    study: section 6); not a result of the paper.
    """
    results_dir = Path(results_dir)
    benchmarks = _benchmarks(results_dir)
    rows: list[dict] = []
    for machine_dir in sorted(p for p in results_dir.iterdir() if p.is_dir()):
        for path in sorted(machine_dir.glob("*.json")):
            if path.name != "machine.json":
                data = _read(path)
                try:
                    rows += _rows(machine_dir.name, data, benchmarks)
                except (TypeError, ValueError, AttributeError, OverflowError, OSError) as exc:
                    raise ReportDataError(
                        f"{path}: not an asv result file ({' '.join(str(exc).split())})"
                    ) from exc
    return pd.DataFrame(rows, columns=COLUMNS)


def single_sample(frame: pd.DataFrame) -> pd.Series:
    """True for timings measured once (``asv run --quick``): a value, but no spread."""
    return (frame["kind"] == "time") & (frame["status"] == "ok") & (frame["repeat"] == 1)
