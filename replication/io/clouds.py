"""Point-cloud files: ``.csv``, ``.txt``, ``.xyz`` (text) and ``.npy`` (numpy).

Text files hold three numeric columns (x, y, z) separated by commas or white space, with an
optional header line, optional ``#`` comments (a whole line, or the end of one) and optional
whole-line ``%`` comments (MATLAB's; see :func:`_without_percent_comments`). A header
that names the axes (``z,x,y``, ``X [mm],Y [mm],Z [mm]``, ``pos_z,pos_x,pos_y``, ``z;x;y``, or
two of them: ``depth,x,y``; a leading ``%`` is not a name) says which column is which; a header
naming each in its own column is a label; one naming none (``east,north,height``, ``py,px,pz``)
is read in file order with a :class:`~replication.errors.CloudFileWarning` saying so (which
name is which axis would be a guess), and a header of other than three names separated by
commas or tabs is refused (names separated by spaces may hold spaces, and are not counted).
A comma-separated header is read with CSV
quoting (``"z, mm","x, mm","y, mm"`` names z, x, y). A comment line just above the data that
names all three axes, as ``numpy.savetxt(..., header="y x z")`` writes it (``# y x z``), is
such a header too (a comment with other words, ``# Z X Y units mm``, is a comment).
A first line ``0,1,2`` (or ``0 1 2``) with no comment above it is refused (see
:func:`_column_number_header`): it is pandas' header of column numbers or the point (0, 1, 2),
and a guess either way would make the same cloud give other numbers as ``.csv`` than as
``.npy``. The files :func:`save_cloud` writes are never ambiguous: their ``.csv`` has the
header ``x,y,z``, and their ``.txt``/``.xyz`` start with the comment ``# x y z``.
Numbers may be written with Fortran's exponent letter ``D`` (``1.0D+00``, as Fortran's
double-precision output has it): they read as ``1.0E+00`` (a first line of them was taken for
a header, and the error blamed line 2). Comma-separated rows may end in a comma (``1,2,3,``)
when the first does: it closes the row and opens no fourth column. Comma-separated values
may be quoted (``"1.0","2.0","3.0"``, as ``csv.QUOTE_ALL`` writes them). ``.npy`` files are read by
:mod:`replication.io.npyclouds` (structured arrays with named fields included).
Every problem is reported as a :class:`~replication.errors.CloudFileError` naming the file
and, where it applies, the line.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
import warnings
from pathlib import Path

import numpy as np

from replication.errors import CloudFileError, CloudFileWarning, InputError, shortened, shown
from replication.io.atomic import atomic_path, atomic_write_text
from replication.io.axisnames import axis_name, axis_order, lone_axis_message, quoted_names
from replication.io.npyclouds import load_npy
from replication.io.paths import dangling, lookup
from replication.io.vtk import shortest_decimals
from replication.surfaces.cloud import as_cloud

__all__ = ["CLOUD_SUFFIXES", "load_cloud", "save_cloud"]

CLOUD_SUFFIXES: tuple[str, ...] = (".csv", ".txt", ".xyz", ".npy")
_TEXT_SUFFIXES = (".csv", ".txt", ".xyz")
#: The first line of the ``.txt``/``.xyz`` files :func:`save_cloud` writes: a comment that says
#: the next line is a point, even a point (0, 1, 2).
TEXT_HEADER = "# x y z\n"


#: A number with Fortran's double-precision exponent letter: ``1.0D+00``, ``-2.5d-3``.
_FORTRAN = re.compile(r"([+-]?(?:\d+\.?\d*|\.\d+))[dD]([+-]?\d+)")


def _fortran(token: str) -> str:
    """``token`` with a Fortran exponent letter ``D`` written as ``e`` (``1.0D+00`` -> ``1.0e+00``)."""
    match = _FORTRAN.fullmatch(token)
    return f"{match[1]}e{match[2]}" if match else token


def _as_read(line: str) -> str:
    """A data line as numpy's reader is given it: its Fortran numbers written with ``e``."""
    comma = "," in line
    return ("," if comma else " ").join(_fortran(token) for token in _split(line, comma))


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _is_float64_text(token: str) -> bool:
    """Whether numpy's text reader takes ``token`` as a number: Python's ``float`` also takes
    digit separators (``1_0``) and non-ASCII digits, which ``np.loadtxt`` refuses."""
    return token.isascii() and "_" not in token and _is_number(token)


