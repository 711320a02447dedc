"""The report pages a reports directory holds, and how a page of ours is told from anyone else's.

A report command writes its pages into the directory ``--output-dir`` names. A directory of
notes with its own ``index.md`` (a common name) lost that file to the reports' index without
a word. Every page is now written with :data:`MARKER` as its last line, and a page is
replaced only when it is one of ours: it carries the marker, or it is a page drawn before
the marker existed (it begins with the title this package gives a page of that name and
names a ``replication`` command). Commands check this before any work
(:func:`check_pages`); writing a page checks it again (:func:`write_page`).

Notes
-----
Infrastructure for the reports of the paper's Table 1 and Fig. 6 (sections 4-5) and its
case study (section 6); the paper itself says nothing about files.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from replication.errors import OutputError

__all__ = ["MARKER", "PAGE_TITLES", "check_pages", "is_ours", "marked", "report_page_in", "write_page"]

#: The last line of every page this package writes (an HTML comment: markdown shows nothing).
MARKER = "<!-- drawn by the replication package from data/: edits are lost when it is drawn again -->"

#: Every page's file name and the title it begins with.
PAGE_TITLES: dict[str, str] = {
    "index.md": "# Reports",
    "table1.md": "# Table 1 and Fig. 6: ADT versus NURBS",
    "casestudy.md": "# Figs. 8 and 9: the water-jet case study",
    "sph.md": "# The case study on a real SPH solver (SPlisHSPlasH)",
    "jet_validation.md": "# The thin-sheet jet model checked against SPH",
    "performance.md": "# Performance history (asv)",
}


def marked(text: str) -> str:
    """A page's text as written: ``text`` with :data:`MARKER` as its last line."""
    return text.rstrip("\n") + "\n\n" + MARKER + "\n"


def is_ours(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is absent or a page this package wrote (see the module notes).

    Parameters
    ----------
    path : path-like
        A page's file; its name decides the title a page drawn before the marker has.

    Returns
    -------
    bool
        True when nothing is there, or the file carries :data:`MARKER`, or it begins with the
        title of its name in :data:`PAGE_TITLES` and names a ``replication`` command.
    """
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        return True
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False  # a directory, an unreadable file, or not UTF-8 text: not a page of ours
    if MARKER in text:
        return True
    title = PAGE_TITLES.get(path.name)
    return title is not None and text.split("\n", 1)[0] == title and "`replication" in text


def report_page_in(directory: str | os.PathLike[str]) -> Path | None:
    """A page of ours in ``directory`` (the first of :data:`PAGE_TITLES` found), or None.

    A directory that holds one is a reports directory: a GA run's checkpoints do not belong
    there (``casestudy --run-dir reports`` added run files to the committed reports).
    """
    for name in PAGE_TITLES:
        path = Path(directory) / name
        if path.is_file() and is_ours(path):
            return path
    return None


def _refusal(path: Path, what: str) -> OutputError:
    return OutputError(
        f"{what}: {path} is not a report page of this package (it would be replaced); move it, "
        "or name another directory"
    )


def check_pages(out: str | os.PathLike[str], what: str, pages: Iterable[str] = tuple(PAGE_TITLES)) -> None:
    """Refuse a reports directory where a page the command writes is somebody else's file.

    Parameters
    ----------
    out : path-like
        The reports directory (it need not exist).
    what : str
        How the message names it (``"--output-dir"``, ``"the reports directory"``).
    pages : iterable of str
        The file names of the pages the command writes.

    Raises
    ------
    OutputError
        Naming the first page that :func:`is_ours` does not recognise.
    """
    for name in pages:
        path = Path(out) / name
        if not is_ours(path):
            raise _refusal(path, what)


def write_page(path: str | os.PathLike[str], text: str) -> Path:
    """Write a page atomically with :data:`MARKER` as its last line, never over another file.

    Parameters
    ----------
    path : path-like
        The page's file.
    text : str
        The page, ending with a line end.

    Returns
    -------
    Path

    Raises
    ------
    OutputError
        When ``path`` holds a file that is not one of this package's pages.
    """
    from replication.io.atomic import atomic_write_text

    path = Path(path)
    if not is_ours(path):
        raise _refusal(path, "report page")
    atomic_write_text(path, marked(text))
    return path
