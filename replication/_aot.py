"""Kernels compiled ahead of time, when the package is built, for commands that must start at once.

A command that triangulates a small cloud spends almost all its time starting numba: importing
it (0.3 s), setting up its compiler target (0.5 s, which imports scipy.linalg), and, the first
time in a fresh environment, compiling the triangulator (12 s; numba re-optimises the whole
call tree of every compiled function, so deep kernels compile slowly). The package's build
(``setup.py``) therefore compiles the kernels listed in :data:`KERNELS` with ``numba.pycc``
into a small extension module, ``_replication_kernels``, that needs only numpy at run time.
It is a top-level module so that a checkout run from its own directory (the test suite) finds
the installed one; its code is generic for the architecture (x86-64, say), not tuned to the
building machine's CPU, so an install copied to another machine still runs. Like numba's
kernels (all compiled with ``nogil=True``) it releases the GIL while it runs, so threads
calling ``adt()`` on small clouds run side by side, and a jet force's two pieces run on two
threads (:func:`releases_gil`).

Which code serves a call of :func:`kernel` (the choice never changes a result: both are
compiled from the same Python source and agree bit for bit, which the tests check):

1. numba's JIT kernel when it is already loaded in this process (after
   :func:`replication.kernels.warm_up`, or after any earlier call compiled or loaded it):
   once numba's start-up is paid for, its code is the faster one, tuned to this CPU (26
   against 30 us for the 200-point triangulation kernel; 0.33-0.53 against 0.38-0.59 ms for
   jet forces on four 101-point surfaces, two threads each; on this project's machine);
2. otherwise the ahead-of-time kernel, when the extension module exists and was built from
   these very sources (a digest of them is compiled into it, so an edited checkout never runs
   stale code);
3. otherwise numba's JIT kernel, loaded from numba's cache or compiled. Arguments of other
   types than the compiled ones (a misaligned array, say) go to it too.

Setting the environment variable ``REPLICATION_AOT=0`` skips step 2 (it is read once, on the
first call that needs the module). When the build could not
compile the module (no C compiler, say), everything works as before through numba alone.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.util
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import numpy as np

__all__ = [
    "KERNELS",
    "MODULE",
    "Kernel",
    "compiled",
    "is_numba",
    "kernel",
    "load_numba",
    "numba_signature",
    "releases_gil",
    "source_digest",
    "stale",
]

#: Name of the extension module that the build compiles.
MODULE = "_replication_kernels"


@dataclass(frozen=True)
class Kernel:
    """One ahead-of-time kernel: the numba function it is compiled from and its one signature.

    Types are numba's spelling: ``float64[:, ::1]`` is a C-contiguous 2-D array (read-only
    when followed by `` ro``), ``int64`` a scalar; ``returns`` lists a tuple's items or one
    type.
    """

    module: str
    function: str
    args: tuple[str, ...]
    returns: tuple[str, ...]


#: Read-only argument types of the table: points (or queries), triangles (or their
#: neighbours), indices, values.
_CLOUD, _TRIANGLES = "float64[:, ::1] ro", "int32[:, ::1] ro"
_INDEX, _VALUES = "int32[::1] ro", "float64[::1] ro"
#: The water-jet model's mesh (``_sheet.prepare``): vertex x, y, z; triangles; neighbours;
#: facet normals; slopes; boundary edges; the per-edge table.
_MESH = (
    "(float64[::1], float64[::1], float64[::1], int64[:, ::1] ro, int64[:, ::1], float64[:, ::1], "
    "float64[:, ::1], int64[:, ::1], float64[:, :, ::1])"
)

#: The kernels compiled ahead of time, by the name :func:`kernel` knows them by: those of
#: ``adt()`` on clouds of at most ``_triangulate.SMALL`` points (the ``replication adt``
#: command on a typical cloud), those of the NURBS baseline's gridding of a triangulation
#: of fewer than ``_grid._PIECES_MIN`` triangles (``replication nurbs``), and the point
#: location and interpolation of :mod:`replication.surfaces.interpolate` (``replication compare``),
#: and the water-jet model (``replication force``; ``sheet_*``).
KERNELS: dict[str, Kernel] = {
    "single": Kernel(
        "replication.surfaces._blocks",
        "single",
        ("float64[:, ::1] ro", "int64", "int64"),
        ("int64", "int32[:, ::1]", "int32[:, ::1]", "int32[::1]", "int32[::1]", "int32[::1]"),
    ),
    "column_spreads": Kernel(
        "replication.surfaces._moments",
        "_small",
        ("float64[:, ::1] ro", "float64[::1]"),
        ("boolean",),
    ),
    "raster": Kernel(
        "replication.surfaces._raster",
        "_raster",
        (_CLOUD, _TRIANGLES, _VALUES, _VALUES, _VALUES, "int64", "int64", "int32[:, ::1]", "float64[:, ::1]"),
        ("none",),
    ),
    "number": Kernel(
        "replication.surfaces._raster",
        "_number",
        (_INDEX, "int64", "int64", "int32[::1]"),
        ("none",),
    ),
    "gather": Kernel(
        "replication.surfaces._raster",
        "_gather",
        (
            _CLOUD,
            "int64[::1] ro",
            "int32[::1]",
            "int64",
            "int64",
            "float64[:, ::1]",
            "float64[::1]",
            "float64[::1]",
        ),
        ("none",),
    ),  # fmt: skip
    "renumber": Kernel(
        "replication.surfaces._raster",
        "_renumber",
        (_TRIANGLES, "int32[::1]", "int64", "int64", "int32[:, ::1]"),
        ("none",),
    ),
    "exits": Kernel(
        "replication.surfaces._walks",
        "_exits",
        (_CLOUD, _TRIANGLES, _TRIANGLES, _CLOUD, _INDEX, "int32[::1]"),
        ("none",),
    ),
    "locate": Kernel(
        "replication.surfaces._walks",
        "_locate",
        (_CLOUD, _TRIANGLES, _TRIANGLES, _CLOUD, "boolean", "int32[::1]", "int32[::1]"),
        ("none",),
    ),
    "barycentric": Kernel(
        "replication.surfaces._walks",
        "_barycentric",
        (_CLOUD, _TRIANGLES, "int32[::1]", _CLOUD, _VALUES, "float64[::1]"),
        ("none",),
    ),
    "sheet_prepare": Kernel(
        "replication.casestudy._sheet",
        "prepare",
        (_CLOUD, "int64[:, ::1] ro", "int64[:, ::1] ro", "boolean"),
        (_MESH, "float64[:, ::1]"),
    ),
    "sheet_trace": Kernel(
        "replication.casestudy._sheet",
        "trace",
        (
            _MESH,
            "boolean",
            "boolean",
            "float64[::1]",
            "float64[::1]",
            "float64[::1] ro",
            "int64[::1]",
            "float64",
            "int64",
            "float64",
            "int64",
            "float64[::1]",
            "int64",
            "int64",
            "float64[:, ::1]",
        ),
        ("none",),
    ),  # fmt: skip
    "sheet_orientations": Kernel(
        "replication.casestudy._sheet",
        "orientations",
        (_VALUES, _VALUES, "int64[:, ::1] ro"),
        ("float64[::1]",),
    ),
    "sheet_first_overlap": Kernel(
        "replication.casestudy._sheet",
        "first_overlap",
        (_VALUES, _VALUES, "int64[:, ::1] ro"),
        ("int64", "int64", "int64"),
    ),
    "nearest": Kernel(
        "replication.surfaces._walks",
        "_nearest",
        (_CLOUD, _TRIANGLES, _TRIANGLES, _CLOUD, _INDEX, "int32[::1]"),
        ("none",),
    ),
}


def source_digest() -> int:
    """A 60-bit digest of the sources the ahead-of-time kernels are compiled from.

    Returns
    -------
    int
        A digest of the kernel table, the builder (``_aotbuild.py``), every private module
        of :mod:`replication.surfaces` and the water-jet model's kernel modules
        (``casestudy/_sheet*.py``), where all kernels and their callees live: more than the
        kernels need, so that no edit is missed.
    """
    package = Path(__file__).resolve().parent
    h = hashlib.sha256(repr(sorted(KERNELS.items())).encode())
    kernels = [*(package / "surfaces").glob("_*.py"), *(package / "casestudy").glob("_sheet*.py")]
    for path in [package / "_aotbuild.py", *sorted(kernels)]:
        h.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return int(h.hexdigest()[:15], 16)


@functools.cache
def compiled() -> ModuleType | None:
    """The ahead-of-time extension module, or None when it is missing, disabled or stale.

    Returns
    -------
    module or None
        ``_replication_kernels`` when it imports and was built from the current sources
        (:func:`source_digest`), unless ``REPLICATION_AOT=0``; the answer is kept for the
        life of the process.
    """
    if os.environ.get("REPLICATION_AOT", "1").strip() == "0":
        return None
    try:
        module = importlib.import_module(MODULE)
    except ImportError:
        return None
    if module.source_digest() != source_digest():
        return None  # built from other sources: an edited checkout
    return module


def stale() -> bool:
    """Whether an ahead-of-time module is installed but refused as built from other sources.

    Returns
    -------
    bool
        True in a checkout whose kernel sources were edited (even an edit since undone)
        after the module was built: every call then runs numba's kernels, correct but with
        numba's start-up; ``python -m replication._aotbuild`` builds it again. False when it
        is current, absent or disabled (``REPLICATION_AOT=0``).
    """
    if os.environ.get("REPLICATION_AOT", "1").strip() == "0" or compiled() is not None:
        return False
    return importlib.util.find_spec(MODULE) is not None


def kernel(name: str) -> Callable:
    """The code to call for a kernel (see the module notes for the choice).

    Parameters
    ----------
    name : str
        A key of :data:`KERNELS`.

    Returns
    -------
    callable
        numba's dispatcher, or the ahead-of-time function behind a check of its arguments.
    """
    spec = KERNELS[name]
    jit_module = sys.modules.get(spec.module)  # may still be importing in another thread
    dispatcher = getattr(jit_module, spec.function, None) if jit_module is not None else None
    # compiled or loaded in this process: numba's start-up is paid. ``overloads`` is the dict
    # behind ``signatures``, which copies its keys at a cost of about 8 us per call
    if getattr(dispatcher, "overloads", None):
        return dispatcher
    if compiled() is not None:
        return _checked(name)
    return _jit(name)


def is_numba(code: Callable) -> bool:
    """Whether ``code`` (from :func:`kernel`) is numba's kernel rather than the ahead-of-time one."""
    return getattr(code, "py_func", None) is not None


