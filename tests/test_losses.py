"""The surrogate's losses in the thin-sheet model: none is the model exactly, a flat plate is
untouched, the momentum balance holds, and more loss means less force on a cup."""

import numpy as np
import pytest

from replication.casestudy.ga import GAConfig
from replication.casestudy.jet import JetConfig, SheetLosses, jet_force
from replication.casestudy.shapes import flat_plate_surface, pelton_bucket_surface
from replication.errors import InputError
from replication.experiments.jet_surfaces import random_lattice_surfaces

JET = JetConfig()


@pytest.fixture(scope="module")
def bucket():
    s = pelton_bucket_surface()
    return s.points, s.triangles


@pytest.fixture(scope="module")
def lattices():
    return [(s.points, s.triangles) for s in random_lattice_surfaces(3, GAConfig(), rng=7)]


def test_no_loss_is_the_model_bit_for_bit(bucket, lattices):
    for points, triangles in [bucket, *lattices]:
        model = jet_force(points, triangles, JET)
        same = jet_force(points, triangles, JET, losses=SheetLosses(0.0, 0.0))
        assert np.array_equal(model.force, same.force)
        assert np.array_equal(model.momentum_out, same.momentum_out)
        assert model.n_parcels == same.n_parcels


HEAVY = [SheetLosses(crease=2.0), SheetLosses(reimpact=0.9), SheetLosses(4.0, 1.0)]
SOME = [SheetLosses(crease=0.7), SheetLosses(reimpact=0.4), SheetLosses(1.5, 0.6)]


@pytest.mark.parametrize("losses", HEAVY)
def test_a_flat_plate_has_no_crease_and_no_reimpact(losses):
    s = flat_plate_surface()
    force = jet_force(s.points, s.triangles, JET, losses=losses).axial_force
    assert force == jet_force(s.points, s.triangles, JET).axial_force
    assert force / JET.momentum_flux == pytest.approx(1.0, abs=1e-12)  # rho Q V: momentum theory


@pytest.mark.parametrize("losses", SOME)
def test_losses_keep_the_momentum_balance(bucket, lattices, losses):
    # the speed lost is momentum given to the surface: force + momentum out = momentum in (z)
    for points, triangles in [bucket, *lattices]:
        r = jet_force(points, triangles, JET, losses=losses)
        assert r.force[2] + r.momentum_out[2] == pytest.approx(-r.mass_flow_hit * JET.velocity, rel=1e-12)
        assert r.mass_flow_out + r.mass_flow_trapped == pytest.approx(r.mass_flow_hit, rel=1e-12)


def test_more_loss_less_force_on_a_cup_and_never_below_a_plate(bucket):
    points, triangles = bucket
    axial = lambda **kw: jet_force(points, triangles, JET, losses=SheetLosses(**kw)).axial_force  # noqa: E731
    creases = [axial(crease=c) for c in (0.0, 0.5, 1.0, 2.0)]
    impacts = [axial(reimpact=e) for e in (0.0, 0.3, 0.6, 0.9)]
    assert np.all(np.diff(creases) < 0) and np.all(np.diff(impacts) < 0)
    # a sheet stopped on the cup leaves nothing backwards: the force stays above the jet's momentum
    assert axial(crease=4.0, reimpact=1.0) >= 0.99 * JET.momentum_flux


@pytest.mark.parametrize(
    "kwargs, match",
    [({"crease": -0.1}, "crease.*-0.1"), ({"reimpact": 1.5}, "reimpact.*1.5"),
     ({"crease": float("nan")}, "nan"), ({"reimpact": "0.2"}, "reimpact.*'0.2'")],
)  # fmt: skip
def test_bad_losses_name_the_value(kwargs, match):
    with pytest.raises(InputError, match=match):
        SheetLosses(**kwargs)
