"""``replication table1``, ``replication report`` and ``replication reproduce``."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

DEFAULT_DIR = "reports"
QUICK_DIR = "reports-quick"


def progress_bar(items: Iterable[Any], description: str, total: int) -> Iterable[Any]:
    """A tqdm progress bar on stderr (plain lines when stderr is not a terminal)."""
    from tqdm import tqdm

    return tqdm(items, desc=description, total=total, file=sys.stderr, leave=False, dynamic_ncols=True)


def output_dir(args: argparse.Namespace) -> Path:
    out = Path(args.output_dir or (QUICK_DIR if getattr(args, "quick", False) else DEFAULT_DIR))
    out.mkdir(parents=True, exist_ok=True)
    return out


def _run_table1(out: Path, quick: bool, command: str) -> Path:
    from replication.experiments.table1 import Table1Config, run_table1
    from replication.report.table1 import render_table1, save_table1_data

    config = Table1Config.quick_config() if quick else Table1Config()
    results = run_table1(config, progress=progress_bar, command=command)
    save_table1_data(results, out)
    return render_table1(out)


def _cmd_table1(args: argparse.Namespace) -> int:
    from replication.report.index import render_index

    out = output_dir(args)
    start = time.perf_counter()
    path = _run_table1(out, args.quick, args.invocation)
    render_index(out)
    print(f"wrote {path} ({time.perf_counter() - start:.1f} s; data in {out / 'data'})")
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from replication.report.casestudy import render_casestudy
    from replication.report.index import render_index
    from replication.report.table1 import render_table1

    out = Path(args.output_dir or DEFAULT_DIR)
    written = []
    if args.performance:
        from replication.report.performance import render_performance

        written.append(render_performance(args.asv_results, out, commits=args.commits))
    if (out / "data" / "table1_provenance.json").is_file():
        written.append(render_table1(out))
    if (out / "data" / "sph_provenance.json").is_file():
        from replication.report.sph import render_sph

        written.append(render_sph(out))
    if (out / "data" / "jet_validation_provenance.json").is_file():  # issue 11: the validation study
        from replication.report.jet_validation import render_jet_validation

        written.append(render_jet_validation(out))
    if (out / "data" / "casestudy_provenance.json").is_file():
        written.append(render_casestudy(out))
    if not written:
        from replication.errors import CloudFileError

        raise CloudFileError(f"no report data under {out / 'data'}: run `replication reproduce` first")
    written.append(render_index(out))
    if args.readme:
        from replication.report.index import update_readme

        written.append(update_readme(args.readme, out))
    for path in written:
        print(f"wrote {path}")
    return 0


STAGES = (
    ("table1", "Table 1 and Fig. 6: file size, computation time and paired statistics, ADT vs NURBS"),
    ("sph", "the case study on a real SPH solver (SPlisHSPlasH; runs when the extra sph is installed)"),
    (
        "jet validation",
        "the thin-sheet model checked against SPH (from the SPH cache; validate-jet fills it)",
    ),
    ("casestudy", "Figs. 8 and 9: the water-jet genetic algorithm"),
)


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from replication.cli.casestudy import run_and_report
    from replication.report.index import render_index

    out = output_dir(args)
    kind = "quick (reduced) run" if args.quick else "full run"
    print(f"replication reproduce: {kind} into {out}/")
    start = time.perf_counter()
    for name, what in STAGES:
        t0 = time.perf_counter()
        if name == "table1":
            path = _run_table1(out, args.quick, args.invocation)
        elif name == "sph":  # optional: needs the engine (pip install ".[sph]")
            from replication.casestudy.sph import INSTALL_HINT, engine_available
            from replication.cli.sph import run_sph_report

            if not engine_available():
                print(f"  [skipped] {name}: the SPH solver is not installed ({INSTALL_HINT})")
                continue
            path = run_sph_report(out, args.quick, args.invocation)
        elif name == "jet validation":  # issue 11: hours of SPH, so only from a filled cache
            from replication.cli.validate_run import reproduce_stage

            path, note = reproduce_stage(out, args.quick, args.invocation)
            if path is None:
                print(f"  [skipped] {name}: {note}")
                continue
        else:
            ga_args = argparse.Namespace(
                quick=args.quick, runs=None, generations=None, population=None, seed=None, run_dir=None,
                resume=False, executor="auto", workers=None, scheduler=None, invocation=args.invocation,
            )  # fmt: skip
            path = run_and_report(ga_args, out)[1]
        print(f"  [done] {name}: {what} -> {path} ({time.perf_counter() - t0:.1f} s)")
    index = render_index(out)
    print(f"wrote {index}; total {time.perf_counter() - start:.1f} s")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the table1, report and reproduce subcommands."""
    for name, func, helptext in (
        ("reproduce", _cmd_reproduce, "regenerate every available report of the paper's results"),
        ("table1", _cmd_table1, "reproduce Table 1 and Fig. 6 (ADT vs NURBS) into reports/table1.md"),
    ):
        p = sub.add_parser(
            name,
            help=helptext,
            description=helptext[0].upper() + helptext[1:] + ". Long stages show a progress bar on stderr.",
        )
        p.add_argument(
            "--quick",
            action="store_true",
            help=f"a reduced run (fewer repeats and seeds, under a minute) into {QUICK_DIR}/",
        )
        p.add_argument(
            "--output-dir",
            metavar="DIR",
            help=f"where reports, figures and data go (default {DEFAULT_DIR}/, or {QUICK_DIR}/ with --quick)",
        )
        p.set_defaults(func=func)
    p = sub.add_parser(
        "report",
        help="re-render the reports' markdown and figures from their saved data (no experiment is run)",
        description="Re-render the markdown and figures of every report from the data in DIR/data.",
    )
    p.add_argument("--output-dir", metavar="DIR", help=f"the reports directory (default: {DEFAULT_DIR}/)")
    p.add_argument(
        "--performance",
        action="store_true",
        help="also write performance.md from the asv results (run `asv run` first; see the README)",
    )
    p.add_argument(
        "--asv-results",
        metavar="DIR",
        default=".asv/results",
        help="asv's results directory (default: .asv/results)",
    )
    p.add_argument(
        "--commits", type=int, default=5, help="how many recent commits performance.md shows (default 5)"
    )
    p.add_argument(
        "--readme", metavar="FILE", help="also refresh the headline block of this README from the data"
    )
    p.set_defaults(func=_cmd_report)