def releases_gil(code: Callable) -> bool:
    """Whether ``code`` (from :func:`kernel`) releases the GIL while it runs, so that other
    threads' calls run side by side with it: numba's kernel where it was compiled with
    ``nogil=True``, and every ahead-of-time kernel (the builder compiles them to release it,
    and refuses a kernel of the table whose numba kernel does not).
    """
    options = getattr(code, "targetoptions", None)  # numba's dispatcher
    if options is not None:
        return bool(options.get("nogil", False))
    return bool(getattr(code, "releases_gil", False))


def _items(text: str) -> list[str] | None:
    """The item types of a tuple type ``"(a, b, ...)"`` (None: not a tuple)."""
    if not text.startswith("("):
        return None
    items, depth, start = [], 0, 1
    for k, char in enumerate(text[1:-1], 1):
        if char in "([":
            depth += 1
        elif char in ")]":
            depth -= 1
        elif char == "," and depth == 0:
            items.append(text[start:k].strip())
            start = k + 1
    items.append(text[start:-1].strip())
    return items


def numba_signature(spec: Kernel):
    """numba's signature of a kernel of the table (imports numba), from the same reading of
    the table's types as the argument checks (:func:`_parse`)."""
    from numba.core import types
    from numba.np.numpy_support import from_dtype

    def typed(check):
        if isinstance(check, list):
            return types.Tuple([typed(item) for item in check])
        dtype, ndim, readonly = check
        scalar = from_dtype(dtype)
        return scalar if ndim == 0 else types.Array(scalar, ndim, "C", readonly=readonly)

    returns = [types.none if text == "none" else typed(_parse(text)) for text in spec.returns]
    result = types.Tuple(returns) if len(returns) > 1 else returns[0]
    return result(*(typed(_parse(a)) for a in spec.args))


