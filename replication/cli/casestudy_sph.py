"""The SPH options of ``replication casestudy``: ``--rescore sph --top K``, ``--solver sph``.

A run scored by SPH records its solver and settings in ``RUN_DIR/fitness.json``; a run
directory without one holds a thin-sheet run. Resuming with another fitness is refused, so
one run never mixes two fitnesses.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from typing import Any

from replication.cli.common import directory_name, positive_int

#: The SPH options (dest names); they need --rescore sph or --solver sph.
SPH_OPTIONS = ("top", "particle_radius", "duration", "sph_timeout", "cache_dir")
#: The record of a run's fitness in its run directory (absent: the thin-sheet model).
FITNESS_NAME = "fitness.json"
#: The ``--rescore`` options of a run, so that ``--resume`` continues with them.
RESCORE_NAME = "rescore.json"
#: An estimate above this many hours is refused without --yes.
CONFIRM_HOURS = 1.0


def add_rescore_options(p: argparse.ArgumentParser) -> None:
    """``--rescore`` and the SPH options of ``replication casestudy``."""
    from replication.cli.sph import positive_float

    g = p.add_argument_group('SPH, the fitness of record (needs pip install ".[sph]")')
    g.add_argument(
        "--solver",
        choices=("sheet", "sph"),
        help="the GA's fitness: sheet, the thin-sheet model (default, milliseconds), or sph, an SPH "
        "simulation of every individual (seconds to minutes each; the cost is estimated first)",
    )
    g.add_argument(
        "--yes",
        action="store_true",
        help=f"--solver sph: start even when the estimate exceeds {CONFIRM_HOURS:g} h",
    )
    g.add_argument(
        "--rescore",
        choices=("sph",),
        help="after the thin-sheet GA, re-score the best distinct surfaces of each run, the flat plate "
        "and the bucket by SPH (SPlisHSPlasH), and rank them by SPH in the report",
    )
    g.add_argument("--top", type=positive_int, metavar="K", help="distinct surfaces per run (default 5)")
    g.add_argument(
        "--particle-radius", type=positive_float, metavar="R", help="SPH particle radius in mm (default 0.75)"
    )
    g.add_argument(
        "--duration",
        type=positive_float,
        metavar="T",
        help="SPH simulated time in ms (default 20; at least about 15 for the paper's jet: the force is "
        "averaged over a quasi-steady window after the impact)",
    )
    g.add_argument(
        "--sph-timeout", type=positive_float, metavar="S", help="wall-clock limit of one simulation (s, 1800)"
    )
    g.add_argument(
        "--cache-dir",
        type=directory_name,
        metavar="DIR",
        help="the SPH cache (default $REPLICATION_SPH_CACHE or .sph-cache/): a rerun reuses every "
        "finished simulation",
    )


def rescore_config(args: argparse.Namespace, config: Any) -> Any:
    """The :class:`RescoreConfig` of the options, checked before any work; None without SPH.

    With ``--solver sph`` alone it carries the settings of the fitness (``top`` unused).

    Raises
    ------
    InputError
        An SPH option without ``--rescore sph`` or ``--solver sph`` (``--top`` without
        ``--rescore``), settings the SPH backend refuses.
    SolverUnavailableError
        The engine is not installed (the message names ``pip install ".[sph]"``).
    """
    from replication.errors import UsageError

    solver = getattr(args, "solver", None) == "sph"
    if solver and getattr(args, "rescore", None) is not None:
        raise UsageError(
            "--rescore sph re-scores the thin-sheet GA's winners; with --solver sph every individual is "
            "already scored by SPH: give one of them"
        )
    if getattr(args, "yes", False) and not solver:
        raise UsageError("--yes applies only with --solver sph")
    if getattr(args, "rescore", None) is None:
        given = [name for name in SPH_OPTIONS if getattr(args, name, None) is not None]
        if given and (given[0] == "top" or not solver):
            need = "--rescore sph" if given[0] == "top" else "--rescore sph or --solver sph"
            raise UsageError(f"--{given[0].replace('_', '-')} applies only with {need}")
        if not solver:
            return None
    from pathlib import Path

    from replication.casestudy import sph
    from replication.casestudy.rescore import RescoreConfig
    from replication.casestudy.sph.settings import SPHSettings
    from replication.casestudy.sph_batch import default_cache_dir
    from replication.casestudy.sph_size import check_jet_particles
    from replication.io.paths import check_utf8_path, check_writable_dir

    cache = Path(args.cache_dir) if args.cache_dir else default_cache_dir()
    what = "--cache-dir" if args.cache_dir else "the SPH cache"
    check_writable_dir(cache, what)
    check_utf8_path(cache, what)  # the engine simulates into it
    sph.require_engine()
    changes: dict[str, Any] = {}
    if args.particle_radius is not None:
        changes["particle_radius"] = args.particle_radius / 1000.0  # mm -> m
    if args.duration is not None:
        changes["duration"] = args.duration / 1000.0  # ms -> s
    settings = SPHSettings(**changes)
    check_jet_particles(settings, config.jet.velocity, config.jet.diameter)  # no window, or no memory: now
    return RescoreConfig(
        top=5 if args.top is None else args.top,
        settings=settings,
        timeout=args.sph_timeout,
        cache_dir=str(cache.resolve()),
    )


def rescore_hint(args: argparse.Namespace) -> list[str]:
    """The SPH options to repeat in the resume hint."""
    words = []
    if getattr(args, "solver", None) is not None:
        words += ["--solver", args.solver] + (["--yes"] if args.yes else [])
    if getattr(args, "rescore", None) is not None:
        words += ["--rescore", args.rescore]
    if not words:
        return []
    for name in SPH_OPTIONS:
        value = getattr(args, name, None)
        if value is not None:
            words += [f"--{name.replace('_', '-')}", f"{value:g}" if isinstance(value, float) else str(value)]
    return words


def _span(seconds: float) -> str:
    """A rough duration: ``40 s``, ``12 min``, ``3.5 h``."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


