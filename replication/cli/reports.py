"""``replication table1``, ``replication report`` and ``replication reproduce``."""

from __future__ import annotations

import argparse
import functools
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from replication.cli.casestudy import plan_casestudy, run_and_report
from replication.cli.common import (
    directory_name,
    drawing_saved_data,
    file_name,
    positive_int,
    saving_data,
    worker_count,
)
from replication.cli.outputs import (
    DEFAULT_DIR,
    QUICK_DIR,
    TABLE1_SUBDIRS,
    check_not_committed,
    check_subdirs_stay_out,
    checkout_readme,
    finish_reports,
    planned_output_dir,
)
from replication.cli.progress import progress_bar
from replication.cpus import usable_cpus
from replication.kernels import release_threads, warm_up
from replication.report.pages import PAGE_TITLES

#: asv's results directory in a checkout (``results_dir`` of asv.conf.json).
DEFAULT_ASV_RESULTS = ".asv/results"
#: How many recent commits each benchmark's history on the committed performance.md shows
#: (``report --commits``).
DEFAULT_COMMITS = 5
#: The markdown files ``replication report`` may write.
RENDERED = tuple(PAGE_TITLES)


def _run_table1(out: Path, quick: bool, command: str, workers: int | None = None) -> Path:
    from replication.experiments.table1 import Table1Config, run_table1
    from replication.report.table1 import render_table1, save_table1_data

    config = Table1Config.quick_config() if quick else Table1Config()
    workers = workers or usable_cpus()
    results = run_table1(config, progress=progress_bar, command=command, workers=workers)
    with saving_data(out):  # minutes of experiment: a Ctrl-C says where they are saved
        save_table1_data(results, out)
    with drawing_saved_data(out, "table1.md"):
        return render_table1(out, workers=workers)


def _said(written: list[Path], out: Path) -> None:
    """Print what :func:`finish_reports` wrote besides the index (the README headline block)."""
    for path in written[1:]:
        print(f"refreshed the headline block of {path} from {out}/data (the reports beside it)")


def _cmd_table1(args: argparse.Namespace) -> int:
    out = planned_output_dir(args, ("table1.md", "index.md"), TABLE1_SUBDIRS, replaces=("table1",))
    start = time.perf_counter()
    path = _run_table1(out, args.quick, args.invocation, args.workers)
    written = finish_reports(out)
    print(f"wrote {path} ({time.perf_counter() - start:.1f} s; data in {out / 'data'})")
    _said(written, out)
    return 0


def _render(render: Callable[[Path], Any], name: str, out: Path) -> Any:
    """Render one report; data that do not fit the renderer become one clear line."""
    from replication.errors import ReplicationError, ReportDataError

    try:
        return render(out)
    except ReplicationError:
        raise
    except (KeyError, ValueError, TypeError, IndexError, AttributeError) as exc:
        raise ReportDataError(
            f"the {name} data under {out / 'data'} are incomplete or inconsistent ({type(exc).__name__}: "
            f"{exc}); regenerate them with `{_again(name, out)}`"
        ) from exc


def _again(name: str, out: Path) -> str:
    """The command that makes the ``name`` data of ``out`` again: the one their provenance
    records (its settings kept), else the command of that name, into ``out``."""
    from replication.report.settings import saved_record
    from replication.report.store import run_again

    prefix = dict((command, experiment) for experiment, command in EXPERIMENTS).get(name)
    record = saved_record(out / "data", prefix) if prefix is not None else None  # None: unreadable
    return run_again(record, f"replication {name}", out)


#: Each experiment's data: the prefix of its files, and the command that makes them.
EXPERIMENTS = (
    ("table1", "table1"),
    ("sph", "sph"),
    ("jet_validation", "validate-jet"),
    ("casestudy", "casestudy"),
)


