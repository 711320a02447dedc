"""The result of one SPH simulation of the jet: a frozen record that round-trips through JSON."""

from __future__ import annotations

import dataclasses
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from replication.casestudy.jet import JetConfig
from replication.casestudy.sph.settings import SPHSettings
from replication.errors import CloudFileError, SimulationError
from replication.io.atomic import atomic_write_text

__all__ = ["SPHForce", "read_result", "write_result", "write_series"]

#: Version of the result format (and of the simulation set-up: part of the content hash).
FORMAT_VERSION = 1


@dataclass(frozen=True, eq=False)
class SPHForce:
    """The force of the jet on a surface from an SPH simulation, or why there is none.

    Forces are those of the modelled jet: for the half jet (simulated whole on the mirrored
    surface, see :func:`~replication.casestudy.sph.score.sph_force`) every force and the mass
    flux are halved. The axial force is positive when the water pushes the surface along -z.
    Numbers a failed simulation could not give are NaN.

    Attributes
    ----------
    status : {"ok", "blowup", "timeout", "crash"}
    reason : str or None
        Why the simulation failed.
    key : str
        Content hash of (surface, jet, settings, engine series, format): a cache key.
    settings : SPHSettings
    jet : JetConfig
    mirrored : bool
        True when the half jet was simulated as the whole jet on the mirrored surface.
    time, force : ndarray
        The force series in bins of ``settings.bin_width``: bin starts (s), mean force (N).
    mean_force : ndarray, shape (3,)
        Mean force over the quasi-steady ``window`` (s, from the start).
    std_axial : float
        Standard deviation of the axial force's bin means inside the window.
    peak_axial, peak_time : float
        First-impact peak: the largest mean axial force over ``settings.peak_window`` before
        the window, and when that interval starts.
    max_axial : float
        The largest such mean over the whole run.
    max_step_axial : float
        The largest axial force of a single time step.
    mass_flow : float
        Mass flux of the simulated jet (kg/s): the mass of its particles per unit length of
        the column times its speed (differs from rho Q at coarse particle sizes).
    fluid_particles, boundary_particles : int or None
    simulated_time, steps, wall_seconds : float, int, float
    engine : str
        Engine version.
    run_dir : str or None
        Where the simulation's files were kept.
    """

    status: str
    reason: str | None
    key: str
    settings: SPHSettings
    jet: JetConfig
    mirrored: bool
    time: np.ndarray
    force: np.ndarray
    mean_force: np.ndarray
    window: tuple[float, float]
    std_axial: float
    peak_axial: float
    peak_time: float
    max_axial: float
    max_step_axial: float
    mass_flow: float
    fluid_particles: int | None
    boundary_particles: int | None
    simulated_time: float
    steps: int
    wall_seconds: float
    engine: str
    run_dir: str | None = None

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def mean_axial(self) -> float:
        """Quasi-steady mean axial force (N)."""
        return float(-self.mean_force[2])

    @property
    def particle_radius(self) -> float:
        return self.settings.particle_radius

    @property
    def momentum_flux(self) -> float:
        """rho Q V of the modelled jet (N), from its nominal diameter and speed."""
        return self.jet.momentum_flux

    @property
    def measured_momentum_flux(self) -> float:
        """Measured mass flux x jet speed (N): rho Q V of the jet as sampled by particles."""
        return self.mass_flow * self.jet.velocity

    def check(self) -> SPHForce:
        """Return self if the simulation succeeded, else raise :class:`SimulationError`."""
        if not self.ok:
            where = f" (files in {self.run_dir})" if self.run_dir else ""
            raise SimulationError(f"SPH simulation failed ({self.status}): {self.reason}{where}")
        return self

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready values (NaN becomes None)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name in ("settings", "jet"):
                value = dataclasses.asdict(value)
            elif isinstance(value, np.ndarray):
                value = value.tolist()
            out[f.name] = value
        out["format"] = FORMAT_VERSION
        return _clean(out)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SPHForce:
        """Inverse of :meth:`as_dict`."""
        data = dict(data)
        if data.pop("format", None) != FORMAT_VERSION:
            raise CloudFileError(f"not an SPH result of format {FORMAT_VERSION}")
        jet = dict(data["jet"])
        jet["center"] = tuple(jet["center"])
        jet["domain"] = None if jet["domain"] is None else tuple(jet["domain"])
        data["jet"] = JetConfig(**jet)
        data["settings"] = SPHSettings.from_dict(data["settings"])
        data["time"] = _floats(data["time"])
        data["force"] = _floats(data["force"]).reshape(-1, 3)
        data["mean_force"] = _floats(data["mean_force"])
        data["window"] = tuple(_floats(data["window"]).tolist())
        for name in (
            "std_axial",
            "peak_axial",
            "peak_time",
            "max_axial",
            "max_step_axial",
            "mass_flow",
            "simulated_time",
            "wall_seconds",
        ):
            data[name] = math.nan if data[name] is None else float(data[name])
        return cls(**data)


def _floats(value: Any) -> np.ndarray:
    arr = np.array(value, dtype=object)
    return np.where(arr == None, np.nan, arr).astype(np.float64)  # noqa: E711 - elementwise


def _clean(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return None if not math.isfinite(float(value)) else float(value)
    if isinstance(value, np.integer):
        return int(value)
    return value


def write_result(result: SPHForce, path: str | os.PathLike[str]) -> int:
    """Write a result as JSON (atomically); returns the bytes written."""
    return atomic_write_text(
        path, json.dumps(result.as_dict(), indent=1, sort_keys=True, allow_nan=False) + "\n"
    )


def read_result(path: str | os.PathLike[str]) -> SPHForce:
    path = Path(path)
    if not path.is_file():
        raise CloudFileError(f"SPH result not found: {path}")
    return SPHForce.from_dict(json.loads(path.read_text()))


def write_series(result: SPHForce, path: str | os.PathLike[str]) -> int:
    """The binned force series as CSV: bin start and end (s), force components, axial (N)."""
    width = result.settings.bin_width
    lines = ["t_start_s,t_end_s,fx_N,fy_N,fz_N,axial_N"]
    for t, (fx, fy, fz) in zip(result.time.tolist(), result.force.tolist()):
        lines.append(f"{t!r},{t + width!r},{fx!r},{fy!r},{fz!r},{-fz!r}")
    return atomic_write_text(path, "\n".join(lines) + "\n")
