"""The warning of ``replication force`` for a jet that only partly strikes the surface (paper
section 6): the force is then that of the part that strikes it."""

from __future__ import annotations

from typing import Any

__all__ = ["partly_missed", "sph_coverage_warning"]


def partly_missed(result: Any, config: Any, points: Any, *, sph: bool = False) -> str | None:
    """The warning for a jet of which some streamlets, but not all, miss the surface: the
    force is then that of the part that strikes it, which a user reading the force alone
    would not know (a half-jet mesh given ``--full-jet`` lost half the jet silently). With
    ``sph``, the streamlets are the thin-sheet model's, asked before a simulation."""
    total, hit = result.mass_flow_total, result.mass_flow_hit
    if result.n_streamlets_hit == 0 or result.n_streamlets_hit == result.n_streamlets:
        return None
    missed = total - hit
    y = points[:, 1]
    if config.full_jet and (y.min() >= 0 or y.max() <= 0):
        side = ">=" if y.min() >= 0 else "<="
        hint = (
            f"the surface lies in y {side} 0 only: the full jet's other half passes it by "
            "(without --full-jet the jet is halved at its symmetry plane y = 0)"
        )
    else:
        hint = "check --center and where the surface lies"
    streamlets = "of the thin-sheet model's streamlets" if sph else "streamlets"
    force = "the simulated force will be" if sph else "the force is"
    return (
        f"warning: {100 * missed / total:.2g} % of the jet's mass flow ({missed:.4g} of {total:.4g} kg/s, "
        f"{result.n_streamlets - result.n_streamlets_hit} of {result.n_streamlets} {streamlets}) misses "
        f"the surface, and {force} that of the rest; {hint}"
    )


def sph_coverage_warning(points: Any, triangles: Any, config: Any) -> str | None:
    """Before an SPH simulation (minutes): the warning of :func:`partly_missed` from the
    thin-sheet model's streamlets (milliseconds), which strike the surface where the jet's
    cross-section lies over it; None when the jet strikes it whole, or not at all (the
    simulation then says what it found)."""
    import warnings

    from replication.casestudy import jet_force
    from replication.errors import JetResolutionWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", JetResolutionWarning)
        result = jet_force(points, triangles, config)
    return partly_missed(result, config, points, sph=True)
