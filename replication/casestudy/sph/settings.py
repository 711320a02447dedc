"""Settings of an SPH simulation of the case study's jet, and the times derived from them.

Everything that changes the simulated physics or its numerical result is a field of
:class:`SPHSettings` (and so part of the content hash of a simulation); how long the caller
waits for it (the timeout) is not.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np

from replication.errors import InputError

__all__ = ["METHODS", "SPHSettings", "Timeline", "timeline"]

#: Pressure solvers: SPlisHSPlasH's simulationMethod numbers.
METHODS: dict[str, int] = {"wcsph": 0, "dfsph": 4}
#: Support radius of SPlisHSPlasH's kernels, in particle radii.
SUPPORT_RADII = 4.0
#: Free fall of the jet's front before it reaches the surface, beyond the kernel support (m).
CLEARANCE = 0.002
#: Acoustic CFL number of the weakly compressible solver: dt <= 0.4 * 2r / (c + V).
ACOUSTIC_CFL = 0.4


@dataclass(frozen=True)
class SPHSettings:
    """How the SPH solver simulates the jet (SI units).

    Attributes
    ----------
    particle_radius : float
        Fluid particle radius r (m); particles sit on a cubic lattice of spacing 2r.
    duration : float
        Simulated time (s). The jet is a free water column long enough to flow onto the
        surface for the whole run (its tail arrives at ``duration``).
    method : {"dfsph", "wcsph"}
        Pressure solver: divergence-free SPH (incompressible, SPlisHSPlasH's default) or
        weakly compressible SPH (Tait equation of state, as in DualSPHysics).
    sound_speed : float or None
        Numerical speed of sound c (m/s) of ``"wcsph"``; None: 10 x the jet speed, the usual
        weakly compressible choice. Sets the stiffness B = rho c^2 / gamma.
    exponent : float
        gamma of the Tait equation p = B ((rho / rho0)^gamma - 1) (``"wcsph"``).
    viscosity : float
        Kinematic viscosity (m^2/s) of SPlisHSPlasH's standard viscosity; 0 for none.
    gravity : float
        Gravitational acceleration (m/s^2) along -z, the jet's direction.
    cfl_factor : float
        Factor of SPlisHSPlasH's CFL condition dt = factor * 0.4 * 2r / max speed.
    max_time_step : float
        Largest time step (s).
    min_time_step : float
        Smallest time step (s): a step this short means the time step collapsed (a blow-up).
    max_speed_factor : float
        A particle faster than this times the jet speed means a runaway (a blow-up).
    settle_time : float
        The quasi-steady averaging window starts this long after the jet's front reaches the
        top of the surface (s): the sheet needs that long to form in a cup.
    bin_width : float
        Width of the bins of the force time series (s); the quasi-steady standard deviation
        is that of the bin means inside the window.
    peak_window : float
        Averaging window of the first-impact peak (s): the largest running mean of the force
        over this window before the quasi-steady window.
    threads : int
        OpenMP threads of the engine; 1 (the default) makes runs bit-for-bit repeatable.

    Notes
    -----
    Paper section 6: the paper's DualSPHysics runs simulated 0.07 s; its particle size,
    solver settings and force definition are not given.
    """

    particle_radius: float = 0.75e-3
    duration: float = 0.020
    method: str = "dfsph"
    sound_speed: float | None = None
    exponent: float = 7.0
    viscosity: float = 0.0
    gravity: float = 9.81
    cfl_factor: float = 0.5
    max_time_step: float = 1e-4
    min_time_step: float = 1e-8
    max_speed_factor: float = 10.0
    settle_time: float = 0.006
    bin_width: float = 0.001
    peak_window: float = 1e-4
    threads: int = 1

    def __post_init__(self) -> None:
        positive = (
            "particle_radius",
            "duration",
            "exponent",
            "cfl_factor",
            "max_time_step",
            "min_time_step",
            "max_speed_factor",
            "bin_width",
            "peak_window",
        )
        for name in (*positive, "viscosity", "gravity", "settle_time"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise InputError(f"SPH {name} must be a number, got {name}={value!r}")
            value = float(value)
            if not math.isfinite(value) or value < 0 or (name in positive and value == 0):
                need = "positive" if name in positive else "non-negative"
                raise InputError(f"SPH {name} must be {need} and finite, got {name}={value!r}")
            object.__setattr__(self, name, value)
        if self.method not in METHODS:
            raise InputError(f"SPH method must be one of {sorted(METHODS)}, got method={self.method!r}")
        if self.sound_speed is not None:
            c = self.sound_speed
            if isinstance(c, bool) or not isinstance(c, (int, float, np.number)) or not (0 < c < math.inf):
                raise InputError(f"SPH sound_speed must be positive and finite or None, got {c!r}")
            object.__setattr__(self, "sound_speed", float(c))
        if self.min_time_step >= self.max_time_step:
            raise InputError(
                f"SPH min_time_step ({self.min_time_step:g} s) must be below max_time_step "
                f"({self.max_time_step:g} s)"
            )
        if (
            isinstance(self.threads, bool)
            or not isinstance(self.threads, (int, np.integer))
            or self.threads < 1
        ):
            raise InputError(f"SPH threads must be a positive integer, got threads={self.threads!r}")
        object.__setattr__(self, "threads", int(self.threads))
        if not 0.1e-3 <= self.particle_radius <= 5e-3:
            raise InputError(
                f"SPH particle_radius must lie between 0.1 and 5 mm, got {1e3 * self.particle_radius:g} mm"
            )

    def as_dict(self) -> dict[str, Any]:
        """Plain values for JSON (and the content hash)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SPHSettings:
        """Inverse of :meth:`as_dict`; unknown keys are an error naming them."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InputError(f"unknown SPH settings: {', '.join(unknown)}")
        return cls(**data)

    @property
    def support_radius(self) -> float:
        """Kernel support radius (m): 4 particle radii."""
        return SUPPORT_RADII * self.particle_radius

    def speed_of_sound(self, jet_speed: float) -> float | None:
        """The numerical speed of sound (m/s) of ``"wcsph"``; None for the incompressible solver."""
        if self.method != "wcsph":
            return None
        return self.sound_speed if self.sound_speed is not None else 10.0 * jet_speed

    def time_step_limit(self, jet_speed: float) -> float:
        """Largest time step (s): ``max_time_step``, and the acoustic CFL limit for ``"wcsph"``.

        SPlisHSPlasH's CFL condition sees particle speeds only; a weakly compressible fluid
        also needs dt <= 0.4 * 2r / (c + V).
        """
        c = self.speed_of_sound(jet_speed)
        if c is None:
            return self.max_time_step
        return min(self.max_time_step, ACOUSTIC_CFL * 2 * self.particle_radius / (c + jet_speed))


@dataclass(frozen=True)
class Timeline:
    """When things happen in a simulation (s from its start) and the column that feeds the jet."""

    gap: float  # height of the column's bottom above the highest point of the surface (m)
    contact: float  # the jet's front reaches the top of the surface
    window: tuple[float, float]  # quasi-steady averaging window
    column_length: float  # length of the water column (m)


def timeline(settings: SPHSettings, jet_speed: float, jet_diameter: float) -> Timeline:
    """The gap, contact time, averaging window and column length of a simulation.

    The column's bottom starts one kernel support plus 2 mm above the surface (so the water
    feels nothing before it falls onto it) and its tail reaches the top of the surface at
    ``duration``. The quasi-steady window runs from ``settle_time`` after contact to one jet
    diameter's travel before the end (the stagnation flow feels the tail coming).

    Raises
    ------
    InputError
        When the duration leaves no window of at least two bins.
    """
    gap = settings.support_radius + CLEARANCE
    contact = gap / jet_speed
    start = contact + settings.settle_time
    end = settings.duration - jet_diameter / jet_speed
    if end - start < 2 * settings.bin_width:
        need = start + 2 * settings.bin_width + jet_diameter / jet_speed
        raise InputError(
            f"SPH duration {1e3 * settings.duration:g} ms leaves no quasi-steady window (it starts "
            f"{1e3 * start:.3g} ms in and ends one jet diameter's travel before the end); use a duration "
            f"of at least {1e3 * need:.3g} ms"
        )
    return Timeline(
        gap=gap, contact=contact, window=(start, end), column_length=jet_speed * (settings.duration - contact)
    )