def load_numba(name: str) -> None:
    """Load (or compile) numba's kernel ``name`` for its one signature, without calling it.

    From then on :func:`kernel` returns numba's code in this process (see the module notes):
    :func:`replication.kernels.warm_up` does this for every kernel of the table, so that the
    timed code and the code a large cloud's pieces run are numba's.
    """
    _jit(name).compile(numba_signature(KERNELS[name]))


def _jit(name: str) -> Callable:
    """numba's dispatcher of kernel ``name`` (importing its module, and numba)."""
    spec = KERNELS[name]
    return getattr(importlib.import_module(spec.module), spec.function)


@functools.cache
def _checked(name: str) -> Callable:
    """The ahead-of-time kernel behind a check of its arguments' types.

    The compiled wrapper trusts its declared types (a float32 array would be read as float64
    and could crash the interpreter), so each array is checked for dtype, dimensions,
    C-contiguity, alignment and, for outputs, writability, and each integer for being one.
    Arguments that fail go to numba's kernel, which compiles for any type it supports or
    raises its own error: the answer never depends on which code ran.
    """
    spec = KERNELS[name]
    function = getattr(compiled(), name)
    checks = tuple(_parse(arg) for arg in spec.args)

    def call(*args):  # a plain loop: this check is paid on every call of a small kernel
        if len(args) == len(checks):
            for value, check in zip(args, checks):
                if not _fits(value, check):
                    break
            else:
                return function(*args)
        return _jit(name)(*args)

    call.__name__ = call.__qualname__ = name
    call.releases_gil = True  # see _aotbuild: both the compiled kernel and numba's fallback do
    call.__doc__ = f"Ahead-of-time {spec.module}.{spec.function} (argument types checked)."
    return call


