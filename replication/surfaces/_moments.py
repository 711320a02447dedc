"""Column sums and squared deviations of a point array in blocks, without temporaries (numba).

The kernels of :mod:`._spread`: they read the array twice (means, then squared deviations),
summing in blocks of ``_BLOCK`` values whose partial sums are added in order, so the rounding
error grows like ``_BLOCK + n / _BLOCK`` units of the last place instead of n. ``_small`` is
the one-call path of small arrays, also compiled ahead of time (:mod:`replication._aot`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from replication import _numbacache

__all__ = []

_BLOCK = 1024


@njit(cache=True, nogil=True)
def _sums(points, lo, hi, out):
    """Column sums of rows lo..hi-1 (in blocks of ``_BLOCK`` rows)."""
    k = points.shape[1]
    part = np.zeros(k)
    for c in range(k):
        out[c] = 0.0
    for i in range(lo, hi):
        for c in range(k):
            part[c] += points[i, c]
        if (i - lo + 1) % _BLOCK == 0:
            for c in range(k):
                out[c] += part[c]
                part[c] = 0.0
    for c in range(k):
        out[c] += part[c]


@njit(cache=True, nogil=True)
def _squares(points, lo, hi, mean, out):
    """Column sums of squared deviations from ``mean`` of rows lo..hi-1 (in blocks)."""
    k = points.shape[1]
    part = np.zeros(k)
    for c in range(k):
        out[c] = 0.0
    for i in range(lo, hi):
        for c in range(k):
            d = points[i, c] - mean[c]
            part[c] += d * d
        if (i - lo + 1) % _BLOCK == 0:
            for c in range(k):
                out[c] += part[c]
                part[c] = 0.0
    for c in range(k):
        out[c] += part[c]


@njit(cache=True, nogil=True)
def _small(points, out):
    """Spreads of a small array in one call; returns whether the means are finite."""
    k = points.shape[1]
    n = points.shape[0]
    zero = np.int64(0)  # not a literal: one compiled signature of the kernels
    _sums(points, zero, n, out)
    mean = np.empty(k)
    finite = True
    for c in range(k):
        mean[c] = out[c] / n
        finite = finite and np.isfinite(mean[c])
    _squares(points, zero, n, mean, out)
    for c in range(k):
        out[c] = np.sqrt(out[c] / n)
    return finite


_numbacache.refresh(globals())  # numba keys its cache on this file only (see replication._numbacache)
