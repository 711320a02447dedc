"""Validation and column spreads of a point cloud in two passes, without temporaries.

``np.std(cloud, axis=0)`` allocates a full-size array of deviations (0.24 GB for 1e7
points) and takes as long as a third of the triangulation at 1e6 points. The kernels of
:mod:`._moments` read the cloud twice (means, then squared deviations), summing in blocks
whose partial sums are added in order, so the rounding error grows like the block size plus
n over it, in units of the last place, instead of n; the result does not depend on any
thread count. They also tell whether every coordinate is finite.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from replication import _aot
from replication.errors import InputError
from replication.surfaces._threads import frozen
from replication.surfaces.cloud import as_cloud

__all__ = ["column_spreads", "validated_cloud"]

#: Clouds of at least this many points are summed in ``_CHUNKS`` pieces, on several threads.
_PARALLEL_MIN = 200_000
_CHUNKS = 4


def column_spreads(points: np.ndarray) -> tuple[np.ndarray, bool]:
    """Population standard deviation of each column of a C-contiguous float64 array.

    Returns the spreads and whether the column means are finite (False when a coordinate is
    NaN or infinite, or their sum overflows). Large arrays are summed in a fixed number of
    pieces whose sums are added in order, on several threads: the result does not depend on
    the thread count.
    """
    points = frozen(points)
    n, k = points.shape
    if n < _PARALLEL_MIN:
        out = np.empty(k)
        return out, bool(_aot.kernel("column_spreads")(points, out))
    from replication.surfaces._moments import _squares, _sums
    from replication.surfaces._threads import run

    chunks = _CHUNKS
    edges = [n * c // chunks for c in range(chunks + 1)]
    out = np.zeros((chunks, k))
    mean = np.zeros(k)

    def summed(squares: bool) -> np.ndarray:
        def piece(c: int):
            if squares:
                return lambda: _squares(points, edges[c], edges[c + 1], mean, out[c])
            return lambda: _sums(points, edges[c], edges[c + 1], out[c])

        run([piece(c) for c in range(chunks)])
        total = out[0].copy()
        for c in range(1, chunks):
            total += out[c]
        return total

    mean[:] = summed(False) / n
    finite = bool(np.all(np.isfinite(mean)))
    return np.sqrt(summed(True) / n), finite


#: Below this spread, squared deviations lose digits as subnormals (or vanish): recompute.
_TINY = 2.0**-450


def _rescaled_spreads(cloud: np.ndarray) -> np.ndarray:
    """Spreads of a cloud whose squared deviations overflow or underflow float64, each column
    computed on itself scaled by a power of two to unit magnitude and scaled back (exact).

    Without this the depth axis depended on the units: at 1e-170 every spread was 0 and the
    tie rule chose z; from 1e155 the spreads overflowed and the cloud was refused. Each column
    takes its own scale: with one scale for the cloud, a column of metres beside one of 1e200
    had its squared deviations underflow, and read a spread of 0.
    """
    spreads = np.zeros(cloud.shape[1])
    for c in range(cloud.shape[1]):
        column = np.ascontiguousarray(cloud[:, c : c + 1])
        magnitude = float(np.abs(column).max())
        if magnitude == 0.0:
            continue
        exponent = math.frexp(magnitude)[1]
        values, _ = column_spreads(np.ldexp(column, -exponent))
        spreads[c] = math.ldexp(float(values[0]), exponent)
    return spreads


def validated_cloud(points: ArrayLike) -> tuple[np.ndarray, tuple[float, float, float]]:
    """The cloud as a C-contiguous float64 (n, 3) array, and the spreads of x, y and z.

    Raises the errors of :func:`.as_cloud` (shape, non-numeric, NaN or infinite rows), and
    an :class:`~replication.errors.InputError` when a spread exceeds float64 even when computed
    at unit scale (:func:`_rescaled_spreads`).
    """
    cloud = None
    if type(points) is np.ndarray and points.dtype.kind in "fiu":  # others (masked, bool) take as_cloud
        cloud = np.asarray(points, dtype=np.float64)
    if cloud is None or cloud.ndim != 2 or cloud.shape[1] != 3 or cloud.shape[0] == 0:
        cloud = as_cloud(points)  # the checks, with their messages
    cloud = np.ascontiguousarray(cloud)
    values, finite = column_spreads(cloud)
    if not finite:
        cloud = as_cloud(cloud)  # names NaN or infinite rows; finite coordinates pass
    sx, sy, sz = values.tolist()  # Python floats: these checks cost a tenth of numpy's on 3 values
    isfinite = math.isfinite
    if not (isfinite(sx) and isfinite(sy) and isfinite(sz) and max(sx, sy, sz) >= _TINY):
        sx, sy, sz = _rescaled_spreads(cloud).tolist()
    spreads = (sx, sy, sz)
    if not (isfinite(sx) and isfinite(sy) and isfinite(sz)):
        raise InputError(
            f"coordinates too large: their standard deviations {spreads} overflow float64; rescale the cloud"
        )
    return cloud, spreads
