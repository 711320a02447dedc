"""The SPH solver on the command line: ``replication force --solver sph`` and ``replication sph``."""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from replication.cli.common import (
    directory_name,
    drawing_saved_data,
    emit_json,
    saving_data,
    worker_count,
)

SOLVERS = ("sheet", "sph")
#: The SPH options of ``replication force`` (dest names); they need --solver sph.
FORCE_OPTIONS = ("particle_radius", "duration", "sph_method", "sound_speed", "timeout", "run_dir")


def positive_float(text: str) -> float:
    """argparse type: a positive finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text}")
    return value


def add_force_options(p: argparse.ArgumentParser) -> None:
    """``--solver`` and the SPH options of ``replication force``."""
    p.add_argument(
        "--solver",
        choices=SOLVERS,
        default="sheet",
        help="sheet: the thin-sheet momentum balance (default, milliseconds); sph: an SPH simulation "
        'with SPlisHSPlasH in a child process (seconds to minutes; pip install ".[sph]")',
    )
    g = p.add_argument_group("SPH solver (with --solver sph)")
    g.add_argument(
        "--particle-radius", type=positive_float, metavar="R", help="particle radius in mm (default 0.75)"
    )
    g.add_argument(
        "--duration",
        type=positive_float,
        metavar="T",
        help="simulated time in ms (default 20; at least about 15 for the paper's jet, more for a slower "
        "one: the force is averaged over a quasi-steady window after the impact)",
    )
    g.add_argument(
        "--sph-method",
        choices=("dfsph", "wcsph"),
        help="pressure solver: dfsph (incompressible, default) or wcsph (weakly compressible)",
    )
    g.add_argument(
        "--sound-speed",
        type=positive_float,
        metavar="C",
        help="wcsph: numerical speed of sound in m/s (default 10 V)",
    )
    g.add_argument(
        "--timeout", type=positive_float, metavar="S", help="wall-clock limit in seconds (default 1800)"
    )
    g.add_argument(
        "--run-dir",
        type=directory_name,
        metavar="DIR",
        help="keep the simulation's files (scene, log, series CSV) in DIR: a new or empty directory, "
        "or an earlier simulation's, whose files are replaced",
    )


def _settings(args: argparse.Namespace) -> Any:
    from replication.casestudy.sph import SPHSettings
    from replication.casestudy.units import to_metres

    changes: dict[str, Any] = {}
    if args.particle_radius is not None:
        changes["particle_radius"] = float(to_metres(args.particle_radius))
    if args.duration is not None:
        changes["duration"] = args.duration / 1000.0  # ms -> s
    if args.sph_method is not None:
        changes["method"] = args.sph_method
    if args.sound_speed is not None:
        changes["sound_speed"] = args.sound_speed
    return SPHSettings(**changes)


#: What a simulation writes into its run directory (:mod:`replication.casestudy.sph`); a
#: directory holding only these, ``job.json`` among them (or the lock alone, which a command
#: holding it made), is an earlier simulation's, whose files a new one replaces.
SIMULATION_ENTRIES = frozenset(
    {".lock", "column.pda", "engine", "engine.log", "job.json", "outcome.json", "progress.json",
     "result.json", "scene.json", "series.csv", "solid.obj", "steps.csv"}
)  # fmt: skip


def check_temporary_dir_utf8() -> None:
    """Refuse a temporary directory whose path is not UTF-8 where simulations run in it (no
    ``--run-dir``): the engine is given paths under it and every simulation crashed."""
    import tempfile

    from replication.io.paths import check_utf8_path

    check_utf8_path(tempfile.gettempdir(), "the temporary directory (TMPDIR)")


def _check_run_dir(run_dir: str) -> None:
    """``--run-dir`` must be new, empty or an earlier simulation's: the simulation replaces
    scene.json, steps.csv, series.csv, result.json, ... there, and deleted a user's files of
    those names without a word. A ``--run-dir`` naming a file is refused too, and one whose
    absolute path is not UTF-8 (the engine cannot be given it). A file browser's files
    (``.DS_Store``, ...) count as nothing."""
    from replication.errors import InputError
    from replication.io.paths import check_utf8_path, check_writable_dir, is_browser_file

    check_utf8_path(run_dir, "--run-dir")  # the engine's binding: every simulation crashed
    path = check_writable_dir(run_dir, "--run-dir")
    if not path.is_dir():
        return
    entries = sorted(entry.name for entry in path.iterdir() if not is_browser_file(entry.name))
    others = [name for name in entries if name not in SIMULATION_ENTRIES]
    if others or (set(entries) - {".lock", "job.json"} and "job.json" not in entries):
        shown = ", ".join((others or entries)[:3]) + (", ..." if len(others or entries) > 3 else "")
        raise InputError(
            f"--run-dir {run_dir} holds files that are not an earlier simulation's ({shown}): the "
            "simulation replaces scene.json, steps.csv, series.csv, result.json and others there; "
            "use a new or empty directory"
        )


def check_force_options(args: argparse.Namespace) -> None:
    """Refuse SPH options without ``--solver sph``, ``--sound-speed`` without ``--sph-method
    wcsph``, and a ``--run-dir`` that holds INPUT, is not a directory, or holds files that
    are not an earlier simulation's."""
    from pathlib import Path

    from replication.errors import InputError, UsageError

    if args.solver != "sph":
        given = [name for name in FORCE_OPTIONS if getattr(args, name, None) is not None]
        if given:
            flag = "--" + given[0].replace("_", "-")
            raise UsageError(f"{flag} applies only with --solver sph")
    if getattr(args, "sound_speed", None) is not None and args.sph_method != "wcsph":
        raise UsageError(
            "--sound-speed applies only with --sph-method wcsph (the default dfsph is incompressible: "
            "it has no speed of sound)"
        )
    source = getattr(args, "input", None)
    if getattr(args, "run_dir", None) and source:
        try:
            run_dir, path = Path(args.run_dir).resolve(), Path(source).resolve()
        except (OSError, RuntimeError) as exc:  # RuntimeError: a loop of symbolic links (Python 3.11)
            raise InputError(f"--run-dir {args.run_dir}: cannot follow the symbolic link ({exc})") from exc
        if run_dir == path or run_dir in path.parents:  # the engine's files (steps.csv, ...) go there
            raise InputError(
                f"--run-dir {args.run_dir} holds INPUT {source}: the simulation writes its files there "
                "(scene, engine log, steps.csv, series.csv, result.json); use a directory of their own"
            )
    if getattr(args, "run_dir", None):
        _check_run_dir(args.run_dir)
    elif args.solver == "sph":
        check_temporary_dir_utf8()