class RescoreProgress:
    """The progress of ``--rescore sph`` on stderr, with the cost still ahead.

    Once the cache is read (:meth:`plan`), one line says how many distinct surfaces are to be
    simulated, and how many at a time (the executor's workers, a dask cluster's included);
    then one line per re-scored surface, and after each simulation the time left. The time
    left is the wall time since the plan per simulation finished, times those not finished;
    until the simulations started together have finished, the ones still running are taken to
    end now and the rest to run that many at a time.
    """

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self.started: float | None = None
        self.to_simulate = 0
        self.at_once = 1
        self.simulated = 0

    def plan(self, plan: Any) -> None:
        """Called with the :class:`~replication.casestudy.sph_batch.Plan` once the cache is read."""
        self.started, self.to_simulate, self.at_once = self.clock(), plan.to_simulate, max(1, plan.at_once)
        parts = [f"{plan.cached} from the cache"]
        if plan.missing:
            parts.append(f"{plan.missing} missing from it")
        parts.append(f"{plan.to_simulate} to simulate")
        if plan.to_simulate:
            parts[-1] += f", {self.at_once} at a time"
        print(f"SPH re-scoring: {plan.distinct} distinct surfaces, {', '.join(parts)}", file=sys.stderr)

    def __call__(self, scored: Any) -> None:
        what = f"{scored.result.mean_axial:.4g} N" if scored.ok else f"{scored.status}: {scored.reason}"
        if scored.cached:
            source = "cache"
        else:
            self.simulated += 1
            source = ""
            if scored.result is not None:  # (a failed run did not simulate what it was asked)
                verb = "simulated in" if scored.ok else "ended after"
                source = f"{verb} {scored.result.wall_seconds:.1f} s"
            if self.started is not None and self.to_simulate:
                left = self.to_simulate - self.simulated
                elapsed = self.clock() - self.started
                at_once = min(self.at_once, self.to_simulate)
                if self.simulated < at_once:  # the first of a batch started together
                    seconds = (self.to_simulate - at_once) * elapsed / at_once
                else:
                    seconds = left * elapsed / self.simulated
                ahead = f"about {_span(seconds)} left" if left > 0 else "the last"
                source = "; ".join(filter(None, (source, f"{self.simulated}/{self.to_simulate}, {ahead}")))
        print(f"SPH {scored.name}: {what}" + (f" ({source})" if source else ""), file=sys.stderr)


