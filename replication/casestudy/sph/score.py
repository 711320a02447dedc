"""Score a surface with SPlisHSPlasH: validate, build the scene, run the child, summarise.

:func:`sph_force` is a pure function of its arguments (one thread: bit-for-bit repeatable),
picklable by reference, and returns a JSON-serialisable :class:`SPHForce` whose ``key``
is a content hash of (surface, jet, settings): what a cache or an executor needs to score
many surfaces.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import importlib.util
import json
from collections.abc import Callable
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from replication.casestudy.jet import JetConfig
from replication.casestudy.mesh import check_domain, check_height_field, weld
from replication.casestudy.sph.analysis import read_steps, summarize_force
from replication.casestudy.sph.geometry import mirror_about_y
from replication.casestudy.sph.process import run_child
from replication.casestudy.sph.result import FORMAT_VERSION, SPHForce, write_result, write_series
from replication.casestudy.sph.scene import write_scene
from replication.casestudy.sph.settings import SPHSettings
from replication.casestudy.units import to_metres
from replication.errors import InputError, SolverUnavailableError

if TYPE_CHECKING:  # pragma: no cover
    from replication.surfaces import Surface

__all__ = [
    "DEFAULT_TIMEOUT",
    "ENGINE",
    "INSTALL_HINT",
    "content_key",
    "engine_available",
    "engine_version",
    "require_engine",
    "sph_force",
    "surface_sph_force",
]

#: The engine's module (probed with importlib.util.find_spec, never imported here).
ENGINE = "pysplishsplash"
#: The engine's supported release series.
ENGINE_SERIES = "2.19"
INSTALL_HINT = 'pip install ".[sph]" in the project\'s checkout'
#: Wall-clock limit of one simulation (s) unless the caller gives one.
DEFAULT_TIMEOUT = 1800.0


def engine_available() -> bool:
    """Whether the engine is installed (without importing it: its import can crash)."""
    return importlib.util.find_spec(ENGINE) is not None


def engine_version() -> str | None:
    try:
        return metadata.version(ENGINE)
    except metadata.PackageNotFoundError:
        return None


def require_engine() -> str:
    """The engine's version; :class:`SolverUnavailableError` naming the fix when it is missing."""
    version = engine_version()
    if not engine_available() or version is None:
        raise SolverUnavailableError(
            f"the SPH solver (SPlisHSPlasH's Python bindings, pysplishsplash {ENGINE_SERIES}) is not "
            f"installed: {INSTALL_HINT}"
        )
    if not (version == ENGINE_SERIES or version.startswith(ENGINE_SERIES + ".")):
        raise SolverUnavailableError(
            f"the SPH backend needs pysplishsplash {ENGINE_SERIES}.x, found {version}: {INSTALL_HINT}"
        )
    return version


def content_key(points: np.ndarray, triangles: np.ndarray, config: JetConfig, settings: SPHSettings) -> str:
    """SHA-256 of a simulation's inputs: surface (metres), jet, settings, engine series, format.

    Stable across processes and machines (no Python ``hash``), so usable as a cache key.
    """
    head = {
        "format": FORMAT_VERSION,
        "engine": ENGINE_SERIES,
        "jet": dataclasses.asdict(config),
        "settings": settings.as_dict(),
    }
    digest = hashlib.sha256(json.dumps(head, sort_keys=True).encode())
    digest.update(np.ascontiguousarray(points, dtype="<f8").tobytes())
    digest.update(np.ascontiguousarray(triangles, dtype="<i8").tobytes())
    return digest.hexdigest()