def _without_provenance(data: Path) -> list[tuple[str, str]]:
    """The experiments whose tables lie in ``data`` without their provenance (see ``store.data_set``)."""
    return [
        (prefix, command)
        for prefix, command in EXPERIMENTS
        if not (data / f"{prefix}_provenance.json").is_file() and any(data.glob(f"{prefix}_*.csv"))
    ]


def _all_quick(data: Path) -> bool:
    """Whether the data sets in ``data`` that record their settings all record a quick run: the
    tables of one without them are then a quick run's too, and made again with ``--quick``."""
    from replication.report.settings import QUICK, saved_settings

    found = [saved_settings(data, prefix) for prefix, _ in EXPERIMENTS]
    known = [settings for settings in found if settings is not None]
    return bool(known) and all(settings[: len(QUICK)] == QUICK for settings in known)


def _check_readme(readme: str, out: Path) -> Path:
    from replication.errors import InputError
    from replication.io.paths import check_distinct
    from replication.report.index import END, START

    path = Path(readme)
    from replication.io.atomic import open_descriptor

    if open_descriptor(path) is not None:  # /dev/stdout >> copy.md: the rename replaced copy.md
        raise InputError(f"--readme {path} names an open file descriptor, not a README file")
    if not path.exists():
        raise InputError(f"--readme {path}: no such file")
    if not path.is_file():
        kind = "a directory" if path.is_dir() else "a device, FIFO or socket"
        raise InputError(f"--readme {path} is {kind}, not a README file")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"--readme {path}: cannot read it as UTF-8 text ({exc})") from exc
    if START not in text or END not in text:
        raise InputError(f"--readme {path} has no {START} ... {END} block to fill")
    if text.index(END) < text.index(START):
        raise InputError(
            f"--readme {path}: its {END} marker comes before {START}, so there is no block to fill"
        )
    _check_not_checkout_readme(path, out)
    data = sorted((out / "data").glob("*")) if (out / "data").is_dir() else []
    check_distinct(
        [("--readme", path), *((f"the report {name}", out / name) for name in RENDERED)],
        [("report data", p) for p in data],
    )
    return path


def _check_not_checkout_readme(readme: Path, out: Path) -> None:
    """Refuse ``--readme`` naming a checkout's README while ``out`` is not that checkout's reports.

    A checkout's README states the numbers of the committed ``reports/`` beside it
    (:func:`replication.cli.outputs.finish_reports`; ``tests/test_readme.py`` checks it):
    ``report --output-dir reports-quick --readme README.md`` wrote a quick run's numbers there.
    """
    from replication.errors import UsageError
    from replication.io.paths import same_file

    target = readme.resolve()  # a link's target is what is written (fill_block)
    beside = checkout_readme(target.parent / DEFAULT_DIR)
    if beside is None or not same_file(beside, target):
        return
    ours = checkout_readme(out)
    if ours is not None and same_file(ours, readme):
        return
    raise UsageError(
        f"--readme {readme} is a checkout's README, whose headline states the numbers of its committed "
        f"{readme.parent / DEFAULT_DIR}/, not those of {out}: name a copy of it"
    )


def _fill_speed_block(readme: Path | None, out: Path) -> list[Path]:
    """The README's speed block from the asv archive: ``--readme``, or a checkout's README."""
    from replication.report.index import fill_block, has_block
    from replication.report.performance import speed_table
    from replication.report.speed_goals import END, START

    target = readme if readme is not None else checkout_readme(out)
    if target is None or not has_block(target, START, END):
        return []
    return [fill_block(target, START, END, speed_table(out))]


