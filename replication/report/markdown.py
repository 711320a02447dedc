"""Markdown building blocks: number formats, tables and the provenance section."""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

__all__ = ["fmt", "table", "provenance_section", "iqr", "write_report"]

#: The part of the provenance line that names the commit that drew the page (not its data).
_RENDERED_BY = re.compile(r"; rendered by commit `[^`\n]*`")


def fmt(value: Any, spec: str = ".3g") -> str:
    """Format a number; missing values become an en dash."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if spec == "int":
        return f"{int(round(float(value))):,}"
    if spec == "pct":  # the fraction rounded as ".2f" rounds it, so that 0.785 reads 79 % beside 0.79
        return f"{100 * float(format(float(value), '.2f')):.0f} %"
    return format(float(value), spec)


def iqr(median: Any, q1: Any, q3: Any, spec: str = ".3g") -> str:
    """``median [q1, q3]``."""
    return f"{fmt(median, spec)} [{fmt(q1, spec)}, {fmt(q3, spec)}]"


def table(rows: Sequence[Sequence[str]], header: Sequence[str], align: str | None = None) -> str:
    """A pipe table; ``align`` is one character per column (l, r, c)."""
    align = align or "l" + "r" * (len(header) - 1)
    marks = {"l": ":---", "r": "---:", "c": ":---:"}
    lines = [
        "| " + " | ".join(header) + " |",
        "| " + " | ".join(marks[a] for a in align) + " |",
    ]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def frame_table(frame: pd.DataFrame, columns: dict[str, tuple[str, Callable[[Any], str]]]) -> str:
    """Render selected columns of a DataFrame: {column: (header, formatter)}."""
    rows = [[f(r[c]) for c, (_, f) in columns.items()] for _, r in frame.iterrows()]
    return table(rows, [h for h, _ in columns.values()])


def provenance_section(record: dict[str, Any], saved_as: str | None = None) -> str:
    """How the report was made: command, commit, versions, machine, date, seeds, run time;
    ``saved_as``: the file of the record, under the reports directory (``data/table1_provenance.json``)."""
    versions = ", ".join(f"{k} {v}" for k, v in record.get("versions", {}).items() if v)
    commit = record.get("commit") or "unknown (not a git checkout)"
    if record.get("dirty"):
        commit += " (with uncommitted changes)"
    from replication.provenance import git_state

    rendered = git_state()
    render_commit = rendered.get("commit") or "unknown"
    if rendered.get("dirty"):
        render_commit += " (with uncommitted changes)"
    lines = [
        "## How this report was made",
        "",
        f"- Command: `{record.get('command', '?')}`",
        f"- Code: git commit `{commit}` (computed the data); rendered by commit `{render_commit}`",
        f"- Date (UTC): {record.get('date_utc', '?')}",
        f"- Machine: {record.get('cpu', '?')}, {record.get('cores', '?')} cores; "
        f"{record.get('platform', '?')}",
        f"- Software: Python {record.get('python', '?')}; {versions}",
        f"- Seeds: {record.get('seeds', '?')}",
        f"- Run time: {fmt(record.get('run_seconds'), '.1f')} s"
        + (
            " ("
            + ", ".join(f"{k.replace('_', ' ')} {v:.1f} s" for k, v in record["stage_seconds"].items())
            + ")"
            if record.get("stage_seconds")
            else ""
        ),
    ]
    if (record.get("workers") or 1) > 1:
        lines.append(f"- Worker processes for the untimed work: {record['workers']} (the timings ran alone)")
    if saved_as is not None:
        lines.append(f"- The whole record, configuration included: `{saved_as}`")
    return "\n".join(lines)


def write_report(path: Path, text: str) -> Path:
    """Write a report page atomically, unless it would differ only in its "rendered by" commit.

    Re-rendering the committed reports from their data at a later commit draws the same page;
    replacing the file would then change only the commit that rendered it and leave a checkout
    with modified reports after a command that changed nothing. The page kept names an earlier
    commit that drew exactly this text, which stays true. The page is written with its marker
    and never over a file that is not a page of ours (:mod:`replication.report.pages`).
    """
    from replication.report.pages import marked, write_page

    try:
        old = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        old = None
    if old is not None and _RENDERED_BY.sub("", old) == _RENDERED_BY.sub("", marked(text)):
        return path
    return write_page(path, text, old=old)
