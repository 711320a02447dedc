"""The paper's case study (section 6): the water-jet force on faceted surfaces and its shapes.

Names are imported on first use (:mod:`replication._lazy`): the jet model's compiled kernels
load only when a force is computed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from replication._lazy import attach

_EXPORTS = {
    "DEFAULT_RESOLUTION": "replication.casestudy.jet",
    "MAX_RESOLUTION": "replication.casestudy.jet",
    "JetConfig": "replication.casestudy.jet",
    "JetForce": "replication.casestudy.jet",
    "jet_force": "replication.casestudy.jet",
    "jet_streamlets": "replication.casestudy.jet",
    "surface_force": "replication.casestudy.jet",
    "PAPER_SPH_FORCES": "replication.casestudy.shapes",
    "flat_plate_cloud": "replication.casestudy.shapes",
    "flat_plate_surface": "replication.casestudy.shapes",
    "pelton_bucket_cloud": "replication.casestudy.shapes",
    "pelton_bucket_surface": "replication.casestudy.shapes",
}

__all__ = [
    "DEFAULT_RESOLUTION",
    "MAX_RESOLUTION",
    "JetConfig",
    "JetForce",
    "PAPER_SPH_FORCES",
    "flat_plate_cloud",
    "flat_plate_surface",
    "jet_force",
    "jet_streamlets",
    "pelton_bucket_cloud",
    "pelton_bucket_surface",
    "surface_force",
]

__getattr__, __dir__ = attach(__name__, _EXPORTS)

if TYPE_CHECKING:  # what the names are, for type checkers and editors
    from replication.casestudy.jet import (
        DEFAULT_RESOLUTION,
        MAX_RESOLUTION,
        JetConfig,
        JetForce,
        jet_force,
        jet_streamlets,
        surface_force,
    )
    from replication.casestudy.shapes import (
        PAPER_SPH_FORCES,
        flat_plate_cloud,
        flat_plate_surface,
        pelton_bucket_cloud,
        pelton_bucket_surface,
    )
