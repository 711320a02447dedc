"""The ``replication`` command line.

Only this package prints or sets an exit status: library errors (:class:`ReplicationError`)
become a one-line message on stderr and exit status 1; usage errors exit with status 2
(argparse); an interrupt exits with 130.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Callable, Sequence

from replication import __version__
from replication.errors import ReplicationError

__all__ = ["build_parser", "main"]


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
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    surfaces.register(sub)
    force.register(sub)
    casestudy.register(sub)
    reports.register(sub)
    sph.register(sub)
    validate.register(sub)  # issue 11: the jet model checked against SPH
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``replication`` command; returns the exit status."""
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    args.invocation = shlex.join(["replication", *argv])
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except ReplicationError as exc:
        print(f"replication {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"replication {args.command}: interrupted", file=sys.stderr)
        return 130