def _cmd_report(args: argparse.Namespace) -> int:
    from replication.errors import ReportDataError, UsageError
    from replication.io.paths import check_report_dir, lookup, same_file
    from replication.report.casestudy import render_casestudy
    from replication.report.index import update_readme
    from replication.report.pages import check_pages
    from replication.report.store import recover_data_sets, rerun_into
    from replication.report.table1 import render_table1

    out = Path(args.output_dir or DEFAULT_DIR)
    first = rerun_into("replication reproduce", out) if args.output_dir else "replication reproduce"
    commits = DEFAULT_COMMITS if args.commits is None else args.commits
    if args.commits is not None and not args.performance:
        raise UsageError(f"--commits {args.commits} applies to performance.md only: add --performance")
    found = lookup(out, ReportDataError, "reports directory")
    if not found.is_dir:  # first: the refusal below speaks of the committed page as of a file that exists
        what = "is a file" if found.exists else "does not exist"
        raise ReportDataError(f"reports directory {out} {what}: run `{first}` first")
    if commits != DEFAULT_COMMITS and args.output_dir:
        check_not_committed(out, [f"--commits {commits}"])
    if commits != DEFAULT_COMMITS and not args.output_dir:  # reports/ is written with its settings only
        raise UsageError(
            f"--commits {commits} would redraw the committed {out / 'performance.md'}, which shows "
            f"{DEFAULT_COMMITS} commits per benchmark: copy {out}/ and name the copy with --output-dir "
            "to draw it there"
        )
    results = None  # asv's default directory may be absent or empty (a fresh checkout): the archive alone
    if args.performance:
        results = args.asv_results or DEFAULT_ASV_RESULTS
        described = Path(results) / "benchmarks.json"
        if args.asv_results is None and not lookup(described, ReportDataError, "--asv-results").exists:
            results = None
    # data/ is only read here (it may be on a read-only share), except where --performance merges
    # asv's results into its archive there; figures/ is written
    written_dirs = ("figures", "data") if results is not None else ("figures",)
    what = "--output-dir" if args.output_dir else "the reports directory"
    check_subdirs_stay_out(out, what, ("figures", "data"))  # figures drawn, data read: one set
    check_report_dir(out, what, written_dirs)
    from replication.io.locks import hold_reports_dir

    hold_reports_dir(out, what)
    if (out / "data").is_dir():  # a save killed while it published its data set: finish it first
        recover_data_sets(out / "data")
    readme = _check_readme(args.readme, out) if args.readme else None
    check_pages(out, what, _pages_drawn(out, performance=args.performance))
    _check_data_sets(out)  # every data set before any page: a bad one leaves every file as it was
    # what the files were, to say which stayed as they were
    before = _contents([*(out / name for name in RENDERED), *filter(None, (readme, checkout_readme(out)))])
    written = []
    if args.performance:
        from replication.report.performance import render_performance

        written.append(render_performance(results, out, commits=commits))
        written += _fill_speed_block(readme, out)
    if (out / "data" / "table1_provenance.json").is_file():
        written.append(_render(render_table1, "table1", out))
    if (out / "data" / "sph_provenance.json").is_file():
        from replication.report.sph import render_sph

        written.append(_render(render_sph, "sph", out))
    if (out / "data" / "jet_validation_provenance.json").is_file():  # issue 11: the validation study
        from replication.report.jet_validation import render_jet_validation

        written.append(_render(render_jet_validation, "validate-jet", out))
    if (out / "data" / "casestudy_provenance.json").is_file():
        written.append(_render(render_casestudy, "casestudy", out))
    quick = " --quick" if _all_quick(out / "data") else ""  # (a reports-quick/ named the paper's run)
    orphans = [(experiment, rerun_into(f"replication {command}{quick}", out))
               for experiment, command in _without_provenance(out / "data")]  # fmt: skip
    why = "a save that was cut short, or the file was removed"
    if not written and orphans:  # one line, not a warning beside "run reproduce first"
        raise ReportDataError(
            f"no report drawn: {out / 'data'} holds {' and '.join(e for e, _ in orphans)} tables without "
            f"their provenance ({why}); run " + " and ".join(f"`{again}`" for _, again in orphans) + " again"
        )
    for experiment, again in orphans:
        print(
            f"warning: {out / 'data'} holds {experiment} tables without their provenance ({why}), so no "
            f"{experiment} report was drawn from them: run `{again}` again",
            file=sys.stderr,
        )
    if not written:
        raise ReportDataError(f"no report data under {out / 'data'}: run `{first}` first")
    finished = _render(finish_reports, "reproduce", out)  # the index, and a checkout's README
    written += finished
    if readme is not None and not any(same_file(readme, path) for path in finished):
        written.append(update_readme(readme, out))
    for path in dict.fromkeys(written):  # a README filled twice (headline, speed) is named once
        kept = before.get(Path(path).resolve()) == _contents([path]).get(Path(path).resolve())
        print(f"unchanged {path}" if kept else f"wrote {path}")
    return 0


