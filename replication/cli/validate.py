"""``replication validate-jet``: the thin-sheet model checked against SPH (jet_validation.md)."""

from __future__ import annotations

import argparse
import time

from replication.cli.common import directory_name, worker_count
from replication.cli.validate_run import run_validation_report

EPILOG = """\
examples:
  replication validate-jet                      the full study (hours of SPH) into reports/
  replication validate-jet --from-cache         re-render from the SPH cache only (seconds)
  replication validate-jet --quick              3 surfaces, coarse particles, into reports-quick/
  replication validate-jet --workers 1          one simulation at a time

Every simulation's result is a directory in the SPH cache (--cache-dir, default .sph-cache/),
named by a hash of the surface, the settings, the engine version and the SPH code: after
Ctrl-C or a crash, the same command skips every finished simulation. Failed simulations are
recorded and skipped on a rerun (--retry-failed runs them again). The study's surfaces are
built once and kept in the cache directory (surfaces/, with the GA runs whose winners they
include, ga-runs/), so a later change of the triangulator or the model does not turn the
cached simulations into misses; --rebuild-surfaces builds them afresh.
"""


def _cmd_validate(args: argparse.Namespace) -> int:
    from replication.cli.outputs import check_replaces_alike, finish_reports, planned_output_dir

    _check_options(args)
    custom = _custom_settings(args)
    _check_custom_run(args, custom)
    out = planned_output_dir(args, ("jet_validation.md", "index.md"), custom=custom)
    what = "--output-dir" if args.output_dir else "the reports directory"
    check_replaces_alike(out, what, [*(["--quick"] if args.quick else []), *custom], ["jet_validation"])
    start = time.perf_counter()
    results, path = run_validation_report(args, out)
    table = results.surfaces
    missing = int((table["sph_status"] == "missing").sum())
    failed = int((~table["sph_status"].isin(["ok", "missing"])).sum())
    overall = results.agreement.iloc[0]
    print(
        f"{len(table)} surfaces: thin-sheet model vs SPH Spearman {overall['spearman']:.3f} "
        f"[{overall['spearman_low']:.3f}, {overall['spearman_high']:.3f}], Kendall {overall['kendall']:.3f} "
        f"over {int(overall['n'])} simulated ({failed} failed, {missing} not in the cache)"
    )
    written = finish_reports(out)
    print(f"wrote {path} ({time.perf_counter() - start:.1f} s; data in {out / 'data'})")
    for readme in written[1:]:
        print(f"refreshed the headline block of {readme} from {out}/data (the reports beside it)")
    return 0


def _check_options(args: argparse.Namespace) -> None:
    """Refuse options that contradict each other or would be ignored, and a ``--ga-run-dir``
    that is not a directory, before any work.

    ``--rebuild-surfaces`` builds the surfaces (running the study's GAs) and stores them in
    the cache, which ``--from-cache`` promises to leave as it is; whether the cache holds their
    simulations cannot be known without building them. The quick study has no GA, so
    ``--ga-run-dir`` would be ignored.
    """
    from pathlib import Path

    from replication.errors import InputError, UsageError
    from replication.io.paths import check_writable_dir

    if args.from_cache and args.rebuild_surfaces:
        raise UsageError(
            "--from-cache changes nothing in the SPH cache, but --rebuild-surfaces builds the surfaces "
            "afresh (running the study's GAs) and stores them there: give one of them"
        )
    if args.ga_run_dir is None:
        return
    if args.quick:
        raise UsageError(
            f"--ga-run-dir {args.ga_run_dir}: the quick study has no GA winners to score; "
            "drop --quick or --ga-run-dir"
        )
    path = Path(args.ga_run_dir)
    if path.exists() and not path.is_dir():
        raise InputError(f"--ga-run-dir {path} is a file, not a directory of GA runs")
    if not path.exists():  # the GA runs there: it must be possible to create it
        check_writable_dir(path, "--ga-run-dir")


