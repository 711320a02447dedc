"""The child process that runs one SPlisHSPlasH simulation: ``python driver.py RUN_DIR``.

The engine keeps global state (one simulation per process), may call ``exit()`` on errors
and can crash on cleanup, so it only ever runs here, in a process of its own started by
:mod:`replication.casestudy.sph.process`. This file is run by path and imports nothing but
the standard library, numpy and the engine (not the ``replication`` package: a bare start-up
is 0.2 s instead of 1.5 s); the functions above :func:`main` are importable for tests
without the engine.

Inputs in RUN_DIR: ``job.json`` (what to watch) and the scene it names. Outputs:
``steps.csv`` (one row per time step: time, step size, force on the surface, largest
particle speed), ``progress.json`` (simulated time so far, replaced a few times a second)
and ``outcome.json`` (status and counts), written last. Exit status 0 for a finished run,
3 for a blow-up, 2 for an error caught here; the engine's own ``exit()`` or a crash leave no
``outcome.json``.

The force comes from the fluid's momentum balance (SPlisHSPlasH accumulates forces on
dynamic bodies only): with no particle added or removed, the force of the water on the
surface over a step of length h is F = -(P_new - P_old - M g h) / h, where P is the total
momentum of the fluid and M its mass; the pressure and viscous forces between fluid
particles cancel in the sum.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

STATUS_OK, STATUS_BLOWUP = "ok", "blowup"
EXIT_OK, EXIT_ERROR, EXIT_BLOWUP = 0, 2, 3
STEPS_HEADER = "step,time_s,dt_s,fx_N,fy_N,fz_N,max_speed_m_s"


def write_json_atomic(path: Path, data: dict) -> None:
    """Write JSON through a temporary file and a rename (a reader never sees half a file)."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(data, sort_keys=True))
    os.replace(tmp, path)


def blowup_reason(
    impulse: np.ndarray, max_speed_sq: float, dt: float, *, max_speed: float, min_time_step: float
) -> str | None:
    """Why a step's state is a blow-up (non-finite values, a runaway particle, a collapsed
    time step), or None when it is sound."""
    if not (np.all(np.isfinite(impulse)) and math.isfinite(max_speed_sq) and math.isfinite(dt)):
        return "non-finite velocities"
    if max_speed_sq > max_speed**2:
        speed = math.sqrt(max_speed_sq)
        return f"runaway velocities: a particle reached {speed:.4g} m/s (limit {max_speed:.4g} m/s)"
    if dt <= min_time_step * (1 + 1e-6):
        return f"time step collapse: the step shrank to {dt:.3g} s (limit {min_time_step:.3g} s)"
    return None


def preload_system_gl() -> None:
    """Load the system's libGLdispatch globally before the engine (else its import segfaults).

    The wheel vendors libGLdispatch under a hashed name while its libGLU pulls in the
    system's libGL, whose dispatch library must then be the system's one.
    """
    if not sys.platform.startswith("linux"):
        return
    for name in ("libGLdispatch.so.0", ctypes.util.find_library("GLdispatch")):
        if not name:
            continue
        try:
            ctypes.CDLL(name, mode=ctypes.RTLD_GLOBAL)
            return
        except OSError:
            continue


