"""The ``replication`` command line.

Only this package prints or sets an exit status: library errors (:class:`ReplicationError`)
become a one-line message on stderr and exit status 1; usage errors exit with status 2
(argparse's, and :class:`~replication.errors.UsageError`: options that do not go together,
or one given without the option it needs); an interrupt (Ctrl-C) exits with 130, and SIGTERM,
which stops a command as Ctrl-C does but without waiting (:mod:`replication.sigterm`), with 143. The
system refusing a file the user named (an operating-system error that carries the file
name, such as a name too long) and a lack of memory are one line too, saying so. So is a
standard output that cannot be written (a full disk, ``> /dev/full``): the line says it was
the standard output, not a file the command wrote. Any other exception is a bug or an
environment problem nobody foresaw: it too becomes one line, naming its type, with a hint to
run again with ``--debug`` for the traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import os
import re
import shlex
import sys
from collections.abc import Callable, Iterable, Sequence
from typing import IO, NoReturn

from replication.errors import ReplicationError, UsageError, escaped, shortened
from replication.io.locks import held_until_the_command_ends
from replication.sigterm import EXIT_STATUS as SIGTERM_EXIT
from replication.sigterm import sigterm_interrupts, terminated

__all__ = ["COMMANDS", "build_parser", "main", "run"]

NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|nan)$", re.IGNORECASE)
DEBUG_HELP = "on an unexpected error, show the full Python traceback"

#: Every command: the module whose ``register`` adds its parser, and its one-line help. The
#: top-level ``--help`` lists them from here, so a command's module (and what it imports) is
#: loaded only when that command runs; a test checks that each module's parser says the same.
COMMANDS: dict[str, tuple[str, str]] = {
    "adt": ("replication.cli.surfaces", "build an ADT surface from a point cloud (paper section 3.2)"),
    "nurbs": ("replication.cli.surfaces", "fit the paper's NURBS baseline to a point cloud (section 3.1)"),
    "compare": ("replication.cli.surfaces", "paired statistics of ADT vs NURBS depths (section 4)"),
    "force": (
        "replication.cli.force",
        "force of the case study's water jet on a surface (paper section 6)",
    ),
    "casestudy": (
        "replication.cli.casestudy",
        "the water-jet genetic algorithm (section 6) into reports/casestudy.md (Figs. 8, 9)",
    ),
    "reproduce": ("replication.cli.reports", "regenerate every available report of the paper's results"),
    "table1": (
        "replication.cli.reports",
        "reproduce Table 1 and Fig. 6 (ADT vs NURBS) into reports/table1.md",
    ),
    "report": (
        "replication.cli.reports",
        "re-render the reports' markdown and figures from their saved data (no experiment is run)",
    ),
    "sph": (
        "replication.cli.sph",
        "the case study on a real SPH solver: convergence and the paper's forces examined (sph.md)",
    ),
    "validate-jet": (
        "replication.cli.validate",
        "check the thin-sheet jet model against SPH on 37 surfaces (jet_validation.md)",
    ),
}


class _Version(argparse.Action):
    """``--version``: reads the installed version only when asked (importlib.metadata is not free)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS, **kwargs: object):
        super().__init__(option_strings, dest=dest, default=argparse.SUPPRESS, nargs=0, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, *args: object, **kwargs: object) -> None:
        from replication import __version__

        print(f"{parser.prog} {__version__}")
        parser.exit()


EPILOG = """\
examples:
  replication reproduce                       every report of the paper's results into reports/
  replication adt cloud.csv -o surface.vtk    an ADT surface from your own point cloud
  replication compare cloud.csv               ADT vs NURBS on a cloud: paired tests of the depths
  replication force bucket.csv                the water jet's force on a surface
  replication COMMAND --help                  a command's options, with examples

Errors print one line (exit status 1; 2 for a misused option); --debug shows the traceback
of an unexpected one.
"""


def build_parser(commands: Iterable[str] | None = None) -> argparse.ArgumentParser:
    """The argument parser; the full parsers of ``commands`` (default: every command).

    A command left out is listed in the top-level help but has no arguments of its own, so
    ``main`` builds the parser of only the command it runs: ``replication --help`` and
    ``replication adt ...`` import nothing of the other commands.
    """
    modules = {COMMANDS[name][0] for name in (COMMANDS if commands is None else commands)}
    parser = _Parser(
        prog="replication",
        description=(
            "Reproduce 'adapted Delaunay triangulation' (ADT) surfaces from random point clouds, "
            "their comparison with NURBS, and the paper's water-jet case study."
        ),
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action=_Version, help="show program's version number and exit")
    parser.add_argument("--debug", action="store_true", help=DEBUG_HELP)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module, helptext) in COMMANDS.items():
        if name in sub.choices:  # registered with a sibling command of its module
            continue
        if module in modules:  # registers all of its commands (they are adjacent in COMMANDS)
            importlib.import_module(module).register(sub)
        else:
            sub.add_parser(name, help=helptext, add_help=False)
    for command in sub.choices.values():  # also accepted after the command: replication adt ... --debug
        command.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=DEBUG_HELP)
        # argparse takes "-1e1" for an option (its pattern of negative numbers has no exponent):
        # --box -1e1 10 ... failed with "expected 6 arguments" while -10 worked
        command._negative_number_matcher = NEGATIVE_NUMBER
    return parser


