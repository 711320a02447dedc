"""Score many surfaces with SPH: a content-addressed cache on disk, resumable, on any executor.

:func:`score_surfaces` takes surfaces, SPH settings and a :class:`concurrent.futures.Executor`
and returns one :class:`Scored` per surface. Every simulation's outcome is a directory of
files in the cache, named by :func:`cache_key`, a SHA-256 of

* the surface (vertex coordinates and triangles, bytes as given), the jet and the settings;
* the engine's full version;
* :func:`code_digest`, a digest of the SPH package's own source files
  (``replication/casestudy/sph/*.py``), so results of older driver or analysis code are
  never reused.

A simulation runs in a scratch directory beside its entry and is renamed into place when
it has finished, by the worker that ran it: an entry is complete or absent, an interrupted
run (Ctrl-C, a killed worker, a power cut) leaves nothing that a later call would trust,
and a rerun skips every finished simulation. Failures (blow-up, timeout, crash) are entries
too, with their reason; they are not retried unless asked. At most ``max_parallel``
simulations are in flight at once (each uses one core in its own child process), so an
interrupt never leaves queued work behind.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import dataclasses
import functools
import hashlib
import json
import os
import shutil
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from replication.casestudy.jetconfig import JetConfig
from replication.errors import InputError, OutputError, SimulationError, no_room
from replication.io.atomic import writer_gone, writer_tag

__all__ = [
    "CACHE_FORMAT",
    "CACHE_ENV",
    "DEFAULT_CACHE_DIR",
    "default_cache_dir",
    "Plan",
    "Scored",
    "SurfaceTask",
    "cache_key",
    "cached_sph_force",
    "code_digest",
    "prepare_cache",
    "entry_path",
    "read_entry",
    "score_surfaces",
]

#: Where the cache lives unless the caller says otherwise (relative to the working directory).
DEFAULT_CACHE_DIR = ".sph-cache"
#: Environment variable naming the SPH cache (``validate-jet`` and ``reproduce``), e.g. one
#: kept in another checkout: the cache is gitignored and hours of SPH to refill.
CACHE_ENV = "REPLICATION_SPH_CACHE"
#: Version of the cache layout (part of the key).
CACHE_FORMAT = 1
#: Files of a finished simulation that are dropped from its entry (regenerable, large).
DROPPED = ("column.pda", "progress.json")
STATUSES = ("ok", "blowup", "timeout", "crash", "error", "missing")


@functools.lru_cache(maxsize=1)
def code_digest() -> str:
    """SHA-256 of the SPH package's source files: their names and bytes, in name order."""
    from replication.casestudy import sph

    digest = hashlib.sha256()
    for path in sorted(Path(sph.__file__).parent.glob("*.py")):
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


@dataclass(frozen=True, eq=False)
class SurfaceTask:
    """A named surface to score: vertices (mm) and triangles of a height field."""

    name: str
    points: np.ndarray
    triangles: np.ndarray

    def __post_init__(self) -> None:
        points = np.array(self.points, dtype=np.float64)
        triangles = np.array(self.triangles)
        if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
            raise InputError(
                f"surface {self.name!r}: points must be finite, shape (n, 3), got {points.shape}"
            )
        if triangles.ndim != 2 or triangles.shape[1] != 3 or not np.issubdtype(triangles.dtype, np.integer):
            raise InputError(
                f"surface {self.name!r}: triangles must be integer indices of shape (m, 3), "
                f"got {triangles.dtype} {triangles.shape}"
            )
        triangles = triangles.astype(np.int64)
        points.flags.writeable = False
        triangles.flags.writeable = False
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "triangles", triangles)

    @classmethod
    def from_surface(cls, name: str, surface: Any) -> SurfaceTask:
        """From an ADT :class:`~replication.surfaces.Surface` built with ``depth="z"``."""
        if surface.depth_axis != 2:
            raise InputError(f"surface {name!r}: the jet needs a height field over x-y (depth axis z)")
        return cls(name, surface.points, surface.triangles)


