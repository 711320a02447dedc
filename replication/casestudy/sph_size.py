"""How many fluid particles an SPH simulation's jet needs, checked before it is set up.

``force --solver sph --duration 1e9`` set up for 47 s, then failed asking for 259 GiB. The
water column falls for the whole duration: its volume over the cubed particle spacing (2r)
is the particle count the engine allocates.

(This lives outside :mod:`replication.casestudy.sph`, whose source files key the SPH cache:
a check here leaves every cached simulation valid.)
"""

from __future__ import annotations

import math
from typing import Any

from replication.errors import InputError

__all__ = ["MAX_JET_PARTICLES", "check_jet_particles"]

#: The most fluid particles a jet may need (about 256 bytes each in the engine: 5 GB); the
#: paper's 20 ms at r = 0.75 mm need about 6,500.
MAX_JET_PARTICLES = 2e7


def check_jet_particles(settings: Any, jet_speed: float, jet_diameter: float) -> float:
    """The particles of the jet's water column (the full jet's; the half jet's are half).

    Raises
    ------
    InputError
        More than :data:`MAX_JET_PARTICLES`, and the errors of
        :func:`~replication.casestudy.sph.settings.timeline` (a duration with no window).
    """
    from replication.casestudy.sph.settings import timeline

    column = timeline(settings, jet_speed, jet_diameter).column_length
    particles = math.pi * (jet_diameter / 2) ** 2 * column / (2 * settings.particle_radius) ** 3
    if particles > MAX_JET_PARTICLES:
        raise InputError(
            f"SPH duration {1e3 * settings.duration:g} ms makes a water column {column:.3g} m long: about "
            f"{particles:.3g} particles at particle radius {1e3 * settings.particle_radius:g} mm, more than "
            f"{MAX_JET_PARTICLES:,.0f}, about 5 GB of memory in the engine; use a shorter duration or larger "
            "particles"
        )
    return particles
