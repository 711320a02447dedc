"""Speed-up of the case study on worker processes (issue 15 item 1).

Run from the project's root: ``python -m benchmarks.casestudy_speedup [--repeats 3]``.

Runs the full ``replication casestudy`` command (the paper's settings: 3 runs x 50
generations x 48) on one core (``--workers 1`` with ``NUMBA_NUM_THREADS=1``), with ``--workers
1`` as it comes (in process, its compiled kernels on numba's threads: both cores of a 2-core
machine), with ``--workers 2`` (a process pool, one kernel thread per worker) and with
``--executor dask --workers 2`` (a local dask cluster), each into its own scratch
directories, in rounds: every round runs each configuration once, in an order rotated from
round to round, so that the load of a shared machine falls on all of them alike. For each
run it records

* ``command_s``: the wall time of the whole command (a fresh process: start-up, GA,
  reference shapes, the timing of one evaluation, the report and its figures);
* ``ga_s``: the GA alone (the sum of the generations' wall times, executor start-up
  included, from the run's provenance);
* ``cpu_s``: CPU time of the command and its children (the work, whatever the load).

Each round also measures what the machine itself gives (:func:`machine_ceiling`): the
throughput of two CPU-bound processes at once over one alone, 2 at best; a shared or
virtual machine gives less, and no executor can beat it.

Speed-ups are over one core: its median over each configuration's median, and per round (the
one-core run over the other run of the same round: median and range). ``--workers 2`` over
``--workers 1`` is the ratio of their two rows. The serial part of the command
(everything but the GA) bounds the command's speed-up by Amdahl's law; the table gives that
bound too. The output is a markdown table (stdout) and, with ``--json FILE``, the raw runs.
Timings on a shared machine are loaded-machine numbers: the output gives the load average
before each run and says so when it exceeds half the number of CPUs.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Config:
    """One configuration: its label, command-line options and the environment it adds."""

    label: str
    options: tuple[str, ...]
    env: tuple[tuple[str, str], ...] = ()


#: The configurations, by the name ``--only`` takes. The first is the reference of every
#: speed-up: one core. ``--workers 1`` alone is not one core: the command evaluates in its own
#: process, whose compiled kernels run on numba's threads (both cores of a 2-core machine; the
#: jet force splits its work in two), while executor workers run them on one thread each
#: (:func:`replication.surfaces._threads.one_thread`).
CONFIGS: dict[str, Config] = {
    "one-core": Config(
        "one core (--workers 1, NUMBA_NUM_THREADS=1)", ("--workers", "1"), (("NUMBA_NUM_THREADS", "1"),)
    ),
    "serial": Config("--workers 1 (its kernels on numba's threads)", ("--workers", "1")),
    "pool": Config("process pool (--workers 2)", ("--executor", "process", "--workers", "2")),
    "dask": Config(
        "dask LocalCluster (--executor dask --workers 2)", ("--executor", "dask", "--workers", "2")
    ),
}


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_once(config: Config, scratch: Path, settings: list[str]) -> dict[str, float]:
    """One ``replication casestudy`` command; its wall, GA and CPU seconds."""
    run_dir, out = Path(tempfile.mkdtemp(dir=scratch)), Path(tempfile.mkdtemp(dir=scratch))
    command = [sys.executable, "-m", "replication", "casestudy", *settings, *config.options]
    command += ["--run-dir", str(run_dir / "run"), "--output-dir", str(out)]
    cpu, started = _children_cpu(), time.perf_counter()
    env = {**os.environ, **dict(config.env)}
    done = subprocess.run(command, cwd=scratch, capture_output=True, text=True, env=env)
    wall, cpu = time.perf_counter() - started, _children_cpu() - cpu
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed:\n{done.stderr}")
    record = json.loads((out / "data" / "casestudy_provenance.json").read_text())
    return {"command_s": wall, "ga_s": float(record["ga_seconds"]), "cpu_s": cpu}


#: A CPU-bound loop of about a second, the same work in every process (no memory traffic, no I/O).
_SPIN = "s = 0\nfor i in range(15_000_000):\n    s += i * i\n"


def machine_ceiling(processes: int = 2) -> float:
    """Throughput of ``processes`` CPU-bound processes at once over one alone (ideal: ``processes``).

    What the machine itself gives for perfectly parallel work: on a virtual machine whose
    cores share a physical core or a host with other guests, less than the number of CPUs.
    """

    def wall(count: int) -> float:
        started = time.perf_counter()
        spinning = [subprocess.Popen([sys.executable, "-c", _SPIN]) for _ in range(count)]
        for process in spinning:
            process.wait()
        return time.perf_counter() - started

    return processes * wall(1) / wall(processes)


def _stats(values: list[float]) -> str:
    v = np.asarray(values)
    return f"{np.median(v):.2f} [{v.min():.2f}, {v.max():.2f}]"


def summarize(runs: dict[str, list[dict[str, float]]], ceilings: list[float] | None = None) -> str:
    """Markdown: medians with ranges, speed-ups of medians and per round, Amdahl's bound, the machine's."""
    serial_name = next(iter(runs))
    serial = runs[serial_name]
    lines = [
        f"Speed-ups over the first row, {serial_name}.",
        "",
        "| configuration | command s: median [min, max] | GA s | CPU s "
        "| speed-up command (medians; per round median [min, max]) | speed-up GA (medians; per round) |",
        "|---|---|---|---|---|---|",
    ]
    for name, rows in runs.items():
        cells = [name] + [_stats([r[k] for r in rows]) for k in ("command_s", "ga_s", "cpu_s")]
        for key in ("command_s", "ga_s"):
            ratio = np.median([r[key] for r in serial]) / np.median([r[key] for r in rows])
            paired = [s[key] / r[key] for s, r in zip(serial, rows)]
            cells.append(f"{ratio:.2f}x; {_stats(paired)}")
        lines.append("| " + " | ".join(cells) + " |")
    rest = np.median([r["command_s"] - r["ga_s"] for r in serial])
    ga = np.median([r["ga_s"] for r in serial])
    bound = (rest + ga) / (rest + ga / 2)
    lines.append("")
    others = "; ".join(
        f"{name} {np.median([r['command_s'] - r['ga_s'] for r in rows]):.2f} s" for name, rows in runs.items()
    )
    lines.append(
        f"Everything but the GA (start-up, reference shapes and timing, report; medians): {others}. "
        f"Were it all serial, a perfect GA speed-up on 2 workers would bound the command at {bound:.2f}x "
        "over the first row."
    )
    if ceilings:
        lines.append(
            f"The machine itself: two CPU-bound processes at once did {_stats(ceilings)} times the work "
            "of one alone in the same time (median [min, max] over the rounds; 2 is ideal)."
        )
    return "\n".join(lines)


def chosen(only: list[str] | None) -> list[str]:
    """The configurations to run, in :data:`CONFIGS`'s order; the one-core reference always first."""
    reference = next(iter(CONFIGS))
    return [name for name in CONFIGS if name == reference or not only or name in only]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="rounds (default 3)")
    parser.add_argument("--quick", action="store_true", help="the --quick GA, to try the script")
    parser.add_argument("--only", choices=list(CONFIGS), action="append", help="configurations to run")
    parser.add_argument("--json", metavar="FILE", help="write the raw runs as JSON")
    args = parser.parse_args(argv)
    from benchmarks.common import warn_if_stale_kernels

    warn_if_stale_kernels()
    settings = ["--quick"] if args.quick else []
    names = chosen(args.only)
    runs: dict[str, list[dict[str, float]]] = {name: [] for name in names}
    loads, ceilings = [], []
    with tempfile.TemporaryDirectory(prefix="casestudy-speedup-") as scratch:
        for k in range(args.repeats):
            ceilings.append(machine_ceiling())
            print(f"round {k + 1}: the machine: {ceilings[-1]:.2f}x", file=sys.stderr, flush=True)
            order = names[k % len(names) :] + names[: k % len(names)]
            for name in order:
                loads.append(os.getloadavg()[0])
                result = run_once(CONFIGS[name], Path(scratch), settings)
                runs[name].append(result)
                print(f"round {k + 1}: {name}: {result}", file=sys.stderr, flush=True)
    cpus, load = os.cpu_count() or 1, max(loads)
    loaded = " (a LOADED machine: these are loaded-machine numbers)" if load > cpus * 0.5 else ""
    print(
        f"Full case study{' (--quick)' if args.quick else ''}, {args.repeats} rounds, {cpus} CPUs, "
        f"1-minute load average before each run {min(loads):.1f}-{load:.1f}{loaded}"
    )
    print()
    print(summarize({CONFIGS[name].label: rows for name, rows in runs.items()}, ceilings))
    if args.json:
        record = {"loads": loads, "cpus": cpus, "ceilings": ceilings, "runs": runs}
        Path(args.json).write_text(json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
