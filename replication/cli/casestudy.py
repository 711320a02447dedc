"""``replication casestudy``: the water-jet GA (paper section 6) and its report (Figs. 8, 9).

Everything that can be checked is checked before the GA starts: the executor options, the
run directory (writable, and on ``--resume`` its ``config.json`` and checkpoints valid), and
the reports directory. ``--resume`` takes the run's settings from its ``config.json``; only
settings given explicitly are compared with them. Where the report goes: ``--output-dir``
when given; else ``reports/`` for the paper's settings, ``reports-quick/`` for the
``--quick`` settings, and the run's own directory (``RUN_DIR/report/``) for any other
settings or an SPH fitness (``--rescore sph``, ``--solver sph``), so that a trial run never
overwrites the committed paper report; such a run is refused before any work when
``--output-dir`` names a checkout's ``reports/`` (:func:`replication.cli.outputs.check_not_committed`).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import functools
import os
import shlex
import sys
import time
from pathlib import Path
from typing import Any

from replication.cli.casestudy_sph import (
    FITNESS_NAME,
    RESCORE_NAME,
    RescoreProgress,
    add_rescore_options,
    check_fitness_record,
    check_rescored,
    rescore_config,
    rescore_hint,
    rescore_summary,
    restore_rescore,
    solver_record,
    sph_fitness,
    write_fitness_record,
    write_rescore_record,
)
from replication.cli.common import (
    directory_name,
    drawing_saved_data,
    emit_json,
    positive_int,
    saving_data,
    say_simulations_finish,
    seed,
    worker_count,
)
from replication.cli.outputs import (
    DEFAULT_DIR,
    QUICK_DIR,
    check_not_committed,
    check_replaces_alike,
    check_subdirs_stay_out,
    finish_reports,
    missing_dirs,
    remove_unused_run_dir,
)
from replication.cli.progress import Progress
from replication.io.atomic import written_before

EPILOG = f"""\
examples:
  replication casestudy                       the paper's GA: 3 runs x 50 generations x 48
  replication casestudy --quick               a reduced GA (smoke test) into {QUICK_DIR}/
  replication casestudy --workers 2           evaluate on a local process pool of 2 workers
  replication casestudy --executor dask --workers 4          a local dask cluster
  replication casestudy --scheduler tcp://host:8786          an existing dask cluster
  replication casestudy --run-dir casestudy-runs/run-X --resume   continue an interrupted run
  replication casestudy --rescore sph --top 5 --particle-radius 1   the GA's winners judged by SPH

Every generation is checkpointed (JSON) in the run directory, printed at the start; after a
crash or Ctrl-C (exit status 130), --resume with the same --run-dir continues where the run
stopped, with the settings recorded in the run directory, and ends exactly as an
uninterrupted run would. Settings given together with --resume must match the recorded ones
(except --sph-timeout: a longer limit simulates again what timed out under the shorter).

The report goes to {DEFAULT_DIR}/ only for the paper's settings ({QUICK_DIR}/ with --quick); a run
with other settings, or with --rescore sph or --solver sph, reports into its run directory
(RUN_DIR/report/), unless --output-dir names a directory; a checkout's committed {DEFAULT_DIR}/
is refused for them, since it holds the paper's results and the README's headline numbers.