@contextlib.contextmanager
def _run_dir_held(run_dir: str | None) -> Iterator[None]:
    """Hold ``--run-dir`` for this command: two simulations writing one directory's files at
    once gave "ok" with a NaN force (a second command is refused instead)."""
    from replication.casestudy.rundir import RunDirBusyError, hold
    from replication.errors import InputError

    if run_dir is None:
        yield
        return
    try:
        with hold(run_dir):
            yield
    except RunDirBusyError:
        raise InputError(
            f"--run-dir {run_dir} is in use by another command; use a directory of its own"
        ) from None


def force_sph(
    args: argparse.Namespace, config: Any, points: Any, triangles: Any, what: str, shared: dict[str, Any]
) -> int:
    """``replication force --solver sph``: simulate, print the result (or one JSON object).

    ``shared`` holds the input's and the jet's keys of the JSON object, as the thin-sheet
    model prints them (:func:`replication.cli.force.shared_report`).
    """
    from replication.casestudy.sph import DEFAULT_TIMEOUT, require_engine, sph_force
    from replication.casestudy.sph_size import check_jet_particles
    from replication.cli.progress import progress as show_progress

    settings = _settings(args)
    check_jet_particles(settings, config.velocity, config.diameter)  # no window, or no memory: refuse first
    require_engine()
    from replication.cli.jet_misses import sph_coverage_warning

    if warning := sph_coverage_warning(points, triangles, config):
        print(warning, file=sys.stderr)
    total_ms = round(1e3 * settings.duration)
    with _run_dir_held(args.run_dir), show_progress(total_ms, "SPH simulated time (ms)") as bar:

        def progress(t: float) -> None:
            reached = min(int(1e3 * t), total_ms)
            if reached > bar.done:
                bar.update(reached - bar.done)

        result = sph_force(
            points,
            triangles,
            config,
            settings,
            timeout=args.timeout or DEFAULT_TIMEOUT,
            run_dir=args.run_dir,
            progress=progress,
        )
    result.check()
    if not math.isfinite(result.mean_axial):  # never "ok" with no force (files changed under it?)
        from replication.errors import SimulationError

        raise SimulationError(
            f"the SPH simulation ended without a force over its averaging window (files in {result.run_dir})"
        )
    report = sph_report(shared, result)
    if args.json:
        emit_json(report)
        return 0
    jet = (
        "full jet"
        if config.full_jet
        else "half jet (y >= 0): simulated whole on the surface mirrored in y = 0, halved"
    )
    method = (
        "DFSPH"
        if settings.method == "dfsph"
        else f"WCSPH, c = {settings.speed_of_sound(config.velocity):.4g} m/s"
    )
    a, b = (1e3 * t for t in result.window)
    print(f"water-jet force on {args.input} ({what}), SPH: SPlisHSPlasH {result.engine}, {method}")
    print(f"{jet}; {args.diameter:g} mm at {config.velocity:g} m/s along -z")
    print(
        f"axial force {result.mean_axial:.4g} N = {report['over_rho_q_v']:.3f} rho Q V "
        f"({report['over_measured_flux']:.3f} x measured mass flux x V): mean over {a:.3g}-{b:.3g} ms, "
        f"std {result.std_axial:.2g} N"
    )
    fx, fy, fz = (v if v is None else float(v) + 0.0 for v in report["force_N"])  # + 0.0: no "-0"
    print(f"force ({fx:.4g}, {'y not simulated' if fy is None else f'{fy:.4g}'}, {fz:.4g}) N")
    print(
        f"first-impact peak {result.peak_axial:.4g} N (mean over {1e3 * settings.peak_window:g} ms from "
        f"{1e3 * result.peak_time:.3g} ms); largest single-step force {result.max_step_axial:.4g} N"
    )
    print(
        f"particle radius {1e3 * settings.particle_radius:g} mm: {result.fluid_particles} fluid and "
        f"{result.boundary_particles} boundary particles, {result.steps} steps, "
        f"{1e3 * result.simulated_time:.3g} ms simulated in {result.wall_seconds:.1f} s"
    )
    if args.run_dir:
        print(f"files (scene, engine log, steps.csv, series.csv, result.json) in {result.run_dir}")
    if merged := shared["points_merged"]:
        print(f"merged {merged} point(s) sharing an (x, y) position (mean height)")
    return 0


