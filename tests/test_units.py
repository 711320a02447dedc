"""One millimetre-to-metre conversion: the CLI, the Python API and the GA give identical forces."""

import json
import warnings

import numpy as np
import pytest

from replication.casestudy import JetConfig, jet_force, surface_force
from replication.casestudy.evaluate import Fitness
from replication.casestudy.ga import GAConfig, genome_from_points
from replication.cli import main
from replication.errors import DuplicatePointsWarning
from replication.io import save_cloud
from replication.surfaces import CASE_STUDY_BOX, adt, random_cloud


def test_millimetres_become_the_literal_metres():
    from replication.casestudy.units import to_metres, to_millimetres

    assert 18 * 1e-3 != 0.018  # why a multiplication is not the conversion
    assert float(to_metres(18)) == 0.018 and float(to_metres(4.34)) == 0.00434
    assert tuple(to_metres([36, 30, 13]).tolist()) == JetConfig().domain
    assert tuple(to_metres([18, 0]).tolist()) == JetConfig().center
    # every whole or half millimetre becomes the double nearest to its decimal value in metres
    mm = np.arange(0, 1000, 0.5)
    np.testing.assert_array_equal(to_metres(mm), [float(f"{v!r}e-3") for v in mm.tolist()])
    assert float(to_millimetres(0.018)) == 18


def _special_clouds():
    """Lattice clouds on which the jet axis (18, 0) mm hits a vertex or an edge of the surface."""
    rng = np.random.default_rng(12)
    clouds = []
    for k in range(6):
        cloud = random_cloud(101, CASE_STUDY_BOX, step=1, rng=rng)
        if k % 2 == 0:  # a vertex exactly on the jet axis
            cloud[0] = [18, 0, rng.integers(0, 14)]
        else:  # an edge through the axis along the symmetry plane, no vertex on it
            cloud[(cloud[:, 0] == 18) & (cloud[:, 1] == 0), 1] = 5
            cloud[0], cloud[1] = [17, 0, rng.integers(0, 14)], [19, 0, rng.integers(0, 14)]
            cloud[(cloud[:, 1] == 0) & (np.abs(cloud[:, 0] - 18) <= 1) & (np.arange(101) > 1), 1] = 7
        clouds.append(cloud)
    return clouds


CLOUDS = [random_cloud(101, CASE_STUDY_BOX, step=1, rng=seed) for seed in range(40)] + _special_clouds()


def test_cli_api_and_ga_give_identical_forces(capsys, tmp_path):
    config = GAConfig()
    fitness = Fitness(config)
    path = tmp_path / "cloud.csv"
    for k, cloud in enumerate(CLOUDS):
        save_cloud(cloud, path)
        assert main(["force", str(path), "--json"]) == 0
        cli = json.loads(capsys.readouterr().out)["axial_force_N"]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DuplicatePointsWarning)
            surface = adt(cloud, depth="z")
        api = surface_force(surface).axial_force
        mesh_api = jet_force(surface.points, surface.triangles).axial_force
        ga = fitness(genome_from_points(cloud, config))
        assert cli == api == mesh_api == ga, (k, cli, api, mesh_api, ga)


@pytest.mark.parametrize("k", range(len(CLOUDS) - 6, len(CLOUDS)))
def test_special_clouds_touch_the_axis(k):
    cloud = CLOUDS[k]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicatePointsWarning)
        surface = adt(cloud, depth="z")
    xy = surface.points[:, :2]
    on_axis = np.all(xy == [18, 0], axis=1)
    if k % 2 == 0:
        assert on_axis.any()
    else:
        assert not on_axis.any()
        a, b = (np.flatnonzero(np.all(xy == p, axis=1))[0] for p in ([17, 0], [19, 0]))
        edges = {
            tuple(sorted(e)) for t in surface.triangles for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))
        }
        assert tuple(sorted((a, b))) in edges