def rescore_summary(results: Any) -> list[str]:
    """Lines for stdout: the best surface by SPH and the bucket beside it."""
    frame = results.rescore
    if frame is None:
        return []
    ok = frame[frame["status"] == "ok"].sort_values("sph_N", ascending=False, kind="stable")
    distinct = frame.drop_duplicates("key")  # a surface listed twice was simulated once
    failed = int((distinct["status"] != "ok").sum())
    cached = int(distinct["cached"].sum())
    lines = [
        f"SPH re-scoring: {len(frame)} surfaces, {len(distinct)} distinct ({cached} from the cache, "
        f"{failed} failed)"
    ]
    if len(ok):
        best = ok.iloc[0]
        lines.append(
            f"best by SPH: {best['surface']} {best['sph_N']:.4g} N (thin-sheet {best['thin_sheet_N']:.4g} N)"
        )
        bucket = ok[ok["surface"] == "pelton bucket"]
        if len(bucket):
            lines.append(f"pelton bucket by SPH: {bucket.iloc[0]['sph_N']:.4g} N")
    return lines


def check_rescored(results: Any, report: Any) -> None:
    """Fail the command (after its report and data are written) when ``--rescore sph`` judged
    none of the GA's winners: an exit status of 0 told a script that SPH had judged them,
    also when every simulation failed or only the reference shapes' succeeded.

    Raises
    ------
    SimulationError
        No GA surface has an SPH score; the message counts their distinct simulations by
        status.
    """
    frame = results.rescore
    if frame is None:
        return
    ga = frame[frame["kind"] == "GA"]
    if ga.empty or bool((ga["status"] == "ok").any()):
        return
    from replication.errors import SimulationError

    counts = ga.drop_duplicates("key")["status"].value_counts(sort=False)
    how = ", ".join(f"{count} {status}" for status, count in counts.items())
    total = int(counts.sum())
    raise SimulationError(
        f"no GA surface was judged by SPH: {'the' if total == 1 else 'every'} simulation of the GA's "
        f"{len(ga)} surface(s) failed ({how}); {report} gives each one's reason"
    )


def solver_record(args: argparse.Namespace, rescore: Any) -> dict[str, Any] | None:
    """What the GA's fitness is (for ``fitness.json`` and the provenance); None: the thin-sheet model."""
    if getattr(args, "solver", None) != "sph":
        return None
    return {"solver": "sph", "settings": rescore.settings.as_dict()}


def check_fitness_record(run_dir: Any, record: dict[str, Any] | None, resume: bool) -> None:
    """Refuse a run directory whose recorded fitness differs from the requested one."""
    import json
    from pathlib import Path

    from replication.errors import InputError

    path = Path(run_dir) / FITNESS_NAME
    recorded = json.loads(path.read_text()) if path.is_file() else None
    has_run = (Path(run_dir) / "config.json").is_file()
    if not has_run and not resume:
        return
    if recorded != record:

        def name(r: Any) -> str:
            if r is None:
                return "the thin-sheet model"
            changed = {k: v for k, v in r.get("settings", {}).items() if v != defaults.get(k)}
            return (
                "SPH (" + (", ".join(as_given(k, v) for k, v in sorted(changed.items())) or "defaults") + ")"
            )

        from replication.casestudy.sph.settings import SPHSettings
        from replication.report.settings import as_given

        defaults = SPHSettings().as_dict()

        raise InputError(
            f"{run_dir} holds a run scored by {name(recorded)}, not {name(record)}: resume it with its "
            "own --solver and SPH options, or start a new run directory"
        )


def write_fitness_record(run_dir: Any, record: dict[str, Any] | None) -> None:
    import json
    from pathlib import Path

    from replication.io.atomic import atomic_write_text

    if record is not None:
        Path(run_dir).mkdir(parents=True, exist_ok=True)
        atomic_write_text(Path(run_dir) / FITNESS_NAME, json.dumps(record, sort_keys=True) + "\n")


def sph_fitness(plan: Any, args: argparse.Namespace, workers: int) -> Any:
    """The SPH fitness of ``--solver sph`` after its cost estimate (stderr); None for the thin sheet.

    Raises
    ------
    InputError
        An estimate above ``CONFIRM_HOURS`` without ``--yes``.
    """
    if plan.solver is None:
        return None
    from replication.casestudy.sph_fitness import SPHFitness, estimate
    from replication.errors import InputError

    r = plan.sph
    fitness = SPHFitness(plan.config, r.settings, r.cache_dir, r.timeout)
    print(
        "--solver sph: measuring one SPH simulation (the flat plate) for the cost estimate", file=sys.stderr
    )
    e = estimate(fitness, workers=workers)
    print(
        f"--solver sph: {e.seconds_per_simulation:.3g} s per simulation"
        f"{' (from the cache)' if e.cached else ''} x at most {e.evaluations} evaluations / {e.workers} "
        f"worker(s) = at most {e.hours:.3g} h (the genome cache saves repeats)",
        file=sys.stderr,
    )
    if e.hours > CONFIRM_HOURS and not args.yes:
        raise InputError(
            f"the estimated cost, {e.hours:.3g} h, exceeds {CONFIRM_HOURS:g} h: pass --yes to start, or "
            "coarsen with --particle-radius, --duration or fewer --runs/--generations/--population"
        )
    return fitness


