"""``replication validate-jet``: the thin-sheet model checked against SPH (jet_validation.md)."""

from __future__ import annotations

import argparse
import functools
import sys
import time
from pathlib import Path
from typing import Any

from replication.cli.common import positive_int

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


def _config(args: argparse.Namespace) -> Any:
    import dataclasses

    from replication.experiments.jet_validation import ValidationConfig

    config = ValidationConfig.quick() if args.quick else ValidationConfig()
    if args.timeout is not None:
        config = dataclasses.replace(config, timeout=args.timeout)
    return config


def run_validation_report(args: argparse.Namespace, out: Path) -> tuple[Any, Path]:
    """Run the study as the arguments say (progress on stderr), save its data, render the report."""
    from tqdm import tqdm

    from replication.casestudy.evaluate import executor
    from replication.casestudy.sph import require_engine
    from replication.casestudy.sph_batch import DEFAULT_CACHE_DIR
    from replication.errors import SimulationError
    from replication.experiments.jet_validation import run_validation
    from replication.report.index import render_index
    from replication.report.jet_validation import render_jet_validation, save_jet_validation_data

    require_engine()
    config = _config(args)
    cache = Path(args.cache_dir or DEFAULT_CACHE_DIR)
    print(f"SPH cache: {cache} (a rerun skips every finished simulation)", file=sys.stderr)
    bar: Any = None

    def stage(label: str, n: int) -> None:
        nonlocal bar
        if bar is not None:
            bar.close()
        bar = tqdm(total=n, desc=label, file=sys.stderr, leave=False, dynamic_ncols=True)

    def done(scored: Any) -> None:
        if bar is not None:
            bar.set_postfix_str(f"{scored.name}: {scored.status}{' (cached)' if scored.cached else ''}")
            bar.update(1)
        if scored.status not in ("ok", "missing"):
            tqdm.write(f"  {scored.name}: {scored.status}: {scored.reason}", file=sys.stderr)

    ga_pool = functools.partial(executor, "serial")
    try:
        kind = "dask" if args.scheduler else args.executor
        with executor(kind, workers=args.workers, scheduler=args.scheduler) as pool:
            results = run_validation(
                config, cache_dir=cache, executor=pool, max_parallel=args.workers,
                ga_run_dir=args.ga_run_dir, ga_pool_factory=ga_pool, retry_failed=args.retry_failed,
                simulate_missing=not args.from_cache, rebuild_surfaces=args.rebuild_surfaces,
                on_result=done, on_stage=stage,
                command=args.invocation, quick=args.quick,
            )  # fmt: skip
    except KeyboardInterrupt:
        print(
            f"interrupted: finished simulations are in {cache}; run the same command to resume",
            file=sys.stderr,
        )
        raise
    finally:
        if bar is not None:
            bar.close()
    missing = int((results.surfaces["sph_status"] == "missing").sum())
    if missing and args.from_cache:
        raise SimulationError(f"{missing} simulation(s) missing from the cache: run without --from-cache")
    save_jet_validation_data(results, out)
    path = render_jet_validation(out)
    render_index(out)
    return results, path


def reproduce_stage(out: Path, quick: bool, command: str) -> tuple[Path | None, str]:
    """The study as a stage of ``replication reproduce``: reported from the SPH cache only, when
    it holds the study (``replication validate-jet [--quick]`` fills it; the full study is hours
    of SPH, and reproduce must not start that unasked).

    Returns the report's path, or None and why the stage was skipped.
    """
    from replication.casestudy.sph import INSTALL_HINT, engine_available
    from replication.casestudy.sph_batch import DEFAULT_CACHE_DIR
    from replication.errors import SimulationError
    from replication.experiments.jet_surface_set import set_path
    from replication.experiments.jet_validation import ValidationConfig

    if not engine_available():
        return None, f"the SPH solver is not installed ({INSTALL_HINT})"
    config = ValidationConfig.quick() if quick else ValidationConfig()
    if not set_path(DEFAULT_CACHE_DIR, config).is_file():
        flag = " --quick" if quick else ""
        return None, f"no study in {DEFAULT_CACHE_DIR}/: run `replication validate-jet{flag}` first (SPH)"
    args = argparse.Namespace(
        quick=quick, timeout=None, cache_dir=None, executor="serial", workers=1, scheduler=None,
        ga_run_dir=None, retry_failed=False, from_cache=True, rebuild_surfaces=False, invocation=command,
    )  # fmt: skip
    try:
        return run_validation_report(args, out)[1], ""
    except SimulationError as exc:
        return None, f"{exc} (run `replication validate-jet`)"


def _cmd_validate(args: argparse.Namespace) -> int:
    from replication.cli.reports import output_dir

    out = output_dir(args)
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
    print(f"wrote {path} ({time.perf_counter() - start:.1f} s; data in {out / 'data'})")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``validate-jet`` subcommand."""
    from replication.casestudy.evaluate import EXECUTORS
    from replication.cli.reports import DEFAULT_DIR, QUICK_DIR
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
    p.add_argument("--cache-dir", metavar="DIR", help="the SPH cache (default .sph-cache/)")
    p.add_argument(
        "--from-cache",
        action="store_true",
        help="simulate nothing: report from the cache, and fail if a simulation is missing",
    )
    p.add_argument("--retry-failed", action="store_true", help="simulate again the failed simulations")
    p.add_argument(
        "--ga-run-dir",
        metavar="DIR",
        help="score the winners of these GA runs (read, or run there) instead of the GA kept in the cache",
    )
    p.add_argument(
        "--rebuild-surfaces",
        action="store_true",
        help="build the surfaces afresh with this code instead of reading the set kept in the cache",
    )
    p.add_argument(
        "--workers", type=positive_int, default=2, help="simulations at a time (default 2; each uses a core)"
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
        metavar="DIR",
        help=f"where the report, figures and data go (default {DEFAULT_DIR}/, or {QUICK_DIR}/ with --quick)",
    )
    p.set_defaults(func=_cmd_validate)