@dataclass(frozen=True)
class Plan:
    """What :func:`score_surfaces` will do, known once the cache is read (before any simulation).

    Counts of distinct surfaces: read from the cache (``cached``, failed simulations
    included), absent from it when simulating is not allowed (``missing``), and to be
    simulated (``to_simulate``), of which ``at_once`` run at a time.
    """

    cached: int
    missing: int
    to_simulate: int
    at_once: int

    @property
    def distinct(self) -> int:
        return self.cached + self.missing + self.to_simulate


@dataclass(frozen=True, eq=False)
class Scored:
    """The SPH score of one surface: the simulation's result, or why there is none.

    ``status`` is the simulation's ("ok", "blowup", "timeout", "crash"), "error" when the
    task itself failed (an invalid surface, a dead worker; not cached), or "missing" when
    the cache had no entry and simulating was not allowed.
    """

    name: str
    key: str
    status: str
    reason: str | None
    result: Any  # SPHForce or None
    cached: bool  # read from the cache rather than simulated by this call
    path: Path | None  # the cache entry

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def cache_key(
    points: np.ndarray, triangles: np.ndarray, jet: JetConfig, settings: Any, *, engine: str | None = None
) -> str:
    """Content key of a simulation: surface, jet, settings, engine version, SPH code digest."""
    from replication.casestudy.sph import engine_version

    head = {
        "format": CACHE_FORMAT,
        "engine": engine if engine is not None else engine_version(),
        "code": code_digest(),
        "jet": dataclasses.asdict(jet),
        "settings": settings.as_dict(),
        "shape": [list(np.shape(points)), list(np.shape(triangles))],
    }
    digest = hashlib.sha256(json.dumps(head, sort_keys=True).encode())
    digest.update(np.ascontiguousarray(points, dtype="<f8").tobytes())
    digest.update(np.ascontiguousarray(triangles, dtype="<i8").tobytes())
    return digest.hexdigest()


def default_cache_dir() -> Path:
    """The SPH cache the commands use: ``$REPLICATION_SPH_CACHE`` if set (and not empty), else
    ``.sph-cache`` in the working directory."""
    return Path(os.environ.get(CACHE_ENV) or DEFAULT_CACHE_DIR)


def entry_path(cache_dir: str | os.PathLike[str], key: str) -> Path:
    """The directory of a cache entry: ``cache_dir/<key[:2]>/<key>``."""
    return Path(cache_dir) / key[:2] / key


def read_entry(cache_dir: str | os.PathLike[str], key: str) -> Any:
    """The SPHForce of a finished entry, or None (absent or unreadable)."""
    from replication.casestudy.sph import read_result

    path = entry_path(cache_dir, key) / "result.json"
    if not path.is_file():
        return None
    try:
        return read_result(path)
    except (ValueError, KeyError, TypeError, OSError):
        return None


#: Between a cache key and the writer's tag in the name of a simulation's scratch directory.
PARTIAL = ".partial-"


def _remove_abandoned_scratch(cache_dir: Path) -> None:
    """Remove the scratch directories of simulations whose process has ended: a simulation
    killed outright (SIGKILL, a lost machine) cannot remove its own, and the cache kept them
    for good. Another machine's, or a running process's, are kept."""
    for path in cache_dir.glob(f"??/.*{PARTIAL}*"):
        if writer_gone(path.name.split(PARTIAL, 1)[1]):
            shutil.rmtree(path, ignore_errors=True)


def _simulate_into_cache(
    task: SurfaceTask,
    jet: JetConfig,
    settings: Any,
    cache_dir: str,
    key: str,
    timeout: float | None,
    simulate: Callable[..., Any] | None,
) -> Any:
    """Run one simulation in a scratch directory and rename it into the cache (in the worker)."""
    from replication.casestudy.sph import read_result, sph_force

    simulate = simulate or sph_force
    final = entry_path(cache_dir, key)
    final.parent.mkdir(parents=True, exist_ok=True)
    scratch = final.parent / f".{key}{PARTIAL}{writer_tag()}{uuid.uuid4().hex[:8]}"
    try:
        result = simulate(task.points, task.triangles, jet, settings, timeout=timeout, run_dir=scratch)
        surface = {"name": task.name, "points": task.points.tolist(), "triangles": task.triangles.tolist()}
        (scratch / "surface.json").write_text(json.dumps(surface) + "\n")
        for name in DROPPED:
            with contextlib.suppress(FileNotFoundError):
                (scratch / name).unlink()
        shutil.rmtree(scratch / "engine", ignore_errors=True)
        for _ in range(3):
            if final.exists():  # a failure being retried, or another process finished it first
                published = read_entry(cache_dir, key)
                if published is not None and published.ok:
                    return read_result(final / "result.json")
                shutil.rmtree(final, ignore_errors=True)
            try:
                os.replace(scratch, final)
                break
            except OSError:  # another command published the entry since the check: use it
                if not final.exists():
                    raise
        else:
            raise SimulationError(f"could not publish the simulation {key} into the cache {cache_dir}")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return dataclasses.replace(result, run_dir=str(final))


