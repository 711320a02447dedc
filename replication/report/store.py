"""Atomic reading and writing of the data behind the reports (CSV and JSON)."""

from __future__ import annotations

import io
import json
import os
from pathlib import Path
from typing import Any

import pandas as pd

from replication.errors import ReportDataError
from replication.io.atomic import atomic_write_text

__all__ = ["read_csv", "read_json", "write_csv", "write_json"]


def write_csv(frame: pd.DataFrame, path: str | os.PathLike[str]) -> int:
    """Write a DataFrame as CSV atomically (full float precision); return bytes written."""
    buffer = io.StringIO()
    frame.to_csv(buffer, index=False, float_format="%.17g", lineterminator="\n")
    return atomic_write_text(path, buffer.getvalue())


def read_csv(path: str | os.PathLike[str], columns: tuple[str, ...] = ()) -> pd.DataFrame:
    """Read report data; a missing, malformed or incomplete file is a :class:`ReportDataError`.

    ``columns`` are required: a file without one of them is refused, naming them.
    """
    path = Path(path)
    if not path.is_file():
        raise ReportDataError(f"report data not found: {path} (run the experiment first)")
    try:
        frame = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, ValueError) as exc:
        reason = " ".join(str(exc).split())
        raise ReportDataError(
            f"{path}: not a readable CSV table ({reason}); regenerate the report data"
        ) from exc
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise ReportDataError(
            f"{path}: missing column(s) {', '.join(missing)} (the file is damaged or from another version); "
            "regenerate the report data"
        )
    return frame


def write_json(data: dict[str, Any], path: str | os.PathLike[str]) -> int:
    return atomic_write_text(path, json.dumps(data, indent=2, sort_keys=True, default=str) + "\n")


def read_json(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a JSON object of report data (a provenance record); refuse anything else clearly."""
    path = Path(path)
    if not path.is_file():
        raise ReportDataError(f"report data not found: {path} (run the experiment first)")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise ReportDataError(f"{path}: malformed JSON ({exc}); regenerate the report data") from exc
    if not isinstance(data, dict):
        raise ReportDataError(f"{path}: expected a JSON object, got {type(data).__name__}")
    return data