def _parse(arg: str):
    """The check of one argument type of :class:`Kernel`: ``(dtype, ndim, readonly)``, ndim 0
    for a scalar (``int64``, ``float64`` or ``boolean``), or a list of item checks for a tuple."""
    items = _items(arg)
    if items is not None:
        return [_parse(item) for item in items]
    readonly = arg.endswith(" ro")
    text = arg.removesuffix(" ro")
    if "[" not in text:
        return np.dtype(bool if text == "boolean" else text), 0, False
    base, dims = text.split("[", 1)
    if not dims.rstrip("]").endswith("::1"):  # the checks require C-contiguous arrays
        raise ValueError(f"the table's arrays are C-contiguous (last dimension '::1'), got {arg!r}")
    return np.dtype(base), dims.count(",") + 1, readonly


_BOOLS = (bool, np.bool_)
_INTEGERS = (int, np.integer)


def _fits(value, check) -> bool:
    """Whether ``value`` has the type of one argument of a compiled kernel (see :func:`_parse`)."""
    if isinstance(check, list):
        return (
            isinstance(value, tuple)
            and len(value) == len(check)
            and all(_fits(v, c) for v, c in zip(value, check))
        )
    dtype, ndim, readonly = check
    if ndim == 0:
        kind = dtype.kind
        if kind == "b":
            return isinstance(value, _BOOLS)
        if kind == "f":
            return isinstance(value, float)  # a Python float or numpy.float64
        return isinstance(value, _INTEGERS) and not isinstance(value, bool)
    if not (isinstance(value, np.ndarray) and value.dtype == dtype and value.ndim == ndim):
        return False
    flags = value.flags
    return flags.c_contiguous and flags.aligned and (readonly or flags.writeable)
