"""The water jet of the case study (paper section 6): its configuration, validated.

:class:`JetConfig` is shared by the jet model (:mod:`.jet`), the mesh checks (:mod:`.mesh`)
and the genetic algorithm (:mod:`.ga`); it lives here so that those modules import it one way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from replication.errors import InputError

__all__ = ["DIAMETER_RANGE", "JetConfig"]

#: Jet diameters (m) the model accepts: a plate scaled with the jet takes rho Q V from 1e-82 m to
#: 1e90 m (tested), and the streamlets' centroids take the cube of radii; a wide margin is kept.
DIAMETER_RANGE = (1e-60, 1e60)
#: Relative slack of those bounds: a few roundings of a unit conversion.
_ROUNDING = 1e-15


@dataclass(frozen=True)
class JetConfig:
    """The water jet of the case study (paper section 6), in SI units.

    Attributes
    ----------
    diameter : float
        Jet diameter (m); the paper's 18 mm.
    velocity : float
        Jet speed (m/s); the jet travels along -z. The paper's 4.34 m/s.
    density : float
        Water density (kg/m^3).
    center : tuple of float
        (x, y) of the jet axis (m): the middle of the bucket length on the symmetry plane.
    full_jet : bool
        False (the paper's choice): only the half jet y >= 0 on the half surface, with the
        symmetry plane y = 0. True: the whole jet on a surface given for both signs of y.
    domain : tuple of float or None
        (length, half width, depth) of the domain (m): the surface must lie in
        [0, length] x [0, half width] x [0, depth] (y in [-half width, half width] with the
        full jet). None accepts surfaces anywhere.

    Notes
    -----
    Paper section 6: 36 x 30 x 13 mm domain, 18 mm jet at 4.34 m/s, half of the domain
    modelled thanks to the symmetry of the flow.
    """

    diameter: float = 0.018
    velocity: float = 4.34
    density: float = 1000.0
    center: tuple[float, float] = (0.018, 0.0)
    full_jet: bool = False
    domain: tuple[float, float, float] | None = (0.036, 0.030, 0.013)

    def __post_init__(self) -> None:
        for name in ("diameter", "velocity", "density"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise InputError(f"jet {name} must be a number, got {value!r}")
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"jet {name} must be positive and finite, got {name}={value!r}")
            object.__setattr__(self, name, float(value))
        low, high = DIAMETER_RANGE
        # the streamlets' centroids take its cube; the bounds allow for the rounding of a
        # diameter given in millimetres (1e63 mm is 1.0000000000000001e60 m)
        if not low * (1 - _ROUNDING) <= self.diameter <= high * (1 + _ROUNDING):
            raise InputError(
                f"jet diameter must lie in [{low:g}, {high:g}] m (SI units: the paper's jet is 0.018 m), "
                f"got diameter={self.diameter!r}"
            )
        center = _floats(self.center, 2, "jet center (x, y)")
        object.__setattr__(self, "center", center)
        if not isinstance(self.full_jet, (bool, np.bool_)):
            raise InputError(f"full_jet must be True or False, got {self.full_jet!r}")
        object.__setattr__(self, "full_jet", bool(self.full_jet))
        for what, value in (
            ("mass flow rho Q", self.mass_flow),
            ("momentum flux rho Q V", self.momentum_flux),
        ):
            if not (math.isfinite(value) and value >= np.finfo(np.float64).tiny):
                raise InputError(
                    f"the jet's {what} = {value:.3g} leaves float64's range (diameter {self.diameter!r} m, "
                    f"velocity {self.velocity!r} m/s, density {self.density!r} kg/m^3): use SI units"
                )
        if not self.full_jet and center[1] != 0.0:
            raise InputError(
                f"the half jet is modelled with the symmetry plane y = 0, so its center must have y = 0, "
                f"got center={center}; use full_jet=True for an off-centre jet"
            )
        if self.domain is not None:
            domain = _floats(self.domain, 3, "domain (length, half width, depth)")
            if min(domain) <= 0:
                raise InputError(f"domain sizes must be positive, got domain={domain}")
            object.__setattr__(self, "domain", domain)

    @property
    def area(self) -> float:
        """Cross-section of the modelled jet (m^2): half the disk unless ``full_jet``."""
        disk = math.pi * self.diameter**2 / 4
        return disk if self.full_jet else disk / 2

    @property
    def mass_flow(self) -> float:
        """Mass flow rate rho Q of the modelled jet (kg/s)."""
        return self.density * self.velocity * self.area

    @property
    def momentum_flux(self) -> float:
        """rho Q V (N): the force on a large flat plate normal to the jet."""
        return self.mass_flow * self.velocity


def _floats(value: Any, n: int, name: str) -> tuple[float, ...]:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be {n} numbers, got {value!r}") from None
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be {n} finite numbers, got {value!r}")
    return tuple(float(v) for v in arr)
