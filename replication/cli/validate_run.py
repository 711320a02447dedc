"""Running the validation study from the command line: progress, data, report (validate-jet, reproduce).

Kept apart from the command's parser (:mod:`.validate`) so that ``replication reproduce``
(:mod:`.reports`) can run it without the two importing each other.
"""

from __future__ import annotations

import argparse
import functools
import sys
from pathlib import Path
from typing import Any


def _config(args: argparse.Namespace) -> Any:
    import dataclasses

    from replication.experiments.jet_validation import ValidationConfig

    config = ValidationConfig.quick() if args.quick else ValidationConfig()
    if args.timeout is not None:
        config = dataclasses.replace(config, timeout=args.timeout)
    return config


def run_validation_report(args: argparse.Namespace, out: Path) -> tuple[Any, Path]:
    """Run the study as the arguments say (progress on stderr), save its data, render the report.

    The index (and a checkout's README headline) is the caller's to refresh.
    """
    from replication.casestudy.evaluate import executor
    from replication.casestudy.sph import require_engine
    from replication.casestudy.sph_batch import default_cache_dir
    from replication.cli.common import drawing_saved_data, saving_data, say_simulations_finish
    from replication.cli.progress import Progress
    from replication.errors import SimulationError
    from replication.experiments.jet_validation import run_validation
    from replication.report.jet_validation import render_jet_validation, save_jet_validation_data

    config = _config(args)
    cache = Path(args.cache_dir) if args.cache_dir else default_cache_dir()
    _check_cache(cache, config, args)
    require_engine()
    print(f"SPH cache: {cache} (a rerun skips every finished simulation)", file=sys.stderr)
    bar: Any = None

    def stage(label: str, n: int) -> None:
        nonlocal bar
        if bar is not None:
            bar.close()
        bar = Progress(n, label)

    def done(scored: Any) -> None:
        line = f"  {scored.name}: {scored.status}: {scored.reason}"
        if scored.status not in ("ok", "missing"):
            if bar is not None:
                bar.write(line)
            else:
                print(line, file=sys.stderr)
        if bar is not None:
            bar.update(1, last=f"{scored.name} {scored.status}{' (cached)' if scored.cached else ''}")

    ga_pool = functools.partial(executor, "serial")
    try:
        kind = "dask" if args.scheduler else args.executor
        serial = kind == "serial"  # one simulation at a time, driven from this process
        workers = None if serial else args.workers
        with executor(
            kind, workers=workers, scheduler=args.scheduler, on_interrupt=say_simulations_finish
        ) as pool:
            results = run_validation(
                config, cache_dir=cache, executor=pool, max_parallel=1 if serial else args.workers,
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
    status = results.surfaces["sph_status"]
    missing = int((status == "missing").sum())
    if missing and args.from_cache:
        raise SimulationError(f"{missing} simulation(s) missing from the cache: run without --from-cache")
    if not (status == "ok").any():  # a study of nothing must not replace a report
        counts = ", ".join(f"{n} {name}" for name, n in status.value_counts().items())
        raise SimulationError(
            f"no simulation succeeded ({counts}); nothing was written (see the reasons above; "
            "--retry-failed simulates the failed ones again)"
        )
    with saving_data(out):
        save_jet_validation_data(results, out)
    with drawing_saved_data(out, "jet_validation.md"):
        return results, render_jet_validation(out)


def _check_cache(cache: Path, config: Any, args: argparse.Namespace) -> None:
    """Refuse, before any work, a cache that is a file, (with --from-cache) that lacks the study,
    or (simulating into it) whose absolute path is not UTF-8: the SPH engine cannot be given it.

    Without its stored surface set, ``--from-cache`` would first run the study's GAs only to
    find every simulation missing.
    """
    from replication.errors import InputError, SimulationError
    from replication.experiments.jet_surface_set import set_path
    from replication.io.paths import check_utf8_path, check_writable_dir

    what = "--cache-dir" if args.cache_dir else "the SPH cache"
    if args.from_cache:
        if cache.exists() and not cache.is_dir():
            raise InputError(f"{what} {cache} is a file, not a directory")
        if not set_path(cache, config).is_file():  # (--rebuild-surfaces is refused with --from-cache)
            raise SimulationError(
                f"the study's surfaces and simulations are missing from the cache: run without "
                f"--from-cache (the cache {cache} holds no surface set of this study)"
            )
    else:  # the engine simulates into the cache
        check_writable_dir(cache, what)
        check_utf8_path(cache, what)


def reproduce_stage(out: Path, quick: bool, command: str) -> tuple[Path | None, str]:
    """The study as a stage of ``replication reproduce``: reported from the SPH cache only, when
    it holds the study (``replication validate-jet [--quick]`` fills it; the full study is hours
    of SPH, and reproduce must not start that unasked).

    The cache is ``$REPLICATION_SPH_CACHE`` or ``.sph-cache/``. Without it (a fresh clone) or
    without the engine, or when the cache lacks a simulation, the report is re-rendered from the
    study's data already in ``out/data`` (the committed CSV files), which are left as they are;
    with no such data either, the stage is skipped.

    Returns the report's path and a note on where it came from (empty: from the cache), or None
    and why the stage was skipped.
    """
    from replication.errors import SimulationError

    cache, why = _cache_why(quick)
    if not why:
        args = argparse.Namespace(
            quick=quick, timeout=None, cache_dir=str(cache), executor="serial", workers=1, scheduler=None,
            ga_run_dir=None, retry_failed=False, from_cache=True, rebuild_surfaces=False, invocation=command,
        )  # fmt: skip
        try:
            return run_validation_report(args, out)[1], ""
        except SimulationError as exc:
            why = f"{exc} (run `replication validate-jet`)"
    return _from_saved(out, why)


def _cache_why(quick: bool) -> tuple[Path, str]:
    """The SPH cache, and why the study cannot be reported from it ("" when it can)."""
    from replication.casestudy.sph import INSTALL_HINT, engine_available
    from replication.casestudy.sph_batch import CACHE_ENV, default_cache_dir
    from replication.experiments.jet_surface_set import set_path
    from replication.experiments.jet_validation import ValidationConfig

    cache = default_cache_dir()
    config = ValidationConfig.quick() if quick else ValidationConfig()
    if not engine_available():
        return cache, f"the SPH solver is not installed ({INSTALL_HINT})"
    if not set_path(cache, config).is_file():
        flag = " --quick" if quick else ""
        return cache, (
            f"no study in the SPH cache {cache}/: run `replication validate-jet{flag}` first (SPH), "
            f"or set {CACHE_ENV} to the directory of a filled cache"
        )
    return cache, ""


def reproduce_draws(out: Path, quick: bool) -> bool:
    """Whether :func:`reproduce_stage` may draw the report into ``out`` (it skips the stage
    otherwise), decided before any work so that only a page it may draw is checked."""
    from replication.report.jet_validation import saved_study

    return reproduce_runs(quick) or saved_study(out)


def reproduce_runs(quick: bool) -> bool:
    """Whether :func:`reproduce_stage` will run the study from the SPH cache (and so save its
    data), not only draw the saved data again."""
    return not _cache_why(quick)[1]


def _from_saved(out: Path, why: str) -> tuple[Path | None, str]:
    """Re-render the report from the study's data in ``out/data``, or None when there is none."""
    from replication.report.jet_validation import render_jet_validation, saved_study

    if not saved_study(out):
        return None, why
    return render_jet_validation(out), f"re-rendered from the saved data in {out / 'data'} ({why})"