def _command(argv: Sequence[str]) -> str | None:
    """The command ``argv`` names: its first word that is not an option (top-level options take no value)."""
    words = iter(argv)
    for word in words:
        if word == "--":
            return next(words, None)
        if not word.startswith("-"):
            return word
    return None


def _interrupted(exc: BaseException) -> bool:
    from replication.casestudy.interrupts import caused_by_interrupt

    return caused_by_interrupt(exc)


class _LostInterrupts:
    """While active, a Ctrl-C whose :class:`KeyboardInterrupt` Python could only report (raised
    in a ctypes callback, a finalizer, a weakref callback) is recorded in :attr:`lost`, not printed.

    Ctrl-C during a first, cold compile of numba's kernels raised inside LLVM's object-cache
    callback, a ctypes callback: Python printed "Exception ignored on calling ctypes callback
    function" and a traceback, the compile went on without its object, and numba's cache save
    then failed, so the command ended in "unexpected RuntimeError: no compiled object yet". The
    command says "interrupted" instead when it fails after such a lost interrupt (:func:`main`).
    Lost where the compile does not fail (the callback that offers numba a cached object), the
    Ctrl-C is not raised at all and the command goes on, as after a Ctrl-C it ignores: a second
    one stops it. (Raising SIGINT again from the hook raises it in the hook, lost again, and
    from another thread, it may come after the command has said how it ended.) SIGTERM's
    :class:`~replication.sigterm.Terminated` is recorded too; :mod:`replication.sigterm` raises a
    lost one when its block ends. Other unraisable exceptions go to the hook that was in place,
    until the command has said that it was stopped (:attr:`quiet`): an object that Ctrl-C cut
    short while it was built (llvmlite's, in a compile) then printed "Exception ignored in
    ObjectRef.__del__" and an ``AttributeError`` traceback below "interrupted" as it was freed.
    """

    def __init__(self) -> None:
        self.lost = False
        self.quiet = False  # set once the command has said it was stopped
        self._previous = sys.unraisablehook

    def __enter__(self) -> _LostInterrupts:
        self._previous = sys.unraisablehook
        sys.unraisablehook = self._hook
        return self

    def __exit__(self, *exc: object) -> None:
        sys.unraisablehook = self._previous

    def _hook(self, unraisable: object) -> None:
        if isinstance(getattr(unraisable, "exc_value", None), KeyboardInterrupt):
            self.lost = True
            return
        if self.quiet:  # an object that the interrupt cut short, complaining as it is freed
            return
        self._previous(unraisable)  # type: ignore[arg-type]


def _one_line(exc: BaseException) -> str:
    """An unexpected exception as one line: its type and message, file names included."""
    text = " ".join(str(exc).split()) or "(no message)"
    if isinstance(exc, OSError) and exc.filename is not None and str(exc.filename) not in text:
        text += f": {exc.filename}"
    return f"unexpected {type(exc).__name__}: {text}"


#: Operating-system errors that are the system's answer about a path the user named (a name
#: too long, no permission, a read-only or full file system, too many open files), not a bug.
_REFUSALS = frozenset(
    getattr(errno, name)
    for name in ("ENAMETOOLONG", "EACCES", "EPERM", "EROFS", "ENOSPC", "EDQUOT", "EMFILE", "ENFILE")
    if hasattr(errno, name)
)


def _file_name(name: object) -> str:
    return shortened(os.fsdecode(name) if isinstance(name, (str, bytes, os.PathLike)) else name)


def _refused(exc: BaseException) -> str | None:
    """The message of an error that is no bug but the system's answer about a path: an
    ``OSError`` naming a file with one of the :data:`_REFUSALS` (``File name too long``), or
    None. Any other exception, a MemoryError included, keeps the ``--debug`` hint: those that
    reached here so far were missing input checks."""
    if isinstance(exc, OSError) and exc.filename is not None and exc.errno in _REFUSALS:
        reason = exc.strerror or " ".join(str(exc).split()) or type(exc).__name__
        names = _file_name(exc.filename)
        if exc.filename2 is not None:
            names += f" -> {_file_name(exc.filename2)}"
        return f"{names}: {reason}"
    return None