def _without_percent_comments(
    path: Path, numbered: list[tuple[int, str]]
) -> tuple[list[tuple[int, str]], set[int]]:
    """The lines without the whole-line ``%`` comments (MATLAB's and Octave's comment sign),
    and the numbers of the lines dropped.

    Of the ``%`` lines above the first data line (with no header line between them and the
    data), one that names an axis or three columns (``% z x y``, ``% depth,x,y``, ``% east
    north height``) is the header, as it would be directly above the data; when several
    could be, the one naming an axis is (of those, the one naming all three), and two such
    are refused (which is the header cannot be told). Every other ``%`` line is a comment;
    one naming all three axes above a header line is a comment header, as ``# z x y`` is
    (:func:`_comment_header`). A first line ``% exported
    2026-11-25`` above a header ``x,y,z`` was taken for the header, and the file refused at
    "line 2, column 1: 'x' is not a number".
    """
    is_percent = [data.lstrip().startswith("%") for _, data in numbered]
    first = next((k for k, percent in enumerate(is_percent) if not percent), len(numbered))
    names: dict[int, list[str]] = {}  # the % lines above the data that could be the header
    if first < len(numbered) and _is_data_line(numbered[first][1]):  # no header line below them
        names = {k: _header_tokens(numbered[k][1]) for k in range(first)}
        names = {k: n for k, n in names.items() if len(n) == 3 or _names_an_axis(n)}
    candidates = list(names)
    if len(candidates) > 1:
        naming = [k for k in candidates if _names_an_axis(names[k])]
        every = [k for k in naming if _names_every_axis(names[k])]
        naming = every if len(every) == 1 else naming  # ("% x-ray source" beside "% z x y")
        if len(naming) > 1:
            shown_lines = " and ".join(f"{numbered[k][0]} ({numbered[k][1].strip()!r})" for k in naming[:2])
            raise CloudFileError(
                f"{path}: the comment lines {shown_lines} both name axes above the data, and which one "
                "names the columns cannot be told: keep one, or start the other with '#'"
            )
        candidates = naming or candidates[-1:]
    keep = set(candidates)
    kept = [line for k, line in enumerate(numbered) if not is_percent[k] or k in keep]
    dropped = {number for k, (number, _) in enumerate(numbered) if is_percent[k] and k not in keep}
    return kept, dropped


def _names_an_axis(names: list[str]) -> bool:
    return any(axis_name(name) in ("x", "y", "z") for name in names)


def _names_every_axis(names: list[str]) -> bool:
    return len(names) == 3 and sorted(axis_name(name) for name in names) == ["x", "y", "z"]


def _is_data_line(line: str) -> bool:
    """Whether ``line`` holds a number (a data line, even a malformed one), not only names."""
    return any(_is_number(_fortran(t.strip("\"'"))) for t in _split(line, "," in line))


_SPACED_COMMA = re.compile(r"\s*,\s*")


def _unquoted(line: str) -> str:
    """A comma-separated data line with the CSV quotes around its values removed.

    A line whose quotes do not close, or a value holding a comma or a quote (``"1,5"``, a
    decimal comma) is left as the file has it, and so reported: its values joined by commas
    again would be other columns.
    """
    try:
        spaced = _SPACED_COMMA.sub(",", line.strip())  # ('4, "5" ,6': no space after a closing quote)
        values = [value.strip() for value in next(csv.reader([spaced], strict=True))]
    except csv.Error:
        return line
    if any("," in value or '"' in value for value in values):
        return line
    return ",".join(values)


