"""A jet that strikes nothing: did it miss the surface, or are its streamlets too coarse for it?

The thin-sheet model (:mod:`replication.casestudy.jet`) samples the jet at the centroids of
``resolution`` rings of equal width, diameter / 2 / resolution apart. A surface smaller than
that spacing can lie under the jet and still fall between the streamlets (a 1000 mm jet on a
36 mm surface at the default resolution: rings 62.5 mm wide), and the force is then 0 N, not
because the jet misses but because the sampling is too coarse. :func:`warn_if_too_coarse`
tells the two apart and names a resolution that puts streamlets on the surface.

A jet that misses a surface of its own scale is no mistake: its force of 0 N is right. One
that misses a surface a hundred times smaller or larger than itself most likely meets lengths
in the wrong unit (vertices in millimetres, :class:`JetConfig` in metres: a surface given in
metres, or a jet diameter in millimetres, is off by a thousand); :func:`warn_if_units_differ`
says so.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np

from replication.casestudy.jetconfig import JetConfig
from replication.casestudy.units import to_millimetres
from replication.errors import JetResolutionWarning, JetUnitsWarning
from replication.surfaces.interpolate import locate

__all__ = ["UNITS_RATIO", "warn_if_too_coarse", "warn_if_units_differ"]

#: A jet and a surface whose sizes differ by this factor or more, and that miss each other,
#: are taken for lengths in different units.
UNITS_RATIO = 100.0


def _in_jet(xy: np.ndarray, config: JetConfig) -> np.ndarray:
    """Which points lie strictly inside the jet's cross-section (the half jet's: the half disk
    y >= its centre's y)."""
    offset = xy - np.asarray(config.center, dtype=np.float64)
    inside = np.hypot(offset[:, 0], offset[:, 1]) < config.diameter / 2
    return inside & (offset[:, 1] >= 0) if not config.full_jet else inside


def warn_if_too_coarse(
    xy: np.ndarray,
    triangles: np.ndarray,
    neighbors: np.ndarray,
    convex: bool,
    config: JetConfig,
    resolution: int,
    streamlets: Callable[[int], np.ndarray],
    finest: int,
    *,
    stacklevel: int = 2,
) -> None:
    """Warn when no streamlet strikes the surface because the streamlets are coarser than it.

    Called only when no streamlet strikes. A jet that lies elsewhere misses, and its force of
    0 N is right: no warning. The streamlets are taken for too coarse when part of the surface
    lies under the jet (one of its vertices does) and either the rings are wider than the
    surface's footprint (the larger side of its bounding box in x-y) or the jet covers the
    centre of that box.

    Parameters
    ----------
    xy : ndarray, shape (n, 2)
        The surface's vertices in the x-y plane (metres), as the model uses them.
    triangles, neighbors : ndarray of int, shape (m, 3)
        Its counter-clockwise triangles and their neighbours.
    convex : bool
        Whether the triangles tile a convex footprint.
    config : JetConfig
    resolution : int
        The resolution that put no streamlet on the surface.
    streamlets : callable
        The streamlet positions (metres, shape (k, 2)) of the jet at a given resolution.
    finest : int
        The finest resolution to suggest.
    stacklevel : int
        As for :func:`warnings.warn`, counted from the caller.

    Warns
    -----
    JetResolutionWarning
        With the ring width against the surface's extent and the finer resolution (doubling,
        up to ``finest``) that first puts streamlets on the surface.

    Notes
    -----
    Paper section 6: the case study's jet, sampled as in
    :func:`~replication.casestudy.jet.jet_streamlets`.
    """
    used = xy[np.unique(triangles)]
    if not _in_jet(used, config).any():
        return
    low, high = used.min(axis=0), used.max(axis=0)
    ring = config.diameter / 2 / resolution
    if not (ring > (high - low).max() or _in_jet(((low + high) / 2)[None], config)[0]):
        return
    finer, hits = resolution, 0
    while hits == 0 and finer < finest:
        finer = min(2 * finer, finest)
        hits = int(np.count_nonzero(locate(xy, triangles, streamlets(finer), neighbors, convex=convex) >= 0))
    advice = (
        f"resolution {finer} is the first to put streamlets on it ({hits}), a finer one samples it better"
        if hits
        else f"even resolution {finer} puts none on it: a narrower jet does"
    )
    width, depth = to_millimetres(high - low).tolist()
    warnings.warn(
        f"the surface lies under the jet, but none of the jet's {streamlets(resolution).shape[0]} streamlets "
        f"strikes it: they lie on rings {float(to_millimetres(ring)):.3g} mm wide (the jet's radius over the "
        f"resolution {resolution}), coarser than the surface ({width:.3g} x {depth:.3g} mm in x-y), so its "
        f"force of 0 N is not the jet's; {advice}",
        JetResolutionWarning,
        stacklevel=stacklevel + 1,
    )


def warn_if_units_differ(
    xy: np.ndarray, triangles: np.ndarray, config: JetConfig, *, stacklevel: int = 2
) -> None:
    """Warn when the jet misses a surface whose size differs from the jet's by :data:`UNITS_RATIO`.

    Called only when no streamlet strikes. A surface partly under the jet is the business of
    :func:`warn_if_too_coarse`; one of the jet's own scale that lies elsewhere misses, rightly.

    Warns
    -----
    JetUnitsWarning
        With both sizes and positions in millimetres and the units each function takes.
    """
    used = xy[np.unique(triangles)]
    if _in_jet(used, config).any():
        return
    low, high = used.min(axis=0), used.max(axis=0)
    size = float((high - low).max())
    ratio = config.diameter / size if size > 0 else np.inf
    if 1 / UNITS_RATIO < ratio < UNITS_RATIO:
        return
    (x0, y0), (x1, y1) = to_millimetres(low).tolist(), to_millimetres(high).tolist()
    cx, cy = to_millimetres(config.center).tolist()
    factor = f"{ratio:.3g} times" if ratio >= 1 else f"1/{1 / ratio:.3g} of"
    width = float(to_millimetres(config.diameter))
    warnings.warn(
        f"the jet ({width:,.6g} mm wide, centred at ({cx:,.6g}, {cy:,.6g}) mm) "
        f"misses the surface (x {x0:.4g}..{x1:.4g}, y {y0:.4g}..{y1:.4g} mm) and is {factor} its size: are "
        "the lengths in the units each takes? Surface vertices are in millimetres, JetConfig in metres "
        "(the paper's jet: diameter=0.018, center=(0.018, 0.0)); on the command line every length is in "
        "millimetres",
        JetUnitsWarning,
        stacklevel=stacklevel + 1,
    )