def _custom_settings(args: argparse.Namespace) -> list[str]:
    """The options besides ``--quick`` that can make the study another than the committed one."""
    from replication.experiments.jet_validation import ValidationConfig

    custom = []
    simulates = not args.from_cache  # --from-cache simulates nothing: a timeout has no effect
    if simulates and args.timeout is not None and args.timeout != ValidationConfig().timeout:
        custom.append(f"--timeout {args.timeout:g}")
    if args.ga_run_dir is not None:
        custom.append(f"--ga-run-dir {args.ga_run_dir}")
    return custom


def _check_custom_run(args: argparse.Namespace, custom: list[str]) -> None:
    """Refuse to let a study with other settings replace the committed one by default.

    ``reports/jet_validation.md`` is the study at its own settings; ``--timeout`` or another
    GA's winners (``--ga-run-dir``) can give another study, which goes where ``--output-dir``
    says, and never into a checkout's committed ``reports/``
    (:func:`replication.cli.outputs.check_not_committed`).
    """
    from replication.cli.outputs import DEFAULT_DIR
    from replication.errors import UsageError

    if args.output_dir is not None or args.quick or not custom:
        return
    raise UsageError(
        f"with {' and '.join(custom)} the study may differ from the committed one in {DEFAULT_DIR}/: "
        "name a report directory with --output-dir"
    )


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``validate-jet`` subcommand."""
    from replication.casestudy.evaluate import EXECUTORS
    from replication.cli.outputs import DEFAULT_DIR, QUICK_DIR
    from replication.cli.sph import positive_float

    p = sub.add_parser(
        "validate-jet",
        help="check the thin-sheet jet model against SPH on 37 surfaces (jet_validation.md)",
        description=(
            "Score plates, cups, the GA's winners and random lattice surfaces with SPH (SPlisHSPlasH, "
            'the optional extra: pip install ".[sph]") and with the thin-sheet model, after a resolution '
            "study, and report how well the model ranks the surfaces (Spearman, Kendall, top-k)."
        ),
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"3 surfaces, coarse particles (under a minute) into {QUICK_DIR}/",
    )
    p.add_argument(
        "--cache-dir", type=directory_name, metavar="DIR", help="the SPH cache (default .sph-cache/)"
    )
    p.add_argument(
        "--from-cache",
        action="store_true",
        help="simulate nothing and change nothing in the cache: report from it, and fail if a simulation "
        "is missing (not with --rebuild-surfaces)",
    )
    p.add_argument("--retry-failed", action="store_true", help="simulate again the failed simulations")
    p.add_argument(
        "--ga-run-dir",
        metavar="DIR",
        help="score the winners of these GA runs (read, or run there) instead of the GA kept in the cache "
        "(not with --quick, whose study has no GA)",
    )
    p.add_argument(
        "--rebuild-surfaces",
        action="store_true",
        help="build the surfaces afresh with this code (running the study's GAs) and store them in the "
        "cache, instead of reading the set kept there (not with --from-cache)",
    )
    p.add_argument(
        "--workers", type=worker_count, default=2, help="simulations at a time (default 2; each uses a core)"
    )
    p.add_argument(
        "--executor",
        choices=EXECUTORS,
        default="process",
        help="where simulations are driven from (default: a process pool)",
    )
    p.add_argument(
        "--scheduler", metavar="ADDRESS", help="a running dask scheduler (its workers share the cache)"
    )
    p.add_argument(
        "--timeout",
        type=positive_float,
        metavar="S",
        help="wall-clock limit of one simulation (default 3600 s)",
    )
    p.add_argument(
        "--output-dir",
        type=directory_name,
        metavar="DIR",
        help=(
            f"where the report, figures and data go (default {DEFAULT_DIR}/, or {QUICK_DIR}/ with --quick; "
            "without --quick, required with --timeout or --ga-run-dir, which can give another study than the "
            "committed one)"
        ),
    )
    p.set_defaults(func=_cmd_validate)