def _validated(points: ArrayLike, triangles: ArrayLike, config: JetConfig) -> tuple[np.ndarray, np.ndarray]:
    """Metres and counter-clockwise triangles of a height field, as the thin-sheet model checks them."""
    from replication.surfaces import as_cloud

    pts = to_metres(as_cloud(points, name="surface points"))
    try:
        tri = np.asarray(triangles)
    except (TypeError, ValueError) as exc:
        raise InputError(f"triangles must be integer vertex indices: {exc}") from exc
    if tri.ndim != 2 or tri.shape[1] != 3 or tri.shape[0] == 0 or not np.issubdtype(tri.dtype, np.integer):
        raise InputError(
            f"triangles must be integer vertex indices of shape (m, 3), got {tri.dtype} {tri.shape}"
        )
    tri = np.array(tri, dtype=np.int64)
    if tri.min() < 0 or tri.max() >= pts.shape[0]:
        raise InputError(
            f"triangle vertex indices must lie in 0..{pts.shape[0] - 1}, got {tri.min()}..{tri.max()}"
        )
    check_domain(pts, config, np.unique(tri))
    pts, tri = weld(pts, tri)
    used = np.unique(tri)
    remap = np.full(pts.shape[0], -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    pts, tri = pts[used], remap[tri]
    tri, _ = check_height_field(pts, tri)
    return pts, tri


def sph_force(
    points: ArrayLike,
    triangles: ArrayLike,
    config: JetConfig | None = None,
    settings: SPHSettings | None = None,
    *,
    timeout: float | None = DEFAULT_TIMEOUT,
    run_dir: str | Path | None = None,
    progress: Callable[[float], None] | None = None,
) -> SPHForce:
    """Force of the water jet on a triangulated height field, simulated with SPlisHSPlasH.

    Parameters
    ----------
    points : array_like, shape (n, 3)
        Vertices in millimetres.
    triangles : array_like of int, shape (m, 3)
        A height field z(x, y), as for :func:`~replication.casestudy.jet.jet_force`.
    config : JetConfig, optional
        The jet (default: the paper's half jet).
    settings : SPHSettings, optional
    timeout : float or None
        Wall-clock limit of the simulation (s).
    run_dir : path, optional
        Keep the simulation's files here (scene, engine log, ``steps.csv`` per step of the
        simulated jet, ``series.csv`` binned and ``result.json`` of the modelled one);
        default: a temporary directory, removed afterwards.
    progress : callable, optional
        Called with the simulated time (s) as the simulation advances.

    Returns
    -------
    SPHForce
        ``status`` "ok", or "blowup", "timeout", "crash" with the reason (never raised).

    Raises
    ------
    InputError
        A surface the thin-sheet model would refuse too, bad settings.
    SolverUnavailableError
        The engine is not installed.

    Notes
    -----
    Paper section 6 simulates half the domain with a symmetry plane. SPlisHSPlasH has no
    symmetry plane, so the half jet is simulated as the whole jet on the surface joined to
    its mirror image in y = 0, and the forces and the mass flux are halved (the y force of
    the half is then that of the halved whole, about zero, not the push on the half alone).
    The engine runs in a child process (:mod:`.process`), never in the caller's.
    """
    config = JetConfig() if config is None else config
    settings = SPHSettings() if settings is None else settings
    pts, tri = _validated(points, triangles, config)
    key = content_key(pts, tri, config, settings)
    version = require_engine()
    mirrored = not config.full_jet
    simulated = dataclasses.replace(config, full_jet=True, domain=None) if mirrored else config
    if mirrored:
        span = float(np.ptp(pts, axis=0).max()) or 1.0
        pts = pts.copy()
        pts[np.abs(pts[:, 1]) <= 1e-9 * span, 1] = 0.0
        pts, tri = mirror_about_y(pts, tri)
    with _directory(run_dir) as directory:
        scene = write_scene(directory, pts, tri, simulated, settings)
        child = run_child(directory, timeout=timeout, threads=settings.threads, progress=progress)
        scale = 0.5 if mirrored else 1.0
        steps = read_steps(directory / "steps.csv") if (directory / "steps.csv").is_file() else None
        summary = summarize_force(
            steps if steps is not None else {k: np.empty(0) for k in ("time", "dt", "fx", "fy", "fz")},
            scene.timeline.window,
            bin_width=settings.bin_width,
            peak_window=settings.peak_window,
            scale=scale,
        )
        info = child.info
        mass = info.get("fluid_mass")
        mass_flow = (
            scale * mass * config.velocity / (scene.column_layers * scene.spacing)
            if mass is not None
            else float("nan")
        )
        result = SPHForce(
            status=child.status,
            reason=child.reason,
            key=key,
            settings=settings,
            jet=config,
            mirrored=mirrored,
            time=summary.bin_time,
            force=summary.bin_force,
            mean_force=summary.mean_force,
            window=scene.timeline.window,
            std_axial=summary.std_axial,
            peak_axial=summary.peak_axial,
            peak_time=summary.peak_time,
            max_axial=summary.max_axial,
            max_step_axial=summary.max_step_axial,
            mass_flow=float(mass_flow),
            fluid_particles=info.get("fluid_particles", scene.column_particles),
            boundary_particles=info.get("boundary_particles"),
            simulated_time=float(steps["time"][-1]) if steps is not None and steps["time"].size else 0.0,
            steps=int(steps["time"].size) if steps is not None else 0,
            wall_seconds=child.wall_seconds,
            engine=version,
            run_dir=None if run_dir is None else str(directory),
        )
        if run_dir is not None:
            write_result(result, directory / "result.json")
            write_series(result, directory / "series.csv")
    return result


@contextlib.contextmanager
def _directory(run_dir: str | Path | None):
    if run_dir is not None:
        path = Path(run_dir).resolve()
        path.mkdir(parents=True, exist_ok=True)
        yield path
        return
    from replication.io.scratch import scratch_directory

    with scratch_directory("replication-sph-") as path:
        yield path


def surface_sph_force(
    surface: Surface, config: JetConfig | None = None, settings: SPHSettings | None = None, **kwargs
) -> SPHForce:
    """:func:`sph_force` of an ADT surface built with ``depth="z"`` (millimetres).

    Notes
    -----
    Paper section 6: the fitness of a surface, scored by SPH as in the paper.
    """
    if surface.depth_axis != 2:
        raise InputError(
            f"the jet travels along -z, so the surface must be a height field over x-y (depth axis z), "
            f"got depth axis {surface.depth_axis_name}; build it with adt(points, depth='z')"
        )
    return sph_force(surface.points, surface.triangles, config, settings, **kwargs)
