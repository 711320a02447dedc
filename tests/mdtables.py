"""Parsing the markdown tables of generated reports, to compare their numbers with the data."""

import re

import numpy as np
import pandas as pd


def parse_tables(markdown: str) -> dict[str, pd.DataFrame]:
    """Every pipe table in the markdown, keyed by its header line."""
    tables, lines = {}, markdown.splitlines()
    i = 0
    while i < len(lines):
        if lines[i].startswith("| ") and i + 1 < len(lines) and set(lines[i + 1]) <= set("|:- "):
            header = [c.strip() for c in lines[i].strip("|").split("|")]
            rows = []
            i += 2
            while i < len(lines) and lines[i].startswith("|"):
                rows.append([c.strip() for c in lines[i].strip().strip("|").split("|")])
                i += 1
            tables[" | ".join(header)] = pd.DataFrame(rows, columns=header)
        else:
            i += 1
    return tables


def find(tables, *words):
    matches = [t for key, t in tables.items() if all(w in key for w in words)]
    assert len(matches) == 1, (words, list(tables))
    return matches[0]


def number(text: str) -> float:
    text = text.replace(",", "").replace("%", "").replace("bytes", "").replace(" s", "").strip()
    return float("nan") if text in ("–", "") else float(text)


def triple(text: str) -> tuple[float, float, float]:
    m = re.fullmatch(r"(\S+) \[(\S+), (\S+)\].*", text.strip())
    assert m, text
    return tuple(number(g) for g in m.groups())


def close(shown: float, exact: float) -> bool:
    """A number shown with 3 significant digits (or as an integer) matches the data."""
    if np.isnan(shown) or np.isnan(exact):
        return np.isnan(shown) and np.isnan(exact)
    return abs(shown - exact) <= max(5e-3 * abs(exact), 0.5 if abs(exact) >= 100 else 1e-12)
