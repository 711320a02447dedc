"""``replication casestudy``: the water-jet GA (paper section 6) and its report (Figs. 8, 9)."""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import functools
import sys
import time
from pathlib import Path
from typing import Any

from replication.cli.common import emit_json, positive_int, seed

EPILOG = """\
examples:
  replication casestudy                       the paper's GA: 3 runs x 50 generations x 48
  replication casestudy --quick               a reduced GA (smoke test) into reports-quick/
  replication casestudy --workers 2           evaluate on a local process pool of 2 workers
  replication casestudy --executor dask --workers 4          a local dask cluster
  replication casestudy --scheduler tcp://host:8786          an existing dask cluster
  replication casestudy --run-dir casestudy-runs/run-X --resume   continue an interrupted run

Every generation is checkpointed (JSON) in the run directory, printed at the start; after a
crash or Ctrl-C, --resume with the same --run-dir continues where the run stopped and ends
exactly as an uninterrupted run would. Resuming with other settings is refused.
"""


def _config(args: argparse.Namespace) -> Any:
    from replication.casestudy.ga import GAConfig
    from replication.experiments.casestudy import quick_ga_config

    base = quick_ga_config() if args.quick else GAConfig()
    changes = {
        k: getattr(args, k)
        for k in ("runs", "generations", "population", "seed")
        if getattr(args, k) is not None
    }
    return dataclasses.replace(base, **changes) if changes else base


def run_and_report(args: argparse.Namespace, out: Path) -> tuple[Any, Path, Path]:
    """Run the case study as the arguments say; save its data and render the report."""
    from tqdm import tqdm

    from replication.casestudy.evaluate import executor
    from replication.errors import InputError
    from replication.experiments.casestudy import run_casestudy
    from replication.report.casestudy import render_casestudy, save_casestudy_data

    config = _config(args)
    if args.resume and not args.run_dir:
        raise InputError("--resume continues the runs in --run-dir DIR: name the directory to resume")
    if args.resume and not any(Path(args.run_dir).glob("run-*.json")):
        raise InputError(f"nothing to resume: {args.run_dir} holds no GA checkpoint (run-*.json)")
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    run_dir = Path(args.run_dir) if args.run_dir else Path("casestudy-runs") / f"run-{stamp}"
    print(f"GA run directory: {run_dir} (resume with --run-dir {run_dir} --resume)", file=sys.stderr)
    pool = functools.partial(executor, args.executor, workers=args.workers, scheduler=args.scheduler)
    with tqdm(
        total=config.runs * config.generations, desc="GA generations", file=sys.stderr, leave=False
    ) as bar:

        def tick(state: Any) -> None:
            bar.set_postfix(run=state.run, best=f"{state.history[-1]['best_so_far']:.3f} N")
            bar.update(1)

        try:
            results = run_casestudy(
                config, run_dir=run_dir, pool_factory=pool, resume=args.resume, on_generation=tick,
                command=args.invocation, quick=args.quick, timing_repeats=20 if args.quick else 100,
            )  # fmt: skip
        except KeyboardInterrupt:
            print(f"interrupted: resume with --run-dir {run_dir} --resume", file=sys.stderr)
            raise
    save_casestudy_data(results, out)
    return results, render_casestudy(out), run_dir


def _cmd_casestudy(args: argparse.Namespace) -> int:
    from replication.cli.reports import output_dir
    from replication.report.index import render_index

    out = output_dir(args)
    start = time.perf_counter()
    results, path, run_dir = run_and_report(args, out)
    render_index(out)
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
            "run_dir": str(run_dir), "report": str(path), "seconds": time.perf_counter() - start,
        })  # fmt: skip
        return 0
    for _, r in results.runs.iterrows():
        print(f"run {r['run']}: best force {r['best_N']:.4f} N after {r['evaluations']} evaluations "
              f"({r['cache_hits']} saved by the cache, {r['failures']} failed)")  # fmt: skip
    print(f"wrote {path} ({time.perf_counter() - start:.1f} s; GA checkpoints in {run_dir})")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the casestudy subcommand."""
    from replication.casestudy.evaluate import EXECUTORS
    from replication.cli.reports import DEFAULT_DIR, QUICK_DIR

    p = sub.add_parser(
        "casestudy",
        help="the water-jet genetic algorithm (section 6) into reports/casestudy.md (Figs. 8, 9)",
        description=(
            "Run the paper's genetic algorithm, which shapes a 101-point ADT surface to maximise the "
            "force of a water jet (scored by a validated thin-sheet momentum model), and write "
            "reports/casestudy.md with Figs. 8 and 9."
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
        "--run-dir", metavar="DIR", help="checkpoint directory (default: casestudy-runs/run-<time>)"
    )
    p.add_argument("--resume", action="store_true", help="continue the runs checkpointed in --run-dir")
    p.add_argument(
        "--executor", choices=EXECUTORS, default="auto", help="where fitness is evaluated (default auto)"
    )
    p.add_argument("--workers", type=positive_int, help="process-pool or local dask workers (default: CPUs)")
    p.add_argument(
        "--scheduler", metavar="ADDRESS", help="address of a running dask scheduler (implies dask)"
    )
    p.add_argument("--output-dir", metavar="DIR", help=f"reports directory (default {DEFAULT_DIR}/)")
    p.add_argument("--json", action="store_true", help="print one JSON object with the results")
    p.set_defaults(func=_cmd_casestudy)