#: The loader of each experiment's data (:data:`EXPERIMENTS`' prefixes), imported when used.
_LOADERS = {
    "table1": "replication.report.table1:load_table1_data",
    "sph": "replication.report.sph:load_sph_data",
    "jet_validation": "replication.report.jet_validation:load_jet_validation_data",
    "casestudy": "replication.report.casestudy:load_casestudy_data",
}


def _check_data_sets(out: Path) -> None:
    """Load every data set ``report`` will draw from, with the checks its renderer makes.

    The reports were drawn one after another, each from its own data: a case-study file
    edited after its save was refused only once table1.md, sph.md and their figures had been
    drawn again (seconds), and the command ended with exit 1 beside pages it had rewritten.
    Loading costs about 0.1 s for the committed data; the renderers load them again.
    """
    import importlib

    for prefix, command in EXPERIMENTS:
        if (out / "data" / f"{prefix}_provenance.json").is_file():
            module, function = _LOADERS[prefix].split(":")
            _render(getattr(importlib.import_module(module), function), command, out)


def _pages_drawn(out: Path, *, performance: bool) -> list[str]:
    """The pages ``replication report`` draws in ``out``: those whose data are there, the index,
    and performance.md with ``--performance``."""
    data = out / "data"
    drawn = [f"{prefix}.md" for prefix, _ in EXPERIMENTS if (data / f"{prefix}_provenance.json").is_file()]
    return [*drawn, "index.md", *(["performance.md"] if performance else [])]


def _contents(paths: list[Path]) -> dict[Path, bytes]:
    """The bytes of those of ``paths`` that are files, by resolved path."""
    found = {}
    for path in paths:
        try:
            found[Path(path).resolve()] = Path(path).read_bytes()
        except OSError:
            continue
    return found


STAGES = (
    ("table1", "Table 1 and Fig. 6: file size, computation time and paired statistics, ADT vs NURBS"),
    ("sph", "the case study on a real SPH solver (SPlisHSPlasH; runs when the extra sph is installed)"),
    (
        "jet validation",
        "the thin-sheet model checked against SPH (from the SPH cache; validate-jet fills it)",
    ),
    ("casestudy", "Figs. 8 and 9: the water-jet genetic algorithm"),
)


def _reproduce_pages(out: Path, *, quick: bool) -> tuple[str, ...]:
    """The pages ``reproduce`` may draw into ``out``: not those of a stage it will skip, so
    that a file of that name there (somebody else's) is not refused for nothing."""
    from replication.casestudy.sph import engine_available
    from replication.cli.validate_run import reproduce_draws

    skipped = set()
    if not engine_available():
        skipped.add("sph.md")
    if not reproduce_draws(out, quick):
        skipped.add("jet_validation.md")
    return tuple(p for p in RENDERED if p != "performance.md" and p not in skipped)


def _reproduce_replaces(out: Path, *, quick: bool) -> tuple[str, ...]:
    """The data sets ``reproduce`` may save into ``out`` (the case study's is checked with its
    plan): Table 1's, the SPH study's when the engine is installed, and the validation study's
    when the SPH cache holds it (else its saved data are only drawn again)."""
    from replication.casestudy.sph import engine_available
    from replication.cli.validate_run import reproduce_runs

    return ("table1", *(("sph",) if engine_available() else ()),
            *(("jet_validation",) if reproduce_runs(quick) else ()))  # fmt: skip


