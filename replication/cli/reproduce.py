"""``replication reproduce``: run every available stage and regenerate the reports."""

from __future__ import annotations

import argparse


def _cmd_reproduce(args: argparse.Namespace) -> int:
    print("replication reproduce: regenerating the paper's results")
    print("stages still to come (not yet available in this version):")
    for name, what in (
        ("table1", "Table 1 and Fig. 6: file size, computation time and paired statistics, ADT vs NURBS"),
        ("casestudy", "Figs. 8 and 9: the water-jet genetic algorithm"),
    ):
        print(f"  - {name}: {what} [not yet available]")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "reproduce",
        help="regenerate the paper's tables and figures into reports/",
        description="Run every available stage of the replication and regenerate the reports.",
    )
    p.add_argument("--quick", action="store_true", help="a reduced run for smoke testing")
    p.set_defaults(func=_cmd_reproduce)
