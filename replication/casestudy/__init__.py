"""The paper's case study (section 6): the water-jet force on faceted surfaces and its shapes."""

from replication.casestudy.jet import (
    DEFAULT_RESOLUTION,
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

__all__ = [
    "DEFAULT_RESOLUTION",
    "PAPER_SPH_FORCES",
    "JetConfig",
    "JetForce",
    "flat_plate_cloud",
    "flat_plate_surface",
    "jet_force",
    "jet_streamlets",
    "pelton_bucket_cloud",
    "pelton_bucket_surface",
    "surface_force",
]
