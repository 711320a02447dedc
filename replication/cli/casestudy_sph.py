"""The SPH options of ``replication casestudy``: ``--rescore sph --top K`` and its settings."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from replication.cli.common import positive_int

#: The SPH options (dest names); they need --rescore sph.
SPH_OPTIONS = ("top", "particle_radius", "duration", "sph_timeout", "cache_dir")


def add_rescore_options(p: argparse.ArgumentParser) -> None:
    """``--rescore`` and the SPH options of ``replication casestudy``."""
    from replication.cli.sph import positive_float

    g = p.add_argument_group('SPH re-scoring (the fitness of record; needs pip install ".[sph]")')
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
        "--duration", type=positive_float, metavar="T", help="SPH simulated time in ms (default 20)"
    )
    g.add_argument(
        "--sph-timeout", type=positive_float, metavar="S", help="wall-clock limit of one simulation (s, 1800)"
    )
    g.add_argument(
        "--cache-dir",
        metavar="DIR",
        help="the SPH cache (default $REPLICATION_SPH_CACHE or .sph-cache/): a rerun reuses every "
        "finished simulation",
    )


def rescore_config(args: argparse.Namespace, config: Any) -> Any:
    """The :class:`RescoreConfig` of the options, checked before any work; None without --rescore.

    Raises
    ------
    InputError
        An SPH option without ``--rescore sph``, settings the SPH backend refuses.
    SolverUnavailableError
        The engine is not installed (the message names ``pip install ".[sph]"``).
    """
    from replication.errors import InputError

    if getattr(args, "rescore", None) is None:
        given = [name for name in SPH_OPTIONS if getattr(args, name, None) is not None]
        if given:
            raise InputError(f"--{given[0].replace('_', '-')} applies only with --rescore sph")
        return None
    from pathlib import Path

    from replication.casestudy import sph
    from replication.casestudy.rescore import RescoreConfig
    from replication.casestudy.sph.settings import SPHSettings, timeline
    from replication.casestudy.sph_batch import default_cache_dir

    sph.require_engine()
    changes: dict[str, Any] = {}
    if args.particle_radius is not None:
        changes["particle_radius"] = args.particle_radius / 1000.0  # mm -> m
    if args.duration is not None:
        changes["duration"] = args.duration / 1000.0  # ms -> s
    settings = SPHSettings(**changes)
    timeline(settings, config.jet.velocity, config.jet.diameter)  # a duration with no window: refuse now
    cache = Path(args.cache_dir) if args.cache_dir else default_cache_dir()
    return RescoreConfig(
        top=5 if args.top is None else args.top,
        settings=settings,
        timeout=args.sph_timeout,
        cache_dir=str(cache.resolve()),
    )


def rescore_hint(args: argparse.Namespace) -> list[str]:
    """The re-scoring options to repeat in the resume hint."""
    if getattr(args, "rescore", None) is None:
        return []
    words = ["--rescore", args.rescore]
    for name in SPH_OPTIONS:
        value = getattr(args, name, None)
        if value is not None:
            words += [f"--{name.replace('_', '-')}", f"{value:g}" if isinstance(value, float) else str(value)]
    return words


def report_rescored(scored: Any) -> None:
    """One line on stderr per re-scored surface (progress)."""
    if scored.ok:
        what = f"{scored.result.mean_axial:.4g} N"
    else:
        what = f"{scored.status}: {scored.reason}"
    if scored.cached:
        source = "cache"
    else:
        source = f"simulated in {scored.result.wall_seconds:.1f} s" if scored.result is not None else ""
    print(f"SPH {scored.name}: {what}" + (f" ({source})" if source else ""), file=sys.stderr)


def rescore_summary(results: Any) -> list[str]:
    """Lines for stdout: the best surface by SPH and the bucket beside it."""
    frame = results.rescore
    if frame is None:
        return []
    ok = frame[frame["status"] == "ok"].sort_values("sph_N", ascending=False, kind="stable")
    failed = int((frame["status"] != "ok").sum())
    cached = int(frame["cached"].sum())
    lines = [f"SPH re-scoring: {len(frame)} surfaces ({cached} from the cache, {failed} failed)"]
    if len(ok):
        best = ok.iloc[0]
        lines.append(
            f"best by SPH: {best['surface']} {best['sph_N']:.4g} N (thin-sheet {best['thin_sheet_N']:.4g} N)"
        )
        bucket = ok[ok["surface"] == "pelton bucket"]
        if len(bucket):
            lines.append(f"pelton bucket by SPH: {bucket.iloc[0]['sph_N']:.4g} N")
    return lines