def _header_count(line: str) -> int | None:
    """How many columns a header line names, when its separator says so: commas (with CSV
    quoting) or tabs; None for names separated by spaces, which may hold spaces themselves
    (``x [mm]``). A separator at the end of the line ("x,y,z,") names no further column, and
    leading ``%`` signs name none ("%\tz\tx\ty" names three)."""
    if line.lstrip().startswith("%"):
        line = line.lstrip().lstrip("%").lstrip(" \t")
    for sep in (",", "\t"):
        if sep in line:
            names = next(csv.reader([line], delimiter=sep))
            while names and not names[-1].strip():
                names.pop()
            return len(names)
    return None


def _overflows(token: str) -> bool:
    """Whether ``token`` is a finite number too large for float64 ("1e400"), not "inf" or "nan"."""
    try:
        value = float(token)
    except ValueError:
        return False
    return not math.isfinite(value) and not any(word in token.lower() for word in ("inf", "nan"))


def _split(line: str, comma: bool) -> list[str]:
    return [t.strip() for t in line.split(",")] if comma else line.split()


def _diagnose(
    path: Path, lines: list[tuple[int, str]], comma: bool, written: dict[int, str] | None = None
) -> CloudFileError:
    """Find the first malformed data line (called only when fast parsing failed); ``written``
    holds the lines as the file has them, where ``lines`` were changed (a closing comma cut)."""
    for number, line in lines:
        tokens = _split(line, comma)
        if len(tokens) != 3:
            quoted = (written or {}).get(number, line).strip()
            return CloudFileError(
                f"{path}: line {number} has {len(tokens)} column(s), expected 3 (x, y, z): {quoted!r}"
            )
        as_written = tokens
        if written and number in written:  # (a closing comma cut, or quotes removed)
            as_written = _split(written[number].rstrip().removesuffix(","), comma)
            as_written = as_written if len(as_written) == len(tokens) else tokens
        for column, token in enumerate(tokens, start=1):
            if not _is_float64_text(_fortran(token)):
                shown_token = as_written[column - 1]
                return CloudFileError(
                    f"{path}: line {number}, column {column}: {shown_token!r} is not a number"
                )
    return CloudFileError(f"{path}: could not parse the file as three numeric columns")


def _column_number_header(path: Path, number: int, line: str) -> CloudFileError:
    """The error for a first line ``0,1,2`` that no comment marks as a point.

    pandas writes the column labels 0, 1, 2 as a header when a frame has no column names; the
    same line is also the point (0, 1, 2). A guess either way (the line was skipped when the
    other points were not all whole numbers) gave the same cloud other results as ``.csv``
    than as ``.npy``, so the file must say which it is.
    """
    return CloudFileError(
        f"{path}: line {number} ({line.strip()!r}) is either pandas' header of column numbers or the point "
        "(0, 1, 2), and the file does not say which: delete the line if it is a header, or put a "
        "comment line such as '# x y z' above it if it is a point"
    )


def _comment_header(path: Path, lines: list[str], first_data: int) -> tuple[list[str], list[int]] | None:
    """A whole-line comment just above the first data line that names all three axes
    (``# y x z``, as ``numpy.savetxt(..., header="y x z")`` writes it): its names, and the
    column order it gives (``[0, 1, 2]`` when it lists x, y, z in order). Other comments are
    comments."""
    above = next((line.strip() for line in reversed(lines[: first_data - 1]) if line.strip()), "")
    if not above.startswith(("#", "%")):  # (blank lines between it and the data do not matter)
        return None
    tokens = _header_tokens(above.lstrip("#%"))
    if not _names_every_axis(tokens):
        return None
    return tokens, axis_order(path, tokens) or [0, 1, 2]