def _cmd_reproduce(args: argparse.Namespace) -> int:
    out = planned_output_dir(
        args, functools.partial(_reproduce_pages, quick=args.quick), TABLE1_SUBDIRS,
        replaces=functools.partial(_reproduce_replaces, quick=args.quick),
    )  # fmt: skip
    ga_args = argparse.Namespace(
        quick=args.quick, runs=None, generations=None, population=None, seed=None, run_dir=None,
        resume=False, executor="auto", workers=args.workers, scheduler=None, invocation=args.invocation,
        output_dir=str(out), json=False,
    )  # fmt: skip
    plan = plan_casestudy(ga_args)  # checks the GA's run directory before the first stage
    from replication.casestudy.sph import engine_available

    # the SPH study's cache, checked now, not after Table 1 (its simulations run in it)
    sph_cache_dir = None
    if engine_available():
        from replication.cli.sph import sph_cache

        sph_cache_dir = str(sph_cache(None))
    kind = "quick (reduced) run" if args.quick else "full run"
    print(f"replication reproduce: {kind} into {out}/")
    start = time.perf_counter()
    print("  preparing the compiled kernels (a fresh environment compiles them once: about 20 s)", flush=True)
    warm_up(processes=args.workers or usable_cpus())  # fresh environment: on two cores at once
    print(f"  [done] kernels: compiled or loaded from numba's cache ({time.perf_counter() - start:.1f} s)")
    written: list[Path] = []
    for name, what in STAGES:
        t0 = time.perf_counter()
        if name == "table1":
            path = _run_table1(out, args.quick, args.invocation, args.workers)
            release_threads()  # the case study's workers can then be forked, not spawned
        elif name == "sph":  # optional: needs the engine (pip install ".[sph]")
            from replication.casestudy.sph import INSTALL_HINT, engine_available
            from replication.cli.sph import run_sph_report

            if not engine_available():
                print(f"  [skipped] {name}: the SPH solver is not installed ({INSTALL_HINT})")
                continue
            path = run_sph_report(out, args.quick, args.invocation, args.workers, sph_cache_dir)
        elif name == "jet validation":  # issue 11: hours of SPH, so only from a filled cache
            from replication.cli.validate_run import reproduce_stage

            path, note = reproduce_stage(out, args.quick, args.invocation)
            if path is None:
                print(f"  [skipped] {name}: {note}")
                continue
            if note:  # no SPH cache here: the saved (committed) data re-rendered, left as they are
                print(f"  [note] {name}: {note}")
        else:
            path = run_and_report(plan, ga_args)[1]
        written = finish_reports(out)  # after each stage, so an interrupted run leaves them consistent
        print(f"  [done] {name}: {what} -> {path} ({time.perf_counter() - t0:.1f} s)")
    if not written:  # every stage was skipped
        written = finish_reports(out)
    print(f"wrote {written[0]}; total {time.perf_counter() - start:.1f} s")
    _said(written, out)
    return 0


EPILOGS = {
    "reproduce": f"""\
examples:
  replication reproduce                       every report, with the paper's settings, into {DEFAULT_DIR}/
  replication reproduce --quick               a reduced run (a smoke test) into {QUICK_DIR}/
  replication reproduce --output-dir mine     the paper's settings, written into mine/
  replication reproduce --workers 1           one task at a time (SPH simulations still in a child process)

An interrupted run keeps the reports of the stages it finished, each consistent with its
data; running the command again runs every stage anew, except the SPH simulations already in
the SPH cache (.sph-cache, or $REPLICATION_SPH_CACHE), which are taken from it. An interrupted
case study also keeps its checkpoints and prints the `replication casestudy ... --resume` that
finishes it.
""",
    "table1": f"""\
examples:
  replication table1                          Table 1 and Fig. 6 into {DEFAULT_DIR}/table1.md
  replication table1 --quick                  a reduced run into {QUICK_DIR}/
  replication table1 --output-dir mine --workers 1
""",
    "report": f"""\
examples:
  replication report                          redraw every report in {DEFAULT_DIR}/ from its data/
  replication report --output-dir {QUICK_DIR}   the same for a quick run's reports
  replication report --performance            merge asv's results (after `asv run`), draw performance.md
  replication report --output-dir copy --performance --commits 10   other settings: a copy of {DEFAULT_DIR}/

No experiment runs: the pages are drawn from the CSV and JSON files under DIR/data. A page
that would differ only in the commit that rendered it is left as it is.
""",
}


