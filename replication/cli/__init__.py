"""The ``replication`` command line.

Only this package prints or sets an exit status: library errors (:class:`ReplicationError`)
become a one-line message on stderr and exit status 1; usage errors exit with status 2
(argparse); an interrupt (Ctrl-C) exits with 130. Any other exception is a bug or an
environment problem nobody foresaw: it too becomes one line, naming its type, with a hint
to run again with ``--debug`` for the traceback.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Callable, Sequence

from replication import __version__
from replication.errors import ReplicationError

__all__ = ["build_parser", "main"]

DEBUG_HELP = "on an unexpected error, show the full Python traceback"


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand registered."""
    from replication.cli import casestudy, force, reports, sph, surfaces, validate

    parser = argparse.ArgumentParser(
        prog="replication",
        description=(
            "Reproduce 'adapted Delaunay triangulation' (ADT) surfaces from random point clouds, "
            "their comparison with NURBS, and the paper's water-jet case study."
        ),
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("--debug", action="store_true", help=DEBUG_HELP)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    surfaces.register(sub)
    force.register(sub)
    casestudy.register(sub)
    reports.register(sub)
    sph.register(sub)
    validate.register(sub)  # issue 11: the jet model checked against SPH
    for command in sub.choices.values():  # also accepted after the command: replication adt ... --debug
        command.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=DEBUG_HELP)
    return parser


def _interrupted(exc: BaseException) -> bool:
    from replication.casestudy.interrupts import caused_by_interrupt

    return caused_by_interrupt(exc)


def _one_line(exc: BaseException) -> str:
    """An unexpected exception as one line: its type and message, file names included."""
    text = " ".join(str(exc).split()) or "(no message)"
    if isinstance(exc, OSError) and exc.filename is not None and str(exc.filename) not in text:
        text += f": {exc.filename}"
    return f"unexpected {type(exc).__name__}: {text}"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``replication`` command; returns the exit status."""
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    args.invocation = shlex.join(["replication", *argv])
    func: Callable[[argparse.Namespace], int] = args.func
    name = f"replication {args.command}"
    try:
        return func(args)
    except ReplicationError as exc:
        print(f"{name}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{name}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        if _interrupted(exc):  # Ctrl-C inside compiled code surfaces as another exception
            print(f"{name}: interrupted", file=sys.stderr)
            return 130
        if args.debug:
            raise
        print(f"{name}: error: {_one_line(exc)} (run with --debug for the traceback)", file=sys.stderr)
        return 1