--rescore sph simulates the best distinct surfaces of each run, the flat plate and the bucket
by SPH (the fitness of record: the thin-sheet model ranks cup-like surfaces unlike SPH) on the
same executor, and the report ranks them by SPH with a cost table. Before the first simulation
it says how many are to be simulated (the rest come from the cache), and after each one the
time left at the rate measured so far. Every simulation is cached by content (--cache-dir):
after Ctrl-C, the resume command reuses every finished simulation. A re-scoring that judged
none of the GA's surfaces (every simulation of them failed) exits with status 1, after its
report.
"""

SETTINGS = ("runs", "generations", "population", "seed")


@dataclasses.dataclass(frozen=True)
class Plan:
    """What a case-study command will do, decided and checked before any work."""

    config: Any  # GAConfig
    run_dir: Path
    resume: bool
    out: Path
    hint: str  # the command that resumes this run
    note: str  # why the report goes where it goes ("" for the paper's or an explicit directory)
    created: tuple[Path, ...]  # directories the command will create for the run (removed on failure)
    quick: bool = False  # the --quick settings (also when resumed without --quick)
    done_generations: int = 0
    rescore: Any = None  # RescoreConfig of --rescore sph (issue 11)
    solver: Any = None  # the GA's fitness when it is SPH (fitness.json), else None
    sph: Any = None  # RescoreConfig of the SPH settings (either use)


def _requested_config(args: argparse.Namespace) -> Any:
    from replication.casestudy.ga import GAConfig
    from replication.experiments.casestudy import quick_ga_config

    base = quick_ga_config() if args.quick else GAConfig()
    changes = {k: getattr(args, k) for k in SETTINGS if getattr(args, k) is not None}
    return dataclasses.replace(base, **changes) if changes else base


def _new_run_dir() -> Path:
    """``casestudy-runs/run-<time>-<process id>``: the process id keeps the names of two commands
    started in the same second apart (with the time alone, both chose one name and the second
    was refused by the first's lock)."""
    stamp = f"{dt.datetime.now().strftime('%Y%m%d-%H%M%S')}-{os.getpid()}"
    run_dir = Path("casestudy-runs") / f"run-{stamp}"
    k = 2
    while run_dir.exists():
        run_dir = Path("casestudy-runs") / f"run-{stamp}-{k}"
        k += 1
    return run_dir


def _default_report_dir(config: Any, run_dir: Path) -> tuple[Path, str]:
    from replication.casestudy.ga import GAConfig
    from replication.experiments.casestudy import differences_from_paper, quick_ga_config

    if config == GAConfig():
        return Path(DEFAULT_DIR), ""
    if config == quick_ga_config():
        return Path(QUICK_DIR), ""
    differ = "; ".join(differences_from_paper(config.as_dict()))
    # (settings that differ from the quick ones too: the report is neither reports/'s nor reports-quick/'s)
    return run_dir / "report", (
        f"settings differ from the paper's ({differ}): the report goes to {run_dir / 'report'}/, "
        f"not {DEFAULT_DIR}/ or {QUICK_DIR}/ (name a directory with --output-dir)"
    )


def _custom_settings(config: Any, quick: bool, sph_option: str | None) -> list[str]:
    """What makes a run's report another than the committed paper report, in words: the option
    ``--quick`` when it was given, else the settings that differ from the paper's."""
    from replication.experiments.casestudy import differences_from_paper

    custom = ["--quick"] if quick else differences_from_paper(config.as_dict())
    return [*custom, *([sph_option] if sph_option else [])]


def _resume_config(args: argparse.Namespace, run_dir: Path) -> Any:
    from replication.casestudy.rundir import CONFIG_NAME, read_config
    from replication.errors import InputError, OutputError

    if run_dir.exists() and not run_dir.is_dir():
        raise OutputError(f"--run-dir {run_dir} is a file, not a run directory")
    recorded = read_config(run_dir) if run_dir.is_dir() else None
    if recorded is None:
        raise InputError(f"nothing to resume: {run_dir} holds no GA run (no {CONFIG_NAME})")
    wanted = _requested_config(args)
    given = [k for k in SETTINGS if getattr(args, k) is not None]
    if args.quick:  # --quick stands for every setting of the quick configuration
        given = list(SETTINGS)
    differ = [
        f"--{k} {getattr(wanted, k)} (the run has {getattr(recorded, k)})"
        for k in given
        if getattr(wanted, k) != getattr(recorded, k)
    ]
    if differ or (args.quick and wanted != recorded):
        what = ", ".join(differ) if differ else "--quick (the run was not a quick run)"
        raise InputError(
            f"{run_dir} holds a run with other settings: {what}; resume without these options to continue "
            "it with its recorded settings, or start a new run directory"
        )
    return recorded


def plan_casestudy(args: argparse.Namespace) -> Plan:
    """Decide and check the run directory, the settings and the reports directory."""
    from replication.casestudy.checkpoints import load_run
    from replication.casestudy.evaluate import check_executor_options
    from replication.casestudy.rundir import CONFIG_NAME, checkpoints, foreign_entries, read_config
    from replication.errors import InputError, UsageError
    from replication.io.paths import REPORT_SUBDIRS, check_report_dir, check_writable_dir, lookup
    from replication.report.pages import check_pages, report_page_in

    check_executor_options(args.executor, args.workers, args.scheduler)
    if args.scheduler is not None:  # before the run directory and its resume command
        from replication.casestudy.cluster import check_scheduler_reachable

        check_scheduler_reachable(args.scheduler)
    if args.resume and args.run_dir:  # the run's own --rescore options, before they are checked
        restore_rescore(args, Path(args.run_dir))
    rescore = rescore_config(args, _requested_config(args))
    if args.resume:
        if not args.run_dir:
            raise UsageError("--resume continues the runs in --run-dir DIR: name the directory to resume")
        run_dir = Path(args.run_dir)
        config = _resume_config(args, run_dir)
    else:
        config = _requested_config(args)
        run_dir = Path(args.run_dir) if args.run_dir else _new_run_dir()
        if lookup(run_dir, InputError, "--run-dir").is_dir:
            page = report_page_in(run_dir)
            if page is not None:
                raise InputError(
                    f"--run-dir {run_dir} is a reports directory (it holds {page.name}): the GA's "
                    "checkpoints go into a directory of their own"
                )
            found = checkpoints(run_dir)
            if found:
                raise InputError(
                    f"{run_dir} holds GA checkpoints ({found[0].name}): pass --resume to continue them, "
                    "or use a new run directory"
                )
            recorded = read_config(run_dir)
            if recorded is not None and recorded != config:
                raise InputError(
                    f"{run_dir} holds a run with other settings: resume it with --resume, or use a new run "
                    "directory"
                )
            others = foreign_entries(run_dir, own=(FITNESS_NAME, RESCORE_NAME, "report"))
            if others:  # as force --run-dir: the run's files do not go among a user's own
                shown = ", ".join(others[:3]) + (", ..." if len(others) > 3 else "")
                raise InputError(
                    f"--run-dir {run_dir} holds files that are not a GA run's ({shown}): the GA writes "
                    f"{CONFIG_NAME}, run-<k>.json and its report there; use a new or empty directory"
                )
    check_writable_dir(run_dir, "--run-dir" if args.run_dir else "the GA run directory")
    solver = solver_record(args, rescore)
    check_fitness_record(run_dir, solver, args.resume)
    done = 0
    if run_dir.is_dir():  # validate every checkpoint now, not after minutes of computing
        for k in range(config.runs):
            state = load_run(run_dir, k, config)
            done += 0 if state is None else state.generation
    default_out, note = _default_report_dir(config, run_dir)
    rescored = getattr(args, "rescore", None) is not None
    sph_option = "--solver sph" if solver is not None else "--rescore sph" if rescored else None
    if sph_option and not note:  # the committed reports are the thin-sheet GA's, not re-scored
        # the directory the settings alone would choose: reports/, or reports-quick/ for --quick
        default_out, instead = run_dir / "report", default_out
        note = (
            f"{sph_option}: the report goes to {default_out}/, not {instead}/ (name a directory with "
            "--output-dir)"
        )
    out = Path(args.output_dir) if args.output_dir else default_out
    if args.output_dir and default_out != Path(DEFAULT_DIR):
        check_not_committed(out, _custom_settings(config, bool(args.quick), sph_option))
    what = "--output-dir" if args.output_dir else "the reports directory"
    check_subdirs_stay_out(out, what, REPORT_SUBDIRS)
    check_report_dir(out, what)
    check_pages(out, what, ("casestudy.md", "index.md"))
    from replication.experiments.casestudy import differences_from_paper, quick_ga_config
    from replication.io.locks import hold_reports_dir
    from replication.report.settings import sph_option as sph_words
    from replication.report.store import dashless

    hold_reports_dir(out, what)  # (two runs into one directory left one's page over the other's data)
    # the run's settings as its provenance will record them (a saved case study of others stays)
    settings = ["--quick"] if config == quick_ga_config() else differences_from_paper(config.as_dict())
    if solver is not None:
        settings.append(sph_words("--solver sph", solver["settings"]))
    elif rescored:
        settings.append(sph_words("--rescore sph", rescore.settings.as_dict(), rescore.top))
    check_replaces_alike(out, what, settings, ["casestudy"])

    # (a directory named like an option, -e, is written ./-e: argparse would read -e as one)
    hint = ["replication", "casestudy", "--run-dir", dashless(run_dir), "--resume"]
    if out.resolve() != default_out.resolve():
        hint += ["--output-dir", dashless(out)]
    # where the fitness is evaluated is not a setting of the run, but the report times it:
    # a resume on other workers would report another evaluation cost
    if getattr(args, "executor", "auto") != "auto":
        hint += ["--executor", args.executor]
    if getattr(args, "workers", None) is not None:
        hint += ["--workers", str(args.workers)]
    if getattr(args, "scheduler", None) is not None:
        hint += ["--scheduler", args.scheduler]
    hint += rescore_hint(args)
    return Plan(
        config=config, run_dir=run_dir, resume=args.resume, out=out, hint=shlex.join(hint),
        note="" if args.output_dir else note, created=missing_dirs(run_dir),
        quick=config == quick_ga_config(), done_generations=done,
        rescore=rescore if getattr(args, "rescore", None) else None, solver=solver, sph=rescore,
    )  # fmt: skip


def run_and_report(plan: Plan, args: argparse.Namespace) -> tuple[Any, Path]:
    """Run the case study as planned; save its data and render the report into ``plan.out``."""
    from replication.casestudy.evaluate import executor
    from replication.casestudy.rundir import hold, write_config
    from replication.experiments.casestudy import run_casestudy

    config = plan.config
    on_interrupt = say_simulations_finish if plan.sph is not None else None  # SPH takes minutes
    pool = functools.partial(
        executor, args.executor, workers=args.workers, scheduler=args.scheduler, on_interrupt=on_interrupt
    )
    fitness = sph_fitness(plan, args, workers=_estimate_workers(plan, args))
    # a second command on this directory is refused here, outside the try: its refusal removes nothing
    with hold(plan.run_dir):
        try:
            # the configuration first, then the hint: a command killed right after printing it
            # left no config.json, and the printed --resume answered "nothing to resume"
            write_config(plan.run_dir, config)
            action = "resuming" if plan.resume else "after an interruption, resume with"
            print(f"GA run directory: {plan.run_dir} ({action}: {plan.hint})", file=sys.stderr)
            write_fitness_record(plan.run_dir, plan.solver)
            write_rescore_record(plan.run_dir, args, plan.rescore)
            with Progress(
                config.runs * config.generations, "GA generations", initial=plan.done_generations
            ) as bar:

                def tick(state: Any) -> None:
                    bar.update(1, run=state.run, best=f"{state.history[-1]['best_so_far']:.3f} N")

                rescored = RescoreProgress()
                results = run_casestudy(
                    config, run_dir=plan.run_dir, pool_factory=pool, resume=plan.resume, on_generation=tick,
                    command=args.invocation, quick=plan.quick,
                    rescore=plan.rescore, on_rescored=rescored, fitness=fitness, solver=plan.solver,
                    on_rescore_plan=rescored.plan,
                )  # fmt: skip
        except KeyboardInterrupt:
            from replication.casestudy.rundir import CONFIG_NAME

            if (plan.run_dir / CONFIG_NAME).is_file():
                saved = f"every completed generation is saved in {plan.run_dir}; resume with: {plan.hint}"
            else:
                saved = "the GA had not started: nothing to resume"
                remove_unused_run_dir(plan.run_dir, plan.created)
            print(f"interrupted: {saved}", file=sys.stderr)
            raise
        except BaseException:
            remove_unused_run_dir(plan.run_dir, plan.created)
            raise
    try:
        # imported once the GA is done (matplotlib: 0.2 s): the GA starts sooner, and a run
        # stopped by Ctrl-C never pays for it
        from replication.report.casestudy import render_casestudy, save_casestudy_data

        with saving_data(plan.out):
            save_casestudy_data(results, plan.out)
    except KeyboardInterrupt as exc:
        if not written_before(exc):  # (else saving_data said that they are saved)
            print(f"interrupted while saving the data: every run is complete in {plan.run_dir} and the "
                  f"previous data in {plan.out / 'data'} are as they were; save them with: {plan.hint}",
                  file=sys.stderr)  # fmt: skip
        raise
    with drawing_saved_data(plan.out, "casestudy.md"):
        return results, render_casestudy(plan.out, workers=_workers(args))


def _workers(args: argparse.Namespace) -> int:
    """The local workers (a named cluster: 1, unknown): evaluations at once for the cost
    estimate, and processes drawing the report's figures."""
    from replication.cpus import usable_cpus

    if args.executor == "serial" or (args.scheduler and not args.workers):
        return 1
    return args.workers or usable_cpus()


def _estimate_workers(plan: Any, args: argparse.Namespace) -> int:
    """The simulations at once of the ``--solver sph`` cost estimate: a named cluster's threads
    as it stands (without ``--workers``, :func:`_workers` cannot know them and said 1, which
    multiplied the estimate by the cluster's size and could ask for ``--yes`` for nothing)."""
    if plan.solver is not None and args.scheduler and not args.workers:
        from replication.casestudy.cluster import cluster_threads

        return cluster_threads(args.scheduler)
    return _workers(args)


def _cmd_casestudy(args: argparse.Namespace) -> int:
    plan = plan_casestudy(args)
    if plan.note:
        print(plan.note, file=sys.stderr)
    start = time.perf_counter()
    results, path = run_and_report(plan, args)
    finish_reports(plan.out)
    history = results.history
    if args.json:
        emit_json({
            "runs": results.runs[["run", "best_N", "evaluations", "cache_hits", "failures"]].to_dict(
                "records"
            ),
            "best_so_far_N": {int(k): g["best_so_far"].tolist() for k, g in history.groupby("run")},
            "evaluations": int(results.runs["evaluations"].sum()),
            "saved_by_cache": int(results.runs["cache_hits"].sum()),
            "failures": int(results.runs["failures"].sum()),
            "reference_shapes_N": dict(zip(results.shapes["shape"], results.shapes["axial_N"])),
            "run_dir": str(plan.run_dir), "report": str(path), "seconds": time.perf_counter() - start,
            **({} if results.rescore is None else {"rescore": results.rescore.to_dict("records")}),
        })  # fmt: skip
    else:
        for _, r in results.runs.iterrows():
            print(f"run {r['run']}: best force {r['best_N']:.4f} N after {r['evaluations']} evaluations "
                  f"({r['cache_hits']} saved by the cache, {r['failures']} failed)")  # fmt: skip
        for line in rescore_summary(results):
            print(line)
        print(f"wrote {path} ({time.perf_counter() - start:.1f} s; GA checkpoints in {plan.run_dir})")
    check_rescored(results, path)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the casestudy subcommand."""
    from replication.casestudy.evaluate import EXECUTORS

    p = sub.add_parser(
        "casestudy",
        help=f"the water-jet genetic algorithm (section 6) into {DEFAULT_DIR}/casestudy.md (Figs. 8, 9)",
        description=(
            "Run the paper's genetic algorithm, which shapes a 101-point ADT surface to maximise the "
            "force of a water jet (scored by a validated thin-sheet momentum model), and write "
            f"{DEFAULT_DIR}/casestudy.md with Figs. 8 and 9 (other settings: RUN_DIR/report/)."
        ),
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--quick", action="store_true", help=f"a reduced GA (smoke test) into {QUICK_DIR}/")
    p.add_argument("--runs", type=positive_int, help="independent runs (default 3)")
    p.add_argument(
        "--generations", type=positive_int, help="generations per run, the initial one included (50)"
    )
    p.add_argument("--population", type=positive_int, help="individuals per generation (default 48)")
    p.add_argument("--seed", type=seed, help="base seed; run k uses [seed, k] (default 2019)")
    p.add_argument(
        "--run-dir",
        type=directory_name,
        metavar="DIR",
        help="checkpoint directory, new or empty (default: casestudy-runs/run-<time>-<process id>)",
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue the runs checkpointed in --run-dir, with the settings recorded there",
    )
    p.add_argument(
        "--executor",
        choices=EXECUTORS,
        default="auto",
        help="where fitness is evaluated (default auto: a dask cluster at --scheduler if given, "
        "else a process pool when more than one worker is asked for or available, else serial)",
    )
    p.add_argument("--workers", type=worker_count, help="process-pool or local dask workers (default: CPUs)")
    p.add_argument(
        "--scheduler", metavar="ADDRESS", help="address of a running dask scheduler (implies dask)"
    )
    p.add_argument(
        "--output-dir",
        type=directory_name,
        metavar="DIR",
        help=f"reports directory (default: {DEFAULT_DIR}/ for the paper's settings, {QUICK_DIR}/ for "
        "--quick, else, or with --rescore sph or --solver sph, RUN_DIR/report/)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object with the results")
    add_rescore_options(p)
    p.set_defaults(func=_cmd_casestudy)
