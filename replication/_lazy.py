"""Package attributes imported on first use (PEP 562), so that importing a package costs nothing.

``import replication`` (and the command line, which imports it for its version) must not pay for
numba, scipy, pyvista or matplotlib: a package ``__init__`` declares which module defines each
public name, and :func:`attach` returns the module-level ``__getattr__`` and ``__dir__`` that
import that module when the name is first used. ``replication.adt(...)`` and
``from replication import adt`` work as before.

A public function may share its name with a submodule (``replication.compare`` is both the
module ``compare.py`` and its function ``compare``). Importing such a submodule binds the module
to the package attribute, which would hide the function; the package's module class therefore
ignores that binding (the submodule stays importable through ``sys.modules`` and its full name).
"""

from __future__ import annotations

import importlib
import sys
import types
from collections.abc import Callable, Mapping

__all__ = ["attach"]


def attach(
    package: str, exports: Mapping[str, str]
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package``, whose public ``name`` lives in ``exports[name]``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : mapping of str to str
        Public name -> the full name of the module that defines it.

    Notes
    -----
    Start-up cost is not part of the paper; the command line's start-up goal is issue 15 item 2.
    """
    module = sys.modules[package]
    shadowed = {name for name, source in exports.items() if source == f"{package}.{name}"}
    if shadowed:
        module.__class__ = _shadowing_module(frozenset(shadowed))

    def __getattr__(name: str) -> object:
        source = exports.get(name)
        if source is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(source), name)
        vars(module)[name] = value  # later lookups are plain attribute reads
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(module)) | set(exports))

    return __getattr__, __dir__


def _shadowing_module(names: frozenset[str]) -> type[types.ModuleType]:
    class Package(types.ModuleType):
        def __setattr__(self, name: str, value: object) -> None:
            if name in names and isinstance(value, types.ModuleType):
                return  # the import system binding submodule ``name``: keep the function of that name
            super().__setattr__(name, value)

    return Package