def register(sub: argparse._SubParsersAction) -> None:
    """Add the table1, report and reproduce subcommands."""
    for name, func, helptext in (
        ("reproduce", _cmd_reproduce, "regenerate every available report of the paper's results"),
        ("table1", _cmd_table1, "reproduce Table 1 and Fig. 6 (ADT vs NURBS) into reports/table1.md"),
    ):
        p = sub.add_parser(
            name,
            help=helptext,
            description=helptext[0].upper() + helptext[1:] + ". Long stages show a progress bar on stderr. "
            f"Written into {DEFAULT_DIR}/ of a checkout of this project, the reports also refresh the "
            "headline block of its README.md.",
            epilog=EPILOGS[name],
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        p.add_argument(
            "--quick",
            action="store_true",
            help=f"a reduced run (fewer repeats and seeds, a coarser NURBS tessellation; under a "
            f"minute) into {QUICK_DIR}/",
        )
        p.add_argument(
            "--output-dir",
            type=directory_name,
            metavar="DIR",
            help=f"where reports, figures and data go (default {DEFAULT_DIR}/, or {QUICK_DIR}/ with --quick; "
            f"a --quick run never writes a checkout's committed {DEFAULT_DIR}/)",
        )
        p.add_argument(
            "--workers",
            type=worker_count,
            metavar="N",
            help="worker processes for the untimed work (Table 1's paired statistics, storage sizes, "
            "scale-sweep file sizes and figures"
            + (
                "; the case study's fitness evaluations and figures; the SPH study's simulations at a "
                "time, default 2 there"
                if name == "reproduce"
                else ""
            )
            + "); Table 1's timings run alone, in the command's own process, and no result depends "
            "on N (default: the number of CPUs)",
        )
        p.set_defaults(func=func)
    p = sub.add_parser(
        "report",
        help="re-render the reports' markdown and figures from their saved data (no experiment is run)",
        description="Re-render the markdown and figures of every report from the data in DIR/data.",
        epilog=EPILOGS["report"],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--output-dir",
        type=directory_name,
        metavar="DIR",
        help=f"the reports directory (default: {DEFAULT_DIR}/)",
    )
    p.add_argument(
        "--performance",
        action="store_true",
        help=(
            "also write performance.md: asv's results merged into the archive DIR/data/performance_asv.csv, "
            "and the page drawn from it (run `asv run` first; see the README)"
        ),
    )
    p.add_argument(
        "--asv-results",
        type=directory_name,
        metavar="DIR",
        help=f"asv's results directory (default: {DEFAULT_ASV_RESULTS}; if absent, the archive alone)",
    )
    p.add_argument(
        "--commits",
        type=positive_int,
        metavar="N",
        help=f"how many recent commits each benchmark's history in performance.md shows (default "
        f"{DEFAULT_COMMITS}; another N only with --output-dir, so that the committed page keeps its "
        "settings)",
    )
    p.add_argument(
        "--readme",
        type=file_name,
        metavar="FILE",
        help="also refresh the headline block of this README from the data (the README.md of a "
        "checkout whose reports/ is drawn is refreshed without it)",
    )
    p.set_defaults(func=_cmd_report)