def _header_tokens(text: str) -> list[str]:
    """The names of a header line; in a whitespace-separated one, a unit in brackets belongs to
    the name before it (``y [mm] x [mm] z [mm]`` names three columns, not six).

    A comma-separated header is read with CSV quoting, as pandas writes it: ``"z, mm","x, mm",
    "y, mm"`` names three columns, not six (split at every comma, it was taken for a label and
    the columns read in file order). Without a comma, a tab separates the names when there is
    one, else ``;`` (``# z;y;x``). A leading ``%`` (a MATLAB/Octave comment sign) is not a name.
    """
    text = text.strip().lstrip("%")  # ("%% z x y": MATLAB's cell marks are comment signs too)
    if "," in text:
        try:
            names = [name.strip() for name in next(csv.reader([text], skipinitialspace=True, strict=True))]
        except csv.Error:  # unbalanced quotes: the names between the commas, quotes and all
            names = _split(text, True)
        return _without_closing_separator(names)
    bare = _UNIT.sub("", text)  # a ';' inside a unit ('z [m; NAP]') separates nothing
    if "\t" in bare:  # tabs separate names that may hold spaces ("Easting m<TAB>Northing m")
        return [name.strip() for name in bare.split("\t") if name.strip()]
    if ";" in bare:
        return _without_closing_separator([name.strip() for name in bare.split(";")])
    return bare.split()


def _without_closing_separator(names: list[str]) -> list[str]:
    """The names of a header whose line ends in its separator ("z,x,y,"): the empty "names"
    after it are none (they made four names, so the header's axis order was not read and a
    file headed "z,x,y," was read in file order, its axes swapped without a word)."""
    while names and not names[-1]:
        names.pop()
    return names


#: A unit in brackets or parentheses after a name, with the white space before it.
_UNIT = re.compile(r"\s*(\[[^\]]*\]|\([^)]*\))")


