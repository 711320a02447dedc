"""The losses the thin-sheet model leaves out, as parameters: the surrogate of issue 11.

The thin-sheet model (:mod:`replication.casestudy.jet`) keeps the sheet at full speed through
every concave crease and every re-impact. An SPH simulation of the same surface does not: a
sheet turned sharply or striking the surface again splashes and slows. Two parameters add
those losses to the model; both zero (the default) is the model exactly, bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from replication.errors import InputError

__all__ = ["SheetLosses"]


@dataclass(frozen=True)
class SheetLosses:
    """Speed lost by the sheet at creases and re-impacts.

    Attributes
    ----------
    crease : float
        At a concave crease the sheet turns by an angle phi into the next facet; its speed is
        multiplied by ``max(0, 1 - crease * (1 - cos phi))``. 0: speed kept (the model); 1: a
        sheet turned by 90 degrees stops. In [0, 4].
    reimpact : float
        Fraction of the speed lost at a re-impact (a separated sheet striking the surface
        again), by both the forward and the backward stream. In [0, 1].

    Notes
    -----
    Paper section 6 computes the jet's force with SPH; these losses are the physics the
    thin-sheet stand-in lacks (issue 11, item 2), fitted to SPH on half of the validation
    study's surfaces.
    """

    crease: float = 0.0
    reimpact: float = 0.0

    def __post_init__(self) -> None:
        for name, value, high in (("crease", self.crease, 4.0), ("reimpact", self.reimpact, 1.0)):
            if not isinstance(value, (int, float)) or not math.isfinite(value) or not 0.0 <= value <= high:
                raise InputError(f"SheetLosses.{name} must be a number in [0, {high:g}], got {value!r}")

    @property
    def none(self) -> bool:
        """True when the losses are zero: the thin-sheet model itself."""
        return self.crease == 0.0 and self.reimpact == 0.0

    def as_array(self) -> np.ndarray:
        """(crease, reimpact) as the compiled tracer takes them."""
        return np.array([self.crease, self.reimpact], dtype=np.float64)
