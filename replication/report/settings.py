"""With which settings a saved data set was made: the paper's, the quick ones, or others.

``table1 --quick --output-dir DIR``, with DIR holding a run of the paper's settings, replaced
that run's data without a word, and DIR's ``index.md`` then put the quick Table 1 headline
beside the full case study's. The commands now compare the settings a data set was saved with
to the run's before any work (:func:`replacement_refused`), and the index names the settings
of every data set that are not the paper's (:func:`settings_note`).

A data set's settings are told in the words of the options that make them, as the commands
already describe a run with other settings (:func:`replication.cli.outputs.check_not_committed`):
``()`` for the paper's, ``("--quick",)`` for a reduced run, or the differences from the paper's
(the case study records its whole configuration; another solver is named by its option).

Notes
-----
Infrastructure for the reports of the paper's Table 1 (sections 4-5) and case study (section 6).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["QUICK", "describe", "replacement_refused", "saved_settings", "settings_note"]

QUICK = ("--quick",)

#: Each experiment's data set prefix and its name in a sentence.
TITLES = {
    "table1": "Table 1 run",
    "sph": "SPH study",
    "jet_validation": "jet-model validation study",
    "casestudy": "case study",
}


def _record(data: Path, prefix: str) -> dict[str, Any] | None:
    """The provenance record of a data set, or None when there is none to read (a damaged one
    is the report's to refuse, with its own message, when it is drawn)."""
    try:
        record = json.loads((data / f"{prefix}_provenance.json").read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    return record if isinstance(record, dict) else None


def _settings(prefix: str, record: dict[str, Any]) -> tuple[str, ...]:
    config = record.get("config") if isinstance(record.get("config"), dict) else {}
    quick = bool(record.get("quick", config.get("quick", False)))
    if prefix != "casestudy":
        return QUICK if quick else ()
    from replication.experiments.casestudy import differences_from_paper

    solver = [option for key, option in (("solver", "--solver sph"), ("rescore", "--rescore sph"))
              if key in record]  # fmt: skip
    return (*(QUICK if quick else differences_from_paper(config)), *solver)


def saved_settings(data: str | Path, prefix: str) -> tuple[str, ...] | None:
    """The settings a data set under ``data`` was saved with, or None when it has no provenance.

    Parameters
    ----------
    data : path-like
        A reports directory's ``data/``.
    prefix : str
        The data set: ``"table1"``, ``"sph"``, ``"jet_validation"`` or ``"casestudy"``.

    Returns
    -------
    tuple of str or None
        ``()`` for the paper's settings, ``("--quick",)`` for a quick run, else the settings
        that differ from the paper's (``"population 24 (paper: 48)"``, ``"--solver sph"``).
    """
    record = _record(Path(data), prefix)
    return None if record is None else _settings(prefix, record)


def describe(settings: Sequence[str]) -> str:
    """``settings`` in words: "the paper's settings", "--quick", or "population 24 (paper: 48)"."""
    return " and ".join(settings) if settings else "the paper's settings"


def replacement_refused(data: str | Path, prefix: str, run: Sequence[str]) -> str | None:
    """Why a run with the settings ``run`` may not replace the data set ``prefix`` under ``data``.

    A run replaces a data set made with the same settings (a regeneration), or a quick one (a
    minute's smoke test). Any other would lose a run of other settings without a word, and the
    directory's index would put the two kinds of run side by side.

    Returns
    -------
    str or None
        The reason as a predicate ("holds a Table 1 run with the paper's settings
        (data/table1_provenance.json) that a run with --quick would replace"), or None when
        nothing is in the way.
    """
    saved = saved_settings(data, prefix)
    if saved is None or saved == QUICK or saved == tuple(run):
        return None
    return (
        f"holds a {TITLES[prefix]} with {describe(saved)} ({Path(data).name}/{prefix}_provenance.json) "
        f"that a run with {describe(run)} would replace"
    )


def settings_note(data: str | Path, prefix: str) -> str:
    """ " (quick run)" or " (other settings: ...)" after a data set's line in the index; "" for
    the paper's settings or a data set without provenance."""
    saved = saved_settings(data, prefix)
    if not saved:
        return ""
    if saved == QUICK:
        return " (*quick run*: reduced settings, a smoke test)"
    return f" (*other settings*: {describe(saved)})"