def _unexpected(exc: BaseException) -> str:
    """An exception nobody foresaw, as one line with the hint to run with ``--debug``."""
    if isinstance(exc, MemoryError):
        text = " ".join(str(exc).split())
        return f"not enough memory{f': {text}' if text else ''} (run with --debug for the traceback)"
    return f"{_one_line(exc)} (run with --debug for the traceback)"


class _StdoutFailed(Exception):
    """Writing the standard output failed; ``__cause__`` is the ``OSError``."""


class _GuardedStdout:
    """``sys.stdout`` while a command runs: an ``OSError`` writing it becomes :class:`_StdoutFailed`.

    A full disk under ``replication adt ... > out.txt`` read "unexpected OSError: [Errno 28]
    No space left on device", as if the surface file had failed. A closed pipe stays a
    ``BrokenPipeError`` (ended quietly). Everything else is the wrapped stream's.
    """

    def __init__(self, stream: object) -> None:
        self._stream = stream

    def __getattr__(self, name: str) -> object:
        return getattr(self._stream, name)

    def _guarded(self, call: Callable[..., object], *args: object) -> object:
        try:
            return call(*args)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise _StdoutFailed(exc.strerror or " ".join(str(exc).split())) from exc

    def write(self, text: str) -> object:
        return self._guarded(self._stream.write, text)

    def writelines(self, lines: Iterable[str]) -> object:
        return self._guarded(self._stream.writelines, lines)

    def flush(self) -> object:
        return self._guarded(self._stream.flush)


def _flush_answer(command: str | None) -> None:
    """Flush what --help or --version printed; a standard output that cannot take it is one line
    and exit status 1 (``SystemExit``), not a success with nothing written."""
    if sys.stdout is None:
        return
    try:
        sys.stdout.flush()
    except BrokenPipeError:  # as when the write itself found the reader gone (unbuffered)
        _quiet_stdout()
        raise SystemExit(141) from None
    except OSError as exc:
        raise SystemExit(_answer_unwritten(command, exc)) from None


def _answer_unwritten(command: str | None, exc: OSError) -> int:
    name = f"replication{f' {command}' if command in COMMANDS else ''}"
    text = f"cannot write the standard output: {exc.strerror or ' '.join(str(exc).split())}"
    print(f"{name}: error: {escaped(text)}", file=sys.stderr)
    _quiet_stdout()
    return 1


def _quiet_stdout() -> None:
    """Point the standard output at the null device: no second error when it is flushed at exit."""
    with contextlib.suppress(OSError, ValueError):
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


