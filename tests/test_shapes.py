"""The case study's reference shapes and their forces."""

import numpy as np
import pytest

from replication.casestudy import (
    DEFAULT_RESOLUTION,
    PAPER_SPH_FORCES,
    JetConfig,
    flat_plate_cloud,
    flat_plate_surface,
    pelton_bucket_cloud,
    pelton_bucket_surface,
    surface_force,
)
from replication.errors import InputError

SHAPES = {
    "flat plate": (flat_plate_cloud, flat_plate_surface),
    "pelton bucket": (pelton_bucket_cloud, pelton_bucket_surface),
}


@pytest.mark.parametrize("name", SHAPES)
def test_clouds_are_101_lattice_points_in_the_domain(name):
    cloud_fn, surface_fn = SHAPES[name]
    cloud = cloud_fn()
    assert cloud.shape == (101, 3) and cloud.dtype == np.float64
    np.testing.assert_array_equal(cloud, np.rint(cloud))
    assert cloud.min(axis=0).tolist() == [0, 0, 0]
    assert np.all(cloud.max(axis=0) <= [36, 30, 13])
    assert len(np.unique(cloud[:, :2], axis=0)) == 101  # no merge: no warning
    np.testing.assert_array_equal(cloud, cloud_fn())  # deterministic
    surface = surface_fn()  # pytest turns a DuplicatePointsWarning into an error
    assert surface.depth_axis == 2 and surface.n_vertices == 101


def test_flat_plate_force_is_rho_q_v():
    """The plate covers the jet: exactly rho Q V of the half jet (2.397 N), tolerance 1e-12."""
    assert np.all(flat_plate_cloud(5)[:, 2] == 5)
    result = surface_force(flat_plate_surface())
    cfg = JetConfig()
    assert result.axial_force == pytest.approx(cfg.momentum_flux, rel=1e-12)
    assert abs(result.force[0]) < 1e-12 and abs(result.force[1]) < 1e-12


def test_bucket_shape_and_force():
    """Splitter ridge at y = 0, a cup, a high outer rim; the sheet is turned back upwards, so the
    force is well above the flat plate's (1.84 rho Q V at the default resolution, ideal 2)."""
    cloud = pelton_bucket_cloud()
    ridge = cloud[cloud[:, 1] == 0]
    rim = cloud[cloud[:, 1] == 30]
    assert np.all(ridge[:, 2] == 13) and np.all(rim[:, 2] == 13)
    assert cloud[:, 2].min() == 0
    result = surface_force(pelton_bucket_surface())
    ratio = result.axial_force / JetConfig().momentum_flux
    assert 1.7 < ratio < 2.0
    assert result.momentum_out[2] > 0.5 * result.mass_flow_total * 4.34  # leaves going up
    assert result.mass_flow_trapped == 0


@pytest.mark.parametrize("name", SHAPES)
def test_streamlet_refinement_changes_force_below_one_percent(name):
    """4 x the resolution (16 x the streamlets, 4 x the directions) changes the force < 1 %."""
    surface = SHAPES[name][1]()
    coarse = surface_force(surface, resolution=DEFAULT_RESOLUTION)
    fine = surface_force(surface, resolution=4 * DEFAULT_RESOLUTION)
    assert fine.axial_force == pytest.approx(coarse.axial_force, rel=0.01)


def test_paper_forces_are_recorded():
    assert PAPER_SPH_FORCES == {"flat plate": 21.96, "pelton bucket": 19.08}


@pytest.mark.parametrize("height", [-1, 14, 2.5])
def test_plate_height_must_be_a_lattice_level(height):
    with pytest.raises(InputError, match="height"):
        flat_plate_cloud(height)
