"""The warning of ``replication force`` for a jet that only partly strikes the surface (paper
section 6): the force is then that of the part that strikes it."""

from __future__ import annotations

from typing import Any

__all__ = ["partly_missed", "sph_coverage_warning"]


def _percent(share: float) -> str:
    """A share of the jet (percent) that rounding never shows as none or all of it."""
    if share < 0.05:
        return "< 0.1"
    if share > 99.95:
        return "> 99.9"
    return f"{share:.1f}"


def _hint(config: Any, points: Any, triangles: Any) -> str:
    """Why the jet may miss: a full jet reaching across y = 0 past a surface on one side of it,
    or else where the jet and the surface lie."""
    import numpy as np

    from replication.casestudy.units import to_millimetres

    used = np.unique(np.asarray(triangles))  # the surface's own vertices, not stray ones of a mesh file
    y = np.asarray(points, dtype=np.float64)[used, 1]
    cy = float(to_millimetres(config.center[1]))
    radius = float(to_millimetres(config.diameter)) / 2
    if config.full_jet and y.min() >= 0 and cy - radius < 0:
        part = "half the jet (its part in y < 0)" if cy == 0 else "the part of the jet in y < 0"
        advice = " (without --full-jet the jet is halved at its symmetry plane y = 0)" if cy == 0 else ""
        return f"the surface lies in y >= 0 only, and {part} passes it by{advice}"
    if config.full_jet and y.max() <= 0 and cy + radius > 0:
        part = "half the jet (its part in y > 0)" if cy == 0 else "the part of the jet in y > 0"
        advice = (
            " (the half jet, without --full-jet, takes a surface in y >= 0: mirror it)" if cy == 0 else ""
        )
        return f"the surface lies in y <= 0 only, and {part} passes it by{advice}"
    return "check --center and where the surface lies"


def partly_missed(result: Any, config: Any, points: Any, triangles: Any, *, sph: bool = False) -> str | None:
    """The warning for a jet of which some streamlets, but not all, miss the surface: the
    force is then that of the part that strikes it, which a user reading the force alone
    would not know (a half-jet mesh given ``--full-jet`` lost half the jet silently). With
    ``sph``, the streamlets are the thin-sheet model's, asked before a simulation."""
    total, hit = result.mass_flow_total, result.mass_flow_hit
    if result.n_streamlets_hit == 0 or result.n_streamlets_hit == result.n_streamlets:
        return None
    missed = total - hit
    streamlets = "of the thin-sheet model's streamlets" if sph else "streamlets"
    force = "the simulated force will be" if sph else "the force is"
    share = _percent(100 * missed / total)
    return (
        f"warning: {share} % of the jet's mass flow ({missed:.4g} of {total:.4g} kg/s, "
        f"{result.n_streamlets - result.n_streamlets_hit} of {result.n_streamlets} {streamlets}) misses "
        f"the surface, and {force} that of the rest; {_hint(config, points, triangles)}"
    )


def sph_coverage_warning(points: Any, triangles: Any, config: Any) -> str | None:
    """Before an SPH simulation (minutes): the warning of :func:`partly_missed` from the
    thin-sheet model's streamlets (milliseconds), which strike the surface where the jet's
    cross-section lies over it; None when the jet strikes it whole, or not at all (the
    simulation then says what it found)."""
    import warnings

    from replication.casestudy import jet_force
    from replication.errors import JetResolutionWarning, ReplicationError

    try:  # advice only: whatever the thin-sheet model makes of the surface, the simulation runs
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", JetResolutionWarning)
            result = jet_force(points, triangles, config)
    except ReplicationError:
        return None
    return partly_missed(result, config, points, triangles, sph=True)
