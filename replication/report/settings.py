"""With which settings a saved data set was made: the paper's, the quick ones, or others.

``table1 --quick --output-dir DIR``, with DIR holding a run of the paper's settings, replaced
that run's data without a word, and DIR's ``index.md`` then put the quick Table 1 headline
beside the full case study's. The commands now compare the settings a data set was saved with
to the run's before any work (:func:`replacement_refused`), and the index names the settings
of every data set that are not the paper's (:func:`settings_note`).

A data set's settings are told in the words of the options that make them, as the commands
already describe a run with other settings (:func:`replication.cli.outputs.check_not_committed`):
``()`` for the paper's, ``("--quick",)`` for a reduced run, or the differences from the paper's
(the case study records its whole configuration; another solver is named by its option with
the SPH settings that differ from the defaults; the validation study's ``--timeout`` and
``--ga-run-dir`` are read from the command line it records).

Notes
-----
Infrastructure for the reports of the paper's Table 1 (sections 4-5) and case study (section 6).
"""

from __future__ import annotations

import json
import shlex
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = [
    "QUICK",
    "as_given",
    "describe",
    "replacement_refused",
    "saved_record",
    "saved_settings",
    "settings_note",
    "sph_option",
    "validation_options",
]

QUICK = ("--quick",)

#: Each experiment's data set prefix and its name in a sentence.
TITLES = {
    "table1": "Table 1 run",
    "sph": "SPH study",
    "jet_validation": "jet-model validation study",
    "casestudy": "case study",
}

#: The SPH settings the command line gives in other units than the record's SI ones.
_OPTION_UNITS = {"particle_radius": ("--particle-radius", 1e3, "mm"), "duration": ("--duration", 1e3, "ms")}


def as_given(name: str, value: Any) -> str:
    """A recorded SPH setting as the command line gives it (``--duration 15 ms``, not
    ``duration 0.015``), or by its name when the command line has no option for it."""
    if name in _OPTION_UNITS and isinstance(value, (int, float)):
        option, scale, unit = _OPTION_UNITS[name]
        return f"{option} {value * scale:g} {unit}"
    return f"{name} {value}"


def _plain(value: Any) -> Any:
    """``value`` as JSON reads it back (tuples become lists), so a record and a run compare."""
    return json.loads(json.dumps(value))


def sph_option(option: str, settings: dict[str, Any] | None, top: int | None = None) -> str:
    """``--rescore sph`` or ``--solver sph`` with the SPH settings that differ from the defaults
    (and ``--top`` when not the default): ``--rescore sph (--top 2, --particle-radius 1.5 mm)``.

    Two re-scorings of other SPH settings are other runs: one replaced the other's forces
    without a word, and the index named both "--rescore sph"."""
    from replication.casestudy.rescore import RescoreConfig
    from replication.casestudy.sph.settings import SPHSettings

    defaults = _plain(SPHSettings().as_dict())
    ours = _plain(settings or {})
    changed = [as_given(k, v) for k, v in sorted(ours.items()) if v != defaults.get(k)]
    if top is not None and top != RescoreConfig().top:
        changed.insert(0, f"--top {top}")
    return option + (f" ({', '.join(changed)})" if changed else "")


def validation_options(command: str) -> tuple[str, ...]:
    """The options of a ``validate-jet`` command line that can make another study than the
    committed one: ``--timeout`` (not the default, and not with ``--from-cache``, which
    simulates nothing) and ``--ga-run-dir``, as :func:`replication.cli.validate._custom_settings`
    names them."""
    from replication.experiments.jet_validation import ValidationConfig

    try:
        words = shlex.split(command)
    except ValueError:
        return ()
    given: dict[str, str] = {}
    for k, word in enumerate(words):
        name, eq, value = word.partition("=")
        if name in ("--timeout", "--ga-run-dir"):
            given[name] = value if eq else (words[k + 1] if k + 1 < len(words) else "")
    options = []
    simulates = "--from-cache" not in words
    try:
        timeout = float(given["--timeout"]) if "--timeout" in given else None
    except ValueError:
        timeout = None
    if simulates and timeout is not None and timeout != ValidationConfig().timeout:
        options.append(f"--timeout {timeout:g}")
    if "--ga-run-dir" in given:
        options.append(f"--ga-run-dir {given['--ga-run-dir']}")
    return tuple(options)


def article(title: str) -> str:
    """``title`` with its indefinite article ("an SPH study", "a case study")."""
    return f"{'an' if title.startswith('SPH') else 'a'} {title}"


def saved_record(data: Path, prefix: str) -> dict[str, Any] | None:
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
    if prefix == "jet_validation":
        command = record.get("command") if isinstance(record.get("command"), str) else ""
        return (*QUICK, *validation_options(command)) if quick else validation_options(command)
    if prefix != "casestudy":
        return QUICK if quick else ()
    from replication.experiments.casestudy import differences_from_paper

    solver = []
    for key, option in (("solver", "--solver sph"), ("rescore", "--rescore sph")):
        entry = record.get(key)
        if isinstance(entry, dict):
            solver.append(sph_option(option, entry.get("settings"), entry.get("top")))
        elif key in record:
            solver.append(option)
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
    record = saved_record(Path(data), prefix)
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
    where = f"{Path(data).name}/{prefix}_provenance.json"
    return (
        f"holds {article(TITLES[prefix])} with {describe(saved)} ({where}) that a run with "
        f"{describe(run)} would replace"
    )


def settings_note(data: str | Path, prefix: str) -> str:
    """What follows a data set's line in the index: a note of a quick run or of other settings,
    or nothing for the paper's settings or a data set without provenance."""
    saved = saved_settings(data, prefix)
    if not saved:
        return ""
    if saved == QUICK:
        return " (*quick run*: reduced settings, a smoke test)"
    return f" (*other settings*: {describe(saved)})"
