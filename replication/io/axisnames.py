"""Which column is which axis, read from the names a cloud file gives its columns.

A text file's header (``z,x,y``, ``X [mm],Y [mm],Z [mm]``, ``pos_z,pos_x,pos_y``) and a
structured ``.npy`` array's field names are read by the same rules, so the same names give
the same cloud in either format (see :mod:`replication.io.clouds`).
"""

from __future__ import annotations

from pathlib import Path

from replication.errors import CloudFileError

__all__ = ["axis_name", "axis_order", "quoted_names"]


def quoted_names(tokens: list[str]) -> str:
    """Column names for a message, a name holding a comma in quotes (``"z, mm", "x, mm"``)."""
    return ", ".join(f'"{t.strip()}"' if "," in t else t.strip() for t in tokens)


def axis_name(token: str) -> str:
    """``x`` of a name such as ``X``, ``x [mm]``, ``x_mm``, ``x, mm``, ``"x"`` or ``pos_x`` (a
    name whose last ``_``-separated part is the axis letter); other names up to their first
    character that is not a letter or digit (``depth [mm]`` is ``depth``)."""
    name = token.strip().strip("\"'").lower()
    word = next((name[:k] for k, char in enumerate(name) if not char.isalnum()), name)
    if word in ("x", "y", "z"):
        return word
    stem = next((name[:k] for k, char in enumerate(name) if not (char.isalnum() or char == "_")), name)
    prefix, _, last = stem.rpartition("_")
    return last if prefix and last in ("x", "y", "z") else word


def _row_index(token: str) -> bool:
    """Whether a column name is one pandas gives a frame's row index: none (``to_csv``
    writes ``,x,y``), ``index`` (``to_records``), ``Unnamed: 0`` (``read_csv`` of such a
    file) or ``level_0``."""
    name = token.strip().strip("\"'").lower()
    return name in ("", "index", "level_0") or name.startswith("unnamed:")


def axis_order(path: Path, tokens: list[str], *, what: str = "header") -> list[int] | None:
    """The column order that puts the named x, y and z first to last, when the names say it.

    Names such as ``z,x,y`` (or ``Z [mm],X [mm],Y [mm]``) name the columns: they are read as
    the axes they name, so the cloud is the same as in a file that lists x, y, z in order.
    Names of two of the axes (``depth,x,y``) name the third column too. Names of no axis, or
    of each axis in its own column (``x,y,height``), are a label only, and the columns are
    x, y and z in their order.

    Parameters
    ----------
    path : Path
        The file, for messages.
    tokens : list of str
        The names, one per column.
    what : {"header", "fields", "columns"}
        What holds the names, for messages: the header of a text file, the fields of a
        structured array, the columns of a pandas DataFrame.

    Raises
    ------
    CloudFileError
        Three names of which one names an axis in another column (``a,x,b``), or an axis
        named twice: which column is which cannot be told, and their order would contradict it.
    """
    names = [axis_name(t) for t in tokens]
    if len(names) != 3:
        return None
    verb, column, drop, tail = _WORDING[what]
    named = [name for name in names if name in ("x", "y", "z")]
    distinct = len(set(named)) == len(named)
    if distinct and all(names[k] == axis for k, axis in enumerate("xyz") if axis in names):
        index = next((k for k in range(3) if names[k] not in named and _row_index(tokens[k])), -1)
        if len(named) == 1 and index >= 0:  # (",lat,z": to_csv of a two-column frame, its index as x)
            raise CloudFileError(
                f"{path}: the {what} {quoted_names(tokens)} {verb} one axis, and its {column} {index + 1} "
                f"({tokens[index].strip()!r}) is pandas' row index, not an axis: {drop}, or name the "
                f"{column}s x, y and z"
            )
        return None  # no axis named, or each in its own column: their order
    if distinct and len(named) >= 2:  # the column not named is the axis not named
        unnamed = next((k for k in range(3) if names[k] not in named), -1)  # -1: all three named
        if unnamed >= 0 and _row_index(tokens[unnamed]):
            raise CloudFileError(
                f"{path}: the {what} {quoted_names(tokens)} {verb} two axes, and its {column} {unnamed + 1} "
                f"({tokens[unnamed].strip()!r}) is pandas' row index, not the third axis: {drop}, or name "
                f"the {column} {'xyz'[3 - sum('xyz'.index(n) for n in named)]}"
            )
        order = [names.index(axis) if axis in names else unnamed for axis in ("x", "y", "z")]
        return None if order == [0, 1, 2] else order
    raise CloudFileError(
        f"{path}: the {what} {quoted_names(tokens)} {verb} "
        + (
            f"the axis {', '.join(sorted(set(n for n in named if named.count(n) > 1)))} more than once"
            if len(set(named)) != len(named)
            else f"{named[0]} as {column} {names.index(named[0]) + 1} but not the other axes"
        )
        + f": name the {column}s x, y and z (in any order){tail}"
    )


def lone_axis_message(path: Path, tokens: list[str], *, what: str = "header") -> str | None:
    """The warning for names that name one axis, in its own column, and two other columns
    (``lat,lon,z``): which of those is x and which y is a guess (their order is taken; in
    geographic data latitude is the y), or None when the names say every column or none.

    ``lat,lon,z`` was read as x = lat, y = lon without a word, while ``east,north,height``
    (no axis named) warned: naming z made the guess look like a reading of the names.
    """
    names = [axis_name(t) for t in tokens]
    named = [name for name in names if name in ("x", "y", "z")]
    if len(names) != 3 or len(named) != 1:
        return None
    axis = named[0]
    if names["xyz".index(axis)] != axis:  # (in another column: axis_order refuses it)
        return None
    verb, column, _, _ = _WORDING[what]
    others = [k for k in range(3) if names[k] != axis]
    read_as = [a for a in "xyz" if a != axis]
    said = " and ".join(f"{tokens[k].strip()!r} as {a}" for k, a in zip(others, read_as))
    return (
        f"{path}: the {what} {quoted_names(tokens)} {verb} only the axis {axis}, so the other {column}s were "
        f"read in their order, {said}; name them {read_as[0]} and {read_as[1]} to say which is which"
    )


#: For each holder of names: its verb, what it calls a column, how to be rid of pandas' row
#: index in it, and what else a message offers.
_WORDING = {
    "header": (
        "names",
        "column",
        "save the frame without its index (to_csv(index=False))",
        ", or give no header",
    ),
    "fields": ("name", "field", "save the frame without its index (to_records(index=False))", ""),
    "columns": ("name", "column", "drop that column (frame.drop(columns=...))", ""),
}