class Recorder:
    """The time-step callback: the force from the momentum balance, blow-up checks, files."""

    def __init__(self, run_dir: Path, job: dict, fluid, clock, n: int, mass: float) -> None:
        self.run_dir, self.fluid, self.clock, self.n = run_dir, fluid, clock, n
        self.mass, self.total_mass = mass, mass * n
        self.gravity = np.array([0.0, 0.0, -job["gravity"]])
        self.max_speed, self.min_time_step = job["max_speed"], job["min_time_step"]
        self.interval = job.get("progress_interval", 0.25)
        self.momentum = self._momentum(self._velocity())
        self.dt = float(clock.getTimeStepSize())  # the step size the next step uses
        self.time, self.steps = 0.0, 0
        self.started = self.last_report = time.perf_counter()
        self.rows = open(run_dir / "steps.csv", "w")  # noqa: SIM115 - closed in finish()
        self.rows.write(STEPS_HEADER + "\n")

    def _velocity(self) -> np.ndarray:
        return np.asarray(self.fluid.getFieldBuffer("velocity"))[: self.n]

    def _momentum(self, v: np.ndarray) -> np.ndarray:
        return self.mass * np.sum(v, axis=0, dtype=np.float64)

    def __call__(self) -> None:
        v = self._velocity()
        h = self.dt
        momentum = self._momentum(v)
        impulse = -(momentum - self.momentum - self.total_mass * self.gravity * h)
        self.momentum = momentum
        self.dt = float(self.clock.getTimeStepSize())
        self.time += h
        self.steps += 1
        speed_sq = float(np.einsum("ij,ij->i", v, v).max()) if self.n else 0.0
        fx, fy, fz = (impulse / h).tolist()
        speed = math.sqrt(speed_sq) if speed_sq >= 0 else speed_sq  # NaN stays NaN
        self.rows.write(f"{self.steps},{self.time!r},{h!r},{fx!r},{fy!r},{fz!r},{speed!r}\n")
        reason = blowup_reason(
            impulse, speed_sq, h, max_speed=self.max_speed, min_time_step=self.min_time_step
        )
        if reason is not None:
            self.finish(STATUS_BLOWUP, reason)
            os._exit(EXIT_BLOWUP)
        now = time.perf_counter()
        if now - self.last_report >= self.interval:
            self.last_report = now
            self.rows.flush()
            write_json_atomic(self.run_dir / "progress.json", {"time": self.time, "steps": self.steps})

    def finish(self, status: str, reason: str | None, **extra) -> None:
        self.rows.close()
        write_json_atomic(self.run_dir / "progress.json", {"time": self.time, "steps": self.steps})
        write_json_atomic(
            self.run_dir / "outcome.json",
            {
                "status": status,
                "reason": reason,
                "steps": self.steps,
                "simulated_time": self.time,
                "run_seconds": time.perf_counter() - self.started,
                "fluid_particles": self.n,
                "particle_mass": self.mass,
                "fluid_mass": self.total_mass,
                **extra,
            },
        )


def _run(run_dir: Path) -> None:
    job = json.loads((run_dir / "job.json").read_text())
    started = time.perf_counter()
    preload_system_gl()
    import pysplishsplash as sph  # the engine: imported here and nowhere else

    base = sph.Exec.SimulatorBase()
    engine_dir = run_dir / "engine"
    base.init(
        ["replication-sph", "--no-gui", "--no-cache", "--output-dir", str(engine_dir), job["scene"]],
        "replication",
    )
    base.initSimulation()
    sim = sph.Simulation.getCurrent()
    fluid = sim.getFluidModel(0)
    n = int(fluid.numActiveParticles())
    mass = float(fluid.getMass(0)) if n else 0.0
    if n and any(float(fluid.getMass(i)) != mass for i in (n // 2, n - 1)):
        raise RuntimeError("fluid particles of unequal mass: the momentum balance assumes one mass")
    recorder = Recorder(run_dir, job, fluid, sph.TimeManager.getCurrent(), n, mass)
    base.setTimeStepCB(recorder)
    base.runSimulation()  # loads the boundary first: its model does not exist before
    try:
        boundary = int(sim.getBoundaryModel(0).numberOfParticles())
    except Exception:  # the binding may not expose the Akinci model's count
        boundary = None
    recorder.finish(
        STATUS_OK,
        None,
        boundary_particles=boundary,
        init_seconds=recorder.started - started,
        engine_time=float(sph.TimeManager.getCurrent().getTime()),
    )


def main(argv: list[str]) -> None:
    """Run the simulation of RUN_DIR; leave with ``os._exit`` (the engine's cleanup can crash)."""
    run_dir = Path(argv[1]).resolve()
    try:
        _run(run_dir)
    except BaseException as exc:  # reported as a file; the parent turns it into a failure
        write_json_atomic(
            run_dir / "outcome.json", {"status": "error", "reason": f"{type(exc).__name__}: {exc}"}
        )
        sys.stdout.flush()
        os._exit(EXIT_ERROR)
    sys.stdout.flush()
    os._exit(EXIT_OK)


if __name__ == "__main__":
    main(sys.argv)