def sph_report(shared: dict[str, Any], result: Any) -> dict[str, Any]:
    """The JSON object of ``replication force --solver sph --json``: the keys shared with the
    thin-sheet model, then the simulation's.

    ``force_N`` means what it means for the thin-sheet model: the push on the surface given.
    For the half jet, simulated as the whole jet on the surface joined to its mirror image,
    the halved y force is about zero whatever the half surface feels (the image cancels it),
    so its y component is null, not a number another solver's could be compared with; the
    simulation's own series (``mean_force``, ``force``) keep the halved values.
    """
    force = [float(v) for v in result.mean_force]
    return {
        **shared,
        "axial_force_N": result.mean_axial,
        "force_N": [force[0], None, force[2]] if result.mirrored else force,
        "momentum_flux_N": result.momentum_flux,
        "over_rho_q_v": result.mean_axial / result.momentum_flux,
        "over_measured_flux": result.mean_axial / result.measured_momentum_flux,
        **{k: v for k, v in result.as_dict().items() if k not in ("jet",)},
    }


def _cmd_sph(args: argparse.Namespace) -> int:
    from replication.casestudy.sph import require_engine
    from replication.cli.outputs import finish_reports, planned_output_dir

    out = planned_output_dir(args, ("sph.md", "index.md"), replaces=("sph",))
    check_temporary_dir_utf8()  # its simulations run in temporary directories
    cache = sph_cache(args.cache_dir)
    require_engine()
    start = time.perf_counter()
    path = run_sph_report(out, args.quick, args.invocation, args.workers, str(cache))
    written = finish_reports(out)
    print(f"wrote {path} ({time.perf_counter() - start:.1f} s; data in {out / 'data'})")
    for readme in written[1:]:
        print(f"refreshed the headline block of {readme} from {out}/data (the reports beside it)")
    return 0


def sph_cache(cache_dir: str | None) -> Path:
    """The SPH cache a study simulates into (``--cache-dir``, else the default), resolved and
    checked before any work: writable, and a UTF-8 path the engine can take (a file in its
    place was an 'unexpected FileExistsError', a non-UTF-8 name a crash of every simulation)."""
    from replication.casestudy.sph_batch import default_cache_dir
    from replication.io.paths import check_utf8_path, check_writable_dir

    cache = Path(cache_dir) if cache_dir else default_cache_dir()
    what = "--cache-dir" if cache_dir else "the SPH cache"
    check_writable_dir(cache, what)
    check_utf8_path(cache, what)
    return cache.resolve()