def _rescore_options(args: argparse.Namespace) -> dict[str, Any]:
    """The ``--rescore`` options given, a cache directory resolved (a resume from another
    working directory names the same cache by another path)."""
    from pathlib import Path

    given = {
        name: getattr(args, name)
        for name in ("rescore", *SPH_OPTIONS)
        if getattr(args, name, None) is not None
    }
    if "cache_dir" in given:
        given["cache_dir"] = str(Path(given["cache_dir"]).resolve())
    return given


#: The options' values when they are not given (as the command line takes them: mm, ms).
_RESCORE_DEFAULTS = {"top": 5, "particle_radius": 0.75, "duration": 20.0}


def write_rescore_record(run_dir: Any, args: argparse.Namespace, rescore: Any) -> None:
    """Record the ``--rescore`` options in the run directory, defaults and the cache used
    included (nothing without ``--rescore``)."""
    import json
    from pathlib import Path

    from replication.io.atomic import atomic_write_text

    if getattr(args, "rescore", None) is None or rescore is None:
        return
    record = {
        **_RESCORE_DEFAULTS,
        **_rescore_options(args),
        "cache_dir": str(Path(rescore.cache_dir).resolve()),
    }
    atomic_write_text(Path(run_dir) / RESCORE_NAME, json.dumps(record, sort_keys=True) + "\n")


#: The SPH option a resume may change: a limit says when to give up, not what is simulated.
_FREE_ON_RESUME = ("sph_timeout",)


def restore_rescore(args: argparse.Namespace, run_dir: Any) -> None:
    """On ``--resume``, take the run's recorded ``--rescore`` options.

    A plain ``--resume`` of a run started with ``--rescore sph`` dropped the re-scoring and,
    its settings then looking like the paper's or the quick ones, wrote its report over
    another run's (a new-user audit); ``--resume --top 3`` was accepted though the run had 2.
    Options given with ``--resume`` must match the recorded ones, as the GA's settings must,
    except ``--sph-timeout``: a limit says when to give up, not what is simulated, and a
    longer one simulates again what timed out under the shorter (a run whose limit was too
    short could not be continued). A run recorded without ``--rescore`` may be re-scored on
    resume.

    Raises
    ------
    InputError
        An option given that differs from the recorded one, or an unreadable record.
    """
    import json
    from pathlib import Path

    from replication.errors import InputError

    path = Path(run_dir) / RESCORE_NAME
    if not path.is_file():
        return
    try:
        recorded = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(recorded, dict) or recorded.get("rescore") != "sph":
            raise ValueError("not a --rescore record")
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: not a readable record of the run's --rescore options ({exc})") from None
    given = {k: v for k, v in _rescore_options(args).items() if k not in _FREE_ON_RESUME}
    differ = [
        f"--{name.replace('_', '-')} {value:g} (the run has {recorded.get(name, 'its default')})"
        if isinstance(value, float)
        else f"--{name.replace('_', '-')} {value} (the run has {recorded.get(name, 'its default')})"
        for name, value in given.items()
        if recorded.get(name) != value
    ]
    if getattr(args, "solver", None) == "sph":
        differ.insert(
            0, "--solver sph (the run's GA was scored by the thin-sheet model and re-scored by SPH)"
        )
    if differ:
        raise InputError(
            f"{run_dir} holds a run re-scored with other SPH options: {', '.join(differ)}; resume without "
            "them to continue it with its recorded ones, or start a new run directory"
        )
    for name, value in recorded.items():
        given_now = name in _FREE_ON_RESUME and getattr(args, name, None) is not None
        if name in ("rescore", *SPH_OPTIONS) and not given_now:
            setattr(args, name, value)  # (a default recorded as given: the same value)