def _load_text(path: Path) -> np.ndarray:
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark (Excel's UTF-8 CSV) is not data
    except UnicodeDecodeError as exc:
        raise CloudFileError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})") from exc
    if "\x00" in text:  # binary data: its NUL bytes made one "header" line and no data
        at = path.read_bytes().index(b"\x00")
        raise CloudFileError(
            f"{path}: not a UTF-8 text file (a NUL byte at byte {at}: binary data, or UTF-16 text); a point "
            "cloud is CSV, TXT or XYZ text in UTF-8, or .npy"
        )
    lines = text.splitlines()
    # a "#" starts a comment anywhere on a line, as numpy's reader has it: the header and the
    # delimiter are decided on the data alone ("1 2 3 # first, in mm" was taken for a header
    # because of its comma, and the point was dropped without a word)
    numbered = [(i, data) for i, line in enumerate(lines, start=1) if (data := line.split("#", 1)[0]).strip()]
    percent_above = False  # a '%' comment above the first line: the file has comments
    if "%" in text:
        numbered, dropped = _without_percent_comments(path, numbered)
        percent_above = bool(numbered) and any(number < numbered[0][0] for number in dropped)
        # a dropped '%' line naming the three axes stays, for _comment_header, as a '#' one does
        # ("% z x y" above a header "x,y,z" was passed over, and the contradiction with it)
        lines = [
            "" if number in dropped and not _names_every_axis(_header_tokens(line)) else line
            for number, line in enumerate(lines, start=1)
        ]
    if not numbered:
        raise CloudFileError(f"{path}: the file is empty (no data lines)")
    first_comma = "," in numbered[0][1]
    first_tokens = _split(numbered[0][1], first_comma)
    commented = _comment_header(path, lines, numbered[0][0])
    header, order = commented if commented is not None else (first_tokens, None)
    # (a quoted number is a number here: a line of them is a data line, not a header)
    numeric = any(_is_number(_fortran(t.strip("\"'"))) for t in first_tokens)
    if not numeric and any(c.isalpha() for c in numbered[0][1]):
        # a header line: names, no numeric token (a malformed data line such as "1;2;3" has no
        # letter, and is reported as line 1, not taken for a header and line 2 blamed)
        first_tokens = _header_tokens(numbered[0][1])
        numbered_header = numbered[0][1]
        numbered = numbered[1:]
        if not numbered:
            raise CloudFileError(f"{path}: the file has a header but no data lines")
        counted = _header_count(numbered_header)
        if counted is not None and counted != 3:  # "x,y,z,i" over three columns: which three?
            index = first_tokens and first_tokens[0].strip().strip("\"'").lower() in (
                "",
                "index",
                "unnamed: 0",
            )
            raise CloudFileError(
                f"{path}: the header {quoted_names(first_tokens)} names {counted} columns, but a point cloud "
                "has 3 (x, y, z): name the file's three columns, or give no header"
                + ("; its first column is pandas' row index: save with to_csv(index=False)" if index else "")
            )
        in_order = [a for a in (axis_name(t) for t in first_tokens) if a in ("x", "y", "z")]
        if counted is None and len(first_tokens) != 3 and len(in_order) >= 2 and in_order != sorted(in_order):
            # "Columns: z x y" was read in file order, its names unread (four words, not three);
            # "X Coord Y Coord Z Coord" names them in file order, which is how it is read
            raise CloudFileError(
                f"{path}: the header {quoted_names(first_tokens)} names the axes {', '.join(in_order)} in "
                f"that order among {len(first_tokens)} names, so which column is which cannot be told: "
                "write it as three names (such as 'z x y'), or separate the names by commas"
            )
        named = axis_order(path, first_tokens) or [0, 1, 2]
        labels = not _names_an_axis(first_tokens)
        if labels and commented is None:  # ("py,px,pz" or "lat,lon,alt": which axis is which is a guess)
            warnings.warn(
                f"{path}: the header {quoted_names(first_tokens)} names none of the axes x, y and z, so its "
                "columns were read in file order as x, y and z; name them x, y and z (in any order) "
                "to say otherwise",
                CloudFileWarning,
                stacklevel=3,
            )
        lone = lone_axis_message(path, first_tokens) if commented is None else None
        if lone is not None:
            warnings.warn(lone, CloudFileWarning, stacklevel=3)
        if commented is None or not labels:  # a label header (east,north,height) leaves the comment's order
            if commented is not None and named != order:
                raise CloudFileError(
                    f"{path}: the comment {quoted_names(header)} and the header "
                    f"{quoted_names(first_tokens)} name the columns in different orders: keep the one that "
                    "is right"
                )
            header, order = first_tokens, named
    elif (
        [t.strip().strip('"').strip() for t in first_tokens] == ["0", "1", "2"]
        and "#" not in "".join(lines[: numbered[0][0]])
        and not percent_above
    ):
        # pandas writes no comments: "# x y z" above it (save_cloud's .txt) or "0,1,2 # the
        # first point" says the line is a point
        raise _column_number_header(path, numbered[0][0], numbered[0][1])
    comma = "," in numbered[0][1]
    written = None
    if comma and numbered[0][1].rstrip().endswith(","):
        # a comma closing each line ("1,2,3,", as some spreadsheets and loggers write rows) ends
        # the row; it opens no fourth column (such files were refused as having 4 columns)
        written = dict(numbered)  # for messages: the lines as the file has them
        numbered = [(i, data.rstrip().removesuffix(",")) for i, data in numbered]
    if comma and '"' in text and any('"' in line for _, line in numbered):
        # every value quoted ('"1.0","2.0","3.0"', csv.QUOTE_ALL as spreadsheets export): the
        # quotes delimit the numbers (such files were refused, "'\"1.0\"' is not a number")
        written = written or dict(numbered)
        numbered = [(i, _unquoted(data)) for i, data in numbered]
    body = "\n".join(line for _, line in numbered)
    if "d" in body or "D" in body:  # Fortran exponents (one scan of the text, not one per line)
        body = "\n".join(_as_read(line) for _, line in numbered)
    try:
        data = np.loadtxt(io.StringIO(body), delimiter="," if comma else None, ndmin=2, dtype=np.float64)
    except ValueError:
        raise _diagnose(path, numbered, comma, written) from None
    if data.shape[1] != 3:
        raise _diagnose(path, numbered, comma, written)
    bad = np.flatnonzero(~np.isfinite(data).all(axis=1))
    if bad.size:
        for i in bad:  # a number too large for float64 ("1e400") reads as infinite: name it
            for column, token in enumerate(_split(numbered[i][1], comma), start=1):
                word = token.strip().strip("\"'")
                if _overflows(_fortran(word)):
                    raise CloudFileError(
                        f"{path}: line {numbered[i][0]}, column {column}: {shortened(word)!r} is too large "
                        f"for a float64 coordinate (at most about 1.8e308 in absolute value)"
                    )
        shown_lines = shown(numbered[i][0] for i in bad)
        raise CloudFileError(f"{path}: NaN or infinite coordinates on {bad.size} line(s): {shown_lines}")
    if order is None or order == [0, 1, 2]:
        return data
    columns = ", ".join(str(k + 1) for k in order[:2]) + f" and {order[2] + 1}"
    warnings.warn(
        f"{path}: the header {quoted_names(header)} names the columns in another order, so x, y "
        f"and z were read from columns {columns} ({quoted_names([header[k] for k in order])})",
        CloudFileWarning,
        stacklevel=3,
    )
    return np.ascontiguousarray(data[:, order])