class _Parser(argparse.ArgumentParser):
    """argparse's parser with errors of one line (argparse prints its whole usage first); the
    exit status stays argparse's 2, a usage error, against 1 for a failed command."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {escaped(message)} (see '{self.prog} --help')\n")

    def _print_message(self, message: str, file: IO[str] | None = None) -> None:
        """argparse's, without swallowing an ``OSError``: ``--help > /dev/full`` exited 0 with
        nothing written (:func:`main` makes it one line and exit status 1)."""
        if not message:
            return
        stream = file or sys.stderr
        try:
            stream.write(message)
        except AttributeError:  # a closed stream (None): nothing to say
            pass
        except OSError:
            if stream is not sys.stderr:  # an error message that stderr cannot take: nowhere to say so
                raise


def _unrecognized(parser: argparse.ArgumentParser, command: str, extra: list[str]) -> NoReturn:
    """Refuse arguments the command does not know, naming the command (not the top level)."""
    target = parser
    for action in parser._actions:  # the command's own parser, for its name in the message
        if isinstance(action, argparse._SubParsersAction) and command in action.choices:
            target = action.choices[command]
    target.error(f"unrecognized arguments: {' '.join(extra)}")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``replication`` command; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    command = _command(argv)
    try:  # building the parser imports the command's module: a second or so
        parser = build_parser([command] if command in COMMANDS else [])
        args, extra = parser.parse_known_args(argv)
        if extra:
            _unrecognized(parser, args.command, extra)
    except KeyboardInterrupt:  # was a traceback: main's handlers below did not cover it yet
        print(f"replication{f' {command}' if command in COMMANDS else ''}: interrupted", file=sys.stderr)
        return 130
    except SystemExit as exc:  # --help, --version (or argparse's own error, already on stderr)
        if exc.code in (0, None):
            _flush_answer(command)
        raise
    except BrokenPipeError:  # ``replication --version | true``: the reader went away, quietly
        _quiet_stdout()
        return 141
    except OSError as exc:  # printing --help or --version: a full disk (> /dev/full)
        return _answer_unwritten(command, exc)
    args.invocation = shlex.join(["replication", *argv])
    func: Callable[[argparse.Namespace], int] = args.func
    name = f"replication {args.command}"
    stdout = sys.stdout
    lost = _LostInterrupts()
    if stdout is not None:  # None when the standard output is closed (>&-): print() drops the text
        sys.stdout = _GuardedStdout(stdout)  # type: ignore[assignment]
    with lost:  # (to the end: objects an interrupt cut short are freed after the handlers)
        try:
            # SIGTERM stops the command as Ctrl-C does (replication.sigterm); the reports directory
            # it holds is released when it ends (replication.io.locks)
            with sigterm_interrupts(), held_until_the_command_ends():
                status = func(args)
            if sys.stdout is not None:
                sys.stdout.flush()  # a file's full disk shows here, not as "Exception ignored" at exit
            return status
        except _StdoutFailed as exc:  # (the surface commands print after writing their files)
            _quiet_stdout()
            text = f"cannot write the standard output: {exc} (any file the command wrote is complete)"
            print(f"{name}: error: {escaped(text)}", file=sys.stderr)
            return 1
        except UsageError as exc:  # options that do not go together: a usage error, as argparse's
            print(f"{name}: error: {escaped(str(exc))} (see '{name} --help')", file=sys.stderr)
            return 2
        except ReplicationError as exc:
            if lost.lost:  # the failure of work cut short by a Ctrl-C that Python could not raise
                return _stopped(name, quiet=lost)
            print(f"{name}: error: {escaped(str(exc))}", file=sys.stderr)
            return 1
        except KeyboardInterrupt as exc:
            return _stopped(name, exc, quiet=lost)
        except BrokenPipeError:  # the reader went away (``replication adt ... --json | head``): quietly
            _quiet_stdout()
            return 141  # 128 + SIGPIPE, as a shell pipeline's other programs end
        except Exception as exc:
            if _interrupted(exc) or lost.lost:  # Ctrl-C inside compiled code surfaces as another exception
                return _stopped(name, quiet=lost)
            if args.debug:
                raise
            refused = _refused(exc)
            text = refused if refused is not None else _unexpected(exc)
            print(f"{name}: error: {escaped(text)}", file=sys.stderr)
            return 1
        finally:
            sys.stdout = stdout


def _stopped(name: str, exc: BaseException | None = None, *, quiet: _LostInterrupts | None = None) -> int:
    """Say that the command was stopped, by Ctrl-C (exit 130) or SIGTERM (143), which files it
    had written when the signal came while they were moved into place, and the error of a
    write that failed meanwhile. From then on ``quiet`` drops what finalizers report."""
    from replication.io.atomic import written_before

    if quiet is not None:
        quiet.quiet = True

    written = written_before(exc) if exc is not None else ()
    after = ""
    if written:
        shown = ", ".join(str(path) for path in written[:3]) + (", ..." if len(written) > 3 else "")
        after = f" after writing {len(written)} file{'s' if len(written) > 1 else ''} ({escaped(shown)})"
    cause = exc.__cause__ if exc is not None else None
    if isinstance(cause, Exception):  # a write that failed while the signal was held
        text = str(cause) if isinstance(cause, ReplicationError) else _refused(cause) or _unexpected(cause)
        after += f"; meanwhile: {escaped(text)}"
    if terminated():
        print(f"{name}: terminated (SIGTERM){after}", file=sys.stderr)
        return SIGTERM_EXIT
    print(f"{name}: interrupted{after}", file=sys.stderr)
    return 130


def run() -> None:
    """The ``replication`` console script (and ``python -m replication``): :func:`main`, then exit.

    At exit the interpreter's final garbage collections walk every object the command loaded
    (numba and LLVM, scipy, pandas): 0.12 s of a 1 s ``replication adt``, measured on this
    project's machine. The command's objects are frozen first (:func:`gc.freeze`), so those
    collections skip them. Output files are written and closed by then, and atexit handlers
    and worker shutdowns run as usual; only finalizers of objects caught in reference cycles
    may not run, which Python never promises at exit anyway.
    """
    import gc

    status = main()
    if status in (130, SIGTERM_EXIT):  # stopped, and said so: objects it cut short are freed at exit
        sys.unraisablehook = _drop
    gc.freeze()
    sys.exit(status)


def _drop(unraisable: object) -> None:
    """An unraisable-exception hook that says nothing (see :func:`run`)."""
