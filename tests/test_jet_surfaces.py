"""The validation study's surfaces: valid for both solvers, known model answers, determinism."""

import math

import numpy as np
import pytest

from replication.casestudy import JetConfig, jet_force
from replication.casestudy.evaluate import executor
from replication.casestudy.ga import GAConfig
from replication.errors import InputError
from replication.experiments import jet_surfaces
from replication.experiments.jet_surfaces import (
    MAX_INCLINATION_DEG,
    bowl_cloud,
    ga_winners,
    inclined_plate_cloud,
    random_lattice_surfaces,
    reference_surfaces,
    surface_signature,
)

JET = JetConfig()
TINY_GA = GAConfig(population=6, generations=3, runs=2)


def serial():
    return executor("serial")


def test_reference_surfaces_are_valid_and_the_model_gives_the_known_answers():
    surfaces = {s.name: s for s in reference_surfaces()}
    assert list(surfaces)[0] == "flat plate" and "Pelton bucket" in surfaces
    assert {s.family for s in surfaces.values()} == {"plate", "cup"}
    rho_q_v = JET.momentum_flux
    for s in surfaces.values():
        assert s.points[:, 1].min() >= 0 and s.points[:, 2].max() <= 13 + 1e-9
        force = jet_force(s.points, s.triangles, JET).axial_force  # full mesh checks
        if s.name == "flat plate":
            assert force == pytest.approx(rho_q_v, rel=1e-9)
        elif s.name.startswith("plate inclined"):
            angle = math.radians(float(s.name.split()[2]))
            assert force == pytest.approx(rho_q_v * math.cos(angle) ** 2, rel=0.02)  # cos^2 law
        else:  # cups turn the sheet back: more than a plate, less than 2 rho Q V
            assert rho_q_v * 1.2 < force < 2 * rho_q_v


def test_the_steepest_plate_fills_the_domain_and_steeper_ones_are_refused():
    cloud = inclined_plate_cloud(MAX_INCLINATION_DEG)
    assert cloud[:, 2].max() == pytest.approx(13.0) and cloud[:, 2].min() == 0.0
    with pytest.raises(InputError, match="inclination"):
        inclined_plate_cloud(25.0)
    with pytest.raises(InputError, match="bowl depth"):
        bowl_cloud(14.0)


def test_a_bowl_is_a_paraboloid_round_the_jet_axis():
    cloud = bowl_cloud(13.0)
    x, y, z = cloud.T
    inside = (x - 18) ** 2 + y**2 <= 18**2
    np.testing.assert_allclose(z[inside], 13.0 * ((x[inside] - 18) ** 2 + y[inside] ** 2) / 324)
    assert z.max() == 13.0 and z[(x == 18) & (y == 0)] == 0.0


def test_random_lattice_surfaces_are_seeded_and_do_not_depend_on_their_count():
    a = random_lattice_surfaces(3, GAConfig(), rng=5)
    b = random_lattice_surfaces(2, GAConfig(), rng=5)
    c = random_lattice_surfaces(1, GAConfig(), rng=6)
    assert [s.name for s in a] == ["random 00", "random 01", "random 02"]
    for s, t in zip(a, b):
        np.testing.assert_array_equal(s.points, t.points)
    assert not np.array_equal(a[0].points, c[0].points)
    for s in a:
        # the GA's 1 mm lattice in x and y (points sharing a node take their mean height)
        assert np.all(s.points[:, :2] == np.round(s.points[:, :2]))
        jet_force(s.points, s.triangles, JET)


def test_the_signature_names_the_geometry_not_the_order():
    s = reference_surfaces((10.0,), ())[1]
    perm = np.random.default_rng(1).permutation(s.points.shape[0])
    inverse = np.argsort(perm)
    points = s.points[perm]
    triangles = inverse[s.triangles][::-1][:, [1, 2, 0]]
    assert surface_signature(points, triangles) == surface_signature(s.points, s.triangles)
    moved = s.points.copy()
    moved[0, 2] += 1e-6
    assert surface_signature(moved, s.triangles) != surface_signature(s.points, s.triangles)


def test_ga_winners_are_the_best_distinct_surfaces_and_a_complete_run_is_read_not_rerun(
    tmp_path, monkeypatch
):
    winners = ga_winners(TINY_GA, 3, run_dir=tmp_path, pool_factory=serial)
    assert [s.name for s in winners] == [f"GA run {k} #{i}" for k in range(2) for i in (1, 2, 3)]
    assert {s.stratum for s in winners} == {"GA run 0", "GA run 1"}
    for k in range(2):
        run = winners[3 * k : 3 * k + 3]
        fitness = [s.ga_fitness for s in run]
        assert fitness == sorted(fitness, reverse=True)
        assert len({surface_signature(s.points, s.triangles) for s in run}) == 3
        for s in run:  # the GA's fitness is the model's force on the winner
            assert jet_force(s.points, s.triangles, JET).axial_force == pytest.approx(s.ga_fitness, rel=1e-12)

    def no_rerun(*args, **kwargs):
        raise AssertionError("a complete run was run again")

    monkeypatch.setattr("replication.casestudy.runner.run_ga", no_rerun)
    again = ga_winners(TINY_GA, 3, run_dir=tmp_path, pool_factory=serial)
    for s, t in zip(winners, again):
        np.testing.assert_array_equal(s.points, t.points)


def test_the_ga_winners_are_deterministic(tmp_path):
    one = ga_winners(TINY_GA, 2, run_dir=tmp_path / "a", pool_factory=serial)
    two = ga_winners(TINY_GA, 2, run_dir=tmp_path / "b", pool_factory=serial)
    assert [s.ga_fitness for s in one] == [s.ga_fitness for s in two]


def test_an_unknown_family_is_refused():
    with pytest.raises(InputError, match="family"):
        jet_surfaces.StudySurface("x", "spiky", "x", np.zeros((3, 3)), np.array([[0, 1, 2]]))