def load_cloud(path: str | os.PathLike[str]) -> np.ndarray:
    """Read a point cloud from a ``.csv``, ``.txt``, ``.xyz`` or ``.npy`` file.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    ndarray of float64, shape (n, 3)

    Raises
    ------
    CloudFileError
        Missing, empty or unreadable file; wrong number of columns; non-numeric text;
        NaN or infinite coordinates (the lines are named), a ``.npy`` file that is not a
        numeric array or a structured array of three numeric fields (object arrays are never
        unpickled); a first line ``0,1,2`` that may
        be pandas' header of column numbers or a point (no comment above says which).

    Warns
    -----
    CloudFileWarning
        A header (or a comment line above the data such as ``# y x z``) that names the axes
        in another order than x, y, z: the columns are reordered.
    """
    if not os.fspath(path):
        raise CloudFileError("no point-cloud file named: the file name is empty")
    path = Path(path)
    found = lookup(path, CloudFileError, "cannot read the point-cloud file")
    if not found.exists:
        raise CloudFileError(f"point-cloud file not found: {path}{dangling(path)}")
    if found.is_dir:
        raise CloudFileError(f"expected a point-cloud file, got a directory: {path}")
    suffix = path.suffix.lower()
    if suffix in _TEXT_SUFFIXES:
        return _load_text(path)
    if suffix == ".npy":
        data = load_npy(path)
        try:
            return as_cloud(data, name=str(path))
        except InputError as exc:
            raise CloudFileError(str(exc)) from exc
    raise CloudFileError(
        f"{path}: unsupported point-cloud file type {suffix or '(no suffix)'!r}; "
        f"use one of {', '.join(CLOUD_SUFFIXES)}"
    )


def save_cloud(points: np.ndarray, path: str | os.PathLike[str]) -> int:
    """Write a point cloud atomically; the format follows the suffix. Return bytes written.

    ``.csv`` gets a header ``x,y,z`` and comma-separated values, ``.txt``/``.xyz`` the comment
    line ``# x y z`` and space-separated values, ``.npy`` a numpy array. Text values use the shortest
    representation that reads back to the same float64.
    """
    cloud = as_cloud(points)
    name, path = path, Path(path)  # the name as given for the writes: Path drops a trailing '/'
    suffix = path.suffix.lower()
    if suffix == ".npy":
        with atomic_path(name) as tmp:
            with open(tmp, "wb") as handle:  # a name not ending in lower-case .npy would get one added
                np.save(handle, cloud, allow_pickle=False)
            size = tmp.stat().st_size
        return size
    if suffix not in _TEXT_SUFFIXES:
        raise CloudFileError(
            f"{path}: unsupported point-cloud file type {suffix or '(no suffix)'!r}; "
            f"use one of {', '.join(CLOUD_SUFFIXES)}"
        )
    sep = "," if suffix == ".csv" else " "
    header = "x,y,z\n" if suffix == ".csv" else TEXT_HEADER
    row = sep.join(["{}"] * cloud.shape[1]) + "\n"
    rows = "".join(map(row.format, *(shortest_decimals(cloud[:, k]) for k in range(cloud.shape[1]))))
    return atomic_write_text(name, header + rows)
