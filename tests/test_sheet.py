"""The jet model's mesh preparation: the ADT surface's own adjacency gives the same forces."""

import numpy as np
import pytest

from replication.casestudy.ga import GAConfig, points_from_genome
from replication.casestudy.jet import jet_force, surface_force
from replication.casestudy.shapes import pelton_bucket_surface
from replication.surfaces import adt


@pytest.mark.filterwarnings("ignore::replication.errors.DuplicatePointsWarning")
def test_surface_force_with_the_triangulator_adjacency_equals_the_checked_mesh_path():
    """surface_force reuses the surface's neighbours and builds the mesh in one compiled call;
    jet_force recomputes neighbours by sorting edges: the forces are bit for bit equal."""
    rng = np.random.default_rng(11)
    surfaces = [pelton_bucket_surface()]
    surfaces += [adt(points_from_genome(rng.integers(0, [37, 31, 14] * 101), GAConfig()), depth="z")
                 for _ in range(20)]  # fmt: skip
    for surface in surfaces:
        fast = surface_force(surface)
        checked = jet_force(surface.points, surface.triangles)
        assert np.array_equal(fast.force, checked.force)
        assert np.array_equal(fast.momentum_out, checked.momentum_out)
        assert fast.n_parcels == checked.n_parcels