def run_sph_report(
    out: Path, quick: bool, command: str, workers: int | None = None, cache_dir: str | None = None
) -> Path:
    """Run the SPH study (quick or full) into ``out`` and render ``sph.md``.

    ``workers`` simulations run at once (default: 2, or 1 on a single CPU), each driven from a
    worker process of its own; 1 runs them one after another in this process. Every finished
    simulation is kept in the SPH cache ``cache_dir`` (default: that of ``validate-jet``,
    ``$REPLICATION_SPH_CACHE`` or ``.sph-cache``) as it finishes, and a rerun takes it from
    there. Ctrl-C ends the simulations under way at once and says that the finished ones are
    kept (the study used to keep none of them).
    """
    from replication.casestudy.evaluate import executor
    from replication.casestudy.sph_batch import default_cache_dir
    from replication.cli.progress import progress
    from replication.cpus import usable_cpus
    from replication.experiments.sph import SPHStudyConfig, run_sph_study
    from replication.report.sph import render_sph, save_sph_data

    config = SPHStudyConfig.quick() if quick else SPHStudyConfig()
    at_once = min(workers or min(2, usable_cpus()), len(config.runs()))
    with progress(len(config.runs()), "SPH simulations") as bar:

        def tick(label: str) -> None:
            bar.update(1, last=label)

        kind = "serial" if at_once == 1 else "process"
        cache = Path(cache_dir) if cache_dir else default_cache_dir()
        try:
            with executor(
                kind, workers=None if kind == "serial" else at_once, abandon_on_interrupt=True
            ) as pool:
                results = run_sph_study(
                    config, command=command, quick=quick, on_run=tick, executor=pool, max_parallel=at_once,
                    cache_dir=cache,
                )  # fmt: skip
        except KeyboardInterrupt:
            print(
                f"interrupted: the simulations that finished are kept in the SPH cache {cache}; the same "
                "command again continues from them",
                file=sys.stderr,
            )
            raise
    with saving_data(out):
        save_sph_data(results, out)
    with drawing_saved_data(out, "sph.md"):
        return render_sph(out)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``sph`` subcommand (the SPH study and its report)."""
    from replication.cli.outputs import DEFAULT_DIR, QUICK_DIR

    p = sub.add_parser(
        "sph",
        help="the case study on a real SPH solver: convergence and the paper's forces examined (sph.md)",
        description=(
            "Simulate the flat plate and the bucket with SPlisHSPlasH (the optional extra: "
            'pip install ".[sph]") at several particle sizes and with two pressure solvers, and '
            "examine what the paper's SPH forces can be. Writes sph.md, its figures and data."
        ),
        epilog=f"""\
examples:
  replication sph                             the study into {DEFAULT_DIR}/sph.md (minutes per simulation)
  replication sph --quick                     coarse particles only, into {QUICK_DIR}/
  replication sph --workers 1                 one simulation at a time
  replication force bucket.csv --solver sph   one surface's force by SPH instead

Each simulation runs in a child process with a time limit; a failed one is recorded with its
reason, and the report says which. Each finished simulation is kept in the SPH cache as it
finishes: after Ctrl-C, the same command again simulates only what is missing.
""",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--quick", action="store_true", help=f"coarse particles only (under a minute) into {QUICK_DIR}/"
    )
    p.add_argument(
        "--output-dir",
        type=directory_name,
        metavar="DIR",
        help=f"where the report, figures and data go (default {DEFAULT_DIR}/, or {QUICK_DIR}/ with --quick)",
    )
    p.add_argument(
        "--workers",
        type=worker_count,
        metavar="N",
        help="simulations at a time, each on a core of its own (default 2, or 1 on a single CPU; 1 runs "
        "them one after another in this process); no result depends on it",
    )
    p.add_argument(
        "--cache-dir",
        type=directory_name,
        metavar="DIR",
        help="the SPH cache, where each finished simulation is kept and a rerun finds it (default "
        "$REPLICATION_SPH_CACHE, else .sph-cache; shared with validate-jet and casestudy --rescore)",
    )
    p.set_defaults(func=_cmd_sph)
