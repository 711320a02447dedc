"""Point clouds in numpy's ``.npy`` files: an (n, 3) array, or a structured array of three fields.

A structured array (``dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")]``, as a numpy record
array or ``DataFrame.to_records(index=False)`` saves it) is a cloud when it has three real
numeric fields: they are read by their names as a text file's header is
(:func:`replication.io.axisnames.axis_order`), so fields ``z, x, y`` give the same cloud as
columns headed ``z,x,y``, and fields that name no axis are read in their order with a
:class:`~replication.errors.CloudFileWarning`. Arrays of Python objects are never loaded
(unpickling could run code), and a file shorter than its header announces is refused before
numpy allocates the array.
"""

from __future__ import annotations

import ast
import io
import math
import os
import warnings
from pathlib import Path

import numpy as np

from replication.errors import CloudFileError, CloudFileWarning
from replication.io.axisnames import axis_name, axis_order, lone_axis_message, quoted_names

__all__ = ["load_npy", "unstructured"]

_NPY_MAGIC = b"\x93NUMPY"


def _check_npy_size(path: Path, handle: io.BufferedReader) -> None:
    """Refuse a ``.npy`` file shorter than the array its header announces, before numpy
    allocates that array (a header claiming 10**11 points ended in a 2.18 TiB MemoryError)."""
    handle.seek(0)
    try:
        version = np.lib.format.read_magic(handle)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(handle)
        elif version == (2, 0):
            shape, _, dtype = np.lib.format.read_array_header_2_0(handle)
        elif version == (3, 0):  # as 2.0, in UTF-8: numpy writes it for non-ASCII field names
            shape, dtype = _header_3_0(handle)
        else:
            return  # numpy's own reading says what it makes of it
    except (ValueError, SyntaxError, KeyError, TypeError, UnicodeDecodeError) as exc:
        raise CloudFileError(f"{path}: not a readable .npy array (damaged header: {exc})") from exc
    if dtype.hasobject:  # pickled: no fixed size, and refused as such by the reading
        return
    need = math.prod(shape) * dtype.itemsize
    held = os.fstat(handle.fileno()).st_size - handle.tell()
    if held < need:
        raise CloudFileError(
            f"{path}: not a readable .npy array (truncated or damaged: its header announces shape "
            f"{tuple(shape)} of {dtype}, {need:,} bytes of data, but the file holds {held:,})"
        )


#: The longest version 3.0 header parsed (numpy's own limit is 10,000 bytes).
_MAX_HEADER = 1_000_000


def _header_3_0(handle: io.BufferedReader) -> tuple[tuple[int, ...], np.dtype]:
    """The shape and dtype of a version 3.0 header: a little-endian uint32 length, then a
    Python dict literal in UTF-8 (numpy's own reader of it is private)."""
    length = int.from_bytes(handle.read(4), "little")
    if length > _MAX_HEADER:  # numpy itself refuses headers over 10,000 bytes unless told otherwise
        raise ValueError(f"a header of {length:,} bytes")
    header = ast.literal_eval(handle.read(length).decode("utf-8"))
    shape = tuple(int(k) for k in header["shape"])
    return shape, np.lib.format.descr_to_dtype(header["descr"])


def _read(path: Path) -> np.ndarray:
    """The array of a ``.npy`` file; never unpickled, and numpy's advice to unpickle is not relayed."""
    try:
        with open(path, "rb") as handle:
            magic = handle.read(len(_NPY_MAGIC))
            if magic == _NPY_MAGIC:
                _check_npy_size(path, handle)
    except OSError as exc:
        raise CloudFileError(f"{path}: cannot read the file ({exc.strerror or exc})") from exc
    if magic != _NPY_MAGIC:
        raise CloudFileError(f"{path}: not a .npy array file (it does not start with numpy's .npy signature)")
    try:
        return np.load(path, allow_pickle=False)
    except ValueError as exc:
        if "pickle" in str(exc).lower():  # an object array: loading it could run code
            raise CloudFileError(
                f"{path}: holds Python objects, not numbers; such files are never loaded (loading them "
                "could run code)"
            ) from exc
        raise CloudFileError(f"{path}: not a readable .npy array ({exc})") from exc
    except (OSError, EOFError) as exc:
        raise CloudFileError(f"{path}: not a readable .npy array (truncated or damaged: {exc})") from exc


def unstructured(path: Path, data: np.ndarray) -> np.ndarray:
    """The (n, 3) coordinates of a structured array of three real numeric fields."""
    names = list(data.dtype.names or ())
    fields = [data.dtype.fields[name][0] for name in names]
    listed = quoted_names(names)
    nested = [name for name, field in zip(names, fields) if field.subdtype is not None or field.names]
    if nested:
        field = data.dtype.fields[nested[0]][0]
        count = math.prod(field.shape)
        held = f"the fields {', '.join(field.names)}" if field.names else f"{count} value{'s' * (count != 1)}"
        raise CloudFileError(
            f"{path}: the field {nested[0]} of the structured array holds {held} per record; save the "
            f"coordinates as an (n, 3) array (np.save(file, data[{nested[0]!r}]) when they are that "
            "field), or as three fields x, y, z"
        )
    odd = [name for name, field in zip(names, fields) if field.kind not in "iuf"]
    if odd:
        kinds = ", ".join(f"{name}: {data.dtype.fields[name][0]}" for name in odd)
        raise CloudFileError(
            f"{path}: a structured array whose fields are not all real numbers ({kinds}); a point "
            "cloud is an (n, 3) array of numbers or a structured array of three numeric fields x, y, z"
        )
    if len(names) != 3:
        raise CloudFileError(
            f"{path}: a structured array of {len(names)} field(s) ({listed}); a point cloud has 3 "
            "(x, y, z): save the three coordinate fields only"
            + (" (DataFrame.to_records(index=False) leaves out the row index)" if "index" in names else "")
        )
    if data.ndim != 1:
        raise CloudFileError(
            f"{path}: a structured array must have one dimension (one record per point), got shape "
            f"{data.shape}"
        )
    order = axis_order(path, names, what="fields") or [0, 1, 2]
    lone = lone_axis_message(path, names, what="fields")
    if lone is not None:
        warnings.warn(lone, CloudFileWarning, stacklevel=4)
    if not any(axis_name(name) in ("x", "y", "z") for name in names):
        warnings.warn(
            f"{path}: the fields {listed} name none of the axes x, y and z, so they were read in their "
            "order as x, y and z; name them x, y and z (in any order) to say otherwise",
            CloudFileWarning,
            stacklevel=4,
        )
    return np.column_stack([data[names[k]].astype(np.float64) for k in order]).reshape(-1, 3)


def load_npy(path: Path) -> np.ndarray:
    """The array of a ``.npy`` point-cloud file, a structured array as its (n, 3) coordinates.

    Raises
    ------
    CloudFileError
        Not a ``.npy`` file, truncated or damaged, an array of Python objects or of text, or a
        structured array that is not three real numeric fields over one dimension. The shape and values
        of a plain array are checked by the caller (:func:`replication.surfaces.cloud.as_cloud`).
    """
    data = _read(path)
    if data.dtype.kind in "US":  # numpy parses text by its own, looser rules: '1_000', ' 2 ', b'1e5'
        raise CloudFileError(
            f"{path}: holds text (dtype {data.dtype}), not numbers; save the coordinates as numbers "
            "(np.save(file, a.astype(float))), or as a .csv, whose numbers are read by the rules of a "
            "cloud file"
        )
    return unstructured(path, data) if data.dtype.names is not None else data
