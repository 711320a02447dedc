"""A stand-in for the SPH engine in tests: ``fake_sph`` has the signature of ``sph_force``.

Its force is a known function of the surface (1 + its mean height, in N), so tests of the
layers above the engine (cache, study, report) run anywhere in milliseconds.
"""

import threading
import time
from pathlib import Path

import numpy as np

from replication.casestudy.sph import SPHForce, write_result
from replication.errors import InputError

CALLS: list[str] = []  # names simulated (serial and thread executors share it)
LOCK = threading.Lock()
RUNNING = [0, 0]  # now, most at once
REFUSED = 12.75  # mm
FORCE_STATUS: str | None = None  # a status every simulation ends with (tests of failures)


def fake_sph(points, triangles, config, settings, *, timeout, run_dir):
    """A stand-in for sph_force: the force is 1 + the surface's mean height (N); the status is
    "blowup" for a surface wholly at 13 mm; a vertex at the height ``REFUSED`` is an InputError."""
    top = float(np.max(points[:, 2]))
    if np.any(points[:, 2] == REFUSED):
        raise InputError("surface refused")
    with LOCK:
        RUNNING[0] += 1
        RUNNING[1] = max(RUNNING)
    time.sleep(0.02)
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)  # as sph_force: an existing --run-dir is used
    status = FORCE_STATUS or ("blowup" if float(np.min(points[:, 2])) >= 13 else "ok")
    reason = None if status == "ok" else "runaway velocities" if status == "blowup" else f"forced {status}"
    result = SPHForce(
        status=status, reason=reason, key="k", settings=settings,
        jet=config, mirrored=True, time=np.arange(3) * 1e-3, force=np.zeros((3, 3)),
        mean_force=np.array([0.0, 0.0, -1.0 - float(np.mean(points[:, 2]))]), window=(0.001, 0.002),
        std_axial=0.1, peak_axial=1.0, peak_time=0.0, max_axial=1.0, max_step_axial=1.0, mass_flow=1.0,
        fluid_particles=10, boundary_particles=20, simulated_time=0.016, steps=3, wall_seconds=0.02,
        engine="test", run_dir=str(run_dir),
    )  # fmt: skip
    write_result(result, run_dir / "result.json")
    (run_dir / "column.pda").write_text("large\n")
    with LOCK:
        CALLS.append(f"{top:g}")
        RUNNING[0] -= 1
    return result


def fake_study_score(surface, jet, settings, *, timeout):
    """A stand-in for ``surface_sph_force`` (the SPH study's score): a force that is a known
    function of the surface and the particle radius, with a wall time that is not."""
    time.sleep(0.01)
    axial = 1.0 + float(np.mean(surface.points[:, 2])) + 1e3 * settings.particle_radius
    return SPHForce(
        status="ok", reason=None, key=f"{axial:.6f}", settings=settings,
        jet=jet, mirrored=True, time=np.arange(3) * 1e-3, force=np.full((3, 3), -axial),
        mean_force=np.array([0.0, 0.0, -axial]), window=(0.001, 0.002),
        std_axial=0.1, peak_axial=2 * axial, peak_time=0.0, max_axial=2 * axial, max_step_axial=2 * axial,
        mass_flow=jet.mass_flow, fluid_particles=10, boundary_particles=20, simulated_time=0.016, steps=3,
        wall_seconds=0.02, engine="test", run_dir="",
    )  # fmt: skip