def prepare_cache(cache_dir: str | os.PathLike[str]) -> Path:
    """Create the cache directory if needed and remove the scratch directories that killed
    simulations left in it (:func:`score_surfaces` does this for its own runs)."""
    cache_dir = Path(cache_dir)
    cache_dir.mkdir(parents=True, exist_ok=True)
    _remove_abandoned_scratch(cache_dir)
    return cache_dir


def reusable(result: Any, timeout: float) -> bool:
    """Whether :func:`cached_sph_force` takes a cache entry's result as it is: a success, a
    blow-up (the flow's own outcome, the same on every rerun) or a timeout under a limit at
    least ``timeout``. An absent entry, a crash (a full disk, no memory: the machine's, not the
    flow's) or a timeout under a shorter limit is simulated again."""
    return result is not None and (
        result.ok
        or result.status == "blowup"
        or (result.status == "timeout" and result.wall_seconds >= 0.99 * timeout)
    )


def cached_sph_force(
    points: np.ndarray,
    triangles: np.ndarray,
    jet: JetConfig,
    settings: Any,
    *,
    cache_dir: str | os.PathLike[str],
    timeout: float | None = None,
    name: str = "surface",
) -> Any:
    """:func:`~.sph.sph_force` through the cache: the entry's result when there is one, else
    simulated here and published into the cache, so that a run stopped by Ctrl-C keeps every
    simulation it finished (the SPH study kept none). A cached blow-up is the flow's outcome
    and is reused; a crash (the machine's: no memory, a full disk) or a timeout under a
    shorter limit is simulated again.
    """
    from replication.casestudy.sph import DEFAULT_TIMEOUT

    timeout = DEFAULT_TIMEOUT if timeout is None else timeout
    key = cache_key(points, triangles, jet, settings)
    result = read_entry(cache_dir, key)
    if reusable(result, timeout):
        return result
    Path(cache_dir).mkdir(parents=True, exist_ok=True)
    task = SurfaceTask(name, points, triangles)
    return _simulate_into_cache(task, jet, settings, str(cache_dir), key, timeout, None)


