"""Where the report commands write, checked before the work starts.

* ``reports/`` is the canonical, committed set of results: only the paper's settings write
  there (``reproduce``, ``table1``, ``casestudy`` with its defaults, or those commands pointed
  at it with ``--output-dir``). ``--quick`` runs go to ``reports-quick/``; a case study with
  other settings reports into its own GA run directory (see :mod:`replication.cli.casestudy`).
  A run with other settings is refused before any work when ``--output-dir`` names the
  ``reports/`` of a checkout (:func:`check_not_committed`): it would replace the committed
  results, and the README's headline numbers would then be the trial run's.
* Output directories are checked for writability (a probe file) before minutes of computing,
  and created only when there is something to write, so a failed command leaves none behind.
* When the reports land in ``reports/`` of a checkout of this project, the README's headline
  block is refreshed from the same data: the README then always states the numbers of the
  reports beside it, which is what ``tests/test_readme.py`` checks, so running the README's
  two commands in order (``replication reproduce``, then the tests) stays green on any machine.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import shlex
from collections.abc import Callable, Sequence
from pathlib import Path

from replication.io.locks import hold_reports_dir
from replication.io.paths import REPORT_SUBDIRS, check_report_dir

__all__ = [
    "DEFAULT_DIR",
    "QUICK_DIR",
    "TABLE1_SUBDIRS",
    "check_not_committed",
    "check_replaces_alike",
    "check_subdirs_stay_out",
    "checkout_readme",
    "finish_reports",
    "missing_dirs",
    "planned_output_dir",
    "remove_unused_run_dir",
]

DEFAULT_DIR = "reports"
QUICK_DIR = "reports-quick"
#: The subdirectories Table 1 writes besides data/ and figures/ (its meshes).
TABLE1_SUBDIRS = (*REPORT_SUBDIRS, "data/table1_meshes")


def planned_output_dir(
    args: argparse.Namespace,
    pages: tuple[str, ...] | Callable[[Path], tuple[str, ...]],
    subdirs: tuple[str, ...] = REPORT_SUBDIRS,
    custom: Sequence[str] = (),
    replaces: Sequence[str] | Callable[[Path], Sequence[str]] = (),
) -> Path:
    """The reports directory of ``table1``/``reproduce``/``sph``/``validate-jet``, checked (not
    created), with the ``subdirs`` the command writes into and the ``pages`` it writes (each
    absent or a page of ours, :func:`replication.report.pages.check_pages`; a function of the
    directory when which pages are drawn depends on what it holds). ``custom`` names the
    settings of the run that are not the paper's besides ``--quick`` (see
    :func:`check_not_committed`); ``replaces`` the data sets the run saves (their prefixes:
    ``"table1"``, ...), each of which may only replace one of its own settings or a quick one
    (:func:`check_replaces_alike`)."""
    from replication.report.pages import check_pages

    explicit = getattr(args, "output_dir", None)
    quick = getattr(args, "quick", False)
    out = Path(explicit or (QUICK_DIR if quick else DEFAULT_DIR))
    if explicit:
        check_not_committed(out, [*(["--quick"] if quick else []), *custom])
    what = "--output-dir" if explicit else "the reports directory"
    check_subdirs_stay_out(out, what, subdirs)
    hold_reports_dir(out, what)
    check_report_dir(out, what, subdirs)
    check_pages(out, what, pages(out) if callable(pages) else pages)
    settings = [*(["--quick"] if quick else []), *custom]
    check_replaces_alike(out, what, settings, replaces(out) if callable(replaces) else replaces)
    return out


def checkout_readme(out: str | Path) -> Path | None:
    """The README whose headline block describes ``out``, when ``out`` is ``reports/`` of a checkout.

    A checkout of this project is recognised by a ``pyproject.toml`` declaring the
    ``replication`` project and a ``README.md`` with the headline markers, both beside ``out``.
    """
    from replication.report.index import END, START

    # as named (a symbolic link reports -> elsewhere is the checkout's reports/ too) and as resolved
    spellings = dict.fromkeys([Path(os.path.abspath(out)), Path(out).resolve()])
    for candidate in spellings:
        if candidate.name != DEFAULT_DIR:
            continue
        readme, project = candidate.parent / "README.md", candidate.parent / "pyproject.toml"
        try:
            if not re.search(r'(?m)^name\s*=\s*"replication"\s*$', project.read_text(encoding="utf-8")):
                continue
            text = readme.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            continue
        if START in text and END in text:
            return readme
    return None


def check_not_committed(out: str | Path, custom: Sequence[str]) -> None:
    """Refuse a run with ``custom`` settings (not the paper's) that reports into a checkout's ``reports/``.

    The committed reports are the paper's settings' results, and the README's headline block is
    drawn from them (:func:`finish_reports`); a trial run written there would replace both
    (``casestudy --runs 1 --generations 2 --output-dir reports`` put "best GA surfaces
    4.41-4.41 N" into the README). A directory that is not ``reports/`` beside a checkout's
    README is anyone's to write.

    Raises
    ------
    UsageError
        ``custom`` is not empty and ``out`` is a checkout's ``reports/`` or lies inside it.
    """
    from replication.errors import UsageError

    if not custom:
        return
    named, resolved = Path(os.path.abspath(out)), Path(out).resolve()
    inside = [*named.parents, *resolved.parents]  # reports/figures of a checkout is its reports too
    within = checkout_readme(out) is None
    if not within or any(checkout_readme(p) is not None for p in inside):
        raise UsageError(
            f"--output-dir {out} is {'inside ' * within}a checkout's committed reports, which hold the "
            f"paper's settings' results (and the README's headline numbers); a run with "
            f"{' and '.join(custom)} would replace them: name another directory"
        )


def check_subdirs_stay_out(out: str | Path, what: str, subdirs: Sequence[str]) -> None:
    """Refuse a reports directory one of whose ``subdirs`` leads, by a symbolic link, into a
    checkout's committed reports while the directory itself is not those reports.

    :func:`check_not_committed` looks at the directory named: ``--output-dir trial`` with
    ``trial/data`` a link to ``reports/data`` let ``table1 --quick`` replace the committed data
    set, which ``report`` then drew into the committed pages and the README.

    Raises
    ------
    UsageError
        A subdirectory resolves to, or into, a checkout's ``reports/``.
    """
    from replication.errors import UsageError

    if checkout_readme(out) is not None:  # the committed reports themselves: checked as such
        return
    for name in subdirs:
        resolved = (Path(out) / name).resolve()
        for place in (resolved, *resolved.parents):
            if checkout_readme(place) is not None:
                raise UsageError(
                    f"{what} {out}: its {name}/ leads into {place}, a checkout's committed reports, "
                    f"so a run reporting into {out} would write there: name another directory"
                )


def check_replaces_alike(out: str | Path, what: str, run: Sequence[str], prefixes: Sequence[str]) -> None:
    """Refuse a run whose data sets would replace, in ``out/data``, saved ones of other settings.

    ``table1 --quick --output-dir DIR``, with DIR holding a run of the paper's settings,
    replaced that run's data without a word, and DIR's index then mixed the two kinds of run.
    A run may replace a data set of its own settings (a regeneration) or a quick one
    (:func:`replication.report.settings.replacement_refused`). A save killed while it published
    its files is finished first (:func:`replication.report.store.recover_data_sets`): its
    provenance, not the one it was replacing, is the data set's.

    Parameters
    ----------
    out : path-like
        The reports directory.
    what : str
        How the directory was named, for the message ("--output-dir").
    run : sequence of str
        The run's settings that are not the paper's, as options ("--quick"), empty for the paper's.
    prefixes : sequence of str
        The data sets the run saves.

    Raises
    ------
    UsageError
        A saved data set is in the way.
    """
    from replication.errors import UsageError
    from replication.report.settings import replacement_refused
    from replication.report.store import dashless, recover_data_sets

    data = Path(out) / "data"
    if prefixes and data.is_dir():  # a save killed while it published: its set, not the one it replaced
        recover_data_sets(data)
    refused = [(prefix, why) for prefix in prefixes
               if (why := replacement_refused(data, prefix, run)) is not None]  # fmt: skip
    if refused:
        # quoted for a shell, the pattern outside the quotes: "my reports" has a space
        moved = " and ".join(f"{shlex.quote(dashless(data / prefix))}_*" for prefix, _ in refused)
        raise UsageError(
            f"{what} {out} "
            + "; it ".join(why for _, why in refused)
            + f": name another directory, or move {moved} away first"
        )


def finish_reports(out: Path) -> list[Path]:
    """Render ``index.md``; in a checkout's ``reports/`` also refresh the README headline block."""
    from replication.report.index import render_index, update_readme

    out.mkdir(parents=True, exist_ok=True)
    written = [render_index(out)]
    readme = checkout_readme(out)
    if readme is not None:
        written.append(update_readme(readme, out))
    return written


def missing_dirs(path: Path) -> tuple[Path, ...]:
    """``path`` and its ancestors that do not exist yet (deepest first)."""
    missing = []
    while not path.exists() and path != path.parent:
        missing.append(path)
        path = path.parent
    return tuple(missing)


def remove_unused_run_dir(run_dir: Path, created: tuple[Path, ...]) -> None:
    """After a failure, remove the GA run directories a command created, if it made no checkpoint.

    A run directory with checkpoints is kept (it can be resumed); one holding only the
    ``config.json`` written at the start is not worth leaving behind after an error.
    """
    from replication.casestudy.rundir import CONFIG_NAME, LOCK_NAME, checkpoints

    if not created or checkpoints(run_dir):
        return
    with contextlib.suppress(OSError):
        (run_dir / CONFIG_NAME).unlink(missing_ok=True)
        (run_dir / LOCK_NAME).unlink(missing_ok=True)
        for directory in created:  # deepest first; stops at the first one not empty
            directory.rmdir()
