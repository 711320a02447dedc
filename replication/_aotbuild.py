"""Compile the ahead-of-time kernels of :mod:`replication._aot` into their extension module.

Run by the package's build (``setup.py``) as ``python -m replication._aotbuild OUT``, where
OUT is the extension module's file. A developer who edited a kernel runs
``python -m replication._aotbuild`` (or reinstalls) to rebuild it, since a module built from
other sources is never used: without OUT it goes beside the package, where an editable install
keeps it.

Needs numba, numpy and a C compiler; compiling takes about 40 s of one core.
"""

from __future__ import annotations

import contextlib
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from replication._aot import KERNELS, MODULE, source_digest

__all__ = ["build", "default_target", "main"]


def build(target: Path) -> None:
    """Compile every kernel of :data:`~replication._aot.KERNELS` into the file ``target``.

    Parameters
    ----------
    target : Path
        The file to write; its name must be the extension module's (``_replication_kernels``
        plus the interpreter's extension suffix).
    """
    import importlib

    from numba.core import types
    from numba.pycc import CC

    from replication._aot import numba_signature

    target = Path(target).resolve()
    if not target.name.startswith(MODULE + "."):
        raise ValueError(f"the extension module's file must be named {MODULE}.<suffix>, not {target.name!r}")
    target.parent.mkdir(parents=True, exist_ok=True)
    cc = CC(MODULE)
    cc.output_dir = str(target.parent)
    cc.output_file = target.name
    # no target_cpu: generic code for the architecture, so a moved install never meets an
    # instruction its CPU lacks (host-specific code measured only 7 % faster)
    for name, spec in KERNELS.items():
        dispatcher = getattr(importlib.import_module(spec.module), spec.function)
        if not dispatcher.targetoptions.get("nogil", False):
            raise ValueError(f"kernel {name!r} ({spec.module}.{spec.function}) is not nogil=True")
        cc.export(name, numba_signature(spec))(_calling(dispatcher, len(spec.args)))
    cc.export("source_digest", types.int64())(_constant(source_digest()))
    with tempfile.TemporaryDirectory(prefix="replication-aot-") as scratch, _releasing_gil():
        tempfile.tempdir, saved = scratch, tempfile.tempdir  # pycc's own scratch goes in here
        try:
            cc.compile()
        finally:
            tempfile.tempdir = saved


@contextlib.contextmanager
def _releasing_gil() -> Iterator[None]:
    """While pycc compiles, every exported function's Python wrapper releases the GIL around
    the kernel, as numba's ``nogil=True`` does for its JIT kernels (the same compiler flag,
    ``release_gil``, which pycc has no option for): the ahead-of-time pieces of a jet force then
    run side by side on the package's thread pool, as numba's do.

    Raises
    ------
    RuntimeError
        When this numba's pycc does not compile through ``compile_extra`` (the build then goes
        on without ahead-of-time kernels rather than build kernels that hold the GIL).
    """
    from numba.pycc import compiler

    original = getattr(compiler, "compile_extra", None)
    if original is None:
        raise RuntimeError("this numba's pycc has no compile_extra to compile GIL-releasing wrappers with")

    def compile_extra(typingctx, targetctx, func, args, return_type, flags, *rest, **options):
        flags = flags.copy()
        flags.release_gil = True
        return original(typingctx, targetctx, func, args, return_type, flags, *rest, **options)

    compiler.compile_extra = compile_extra
    try:
        yield
    finally:
        compiler.compile_extra = original


def _calling(dispatcher, arity: int) -> Callable:
    """A function of ``arity`` arguments that only calls ``dispatcher``: exporting this wrapper,
    rather than the kernel's Python function, compiles the kernel with its own options
    (``error_model`` and the rest), as the JIT does. numba compiles it from its bytecode, so it
    is written out with named arguments (numba's export takes no ``*args``)."""
    if not 1 <= arity <= 16:
        raise ValueError(f"no wrapper for kernels of {arity} arguments")
    names = ", ".join(f"a{k}" for k in range(arity))
    namespace = {"dispatcher": dispatcher}
    exec(f"def call({names}):\n    return dispatcher({names})\n", namespace)  # noqa: S102 - fixed text
    return namespace["call"]


def _constant(value: int) -> Callable:
    def constant():
        return value

    return constant


def default_target() -> Path:
    """The extension module's file beside the package (a checkout's root, or site-packages)."""
    import sysconfig

    return Path(__file__).resolve().parents[1] / (MODULE + sysconfig.get_config_var("EXT_SUFFIX"))


def main(argv: list[str] | None = None) -> int:
    """``python -m replication._aotbuild [OUT]``: build, then print one line; exit 1 on failure."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) > 1 or any(a.startswith("-") for a in args):
        print("usage: python -m replication._aotbuild [OUT]  (the extension module's file)", file=sys.stderr)
        return 2
    target = Path(args[0]) if args else default_target()
    try:
        build(target)
    except Exception as exc:  # noqa: BLE001 - a build step reports any failure in one line
        print(f"replication: ahead-of-time kernels not built ({type(exc).__name__}: {exc})", file=sys.stderr)
        return 1
    print(f"replication: ahead-of-time kernels built into {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
