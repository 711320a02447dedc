"""Helpers shared by the subcommands: cloud sources, frame options, parsing, output."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import warnings
from collections.abc import Iterator
from typing import Any

import numpy as np

from replication.cpus import usable_cpus
from replication.errors import DuplicatePointsWarning, InputError, ReplicationError, UsageError, escaped

__all__ = [
    "about_the_input",
    "add_cloud_source",
    "add_frame_options",
    "directory_name",
    "draw_command",
    "emit_json",
    "file_name",
    "finite_float",
    "finite_positive",
    "frame_kwargs",
    "int_between",
    "load_or_generate",
    "pair",
    "positive_int",
    "positive_within",
    "relay_warnings",
    "seed",
    "significance",
    "usable_cpus",
    "warm_up",
    "worker_count",
]


def _int_at_least(minimum: int, what: str):
    """An argparse type accepting integers >= ``minimum``; ``what`` names them in errors."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected {what}, got {value}")
        return value

    return parse


#: argparse type: an integer >= 1.
positive_int = _int_at_least(1, "a positive integer")


def int_between(minimum: int, maximum: int, what: str):
    """An argparse type accepting integers in ``minimum .. maximum``; ``what`` names them."""
    at_least = _int_at_least(minimum, what)

    def parse(text: str) -> int:
        value = at_least(text)
        if value > maximum:
            raise argparse.ArgumentTypeError(f"expected {what}, got {value}")
        return value

    return parse


#: argparse type: a non-negative integer seed.
seed = _int_at_least(0, "a non-negative integer seed")

#: Local worker processes per CPU at most (``--workers``): a process pool starts all its
#: workers at once, each holding the package (about 80-100 MB), and more than a few per core
#: only compete for the cores; ``--workers 100000`` started processes until memory ran out.
WORKERS_PER_CPU = 4


def worker_count(text: str) -> int:
    """argparse type: a number of local worker processes, 1 to :data:`WORKERS_PER_CPU` per CPU."""
    value = positive_int(text)
    cpus = usable_cpus()
    if value > WORKERS_PER_CPU * cpus:
        raise argparse.ArgumentTypeError(
            f"at most {WORKERS_PER_CPU * cpus} worker processes on this machine's {cpus} CPU(s) "
            f"({WORKERS_PER_CPU} per CPU: more only compete for its cores and memory), got {value}"
        )
    return value


def _float(text: str, what: str) -> float:
    # Python reads "1_8" as 18; the cloud files refuse it, and so does the command line
    if "_" in text:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None