def score_surfaces(
    tasks: Sequence[SurfaceTask],
    settings: Any,
    *,
    jet: JetConfig | None = None,
    cache_dir: str | os.PathLike[str] = DEFAULT_CACHE_DIR,
    executor: cf.Executor | None = None,
    max_parallel: int = 2,
    timeout: float | None = None,
    retry_failed: bool = False,
    simulate_missing: bool = True,
    on_result: Callable[[Scored], None] | None = None,
    simulate: Callable[..., Any] | None = None,
    on_plan: Callable[[Plan], None] | None = None,
) -> list[Scored]:
    """SPH scores of surfaces, from the cache where it has them, else simulated on ``executor``.

    Parameters
    ----------
    tasks : sequence of SurfaceTask
        The surfaces (equal surfaces are simulated once).
    settings : SPHSettings
    jet : JetConfig, optional
        Default: the paper's half jet.
    cache_dir : path
        The cache (created when needed). With a dask cluster it must be shared by the workers.
    executor : concurrent.futures.Executor, optional
        Where simulations run (a process pool, ``Client.get_executor()``); default: one at a
        time in this process.
    max_parallel : int
        Simulations in flight at once.
    timeout : float or None
        Wall-clock limit of one simulation (s); default that of :func:`~.sph.sph_force`.
    retry_failed : bool
        Simulate again the surfaces whose cached simulation failed.
    simulate_missing : bool
        False: never simulate; a surface without an entry gets status "missing".
    on_result : callable, optional
        Called with each :class:`Scored` as it becomes known (progress display).
    simulate : callable, optional
        Replaces :func:`~.sph.sph_force` (same signature; picklable by reference): for tests.
    on_plan : callable, optional
        Called once the cache is read, before ``on_result`` is called for any surface, with
        the :class:`Plan`: the distinct surfaces read from the cache, missing from it, and to
        be simulated, and how many run at once (a cost estimate).

    Returns
    -------
    list of Scored
        In the order of ``tasks``.

    Notes
    -----
    Paper section 6: every surface of the case study scored by an SPH simulation.
    """
    from replication.casestudy.sph import DEFAULT_TIMEOUT, require_engine
    from replication.casestudy.sph.settings import SPHSettings

    if not isinstance(settings, SPHSettings):
        raise InputError(f"settings must be SPHSettings, got {type(settings).__name__}")
    if isinstance(max_parallel, bool) or not isinstance(max_parallel, int) or max_parallel < 1:
        raise InputError(f"max_parallel must be a positive integer, got {max_parallel!r}")
    jet = JetConfig() if jet is None else jet
    timeout = DEFAULT_TIMEOUT if timeout is None else timeout
    engine = require_engine() if simulate is None else "test"
    cache_dir = Path(cache_dir)
    keys = [cache_key(t.points, t.triangles, jet, settings, engine=engine) for t in tasks]
    done: dict[str, Scored] = {}
    todo: dict[str, SurfaceTask] = {}

    def record(scored: Scored) -> None:
        done[scored.key] = scored
        if on_result is not None:
            on_result(scored)

    given: dict[str, Scored] = {}  # not simulated: reported after the plan
    for task, key in zip(tasks, keys):
        if key in todo or key in given:
            continue
        result = read_entry(cache_dir, key)
        if result is not None and result.status == "timeout" and result.wall_seconds < 0.99 * timeout:
            result = None  # it timed out under a shorter limit than this run's: simulate it again
        if result is not None and (result.ok or not retry_failed):
            path = entry_path(cache_dir, key)
            given[key] = Scored(task.name, key, result.status, result.reason, result, True, path)
        elif simulate_missing:
            todo[key] = task
        else:
            given[key] = Scored(task.name, key, "missing", "not in the SPH cache", None, False, None)
    if on_plan is not None:
        missing = sum(s.status == "missing" for s in given.values())
        on_plan(Plan(len(given) - missing, missing, len(todo), min(max_parallel, len(todo))))
    for scored in given.values():
        record(scored)
    if todo:
        cache_dir.mkdir(parents=True, exist_ok=True)
        _remove_abandoned_scratch(cache_dir)
        _run(todo, jet, settings, cache_dir, timeout, simulate, executor, max_parallel, record)
    return [dataclasses.replace(done[key], name=task.name) for task, key in zip(tasks, keys)]


def _run(todo, jet, settings, cache_dir, timeout, simulate, executor, max_parallel, record) -> None:
    """Simulate ``todo`` (key -> task), at most ``max_parallel`` at a time."""
    from replication.casestudy.evaluate import SerialExecutor, run_bounded

    def finished(key: str, future: cf.Future) -> None:
        task = todo[key]
        try:
            result = future.result()
        except Exception as exc:  # the task failed (not the simulation): record, carry on...
            if no_room(exc):  # ...unless the cache cannot take any simulation (a full disk)
                raise OutputError(
                    f"cannot simulate into the SPH cache {cache_dir}: {exc}; the simulations finished "
                    "before are kept there: once it can take more, run the command again"
                ) from exc
            record(Scored(task.name, key, "error", f"{type(exc).__name__}: {exc}", None, False, None))
            return
        path = entry_path(cache_dir, key)
        record(Scored(task.name, key, result.status, result.reason, result, False, path))

    tasks = [
        (key, _simulate_into_cache, (task, jet, settings, str(cache_dir), key, timeout, simulate))
        for key, task in todo.items()
    ]
    pool = executor if executor is not None else SerialExecutor()
    try:  # a running simulation finishes into the cache; those not started are cancelled
        run_bounded(pool, tasks, max_parallel, finished)
    except cf.BrokenExecutor as exc:
        raise SimulationError(
            f"the executor broke ({exc}); finished simulations are cached: run again to resume"
        ) from exc
