"""Atomic reading and writing of the data behind the reports (CSV and JSON)."""

from __future__ import annotations

import io
import json
import os
from pathlib import Path
from typing import Any

import pandas as pd

from replication.errors import CloudFileError
from replication.io.atomic import atomic_write_text

__all__ = ["read_csv", "read_json", "write_csv", "write_json"]


def write_csv(frame: pd.DataFrame, path: str | os.PathLike[str]) -> int:
    """Write a DataFrame as CSV atomically (full float precision); return bytes written."""
    buffer = io.StringIO()
    frame.to_csv(buffer, index=False, float_format="%.17g", lineterminator="\n")
    return atomic_write_text(path, buffer.getvalue())


def read_csv(path: str | os.PathLike[str]) -> pd.DataFrame:
    path = Path(path)
    if not path.is_file():
        raise CloudFileError(f"report data not found: {path} (run the experiment first)")
    return pd.read_csv(path)


def write_json(data: dict[str, Any], path: str | os.PathLike[str]) -> int:
    return atomic_write_text(path, json.dumps(data, indent=2, sort_keys=True, default=str) + "\n")


def read_json(path: str | os.PathLike[str]) -> dict[str, Any]:
    path = Path(path)
    if not path.is_file():
        raise CloudFileError(f"report data not found: {path} (run the experiment first)")
    return json.loads(path.read_text())
