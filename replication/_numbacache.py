"""numba's on-disk cache of the package's kernels, flushed whenever any kernel source changes.

numba keys a cached kernel on its own source file (modification time and size) and on
nothing else. A kernel whose callees live in other modules keeps its old machine code after
those modules change: in this project's development checkout, the 200-point triangulation
ran code compiled before two later changes to the sweep (the shared flip kernel, and
``legalize`` no longer inlined) for most of a day, and measured 20 % faster than the code
in the repository. An upgrade that leaves a kernel's own file as it was could do the same
with a fixed bug.

Every kernel module therefore calls :func:`refresh` once its kernels are defined: when the
digest of all kernel sources (:func:`replication._aot.source_digest`, the digest that also
guards the ahead-of-time module) differs from the one stamped beside the module's cache,
the cache of each of the module's kernels is flushed, so that numba compiles them afresh and
caches the new code, and the stamp is rewritten. Only kernel modules import this (they import
numba anyway); the check reads one small file per module and process.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path
from typing import Any

__all__ = ["STAMP_SUFFIX", "refresh"]

#: Suffix of the stamp file beside a module's cache: ``<module name><suffix>``.
STAMP_SUFFIX = ".replication-digest"


@functools.cache
def _digest() -> str:
    from replication._aot import source_digest

    return str(source_digest())


def _kernels(namespace: dict[str, Any]) -> list[tuple[str, Any]]:
    """The module's own cached numba kernels: dispatchers with a flushable cache."""
    module = namespace.get("__name__")
    found = []
    for name, value in namespace.items():
        cache = getattr(value, "_cache", None)
        py_func = getattr(value, "py_func", None)
        if py_func is None or getattr(py_func, "__module__", None) != module:
            continue  # not a dispatcher, or imported from another module (that one refreshes it)
        if callable(getattr(cache, "flush", None)) and getattr(cache, "cache_path", None):
            found.append((name, value))
    return found


def refresh(namespace: dict[str, Any]) -> list[str]:
    """Flush the numba caches of a kernel module's kernels if the kernel sources changed.

    Parameters
    ----------
    namespace : dict
        The kernel module's ``globals()``, after its kernels are defined.

    Returns
    -------
    list of str
        The kernels whose cache was flushed (empty when the stamp was current).

    Notes
    -----
    A cache directory that cannot be written is left alone: numba cannot save there either.
    Two processes that refresh at once both flush; one of them may then compile a kernel the
    other had just cached, which costs time, never a wrong result.
    """
    kernels = _kernels(namespace)
    if not kernels:
        return []
    path = Path(kernels[0][1]._cache.cache_path)  # one directory for all kernels of a module
    stamp = path / f"{namespace['__name__']}{STAMP_SUFFIX}"
    digest = _digest()
    try:
        if stamp.read_text() == digest:
            return []
    except OSError:
        pass  # no stamp yet: a fresh cache, or one written before stamps existed
    try:
        for _, kernel in kernels:
            kernel._cache.flush()
        path.mkdir(parents=True, exist_ok=True)
        tmp = stamp.with_name(f"{stamp.name}.{os.getpid()}.tmp")
        tmp.write_text(digest)
        os.replace(tmp, stamp)
    except OSError:
        return []
    return [name for name, _ in kernels]