def finite_positive(text: str) -> float:
    """argparse type: a finite number > 0 (``inf`` and ``nan`` are refused)."""
    value = _float(text, "a positive number")
    if not (np.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a finite positive number, got {text!r}")
    return value


def finite_float(text: str) -> float:
    """argparse type: a finite number (``inf`` and ``nan`` are refused)."""
    value = _float(text, "a number")
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def positive_within(low: float, high: float, noun: str, unit: str, why: str):
    """An argparse type for a positive size the code can only hold in ``[low, high]``.

    The error for zero or a negative size says that it must be positive; only a positive size
    outside the bounds hears the bound it crossed and ``why`` there is one (quoting the range
    for ``0`` sent users to a bound such as 1e-57 that had nothing to do with their mistake).
    """

    def parse(text: str) -> float:
        value = _float(text, f"a finite positive {noun} in {unit}")
        if not (np.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"expected a finite positive {noun} in {unit}, got {text!r}")
        if not low <= value <= high:
            bound = f"at least {low:g}" if value < low else f"at most {high:g}"
            raise argparse.ArgumentTypeError(f"expected a {noun} of {bound} {unit} ({why}), got {text!r}")
        return value

    return parse


def significance(text: str) -> float:
    """argparse type: a significance level strictly between 0 and 0.5 (the equivalence test's
    interval has confidence 1 - 2 alpha)."""
    value = _float(text, "a significance level between 0 and 0.5")
    if not 0 < value < 0.5:
        raise argparse.ArgumentTypeError(
            f"expected a significance level strictly between 0 and 0.5 (the equivalence interval has "
            f"confidence 1 - 2 alpha), got {text!r}"
        )
    return value


def _name(what: str):
    """An argparse type accepting any name but the empty one; ``what`` names it in errors."""

    def parse(text: str) -> str:
        if not text:
            raise argparse.ArgumentTypeError(f"expected {what}, got ''")
        return text

    return parse


#: argparse type: the name of a file to write, not empty (``--save-cloud ''`` was ignored).
file_name = _name("a file name")
#: argparse type: the name of a directory, not empty (``--output-dir ''`` meant the default).
directory_name = _name("a directory name")


def pair(text: str) -> tuple[int, int]:
    """argparse type: ``"5x9"`` -> (5, 9)."""
    parts = text.lower().replace("*", "x").split("x")
    try:
        a, b = (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected two integers like 5x9, got {text!r}") from None
    if a < 1 or b < 1:
        raise argparse.ArgumentTypeError(f"expected positive sizes like 5x9, got {text!r}")
    return a, b


def samples(text: str) -> tuple[int, int]:
    """argparse type: ``"50x50"`` -> (50, 50), at least 2 per direction (a grid of samples)."""
    a, b = pair(text)
    if a < 2 or b < 2:  # was: the library's "sample_shape must be ...", an argument no user typed
        raise argparse.ArgumentTypeError(
            f"expected at least 2 samples per direction like 50x50, got {text!r}"
        )
    return a, b


def add_cloud_source(p: argparse.ArgumentParser) -> None:
    """INPUT or a generated cloud (--random N, --seed, --box, --step, --save-cloud)."""
    from replication.io import CLOUD_SUFFIXES

    p.add_argument(
        "input",
        nargs="?",
        metavar="INPUT",
        help=f"point-cloud file ({', '.join(CLOUD_SUFFIXES)}); omit when using --random",
    )
    g = p.add_argument_group("random cloud (instead of INPUT)")
    g.add_argument("--random", type=positive_int, metavar="N", help="generate N random points")
    g.add_argument(
        "--seed", type=seed, default=None, metavar="S", help="random seed (default: fresh entropy)"
    )
    g.add_argument(
        "--box",
        type=float,
        nargs=6,
        metavar=("XMIN", "XMAX", "YMIN", "YMAX", "ZMIN", "ZMAX"),
        help="domain of the random cloud (default: the case study's 0 36 0 30 0 13, in mm)",
    )
    g.add_argument(
        "--step",
        type=finite_positive,
        metavar="H",
        help="draw coordinates on a lattice of step H (the case study: 1)",
    )
    g.add_argument(
        "--save-cloud",
        type=file_name,
        metavar="FILE",
        help="also write the generated points (.csv, .txt, .xyz, .npy)",
    )


def add_frame_options(p: argparse.ArgumentParser) -> None:
    """--depth, --duplicates, --backend: how a cloud becomes a height field."""
    from replication.surfaces import BACKENDS, DEPTH_RULES, DUPLICATE_POLICIES

    p.add_argument(
        "--depth",
        choices=DEPTH_RULES,
        default="min",
        help="depth axis: the axis of min or max spread, or an imposed axis (default: min)",
    )
    p.add_argument(
        "--duplicates",
        choices=DUPLICATE_POLICIES,
        default="mean",
        help="points sharing a projected position: merge with the mean/min/max/first depth, "
        "or raise an error (default: mean)",
    )
    p.add_argument(
        "--backend",
        choices=BACKENDS,
        default="auto",
        help="2-D Delaunay backend (default: auto = sweephull, Qhull if rounding defeats it)",
    )


def frame_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """The frame options (--depth, --duplicates, --backend) as keyword arguments."""
    return {"depth": args.depth, "duplicates": args.duplicates, "backend": args.backend}


def load_or_generate(args: argparse.Namespace) -> tuple[np.ndarray, str, dict[str, Any]]:
    """The cloud named by INPUT or generated by --random; a label; generation metadata."""
    from replication.cli.resources import check_random_cloud
    from replication.io import load_cloud
    from replication.surfaces import CASE_STUDY_BOX, Box, random_cloud

    if args.random is None:
        if args.input is None:
            raise UsageError("give a point-cloud file INPUT, or --random N for a generated cloud")
        if not str(args.input):  # as an empty -o is: a misused command line
            raise UsageError("INPUT is empty: give the name of a point-cloud file")
        for flag in ("seed", "box", "step", "save_cloud"):
            if getattr(args, flag) is not None:
                raise UsageError(f"--{flag.replace('_', '-')} applies only with --random")
        return load_cloud(args.input), str(args.input), {}
    if args.input is not None:
        raise UsageError(f"give either INPUT ({args.input}) or --random, not both")
    try:
        box = CASE_STUDY_BOX if args.box is None else Box.from_bounds(args.box)
    except InputError as exc:  # bounds out of order: a misused --box, refused before any work
        raise UsageError(f"--box {' '.join(f'{v:g}' for v in args.box)}: {exc}") from exc
    if args.step is not None:
        _check_lattice(box, args.step)
    writes = args.save_cloud is not None or (
        args.command == "adt" and getattr(args, "output", None) is not None
    )
    check_random_cloud(args.random, args.command, writes)  # was killed by the kernel past a billion points
    seed = args.seed if args.seed is not None else int(np.random.SeedSequence().entropy % 2**32)
    cloud = random_cloud(args.random, box, step=args.step, rng=seed)
    meta: dict[str, Any] = {
        "seed": seed,
        "box": [box.xmin, box.xmax, box.ymin, box.ymax, box.zmin, box.zmax],
        "step": args.step,
    }
    return cloud, f"{args.random} random points (seed {seed})", meta


def _check_lattice(box: Any, step: float) -> None:
    """Refuse a --step that leaves fewer than two lattice values on two of the box's axes.

    Every point of such a lattice lies on one line (or is one point), and the build failed
    with "need at least 3 distinct projected points, got 1", which named neither the step
    nor the box.
    """
    from replication.surfaces.cloud import lattice_count

    bounds = [(box.xmin, box.xmax), (box.ymin, box.ymax), (box.zmin, box.zmax)]
    try:
        counts = [lattice_count(lo, hi, step) for lo, hi in bounds]
    except InputError as exc:
        raise UsageError(f"--step {step:g}: {exc}") from exc
    if sum(count >= 2 for count in counts) >= 2:
        return
    sides = sorted((hi - lo for lo, hi in bounds), reverse=True)
    raise UsageError(
        f"--step {step:g} leaves a lattice of {' x '.join(map(str, counts))} value(s) in the box, so every "
        f"point lies on one line and no surface can be built; use a step of at most {sides[1]!r}, the "
        "box's second-longest side"
    )


def warm_up(kind: str, args: argparse.Namespace) -> float:
    """Load the compiled kernels a build uses (once per process); return the seconds it took.

    Timings reported as ``build_seconds`` then measure the build itself, not the start-up.
    """
    import time

    u, v = np.meshgrid([0.0, 1.0, 2.0], [0.0, 1.0, 2.0])
    points = np.column_stack([u.ravel(), v.ravel(), 0.1 * (u * v).ravel()])  # 3 x 3: enough for degree 2
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if kind == "nurbs":
            from replication.surfaces.nurbs import fit_nurbs

            fit_nurbs(points, tessellation=(3, 3), evaluator=args.evaluator, backend=args.backend)
        else:
            from replication.surfaces import adt

            adt(points, depth="z", backend=args.backend)
    return time.perf_counter() - start


@contextlib.contextmanager
def relay_warnings() -> Iterator[list[warnings.WarningMessage]]:
    """Collect warnings; on exit (an error too) print all but duplicate merges (reported by the command)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            yield caught
        finally:
            for w in caught:
                if not issubclass(w.category, DuplicatePointsWarning):
                    print(f"warning: {escaped(str(w.message))}", file=sys.stderr)


@contextlib.contextmanager
def about_the_input(args: argparse.Namespace) -> Iterator[None]:
    """Around the work on the data of the command's input file: an error about them that does
    not name the file gets its name first ("need at least 3 distinct projected points, got 2"
    did not say which file had two). Errors about options, raised outside the block, do not."""
    from replication.errors import CloudFileError, shortened

    try:
        yield
    except InputError as exc:
        source = getattr(args, "input", None)
        text = str(exc)
        named = source is not None and (str(source) in text or shortened(source) in text)
        if source is None or named or isinstance(exc, (UsageError, CloudFileError)):
            raise
        raise type(exc)(f"{shortened(source)}: {text}") from exc


def draw_command(out: Any) -> str:
    """The command that draws the reports in ``out`` from their saved data."""
    import shlex

    from replication.report.store import dashless

    return shlex.join(["replication", "report", "--output-dir", dashless(out)])


@contextlib.contextmanager
def saving_data(out: Any) -> Iterator[None]:
    """Around saving report data into ``out/data``: a wait for another command's save is said,
    and a Ctrl-C (or SIGTERM) held while the files were moved into place says that they are
    saved and how to draw the report (the command's last line names the files)."""
    from pathlib import Path

    from replication.io.atomic import written_before

    try:
        with say_when_publishing_waits():
            yield
    except KeyboardInterrupt as exc:
        if written_before(exc):
            print(f"interrupted once the data were saved in {Path(out) / 'data'}: draw the report with: "
                  f"{draw_command(out)}", file=sys.stderr)  # fmt: skip
        raise


@contextlib.contextmanager
def drawing_saved_data(out: Any, page: str) -> Iterator[None]:
    """Around drawing the report ``page`` from the data just saved into ``out/data``: an error
    (a full disk) leaves the page and figures of an earlier run beside the new data, or some of
    them redrawn, so its one line also says that the data are saved and how to draw the report;
    so does a line before the command's last after a Ctrl-C. An earlier run's page that was
    not drawn again gets a note saying that it is out of date
    (:func:`replication.report.pages.mark_out_of_date`)."""
    from pathlib import Path

    from replication.io.atomic import written_before

    draw = draw_command(out)
    path = Path(out) / page
    try:
        earlier = path.read_bytes()
    except OSError:
        earlier = None
    try:
        yield
    except ReplicationError as exc:
        _mark_if_not_drawn(path, earlier, draw)
        raise type(exc)(
            f"{exc}; the new data are saved in {out}/data: once that is fixed, draw the report with: {draw}"
        ) from exc
    except KeyboardInterrupt as exc:
        if not written_before(exc):  # (else it was drawn: the command's last line names its files)
            _mark_if_not_drawn(path, earlier, draw)
            print(f"interrupted while drawing the report: its data are saved in {Path(out) / 'data'}; "
                  f"draw it with: {draw}", file=sys.stderr)  # fmt: skip
        raise


def _mark_if_not_drawn(path: Any, earlier: bytes | None, draw: str) -> None:
    """Mark the page at ``path`` out of date when it is still the earlier run's (``earlier``),
    and the index beside it, which is drawn after the page: its headline is the earlier run's."""
    from replication.report.pages import mark_out_of_date

    try:
        if earlier is not None and path.read_bytes() == earlier:  # (drawn anew, or gone: not marked)
            mark_out_of_date(path, draw)
        mark_out_of_date(path.parent / "index.md", draw)
    except (OSError, ReplicationError):  # the disk that failed the drawing: the message says it
        return


@contextlib.contextmanager
def say_when_publishing_waits() -> Iterator[None]:
    """Print a line when saving report data waits for another command's save into the same
    directory (it was silent: a save stopped with Ctrl-Z held the other without a word)."""
    from replication.report.store import PUBLISH_WAIT

    def notice(data: Any) -> None:
        print(f"waiting for another command to finish saving its data into {data} ...", file=sys.stderr)

    token = PUBLISH_WAIT.set(notice)
    try:
        yield
    finally:
        PUBLISH_WAIT.reset(token)


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    if isinstance(value, float) and not np.isfinite(value):
        return None if np.isnan(value) else ("inf" if value > 0 else "-inf")
    return value


def emit_json(report: dict[str, Any]) -> None:
    """Print one JSON object (NaN becomes null so that strict parsers accept it)."""
    print(json.dumps(_jsonable(report), allow_nan=False))


def say_simulations_finish() -> None:
    """What a first Ctrl-C does to SPH simulations under way (see :func:`.evaluate.executor`)."""
    print(
        "stopping: the simulations under way finish into the cache first (Ctrl-C again abandons them)",
        file=sys.stderr,
        flush=True,
    )
