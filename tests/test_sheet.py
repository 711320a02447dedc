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


def _random_surfaces(count, seed):
    rng = np.random.default_rng(seed)
    return [adt(points_from_genome(rng.integers(0, [37, 31, 14] * 101), GAConfig()), depth="z")
            for _ in range(count)]  # fmt: skip


@pytest.mark.filterwarnings("ignore::replication.errors.DuplicatePointsWarning")
def test_the_force_does_not_depend_on_how_the_jet_is_cut_into_pieces_or_on_the_threads(monkeypatch):
    """Each streamlet is summed on its own and the streamlets are added in order: one piece on
    one thread, or several pieces on several threads, give the same bits."""
    from replication.casestudy import jet
    from replication.surfaces import _threads

    surfaces = [pelton_bucket_surface(), *_random_surfaces(8, 5)]
    monkeypatch.setattr(_threads, "_one", True)
    monkeypatch.setattr(jet, "PIECES", 1)
    reference = [surface_force(s) for s in surfaces]
    monkeypatch.setattr(_threads, "_one", False)
    calls = []
    monkeypatch.setattr(jet, "run", lambda tasks: calls.append(len(tasks)) or _threads.run(tasks))
    for pieces in (2, 3, 7):
        monkeypatch.setattr(jet, "PIECES", pieces)
        for surface, ref in zip(surfaces, reference):
            result = surface_force(surface)
            assert np.array_equal(result.force, ref.force)
            assert np.array_equal(result.momentum_out, ref.momentum_out)
            for name in ("mass_flow_hit", "mass_flow_out", "mass_flow_trapped", "n_parcels"):
                assert getattr(result, name) == getattr(ref, name)
    assert calls == [2] * len(surfaces) + [3] * len(surfaces) + [7] * len(surfaces)  # the threaded path ran


def test_a_jet_force_s_arrays_are_read_only():
    result = surface_force(pelton_bucket_surface())
    for array in (result.force, result.momentum_out):
        assert not array.flags.writeable
        with pytest.raises(ValueError):
            array[0] = 1.0
