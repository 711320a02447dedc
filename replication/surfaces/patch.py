"""A tensor-product NURBS surface as data: degrees, knots, control points and weights.

:class:`NurbsPatch` is what the fitting (:mod:`.nurbs`), the fast evaluator (:mod:`.bspline`)
and the file formats (:mod:`replication.io.nurbs`) share; it lives here so that those modules
import it one way (paper section 3.1 describes the surfaces it holds).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from replication.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from geomdl.NURBS import Surface as GeomdlSurface
    from scipy.interpolate import NdBSpline

__all__ = ["NurbsPatch"]


def _frozen_float64(value: object) -> bool:
    """A C-contiguous float64 array that owns its data and is read-only (e.g. made so by the fit)."""
    return (
        isinstance(value, np.ndarray)
        and value.dtype == np.float64
        and value.base is None
        and not value.flags.writeable
        and value.flags.c_contiguous
    )


@dataclass(frozen=True, eq=False)
class NurbsPatch:
    """A tensor-product NURBS surface: everything a NURBS needs, and nothing else.

    ``control_points[i, j]`` is the point for the i-th u and j-th v basis function (geomdl's
    ``ctrlpts2d`` order); ``weights`` has the same (m_u, m_v) shape.
    """

    degree_u: int
    degree_v: int
    knots_u: np.ndarray
    knots_v: np.ndarray
    control_points: np.ndarray
    weights: np.ndarray

    def __post_init__(self) -> None:
        for a in ("knots_u", "knots_v", "control_points", "weights"):
            given = getattr(self, a)
            if _frozen_float64(given):  # already a read-only array of its own: kept, not copied
                arr = given
            else:  # a copy, so that the caller's array can change without changing the patch
                arr = np.array(given, dtype=np.float64)
                arr.flags.writeable = False
            object.__setattr__(self, a, arr)
        object.__setattr__(self, "degree_u", int(self.degree_u))
        object.__setattr__(self, "degree_v", int(self.degree_v))
        if self.control_points.ndim != 3 or self.control_points.shape[2] != 3:
            raise InputError(f"control points must have shape (m_u, m_v, 3), got {self.control_points.shape}")
        if not np.all(np.isfinite(self.control_points)):
            raise InputError("control points must be finite")
        m_u, m_v = self.control_points.shape[:2]
        if self.weights.shape != (m_u, m_v) or not np.all(np.isfinite(self.weights) & (self.weights > 0)):
            raise InputError(f"weights must be positive with shape {(m_u, m_v)}, got {self.weights.shape}")
        for name, knots, m, p in (
            ("u", self.knots_u, m_u, self.degree_u),
            ("v", self.knots_v, m_v, self.degree_v),
        ):
            if (
                knots.shape != (m + p + 1,)
                or not np.all(np.isfinite(knots))
                or np.any(np.diff(knots) < 0)
                or not knots[-1] > knots[0]  # (a zero-width domain: geomdl divided by zero)
            ):
                raise InputError(
                    f"knot vector {name} must be finite, non-decreasing and of positive width with "
                    f"{m + p + 1} entries, got {knots.tolist()}"
                )

    @property
    def net_shape(self) -> tuple[int, int]:
        return (int(self.control_points.shape[0]), int(self.control_points.shape[1]))

    @cached_property
    def rational(self) -> bool:
        """False when every weight is 1 (the paper's case: a B-spline in NURBS clothing)."""
        return bool(np.any(self.weights != 1.0))

    def to_geomdl(self) -> GeomdlSurface:
        """The same surface as a geomdl ``NURBS.Surface`` (the paper-faithful reference)."""
        from geomdl import NURBS

        surf = NURBS.Surface()
        surf.degree_u = self.degree_u
        surf.degree_v = self.degree_v
        m_u, m_v = self.net_shape
        surf.ctrlpts_size_u = m_u
        surf.ctrlpts_size_v = m_v
        surf.ctrlpts = self.control_points.reshape(-1, 3).tolist()
        surf.weights = self.weights.ravel().tolist()
        surf.knotvector_u = self.knots_u.tolist()
        surf.knotvector_v = self.knots_v.tolist()
        return surf

    @cached_property
    def spline(self) -> NdBSpline:
        """scipy ``NdBSpline`` of the homogeneous control points (w x, w y, w z, w).

        When every weight is 1 (the paper's case) it is the spline of the control points
        themselves, (x, y, z): the weight column would be 1 everywhere, and the points are
        used without a copy (a 1000 x 1000 net is 24 MB).
        """
        from scipy.interpolate import NdBSpline

        knots, degrees = (self.knots_u, self.knots_v), (self.degree_u, self.degree_v)
        if not self.rational:
            return NdBSpline(knots, self.control_points, degrees)
        coefficients = np.empty((*self.weights.shape, 4))
        coefficients[..., :3] = self.control_points * self.weights[..., None]
        coefficients[..., 3] = self.weights
        return NdBSpline(knots, coefficients, degrees)
